//! The report's place in a Markdown file (`--write-docs FILE`): the text between the lines
//! [`BEGIN`] and [`END`] is replaced; a file without them gets a new section at its end, headed
//! [`HEADING`], holding them. The file is written through a temporary file in its folder that is
//! renamed into place, so it is never left half written.

use anyhow::{bail, Context as _};
use std::io::Write as _;
use std::path::Path;

/// The line that opens the generated text.
pub const BEGIN: &str = "<!-- bench peers: begin -->";
/// The line that closes it.
pub const END: &str = "<!-- bench peers: end -->";
/// The heading of the section added to a file without the markers.
pub const HEADING: &str = "## Strahl against POV-Ray: `strahl bench peers`";

/// `existing` with the text between the markers replaced by `body`, or with a new section
/// holding the markers and `body` appended if it has neither marker.
///
/// # Errors
/// If only one marker is there, one is there twice, or the end comes before the begin.
pub fn splice(existing: &str, body: &str) -> anyhow::Result<String> {
    let lines: Vec<&str> = existing.lines().collect();
    let find = |marker: &str| -> Vec<usize> {
        lines
            .iter()
            .enumerate()
            .filter(|(_, l)| l.trim() == marker)
            .map(|(i, _)| i)
            .collect()
    };
    let body = if body.is_empty() || body.ends_with('\n') {
        body.to_string()
    } else {
        format!("{body}\n")
    };
    match (find(BEGIN).as_slice(), find(END).as_slice()) {
        ([], []) => {
            let mut out = existing.to_string();
            if !out.is_empty() {
                if !out.ends_with('\n') {
                    out.push('\n');
                }
                out.push('\n');
            }
            out.push_str(&format!("{HEADING}\n\n{BEGIN}\n{body}{END}\n"));
            Ok(out)
        }
        ([b], [e]) if b < e => {
            let mut out = String::new();
            for l in &lines[..=*b] {
                out.push_str(l);
                out.push('\n');
            }
            out.push_str(&body);
            for l in &lines[*e..] {
                out.push_str(l);
                out.push('\n');
            }
            Ok(out)
        }
        ([b], [e]) => bail!(
            "the end marker (line {}) comes before the begin marker (line {})",
            e + 1,
            b + 1
        ),
        (b, e) => bail!(
            "expected the lines `{BEGIN}` and `{END}` once each, or neither; found {} and {}",
            b.len(),
            e.len()
        ),
    }
}

/// The file's text, or nothing if it does not exist yet.
fn read_existing(path: &Path) -> anyhow::Result<String> {
    match std::fs::read_to_string(path) {
        Ok(text) => Ok(text),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(String::new()),
        Err(e) => Err(e).with_context(|| format!("{}: cannot read", path.display())),
    }
}

/// Checks, before anything is measured, that the report can go into `path`: its markers are in
/// order (or absent), and its folder exists.
///
/// # Errors
/// As [`splice`], naming the file; or if its folder is missing.
pub fn check_docs(path: &Path) -> anyhow::Result<()> {
    let folder = crate::formats::fs::destination_folder(path);
    if !folder.is_dir() {
        bail!(
            "{}: the folder {} does not exist",
            path.display(),
            folder.display()
        );
    }
    splice(&read_existing(path)?, "").with_context(|| format!("{}", path.display()))?;
    Ok(())
}

/// Puts `body` between the markers of `path` (see [`splice`]), atomically.
///
/// # Errors
/// As [`splice`], or if the file cannot be read or written.
pub fn write_docs(path: &Path, body: &str) -> anyhow::Result<()> {
    let text =
        splice(&read_existing(path)?, body).with_context(|| format!("{}", path.display()))?;
    crate::formats::fs::write_atomically(path, |w| {
        w.write_all(text.as_bytes())
            .with_context(|| format!("{}: cannot write", path.display()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn appends_a_section_then_replaces_it() {
        let first = splice("# Performance\n\nintro", "table 1").expect("appended");
        assert_eq!(
            first,
            format!("# Performance\n\nintro\n\n{HEADING}\n\n{BEGIN}\ntable 1\n{END}\n")
        );
        let with_after = format!("{first}\n## Later\n");
        let second = splice(&with_after, "table 2\n").expect("replaced");
        assert_eq!(
            second,
            format!("# Performance\n\nintro\n\n{HEADING}\n\n{BEGIN}\ntable 2\n{END}\n\n## Later\n")
        );
        assert_eq!(second.matches(HEADING).count(), 1);
        assert_eq!(
            splice("", "x").expect("new"),
            format!("{HEADING}\n\n{BEGIN}\nx\n{END}\n")
        );
    }

    #[test]
    fn broken_markers_are_errors() {
        let err = splice(&format!("{BEGIN}\n"), "x")
            .expect_err("one marker")
            .to_string();
        assert!(err.contains("found 1 and 0"), "{err}");
        let err = splice(&format!("{END}\n{BEGIN}\n"), "x")
            .expect_err("reversed")
            .to_string();
        assert!(err.contains("before"), "{err}");
        let twice = format!("{BEGIN}\n{END}\n{BEGIN}\n{END}\n");
        assert!(splice(&twice, "x").is_err());
    }

    #[test]
    fn writes_and_rewrites_a_file() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("perf.md");
        check_docs(&path).expect("a new file is fine");
        write_docs(&path, "one").expect("written");
        write_docs(&path, "two").expect("rewritten");
        let text = std::fs::read_to_string(&path).expect("read");
        assert_eq!(text, format!("{HEADING}\n\n{BEGIN}\ntwo\n{END}\n"));
        let err = check_docs(&dir.path().join("no/perf.md"))
            .expect_err("no folder")
            .to_string();
        assert!(err.contains("does not exist"), "{err}");
    }
}
