//! Octree construction: split cells at their centre where the surface area heuristic says it pays,
//! best first, within a memory budget; file each primitive in every child it touches. The root
//! cell is the primitives' box, grown where it is much flatter than a cube ([`root_cell`]).
//!
//! Primitives are the scene's triangles (indices `0..T`) followed by its bounded solids (indices
//! `T..`): a triangle is filed by the exact triangle/box test, a sphere standing alone by where
//! its surface is, a cylinder or cone standing alone by how near its axis passes (and within its
//! reject box), another solid by its reject box (where its test can report a hit: its world
//! box and the test's rounding; `SolidExtent::reach`). A primitive whose box lies on one
//! side of a centre plane, touching it or in it, is filed on that side only (exact comparisons,
//! no margin): its points on the plane belong to that side's closed cells as well, and the walk
//! visits the cells on both sides of every point where a ray meets a centre plane. Without this,
//! meshes on a power-of-two lattice (SPD's tetra) filed every face in up to eight cells.
//!
//! A leaf that may be split is queued at the most its split could gain; when it comes first it
//! is appraised (its children's lists computed, and the split's gain in expected tests per ray
//! per byte it adds becomes its priority) and queued again. An appraised leaf that comes first is
//! split. The build ends at the first split that would take the tree past
//! [`BYTES_PER_PRIMITIVE`], so leaves that would never be split are mostly never appraised; a
//! leaf whose split would not pay (its primitives overlap too much to separate) stays a leaf. The
//! order depends only on the scene, so every machine builds the same tree.

use super::filing::{bits, ChildCells, Filing};
use super::overlap::cell_margin;
use super::queue::Queue;
use super::{child_box, Node, Octree, OctreeParams, OctreeStats, INTERIOR, MAX_DEPTH_LIMIT};
use crate::accel::prefetch::prefetch;
use crate::geom::solid::extent::SolidExtent;
use crate::geom::triangle::unit_normal;
use crate::math::aabb::Aabb;
use alloc::vec::Vec;
use glam::Vec3;

/// The memory the tree may take, in bytes per primitive given to the build (nodes and leaf
/// entries together). Splits are made best first until the next would pass it.
pub const BYTES_PER_PRIMITIVE: usize = 48;

/// The cost of entering a cell, in units of one primitive test (the surface area heuristic's
/// traversal cost).
const CELL_COST: f32 = 1.0;

/// The tests per ray a split of a cell of `n` entries into children of `total` entries saves
/// (surface area heuristic): a ray that enters a cell enters each child with probability 1/4 (a
/// child's surface is a quarter of its parent's), so the split turns `n` tests into
/// [`CELL_COST`] plus a quarter of the children's entries.
fn split_gain(n: usize, total: usize) -> f32 {
    n as f32 - (CELL_COST + total as f32 / 4.0)
}

/// The priority of a split that gains `gain` tests per ray entering a cell at `depth` and adds
/// `bytes`: the gain weighted by the chance of reaching the cell at all (`4^-depth`), per byte.
fn priority(gain: f32, depth: u32, bytes: usize) -> f32 {
    // Dividing by a power of two is exact, so this is `gain · 0.25^depth / bytes` to the bit.
    gain / (1u64 << (2 * depth)) as f32 / bytes as f32
}

/// The queue's key of `node` at `priority` (positive, so its bits order as its value): the
/// priority, then the node's complement, so that of two equal priorities the lower node comes
/// first; below them the leaf's [`Queued`] slot, which orders nothing (nodes differ) but saves a
/// load from the node's record on every pop. One integer comparison orders two keys.
fn queue_key(priority: f32, node: usize, slot: u32) -> u128 {
    let order = u64::from(priority.to_bits()) << 32 | u64::from(!(node as u32));
    u128::from(order) << 64 | u128::from(slot)
}

/// The node and the slot of a [`queue_key`].
fn queue_entry(key: u128) -> (usize, usize) {
    (!((key >> 64) as u32) as usize, key as u32 as usize)
}

/// How many entries ahead of the one appraised [`Builder::split`] asks for a primitive's record
/// ([`Filing::prefetch`]); the leaf's first ones are asked for before the loop. Measured on
/// SPD's mount_8 and the generated scene: 8 and 16 alike, 4 one to three per cent slower.
/// [`Builder::finish`] asks for the leaves' lists as many nodes ahead.
const PREFETCH_AHEAD: usize = 8;

/// Bytes of a node and of a leaf entry.
const NODE_BYTES: usize = core::mem::size_of::<Node>();
const ENTRY_BYTES: usize = core::mem::size_of::<u32>();

struct Builder<'a> {
    /// The primitives and the tests that say which children each is filed in.
    filing: Filing<'a>,
    params: OctreeParams,
    nodes: Vec<Node>,
    /// Per node: its primitives while it is a leaf (`None` once it is split).
    leaves: Vec<Option<Refs>>,
    /// Every primitive list of the build, one after another: the root's, then each appraisal's
    /// children's lists ([`Children`]). A leaf's list is a range of it ([`Refs`]), so a split
    /// copies nothing and no list is allocated or freed on its own; only an appraisal whose
    /// split would not pay gives its lists back (they are the last).
    lists: Vec<u32>,
    /// The leaves in the queue, by slot; a slot is reused once its leaf leaves the queue.
    queued: Vec<Queued>,
    free: Vec<u32>,
    /// Leaves worth splitting, best first: [`queue_key`]s (priority, then the lower node).
    queue: Queue,
    /// The deepest leaf so far.
    depth: u32,
    /// Bytes of the tree as it stands (8 per node, 4 per leaf entry), and the most it may take.
    bytes: usize,
    /// Scratch for [`Builder::split`]: which children each primitive touches.
    masks: Vec<u8>,
    budget: usize,
    /// The most entries `lists` may hold ([`MOST_LISTED`]).
    most_listed: usize,
}

/// A leaf of the tree being built that is queued to be split: its cell and depth and, once
/// appraised, its children's primitive lists. The other leaves keep only their primitives, so a
/// build touches 24 bytes per node for them (a third of the nodes are queued on SPD's mount).
struct Queued {
    cell: Aabb,
    depth: u32,
    children: Option<Children>,
}

/// A leaf's primitives: the range `start..end` of the build's lists ([`Builder::lists`]).
#[derive(Clone, Copy)]
struct Refs {
    start: u32,
    end: u32,
}

impl Refs {
    /// Its entries in `lists`.
    fn get(self, lists: &[u32]) -> &[u32] {
        &lists[self.start as usize..self.end as usize]
    }

    fn len(&self) -> usize {
        (self.end - self.start) as usize
    }
}

/// The primitive lists of a cell's eight children, one after another in the build's lists:
/// child `c`'s are the range `start(c)..ends[c]`, where `start(0)` is `start` and `start(c)`
/// is `ends[c − 1]`. Kept in the leaf's [`Queued`] slot itself.
#[derive(Clone, Copy)]
struct Children {
    start: u32,
    ends: [u32; 8],
}

impl Children {
    /// Child `c`'s list.
    fn refs(&self, c: usize) -> Refs {
        Refs {
            start: if c == 0 { self.start } else { self.ends[c - 1] },
            end: self.ends[c],
        }
    }

    /// Entries over all eight lists.
    fn total(&self) -> usize {
        (self.ends[7] - self.start) as usize
    }

    /// The children that are not empty (bit `c` for child `c`): an interior node's mask of
    /// them ([`Node`]). A child empty when its parent is split stays an empty leaf, since only
    /// a leaf with primitives is split.
    fn occupied(&self) -> u8 {
        (0..8).fold(0, |mask, c| mask | u8::from(self.refs(c).len() > 0) << c)
    }
}

impl Octree {
    /// Builds the octree over `triangles` (vertex positions by triangle index).
    ///
    /// Degenerate (zero-area) triangles are left out: the watertight test never hits them.
    pub fn build(triangles: &[[Vec3; 3]], params: &OctreeParams) -> Octree {
        Self::build_mixed(triangles, &[], params)
    }

    /// Builds the octree over `triangles` (primitives `0..T`) and `solids` (primitives `T..`).
    /// An unbounded solid is not filed.
    pub fn build_mixed(
        triangles: &[[Vec3; 3]],
        solids: &[SolidExtent],
        params: &OctreeParams,
    ) -> Octree {
        Self::build_listing_at_most(triangles, solids, params, MOST_LISTED)
    }

    /// [`Octree::build_mixed`] with its lists ending the build at `most_listed` entries.
    fn build_listing_at_most(
        triangles: &[[Vec3; 3]],
        solids: &[SolidExtent],
        params: &OctreeParams,
        most_listed: usize,
    ) -> Octree {
        let params = OctreeParams {
            max_depth: params.max_depth.min(MAX_DEPTH_LIMIT),
            max_leaf_triangles: params.max_leaf_triangles.max(1),
        };
        let (filed, world, reach) = filed_primitives(triangles, solids);
        let bounds = union(world.iter().copied());
        let filed_count = filed.len() as u32;
        let budget = (BYTES_PER_PRIMITIVE * filed.len()).max(MIN_BUDGET);
        let (filed, large, tree_bounds) = set_apart_large(filed, &world, bounds);
        let root = root_cell(tree_bounds);
        let root_refs = Refs {
            start: 0,
            end: filed.len() as u32,
        };
        let mut lists = Vec::with_capacity(LISTS_RESERVED * (budget / ENTRY_BYTES) + filed.len());
        lists.extend_from_slice(&filed);
        let mut b = Builder {
            filing: Filing {
                triangles,
                reach,
                solids,
                margin: cell_margin(&root),
            },
            params,
            nodes: Vec::with_capacity(most_nodes(budget)),
            leaves: Vec::with_capacity(most_nodes(budget)),
            lists,
            queued: Vec::new(),
            free: Vec::new(),
            queue: Queue::default(),
            depth: 0,
            bytes: 0,
            masks: Vec::new(),
            budget,
            most_listed,
        };
        b.add_leaf(root, 0, root_refs);
        while let Some(key) = b.queue.pop() {
            let (node, slot) = queue_entry(key);
            if let Some(next) = b.queue.peek() {
                b.prefetch_step(next);
            }
            if !b.step(node, slot) {
                break;
            }
            if let Some(next) = b.queue.peek() {
                b.prefetch_lists(next);
            }
        }
        let (nodes, indices, mut stats) = b.finish();
        stats.triangles = (triangles.len() + solids.len()) as u32;
        stats.filed_triangles = filed_count;
        Octree {
            nodes,
            indices,
            bounds,
            root,
            large,
            stats,
        }
    }
}

/// How much longer than its shortest side the root cell may be: a box flatter than this is grown
/// along its short sides (from its lower corner) until it is not.
///
/// Every cell of an octree has its root's shape, so a scene much wider than tall (a small object
/// on a large floor: SPD's tree, 30 : 1, and balls, 18 : 1) would be cut into flat slabs, and a
/// ray through the object crosses one slab per level of height. Growing those roots to 4 : 1
/// cut tracing to 0.65 (tree_8) and 0.59 (balls_4) of its time; growing them all the way to a
/// cube did about as well on those two but made SPD's gears (4 : 1, flat gears on a floor) 1.5×
/// slower, as did growing gears' root to 2 : 1 (`docs/performance.md`, fifth round). The surface
/// area heuristic cannot choose the root's shape: it assumes rays spread evenly over directions,
/// and judged the flat trees cheaper for tree and balls. Since their floors (two triangles) are
/// set apart ([`set_apart_large`]), those roots are not flat any more; the limit still serves a
/// floor of many tiles.
const MAX_ROOT_ASPECT: f32 = 4.0;

/// The root cell around `bounds`: the box itself, grown where it is flatter than
/// [`MAX_ROOT_ASPECT`].
fn root_cell(bounds: Aabb) -> Aabb {
    let shortest = (bounds.max - bounds.min).max_element() / MAX_ROOT_ASPECT;
    Aabb {
        min: bounds.min,
        max: bounds.max.max(bounds.min + Vec3::splat(shortest)),
    }
}

/// The most nodes a tree within `budget` bytes can have (each takes [`NODE_BYTES`] of it, and
/// the split that passes it is not made): the build reserves this many nodes and leaf records at
/// its start, so neither list is copied while it grows. A doubling holds the old and the new list
/// at once: building the room on the emulated board, the leaf records went from 0.7 to 1.4 MB
/// that way, more than the reservation's peak, on a heap of 3.75 MiB.
fn most_nodes(budget: usize) -> usize {
    budget / NODE_BYTES + 1
}

/// The smallest budget in bytes, so that small scenes still get a few levels.
const MIN_BUDGET: usize = 64 * 1024;

/// How many times the entries a tree within its budget can hold the build reserves for its
/// lists ([`Builder::lists`]), which keep every appraisal's lists to the end: a build of SPD's
/// scenes appends 0.7 (tetra_8) to 2.1 (gears_4) times that many, 3.3 on shells_6, where the
/// list grows once; the demo room 1.5. So the list is seldom copied as it grows, and a host
/// does not touch the reserved pages it never fills.
const LISTS_RESERVED: usize = 2;

/// The most entries the build's lists may hold: their ranges ([`Refs`], [`Children`]) and the
/// leaves' places in the laid-out tree ([`Node`]) are `u32`s.
const MOST_LISTED: usize = u32::MAX as usize;

/// The primitives to file (non-degenerate triangles, bounded solids) with their world boxes, and
/// each solid's box as the build files it (where its test can hit; empty if it is unbounded).
fn filed_primitives(
    triangles: &[[Vec3; 3]],
    solids: &[SolidExtent],
) -> (Vec<u32>, Vec<Aabb>, Vec<Aabb>) {
    let mut filed = Vec::with_capacity(triangles.len() + solids.len());
    let mut world = Vec::with_capacity(triangles.len() + solids.len());
    let mut reach = Vec::with_capacity(solids.len());
    for (i, p) in triangles.iter().enumerate() {
        if unit_normal(p).is_some() {
            filed.push(i as u32);
            world.push(Aabb::of_triangle(p));
        }
    }
    for (j, solid) in solids.iter().enumerate() {
        match solid.bounds().zip(solid.reach()) {
            Some((b, r)) => {
                reach.push(r);
                filed.push((triangles.len() + j) as u32);
                world.push(b);
            }
            None => reach.push(Aabb::EMPTY),
        }
    }
    (filed, world, reach)
}

/// The box around `boxes`; a point at the origin if there are none.
fn union(boxes: impl Iterator<Item = Aabb>) -> Aabb {
    let mut u = Aabb::EMPTY;
    for b in boxes {
        u.min = u.min.min(b.min);
        u.max = u.max.max(b.max);
    }
    if u.is_empty() {
        u = Aabb {
            min: Vec3::ZERO,
            max: Vec3::ZERO,
        };
    }
    u
}

/// The most primitives [`set_apart_large`] keeps out of the tree: a floor or a backdrop of a few
/// triangles. A room's walls are more, and stay in it.
const MAX_LARGE: usize = 4;

/// Splits the primitives `filed` (world boxes `world`) into those the tree files and the large
/// ones every query tests before its walk: those whose box spans at least half of `bounds` (the
/// box around all) along two axes, if there are at most [`MAX_LARGE`] of them and others
/// remain. Returns both lists and the box around the tree's.
///
/// A floor under a small object (SPD's tree: a floor 100 wide under a tree 3 tall) is filed in
/// every cell along it and makes the root as wide as itself, so a ray at the object descends
/// five levels of floor cells before it reaches the object's scale. Tested by every query
/// instead, it costs one or two tests per ray, and a closest hit on it bounds the walk.
fn set_apart_large(filed: Vec<u32>, world: &[Aabb], bounds: Aabb) -> (Vec<u32>, Vec<u32>, Aabb) {
    let half = (bounds.max - bounds.min) * 0.5;
    let large = |b: &Aabb| {
        let spans = (b.max - b.min).cmpge(half) & half.cmpgt(Vec3::ZERO);
        spans.bitmask().count_ones() >= 2
    };
    let count = world.iter().filter(|b| large(b)).count();
    if count == 0 || count > MAX_LARGE || count == filed.len() {
        return (filed, Vec::new(), bounds);
    }
    let (mut tree, mut apart) = (Vec::with_capacity(filed.len() - count), Vec::new());
    for (&i, b) in filed.iter().zip(world) {
        if large(b) {
            apart.push(i);
        } else {
            tree.push(i);
        }
    }
    let tree_bounds = union(world.iter().copied().filter(|b| !large(b)));
    (tree, apart, tree_bounds)
}

impl Builder<'_> {
    /// Appends a leaf over `refs` and queues it, at the most its split could be worth, if it may
    /// be split at all.
    fn add_leaf(&mut self, cell: Aabb, depth: u32, refs: Refs) {
        let node = self.nodes.len();
        let n = refs.len();
        self.bytes += NODE_BYTES + ENTRY_BYTES * n;
        self.nodes.push(Node { first: 0, count: 0 });
        self.leaves.push(Some(refs));
        self.depth = self.depth.max(depth);
        if n > self.params.max_leaf_triangles as usize && depth < self.params.max_depth {
            // Every primitive lands in at least one child (the grown children cover the grown
            // cell), so no split gains more than `n − CELL_COST − n/4` or adds fewer bytes than
            // its eight nodes.
            let best = priority(split_gain(n, n), depth, 8 * NODE_BYTES);
            let slot = self.queued_slot(Queued {
                cell,
                depth,
                children: None,
            });
            self.queue.push(queue_key(best, node, slot));
        }
    }

    /// Keeps `queued` in a free slot, or a new one, and names it.
    fn queued_slot(&mut self, queued: Queued) -> u32 {
        match self.free.pop() {
            Some(slot) => {
                self.queued[slot as usize] = queued;
                slot
            }
            None => {
                self.queued.push(queued);
                (self.queued.len() - 1) as u32
            }
        }
    }

    /// Asks for the records [`Builder::step`] reads first for the queue's entry `key`
    /// ([`prefetch`]): while this step runs, the next one's are on their way.
    #[inline(always)]
    fn prefetch_step(&self, key: u128) {
        let (node, slot) = queue_entry(key);
        if let (Some(leaf), Some(queued)) = (self.leaves.get(node), self.queued.get(slot)) {
            prefetch(leaf);
            prefetch(queued);
        }
    }

    /// Asks for what [`Builder::step`] reads first for the queue's entry `key` beyond the two
    /// records [`Builder::prefetch_step`] asked for a step ago (so reading them here mostly
    /// finds them in the cache): for a leaf not yet appraised, the start of its list (its
    /// appraisal reads it first). A split reads no list. `perf annotate` of SPD's mount_8's
    /// build showed that load waited on.
    #[inline(always)]
    fn prefetch_lists(&self, key: u128) {
        let (node, slot) = queue_entry(key);
        let (Some(Some(refs)), Some(queued)) = (self.leaves.get(node), self.queued.get(slot))
        else {
            return;
        };
        if queued.children.is_none() {
            if let Some(first) = self.lists.get(refs.start as usize) {
                prefetch(first);
            }
        }
    }

    /// Takes the best queued leaf a step further: a leaf not yet appraised is appraised and
    /// queued again at its true priority (or stays a leaf if splitting would not pay); an
    /// appraised one is split. Returns false when that split would pass the budget, or the
    /// appraisal the lists' limit ([`MOST_LISTED`]): the build ends there.
    fn step(&mut self, node: usize, slot: usize) -> bool {
        let Some(refs) = self.leaves[node] else {
            return true;
        };
        let queued = &self.queued[slot];
        if queued.children.is_some() {
            return self.split_if_it_fits(node, slot);
        }
        let (cell, depth, n) = (queued.cell, queued.depth, refs.len());
        if n.saturating_mul(8).saturating_add(self.lists.len()) > self.most_listed {
            // The children's lists could pass what a `u32` indexes: the build ends here, as at
            // its budget (a scene of some hundred million primitives).
            return false;
        }
        let children = self.split(refs, &cell);
        let total = children.total();
        let gain = split_gain(n, total);
        if gain > 0.0 {
            let added = 8 * NODE_BYTES + ENTRY_BYTES * total.saturating_sub(n);
            let p = priority(gain, depth, added);
            self.queue.push(queue_key(p, node, slot as u32));
            self.queued[slot].children = Some(children);
        } else {
            // The lists just appended are the last ones, and nothing refers to them.
            self.lists.truncate(children.start as usize);
            self.free.push(slot as u32);
        }
        true
    }

    /// Splits appraised leaf `node` into eight children; false if the tree would pass its
    /// budget.
    fn split_if_it_fits(&mut self, node: usize, slot: usize) -> bool {
        let Some(children) = self.queued[slot].children.take() else {
            return true;
        };
        let (cell, depth) = (self.queued[slot].cell, self.queued[slot].depth);
        let n = self.leaves[node].map_or(0, |refs| refs.len());
        let total = children.total();
        if self.bytes + 8 * NODE_BYTES + ENTRY_BYTES * total > self.budget + ENTRY_BYTES * n {
            return false;
        }
        self.leaves[node] = None;
        self.free.push(slot as u32);
        self.bytes -= ENTRY_BYTES * n;
        self.nodes[node] = Node {
            first: self.nodes.len() as u32,
            count: INTERIOR | u32::from(children.occupied()),
        };
        let mid = cell.center();
        for c in 0..8 {
            self.add_leaf(child_box(&cell, mid, c), depth + 1, children.refs(c));
        }
        true
    }

    /// Lays the leaves' lists out in node order and sums up the statistics.
    fn finish(self) -> (Vec<Node>, Vec<u32>, OctreeStats) {
        let mut nodes = self.nodes;
        let mut indices = Vec::with_capacity((self.bytes - NODE_BYTES * nodes.len()) / ENTRY_BYTES);
        let mut stats = OctreeStats {
            depth: self.depth,
            ..OctreeStats::default()
        };
        for (k, (node, refs)) in nodes.iter_mut().zip(&self.leaves).enumerate() {
            // The lists lie in the order their leaves were appraised, not in node order: the list
            // of the leaf `PREFETCH_AHEAD` nodes on is asked for while this one is copied.
            if let Some(Some(ahead)) = self.leaves.get(k + PREFETCH_AHEAD) {
                if let Some(first) = self.lists.get(ahead.start as usize) {
                    prefetch(first);
                }
            }
            let Some(refs) = *refs else { continue };
            let count = refs.len() as u32;
            *node = Node {
                first: indices.len() as u32,
                count,
            };
            // Element by element: a list holds 4.5 entries on average (SPD's mount_8), where a
            // call of `memcpy` per list took 6 % of the build; empty leaves copy nothing.
            if count > 0 {
                indices.extend(refs.get(&self.lists).iter().copied());
            }
            stats.leaves += 1;
            stats.empty_leaves += u32::from(count == 0);
            stats.max_leaf_triangles = stats.max_leaf_triangles.max(count);
        }
        // The reservation (`most_nodes`) is returned now that the leaf records are gone.
        nodes.shrink_to_fit();
        stats.nodes = nodes.len() as u32;
        stats.references = indices.len() as u32;
        stats.bytes = nodes.len() * NODE_BYTES + indices.len() * ENTRY_BYTES;
        (nodes, indices, stats)
    }

    /// The primitives of the list `leaf` (a leaf's, whose cell is `cell`) that each child of the
    /// cell touches, appended to the build's lists.
    fn split(&mut self, leaf: Refs, cell: &Aabb) -> Children {
        // First which children each primitive touches, then the lists, each of exactly its size.
        let cells = ChildCells::new(cell, self.filing.margin);
        let mut masks = core::mem::take(&mut self.masks);
        masks.clear();
        let base = self.lists.len();
        let refs = leaf.get(&self.lists);
        let mut tally = Tally::default();
        for &t in refs.iter().take(PREFETCH_AHEAD) {
            self.filing.prefetch(t as usize);
        }
        for (k, &t) in refs.iter().enumerate() {
            if let Some(&ahead) = refs.get(k + PREFETCH_AHEAD) {
                self.filing.prefetch(ahead as usize);
            }
            let mask = self.filing.children_touched(&cells, t as usize);
            tally.add(mask);
            masks.push(mask);
        }
        let mut ends = tally.counts();
        for c in 1..8 {
            ends[c] += ends[c - 1];
        }
        let mut next: [u32; 8] = core::array::from_fn(|c| if c == 0 { 0 } else { ends[c - 1] });
        let end = self.lists.len() + ends[7] as usize;
        self.lists.resize(end, 0);
        let (before, out) = self.lists.split_at_mut(base);
        let refs = leaf.get(before);
        for (&t, &mask) in refs.iter().zip(&masks) {
            for c in bits(mask) {
                out[next[c] as usize] = t;
                next[c] += 1;
            }
        }
        self.masks = masks;
        Children {
            start: base as u32,
            ends: ends.map(|e| base as u32 + e),
        }
    }
}

/// Per child, how many of the masks added so far have its bit set. The counts are eight bytes of
/// one word, and a mask adds its bits spread one to a byte ([`SPREAD`]): one addition per mask,
/// where a loop over its set bits ends after one to eight rounds, which the processor cannot
/// foresee. The bytes are moved into `u32`s before one can overflow.
#[derive(Default)]
struct Tally {
    bytes: u64,
    pending: u32,
    counts: [u32; 8],
}

/// Per mask, its bit `c` in the lowest bit of byte `c`.
const SPREAD: [u64; 256] = {
    let mut table = [0u64; 256];
    let mut m = 0;
    while m < 256 {
        let mut c = 0;
        while c < 8 {
            table[m] |= ((m as u64 >> c) & 1) << (8 * c);
            c += 1;
        }
        m += 1;
    }
    table
};

impl Tally {
    /// Counts the children in `mask` (bit `c` for child `c`).
    #[inline]
    fn add(&mut self, mask: u8) {
        self.bytes += SPREAD[usize::from(mask)];
        self.pending += 1;
        if self.pending == u32::from(u8::MAX) {
            self.flush();
        }
    }

    /// Moves the byte counts into the `u32` counts.
    fn flush(&mut self) {
        for (c, count) in self.counts.iter_mut().enumerate() {
            *count += (self.bytes >> (8 * c)) as u32 & 0xFF;
        }
        self.bytes = 0;
        self.pending = 0;
    }

    /// The counts, child by child.
    fn counts(mut self) -> [u32; 8] {
        self.flush();
        self.counts
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::octree::{brute_force_closest_hit, xorshift};
    use crate::math::ray::Ray;

    #[test]
    fn a_tally_counts_each_childs_bit_as_a_loop_over_the_bits_does() {
        let mut next = xorshift(0x9e37_79b9);
        // Past several flushes: the full mask 600 times in a row (a byte holds 255), then every
        // mask, the full one often.
        for len in [0usize, 1, 254, 255, 256, 1000, 70_000] {
            let mut tally = Tally::default();
            let mut expected = [0u32; 8];
            for k in 0..len {
                let mask = if k < 600 || k % 3 == 0 {
                    0xFF
                } else {
                    next() as u8
                };
                tally.add(mask);
                for c in bits(mask) {
                    expected[c] += 1;
                }
            }
            assert_eq!(tally.counts(), expected, "{len} masks");
        }
    }

    /// A build whose lists would pass their limit ends there, as at its budget: a smaller tree
    /// that finds every ray's closest hit as testing every triangle does.
    #[test]
    fn a_build_ends_where_its_lists_would_pass_their_limit() {
        let mut next = xorshift(0x0bad_cafe);
        let mut coordinate = move || (next() % 10_000) as f32 / 1000.0;
        let triangles: Vec<[Vec3; 3]> = (0..4000)
            .map(|_| {
                let base = Vec3::new(coordinate(), coordinate(), coordinate());
                let d = Vec3::new(coordinate(), coordinate(), coordinate()) * 0.05;
                [
                    base,
                    base + Vec3::new(d.x, d.y, 0.0),
                    base + Vec3::new(0.0, d.y, d.z),
                ]
            })
            .collect();
        let params = OctreeParams::default();
        let full = Octree::build(&triangles, &params);
        let limited = Octree::build_listing_at_most(&triangles, &[], &params, 20_000);
        assert!(
            limited.nodes().len() * 4 < full.nodes().len(),
            "{} nodes within the limit, {} without",
            limited.nodes().len(),
            full.nodes().len()
        );
        let mut next = xorshift(0x5eed_0001);
        let mut coordinate = move || (next() % 10_000) as f32 / 1000.0;
        for _ in 0..2000 {
            let origin = Vec3::new(coordinate(), coordinate(), coordinate());
            let toward = Vec3::new(coordinate(), coordinate(), coordinate());
            let ray = Ray::new(origin, toward - origin);
            let expected = brute_force_closest_hit(&triangles, &ray, f32::INFINITY);
            let got = limited.closest_hit(&triangles, &ray, f32::INFINITY);
            assert_eq!(got, expected, "{ray:?}");
        }
    }

    /// Every interior node's mask, set when it was split, names exactly its children that are
    /// not empty leaves in the finished tree: a child empty at the split stays so, and every
    /// other stays occupied.
    #[test]
    fn an_interior_nodes_mask_names_its_children_that_are_not_empty() {
        let mut next = xorshift(0x51ed_270b);
        let mut coordinate = || (next() % 10_000) as f32 / 1000.0;
        // Small triangles clustered in a few places of a large box: many empty children.
        let triangles: Vec<[Vec3; 3]> = (0..3000)
            .map(|k| {
                let corner = Vec3::splat((k % 3) as f32 * 3.0);
                let base = corner + Vec3::new(coordinate(), coordinate(), coordinate()) * 0.1;
                let d = Vec3::new(coordinate(), coordinate(), coordinate()) * 0.01;
                [
                    base,
                    base + Vec3::new(d.x, 0.0, d.z),
                    base + Vec3::new(0.0, d.y, d.x),
                ]
            })
            .collect();
        let tree = Octree::build(&triangles, &OctreeParams::default());
        let nodes = tree.nodes();
        let (mut interior, mut empty) = (0, 0);
        for node in nodes.iter().filter(|n| !n.is_leaf()) {
            interior += 1;
            for c in 0..8 {
                let child = nodes[node.first as usize + c];
                let is_empty = child.is_leaf() && child.count == 0;
                empty += usize::from(is_empty);
                assert_eq!(node.child_occupied(c), !is_empty, "{node:?} child {c}");
            }
        }
        assert!(
            interior > 50 && empty > 100,
            "{interior} interior nodes, {empty} empty"
        );
    }
}
