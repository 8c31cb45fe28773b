//! [`SceneDesc::validate`]: the seed's rules and every index and number, checked before a scene
//! is prepared.

use super::camera::Camera;
use super::error::SceneError;
use super::model::{shares_fit, SceneDesc, Shader, MAX_IMAGE_SIDE};
use super::triangle_shading::MAX_SHADERS;
use crate::geom::solid::{SolidNode, MAX_CSG_DEPTH};
use alloc::vec::Vec;
use glam::Vec3;

fn finite(v: Vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

impl SceneDesc {
    /// Checks the rules the seed states and every index and number.
    ///
    /// # Errors
    /// The first [`SceneError`] found.
    pub fn validate(&self) -> Result<(), SceneError> {
        let s = &self.settings;
        if s.width == 0 || s.height == 0 || s.width > MAX_IMAGE_SIDE || s.height > MAX_IMAGE_SIDE {
            return Err(SceneError::BadImageSize);
        }
        if self.shaders.is_empty() {
            return Err(SceneError::NoShader);
        }
        if self.lights.is_empty() {
            return Err(SceneError::NoLight);
        }
        let counts = [
            self.points.len(),
            self.triangles.len(),
            self.normals.len(),
            self.solids.len(),
        ];
        if counts.iter().any(|&n| u32::try_from(n).is_err()) || self.shaders.len() > MAX_SHADERS {
            return Err(SceneError::TooLarge);
        }
        if !self.numbers_are_finite() {
            return Err(SceneError::NonFiniteNumber);
        }
        if !self.camera.is_valid() {
            return Err(match self.camera {
                Camera::Seed(_) => SceneError::NonFiniteNumber,
                Camera::LookAt(_) => SceneError::BadCamera,
            });
        }
        if !s.knobs_in_range() {
            return Err(SceneError::BadSettings);
        }
        self.validate_shaders()?;
        if let Some(i) = self.normals.iter().position(|&n| n == Vec3::ZERO) {
            return Err(SceneError::ZeroNormal { normal: i as u32 });
        }
        self.validate_solids()?;
        self.validate_triangles()
    }

    /// Whether every coordinate, colour, factor and setting is a finite number.
    fn numbers_are_finite(&self) -> bool {
        let s = &self.settings;
        self.points.iter().all(|&p| finite(p))
            && self.normals.iter().all(|&n| finite(n))
            && self.solid_triangles.iter().flatten().all(|&p| finite(p))
            && self.shaders.iter().all(Shader::is_finite)
            && self
                .lights
                .iter()
                .all(|l| finite(l.position) && finite(l.color) && l.amount.is_finite())
            && finite(s.background)
            && s.min_reflection_weight.is_finite()
            && s.ao_distance.is_none_or(f32::is_finite)
            && s.aa_threshold.is_none_or(f32::is_finite)
    }

    /// Checks each shader's shares: reflection and transparency in `[0, 1]` with a sum of at
    /// most 1, and a positive index of refraction. The one check of these on the way from a
    /// scene file to the pixel.
    fn validate_shaders(&self) -> Result<(), SceneError> {
        for (i, sh) in self.shaders.iter().enumerate() {
            if !shares_fit(sh.reflection, sh.transparency) || sh.ior <= 0.0 {
                return Err(SceneError::BadShader { shader: i as u32 });
            }
        }
        Ok(())
    }

    /// Checks each triangle's point, shader and normal indices.
    fn validate_triangles(&self) -> Result<(), SceneError> {
        for (i, t) in self.triangles.iter().enumerate() {
            if t.points.iter().any(|&p| p as usize >= self.points.len()) {
                return Err(SceneError::PointIndexOutOfRange { triangle: i as u32 });
            }
            if t.shader as usize >= self.shaders.len() {
                return Err(SceneError::ShaderIndexOutOfRange { triangle: i as u32 });
            }
            if let Some(n) = t.normals {
                if n.iter().any(|&k| k as usize >= self.normals.len()) {
                    return Err(SceneError::NormalIndexOutOfRange { triangle: i as u32 });
                }
            }
        }
        Ok(())
    }

    /// Checks the solid arena: parameters, transforms, shaders, operand order and depth.
    fn validate_solids(&self) -> Result<(), SceneError> {
        let mut depth: Vec<u32> = Vec::with_capacity(self.solids.len());
        for (i, node) in self.solids.iter().enumerate() {
            let solid = i as u32;
            let d = match *node {
                SolidNode::Leaf {
                    shape,
                    transform,
                    shader,
                } => {
                    if !shape.is_valid() || !transform.is_valid() {
                        return Err(SceneError::BadSolid { solid });
                    }
                    if shader as usize >= self.shaders.len() {
                        return Err(SceneError::SolidShaderOutOfRange { solid });
                    }
                    0
                }
                SolidNode::Mesh {
                    first,
                    count,
                    transform,
                    shader,
                } => {
                    let end = u64::from(first) + u64::from(count);
                    if count == 0
                        || end > self.solid_triangles.len() as u64
                        || !transform.is_valid()
                    {
                        return Err(SceneError::BadSolid { solid });
                    }
                    if shader as usize >= self.shaders.len() {
                        return Err(SceneError::SolidShaderOutOfRange { solid });
                    }
                    0
                }
                SolidNode::Csg { a, b, .. } => {
                    if a >= solid || b >= solid {
                        return Err(SceneError::SolidIndexOutOfRange { solid });
                    }
                    1 + depth[a as usize].max(depth[b as usize])
                }
            };
            if d > MAX_CSG_DEPTH {
                return Err(SceneError::CsgTooDeep);
            }
            depth.push(d);
        }
        for (i, &root) in self.objects.iter().enumerate() {
            if root as usize >= self.solids.len() {
                return Err(SceneError::SolidIndexOutOfRange { solid: i as u32 });
            }
        }
        Ok(())
    }
}
