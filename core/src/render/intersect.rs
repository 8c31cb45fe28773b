//! The scene's ray queries over every primitive: triangles and bounded solids through the octree,
//! unbounded solids (half-spaces) beside it.
//!
//! Where the octree's leaves are large (many overlapping spheres), the closest-hit and shadow
//! queries test lone spheres in groups ([`SphereGroup`]), to the same answers: the groups the
//! scene keeps per large leaf ([`Scene::leaf_spheres`]), else groups gathered as the walk
//! goes. Elsewhere four neighbouring camera rays can find their closest hits together
//! ([`Scene::closest_hits4`]), each the one it finds alone.
//!
//! Shadow rays towards a light with a light buffer test the primitives it lists for their
//! direction instead of walking the octree ([`Scene::shadowed`]).
//!
//! Both queries follow the octree's rule for the closest hit: the smallest `t`, ties to the
//! smallest primitive index (triangles first, then solids), so every machine picks the same one.
//! Each query adds the cells it entered and the tests it made to its [`QueryScratch`]'s
//! [`QueryWork`].

use crate::accel::light_buffer::Candidates;
use crate::accel::octree::{
    lanes_of, per_lane, GroupBlocks, GroupTests, Packet, PacketStack, LANES,
};
use crate::accel::work::QueryWork;
use crate::geom::axis_planes::AxisPlanes;
use crate::geom::hit::{closer, Closest, RayHit};
use crate::geom::solid::lone_sphere::SphereGroup;
use crate::geom::solid::prepared::{SolidHit, SpanScratch};
use crate::geom::triangle::{intersect, intersect4, RayFrame, RayFrame4, TriangleHit};
use crate::math::aabb::Aabb;
use crate::math::float::gamma;
use crate::math::ray::Ray;
use crate::scene::Scene;
use core::cell::OnceCell;
use glam::Vec4;

/// How many blockers each light remembers for [`Scene::shadowed`] (two: 0.94× on gears_4
/// against one; four gave no more).
pub const SHADOW_CACHE: usize = 2;

/// Where the triangles next to a light's latest blocker are in the scene's list, tried (in this
/// order) after the blockers it remembers: a polygon's triangles, a mesh's and a patch's are
/// listed together, so a shadow ray that just misses the latest blocker mostly crosses a
/// triangle a place or two from it. SPD's gears, when their faces were fanned into up to 142
/// thin triangles: gears_3 −9.4 % instructions with ±1 and ±2, −7.1 % with ±1 alone, −10.2 %
/// with ±3 as well; tetra_8 +0.7 % (its shadow rays that miss the remembered triangle and its
/// neighbours walk anyway). With the faces cut by ear clipping (compact triangles): gears_4
/// −0.8 %, gears_3 +0.3 %.
pub const NEIGHBOURS: [i32; 4] = [-1, 1, -2, 2];

/// What a light remembers of its latest shadow rays, for [`Scene::shadowed`] to try first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShadowMemory {
    /// The primitives that blocked its latest blocked shadow rays, the latest first.
    pub blockers: [Option<u32>; SHADOW_CACHE],
    /// True if its latest shadow ray reached it. The next most likely does too (the lit part of
    /// a floor), so the blockers are not tried first: they would only add tests. They are kept
    /// for the next shadow.
    pub reached: bool,
}

impl ShadowMemory {
    /// Puts blocker `i` in front, the others after it in their order (`i` once).
    fn put_first(&mut self, i: u32) {
        let k = self.blockers.iter().position(|&b| b == Some(i));
        let k = k.unwrap_or(SHADOW_CACHE - 1);
        self.blockers[..=k].rotate_right(1);
        self.blockers[0] = Some(i);
    }
}

/// What [`Scene::shadowed`] knows of a shadow ray besides the ray: the light it goes to (its
/// index in [`Scene::lights`], for the light's [`LightBuffer`](crate::accel::light_buffer::LightBuffer);
/// `None` walks the octree), what the light remembers, and the triangle the ray leaves.
pub type ShadowOf<'a> = (Option<usize>, &'a mut ShadowMemory, Option<u32>);

/// A hit of one primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrimitiveHit {
    /// A triangle (index into the scene's triangles).
    Triangle(u32, TriangleHit),
    /// A solid object (index into the scene's objects).
    Solid(u32, SolidHit),
}

/// What one tracer's ray queries reuse and count: the solids' span buffers, the packet walk's
/// stack and the work done.
#[derive(Clone, Debug, Default)]
pub struct QueryScratch {
    /// Buffers of the solids' span evaluation.
    pub spans: SpanScratch,
    /// The stack of [`Scene::closest_hits4`]'s walk.
    pub packet_stack: PacketStack,
    /// Cells entered and primitives tested so far.
    pub work: QueryWork,
}

impl RayHit for PrimitiveHit {
    #[inline]
    fn t(&self) -> f32 {
        match self {
            PrimitiveHit::Triangle(_, h) => h.t,
            PrimitiveHit::Solid(_, h) => h.t,
        }
    }
    #[inline]
    fn t_error(&self) -> f32 {
        match self {
            PrimitiveHit::Triangle(_, h) => h.t_error,
            PrimitiveHit::Solid(_, h) => h.t_error,
        }
    }
}

/// What one ray's tests share: the triangle test's frame, made at the ray's first triangle
/// test (most shadow rays of a scene of spheres and cylinders meet none), and the slab test's
/// reciprocal direction.
struct QueryFrame {
    triangles: OnceCell<RayFrame>,
    inv_dir: glam::Vec3,
}

impl QueryFrame {
    fn new(ray: &Ray) -> QueryFrame {
        QueryFrame {
            triangles: OnceCell::new(),
            inv_dir: (glam::Vec3A::ONE / glam::Vec3A::from(ray.dir)).into(),
        }
    }

    /// The triangle test's frame of `ray` (the ray this frame was made for).
    #[inline(always)]
    fn triangles(&self, ray: &Ray) -> &RayFrame {
        self.triangles.get_or_init(|| RayFrame::new(ray))
    }
}

/// One closest-hit query's tests for [`Octree::closest_hit_grouped`]: lone spheres in groups,
/// together (their hits are [`Scene::test_primitive`]'s to the bit), the rest one by one.
struct SceneTests<'a> {
    scene: &'a Scene,
    frame: &'a QueryFrame,
    ray: &'a Ray,
    spans: &'a mut SpanScratch,
    spheres: SphereGroup,
}

impl GroupTests<PrimitiveHit> for SceneTests<'_> {
    #[inline(always)]
    fn test(&mut self, i: u32, bound: f32) -> Option<PrimitiveHit> {
        self.scene
            .test_primitive(self.frame, self.ray, i, bound, self.spans)
    }

    #[inline]
    fn test_group(&mut self, group: &[u32], closest: &mut Closest<PrimitiveHit>) {
        let n = self.scene.triangle_points.len() as u32;
        self.spheres.clear();
        for &i in group {
            match i
                .checked_sub(n)
                .and_then(|j| self.scene.solids.lone_sphere(j))
            {
                Some(sphere) => self.spheres.push(i, sphere),
                None => {
                    if let Some(h) = self.test(i, closest.bound()) {
                        closest.offer(i, h);
                    }
                }
            }
        }
        if !self.spheres.is_empty() {
            self.spheres
                .test(self.ray, closest, |i, h| PrimitiveHit::Solid(i - n, h));
        }
    }

    #[inline]
    fn test_leaf(&mut self, start: u32, closest: &mut Closest<PrimitiveHit>) -> Option<u64> {
        let leaf = self.scene.leaf_spheres.leaf(start)?;
        let n = self.scene.triangle_points.len() as u32;
        for &i in leaf.others {
            if let Some(h) = self.test(i, closest.bound()) {
                closest.offer(i, h);
            }
        }
        let mut tested = leaf.others.len();
        let grow = origin_reach(self.ray);
        for (group, reach) in leaf.groups.iter().zip(leaf.reach) {
            if may_reach(reach, grow, self.ray, self.frame, closest.bound()) {
                group.test(self.ray, closest, |i, h| PrimitiveHit::Solid(i - n, h));
                tested += group.len();
            }
        }
        Some(tested as u64)
    }
}

/// The triangles a shadow ray cannot meet in front of its origin: the one it leaves from and
/// the others in that one's axis-aligned plane, if it shares one ([`AxisPlanes`]); see
/// [`Scene::shadowed`].
#[derive(Clone, Copy)]
struct LeftBehind {
    triangle: Option<u32>,
    plane: u32,
}

impl LeftBehind {
    fn new(scene: &Scene, leaving: Option<u32>) -> LeftBehind {
        LeftBehind {
            triangle: leaving,
            plane: leaving.map_or(AxisPlanes::NONE, |t| scene.axis_planes.of(t)),
        }
    }

    /// True if primitive `i` is one of them.
    #[inline(always)]
    fn holds(&self, scene: &Scene, i: u32) -> bool {
        Some(i) == self.triangle
            || (self.plane != AxisPlanes::NONE && scene.axis_planes.of(i) == self.plane)
    }
}

/// One shadow query's tests for [`Octree::any_hit_grouped`]: lone spheres in groups, the rest
/// one by one, and never a triangle `left` holds (see [`Scene::shadowed`]).
struct SceneBlocks<'a> {
    scene: &'a Scene,
    frame: &'a QueryFrame,
    ray: &'a Ray,
    t_max: f32,
    spans: &'a mut SpanScratch,
    /// Made when a leaf is first tested as a group.
    spheres: Option<SphereGroup>,
    left: LeftBehind,
}

impl SceneBlocks<'_> {
    /// True if primitive `i` blocks the ray; the caller has checked that `left` does not hold
    /// it.
    #[inline(always)]
    fn tested(&mut self, i: u32) -> bool {
        self.scene
            .blocks(self.frame, self.ray, i, self.t_max, self.spans)
    }
}

impl GroupBlocks for SceneBlocks<'_> {
    #[inline(always)]
    fn blocks(&mut self, i: u32) -> bool {
        !self.left.holds(self.scene, i) && self.tested(i)
    }

    #[inline]
    fn blocks_group(&mut self, group: &[u32]) -> Option<u32> {
        let n = self.scene.triangle_points.len() as u32;
        let mut spheres = self.spheres.take().unwrap_or_default();
        spheres.clear();
        let mut found = None;
        for &i in group {
            match i
                .checked_sub(n)
                .and_then(|j| self.scene.solids.lone_sphere(j))
            {
                Some(sphere) => spheres.push(i, sphere),
                None if self.blocks(i) => {
                    found = Some(i);
                    break;
                }
                None => {}
            }
        }
        let found = found.or_else(|| spheres.blocks(self.ray, self.t_max));
        self.spheres = Some(spheres);
        found
    }

    #[inline]
    fn blocks_leaf(&mut self, start: u32) -> Option<(Option<u32>, u64)> {
        let leaf = self.scene.leaf_spheres.leaf(start)?;
        let mut tested = 0u64;
        for &i in leaf.others {
            tested += 1;
            if self.blocks(i) {
                return Some((Some(i), tested));
            }
        }
        let grow = origin_reach(self.ray);
        for (group, reach) in leaf.groups.iter().zip(leaf.reach) {
            if !may_reach(reach, grow, self.ray, self.frame, self.t_max) {
                continue;
            }
            tested += group.len() as u64;
            if let Some(i) = group.blocks(self.ray, self.t_max) {
                return Some((Some(i), tested));
            }
        }
        Some((None, tested))
    }
}

/// How much further than a sphere group's reach ([`SphereGroup::reach`]) a sphere test of `ray`
/// can report a hit, in world units. The test rounds the ray's offset from each centre, so its
/// hits stray from the sphere by a few roundings of that offset's size: the reach's margin
/// covers the centre's and the sphere's share, this the origin's (`gamma(32)`, twice the
/// roundings of a crossing's error bound, of twice the origin's largest coordinate).
#[inline]
fn origin_reach(ray: &Ray) -> f32 {
    gamma(32) * 2.0 * ray.origin.abs().max_element()
}

/// True unless `ray` provably gets no hit below `t_max` from the sphere group whose reach is
/// `reach`: the reach grown by `grow` ([`origin_reach`] of the ray) meets the ray within
/// `[0, t_max]`.
#[inline(always)]
fn may_reach(reach: &Aabb, grow: f32, ray: &Ray, frame: &QueryFrame, t_max: f32) -> bool {
    reach
        .grown(grow)
        .intersect(ray, frame.inv_dir, t_max)
        .is_some()
}

impl Scene {
    /// Primitive index of solid object `j`.
    #[inline]
    fn solid_index(&self, j: u32) -> u32 {
        self.triangle_points.len() as u32 + j
    }

    /// Tests primitive `i` against the ray. Inlined where it is called, with the triangle test
    /// ([`intersect`]): as a call of its own it saved and restored registers around every
    /// triangle test (16 instructions a test on gears_3, whose test takes about 116).
    #[inline(always)]
    fn test_primitive(
        &self,
        frame: &QueryFrame,
        ray: &Ray,
        i: u32,
        t_max: f32,
        spans: &mut SpanScratch,
    ) -> Option<PrimitiveHit> {
        match self.triangle_points.get(i as usize) {
            Some(p) => {
                intersect(frame.triangles(ray), p, t_max).map(|h| PrimitiveHit::Triangle(i, h))
            }
            None => self.test_solid(frame, ray, i, t_max, spans),
        }
    }

    /// [`Scene::test_primitive`] for a solid's primitive index `i`.
    #[inline]
    fn test_solid(
        &self,
        frame: &QueryFrame,
        ray: &Ray,
        i: u32,
        t_max: f32,
        spans: &mut SpanScratch,
    ) -> Option<PrimitiveHit> {
        let j = i - self.triangle_points.len() as u32;
        self.solids
            .first_hit_in_box(j, ray, frame.inv_dir, t_max, spans)
            .map(|h| PrimitiveHit::Solid(j, h))
    }

    /// The closest hit of `ray` with `0 < t < t_max` over all primitives.
    pub fn closest_hit(
        &self,
        ray: &Ray,
        t_max: f32,
        scratch: &mut QueryScratch,
    ) -> Option<PrimitiveHit> {
        let work = &mut scratch.work;
        if self.solids.is_empty() {
            // Triangles only (the seed's scenes): the octree's own triangle query.
            return self
                .octree
                .closest_hit_counted(&self.triangle_points, ray, t_max, work)
                .map(|h| PrimitiveHit::Triangle(h.triangle, h.tri));
        }
        let spans = &mut scratch.spans;
        let frame = QueryFrame::new(ray);
        let best = if self.group_spheres {
            let mut tests = SceneTests {
                scene: self,
                frame: &frame,
                ray,
                spans,
                spheres: SphereGroup::new(),
            };
            self.octree
                .closest_hit_grouped(ray, t_max, work, &mut tests)
        } else {
            self.octree.closest_hit_with(ray, t_max, work, |i, bound| {
                self.test_primitive(&frame, ray, i, bound, spans)
            })
        };
        self.closest_unbounded(ray, t_max, best, spans, work)
    }

    /// [`Scene::closest_hit`] of `ray` with no bound, for a ray that starts inside the transparent
    /// lone sphere `object` (refracted into it, or reflected inside it): the sphere and the few
    /// primitives near it tested instead of a walk ([`SphereInteriors`], whose module doc proves
    /// the answer the walk's). `None` where that cannot answer: the sphere has no entry, the ray
    /// starts outside its box, or the best of those hits lies outside it; the caller walks.
    ///
    /// [`SphereInteriors`]: crate::accel::sphere_interiors::SphereInteriors
    pub fn closest_hit_inside(
        &self,
        object: u32,
        ray: &Ray,
        scratch: &mut QueryScratch,
    ) -> Option<Option<PrimitiveHit>> {
        let inside = self.sphere_interiors.of(object)?;
        if !inside.bounds.holds(ray.origin) {
            return None;
        }
        let (spans, work) = (&mut scratch.spans, &mut scratch.work);
        let mut closest = Closest::new(f32::INFINITY);
        let n = self.triangle_points.len() as u32;
        // `LoneSphere::first_hit` is a lone sphere's `test_primitive`. The sphere first: its
        // hit bounds the others, and a neighbour the ray stays clear of up to that bound
        // reports nothing that could win.
        let (i, sphere) = inside.sphere;
        if let Some(h) = sphere.first_hit(ray, f32::INFINITY) {
            closest.offer(i, PrimitiveHit::Solid(i - n, h));
        }
        let mut tests = 1 + inside.others.len() as u64;
        for &(i, sphere, clearance) in inside.spheres {
            if clearance.clears(ray, closest.bound()) {
                continue;
            }
            tests += 1;
            if let Some(h) = sphere.first_hit(ray, closest.bound()) {
                closest.offer(i, PrimitiveHit::Solid(i - n, h));
            }
        }
        if !inside.others.is_empty() {
            let frame = QueryFrame::new(ray);
            for &i in inside.others {
                if let Some(h) = self.test_primitive(&frame, ray, i, closest.bound(), spans) {
                    closest.offer(i, h);
                }
            }
        }
        work.intersection_tests += tests;
        let (_, best) = closest.best()?;
        if !inside.ends.holds(ray.at(best.t())) {
            return None;
        }
        Some(self.closest_unbounded(ray, f32::INFINITY, closest.best(), spans, work))
    }

    /// The closest hits of four rays with `0 < t < t_max`, each what [`Scene::closest_hit`]
    /// returns for it. Neighbouring camera rays walk the octree together
    /// ([`Octree::closest_hits4`](crate::accel::octree::Octree::closest_hits4)); where lone
    /// spheres are tested in groups, or the four rays do not go the same way along every axis
    /// (no [`Packet`]), the rays go one at a time, and where all four miss the tree
    /// ([`Octree::missed_by4`](crate::accel::octree::Octree::missed_by4)) none walks.
    /// `leaving[l]` is the triangle ray `l` leaves, if it leaves one (its origin moved off that
    /// triangle's plane by [`LeavingOrigins`](crate::math::ray::LeavingOrigins), towards its
    /// direction): the ray cannot meet it again, as [`Scene::shadowed`] says, so where the four
    /// rays walk together it is not tested.
    pub fn closest_hits4(
        &self,
        rays: &[Ray; LANES],
        t_max: f32,
        leaving: [Option<u32>; LANES],
        scratch: &mut QueryScratch,
    ) -> [Option<PrimitiveHit>; LANES] {
        self.closest_hits4_walking(rays, t_max, leaving, true, scratch)
    }

    /// [`Scene::closest_hits4`] for four rays from the camera that enter no cell holding a
    /// primitive (a clear packet of the camera's cover, [`Scene::camera_cover`]): the same
    /// answers with no walk, only the large primitives and the unbounded solids tested.
    pub fn closest_hits4_beside_tree(
        &self,
        rays: &[Ray; LANES],
        scratch: &mut QueryScratch,
    ) -> [Option<PrimitiveHit>; LANES] {
        self.closest_hits4_walking(rays, f32::INFINITY, [None; LANES], false, scratch)
    }

    /// [`Scene::closest_hits4`], walking the tree only if `walk` (the caller knows the rays
    /// enter no cell holding a primitive otherwise).
    fn closest_hits4_walking(
        &self,
        rays: &[Ray; LANES],
        t_max: f32,
        leaving: [Option<u32>; LANES],
        walk: bool,
        scratch: &mut QueryScratch,
    ) -> [Option<PrimitiveHit>; LANES] {
        // Rays that part (mirror rays off spheres, mostly) go one at a time, without the four
        // rays' set-up for the tests; where spheres are tested in groups, all do that walk.
        let packet = if walk && self.group_spheres {
            None
        } else {
            Packet::new(rays)
        };
        let Some(packet) = packet else {
            return per_lane(|l| self.closest_hit(&rays[l], t_max, scratch));
        };
        let (spans, work, stack) = (
            &mut scratch.spans,
            &mut scratch.work,
            &mut scratch.packet_stack,
        );
        let nothing_filed = !walk && self.octree.large().is_empty();
        if nothing_filed || self.octree.missed_by4(&packet, t_max) {
            // No set-up for tests no ray will make.
            return per_lane(|l| self.closest_unbounded(&rays[l], t_max, None, spans, work));
        }
        let triangles = per_lane(|l| RayFrame::new(&rays[l]));
        let frame4 = RayFrame4::new(&triangles);
        let n = self.triangle_points.len() as u32;
        let hits = self.octree.closest_hits4(
            &packet,
            t_max,
            leaving,
            walk,
            (work, stack),
            |asked, i, closest| {
                let Some(triangle) = self.triangle_points.get(i as usize) else {
                    let (mut asked, j) = (asked, i - n);
                    let (origins, dirs) = (&packet.origin, &packet.dir);
                    // The four rays' sure misses at once: most tests end there.
                    if let Some(sphere) = self.solids.lone_sphere(j) {
                        asked &= !sphere.surely_missed_by4(origins, dirs);
                    } else if let Some(b) = self.solids.reject_box(j) {
                        let bounds = Vec4::from(per_lane(|l| closest[l].bound()));
                        asked &= !b.missed_by4(origins, &packet.inv_dir, bounds);
                        if asked != 0 {
                            asked &= !self.solids.cylinder_missed_by4(j, origins, dirs);
                        }
                    }
                    // `first_hit` gives `first_hit_in_box`'s answer without its box: a lane
                    // left here passed the box above, or the box could not be asked four at
                    // a time (a reciprocal direction that overflows, a NaN), or the object has
                    // none.
                    for l in lanes_of(asked) {
                        let hit = self
                            .solids
                            .first_hit(j, &rays[l], closest[l].bound(), spans);
                        if let Some(h) = hit {
                            closest[l].offer(i, PrimitiveHit::Solid(j, h));
                        }
                    }
                    return;
                };
                // Four rays at once where they share an axis permutation, one at a time where
                // they do not, or where only the one-ray test's `f64` steps can answer.
                let undecided = match &frame4 {
                    Some(f) => {
                        let bounds = Vec4::from(per_lane(|l| closest[l].bound()));
                        let four = intersect4(f, triangle, asked, bounds);
                        for l in lanes_of(four.hit) {
                            closest[l].offer(i, PrimitiveHit::Triangle(i, four.of(l)));
                        }
                        four.undecided
                    }
                    None => asked,
                };
                for l in lanes_of(undecided) {
                    if let Some(h) = intersect(&triangles[l], triangle, closest[l].bound()) {
                        closest[l].offer(i, PrimitiveHit::Triangle(i, h));
                    }
                }
            },
        );
        per_lane(|l| {
            let best = hits[l];
            self.closest_unbounded(&rays[l], t_max, best, spans, work)
        })
    }

    /// The closer of `best` and the unbounded solids' closest hit of `ray` (their tests added
    /// to `work`).
    fn closest_unbounded(
        &self,
        ray: &Ray,
        t_max: f32,
        mut best: Option<(u32, PrimitiveHit)>,
        spans: &mut SpanScratch,
        work: &mut QueryWork,
    ) -> Option<PrimitiveHit> {
        if self.unbounded.is_empty() {
            // Most scenes: no half-space (about 20 instructions a ray on tetra_8 otherwise).
            return best.map(|(_, h)| h);
        }
        work.intersection_tests += self.unbounded.len() as u64;
        for &j in &self.unbounded {
            let bound = best.map_or(t_max, |(_, h)| {
                h.t().min(t_max) * (1.0 + 4.0 * crate::math::float::MACHINE_EPSILON)
            });
            let i = self.solid_index(j);
            if let Some(h) = self.solids.first_hit(j, ray, bound.min(t_max), spans) {
                if closer(h.t, i, &best) {
                    best = Some((i, PrimitiveHit::Solid(j, h)));
                }
            }
        }
        best.map(|(_, h)| h)
    }

    /// True if primitive `i` blocks `ray` provably before `t_max`: `0 < t` and
    /// `t + t_error < t_max`.
    #[inline]
    fn blocks(
        &self,
        frame: &QueryFrame,
        ray: &Ray,
        i: u32,
        t_max: f32,
        spans: &mut SpanScratch,
    ) -> bool {
        self.test_primitive(frame, ray, i, t_max, spans)
            .is_some_and(|h| h.t() + h.t_error() < t_max)
    }

    /// [`Scene::any_hit`] for a shadow ray towards light `light` (see [`ShadowOf`]), trying
    /// first, unless the latest shadow ray towards the same light reached it, the primitives that
    /// blocked the latest blocked ones, the latest first (POV-Ray's light buffer keeps one), then
    /// the triangles listed next to the latest ([`NEIGHBOURS`]). Neighbouring pixels are mostly
    /// shadowed by the same object, and where two objects' shadows meet or alternate by the
    /// other, so a few tests often settle the query. The answer is
    /// `any_hit`'s whatever is remembered: `memory` only decides what is tried first. A blocker
    /// found, remembered or by the walk, moves to the front of its blockers; they are kept as
    /// they are when nothing blocks.
    ///
    /// Where the light has a [`LightBuffer`](crate::accel::light_buffer::LightBuffer) that
    /// answers the ray, the primitives it lists are tested instead of walking the octree: the
    /// same answer, since every primitive that can block the ray is listed.
    ///
    /// `leaving` is the triangle the ray leaves from, if any, with its origin moved off the
    /// triangle's plane (by at least the point's error bound) to the side the ray goes: the ray
    /// meets that plane at `t ≤ 0`, which the triangle test never reports (it reports only a `t`
    /// provably above 0), so it is not tested. On a large floor that test could not tell the
    /// sign of `t` in `f32` and went to `f64` for every shadow ray. Nor are the other triangles
    /// of its plane where that is an axis-aligned plane they share exactly ([`AxisPlanes`]):
    /// the same plane, so the same reason (on SPD's floors, the quad's other half).
    pub fn shadowed(
        &self,
        ray: &Ray,
        t_max: f32,
        scratch: &mut QueryScratch,
        (light, memory, leaving): ShadowOf<'_>,
    ) -> bool {
        let frame = QueryFrame::new(ray);
        let left = LeftBehind::new(self, leaving);
        if self.remembered_blocks(&frame, ray, t_max, left, memory, scratch) {
            return true;
        }
        let (spans, work) = (&mut scratch.spans, &mut scratch.work);
        let mut tests = SceneBlocks {
            scene: self,
            frame: &frame,
            ray,
            t_max,
            spans,
            spheres: None,
            left,
        };
        let listed = light
            .and_then(|l| self.light_buffers.get(l)?.as_ref())
            .map_or(Candidates::Walk, |b| b.candidates(ray, t_max));
        let blocker = match listed {
            Candidates::List { entries, depth } => {
                work.octree_cells += 1;
                entries
                    .iter()
                    .take_while(|e| e.near < depth)
                    .map(|e| e.index)
                    .filter(|&i| !left.holds(self, i))
                    .find(|&i| {
                        work.intersection_tests += 1;
                        tests.tested(i)
                    })
            }
            Candidates::Walk if self.group_spheres => {
                self.octree.any_hit_grouped(ray, t_max, work, &mut tests)
            }
            Candidates::Walk => self
                .octree
                .first_blocker_with(ray, t_max, work, |i| tests.blocks(i)),
        };
        let blocker = blocker.or_else(|| self.unbounded_blocker(work, &mut |i| tests.blocks(i)));
        memory.reached = blocker.is_none();
        if let Some(i) = blocker {
            memory.put_first(i);
        }
        blocker.is_some()
    }

    /// True if a primitive `memory` remembers blocks `ray`, or a triangle listed next to the
    /// latest of them ([`NEIGHBOURS`]); tried only where the latest shadow ray towards the light
    /// was blocked. The blocker found goes to the front of the memory.
    #[inline(always)]
    fn remembered_blocks(
        &self,
        frame: &QueryFrame,
        ray: &Ray,
        t_max: f32,
        left: LeftBehind,
        memory: &mut ShadowMemory,
        scratch: &mut QueryScratch,
    ) -> bool {
        if memory.reached {
            return false;
        }
        // A scratch carried over from another scene may remember an index this one lacks.
        let primitives = self.solid_index(self.solids.len() as u32);
        let (spans, work) = (&mut scratch.spans, &mut scratch.work);
        let mut found = None;
        for k in 0..SHADOW_CACHE {
            if let Some(i) = memory.blockers[k].filter(|&i| i < primitives && !left.holds(self, i))
            {
                work.intersection_tests += 1;
                if self.blocks(frame, ray, i, t_max, spans) {
                    found = Some(i);
                    break;
                }
            }
        }
        let triangles = self.triangle_points.len() as u32;
        if let Some(latest) = memory.blockers[0].filter(|&i| found.is_none() && i < triangles) {
            for k in NEIGHBOURS {
                let j = latest.wrapping_add_signed(k);
                if j < triangles && !left.holds(self, j) {
                    work.intersection_tests += 1;
                    if self.blocks(frame, ray, j, t_max, spans) {
                        found = Some(j);
                        break;
                    }
                }
            }
        }
        if let Some(i) = found {
            memory.put_first(i);
        }
        found.is_some()
    }

    /// True if `ray` hits any primitive provably before `t_max`: `0 < t` and
    /// `t + t_error < t_max` (shadow and occlusion rays).
    pub fn any_hit(&self, ray: &Ray, t_max: f32, scratch: &mut QueryScratch) -> bool {
        let (spans, work) = (&mut scratch.spans, &mut scratch.work);
        if self.solids.is_empty() {
            return self
                .octree
                .any_hit_counted(&self.triangle_points, ray, t_max, work);
        }
        let frame = QueryFrame::new(ray);
        let mut test = |i: u32| self.blocks(&frame, ray, i, t_max, spans);
        self.octree.any_hit_with(ray, t_max, work, &mut test)
            || self.unbounded_blocker(work, &mut test).is_some()
    }

    /// The first unbounded solid (in order) for which `blocks` holds, as a primitive index;
    /// counts the tests in `work`.
    fn unbounded_blocker(
        &self,
        work: &mut QueryWork,
        blocks: &mut impl FnMut(u32) -> bool,
    ) -> Option<u32> {
        self.unbounded
            .iter()
            .map(|&j| self.solid_index(j))
            .find(|&i| {
                work.intersection_tests += 1;
                blocks(i)
            })
    }
}
