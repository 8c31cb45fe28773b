//! The Markdown tables: the comparison (one row per scene: times and their ratios, rays, work per
//! ray, the octree, image agreement) and the rays by kind.
//!
//! Times are printed to the millisecond (POV-Ray's resolution), and each ratio is Strahl's
//! printed time over POV-Ray's printed time, so a reader can check it from the table; `-` where
//! POV-Ray's printed time is 0.000 or a figure is not reported.

use super::measure::SceneMeasure;
use super::rays::RaysByKind;
use super::strahl::OctreeShape;
use crate::bench::stats::median_by;
use crate::util::units::format_bytes;
use std::fmt::Write as _;

/// A scene's row: its name, its figures and how far its images differ.
#[derive(Clone, Debug)]
pub struct PeerRow {
    /// The scene.
    pub name: String,
    /// Its figures.
    pub measure: SceneMeasure,
    /// Mean absolute difference of R, G and B (0 to 255) between the one-thread images.
    pub mad: [f64; 3],
}

/// `secs` rounded to the millisecond, as the table prints it.
pub fn millis(secs: f64) -> f64 {
    (secs * 1000.0).round() / 1000.0
}

/// Seconds to the millisecond.
pub fn fmt_secs(secs: f64) -> String {
    format!("{:.3}", millis(secs))
}

/// Strahl over POV-Ray of the printed times, two decimals; `-` if POV-Ray's is 0.000.
pub fn fmt_ratio(strahl: f64, povray: f64) -> String {
    let (s, p) = (millis(strahl), millis(povray));
    if p > 0.0 {
        format!("{:.2}", s / p)
    } else {
        "-".to_string()
    }
}

/// The median of per-round ratios ([`median_by`]) with their range, `0.33 (0.30–0.41)`; `-`
/// for none.
pub fn fmt_spread(ratios: &[f64]) -> String {
    let extreme = |pick: fn(f64, f64) -> f64| ratios.iter().copied().reduce(pick);
    match (
        median_by(ratios.to_vec(), f64::total_cmp),
        extreme(f64::min),
        extreme(f64::max),
    ) {
        (Some(mid), Some(lo), Some(hi)) => format!("{mid:.2} ({lo:.2}–{hi:.2})"),
        _ => "-".to_string(),
    }
}

/// A count with thousands separated by commas (`1,234,567`).
pub fn fmt_count(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// `v` with two decimals, `-` if absent.
fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "-".to_string(), |v| format!("{v:.2}"))
}

/// The octree's bytes, with the sphere groups beside it where there are any; `-` if absent.
fn octree_bytes(o: &OctreeShape) -> String {
    let bytes = |b: u64| format_bytes(usize::try_from(b).unwrap_or(usize::MAX));
    match (o.bytes, o.group_bytes) {
        (None, _) => "-".to_string(),
        (Some(b), Some(g)) if g > 0 => format!("{} + {} groups", bytes(b), bytes(g)),
        (Some(b), _) => bytes(b),
    }
}

/// Strahl's and POV-Ray's counts of one kind.
fn pair(s: u64, p: u64) -> String {
    format!("{} / {}", fmt_count(s), fmt_count(p))
}

/// The comparison table.
pub fn comparison_table(rows: &[PeerRow]) -> String {
    let mut t = String::from(
        "| scene | POV-Ray trace s | Strahl trace s | ratio | by round | POV-Ray whole s \
         | Strahl whole s | ratio | rays Strahl / POV-Ray (total) | tests/ray | cells/ray \
         | octree depth | octree bytes (+ sphere groups) | MAD R/G/B |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let m = &r.measure;
        let o = &m.strahl.octree;
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} \
             | {:.2} / {:.2} / {:.2} |",
            r.name,
            fmt_secs(m.povray_trace),
            fmt_secs(m.strahl_trace),
            fmt_ratio(m.strahl_trace, m.povray_trace),
            fmt_spread(&m.trace_ratios),
            fmt_secs(m.povray_whole),
            fmt_secs(m.strahl_whole),
            fmt_ratio(m.strahl_whole, m.povray_whole),
            pair(m.strahl.rays.total(), m.povray.rays.total()),
            fmt_opt(m.strahl.work.tests_per_ray),
            fmt_opt(m.strahl.work.cells_per_ray),
            o.depth.map_or_else(|| "-".to_string(), |d| d.to_string()),
            octree_bytes(o),
            r.mad[0],
            r.mad[1],
            r.mad[2],
        );
    }
    t
}

/// The rays-by-kind table, Strahl / POV-Ray in each cell.
pub fn rays_table(rows: &[PeerRow]) -> String {
    let mut t = String::from(
        "| scene | camera | shadow | reflected | refracted | other |\n\
         |---|---|---|---|---|---|\n",
    );
    for r in rows {
        let (s, p): (&RaysByKind, &RaysByKind) = (&r.measure.strahl.rays, &r.measure.povray.rays);
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} | {} | {} |",
            r.name,
            pair(s.camera, p.camera),
            pair(s.shadow, p.shadow),
            pair(s.reflected, p.reflected),
            pair(s.refracted, p.refracted),
            pair(s.other, p.other),
        );
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::peers::povray::PovrayReport;
    use crate::bench::peers::strahl::{StrahlReport, Work};
    use std::path::PathBuf;

    fn row() -> PeerRow {
        let rays = |n| RaysByKind {
            camera: n,
            shadow: 2 * n,
            ..RaysByKind::default()
        };
        PeerRow {
            name: "tiny".into(),
            measure: SceneMeasure {
                trace_ratios: vec![2.5, 1.9, 2.0],
                strahl_trace: 0.5004,
                povray_trace: 0.25,
                strahl_whole: 1.0,
                povray_whole: 0.0004,
                strahl: StrahlReport {
                    tracing_seconds: 0.5,
                    rays: rays(1000),
                    work: Work {
                        tests_per_ray: Some(3.456),
                        cells_per_ray: None,
                    },
                    octree: OctreeShape {
                        depth: Some(7),
                        bytes: Some(2048),
                        group_bytes: Some(0),
                    },
                },
                povray: PovrayReport {
                    trace_seconds: 0.25,
                    rays: rays(500),
                    max_level: Some(5),
                    version: None,
                },
                strahl_image: PathBuf::new(),
                povray_image: PathBuf::new(),
            },
            mad: [1.0, 0.5, 12.345],
        }
    }

    #[test]
    fn the_row_prints_every_figure() {
        let t = comparison_table(&[row()]);
        let line = t.lines().nth(2).expect("a row");
        assert_eq!(
            line,
            "| tiny | 0.250 | 0.500 | 2.00 | 2.00 (1.90–2.50) | 0.000 | 1.000 | - | 3,000 / 1,500 \
             | 3.46 | - | 7 | 2.0 KiB | 1.00 / 0.50 / 12.35 |"
        );
        let mut grouped = row();
        grouped.measure.strahl.octree.group_bytes = Some(4096);
        let t = comparison_table(&[grouped]);
        assert!(
            t.lines()
                .nth(2)
                .is_some_and(|l| l.contains("| 2.0 KiB + 4.0 KiB groups |")),
            "{t}"
        );
        let r = rays_table(&[row()]);
        assert_eq!(
            r.lines().nth(2),
            Some("| tiny | 1,000 / 500 | 2,000 / 1,000 | 0 / 0 | 0 / 0 | 0 / 0 |")
        );
    }

    #[test]
    fn ratios_are_of_the_printed_times() {
        assert_eq!(fmt_ratio(0.1234, 0.0996), format!("{:.2}", 0.123 / 0.100));
        assert_eq!(fmt_spread(&[]), "-");
        assert_eq!(fmt_spread(&[0.3]), "0.30 (0.30–0.30)");
        assert_eq!(fmt_count(999), "999");
        assert_eq!(fmt_count(1_234_567), "1,234,567");
    }
}
