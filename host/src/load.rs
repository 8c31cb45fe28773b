//! Loading a whole scene: the configuration file, the command line's overrides and the data file
//! it names, checked and assembled into a [`SceneDesc`].

use crate::config::read_config;
use crate::datafile::read_data;
use crate::error::LoadError;
use std::path::{Path, PathBuf};
use strahl_core::camera::Camera;
use strahl_core::scene::{RenderSettings, SceneDesc, MAX_IMAGE_SIDE};

/// Settings from the command line; each one given replaces the configuration file's.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    /// Output image, used as given (relative to the current directory).
    pub output: Option<PathBuf>,
    /// Image width in pixels.
    pub width: Option<u32>,
    /// Image height in pixels.
    pub height: Option<u32>,
    /// Shadows on or off.
    pub shadows: Option<bool>,
    /// Reflections on or off.
    pub reflections: Option<bool>,
    /// Index base of the data file's `_TR` records (0 or 1).
    pub index_base: Option<u32>,
}

/// A scene loaded from a configuration file and its data file, ready for `Scene::build`.
#[derive(Clone, Debug)]
pub struct LoadedScene {
    /// The scene, validated.
    pub desc: SceneDesc,
    /// Where the image goes.
    pub output: PathBuf,
    /// The configuration file read.
    pub config_path: PathBuf,
    /// The data file read (resolved against the configuration file's folder).
    pub data_path: PathBuf,
}

/// Reads the configuration file at `config_path`, applies `overrides`, reads the data file it
/// names and returns the validated scene.
///
/// `$IMAGE_NAME` and `$INPUT_DATA` are resolved against the configuration file's folder;
/// `overrides.output` is used as given.
///
/// # Errors
/// A [`LoadError`] naming the file (and line) at fault: unreadable files, bad lines, a missing
/// `$IMAGE_NAME` (without `overrides.output`) or `$INPUT_DATA`, an override out of range, a data
/// file without shader or light, or an index out of range.
pub fn load_config_scene(
    config_path: &Path,
    overrides: &Overrides,
) -> Result<LoadedScene, LoadError> {
    let cfg = read_config(config_path)?;
    let config_error = |message: String| LoadError::File {
        path: config_path.to_path_buf(),
        message,
    };
    let folder = config_path.parent().unwrap_or_else(|| Path::new(""));

    let output = match (&overrides.output, &cfg.image_name) {
        (Some(o), _) => o.clone(),
        (None, Some(name)) => folder.join(name),
        (None, None) => {
            return Err(config_error(
                "`$IMAGE_NAME` is missing; it names the output image".to_string(),
            ))
        }
    };
    let data_path = match &cfg.input_data {
        Some(name) => folder.join(name),
        None => {
            return Err(config_error(
                "`$INPUT_DATA` is missing; it names the data file".to_string(),
            ))
        }
    };

    let side = |v: Option<u32>, file: u32, what: &str| match v {
        None => Ok(file),
        Some(v) if (1..=MAX_IMAGE_SIDE).contains(&v) => Ok(v),
        Some(v) => Err(config_error(format!(
            "the image {what} given on the command line must be 1 to {MAX_IMAGE_SIDE}, found {v}"
        ))),
    };
    let width = side(overrides.width, cfg.width, "width")?;
    let height = side(overrides.height, cfg.height, "height")?;
    let index_base = overrides.index_base.unwrap_or(cfg.index_base);
    if index_base > 1 {
        return Err(config_error(format!(
            "the index base given on the command line must be 0 or 1, found {index_base}"
        )));
    }

    let data = read_data(&data_path, index_base)?;
    let desc = SceneDesc {
        points: data.points,
        triangles: data.triangles,
        shaders: data.shaders,
        lights: data.lights,
        normals: Vec::new(),
        solids: Vec::new(),
        objects: Vec::new(),
        camera: Camera::Seed(cfg.camera),
        settings: RenderSettings {
            width,
            height,
            background: cfg.background,
            shadows: overrides.shadows.unwrap_or(cfg.shadows),
            reflections: overrides.reflections.unwrap_or(cfg.reflections),
            ..RenderSettings::default()
        },
    };
    desc.validate().map_err(|e| LoadError::File {
        path: data_path.clone(),
        message: e.to_string(),
    })?;
    Ok(LoadedScene {
        desc,
        output,
        config_path: config_path.to_path_buf(),
        data_path,
    })
}
