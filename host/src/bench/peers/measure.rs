//! One scene, measured: `runs` rounds, each running Strahl and POV-Ray in turn, first on one
//! thread (tracing time as each reports it) and then on two (the whole process, timed from
//! spawn to exit). The medians of the rounds, each round's tracing-time ratio (the two runs of
//! a round are seconds apart, so a pair shares the host's load), the rays and work of the last
//! one-thread runs, and their two images.

use super::child::{command_line, run_child};
use super::povray::{parse_report, povray_command, PovrayReport};
use super::scenes::ScenePair;
use super::strahl::{parse_stats, strahl_command, StrahlReport};
use crate::bench::stats::{median, median_by};
use anyhow::Context as _;
use std::path::{Path, PathBuf};

/// Threads of the tracing-time runs.
pub const TRACE_THREADS: u32 = 1;
/// Threads of the whole-process runs.
pub const WHOLE_THREADS: u32 = 2;

/// What every scene's runs share.
#[derive(Clone, Debug)]
pub struct Setup {
    /// The `strahl` binary (this one).
    pub strahl: PathBuf,
    /// The `povray` binary.
    pub povray: PathBuf,
    /// The folder the children write their images and statistics in (and POV-Ray runs in).
    pub work_dir: PathBuf,
    /// Side of the square image.
    pub size: u32,
    /// Strahl's `-d`.
    pub depth: u32,
    /// Rounds per scene.
    pub runs: u32,
}

/// A scene's figures.
#[derive(Clone, Debug)]
pub struct SceneMeasure {
    /// Median tracing seconds, one thread: Strahl's `seconds.tracing`.
    pub strahl_trace: f64,
    /// Median tracing seconds, one thread: POV-Ray's `Trace Time`.
    pub povray_trace: f64,
    /// Strahl's tracing seconds over POV-Ray's, one per round, each of a round's own pair
    /// (rounds where POV-Ray reported no time left out).
    pub trace_ratios: Vec<f64>,
    /// Median whole-process seconds on two threads, Strahl.
    pub strahl_whole: f64,
    /// Median whole-process seconds on two threads, POV-Ray.
    pub povray_whole: f64,
    /// The last one-thread Strahl run's statistics.
    pub strahl: StrahlReport,
    /// The last one-thread POV-Ray run's statistics.
    pub povray: PovrayReport,
    /// The last one-thread Strahl run's image.
    pub strahl_image: PathBuf,
    /// The last one-thread POV-Ray run's image.
    pub povray_image: PathBuf,
}

/// The median of `secs` (zero for none, which no scene has: it takes at least one run).
fn median_secs(secs: &[f64]) -> f64 {
    median_by(secs.to_vec(), f64::total_cmp).unwrap_or_default()
}

/// `strahl[i] / povray[i]` for each round `i` where POV-Ray's time is above zero.
fn round_ratios(strahl: &[f64], povray: &[f64]) -> Vec<f64> {
    strahl
        .iter()
        .zip(povray)
        .filter(|&(_, &p)| p > 0.0)
        .map(|(&s, &p)| s / p)
        .collect()
}

/// Runs `scene` `setup.runs` times on each tracer and each thread count, printing a line per
/// round on stderr.
///
/// # Errors
/// If a child fails or its statistics cannot be read; the message names the scene.
pub fn measure_scene(setup: &Setup, scene: &ScenePair) -> anyhow::Result<SceneMeasure> {
    let name = &scene.name;
    let file = |what: &str| setup.work_dir.join(format!("{name}-{what}"));
    let (s_img1, s_img2, s_json) = (
        file("strahl-1.png"),
        file("strahl-2.png"),
        file("strahl.json"),
    );
    // POV-Ray writes relative to its folder (the work folder): Debian's povray.conf allows that.
    let (p_out1, p_out2) = (
        format!("{name}-povray-1.png"),
        format!("{name}-povray-2.png"),
    );
    let strahl = |out: &Path, threads: u32, stats: Option<&Path>| {
        strahl_command(
            &setup.strahl,
            &scene.nff,
            out,
            setup.size,
            setup.depth,
            threads,
            stats,
        )
    };
    let povray = |out: &str, threads: u32| {
        let mut cmd = povray_command(&setup.povray, &scene.pov, out, setup.size, threads);
        cmd.current_dir(&setup.work_dir);
        cmd
    };

    let runs = setup.runs.max(1) as usize;
    let (mut st, mut pt, mut sw, mut pw) = (vec![], vec![], vec![], vec![]);
    let mut last = None;
    for round in 1..=runs {
        eprintln!("bench peers: {name}, round {round} of {runs}");
        run_child(name, strahl(&s_img1, TRACE_THREADS, Some(&s_json)))?;
        let json = std::fs::read_to_string(&s_json)
            .with_context(|| format!("scene {name}: cannot read {}", s_json.display()))?;
        let s_report = parse_stats(&json).with_context(|| format!("scene {name}"))?;

        let cmd = povray(&p_out1, TRACE_THREADS);
        let line = command_line(&cmd);
        let run = run_child(name, cmd)?;
        let p_report = parse_report(&format!("{}{}", run.stdout, run.stderr))
            .with_context(|| format!("scene {name}: `{line}`"))?;

        sw.push(run_child(name, strahl(&s_img2, WHOLE_THREADS, None))?.wall);
        pw.push(run_child(name, povray(&p_out2, WHOLE_THREADS))?.wall);
        st.push(s_report.tracing_seconds);
        pt.push(p_report.trace_seconds);
        last = Some((s_report, p_report));
    }
    let Some((strahl, povray)) = last else {
        anyhow::bail!("scene {name}: no runs");
    };
    Ok(SceneMeasure {
        trace_ratios: round_ratios(&st, &pt),
        strahl_trace: median_secs(&st),
        povray_trace: median_secs(&pt),
        strahl_whole: median(sw).as_secs_f64(),
        povray_whole: median(pw).as_secs_f64(),
        strahl,
        povray,
        strahl_image: s_img1,
        povray_image: setup.work_dir.join(p_out1),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_seconds() {
        assert_eq!(median_secs(&[0.5, 0.25, 2.0]), 0.5);
        assert_eq!(median_secs(&[1.0]), 1.0);
    }

    #[test]
    fn ratios_pair_each_rounds_runs() {
        assert_eq!(
            round_ratios(&[1.0, 3.0, 2.0], &[2.0, 0.0, 8.0]),
            [0.5, 0.25]
        );
    }
}
