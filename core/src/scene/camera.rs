//! Cameras: the seed's (a position, a tilt, a turn and a zoom) and FART's (position, look-at
//! point, up vector and vertical field of view), both made into one [`CameraFrame`] of primary rays.
//!
//! Our reading of the seed (documented in `scenes/FORMATS.md`): Z is up. With both angles 0 the
//! camera looks along +Y with +X to the right. `angle_x` tilts it (positive looks up), then
//! `angle_z` turns it about the world Z axis (positive turns left, counter-clockwise seen from
//! above); both in degrees. Zoom `z` gives a horizontal field of view of `2·atan(1/z)`.
//!
//! The frame also runs the other way: [`Projection`] places a point on the image where the
//! frame's rays meet it, and [`CameraFrame::cover`] makes from it the camera's cover of the
//! octree (which four-pixel packets' rays may meet it at all).

use crate::accel::camera_cover::{CameraCover, Seen};
use crate::accel::octree::Octree;
use crate::math::norm::Norm;
use crate::math::ray::Ray;
use glam::Vec3;

/// A camera as a scene file describes it.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Camera {
    /// The seed's configuration-file camera.
    Seed(SeedCamera),
    /// A camera aimed at a point (FART, NFF).
    LookAt(LookAtCamera),
}

impl Default for Camera {
    fn default() -> Self {
        Camera::Seed(SeedCamera::default())
    }
}

/// A camera aimed at a point, with a vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LookAtCamera {
    /// Eye position.
    pub position: Vec3,
    /// The point at the image centre.
    pub look_at: Vec3,
    /// Which way is up (need not be perpendicular to the view, must not be parallel to it).
    pub up: Vec3,
    /// Angle between the top and bottom image edges, in degrees, in `(0, 180)`.
    pub vfov_deg: f32,
}

impl Camera {
    /// True if every number is finite and the camera defines a view.
    pub fn is_valid(&self) -> bool {
        match self {
            Camera::Seed(c) => {
                c.position.is_finite()
                    && c.angle_x_deg.is_finite()
                    && c.angle_z_deg.is_finite()
                    && c.zoom.is_finite()
            }
            Camera::LookAt(c) => {
                let forward = c.look_at - c.position;
                c.position.is_finite()
                    && c.look_at.is_finite()
                    && c.up.is_finite()
                    && c.vfov_deg > 0.0
                    && c.vfov_deg < 180.0
                    && forward != Vec3::ZERO
                    && forward.cross(c.up).unit_or_zero() != Vec3::ZERO
            }
        }
    }
}

/// The seed's camera as the configuration file describes it.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeedCamera {
    /// Eye position.
    pub position: Vec3,
    /// Tilt in degrees, positive looks up (`$CAM_POS_ANGLE_X`).
    pub angle_x_deg: f32,
    /// Turn about world Z in degrees, positive turns left (`$CAM_POS_ANGLE_Z`).
    pub angle_z_deg: f32,
    /// Zoom: the image plane's distance for a half-width of 1 (`$CAM_POS_ZOOM`, default 1).
    pub zoom: f32,
}

impl Default for SeedCamera {
    fn default() -> Self {
        SeedCamera {
            position: Vec3::ZERO,
            angle_x_deg: 0.0,
            angle_z_deg: 0.0,
            zoom: 1.0,
        }
    }
}

/// The camera's orthonormal frame and image-plane mapping, computed once per scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraFrame {
    position: Vec3,
    /// View direction scaled by the zoom.
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    width: u32,
    height: u32,
}

impl CameraFrame {
    /// The frame of `cam` for an image of `width × height` square pixels.
    pub fn new(cam: &Camera, width: u32, height: u32) -> Self {
        match cam {
            Camera::Seed(c) => Self::seed(c, width, height),
            Camera::LookAt(c) => Self::look_at(c, width, height),
        }
    }

    fn look_at(cam: &LookAtCamera, width: u32, height: u32) -> Self {
        let forward = (cam.look_at - cam.position).unit_or_zero();
        let right = forward.cross(cam.up).unit_or_zero();
        let up = right.cross(forward);
        let half = libm::tanf(cam.vfov_deg.to_radians() * 0.5);
        let aspect = height as f32 / width as f32;
        CameraFrame {
            position: cam.position,
            forward: forward * (aspect / half),
            right,
            up,
            width,
            height,
        }
    }

    fn seed(cam: &SeedCamera, width: u32, height: u32) -> Self {
        let ax = cam.angle_x_deg.to_radians();
        let az = cam.angle_z_deg.to_radians();
        let (sx, cx) = (libm::sinf(ax), libm::cosf(ax));
        let (sz, cz) = (libm::sinf(az), libm::cosf(az));
        // Tilt about +X, then turn about +Z.
        let forward = Vec3::new(-sz * cx, cz * cx, sx);
        let right = Vec3::new(cz, sz, 0.0);
        let up = Vec3::new(sz * sx, -cz * sx, cx);
        CameraFrame {
            position: cam.position,
            forward: forward * cam.zoom,
            right,
            up,
            width,
            height,
        }
    }

    /// The primary ray through the point `(x, y)` of the image in pixel units, `(0, 0)` being the
    /// top-left corner and `(x + 0.5, y + 0.5)` the centre of pixel `(x, y)`.
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let w = self.width as f32;
        let u = 2.0 * x / w - 1.0;
        let v = (self.height as f32 - 2.0 * y) / w;
        Ray::new(self.position, self.forward + self.right * u + self.up * v)
    }

    /// How this camera places points on its image ([`Projection`]).
    pub fn projection(&self) -> Projection {
        let (f, r, u) = (wide(self.forward), wide(self.right), wide(self.up));
        let det = dot(f, cross(r, u));
        let over = |v: [f64; 3]| v.map(|c| c / det);
        Projection {
            position: wide(self.position),
            depth: over(cross(r, u)),
            across: over(cross(u, f)),
            upward: over(cross(f, r)),
            width: f64::from(self.width),
            height: f64::from(self.height),
        }
    }

    /// How far, in pixels, a camera ray as [`CameraFrame::ray`] casts it (in `f32`) and as the
    /// octree's walk widens its interval may stray from the exact projection
    /// ([`Projection::see`]): the margin of the camera's [`CameraCover`]. In image units
    /// (`width / 2` pixels) a direction `forward + right·u + up·v` has parts of size at most
    /// `s = |forward|₁ + 1 + height / width` on the image. Its rounding (three products and
    /// two sums per component) and the walk's widening (2·γ(3) of `t`) each turn it by less
    /// than `8 ε·s` radians (ε = 2⁻²⁴), and a turn of `a` radians moves its image point by at
    /// most `a·s² / |forward|²` image units. Four times their sum is kept, plus one pixel.
    pub fn cover_margin(&self) -> f64 {
        let (w, h) = (f64::from(self.width.max(1)), f64::from(self.height));
        let forward = wide(self.forward);
        let s = forward.map(f64::abs).iter().sum::<f64>() + 1.0 + h / w;
        let turn = 16.0 * f64::from(f32::EPSILON / 2.0) * s;
        1.0 + 4.0 * turn * s * s / dot(forward, forward) * w / 2.0
    }

    /// Which four-pixel packets of this camera's image may meet `octree` ([`CameraCover`]).
    pub fn cover(&self, octree: &Octree) -> Option<CameraCover> {
        let projection = self.projection();
        CameraCover::new(
            octree,
            (self.width, self.height),
            self.cover_margin(),
            |p| projection.see(p),
        )
    }
}

/// Where a camera's rays meet points ([`CameraFrame::projection`]), in `f64` from the frame's
/// `f32` numbers, with no assumption that the frame is orthonormal. The ray through image
/// point `(u, v)` (in [`CameraFrame::ray`]'s units) has direction `forward + right·u + up·v`,
/// so `p − position = t·forward + t·u·right + t·v·up`; by Cramer's rule `t`, `t·u` and `t·v`
/// are dot products of `p − position` with the cross products of the other two vectors over
/// the frame's determinant, made once.
#[derive(Clone, Copy, Debug)]
pub struct Projection {
    position: [f64; 3],
    depth: [f64; 3],
    across: [f64; 3],
    upward: [f64; 3],
    width: f64,
    height: f64,
}

impl Projection {
    /// Where `p` lies ([`Seen`]): in front of the camera's plane, the image point whose ray
    /// [`CameraFrame::ray`] would cast through `p` if it computed exactly; behind or on the
    /// plane where `t` is below or within its rounding bound.
    pub fn see(&self, p: Vec3) -> Seen {
        let q = sub(wide(p), self.position);
        let t = dot(q, self.depth);
        // `q`, the vectors made once and the dot are each a few `f64` roundings of the
        // products' magnitudes: far below this bound.
        let bound = 64.0 * f64::EPSILON * dot(q.map(f64::abs), self.depth.map(f64::abs));
        // A NaN (a point the frame cannot place) is near: its cell covers every pixel.
        if t < -bound {
            return Seen::Behind;
        }
        if t <= bound || t.is_nan() {
            return Seen::Near;
        }
        let (u, v) = (dot(q, self.across) / t, dot(q, self.upward) / t);
        let x = (u + 1.0) * self.width / 2.0;
        let y = (self.height - v * self.width) / 2.0;
        Seen::Front(x, y)
    }
}

/// `v` in `f64`, and the vector operations [`CameraFrame::projection`] makes in it.
fn wide(v: Vec3) -> [f64; 3] {
    v.to_array().map(f64::from)
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_camera_looks_along_y_with_x_right() {
        let f = CameraFrame::new(&Camera::default(), 100, 100);
        let centre = f.ray(50.0, 50.0);
        assert_eq!(centre.dir, Vec3::new(0.0, 1.0, 0.0));
        assert!(f.ray(100.0, 50.0).dir.x > 0.0, "right edge is +X");
        assert!(f.ray(50.0, 0.0).dir.z > 0.0, "top edge is +Z");
        // Zoom 1 is a 90° horizontal field of view.
        assert_eq!(f.ray(100.0, 50.0).dir, Vec3::new(1.0, 1.0, 0.0));
    }

    #[test]
    fn positive_angles_look_up_and_turn_left() {
        let up = CameraFrame::new(
            &Camera::Seed(SeedCamera {
                angle_x_deg: 30.0,
                ..SeedCamera::default()
            }),
            10,
            10,
        );
        assert!(up.ray(5.0, 5.0).dir.z > 0.0);
        let left = CameraFrame::new(
            &Camera::Seed(SeedCamera {
                angle_z_deg: 90.0,
                ..SeedCamera::default()
            }),
            10,
            10,
        );
        let d = left.ray(5.0, 5.0).dir;
        assert!(
            d.x < -0.999 && d.y.abs() < 1e-6,
            "turned 90° left looks along -X: {d:?}"
        );
    }

    #[test]
    fn look_at_camera_spans_its_vertical_field_of_view() {
        let cam = Camera::LookAt(LookAtCamera {
            position: Vec3::ZERO,
            look_at: Vec3::new(0.0, 0.0, -5.0),
            up: Vec3::Y,
            vfov_deg: 90.0,
        });
        let f = CameraFrame::new(&cam, 200, 100);
        let centre = f.ray(100.0, 50.0).dir.unit();
        assert!((centre - Vec3::NEG_Z).norm() < 1e-6);
        // 90° vertical: the top edge's centre is 45° up.
        let top = f.ray(100.0, 0.0).dir.unit();
        assert!((top.y - top.z.abs()).abs() < 1e-6 && top.y > 0.0, "{top:?}");
        assert!(f.ray(200.0, 50.0).dir.x > 0.0, "right edge is +X");
        assert!(cam.is_valid());
    }
}
