//! Light buffers: for each light, the primitives that may stand between it and a point, looked
//! up by the direction from the light (after Haines and Greenberg's light buffer, 1986).
//!
//! A [`LightBuffer`] is a cube around the light: six faces, each a grid of cells over the part
//! of the face where primitives project. A cell lists every primitive whose projection from the
//! light may cover it, nearest first by depth along the face's axis. A shadow ray from `o`
//! towards the light asks [`LightBuffer::candidates`] for the cell its direction falls in and
//! tests the primitives listed there that may lie before `o`, instead of walking the octree from
//! `o` to the light. A lit point seldom has more than a few such primitives; the walk passes
//! through every cell between the point and the light.
//!
//! # Why no blocker is missed
//! The shadow ray is `o + t·d̃` with `d̃ = fl(L − o)`, so its points are `X = L + e + s·q` with
//! `q = fl(o − L) = −d̃`, `s = 1 − t`, and `e = d̃ − (L − o)` the rounding of `d̃`, the same
//! for every `t` (`|e| ≤ u·|L − o|` per axis). A blocker has `0 < t < 1`, so the point `X − e`
//! of the blocker moved by `−e` lies on the exact segment from `L` in direction `q`, at depth
//! below `|q|` on `q`'s dominant axis. Each primitive is therefore filed by the projection of
//! its points moved by up to `g ≥ |e|` (the guard, from the buffer's reach), with every
//! rounding of the projection bounded ([`crate::math::float::gamma`]); a query whose `|o − L|`
//! could make `e` larger than `g` walks the octree instead. Cells are found by a monotone map
//! from the face coordinates, so a value inside a primitive's range lands in one of the cells
//! it was filed in. A face answers only the directions whose depth is at least their other two
//! coordinates (its pyramid), and so do the blocker's points `X − e` on it: a primitive that
//! reaches the light's plane, whose projection is unbounded, is filed by the part of its box
//! inside that pyramid, not over the whole face.
//!
//! Like the octree, the buffer relies on the primitive tests reporting hits on the primitive
//! (or within its reach box, for solids, and within its larger radius and margin of its axis,
//! for a lone cylinder or cone): the triangle test's known `f32` exception for rays grazing a
//! face from far away (see [`crate::accel::octree`]) applies here too.
//!
//! Where a cell lists more than [`CELL_LIMIT`] primitives it may be split: gridded again,
//! finer, over that cell alone (the `split` module), where its primitives are small against
//! it; in a small scene, so may a cell listing fewer but many. A query in a crowded cell that
//! is not split, or in a sub-cell still over the limit, says [`Candidates::Walk`]. A light
//! gets no buffer where over a third of its occupied cells are over the limit (primitives
//! crowd around it, and the walk is as short as a list), or where the buffer would outgrow
//! its budget even with coarse cells.

mod split;

use crate::geom::solid::extent::SolidExtent;
use crate::math::aabb::Aabb;
use crate::math::float::gamma;
use crate::math::lanes::sqrt;
use crate::math::ray::Ray;
use alloc::vec;
use alloc::vec::Vec;
use core::mem::size_of;
use glam::Vec3;
use split::Splits;

/// A cell with more primitives than this sends its queries through the octree walk.
pub const CELL_LIMIT: usize = 64;

/// Cells per primitive projected onto a face (before the budget shrinks them), or per primitive
/// a small scene's buffer is sized for ([`SIZED_FOR`]).
const CELLS_PER_PRIMITIVE: f32 = 8.0;

/// How many grids the build may try, halving the cells per primitive each time to fit its
/// budget: from [`CELLS_PER_PRIMITIVE`] down to 1/256.
const COARSER: usize = 12;

/// The most cells along one side of a face.
const MAX_SIDE: u32 = 1024;

/// The fewest primitives a buffer's cells and kept entries are sized for, finest first: a scene
/// gets the first whose [`LightBuffer::peak_bytes`] fits the memory it is given (a host: 4,096;
/// a board's heap: 1,024 where that fits). A small scene's buffer was as coarse as its few
/// primitives allowed (SPD's balls_2, 92 primitives: 736 cells over six faces, 3.6 tests per
/// shadow ray); sized as for 4,096 instead of 1,024, with its long cells split
/// ([`split::SPLIT_FROM`]), tree_5 traced in 0.86 of the time, tree_8, teapot_4 and teapot_6
/// in 0.95 to 0.96, rings_3 and balls_3 in 0.97 to 0.98 (`docs/performance.md`, thirty-ninth
/// round).
pub const SIZED_FOR: [usize; 2] = [4096, 1024];

/// The number of primitives a buffer over `primitives` is sized for, `least` at least.
fn sized_for(primitives: usize, least: usize) -> usize {
    primitives.max(least)
}

/// How many entries a buffer may keep per primitive, above one per cell.
const KEPT: usize = 8;

/// How many entries filing may make per primitive, above one per cell, before the cells are
/// made coarser (this bounds the build's time: most of these land in cells over the limit).
const FILED: usize = 256;

/// The index of the one entry a cell over [`CELL_LIMIT`] keeps: "walk the octree". No
/// primitive has it (indices are below the number of primitives, itself a `u32`).
const WALK: u32 = u32::MAX;

/// The one entry a split cell keeps is `SPLIT + k`, for its grid `k` in
/// [`LightBuffer::splits`]; primitive indices are below it (the build takes fewer
/// primitives) and split indices far below `WALK − SPLIT`.
const SPLIT: u32 = 1 << 31;

/// True where over a third of the occupied cells are over [`CELL_LIMIT`]: primitives so
/// crowded around the light (SPD's gears and shells: 44 and 73 %) that the octree walk is as
/// short as a list, and the buffer would only add a lookup before most walks (gears_4 traced
/// 1.07× slower with it). The scenes it speeds up have at most 25 % (rings).
fn mostly_walks(counts: &[u32]) -> bool {
    let over = counts.iter().filter(|&&n| n as usize > CELL_LIMIT).count();
    let occupied = counts.iter().filter(|&&n| n > 0).count();
    3 * over > occupied
}

/// The entries a cell of `n` filed primitives keeps.
fn kept_in(n: u32) -> u32 {
    if n as usize > CELL_LIMIT {
        1
    } else {
        n
    }
}

/// One listed primitive: its index and a lower bound of its depth from the light along the
/// face's axis (minus the guard; `-∞` where it reaches the light's plane).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    /// Lower bound of the primitive's depth: no blocker it holds lies nearer the light.
    pub near: f32,
    /// Primitive index (triangles first, then solids, as the octree files them).
    pub index: u32,
}

/// What a shadow query towards the light should test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Candidates<'a> {
    /// Walk the octree: this ray is not one the buffer answers (see [`LightBuffer::candidates`]).
    Walk,
    /// Test the entries with `near < depth`, in order; no other bounded primitive can block.
    List {
        /// The cell's entries, nearest first.
        entries: &'a [Entry],
        /// The query's depth: entries from the first with `near >= depth` on cannot block.
        depth: f32,
    },
}

/// One face's grid: the cells over `[lo, hi]` in `u` and `v` of the face's plane at depth 1.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Grid {
    lo: [f32; 2],
    hi: [f32; 2],
    /// Cells per unit of `u` and `v` (0 where the range is a single value).
    scale: [f32; 2],
    side: [u32; 2],
    /// Index of the face's first cell in [`LightBuffer::starts`].
    first: u32,
}

impl Grid {
    /// The cell holding face coordinate `x` on `axis` (0: `u`, 1: `v`), clamped to the grid.
    /// Monotone in `x`: every step rounds monotonically.
    #[inline]
    fn cell(&self, axis: usize, x: f32) -> u32 {
        let k = (x - self.lo[axis]) * self.scale[axis];
        let last = self.side[axis] - 1;
        if k >= last as f32 {
            last
        } else if k > 0.0 {
            k as u32
        } else {
            0
        }
    }

    /// The cells `[first, last]` along each axis that a footprint covers.
    fn cells(&self, f: &Footprint) -> [[u32; 2]; 2] {
        [0, 1].map(|a| [self.cell(a, f.lo[a]), self.cell(a, f.hi[a])])
    }
}

/// Where a primitive projects on one face: `[lo, hi]` in `u` and `v`, and its depth bound.
#[derive(Clone, Copy, Debug)]
struct Footprint {
    lo: [f32; 2],
    hi: [f32; 2],
    near: f32,
}

/// The axes of a face: depth axis, the two in-face axes, and the depth sign.
const FACES: [(usize, usize, usize, f32); 6] = [
    (0, 1, 2, 1.0),
    (0, 1, 2, -1.0),
    (1, 2, 0, 1.0),
    (1, 2, 0, -1.0),
    (2, 0, 1, 1.0),
    (2, 0, 1, -1.0),
];

/// The primitives around one light, by direction (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct LightBuffer {
    light: Vec3,
    /// The largest `|o − L|` on any axis a query may have.
    reach: f32,
    faces: [Option<Grid>; 6],
    /// The split cells' grids, whose `first` is their first sub-cell in `starts` (after the
    /// faces' cells).
    splits: Vec<Grid>,
    /// Per cell, then per sub-cell, the start of its entries; one more at the end.
    starts: Vec<u32>,
    entries: Vec<Entry>,
}

impl LightBuffer {
    /// Files `triangles` (indices `0..`) and the bounded solids (indices from
    /// `triangles.len()`: each by its reach box, [`SolidExtent::reach`], a slanted lone cylinder
    /// or cone by the hull of the cubes around its caps' centres grown by its radius) around the
    /// light at `light`, for queries from points within `bounds`
    /// (the box around every bounded primitive) or twice as far, its cells and budgets sized
    /// for `least` primitives at least ([`SIZED_FOR`]). `None` where there is nothing to
    /// file, a coordinate overflows, most occupied cells would be over [`CELL_LIMIT`], or the
    /// buffer would exceed its budget even at a coarse resolution.
    pub fn build(
        light: Vec3,
        bounds: &Aabb,
        triangles: &[[Vec3; 3]],
        solids: &[SolidExtent],
        least: usize,
    ) -> Option<LightBuffer> {
        if bounds.is_empty() || triangles.len() + solids.len() >= SPLIT as usize {
            return None;
        }
        let reach = 2.0
            * (bounds.max - light)
                .abs()
                .max((bounds.min - light).abs())
                .max_element();
        let guard = gamma(2) * reach;
        if !guard.is_finite() {
            return None;
        }
        let shapes = Shapes { triangles, solids };
        let footprints = shapes.footprints(light, guard);
        let sized = sized_for(shapes.len(), least);
        let (kept_budget, filed_budget) = (KEPT * sized, FILED * shapes.len());
        let mut density = CELLS_PER_PRIMITIVE * sized as f32 / shapes.len() as f32;
        for _ in 0..COARSER {
            let mut faces: [Option<Grid>; 6] =
                core::array::from_fn(|f| grid_over(&footprints[f], density));
            let (cells, filed) = count(&mut faces, &footprints);
            if filed <= filed_budget + cells {
                let mut counts = vec![0u32; cells];
                each_cell(&faces, &footprints, |cell, _, _| {
                    counts[cell] = counts[cell].saturating_add(1)
                });
                if mostly_walks(&counts) {
                    return None;
                }
                let kept: usize = counts.iter().map(|&n| kept_in(n) as usize).sum();
                if kept <= kept_budget + cells {
                    let long = shapes.len() < sized;
                    let splits = split::plan(&faces, &footprints, &counts, (sized, long));
                    let mut buffer = LightBuffer {
                        light,
                        reach,
                        faces,
                        splits: Vec::new(),
                        starts: Vec::new(),
                        entries: Vec::new(),
                    };
                    buffer.fill(&footprints, counts, splits);
                    return Some(buffer);
                }
            }
            // Half as many cells, not a quarter: where 8 per primitive is over budget, 4 may
            // fit (SPD's balls and mount), where a quarter fell back to 2.
            density *= 0.5;
        }
        None
    }

    /// Files every footprint in its cells (`counts` per cell) and the split cells' sub-cells,
    /// and sorts each cell nearest first (ties by index). A split cell keeps only its
    /// [`SPLIT`] mark, another cell or sub-cell over [`CELL_LIMIT`] only the [`WALK`] mark.
    fn fill(
        &mut self,
        footprints: &[Vec<(u32, Footprint)>; 6],
        mut counts: Vec<u32>,
        splits: Splits,
    ) {
        let cells = counts.len();
        // A split cell keeps one entry and files none, as a crowded one: a long one (within
        // the limit) counts as crowded from here on.
        for &cell in &splits.cells {
            counts[cell as usize] = u32::MAX;
        }
        let mut starts = Vec::with_capacity(cells + splits.counts.len() + 1);
        let mut start = 0u32;
        for &n in counts.iter().chain(&splits.counts) {
            starts.push(start);
            start += kept_in(n);
        }
        starts.push(start);
        let mark = |index| Entry {
            near: f32::NEG_INFINITY,
            index,
        };
        self.entries = vec![mark(WALK); start as usize];
        for (k, &cell) in splits.cells.iter().enumerate() {
            self.entries[starts[cell as usize] as usize] = mark(SPLIT + k as u32);
        }
        let mut next = starts.clone();
        let entries = &mut self.entries;
        let mut file = |cell: usize, n: u32, index, print: &Footprint| {
            if n as usize <= CELL_LIMIT {
                let near = print.near;
                entries[next[cell] as usize] = Entry { near, index };
                next[cell] += 1;
            }
        };
        each_cell(&self.faces, footprints, |cell, index, print| {
            file(cell, counts[cell], index, print)
        });
        splits.each_sub_cell(&self.faces, footprints, &counts, |sub, index, print| {
            file(cells + sub, splits.counts[sub], index, print)
        });
        self.splits = splits.grids;
        for grid in &mut self.splits {
            grid.first += cells as u32;
        }
        for w in starts.windows(2) {
            self.entries[w[0] as usize..w[1] as usize]
                .sort_unstable_by(|a, b| a.near.total_cmp(&b.near).then(a.index.cmp(&b.index)));
        }
        self.starts = starts;
    }

    /// The primitives a shadow ray may meet, or [`Candidates::Walk`] where the buffer cannot
    /// say: a ray that does not end at this light (`ray.dir` must be `light − ray.origin` as
    /// `f32` computes it), `t_max` above 1, an origin beyond the buffer's reach or at the light,
    /// or a cell over [`CELL_LIMIT`] that is not split, or a split cell's sub-cell over it.
    #[inline]
    pub fn candidates(&self, ray: &Ray, t_max: f32) -> Candidates<'_> {
        let q = ray.origin - self.light;
        let a = q.abs();
        let answerable = t_max <= 1.0 && ray.dir == -q && a.max_element() <= self.reach;
        if !answerable {
            return Candidates::Walk;
        }
        let axis = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let depth = a[axis];
        if depth == 0.0 {
            return Candidates::Walk;
        }
        let face = 2 * axis + usize::from(q[axis] < 0.0);
        let none = Candidates::List {
            entries: &[],
            depth,
        };
        let Some(grid) = &self.faces[face] else {
            return none;
        };
        let (_, b, c, _) = FACES[face];
        let uv = [q[b] / depth, q[c] / depth];
        if (0..2).any(|k| !(uv[k] >= grid.lo[k] && uv[k] <= grid.hi[k])) {
            return none;
        }
        let mut entries = self.entries_in(grid, uv);
        if let Some(mark) = entries.first().filter(|e| e.index >= SPLIT) {
            if mark.index == WALK {
                return Candidates::Walk;
            }
            entries = self.entries_in(&self.splits[(mark.index - SPLIT) as usize], uv);
            if entries.first().is_some_and(|e| e.index == WALK) {
                return Candidates::Walk;
            }
        }
        Candidates::List { entries, depth }
    }

    /// The entries of `grid`'s cell (a face's or a split cell's) at face coordinates `uv`.
    #[inline(always)]
    fn entries_in(&self, grid: &Grid, uv: [f32; 2]) -> &[Entry] {
        let cell = (grid.first + grid.cell(1, uv[1]) * grid.side[0] + grid.cell(0, uv[0])) as usize;
        &self.entries[self.starts[cell] as usize..self.starts[cell + 1] as usize]
    }

    /// Bytes the buffer holds: its cells' starts, its entries and its split cells' grids.
    pub fn bytes(&self) -> u64 {
        (self.starts.len() * size_of::<u32>()
            + self.entries.len() * size_of::<Entry>()
            + self.splits.len() * size_of::<Grid>()) as u64
    }

    /// An upper bound of the heap [`LightBuffer::build`] may use at once for `primitives`
    /// primitives sized for `least` at least, what it keeps included: every primitive's
    /// footprints on all six faces (in vectors of at most twice their length, or 4); the cells
    /// (at most [`CELLS_PER_PRIMITIVE`] per primitive sized for, plus the rounding up of
    /// [`MAX_SIDE`]-bounded sides on each face) and the split cells' sub-cells, each counted,
    /// started and filled in `u32` arrays, with the lists of cells to split and a second count
    /// of the sub-cells; the split cells, their grids and their filed entries,
    /// twice; and the kept entries within their budgets.
    pub fn peak_bytes(primitives: usize, least: usize) -> u64 {
        let n = primitives as u64;
        let sized = sized_for(primitives, least) as u64;
        let footprints = 6 * (2 * n + 4) * size_of::<(u32, Footprint)>() as u64;
        let cells = 6 * (CELLS_PER_PRIMITIVE as u64 * sized + 2 * u64::from(MAX_SIDE) + 1);
        let splits = Splits::most(sized as usize) as u64;
        let sub_cells = splits * split::CELLS as u64;
        let kept = 2 * KEPT as u64 * sized + cells + sub_cells;
        let split_cells =
            2 * splits * (size_of::<Grid>() + size_of::<u32>() + size_of::<usize>()) as u64;
        footprints
            + 4 * (cells + sub_cells + 1) * size_of::<u32>() as u64
            + split_cells
            + kept * size_of::<Entry>() as u64
    }

    /// Cells over all faces and the split cells' sub-cells, and the entries filed in them.
    pub fn size(&self) -> (usize, usize) {
        (self.starts.len().saturating_sub(1), self.entries.len())
    }
}

/// Calls `f(cell, index, footprint)` for every cell each footprint covers.
fn each_cell(
    faces: &[Option<Grid>; 6],
    footprints: &[Vec<(u32, Footprint)>; 6],
    mut f: impl FnMut(usize, u32, &Footprint),
) {
    for (grid, prints) in faces.iter().zip(footprints) {
        let Some(grid) = grid else { continue };
        for (index, print) in prints {
            let [[u0, u1], [v0, v1]] = grid.cells(print);
            for v in v0..=v1 {
                for u in u0..=u1 {
                    f((grid.first + v * grid.side[0] + u) as usize, *index, print);
                }
            }
        }
    }
}

/// The primitives a buffer files: triangles by their corners, solids by their reach boxes'
/// corners, a slanted lone cylinder or cone by its axis' hull ([`axis_hull`]).
struct Shapes<'a> {
    triangles: &'a [[Vec3; 3]],
    solids: &'a [SolidExtent],
}

impl Shapes<'_> {
    fn len(&self) -> usize {
        self.triangles.len() + self.solids.len()
    }

    /// Every primitive's footprints on the six faces of the light at `light`.
    fn footprints(&self, light: Vec3, guard: f32) -> [Vec<(u32, Footprint)>; 6] {
        let mut faces: [Vec<(u32, Footprint)>; 6] = Default::default();
        let mut file = |i: usize, points: &[Vec3]| {
            for (f, prints) in faces.iter_mut().enumerate() {
                if let Some(print) = footprint(points, light, f, guard) {
                    prints.push((i as u32, print));
                }
            }
        };
        for (i, t) in self.triangles.iter().enumerate() {
            file(i, t);
        }
        for (j, solid) in self.solids.iter().enumerate() {
            let i = self.triangles.len() + j;
            if let Some(hull) = axis_hull(solid) {
                file(i, &hull);
            } else if let Some(reach) = solid.reach() {
                file(i, &corners(&reach));
            }
        }
        faces
    }
}

/// For a lone cylinder or cone whose axis is slanted, points whose hull holds it: the corners of
/// the cubes of half side its larger radius plus its margin around its caps' centres (every
/// point of it lies within its radius of a point of its axis). `None` for another solid, and
/// for an axis along a coordinate axis, whose reach box is as tight.
fn axis_hull(solid: &SolidExtent) -> Option<[Vec3; 16]> {
    let SolidExtent::Cone {
        a,
        b,
        radius,
        margin,
        ..
    } = *solid
    else {
        return None;
    };
    let r = Vec3::splat(radius + margin);
    if (b - a).abs().cmpgt(r).bitmask().count_ones() < 2 {
        return None;
    }
    let cube = |c: Vec3| {
        corners(&Aabb {
            min: c - r,
            max: c + r,
        })
    };
    let (at_a, at_b) = (cube(a), cube(b));
    Some(core::array::from_fn(|k| {
        if k < 8 {
            at_a[k]
        } else {
            at_b[k - 8]
        }
    }))
}

/// The eight corners of a box.
fn corners(b: &Aabb) -> [Vec3; 8] {
    core::array::from_fn(|k| {
        let pick = |bit: usize, lo: f32, hi: f32| if k & bit == 0 { lo } else { hi };
        Vec3::new(
            pick(1, b.min.x, b.max.x),
            pick(2, b.min.y, b.max.y),
            pick(4, b.min.z, b.max.z),
        )
    })
}

/// Where the convex hull of `points`, each moved by up to `guard` per axis, projects from
/// `light` onto face `f` (clamped to the face's square `[−1, 1]²`), or `None` if it lies
/// behind the face or outside its square.
fn footprint(points: &[Vec3], light: Vec3, f: usize, guard: f32) -> Option<Footprint> {
    let (a, b, c, sign) = FACES[f];
    let rel = points.iter().map(|&p| p - light);
    let depths = rel.clone().map(|r| sign * r[a]);
    let (w_min, w_max) = depths.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), w| {
        (lo.min(w), hi.max(w))
    });
    // Entirely behind the face's plane, even moved by the guard (each depth is within one
    // rounding of the exact one).
    if w_max * (1.0 - gamma(1)) + guard < 0.0 {
        return None;
    }
    let whole = Footprint {
        lo: [-1.0; 2],
        hi: [1.0; 2],
        near: f32::NEG_INFINITY,
    };
    // Reaching the light's plane: its projection is unbounded, but only the part the face
    // sees is filed.
    let clear = w_min > 4.0 * guard;
    if !clear {
        return seen_part(rel, f, guard).map(|p| p.unwrap_or(whole));
    }
    let mut lo = [f32::INFINITY; 2];
    let mut hi = [f32::NEG_INFINITY; 2];
    for r in rel {
        let w = sign * r[a];
        for (k, axis) in [b, c].into_iter().enumerate() {
            let x = r[axis] / w;
            lo[k] = lo[k].min(x);
            hi[k] = hi[k].max(x);
        }
    }
    let big = lo.iter().chain(&hi).fold(1.0f32, |m, x| m.max(x.abs()));
    if !big.is_finite() {
        return Some(whole);
    }
    // Moving a point by `guard` on each axis moves `x / w` by at most
    // `guard · (1 + |x / w|) / (w − guard)`, and `w − guard > w / 2` here; the projection and
    // the query's own division round by at most `gamma(4) · |x / w|`.
    let margin = 2.0 * guard * (1.0 + big) / w_min * (1.0 + gamma(4)) + gamma(6) * big;
    for k in 0..2 {
        lo[k] = (lo[k] - margin).max(-1.0);
        hi[k] = (hi[k] + margin).min(1.0);
        if lo[k] > hi[k] {
            return None;
        }
    }
    Some(Footprint {
        lo,
        hi,
        near: w_min * (1.0 - gamma(2)) - guard,
    })
}

/// The footprint on face `f` of a primitive that reaches the light's plane (`rel`: its points
/// relative to the light), from the part of it the face sees: a shadow query reads this face
/// only for directions whose depth is at least their other two coordinates, so a point it
/// files lies no nearer the light in depth than the primitive's gap from the light along those
/// axes. A layer of primitives through the light's plane, off to the side (a lattice row
/// pointing at the light), is thus not filed over the whole face. `None` where no part of it
/// is seen, `Some(None)` where the gaps leave no positive depth (the whole face).
fn seen_part(rel: impl Iterator<Item = Vec3>, f: usize, guard: f32) -> Option<Option<Footprint>> {
    let (a, b, c, sign) = FACES[f];
    let (lo, hi) = rel.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), r| {
        (lo.min(r), hi.max(r))
    });
    let (d_lo, d_hi) = widened(lo[a], hi[a], guard);
    let depth_hi = if sign > 0.0 { d_hi } else { -d_lo };
    let across = [b, c].map(|k| widened(lo[k], hi[k], guard));
    let gap = |(l, h): (f32, f32)| l.max(-h).max(0.0);
    let near = gap(across[0]).max(gap(across[1]));
    if near > depth_hi {
        return None;
    }
    if near <= 0.0 {
        return Some(None);
    }
    // `x / w` over `x` in `[l, h]` and the depth `w` in `[near, depth_hi]` is extreme at a
    // corner; the corners' divisions and the query's own round by at most `gamma(2)·|x / w|`,
    // and a query in this face has `|x / w| <= 1` (the ends beyond are clamped).
    let mut print = Footprint {
        lo: [-1.0; 2],
        hi: [1.0; 2],
        near,
    };
    for (k, (l, h)) in across.into_iter().enumerate() {
        let ends = [l / near, l / depth_hi, h / near, h / depth_hi];
        let (x_lo, x_hi) = ends
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(m, n), &x| {
                (m.min(x), n.max(x))
            });
        let margin = gamma(2) * x_lo.abs().max(x_hi.abs()).min(1.0);
        print.lo[k] = (x_lo - margin).max(-1.0);
        print.hi[k] = (x_hi + margin).min(1.0);
        if print.lo[k] > print.hi[k] {
            return None;
        }
    }
    Some(Some(print))
}

/// Bounds of the exact coordinates of a primitive's points moved by up to `guard`, where their
/// computed values (each one rounding of `p − light`) span `[lo, hi]`: widened by twice the
/// rounding and the guard, which covers the widening's own roundings.
fn widened(lo: f32, hi: f32, guard: f32) -> (f32, f32) {
    let out = |x: f32| 2.0 * (x.abs() * gamma(2) + guard);
    (lo - out(lo), hi + out(hi))
}

/// The grid over a face's footprints with about `density` cells per footprint, or `None` if
/// nothing projects there.
fn grid_over(prints: &[(u32, Footprint)], density: f32) -> Option<Grid> {
    let (lo, hi) = prints.iter().fold(
        ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]),
        |(lo, hi), (_, p)| {
            (
                [lo[0].min(p.lo[0]), lo[1].min(p.lo[1])],
                [hi[0].max(p.hi[0]), hi[1].max(p.hi[1])],
            )
        },
    );
    if prints.is_empty() {
        return None;
    }
    let cells = (prints.len() as f32 * density).max(1.0);
    let extent = [hi[0] - lo[0], hi[1] - lo[1]];
    let aspect = if extent[1] > 0.0 && extent[0] > 0.0 {
        extent[0] / extent[1]
    } else {
        1.0
    };
    let nu = libm::ceilf(sqrt(cells * aspect));
    let nv = libm::ceilf(cells / nu.max(1.0));
    let side = [nu, nv].map(|n| (n as u32).clamp(1, MAX_SIDE));
    let scale = [0, 1].map(|k| {
        if extent[k] > 0.0 && side[k] > 1 {
            side[k] as f32 / extent[k]
        } else {
            0.0
        }
    });
    Some(Grid {
        lo,
        hi,
        scale,
        side,
        first: 0,
    })
}

/// Numbers the faces' cells one after another; returns the cells and the entries filing
/// would make.
fn count(faces: &mut [Option<Grid>; 6], footprints: &[Vec<(u32, Footprint)>; 6]) -> (usize, usize) {
    let mut cells = 0usize;
    let mut filed = 0usize;
    for (grid, prints) in faces.iter_mut().zip(footprints) {
        let Some(grid) = grid else { continue };
        grid.first = cells as u32;
        for (_, p) in prints {
            let [[u0, u1], [v0, v1]] = grid.cells(p);
            filed += (u1 - u0 + 1) as usize * (v1 - v0 + 1) as usize;
        }
        cells += grid.side[0] as usize * grid.side[1] as usize;
    }
    (cells, filed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::solid::extent::reject_margin;
    use crate::geom::triangle::{intersect, RayFrame};
    use crate::math::norm::Norm;
    use crate::scene::mesh::Rng;

    pub(super) fn point(rng: &mut Rng, r: f32) -> Vec3 {
        Vec3::new(rng.range(-r, r), rng.range(-r, r), rng.range(-r, r))
    }

    /// `n` triangles of corners within `size` of centres within `spread` of the origin.
    pub(super) fn scatter(rng: &mut Rng, n: usize, spread: f32, size: f32) -> Vec<[Vec3; 3]> {
        (0..n)
            .map(|_| {
                let c = point(rng, spread);
                [0; 3].map(|_| c + point(rng, size))
            })
            .collect()
    }

    /// The box around the triangles and boxes, as the scene hands it to the build.
    pub(super) fn bounds_of(tris: &[[Vec3; 3]], boxes: &[Option<Aabb>]) -> Aabb {
        let mut bounds = Aabb::EMPTY;
        tris.iter().flatten().for_each(|&p| bounds.add_point(p));
        boxes.iter().flatten().for_each(|b| {
            bounds.add_point(b.min);
            bounds.add_point(b.max);
        });
        bounds
    }

    /// Small and large triangles, some of them through the light or with a corner on it.
    fn soup(rng: &mut Rng, light: Vec3) -> Vec<[Vec3; 3]> {
        let mut tris: Vec<[Vec3; 3]> = (0..400)
            .map(|k| {
                let c = point(rng, 2.0);
                let size = if k % 10 == 0 { 1.5 } else { 0.2 };
                [0; 3].map(|_| c + point(rng, size))
            })
            .collect();
        // One with a corner on the light, one whose plane holds it, one around it.
        tris.push([light, light + Vec3::X, light + Vec3::Y]);
        tris.push([
            light + Vec3::X,
            light - Vec3::X + Vec3::Z,
            light + Vec3::Z * 2.0,
        ]);
        tris.push([
            light + Vec3::new(-1.0, -1.0, 0.3),
            light + Vec3::new(1.0, -1.0, 0.3),
            light + Vec3::new(0.0, 1.0, 0.3),
        ]);
        tris
    }

    /// Thin cones and cylinders at random slants around the origin (as SPD's rings and trees
    /// have), as the octree files them; bottom radius `r0`, top `r1` along the axis `a`–`b`.
    fn cones(rng: &mut Rng, n: usize) -> Vec<(SolidExtent, [Vec3; 2], [f32; 2])> {
        (0..n)
            .map(|k| {
                let a = point(rng, 2.0);
                let b = a + point(rng, 1.0);
                let (r0, r1) = (rng.range(0.01, 0.05), if k % 3 == 0 { 0.0 } else { 0.03 });
                let r = Vec3::splat(r0.max(r1));
                let bounds = Aabb {
                    min: a.min(b) - r,
                    max: a.max(b) + r,
                };
                let extent = SolidExtent::Cone {
                    bounds,
                    a,
                    b,
                    radius: r0.max(r1),
                    margin: reject_margin(&bounds),
                };
                (extent, [a, b], [r0, r1])
            })
            .collect()
    }

    #[test]
    fn every_cone_is_listed_where_it_blocks() {
        let mut rng = Rng::new(11);
        let (mut answered, mut listed_cones, mut listed_boxes) = (0, 0, 0);
        for light in [Vec3::new(0.2, 0.1, 0.0), Vec3::new(6.0, -5.0, 9.0)] {
            let cones = cones(&mut rng, 60);
            let solids: Vec<SolidExtent> = cones.iter().map(|c| c.0).collect();
            let boxes: Vec<SolidExtent> = solids
                .iter()
                .map(|e| e.reach().map_or(SolidExtent::Unbounded, SolidExtent::Box))
                .collect();
            let bounds = bounds_of(
                &[],
                &solids.iter().map(SolidExtent::bounds).collect::<Vec<_>>(),
            );
            let buffer =
                LightBuffer::build(light, &bounds, &[], &solids, SIZED_FOR[0]).expect("a buffer");
            let by_boxes =
                LightBuffer::build(light, &bounds, &[], &boxes, SIZED_FOR[0]).expect("a buffer");
            for k in 0..20_000 {
                // A point on a cone's side or cap, and a shadow ray from just beyond it.
                let (j, (_, [a, b], [r0, r1])) = (k % cones.len(), cones[k % cones.len()]);
                let axis = (b - a).unit();
                let (u, v) = axis.any_orthonormal_pair();
                let (t, angle) = (rng.next_f32(), rng.range(0.0, core::f32::consts::TAU));
                let radius = (r0 + (r1 - r0) * t) * if k % 5 == 0 { rng.next_f32() } else { 1.0 };
                let on = a + (b - a) * t + (u * libm::cosf(angle) + v * libm::sinf(angle)) * radius;
                let origin = light + (on - light) * rng.range(1.001, 1.3);
                let ray = Ray::new(origin, light - origin);
                let Some(list) = listed(buffer.candidates(&ray, 1.0)) else {
                    continue;
                };
                answered += 1;
                assert!(
                    list.contains(&(j as u32)),
                    "light {light}, ray {ray:?}: cone {j} not listed"
                );
                // Compared where both buffers answer.
                if let Some(by_box) = listed(by_boxes.candidates(&ray, 1.0)) {
                    listed_cones += list.len();
                    listed_boxes += by_box.len();
                }
            }
        }
        assert!(answered > 20_000, "{answered} answered");
        // Filed by their axes, fewer cones are listed than by their boxes.
        assert!(
            listed_cones * 20 < listed_boxes * 19,
            "{listed_cones} listed, by boxes {listed_boxes}"
        );
    }

    /// How many of `tris` block the shadow ray `ray` (towards the light, `t` below 1);
    /// panics where one of them is not in `list`.
    pub(super) fn blockers_listed(list: &[u32], ray: &Ray, tris: &[[Vec3; 3]]) -> usize {
        let frame = RayFrame::new(ray);
        let mut blockers = 0;
        for (i, t) in tris.iter().enumerate() {
            if intersect(&frame, t, 1.0).is_some_and(|h| h.t + h.t_error < 1.0) {
                blockers += 1;
                assert!(
                    list.contains(&(i as u32)),
                    "ray {ray:?}: triangle {i} blocks, not listed"
                );
            }
        }
        blockers
    }

    /// The entries a listed query tests.
    pub(super) fn listed(c: Candidates<'_>) -> Option<Vec<u32>> {
        match c {
            Candidates::Walk => None,
            Candidates::List { entries, depth } => Some(
                entries
                    .iter()
                    .take_while(|e| e.near < depth)
                    .map(|e| e.index)
                    .collect(),
            ),
        }
    }

    #[test]
    fn every_blocker_is_listed() {
        let mut rng = Rng::new(5);
        let (mut answered, mut queries, mut blockers, mut corners) = (0, 0, 0, 0);
        let lights = [
            Vec3::new(0.3, 0.2, -0.1),
            Vec3::new(9.0, 7.0, -12.0),
            Vec3::new(-2.0, 0.0, 0.0),
            Vec3::new(0.0, 40.0, 0.0),
        ];
        for light in lights {
            let tris = soup(&mut rng, light);
            let boxes: Vec<Option<Aabb>> = (0..40)
                .map(|k| {
                    (k % 5 != 0).then(|| {
                        let c = point(&mut rng, 2.0);
                        Aabb {
                            min: c - Vec3::splat(0.1),
                            max: c + point(&mut rng, 0.3).abs() + Vec3::splat(0.01),
                        }
                    })
                })
                .collect();
            let bounds = bounds_of(&tris, &boxes);
            let solids: Vec<SolidExtent> = boxes
                .iter()
                .map(|b| b.map_or(SolidExtent::Unbounded, SolidExtent::Box))
                .collect();
            let buffer =
                LightBuffer::build(light, &bounds, &tris, &solids, SIZED_FOR[0]).expect("a buffer");
            // Through every corner, seen from the light: among them the corners that bound
            // the grids, where only the margins keep a ray's rounded direction inside.
            for (i, v) in tris.iter().enumerate().flat_map(|(i, t)| t.map(|v| (i, v))) {
                let origin = light + (v - light) * rng.range(1.0001, 1.1);
                let ray = Ray::new(origin, light - origin);
                let hit = intersect(&RayFrame::new(&ray), &tris[i], 1.0);
                if let (Some(list), Some(h)) = (listed(buffer.candidates(&ray, 1.0)), hit) {
                    if h.t + h.t_error < 1.0 {
                        corners += 1;
                        assert!(
                            list.contains(&(i as u32)),
                            "light {light}, ray {ray:?}: corner of {i} not listed"
                        );
                    }
                }
            }
            for k in 0..6000 {
                // Origins in the cloud, on its triangles, next to the light, and beyond the
                // boxes (so that the ray towards the light crosses them).
                let origin = match k % 4 {
                    0 if k % 8 == 0 => point(&mut rng, 2.5),
                    0 => {
                        // Beyond a corner or an edge of a triangle, seen from the light: rays
                        // along the edges of its projection.
                        let t = tris[rng.next_u64() as usize % tris.len()];
                        let (i, a) = (rng.next_u64() as usize % 3, rng.next_f32());
                        let edge = if k % 16 == 4 {
                            t[i]
                        } else {
                            t[i].lerp(t[(i + 1) % 3], a)
                        };
                        light + (edge - light) * rng.range(1.001, 1.5)
                    }
                    1 => {
                        let t = tris[rng.next_u64() as usize % tris.len()];
                        rng.point_in_triangle(&t)
                    }
                    2 => light + point(&mut rng, 1e-3) * rng.next_f32().powi(8),
                    _ => {
                        let Some(b) = boxes[k / 4 % boxes.len()] else {
                            continue;
                        };
                        let inside = b.min
                            + (b.max - b.min)
                                * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                        light + (inside - light) * rng.range(1.01, 1.5)
                    }
                };
                let ray = Ray::new(origin, light - origin);
                queries += 1;
                let Some(list) = listed(buffer.candidates(&ray, 1.0)) else {
                    continue;
                };
                answered += 1;
                blockers += blockers_listed(&list, &ray, &tris);
                if k % 4 == 3 {
                    let j = k / 4 % boxes.len();
                    blockers += 1;
                    let i = (tris.len() + j) as u32;
                    assert!(
                        list.contains(&i),
                        "light {light}, ray {ray:?}: box {j} on the ray, not listed"
                    );
                }
            }
        }
        // The buffer answers most queries (not all walks), and the checks meet real blockers.
        assert!(answered * 2 > queries, "{answered} of {queries} answered");
        assert!(blockers > 5000, "{blockers} blockers checked");
        assert!(corners > 300, "{corners} rays through corners checked");
    }

    #[test]
    fn rays_it_cannot_answer_walk() {
        let mut rng = Rng::new(8);
        let light = Vec3::new(0.0, 5.0, 0.0);
        // A crowd of tiny triangles in one spot, and a spread of others.
        let mut tris = scatter(&mut rng, 300, 2.0, 0.05);
        let spot = Vec3::new(0.5, 0.0, 0.5);
        tris.extend((0..200).map(|_| [0; 3].map(|_| spot + point(&mut rng, 0.01))));
        let bounds = bounds_of(&tris, &[]);
        let buffer =
            LightBuffer::build(light, &bounds, &tris, &[], SIZED_FOR[0]).expect("a buffer");
        let o = Vec3::new(0.2, -1.0, 0.3);
        assert!(listed(buffer.candidates(&Ray::new(o, light - o), 1.0)).is_some());
        // Not towards this light; a longer ray; from beyond its reach; from the light.
        assert_eq!(
            buffer.candidates(&Ray::new(o, light - o + Vec3::X * 1e-3), 1.0),
            Candidates::Walk
        );
        assert_eq!(
            buffer.candidates(&Ray::new(o, light - o), 1.5),
            Candidates::Walk
        );
        let far = Vec3::new(0.0, -1e4, 0.0);
        assert_eq!(
            buffer.candidates(&Ray::new(far, light - far), 1.0),
            Candidates::Walk
        );
        assert_eq!(
            buffer.candidates(&Ray::new(light, Vec3::ZERO), 1.0),
            Candidates::Walk
        );
        // Through the crowd: over the limit.
        let below = spot + (spot - light) * 0.5;
        assert_eq!(
            buffer.candidates(&Ray::new(below, light - below), 1.0),
            Candidates::Walk
        );
    }

    #[test]
    fn crowds_around_the_light_get_no_buffer() {
        let mut rng = Rng::new(9);
        let tris = scatter(&mut rng, 2000, 1.0, 0.8);
        let bounds = bounds_of(&tris, &[]);
        assert_eq!(
            LightBuffer::build(Vec3::ZERO, &bounds, &tris, &[], SIZED_FOR[0]),
            None
        );
    }

    /// A scene of few primitives is gridded as one of [`SIZED_FOR`] (a halving for the
    /// budget allowed), not by its own count: 60 triangles got 480 cells at most before.
    #[test]
    fn a_small_scene_is_gridded_as_a_larger_one() {
        let mut rng = Rng::new(12);
        let light = Vec3::new(0.0, 0.0, -8.0);
        let tris = scatter(&mut rng, 60, 2.0, 0.1);
        let bounds = bounds_of(&tris, &[]);
        let buffer =
            LightBuffer::build(light, &bounds, &tris, &[], SIZED_FOR[0]).expect("a buffer");
        let (cells, entries) = buffer.size();
        let own = CELLS_PER_PRIMITIVE as usize * tris.len();
        let floor = CELLS_PER_PRIMITIVE as usize * SIZED_FOR[0] / 2;
        assert!(
            cells >= floor && cells > 4 * own,
            "{cells} cells, {entries} entries"
        );
        assert!(buffer.bytes() < LightBuffer::peak_bytes(tris.len(), SIZED_FOR[0]));
    }

    /// The buffer of `light` over `boxes` (solids by their boxes).
    fn box_buffer(light: Vec3, boxes: &[Aabb]) -> LightBuffer {
        let solids: Vec<SolidExtent> = boxes.iter().map(|&b| SolidExtent::Box(b)).collect();
        let bounds = bounds_of(&[], &boxes.iter().map(|&b| Some(b)).collect::<Vec<_>>());
        LightBuffer::build(light, &bounds, &[], &solids, SIZED_FOR[0]).expect("a buffer")
    }

    /// Whether the buffer answers the shadow ray from `origin` (not a walk); panics where it
    /// does without listing primitive `j`.
    fn answers_listing(buffer: &LightBuffer, origin: Vec3, j: usize) -> bool {
        let ray = Ray::new(origin, buffer.light - origin);
        let Some(list) = listed(buffer.candidates(&ray, 1.0)) else {
            return false;
        };
        assert!(list.contains(&(j as u32)), "ray {ray:?}: {j} not listed");
        true
    }

    /// Directions from the light, on the boundary between two faces.
    const DIAGONALS: [Vec3; 2] = [Vec3::new(-1.0, 1.0, 0.0), Vec3::new(-1.0, 0.0, -1.0)];

    /// A lattice of boxes around `[0, 1]³` (nodes, and bars between neighbours) with rows in
    /// the planes through `light`, as SPD's even-sized lattices have, and boxes straddling those
    /// planes on their diagonals, where a shadow ray's face is decided by a tie.
    fn lattice(light: Vec3) -> Vec<Aabb> {
        let (step, r) = (0.25, Vec3::splat(0.02));
        let node = |i: usize, j: usize, k: usize| Vec3::new(i as f32, j as f32, k as f32) * step;
        let mut boxes = Vec::new();
        for (i, j, k) in
            (0..5).flat_map(|i| (0..5).flat_map(move |j| (0..5).map(move |k| (i, j, k))))
        {
            let p = node(i, j, k);
            boxes.push(Aabb {
                min: p - r,
                max: p + r,
            });
            for q in [node(i + 1, j, k), node(i, j + 1, k), node(i, j, k + 1)] {
                if q.max_element() <= 1.0 {
                    boxes.push(Aabb {
                        min: p - r,
                        max: q + r,
                    });
                }
            }
        }
        for d in DIAGONALS {
            let c = light + d * 0.75;
            boxes.push(Aabb {
                min: c - r,
                max: c + r,
            });
        }
        boxes
    }

    /// Primitives through the light's planes, off to the side, are filed only where a face
    /// sees them: the faces that look along the rows get nothing, and every box on a shadow
    /// ray is listed, the diagonal ones through the face their direction picks.
    #[test]
    fn a_layer_through_the_light_is_filed_where_the_face_sees_it() {
        let mut rng = Rng::new(13);
        let light = Vec3::new(2.0, 0.5, 0.5);
        let boxes = lattice(light);
        let buffer = box_buffer(light, &boxes);
        // The rows' layers reach the planes of ±y and ±z; only the diagonal boxes show there.
        let diagonal = |f: usize| f == 2 || f == 5;
        for (f, grid) in buffer.faces.iter().enumerate() {
            let seen = grid.map(|g| (g.hi[0] - g.lo[0]) * (g.hi[1] - g.lo[1]));
            assert!(
                f == 1 || seen.is_some_and(|area| diagonal(f) && area < 0.1) || seen.is_none(),
                "face {f}: {grid:?}"
            );
        }
        let mut answered = 0;
        for k in 0..20_000 {
            let j = k % boxes.len();
            let b = boxes[j];
            let inside =
                b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            // Exactly along a diagonal for the last boxes (every sum is exact): the ray's face
            // is decided by a tie.
            let diagonal = (j + DIAGONALS.len()).checked_sub(boxes.len());
            let origin = match diagonal {
                Some(d) => light + DIAGONALS[d] * (0.75 * (1.0 + (k % 7) as f32 / 8.0)),
                None => light + (inside - light) * rng.range(1.01, 1.5),
            };
            answered += usize::from(answers_listing(&buffer, origin, j));
        }
        assert!(answered > 19_000, "{answered} answered");
    }

    /// Slabs beside the light that reach its planes are seen by the faces across them only
    /// from their gap to the light on: shadow rays through their nearest seen points, at the
    /// edge of a face's pyramid, list them (the depth bound is not above that gap).
    #[test]
    fn slabs_beside_the_light_are_listed_from_their_gap_on() {
        let mut rng = Rng::new(14);
        let light = Vec3::new(0.3, -0.2, 0.1);
        // (the slab's side of the light, its gap, another axis across)
        let slabs = [
            (Vec3::Y, 0.05, Vec3::X),
            (-Vec3::Z, 0.07, Vec3::Y),
            (Vec3::X, 0.03, Vec3::Z),
        ];
        let boxes: Vec<Aabb> = slabs
            .iter()
            .map(|&(n, gap, _)| {
                let (a, b) = (light + n * gap, light + n * 0.6);
                Aabb {
                    min: a.min(b) - (Vec3::ONE - n.abs()) * 0.5,
                    max: a.max(b) + (Vec3::ONE - n.abs()) * 0.5,
                }
            })
            .collect();
        let buffer = box_buffer(light, &boxes);
        let mut answered = 0;
        for k in 0..30_000 {
            let j = k % slabs.len();
            let (n, gap, across) = slabs[j];
            let side = n.cross(across);
            // Just past the slab's near face, as far along `across` as the gap (the edge of
            // `across`' face), within it sideways.
            let t = gap * rng.range(1.0, 1.04) * if k % 2 == 0 { 1.0 } else { -1.0 };
            let inside = light + n * gap * 1.0001 + across * t + side * rng.range(-gap, gap);
            let origin = light + (inside - light) * rng.range(1.0001, 1.01);
            answered += usize::from(answers_listing(&buffer, origin, j));
        }
        assert!(answered > 25_000, "{answered} answered");
    }

    #[test]
    fn cells_list_nearest_first() {
        let mut rng = Rng::new(10);
        let light = Vec3::new(0.0, 0.0, -8.0);
        let tris = scatter(&mut rng, 500, 2.0, 0.3);
        let bounds = bounds_of(&tris, &[]);
        let buffer =
            LightBuffer::build(light, &bounds, &tris, &[], SIZED_FOR[0]).expect("a buffer");
        let (cells, entries) = buffer.size();
        assert!(
            cells > 100 && entries > cells / 2,
            "{cells} cells, {entries} entries"
        );
        for w in buffer.starts.windows(2) {
            let list = &buffer.entries[w[0] as usize..w[1] as usize];
            assert!(list
                .windows(2)
                .all(|p| (p[0].near, p[0].index) < (p[1].near, p[1].index)));
        }
    }
}
