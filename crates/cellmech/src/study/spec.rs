//! The study file: a base scenario and axes of variants, expanded into cases.
//!
//! ```toml
//! title = "Disruption of the suspended cell in tension"
//! base = "suspended-tension"          # a built-in example, or a scenario file (relative
//!                                     # to the study file)
//! [set]                               # optional: applied to every case (dotted keys)
//! "cell.core_divisions" = 4
//!
//! [[axis]]
//! kind = "disruption"                 # every subset of these families removed
//! families = ["actin", "microtubule", "intermediate"]
//!
//! [[axis]]
//! kind = "grid"                       # one declared parameter over a list of values
//! parameter = "cell.microtubules.coupling"
//! values = ["free", "embedded"]
//! ```
//!
//! Axes combine as a cross product. Member 0 of every axis is its control (nothing
//! removed, factor 1, the base value). `disruption`, `modulus`, `thickness`,
//! `compressibility` and `density` axes are *compared*: a case's force is divided by the force of the
//! case that has the control on every compared axis and the same members elsewhere. A
//! `grid` or `cases` axis is context (e.g. the coupling mode), never normalised away.
//!
//! Every case is a complete scenario document (the base with the case's keys set), so it
//! is checked by the same parser as `cellmech run`: an unknown or misspelt parameter is
//! rejected, with the case, key and line, before anything runs.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Value;

use crate::param::read_section;

/// A study that cannot be read or expanded.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// The study file cannot be read.
    #[error("{path}: {error}")]
    Read {
        /// File.
        path: String,
        /// Cause.
        error: std::io::Error,
    },
    /// The study file is not what is expected.
    #[error("{path}: {message}")]
    Invalid {
        /// File (or built-in study name).
        path: String,
        /// What was expected and found, with the key.
        message: String,
    },
    /// A case's scenario is rejected by the scenario parser.
    #[error("case `{case}`: {message}")]
    Case {
        /// Case name.
        case: String,
        /// The scenario parser's message.
        message: String,
    },
    /// Writing the study's files failed.
    #[error("{0}")]
    Output(String),
}

/// One member of an axis: a label and the keys it sets.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    /// Label used in case names (`control` for an axis's control).
    pub label: String,
    /// Dotted scenario keys and their values.
    pub set: Vec<(String, Value)>,
    /// `modulus` axes: the component whose modulus this member scales, and the factor
    /// (`None` for the control and on other axes).
    pub scaled: Option<(String, f64)>,
}

/// One axis of variants.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// `disruption`, `modulus`, `thickness`, `compressibility`, `density`, `grid` or
    /// `cases`.
    pub kind: String,
    /// Whether a case's force is normalised by the control on this axis.
    pub compared: bool,
    /// Members; member 0 is the control.
    pub members: Vec<Member>,
}

/// One case of the study: a member of every axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Case {
    /// Unique, folder-safe name (member labels joined by `.`; `control` when all are).
    pub name: String,
    /// Member index on every axis.
    pub members: Vec<usize>,
    /// Member labels on every axis.
    pub labels: Vec<String>,
    /// Every key the case sets (study-wide first, then per axis).
    pub set: Vec<(String, Value)>,
}

/// A parsed study.
#[derive(Debug, Clone)]
pub struct StudySpec {
    /// Title.
    pub title: String,
    /// Where the study came from (file or `<built-in: NAME>`).
    pub origin: String,
    /// The base scenario document.
    pub base: toml::Table,
    /// Where the base came from.
    pub base_origin: String,
    /// Directory relative mesh paths of the base are resolved against.
    pub base_dir: PathBuf,
    /// Keys set in every case.
    pub set: Vec<(String, Value)>,
    /// The axes.
    pub axes: Vec<Axis>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct StudyFile {
    title: Option<String>,
    base: String,
    #[serde(default)]
    set: toml::Table,
    #[serde(default)]
    axis: Vec<AxisSection>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct AxisSection {
    kind: String,
    families: Option<Vec<String>>,
    components: Option<Vec<String>>,
    factors: Option<Vec<f64>>,
    parameter: Option<String>,
    values: Option<Vec<Value>>,
    poisson_ratio: Option<f64>,
    subsets: Option<Vec<Vec<String>>>,
    counts: Option<Vec<i64>>,
    #[serde(default)]
    case: Vec<CaseSection>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseSection {
    name: String,
    #[serde(default)]
    set: toml::Table,
}

/// The axis kinds a study file accepts.
pub const AXIS_KINDS: [&str; 7] = [
    "disruption",
    "modulus",
    "thickness",
    "compressibility",
    "density",
    "grid",
    "cases",
];

/// Continuum components whose modulus is a `[cell]` parameter (and that parameter).
const CONTINUUM_MODULI: [(&str, &str); 2] = [
    ("cytoplasm", "cytoplasm.shear_modulus"),
    ("nucleus", "nucleus.shear_modulus"),
];

/// Reads a study file; `base` is a built-in example name or a path relative to the file.
pub fn load(path: &Path) -> Result<StudySpec, StudyError> {
    let text = std::fs::read_to_string(path).map_err(|error| StudyError::Read {
        path: path.display().to_string(),
        error,
    })?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    parse(&text, &path.display().to_string(), &dir)
}

/// Parses study text (`origin` names it in messages; `dir` anchors a relative base path).
pub fn parse(text: &str, origin: &str, dir: &Path) -> Result<StudySpec, StudyError> {
    let invalid = |message: String| StudyError::Invalid {
        path: origin.into(),
        message,
    };
    let file: StudyFile = toml::from_str(text).map_err(|e| invalid(e.to_string()))?;
    let (base_text, base_origin, base_dir) = match crate::examples::find(&file.base) {
        Some(example) => (
            example.text.to_string(),
            format!("<built-in: {}>", example.name),
            PathBuf::from("."),
        ),
        None => {
            let path = dir.join(&file.base);
            let text = std::fs::read_to_string(&path).map_err(|e| {
                invalid(format!(
                    "`base`: expected a built-in example ({}) or a scenario file; cannot read {}: {e}",
                    crate::examples::EXAMPLES
                        .iter()
                        .map(|e| e.name)
                        .collect::<Vec<_>>()
                        .join(", "),
                    path.display()
                ))
            })?;
            let base_dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
            (text, path.display().to_string(), base_dir)
        }
    };
    let base: toml::Table =
        toml::from_str(&base_text).map_err(|e| invalid(format!("`base` {base_origin}: {e}")))?;
    let set = flatten(&file.set);
    // The base with the study-wide keys: what moduli and thicknesses are factors of.
    let mut base_with_set = base.clone();
    for (key, value) in &set {
        set_dotted(&mut base_with_set, key, value.clone()).map_err(&invalid)?;
    }
    let axes = file
        .axis
        .iter()
        .enumerate()
        .map(|(i, a)| axis(a, &base_with_set).map_err(|m| invalid(format!("axis[{i}]: {m}"))))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(StudySpec {
        title: file
            .title
            .unwrap_or_else(|| format!("cellmech study of {base_origin}")),
        origin: origin.into(),
        base,
        base_origin,
        base_dir,
        set,
        axes,
    })
}

/// Dotted keys of a (possibly nested) table: `{a = {b = 1}}` and `{"a.b" = 1}` both give
/// `("a.b", 1)`.
fn flatten(table: &toml::Table) -> Vec<(String, Value)> {
    let mut out = Vec::new();
    fn walk(prefix: &str, table: &toml::Table, out: &mut Vec<(String, Value)>) {
        for (k, v) in table {
            let key = if prefix.is_empty() {
                k.clone()
            } else {
                format!("{prefix}.{k}")
            };
            match v {
                Value::Table(t) => walk(&key, t, out),
                other => out.push((key, other.clone())),
            }
        }
    }
    walk("", table, &mut out);
    out
}

/// Sets `a.b.c = value` in `table`, creating tables on the way.
pub fn set_dotted(table: &mut toml::Table, key: &str, value: Value) -> Result<(), String> {
    let mut parts: Vec<&str> = key.split('.').collect();
    let last = parts.pop().filter(|s| !s.is_empty()).ok_or_else(|| {
        format!("expected a dotted parameter name such as \"cell.cytoplasm.shear_modulus\"; found \"{key}\"")
    })?;
    let mut t = table;
    for p in parts {
        let entry = t
            .entry(p.to_string())
            .or_insert_with(|| Value::Table(toml::Table::new()));
        t = match entry {
            Value::Table(inner) => inner,
            _ => return Err(format!("`{key}`: `{p}` is a value, not a section")),
        };
    }
    t.insert(last.to_string(), value);
    Ok(())
}

fn label_of(value: &Value) -> String {
    let raw = match value {
        Value::String(s) => s.clone(),
        other => other.to_string(),
    };
    sanitize(&raw)
}

/// A folder-safe label: ASCII letters, digits, `-`, `_`, `.` replaced by `p`.
fn sanitize(raw: &str) -> String {
    raw.chars()
        .filter_map(|c| match c {
            'a'..='z' | 'A'..='Z' | '0'..='9' | '-' | '_' => Some(c),
            '.' => Some('p'),
            ' ' => None,
            '%' => Some('%'),
            _ => Some('-'),
        })
        .collect()
}

fn factor_label(component: &str, factor: f64) -> String {
    format!("{component}-x{}", sanitize(&format!("{factor}")))
}

fn control() -> Member {
    Member {
        label: "control".into(),
        set: Vec::new(),
        scaled: None,
    }
}

/// Whether the base scenario (with the study-wide keys) is the adherent cell.
fn is_adherent(base: &toml::Table) -> bool {
    base.get("cell")
        .and_then(Value::as_table)
        .and_then(|c| c.get("model"))
        .and_then(Value::as_str)
        == Some("adherent")
}

/// The base's value of a `[cell]` quantity (its declared default when the base omits it),
/// in the table's unit.
fn base_cell_number(base: &toml::Table, key: &str) -> Result<f64, String> {
    let text = toml::to_string(base).map_err(|e| e.to_string())?;
    let root = toml::de::DeTable::parse(&text).map_err(|e| e.to_string())?;
    let table = if is_adherent(base) {
        &crate::cell::adherent::params::ADHERENT_CELL
    } else {
        &crate::cell::suspended::params::SUSPENDED_CELL
    };
    let values = read_section(root.get_ref(), table, &["model"], &[])
        .map_err(|e| format!("the base's [cell]: `{}`: {}", e.key, e.message))?;
    Ok(values.number(key))
}

fn unit_of(key: &str) -> &'static str {
    if key.ends_with("thickness") {
        "um"
    } else {
        "kPa"
    }
}

fn factors(a: &AxisSection) -> Result<Vec<f64>, String> {
    let f = a.factors.clone().unwrap_or_else(|| vec![0.5, 1.5]);
    if f.is_empty() || f.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        return Err(format!("`factors`: expected factors > 0; found {f:?}"));
    }
    Ok(f)
}

/// The sets of families a disruption axis removes, each in the order of `families`:
/// `subsets` as listed (each entry a non-empty list of names among `families`), or every
/// non-empty subset, smallest first.
fn removal_sets(
    families: &[String],
    subsets: Option<&[Vec<String>]>,
) -> Result<Vec<Vec<String>>, String> {
    let Some(subsets) = subsets else {
        let n = families.len();
        let mut masks: Vec<u32> = (1..(1u32 << n)).collect();
        masks.sort_by_key(|&m| {
            (
                m.count_ones(),
                (0..n).filter(|i| m & (1 << i) != 0).collect::<Vec<_>>(),
            )
        });
        return Ok(masks
            .into_iter()
            .map(|m| {
                (0..n)
                    .filter(|i| m & (1 << i) != 0)
                    .map(|i| families[i].clone())
                    .collect()
            })
            .collect());
    };
    if subsets.is_empty() {
        return Err(
            "`subsets`: expected a non-empty list of family lists such as [[\"cortex\"], [\"cortex\", \"microtubule\"]]; found []"
                .into(),
        );
    }
    let mut out: Vec<Vec<String>> = Vec::with_capacity(subsets.len());
    for (k, entry) in subsets.iter().enumerate() {
        if entry.is_empty() {
            return Err(format!(
                "`subsets[{k}]`: expected at least one family name; found [] (the control is always included)"
            ));
        }
        let mut indices = Vec::with_capacity(entry.len());
        for name in entry {
            let i = families.iter().position(|f| f == name).ok_or_else(|| {
                format!(
                    "`subsets[{k}]` = {entry:?}: \"{name}\" is not among `families` {families:?}"
                )
            })?;
            if indices.contains(&i) {
                return Err(format!(
                    "`subsets[{k}]` = {entry:?}: \"{name}\" is listed twice"
                ));
            }
            indices.push(i);
        }
        indices.sort_unstable();
        let set: Vec<String> = indices.iter().map(|&i| families[i].clone()).collect();
        if let Some(j) = out.iter().position(|o| *o == set) {
            return Err(format!(
                "`subsets[{k}]` = {entry:?}: the same families as `subsets[{j}]`"
            ));
        }
        out.push(set);
    }
    Ok(out)
}

/// The optional keys of an axis and the kinds each applies to (`grid` and `cases` read
/// their own keys and ignore the rest).
const AXIS_KEYS: [(&str, &[&str]); 8] = [
    ("families", &["disruption", "density"]),
    ("subsets", &["disruption"]),
    ("components", &["modulus"]),
    ("factors", &["modulus", "thickness"]),
    ("counts", &["density"]),
    ("parameter", &["grid"]),
    ("values", &["grid"]),
    ("poisson_ratio", &["compressibility"]),
];

/// Rejects a key given for a kind it does not apply to, naming the key and where it applies
/// (an unknown kind is left to the caller's message listing the kinds).
fn check_keys(a: &AxisSection) -> Result<(), String> {
    let checked = [
        "disruption",
        "density",
        "modulus",
        "thickness",
        "compressibility",
    ];
    if !checked.contains(&a.kind.as_str()) {
        return Ok(());
    }
    let present = [
        a.families.is_some(),
        a.subsets.is_some(),
        a.components.is_some(),
        a.factors.is_some(),
        a.counts.is_some(),
        a.parameter.is_some(),
        a.values.is_some(),
        a.poisson_ratio.is_some(),
    ];
    for ((key, kinds), given) in AXIS_KEYS.iter().zip(present) {
        if given && !kinds.contains(&a.kind.as_str()) {
            return Err(format!(
                "`{key}` does not apply to kind = \"{}\" (only to {})",
                a.kind,
                kinds
                    .iter()
                    .map(|k| format!("\"{k}\""))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
    }
    Ok(())
}

fn axis(a: &AxisSection, base: &toml::Table) -> Result<Axis, String> {
    check_keys(a)?;
    let mut members = vec![control()];
    let compared = match a.kind.as_str() {
        "density" => {
            members.extend(density_members(a, is_adherent(base))?);
            true
        }
        "disruption" => {
            let families = a.families.clone().unwrap_or_else(|| {
                let names: &[&str] = if is_adherent(base) {
                    &["cortex", "bundles", "microtubule", "intermediate"]
                } else {
                    &["actin", "microtubule", "intermediate"]
                };
                names.iter().map(|s| s.to_string()).collect()
            });
            if families.is_empty() || families.len() > 6 {
                return Err(format!(
                    "`families`: expected 1 to 6 families; found {}",
                    families.len()
                ));
            }
            let mut seen = std::collections::BTreeSet::new();
            if let Some(f) = families.iter().find(|f| !seen.insert(f.as_str())) {
                return Err(format!("`families`: \"{f}\" is listed twice"));
            }
            for removed in removal_sets(&families, a.subsets.as_deref())? {
                members.push(Member {
                    label: format!(
                        "no-{}",
                        removed
                            .iter()
                            .map(|f| f.as_str())
                            .collect::<Vec<_>>()
                            .join("-")
                    ),
                    set: removed
                        .iter()
                        .map(|f| (format!("families.{f}.enabled"), Value::Boolean(false)))
                        .collect(),
                    scaled: None,
                });
            }
            true
        }
        "modulus" => {
            let components = a.components.clone().unwrap_or_else(|| {
                let names: &[&str] = if is_adherent(base) {
                    &[
                        "cytoplasm",
                        "nucleus",
                        "cortex",
                        "bundles",
                        "microtubule",
                        "intermediate",
                    ]
                } else {
                    &[
                        "cytoplasm",
                        "nucleus",
                        "membrane",
                        "actin",
                        "microtubule",
                        "intermediate",
                    ]
                };
                names.iter().map(|s| s.to_string()).collect()
            });
            if components.is_empty() {
                return Err("`components`: expected at least one component; found []".into());
            }
            for c in &components {
                for &f in &factors(a)? {
                    let set = match CONTINUUM_MODULI.iter().find(|(name, _)| name == c) {
                        Some((_, key)) => {
                            let v = base_cell_number(base, key)?;
                            vec![(
                                format!("cell.{key}"),
                                Value::String(format!("{} {}", v * f, unit_of(key))),
                            )]
                        }
                        None => vec![(format!("families.{c}.modulus_scale"), Value::Float(f))],
                    };
                    members.push(Member {
                        label: factor_label(c, f),
                        set,
                        scaled: Some((c.clone(), f)),
                    });
                }
            }
            true
        }
        "thickness" => {
            // The surface layer: the suspended cell's membrane, the adherent cell's cortex.
            let layer = if is_adherent(base) {
                "cortex"
            } else {
                "membrane"
            };
            let key = format!("{layer}.thickness");
            let v = base_cell_number(base, &key)?;
            for &f in &factors(a)? {
                members.push(Member {
                    label: factor_label(&format!("{layer}-thickness"), f),
                    set: vec![(
                        format!("cell.{key}"),
                        Value::String(format!("{} um", v * f)),
                    )],
                    scaled: None,
                });
            }
            true
        }
        "compressibility" => {
            let nu = a.poisson_ratio.unwrap_or(0.3);
            if !(nu > -1.0 && nu < 0.5) {
                return Err(format!(
                    "`poisson_ratio`: expected a value in (-1, 0.5); found {nu}"
                ));
            }
            members.push(Member {
                label: format!("compressible-nu{}", sanitize(&format!("{nu}"))),
                set: ["cell.cytoplasm.poisson_ratio", "cell.nucleus.poisson_ratio"]
                    .iter()
                    .map(|k| (k.to_string(), Value::Float(nu)))
                    .collect(),
                scaled: None,
            });
            true
        }
        "grid" => {
            let parameter = a
                .parameter
                .clone()
                .ok_or("kind = \"grid\" needs `parameter` (a dotted scenario key)")?;
            let values = a.values.clone().unwrap_or_default();
            if values.is_empty() {
                return Err("kind = \"grid\" needs a non-empty `values` list".into());
            }
            // A grid has no separate control: its first value is member 0.
            members.clear();
            for v in values {
                members.push(Member {
                    label: format!(
                        "{}-{}",
                        sanitize(parameter.rsplit('.').next().unwrap_or("")),
                        label_of(&v)
                    ),
                    set: vec![(parameter.clone(), v)],
                    scaled: None,
                });
            }
            false
        }
        "cases" => {
            if a.case.is_empty() {
                return Err(
                    "kind = \"cases\" needs [[axis.case]] entries with `name` and `set`".into(),
                );
            }
            members.clear();
            for c in &a.case {
                members.push(Member {
                    label: sanitize(&c.name),
                    set: flatten(&c.set),
                    scaled: None,
                });
            }
            false
        }
        other => {
            return Err(format!(
                "`kind`: expected one of {}; found \"{other}\"",
                AXIS_KINDS.join(", ")
            ))
        }
    };
    let mut seen = std::collections::BTreeSet::new();
    if let Some(m) = members.iter().find(|m| !seen.insert(m.label.clone())) {
        return Err(format!("two members are both labelled `{}`", m.label));
    }
    Ok(Axis {
        kind: a.kind.clone(),
        compared,
        members,
    })
}

/// The key of each family a density axis adds filaments to, in the suspended cell
/// (`[cell.density]`).
const DENSITY_KEYS: [(&str, &str); 3] = [
    ("actin", "cell.density.extra_actin"),
    ("microtubule", "cell.density.extra_microtubules"),
    ("intermediate", "cell.density.extra_intermediate"),
];

/// The same in the adherent cell: its ABs, MTs and IFs each have an `extra` count.
const ADHERENT_DENSITY_KEYS: [(&str, &str); 3] = [
    ("bundles", "cell.bundles.extra"),
    ("microtubule", "cell.microtubules.extra"),
    ("intermediate", "cell.intermediate.extra"),
];

/// The members of a `density` axis after its control: each family × each count of extra
/// filaments (absolute numbers added to the published 60 AFs, 30 MTs, 60 IFs of the
/// suspended cell, or 8 ABs, 16 MTs, 32 IFs of the adherent one), one family at a time,
/// labelled `extra-FAMILY-COUNT`. Default families: the model's three (`adherent`: the
/// base is the adherent cell).
fn density_members(a: &AxisSection, adherent: bool) -> Result<Vec<Member>, String> {
    let keys: &[(&str, &str)] = if adherent {
        &ADHERENT_DENSITY_KEYS
    } else {
        &DENSITY_KEYS
    };
    let families = a
        .families
        .clone()
        .unwrap_or_else(|| keys[..3].iter().map(|(f, _)| f.to_string()).collect());
    if families.is_empty() {
        return Err("`families`: expected at least one family".into());
    }
    let counts = a.counts.clone().unwrap_or_else(|| vec![30]);
    if counts.is_empty() || counts.iter().any(|&c| c < 1) {
        return Err(format!(
            "`counts`: expected whole numbers ≥ 1 of extra filaments; found {counts:?}"
        ));
    }
    let mut members = Vec::new();
    for family in &families {
        let key = keys
            .iter()
            .find(|(f, _)| f == family)
            .map(|(_, k)| *k)
            .ok_or_else(|| {
                format!(
                    "`families`: expected {}; found \"{family}\"",
                    keys.iter()
                        .map(|(f, _)| format!("\"{f}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })?;
        for &count in &counts {
            members.push(Member {
                label: format!("extra-{}-{count}", sanitize(family)),
                set: vec![(key.to_string(), Value::Integer(count))],
                scaled: None,
            });
        }
    }
    Ok(members)
}

impl StudySpec {
    /// Every case: the cross product of the axes, in order (the first axis varies slowest).
    pub fn cases(&self) -> Vec<Case> {
        let mut cases = vec![Case {
            name: String::new(),
            members: Vec::new(),
            labels: Vec::new(),
            set: self.set.clone(),
        }];
        for axis in &self.axes {
            let mut next = Vec::with_capacity(cases.len() * axis.members.len());
            for case in &cases {
                for (m, member) in axis.members.iter().enumerate() {
                    let mut c = case.clone();
                    c.members.push(m);
                    c.labels.push(member.label.clone());
                    c.set.extend(member.set.iter().cloned());
                    next.push(c);
                }
            }
            cases = next;
        }
        for c in &mut cases {
            let shown: Vec<&str> = c
                .labels
                .iter()
                .map(String::as_str)
                .filter(|l| *l != "control")
                .collect();
            c.name = if shown.is_empty() {
                "control".into()
            } else {
                shown.join(".")
            };
        }
        cases
    }

    /// The case's scenario: the base with the case's keys set (the title as the base's).
    pub fn case_scenario(&self, case: &Case) -> Result<toml::Table, StudyError> {
        let mut doc = self.base.clone();
        for (key, value) in &case.set {
            set_dotted(&mut doc, key, value.clone()).map_err(|message| StudyError::Case {
                case: case.name.clone(),
                message,
            })?;
        }
        Ok(doc)
    }

    /// The scenario document of a case.
    pub fn case_document(&self, case: &Case) -> Result<String, StudyError> {
        let mut doc = self.case_scenario(case)?;
        let title = doc
            .get("title")
            .and_then(Value::as_str)
            .unwrap_or("cellmech case")
            .to_string();
        doc.insert(
            "title".into(),
            Value::String(format!("{title} [{}]", case.name)),
        );
        let header = format!(
            "# Case `{}` of the study \"{}\" ({}), base {}.\n# Re-run it alone with `cellmech run case.toml`.\n",
            case.name, self.title, self.origin, self.base_origin
        );
        let body = toml::to_string(&doc).map_err(|e| StudyError::Case {
            case: case.name.clone(),
            message: e.to_string(),
        })?;
        Ok(header + &body)
    }

    /// The index of the case that `case` is compared with: the control on every compared
    /// axis, the same member on the others.
    pub fn control_of(&self, cases: &[Case], case: &Case) -> Option<usize> {
        let wanted: Vec<usize> = self
            .axes
            .iter()
            .zip(&case.members)
            .map(|(a, &m)| if a.compared { 0 } else { m })
            .collect();
        cases.iter().position(|c| c.members == wanted)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn study(axes: &str) -> Result<StudySpec, StudyError> {
        parse(
            &format!("title = \"t\"\nbase = \"suspended-tension\"\n{axes}"),
            "test",
            Path::new("."),
        )
    }

    #[test]
    fn a_cross_product_compares_each_case_with_its_own_control() {
        let spec = study(
            "[[axis]]\nkind = \"cases\"\n[[axis.case]]\nname = \"a\"\n[[axis.case]]\nname = \"b\"\nset = { \"cell.seed\" = 7 }\n\
             [[axis]]\nkind = \"disruption\"\nfamilies = [\"actin\", \"microtubule\"]\n",
        )
        .unwrap();
        let cases = spec.cases();
        let names: Vec<&str> = cases.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "a",
                "a.no-actin",
                "a.no-microtubule",
                "a.no-actin-microtubule",
                "b",
                "b.no-actin",
                "b.no-microtubule",
                "b.no-actin-microtubule"
            ]
        );
        // The disruption axis is compared, the cases axis is context.
        let control = |name: &str| {
            let case = cases.iter().find(|c| c.name == name).unwrap();
            cases[spec.control_of(&cases, case).unwrap()].name.clone()
        };
        assert_eq!(control("b.no-actin-microtubule"), "b");
        assert_eq!(control("a.no-microtubule"), "a");
        assert_eq!(control("b"), "b");
        let b = cases.iter().find(|c| c.name == "b.no-actin").unwrap();
        assert!(b
            .set
            .iter()
            .any(|(k, v)| k == "cell.seed" && v.as_integer() == Some(7)));
        assert!(b
            .set
            .iter()
            .any(|(k, v)| k == "families.actin.enabled" && v.as_bool() == Some(false)));
    }

    #[test]
    fn moduli_are_factors_of_the_base_value_with_its_unit() {
        let spec = study(
            "[set]\n\"cell.cytoplasm.shear_modulus\" = \"0.2 kPa\"\n\
             [[axis]]\nkind = \"modulus\"\ncomponents = [\"cytoplasm\", \"actin\"]\nfactors = [0.5]\n",
        )
        .unwrap();
        let cases = spec.cases();
        assert_eq!(cases.len(), 3);
        let set = |name: &str| cases.iter().find(|c| c.name == name).unwrap().set.clone();
        assert!(set("cytoplasm-x0p5")
            .iter()
            .any(|(k, v)| k == "cell.cytoplasm.shear_modulus" && v.as_str() == Some("0.1 kPa")));
        assert!(set("actin-x0p5")
            .iter()
            .any(|(k, v)| k == "families.actin.modulus_scale" && v.as_float() == Some(0.5)));
    }

    #[test]
    fn bad_axes_are_rejected_with_the_key() {
        let err = |axes: &str| study(axes).unwrap_err().to_string();
        assert!(err("[[axis]]\nkind = \"disruption\"\nfactors = [2.0]\n").contains("`factors`"));
        assert!(err("[[axis]]\nkind = \"bogus\"\n").contains("disruption"));
        assert!(err("[[axis]]\nkind = \"modulus\"\nfactors = [0.0]\n").contains("factors"));
        assert!(err("[[axis]]\nkind = \"grid\"\nvalues = [1]\n").contains("parameter"));
        assert!(
            err("[[axis]]\nkind = \"compressibility\"\npoisson_ratio = 0.7\n")
                .contains("poisson_ratio")
        );
    }

    #[test]
    fn a_named_list_of_subsets_gives_those_removals_in_order() {
        let spec = study(
            "[[axis]]\nkind = \"disruption\"\nfamilies = [\"actin\", \"microtubule\", \"intermediate\"]\n\
             subsets = [[\"microtubule\"], [\"intermediate\", \"actin\"], [\"actin\", \"microtubule\", \"intermediate\"]]\n",
        )
        .unwrap();
        let cases = spec.cases();
        let names: Vec<&str> = cases.iter().map(|c| c.name.as_str()).collect();
        // Listed order; names inside an entry in the order of `families`.
        assert_eq!(
            names,
            [
                "control",
                "no-microtubule",
                "no-actin-intermediate",
                "no-actin-microtubule-intermediate"
            ]
        );
        let removed = |name: &str| -> Vec<String> {
            let case = cases.iter().find(|c| c.name == name).unwrap();
            case.set
                .iter()
                .filter(|(k, v)| k.ends_with(".enabled") && v.as_bool() == Some(false))
                .map(|(k, _)| k.clone())
                .collect()
        };
        assert_eq!(
            removed("no-actin-intermediate"),
            ["families.actin.enabled", "families.intermediate.enabled"]
        );
        assert_eq!(removed("no-microtubule"), ["families.microtubule.enabled"]);
        assert!(removed("control").is_empty());
        // Every case is compared with the control.
        for c in &cases {
            assert_eq!(spec.control_of(&cases, c), Some(0));
        }
    }

    #[test]
    fn bad_subsets_are_rejected_naming_the_key_and_the_entry() {
        let err = |subsets: &str| {
            study(&format!(
                "[[axis]]\nkind = \"disruption\"\nfamilies = [\"actin\", \"microtubule\"]\nsubsets = {subsets}\n"
            ))
            .unwrap_err()
            .to_string()
        };
        let e = err("[[\"actin\"], [\"cortex\"]]");
        assert!(
            e.contains("`subsets[1]`") && e.contains("\"cortex\"") && e.contains("`families`"),
            "{e}"
        );
        let e = err("[[\"actin\"], []]");
        assert!(
            e.contains("`subsets[1]`") && e.contains("at least one"),
            "{e}"
        );
        let e = err("[]");
        assert!(e.contains("`subsets`"), "{e}");
        let e = err("[[\"actin\", \"actin\"]]");
        assert!(e.contains("`subsets[0]`") && e.contains("twice"), "{e}");
        let e = err("[[\"microtubule\", \"actin\"], [\"actin\", \"microtubule\"]]");
        assert!(
            e.contains("`subsets[1]`") && e.contains("`subsets[0]`"),
            "{e}"
        );
        let e = err("[\"actin\"]");
        assert!(e.contains("subsets"), "{e}");
        // Only a disruption axis takes subsets.
        let e = study("[[axis]]\nkind = \"modulus\"\nsubsets = [[\"actin\"]]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`subsets`") && e.contains("modulus"), "{e}");
        // The error names the study file.
        assert!(e.starts_with("test: axis[0]"), "{e}");
    }

    #[test]
    fn the_adherent_cell_has_its_own_families_and_moduli() {
        let spec = parse(
            "title = \"t\"\nbase = \"adherent-afm-apex\"\n\
             [[axis]]\nkind = \"modulus\"\n[[axis]]\nkind = \"disruption\"\nsubsets = [[\"cortex\"]]\n\
             [[axis]]\nkind = \"thickness\"\nfactors = [2.0]\n",
            "test",
            Path::new("."),
        )
        .unwrap();
        let labels: Vec<&str> = spec.axes[0]
            .members
            .iter()
            .map(|m| m.label.as_str())
            .collect();
        assert_eq!(labels.len(), 13);
        for c in [
            "cytoplasm",
            "nucleus",
            "cortex",
            "bundles",
            "microtubule",
            "intermediate",
        ] {
            assert!(labels.contains(&format!("{c}-x0p5").as_str()), "{labels:?}");
        }
        let set = &spec.axes[0].members[1].set;
        assert_eq!(
            spec.axes[0].members[1].scaled,
            Some(("cytoplasm".into(), 0.5))
        );
        assert_eq!(set[0].0, "cell.cytoplasm.shear_modulus");
        assert_eq!(set[0].1.as_str(), Some("0.085 kPa"));
        assert_eq!(spec.axes[1].members[1].label, "no-cortex");
        assert_eq!(spec.axes[2].members[1].set[0].0, "cell.cortex.thickness");
        assert_eq!(spec.axes[2].members[1].set[0].1.as_str(), Some("0.4 um"));
        // The default disruption families of the adherent cell.
        let spec = parse(
            "base = \"adherent-afm-apex\"\n[[axis]]\nkind = \"disruption\"\n",
            "test",
            Path::new("."),
        )
        .unwrap();
        assert_eq!(spec.axes[0].members.len(), 16);
        assert_eq!(spec.axes[0].members[2].label, "no-bundles");
    }

    #[test]
    fn a_density_axis_adds_each_family_s_extra_filaments_one_at_a_time() {
        let spec = study(
            "[[axis]]\nkind = \"density\"\nfamilies = [\"actin\", \"microtubule\"]\ncounts = [10, 30]\n",
        )
        .unwrap();
        assert!(spec.axes[0].compared);
        let cases = spec.cases();
        let names: Vec<&str> = cases.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "control",
                "extra-actin-10",
                "extra-actin-30",
                "extra-microtubule-10",
                "extra-microtubule-30"
            ]
        );
        let set = |name: &str| cases.iter().find(|c| c.name == name).unwrap().set.clone();
        assert!(set("control").is_empty());
        assert_eq!(
            set("extra-microtubule-30"),
            [(
                "cell.density.extra_microtubules".to_string(),
                Value::Integer(30)
            )]
        );
        assert_eq!(
            set("extra-actin-10"),
            [("cell.density.extra_actin".to_string(), Value::Integer(10))]
        );
        for c in &cases {
            assert_eq!(cases[spec.control_of(&cases, c).unwrap()].name, "control");
            // Every case is a scenario the parser accepts.
            let doc = spec.case_document(c).unwrap();
            crate::scenario::parse(&doc, "case", Path::new("."))
                .unwrap_or_else(|e| panic!("{}: {e}", c.name));
        }
        // Defaults: the three families, 30 extra each.
        let spec = study("[[axis]]\nkind = \"density\"\n").unwrap();
        let names: Vec<String> = spec.cases().into_iter().map(|c| c.name).collect();
        assert_eq!(
            names,
            [
                "control",
                "extra-actin-30",
                "extra-microtubule-30",
                "extra-intermediate-30"
            ]
        );
        // The adherent cell's bundles have their own key.
        let spec = parse(
            "base = \"adherent-afm-apex\"\n[[axis]]\nkind = \"density\"\nfamilies = [\"bundles\"]\ncounts = [8]\n",
            "test",
            Path::new("."),
        )
        .unwrap();
        let cases = spec.cases();
        assert_eq!(cases[1].name, "extra-bundles-8");
        assert_eq!(
            cases[1].set,
            [("cell.bundles.extra".to_string(), Value::Integer(8))]
        );
        // Its default families: ABs, MTs and IFs, each with its own `extra` key; the
        // suspended cell's `actin` is not one of them.
        let spec = parse(
            "base = \"adherent-afm-apex\"\n[[axis]]\nkind = \"density\"\ncounts = [16]\n",
            "test",
            Path::new("."),
        )
        .unwrap();
        let sets: Vec<_> = spec.cases().into_iter().skip(1).map(|c| c.set).collect();
        assert_eq!(
            sets,
            [
                "cell.bundles.extra",
                "cell.microtubules.extra",
                "cell.intermediate.extra"
            ]
            .map(|k| vec![(k.to_string(), Value::Integer(16))])
        );
        let e = parse(
            "base = \"adherent-afm-apex\"\n[[axis]]\nkind = \"density\"\nfamilies = [\"actin\"]\n",
            "test",
            Path::new("."),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("\"bundles\", \"microtubule\", \"intermediate\""),
            "{e}"
        );
    }

    #[test]
    fn bad_density_axes_are_rejected_with_the_key() {
        let err = |axes: &str| study(axes).unwrap_err().to_string();
        let e = err("[[axis]]\nkind = \"density\"\nfamilies = [\"membrane\"]\n");
        assert!(e.contains("`families`") && e.contains("membrane"), "{e}");
        let e = err("[[axis]]\nkind = \"density\"\ncounts = [0]\n");
        assert!(e.contains("`counts`"), "{e}");
        let e = err("[[axis]]\nkind = \"density\"\ncounts = [-5]\n");
        assert!(e.contains("`counts`"), "{e}");
        let e = err("[[axis]]\nkind = \"density\"\ncounts = []\n");
        assert!(e.contains("`counts`"), "{e}");
        let e = err("[[axis]]\nkind = \"density\"\nfactors = [2.0]\n");
        assert!(e.contains("`factors`"), "{e}");
        let e = err("[[axis]]\nkind = \"modulus\"\ncounts = [3]\n");
        assert!(e.contains("`counts`"), "{e}");
        let e = err("[[axis]]\nkind = \"density\"\nfamilies = [\"actin\", \"actin\"]\n");
        assert!(e.contains("extra-actin-30"), "{e}");
    }

    #[test]
    fn shards_split_the_cases_exactly_once() {
        let spec = study("[[axis]]\nkind = \"modulus\"\n").unwrap();
        let cases = spec.cases();
        for n in 1..5 {
            let mut seen = vec![0; cases.len()];
            for k in 0..n {
                for (i, c) in cases.iter().enumerate() {
                    if super::super::run::shard_of(&c.name, n) == k {
                        seen[i] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&s| s == 1));
        }
    }
}
