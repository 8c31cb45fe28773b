//! A master's connection to one worker, whatever carries it.
//!
//! A [`Link`] is two byte streams and a way to cut them: TCP sockets, serial ports and
//! in-process pipes all become one, so the master has one code path for every transport.

use crate::cluster::pipe::PipeEnd;
use std::fmt;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// What carries a link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkKind {
    /// A worker thread in this process.
    InProcess,
    /// A TCP connection.
    Tcp,
    /// A serial port.
    Serial,
}

impl fmt::Display for LinkKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LinkKind::InProcess => "local",
            LinkKind::Tcp => "tcp",
            LinkKind::Serial => "serial",
        })
    }
}

/// A connection to one worker.
pub struct Link {
    /// How the user knows the worker before it says its name: `local 3`, `10.0.0.7:7415`,
    /// `/dev/ttyUSB0`.
    pub address: String,
    /// What carries it.
    pub kind: LinkKind,
    /// Bytes from the worker.
    pub reader: Box<dyn Read + Send>,
    /// Bytes to the worker.
    pub writer: Box<dyn Write + Send>,
    /// Cuts the link: blocked reads and writes return.
    pub closer: Box<dyn Fn() + Send + Sync>,
    /// Ends the master's side after its last frame, while the worker's frames can still be read
    /// until the worker closes its end. Over TCP this shuts down writing only: a socket closed
    /// with unread data sends a reset, which can destroy the worker's last unread frame (the
    /// `EndSession` it is waiting for).
    pub hang_up: Box<dyn Fn() + Send + Sync>,
}

impl fmt::Debug for Link {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Link")
            .field("address", &self.address)
            .field("kind", &self.kind)
            .finish_non_exhaustive()
    }
}

impl Link {
    /// A link over the master's end of an in-process pipe.
    pub fn from_pipe(address: String, end: PipeEnd) -> Self {
        let closer = end.closer();
        let hang_up = end.closer();
        let (reader, writer) = end.split();
        Link {
            address,
            kind: LinkKind::InProcess,
            reader: Box::new(reader),
            writer: Box::new(writer),
            closer: Box::new(move || closer.close()),
            // In-process pipes keep what was written until it is read: closing is graceful.
            hang_up: Box::new(move || hang_up.close()),
        }
    }

    /// A link over a connected TCP stream (Nagle's algorithm off: frames are small).
    ///
    /// # Errors
    /// If the socket cannot be configured or duplicated.
    pub fn from_tcp(address: String, stream: std::net::TcpStream) -> std::io::Result<Self> {
        stream.set_nodelay(true)?;
        let reader = stream.try_clone()?;
        let closer = stream.try_clone()?;
        let hang_up = stream.try_clone()?;
        Ok(Link {
            address,
            kind: LinkKind::Tcp,
            reader: Box::new(std::io::BufReader::with_capacity(1 << 16, reader)),
            writer: Box::new(stream),
            closer: Box::new(move || {
                let _ = closer.shutdown(std::net::Shutdown::Both);
            }),
            hang_up: Box::new(move || {
                let _ = hang_up.shutdown(std::net::Shutdown::Write);
            }),
        })
    }

    /// This link, counted in `live` while its reader is alive: one more now, one less when the
    /// master's reader thread ends with the link.
    pub fn counted(mut self, live: Arc<AtomicUsize>) -> Self {
        live.fetch_add(1, Ordering::SeqCst);
        self.reader = Box::new(Counted {
            inner: self.reader,
            live,
        });
        self
    }

    /// A link over an open serial port. Its reads time out; the master treats that as "no data
    /// yet". Closing stops the master's reader at its next time-out.
    ///
    /// # Errors
    /// If the port cannot be duplicated.
    pub fn from_serial(
        address: String,
        port: strahl_serial::SerialPort,
    ) -> Result<Self, strahl_serial::Error> {
        let reader = port.try_clone_native()?;
        let closed = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let flag = std::sync::Arc::clone(&closed);
        let hang_up_flag = std::sync::Arc::clone(&closed);
        let writer = PatientWriter {
            inner: port,
            closed: std::sync::Arc::clone(&closed),
        };
        Ok(Link {
            address,
            kind: LinkKind::Serial,
            reader: Box::new(ClosableReader {
                inner: reader,
                closed,
            }),
            writer: Box::new(writer),
            closer: Box::new(move || flag.store(true, std::sync::atomic::Ordering::Relaxed)),
            // A serial line has no reset: the worker reads what was sent whatever the master does.
            hang_up: Box::new(move || {
                hang_up_flag.store(true, std::sync::atomic::Ordering::Relaxed);
            }),
        })
    }
}

/// A reader counted in a number of live links (see [`Link::counted`]).
struct Counted {
    inner: Box<dyn Read + Send>,
    live: Arc<AtomicUsize>,
}

impl Read for Counted {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.inner.read(buf)
    }
}

impl Drop for Counted {
    fn drop(&mut self) {
        self.live.fetch_sub(1, Ordering::SeqCst);
    }
}

/// A serial port's writer that waits through the port's time-outs: a slow line (a board that
/// takes a byte at a time) is not a broken one. A worker that stops reading for good is
/// dropped by the master's worker time-out, which closes the link and ends the wait.
struct PatientWriter<W> {
    inner: W,
    closed: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl<W: Write> Write for PatientWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        loop {
            match self.inner.write(buf) {
                Err(e)
                    if e.kind() == std::io::ErrorKind::TimedOut
                        && !self.closed.load(std::sync::atomic::Ordering::Relaxed) => {}
                other => return other,
            }
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        loop {
            match self.inner.flush() {
                Err(e)
                    if e.kind() == std::io::ErrorKind::TimedOut
                        && !self.closed.load(std::sync::atomic::Ordering::Relaxed) => {}
                other => return other,
            }
        }
    }
}

/// A reader that reports end of stream once closed (for ports whose reads cannot be cut).
struct ClosableReader<R> {
    inner: R,
    closed: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl<R: Read> Read for ClosableReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.closed.load(std::sync::atomic::Ordering::Relaxed) {
            return Ok(0);
        }
        self.inner.read(buf)
    }
}
