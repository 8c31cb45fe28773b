//! The octree build stays within its memory budget and still splits where splitting pays.

use strahl_core::accel::octree::{Octree, OctreeParams, BYTES_PER_PRIMITIVE};
use strahl_core::geom::solid::extent::SolidExtent;
use strahl_core::math::aabb::Aabb;
use strahl_core::scene::mesh::Rng;
use strahl_core_tests::meshes::random_soup;

#[test]
fn a_large_soup_stays_within_the_bytes_per_primitive() {
    let mut rng = Rng::new(3);
    let tris = random_soup(40_000, &mut rng);
    let tree = Octree::build(&tris, &OctreeParams::default());
    let s = tree.stats();
    assert!(
        s.bytes <= BYTES_PER_PRIMITIVE * tris.len(),
        "{} bytes for {} triangles",
        s.bytes,
        tris.len()
    );
    assert!(s.depth >= 3, "the soup is split: {s:?}");
    assert!(s.max_leaf_triangles < 400, "{s:?}");
}

#[test]
fn overlapping_boxes_are_split_only_while_it_pays() {
    // A thousand solids whose boxes all cover the same cube: no split separates them, so the
    // root stays one leaf instead of filing each box in every cell down to the depth limit.
    let cube = Aabb {
        min: glam::Vec3::splat(-1.0),
        max: glam::Vec3::splat(1.0),
    };
    let solids = vec![SolidExtent::Box(cube); 1000];
    let tree = Octree::build_mixed(&[], &solids, &OctreeParams::default());
    assert_eq!(tree.stats().nodes, 1, "{:?}", tree.stats());
    // Two clusters far apart are separated.
    let mut solids = vec![SolidExtent::Box(cube); 500];
    let far = Aabb {
        min: glam::Vec3::splat(9.0),
        max: glam::Vec3::splat(10.0),
    };
    solids.extend(vec![SolidExtent::Box(far); 500]);
    let tree = Octree::build_mixed(&[], &solids, &OctreeParams::default());
    assert!(tree.stats().nodes > 1, "{:?}", tree.stats());
    assert!(tree.stats().max_leaf_triangles <= 500, "{:?}", tree.stats());
}
