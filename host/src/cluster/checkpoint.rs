//! The checkpoint of a render: every result the master uses, appended to a file beside the
//! output as it arrives, so a render killed or interrupted can go on where it stopped
//! (`strahl render ... --resume`) and end byte-identical to one that was never stopped.
//!
//! The file is the wire protocol's framing put to a second use: a header frame that ties it to
//! the scene (the digest of the scene's encoding, which covers every setting, and the image
//! size), then one `LineResult` frame per task used (first pass or second pass), each with its
//! CRC-32. Records are appended with one write each, so a killed process leaves at most one
//! partial record at the end; reading drops it (and any record that fails its CRC) and the
//! task is rendered again. On resume the records are replayed through the master's session as
//! if they had just arrived, so adaptive multisampling's decisions come out the same.

use crate::cluster::job::ClusterJob;
use anyhow::{bail, Context as _};
use serde::{Deserialize, Serialize};
use std::fs::{File, OpenOptions};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_core::wire::frame::{FrameReader, FrameWriter, LinkError, ReadEvent};
use strahl_core::wire::message::{decode_pixels, encode_pixels, Digest, WorkerMessage};
use strahl_core::wire::{MAX_FRAME_LEN, PIXEL_WIRE_BYTES};

/// What the first frame of a checkpoint says.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
struct Header {
    /// `STRAHL-CHECKPOINT`, the format's name.
    magic: [u8; 17],
    /// The format's version.
    version: u32,
    /// The digest of the scene's encoding (scene, settings, octree parameters).
    digest: Digest,
    width: u32,
    height: u32,
}

const MAGIC: [u8; 17] = *b"STRAHL-CHECKPOINT";
const VERSION: u32 = 1;

/// One result the master used: task number (first passes `0..height`, second passes after), its
/// rays and pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// The task's number ([`crate::cluster::schedule::Task::index`]).
    pub task: u32,
    /// Rays the result took.
    pub rays: RayCounts,
    /// The line's pixels.
    pub pixels: Vec<Pixel>,
}

/// An open checkpoint, appended to as results are used.
#[derive(Debug)]
pub struct Checkpoint {
    path: PathBuf,
    file: File,
    frames: FrameWriter,
    wire: Vec<u8>,
    height: u32,
    /// Results in the file (those it was resumed with included).
    records: usize,
}

/// The checkpoint of a render that writes `output`: `OUTPUT.checkpoint`.
pub fn checkpoint_path(output: &Path) -> PathBuf {
    let mut name = output.as_os_str().to_owned();
    name.push(".checkpoint");
    PathBuf::from(name)
}

fn header(job: &ClusterJob) -> Header {
    Header {
        magic: MAGIC,
        version: VERSION,
        digest: job.blob.digest,
        width: job.width,
        height: job.height,
    }
}

impl Checkpoint {
    /// The checkpoint of `job` in `file` (at `path`), which holds `records` results.
    fn over(path: &Path, file: File, job: &ClusterJob, records: usize) -> Checkpoint {
        Checkpoint {
            path: path.to_path_buf(),
            file,
            frames: FrameWriter::new(),
            wire: Vec::new(),
            height: job.height,
            records,
        }
    }

    /// Starts a new checkpoint for `job` at `path`, replacing none: a checkpoint already there
    /// belongs to an interrupted render and is kept.
    ///
    /// # Errors
    /// If a checkpoint exists at `path` (the message says to resume or delete it), or the file
    /// cannot be written.
    pub fn create(path: &Path, job: &ClusterJob) -> anyhow::Result<Checkpoint> {
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(path)
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::AlreadyExists => anyhow::anyhow!(
                    "{}: the checkpoint of an interrupted render of this output is there; add \
                     --resume to go on with it, or delete it to start afresh",
                    path.display()
                ),
                _ => anyhow::anyhow!("{}: cannot create the checkpoint: {e}", path.display()),
            })?;
        let mut c = Checkpoint::over(path, file, job, 0);
        let frame = c.frames.encode(&header(job))?.to_vec();
        c.write(&frame)?;
        Ok(c)
    }

    /// Opens the checkpoint at `path` to go on with `job`: checks that it was made for the same
    /// scene and settings and gives the results recorded in it (a partial or damaged record is
    /// dropped).
    ///
    /// # Errors
    /// If there is none, it is not a checkpoint, or it belongs to another scene or settings.
    pub fn resume(path: &Path, job: &ClusterJob) -> anyhow::Result<(Checkpoint, Vec<Record>)> {
        let bytes = std::fs::read(path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => anyhow::anyhow!(
                "{}: no checkpoint to resume from (--resume continues an interrupted render of \
                 the same output)",
                path.display()
            ),
            _ => anyhow::anyhow!("{}: cannot read the checkpoint: {e}", path.display()),
        })?;
        let mut frames = frames_of(&bytes);
        let first = frames.next();
        let found: Option<Header> = first.and_then(|f| postcard::from_bytes(&f).ok());
        let Some(found) = found.filter(|h| h.magic == MAGIC && h.version == VERSION) else {
            bail!("{}: not a Strahl checkpoint", path.display());
        };
        if found != header(job) {
            bail!(
                "{}: this checkpoint was made for another scene or other settings (its scene \
                 digest or image size differs); delete it, or render without --resume to \
                 another output",
                path.display()
            );
        }
        let records: Vec<Record> = frames.filter_map(|payload| record(&payload, job)).collect();
        let file = OpenOptions::new()
            .append(true)
            .open(path)
            .with_context(|| format!("{}: cannot append to the checkpoint", path.display()))?;
        let mut c = Checkpoint::over(path, file, job, records.len());
        // A partial record at the end is cut off by the delimiter of the next one.
        c.write(&[0])?;
        Ok((c, records))
    }

    /// Appends the result used for task `task`.
    ///
    /// # Errors
    /// If the file cannot be written.
    pub fn append(&mut self, task: u32, rays: RayCounts, pixels: &[Pixel]) -> anyhow::Result<()> {
        self.wire.resize(pixels.len() * PIXEL_WIRE_BYTES, 0);
        encode_pixels(pixels, &mut self.wire)?;
        let (line, refined) = match task.checked_sub(self.height) {
            Some(y) => (y, true),
            None => (task, false),
        };
        let msg = WorkerMessage::LineResult {
            job: 0,
            line,
            refined,
            rays,
            pixels: &self.wire,
        };
        let frame = self.frames.encode(&msg)?.to_vec();
        self.write(&frame)?;
        self.records += 1;
        Ok(())
    }

    /// Results in the file.
    pub fn records(&self) -> usize {
        self.records
    }

    fn write(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        self.file
            .write_all(bytes)
            .with_context(|| format!("{}: cannot write the checkpoint", self.path.display()))
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Removes the file: the render it kept is complete.
    ///
    /// # Errors
    /// If it cannot be removed.
    pub fn remove(self) -> anyhow::Result<()> {
        drop(self.file);
        std::fs::remove_file(&self.path)
            .with_context(|| format!("{}: cannot remove the checkpoint", self.path.display()))
    }
}

/// The intact frames of a checkpoint's bytes, as payloads.
fn frames_of(bytes: &[u8]) -> impl Iterator<Item = Vec<u8>> + '_ {
    let mut link = bytes;
    let mut reader = FrameReader::new(vec![0u8; MAX_FRAME_LEN]);
    std::iter::from_fn(move || loop {
        match reader.next(&mut link) {
            Ok(ReadEvent::Frame(p)) => return Some(p.to_vec()),
            Ok(ReadEvent::Dropped(_)) => {}
            Err(LinkError::TimedOut) => {}
            Err(_) => return None,
        }
    })
}

/// A record from a frame's payload, if it is a line result that fits `job`.
fn record(payload: &[u8], job: &ClusterJob) -> Option<Record> {
    let WorkerMessage::LineResult {
        line,
        refined,
        rays,
        pixels,
        ..
    } = WorkerMessage::decode(payload).ok()?
    else {
        return None;
    };
    if line >= job.height || (refined && job.adaptive.is_none()) {
        return None;
    }
    let mut out = vec![Pixel::default(); job.width as usize];
    decode_pixels(pixels, &mut out).ok()?;
    let task = if refined { job.height + line } else { line };
    Some(Record {
        task,
        rays,
        pixels: out,
    })
}
