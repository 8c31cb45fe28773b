//! The octree finds exactly the triangle and the bit-identical `t` that testing every triangle
//! finds, for hundreds of thousands of rays on soups, closed meshes, boundary-aligned grids and
//! thousands of triangles in one spot.

use glam::Vec3;
use strahl_core::accel::octree::{brute_force_closest_hit, Octree, OctreeParams};
use strahl_core::math::ray::Ray;
use strahl_core::scene::mesh::{MeshBuilder, Rng};
use strahl_core_tests::meshes::{boundary_grid, bounds, closed_sphere, positions, random_soup};

fn key(h: Option<strahl_core::accel::octree::Hit>) -> Option<(u32, u32)> {
    h.map(|h| (h.triangle, h.tri.t.to_bits()))
}

/// Shoots `n` rays at `tris` from around their bounds and compares octree and brute force.
/// A third of the rays are aimed exactly at vertices, some have zero direction components.
fn compare(tris: &[[Vec3; 3]], params: &OctreeParams, n: usize, seed: u64) -> usize {
    let tree = Octree::build(tris, params);
    let (lo, hi) = bounds(tris);
    let ext = hi - lo;
    let mut rng = Rng::new(seed);
    let mut hits = 0;
    for i in 0..n {
        let origin =
            lo - ext * 0.25 + ext * 1.5 * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut dir = match i % 3 {
            0 => rng.direction(),
            1 => {
                let t = &tris[(rng.next_u64() % tris.len() as u64) as usize];
                t[(rng.next_u64() % 3) as usize] - origin
            }
            _ => {
                let t = &tris[(rng.next_u64() % tris.len() as u64) as usize];
                let (a, b) = (rng.next_f32(), rng.next_f32());
                (t[0] * (1.0 - a) + t[1] * a) * (1.0 - b) + t[2] * b - origin
            }
        };
        if i % 7 == 0 {
            dir[(i / 7) % 3] = if i % 2 == 0 { 0.0 } else { -0.0 };
        }
        if dir == Vec3::ZERO {
            continue;
        }
        let ray = Ray::new(origin, dir);
        let expected = brute_force_closest_hit(tris, &ray, f32::INFINITY);
        let got = tree.closest_hit(tris, &ray, f32::INFINITY);
        assert_eq!(key(got), key(expected), "ray {i}: {ray:?}");
        // Any-hit agrees with closest-hit about whether there is a hit at all.
        assert_eq!(
            tree.any_hit(tris, &ray, f32::INFINITY),
            expected.is_some(),
            "any-hit, ray {i}"
        );
        hits += usize::from(expected.is_some());
    }
    hits
}

#[test]
fn random_soup_matches() {
    let tris = random_soup(600, &mut Rng::new(1));
    let hits = compare(&tris, &OctreeParams::default(), 40_000, 11);
    assert!(hits > 10_000, "too few hits ({hits}) to mean anything");
}

#[test]
fn closed_sphere_and_torus_match() {
    let mut m = closed_sphere(40, 20, 0.02, &mut Rng::new(2));
    m.torus(Vec3::new(0.5, 0.0, 0.0), 1.2, 0.3, 48, 16, 0);
    let tris = positions(&m);
    let hits = compare(&tris, &OctreeParams::default(), 30_000, 12);
    assert!(hits > 10_000);
}

#[test]
fn boundary_aligned_grid_matches() {
    // Edges and vertices on the octree's centre planes; rays along the axes hit them exactly.
    let tris = positions(&boundary_grid(16));
    let hits = compare(
        &tris,
        &OctreeParams {
            max_depth: 8,
            max_leaf_triangles: 2,
        },
        30_000,
        13,
    );
    assert!(hits > 10_000);
}

#[test]
fn a_small_object_on_a_wide_floor_matches_with_a_grown_root() {
    // A floor 100 wide with a ball of radius 1 on it: 100 : 2. Cut as it is, every cell would be
    // a slab 50 times wider than tall; the root is grown upward to at most 4 : 1.
    let mut m = MeshBuilder::default();
    m.grid(
        Vec3::new(-50.0, -50.0, 0.0),
        Vec3::new(100.0, 0.0, 0.0),
        Vec3::new(0.0, 100.0, 0.0),
        10,
        0,
    );
    let mut tris = positions(&m);
    let ball = positions(&closed_sphere(24, 12, 0.0, &mut Rng::new(4)));
    tris.extend(
        ball.into_iter()
            .map(|t| t.map(|p| p + Vec3::new(0.0, 0.0, 1.0))),
    );
    let tree = Octree::build(&tris, &OctreeParams::default());
    let (bounds, root) = (tree.bounds(), tree.root());
    assert_eq!(root.min, bounds.min);
    assert!(
        root.max.cmpge(bounds.max).all(),
        "{root:?} does not hold {bounds:?}"
    );
    let size = root.max - root.min;
    assert!(size.z >= size.x / 4.0, "root {size} is flatter than 4 : 1");
    assert!(
        bounds.max.z - bounds.min.z < size.z / 10.0,
        "root not grown: {size}"
    );
    let hits = compare(&tris, &OctreeParams::default(), 30_000, 15);
    assert!(hits > 10_000);
}

#[test]
fn a_floor_of_two_triangles_is_kept_out_of_the_tree_and_still_found() {
    // A floor 100 wide of two triangles under a ball of radius 1: the floor is tested by every
    // query, the tree divides the ball's box alone.
    let c = [
        Vec3::new(50.0, 50.0, 0.0),
        Vec3::new(-50.0, 50.0, 0.0),
        Vec3::new(-50.0, -50.0, 0.0),
        Vec3::new(50.0, -50.0, 0.0),
    ];
    let mut tris = vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]];
    let ball = positions(&closed_sphere(24, 12, 0.0, &mut Rng::new(6)));
    tris.extend(
        ball.into_iter()
            .map(|t| t.map(|p| p + Vec3::new(0.0, 0.0, 1.0))),
    );
    let tree = Octree::build(&tris, &OctreeParams::default());
    assert_eq!(tree.large(), &[0, 1]);
    let size = tree.root().max - tree.root().min;
    assert!(
        size.max_element() <= 2.01,
        "root {:?} is not the ball's",
        tree.root()
    );
    assert_eq!(tree.bounds().max.x, 50.0);
    let hits = compare(&tris, &OctreeParams::default(), 30_000, 16);
    assert!(hits > 10_000);
}

#[test]
fn the_walls_of_a_room_stay_in_the_tree() {
    // Six walls of two triangles each all span the room: too many to test on every ray.
    let mut m = MeshBuilder::default();
    let (o, x, y, z) = (Vec3::ZERO, Vec3::X * 10.0, Vec3::Y * 10.0, Vec3::Z * 10.0);
    for (origin, u, v) in [
        (o, x, y),
        (o, y, z),
        (o, z, x),
        (z, x, y),
        (x, y, z),
        (y, z, x),
    ] {
        m.grid(origin, u, v, 1, 0);
    }
    let mut tris = positions(&m);
    tris.extend(
        random_soup(200, &mut Rng::new(8))
            .into_iter()
            .map(|t| t.map(|p| p + 5.0)),
    );
    let tree = Octree::build(&tris, &OctreeParams::default());
    assert!(tree.large().is_empty(), "{:?}", tree.large());
    let hits = compare(&tris, &OctreeParams::default(), 20_000, 17);
    assert!(hits > 10_000);
}

#[test]
fn thousands_of_triangles_in_one_spot_match() {
    // A big room around a tiny dense cluster: deep cells, identical and overlapping triangles.
    let mut m = MeshBuilder::default();
    m.grid(
        Vec3::splat(-100.0),
        Vec3::new(200.0, 0.0, 0.0),
        Vec3::new(0.0, 200.0, 0.0),
        4,
        0,
    );
    let mut tris = positions(&m);
    let mut rng = Rng::new(3);
    let spot = random_soup(3000, &mut rng)
        .into_iter()
        .map(|t| t.map(|p| p * 1e-3 + Vec3::splat(0.37)));
    tris.extend(spot);
    let same = tris[10];
    tris.extend(std::iter::repeat_n(same, 50));
    let tree = Octree::build(&tris, &OctreeParams::default());
    assert!(tree.stats().depth <= 16);
    compare(&tris, &OctreeParams::default(), 20_000, 14);
}

#[test]
fn zero_volume_bounds_match() {
    // All triangles in the plane z = 0: the root cell has no height.
    let mut m = MeshBuilder::default();
    m.grid(Vec3::ZERO, Vec3::X * 10.0, Vec3::Y * 10.0, 30, 0);
    let tris = positions(&m);
    let tree = Octree::build(&tris, &OctreeParams::default());
    assert_eq!(tree.bounds().min.z, tree.bounds().max.z);
    let mut rng = Rng::new(5);
    for _ in 0..20_000 {
        let origin = Vec3::new(
            rng.range(-2.0, 12.0),
            rng.range(-2.0, 12.0),
            rng.range(0.5, 5.0),
        );
        let target = Vec3::new(rng.range(0.0, 10.0), rng.range(0.0, 10.0), 0.0);
        let ray = Ray::new(origin, target - origin);
        let expected = brute_force_closest_hit(&tris, &ray, f32::INFINITY);
        assert!(expected.is_some(), "the grid covers the target");
        assert_eq!(
            key(tree.closest_hit(&tris, &ray, f32::INFINITY)),
            key(expected)
        );
    }
}

#[test]
fn depth_and_leaf_limits_do_not_change_hits() {
    let tris = random_soup(400, &mut Rng::new(6));
    for params in [
        OctreeParams {
            max_depth: 0,
            max_leaf_triangles: 1,
        },
        OctreeParams {
            max_depth: 3,
            max_leaf_triangles: 1,
        },
        OctreeParams {
            max_depth: 20,
            max_leaf_triangles: 1,
        },
        OctreeParams {
            max_depth: 12,
            max_leaf_triangles: 32,
        },
    ] {
        compare(&tris, &params, 5_000, 15);
    }
}
