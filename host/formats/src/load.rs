//! Loading a whole scene, whatever file it comes from, with the command line's overrides.
//!
//! [`load_scene`] picks the reader by the file's extension: `.fart` (FART's scene language,
//! [`crate::fart`]), `.nff` (Eric Haines' Neutral File Format, [`crate::nff`]), and anything else
//! is the seed's configuration file with the data file it names ([`load_config_scene`]). Then
//! [`apply_overrides`] lets the command line beat the file, as FART's rule says.

use crate::config::{read_config, Config};
use crate::datafile::read_data;
use crate::error::LoadError;
use core::fmt::Display;
use core::ops::RangeInclusive;
use std::path::{Path, PathBuf};
use strahl_core::scene::camera::Camera;
use strahl_core::scene::settings::{AA_THRESHOLD, AMBIENT_OCCLUSION, MAX_DEPTH, SAMPLES};
use strahl_core::scene::{RenderSettings, SceneDesc, MAX_IMAGE_SIDE};

/// Settings from the command line; each one given replaces the scene file's.
///
/// The settings themselves and their ranges are core's ([`RenderSettings`] and the ranges in
/// `strahl_core::scene::settings`); this is the set a caller may leave unset. The command line's
/// clap type (`RenderArgs` in the host) fills it in one place, `RenderArgs::overrides`: it is a
/// separate type so that a user of these parsers does not need clap. Clap checks the same ranges
/// before a flag gets here; [`apply_overrides`] checks them again for callers of this crate.
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
    /// Samples per pixel side (`-m`).
    pub samples: Option<u32>,
    /// Vertical field of view in degrees (`-f`).
    pub field_of_view: Option<f32>,
    /// Bounce depth cap for reflection and refraction (`-d`).
    pub max_depth: Option<u32>,
    /// Ambient-occlusion level 0 to 9 (`-a`).
    pub ambient_occlusion: Option<u32>,
    /// FART's preview (`-p`): 400×300, one sample, depth 8, no occlusion, each unless given
    /// explicitly.
    pub preview: bool,
    /// Adaptive multisampling threshold (`--aa-threshold`).
    pub aa_threshold: Option<f32>,
    /// Effect skipping on or off (`--skip-effects`).
    pub skip_effects: Option<bool>,
}

/// FART's preview settings (`-w400 -h300 -m1 -d8 -a0`).
pub const PREVIEW: (u32, u32, u32, u32, u32) = (400, 300, 1, 8, 0);

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
    /// Every file read: the scene's, and its data, mesh and material files. No output may
    /// replace one of them ([`crate::fs::refuse_to_replace_input`]).
    pub inputs: Vec<PathBuf>,
    /// Problems that did not stop loading, one sentence each, naming their file (a FART mesh's
    /// `.mtl` file that cannot be read, a `usemtl` naming no material).
    pub warnings: Vec<String>,
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
    let (output, data_path) = file_paths(config_path, &cfg, overrides).map_err(config_error)?;
    let given = |v: Option<u32>, file: u32, range, what| {
        v.map_or(Ok(file), |v| in_range(v, range, what).map_err(config_error))
    };
    let width = given(
        overrides.width,
        cfg.width,
        1..=MAX_IMAGE_SIDE,
        "image width",
    )?;
    let height = given(
        overrides.height,
        cfg.height,
        1..=MAX_IMAGE_SIDE,
        "image height",
    )?;
    let index_base = overrides.index_base.unwrap_or(cfg.index_base);
    if index_base > 1 {
        return Err(config_error(format!(
            "the index base given on the command line must be 0 or 1, found {index_base}"
        )));
    }

    let data = read_data(&data_path, index_base)?;
    let mut desc = SceneDesc {
        points: data.points,
        triangles: data.triangles,
        shaders: data.shaders,
        lights: data.lights,
        normals: Vec::new(),
        solids: Vec::new(),
        objects: Vec::new(),
        solid_triangles: Vec::new(),
        camera: Camera::Seed(cfg.camera),
        settings: RenderSettings {
            width,
            height,
            background: cfg.background,
            shadows: cfg.shadows,
            reflections: cfg.reflections,
            ..RenderSettings::default()
        },
    };
    apply_overrides(&mut desc, overrides).map_err(config_error)?;
    desc.validate().map_err(|e| LoadError::File {
        path: data_path.clone(),
        message: e.to_string(),
    })?;
    Ok(LoadedScene {
        desc,
        output,
        config_path: config_path.to_path_buf(),
        inputs: vec![config_path.to_path_buf(), data_path.clone()],
        data_path,
        warnings: Vec::new(),
    })
}

/// The output image (`overrides.output` as given, else `$IMAGE_NAME`) and the data file
/// (`$INPUT_DATA`), the file names resolved against the configuration file's folder.
fn file_paths(
    config_path: &Path,
    cfg: &Config,
    overrides: &Overrides,
) -> Result<(PathBuf, PathBuf), String> {
    let folder = config_path.parent().unwrap_or_else(|| Path::new(""));
    let output = match (&overrides.output, &cfg.image_name) {
        (Some(o), _) => o.clone(),
        (None, Some(name)) => folder.join(name),
        (None, None) => return Err("`$IMAGE_NAME` is missing; it names the output image".into()),
    };
    let data_path = match &cfg.input_data {
        Some(name) => folder.join(name),
        None => return Err("`$INPUT_DATA` is missing; it names the data file".into()),
    };
    Ok((output, data_path))
}

/// What Strahl reads, in words, for the error about a file it does not.
pub const SCENE_FORMATS: &str = "the seed's configuration files (.cfg, such as raytracer.cfg, \
    with the data file they name), FART scenes (.fart) and NFF scenes (.nff); an OBJ mesh is \
    rendered through `strahl convert MODEL.obj -o DATA.txt` or a .fart scene's \
    `mesh { file \"MODEL.obj\" }`";

/// Which reader a scene file needs, by its extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneFormat {
    /// The seed's configuration file, `.cfg`.
    SeedConfig,
    /// FART's scene language, `.fart`.
    Fart,
    /// Neutral File Format, `.nff`.
    Nff,
}

impl SceneFormat {
    /// The format of `path`, by its extension (case-insensitive).
    ///
    /// # Errors
    /// An extension Strahl reads no scene from, in words that list what it reads.
    pub fn of(path: &Path) -> Result<SceneFormat, String> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("cfg") => Ok(SceneFormat::SeedConfig),
            Some("fart") => Ok(SceneFormat::Fart),
            Some("nff") => Ok(SceneFormat::Nff),
            Some(other) => Err(format!(
                "Strahl reads no scene from a .{other} file; it reads {SCENE_FORMATS}"
            )),
            None => Err(format!(
                "the scene's name has no extension; Strahl reads {SCENE_FORMATS}"
            )),
        }
    }
}

/// Loads the scene at `path` in the format its extension names, applies `overrides` and checks it.
///
/// A `.fart` or `.nff` scene's image goes to `overrides.output`, or else to the scene's file name
/// with `.bmp` in the current folder.
///
/// # Errors
/// A [`LoadError`] naming the file (and line, and for `.fart` the column) at fault.
pub fn load_scene(path: &Path, overrides: &Overrides) -> Result<LoadedScene, LoadError> {
    let format = SceneFormat::of(path).map_err(|message| LoadError::File {
        path: path.to_path_buf(),
        message,
    })?;
    let mut inputs = vec![path.to_path_buf()];
    let mut warnings = Vec::new();
    let mut desc = match format {
        SceneFormat::SeedConfig => return load_config_scene(path, overrides),
        SceneFormat::Fart => {
            let fart = crate::fart::read_fart(path)?;
            inputs.extend(fart.files);
            warnings = fart.warnings;
            fart.desc
        }
        SceneFormat::Nff => crate::nff::load_nff(path)?,
    };
    let file_error = |message: String| LoadError::File {
        path: path.to_path_buf(),
        message,
    };
    apply_overrides(&mut desc, overrides).map_err(file_error)?;
    desc.validate().map_err(|e| file_error(e.to_string()))?;
    let output = match &overrides.output {
        Some(o) => o.clone(),
        None => {
            let stem = path.file_stem().unwrap_or(path.as_os_str());
            PathBuf::from(stem).with_extension("bmp")
        }
    };
    Ok(LoadedScene {
        desc,
        output,
        config_path: path.to_path_buf(),
        data_path: path.to_path_buf(),
        inputs,
        warnings,
    })
}

/// Applies the command line's settings to `desc`: each option given beats the scene file, and
/// `preview` sets FART's preview values for the options not given.
///
/// The field of view is the vertical angle; a seed camera gets the zoom that gives it
/// (`zoom = (height / width) / tan(fov / 2)`).
///
/// # Errors
/// A message for a value out of range.
pub fn apply_overrides(desc: &mut SceneDesc, o: &Overrides) -> Result<(), String> {
    let s = &mut desc.settings;
    if o.preview {
        let (w, h, m, d, a) = PREVIEW;
        (
            s.width,
            s.height,
            s.samples,
            s.max_depth,
            s.ambient_occlusion,
        ) = (w, h, m, d, a);
    }
    if let Some(w) = o.width {
        s.width = w;
    }
    if let Some(h) = o.height {
        s.height = h;
    }
    if let Some(v) = o.shadows {
        s.shadows = v;
    }
    if let Some(v) = o.reflections {
        s.reflections = v;
    }
    if let Some(m) = o.samples {
        s.samples = in_range(m, SAMPLES, "multisample")?;
    }
    if let Some(d) = o.max_depth {
        s.max_depth = in_range(d, MAX_DEPTH, "max depth")?;
    }
    if let Some(a) = o.ambient_occlusion {
        s.ambient_occlusion = in_range(a, AMBIENT_OCCLUSION, "ambient occlusion")?;
    }
    if let Some(t) = o.aa_threshold {
        s.aa_threshold = Some(in_range(t, AA_THRESHOLD, "multisampling threshold")?);
    }
    if let Some(v) = o.skip_effects {
        s.skip_effects = v;
    }
    if let Some(f) = o.field_of_view {
        if !(f > 0.0 && f < 180.0) {
            return Err(format!(
                "the field of view given on the command line must be above 0 and below 180 degrees, found {f}"
            ));
        }
        let aspect = s.height as f32 / s.width as f32;
        match &mut desc.camera {
            Camera::LookAt(c) => c.vfov_deg = f,
            Camera::Seed(c) => c.zoom = aspect / libm::tanf(f.to_radians() * 0.5),
        }
    }
    Ok(())
}

/// `value` if `range` (one of core's settings ranges) holds it, else the message that names the
/// setting `what` and the range.
fn in_range<T>(value: T, range: RangeInclusive<T>, what: &str) -> Result<T, String>
where
    T: PartialOrd + Display,
{
    if range.contains(&value) {
        Ok(value)
    } else {
        Err(format!(
            "the {what} given on the command line must be {} to {}, found {value}",
            range.start(),
            range.end()
        ))
    }
}
