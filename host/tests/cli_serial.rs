//! End-to-end tests of serial workers over pseudo-terminal pairs, which stand in for serial
//! cables: `strahl render --serial` with a worker thread on the far end, `strahl worker --serial`
//! serving two masters in a row, a noisy "cable" (a thread bridging two pty pairs that flips
//! bits, drops bytes and inserts garbage), a render mixing in-process, TCP and serial workers,
//! and serial ports that do not exist.
//!
//! A pty pair from `strahl_serial::pty_pair` has a master end without a path and a slave end
//! with one (`/dev/pts/N`, found through `/proc/self/fd`), which the `strahl` binary opens like
//! any serial port. The tests keep the slave end open themselves, so the master end never reads
//! a hang-up while the binary is starting or between sessions; a worker thread on the master end
//! is stopped by writing `Hello` and `EndSession` frames into the slave end.

use std::error::Error;
use std::io::{BufRead as _, BufReader, Read, Write};
use std::os::fd::AsRawFd as _;
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::wire::frame::{FrameReader, FrameWriter, ReadEvent};
use strahl_core::wire::message::{Hello, MasterMessage};
use strahl_core::wire::{MAX_MASTER_FRAME_LEN, PROTOCOL_VERSION};
use strahl_core::worker::{NodeInfo, SceneCache};
use strahl_host::cluster::link::{Link, LinkKind};
use strahl_host::cluster::local::render_local;
use strahl_host::cluster::master::{run_master, ClusterImage, MasterOptions};
use strahl_host::cluster::prepared::PreparedScene;
use strahl_host::formats::load::{load_config_scene, Overrides};
use strahl_serial::SerialPort;

type TestResult = Result<(), Box<dyn Error>>;

/// A wall facing the camera, a small triangle in front of it that shadows it, one shader each and
/// a shadow-casting light off to the side (the fixture `cli.rs` uses too).
const DATA: &str = include_str!("fixtures/wall/room.txt");

/// The configuration: camera 10 units in front of the origin; the tests override the size.
const CONFIG: &str = include_str!("fixtures/wall/scene.cfg");

/// Image size of every render here: small, since a pty carries every line.
const WIDTH: u32 = 64;
const HEIGHT: u32 = 48;
const SIZE_ARGS: [&str; 4] = ["--width", "64", "--height", "48"];

/// The longest any `strahl` process may run before it is killed and the test fails.
const PROCESS_LIMIT: Duration = Duration::from_secs(60);
/// How long a worker thread or process gets to finish or to say something expected.
const WORKER_LIMIT: Duration = Duration::from_secs(10);

/// A temporary folder holding `scene.cfg` and `room.txt` (with `data` in it).
fn scene_dir(data: &str) -> std::io::Result<tempfile::TempDir> {
    let dir = tempfile::tempdir()?;
    std::fs::write(dir.path().join("scene.cfg"), CONFIG)?;
    std::fs::write(dir.path().join("room.txt"), data)?;
    Ok(dir)
}

/// [`DATA`] plus `n` small triangles on a grid just in front of the wall, so that the scene's
/// encoding spans several chunks and scene windows.
fn big_data(n: usize) -> String {
    let mut data = DATA.to_string();
    let side = (n as f64).sqrt().ceil() as usize;
    for i in 0..n {
        let x = -8.0 + 16.0 * (i % side) as f64 / side as f64;
        let z = -8.0 + 16.0 * (i / side) as f64 / side as f64;
        data.push_str(&format!(
            "_PT {x:.3} 4.5 {z:.3}\n_PT {:.3} 4.5 {z:.3}\n_PT {x:.3} 4.5 {:.3}\n",
            x + 0.2,
            z + 0.2
        ));
    }
    for i in 0..n {
        let p = 6 + 3 * i;
        data.push_str(&format!("_TR {p} {} {} {}\n", p + 1, p + 2, i % 2));
    }
    data
}

/// The scene of `dir`'s `scene.cfg` at the test size, prepared as `strahl render` prepares it.
fn prepare(dir: &Path) -> Result<PreparedScene, Box<dyn Error>> {
    let overrides = Overrides {
        width: Some(WIDTH),
        height: Some(HEIGHT),
        ..Overrides::default()
    };
    let loaded = load_config_scene(&dir.join("scene.cfg"), &overrides)?;
    Ok(PreparedScene::new(&loaded.desc, &OctreeParams::default())?)
}

/// The render of `prepared` by one in-process worker.
fn clean_render(prepared: &PreparedScene) -> Result<ClusterImage, Box<dyn Error>> {
    Ok(render_local(prepared, 1, &|_, _| {})?)
}

/// Master options with short probes, for tests.
fn quick_master(probe_ms: u64, timeout_s: u64) -> MasterOptions {
    MasterOptions {
        probe_interval: Duration::from_millis(probe_ms),
        worker_timeout: Duration::from_secs(timeout_s),
        wait_for_workers: Duration::from_secs(timeout_s),
        name: "test-master".to_string(),
        ..MasterOptions::default()
    }
}

// ---------------------------------------------------------------------------------------------
// Processes

fn read_all<R: Read + Send + 'static>(r: Option<R>) -> Option<JoinHandle<Vec<u8>>> {
    r.map(|mut r| {
        thread::spawn(move || {
            let mut bytes = Vec::new();
            let _ = r.read_to_end(&mut bytes);
            bytes
        })
    })
}

fn joined(h: Option<JoinHandle<Vec<u8>>>) -> Vec<u8> {
    h.and_then(|h| h.join().ok()).unwrap_or_default()
}

/// Runs `strahl ARGS...` in `cwd`, killing it after [`PROCESS_LIMIT`].
fn strahl(cwd: &Path, args: &[&str]) -> std::io::Result<Output> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .current_dir(cwd)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()?;
    let stdout = read_all(child.stdout.take());
    let stderr = read_all(child.stderr.take());
    let deadline = Instant::now() + PROCESS_LIMIT;
    let mut killed = false;
    let status = loop {
        if let Some(status) = child.try_wait()? {
            break status;
        }
        if Instant::now() >= deadline {
            killed = true;
            let _ = child.kill();
            break child.wait()?;
        }
        thread::sleep(Duration::from_millis(20));
    };
    let mut stderr = joined(stderr);
    if killed {
        stderr.extend_from_slice(b"\n[test: killed after the time limit]\n");
    }
    Ok(Output {
        status,
        stdout: joined(stdout),
        stderr,
    })
}

/// `strahl render scene.cfg --width 64 --height 48 ARGS...` in `dir`.
fn render(dir: &Path, args: &[&str]) -> std::io::Result<Output> {
    let mut all = vec!["render", "scene.cfg"];
    all.extend_from_slice(&SIZE_ARGS);
    all.extend_from_slice(args);
    strahl(dir, &all)
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Fails with the process's stderr unless it exited with code 0.
fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "exit {:?}, stderr:\n{}",
        out.status.code(),
        stderr(out)
    );
}

/// The single-worker reference image `ref.bmp` of `dir`, as bytes.
fn reference_bmp(dir: &Path) -> Result<Vec<u8>, Box<dyn Error>> {
    let out = render(dir, &["-o", "ref.bmp", "--workers", "1"])?;
    assert_success(&out);
    Ok(std::fs::read(dir.join("ref.bmp"))?)
}

/// The line of the per-worker table for the worker named `name`, split at whitespace.
fn table_row(err: &str, name: &str) -> Option<Vec<String>> {
    err.lines()
        .find(|l| l.split_whitespace().next() == Some(name))
        .map(|l| l.split_whitespace().map(str::to_string).collect())
}

/// Asserts that the table has a row for `name` over `link` whose status is `ok`; returns its
/// lines column.
fn assert_row(err: &str, name: &str, link: &str) -> u32 {
    let row = table_row(err, name).unwrap_or_else(|| panic!("no row for {name}:\n{err}"));
    assert_eq!(row.get(1).map(String::as_str), Some(link), "{err}");
    assert_eq!(row.last().map(String::as_str), Some("ok"), "{err}");
    row.get(3)
        .and_then(|l| l.parse().ok())
        .unwrap_or_else(|| panic!("no line count for {name}:\n{err}"))
}

/// A `strahl worker` process, killed when dropped; its stderr arrives line by line.
struct WorkerProcess {
    child: Child,
    lines: Receiver<String>,
    reader: Option<JoinHandle<()>>,
}

impl WorkerProcess {
    fn spawn(args: &[&str]) -> std::io::Result<Self> {
        let mut child = Command::new(env!("CARGO_BIN_EXE_strahl"))
            .arg("worker")
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()?;
        let (tx, lines) = mpsc::channel();
        let reader = child.stderr.take().map(|stderr| {
            thread::spawn(move || {
                for line in BufReader::new(stderr).lines() {
                    let Ok(line) = line else { break };
                    if tx.send(line).is_err() {
                        break;
                    }
                }
            })
        });
        Ok(WorkerProcess {
            child,
            lines,
            reader,
        })
    }

    /// Waits for a stderr line containing `needle` and returns it; the lines before it are
    /// consumed.
    fn wait_for(&self, needle: &str) -> Result<String, String> {
        let deadline = Instant::now() + WORKER_LIMIT;
        let mut seen = Vec::new();
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) if line.contains(needle) => return Ok(line),
                Ok(line) => seen.push(line),
                Err(_) => {
                    return Err(format!(
                        "the worker said nothing with `{needle}` within {WORKER_LIMIT:?}; it \
                         said: {seen:?}"
                    ))
                }
            }
        }
    }
}

impl Drop for WorkerProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(reader) = self.reader.take() {
            let _ = reader.join();
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Pseudo-terminals and a worker thread on one

/// The path of `port`'s device (`/dev/pts/N` for a pty slave end).
fn device_path(port: &SerialPort) -> Result<String, Box<dyn Error>> {
    let link = std::fs::read_link(format!("/proc/self/fd/{}", port.as_raw_fd()))?;
    let path = link.to_str().ok_or("device path is not UTF-8")?.to_string();
    assert!(path.starts_with("/dev/pts/"), "{path}");
    Ok(path)
}

/// How a worker thread ended: `serve_port`'s result, its scene cache, and how each session
/// ended.
type ThreadOutcome = (Result<(), String>, SceneCache, Vec<String>);

/// A worker thread serving one session (`strahl_serial::serve_port`, empty cache) on the master
/// end of a pty pair; the slave end (with a path) is held here.
struct PtyWorker {
    path: String,
    slave: SerialPort,
    done: Receiver<ThreadOutcome>,
    thread: Option<JoinHandle<()>>,
}

impl PtyWorker {
    fn start(name: &str) -> Result<Self, Box<dyn Error>> {
        PtyWorker::start_with(name, None)
    }

    /// A worker that requires masters to prove `secret`.
    fn start_with(name: &str, secret: Option<&'static [u8]>) -> Result<Self, Box<dyn Error>> {
        let (master, slave) = strahl_serial::pty_pair()?;
        let path = device_path(&slave)?;
        let (tx, done) = mpsc::channel();
        let name = name.to_string();
        let thread = thread::Builder::new()
            .name(format!("pty-worker-{name}"))
            .spawn(move || {
                let node = NodeInfo {
                    name: &name,
                    arch: std::env::consts::ARCH,
                    scene_memory: u64::MAX,
                    threads: 1,
                    secret,
                    nonce: || [7; 32],
                };
                let mut cache = SceneCache::new();
                let mut ends = Vec::new();
                let result =
                    strahl_serial::serve_port(master, &node, &mut cache, Some(1), &mut |outcome| {
                        ends.push(format!("{outcome:?}"))
                    })
                    .map_err(|e| format!("{e:?}"));
                let _ = tx.send((result, cache, ends));
            })?;
        Ok(PtyWorker {
            path,
            slave,
            done,
            thread: Some(thread),
        })
    }

    /// Another handle on the slave end (for a cable).
    fn peer(&self) -> Result<SerialPort, strahl_serial::Error> {
        self.slave.try_clone_native()
    }

    /// Waits for the thread to finish its session by itself.
    fn finish(&mut self) -> Result<ThreadOutcome, String> {
        let outcome = self
            .done
            .recv_timeout(WORKER_LIMIT)
            .map_err(|_| format!("the worker thread did not finish within {WORKER_LIMIT:?}"))?;
        if let Some(thread) = self.thread.take() {
            thread
                .join()
                .map_err(|_| "the worker thread panicked".to_string())?;
        }
        Ok(outcome)
    }

    /// Ends the worker's session from the slave end (`Hello`, then `EndSession`), then waits.
    fn stop(&mut self) -> Result<ThreadOutcome, String> {
        let mut frames = FrameWriter::new();
        let mut bytes = vec![0u8];
        let hello = MasterMessage::Hello(Hello {
            version: PROTOCOL_VERSION,
            name: "test-stop",
            arch: "test",
            scene_memory: 0,
            threads: 0,
            nonce: [0; 32],
            proof: None,
        });
        for msg in [hello, MasterMessage::EndSession] {
            bytes.extend_from_slice(frames.encode(&msg).map_err(|e| format!("{e:?}"))?);
        }
        // The thread may be gone already; then nobody reads these bytes.
        let _ = self
            .slave
            .write_all(&bytes)
            .and_then(|()| self.slave.flush());
        self.finish()
    }
}

impl Drop for PtyWorker {
    fn drop(&mut self) {
        if self.thread.is_some() {
            // A thread that does not stop is left behind rather than hanging the test.
            let _ = self.stop();
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Recording what the master sends

/// Bytes a [`Tee`] has seen.
type ByteLog = Arc<Mutex<Vec<u8>>>;

/// A writer that keeps a copy of every byte written through it.
struct Tee {
    inner: Box<dyn Write + Send>,
    log: ByteLog,
}

impl Write for Tee {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.log
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .extend_from_slice(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// A serial link over `port` whose outgoing bytes are also kept in the returned log.
fn recorded_link(address: &str, port: SerialPort) -> Result<(Link, ByteLog), Box<dyn Error>> {
    let mut link = Link::from_serial(address.to_string(), port)?;
    let log = Arc::new(Mutex::new(Vec::new()));
    let inner = std::mem::replace(&mut link.writer, Box::new(std::io::sink()));
    link.writer = Box::new(Tee {
        inner,
        log: Arc::clone(&log),
    });
    Ok((link, log))
}

/// The number of `SceneChunk` messages in a master's byte stream.
fn scene_chunks(log: &Mutex<Vec<u8>>) -> usize {
    let bytes = log
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .clone();
    let mut buf = vec![0u8; MAX_MASTER_FRAME_LEN];
    let mut frames = FrameReader::new(&mut buf[..]);
    let mut stream: &[u8] = &bytes;
    let mut chunks = 0;
    loop {
        match frames.next(&mut stream) {
            Ok(ReadEvent::Frame(payload)) => {
                if let Ok(MasterMessage::SceneChunk { .. }) = MasterMessage::decode(payload) {
                    chunks += 1;
                }
            }
            Ok(ReadEvent::Dropped(_)) => {}
            Err(_) => return chunks,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// A noisy cable

/// A small seeded generator (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }

    /// True with probability `per_mille` / 1000.
    fn chance(&mut self, per_mille: u64) -> bool {
        self.below(1000) < per_mille
    }
}

/// How one direction of the cable damages bytes. Frames are found by their `0x00` delimiters.
#[derive(Clone, Copy, Debug)]
struct Noise {
    seed: u64,
    /// Per mille of frames damaged inside: a bit flip, dropped bytes (a truncated or shortened
    /// frame) or a burst of garbage; a fifth of this, per mille of delimiters lost (two frames
    /// run together).
    frame: u64,
    /// Per mille of delimiters followed by a burst of garbage (between frames, or at the start of
    /// one).
    between: u64,
}

/// What a damager did.
#[derive(Clone, Copy, Debug, Default)]
struct Damage {
    flips: u32,
    drops: u32,
    bursts: u32,
    between: u32,
    merges: u32,
}

impl Damage {
    fn total(&self) -> u32 {
        self.flips + self.drops + self.bursts + self.between + self.merges
    }
}

#[derive(Clone, Copy, Debug)]
enum Plan {
    Clean,
    Flip { at: usize, bit: u8 },
    Drop { at: usize, len: usize },
    Burst { at: usize, len: usize },
}

struct Damager {
    rng: Rng,
    noise: Noise,
    plan: Plan,
    /// Position of the next byte within its frame.
    pos: usize,
    /// Dropping delimiters until the next other byte.
    merging: bool,
    done: Damage,
}

impl Damager {
    fn new(noise: Noise) -> Self {
        Damager {
            rng: Rng(noise.seed),
            noise,
            plan: Plan::Clean,
            pos: 0,
            merging: false,
            done: Damage::default(),
        }
    }

    fn choose(&mut self) -> Plan {
        if !self.rng.chance(self.noise.frame) {
            return Plan::Clean;
        }
        // Most frames here are short requests: damage near their start.
        let at = self.rng.below(12) as usize;
        match self.rng.below(4) {
            0 | 1 => Plan::Flip {
                at,
                bit: self.rng.below(8) as u8,
            },
            2 => Plan::Drop {
                at,
                // Up to 8 bytes, or the rest of the frame.
                len: if self.rng.chance(300) {
                    usize::MAX
                } else {
                    1 + self.rng.below(8) as usize
                },
            },
            _ => Plan::Burst {
                at,
                len: 1 + self.rng.below(16) as usize,
            },
        }
    }

    fn garbage(&mut self, len: usize, out: &mut Vec<u8>) {
        for _ in 0..len {
            out.push(self.rng.next() as u8);
        }
    }

    fn apply(&mut self, input: &[u8], out: &mut Vec<u8>) {
        for &b in input {
            if b == 0 {
                if self.merging || self.rng.chance(self.noise.frame / 5) {
                    // A lost delimiter (or two, between frames): two frames run together.
                    if !self.merging {
                        self.done.merges += 1;
                    }
                    self.merging = true;
                    continue;
                }
                out.push(0);
                if self.rng.chance(self.noise.between) {
                    let len = 1 + self.rng.below(24) as usize;
                    self.garbage(len, out);
                    self.done.between += 1;
                }
                self.pos = 0;
                self.plan = self.choose();
                continue;
            }
            self.merging = false;
            let pos = self.pos;
            self.pos += 1;
            match self.plan {
                Plan::Flip { at, bit } if at == pos => {
                    out.push(b ^ (1 << bit));
                    self.done.flips += 1;
                }
                Plan::Drop { at, len } if pos >= at && pos - at < len => {
                    if pos == at {
                        self.done.drops += 1;
                    }
                }
                Plan::Burst { at, len } if at == pos => {
                    out.push(b);
                    self.garbage(len, out);
                    self.done.bursts += 1;
                }
                _ => out.push(b),
            }
        }
    }
}

/// Copies bytes from `from` to `to` (damaged by `noise`, if given) until `stop` or a link error.
fn pump(
    mut from: SerialPort,
    mut to: SerialPort,
    noise: Option<Noise>,
    stop: &AtomicBool,
) -> Damage {
    let mut damager = noise.map(Damager::new);
    let mut buf = [0u8; 4096];
    let mut out = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        let n = match from.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted
                ) =>
            {
                continue
            }
            Err(_) => break,
        };
        out.clear();
        match &mut damager {
            Some(d) => d.apply(&buf[..n], &mut out),
            None => out.extend_from_slice(&buf[..n]),
        }
        let mut rest = &out[..];
        while !rest.is_empty() && !stop.load(Ordering::Relaxed) {
            match to.write(rest) {
                Ok(0) => return damager.map(|d| d.done).unwrap_or_default(),
                Ok(k) => rest = &rest[k..],
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::TimedOut
                            | std::io::ErrorKind::Interrupted
                            | std::io::ErrorKind::WouldBlock
                    ) => {}
                Err(_) => return damager.map(|d| d.done).unwrap_or_default(),
            }
        }
    }
    damager.map(|d| d.done).unwrap_or_default()
}

/// Two threads copying bytes both ways between two ports, stopped (and joined) when dropped.
struct Cable {
    stop: Arc<AtomicBool>,
    pumps: Vec<JoinHandle<Damage>>,
}

impl Cable {
    /// Bridges port `a` (two handles: read, write) and port `b`; `a_to_b` and `b_to_a` damage
    /// the two directions.
    fn connect(
        a: (SerialPort, SerialPort),
        b: (SerialPort, SerialPort),
        a_to_b: Option<Noise>,
        b_to_a: Option<Noise>,
    ) -> std::io::Result<Self> {
        let stop = Arc::new(AtomicBool::new(false));
        let mut cable = Cable {
            stop: Arc::clone(&stop),
            pumps: Vec::new(),
        };
        let (a_read, a_write) = a;
        let (b_read, b_write) = b;
        for (name, from, to, noise) in [
            ("cable-a-b", a_read, b_write, a_to_b),
            ("cable-b-a", b_read, a_write, b_to_a),
        ] {
            let stop = Arc::clone(&stop);
            cable.pumps.push(
                thread::Builder::new()
                    .name(name.to_string())
                    .spawn(move || pump(from, to, noise, &stop))?,
            );
        }
        Ok(cable)
    }

    /// Stops both directions; returns the damage done a→b and b→a.
    fn stop(&mut self) -> Vec<Damage> {
        self.stop.store(true, Ordering::Relaxed);
        self.pumps
            .drain(..)
            .map(|p| p.join().unwrap_or_default())
            .collect()
    }
}

impl Drop for Cable {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Renders `prepared` through a master in this process and a worker thread, over a cable between
/// two pty pairs that damages what goes to the worker with `to_worker` and what comes back with
/// `to_master`. Returns the image and the damage done each way.
fn render_over_cable(
    prepared: &PreparedScene,
    to_worker: Option<Noise>,
    to_master: Option<Noise>,
) -> Result<(ClusterImage, Vec<Damage>), Box<dyn Error>> {
    let (master_end, master_side) = strahl_serial::pty_pair()?;
    let mut worker = PtyWorker::start("noisy-worker")?;
    let mut cable = Cable::connect(
        (master_side.try_clone_native()?, master_side),
        (worker.peer()?, worker.peer()?),
        to_worker,
        to_master,
    )?;
    let link = Link::from_serial("cable".to_string(), master_end)?;
    let logs = Mutex::new(Vec::new());
    let started = Instant::now();
    let image = run_master(
        &prepared.job(),
        vec![link],
        None,
        &quick_master(100, 3),
        &|_, _| {},
        &|msg| {
            logs.lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .push(msg.to_string());
        },
    );
    let elapsed = started.elapsed();
    let damage = cable.stop();
    // The EndSession may have been damaged: end the session from the worker's side of the cable.
    let outcome = worker.stop();
    let image = image.map_err(|e| {
        format!(
            "{e} (after {elapsed:?}; damage {damage:?}; master log {:?})",
            logs.lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
        )
    })?;
    let (result, _, _) = outcome?;
    // The session ended one way or another; only a broken link is acceptable besides success.
    if let Err(e) = result {
        assert!(e.contains("Link"), "worker error: {e}");
    }
    Ok((image, damage))
}

// ---------------------------------------------------------------------------------------------
// Tests

#[test]
fn cli_master_renders_with_a_serial_worker_thread() -> TestResult {
    let dir = scene_dir(DATA)?;
    let reference = reference_bmp(dir.path())?;
    let prepared = prepare(dir.path())?;
    let mut worker = PtyWorker::start("pty-worker")?;

    let out = render(
        dir.path(),
        &[
            "-o",
            "serial.bmp",
            "--workers",
            "0",
            "--serial",
            &worker.path,
        ],
    )?;
    let (result, cache, ends) = worker.finish()?;
    assert_success(&out);
    assert_eq!(result, Ok(()));
    assert_eq!(ends, ["Ok(Ended)"], "the master ended the session");
    assert!(
        cache.get(&prepared.blob.digest).is_some(),
        "the worker received and cached the scene over the serial link"
    );
    assert_eq!(std::fs::read(dir.path().join("serial.bmp"))?, reference);

    let err = stderr(&out);
    let lines = assert_row(&err, "pty-worker", "serial");
    assert_eq!(lines, HEIGHT, "the only worker rendered every line:\n{err}");
    Ok(())
}

#[test]
fn cli_worker_serves_two_masters_on_one_serial_link() -> TestResult {
    let dir = scene_dir(DATA)?;
    let prepared = prepare(dir.path())?;
    let clean = clean_render(&prepared)?;
    let (master_end, slave) = strahl_serial::pty_pair()?;
    let path = device_path(&slave)?;

    let worker = WorkerProcess::spawn(&["--serial", &path, "--name", "serial-proc"])?;
    worker.wait_for("serving on")?;
    let opts = quick_master(200, 10);

    for session in 1..=2 {
        // Each session's link gets its own handle; `master_end` keeps the pty open between them.
        let (link, log) = recorded_link(&path, master_end.try_clone_native()?)?;
        let image = run_master(
            &prepared.job(),
            vec![link],
            None,
            &opts,
            &|_, _| {},
            &|_| {},
        )?;
        assert!(
            image.pixels == clean.pixels,
            "session {session}: pixels differ"
        );
        assert_eq!(image.workers.len(), 1);
        let report = &image.workers[0];
        assert_eq!(report.name, "serial-proc");
        assert_eq!(report.kind, LinkKind::Serial);
        assert_eq!(report.lines, HEIGHT);
        assert_eq!(report.lost, None);
        worker.wait_for("the master ended the session")?;
        // The first session's reader thread stops at its next read time-out; let it, so it
        // takes no bytes of the next session.
        thread::sleep(strahl_serial::READ_TIMEOUT * 3);
        let chunks = scene_chunks(&log);
        if session == 1 {
            assert!(chunks > 0, "the scene went over the link");
        } else {
            assert_eq!(chunks, 0, "the worker kept the scene: no transfer");
        }
    }
    drop(worker);
    drop((master_end, slave));
    Ok(())
}

#[test]
fn noisy_cable_both_ways_gives_the_clean_image() -> TestResult {
    let dir = scene_dir(&big_data(1000))?;
    let prepared = prepare(dir.path())?;
    assert!(
        prepared.blob.len() > 2 * strahl_core::wire::SCENE_WINDOW,
        "the scene spans several windows: {} bytes",
        prepared.blob.len()
    );
    let clean = clean_render(&prepared)?;
    let (image, damage) = render_over_cable(
        &prepared,
        Some(Noise {
            seed: 0x5EED_0001,
            frame: 120,
            between: 40,
        }),
        Some(Noise {
            seed: 0x5EED_0002,
            frame: 150,
            between: 40,
        }),
    )?;
    assert!(
        damage.iter().all(|d| d.total() > 0),
        "the cable damaged both ways: {damage:?}"
    );
    assert!(image.pixels == clean.pixels, "the noisy render differs");
    let report = &image.workers[0];
    assert_eq!(report.lost, None);
    assert_eq!(report.lines, HEIGHT);
    assert!(report.frames_dropped > 0, "damage was detected: {report:?}");
    Ok(())
}

#[test]
fn noisy_cable_to_the_worker_only_gives_the_clean_image() -> TestResult {
    let dir = scene_dir(&big_data(1000))?;
    let prepared = prepare(dir.path())?;
    let clean = clean_render(&prepared)?;
    let (image, damage) = render_over_cable(
        &prepared,
        Some(Noise {
            seed: 0x5EED_0003,
            frame: 200,
            between: 50,
        }),
        None,
    )?;
    assert!(damage[0].total() > 0, "the cable damaged: {damage:?}");
    assert_eq!(damage[1].total(), 0);
    assert!(image.pixels == clean.pixels, "the noisy render differs");
    let report = &image.workers[0];
    assert_eq!(report.lost, None);
    assert!(
        report.frames_dropped > 0,
        "the worker reported the damaged frames: {report:?}"
    );
    Ok(())
}

#[test]
fn cli_mixes_local_tcp_and_serial_workers() -> TestResult {
    let dir = scene_dir(DATA)?;
    // 16 samples per pixel: a line costs enough that a worker still greeting finds lines left
    // (at one sample the in-process worker could finish all 48 before a TCP worker has said
    // hello, render after render).
    let out = render(dir.path(), &["-o", "ref.bmp", "--workers", "1", "-m", "4"])?;
    assert_success(&out);
    let reference = std::fs::read(dir.path().join("ref.bmp"))?;
    let tcp = WorkerProcess::spawn(&["--listen", "127.0.0.1:0", "--name", "tcp-proc"])?;
    let line = tcp.wait_for("listening on ")?;
    let address = line
        .rsplit_once("listening on ")
        .map(|(_, a)| a.trim().to_string())
        .ok_or("no address")?;
    // On a loaded machine the other two can finish all 48 lines before a slow worker has said
    // hello (its row then carries its link's name and no line). Every render must be right; one
    // of a few must show all three workers rendering, or the test fails.
    const ATTEMPTS: usize = 10;
    for attempt in 1..=ATTEMPTS {
        let mut serial = PtyWorker::start("pty-worker")?;
        let image = format!("mixed{attempt}.bmp");
        let out = render(
            dir.path(),
            &[
                "-o",
                &image,
                "-m",
                "4",
                "--workers",
                "1",
                "--worker",
                &address,
                "--serial",
                &serial.path,
            ],
        )?;
        let (result, _, _) = serial.finish()?;
        assert_success(&out);
        assert_eq!(result, Ok(()));
        assert_eq!(std::fs::read(dir.path().join(&image))?, reference);
        let err = stderr(&out);
        assert!(err.contains("3 workers"), "{err}");
        let greeted = |name: &str, link_name: &str, link: &str| match table_row(&err, name) {
            Some(_) => assert_row(&err, name, link),
            None => assert_row(&err, link_name, link),
        };
        let lines = [
            greeted("local-1", "local-1", "local"),
            greeted("tcp-proc", &address, "tcp"),
            greeted("pty-worker", &serial.path, "serial"),
        ];
        assert_eq!(
            lines.iter().sum::<u32>(),
            HEIGHT,
            "each line used once:\n{err}"
        );
        if lines.iter().all(|&l| l > 0) {
            drop(tcp);
            return Ok(());
        }
        eprintln!("attempt {attempt}: not every worker rendered a line:\n{err}");
    }
    Err(format!("in {ATTEMPTS} renders the three workers never all rendered a line").into())
}

#[test]
fn missing_serial_port_is_a_warning_unless_it_is_the_only_worker() -> TestResult {
    let dir = scene_dir(DATA)?;
    let reference = reference_bmp(dir.path())?;
    let bad = "/dev/does-not-exist";

    let out = render(
        dir.path(),
        &["-o", "with.bmp", "--workers", "1", "--serial", bad],
    )?;
    assert_success(&out);
    let err = stderr(&out);
    assert!(
        err.lines()
            .any(|l| l.starts_with("warning: ") && l.contains(bad)),
        "{err}"
    );
    assert_eq!(std::fs::read(dir.path().join("with.bmp"))?, reference);

    let out = render(
        dir.path(),
        &["-o", "without.bmp", "--workers", "0", "--serial", bad],
    )?;
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("error: "), "{err}");
    assert!(err.contains(bad), "{err}");
    assert!(!dir.path().join("without.bmp").exists());
    Ok(())
}

#[test]
fn worker_on_a_missing_serial_port_fails() -> TestResult {
    let dir = tempfile::tempdir()?;
    let bad = "/dev/does-not-exist";
    let out = strahl(dir.path(), &["worker", "--serial", bad])?;
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.starts_with("error: "), "{err}");
    assert!(err.contains(bad), "{err}");
    Ok(())
}

#[test]
fn the_shared_secret_works_over_a_serial_link() -> TestResult {
    // The same handshake as over TCP: a master with the worker's secret renders the reference
    // image; one without it is told the worker requires one.
    const SECRET: &[u8] = b"a serial cable's secret, 16+ bytes";
    let dir = scene_dir(DATA)?;
    let reference = reference_bmp(dir.path())?;
    std::fs::write(dir.path().join("key"), SECRET)?;
    let mut worker = PtyWorker::start_with("pty-guarded", Some(SECRET))?;
    let out = render(
        dir.path(),
        &[
            "-o",
            "s.bmp",
            "--workers",
            "0",
            "--serial",
            &worker.path,
            "--secret-file",
            "key",
        ],
    )?;
    assert_success(&out);
    assert_eq!(std::fs::read(dir.path().join("s.bmp"))?, reference);
    let (result, _, ends) = worker.finish()?;
    assert_eq!(result, Ok(()));
    assert_eq!(ends, ["Ok(Ended)"]);

    let mut worker = PtyWorker::start_with("pty-guarded", Some(SECRET))?;
    let out = render(
        dir.path(),
        &["-o", "n.bmp", "--workers", "0", "--serial", &worker.path],
    )?;
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("it requires a shared secret"),
        "{}",
        stderr(&out)
    );
    let (_, _, ends) = worker.finish()?;
    assert_eq!(
        ends,
        ["Err(Rejected(MasterHasNoSecret))"],
        "the worker logs why"
    );
    Ok(())
}
