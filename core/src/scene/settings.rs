//! The render settings: image size, switches and quality knobs, with their one set of limits.

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
    /// How far an occlusion ray looks; 0 picks a tenth of the scene's bounding-box diagonal.
    pub ao_distance: f32,
    /// Adaptive multisampling: a pixel gets its `samples × samples` rays only if its centre
    /// sample differs from a neighbour's (left, right, above, below) by more than this in some
    /// channel (colours in `[0, 1]`); below 0 (the default) every pixel is supersampled.
    pub aa_threshold: f32,
    /// Leave out rays that cannot change a pixel (the default). Off, the tracer also sends them
    /// and drops their answers: the image must not change by a bit.
    pub skip_effects: bool,
}

/// The most samples per pixel side (`-m`).
pub const MAX_SAMPLES: u32 = 16;

/// The highest ambient-occlusion level (`-a`), as in FART.
pub const MAX_AMBIENT_OCCLUSION: u32 = 9;

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
            ao_distance: 0.0,
            aa_threshold: -1.0,
            skip_effects: true,
        }
    }
}
