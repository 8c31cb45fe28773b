//! Split cells: a crowded or long cell of a light buffer's face, gridded again finer.
//!
//! A cell over [`CELL_LIMIT`] sends its queries through the octree walk. Where such a cell's
//! primitives are small against it (a tree's branches seen past its trunk), a [`SIDE`]` × `
//! [`SIDE`] grid over that one cell lists most of its directions again. [`plan`] chooses the
//! crowded cells to split, least crowded first, within budgets in proportion to the primitives
//! the buffer is sized for (so a split buffer keeps the memory bound of
//! [`LightBuffer::peak_bytes`]). In a small scene, whose budgets have room, cells of more than
//! [`SPLIT_FROM`] primitives come next, longest first: their queries test every one listed
//! (SPD's tree_5 sized as for 4,096 primitives: 1.85 tests per ray without them, 1.39 with).
//! A split whose sub-cells would be filed more than [`SHORT`] entries on average, or a quarter
//! of the cell's, is not kept: its primitives are about as large as the cell (SPD's mount
//! seen from its lights, where splitting left the tests per ray as they were). Only then are
//! the kept splits' sub-cells counted and filed.
//!
//! # Why no blocker is missed
//! A sub-grid's cell map is the face grid's map ([`Grid::cell`]): monotone in the face
//! coordinate and clamped. A footprint covering a query's coordinate is filed in the query's
//! top cell (the face grid's argument); there it is filed again in every sub-cell from the
//! sub-cell of its low end to that of its high end, and by monotony the query's sub-cell lies
//! between them. Where the sub-grid's range, computed in `f32`, misses the top cell's exact
//! range by a rounding, the clamping puts those coordinates in an edge sub-cell; that costs
//! entries, never a blocker.
//!
//! [`LightBuffer::peak_bytes`]: super::LightBuffer::peak_bytes

use super::{each_cell, Footprint, Grid, CELL_LIMIT, KEPT};
use alloc::vec;
use alloc::vec::Vec;

/// Sub-cells along each side of a split cell.
pub const SIDE: u32 = 16;

/// Sub-cells of one split cell.
pub const CELLS: usize = (SIDE * SIDE) as usize;

/// At most one split cell per this many primitives.
const PRIMITIVES_PER_SPLIT: usize = 64;

/// A split is kept where its sub-cells would be filed at most this many entries on average.
const SHORT: usize = 16;

/// Cells listing more than this many primitives (and at most [`CELL_LIMIT`]) may be split
/// too, after the crowded ones, longest first.
pub const SPLIT_FROM: usize = 16;

/// At most this many footprints per primitive in the cells considered for splitting (this
/// bounds the planning's time; the filing's is bounded by the kept splits' entries).
const FILED_PER_PRIMITIVE: usize = 4;

/// The split cells of a buffer and what their sub-cells list.
#[derive(Debug, Default)]
pub struct Splits {
    /// The split cells (indices among the faces' cells), ascending.
    pub cells: Vec<u32>,
    /// Each split cell's grid; its `first` is its first sub-cell among all splits' sub-cells.
    pub grids: Vec<Grid>,
    /// Footprints filed per sub-cell, [`CELLS`] per split cell.
    pub counts: Vec<u32>,
    /// The fewest footprints a split cell holds: cells with fewer are not split.
    least: u32,
}

impl Splits {
    /// The most split cells a buffer of `primitives` primitives may have.
    pub fn most(primitives: usize) -> usize {
        primitives / PRIMITIVES_PER_SPLIT + 1
    }

    /// Which split a cell is, if it is one.
    fn find(&self, cell: usize) -> Option<usize> {
        self.cells.binary_search(&(cell as u32)).ok()
    }

    /// Calls `f(sub_cell, index, footprint)` for every sub-cell (numbered from 0 over all
    /// splits) each footprint covers; `counts` are the face cells' footprints, which tell the
    /// crowded cells without a search.
    pub fn each_sub_cell(
        &self,
        faces: &[Option<Grid>; 6],
        footprints: &[Vec<(u32, Footprint)>; 6],
        counts: &[u32],
        mut f: impl FnMut(usize, u32, &Footprint),
    ) {
        each_split(self, faces, footprints, counts, |_, grid, index, print| {
            let [[u0, u1], [v0, v1]] = grid.cells(print);
            for v in v0..=v1 {
                for u in u0..=u1 {
                    f((grid.first + v * SIDE + u) as usize, index, print);
                }
            }
        });
    }
}

/// Chooses the cells to split (see the module documentation) for a buffer sized for
/// `primitives` (the budgets' measure) whose face cells hold `counts` footprints: the crowded
/// cells and, where `long` (a small scene, whose budgets have room), the long ones.
pub fn plan(
    faces: &[Option<Grid>; 6],
    footprints: &[Vec<(u32, Footprint)>; 6],
    counts: &[u32],
    (primitives, long): (usize, bool),
) -> Splits {
    let mut splits = Splits {
        least: u32::MAX,
        ..Splits::default()
    };
    for c in candidates(counts, primitives, long) {
        if let Some(grid) = sub_grid(faces, c as usize, splits.cells.len()) {
            splits.least = splits.least.min(counts[c as usize]);
            splits.cells.push(c);
            splits.grids.push(grid);
        }
    }
    splits.keep_short(faces, footprints, counts, primitives);
    let mut sub = vec![0u32; splits.cells.len() * CELLS];
    splits.each_sub_cell(faces, footprints, counts, |s, _, _| {
        sub[s] = sub[s].saturating_add(1)
    });
    splits.counts = sub;
    splits
}

/// The cells worth splitting, ascending: the crowded ones (over [`CELL_LIMIT`]), least crowded
/// first, then where `long` those over [`SPLIT_FROM`], longest first; at most
/// [`Splits::most`] of them, and only while their footprints stay within
/// [`FILED_PER_PRIMITIVE`] per primitive.
fn candidates(counts: &[u32], primitives: usize, long: bool) -> Vec<u32> {
    let listing = |range: core::ops::RangeInclusive<usize>| {
        (0..counts.len() as u32).filter(move |&c| range.contains(&(counts[c as usize] as usize)))
    };
    let most = Splits::most(primitives);
    let mut cells: Vec<u32> = listing(CELL_LIMIT + 1..=usize::MAX).collect();
    cells.sort_unstable_by_key(|&c| (counts[c as usize], c));
    cells.truncate(most);
    let room = if long { most - cells.len() } else { 0 };
    if room > 0 {
        let mut longer: Vec<u32> = listing(SPLIT_FROM + 1..=CELL_LIMIT).collect();
        let longest_first = |&c: &u32| (core::cmp::Reverse(counts[c as usize]), c);
        if longer.len() > room {
            longer.select_nth_unstable_by_key(room - 1, longest_first);
            longer.truncate(room);
        }
        longer.sort_unstable_by_key(longest_first);
        cells.extend(longer);
    }
    let mut filed = 0usize;
    let within = cells
        .iter()
        .take_while(|&&c| {
            filed += counts[c as usize] as usize;
            filed <= FILED_PER_PRIMITIVE * primitives
        })
        .count();
    cells.truncate(within);
    cells.sort_unstable();
    cells
}

impl Splits {
    /// Keeps, in order, the splits whose sub-cells would be filed at most [`SHORT`] entries
    /// on average, and at most a quarter of the cell's, while all kept splits' filed entries
    /// stay within [`KEPT`] per primitive. Counting a footprint's sub-cells takes one product,
    /// so a split that is not kept costs no filing.
    fn keep_short(
        &mut self,
        faces: &[Option<Grid>; 6],
        footprints: &[Vec<(u32, Footprint)>; 6],
        counts: &[u32],
        primitives: usize,
    ) {
        let mut filed = vec![0usize; self.cells.len()];
        each_split(self, faces, footprints, counts, |k, grid, _, print| {
            let [[u0, u1], [v0, v1]] = grid.cells(print);
            filed[k] += (u1 - u0 + 1) as usize * (v1 - v0 + 1) as usize;
        });
        let mut total = 0usize;
        let mut next = Splits {
            least: self.least,
            ..Splits::default()
        };
        for (k, &n) in filed.iter().enumerate() {
            let listed = counts[self.cells[k] as usize] as usize;
            if n > SHORT.min(listed / 4) * CELLS || total + n > KEPT * primitives {
                continue;
            }
            total += n;
            let grid = Grid {
                first: (next.cells.len() * CELLS) as u32,
                ..self.grids[k]
            };
            next.cells.push(self.cells[k]);
            next.grids.push(grid);
        }
        *self = next;
    }
}

/// Calls `f(k, grid, index, footprint)` for every footprint filed in a split cell, with the
/// split's index and grid and the footprint's primitive.
fn each_split(
    splits: &Splits,
    faces: &[Option<Grid>; 6],
    footprints: &[Vec<(u32, Footprint)>; 6],
    counts: &[u32],
    mut f: impl FnMut(usize, &Grid, u32, &Footprint),
) {
    if splits.cells.is_empty() {
        return;
    }
    each_cell(faces, footprints, |cell, index, print| {
        if counts[cell] < splits.least {
            return;
        }
        if let Some(k) = splits.find(cell) {
            f(k, &splits.grids[k], index, print);
        }
    });
}

/// The grid over face cell `cell`, the `k`-th split: [`SIDE`] sub-cells on each axis of the
/// face grid that has a range there (`None` for a cell on no face).
fn sub_grid(faces: &[Option<Grid>; 6], cell: usize, k: usize) -> Option<Grid> {
    let grid = faces.iter().flatten().find(|g| {
        let first = g.first as usize;
        (first..first + g.side[0] as usize * g.side[1] as usize).contains(&cell)
    })?;
    let at = cell - grid.first as usize;
    let index = [at % grid.side[0] as usize, at / grid.side[0] as usize];
    let mut lo = grid.lo;
    let mut scale = [0.0; 2];
    for a in 0..2 {
        let finer = grid.scale[a] * SIDE as f32;
        if grid.scale[a] > 0.0 && finer.is_finite() {
            lo[a] = grid.lo[a] + index[a] as f32 / grid.scale[a];
            scale[a] = finer;
        }
    }
    Some(Grid {
        lo,
        hi: grid.hi,
        scale,
        side: [SIDE; 2],
        first: (k * CELLS) as u32,
    })
}

#[cfg(test)]
mod tests {
    use super::super::tests::{blockers_listed, bounds_of, listed, point, scatter};
    use super::super::{LightBuffer, SIZED_FOR};
    use crate::math::ray::Ray;
    use crate::scene::mesh::Rng;
    use alloc::vec::Vec;
    use glam::Vec3;

    #[test]
    fn crowded_cells_of_small_primitives_are_split_and_answer() {
        let mut rng = Rng::new(12);
        let light = Vec3::new(0.0, 6.0, 0.0);
        // A spread, and a patch of tiny triangles side by side below the light: far more
        // than the limit in each face cell the patch covers, a few in each sub-cell.
        let mut tris = scatter(&mut rng, 300, 3.0, 0.05);
        let patch = Vec3::new(0.4, 0.0, -0.3);
        let in_patch = |rng: &mut Rng| {
            let (x, y, z) = (
                rng.range(-0.2, 0.2),
                rng.range(-0.01, 0.01),
                rng.range(-0.2, 0.2),
            );
            patch + Vec3::new(x, y, z)
        };
        for _ in 0..800 {
            let c = in_patch(&mut rng);
            tris.push([0; 3].map(|_| c + point(&mut rng, 0.015)));
        }
        let bounds = bounds_of(&tris, &[]);
        let buffer =
            LightBuffer::build(light, &bounds, &tris, &[], SIZED_FOR[1]).expect("a buffer");
        assert!(!buffer.splits.is_empty(), "the patch's cells are split");
        assert!(buffer.bytes() < LightBuffer::peak_bytes(tris.len(), SIZED_FOR[1]));
        let queries = 4000;
        // From below the patch, towards the light through it.
        let (answered, blockers, listed_total) =
            through_points(&buffer, &tris, &mut rng, queries, |rng, _| in_patch(rng));
        // Without the splits every one of these queries would walk.
        assert!(
            answered * 10 > queries * 9,
            "{answered} of {queries} answered"
        );
        assert!(blockers > 300, "{blockers} blockers checked");
        // A few listed each, where the patch's face cells hold over a hundred.
        assert!(
            listed_total < 24 * answered,
            "{listed_total} listed in {answered}"
        );
    }

    /// A face cell of more than [`SPLIT_FROM`] small primitives, though within the limit, is
    /// split too: queries through it test a few, not all of them. Eight such cells in a scene
    /// of 252 primitives: the splits' budget counts the 4,096 primitives the buffer is sized
    /// for (its own count would allow four).
    #[test]
    fn long_cells_of_small_primitives_are_split_and_answer() {
        let mut rng = Rng::new(31);
        let light = Vec3::new(0.0, 6.0, 0.0);
        let mut tris = scatter(&mut rng, 60, 3.0, 0.05);
        // The face below the light (depth along −y, `u` = z, `v` = x), gridded as for the
        // spread alone; patches of 24 small triangles at depth 6, each inside one cell.
        let bounds = bounds_of(&tris, &[]);
        let alone = LightBuffer::build(light, &bounds, &tris, &[], SIZED_FOR[0]).expect("a buffer");
        let grid = alone.faces[3].expect("a face below the light");
        let size = grid.scale.map(|s| 6.0 / s);
        let first = [0, 1].map(|a| grid.cell(a, [-0.3f32, 0.4][a] / 6.0));
        let centres: Vec<Vec3> = (0..8u32)
            .map(|k| {
                let cell = [first[0] + 2 * (k % 4), first[1] + 2 * (k / 4)];
                let [u, v] =
                    [0, 1].map(|a| 6.0 * (grid.lo[a] + (cell[a] as f32 + 0.5) / grid.scale[a]));
                Vec3::new(v, 0.0, u)
            })
            .collect();
        let in_patch = |rng: &mut Rng, centre: Vec3| {
            let (z, x) = (0.4 * size[0], 0.4 * size[1]);
            centre + Vec3::new(rng.range(-x, x), rng.range(-0.01, 0.01), rng.range(-z, z))
        };
        let small = 0.1 * size[0].min(size[1]);
        for &centre in &centres {
            for _ in 0..24 {
                let c = in_patch(&mut rng, centre);
                tris.push([0; 3].map(|_| c + point(&mut rng, small)));
            }
        }
        let bounds = bounds_of(&tris, &[]);
        let buffer =
            LightBuffer::build(light, &bounds, &tris, &[], SIZED_FOR[0]).expect("a buffer");
        assert_eq!(
            buffer.faces[3], alone.faces[3],
            "the patches changed the grid"
        );
        assert!(buffer.splits.len() >= 8, "{} splits", buffer.splits.len());
        assert!(buffer.bytes() < LightBuffer::peak_bytes(tris.len(), SIZED_FOR[0]));
        let queries = 4000;
        let (answered, blockers, listed_total) =
            through_points(&buffer, &tris, &mut rng, queries, |rng, q| {
                in_patch(rng, centres[q % centres.len()])
            });
        assert_eq!(answered, queries, "every query is answered from a list");
        assert!(blockers > 300, "{blockers} blockers checked");
        // Unsplit, each query would list its patch's 24.
        assert!(
            listed_total < 8 * answered,
            "{listed_total} listed in {answered}"
        );
    }

    /// `queries` shadow queries towards the buffer's light from beyond `through(rng, q)`: how
    /// many the buffer answered from a list, the blockers found among `tris` (each checked to
    /// be listed), and the entries listed in all.
    fn through_points(
        buffer: &LightBuffer,
        tris: &[[Vec3; 3]],
        rng: &mut Rng,
        queries: usize,
        mut through: impl FnMut(&mut Rng, usize) -> Vec3,
    ) -> (usize, usize, usize) {
        let light = buffer.light;
        let (mut answered, mut blockers, mut listed_total) = (0, 0, 0);
        for q in 0..queries {
            let through = through(rng, q);
            let origin = light + (through - light) * rng.range(1.01, 1.5);
            let ray = Ray::new(origin, light - origin);
            let Some(list) = listed(buffer.candidates(&ray, 1.0)) else {
                continue;
            };
            answered += 1;
            blockers += blockers_listed(&list, &ray, tris);
            listed_total += list.len();
        }
        (answered, blockers, listed_total)
    }
}
