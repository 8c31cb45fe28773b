//! Completions and the manual page come from the clap definitions: bash takes the script and
//! completes `strahl`, and the page is roff that names the subcommands.

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_strahl");

#[test]
fn bash_completes_strahl_from_the_generated_script() -> Result<(), Box<dyn std::error::Error>> {
    let script = Command::new(BIN).args(["completions", "bash"]).output()?;
    assert!(script.status.success());
    let text = String::from_utf8(script.stdout)?;
    assert!(
        text.contains("--region") && text.contains("--view"),
        "every option is there"
    );
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("strahl.bash");
    std::fs::write(&path, &text)?;
    // Sourced, it registers a completion function for `strahl`.
    let check = Command::new("bash")
        .args([
            "-c",
            &format!("source {} && complete -p strahl", path.display()),
        ])
        .output()?;
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );
    assert!(String::from_utf8(check.stdout)?.contains("_strahl"));
    for shell in ["zsh", "fish"] {
        let out = Command::new(BIN).args(["completions", shell]).output()?;
        assert!(out.status.success() && !out.stdout.is_empty(), "{shell}");
    }
    let bad = Command::new(BIN).args(["completions", "tcsh"]).output()?;
    assert_eq!(bad.status.code(), Some(2));
    Ok(())
}

#[test]
fn the_manual_page_is_roff_naming_the_subcommands() -> Result<(), Box<dyn std::error::Error>> {
    let out = Command::new(BIN).arg("man").output()?;
    assert!(out.status.success());
    let page = String::from_utf8(out.stdout)?;
    assert!(page.contains(".TH strahl 1"), "{page}");
    for sub in ["render", "worker", "view", "convert", "bench"] {
        assert!(page.contains(sub), "{sub} is named");
    }
    Ok(())
}

#[test]
fn the_systemd_units_command_is_a_valid_worker_command() -> Result<(), Box<dyn std::error::Error>> {
    use clap::Parser as _;
    use strahl_host::cli::{Cli, Command as Sub};
    let unit = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/strahl-worker.service"),
    )?;
    let exec = unit
        .lines()
        .find_map(|l| l.strip_prefix("ExecStart="))
        .ok_or("no ExecStart")?;
    let dir = tempfile::tempdir()?;
    let words: Vec<String> = exec
        .replace(
            "${CREDENTIALS_DIRECTORY}",
            &dir.path().display().to_string(),
        )
        .split_whitespace()
        .map(String::from)
        .collect();
    assert_eq!(words[0], "/usr/local/bin/strahl");
    let cli = Cli::try_parse_from(&words)?;
    let Sub::Worker(w) = cli.command else {
        return Err("ExecStart does not run `strahl worker`".into());
    };
    assert_eq!(w.listen.as_deref(), Some("0.0.0.0:7415"));
    assert!(
        w.secret_file.is_some(),
        "a worker on every interface proves a secret"
    );
    // The credential systemd hands over is a file the worker reads like any secret file.
    let key = w.secret_file.ok_or("no secret file")?;
    std::fs::write(&key, "0123456789abcdef0123456789abcdef\n")?;
    assert!(strahl_host::util::secret::load_secret(Some(&key))?.is_some());
    for needed in [
        "LoadCredential=cluster.key:",
        "DynamicUser=yes",
        "Restart=on-failure",
        "WantedBy=multi-user.target",
    ] {
        assert!(unit.contains(needed), "{needed}");
    }
    Ok(())
}

#[test]
fn errors_are_coloured_as_clap_colours_its_own_and_never_with_no_color(
) -> Result<(), Box<dyn std::error::Error>> {
    // `script` (util-linux) runs the command on a pseudo-terminal, as a user's shell would.
    let on_terminal = |cmd: &str, no_color: bool| -> Result<String, Box<dyn std::error::Error>> {
        let mut c = Command::new("script");
        c.args(["-qc", cmd, "/dev/null"]).env_remove("NO_COLOR");
        if no_color {
            c.env("NO_COLOR", "1");
        }
        Ok(String::from_utf8_lossy(&c.output()?.stdout).into_owned())
    };
    let ours = on_terminal(&format!("{BIN} render scene.jpg"), false)?;
    let clap = on_terminal(&format!("{BIN} render --no-such-option"), false)?;
    let red = "\u{1b}[1m\u{1b}[31merror:\u{1b}[0m ";
    assert!(ours.starts_with(red), "{ours:?}");
    assert!(
        clap.starts_with(red),
        "clap writes its errors the same way: {clap:?}"
    );
    let plain = on_terminal(&format!("{BIN} render scene.jpg"), true)?;
    assert!(plain.starts_with("error: scene.jpg:"), "{plain:?}");
    let piped = Command::new(BIN).args(["render", "scene.jpg"]).output()?;
    assert!(String::from_utf8(piped.stderr)?.starts_with("error: scene.jpg:"));
    Ok(())
}
