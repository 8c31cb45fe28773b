//! What the operating system says about this machine, and the waits the host side uses.
//!
//! [`host_name`] names this machine to its peers: a master puts it in its session header and in
//! the address it gives launched workers, a worker gives it to its masters. Both sides take it
//! from here, so neither the command line nor the cluster depends on the other for it.
//! [`peak_memory_bytes`] is the process's largest resident set so far, for a render's summary;
//! [`thread_cpu_time`] a thread's CPU time, for the master's share in `strahl bench scaling`.

use std::time::Duration;
use strahl_core::wire::MAX_NAME_LEN;

/// How long connecting to a TCP worker may take before it counts as unreachable (the TCP
/// transport's own dial limit, named once there).
pub use strahl_tcp::CONNECT_TIMEOUT;

/// How often a waiting thread looks again: the master's loop checks time-outs, a blocked pipe
/// read whether the pipe was closed, a hung simulated worker whether its link was cut, a
/// non-blocking accept for a new worker.
pub const POLL_INTERVAL: Duration = Duration::from_millis(20);

/// The host name, from the kernel or the environment, cut to [`MAX_NAME_LEN`] bytes.
pub fn host_name() -> String {
    let name = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "worker".to_string());
    cut_name(&name)
}

/// `name` cut to at most [`MAX_NAME_LEN`] bytes on a character boundary.
pub fn cut_name(name: &str) -> String {
    let mut end = name.len().min(MAX_NAME_LEN);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    name[..end].to_string()
}

/// The most memory this process has held resident so far (`getrusage`'s maximum resident set
/// size, through nix), in bytes; `None` where the system does not say.
pub fn peak_memory_bytes() -> Option<u64> {
    let usage = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_SELF).ok()?;
    let max_rss = u64::try_from(usage.max_rss()).ok()?;
    // Linux and the BSDs count kibibytes, macOS bytes.
    let unit = if cfg!(target_os = "macos") { 1 } else { 1024 };
    Some(max_rss * unit).filter(|&b| b > 0)
}

/// CPU time the calling thread has used so far (`CLOCK_THREAD_CPUTIME_ID`, through nix);
/// `None` where the system does not say.
pub fn thread_cpu_time() -> Option<Duration> {
    let t = nix::time::clock_gettime(nix::time::ClockId::CLOCK_THREAD_CPUTIME_ID).ok()?;
    Some(Duration::from(t))
}

/// Memory the system reports available (`MemAvailable` in `/proc/meminfo`), if it does.
pub fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}
