//! A microcontroller in the cluster: the firmware (`firmware/`, the unchanged core worker loop
//! on a Cortex-M4F's UART) runs under QEMU's `mps2-an386` board, and `strahl render --serial`
//! renders the demo room with it alone and beside an in-process worker, byte-identical to a
//! local render; a scene too large for the board is refused at the handshake and rendered by
//! the others; a board reset mid-render (QEMU killed) costs nothing.
//!
//! The test builds the firmware itself (`cargo build --manifest-path firmware/Cargo.toml`) and
//! starts every QEMU it uses, killed when the test ends, even when it fails. It is skipped, with
//! the reason printed, only where `qemu-system-arm` or the target is missing;
//! `STRAHL_REQUIRE_QEMU=1` (set by `.ci/run`, whose setup installs both) makes that a failure.

mod support;

use std::error::Error;
use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;
use support::{finish, room_config, table, Proc, TestResult};

const QEMU: &str = "/usr/bin/qemu-system-arm";

/// An emulated board; QEMU is killed when it is dropped.
struct Board {
    qemu: Child,
    /// The pseudo-terminal of its UART0.
    pty: String,
}

impl Board {
    fn start(elf: &Path) -> Result<Board, Box<dyn Error>> {
        let mut qemu = Command::new(QEMU)
            .args([
                "-machine",
                "mps2-an386",
                "-cpu",
                "cortex-m4",
                "-nographic",
                "-monitor",
                "none",
            ])
            .args([
                "-semihosting-config",
                "enable=on,target=native",
                "-serial",
                "pty",
                "-kernel",
            ])
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
            .ok_or_else(|| format!("QEMU named no pseudo-terminal: {line:?}"))?
            .to_string();
        Ok(Board { qemu, pty })
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

/// Why the firmware cannot run here, if it cannot.
fn missing() -> Option<String> {
    if !Path::new(QEMU).exists() {
        return Some(format!(
            "{QEMU} is not installed (Debian: apt-get install qemu-system-arm; .ci/setup does this)"
        ));
    }
    None
}

/// Builds the firmware (release, with semihosting for panic messages); its ELF.
fn firmware() -> Result<PathBuf, Box<dyn Error>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "build",
            "--release",
            "--target",
            "thumbv7em-none-eabihf",
            "--features",
            "semihosting",
        ])
        .arg("--manifest-path")
        .arg(dir.join("Cargo.toml"))
        .output()?;
    if !out.status.success() {
        return Err(format!(
            "the firmware does not build:\n{}",
            String::from_utf8_lossy(&out.stderr)
        )
        .into());
    }
    Ok(dir.join("target/thumbv7em-none-eabihf/release/strahl-firmware"))
}

/// `strahl render ROOM -o OUT -w W -h H EXTRA...`.
fn room(out: &Path, size: (u32, u32), extra: &[&str]) -> Result<support::Rendered, Box<dyn Error>> {
    let scene = room_config().display().to_string();
    let o = out.display().to_string();
    let (w, h) = (size.0.to_string(), size.1.to_string());
    let mut args = vec![
        "render",
        &scene,
        "-o",
        &o,
        "-w",
        &w,
        "-h",
        &h,
        "--worker-timeout",
        "60",
    ];
    args.extend_from_slice(extra);
    finish(Proc::spawn(&args)?)
}

#[test]
fn the_emulated_board_renders_alone_mixed_refuses_too_much_and_its_loss_costs_nothing() -> TestResult
{
    if let Some(why) = missing() {
        if std::env::var_os("STRAHL_REQUIRE_QEMU").is_some_and(|v| v == "1") {
            return Err(format!("STRAHL_REQUIRE_QEMU=1 but {why}").into());
        }
        eprintln!("SKIPPED: {why}");
        return Ok(());
    }
    let elf = firmware()?;
    let dir = tempfile::tempdir()?;
    // The image one in-process worker renders of the room at `size` with `extra` options.
    let reference = |size: (u32, u32), extra: &[&str]| -> Result<Vec<u8>, Box<dyn Error>> {
        let out = dir.path().join("reference.bmp");
        room(&out, size, &[&["--workers", "1", "-q"][..], extra].concat())?.assert_success();
        Ok(std::fs::read(out)?)
    };

    // Alone: the board renders every line of the room.
    let board = Board::start(&elf)?;
    let alone = dir.path().join("alone.bmp");
    let r = room(
        &alone,
        (64, 48),
        &["--workers", "0", "--serial", &board.pty],
    )?;
    r.assert_success();
    assert!(
        std::fs::read(&alone)? == reference((64, 48), &[])?,
        "the board's image differs:\n{}",
        r.stderr
    );
    let rows = table(&r.stderr);
    assert_eq!(
        (rows.len(), rows[0].name.as_str(), rows[0].lines),
        (1, "mps2-an386", 48),
        "{}",
        r.stderr
    );

    // Mixed with an in-process worker, the board keeping the scene it has.
    let mixed = dir.path().join("mixed.bmp");
    let r = room(
        &mixed,
        (64, 48),
        &["-m", "3", "--workers", "1", "--serial", &board.pty],
    )?;
    r.assert_success();
    assert!(
        std::fs::read(&mixed)? == reference((64, 48), &["-m", "3"])?,
        "mixed image differs:\n{}",
        r.stderr
    );
    let rows = table(&r.stderr);
    assert!(rows.iter().all(|w| w.status == "ok"), "{}", r.stderr);

    // A scene larger than the board's heap is refused when the master offers it, with the
    // reason; alone, the render fails saying so; beside another worker, the others render it.
    let large_dir = dir.path().join("large");
    std::fs::create_dir(&large_dir)?;
    let d = large_dir.display().to_string();
    finish(Proc::spawn(&[
        "generate",
        "large",
        "--triangles",
        "300000",
        "-o",
        &d,
    ])?)?
    .assert_success();
    let cfg = large_dir.join("raytracer.cfg").display().to_string();
    let big = dir.path().join("big.bmp").display().to_string();
    let small = ["-w", "32", "-h", "24", "--worker-timeout", "30"];
    let alone = [
        &[
            "render",
            &cfg,
            "-o",
            &big,
            "--workers",
            "0",
            "--serial",
            &board.pty,
        ][..],
        &small,
    ]
    .concat();
    let r = finish(Proc::spawn(&alone)?)?;
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr.contains("mps2-an386")
            && r.stderr
                .contains("it refused the job: the scene needs more than"),
        "{}",
        r.stderr
    );
    assert!(!Path::new(&big).exists());
    let _ = std::fs::remove_file(format!("{big}.checkpoint"));
    let mixed = [
        &[
            "render",
            &cfg,
            "-o",
            &big,
            "--workers",
            "1",
            "--serial",
            &board.pty,
            "-q",
        ][..],
        &small,
    ]
    .concat();
    finish(Proc::spawn(&mixed)?)?.assert_success();
    let local = dir.path().join("big-local.bmp").display().to_string();
    let only_local = [
        &["render", &cfg, "-o", &local, "--workers", "1", "-q"][..],
        &small,
    ]
    .concat();
    finish(Proc::spawn(&only_local)?)?.assert_success();
    assert!(
        std::fs::read(&big)? == std::fs::read(&local)?,
        "the others' image differs"
    );
    drop(board);

    // A board reset mid-render: the image is the same.
    let mut board = Board::start(&elf)?;
    let scene = room_config().display().to_string();
    let lost = dir.path().join("lost.bmp");
    let l = lost.display().to_string();
    let render = Proc::spawn(&[
        "render",
        &scene,
        "-o",
        &l,
        "-w",
        "160",
        "-h",
        "120",
        "-m",
        "4",
        "--workers",
        "1",
        "--serial",
        &board.pty,
        "--worker-timeout",
        "60",
    ])?;
    std::thread::sleep(Duration::from_millis(1500));
    board.kill();
    let r = finish(render)?;
    r.assert_success();
    assert!(
        std::fs::read(&lost)? == reference((160, 120), &["-m", "4"])?,
        "image after the reset differs:\n{}",
        r.stderr
    );
    Ok(())
}
