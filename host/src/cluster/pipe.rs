//! In-process byte pipes: the transport of local workers and of the simulated cluster.
//!
//! A [`duplex`] pipe joins two [`PipeEnd`]s. Bytes written at one end are read at the other, in
//! order, as real encoded frames, so in-process workers run exactly the protocol that TCP and
//! serial workers run. Each direction can model a link ([`LinkModel`]): a latency added to every
//! write, a bandwidth that makes writes take time, and seeded bit flips. Closing either end (or
//! dropping it) ends the stream for both: reads return end of stream, writes a broken pipe.

use crate::util::sys::POLL_INTERVAL;
use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How one direction of a pipe behaves.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LinkModel {
    /// Added to the delivery time of every write.
    pub latency: Duration,
    /// If set, a write of `n` bytes blocks the writer for `n / bytes_per_second`.
    pub bytes_per_second: Option<u64>,
    /// If set, each byte has this probability of one flipped bit.
    pub bit_flip_rate: Option<f64>,
    /// Seed of the bit flips.
    pub seed: u64,
}

struct Chunk {
    bytes: Vec<u8>,
    deliver_at: Instant,
}

/// The shared "closed" flag of a pipe; [`PipeCloser::close`] ends both directions.
#[derive(Clone, Debug)]
pub struct PipeCloser(Arc<AtomicBool>);

impl PipeCloser {
    /// Closes the pipe: blocked and later reads return end of stream, writes fail.
    pub fn close(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether the pipe was closed.
    pub fn is_closed(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// The reading half of a pipe end.
pub struct PipeReader {
    rx: Receiver<Chunk>,
    current: Vec<u8>,
    pos: usize,
    closed: PipeCloser,
}

/// The writing half of a pipe end.
pub struct PipeWriter {
    tx: Sender<Chunk>,
    model: LinkModel,
    rng: u64,
    closed: PipeCloser,
}

/// One end of a duplex pipe: reads what the other end writes and the other way round.
pub struct PipeEnd {
    /// Bytes from the other end.
    pub reader: PipeReader,
    /// Bytes to the other end.
    pub writer: PipeWriter,
}

/// A pipe whose `a` end writes through `a_to_b` and whose `b` end writes through `b_to_a`.
pub fn duplex(a_to_b: LinkModel, b_to_a: LinkModel) -> (PipeEnd, PipeEnd) {
    let closed = PipeCloser(Arc::new(AtomicBool::new(false)));
    let (tx_ab, rx_ab) = mpsc::channel();
    let (tx_ba, rx_ba) = mpsc::channel();
    let end = |tx, rx, model: LinkModel| PipeEnd {
        reader: PipeReader {
            rx,
            current: Vec::new(),
            pos: 0,
            closed: closed.clone(),
        },
        writer: PipeWriter {
            tx,
            model,
            rng: model.seed | 1,
            closed: closed.clone(),
        },
    };
    (end(tx_ab, rx_ba, a_to_b), end(tx_ba, rx_ab, b_to_a))
}

impl PipeEnd {
    /// The handle that closes this pipe.
    pub fn closer(&self) -> PipeCloser {
        self.reader.closed.clone()
    }

    /// Splits the end into its halves.
    pub fn split(self) -> (PipeReader, PipeWriter) {
        (self.reader, self.writer)
    }
}

impl Read for PipeReader {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        while self.pos == self.current.len() {
            if self.closed.is_closed() {
                return Ok(0);
            }
            match self.rx.recv_timeout(POLL_INTERVAL) {
                Ok(chunk) => {
                    let now = Instant::now();
                    if chunk.deliver_at > now {
                        std::thread::sleep(chunk.deliver_at - now);
                    }
                    self.current = chunk.bytes;
                    self.pos = 0;
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return Ok(0),
            }
        }
        let n = buf.len().min(self.current.len() - self.pos);
        buf[..n].copy_from_slice(&self.current[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

impl PipeWriter {
    /// The next value of the bit-flip generator (xorshift64*), in `[0, 1)`.
    fn uniform(&mut self) -> f64 {
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        (self.rng.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
}

impl Write for PipeWriter {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if self.closed.is_closed() {
            return Err(io::ErrorKind::BrokenPipe.into());
        }
        let mut bytes = buf.to_vec();
        if let Some(rate) = self.model.bit_flip_rate {
            for b in &mut bytes {
                if self.uniform() < rate {
                    *b ^= 1 << (self.uniform() * 8.0) as u32;
                }
            }
        }
        if let Some(bps) = self.model.bytes_per_second {
            let secs = buf.len() as f64 / bps.max(1) as f64;
            std::thread::sleep(Duration::from_secs_f64(secs));
        }
        let chunk = Chunk {
            bytes,
            deliver_at: Instant::now() + self.model.latency,
        };
        self.tx
            .send(chunk)
            .map_err(|_| io::Error::from(io::ErrorKind::BrokenPipe))?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Read for PipeEnd {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.reader.read(buf)
    }
}

impl Write for PipeEnd {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.writer.flush()
    }
}
