//! `pgo/record.sh`, which records the profile of the profile-guided build, trains with renders
//! whose counts do not depend on timing: each has one worker. With two, which lines each worker
//! traced (and so what its remembered shadow blockers held) and how many lines the master's end
//! game traced twice varied from run to run, and two recordings of one commit compiled 18 of the
//! core's 101 functions differently (`docs/performance.md`, thirty-first round). Recording takes
//! minutes, so this reads the script instead of running it twice.

use std::path::Path;

/// The script's render commands: the lines that call its `render` function.
fn training_renders() -> Vec<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../pgo/record.sh");
    let script = std::fs::read_to_string(&path).expect("pgo/record.sh in the checkout");
    script
        .lines()
        .map(str::trim)
        .filter(|line| line.starts_with("render "))
        .map(str::to_owned)
        .collect()
}

#[test]
fn every_training_render_has_one_worker() {
    let renders = training_renders();
    assert!(renders.len() >= 5, "found only {renders:?}");
    for render in &renders {
        let words: Vec<&str> = render.split_whitespace().collect();
        let workers: Vec<&str> = words
            .windows(2)
            .filter(|pair| pair[0] == "--workers")
            .map(|pair| pair[1])
            .collect();
        assert_eq!(workers, ["1"], "{render}");
    }
}
