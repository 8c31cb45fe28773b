//! The simulated cluster: in-process workers with their own speed, link and seeded faults.
//!
//! Each simulated worker is the real worker loop on a thread, behind an in-process pipe whose
//! two directions follow a [`LinkModel`] (latency, bandwidth, bit flips). A [`Fault`] wraps the
//! worker's end of the link: it can crash (the link closes), hang (stops answering), run
//! slower than the machine, or send wrong pixels. Tests use it to run the real master against 64 and more workers,
//! with failures, in seconds.

use crate::cluster::link::Link;
use crate::cluster::pipe::{duplex, LinkModel, PipeCloser, PipeEnd};
use crate::util::secret::random_nonce;
use crate::util::sys::POLL_INTERVAL;
use embedded_io::{ErrorKind, ErrorType, Read, Write};
use embedded_io_adapters::std::FromStd;
use std::time::Instant;
use strahl_core::wire::frame::FrameWriter;
use strahl_core::wire::message::WorkerMessage;
use strahl_core::worker::{
    serve, serve_with, LineBuffers, LineRequest, NodeInfo, Outbox, SceneCache, WorkerError,
};

/// What goes wrong with a simulated worker.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Fault {
    /// Nothing.
    #[default]
    None,
    /// The worker dies (its link closes) when it is about to send its `n`-th frame (its `Hello`
    /// is frame 1, its `Ready` frame 2, line results follow).
    CrashAt(u32),
    /// The worker stops answering, link open, when it is about to send its `n`-th frame.
    HangAt(u32),
    /// The worker takes `factor` times as long per frame as the machine does.
    Slow(f64),
    /// The worker speaks the protocol correctly but sends wrong pixels: the first channel of
    /// the first pixel of every line result is off by one.
    WrongPixels,
}

/// The outbox of a [`Fault::WrongPixels`] worker: renders like [`strahl_core::worker::Inline`],
/// then changes one pixel. Public for tests that put a lying worker behind other transports.
#[derive(Default)]
pub struct Liar {
    writer: FrameWriter,
    buffers: LineBuffers,
    pixels: Vec<u8>,
}

impl<L: Write> Outbox<L> for Liar {
    fn send(&mut self, link: &mut L, msg: &WorkerMessage<'_>) -> Result<(), WorkerError> {
        Ok(self.writer.send(link, msg)?)
    }

    fn render(&mut self, link: &mut L, request: LineRequest<'_>) -> Result<(), WorkerError> {
        let answer = self.buffers.answer(request)?;
        let WorkerMessage::LineResult {
            job,
            line,
            refined,
            rays,
            pixels,
        } = answer
        else {
            return Ok(self.writer.send(link, &answer)?);
        };
        self.pixels.clear();
        self.pixels.extend_from_slice(pixels);
        if let Some(b) = self.pixels.first_mut() {
            *b ^= 1;
        }
        let lie = WorkerMessage::LineResult {
            job,
            line,
            refined,
            rays,
            pixels: &self.pixels,
        };
        Ok(self.writer.send(link, &lie)?)
    }
}

/// One simulated worker.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SimWorker {
    /// Its fault.
    pub fault: Fault,
    /// The link from the master to it.
    pub down: LinkModel,
    /// The link from it to the master.
    pub up: LinkModel,
}

/// The worker's end of the link, with its fault applied before each frame it sends.
struct FaultyLink {
    inner: FromStd<PipeEnd>,
    closer: PipeCloser,
    fault: Fault,
    /// Frames begun so far.
    frames: u32,
    /// The next write starts a frame (the frame writer writes a frame, then flushes).
    frame_start: bool,
    last_read: Instant,
}

impl ErrorType for FaultyLink {
    type Error = ErrorKind;
}

impl Read for FaultyLink {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        let n = self
            .inner
            .read(buf)
            .map_err(|e| embedded_io::Error::kind(&e))?;
        self.last_read = Instant::now();
        Ok(n)
    }
}

impl Write for FaultyLink {
    fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
        if self.frame_start {
            self.frame_start = false;
            self.before_frame()?;
        }
        self.inner
            .write(buf)
            .map_err(|e| embedded_io::Error::kind(&e))
    }

    fn flush(&mut self) -> Result<(), ErrorKind> {
        self.frame_start = true;
        self.inner.flush().map_err(|e| embedded_io::Error::kind(&e))
    }
}

impl FaultyLink {
    /// Applies the fault as a frame begins.
    fn before_frame(&mut self) -> Result<(), ErrorKind> {
        self.frames += 1;
        match self.fault {
            Fault::CrashAt(n) if self.frames >= n => {
                self.closer.close();
                Err(ErrorKind::BrokenPipe)
            }
            Fault::HangAt(n) if self.frames >= n => {
                while !self.closer.is_closed() {
                    std::thread::sleep(POLL_INTERVAL);
                }
                Err(ErrorKind::BrokenPipe)
            }
            Fault::Slow(factor) => {
                // The time since the request arrived is the machine's time for the frame.
                let spent = self.last_read.elapsed();
                std::thread::sleep(spent.mul_f64((factor - 1.0).max(0.0)));
                Ok(())
            }
            Fault::None | Fault::CrashAt(_) | Fault::HangAt(_) | Fault::WrongPixels => Ok(()),
        }
    }
}

/// Starts the simulated worker `spec` as `sim <index>` with a copy of `cache`, and returns the
/// master's link to it.
///
/// # Errors
/// If its thread cannot be started.
pub fn spawn_sim_worker(
    index: usize,
    spec: SimWorker,
    cache: &SceneCache,
) -> std::io::Result<Link> {
    let (master_end, worker_end) = duplex(spec.down, spec.up);
    let closer = worker_end.closer();
    let mut cache = cache.clone();
    std::thread::Builder::new()
        .name(format!("strahl-sim-{index}"))
        .spawn(move || {
            let name = format!("sim-{index}");
            let node = NodeInfo {
                name: &name,
                arch: "simulated",
                scene_memory: u64::MAX,
                threads: 1,
                secret: None,
                nonce: random_nonce,
            };
            let mut link = FaultyLink {
                inner: FromStd::new(worker_end),
                closer,
                fault: spec.fault,
                frames: 0,
                frame_start: true,
                last_read: Instant::now(),
            };
            // A crashed worker's link is closed by its fault; the master sees that.
            let _ = if spec.fault == Fault::WrongPixels {
                serve_with(&mut link, &mut Liar::default(), &node, &mut cache)
            } else {
                serve(&mut link, &node, &mut cache)
            };
        })?;
    Ok(Link::from_pipe(format!("sim {index}"), master_end))
}
