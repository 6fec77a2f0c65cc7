//! Declared parameters: every parameter of a cell model or a protocol is one line of a
//! [`ParamTable`] (key, kind and unit, default, allowed range, one-line doc, source).
//!
//! The table is the single source of truth: the scenario parser reads a TOML section
//! against it ([`read_section`]: units converted, ranges checked, unknown keys rejected
//! with a "did you mean" suggestion, errors with file, line and key), the documentation
//! tables are generated from it ([`ParamTable::markdown`], checked against `docs/` by a
//! test), and `cellmech params` prints it. A model reads the resolved values by key
//! ([`ParamValues`]); a key that is not declared is a programming error caught by the
//! tests that build every model with its defaults.

use std::collections::BTreeMap;
use std::ops::Range;

use toml::de::{DeTable, DeValue};
use toml::Spanned;

use crate::units::{format_quantity, parse_quantity, Dimension};

/// What kind of value a parameter takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamKind {
    /// A quantity with a unit (a dimensionless one accepts `%`), in internal units.
    Quantity(Dimension),
    /// A list of quantities of one dimension.
    QuantityList(Dimension),
    /// A whole number.
    Count,
    /// A plain number without a unit.
    Number,
    /// One of the listed words.
    Choice(&'static [&'static str]),
    /// Three numbers (a direction).
    Vector3,
    /// A seed of random choices (a whole number ≥ 0).
    Seed,
}

/// A parameter's default value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParamDefault {
    /// A number in internal units.
    Number(f64),
    /// A list of numbers in internal units.
    List(&'static [f64]),
    /// A whole number.
    Count(usize),
    /// A word.
    Word(&'static str),
    /// Three numbers.
    Vector3([f64; 3]),
    /// A seed.
    Seed(u64),
    /// No default: the parameter is optional and its absence has a documented meaning.
    Absent(&'static str),
}

/// The allowed range of a number (bounds in internal units; open or closed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Lower bound.
    pub min: f64,
    /// Whether `min` itself is allowed.
    pub min_inclusive: bool,
    /// Upper bound.
    pub max: f64,
    /// Whether `max` itself is allowed.
    pub max_inclusive: bool,
}

impl Bounds {
    /// Any finite value.
    pub const ANY: Bounds = Bounds::new(f64::NEG_INFINITY, false, f64::INFINITY, false);
    /// Strictly positive.
    pub const POSITIVE: Bounds = Bounds::new(0.0, false, f64::INFINITY, false);
    /// Zero or more.
    pub const NON_NEGATIVE: Bounds = Bounds::new(0.0, true, f64::INFINITY, false);

    /// Bounds from their parts.
    pub const fn new(min: f64, min_inclusive: bool, max: f64, max_inclusive: bool) -> Self {
        Bounds {
            min,
            min_inclusive,
            max,
            max_inclusive,
        }
    }

    /// Whether `x` lies within the bounds (and is finite).
    pub fn contains(&self, x: f64) -> bool {
        x.is_finite()
            && (x > self.min || (self.min_inclusive && x == self.min))
            && (x < self.max || (self.max_inclusive && x == self.max))
    }

    /// The range as text in the parameter's unit, e.g. `> 0 um` or `[1, 64]`.
    pub fn describe(&self, dim: Option<Dimension>) -> String {
        let show = |v: f64| match dim {
            Some(d) if d != Dimension::Dimensionless => format_quantity(v, d),
            _ => format!("{v}"),
        };
        match (self.min.is_finite(), self.max.is_finite()) {
            (false, false) => "any".into(),
            (true, false) => format!(
                "{} {}",
                if self.min_inclusive { "≥" } else { ">" },
                show(self.min)
            ),
            (false, true) => format!(
                "{} {}",
                if self.max_inclusive { "≤" } else { "<" },
                show(self.max)
            ),
            (true, true) => format!(
                "{}{}, {}{}",
                if self.min_inclusive { "[" } else { "(" },
                show(self.min),
                show(self.max),
                if self.max_inclusive { "]" } else { ")" }
            ),
        }
    }
}

/// One declared parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamDef {
    /// Dotted key within its section (`cytoplasm.shear_modulus`).
    pub key: &'static str,
    /// Kind and unit.
    pub kind: ParamKind,
    /// Default.
    pub default: ParamDefault,
    /// Allowed range of numbers (counts and quantities).
    pub bounds: Bounds,
    /// One line saying what it is.
    pub doc: &'static str,
    /// Where the default comes from (`spec: Suspended cell`, a paper, or a documented choice).
    pub source: &'static str,
}

/// The declared parameters of one model or protocol.
#[derive(Debug, Clone, Copy)]
pub struct ParamTable {
    /// Name (`suspended-cell`, `micropipette-tension`).
    pub name: &'static str,
    /// The TOML section it is read from (`cell`, `protocol`).
    pub section: &'static str,
    /// The parameters in documentation order.
    pub params: &'static [ParamDef],
}

/// A resolved value.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum ParamValue {
    /// Number in internal units.
    Number(f64),
    /// List of numbers in internal units.
    List(Vec<f64>),
    /// Whole number.
    Count(usize),
    /// Word.
    Word(String),
    /// Three numbers.
    Vector3([f64; 3]),
    /// Seed.
    Seed(u64),
}

/// The resolved parameters of one table: every declared key with its value (the default
/// where the file gave none), and where each given value was written.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize)]
pub struct ParamValues {
    /// Values by key (absent optional parameters are missing).
    pub values: BTreeMap<&'static str, ParamValue>,
    /// Byte spans of the values the file gave (for messages of later checks).
    #[serde(skip)]
    pub spans: BTreeMap<&'static str, Range<usize>>,
}

impl ParamValues {
    /// Every parameter of `table` at its default.
    pub fn defaults(table: &ParamTable) -> Self {
        let mut out = ParamValues::default();
        for p in table.params {
            if let Some(v) = default_value(p.default) {
                out.values.insert(p.key, v);
            }
        }
        out
    }

    /// Sets `key` (declared in `table`) to `value` after checking kind and range: the way
    /// library code overrides a default. The error says what was expected.
    pub fn set(&mut self, table: &ParamTable, key: &str, value: ParamValue) -> Result<(), String> {
        let def = table
            .params
            .iter()
            .find(|p| p.key == key)
            .ok_or_else(|| unknown_key_message(table, key))?;
        check_value(def, &value)?;
        self.values.insert(def.key, value);
        Ok(())
    }

    /// A number (quantity or plain), in internal units.
    pub fn number(&self, key: &str) -> f64 {
        match self.values.get(key) {
            Some(ParamValue::Number(x)) => *x,
            other => undeclared(key, other),
        }
    }

    /// A whole number.
    pub fn count(&self, key: &str) -> usize {
        match self.values.get(key) {
            Some(ParamValue::Count(x)) => *x,
            other => undeclared(key, other),
        }
    }

    /// The number of an optional parameter (`None`: absent, its documented meaning applies).
    pub fn optional_number(&self, key: &str) -> Option<f64> {
        match self.values.get(key) {
            None => None,
            Some(ParamValue::Number(x)) => Some(*x),
            other => undeclared(key, other),
        }
    }

    /// An optional whole number (`None` when absent).
    pub fn optional_count(&self, key: &str) -> Option<usize> {
        match self.values.get(key) {
            None => None,
            Some(ParamValue::Count(x)) => Some(*x),
            other => undeclared(key, other),
        }
    }

    /// A word.
    pub fn word(&self, key: &str) -> &str {
        match self.values.get(key) {
            Some(ParamValue::Word(x)) => x,
            other => undeclared(key, other),
        }
    }

    /// A list of numbers.
    pub fn list(&self, key: &str) -> &[f64] {
        match self.values.get(key) {
            Some(ParamValue::List(x)) => x,
            other => undeclared(key, other),
        }
    }

    /// Three numbers.
    pub fn vector3(&self, key: &str) -> [f64; 3] {
        match self.values.get(key) {
            Some(ParamValue::Vector3(x)) => *x,
            other => undeclared(key, other),
        }
    }

    /// A seed.
    pub fn seed(&self, key: &str) -> u64 {
        match self.values.get(key) {
            Some(ParamValue::Seed(x)) => *x,
            other => undeclared(key, other),
        }
    }

    /// Whether the file (or the caller) gave `key` explicitly.
    pub fn given(&self, key: &str) -> bool {
        self.spans.contains_key(key)
    }

    /// The span of the value the file gave for `key`.
    pub fn span(&self, key: &str) -> Option<Range<usize>> {
        self.spans.get(key).cloned()
    }
}

#[track_caller]
fn undeclared(key: &str, found: Option<&ParamValue>) -> ! {
    // A model read a key its own table does not declare (or with the wrong accessor): a
    // bug in the model's code, caught by the tests that build every model with defaults.
    panic!("parameter `{key}` is not declared with this kind (found {found:?})")
}

fn default_value(d: ParamDefault) -> Option<ParamValue> {
    Some(match d {
        ParamDefault::Number(x) => ParamValue::Number(x),
        ParamDefault::List(x) => ParamValue::List(x.to_vec()),
        ParamDefault::Count(x) => ParamValue::Count(x),
        ParamDefault::Word(x) => ParamValue::Word(x.into()),
        ParamDefault::Vector3(x) => ParamValue::Vector3(x),
        ParamDefault::Seed(x) => ParamValue::Seed(x),
        ParamDefault::Absent(_) => return None,
    })
}

fn check_value(def: &ParamDef, value: &ParamValue) -> Result<(), String> {
    let dim = match def.kind {
        ParamKind::Quantity(d) | ParamKind::QuantityList(d) => Some(d),
        _ => None,
    };
    let range = || def.bounds.describe(dim);
    match (def.kind, value) {
        (ParamKind::Quantity(_) | ParamKind::Number, ParamValue::Number(x)) => {
            if def.bounds.contains(*x) {
                Ok(())
            } else {
                Err(format!(
                    "expected a value {}; found {}",
                    range(),
                    show(*x, dim)
                ))
            }
        }
        (ParamKind::QuantityList(_), ParamValue::List(xs)) => {
            match xs.iter().find(|x| !def.bounds.contains(**x)) {
                Some(x) => Err(format!(
                    "expected values {}; found {}",
                    range(),
                    show(*x, dim)
                )),
                None => Ok(()),
            }
        }
        (ParamKind::Count, ParamValue::Count(n)) => {
            if def.bounds.contains(*n as f64) {
                Ok(())
            } else {
                Err(format!("expected a whole number {}; found {n}", range()))
            }
        }
        (ParamKind::Choice(words), ParamValue::Word(w)) => {
            if words.contains(&w.as_str()) {
                Ok(())
            } else {
                Err(format!("expected {}; found \"{w}\"", quoted_list(words)))
            }
        }
        (ParamKind::Vector3, ParamValue::Vector3(v)) => {
            if v.iter().all(|c| c.is_finite()) && v.iter().any(|c| *c != 0.0) {
                Ok(())
            } else {
                Err(format!(
                    "expected three finite numbers, not all zero; found {v:?}"
                ))
            }
        }
        (ParamKind::Seed, ParamValue::Seed(_)) => Ok(()),
        (kind, v) => Err(format!("expected {}; found {v:?}", kind_text(kind))),
    }
}

fn show(x: f64, dim: Option<Dimension>) -> String {
    match dim {
        Some(d) if d != Dimension::Dimensionless => format_quantity(x, d),
        _ => format!("{x}"),
    }
}

fn quoted_list(words: &[&str]) -> String {
    let q: Vec<String> = words.iter().map(|w| format!("\"{w}\"")).collect();
    match q.len() {
        0 => String::new(),
        1 => q[0].clone(),
        n => format!("{} or {}", q[..n - 1].join(", "), q[n - 1]),
    }
}

fn kind_text(kind: ParamKind) -> String {
    match kind {
        ParamKind::Quantity(d) => format!("{} with its unit, e.g. \"{}\"", d.name(), d.example()),
        ParamKind::QuantityList(d) => {
            format!("a list of {}s, e.g. [\"{}\"]", &d.name()[2..], d.example())
        }
        ParamKind::Count => "a whole number".into(),
        ParamKind::Number => "a number".into(),
        ParamKind::Choice(words) => quoted_list(words),
        ParamKind::Vector3 => "three numbers, e.g. [1, 1, 1]".into(),
        ParamKind::Seed => "a whole number ≥ 0".into(),
    }
}

/// Edit distance (Levenshtein) for "did you mean".
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// The closest declared key to `key`, if close enough to be a typo.
pub fn suggestion<'a>(keys: impl IntoIterator<Item = &'a str>, key: &str) -> Option<&'a str> {
    let last = |k: &str| k.rsplit('.').next().unwrap_or(k).to_string();
    keys.into_iter()
        .map(|k| {
            let d = edit_distance(k, key).min(edit_distance(&last(k), &last(key)) + 1);
            (d, k)
        })
        .filter(|(d, k)| *d <= (k.len().max(key.len()) / 3).max(2))
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k)
}

fn unknown_key_message(table: &ParamTable, key: &str) -> String {
    let hint = match suggestion(table.params.iter().map(|p| p.key), key) {
        Some(k) => format!("did you mean `{k}`? "),
        None => String::new(),
    };
    format!(
        "unknown key for {}; {hint}the keys are listed by `cellmech params {}`",
        table.name, table.name
    )
}

/// A parameter problem located in a section: key (dotted, with the section) and span.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    /// Full dotted key (`cell.cytoplasm.shear_modulus`).
    pub key: String,
    /// Byte span in the file, when known.
    pub span: Option<Range<usize>>,
    /// What was expected and what was found.
    pub message: String,
}

/// Reads the section `table.section` of the parsed file `root` (the whole document)
/// against `table`. `skip` lists keys handled by the caller (e.g. `kind`). Absent section:
/// every default.
pub fn read_section(
    root: &DeTable<'_>,
    table: &ParamTable,
    skip: &[&str],
    others: &[&ParamTable],
) -> Result<ParamValues, ParamError> {
    let mut out = ParamValues::defaults(table);
    let Some(section) = root.get(table.section) else {
        return Ok(out);
    };
    let section_key = table.section;
    let DeValue::Table(section_table) = section.get_ref() else {
        return Err(ParamError {
            key: section_key.into(),
            span: Some(section.span()),
            message: format!(
                "expected a table [{section_key}]; found a {}",
                section.get_ref().type_str()
            ),
        });
    };
    let mut leaves = Vec::new();
    flatten(section_table, String::new(), &mut leaves);
    for (key, value) in leaves {
        if skip.contains(&key.as_str()) {
            continue;
        }
        let full = format!("{section_key}.{key}");
        let Some(def) = table.params.iter().find(|p| p.key == key) else {
            let message = match others
                .iter()
                .find(|t| t.params.iter().any(|p| p.key == key))
            {
                Some(other) => format!(
                    "`{key}` does not apply to {} (it is a key of {})",
                    table.name, other.name
                ),
                None => unknown_key_message(table, &key),
            };
            return Err(ParamError {
                key: full,
                span: Some(value.span()),
                message,
            });
        };
        let parsed = convert(def, value.get_ref()).and_then(|v| {
            check_value(def, &v)?;
            Ok(v)
        });
        match parsed {
            Ok(v) => {
                out.values.insert(def.key, v);
                out.spans.insert(def.key, value.span());
            }
            Err(message) => {
                return Err(ParamError {
                    key: full,
                    span: Some(value.span()),
                    message,
                })
            }
        }
    }
    Ok(out)
}

/// Leaf values of a table with their dotted keys (sub-tables descended into).
fn flatten<'a, 'i>(
    table: &'a DeTable<'i>,
    prefix: String,
    out: &mut Vec<(String, &'a Spanned<DeValue<'i>>)>,
) {
    for (k, v) in table.iter() {
        let key = if prefix.is_empty() {
            k.get_ref().to_string()
        } else {
            format!("{prefix}.{}", k.get_ref())
        };
        match v.get_ref() {
            DeValue::Table(t) => flatten(t, key, out),
            _ => out.push((key, v)),
        }
    }
}

fn number_of(v: &DeValue<'_>) -> Option<f64> {
    match v {
        DeValue::Integer(i) => i64::from_str_radix(&i.as_str().replace('_', ""), i.radix())
            .ok()
            .map(|x| x as f64),
        DeValue::Float(f) => f.as_str().replace('_', "").parse().ok(),
        _ => None,
    }
}

fn convert(def: &ParamDef, v: &DeValue<'_>) -> Result<ParamValue, String> {
    let wrong = || format!("expected {}; found a {}", kind_text(def.kind), v.type_str());
    match def.kind {
        ParamKind::Quantity(d) => match v {
            DeValue::String(s) => parse_quantity(s, d)
                .map(ParamValue::Number)
                .map_err(|e| e.to_string()),
            _ if d == Dimension::Dimensionless => {
                number_of(v).map(ParamValue::Number).ok_or_else(wrong)
            }
            _ => Err(wrong()),
        },
        ParamKind::QuantityList(d) => {
            let DeValue::Array(items) = v else {
                return Err(wrong());
            };
            let mut list = Vec::new();
            for item in items.iter() {
                let x = match item.get_ref() {
                    DeValue::String(s) => parse_quantity(s, d).map_err(|e| e.to_string())?,
                    other if d == Dimension::Dimensionless => number_of(other).ok_or_else(wrong)?,
                    _ => return Err(wrong()),
                };
                list.push(x);
            }
            Ok(ParamValue::List(list))
        }
        ParamKind::Count => match v {
            DeValue::Integer(i) => i64::from_str_radix(&i.as_str().replace('_', ""), i.radix())
                .ok()
                .and_then(|x| usize::try_from(x).ok())
                .map(ParamValue::Count)
                .ok_or_else(|| format!("expected a whole number ≥ 0; found {}", i.as_str())),
            _ => Err(wrong()),
        },
        ParamKind::Seed => match v {
            DeValue::Integer(i) => i64::from_str_radix(&i.as_str().replace('_', ""), i.radix())
                .ok()
                .and_then(|x| u64::try_from(x).ok())
                .map(ParamValue::Seed)
                .ok_or_else(|| format!("expected a whole number ≥ 0; found {}", i.as_str())),
            _ => Err(wrong()),
        },
        ParamKind::Number => number_of(v).map(ParamValue::Number).ok_or_else(wrong),
        ParamKind::Choice(_) => match v {
            DeValue::String(s) => Ok(ParamValue::Word(s.to_string())),
            _ => Err(wrong()),
        },
        ParamKind::Vector3 => {
            let DeValue::Array(items) = v else {
                return Err(wrong());
            };
            let xs: Vec<f64> = items
                .iter()
                .filter_map(|i| number_of(i.get_ref()))
                .collect();
            match <[f64; 3]>::try_from(xs) {
                Ok(a) if items.len() == 3 => Ok(ParamValue::Vector3(a)),
                _ => Err(wrong()),
            }
        }
    }
}

impl ParamTable {
    /// The parameter with this key.
    pub fn get(&self, key: &str) -> Option<&ParamDef> {
        self.params.iter().find(|p| p.key == key)
    }

    /// The documentation table (Markdown): key, default with unit, range, meaning, source.
    pub fn markdown(&self) -> String {
        let mut s = format!(
            "| `[{}]` key | default | allowed | meaning | source |\n|---|---|---|---|---|\n",
            self.section
        );
        for p in self.params {
            let dim = match p.kind {
                ParamKind::Quantity(d) | ParamKind::QuantityList(d) => Some(d),
                _ => None,
            };
            let default = match p.default {
                ParamDefault::Number(x) => format!("`{}`", toml_number(x, dim)),
                ParamDefault::List(xs) => format!(
                    "`[{}]`",
                    xs.iter()
                        .map(|x| toml_number(*x, dim))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                ParamDefault::Count(n) => format!("`{n}`"),
                ParamDefault::Word(w) => format!("`\"{w}\"`"),
                ParamDefault::Vector3(v) => format!("`[{}, {}, {}]`", v[0], v[1], v[2]),
                ParamDefault::Seed(n) => format!("`{n}`"),
                ParamDefault::Absent(meaning) => meaning.to_string(),
            };
            let allowed = match p.kind {
                ParamKind::Choice(words) => quoted_list(words),
                ParamKind::Vector3 => "finite, not all zero".into(),
                ParamKind::Seed => "≥ 0".into(),
                _ => p.bounds.describe(dim),
            };
            s.push_str(&format!(
                "| `{}` | {} | {} | {} | {} |\n",
                p.key, default, allowed, p.doc, p.source
            ));
        }
        s
    }

    /// The section as commented TOML with every key at its default (for `cellmech params`).
    pub fn toml_template(&self) -> String {
        let mut s = format!("[{}]\n", self.section);
        if self.section == "protocol" {
            s.push_str(&format!("kind = \"{}\"\n", self.name));
        }
        for p in self.params {
            let dim = match p.kind {
                ParamKind::Quantity(d) | ParamKind::QuantityList(d) => Some(d),
                _ => None,
            };
            let value = match p.default {
                ParamDefault::Number(x) => toml_number(x, dim),
                ParamDefault::List(xs) => format!(
                    "[{}]",
                    xs.iter()
                        .map(|x| toml_number(*x, dim))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                ParamDefault::Count(n) => n.to_string(),
                ParamDefault::Word(w) => format!("\"{w}\""),
                ParamDefault::Vector3(v) => format!("[{}, {}, {}]", v[0], v[1], v[2]),
                ParamDefault::Seed(n) => n.to_string(),
                ParamDefault::Absent(meaning) => {
                    s.push_str(&format!("# {} = ...   # {} ({meaning})\n", p.key, p.doc));
                    continue;
                }
            };
            s.push_str(&format!("# {} = {value}   # {}\n", p.key, p.doc));
        }
        s
    }
}

/// A number as it would be written in a scenario: a quoted quantity with its internal unit,
/// or a bare number.
fn toml_number(x: f64, dim: Option<Dimension>) -> String {
    match dim {
        Some(Dimension::Dimensionless) => format!("\"{}%\"", round_percent(100.0 * x)),
        Some(d) => format!("\"{}\"", format_quantity(x, d)),
        // 1e-8, not 0.00000001 (both are TOML).
        None if x != 0.0 && x.abs() < 1e-3 => format!("{x:e}"),
        None => format!("{x}"),
    }
}

fn round_percent(p: f64) -> f64 {
    (p * 1e9).round() / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggestion_finds_typos_and_rejects_strangers() {
        let keys = [
            "cytoplasm.shear_modulus",
            "cell_diameter",
            "nucleus_diameter",
        ];
        assert_eq!(
            suggestion(keys, "cytoplasm.shear_modulos"),
            Some("cytoplasm.shear_modulus")
        );
        assert_eq!(suggestion(keys, "cell_diametre"), Some("cell_diameter"));
        assert_eq!(suggestion(keys, "colour"), None);
    }

    #[test]
    fn bounds_describe_and_contain() {
        let b = Bounds::new(0.0, false, 1.0, true);
        assert!(b.contains(1.0) && !b.contains(0.0) && !b.contains(f64::NAN));
        assert_eq!(b.describe(None), "(0, 1]");
        assert_eq!(Bounds::POSITIVE.describe(Some(Dimension::Length)), "> 0 um");
    }
}
