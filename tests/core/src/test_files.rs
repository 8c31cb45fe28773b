//! The check that a package whose integration tests are one binary (`autotests = false`, each
//! file a module of `tests/main.rs`) compiles every file of its `tests/` folder: cargo finds no
//! file by itself there, so a new file that is not declared would never run, and nobody would
//! see it.

use std::path::Path;

/// Fails, naming them, if files of `package_dir`'s `tests/` are [`left_out`] of the binary whose
/// `main.rs` is `main_rs` and of the targets of `manifest`.
pub fn check(package_dir: &str, main_rs: &str, manifest: &str) -> Result<(), String> {
    let dir = Path::new(package_dir).join("tests");
    match left_out(&dir, main_rs, manifest) {
        Ok(left) if left.is_empty() => Ok(()),
        Ok(left) => Err(format!(
            "{}: not compiled into any test: {left:?}",
            dir.display()
        )),
        Err(e) => Err(format!("{}: {e}", dir.display())),
    }
}

/// The `.rs` files of `dir` (a package's `tests/`) that are neither `main.rs`, a module that
/// `main_rs` (that file's text) declares as `mod NAME;` on a line of its own, nor a test target
/// of its own in `manifest` (the package's `Cargo.toml`, naming `"tests/NAME.rs"`).
pub fn left_out(dir: &Path, main_rs: &str, manifest: &str) -> std::io::Result<Vec<String>> {
    let declared = |name: &str| main_rs.contains(&format!("\nmod {name};\n"));
    let own_target = |name: &str| manifest.contains(&format!("\"tests/{name}.rs\""));
    let mut left = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        let Some(name) = path.file_stem().and_then(|s| s.to_str()) else {
            continue;
        };
        let is_rs = path.extension().is_some_and(|e| e == "rs");
        if is_rs && name != "main" && !declared(name) && !own_target(name) {
            left.push(name.to_owned());
        }
    }
    left.sort();
    Ok(left)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_only_the_files_no_target_compiles() -> std::io::Result<()> {
        let tmp = tempfile::tempdir()?;
        let dir = tmp.path();
        for name in ["main.rs", "a.rs", "b.rs", "alone.rs", "c.rs", "notes.txt"] {
            std::fs::write(dir.join(name), "")?;
        }
        std::fs::create_dir(dir.join("support"))?;
        let main_rs = "//! doc\n\nmod a;\nmod b;\n// mod c;\n";
        let manifest = "[[test]]\nname = \"alone\"\npath = \"tests/alone.rs\"\n";
        assert_eq!(left_out(dir, main_rs, manifest)?, ["c"]);
        Ok(())
    }
}
