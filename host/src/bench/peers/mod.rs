//! `strahl bench peers`: Strahl against POV-Ray 3.7, scene by scene, on the SPD scenes.
//!
//! Each scene comes as a pair, `X.nff` for Strahl and `X.pov` for POV-Ray (`--scenes`, default
//! `../shared/spd`; `--only a,b` picks some). For each, `runs` rounds run Strahl and POV-Ray in
//! turn (Debian's `povray`, found on the `PATH`), at `size`×`size`, one sample per pixel,
//! Strahl at `-d depth`:
//!
//! 1. **tracing time on one thread**: Strahl's `seconds.tracing` from `--stats-json` against
//!    POV-Ray's `Trace Time` (`+WT1`);
//! 2. **the whole process on two threads** (`--workers 2`, `+WT2`), timed from spawn to exit.
//!
//! The medians are printed as a Markdown table with their ratios, the rays each traced (by kind
//! in a second table), Strahl's work per ray and octree (where its statistics carry them) and
//! how far the two one-thread images differ (mean absolute difference per channel). A
//! side-by-side picture per scene goes to `peers/` beside the `--write-docs` file (else to the
//! `--pictures` folder, else `docs/peers/`), and with `--write-docs FILE` the report replaces
//! the text between the markers of FILE.
//!
//! The parts: `scenes` (the pairs), `child` (running and timing a process), `strahl` and
//! `povray` (each tracer's command line and statistics), `rays` (rays by kind), `measure` (one
//! scene's rounds and medians), `images` (difference and side-by-side picture), `table` (the
//! Markdown tables), `machine` (date, CPU, command line), `section` (the report's text) and
//! `docs` (the markers, and writing the file).

use anyhow::Context as _;
use std::path::PathBuf;

mod child;
mod docs;
mod images;
mod measure;
mod povray;
mod rays;
mod scenes;
mod section;
mod strahl;
mod table;

pub use docs::{BEGIN, END, HEADING};

use super::machine::{machine, today};
use child::own_command_line;
use docs::{check_docs, write_docs};
use images::{load_rgb, mean_abs_diff, side_by_side, write_png};
use measure::{measure_scene, Setup};
use povray::locate_povray;
use scenes::find_pairs;
use section::{section, RunFacts};
use table::{comparison_table, rays_table, PeerRow};

/// The scene folder used when `--scenes` is not given (relative to the current folder).
pub const DEFAULT_SCENES: &str = "../shared/spd";
/// Where the side-by-side pictures go without `--write-docs` or `--pictures`.
pub const DEFAULT_IMAGES: &str = "docs/peers";
/// The pictures' folder's name beside the `--write-docs` file.
pub const IMAGES_FOLDER: &str = "peers";

/// The options of `strahl bench peers`.
#[derive(Clone, Debug)]
pub struct PeersOptions {
    /// The folder of `X.nff` + `X.pov` pairs.
    pub scenes: PathBuf,
    /// Only these scenes (empty: all pairs).
    pub only: Vec<String>,
    /// Side of the square images.
    pub size: u32,
    /// Rounds per scene.
    pub runs: u32,
    /// Strahl's `-d`.
    pub depth: u32,
    /// The Markdown file whose marked section gets the report.
    pub write_docs: Option<PathBuf>,
    /// The folder of the side-by-side pictures, where the report is not written.
    pub pictures: Option<PathBuf>,
}

impl PeersOptions {
    /// The folder of the side-by-side pictures: `peers/` beside the docs file (whose report
    /// links them there), else the folder asked for, else [`DEFAULT_IMAGES`].
    pub fn images_dir(&self) -> PathBuf {
        match (&self.write_docs, &self.pictures) {
            (Some(docs), _) => crate::formats::fs::destination_folder(docs).join(IMAGES_FOLDER),
            (None, Some(dir)) => dir.clone(),
            (None, None) => PathBuf::from(DEFAULT_IMAGES),
        }
    }
}

/// Runs the comparison, prints the tables on stdout and, with `write_docs`, writes the report.
///
/// # Errors
/// If the scene folder holds no pairs or lacks a scene `only` names, the docs file's markers are
/// broken, `povray` is not on the `PATH`, a child fails, or a file cannot be written.
pub fn run(opts: &PeersOptions) -> anyhow::Result<()> {
    let scenes = find_pairs(&opts.scenes, &opts.only)?;
    if let Some(docs) = &opts.write_docs {
        check_docs(docs)?;
    }
    let povray = locate_povray()?;
    let strahl = std::env::current_exe().context("cannot find the path of this strahl binary")?;
    let images = opts.images_dir();
    std::fs::create_dir_all(&images)
        .with_context(|| format!("{}: cannot create the folder", images.display()))?;
    let work = tempfile::Builder::new()
        .prefix("strahl-peers-")
        .tempdir()
        .context("cannot create a temporary folder")?;
    let setup = Setup {
        strahl,
        povray,
        work_dir: work.path().to_path_buf(),
        size: opts.size,
        depth: opts.depth,
        runs: opts.runs,
    };
    eprintln!(
        "bench peers: {} scene{} against {}, {n}x{n}, {} round{} each",
        scenes.len(),
        if scenes.len() == 1 { "" } else { "s" },
        setup.povray.display(),
        opts.runs,
        if opts.runs == 1 { "" } else { "s" },
        n = opts.size,
    );

    let mut rows = Vec::with_capacity(scenes.len());
    for scene in &scenes {
        let measure = measure_scene(&setup, scene)?;
        let name = &scene.name;
        if let Some(level) = measure.povray.max_level.filter(|&l| l != opts.depth) {
            eprintln!(
                "bench peers: warning: {name}: POV-Ray traced to its scene's trace-level limit \
                 {level}, Strahl to -d {}",
                opts.depth
            );
        }
        let (s, p) = (
            load_rgb(&measure.strahl_image)?,
            load_rgb(&measure.povray_image)?,
        );
        let mad = mean_abs_diff(&s, &p).with_context(|| format!("scene {name}"))?;
        write_png(&images.join(format!("{name}.png")), &side_by_side(&s, &p))?;
        rows.push(PeerRow {
            name: name.clone(),
            measure,
            mad,
        });
    }

    println!("{}", comparison_table(&rows));
    println!("Rays by kind, Strahl / POV-Ray:\n\n{}", rays_table(&rows));
    eprintln!(
        "bench peers: side by side (Strahl left, POV-Ray right) in {}",
        images.display()
    );
    if let Some(docs) = &opts.write_docs {
        let facts = RunFacts {
            date: today(),
            machine: machine(),
            povray_version: rows.iter().find_map(|r| r.measure.povray.version.clone()),
            command: own_command_line(),
            size: opts.size,
            depth: opts.depth,
            runs: opts.runs,
            images: IMAGES_FOLDER.to_string(),
        };
        write_docs(docs, &section(&facts, &rows))?;
        eprintln!("bench peers: wrote {}", docs.display());
    }
    Ok(())
}
