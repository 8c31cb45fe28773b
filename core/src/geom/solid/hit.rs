//! Where a ray first meets a solid object: the hit every solid query returns, ordered by the
//! same rule as triangles' hits ([`RayHit`]).

use super::shape::Face;
use crate::geom::hit::RayHit;

/// Where a ray first meets a solid object's surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolidHit {
    /// Ray parameter.
    pub t: f32,
    /// Bound on the error of `t`.
    pub t_error: f32,
    /// The leaf shape actually hit (index into the arena).
    pub leaf: u32,
    /// Its face.
    pub face: Face,
    /// True if the composite's outward normal is the leaf's inward one (surface from `B` in
    /// `A − B`).
    pub flip: bool,
}

impl RayHit for SolidHit {
    #[inline]
    fn t(&self) -> f32 {
        self.t
    }
    #[inline]
    fn t_error(&self) -> f32 {
        self.t_error
    }
}
