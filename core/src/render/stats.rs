//! Ray statistics: how many rays of each kind a render traced, and the work they cost.

use crate::accel::work::QueryWork;

/// Rays traced, by kind, and the octree cells and intersection tests they cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RayCounts {
    /// Rays from the camera, one per pixel.
    pub primary: u64,
    /// Further camera rays of multisampling (`m² − 1` per pixel).
    pub extra_samples: u64,
    /// Rays towards lights.
    pub shadow: u64,
    /// Mirror rays.
    pub reflection: u64,
    /// Rays through transparent surfaces.
    pub refraction: u64,
    /// Ambient-occlusion rays.
    pub occlusion: u64,
    /// Cells entered and primitives tested by all these rays (not rays: left out of
    /// [`RayCounts::total`]).
    pub work: QueryWork,
}

impl RayCounts {
    /// All rays together.
    pub fn total(&self) -> u64 {
        self.primary
            + self.extra_samples
            + self.shadow
            + self.reflection
            + self.refraction
            + self.occlusion
    }
}

impl core::ops::AddAssign for RayCounts {
    fn add_assign(&mut self, o: RayCounts) {
        self.primary += o.primary;
        self.extra_samples += o.extra_samples;
        self.shadow += o.shadow;
        self.reflection += o.reflection;
        self.refraction += o.refraction;
        self.occlusion += o.occlusion;
        self.work += o.work;
    }
}
