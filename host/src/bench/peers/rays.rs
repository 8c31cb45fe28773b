//! Rays by kind, in the terms both tracers can be read in: camera rays, shadow rays (tests
//! towards lights), reflected and refracted rays, and the rest (Strahl's ambient-occlusion rays,
//! POV-Ray's transmitted rays).

/// Rays one render traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RaysByKind {
    /// Rays from the camera (every sample).
    pub camera: u64,
    /// Rays towards lights.
    pub shadow: u64,
    /// Mirror rays.
    pub reflected: u64,
    /// Rays through transparent surfaces.
    pub refracted: u64,
    /// Any other kind.
    pub other: u64,
}

impl RaysByKind {
    /// All rays together.
    pub fn total(&self) -> u64 {
        self.camera + self.shadow + self.reflected + self.refracted + self.other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn total_sums_every_kind() {
        let r = RaysByKind {
            camera: 1,
            shadow: 2,
            reflected: 4,
            refracted: 8,
            other: 16,
        };
        assert_eq!(r.total(), 31);
    }
}
