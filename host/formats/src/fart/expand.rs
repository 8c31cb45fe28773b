//! The expander: runs a parsed `.fart` scene and builds the [`SceneDesc`].
//!
//! It evaluates expressions (in `f64`, each result checked to be finite; numbers become `f32`
//! where the scene takes them), runs `let`, `for` and `if`, and turns shapes into values:
//! a shape value is a leaf, a mesh or a CSG node of earlier values, with the transform and
//! material written at it. `define` stores such a value (or a material) under a name; a use adds
//! its own transforms after the definition's and may replace its material. Values placed at
//! scene level are emitted at once into the solid arena (operands before their CSG node, with
//! `union`/`intersect` folded into a balanced tree) or, for meshes, into points and triangles.
//!
//! Variables and definitions share one namespace of nested scopes: a block (`for`/`if` body, CSG
//! braces) opens a scope; `let`/`define` of a name visible from an enclosing scope changes that
//! variable, otherwise it creates one in the current scope that ends with the block.
//!
//! Limits keep hostile files from running forever or exhausting memory: [`MAX_SHAPES`] shapes,
//! [`MAX_LOOP`] values per `for`, [`MAX_ITERATIONS`] loop iterations in all, [`MAX_TRIANGLES`] mesh
//! triangles, CSG nesting up to [`MAX_CSG_DEPTH`].

use super::parser::{
    BinaryOp, Definable, Expr, ExprKind, ForLoop, IfChain, MaterialAst, Name, SceneAst, Setting,
    SettingValue, SettingsBlock, ShapeAst, ShapeItem, ShapeItemKind, ShapeKind, Stmt,
    TransformKind, UnaryOp, FUNCTIONS,
};
use super::{FartError, FartScene, Pos};
use crate::error::LoadError;
use crate::mesh::append_mesh;
use crate::obj::{read_obj_file, ObjMaterial, ObjMesh, ObjTriangle};
use glam::Vec3;
use std::collections::HashMap;
use std::ops::{Add, Div, Mul, Neg, Sub};
use std::path::{Path, PathBuf};
use std::rc::Rc;
use strahl_core::geom::solid::{CsgOp, Shape, SolidNode, MAX_CSG_DEPTH};
use strahl_core::math::transform::Transform;
use strahl_core::scene::camera::{Camera, LookAtCamera};
use strahl_core::scene::{
    model::shares_fit, settings::MAX_BOUNCES, Blend, Light, RenderSettings, SceneDesc, Shader,
    MAX_AMBIENT_OCCLUSION, MAX_IMAGE_SIDE, MAX_SAMPLES,
};

pub use crate::limits::{MAX_SHAPES, MAX_TRIANGLES};

/// The most values one `for` may run through.
pub const MAX_LOOP: i64 = 1_000_000;

/// The most loop iterations of all `for`s together.
pub const MAX_ITERATIONS: u64 = 10_000_000;

/// The material written as `material { }` (FART's defaults).
pub const DEFAULT_MATERIAL: Shader = Shader {
    ambient: Vec3::splat(0.1),
    diffuse: Vec3::splat(0.8),
    specular: Vec3::ZERO,
    shininess: 20.0,
    reflection: 0.0,
    transparency: 0.0,
    ior: 1.0,
    blend: Blend::Share,
};

/// Runs `scene`, read from `path` (the base for mesh files), and returns its description (not
/// yet validated) with the mesh files read and their warnings.
///
/// # Errors
/// [`LoadError::AtColumn`] for any problem at a place in the file, the OBJ reader's error for a
/// bad mesh file.
pub fn expand(scene: &SceneAst, path: &Path) -> Result<FartScene, LoadError> {
    let mut x = Expander {
        folder: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        scopes: vec![HashMap::new()],
        desc: SceneDesc::default(),
        shader_ids: HashMap::new(),
        meshes: HashMap::new(),
        files: Vec::new(),
        warnings: Vec::new(),
        camera: None,
        options: None,
        shapes: 0,
        triangles: 0,
        iterations: 0,
    };
    x.run(scene).map_err(|f| match f {
        Fail::At(e) => e.at(path),
        Fail::Load(e) => e,
    })?;
    Ok(FartScene {
        desc: x.desc,
        files: x.files,
        warnings: x.warnings,
    })
}

/// Why expansion stopped.
enum Fail {
    /// A problem at a place in the `.fart` file.
    At(FartError),
    /// A mesh file that cannot be loaded.
    Load(LoadError),
}

impl From<FartError> for Fail {
    fn from(e: FartError) -> Self {
        Fail::At(e)
    }
}

type Res<T> = Result<T, Fail>;

fn err<T>(pos: Pos, message: impl Into<String>) -> Res<T> {
    Err(Fail::At(FartError::new(pos, message)))
}

/// A value of the language.
#[derive(Clone, Debug)]
enum Value {
    Num(f64),
    Vector(DVec3),
    Material(Shader),
    Shape(Rc<ShapeVal>),
}

/// A vector of the language, in `f64` like its numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
struct DVec3 {
    x: f64,
    y: f64,
    z: f64,
}

impl DVec3 {
    const ONE: DVec3 = DVec3::splat(1.0);

    const fn splat(v: f64) -> Self {
        DVec3 { x: v, y: v, z: v }
    }

    fn from_array([x, y, z]: [f64; 3]) -> Self {
        DVec3 { x, y, z }
    }

    fn length(self) -> f64 {
        (self.x * self.x + self.y * self.y + self.z * self.z).sqrt()
    }

    fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }

    fn zip(self, o: DVec3, f: impl Fn(f64, f64) -> f64) -> DVec3 {
        DVec3 {
            x: f(self.x, o.x),
            y: f(self.y, o.y),
            z: f(self.z, o.z),
        }
    }
}

impl Add for DVec3 {
    type Output = DVec3;
    fn add(self, o: DVec3) -> DVec3 {
        self.zip(o, |a, b| a + b)
    }
}

impl Sub for DVec3 {
    type Output = DVec3;
    fn sub(self, o: DVec3) -> DVec3 {
        self.zip(o, |a, b| a - b)
    }
}

impl Neg for DVec3 {
    type Output = DVec3;
    fn neg(self) -> DVec3 {
        self.zip(self, |a, _| -a)
    }
}

impl Mul<f64> for DVec3 {
    type Output = DVec3;
    fn mul(self, s: f64) -> DVec3 {
        self.zip(self, |a, _| a * s)
    }
}

impl Div<f64> for DVec3 {
    type Output = DVec3;
    fn div(self, s: f64) -> DVec3 {
        self.zip(self, |a, _| a / s)
    }
}

/// Checks a block `word` that a scene holds at most once, at scene level (`top`): `first` is
/// where an earlier one was; `expected` says how many may be written. Returns the block's place.
fn once(first: Option<Pos>, b: &SettingsBlock, top: bool, word: &str, expected: &str) -> Res<Pos> {
    if !top {
        return err(b.pos, format!("`{word}` does not belong in a CSG node"));
    }
    if let Some(first) = first {
        return err(
            b.pos,
            format!(
                "expected {expected}, found a second one (the first is at {}:{})",
                first.line, first.column
            ),
        );
    }
    Ok(b.pos)
}

/// The shapes that are neither CSG nor a use of a definition: [`ShapeKind`] less those two, so
/// that building their node needs no arm for a kind handled elsewhere.
#[derive(Clone, Copy, Debug)]
enum Primitive {
    Sphere,
    Plane,
    Box,
    Cyl,
    Mesh,
}

/// The items of one shape's block, as [`Expander::shape_items`] read them.
struct ShapeItems<'a> {
    /// The transforms, composed in the order written.
    transform: Transform,
    material: Option<Shader>,
    radius: Option<f32>,
    /// The size and where it was written.
    size: Option<(DVec3, Pos)>,
    /// A plane's unit normal and distance.
    plane: Option<(Vec3, f32)>,
    file: Option<(String, Pos)>,
    vertices: Option<(&'a Vec<Expr>, Pos)>,
    triangles: Option<(&'a Vec<Expr>, Pos)>,
}

/// The cylinder (cone frustum) of `size <bottom radius, top radius, height>` written at `pos`.
fn cylinder((v, pos): (DVec3, Pos)) -> Res<Shape> {
    let s = vec3_of(v, pos)?;
    if s.x < 0.0 || s.y < 0.0 || s.x.max(s.y) <= 0.0 || s.z <= 0.0 {
        return err(
            pos,
            format!(
                "expected <bottom radius, top radius, height> with radii at least 0 (not both 0) and a positive height after `size`, found {}",
                show_vec(v)
            ),
        );
    }
    Ok(Shape::Cylinder {
        bottom_radius: s.x,
        top_radius: s.y,
        height: s.z,
    })
}

/// A number for a message: as written where that is short, in exponent form (`1e300`) where
/// plain digits would run long.
fn show_num(v: f64) -> String {
    let magnitude = v.abs();
    if magnitude == 0.0 || (1e-6..1e16).contains(&magnitude) || !v.is_finite() {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

fn show_vec(v: DVec3) -> String {
    format!("<{}, {}, {}>", show_num(v.x), show_num(v.y), show_num(v.z))
}

impl Value {
    fn describe(&self) -> String {
        match self {
            Value::Num(v) => format!("the number {}", show_num(*v)),
            Value::Vector(v) => format!("the vector {}", show_vec(*v)),
            Value::Material(_) => "a material".to_string(),
            Value::Shape(_) => "a shape".to_string(),
        }
    }
}

/// A shape as a value: what it is, and the transform and material written at it.
#[derive(Clone, Debug)]
struct ShapeVal {
    /// Where it was written (or used, for a defined shape).
    pos: Pos,
    /// Its own placement, applied before any enclosing node's.
    transform: Transform,
    /// Its own material; `None` inherits the enclosing node's.
    material: Option<Shader>,
    node: Node,
    /// Analytic shapes in it.
    leaves: u64,
    /// CSG levels in its arena form (0 for a leaf).
    depth: u32,
}

/// A mesh's triangles and, for a `file` with `.mtl` materials, each triangle's shader.
#[derive(Debug)]
struct MeshVal {
    mesh: ObjMesh,
    /// One per triangle when the OBJ names materials (`None`: a triangle without one); empty
    /// otherwise.
    mtl: Vec<Option<Shader>>,
}

#[derive(Clone, Debug)]
enum Node {
    Leaf(Shape),
    Mesh(Rc<MeshVal>),
    Csg(CsgOp, Vec<Rc<ShapeVal>>),
}

/// CSG operands collected from a node's body.
#[derive(Default)]
struct Operands {
    vals: Vec<Rc<ShapeVal>>,
    leaves: u64,
}

struct Expander {
    folder: PathBuf,
    scopes: Vec<HashMap<String, Value>>,
    desc: SceneDesc,
    shader_ids: HashMap<[u32; 15], u32>,
    meshes: HashMap<PathBuf, Rc<MeshVal>>,
    /// The mesh files and their `.mtl` files read, in order, and their warnings.
    files: Vec<PathBuf>,
    warnings: Vec<String>,
    camera: Option<Pos>,
    options: Option<Pos>,
    shapes: u64,
    triangles: u64,
    iterations: u64,
}

/// Settings of a block by key, each at most once.
struct Keyed<'a> {
    items: HashMap<&'a str, &'a Setting>,
}

impl<'a> Keyed<'a> {
    fn new(block: &'a SettingsBlock, owner: &str) -> Res<Self> {
        let mut items: HashMap<&str, &Setting> = HashMap::new();
        for s in &block.items {
            if let Some(first) = items.insert(s.key.text.as_str(), s) {
                return err(
                    s.key.pos,
                    format!(
                        "`{}` is given twice in this `{owner}` (first at {}:{})",
                        s.key.text, first.key.pos.line, first.key.pos.column
                    ),
                );
            }
        }
        Ok(Keyed { items })
    }

    fn get(&self, key: &str) -> Option<&'a Setting> {
        self.items.get(key).copied()
    }
}

fn f32_of(v: f64, pos: Pos) -> Res<f32> {
    let f = v as f32;
    if f.is_finite() {
        Ok(f)
    } else {
        err(pos, format!("the number {} is too large", show_num(v)))
    }
}

/// Fails at `pos` unless the shape's whole placement is finite and invertible in single
/// precision (each factor alone may be fine while their product is not).
fn check_placement(pos: Pos, transform: &Transform) -> Res<()> {
    if transform.is_valid() {
        return Ok(());
    }
    err(
        pos,
        "this shape's translations, rotations and scales together leave the range of single \
         precision (a scale too small or too large, or a translation too far): its placement \
         cannot be inverted",
    )
}

fn vec3_of(v: DVec3, pos: Pos) -> Res<Vec3> {
    Ok(Vec3::new(
        f32_of(v.x, pos)?,
        f32_of(v.y, pos)?,
        f32_of(v.z, pos)?,
    ))
}

fn truth(v: f64) -> f64 {
    if v != 0.0 {
        1.0
    } else {
        0.0
    }
}

/// The position of a statement, for ordering statements and items of a CSG body.
fn stmt_pos(s: &Stmt) -> Pos {
    match s {
        Stmt::Let { name, .. } | Stmt::Define { name, .. } => name.pos,
        Stmt::For(f) => f.pos,
        Stmt::If(c) => c
            .branches
            .first()
            .map_or(Pos { line: 0, column: 0 }, |b| b.0.pos),
        Stmt::Options(b) | Stmt::Camera(b) | Stmt::Light(b) => b.pos,
        Stmt::Shape(s) => s.pos,
    }
}

/// Arena depth of `depths` folded into a balanced tree of binary nodes.
fn folded_depth(depths: &[u32]) -> u32 {
    match depths {
        [] => 0,
        [d] => *d,
        _ => {
            let (a, b) = depths.split_at(depths.len() / 2);
            1 + folded_depth(a).max(folded_depth(b))
        }
    }
}

impl Expander {
    fn run(&mut self, scene: &SceneAst) -> Res<()> {
        self.exec_stmts(&scene.body, None)?;
        if self.camera.is_none() {
            return err(
                scene.end,
                "expected a `camera { ... }` in the scene, found its closing `}` without one",
            );
        }
        if self.desc.lights.is_empty() {
            return err(
                scene.end,
                "expected at least one `light { ... }` in the scene, found its closing `}` without one",
            );
        }
        if self.desc.shaders.is_empty() {
            self.shader_id(DEFAULT_MATERIAL);
        }
        Ok(())
    }

    // ---- variables ----

    fn lookup(&self, name: &str) -> Option<&Value> {
        self.scopes.iter().rev().find_map(|s| s.get(name))
    }

    fn assign(&mut self, name: &str, value: Value) {
        for scope in self.scopes.iter_mut().rev() {
            if let Some(slot) = scope.get_mut(name) {
                *slot = value;
                return;
            }
        }
        if let Some(top) = self.scopes.last_mut() {
            top.insert(name.to_string(), value);
        }
    }

    fn block(&mut self, stmts: &[Stmt], out: Option<&mut Operands>) -> Res<()> {
        self.scopes.push(HashMap::new());
        let r = self.exec_stmts(stmts, out);
        self.scopes.pop();
        r
    }

    // ---- statements ----

    fn exec_stmts(&mut self, stmts: &[Stmt], mut out: Option<&mut Operands>) -> Res<()> {
        for s in stmts {
            self.exec(s, out.as_deref_mut())?;
        }
        Ok(())
    }

    fn exec(&mut self, s: &Stmt, out: Option<&mut Operands>) -> Res<()> {
        match s {
            Stmt::Let { name, value } => {
                let v = self.eval(value)?;
                self.assign(&name.text, v);
            }
            Stmt::Define { name, item } => {
                let v = match item {
                    Definable::Material(m) => Value::Material(self.material(m)?),
                    Definable::Shape(shape) => Value::Shape(self.shape(shape)?),
                };
                self.assign(&name.text, v);
            }
            Stmt::For(f) => self.for_loop(f, out)?,
            Stmt::If(c) => self.if_chain(c, out)?,
            Stmt::Options(b) => self.options(b, out.is_none())?,
            Stmt::Camera(b) => self.camera(b, out.is_none())?,
            Stmt::Light(b) => self.light(b, out.is_none())?,
            Stmt::Shape(ast) => {
                let v = self.shape(ast)?;
                match out {
                    None => self.emit_object(&v)?,
                    Some(ops) => {
                        ops.leaves = ops.leaves.saturating_add(v.leaves);
                        if ops.leaves > MAX_SHAPES {
                            return err(
                                v.pos,
                                format!("the scene expands to more than {MAX_SHAPES} shapes"),
                            );
                        }
                        ops.vals.push(v);
                    }
                }
            }
        }
        Ok(())
    }

    fn integer(&self, e: &Expr, what: &str) -> Res<i64> {
        match self.eval(e)? {
            Value::Num(v) if v.fract() == 0.0 && v.abs() <= 9.0e15 => Ok(v as i64),
            other => err(
                e.pos,
                format!(
                    "expected a whole number for {what}, found {}",
                    other.describe()
                ),
            ),
        }
    }

    fn for_loop(&mut self, f: &ForLoop, mut out: Option<&mut Operands>) -> Res<()> {
        let a = self.integer(&f.start, "the start of the range")?;
        let b = self.integer(&f.end, "the end of the range")?;
        let step = match &f.step {
            None => 1,
            Some(s) => {
                let v = self.integer(s, "the step")?;
                if v == 0 {
                    return err(s.pos, "expected a step other than 0, found 0");
                }
                v
            }
        };
        let span = if step > 0 { b - a } else { a - b };
        let stride = step.abs();
        let count = if span <= 0 {
            0
        } else {
            (span + stride - 1) / stride
        };
        if count > MAX_LOOP {
            return err(
                f.start.pos,
                format!("the range {a} .. {b} has {count} values; a `for` may run at most {MAX_LOOP} times"),
            );
        }
        let mut i = a;
        for _ in 0..count {
            self.iterations += 1;
            if self.iterations > MAX_ITERATIONS {
                return err(
                    f.pos,
                    format!("the loops run more than {MAX_ITERATIONS} times in all"),
                );
            }
            self.scopes
                .push(HashMap::from([(f.var.text.clone(), Value::Num(i as f64))]));
            let r = self.exec_stmts(&f.body, out.as_deref_mut());
            self.scopes.pop();
            r?;
            i += step;
        }
        Ok(())
    }

    fn if_chain(&mut self, c: &IfChain, out: Option<&mut Operands>) -> Res<()> {
        for (cond, body) in &c.branches {
            let v = match self.eval(cond)? {
                Value::Num(v) => v,
                other => {
                    return err(
                        cond.pos,
                        format!(
                            "expected a number as the condition of `if` (0 is false), found {}",
                            other.describe()
                        ),
                    )
                }
            };
            if v != 0.0 {
                return self.block(body, out);
            }
        }
        match &c.otherwise {
            Some(body) => self.block(body, out),
            None => Ok(()),
        }
    }

    // ---- settings blocks ----

    fn num_setting(&self, s: &Setting, what: &str) -> Res<(f64, Pos)> {
        let e = self.setting_expr(s)?;
        match self.eval(e)? {
            Value::Num(v) => Ok((v, e.pos)),
            other => err(
                e.pos,
                format!(
                    "expected {what} after `{}`, found {}",
                    s.key.text,
                    other.describe()
                ),
            ),
        }
    }

    fn vec_setting(&self, s: &Setting) -> Res<(DVec3, Pos)> {
        let e = self.setting_expr(s)?;
        match self.eval(e)? {
            Value::Vector(v) => Ok((v, e.pos)),
            other => err(
                e.pos,
                format!(
                    "expected a vector <x, y, z> after `{}`, found {}",
                    s.key.text,
                    other.describe()
                ),
            ),
        }
    }

    fn setting_expr<'s>(&self, s: &'s Setting) -> Res<&'s Expr> {
        match &s.value {
            SettingValue::Expr(e) => Ok(e),
            SettingValue::Switch(_) => err(
                s.key.pos,
                format!(
                    "expected a number or a vector after `{}`, found `on`/`off`",
                    s.key.text
                ),
            ),
        }
    }

    fn int_setting(&self, s: &Setting, lo: u32, hi: u32) -> Res<u32> {
        let what = format!("a whole number from {lo} to {hi}");
        let (v, pos) = self.num_setting(s, &what)?;
        if v.fract() != 0.0 || v < f64::from(lo) || v > f64::from(hi) {
            return err(
                pos,
                format!(
                    "expected {what} after `{}`, found {}",
                    s.key.text,
                    show_num(v)
                ),
            );
        }
        Ok(v as u32)
    }

    fn colour_setting(&self, s: &Setting) -> Res<Vec3> {
        let (v, pos) = self.vec_setting(s)?;
        let c = vec3_of(v, pos)?;
        if c.min_element() < 0.0 {
            return err(
                pos,
                format!(
                    "expected a colour with no negative component after `{}`, found {}",
                    s.key.text,
                    show_vec(v)
                ),
            );
        }
        Ok(c)
    }

    fn non_negative(&self, s: &Setting) -> Res<f32> {
        let (v, pos) = self.num_setting(s, "a number at least 0")?;
        if v < 0.0 {
            return err(
                pos,
                format!(
                    "expected a number at least 0 after `{}`, found {}",
                    s.key.text,
                    show_num(v)
                ),
            );
        }
        f32_of(v, pos)
    }

    fn unit_interval(&self, s: &Setting) -> Res<f32> {
        let (v, pos) = self.num_setting(s, "a number from 0 to 1")?;
        if !(0.0..=1.0).contains(&v) {
            return err(
                pos,
                format!(
                    "expected a number from 0 to 1 after `{}`, found {}",
                    s.key.text,
                    show_num(v)
                ),
            );
        }
        f32_of(v, pos)
    }

    fn options(&mut self, b: &SettingsBlock, top: bool) -> Res<()> {
        self.options = Some(once(
            self.options,
            b,
            top,
            "options",
            "one `options` block",
        )?);
        let k = Keyed::new(b, "options")?;
        let mut s = RenderSettings::default();
        if let Some(v) = k.get("width") {
            s.width = self.int_setting(v, 1, MAX_IMAGE_SIDE)?;
        }
        if let Some(v) = k.get("height") {
            s.height = self.int_setting(v, 1, MAX_IMAGE_SIDE)?;
        }
        if let Some(v) = k.get("multisample") {
            s.samples = self.int_setting(v, 1, MAX_SAMPLES)?;
        }
        if let Some(v) = k.get("max_depth") {
            s.max_depth = self.int_setting(v, 0, MAX_BOUNCES)?;
        }
        if let Some(v) = k.get("ambient_occlusion") {
            s.ambient_occlusion = self.int_setting(v, 0, MAX_AMBIENT_OCCLUSION)?;
        }
        if let Some(v) = k.get("background") {
            s.background = self.colour_setting(v)?;
        }
        self.desc.settings = s;
        Ok(())
    }

    fn camera(&mut self, b: &SettingsBlock, top: bool) -> Res<()> {
        self.camera = Some(once(self.camera, b, top, "camera", "exactly one `camera`")?);
        let k = Keyed::new(b, "camera")?;
        let required = |key: &str| {
            k.get(key).ok_or_else(|| {
                Fail::At(FartError::new(
                    b.pos,
                    format!("expected `{key} <x, y, z>` in this `camera`, found none"),
                ))
            })
        };
        let (position, ppos) = self.vec_setting(required("position")?)?;
        let (look_at, lpos) = self.vec_setting(required("look_at")?)?;
        let position = vec3_of(position, ppos)?;
        let look_at = vec3_of(look_at, lpos)?;
        let (up, upos) = match k.get("up") {
            Some(s) => {
                let (v, pos) = self.vec_setting(s)?;
                (vec3_of(v, pos)?, pos)
            }
            None => (Vec3::Y, b.pos),
        };
        let vfov = match k.get("vfov") {
            Some(s) => {
                let (v, pos) = self.num_setting(s, "an angle in degrees")?;
                if !(v > 0.0 && v < 180.0) {
                    return err(
                        pos,
                        format!(
                            "expected a field of view between 0 and 180 degrees after `vfov`, found {}",
                            show_num(v)
                        ),
                    );
                }
                v as f32
            }
            None => 45.0,
        };
        let forward = look_at - position;
        if !forward.is_finite() {
            return err(
                lpos,
                "expected `look_at` within single precision (about 3.4e38) of the camera's `position`",
            );
        }
        if forward == Vec3::ZERO {
            return err(
                lpos,
                "expected `look_at` to differ from the camera's `position`, found the same point",
            );
        }
        if forward.cross(up).normalize_or_zero() == Vec3::ZERO {
            return err(
                upos,
                "expected an `up` vector that is not zero nor parallel to the view direction (from `position` to `look_at`)",
            );
        }
        self.desc.camera = Camera::LookAt(LookAtCamera {
            position,
            look_at,
            up,
            vfov_deg: vfov,
        });
        Ok(())
    }

    fn light(&mut self, b: &SettingsBlock, top: bool) -> Res<()> {
        if !top {
            return err(b.pos, "`light` does not belong in a CSG node");
        }
        let k = Keyed::new(b, "light")?;
        let Some(p) = k.get("position") else {
            return err(
                b.pos,
                "expected `position <x, y, z>` in this `light`, found none",
            );
        };
        let (position, ppos) = self.vec_setting(p)?;
        let position = vec3_of(position, ppos)?;
        let color = match k.get("color") {
            Some(s) => self.colour_setting(s)?,
            None => Vec3::ONE,
        };
        let amount = match k.get("intensity") {
            Some(s) => self.non_negative(s)?,
            None => 1.0,
        };
        let casts_shadows = match k.get("shadows").map(|s| &s.value) {
            Some(SettingValue::Switch(on)) => *on,
            Some(SettingValue::Expr(e)) => {
                return err(
                    e.pos,
                    "expected `on` or `off` after `shadows`, found an expression",
                )
            }
            None => true,
        };
        self.desc.lights.push(Light {
            position,
            color,
            amount,
            casts_shadows,
        });
        Ok(())
    }

    // ---- materials ----

    fn material(&self, m: &MaterialAst) -> Res<Shader> {
        let b = match m {
            MaterialAst::Named(name) => return self.named_material(name),
            MaterialAst::Block(b) => b,
        };
        let k = Keyed::new(b, "material")?;
        let color = match k.get("color") {
            Some(s) => self.colour_setting(s)?,
            None => Vec3::ONE,
        };
        let num = |key: &str, default: f32| -> Res<f32> {
            match k.get(key) {
                Some(s) => self.non_negative(s),
                None => Ok(default),
            }
        };
        let unit = |key: &str| -> Res<f32> {
            match k.get(key) {
                Some(s) => self.unit_interval(s),
                None => Ok(0.0),
            }
        };
        let ambient = num("ambient", DEFAULT_MATERIAL.ambient.x)?;
        let diffuse = num("diffuse", DEFAULT_MATERIAL.diffuse.x)?;
        let specular = num("specular", DEFAULT_MATERIAL.specular.x)?;
        let shininess = num("shininess", DEFAULT_MATERIAL.shininess)?;
        let reflection = unit("reflectance")?;
        let transparency = unit("transparency")?;
        if !shares_fit(reflection, transparency) {
            let later = [k.get("reflectance"), k.get("transparency")]
                .into_iter()
                .flatten()
                .map(|s| s.key.pos)
                .max()
                .unwrap_or(b.pos);
            return err(
                later,
                format!(
                    "expected `reflectance` + `transparency` to be at most 1, found {reflection} + {transparency}"
                ),
            );
        }
        let ior = self.ior_setting(&k)?;
        let shader = Shader {
            ambient: color * ambient,
            diffuse: color * diffuse,
            specular: Vec3::splat(specular),
            shininess,
            reflection,
            transparency,
            ior,
            // FART keeps the seed's rule: the shares split the colour.
            blend: Blend::Share,
        };
        if !shader.is_finite() {
            return err(
                b.pos,
                "expected a material whose `color` times `ambient` and `diffuse` stays within \
                 single precision (about 3.4e38)",
            );
        }
        Ok(shader)
    }

    /// The material defined as `name`.
    fn named_material(&self, name: &Name) -> Res<Shader> {
        match self.lookup(&name.text) {
            Some(Value::Material(sh)) => Ok(*sh),
            Some(other) => err(
                name.pos,
                format!(
                    "expected a material after `material`, found `{}`, which is {}",
                    name.text,
                    other.describe()
                ),
            ),
            None => err(
                name.pos,
                format!(
                    "expected a material after `material`, found `{}`, which is not defined (write `define {} material {{ ... }}` before it)",
                    name.text, name.text
                ),
            ),
        }
    }

    /// A material's `ior` (1 when not given): a positive number.
    fn ior_setting(&self, k: &Keyed<'_>) -> Res<f32> {
        match k.get("ior") {
            Some(s) => {
                let (v, pos) = self.num_setting(s, "a positive number")?;
                if v <= 0.0 {
                    return err(
                        pos,
                        format!(
                            "expected a positive number after `ior`, found {}",
                            show_num(v)
                        ),
                    );
                }
                f32_of(v, pos)
            }
            None => Ok(1.0),
        }
    }

    fn shader_id(&mut self, sh: Shader) -> u32 {
        let f = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        let [a, b, c] = [f(sh.ambient), f(sh.diffuse), f(sh.specular)];
        let key = [
            a[0],
            a[1],
            a[2],
            b[0],
            b[1],
            b[2],
            c[0],
            c[1],
            c[2],
            sh.shininess.to_bits(),
            sh.reflection.to_bits(),
            sh.transparency.to_bits(),
            sh.ior.to_bits(),
            0,
            0,
        ];
        let next = self.desc.shaders.len() as u32;
        let id = *self.shader_ids.entry(key).or_insert(next);
        if id == next {
            self.desc.shaders.push(sh);
        }
        id
    }

    // ---- shapes ----

    fn num_item(&self, e: &Expr, key: &str, what: &str) -> Res<f64> {
        match self.eval(e)? {
            Value::Num(v) => Ok(v),
            other => err(
                e.pos,
                format!("expected {what} after `{key}`, found {}", other.describe()),
            ),
        }
    }

    fn vec_item(&self, e: &Expr, key: &str, what: &str) -> Res<DVec3> {
        match self.eval(e)? {
            Value::Vector(v) => Ok(v),
            other => err(
                e.pos,
                format!("expected {what} after `{key}`, found {}", other.describe()),
            ),
        }
    }

    fn transform_step(&self, kind: TransformKind, e: &Expr) -> Res<Transform> {
        Ok(match kind {
            TransformKind::Translate => {
                let v = self.vec_item(e, "translate", "a vector <x, y, z>")?;
                Transform::translate(vec3_of(v, e.pos)?)
            }
            TransformKind::Rotate => {
                let v = self.vec_item(e, "rotate", "a vector of angles <ax, ay, az>")?;
                Transform::rotate_xyz_deg(vec3_of(v, e.pos)?)
            }
            TransformKind::Scale => {
                let s = match self.eval(e)? {
                    Value::Num(v) => DVec3::splat(v),
                    Value::Vector(v) => v,
                    other => {
                        return err(
                            e.pos,
                            format!(
                                "expected a number or a vector after `scale`, found {}",
                                other.describe()
                            ),
                        )
                    }
                };
                let s32 = vec3_of(s, e.pos)?;
                if s32.x == 0.0 || s32.y == 0.0 || s32.z == 0.0 {
                    return err(
                        e.pos,
                        format!(
                            "expected a scale with no zero factor after `scale`, found {}",
                            show_vec(s)
                        ),
                    );
                }
                Transform::scale(s32)
            }
        })
    }

    /// The shape value of `ast`: a CSG node, a use of a defined shape, or a primitive.
    fn shape(&mut self, ast: &ShapeAst) -> Res<Rc<ShapeVal>> {
        let primitive = match &ast.kind {
            ShapeKind::Csg(op) => return self.csg(ast, *op),
            ShapeKind::Defined(name) => return self.defined_use(ast, name),
            ShapeKind::Sphere => Primitive::Sphere,
            ShapeKind::Plane => Primitive::Plane,
            ShapeKind::Box => Primitive::Box,
            ShapeKind::Cyl => Primitive::Cyl,
            ShapeKind::Mesh => Primitive::Mesh,
        };
        let items = self.shape_items(ast)?;
        let node = self.primitive_node(ast, primitive, &items)?;
        let leaves = u64::from(matches!(node, Node::Leaf(_)));
        Ok(Rc::new(ShapeVal {
            pos: ast.pos,
            transform: items.transform,
            material: items.material,
            node,
            leaves,
            depth: 0,
        }))
    }

    /// A use of the shape defined as `name`: the definition's node with the use's transforms
    /// after the definition's, and the use's material if it gives one.
    fn defined_use(&mut self, ast: &ShapeAst, name: &str) -> Res<Rc<ShapeVal>> {
        let def = self.definition(ast, name)?;
        let items = self.shape_items(ast)?;
        Ok(Rc::new(ShapeVal {
            pos: ast.pos,
            transform: items.transform.after(&def.transform),
            material: items.material.or(def.material),
            node: def.node.clone(),
            leaves: def.leaves,
            depth: def.depth,
        }))
    }

    /// The items written in a shape's block, each checked on its own, in the order written;
    /// an item given twice is an error at its second place.
    fn shape_items<'a>(&mut self, ast: &'a ShapeAst) -> Res<ShapeItems<'a>> {
        let mut items = ShapeItems {
            transform: Transform::IDENTITY,
            material: None,
            radius: None,
            size: None,
            plane: None,
            file: None,
            vertices: None,
            triangles: None,
        };
        let mut seen: HashMap<&'static str, Pos> = HashMap::new();
        let word = ast.kind.word();
        for it in &ast.items {
            let key = match &it.item {
                ShapeItemKind::Transform(kind, e) => {
                    items.transform = self.transform_step(*kind, e)?.after(&items.transform);
                    continue;
                }
                ShapeItemKind::Radius(_) => "radius",
                ShapeItemKind::Size(_) => "size",
                ShapeItemKind::PlanePosition { .. } => "position",
                ShapeItemKind::Material(_) => "material",
                ShapeItemKind::File(_) => "file",
                ShapeItemKind::Vertices(_) => "vertices",
                ShapeItemKind::Triangles(_) => "triangles",
            };
            if let Some(first) = seen.insert(key, it.pos) {
                return err(
                    it.pos,
                    format!(
                        "`{key}` is given twice in this `{word}` (first at {}:{})",
                        first.line, first.column
                    ),
                );
            }
            match &it.item {
                ShapeItemKind::Transform(..) => {}
                ShapeItemKind::Radius(e) => items.radius = Some(self.radius_item(e)?),
                ShapeItemKind::Size(e) => items.size = Some((self.size_item(e, &ast.kind)?, e.pos)),
                ShapeItemKind::PlanePosition { normal, d } => {
                    items.plane = Some(self.plane_item(normal, d)?);
                }
                ShapeItemKind::Material(m) => items.material = Some(self.material(m)?),
                ShapeItemKind::File(name) => items.file = Some((name.clone(), it.pos)),
                ShapeItemKind::Vertices(list) => items.vertices = Some((list, it.pos)),
                ShapeItemKind::Triangles(list) => items.triangles = Some((list, it.pos)),
            }
        }
        Ok(items)
    }

    /// The value of `radius e`: a positive number that stays positive in single precision.
    fn radius_item(&self, e: &Expr) -> Res<f32> {
        let r = self.num_item(e, "radius", "a positive number")?;
        let r32 = f32_of(r, e.pos)?;
        if r > 0.0 && r32 == 0.0 {
            return err(
                e.pos,
                format!(
                    "the radius {} is too small: it rounds to 0 in single precision",
                    show_num(r)
                ),
            );
        }
        if r32 <= 0.0 {
            return err(
                e.pos,
                format!(
                    "expected a positive number after `radius`, found {}",
                    show_num(r)
                ),
            );
        }
        Ok(r32)
    }

    /// The value of `size e` in a shape of `kind`: a vector, or for a box also a number (a cube).
    fn size_item(&self, e: &Expr, kind: &ShapeKind) -> Res<DVec3> {
        match (self.eval(e)?, kind) {
            (Value::Num(s), ShapeKind::Box) => Ok(DVec3::splat(s)),
            (Value::Vector(v), _) => Ok(v),
            (other, ShapeKind::Box) => err(
                e.pos,
                format!(
                    "expected a vector <x, y, z> or a number after `size`, found {}",
                    other.describe()
                ),
            ),
            (other, _) => err(
                e.pos,
                format!(
                    "expected a vector <bottom radius, top radius, height> after `size`, found {}",
                    other.describe()
                ),
            ),
        }
    }

    /// The value of a plane's `position normal, d`: the unit normal and the distance scaled
    /// with it.
    fn plane_item(&self, normal: &Expr, d: &Expr) -> Res<(Vec3, f32)> {
        let n = self.vec_item(normal, "position", "a normal vector <nx, ny, nz>")?;
        let len = n.length();
        if len == 0.0 || !len.is_finite() {
            return err(
                normal.pos,
                format!(
                    "expected a non-zero normal after `position`, found {}",
                    show_vec(n)
                ),
            );
        }
        let dist = self.num_item(d, ",", "the plane's distance (a number)")?;
        let unit = vec3_of(n / len, normal.pos)?;
        Ok((unit, f32_of(dist / len, d.pos)?))
    }

    /// The node of a primitive shape from its items, with the documented defaults for what
    /// they leave out.
    fn primitive_node(
        &mut self,
        ast: &ShapeAst,
        primitive: Primitive,
        items: &ShapeItems<'_>,
    ) -> Res<Node> {
        Ok(match primitive {
            Primitive::Sphere => Node::Leaf(Shape::Sphere {
                radius: items.radius.unwrap_or(1.0),
            }),
            Primitive::Plane => {
                let (normal, d) = items.plane.unwrap_or((Vec3::Y, 0.0));
                Node::Leaf(Shape::Plane { normal, d })
            }
            Primitive::Box => {
                let (v, pos) = items.size.unwrap_or((DVec3::ONE, ast.pos));
                let s = vec3_of(v, pos)?;
                if s.min_element() <= 0.0 {
                    return err(
                        pos,
                        format!(
                            "expected a size with positive edges after `size`, found {}",
                            show_vec(v)
                        ),
                    );
                }
                Node::Leaf(Shape::Cuboid { size: s })
            }
            Primitive::Cyl => Node::Leaf(cylinder(items.size.unwrap_or((DVec3::ONE, ast.pos)))?),
            Primitive::Mesh => {
                Node::Mesh(self.mesh(ast, items.file.clone(), items.vertices, items.triangles)?)
            }
        })
    }

    /// The shape `name` stands for, at its use `ast`, which may only add transforms and a
    /// material.
    fn definition(&self, ast: &ShapeAst, name: &str) -> Res<Rc<ShapeVal>> {
        let def = match self.lookup(name) {
            Some(Value::Shape(s)) => Rc::clone(s),
            Some(other) => {
                return err(
                    ast.pos,
                    format!(
                        "expected a shape, found `{name}`, which is {}",
                        other.describe()
                    ),
                )
            }
            None => {
                return err(
                    ast.pos,
                    format!(
                        "expected a shape, found `{name}`, which is not defined (shapes are sphere, plane, box, cyl, mesh, union, intersect, subtract, or a name given by `define`)"
                    ),
                )
            }
        };
        for it in &ast.items {
            if !matches!(
                it.item,
                ShapeItemKind::Transform(..) | ShapeItemKind::Material(_)
            ) {
                return err(
                    it.pos,
                    format!(
                        "`{}` does not belong in a use of `{name}`; a defined shape takes `translate`, `rotate`, `scale`, `material` or `}}`",
                        item_word(&it.item)
                    ),
                );
            }
        }
        Ok(def)
    }

    /// The mesh in the OBJ file `name` (relative to the scene's folder, read once), with each
    /// triangle's `.mtl` shader.
    fn mesh_file(&mut self, name: &str, pos: Pos) -> Res<Rc<MeshVal>> {
        let path = self.folder.join(name);
        if let Some(m) = self.meshes.get(&path) {
            return Ok(Rc::clone(m));
        }
        let file = read_obj_file(&path).map_err(|e| match e {
            LoadError::Io { source, .. } => Fail::At(FartError::new(
                pos,
                format!(
                    "cannot read the mesh file `{name}` ({}): {source}",
                    path.display()
                ),
            )),
            other => Fail::Load(other),
        })?;
        let mtl = if file.materials.is_empty() {
            Vec::new()
        } else {
            file.triangle_materials
                .iter()
                .map(|m| {
                    m.and_then(|i| file.materials.get(i as usize))
                        .map(ObjMaterial::shader)
                })
                .collect()
        };
        self.files.push(path.clone());
        self.files.extend(file.material_files);
        self.warnings.extend(file.warnings);
        let mesh = Rc::new(MeshVal {
            mesh: file.mesh,
            mtl,
        });
        self.meshes.insert(path, Rc::clone(&mesh));
        Ok(mesh)
    }

    fn mesh(
        &mut self,
        ast: &ShapeAst,
        file: Option<(String, Pos)>,
        vertices: Option<(&Vec<Expr>, Pos)>,
        triangles: Option<(&Vec<Expr>, Pos)>,
    ) -> Res<Rc<MeshVal>> {
        match (file, vertices, triangles) {
            (Some((name, pos)), None, None) => self.mesh_file(&name, pos),
            (Some((_, pos)), _, _) => err(
                pos,
                "expected either `file` or `vertices` and `triangles` in a `mesh`, found both",
            ),
            (None, Some((vs, _)), Some((ts, tpos))) => {
                let mut points = Vec::with_capacity(vs.len());
                for e in vs {
                    let v = self.vec_item(e, "vertices", "a vector <x, y, z>")?;
                    points.push(vec3_of(v, e.pos)?);
                }
                let n = points.len();
                let mut tris = Vec::with_capacity(ts.len());
                for e in ts {
                    let v = self.vec_item(e, "triangles", "three point indices <i, j, k>")?;
                    let mut idx = [0u32; 3];
                    for (slot, c) in idx.iter_mut().zip([v.x, v.y, v.z]) {
                        if c.fract() != 0.0 || c < 0.0 || c >= n as f64 {
                            return err(
                                e.pos,
                                format!(
                                    "expected point indices from 0 to {} (the mesh has {n} vertices), found {}",
                                    n.saturating_sub(1),
                                    show_vec(v)
                                ),
                            );
                        }
                        *slot = c as u32;
                    }
                    tris.push(ObjTriangle {
                        points: idx,
                        normals: None,
                    });
                }
                if tris.is_empty() {
                    return err(tpos, "expected at least one triangle in `triangles`, found none");
                }
                Ok(Rc::new(MeshVal {
                    mesh: ObjMesh {
                        points,
                        normals: Vec::new(),
                        triangles: tris,
                    },
                    mtl: Vec::new(),
                }))
            }
            (None, Some((_, pos)), None) => err(
                pos,
                "expected `triangles { ... }` with the `vertices` of this `mesh`, found none",
            ),
            (None, None, Some((_, pos))) => err(
                pos,
                "expected `vertices { ... }` with the `triangles` of this `mesh`, found none",
            ),
            (None, None, None) => err(
                ast.pos,
                "expected `file \"name.obj\"` or `vertices { ... } triangles { ... }` in this `mesh`, found neither",
            ),
        }
    }

    fn csg(&mut self, ast: &ShapeAst, op: CsgOp) -> Res<Rc<ShapeVal>> {
        let word = ast.kind.word();
        let mut ops = Operands::default();
        let mut transform = Transform::IDENTITY;
        let mut material: Option<(Shader, Pos)> = None;
        self.scopes.push(HashMap::new());
        // Statements and items in the order written, so each expression sees the variables set
        // before it.
        let (mut si, mut ii) = (0, 0);
        let result = loop {
            let next_stmt = ast.body.get(si);
            let next_item = ast.items.get(ii);
            let take_item = match (next_stmt, next_item) {
                (None, None) => break Ok(()),
                (Some(_), None) => false,
                (None, Some(_)) => true,
                (Some(s), Some(i)) => i.pos < stmt_pos(s),
            };
            let r = if take_item {
                ii += 1;
                self.csg_item(next_item, &mut transform, &mut material, word)
            } else {
                si += 1;
                match next_stmt {
                    Some(s) => self.exec(s, Some(&mut ops)),
                    None => Ok(()),
                }
            };
            if let Err(e) = r {
                break Err(e);
            }
        };
        self.scopes.pop();
        result?;
        let n = ops.vals.len();
        if n < 2 {
            let what = match op {
                CsgOp::Subtract => " (the first, minus all the others)",
                _ => "",
            };
            return err(
                ast.end,
                format!("expected at least two shapes in a `{word}`{what}, found {n}"),
            );
        }
        let depths: Vec<u32> = ops.vals.iter().map(|v| v.depth).collect();
        let depth = match op {
            // A minus the union of the others.
            CsgOp::Subtract => 1 + depths[0].max(folded_depth(&depths[1..])),
            _ => folded_depth(&depths),
        };
        if depth > MAX_CSG_DEPTH {
            return err(
                ast.pos,
                format!("CSG nested more than {MAX_CSG_DEPTH} levels deep"),
            );
        }
        Ok(Rc::new(ShapeVal {
            pos: ast.pos,
            transform,
            material: material.map(|m| m.0),
            node: Node::Csg(op, ops.vals),
            leaves: ops.leaves,
            depth,
        }))
    }

    fn csg_item(
        &mut self,
        item: Option<&ShapeItem>,
        transform: &mut Transform,
        material: &mut Option<(Shader, Pos)>,
        word: &str,
    ) -> Res<()> {
        let Some(it) = item else { return Ok(()) };
        match &it.item {
            ShapeItemKind::Transform(kind, e) => {
                *transform = self.transform_step(*kind, e)?.after(transform);
            }
            ShapeItemKind::Material(m) => {
                if let Some((_, first)) = material {
                    return err(
                        it.pos,
                        format!(
                            "`material` is given twice in this `{word}` (first at {}:{})",
                            first.line, first.column
                        ),
                    );
                }
                *material = Some((self.material(m)?, it.pos));
            }
            _ => return err(it.pos, format!("this does not belong in a `{word}`")),
        }
        Ok(())
    }

    // ---- emission ----

    fn emit_object(&mut self, v: &ShapeVal) -> Res<()> {
        if let Node::Mesh(m) = &v.node {
            let mesh = &m.mesh;
            self.triangles = self.triangles.saturating_add(mesh.triangles.len() as u64);
            if self.triangles > MAX_TRIANGLES {
                return err(
                    v.pos,
                    format!("the scene places more than {MAX_TRIANGLES} mesh triangles"),
                );
            }
            check_placement(v.pos, &v.transform)?;
            let shader = self.shader_id(v.material.unwrap_or(DEFAULT_MATERIAL));
            let first = self.desc.triangles.len();
            append_mesh(&mut self.desc, mesh, &v.transform, shader);
            // The OBJ's own materials, unless the mesh gives one.
            if v.material.is_none() {
                for (i, mtl) in m.mtl.iter().enumerate() {
                    if let Some(s) = mtl {
                        self.desc.triangles[first + i].shader = self.shader_id(*s);
                    }
                }
            }
            return Ok(());
        }
        let root = self.emit_solid(v, &Transform::IDENTITY, None)?;
        self.desc.objects.push(root);
        Ok(())
    }

    fn emit_solid(
        &mut self,
        v: &ShapeVal,
        outer: &Transform,
        inherited: Option<Shader>,
    ) -> Res<u32> {
        let transform = outer.after(&v.transform);
        let material = v.material.or(inherited);
        if matches!(v.node, Node::Leaf(_) | Node::Mesh(_)) {
            check_placement(v.pos, &transform)?;
        }
        match &v.node {
            Node::Leaf(shape) => {
                self.shapes += 1;
                if self.shapes > MAX_SHAPES {
                    return err(
                        v.pos,
                        format!("the scene expands to more than {MAX_SHAPES} shapes"),
                    );
                }
                let shader = self.shader_id(material.unwrap_or(DEFAULT_MATERIAL));
                Ok(self.push_solid(SolidNode::Leaf {
                    shape: *shape,
                    transform,
                    shader,
                }))
            }
            Node::Csg(op, operands) => {
                let mut ids = Vec::with_capacity(operands.len());
                for o in operands {
                    ids.push(self.emit_solid(o, &transform, material)?);
                }
                Ok(match (op, ids.split_first()) {
                    // `subtract { A B C }` is A minus all the others: A − (B ∪ C).
                    (CsgOp::Subtract, Some((&a, rest))) if rest.len() > 1 => {
                        let b = self.fold(CsgOp::Union, rest);
                        self.push_solid(SolidNode::Csg {
                            op: CsgOp::Subtract,
                            a,
                            b,
                        })
                    }
                    _ => self.fold(*op, &ids),
                })
            }
            Node::Mesh(m) => {
                // A CSG operand: the mesh's triangles in object space, as a closed solid, with
                // one material (the solid's; a CSG mesh does not take the OBJ's materials).
                let mesh = &m.mesh;
                self.triangles = self.triangles.saturating_add(mesh.triangles.len() as u64);
                if self.triangles > MAX_TRIANGLES {
                    return err(
                        v.pos,
                        format!("the scene places more than {MAX_TRIANGLES} mesh triangles"),
                    );
                }
                let shader = self.shader_id(material.unwrap_or(DEFAULT_MATERIAL));
                let first = self.desc.solid_triangles.len() as u32;
                for t in &mesh.triangles {
                    self.desc
                        .solid_triangles
                        .push(t.points.map(|i| mesh.points[i as usize]));
                }
                Ok(self.push_solid(SolidNode::Mesh {
                    first,
                    count: mesh.triangles.len() as u32,
                    transform,
                    shader,
                }))
            }
        }
    }

    fn push_solid(&mut self, node: SolidNode) -> u32 {
        self.desc.solids.push(node);
        (self.desc.solids.len() - 1) as u32
    }

    /// Combines `ids` with `op` as a balanced tree (the same set as folding from the left, with
    /// a nesting depth of log₂ n); returns the root.
    fn fold(&mut self, op: CsgOp, ids: &[u32]) -> u32 {
        match ids {
            [] => 0,
            [one] => *one,
            _ => {
                let (l, r) = ids.split_at(ids.len() / 2);
                let a = self.fold(op, l);
                let b = self.fold(op, r);
                self.push_solid(SolidNode::Csg { op, a, b })
            }
        }
    }

    // ---- expressions ----

    fn eval(&self, e: &Expr) -> Res<Value> {
        let v = match &e.kind {
            ExprKind::Number(v) => Value::Num(*v),
            ExprKind::Var(name) if name == "pi" => Value::Num(std::f64::consts::PI),
            ExprKind::Var(name) => match self.lookup(name) {
                Some(v @ (Value::Num(_) | Value::Vector(_))) => v.clone(),
                Some(other) => {
                    return err(
                        e.pos,
                        format!(
                            "expected a number or a vector, found `{name}`, which is {}",
                            other.describe()
                        ),
                    )
                }
                None if FUNCTIONS.iter().any(|(f, _)| f == name) => {
                    return err(
                        e.pos,
                        format!("`{name}` is a function; expected `(` and its argument after it"),
                    )
                }
                None => {
                    return err(
                        e.pos,
                        format!(
                            "undefined variable `{name}`; set it with `let {name} = ...` first"
                        ),
                    )
                }
            },
            ExprKind::Vector(parts) => {
                let mut c = [0.0; 3];
                for (slot, (part, axis)) in c.iter_mut().zip(parts.iter().zip(["x", "y", "z"])) {
                    *slot = match self.eval(part)? {
                        Value::Num(v) => v,
                        other => {
                            return err(
                                part.pos,
                                format!(
                                "expected a number as the {axis} component of a vector, found {}",
                                other.describe()
                            ),
                            )
                        }
                    };
                }
                Value::Vector(DVec3::from_array(c))
            }
            ExprKind::Unary(op, inner) => match (op, self.eval(inner)?) {
                (UnaryOp::Neg, Value::Num(v)) => Value::Num(-v),
                (UnaryOp::Neg, Value::Vector(v)) => Value::Vector(-v),
                (UnaryOp::Not, Value::Num(v)) => Value::Num(1.0 - truth(v)),
                (_, other) => {
                    return err(
                        e.pos,
                        format!(
                            "cannot apply `!` to {}; expected a number",
                            other.describe()
                        ),
                    )
                }
            },
            ExprKind::Binary(op, op_pos, a, b) => self.binary(*op, *op_pos, a, b)?,
            ExprKind::Call(name, args) => self.call(e.pos, name, args)?,
        };
        let finite = match &v {
            Value::Num(x) => x.is_finite(),
            Value::Vector(x) => x.is_finite(),
            _ => true,
        };
        if !finite {
            return err(e.pos, "this expression's result is not a finite number");
        }
        Ok(v)
    }

    fn binary(&self, op: BinaryOp, pos: Pos, a: &Expr, b: &Expr) -> Res<Value> {
        use Value::{Num, Vector};
        let lhs = self.eval(a)?;
        // `&&` and `||` evaluate their right side only when it matters.
        if let (BinaryOp::And | BinaryOp::Or, Num(x)) = (op, &lhs) {
            let decided = if op == BinaryOp::And {
                *x == 0.0
            } else {
                *x != 0.0
            };
            if decided {
                return Ok(Num(truth(*x)));
            }
            return match self.eval(b)? {
                Num(y) => Ok(Num(truth(y))),
                other => err(
                    b.pos,
                    format!(
                        "expected a number after `{}`, found {}",
                        op.symbol(),
                        other.describe()
                    ),
                ),
            };
        }
        let rhs = self.eval(b)?;
        let bool_num = |c: bool| Num(if c { 1.0 } else { 0.0 });
        let out = match (op, &lhs, &rhs) {
            (BinaryOp::Add, Num(x), Num(y)) => Num(x + y),
            (BinaryOp::Add, Vector(x), Vector(y)) => Vector(*x + *y),
            (BinaryOp::Sub, Num(x), Num(y)) => Num(x - y),
            (BinaryOp::Sub, Vector(x), Vector(y)) => Vector(*x - *y),
            (BinaryOp::Mul, Num(x), Num(y)) => Num(x * y),
            (BinaryOp::Mul, Vector(x), Num(y)) => Vector(*x * *y),
            (BinaryOp::Mul, Num(x), Vector(y)) => Vector(*y * *x),
            (BinaryOp::Div | BinaryOp::Rem, _, Num(y)) if *y == 0.0 => {
                return err(
                    pos,
                    format!("division by zero: the right side of `{}` is 0", op.symbol()),
                )
            }
            (BinaryOp::Div, Num(x), Num(y)) => Num(x / y),
            (BinaryOp::Div, Vector(x), Num(y)) => Vector(*x / *y),
            (BinaryOp::Rem, Num(x), Num(y)) => Num(x.rem_euclid(*y)),
            (BinaryOp::Lt, Num(x), Num(y)) => bool_num(x < y),
            (BinaryOp::Le, Num(x), Num(y)) => bool_num(x <= y),
            (BinaryOp::Gt, Num(x), Num(y)) => bool_num(x > y),
            (BinaryOp::Ge, Num(x), Num(y)) => bool_num(x >= y),
            (BinaryOp::Eq, Num(x), Num(y)) => bool_num(x == y),
            (BinaryOp::Ne, Num(x), Num(y)) => bool_num(x != y),
            (BinaryOp::Eq, Vector(x), Vector(y)) => bool_num(x == y),
            (BinaryOp::Ne, Vector(x), Vector(y)) => bool_num(x != y),
            _ => {
                return err(
                    pos,
                    format!(
                        "cannot apply `{}` to {} and {}",
                        op.symbol(),
                        lhs.describe(),
                        rhs.describe()
                    ),
                )
            }
        };
        let finite = match &out {
            Num(x) => x.is_finite(),
            Vector(x) => x.is_finite(),
            _ => true,
        };
        if !finite {
            return err(
                pos,
                format!("the result of `{}` is not a finite number", op.symbol()),
            );
        }
        Ok(out)
    }

    fn call(&self, pos: Pos, name: &str, args: &[Expr]) -> Res<Value> {
        let Some(&(_, arity)) = FUNCTIONS.iter().find(|(f, _)| *f == name) else {
            let names: Vec<&str> = FUNCTIONS.iter().map(|(f, _)| *f).collect();
            return err(
                pos,
                format!(
                    "unknown function `{name}`; the functions are {}",
                    names.join(", ")
                ),
            );
        };
        if args.len() != arity {
            return err(
                pos,
                format!(
                    "`{name}` takes {arity} argument{}, found {}",
                    if arity == 1 { "" } else { "s" },
                    args.len()
                ),
            );
        }
        let mut x = [0.0f64; 2];
        for (slot, a) in x.iter_mut().zip(args) {
            *slot = match self.eval(a)? {
                Value::Num(v) => v,
                other => {
                    return err(
                        a.pos,
                        format!(
                            "expected a number as the argument of `{name}`, found {}",
                            other.describe()
                        ),
                    )
                }
            };
        }
        let [a, b] = x;
        let v = match name {
            "sin" => a.to_radians().sin(),
            "cos" => a.to_radians().cos(),
            "tan" => a.to_radians().tan(),
            "sqrt" if a < 0.0 => {
                return err(
                    pos,
                    format!(
                        "expected a number at least 0 for `sqrt`, found {}",
                        show_num(a)
                    ),
                )
            }
            "sqrt" => a.sqrt(),
            "abs" => a.abs(),
            "floor" => a.floor(),
            "ceil" => a.ceil(),
            "min" => a.min(b),
            "max" => a.max(b),
            _ => a.powf(b),
        };
        if !v.is_finite() {
            return err(
                pos,
                format!(
                    "`{name}` of {} is not a finite number",
                    args_text(&x[..arity])
                ),
            );
        }
        Ok(Value::Num(v))
    }
}

fn item_word(item: &ShapeItemKind) -> &'static str {
    match item {
        ShapeItemKind::Radius(_) => "radius",
        ShapeItemKind::Size(_) => "size",
        ShapeItemKind::PlanePosition { .. } => "position",
        ShapeItemKind::Transform(TransformKind::Translate, _) => "translate",
        ShapeItemKind::Transform(TransformKind::Rotate, _) => "rotate",
        ShapeItemKind::Transform(TransformKind::Scale, _) => "scale",
        ShapeItemKind::Material(_) => "material",
        ShapeItemKind::File(_) => "file",
        ShapeItemKind::Vertices(_) => "vertices",
        ShapeItemKind::Triangles(_) => "triangles",
    }
}

fn args_text(args: &[f64]) -> String {
    args.iter()
        .map(|a| show_num(*a))
        .collect::<Vec<_>>()
        .join(", ")
}
