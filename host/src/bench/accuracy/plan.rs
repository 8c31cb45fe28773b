//! The plan of one scene's sweep: every knob's values from the baseline, each with its
//! configuration, its labels and the reference it is compared with.

use super::format::percent;
use super::{Config, Knob, RefKind};
use std::fmt;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::scene::{RenderSettings, MAX_AMBIENT_OCCLUSION};

/// The value a knob takes in one row, as a number rather than a label.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Setting {
    /// Samples per side, depth cap, ambient-occlusion level, octree depth or leaf size, bits.
    Whole(u32),
    /// Adaptive threshold or reflection cut-off.
    Fraction(f32),
}

impl Setting {
    /// The value as a number.
    pub(super) fn num(self) -> f64 {
        match self {
            Setting::Whole(n) => f64::from(n),
            Setting::Fraction(f) => f64::from(f),
        }
    }
}

impl fmt::Display for Setting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Setting::Whole(n) => write!(f, "{n}"),
            Setting::Fraction(v) => write!(f, "{v}"),
        }
    }
}

/// One planned row: what is rendered, how it is labelled, what it is compared with.
pub(super) struct Planned {
    pub(super) knob: Knob,
    pub(super) setting: Setting,
    /// The value in the table.
    pub(super) value: String,
    /// Short label in the plot.
    pub(super) short: String,
    pub(super) config: Config,
    pub(super) reference: RefKind,
    /// 8-bit pixels (precision row).
    pub(super) eight_bit: bool,
}

impl Planned {
    fn new(knob: Knob, setting: Setting, value: String, short: String, config: Config) -> Self {
        Planned {
            knob,
            setting,
            value,
            short,
            config,
            reference: RefKind::Main,
            eight_bit: false,
        }
    }

    fn compared_with(self, reference: RefKind) -> Self {
        Planned { reference, ..self }
    }
}

/// The planned rows of one scene, knob by knob in report order.
pub(super) fn plan(baseline: &RenderSettings, quick: bool) -> Vec<Planned> {
    let mut rows = multisample_rows(baseline, quick);
    rows.extend(adaptive_rows(baseline, quick));
    rows.extend(reflection_rows(baseline, quick));
    rows.extend(occlusion_rows(baseline, quick));
    rows.extend(octree_rows(baseline, quick));
    rows.extend(precision_rows(baseline));
    rows
}

/// The full sweep's values, or the quick one's.
fn pick(quick: bool, full: &[u32], q: &[u32]) -> Vec<u32> {
    if quick {
        q.to_vec()
    } else {
        full.to_vec()
    }
}

/// A configuration with the default octree.
fn cfg(settings: RenderSettings) -> Config {
    Config {
        settings,
        octree: OctreeParams::default(),
    }
}

fn multisample_rows(baseline: &RenderSettings, quick: bool) -> Vec<Planned> {
    pick(quick, &[1, 2, 3, 4, 5, 6, 7, 8], &[1, 2, 4])
        .into_iter()
        .map(|m| {
            let s = RenderSettings {
                samples: m,
                aa_threshold: None,
                ..*baseline
            };
            Planned::new(
                Knob::Multisample,
                Setting::Whole(m),
                format!("{m} ({} spp)", m * m),
                format!("m{m}"),
                cfg(s),
            )
        })
        .collect()
}

fn adaptive_rows(baseline: &RenderSettings, quick: bool) -> Vec<Planned> {
    let thresholds: &[f32] = if quick {
        &[0.1]
    } else {
        &[0.3, 0.1, 0.03, 0.01]
    };
    thresholds
        .iter()
        .map(|&t| {
            let s = RenderSettings {
                samples: 4,
                aa_threshold: Some(t),
                ..*baseline
            };
            Planned::new(
                Knob::Adaptive,
                Setting::Fraction(t),
                format!("{t}"),
                format!("t{t}"),
                cfg(s),
            )
        })
        .collect()
}

/// The reflection cut-off and depth cap sweeps, with reflections on; the scene's own cut-off
/// and depth cap join them.
fn reflection_rows(baseline: &RenderSettings, quick: bool) -> Vec<Planned> {
    let reflect_ref = if baseline.reflections {
        RefKind::Main
    } else {
        RefKind::Reflections
    };
    let reflective = RenderSettings {
        reflections: true,
        ..*baseline
    };
    let mut cutoffs: Vec<f32> = if quick {
        vec![0.1, 0.0]
    } else {
        vec![0.1, 0.05, 0.01, 0.0]
    };
    if !cutoffs.contains(&baseline.min_reflection_weight) {
        cutoffs.push(baseline.min_reflection_weight);
        cutoffs.sort_by(|a, b| b.total_cmp(a));
    }
    let mut rows: Vec<Planned> = cutoffs
        .into_iter()
        .map(|c| {
            let s = RenderSettings {
                min_reflection_weight: c,
                ..reflective
            };
            Planned::new(
                Knob::Cutoff,
                Setting::Fraction(c),
                percent(c),
                format!("cut {}", percent(c)),
                cfg(s),
            )
            .compared_with(reflect_ref)
        })
        .collect();
    let mut depths = pick(quick, &[1, 2, 4, 8, 16], &[1, 16]);
    if !depths.contains(&baseline.max_depth) {
        depths.push(baseline.max_depth);
        depths.sort_unstable();
    }
    rows.extend(depths.into_iter().map(|d| {
        let s = RenderSettings {
            max_depth: d,
            ..reflective
        };
        Planned::new(
            Knob::Depth,
            Setting::Whole(d),
            d.to_string(),
            format!("d{d}"),
            cfg(s),
        )
        .compared_with(reflect_ref)
    }));
    rows
}

fn occlusion_rows(baseline: &RenderSettings, quick: bool) -> Vec<Planned> {
    let levels: Vec<u32> = match (baseline.ambient_occlusion, quick) {
        (0, false) => vec![0, 1, 2, 4],
        (0, true) => vec![0, 1],
        (l, false) => (0..=MAX_AMBIENT_OCCLUSION).chain([l]).collect(),
        (l, true) => vec![0, l, MAX_AMBIENT_OCCLUSION],
    };
    let mut seen = Vec::new();
    let mut rows = Vec::new();
    for a in levels {
        if seen.contains(&a) {
            continue;
        }
        seen.push(a);
        let s = RenderSettings {
            ambient_occlusion: a,
            ..*baseline
        };
        let value = match a {
            0 => "0 (off)".to_string(),
            1 => "1 (1 ray)".to_string(),
            _ => format!("{a} ({} rays)", a * a),
        };
        rows.push(
            Planned::new(
                Knob::Occlusion,
                Setting::Whole(a),
                value,
                format!("AO {a}"),
                cfg(s),
            )
            .compared_with(RefKind::Occlusion9),
        );
    }
    rows
}

/// Octree depth and leaf size, each alone from the default octree; compared with the baseline.
fn octree_rows(baseline: &RenderSettings, quick: bool) -> Vec<Planned> {
    let octree = OctreeParams::default();
    let row = |knob: Knob, n: u32, short: String, octree: OctreeParams| {
        Planned::new(
            knob,
            Setting::Whole(n),
            n.to_string(),
            short,
            Config {
                settings: *baseline,
                octree,
            },
        )
        .compared_with(RefKind::Baseline)
    };
    let depths = pick(quick, &[4, 8, 12, 16, 20], &[4, 16])
        .into_iter()
        .map(|d| {
            let params = OctreeParams {
                max_depth: d,
                ..octree
            };
            row(Knob::OctreeDepth, d, format!("depth {d}"), params)
        });
    let leaves = pick(quick, &[1, 2, 4, 8, 16, 32], &[1, 8])
        .into_iter()
        .map(|l| {
            let params = OctreeParams {
                max_leaf_triangles: l,
                ..octree
            };
            row(Knob::OctreeLeaf, l, format!("leaf {l}"), params)
        });
    depths.chain(leaves).collect()
}

/// 16-bit pixels and the same render through 8 bits.
fn precision_rows(baseline: &RenderSettings) -> Vec<Planned> {
    [16, 8]
        .into_iter()
        .map(|bits| Planned {
            eight_bit: bits == 8,
            ..Planned::new(
                Knob::Precision,
                Setting::Whole(bits),
                format!("{bits} bit"),
                format!("{bits} bit"),
                cfg(*baseline),
            )
        })
        .collect()
}
