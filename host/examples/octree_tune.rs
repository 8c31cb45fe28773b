//! Scratch: octree parameter sweep (not shipped).
fn main() {
    let args: Vec<u32> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (d, l) = (
        args.first().copied().unwrap_or(16),
        args.get(1).copied().unwrap_or(8),
    );
    let opts = strahl_host::bench::BenchOptions {
        runs: 3,
        octree: strahl_core::octree::OctreeParams {
            max_depth: d,
            max_leaf_triangles: l,
        },
        ..Default::default()
    };
    println!("depth {d} leaf {l}\n{}", strahl_host::bench::run(&opts));
}
