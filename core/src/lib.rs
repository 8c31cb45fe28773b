//! Strahl's renderer core: everything that turns a scene into pixels, with no operating system.
//!
//! The crate is `#![no_std]` (it uses `alloc`) so the same code renders on a laptop, a cluster node
//! and a microcontroller on a serial link. It touches no files, sockets, threads or clocks.
//!
//! It reads in layers, bottom up; each uses only the layers listed before it (a test,
//! `tests/tests/layers.rs`, fails when a module imports from a later layer):
//! 1. [`math`]: float error bounds, rays, boxes, affine transforms, square roots and lengths.
//! 2. [`geom`]: the watertight triangle test, analytic solids and CSG, the hit ordering rule,
//!    the axis-aligned planes that triangles share.
//! 3. [`accel`]: the arena octree over triangles and bounded solids, per light the primitives
//!    by direction that shadow rays test (light buffers), and per glass sphere the few
//!    primitives near it that rays inside it test instead of walking.
//! 4. [`scene`]: the scene model loaders fill in, render settings and their limits, cameras,
//!    which effects can change a pixel, validation, the prepared [`scene::Scene`], and
//!    procedural meshes for generated scenes and tests.
//! 5. [`render`]: scene queries, optics, sampling, shading, pixels, ray statistics,
//!    [`render::render_line`] (the unit of work every executor calls), adaptive multisampling's
//!    second pass and [`render::render_image`].
//! 6. [`wire`]: the wire protocol, pure: frames, the two message enums, scene transfer, limits.
//! 7. [`worker`]: the worker loop that serves the wire protocol over any `embedded_io` link,
//!    building scenes and rendering lines.
//!
//! Each layer has its own small `Copy` error enum beside its code: [`scene::error::SceneError`],
//! [`render::error::RenderError`], [`wire::error::ProtocolError`].
#![no_std]
#![forbid(unsafe_code)]

extern crate alloc;

pub mod math;

pub mod geom;

pub mod accel;

pub mod scene;

pub mod render;

pub mod wire;

pub mod worker;

pub use glam::Vec3;

/// The x86 extensions of x86-64-v3 (the level optimised x86_64 builds compile this crate for,
/// `pgo/rustc-wrapper`), each with whether this build of the crate was compiled to use it. A
/// constant, so a caller built for any x86-64 can read it, and refuse to run the tracer on a
/// processor that lacks one (`strahl` does), before any of this crate's code runs.
pub const X86_FEATURES: [(&str, bool); 8] = [
    ("avx", cfg!(target_feature = "avx")),
    ("avx2", cfg!(target_feature = "avx2")),
    ("bmi1", cfg!(target_feature = "bmi1")),
    ("bmi2", cfg!(target_feature = "bmi2")),
    ("f16c", cfg!(target_feature = "f16c")),
    ("fma", cfg!(target_feature = "fma")),
    ("lzcnt", cfg!(target_feature = "lzcnt")),
    ("movbe", cfg!(target_feature = "movbe")),
];
