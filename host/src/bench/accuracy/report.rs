//! The Markdown report: method, scenes, references and residuals, the results table, and a
//! paragraph per knob.

use super::conclusions::{
    adaptive_conclusion, all_same, cutoff_conclusion, depth_conclusion, multisample_conclusion,
    occlusion_conclusion, octree_conclusion, precision_conclusion, share, sweep_of,
};
use super::format::{
    fmt_psnr, fmt_ratio, fmt_rays, fmt_secs, fmt_ssim, join_values, percent, rmse_change,
    row_cells, settings_summary, sig3, sig_pair,
};
use super::metrics::pareto_front;
use super::plan::Setting;
use super::wire::{fmt_bytes, serial_seconds, PIXEL_WIRE_BYTES_8};
use super::{
    residual_probe_samples, AccuracyOptions, Knob, RefKind, Row, SceneRun, MIN_RUN,
    OCCLUSION_REFERENCE_SAMPLES, REFERENCE_DEPTH, REFERENCE_SAMPLES,
};
use std::fmt::Write as _;
use std::time::Duration;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::scene::{MAX_AMBIENT_OCCLUSION, MAX_SAMPLES};
use strahl_core::wire::PIXEL_WIRE_BYTES;

pub(super) fn rows_of(rows: &[Row], scene: usize, knob: Knob) -> Vec<&Row> {
    rows.iter()
        .filter(|r| r.scene == scene && r.knob == knob)
        .collect()
}

/// The rows of scene `si` on its Pareto front (compared with the main reference, one row per
/// render, octree rows left out), fastest first.
pub(super) fn front_rows(rows: &[Row], si: usize) -> Vec<&Row> {
    let mut seen: Vec<(usize, bool)> = Vec::new();
    let candidates: Vec<&Row> = rows
        .iter()
        .filter(|r| {
            r.scene == si
                && r.reference == RefKind::Main
                && !matches!(r.knob, Knob::OctreeDepth | Knob::OctreeLeaf)
        })
        .filter(|r| {
            let key = (r.measured, r.eight_bit);
            let new = !seen.contains(&key);
            seen.push(key);
            new
        })
        .collect();
    let points: Vec<(f64, f64)> = candidates
        .iter()
        .map(|r| (r.time.as_secs_f64(), r.errors.rmse))
        .collect();
    pareto_front(&points)
        .into_iter()
        .map(|i| candidates[i])
        .collect()
}

pub(super) fn figures(r: &Row) -> String {
    format!(
        "{} the baseline time, RMSE {} (PSNR {} dB, SSIM {})",
        fmt_ratio(r.ratio),
        sig3(r.errors.rmse),
        fmt_psnr(r.errors.psnr),
        fmt_ssim(r.errors.ssim)
    )
}

/// Groups of values of one knob that gave identical images (groups of two or more).
pub(super) fn identical_groups(rows: &[&Row], scene: &SceneRun) -> Vec<Vec<String>> {
    let mut groups: Vec<(usize, Vec<String>)> = Vec::new();
    for r in rows {
        let id = scene.measured[r.measured].image;
        match groups.iter_mut().find(|(g, _)| *g == id) {
            Some((_, v)) => v.push(r.value.clone()),
            None => groups.push((id, vec![r.value.clone()])),
        }
    }
    groups
        .into_iter()
        .map(|(_, v)| v)
        .filter(|v| v.len() > 1)
        .collect()
}

pub(super) fn identical_note(rows: &[&Row], scene: &SceneRun, what: &str) -> String {
    let groups = identical_groups(rows, scene);
    if groups.is_empty() {
        return String::new();
    }
    if groups.len() == 1 && groups[0].len() == rows.len() {
        return format!(" Every {what} gave the same image: this knob changes nothing here.");
    }
    let parts: Vec<String> = groups
        .iter()
        .map(|g| format!("{what}s {} give identical images", join_values(g)))
        .collect();
    let sentence = parts.join("; ");
    let mut chars = sentence.chars();
    match chars.next() {
        Some(c) => format!(" {}{}.", c.to_uppercase(), chars.as_str()),
        None => String::new(),
    }
}

/// What one knob's paragraph about one scene draws on.
struct Section<'a> {
    knob: Knob,
    /// The scene's index.
    si: usize,
    sc: &'a SceneRun,
    /// Every row of every scene.
    rows: &'a [Row],
    /// The scene's rows of this knob.
    rs: Vec<&'a Row>,
    /// The scene's multisample rows.
    multisample: Vec<&'a Row>,
    /// The baseline's RMSE against the reference as a sentence (empty when unknown).
    scale: String,
    /// The residual of the reference these rows are compared with.
    residual: f64,
}

/// The paragraph on `knob`: one item per scene that has rows of it.
pub(super) fn paragraph(knob: Knob, scenes: &[SceneRun], rows: &[Row]) -> String {
    let mut text = String::new();
    for (si, sc) in scenes.iter().enumerate() {
        let rs = rows_of(rows, si, knob);
        if rs.is_empty() {
            continue;
        }
        let multisample = rows_of(rows, si, Knob::Multisample);
        let scale = multisample
            .first()
            .filter(|r| r.measured == 0)
            .map(|r| {
                format!(
                    " For scale: the baseline's RMSE against the scene's own reference is {}, \
                     mostly aliasing at multisample 1.",
                    sig3(r.errors.rmse)
                )
            })
            .unwrap_or_default();
        let residual = sc.residual(rs[0].reference);
        let _ = write!(text, "- **{}.** ", sc.name);
        let body_start = text.len();
        let section = Section {
            knob,
            si,
            sc,
            rows,
            rs,
            multisample,
            scale,
            residual,
        };
        let body = match knob {
            Knob::Multisample => multisample_text,
            Knob::Adaptive => adaptive_text,
            Knob::Cutoff | Knob::Depth => reflection_text,
            Knob::Occlusion => occlusion_text,
            Knob::OctreeDepth | Knob::OctreeLeaf => octree_text,
            Knob::Precision => precision_text,
        };
        body(&section, &mut text);
        let body = text.split_off(body_start);
        text.push_str(body.trim_start());
        text.push('\n');
    }
    text
}

/// The multisample sweep: the first setting, the big steps, where most of the gain is reached.
fn multisample_text(s: &Section<'_>, text: &mut String) {
    let &Section { sc, ref rs, .. } = s;
    let first = rs[0];
    let _ = write!(
        text,
        "Multisample {} ({} s) has RMSE {} (PSNR {} dB, SSIM {}).",
        first.setting,
        fmt_secs(first.time),
        sig3(first.errors.rmse),
        fmt_psnr(first.errors.psnr),
        fmt_ssim(first.errors.ssim)
    );
    for r in rs.iter().skip(1).filter(|r| {
        [2, 4, 8].map(Setting::Whole).contains(&r.setting)
            || r.measured == rs[rs.len() - 1].measured
    }) {
        let _ = write!(
            text,
            " Multisample {} costs {} the time and {} (PSNR {} dB, SSIM {}).",
            r.setting,
            fmt_ratio(r.ratio),
            rmse_change(first.errors.rmse, r.errors.rmse),
            fmt_psnr(r.errors.psnr),
            fmt_ssim(r.errors.ssim)
        );
    }
    if let Some(last) = rs.last() {
        let drop = first.errors.rmse - last.errors.rmse;
        if drop > 0.0 && rs.len() > 2 {
            for share in [0.5, 0.9] {
                if let Some(r) = rs
                    .iter()
                    .find(|r| first.errors.rmse - r.errors.rmse >= share * drop)
                {
                    let _ = write!(
                        text,
                        " {:.0} % of the RMSE reduction from {} to {} is reached at multisample {} ({}).",
                        share * 100.0,
                        first.setting,
                        last.setting,
                        r.setting,
                        fmt_ratio(r.ratio)
                    );
                }
            }
        }
        if last.errors.rmse == 0.0 {
            let _ = write!(
                text,
                " Multisample {} is the reference's own setting for this scene \
                 (the other reference settings change nothing here), hence error 0.",
                last.setting
            );
        }
    }
    let b = &sc.baseline;
    let other = (b.reflections
        && (b.min_reflection_weight != 0.0 || b.max_depth != REFERENCE_DEPTH))
        .then(|| {
            format!(
                "its cut-off ({} against 0) and depth cap ({} against \
                 {REFERENCE_DEPTH})",
                percent(b.min_reflection_weight),
                b.max_depth
            )
        });
    text.push_str(&multisample_conclusion(&sweep_of(rs, sc), other.as_deref()));
}

/// The adaptive threshold against full multisample 4: time, error and pixels refined.
fn adaptive_text(s: &Section<'_>, text: &mut String) {
    let &Section {
        sc,
        ref rs,
        ref multisample,
        ..
    } = s;
    let full = multisample
        .iter()
        .copied()
        .find(|r| r.setting == Setting::Whole(4));
    if let Some(f) = full {
        let _ = write!(
            text,
            "Full multisample 4 costs {} with RMSE {}.",
            fmt_ratio(f.ratio),
            sig3(f.errors.rmse)
        );
    }
    if !sc.baseline.skip_effects {
        let _ = write!(
            text,
            " The scene has skip-effects off, so the second pass supersamples every \
             pixel and keeps only the flagged ones: adaptive multisampling saves no \
             rays here."
        );
    }
    let pixels = u64::from(sc.baseline.width) * u64::from(sc.baseline.height);
    for r in rs {
        let m = &sc.measured[r.measured];
        let per_pixel = u64::from(m.config.settings.samples).pow(2).max(1);
        let refined = if sc.baseline.skip_effects && pixels > 0 {
            format!(
                "; {:.1} % of pixels refined",
                share((m.rays.extra_samples / per_pixel) as f64, pixels as f64)
            )
        } else {
            String::new()
        };
        let _ = write!(text, " Threshold {}: {}{refined}.", r.value, figures(r));
    }
    if let Some(f) = full {
        let mut all = vec![f];
        all.extend(rs.iter().copied());
        let k = all.len();
        all.extend(multisample.iter().copied());
        let sw = sweep_of(&all, sc);
        text.push_str(&identical_note(rs, sc, "threshold"));
        text.push_str(&adaptive_conclusion(&sw, 1..k, k..all.len()));
    } else {
        text.push_str(&identical_note(rs, sc, "threshold"));
    }
}

/// The reflection cut-off or depth cap sweep: error and reflection and refraction rays.
fn reflection_text(s: &Section<'_>, text: &mut String) {
    let &Section {
        knob,
        sc,
        ref rs,
        ref multisample,
        ref scale,
        ..
    } = s;
    if sc.reflections_forced {
        let _ = write!(
            text,
            "The scene has reflections off; this sweep turns them on and compares \
             with the reference with reflections on.{scale}"
        );
    }
    for r in rs {
        let rays = sc.measured[r.measured].rays;
        let _ = write!(
            text,
            " {} {}: {}; {} reflection and {} refraction rays.",
            if knob == Knob::Cutoff {
                "Cut-off"
            } else {
                "Depth cap"
            },
            r.value,
            figures(r),
            rays.reflection,
            rays.refraction
        );
    }
    text.push_str(&identical_note(
        rs,
        sc,
        if knob == Knob::Cutoff {
            "cut-off"
        } else {
            "depth cap"
        },
    ));
    let sw = sweep_of(rs, sc);
    let same = all_same(rs, sc);
    if knob == Knob::Cutoff {
        let own = sw
            .points
            .iter()
            .position(|q| q.num == f64::from(sc.baseline.min_reflection_weight));
        let m = |n: u32| {
            multisample
                .iter()
                .find(|r| r.setting == Setting::Whole(n))
                .map(|r| r.errors.rmse)
        };
        let aliasing = m(1).zip(m(2)).map(|(a, b)| a - b).filter(|&d| d > 0.0);
        text.push_str(&cutoff_conclusion(&sw, own, aliasing, same));
    } else {
        let own = sw
            .points
            .iter()
            .position(|q| q.num == f64::from(sc.baseline.max_depth));
        text.push_str(&depth_conclusion(&sw, own, same));
    }
}

/// The ambient-occlusion levels against the level-9 reference.
fn occlusion_text(s: &Section<'_>, text: &mut String) {
    let &Section {
        sc,
        ref rs,
        ref scale,
        residual,
        ..
    } = s;
    let level = sc.baseline.ambient_occlusion;
    if level == 0 {
        let _ = write!(
            text,
            "The scene does not use ambient occlusion (level 0); the sweep turns it \
             on and compares with the reference at level 9, so level 0's error \
             includes the occlusion the scene leaves out."
        );
    } else {
        let _ = write!(
            text,
            "The scene uses level {level}; compared with the reference at level 9."
        );
    }
    text.push_str(scale);
    let _ = write!(text, " That reference's residual is {}.", sig3(residual));
    for r in rs {
        let rays = sc.measured[r.measured].rays;
        let _ = write!(
            text,
            " Level {}: {}; {} occlusion rays.",
            r.value,
            figures(r),
            fmt_rays(rays.occlusion)
        );
    }
    text.push_str(&identical_note(rs, sc, "level"));
    let reference = sc
        .references
        .iter()
        .find(|r| r.kinds.contains(&RefKind::Occlusion9))
        .map_or_else(
            || "level-9 reference".to_string(),
            |r| {
                format!(
                    "level-9 reference ({} rays per shaded point, multisample {})",
                    MAX_AMBIENT_OCCLUSION * MAX_AMBIENT_OCCLUSION,
                    r.settings.samples
                )
            },
        );
    text.push_str(&occlusion_conclusion(&sweep_of(rs, sc), level, &reference));
}

/// The octree depth and leaf size: identical images, and their render times.
fn octree_text(s: &Section<'_>, text: &mut String) {
    let &Section {
        knob,
        si,
        sc,
        rows,
        ref rs,
        ..
    } = s;
    let leaves = rows_of(rows, si, Knob::OctreeLeaf);
    let all = rs.len()
        + if knob == Knob::OctreeDepth {
            leaves.len()
        } else {
            0
        };
    let _ = write!(
        text,
        "No setting changed a pixel: all {all} renders are identical to the default \
         octree's (depth {}, leaf size {}).",
        OctreeParams::default().max_depth,
        OctreeParams::default().max_leaf_triangles
    );
    let mut groups = vec![(knob, rs.clone())];
    if knob == Knob::OctreeDepth {
        groups.push((Knob::OctreeLeaf, leaves));
    }
    let mut times = Vec::new();
    for (k, g) in groups {
        let listed: Vec<String> = g
            .iter()
            .map(|r| format!("{}: {}", r.value, fmt_ratio(r.ratio)))
            .collect();
        let _ = write!(
            text,
            " Render time against the baseline by {}: {}.",
            k.name(),
            listed.join(", ")
        );
        times.extend(g.iter().map(|r| (r.short.clone(), r.ratio)));
    }
    text.push_str(&octree_conclusion(&times, sc.noise().map(|(n, _)| n)));
}

/// 8 against 16 bits per channel: the quantisation error and the bytes on the wire.
fn precision_text(s: &Section<'_>, text: &mut String) {
    let &Section {
        si,
        sc,
        rows,
        ref rs,
        ..
    } = s;
    let q = sc.quantization;
    let wire = &sc.wire;
    let (sixteen, eight) = (
        rs.iter().find(|r| !r.eight_bit),
        rs.iter().find(|r| r.eight_bit),
    );
    let _ = write!(
        text,
        "Quantising the baseline to 8 bits per channel and back differs from its \
         16-bit pixels by RMSE {} (PSNR {} dB, SSIM {}).",
        sig3(q.rmse),
        fmt_psnr(q.psnr),
        fmt_ssim(q.ssim)
    );
    if let (Some(a), Some(b)) = (sixteen, eight) {
        let _ = write!(
            text,
            " Against the reference, the baseline's RMSE is {} with 16-bit pixels and \
             {} with 8-bit ones.",
            sig_pair(a.errors.rmse, b.errors.rmse).0,
            sig_pair(a.errors.rmse, b.errors.rmse).1
        );
    }
    let baud = strahl_serial::DEFAULT_BAUD;
    let _ = write!(
        text,
        " On the wire (the protocol carries 16-bit pixels only) a line result of {} \
         pixels is {:.0} bytes framed ({} of them pixel bytes), the image's {} line \
         results {} bytes; with 8-bit pixels they would be {:.0} bytes ({} pixel \
         bytes) and {} bytes, {:.0} % less. Over a serial line at the default {baud} \
         baud (8N1) that is {:.1} s against {:.1} s per image.",
        wire.width,
        wire.per_line(false),
        wire.pixel_bytes(false),
        wire.lines,
        fmt_bytes(wire.image16),
        wire.per_line(true),
        wire.pixel_bytes(true),
        fmt_bytes(wire.image8),
        wire.saving() * 100.0,
        serial_seconds(wire.image16, baud),
        serial_seconds(wire.image8, baud)
    );
    if let (Some(a), Some(b)) = (sixteen, eight) {
        let mut sw = sweep_of(&[*a, *b], sc);
        sw.dist[0][1] = q.rmse;
        sw.dist[1][0] = q.rmse;
        // The render closest to the main reference (octree rows are the baseline).
        let closest = rows
            .iter()
            .filter(|r| r.scene == si && r.reference == RefKind::Main && !r.eight_bit)
            .min_by(|x, y| x.errors.rmse.total_cmp(&y.errors.rmse))
            .map(|r| (format!("{} {}", r.knob.name(), r.value), r.errors.rmse));
        text.push_str(&precision_conclusion(
            &sw,
            q.rmse,
            closest.as_ref().map(|(l, e)| (l.as_str(), *e)),
            wire,
        ));
    }
}

pub(super) fn knob_intro(knob: Knob) -> String {
    match knob {
        Knob::Multisample => format!(
            "`-m N`: `N × N` stratified camera rays per pixel. The reference uses \
             {REFERENCE_SAMPLES}, the renderer's most."
        ),
        Knob::Adaptive => {
            "`--aa-threshold T` at multisample 4, in two passes: the first traces one \
             ray through each pixel's centre; the second gives the full 4 × 4 samples (16 more \
             rays, whose mean replaces the centre's colour) only to the pixels whose centre \
             differs from its left, right, upper or lower neighbour's by more than `T` in some \
             channel. Elsewhere the centre ray is the pixel. A refined pixel is exactly full \
             multisample 4's, so all the error beyond full multisample 4's is in pixels that \
             were not refined. These rows run the same two-pass path as `strahl render` (the \
             cluster master with in-process workers)."
                .to_string()
        }
        Knob::Cutoff => "The path weight below which reflection and refraction rays are not \
             traced (the seed's 10 %); the share not traced goes to the local colour. The \
             reference uses 0."
            .to_string(),
        Knob::Depth => format!(
            "`-d N`: the most bounces (reflection and refraction together), at the scene's \
             cut-off. The reference uses {REFERENCE_DEPTH} at cut-off 0."
        ),
        Knob::Occlusion => format!(
            "`-a N`: `N × N` occlusion rays at each shaded point scale the ambient term by the \
             share that escapes. Compared with the reference at level 9 (multisample \
             {OCCLUSION_REFERENCE_SAMPLES})."
        ),
        Knob::OctreeDepth | Knob::OctreeLeaf => "`--octree-depth` and `--octree-leaf` change \
             only the acceleration structure: the octree returns exactly the brute-force closest \
             hit, so the image must not change. The command checks every pixel against the \
             default octree's render and fails otherwise. Times are render times; the octree \
             build is not timed here (`strahl bench` measures it)."
            .to_string(),
        Knob::Precision => format!(
            "The protocol carries 16-bit pixels only: three little-endian `u16` channels, \
             {PIXEL_WIRE_BYTES} bytes per pixel in each `LineResult`. The 8-bit row is simulated: \
             the same render quantised to 8 bits per channel and widened back, so its time is \
             the same render's. What 8 bits would change is the error and the bytes on the wire \
             ({PIXEL_WIRE_BYTES_8} bytes per pixel), which are computed by encoding every line \
             of the baseline image as the protocol's framed `LineResult` (postcard, CRC-32, \
             COBS) with either pixel size."
        ),
    }
}

pub(super) fn knob_title(knob: Knob) -> &'static str {
    match knob {
        Knob::Multisample => "Multisample",
        Knob::Adaptive => "Adaptive multisampling threshold",
        Knob::Cutoff => "Reflection cut-off",
        Knob::Depth => "Depth cap",
        Knob::Occlusion => "Ambient-occlusion level",
        Knob::OctreeDepth => "Octree depth and leaf size",
        Knob::OctreeLeaf => "",
        Knob::Precision => "Pixel precision: 8 against 16 bits",
    }
}

pub(super) fn machine_info(cores: usize, load_start: &str) -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let cpu = crate::bench::machine::cpu_from(&cpuinfo)
        .0
        .unwrap_or_else(|| "CPU model unknown".to_string());
    let date = crate::bench::machine::today();
    format!(
        "{cores} CPUs ({cpu}), {} {}, {} build, {date}; 1-minute load average {load_start} at the \
         start, {} at the end",
        std::env::consts::OS,
        std::env::consts::ARCH,
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
        load_average()
    )
}

/// The 1-minute load average, from `/proc/loadavg` where there is one.
pub(super) fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|t| t.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "unknown".to_string())
}

pub(super) fn command_line() -> String {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .map(|a| {
            if a.is_empty() || a.contains(|c: char| c.is_whitespace() || "'\"$`\\".contains(c)) {
                format!("'{}'", a.replace('\'', r"'\''"))
            } else {
                a
            }
        })
        .collect();
    format!("strahl {}", args.join(" "))
}

#[allow(clippy::too_many_arguments)]
/// The Markdown report.
pub(super) fn report(
    args: &AccuracyOptions,
    scenes: &[SceneRun],
    skipped: &[String],
    rows: &[Row],
    cores: usize,
    total: Duration,
    svg_name: &str,
    load_start: &str,
) -> String {
    let mut md = String::new();
    intro(&mut md, args, skipped, cores, total, svg_name, load_start);
    method(&mut md);
    scenes_section(&mut md, scenes);
    results_section(&mut md, scenes, rows);
    front_and_knobs(&mut md, scenes, rows, svg_name);
    md
}

/// The title and how the run was made: command, machine, image size, runs, skipped scenes.
fn intro(
    md: &mut String,
    args: &AccuracyOptions,
    skipped: &[String],
    cores: usize,
    total: Duration,
    svg_name: &str,
    load_start: &str,
) {
    let runs = args.runs.max(1);
    let _ = writeln!(md, "# Accuracy and what it costs\n");
    let _ = writeln!(
        md,
        "Generated by `strahl bench accuracy`; rerun it to refresh this file and \
         [`{svg_name}`]({svg_name}). Every figure below comes from one run of the command.\n"
    );
    let _ = writeln!(md, "- Command: `{}`", command_line());
    let _ = writeln!(md, "- Machine: {}", machine_info(cores, load_start));
    let _ = writeln!(
        md,
        "- Image size {}×{}; every time is the median of {runs} run{} with {cores} in-process \
         worker{} (`render_local`, one per CPU); a run repeats a render shorter than {} ms \
         until it lasts that long and takes the mean. The runs go in rounds: each round \
         renders every setting of a scene once, starting at another setting each time, so a \
         busy spell of the machine spreads over all settings instead of spoiling one. Scene \
         preparation (octree build, scene encoding) is not timed. The `rays` column counts every ray of one render: a measure of work that no \
         other load on the machine disturbs. The whole command took {:.1} s.",
        args.size.width,
        args.size.height,
        if runs == 1 { "" } else { "s" },
        if cores == 1 { "" } else { "s" },
        MIN_RUN.as_millis(),
        total.as_secs_f64()
    );
    if args.quick {
        let _ = writeln!(md, "- `--quick`: fewer values per knob.");
    }
    for s in skipped {
        let _ = writeln!(md, "- Skipped: {s}");
    }
}

/// The method: references, residuals, baseline, error measures.
fn method(md: &mut String) {
    let _ = writeln!(md, "\n## Method\n");
    let _ = writeln!(
        md,
        "- **Reference.** Each scene is rendered once at multisample {REFERENCE_SAMPLES} ({} \
         stratified samples per pixel), reflection cut-off 0 and depth cap {REFERENCE_DEPTH}, \
         with ambient occlusion at the scene's level; multisample {REFERENCE_SAMPLES} is the \
         renderer's most. The reference is the renderer's own output: 16-bit fixed-point \
         pixels, colours clamped to [0, 1].",
        REFERENCE_SAMPLES * REFERENCE_SAMPLES
    );
    let _ = writeln!(
        md,
        "- **Residual.** A reference is not the truth. Each one is rendered again at half its \
         samples per side ({} for the main reference); the RMSE between the two, the \
         reference's *residual*, estimates its own error from above: the half-sample render is \
         the less accurate, and where their sampling errors are independent they add. The \
         renderer stops at multisample {MAX_SAMPLES}, so no render at twice the reference's \
         samples exists to compare with. The residual decides what the run resolves: for two \
         settings A and B whose images differ by RMSE d, the reference's own error can shift \
         RMSE(A)² − RMSE(B)² by at most 2·d·residual (Cauchy–Schwarz), so a difference within \
         that is reported as not resolved, and no conclusion rests on it.",
        residual_probe_samples(REFERENCE_SAMPLES)
    );
    let _ = writeln!(
        md,
        "- **Own references.** Ambient occlusion is compared with the reference at level 9, \
         rendered at multisample {OCCLUSION_REFERENCE_SAMPLES} ({} occlusion rays per pixel at \
         most; multisample 8 would take four times as long) unless the scene itself uses level \
         9. A scene with reflections off has its reflection cut-off and depth cap swept with \
         reflections on, compared with the reference with reflections on. The octree rows are \
         compared with the baseline render (they must match it exactly).",
        OCCLUSION_REFERENCE_SAMPLES
            * OCCLUSION_REFERENCE_SAMPLES
            * MAX_AMBIENT_OCCLUSION
            * MAX_AMBIENT_OCCLUSION
    );
    let _ = writeln!(
        md,
        "- **Baseline.** The scene's own settings at multisample 1. Each knob is changed alone \
         from it, so every error includes what the other knobs leave out (mostly aliasing at \
         multisample 1). The time ratio is against the baseline time of the same run."
    );
    let _ = writeln!(
        md,
        "- **Error.** RMSE over all channels of all pixels (colours in [0, 1]); PSNR = \
         20·log10(1 / RMSE) dB (∞ for identical images); SSIM on Rec. 709 luminance with an \
         11×11 Gaussian window (σ = 1.5), C1 = 0.01², C2 = 0.03², mean over the positions where \
         the window fits."
    );
    let _ = writeln!(
        md,
        "- **Not measured: f32 against an f64 reference.** The core renders in f32 (a `no_std` \
         renderer on `glam::Vec3`; f64 only settles triangle hits whose f32 `t` bound cannot \
         prove them in front of the ray); there is no f64 tracer to compare with, so no figure \
         is given rather than an invented one."
    );
}

/// The scenes, their references with residuals, and the timing noise of each.
fn scenes_section(md: &mut String, scenes: &[SceneRun]) {
    let _ = writeln!(md, "\n## Scenes\n");
    let _ = writeln!(
        md,
        "| scene | triangles | solids | baseline settings | baseline s |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|");
    for s in scenes {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} |",
            s.name,
            s.triangles,
            s.solids,
            settings_summary(&s.baseline),
            fmt_secs(s.baseline_time)
        );
    }
    let _ = writeln!(md, "\n### References and their residuals\n");
    let _ = writeln!(
        md,
        "| scene | reference | settings | s | × baseline | rays | residual render | its s | \
         residual (RMSE) | PSNR dB | SSIM |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|");
    for s in scenes {
        let base = s.baseline_time.as_secs_f64().max(1e-12);
        for r in &s.references {
            let kinds: Vec<&str> = r.kinds.iter().map(|k| k.name()).collect();
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} | multisample {} | {} | {} | {} | {} |",
                s.name,
                kinds.join("; "),
                settings_summary(&r.settings),
                fmt_secs(r.time),
                fmt_ratio(r.time.as_secs_f64() / base),
                fmt_rays(r.rays.total()),
                r.probe_samples,
                fmt_secs(r.probe_time),
                sig3(r.residual.rmse),
                fmt_psnr(r.residual.psnr),
                fmt_ssim(r.residual.ssim)
            );
        }
    }
    let _ = writeln!(
        md,
        "\nReference and residual times are one run each. The residual is each reference's RMSE \
         against the residual render; every RMSE below against that reference is uncertain by \
         about that much.\n"
    );
    let _ = writeln!(
        md,
        "**Timing noise.** Some settings do exactly the same work: the same image from the same \
         rays (for example a depth cap above the deepest path, or a cut-off no path reaches). \
         Their times should match; the spread between them shows how far to trust a time \
         difference in this run:\n"
    );
    for sc in scenes {
        match sc.noise() {
            Some((spread, n)) => {
                let _ = writeln!(
                    md,
                    "- {}: up to {:.0} % between {n} settings doing the same work.",
                    sc.name,
                    spread * 100.0
                );
            }
            None => {
                let _ = writeln!(md, "- {}: no two settings did the same work.", sc.name);
            }
        }
    }
    let _ = writeln!(md);
}

/// The results table and the line results on the wire.
fn results_section(md: &mut String, scenes: &[SceneRun], rows: &[Row]) {
    let _ = writeln!(md, "## Results\n");
    let _ = writeln!(
        md,
        "| scene | knob | value | median s | × baseline | RMSE | PSNR dB | SSIM | rays | compared with |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let sc = &scenes[r.scene];
        let cells = row_cells(&sc.name, r, sc.measured[r.measured].rays.total());
        let _ = writeln!(md, "| {} |", cells.join(" | "));
    }
    let _ = writeln!(
        md,
        "\nPixel precision: the protocol carries 16-bit pixels only ({PIXEL_WIRE_BYTES} bytes \
         each). The 8-bit rows are the 16-bit baseline quantised to 8 bits per channel after \
         the render, so they share its time and rays; an 8-bit wire would carry \
         {PIXEL_WIRE_BYTES_8} bytes per pixel. Framed line results of the baseline image \
         (`LineResult`, postcard, CRC-32, COBS, as the workers send them), 16 against 8 bits, \
         and their time over a serial line at {} baud (8N1):\n",
        strahl_serial::DEFAULT_BAUD
    );
    for sc in scenes {
        let wb = &sc.wire;
        let baud = strahl_serial::DEFAULT_BAUD;
        let _ = writeln!(
            md,
            "- {}: {:.0} against {:.0} bytes per line of {} pixels; {} against {} bytes per \
             image ({} lines), {:.0} % less; {:.1} s against {:.1} s at {baud} baud.",
            sc.name,
            wb.per_line(false),
            wb.per_line(true),
            wb.width,
            fmt_bytes(wb.image16),
            fmt_bytes(wb.image8),
            wb.lines,
            wb.saving() * 100.0,
            serial_seconds(wb.image16, baud),
            serial_seconds(wb.image8, baud)
        );
    }
}

/// The plot, each scene's Pareto front, the paragraph per knob and the f64 note.
fn front_and_knobs(md: &mut String, scenes: &[SceneRun], rows: &[Row], svg_name: &str) {
    let _ = writeln!(md, "\n## Error against time\n");
    let _ = writeln!(md, "![RMSE against median render time]({svg_name})\n");
    let _ = writeln!(
        md,
        "Both axes are logarithmic; one panel per scene. Filled points are compared with the \
         scene's reference; the black line joins the Pareto front among them (no other filled \
         point is both faster and closer to the reference). Hollow points have their own \
         reference (ambient occlusion, and the reflection knobs of a scene with reflections \
         off) and are not on the front. Points with RMSE 0 sit on the dashed line below the \
         axis. A render that several knobs share (the baseline) is drawn once, under the first \
         knob. Octree rows are left out (their error is the baseline's)."
    );
    let _ = writeln!(
        md,
        "\nThe Pareto front of each scene, fastest first (settings whose times differ by less \
         than the timing noise above can trade places on it):\n"
    );
    for (si, sc) in scenes.iter().enumerate() {
        let front: Vec<String> = front_rows(rows, si)
            .iter()
            .map(|r| {
                format!(
                    "{} ({}, RMSE {})",
                    r.short,
                    fmt_ratio(r.ratio),
                    sig3(r.errors.rmse)
                )
            })
            .collect();
        let _ = writeln!(md, "- {}: {}", sc.name, front.join(" → "));
    }
    let _ = writeln!(md, "\n## What each knob buys\n");
    for knob in Knob::ALL {
        if knob == Knob::OctreeLeaf {
            continue;
        }
        let _ = writeln!(md, "### {}\n", knob_title(knob));
        let _ = writeln!(md, "{}\n", knob_intro(knob));
        let _ = writeln!(md, "{}", paragraph(knob, scenes, rows));
    }
    let _ = writeln!(md, "### Floating point: f32 against f64\n");
    let _ = writeln!(
        md,
        "Not supported. The core computes in f32 (`no_std`, `glam::Vec3`, error-bounded f32 \
         intersection tests, with an f64 recheck only where a triangle hit's f32 bound is \
         inconclusive); an f64 reference would need a second renderer, so this report gives \
         no figure for it."
    );
}
