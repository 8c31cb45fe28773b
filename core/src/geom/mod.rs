//! The geometry layer: what a ray can hit, one primitive at a time.
//!
//! - [`triangle`]: the watertight ray/triangle test that reports `t` with its error bound.
//! - [`solid`]: analytic shapes placed by affine transforms, closed meshes used as solids, and CSG
//!   on them, with the render-time form [`solid::prepared::Solids`].
//! - [`axis_planes`]: the axis-aligned planes that triangles share, which a shadow ray leaving
//!   one of them can pass over.
//! - [`hit`]: what the closest-hit queries need of any primitive's hit ([`hit::RayHit`]) and the
//!   rule that orders hits ([`hit::closer`]).
//!
//! `triangle` ← `hit` ← `solid`; the layer uses only [`crate::math`].

pub mod axis_planes;
pub mod hit;
pub mod solid;
pub mod triangle;
