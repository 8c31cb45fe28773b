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
    /// All rays together (saturating: counts from peers are not trusted to be small).
    pub fn total(&self) -> u64 {
        [
            self.extra_samples,
            self.shadow,
            self.reflection,
            self.refraction,
            self.occlusion,
        ]
        .iter()
        .fold(self.primary, |sum, &n| sum.saturating_add(n))
    }
}

/// Sums saturate: counts come from peers, and a wrong or hostile one must not wrap around.
impl core::ops::AddAssign for RayCounts {
    fn add_assign(&mut self, o: RayCounts) {
        self.primary = self.primary.saturating_add(o.primary);
        self.extra_samples = self.extra_samples.saturating_add(o.extra_samples);
        self.shadow = self.shadow.saturating_add(o.shadow);
        self.reflection = self.reflection.saturating_add(o.reflection);
        self.refraction = self.refraction.saturating_add(o.refraction);
        self.occlusion = self.occlusion.saturating_add(o.occlusion);
        self.work += o.work;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_saturate_instead_of_wrapping() {
        let mut a = RayCounts {
            primary: u64::MAX - 1,
            shadow: u64::MAX,
            ..RayCounts::default()
        };
        a += RayCounts {
            primary: 5,
            shadow: 1,
            ..RayCounts::default()
        };
        assert_eq!(
            (a.primary, a.shadow, a.total()),
            (u64::MAX, u64::MAX, u64::MAX)
        );
    }
}
