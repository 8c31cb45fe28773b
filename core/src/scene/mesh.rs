//! Procedural meshes: a [`MeshBuilder`] that adds quads, grids, UV spheres and tori to a point
//! and triangle list, and the small deterministic generator ([`Rng`]) that jitters them.
//!
//! Both are pure functions of their arguments and seed (xorshift64*, `libm` trigonometry), so a
//! generated mesh is the same on every machine. The host's procedural scenes (the demo room, the
//! large benchmark scene) and the octree and solid tests build their geometry here.

use super::model::TriangleDesc;
use crate::math::lanes::sqrt;
use alloc::vec::Vec;
use glam::Vec3;

/// A small deterministic random generator (xorshift64*), for scenes and tests.
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed (0 is replaced by a fixed non-zero value).
    pub fn new(seed: u64) -> Self {
        Rng(if seed == 0 {
            0x9E37_79B9_7F4A_7C15
        } else {
            seed
        })
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// A uniform `f32` in `[0, 1)`.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A uniform `f32` in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }

    /// A random point of triangle `t`, uniform over its area (two uniform weights, folded back
    /// into the triangle where they sum past 1).
    pub fn point_in_triangle(&mut self, t: &[Vec3; 3]) -> Vec3 {
        let (a, b) = (self.next_f32(), self.next_f32());
        let (a, b) = if a + b > 1.0 {
            (1.0 - a, 1.0 - b)
        } else {
            (a, b)
        };
        t[0] + (t[1] - t[0]) * a + (t[2] - t[0]) * b
    }

    /// A random direction, uniform on the unit sphere.
    pub fn direction(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length_squared();
            // Rejection sampling in the unit ball; points near the centre are dropped so the
            // division below never magnifies rounding (the distribution stays uniform).
            if l > 1e-4 && l <= 1.0 {
                return v / sqrt(l);
            }
        }
    }
}

/// A triangle mesh under construction: points and triangles with one shader each.
#[derive(Clone, Debug, Default)]
pub struct MeshBuilder {
    /// Vertex positions.
    pub points: Vec<Vec3>,
    /// Triangles indexing `points`.
    pub triangles: Vec<TriangleDesc>,
}

impl MeshBuilder {
    fn point(&mut self, p: Vec3) -> u32 {
        self.points.push(p);
        (self.points.len() - 1) as u32
    }

    fn tri(&mut self, a: u32, b: u32, c: u32, shader: u32) {
        self.triangles.push(TriangleDesc {
            normals: None,
            points: [a, b, c],
            shader,
        });
    }

    /// A quad `a b c d` (counter-clockwise seen from the front) as two triangles.
    pub fn quad(&mut self, corners: [Vec3; 4], shader: u32) {
        let i = corners.map(|p| self.point(p));
        self.tri(i[0], i[1], i[2], shader);
        self.tri(i[0], i[2], i[3], shader);
    }

    /// A quad split into `n × n` cells (so lights and shadows have vertices to land between).
    pub fn grid(&mut self, origin: Vec3, u: Vec3, v: Vec3, n: u32, shader: u32) {
        let base = self.points.len() as u32;
        for j in 0..=n {
            for i in 0..=n {
                self.point(origin + u * (i as f32 / n as f32) + v * (j as f32 / n as f32));
            }
        }
        let row = n + 1;
        for j in 0..n {
            for i in 0..n {
                let a = base + j * row + i;
                self.tri(a, a + 1, a + row + 1, shader);
                self.tri(a, a + row + 1, a + row, shader);
            }
        }
    }

    /// A closed UV sphere with `segments` around and `rings` from pole to pole. Each vertex is
    /// moved by up to `jitter` (a fraction of the radius) along a random direction, which keeps
    /// the mesh closed: neighbouring triangles still share their vertices.
    #[allow(clippy::too_many_arguments)]
    pub fn sphere(
        &mut self,
        c: Vec3,
        radius: f32,
        segments: u32,
        rings: u32,
        jitter: f32,
        shader: u32,
        rng: &mut Rng,
    ) {
        let mut jit = |p: Vec3| p + rng.direction() * (jitter * radius * rng.next_f32());
        let top = self.point(jit(c + Vec3::Z * radius));
        let first = self.points.len() as u32;
        for r in 1..rings {
            let theta = core::f32::consts::PI * r as f32 / rings as f32;
            for s in 0..segments {
                let phi = 2.0 * core::f32::consts::PI * s as f32 / segments as f32;
                let d = Vec3::new(
                    libm::sinf(theta) * libm::cosf(phi),
                    libm::sinf(theta) * libm::sinf(phi),
                    libm::cosf(theta),
                );
                self.point(jit(c + d * radius));
            }
        }
        let bottom = self.point(jit(c - Vec3::Z * radius));
        let at = |r: u32, s: u32| first + (r - 1) * segments + (s % segments);
        for s in 0..segments {
            self.tri(top, at(1, s), at(1, s + 1), shader);
            for r in 1..rings - 1 {
                self.tri(at(r, s), at(r + 1, s), at(r + 1, s + 1), shader);
                self.tri(at(r, s), at(r + 1, s + 1), at(r, s + 1), shader);
            }
            self.tri(bottom, at(rings - 1, s + 1), at(rings - 1, s), shader);
        }
    }

    /// A closed torus around the Z axis through `c`.
    pub fn torus(
        &mut self,
        c: Vec3,
        major: f32,
        minor: f32,
        segments: u32,
        sides: u32,
        shader: u32,
    ) {
        let base = self.points.len() as u32;
        for i in 0..segments {
            let u = 2.0 * core::f32::consts::PI * i as f32 / segments as f32;
            for j in 0..sides {
                let v = 2.0 * core::f32::consts::PI * j as f32 / sides as f32;
                let r = major + minor * libm::cosf(v);
                self.point(
                    c + Vec3::new(r * libm::cosf(u), r * libm::sinf(u), minor * libm::sinf(v)),
                );
            }
        }
        let at = |i: u32, j: u32| base + (i % segments) * sides + (j % sides);
        for i in 0..segments {
            for j in 0..sides {
                self.tri(at(i, j), at(i + 1, j), at(i + 1, j + 1), shader);
                self.tri(at(i, j), at(i + 1, j + 1), at(i, j + 1), shader);
            }
        }
    }
}
