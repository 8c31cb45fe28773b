//! Eric Haines' Neutral File Format (`.nff`), the language of the Standard Procedural Databases
//! (SPD) benchmark scenes.
//!
//! [`load_nff`] reads a file into a [`SceneDesc`]; `scenes/FORMATS.md` section 10 is the
//! reference. In short:
//!
//! | NFF | Strahl |
//! |---|---|
//! | `v` block: `from`, `at`, `up`, `angle`, `hither`, `resolution` | [`Camera::LookAt`] with `angle` as the vertical field of view; the image size; `hither` is read and ignored |
//! | `b r g b` | the background colour |
//! | `l x y z [r g b]` | a shadow-casting point light, white unless given, amount `1/√n` for `n` lights (as SPD's POV-Ray files) |
//! | `f r g b Kd Ks Shine T ior` | a [`Shader`] for the primitives that follow, with NFF's additive [`Blend`] (see [`shader_from_nff`]) |
//! | `c bx by bz br ax ay az ar` | a cone frustum [`Shape::Cylinder`] from base to apex, **capped** (NFF's is open) |
//! | `s x y z r` | a [`Shape::Sphere`] |
//! | `p n` + `n` vertices `x y z` | a polygon, split into `n − 2` triangles ([`triangulate`]: a fan around its first corner where that covers it once, else ear clipping; flat: its points are its own) |
//! | `pp n` + `n` vertices `x y z nx ny nz` | the same with a shading normal at each corner |
//! | `#` | a comment line |
//!
//! The file is read as a stream of whitespace-separated **records**, not lines: a keyword and
//! then exactly the numbers it takes (cone 8, sphere 4, `f` 8, `b` 3, `l` 3 or 6, `p n` 3n,
//! `pp n` 6n, each `v` sub-keyword its own), on its line or on any lines after it. So both
//! layouts SPD's programs write load: a cone on one line and the specification's `c` with its base
//! and apex on two lines below it. Numbers are never keywords, so a record ends where its count
//! is reached; a keyword before that cuts it short (an error), and a number where a keyword is
//! expected is an error too. A line whose first word starts with `#` is a comment.
//!
//! NFF's material model is additive (NFF.TXT: "it is not required that Kd + Ks == 1"): a
//! surface's colour is its local colour plus Ks times the reflected colour plus T times the
//! transmitted colour ([`Blend::Additive`]), as POV-Ray renders SPD's `.pov` files. The seed's
//! formats keep the seed's rule, which scales the local colour down by `1 − Ks − T`.
//!
//! The image size and background come from the file. Reflection and refraction rays are traced
//! down to a weight of [`NFF_MIN_RAY_WEIGHT`] (1/255, POV-Ray's default `adc_bailout`, with
//! which SPD's `.pov` files render) instead of the seed's 10 %. Other settings keep Strahl's
//! defaults (SPD's own rules trace at most 5 bounces; `--max-depth 5` says so).
//!
//! Every error is `path:line: what is wrong, what was expected` ([`LoadError::At`]), or
//! `path: what is wrong` for a problem of the whole file (no `v` block, no light).

use crate::error::LoadError;
use crate::limits::{MAX_SHAPES, MAX_TRIANGLES};
use crate::lines::read_text;
use crate::polygon::triangulate;
use glam::{Mat3, Quat, Vec3};
use std::fmt;
use std::path::Path;
use strahl_core::geom::solid::{Shape, SolidNode};
use strahl_core::math::transform::Transform;
use strahl_core::scene::camera::{Camera, LookAtCamera};
use strahl_core::scene::{Blend, Light, SceneDesc, Shader, TriangleDesc, MAX_IMAGE_SIDE};

/// The lightest reflection or refraction ray an NFF scene traces: POV-Ray's default
/// `adc_bailout`, 1/255, below which a ray cannot move an 8-bit channel by a whole step. SPD's
/// rules trace every ray to the depth cap; POV-Ray, which renders SPD's `.pov` files, stops here.
pub const NFF_MIN_RAY_WEIGHT: f32 = 1.0 / 255.0;

/// Reads the NFF file at `path` into a validated scene.
///
/// # Errors
/// [`LoadError::Io`] if it cannot be read; otherwise as [`parse_nff`].
pub fn load_nff(path: &Path) -> Result<SceneDesc, LoadError> {
    let text = read_text(path)?;
    parse_nff(path, &text)
}

/// Parses NFF text into a validated scene; `path` is only used in error messages.
///
/// # Errors
/// [`LoadError::At`] for the first bad word, naming its line: an unknown keyword, a number where a
/// keyword belongs, a word that is not a number or not finite, a value out of range, a primitive
/// before the first `f`, a second `v` or `b`, or a record cut short by the next keyword or the end
/// of the file (named by its keyword's line). [`LoadError::File`] for a file without `v` block or
/// light, or a scene that [`SceneDesc::validate`] rejects.
pub fn parse_nff(path: &Path, text: &str) -> Result<SceneDesc, LoadError> {
    let mut p = Parser {
        path,
        words: Words::new(text),
        previous: None,
        desc: SceneDesc::default(),
        shader: None,
        view_seen: false,
        background_seen: false,
        corners: Vec::new(),
    };
    p.run()?;
    p.finish()
}

/// The shader of an NFF material `f r g b Kd Ks Shine T ior`.
///
/// - diffuse = colour · Kd; specular = (Ks, Ks, Ks); shininess = Shine;
/// - reflection = Ks (NFF uses Ks both for highlights and as the mirror coefficient, and SPD's
///   POV-Ray files write it as `reflection`); transparency = T; ior as given (1 when T = 0, as
///   SPD writes 0 there);
/// - ambient = colour · max(0, 1 − Kd − Ks − T). NFF has no ambient term; SPD's generators pass
///   one (and a highlight coefficient apart from Ks) to their POV-Ray output but not to NFF. This
///   rule gives the `ambient` of the balls, mount, teapot and tetra `.pov` files (0.2 for the
///   sphereflake's floor, 0 elsewhere) and of shells and tree, but not of rings (0 there, 0.3
///   here), lattice's cylinders (0.1, here 0.01) or gears' floor (0, here 0.1);
/// - blend = [`Blend::Additive`]: colour = local + Ks · reflected + T · transmitted, NFF's model
///   ("it is not required that Kd + Ks == 1") and POV-Ray's, whose `reflection` adds the mirror
///   colour without dimming the rest. A mirror or refracted ray under the cut-off or past the
///   depth cap adds nothing.
pub fn shader_from_nff(colour: Vec3, kd: f32, ks: f32, shine: f32, t: f32, ior: f32) -> Shader {
    Shader {
        ambient: colour * (1.0 - kd - ks - t).max(0.0),
        diffuse: colour * kd,
        specular: Vec3::splat(ks),
        shininess: shine,
        reflection: ks,
        transparency: t,
        ior: if t > 0.0 { ior } else { 1.0 },
        blend: Blend::Additive,
    }
}

/// The transform that places the Y-axis [`Shape::Cylinder`] of height `|apex − base|`, centred on
/// the origin, so that its bottom (`y = −h/2`) lands on `base` and its top (`y = h/2`) on `apex`.
///
/// Returns `None` when `base` and `apex` coincide.
pub fn cone_transform(base: Vec3, apex: Vec3) -> Option<(Transform, f32)> {
    let axis = apex - base;
    let height = axis.length();
    let dir = axis.normalize_or_zero();
    if !(height > 0.0 && height.is_finite()) || dir == Vec3::ZERO {
        return None;
    }
    let rotation = Mat3::from_quat(Quat::from_rotation_arc(Vec3::Y, dir));
    Some((
        Transform {
            matrix: rotation,
            translation: (base + apex) * 0.5,
        },
        height,
    ))
}

/// One word of the file and the line it is on.
#[derive(Clone, Copy)]
struct Word<'a> {
    text: &'a str,
    line: usize,
}

/// The words of an NFF text in order, across lines: blank lines and comment lines (first word
/// starting with `#`) are skipped, and a byte order mark before the first word is dropped.
struct Words<'a> {
    lines: std::iter::Enumerate<std::str::Split<'a, char>>,
    /// The words left on the current line.
    current: std::str::SplitAsciiWhitespace<'a>,
    /// The current line's number, from 1.
    line: usize,
    /// A word read ahead by [`Words::peek`], handed out next.
    peeked: Option<Word<'a>>,
}

impl<'a> Words<'a> {
    fn new(text: &'a str) -> Self {
        Words {
            lines: text.split('\n').enumerate(),
            current: "".split_ascii_whitespace(),
            line: 0,
            peeked: None,
        }
    }

    /// The next word, without taking it.
    fn peek(&mut self) -> Option<Word<'a>> {
        if self.peeked.is_none() {
            self.peeked = self.read();
        }
        self.peeked
    }

    /// The next word of the file, moving on to the next meaningful line when this one is spent.
    fn read(&mut self) -> Option<Word<'a>> {
        loop {
            if let Some(text) = self.current.next() {
                return Some(Word {
                    text,
                    line: self.line,
                });
            }
            let (i, raw) = self.lines.next()?;
            let text = if i == 0 {
                raw.strip_prefix('\u{feff}').unwrap_or(raw)
            } else {
                raw
            };
            // `\r` of a CRLF line end is ASCII white space, so it never reaches a word.
            let words = text.split_ascii_whitespace();
            if !words.clone().next().is_some_and(|w| w.starts_with('#')) {
                self.current = words;
                self.line = i + 1;
            }
        }
    }
}

impl<'a> Iterator for Words<'a> {
    type Item = Word<'a>;

    fn next(&mut self) -> Option<Word<'a>> {
        self.peeked.take().or_else(|| self.read())
    }
}

/// Whether `word` starts a record (or a `v` sub-record): such a word ends the numbers before it.
fn is_keyword(word: &str) -> bool {
    matches!(
        word,
        "v" | "b"
            | "l"
            | "f"
            | "c"
            | "s"
            | "p"
            | "pp"
            | "from"
            | "at"
            | "up"
            | "angle"
            | "hither"
            | "resolution"
    )
}

fn is_number(word: &str) -> bool {
    word.parse::<f32>().is_ok()
}

/// A number read from the file and the line it is on.
#[derive(Clone, Copy, Default)]
struct Num {
    value: f32,
    line: usize,
}

struct Parser<'a> {
    path: &'a Path,
    words: Words<'a>,
    /// The keyword of the last complete record, for the message about a stray number after it.
    previous: Option<Word<'a>>,
    desc: SceneDesc,
    /// The current `f` material, an index into `desc.shaders`.
    shader: Option<u32>,
    view_seen: bool,
    background_seen: bool,
    /// Reused for each polygon's triangles (corner indices local to it).
    corners: Vec<[u32; 3]>,
}

/// "`p` vertex 2 of 4", for messages about one vertex of a polygon.
struct VertexOf<'k> {
    keyword: &'k str,
    k: u32,
    n: u32,
}

impl fmt::Display for VertexOf<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}` vertex {} of {}", self.keyword, self.k, self.n)
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

/// Reading words: records, their numbers, and the errors about them.
impl<'a> Parser<'a> {
    fn error(&self, line: usize, message: impl Into<String>) -> LoadError {
        LoadError::At {
            path: self.path.to_path_buf(),
            line,
            message: message.into(),
        }
    }

    /// The next word if it belongs to the current record (it is not a keyword); `None` at the end
    /// of the file or before the next keyword, which stays unread.
    fn value_word(&mut self) -> Option<Word<'a>> {
        match self.words.peek() {
            Some(w) if !is_keyword(w.text) => self.words.next(),
            _ => None,
        }
    }

    /// Whether the next word is a number (and so continues the current record).
    fn next_is_number(&mut self) -> bool {
        self.words.peek().is_some_and(|w| is_number(w.text))
    }

    /// The error for a record cut short: `message` on the record's keyword `line`, saying which
    /// keyword cut it (at the end of the file, `message` alone).
    fn cut_short(&mut self, line: usize, message: String) -> LoadError {
        match self.words.peek() {
            Some(next) => self.error(
                line,
                format!(
                    "{message} before the next keyword `{}` (line {})",
                    next.text, next.line
                ),
            ),
            None => self.error(line, message),
        }
    }

    /// The next `N` numbers of the record whose keyword is on `line`; `what` names the record and
    /// `fields` the expected values, for messages.
    fn numbers<const N: usize>(
        &mut self,
        line: usize,
        what: &dyn fmt::Display,
        fields: &str,
    ) -> Result<[Num; N], LoadError> {
        let mut out = [Num::default(); N];
        for (found, slot) in out.iter_mut().enumerate() {
            let Some(word) = self.value_word() else {
                let message = format!(
                    "{what}: expected {N} number{} ({fields}), found {found}",
                    plural(N)
                );
                return Err(self.cut_short(line, message));
            };
            *slot = Num {
                value: self.number(word, what)?,
                line: word.line,
            };
        }
        Ok(out)
    }

    fn number(&self, word: Word<'_>, what: &dyn fmt::Display) -> Result<f32, LoadError> {
        match word.text.parse::<f32>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.error(
                word.line,
                format!("{what}: `{}` is not a finite number", word.text),
            )),
            Err(_) => Err(self.error(
                word.line,
                format!("{what}: `{}` is not a number", word.text),
            )),
        }
    }

    /// The error for a word where a keyword belongs: a stray number or an unknown keyword.
    fn not_a_keyword(&self, word: Word<'_>) -> LoadError {
        if !is_number(word.text) {
            return self.error(
                word.line,
                format!(
                    "unknown keyword `{}`; expected v, b, l, f, c, s, p, pp or a # comment",
                    word.text
                ),
            );
        }
        let after = match self.previous {
            Some(p) => format!(" after the complete `{}` record of line {}", p.text, p.line),
            None => String::new(),
        };
        self.error(
            word.line,
            format!(
                "unexpected number `{}`{after}; expected a keyword (v, b, l, f, c, s, p, pp) or \
                 a # comment",
                word.text
            ),
        )
    }
}

/// The records.
impl<'a> Parser<'a> {
    fn run(&mut self) -> Result<(), LoadError> {
        while let Some(keyword) = self.words.next() {
            self.record(keyword)?;
            self.previous = Some(keyword);
        }
        Ok(())
    }

    /// Reads the record that `keyword` starts.
    fn record(&mut self, keyword: Word<'a>) -> Result<(), LoadError> {
        match keyword.text {
            "v" => self.view(keyword),
            "b" => self.background(keyword),
            "l" => self.light(keyword),
            "f" => self.material(keyword),
            "c" => self.cone(keyword),
            "s" => self.sphere(keyword),
            "p" => self.polygon(keyword, false),
            "pp" => self.polygon(keyword, true),
            "from" | "at" | "up" | "angle" | "hither" | "resolution" => Err(self.error(
                keyword.line,
                format!(
                    "`{}` outside a `v` block; it belongs after `v`",
                    keyword.text
                ),
            )),
            _ => Err(self.not_a_keyword(keyword)),
        }
    }

    fn background(&mut self, keyword: Word<'_>) -> Result<(), LoadError> {
        if self.background_seen {
            return Err(self.error(
                keyword.line,
                "a second `b`; the background colour is given once",
            ));
        }
        self.background_seen = true;
        let [r, g, b] = self.numbers::<3>(keyword.line, &"`b`", "r g b")?;
        self.desc.settings.background = Vec3::new(r.value, g.value, b.value);
        Ok(())
    }

    /// The next word of the `v` block, which must be the sub-keyword `expected`.
    fn view_keyword(&mut self, block: Word<'_>, expected: &str) -> Result<Word<'a>, LoadError> {
        let Some(word) = self.words.next() else {
            return Err(self.error(
                block.line,
                format!("the file ends inside the `v` block; expected `{expected}`"),
            ));
        };
        if word.text != expected {
            return Err(self.error(
                word.line,
                format!(
                    "expected `{expected}` (the `v` block is v, from, at, up, angle, hither, \
                     resolution, in this order), found `{}`",
                    word.text
                ),
            ));
        }
        Ok(word)
    }

    /// The `v` block's next sub-record: `keyword` and `N` numbers; also the keyword's line.
    fn view_numbers<const N: usize>(
        &mut self,
        block: Word<'_>,
        keyword: &str,
        fields: &str,
    ) -> Result<([Num; N], usize), LoadError> {
        let sub = self.view_keyword(block, keyword)?;
        let v = self.numbers::<N>(sub.line, &format!("`{keyword}`"), fields)?;
        Ok((v, sub.line))
    }

    /// The `v` block's `from x y z`, `at x y z` and `up x y z`: a camera that can look somewhere.
    fn view_axes(&mut self, block: Word<'_>) -> Result<[Vec3; 3], LoadError> {
        let point = |[x, y, z]: [Num; 3]| Vec3::new(x.value, y.value, z.value);
        let (from, _) = self.view_numbers::<3>(block, "from", "x y z")?;
        let (at, at_line) = self.view_numbers::<3>(block, "at", "x y z")?;
        let (up, up_line) = self.view_numbers::<3>(block, "up", "x y z")?;
        let (from, at, up) = (point(from), point(at), point(up));
        if from == at {
            return Err(self.error(
                at_line,
                "`at`: the camera looks at its own position; `at` must differ from `from`",
            ));
        }
        if !(at - from).is_finite() {
            return Err(self.error(
                at_line,
                "`at`: the distance from `from` is beyond single precision (about 3.4e38)",
            ));
        }
        if (at - from).cross(up).normalize_or_zero() == Vec3::ZERO {
            return Err(self.error(
                up_line,
                "`up`: parallel to the view direction (or zero); it must point across the view",
            ));
        }
        Ok([from, at, up])
    }

    fn view(&mut self, block: Word<'_>) -> Result<(), LoadError> {
        if self.view_seen {
            return Err(self.error(
                block.line,
                "a second `v` block; the viewpoint is given once",
            ));
        }
        self.view_seen = true;
        let [from, at, up] = self.view_axes(block)?;
        let ([angle], _) = self.view_numbers::<1>(block, "angle", "degrees")?;
        if !(angle.value > 0.0 && angle.value < 180.0) {
            return Err(self.error(
                angle.line,
                format!(
                    "`angle` must be above 0 and below 180 degrees, found {}",
                    angle.value
                ),
            ));
        }
        // Read for the format's sake; Strahl has no near clipping plane.
        let _hither = self.view_numbers::<1>(block, "hither", "distance")?;
        let sub = self.view_keyword(block, "resolution")?;
        let [width, height] = [self.image_side(sub.line, 0)?, self.image_side(sub.line, 1)?];
        self.desc.camera = Camera::LookAt(LookAtCamera {
            position: from,
            look_at: at,
            up,
            vfov_deg: angle.value,
        });
        self.desc.settings.width = width;
        self.desc.settings.height = height;
        Ok(())
    }

    /// Number `found` (0 or 1) of `resolution` (on `line`): a whole number from 1 to the limit.
    fn image_side(&mut self, line: usize, found: usize) -> Result<u32, LoadError> {
        let Some(word) = self.value_word() else {
            let message = format!("`resolution`: expected 2 numbers (width height), found {found}");
            return Err(self.cut_short(line, message));
        };
        match word.text.parse::<u32>() {
            Ok(v) if (1..=MAX_IMAGE_SIDE).contains(&v) => Ok(v),
            _ => Err(self.error(
                word.line,
                format!(
                    "`resolution`: `{}` is not an image side; expected a whole number from 1 to \
                     {MAX_IMAGE_SIDE}",
                    word.text
                ),
            )),
        }
    }

    /// `l x y z [r g b]`: the colour is read when a number follows the position.
    fn light(&mut self, keyword: Word<'_>) -> Result<(), LoadError> {
        let mut v = [1.0f32; 6];
        for (found, slot) in v.iter_mut().enumerate() {
            if found == 3 && !self.next_is_number() {
                break;
            }
            *slot = self.light_number(keyword, found)?;
        }
        self.desc.lights.push(Light {
            position: Vec3::new(v[0], v[1], v[2]),
            color: Vec3::new(v[3], v[4], v[5]),
            amount: 1.0, // set once all lights are known
            casts_shadows: true,
        });
        Ok(())
    }

    /// The next number of the `l` record, `found` numbers having been read.
    fn light_number(&mut self, keyword: Word<'_>, found: usize) -> Result<f32, LoadError> {
        match self.value_word() {
            Some(word) => self.number(word, &"`l`"),
            None => {
                let message =
                    format!("`l`: expected 3 numbers (x y z) or 6 (x y z r g b), found {found}");
                Err(self.cut_short(keyword.line, message))
            }
        }
    }

    fn material(&mut self, keyword: Word<'_>) -> Result<(), LoadError> {
        let values = self.numbers::<8>(keyword.line, &"`f`", "r g b Kd Ks Shine T ior")?;
        self.check_material(&values)?;
        let [r, g, b, kd, ks, shine, t, ior] = values.map(|n| n.value);
        let index = u32::try_from(self.desc.shaders.len())
            .map_err(|_| self.error(keyword.line, "`f`: too many materials"))?;
        let shader = shader_from_nff(Vec3::new(r, g, b), kd, ks, shine, t, ior);
        if !shader.is_finite() {
            return Err(self.error(
                keyword.line,
                "`f`: the colour times Kd is beyond single precision (about 3.4e38)",
            ));
        }
        self.desc.shaders.push(shader);
        self.shader = Some(index);
        Ok(())
    }

    /// The ranges of `f`'s values; an error names the line of the value (of T for Ks + T).
    fn check_material(&self, values: &[Num; 8]) -> Result<(), LoadError> {
        let [_, _, _, kd, ks, shine, t, ior] = *values;
        let fail = |n: Num, message: String| Err(self.error(n.line, format!("`f`: {message}")));
        let range = |what: &str, n: Num| {
            if (0.0..=1.0).contains(&n.value) {
                Ok(())
            } else {
                fail(n, format!("{what} must be 0 to 1, found {}", n.value))
            }
        };
        range("Ks (the reflection coefficient)", ks)?;
        range("T (the transmittance)", t)?;
        if kd.value < 0.0 {
            return fail(kd, format!("Kd must be 0 or more, found {}", kd.value));
        }
        if shine.value < 0.0 {
            return fail(
                shine,
                format!("Shine must be 0 or more, found {}", shine.value),
            );
        }
        if ks.value + t.value > 1.0 {
            return fail(
                t,
                format!(
                    "Ks + T must be at most 1 (reflected and transmitted shares), found {}",
                    ks.value + t.value
                ),
            );
        }
        if t.value > 0.0 && ior.value <= 0.0 {
            return fail(
                ior,
                format!(
                    "ior must be above 0 for a transparent material, found {}",
                    ior.value
                ),
            );
        }
        Ok(())
    }

    fn current_shader(&self, keyword: Word<'_>) -> Result<u32, LoadError> {
        self.shader.ok_or_else(|| {
            self.error(
                keyword.line,
                format!(
                    "`{}` before the first `f`; a primitive takes the material of the last `f` \
                     above it",
                    keyword.text
                ),
            )
        })
    }

    fn add_solid(&mut self, line: usize, node: SolidNode) -> Result<(), LoadError> {
        if self.desc.solids.len() as u64 >= MAX_SHAPES {
            return Err(self.error(
                line,
                format!("more than {MAX_SHAPES} spheres, cones and other solids"),
            ));
        }
        let index = u32::try_from(self.desc.solids.len())
            .map_err(|_| self.error(line, "too many primitives"))?;
        self.desc.solids.push(node);
        self.desc.objects.push(index);
        Ok(())
    }

    fn sphere(&mut self, keyword: Word<'_>) -> Result<(), LoadError> {
        let shader = self.current_shader(keyword)?;
        let [x, y, z, radius] = self.numbers::<4>(keyword.line, &"`s`", "x y z radius")?;
        if radius.value <= 0.0 {
            return Err(self.error(
                radius.line,
                format!("`s`: the radius must be above 0, found {}", radius.value),
            ));
        }
        self.add_solid(
            keyword.line,
            SolidNode::Leaf {
                shape: Shape::Sphere {
                    radius: radius.value,
                },
                transform: Transform::translate(Vec3::new(x.value, y.value, z.value)),
                shader,
            },
        )
    }

    /// `c bx by bz br ax ay az ar`, on one line or over several.
    fn cone(&mut self, keyword: Word<'_>) -> Result<(), LoadError> {
        let shader = self.current_shader(keyword)?;
        let values =
            self.numbers::<8>(keyword.line, &"`c`", "base x y z radius, apex x y z radius")?;
        let [bx, by, bz, br, ax, ay, az, ar] = values;
        let (bottom_radius, top_radius) = self.cone_radii(br, ar)?;
        let base = Vec3::new(bx.value, by.value, bz.value);
        let apex = Vec3::new(ax.value, ay.value, az.value);
        let Some((transform, height)) = cone_transform(base, apex) else {
            let why = if base == apex {
                "`c`: the apex is the base point; they must differ"
            } else {
                "`c`: the distance from the base to the apex is beyond single precision (about \
                 3.4e38)"
            };
            return Err(self.error(ax.line, why));
        };
        self.add_solid(
            keyword.line,
            SolidNode::Leaf {
                shape: Shape::Cylinder {
                    bottom_radius,
                    top_radius,
                    height,
                },
                transform,
                shader,
            },
        )
    }

    /// The base and apex radii of a cone: both 0 or more, or both negative (NFF: shows the
    /// inside; Strahl's solids have both sides anyway), and not both 0.
    fn cone_radii(&self, base: Num, apex: Num) -> Result<(f32, f32), LoadError> {
        let (b, a) = (base.value, apex.value);
        if (b < 0.0) != (a < 0.0) {
            return Err(self.error(
                if b < 0.0 { base.line } else { apex.line },
                "`c`: a negative radius needs the other one negative too (both negative shows \
                 the inside)",
            ));
        }
        if b == 0.0 && a == 0.0 {
            return Err(self.error(
                apex.line,
                "`c`: the base and apex radii are both 0; at least one must be above 0",
            ));
        }
        Ok((b.abs(), a.abs()))
    }

    /// `p n` followed by `n` vertices `x y z`, or `pp n` by `n` vertices `x y z nx ny nz`
    /// (`with_normals`), the numbers on any lines.
    fn polygon(&mut self, keyword: Word<'_>, with_normals: bool) -> Result<(), LoadError> {
        let shader = self.current_shader(keyword)?;
        let n = self.vertex_count(keyword)?;
        let first_point = self.desc.points.len();
        let first_normal = self.desc.normals.len();
        for k in 1..=n {
            // Messages are only formatted on error: no allocation per vertex.
            let what = VertexOf {
                keyword: keyword.text,
                k,
                n,
            };
            if with_normals {
                self.vertex_with_normal(keyword.line, &what)?;
            } else {
                let [x, y, z] = self.numbers::<3>(keyword.line, &what, "x y z")?;
                self.desc.points.push(Vec3::new(x.value, y.value, z.value));
            }
        }
        let (Ok(p0), Ok(n0), Ok(_)) = (
            u32::try_from(first_point),
            u32::try_from(first_normal),
            u32::try_from(self.desc.points.len()),
        ) else {
            return Err(self.error(
                keyword.line,
                format!("`{}`: too many vertices", keyword.text),
            ));
        };
        if self.desc.triangles.len() as u64 + u64::from(n) > MAX_TRIANGLES {
            return Err(self.error(
                keyword.line,
                format!("more than {MAX_TRIANGLES} triangles (polygons count n − 2 each)"),
            ));
        }
        self.triangles_of(n, p0, with_normals.then_some(n0), shader);
        Ok(())
    }

    /// One vertex `x y z nx ny nz` of a `pp` patch (whose keyword is on `line`).
    fn vertex_with_normal(&mut self, line: usize, what: &VertexOf<'_>) -> Result<(), LoadError> {
        let values = self.numbers::<6>(line, what, "x y z nx ny nz")?;
        let [x, y, z, nx, ny, nz] = values.map(|n| n.value);
        let normal = Vec3::new(nx, ny, nz);
        if normal.length_squared() == 0.0 {
            return Err(self.error(
                values[3].line,
                format!("{what}: the normal ({nx} {ny} {nz}) has zero length"),
            ));
        }
        self.desc.points.push(Vec3::new(x, y, z));
        self.desc.normals.push(normal);
        Ok(())
    }

    /// The `n − 2` triangles of the polygon whose `n` points start at `p0` (and its normals, if
    /// any, at `n0`): a fan around corner 0 where it covers the polygon once, else cut by ear
    /// clipping ([`triangulate`]).
    fn triangles_of(&mut self, n: u32, p0: u32, n0: Option<u32>, shader: u32) {
        let points = &self.desc.points[p0 as usize..(p0 + n) as usize];
        let mut corners = std::mem::take(&mut self.corners);
        corners.clear();
        triangulate(points, &mut corners);
        for &local in &corners {
            self.desc.triangles.push(TriangleDesc {
                points: local.map(|c| p0 + c),
                shader,
                normals: n0.map(|n0| local.map(|c| n0 + c)),
            });
        }
        self.corners = corners;
    }

    /// The vertex count after `p` or `pp`: a whole number, 3 or more.
    fn vertex_count(&mut self, keyword: Word<'_>) -> Result<u32, LoadError> {
        let name = keyword.text;
        let Some(word) = self.value_word() else {
            let message = format!("`{name}`: expected the number of vertices after `{name}`");
            return Err(self.cut_short(keyword.line, message));
        };
        match word.text.parse::<u32>() {
            Ok(n) if n >= 3 => Ok(n),
            Ok(n) => Err(self.error(
                word.line,
                format!("`{name}`: a polygon needs at least 3 vertices, found {n}"),
            )),
            Err(_) => Err(self.error(
                word.line,
                format!(
                    "`{name}`: `{}` is not a number of vertices (a whole number, 3 or more)",
                    word.text
                ),
            )),
        }
    }

    fn finish(mut self) -> Result<SceneDesc, LoadError> {
        let file_error = |message: String| LoadError::File {
            path: self.path.to_path_buf(),
            message,
        };
        if !self.view_seen {
            return Err(file_error(
                "no viewpoint in the file; a `v` block (from, at, up, angle, hither, \
                 resolution) is required"
                    .to_string(),
            ));
        }
        if self.desc.lights.is_empty() {
            return Err(file_error(
                "no light (`l`) in the file; at least one is required".to_string(),
            ));
        }
        self.desc.settings.min_reflection_weight = NFF_MIN_RAY_WEIGHT;
        // As SPD's POV-Ray files: n lights of 1/√n each keep the total brightness.
        let amount = 1.0 / (self.desc.lights.len() as f32).sqrt();
        for l in &mut self.desc.lights {
            l.amount = amount;
        }
        self.desc
            .validate()
            .map_err(|e| file_error(e.to_string()))?;
        Ok(self.desc)
    }
}
