//! The lexer: `.fart` text to [`Token`]s, each with the line and column where it starts.
//!
//! White space separates tokens; `//` comments run to the end of the line and `/* ... */`
//! comments may span lines (they do not nest). Numbers start with a digit (`3`, `0.25`, `1e-3`);
//! `0..10` is `0`, `..`, `10`. Strings are written in double quotes, with `\"` and `\\` as the
//! only escapes. Columns count characters, from 1.

use super::{FartError, Pos};

/// What a token is.
#[derive(Clone, Debug, PartialEq)]
pub enum TokenKind {
    /// A name: keyword, variable, function or defined name (`[A-Za-z_][A-Za-z0-9_]*`).
    Ident(String),
    /// A number literal.
    Number(f64),
    /// A string literal, without its quotes.
    Str(String),
    /// `{`
    LBrace,
    /// `}`
    RBrace,
    /// `(`
    LParen,
    /// `)`
    RParen,
    /// `<`, which opens a vector or compares.
    Less,
    /// `>`, which closes a vector or compares.
    Greater,
    /// `<=`
    LessEq,
    /// `>=`
    GreaterEq,
    /// `==`
    EqEq,
    /// `!=`
    NotEq,
    /// `=`
    Assign,
    /// `,`
    Comma,
    /// `..`
    DotDot,
    /// `+`
    Plus,
    /// `-`
    Minus,
    /// `*`
    Star,
    /// `/`
    Slash,
    /// `%`
    Percent,
    /// `!`
    Not,
    /// `&&`
    AndAnd,
    /// `||`
    OrOr,
    /// The end of the file.
    Eof,
}

impl TokenKind {
    /// How the token reads in an error message: `` `}` ``, `` `radius` ``, `the end of the file`.
    pub fn describe(&self) -> String {
        let punct = |s: &str| format!("`{s}`");
        match self {
            TokenKind::Ident(s) => format!("`{s}`"),
            TokenKind::Number(n) => format!("`{n}`"),
            TokenKind::Str(s) => format!("the string \"{s}\""),
            TokenKind::LBrace => punct("{"),
            TokenKind::RBrace => punct("}"),
            TokenKind::LParen => punct("("),
            TokenKind::RParen => punct(")"),
            TokenKind::Less => punct("<"),
            TokenKind::Greater => punct(">"),
            TokenKind::LessEq => punct("<="),
            TokenKind::GreaterEq => punct(">="),
            TokenKind::EqEq => punct("=="),
            TokenKind::NotEq => punct("!="),
            TokenKind::Assign => punct("="),
            TokenKind::Comma => punct(","),
            TokenKind::DotDot => punct(".."),
            TokenKind::Plus => punct("+"),
            TokenKind::Minus => punct("-"),
            TokenKind::Star => punct("*"),
            TokenKind::Slash => punct("/"),
            TokenKind::Percent => punct("%"),
            TokenKind::Not => punct("!"),
            TokenKind::AndAnd => punct("&&"),
            TokenKind::OrOr => punct("||"),
            TokenKind::Eof => "the end of the file".to_string(),
        }
    }
}

/// A token and where it starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Token {
    /// What it is.
    pub kind: TokenKind,
    /// Its first character.
    pub pos: Pos,
}

/// Splits `source` into tokens, ending with one [`TokenKind::Eof`].
///
/// # Errors
/// A [`FartError`] at an unexpected character, an unterminated string or comment, or a number
/// that does not fit an `f64`.
pub fn tokenize(source: &str) -> Result<Vec<Token>, FartError> {
    let mut lexer = Lexer {
        chars: source
            .strip_prefix('\u{feff}')
            .unwrap_or(source)
            .chars()
            .collect(),
        at: 0,
        pos: Pos { line: 1, column: 1 },
    };
    let mut tokens = Vec::new();
    loop {
        lexer.skip_space_and_comments()?;
        let pos = lexer.pos;
        let Some(c) = lexer.peek(0) else {
            tokens.push(Token {
                kind: TokenKind::Eof,
                pos,
            });
            return Ok(tokens);
        };
        let kind = if c.is_ascii_digit() {
            lexer.number()?
        } else if c.is_ascii_alphabetic() || c == '_' {
            let mut name = String::new();
            while let Some(c) = lexer
                .peek(0)
                .filter(|c| c.is_ascii_alphanumeric() || *c == '_')
            {
                name.push(c);
                lexer.bump();
            }
            TokenKind::Ident(name)
        } else if c == '"' {
            lexer.string()?
        } else {
            lexer.punct(c)?
        };
        tokens.push(Token { kind, pos });
    }
}

struct Lexer {
    chars: Vec<char>,
    at: usize,
    pos: Pos,
}

impl Lexer {
    fn peek(&self, ahead: usize) -> Option<char> {
        self.chars.get(self.at + ahead).copied()
    }

    fn bump(&mut self) {
        if let Some(c) = self.peek(0) {
            self.at += 1;
            if c == '\n' {
                self.pos.line += 1;
                self.pos.column = 1;
            } else {
                self.pos.column += 1;
            }
        }
    }

    fn skip_space_and_comments(&mut self) -> Result<(), FartError> {
        loop {
            match (self.peek(0), self.peek(1)) {
                (Some(c), _) if c.is_whitespace() => self.bump(),
                (Some('/'), Some('/')) => {
                    while self.peek(0).is_some_and(|c| c != '\n') {
                        self.bump();
                    }
                }
                (Some('/'), Some('*')) => {
                    let start = self.pos;
                    self.bump();
                    self.bump();
                    loop {
                        match (self.peek(0), self.peek(1)) {
                            (Some('*'), Some('/')) => {
                                self.bump();
                                self.bump();
                                break;
                            }
                            (Some(_), _) => self.bump(),
                            (None, _) => {
                                return Err(FartError::new(
                                    start,
                                    "this `/*` comment is never closed; expected `*/`, found the end of the file",
                                ))
                            }
                        }
                    }
                }
                _ => return Ok(()),
            }
        }
    }

    fn number(&mut self) -> Result<TokenKind, FartError> {
        let start = self.pos;
        let mut text = String::new();
        let digits = |lexer: &mut Lexer, text: &mut String| {
            while let Some(c) = lexer.peek(0).filter(char::is_ascii_digit) {
                text.push(c);
                lexer.bump();
            }
        };
        digits(self, &mut text);
        if self.peek(0) == Some('.') && self.peek(1).is_some_and(|c| c.is_ascii_digit()) {
            text.push('.');
            self.bump();
            digits(self, &mut text);
        }
        if matches!(self.peek(0), Some('e' | 'E')) {
            let sign = matches!(self.peek(1), Some('+' | '-'));
            let digit_at = if sign { 2 } else { 1 };
            if self.peek(digit_at).is_some_and(|c| c.is_ascii_digit()) {
                for _ in 0..digit_at {
                    if let Some(c) = self.peek(0) {
                        text.push(c);
                    }
                    self.bump();
                }
                digits(self, &mut text);
            }
        }
        if let Some(c) = self
            .peek(0)
            .filter(|c| c.is_ascii_alphanumeric() || *c == '_')
        {
            return Err(FartError::new(
                self.pos,
                format!("expected a space or an operator after the number `{text}`, found `{c}`"),
            ));
        }
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(TokenKind::Number(v)),
            _ => Err(FartError::new(
                start,
                format!("the number `{text}` is too large"),
            )),
        }
    }

    fn string(&mut self) -> Result<TokenKind, FartError> {
        let start = self.pos;
        self.bump();
        let mut text = String::new();
        loop {
            match self.peek(0) {
                Some('"') => {
                    self.bump();
                    return Ok(TokenKind::Str(text));
                }
                Some('\\') if matches!(self.peek(1), Some('"' | '\\')) => {
                    self.bump();
                    if let Some(c) = self.peek(0) {
                        text.push(c);
                    }
                    self.bump();
                }
                Some('\n') | None => {
                    return Err(FartError::new(
                        start,
                        "this string is never closed; expected `\"` before the end of the line",
                    ))
                }
                Some(c) => {
                    text.push(c);
                    self.bump();
                }
            }
        }
    }

    fn punct(&mut self, c: char) -> Result<TokenKind, FartError> {
        let next = self.peek(1);
        let (kind, len) = match (c, next) {
            ('<', Some('=')) => (TokenKind::LessEq, 2),
            ('>', Some('=')) => (TokenKind::GreaterEq, 2),
            ('=', Some('=')) => (TokenKind::EqEq, 2),
            ('!', Some('=')) => (TokenKind::NotEq, 2),
            ('&', Some('&')) => (TokenKind::AndAnd, 2),
            ('|', Some('|')) => (TokenKind::OrOr, 2),
            ('.', Some('.')) => (TokenKind::DotDot, 2),
            ('{', _) => (TokenKind::LBrace, 1),
            ('}', _) => (TokenKind::RBrace, 1),
            ('(', _) => (TokenKind::LParen, 1),
            (')', _) => (TokenKind::RParen, 1),
            ('<', _) => (TokenKind::Less, 1),
            ('>', _) => (TokenKind::Greater, 1),
            ('=', _) => (TokenKind::Assign, 1),
            (',', _) => (TokenKind::Comma, 1),
            ('+', _) => (TokenKind::Plus, 1),
            ('-', _) => (TokenKind::Minus, 1),
            ('*', _) => (TokenKind::Star, 1),
            ('/', _) => (TokenKind::Slash, 1),
            ('%', _) => (TokenKind::Percent, 1),
            ('!', _) => (TokenKind::Not, 1),
            _ => {
                return Err(FartError::new(
                    self.pos,
                    format!("unexpected character `{}`", c.escape_debug()),
                ))
            }
        };
        for _ in 0..len {
            self.bump();
        }
        Ok(kind)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(src: &str) -> Vec<TokenKind> {
        tokenize(src)
            .map(|t| t.into_iter().map(|t| t.kind).collect())
            .unwrap_or_default()
    }

    #[test]
    fn ranges_numbers_and_comments() {
        assert_eq!(
            kinds("0..10 // x\n/* y\n */ 1.5e2"),
            vec![
                TokenKind::Number(0.0),
                TokenKind::DotDot,
                TokenKind::Number(10.0),
                TokenKind::Number(150.0),
                TokenKind::Eof
            ]
        );
    }

    #[test]
    fn positions_count_lines_and_characters() {
        let t = tokenize("a\n/*ä*/ b").unwrap_or_default();
        assert_eq!(t[1].kind, TokenKind::Ident("b".into()));
        assert_eq!(t[1].pos, Pos { line: 2, column: 7 });
    }

    #[test]
    fn errors_have_places() {
        let e = tokenize("a /* open").err();
        assert_eq!(e.map(|e| e.pos), Some(Pos { line: 1, column: 3 }));
        let e = tokenize("\n  12abc").err();
        assert_eq!(e.map(|e| e.pos), Some(Pos { line: 2, column: 5 }));
    }
}
