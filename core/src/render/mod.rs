//! The render layer: from a prepared [`Scene`](crate::scene::Scene) to pixels.
//!
//! - [`intersect`]: the scene's closest-hit and any-hit queries over triangles and solids.
//! - [`optics`]: mirror reflection and Snell refraction.
//! - [`sampling`]: deterministic sample patterns, seeded by the pixel's coordinates.
//! - [`shade`]: [`shade::trace`], Phong shading with shadows, reflection and refraction under
//!   the 10% cut-off, and ambient occlusion.
//! - [`stats`]: [`RayCounts`](stats::RayCounts), the rays traced by kind.
//! - [`ray_limit`]: the most rays of each kind a line can trace (what a master checks a
//!   worker's counts against).
//! - [`pixel`]: fixed-point pixels and the one place where colours are clamped and quantised.
//! - [`line`](mod@line): [`render_line`], the unit of work every executor calls.
//! - [`adaptive`]: adaptive multisampling's second pass: which pixels differ from a neighbour,
//!   and [`adaptive::refine_line`], which supersamples them.
//! - [`image`]: [`render_image`], both passes over every line on one machine.
//! - [`error`]: the [`RenderError`](error::RenderError) enum.
//!
//! Inside the layer: `optics`, `sampling`, `stats`, `ray_limit`, `pixel`, `error` ← `intersect`
//! ← `shade` ← `line` ← `adaptive` ← `image`. The layer uses `math`, `geom`, `accel` and `scene`
//! below it.

pub mod adaptive;
pub mod error;
pub mod image;
pub mod intersect;
pub mod line;
pub mod optics;
pub mod pixel;
pub mod ray_limit;
pub mod sampling;
pub mod shade;
pub mod stats;

pub use image::render_image;
pub use line::render_line;
