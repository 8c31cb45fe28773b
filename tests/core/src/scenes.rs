//! Scene descriptions the query tests build on: one grey Phong shader and one light, to which a
//! test adds its triangles and solids.

use glam::Vec3;
use strahl_core::geom::solid::{Shape, SolidNode};
use strahl_core::math::transform::Transform;
use strahl_core::scene::{Light, SceneDesc, Shader, TriangleDesc};

/// A scene of nothing yet: shader 0 is a grey Phong surface, and one light shines from `light`.
pub fn lit(light: Vec3) -> SceneDesc {
    SceneDesc {
        shaders: vec![Shader::phong(
            Vec3::splat(0.5),
            Vec3::ZERO,
            Vec3::ZERO,
            1.0,
            0.0,
        )],
        lights: vec![Light {
            position: light,
            color: Vec3::ONE,
            amount: 1.0,
            casts_shadows: true,
        }],
        ..SceneDesc::default()
    }
}

/// Adds `tris` to `desc` as separate triangles with shader 0.
pub fn add_triangles(desc: &mut SceneDesc, tris: &[[Vec3; 3]]) {
    for tri in tris {
        let first = desc.points.len() as u32;
        desc.points.extend_from_slice(tri);
        desc.triangles
            .push(TriangleDesc::new([first, first + 1, first + 2], 0));
    }
}

/// Adds a scene object made of one `shape` placed by `transform`, with shader 0.
pub fn add_solid(desc: &mut SceneDesc, shape: Shape, transform: Transform) {
    desc.objects.push(desc.solids.len() as u32);
    desc.solids.push(SolidNode::Leaf {
        shape,
        transform,
        shader: 0,
    });
}
