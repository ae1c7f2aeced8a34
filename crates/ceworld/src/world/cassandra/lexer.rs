//! Tokeniser for Cassandra's `.pomdp` format.
//!
//! The lexer works on raw bytes: every meaningful token is ASCII, so bytes
//! outside ASCII (including invalid UTF-8) are only allowed inside comments,
//! and anywhere else they produce a [`Tok::Bad`] token with a message.
//!
//! A *word* is a maximal run of bytes that are not whitespace, `:` or `#`.
//! Each word is then classified as `*`, a lone sign (`-` / `+`, since
//! pomdp-solve lexes `- 2` as two tokens), a number, or a name.

use std::fmt;

/// A 1-based line and column (columns count characters; every character
/// before a valid token on its line is ASCII, so bytes and characters agree).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Pos {
    pub line: usize,
    pub col: usize,
}

impl fmt::Display for Pos {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.col)
    }
}

/// The kinds of token.
#[derive(Clone, Debug, PartialEq)]
pub enum Tok<'a> {
    /// `:`
    Colon,
    /// `*`
    Star,
    /// A lone `-` (true) or `+` (false), to be followed by a number.
    Sign(bool),
    /// A finite number; `text` is the literal as written.
    Number { value: f64, text: &'a str },
    /// A name: an ASCII letter or `_`, then letters, digits, `_`, `-` or `.`.
    Name(&'a str),
    /// End of input.
    Eof,
    /// A lexical error; the message says what was found.
    Bad(String),
}

impl Tok<'_> {
    /// For numbers written as plain decimal digits (no sign, point or
    /// exponent), their value, saturating at `u64::MAX` (which is out of
    /// range for any use).
    pub fn int_literal(&self) -> Option<u64> {
        match self {
            Tok::Number { text, .. } if text.bytes().all(|b| b.is_ascii_digit()) => {
                // All digits and non-empty: the only possible error is overflow.
                Some(text.parse::<u64>().unwrap_or(u64::MAX))
            }
            _ => None,
        }
    }

    /// A short description for error messages ("name 'foo'", "':'", ...).
    pub fn describe(&self) -> String {
        match self {
            Tok::Colon => "':'".to_string(),
            Tok::Star => "'*'".to_string(),
            Tok::Sign(true) => "'-'".to_string(),
            Tok::Sign(false) => "'+'".to_string(),
            Tok::Number { text, .. } => format!("number {text}"),
            Tok::Name(n) => format!("name '{n}'"),
            Tok::Eof => "end of file".to_string(),
            Tok::Bad(m) => m.clone(),
        }
    }
}

/// A token and where it starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Token<'a> {
    pub tok: Tok<'a>,
    pub pos: Pos,
}

fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c)
}

fn ends_word(b: u8) -> bool {
    is_space(b) || b == b':' || b == b'#'
}

/// Whether `w` has the shape `[+-]? (digits [. digits?] | . digits) ([eE] [+-]? digits)?`.
fn looks_numeric(w: &[u8]) -> bool {
    let mut i = 0;
    if matches!(w.first(), Some(b'+' | b'-')) {
        i = 1;
    }
    let int_start = i;
    while w.get(i).is_some_and(u8::is_ascii_digit) {
        i += 1;
    }
    let mut digits = i - int_start;
    if w.get(i) == Some(&b'.') {
        i += 1;
        let frac_start = i;
        while w.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
        }
        digits += i - frac_start;
    }
    if digits == 0 {
        return false;
    }
    if matches!(w.get(i), Some(b'e' | b'E')) {
        i += 1;
        if matches!(w.get(i), Some(b'+' | b'-')) {
            i += 1;
        }
        let exp_start = i;
        while w.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
        }
        if i == exp_start {
            return false;
        }
    }
    i == w.len()
}

fn looks_like_name(w: &[u8]) -> bool {
    match w.split_first() {
        Some((first, rest)) => {
            (first.is_ascii_alphabetic() || *first == b'_')
                && rest.iter().all(|b| b.is_ascii_alphanumeric() || matches!(b, b'_' | b'-' | b'.'))
        }
        None => false,
    }
}

/// Shortens a word for display in a message.
fn show(w: &[u8]) -> String {
    let text = String::from_utf8_lossy(w);
    let mut out: String = text.chars().take(40).collect();
    if text.chars().count() > 40 {
        out.push_str("...");
    }
    out.escape_debug().to_string()
}

fn classify(w: &[u8]) -> Tok<'_> {
    if w == b"*" {
        return Tok::Star;
    }
    if w == b"-" {
        return Tok::Sign(true);
    }
    if w == b"+" {
        return Tok::Sign(false);
    }
    // Every byte of a numeric or name word is ASCII, so this conversion
    // succeeds for them; anything else is reported as a bad token.
    let text = std::str::from_utf8(w).ok();
    if let Some(text) = text.filter(|_| looks_numeric(w)) {
        return match text.parse::<f64>() {
            Ok(value) if value.is_finite() => Tok::Number { value, text },
            _ => Tok::Bad(format!("number '{}' is out of range (expected a finite number)", show(w))),
        };
    }
    if let Some(text) = text.filter(|_| looks_like_name(w)) {
        return Tok::Name(text);
    }
    if !w.is_ascii() {
        return Tok::Bad(format!(
            "unexpected non-ASCII text '{}' (names and numbers are ASCII; \
             other text is only allowed in '#' comments)",
            show(w)
        ));
    }
    Tok::Bad(format!("unexpected '{}' (expected a name, a number, '*' or ':')", show(w)))
}

/// Splits `input` into tokens. The result always ends with exactly one
/// [`Tok::Eof`] or [`Tok::Bad`] token (lexing stops at the first bad word).
pub fn tokenize(input: &[u8]) -> Vec<Token<'_>> {
    let mut tokens = Vec::new();
    let mut i = 0;
    let mut line = 1;
    let mut line_start = 0;
    loop {
        // Skip whitespace and comments.
        while let Some(&b) = input.get(i) {
            if b == b'\n' {
                line += 1;
                line_start = i + 1;
                i += 1;
            } else if is_space(b) {
                i += 1;
            } else if b == b'#' {
                while input.get(i).is_some_and(|&c| c != b'\n') {
                    i += 1;
                }
            } else {
                break;
            }
        }
        let pos = Pos { line, col: i - line_start + 1 };
        let Some(&b) = input.get(i) else {
            tokens.push(Token { tok: Tok::Eof, pos });
            return tokens;
        };
        if b == b':' {
            tokens.push(Token { tok: Tok::Colon, pos });
            i += 1;
            continue;
        }
        let start = i;
        while input.get(i).is_some_and(|&c| !ends_word(c)) {
            i += 1;
        }
        let tok = classify(input.get(start..i).unwrap_or_default());
        let bad = matches!(tok, Tok::Bad(_));
        tokens.push(Token { tok, pos });
        if bad {
            return tokens;
        }
    }
}

#[cfg(test)]
// The literals compared are exactly representable.
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    fn kinds(s: &str) -> Vec<Tok<'_>> {
        tokenize(s.as_bytes()).into_iter().map(|t| t.tok).collect()
    }

    #[test]
    fn numbers_and_names() {
        let toks = kinds("T:a-1 : * 0.5 .5 5. 1e-3 -2 - 3 # c\nx_y");
        assert_eq!(toks[0], Tok::Name("T"));
        assert_eq!(toks[1], Tok::Colon);
        assert_eq!(toks[2], Tok::Name("a-1"));
        assert_eq!(toks[4], Tok::Star);
        assert!(matches!(toks[5], Tok::Number { value, .. } if value == 0.5));
        assert!(matches!(toks[6], Tok::Number { value, .. } if value == 0.5));
        assert!(matches!(toks[7], Tok::Number { value, .. } if value == 5.0));
        assert!(matches!(toks[8], Tok::Number { value, .. } if value == 1e-3));
        assert!(matches!(toks[9], Tok::Number { value, .. } if value == -2.0));
        assert_eq!(toks[10], Tok::Sign(true));
        assert_eq!(toks[12], Tok::Name("x_y"));
        assert_eq!(toks[13], Tok::Eof);
    }

    #[test]
    fn bad_tokens_stop() {
        let toks = kinds("a 1e999 b");
        assert!(matches!(&toks[1], Tok::Bad(m) if m.contains("out of range")));
        assert_eq!(toks.len(), 2);
        assert!(matches!(&kinds("nan")[0], Tok::Name("nan")));
        assert!(matches!(&kinds("1d")[0], Tok::Bad(_)));
        assert!(matches!(&kinds("\u{e9}")[0], Tok::Bad(m) if m.contains("non-ASCII")));
    }

    #[test]
    fn positions() {
        let toks = tokenize(b"# x\n  ab :\r\n\t3");
        assert_eq!(toks[0].pos, Pos { line: 2, col: 3 });
        assert_eq!(toks[1].pos, Pos { line: 2, col: 6 });
        assert_eq!(toks[2].pos, Pos { line: 3, col: 2 });
    }
}
