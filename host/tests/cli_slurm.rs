//! `--slurm` against a real single-node Slurm: the test writes a `slurm.conf` for this machine,
//! starts `munged` (unless one runs), `slurmctld` and `slurmd`, submits the shipped
//! `docs/slurm.sbatch` with `sbatch --wait`, and compares the image with a local render; then
//! it loses the node's worker mid-render (SIGKILL) with a local worker beside it, and the image
//! still completes, identical. Every daemon it started is stopped when it ends, even when it
//! fails.
//!
//! Skipped, with the reason printed, where Debian's `slurmctld`, `slurmd` and `munge` are not
//! installed or the test is not root (the daemons need it); `STRAHL_REQUIRE_SLURM=1` (set by
//! `.ci/run`, whose setup installs them) turns the skip into a failure.

use crate::support;

use std::error::Error;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use support::{room_config, TestResult, BIN};

/// Daemons this test started; killed when dropped.
struct Daemons(Vec<Child>);

impl Drop for Daemons {
    fn drop(&mut self) {
        for child in &mut self.0 {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// Why Slurm cannot run here, if it cannot.
fn missing() -> Option<String> {
    for tool in [
        "/usr/sbin/slurmctld",
        "/usr/sbin/slurmd",
        "/usr/sbin/munged",
        "/usr/bin/sbatch",
    ] {
        if !Path::new(tool).exists() {
            return Some(format!(
                "{tool} is not installed (Debian: apt-get install slurmctld slurmd munge; .ci/setup does this)"
            ));
        }
    }
    let uid = Command::new("id")
        .arg("-u")
        .output()
        .map(|o| o.stdout)
        .unwrap_or_default();
    if String::from_utf8_lossy(&uid).trim() != "0" {
        return Some("the Slurm daemons need root, and this test is not root".into());
    }
    None
}

fn free_port() -> Result<u16, Box<dyn Error>> {
    Ok(std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port())
}

fn host_name() -> Result<String, Box<dyn Error>> {
    let out = Command::new("hostname").output()?;
    Ok(String::from_utf8(out.stdout)?.trim().to_string())
}

/// Writes `slurm.conf` for one node (this machine) under `dir`; its path.
fn write_config(dir: &Path) -> Result<PathBuf, Box<dyn Error>> {
    let host = host_name()?;
    let cpus = std::thread::available_parallelism()?.get();
    let d = dir.display();
    for sub in ["state", "spool"] {
        std::fs::create_dir_all(dir.join(sub))?;
    }
    let conf = format!(
        "ClusterName=strahltest\nSlurmctldHost={host}\nSlurmUser=root\nSlurmdUser=root\n\
         AuthType=auth/munge\nSlurmctldPort={}\nSlurmdPort={}\nStateSaveLocation={d}/state\n\
         SlurmdSpoolDir={d}/spool\nSlurmctldPidFile={d}/slurmctld.pid\nSlurmdPidFile={d}/slurmd.pid\n\
         SlurmctldLogFile={d}/slurmctld.log\nSlurmdLogFile={d}/slurmd.log\n\
         ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nSelectType=select/cons_tres\n\
         SelectTypeParameters=CR_CPU\nMpiDefault=none\nReturnToService=2\n\
         NodeName={host} CPUs={cpus} State=UNKNOWN\n\
         PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
        free_port()?,
        free_port()?
    );
    let path = dir.join("slurm.conf");
    std::fs::write(&path, conf)?;
    Ok(path)
}

/// Starts munged (when none answers), slurmctld and slurmd, and waits until the node is idle.
fn start_slurm(conf: &Path) -> Result<Daemons, Box<dyn Error>> {
    let mut daemons = Daemons(Vec::new());
    let munge_answers = Command::new("munge")
        .arg("-n")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !munge_answers {
        std::fs::create_dir_all("/run/munge")?;
        let _ = Command::new("chown")
            .args(["munge:munge", "/run/munge"])
            .status();
        daemons.0.push(
            Command::new("/usr/sbin/munged")
                .args(["-F", "--force"])
                .stderr(Stdio::null())
                .spawn()?,
        );
    }
    for daemon in ["/usr/sbin/slurmctld", "/usr/sbin/slurmd"] {
        let child = Command::new(daemon)
            .args(["-D", "-f"])
            .arg(conf)
            .env("SLURM_CONF", conf)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()?;
        daemons.0.push(child);
    }
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let out = Command::new("sinfo")
            .args(["-h", "-o", "%t"])
            .env("SLURM_CONF", conf)
            .output()?;
        if String::from_utf8_lossy(&out.stdout).trim() == "idle" {
            return Ok(daemons);
        }
        if Instant::now() > deadline {
            let log =
                std::fs::read_to_string(conf.with_file_name("slurmctld.log")).unwrap_or_default();
            return Err(format!("the Slurm node did not become idle within 60 s:\n{log}").into());
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// `sbatch --wait docs/slurm.sbatch ARGS`, with the image at `output`; the job's log.
fn submit(conf: &Path, dir: &Path, output: &Path, args: &[&str]) -> Result<String, Box<dyn Error>> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/slurm.sbatch");
    let log = dir.join("job.log");
    let status = Command::new("sbatch")
        .args(["--wait", "--nodes=1", "--exclusive", "--output"])
        .arg(&log)
        .arg(&script)
        .args(args)
        .env("SLURM_CONF", conf)
        .env("STRAHL", BIN)
        .env("SCENE", room_config())
        .env("OUTPUT", output)
        .current_dir(dir)
        .stdout(Stdio::null())
        .status()?;
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    if !status.success() {
        return Err(format!("sbatch failed ({status}); the job's log:\n{text}").into());
    }
    Ok(text)
}

/// The image a local render of the room gives with `args`.
fn local(dir: &Path, args: &[&str]) -> Result<Vec<u8>, Box<dyn Error>> {
    let out = dir.join("local.bmp");
    let scene = room_config().display().to_string();
    let o = out.display().to_string();
    let mut all = vec!["render", &scene, "-o", &o, "-q", "--workers", "1"];
    all.extend_from_slice(args);
    let r = support::finish(support::Proc::spawn(&all)?)?;
    r.assert_success();
    Ok(std::fs::read(out)?)
}

/// Kills (SIGKILL) the first `strahl worker --connect` process once it has rendered a while.
fn kill_worker_when_busy(deadline: Instant) -> Result<bool, String> {
    while Instant::now() < deadline {
        for entry in std::fs::read_dir("/proc")
            .map_err(|e| e.to_string())?
            .flatten()
        {
            let path = entry.path();
            let Ok(cmd) = std::fs::read(path.join("cmdline")) else {
                continue;
            };
            let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
            let Some(pid) = path
                .file_name()
                .and_then(|n| n.to_str())
                .and_then(|n| n.parse::<u32>().ok())
            else {
                continue;
            };
            if cmd.starts_with(BIN)
                && cmd.contains(" worker --connect ")
                && support::cpu_ticks(pid).is_some_and(|t| t >= support::RENDERING_TICKS)
            {
                let pid = nix::unistd::Pid::from_raw(pid as i32);
                nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGKILL)
                    .map_err(|e| e.to_string())?;
                return Ok(true);
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(false)
}

#[test]
fn renders_through_slurm_and_survives_losing_the_node() -> TestResult {
    if let Some(why) = missing() {
        if std::env::var_os("STRAHL_REQUIRE_SLURM").is_some_and(|v| v == "1") {
            return Err(format!("STRAHL_REQUIRE_SLURM=1 but {why}").into());
        }
        eprintln!("SKIPPED: {why}");
        return Ok(());
    }
    let dir = tempfile::tempdir()?;
    let conf = write_config(dir.path())?;
    let _daemons = start_slurm(&conf)?;

    let out = dir.path().join("slurm.bmp");
    let log = submit(
        &conf,
        dir.path(),
        &out,
        &["-w", "320", "-h", "240", "--reflections", "on"],
    )?;
    assert!(log.contains("listening for workers on"), "{log}");
    let reference = local(
        dir.path(),
        &["-w", "320", "-h", "240", "--reflections", "on"],
    )?;
    assert!(
        std::fs::read(&out)? == reference,
        "the Slurm render differs from the local one:\n{log}"
    );
    // One worker, from srun, rendered every line.
    let rows = support::table(&log);
    assert_eq!(rows.len(), 1, "{log}");
    assert_eq!(rows[0].lines, 240, "{log}");

    // The node's worker lost mid-render: the local worker finishes, and the image is the same.
    let big = [
        "-w",
        "1280",
        "-h",
        "960",
        "-m",
        "2",
        "--reflections",
        "on",
        "--workers",
        "1",
    ];
    let killer =
        std::thread::spawn(|| kill_worker_when_busy(Instant::now() + Duration::from_secs(60)));
    let lost = dir.path().join("lost.bmp");
    let log = submit(&conf, dir.path(), &lost, &big)?;
    assert!(
        killer.join().map_err(|_| "the killer panicked")??,
        "no worker to kill:\n{log}"
    );
    let reference = local(dir.path(), &big[..8])?;
    assert!(
        std::fs::read(&lost)? == reference,
        "image after losing the node differs:\n{log}"
    );
    let rows = support::table(&log);
    assert!(
        rows.iter().any(|r| r.status != "ok"),
        "the lost worker shows:\n{log}"
    );
    Ok(())
}
