//! The data file (`ROOM.txt`, seed section 2.6): points, triangles, shaders and lights, as
//! `scenes/FORMATS.md` specifies it.
//!
//! The reader ([`read_data`], [`parse_data`]) gives a [`SceneData`]; the writer
//! ([`write_data_file`]) writes a [`SceneDesc`]'s geometry, shaders and lights in the same format.
//! `strahl generate` and `strahl convert` write through it, so what they write is what this
//! module reads.

use crate::error::LoadError;
use crate::limits::MAX_TRIANGLES;
use crate::lines::{lines, read_text, Line};
use glam::Vec3;
use std::fmt::Write as _;
use std::path::Path;
use strahl_core::scene::model::SHARE;
use strahl_core::scene::{Light, SceneDesc, Shader, TriangleDesc};

/// The most elements of one kind an `_OBJ` hint reserves room for; it is never trusted further.
const RESERVE_CAP: usize = 1 << 20;

/// The contents of a data file, with 0-based indices whatever the file's index base.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneData {
    /// Points (`_PT`), in file order.
    pub points: Vec<Vec3>,
    /// Triangles (`_TR`), in file order, every index checked.
    pub triangles: Vec<TriangleDesc>,
    /// Shaders (`_SHD`), in file order.
    pub shaders: Vec<Shader>,
    /// Lights (`_LIGHT`), in file order.
    pub lights: Vec<Light>,
}

/// Reads and parses the data file at `path`; `index_base` (0 or 1) is the number of the first
/// point and shader in `_TR` records.
///
/// # Errors
/// [`LoadError::Io`] if it cannot be read; otherwise as [`parse_data`].
pub fn read_data(path: &Path, index_base: u32) -> Result<SceneData, LoadError> {
    let text = read_text(path)?;
    parse_data(path, &text, index_base)
}

/// Parses data-file text; `path` is only used in error messages.
///
/// # Errors
/// [`LoadError::At`] for the first bad line (unknown record, wrong number of values, bad number,
/// value out of range, a `_TR` index out of range — reported at the `_TR`'s line once the whole
/// file is read), and [`LoadError::File`] if the file has no shader or no light, or
/// `index_base` is neither 0 nor 1.
pub fn parse_data(path: &Path, text: &str, index_base: u32) -> Result<SceneData, LoadError> {
    if index_base > 1 {
        return Err(LoadError::File {
            path: path.to_path_buf(),
            message: format!("index base must be 0 or 1, found {index_base}"),
        });
    }
    let mut data = SceneData::default();
    // The line of each triangle, for index errors found after the whole file is read.
    let mut triangle_lines: Vec<usize> = Vec::new();
    for line in lines(path, text) {
        match line.name {
            "_OBJ" => {
                line.expect_count(4)?;
                let mut n = [0usize; 4];
                for (n, w) in n.iter_mut().zip(&line.values) {
                    *n = (line.unsigned(w)? as usize).min(RESERVE_CAP);
                }
                data.points.reserve(n[0].saturating_sub(data.points.len()));
                data.triangles
                    .reserve(n[1].saturating_sub(data.triangles.len()));
                triangle_lines.reserve(n[1].saturating_sub(triangle_lines.len()));
                data.shaders
                    .reserve(n[2].saturating_sub(data.shaders.len()));
                data.lights.reserve(n[3].saturating_sub(data.lights.len()));
            }
            "_SHD" => data.shaders.push(shader(&line)?),
            "_LIGHT" => data.lights.push(light(&line)?),
            "_PT" => data.points.push(Vec3::from_array(line.numbers::<3>()?)),
            "_TR" => {
                if data.triangles.len() as u64 >= MAX_TRIANGLES {
                    return Err(line.error(format!("more than {MAX_TRIANGLES} triangles")));
                }
                data.triangles.push(triangle(&line, index_base)?);
                triangle_lines.push(line.number);
            }
            name if name.starts_with('$') => {
                return Err(line.error(format!(
                    "unknown record `{name}` (variables belong in the configuration file)"
                )));
            }
            name => return Err(line.error(format!("unknown record `{name}`"))),
        }
    }
    check_indices(path, &data, &triangle_lines, index_base)?;
    let file_error = |message: &str| LoadError::File {
        path: path.to_path_buf(),
        message: message.to_string(),
    };
    if data.shaders.is_empty() {
        return Err(file_error(
            "no shader (_SHD) in the file; at least one is required",
        ));
    }
    if data.lights.is_empty() {
        return Err(file_error(
            "no light (_LIGHT) in the file; at least one is required",
        ));
    }
    Ok(data)
}

fn shader(line: &Line<'_>) -> Result<Shader, LoadError> {
    let v = line.numbers::<11>()?;
    let (shininess, reflection) = (v[9], v[10]);
    if shininess < 0.0 {
        return Err(line.error(format!(
            "`_SHD`: shininess must be 0 or more, found `{}`",
            line.values[9]
        )));
    }
    if !SHARE.contains(&reflection) {
        return Err(line.error(format!(
            "`_SHD`: reflection amount must be 0 to 1, found `{}`",
            line.values[10]
        )));
    }
    Ok(Shader::phong(
        Vec3::new(v[0], v[1], v[2]),
        Vec3::new(v[3], v[4], v[5]),
        Vec3::new(v[6], v[7], v[8]),
        shininess,
        reflection,
    ))
}

fn light(line: &Line<'_>) -> Result<Light, LoadError> {
    line.expect_count(8)?;
    let mut v = [0.0f32; 7];
    for (o, w) in v.iter_mut().zip(&line.values) {
        *o = line.number(w)?;
    }
    let casts_shadows = line.flag(line.values[7], "`_LIGHT`: ShadowCasting")?;
    Ok(Light {
        position: Vec3::new(v[0], v[1], v[2]),
        color: Vec3::new(v[3], v[4], v[5]),
        amount: v[6],
        casts_shadows,
    })
}

fn triangle(line: &Line<'_>, index_base: u32) -> Result<TriangleDesc, LoadError> {
    line.expect_count(4)?;
    let mut idx = [0u32; 4];
    for (o, w) in idx.iter_mut().zip(&line.values) {
        let v = line.unsigned(w)?;
        if v < index_base {
            return Err(line.error("`_TR`: index 0 with index base 1 (numbering starts at 1)"));
        }
        *o = v - index_base;
    }
    Ok(TriangleDesc {
        normals: None,
        points: [idx[0], idx[1], idx[2]],
        shader: idx[3],
    })
}

fn check_indices(
    path: &Path,
    data: &SceneData,
    triangle_lines: &[usize],
    index_base: u32,
) -> Result<(), LoadError> {
    let at = |line: usize, message: String| LoadError::At {
        path: path.to_path_buf(),
        line,
        message,
    };
    let shown = |i: u32| u64::from(i) + u64::from(index_base);
    let (n_points, n_shaders) = (data.points.len(), data.shaders.len());
    for (t, &line) in data.triangles.iter().zip(triangle_lines) {
        if let Some(&p) = t.points.iter().find(|&&p| p as usize >= n_points) {
            return Err(at(
                line,
                format!(
                    "`_TR`: point index {} out of range ({n_points} point{})",
                    shown(p),
                    if n_points == 1 { "" } else { "s" }
                ),
            ));
        }
        if t.shader as usize >= n_shaders && n_shaders > 0 {
            return Err(at(
                line,
                format!(
                    "`_TR`: shader index {} out of range ({n_shaders} shader{})",
                    shown(t.shader),
                    if n_shaders == 1 { "" } else { "s" }
                ),
            ));
        }
    }
    Ok(())
}

/// Writes the geometry, shaders and lights of `desc` in the seed's data format (0-based indices),
/// with `header` as `REM` lines. Numbers are written so they read back to the same `f32`.
pub fn write_data_file(desc: &SceneDesc, header: &str) -> String {
    let mut s = String::new();
    for line in header.lines() {
        let _ = writeln!(s, "REM {line}");
    }
    let _ = writeln!(
        s,
        "_OBJ {} {} {} {}",
        desc.points.len(),
        desc.triangles.len(),
        desc.shaders.len(),
        desc.lights.len()
    );
    // One `writeln!` per record kind, field by field: the records look alike but each lists its
    // own fields in the order the reader above takes them.
    for sh in &desc.shaders {
        let _ = writeln!(
            s,
            "_SHD {} {} {} {} {} {} {} {} {} {} {}",
            sh.ambient.x,
            sh.ambient.y,
            sh.ambient.z,
            sh.diffuse.x,
            sh.diffuse.y,
            sh.diffuse.z,
            sh.specular.x,
            sh.specular.y,
            sh.specular.z,
            sh.shininess,
            sh.reflection
        );
    }
    for l in &desc.lights {
        let _ = writeln!(
            s,
            "_LIGHT {} {} {} {} {} {} {} {}",
            l.position.x,
            l.position.y,
            l.position.z,
            l.color.x,
            l.color.y,
            l.color.z,
            l.amount,
            u8::from(l.casts_shadows)
        );
    }
    for p in &desc.points {
        let _ = writeln!(s, "_PT {} {} {}", p.x, p.y, p.z);
    }
    for t in &desc.triangles {
        let _ = writeln!(
            s,
            "_TR {} {} {} {}",
            t.points[0], t.points[1], t.points[2], t.shader
        );
    }
    s.push_str("QUIT\n");
    s
}
