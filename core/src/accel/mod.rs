//! The acceleration layer: finding the primitives a ray may hit without testing them all.
//!
//! - [`octree`]: an arena octree (flat node array, `u32` handles) over triangles and bounded
//!   solids, with generic closest-hit and any-hit walks that take a per-primitive test.
//! - [`work`]: the counts of cells entered and primitives tested that the walks keep.
//!
//! The layer uses [`crate::math`] and [`crate::geom`].

pub mod octree;
pub mod work;
