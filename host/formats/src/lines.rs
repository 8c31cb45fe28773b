//! The lexing both file formats share (seed section 2.6: "the same parser as the configuration
//! file"): lines of words, `REM` comments, `QUIT`, and numbers with messages that name the line.
//!
//! The rules, as `scenes/FORMATS.md` states them: the text is UTF-8 with an optional byte order
//! mark; lines end in LF, CRLF or a lone CR (old Mac files, read as line ends); words are separated by any mix of spaces and tabs; blank lines
//! are skipped; a line whose first word is `REM` is a comment; a line whose first word is `QUIT`
//! ends the file (nothing after it is read, not even the rest of that line). Names are
//! case-sensitive.

use crate::error::LoadError;
use std::path::Path;

/// Reads `path` as UTF-8 text, with lone CR line ends (old Mac files) turned into LF so lines
/// count as they look.
///
/// # Errors
/// [`LoadError::Io`] if the file cannot be read, [`LoadError::At`] naming the line of the first
/// byte that is not valid UTF-8.
pub fn read_text(path: &Path) -> Result<String, LoadError> {
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let text = match String::from_utf8(bytes) {
        Ok(text) => text,
        Err(e) => {
            let good = e.utf8_error().valid_up_to();
            let bytes = e.as_bytes();
            match std::str::from_utf8(&bytes[..good]) {
                // Nothing after `QUIT` is read, so it need not be text either.
                Ok(before) if quits(before) => before.to_string(),
                _ => {
                    let line = 1 + bytes[..good].iter().filter(|&&b| b == b'\n').count();
                    return Err(LoadError::At {
                        path: path.to_path_buf(),
                        line,
                        message: format!("the file is not UTF-8 text (bad byte at offset {good})"),
                    });
                }
            }
        }
    };
    Ok(if text.contains('\r') {
        text.replace("\r\n", "\n").replace('\r', "\n")
    } else {
        text
    })
}

/// Whether `text`, a file's start, reaches a `QUIT` line as [`lines`] reads it: the file ends
/// there. Only its whole words count, up to its last separator (a word cut off by the end of
/// `text` may go on past it: `QUITE`).
fn quits(text: &str) -> bool {
    let whole = text.rfind(is_separator).map_or("", |i| &text[..=i]);
    let mut read = lines(Path::new(""), whole);
    read.by_ref().for_each(drop);
    read.quit
}

/// Whether `c` separates words: spaces and tabs (and the other ASCII white space).
fn is_separator(c: char) -> bool {
    c.is_ascii_whitespace()
}

/// One meaningful line: its place, its first word and the words after it.
#[derive(Clone, Debug)]
pub struct Line<'a> {
    /// The file the line is from, for error messages.
    pub path: &'a Path,
    /// 1-based line number.
    pub number: usize,
    /// The first word: a command, a `$VARIABLE` or a record name.
    pub name: &'a str,
    /// The words after the first.
    pub values: Vec<&'a str>,
    /// Everything after the first word, with surrounding separators trimmed (for paths).
    pub rest: &'a str,
}

/// An iterator over the meaningful lines of a text: blank lines and `REM` lines are skipped, and
/// it ends at the first `QUIT` line.
#[derive(Clone, Debug)]
pub struct Lines<'a> {
    path: &'a Path,
    inner: std::iter::Enumerate<std::str::Split<'a, char>>,
    done: bool,
    /// It ended at a `QUIT` line.
    quit: bool,
}

/// The meaningful lines of `text`, read from `path`.
pub fn lines<'a>(path: &'a Path, text: &'a str) -> Lines<'a> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    Lines {
        path,
        inner: text.split('\n').enumerate(),
        done: false,
        quit: false,
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = Line<'a>;

    fn next(&mut self) -> Option<Line<'a>> {
        if self.done {
            return None;
        }
        for (index, raw) in self.inner.by_ref() {
            let raw = raw.strip_suffix('\r').unwrap_or(raw);
            let trimmed = raw.trim_matches(is_separator);
            let (name, rest) = match trimmed.find(is_separator) {
                Some(at) => (&trimmed[..at], trimmed[at..].trim_matches(is_separator)),
                None => (trimmed, ""),
            };
            match name {
                "" | "REM" => continue,
                "QUIT" => {
                    self.done = true;
                    self.quit = true;
                    return None;
                }
                _ => {}
            }
            let values = rest.split(is_separator).filter(|w| !w.is_empty()).collect();
            return Some(Line {
                path: self.path,
                number: index + 1,
                name,
                values,
                rest,
            });
        }
        self.done = true;
        None
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

impl Line<'_> {
    /// A [`LoadError::At`] for this line.
    pub fn error(&self, message: impl Into<String>) -> LoadError {
        LoadError::At {
            path: self.path.to_path_buf(),
            line: self.number,
            message: message.into(),
        }
    }

    /// Checks that the line has exactly `n` values after its name.
    ///
    /// # Errors
    /// "`NAME`: expected n values, found m".
    pub fn expect_count(&self, n: usize) -> Result<(), LoadError> {
        if self.values.len() == n {
            Ok(())
        } else {
            Err(self.error(format!(
                "`{}`: expected {n} value{}, found {}",
                self.name,
                plural(n),
                self.values.len()
            )))
        }
    }

    /// Parses `word` as a finite `f32`.
    ///
    /// # Errors
    /// "`abc` is not a number" or "`inf` is not a finite number".
    pub fn number(&self, word: &str) -> Result<f32, LoadError> {
        match word.parse::<f32>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.error(format!("`{word}` is not a finite number"))),
            Err(_) if word.contains(',') => {
                Err(self.error(format!("`{word}` is not a number (use a decimal point)")))
            }
            Err(_) => Err(self.error(format!("`{word}` is not a number"))),
        }
    }

    /// Parses all values as finite `f32`s; the count must be `N`.
    ///
    /// # Errors
    /// As [`Line::expect_count`] and [`Line::number`].
    pub fn numbers<const N: usize>(&self) -> Result<[f32; N], LoadError> {
        self.expect_count(N)?;
        let mut out = [0.0; N];
        for (o, w) in out.iter_mut().zip(&self.values) {
            *o = self.number(w)?;
        }
        Ok(out)
    }

    /// Parses `word` as a whole number (no fraction, no exponent) in `i64`.
    fn integer(&self, word: &str) -> Result<i64, LoadError> {
        use std::num::IntErrorKind;
        match word.parse::<i64>() {
            Ok(v) => Ok(v),
            Err(e) if matches!(e.kind(), IntErrorKind::PosOverflow) => Ok(i64::MAX),
            Err(e) if matches!(e.kind(), IntErrorKind::NegOverflow) => Ok(i64::MIN),
            Err(_) if word.parse::<f64>().is_ok() => {
                Err(self.error(format!("`{word}` is not a whole number")))
            }
            Err(_) => Err(self.error(format!("`{word}` is not a number"))),
        }
    }

    /// Parses `word` as a non-negative integer that fits a `u32`.
    ///
    /// # Errors
    /// "`abc` is not a number", "`1.5` is not a whole number", "`-1` is negative" or "... is too
    /// large".
    pub fn unsigned(&self, word: &str) -> Result<u32, LoadError> {
        let v = self.integer(word)?;
        if v < 0 {
            Err(self.error(format!(
                "`{word}` is negative; a non-negative whole number is needed"
            )))
        } else {
            u32::try_from(v)
                .map_err(|_| self.error(format!("`{word}` is too large (at most {})", u32::MAX)))
        }
    }

    /// Parses `word` as an integer in `lo..=hi`; `what` names the value in the message.
    ///
    /// # Errors
    /// A parse error as [`Line::unsigned`], or "WHAT must be LO to HI, found V" (or "must be 0 or
    /// 1" for a flag).
    pub fn integer_in(&self, word: &str, lo: u32, hi: u32, what: &str) -> Result<u32, LoadError> {
        let v = self.integer(word)?;
        match u32::try_from(v) {
            Ok(v) if (lo..=hi).contains(&v) => Ok(v),
            _ if hi == lo + 1 => {
                Err(self.error(format!("{what} must be {lo} or {hi}, found `{word}`")))
            }
            _ => Err(self.error(format!("{what} must be {lo} to {hi}, found `{word}`"))),
        }
    }

    /// Parses `word` as a flag: `0` is false, `1` is true.
    ///
    /// # Errors
    /// As [`Line::integer_in`].
    pub fn flag(&self, word: &str, what: &str) -> Result<bool, LoadError> {
        Ok(self.integer_in(word, 0, 1, what)? == 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_that_are_not_text_after_quit_are_not_read() -> Result<(), LoadError> {
        let dir = tempfile::tempdir().map_err(|source| LoadError::Io {
            path: "tempdir".into(),
            source,
        })?;
        let file = |name: &str, bytes: &[u8]| {
            let path = dir.path().join(name);
            std::fs::write(&path, bytes).map(|()| path)
        };
        let io = |source| LoadError::Io {
            path: "written".into(),
            source,
        };
        for (name, bytes) in [
            ("own-line.txt", &b"A 1\nQUIT\n\xff\xfe junk\n"[..]),
            ("same-line.txt", b"A 1\r\n  QUIT \xe4 (Latin-1)\n"),
        ] {
            let text = read_text(&file(name, bytes).map_err(io)?)?;
            assert!(text.starts_with("A 1\n"), "{name}: {text:?}");
        }
        for (name, bytes, line) in [
            ("before.txt", &b"A \xff\nQUIT\n"[..], 1),
            ("glued.txt", b"B 2\nQUIT\xff\n", 2),
            ("in-rem.txt", b"REM QUIT\n\xff\n", 2),
        ] {
            match read_text(&file(name, bytes).map_err(io)?) {
                Err(LoadError::At { line: at, .. }) => assert_eq!(at, line, "{name}"),
                other => panic!("{name}: {other:?}"),
            }
        }
        Ok(())
    }

    #[test]
    fn skips_rem_blank_and_stops_at_quit() {
        let p = Path::new("f");
        let text = "\u{feff}REM x\r\n\r\n\t A  1\t2 \r\nREMARK\nQUIT now\nB\n";
        let got: Vec<_> = lines(p, text)
            .map(|l| (l.number, l.name, l.values, l.rest))
            .collect();
        assert_eq!(
            got,
            vec![(3, "A", vec!["1", "2"], "1\t2"), (4, "REMARK", vec![], "")]
        );
    }

    #[test]
    fn numbers_and_integers() {
        let p = Path::new("f");
        let l = lines(p, "X").next().expect("a line");
        assert_eq!(l.number("1.5e1").ok(), Some(15.0));
        assert!(l.number("nan").is_err() && l.number("inf").is_err() && l.number("1e39").is_err());
        assert_eq!(l.unsigned("7").ok(), Some(7));
        assert!(l.unsigned("-1").is_err() && l.unsigned("1.0").is_err());
        assert!(l.unsigned("4294967296").is_err());
        assert!(l.integer_in("99999999999999999999999", 1, 5, "w").is_err());
        assert!(l.flag("2", "f").is_err());
    }
}
