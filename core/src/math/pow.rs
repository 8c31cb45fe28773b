//! `x^y` for Phong's highlight: `libm::powf`'s job, five times as fast and more exact.
//!
//! `libm::powf` is FreeBSD's `e_powf`, written in `f32` with float pairs: on this tracer's
//! inputs (`x` in `(0, 1]`, a shader's exponent) about one result in ten is one unit in the last
//! place off the correctly rounded one, and its long chain of dependent steps (a division among
//! them) cost about a tenth of the tracing on a scene of shiny triangles. [`powf`] follows the
//! method of ARM's optimized-routines (which glibc and musl use): `log2 x` from a table of 128
//! subintervals and a series to the sixth power, times `y`, then `2^z` from a table of 128
//! fractions and a series to the fifth power, all in `f64`, rounded once to `f32`. The series
//! are summed in pairs and no step divides, so the chain of dependent steps is short (the
//! tracer waits on it once per light and hit). Its error before that rounding is about
//! 2⁻⁴⁴ of the result at most, so the rounded result is the correctly rounded `x^y` except where
//! `x^y` lies that close to a midpoint between two floats (none among the tests' 1.8 million
//! highlight inputs). `docs/accuracy.md` records what the change did to images.
//!
//! Only basic `f64` operations are used, in a fixed order and without fused multiply-adds, so the
//! result is the same bits on every machine (on a microcontroller without a double-precision unit
//! the operations are done in software: slower there, the same answer). The tables are
//! computed by the compiler from their definitions ([`LOG2_CENTRE`], [`EXP2_FRACTION`], and
//! the series' coefficients [`LOG2_SERIES`], [`EXP2_SERIES`]); the tests compare them with
//! `libm`.
//!
//! Arguments outside the fast path (`x` zero, negative, subnormal, infinite or NaN; `y` infinite
//! or NaN) go to `libm::powf`, which knows every special case of C's `powf`.

use core::f64::consts::LN_2;

/// Bits of the table index: the tables have `1 << TABLE_BITS` entries (1 KiB each).
const TABLE_BITS: u32 = 7;
const N: usize = 1 << TABLE_BITS;

/// The centre of the `i`-th of `N` equal subintervals of `[1, 2)`.
const fn centre(i: usize) -> f64 {
    1.0 + (i as f64 + 0.5) / N as f64
}

/// `ln c` for `c` in `[1, 2]`: `2 atanh s` with `s = (c − 1)/(c + 1)` (at most 1/3), summed
/// until its terms are far below `f64`'s precision.
const fn ln(c: f64) -> f64 {
    let s = (c - 1.0) / (c + 1.0);
    let s2 = s * s;
    let (mut term, mut sum, mut k) = (s, 0.0, 1);
    while k < 80 {
        sum += term / k as f64;
        term *= s2;
        k += 2;
    }
    2.0 * sum
}

/// `e^x` for `x` in `[0, 1]`: its Taylor series, summed until its terms are far below `f64`'s
/// precision.
const fn exp(x: f64) -> f64 {
    let (mut term, mut sum, mut k) = (1.0, 0.0, 1);
    while k < 40 {
        sum += term;
        term = term * x / k as f64;
        k += 1;
    }
    sum
}

/// `1 / centre(i)`.
const INVERSE_CENTRE: [f64; N] = {
    let mut t = [0.0; N];
    let mut i = 0;
    while i < N {
        t[i] = 1.0 / centre(i);
        i += 1;
    }
    t
};

/// `log2 centre(i)`.
const LOG2_CENTRE: [f64; N] = {
    let mut t = [0.0; N];
    let mut i = 0;
    while i < N {
        t[i] = ln(centre(i)) / LN_2;
        i += 1;
    }
    t
};

/// `2^(j / N)`.
const EXP2_FRACTION: [f64; N] = {
    let mut t = [0.0; N];
    let mut j = 0;
    while j < N {
        t[j] = exp(j as f64 / N as f64 * LN_2);
        j += 1;
    }
    t
};

/// The series of `log2(1 + r)`: coefficient `k − 1` is that of `r^k`, `(−1)^(k+1) / (k ln 2)`.
const LOG2_SERIES: [f64; 6] = {
    let mut c = [0.0; 6];
    let mut k = 1;
    while k <= 6 {
        let sign = if k % 2 == 1 { 1.0 } else { -1.0 };
        c[k - 1] = sign / (k as f64 * LN_2);
        k += 1;
    }
    c
};

/// The series of `2^(g / N)`: coefficient `k − 1` is that of `g^k`, `(ln 2 / N)^k / k!`.
const EXP2_SERIES: [f64; 5] = {
    let mut c = [0.0; 5];
    let (mut term, mut k) = (1.0, 1);
    while k <= 5 {
        term = term * (LN_2 / N as f64) / k as f64;
        c[k - 1] = term;
        k += 1;
    }
    c
};

/// Adding it rounds a number below 2⁵¹ in magnitude to an integer held in the low bits.
const ROUND_SHIFT: f64 = 6_755_399_441_055_744.0; // 1.5 · 2⁵²

/// `x^y`. See the module documentation for its accuracy.
#[inline]
pub fn powf(x: f32, y: f32) -> f32 {
    let bits = x.to_bits();
    // Positive normal `x` only (sign bit clear, exponent neither 0 nor all ones).
    if !(0x0080_0000..0x7f80_0000).contains(&bits) || !y.is_finite() {
        // The special cases (`core/clippy.toml` sends every other power here).
        #[allow(clippy::disallowed_methods)]
        return libm::powf(x, y);
    }
    // `z = y · log2 x`, times `N` for `exp2`: the factor `N` joins `y` off the chain of dependent
    // steps, and being a power of two it changes no bit of the product.
    let z = f64::from(y) * N as f64 * log2(bits);
    // 2^(z / N) rounds to 0 below 2⁻¹⁵⁰ and overflows above 2¹²⁸.
    if z < -151.0 * N as f64 {
        return 0.0;
    }
    if z > 129.0 * N as f64 {
        return f32::INFINITY;
    }
    exp2(z) as f32
}

/// `log2 x` of a positive normal `f32` given by its `bits`, within about 2⁻⁵¹.
#[inline]
fn log2(bits: u32) -> f64 {
    let exponent = (bits >> 23) as i32 - 127;
    let i = (bits >> (23 - TABLE_BITS)) as usize & (N - 1);
    // The significand in [1, 2), exactly.
    let m = f64::from_bits((u64::from(bits & 0x007f_ffff) << 29) | 0x3ff0_0000_0000_0000);
    // m = centre(i) · (1 + r) with |r| < 1/256.
    let r = m * INVERSE_CENTRE[i] - 1.0;
    let r2 = r * r;
    // log2(1 + r) to r⁶ (the first term left out is below 2⁻⁵⁸), in pairs to shorten the chain.
    let c = &LOG2_SERIES;
    let pairs = (c[0] + c[1] * r) + r2 * ((c[2] + c[3] * r) + r2 * (c[4] + c[5] * r));
    f64::from(exponent) + LOG2_CENTRE[i] + r * pairs
}

/// `2^(z / N)` for `z / N` in `[-151, 129]`, within about 2⁻⁵⁰ of itself.
#[inline]
fn exp2(z: f64) -> f64 {
    // z = n + g with n an integer and |g| <= 1/2; the subtraction is exact.
    let shifted = z + ROUND_SHIFT;
    let n = shifted.to_bits() as i32;
    let g = z - (shifted - ROUND_SHIFT);
    let g2 = g * g;
    // 2^(g / N) to g⁵ (|g / N| ≤ 1/256: the first term left out is below 2⁻⁶⁰), in pairs.
    let c = &EXP2_SERIES;
    let series = (1.0 + c[0] * g) + g2 * ((c[1] + c[2] * g) + g2 * (c[3] + c[4] * g));
    // 2^(n / N) = 2^(n >> TABLE_BITS) · 2^((n mod N) / N): the first, a power of two that keeps
    // the product normal for every n this function is given, is added to the table entry's
    // exponent, which multiplies by it exactly.
    let fraction = EXP2_FRACTION[n as usize & (N - 1)].to_bits();
    let scale = f64::from_bits(fraction.wrapping_add(((n >> TABLE_BITS) as i64 as u64) << 52));
    scale * series
}

#[cfg(test)]
// The tests compare with `libm::powf`, which the core's code may not call (`core/clippy.toml`).
#[allow(clippy::disallowed_methods)]
mod tests {
    use super::*;

    /// The correctly rounded `x^y`, nearly always: `libm::pow` in `f64` (under one unit in the
    /// last place of `f64`), rounded to `f32`.
    fn reference(x: f32, y: f32) -> f32 {
        libm::pow(f64::from(x), f64::from(y)) as f32
    }

    /// The tables and the series' coefficients agree with `libm` to within four units in the
    /// last place (2⁻⁵⁰).
    #[test]
    fn tables_match_libm() {
        let close = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).abs() <= 4;
        for i in 0..N {
            assert_eq!(INVERSE_CENTRE[i], 1.0 / centre(i));
            assert!(close(LOG2_CENTRE[i], libm::log2(centre(i))), "log2 {i}");
            let f = i as f64 / N as f64;
            assert!(close(EXP2_FRACTION[i], libm::exp2(f)), "exp2 {i}");
        }
        for (k, &c) in (1..).zip(&LOG2_SERIES) {
            let sign = if k % 2 == 1 { 1.0 } else { -1.0 };
            assert!(
                close(c, sign / (k as f64 * libm::log(2.0))),
                "log2 series {k}"
            );
        }
        let mut factorial = 1.0;
        for (k, &c) in (1..).zip(&EXP2_SERIES) {
            factorial *= k as f64;
            let term = libm::pow(libm::log(2.0) / N as f64, k as f64) / factorial;
            assert!(close(c, term), "exp2 series {k}");
        }
    }

    /// On the highlight's inputs (`x` in `(0, 1]`, the SPD scenes' exponents and others) the
    /// result is the reference's, to the bit; `libm::powf` misses it on several per cent.
    #[test]
    fn highlights_are_correctly_rounded() {
        let mut rng = crate::scene::mesh::Rng::new(5);
        for y in [
            1.0, 3.0827, 4.81884, 10.0, 45.2776, 101.148, 1000.0, 0.5, 0.01,
        ] {
            let mut libm_misses = 0;
            for _ in 0..200_000 {
                let x = 1.0 - rng.next_f32();
                assert_eq!(powf(x, y).to_bits(), reference(x, y).to_bits(), "{x}^{y}");
                libm_misses += usize::from(libm::powf(x, y) != reference(x, y));
            }
            if y == 4.81884 {
                assert!(libm_misses > 1_000, "libm::powf missed only {libm_misses}");
            }
        }
    }

    /// Across the whole range of `f32` bases and both signs of exponent, including results that
    /// round to subnormals, to zero and to infinity: never more than one unit in the last place
    /// off, and that only where the result lies next to a midpoint between two floats. An exact
    /// midpoint needs a base of few significant bits and a small integer exponent.
    #[test]
    fn whole_range_is_within_one_unit() {
        let mut rng = crate::scene::mesh::Rng::new(9);
        let mut misses = 0;
        for _ in 0..400_000 {
            let x = f32::from_bits(0x0080_0000 + (rng.next_f32() * 2.0e9) as u32);
            let y = (rng.next_f32() - 0.5) * 16.0;
            let (got, want) = (powf(x, y).to_bits(), reference(x, y).to_bits());
            assert!(
                got.abs_diff(want) <= 1,
                "{x}^{y}: {got:#x} against {want:#x}"
            );
            misses += usize::from(got != want);
        }
        assert!(misses <= 4, "{misses} of 400,000 off by one unit");
        for (x, y) in [
            (0.5, 149.0),
            (0.5, 150.0),
            (0.5, 151.0),
            (2.0, 127.9),
            (2.0, 128.0),
        ] {
            assert_eq!(powf(x, y).to_bits(), reference(x, y).to_bits(), "{x}^{y}");
        }
        // An exact midpoint: the square of a base of 12 significant bits.
        let x = f32::from_bits(0x3a17_b800);
        assert_eq!(powf(x, 2.0).to_bits().abs_diff((x * x).to_bits()), 1);
    }

    /// Exact cases stay exact, and the special cases are C's.
    #[test]
    fn exact_and_special_cases() {
        for y in [0.0, 1.0, 3.0827, -7.5, 101.148] {
            assert_eq!(powf(1.0, y), 1.0);
        }
        assert_eq!(powf(0.75, 0.0), 1.0);
        assert_eq!(powf(0.75, 1.0), 0.75);
        assert_eq!(powf(0.5, 3.0), 0.125);
        assert_eq!(powf(4.0, 0.5), 2.0);
        assert_eq!(powf(0.0, 2.0), 0.0);
        assert_eq!(powf(0.0, -2.0), f32::INFINITY);
        assert_eq!(powf(-2.0, 3.0), -8.0);
        assert!(powf(-2.0, 0.5).is_nan());
        assert!(powf(0.5, f32::NAN).is_nan());
        assert_eq!(powf(0.5, f32::INFINITY), 0.0);
        assert_eq!(
            powf(f32::MIN_POSITIVE / 4.0, 0.5),
            libm::powf(f32::MIN_POSITIVE / 4.0, 0.5)
        );
    }
}
