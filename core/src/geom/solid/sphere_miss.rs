//! A sphere missed for sure, known without a division.
//!
//! `shape.rs` finds a sphere's roots from the distance of its centre to the ray's line
//! (pbrt-v4): `f = o − d·(o·d / d·d)`, and the ray misses where `f·f > r²` as `f32` computes
//! them. That costs a division and a chain of products before the answer, and most tests of a
//! sphere are misses. [`surely_misses`] asks the same question of the cheap form
//! `X = a·(o·o − r²) − (o·d)²` (`a = d·d`), which is `a·(|f|² − r²)` in exact arithmetic but
//! loses digits to cancellation when the ray passes close to the sphere's rim. It answers only
//! where `X` is above a bound on both forms' rounding, so whenever it answers, the
//! distance form's `f·f > r*r` holds too and the sphere test would have found no roots: the
//! answer is the same, bit for bit, for every ray. [`surely_misses4`] asks it of four rays at
//! once, lane by lane, by the same operations: a camera packet's test of a lone sphere.
//!
//! **The bound.** Write `S = |o|²`, `A = |d|²` and `F = |f|²` for exact values, `u` for the unit
//! roundoff and `γ(n) = nu/(1 − nu)`, and let `M = A·(S + r²)`.
//! - The distance form: `o·d` is within `γ(3)·|o||d|` of its value and `a` within `γ(3)·A`, so the
//!   quotient is within `γ(8)·|o|/|d|` of `o·d / A`; each component of the computed `f` is then
//!   within `γ(11)·|o|` of the exact one, and since `|f| ≤ |o|` the computed `f·f` is at least
//!   `F − γ(48)·S`. With `r*r ≤ r²(1 + u)`, `F − r² > γ(48)·(S + r²)` makes `f·f > r*r`.
//! - The cheap form: `a·(o·o − r*r)` is within `γ(10)·M` of `A·(S − r²)`, `(o·d)²` within
//!   `γ(8)·A·S`, and the last subtraction adds at most `3u·M`: `X` is within `γ(21)·M` of
//!   `A·(F − r²)`.
//! - So `X > γ(69)·M` implies `F − r² > γ(48)·(S + r²)`. The computed `M` is at least
//!   `(1 − γ(6))` of the exact one, and [`surely_misses`] asks `X > γ(128)·M` of the computed
//!   values: above what is needed. The cost is that rays near the rim take the full test:
//!   within some 10⁻⁵ of the radius from close by, and more from far away, since `X` is
//!   compared with `|o|²` (a ray from `n` radii away is answered only beyond about
//!   `γ(128)·n²/2` of the radius outside the rim).
//! - The argument is about normal numbers. Both `a` and `o·o + r*r` must be at least 2⁻⁶⁰: an
//!   underflowing product is then off by at most 2⁻¹⁵⁰, far below `γ(1)·M`. Infinities and NaN
//!   fail the comparison (`X > bound` with `X` or the bound infinite or NaN is false), so the full
//!   test decides them.

use crate::math::float::gamma;
use glam::{Vec3, Vec4};

/// The smallest `d·d` and `o·o + r²` the rounding argument covers (2⁻⁶⁰).
const LEAST_SCALE: f32 = 1.0 / (1u64 << 60) as f32;

/// True only if the ray `o + t·d` misses the sphere of radius `r` around the origin as the
/// distance form in `shape.rs` computes it (`f·f > r*r`); false where that is not certain.
#[inline(always)]
pub fn surely_misses(r: f32, o: Vec3, d: Vec3) -> bool {
    let (a, oo, rr, od) = (d.dot(d), o.dot(o), r * r, o.dot(d));
    let x = a * (oo - rr) - od * od;
    let scale = oo + rr;
    x > gamma(128) * (a * scale) && a >= LEAST_SCALE && scale >= LEAST_SCALE
}

/// [`surely_misses`] for four rays at once, one per lane (`o` and `d` per axis): the lanes
/// (bit `l` for ray `l`) it says surely miss. Each lane's values are computed by the very
/// operations `surely_misses` makes, in its order, so its answer is `surely_misses`'s.
#[inline(always)]
pub fn surely_misses4(r: f32, o: [Vec4; 3], d: [Vec4; 3]) -> u32 {
    let dot = |u: &[Vec4; 3], v: &[Vec4; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let (a, oo, rr, od) = (dot(&d, &d), dot(&o, &o), Vec4::splat(r * r), dot(&o, &d));
    let x = a * (oo - rr) - od * od;
    let scale = oo + rr;
    let least = Vec4::splat(LEAST_SCALE);
    let sure = x.cmpgt(Vec4::splat(gamma(128)) * (a * scale)) & a.cmpge(least) & scale.cmpge(least);
    sure.bitmask()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::norm::Norm;
    use crate::scene::mesh::Rng;

    /// The distance form's answer, as `shape.rs` computes it: true where it finds no roots.
    fn distance_form_misses(r: f32, o: Vec3, d: Vec3) -> bool {
        let a = d.dot(d);
        let f = o - d * (o.dot(d) / a);
        r * r - f.dot(f) < 0.0
    }

    /// A ray whose line passes at `r·(1 + k)` from the centre, from `far` radii away, at a
    /// random scale, with an unnormalised direction.
    fn near_rim(rng: &mut Rng, k: f32) -> (f32, Vec3, Vec3) {
        let mut unit = || rng.next_f32() * 2.0 - 1.0;
        let scale = libm::exp2f(unit() * 40.0);
        let r = scale * (0.5 + unit().abs());
        let dir = Vec3::new(unit(), unit(), unit()).unit_or(Vec3::X);
        let side = dir.any_orthonormal_vector();
        let far = libm::exp2f(unit().abs() * 16.0);
        let closest = side * r * (1.0 + k);
        let o = closest - dir * r * far * unit().signum();
        let d = dir * libm::exp2f(unit() * 20.0);
        (r, o, d)
    }

    /// Wherever the cheap form says "miss", the distance form misses too, at scales from 2⁻⁴⁰
    /// to 2⁴⁰, and clear misses from close by are caught ([`miss_checks`]).
    ///
    /// [`miss_checks`]: super::super::miss_checks::sure_misses_are_misses
    #[test]
    fn a_sure_miss_is_a_miss_of_the_distance_form() {
        super::super::miss_checks::sure_misses_are_misses(
            17,
            near_rim,
            (surely_misses, distance_form_misses),
            |r, _, d| r * r >= 1e-12 && d.dot(d) >= 1e-12,
        );
    }

    /// The four-lane form answers as the one-ray form in every lane, bit for bit: rays near the
    /// rim and far from it, at every scale, and zero, infinite and NaN components.
    #[test]
    fn four_lanes_answer_as_one() {
        super::super::miss_checks::four_lanes_answer_as_one(
            23,
            near_rim,
            surely_misses,
            surely_misses4,
        );
    }

    /// Rays that hit, or start inside, are never called misses; nor are degenerate inputs.
    #[test]
    fn hits_and_degenerate_inputs_are_not_sure_misses() {
        let mut rng = Rng::new(5);
        for _ in 0..100_000 {
            let k = -rng.next_f32() * 0.999;
            let (r, o, d) = near_rim(&mut rng, k);
            assert!(!surely_misses(r, o, d));
        }
        let o = Vec3::new(0.0, 3.0, -10.0);
        assert!(surely_misses(1.0, o, Vec3::Z));
        assert!(!surely_misses(1.0, Vec3::ZERO, Vec3::Z), "origin inside");
        assert!(!surely_misses(1.0, o, Vec3::ZERO), "no direction");
        assert!(!surely_misses(1.0, o, Vec3::splat(f32::NAN)));
        assert!(!surely_misses(1.0, Vec3::splat(f32::INFINITY), Vec3::Z));
        assert!(!surely_misses(1.0, o * 1e30, Vec3::Z * 1e30), "overflow");
        let tiny = 1e-25;
        assert!(
            !surely_misses(tiny, o * tiny, Vec3::Z),
            "below the covered scale"
        );
    }
}
