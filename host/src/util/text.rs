//! Text from input, made safe to print: a message may quote a word from a file, the network or
//! the command line, and that word must neither drive the terminal (control bytes) nor flood
//! it (a token of a megabyte).
//!
//! [`printable`] escapes every control character but the line break and shortens each quoted
//! word (between backticks, as every message of this program quotes input) to
//! [`MAX_QUOTED_CHARS`] characters, keeping its start and end.

/// The most characters of one quoted word a message shows.
pub const MAX_QUOTED_CHARS: usize = 60;

/// `message` with control characters escaped (`\u{1b}`) and overlong quoted words shortened.
pub fn printable(message: &str) -> String {
    let mut out = String::with_capacity(message.len().min(4096));
    for (i, part) in message.split('`').enumerate() {
        if i > 0 {
            out.push('`');
        }
        // Odd parts are inside backticks.
        let part = if i % 2 == 1 {
            shorten(part)
        } else {
            part.to_string()
        };
        for c in part.chars() {
            if c.is_control() && c != '\n' {
                out.extend(c.escape_unicode());
            } else {
                out.push(c);
            }
        }
    }
    out
}

/// `word` cut to its first and last characters with the count of those left out between.
fn shorten(word: &str) -> String {
    let n = word.chars().count();
    if n <= MAX_QUOTED_CHARS {
        return word.to_string();
    }
    let head: String = word.chars().take(MAX_QUOTED_CHARS - 20).collect();
    let tail: String = word.chars().skip(n - 10).collect();
    let left_out = n - head.chars().count() - tail.chars().count();
    format!("{head}…({left_out} more characters)…{tail}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_bytes_are_escaped_and_long_words_shortened() {
        assert_eq!(
            printable("f.nff:3: `1\u{1b}[31mRED` is not a number"),
            "f.nff:3: `1\\u{1b}[31mRED` is not a number"
        );
        let long = "x".repeat(1_000_000);
        let msg = printable(&format!("`{long}` is not a number"));
        assert!(msg.len() < 200, "{}", msg.len());
        assert!(msg.ends_with("xxxxxxxxxx` is not a number"), "{msg}");
        assert_eq!(printable("two\nlines, `ok`"), "two\nlines, `ok`");
    }
}
