//! The counts every scene format is held to, whichever file they come from: a hostile or broken
//! file must not exhaust memory or run for ever. `scenes/FORMATS.md` documents them.

/// The most analytic shapes (spheres, cones, boxes, ... and CSG leaves) a scene may have.
pub const MAX_SHAPES: u64 = 1_000_000;

/// The most triangles a scene may have (a FART mesh used several times counts each time).
pub const MAX_TRIANGLES: u64 = 20_000_000;
