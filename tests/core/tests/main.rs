//! The tests of `strahl-core` alone, in one binary: each file of `tests/core/tests/` is a module
//! here, so cargo compiles and links them once rather than once per file. The tests of all files
//! run side by side, one per CPU.

mod csg;
mod effects;
mod first_crossing;
mod hard_cases_solids;
mod leaving_triangle;
mod light_buffers;
mod no_self_intersection;
mod octree_budget;
mod octree_matches_brute_force;
mod octree_packets;
mod octree_plane_contact;
mod refraction;
mod shading;
mod shadow_cache;
mod solid_filing;
mod sphere_groups;
mod sphere_interiors;
mod watertight;
mod work_counts;

/// Every `.rs` file of `tests/core/tests/` is compiled: a module of this binary
/// (`autotests = false`, so cargo would not find a new file by itself).
#[test]
fn every_test_file_is_compiled() -> Result<(), String> {
    let (main_rs, manifest) = (include_str!("main.rs"), include_str!("../Cargo.toml"));
    strahl_core_tests::test_files::check(env!("CARGO_MANIFEST_DIR"), main_rs, manifest)
}
