//! [`Scene`], the prepared form of a [`SceneDesc`]: validated, with smooth vertex normals (the
//! area-weighted average of the adjacent faces' normals, seed section 3.2.2.1), solids, the
//! resolved occlusion distance, the derived effects, the octree, the lights' buffers and the
//! camera's cover.
//! Renderers only ever see a [`Scene`]. It is built in three stages: [`SceneGeometry`] (the
//! validated geometry), [`IndexedGeometry`] (with its octree) and the scene, so that a caller
//! with a clock can time the octree's build alone.

use super::camera::CameraFrame;
use super::effects::{shadow_ray_matters, Effects};
use super::error::SceneError;
use super::model::{Light, SceneDesc, Shader};
use super::settings::RenderSettings;
use super::triangle_shading::TriangleShadings;
use crate::accel::camera_cover::CameraCover;
use crate::accel::leaf_spheres::LeafSpheres;
use crate::accel::light_buffer::{LightBuffer, SIZED_FOR};
use crate::accel::octree::{Octree, OctreeParams, GROUP};
use crate::accel::sphere_interiors::SphereInteriors;
use crate::geom::axis_planes::AxisPlanes;
use crate::geom::solid::extent::SolidExtent;
use crate::geom::solid::prepared::Solids;
use crate::geom::triangle::{area_normal, unit_normal};
use crate::math::aabb::Aabb;
use crate::math::norm::Norm;
use alloc::vec::Vec;
use glam::Vec3;

/// A scene prepared for rendering: validated, with vertex normals, solids and the octree.
///
/// Primitives are numbered triangles first (`0..T`), then solid objects (`T..`); the octree files
/// both, and unbounded solids (half-spaces and what contains them) are tested beside it.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Image size and switches.
    pub settings: RenderSettings,
    /// Shaders, indexed by [`Scene::triangle_shading`]'s shaders and the solids' leaves.
    pub shaders: Vec<Shader>,
    /// Lights.
    pub lights: Vec<Light>,
    /// The camera's frame for the image size.
    pub camera: CameraFrame,
    /// Vertex positions of each triangle, by triangle index.
    pub triangle_points: Vec<[Vec3; 3]>,
    /// Smooth normal at each corner of each triangle, by triangle index (unit length); empty
    /// where every triangle is flat ([`TriangleShadings::all_flat`]), as no hit reads them.
    pub triangle_normals: Vec<[Vec3; 3]>,
    /// Shader index of each triangle, and whether it is flat (its corner normals are its
    /// geometric normal, which a hit reads instead).
    pub triangle_shading: TriangleShadings,
    /// The axis-aligned planes that triangles share, which a shadow ray leaving one of their
    /// triangles passes over ([`Scene::shadowed`]).
    pub axis_planes: AxisPlanes,
    /// Number of triangles with zero area, in the triangle list and in the meshes of CSG
    /// solids (kept, but never hit).
    pub degenerate_triangles: u32,
    /// The analytic solids and CSG objects.
    pub solids: Solids,
    /// Solid objects with no bounding box (indices into the objects), tested for every ray.
    pub unbounded: Vec<u32>,
    /// The box around every bounded primitive.
    pub bounds: Aabb,
    /// How far occlusion rays look (resolved from [`RenderSettings::ao_distance`]).
    pub ao_distance: f32,
    /// The effects that can change a pixel, derived before rendering.
    pub effects: Effects,
    /// The acceleration structure over triangles and bounded solids.
    pub octree: Octree,
    /// Whether closest-hit and shadow queries test lone spheres in groups
    /// ([`Octree::closest_hit_grouped`], [`Octree::any_hit_grouped`]): where the octree's
    /// occupied leaves hold [`GROUP`] primitives or more on average (SPD's shells: 62 and 203),
    /// as many overlapping spheres do. Where leaves are small (2 to 5 on SPD's other scenes) a
    /// leaf seldom fills a group and the grouped walk cost 2 to 4 % more.
    pub group_spheres: bool,
    /// Where [`Scene::group_spheres`] holds, the lone spheres of the octree's large leaves in
    /// their groups (empty otherwise).
    pub leaf_spheres: LeafSpheres,
    /// Per light, the primitives by direction that its shadow rays test instead of walking the
    /// octree (see [`LightBuffer`]); `None` for a light without shadow rays, where the memory
    /// given does not allow it ([`Scene::build_within`]), or where the buffer would not pay.
    pub light_buffers: Vec<Option<LightBuffer>>,
    /// The transparent lone spheres whose inside rays test a few primitives instead of walking
    /// the octree ([`Scene::closest_hit_inside`]).
    pub sphere_interiors: SphereInteriors,
    /// The camera's four-pixel packets whose rays may meet the octree ([`CameraCover`]), with
    /// the camera frame it was made for: the other packets' camera rays skip the walk. `None`
    /// where a leaf lies across the camera's plane (every packet may meet it) or the image is
    /// too large for it.
    pub camera_cover: Option<(CameraFrame, CameraCover)>,
}

impl Scene {
    /// The camera's cover ([`Scene::camera_cover`]) if it was made for the camera the scene
    /// has now.
    pub fn cover(&self) -> Option<&CameraCover> {
        let (frame, cover) = self.camera_cover.as_ref()?;
        (*frame == self.camera).then_some(cover)
    }

    /// Validates `desc`, computes smooth vertex normals and builds the octree with `params` and
    /// the lights' buffers.
    ///
    /// # Errors
    /// A [`SceneError`] for a missing shader or light, an index out of range, a non-finite number,
    /// a bad image size, or more elements than `u32` indices address.
    pub fn build(desc: &SceneDesc, params: &OctreeParams) -> Result<Scene, SceneError> {
        Scene::build_within(desc, params, u64::MAX)
    }

    /// [`Scene::build`], giving the lights' buffers and the large leaves' sphere groups at most
    /// `buffer_memory` bytes (a board's heap, say): a light gets its buffer only while
    /// [`light_buffer_peak`] fits in what the earlier lights' buffers left (its shadow rays
    /// then walk the octree), and the groups ([`LeafSpheres`]) are kept only if they fit in what
    /// the buffers left (the queries then gather them per leaf). Either way the answers are the
    /// same.
    ///
    /// The three stages are [`SceneGeometry::new`], [`SceneGeometry::index`] (the octree) and
    /// [`IndexedGeometry::into_scene`]; a caller with a clock runs them itself to time the
    /// octree's build alone.
    ///
    /// # Errors
    /// As [`Scene::build`].
    pub fn build_within(
        desc: &SceneDesc,
        params: &OctreeParams,
        buffer_memory: u64,
    ) -> Result<Scene, SceneError> {
        let geometry = SceneGeometry::new(desc)?;
        Ok(geometry.index(params).into_scene(buffer_memory))
    }
}

/// A scene's geometry as its octree files it, before the octree is built: validated, its
/// triangles' points and smooth normals, its solids. The first stage of
/// [`Scene::build_within`].
pub struct SceneGeometry<'a> {
    desc: &'a SceneDesc,
    triangle_points: Vec<[Vec3; 3]>,
    triangle_normals: Vec<[Vec3; 3]>,
    degenerate: u32,
    solids: Solids,
    extents: Vec<SolidExtent>,
}

/// A scene's geometry and the octree over it: the second stage of [`Scene::build_within`].
pub struct IndexedGeometry<'a> {
    geometry: SceneGeometry<'a>,
    octree: Octree,
}

impl<'a> SceneGeometry<'a> {
    /// Validates `desc` and prepares its geometry.
    ///
    /// # Errors
    /// As [`Scene::build`].
    pub fn new(desc: &'a SceneDesc) -> Result<SceneGeometry<'a>, SceneError> {
        desc.validate()?;
        let triangle_points: Vec<[Vec3; 3]> = desc
            .triangles
            .iter()
            .map(|t| t.points.map(|i| desc.points[i as usize]))
            .collect();
        let (triangle_normals, mut degenerate) = smooth_normals(desc, &triangle_points);
        degenerate += desc
            .solid_triangles
            .iter()
            .filter(|p| unit_normal(p).is_none())
            .count() as u32;
        let solids = Solids::new(&desc.solids, &desc.objects, &desc.solid_triangles);
        let extents = solids.extents();
        Ok(SceneGeometry {
            desc,
            triangle_points,
            triangle_normals,
            degenerate,
            solids,
            extents,
        })
    }

    /// Builds the octree over the triangles and the bounded solids with `params`.
    pub fn index(self, params: &OctreeParams) -> IndexedGeometry<'a> {
        let octree = Octree::build_mixed(&self.triangle_points, &self.extents, params);
        IndexedGeometry {
            geometry: self,
            octree,
        }
    }
}

impl IndexedGeometry<'_> {
    /// The scene: the structures beside the octree (the lights' buffers within `buffer_memory`
    /// bytes, the large leaves' sphere groups in what the buffers leave, the glass spheres'
    /// insides), the triangles' shading, the camera and the effects.
    pub fn into_scene(self, buffer_memory: u64) -> Scene {
        let light_buffers = self.light_buffers_within(buffer_memory);
        let buffers: u64 = light_buffers.iter().flatten().map(LightBuffer::bytes).sum();
        let (group_spheres, leaf_spheres) =
            self.sphere_groups_within(buffer_memory.saturating_sub(buffers));
        let sphere_interiors = self.sphere_interiors();
        let IndexedGeometry { geometry, octree } = self;
        let SceneGeometry {
            desc,
            triangle_points,
            mut triangle_normals,
            degenerate,
            solids,
            ..
        } = geometry;
        let unbounded = (0..solids.len() as u32)
            .filter(|&j| solids.bounds()[j as usize].is_none())
            .collect();
        let bounds = octree.bounds();
        let shaders = desc.triangles.iter().map(|t| t.shader);
        let triangle_shading = TriangleShadings::new(&triangle_points, &triangle_normals, shaders);
        if triangle_shading.all_flat() {
            // 36 bytes a triangle no hit reads (SPD's tetra and mount).
            triangle_normals = Vec::new();
        }
        let camera = CameraFrame::new(&desc.camera, desc.settings.width, desc.settings.height);
        let camera_cover = camera.cover(&octree).map(|cover| (camera, cover));
        Scene {
            light_buffers,
            sphere_interiors,
            settings: desc.settings,
            shaders: desc.shaders.clone(),
            lights: desc.lights.clone(),
            camera,
            camera_cover,
            axis_planes: AxisPlanes::new(&triangle_points),
            triangle_shading,
            triangle_points,
            triangle_normals,
            degenerate_triangles: degenerate,
            solids,
            unbounded,
            bounds,
            ao_distance: occlusion_distance(&desc.settings, &bounds),
            effects: Effects::derive(&desc.shaders, &desc.lights, &desc.settings),
            octree,
            group_spheres,
            leaf_spheres,
        }
    }

    /// Each light's buffer ([`Scene::light_buffers`]) within `memory` bytes.
    fn light_buffers_within(&self, memory: u64) -> Vec<Option<LightBuffer>> {
        let g = &self.geometry;
        let filed = Filed {
            bounds: self.octree.bounds(),
            triangles: &g.triangle_points,
            extents: &g.extents,
        };
        light_buffers(g.desc, &filed, memory)
    }

    /// Whether the queries test lone spheres in groups ([`Scene::group_spheres`]), and then the
    /// large leaves' groups within `memory` bytes ([`Scene::leaf_spheres`]).
    fn sphere_groups_within(&self, memory: u64) -> (bool, LeafSpheres) {
        let (g, stats) = (&self.geometry, self.octree.stats());
        let occupied = stats.leaves - stats.empty_leaves;
        let grouped = g.solids.has_lone_spheres()
            && stats.references as usize >= GROUP * occupied.max(1) as usize;
        if !grouped {
            return (false, LeafSpheres::default());
        }
        let n = g.triangle_points.len() as u32;
        let sphere_of = |i: u32| g.solids.lone_sphere(i.checked_sub(n)?);
        (true, LeafSpheres::build(&self.octree, sphere_of, memory))
    }

    /// The transparent lone spheres' insides ([`Scene::sphere_interiors`]): rays start inside a
    /// lone sphere only where they can refract into it.
    fn sphere_interiors(&self) -> SphereInteriors {
        let (g, solids) = (&self.geometry, &self.geometry.solids);
        let transparent = |j: u32| {
            solids.lone_sphere(j).is_some()
                && solids
                    .object_shader(j)
                    .and_then(|s| g.desc.shaders.get(s as usize))
                    .is_some_and(|s| s.transparency > 0.0)
        };
        let spheres = (0..solids.len() as u32)
            .filter(|&j| transparent(j))
            .filter_map(|j| Some((j, solids.bounds()[j as usize]?)));
        let n = g.triangle_points.len() as u32;
        let sphere_of = |i: u32| solids.lone_sphere(i.checked_sub(n)?);
        SphereInteriors::build(
            &self.octree,
            &g.triangle_points,
            &g.extents,
            spheres,
            sphere_of,
        )
    }
}

/// The most memory one light's buffer may take while it is built, what it keeps included, in a
/// scene of `triangles` triangles and `objects` solid objects, sized for `least` primitives at
/// least ([`SIZED_FOR`]): [`LightBuffer::peak_bytes`] and the solids' boxes.
/// [`Scene::build_within`] builds a light's buffer only where this fits.
pub fn light_buffer_peak(triangles: usize, objects: usize, least: usize) -> u64 {
    let boxes = objects * core::mem::size_of::<Option<Aabb>>();
    LightBuffer::peak_bytes(triangles + objects, least) + boxes as u64
}

/// What the lights' buffers file: the triangles and the solids' extents, within `bounds`.
struct Filed<'a> {
    bounds: Aabb,
    triangles: &'a [[Vec3; 3]],
    extents: &'a [SolidExtent],
}

/// Each light's [`LightBuffer`] over the triangles and the solids' reach boxes (where a solid's
/// test can report a hit), for lights whose shadow rays are traced (the light casts shadows and
/// the settings ask for them), while [`light_buffer_peak`] fits in what is left of `memory`,
/// all sized for the first of [`SIZED_FOR`] whose peak fits `memory`.
/// Small scenes get them too: SPD's rings_1 (62 primitives) traced in 0.78 of the time with
/// them, balls_1 (12) in 0.86 (`docs/performance.md`, thirty-eighth round).
fn light_buffers(desc: &SceneDesc, filed: &Filed, mut memory: u64) -> Vec<Option<LightBuffer>> {
    let (triangles, objects) = (filed.triangles.len(), filed.extents.len());
    let Some((least, peak)) = SIZED_FOR
        .iter()
        .map(|&least| (least, light_buffer_peak(triangles, objects, least)))
        .find(|&(_, peak)| peak <= memory)
    else {
        return desc.lights.iter().map(|_| None).collect();
    };
    desc.lights
        .iter()
        .map(|light| {
            let wanted = shadow_ray_matters(&desc.settings, light) && peak <= memory;
            let buffer = wanted
                .then(|| {
                    LightBuffer::build(
                        light.position,
                        &filed.bounds,
                        filed.triangles,
                        filed.extents,
                        least,
                    )
                })
                .flatten();
            memory = memory.saturating_sub(buffer.as_ref().map_or(0, LightBuffer::bytes));
            buffer
        })
        .collect()
}

/// The shading normal at each corner of each triangle, and how many triangles have no area.
///
/// A corner's normal is the one the triangle names, else the area-weighted average of the
/// adjacent faces' normals (the unnormalised face normal has length 2·area), else, where the
/// neighbours cancel out, the face's own normal.
fn smooth_normals(desc: &SceneDesc, triangle_points: &[[Vec3; 3]]) -> (Vec<[Vec3; 3]>, u32) {
    let mut point_normals = alloc::vec![Vec3::ZERO; desc.points.len()];
    let mut degenerate = 0u32;
    let mut face_normals = Vec::with_capacity(triangle_points.len());
    for (t, p) in desc.triangles.iter().zip(triangle_points) {
        let unit = unit_normal(p);
        match unit {
            None => degenerate += 1,
            Some(_) => {
                let n = area_normal(p);
                for &i in &t.points {
                    point_normals[i as usize] += n;
                }
            }
        }
        face_normals.push(unit.unwrap_or(Vec3::ZERO));
    }
    let normals = desc
        .triangles
        .iter()
        .zip(&face_normals)
        .map(|(t, &face)| {
            if let Some(given) = t.normals {
                // Checked by `validate`: in range and not zero.
                return given.map(|i| desc.normals[i as usize].unit_or_zero());
            }
            t.points.map(|i| {
                let n = point_normals[i as usize].unit_or_zero();
                if n == Vec3::ZERO {
                    face
                } else {
                    n
                }
            })
        })
        .collect();
    (normals, degenerate)
}

/// How far occlusion rays look: the settings' distance, or a tenth of the scene's bounding-box
/// diagonal (1 for an empty or unbounded scene).
fn occlusion_distance(settings: &RenderSettings, bounds: &Aabb) -> f32 {
    if let Some(distance) = settings.ao_distance {
        return distance;
    }
    let diagonal = (bounds.max - bounds.min).norm();
    if diagonal > 0.0 && diagonal.is_finite() {
        0.1 * diagonal
    } else {
        1.0
    }
}
