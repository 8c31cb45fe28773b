//! The scenes to compare: each `X.nff` of the scene folder that has an `X.pov` beside it, the
//! same scene for Strahl and for POV-Ray, optionally narrowed to the names `--only` gives.

use anyhow::{bail, Context as _};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// One scene in its two forms.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScenePair {
    /// The common file stem (`teapot_12`): the scene's name in the table and its image's.
    pub name: String,
    /// The scene for Strahl.
    pub nff: PathBuf,
    /// The same scene for POV-Ray.
    pub pov: PathBuf,
}

/// The pairs in `dir`, sorted by name, their paths absolute; with `only` non-empty, exactly
/// those names, in the order given.
///
/// # Errors
/// If `dir` cannot be read, holds no pair, a `.nff` lacks its `.pov` while `only` names it, or a
/// name in `only` has no pair (the message lists the pairs there are).
pub fn find_pairs(dir: &Path, only: &[String]) -> anyhow::Result<Vec<ScenePair>> {
    // Absolute: POV-Ray runs in another folder.
    let dir = &dir
        .canonicalize()
        .with_context(|| format!("scene folder {}: cannot read it", dir.display()))?;
    let entries = std::fs::read_dir(dir)
        .with_context(|| format!("scene folder {}: cannot read it", dir.display()))?;
    let mut nff = BTreeSet::new();
    let mut pov = BTreeSet::new();
    for entry in entries {
        let path = entry
            .with_context(|| format!("scene folder {}: cannot read it", dir.display()))?
            .path();
        let (Some(stem), Some(ext)) = (
            path.file_stem().and_then(|s| s.to_str()),
            path.extension().and_then(|e| e.to_str()),
        ) else {
            continue;
        };
        match ext {
            "nff" => nff.insert(stem.to_string()),
            "pov" => pov.insert(stem.to_string()),
            _ => false,
        };
    }
    let pair = |name: &str| ScenePair {
        name: name.to_string(),
        nff: dir.join(format!("{name}.nff")),
        pov: dir.join(format!("{name}.pov")),
    };
    let names: Vec<&String> = nff.intersection(&pov).collect();
    if names.is_empty() {
        bail!(
            "scene folder {}: no scene pairs (an X.nff with an X.pov beside it) found",
            dir.display()
        );
    }
    if only.is_empty() {
        return Ok(names.into_iter().map(|n| pair(n)).collect());
    }
    let mut chosen: Vec<ScenePair> = Vec::with_capacity(only.len());
    for name in only {
        if chosen.iter().any(|p| &p.name == name) {
            continue;
        }
        if nff.contains(name) && pov.contains(name) {
            chosen.push(pair(name));
        } else {
            let missing = match (nff.contains(name), pov.contains(name)) {
                (true, false) => format!("{name}.nff has no {name}.pov beside it"),
                (false, true) => format!("{name}.pov has no {name}.nff beside it"),
                _ => format!("no {name}.nff and {name}.pov"),
            };
            let there: Vec<&str> = names.iter().map(|n| n.as_str()).collect();
            bail!(
                "--only {name:?}: {missing} in {} (the pairs there: {})",
                dir.display(),
                there.join(", ")
            );
        }
    }
    Ok(chosen)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(files: &[&str]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().expect("tempdir");
        for f in files {
            std::fs::write(dir.path().join(f), "").expect("write");
        }
        dir
    }

    #[test]
    fn pairs_are_sorted_and_lone_files_left_out() {
        let dir = folder(&[
            "b.nff",
            "b.pov",
            "a.nff",
            "a.pov",
            "c.nff",
            "d.pov",
            "README.md",
        ]);
        let names: Vec<String> = find_pairs(dir.path(), &[])
            .expect("pairs")
            .into_iter()
            .map(|p| p.name)
            .collect();
        assert_eq!(names, ["a", "b"]);
    }

    #[test]
    fn only_keeps_its_order_and_names_what_is_missing() {
        let dir = folder(&["a.nff", "a.pov", "b.nff", "b.pov", "c.nff"]);
        let only = |names: &[&str]| {
            let v: Vec<String> = names.iter().map(|s| s.to_string()).collect();
            find_pairs(dir.path(), &v)
        };
        let got: Vec<String> = only(&["b", "a", "b"])
            .expect("pairs")
            .into_iter()
            .map(|p| p.name)
            .collect();
        assert_eq!(got, ["b", "a"]);
        let err = only(&["c"]).expect_err("c has no .pov").to_string();
        assert!(err.contains("c.nff has no c.pov"), "{err}");
        let err = only(&["nosuch"]).expect_err("no such pair").to_string();
        assert!(err.contains("\"nosuch\"") && err.contains("a, b"), "{err}");
    }

    #[test]
    fn a_folder_without_pairs_or_missing_is_an_error() {
        let dir = folder(&["a.nff", "b.pov"]);
        let err = find_pairs(dir.path(), &[])
            .expect_err("no pairs")
            .to_string();
        assert!(err.contains("no scene pairs"), "{err}");
        let err = find_pairs(&dir.path().join("nope"), &[])
            .expect_err("missing")
            .to_string();
        assert!(err.contains("cannot read"), "{err}");
    }
}
