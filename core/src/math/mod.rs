//! The math layer: numbers and the simplest geometry, with error bounds instead of epsilons.
//!
//! - [`float`]: floating-point error bounds (`gamma`, next representable values) that replace
//!   magic epsilons everywhere above.
//! - [`ray`]: rays and the offsetting of a new ray's origin past a hit point's error bound.
//! - [`aabb`]: axis-aligned boxes and the robust slab test.
//! - [`transform`]: affine placements of shapes, inverted once, with their error bounds.
//! - [`lanes`]: square roots of several numbers at once, each the scalar one's to the bit.
//!
//! `float` ← `ray` ← `aabb`; `float` ← `transform`. Nothing here knows about scenes.

pub mod aabb;
pub mod float;
pub mod lanes;
pub mod ray;
pub mod transform;
