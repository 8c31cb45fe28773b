//! Wavefront OBJ meshes (`.obj`) and their materials (`.mtl`).
//!
//! [`read_obj`] reads the geometry of a file: every `v` (position), every `vn` (normal) and every
//! `f` (face), with all objects and groups of the file merged into one [`ObjMesh`]. Faces with
//! more than three corners are split into triangles ([`triangulate`]): a fan around their first
//! corner where that covers the face once (every convex face), else by ear clipping.
//! [`read_obj_file`] also reads the materials of the `mtllib` files and records which material
//! (`usemtl`) each triangle has.
//!
//! The rules:
//!
//! - Lines are split into words at ASCII white space; a line whose first word starts with `#` is
//!   a comment, and on `v`, `vn` and `f` lines a word starting with `#` ends the line.
//! - `v x y z` takes 3 numbers, optionally a 4th (`w`, which divides the others) or 3 more (a
//!   vertex colour, ignored). `vn x y z` takes exactly 3 numbers and must not be zero.
//! - `f` takes at least 3 corners `v`, `v/vt`, `v//vn` or `v/vt/vn`. Indices count from 1;
//!   negative indices count back from the last element defined so far (`-1` is the last one).
//!   An index must name an element defined above the face. Either every corner of a face has a
//!   normal or none has: a corner without one would need a made-up normal.
//! - Texture coordinates (`vt`), points (`p`), lines (`l`), free-form geometry, `o`, `g`, `s`
//!   and every other statement are ignored.
//! - Numbers are Rust `f32` literals and must be finite: `nan`, `inf` or `1e39` are errors.
//!
//! Every error names the file and, for a bad line, the line: `mesh.obj:12: `f`: vertex index 9
//! out of range (8 vertices defined so far)`.
//!
//! Why not the `tobj` crate: tobj 4.0.5 makes up a normal (the previous corner's,
//! or the file's first) for face corners without one, reports no line numbers nor which index is
//! wrong, and panics on an `.mtl` colour with fewer than three values (`Kd 0.5`). The format is
//! small enough to read here with exact messages.

use crate::error::LoadError;
use crate::limits::MAX_TRIANGLES;
use crate::polygon::triangulate;
use glam::Vec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A triangle mesh read from an OBJ file: all objects and groups of the file merged.
///
/// Indices are 0-based and local to the mesh: `points[i]` for the corners, `normals[i]` for the
/// corners' shading normals.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjMesh {
    /// Vertex positions (`v`), in file order, all of them (used by a face or not).
    pub points: Vec<Vec3>,
    /// Vertex normals (`vn`), in file order, as the file gives them (not normalised; never zero).
    pub normals: Vec<Vec3>,
    /// The faces, split into triangles, in file order.
    pub triangles: Vec<ObjTriangle>,
}

/// One triangle of an [`ObjMesh`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ObjTriangle {
    /// Indices into [`ObjMesh::points`], in the face's corner order.
    pub points: [u32; 3],
    /// Indices into [`ObjMesh::normals`] when the face gives normals (`v//vn`), else `None`.
    pub normals: Option<[u32; 3]>,
}

/// A material of an `.mtl` file, with the fields Strahl uses; fields the file leaves out are
/// `None`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjMaterial {
    /// The name after `newmtl`.
    pub name: String,
    /// `Ka`: ambient colour.
    pub ambient: Option<Vec3>,
    /// `Kd`: diffuse colour.
    pub diffuse: Option<Vec3>,
    /// `Ks`: specular colour.
    pub specular: Option<Vec3>,
    /// `Ns`: specular (Phong) exponent.
    pub shininess: Option<f32>,
    /// `d` (or `1 − Tr`): opacity, 1 being opaque.
    pub dissolve: Option<f32>,
}

impl ObjMaterial {
    /// Its shader: diffuse = `Kd` (0.8 grey if absent); ambient = 0.1 · `Ka` (0.1 · diffuse if
    /// absent: MTL scales `Ka` by an ambient light, which the seed's model lacks, and 0.1 is the
    /// light assumed); specular = `Ks` (black if absent); shininess = `Ns` (10 if absent, at
    /// least 0); no reflection.
    pub fn shader(&self) -> strahl_core::scene::Shader {
        let diffuse = self.diffuse.unwrap_or(Vec3::splat(0.8));
        strahl_core::scene::Shader::phong(
            self.ambient.unwrap_or(diffuse) * 0.1,
            diffuse,
            self.specular.unwrap_or(Vec3::ZERO),
            self.shininess.unwrap_or(10.0).max(0.0),
            0.0,
        )
    }
}

/// An OBJ file with its materials: what [`read_obj_file`] returns.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjFile {
    /// The geometry.
    pub mesh: ObjMesh,
    /// The materials of every `mtllib` file that could be read, in file order.
    pub materials: Vec<ObjMaterial>,
    /// For each triangle of [`ObjFile::mesh`], the index into [`ObjFile::materials`] of its
    /// `usemtl` material, or `None` (no `usemtl` before it, or an unknown name).
    pub triangle_materials: Vec<Option<u32>>,
    /// Problems that do not stop loading, one sentence each: an `.mtl` file that cannot be read,
    /// a `usemtl` naming no known material.
    pub warnings: Vec<String>,
    /// The `.mtl` files read.
    pub material_files: Vec<PathBuf>,
}

/// Reads the geometry of the OBJ file at `path` (materials are not read).
///
/// # Errors
/// [`LoadError::Io`] if the file cannot be read, [`LoadError::At`] for a bad line (a number that
/// is not one or not finite, a wrong count of values, an index of 0 or out of range, a zero-length
/// normal, a face with fewer than three corners or with normals at some corners only), and
/// [`LoadError::File`] for a file without faces.
pub fn read_obj(path: &Path) -> Result<ObjMesh, LoadError> {
    parse_obj(path, &read_bytes(path)?)
}

/// Parses the bytes of an OBJ file read from `path` (which names it in errors), without its
/// materials.
///
/// # Errors
/// As [`read_obj`], but for reading the file.
pub fn parse_obj(path: &Path, bytes: &[u8]) -> Result<ObjMesh, LoadError> {
    let mut reader = Reader::new(path, false);
    reader.parse(bytes)?;
    Ok(reader.finish()?.mesh)
}

/// Reads the OBJ file at `path` with its materials: the `mtllib` files are read relative to the
/// OBJ file's folder and each triangle gets the material its `usemtl` names.
///
/// An `.mtl` file that cannot be read and a `usemtl` naming no known material are not errors:
/// they are listed in [`ObjFile::warnings`] and the triangles concerned get no material.
///
/// # Errors
/// As [`read_obj`], and [`LoadError::At`] for a bad line of an `.mtl` file that can be read.
pub fn read_obj_file(path: &Path) -> Result<ObjFile, LoadError> {
    let text = read_bytes(path)?;
    let mut reader = Reader::new(path, true);
    reader.parse(&text)?;
    reader.finish()
}

fn read_bytes(path: &Path) -> Result<Vec<u8>, LoadError> {
    std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The lines of `text` with their 1-based numbers, without line ends (LF or CRLF). Bytes that
/// are not UTF-8 are replaced (they can only matter in names and comments).
fn numbered_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
}

/// The words of a statement up to a word that starts a comment.
fn words_before_comment(rest: std::str::SplitAsciiWhitespace<'_>) -> impl Iterator<Item = &str> {
    rest.take_while(|w| !w.starts_with('#'))
}

/// Everything after the first word of `line`, trimmed (for names with spaces).
fn rest_of_line<'a>(line: &'a str, keyword: &str) -> &'a str {
    let trimmed = line.trim_start_matches(|c: char| c.is_ascii_whitespace());
    trimmed
        .get(keyword.len()..)
        .unwrap_or("")
        .trim_matches(|c: char| c.is_ascii_whitespace())
}

fn parse_number(word: &str) -> Result<f32, String> {
    match word.parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("`{word}` is not a finite number")),
        Err(_) => Err(format!("`{word}` is not a number")),
    }
}

/// One corner of a face: a point index and an optional normal index, both 0-based.
type Corner = (u32, Option<u32>);

struct Reader<'p> {
    path: &'p Path,
    with_materials: bool,
    file: ObjFile,
    /// Material name to index into `file.materials` (the last definition of a name wins).
    material_names: HashMap<String, u32>,
    current_material: Option<u32>,
    /// `usemtl` names already warned about.
    unknown_materials: Vec<String>,
    /// Reused for the corners of each face.
    corners: Vec<Corner>,
    /// Reused for the corners' positions and the triangles of each face.
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

impl<'p> Reader<'p> {
    fn new(path: &'p Path, with_materials: bool) -> Self {
        Reader {
            path,
            with_materials,
            file: ObjFile::default(),
            material_names: HashMap::new(),
            current_material: None,
            unknown_materials: Vec::new(),
            corners: Vec::new(),
            positions: Vec::new(),
            triangles: Vec::new(),
        }
    }

    fn at(&self, line: usize, message: impl Into<String>) -> LoadError {
        LoadError::At {
            path: self.path.to_path_buf(),
            line,
            message: message.into(),
        }
    }

    fn parse(&mut self, bytes: &[u8]) -> Result<(), LoadError> {
        let text = String::from_utf8_lossy(bytes);
        for (number, line) in numbered_lines(&text) {
            let mut words = line.split_ascii_whitespace();
            let Some(keyword) = words.next() else {
                continue;
            };
            match keyword {
                "v" => self.vertex(number, words)?,
                "vn" => self.normal(number, words)?,
                "f" => self.face(number, words)?,
                "mtllib" if self.with_materials => self.mtllib(rest_of_line(line, keyword))?,
                "usemtl" if self.with_materials => self.usemtl(rest_of_line(line, keyword)),
                _ => {} // comments, vt, o, g, s, l, p and the rest
            }
        }
        Ok(())
    }

    /// The numbers on a `keyword` line before any comment: the first `N` parsed (the rest of
    /// the array 0) and how many words there were in all.
    fn numbers<const N: usize>(
        &self,
        line: usize,
        words: std::str::SplitAsciiWhitespace<'_>,
        keyword: &str,
    ) -> Result<([f32; N], usize), LoadError> {
        let mut v = [0.0f32; N];
        let mut n = 0;
        for w in words_before_comment(words) {
            if n < N {
                v[n] = parse_number(w).map_err(|m| self.at(line, format!("`{keyword}`: {m}")))?;
            }
            n += 1;
        }
        Ok((v, n))
    }

    fn vertex(
        &mut self,
        line: usize,
        words: std::str::SplitAsciiWhitespace<'_>,
    ) -> Result<(), LoadError> {
        let (v, n) = self.numbers::<6>(line, words, "v")?;
        let p = match n {
            3 | 6 => Vec3::new(v[0], v[1], v[2]),
            4 => {
                if v[3] == 0.0 {
                    return Err(self.at(line, "`v`: the weight w is 0"));
                }
                let p = Vec3::new(v[0], v[1], v[2]) / v[3];
                if !p.is_finite() {
                    return Err(self.at(line, "`v`: x/w, y/w or z/w is not a finite number"));
                }
                p
            }
            _ => {
                return Err(self.at(
                    line,
                    format!(
                        "`v`: expected 3 numbers (x y z), 4 (x y z w) or 6 (x y z r g b), found {n}"
                    ),
                ))
            }
        };
        if self.file.mesh.points.len() >= u32::MAX as usize {
            return Err(self.at(line, "`v`: too many vertices"));
        }
        self.file.mesh.points.push(p);
        Ok(())
    }

    fn normal(
        &mut self,
        line: usize,
        words: std::str::SplitAsciiWhitespace<'_>,
    ) -> Result<(), LoadError> {
        let (v, n) = self.numbers::<3>(line, words, "vn")?;
        if n != 3 {
            return Err(self.at(line, format!("`vn`: expected 3 numbers (x y z), found {n}")));
        }
        let normal = Vec3::from_array(v);
        let index = self.file.mesh.normals.len() + 1;
        // A normal so short that its square underflows cannot be normalised either.
        if normal.length_squared() == 0.0 {
            return Err(self.at(line, format!("normal {index} has zero length")));
        }
        if index > u32::MAX as usize {
            return Err(self.at(line, "`vn`: too many normals"));
        }
        self.file.mesh.normals.push(normal);
        Ok(())
    }

    /// Resolves a 1-based or negative (relative) OBJ index against `count` elements.
    fn index(&self, line: usize, word: &str, count: usize, what: &str) -> Result<u32, LoadError> {
        let counted = match (what, count) {
            ("vertex", 1) => "vertex",
            ("vertex", _) => "vertices",
            (_, 1) => "normal",
            _ => "normals",
        };
        let Ok(k) = word.parse::<i64>() else {
            return Err(self.at(
                line,
                format!("`f`: `{word}` is not a {what} index (a whole number)"),
            ));
        };
        let resolved = if k > 0 {
            k - 1
        } else if k < 0 {
            count as i64 + k
        } else {
            return Err(self.at(
                line,
                format!("`f`: {what} index 0; OBJ indices count from 1 (or back from -1)"),
            ));
        };
        if resolved < 0 || resolved >= count as i64 {
            return Err(self.at(
                line,
                format!("`f`: {what} index {k} out of range ({count} {counted} defined so far)"),
            ));
        }
        // `resolved < count <= u32::MAX`.
        u32::try_from(resolved).map_err(|_| self.at(line, format!("`f`: {what} index too large")))
    }

    fn face(
        &mut self,
        line: usize,
        words: std::str::SplitAsciiWhitespace<'_>,
    ) -> Result<(), LoadError> {
        let mut corners = std::mem::take(&mut self.corners);
        corners.clear();
        let mut result = self.face_corners(line, words, &mut corners);
        let total = self.file.mesh.triangles.len() + corners.len().saturating_sub(2);
        if result.is_ok() && total as u64 > MAX_TRIANGLES {
            result = Err(self.at(line, format!("more than {MAX_TRIANGLES} triangles")));
        }
        if result.is_ok() {
            self.face_triangles(&corners);
        }
        self.corners = corners;
        result
    }

    /// Adds the triangles of the face `corners` ([`triangulate`]: a fan around the first corner
    /// where it covers the face once).
    fn face_triangles(&mut self, corners: &[Corner]) {
        let (mut positions, mut triangles) = (
            std::mem::take(&mut self.positions),
            std::mem::take(&mut self.triangles),
        );
        positions.clear();
        positions.extend(corners.iter().map(|c| self.file.mesh.points[c.0 as usize]));
        triangles.clear();
        triangulate(&positions, &mut triangles);
        for t in &triangles {
            let [a, b, c] = t.map(|k| corners[k as usize]);
            let normals = match (a.1, b.1, c.1) {
                (Some(x), Some(y), Some(z)) => Some([x, y, z]),
                _ => None,
            };
            self.file.mesh.triangles.push(ObjTriangle {
                points: [a.0, b.0, c.0],
                normals,
            });
            self.file.triangle_materials.push(self.current_material);
        }
        (self.positions, self.triangles) = (positions, triangles);
    }

    fn face_corners(
        &self,
        line: usize,
        words: std::str::SplitAsciiWhitespace<'_>,
        corners: &mut Vec<Corner>,
    ) -> Result<(), LoadError> {
        let (n_points, n_normals) = (self.file.mesh.points.len(), self.file.mesh.normals.len());
        for word in words_before_comment(words) {
            let mut parts = word.split('/');
            let v = parts.next().unwrap_or("");
            let _vt = parts.next();
            let vn = parts.next();
            if parts.next().is_some() {
                return Err(self.at(
                    line,
                    format!("`f`: `{word}` is not a corner; expected v, v/vt, v//vn or v/vt/vn"),
                ));
            }
            let point = self.index(line, v, n_points, "vertex")?;
            let normal = match vn {
                None | Some("") => None,
                Some(vn) => Some(self.index(line, vn, n_normals, "normal")?),
            };
            corners.push((point, normal));
        }
        if corners.len() < 3 {
            return Err(self.at(
                line,
                format!(
                    "`f`: a face needs at least 3 corners, found {}",
                    corners.len()
                ),
            ));
        }
        let with_normals = corners.iter().filter(|c| c.1.is_some()).count();
        if with_normals != 0 && with_normals != corners.len() {
            return Err(self.at(
                line,
                "`f`: some corners have a normal (v//vn) and others do not; give all or none",
            ));
        }
        Ok(())
    }

    fn mtllib(&mut self, names: &str) -> Result<(), LoadError> {
        let folder = self.path.parent().unwrap_or_else(|| Path::new(""));
        // A name with spaces is one file if it exists; otherwise the words are several files.
        let whole = folder.join(names);
        let files: Vec<PathBuf> = if names.is_empty() {
            Vec::new()
        } else if whole.is_file() || !names.contains(|c: char| c.is_ascii_whitespace()) {
            vec![whole]
        } else {
            names
                .split_ascii_whitespace()
                .map(|n| folder.join(n))
                .collect()
        };
        for file in files {
            match std::fs::read(&file) {
                Ok(bytes) => {
                    self.file.material_files.push(file.clone());
                    for m in parse_mtl(&file, &bytes)? {
                        let index = self.file.materials.len() as u32;
                        self.material_names.insert(m.name.clone(), index);
                        self.file.materials.push(m);
                    }
                }
                Err(e) => self.file.warnings.push(format!(
                    "{}: cannot read the material file ({e}); its materials are not used",
                    file.display()
                )),
            }
        }
        Ok(())
    }

    fn usemtl(&mut self, name: &str) {
        self.current_material = self.material_names.get(name).copied();
        if self.current_material.is_none() && !self.unknown_materials.iter().any(|n| n == name) {
            self.unknown_materials.push(name.to_string());
            self.file.warnings.push(format!(
                "{}: `usemtl {name}` names no material of the `mtllib` files; \
                 its faces get the default material",
                self.path.display()
            ));
        }
    }

    fn finish(self) -> Result<ObjFile, LoadError> {
        if self.file.mesh.triangles.is_empty() {
            return Err(LoadError::File {
                path: self.path.to_path_buf(),
                message: "no faces (`f`) in the file; a mesh needs at least one triangle"
                    .to_string(),
            });
        }
        Ok(self.file)
    }
}

/// Parses an `.mtl` file: `newmtl`, `Ka`, `Kd`, `Ks` (1 or 3 numbers; one number is grey), `Ns`,
/// `d` and `Tr`; everything else (textures, `illum`, `Ni`, `Ke`, ...) is ignored.
fn parse_mtl(path: &Path, bytes: &[u8]) -> Result<Vec<ObjMaterial>, LoadError> {
    let text = String::from_utf8_lossy(bytes);
    let mut out: Vec<ObjMaterial> = Vec::new();
    for (line, raw) in numbered_lines(&text) {
        let at = |message: String| LoadError::At {
            path: path.to_path_buf(),
            line,
            message,
        };
        let mut words = raw.split_ascii_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        if keyword == "newmtl" {
            let name = rest_of_line(raw, keyword);
            if name.is_empty() {
                return Err(at("`newmtl`: the material needs a name".to_string()));
            }
            out.push(ObjMaterial {
                name: name.to_string(),
                ..ObjMaterial::default()
            });
            continue;
        }
        if !matches!(keyword, "Ka" | "Kd" | "Ks" | "Ns" | "d" | "Tr") {
            continue;
        }
        let mut words = words_before_comment(words).peekable();
        if matches!(words.peek(), Some(&("spectral" | "xyz"))) {
            continue; // spectral curves and CIE XYZ colours are not supported: ignored
        }
        let mut v = [0.0f32; 3];
        let mut n = 0;
        for w in words {
            if n < 3 {
                v[n] = parse_number(w).map_err(|m| at(format!("`{keyword}`: {m}")))?;
            }
            n += 1;
        }
        let Some(material) = out.last_mut() else {
            return Err(at(format!("`{keyword}` before the first `newmtl`")));
        };
        match keyword {
            "Ka" | "Kd" | "Ks" => {
                let colour = match n {
                    1 => Vec3::splat(v[0]),
                    3 => Vec3::from_array(v),
                    _ => {
                        return Err(at(format!(
                            "`{keyword}`: expected 3 numbers (r g b) or 1 (grey), found {n}"
                        )))
                    }
                };
                match keyword {
                    "Ka" => material.ambient = Some(colour),
                    "Kd" => material.diffuse = Some(colour),
                    _ => material.specular = Some(colour),
                }
            }
            _ => {
                if n != 1 {
                    return Err(at(format!("`{keyword}`: expected 1 number, found {n}")));
                }
                match keyword {
                    "Ns" => material.shininess = Some(v[0]),
                    "d" => material.dissolve = Some(v[0]),
                    _ => material.dissolve = Some(1.0 - v[0]),
                }
            }
        }
    }
    Ok(out)
}
