//! `strahl bench accuracy`: what each accuracy knob buys, and what it costs in time.
//!
//! For each scene (the demo room of `scenes/room/raytracer.cfg` and up to two `scenes/fart/*.fart`
//! by default, or the `--scene` files given) at a modest size, the command
//!
//! 1. renders a converged **reference**: multisample 16 (256 stratified samples per pixel, the
//!    renderer's most), reflection cut-off 0, depth cap 32, ambient occlusion at the scene's
//!    level. Pixels are the renderer's 16-bit fixed point, the reference's too. Two knobs get their
//!    own reference: ambient occlusion is compared with the same render at level 9, and the
//!    reflection knobs of a scene with reflections off are swept with reflections on and compared
//!    with the reference with reflections on. Every reference is also rendered at half its samples
//!    per side; the RMSE between the two is the reference's **residual**, an upper estimate of its
//!    own error, and differences between settings that the residual could explain are reported
//!    as not resolved;
//! 2. sweeps each knob alone from the **baseline** (the scene's own settings at multisample 1):
//!    multisample, adaptive threshold, reflection cut-off, depth cap, ambient-occlusion level,
//!    octree depth and leaf size, and 8- against 16-bit pixels (the protocol carries 16-bit pixels
//!    only: the 8-bit row is simulated on the rendered pixels, and the bytes its line results
//!    would take on the wire are computed with the protocol's own encoder);
//! 3. times every setting (median of `--runs` renders with one in-process worker per CPU, scene
//!    preparation not timed) and measures its error against the reference: RMSE and PSNR over
//!    the colour channels in `[0, 1]`, and SSIM (11×11 Gaussian window, σ = 1.5) on luminance;
//! 4. writes a Markdown report (`--out`, default `docs/accuracy.md`) with the table, an SVG plot
//!    of error against time with the Pareto front (written next to it), and a paragraph per knob
//!    generated from the measured numbers, each ending with a conclusion drawn from them.
//!
//! Octree settings must not change a pixel: the command fails, naming the setting and the first
//! pixel that differs, if one does.

use crate::cluster::local::render_local;
use crate::cluster::prepared::PreparedScene;
use crate::load::{load_scene, Overrides};
use anyhow::{anyhow, bail, Context as _};
use std::fmt::Write as _;
use std::io::Write as _;
use std::num::NonZeroUsize;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use strahl_core::error::ProtocolError;
use strahl_core::octree::OctreeParams;
use strahl_core::pixel::Pixel;
use strahl_core::protocol::frame::FrameWriter;
use strahl_core::protocol::message::{encode_pixels, WorkerMessage};
use strahl_core::protocol::PIXEL_WIRE_BYTES;
use strahl_core::scene::{
    RenderSettings, SceneDesc, MAX_AMBIENT_OCCLUSION, MAX_IMAGE_SIDE, MAX_SAMPLES,
};
use strahl_core::shade::RayCounts;

/// The demo room's configuration file, relative to the checkout's root.
pub const DEFAULT_ROOM: &str = "scenes/room/raytracer.cfg";
/// The folder whose `.fart` scenes are added by default: the first two that load of
/// [`PREFERRED_FART_SCENES`] and then the others by name.
pub const DEFAULT_FART_DIR: &str = "scenes/fart";
/// The `.fart` scenes tried first: facing mirrors (the reflection knobs matter) and glass
/// spheres (refraction, so the depth cap matters).
pub const PREFERRED_FART_SCENES: [&str; 2] = ["mirrors.fart", "glass.fart"];
/// The least wall time of one timed run: shorter renders repeat within the run, and the run's
/// time is the mean per render.
pub const MIN_RUN: Duration = Duration::from_millis(100);
/// Samples per pixel side of the main reference: the renderer's most ([`MAX_SAMPLES`]).
///
/// Chosen by measured cost. Multisample 8 was not converged: against multisample 16 its RMSE was
/// about 0.0009, as large as the differences between multisample 5, 6 and 7. There is no render
/// at twice the samples per side of multisample 16 to measure its residual against (the renderer
/// stops at 16), so the reference is multisample 16 and its residual is measured against
/// multisample 8 ([`residual_probe_samples`]), which bounds it from above. Multisample 16 costs
/// about four times multisample 8 (glass.fart at 240×180 on 2 CPUs: 2.8 s against 14.8 s): in the
/// run that wrote `docs/accuracy.md` (282 s) the three scenes' main references took 20 s at
/// multisample 8, so multisample 16 adds about a minute, and the residual renders (a quarter of
/// each reference, the ambient-occlusion ones included) about 45 s more: acceptable.
pub const REFERENCE_SAMPLES: u32 = MAX_SAMPLES;
/// Depth cap of the reference.
pub const REFERENCE_DEPTH: u32 = 32;
/// Samples per pixel side of the ambient-occlusion reference (level 9): 16 × 81 = 1,296
/// occlusion rays per pixel; multisample 8 would take four times as long. Its residual is
/// measured like the main reference's, against half the samples per side.
pub const OCCLUSION_REFERENCE_SAMPLES: u32 = 4;

/// Samples per pixel side of the render a reference's residual is measured against: half the
/// reference's (at least 1).
pub const fn residual_probe_samples(samples: u32) -> u32 {
    if samples > 1 {
        samples / 2
    } else {
        1
    }
}

/// An image size given as `WxH`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageSize {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// Parses `WxH` (for example `320x240`), each side 8 to [`MAX_IMAGE_SIDE`].
///
/// # Errors
/// A message naming what is wrong.
pub fn parse_size(s: &str) -> Result<ImageSize, String> {
    let (w, h) = s
        .split_once(['x', 'X', '×'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, e.g. 320x240, found `{s}`"))?;
    let side = |v: &str, what: &str| -> Result<u32, String> {
        let n: u32 = v
            .trim()
            .parse()
            .map_err(|_| format!("the {what} `{v}` is not a whole number"))?;
        if !(8..=MAX_IMAGE_SIDE).contains(&n) {
            return Err(format!(
                "the {what} must be 8 to {MAX_IMAGE_SIDE} pixels, found {n}"
            ));
        }
        Ok(n)
    };
    Ok(ImageSize {
        width: side(w, "width")?,
        height: side(h, "height")?,
    })
}

/// Arguments of `strahl bench accuracy`.
#[derive(Debug, clap::Args)]
pub struct AccuracyArgs {
    /// A scene to measure (repeatable) [default: scenes/room/raytracer.cfg and the first two
    /// scenes/fart/*.fart that load, mirrors.fart and glass.fart first; from the current folder].
    #[arg(long = "scene", value_name = "PATH")]
    pub scenes: Vec<PathBuf>,
    /// Image size of every render.
    #[arg(long, value_name = "WxH", default_value = "320x240", value_parser = parse_size)]
    pub size: ImageSize,
    /// Timed runs per setting (the median is reported).
    #[arg(long, value_name = "N", default_value_t = 3,
          value_parser = clap::value_parser!(u32).range(1..=100))]
    pub runs: u32,
    /// The Markdown report; the SVG plot goes next to it (same name, `.svg`).
    #[arg(long, value_name = "FILE", default_value = "docs/accuracy.md")]
    pub out: PathBuf,
    /// Sweep fewer values of each knob (for tests and a first look).
    #[arg(long)]
    pub quick: bool,
}

// ---------------------------------------------------------------------------------------------
// Metrics
// ---------------------------------------------------------------------------------------------

/// An image as linear colours in `[0, 1]`, row-major.
pub type Colors = Vec<[f32; 3]>;

/// The colours of 16-bit pixels.
pub fn to_colors(pixels: &[Pixel]) -> Colors {
    pixels
        .iter()
        .map(|p| p.0.map(|c| f32::from(c) / 65535.0))
        .collect()
}

/// `pixels` sent as 8 bits per channel and widened back to 16 (what an 8-bit wire would deliver).
pub fn through_8_bits(pixels: &[Pixel]) -> Vec<Pixel> {
    pixels
        .iter()
        .map(|p| Pixel(p.to_rgb8().map(|c| u16::from(c) * 257)))
        .collect()
}

/// Root-mean-square difference over every channel of every pixel (colours in `[0, 1]`); 0 for
/// identical images. Images of different lengths compare over the shorter.
pub fn rmse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let n = a.len().min(b.len());
    if n == 0 {
        return 0.0;
    }
    let sum: f64 = a
        .iter()
        .zip(b)
        .flat_map(|(p, q)| (0..3).map(move |c| f64::from(p[c]) - f64::from(q[c])))
        .map(|d| d * d)
        .sum();
    (sum / (3 * n) as f64).sqrt()
}

/// Peak signal-to-noise ratio in dB for colours in `[0, 1]`: `20·log10(1 / rmse)`, infinite for
/// identical images.
pub fn psnr(rmse: f64) -> f64 {
    if rmse <= 0.0 {
        f64::INFINITY
    } else {
        -20.0 * rmse.log10()
    }
}

/// Rec. 709 luminance of linear colours.
fn luminance(img: &[[f32; 3]]) -> Vec<f64> {
    img.iter()
        .map(|c| 0.2126 * f64::from(c[0]) + 0.7152 * f64::from(c[1]) + 0.0722 * f64::from(c[2]))
        .collect()
}

/// Structural similarity (Wang et al. 2004) of two `width × height` images on luminance: an
/// 11×11 Gaussian window with σ = 1.5 over every position where it fits (smaller images get
/// the largest odd window that fits, σ scaled with it), `C1 = (0.01)²`, `C2 = (0.03)²` for a
/// dynamic range of 1, averaged. 1 for identical images; near or below 0 for unrelated or
/// inverted ones.
pub fn ssim(a: &[[f32; 3]], b: &[[f32; 3]], width: usize, height: usize) -> f64 {
    let n = width * height;
    if n == 0 || a.len() < n || b.len() < n {
        return 0.0;
    }
    let mut size = 11.min(width).min(height);
    if size % 2 == 0 {
        size -= 1;
    }
    let sigma = 1.5 * size as f64 / 11.0;
    let r = (size / 2) as isize;
    let mut weights: Vec<f64> = (-r..=r)
        .map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    let total: f64 = weights.iter().sum();
    weights.iter_mut().for_each(|w| *w /= total);

    let x = luminance(&a[..n]);
    let y = luminance(&b[..n]);
    let planes: [Vec<f64>; 5] = [
        x.clone(),
        y.clone(),
        x.iter().map(|v| v * v).collect(),
        y.iter().map(|v| v * v).collect(),
        x.iter().zip(&y).map(|(p, q)| p * q).collect(),
    ];
    // Separable filtering over the valid region: rows first, then columns.
    let (ow, oh) = (width + 1 - size, height + 1 - size);
    let filter = |plane: &[f64]| -> Vec<f64> {
        let mut rows = vec![0.0; ow * height];
        for yy in 0..height {
            for xx in 0..ow {
                rows[yy * ow + xx] = weights
                    .iter()
                    .enumerate()
                    .map(|(k, w)| w * plane[yy * width + xx + k])
                    .sum();
            }
        }
        let mut out = vec![0.0; ow * oh];
        for yy in 0..oh {
            for xx in 0..ow {
                out[yy * ow + xx] = weights
                    .iter()
                    .enumerate()
                    .map(|(k, w)| w * rows[(yy + k) * ow + xx])
                    .sum();
            }
        }
        out
    };
    let [mx, my, mxx, myy, mxy] = planes.map(|p| filter(&p));
    let (c1, c2) = (0.01f64 * 0.01, 0.03f64 * 0.03);
    let sum: f64 = (0..ow * oh)
        .map(|i| {
            let (ux, uy) = (mx[i], my[i]);
            let vx = mxx[i] - ux * ux;
            let vy = myy[i] - uy * uy;
            let cxy = mxy[i] - ux * uy;
            ((2.0 * ux * uy + c1) * (2.0 * cxy + c2)) / ((ux * ux + uy * uy + c1) * (vx + vy + c2))
        })
        .sum();
    sum / (ow * oh) as f64
}

/// The Pareto front of `(time, error)` points, both to be minimised: the indices of the points
/// that no other point matches or beats in both with one strictly better, ordered by time.
/// Points with a non-finite coordinate are left out; of equal points the first is kept.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    order.sort_by(|&i, &j| {
        points[i]
            .0
            .total_cmp(&points[j].0)
            .then(points[i].1.total_cmp(&points[j].1))
            .then(i.cmp(&j))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

// ---------------------------------------------------------------------------------------------
// Bytes on the wire
// ---------------------------------------------------------------------------------------------

/// Bytes per pixel of an 8-bit wire: one byte per channel (the protocol's pixels are
/// [`PIXEL_WIRE_BYTES`], three little-endian `u16`).
pub const PIXEL_WIRE_BYTES_8: usize = 3;

/// Bits on a serial line per byte: 8N1 (start bit, 8 data bits, stop bit).
pub const SERIAL_BITS_PER_BYTE: u32 = 10;

/// The bytes one image's line results take on the wire, framed as the protocol sends them
/// (postcard payload, CRC-32, COBS, both `0x00` delimiters), with 16-bit pixels as the protocol
/// carries them and with 8-bit ones as an 8-bit wire would.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WireBytes {
    /// Pixels per line.
    pub width: u32,
    /// Lines (one `LineResult` each; an adaptive render sends a second one per refined line).
    pub lines: u32,
    /// Every line result with 16-bit pixels ([`PIXEL_WIRE_BYTES`] each).
    pub image16: usize,
    /// Every line result with 8-bit pixels ([`PIXEL_WIRE_BYTES_8`] each, in the same field).
    pub image8: usize,
}

impl WireBytes {
    /// Mean framed bytes of one line result.
    pub fn per_line(&self, eight_bit: bool) -> f64 {
        let total = if eight_bit { self.image8 } else { self.image16 };
        total as f64 / f64::from(self.lines.max(1))
    }

    /// The pixel bytes alone of one line.
    pub fn pixel_bytes(&self, eight_bit: bool) -> usize {
        self.width as usize
            * if eight_bit {
                PIXEL_WIRE_BYTES_8
            } else {
                PIXEL_WIRE_BYTES
            }
    }

    /// The share of the image's bytes an 8-bit wire would save.
    pub fn saving(&self) -> f64 {
        if self.image16 == 0 {
            0.0
        } else {
            1.0 - self.image8 as f64 / self.image16 as f64
        }
    }
}

/// Seconds `bytes` take on a serial line at `baud`, 8N1.
pub fn serial_seconds(bytes: usize, baud: u32) -> f64 {
    bytes as f64 * f64::from(SERIAL_BITS_PER_BYTE) / f64::from(baud.max(1))
}

/// The framed `LineResult` of line `line` of job `job` carrying `pixels` as the protocol encodes
/// them ([`encode_pixels`], 16 bits per channel) or, with `eight_bit`, as 8-bit channels in the
/// same field (a message the protocol does not define: decoders reject it; only its length
/// matters). Returns the frame's bytes, delimiters included.
///
/// # Errors
/// [`ProtocolError::Encode`] if postcard cannot encode the message.
pub fn line_result_frame(
    writer: &mut FrameWriter,
    job: u32,
    line: u32,
    rays: RayCounts,
    pixels: &[Pixel],
    eight_bit: bool,
) -> Result<Vec<u8>, ProtocolError> {
    let bytes: Vec<u8> = if eight_bit {
        pixels.iter().flat_map(|p| p.to_rgb8()).collect()
    } else {
        let mut wire = vec![0u8; pixels.len() * PIXEL_WIRE_BYTES];
        encode_pixels(pixels, &mut wire)?;
        wire
    };
    let frame = writer.encode(&WorkerMessage::LineResult {
        job,
        line,
        refined: false,
        rays,
        pixels: &bytes,
    })?;
    Ok(frame.to_vec())
}

/// The line results of an image (`pixels`, row-major, `width` per line) that took `rays`, one
/// per line, with 16- and with 8-bit pixels. Each line carries the image's mean rays per line
/// (a ray count takes one to a few bytes). Job 1 (job numbers take one byte up to 127).
///
/// # Errors
/// [`ProtocolError::Encode`] if a message cannot be encoded.
pub fn wire_bytes(
    pixels: &[Pixel],
    width: u32,
    rays: RayCounts,
) -> Result<WireBytes, ProtocolError> {
    let w = width.max(1) as usize;
    let lines = (pixels.len() / w) as u32;
    let n = u64::from(lines.max(1));
    let per_line = RayCounts {
        primary: rays.primary / n,
        extra_samples: rays.extra_samples / n,
        shadow: rays.shadow / n,
        reflection: rays.reflection / n,
        refraction: rays.refraction / n,
        occlusion: rays.occlusion / n,
    };
    let mut writer = FrameWriter::new();
    let (mut image16, mut image8) = (0, 0);
    for (y, line) in pixels.chunks_exact(w).enumerate() {
        image16 += line_result_frame(&mut writer, 1, y as u32, per_line, line, false)?.len();
        image8 += line_result_frame(&mut writer, 1, y as u32, per_line, line, true)?.len();
    }
    Ok(WireBytes {
        width,
        lines,
        image16,
        image8,
    })
}

/// Bytes with thousands separated by a thin space (`1 234 567`).
fn fmt_bytes(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push('\u{2009}');
        }
        out.push(c);
    }
    out
}

// ---------------------------------------------------------------------------------------------
// The sweep
// ---------------------------------------------------------------------------------------------

/// The knobs swept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Knob {
    /// Samples per pixel side (`-m`).
    Multisample,
    /// Adaptive multisampling threshold at multisample 4.
    Adaptive,
    /// Reflection (and refraction) weight cut-off.
    Cutoff,
    /// Bounce depth cap.
    Depth,
    /// Ambient-occlusion level.
    Occlusion,
    /// Octree depth limit.
    OctreeDepth,
    /// Octree leaf size.
    OctreeLeaf,
    /// Bits per channel of the pixels on the wire.
    Precision,
}

impl Knob {
    /// Every knob, in report order.
    pub const ALL: [Knob; 8] = [
        Knob::Multisample,
        Knob::Adaptive,
        Knob::Cutoff,
        Knob::Depth,
        Knob::Occlusion,
        Knob::OctreeDepth,
        Knob::OctreeLeaf,
        Knob::Precision,
    ];

    /// The knob's name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Knob::Multisample => "multisample",
            Knob::Adaptive => "adaptive threshold (m 4)",
            Knob::Cutoff => "reflection cut-off",
            Knob::Depth => "depth cap",
            Knob::Occlusion => "ambient occlusion",
            Knob::OctreeDepth => "octree depth",
            Knob::OctreeLeaf => "octree leaf size",
            Knob::Precision => "pixel precision",
        }
    }

    /// Its colour in the plot.
    fn color(self) -> &'static str {
        match self {
            Knob::Multisample => "#1f77b4",
            Knob::Adaptive => "#ff7f0e",
            Knob::Cutoff => "#2ca02c",
            Knob::Depth => "#d62728",
            Knob::Occlusion => "#9467bd",
            Knob::OctreeDepth => "#8c564b",
            Knob::OctreeLeaf => "#e377c2",
            Knob::Precision => "#7f7f7f",
        }
    }
}

/// What a row's error is measured against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RefKind {
    /// The converged reference at the scene's settings.
    Main,
    /// The reference with reflections turned on (scenes that have them off).
    Reflections,
    /// The reference at ambient-occlusion level 9.
    Occlusion9,
    /// The baseline render with the default octree (octree rows: must be identical).
    Baseline,
}

impl RefKind {
    fn name(self) -> &'static str {
        match self {
            RefKind::Main => "reference",
            RefKind::Reflections => "reference, reflections on",
            RefKind::Occlusion9 => "reference, AO 9 (m 4)",
            RefKind::Baseline => "baseline (default octree)",
        }
    }
}

/// One render configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Config {
    settings: RenderSettings,
    octree: OctreeParams,
}

/// A configuration rendered and timed.
struct Measured {
    config: Config,
    /// Wall time of each render, one per round.
    times: Vec<Duration>,
    /// Median of `times`.
    time: Duration,
    pixels: Vec<Pixel>,
    colors: Colors,
    rays: RayCounts,
    /// Index of the first measured configuration of this scene with exactly these pixels.
    image: usize,
}

/// The three error figures.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Errors {
    rmse: f64,
    psnr: f64,
    ssim: f64,
}

/// One row of the report.
struct Row {
    scene: usize,
    knob: Knob,
    value: String,
    /// Short label in the plot.
    short: String,
    /// Index into the scene's measured configurations.
    measured: usize,
    /// 8-bit pixels (precision row).
    eight_bit: bool,
    reference: RefKind,
    time: Duration,
    ratio: f64,
    errors: Errors,
}

/// A reference as rendered, with its residual.
struct Reference {
    /// The comparisons it serves (several when they share its settings).
    kinds: Vec<RefKind>,
    settings: RenderSettings,
    /// Render time (one run).
    time: Duration,
    rays: RayCounts,
    /// Samples per pixel side of the residual render ([`residual_probe_samples`]).
    probe_samples: u32,
    /// Its render time (one run).
    probe_time: Duration,
    /// The residual render's error against the reference: its RMSE is the reference's residual.
    residual: Errors,
}

/// A scene as measured.
struct SceneRun {
    name: String,
    triangles: usize,
    solids: usize,
    baseline: RenderSettings,
    baseline_time: Duration,
    /// The distinct references.
    references: Vec<Reference>,
    reflections_forced: bool,
    measured: Vec<Measured>,
    /// Error of 8-bit against 16-bit pixels of the baseline render.
    quantization: Errors,
    /// The baseline image's line results on the wire.
    wire: WireBytes,
}

impl SceneRun {
    /// The residual (RMSE) of the reference that `kind` compares with; 0 for the baseline.
    fn residual(&self, kind: RefKind) -> f64 {
        self.residual_errors(kind).map_or(0.0, |e| e.rmse)
    }

    /// The residual render's errors against the reference that `kind` compares with; `None`
    /// for the baseline (compared exactly).
    fn residual_errors(&self, kind: RefKind) -> Option<Errors> {
        self.references
            .iter()
            .find(|r| r.kinds.contains(&kind))
            .map(|r| r.residual)
    }

    /// The largest relative spread of median times among settings that do the same work (default
    /// octree, identical image, identical ray counts): `(max / min − 1, how many settings)`.
    fn noise(&self) -> Option<(f64, usize)> {
        let same_octree: Vec<&Measured> = self
            .measured
            .iter()
            .filter(|m| m.config.octree == OctreeParams::default())
            .collect();
        let mut worst: Option<(f64, usize)> = None;
        for (i, a) in same_octree.iter().enumerate() {
            let group: Vec<&&Measured> = same_octree[i..]
                .iter()
                .filter(|b| b.image == a.image && b.rays == a.rays)
                .collect();
            if group.len() < 2 {
                continue;
            }
            let (lo, hi) = group.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), m| {
                let t = m.time.as_secs_f64();
                (lo.min(t), hi.max(t))
            });
            if lo > 0.0 {
                let spread = hi / lo - 1.0;
                if worst.is_none_or(|(w, _)| spread > w) {
                    worst = Some((spread, group.len()));
                }
            }
        }
        worst
    }
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v.get(v.len() / 2).copied().unwrap_or_default()
}

/// A fraction as a percentage with at most two decimals (`0.1` is `10 %`, `0.005` is `0.5 %`).
fn percent(v: f32) -> String {
    let p = format!("{:.2}", f64::from(v) * 100.0);
    let p = p.trim_end_matches('0').trim_end_matches('.');
    format!("{p} %")
}

/// The planned rows of one scene: knob, value, plot label, configuration, reference.
fn plan(
    baseline: &RenderSettings,
    quick: bool,
) -> Vec<(Knob, String, String, Config, RefKind, bool)> {
    let octree = OctreeParams::default();
    let cfg = |settings: RenderSettings| Config { settings, octree };
    let mut rows = Vec::new();
    let pick = |full: &[u32], q: &[u32]| -> Vec<u32> {
        if quick {
            q.to_vec()
        } else {
            full.to_vec()
        }
    };
    for m in pick(&[1, 2, 3, 4, 5, 6, 7, 8], &[1, 2, 4]) {
        let s = RenderSettings {
            samples: m,
            aa_threshold: -1.0,
            ..*baseline
        };
        rows.push((
            Knob::Multisample,
            format!("{m} ({} spp)", m * m),
            format!("m{m}"),
            cfg(s),
            RefKind::Main,
            false,
        ));
    }
    let thresholds: &[f32] = if quick {
        &[0.1]
    } else {
        &[0.3, 0.1, 0.03, 0.01]
    };
    for &t in thresholds {
        let s = RenderSettings {
            samples: 4,
            aa_threshold: t,
            ..*baseline
        };
        rows.push((
            Knob::Adaptive,
            format!("{t}"),
            format!("t{t}"),
            cfg(s),
            RefKind::Main,
            false,
        ));
    }
    let reflect_ref = if baseline.reflections {
        RefKind::Main
    } else {
        RefKind::Reflections
    };
    let reflective = RenderSettings {
        reflections: true,
        ..*baseline
    };
    // The scene's own cut-off and depth cap join the sweeps.
    let mut cutoffs: Vec<f32> = if quick {
        vec![0.1, 0.0]
    } else {
        vec![0.1, 0.05, 0.01, 0.0]
    };
    if !cutoffs.contains(&baseline.min_reflection_weight) {
        cutoffs.push(baseline.min_reflection_weight);
        cutoffs.sort_by(|a, b| b.total_cmp(a));
    }
    for c in cutoffs {
        let s = RenderSettings {
            min_reflection_weight: c,
            ..reflective
        };
        rows.push((
            Knob::Cutoff,
            percent(c),
            format!("cut {}", percent(c)),
            cfg(s),
            reflect_ref,
            false,
        ));
    }
    let mut depths = pick(&[1, 2, 4, 8, 16], &[1, 16]);
    if !depths.contains(&baseline.max_depth) {
        depths.push(baseline.max_depth);
        depths.sort_unstable();
    }
    for d in depths {
        let s = RenderSettings {
            max_depth: d,
            ..reflective
        };
        rows.push((
            Knob::Depth,
            d.to_string(),
            format!("d{d}"),
            cfg(s),
            reflect_ref,
            false,
        ));
    }
    let levels: Vec<u32> = match (baseline.ambient_occlusion, quick) {
        (0, false) => vec![0, 1, 2, 4],
        (0, true) => vec![0, 1],
        (l, false) => (0..=MAX_AMBIENT_OCCLUSION).chain([l]).collect(),
        (l, true) => vec![0, l, MAX_AMBIENT_OCCLUSION],
    };
    let mut seen = Vec::new();
    for a in levels {
        if seen.contains(&a) {
            continue;
        }
        seen.push(a);
        let s = RenderSettings {
            ambient_occlusion: a,
            ..*baseline
        };
        rows.push((
            Knob::Occlusion,
            match a {
                0 => "0 (off)".to_string(),
                1 => "1 (1 ray)".to_string(),
                _ => format!("{a} ({} rays)", a * a),
            },
            format!("AO {a}"),
            cfg(s),
            RefKind::Occlusion9,
            false,
        ));
    }
    for d in pick(&[4, 8, 12, 16, 20], &[4, 16]) {
        rows.push((
            Knob::OctreeDepth,
            d.to_string(),
            format!("depth {d}"),
            Config {
                settings: *baseline,
                octree: OctreeParams {
                    max_depth: d,
                    ..octree
                },
            },
            RefKind::Baseline,
            false,
        ));
    }
    for l in pick(&[1, 2, 4, 8, 16, 32], &[1, 8]) {
        rows.push((
            Knob::OctreeLeaf,
            l.to_string(),
            format!("leaf {l}"),
            Config {
                settings: *baseline,
                octree: OctreeParams {
                    max_leaf_triangles: l,
                    ..octree
                },
            },
            RefKind::Baseline,
            false,
        ));
    }
    for bits in [16, 8] {
        rows.push((
            Knob::Precision,
            format!("{bits} bit"),
            format!("{bits} bit"),
            cfg(*baseline),
            RefKind::Main,
            bits == 8,
        ));
    }
    rows
}

/// Renders `desc` with `config` `runs` times on `workers` in-process workers; returns the median
/// time, the pixels and the rays. Every run must give the same pixels. Scene preparation is not
/// timed.
fn render_timed(
    name: &str,
    desc: &SceneDesc,
    config: &Config,
    workers: usize,
    runs: usize,
) -> anyhow::Result<(Duration, Vec<Pixel>, RayCounts)> {
    let mut d = desc.clone();
    d.settings = config.settings;
    let prepared = PreparedScene::new(&d, &config.octree).map_err(|e| anyhow!("{name}: {e}"))?;
    let mut times = Vec::with_capacity(runs);
    let mut first: Option<(Vec<Pixel>, RayCounts)> = None;
    for _ in 0..runs.max(1) {
        // Short renders repeat until the run lasts MIN_RUN: the time is per render.
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
        times.push(t.elapsed() / count);
        match &first {
            None => first = Some((img.pixels, img.rays)),
            Some((p, _)) if *p != img.pixels => {
                bail!("{name}: two renders of the same settings differ (a bug): {config:?}")
            }
            Some(_) => {}
        }
    }
    let (pixels, rays) = first.ok_or_else(|| anyhow!("{name}: no render"))?;
    Ok((median(times), pixels, rays))
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

// ---------------------------------------------------------------------------------------------
// Formatting
// ---------------------------------------------------------------------------------------------

/// `v` with three significant digits, without exponent.
fn sig3(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    if !v.is_finite() {
        return v.to_string();
    }
    let mag = v.abs().log10().floor() as i32;
    let decimals = (2 - mag).max(0) as usize;
    format!("{v:.decimals$}")
}

fn fmt_psnr(p: f64) -> String {
    if p.is_infinite() {
        "∞".to_string()
    } else {
        format!("{p:.2}")
    }
}

fn fmt_ssim(s: f64) -> String {
    if s == 1.0 {
        "1".to_string()
    } else {
        format!("{s:.5}")
    }
}

fn fmt_secs(t: Duration) -> String {
    format!("{:.3}", t.as_secs_f64())
}

fn fmt_ratio(r: f64) -> String {
    if r >= 10.0 {
        format!("{r:.1}×")
    } else {
        format!("{r:.2}×")
    }
}

fn fmt_rays(r: u64) -> String {
    if r >= 10_000_000 {
        format!("{:.0} M", r as f64 / 1e6)
    } else if r >= 1_000_000 {
        format!("{:.1} M", r as f64 / 1e6)
    } else if r >= 10_000 {
        format!("{:.0} k", r as f64 / 1e3)
    } else {
        r.to_string()
    }
}

/// Two figures to three significant digits, or five where three would look the same.
fn sig_pair(a: f64, b: f64) -> (String, String) {
    let (x, y) = (sig3(a), sig3(b));
    if x != y || a == b {
        return (x, y);
    }
    let five = |v: f64| {
        let mag = v.abs().log10().floor() as i32;
        let decimals = (4 - mag).max(0) as usize;
        format!("{v:.decimals$}")
    };
    (five(a), five(b))
}

/// "lowers RMSE from a to b", "raises ...", or "leaves RMSE at a".
fn rmse_change(a: f64, b: f64) -> String {
    let (x, y) = sig_pair(a, b);
    if a == b {
        format!("leaves RMSE at {x}")
    } else if b < a {
        format!("lowers RMSE from {x} to {y}")
    } else {
        format!("raises RMSE from {x} to {y}")
    }
}

fn settings_summary(s: &RenderSettings) -> String {
    format!(
        "multisample {}, shadows {}, reflections {}, cut-off {}, depth cap {}, AO {}",
        s.samples,
        if s.shadows { "on" } else { "off" },
        if s.reflections { "on" } else { "off" },
        percent(s.min_reflection_weight),
        s.max_depth,
        s.ambient_occlusion
    )
}

fn stdout_row(
    out: &mut impl std::io::Write,
    scene: &str,
    r: &Row,
    rays: u64,
) -> std::io::Result<()> {
    writeln!(
        out,
        "{:<28} {:<26} {:>12} {:>9} {:>8} {:>10} {:>7} {:>8} {:>8}  {}",
        scene,
        r.knob.name(),
        r.value,
        fmt_secs(r.time),
        fmt_ratio(r.ratio),
        sig3(r.errors.rmse),
        fmt_psnr(r.errors.psnr),
        fmt_ssim(r.errors.ssim),
        fmt_rays(rays),
        r.reference.name()
    )
}

// ---------------------------------------------------------------------------------------------
// The plot
// ---------------------------------------------------------------------------------------------

/// One point of the plot.
#[derive(Clone, Debug)]
pub struct PlotPoint {
    /// Median time in seconds.
    pub time: f64,
    /// RMSE against the reference (0 is drawn on the strip below the axis).
    pub rmse: f64,
    /// The knob, for its colour.
    pub knob: Knob,
    /// Short label.
    pub label: String,
    /// Compared with the panel's main reference (filled, eligible for the front); hollow points
    /// have a knob-specific reference.
    pub main: bool,
}

/// One panel of the plot: a scene.
#[derive(Clone, Debug)]
pub struct PlotPanel {
    /// The scene's name.
    pub title: String,
    /// Its points.
    pub points: Vec<PlotPoint>,
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Tick values `{1, 2, 5} × 10^k` in `[lo, hi]` (only powers of ten over a range of 100× or more).
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Vec::new();
    }
    let mantissas: &[f64] = if hi / lo >= 100.0 {
        &[1.0]
    } else {
        &[1.0, 2.0, 5.0]
    };
    let mut ticks = Vec::new();
    for k in (lo.log10().floor() as i32)..=(hi.log10().ceil() as i32) {
        for &m in mantissas {
            let v = m * 10f64.powi(k);
            if v >= lo * 0.999_999 && v <= hi * 1.000_001 {
                ticks.push(v);
            }
        }
    }
    ticks
}

/// A tick label: one significant digit, no exponent.
fn tick_label(v: f64) -> String {
    let mag = v.log10().floor() as i32;
    let decimals = (-mag).max(0) as usize;
    format!("{v:.decimals$}")
}

/// The plot as an SVG document: one panel per scene, RMSE (log) against median time (log), the
/// Pareto front of the filled points connected by a line (`class="pareto"`).
pub fn svg(panels: &[PlotPanel]) -> String {
    const W: f64 = 820.0;
    const PH: f64 = 440.0;
    const X0: f64 = 80.0;
    const X1: f64 = 600.0;
    const TOP: f64 = 46.0;
    const PLOT_H: f64 = 300.0;
    let height = PH * panels.len().max(1) as f64 + 10.0;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{height}" viewBox="0 0 {W} {height}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(
        s,
        r#"<rect x="0" y="0" width="{W}" height="{height}" fill="white"/>"#
    );
    for (pi, panel) in panels.iter().enumerate() {
        let oy = pi as f64 * PH;
        let (y0, y1) = (oy + TOP, oy + TOP + PLOT_H);
        let zero_y = y1 + 22.0;
        let _ = writeln!(
            s,
            r#"<text x="{X0}" y="{}" font-size="15" font-weight="bold">{}</text>"#,
            oy + 24.0,
            xml_escape(&panel.title)
        );
        let pts: Vec<&PlotPoint> = panel
            .points
            .iter()
            .filter(|p| p.time > 0.0 && p.time.is_finite() && p.rmse.is_finite())
            .collect();
        if pts.is_empty() {
            let _ = writeln!(s, r#"<text x="{X0}" y="{}">no points</text>"#, y0 + 20.0);
            continue;
        }
        let (tmin, tmax) = pts.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.time), b.max(p.time))
        });
        let positive: Vec<f64> = pts.iter().map(|p| p.rmse).filter(|&e| e > 0.0).collect();
        let (emin, emax) = if positive.is_empty() {
            (1e-4, 1e-1)
        } else {
            positive
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(a, b), &e| (a.min(e), b.max(e)))
        };
        let (lx0, lx1) = ((tmin / 1.25).log10(), (tmax * 1.25).log10());
        let (ly0, ly1) = ((emin / 1.5).log10(), (emax * 1.5).log10());
        let lx1 = if lx1 - lx0 < 0.3 { lx0 + 0.3 } else { lx1 };
        let ly1 = if ly1 - ly0 < 0.3 { ly0 + 0.3 } else { ly1 };
        let fx = |t: f64| X0 + (t.log10() - lx0) / (lx1 - lx0) * (X1 - X0);
        let fy = |e: f64| {
            if e > 0.0 {
                y1 - (e.log10() - ly0) / (ly1 - ly0) * PLOT_H
            } else {
                zero_y
            }
        };
        // Frame, grid and ticks.
        let _ = writeln!(
            s,
            r##"<rect x="{X0}" y="{y0}" width="{}" height="{PLOT_H}" fill="none" stroke="#444"/>"##,
            X1 - X0
        );
        for t in log_ticks(10f64.powf(lx0), 10f64.powf(lx1)) {
            let x = fx(t);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{y0}" x2="{x:.1}" y2="{y1}" stroke="#ddd"/><text x="{x:.1}" y="{}" text-anchor="middle">{}</text>"##,
                zero_y + 20.0,
                tick_label(t)
            );
        }
        for e in log_ticks(10f64.powf(ly0), 10f64.powf(ly1)) {
            let y = fy(e);
            let _ = writeln!(
                s,
                r##"<line x1="{X0}" y1="{y:.1}" x2="{X1}" y2="{y:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" text-anchor="end">{}</text>"##,
                X0 - 6.0,
                y + 4.0,
                tick_label(e)
            );
        }
        let _ = writeln!(
            s,
            r##"<line x1="{X0}" y1="{zero_y}" x2="{X1}" y2="{zero_y}" stroke="#bbb" stroke-dasharray="4 3"/><text x="{}" y="{}" text-anchor="end">0</text>"##,
            X0 - 6.0,
            zero_y + 4.0
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">median render time, s (log scale)</text>"#,
            (X0 + X1) / 2.0,
            zero_y + 40.0
        );
        let _ = writeln!(
            s,
            r#"<text transform="translate({},{}) rotate(-90)" text-anchor="middle">RMSE against the reference (log scale)</text>"#,
            X0 - 58.0,
            (y0 + y1) / 2.0
        );
        // Points: hollow first, then filled.
        for p in pts.iter().filter(|p| !p.main) {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="white" stroke="{}" stroke-width="1.5"><title>{}</title></circle>"#,
                fx(p.time),
                fy(p.rmse),
                p.knob.color(),
                xml_escape(&p.label)
            );
        }
        for p in pts.iter().filter(|p| p.main) {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{}"><title>{}</title></circle>"#,
                fx(p.time),
                fy(p.rmse),
                p.knob.color(),
                xml_escape(&p.label)
            );
        }
        // The Pareto front of the filled points.
        let main: Vec<&PlotPoint> = pts.iter().copied().filter(|p| p.main).collect();
        let front = pareto_front(&main.iter().map(|p| (p.time, p.rmse)).collect::<Vec<_>>());
        if !front.is_empty() {
            let line: Vec<String> = front
                .iter()
                .map(|&i| format!("{:.1},{:.1}", fx(main[i].time), fy(main[i].rmse)))
                .collect();
            let _ = writeln!(
                s,
                r#"<polyline class="pareto" points="{}" fill="none" stroke="black" stroke-width="2"/>"#,
                line.join(" ")
            );
            // Labels go beside their ring where they overlap no other label; else they are left
            // out (the report lists the whole front).
            let mut placed: Vec<(f64, f64, f64, f64)> = Vec::new();
            for &i in &front {
                let (x, y) = (fx(main[i].time), fy(main[i].rmse));
                let _ = writeln!(
                    s,
                    r#"<circle cx="{x:.1}" cy="{y:.1}" r="7" fill="none" stroke="black" stroke-width="1.5"/>"#
                );
                let label = &main[i].label;
                let w = 6.2 * label.chars().count() as f64;
                let h = 11.0;
                let spots = [
                    (x + 8.0, y - 8.0),
                    (x + 9.0, y + 16.0),
                    (x - 8.0 - w, y - 8.0),
                    (x - 9.0 - w, y + 16.0),
                ];
                let free = spots.into_iter().find(|&(tx, ty)| {
                    let r = (tx, ty - h, tx + w, ty);
                    r.0 >= X0 - 30.0
                        && r.2 <= X1 + 14.0
                        && !placed
                            .iter()
                            .any(|p| r.0 < p.2 && p.0 < r.2 && r.1 < p.3 && p.1 < r.3)
                });
                if let Some((tx, ty)) = free {
                    placed.push((tx, ty - h, tx + w, ty));
                    let _ = writeln!(
                        s,
                        r#"<text x="{tx:.1}" y="{ty:.1}" font-size="11">{}</text>"#,
                        xml_escape(label)
                    );
                }
            }
        }
        // Legend.
        let lx = X1 + 22.0;
        let mut ly = y0 + 8.0;
        for k in Knob::ALL {
            if let Some(p) = pts.iter().find(|p| p.knob == k) {
                let fill = if p.main { k.color() } else { "white" };
                let _ = writeln!(
                    s,
                    r#"<circle cx="{lx}" cy="{ly}" r="4" fill="{fill}" stroke="{}" stroke-width="1.5"/><text x="{}" y="{}">{}</text>"#,
                    k.color(),
                    lx + 10.0,
                    ly + 4.0,
                    xml_escape(k.name())
                );
                ly += 18.0;
            }
        }
        let _ = writeln!(
            s,
            r#"<line x1="{}" y1="{ly}" x2="{}" y2="{ly}" stroke="black" stroke-width="2"/><text x="{}" y="{}">Pareto front</text>"#,
            lx - 6.0,
            lx + 6.0,
            lx + 10.0,
            ly + 4.0
        );
        ly += 18.0;
        if pts.iter().any(|p| !p.main) {
            for line in ["hollow: own reference", "(not on the front)"] {
                let _ = writeln!(
                    s,
                    r##"<text x="{}" y="{}" fill="#555">{line}</text>"##,
                    lx - 6.0,
                    ly + 4.0
                );
                ly += 16.0;
            }
        }
    }
    s.push_str("</svg>\n");
    s
}

// ---------------------------------------------------------------------------------------------
// Conclusions
// ---------------------------------------------------------------------------------------------

/// One setting of a knob as the conclusions see it.
#[derive(Clone, Debug, PartialEq)]
struct Point {
    /// The setting as the text names it (`4`, `10 %`, `0.1`).
    label: String,
    /// Its value (samples per side, threshold, cut-off, depth cap, level, bits).
    num: f64,
    /// Median time against the baseline's.
    ratio: f64,
    /// Rays of one render.
    rays: u64,
    rmse: f64,
    ssim: f64,
}

/// The settings of one comparison, and what tells them apart.
struct Sweep {
    points: Vec<Point>,
    /// `dist[i][j]`: RMSE between the images of points `i` and `j`.
    dist: Vec<Vec<f64>>,
    /// The residual of the reference they are compared with.
    residual: f64,
    /// `1 −` the residual render's SSIM against that reference: SSIM differences up to this
    /// are not taken as resolved.
    ssim_tol: f64,
}

impl Sweep {
    /// Whether the reference tells which of points `i` and `j` is closer to the truth. With the
    /// reference `F = T + ε`, `‖A − T‖² − ‖B − T‖² = ‖A − F‖² − ‖B − F‖² + 2⟨A − B, ε⟩` and
    /// `|⟨A − B, ε⟩| ≤ d·‖ε‖` (Cauchy–Schwarz, all per channel), so the measured squared RMSEs
    /// give the true order when they differ by more than `2·d·residual`, `d` being the RMSE
    /// between the two images and the residual the bound on `‖ε‖`. Identical images are never
    /// told apart.
    fn resolved(&self, i: usize, j: usize) -> bool {
        let (a, b) = (self.points[i].rmse, self.points[j].rmse);
        (a * a - b * b).abs() > 2.0 * self.dist[i][j] * self.residual
    }

    /// Whether point `i` is closer to the truth than `j` by a margin the reference resolves.
    fn beats(&self, i: usize, j: usize) -> bool {
        self.points[i].rmse < self.points[j].rmse && self.resolved(i, j)
    }

    /// Of `among`, the cheapest (fewest rays; of equal rays the first) that none of `among`
    /// beats.
    fn cheapest_unbeaten(&self, among: &[usize]) -> Option<usize> {
        among
            .iter()
            .copied()
            .filter(|&i| !among.iter().any(|&j| self.beats(j, i)))
            .min_by_key(|&i| (self.points[i].rays, i))
    }

    /// The first position in `order` (not the last) from which no two of the points that follow
    /// are told apart; `None` if even the last two are.
    fn settled_from(&self, order: &[usize]) -> Option<usize> {
        let mut found = None;
        for start in (0..order.len().saturating_sub(1)).rev() {
            let a = order[start];
            if order[start + 1..].iter().any(|&b| self.resolved(a, b)) {
                break;
            }
            found = Some(start);
        }
        found
    }
}

/// `part` of `whole` as a whole percentage (`0` for an empty whole).
fn share(part: f64, whole: f64) -> f64 {
    if whole > 0.0 {
        100.0 * part / whole
    } else {
        0.0
    }
}

/// `more` rays against `base` rays: `12 % more rays`, `3 % fewer rays`, `the same rays`.
fn rays_change(base: u64, more: u64) -> String {
    if base == more || base == 0 {
        return "the same rays".to_string();
    }
    let d = share(more as f64 - base as f64, base as f64);
    if d >= 0.0 {
        format!("{:.0} % more rays", d.max(1.0))
    } else {
        format!("{:.0} % fewer rays", (-d).max(1.0))
    }
}

/// The multisample paragraph's resolution sentence and conclusion; `p` in increasing samples,
/// the first multisample 1. `other` names the baseline's other differences from the reference
/// (cut-off, depth cap) when they can matter.
fn multisample_conclusion(sw: &Sweep, other: Option<&str>) -> String {
    let p = &sw.points;
    let n = p.len();
    if n < 2 {
        return String::new();
    }
    let mut s = String::new();
    let unresolved: Vec<String> = (0..n - 1)
        .filter(|&i| !sw.resolved(i, i + 1))
        .map(|i| format!("{} → {}", p[i].label, p[i + 1].label))
        .collect();
    let _ = write!(
        s,
        " The reference's residual is {} (RMSE); a step is resolved only when the residual \
         cannot explain the change of RMSE.",
        sig3(sw.residual)
    );
    if unresolved.is_empty() {
        let _ = write!(s, " Every step here is resolved.");
    } else {
        let _ = write!(
            s,
            " Not resolved: multisample {}.",
            join_values(&unresolved)
        );
    }
    let order: Vec<usize> = (0..n).collect();
    let settled = sw.settled_from(&order);
    let last = n - 1;
    if settled == Some(0) {
        let _ = write!(
            s,
            " Conclusion: this reference cannot tell multisample {} from {} (RMSE {} against {}): \
             more samples buy nothing measurable here, so multisample {} is enough.",
            p[0].label,
            p[last].label,
            sig3(p[0].rmse),
            sig3(p[last].rmse),
            p[0].label
        );
        return s;
    }
    if let Some(i) = settled {
        let _ = write!(
            s,
            " From multisample {} on (RMSE {} to {}) no two settings are told apart: whether more \
             than {} samples per side help is below what this reference resolves.",
            p[i].label,
            sig3(p[i..].iter().map(|q| q.rmse).fold(0.0, f64::max)),
            sig3(p[i..].iter().map(|q| q.rmse).fold(f64::INFINITY, f64::min)),
            p[i].label
        );
    }
    let drop = p[0].rmse - p[last].rmse;
    if drop <= 0.0 {
        let _ = write!(
            s,
            " Conclusion: more samples did not lower the RMSE here; multisample {} is enough.",
            p[0].label
        );
        return s;
    }
    let knee = (1..n)
        .find(|&i| p[0].rmse - p[i].rmse >= 0.9 * drop)
        .unwrap_or(last);
    let pick = settled.map_or(knee, |i| knee.min(i.max(1)));
    if pick == last {
        let _ = write!(
            s,
            " Conclusion: pick multisample {} (the most measured, {} the baseline time) when \
             quality matters: every step up to it lowers the RMSE by a margin the reference \
             resolves, and the last step, from multisample {}, still removes {:.0} % of the \
             whole reduction from multisample {}.",
            p[last].label,
            fmt_ratio(p[last].ratio),
            p[last - 1].label,
            share(p[last - 1].rmse - p[last].rmse, drop).max(0.0),
            p[0].label
        );
    } else {
        let _ = write!(
            s,
            " Conclusion: pick multisample {} when quality matters: it buys {:.0} % of the RMSE \
             reduction that multisample {} buys at {} the baseline time; the rest costs {} as \
             much time again ({} the baseline time){}.",
            p[pick].label,
            share(p[0].rmse - p[pick].rmse, drop),
            p[last].label,
            fmt_ratio(p[pick].ratio),
            fmt_ratio(p[last].ratio / p[pick].ratio.max(1e-12)),
            fmt_ratio(p[last].ratio),
            if settled.is_some_and(|i| i <= pick) {
                " and is not resolved by this reference"
            } else {
                ""
            }
        );
    }
    if p[last].rmse > 2.0 * sw.residual {
        match other {
            Some(o) => {
                let _ = write!(
                    s,
                    " What is left at multisample {} (RMSE {}) is more than the reference's \
                     residual explains (more than twice it); the baseline also differs from the reference in {o}, \
                     and more samples cannot remove that part.",
                    p[last].label,
                    sig3(p[last].rmse)
                );
            }
            None => {
                let _ = write!(
                    s,
                    " Multisample {} is still more than twice the reference's residual from it \
                     (RMSE {}): more samples would still help.",
                    p[last].label,
                    sig3(p[last].rmse)
                );
            }
        }
    }
    s
}

/// The adaptive paragraph's conclusion: point 0 is full multisample 4, `thresholds` the
/// adaptive points, `multisample` the plain multisample points.
fn adaptive_conclusion(
    sw: &Sweep,
    thresholds: std::ops::Range<usize>,
    multisample: std::ops::Range<usize>,
) -> String {
    let p = &sw.points;
    let Some(full) = p.first() else {
        return String::new();
    };
    let matching: Vec<usize> = thresholds
        .clone()
        .filter(|&i| p[i].rmse <= full.rmse * 1.1 || !sw.beats(0, i))
        .collect();
    let pct = |i: usize| share(p[i].ratio, full.ratio);
    let close = matching
        .iter()
        .copied()
        .min_by(|&a, &b| p[a].ratio.total_cmp(&p[b].ratio).then(a.cmp(&b)));
    let mut s = String::new();
    match close {
        Some(c) => {
            let _ = write!(
                s,
                " Conclusion: use threshold {} rather than full multisampling: its RMSE ({}) is \
                 {} full multisample 4's ({}) at {:.0} % of its time.",
                p[c].label,
                sig3(p[c].rmse),
                if sw.beats(0, c) {
                    "within 10 % of"
                } else {
                    "not told apart from"
                },
                sig3(full.rmse),
                pct(c)
            );
            let same_time = multisample
                .filter(|&m| p[m].ratio <= p[c].ratio * 1.05)
                .max_by(|&a, &b| p[a].ratio.total_cmp(&p[b].ratio));
            if let Some(m) = same_time.filter(|&m| sw.beats(c, m)) {
                let _ = write!(
                    s,
                    " In that time plain multisampling gets no further than multisample {} ({}, \
                     RMSE {}).",
                    p[m].label,
                    fmt_ratio(p[m].ratio),
                    sig3(p[m].rmse)
                );
            }
        }
        None => {
            let best = thresholds.min_by(|&a, &b| p[a].rmse.total_cmp(&p[b].rmse));
            if let Some(b) = best {
                let _ = write!(
                    s,
                    " Conclusion: no threshold matched full multisample 4 here (RMSE {}); the \
                     closest, {}, has RMSE {} at {:.0} % of its time. A refined pixel is exactly \
                     full multisample 4's, so the difference lies in pixels whose centre matched \
                     its neighbours' and kept one ray: where that matters, use full \
                     multisampling or a lower threshold.",
                    sig3(full.rmse),
                    p[b].label,
                    sig3(p[b].rmse),
                    pct(b)
                );
            }
        }
    }
    s
}

/// The reflection cut-off's conclusion: `own` is the scene's own cut-off's point, `aliasing`
/// the RMSE that multisample 2 removes from the baseline (when measured).
fn cutoff_conclusion(sw: &Sweep, own: Option<usize>, aliasing: Option<f64>, same: bool) -> String {
    let p = &sw.points;
    let all: Vec<usize> = (0..p.len()).collect();
    let Some(pick) = sw.cheapest_unbeaten(&all) else {
        return String::new();
    };
    let own_label = own.map_or_else(String::new, |o| p[o].label.clone());
    if same {
        let most = all
            .iter()
            .copied()
            .max_by_key(|&i| p[i].rays)
            .unwrap_or(pick);
        return format!(
            " Conclusion: keep the scene's {own_label}: lower cut-offs buy nothing here{}.",
            if p[most].rays > p[pick].rays {
                format!(
                    ", and cut-off {} traces {} for the same pixels",
                    p[most].label,
                    rays_change(p[pick].rays, p[most].rays)
                )
            } else {
                String::new()
            }
        );
    }
    let mut s = format!(
        " Conclusion: for accuracy, pick cut-off {}, the cheapest setting that no other beats \
         by a margin the reference resolves (RMSE {}).",
        p[pick].label,
        sig3(p[pick].rmse)
    );
    if let Some(o) = own {
        if o == pick {
            s.push_str(" That is the scene's own.");
        } else if sw.beats(pick, o) {
            let gain = p[o].rmse - p[pick].rmse;
            let _ = write!(
                s,
                " The scene's {} falls short: {} lowers RMSE from {} to {} for {} ({} the \
                 baseline time against {}).",
                p[o].label,
                p[pick].label,
                sig3(p[o].rmse),
                sig3(p[pick].rmse),
                rays_change(p[o].rays, p[pick].rays),
                fmt_ratio(p[pick].ratio),
                fmt_ratio(p[o].ratio)
            );
            if let Some(a) = aliasing.filter(|&a| a > gain) {
                let _ = write!(
                    s,
                    " That gain is {:.0} times smaller than what multisample 2 removes ({}); but \
                     the cut-off's error is a bias that multisampling does not remove, so it \
                     matters most in multisampled images.",
                    a / gain.max(1e-12),
                    sig3(a)
                );
            }
        } else {
            let _ = write!(
                s,
                " The scene's {} is as good by what the reference resolves, with {}.",
                p[o].label,
                rays_change(p[pick].rays, p[o].rays)
            );
        }
    }
    s
}

/// The depth cap's conclusion; `p` in increasing caps, `own` the scene's cap's point.
fn depth_conclusion(sw: &Sweep, own: Option<usize>, same: bool) -> String {
    let p = &sw.points;
    let all: Vec<usize> = (0..p.len()).collect();
    let Some(pick) = sw.cheapest_unbeaten(&all) else {
        return String::new();
    };
    if same {
        return format!(
            " Conclusion: no path here needs more than {} bounce{} (every cap gave the same \
             image), so the cap buys nothing; any value will do.",
            p[0].label,
            if p[0].num == 1.0 { "" } else { "s" }
        );
    }
    let mut s = format!(
        " Conclusion: a depth cap of {} is enough: no deeper cap beats it by a margin the \
         reference resolves (RMSE {}).",
        p[pick].label,
        sig3(p[pick].rmse)
    );
    if let Some(o) = own {
        if o == pick {
            s.push_str(" That is the scene's own.");
        } else if sw.beats(pick, o) {
            let _ = write!(
                s,
                " The scene's own cap, {}, is too low: RMSE {} against {}.",
                p[o].label,
                sig3(p[o].rmse),
                sig3(p[pick].rmse)
            );
        } else {
            let _ = write!(
                s,
                " The scene's own cap, {}, is more than enough ({}).",
                p[o].label,
                rays_change(p[pick].rays, p[o].rays)
            );
        }
    }
    if pick > 0 && sw.beats(pick, 0) {
        let _ = write!(
            s,
            " Lower caps cut paths short: cap {} has RMSE {} (SSIM {}) for {}.",
            p[0].label,
            sig3(p[0].rmse),
            fmt_ssim(p[0].ssim),
            rays_change(p[pick].rays, p[0].rays)
        );
    }
    s
}

/// The ambient-occlusion conclusion: the points' `num` is the level (0 is off); `own` is the
/// scene's level; `reference` names what they are compared with.
fn occlusion_conclusion(sw: &Sweep, own: u32, reference: &str) -> String {
    let p = &sw.points;
    let Some(off) = p.iter().position(|q| q.num == 0.0) else {
        return String::new();
    };
    let levels: Vec<usize> = (0..p.len()).filter(|&i| i != off).collect();
    let worse_ssim = |i: usize| p[i].ssim < p[off].ssim - sw.ssim_tol;
    let worse: Vec<usize> = levels
        .iter()
        .copied()
        .filter(|&i| worse_ssim(i) || sw.beats(off, i))
        .collect();
    let mut s = String::new();
    if !worse.is_empty() {
        let items: Vec<String> = worse
            .iter()
            .map(|&i| {
                if p[i].rmse >= p[off].rmse {
                    format!(
                        "level {} (SSIM {} against {}, RMSE {} against {})",
                        p[i].label,
                        fmt_ssim(p[i].ssim),
                        fmt_ssim(p[off].ssim),
                        sig3(p[i].rmse),
                        sig3(p[off].rmse)
                    )
                } else {
                    format!(
                        "level {} in SSIM ({} against {}), though its RMSE is lower ({} against \
                         {})",
                        p[i].label,
                        fmt_ssim(p[i].ssim),
                        fmt_ssim(p[off].ssim),
                        sig3(p[i].rmse),
                        sig3(p[off].rmse)
                    )
                }
            })
            .collect();
        let rays: Vec<String> = worse
            .iter()
            .map(|&i| {
                let n = (p[i].num * p[i].num) as u32;
                format!(
                    "{n} ray{} at level {}",
                    if n == 1 { "" } else { "s" },
                    p[i].label
                )
            })
            .collect();
        let _ = write!(
            s,
            " Worse than off: {}. With so few occlusion rays per shaded point ({}) the share that \
             escapes is coarse{}, so the ambient term turns into noise from pixel to pixel; at \
             multisample 1 nothing averages it, and the {reference} it is compared with is \
             smooth. That noise costs more than the occlusion it adds, and SSIM, which weighs \
             local structure, shows it most.",
            items.join("; "),
            join_values(&rays),
            if worse.iter().any(|&i| p[i].num == 1.0) {
                " (with one ray, 0 or 1)"
            } else {
                ""
            }
        );
    }
    let beats_off: Vec<usize> = levels
        .iter()
        .copied()
        .filter(|&i| sw.beats(i, off) && !worse_ssim(i))
        .collect();
    let unresolved: Vec<usize> = levels
        .iter()
        .copied()
        .filter(|&i| p[i].rmse < p[off].rmse && p[i].ssim > p[off].ssim && !sw.beats(i, off))
        .collect();
    if !unresolved.is_empty() {
        let labels: Vec<String> = unresolved.iter().map(|&i| p[i].label.clone()).collect();
        let _ = write!(
            s,
            " Level{} {} score{} better than off in both RMSE and SSIM, but by less than that \
             reference resolves (its residual is {}): a sharper reference would be needed to \
             tell.",
            if unresolved.len() == 1 { "" } else { "s" },
            join_values(&labels),
            if unresolved.len() == 1 { "s" } else { "" },
            sig3(sw.residual)
        );
    }
    let candidates: Vec<usize> = (0..p.len()).filter(|i| !worse.contains(i)).collect();
    let pick = sw.cheapest_unbeaten(&candidates).unwrap_or(off);
    if pick == off {
        let _ = write!(
            s,
            " Conclusion: at multisample 1 no level measured here beats leaving occlusion off by \
             a margin the reference resolves{}: leave it off, or pair it with multisampling, which \
             averages the occlusion rays of a pixel's samples (not measured here).",
            if beats_off.is_empty() {
                String::new()
            } else {
                " on both RMSE and SSIM".to_string()
            }
        );
    } else {
        let _ = write!(
            s,
            " Conclusion: pick level {} ({} the baseline time): the cheapest level that scores no \
             worse than off and that no other level beats by a margin the reference resolves \
             (RMSE {}, SSIM {}, against off's {} and {}).",
            p[pick].label,
            fmt_ratio(p[pick].ratio),
            sig3(p[pick].rmse),
            fmt_ssim(p[pick].ssim),
            sig3(p[off].rmse),
            fmt_ssim(p[off].ssim)
        );
        if let Some(&first) = beats_off.first().filter(|&&f| f != pick) {
            let _ = write!(
                s,
                " Level {} is the first to beat off on both RMSE and SSIM.",
                p[first].label
            );
        }
    }
    if own > 0 {
        if let Some(o) = p.iter().position(|q| q.num == f64::from(own)) {
            if o != pick {
                let _ = write!(
                    s,
                    " The scene's own level {} {}.",
                    p[o].label,
                    if sw.beats(pick, o) || worse.contains(&o) {
                        "does worse".to_string()
                    } else {
                        format!(
                            "is as good by what the reference resolves, at {}",
                            fmt_ratio(p[o].ratio)
                        )
                    }
                );
            }
        }
    }
    s
}

/// The octree's conclusion: `times` are `(label, time against the default octree's)`, `noise`
/// the run's timing noise (a fraction).
fn octree_conclusion(times: &[(String, f64)], noise: Option<f64>) -> String {
    let Some((fast, f)) = times.iter().min_by(|a, b| a.1.total_cmp(&b.1)) else {
        return String::new();
    };
    let Some((slow, sl)) = times.iter().max_by(|a, b| a.1.total_cmp(&b.1)) else {
        return String::new();
    };
    let noise_text = noise.map_or_else(
        || "this run has no estimate of its timing noise".to_string(),
        |n| format!("the timing noise of this run is up to {:.0} %", n * 100.0),
    );
    let spread = sl / f.max(1e-12) - 1.0;
    // The default octree is the baseline: ratio 1.
    let gain = 1.0 / f.max(1e-12) - 1.0;
    format!(
        " Conclusion: the octree settings change only the time. The fastest here was {fast} \
         ({}), the slowest {slow} ({}), a spread of {:.0} %; {noise_text}, so {}.",
        fmt_ratio(*f),
        fmt_ratio(*sl),
        spread * 100.0,
        if *f >= 1.0 {
            "no setting beat the default: keep it".to_string()
        } else if noise.is_some_and(|n| gain <= n) {
            format!(
                "the fastest gains {:.0} % on the default, within the noise: keep the default",
                gain * 100.0
            )
        } else if noise.is_none() {
            format!(
                "the fastest gains {:.0} % on the default, which this run cannot tell from \
                 noise: keep the default unless a repeat run confirms it",
                gain * 100.0
            )
        } else {
            format!(
                "the fastest gains {:.0} % on the default, more than the noise: it may be worth \
                 a try on scenes like this one; the default is never wrong, only slower",
                gain * 100.0
            )
        }
    )
}

/// The pixel precision's conclusion: point 0 is the baseline with 16-bit pixels, point 1 with
/// 8-bit ones; `quantization` the RMSE between the two; `closest` the label and RMSE of the
/// scene's render closest to the reference.
fn precision_conclusion(
    sw: &Sweep,
    quantization: f64,
    closest: Option<(&str, f64)>,
    wire: &WireBytes,
) -> String {
    let p = &sw.points;
    if p.len() < 2 {
        return String::new();
    }
    let mut s = format!(
        " Conclusion: 8-bit pixels would save {:.0} % of the line-result bytes for RMSE {} \
         against the 16-bit pixels; against the reference they move the baseline's SSIM from {} \
         to {}",
        wire.saving() * 100.0,
        sig3(quantization),
        fmt_ssim(p[0].ssim),
        fmt_ssim(p[1].ssim)
    );
    s.push_str(if sw.resolved(0, 1) {
        " and its RMSE by a margin the reference resolves."
    } else {
        " and its RMSE by less than the reference resolves."
    });
    if let Some((label, best)) = closest.filter(|c| c.1 > 0.0) {
        let k = best / quantization.max(1e-12);
        // Quantisation adds about independently of the render's own error.
        let with8 = best.hypot(quantization);
        let more = share(with8 - best, best);
        if k >= 3.0 {
            let _ = write!(
                s,
                " Even the closest render here, {label} at RMSE {}, is {k:.0} times further from \
                 the reference than 8 bits move a pixel: 8 bits would raise its RMSE only to \
                 about {} (+{more:.0} %, adding independently), so at these settings they would \
                 cost nothing that matters and save {:.0} % of the traffic, which counts on slow \
                 links such as serial lines; 16 bits matter once a render's own error nears the \
                 8-bit step.",
                sig3(best),
                sig3(with8),
                wire.saving() * 100.0
            );
        } else {
            let _ = write!(
                s,
                " The closest render here, {label} at RMSE {}, is only {k:.1} times the 8-bit \
                 error: 8 bits would raise its RMSE to about {} (+{more:.0} %, adding \
                 independently), so keep 16-bit pixels for such renders unless the link is the \
                 bottleneck{}.",
                sig3(best),
                sig3(with8),
                if sw.resolved(0, 1) {
                    ""
                } else {
                    "; for renders as rough as the baseline, where the change is not resolved, \
                     8 bits would do"
                }
            );
        }
    }
    s
}

// ---------------------------------------------------------------------------------------------
// The report
// ---------------------------------------------------------------------------------------------

fn rows_of(rows: &[Row], scene: usize, knob: Knob) -> Vec<&Row> {
    rows.iter()
        .filter(|r| r.scene == scene && r.knob == knob)
        .collect()
}

/// The rows of scene `si` on its Pareto front (compared with the main reference, one row per
/// render, octree rows left out), fastest first.
fn front_rows(rows: &[Row], si: usize) -> Vec<&Row> {
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

fn figures(r: &Row) -> String {
    format!(
        "{} the baseline time, RMSE {} (PSNR {} dB, SSIM {})",
        fmt_ratio(r.ratio),
        sig3(r.errors.rmse),
        fmt_psnr(r.errors.psnr),
        fmt_ssim(r.errors.ssim)
    )
}

/// Groups of values of one knob that gave identical images (groups of two or more).
fn identical_groups(rows: &[&Row], scene: &SceneRun) -> Vec<Vec<String>> {
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

fn join_values(v: &[String]) -> String {
    match v {
        [] => String::new(),
        [a] => a.clone(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
    }
}

fn identical_note(rows: &[&Row], scene: &SceneRun, what: &str) -> String {
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

/// The colours a row is measured by: its render's, through 8 bits for an 8-bit row.
fn row_colors(r: &Row, sc: &SceneRun) -> Colors {
    let m = &sc.measured[r.measured];
    if r.eight_bit {
        to_colors(&through_8_bits(&m.pixels))
    } else {
        m.colors.clone()
    }
}

/// The value a row's knob takes in its configuration.
fn knob_value(r: &Row, sc: &SceneRun) -> f64 {
    let s = &sc.measured[r.measured].config.settings;
    match r.knob {
        Knob::Multisample => f64::from(s.samples),
        Knob::Adaptive => f64::from(s.aa_threshold),
        Knob::Cutoff => f64::from(s.min_reflection_weight),
        Knob::Depth => f64::from(s.max_depth),
        Knob::Occlusion => f64::from(s.ambient_occlusion),
        Knob::OctreeDepth => f64::from(sc.measured[r.measured].config.octree.max_depth),
        Knob::OctreeLeaf => f64::from(sc.measured[r.measured].config.octree.max_leaf_triangles),
        Knob::Precision => {
            if r.eight_bit {
                8.0
            } else {
                16.0
            }
        }
    }
}

/// The rows as a [`Sweep`], compared with `residual`.
fn sweep_of(rs: &[&Row], sc: &SceneRun) -> Sweep {
    let residual = rs
        .first()
        .and_then(|r| sc.residual_errors(r.reference))
        .unwrap_or(Errors {
            rmse: 0.0,
            psnr: f64::INFINITY,
            ssim: 1.0,
        });
    let colors: Vec<Colors> = rs.iter().map(|r| row_colors(r, sc)).collect();
    let n = rs.len();
    let mut dist = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in i + 1..n {
            let same = rs[i].measured == rs[j].measured && rs[i].eight_bit == rs[j].eight_bit;
            let d = if same {
                0.0
            } else {
                rmse(&colors[i], &colors[j])
            };
            dist[i][j] = d;
            dist[j][i] = d;
        }
    }
    let points = rs
        .iter()
        .map(|r| {
            let num = knob_value(r, sc);
            Point {
                label: match r.knob {
                    Knob::Multisample | Knob::Occlusion | Knob::Depth => format!("{num}"),
                    _ => r.value.clone(),
                },
                num,
                ratio: r.ratio,
                rays: sc.measured[r.measured].rays.total(),
                rmse: r.errors.rmse,
                ssim: r.errors.ssim,
            }
        })
        .collect();
    Sweep {
        points,
        dist,
        residual: residual.rmse,
        ssim_tol: (1.0 - residual.ssim).max(0.0),
    }
}

/// Whether every row gave the same image.
fn all_same(rs: &[&Row], sc: &SceneRun) -> bool {
    rs.windows(2)
        .all(|w| sc.measured[w[0].measured].image == sc.measured[w[1].measured].image)
}

fn paragraph(knob: Knob, scenes: &[SceneRun], rows: &[Row]) -> String {
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
        match knob {
            Knob::Multisample => {
                let first = rs[0];
                let _ = write!(
                    text,
                    "Multisample {} ({} s) has RMSE {} (PSNR {} dB, SSIM {}).",
                    first.short.trim_start_matches('m'),
                    fmt_secs(first.time),
                    sig3(first.errors.rmse),
                    fmt_psnr(first.errors.psnr),
                    fmt_ssim(first.errors.ssim)
                );
                for r in rs.iter().skip(1).filter(|r| {
                    let m = r.short.trim_start_matches('m');
                    ["2", "4", "8"].contains(&m) || r.measured == rs[rs.len() - 1].measured
                }) {
                    let _ = write!(
                        text,
                        " Multisample {} costs {} the time and {} (PSNR {} dB, SSIM {}).",
                        r.short.trim_start_matches('m'),
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
                                    first.short.trim_start_matches('m'),
                                    last.short.trim_start_matches('m'),
                                    r.short.trim_start_matches('m'),
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
                            last.short.trim_start_matches('m')
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
                text.push_str(&multisample_conclusion(
                    &sweep_of(&rs, sc),
                    other.as_deref(),
                ));
            }
            Knob::Adaptive => {
                let full = multisample.iter().copied().find(|r| r.short == "m4");
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
                for r in &rs {
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
                    text.push_str(&identical_note(&rs, sc, "threshold"));
                    text.push_str(&adaptive_conclusion(&sw, 1..k, k..all.len()));
                } else {
                    text.push_str(&identical_note(&rs, sc, "threshold"));
                }
            }
            Knob::Cutoff | Knob::Depth => {
                if sc.reflections_forced {
                    let _ = write!(
                        text,
                        "The scene has reflections off; this sweep turns them on and compares \
                         with the reference with reflections on.{scale}"
                    );
                }
                for r in &rs {
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
                    &rs,
                    sc,
                    if knob == Knob::Cutoff {
                        "cut-off"
                    } else {
                        "depth cap"
                    },
                ));
                let sw = sweep_of(&rs, sc);
                let same = all_same(&rs, sc);
                if knob == Knob::Cutoff {
                    let own = sw
                        .points
                        .iter()
                        .position(|q| q.num == f64::from(sc.baseline.min_reflection_weight));
                    let m = |n: u32| {
                        multisample
                            .iter()
                            .find(|r| r.short == format!("m{n}"))
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
            Knob::Occlusion => {
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
                text.push_str(&scale);
                let _ = write!(text, " That reference's residual is {}.", sig3(residual));
                for r in &rs {
                    let rays = sc.measured[r.measured].rays;
                    let _ = write!(
                        text,
                        " Level {}: {}; {} occlusion rays.",
                        r.value,
                        figures(r),
                        fmt_rays(rays.occlusion)
                    );
                }
                text.push_str(&identical_note(&rs, sc, "level"));
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
                text.push_str(&occlusion_conclusion(&sweep_of(&rs, sc), level, &reference));
            }
            Knob::OctreeDepth | Knob::OctreeLeaf => {
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
            Knob::Precision => {
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
        }
        let body = text.split_off(body_start);
        text.push_str(body.trim_start());
        text.push('\n');
    }
    text
}

fn knob_intro(knob: Knob) -> String {
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

fn knob_title(knob: Knob) -> &'static str {
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

/// Days since 1970-01-01 to a civil date (Howard Hinnant's algorithm).
fn civil_date(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

fn machine_info(cores: usize, load_start: &str) -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "CPU model unknown".to_string());
    let date = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| {
            let (y, m, day) = civil_date((d.as_secs() / 86_400) as i64);
            format!("{y}-{m:02}-{day:02}")
        })
        .unwrap_or_else(|_| "date unknown".to_string());
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
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|t| t.split_whitespace().next().map(str::to_string))
        .unwrap_or_else(|| "unknown".to_string())
}

fn command_line() -> String {
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
fn report(
    args: &AccuracyArgs,
    scenes: &[SceneRun],
    skipped: &[String],
    rows: &[Row],
    cores: usize,
    total: Duration,
    svg_name: &str,
    load_start: &str,
) -> String {
    let mut md = String::new();
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
    let _ = writeln!(md, "## Results\n");
    let _ = writeln!(
        md,
        "| scene | knob | value | median s | × baseline | RMSE | PSNR dB | SSIM | rays | compared with |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let sc = &scenes[r.scene];
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            sc.name,
            r.knob.name(),
            r.value,
            fmt_secs(r.time),
            fmt_ratio(r.ratio),
            sig3(r.errors.rmse),
            fmt_psnr(r.errors.psnr),
            fmt_ssim(r.errors.ssim),
            fmt_rays(sc.measured[r.measured].rays.total()),
            r.reference.name()
        );
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
    md
}

// ---------------------------------------------------------------------------------------------
// Running it
// ---------------------------------------------------------------------------------------------

/// The scenes to measure, each with whether it must load: the ones given, or the demo room and
/// every `scenes/fart/*.fart`, preferred ones first (the first two that load are used).
fn scene_list(args: &AccuracyArgs) -> anyhow::Result<Vec<(PathBuf, bool)>> {
    if !args.scenes.is_empty() {
        return Ok(args.scenes.iter().map(|p| (p.clone(), true)).collect());
    }
    let room = PathBuf::from(DEFAULT_ROOM);
    if !room.is_file() {
        bail!(
            "{DEFAULT_ROOM}: not found; run from the checkout's root folder or name scenes with \
             --scene PATH"
        );
    }
    let mut list = vec![(room, true)];
    let mut farts: Vec<PathBuf> = std::fs::read_dir(DEFAULT_FART_DIR)
        .map(|d| {
            d.filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|e| e == "fart"))
                .collect()
        })
        .unwrap_or_default();
    farts.sort_by_key(|p| {
        let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
        let rank = PREFERRED_FART_SCENES
            .iter()
            .position(|&f| name.as_deref() == Some(f))
            .unwrap_or(PREFERRED_FART_SCENES.len());
        (rank, p.clone())
    });
    list.extend(farts.into_iter().map(|p| (p, false)));
    Ok(list)
}

fn load(path: &Path, size: ImageSize) -> anyhow::Result<SceneDesc> {
    let loaded = load_scene(path, &Overrides::default()).map_err(|e| anyhow!("{e}"))?;
    let mut desc = loaded.desc;
    desc.settings.width = size.width;
    desc.settings.height = size.height;
    desc.validate()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok(desc)
}

/// Measures one scene, printing its rows on stdout as they come.
fn run_scene(
    name: &str,
    desc: &SceneDesc,
    args: &AccuracyArgs,
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
    let main_ref = RenderSettings {
        samples: REFERENCE_SAMPLES,
        aa_threshold: -1.0,
        min_reflection_weight: 0.0,
        max_depth: REFERENCE_DEPTH,
        ..baseline
    };
    let mut ref_settings = vec![(RefKind::Main, main_ref)];
    let reflections_forced = !baseline.reflections;
    if reflections_forced {
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
    writeln!(
        out,
        "\n{name}: {w}x{h}, {} triangles, {} solid objects; baseline: {}",
        desc.triangles.len(),
        desc.objects.len(),
        settings_summary(&baseline)
    )?;
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
        let (t, px, rays) = render_timed(name, desc, &config, cores, 1)?;
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
        let (probe_time, probe_px, _) = render_timed(name, desc, &probe, cores, 1)?;
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
    let header = |out: &mut std::io::StdoutLock<'_>, time: &str| {
        writeln!(
            out,
            "{:<28} {:<26} {:>12} {:>9} {:>8} {:>10} {:>7} {:>8} {:>8}  compared with",
            "scene", "knob", "value", time, "×base", "RMSE", "PSNR", "SSIM", "rays"
        )
    };
    if runs > 1 {
        writeln!(out, "round 1 of {runs} (times of this round only):")?;
    }
    header(&mut out, if runs > 1 { "1st s" } else { "s" })?;

    let mut measured: Vec<Measured> = Vec::new();
    let measure = |measured: &mut Vec<Measured>, config: &Config| -> anyhow::Result<usize> {
        if let Some(i) = measured.iter().position(|m| m.config == *config) {
            return Ok(i);
        }
        let (time, pixels, rays) = render_timed(name, desc, config, cores, 1)?;
        let image = measured
            .iter()
            .position(|m| m.pixels == pixels)
            .unwrap_or(measured.len());
        measured.push(Measured {
            config: *config,
            times: vec![time],
            time,
            colors: to_colors(&pixels),
            pixels,
            rays,
            image,
        });
        Ok(measured.len() - 1)
    };
    let base_config = Config {
        settings: baseline,
        octree: OctreeParams::default(),
    };
    let base = measure(&mut measured, &base_config)?;
    let plan = plan(&baseline, args.quick);
    let mut mine = Vec::new();
    for (knob, value, short, config, reference, eight_bit) in plan {
        let i = measure(&mut measured, &config)?;
        let m = &measured[i];
        let b = &measured[base];
        let errs = if reference == RefKind::Baseline {
            if m.pixels != b.pixels {
                let n = m
                    .pixels
                    .iter()
                    .zip(&b.pixels)
                    .filter(|(p, q)| p != q)
                    .count();
                let detail = first_difference(&m.pixels, &b.pixels, w).map_or_else(
                    String::new,
                    |(x, y, p, q)| {
                        format!(
                            "; first at pixel ({x}, {y}): {:?} instead of {:?}",
                            p.0, q.0
                        )
                    },
                );
                bail!(
                    "{name}: {} {value} (octree depth {}, leaf {}) changed {n} of {} pixels \
                     against the default octree (depth {}, leaf {}){detail}. Octree settings \
                     must never change the image: this is a bug.",
                    knob.name(),
                    config.octree.max_depth,
                    config.octree.max_leaf_triangles,
                    m.pixels.len(),
                    base_config.octree.max_depth,
                    base_config.octree.max_leaf_triangles,
                );
            }
            errors(&m.colors, &b.colors, w, h)
        } else {
            let reference = ref_images
                .iter()
                .find(|(k, _)| *k == reference)
                .map(|(_, c)| c)
                .ok_or_else(|| anyhow!("internal error: no {} image", reference.name()))?;
            if eight_bit {
                errors(&to_colors(&through_8_bits(&m.pixels)), reference, w, h)
            } else {
                errors(&m.colors, reference, w, h)
            }
        };
        let row = Row {
            scene: scene_index,
            knob,
            value,
            short,
            measured: i,
            eight_bit,
            reference,
            time: m.time,
            ratio: m.time.as_secs_f64() / b.time.as_secs_f64().max(1e-12),
            errors: errs,
        };
        stdout_row(&mut out, name, &row, m.rays.total())?;
        mine.push(row);
    }
    // The other runs in rounds over every setting, so a busy spell of the machine spreads over
    // all settings instead of spoiling one.
    // Each round starts at another setting, so no setting always follows the same one.
    let n = measured.len();
    for round in 2..=runs {
        writeln!(out, "round {round} of {runs}")?;
        let offset = (round - 1) * n / runs;
        for k in 0..n {
            let m = &mut measured[(k + offset) % n];
            let (t, pixels, _) = render_timed(name, desc, &m.config, cores, 1)?;
            if pixels != m.pixels {
                bail!(
                    "{name}: two renders of the same settings differ (a bug): {:?}",
                    m.config
                );
            }
            m.times.push(t);
        }
    }
    for m in &mut measured {
        m.time = median(m.times.clone());
    }
    let base_time = measured[base].time.as_secs_f64().max(1e-12);
    for r in &mut mine {
        r.time = measured[r.measured].time;
        r.ratio = r.time.as_secs_f64() / base_time;
    }
    if runs > 1 {
        writeln!(out, "median of {runs} runs:")?;
        header(&mut out, "median s")?;
        for r in &mine {
            stdout_row(&mut out, name, r, measured[r.measured].rays.total())?;
        }
    }
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
        reflections_forced,
        measured,
        quantization,
        wire,
    };
    rows.extend(mine);
    Ok(run)
}

/// Runs `strahl bench accuracy`: prints the table on stdout as it goes and writes the report and
/// its plot.
///
/// # Errors
/// A scene that cannot be loaded (naming the file; default `.fart` scenes that fail are skipped
/// with a note), a render failure, an octree setting that changes a pixel, or a report that
/// cannot be written (naming the file).
pub fn run(args: &AccuracyArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    let load_start = load_average();
    let cores = std::thread::available_parallelism().map_or(1, NonZeroUsize::get);
    let svg_path = args.out.with_extension("svg");
    let svg_name = svg_path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| anyhow!("{}: not a file name", args.out.display()))?;
    // Fail before the long part if the report cannot be written.
    let folder = match args.out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !folder.is_dir() {
        bail!(
            "{}: cannot write the report: no such folder {}",
            args.out.display(),
            folder.display()
        );
    }

    let list = scene_list(args)?;
    let mut skipped = Vec::new();
    let mut scenes = Vec::new();
    let mut rows = Vec::new();
    println!(
        "strahl bench accuracy: {}x{}, {} runs per setting, {cores} workers{}",
        args.size.width,
        args.size.height,
        args.runs.max(1),
        if args.quick { ", quick sweep" } else { "" }
    );
    let mut optional = 0;
    for (path, required) in list {
        if !required && optional == 2 {
            break;
        }
        let desc = match load(&path, args.size) {
            Ok(d) => d,
            Err(e) if !required => {
                eprintln!("skipping {}: {e}", path.display());
                skipped.push(format!("`{}`: {e}", path.display()));
                continue;
            }
            Err(e) => return Err(e),
        };
        optional += usize::from(!required);
        let name = path.display().to_string();
        let index = scenes.len();
        scenes.push(run_scene(&name, &desc, args, cores, index, &mut rows)?);
    }
    let total = start.elapsed();

    let panels: Vec<PlotPanel> = scenes
        .iter()
        .enumerate()
        .map(|(si, sc)| {
            // One point per render and reference: the baseline appears under several knobs.
            let mut seen: Vec<(usize, bool, RefKind)> = Vec::new();
            let mut points = Vec::new();
            for r in rows.iter().filter(|r| {
                r.scene == si && !matches!(r.knob, Knob::OctreeDepth | Knob::OctreeLeaf)
            }) {
                let key = (r.measured, r.eight_bit, r.reference);
                if seen.contains(&key) {
                    continue;
                }
                seen.push(key);
                points.push(PlotPoint {
                    time: r.time.as_secs_f64(),
                    rmse: r.errors.rmse,
                    knob: r.knob,
                    label: r.short.clone(),
                    main: r.reference == RefKind::Main,
                });
            }
            PlotPanel {
                title: sc.name.clone(),
                points,
            }
        })
        .collect();
    let md = report(
        args,
        &scenes,
        &skipped,
        &rows,
        cores,
        total,
        &svg_name,
        &load_start,
    );
    let picture = svg(&panels);
    for (path, text) in [(&args.out, &md), (&svg_path, &picture)] {
        crate::output::write_atomically(path, |w| {
            w.write_all(text.as_bytes())
                .with_context(|| format!("{}: cannot write", path.display()))
        })?;
    }
    println!(
        "\nwrote {} and {} ({:.1} s)",
        args.out.display(),
        svg_path.display(),
        total.as_secs_f64()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A textured test image: a ramp plus a strong local pattern (SSIM needs local contrast
    /// well above its stabilising constants).
    fn gradient(w: usize, h: usize) -> Colors {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let v = 0.2 * x / w as f32 + 0.4 + 0.35 * (x * 1.3).sin() * (y * 0.9).cos();
                [v, v * 0.9, v * 0.8 + 0.1]
            })
            .collect()
    }

    #[test]
    fn rmse_and_psnr_of_identical_images() {
        let a = gradient(20, 15);
        assert_eq!(rmse(&a, &a), 0.0);
        assert!(psnr(rmse(&a, &a)).is_infinite());
        assert!(psnr(0.0) > 0.0);
    }

    #[test]
    fn rmse_and_psnr_of_a_known_offset() {
        let a = vec![[0.25f32, 0.5, 0.75]; 12];
        let b: Colors = a.iter().map(|c| c.map(|v| v + 0.125)).collect();
        assert!((rmse(&a, &b) - 0.125).abs() < 1e-9);
        assert!((psnr(0.1) - 20.0).abs() < 1e-9);
        assert!((psnr(0.01) - 40.0).abs() < 1e-9);
    }

    #[test]
    fn ssim_of_identical_images_is_one_and_of_the_inverse_is_low() {
        let (w, h) = (24, 18);
        let a = gradient(w, h);
        assert!((ssim(&a, &a, w, h) - 1.0).abs() < 1e-12);
        let inv: Colors = a.iter().map(|c| c.map(|v| 1.0 - v)).collect();
        let s = ssim(&a, &inv, w, h);
        assert!(s < 0.1, "SSIM of an image and its inverse: {s}");
        // A little noise keeps it high.
        let noisy: Colors = a
            .iter()
            .enumerate()
            .map(|(i, c)| c.map(|v| v + if i % 2 == 0 { 0.002 } else { -0.002 }))
            .collect();
        let s = ssim(&a, &noisy, w, h);
        assert!(s > 0.9 && s < 1.0, "SSIM with slight noise: {s}");
    }

    #[test]
    fn ssim_of_images_smaller_than_the_window() {
        let a = gradient(6, 4);
        assert!((ssim(&a, &a, 6, 4) - 1.0).abs() < 1e-12);
        assert_eq!(ssim(&a, &a, 0, 0), 0.0);
    }

    #[test]
    fn pareto_front_of_a_known_set() {
        let pts = [
            (1.0, 0.10),     // 0: front (fastest)
            (2.0, 0.05),     // 1: front
            (2.5, 0.08),     // 2: dominated by 1
            (4.0, 0.02),     // 3: front
            (4.0, 0.03),     // 4: dominated by 3 (same time, more error)
            (8.0, 0.02),     // 5: dominated by 3 (same error, slower)
            (16.0, 0.0),     // 6: front (exact)
            (f64::NAN, 0.0), // 7: left out
        ];
        assert_eq!(pareto_front(&pts), vec![0, 1, 3, 6]);
        assert!(pareto_front(&[]).is_empty());
        assert_eq!(pareto_front(&[(1.0, 1.0), (1.0, 1.0)]), vec![0]);
    }

    #[test]
    fn eight_bit_round_trip_error_is_within_half_a_step() {
        let px: Vec<Pixel> = (0..=65535u16)
            .step_by(97)
            .map(|v| Pixel([v, v / 2, 65535 - v]))
            .collect();
        let e = rmse(&to_colors(&px), &to_colors(&through_8_bits(&px)));
        assert!(e > 0.0 && e <= 0.5 / 255.0 + 1e-6, "{e}");
        let exact: Vec<Pixel> = (0..=255u16).map(|v| Pixel([v * 257; 3])).collect();
        assert_eq!(through_8_bits(&exact), exact);
    }

    #[test]
    fn sizes_parse() {
        assert_eq!(
            parse_size("320x240"),
            Ok(ImageSize {
                width: 320,
                height: 240
            })
        );
        assert!(parse_size("320").is_err());
        assert!(parse_size("4x4").is_err());
        assert!(parse_size("ax3").is_err());
    }

    #[test]
    fn svg_has_the_front() {
        let p = |time, rmse, main| PlotPoint {
            time,
            rmse,
            knob: Knob::Multisample,
            label: format!("m{time}"),
            main,
        };
        let s = svg(&[PlotPanel {
            title: "a <scene>".into(),
            points: vec![
                p(1.0, 0.1, true),
                p(2.0, 0.2, true),
                p(4.0, 0.01, true),
                p(3.0, 0.0, false),
            ],
        }]);
        assert!(s.starts_with("<svg"));
        assert!(s.contains("<polyline class=\"pareto\""));
        assert!(s.contains("a &lt;scene&gt;"));
        assert!(s.trim_end().ends_with("</svg>"));
    }

    #[test]
    fn civil_dates() {
        assert_eq!(civil_date(0), (1970, 1, 1));
        assert_eq!(civil_date(19_723), (2024, 1, 1));
    }

    fn pt(label: &str, num: f64, ratio: f64, rays: u64, rmse: f64, ssim: f64) -> Point {
        Point {
            label: label.to_string(),
            num,
            ratio,
            rays,
            rmse,
            ssim,
        }
    }

    /// A sweep whose images differ as independent errors would: `d = √(a² + b²)`.
    fn independent(points: Vec<Point>, residual: f64) -> Sweep {
        let dist = points
            .iter()
            .map(|a| {
                points
                    .iter()
                    .map(|b| if a == b { 0.0 } else { a.rmse.hypot(b.rmse) })
                    .collect()
            })
            .collect();
        Sweep {
            points,
            dist,
            residual,
            ssim_tol: 0.0,
        }
    }

    #[test]
    fn wire_bytes_are_the_protocols_frames() {
        use strahl_core::protocol::frame::{FrameReader, ReadEvent};
        use strahl_core::protocol::message::decode_pixels;
        use strahl_core::protocol::MAX_FRAME_LEN;
        let (w, h) = (40u32, 3u32);
        let px: Vec<Pixel> = (0..w * h)
            .map(|i| Pixel([(i * 523) as u16, (i * 97) as u16, 65535 - i as u16]))
            .collect();
        let rays = RayCounts {
            primary: u64::from(w * h),
            shadow: 300,
            ..RayCounts::default()
        };
        let wb = wire_bytes(&px, w, rays).expect("encodes");
        assert_eq!((wb.width, wb.lines), (w, h));
        assert_eq!(wb.pixel_bytes(false), 240);
        assert_eq!(wb.pixel_bytes(true), 120);
        // Each 16-bit frame is a valid line result that decodes to the line's pixels.
        let mut writer = FrameWriter::new();
        let mut total = 0;
        for (y, line) in px.chunks_exact(w as usize).enumerate() {
            let frame =
                line_result_frame(&mut writer, 1, y as u32, rays, line, false).expect("encodes");
            total += frame.len();
            let mut reader = FrameReader::new(vec![0u8; MAX_FRAME_LEN]);
            let mut link: &[u8] = &frame;
            let ReadEvent::Frame(payload) = reader.next(&mut link).expect("reads") else {
                panic!("no frame");
            };
            let WorkerMessage::LineResult {
                line: l, pixels, ..
            } = WorkerMessage::decode(payload).expect("decodes")
            else {
                panic!("not a line result");
            };
            assert_eq!(l, y as u32);
            let mut back = vec![Pixel::default(); w as usize];
            decode_pixels(pixels, &mut back).expect("whole pixels");
            assert_eq!(back, line);
        }
        // The image's bytes are those frames (with the mean rays per line, which here are
        // encoded in as many bytes as the image's).
        assert!(
            total.abs_diff(wb.image16) <= 3 * h as usize,
            "{total} {}",
            wb.image16
        );
        // 8 bits: 3 bytes less per pixel, give or take COBS's code bytes.
        let saved = wb.image16 - wb.image8;
        assert!(
            saved.abs_diff(3 * (w * h) as usize) <= 2 * h as usize,
            "{saved}"
        );
        assert!(wb.saving() > 0.4 && wb.saving() < 0.5, "{}", wb.saving());
        assert!((wb.per_line(false) - wb.image16 as f64 / 3.0).abs() < 1e-9);
        assert!((serial_seconds(11_520, 115_200) - 1.0).abs() < 1e-12);
        assert_eq!(fmt_bytes(1_234_567), "1\u{2009}234\u{2009}567");
        assert_eq!(fmt_bytes(999), "999");
    }

    #[test]
    fn resolution_follows_the_residual() {
        // Two settings 0.01 and 0.009 with independent errors (d ≈ 0.0135): resolved when
        // 0.01² − 0.009² = 1.9e-5 > 2·d·residual, i.e. residual < about 0.0007.
        let pts = vec![
            pt("a", 1.0, 1.0, 10, 0.010, 0.9),
            pt("b", 2.0, 2.0, 20, 0.009, 0.9),
        ];
        assert!(independent(pts.clone(), 0.0005).resolved(0, 1));
        assert!(!independent(pts.clone(), 0.001).resolved(0, 1));
        // Close images (small d) are told apart by smaller differences.
        let mut close = independent(pts, 0.001);
        close.dist[0][1] = 0.002;
        close.dist[1][0] = 0.002;
        assert!(close.resolved(0, 1));
        assert!(close.beats(1, 0) && !close.beats(0, 1));
        // Identical images are never told apart, even with a zero residual.
        let same = independent(
            vec![
                pt("a", 1.0, 1.0, 1, 0.01, 1.0),
                pt("a", 1.0, 1.0, 1, 0.01, 1.0),
            ],
            0.0,
        );
        assert!(!same.resolved(0, 1));
    }

    #[test]
    fn cheapest_unbeaten_and_settled() {
        let sw = independent(
            vec![
                pt("1", 1.0, 1.0, 100, 0.0500, 0.9),
                pt("2", 2.0, 2.0, 200, 0.0200, 0.9),
                pt("3", 3.0, 3.0, 300, 0.0102, 0.9),
                pt("4", 4.0, 4.0, 400, 0.0100, 0.9),
            ],
            0.001,
        );
        // 3 and 4 are not told apart; 2 is beaten.
        assert_eq!(sw.cheapest_unbeaten(&[0, 1, 2, 3]), Some(2));
        assert_eq!(sw.settled_from(&[0, 1, 2, 3]), Some(2));
        let exact = independent(sw.points.clone(), 0.0);
        assert_eq!(exact.settled_from(&[0, 1, 2, 3]), None);
        assert_eq!(exact.cheapest_unbeaten(&[0, 1, 2, 3]), Some(3));
    }

    #[test]
    fn multisample_conclusion_names_what_is_not_resolved() {
        let pts = vec![
            pt("1", 1.0, 1.0, 100, 0.0138, 0.989),
            pt("2", 2.0, 3.0, 400, 0.0064, 0.997),
            pt("4", 4.0, 11.0, 1600, 0.0026, 0.9995),
            pt("6", 6.0, 26.0, 3600, 0.0015, 0.9998),
            pt("8", 8.0, 46.0, 6400, 0.0011, 0.9999),
        ];
        let text = multisample_conclusion(&independent(pts.clone(), 0.0009), None);
        assert!(
            text.contains("Not resolved: multisample 4 → 6 and 6 → 8."),
            "{text}"
        );
        // 4 and 8 are told apart, 6 and 8 are not.
        assert!(text.contains("From multisample 6 on"), "{text}");
        assert!(
            text.contains("Conclusion: pick multisample 6 when quality matters"),
            "{text}"
        );
        assert!(text.contains("is not resolved by this reference"), "{text}");
        assert!(!text.contains("more samples would still help"), "{text}");
        // With an exact reference every step counts and the last one still has error left.
        let text = multisample_conclusion(&independent(pts.clone(), 0.0), Some("its cut-off"));
        assert!(text.contains("Every step here is resolved."), "{text}");
        assert!(text.contains("Conclusion: pick multisample 6"), "{text}");
        assert!(!text.contains("not resolved by this reference"), "{text}");
        assert!(
            text.contains("differs from the reference in its cut-off"),
            "{text}"
        );
        // A reference too coarse to resolve anything.
        let text = multisample_conclusion(&independent(pts, 0.05), None);
        assert!(text.contains("cannot tell multisample 1 from 8"), "{text}");
        assert!(text.contains("multisample 1 is enough"), "{text}");
    }

    #[test]
    fn occlusion_conclusion_says_when_few_rays_are_worse_than_none() {
        // The last run's room: level 1 worse than off in SSIM and RMSE, level 4 better.
        let pts = vec![
            pt("0", 0.0, 1.0, 85, 0.0170, 0.98468),
            pt("1", 1.0, 1.35, 129, 0.0184, 0.92371),
            pt("2", 2.0, 2.04, 258, 0.0147, 0.97219),
            pt("4", 4.0, 5.0, 776, 0.0137, 0.98648),
        ];
        let text = occlusion_conclusion(&independent(pts.clone(), 0.002), 0, "level-9 reference");
        assert!(
            text.contains("Worse than off: level 1 (SSIM 0.92371 against 0.98468"),
            "{text}"
        );
        assert!(
            text.contains("level 2 in SSIM (0.97219 against 0.98468), though its RMSE is lower"),
            "{text}"
        );
        assert!(text.contains("(with one ray, 0 or 1)"), "{text}");
        assert!(text.contains("Conclusion: pick level 4"), "{text}");
        // When no level beats off by a resolved margin, the advice is to leave it off, and a
        // level better on both counts is named as not resolved.
        let text = occlusion_conclusion(&independent(pts, 0.02), 0, "level-9 reference");
        assert!(text.contains("leave it off"), "{text}");
        assert!(
            text.contains("Level 4 scores better than off in both RMSE and SSIM, but by less"),
            "{text}"
        );
        // An SSIM drop within the residual's own SSIM is not "worse".
        let mut sw = independent(
            vec![
                pt("0", 0.0, 1.0, 85, 0.0227, 0.97294),
                pt("2", 2.0, 2.0, 258, 0.0202, 0.97292),
            ],
            0.001,
        );
        sw.ssim_tol = 0.002;
        let text = occlusion_conclusion(&sw, 0, "level-9 reference");
        assert!(!text.contains("Worse than off"), "{text}");
        assert!(text.contains("Conclusion: pick level 2"), "{text}");
        // No level worse than off: no such sentence.
        let text = occlusion_conclusion(
            &independent(
                vec![
                    pt("0", 0.0, 1.0, 85, 0.0170, 0.980),
                    pt("2", 2.0, 2.0, 258, 0.0120, 0.990),
                ],
                0.001,
            ),
            2,
            "level-9 reference",
        );
        assert!(!text.contains("Worse than off"), "{text}");
        assert!(text.contains("Conclusion: pick level 2"), "{text}");
    }

    #[test]
    fn cutoff_and_depth_conclusions_follow_the_numbers() {
        let cut = vec![
            pt("10 %", 0.1, 1.0, 258, 0.0157, 0.9827),
            pt("1 %", 0.01, 1.03, 265, 0.0146, 0.9846),
            pt("0 %", 0.0, 1.03, 268, 0.0146, 0.9846),
        ];
        let mut sw = independent(cut, 0.0009);
        // Cut-off changes are small image changes.
        for (i, j, d) in [(0, 1, 0.004), (0, 2, 0.0041), (1, 2, 0.0002)] {
            sw.dist[i][j] = d;
            sw.dist[j][i] = d;
        }
        let text = cutoff_conclusion(&sw, Some(0), Some(0.0066), false);
        assert!(
            text.contains("Conclusion: for accuracy, pick cut-off 1 %"),
            "{text}"
        );
        assert!(text.contains("The scene's 10 % falls short"), "{text}");
        assert!(
            text.contains("bias that multisampling does not remove"),
            "{text}"
        );
        let same = independent(
            vec![
                pt("10 %", 0.1, 1.0, 98, 0.0133, 0.99),
                pt("0 %", 0.0, 1.0, 98, 0.0133, 0.99),
            ],
            0.001,
        );
        let text = cutoff_conclusion(&same, Some(0), None, true);
        assert!(
            text.contains("keep the scene's 10 %: lower cut-offs buy nothing"),
            "{text}"
        );

        let depth = vec![
            pt("1", 1.0, 0.9, 209, 0.0518, 0.899),
            pt("2", 2.0, 1.0, 241, 0.0257, 0.957),
            pt("4", 4.0, 1.0, 253, 0.0166, 0.978),
            pt("8", 8.0, 1.0, 256, 0.0158, 0.982),
            pt("16", 16.0, 1.0, 258, 0.0157, 0.983),
        ];
        let mut sw = independent(depth, 0.0009);
        for i in 0..5 {
            for j in 0..5 {
                if i != j {
                    sw.dist[i][j] = (sw.points[i].rmse - sw.points[j].rmse).abs() + 0.002;
                }
            }
        }
        let text = depth_conclusion(&sw, Some(1), false);
        assert!(
            text.contains("Conclusion: a depth cap of 8 is enough"),
            "{text}"
        );
        assert!(
            text.contains("The scene's own cap, 2, is too low"),
            "{text}"
        );
        assert!(text.contains("cap 1 has RMSE 0.0518"), "{text}");
        let text = depth_conclusion(&sw, Some(4), false);
        assert!(
            text.contains("The scene's own cap, 16, is more than enough"),
            "{text}"
        );
    }

    #[test]
    fn adaptive_octree_and_precision_conclusions() {
        let pts = vec![
            pt("4", 4.0, 11.5, 1400, 0.00263, 0.9996),
            pt("0.3", 0.3, 2.84, 293, 0.00543, 0.9969),
            pt("0.1", 0.1, 3.02, 322, 0.00273, 0.9994),
            pt("1", 1.0, 1.0, 85, 0.0138, 0.989),
            pt("2", 2.0, 3.01, 341, 0.00636, 0.9973),
        ];
        let text = adaptive_conclusion(&independent(pts.clone(), 0.0009), 1..3, 3..5);
        assert!(
            text.contains("use threshold 0.1 rather than full multisampling"),
            "{text}"
        );
        assert!(
            text.contains("gets no further than multisample 2 (3.01×, RMSE 0.00636)"),
            "{text}"
        );
        let text = adaptive_conclusion(&independent(pts[..2].to_vec(), 0.0), 1..2, 2..2);
        assert!(
            text.contains("no threshold matched full multisample 4"),
            "{text}"
        );

        let times = vec![("depth 8".to_string(), 0.88), ("leaf 8".to_string(), 1.0)];
        assert!(
            octree_conclusion(&times, Some(0.15)).contains("within the noise: keep the default")
        );
        assert!(octree_conclusion(&times, Some(0.05)).contains("more than the noise"));
        let unsure = octree_conclusion(&times, None);
        assert!(
            unsure.contains("no estimate of its timing noise"),
            "{unsure}"
        );
        assert!(
            unsure.contains("cannot tell from noise: keep the default"),
            "{unsure}"
        );
        let slower = vec![("depth 4".to_string(), 1.12), ("leaf 8".to_string(), 1.0)];
        assert!(octree_conclusion(&slower, None).contains("no setting beat the default"));

        let wire = WireBytes {
            width: 240,
            lines: 180,
            image16: 263_000,
            image8: 133_000,
        };
        let mut sw = independent(
            vec![
                pt("16 bit", 16.0, 1.0, 85, 0.0138, 0.98937),
                pt("8 bit", 8.0, 1.0, 85, 0.01385, 0.98888),
            ],
            0.0009,
        );
        sw.dist[0][1] = 0.0011;
        sw.dist[1][0] = 0.0011;
        let text = precision_conclusion(&sw, 0.0011, Some(("multisample 8", 0.0011 * 5.0)), &wire);
        assert!(
            text.contains("save 49 % of the line-result bytes"),
            "{text}"
        );
        assert!(
            text.contains("by less than the reference resolves"),
            "{text}"
        );
        assert!(text.contains("5 times further"), "{text}");
        // √(0.0055² + 0.0011²) = 0.00561: +2 %.
        assert!(text.contains("only to about 0.00561 (+2 %"), "{text}");
        let text = precision_conclusion(&sw, 0.0011, Some(("multisample 8", 0.002)), &wire);
        assert!(text.contains("keep 16-bit pixels"), "{text}");
        assert!(text.contains("as rough as the baseline"), "{text}");
    }

    #[test]
    fn sig3_formats() {
        assert_eq!(sig3(0.012345), "0.0123");
        assert_eq!(sig3(1.5), "1.50");
        assert_eq!(sig3(0.0), "0");
    }
}
