//! The text `--write-docs` puts between the markers: when and where it ran, the exact command,
//! what each column means, the two tables and links to the side-by-side pictures.

use super::table::{comparison_table, rays_table, PeerRow};
use std::collections::BTreeSet;
use std::fmt::Write as _;

/// What the section says besides the rows.
#[derive(Clone, Debug)]
pub struct RunFacts {
    /// The date (UTC) of the run.
    pub date: String,
    /// The machine in words.
    pub machine: String,
    /// POV-Ray's version, if its banner said.
    pub povray_version: Option<String>,
    /// The command line as given.
    pub command: String,
    /// Side of the square images.
    pub size: u32,
    /// Strahl's `-d`.
    pub depth: u32,
    /// Rounds per scene.
    pub runs: u32,
    /// The side-by-side pictures' folder, relative to the docs file (`peers`).
    pub images: String,
}

/// The trace-level limits POV-Ray reported, as text (`5`, or `5, 7`, or `not reported`).
fn levels(rows: &[PeerRow]) -> String {
    let set: BTreeSet<u32> = rows
        .iter()
        .filter_map(|r| r.measure.povray.max_level)
        .collect();
    if set.is_empty() {
        "not reported".to_string()
    } else {
        set.iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The section's text.
pub fn section(facts: &RunFacts, rows: &[PeerRow]) -> String {
    let f = facts;
    let n = f.size;
    let version = f.povray_version.as_deref().map_or_else(
        || "POV-Ray (version not reported)".to_string(),
        |v| format!("POV-Ray {v}"),
    );
    let mut s = String::new();
    let _ = writeln!(s, "Run on {}, {}; {version}.", f.date, f.machine);
    let _ = writeln!(s);
    let _ = writeln!(s, "Command: `{}`", f.command);
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "{n}×{n} pixels, one sample per pixel, Strahl at `-d {}`, POV-Ray at its scenes' trace-level \
         limit ({}); medians of {} round{}, Strahl and POV-Ray alternating.",
        f.depth,
        levels(rows),
        f.runs,
        if f.runs == 1 { "" } else { "s" }
    );
    let _ = writeln!(s);
    let _ = write!(
        s,
        "- **trace s**: tracing alone on one thread: Strahl's `seconds.tracing` from \
         `--stats-json` (`strahl render X.nff -w {n} -h {n} -m 1 -d {d} --workers 1`) against \
         POV-Ray's own `Trace Time` (`povray +IX.pov +W{n} +H{n} -D -A +WT1`).\n\
         - **whole s**: the whole process on two threads (`--workers 2`, `+WT2`), spawn to exit: \
         start-up, parsing, the octree or bounding boxes, tracing and the PNG.\n\
         - **ratio**: Strahl over POV-Ray, of the printed times; below 1, Strahl is faster.\n\
         - **by round**: the median of the rounds' own tracing-time ratios (each round runs the \
         two tracers seconds apart, so a pair shares the host's load of that moment), with the \
         smallest and largest in brackets.\n\
         - **rays**: Strahl's `rays.total`; POV-Ray's `Rays` (camera, reflected, refracted and \
         transmitted rays) plus its `Shadow Ray Tests`. By kind in the second table.\n\
         - **tests/ray, cells/ray, octree depth, octree bytes**: Strahl's `--stats-json` (`work`, \
         `octree`); `-` where it does not report them. Where a scene keeps sphere groups for the \
         octree's large leaves (`octree.sphere_group_bytes`), their bytes follow the octree's.\n\
         - **MAD R/G/B**: mean absolute difference of each 8-bit channel between the two \
         one-thread images.\n\n",
        d = f.depth
    );
    s.push_str(&comparison_table(rows));
    let _ = writeln!(s);
    let _ = writeln!(s, "Rays by kind, Strahl / POV-Ray:");
    let _ = writeln!(s);
    s.push_str(&rays_table(rows));
    let _ = writeln!(s);
    let links: Vec<String> = rows
        .iter()
        .map(|r| format!("[{0}]({1}/{0}.png)", r.name, f.images))
        .collect();
    let _ = writeln!(
        s,
        "Side by side, Strahl left, POV-Ray right: {}.",
        links.join(", ")
    );
    s
}
