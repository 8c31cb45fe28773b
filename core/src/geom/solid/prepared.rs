//! Solids prepared for rendering: placements inverted once, world bounds, and ray queries.
//!
//! [`Solids`] holds the arena with each leaf's [`Placement`]. [`Solids::first_hit`] evaluates one
//! scene object (a root node) against a ray: it collects the spans of every leaf below the root
//! into a [`SpanScratch`] (reused across queries so a render allocates only while it warms up),
//! combines them bottom-up, and returns the first boundary in front of the origin.

use super::cylinder_miss::surely_misses_side4;
use super::extent::{reject_box, reject_margin, SolidExtent};
pub use super::hit::SolidHit;
use super::lone_sphere::LoneSphere;
use super::mesh;
use super::shape;
use super::spans::{combine, Boundary, Span};
use super::{CsgOp, Shape, SolidNode};
use crate::math::aabb::Aabb;
use crate::math::float::gamma;
use crate::math::norm::Norm;
use crate::math::ray::Ray;
use crate::math::transform::Placement;
use alloc::vec::Vec;
use glam::{Vec3, Vec4};

/// A node of the prepared arena.
#[derive(Clone, Copy, Debug)]
pub enum PreparedNode {
    /// A placed shape.
    Leaf {
        /// The shape in object space.
        shape: Shape,
        /// Its placement, with the inverse.
        placement: Placement,
        /// Shader index.
        shader: u32,
    },
    /// A placed closed mesh.
    Mesh {
        /// Its triangles: `first .. first + count` of [`Solids`]' mesh triangles.
        first: u32,
        /// Number of triangles.
        count: u32,
        /// Its placement, with the inverse.
        placement: Placement,
        /// Shader index.
        shader: u32,
    },
    /// A boolean operation on two earlier nodes.
    Csg {
        /// Which operation.
        op: CsgOp,
        /// First operand.
        a: u32,
        /// Second operand.
        b: u32,
    },
}

/// Reusable buffers for span evaluation.
#[derive(Clone, Debug, Default)]
pub struct SpanScratch {
    spans: Vec<Span>,
    combined: Vec<Span>,
    crossings: Vec<mesh::MeshCrossing>,
}

/// The surface at a solid hit, in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolidSurface {
    /// The hit point.
    pub point: Vec3,
    /// Per-axis bound on its error.
    pub point_error: Vec3,
    /// Unit outward normal of the composite solid.
    pub normal: Vec3,
    /// Shader of the leaf hit.
    pub shader: u32,
}

/// The scene's solids, ready for rendering.
#[derive(Clone, Debug, Default)]
pub struct Solids {
    nodes: Vec<PreparedNode>,
    /// Root node of each scene object.
    objects: Vec<u32>,
    /// World box of each object (`None`: unbounded).
    bounds: Vec<Option<Aabb>>,
    /// Per object, what its test settles before reading its node (one load per test).
    shortcuts: Vec<Shortcut>,
    /// True if any of them is one.
    any_lone_sphere: bool,
    /// Object-space triangles of the mesh nodes.
    mesh_triangles: Vec<[Vec3; 3]>,
}

/// What a test of one object settles before it reads the object's node.
#[derive(Clone, Copy, Debug)]
enum Shortcut {
    /// One sphere moved by a translation alone, tested without its node.
    Sphere(LoneSphere),
    /// The box a ray must cross before the object is evaluated: its world box grown by
    /// [`REJECT_MARGIN`](super::extent::REJECT_MARGIN).
    Reject(Aabb),
    /// Neither: an unbounded object, or a sphere that is not lone (a sphere's own test is
    /// about as cheap as its box's).
    Node,
}

impl Shortcut {
    /// The shortcut of the object whose root is `node`, node `root` of the arena, with world
    /// box `bounds` (`None`: unbounded).
    fn of(node: &PreparedNode, root: u32, bounds: Option<&Aabb>) -> Shortcut {
        match node {
            PreparedNode::Leaf {
                shape: shape @ Shape::Sphere { .. },
                placement,
                ..
            } => LoneSphere::of(shape, placement, root).map_or(Shortcut::Node, Shortcut::Sphere),
            _ => bounds.map_or(Shortcut::Node, |b| Shortcut::Reject(reject_box(b))),
        }
    }
}

/// The scale of `placement` if its linear part is a rotation times one scale, to a millionth
/// (the rest is far inside [`REJECT_MARGIN`](super::extent::REJECT_MARGIN)); `None` for another
/// linear map. A sphere or a cylinder placed by it keeps its shape.
fn similarity_scale(placement: &Placement) -> Option<f64> {
    let m = placement.to_world.matrix;
    let cols = [m.x_axis, m.y_axis, m.z_axis].map(|c| c.to_array().map(f64::from));
    let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let lengths = cols.map(|c| libm::sqrt(dot(&c, &c)));
    let longest = lengths[0].max(lengths[1]).max(lengths[2]);
    let tolerance = 1e-6 * longest;
    let similar = lengths.iter().all(|&l| longest - l <= tolerance)
        && [(0, 1), (0, 2), (1, 2)]
            .iter()
            .all(|&(i, j)| dot(&cols[i], &cols[j]).abs() <= tolerance * longest);
    similar.then_some(longest)
}

/// The world centre and radius of a sphere placed by `placement`, if the placement keeps it a
/// sphere ([`similarity_scale`]); `None` for an ellipsoid.
fn world_sphere(radius: f32, placement: &Placement) -> Option<(Vec3, f32)> {
    let scale = similarity_scale(placement)?;
    Some((
        placement.to_world.translation,
        (f64::from(radius) * scale) as f32,
    ))
}

/// The world centres of the caps and the larger radius of the cylinder or cone with radii `r0`,
/// `r1` and height `h` (its axis is the object's y axis, its caps at `y = ±h/2`) placed by
/// `placement`, if the placement keeps its section round ([`similarity_scale`]).
fn world_cone(r0: f32, r1: f32, h: f32, placement: &Placement) -> Option<(Vec3, Vec3, f32)> {
    let scale = similarity_scale(placement)?;
    let cap = |y: f32| placement.to_world.point(Vec3::new(0.0, y, 0.0));
    Some((
        cap(-0.5 * h),
        cap(0.5 * h),
        (f64::from(r0.max(r1)) * scale) as f32,
    ))
}

fn finite_box(b: &Aabb) -> bool {
    b.min.is_finite() && b.max.is_finite()
}

impl Solids {
    /// Prepares the arena; `nodes`, `objects` and the mesh nodes' `mesh_triangles` must have
    /// passed the scene's validation.
    pub fn new(nodes: &[SolidNode], objects: &[u32], mesh_triangles: &[[Vec3; 3]]) -> Solids {
        let prepared: Vec<PreparedNode> = nodes
            .iter()
            .map(|n| match *n {
                SolidNode::Leaf {
                    shape,
                    transform,
                    shader,
                } => PreparedNode::Leaf {
                    shape,
                    placement: Placement::new(&transform),
                    shader,
                },
                SolidNode::Mesh {
                    first,
                    count,
                    transform,
                    shader,
                } => PreparedNode::Mesh {
                    first,
                    count,
                    placement: Placement::new(&transform),
                    shader,
                },
                SolidNode::Csg { op, a, b } => PreparedNode::Csg { op, a, b },
            })
            .collect();
        let mut boxes: Vec<Aabb> = Vec::with_capacity(prepared.len());
        for n in &prepared {
            let b = match *n {
                PreparedNode::Leaf {
                    shape, placement, ..
                } => world_box(&shape::object_bounds(&shape), &placement),
                PreparedNode::Mesh {
                    first,
                    count,
                    placement,
                    ..
                } => {
                    let mut ob = Aabb::EMPTY;
                    for p in &mesh_triangles[first as usize..(first + count) as usize] {
                        for &v in p {
                            ob.add_point(v);
                        }
                    }
                    world_box(&ob, &placement)
                }
                PreparedNode::Csg { op, a, b } => {
                    let (ba, bb) = (boxes[a as usize], boxes[b as usize]);
                    match op {
                        CsgOp::Union => Aabb {
                            min: ba.min.min(bb.min),
                            max: ba.max.max(bb.max),
                        },
                        CsgOp::Intersect => Aabb {
                            min: ba.min.max(bb.min),
                            max: ba.max.min(bb.max),
                        },
                        CsgOp::Subtract => ba,
                    }
                }
            };
            boxes.push(b);
        }
        let bounds: Vec<Option<Aabb>> = objects
            .iter()
            .map(|&r| {
                let b = boxes[r as usize];
                finite_box(&b).then_some(b)
            })
            .collect();
        let shortcuts: Vec<Shortcut> = objects
            .iter()
            .zip(&bounds)
            .map(|(&r, b)| Shortcut::of(&prepared[r as usize], r, b.as_ref()))
            .collect();
        let any_lone_sphere = shortcuts.iter().any(|s| matches!(s, Shortcut::Sphere(_)));
        Solids {
            nodes: prepared,
            objects: objects.to_vec(),
            bounds,
            shortcuts,
            any_lone_sphere,
            mesh_triangles: mesh_triangles.to_vec(),
        }
    }

    /// Object `object` as a lone sphere, if it is one (one sphere moved by a translation alone).
    #[inline]
    pub fn lone_sphere(&self, object: u32) -> Option<LoneSphere> {
        match self.shortcuts.get(object as usize) {
            Some(&Shortcut::Sphere(sphere)) => Some(sphere),
            _ => None,
        }
    }

    /// The box a ray must cross before object `object` is evaluated, if it has one (not for
    /// lone spheres and unbounded objects): [`Solids::first_hit_in_box`] tests it first.
    #[inline]
    pub fn reject_box(&self, object: u32) -> Option<&Aabb> {
        match self.shortcuts.get(object as usize) {
            Some(Shortcut::Reject(b)) => Some(b),
            _ => None,
        }
    }

    /// The rays of four, their origins and directions per axis lane by lane, that surely miss
    /// object `object` (bit `l` for ray `l`) where it is one cylinder: its test
    /// ([`Solids::first_hit`]) asks [`surely_misses_side`](super::cylinder_miss) first, of the
    /// same object-space rays ([`Placement::to_object4`]), and this asks it of the four at once.
    /// No lane is reported for other objects.
    #[inline]
    pub fn cylinder_missed_by4(&self, object: u32, origin: &[Vec4; 3], dir: &[Vec4; 3]) -> u32 {
        let Some(&root) = self.objects.get(object as usize) else {
            return 0;
        };
        match &self.nodes[root as usize] {
            PreparedNode::Leaf {
                shape:
                    Shape::Cylinder {
                        bottom_radius,
                        top_radius,
                        height,
                    },
                placement,
                ..
            } if shape::is_cylinder(*bottom_radius, *top_radius, *height) => {
                let (o, d) = placement.to_object4(origin, dir);
                surely_misses_side4(*bottom_radius, o, d)
            }
            _ => 0,
        }
    }

    /// True if any object is a lone sphere.
    #[inline]
    pub fn has_lone_spheres(&self) -> bool {
        self.any_lone_sphere
    }

    /// World boxes of the objects, `None` for unbounded ones (those stay out of the octree).
    pub fn bounds(&self) -> &[Option<Aabb>] {
        &self.bounds
    }

    /// How the octree files each object: a lone sphere by its surface, a lone cylinder or cone
    /// by its axis, other bounded objects by their world box.
    pub fn extents(&self) -> Vec<SolidExtent> {
        self.objects
            .iter()
            .zip(&self.bounds)
            .map(|(&root, b)| {
                let Some(b) = *b else {
                    return SolidExtent::Unbounded;
                };
                let margin = reject_margin(&b);
                let PreparedNode::Leaf {
                    shape, placement, ..
                } = self.nodes[root as usize]
                else {
                    return SolidExtent::Box(b);
                };
                let extent = match shape {
                    Shape::Sphere { radius } => {
                        world_sphere(radius, &placement).map(|(center, radius)| {
                            SolidExtent::Sphere {
                                bounds: b,
                                center,
                                radius,
                                margin,
                            }
                        })
                    }
                    Shape::Cylinder {
                        bottom_radius,
                        top_radius,
                        height,
                    } => world_cone(bottom_radius, top_radius, height, &placement).map(
                        |(a, c, radius)| SolidExtent::Cone {
                            bounds: b,
                            a,
                            b: c,
                            radius,
                            margin,
                        },
                    ),
                    _ => None,
                };
                extent.unwrap_or(SolidExtent::Box(b))
            })
            .collect()
    }

    /// Number of triangles in the meshes of CSG solids.
    pub fn mesh_triangle_count(&self) -> usize {
        self.mesh_triangles.len()
    }

    /// Number of scene objects.
    pub fn len(&self) -> usize {
        self.objects.len()
    }

    /// True if the scene has no solid objects.
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// The shader of object `object` where the object is one leaf (a lone shape or mesh).
    pub fn object_shader(&self, object: u32) -> Option<u32> {
        let &root = self.objects.get(object as usize)?;
        match self.nodes[root as usize] {
            PreparedNode::Leaf { shader, .. } | PreparedNode::Mesh { shader, .. } => Some(shader),
            PreparedNode::Csg { .. } => None,
        }
    }

    /// The shader of leaf `leaf`.
    pub fn leaf_shader(&self, leaf: u32) -> u32 {
        match self.nodes[leaf as usize] {
            PreparedNode::Leaf { shader, .. } | PreparedNode::Mesh { shader, .. } => shader,
            PreparedNode::Csg { .. } => 0,
        }
    }

    /// The spans of `ray` inside node `node`, appended to `scratch.spans`; returns where they
    /// start.
    fn eval(&self, node: u32, ray: &Ray, scratch: &mut SpanScratch) -> usize {
        let start = scratch.spans.len();
        match self.nodes[node as usize] {
            PreparedNode::Leaf {
                shape, placement, ..
            } => {
                let o = placement.point_to_object(ray.origin);
                let d = placement.vector_to_object(ray.dir);
                if let Some(s) = shape::span(&shape, o, d) {
                    let end = |c: shape::Crossing| Boundary {
                        t: c.t,
                        t_error: c.t_error,
                        merge_error: c.merge_error,
                        leaf: node,
                        face: c.face,
                        flip: false,
                    };
                    scratch.spans.push(Span {
                        enter: end(s.enter),
                        exit: end(s.exit),
                    });
                }
            }
            PreparedNode::Mesh {
                first,
                count,
                placement,
                ..
            } => {
                let o = placement.point_to_object(ray.origin);
                let d = placement.vector_to_object(ray.dir);
                let triangles = &self.mesh_triangles[first as usize..(first + count) as usize];
                mesh::spans(
                    triangles,
                    o,
                    d,
                    node,
                    &mut scratch.crossings,
                    &mut scratch.spans,
                );
            }
            PreparedNode::Csg { op, a, b } => {
                let sa = self.eval(a, ray, scratch);
                let sb = self.eval(b, ray, scratch);
                let mut combined = core::mem::take(&mut scratch.combined);
                combined.clear();
                combine(
                    op,
                    &scratch.spans[sa..sb],
                    &scratch.spans[sb..],
                    &mut combined,
                    |bound| {
                        let hit = SolidHit {
                            t: bound.t,
                            t_error: bound.t_error,
                            leaf: bound.leaf,
                            face: bound.face,
                            flip: bound.flip,
                        };
                        self.surface(ray, &hit).normal
                    },
                );
                scratch.spans.truncate(start);
                scratch.spans.extend_from_slice(&combined);
                scratch.combined = combined;
            }
        }
        start
    }

    /// The first surface of object `object` that `ray` crosses with `t` in front of its origin
    /// (beyond the crossing's error bound) and below `t_max`.
    #[inline]
    pub fn first_hit(
        &self,
        object: u32,
        ray: &Ray,
        t_max: f32,
        scratch: &mut SpanScratch,
    ) -> Option<SolidHit> {
        match &self.shortcuts[object as usize] {
            Shortcut::Sphere(sphere) => sphere.first_hit(ray, t_max),
            _ => self.node_first_hit(object, ray, t_max, scratch),
        }
    }

    /// [`Solids::first_hit`] of an object that is not a lone sphere, from its node.
    #[inline]
    fn node_first_hit(
        &self,
        object: u32,
        ray: &Ray,
        t_max: f32,
        scratch: &mut SpanScratch,
    ) -> Option<SolidHit> {
        let root = self.objects[object as usize];
        if let PreparedNode::Leaf {
            shape, placement, ..
        } = &self.nodes[root as usize]
        {
            // A shape alone: its first crossing, without collecting spans.
            let o = placement.point_to_object(ray.origin);
            let d = placement.vector_to_object(ray.dir);
            let (t, t_error, face) = shape::first_crossing(shape, o, d, t_max)?;
            return Some(SolidHit {
                t,
                t_error,
                leaf: root,
                face,
                flip: false,
            });
        }
        scratch.spans.clear();
        self.eval(root, ray, scratch);
        let front = |b: &Boundary| shape::in_front(b.t, b.t_error);
        let first = scratch
            .spans
            .iter()
            .flat_map(|s| [s.enter, s.exit])
            .find(front)?;
        (first.t < t_max).then_some(SolidHit {
            t: first.t,
            t_error: first.t_error,
            leaf: first.leaf,
            face: first.face,
            flip: first.flip,
        })
    }

    /// [`Solids::first_hit`], skipped when the ray misses the object's reject box within
    /// `[0, t_max]` (`inv_dir` is `1 / ray.dir`): the same answer, found cheaply for rays that
    /// pass far from a cone, a box or a CSG object.
    #[inline(always)]
    pub fn first_hit_in_box(
        &self,
        object: u32,
        ray: &Ray,
        inv_dir: Vec3,
        t_max: f32,
        scratch: &mut SpanScratch,
    ) -> Option<SolidHit> {
        match &self.shortcuts[object as usize] {
            Shortcut::Sphere(sphere) => return sphere.first_hit(ray, t_max),
            Shortcut::Reject(b) => {
                b.intersect(ray, inv_dir, t_max)?;
            }
            Shortcut::Node => {}
        }
        self.node_first_hit(object, ray, t_max, scratch)
    }

    /// The surface at `hit` of `ray`: point (re-projected onto the leaf shape), error bound,
    /// outward normal and shader.
    pub fn surface(&self, ray: &Ray, hit: &SolidHit) -> SolidSurface {
        // By reference: a placement is 156 bytes, and copying it out of the node was an eighth
        // of this function's instructions on SPD's mount.
        let (placement, shader, p, err, object_normal) = match &self.nodes[hit.leaf as usize] {
            PreparedNode::Leaf {
                shape,
                placement,
                shader,
            } => {
                let o = placement.point_to_object(ray.origin);
                let d = placement.vector_to_object(ray.dir);
                let (p, err) = shape::surface(shape, o, d, hit.t, hit.t_error, hit.face);
                (
                    placement,
                    *shader,
                    p,
                    err,
                    shape::normal(shape, p, hit.face),
                )
            }
            PreparedNode::Mesh {
                first,
                placement,
                shader,
                ..
            } => {
                let tri = &self.mesh_triangles[(*first + hit.face) as usize];
                let o = placement.point_to_object(ray.origin);
                let d = placement.vector_to_object(ray.dir);
                let p = o + d * hit.t;
                // The point's error: the crossing's t error along d, plus the sum's rounding.
                let err = d.abs() * hit.t_error + p.abs() * crate::math::float::gamma(4);
                let n = crate::geom::triangle::unit_normal(tri).unwrap_or(Vec3::Z);
                (placement, *shader, p, err, n)
            }
            PreparedNode::Csg { .. } => {
                // Hits always name leaves; a CSG node here would be a bug upstream.
                return SolidSurface {
                    point: ray.at(hit.t),
                    point_error: Vec3::ZERO,
                    normal: Vec3::Z,
                    shader: 0,
                };
            }
        };
        let (point, point_error) = placement.point_to_world(p, err);
        let mut normal = placement.normal_to_world(object_normal);
        if normal == Vec3::ZERO {
            normal = -ray.dir.unit();
        }
        if hit.flip {
            normal = -normal;
        }
        SolidSurface {
            point,
            point_error,
            normal,
            shader,
        }
    }
}

/// The world box of an object-space box `ob`: its corners mapped, grown by their rounding.
fn world_box(ob: &Aabb, placement: &Placement) -> Aabb {
    if !finite_box(ob) {
        return *ob;
    }
    let mut b = Aabb::EMPTY;
    for c in 0..8 {
        let corner = Vec3::new(
            if c & 1 == 0 { ob.min.x } else { ob.max.x },
            if c & 2 == 0 { ob.min.y } else { ob.max.y },
            if c & 4 == 0 { ob.min.z } else { ob.max.z },
        );
        let (p, err) = placement.point_to_world(corner, corner.abs() * gamma(2));
        b.add_point(p - err);
        b.add_point(p + err);
    }
    b
}
