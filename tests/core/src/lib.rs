//! Helpers for the tests of `strahl-core` alone (this package's `tests/`) and for the cross-crate
//! tests in `tests/tests/`, which reuse them.
//!
//! - [`meshes`]: triangle sets to shoot rays at (random soups, closed jittered spheres, grids on
//!   octree cell planes) and their bounds.
//! - [`scenes`]: a lit scene description to add triangles and solids to.
//! - [`checked`]: a checked render (every pixel's centre ray traced again) and the closest solid
//!   hit of a ray with its surface.
//! - [`test_files`]: the check that a package's one test binary compiles every file of its
//!   `tests/` (the host's, this package's and `tests/`'s integration tests are each one binary).
//!
//! The package depends on `strahl-core` only, so the octree, solid and shading tests build without
//! the host, its command line or its transports.

pub mod checked;
pub mod meshes;
pub mod scenes;
pub mod test_files;
