//! Strahl's side: the `strahl render` command line of a run, and what its `--stats-json` says
//! (tracing seconds, rays by kind, and, where the JSON carries them, the work per ray and the
//! octree's shape; each of those may be absent and is then shown as `-`).

use super::rays::RaysByKind;
use anyhow::{anyhow, Context as _};
use serde_json::Value;
use std::path::Path;
use std::process::Command;

/// Work per ray, from the `work` object of the statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Work {
    /// Primitive intersection tests per ray.
    pub tests_per_ray: Option<f64>,
    /// Octree cells visited per ray.
    pub cells_per_ray: Option<f64>,
}

/// The octree's shape, from the `octree` object of the statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OctreeShape {
    /// Deepest level.
    pub depth: Option<u64>,
    /// Bytes it takes.
    pub bytes: Option<u64>,
    /// Bytes of the sphere groups kept beside it for its large leaves.
    pub group_bytes: Option<u64>,
}

/// What one Strahl render reported.
#[derive(Clone, Debug, PartialEq)]
pub struct StrahlReport {
    /// `seconds.tracing`.
    pub tracing_seconds: f64,
    /// Rays by kind.
    pub rays: RaysByKind,
    /// Work per ray (fields absent from older statistics are `None`).
    pub work: Work,
    /// The octree (fields absent from older statistics are `None`).
    pub octree: OctreeShape,
}

/// `strahl render <nff> -w <size> -h <size> -m 1 -d <depth> --workers <workers> -q -o
/// <output>`, with `--stats-json <stats>` when given.
pub fn strahl_command(
    strahl: &Path,
    nff: &Path,
    output: &Path,
    size: u32,
    depth: u32,
    workers: u32,
    stats: Option<&Path>,
) -> Command {
    let mut cmd = Command::new(strahl);
    let (size, depth, workers) = (size.to_string(), depth.to_string(), workers.to_string());
    cmd.arg("render")
        .arg(nff)
        .args(["-w", &size, "-h", &size, "-m", "1", "-d", &depth])
        .args(["--workers", &workers, "-q", "-o"])
        .arg(output);
    if let Some(stats) = stats {
        cmd.arg("--stats-json").arg(stats);
    }
    cmd
}

/// The value at `path` (object keys) in `v`.
fn at<'a>(v: &'a Value, path: &[&str]) -> Option<&'a Value> {
    path.iter().try_fold(v, |v, key| v.get(key))
}

/// Parses the JSON `--stats-json` wrote.
///
/// # Errors
/// If it is not JSON, or `seconds.tracing` or `rays` is missing.
pub fn parse_stats(json: &str) -> anyhow::Result<StrahlReport> {
    let v: Value = serde_json::from_str(json).context("Strahl's --stats-json is not JSON")?;
    let tracing_seconds = at(&v, &["seconds", "tracing"])
        .and_then(Value::as_f64)
        .ok_or_else(|| anyhow!("Strahl's --stats-json has no number `seconds.tracing`"))?;
    let rays = v
        .get("rays")
        .filter(|r| r.is_object())
        .ok_or_else(|| anyhow!("Strahl's --stats-json has no object `rays`"))?;
    let kind = |k: &str| rays.get(k).and_then(Value::as_u64).unwrap_or(0);
    let rays = RaysByKind {
        camera: kind("primary") + kind("extra_samples"),
        shadow: kind("shadow"),
        reflected: kind("reflection"),
        refracted: kind("refraction"),
        other: kind("occlusion"),
    };
    let float = |path: &[&str]| at(&v, path).and_then(Value::as_f64);
    let count = |path: &[&str]| at(&v, path).and_then(Value::as_u64);
    Ok(StrahlReport {
        tracing_seconds,
        rays,
        work: Work {
            tests_per_ray: float(&["work", "tests_per_ray"]),
            cells_per_ray: float(&["work", "cells_per_ray"]),
        },
        octree: OctreeShape {
            depth: count(&["octree", "depth"]),
            bytes: count(&["octree", "bytes"]),
            group_bytes: count(&["octree", "sphere_group_bytes"]),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_todays_statistics() {
        let json = r#"{"width": 64, "seconds": {"total": 0.16, "load": 0.01, "octree": 0.09,
            "tracing": 0.051}, "rays": {"primary": 4096, "extra_samples": 0, "shadow": 6188,
            "reflection": 3104, "refraction": 0, "occlusion": 0, "total": 13388}}"#;
        let r = parse_stats(json).expect("statistics");
        assert_eq!(r.tracing_seconds, 0.051);
        assert_eq!(r.rays.total(), 13388);
        assert_eq!(r.rays.camera, 4096);
        assert_eq!(r.work, Work::default());
        assert_eq!(r.octree, OctreeShape::default());
    }

    #[test]
    fn reads_work_and_octree_where_present() {
        let json = r#"{"seconds": {"tracing": 1.5}, "rays": {"primary": 10, "refraction": 2},
            "work": {"intersection_tests": 120, "octree_cells": 60, "tests_per_ray": 10.0,
                     "cells_per_ray": 5.0},
            "octree": {"nodes": 9, "leaves": 8, "depth": 3, "references": 40, "bytes": 4096,
                       "bytes_per_primitive": 12.5, "sphere_group_bytes": 392}}"#;
        let r = parse_stats(json).expect("statistics");
        assert_eq!(r.rays.refracted, 2);
        assert_eq!(r.work.tests_per_ray, Some(10.0));
        assert_eq!(r.work.cells_per_ray, Some(5.0));
        assert_eq!(r.octree.depth, Some(3));
        assert_eq!(r.octree.bytes, Some(4096));
        assert_eq!(r.octree.group_bytes, Some(392));
    }

    #[test]
    fn missing_fields_are_named() {
        let err = parse_stats("{").expect_err("not JSON").to_string();
        assert!(err.contains("not JSON"), "{err}");
        let err = parse_stats(r#"{"rays": {}}"#)
            .expect_err("no time")
            .to_string();
        assert!(err.contains("seconds.tracing"), "{err}");
        let err = parse_stats(r#"{"seconds": {"tracing": 1}}"#)
            .expect_err("no rays")
            .to_string();
        assert!(err.contains("`rays`"), "{err}");
    }

    #[test]
    fn the_command_line_is_the_documented_one() {
        let cmd = strahl_command(
            Path::new("strahl"),
            Path::new("x.nff"),
            Path::new("o.png"),
            64,
            5,
            1,
            Some(Path::new("s.json")),
        );
        let args: Vec<String> = cmd
            .get_args()
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            args.join(" "),
            "render x.nff -w 64 -h 64 -m 1 -d 5 --workers 1 -q -o o.png --stats-json s.json"
        );
    }
}
