//! One child process of the benchmark (a Strahl render or a POV-Ray run): run it, time it from
//! spawn to exit, and turn a failure into an error naming the scene, the command and the end of
//! what the child wrote on stderr.

use anyhow::bail;
use std::process::Command;
use std::time::{Duration, Instant};

/// Lines of a failed child's stderr quoted in the error.
const STDERR_TAIL_LINES: usize = 12;

/// What a child that exited successfully left.
#[derive(Clone, Debug)]
pub struct ChildRun {
    /// Wall time from spawn to exit (the whole process: start-up, parsing, tracing, writing).
    pub wall: Duration,
    /// Its standard output.
    pub stdout: String,
    /// Its standard error.
    pub stderr: String,
}

/// The command as a shell line, for messages: the program and each argument, quoted where a
/// shell would need it.
pub fn command_line(cmd: &Command) -> String {
    std::iter::once(cmd.get_program())
        .chain(cmd.get_args())
        .map(|a| shell_word(&a.to_string_lossy()))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `word` as one shell word: as it is when it holds only safe characters, else in single quotes.
pub fn shell_word(word: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "+-_./,=:@%".contains(c);
    if !word.is_empty() && word.chars().all(safe) {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

/// The last [`STDERR_TAIL_LINES`] non-empty lines of `text`.
pub fn tail(text: &str) -> String {
    let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
    let from = lines.len().saturating_sub(STDERR_TAIL_LINES);
    lines[from..].join("\n")
}

/// Runs `cmd` to its end, timed, with its output captured.
///
/// # Errors
/// If it cannot be started or exits unsuccessfully: the message names `scene`, the command line
/// and the tail of its stderr.
pub fn run_child(scene: &str, mut cmd: Command) -> anyhow::Result<ChildRun> {
    let line = command_line(&cmd);
    let start = Instant::now();
    let out = match cmd.output() {
        Ok(out) => out,
        Err(e) => bail!("scene {scene}: cannot start `{line}`: {e}"),
    };
    let wall = start.elapsed();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    if !out.status.success() {
        let what = out.status.code().map_or_else(
            || "was killed by a signal".to_string(),
            |c| format!("exited with {c}"),
        );
        let t = tail(&stderr);
        let said = if t.is_empty() {
            "nothing on stderr".to_string()
        } else {
            format!("its stderr ends:\n{t}")
        };
        bail!("scene {scene}: `{line}` {what}; {said}");
    }
    Ok(ChildRun {
        wall,
        stdout,
        stderr,
    })
}

/// This process's command line, each word quoted where a shell would need it.
pub fn own_command_line() -> String {
    std::env::args_os()
        .map(|a| shell_word(&a.to_string_lossy()))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_are_quoted_only_where_needed() {
        assert_eq!(shell_word("+W512"), "+W512");
        assert_eq!(shell_word("/a b/c.nff"), "'/a b/c.nff'");
        assert_eq!(shell_word("it's"), r"'it'\''s'");
        assert_eq!(shell_word(""), "''");
    }

    #[test]
    fn tail_keeps_the_last_lines() {
        let text: String = (1..=20).map(|i| format!("line {i}\n\n")).collect();
        let t = tail(&text);
        assert!(t.starts_with("line 9\n") && t.ends_with("line 20"), "{t}");
    }

    #[test]
    fn a_failing_child_names_scene_command_and_stderr() {
        let mut cmd = Command::new("sh");
        cmd.args(["-c", "echo first >&2; echo oops >&2; exit 3"]);
        let err = run_child("tiny", cmd).expect_err("exit 3").to_string();
        assert!(err.contains("scene tiny"), "{err}");
        assert!(err.contains("exited with 3"), "{err}");
        assert!(err.contains("sh -c"), "{err}");
        assert!(err.ends_with("first\noops"), "{err}");
        let ok = run_child("tiny", Command::new("true")).expect("true runs");
        assert!(ok.stdout.is_empty());
    }

    #[test]
    fn a_missing_program_is_an_error() {
        let err = run_child("tiny", Command::new("/nonexistent/program"))
            .expect_err("no such program")
            .to_string();
        assert!(err.contains("cannot start"), "{err}");
    }
}
