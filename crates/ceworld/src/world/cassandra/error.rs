//! The error type.

use std::fmt;

/// Why a file was refused, and where.
///
/// `line` and `column` are 1-based. They are 0 only for errors that have no
/// place in the text (the file could not be read).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParseError {
    /// The file name, when parsing through [`crate::world::cassandra::parse_file`].
    pub file: Option<String>,
    pub line: usize,
    pub column: usize,
    /// What was found and what was expected.
    pub message: String,
}

impl ParseError {
    pub(crate) fn at(pos: crate::world::cassandra::lexer::Pos, message: impl Into<String>) -> Self {
        ParseError { file: None, line: pos.line, column: pos.col, message: message.into() }
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut prefixed = false;
        if let Some(file) = &self.file {
            write!(f, "{file}:")?;
            prefixed = true;
        }
        if self.line > 0 {
            write!(f, "{}:{}:", self.line, self.column)?;
            prefixed = true;
        }
        if prefixed {
            write!(f, " ")?;
        }
        write!(f, "{}", self.message)
    }
}

impl std::error::Error for ParseError {}
