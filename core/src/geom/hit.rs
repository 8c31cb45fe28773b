//! What the closest-hit queries need of any primitive's hit: its `t`, that value's error bound,
//! and the one rule that orders hits (smaller `t`, ties to the smaller primitive index).

use super::triangle::TriangleHit;

/// A hit of some primitive, as the generic queries need it: its `t` and that value's error bound.
pub trait RayHit: Copy {
    /// The ray parameter of the hit.
    fn t(&self) -> f32;
    /// Bound on the error of [`RayHit::t`].
    fn t_error(&self) -> f32;
}

impl RayHit for TriangleHit {
    #[inline]
    fn t(&self) -> f32 {
        self.t
    }
    #[inline]
    fn t_error(&self) -> f32 {
        self.t_error
    }
}

/// True if a hit at `t` of primitive `index` is closer than `best`: smaller `t`, ties to the
/// smaller index.
#[inline]
pub fn closer<H: RayHit>(t: f32, index: u32, best: &Option<(u32, H)>) -> bool {
    match best {
        None => true,
        Some((i, b)) => t < b.t() || (t == b.t() && index < *i),
    }
}
