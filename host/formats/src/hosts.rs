//! FART's hosts file: the machines a master uses, one `host[:port]` per line.
//!
//! `#` starts a comment (to the end of the line); blank lines are skipped; surrounding spaces
//! are ignored. A host without a port gets [`strahl_tcp::DEFAULT_PORT`]. Errors name the line.

use crate::error::LoadError;
use crate::lines::read_text;
use std::path::Path;

/// One host of a hosts file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostEntry {
    /// `host:port`.
    pub endpoint: String,
    /// Just the host part, as written (for `{host}` in a launch template).
    pub host: String,
    /// The 1-based line it is on.
    pub line: usize,
}

/// Reads and parses a hosts file.
///
/// # Errors
/// [`LoadError::Io`] if it cannot be read, [`LoadError::At`] for a line that is not
/// `host[:port]`, [`LoadError::File`] if it names no host.
pub fn read_hosts_file(path: &Path) -> Result<Vec<HostEntry>, LoadError> {
    let text = read_text(path)?;
    let hosts = parse_hosts(&text, path)?;
    if hosts.is_empty() {
        return Err(LoadError::File {
            path: path.to_path_buf(),
            message: "the hosts file names no host".to_string(),
        });
    }
    Ok(hosts)
}

/// Parses the text of a hosts file read from `path`.
///
/// # Errors
/// [`LoadError::At`] for the first line that is not `host[:port]`.
pub fn parse_hosts(text: &str, path: &Path) -> Result<Vec<HostEntry>, LoadError> {
    let mut hosts = Vec::new();
    for (i, raw) in text.trim_start_matches('\u{feff}').lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let at = |message: String| LoadError::At {
            path: path.to_path_buf(),
            line: i + 1,
            message,
        };
        let endpoint = strahl_tcp::parse_endpoint(line).map_err(at)?;
        let host = match endpoint.rsplit_once(':') {
            Some((h, _)) => h.trim_start_matches('[').trim_end_matches(']').to_string(),
            None => endpoint.clone(),
        };
        check_host(&host).map_err(at)?;
        hosts.push(HostEntry {
            endpoint,
            host,
            line: i + 1,
        });
    }
    Ok(hosts)
}

/// The longest host name (RFC 1035: 253 characters written out).
const MAX_NAME: usize = 253;
/// The longest part of a host name between dots (RFC 1035).
const MAX_LABEL: usize = 63;

/// Checks that `host` can only be a host name or address. A host goes into launch commands
/// (`ssh {host} ...`): only what names and addresses are made of, and no leading `-`, which a
/// command would read as an option. Messages quote the host in backticks, which the program's
/// error printer shortens where it is long.
fn check_host(host: &str) -> Result<(), String> {
    if let Some(c) = host.chars().find(|&c| !is_host_char(c)) {
        return Err(format!(
            "`{host}` is not a host name or address (`{}` is not allowed in one)",
            c.escape_default()
        ));
    }
    if host.starts_with('-') {
        return Err(format!(
            "`{host}` is not a host name or address (it must not start with `-`, which a \
             launch command would read as an option)"
        ));
    }
    if host.len() > MAX_NAME {
        return Err(format!(
            "`{host}` is not a host name: {} characters, at most {MAX_NAME}",
            host.len()
        ));
    }
    if !host.contains(':') {
        if let Some(label) = host.split('.').find(|l| l.len() > MAX_LABEL) {
            return Err(format!(
                "`{host}` is not a host name: its part `{}` has {} characters, at most \
                 {MAX_LABEL}",
                label,
                label.len()
            ));
        }
    }
    Ok(())
}

/// Letters, digits, `.`, `-`, `_` and, in IPv6 addresses, `:` and `%` (a zone).
fn is_host_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_' | ':' | '%')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_that_are_not_host_names_are_refused() {
        for bad in ["x;touch${IFS}pwned;echo", "a$(id)", "h`x`", "n\\1", "h'q"] {
            let err = parse_hosts(&format!("ok\n{bad}\n"), Path::new("h.txt"));
            let Err(LoadError::At { line, message, .. }) = err else {
                panic!("{bad}: {err:?}");
            };
            assert_eq!(line, 2, "{bad}");
            assert!(
                message.contains("host name") || message.contains("host:port"),
                "{message}"
            );
        }
    }

    #[test]
    fn options_and_overlong_names_are_refused() {
        let long_label = "a".repeat(64);
        let long_name = ["b", "c", "d", "e", "k"].map(|c| c.repeat(60)).join(".");
        let huge = "f".repeat(5000);
        for (bad, says) in [
            ("-G", "must not start with `-`"),
            ("-oProxy:22", "must not start with `-`"),
            (long_label.as_str(), "at most 63"),
            (long_name.as_str(), "at most 253"),
            (huge.as_str(), "at most 253"),
        ] {
            let err = parse_hosts(&format!("ok\n{bad}\n"), Path::new("h.txt"));
            let Err(LoadError::At { line, message, .. }) = err else {
                panic!("{bad}: {err:?}");
            };
            assert_eq!(line, 2, "{bad}");
            assert!(message.contains(says), "{bad}: {message}");
        }
        let fits = [
            "g".repeat(63),
            "h".repeat(63),
            "i".repeat(63),
            "j".repeat(61),
        ]
        .join(".");
        assert_eq!(fits.len(), 253);
        assert!(parse_hosts(&format!("{fits}\nnode-1\n"), Path::new("h.txt")).is_ok());
    }

    #[test]
    fn parses_hosts_with_comments_and_ports() -> Result<(), LoadError> {
        let text = "# cluster\nnode1\n  node2:9000  # fast one\n\n[::1]:7\n";
        let hosts = parse_hosts(text, Path::new("h.txt"))?;
        let got: Vec<(&str, &str, usize)> = hosts
            .iter()
            .map(|h| (h.endpoint.as_str(), h.host.as_str(), h.line))
            .collect();
        assert_eq!(
            got,
            [
                ("node1:7415", "node1", 2),
                ("node2:9000", "node2", 3),
                ("[::1]:7", "::1", 5)
            ]
        );
        Ok(())
    }

    #[test]
    fn bad_line_is_named() {
        let err = parse_hosts("node1\nnode2:http\n", Path::new("h.txt"))
            .err()
            .map(|e| e.to_string());
        let msg = err.unwrap_or_default();
        assert!(msg.starts_with("h.txt:2: "), "{msg}");
        assert!(msg.contains("port"), "{msg}");
    }
}
