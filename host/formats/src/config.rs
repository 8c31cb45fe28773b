//! The configuration file `raytracer.cfg` (seed section 2.5), as `scenes/FORMATS.md` specifies it:
//! its reader ([`read_config`], [`parse_config`]) and its writer ([`write_config`]), both over
//! [`Config`]. `strahl convert` and `strahl generate large` write through [`write_config`], so the
//! file they write is the file this module reads.

use crate::error::LoadError;
use crate::lines::{lines, read_text, Line};
use glam::Vec3;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use strahl_core::scene::camera::SeedCamera;
use strahl_core::scene::MAX_IMAGE_SIDE;

/// Everything a configuration file sets, with the documented defaults for what it leaves out.
///
/// Paths are kept as written; [`crate::load`] resolves them against the configuration file's
/// folder.
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    /// `$IMAGE_NAME`: the output image, as written (`None` if absent).
    pub image_name: Option<PathBuf>,
    /// `$IMAGE_WIDTH` (default 640).
    pub width: u32,
    /// `$IMAGE_HEIGHT` (default 480).
    pub height: u32,
    /// `$INPUT_DATA`: the data file, as written (`None` if absent).
    pub input_data: Option<PathBuf>,
    /// `$SHADOWS` (default on).
    pub shadows: bool,
    /// `$REFLECTIONS` (default on).
    pub reflections: bool,
    /// `$COLOR_BG_R/G/B` (default black).
    pub background: Vec3,
    /// `$CAM_POS_*` (default: at the origin, angles 0, zoom 1).
    pub camera: SeedCamera,
    /// `$INDEX_BASE`, our extension: 0 or 1 (default 0).
    pub index_base: u32,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            image_name: None,
            width: 640,
            height: 480,
            input_data: None,
            shadows: true,
            reflections: true,
            background: Vec3::ZERO,
            camera: SeedCamera::default(),
            index_base: 0,
        }
    }
}

/// Reads and parses the configuration file at `path`.
///
/// # Errors
/// [`LoadError::Io`] if it cannot be read, [`LoadError::At`] for the first bad line.
pub fn read_config(path: &Path) -> Result<Config, LoadError> {
    let text = read_text(path)?;
    parse_config(path, &text)
}

/// Parses configuration text; `path` is only used in error messages.
///
/// # Errors
/// [`LoadError::At`] for the first bad line: an unknown command or variable, a wrong number of
/// values, a value that is not a finite number, or a value out of range.
pub fn parse_config(path: &Path, text: &str) -> Result<Config, LoadError> {
    let mut cfg = Config::default();
    for line in lines(path, text) {
        apply(&mut cfg, &line)?;
    }
    Ok(cfg)
}

/// The text of a configuration file that sets everything `cfg` holds, after `comment` as `REM`
/// lines: the image name and data file when given, the size, shadows, reflections, background
/// and camera, then `QUIT`. `$INDEX_BASE` is written only when it is not 0. Numbers are written
/// so they read back to the same `f32`.
pub fn write_config(cfg: &Config, comment: &str) -> String {
    let mut s = String::new();
    for line in comment.lines() {
        let _ = writeln!(s, "REM {line}");
    }
    if let Some(name) = &cfg.image_name {
        let _ = writeln!(s, "$IMAGE_NAME {}", name.display());
    }
    let _ = writeln!(
        s,
        "$IMAGE_WIDTH {}\n$IMAGE_HEIGHT {}",
        cfg.width, cfg.height
    );
    if let Some(data) = &cfg.input_data {
        let _ = writeln!(s, "$INPUT_DATA {}", data.display());
    }
    if cfg.index_base != 0 {
        let _ = writeln!(s, "$INDEX_BASE {}", cfg.index_base);
    }
    let (shadows, reflections) = (u8::from(cfg.shadows), u8::from(cfg.reflections));
    let _ = writeln!(s, "$SHADOWS {shadows}\n$REFLECTIONS {reflections}");
    let bg = cfg.background;
    let _ = writeln!(
        s,
        "$COLOR_BG_R {}\n$COLOR_BG_G {}\n$COLOR_BG_B {}",
        bg.x, bg.y, bg.z
    );
    let c = &cfg.camera;
    let p = c.position;
    let _ = writeln!(
        s,
        "$CAM_POS_X {}\n$CAM_POS_Y {}\n$CAM_POS_Z {}",
        p.x, p.y, p.z
    );
    let _ = writeln!(
        s,
        "$CAM_POS_ANGLE_X {}\n$CAM_POS_ANGLE_Z {}\n$CAM_POS_ZOOM {}\nQUIT",
        c.angle_x_deg, c.angle_z_deg, c.zoom
    );
    s
}

/// The single value of `line`, after checking there is exactly one.
fn one<'a>(line: &Line<'a>) -> Result<&'a str, LoadError> {
    line.expect_count(1)?;
    Ok(line.values[0])
}

/// The rest of `line` as a path.
fn path_value(line: &Line<'_>) -> Result<PathBuf, LoadError> {
    if line.rest.is_empty() {
        Err(line.error(format!(
            "`{}`: expected a file name, found nothing",
            line.name
        )))
    } else {
        Ok(PathBuf::from(line.rest))
    }
}

fn image_side(line: &Line<'_>) -> Result<u32, LoadError> {
    let what = format!("`{}`", line.name);
    line.integer_in(one(line)?, 1, MAX_IMAGE_SIDE, &what)
}

fn finite(line: &Line<'_>) -> Result<f32, LoadError> {
    line.number(one(line)?)
}

fn colour(line: &Line<'_>) -> Result<f32, LoadError> {
    let word = one(line)?;
    let v = line.number(word)?;
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(line.error(format!("`{}` must be 0 to 1, found `{word}`", line.name)))
    }
}

fn flag(line: &Line<'_>) -> Result<bool, LoadError> {
    let what = format!("`{}`", line.name);
    line.flag(one(line)?, &what)
}

fn apply(cfg: &mut Config, line: &Line<'_>) -> Result<(), LoadError> {
    let cam = &mut cfg.camera;
    match line.name {
        "$IMAGE_NAME" => cfg.image_name = Some(path_value(line)?),
        "$IMAGE_WIDTH" => cfg.width = image_side(line)?,
        "$IMAGE_HEIGHT" => cfg.height = image_side(line)?,
        "$INPUT_DATA" => cfg.input_data = Some(path_value(line)?),
        "$SHADOWS" => cfg.shadows = flag(line)?,
        "$REFLECTIONS" => cfg.reflections = flag(line)?,
        "$COLOR_BG_R" => cfg.background.x = colour(line)?,
        "$COLOR_BG_G" => cfg.background.y = colour(line)?,
        "$COLOR_BG_B" => cfg.background.z = colour(line)?,
        "$CAM_POS_X" => cam.position.x = finite(line)?,
        "$CAM_POS_Y" => cam.position.y = finite(line)?,
        "$CAM_POS_Z" => cam.position.z = finite(line)?,
        "$CAM_POS_ANGLE_X" => cam.angle_x_deg = finite(line)?,
        "$CAM_POS_ANGLE_Z" => cam.angle_z_deg = finite(line)?,
        "$CAM_POS_ZOOM" => {
            let word = one(line)?;
            let zoom = line.number(word)?;
            if zoom <= 0.0 {
                return Err(line.error(format!("`$CAM_POS_ZOOM` must be above 0, found `{word}`")));
            }
            cam.zoom = zoom;
        }
        "$INDEX_BASE" => cfg.index_base = line.integer_in(one(line)?, 0, 1, "`$INDEX_BASE`")?,
        name if name.starts_with('$') => {
            return Err(line.error(format!("unknown variable `{name}`")));
        }
        name if name.starts_with('_') => {
            return Err(line.error(format!(
                "unknown command `{name}` (records such as `_PT` belong in the data file)"
            )));
        }
        name => return Err(line.error(format!("unknown command `{name}`"))),
    }
    Ok(())
}
