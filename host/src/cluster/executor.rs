//! Which workers a render uses, from the command line: in-process threads, TCP workers that
//! listen (`--worker`, `--hosts`), TCP workers that dial in (`--listen`, `--launch`), and serial
//! workers (`--serial`), in any mix.
//!
//! [`start_workers`] connects or starts them all and hands back their links for the master, plus
//! the channel on which dialling workers arrive and the launched processes (killed when dropped).

use crate::cluster::link::Link;
use crate::cluster::local::spawn_local_workers;
use crate::cluster::prepared::PreparedScene;
use crate::cluster::slurm::Allocation;
use crate::formats::hosts::{read_hosts_file, HostEntry};
use crate::util::secret::listen_endpoint;
use crate::util::sys::{CONNECT_TIMEOUT, POLL_INTERVAL};
use anyhow::{anyhow, bail, Context as _};
use nix::sys::signal::{killpg, Signal};
use nix::unistd::Pid;
use std::net::{SocketAddr, TcpListener};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The workers outside this process a render uses, as the user named them (the command line's
/// `ClusterArgs` of `strahl render` gives one); the specs are checked when the workers
/// start.
#[derive(Clone, Debug, Default)]
pub struct WorkerSources {
    /// TCP workers listening at `HOST[:PORT]`.
    pub worker: Vec<String>,
    /// A hosts file: the workers to dial, or with `launch` the hosts to start workers on.
    pub hosts: Option<PathBuf>,
    /// Where to accept workers that dial in, `HOST[:PORT]`.
    pub listen: Option<String>,
    /// The shell command that starts one worker per hosts-file line.
    pub launch: Option<String>,
    /// Serial workers at `PATH[:BAUD]`.
    pub serial: Vec<String>,
    /// Whether the master has a shared secret (then it may listen on any address).
    pub secret: bool,
    /// Listen beyond this machine without a secret (`--insecure`).
    pub insecure: bool,
    /// Start a worker on every node of the Slurm allocation (`--slurm`).
    pub slurm: bool,
    /// The secret's file, for workers started with `--slurm` (absolute).
    pub secret_file: Option<PathBuf>,
}

impl WorkerSources {
    /// Whether any worker outside this process is named.
    pub fn has_remote(&self) -> bool {
        !self.worker.is_empty()
            || self.hosts.is_some()
            || self.listen.is_some()
            || !self.serial.is_empty()
            || self.slurm
    }
}

/// A launched worker process, killed (if still running) when dropped.
#[derive(Debug)]
pub struct LaunchedWorker {
    /// The host it was launched for.
    pub host: String,
    child: Child,
    /// The end of what the command wrote on stderr.
    stderr: Arc<Mutex<Vec<u8>>>,
}

/// How long a render waits after starting its launch commands to see which failed at once.
pub const LAUNCH_GRACE: Duration = Duration::from_millis(500);

/// The most bytes of a launch command's stderr kept for its error message.
const LAUNCH_STDERR_KEEP: usize = 1024;

impl LaunchedWorker {
    /// Why the command has already failed, if it has: its exit status and the end of its
    /// stderr.
    fn failure(&mut self) -> Option<String> {
        let status = self.child.try_wait().ok()??;
        if status.success() {
            return None;
        }
        let err = self.stderr.lock().unwrap_or_else(|e| e.into_inner());
        let text = String::from_utf8_lossy(&err);
        Some(format!(
            "the launch command for host {} failed ({status}){}",
            self.host,
            match text.trim() {
                "" => String::new(),
                t => format!(": {t}"),
            }
        ))
    }
}

/// Waits [`LAUNCH_GRACE`] and reports the launch commands that failed at once through `warn`;
/// if every one did and no other worker is there, that is the error.
///
/// # Errors
/// Every launch command failed and no other worker was named.
fn check_launches(w: &mut Workers, others: bool, warn: &dyn Fn(&str)) -> anyhow::Result<()> {
    if w.launched.is_empty() {
        return Ok(());
    }
    let deadline = std::time::Instant::now() + LAUNCH_GRACE;
    let mut failed: Vec<String> = Vec::new();
    while std::time::Instant::now() < deadline && failed.len() < w.launched.len() {
        std::thread::sleep(LAUNCHED_EXIT_POLL);
        failed = w
            .launched
            .iter_mut()
            .filter_map(LaunchedWorker::failure)
            .collect();
    }
    if failed.len() == w.launched.len() && !others {
        bail!("{}", failed.join("; "));
    }
    for f in &failed {
        warn(&format!("{f}; going on without it"));
    }
    Ok(())
}

/// How often a dropped [`LaunchedWorker`] looks whether its command has exited.
const LAUNCHED_EXIT_POLL: Duration = Duration::from_millis(25);

/// How many times it looks ([`LAUNCHED_EXIT_POLL`] apart, half a second in all) before it stops
/// the command.
const LAUNCHED_EXIT_POLLS: u32 = 20;

impl Drop for LaunchedWorker {
    fn drop(&mut self) {
        // A worker that served its session has exited by now; give it a moment, then stop the
        // launch command's whole process group (the command and whatever it started).
        for _ in 0..LAUNCHED_EXIT_POLLS {
            if matches!(self.child.try_wait(), Ok(Some(_))) {
                return;
            }
            std::thread::sleep(LAUNCHED_EXIT_POLL);
        }
        // `Child::kill` alone signals only the command, so a worker an `ssh` or a script
        // started would live on: the whole group goes first (the command leads it).
        if let Ok(id) = i32::try_from(self.child.id()) {
            let _ = killpg(Pid::from_raw(id), Signal::SIGTERM);
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Stops the accepting thread when dropped.
#[derive(Debug)]
pub struct Acceptor {
    /// The address workers dial.
    pub address: SocketAddr,
    stop: Arc<AtomicBool>,
}

impl Drop for Acceptor {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// The workers of a render.
#[derive(Debug, Default)]
pub struct Workers {
    /// Links to the workers that are there from the start.
    pub links: Vec<Link>,
    /// Where workers that dial in arrive, while the master listens.
    pub joins: Option<Receiver<Link>>,
    /// The listening socket's thread.
    pub acceptor: Option<Acceptor>,
    /// Workers started with --launch.
    pub launched: Vec<LaunchedWorker>,
}

/// Starts `local` in-process workers and connects, launches or opens every worker `args` names.
/// A named worker that cannot be reached is reported through `warn` and left out.
///
/// # Errors
/// A bad hosts file, address or port spec, a listen address that cannot be bound, a launch
/// command that cannot be started, or no worker at all.
pub fn start_workers(
    args: &WorkerSources,
    local: usize,
    prepared: &PreparedScene,
    warn: &dyn Fn(&str),
) -> anyhow::Result<Workers> {
    let mut w = Workers {
        links: spawn_local_workers(local, &prepared.cache())
            .context("cannot start in-process workers")?,
        ..Workers::default()
    };
    let hosts: Vec<HostEntry> = match &args.hosts {
        Some(path) => read_hosts_file(path)?,
        None => Vec::new(),
    };
    let mut dial: Vec<String> = Vec::new();
    for spec in &args.worker {
        dial.push(strahl_tcp::parse_endpoint(spec).map_err(|e| anyhow!("--worker {e}"))?);
    }
    if args.launch.is_none() {
        dial.extend(hosts.iter().map(|h| h.endpoint.clone()));
    }
    let dial = once_each(dial, warn);
    let mut serial = Vec::new();
    for spec in &args.serial {
        serial.push(strahl_serial::parse_port_spec(spec).map_err(|e| anyhow!("--serial {e}"))?);
    }

    if args.listen.is_some() || args.launch.is_some() || args.slurm {
        let others = !w.links.is_empty() || !dial.is_empty() || !serial.is_empty();
        listen_and_launch(args, &hosts, others, &mut w, warn)?;
    }

    // Why each named worker could not be used: a warning while others render, the error's
    // reasons when none can (so `-q`, which hides warnings, still says why).
    let mut unreachable = Vec::new();
    for endpoint in dial {
        match strahl_tcp::connect(&endpoint, CONNECT_TIMEOUT)
            .and_then(|s| Link::from_tcp(endpoint.clone(), s))
        {
            Ok(link) => w.links.push(link),
            Err(e) => unreachable.push(format!("cannot reach worker {endpoint}: {e}")),
        }
    }
    for (path, baud) in serial {
        match strahl_serial::open(&path, baud)
            .and_then(|port| Link::from_serial(path.clone(), port))
        {
            Ok(link) => w.links.push(link),
            Err(e) => unreachable.push(format!("cannot open serial worker {path}: {e}")),
        }
    }
    if w.links.is_empty() && w.joins.is_none() {
        bail!(
            "no worker could be reached, so nothing can be rendered ({})",
            unreachable.join("; ")
        );
    }
    for why in unreachable {
        warn(&format!("{why}; going on without it"));
    }
    Ok(w)
}

/// The most workers dialled in to one render at once; more connections are closed at once
/// (each joined worker costs the master two threads). A worker that is lost or leaves gives
/// its place back.
pub const MAX_JOINED: usize = 256;

/// The shortest time between two accepted connections: at most 500 a second.
const ACCEPT_PACE: Duration = Duration::from_millis(2);

/// Listens for workers that dial in (`--listen`, or a free port with `--launch`) and starts a
/// launch command per host; `others`: whether other workers are named.
///
/// # Errors
/// A bad or refused listen address, a launch command that cannot start, or every launch failing
/// with no other worker.
fn listen_and_launch(
    args: &WorkerSources,
    hosts: &[HostEntry],
    others: bool,
    w: &mut Workers,
    warn: &dyn Fn(&str),
) -> anyhow::Result<()> {
    // Without a secret, a master that listens for workers listens on this machine only.
    let spec = args.listen.as_deref().unwrap_or(":0");
    let endpoint = strahl_tcp::parse_listen_address(spec).map_err(|e| anyhow!("--listen {e}"))?;
    let endpoint = if args.listen.is_none() && !args.secret {
        "127.0.0.1:0".to_string()
    } else {
        listen_endpoint(&endpoint, args.secret, args.insecure, "this master")?
    };
    let allocation = if args.slurm {
        Some(slurm_allocation(&endpoint)?)
    } else {
        None
    };
    let (acceptor, joins) = accept_workers(&endpoint)?;
    let master = if acceptor.address.ip().is_unspecified() {
        format!(
            "{}:{}",
            crate::util::sys::host_name(),
            acceptor.address.port()
        )
    } else {
        acceptor.address.to_string()
    };
    if let Some(template) = &args.launch {
        for h in hosts {
            let argv = template_words(template, h, &master)?;
            w.launched.push(launch(&argv, &h.host)?);
        }
    }
    if let Some(a) = allocation {
        let exe = std::env::current_exe().context("--slurm: cannot find this program's path")?;
        let argv = a.srun_command(&exe, &master, args.secret_file.as_deref());
        w.launched
            .push(launch(&argv, &format!("Slurm job {}", a.job))?);
    }
    check_launches(w, others, warn)?;
    w.acceptor = Some(acceptor);
    w.joins = Some(joins);
    Ok(())
}

/// `endpoints` with each worker once: one named twice (the same text, or names that resolve to
/// the same address, as `localhost:7415` and `127.0.0.1:7415`) is dialled once, with a warning.
fn once_each(endpoints: Vec<String>, warn: &dyn Fn(&str)) -> Vec<String> {
    use std::net::ToSocketAddrs as _;
    let mut seen: Vec<(String, Option<std::net::SocketAddr>)> = Vec::new();
    let mut out = Vec::new();
    for e in endpoints {
        let resolved = e.to_socket_addrs().ok().and_then(|mut a| a.next());
        let twin = seen
            .iter()
            .find(|(text, addr)| *text == e || (resolved.is_some() && *addr == resolved));
        match twin {
            Some((first, _)) => warn(&format!(
                "the worker at {e} is named twice (also as {first}); it is used once"
            )),
            None => {
                seen.push((e.clone(), resolved));
                out.push(e);
            }
        }
    }
    out
}

/// Listens at `endpoint` and sends a link for each worker that connects, until dropped; at most
/// [`MAX_JOINED`] of them, at most one per [`ACCEPT_PACE`].
fn accept_workers(endpoint: &str) -> anyhow::Result<(Acceptor, Receiver<Link>)> {
    let listener =
        TcpListener::bind(endpoint).with_context(|| format!("cannot listen on {endpoint}"))?;
    listener.set_nonblocking(true)?;
    let address = listener.local_addr()?;
    let stop = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel();
    let flag = Arc::clone(&stop);
    std::thread::Builder::new()
        .name("strahl-accept".to_string())
        .spawn(move || {
            let joined = Arc::new(AtomicUsize::new(0));
            while !flag.load(Ordering::Relaxed) {
                match listener.accept() {
                    Ok((stream, _)) if joined.load(Ordering::SeqCst) >= MAX_JOINED => {
                        let _ = stream.shutdown(std::net::Shutdown::Both);
                    }
                    Ok((stream, peer)) => {
                        std::thread::sleep(ACCEPT_PACE);
                        let link = stream
                            .set_nonblocking(false)
                            .and_then(|()| Link::from_tcp(peer.to_string(), stream));
                        if let Ok(link) = link {
                            if tx.send(link.counted(Arc::clone(&joined))).is_err() {
                                return;
                            }
                        }
                    }
                    Err(_) => std::thread::sleep(POLL_INTERVAL),
                }
            }
        })
        .context("cannot start the accepting thread")?;
    Ok((Acceptor { address, stop }, rx))
}

/// Starts the launch command for one host.
/// The Slurm allocation `--slurm` starts workers in; without a secret, only a one-node
/// allocation (the workers dial a master on this machine).
///
/// # Errors
/// No allocation, or several nodes and a master listening on this machine only.
fn slurm_allocation(endpoint: &str) -> anyhow::Result<Allocation> {
    let a = Allocation::from_env(|k| std::env::var(k).ok()).map_err(|e| anyhow!("{e}"))?;
    if a.nodes > 1 && crate::util::secret::is_loopback(endpoint) {
        bail!(
            "--slurm: the allocation has {} nodes, whose workers must reach this master, but \
             without a shared secret it listens on this machine only; give --secret-file FILE \
             (on a file system the nodes share) or STRAHL_SECRET",
            a.nodes
        );
    }
    Ok(a)
}

/// A launch template's words with `{host}` and `{master}` put in.
///
/// # Errors
/// An empty template or an unclosed quote.
fn template_words(template: &str, host: &HostEntry, master: &str) -> anyhow::Result<Vec<String>> {
    // No shell: the template is split into words first and `{host}` and `{master}` are put
    // into them, so a value can never become a second command.
    let words: Vec<String> = split_template(template)?
        .iter()
        .map(|w| w.replace("{host}", &host.host).replace("{master}", master))
        .collect();
    if words.is_empty() {
        bail!("--launch: the template is empty");
    }
    Ok(words)
}

/// Starts the command `args` (a program and its arguments, no shell) for `host`, in a process
/// group of its own, keeping the end of its stderr.
///
/// # Errors
/// The command cannot be started.
fn launch(args: &[String], host: &str) -> anyhow::Result<LaunchedWorker> {
    let (program, rest) = args
        .split_first()
        .ok_or_else(|| anyhow!("--launch: the template is empty"))?;
    let mut command = Command::new(program);
    command
        .args(rest)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    // Its own process group, so stopping it stops what it started too.
    #[cfg(unix)]
    std::os::unix::process::CommandExt::process_group(&mut command, 0);
    let mut child = command
        .spawn()
        .with_context(|| format!("cannot start `{}` for {host}", args.join(" ")))?;
    let stderr = Arc::new(Mutex::new(Vec::new()));
    if let Some(mut pipe) = child.stderr.take() {
        let keep = Arc::clone(&stderr);
        // Drained to the end (so the command never blocks on a full pipe); the end is kept.
        std::thread::spawn(move || {
            let mut buf = [0u8; 512];
            while let Ok(n @ 1..) = std::io::Read::read(&mut pipe, &mut buf) {
                let mut k = keep.lock().unwrap_or_else(|e| e.into_inner());
                k.extend_from_slice(&buf[..n]);
                let excess = k.len().saturating_sub(LAUNCH_STDERR_KEEP);
                k.drain(..excess);
            }
        });
    }
    Ok(LaunchedWorker {
        host: host.to_string(),
        child,
        stderr,
    })
}

/// A launch template's words: split at spaces, with `'...'` and `"..."` keeping spaces in one
/// word (no other shell syntax: no variables, no `;`, no pipes).
///
/// # Errors
/// An unclosed quote.
fn split_template(template: &str) -> anyhow::Result<Vec<String>> {
    let mut words = Vec::new();
    let mut word: Option<String> = None;
    let mut quote: Option<char> = None;
    for c in template.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), c) => word.get_or_insert_with(String::new).push(c),
            (None, '\'' | '"') => {
                quote = Some(c);
                word.get_or_insert_with(String::new);
            }
            (None, c) if c.is_whitespace() => words.extend(word.take()),
            (None, c) => word.get_or_insert_with(String::new).push(c),
        }
    }
    if quote.is_some() {
        bail!("--launch: a quote is not closed in `{template}`");
    }
    words.extend(word);
    Ok(words)
}

#[cfg(test)]
mod tests {
    use super::split_template;

    #[test]
    fn templates_split_into_words_without_a_shell() {
        let words =
            split_template("ssh -o 'Batch Mode=yes' {host} strahl worker --connect \"{master}\"")
                .expect("a template");
        assert_eq!(
            words,
            [
                "ssh",
                "-o",
                "Batch Mode=yes",
                "{host}",
                "strahl",
                "worker",
                "--connect",
                "{master}"
            ]
        );
        assert!(split_template("ssh 'x").is_err());
        assert_eq!(split_template("a ''").expect("empty word"), ["a", ""]);
    }
}
