//! A cylinder's side missed for sure, known without a division or a square root.
//!
//! `shape.rs` finds where a ray meets a cylinder's side (`x² + z² = r²`, object space, axis
//! `y`) by solving a quadratic from the ray's point nearest the centre, `m = o + s·d` with
//! `s = −o·d / d·d`: `a = dx² + dz²`, `b = 2·(mx·dx + mz·dz)`, `c = mx² + mz² − r²`, and the
//! side is missed where `b² − 4ac < 0` as `f32` computes it. Then the whole cylinder is missed.
//! That answer costs two divisions for the caps' slab, one for `s` and the products of the
//! quadratic; most tests of a cylinder are misses. [`surely_misses_side`] asks the question of
//! the ray's origin instead: in exact arithmetic `(b² − 4ac)/4 = r²·a − C²` for any point of
//! the ray's line, where `C = ox·dz − oz·dx` is the cross product of the ray's point and
//! direction across the axis, the same for every point of the line. It answers only where
//! `X = C² − r²·a` as computed is above a bound on both forms' rounding, so whenever it
//! answers, `shape.rs` finds `b² − 4ac < 0` too and the cylinder test returns no crossing: the
//! answer is the same, bit for bit, for every ray. [`surely_misses_side4`] asks it of four rays
//! at once, lane by lane, by the same operations: a packet's test of a cylinder.
//!
//! **The bound.** Write `S = |o|²` (all three axes), `A = dx² + dz²`, `u` for the unit
//! roundoff and `γ(n) = nu/(1 − nu)`, and let `M = A·(S + r²)`. This holds for a cylinder
//! (both radii `r`, a finite height that is not zero), where the cone's slope `k` in
//! `shape.rs` is zero and all its terms vanish exactly.
//! - The computed `s` is within `γ(7)` of `o·d / d·d` relative, so `|s| ≤ |o|/|d|·(1 + γ(7))`;
//!   each component of the computed `m` is within `γ(2)·(|oᵢ| + |dᵢ·s|)` of `o + s·d`, and
//!   moving off the line by that changes `C` by at most `γ(2)·(|o|·√A + |s|·A) ≤ γ(5)·|o|·√A`.
//!   With `|C| ≤ |o|·√A`, the computed `m`'s `C²` is at least `C² − γ(10)·S·A`; `|m|` is at
//!   most `|o|·(1 + γ(5))`.
//! - `shape.rs`'s `b²` is within `γ(5)` of its exact value and `4ac` within `γ(7)·4A·(|m|² + r²)`;
//!   with `(mx·dx + mz·dz)² ≤ A·|m|²`, the computed `b² − 4ac` is below zero wherever
//!   `C² − r²·A > γ(12)·A·(1.01·S + r²)` holds for the computed `m`, so wherever
//!   `C² − r²·A > γ(23)·M` holds for the origin.
//! - The computed `X` is within `γ(8)·M` of `C² − r²·A`, and the computed `M` at least
//!   `(1 − γ(6))` of the exact one: [`surely_misses_side`] asks `X > γ(128)·M` of the computed
//!   values, above what is needed. Rays within some `γ(128)·|o|²/r` of the rim take the full
//!   test.
//! - The argument is about normal numbers. `a` and `|o|² + r²` must be at least 2⁻⁶⁰ (an
//!   underflowing product is then off by at most 2⁻¹⁵⁰, far below `γ(1)·M`), `M` at most 2¹⁰⁰
//!   (so nothing in either form overflows) and `dy` finite (so the vanishing terms vanish).
//!   Infinities and NaN elsewhere fail the comparison, so the full test decides them.

use crate::math::float::gamma;
use glam::{Vec3, Vec4};

/// The smallest `a` and `|o|² + r²` the rounding argument covers (2⁻⁶⁰).
const LEAST_SCALE: f32 = 1.0 / (1u64 << 60) as f32;

/// The largest `M` the rounding argument covers (2¹⁰⁰).
const LARGEST_PRODUCT: f32 = (1u128 << 100) as f32;

/// True only if the ray `o + t·d` misses the side of the cylinder of radius `r` around the `y`
/// axis as `shape.rs` computes it (`b² − 4ac < 0`); false where that is not certain. Only for
/// a cylinder: both radii `r` and a finite height that is not zero.
#[inline(always)]
pub fn surely_misses_side(r: f32, o: Vec3, d: Vec3) -> bool {
    let a = d.x * d.x + d.z * d.z;
    let cross = o.x * d.z - o.z * d.x;
    let rr = r * r;
    let x = cross * cross - rr * a;
    let scale = o.dot(o) + rr;
    let m = a * scale;
    x > gamma(128) * m
        && a >= LEAST_SCALE
        && scale >= LEAST_SCALE
        && m <= LARGEST_PRODUCT
        && d.y.is_finite()
}

/// [`surely_misses_side`] for four rays at once, one per lane (`o` and `d` per axis, in the
/// cylinder's object space): the lanes (bit `l` for ray `l`) it says surely miss. Each lane's
/// values are computed by the very operations `surely_misses_side` makes, in its order, so its
/// answer is `surely_misses_side`'s.
#[inline(always)]
pub fn surely_misses_side4(r: f32, o: [Vec4; 3], d: [Vec4; 3]) -> u32 {
    let a = d[0] * d[0] + d[2] * d[2];
    let cross = o[0] * d[2] - o[2] * d[0];
    let rr = Vec4::splat(r * r);
    let x = cross * cross - rr * a;
    let scale = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] + rr;
    let m = a * scale;
    let sure = x.cmpgt(Vec4::splat(gamma(128)) * m)
        & a.cmpge(Vec4::splat(LEAST_SCALE))
        & scale.cmpge(Vec4::splat(LEAST_SCALE))
        & m.cmple(Vec4::splat(LARGEST_PRODUCT))
        & d[1].is_finite_mask();
    sure.bitmask()
}

#[cfg(test)]
mod tests {
    use super::super::shape::cone_side;
    use super::*;
    use crate::math::norm::Norm;
    use crate::scene::mesh::Rng;

    /// `shape.rs`'s answer for the side of a cylinder of radius `r` and height 2: true where it
    /// finds no crossing.
    fn side_missed(r: f32, o: Vec3, d: Vec3) -> bool {
        cone_side(r, r, 2.0, o, d, (f32::NEG_INFINITY, f32::INFINITY)).is_none()
    }

    /// A ray whose line passes at `r·(1 + k)` from the `y` axis, from `far` radii away, at a
    /// random scale and slope, with an unnormalised direction.
    fn near_rim(rng: &mut Rng, k: f32) -> (f32, Vec3, Vec3) {
        let mut unit = || rng.next_f32() * 2.0 - 1.0;
        let scale = libm::exp2f(unit() * 40.0);
        let r = scale * (0.5 + unit().abs());
        let across = Vec3::new(unit(), 0.0, unit()).unit_or(Vec3::X);
        let dir = (across + Vec3::Y * unit() * 4.0).unit();
        let side = Vec3::new(-across.z, 0.0, across.x);
        let far = libm::exp2f(unit().abs() * 16.0);
        let closest = side * r * (1.0 + k) + Vec3::Y * r * unit() * 8.0;
        let o = closest - dir * r * far * unit().signum();
        let d = dir * libm::exp2f(unit() * 20.0);
        (r, o, d)
    }

    /// Wherever the cheap form says "miss", `shape.rs` finds no crossing of the side either, at
    /// scales from 2⁻⁴⁰ to 2⁴⁰, and clear misses from close by are caught ([`miss_checks`]).
    ///
    /// [`miss_checks`]: super::super::miss_checks::sure_misses_are_misses
    #[test]
    fn a_sure_miss_is_a_miss_of_the_side_test() {
        super::super::miss_checks::sure_misses_are_misses(
            29,
            near_rim,
            (surely_misses_side, side_missed),
            |r, o, d| {
                let a = d.x * d.x + d.z * d.z;
                r * r >= 1e-12 && a >= 1e-12 && a * (o.dot(o) + r * r) <= 1e24
            },
        );
    }

    /// Rays that hit the side, or start inside it, are never called misses; nor are degenerate
    /// inputs.
    #[test]
    fn hits_and_degenerate_inputs_are_not_sure_misses() {
        let mut rng = Rng::new(31);
        for _ in 0..100_000 {
            let k = -rng.next_f32() * 0.999;
            let (r, o, d) = near_rim(&mut rng, k);
            assert!(!surely_misses_side(r, o, d));
        }
        let o = Vec3::new(3.0, 0.0, -10.0);
        assert!(surely_misses_side(1.0, o, Vec3::Z));
        assert!(
            !surely_misses_side(1.0, Vec3::ZERO, Vec3::Z),
            "origin inside"
        );
        assert!(!surely_misses_side(1.0, o, Vec3::Y), "along the axis");
        assert!(!surely_misses_side(1.0, o, Vec3::ZERO), "no direction");
        assert!(!surely_misses_side(1.0, o, Vec3::splat(f32::NAN)));
        assert!(!surely_misses_side(1.0, o, Vec3::new(0.0, f32::NAN, 1.0)));
        assert!(!surely_misses_side(
            1.0,
            o,
            Vec3::new(0.0, f32::INFINITY, 1.0)
        ));
        assert!(!surely_misses_side(
            1.0,
            Vec3::splat(f32::INFINITY),
            Vec3::Z
        ));
        assert!(
            !surely_misses_side(1.0, o * 1e30, Vec3::Z * 1e30),
            "overflow"
        );
        assert!(!surely_misses_side(f32::INFINITY, o, Vec3::Z));
        let tiny = 1e-25;
        assert!(
            !surely_misses_side(tiny, o * tiny, Vec3::Z),
            "below the covered scale"
        );
    }

    /// The four-lane form answers as the one-ray form in every lane, bit for bit: rays near the
    /// rim and far from it, at every scale, and zero, infinite and NaN components.
    #[test]
    fn four_lanes_answer_as_one() {
        super::super::miss_checks::four_lanes_answer_as_one(
            37,
            near_rim,
            surely_misses_side,
            surely_misses_side4,
        );
    }
}
