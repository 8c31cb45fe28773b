//! What the closest-hit queries need of any primitive's hit: its `t`, that value's error bound,
//! the one rule that orders hits (smaller `t`, ties to the smaller primitive index), and the
//! closest hit so far ([`Closest`]) with the bound it puts on further tests.

use crate::math::float::MACHINE_EPSILON;

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

/// The most primitives a grouped test gets at once (the octree's `closest_hit_grouped` hands
/// a large leaf's primitives to its tests this many at a time).
pub const GROUP: usize = 16;

/// The closest hit a query has found so far, and the bound it puts on the tests still to come.
#[derive(Clone, Copy, Debug)]
pub struct Closest<H> {
    best: Option<(u32, H)>,
    bound: f32,
    /// [`Closest::cutoff`], kept with the hit: the walks ask for it at every leaf, hits come
    /// seldom.
    cutoff: f32,
}

impl<H: RayHit> Closest<H> {
    /// No hit yet; tests are bounded by `t_max`.
    #[inline]
    pub fn new(t_max: f32) -> Self {
        Closest {
            best: None,
            bound: t_max,
            cutoff: f32::INFINITY,
        }
    }

    /// The bound to give the next test: `t_max`, and once there is a hit its `t` loosened by four
    /// roundings, so only hits that lose the comparison anyway are cut early (the winner stays
    /// exact). A test's hit does not depend on its bound, only whether it is reported.
    #[inline]
    pub fn bound(&self) -> f32 {
        self.bound
    }

    /// Offers primitive `index`'s hit `h`; it is kept if it is [`closer`].
    #[inline]
    pub fn offer(&mut self, index: u32, h: H) {
        if closer(h.t(), index, &self.best) {
            self.best = Some((index, h));
            self.bound = self.bound.min(h.t() * (1.0 + 4.0 * MACHINE_EPSILON));
            self.cutoff = h.t() + h.t_error();
        }
    }

    /// Where cells stop mattering: those that start beyond the best hit plus its error bound
    /// cannot hold a closer one.
    #[inline]
    pub fn cutoff(&self) -> f32 {
        self.cutoff
    }

    /// The closest hit, with its primitive's index.
    #[inline]
    pub fn best(&self) -> Option<(u32, H)> {
        self.best
    }
}
