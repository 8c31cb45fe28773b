//! Floating-point error bounds, after pbrt-v4's `gamma(n)` and `NextFloatUp/Down`.
//!
//! Every tolerance in the core is derived from these: a computation with `n` rounded operations
//! has a relative error of at most `gamma(n)`, and new rays step off surfaces by a bound computed
//! from the hit, never by a fixed epsilon that breaks at large or small scales.

/// Half the distance between 1.0 and the next `f32`: the unit roundoff of one rounded operation.
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// Bound on the relative error of `n` successive rounded `f32` operations: `nε / (1 − nε)`.
#[inline]
pub const fn gamma(n: u32) -> f32 {
    let ne = n as f32 * MACHINE_EPSILON;
    ne / (1.0 - ne)
}

/// The smallest `f32` strictly greater than `v` (infinity and NaN are returned unchanged).
#[inline]
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 || v.is_nan() {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v >= 0.0 { bits + 1 } else { bits - 1 };
    f32::from_bits(bits)
}

/// The largest `f32` strictly less than `v` (infinity and NaN are returned unchanged).
#[inline]
pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 || v.is_nan() {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v > 0.0 { bits - 1 } else { bits + 1 };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_float_steps_by_one_ulp() {
        assert!(next_float_up(1.0) > 1.0);
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert!(next_float_down(1.0) < 1.0);
        assert!(next_float_up(0.0) > 0.0);
        assert!(next_float_up(-0.0) > 0.0);
        assert!(next_float_down(0.0) < 0.0);
        assert!(next_float_down(-1e-30) < -1e-30);
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn gamma_grows_with_operation_count() {
        assert!(gamma(1) > 0.0);
        assert!(gamma(3) > gamma(2));
        assert!(gamma(3) < 1e-6);
    }
}
