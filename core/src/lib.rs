//! Strahl's renderer core: everything that turns a scene into pixels, with no operating system.
//!
//! The crate is `#![no_std]` (it uses `alloc`) so the same code renders on a laptop, a cluster node
//! and a microcontroller on a serial link. It touches no files, sockets, threads or clocks.
//!
//! It reads in layers, each using only the ones above it:
//! - [`float`]: floating-point error bounds (`gamma`, next representable values) that replace
//!   magic epsilons everywhere below.
//! - [`ray`], [`aabb`]: rays, their origin offsetting, and the robust slab test.
//! - [`triangle`]: the watertight ray/triangle test that reports `t` with its error bound.
//! - [`transform`], [`solid`]: analytic shapes placed by affine transforms, and CSG on them.
//! - [`scene`]: the scene model (points, triangles, shaders, lights, camera, settings) and
//!   [`scene::Scene`], the prepared form with smooth vertex normals and the octree.
//! - [`octree`]: an arena octree (flat node array, `u32` handles) with closest-hit and any-hit queries.
//! - [`intersect`]: the scene's closest-hit and any-hit queries over triangles and solids.
//! - [`camera`]: the seed's camera (position, tilt, turn, zoom) and FART's look-at camera.
//! - [`sampling`], [`optics`]: deterministic sample patterns; reflection and Snell refraction.
//! - [`effects`]: which effects can change a pixel of a scene, derived before rendering.
//! - [`shade`]: Phong shading, shadows, reflection and refraction with the 10% cut-off, ambient
//!   occlusion.
//! - [`pixel`]: fixed-point pixels and the one place where colours are clamped and quantised.
//! - [`render`]: [`render::render_line`], the unit of work every executor calls.
//! - [`protocol`]: the wire protocol (frames, messages, scene transfer) and the worker loop that
//!   serves it over any `embedded_io` link.
//! - [`error`]: the small `Copy` error enums.
#![no_std]
#![forbid(unsafe_code)]

extern crate alloc;

pub mod aabb;
pub mod adaptive;
pub mod camera;
pub mod effects;
pub mod error;
pub mod float;
pub mod intersect;
pub mod octree;
pub mod optics;
pub mod pixel;
pub mod protocol;
pub mod ray;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod shade;
pub mod solid;
pub mod transform;
pub mod triangle;

pub use glam::Vec3;
