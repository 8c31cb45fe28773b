//! The math layer: numbers and the simplest geometry, with error bounds instead of epsilons.
//!
//! - [`float`]: floating-point error bounds (`gamma`, next representable values) that replace
//!   magic epsilons everywhere above.
//! - [`ray`]: rays and the offsetting of a new ray's origin past a hit point's error bound.
//! - [`aabb`]: axis-aligned boxes and the robust slab test.
//! - [`transform`]: affine placements of shapes, inverted once, with their error bounds.
//! - [`lanes`]: square roots, of one number or several at once, each `libm::sqrtf`'s to the
//!   bit, in the encoding of the code around them.
//! - [`norm`]: a vector's length and unit vector, glam's to the bit, with `lanes`' root.
//! - [`pow`]: `x^y` for Phong's highlight, correctly rounded in practice, faster than
//!   `libm::powf`.
//!
//! `float` ← `ray` ← `aabb`; `float` ← `transform`; `lanes` ← `norm`; `pow` stands alone.
//! Nothing here knows about scenes.

pub mod aabb;
pub mod float;
pub mod lanes;
pub mod norm;
pub mod pow;
pub mod ray;
pub mod transform;
