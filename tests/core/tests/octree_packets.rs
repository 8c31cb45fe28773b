//! Four rays walked together (`Octree::closest_hits4`) find, each, exactly the triangle and the
//! bit-identical `t` it finds walked alone, and the triangle testing every triangle finds: on
//! soups, closed meshes and grids whose edges lie on the octree's centre planes, with packets
//! of neighbouring rays as a camera sends them and rays through cell edges and corners.

use glam::Vec3;
use std::cell::RefCell;
use strahl_core::accel::octree::{
    brute_force_closest_hit, lanes_of, Octree, OctreeParams, Packet, PacketStack, LANES,
};
use strahl_core::accel::work::QueryWork;
use strahl_core::geom::triangle::{intersect, RayFrame};
use strahl_core::math::ray::Ray;
use strahl_core::scene::mesh::Rng;
use strahl_core_tests::meshes::{boundary_grid, bounds, closed_sphere, positions, random_soup};

fn key(h: Option<(u32, f32)>) -> Option<(u32, u32)> {
    h.map(|(i, t)| (i, t.to_bits()))
}

thread_local! {
    /// One packet stack for every walk of a test, whatever its tree, as a tracer keeps one:
    /// what a walk leaves on it must not change the next walk's answers.
    static STACK: RefCell<PacketStack> = RefCell::default();
}

/// Compares the four rays' hits walked together, where they make a [`Packet`], with each
/// walked alone and with brute force. Returns how many of them hit, and whether they walked
/// together.
fn check(tree: &Octree, tris: &[[Vec3; 3]], rays: &[Ray; LANES]) -> (usize, bool) {
    let frames = rays.each_ref().map(RayFrame::new);
    let mut work = QueryWork::default();
    let packet = Packet::new(rays);
    let four = packet.as_ref().map(|packet| {
        STACK.with_borrow_mut(|stack| {
            tree.closest_hits4(
                packet,
                f32::INFINITY,
                [None; LANES],
                true,
                (&mut work, stack),
                |lanes, i, closest| {
                    for l in lanes_of(lanes) {
                        let tri = &tris[i as usize];
                        if let Some(h) = intersect(&frames[l], tri, closest[l].bound()) {
                            closest[l].offer(i, h);
                        }
                    }
                },
            )
        })
    });
    if let (Some(packet), Some(four)) = (&packet, four) {
        if tree.missed_by4(packet, f32::INFINITY) {
            // Said to meet nothing: the walk found nothing and entered no cell.
            assert_eq!(four.map(|h| h.is_some()), [false; LANES], "{rays:?}");
            assert_eq!(work.octree_cells, 0, "{rays:?}");
        }
    }
    let mut hits = 0;
    for (l, ray) in rays.iter().enumerate() {
        let alone = tree.closest_hit(tris, ray, f32::INFINITY);
        let alone = key(alone.map(|h| (h.triangle, h.tri.t)));
        if let Some(four) = four {
            assert_eq!(
                key(four[l].map(|(i, h)| (i, h.t))),
                alone,
                "lane {l}: {rays:?}"
            );
        }
        let brute = brute_force_closest_hit(tris, ray, f32::INFINITY);
        assert_eq!(
            alone,
            key(brute.map(|h| (h.triangle, h.tri.t))),
            "lane {l}: {ray:?}"
        );
        hits += usize::from(alone.is_some());
    }
    (hits, packet.is_some())
}

/// Packets as a camera sends them: from one eye around the triangles' bounds, four directions
/// a small step apart, aimed at random points, vertices or points on faces.
fn camera_packets(tris: &[[Vec3; 3]], n: usize, seed: u64) -> usize {
    let tree = Octree::build(tris, &OctreeParams::default());
    let (lo, hi) = bounds(tris);
    let ext = hi - lo;
    let mut rng = Rng::new(seed);
    let (mut hits, mut together) = (0, 0);
    for i in 0..n {
        let eye =
            lo - ext * 0.5 + ext * 2.0 * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let t = &tris[(rng.next_u64() % tris.len() as u64) as usize];
        let target = match i % 3 {
            0 => lo + ext * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
            1 => t[(rng.next_u64() % 3) as usize],
            _ => (t[0] + t[1] + t[2]) / 3.0,
        };
        let step = ext.length() * 1e-3 * rng.next_f32();
        let right = (target - eye).cross(Vec3::Z).normalize_or(Vec3::X) * step;
        let rays = std::array::from_fn(|l| Ray::new(eye, target + right * l as f32 - eye));
        let (found, walked) = check(&tree, tris, &rays);
        hits += found;
        together += usize::from(walked);
    }
    // Neighbouring camera rays go the same way along every axis, but where one crosses zero.
    assert!(
        together > n * 9 / 10,
        "only {together} of {n} packets walked together"
    );
    hits
}

#[test]
fn random_soup_packets() {
    let tris = random_soup(600, &mut Rng::new(3));
    let hits = camera_packets(&tris, 10_000, 21);
    assert!(hits > 10_000, "too few hits ({hits}) to mean anything");
}

#[test]
fn closed_sphere_packets() {
    let tris = positions(&closed_sphere(40, 20, 0.02, &mut Rng::new(4)));
    let hits = camera_packets(&tris, 8_000, 22);
    assert!(hits > 10_000, "too few hits ({hits}) to mean anything");
}

/// Packets that pass the tree by, all four rays or some of them: rays aimed at points beside
/// the triangles' bounds (the background around a model) find nothing, as walked alone, and
/// their neighbours still find their hits. Packets [`Octree::missed_by4`] says pass it by
/// find nothing and enter no cell (`check`).
#[test]
fn packets_beside_the_tree() {
    let tris = random_soup(400, &mut Rng::new(6));
    let tree = Octree::build(&tris, &OctreeParams::default());
    let (lo, hi) = bounds(&tris);
    let ext = hi - lo;
    let mut rng = Rng::new(25);
    let (mut hits, mut blank, mut passed_by) = (0, 0, 0);
    for i in 0..6_000 {
        let eye = lo - ext + ext * 3.0 * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let inside = lo + ext * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        // Beside the bounds: pushed out along one axis, past the far side.
        let mut beside = inside;
        let a = i % 3;
        beside[a] = if rng.next_f32() < 0.5 {
            lo[a] - ext[a]
        } else {
            hi[a] + ext[a]
        };
        let rays: [Ray; LANES] = std::array::from_fn(|l| {
            let target = if i % 2 == 0 || l < 2 { beside } else { inside };
            let wiggle = ext * 1e-3 * l as f32;
            Ray::new(eye, target + wiggle - eye)
        });
        let (found, walked) = check(&tree, &tris, &rays);
        hits += found;
        blank += usize::from(i % 2 == 0 && found == 0);
        let packet = Packet::new(&rays);
        assert_eq!(packet.is_some(), walked);
        passed_by += usize::from(packet.is_some_and(|p| tree.missed_by4(&p, f32::INFINITY)));
    }
    assert!(blank > 1_000, "only {blank} packets met nothing");
    // Rays beside the bounds mostly miss the root cell too: those need no walk at all.
    assert!(
        passed_by > 500,
        "only {passed_by} packets said to pass the tree by"
    );
    assert!(hits > 1_000, "too few hits ({hits}) to mean anything");
}

/// A grid whose edges and vertices lie on the centre planes, with rays from grid points along
/// diagonals: their crossings of two or three centre planes tie, at cell edges and corners.
#[test]
fn grid_packets_through_cell_edges_and_corners() {
    let tris = positions(&boundary_grid(16));
    let tree = Octree::build(&tris, &OctreeParams::default());
    let (lo, hi) = bounds(&tris);
    let cell = (hi - lo) / 16.0;
    let mut rng = Rng::new(23);
    let mut hits = 0;
    for i in 0..6_000 {
        let grid_point = |rng: &mut Rng| {
            let k = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 20.0;
            lo - cell * 2.0 + cell * k.floor()
        };
        let signs = Vec3::new(1.0, -1.0, 1.0).map(|s| if rng.next_f32() < 0.5 { s } else { -s });
        let rays = std::array::from_fn(|l| {
            let mut dir = Vec3::ONE;
            if i % 2 == 1 && l > 0 {
                dir[l % 3] = 2.0; // along a face diagonal and off it
            }
            Ray::new(grid_point(&mut rng), dir * cell * signs)
        });
        let (found, walked) = check(&tree, &tris, &rays);
        assert!(walked, "rays of one sign walk together: {rays:?}");
        hits += found;
    }
    assert!(hits > 2_000, "too few hits ({hits}) to mean anything");
}

/// Packets whose rays go different ways, or have a zero component, make no [`Packet`] (the
/// scene walks them one ray at a time); those whose rays share every sign do and walk together.
#[test]
fn mixed_packets() {
    let tris = random_soup(300, &mut Rng::new(5));
    let tree = Octree::build(&tris, &OctreeParams::default());
    let (lo, hi) = bounds(&tris);
    let mut rng = Rng::new(24);
    let (mut hits, mut together, mut apart) = (0, 0, 0);
    for i in 0..5_000 {
        let origin = lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let first = rng.direction();
        let rays: [Ray; LANES] = std::array::from_fn(|l| {
            // Half the packets near one direction (signs mostly shared), half at random.
            let mut dir = if i % 2 == 0 {
                first + rng.direction() * 0.05
            } else {
                rng.direction()
            };
            if (i + l) % 7 == 0 {
                dir[l % 3] = 0.0;
            }
            Ray::new(origin, dir)
        });
        let shared = (0..3)
            .all(|a| rays.iter().all(|r| r.dir[a] > 0.0) || rays.iter().all(|r| r.dir[a] < 0.0));
        let (found, walked) = check(&tree, &tris, &rays);
        assert_eq!(walked, shared, "{rays:?}");
        hits += found;
        together += usize::from(walked);
        apart += usize::from(!walked);
    }
    assert!(
        together > 500 && apart > 2_000,
        "{together} together, {apart} apart"
    );
    assert!(hits > 2_000, "too few hits ({hits}) to mean anything");
}
