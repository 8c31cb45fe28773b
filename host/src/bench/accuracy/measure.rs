//! Measuring one scene: its references and their residuals, then every planned setting in
//! rounds, each row's errors against what it is compared with, and the median times.

use super::format::{fmt_rays, fmt_secs, settings_summary, sig3, stdout_row};
use super::metrics::{psnr, rmse, ssim, through_8_bits, to_colors, Colors};
use super::plan::{plan, Planned};
use super::wire::wire_bytes;
use super::{
    residual_probe_samples, AccuracyOptions, Config, Errors, Measured, RefKind, Reference, Row,
    SceneRun, MIN_RUN, OCCLUSION_REFERENCE_SAMPLES, REFERENCE_DEPTH, REFERENCE_SAMPLES,
};
use crate::bench::stats::median;
use crate::cluster::local::render_local;
use crate::cluster::prepared::PreparedScene;
use anyhow::{anyhow, bail, Context as _};
use std::io::Write;
use std::time::{Duration, Instant};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::{RenderSettings, SceneDesc, MAX_AMBIENT_OCCLUSION};

/// The references of a scene with `baseline`: the main one, the one with reflections on when
/// the scene has them off, and the ambient-occlusion one at level 9.
fn reference_settings(baseline: &RenderSettings) -> Vec<(RefKind, RenderSettings)> {
    let main_ref = RenderSettings {
        samples: REFERENCE_SAMPLES,
        aa_threshold: None,
        min_reflection_weight: 0.0,
        max_depth: REFERENCE_DEPTH,
        ..*baseline
    };
    let mut ref_settings = vec![(RefKind::Main, main_ref)];
    if !baseline.reflections {
        ref_settings.push((
            RefKind::Reflections,
            RenderSettings {
                reflections: true,
                ..main_ref
            },
        ));
    }
    ref_settings.push((
        RefKind::Occlusion9,
        RenderSettings {
            ambient_occlusion: MAX_AMBIENT_OCCLUSION,
            samples: if baseline.ambient_occlusion == MAX_AMBIENT_OCCLUSION {
                REFERENCE_SAMPLES
            } else {
                OCCLUSION_REFERENCE_SAMPLES
            },
            ..main_ref
        },
    ));
    ref_settings
}

/// The image each kind of reference compares with.
struct RefImages(Vec<(RefKind, Colors)>);

impl RefImages {
    fn get(&self, kind: RefKind) -> Option<&Colors> {
        self.0.iter().find(|(k, _)| *k == kind).map(|(_, c)| c)
    }
}

/// Renders the references and their residual probes, printing a line for each.
fn render_references(
    out: &mut impl Write,
    name: &str,
    desc: &SceneDesc,
    ref_settings: &[(RefKind, RenderSettings)],
    cores: usize,
) -> anyhow::Result<(Vec<Reference>, RefImages)> {
    let (w, h) = (desc.settings.width, desc.settings.height);
    let mut references: Vec<Reference> = Vec::new();
    let mut ref_images: Vec<(RefKind, Colors)> = Vec::new();
    for (i, (kind, s)) in ref_settings.iter().enumerate() {
        // The AO-9 reference is the main one when the scene already uses level 9.
        if let Some(j) = ref_settings[..i]
            .iter()
            .position(|(_, earlier)| earlier == s)
        {
            let colors = ref_images[j].1.clone();
            ref_images.push((*kind, colors));
            if let Some(r) = references.iter_mut().find(|r| r.settings == *s) {
                r.kinds.push(*kind);
            }
            continue;
        }
        let config = Config {
            settings: *s,
            octree: OctreeParams::default(),
        };
        let (t, px, rays) = render_timed(name, desc, &config, cores)?;
        let colors = to_colors(&px);
        // The residual: the same settings at half the samples per side.
        let probe_samples = residual_probe_samples(s.samples);
        let probe = Config {
            settings: RenderSettings {
                samples: probe_samples,
                ..*s
            },
            octree: OctreeParams::default(),
        };
        let (probe_time, probe_px, _) = render_timed(name, desc, &probe, cores)?;
        let residual = errors(&to_colors(&probe_px), &colors, w, h);
        writeln!(
            out,
            "{}: {} s, {} rays; residual (RMSE of multisample {probe_samples} against it, {} s): {}",
            kind.name(),
            fmt_secs(t),
            fmt_rays(rays.total()),
            fmt_secs(probe_time),
            sig3(residual.rmse)
        )?;
        references.push(Reference {
            kinds: vec![*kind],
            settings: *s,
            time: t,
            rays,
            probe_samples,
            probe_time,
            residual,
        });
        ref_images.push((*kind, colors));
    }
    Ok((references, RefImages(ref_images)))
}

/// The header of the table on stdout, with `time` over the time column.
fn stdout_header(out: &mut impl Write, time: &str) -> std::io::Result<()> {
    writeln!(
        out,
        "{:<28} {:<26} {:>12} {:>9} {:>8} {:>10} {:>7} {:>8} {:>8}  compared with",
        "scene", "knob", "value", time, "×base", "RMSE", "PSNR", "SSIM", "rays"
    )
}

/// The configurations of one scene as measured, each rendered once per round.
struct Measurements<'a> {
    name: &'a str,
    desc: &'a SceneDesc,
    cores: usize,
    measured: Vec<Measured>,
}

impl Measurements<'_> {
    /// The index of `config`'s measurement, rendering it first if it is new.
    fn measure(&mut self, config: &Config) -> anyhow::Result<usize> {
        if let Some(i) = self.measured.iter().position(|m| m.config == *config) {
            return Ok(i);
        }
        let (time, pixels, rays) = render_timed(self.name, self.desc, config, self.cores)?;
        let image = self
            .measured
            .iter()
            .position(|m| m.pixels == pixels)
            .unwrap_or(self.measured.len());
        self.measured.push(Measured {
            config: *config,
            times: vec![time],
            time,
            colors: to_colors(&pixels),
            pixels,
            rays,
            image,
        });
        Ok(self.measured.len() - 1)
    }

    /// Round 1: measures the configuration of every planned row (rendering only new ones) and
    /// prints its row; `base` is the baseline's measurement.
    fn first_round(
        &mut self,
        out: &mut impl Write,
        plan: Vec<Planned>,
        base: usize,
        ref_images: &RefImages,
        scene: usize,
    ) -> anyhow::Result<Vec<Row>> {
        let name = self.name;
        let size = (self.desc.settings.width, self.desc.settings.height);
        let mut rows = Vec::new();
        for planned in plan {
            let i = self.measure(&planned.config)?;
            let (m, b) = (&self.measured[i], &self.measured[base]);
            let errs = row_errors(name, &planned, m, b, ref_images, size)?;
            let row = Row {
                scene,
                knob: planned.knob,
                setting: planned.setting,
                value: planned.value,
                short: planned.short,
                measured: i,
                eight_bit: planned.eight_bit,
                reference: planned.reference,
                time: m.time,
                ratio: m.time.as_secs_f64() / b.time.as_secs_f64().max(1e-12),
                errors: errs,
            };
            stdout_row(out, name, &row, m.rays.total())?;
            rows.push(row);
        }
        Ok(rows)
    }

    /// Rounds 2 to `runs` over every setting; then each setting's time is the median.
    ///
    /// The other runs go in rounds over every setting, so a busy spell of the machine spreads
    /// over all settings instead of spoiling one. Each round starts at another setting, so no
    /// setting always follows the same one.
    fn remaining_rounds(&mut self, out: &mut impl Write, runs: usize) -> anyhow::Result<()> {
        let name = self.name;
        let n = self.measured.len();
        for round in 2..=runs {
            writeln!(out, "round {round} of {runs}")?;
            let offset = (round - 1) * n / runs;
            for k in 0..n {
                let m = &mut self.measured[(k + offset) % n];
                let (t, pixels, _) = render_timed(name, self.desc, &m.config, self.cores)?;
                if pixels != m.pixels {
                    bail!(
                        "{name}: two renders of the same settings differ (a bug): {:?}",
                        m.config
                    );
                }
                m.times.push(t);
            }
        }
        for m in &mut self.measured {
            m.time = median(m.times.clone());
        }
        Ok(())
    }
}

/// Fails unless an octree row's image `m` is the default octree's `b`, naming the setting and
/// the first pixel that differs.
fn check_octree_row(
    name: &str,
    planned: &Planned,
    m: &Measured,
    b: &Measured,
    width: u32,
) -> anyhow::Result<()> {
    if m.pixels == b.pixels {
        return Ok(());
    }
    let n = m
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| p != q)
        .count();
    let detail =
        first_difference(&m.pixels, &b.pixels, width).map_or_else(String::new, |(x, y, p, q)| {
            format!(
                "; first at pixel ({x}, {y}): {:?} instead of {:?}",
                p.0, q.0
            )
        });
    bail!(
        "{name}: {} {} (octree depth {}, leaf {}) changed {n} of {} pixels \
         against the default octree (depth {}, leaf {}){detail}. Octree settings \
         must never change the image: this is a bug.",
        planned.knob.name(),
        planned.value,
        planned.config.octree.max_depth,
        planned.config.octree.max_leaf_triangles,
        m.pixels.len(),
        b.config.octree.max_depth,
        b.config.octree.max_leaf_triangles,
    );
}

/// The errors of a planned row's render `m` against what it is compared with: the baseline `b`
/// for octree rows (which must match it exactly), else its reference.
fn row_errors(
    name: &str,
    planned: &Planned,
    m: &Measured,
    b: &Measured,
    ref_images: &RefImages,
    (w, h): (u32, u32),
) -> anyhow::Result<Errors> {
    if planned.reference == RefKind::Baseline {
        check_octree_row(name, planned, m, b, w)?;
        return Ok(errors(&m.colors, &b.colors, w, h));
    }
    let Some(reference) = ref_images.get(planned.reference) else {
        // reference_settings plans every kind but the baseline, which is handled above.
        debug_assert!(false, "no {} image", planned.reference.name());
        bail!("{name}: no {} image", planned.reference.name());
    };
    Ok(if planned.eight_bit {
        errors(&to_colors(&through_8_bits(&m.pixels)), reference, w, h)
    } else {
        errors(&m.colors, reference, w, h)
    })
}

/// Gives `rows` the median times of their `measured` configurations and their ratio to the
/// baseline's (`base`); with more than one run, prints the rows again with them.
fn settle_times(
    out: &mut impl Write,
    name: &str,
    runs: usize,
    measured: &[Measured],
    base: usize,
    rows: &mut [Row],
) -> anyhow::Result<()> {
    let base_time = measured[base].time.as_secs_f64().max(1e-12);
    for r in rows.iter_mut() {
        r.time = measured[r.measured].time;
        r.ratio = r.time.as_secs_f64() / base_time;
    }
    if runs > 1 {
        writeln!(out, "median of {runs} runs:")?;
        stdout_header(out, "median s")?;
        for r in rows.iter() {
            stdout_row(out, name, r, measured[r.measured].rays.total())?;
        }
    }
    Ok(())
}

/// Measures one scene, printing its rows on stdout as they come.
pub(super) fn run_scene(
    name: &str,
    desc: &SceneDesc,
    args: &AccuracyOptions,
    cores: usize,
    scene_index: usize,
    rows: &mut Vec<Row>,
) -> anyhow::Result<SceneRun> {
    let runs = args.runs.max(1) as usize;
    let (w, h) = (args.size.width, args.size.height);
    let mut out = std::io::stdout().lock();
    let baseline = RenderSettings {
        samples: 1,
        ..desc.settings
    };
    writeln!(
        out,
        "\n{name}: {w}x{h}, {} triangles, {} solid objects; baseline: {}",
        desc.triangles.len(),
        desc.objects.len(),
        settings_summary(&baseline)
    )?;
    let ref_settings = reference_settings(&baseline);
    let (references, ref_images) = render_references(&mut out, name, desc, &ref_settings, cores)?;
    if runs > 1 {
        writeln!(out, "round 1 of {runs} (times of this round only):")?;
    }
    stdout_header(&mut out, if runs > 1 { "1st s" } else { "s" })?;

    let mut ms = Measurements {
        name,
        desc,
        cores,
        measured: Vec::new(),
    };
    let base = ms.measure(&Config {
        settings: baseline,
        octree: OctreeParams::default(),
    })?;
    let planned = plan(&baseline, args.quick);
    let mut mine = ms.first_round(&mut out, planned, base, &ref_images, scene_index)?;
    ms.remaining_rounds(&mut out, runs)?;
    let measured = ms.measured;
    settle_times(&mut out, name, runs, &measured, base, &mut mine)?;
    let b = &measured[base];
    let quantization = errors(&to_colors(&through_8_bits(&b.pixels)), &b.colors, w, h);
    let wire = wire_bytes(&b.pixels, w, b.rays)
        .map_err(|e| anyhow!("{name}: cannot encode line results: {e}"))?;
    let run = SceneRun {
        name: name.to_string(),
        triangles: desc.triangles.len(),
        solids: desc.objects.len(),
        baseline,
        baseline_time: b.time,
        references,
        reflections_forced: !baseline.reflections,
        measured,
        quantization,
        wire,
    };
    rows.extend(mine);
    Ok(run)
}

/// Renders `desc` with `config` on `workers` in-process workers; returns the time per render,
/// the pixels and the rays. A render shorter than [`MIN_RUN`] repeats until the run lasts that
/// long, and the time is the mean per render. Scene preparation is not timed.
fn render_timed(
    name: &str,
    desc: &SceneDesc,
    config: &Config,
    workers: usize,
) -> anyhow::Result<(Duration, Vec<Pixel>, RayCounts)> {
    let mut d = desc.clone();
    d.settings = config.settings;
    let prepared = PreparedScene::new(&d, &config.octree).map_err(|e| anyhow!("{name}: {e}"))?;
    let t = Instant::now();
    let mut count = 0u32;
    let img = loop {
        let img = render_local(&prepared, workers, &|_, _| {})
            .with_context(|| format!("{name}: render failed"))?;
        count += 1;
        if t.elapsed() >= MIN_RUN {
            break img;
        }
    };
    Ok((t.elapsed() / count, img.pixels, img.rays))
}

/// Where two images first differ: `(x, y, a, b)`.
fn first_difference(a: &[Pixel], b: &[Pixel], width: u32) -> Option<(u32, u32, Pixel, Pixel)> {
    let w = width.max(1) as usize;
    a.iter()
        .zip(b)
        .position(|(p, q)| p != q)
        .map(|i| ((i % w) as u32, (i / w) as u32, a[i], b[i]))
}

fn errors(a: &[[f32; 3]], b: &[[f32; 3]], width: u32, height: u32) -> Errors {
    let e = rmse(a, b);
    Errors {
        rmse: e,
        psnr: psnr(e),
        ssim: ssim(a, b, width as usize, height as usize),
    }
}
