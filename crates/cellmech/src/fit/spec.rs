//! The fit file: an experiment (a base scenario and keys set in it, as in a study), a
//! measured curve, the parameters to fit with their bounds, and the optimiser's settings.
//!
//! ```toml
//! title = "Cytoplasm and membrane moduli from a tensile curve"
//! base = "suspended-tension"            # built-in example or scenario file (relative path)
//! data = "tension-curve.csv"            # measured curve; header with units
//! # columns = ["displacement", "force"] # measured columns (default: the first two)
//! # simulated = ["elongation_um", "force_nN"]  # protocol CSV columns (default per protocol)
//! range = ["0.5 um", "6.3 um"]          # optional: the x range fitted
//! residual = "absolute"                 # or "relative" (each residual / |measured|)
//!
//! [set]                                 # optional: dotted scenario keys set in every run
//! "cell.core_divisions" = 4
//!
//! [[parameter]]
//! key = "cell.cytoplasm.shear_modulus"
//! start = "0.25 kPa"
//! lower = "0.01 kPa"
//! upper = "10 kPa"
//! # scale = "log"                       # default: log when lower > 0, else linear
//!
//! [optimizer]                           # optional
//! max_runs = 60                         # FE runs (cached ones included)
//! ```

use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Value;

use super::curve::{read_measured, Curve};
use super::lm::LmSettings;
use super::FitError;
use crate::study::spec::set_dotted;
use crate::study::{Case, StudySpec};
use crate::units::{find_unit, format_quantity, parse_quantity, Dimension};

/// How a parameter is seen by the optimiser.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Scale {
    /// The optimiser works on ln(value): relative steps, positive values.
    Log,
    /// The optimiser works on the value itself.
    Linear,
}

/// Residuals: the simulated minus the measured value, or that over |measured|.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Residual {
    /// `f_sim(xᵢ) − f_meas,ᵢ` (in the y column's internal unit).
    Absolute,
    /// `(f_sim(xᵢ) − f_meas,ᵢ) / max(|f_meas,ᵢ|, 1e-3 max|f_meas|)`.
    Relative,
}

/// One fitted parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct FitParameter {
    /// Dotted scenario key (`cell.cytoplasm.shear_modulus`).
    pub key: String,
    /// Its dimension (from the unit of `start`).
    pub dimension: Dimension,
    /// Start, lower and upper bound (internal units).
    pub start: f64,
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
    /// How the optimiser sees it.
    pub scale: Scale,
}

impl FitParameter {
    /// The optimiser's variable for `value`.
    pub fn to_variable(&self, value: f64) -> f64 {
        match self.scale {
            Scale::Log => value.ln(),
            Scale::Linear => value,
        }
    }

    /// The value of the optimiser's variable `v`.
    pub fn to_value(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Log => v.exp(),
            Scale::Linear => v,
        }
    }

    /// d value / d variable at `value` (the delta method's factor).
    pub fn derivative(&self, value: f64) -> f64 {
        match self.scale {
            Scale::Log => value,
            Scale::Linear => 1.0,
        }
    }

    /// The value as written into a scenario: a quantity with the internal unit (exact:
    /// shortest round-trip formatting), or a bare number for a pure number.
    pub fn toml_value(&self, value: f64) -> Value {
        match self.dimension {
            Dimension::Dimensionless => Value::Float(value),
            d => Value::String(format_quantity(value, d)),
        }
    }

    /// The internal unit, for reports.
    pub fn unit(&self) -> &'static str {
        self.dimension.internal_unit()
    }
}

/// A parsed fit.
#[derive(Debug, Clone)]
pub struct FitSpec {
    /// Title.
    pub title: String,
    /// Where the fit came from (a file or `<string>`).
    pub origin: String,
    /// The fit file's text, as given.
    pub text: String,
    /// The experiment: the base scenario and the keys set in every run (no axes).
    pub experiment: StudySpec,
    /// Protocol kind of the experiment (`micropipette-tension`, …).
    pub protocol: String,
    /// The measured curve (internal units).
    pub data: Curve,
    /// Path of the measured curve.
    pub data_path: PathBuf,
    /// File of the run's curve (`tension.csv`, `compression.csv`, `indentation.csv`).
    pub simulated_file: String,
    /// Its x and y columns.
    pub simulated: [String; 2],
    /// Fitted x range (internal units), inclusive.
    pub range: Option<[f64; 2]>,
    /// Residual kind.
    pub residual: Residual,
    /// The parameters.
    pub parameters: Vec<FitParameter>,
    /// Optimiser settings (`max_evaluations` is `max_runs`).
    pub optimizer: LmSettings,
    /// Relative finite-difference step in the optimiser's variables.
    pub fd_step: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FitFile {
    title: Option<String>,
    base: String,
    data: String,
    columns: Option<[String; 2]>,
    simulated: Option<[String; 2]>,
    range: Option<[Value; 2]>,
    residual: Option<String>,
    #[serde(default)]
    set: toml::Table,
    #[serde(default)]
    parameter: Vec<ParameterSection>,
    #[serde(default)]
    optimizer: OptimizerSection,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParameterSection {
    key: String,
    start: Value,
    lower: Value,
    upper: Value,
    scale: Option<String>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct OptimizerSection {
    max_runs: Option<usize>,
    max_iterations: Option<usize>,
    fd_step: Option<f64>,
    cost_tolerance: Option<f64>,
    step_tolerance: Option<f64>,
}

/// The protocols a fit accepts, their curve file and default columns.
pub const PROTOCOL_CURVES: [(&str, &str, &str); 3] = [
    ("micropipette-tension", "tension.csv", "elongation_um"),
    (
        "microplate-compression",
        "compression.csv",
        "plate_travel_um",
    ),
    ("afm-indentation", "indentation.csv", "indentation_um"),
];

/// Reads a fit file (relative `base` and `data` paths are relative to it).
pub fn load(path: &Path) -> Result<FitSpec, FitError> {
    let text = std::fs::read_to_string(path).map_err(|e| FitError::Invalid {
        path: path.display().to_string(),
        message: format!("cannot read: {e}"),
    })?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    parse(&text, &path.display().to_string(), &dir)
}

/// A quantity given as a string with a unit, or a bare number for a pure number.
fn quantity(v: &Value, dim: Option<Dimension>) -> Result<(f64, Dimension), String> {
    match (v, dim) {
        (Value::String(s), Some(d)) => parse_quantity(s, d)
            .map(|x| (x, d))
            .map_err(|e| e.to_string()),
        (Value::String(s), None) => {
            let unit = s.trim_start_matches(|c: char| c.is_ascii_digit() || "+-.eE ".contains(c));
            let d = if unit.trim().is_empty() {
                Dimension::Dimensionless
            } else {
                find_unit(unit.trim()).map(|u| u.dimension).ok_or_else(|| {
                    format!("expected a quantity with a unit such as \"0.2 kPa\"; found \"{s}\"")
                })?
            };
            parse_quantity(s, d)
                .map(|x| (x, d))
                .map_err(|e| e.to_string())
        }
        (Value::Integer(i), None | Some(Dimension::Dimensionless)) => {
            Ok((*i as f64, Dimension::Dimensionless))
        }
        (Value::Float(f), None | Some(Dimension::Dimensionless)) => {
            Ok((*f, Dimension::Dimensionless))
        }
        (other, Some(d)) => Err(format!(
            "expected a {} with its unit such as \"{}\"; found {other}",
            d.name(),
            d.example()
        )),
        (other, None) => Err(format!(
            "expected a quantity such as \"0.2 kPa\"; found {other}"
        )),
    }
}

/// Parses fit text (`origin` names it in messages; `dir` anchors relative paths).
pub fn parse(text: &str, origin: &str, dir: &Path) -> Result<FitSpec, FitError> {
    parse_with(text, origin, dir, true)
}

/// [`parse`]; with `need_data = false` a missing measured file is an empty curve (to make
/// a synthetic one with [`super::synthetic`]).
pub fn parse_with(
    text: &str,
    origin: &str,
    dir: &Path,
    need_data: bool,
) -> Result<FitSpec, FitError> {
    let invalid = |message: String| FitError::Invalid {
        path: origin.into(),
        message,
    };
    let file: FitFile = toml::from_str(text).map_err(|e| invalid(e.to_string()))?;
    let title = file
        .title
        .clone()
        .unwrap_or_else(|| format!("fit of {} to {}", file.base, file.data));
    // The experiment is a study without axes: the same base resolution and `[set]` keys.
    let mut study = toml::Table::new();
    study.insert("title".into(), Value::String(title.clone()));
    study.insert("base".into(), Value::String(file.base.clone()));
    study.insert("set".into(), Value::Table(file.set.clone()));
    let study_text = toml::to_string(&study).map_err(|e| invalid(e.to_string()))?;
    let experiment = crate::study::spec::parse(&study_text, origin, dir)?;
    let mut resolved = experiment.base.clone();
    for (k, v) in &experiment.set {
        set_dotted(&mut resolved, k, v.clone()).map_err(&invalid)?;
    }
    let protocol = resolved
        .get("protocol")
        .and_then(|p| p.get("kind"))
        .and_then(Value::as_str)
        .unwrap_or("")
        .to_string();
    let (_, simulated_file, x_column) = PROTOCOL_CURVES
        .iter()
        .find(|(k, _, _)| *k == protocol)
        .ok_or_else(|| {
            invalid(format!(
                "`base`: expected an experiment with a [protocol] of kind {}; found {}",
                PROTOCOL_CURVES
                    .map(|(k, _, _)| format!("\"{k}\""))
                    .join(", "),
                if protocol.is_empty() {
                    "none".to_string()
                } else {
                    format!("\"{protocol}\"")
                }
            ))
        })?;
    let simulated = file
        .simulated
        .clone()
        .unwrap_or_else(|| [x_column.to_string(), "force_nN".to_string()]);
    let data_path = dir.join(&file.data);
    let data = if need_data || data_path.exists() {
        read_measured(&data_path, file.columns.as_ref())
            .map_err(|e| invalid(format!("`data`: {e}")))?
    } else {
        Curve::empty(&simulated[0], &simulated[1])
    };
    for (k, (name, dim)) in [(&simulated[0], data.x_dim), (&simulated[1], data.y_dim)]
        .into_iter()
        .enumerate()
    {
        let sim = super::curve::column_dimension(name);
        if sim != dim {
            return Err(invalid(format!(
                "`simulated`: the run's column `{name}` is a {}, but the measured column \"{}\" is a {}",
                sim.name(),
                if k == 0 { &data.x_name } else { &data.y_name },
                dim.name()
            )));
        }
    }
    let range = match &file.range {
        None => None,
        Some([a, b]) => {
            let a = quantity(a, Some(data.x_dim))
                .map_err(|e| invalid(format!("`range`: {e}")))?
                .0;
            let b = quantity(b, Some(data.x_dim))
                .map_err(|e| invalid(format!("`range`: {e}")))?
                .0;
            if !(a < b) {
                return Err(invalid(format!(
                    "`range`: expected [from, to] with from < to; found [{a}, {b}]"
                )));
            }
            Some([a, b])
        }
    };
    let residual = match file.residual.as_deref() {
        None | Some("absolute") => Residual::Absolute,
        Some("relative") => Residual::Relative,
        Some(other) => {
            return Err(invalid(format!(
                "`residual`: expected \"absolute\" or \"relative\"; found \"{other}\""
            )))
        }
    };
    if file.parameter.is_empty() {
        return Err(invalid(
            "expected at least one [[parameter]] with key, start, lower, upper; found none".into(),
        ));
    }
    let mut parameters = Vec::new();
    for (i, p) in file.parameter.iter().enumerate() {
        let at = |m: String| invalid(format!("parameter[{i}] `{}`: {m}", p.key));
        if parameters.iter().any(|q: &FitParameter| q.key == p.key) {
            return Err(at("expected each key once; found it twice".into()));
        }
        let (start, dimension) =
            quantity(&p.start, None).map_err(|e| at(format!("`start`: {e}")))?;
        let lower = quantity(&p.lower, Some(dimension))
            .map_err(|e| at(format!("`lower`: {e}")))?
            .0;
        let upper = quantity(&p.upper, Some(dimension))
            .map_err(|e| at(format!("`upper`: {e}")))?
            .0;
        if !(lower < upper && lower <= start && start <= upper) {
            return Err(at(format!(
                "expected lower < upper and lower ≤ start ≤ upper; found {lower} ≤ {start} ≤ {upper} ({})",
                dimension.internal_unit()
            )));
        }
        let scale = match p.scale.as_deref() {
            None if lower > 0.0 => Scale::Log,
            None => Scale::Linear,
            Some("log") if lower > 0.0 => Scale::Log,
            Some("log") => {
                return Err(at(format!(
                    "`scale = \"log\"` needs a positive lower bound; found {lower}"
                )))
            }
            Some("linear") => Scale::Linear,
            Some(other) => {
                return Err(at(format!(
                    "`scale`: expected \"log\" or \"linear\"; found \"{other}\""
                )))
            }
        };
        parameters.push(FitParameter {
            key: p.key.clone(),
            dimension,
            start,
            lower,
            upper,
            scale,
        });
    }
    let o = &file.optimizer;
    let defaults = LmSettings::default();
    let optimizer = LmSettings {
        max_evaluations: o.max_runs.unwrap_or(defaults.max_evaluations),
        max_iterations: o.max_iterations.unwrap_or(defaults.max_iterations),
        cost_tolerance: o.cost_tolerance.unwrap_or(defaults.cost_tolerance),
        step_tolerance: o.step_tolerance.unwrap_or(defaults.step_tolerance),
        initial_damping: defaults.initial_damping,
    };
    let fd_step = o.fd_step.unwrap_or(DEFAULT_FD_STEP);
    if !(fd_step > 0.0 && fd_step < 0.5) {
        return Err(invalid(format!(
            "`optimizer.fd_step`: expected 0 < step < 0.5; found {fd_step}"
        )));
    }
    if optimizer.max_evaluations <= parameters.len() || optimizer.max_iterations == 0 {
        return Err(invalid(format!(
            "`optimizer`: expected max_runs > the number of parameters ({}) and max_iterations ≥ 1; found {} and {}",
            parameters.len(),
            optimizer.max_evaluations,
            optimizer.max_iterations
        )));
    }
    let spec = FitSpec {
        title,
        origin: origin.into(),
        text: text.into(),
        experiment,
        protocol,
        data,
        data_path,
        simulated_file: simulated_file.to_string(),
        simulated,
        range,
        residual,
        parameters,
        optimizer,
        fd_step,
    };
    // Every parameter key is checked by the scenario parser, at the start and at both
    // corners of the box, before anything runs (unknown keys, wrong units, ranges).
    for (name, pick) in [("start", 0), ("lower", 1), ("upper", 2)] {
        let values: Vec<f64> = spec
            .parameters
            .iter()
            .map(|p| [p.start, p.lower, p.upper][pick])
            .collect();
        let mut case = spec.case(&values, "check");
        case.name = format!("parameters at {name}");
        crate::study::run::check_cases(&spec.experiment, &[case])?;
    }
    if let (true, Some([a, b])) = (need_data, spec.range) {
        if spec.fitted_points().len() < spec.parameters.len() + 1 {
            return Err(invalid(format!(
                "`range`: expected more measured points in [{a}, {b}] than parameters ({}); found {}",
                spec.parameters.len(),
                spec.fitted_points().len()
            )));
        }
    }
    Ok(spec)
}

/// Default relative finite-difference step (see `docs/fitting.md`, "Derivatives").
pub const DEFAULT_FD_STEP: f64 = 0.01;

impl FitSpec {
    /// The case (a study case without axes) that runs the experiment at `values`.
    pub fn case(&self, values: &[f64], name: &str) -> Case {
        let mut set = self.experiment.set.clone();
        for (p, v) in self.parameters.iter().zip(values) {
            set.push((p.key.clone(), p.toml_value(*v)));
        }
        Case {
            name: name.into(),
            members: Vec::new(),
            labels: Vec::new(),
            set,
        }
    }

    /// The scenario document of the run at `values` with every key set (the cache key).
    pub fn document(&self, values: &[f64]) -> Result<String, FitError> {
        let case = self.case(values, "");
        let mut doc = self.experiment.base.clone();
        for (k, v) in &case.set {
            set_dotted(&mut doc, k, v.clone()).map_err(|message| FitError::Invalid {
                path: self.origin.clone(),
                message,
            })?;
        }
        toml::to_string(&doc).map_err(|e| FitError::Invalid {
            path: self.origin.clone(),
            message: e.to_string(),
        })
    }

    /// Indices of the measured points inside the range.
    pub fn fitted_points(&self) -> Vec<usize> {
        (0..self.data.x.len())
            .filter(|&i| {
                self.range
                    .is_none_or(|[a, b]| (a..=b).contains(&self.data.x[i]))
            })
            .collect()
    }
}
