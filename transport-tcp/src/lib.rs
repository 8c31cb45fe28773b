//! TCP transport for Strahl: endpoints, connecting, and the worker side of a TCP link.
//!
//! The master's side of a connection is a plain [`TcpStream`] (the host wraps it into its link
//! type); the worker's side runs the core's worker session over the stream, rendering on the
//! node's threads ([`threads`]). Frames are small and latency-bound, so every stream has
//! Nagle's algorithm off.
//!
//! Workers either listen ([`serve_listener`]: one session at a time, with limits on who may
//! hold a connection, [`listener`]) or dial a
//! master that listens ([`dial`]), which suits batch schedulers and NAT.
#![forbid(unsafe_code)]

pub mod listener;
pub mod threads;

pub use listener::serve_listener;

use std::io::{self, BufReader};
use std::net::{Shutdown, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use strahl_core::worker::{NodeInfo, SceneCache, SessionEnd, WorkerError};

/// How long one attempt to connect may take before it counts as failed.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);

/// How long a dialling worker waits before it tries its master again.
const REDIAL_INTERVAL: Duration = Duration::from_millis(200);

/// The port workers listen on and masters dial when an address names none.
pub const DEFAULT_PORT: u16 = 7415;

/// The forms an address takes, for error messages.
pub const ADDRESS_FORMS: &str = "PORT, :PORT, HOST or HOST:PORT, for example 7415, :7415, \
                                 node1, node1:7415, 0.0.0.0:7415 or [::1]:7415";

/// `host`, `host:port`, `[v6]` or `[v6]:port` as `host:port`, with [`DEFAULT_PORT`] when no
/// port is given, and `PORT` or `:PORT` as a port on this machine (`localhost:PORT`): an address
/// to dial.
///
/// # Errors
/// A message if the text is empty, has spaces, or its port is not a number from 1 to 65535.
pub fn parse_endpoint(text: &str) -> Result<String, String> {
    let address = parse_address(text, false)?;
    Ok(match address.strip_prefix(':') {
        Some(port) => format!("localhost:{port}"),
        None => address,
    })
}

/// Like [`parse_endpoint`], for an address to listen on: port 0 (any free port) is allowed,
/// and `PORT` or `:PORT` is given back as `:PORT` (no host): the caller chooses the interfaces.
///
/// # Errors
/// A message if the text is empty, has spaces, or its port is not a number from 0 to 65535.
pub fn parse_listen_address(text: &str) -> Result<String, String> {
    parse_address(text, true)
}

fn parse_address(text: &str, allow_port_0: bool) -> Result<String, String> {
    let text = text.trim();
    if text.is_empty() || text.contains(char::is_whitespace) {
        return Err(format!(
            "`{text}` is not an address: expected {ADDRESS_FORMS}"
        ));
    }
    let bare_port = text.strip_prefix(':').unwrap_or(text);
    if !bare_port.is_empty() && bare_port.bytes().all(|b| b.is_ascii_digit()) {
        return Ok(format!(":{}", parse_port(text, bare_port, allow_port_0)?));
    }
    let (host, port) = split_host_port(text)?;
    if host.is_empty() || host == "[]" {
        return Err(format!("`{text}` names no host: expected {ADDRESS_FORMS}"));
    }
    let port = match port {
        None => DEFAULT_PORT,
        Some(p) => parse_port(text, p, allow_port_0)?,
    };
    Ok(format!("{host}:{port}"))
}

/// `text`'s host and port, if it names one (`[v6]` keeps its brackets).
fn split_host_port(text: &str) -> Result<(String, Option<&str>), String> {
    if let Some(rest) = text.strip_prefix('[') {
        let Some((v6, after)) = rest.split_once(']') else {
            return Err(format!(
                "`{text}`: missing `]` after an IPv6 address (for example [::1]:7415)"
            ));
        };
        return match after.strip_prefix(':') {
            Some(port) => Ok((format!("[{v6}]"), Some(port))),
            None if after.is_empty() => Ok((format!("[{v6}]"), None)),
            None => Err(format!(
                "`{text}`: expected `:PORT` after `]` (for example [::1]:7415)"
            )),
        };
    }
    match text.rsplit_once(':') {
        Some((h, _)) if h.contains(':') => Err(format!(
            "`{text}`: write IPv6 addresses in brackets, for example [::1]:7415"
        )),
        Some((h, p)) => Ok((h.to_string(), Some(p))),
        None => Ok((text.to_string(), None)),
    }
}

/// The port `p` of address `text`.
fn parse_port(text: &str, p: &str, allow_port_0: bool) -> Result<u16, String> {
    match p.parse::<u16>() {
        Ok(n) if n > 0 || allow_port_0 => Ok(n),
        _ => {
            let low = if allow_port_0 { 0 } else { 1 };
            Err(format!(
                "`{text}`: the port must be a number from {low} to 65535 (for example 7415)"
            ))
        }
    }
}

/// Connects to `endpoint` (`host:port`), trying each address it resolves to, each within
/// `timeout`, with Nagle's algorithm off.
///
/// # Errors
/// The last connection error, or one saying the name did not resolve.
pub fn connect(endpoint: &str, timeout: Duration) -> io::Result<TcpStream> {
    let mut last = io::Error::new(
        io::ErrorKind::NotFound,
        format!("{endpoint} resolves to no address"),
    );
    for addr in endpoint.to_socket_addrs()? {
        match TcpStream::connect_timeout(&addr, timeout) {
            Ok(stream) => {
                stream.set_nodelay(true)?;
                return Ok(stream);
            }
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// Serves one master over a connected stream, rendering on `node.threads` threads
/// ([`threads::serve_threaded`]). The master has [`listener::HANDSHAKE_TIMEOUT`] from the
/// session's start to finish the handshake (greet, and prove the secret when the worker has
/// one), then [`listener::IDLE_TIMEOUT`] between frames: a peer that greets and goes silent
/// holds a worker no longer than one that says nothing.
///
/// # Errors
/// The stream cannot be set up, or what the session reports.
pub fn serve_stream(
    stream: TcpStream,
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
) -> Result<SessionEnd, SessionError> {
    let established = Arc::new(AtomicBool::new(false));
    let timed_out = Arc::new(Mutex::new(None));
    let setup = || -> io::Result<_> {
        stream.set_nodelay(true)?;
        let silence = Silence {
            stream: stream.try_clone()?,
            established: Arc::clone(&established),
            timed_out: Arc::clone(&timed_out),
            deadline: Instant::now() + listener::HANDSHAKE_TIMEOUT,
            idle: false,
        };
        Ok((
            BufReader::with_capacity(1 << 16, silence),
            stream.try_clone()?,
        ))
    };
    let (reader, writer) = setup().map_err(SessionError::Setup)?;
    let hang_up = || {
        // Already closed or never connected: nothing left to end.
        let _ = stream.shutdown(Shutdown::Both);
    };
    let greeted = || established.store(true, Ordering::SeqCst);
    let threads = node.threads as usize;
    let outcome = threads::serve_threaded(reader, writer, &hang_up, &greeted, node, cache, threads)
        .map_err(SessionError::Worker);
    let why = timed_out.lock().unwrap_or_else(|e| e.into_inner()).take();
    match why {
        Some(why) => Err(SessionError::TimedOut(why)),
        None => outcome,
    }
}

/// A stream whose read time-outs end the session: the worker loop waits through time-outs (a
/// serial port says nothing for long), so a TCP master that has not finished its handshake by
/// `deadline`, or is silent for [`listener::IDLE_TIMEOUT`] after it, is reported as gone.
struct Silence {
    stream: TcpStream,
    /// Set when the handshake is over.
    established: Arc<AtomicBool>,
    /// Why the session was cut off, once it was.
    timed_out: Arc<Mutex<Option<String>>>,
    /// When the handshake must be over.
    deadline: Instant,
    /// The read time-out is the idle one already.
    idle: bool,
}

impl io::Read for Silence {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let greeting = !self.established.load(Ordering::SeqCst);
        let timeout = if greeting {
            self.deadline.saturating_duration_since(Instant::now())
        } else {
            listener::IDLE_TIMEOUT
        };
        if greeting || !self.idle {
            self.idle = !greeting;
            // A zero time-out means none: past the deadline, one more millisecond.
            self.stream
                .set_read_timeout(Some(timeout.max(Duration::from_millis(1))))?;
        }
        self.stream.read(buf).map_err(|e| {
            if !matches!(
                e.kind(),
                io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
            ) {
                return e;
            }
            let why = if greeting {
                format!(
                    "the master did not finish its handshake within {} s",
                    listener::HANDSHAKE_TIMEOUT.as_secs()
                )
            } else {
                format!(
                    "the master sent nothing for {} s",
                    listener::IDLE_TIMEOUT.as_secs()
                )
            };
            *self.timed_out.lock().unwrap_or_else(|e| e.into_inner()) = Some(why.clone());
            io::Error::new(io::ErrorKind::ConnectionAborted, why)
        })
    }
}

/// Why a TCP session ended abnormally.
#[derive(Debug)]
pub enum SessionError {
    /// The stream could not be set up.
    Setup(io::Error),
    /// The session failed.
    Worker(WorkerError),
    /// The master took too long (to finish its handshake, or between frames): why.
    TimedOut(String),
}

/// Dials a listening master, retrying for up to `patience` while it is not up yet, and serves
/// one session.
///
/// # Errors
/// The last connection error once `patience` is spent, or what the session reports.
pub fn dial(
    endpoint: &str,
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
    patience: Duration,
) -> Result<SessionEnd, SessionError> {
    let start = Instant::now();
    let stream = loop {
        match connect(endpoint, CONNECT_TIMEOUT) {
            Ok(s) => break s,
            Err(e) if start.elapsed() >= patience => return Err(SessionError::Setup(e)),
            Err(_) => std::thread::sleep(REDIAL_INTERVAL),
        }
    };
    serve_stream(stream, node, cache)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints() {
        assert_eq!(parse_endpoint("node1").as_deref(), Ok("node1:7415"));
        assert_eq!(parse_endpoint("node1:99").as_deref(), Ok("node1:99"));
        assert_eq!(parse_endpoint("10.0.0.7").as_deref(), Ok("10.0.0.7:7415"));
        assert_eq!(parse_endpoint("[::1]").as_deref(), Ok("[::1]:7415"));
        assert_eq!(parse_endpoint("[::1]:8").as_deref(), Ok("[::1]:8"));
        assert_eq!(
            parse_listen_address("0.0.0.0:0").as_deref(),
            Ok("0.0.0.0:0")
        );
        assert!(parse_listen_address("0.0.0.0:65536").is_err());
        assert_eq!(parse_endpoint("7418").as_deref(), Ok("localhost:7418"));
        assert_eq!(parse_endpoint(":7418").as_deref(), Ok("localhost:7418"));
        assert_eq!(parse_listen_address("7418").as_deref(), Ok(":7418"));
        assert_eq!(parse_listen_address(":0").as_deref(), Ok(":0"));
        assert!(parse_endpoint("0").is_err());
        assert!(parse_endpoint("70000").is_err());
        for bad in [
            "", "a b", "h:0", "h:70000", "h:x", "::1", "[::1", "[::1]x", ":", ":x",
        ] {
            assert!(parse_endpoint(bad).is_err(), "{bad}");
        }
    }
}
