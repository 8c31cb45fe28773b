//! The scene layer: the model loaders fill in, its checks, and the prepared form renderers use.
//!
//! - [`model`]: [`SceneDesc`] and its parts (points, triangles, [`Shader`]s, [`Light`]s) as the
//!   seed's files describe them (sections 2.5 and 2.6), plus the analytic solids' arena.
//! - [`settings`]: [`RenderSettings`], the image size and switches, with their limits.
//! - [`camera`]: the seed's camera (position, tilt, turn, zoom) and FART's look-at camera, and
//!   the per-image [`CameraFrame`](camera::CameraFrame) that turns pixels into rays.
//! - [`effects`]: which rays can change a pixel, as predicates on a shader and the settings; the
//!   shader calls them per hit and [`Effects`](effects::Effects) sums them up per scene.
//! - [`validate`]: [`SceneDesc::validate`], every rule and index checked before preparing.
//! - [`prepared`]: [`Scene::build`], which validates, computes smooth vertex normals, prepares the
//!   solids and builds the octree.
//! - [`triangle_shading`]: each triangle's shader and whether its smooth normals are its
//!   geometric normal, which is all a hit of a flat triangle reads besides its points.
//! - [`mesh`]: [`MeshBuilder`](mesh::MeshBuilder) and [`Rng`](mesh::Rng), procedural meshes
//!   for generated scenes and tests.
//! - [`error`]: [`SceneError`](error::SceneError), why a description cannot be prepared.
//!
//! Inside the layer (`a ← b`: `b` uses `a`): `settings` ← `model` ← `effects`, `validate`,
//! `mesh`, and `effects`, `validate`, `triangle_shading` ← `prepared`; the layer uses `math`,
//! `geom` and `accel` below it.

pub mod camera;
pub mod effects;
pub mod error;
pub mod mesh;
pub mod model;
pub mod prepared;
pub mod settings;
pub mod triangle_shading;
pub mod validate;

pub use model::{Blend, Light, SceneDesc, Shader, TriangleDesc, MAX_IMAGE_SIDE};
pub use prepared::Scene;
pub use settings::{RenderSettings, MAX_AMBIENT_OCCLUSION, MAX_SAMPLES};
