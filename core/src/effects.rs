//! Which effects can change a pixel of a scene, derived once from the scene and its settings
//! before rendering.
//!
//! The tracer makes the same decisions per hit (see [`crate::shade`]); [`Effects`] states them for
//! the whole scene, so a render can report what it will simulate and what it leaves out.

use crate::scene::{RenderSettings, Shader};
use alloc::vec::Vec;

/// The effects a scene calls for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Effects {
    /// Lights whose shadows are traced (shadows on and the light casts them).
    pub shadow_lights: u32,
    /// All lights.
    pub lights: u32,
    /// Mirror rays: reflections on, depth cap above 0, and some shader reflects at least the
    /// cut-off; or refraction rays (total internal reflection sends the refracted share along
    /// the mirror ray, whatever the reflection settings).
    pub reflection: bool,
    /// Refraction rays: refractions on, depth cap above 0, and some shader lets at least the
    /// cut-off through.
    pub refraction: bool,
    /// Samples per pixel side, when above 1.
    pub multisampling: u32,
    /// Multisampling only where neighbours differ.
    pub adaptive: bool,
    /// The ambient-occlusion level, when some shader has an ambient colour to darken.
    pub ambient_occlusion: u32,
    /// Some shader has a specular colour.
    pub highlights: bool,
}

impl Effects {
    /// The effects of a scene with these shaders, lights (their shadow flags) and settings.
    pub fn derive(shaders: &[Shader], casts_shadows: &[bool], s: &RenderSettings) -> Effects {
        let cutoff = s.min_reflection_weight;
        let deeper = s.max_depth > 0;
        let shadow_lights = if s.shadows {
            casts_shadows.iter().filter(|&&c| c).count() as u32
        } else {
            0
        };
        let any = |f: &dyn Fn(&Shader) -> bool| shaders.iter().any(f);
        let refraction = s.refractions
            && deeper
            && any(&|sh| sh.transparency > 0.0 && sh.transparency >= cutoff);
        Effects {
            shadow_lights,
            lights: casts_shadows.len() as u32,
            reflection: refraction
                || s.reflections
                    && deeper
                    && any(&|sh| sh.reflection > 0.0 && sh.reflection >= cutoff),
            refraction,
            multisampling: if s.samples > 1 { s.samples } else { 0 },
            adaptive: s.samples > 1 && s.aa_threshold >= 0.0,
            ambient_occlusion: if any(&|sh| sh.ambient != glam::Vec3::ZERO) {
                s.ambient_occlusion
            } else {
                0
            },
            highlights: any(&|sh| sh.specular != glam::Vec3::ZERO),
        }
    }

    /// The effects as short words for a summary, e.g. `shadows 2/3 lights, reflection, 3×3
    /// samples (adaptive), occlusion 2, highlights`; `none` if nothing beyond direct light.
    pub fn describe(&self) -> alloc::string::String {
        use alloc::format;
        let mut parts: Vec<alloc::string::String> = Vec::new();
        parts.push(format!(
            "shadows {}/{} lights",
            self.shadow_lights, self.lights
        ));
        if self.reflection {
            parts.push("reflection".into());
        }
        if self.refraction {
            parts.push("refraction".into());
        }
        if self.multisampling > 1 {
            let m = self.multisampling;
            parts.push(if self.adaptive {
                format!("{m}x{m} samples (adaptive)")
            } else {
                format!("{m}x{m} samples")
            });
        }
        if self.ambient_occlusion > 0 {
            parts.push(format!("occlusion {}", self.ambient_occlusion));
        }
        if self.highlights {
            parts.push("highlights".into());
        }
        parts.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn derives_only_what_can_change_a_pixel() {
        let matte = Shader::phong(Vec3::splat(0.1), Vec3::ONE, Vec3::ZERO, 10.0, 0.05);
        let s = RenderSettings::default();
        let e = Effects::derive(&[matte], &[true, false], &s);
        assert_eq!(e.shadow_lights, 1);
        assert!(!e.reflection, "5 % is under the 10 % cut-off");
        assert!(!e.refraction && !e.highlights);
        assert_eq!((e.multisampling, e.ambient_occlusion), (0, 0));
        let glass = Shader {
            transparency: 0.9,
            ior: 1.5,
            reflection: 0.1,
            specular: Vec3::ONE,
            ..matte
        };
        let rich = RenderSettings {
            samples: 3,
            aa_threshold: 0.1,
            ambient_occlusion: 2,
            shadows: false,
            ..s
        };
        let e = Effects::derive(&[matte, glass], &[true], &rich);
        assert_eq!(e.shadow_lights, 0);
        // Glass under the cut-off for reflection still reflects totally inside.
        let clear = Shader {
            reflection: 0.0,
            ..glass
        };
        let no_mirrors = RenderSettings {
            reflections: false,
            ..s
        };
        let tir = Effects::derive(&[clear], &[true], &no_mirrors);
        assert!(tir.refraction && tir.reflection);
        assert!(e.reflection && e.refraction && e.highlights && e.adaptive);
        assert_eq!((e.multisampling, e.ambient_occlusion), (3, 2));
        assert_eq!(
            e.describe(),
            "shadows 0/1 lights, reflection, refraction, 3x3 samples (adaptive), occlusion 2, highlights"
        );
        let no_ambient = Shader {
            ambient: Vec3::ZERO,
            ..matte
        };
        assert_eq!(
            Effects::derive(&[no_ambient], &[true], &rich).ambient_occlusion,
            0
        );
    }
}
