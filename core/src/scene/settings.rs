//! The render settings: image size, switches and quality knobs, with their one set of limits.
//!
//! Every loader, the command line and [`SceneDesc::validate`](crate::scene::SceneDesc::validate)
//! check a knob against the range defined here ([`SAMPLES`], [`AMBIENT_OCCLUSION`],
//! [`MAX_DEPTH`], [`AA_THRESHOLD`]); none writes its own bounds.

use core::ops::RangeInclusive;
use glam::Vec3;

/// Global render settings (the configuration file's switches and image size).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Colour of rays that hit nothing.
    pub background: Vec3,
    /// `$SHADOWS`: shadow rays for shadow-casting lights.
    pub shadows: bool,
    /// `$REFLECTIONS`: reflection rays for reflective shaders.
    pub reflections: bool,
    /// A reflection is traced only while the path weight (product of the reflection amounts along
    /// it) stays at or above this; the seed's value is 10%.
    pub min_reflection_weight: f32,
    /// Refraction rays for transparent shaders (same cut-off and depth cap as reflections).
    pub refractions: bool,
    /// Hard cap on bounces (reflection and refraction together): a mirror with `r = 1` never
    /// falls under the weight limit.
    pub max_depth: u32,
    /// Samples per pixel side: `samples × samples` stratified samples per pixel (1 to
    /// [`MAX_SAMPLES`]).
    pub samples: u32,
    /// Ambient-occlusion level 0 to [`MAX_AMBIENT_OCCLUSION`]: level `n` traces `n × n` occlusion
    /// rays at each shaded point and scales the ambient term by the share that escapes.
    pub ambient_occlusion: u32,
    /// How far an occlusion ray looks (above 0); `None` picks a tenth of the scene's
    /// bounding-box diagonal.
    pub ao_distance: Option<f32>,
    /// Adaptive multisampling: a pixel gets its `samples × samples` rays only if its centre
    /// sample differs from a neighbour's (left, right, above, below) by more than this in some
    /// channel (colours in `[0, 1]`, the threshold in [`AA_THRESHOLD`]); `None` (the default)
    /// supersamples every pixel.
    pub aa_threshold: Option<f32>,
    /// Leave out rays that cannot change a pixel (the default). Off, the tracer also sends them
    /// and drops their answers: the image must not change by a bit.
    pub skip_effects: bool,
}

/// The most samples per pixel side (`-m`).
pub const MAX_SAMPLES: u32 = 16;

/// Samples per pixel side (`-m`).
pub const SAMPLES: RangeInclusive<u32> = 1..=MAX_SAMPLES;

/// The highest ambient-occlusion level (`-a`), as in FART.
pub const MAX_AMBIENT_OCCLUSION: u32 = 9;

/// Ambient-occlusion levels (`-a`).
pub const AMBIENT_OCCLUSION: RangeInclusive<u32> = 0..=MAX_AMBIENT_OCCLUSION;

/// The highest bounce cap (`-d`, FART's `max_depth`). A path's work grows with its bounces, and a
/// mirror of `r = 1` never falls under the weight cut-off: without a bound, two facing mirrors
/// and a huge cap would trace for ever.
pub const MAX_BOUNCES: u32 = 100;

/// Bounce caps (`-d`).
pub const MAX_DEPTH: RangeInclusive<u32> = 0..=MAX_BOUNCES;

/// Adaptive multisampling thresholds (`--aa-threshold`): a difference of colours in `[0, 1]`.
pub const AA_THRESHOLD: RangeInclusive<f32> = 0.0..=1.0;

impl RenderSettings {
    /// Whether every knob lies in its range (the image size is checked with the scene).
    pub fn knobs_in_range(&self) -> bool {
        SAMPLES.contains(&self.samples)
            && AMBIENT_OCCLUSION.contains(&self.ambient_occlusion)
            && MAX_DEPTH.contains(&self.max_depth)
            && self.aa_threshold.is_none_or(|t| AA_THRESHOLD.contains(&t))
            && self.ao_distance.is_none_or(|d| d > 0.0)
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 480,
            background: Vec3::ZERO,
            shadows: true,
            reflections: true,
            min_reflection_weight: 0.1,
            refractions: true,
            max_depth: 16,
            samples: 1,
            ambient_occlusion: 0,
            ao_distance: None,
            aa_threshold: None,
            skip_effects: true,
        }
    }
}
