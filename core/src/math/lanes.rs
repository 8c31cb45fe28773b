//! Square roots, of one number or of several at once, each `libm::sqrtf`'s to the bit.
//!
//! IEEE 754 requires a square root to be correctly rounded, so the processor's instruction
//! (SSE's `sqrtps`, NEON's `fsqrt`) gives the bits `libm::sqrtf` gives, four at a time. They are
//! reached through the `wide` crate's safe `f32x4`; where the target has neither, each lane is
//! `libm::sqrtf` itself (a board's build keeps the code it had).
//!
//! One number's root ([`sqrt`]) goes the same way, and every square root of the core's own code
//! is one of these (`core/clippy.toml` refuses `libm::sqrtf` and glam's lengths of a `Vec3`;
//! [`super::norm`] has those). `libm::sqrtf` on x86 is an `asm!` block of the legacy SSE
//! instruction `sqrtss`, which the compiler copies as it is into code built for x86-64-v3, whose
//! other instructions are AVX's: on the Intel Xeon of 2026-11-29 each such `sqrtss` among them
//! cost so much that the tracer took 1.2 to 1.5 times as long (3.1 times at worst in the
//! profile-guided build; `docs/performance.md`, twenty-ninth round). Through `wide` the compiler
//! picks the encoding (`vsqrtps` there).

/// `libm::sqrtf` of `x`.
#[inline(always)]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(any(
        target_feature = "sse",
        all(target_arch = "aarch64", target_feature = "neon")
    ))]
    {
        wide::f32x4::splat(x).sqrt().to_array()[0]
    }
    #[cfg(not(any(
        target_feature = "sse",
        all(target_arch = "aarch64", target_feature = "neon")
    )))]
    {
        #[allow(clippy::disallowed_methods)] // no vector unit: the crate's own
        libm::sqrtf(x)
    }
}

/// `libm::sqrtf` of every lane of `x`.
#[inline(always)]
pub fn sqrt_lanes<const N: usize>(x: [f32; N]) -> [f32; N] {
    #[cfg(any(
        target_feature = "sse",
        all(target_arch = "aarch64", target_feature = "neon")
    ))]
    {
        let mut out = x;
        let mut chunks = out.chunks_exact_mut(4);
        for c in &mut chunks {
            let v = wide::f32x4::new([c[0], c[1], c[2], c[3]]).sqrt();
            c.copy_from_slice(&v.to_array());
        }
        for v in chunks.into_remainder() {
            *v = sqrt(*v);
        }
        out
    }
    #[cfg(not(any(
        target_feature = "sse",
        all(target_arch = "aarch64", target_feature = "neon")
    )))]
    {
        x.map(sqrt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every kind of `f32`: zeros of both signs, subnormals, normals across the exponent range,
    /// infinities, NaNs, negatives, and a sweep of bit patterns.
    fn samples() -> impl Iterator<Item = f32> {
        let special = [
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            -1.0,
            2.0,
        ];
        let sweep = (0..200_000u32).map(|k| f32::from_bits(k.wrapping_mul(21_467)));
        special.into_iter().chain(sweep)
    }

    #[test]
    fn one_root_is_libms_to_the_bit() {
        let mut finite = 0;
        for x in samples() {
            #[allow(clippy::disallowed_methods)] // the reference
            let expected = libm::sqrtf(x);
            assert_eq!(sqrt(x).to_bits(), expected.to_bits(), "sqrt({x:e})");
            finite += usize::from(expected.is_finite() && x > 0.0);
        }
        assert!(finite > 50_000, "{finite} positive finite roots");
    }

    #[test]
    fn each_lane_is_libms_to_the_bit() {
        let xs: alloc::vec::Vec<f32> = samples().collect();
        let mut finite = 0;
        for chunk in xs.chunks_exact(7) {
            let lanes: [f32; 7] = chunk.try_into().expect("seven");
            let got = sqrt_lanes(lanes);
            for (x, r) in lanes.iter().zip(got) {
                #[allow(clippy::disallowed_methods)] // the reference
                let expected = libm::sqrtf(*x);
                assert_eq!(r.to_bits(), expected.to_bits(), "sqrt({x:e})");
                finite += usize::from(r.is_finite() && *x > 0.0);
            }
        }
        assert!(finite > 50_000, "{finite} positive finite roots");
    }
}
