//! Four rays walked together: the closest hits of neighbouring camera rays.
//!
//! Neighbouring camera rays cross mostly the same cells. [`Octree::closest_hits4`] walks four
//! rays at once, one per lane of a [`Vec4`]: an interior cell computes the four rays'
//! centre-plane crossings and their pieces in each child with a few vector operations
//! ([`push_children4`]), where the one-ray walk does that work once per ray. A leaf hands each
//! primitive once to the caller's test with the rays that enter the leaf and have not tested
//! it yet (each ray keeps its own mailbox); the test decides for each of them as the one-ray
//! test does (the scene's test filters triangles and lone spheres four rays at a time,
//! `intersect4` and `surely_missed_by4`).
//!
//! Each ray gets the one-ray walk's answer. Its pieces are the one-ray walk's to the bit: a
//! crossing inside a ray's interval cuts it, widened by [`WIDEN`], and one outside decides the
//! side by the same comparison as `push_children` in `traverse.rs`. Where a ray's crossings tie
//! (a ray through a cell's edge or corner) its children are cut by that function itself
//! ([`lanes_that_tie`]). So a ray enters the cells the one-ray walk enters, over the same
//! intervals; only the order of cells off its computed path and the other rays' cells around
//! them differ, and the closest hit (the smallest `t`, ties to the smallest index) does not
//! depend on the order primitives are tested in.
//!
//! The four rays must go the same way along each axis (no zero component), so that one order of
//! the children is nearest first for each of them: a ray passes through children in order of
//! how many centre planes it has crossed, and these are popped in that order. Camera rays of
//! neighbouring pixels almost always qualify; other rays make no [`Packet`], and the scene
//! walks them one at a time.

use super::traverse::{
    next_cell, push_children, sized, Entry, Path, SizedWalk, MAILBOX_SLOTS, WIDEN,
};
use super::{Node, Octree};
use crate::accel::work::QueryWork;
use crate::geom::hit::{Closest, RayHit};
use crate::math::ray::Ray;
use alloc::vec::Vec;
use glam::{BVec4A, Vec3, Vec4};
use wide::{i32x4, CmpEq};

/// Rays per packet.
pub const LANES: usize = 4;

/// `[f(0), f(1), f(2), f(3)]`: a value per lane, written out. `core::array::from_fn` builds its
/// array through a guard over uninitialised memory, which the compiler left as copies and
/// branches in the tracer's per-pixel paths (on tetra_6, `perf annotate` put over three
/// quarters of `render_line`'s own samples and two fifths of `trace4`'s there).
#[inline(always)]
pub fn per_lane<T>(mut f: impl FnMut(usize) -> T) -> [T; LANES] {
    [f(0), f(1), f(2), f(3)]
}

/// A cell waiting on the packet's stack: the four rays' intervals in it (empty, `t0 > t1`, for
/// a ray that does not enter it), its node, depth and which child of its parent it is.
#[derive(Clone, Copy, Debug)]
struct Entry4 {
    t0: Vec4,
    t1: Vec4,
    node: u32,
    depth: u16,
    child: u16,
}

/// All zero: what fills the stack above its top (the compiler clears it with one fill).
impl Default for Entry4 {
    fn default() -> Self {
        Entry4 {
            t0: Vec4::ZERO,
            t1: Vec4::ZERO,
            node: 0,
            depth: 0,
            child: 0,
        }
    }
}

/// The packet walk's stack, kept from one walk to the next so that a walk does not clear one
/// (a cleared stack of a tree at most 10 deep is 72 entries, 3.4 KiB, per packet). A walk only
/// reads entries it pushed itself, below its top, so what earlier walks left above it is never
/// read.
#[derive(Clone, Debug, Default)]
pub struct PacketStack(Vec<Entry4>);

/// Four rays lane by lane, as the packet walk and the scene's four-ray tests read them: per
/// axis, their origins, directions and reciprocal directions, one lane a ray, and which axes
/// they all go down (`flip`: bit `a` set where the direction is negative along axis `a`). Made
/// once per query ([`Packet::new`]) for every four-ray test of it: the root test
/// ([`Octree::missed_by4`]), the walk ([`Octree::closest_hits4`]) and the solids' tests.
pub struct Packet<'a> {
    /// The rays.
    pub rays: &'a [Ray; LANES],
    /// Per axis, the four origins.
    pub origin: [Vec4; 3],
    /// Per axis, the four directions.
    pub dir: [Vec4; 3],
    /// Per axis, the four reciprocal directions: lane `l` of axis `a` is component `a` of
    /// the one-ray walk's `inv_dir` of ray `l`, to the bit (the same IEEE division).
    pub inv_dir: [Vec4; 3],
    flip: usize,
}

impl<'a> Packet<'a> {
    /// The packet, or `None` if the rays do not all go the same way along every axis (a zero
    /// or NaN component included): the scene walks those one ray at a time.
    pub fn new(rays: &'a [Ray; LANES]) -> Option<Self> {
        let lanes = |v: &dyn Fn(&Ray) -> Vec3| {
            let [a, b, c, d] = rays.each_ref().map(v);
            [0, 1, 2].map(|k| Vec4::new(a[k], b[k], c[k], d[k]))
        };
        let dir = lanes(&|r| r.dir);
        let flip = shared_signs(&dir)?;
        Some(Packet {
            rays,
            origin: lanes(&|r| r.origin),
            dir,
            inv_dir: dir.map(|d| Vec4::ONE / d),
            flip,
        })
    }

    /// Ray `l`'s reciprocal direction, the one-ray walk's `inv_dir`.
    #[inline(always)]
    fn ray_inv_dir(&self, l: usize) -> Vec3 {
        Vec3::new(self.inv_dir[0][l], self.inv_dir[1][l], self.inv_dir[2][l])
    }
}

/// The signs the four directions (per axis, lane by lane) share: bit `a` set where all go down
/// axis `a`; `None` if they differ along an axis or a component is zero or NaN (which compare
/// false both ways). One comparison of the four lanes each way per axis, no branch per ray.
fn shared_signs(dir: &[Vec4; 3]) -> Option<usize> {
    let mut flip = 0;
    for (a, d) in dir.iter().enumerate() {
        match (d.cmplt(Vec4::ZERO).bitmask(), d.cmpgt(Vec4::ZERO).bitmask()) {
            (ALL_LANES, 0) => flip |= 1 << a,
            (0, ALL_LANES) => {}
            _ => return None,
        }
    }
    Some(flip)
}

/// Every lane's bit.
const ALL_LANES: u32 = (1 << LANES) - 1;

/// The order [`push_children4`] takes a cell's children in, farthest first, as the rays' own
/// child numbers (child `r ^ flip` of the cell): a ray passes through children in order of the
/// centre planes it has crossed.
const ORDER: [usize; 8] = [7, 6, 5, 3, 4, 2, 1, 0];

/// Per `flip` and occupancy mask (bit `c` for child `c`, [`Node::occupied`]), the children
/// occupied in [`ORDER`]: bit `k` for child `ORDER[k] ^ flip`. One load where a shift and a
/// test per child were.
const OCCUPIED_IN_ORDER: [[u8; 256]; 8] = {
    let mut table = [[0u8; 256]; 8];
    let mut flip = 0;
    while flip < 8 {
        let mut mask = 0;
        while mask < 256 {
            let mut k = 0;
            while k < 8 {
                table[flip][mask] |= (((mask >> (ORDER[k] ^ flip)) & 1) << k) as u8;
                k += 1;
            }
            mask += 1;
        }
        flip += 1;
    }
    table
};

/// The four rays' mailboxes (each the one-ray walk's `Mailbox`), slot by slot in vector lanes,
/// lane `l` ray `l`'s: one comparison and one select visit a primitive for every ray entering
/// the leaf, where a loop over the rays took a few instructions each. Lanes hold the indices'
/// bits as `i32` (`wide` compares and selects those); `-1` is `u32::MAX`, which no primitive
/// has.
struct Mailboxes([i32x4; MAILBOX_SLOTS]);

impl Mailboxes {
    /// Empty mailboxes, except that ray `l`'s holds `leaving[l]`, if given, as if tested.
    fn holding(leaving: [Option<u32>; LANES]) -> Self {
        let mut slots = [[-1i32; LANES]; MAILBOX_SLOTS];
        for (l, i) in leaving.into_iter().enumerate() {
            if let Some(i) = i {
                slots[i as usize % MAILBOX_SLOTS][l] = i as i32;
            }
        }
        Mailboxes(slots.map(i32x4::new))
    }

    /// The rays among `entered` (a [`lane_mask`]) that see `i` for the first time since its
    /// slot of their mailbox last held another primitive (bit `l` for ray `l`); their slots
    /// now hold `i`, the other rays' are left alone.
    #[inline(always)]
    fn first_visits(&mut self, i: u32, entered: i32x4) -> u32 {
        let slot = &mut self.0[i as usize % MAILBOX_SLOTS];
        let i = i32x4::splat(i as i32);
        let fresh = !slot.cmp_eq(i) & entered;
        *slot = entered.blend(i, *slot);
        fresh.move_mask() as u32
    }
}

/// All ones in lane `l` where bit `l` of `bits` is set, zeros elsewhere.
#[inline(always)]
fn lane_mask(bits: u32) -> i32x4 {
    let each = i32x4::new([1, 2, 4, 8]);
    (i32x4::splat(bits as i32) & each).cmp_eq(each)
}

/// The lanes set in `bits` (bit `l` for lane `l`), lowest first.
pub fn lanes_of(mut bits: u32) -> impl Iterator<Item = usize> {
    core::iter::from_fn(move || {
        (bits != 0).then(|| {
            let l = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            l
        })
    })
}

impl Octree {
    /// The closest hits of the packet's four rays with `0 < t < t_max`, each what
    /// [`Octree::closest_hit_with`] returns for it. `test(lanes, index, closest)` tests
    /// primitive `index` against the rays in `lanes` (bit `l` for ray `l`) and offers each
    /// ray's hit with `t < closest[l].bound()` to `closest[l]`, as `test(index, bound)` finds it
    /// there. `leaving[l]` is a primitive ray `l` cannot hit, which the walk does not test it
    /// against (the triangle it leaves: its test could only find nothing, at a cost, as `t`
    /// rounds about 0). With `walk` false only the large primitives are tested: the caller
    /// knows the rays enter no cell that holds a primitive. The cells entered and the tests
    /// made are added to `work`; `stack` is the walk's.
    pub fn closest_hits4<H: RayHit>(
        &self,
        packet: &Packet,
        t_max: f32,
        leaving: [Option<u32>; LANES],
        walk: bool,
        (work, stack): (&mut QueryWork, &mut PacketStack),
        mut test: impl FnMut(u32, u32, &mut [Closest<H>; LANES]),
    ) -> [Option<(u32, H)>; LANES] {
        let mut closest: [Closest<H>; LANES] = per_lane(|_| Closest::new(t_max));
        let mut tests = 0;
        for &i in &self.large {
            let mut lanes = 0;
            for (l, leaving) in leaving.iter().enumerate() {
                lanes |= u32::from(*leaving != Some(i)) << l;
            }
            if lanes != 0 {
                tests += u64::from(lanes.count_ones());
                test(lanes, i, &mut closest);
            }
        }
        if !walk {
            work.intersection_tests += tests;
            return per_lane(|l| closest[l].best());
        }
        // A hit on a large primitive already bounds the ray's walk.
        let t_max = per_lane(|l| t_max.min(closest[l].cutoff()));
        // Each ray's mailbox starts with the primitive it leaves, as if tested already.
        let mut mailboxes = Mailboxes::holding(leaving);
        work.octree_cells += self.walk4(packet, t_max, stack, |entered, indices| {
            let entered = lane_mask(entered);
            for &i in indices {
                let lanes = mailboxes.first_visits(i, entered);
                if lanes != 0 {
                    tests += u64::from(lanes.count_ones());
                    test(lanes, i, &mut closest);
                }
            }
            per_lane(|l| closest[l].cutoff())
        });
        work.intersection_tests += tests;
        per_lane(|l| closest[l].best())
    }

    /// True if none of the packet's rays enters the tree's root cell within `t_max` and no
    /// primitive is set apart from the tree: [`Octree::closest_hits4`] would find no hit for
    /// any of them (by its root test), so a caller can skip preparing its tests. Four
    /// background pixels, mostly; a ray that enters ends the check.
    ///
    /// The four root tests are made in vector lanes ([`Aabb::enter4`]), as the walk makes them.
    /// On SPD's tetra, four fifths of whose pixels are background, the four tests one ray at a
    /// time (each with its division) were about a third of a background pixel's work.
    ///
    /// [`Aabb::enter4`]: crate::math::aabb::Aabb::enter4
    pub fn missed_by4(&self, packet: &Packet, t_max: f32) -> bool {
        self.large.is_empty()
            && self
                .root
                .missed_by4(&packet.origin, &packet.inv_dir, Vec4::splat(t_max))
                == ALL_LANES
    }

    /// Visits the non-empty leaves the packet's rays cross, nearest leaves first for each ray:
    /// `leaf(lanes, indices)` gets the rays that enter the leaf (bit `l` for ray `l`) and returns
    /// every ray's cut-off (cells a ray enters beyond its own are skipped). Returns the cells
    /// entered, counted once per ray that enters them.
    fn walk4(
        &self,
        packet: &Packet,
        t_max: [f32; LANES],
        stack: &mut PacketStack,
        leaf: impl FnMut(u32, &[u32]) -> [f32; LANES],
    ) -> u64 {
        struct Four<'a, 'b, F> {
            tree: &'a Octree,
            packet: &'a Packet<'b>,
            t_max: [f32; LANES],
            stack: &'a mut PacketStack,
            leaf: F,
        }
        impl<F: FnMut(u32, &[u32]) -> [f32; LANES]> SizedWalk for Four<'_, '_, F> {
            type Out = u64;
            #[inline(always)]
            fn run<const S: usize, const P: usize>(self) -> u64 {
                self.tree
                    .walk4_in::<S, P>(self.packet, self.t_max, self.stack, self.leaf)
            }
        }
        sized(
            self.stats.depth,
            Four {
                tree: self,
                packet,
                t_max,
                stack,
                leaf,
            },
        )
    }

    /// [`Octree::walk4`] with a stack of `S` entries and a path of `P` boxes. Each level pushes
    /// at most eight cells and pops one, as the one-ray walk's does.
    fn walk4_in<const S: usize, const P: usize>(
        &self,
        packet: &Packet,
        t_max: [f32; LANES],
        stack: &mut PacketStack,
        mut leaf: impl FnMut(u32, &[u32]) -> [f32; LANES],
    ) -> u64 {
        let mut root = Entry4 {
            t0: Vec4::INFINITY,
            t1: Vec4::NEG_INFINITY,
            ..Entry4::default()
        };
        let (t0, t1, exact) =
            self.root
                .enter4(&packet.origin, &packet.inv_dir, Vec4::from_array(t_max));
        let entered = t0.cmple(t1) & exact;
        root.t0 = Vec4::select(entered, t0 * (1.0 - WIDEN), root.t0);
        root.t1 = Vec4::select(entered, t1, root.t1);
        // Lanes the vector test could not answer exactly: one ray at a time.
        for l in lanes_of(!exact.bitmask() & ALL_LANES) {
            let (ray, inv_dir) = (&packet.rays[l], packet.ray_inv_dir(l));
            if let Some((t0, t1)) = self.root.intersect(ray, inv_dir, t_max[l]) {
                root.t0[l] = t0 * (1.0 - WIDEN);
                root.t1[l] = t1;
            }
        }
        if root.t0.cmple(root.t1).bitmask() == 0 {
            // No ray enters the tree (background pixels): nothing to clear a stack for.
            return 0;
        }
        if stack.0.len() < S {
            stack.0.resize(S, Entry4::default());
        }
        let Some(stack) = stack.0.first_chunk_mut::<S>() else {
            unreachable!("the stack holds at least S entries")
        };
        let mut path = Path::<P>::new();
        // The cell to enter next when it is not on the stack: the nearest child of the cell
        // entered last, kept in registers, as in the one-ray walk.
        let mut next = Some(root);
        let mut top = 0usize;
        let mut cutoff = [f32::INFINITY; LANES];
        let mut cells = 0u64;
        while let Some(e) = next_cell(&mut next, stack, &mut top) {
            let active = e.t0.cmple(e.t1) & e.t0.cmple(Vec4::from_array(cutoff));
            let bits = active.bitmask();
            if bits == 0 {
                continue;
            }
            cells += u64::from(bits.count_ones());
            let node = self.nodes[e.node as usize];
            if node.is_leaf() {
                let start = node.first as usize;
                let indices = &self.indices[start..start + node.count as usize];
                cutoff = leaf(bits, indices);
                continue;
            }
            let cell = path.enter(e.depth, e.child, self.root);
            let e = Entry4 {
                t0: Vec4::select(active, e.t0, Vec4::INFINITY),
                t1: Vec4::select(active, e.t1, Vec4::NEG_INFINITY),
                ..e
            };
            (top, next) = push_children4(packet, &e, node, cell.center(), stack, top);
        }
        cells
    }
}

/// Pushes the occupied children of interior node `node` (entered as `e`, its centre `mid`) with
/// the pieces of the four rays' intervals in them, farthest first; returns the new stack top
/// and the nearest child, which it does not push: the walk enters it next.
///
/// Per axis, a ray's crossing `c` of the centre plane cuts its interval if it lies inside: the
/// ray is in the half it starts in until `c·(1 + WIDEN)` and in the other from `c·(1 − WIDEN)`.
/// A crossing outside leaves the ray in one half, the one `push_children` picks. Child `r`
/// counted from the ray's side (bit `a` set: the half reached second along axis `a`) starts at
/// the latest widened crossing it is past and ends at the earliest it is before, or at the
/// interval's ends where there is none: the one-ray walk's pieces, where crossings do not tie.
#[inline(always)]
fn push_children4<const S: usize>(
    packet: &Packet,
    e: &Entry4,
    node: Node,
    mid: Vec3,
    stack: &mut [Entry4; S],
    mut top: usize,
) -> (usize, Option<Entry4>) {
    let (t0, t1) = (e.t0, e.t1);
    // Per axis, where each ray may start in the half it reaches second (`lo`) and must have
    // left the half it starts in (`hi`): ±∞ where it stays in one half.
    let mut lo = [Vec4::ZERO; 3];
    let mut hi = [Vec4::ZERO; 3];
    let mut inside = [BVec4A::FALSE; 3];
    for a in 0..3 {
        let gap = Vec4::splat(mid[a]) - packet.origin[a];
        // An origin on the plane crosses it at 0, also where `1/d` overflows (0 · ∞).
        let c = Vec4::select(gap.cmpeq(Vec4::ZERO), Vec4::ZERO, gap * packet.inv_dir[a]);
        inside[a] = c.cmpgt(t0) & c.cmplt(t1);
        let side = Vec4::select(t0.cmpge(c), Vec4::NEG_INFINITY, Vec4::INFINITY);
        lo[a] = Vec4::select(inside[a], c * (1.0 - WIDEN), side);
        hi[a] = Vec4::select(inside[a], c * (1.0 + WIDEN), side);
    }
    // Starts: the latest `lo` of the axes crossed (t0 where all are -∞, none crossed inside).
    let s1 = lo[0];
    let s2 = lo[1];
    let s3 = s1.max(lo[1]);
    let mut starts = [
        t0,
        s1,
        s2,
        s3,
        lo[2],
        s1.max(lo[2]),
        s2.max(lo[2]),
        s3.max(lo[2]),
    ];
    // Ends: the earliest `hi` of the axes not crossed (t1 where all are +∞).
    let e6 = hi[0];
    let e5 = hi[1];
    let e4 = e6.min(hi[1]);
    let mut ends = [
        e4.min(hi[2]),
        e5.min(hi[2]),
        e6.min(hi[2]),
        hi[2],
        e4,
        e5,
        e6,
        t1,
    ];
    for r in 1..8 {
        starts[r] = Vec4::select(starts[r].cmpeq(Vec4::NEG_INFINITY), t0, starts[r]);
        ends[7 - r] = Vec4::select(ends[7 - r].cmpeq(Vec4::INFINITY), t1, ends[7 - r]);
    }
    let ties = lanes_that_tie(&lo, &hi, &inside);
    if ties != 0 {
        one_ray_pieces(packet, e, node, mid, ties, (&mut starts, &mut ends));
    }
    // Farthest first: a ray passes through children in order of the planes crossed. The
    // nearest is not pushed but returned. Which children are taken is found for all eight
    // first, without a branch per child (whether a child is taken is a coin toss), and only
    // those are visited, in that order (bit `k` for `ORDER[k]`; `lanes_of` walks any mask).
    let mut entered = 0u32;
    for (k, r) in ORDER.into_iter().enumerate() {
        entered |= u32::from(starts[r].cmple(ends[r]).any()) << k;
    }
    let taken = entered & u32::from(OCCUPIED_IN_ORDER[packet.flip][node.occupied()]);
    let mut nearest = None;
    for k in lanes_of(taken) {
        let r = ORDER[k];
        let c = r ^ packet.flip;
        if let Some(farther) = nearest.replace(Entry4 {
            t0: starts[r],
            t1: ends[r],
            node: node.first + c as u32,
            depth: e.depth + 1,
            child: c as u16,
        }) {
            stack[top] = farther;
            top += 1;
        }
    }
    (top, nearest)
}

/// The lanes in which two crossings inside the interval are too close to order: their widened
/// values overlap (the one-ray walk's `tie`, taken over every pair).
#[inline(always)]
fn lanes_that_tie(lo: &[Vec4; 3], hi: &[Vec4; 3], inside: &[BVec4A; 3]) -> u32 {
    let pair = |a: usize, b: usize| inside[a] & inside[b] & lo[b].cmple(hi[a]) & lo[a].cmple(hi[b]);
    (pair(0, 1) | pair(1, 2) | pair(0, 2)).bitmask()
}

/// Replaces the pieces of the rays in `ties` by the ones the one-ray walk cuts
/// (`push_children`, which also enters the cells around crossings that tie). Rare: rays through
/// cells' edges and corners.
#[cold]
#[inline(never)]
fn one_ray_pieces(
    packet: &Packet,
    e: &Entry4,
    node: Node,
    mid: Vec3,
    ties: u32,
    (starts, ends): (&mut [Vec4; 8], &mut [Vec4; 8]),
) {
    for l in lanes_of(ties) {
        // At most eight children, each pushed once.
        let mut pushed = [Entry::default(); 8];
        let (n, nearest) = one_ray_children(packet, (e, l), node, mid, &mut pushed);
        for r in 0..8 {
            starts[r][l] = f32::INFINITY;
            ends[r][l] = f32::NEG_INFINITY;
        }
        for p in pushed[..n].iter().chain(nearest.as_ref()) {
            let r = p.child as usize ^ packet.flip;
            starts[r][l] = p.t0;
            ends[r][l] = p.t1;
        }
    }
}

/// `push_children` for ray `l` of the packet, entered as lane `l` of `e`, onto `stack`.
fn one_ray_children(
    packet: &Packet,
    (e, l): (&Entry4, usize),
    node: Node,
    mid: Vec3,
    stack: &mut [Entry; 8],
) -> (usize, Option<Entry>) {
    let one = Entry {
        node: e.node,
        t0: e.t0[l],
        t1: e.t1[l],
        depth: e.depth,
        child: e.child,
    };
    let (ray, inv_dir) = (&packet.rays[l], packet.ray_inv_dir(l));
    push_children(ray, inv_dir, &one, node, mid, stack, 0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::octree::INTERIOR;

    /// The table gives, for every flip and occupancy, each child's own occupancy bit in
    /// [`ORDER`]'s places.
    #[test]
    fn occupied_in_order_is_each_childs_bit() {
        for (flip, row) in OCCUPIED_IN_ORDER.iter().enumerate() {
            for mask in 0..256u32 {
                let node = Node {
                    first: 0,
                    count: INTERIOR | mask,
                };
                let bits = row[node.occupied()];
                for (k, r) in ORDER.into_iter().enumerate() {
                    assert_eq!(bits >> k & 1 == 1, node.child_occupied(r ^ flip));
                }
            }
        }
    }

    /// Every child's piece of every ray, as `(child, t0 bits, t1 bits)`, sorted.
    type Pieces = alloc::vec::Vec<(u16, u32, u32)>;

    fn one_ray(packet: &Packet, e: &Entry4, node: Node, mid: Vec3, l: usize) -> Pieces {
        let mut stack = [Entry::default(); 8];
        let (n, nearest) = one_ray_children(packet, (e, l), node, mid, &mut stack);
        let mut p: Pieces = stack[..n]
            .iter()
            .chain(nearest.as_ref())
            .map(|p| (p.child, p.t0.to_bits(), p.t1.to_bits()))
            .collect();
        p.sort_unstable();
        p
    }

    fn four_rays(packet: &Packet, e: &Entry4, node: Node, mid: Vec3, l: usize) -> Pieces {
        let mut stack = [Entry4::default(); 8];
        let (n, nearest) = push_children4(packet, e, node, mid, &mut stack, 0);
        let mut p: Pieces = stack[..n]
            .iter()
            .chain(nearest.as_ref())
            .filter(|p| p.t0[l] <= p.t1[l])
            .map(|p| (p.child, p.t0[l].to_bits(), p.t1[l].to_bits()))
            .collect();
        p.sort_unstable();
        p
    }

    /// The pieces the packet cuts are the one-ray walk's, bit for bit, for rays in general
    /// position and for rays through a cell's centre, edges and corners (crossings that tie).
    #[test]
    fn pieces_are_the_one_ray_walks() {
        let mut rng = crate::scene::mesh::Rng::new(7);
        let mut unit = move || rng.next_f32();
        let node = Node {
            first: 8,
            count: INTERIOR | 0xff,
        };
        let (mut ties, mut cut) = (0, 0);
        for case in 0..20_000 {
            let mid = Vec3::new(unit(), unit(), unit()) * 4.0 - 2.0;
            let signs = Vec3::new(1.0, -1.0, 1.0).map(|s| if unit() < 0.5 { s } else { -s });
            let rays: [Ray; LANES] = core::array::from_fn(|_| {
                let dir = (Vec3::new(unit(), unit(), unit()) + 0.01) * signs;
                let origin = if case % 2 == 0 {
                    // Through the centre: the three crossings tie (up to rounding).
                    mid - dir * (1.0 + 9.0 * unit())
                } else {
                    Vec3::new(unit(), unit(), unit()) * 20.0 - 10.0
                };
                Ray::new(origin, dir)
            });
            let Some(packet) = Packet::new(&rays) else {
                continue;
            };
            let mut e = Entry4::default();
            for l in 0..LANES {
                let (a, b) = (unit() * 30.0, unit() * 30.0);
                (e.t0[l], e.t1[l]) = (a.min(b), a.max(b));
            }
            let lo_hi: [(Vec4, Vec4, BVec4A); 3] = core::array::from_fn(|a| {
                let gap = Vec4::splat(mid[a]) - packet.origin[a];
                let c = gap * packet.inv_dir[a];
                let inside = c.cmpgt(e.t0) & c.cmplt(e.t1);
                (c * (1.0 - WIDEN), c * (1.0 + WIDEN), inside)
            });
            let tie = lanes_that_tie(
                &lo_hi.map(|x| x.0),
                &lo_hi.map(|x| x.1),
                &lo_hi.map(|x| x.2),
            );
            ties += tie.count_ones();
            for l in 0..LANES {
                let want = one_ray(&packet, &e, node, mid, l);
                cut += usize::from(want.len() > 1);
                assert_eq!(
                    four_rays(&packet, &e, node, mid, l),
                    want,
                    "case {case} lane {l}"
                );
            }
        }
        assert!(ties > 5_000, "only {ties} rays with tied crossings");
        assert!(cut > 15_000, "only {cut} rays cut into several pieces");
    }

    #[test]
    fn rays_of_mixed_or_zero_signs_are_not_a_packet() {
        let ray = |d: Vec3| Ray::new(Vec3::ZERO, d);
        let same = [ray(Vec3::new(1.0, -1.0, 2.0)); LANES];
        assert_eq!(Packet::new(&same).map(|p| p.flip), Some(0b010));
        let mut mixed = same;
        mixed[3] = ray(Vec3::new(1.0, 1.0, 2.0));
        assert!(Packet::new(&mixed).is_none());
        let mut zero = same;
        zero[1] = ray(Vec3::new(1.0, -0.0, 2.0));
        assert!(Packet::new(&zero).is_none());
    }
}
