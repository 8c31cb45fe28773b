//! What the end-to-end tests of `strahl render` and `strahl worker` share: child processes
//! whose stderr is collected (and which are killed when a test ends, even when it fails), the
//! demo room at three sizes and its reference image, the per-worker table of a render's output,
//! and a process's CPU time from `/proc`. Each test file uses a part of it.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::error::Error;
use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::thread;
use std::time::{Duration, Instant};

pub type TestResult = Result<(), Box<dyn Error>>;

/// The `strahl` binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_strahl");

/// The longest a render may take before the test kills it and fails.
pub const RENDER_TIMEOUT: Duration = Duration::from_secs(90);

/// CPU time (in clock ticks, 10 ms each) after which a worker process is surely rendering lines:
/// starting, receiving the scene and building its octree take a few ticks.
pub const RENDERING_TICKS: u64 = 10;

/// An image size for the demo room.
#[derive(Clone, Copy, Debug)]
pub struct Size {
    pub width: u32,
    pub height: u32,
}

/// About 0.07 s of CPU time with reflections (measured 2026-11-25; the sizes below scale with
/// their pixels).
pub const SMALL: Size = Size {
    width: 320,
    height: 240,
};

/// About 0.3 s of CPU time with reflections.
pub const MEDIUM: Size = Size {
    width: 640,
    height: 480,
};

/// About 1 s of CPU time with reflections (0.6 s in the test build on 2026-12-01): renders that
/// must outlast a cut or hang.
pub const LARGE: Size = Size {
    width: 1280,
    height: 960,
};

/// About 2.6 s of CPU time with reflections (1.2 s in the test build on 2026-12-01): a render
/// that must go on after a worker stops answering, so the master's time-out (not the end of the
/// image) ends it, or after workers are killed mid-render (`cli_tcp.rs`).
pub const HUGE: Size = Size {
    width: 2048,
    height: 1536,
};

/// The demo room's configuration in the repository (rendered with `-o`, so nothing is written
/// next to it).
pub fn room_config() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room/raytracer.cfg")
}

/// `render ROOM -o OUT --width W --height H --reflections on EXTRA...`.
pub fn render_args(size: Size, out: &Path, extra: &[&str]) -> Vec<String> {
    let mut args: Vec<String> = vec![
        "render".into(),
        room_config().display().to_string(),
        "-o".into(),
        out.display().to_string(),
        "--width".into(),
        size.width.to_string(),
        "--height".into(),
        size.height.to_string(),
        "--reflections".into(),
        "on".into(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    args
}

/// What a child wrote on stderr so far, and whether it has closed it.
#[derive(Default)]
pub struct Captured {
    pub text: String,
    pub closed: bool,
}

/// A running `strahl` process whose stderr is collected by a thread; killed (if still running)
/// and reaped when dropped, so no test leaves processes behind, even when it fails.
pub struct Proc {
    pub what: String,
    pub child: Child,
    pub stderr: Arc<(Mutex<Captured>, Condvar)>,
}

impl Proc {
    /// Starts `strahl ARGS...` with stdin and stdout closed and stderr collected.
    pub fn spawn<S: AsRef<str>>(args: &[S]) -> Result<Proc, Box<dyn Error>> {
        Proc::spawn_env(args, &[])
    }

    /// [`Proc::spawn`] with environment variables set.
    pub fn spawn_env<S: AsRef<str>>(
        args: &[S],
        env: &[(&str, &str)],
    ) -> Result<Proc, Box<dyn Error>> {
        let args: Vec<&str> = args.iter().map(AsRef::as_ref).collect();
        let mut child = Command::new(BIN)
            .args(&args)
            .envs(env.iter().copied())
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()?;
        let pipe = child.stderr.take().ok_or("no stderr pipe")?;
        let stderr = Arc::new((Mutex::new(Captured::default()), Condvar::new()));
        let shared = Arc::clone(&stderr);
        thread::spawn(move || {
            let (lock, changed) = &*shared;
            let mut reader = BufReader::new(pipe);
            let mut line = Vec::new();
            loop {
                line.clear();
                match reader.read_until(b'\n', &mut line) {
                    Ok(0) | Err(_) => break,
                    Ok(_) => {
                        let mut c = lock.lock().unwrap_or_else(PoisonError::into_inner);
                        c.text.push_str(&String::from_utf8_lossy(&line));
                        changed.notify_all();
                    }
                }
            }
            lock.lock().unwrap_or_else(PoisonError::into_inner).closed = true;
            changed.notify_all();
        });
        Ok(Proc {
            what: format!("strahl {}", args.join(" ")),
            child,
            stderr,
        })
    }

    /// Starts `strahl worker --listen 127.0.0.1:0 --name NAME` and returns it with the address
    /// it printed.
    pub fn listening_worker(name: &str) -> Result<(Proc, String), Box<dyn Error>> {
        Proc::listening_worker_with(name, &[])
    }

    /// [`Proc::listening_worker`] with more options (`--threads N`).
    pub fn listening_worker_with(
        name: &str,
        extra: &[&str],
    ) -> Result<(Proc, String), Box<dyn Error>> {
        let mut args = vec!["worker", "--listen", "127.0.0.1:0", "--name", name];
        args.extend_from_slice(extra);
        let p = Proc::spawn(&args)?;
        let address = p.listen_address()?;
        Ok((p, address))
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Everything it wrote on stderr so far.
    pub fn stderr(&self) -> String {
        let (lock, _) = &*self.stderr;
        lock.lock()
            .unwrap_or_else(PoisonError::into_inner)
            .text
            .clone()
    }

    /// Waits up to `timeout` until its stderr satisfies `done` or is closed; returns whether
    /// `done` was satisfied, and the text.
    pub fn wait_stderr(&self, timeout: Duration, done: impl Fn(&str) -> bool) -> (bool, String) {
        let (lock, changed) = &*self.stderr;
        let deadline = Instant::now() + timeout;
        let mut c = lock.lock().unwrap_or_else(PoisonError::into_inner);
        loop {
            if done(&c.text) {
                return (true, c.text.clone());
            }
            let now = Instant::now();
            if c.closed || now >= deadline {
                return (false, c.text.clone());
            }
            c = changed
                .wait_timeout(c, deadline - now)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
    }

    /// The address a listening worker printed: `strahl worker NAME: listening on ADDR`.
    pub fn listen_address(&self) -> Result<String, Box<dyn Error>> {
        const MARK: &str = ": listening on ";
        let (found, text) = self.wait_stderr(Duration::from_secs(30), |t| {
            t.lines().any(|l| l.contains(MARK))
        });
        if !found {
            return Err(format!("`{}` printed no address:\n{text}", self.what).into());
        }
        let line = text
            .lines()
            .find(|l| l.contains(MARK))
            .ok_or("no listening line")?;
        let at = line.find(MARK).ok_or("no listening line")? + MARK.len();
        Ok(line[at..].trim().to_string())
    }

    /// Whether it has not exited yet.
    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    /// Waits up to `timeout` for it to exit (then up to 5 s more for its stderr to close);
    /// kills it and fails if it does not.
    pub fn wait(&mut self, timeout: Duration) -> Result<ExitStatus, Box<dyn Error>> {
        let deadline = Instant::now() + timeout;
        let status = loop {
            if let Some(status) = self.child.try_wait()? {
                break status;
            }
            if Instant::now() >= deadline {
                self.kill();
                return Err(format!(
                    "`{}` did not exit within {timeout:?}; stderr:\n{}",
                    self.what,
                    self.stderr()
                )
                .into());
            }
            thread::sleep(Duration::from_millis(10));
        };
        // Processes it started may hold its stderr a little longer; do not wait for them long.
        self.wait_stderr(Duration::from_secs(5), |_| false);
        Ok(status)
    }

    /// Kills it (SIGKILL) and reaps it.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.kill();
    }
}

/// How a render ended.
pub struct Rendered {
    pub status: ExitStatus,
    pub stderr: String,
}

impl Rendered {
    pub fn assert_success(&self) {
        assert!(
            self.status.success(),
            "render failed ({:?}):\n{}",
            self.status.code(),
            self.stderr
        );
    }
}

/// Runs a render to its end.
pub fn render(size: Size, out: &Path, extra: &[&str]) -> Result<Rendered, Box<dyn Error>> {
    finish(Proc::spawn(&render_args(size, out, extra))?)
}

/// Waits for a render started with [`Proc::spawn`].
pub fn finish(mut p: Proc) -> Result<Rendered, Box<dyn Error>> {
    let status = p.wait(RENDER_TIMEOUT)?;
    Ok(Rendered {
        status,
        stderr: p.stderr(),
    })
}

/// The image one in-process worker renders (`--workers 1`) at `size`, rendered once per test
/// run.
pub fn reference(size: Size) -> Result<Vec<u8>, Box<dyn Error>> {
    static IMAGES: Mutex<BTreeMap<(u32, u32), Vec<u8>>> = Mutex::new(BTreeMap::new());
    let mut images = IMAGES.lock().unwrap_or_else(PoisonError::into_inner);
    let key = (size.width, size.height);
    if let Some(bytes) = images.get(&key) {
        return Ok(bytes.clone());
    }
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("reference.bmp");
    let r = render(size, &out, &["--workers", "1", "-q"])?;
    r.assert_success();
    let bytes = std::fs::read(&out)?;
    images.insert(key, bytes.clone());
    Ok(bytes)
}

/// Fails unless the image at `path` is byte for byte the reference image of `size`.
pub fn assert_reference_image(path: &Path, size: Size) -> TestResult {
    let got = std::fs::read(path)?;
    let want = reference(size)?;
    if got != want {
        let first = got.iter().zip(&want).position(|(a, b)| a != b);
        return Err(format!(
            "{} differs from the --workers 1 image: {} vs {} bytes, first difference at {first:?}",
            path.display(),
            got.len(),
            want.len()
        )
        .into());
    }
    Ok(())
}

/// One line of the per-worker table.
#[derive(Debug)]
pub struct Row {
    pub name: String,
    pub threads: u32,
    pub lines: u32,
    pub reissued: u32,
    /// `ok`, or why the worker was lost.
    pub status: String,
}

/// The per-worker table from a render's stderr: the rows after the header, each lost worker's
/// status the reason on the indented `lost: REASON` line below its row.
pub fn table(stderr: &str) -> Vec<Row> {
    let mut rows: Vec<Row> = Vec::new();
    let body = stderr
        .lines()
        .skip_while(|l| !(l.starts_with("worker ") && l.trim_end().ends_with("status")))
        .skip(1);
    for line in body {
        match (line.trim_start().strip_prefix("lost: "), rows.last_mut()) {
            (Some(why), Some(last)) if line.starts_with("    ") => {
                last.status = why.to_string();
            }
            _ => rows.extend(parse_row(line)),
        }
    }
    rows
}

/// `NAME LINK THREADS LINES DUP LINES/REQ RATE RATE/THREAD REISSUED DROPPED STATUS`.
pub fn parse_row(line: &str) -> Option<Row> {
    let cols: Vec<&str> = line.split_whitespace().collect();
    let [name, _link, threads, lines, _dup, _lpr, _rate, _per_thread, reissued, _dropped, status] =
        cols[..]
    else {
        return None;
    };
    Some(Row {
        name: name.to_string(),
        threads: threads.parse().ok()?,
        lines: lines.parse().ok()?,
        reissued: reissued.parse().ok()?,
        status: status.to_string(),
    })
}

/// The table row of worker `name`.
pub fn row<'a>(rows: &'a [Row], name: &str, stderr: &str) -> Result<&'a Row, String> {
    rows.iter()
        .find(|r| r.name == name)
        .ok_or_else(|| format!("no table row for {name}:\n{stderr}"))
}

/// Fails unless worker `name` finished the render (status `ok`).
pub fn assert_ok(r: &Rendered, name: &str) -> TestResult {
    let rows = table(&r.stderr);
    let w = row(&rows, name, &r.stderr)?;
    assert_eq!(w.status, "ok", "{name}:\n{}", r.stderr);
    Ok(())
}

/// Fails unless worker `name` was lost after it had taken work (its lines were re-queued);
/// returns why it was lost.
pub fn assert_lost(r: &Rendered, name: &str) -> Result<String, Box<dyn Error>> {
    let rows = table(&r.stderr);
    let w = row(&rows, name, &r.stderr)?;
    assert_ne!(w.status, "ok", "{name} was not lost:\n{}", r.stderr);
    assert!(
        w.reissued >= 1,
        "{name}'s lines were not re-queued:\n{}",
        r.stderr
    );
    assert!(
        r.stderr.contains(&format!("warning: worker {name} (")),
        "no warning about {name}:\n{}",
        r.stderr
    );
    Ok(w.status.clone())
}

/// CPU time (user and system, in clock ticks) process `pid` has used, from `/proc`.
pub fn cpu_ticks(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The fields after the command name (which is in parentheses and may hold spaces); utime
    // and stime are fields 14 and 15.
    let fields: Vec<&str> = stat[stat.rfind(')')? + 1..].split_whitespace().collect();
    let utime: u64 = fields.get(11)?.parse().ok()?;
    let stime: u64 = fields.get(12)?.parse().ok()?;
    Some(utime + stime)
}

/// Waits until worker `p` is rendering lines: it has used [`RENDERING_TICKS`] of CPU time.
/// Without `/proc`, waits 0.4 s instead.
pub fn wait_until_rendering(p: &mut Proc) -> TestResult {
    let start = Instant::now();
    loop {
        if !p.is_running() {
            return Err(format!("{} exited:\n{}", p.what, p.stderr()).into());
        }
        match cpu_ticks(p.pid()) {
            Some(t) if t >= RENDERING_TICKS => return Ok(()),
            Some(_) => {}
            None => {
                thread::sleep(Duration::from_millis(400));
                return Ok(());
            }
        }
        if start.elapsed() > Duration::from_secs(60) {
            return Err(format!("{} never started rendering", p.what).into());
        }
        thread::sleep(Duration::from_millis(2));
    }
}

/// Waits until each of `workers` is rendering, checks that the render `master` is still
/// running, and kills the workers.
pub fn kill_mid_render(master: &mut Proc, workers: &mut [&mut Proc]) -> TestResult {
    for w in workers.iter_mut() {
        wait_until_rendering(w)?;
    }
    assert!(
        master.is_running(),
        "the render ended before the workers were killed:\n{}",
        master.stderr()
    );
    for w in workers.iter_mut() {
        w.kill();
    }
    Ok(())
}
