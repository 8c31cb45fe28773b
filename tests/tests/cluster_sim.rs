//! The real master (`run_master`) against in-process and simulated workers: the image of a
//! distributed render is byte-identical to a single worker's, whatever the worker count and
//! window, and stays identical when workers crash, hang, run slow, sit behind slow links, receive
//! the scene over links that damage chunks, or garble frames in either direction. The reports say
//! what happened: lost workers, re-issued lines, dropped frames, duplicates.
//!
//! Outcomes here must not depend on thread timing. Where an assertion needs one event to happen
//! before another (a crash noticed before the image is finished, a slow worker holding lines when
//! a fast one starts, a late copy arriving before the last line), the test orders them itself
//! instead of sleeping: a worker's frames are held back from the master, or the master's line
//! requests from a worker, until the master has reported other workers lost, has sent a line
//! request to another worker, or has finished the image; in the 72-worker test the healthy
//! workers join only after the faulty ones are reported lost. Where the master must notice a hang
//! before the image is done, the other worker's link bandwidth makes the image take more than
//! twice the time-out. Crash and hang points leave room for the frames a master adds under load
//! (a repeated `Hello` or `Job` is answered, and counts as a frame of the fault).

use std::io::{Read, Write};
use std::path::Path;
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::mesh::Rng;
use strahl_core::wire::frame::{FrameReader, ReadEvent};
use strahl_core::wire::message::MasterMessage;
use strahl_core::wire::{MAX_MASTER_FRAME_LEN, SCENE_WINDOW};
use strahl_core::worker::SceneCache;
use strahl_host::cluster::link::Link;
use strahl_host::cluster::local::{render_local, spawn_local_workers};
use strahl_host::cluster::master::{
    run_master, run_master_with, ClusterError, ClusterImage, Hooks, MasterOptions,
};
use strahl_host::cluster::pipe::LinkModel;
use strahl_host::cluster::prepared::PreparedScene;
use strahl_host::cluster::report::{Activity, WorkerReport, WorkerState};
use strahl_host::cluster::sim::{spawn_sim_worker, Fault, SimWorker};
use strahl_host::formats::load::{load_config_scene, Overrides};

/// The longest a gate holds a link shut; only reached if the test is already failing.
const GATE_LIMIT: Duration = Duration::from_secs(20);

// ---------------------------------------------------------------------------------------------
// Scenes and reference images
// ---------------------------------------------------------------------------------------------

/// The demo room at `width × height` with reflections on (the mirror makes some lines costlier).
fn room(width: u32, height: u32) -> PreparedScene {
    let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room/raytracer.cfg");
    let overrides = Overrides {
        width: Some(width),
        height: Some(height),
        reflections: Some(true),
        ..Overrides::default()
    };
    let desc = load_config_scene(&cfg, &overrides)
        .expect("the demo room loads")
        .desc;
    PreparedScene::new(&desc, &OctreeParams::default()).expect("the demo room is a valid scene")
}

/// The image every distributed render must reproduce: `render_line` for each line in one thread,
/// which one in-process worker behind the master reproduces.
struct Reference {
    width: usize,
    height: u32,
    pixels: Vec<Pixel>,
    /// Rays of each line.
    line_rays: Vec<RayCounts>,
    rays: RayCounts,
}

/// Renders `prepared` line by line in this thread, and checks that one in-process worker behind
/// the master produces the same pixels and rays.
fn reference(prepared: &PreparedScene) -> Reference {
    let scene = &prepared.scene;
    let width = scene.settings.width as usize;
    let height = scene.settings.height;
    let mut pixels = vec![Pixel::default(); width * height as usize];
    let mut line_rays = Vec::new();
    let mut rays = RayCounts::default();
    for (y, out) in (0..height).zip(pixels.chunks_mut(width)) {
        let r = render_line(scene, y, out).expect("every line of the image renders");
        line_rays.push(r);
        rays += r;
    }
    let reference = Reference {
        width,
        height,
        pixels,
        line_rays,
        rays,
    };
    let single = render_local(prepared, 1, &|_, _| {}).expect("one in-process worker renders");
    assert_same_image(&single, &reference, "one in-process worker");
    reference
}

/// Asserts that `image` has exactly the reference's pixels, and the rays of each line once.
fn assert_same_image(image: &ClusterImage, want: &Reference, what: &str) {
    assert_same_pixels(image, want, what);
    assert_duplicates_carry_the_extra_rays(image, want, what);
}

/// Asserts that `image` has exactly the reference's pixels and rays, and that its workers'
/// used lines add up to its height.
fn assert_same_pixels(image: &ClusterImage, want: &Reference, what: &str) {
    assert_eq!(
        image.pixels.len(),
        want.pixels.len(),
        "{what}: the image has the wrong size"
    );
    let differing = image
        .pixels
        .iter()
        .zip(&want.pixels)
        .filter(|(a, b)| a != b)
        .count();
    if let Some(i) = image
        .pixels
        .iter()
        .zip(&want.pixels)
        .position(|(a, b)| a != b)
    {
        panic!(
            "{what}: {differing} pixels differ from the reference image, the first at \
             ({}, {}): {:?} instead of {:?}",
            i % want.width,
            i / want.width,
            image.pixels[i],
            want.pixels[i]
        );
    }
    assert_eq!(
        image.rays, want.rays,
        "{what}: the rays of the lines used are not those of one render"
    );
    let used: u32 = image.workers.iter().map(|w| w.lines).sum();
    assert_eq!(
        used,
        want.height,
        "{what}: the workers' used lines do not add up to the image height: {}",
        table(&image.workers)
    );
}

/// Asserts that the rays the workers delivered beyond the image's are those of their
/// duplicates.
fn assert_duplicates_carry_the_extra_rays(image: &ClusterImage, want: &Reference, what: &str) {
    // Each result's rays are in its worker's report, used or not; the image has each line's
    // rays once. The difference is the rays of the duplicates.
    let delivered: u64 = image.workers.iter().map(|w| w.rays.total()).sum();
    let duplicates = u64::from(image.workers.iter().map(|w| w.duplicates).sum::<u32>());
    let extra = delivered
        .checked_sub(image.rays.total())
        .unwrap_or_else(|| {
            panic!(
                "{what}: the workers delivered fewer rays than the image has: {}",
                table(&image.workers)
            )
        });
    let min = want
        .line_rays
        .iter()
        .map(RayCounts::total)
        .min()
        .unwrap_or(0);
    let max = want
        .line_rays
        .iter()
        .map(RayCounts::total)
        .max()
        .unwrap_or(0);
    assert!(
        (duplicates * min..=duplicates * max).contains(&extra),
        "{what}: {duplicates} duplicates carried {extra} rays, lines have {min} to {max}: {}",
        table(&image.workers)
    );
}

/// The workers' reports, one per line, for assertion messages.
fn table(workers: &[WorkerReport]) -> String {
    workers
        .iter()
        .map(|w| {
            format!(
                "\n  {} ({}): lines {}, dup {}, reissued {}, dropped {}, lost {:?}",
                w.name, w.address, w.lines, w.duplicates, w.reissued, w.frames_dropped, w.lost
            )
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Master options and runs
// ---------------------------------------------------------------------------------------------

/// Short time-outs: probes after 50 ms of silence, a worker silent for `timeout_ms` is dropped.
fn options(window: u32, timeout_ms: u64) -> MasterOptions {
    MasterOptions {
        window,
        lines_per_request: None,
        probe_interval: Duration::from_millis(50),
        worker_timeout: Duration::from_millis(timeout_ms),
        wait_for_workers: Duration::from_secs(30),
        name: "cluster-sim-test".to_string(),
        secret: None,
        verify: 0.0,
    }
}

/// Runs the master over `links` (and `joins`), logging into `log`.
fn master(
    prepared: &PreparedScene,
    links: Vec<Link>,
    joins: Option<&Receiver<Link>>,
    opts: &MasterOptions,
    log: &(dyn Fn(&str) + Sync),
) -> Result<ClusterImage, ClusterError> {
    run_master(&prepared.job(), links, joins, opts, &|_, _| {}, log)
}

/// Simulated worker `index` with `spec` and `cache`.
fn sim(index: usize, spec: SimWorker, cache: &SceneCache) -> Link {
    spawn_sim_worker(index, spec, cache).expect("a simulated worker's thread starts")
}

/// A link direction that flips bits at `rate` per byte, seeded with `seed`.
fn flips(rate: f64, seed: u64) -> LinkModel {
    LinkModel {
        bit_flip_rate: Some(rate),
        seed,
        ..LinkModel::default()
    }
}

/// A link direction that carries `bytes_per_second`.
fn bandwidth(bytes_per_second: u64) -> LinkModel {
    LinkModel {
        bytes_per_second: Some(bytes_per_second),
        ..LinkModel::default()
    }
}

/// The report of the worker whose link was named `address`.
fn report<'a>(workers: &'a [WorkerReport], address: &str) -> &'a WorkerReport {
    workers
        .iter()
        .find(|w| w.address == address)
        .unwrap_or_else(|| panic!("no report for {address}: {}", table(workers)))
}

// ---------------------------------------------------------------------------------------------
// Ordering helpers: gates, held links, spies on line requests
// ---------------------------------------------------------------------------------------------

/// A one-way gate: closed until opened.
#[derive(Default)]
struct Gate {
    open: Mutex<bool>,
    cv: Condvar,
}

impl Gate {
    fn open(&self) {
        *self.open.lock().expect("gate lock") = true;
        self.cv.notify_all();
    }

    /// Waits until the gate is open (at most `limit`); whether it is.
    fn wait(&self, limit: Duration) -> bool {
        let open = self.open.lock().expect("gate lock");
        let (open, _) = self
            .cv
            .wait_timeout_while(open, limit, |open| !*open)
            .expect("gate lock");
        *open
    }
}

/// A reader that delivers nothing until its gate opens.
struct GatedReader {
    inner: Box<dyn Read + Send>,
    gate: Arc<Gate>,
    passed: bool,
}

impl Read for GatedReader {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if !self.passed {
            self.gate.wait(GATE_LIMIT);
            self.passed = true;
        }
        self.inner.read(buf)
    }
}

/// `link`, with the worker's frames held back (the worker runs; the master hears nothing from
/// it) until `gate` opens.
fn held(link: Link, gate: &Arc<Gate>) -> Link {
    let Link {
        address,
        kind,
        reader,
        writer,
        closer,
        hang_up,
    } = link;
    Link {
        address,
        kind,
        reader: Box::new(GatedReader {
            inner: reader,
            gate: Arc::clone(gate),
            passed: false,
        }),
        writer,
        closer,
        hang_up,
    }
}

/// The line requests the master sent to one worker, seen on the wire.
#[derive(Default)]
struct Spy {
    lines: Mutex<Vec<u32>>,
    /// Opens at the first line request.
    requested: Arc<Gate>,
}

impl Spy {
    fn lines(&self) -> Vec<u32> {
        self.lines.lock().expect("spy lock").clone()
    }
}

/// Holds back the master's line requests to one worker: a request for `line` (any line if
/// `None`) first opens `opens`, then waits for `waits` before it goes out.
struct Hold {
    line: Option<u32>,
    opens: Option<Arc<Gate>>,
    waits: Arc<Gate>,
}

/// A writer that decodes the master's frames as they go out, records line requests, and holds
/// them back as its [`Hold`] says.
struct SpyWriter {
    inner: Box<dyn Write + Send>,
    frames: FrameReader<Vec<u8>>,
    spy: Arc<Spy>,
    hold: Option<Hold>,
}

impl Write for SpyWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        // The master writes whole frames; a frame split over writes is seen at its end.
        let mut bytes = buf;
        loop {
            match self.frames.next(&mut bytes) {
                Ok(ReadEvent::Frame(payload)) => {
                    if let Ok(MasterMessage::RenderLine { line, .. }) =
                        MasterMessage::decode(payload)
                    {
                        self.spy.lines.lock().expect("spy lock").push(line);
                        self.spy.requested.open();
                        if let Some(hold) = &self.hold {
                            if hold.line.is_none_or(|l| l == line) {
                                if let Some(gate) = &hold.opens {
                                    gate.open();
                                }
                                hold.waits.wait(GATE_LIMIT);
                            }
                        }
                    }
                }
                Ok(ReadEvent::Dropped(_)) => {}
                // All bytes of this write seen; a partial frame waits for the next write.
                Err(_) => break,
            }
        }
        self.inner.write_all(buf)?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// `link`, with the master's line requests to it recorded in the returned spy.
fn spied(link: Link) -> (Link, Arc<Spy>) {
    spied_holding(link, None)
}

/// `link`, with the master's line requests to it recorded in the returned spy and held back as
/// `hold` says.
fn spied_holding(link: Link, hold: Option<Hold>) -> (Link, Arc<Spy>) {
    let spy = Arc::new(Spy::default());
    let Link {
        address,
        kind,
        reader,
        writer,
        closer,
        hang_up,
    } = link;
    let link = Link {
        address,
        kind,
        reader,
        writer: Box::new(SpyWriter {
            inner: writer,
            frames: FrameReader::new(vec![0; MAX_MASTER_FRAME_LEN]),
            spy: Arc::clone(&spy),
            hold,
        }),
        closer,
        hang_up,
    };
    (link, spy)
}

/// A log callback that counts lost workers and opens `gate` at the `n`-th.
struct LossCounter {
    messages: Mutex<Vec<String>>,
    gate: Arc<Gate>,
    open_at: usize,
}

impl LossCounter {
    fn new(open_at: usize) -> Self {
        LossCounter {
            messages: Mutex::new(Vec::new()),
            gate: Arc::new(Gate::default()),
            open_at,
        }
    }

    fn log(&self, message: &str) {
        let mut messages = self.messages.lock().expect("log lock");
        messages.push(message.to_string());
        if messages.len() >= self.open_at {
            self.gate.open();
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 1. Worker count and window do not change the image
// ---------------------------------------------------------------------------------------------

#[test]
fn worker_count_and_window_do_not_change_the_image() {
    let prepared = room(64, 48);
    let want = reference(&prepared);
    assert!(
        want.line_rays.iter().any(|r| r.reflection > 0),
        "the scene must trace reflections, so lines differ in cost"
    );
    for workers in [1, 2, 3, 8] {
        let image = render_local(&prepared, workers, &|_, _| {}).expect("in-process render");
        assert_same_image(&image, &want, &format!("{workers} workers, window 2"));
        assert_eq!(image.workers.len(), workers);
        for window in [1, 4] {
            let links =
                spawn_local_workers(workers, &prepared.cache()).expect("worker threads start");
            let opts = MasterOptions {
                window,
                ..MasterOptions::default()
            };
            let image = master(&prepared, links, None, &opts, &|_| {}).expect("in-process render");
            let what = format!("{workers} workers, window {window}");
            assert_same_image(&image, &want, &what);
            for w in &image.workers {
                assert!(
                    w.lost.is_none() && w.reissued == 0 && w.frames_dropped == 0,
                    "{what}: a clean in-process worker lost work: {}",
                    table(&image.workers)
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 2. 72 simulated workers with a seeded mix of faults
// ---------------------------------------------------------------------------------------------

/// 72 simulated workers. The first 12 start alone: 8 crash (during the handshake or after up to
/// 4 results) and 4 hang. Once the master has reported all 12 lost, 60 more join: clean, 3× slow,
/// with latency, with bit flips up, down or both at 1e-4 to 1e-3 per byte, some combined.
#[test]
fn seventy_two_simulated_workers_with_faults() {
    let prepared = room(40, 160);
    let want = reference(&prepared);
    let cache = prepared.cache();
    let mut rng = Rng::new(0x5eed_c1a5);

    let early_faults = [
        Fault::CrashAt(1),
        Fault::CrashAt(2),
        Fault::CrashAt(3),
        Fault::CrashAt(4),
        Fault::CrashAt(5),
        Fault::CrashAt(6),
        Fault::CrashAt(7),
        Fault::CrashAt(7),
        Fault::HangAt(2),
        Fault::HangAt(3),
        Fault::HangAt(5),
        Fault::HangAt(6),
    ];
    let mut specs: Vec<SimWorker> = early_faults
        .iter()
        .map(|&fault| SimWorker {
            fault,
            ..SimWorker::default()
        })
        .collect();
    let early = specs.len();
    for i in 0..60 {
        let rate = |rng: &mut Rng| f64::from(rng.range(1e-4, 1e-3));
        let latency = |rng: &mut Rng| LinkModel {
            latency: Duration::from_micros(500 + rng.next_u64() % 4500),
            ..LinkModel::default()
        };
        let mut spec = SimWorker::default();
        match i % 6 {
            0 => {}
            1 => spec.fault = Fault::Slow(3.0),
            2 => spec.up = flips(rate(&mut rng), rng.next_u64()),
            3 => spec.down = flips(rate(&mut rng), rng.next_u64()),
            4 => {
                spec.up = flips(rate(&mut rng), rng.next_u64());
                spec.down = flips(rate(&mut rng), rng.next_u64());
            }
            _ => {
                spec.up = latency(&mut rng);
                spec.down = latency(&mut rng);
            }
        }
        // Every fourth worker is also slow or delayed on top of its category.
        if i % 4 == 3 {
            if spec.fault == Fault::None {
                spec.fault = Fault::Slow(3.0);
            } else {
                spec.up.latency = Duration::from_millis(2);
            }
        }
        specs.push(spec);
    }
    assert_eq!(specs.len(), 72);

    let links: Vec<Link> = specs
        .iter()
        .enumerate()
        .map(|(i, &spec)| sim(i + 1, spec, &cache))
        .collect();
    let mut links = links.into_iter();
    let first: Vec<Link> = links.by_ref().take(early).collect();
    let later: Vec<Link> = links.collect();

    let losses = LossCounter::new(early);
    let (join_tx, join_rx): (Sender<Link>, Receiver<Link>) = mpsc::channel();
    let opts = options(2, 500);
    let started = Instant::now();
    let result = std::thread::scope(|s| {
        let gate = Arc::clone(&losses.gate);
        s.spawn(move || {
            // The others join only after the master reported the first 12 lost, so each of
            // those losses is in its report whatever the timing.
            gate.wait(GATE_LIMIT);
            for link in later {
                join_tx
                    .send(link)
                    .expect("the master takes joining workers");
            }
        });
        master(&prepared, first, Some(&join_rx), &opts, &|m| losses.log(m))
    });
    let elapsed = started.elapsed();
    let image = result.expect("the render completes despite the faults");
    let workers = &image.workers;
    let log = losses.messages.lock().expect("log lock").clone();
    assert_same_image(&image, &want, "72 simulated workers");
    assert_eq!(workers.len(), 72, "every worker has a report");

    let mut early_reissued = 0;
    let mut dropped_on_flipping_links = 0;
    for (i, spec) in specs.iter().enumerate() {
        let w = report(workers, &format!("sim {}", i + 1));
        let flipping = spec.up.bit_flip_rate.is_some() || spec.down.bit_flip_rate.is_some();
        match spec.fault {
            Fault::CrashAt(n) | Fault::HangAt(n) => {
                let lost = w.lost.as_deref().unwrap_or_else(|| {
                    panic!(
                        "{} ({:?}) is not reported lost: {}",
                        w.address,
                        spec.fault,
                        table(workers)
                    )
                });
                if matches!(spec.fault, Fault::HangAt(_)) {
                    assert!(
                        lost.contains("no answer"),
                        "{}: a hung worker is lost for silence, not {lost:?}",
                        w.address
                    );
                }
                // Frames 1 and 2 are its Hello and Ready; it fails at frame n.
                assert!(
                    w.lines + w.duplicates <= n.saturating_sub(3),
                    "{} ({:?}) delivered more results than it sent: {}",
                    w.address,
                    spec.fault,
                    table(workers)
                );
                early_reissued += w.reissued;
            }
            Fault::None | Fault::Slow(_) | Fault::WrongPixels => {
                assert!(
                    w.lost.is_none(),
                    "{} ({spec:?}) was dropped although it answers: {}",
                    w.address,
                    table(workers)
                );
            }
        }
        if flipping {
            dropped_on_flipping_links += w.frames_dropped;
        } else {
            assert_eq!(
                w.frames_dropped, 0,
                "{}: frames dropped on a clean link",
                w.address
            );
        }
    }
    assert!(
        early_reissued > 0,
        "lines held by crashed and hung workers are re-issued: {}",
        table(workers)
    );
    assert!(
        dropped_on_flipping_links > 0,
        "links that flip bits drop frames: {}",
        table(workers)
    );
    assert_eq!(log.len(), early, "one log line per lost worker: {log:?}");
    assert!(
        elapsed < Duration::from_secs(20),
        "the render took {elapsed:?}"
    );
}

// ---------------------------------------------------------------------------------------------
// 3. The scene over the link, in several windows, through links that damage chunks
// ---------------------------------------------------------------------------------------------

#[test]
fn scene_sent_over_damaging_links() {
    let prepared = room(48, 64);
    let want = reference(&prepared);
    assert!(
        prepared.blob.len() > 3 * SCENE_WINDOW,
        "the scene ({} bytes) must span several transfer windows of {SCENE_WINDOW}",
        prepared.blob.len()
    );
    // Every worker starts with an empty cache and a link that damages chunks on the way down,
    // so every line of the image comes from a scene that crossed a damaging link.
    let specs = [
        SimWorker {
            down: flips(1e-4, 11),
            ..SimWorker::default()
        },
        SimWorker {
            down: flips(2e-4, 12),
            ..SimWorker::default()
        },
        SimWorker {
            down: flips(3e-4, 13),
            up: flips(5e-4, 14),
            ..SimWorker::default()
        },
        SimWorker {
            down: LinkModel {
                latency: Duration::from_millis(1),
                ..flips(2e-4, 15)
            },
            fault: Fault::Slow(2.0),
            ..SimWorker::default()
        },
    ];
    let links = specs
        .iter()
        .enumerate()
        .map(|(i, &spec)| sim(i + 1, spec, &SceneCache::new()))
        .collect();
    // No worker hangs here; the long time-out only spares workers building the scene.
    let image = master(&prepared, links, None, &options(2, 5_000), &|_| {})
        .expect("the render completes with scenes sent over damaging links");
    assert_same_image(&image, &want, "scenes sent over damaging links");
    let dropped: u32 = image.workers.iter().map(|w| w.frames_dropped).sum();
    assert!(
        dropped > 0,
        "damaged chunks are reported dropped: {}",
        table(&image.workers)
    );
    for w in &image.workers {
        assert!(
            w.lost.is_none(),
            "{}: lost while loading the scene: {}",
            w.address,
            table(&image.workers)
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 4. All but one worker crash early
// ---------------------------------------------------------------------------------------------

#[test]
fn all_but_one_worker_crash_early() {
    let prepared = room(64, 48);
    let want = reference(&prepared);
    let cache = prepared.cache();
    let losses = LossCounter::new(7);
    let mut links: Vec<Link> = [3, 4, 5, 6, 4, 5, 6]
        .iter()
        .enumerate()
        .map(|(i, &n)| {
            sim(
                i + 1,
                SimWorker {
                    fault: Fault::CrashAt(n),
                    ..SimWorker::default()
                },
                &cache,
            )
        })
        .collect();
    // The survivor's answers reach the master only once the 7 crashes are reported, so the
    // crashed workers hold lines when they die and cannot be outrun.
    links.push(held(sim(8, SimWorker::default(), &cache), &losses.gate));
    let image = master(&prepared, links, None, &options(2, 5_000), &|m| {
        losses.log(m)
    })
    .expect("one surviving worker finishes the image");
    assert_same_image(&image, &want, "7 of 8 workers crashed");
    let workers = &image.workers;
    let lost = workers.iter().filter(|w| w.lost.is_some()).count();
    assert_eq!(lost, 7, "7 workers are reported lost: {}", table(workers));
    let survivor = report(workers, "sim 8");
    assert!(survivor.lost.is_none(), "the survivor is not lost");
    let crashed_lines: u32 = workers
        .iter()
        .filter(|w| w.lost.is_some())
        .map(|w| w.lines)
        .sum();
    assert_eq!(survivor.lines, want.height - crashed_lines);
    let reissued: u32 = workers.iter().map(|w| w.reissued).sum();
    assert!(
        reissued > 0,
        "the crashed workers' lines were re-issued: {}",
        table(workers)
    );
}

// ---------------------------------------------------------------------------------------------
// 5. All workers crash
// ---------------------------------------------------------------------------------------------

#[test]
fn all_workers_crash() {
    let prepared = room(64, 48);
    let cache = prepared.cache();
    let links = [1, 3, 4, 5]
        .iter()
        .enumerate()
        .map(|(i, &n)| {
            sim(
                i + 1,
                SimWorker {
                    fault: Fault::CrashAt(n),
                    ..SimWorker::default()
                },
                &cache,
            )
        })
        .collect();
    let err = master(&prepared, links, None, &options(2, 500), &|_| {})
        .expect_err("no image without workers");
    let message = err.to_string();
    let ClusterError::AllWorkersLost {
        finished,
        total,
        workers,
    } = err
    else {
        panic!("expected AllWorkersLost, got {message}");
    };
    assert_eq!(total, 48);
    // At most 0 + 0 + 1 + 2 results before the crashes.
    assert!(
        finished <= 3,
        "{finished} lines finished: {}",
        table(&workers)
    );
    assert_eq!(finished, workers.iter().map(|w| w.lines).sum::<u32>());
    assert_eq!(workers.len(), 4);
    for w in &workers {
        assert!(w.lost.is_some(), "{} is not reported lost", w.address);
        assert!(
            message.contains(&w.name),
            "the message names {}: {message}",
            w.name
        );
    }
    assert!(
        message.contains(&format!("{finished} of {total} lines")),
        "the message says how many lines were finished: {message}"
    );
    assert!(message.contains("all 4 workers were lost"), "{message}");

    // No worker at all, none to join.
    let err = master(&prepared, Vec::new(), None, &options(2, 500), &|_| {})
        .expect_err("no image without workers");
    assert!(
        matches!(
            err,
            ClusterError::AllWorkersLost {
                finished: 0,
                total: 48,
                ref workers
            } if workers.is_empty()
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("0 of 48 lines"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// 6. A hung worker
// ---------------------------------------------------------------------------------------------

/// The bandwidth at which one result line of `width` pixels takes about `ms` milliseconds.
fn line_bandwidth(width: u32, ms: u64) -> u64 {
    u64::from(width) * 6 * 1000 / ms
}

#[test]
fn hung_worker_is_dropped_and_its_lines_reissued() {
    let prepared = room(64, 48);
    let want = reference(&prepared);
    let cache = prepared.cache();
    // It hangs at its 6th frame: normally its 4th result, earlier if the master had to repeat
    // its Hello or Job (each repeat costs a frame), but always while it holds lines.
    let (hung, hung_spy) = spied(sim(
        1,
        SimWorker {
            fault: Fault::HangAt(6),
            ..SimWorker::default()
        },
        &cache,
    ));
    // The other worker is heard only once the hung one holds lines, and delivers one line per
    // 25 ms or slower: the image takes over a second, the time-out is half a second.
    let steady = held(
        sim(
            2,
            SimWorker {
                up: bandwidth(line_bandwidth(64, 25)),
                ..SimWorker::default()
            },
            &cache,
        ),
        &hung_spy.requested,
    );
    let image = master(
        &prepared,
        vec![hung, steady],
        None,
        &options(2, 500),
        &|_| {},
    )
    .expect("the render completes without the hung worker");
    assert_same_image(&image, &want, "one hung worker");
    let workers = &image.workers;
    let hung = report(workers, "sim 1");
    let steady = report(workers, "sim 2");
    let lost = hung
        .lost
        .as_deref()
        .unwrap_or_else(|| panic!("the hung worker is not lost: {}", table(workers)));
    assert!(lost.contains("no answer"), "lost for silence: {lost:?}");
    assert!(hung.lines <= 3, "it hung at its 4th result at the latest");
    assert_eq!(
        hung.reissued,
        2,
        "the hung worker's window of lines was re-issued: {}",
        table(workers)
    );
    assert_eq!(
        hung_spy.lines().len() as u32,
        hung.lines + hung.reissued,
        "every line sent to the hung worker was delivered or re-issued"
    );
    assert!(steady.lost.is_none());
    assert_eq!(steady.lines, want.height - hung.lines);
}

#[test]
fn worker_hung_when_the_image_completes_is_lost_in_the_report_and_the_last_tick() {
    let prepared = room(64, 48);
    let want = reference(&prepared);
    let cache = prepared.cache();
    // It hangs at its 3rd frame: its first result, or an answer to a repeated Hello or Job.
    // The other worker joins once the hung one holds lines (the first tick that shows it busy;
    // joined from the start, it could finish the image, on a loaded machine, before the hung
    // one was given any), and finishes the image (copies of the hung one's lines included)
    // long before the 1.5 s time-out. So the time-out comes while the master waits for the
    // links to close; until 2026-11-29 the master waited its 2 s out there and reported the
    // worker `ok`. (On a machine too slow for that, it comes during the render, with the same
    // outcome.) A simulated hang ends when the master hangs up; a hung machine would not
    // notice.
    let hung = Link {
        hang_up: Box::new(|| {}),
        ..sim(
            1,
            SimWorker {
                fault: Fault::HangAt(3),
                ..SimWorker::default()
            },
            &cache,
        )
    };
    let (join_tx, join_rx) = mpsc::channel::<Link>();
    let steady = Mutex::new(Some((join_tx, sim(2, SimWorker::default(), &cache))));
    let last = Mutex::new(Vec::new());
    let on_tick = |w: &[WorkerState]| {
        let busy = w
            .iter()
            .any(|w| w.report.address == "sim 1" && w.activity == Activity::Busy);
        if busy {
            if let Some((tx, link)) = steady.lock().expect("not poisoned").take() {
                tx.send(link).expect("the master takes joining workers");
            }
        }
        *last.lock().expect("not poisoned") = w.to_vec();
    };
    let hooks = Hooks {
        on_line: &|_, _| {},
        log: &|_| {},
        on_result: None,
        on_final: None,
        on_tick: Some(&on_tick),
        resume: &[],
        stop: None,
    };
    let opts = options(2, 1500);
    let image = run_master_with(&prepared.job(), vec![hung], Some(&join_rx), &opts, &hooks)
        .expect("the render completes without the hung worker");
    assert_same_image(&image, &want, "a worker hung at the end");
    let workers = &image.workers;
    let lost = report(workers, "sim 1")
        .lost
        .as_deref()
        .unwrap_or_else(|| panic!("the hung worker is not lost: {}", table(workers)));
    assert!(lost.contains("no answer"), "lost for silence: {lost:?}");
    assert!(report(workers, "sim 2").lost.is_none());
    // The live view's last word on it agrees.
    let last = last.lock().expect("not poisoned");
    let shown = last
        .iter()
        .find(|w| w.report.address == "sim 1")
        .expect("the last tick lists the hung worker");
    assert_eq!(shown.activity, Activity::Lost, "{}", table(workers));
}

// ---------------------------------------------------------------------------------------------
// 7. Copies of lines in flight, and duplicates
// ---------------------------------------------------------------------------------------------

/// A slow worker holds lines 0 and 1 when the queue runs dry; the fast one gets copies of both.
/// The order of events is fixed by holding requests back: the slow worker receives its two
/// requests only when the fast one is sent its copy of line 1, by which time the fast one has
/// delivered line 0; the copy of line 1 goes out only once the image is complete. So the slow
/// worker's line 0 arrives as a duplicate and its line 1 finishes the image.
#[test]
fn slow_worker_lines_are_copied_and_duplicates_counted() {
    let prepared = room(64, 48);
    let want = reference(&prepared);
    let cache = prepared.cache();
    let slow_may_start = Arc::new(Gate::default());
    let image_complete = Arc::new(Gate::default());
    let (slow, slow_spy) = spied_holding(
        sim(
            1,
            SimWorker {
                fault: Fault::Slow(20.0),
                ..SimWorker::default()
            },
            &cache,
        ),
        Some(Hold {
            line: None,
            opens: None,
            waits: Arc::clone(&slow_may_start),
        }),
    );
    // The fast worker is heard only once the slow one holds its window (lines 0 and 1).
    let (fast, fast_spy) = spied_holding(
        held(sim(2, SimWorker::default(), &cache), &slow_spy.requested),
        Some(Hold {
            line: Some(1),
            opens: Some(Arc::clone(&slow_may_start)),
            waits: Arc::clone(&image_complete),
        }),
    );
    let finished = Mutex::new(0u32);
    let on_line = |_: u32, _: RayCounts| {
        let mut n = finished.lock().expect("count lock");
        *n += 1;
        if *n == want.height {
            image_complete.open();
        }
    };
    let image = run_master(
        &prepared.job(),
        vec![slow, fast],
        None,
        // The holds watch single-line requests.
        &MasterOptions {
            lines_per_request: Some(1),
            ..options(2, 5_000)
        },
        &on_line,
        &|_| {},
    )
    .expect("the render completes");
    assert_same_image(&image, &want, "one slow, one fast worker");
    let workers = &image.workers;
    let slow = report(workers, "sim 1");
    let fast = report(workers, "sim 2");
    assert!(
        slow.lost.is_none() && fast.lost.is_none(),
        "{}",
        table(workers)
    );
    let slow_lines = slow_spy.lines();
    let fast_lines = fast_spy.lines();
    assert_eq!(slow_lines, [0, 1], "the slow worker got one window");
    assert_eq!(
        fast_lines,
        (2..want.height).chain([0, 1]).collect::<Vec<u32>>(),
        "the fast worker got the rest, then copies of the slow worker's lines, lowest first"
    );
    assert_eq!(
        (slow.lines, slow.duplicates),
        (1, 1),
        "line 0 from the slow worker is a duplicate, its line 1 is used: {}",
        table(workers)
    );
    assert_eq!(
        (fast.lines, fast.duplicates),
        (want.height - 1, 0),
        "{}",
        table(workers)
    );
    for (w, sent) in [(slow, &slow_lines), (fast, &fast_lines)] {
        assert!(
            w.lines + w.duplicates <= sent.len() as u32,
            "{}: more results counted than requests sent ({}): {}",
            w.address,
            sent.len(),
            table(workers)
        );
    }
    // The duplicate's rays are in the slow worker's report, not in the image.
    assert_eq!(
        slow.rays.total(),
        want.line_rays[0].total() + want.line_rays[1].total()
    );
    assert_eq!(
        workers.iter().map(|w| w.rays.total()).sum::<u64>(),
        want.rays.total() + want.line_rays[0].total()
    );
}

// ---------------------------------------------------------------------------------------------
// 8. Bit flips in both directions
// ---------------------------------------------------------------------------------------------

#[test]
fn bit_flips_both_ways_with_window_two() {
    let prepared = room(64, 48);
    let want = reference(&prepared);
    let cache = prepared.cache();
    let links = (1..=3u64)
        .map(|i| {
            sim(
                i as usize,
                SimWorker {
                    up: flips(2e-3, 100 + i),
                    down: flips(2e-3, 200 + i),
                    ..SimWorker::default()
                },
                &cache,
            )
        })
        .collect();
    let image = master(&prepared, links, None, &options(2, 5_000), &|_| {})
        .expect("the render completes over noisy links");
    assert_same_image(&image, &want, "bit flips both ways");
    let workers = &image.workers;
    let dropped: u32 = workers.iter().map(|w| w.frames_dropped).sum();
    let reissued: u32 = workers.iter().map(|w| w.reissued).sum();
    assert!(
        dropped > 0,
        "corrupt frames are dropped: {}",
        table(workers)
    );
    assert!(
        reissued > 0,
        "lines whose results were lost are re-issued: {}",
        table(workers)
    );
    for w in workers {
        assert!(w.lost.is_none(), "{}: lost: {}", w.address, table(workers));
    }
}

// ---------------------------------------------------------------------------------------------
// 9. A worker that joins while the master waits
// ---------------------------------------------------------------------------------------------

#[test]
fn worker_joins_a_master_with_none() {
    let prepared = room(64, 48);
    let want = reference(&prepared);
    let cache = prepared.cache();
    let (join_tx, join_rx) = mpsc::channel::<Link>();
    let started = Instant::now();
    let result = std::thread::scope(|s| {
        s.spawn(move || {
            std::thread::sleep(Duration::from_millis(100));
            let link = spawn_local_workers(1, &cache)
                .expect("a worker thread starts")
                .pop()
                .expect("one link");
            join_tx
                .send(link)
                .expect("the master takes joining workers");
        });
        master(
            &prepared,
            Vec::new(),
            Some(&join_rx),
            &options(2, 500),
            &|_| {},
        )
    });
    let image = result.expect("the joined worker renders the image");
    assert!(
        started.elapsed() >= Duration::from_millis(100),
        "the master waited for the worker"
    );
    assert_same_image(&image, &want, "a joined worker");
    assert_eq!(image.workers.len(), 1);
    assert_eq!(image.workers[0].address, "local-1");
    assert_eq!(image.workers[0].lines, want.height);
    assert!(image.workers[0].lost.is_none());
}

#[test]
fn worker_whose_link_only_carries_garbage_is_dropped() {
    // Every byte from worker 1 has a flipped bit: its frames all fail their CRC, so the master
    // hears only bad frames. It never gets a line; the clean worker finishes the image (too
    // fast for the garbage worker's time-out, so it need not be reported lost). The clean
    // worker's answers take 20 ms to arrive, so the render lasts until the garbage has been
    // heard (without it, the clean worker could finish before the first garbage frame).
    let prepared = room(32, 24);
    let want = reference(&prepared);
    let cache = prepared.cache();
    let garbage = SimWorker {
        up: flips(1.0, 7),
        ..SimWorker::default()
    };
    let slow = SimWorker {
        up: LinkModel {
            latency: Duration::from_millis(20),
            ..LinkModel::default()
        },
        ..SimWorker::default()
    };
    let links = vec![sim(1, garbage, &cache), sim(2, slow, &cache)];
    let image = master(&prepared, links, None, &options(2, 400), &|_| {}).expect("image");
    assert_same_image(&image, &want, "one garbage link");
    let bad = report(&image.workers, "sim 1");
    assert_eq!(bad.lines, 0, "{}", table(&image.workers));
    assert!(bad.frames_dropped > 0, "{}", table(&image.workers));

    // Alone, it cannot finish anything. Bad frames are no sign of life: it is probed, then
    // dropped for silence, and the render stops instead of waiting forever.
    let links = vec![sim(3, garbage, &cache)];
    let err = master(&prepared, links, None, &options(2, 400), &|_| {})
        .expect_err("no image from a garbage link");
    let ClusterError::AllWorkersLost {
        finished, workers, ..
    } = &err
    else {
        panic!("expected AllWorkersLost, got {err}");
    };
    assert_eq!(*finished, 0, "{err}");
    assert!(
        workers[0]
            .lost
            .as_deref()
            .is_some_and(|l| l.starts_with("no answer")),
        "{err}"
    );
}

#[test]
fn worker_alive_but_never_delivering_a_line_is_dropped() {
    // At one flipped bit per 100 bytes, a worker's short frames (Hello, Ready, FenceAck) mostly
    // arrive, but a 640-pixel line result (3.9 KB) never does. Fence answers keep coming, yet
    // they are no progress: the worker is dropped instead of being asked forever.
    let prepared = room(640, 4);
    let cache = prepared.cache();
    let noisy = SimWorker {
        up: flips(1e-2, 11),
        ..SimWorker::default()
    };
    let err = master(
        &prepared,
        vec![sim(1, noisy, &cache)],
        None,
        &options(2, 400),
        &|_| {},
    )
    .expect_err("no line can get through");
    let ClusterError::AllWorkersLost {
        finished, workers, ..
    } = &err
    else {
        panic!("expected AllWorkersLost, got {err}");
    };
    assert_eq!(*finished, 0, "{err}");
    assert!(workers[0].frames_dropped > 0, "{err}");
    assert!(
        workers[0]
            .lost
            .as_deref()
            .is_some_and(|l| l.starts_with("no answer")),
        "{err}"
    );
}

// ---------------------------------------------------------------------------------------------
// 8. Trust but verify: a worker that sends wrong pixels
// ---------------------------------------------------------------------------------------------

/// A worker that sends wrong pixels.
fn liar() -> SimWorker {
    SimWorker {
        fault: Fault::WrongPixels,
        ..SimWorker::default()
    }
}

/// A liar among honest workers, with `--verify FRACTION`: the image is the reference image,
/// the liar is dropped with a reason that names the verification, and the honest workers are
/// not.
fn liar_is_caught(fraction: f64) {
    let prepared = room(64, 48);
    let want = reference(&prepared);
    let cache = prepared.cache();
    // The honest workers' answers take 10 ms to arrive, so the liar is heard before they have
    // finished the image (without it, in about 1 run in 20 the liar rendered nothing).
    let honest = || SimWorker {
        up: LinkModel {
            latency: Duration::from_millis(10),
            ..LinkModel::default()
        },
        ..SimWorker::default()
    };
    let links = vec![
        sim(1, liar(), &cache),
        sim(2, honest(), &cache),
        sim(3, honest(), &cache),
    ];
    let opts = MasterOptions {
        verify: fraction,
        ..options(2, 5_000)
    };
    let image = master(&prepared, links, None, &opts, &|_| {}).expect("the honest finish it");
    // Not the rays of the duplicates: a result held for a second opinion and settled by the
    // master's own render is sometimes counted neither as a line nor as a copy (about 1 run in
    // 10 was one line's rays over).
    assert_same_pixels(&image, &want, &format!("--verify {fraction} with a liar"));
    let workers = &image.workers;
    let caught = report(workers, "sim 1");
    assert!(
        caught
            .lost
            .as_deref()
            .is_some_and(|r| r.contains("--verify")),
        "the liar is dropped for its pixels: {}",
        table(workers)
    );
    for honest in ["sim 2", "sim 3"] {
        assert!(report(workers, honest).lost.is_none(), "{}", table(workers));
    }
    let verified: u32 = workers.iter().map(|w| w.verified).sum();
    assert!(verified > 0, "results were checked: {}", table(workers));
}

#[test]
fn verify_all_catches_a_worker_with_wrong_pixels() {
    liar_is_caught(1.0);
}

#[test]
fn verify_a_sample_catches_a_liar_and_renders_its_unchecked_lines_again() {
    liar_is_caught(0.25);
}

#[test]
fn without_verify_a_liar_goes_unnoticed() {
    // The check above could pass without verification only if the liar rendered nothing.
    let prepared = room(64, 48);
    let want = reference(&prepared);
    let cache = prepared.cache();
    let image = master(
        &prepared,
        vec![sim(1, liar(), &cache)],
        None,
        &options(2, 5_000),
        &|_| {},
    )
    .expect("a render");
    assert_ne!(
        image.pixels, want.pixels,
        "the liar's pixels are used unchecked"
    );
}

#[test]
fn verify_with_a_single_liar_is_settled_by_the_master() {
    // No second worker to compare with: the master renders the held line itself, convicts
    // the liar, and the render fails for lack of workers instead of writing wrong pixels.
    let prepared = room(64, 48);
    let cache = prepared.cache();
    let opts = MasterOptions {
        verify: 1.0,
        ..options(2, 5_000)
    };
    let result = master(
        &prepared,
        vec![sim(1, liar(), &cache)],
        None,
        &opts,
        &|_| {},
    );
    let Err(ClusterError::AllWorkersLost { workers, .. }) = result else {
        panic!("the render must fail: {result:?}");
    };
    assert!(workers[0]
        .lost
        .as_deref()
        .is_some_and(|r| r.contains("--verify")));
}
