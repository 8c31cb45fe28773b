//! Cameras: the seed's (a position, a tilt, a turn and a zoom) and FART's (position, look-at
//! point, up vector and vertical field of view), both made into one [`CameraFrame`] of primary rays.
//!
//! Our reading of the seed (documented in `scenes/FORMATS.md`): Z is up. With both angles 0 the
//! camera looks along +Y with +X to the right. `angle_x` tilts it (positive looks up), then
//! `angle_z` turns it about the world Z axis (positive turns left, counter-clockwise seen from
//! above); both in degrees. Zoom `z` gives a horizontal field of view of `2·atan(1/z)`.

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
