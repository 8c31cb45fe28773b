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
//! | `c` + two lines `x y z r` | a cone frustum [`Shape::Cylinder`] from base to apex, **capped** (NFF's is open) |
//! | `s x y z r` | a [`Shape::Sphere`] |
//! | `p n` + `n` lines `x y z` | a convex polygon, split into a fan of `n − 2` triangles (flat: its points are its own) |
//! | `pp n` + `n` lines `x y z nx ny nz` | the same with a shading normal at each corner |
//! | `#` | a comment line |
//!
//! NFF's material model is additive (NFF.TXT: "it is not required that Kd + Ks == 1"): a
//! surface's colour is its local colour plus Ks times the reflected colour plus T times the
//! transmitted colour ([`Blend::Additive`]), as POV-Ray renders SPD's `.pov` files. The seed's
//! formats keep the seed's rule, which scales the local colour down by `1 − Ks − T`.
//!
//! Render settings other than the image size and background keep Strahl's defaults (SPD's own
//! rules trace at most 5 bounces without a weight cut-off; `--max-depth 5` comes closer).
//!
//! Every error is `path:line: what is wrong, what was expected` ([`LoadError::At`]), or
//! `path: what is wrong` for a problem of the whole file (no `v` block, no light).

use crate::error::LoadError;
use crate::lines::read_text;
use glam::{Mat3, Quat, Vec3};
use std::fmt;
use std::path::Path;
use strahl_core::geom::solid::{Shape, SolidNode};
use strahl_core::math::transform::Transform;
use strahl_core::scene::camera::{Camera, LookAtCamera};
use strahl_core::scene::{Blend, Light, SceneDesc, Shader, TriangleDesc, MAX_IMAGE_SIDE};

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
/// [`LoadError::At`] for the first bad line: an unknown keyword, a wrong count of numbers, a
/// number that is not one or not finite, a value out of range, a primitive before the first `f`,
/// a second `v` or `b`, or a block (`v`, `c`, `p`, `pp`) cut short. [`LoadError::File`] for a
/// file without `v` block or light, or a scene that [`SceneDesc::validate`] rejects.
pub fn parse_nff(path: &Path, text: &str) -> Result<SceneDesc, LoadError> {
    let mut p = Parser {
        path,
        lines: text.split('\n').enumerate(),
        desc: SceneDesc::default(),
        shader: None,
        view_seen: false,
        background_seen: false,
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
///   one to their POV-Ray output but not to NFF, and this rule gives the `ambient` of every SPD
///   `.pov` file (0.2 for the sphereflake's floor, 0 elsewhere);
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

type NumberedLines<'a> = std::iter::Enumerate<std::str::Split<'a, char>>;

struct Parser<'a> {
    path: &'a Path,
    lines: NumberedLines<'a>,
    desc: SceneDesc,
    /// The current `f` material, an index into `desc.shaders`.
    shader: Option<u32>,
    view_seen: bool,
    background_seen: bool,
}

/// One meaningful line: its number and text.
#[derive(Clone, Copy)]
struct Ln<'a> {
    number: usize,
    text: &'a str,
}

/// "`p` vertex 2 of 4", for messages about one vertex line of a polygon.
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

/// "4 vertex lines of 3 numbers, found 2", for a polygon cut short by the end of the file.
struct VertexLines<'e> {
    n: u32,
    expected: &'e str,
    found: u32,
}

impl fmt::Display for VertexLines<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} vertex lines of {}, found {}",
            self.n, self.expected, self.found
        )
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

impl<'a> Parser<'a> {
    fn error(&self, line: usize, message: impl Into<String>) -> LoadError {
        LoadError::At {
            path: self.path.to_path_buf(),
            line,
            message: message.into(),
        }
    }

    /// The next line that is neither blank nor a `#` comment.
    fn next_line(&mut self) -> Option<Ln<'a>> {
        for (i, raw) in self.lines.by_ref() {
            let text = raw.strip_suffix('\r').unwrap_or(raw);
            let text = if i == 0 {
                text.strip_prefix('\u{feff}').unwrap_or(text)
            } else {
                text
            };
            match text.split_ascii_whitespace().next() {
                None => continue,
                Some(w) if w.starts_with('#') => continue,
                Some(_) => {
                    return Some(Ln {
                        number: i + 1,
                        text,
                    })
                }
            }
        }
        None
    }

    /// Parses exactly `N` finite numbers from `words`; `what` names the statement and `fields`
    /// the expected values, for messages.
    fn numbers<const N: usize>(
        &self,
        line: usize,
        mut words: std::str::SplitAsciiWhitespace<'_>,
        what: &dyn fmt::Display,
        fields: &str,
    ) -> Result<[f32; N], LoadError> {
        let mut out = [0.0f32; N];
        let mut n = 0;
        for w in words.by_ref() {
            if n == N {
                n += 1 + words.count();
                break;
            }
            out[n] = self.number(line, w, what)?;
            n += 1;
        }
        if n != N {
            return Err(self.error(
                line,
                format!(
                    "{what}: expected {N} number{} ({fields}), found {n}",
                    plural(N)
                ),
            ));
        }
        Ok(out)
    }

    fn number(&self, line: usize, word: &str, what: &dyn fmt::Display) -> Result<f32, LoadError> {
        match word.parse::<f32>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.error(line, format!("{what}: `{word}` is not a finite number"))),
            Err(_) => Err(self.error(line, format!("{what}: `{word}` is not a number"))),
        }
    }

    fn run(&mut self) -> Result<(), LoadError> {
        while let Some(ln) = self.next_line() {
            let mut words = ln.text.split_ascii_whitespace();
            let keyword = words.next().unwrap_or("");
            match keyword {
                "v" => self.view(ln, words)?,
                "b" => {
                    if self.background_seen {
                        return Err(self.error(
                            ln.number,
                            "a second `b`; the background colour is given once",
                        ));
                    }
                    self.background_seen = true;
                    let c = self.numbers::<3>(ln.number, words, &"`b`", "r g b")?;
                    self.desc.settings.background = Vec3::from_array(c);
                }
                "l" => self.light(ln, words)?,
                "f" => self.material(ln, words)?,
                "c" => self.cone(ln, words)?,
                "s" => self.sphere(ln, words)?,
                "p" => self.polygon(ln, words, false)?,
                "pp" => self.polygon(ln, words, true)?,
                "from" | "at" | "up" | "angle" | "hither" | "resolution" => {
                    return Err(self.error(
                        ln.number,
                        format!("`{keyword}` outside a `v` block; it belongs after `v`"),
                    ))
                }
                _ => {
                    return Err(self.error(
                        ln.number,
                        format!(
                            "unknown keyword `{keyword}`; expected v, b, l, f, c, s, p, pp or a \
                             # comment"
                        ),
                    ))
                }
            }
        }
        Ok(())
    }

    fn expect_no_values(
        &self,
        ln: Ln<'_>,
        mut words: std::str::SplitAsciiWhitespace<'_>,
        keyword: &str,
        lines: &str,
    ) -> Result<(), LoadError> {
        match words.next() {
            None => Ok(()),
            Some(w) => Err(self.error(
                ln.number,
                format!("`{keyword}` stands alone on its line ({lines} follow it), found `{w}`"),
            )),
        }
    }

    /// The next line of a block, whose first word must be `keyword`.
    fn block_line(&mut self, block: Ln<'_>, keyword: &str) -> Result<Ln<'a>, LoadError> {
        let Some(ln) = self.next_line() else {
            return Err(self.error(
                block.number,
                format!("the file ends inside the `v` block; expected the `{keyword}` line"),
            ));
        };
        let first = ln.text.split_ascii_whitespace().next().unwrap_or("");
        if first != keyword {
            return Err(self.error(
                ln.number,
                format!(
                    "expected `{keyword}` (the `v` block is v, from, at, up, angle, hither, \
                     resolution, one per line, in this order), found `{first}`"
                ),
            ));
        }
        Ok(ln)
    }

    /// The next line of the `v` block, `keyword` and `N` numbers, with its line number.
    fn view_numbers<const N: usize>(
        &mut self,
        block: Ln<'_>,
        keyword: &str,
        fields: &str,
    ) -> Result<([f32; N], usize), LoadError> {
        let l = self.block_line(block, keyword)?;
        let mut w = l.text.split_ascii_whitespace();
        w.next();
        let v = self.numbers::<N>(l.number, w, &format!("`{keyword}`"), fields)?;
        Ok((v, l.number))
    }

    fn view(
        &mut self,
        ln: Ln<'_>,
        words: std::str::SplitAsciiWhitespace<'_>,
    ) -> Result<(), LoadError> {
        if self.view_seen {
            return Err(self.error(ln.number, "a second `v` block; the viewpoint is given once"));
        }
        self.view_seen = true;
        self.expect_no_values(ln, words, "v", "from, at, up, angle, hither and resolution")?;
        let (from, _) = self.view_numbers::<3>(ln, "from", "x y z")?;
        let (at, at_line) = self.view_numbers::<3>(ln, "at", "x y z")?;
        let (up, up_line) = self.view_numbers::<3>(ln, "up", "x y z")?;
        let (from, at, up) = (
            Vec3::from_array(from),
            Vec3::from_array(at),
            Vec3::from_array(up),
        );
        if from == at {
            return Err(self.error(
                at_line,
                "`at`: the camera looks at its own position; `at` must differ from `from`",
            ));
        }
        if (at - from).cross(up).normalize_or_zero() == Vec3::ZERO {
            return Err(self.error(
                up_line,
                "`up`: parallel to the view direction (or zero); it must point across the view",
            ));
        }
        let ([angle], angle_line) = self.view_numbers::<1>(ln, "angle", "degrees")?;
        if !(angle > 0.0 && angle < 180.0) {
            return Err(self.error(
                angle_line,
                format!("`angle` must be above 0 and below 180 degrees, found {angle}"),
            ));
        }
        // Read for the format's sake; Strahl has no near clipping plane.
        let _hither = self.view_numbers::<1>(ln, "hither", "distance")?;
        let l = self.block_line(ln, "resolution")?;
        let mut w = l.text.split_ascii_whitespace();
        w.next();
        let (width, height) = self.resolution(l.number, w)?;
        self.desc.camera = Camera::LookAt(LookAtCamera {
            position: from,
            look_at: at,
            up,
            vfov_deg: angle,
        });
        self.desc.settings.width = width;
        self.desc.settings.height = height;
        Ok(())
    }

    fn resolution(
        &self,
        line: usize,
        words: std::str::SplitAsciiWhitespace<'_>,
    ) -> Result<(u32, u32), LoadError> {
        let mut out = [0u32; 2];
        let mut n = 0;
        for w in words {
            if n < 2 {
                out[n] = match w.parse::<u32>() {
                    Ok(v) if (1..=MAX_IMAGE_SIDE).contains(&v) => v,
                    _ => {
                        return Err(self.error(
                            line,
                            format!(
                                "`resolution`: `{w}` is not an image side; expected a whole \
                                 number from 1 to {MAX_IMAGE_SIDE}"
                            ),
                        ))
                    }
                };
            }
            n += 1;
        }
        if n != 2 {
            return Err(self.error(
                line,
                format!("`resolution`: expected 2 numbers (width height), found {n}"),
            ));
        }
        Ok((out[0], out[1]))
    }

    fn light(
        &mut self,
        ln: Ln<'_>,
        mut words: std::str::SplitAsciiWhitespace<'_>,
    ) -> Result<(), LoadError> {
        let mut v = [1.0f32; 6];
        let mut n = 0;
        for w in words.by_ref() {
            if n < 6 {
                v[n] = self.number(ln.number, w, &"`l`")?;
            }
            n += 1;
        }
        if n != 3 && n != 6 {
            return Err(self.error(
                ln.number,
                format!("`l`: expected 3 numbers (x y z) or 6 (x y z r g b), found {n}"),
            ));
        }
        self.desc.lights.push(Light {
            position: Vec3::new(v[0], v[1], v[2]),
            color: Vec3::new(v[3], v[4], v[5]),
            amount: 1.0, // set once all lights are known
            casts_shadows: true,
        });
        Ok(())
    }

    fn material(
        &mut self,
        ln: Ln<'_>,
        words: std::str::SplitAsciiWhitespace<'_>,
    ) -> Result<(), LoadError> {
        let [r, g, b, kd, ks, shine, t, ior] =
            self.numbers::<8>(ln.number, words, &"`f`", "r g b Kd Ks Shine T ior")?;
        let range = |what: &str, v: f32, lo: f32, hi: f32| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(self.error(
                    ln.number,
                    format!("`f`: {what} must be {lo} to {hi}, found {v}"),
                ))
            }
        };
        range("Ks (the reflection coefficient)", ks, 0.0, 1.0)?;
        range("T (the transmittance)", t, 0.0, 1.0)?;
        if kd < 0.0 {
            return Err(self.error(ln.number, format!("`f`: Kd must be 0 or more, found {kd}")));
        }
        if shine < 0.0 {
            return Err(self.error(
                ln.number,
                format!("`f`: Shine must be 0 or more, found {shine}"),
            ));
        }
        if ks + t > 1.0 {
            return Err(self.error(
                ln.number,
                format!(
                    "`f`: Ks + T must be at most 1 (reflected and transmitted shares), found {}",
                    ks + t
                ),
            ));
        }
        if t > 0.0 && ior <= 0.0 {
            return Err(self.error(
                ln.number,
                format!("`f`: ior must be above 0 for a transparent material, found {ior}"),
            ));
        }
        let index = u32::try_from(self.desc.shaders.len())
            .map_err(|_| self.error(ln.number, "`f`: too many materials"))?;
        self.desc
            .shaders
            .push(shader_from_nff(Vec3::new(r, g, b), kd, ks, shine, t, ior));
        self.shader = Some(index);
        Ok(())
    }

    fn current_shader(&self, line: usize, keyword: &str) -> Result<u32, LoadError> {
        self.shader.ok_or_else(|| {
            self.error(
                line,
                format!(
                    "`{keyword}` before the first `f`; a primitive takes the material of the \
                     last `f` above it"
                ),
            )
        })
    }

    fn add_solid(&mut self, line: usize, node: SolidNode) -> Result<(), LoadError> {
        let index = u32::try_from(self.desc.solids.len())
            .map_err(|_| self.error(line, "too many primitives"))?;
        self.desc.solids.push(node);
        self.desc.objects.push(index);
        Ok(())
    }

    fn sphere(
        &mut self,
        ln: Ln<'_>,
        words: std::str::SplitAsciiWhitespace<'_>,
    ) -> Result<(), LoadError> {
        let shader = self.current_shader(ln.number, "s")?;
        let [x, y, z, radius] = self.numbers::<4>(ln.number, words, &"`s`", "x y z radius")?;
        if radius <= 0.0 {
            return Err(self.error(
                ln.number,
                format!("`s`: the radius must be above 0, found {radius}"),
            ));
        }
        self.add_solid(
            ln.number,
            SolidNode::Leaf {
                shape: Shape::Sphere { radius },
                transform: Transform::translate(Vec3::new(x, y, z)),
                shader,
            },
        )
    }

    /// The line after a block's first line (`c`, `p`, `pp`), or an error naming the block.
    fn member_line(&mut self, block: Ln<'_>, what: &dyn fmt::Display) -> Result<Ln<'a>, LoadError> {
        self.next_line().ok_or_else(|| {
            self.error(
                block.number,
                format!("the file ends inside this block; expected {what}"),
            )
        })
    }

    fn cone(
        &mut self,
        ln: Ln<'_>,
        words: std::str::SplitAsciiWhitespace<'_>,
    ) -> Result<(), LoadError> {
        let shader = self.current_shader(ln.number, "c")?;
        self.expect_no_values(ln, words, "c", "the base and apex lines")?;
        let base_ln = self.member_line(ln, &"the base line `x y z radius`")?;
        let [bx, by, bz, br] = self.numbers::<4>(
            base_ln.number,
            base_ln.text.split_ascii_whitespace(),
            &"`c` base",
            "x y z radius",
        )?;
        let apex_ln = self.member_line(ln, &"the apex line `x y z radius`")?;
        let [ax, ay, az, ar] = self.numbers::<4>(
            apex_ln.number,
            apex_ln.text.split_ascii_whitespace(),
            &"`c` apex",
            "x y z radius",
        )?;
        // NFF: both radii negative shows the inside; Strahl's solids have both sides anyway.
        let (br, ar) = if br < 0.0 && ar < 0.0 {
            (-br, -ar)
        } else if br < 0.0 || ar < 0.0 {
            return Err(self.error(
                if br < 0.0 {
                    base_ln.number
                } else {
                    apex_ln.number
                },
                "`c`: a negative radius needs the other one negative too (both negative shows \
                 the inside)",
            ));
        } else {
            (br, ar)
        };
        if br == 0.0 && ar == 0.0 {
            return Err(self.error(
                apex_ln.number,
                "`c`: the base and apex radii are both 0; at least one must be above 0",
            ));
        }
        let (base, apex) = (Vec3::new(bx, by, bz), Vec3::new(ax, ay, az));
        let Some((transform, height)) = cone_transform(base, apex) else {
            return Err(self.error(
                apex_ln.number,
                "`c`: the apex is the base point; they must differ",
            ));
        };
        self.add_solid(
            ln.number,
            SolidNode::Leaf {
                shape: Shape::Cylinder {
                    bottom_radius: br,
                    top_radius: ar,
                    height,
                },
                transform,
                shader,
            },
        )
    }

    fn polygon(
        &mut self,
        ln: Ln<'_>,
        mut words: std::str::SplitAsciiWhitespace<'_>,
        with_normals: bool,
    ) -> Result<(), LoadError> {
        let keyword = if with_normals { "pp" } else { "p" };
        let shader = self.current_shader(ln.number, keyword)?;
        let n = self.vertex_count(ln.number, keyword, &mut words)?;
        let (fields, expected) = if with_normals {
            ("x y z nx ny nz", "6 numbers")
        } else {
            ("x y z", "3 numbers")
        };
        let first_point = self.desc.points.len();
        let first_normal = self.desc.normals.len();
        for k in 1..=n {
            // Messages are only formatted on error: no allocation per vertex.
            let v = self.member_line(
                ln,
                &VertexLines {
                    n,
                    expected,
                    found: k - 1,
                },
            )?;
            let what = VertexOf { keyword, k, n };
            let words = v.text.split_ascii_whitespace();
            if with_normals {
                let [x, y, z, nx, ny, nz] = self.numbers::<6>(v.number, words, &what, fields)?;
                let normal = Vec3::new(nx, ny, nz);
                if normal.length_squared() == 0.0 {
                    return Err(self.error(
                        v.number,
                        format!("{what}: the normal ({nx} {ny} {nz}) has zero length"),
                    ));
                }
                self.desc.points.push(Vec3::new(x, y, z));
                self.desc.normals.push(normal);
            } else {
                let p = self.numbers::<3>(v.number, words, &what, fields)?;
                self.desc.points.push(Vec3::from_array(p));
            }
        }
        let (Ok(p0), Ok(n0), Ok(_)) = (
            u32::try_from(first_point),
            u32::try_from(first_normal),
            u32::try_from(self.desc.points.len()),
        ) else {
            return Err(self.error(ln.number, format!("`{keyword}`: too many vertices")));
        };
        for k in 1..n - 1 {
            let corners = [0, k, k + 1];
            self.desc.triangles.push(TriangleDesc {
                points: corners.map(|c| p0 + c),
                shader,
                normals: with_normals.then(|| corners.map(|c| n0 + c)),
            });
        }
        Ok(())
    }

    /// The vertex count after `p` or `pp` (`keyword`) on line `line`: a whole number, 3 or
    /// more, alone on the line.
    fn vertex_count(
        &self,
        line: usize,
        keyword: &str,
        words: &mut std::str::SplitAsciiWhitespace<'_>,
    ) -> Result<u32, LoadError> {
        let count_word = words.next();
        let extra = words.next();
        match (count_word.map(str::parse::<u32>), extra) {
            (Some(Ok(n)), None) if n >= 3 => Ok(n),
            (Some(Ok(n)), None) => Err(self.error(
                line,
                format!("`{keyword}`: a polygon needs at least 3 vertices, found {n}"),
            )),
            (None, _) => Err(self.error(
                line,
                format!("`{keyword}`: expected the number of vertices after `{keyword}`"),
            )),
            (Some(_), Some(w)) => Err(self.error(
                line,
                format!(
                    "`{keyword}`: expected only the number of vertices, found `{w}` after \
                         it (vertices go on the following lines)"
                ),
            )),
            (Some(Err(_)), None) => Err(self.error(
                line,
                format!(
                    "`{keyword}`: `{}` is not a number of vertices (a whole number, 3 or \
                         more)",
                    count_word.unwrap_or("")
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
