//! Which of the camera's four-pixel packets can meet the octree at all: a bit per packet, set
//! where a camera ray through one of its pixels may enter a cell that holds a primitive. A
//! packet whose bit is clear needs no walk: its rays can only meet what lies beside the tree
//! (the large primitives and the unbounded solids). On SPD's tetra and mount about two fifths
//! of the camera rays enter the tree's root cell and meet nothing in it.
//!
//! The cover is made once per scene and camera ([`CameraCover::new`]): the tree's occupied
//! cells are visited from the root down ([`Octree::descend`]), each cell's eight corners are
//! placed on the image by the camera (`see`, a [`Seen`] per corner), and a cell in front of the
//! camera marks the packets its corners' bounding rectangle, grown by `margin` pixels, meets.
//! A ray that enters a box in front of the camera passes through the box's projection, the
//! convex hull of its corners' images, so no packet that may meet a cell is left clear. A cell
//! is marked whole once it covers at most [`FINEST`] pixels each way, or once it is a leaf; a
//! cell behind the camera marks nothing, and a leaf across the camera's plane marks every
//! packet (then the cover is not made: it would clear none).

use crate::accel::octree::{Octree, LANES};
use crate::math::aabb::Aabb;
use alloc::vec;
use alloc::vec::Vec;
use glam::Vec3;

/// Where a point lies for the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Seen {
    /// In front of the camera's plane: its image point `(x, y)` in pixel units (`(0, 0)` the
    /// top-left corner of the image), where the camera's rays through it are cast. A point
    /// placed at no finite image point makes its cell cover every pixel.
    Front(f64, f64),
    /// Behind the camera's plane, beyond the rounding of the test: no camera ray reaches it.
    Behind,
    /// On the camera's plane, to within the rounding of the test.
    Near,
}

/// Cells whose image is at most this many pixels wide and tall are marked whole instead of
/// looked into further: finer marks clear more packets and cost more cells visited.
pub const FINEST: f64 = 4.0;

/// The most pixels an image may have for a cover to be made: 2²⁶, a bit per four pixels in
/// 2 MiB.
const MOST_PIXELS: u64 = 1 << 26;

/// The packets of [`LANES`] pixels, line by line, that a camera ray may meet the tree from: see
/// the module's doc.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraCover {
    width: u32,
    height: u32,
    /// Packets per line.
    per_line: usize,
    /// Bit `k` for packet `k`, counted line by line.
    bits: Vec<u64>,
}

/// The pixels a cell's image may cover, as inclusive ranges of columns and lines.
struct Rect {
    columns: (u32, u32),
    lines: (u32, u32),
    /// Whether its image is at most [`FINEST`] pixels each way.
    fine: bool,
}

/// What a cell's corners say about it.
enum Footprint {
    /// Behind the camera, or beside the image: no packet meets it.
    Unseen,
    /// Across the camera's plane: a ray from any pixel may meet it.
    Everywhere,
    /// In front of the camera: the pixels its image may cover.
    Pixels(Rect),
}

impl CameraCover {
    /// The cover of `octree` for an image of `width × height` pixels, whose corners `see`
    /// places on the image; each cell's rectangle is grown by `margin` pixels, which must
    /// bound how far the camera's rays (as cast, rounded) and the walk's widening of their
    /// intervals may stray from the exact projection. `None` where the image is empty or
    /// larger than 2²⁶ pixels, or where a leaf lies across the camera's plane.
    pub fn new(
        octree: &Octree,
        (width, height): (u32, u32),
        margin: f64,
        see: impl Fn(Vec3) -> Seen,
    ) -> Option<CameraCover> {
        let pixels = u64::from(width) * u64::from(height);
        if pixels == 0 || pixels > MOST_PIXELS {
            return None;
        }
        let per_line = (width as usize).div_ceil(LANES);
        let mut cover = CameraCover {
            width,
            height,
            per_line,
            bits: vec![0; (per_line * height as usize).div_ceil(64)],
        };
        let mut everywhere = false;
        octree.descend(|cell, node| {
            if everywhere {
                return false;
            }
            match cover.footprint(cell, margin, &see) {
                Footprint::Unseen => false,
                Footprint::Everywhere => {
                    everywhere = node.is_leaf();
                    !everywhere
                }
                // A cell whose packets are all marked already adds nothing, nor do its cells.
                Footprint::Pixels(rect) if cover.marked(&rect) => false,
                Footprint::Pixels(rect) => {
                    let whole = node.is_leaf() || rect.fine;
                    if whole {
                        cover.mark(&rect);
                    }
                    !whole
                }
            }
        });
        (!everywhere).then_some(cover)
    }

    /// True if no camera ray through pixels `x .. x + LANES` of line `y` can enter a cell that
    /// holds a primitive (`x` a multiple of [`LANES`]); false for a packet beyond the image.
    #[inline]
    pub fn clear(&self, x: u32, y: u32) -> bool {
        if x >= self.width || y >= self.height {
            return false;
        }
        let k = y as usize * self.per_line + x as usize / LANES;
        self.bits[k / 64] >> (k % 64) & 1 == 0
    }

    /// What `cell`'s corners say about it (see [`Footprint`]).
    fn footprint(&self, cell: &Aabb, margin: f64, see: &impl Fn(Vec3) -> Seen) -> Footprint {
        let (mut lo, mut hi) = (
            (f64::INFINITY, f64::INFINITY),
            (f64::NEG_INFINITY, f64::NEG_INFINITY),
        );
        let (mut behind, mut front) = (0, 0);
        for c in 0..8 {
            let pick = |a: usize, low: f32, high: f32| if c >> a & 1 == 0 { low } else { high };
            let corner = Vec3::new(
                pick(0, cell.min.x, cell.max.x),
                pick(1, cell.min.y, cell.max.y),
                pick(2, cell.min.z, cell.max.z),
            );
            match see(corner) {
                Seen::Front(x, y) => {
                    front += 1;
                    lo = (lo.0.min(x), lo.1.min(y));
                    hi = (hi.0.max(x), hi.1.max(y));
                }
                Seen::Behind => behind += 1,
                Seen::Near => {}
            }
        }
        if behind == 8 {
            return Footprint::Unseen;
        }
        if front < 8 {
            return Footprint::Everywhere;
        }
        if ![lo.0, lo.1, hi.0, hi.1].iter().all(|v| v.is_finite()) {
            return Footprint::Everywhere;
        }
        let fine = hi.0 - lo.0 <= FINEST && hi.1 - lo.1 <= FINEST;
        let (lo, hi) = (
            (lo.0 - margin, lo.1 - margin),
            (hi.0 + margin, hi.1 + margin),
        );
        if hi.0 < 0.0 || hi.1 < 0.0 || lo.0 > f64::from(self.width) || lo.1 > f64::from(self.height)
        {
            return Footprint::Unseen;
        }
        // Pixel `k` spans `k ..= k + 1`; clamped to the image.
        let pixel = |v: f64, n: u32| libm::floor(v).clamp(0.0, f64::from(n - 1)) as u32;
        Footprint::Pixels(Rect {
            columns: (pixel(lo.0, self.width), pixel(hi.0, self.width)),
            lines: (pixel(lo.1, self.height), pixel(hi.1, self.height)),
            fine,
        })
    }

    /// Sets the bits of the packets `rect` meets.
    fn mark(&mut self, rect: &Rect) {
        for (word, bits) in words(self.per_line, rect) {
            self.bits[word] |= bits;
        }
    }

    /// True if the bits of the packets `rect` meets are all set.
    fn marked(&self, rect: &Rect) -> bool {
        words(self.per_line, rect).all(|(word, bits)| self.bits[word] & bits == bits)
    }
}

/// The words of [`CameraCover::bits`] (`per_line` packets a line) that hold the packets `rect`
/// meets, each with the bits of those packets: per line, the run of packets from its first
/// column's to its last's.
fn words(per_line: usize, rect: &Rect) -> impl Iterator<Item = (usize, u64)> {
    let (first, last) = (
        rect.columns.0 as usize / LANES,
        rect.columns.1 as usize / LANES,
    );
    (rect.lines.0..=rect.lines.1).flat_map(move |y| {
        let line = y as usize * per_line;
        let (start, end) = (line + first, line + last + 1);
        (start / 64..=(end - 1) / 64).map(move |word| {
            let (lo, hi) = (
                (start.max(word * 64) - word * 64),
                (end.min(word * 64 + 64) - word * 64),
            );
            // Bits `lo .. hi` of the word (`hi` up to 64).
            let bits = (u64::MAX >> (64 - (hi - lo))) << lo;
            (word, bits)
        })
    })
}
