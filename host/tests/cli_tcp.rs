//! End-to-end tests of distributed rendering over TCP: real `strahl worker` and `strahl render`
//! processes on the loopback interface. Workers are killed mid-render, their connections cut or
//! hung by a proxy in the test, masters and workers meet peers of another protocol version,
//! workers dial in or are launched from a hosts file, and worker addresses are bad or
//! unreachable. Every image is compared byte for byte with the one a single in-process worker
//! renders (`--workers 1`); the per-worker table at the end of `strahl render`'s output tells
//! which workers were lost.
//!
//! Renders that must still be running when a worker is killed use the demo room at 1280×960 with
//! reflections, about 2.7 s of CPU time. A worker is killed once it has used
//! [`RENDERING_TICKS`] of CPU time (it has the scene and is rendering lines); the rest of the
//! image is then still more than two CPU-seconds of work, over a second on two cores, so the
//! kill cannot come after the end. The tests check that the render is still running when the
//! kill is done. Cuts and hangs are triggered by the proxy after a fixed number of bytes from
//! the worker, a few line results into its work, which the rest of the image outlasts the same
//! way.

use embedded_io_adapters::std::FromStd;
use std::collections::BTreeMap;
use std::error::Error;
use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::thread;
use std::time::{Duration, Instant};
use strahl_core::wire::frame::{FrameReader, FrameWriter, LinkError, ReadEvent};
use strahl_core::wire::message::{Hello, MasterMessage, WorkerMessage};
use strahl_core::wire::{MAX_FRAME_LEN, PROTOCOL_VERSION};

type TestResult = Result<(), Box<dyn Error>>;

/// The `strahl` binary under test.
const BIN: &str = env!("CARGO_BIN_EXE_strahl");

/// The longest a render may take before the test kills it and fails.
const RENDER_TIMEOUT: Duration = Duration::from_secs(90);

/// CPU time (in clock ticks, 10 ms each) after which a worker process is surely rendering lines:
/// starting, receiving the scene and building its octree take a few ticks.
const RENDERING_TICKS: u64 = 10;

/// An image size for the demo room.
#[derive(Clone, Copy, Debug)]
struct Size {
    width: u32,
    height: u32,
}

/// About 0.2 s of CPU time with reflections.
const SMALL: Size = Size {
    width: 320,
    height: 240,
};

/// About 0.7 s of CPU time with reflections.
const MEDIUM: Size = Size {
    width: 640,
    height: 480,
};

/// About 2.7 s of CPU time with reflections: renders that must outlast a kill, cut or hang.
const LARGE: Size = Size {
    width: 1280,
    height: 960,
};

/// The demo room's configuration in the repository (rendered with `-o`, so nothing is written
/// next to it).
fn room_config() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room/raytracer.cfg")
}

/// `render ROOM -o OUT --width W --height H --reflections on EXTRA...`.
fn render_args(size: Size, out: &Path, extra: &[&str]) -> Vec<String> {
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
struct Captured {
    text: String,
    closed: bool,
}

/// A running `strahl` process whose stderr is collected by a thread; killed (if still running)
/// and reaped when dropped, so no test leaves processes behind, even when it fails.
struct Proc {
    what: String,
    child: Child,
    stderr: Arc<(Mutex<Captured>, Condvar)>,
}

impl Proc {
    /// Starts `strahl ARGS...` with stdin and stdout closed and stderr collected.
    fn spawn<S: AsRef<str>>(args: &[S]) -> Result<Proc, Box<dyn Error>> {
        let args: Vec<&str> = args.iter().map(AsRef::as_ref).collect();
        let mut child = Command::new(BIN)
            .args(&args)
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
    fn listening_worker(name: &str) -> Result<(Proc, String), Box<dyn Error>> {
        let p = Proc::spawn(&["worker", "--listen", "127.0.0.1:0", "--name", name])?;
        let address = p.listen_address()?;
        Ok((p, address))
    }

    fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Everything it wrote on stderr so far.
    fn stderr(&self) -> String {
        let (lock, _) = &*self.stderr;
        lock.lock()
            .unwrap_or_else(PoisonError::into_inner)
            .text
            .clone()
    }

    /// Waits up to `timeout` until its stderr satisfies `done` or is closed; returns whether
    /// `done` was satisfied, and the text.
    fn wait_stderr(&self, timeout: Duration, done: impl Fn(&str) -> bool) -> (bool, String) {
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
    fn listen_address(&self) -> Result<String, Box<dyn Error>> {
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
    fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    /// Waits up to `timeout` for it to exit (then up to 5 s more for its stderr to close);
    /// kills it and fails if it does not.
    fn wait(&mut self, timeout: Duration) -> Result<ExitStatus, Box<dyn Error>> {
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
    fn kill(&mut self) {
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
struct Rendered {
    status: ExitStatus,
    stderr: String,
}

impl Rendered {
    fn assert_success(&self) {
        assert!(
            self.status.success(),
            "render failed ({:?}):\n{}",
            self.status.code(),
            self.stderr
        );
    }
}

/// Runs a render to its end.
fn render(size: Size, out: &Path, extra: &[&str]) -> Result<Rendered, Box<dyn Error>> {
    finish(Proc::spawn(&render_args(size, out, extra))?)
}

/// Waits for a render started with [`Proc::spawn`].
fn finish(mut p: Proc) -> Result<Rendered, Box<dyn Error>> {
    let status = p.wait(RENDER_TIMEOUT)?;
    Ok(Rendered {
        status,
        stderr: p.stderr(),
    })
}

/// The image one in-process worker renders (`--workers 1`) at `size`, rendered once per test
/// run.
fn reference(size: Size) -> Result<Vec<u8>, Box<dyn Error>> {
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
fn assert_reference_image(path: &Path, size: Size) -> TestResult {
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
struct Row {
    name: String,
    lines: u32,
    reissued: u32,
    /// `ok`, or why the worker was lost.
    status: String,
}

/// The per-worker table from a render's stderr: the lines after the header that have a rate.
fn table(stderr: &str) -> Vec<Row> {
    stderr
        .lines()
        .skip_while(|l| !(l.starts_with("worker ") && l.trim_end().ends_with("status")))
        .skip(1)
        .filter_map(parse_row)
        .collect()
}

/// `NAME LINK LINES DUP RAYS BUSY RATE.. rays/s REISSUED DROPPED  STATUS...`.
fn parse_row(line: &str) -> Option<Row> {
    let mut cols = line.split_whitespace();
    let name = cols.next()?.to_string();
    let lines = cols.nth(1)?.parse().ok()?;
    let rest = line[line.find("rays/s")? + "rays/s".len()..].trim_start();
    let (reissued, rest) = rest.split_once(char::is_whitespace)?;
    let (_dropped, status) = rest.trim_start().split_once(char::is_whitespace)?;
    Some(Row {
        name,
        lines,
        reissued: reissued.parse().ok()?,
        status: status.trim().to_string(),
    })
}

/// The table row of worker `name`.
fn row<'a>(rows: &'a [Row], name: &str, stderr: &str) -> Result<&'a Row, String> {
    rows.iter()
        .find(|r| r.name == name)
        .ok_or_else(|| format!("no table row for {name}:\n{stderr}"))
}

/// Fails unless worker `name` finished the render (status `ok`).
fn assert_ok(r: &Rendered, name: &str) -> TestResult {
    let rows = table(&r.stderr);
    let w = row(&rows, name, &r.stderr)?;
    assert_eq!(w.status, "ok", "{name}:\n{}", r.stderr);
    Ok(())
}

/// Fails unless worker `name` was lost after it had taken work (its lines were re-queued);
/// returns why it was lost.
fn assert_lost(r: &Rendered, name: &str) -> Result<String, Box<dyn Error>> {
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
fn cpu_ticks(pid: u32) -> Option<u64> {
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
fn wait_until_rendering(p: &mut Proc) -> TestResult {
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
fn kill_mid_render(master: &mut Proc, workers: &mut [&mut Proc]) -> TestResult {
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

/// What the proxy does to a connection once its byte budget from the worker is spent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fault {
    /// Close both sides.
    Cut,
    /// Forward nothing more in either direction, but keep both sockets open.
    Hang,
}

/// A TCP proxy between a master and one worker: forwards the first connection it accepts to
/// `target`, passes `budget` bytes from the worker to the master, and then cuts or hangs the
/// connection. Dropping it closes everything.
struct Proxy {
    /// Where the master connects.
    address: String,
    /// Set when the budget was spent and the fault happened.
    tripped: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    sockets: Arc<Mutex<Vec<TcpStream>>>,
}

impl Proxy {
    fn start(target: &str, budget: usize, fault: Fault) -> Result<Proxy, Box<dyn Error>> {
        let listener = TcpListener::bind("127.0.0.1:0")?;
        listener.set_nonblocking(true)?;
        let address = listener.local_addr()?.to_string();
        let tripped = Arc::new(AtomicBool::new(false));
        let stop = Arc::new(AtomicBool::new(false));
        let sockets = Arc::new(Mutex::new(Vec::new()));
        let proxy = Proxy {
            address,
            tripped: Arc::clone(&tripped),
            stop: Arc::clone(&stop),
            sockets: Arc::clone(&sockets),
        };
        let target = target.to_string();
        thread::spawn(move || {
            let master = loop {
                if stop.load(Ordering::Relaxed) {
                    return;
                }
                match listener.accept() {
                    Ok((s, _)) => break s,
                    Err(_) => thread::sleep(Duration::from_millis(5)),
                }
            };
            let Ok(worker) = TcpStream::connect(&target) else {
                return;
            };
            let clones = (|| {
                master.set_nonblocking(false)?;
                master.set_nodelay(true)?;
                worker.set_nodelay(true)?;
                Ok::<_, std::io::Error>([
                    master.try_clone()?,
                    worker.try_clone()?,
                    master.try_clone()?,
                    worker.try_clone()?,
                ])
            })();
            let Ok([m1, w1, m2, w2]) = clones else {
                return;
            };
            sockets
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .extend([master, worker]);
            let pump = Pump {
                fault,
                tripped,
                stop,
            };
            let back = pump.clone();
            thread::spawn(move || back.run(w1, m1, Some(budget)));
            pump.run(m2, w2, None);
        });
        Ok(proxy)
    }
}

impl Drop for Proxy {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for s in self
            .sockets
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .iter()
        {
            let _ = s.shutdown(Shutdown::Both);
        }
    }
}

/// One direction of a proxied connection.
#[derive(Clone)]
struct Pump {
    fault: Fault,
    tripped: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
}

impl Pump {
    /// Copies `from` to `to`, at most `budget` bytes if given; then faults. A side that closes
    /// closes the other (until a hang).
    fn run(&self, mut from: TcpStream, mut to: TcpStream, budget: Option<usize>) {
        let mut buf = vec![0u8; 1 << 16];
        let mut passed = 0;
        loop {
            if self.hung() {
                return self.park();
            }
            let n = match from.read(&mut buf) {
                Ok(0) | Err(_) => break,
                Ok(n) => n,
            };
            if self.hung() {
                return self.park();
            }
            let take = budget.map_or(n, |b| n.min(b - passed));
            if to.write_all(&buf[..take]).is_err() {
                break;
            }
            passed += take;
            if budget.is_some_and(|b| passed >= b) {
                self.tripped.store(true, Ordering::SeqCst);
                match self.fault {
                    Fault::Cut => break,
                    Fault::Hang => return self.park(),
                }
            }
        }
        let _ = from.shutdown(Shutdown::Both);
        let _ = to.shutdown(Shutdown::Both);
    }

    fn hung(&self) -> bool {
        self.fault == Fault::Hang && self.tripped.load(Ordering::SeqCst)
    }

    /// Holds the sockets open, forwarding nothing, until the proxy is dropped.
    fn park(&self) {
        while !self.stop.load(Ordering::Relaxed) {
            thread::sleep(Duration::from_millis(20));
        }
    }
}

/// Reads frames from a raw TCP connection.
struct RawFrames {
    stream: TcpStream,
    frames: FrameReader<Vec<u8>>,
}

impl RawFrames {
    fn new(stream: TcpStream) -> Result<Self, Box<dyn Error>> {
        stream.set_read_timeout(Some(Duration::from_secs(20)))?;
        Ok(RawFrames {
            stream,
            frames: FrameReader::new(vec![0u8; MAX_FRAME_LEN]),
        })
    }

    /// The next frame's payload; `None` when the peer closed the connection.
    fn next(&mut self) -> Result<Option<Vec<u8>>, String> {
        let mut link = FromStd::new(&mut self.stream);
        match self.frames.next(&mut link) {
            Ok(ReadEvent::Frame(payload)) => Ok(Some(payload.to_vec())),
            Ok(ReadEvent::Dropped(why)) => Err(format!("dropped frame: {why:?}")),
            Err(LinkError::Closed) => Ok(None),
            Err(e) => Err(format!("read failed: {e:?}")),
        }
    }

    /// Writes `frame`, or its first `cut` bytes.
    fn send(&mut self, frame: &[u8], cut: Option<usize>) -> TestResult {
        let n = cut.map_or(frame.len(), |c| c.min(frame.len()));
        self.stream.write_all(&frame[..n])?;
        Ok(())
    }
}

/// `msg` as a frame, delimiters included.
fn master_frame(msg: &MasterMessage<'_>) -> Result<Vec<u8>, String> {
    FrameWriter::new()
        .encode(msg)
        .map(<[u8]>::to_vec)
        .map_err(|e| e.to_string())
}

/// `msg` as a frame, delimiters included.
fn worker_frame(msg: &WorkerMessage<'_>) -> Result<Vec<u8>, String> {
    FrameWriter::new()
        .encode(msg)
        .map(<[u8]>::to_vec)
        .map_err(|e| e.to_string())
}

/// A `Hello` of protocol `version`.
fn hello(version: u32, name: &str) -> Hello<'_> {
    Hello {
        version,
        name,
        arch: "test",
        scene_memory: 0,
    }
}

/// A port on 127.0.0.1 that was free a moment ago.
fn free_port() -> Result<u16, Box<dyn Error>> {
    Ok(TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
}

/// The names of the entries in `dir`.
fn listing(dir: &Path) -> Result<Vec<String>, Box<dyn Error>> {
    let mut names = std::fs::read_dir(dir)?
        .map(|e| e.map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect::<Result<Vec<_>, _>>()?;
    names.sort();
    Ok(names)
}

#[test]
fn three_tcp_workers_render_the_same_image_as_one_local_worker() -> TestResult {
    let (_a, a) = Proc::listening_worker("tcp-a")?;
    let (_b, b) = Proc::listening_worker("tcp-b")?;
    let (_c, c) = Proc::listening_worker("tcp-c")?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let r = render(
        SMALL,
        &out,
        &[
            "--workers",
            "0",
            "--worker",
            &a,
            "--worker",
            &b,
            "--worker",
            &c,
        ],
    )?;
    r.assert_success();
    assert_reference_image(&out, SMALL)?;
    let rows = table(&r.stderr);
    assert_eq!(rows.len(), 3, "{}", r.stderr);
    for name in ["tcp-a", "tcp-b", "tcp-c"] {
        assert_ok(&r, name)?;
    }
    let lines: u32 = rows.iter().map(|w| w.lines).sum();
    assert_eq!(lines, SMALL.height, "{}", r.stderr);
    Ok(())
}

#[test]
fn tcp_workers_report_the_same_ray_counts_as_a_local_worker() -> TestResult {
    // Ray counters travel in every line result: over TCP, with adaptive multisampling (both
    // passes) and the render's skipping, the summary and --stats-json must count exactly the rays
    // one in-process worker counts.
    let (_a, a) = Proc::listening_worker("count-a")?;
    let (_b, b) = Proc::listening_worker("count-b")?;
    let dir = tempfile::tempdir()?;
    let stats = |name: &str, extra: &[&str]| -> Result<serde_json::Value, Box<dyn Error>> {
        let json = dir.path().join(format!("{name}.json"));
        let out = dir.path().join(format!("{name}.bmp"));
        let mut args = vec!["-m", "2", "--aa-threshold", "0.05", "-q", "--stats-json"];
        let json_arg = json.display().to_string();
        args.push(&json_arg);
        args.extend_from_slice(extra);
        render(SMALL, &out, &args)?.assert_success();
        Ok(serde_json::from_str(&std::fs::read_to_string(&json)?)?)
    };
    let local = stats("local", &["--workers", "1"])?;
    let tcp = stats("tcp", &["--workers", "0", "--worker", &a, "--worker", &b])?;
    let rays = |s: &serde_json::Value, kind: &str| s["rays"][kind].as_u64();
    for kind in [
        "primary",
        "extra_samples",
        "shadow",
        "reflection",
        "refraction",
        "occlusion",
        "total",
    ] {
        assert_eq!(
            rays(&tcp, kind),
            rays(&local, kind),
            "{kind}: {tcp:#} vs {local:#}"
        );
    }
    let primary = u64::from(SMALL.width) * u64::from(SMALL.height);
    assert_eq!(rays(&tcp, "primary"), Some(primary), "{tcp:#}");
    for kind in ["extra_samples", "shadow", "reflection"] {
        assert!(rays(&tcp, kind).is_some_and(|n| n > 0), "{kind}: {tcp:#}");
    }
    Ok(())
}

#[test]
fn worker_killed_mid_render_is_reported_and_the_image_is_complete() -> TestResult {
    let (mut victim, v) = Proc::listening_worker("victim")?;
    let (_a, a) = Proc::listening_worker("survivor-a")?;
    let (_b, b) = Proc::listening_worker("survivor-b")?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let mut master = Proc::spawn(&render_args(
        LARGE,
        &out,
        &[
            "--workers",
            "0",
            "--worker",
            &v,
            "--worker",
            &a,
            "--worker",
            &b,
        ],
    ))?;
    kill_mid_render(&mut master, &mut [&mut victim])?;
    let r = finish(master)?;
    r.assert_success();
    assert_reference_image(&out, LARGE)?;
    assert_lost(&r, "victim")?;
    assert_ok(&r, "survivor-a")?;
    assert_ok(&r, "survivor-b")?;
    Ok(())
}

#[test]
fn last_worker_standing_finishes_the_image() -> TestResult {
    let (mut k1, a) = Proc::listening_worker("doomed-a")?;
    let (mut k2, b) = Proc::listening_worker("doomed-b")?;
    let (_last, c) = Proc::listening_worker("last")?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let mut master = Proc::spawn(&render_args(
        LARGE,
        &out,
        &[
            "--workers",
            "0",
            "--worker",
            &a,
            "--worker",
            &b,
            "--worker",
            &c,
        ],
    ))?;
    kill_mid_render(&mut master, &mut [&mut k1, &mut k2])?;
    let r = finish(master)?;
    r.assert_success();
    assert_reference_image(&out, LARGE)?;
    assert_lost(&r, "doomed-a")?;
    assert_lost(&r, "doomed-b")?;
    assert_ok(&r, "last")?;
    Ok(())
}

#[test]
fn cut_connection_loses_the_worker_and_the_image_is_complete() -> TestResult {
    let (_cut, cut) = Proc::listening_worker("cut")?;
    let (_steady, steady) = Proc::listening_worker("steady")?;
    // The handshake is well under 1 KB from the worker and a line result of 640 pixels about
    // 3.9 KB: the cut comes in the third or fourth line result.
    let proxy = Proxy::start(&cut, 12_000, Fault::Cut)?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let r = render(
        MEDIUM,
        &out,
        &[
            "--workers",
            "0",
            "--worker",
            &proxy.address,
            "--worker",
            &steady,
        ],
    )?;
    r.assert_success();
    assert!(
        proxy.tripped.load(Ordering::SeqCst),
        "the connection was never cut"
    );
    assert_reference_image(&out, MEDIUM)?;
    assert_lost(&r, "cut")?;
    let rows = table(&r.stderr);
    assert!(
        row(&rows, "cut", &r.stderr)?.lines >= 1,
        "cut before it rendered:\n{}",
        r.stderr
    );
    assert_ok(&r, "steady")?;
    Ok(())
}

#[test]
fn hung_connection_times_out_and_the_image_is_complete() -> TestResult {
    let (_hung, hung) = Proc::listening_worker("hung")?;
    let (_steady, steady) = Proc::listening_worker("steady")?;
    // A line result of 1280 pixels is about 7.7 KB: the hang comes in the third.
    let proxy = Proxy::start(&hung, 20_000, Fault::Hang)?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let start = Instant::now();
    let r = render(
        LARGE,
        &out,
        &[
            "--workers",
            "0",
            "--worker",
            &proxy.address,
            "--worker",
            &steady,
            "--worker-timeout",
            "1",
        ],
    )?;
    r.assert_success();
    assert!(
        proxy.tripped.load(Ordering::SeqCst),
        "the connection never hung"
    );
    assert_reference_image(&out, LARGE)?;
    let why = assert_lost(&r, "hung")?;
    assert!(why.starts_with("no answer for "), "{why}:\n{}", r.stderr);
    let rows = table(&r.stderr);
    assert!(
        row(&rows, "hung", &r.stderr)?.lines >= 1,
        "hung before it rendered:\n{}",
        r.stderr
    );
    assert_ok(&r, "steady")?;
    assert!(start.elapsed() >= Duration::from_secs(1));
    Ok(())
}

#[test]
fn worker_outlives_a_master_that_vanishes_and_serves_the_next_ones() -> TestResult {
    let (w, address) = Proc::listening_worker("loyal")?;

    // A master that greets, announces a job, starts sending its scene and vanishes mid-frame.
    let mut raw = RawFrames::new(TcpStream::connect(&address)?)?;
    raw.send(
        &master_frame(&MasterMessage::Hello(hello(PROTOCOL_VERSION, "ghost")))?,
        None,
    )?;
    let payload = raw.next()?.ok_or("the worker closed instead of greeting")?;
    match WorkerMessage::decode(&payload) {
        Ok(WorkerMessage::Hello(h)) => {
            assert_eq!(h.version, PROTOCOL_VERSION);
            assert_eq!(h.name, "loyal");
        }
        other => return Err(format!("expected the worker's Hello, got {other:?}").into()),
    }
    let digest = [7u8; 32];
    raw.send(
        &master_frame(&MasterMessage::Job {
            job: 9,
            digest,
            scene_len: 5000,
        })?,
        None,
    )?;
    let payload = raw
        .next()?
        .ok_or("the worker closed instead of answering")?;
    assert!(
        matches!(
            WorkerMessage::decode(&payload),
            Ok(WorkerMessage::NeedScene {
                job: 9,
                offset: 0,
                ..
            })
        ),
        "{:?}",
        WorkerMessage::decode(&payload)
    );
    raw.send(
        &master_frame(&MasterMessage::SceneChunk {
            digest,
            offset: 0,
            bytes: &[1u8; 1000],
        })?,
        Some(500),
    )?;
    drop(raw);
    let (seen, text) = w.wait_stderr(Duration::from_secs(20), |t| {
        t.contains("the master disconnected")
    });
    assert!(seen, "{text}");

    // Two real masters, one after the other.
    let dir = tempfile::tempdir()?;
    for name in ["first.bmp", "second.bmp"] {
        let out = dir.path().join(name);
        let r = render(SMALL, &out, &["--workers", "0", "--worker", &address])?;
        r.assert_success();
        assert_reference_image(&out, SMALL)?;
        assert_ok(&r, "loyal")?;
    }
    let (seen, text) = w.wait_stderr(Duration::from_secs(20), |t| {
        t.matches("the master ended the session").count() == 2
    });
    assert!(seen, "{text}");
    Ok(())
}

#[test]
fn worker_refuses_a_master_of_another_protocol_version() -> TestResult {
    let (w, address) = Proc::listening_worker("strict")?;
    let mut raw = RawFrames::new(TcpStream::connect(&address)?)?;
    raw.send(
        &master_frame(&MasterMessage::Hello(hello(PROTOCOL_VERSION + 1, "future")))?,
        None,
    )?;
    let payload = raw.next()?.ok_or("the worker closed without its Hello")?;
    match WorkerMessage::decode(&payload) {
        Ok(WorkerMessage::Hello(h)) => assert_eq!(h.version, PROTOCOL_VERSION),
        other => return Err(format!("expected the worker's Hello, got {other:?}").into()),
    }
    assert_eq!(raw.next()?, None, "the worker keeps the connection open");
    let theirs = format!("version {}", PROTOCOL_VERSION + 1);
    let ours = format!("version {PROTOCOL_VERSION}");
    let (seen, text) = w.wait_stderr(Duration::from_secs(20), |t| {
        t.contains(&theirs) && t.contains(&ours)
    });
    assert!(seen, "the worker does not name both versions:\n{text}");

    // It goes on serving masters that speak its version.
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let r = render(SMALL, &out, &["--workers", "0", "--worker", &address])?;
    r.assert_success();
    assert_reference_image(&out, SMALL)?;
    Ok(())
}

#[test]
fn master_refuses_a_worker_of_another_protocol_version() -> TestResult {
    let listener = TcpListener::bind("127.0.0.1:0")?;
    listener.set_nonblocking(true)?;
    let address = listener.local_addr()?.to_string();
    // A fake worker: answers the master's Hello with a Hello of the next version, then waits for
    // the master to hang up. Returns the master's version.
    let fake = thread::spawn(move || -> Result<u32, String> {
        let deadline = Instant::now() + Duration::from_secs(30);
        let stream = loop {
            match listener.accept() {
                Ok((s, _)) => break s,
                Err(_) if Instant::now() < deadline => thread::sleep(Duration::from_millis(5)),
                Err(e) => return Err(format!("no master came: {e}")),
            }
        };
        stream.set_nonblocking(false).map_err(|e| e.to_string())?;
        let mut raw = RawFrames::new(stream).map_err(|e| e.to_string())?;
        let payload = raw.next()?.ok_or("the master closed before its Hello")?;
        let version = match MasterMessage::decode(&payload) {
            Ok(MasterMessage::Hello(h)) => h.version,
            other => return Err(format!("expected the master's Hello, got {other:?}")),
        };
        let mine = hello(PROTOCOL_VERSION + 1, "future");
        raw.send(&worker_frame(&WorkerMessage::Hello(mine))?, None)
            .map_err(|e| e.to_string())?;
        while raw.next()?.is_some() {}
        Ok(version)
    });

    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let r = render(SMALL, &out, &["--workers", "0", "--worker", &address])?;
    let master_version = fake.join().map_err(|_| "the fake worker panicked")??;
    assert_eq!(master_version, PROTOCOL_VERSION);
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr
            .contains(&format!("protocol version {}", PROTOCOL_VERSION + 1))
            && r.stderr.contains(&format!("version {PROTOCOL_VERSION}")),
        "{}",
        r.stderr
    );
    assert!(r.stderr.contains("error: "), "{}", r.stderr);
    assert!(listing(dir.path())?.is_empty(), "{:?}", listing(dir.path()));
    Ok(())
}

#[test]
fn workers_dial_in_to_a_listening_master_and_exit_after_the_render() -> TestResult {
    let port = free_port()?;
    let master_address = format!("127.0.0.1:{port}");
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    // The workers first: they retry every 0.2 s until the master listens, so both join long
    // before one alone could finish the image (0.7 s of CPU time).
    let mut workers = Vec::new();
    for name in ["dial-1", "dial-2"] {
        workers.push(Proc::spawn(&[
            "worker",
            "--connect",
            &master_address,
            "--name",
            name,
            "--patience",
            "30",
        ])?);
    }
    let master = Proc::spawn(&render_args(
        MEDIUM,
        &out,
        &["--workers", "0", "--listen", &master_address],
    ))?;
    let r = finish(master)?;
    r.assert_success();
    assert_reference_image(&out, MEDIUM)?;
    assert_ok(&r, "dial-1")?;
    assert_ok(&r, "dial-2")?;
    for w in &mut workers {
        let status = w.wait(Duration::from_secs(20))?;
        assert!(status.success(), "{status:?}: {}", w.stderr());
        assert!(
            w.stderr().contains("the master ended the session"),
            "{}",
            w.stderr()
        );
    }
    Ok(())
}

#[test]
fn launch_starts_a_worker_per_hosts_file_line() -> TestResult {
    let dir = tempfile::tempdir()?;
    let hosts = dir.path().join("hosts");
    std::fs::write(&hosts, "127.0.0.1\nlocalhost # comment\n")?;
    let template = format!("'{BIN}' worker --connect {{master}} --name w-{{host}}");
    let out = dir.path().join("out.bmp");
    let hosts_arg = hosts.display().to_string();
    let r = render(
        MEDIUM,
        &out,
        &[
            "--workers",
            "0",
            "--hosts",
            &hosts_arg,
            "--launch",
            &template,
            "--listen",
            "127.0.0.1:0",
        ],
    )?;
    r.assert_success();
    assert_reference_image(&out, MEDIUM)?;
    assert_ok(&r, "w-127.0.0.1")?;
    assert_ok(&r, "w-localhost")?;
    assert_eq!(table(&r.stderr).len(), 2, "{}", r.stderr);
    Ok(())
}

#[test]
fn hosts_file_names_listening_workers() -> TestResult {
    let (_a, a) = Proc::listening_worker("listed-a")?;
    let (_b, b) = Proc::listening_worker("listed-b")?;
    let dir = tempfile::tempdir()?;
    let hosts = dir.path().join("hosts.txt");
    std::fs::write(
        &hosts,
        format!("# the workers\n{a}\n\n  {b}  # the second\n"),
    )?;
    let out = dir.path().join("out.bmp");
    let hosts_arg = hosts.display().to_string();
    let r = render(SMALL, &out, &["--workers", "0", "--hosts", &hosts_arg])?;
    r.assert_success();
    assert_reference_image(&out, SMALL)?;
    assert_ok(&r, "listed-a")?;
    assert_ok(&r, "listed-b")?;
    Ok(())
}

#[test]
fn bad_hosts_file_line_is_named() -> TestResult {
    let dir = tempfile::tempdir()?;
    let hosts = dir.path().join("hosts.txt");
    std::fs::write(&hosts, "127.0.0.1:7415\nnode2:http\n")?;
    let out = dir.path().join("out.bmp");
    let hosts_arg = hosts.display().to_string();
    let r = render(SMALL, &out, &["--workers", "0", "--hosts", &hosts_arg])?;
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr.contains(&format!("{hosts_arg}:2:")),
        "{}",
        r.stderr
    );
    assert!(!out.exists());
    Ok(())
}

#[test]
fn unreachable_worker_is_a_warning_when_another_works() -> TestResult {
    let (_w, address) = Proc::listening_worker("reachable")?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let r = render(
        SMALL,
        &out,
        &[
            "--workers",
            "0",
            "--worker",
            "127.0.0.1:1",
            "--worker",
            &address,
        ],
    )?;
    r.assert_success();
    assert!(
        r.stderr
            .contains("warning: cannot reach worker 127.0.0.1:1"),
        "{}",
        r.stderr
    );
    assert_reference_image(&out, SMALL)?;
    assert_ok(&r, "reachable")?;
    assert_eq!(table(&r.stderr).len(), 1, "{}", r.stderr);
    Ok(())
}

#[test]
fn only_unreachable_workers_is_an_error() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let r = render(SMALL, &out, &["--workers", "0", "--worker", "127.0.0.1:1"])?;
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    assert!(r.stderr.contains("error: "), "{}", r.stderr);
    assert!(r.stderr.contains("127.0.0.1:1"), "{}", r.stderr);
    assert!(listing(dir.path())?.is_empty(), "{:?}", listing(dir.path()));
    Ok(())
}

#[test]
fn all_workers_lost_mid_render_is_an_error_and_writes_nothing() -> TestResult {
    let (mut k1, a) = Proc::listening_worker("lost-1")?;
    let (mut k2, b) = Proc::listening_worker("lost-2")?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    std::fs::write(&out, b"old")?;
    let mut master = Proc::spawn(&render_args(
        LARGE,
        &out,
        &["--workers", "0", "--worker", &a, "--worker", &b],
    ))?;
    kill_mid_render(&mut master, &mut [&mut k1, &mut k2])?;
    let r = finish(master)?;
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    let error = r
        .stderr
        .lines()
        .find(|l| l.starts_with("error: "))
        .ok_or_else(|| format!("no error line:\n{}", r.stderr))?;
    let of = format!(" of {} lines were finished", LARGE.height);
    let at = error.find(&of).ok_or_else(|| error.to_string())?;
    let finished: u32 = error[..at]
        .rsplit(' ')
        .next()
        .ok_or("no count")?
        .parse()
        .map_err(|e| format!("{e}: {error}"))?;
    assert!((1..LARGE.height).contains(&finished), "{error}");
    assert!(
        error.contains("lost-1") && error.contains("lost-2"),
        "{error}"
    );
    assert_eq!(std::fs::read(&out)?, b"old", "the old image was touched");
    assert_eq!(listing(dir.path())?, ["out.bmp"]);
    Ok(())
}
