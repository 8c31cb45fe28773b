//! Files written whole or not at all: [`write_atomically`] and the folder it writes in.
//!
//! Every writer of Strahl (images, generated scenes, converted meshes, statistics, reports)
//! goes through [`write_atomically`], so no failed run leaves a partial file behind.

use anyhow::Context as _;
use std::io::{BufWriter, Write as _};
use std::path::{Path, PathBuf};

/// The folder a file at `path` lives in (`.` for a bare file name).
pub fn destination_folder(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Writes a file through a temporary file in its folder that is renamed into place at the end:
/// readers never see a partial file, and on any error nothing is left at `path` (an existing
/// file there stays as it was).
///
/// # Errors
/// Any error of `write`, or an I/O error naming `path`.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<&mut std::fs::File>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let dir = destination_folder(path);
    let mut builder = tempfile::Builder::new();
    builder.prefix(".strahl-").suffix(".tmp");
    #[cfg(unix)]
    {
        // Like any new file: readable by all, subject to the umask (tempfile defaults to 0600).
        use std::os::unix::fs::PermissionsExt as _;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(&dir).with_context(|| {
        format!(
            "{}: cannot create a temporary file in {}",
            path.display(),
            dir.display()
        )
    })?;
    {
        let mut w = BufWriter::new(tmp.as_file_mut());
        write(&mut w)?;
        w.flush()
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    tmp.as_file()
        .sync_all()
        .with_context(|| format!("{}: cannot write", path.display()))?;
    tmp.persist(path).map_err(|e| e.error).with_context(|| {
        format!(
            "{}: cannot move the finished file into place",
            path.display()
        )
    })?;
    Ok(())
}

/// Writes `text` to `path` atomically (see [`write_atomically`]).
///
/// # Errors
/// As [`write_atomically`]; a failed write says `path: cannot write`.
pub fn write_text_atomically(path: &Path, text: &str) -> anyhow::Result<()> {
    write_atomically(path, |w| {
        w.write_all(text.as_bytes())
            .with_context(|| format!("{}: cannot write", path.display()))
    })
}

/// Refuses, unless `force`, to replace any of `paths` that is there already: no command
/// replaces a file it did not write in the same run unless asked (`--force`).
///
/// # Errors
/// The first file that is there, named, with the option that replaces it.
pub fn refuse_to_replace(paths: &[&Path], force: bool) -> anyhow::Result<()> {
    match paths.iter().find(|p| !force && p.exists()) {
        Some(there) => anyhow::bail!(
            "{}: the file is there already and is not replaced; give --force to replace it, or \
             another output",
            there.display()
        ),
        None => Ok(()),
    }
}
