//! Procedural scenes: the demo room's `ROOM.txt` and the large benchmark scene, built with core's
//! [`MeshBuilder`] and [`Rng`].
//!
//! Everything here is deterministic (a fixed xorshift generator, no clock), so a generated file is
//! the same on every machine. The generated scenes reach users as files in the seed's formats,
//! written by [`crate::formats::datafile::write_data_file`] and, for the large scene's
//! [`large_config`], [`crate::formats::config::write_config`], when `strahl generate room|large`
//! runs (the command line's `generate` module). Benchmarks and the tests crate use the scenes
//! directly.

use crate::formats::config::Config;
use crate::formats::datafile::write_data_file;
use glam::Vec3;
use std::path::PathBuf;
use strahl_core::scene::camera::{Camera, SeedCamera};
use strahl_core::scene::mesh::{MeshBuilder, Rng};
use strahl_core::scene::{Light, SceneDesc, Shader, TriangleDesc};

/// The demo room for the seed's example camera (0, −100, 25), tilt −15°, zoom 1.5: a floor and
/// four walls, a smooth sphere, a smooth torus, a mirror on the back wall and two lights, one
/// of which casts no shadow.
pub fn room() -> SceneDesc {
    let m = room_geometry();
    SceneDesc {
        points: m.points,
        triangles: m.triangles,
        shaders: room_shaders(),
        lights: room_lights(),
        ..SceneDesc::default()
    }
}

/// The room's triangles: shader 0 the floor, 1 the back and front walls, 2 the side walls, 3 the
/// sphere, 4 the torus, 5 the mirror.
fn room_geometry() -> MeshBuilder {
    let mut m = MeshBuilder::default();
    let mut rng = Rng::new(7);
    let (floor, wall, side, sphere, torus, mirror) = (0, 1, 2, 3, 4, 5);
    // The room reaches behind the camera (y = −100), closed by a front wall the mirror shows.
    let (x0, x1, y0, y1, z1) = (-70.0, 70.0, -130.0, 70.0, 80.0);
    m.grid(
        Vec3::new(x0, y0, 0.0),
        Vec3::new(x1 - x0, 0.0, 0.0),
        Vec3::new(0.0, y1 - y0, 0.0),
        8,
        floor,
    );
    m.grid(
        Vec3::new(x0, y1, 0.0),
        Vec3::new(x1 - x0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, z1),
        8,
        wall,
    );
    m.grid(
        Vec3::new(x0, y0, 0.0),
        Vec3::new(0.0, y1 - y0, 0.0),
        Vec3::new(0.0, 0.0, z1),
        8,
        side,
    );
    m.grid(
        Vec3::new(x1, y1, 0.0),
        Vec3::new(0.0, y0 - y1, 0.0),
        Vec3::new(0.0, 0.0, z1),
        8,
        side,
    );
    m.grid(
        Vec3::new(x1, y0, 0.0),
        Vec3::new(x0 - x1, 0.0, 0.0),
        Vec3::new(0.0, 0.0, z1),
        8,
        wall,
    );
    // A mirror standing in front of the back wall.
    m.quad(
        [
            Vec3::new(-5.0, 66.0, 4.0),
            Vec3::new(55.0, 66.0, 4.0),
            Vec3::new(55.0, 66.0, 54.0),
            Vec3::new(-5.0, 66.0, 54.0),
        ],
        mirror,
    );
    m.sphere(
        Vec3::new(-28.0, 15.0, 18.0),
        18.0,
        48,
        24,
        0.0,
        sphere,
        &mut rng,
    );
    m.torus(Vec3::new(26.0, 0.0, 7.0), 15.0, 6.0, 64, 24, torus);
    m
}

/// The room's shaders, in the order of [`room_geometry`]'s shader numbers.
fn room_shaders() -> Vec<Shader> {
    vec![
        Shader::phong(
            Vec3::splat(0.06),
            Vec3::new(0.55, 0.52, 0.48),
            Vec3::splat(0.05),
            8.0,
            0.0,
        ),
        Shader::phong(
            Vec3::splat(0.05),
            Vec3::new(0.35, 0.45, 0.6),
            Vec3::ZERO,
            1.0,
            0.0,
        ),
        Shader::phong(
            Vec3::splat(0.05),
            Vec3::new(0.6, 0.35, 0.3),
            Vec3::ZERO,
            1.0,
            0.0,
        ),
        Shader::phong(
            Vec3::new(0.04, 0.01, 0.01),
            Vec3::new(0.75, 0.12, 0.1),
            Vec3::splat(0.6),
            40.0,
            0.15,
        ),
        Shader::phong(
            Vec3::new(0.01, 0.03, 0.01),
            Vec3::new(0.2, 0.6, 0.25),
            Vec3::splat(0.5),
            25.0,
            0.0,
        ),
        // The mirror: its local colour is silvered glass, a light blue-grey, which is all it
        // shows under the seed's `$REFLECTIONS 0` and a 15 % tint of what it reflects with
        // reflections on.
        Shader::phong(
            Vec3::new(0.06, 0.065, 0.07),
            Vec3::new(0.55, 0.6, 0.66),
            Vec3::splat(0.3),
            60.0,
            0.85,
        ),
    ]
}

/// The room's two lights: a warm one that casts shadows, a cool fill light that does not.
fn room_lights() -> Vec<Light> {
    vec![
        Light {
            position: Vec3::new(-40.0, -40.0, 75.0),
            color: Vec3::new(1.0, 0.95, 0.85),
            amount: 0.8,
            casts_shadows: true,
        },
        Light {
            position: Vec3::new(50.0, -70.0, 40.0),
            color: Vec3::new(0.7, 0.8, 1.0),
            amount: 0.35,
            casts_shadows: false,
        },
    ]
}

/// A large scene of at least `min_triangles` triangles: a fractal-noise terrain under a ring of
/// smooth spheres, lit by two lights, for performance work.
pub fn large(min_triangles: u32) -> SceneDesc {
    let mut m = MeshBuilder::default();
    let mut rng = Rng::new(42);
    // Spheres take a fifth, the terrain the rest.
    let spheres = 12u32;
    let per_sphere = (min_triangles / 5 / spheres).max(64);
    let seg = ((per_sphere / 2) as f32).sqrt().ceil() as u32 * 2;
    for k in 0..spheres {
        let a = 2.0 * core::f32::consts::PI * k as f32 / spheres as f32;
        let c = Vec3::new(60.0 * libm::cosf(a), 60.0 * libm::sinf(a) + 40.0, 22.0);
        m.sphere(c, 12.0, seg, seg / 2, 0.0, 1 + (k % 2), &mut rng);
    }
    large_terrain(&mut m, min_triangles);
    let shaders = large_shaders();
    let lights = large_lights();
    let camera = Camera::Seed(LARGE_CAMERA);
    SceneDesc {
        points: m.points,
        triangles: m.triangles,
        shaders,
        lights,
        camera,
        ..SceneDesc::default()
    }
}

/// Adds the large scene's terrain (shader 0) to `m`: a square grid of fractal-noise heights with
/// enough triangles to bring `m` to at least `min_triangles`.
fn large_terrain(m: &mut MeshBuilder, min_triangles: u32) {
    let remaining = min_triangles.saturating_sub(m.triangles.len() as u32);
    let n = (((remaining as f32) / 2.0).sqrt().ceil() as u32).max(2);
    let size = 300.0;
    let base = m.points.len() as u32;
    let height = |x: f32, y: f32| {
        let mut h = 0.0;
        let mut f = 0.02;
        let mut amp = 6.0;
        for _ in 0..4 {
            h += amp * libm::sinf(x * f + 1.3) * libm::cosf(y * f * 1.1 + 0.7);
            f *= 2.3;
            amp *= 0.45;
        }
        h
    };
    for j in 0..=n {
        for i in 0..=n {
            let x = -size / 2.0 + size * i as f32 / n as f32;
            let y = -size / 2.0 + 40.0 + size * j as f32 / n as f32;
            m.points.push(Vec3::new(x, y, height(x, y)));
        }
    }
    let row = n + 1;
    for j in 0..n {
        for i in 0..n {
            let a = base + j * row + i;
            m.triangles.push(TriangleDesc {
                normals: None,
                points: [a, a + 1, a + row + 1],
                shader: 0,
            });
            m.triangles.push(TriangleDesc {
                normals: None,
                points: [a, a + row + 1, a + row],
                shader: 0,
            });
        }
    }
}

/// The large scene's shaders: the terrain, then the two sphere colours.
fn large_shaders() -> Vec<Shader> {
    vec![
        Shader::phong(
            Vec3::splat(0.05),
            Vec3::new(0.45, 0.5, 0.35),
            Vec3::splat(0.1),
            10.0,
            0.0,
        ),
        Shader::phong(
            Vec3::splat(0.04),
            Vec3::new(0.7, 0.3, 0.2),
            Vec3::splat(0.6),
            40.0,
            0.3,
        ),
        Shader::phong(
            Vec3::splat(0.04),
            Vec3::new(0.2, 0.3, 0.7),
            Vec3::splat(0.6),
            40.0,
            0.0,
        ),
    ]
}

/// The large scene's lights: a white one that casts shadows, a blue fill light that does not.
fn large_lights() -> Vec<Light> {
    vec![
        Light {
            position: Vec3::new(-100.0, -150.0, 200.0),
            color: Vec3::ONE,
            amount: 0.8,
            casts_shadows: true,
        },
        Light {
            position: Vec3::new(150.0, -50.0, 80.0),
            color: Vec3::new(0.6, 0.7, 1.0),
            amount: 0.3,
            casts_shadows: false,
        },
    ]
}

/// The seed camera of the large scene: its [`SceneDesc`] and its configuration file share it.
pub const LARGE_CAMERA: SeedCamera = SeedCamera {
    position: Vec3::new(0.0, -160.0, 60.0),
    angle_x_deg: -18.0,
    angle_z_deg: 0.0,
    zoom: 1.2,
};

/// The configuration file `strahl generate large` writes beside `LARGE.txt`: a 1024 × 768
/// `large.bmp` under a sky-blue background, seen from [`LARGE_CAMERA`].
pub fn large_config() -> Config {
    Config {
        image_name: Some(PathBuf::from("large.bmp")),
        width: 1024,
        height: 768,
        input_data: Some(PathBuf::from("LARGE.txt")),
        background: Vec3::new(0.55, 0.7, 0.9),
        camera: LARGE_CAMERA,
        ..Config::default()
    }
}

/// The text of `scenes/room/ROOM.txt`, exactly as `strahl generate room` writes it.
pub fn room_data_file() -> String {
    write_data_file(
        &room(),
        "Strahl demo room, written by `strahl generate room`.\n\
         Floor and four walls, a smooth sphere, a smooth torus, a mirror, two lights\n\
         (the second casts no shadow). For the seed's example raytracer.cfg.",
    )
}
