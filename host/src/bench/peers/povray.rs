//! POV-Ray 3.7, the peer: finding `povray` on the `PATH`, the command line of a run, and what
//! its statistics (on stderr) say: the trace time, the rays by kind, the trace-level limit and
//! its version.
//!
//! POV-Ray 3.7 prints, among others (labels from its own format strings):
//!
//! ```text
//! Persistence of Vision(tm) Ray Tracer Version 3.7.0.10.unofficial (g++ @
//! Rays:              16540   Saved:              1820   Max Level: 5/5
//! Shadow Ray Tests:   9701   Succeeded:          4566
//! Reflected Rays:     6222                                (may add `Total Internal: N`)
//! Refracted Rays:     6222
//! Transmitted Rays:      0
//!   Trace Time:       0 hours  0 minutes  0 seconds (0.013 seconds)
//! ```
//!
//! `Rays` counts every ray POV-Ray traced into the scene (camera, reflected, refracted and
//! transmitted rays), not shadow rays; the `Reflected`, `Refracted` and `Transmitted` lines
//! appear only when their count is not zero. So the camera rays are `Rays` less those three, and
//! all rays are `Rays` plus the shadow ray tests.

use super::rays::RaysByKind;
use anyhow::bail;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The program's name on the `PATH`.
pub const POVRAY: &str = "povray";

/// What one POV-Ray run reported.
#[derive(Clone, Debug, PartialEq)]
pub struct PovrayReport {
    /// Its `Trace Time` in seconds (milliseconds are its resolution).
    pub trace_seconds: f64,
    /// Rays by kind.
    pub rays: RaysByKind,
    /// The trace-level limit it ran with (the scene's `max_trace_level`), if it said.
    pub max_level: Option<u32>,
    /// Its version, if its banner said.
    pub version: Option<String>,
}

/// `povray` on the `PATH`.
///
/// # Errors
/// If no executable `povray` is on the `PATH`: the message says how to install it.
pub fn locate_povray() -> anyhow::Result<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    for dir in std::env::split_paths(&path) {
        let candidate = dir.join(POVRAY);
        if is_executable(&candidate) {
            return Ok(candidate);
        }
    }
    bail!(
        "POV-Ray 3.7 (`{POVRAY}`) is not on the PATH; `strahl bench peers` renders every scene with \
         it too: install it with `apt-get install povray` (Debian's package)"
    )
}

/// Whether `path` is a file this process may run.
fn is_executable(path: &Path) -> bool {
    let Ok(meta) = std::fs::metadata(path) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        meta.is_file() && meta.permissions().mode() & 0o111 != 0
    }
    #[cfg(not(unix))]
    {
        meta.is_file()
    }
}

/// `povray +I<pov> +O<output> +W<size> +H<size> -D -A +WT<threads>`: no display, no
/// antialiasing, `threads` render threads. The output name is taken relative to the child's
/// folder: Debian's `povray.conf` lets POV-Ray write only there and under /tmp.
pub fn povray_command(povray: &Path, pov: &Path, output: &str, size: u32, threads: u32) -> Command {
    let mut cmd = Command::new(povray);
    let mut input = std::ffi::OsString::from("+I");
    input.push(pov);
    cmd.arg(input)
        .arg(format!("+O{output}"))
        .arg(format!("+W{size}"))
        .arg(format!("+H{size}"))
        .args(["-D", "-A"])
        .arg(format!("+WT{threads}"));
    cmd
}

/// The first whitespace-separated word after `label` on the first line that starts with it
/// (leading blanks aside).
fn value_after<'a>(text: &'a str, label: &str) -> Option<&'a str> {
    text.lines().find_map(|line| {
        line.trim_start()
            .strip_prefix(label)
            .and_then(|rest| rest.split_whitespace().next())
    })
}

/// A count POV-Ray printed after `label` (`%15.0f`, so read as a float); `None` if the line is
/// absent or the value is not a count.
fn count_after(text: &str, label: &str) -> Option<u64> {
    let v: f64 = value_after(text, label)?.parse().ok()?;
    (v.is_finite() && v >= 0.0).then_some(v as u64)
}

/// The seconds in parentheses on the `Trace Time:` line.
pub fn parse_trace_seconds(text: &str) -> Option<f64> {
    let line = text.lines().find(|l| l.contains("Trace Time:"))?;
    let inner = line.rsplit_once('(')?.1;
    let secs: f64 = inner.strip_suffix("seconds)")?.trim().parse().ok()?;
    (secs.is_finite() && secs >= 0.0).then_some(secs)
}

/// The rays by kind of the statistics; `None` without a `Rays:` line.
pub fn parse_rays(text: &str) -> Option<RaysByKind> {
    let traced = count_after(text, "Rays:")?;
    let reflected = count_after(text, "Reflected Rays:").unwrap_or(0);
    let refracted = count_after(text, "Refracted Rays:").unwrap_or(0);
    let transmitted = count_after(text, "Transmitted Rays:").unwrap_or(0);
    Some(RaysByKind {
        camera: traced.saturating_sub(reflected + refracted + transmitted),
        shadow: count_after(text, "Shadow Ray Tests:").unwrap_or(0),
        reflected,
        refracted,
        other: transmitted,
    })
}

/// The limit of `Max Level: used/limit` (at the end of the `Rays:` line).
pub fn parse_max_level(text: &str) -> Option<u32> {
    text.lines()
        .find_map(|line| line.split_once("Max Level:"))?
        .1
        .split_whitespace()
        .next()?
        .split_once('/')?
        .1
        .parse()
        .ok()
}

/// The version of the banner (`3.7.0.10.unofficial`).
pub fn parse_version(text: &str) -> Option<String> {
    text.lines().find_map(|line| {
        let rest = line.split_once("Ray Tracer Version ")?.1;
        rest.split_whitespace().next().map(str::to_string)
    })
}

/// Everything a run's statistics report.
///
/// # Errors
/// A message naming the line that is missing.
pub fn parse_report(text: &str) -> anyhow::Result<PovrayReport> {
    let Some(trace_seconds) = parse_trace_seconds(text) else {
        bail!("POV-Ray printed no `Trace Time: ... (S seconds)` line");
    };
    let Some(rays) = parse_rays(text) else {
        bail!("POV-Ray printed no `Rays:` statistics line");
    };
    Ok(PovrayReport {
        trace_seconds,
        rays,
        max_level: parse_max_level(text),
        version: parse_version(text),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The statistics POV-Ray 3.7.0.10 printed for `mount_6` at 64×64 (abridged).
    const MOUNT: &str = "\
Persistence of Vision(tm) Ray Tracer Version 3.7.0.10.unofficial (g++ @
 x86_64-pc-linux-gnu)
Rendered 4096 of 4096 pixels (100%)
----------------------------------------------------------------------------
Render Statistics
Image Resolution 64 x 64
----------------------------------------------------------------------------
Pixels:             4096   Samples:               0   Smpls/Pxl: 0.00
Rays:              16540   Saved:              1820   Max Level: 5/5
----------------------------------------------------------------------------
Ray->Shape Intersection          Tests       Succeeded  Percentage
----------------------------------------------------------------------------
Sphere                           26918           15369     57.10
Triangle                         21623            2949     13.64
Bounding Box                    542603          226154     41.68
----------------------------------------------------------------------------
Shadow Ray Tests:              9701   Succeeded:                  4566
Shadow Cache Hits:               48
Reflected Rays:                6222
Refracted Rays:                6222
----------------------------------------------------------------------------
Render Time:
  Photon Time:      No photons
  Radiosity Time:   No radiosity
  Trace Time:       0 hours  0 minutes  0 seconds (0.013 seconds)
              using 1 thread(s) with 0.012 CPU-seconds total
POV-Ray finished
";

    #[test]
    fn reads_trace_time_rays_level_and_version() {
        let r = parse_report(MOUNT).expect("report");
        assert_eq!(r.trace_seconds, 0.013);
        assert_eq!(
            r.rays,
            RaysByKind {
                camera: 4096,
                shadow: 9701,
                reflected: 6222,
                refracted: 6222,
                other: 0,
            }
        );
        assert_eq!(r.rays.total(), 16540 + 9701);
        assert_eq!(r.max_level, Some(5));
        assert_eq!(r.version.as_deref(), Some("3.7.0.10.unofficial"));
    }

    #[test]
    fn long_trace_times_and_internal_reflections() {
        let text = "Rays:  100   Saved: 0   Max Level: 3/7\n\
                    Reflected Rays:   40   Total Internal:   5\n\
                    Transmitted Rays: 10\n  \
                    Trace Time:       1 hours  2 minutes  3 seconds (3723.456 seconds)\n";
        let r = parse_report(text).expect("report");
        assert_eq!(r.trace_seconds, 3723.456);
        assert_eq!(r.rays.camera, 50);
        assert_eq!(r.rays.reflected, 40);
        assert_eq!(r.rays.other, 10);
        assert_eq!(r.rays.shadow, 0);
        assert_eq!(r.max_level, Some(7));
    }

    #[test]
    fn missing_lines_are_named() {
        let err = parse_report("Rays: 5\n")
            .expect_err("no trace time")
            .to_string();
        assert!(err.contains("Trace Time"), "{err}");
        let err = parse_report("  Trace Time: 0 hours 0 minutes 0 seconds (0.1 seconds)\n")
            .expect_err("no rays")
            .to_string();
        assert!(err.contains("Rays:"), "{err}");
        assert_eq!(parse_trace_seconds("  Trace Time:       No trace\n"), None);
    }

    #[test]
    fn the_command_line_is_the_documented_one() {
        let cmd = povray_command(Path::new("povray"), Path::new("/s/x.pov"), "p.png", 64, 2);
        let args: Vec<String> = cmd
            .get_args()
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            args,
            ["+I/s/x.pov", "+Op.png", "+W64", "+H64", "-D", "-A", "+WT2"]
        );
    }
}
