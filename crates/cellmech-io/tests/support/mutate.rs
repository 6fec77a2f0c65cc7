//! Text mutations and a panic/hang guard for the parser property tests (issue 9).
//!
//! Shared by `crates/cellmech-io/tests/parser_properties.rs` and
//! `crates/cellmech/tests/scenario_properties.rs` through `#[path]`. A [`Mutation`] holds
//! [`Index`]es rather than positions, so one mutation applies to any text and proptest can
//! shrink a failing list of mutations to the smallest one.

#![allow(dead_code)]

use std::sync::mpsc;
use std::time::Duration;

use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, FileFailurePersistence, RngSeed};

/// The seed of every property in CI, so that a failure reproduces exactly.
pub const SEED: u64 = 0x00C3_11AE_C400_0009;

/// A proptest config with `cases` cases and the fixed [`SEED`], unless `PROPTEST_CASES` or
/// `PROPTEST_RNG_SEED` are set (then those win, for longer local runs).
pub fn config(cases: u32) -> Config {
    let mut config = Config::default();
    if std::env::var_os("PROPTEST_CASES").is_none() {
        config.cases = cases;
    }
    if std::env::var_os("PROPTEST_RNG_SEED").is_none() {
        config.rng_seed = RngSeed::Fixed(SEED);
    }
    // Integration tests have no lib.rs for proptest's default persistence to find: keep the
    // failing seeds in `<test file>.proptest-regressions` beside the test source instead.
    config.failure_persistence = Some(Box::new(FileFailurePersistence::WithSource(
        "proptest-regressions",
    )));
    // A failing case is shrunk for at most this long: CI must stay fast even then.
    if std::env::var_os("PROPTEST_MAX_SHRINK_TIME").is_none() {
        config.max_shrink_time = 60_000;
    }
    config
}

/// Numbers that break naive parsers: zero, negatives, the integer limits and one past them,
/// NaN and infinities in their spellings, overflowing floats, non-numbers.
pub const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "2",
    "3",
    "-1",
    "-3",
    "7",
    "1.5",
    "-2.5",
    "0.0",
    "1e9",
    "1000000000",
    "99999999",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "9223372036854775808",
    "-9223372036854775808",
    "18446744073709551615",
    "18446744073709551616",
    "1e400",
    "-1e400",
    "1e-400",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "infinity",
    "x",
    "",
    "0x10",
    "1,2",
    "--1",
    "1e",
    "\u{b5}",
];

/// Values a TOML key may get instead of its own: wrong types, bad units and numbers out of
/// range.
pub const TOML_VALUES: &[&str] = &[
    "\"1 furlong\"",
    "\"-3 um\"",
    "\"nan kPa\"",
    "\"1e400 um\"",
    "\"0 um\"",
    "\"1e9 um\"",
    "\"1e-30 um\"",
    "\"-50%\"",
    "\"500%\"",
    "\"0%\"",
    "\"1 kPa\"",
    "\"1 nN\"",
    "\"um\"",
    "\"\"",
    "\"x\"",
    "0",
    "-1",
    "1",
    "3",
    "1.5",
    "-0.5",
    "0.5",
    "1e9",
    "1000000000",
    "9223372036854775807",
    "-9223372036854775808",
    "nan",
    "inf",
    "-inf",
    "true",
    "[]",
    "[1, 2]",
    "[\"1 um\"]",
    "[\"1 um\", \"1 um\", \"1 um\", \"1 um\"]",
    "[0, 0, 0]",
    "[-1, 0, 0]",
    "[1000000000, 1000000000, 1000000000]",
    "[[]]",
    "{}",
    "{ a = 1 }",
];

/// Numbers a quoted quantity (`"1.5 um"`) may get instead of its own number.
pub const QUANTITY_NUMBERS: &[&str] = &[
    "0", "-0", "-3", "1e-30", "1e9", "1e308", "1e400", "-1e400", "nan", "NaN", "inf", "-inf", "x",
    "", "1e", "0.5", "100", "-100",
];

/// TOML numbers a bare number may become: zero, negatives, huge counts, NaN.
pub const TOML_NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1",
    "2",
    "3",
    "5",
    "1.5",
    "-0.5",
    "100",
    "400",
    "65536",
    "1e9",
    "1000000000",
    "4294967296",
    "9223372036854775807",
    "-9223372036854775808",
    "nan",
    "inf",
    "-inf",
];

/// Units a quantity may get instead of its own.
pub const UNITS: &[&str] = &[
    "furlong", "", "um um", "m", "mm", "nm", "kPa", "GPa", "Pa", "nN", "N", "%", "\u{b5}m", "UM",
    "1",
];

/// Lines inserted at random places.
pub const LINES: &[&str] = &[
    "",
    "bogus_key = 1",
    "[mesh]",
    "[cell]",
    "[[step]]",
    "[[material]]",
    "[[tool]]",
    "[protocol]",
    "[output]",
    "[[step.fix]]",
    "[[output.curve]]",
    "$MeshFormat",
    "$EndMeshFormat",
    "$Nodes",
    "$EndNodes",
    "$Elements",
    "$EndElements",
    "$Entities",
    "$PhysicalNames",
    "4.1 0 8",
    "1 1 1 1",
    "0 0 0",
    "3 1 5 1",
    "*NODE",
    "*ELEMENT, TYPE=C3D8, ELSET=X",
    "*ELEMENT, TYPE=T3D2",
    "*NSET, NSET=A",
    "*NSET, NSET=A, GENERATE",
    "*ELSET, ELSET=B",
    "*ELSET, ELSET=B, GENERATE",
    "*NSET, NSET=C, ELSET=B",
    "*INCLUDE, INPUT=x.inp",
    "A",
    "B",
    "1, 0, 0, 0",
    "1, 2, 3, 4, 5, 6, 7, 8",
    "1, 1000000000, 1",
    "-9223372036854775808, 9223372036854775807",
    "*",
    ",",
    "\"",
];

/// One edit of a text.
#[derive(Debug, Clone)]
pub enum Mutation {
    /// Remove a line.
    DeleteLine(Index),
    /// Remove a run of up to 8 lines.
    DeleteLines(Index, u8),
    /// Repeat a line (once, or many times).
    DuplicateLine(Index, u8),
    /// Exchange two lines.
    SwapLines(Index, Index),
    /// Insert a line before another.
    InsertLine(Index, String),
    /// Replace the n-th number of the text.
    ReplaceNumber(Index, String),
    /// Replace the n-th token (run of characters without blanks and commas).
    ReplaceToken(Index, String),
    /// Replace the value of the n-th `key = value` line.
    ReplaceValue(Index, String),
    /// Replace the n-th number inside a quoted string (`"1.5 um"`, `"24%"`).
    ReplaceQuotedNumber(Index, String),
    /// Replace the n-th number outside quoted strings and comments (a TOML number).
    ReplaceBareNumber(Index, String),
    /// Replace the unit of the n-th quoted quantity (`"1.5 um"`).
    ReplaceUnit(Index, String),
    /// Append a copy of the n-th `[section]` / `[[section]]` with its lines.
    DuplicateSection(Index),
    /// Cut the text at a character.
    Truncate(Index),
}

/// A mutation that suits every text format.
pub fn generic_mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        3 => any::<Index>().prop_map(Mutation::DeleteLine),
        1 => (any::<Index>(), 1u8..8).prop_map(|(i, n)| Mutation::DeleteLines(i, n)),
        2 => (any::<Index>(), prop_oneof![Just(1u8), 2u8..=255]).prop_map(|(i, n)| Mutation::DuplicateLine(i, n)),
        2 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::SwapLines(a, b)),
        2 => (any::<Index>(), line_text()).prop_map(|(i, l)| Mutation::InsertLine(i, l)),
        6 => (any::<Index>(), number_text()).prop_map(|(i, n)| Mutation::ReplaceNumber(i, n)),
        2 => (any::<Index>(), number_text()).prop_map(|(i, n)| Mutation::ReplaceToken(i, n)),
        1 => any::<Index>().prop_map(Mutation::Truncate),
    ]
}

/// A mutation of a TOML scenario: the generic ones plus value, number, unit and section
/// edits that keep the TOML well-formed, so that most cases reach the scenario checks.
pub fn toml_mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        3 => generic_mutation(),
        4 => (any::<Index>(), prop::sample::select(TOML_VALUES).prop_map(str::to_string))
            .prop_map(|(i, v)| Mutation::ReplaceValue(i, v)),
        4 => (any::<Index>(), prop::sample::select(QUANTITY_NUMBERS).prop_map(str::to_string))
            .prop_map(|(i, v)| Mutation::ReplaceQuotedNumber(i, v)),
        3 => (any::<Index>(), prop::sample::select(TOML_NUMBERS).prop_map(str::to_string))
            .prop_map(|(i, v)| Mutation::ReplaceBareNumber(i, v)),
        2 => (any::<Index>(), prop::sample::select(UNITS).prop_map(str::to_string))
            .prop_map(|(i, u)| Mutation::ReplaceUnit(i, u)),
        1 => any::<Index>().prop_map(Mutation::DuplicateSection),
    ]
}

/// `text` without its comment-only lines: mutations of TOML seeds then hit keys and values.
pub fn strip_comment_lines(text: &str) -> String {
    text.split_inclusive('\n')
        .filter(|l| !l.trim_start().starts_with('#'))
        .collect()
}

/// Whether each byte of `text` is inside a quoted string or a `#` comment (TOML, one line).
fn quoted_or_comment(text: &str) -> (Vec<bool>, Vec<bool>) {
    let mut quoted = vec![false; text.len()];
    let mut comment = vec![false; text.len()];
    let (mut in_quote, mut in_comment) = (false, false);
    for (i, c) in text.char_indices() {
        if c == '\n' {
            in_quote = false;
            in_comment = false;
        } else if !in_comment && c == '"' {
            in_quote = !in_quote;
        } else if !in_quote && c == '#' {
            in_comment = true;
        }
        quoted[i] = in_quote;
        comment[i] = in_comment;
    }
    (quoted, comment)
}

/// How many `key = value` lines `text` has.
pub fn count_key_values(text: &str) -> usize {
    split_lines(text)
        .iter()
        .filter(|l| key_value(l).is_some())
        .count()
}

/// How many numbers `text` has inside (`quoted`) or outside quoted strings.
pub fn count_numbers(text: &str, quoted: bool) -> usize {
    number_spans_where(text, quoted).len()
}

/// Number spans inside (`inside`) or outside quoted strings, never in comments.
fn number_spans_where(text: &str, inside: bool) -> Vec<(usize, usize)> {
    let (quoted, comment) = quoted_or_comment(text);
    number_spans(text)
        .into_iter()
        .filter(|&(s, _)| quoted[s] == inside && !comment[s])
        .collect()
}

/// A number from [`NUMBERS`] or an arbitrary integer or float.
pub fn number_text() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => prop::sample::select(NUMBERS).prop_map(str::to_string),
        1 => any::<i64>().prop_map(|n| n.to_string()),
        1 => any::<f64>().prop_map(|x| x.to_string()),
        1 => (0u32..100).prop_map(|n| n.to_string()),
    ]
}

/// A line from [`LINES`] or a short line of random numbers and words.
pub fn line_text() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => prop::sample::select(LINES).prop_map(str::to_string),
        1 => prop::collection::vec(number_text(), 0..10).prop_map(|v| v.join(" ")),
        1 => prop::collection::vec(number_text(), 0..10).prop_map(|v| v.join(", ")),
        1 => "[ -~]{0,40}",
    ]
}

/// The lines of `text`, each with its line ending.
fn split_lines(text: &str) -> Vec<String> {
    text.split_inclusive('\n').map(str::to_string).collect()
}

/// A line with a newline at its end.
fn as_line(s: &str) -> String {
    if s.ends_with('\n') {
        s.to_string()
    } else {
        format!("{s}\n")
    }
}

/// Byte ranges of the numbers in `text` (digits with sign, point and exponent), not counting
/// digits inside words such as `C3D8`.
pub fn number_spans(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let prev_word = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        let starts = b[i].is_ascii_digit()
            || ((b[i] == b'-' || b[i] == b'+' || b[i] == b'.')
                && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        if !starts || prev_word {
            i += 1;
            continue;
        }
        let start = i;
        i += 1;
        while i < b.len()
            && (b[i].is_ascii_digit()
                || b[i] == b'.'
                || ((b[i] == b'e' || b[i] == b'E')
                    && b.get(i + 1)
                        .is_some_and(|c| c.is_ascii_digit() || *c == b'-' || *c == b'+'))
                || ((b[i] == b'-' || b[i] == b'+') && (b[i - 1] == b'e' || b[i - 1] == b'E')))
        {
            i += 1;
        }
        if i < b.len() && (b[i].is_ascii_alphabetic() || b[i] == b'_') && b[i] != b'e' {
            // Part of a word (`3D8`): skip the word.
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            continue;
        }
        spans.push((start, i));
    }
    spans
}

/// Byte ranges of the tokens of `text` (runs without blanks and commas).
fn token_spans(text: &str) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = None;
    for (i, c) in text.char_indices() {
        let sep = c.is_whitespace() || c == ',';
        match (start, sep) {
            (None, false) => start = Some(i),
            (Some(s), true) => {
                spans.push((s, i));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        spans.push((s, text.len()));
    }
    spans
}

/// Byte ranges of the units of quoted quantities: `"1.5 um"` gives the range of `um`.
fn unit_spans(text: &str) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut quote: Option<usize> = None;
    for (i, c) in text.char_indices() {
        if c == '\n' {
            quote = None;
        } else if c == '"' {
            match quote {
                None => quote = Some(i + 1),
                Some(s) => {
                    let inner = &text[s..i];
                    if let Some(space) = inner.rfind(' ') {
                        if inner[..space].trim().parse::<f64>().is_ok() {
                            spans.push((s + space + 1, i));
                        }
                    }
                    quote = None;
                }
            }
        }
    }
    spans
}

fn replace_span(text: &str, spans: &[(usize, usize)], at: &Index, with: &str) -> String {
    if spans.is_empty() {
        return text.to_string();
    }
    let (s, e) = spans[at.index(spans.len())];
    format!("{}{}{}", &text[..s], with, &text[e..])
}

/// Whether a line is a `key = value` line (TOML).
fn key_value(line: &str) -> Option<usize> {
    let trimmed = line.trim_start();
    let first = trimmed.chars().next()?;
    if !(first.is_ascii_alphabetic() || first == '_') {
        return None;
    }
    line.find('=')
}

impl Mutation {
    /// This mutation applied to `text`.
    pub fn apply(&self, text: &str) -> String {
        let mut lines = split_lines(text);
        let n = lines.len();
        match self {
            Mutation::DeleteLine(i) if n > 0 => {
                lines.remove(i.index(n));
            }
            Mutation::DeleteLines(i, count) if n > 0 => {
                let start = i.index(n);
                let end = (start + *count as usize).min(n);
                lines.drain(start..end);
            }
            Mutation::DuplicateLine(i, times) if n > 0 => {
                let at = i.index(n);
                let line = as_line(&lines[at]);
                for _ in 0..*times {
                    lines.insert(at, line.clone());
                }
            }
            Mutation::SwapLines(a, b) if n > 0 => {
                let (a, b) = (a.index(n), b.index(n));
                let (la, lb) = (as_line(&lines[a]), as_line(&lines[b]));
                lines[a] = lb;
                lines[b] = la;
            }
            Mutation::InsertLine(i, l) => {
                let at = if n == 0 { 0 } else { i.index(n + 1) };
                if at == n && n > 0 {
                    lines[n - 1] = as_line(&lines[n - 1]);
                }
                lines.insert(at, as_line(l));
            }
            Mutation::ReplaceNumber(i, with) => {
                return replace_span(text, &number_spans(text), i, with)
            }
            Mutation::ReplaceToken(i, with) => {
                return replace_span(text, &token_spans(text), i, with)
            }
            Mutation::ReplaceUnit(i, with) => {
                return replace_span(text, &unit_spans(text), i, with)
            }
            Mutation::ReplaceValue(i, with) => {
                let keyed: Vec<usize> =
                    (0..n).filter(|&k| key_value(&lines[k]).is_some()).collect();
                if !keyed.is_empty() {
                    let k = keyed[i.index(keyed.len())];
                    let eq = key_value(&lines[k]).unwrap_or(0);
                    lines[k] = format!("{}= {with}\n", &lines[k][..eq]);
                }
            }
            Mutation::DuplicateSection(i) => {
                let headers: Vec<usize> = (0..n)
                    .filter(|&k| lines[k].trim_start().starts_with('['))
                    .collect();
                if !headers.is_empty() {
                    let h = headers[i.index(headers.len())];
                    let end = headers.iter().copied().find(|&k| k > h).unwrap_or(n);
                    let copy: Vec<String> = lines[h..end].iter().map(|l| as_line(l)).collect();
                    if n > 0 {
                        lines[n - 1] = as_line(&lines[n - 1]);
                    }
                    lines.extend(copy);
                }
            }
            Mutation::Truncate(i) => {
                let mut at = i.index(text.len() + 1);
                while !text.is_char_boundary(at) {
                    at -= 1;
                }
                return text[..at].to_string();
            }
            _ => {}
        }
        lines.concat()
    }
}

/// `text` with every mutation applied in order.
pub fn apply_all(text: &str, mutations: &[Mutation]) -> String {
    mutations.iter().fold(text.to_string(), |t, m| m.apply(&t))
}

/// How a guarded call ended badly.
pub fn describe(input: &str) -> String {
    const SHOWN: usize = 6000;
    if input.len() <= SHOWN {
        format!("input ({} bytes):\n-----\n{input}\n-----", input.len())
    } else {
        let path = std::env::temp_dir().join(format!(
            "cellmech-fuzz-input-{}-{}.txt",
            std::process::id(),
            input.len()
        ));
        let _ = std::fs::write(&path, input);
        format!(
            "input ({} bytes, written to {}), its start:\n-----\n{}\n-----",
            input.len(),
            path.display(),
            &input[..input.floor_char_boundary_compat(SHOWN)]
        )
    }
}

trait FloorBoundary {
    fn floor_char_boundary_compat(&self, at: usize) -> usize;
}

impl FloorBoundary for str {
    fn floor_char_boundary_compat(&self, mut at: usize) -> usize {
        at = at.min(self.len());
        while !self.is_char_boundary(at) {
            at -= 1;
        }
        at
    }
}

/// Runs `f` on its own thread: a panic or a run longer than `timeout` becomes an `Err` that
/// shows `input` (the test then fails with it); otherwise `f`'s value.
pub fn guarded<T: Send + 'static>(
    what: &str,
    input: &str,
    timeout: Duration,
    f: impl FnOnce() -> T + Send + 'static,
) -> Result<T, TestCaseError> {
    let (tx, rx) = mpsc::channel();
    let handle = std::thread::Builder::new()
        .name(format!("guarded {what}"))
        .spawn(move || {
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
            let _ = tx.send(result);
        })
        .expect("spawn a thread");
    match rx.recv_timeout(timeout) {
        Ok(Ok(value)) => {
            let _ = handle.join();
            Ok(value)
        }
        Ok(Err(payload)) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "(non-string panic payload)".into());
            Err(TestCaseError::fail(format!(
                "{what} PANICKED ({message}) on {}",
                describe(input)
            )))
        }
        Err(_) => Err(TestCaseError::fail(format!(
            "{what} did not return within {timeout:?} (hang or unbounded work) on {}",
            describe(input)
        ))),
    }
}
