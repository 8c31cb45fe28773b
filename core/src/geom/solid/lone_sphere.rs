//! Lone spheres moved into place by a translation alone, tested without their node.
//!
//! Most spheres of NFF and FART scenes are objects of one sphere shape, translated. Their node
//! ([`PreparedNode::Leaf`](super::prepared::PreparedNode)) carries the shape and a placement of
//! four matrices, about 170 bytes, and a test reads both and applies the inverse matrix. A
//! [`LoneSphere`] keeps the 24 bytes the test needs and runs the node's test operation for
//! operation, but for the identity's products where they change no bit of the answer
//! ([`LoneSphere::first_hit`] says why), so every hit is the node's to the bit.
//!
//! [`SphereGroup`] tests up to [`GROUP`] of them against one ray together: their roots are
//! computed lane by lane without branches, as `shape.rs`'s `sphere_roots` computes them (the
//! square roots four at a time, [`sqrt_lanes`]), and only those with a root in front of the
//! origin and the nearer below the bound go on, one by one, to the error bounds. On SPD's
//! shells a ray meets hundreds of overlapping spheres in one cell, most of which it misses,
//! leaves behind it or meets behind a closer one; one by one, each such test waited on its
//! divisions and on a branch the processor could not predict. A group keeps its spheres lane
//! by lane, the layout the test reads; the octree's large leaves keep theirs ready
//! ([`LeafSpheres`](crate::accel::leaf_spheres::LeafSpheres)).

use super::extent::reject_box;
use super::hit::SolidHit;
use super::shape;
use super::Shape;
use crate::geom::hit::{Closest, RayHit, GROUP};
use crate::math::aabb::Aabb;
use crate::math::lanes::sqrt_lanes;
use crate::math::ray::Ray;
use crate::math::transform::Placement;
use glam::{Mat3, Vec3, Vec4};

/// A sphere object whose placement is a translation: its world centre, radius and node.
#[derive(Clone, Copy, Debug)]
pub struct LoneSphere {
    centre: Vec3,
    radius: f32,
    /// The sphere's node in the arena (the object's root), named in its hits.
    leaf: u32,
}

impl LoneSphere {
    /// The record of the object whose root `leaf` is `shape` placed by `placement`, if that is a
    /// sphere whose inverse placement is exactly the identity matrix.
    pub fn of(shape: &Shape, placement: &Placement, leaf: u32) -> Option<LoneSphere> {
        match *shape {
            Shape::Sphere { radius } if placement.inverse == Mat3::IDENTITY => Some(LoneSphere {
                centre: placement.to_world.translation,
                radius,
                leaf,
            }),
            _ => None,
        }
    }

    /// The first crossing of `ray` in front of its origin before `t_max`: the node's
    /// [`Solids::first_hit`](super::prepared::Solids::first_hit), to the bit.
    ///
    /// The node maps the ray by its inverse placement, the identity: `1·x + 0·y + 0·z` per
    /// axis. Where every component is finite that is `x` but for the sign of a zero, and the
    /// sphere test does not read the signs of zeros in `o` and `d`: it reads them through
    /// squares, absolute values, and `b = 2·o·d`, whose zeros of either sign pick the same
    /// branch of `quadratic` (`b < 0` is false for both) and give the same `b + √disc`
    /// (`√disc ≥ +0`). So the products are skipped where `o·o + d·d` is finite, which it is
    /// only if every component is; an infinity or NaN (`0·∞` is NaN) takes the node's maps.
    #[inline]
    pub fn first_hit(&self, ray: &Ray, t_max: f32) -> Option<SolidHit> {
        let (mut o, mut d) = (ray.origin - self.centre, ray.dir);
        if !(o.dot(o) + d.dot(d)).is_finite() {
            // `Placement::point_to_object` and `vector_to_object` with the identity as inverse,
            // the products by 1 and 0 and their sums kept.
            (o, d) = (Mat3::IDENTITY * o, Mat3::IDENTITY * d);
        }
        let (t, t_error, face) = shape::sphere_first_crossing(self.radius, o, d, t_max)?;
        Some(SolidHit {
            t,
            t_error,
            leaf: self.leaf,
            face,
            flip: false,
        })
    }

    /// The rays of four, their origins and directions per axis lane by lane, that surely miss
    /// the sphere (bit `l` for ray `l`): [`LoneSphere::first_hit`] finds no hit for them. Its
    /// test asks [`surely_misses`](super::sphere_miss::surely_misses) first, of the same
    /// offsets from the centre where they are finite, and this asks it of the four at once
    /// ([`surely_misses4`](super::sphere_miss::surely_misses4)); a lane with an infinite or NaN
    /// value is never a sure miss.
    #[inline(always)]
    pub fn surely_missed_by4(&self, origin: &[Vec4; 3], dir: &[Vec4; 3]) -> u32 {
        let c = self.centre;
        let o = [0, 1, 2].map(|a| origin[a] - Vec4::splat(c[a]));
        super::sphere_miss::surely_misses4(self.radius, o, *dir)
    }
}

/// Up to [`GROUP`] lone spheres, with their primitive indices, to test against one ray. They are
/// kept lane by lane (each field of every sphere together), the layout the test reads.
#[derive(Clone, Copy, Debug)]
pub struct SphereGroup {
    x: [f32; GROUP],
    y: [f32; GROUP],
    z: [f32; GROUP],
    r: [f32; GROUP],
    leaf: [u32; GROUP],
    indices: [u32; GROUP],
    len: usize,
}

impl SphereGroup {
    /// A group of no spheres.
    pub fn new() -> SphereGroup {
        SphereGroup {
            x: [0.0; GROUP],
            y: [0.0; GROUP],
            z: [0.0; GROUP],
            r: [0.0; GROUP],
            leaf: [0; GROUP],
            indices: [0; GROUP],
            len: 0,
        }
    }

    /// Empties the group.
    #[inline]
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Adds `sphere`, primitive `index`; the group must not be full.
    #[inline]
    pub fn push(&mut self, index: u32, sphere: LoneSphere) {
        let k = self.len;
        (self.x[k], self.y[k], self.z[k]) = sphere.centre.into();
        self.r[k] = sphere.radius;
        self.leaf[k] = sphere.leaf;
        self.indices[k] = index;
        self.len += 1;
    }

    /// How many spheres the group holds.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// True if the group holds no sphere.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The primitive indices of the group's spheres, in the order they were added.
    #[inline]
    pub fn indices(&self) -> &[u32] {
        &self.indices[..self.len]
    }

    /// True if the group holds [`GROUP`] spheres.
    #[inline]
    pub fn is_full(&self) -> bool {
        self.len == GROUP
    }

    /// Where a sphere of the group can report a hit: the box around the spheres' reject boxes
    /// ([`reject_box`] of each one's world box), so a ray that misses it within `[0, t_max]`
    /// gets no hit below `t_max` from any of them.
    pub fn reach(&self) -> Aabb {
        let mut all = Aabb::EMPTY;
        for (sphere, _) in self.spheres() {
            let r = Vec3::splat(sphere.radius);
            let b = reject_box(&Aabb {
                min: sphere.centre - r,
                max: sphere.centre + r,
            });
            all.add_point(b.min);
            all.add_point(b.max);
        }
        all
    }

    /// The spheres of the group with their primitive indices, in the order they were added.
    #[inline]
    fn spheres(&self) -> impl Iterator<Item = (LoneSphere, u32)> + '_ {
        (0..self.len).map(|k| {
            let sphere = LoneSphere {
                centre: Vec3::new(self.x[k], self.y[k], self.z[k]),
                radius: self.r[k],
                leaf: self.leaf[k],
            };
            (sphere, self.indices[k])
        })
    }

    /// Tests every sphere of the group against `ray` and offers each hit to `closest`, as
    /// `hit(index, solid_hit)`: the hits [`LoneSphere::first_hit`] reports with the bound
    /// `closest` gives at the time, to the bit.
    #[inline]
    pub fn test<H: RayHit>(
        &self,
        ray: &Ray,
        closest: &mut Closest<H>,
        hit: impl Fn(u32, SolidHit) -> H,
    ) {
        if self.len < GROUP / 2 {
            // Too few to fill the lanes: one by one costs less.
            for (sphere, i) in self.spheres() {
                if let Some(h) = sphere.first_hit(ray, closest.bound()) {
                    closest.offer(i, hit(i, h));
                }
            }
            return;
        }
        let d = Mat3::IDENTITY * ray.dir;
        let lanes = Lanes::new(self, ray.origin);
        let (t0, t1, mut may_hit) = lanes.roots(d, self.len, closest.bound());
        while may_hit != 0 {
            let k = may_hit.trailing_zeros() as usize;
            may_hit &= may_hit - 1;
            let o = Vec3::new(lanes.x[k], lanes.y[k], lanes.z[k]);
            let found = shape::first_root_in_front(o, d, (t0[k], t1[k]), closest.bound());
            if let Some((t, t_error, face)) = found {
                let solid = SolidHit {
                    t,
                    t_error,
                    leaf: self.leaf[k],
                    face,
                    flip: false,
                };
                closest.offer(self.indices[k], hit(self.indices[k], solid));
            }
        }
    }
}

impl SphereGroup {
    /// The index of a sphere of the group that blocks `ray` provably before `t_max` (`0 < t`
    /// and `t + t_error < t_max`, as [`LoneSphere::first_hit`] finds `t`), if any.
    #[inline]
    pub fn blocks(&self, ray: &Ray, t_max: f32) -> Option<u32> {
        let blocking = |h: (f32, f32)| h.0 + h.1 < t_max;
        if self.len < GROUP / 2 {
            return self
                .spheres()
                .find(|(sphere, _)| {
                    sphere
                        .first_hit(ray, t_max)
                        .is_some_and(|h| blocking((h.t, h.t_error)))
                })
                .map(|(_, i)| i);
        }
        let d = Mat3::IDENTITY * ray.dir;
        let lanes = Lanes::new(self, ray.origin);
        let (t0, t1, mut may_hit) = lanes.roots(d, self.len, t_max);
        while may_hit != 0 {
            let k = may_hit.trailing_zeros() as usize;
            may_hit &= may_hit - 1;
            let o = Vec3::new(lanes.x[k], lanes.y[k], lanes.z[k]);
            let found = shape::first_root_in_front(o, d, (t0[k], t1[k]), t_max);
            if found.is_some_and(|(t, t_error, _)| blocking((t, t_error))) {
                return Some(self.indices[k]);
            }
        }
        None
    }
}

impl Default for SphereGroup {
    fn default() -> Self {
        SphereGroup::new()
    }
}

/// The ray's origin in each sphere's object space, and the radii, one lane per sphere.
struct Lanes {
    x: [f32; GROUP],
    y: [f32; GROUP],
    z: [f32; GROUP],
    r: [f32; GROUP],
}

impl Lanes {
    /// The lanes of `group` for a ray from `origin`: `Mat3::IDENTITY * (origin − centre)`, as
    /// the node's maps compute it (the products by 0 and their sums kept; eight lanes at once
    /// they cost little, and [`LoneSphere::first_hit`]'s reason to skip them holds here too).
    #[inline(always)]
    fn new(group: &SphereGroup, origin: Vec3) -> Lanes {
        let mut l = Lanes {
            x: [0.0; GROUP],
            y: [0.0; GROUP],
            z: [0.0; GROUP],
            r: group.r,
        };
        for k in 0..GROUP {
            let o = Vec3::new(
                origin.x - group.x[k],
                origin.y - group.y[k],
                origin.z - group.z[k],
            );
            l.x[k] = (o.x + 0.0 * o.y) + 0.0 * o.z;
            l.y[k] = (0.0 * o.x + o.y) + 0.0 * o.z;
            l.z[k] = (0.0 * o.x + 0.0 * o.y) + o.z;
        }
        l
    }

    /// Per lane, the roots `shape.rs`'s `sphere_roots` and `quadratic` compute for direction `d`
    /// (anything where there are none), and a mask of the first `len` lanes that have roots and
    /// whose nearer root is not at or past `bound`.
    #[inline(always)]
    fn roots(&self, d: Vec3, len: usize, bound: f32) -> ([f32; GROUP], [f32; GROUP], u32) {
        let a = d.dot(d);
        // Three passes, so each compiles to vector instructions (the square roots in the middle
        // are `libm`'s to the bit, four lanes at a time where the processor can).
        let mut b = [0.0f32; GROUP];
        let mut c = [0.0f32; GROUP];
        let mut disc = [0.0f32; GROUP];
        for k in 0..GROUP {
            let (x, y, z, r) = (self.x[k], self.y[k], self.z[k], self.r[k]);
            let od = (x * d.x + y * d.y) + z * d.z;
            b[k] = 2.0 * od;
            c[k] = ((x * x + y * y) + z * z) - r * r;
            let s = od / a;
            let (fx, fy, fz) = (x - d.x * s, y - d.y * s, z - d.z * s);
            disc[k] = 4.0 * a * (r * r - ((fx * fx + fy * fy) + fz * fz));
        }
        let root = sqrt_lanes(disc);
        let mut t0 = [0.0f32; GROUP];
        let mut t1 = [0.0f32; GROUP];
        let mut keep = [false; GROUP];
        for k in 0..GROUP {
            let q = if b[k] < 0.0 {
                -0.5 * (b[k] - root[k])
            } else {
                -0.5 * (b[k] + root[k])
            };
            let (u, v) = if q == 0.0 {
                (0.0, 0.0)
            } else {
                (q / a, c[k] / q)
            };
            (t0[k], t1[k]) = if u <= v { (u, v) } else { (v, u) };
            // As `quadratic` and `first_root_in_front` decide: no roots where the discriminant
            // is negative or `a` zero, and a NaN nearer root does not stop the test. A root is
            // in front only if it is above its error bound, which is not negative
            // (`shape::in_front`), so a sphere with neither root above 0 is behind the origin.
            let before = t0[k] < bound || t0[k].is_nan();
            let roots = (disc[k] >= 0.0 || disc[k].is_nan()) && a != 0.0;
            let ahead = t0[k] > 0.0 || t1[k] > 0.0;
            keep[k] = roots && before && ahead;
        }
        let mask = keep
            .iter()
            .take(len)
            .enumerate()
            .fold(0u32, |m, (k, &h)| m | u32::from(h) << k);
        (t0, t1, mask)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::transform::Transform;
    use crate::scene::mesh::Rng;

    /// The node's test: the placement's maps, then the shape's first crossing.
    fn node_hit(shape: &Shape, pl: &Placement, ray: &Ray, t_max: f32) -> Option<(u32, u32, u32)> {
        let o = pl.point_to_object(ray.origin);
        let d = pl.vector_to_object(ray.dir);
        shape::first_crossing(shape, o, d, t_max).map(|(t, e, f)| (t.to_bits(), e.to_bits(), f))
    }

    /// Ray `i` of a test around `centre` at scale `size`: from anywhere within 8 sizes (the
    /// centre's surroundings included: rays from inside), aimed within 4 sizes of it so about
    /// half hit, every fifth with a component zero of either sign; and its `t_max`, every third
    /// infinite. `None` for a zero direction.
    fn ray_near(rng: &mut Rng, centre: Vec3, size: f32, i: usize) -> Option<(Ray, f32)> {
        let origin = centre + rng.direction() * rng.range(0.0, 8.0) * size;
        let mut dir = centre + rng.direction() * rng.range(0.0, 4.0) * size - origin;
        if i % 5 == 0 {
            dir[i % 3] = if i % 2 == 0 { 0.0 } else { -0.0 };
        }
        let t_max = if i % 3 == 0 {
            f32::INFINITY
        } else {
            rng.range(0.0, 8.0) * size
        };
        (dir != Vec3::ZERO).then(|| (Ray::new(origin, dir), t_max))
    }

    #[test]
    fn hits_are_the_nodes_to_the_bit() {
        let mut rng = Rng::new(7);
        let mut hits = 0;
        for i in 0..20_000 {
            let centre = Vec3::new(
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
            );
            let shape = Shape::Sphere {
                radius: rng.range(0.01, 3.0),
            };
            let pl = Placement::new(&Transform::translate(centre));
            let sphere = LoneSphere::of(&shape, &pl, 3).expect("a translated sphere is lone");
            let Some((ray, t_max)) = ray_near(&mut rng, centre, 1.0, i) else {
                continue;
            };
            let got = sphere.first_hit(&ray, t_max);
            assert_eq!(
                got.map(|h| (h.t.to_bits(), h.t_error.to_bits(), h.face)),
                node_hit(&shape, &pl, &ray, t_max),
                "ray {i}: {ray:?}"
            );
            assert!(got.is_none_or(|h| h.leaf == 3 && !h.flip));
            hits += usize::from(got.is_some());
        }
        assert!(hits > 5_000, "{hits} hits");
    }

    #[test]
    fn hits_are_the_nodes_to_the_bit_on_axes_zeros_and_infinities() {
        // Origins, directions and centres from a few values, so rays start on a centre's
        // axes and planes (offsets of +0 and -0), run along them (direction components of
        // either zero), graze and touch the spheres, and overflow `o·o` or carry an infinity.
        let values = [0.0, -0.0, 1.0, -1.0, 0.5, 3e19, f32::INFINITY];
        let vectors = |v: &[f32]| {
            let mut all = alloc::vec::Vec::new();
            for &x in v {
                for &y in v {
                    for &z in v {
                        all.push(Vec3::new(x, y, z));
                    }
                }
            }
            all
        };
        let (points, dirs) = (vectors(&values), vectors(&values[..6]));
        let mut hits = 0;
        for centre in vectors(&[0.0, -0.0, 1.0]) {
            for radius in [0.5, 1.0, 2.0] {
                let shape = Shape::Sphere { radius };
                let pl = Placement::new(&Transform::translate(centre));
                let sphere = LoneSphere::of(&shape, &pl, 3).expect("a translated sphere is lone");
                for (&origin, &dir) in points.iter().flat_map(|o| dirs.iter().map(move |d| (o, d)))
                {
                    if dir == Vec3::ZERO {
                        continue;
                    }
                    let ray = Ray::new(origin, dir);
                    for t_max in [f32::INFINITY, 2.0] {
                        let got = sphere.first_hit(&ray, t_max);
                        assert_eq!(
                            got.map(|h| (h.t.to_bits(), h.t_error.to_bits(), h.face)),
                            node_hit(&shape, &pl, &ray, t_max),
                            "centre {centre:?}, radius {radius}: {ray:?} to {t_max}"
                        );
                        hits += usize::from(got.is_some());
                    }
                }
            }
        }
        assert!(hits > 10_000, "{hits} hits");
    }

    #[test]
    fn a_group_finds_the_closest_hit_of_its_spheres_one_by_one_to_the_bit() {
        let mut rng = Rng::new(9);
        let mut hits = 0;
        for i in 0..20_000u32 {
            // A cluster of overlapping spheres, at times far out (squares overflow to infinity).
            let scale = if i % 50 == 0 { 1e20 } else { 1.0 };
            let base = Vec3::new(
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
            );
            let mut group = SphereGroup::new();
            let mut pushed = alloc::vec::Vec::new();
            let len = 1 + (i as usize % GROUP);
            for k in 0..len {
                let centre = (base + rng.direction() * rng.range(0.0, 0.5)) * scale;
                let shape = Shape::Sphere {
                    radius: rng.range(0.05, 1.0) * scale,
                };
                let pl = Placement::new(&Transform::translate(centre));
                let sphere = LoneSphere::of(&shape, &pl, 40 + k as u32).expect("lone");
                group.push(100 + k as u32, sphere);
                pushed.push((100 + k as u32, sphere));
            }
            let Some((ray, t_max)) = ray_near(&mut rng, base * scale, scale, i as usize) else {
                continue;
            };
            let mut one_by_one = Closest::new(t_max);
            for (i, sphere) in &pushed {
                if let Some(h) = sphere.first_hit(&ray, one_by_one.bound()) {
                    one_by_one.offer(*i, h);
                }
            }
            let mut together = Closest::new(t_max);
            group.test(&ray, &mut together, |_, h| h);
            let key = |c: &Closest<SolidHit>| {
                c.best()
                    .map(|(i, h)| (i, h.t.to_bits(), h.t_error.to_bits(), h.leaf))
            };
            assert_eq!(key(&together), key(&one_by_one), "case {i}: {ray:?}");
            hits += usize::from(one_by_one.best().is_some());
        }
        assert!(hits > 5_000, "{hits} hits");
    }

    #[test]
    fn only_translated_spheres_are_lone() {
        let sphere = Shape::Sphere { radius: 1.0 };
        let moved = Placement::new(&Transform::translate(Vec3::ONE));
        let scaled = Placement::new(&Transform::scale(Vec3::splat(2.0)));
        assert!(LoneSphere::of(&sphere, &moved, 0).is_some());
        assert!(LoneSphere::of(&sphere, &scaled, 0).is_none());
        let cube = Shape::Cuboid { size: Vec3::ONE };
        assert!(LoneSphere::of(&cube, &moved, 0).is_none());
    }
}
