//! A line cursor with 1-based line numbers, shared by the text readers.

use crate::error::ReadError;

/// Walks the lines of a text, remembering the current line number for error messages.
pub(crate) struct Lines<'a> {
    file: &'a str,
    lines: Vec<&'a str>,
    next: usize,
}

impl<'a> Lines<'a> {
    /// A cursor at the start of `text`; `file` names the source in errors.
    pub(crate) fn new(text: &'a str, file: &'a str) -> Self {
        Lines {
            file,
            lines: text.lines().collect(),
            next: 0,
        }
    }

    /// The next line as `(line number, trimmed text)`, or `None` at the end.
    pub(crate) fn next_line(&mut self) -> Option<(usize, &'a str)> {
        let line = self.lines.get(self.next)?;
        self.next += 1;
        Some((self.next, line.trim()))
    }

    /// The number of lines not read yet.
    pub(crate) fn remaining(&self) -> usize {
        self.lines.len() - self.next
    }

    /// The next line, without consuming it.
    pub(crate) fn peek(&self) -> Option<(usize, &'a str)> {
        self.lines.get(self.next).map(|l| (self.next + 1, l.trim()))
    }

    /// The next line, or an error saying what was expected instead of the end of the file.
    pub(crate) fn expect_line(&mut self, what: &str) -> Result<(usize, &'a str), ReadError> {
        match self.next_line() {
            Some(l) => Ok(l),
            None => Err(self.error(
                self.lines.len(),
                format!("expected {what}, found the end of the file"),
            )),
        }
    }

    /// A syntax error at `line`.
    pub(crate) fn error(&self, line: usize, message: impl Into<String>) -> ReadError {
        ReadError::Syntax {
            file: self.file.to_string(),
            line,
            message: message.into(),
        }
    }

    /// An error about the whole file.
    pub(crate) fn content_error(&self, message: impl Into<String>) -> ReadError {
        ReadError::Content {
            file: self.file.to_string(),
            message: message.into(),
        }
    }
}

/// Parses one token as `T`, with an error naming what was expected and what was found.
pub(crate) fn parse_token<T: std::str::FromStr>(
    lines: &Lines<'_>,
    line: usize,
    token: &str,
    what: &str,
) -> Result<T, ReadError> {
    token
        .trim()
        .parse()
        .map_err(|_| lines.error(line, format!("expected {what}, found '{}'", token.trim())))
}

/// Parses one token as a finite `f64` (a coordinate): `NaN`, `inf` and overflowing numbers
/// such as `1e400` are errors, like any other token that is not a number.
pub(crate) fn parse_finite(
    lines: &Lines<'_>,
    line: usize,
    token: &str,
    what: &str,
) -> Result<f64, ReadError> {
    let x: f64 = parse_token(lines, line, token, what)?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(lines.error(
            line,
            format!(
                "expected {what}, found '{}', which is not finite",
                token.trim()
            ),
        ))
    }
}
