//! The acceleration layer: finding the primitives a ray may hit without testing them all.
//!
//! - [`octree`]: an arena octree (flat node array, `u32` handles) over triangles and bounded
//!   solids, with generic closest-hit and any-hit walks that take a per-primitive test.
//! - [`light_buffer`]: per light, the primitives that may stand between it and a point, by
//!   direction; shadow rays test those instead of walking the octree where it is short.
//! - [`leaf_spheres`]: the lone spheres of the octree's large leaves, in groups ready for the
//!   grouped tests.
//! - [`sphere_interiors`]: per transparent lone sphere, the few primitives near it, so a ray
//!   inside it finds its closest hit by testing those instead of walking the octree.
//! - [`camera_cover`]: which of the camera's four-pixel packets may meet the octree at all;
//!   the others' camera rays skip the walk.
//! - [`prefetch`]: a hint that a value is read soon, for reads the processor cannot foresee.
//! - [`work`]: the counts of cells entered and primitives tested that the walks keep.
//!
//! The layer uses [`crate::math`] and [`crate::geom`].

pub mod camera_cover;
pub mod leaf_spheres;
pub mod light_buffer;
pub mod octree;
pub mod prefetch;
pub mod sphere_interiors;
pub mod work;
