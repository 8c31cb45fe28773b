//! [`QueryWork`]: what ray queries cost, counted in units that do not depend on the machine.
//!
//! The octree walk counts every cell it enters and every primitive test it makes (a primitive
//! skipped by the walk's mailbox is not tested, so it is not counted). Divided by the rays
//! traced, these are the figures Havran's comparison of octree traversals reports for the SPD
//! scenes (intersection tests per ray), so a change to the tree or the walk can be judged without
//! a stopwatch. A shadow ray answered from a light buffer counts its one cell and the listed
//! primitives it tests.

/// Counts of the work behind a set of ray queries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct QueryWork {
    /// Ray–primitive intersection tests made (triangles and solids alike).
    pub intersection_tests: u64,
    /// Octree cells entered, interior and leaf, and light-buffer cells looked up (one per
    /// shadow ray a [`LightBuffer`](crate::accel::light_buffer::LightBuffer) answers).
    pub octree_cells: u64,
}

impl core::ops::AddAssign for QueryWork {
    fn add_assign(&mut self, o: QueryWork) {
        self.intersection_tests = self.intersection_tests.saturating_add(o.intersection_tests);
        self.octree_cells = self.octree_cells.saturating_add(o.octree_cells);
    }
}
