//! Which rays can change a pixel: one set of predicates, asked per hit by the shader and summed
//! up per scene before rendering.
//!
//! The tracer ([`crate::render::shade`]) calls [`mirror_ray_matters`], [`refraction_ray_matters`],
//! [`shadow_ray_matters`] and [`occlusion_matters`] at each hit; [`Effects::derive`] asks the same
//! questions of every shader at the start of a path, so a render can report what it will
//! simulate and what it leaves out.

use super::model::{Light, Shader};
use super::settings::RenderSettings;
use alloc::vec::Vec;

/// Whether `settings` ask for adaptive multisampling (so lines take two passes).
#[inline]
pub fn is_adaptive(settings: &RenderSettings) -> bool {
    settings.samples > 1 && settings.aa_threshold.is_some()
}

/// Whether a mirror ray carrying `share` of the colour of a path of weight `weight` at bounce
/// `depth` can change a pixel: reflections on, a share above 0, the path's weight after it at or
/// above the cut-off, and the depth cap not reached.
#[inline]
pub fn mirror_ray_matters(s: &RenderSettings, share: f32, weight: f32, depth: u32) -> bool {
    s.reflections && share > 0.0 && weight * share >= s.min_reflection_weight && depth < s.max_depth
}

/// Whether a refracted ray carrying `share` can change a pixel: as [`mirror_ray_matters`], with
/// the refraction switch.
#[inline]
pub fn refraction_ray_matters(s: &RenderSettings, share: f32, weight: f32, depth: u32) -> bool {
    s.refractions && share > 0.0 && weight * share >= s.min_reflection_weight && depth < s.max_depth
}

/// Whether shadow rays towards `light` are traced at all (at a hit, only towards a light in
/// front of the surface).
#[inline]
pub fn shadow_ray_matters(s: &RenderSettings, light: &Light) -> bool {
    s.shadows && light.casts_shadows
}

/// Whether ambient-occlusion rays can change the colour of a surface with this shader: occlusion
/// on and an ambient colour to darken.
#[inline]
pub fn occlusion_matters(s: &RenderSettings, shader: &Shader) -> bool {
    s.ambient_occlusion > 0 && shader.ambient != glam::Vec3::ZERO
}

/// Whether a surface with this shader can show a highlight (a specular colour).
#[inline]
pub fn highlight_matters(shader: &Shader) -> bool {
    shader.specular != glam::Vec3::ZERO
}

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
    /// The effects of a scene with these shaders, lights and settings: what the predicates above
    /// say of each shader at the start of a path (weight 1, no bounce yet).
    pub fn derive(shaders: &[Shader], lights: &[Light], s: &RenderSettings) -> Effects {
        let any = |f: &dyn Fn(&Shader) -> bool| shaders.iter().any(f);
        let refraction = any(&|sh| refraction_ray_matters(s, sh.transparency, 1.0, 0));
        let occlusion = any(&|sh| occlusion_matters(s, sh));
        Effects {
            shadow_lights: lights.iter().filter(|l| shadow_ray_matters(s, l)).count() as u32,
            lights: lights.len() as u32,
            reflection: refraction || any(&|sh| mirror_ray_matters(s, sh.reflection, 1.0, 0)),
            refraction,
            multisampling: if s.samples > 1 { s.samples } else { 0 },
            adaptive: is_adaptive(s),
            ambient_occlusion: if occlusion { s.ambient_occlusion } else { 0 },
            highlights: any(&|sh| highlight_matters(sh)),
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

    fn lights(casts_shadows: &[bool]) -> Vec<Light> {
        casts_shadows
            .iter()
            .map(|&casts_shadows| Light {
                position: Vec3::ONE,
                color: Vec3::ONE,
                amount: 1.0,
                casts_shadows,
            })
            .collect()
    }

    #[test]
    fn derives_only_what_can_change_a_pixel() {
        let matte = Shader::phong(Vec3::splat(0.1), Vec3::ONE, Vec3::ZERO, 10.0, 0.05);
        let s = RenderSettings::default();
        let e = Effects::derive(&[matte], &lights(&[true, false]), &s);
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
            aa_threshold: Some(0.1),
            ambient_occlusion: 2,
            shadows: false,
            ..s
        };
        let e = Effects::derive(&[matte, glass], &lights(&[true]), &rich);
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
        let tir = Effects::derive(&[clear], &lights(&[true]), &no_mirrors);
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
            Effects::derive(&[no_ambient], &lights(&[true]), &rich).ambient_occlusion,
            0
        );
    }
}
