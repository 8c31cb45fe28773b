//! A listening worker: masters connect, one session runs at a time, and nobody who merely
//! connects can hold the worker.
//!
//! The accepting thread hands each connection to a thread of its own, at most
//! [`MAX_CONNECTIONS`] at once and [`MAX_CONNECTIONS_PER_ADDRESS`] from one address ([`Places`];
//! more are closed at once, with a line in the report), and accepts at most one connection per
//! [`ACCEPT_PACE`]. A
//! connection must send its first bytes within [`HANDSHAKE_TIMEOUT`] or it is closed; only then
//! does it wait for the session, so silent connections never stand between the worker and its
//! master. In the session, the master has [`HANDSHAKE_TIMEOUT`] again to finish the handshake
//! ([`crate::serve_stream`]), then may be silent for [`IDLE_TIMEOUT`] before the session ends.
//! The scene cache is shared by the sessions, one after another.

use crate::{serve_stream, SessionError};
use std::collections::HashMap;
use std::io;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;
use std::time::Duration;
use strahl_core::worker::{NodeInfo, SceneCache, SessionEnd};

/// How long a new connection may take to send its first bytes before it is closed, and a
/// session to finish its handshake before it ends.
pub const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(10);

/// How long a master may send nothing in a session before the worker ends it.
pub const IDLE_TIMEOUT: Duration = Duration::from_secs(300);

/// Connections a listening worker holds at once (one in session, the others waiting for it or
/// for their first bytes); more are closed at once.
pub const MAX_CONNECTIONS: usize = 8;

/// Connections one address may hold at once: half of [`MAX_CONNECTIONS`], so one machine
/// cannot take every place and keep the others' masters out.
pub const MAX_CONNECTIONS_PER_ADDRESS: usize = MAX_CONNECTIONS / 2;

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
    let places = Places::default();
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
            let ip = peer_ip(&stream);
            if let Err(why) = places.take(ip) {
                let _ = stream.shutdown(Shutdown::Both);
                tell(Err(setup(why)));
                continue;
            }
            let (session, served, places, wake) = (&session, &served, &places, &wake);
            s.spawn(move || {
                if done() {
                    places.give_back(ip);
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
                places.give_back(ip);
                tell(outcome);
            });
        }
        Ok(())
    })
}

/// The address a connection comes from (unspecified if the socket cannot say).
fn peer_ip(stream: &TcpStream) -> IpAddr {
    stream
        .peer_addr()
        .map_or(IpAddr::V4(Ipv4Addr::UNSPECIFIED), |a| a.ip())
}

/// The connections held: in all, and per address.
#[derive(Default)]
pub struct Places {
    held: Mutex<HashMap<IpAddr, usize>>,
}

impl Places {
    /// Takes a place for a connection from `ip`, or says why there is none.
    ///
    /// # Errors
    /// A message when [`MAX_CONNECTIONS`] are held, or [`MAX_CONNECTIONS_PER_ADDRESS`] from `ip`.
    pub fn take(&self, ip: IpAddr) -> Result<(), String> {
        let mut held = self.held.lock().unwrap_or_else(|e| e.into_inner());
        if held.values().sum::<usize>() >= MAX_CONNECTIONS {
            return Err(format!(
                "refused: {MAX_CONNECTIONS} connections are open already"
            ));
        }
        let from_ip = held.entry(ip).or_insert(0);
        if *from_ip >= MAX_CONNECTIONS_PER_ADDRESS {
            return Err(format!(
                "refused: {MAX_CONNECTIONS_PER_ADDRESS} connections from {ip} are open already"
            ));
        }
        *from_ip += 1;
        Ok(())
    }

    /// Gives back a place [`Places::take`] gave for `ip`.
    pub fn give_back(&self, ip: IpAddr) {
        let mut held = self.held.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(n) = held.get_mut(&ip) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                held.remove(&ip);
            }
        }
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_address_takes_half_the_places_and_others_the_rest() {
        let places = Places::default();
        let a: IpAddr = "10.0.0.1".parse().expect("an address");
        let b: IpAddr = "10.0.0.2".parse().expect("an address");
        for _ in 0..MAX_CONNECTIONS_PER_ADDRESS {
            assert_eq!(places.take(a), Ok(()));
        }
        let refused = places.take(a).expect_err("a's share is taken");
        assert!(refused.contains("from 10.0.0.1"), "{refused}");
        for _ in 0..MAX_CONNECTIONS - MAX_CONNECTIONS_PER_ADDRESS {
            assert_eq!(places.take(b), Ok(()));
        }
        let c: IpAddr = "10.0.0.3".parse().expect("an address");
        let full = places.take(c).expect_err("every place is taken");
        assert!(full.contains("connections are open already"), "{full}");
        places.give_back(a);
        assert_eq!(places.take(c), Ok(()));
        assert!(places.take(a).is_err(), "the place went to c");
    }
}
