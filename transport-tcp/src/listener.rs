//! A listening worker: masters connect, one session runs at a time, and nobody who merely
//! connects can hold the worker.
//!
//! The accepting thread hands each connection to a thread of its own, at most
//! [`MAX_CONNECTIONS`] at once (more are closed at once, with a line in the report), and
//! accepts at most one connection per [`ACCEPT_PACE`]. A
//! connection must send its first bytes within [`HANDSHAKE_TIMEOUT`] or it is closed; only then
//! does it wait for the session, so silent connections never stand between the worker and its
//! master. A session whose master sends nothing for [`IDLE_TIMEOUT`] ends. The scene cache is
//! shared by the sessions, one after another.

use crate::{serve_stream, SessionError};
use std::io;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Duration;
use strahl_core::worker::{NodeInfo, SceneCache, SessionEnd};

/// How long a new connection may take to send its first bytes before it is closed.
pub const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(10);

/// How long a master may send nothing in a session before the worker ends it.
pub const IDLE_TIMEOUT: Duration = Duration::from_secs(300);

/// Connections a listening worker holds at once (one in session, the others waiting for it or
/// for their first bytes); more are closed at once.
pub const MAX_CONNECTIONS: usize = 8;

/// The shortest time between two accepted connections: at most 500 a second, so a peer that
/// connects in a loop cannot keep the worker busy opening and closing threads.
pub const ACCEPT_PACE: Duration = Duration::from_millis(2);

/// What a report says about one connection.
pub type Report<'r> = &'r mut (dyn FnMut(String, Result<SessionEnd, SessionError>) + Send);

/// Accepts masters on `listener` and serves them one session at a time; `report` is told about
/// each connection (the peer, how it ended). Returns after `sessions` sessions if given, never
/// otherwise.
///
/// # Errors
/// If accepting fails.
pub fn serve_listener(
    listener: &TcpListener,
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
    sessions: Option<u32>,
    report: Report<'_>,
) -> io::Result<()> {
    let wake = wake_address(listener)?;
    let session = Mutex::new(cache);
    let report = Mutex::new(report);
    let served = AtomicU32::new(0);
    let open = AtomicUsize::new(0);
    let done = || sessions.is_some_and(|n| served.load(Ordering::SeqCst) >= n);
    std::thread::scope(|s| {
        while !done() {
            let (stream, peer) = match listener.accept() {
                Ok(c) => c,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if done() {
                break;
            }
            std::thread::sleep(ACCEPT_PACE);
            let peer = peer.to_string();
            let report = &report;
            let tell = move |outcome| {
                let mut r = report.lock().unwrap_or_else(|e| e.into_inner());
                r(peer, outcome);
            };
            if open.fetch_add(1, Ordering::SeqCst) >= MAX_CONNECTIONS {
                open.fetch_sub(1, Ordering::SeqCst);
                let _ = stream.shutdown(Shutdown::Both);
                tell(Err(setup(format!(
                    "refused: {MAX_CONNECTIONS} connections are open already"
                ))));
                continue;
            }
            let (session, served, open, wake) = (&session, &served, &open, &wake);
            s.spawn(move || {
                if done() {
                    open.fetch_sub(1, Ordering::SeqCst);
                    return;
                }
                let outcome = match first_bytes(&stream) {
                    Ok(()) => {
                        let mut cache = session.lock().unwrap_or_else(|e| e.into_inner());
                        let outcome = serve_stream(stream, node, &mut cache);
                        served.fetch_add(1, Ordering::SeqCst);
                        if done() {
                            // The accepting thread waits in `accept`: a connection wakes it.
                            let _ = TcpStream::connect(wake);
                        }
                        outcome
                    }
                    Err(e) => Err(e),
                };
                open.fetch_sub(1, Ordering::SeqCst);
                tell(outcome);
            });
        }
        Ok(())
    })
}

/// Where a connection to `listener` from this machine goes (its port on loopback when it
/// listens on every address).
fn wake_address(listener: &TcpListener) -> io::Result<SocketAddr> {
    let mut address = listener.local_addr()?;
    if address.ip().is_unspecified() {
        let loopback: IpAddr = match address {
            SocketAddr::V4(_) => Ipv4Addr::LOCALHOST.into(),
            SocketAddr::V6(_) => Ipv6Addr::LOCALHOST.into(),
        };
        address.set_ip(loopback);
    }
    Ok(address)
}

/// Waits up to [`HANDSHAKE_TIMEOUT`] for the connection's first bytes.
fn first_bytes(stream: &TcpStream) -> Result<(), SessionError> {
    let mut byte = [0u8; 1];
    stream
        .set_read_timeout(Some(HANDSHAKE_TIMEOUT))
        .map_err(SessionError::Setup)?;
    match stream.peek(&mut byte) {
        Ok(0) => Err(setup("the peer closed before it said anything".to_string())),
        Ok(_) => Ok(()),
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
            ) =>
        {
            let _ = stream.shutdown(Shutdown::Both);
            Err(setup(format!(
                "closed: nothing arrived within {} s of connecting",
                HANDSHAKE_TIMEOUT.as_secs()
            )))
        }
        Err(e) => Err(SessionError::Setup(e)),
    }
}

fn setup(message: String) -> SessionError {
    SessionError::Setup(io::Error::other(message))
}
