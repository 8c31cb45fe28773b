//! Placing a mesh read from a file (an [`ObjMesh`]) into a scene.
//!
//! [`append_mesh`] adds a mesh's points, normals and triangles to a [`SceneDesc`], moved by a
//! [`Transform`]: points with [`Transform::point`], normals with the inverse transpose
//! ([`Placement::normal_to_world`]), so they stay perpendicular to the surface under a
//! non-uniform scale. Every triangle gets the given shader; its indices are shifted past what the
//! scene held before.

use crate::obj::ObjMesh;
use strahl_core::math::transform::{Placement, Transform};
use strahl_core::scene::{SceneDesc, TriangleDesc};

/// Appends `mesh`, placed by `transform`, to `desc`, with `shader` for every triangle.
///
/// Points go to [`SceneDesc::points`] and normals to [`SceneDesc::normals`] (unit length, in
/// world space); each triangle becomes a [`TriangleDesc`] whose point and normal indices are the
/// mesh's, shifted by the number of points and normals `desc` held before. A triangle without
/// normals keeps `normals: None` (smooth normals computed from its neighbours).
///
/// `transform` should be [`Transform::is_valid`]: a singular one maps every normal to zero, which
/// [`SceneDesc::validate`] then rejects. `shader` is not checked here either (`validate` does).
pub fn append_mesh(desc: &mut SceneDesc, mesh: &ObjMesh, transform: &Transform, shader: u32) {
    // Scenes past u32 indices are rejected by `validate` (TooLarge); saturate rather than wrap.
    let point_base = u32::try_from(desc.points.len()).unwrap_or(u32::MAX);
    let normal_base = u32::try_from(desc.normals.len()).unwrap_or(u32::MAX);
    desc.points
        .extend(mesh.points.iter().map(|&p| transform.point(p)));
    if !mesh.normals.is_empty() {
        let placement = Placement::new(transform);
        desc.normals
            .extend(mesh.normals.iter().map(|&n| placement.normal_to_world(n)));
    }
    desc.triangles
        .extend(mesh.triangles.iter().map(|t| TriangleDesc {
            points: t.points.map(|i| point_base.saturating_add(i)),
            shader,
            normals: t.normals.map(|n| n.map(|i| normal_base.saturating_add(i))),
        }));
}
