//! The lone spheres of the octree's large leaves, gathered into [`SphereGroup`]s once, when the
//! scene is prepared.
//!
//! A leaf of [`GROUP`] primitives or more is tested in groups (SPD's shells: dozens to hundreds
//! of overlapping spheres a leaf). Gathered per query, each sphere cost a mailbox lookup, a load
//! of its record by index from anywhere in the object list and a copy into the group; here the
//! groups lie ready in leaf order, next to the leaf's other primitives, and a query finds them
//! by the leaf's start in [`Octree::indices`] (binary search over the large leaves).
//!
//! Each group keeps its reach ([`SphereGroup::reach`]), a box around its spheres: a query skips
//! a group whose reach its ray misses (`render/intersect.rs`), as a solid's reject box lets it
//! skip the solid.
//!
//! A leaf's primitives are all tested each time the walk enters it, without the mailbox: a
//! sphere filed in several cells the ray crosses is tested again, which changes no answer (a
//! test's hit does not depend on its bound, and offering the same hit twice keeps the first).

use crate::accel::octree::{Octree, GROUP};
use crate::geom::solid::lone_sphere::{LoneSphere, SphereGroup};
use crate::math::aabb::Aabb;
use alloc::vec::Vec;

/// The large leaves' lone spheres in groups, and their other primitives.
#[derive(Clone, Debug, Default)]
pub struct LeafSpheres {
    /// One per large leaf, in order of `start`, then one past the last: the leaf's groups are
    /// `groups[e.groups .. next.groups]` and its other primitives `others[e.others ..
    /// next.others]`.
    leaves: Vec<LeafEntry>,
    groups: Vec<SphereGroup>,
    /// Per group, where its spheres can report a hit ([`SphereGroup::reach`]).
    reach: Vec<Aabb>,
    others: Vec<u32>,
}

#[derive(Clone, Copy, Debug)]
struct LeafEntry {
    /// The leaf's start in [`Octree::indices`].
    start: u32,
    groups: u32,
    others: u32,
}

/// One large leaf's primitives: its lone spheres in groups, the rest by primitive index.
#[derive(Clone, Copy, Debug)]
pub struct LeafPrimitives<'a> {
    /// The lone spheres, [`GROUP`] to a group but the last, in the leaf's order.
    pub groups: &'a [SphereGroup],
    /// Per group, where its spheres can report a hit.
    pub reach: &'a [Aabb],
    /// The primitives that are not lone spheres, in the leaf's order.
    pub others: &'a [u32],
}

impl LeafSpheres {
    /// The groups of `octree`'s leaves of [`GROUP`] primitives or more, if they take at most
    /// `memory` bytes (else none: the queries gather each leaf's spheres themselves, to the same
    /// answers); `sphere_of(i)` is primitive `i` as a lone sphere, if it is one.
    pub fn build(
        octree: &Octree,
        sphere_of: impl Fn(u32) -> Option<LoneSphere>,
        memory: u64,
    ) -> LeafSpheres {
        let large = || octree.leaves().filter(|(_, ix)| ix.len() >= GROUP);
        let (mut leaves, mut groups, mut others) = (1, 0, 0);
        for (_, indices) in large() {
            let spheres = indices.iter().filter(|&&i| sphere_of(i).is_some()).count();
            leaves += 1;
            groups += spheres.div_ceil(GROUP);
            others += indices.len() - spheres;
        }
        if Self::bytes_of(leaves, groups, others) as u64 > memory {
            return LeafSpheres::default();
        }
        let mut all = LeafSpheres {
            leaves: Vec::with_capacity(leaves),
            groups: Vec::with_capacity(groups),
            reach: Vec::with_capacity(groups),
            others: Vec::with_capacity(others),
        };
        for (start, indices) in large() {
            all.push_entry(start);
            let mut group = SphereGroup::new();
            for &i in indices {
                let Some(sphere) = sphere_of(i) else {
                    all.others.push(i);
                    continue;
                };
                group.push(i, sphere);
                if group.is_full() {
                    all.push_group(&group);
                    group.clear();
                }
            }
            if !group.is_empty() {
                all.push_group(&group);
            }
        }
        all.push_entry(u32::MAX);
        all
    }

    fn push_group(&mut self, group: &SphereGroup) {
        self.groups.push(*group);
        self.reach.push(group.reach());
    }

    fn push_entry(&mut self, start: u32) {
        self.leaves.push(LeafEntry {
            start,
            groups: self.groups.len() as u32,
            others: self.others.len() as u32,
        });
    }

    /// The primitives of the leaf that starts at `start` in [`Octree::indices`], if it is a
    /// large one.
    #[inline]
    pub fn leaf(&self, start: u32) -> Option<LeafPrimitives<'_>> {
        let e = self.leaves.binary_search_by_key(&start, |e| e.start).ok()?;
        let (this, next) = (self.leaves[e], *self.leaves.get(e + 1)?);
        Some(LeafPrimitives {
            groups: &self.groups[this.groups as usize..next.groups as usize],
            reach: &self.reach[this.groups as usize..next.groups as usize],
            others: &self.others[this.others as usize..next.others as usize],
        })
    }

    /// The bytes the groups and lists take.
    pub fn bytes(&self) -> usize {
        Self::bytes_of(self.leaves.len(), self.groups.len(), self.others.len())
    }

    /// The bytes of `leaves` entries, `groups` groups and `others` other primitives.
    fn bytes_of(leaves: usize, groups: usize, others: usize) -> usize {
        use core::mem::size_of;
        leaves * size_of::<LeafEntry>()
            + groups * (size_of::<SphereGroup>() + size_of::<Aabb>())
            + others * size_of::<u32>()
    }

    /// True if no leaf's groups are kept.
    pub fn is_empty(&self) -> bool {
        self.groups.is_empty() && self.others.is_empty()
    }
}
