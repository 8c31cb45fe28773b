//! Primitives that touch the octree's centre planes from one side are filed on that side only
//! (`build.rs`), so the walk must reach every cell a ray touches, even at a single point: rays
//! in a centre plane, along cell edges, and through cell corners. A Sierpinski tetrahedron on a
//! power-of-two lattice puts faces, edges and corners of its pieces exactly on the centre planes
//! at every level; every ray below must find exactly the brute-force hit.

use glam::Vec3;
use strahl_core::accel::octree::{brute_force_closest_hit, Octree, OctreeParams};
use strahl_core::math::ray::Ray;
use strahl_core::scene::mesh::Rng;

/// The faces of a Sierpinski tetrahedron of `levels` levels in `[0, size]³` (corners at the
/// origin and on the three axes), whose vertices are all multiples of `size / 2^levels`.
fn sierpinski(levels: u32, size: f32) -> Vec<[Vec3; 3]> {
    fn go(c: [Vec3; 4], levels: u32, out: &mut Vec<[Vec3; 3]>) {
        if levels == 0 {
            let [a, b, d, e] = c;
            out.extend([[a, b, d], [a, d, e], [a, e, b], [b, e, d]]);
            return;
        }
        for k in 0..4 {
            let sub = c.map(|p| (p + c[k]) * 0.5);
            go(sub, levels - 1, out);
        }
    }
    let mut out = Vec::new();
    let corners = [Vec3::ZERO, Vec3::X * size, Vec3::Y * size, Vec3::Z * size];
    go(corners, levels, &mut out);
    out
}

fn key(h: Option<strahl_core::accel::octree::Hit>) -> Option<(u32, u32)> {
    h.map(|h| (h.triangle, h.tri.t.to_bits()))
}

/// A random lattice point of `[0, n]³` (every centre plane of the tree is on the lattice).
fn lattice(rng: &mut Rng, n: u64) -> Vec3 {
    let mut c = || (rng.next_u64() % (n + 1)) as f32;
    Vec3::new(c(), c(), c())
}

/// Checks closest hit and any hit of `ray` against brute force; returns whether it hits.
fn check(tree: &Octree, tris: &[[Vec3; 3]], ray: &Ray, what: &str) -> bool {
    let expected = brute_force_closest_hit(tris, ray, f32::INFINITY);
    let got = tree.closest_hit(tris, ray, f32::INFINITY);
    assert_eq!(key(got), key(expected), "{what}: {ray:?}");
    assert_eq!(
        tree.any_hit(tris, ray, f32::INFINITY),
        expected.is_some(),
        "{what}, any hit: {ray:?}"
    );
    expected.is_some()
}

#[test]
fn rays_in_planes_along_edges_and_through_corners_find_the_brute_force_hit() {
    let n = 32u64;
    let tris = sierpinski(5, n as f32);
    for params in [
        OctreeParams::default(),
        OctreeParams {
            max_depth: 6,
            max_leaf_triangles: 1,
        },
    ] {
        let tree = Octree::build(&tris, &params);
        assert!(tree.stats().depth >= 4, "{:?}", tree.stats());
        let mut rng = Rng::new(21);
        let mut hits = 0;
        for i in 0..30_000u32 {
            let from = lattice(&mut rng, n);
            let to = lattice(&mut rng, n);
            let (origin, dir, what) = match i % 5 {
                // Along an axis, in one or two centre planes (the others' lattice values).
                0 => {
                    let a = (i / 5 % 3) as usize;
                    let mut d = Vec3::ZERO;
                    d[a] = if i % 2 == 0 { 1.0 } else { -1.0 };
                    let mut o = from;
                    o[a] = if i % 2 == 0 { -3.0 } else { n as f32 + 3.0 };
                    (o, d, "along an axis")
                }
                // In one centre plane, diagonally: one zero component.
                1 => {
                    let a = (i / 5 % 3) as usize;
                    let mut d = to - from;
                    d[a] = 0.0;
                    (from, d, "in a plane")
                }
                // From outside through a lattice point (a cell corner at some level).
                2 => {
                    let o = Vec3::new(rng.range(-8.0, 40.0), rng.range(-8.0, 40.0), -5.0);
                    (o, to - o, "through a corner")
                }
                // From one lattice point to another, through edges and corners on the way.
                3 => (from, to - from, "lattice to lattice"),
                // From a lattice point, in a random direction.
                _ => (from, rng.direction(), "from a corner"),
            };
            if dir == Vec3::ZERO {
                continue;
            }
            hits += usize::from(check(&tree, &tris, &Ray::new(origin, dir), what));
        }
        assert!(hits > 5_000, "too few hits ({hits}) to mean anything");
    }
}

#[test]
fn the_lattice_tetrahedron_files_each_face_in_few_cells() {
    // Touching a plane from one side no longer files a face on both: at depth 5 on this
    // lattice most faces lie in one cell (they were in about eight when contact counted for
    // both sides).
    let tris = sierpinski(5, 32.0);
    let tree = Octree::build(&tris, &OctreeParams::default());
    let s = tree.stats();
    let per_face = s.references as f32 / s.filed_triangles as f32;
    assert!(per_face < 2.0, "{per_face} references per face: {s:?}");
}

#[test]
fn an_origin_on_a_centre_plane_with_a_subnormal_direction_finds_the_brute_force_hit() {
    // The root's centre plane is x = 16. A face touches it from above along an edge; rays start
    // on the plane with a subnormal x component (1/d overflows, so the crossing is 0 · ∞) and
    // hit the face within a hair of that edge, or hit the tetrahedron below.
    let mut tris = sierpinski(4, 32.0);
    tris.push([
        Vec3::new(16.0, 0.0, 8.0),
        Vec3::new(16.0, 32.0, 8.0),
        Vec3::new(32.0, 16.0, 8.0),
    ]);
    let tree = Octree::build(&tris, &OctreeParams::default());
    assert_eq!(tree.bounds().center().x, 16.0);
    let mut hits = 0;
    for (i, x) in [1e-39f32, -1e-39, 1e-45, -1e-45].into_iter().enumerate() {
        for y in 1..31 {
            let origin = Vec3::new(16.0, y as f32, 20.0 + i as f32);
            let ray = Ray::new(origin, Vec3::new(x, 0.0, -1.0));
            hits += usize::from(check(&tree, &tris, &ray, "subnormal x"));
        }
    }
    assert!(hits >= 60, "{hits} hits");
}

#[test]
fn a_solid_touching_a_centre_plane_is_found_where_its_test_reaches_past_its_box() {
    // Solids in small boxes on a grid of x = 0..32 whose boxes end exactly on the root's centre
    // plane x = 16, from below. A solid's test may report a hit a little past its world box (its
    // rounding, within the reject box), so a ray just above the plane, in the upper cells only,
    // must still meet them.
    use strahl_core::accel::work::QueryWork;
    use strahl_core::geom::solid::extent::{reject_margin, SolidExtent};
    use strahl_core::math::aabb::Aabb;
    let boxes: Vec<Aabb> = (0..16)
        .flat_map(|i| (0..16).map(move |k| (i, k)))
        .map(|(i, k)| {
            let lo = Vec3::new(
                2.0 * (i % 8) as f32 + if i < 8 { 0.0 } else { 16.0 },
                0.0,
                0.0,
            );
            let lo = lo + Vec3::new(0.0, 2.0 * k as f32, 0.0);
            Aabb {
                min: lo,
                max: lo + Vec3::new(2.0, 2.0, 32.0),
            }
        })
        .collect();
    let solids: Vec<SolidExtent> = boxes.iter().map(|&b| SolidExtent::Box(b)).collect();
    let tree = Octree::build_mixed(&[], &solids, &OctreeParams::default());
    assert_eq!(tree.bounds().center().x, 16.0);
    assert!(tree.stats().depth >= 2, "{:?}", tree.stats());
    // The solids ending at x = 16: i = 7, their boxes' max.x is 16.
    let touching: Vec<u32> = (0..boxes.len() as u32)
        .filter(|&i| boxes[i as usize].max.x == 16.0)
        .collect();
    assert_eq!(touching.len(), 16);
    for &i in &touching {
        let b = boxes[i as usize];
        let x = 16.0 + reject_margin(&b) / 2.0;
        let y = (b.min.y + b.max.y) / 2.0;
        // Along z, just above the plane: the test reports a hit for any primitive whose reject
        // box the ray passes through (what a solid's test may do). The solids starting at
        // x = 16 are reached too, at the same `t`: the tie goes to the touching one, the lower
        // index, only if the walk tests it.
        let ray = Ray::new(Vec3::new(x, y, -1.0), Vec3::Z);
        let reach = |j: u32| {
            let b = boxes[j as usize];
            let m = reject_margin(&b);
            (b.min.x - m..=b.max.x + m).contains(&x) && (b.min.y - m..=b.max.y + m).contains(&y)
        };
        let hit = tree.closest_hit_with(
            &ray,
            f32::INFINITY,
            &mut QueryWork::default(),
            |j, bound| {
                let t = boxes[j as usize].min.z + 1.0;
                (reach(j) && t < bound).then_some(strahl_core::geom::triangle::TriangleHit {
                    t,
                    t_error: 0.0,
                    b: [1.0, 0.0, 0.0],
                })
            },
        );
        assert_eq!(hit.map(|(j, _)| j), Some(i), "ray {ray:?}");
    }
}
