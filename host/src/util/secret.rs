//! The shared secret of a cluster: where it comes from, how it is kept out of logs, and the
//! fresh nonces of each handshake.
//!
//! A secret is read from a file (`--secret-file FILE`) or from the environment variable
//! [`SECRET_ENV`], never from a command-line value, which other users of a machine can see in
//! the process list. A file's trailing line break is not part of the secret. It must be at
//! least [`MIN_SECRET_LEN`] bytes. The proofs are `strahl_core::wire::auth`'s.

use std::fmt;
use std::path::Path;
use strahl_core::wire::auth::{Nonce, MIN_SECRET_LEN};

/// The environment variable that holds the secret when no `--secret-file` is given.
pub const SECRET_ENV: &str = "STRAHL_SECRET";

/// A shared secret; its `Debug` form does not show it.
#[derive(Clone, PartialEq, Eq)]
pub struct Secret(Vec<u8>);

impl Secret {
    /// The secret's bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.0
    }

    /// A secret from `bytes` (a trailing line break dropped); `what` names the source in the
    /// error.
    ///
    /// # Errors
    /// If it is shorter than [`MIN_SECRET_LEN`] bytes.
    pub fn new(mut bytes: Vec<u8>, what: &str) -> anyhow::Result<Secret> {
        while bytes.last().is_some_and(|b| matches!(b, b'\n' | b'\r')) {
            bytes.pop();
        }
        if bytes.len() < MIN_SECRET_LEN {
            anyhow::bail!(
                "{what}: the secret is {} bytes long; use at least {MIN_SECRET_LEN} (for example \
                 `head -c 32 /dev/urandom | base64 > FILE`)",
                bytes.len()
            );
        }
        Ok(Secret(bytes))
    }
}

impl fmt::Debug for Secret {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Secret(..)")
    }
}

/// The secret from `file`, else from [`SECRET_ENV`], else none.
///
/// # Errors
/// If the file cannot be read, or the secret is too short.
pub fn load_secret(file: Option<&Path>) -> anyhow::Result<Option<Secret>> {
    if let Some(path) = file {
        let bytes = std::fs::read(path)
            .map_err(|e| anyhow::anyhow!("{}: cannot read the secret: {e}", path.display()))?;
        return Secret::new(bytes, &path.display().to_string()).map(Some);
    }
    match std::env::var_os(SECRET_ENV) {
        Some(value) => Secret::new(value.into_encoded_bytes(), SECRET_ENV).map(Some),
        None => Ok(None),
    }
}

/// A fresh random nonce from the operating system.
pub fn random_nonce() -> Nonce {
    let mut nonce = [0u8; 32];
    if getrandom::fill(&mut nonce).is_err() {
        // No random source: fall back on the clock and the process, hashed. Unpredictable
        // enough to be fresh, which is what a nonce must be; the secret stays the secret.
        use sha2::{Digest as _, Sha256};
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default();
        let mut h = Sha256::new();
        h.update(now.as_nanos().to_le_bytes());
        h.update(std::process::id().to_le_bytes());
        h.update(format!("{:?}", std::thread::current().id()));
        nonce = h.finalize().into();
    }
    nonce
}

/// Whether `address` (`host:port` as the TCP transport parses it) names only this machine:
/// `localhost`, `127.0.0.0/8` or `[::1]`.
pub fn is_loopback(address: &str) -> bool {
    let host = address.rsplit_once(':').map_or(address, |(h, _)| h);
    let host = host.trim_start_matches('[').trim_end_matches(']');
    host.eq_ignore_ascii_case("localhost")
        || host
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// Where to listen for `endpoint` as [`strahl_tcp::parse_listen_address`] gives it: an
/// address without a host (`PORT`, `:PORT`) means every interface with a secret and this
/// machine only without one (which `who` says); an address with a host goes through
/// [`check_exposure`].
///
/// # Errors
/// As [`check_exposure`].
pub fn listen_endpoint(
    endpoint: &str,
    secret: bool,
    insecure: bool,
    who: &str,
) -> anyhow::Result<String> {
    let Some(port) = endpoint.strip_prefix(':') else {
        check_exposure(endpoint, secret, insecure, who)?;
        return Ok(endpoint.to_string());
    };
    if secret || insecure {
        if !secret {
            check_exposure(&format!("0.0.0.0:{port}"), secret, insecure, who)?;
        }
        return Ok(format!("0.0.0.0:{port}"));
    }
    eprintln!(
        "note: without a shared secret {who} listens on this machine only (127.0.0.1:{port}); \
         give --secret-file FILE (or STRAHL_SECRET) to listen on every interface"
    );
    Ok(format!("127.0.0.1:{port}"))
}

/// Refuses to listen beyond this machine without a secret unless `--insecure`, and warns when
/// it does.
///
/// # Errors
/// A non-loopback `address` with neither a secret nor `--insecure`.
pub fn check_exposure(
    address: &str,
    secret: bool,
    insecure: bool,
    who: &str,
) -> anyhow::Result<()> {
    if secret || is_loopback(address) {
        return Ok(());
    }
    if !insecure {
        anyhow::bail!(
            "--listen {address}: without a shared secret {who} listens only on this machine \
             (127.0.0.1 or [::1]); give --secret-file FILE (or STRAHL_SECRET) to listen on \
             other addresses, or --insecure to accept anyone who can reach the port"
        );
    }
    eprintln!(
        "warning: {who} listens on {address} without a shared secret (--insecure): anyone who \
         can reach the port can use it"
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secrets_are_long_enough_and_never_printed() {
        assert!(Secret::new(b"short\n".to_vec(), "f").is_err());
        let s = Secret::new(b"0123456789abcdef\r\n".to_vec(), "f").expect("16 bytes");
        assert_eq!(s.bytes(), b"0123456789abcdef");
        assert_eq!(format!("{s:?}"), "Secret(..)");
    }

    #[test]
    fn loopback_addresses() {
        for a in ["127.0.0.1:7415", "localhost:1", "[::1]:7415", "127.9.9.9:0"] {
            assert!(is_loopback(a), "{a}");
        }
        for a in ["0.0.0.0:7415", "[::]:7415", "10.0.0.1:7", "node1:7415"] {
            assert!(!is_loopback(a), "{a}");
        }
    }

    #[test]
    fn nonces_are_fresh() {
        assert_ne!(random_nonce(), random_nonce());
    }
}
