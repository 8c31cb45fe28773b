//! Serial transport for Strahl: opening ports, `PATH[:BAUD]` specs, the worker side of a serial
//! link, and a pseudo-terminal pair for tests without hardware.
//!
//! A serial line carries the same frames as TCP. Line noise is the frames' business (COBS
//! resynchronises, the CRC drops damaged frames); this crate only opens the port with a read
//! time-out, which the frame reader treats as "no data yet". Unix only (serial ports as
//! `/dev/tty*` files).
#![forbid(unsafe_code)]

use embedded_io_adapters::std::FromStd;
use std::time::Duration;
use strahl_core::worker::{serve, NodeInfo, SceneCache, SessionEnd, WorkerError};

pub use serialport::Error;

/// An open serial port.
pub type SerialPort = serialport::TTYPort;

/// The baud rate when none is given.
pub const DEFAULT_BAUD: u32 = 115_200;

/// How long a read waits for a byte before reporting a time-out.
pub const READ_TIMEOUT: Duration = Duration::from_millis(100);

/// Splits `PATH[:BAUD]`. A colon is read as the baud separator only when what follows is all
/// digits, so paths with colons still work.
///
/// # Errors
/// A message if the path is empty or the baud rate is 0 or too large.
pub fn parse_port_spec(spec: &str) -> Result<(String, u32), String> {
    let (path, baud) = match spec.rsplit_once(':') {
        Some((p, b)) if !b.is_empty() && b.bytes().all(|c| c.is_ascii_digit()) => {
            match b.parse::<u32>() {
                Ok(n) if n > 0 => (p, n),
                _ => return Err(format!("`{spec}`: the baud rate must be 1 to {}", u32::MAX)),
            }
        }
        _ => (spec, DEFAULT_BAUD),
    };
    if path.is_empty() {
        return Err(format!("`{spec}` names no serial port"));
    }
    Ok((path.to_string(), baud))
}

/// Opens the serial port at `path` with `baud`, 8N1, no flow control, [`READ_TIMEOUT`].
///
/// # Errors
/// The port's error (missing device, no permission, busy).
pub fn open(path: &str, baud: u32) -> Result<SerialPort, Error> {
    serialport::new(path, baud)
        .timeout(READ_TIMEOUT)
        .open_native()
}

/// A connected pair of pseudo-terminals, standing in for a serial cable in tests.
///
/// # Errors
/// If the system has no pseudo-terminals to give.
pub fn pty_pair() -> Result<(SerialPort, SerialPort), Error> {
    let (mut a, mut b) = serialport::TTYPort::pair()?;
    use serialport::SerialPort as _;
    a.set_timeout(READ_TIMEOUT)?;
    b.set_timeout(READ_TIMEOUT)?;
    Ok((a, b))
}

/// Serves masters over `port` until the link fails: after each session (ended by the master,
/// or a master that went away), the worker waits for the next master's `Hello`. `report` is
/// told how each session ended. Returns after `sessions` sessions if given.
///
/// # Errors
/// A session's error other than a refused session (another protocol version, a master without
/// the secret, a master that rejected this worker), which is reported and waited through.
pub fn serve_port(
    port: SerialPort,
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
    sessions: Option<u32>,
    report: &mut dyn FnMut(Result<SessionEnd, WorkerError>),
) -> Result<(), WorkerError> {
    let mut link = FromStd::new(port);
    let mut served = 0;
    while sessions.is_none_or(|n| served < n) {
        let outcome = serve(&mut link, node, cache);
        served += 1;
        match outcome {
            Ok(SessionEnd::Closed { .. }) => {
                report(outcome);
                // The other end is gone (a pseudo-terminal whose master closed): nothing more
                // will come on this port.
                return Ok(());
            }
            // A session refused either way ends; the worker waits for the next master.
            Ok(SessionEnd::Ended)
            | Err(
                WorkerError::VersionMismatch { .. }
                | WorkerError::Unauthenticated
                | WorkerError::Rejected(_),
            ) => report(outcome),
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn port_specs() {
        assert_eq!(
            parse_port_spec("/dev/ttyUSB0"),
            Ok(("/dev/ttyUSB0".to_string(), DEFAULT_BAUD))
        );
        assert_eq!(
            parse_port_spec("/dev/ttyUSB0:9600"),
            Ok(("/dev/ttyUSB0".to_string(), 9600))
        );
        assert_eq!(
            parse_port_spec("/dev/serial/by-path/pci-0:1.0:x"),
            Ok(("/dev/serial/by-path/pci-0:1.0:x".to_string(), DEFAULT_BAUD))
        );
        assert!(parse_port_spec(":9600").is_err());
        assert!(parse_port_spec("/dev/x:0").is_err());
        assert!(parse_port_spec("/dev/x:99999999999").is_err());
    }
}
