//! `strahl convert`: an OBJ mesh to the seed's data format, with a configuration file to render it.
//!
//! [`convert_obj`] reads an OBJ file and its materials ([`crate::obj::read_obj_file`]) and writes
//! two files:
//!
//! - the **data file** (the output name given): `_SHD`, `_LIGHT`, `_PT` and `_TR` records as
//!   `scenes/FORMATS.md` section 3 describes them (0-based indices), written by
//!   [`crate::datafile::write_data_file`];
//! - a **`raytracer.cfg`** in the same folder, written by [`crate::config::write_config`], whose `$INPUT_DATA`
//!   names the data file and whose seed camera frames the mesh: it stands in front of the model
//!   (on the −Y side), tilted 15° down, with zoom 1.5, far enough that the mesh's bounding sphere
//!   fits the 640 × 480 image.
//!
//! What carries over and what does not:
//!
//! - **Axes**: OBJ files are Y-up by convention, the seed is Z-up (section 5). By default points
//!   are turned with `(x, y, z) → (x, −z, y)` (a quarter turn about X), so the model stands up
//!   and its front (+Z in OBJ) faces the camera. [`ConvertOptions::y_up`] `false` keeps the
//!   coordinates as they are.
//! - **Normals**: the seed's format has no normals, so `vn` normals are dropped and the renderer
//!   computes smooth normals from the faces (area-weighted, seed section 3.2.2.1).
//! - **Materials**: each `.mtl` material used by a face becomes a shader ([`crate::obj::ObjMaterial::shader`]);
//!   faces without a known material share one grey shader. Transparency (`d`, `Tr`), textures and
//!   everything else of the `.mtl` are dropped (the seed's shaders are opaque).
//! - **Light**: one white shadow-casting light above the model, in front of it and to the left.
//!
//! Both files are written atomically (a temporary file in the same folder, renamed into place).
//! Neither replaces a file that is there unless [`ConvertOptions::force`] says so (the seed's own
//! `raytracer.cfg` says "Datei nicht verändern!": do not change this file).

use crate::config::{write_config, Config};
use crate::crease::{split_creases, DEFAULT_CREASE_DEGREES};
use crate::datafile::write_data_file;
use crate::fs::{refuse_to_replace, refuse_to_replace_input, write_text_atomically};
use crate::obj::{read_obj_file, ObjFile};
use anyhow::{bail, Context as _};
use glam::Vec3;
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};
use strahl_core::scene::camera::{Camera, SeedCamera};
use strahl_core::scene::{Light, SceneDesc, Shader, TriangleDesc};

/// The image size the written `raytracer.cfg` asks for.
pub const IMAGE_SIZE: (u32, u32) = (640, 480);

/// The camera's zoom: a horizontal field of view of `2·atan(1/1.5)` ≈ 67°.
pub const ZOOM: f32 = 1.5;

/// The camera's tilt in degrees (negative looks down).
pub const TILT_DEG: f32 = -15.0;

/// The background colour of the written `raytracer.cfg`.
pub const BACKGROUND: Vec3 = Vec3::new(0.15, 0.15, 0.18);

/// How [`convert_obj_with`] converts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConvertOptions {
    /// The OBJ is Y-up (OBJ's convention, the default): turn it to the seed's Z-up with
    /// `(x, y, z) → (x, −z, y)`. `false` keeps the coordinates.
    pub y_up: bool,
    /// Replace a data file or `raytracer.cfg` that is there already (`--force`); without it,
    /// an existing file is an error that names it.
    pub force: bool,
    /// Faces meeting at more than this angle (degrees) keep a hard edge: their shared points are
    /// split ([`crate::crease`]); 180 keeps every point shared (all smooth).
    pub crease_degrees: f32,
}

impl Default for ConvertOptions {
    fn default() -> Self {
        ConvertOptions {
            y_up: true,
            force: false,
            crease_degrees: DEFAULT_CREASE_DEGREES,
        }
    }
}

/// What [`convert_obj`] did; its `Display` form is the command's report.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvertSummary {
    /// The OBJ file read.
    pub input: PathBuf,
    /// Points written (`_PT`).
    pub points: usize,
    /// Triangles written (`_TR`).
    pub triangles: usize,
    /// Shaders written (`_SHD`).
    pub shaders: usize,
    /// Lights written (`_LIGHT`).
    pub lights: usize,
    /// Normals of the OBJ (`vn`) that the seed's format cannot hold.
    pub normals_dropped: usize,
    /// Points added to keep edges sharper than the crease angle hard.
    pub points_split: usize,
    /// The crease angle used, in degrees.
    pub crease_degrees: f32,
    /// Whether the axes were turned from Y-up to Z-up.
    pub y_up: bool,
    /// The data file written.
    pub data_file: PathBuf,
    /// The configuration file written.
    pub config_file: PathBuf,
    /// Problems that did not stop the conversion (unreadable `.mtl`, unknown `usemtl`, dropped
    /// transparency).
    pub warnings: Vec<String>,
}

/// `n` and `noun`, with an `s` unless `n` is 1.
fn count(n: usize, noun: &str) -> String {
    format!("{n} {noun}{}", if n == 1 { "" } else { "s" })
}

impl fmt::Display for ConvertSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "converted {}: {}, {}, {}, {}",
            self.input.display(),
            count(self.points, "point"),
            count(self.triangles, "triangle"),
            count(self.shaders, "shader"),
            count(self.lights, "light"),
        )?;
        writeln!(
            f,
            "wrote {} and {}",
            self.data_file.display(),
            self.config_file.display()
        )?;
        if self.y_up {
            writeln!(
                f,
                "axes: the OBJ's Y-up turned to the seed's Z-up, (x, y, z) -> (x, -z, y)"
            )?;
        }
        if self.points_split > 0 {
            writeln!(
                f,
                "edges sharper than {}° kept hard: {} added (a point per face group)",
                self.crease_degrees,
                count(self.points_split, "point")
            )?;
        }
        if self.normals_dropped > 0 {
            writeln!(
                f,
                "normals from the OBJ are dropped; the seed computes smooth normals ({} `vn` not kept)",
                self.normals_dropped
            )?;
        }
        for w in &self.warnings {
            writeln!(f, "warning: {w}")?;
        }
        Ok(())
    }
}

/// Converts the OBJ file `input` to the seed's data format at `output`, and writes a
/// `raytracer.cfg` for it in `output`'s folder; OBJ axes are taken as Y-up.
///
/// # Errors
/// An unreadable or bad OBJ file or `.mtl` line (naming the file and line), an output name that
/// the configuration file cannot name (not UTF-8, a line break, `raytracer.cfg` itself), an
/// output (or the configuration file) that would replace the OBJ or one of its `.mtl` files,
/// or a file that cannot be written.
pub fn convert_obj(input: &Path, output: &Path) -> anyhow::Result<ConvertSummary> {
    convert_obj_with(input, output, &ConvertOptions::default())
}

/// [`convert_obj`] with options.
///
/// # Errors
/// As [`convert_obj`].
pub fn convert_obj_with(
    input: &Path,
    output: &Path,
    options: &ConvertOptions,
) -> anyhow::Result<ConvertSummary> {
    let data_name = output
        .file_name()
        .and_then(|n| n.to_str())
        .with_context(|| {
            format!(
                "{}: the output must be a file name in UTF-8 (the configuration file names it)",
                output.display()
            )
        })?;
    if data_name.contains(['\n', '\r']) || data_name.trim() != data_name {
        bail!(
            "{}: the output name must not hold line breaks nor start or end with spaces \
             (the configuration file names it)",
            output.display()
        );
    }
    if data_name == "raytracer.cfg" {
        bail!(
            "{}: the data file cannot be called raytracer.cfg; the configuration file is written \
             under that name beside it",
            output.display()
        );
    }
    let folder = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let config_file = folder.join("raytracer.cfg");

    let obj = read_obj_file(input)?;
    let inputs: Vec<PathBuf> = std::iter::once(input.to_path_buf())
        .chain(obj.material_files.iter().cloned())
        .collect();
    for written in [output, &config_file] {
        refuse_to_replace_input(written, &inputs, "the output")?;
    }
    refuse_to_replace(&[output, &config_file], options.force)?;
    let (desc, camera, mut warnings) = framed_scene(&obj, options);
    warnings.splice(0..0, obj.warnings.iter().cloned());

    let input_name = input
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| input.display().to_string());
    let header = format!(
        "Converted from {input_name} by `strahl convert`.\n\
         {}, {}, {}, 1 light. The OBJ's normals are not kept (the\n\
         format has none); the renderer computes smooth normals.",
        count(desc.points.len(), "point"),
        count(desc.triangles.len(), "triangle"),
        count(desc.shaders.len(), "shader"),
    );
    let data = write_data_file(&desc, &header);
    let image_name = Path::new(data_name).with_extension("bmp");
    let config = config_text(&desc, &camera, &input_name, data_name, &image_name);
    write_text_atomically(output, &data)?;
    write_text_atomically(&config_file, &config)?;

    Ok(ConvertSummary {
        input: input.to_path_buf(),
        points: desc.points.len(),
        triangles: desc.triangles.len(),
        shaders: desc.shaders.len(),
        lights: desc.lights.len(),
        normals_dropped: obj.mesh.normals.len(),
        points_split: desc.points.len() - obj.mesh.points.len(),
        crease_degrees: options.crease_degrees,
        y_up: options.y_up,
        data_file: output.to_path_buf(),
        config_file,
        warnings,
    })
}

/// The grey shader of faces without a material.
pub fn default_shader() -> Shader {
    Shader::phong(
        Vec3::splat(0.08),
        Vec3::splat(0.7),
        Vec3::splat(0.3),
        30.0,
        0.0,
    )
}

/// Turns an OBJ's Y-up coordinates to Z-up: `(x, y, z) → (x, −z, y)`.
pub fn y_up_to_z_up(p: Vec3) -> Vec3 {
    Vec3::new(p.x, -p.z, p.y)
}

/// The scene [`convert_obj`] writes: the mesh's points (turned to Z-up if asked), its triangles
/// without normals, a shader per material used (in order of first use) plus the grey one if some
/// face has no material, one light and a seed camera that frames the mesh. Also returns warnings
/// (materials whose transparency is dropped).
pub fn obj_to_scene(obj: &ObjFile, options: &ConvertOptions) -> (SceneDesc, Vec<String>) {
    let (desc, _, warnings) = framed_scene(obj, options);
    (desc, warnings)
}

/// [`obj_to_scene`], also returning the seed camera the scene holds, so the configuration file
/// is written from it without looking into [`SceneDesc::camera`] again.
fn framed_scene(obj: &ObjFile, options: &ConvertOptions) -> (SceneDesc, SeedCamera, Vec<String>) {
    let mut warnings = Vec::new();
    let mut points: Vec<Vec3> = if options.y_up {
        obj.mesh.points.iter().map(|&p| y_up_to_z_up(p)).collect()
    } else {
        obj.mesh.points.clone()
    };
    let mut shaders = Vec::new();
    let mut shader_of: HashMap<Option<u32>, u32> = HashMap::new();
    let mut triangles = Vec::with_capacity(obj.mesh.triangles.len());
    for (i, t) in obj.mesh.triangles.iter().enumerate() {
        let material = obj.triangle_materials.get(i).copied().flatten();
        let shader = *shader_of.entry(material).or_insert_with(|| {
            let m = material.and_then(|m| obj.materials.get(m as usize));
            shaders.push(match m {
                Some(m) => {
                    if let Some(d) = m.dissolve.filter(|&d| d < 1.0) {
                        warnings.push(format!(
                            "material `{}` is partly transparent (d {d}); the seed's shaders are \
                             opaque",
                            m.name
                        ));
                    }
                    m.shader()
                }
                None => default_shader(),
            });
            (shaders.len() - 1) as u32
        });
        triangles.push(TriangleDesc::new(t.points, shader));
    }
    split_creases(&mut points, &mut triangles, options.crease_degrees);

    let (centre, radius) = bounding_sphere(&points);
    let lights = vec![Light {
        position: centre + Vec3::new(-1.0, -2.0, 2.5) * radius,
        color: Vec3::ONE,
        amount: 1.0,
        casts_shadows: true,
    }];
    let camera = framing_camera(centre, radius);
    let mut desc = SceneDesc {
        points,
        triangles,
        shaders,
        lights,
        camera: Camera::Seed(camera),
        ..SceneDesc::default()
    };
    desc.settings.width = IMAGE_SIZE.0;
    desc.settings.height = IMAGE_SIZE.1;
    desc.settings.background = BACKGROUND;
    (desc, camera, warnings)
}

/// The centre of the points' bounding box and half its diagonal (1 for an empty or flat-to-a-
/// point set, so the camera still stands somewhere).
fn bounding_sphere(points: &[Vec3]) -> (Vec3, f32) {
    let Some(&first) = points.first() else {
        return (Vec3::ZERO, 1.0);
    };
    let (lo, hi) = points
        .iter()
        .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let radius = 0.5 * (hi - lo).length();
    let radius = if radius > 0.0 && radius.is_finite() {
        radius
    } else {
        1.0
    };
    ((lo + hi) * 0.5, radius)
}

/// A seed camera tilted [`TILT_DEG`] with zoom [`ZOOM`], on the −Y side of `centre`, at the
/// distance where a sphere of `radius` fills the image's height with a margin of 15%.
pub fn framing_camera(centre: Vec3, radius: f32) -> SeedCamera {
    let (w, h) = IMAGE_SIZE;
    // Zoom z: the image plane at distance z has half-width 1 and half-height h/w.
    let half_vertical = ((h as f32 / w as f32) / ZOOM).atan();
    let distance = 1.15 * radius / half_vertical.sin();
    let tilt = TILT_DEG.to_radians();
    let forward = Vec3::new(0.0, tilt.cos(), tilt.sin());
    SeedCamera {
        position: centre - forward * distance,
        angle_x_deg: TILT_DEG,
        angle_z_deg: 0.0,
        zoom: ZOOM,
    }
}

/// The `raytracer.cfg` beside the data file: `desc`'s size and background, `camera`, the data
/// file `data_name` and the image `image_name`.
fn config_text(
    desc: &SceneDesc,
    camera: &SeedCamera,
    input_name: &str,
    data_name: &str,
    image_name: &Path,
) -> String {
    let input_name = input_name.replace(['\n', '\r'], " ");
    let cfg = Config {
        image_name: Some(image_name.to_path_buf()),
        width: desc.settings.width,
        height: desc.settings.height,
        input_data: Some(PathBuf::from(data_name)),
        background: desc.settings.background,
        camera: *camera,
        ..Config::default()
    };
    let comment =
        format!("Converted from {input_name} by `strahl convert`; the camera frames the mesh.");
    write_config(&cfg, &comment)
}
