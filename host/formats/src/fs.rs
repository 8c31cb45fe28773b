//! Files written whole or not at all: [`write_atomically`] and the folder it writes in.
//!
//! Every writer of Strahl (images, generated scenes, converted meshes, statistics, reports)
//! goes through [`write_atomically`], so no failed run leaves a partial file behind. What it may
//! replace is decided in one place, [`write_target`] (a link is written through; a folder,
//! device, pipe or socket is refused), and no writer replaces a file its run read
//! ([`refuse_to_replace_input`], by [`same_file`]) nor, unless asked, one that is there
//! ([`refuse_to_replace`]).

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

/// Why [`write_target`] refuses a device, a pipe or a socket.
const NOT_REGULAR: &str = "it is not a regular file (a device, a pipe or a socket); Strahl \
    writes a whole new file and moves it into place, which would replace it";

/// The file a write to `path` replaces: `path` itself, or the file a symbolic link there
/// names (the link is kept, as a program writing through it would keep it). A file is written
/// whole and moved into place, which would put a regular file in the place of a device, a
/// pipe or a socket (as root, of `/dev/null`): those are refused.
///
/// # Errors
/// Why not, for a message after `path`: it (or the file its link names) is a folder, a device,
/// a pipe or a socket, or a link to nothing.
pub fn write_target(path: &Path) -> Result<PathBuf, String> {
    let target = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(path.to_path_buf()),
        Err(e) => return Err(format!("cannot look at the file there ({e})")),
        Ok(m) if m.file_type().is_symlink() => std::fs::canonicalize(path)
            .map_err(|e| format!("it is a symbolic link to a file that cannot be reached ({e})"))?,
        Ok(_) => path.to_path_buf(),
    };
    let meta =
        std::fs::metadata(&target).map_err(|e| format!("cannot look at the file there ({e})"))?;
    if meta.is_dir() {
        return Err("it is a folder".to_string());
    }
    if !meta.is_file() {
        return Err(NOT_REGULAR.to_string());
    }
    Ok(target)
}

/// True if a file written at `a` and one written at `b` would be the same file: the same
/// existing file ([`same_file`]), or the same name in the same folder.
pub fn same_destination(a: &Path, b: &Path) -> bool {
    let place = |p: &Path| {
        let target = write_target(p).ok()?;
        let folder = std::fs::canonicalize(destination_folder(&target)).ok()?;
        Some((folder, target.file_name()?.to_os_string()))
    };
    same_file(a, b) || matches!((place(a), place(b)), (Some(x), Some(y)) if x == y)
}

/// True if `a` and `b` are the same file, whatever the paths (links, `..`, hard links);
/// false where either cannot be looked at.
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        #[cfg(unix)]
        (Ok(a), Ok(b)) => {
            use std::os::unix::fs::MetadataExt as _;
            (a.dev(), a.ino()) == (b.dev(), b.ino())
        }
        #[cfg(not(unix))]
        (Ok(_), Ok(_)) => matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(a), Ok(b)) if a == b
        ),
        _ => false,
    }
}

/// Refuses an output at `output` that is one of the files `inputs` a run read (its scene,
/// data, mesh or material files): writing it would destroy what the run was made from.
/// `what` names the output in the message ("the image", "the statistics").
///
/// # Errors
/// The input `output` would replace, named.
pub fn refuse_to_replace_input(
    output: &Path,
    inputs: &[PathBuf],
    what: &str,
) -> anyhow::Result<()> {
    match inputs.iter().find(|input| same_file(output, input)) {
        Some(input) => anyhow::bail!(
            "{}: {what} would replace the input {}; choose another name",
            output.display(),
            input.display()
        ),
        None => Ok(()),
    }
}

/// A temporary file in `dir`, as [`write_atomically`] makes one (`.strahl-*.tmp`, removed
/// when dropped).
///
/// # Errors
/// Why not, for a message after the path the user named: whether the folder exists, and the
/// system's error without the temporary file's name, which the user never asked for.
pub fn temporary_file_in(dir: &Path) -> Result<tempfile::NamedTempFile, String> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(".strahl-").suffix(".tmp");
    #[cfg(unix)]
    {
        // Like any new file: readable by all, subject to the umask (tempfile defaults to 0600).
        use std::os::unix::fs::PermissionsExt as _;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    builder.tempfile_in(dir).map_err(|e| {
        // tempfile's message is the OS's error followed by ` at path "…"`, the temporary file.
        let text = e.to_string();
        let cause = text.split(" at path ").next().unwrap_or(&text);
        if dir.is_dir() {
            format!("folder {} takes no new file ({cause})", dir.display())
        } else {
            format!("folder {} does not exist ({cause})", dir.display())
        }
    })
}

/// Writes a file through a temporary file in its folder that is renamed into place at the end:
/// readers never see a partial file, and on any error nothing is left at `path` (an existing
/// file there stays as it was). Where `path` is a symbolic link, the file it names is written
/// ([`write_target`]).
///
/// # Errors
/// Any error of `write`, a `path` that [`write_target`] refuses, or an I/O error naming
/// `path`.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<&mut std::fs::File>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let target = write_target(path).map_err(|why| anyhow::anyhow!("{}: {why}", path.display()))?;
    let dir = destination_folder(&target);
    let mut tmp =
        temporary_file_in(&dir).map_err(|why| anyhow::anyhow!("{}: {why}", path.display()))?;
    {
        let mut w = BufWriter::new(tmp.as_file_mut());
        write(&mut w)?;
        w.flush()
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    tmp.as_file()
        .sync_all()
        .with_context(|| format!("{}: cannot write", path.display()))?;
    tmp.persist(&target).map_err(|e| e.error).with_context(|| {
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
/// replaces a file it did not write in the same run unless asked (`--force`). Nor, even
/// with it, what [`write_target`] refuses (a folder, a device, a pipe, a socket).
///
/// # Errors
/// The first file that is there, named, with the option that replaces it, or the first that
/// cannot be replaced, named, with why.
pub fn refuse_to_replace(paths: &[&Path], force: bool) -> anyhow::Result<()> {
    for path in paths {
        write_target(path).map_err(|why| anyhow::anyhow!("{}: {why}", path.display()))?;
    }
    match paths.iter().find(|p| !force && p.exists()) {
        Some(there) => anyhow::bail!(
            "{}: the file is there already and is not replaced; give --force to replace it, or \
             another output",
            there.display()
        ),
        None => Ok(()),
    }
}
