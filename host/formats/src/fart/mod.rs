//! FART's scene language (`.fart`): a `scene { ... }` of shapes, CSG, materials, lights, a camera
//! and options, with variables, loops and conditions expanded at load time.
//!
//! Loading runs in three stages, one file each:
//!
//! 1. [`lexer`] turns the text into tokens, each with its line and column.
//! 2. [`parser`] turns the tokens into a syntax tree, checking which keyword belongs in which
//!    block (a `radius` in a `plane` is an error there) and limiting nesting.
//! 3. [`expand`] runs the tree: it evaluates `let`, `for`, `if`, expressions and `define`d names,
//!    and builds the [`SceneDesc`]: solids in a flat arena (CSG operands before their node),
//!    deduplicated shaders, lights, the look-at camera, settings and mesh triangles.
//!
//! Every problem is a [`LoadError::AtColumn`] (`path:line:column: message`) that says what was
//! expected and what was found; only a scene that `SceneDesc::validate` rejects afterwards (which
//! the checks here should leave no room for) is a [`LoadError::File`]. The language is described
//! in `scenes/FORMATS.md`, section 9.

pub mod expand;
pub mod lexer;
pub mod parser;

use crate::error::LoadError;
use std::path::{Path, PathBuf};
use strahl_core::scene::SceneDesc;

/// A place in the source: 1-based line and column (in characters).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Pos {
    /// Line, from 1.
    pub line: usize,
    /// Column, from 1, in characters.
    pub column: usize,
}

/// A problem at a place in a `.fart` file, before the file's path is attached.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FartError {
    /// Where.
    pub pos: Pos,
    /// What was expected and what was found.
    pub message: String,
}

impl FartError {
    /// A problem at `pos`.
    pub fn new(pos: Pos, message: impl Into<String>) -> Self {
        FartError {
            pos,
            message: message.into(),
        }
    }

    /// The [`LoadError::AtColumn`] for this problem in the file `path`.
    pub fn at(self, path: &Path) -> LoadError {
        LoadError::AtColumn {
            path: path.to_path_buf(),
            line: self.pos.line,
            column: self.pos.column,
            message: self.message,
        }
    }
}

/// A `.fart` scene loaded, with the files it read besides itself and what it warns about.
#[derive(Clone, Debug)]
pub struct FartScene {
    /// The scene, validated.
    pub desc: SceneDesc,
    /// The mesh files (`mesh { file ... }`) and their `.mtl` files read, in order.
    pub files: Vec<PathBuf>,
    /// Problems of the mesh files that do not stop loading (`.mtl` files that cannot be read,
    /// `usemtl` naming no material), one sentence each, naming the file.
    pub warnings: Vec<String>,
}

/// Reads and loads the `.fart` file at `path` ([`read_fart`]), the scene alone.
///
/// # Errors
/// As [`read_fart`].
pub fn load_fart(path: &Path) -> Result<SceneDesc, LoadError> {
    read_fart(path).map(|scene| scene.desc)
}

/// Reads and loads the `.fart` file at `path`; mesh files it names are read relative to its
/// folder.
///
/// # Errors
/// [`LoadError::Io`] if the file cannot be read, [`LoadError::AtColumn`] for a problem at a place
/// in it (or [`LoadError::At`] for one in an OBJ file it names), [`LoadError::File`] if the
/// assembled scene fails validation.
pub fn read_fart(path: &Path) -> Result<FartScene, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let source = match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => {
            let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
            let text = String::from_utf8_lossy(good);
            let line = 1 + text.matches('\n').count();
            let column = 1 + text.rsplit('\n').next().map_or(0, |l| l.chars().count());
            return Err(LoadError::AtColumn {
                path: path.to_path_buf(),
                line,
                column,
                message: "the file is not valid UTF-8 text".to_string(),
            });
        }
    };
    fart_source(path, &source)
}

/// Loads `.fart` text `source` as if read from `path` (which names the file in messages and is
/// the base for mesh files), the scene alone.
///
/// # Errors
/// As [`load_fart`], without the reading.
pub fn load_fart_source(path: &Path, source: &str) -> Result<SceneDesc, LoadError> {
    fart_source(path, source).map(|scene| scene.desc)
}

/// [`load_fart_source`] with the files read and the warnings.
fn fart_source(path: &Path, source: &str) -> Result<FartScene, LoadError> {
    let tokens = lexer::tokenize(source).map_err(|e| e.at(path))?;
    let ast = parser::parse(&tokens).map_err(|e| e.at(path))?;
    let scene = expand::expand(&ast, path)?;
    scene.desc.validate().map_err(|e| LoadError::File {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    Ok(scene)
}
