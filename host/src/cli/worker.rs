//! `strahl worker`: serve masters over TCP (listening or dialling) or a serial port.
//!
//! The worker keeps the last scene it prepared across sessions, so a master that renders the
//! same scene again (or the next master with it) skips the transfer. A listening or serial
//! worker outlives its masters: when one ends its session or disappears, it waits for the next.
//! A dialling worker serves one render and exits, which suits launchers and batch schedulers.
//!
//! This module is argument handling: [`WorkerArgs`] become a [`NodeInfo`] (name, architecture,
//! memory) and a choice of transport, and [`run`] hands them to the serving loops of
//! `strahl_tcp` and `strahl_serial`, which run `strahl_core`'s worker protocol; it only turns
//! each session's outcome into a line on stderr. So it lives with the command line, not with the
//! master's side in [`crate::cluster`]. The host name it defaults to comes from
//! [`crate::util::sys`], shared with the master.

use crate::util::secret::{listen_endpoint, load_secret, random_nonce, Secret};
use crate::util::sys::{available_memory, cut_name, host_name};
use anyhow::{anyhow, Context as _};
use clap::{ArgGroup, Args};
use std::net::TcpListener;
use std::path::PathBuf;
use std::time::Duration;
use strahl_core::wire::message::Rejection;
use strahl_core::worker::{NodeInfo, SceneCache, SessionEnd, WorkerError};
use strahl_tcp::SessionError;

/// Arguments of `strahl worker`.
#[derive(Debug, Args)]
#[command(group(ArgGroup::new("transport").required(true).args(["listen", "connect", "serial"])))]
pub struct WorkerArgs {
    /// Listen for masters at HOST[:PORT] (default port 7415; port 0 picks a free one, printed on
    /// stderr) and serve them one after another.
    #[arg(long, value_name = "HOST[:PORT]", value_parser = super::render::listen_arg)]
    pub listen: Option<String>,

    /// Dial the master listening at HOST[:PORT], serve its render, then exit.
    #[arg(long, value_name = "HOST[:PORT]", value_parser = super::render::endpoint_arg)]
    pub connect: Option<String>,

    /// Serve masters on the serial port at PATH.
    #[arg(long, value_name = "PATH")]
    pub serial: Option<String>,

    /// Baud rate of the serial port.
    #[arg(long, value_name = "N", requires = "serial", default_value_t = strahl_serial::DEFAULT_BAUD)]
    pub baud: u32,

    /// The name this worker gives masters [default: the host name].
    #[arg(long, value_name = "NAME", value_parser = worker_name)]
    pub name: Option<String>,

    /// Memory in MiB this worker gives a scene; larger scenes are refused [default: the memory
    /// the system reports available].
    #[arg(long, value_name = "MIB", value_parser = clap::value_parser!(u64).range(1..))]
    pub memory: Option<u64>,

    /// Render threads of a TCP worker (`--listen`, `--connect`) [default: every CPU of the
    /// node]. A serial worker renders on one: its link, not its CPU, is what limits it.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=MAX_THREADS))]
    pub threads: Option<u32>,

    /// Require masters to prove they hold the shared secret in FILE (at least 16 bytes; a
    /// trailing line break is not part of it) [default: the secret in the environment
    /// variable STRAHL_SECRET, if set]. Without a secret, --listen binds only to this machine.
    #[arg(long, value_name = "FILE")]
    pub secret_file: Option<PathBuf>,

    /// Listen on an address other machines can reach without a secret: anyone who reaches the
    /// port can make this worker render.
    #[arg(long)]
    pub insecure: bool,

    /// Stop after serving N sessions (listening and serial workers) [default: never].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub sessions: Option<u32>,

    /// How long a dialling worker keeps trying to reach its master, in seconds.
    #[arg(long, value_name = "SECS", default_value_t = 30)]
    pub patience: u64,
}

/// The most render threads a worker takes (`--threads`).
const MAX_THREADS: i64 = 1024;

fn describe(outcome: &Result<SessionEnd, WorkerError>) -> String {
    match outcome {
        Ok(SessionEnd::Ended) => "the master ended the session".to_string(),
        Ok(SessionEnd::Closed { unreadable: 0 }) => "the master disconnected".to_string(),
        Ok(SessionEnd::Closed { unreadable }) => format!(
            "the master disconnected; {}",
            crate::cluster::session::unreadable_frames(*unreadable)
        ),
        Err(WorkerError::VersionMismatch { master }) => format!(
            "the master speaks protocol version {master}, this worker speaks version {}; \
             session refused",
            strahl_core::wire::PROTOCOL_VERSION
        ),
        Err(WorkerError::Link(e)) => format!("the link failed: {e:?}"),
        Err(WorkerError::Encode(e)) => {
            format!("a reply to the master could not be encoded ({e}); session ended")
        }
        Err(WorkerError::Unauthenticated) => "refused: the master did not prove the shared \
                                              secret (give it the same --secret-file)"
            .to_string(),
        Err(WorkerError::Rejected(r)) => {
            format!("the master rejected this worker: {}", rejection_text(*r))
        }
    }
}

fn describe_tcp(outcome: &Result<SessionEnd, SessionError>) -> String {
    match outcome {
        Ok(end) => describe(&Ok(*end)),
        Err(SessionError::Worker(e)) => describe(&Err(*e)),
        Err(SessionError::Setup(e)) => format!("cannot set up the connection: {e}"),
        Err(SessionError::TimedOut(why)) => why.clone(),
    }
}

/// A master's rejection in words.
fn rejection_text(r: Rejection) -> &'static str {
    match r {
        Rejection::NoProof => "it requires a shared secret; start this worker with --secret-file",
        Rejection::WrongProof => "this worker's secret is not the master's",
        Rejection::MasterHasNoSecret => {
            "this worker requires a shared secret and the master has none (give it the same \
             --secret-file)"
        }
    }
}

/// Listens at `listen` and serves masters (`--listen`), announcing where and how.
///
/// # Errors
/// A bad address, one beyond this machine without a secret or `--insecure`, or one that cannot
/// be bound.
fn serve_listening(
    args: &WorkerArgs,
    listen: &str,
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
) -> anyhow::Result<()> {
    let name = node.name;
    let endpoint = strahl_tcp::parse_listen_address(listen).map_err(|e| anyhow!("--listen {e}"))?;
    let endpoint = listen_endpoint(
        &endpoint,
        node.secret.is_some(),
        args.insecure,
        "this worker",
    )?;
    let listener =
        TcpListener::bind(&endpoint).with_context(|| format!("cannot listen on {endpoint}"))?;
    let addr = listener.local_addr()?;
    let trust = if node.secret.is_some() {
        "masters must prove the shared secret"
    } else {
        "no secret: any master that reaches the port"
    };
    eprintln!(
        "strahl worker {name} ({} threads, {trust}): listening on {addr}",
        node.threads
    );
    strahl_tcp::serve_listener(
        &listener,
        node,
        cache,
        args.sessions,
        &mut |peer, outcome| {
            eprintln!(
                "strahl worker {name}: master {peer}: {}",
                describe_tcp(&outcome)
            );
        },
    )
    .with_context(|| format!("accepting on {addr}"))
}

/// Parses `--name`: not empty, and no control characters (masters show it on their terminal
/// and refuse a `Hello` that holds any).
///
/// # Errors
/// A message saying which.
fn worker_name(s: &str) -> Result<String, String> {
    if s.is_empty() {
        return Err("a worker's name must not be empty".to_string());
    }
    if s.chars().any(char::is_control) {
        return Err(format!(
            "`{}` holds control characters, which a worker's name must not",
            s.escape_default()
        ));
    }
    Ok(s.to_string())
}

/// Runs `strahl worker`.
///
/// # Errors
/// If the address cannot be bound, the master cannot be reached, or the port cannot be opened.
pub fn run(args: &WorkerArgs) -> anyhow::Result<()> {
    let name = args.name.as_deref().map_or_else(host_name, cut_name);
    let memory = args
        .memory
        .map(|mib| mib.saturating_mul(1 << 20))
        .or_else(available_memory)
        .unwrap_or(u64::MAX);
    let threads = match (&args.serial, args.threads) {
        (Some(_), _) => 1,
        (None, Some(n)) => n,
        (None, None) => std::thread::available_parallelism().map_or(1, |n| n.get() as u32),
    };
    let secret = load_secret(args.secret_file.as_deref())?;
    let node = NodeInfo {
        name: &name,
        arch: std::env::consts::ARCH,
        scene_memory: memory,
        threads,
        secret: secret.as_ref().map(Secret::bytes),
        nonce: random_nonce,
    };
    let mut cache = SceneCache::new();
    if let Some(listen) = &args.listen {
        serve_listening(args, listen, &node, &mut cache)?;
    } else if let Some(master) = &args.connect {
        let endpoint = strahl_tcp::parse_endpoint(master).map_err(|e| anyhow!("--connect {e}"))?;
        eprintln!("strahl worker {name} ({threads} threads): dialling the master at {endpoint}");
        let outcome = strahl_tcp::dial(
            &endpoint,
            &node,
            &mut cache,
            Duration::from_secs(args.patience),
        );
        match outcome {
            Err(SessionError::Setup(e)) => {
                return Err(anyhow!("cannot reach the master at {endpoint}: {e}"));
            }
            Err(SessionError::Worker(e @ WorkerError::VersionMismatch { .. })) => {
                return Err(anyhow!("{endpoint}: {}", describe(&Err(e))));
            }
            other => eprintln!(
                "strahl worker {name}: master {endpoint}: {}",
                describe_tcp(&other)
            ),
        }
    } else if let Some(path) = &args.serial {
        let port = strahl_serial::open(path, args.baud)
            .with_context(|| format!("cannot open serial port {path}"))?;
        eprintln!(
            "strahl worker {name}: serving on {path} at {} baud",
            args.baud
        );
        strahl_serial::serve_port(port, &node, &mut cache, args.sessions, &mut |outcome| {
            eprintln!("strahl worker {name}: {path}: {}", describe(&outcome));
        })
        .map_err(|e| anyhow!("{path}: {}", describe(&Err(e))))?;
    }
    Ok(())
}
