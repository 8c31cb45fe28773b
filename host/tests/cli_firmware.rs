//! A microcontroller in the cluster: the firmware (`firmware/`, the unchanged core worker loop
//! on a Cortex-M4F's UART) runs under QEMU's `mps2-an386` board, and `strahl render --serial`
//! renders with it alone and beside in-process and TCP workers, byte-identical to a local
//! render. A scene too large for the board is refused at the handshake and rendered by the
//! others; a board reset mid-render (QEMU killed) costs nothing; a board built with a shared
//! secret serves only masters that hold it; boards booted alike give different nonces.
//!
//! The tests build the firmware themselves (`cargo build --manifest-path firmware/Cargo.toml`,
//! with and without a secret) and start every QEMU they use, killed when a test ends, even when
//! it fails. They are skipped, with the reason printed, only where `qemu-system-arm` is
//! missing; `STRAHL_REQUIRE_QEMU=1` (set by `.ci/run`, whose setup installs it) makes that a
//! failure.

use crate::support::{finish, room_config, table, Proc, Rendered, TestResult};
use embedded_io_adapters::std::FromStd;
use std::error::Error;
use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};
use strahl_core::wire::auth::Nonce;
use strahl_core::wire::frame::{FrameReader, FrameWriter, LinkError, ReadEvent};
use strahl_core::wire::message::{Hello, MasterMessage, WorkerMessage};
use strahl_core::wire::{MAX_FRAME_LEN, PROTOCOL_VERSION};

const QEMU: &str = "/usr/bin/qemu-system-arm";

/// The board's name in its `Hello`.
const BOARD: &str = "mps2-an386";

/// A small scene (a few solids): its transfer to the board takes milliseconds, not the room's
/// seconds.
const MIRRORS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/fart/mirrors.fart");

/// An emulated board; QEMU is killed when it is dropped.
struct Board {
    qemu: Child,
    /// The pseudo-terminal of its UART0.
    pty: String,
}

impl Board {
    fn start(elf: &Path) -> Result<Board, Box<dyn Error>> {
        let mut qemu = Command::new(QEMU)
            .args(["-machine", BOARD, "-cpu", "cortex-m4", "-nographic"])
            .args([
                "-monitor",
                "none",
                "-semihosting-config",
                "enable=on,target=native",
            ])
            .args(["-serial", "pty", "-kernel"])
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()?;
        let out = qemu.stdout.take().ok_or("no stdout")?;
        let mut line = String::new();
        BufReader::new(out).read_line(&mut line)?;
        let pty = line
            .split_whitespace()
            .find(|w| w.starts_with("/dev/pts/"))
            .map(str::to_string);
        let board = Board {
            qemu,
            pty: pty.unwrap_or_default(),
        };
        if board.pty.is_empty() {
            return Err(format!("QEMU named no pseudo-terminal: {line:?}").into());
        }
        Ok(board)
    }

    fn kill(&mut self) {
        let _ = self.qemu.kill();
        let _ = self.qemu.wait();
    }
}

impl Drop for Board {
    fn drop(&mut self) {
        self.kill();
    }
}

/// Whether QEMU can run here: `Ok(false)` (the reason printed) skips a test, unless
/// `STRAHL_REQUIRE_QEMU=1` makes it a failure.
fn qemu_here() -> Result<bool, Box<dyn Error>> {
    if Path::new(QEMU).exists() {
        return Ok(true);
    }
    let why = format!(
        "{QEMU} is not installed (Debian: apt-get install qemu-system-arm; .ci/setup does)"
    );
    if std::env::var_os("STRAHL_REQUIRE_QEMU").is_some_and(|v| v == "1") {
        return Err(format!("STRAHL_REQUIRE_QEMU=1 but {why}").into());
    }
    eprintln!("SKIPPED: {why}");
    Ok(false)
}

/// The firmware built plain, and built with a shared secret and a heap too small for the room
/// (it announces more than the heap can give, so the room's octree runs it out; one build for
/// both, as a rebuild takes about 19 s on 2 cores), and the secret's file.
struct Firmware {
    plain: PathBuf,
    guarded: PathBuf,
    secret_file: PathBuf,
    _dir: tempfile::TempDir,
}

/// Builds both firmwares once per test run (release, with semihosting for panic messages).
fn firmware() -> Result<&'static Firmware, Box<dyn Error>> {
    static BUILT: OnceLock<Result<Firmware, String>> = OnceLock::new();
    let built = BUILT.get_or_init(|| {
        let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
        let secret_file = dir.path().join("secret");
        std::fs::write(&secret_file, "a board's secret, 32 bytes long.\n")
            .map_err(|e| e.to_string())?;
        // The plain build comes last, so the checkout is left with that one. The room needs
        // 2.56 to 2.63 MiB of heap (README); at 2048 KiB its octree's build runs the board out.
        let guarded = build(
            Some(&secret_file),
            Some(2048),
            &dir.path().join("guarded.elf"),
        )?;
        let plain = build(None, None, &dir.path().join("plain.elf"))?;
        Ok(Firmware {
            plain,
            guarded,
            secret_file,
            _dir: dir,
        })
    });
    built.as_ref().map_err(|e| e.clone().into())
}

/// Builds the firmware with `secret` (`STRAHL_FIRMWARE_SECRET_FILE`) and a heap of `heap_kib`
/// KiB (`STRAHL_FIRMWARE_HEAP_KIB`, the default without) and copies it to `to`.
fn build(secret: Option<&Path>, heap_kib: Option<u32>, to: &Path) -> Result<PathBuf, String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut command = Command::new(cargo);
    command
        .args(["build", "--release", "--target", "thumbv7em-none-eabihf"])
        .args(["--features", "semihosting", "--manifest-path"])
        .arg(dir.join("Cargo.toml"))
        // The ELF is looked for in the firmware's own target folder, wherever the tests build.
        .env_remove("CARGO_TARGET_DIR")
        .env_remove("STRAHL_FIRMWARE_SECRET_FILE")
        .env_remove("STRAHL_FIRMWARE_HEAP_KIB");
    if let Some(file) = secret {
        command.env("STRAHL_FIRMWARE_SECRET_FILE", file);
    }
    if let Some(kib) = heap_kib {
        command.env("STRAHL_FIRMWARE_HEAP_KIB", kib.to_string());
    }
    let out = command.output().map_err(|e| e.to_string())?;
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        return Err(format!("the firmware does not build:\n{stderr}"));
    }
    let elf = dir.join("target/thumbv7em-none-eabihf/release/strahl-firmware");
    std::fs::copy(elf, to).map_err(|e| e.to_string())?;
    Ok(to.to_path_buf())
}

/// `strahl render SCENE -o OUT --worker-timeout 60 EXTRA...` to its end.
fn render(scene: &str, out: &Path, extra: &[&str]) -> Result<Rendered, Box<dyn Error>> {
    let o = out.display().to_string();
    let args = [
        &["render", scene, "-o", &o, "--worker-timeout", "60"][..],
        extra,
    ]
    .concat();
    finish(Proc::spawn(&args)?)
}

/// The image one in-process worker renders of `scene` with `extra` options.
fn reference(scene: &str, dir: &Path, extra: &[&str]) -> Result<Vec<u8>, Box<dyn Error>> {
    let out = dir.join("reference.bmp");
    render(
        scene,
        &out,
        &[&["--workers", "1", "-q"][..], extra].concat(),
    )?
    .assert_success();
    Ok(std::fs::read(out)?)
}

/// The room (its scene, the room's 90 kB, sent to the board).
fn room() -> String {
    room_config().display().to_string()
}

#[test]
fn the_board_renders_alone_and_refuses_a_scene_too_large() -> TestResult {
    if !qemu_here()? {
        return Ok(());
    }
    let board = Board::start(&firmware()?.plain)?;
    let dir = tempfile::tempdir()?;
    let size = ["-w", "64", "-h", "48"];

    // Alone: the board renders every line of the room.
    let alone = dir.path().join("alone.bmp");
    let r = render(
        &room(),
        &alone,
        &[&size[..], &["--workers", "0", "--serial", &board.pty]].concat(),
    )?;
    r.assert_success();
    assert!(
        std::fs::read(&alone)? == reference(&room(), dir.path(), &size)?,
        "the board's image differs:\n{}",
        r.stderr
    );
    let rows = table(&r.stderr);
    assert_eq!(
        (rows.len(), rows[0].name.as_str(), rows[0].lines),
        (1, BOARD, 48),
        "{}",
        r.stderr
    );

    // A scene larger than the board's heap is refused when the master offers it, with the
    // reason; alone, the render fails saying so; beside another worker, the others render it.
    let large_dir = dir.path().join("large");
    std::fs::create_dir(&large_dir)?;
    let d = large_dir.display().to_string();
    let generate = ["generate", "large", "--triangles", "300000", "-o", &d];
    finish(Proc::spawn(&generate)?)?.assert_success();
    let cfg = large_dir.join("raytracer.cfg").display().to_string();
    let big = dir.path().join("big.bmp");
    let small = ["-w", "32", "-h", "24"];
    let r = render(
        &cfg,
        &big,
        &[&small[..], &["--workers", "0", "--serial", &board.pty]].concat(),
    )?;
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr.contains(BOARD)
            && r.stderr
                .contains("it refused the job: the scene needs more than"),
        "{}",
        r.stderr
    );
    assert!(!big.exists());
    let _ = std::fs::remove_file(dir.path().join("big.bmp.checkpoint"));
    let mixed = ["--workers", "1", "--serial", &board.pty, "-q"];
    render(&cfg, &big, &[&small[..], &mixed].concat())?.assert_success();
    assert!(
        std::fs::read(&big)? == reference(&cfg, dir.path(), &small)?,
        "the others' image differs"
    );
    Ok(())
}

#[test]
fn the_board_earns_lines_beside_local_and_tcp_workers() -> TestResult {
    if !qemu_here()? {
        return Ok(());
    }
    let board = Board::start(&firmware()?.plain)?;
    let (_tcp, address) = Proc::listening_worker_with("tcp-peer", &["--threads", "1"])?;
    let dir = tempfile::tempdir()?;
    // Narrow lines, many of them: the board (about 2 % of a PC core) needs the render to
    // outlast its first second (QEMU looks at an unopened pseudo-terminal once a second).
    let settings = ["-w", "160", "-h", "960", "-m", "4"];
    let expected = reference(MIRRORS, dir.path(), &settings)?;
    let workers = [
        "--workers",
        "1",
        "--worker",
        &address,
        "--serial",
        &board.pty,
    ];
    // Every render must be right; one of a few must show all three workers rendering.
    let mut last = String::new();
    for attempt in 1..=3 {
        let out = dir.path().join(format!("mixed{attempt}.bmp"));
        let r = render(MIRRORS, &out, &[&settings[..], &workers].concat())?;
        r.assert_success();
        assert!(
            std::fs::read(&out)? == expected,
            "mixed image differs:\n{}",
            r.stderr
        );
        let rows = table(&r.stderr);
        let lines = |name: &str| rows.iter().find(|w| w.name == name).map_or(0, |w| w.lines);
        if [BOARD, "tcp-peer", "local-1"].iter().all(|n| lines(n) > 0) {
            return Ok(());
        }
        last = r.stderr;
    }
    Err(format!("in no render did all three workers render lines; the last:\n{last}").into())
}

#[test]
fn a_board_that_panics_is_dropped_at_once_with_its_message() -> TestResult {
    if !qemu_here()? {
        return Ok(());
    }
    let fw = firmware()?;
    let board = Board::start(&fw.guarded)?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("never.bmp");
    let secret = fw.secret_file.display().to_string();
    let started = Instant::now();
    // Alone, so the board must take the room and run out of heap building it; `render` waits
    // 60 s for a silent worker.
    let r = render(
        &room(),
        &out,
        &[
            "-w",
            "64",
            "-h",
            "48",
            "--workers",
            "0",
            "--serial",
            &board.pty,
            "--secret-file",
            &secret,
        ],
    )?;
    let took = started.elapsed();
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr.contains("it halted: panicked at") && r.stderr.contains("memory allocation of"),
        "the master shows the board's panic:\n{}",
        r.stderr
    );
    assert!(
        took < Duration::from_secs(30),
        "dropped when it panicked, not after the 60 s worker time-out: {took:?}"
    );
    assert!(!out.exists(), "no image");
    Ok(())
}

#[test]
fn a_board_reset_mid_render_costs_nothing() -> TestResult {
    if !qemu_here()? {
        return Ok(());
    }
    let mut board = Board::start(&firmware()?.plain)?;
    let dir = tempfile::tempdir()?;
    let settings = ["-w", "160", "-h", "120", "-m", "4"];
    let lost = dir.path().join("lost.bmp");
    let l = lost.display().to_string();
    let scene = room();
    let args = [
        &["render", &scene, "-o", &l, "--worker-timeout", "60"][..],
        &settings,
        &["--workers", "1", "--serial", &board.pty],
    ]
    .concat();
    let render = Proc::spawn(&args)?;
    std::thread::sleep(Duration::from_millis(1500));
    board.kill();
    let r = finish(render)?;
    r.assert_success();
    assert!(
        std::fs::read(&lost)? == reference(&room(), dir.path(), &settings)?,
        "image after the reset differs:\n{}",
        r.stderr
    );
    Ok(())
}

#[test]
fn a_board_built_with_a_secret_serves_only_masters_that_hold_it() -> TestResult {
    if !qemu_here()? {
        return Ok(());
    }
    let fw = firmware()?;
    let board = Board::start(&fw.guarded)?;
    let dir = tempfile::tempdir()?;
    let settings = ["-w", "32", "-h", "24"];
    let out = dir.path().join("out.bmp");
    let alone = ["--workers", "0", "--serial", &board.pty];

    let r = render(MIRRORS, &out, &[&settings[..], &alone].concat())?;
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr
            .contains("it requires a shared secret: give this master the same --secret-file"),
        "{}",
        r.stderr
    );
    let wrong = dir.path().join("wrong");
    std::fs::write(&wrong, "another secret, also long enough")?;
    let w = wrong.display().to_string();
    let r = render(
        MIRRORS,
        &out,
        &[&settings[..], &alone, &["--secret-file", &w]].concat(),
    )?;
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr
            .contains("its proof of the shared secret is wrong (another secret)"),
        "{}",
        r.stderr
    );
    assert!(!out.exists());
    let _ = std::fs::remove_file(dir.path().join("out.bmp.checkpoint"));

    let s = fw.secret_file.display().to_string();
    let r = render(
        MIRRORS,
        &out,
        &[&settings[..], &alone, &["--secret-file", &s]].concat(),
    )?;
    r.assert_success();
    assert!(
        std::fs::read(&out)? == reference(MIRRORS, dir.path(), &settings)?,
        "the image differs:\n{}",
        r.stderr
    );
    Ok(())
}

/// Sends a master's `Hello` with nonce `master` to the board on `pty`; the nonce it answers.
fn worker_nonce(pty: &str, master: Nonce) -> Result<Nonce, Box<dyn Error>> {
    let mut link = FromStd::new(strahl_serial::open(pty, 115_200)?);
    let hello = MasterMessage::Hello(Hello {
        version: PROTOCOL_VERSION,
        name: "test",
        arch: "test",
        scene_memory: 0,
        threads: 0,
        nonce: master,
        proof: None,
    });
    let mut frames = FrameWriter::new();
    let bytes = [
        &[0u8][..],
        frames.encode(&hello).map_err(|e| format!("{e:?}"))?,
    ]
    .concat();
    std::io::Write::write_all(link.inner_mut(), &bytes)?;
    let mut buf = vec![0u8; MAX_FRAME_LEN];
    let mut reader = FrameReader::new(&mut buf[..]);
    let deadline = Instant::now() + Duration::from_secs(20);
    while Instant::now() < deadline {
        match reader.next(&mut link) {
            Ok(ReadEvent::Frame(payload)) => {
                if let Ok(WorkerMessage::Hello(h)) = WorkerMessage::decode(payload) {
                    return Ok(h.nonce);
                }
            }
            Ok(ReadEvent::Dropped(_)) | Err(LinkError::TimedOut) => {}
            Err(e) => return Err(format!("{pty}: {e:?}").into()),
        }
    }
    Err(format!("{pty}: no Hello from the board within 20 s").into())
}

#[test]
fn boards_booted_alike_give_different_nonces() -> TestResult {
    if !qemu_here()? {
        return Ok(());
    }
    // Two boards from the same image, greeted alike, then by a second master: a nonce that
    // repeats across resets would let a recorded session be replayed to the board. (The same
    // Hello twice in a session is answered alike, by design: it is a master probing.)
    let elf = &firmware()?.plain;
    let mut nonces = Vec::new();
    for _ in 0..2 {
        let board = Board::start(elf)?;
        nonces.push(worker_nonce(&board.pty, [7; 32])?);
        nonces.push(worker_nonce(&board.pty, [8; 32])?);
    }
    for (i, a) in nonces.iter().enumerate() {
        for b in &nonces[i + 1..] {
            assert_ne!(a, b, "two handshakes got the same nonce: {nonces:02x?}");
        }
    }
    Ok(())
}
