//! `cellmech._cellmech`: the native part of the Python package `cellmech`.
//!
//! A thin layer over the library, like the CLI: scenario files and TOML text go through
//! `cellmech::scenario::{load, parse}` (the CLI's own path, so errors carry the CLI's
//! messages), keyword-built experiments are checked against the declared parameter tables
//! (`cellmech::param::read_section`) and then composed into scenario TOML that the same
//! parser resolves, and a run is `cellmech::run::run_with_threads` with the GIL released.
//! The Python part (`python/cellmech/__init__.py`) turns the raw results into numpy arrays.

use std::path::{Path, PathBuf};

use cellmech::analysis::Analysis as RustAnalysis;
use cellmech::param::{read_section, ParamTable};
use cellmech::run::RunError as RustRunError;
use cellmech::scenario::ScenarioError as RustScenarioError;
use cellmech_fem::solve::{IncrementReport, Observer, Problem};
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

create_exception!(
    cellmech,
    ScenarioError,
    PyValueError,
    "A scenario, a parameter or an experiment is invalid. The message is the CLI's: it names \
     the file (or `<cellmech.NAME>` for keyword input), the line where known, and the key."
);
create_exception!(
    cellmech,
    RunError,
    PyRuntimeError,
    "A run could not start or its outputs could not be written (building the model, writing \
     files, an internal error)."
);
create_exception!(
    cellmech,
    AnalysisError,
    RunError,
    "The analysis stopped early (no convergence). Raised by `run(..., check=True)` only; its \
     `result` attribute holds the `Result` with every converged increment."
);

/// An error and its sources, joined as the CLI prints them (`a: b: c`).
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        let text = cause.to_string();
        if !s.contains(&text) {
            s.push_str(": ");
            s.push_str(&text);
        }
        source = cause.source();
    }
    s
}

fn scenario_err(e: RustScenarioError) -> PyErr {
    ScenarioError::new_err(e.to_string())
}

/// A model ready to run: from a scenario file, TOML text or keyword arguments.
#[pyclass(module = "cellmech._cellmech", frozen, name = "NativeAnalysis")]
struct NativeAnalysis {
    inner: RustAnalysis,
    toml: Option<String>,
}

/// Forwards every converged increment to a Python callable, taking the GIL for the call.
struct PyProgress {
    callback: Option<Py<PyAny>>,
    error: Option<PyErr>,
}

impl Observer for PyProgress {
    fn on_increment(&mut self, _problem: &Problem, r: &IncrementReport<'_>) {
        let Some(callback) = &self.callback else {
            return;
        };
        if self.error.is_some() {
            return;
        }
        let outcome = Python::attach(|py| -> PyResult<()> {
            let info = PyDict::new(py);
            info.set_item("step", r.step_index)?;
            info.set_item("step_name", r.step_name)?;
            info.set_item("increment", r.increment)?;
            info.set_item("step_time", r.step_time)?;
            info.set_item("total_time", r.total_time)?;
            info.set_item("iterations", r.iterations)?;
            info.set_item("energy", r.energy)?;
            callback.call1(py, (info,))?;
            Ok(())
        });
        if let Err(e) = outcome {
            // The solver cannot be stopped from an observer: the run goes on without
            // further calls, and the error is raised when it returns.
            self.error = Some(e);
        }
    }
}

/// A column of a CSV file: numbers (empty fields are NaN) or words.
enum Column {
    Numbers(Vec<f64>),
    Words(Vec<String>),
}

impl<'py> IntoPyObject<'py> for Column {
    type Target = PyAny;
    type Output = Bound<'py, PyAny>;
    type Error = PyErr;
    fn into_pyobject(self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(match self {
            Column::Numbers(v) => v.into_pyobject(py)?.into_any(),
            Column::Words(v) => v.into_pyobject(py)?.into_any(),
        })
    }
}

/// Reads a CSV file written by the run into (header, columns). Numbers are written with
/// Rust's shortest round-trip form, so they read back bit for bit.
fn read_csv(path: &Path) -> Result<(Vec<String>, Vec<Column>), String> {
    let mut reader =
        csv::Reader::from_path(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| format!("{}: {e}", path.display()))?
        .iter()
        .map(str::to_string)
        .collect();
    let mut raw: Vec<Vec<String>> = vec![Vec::new(); header.len()];
    for record in reader.records() {
        let record = record.map_err(|e| format!("{}: {e}", path.display()))?;
        for (i, field) in record.iter().enumerate().take(header.len()) {
            raw[i].push(field.to_string());
        }
    }
    let columns = raw
        .into_iter()
        .map(|fields| {
            let numbers: Option<Vec<f64>> = fields
                .iter()
                .map(|f| {
                    if f.is_empty() {
                        Some(f64::NAN)
                    } else {
                        f.parse::<f64>().ok()
                    }
                })
                .collect();
            match numbers {
                Some(v) => Column::Numbers(v),
                None => Column::Words(fields),
            }
        })
        .collect();
    Ok((header, columns))
}

fn table_dict<'py>(
    py: Python<'py>,
    (header, columns): (Vec<String>, Vec<Column>),
) -> PyResult<Bound<'py, PyTuple>> {
    let names = PyList::new(py, header)?;
    let cols = PyList::empty(py);
    for c in columns {
        cols.append(c)?;
    }
    PyTuple::new(py, [names.into_any(), cols.into_any()])
}

#[pymethods]
impl NativeAnalysis {
    /// The scenario's title.
    #[getter]
    fn title(&self) -> &str {
        &self.inner.title
    }

    /// Where the analysis came from (a path, `<string>` or `<cellmech.experiment>`).
    #[getter]
    fn origin(&self) -> &str {
        &self.inner.origin
    }

    /// The names of the analysis steps, in order.
    #[getter]
    fn steps(&self) -> Vec<String> {
        self.inner
            .model
            .steps
            .iter()
            .map(|s| s.name.clone())
            .collect()
    }

    /// Number of nodes and elements of the model's mesh.
    #[getter]
    fn mesh_size(&self) -> (usize, usize) {
        (
            self.inner.model.mesh.num_nodes(),
            self.inner.model.mesh.num_elements(),
        )
    }

    /// The scenario TOML of a keyword-built experiment (`None` for a loaded file).
    #[getter]
    fn toml(&self) -> Option<&str> {
        self.toml.as_deref()
    }

    /// Runs the analysis into `out_dir` with the GIL released; calls `progress(info)` after
    /// every converged increment. Returns a dict of raw results (see `cellmech.Result`).
    #[pyo3(signature = (out_dir, progress=None, threads=0))]
    fn run<'py>(
        &self,
        py: Python<'py>,
        out_dir: PathBuf,
        progress: Option<Py<PyAny>>,
        threads: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        if let Some(p) = &progress {
            if !p.bind(py).is_callable() {
                return Err(PyTypeError::new_err("`progress` must be callable or None"));
            }
        }
        let mut observer = PyProgress {
            callback: progress,
            error: None,
        };
        let analysis = &self.inner;
        let dir = out_dir.clone();
        let outcome = py.detach(|| {
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                cellmech::run::run_with_threads(analysis, &dir, &mut observer, threads)
                    .map_err(Box::new)
            }))
        });
        if let Some(e) = observer.error.take() {
            return Err(e);
        }
        let (summary, error) = match outcome {
            Err(panic) => {
                let what = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "unknown".into());
                return Err(RunError::new_err(format!(
                    "running {}: internal error (please report it): {what}",
                    analysis.origin
                )));
            }
            Ok(Ok(summary)) => (summary, None),
            Ok(Err(e)) => match *e {
                RustRunError::Analysis { error, summary, .. } => {
                    (*summary, Some(format!("the analysis stopped: {error}")))
                }
                other => {
                    return Err(RunError::new_err(format!(
                        "running {}: {}",
                        analysis.origin,
                        chain(&other)
                    )))
                }
            },
        };
        let raw = PyDict::new(py);
        raw.set_item("status", &summary.status)?;
        raw.set_item("error", error)?;
        raw.set_item("out_dir", out_dir.clone())?;
        let json = serde_json::to_string(&summary)
            .map_err(|e| RunError::new_err(format!("cannot encode the summary: {e}")))?;
        raw.set_item("summary_json", json)?;
        let curve = read_csv(&out_dir.join("curve.csv")).map_err(RunError::new_err)?;
        raw.set_item("curve", table_dict(py, curve)?)?;
        let filaments_path = out_dir.join("filaments.csv");
        if summary.files.iter().any(|f| f == "filaments.csv") {
            let filaments = read_csv(&filaments_path).map_err(RunError::new_err)?;
            raw.set_item("filaments", table_dict(py, filaments)?)?;
        } else {
            raw.set_item("filaments", py.None())?;
        }
        Ok(raw)
    }

    fn __repr__(&self) -> String {
        format!(
            "<cellmech analysis {:?} from {}: {} steps>",
            self.inner.title,
            self.inner.origin,
            self.inner.model.steps.len()
        )
    }
}

/// Reads, parses and resolves a scenario file (relative mesh paths are relative to it).
#[pyfunction]
fn load(path: PathBuf) -> PyResult<NativeAnalysis> {
    let inner = cellmech::scenario::load(&path).map_err(scenario_err)?;
    Ok(NativeAnalysis { inner, toml: None })
}

/// Parses and resolves scenario text; `origin` names it in messages, `base_dir` anchors
/// relative mesh paths.
#[pyfunction]
#[pyo3(signature = (text, origin="<string>", base_dir=None))]
fn parse(text: &str, origin: &str, base_dir: Option<PathBuf>) -> PyResult<NativeAnalysis> {
    let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
    let inner = cellmech::scenario::parse(text, origin, &base).map_err(scenario_err)?;
    Ok(NativeAnalysis { inner, toml: None })
}

/// A Python value as a TOML value (`key` names it in errors).
fn to_toml(origin: &str, key: &str, v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_cow()?.into_owned()));
    }
    if v.is_instance_of::<PyInt>() {
        return Ok(toml::Value::Integer(v.extract().map_err(|_| {
            ScenarioError::new_err(format!("{origin}: `{key}`: the integer {v} is too large"))
        })?));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        return Ok(toml::Value::Table(dict_to_table(origin, key, d)?));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: PyResult<Vec<toml::Value>> = v
            .try_iter()?
            .map(|item| to_toml(origin, key, &item?))
            .collect();
        return Ok(toml::Value::Array(items?));
    }
    // numpy scalars and other numbers.
    if v.hasattr("__index__")? {
        if let Ok(i) = v.call_method0("__index__").and_then(|i| i.extract::<i64>()) {
            return Ok(toml::Value::Integer(i));
        }
    }
    if let Ok(x) = v.extract::<f64>() {
        return Ok(toml::Value::Float(x));
    }
    Err(ScenarioError::new_err(format!(
        "{origin}: `{key}`: expected a string with a unit (\"0.17 kPa\"), a number, a boolean, a list or a dict; found a {}",
        v.get_type().name()?
    )))
}

/// A dict with dotted (or `__`-separated) keys as a nested TOML table.
fn dict_to_table(origin: &str, prefix: &str, d: &Bound<'_, PyDict>) -> PyResult<toml::Table> {
    let mut out = toml::Table::new();
    for (k, v) in d.iter() {
        let key: String = k.extract().map_err(|_| {
            PyTypeError::new_err(format!("{origin}: `{prefix}`: keys must be strings"))
        })?;
        let dotted = key.replace("__", ".");
        let full = if prefix.is_empty() {
            dotted.clone()
        } else {
            format!("{prefix}.{dotted}")
        };
        let parts: Vec<&str> = dotted.split('.').collect();
        if parts.iter().any(|p| p.is_empty()) {
            return Err(ScenarioError::new_err(format!(
                "{origin}: `{full}`: a key has an empty part"
            )));
        }
        let value = to_toml(origin, &full, &v)?;
        insert(&mut out, &parts, value, &format!("{origin}: `{full}`"))?;
    }
    Ok(out)
}

fn insert(table: &mut toml::Table, parts: &[&str], value: toml::Value, full: &str) -> PyResult<()> {
    let (first, rest) = parts.split_first().expect("a key has at least one part");
    if rest.is_empty() {
        match (table.get_mut(*first), value) {
            (Some(toml::Value::Table(existing)), toml::Value::Table(new)) => {
                for (k, v) in new {
                    insert(existing, &[k.as_str()], v, full)?;
                }
            }
            (Some(_), _) => {
                return Err(ScenarioError::new_err(format!("{full}: given twice")));
            }
            (None, value) => {
                table.insert((*first).to_string(), value);
            }
        }
        return Ok(());
    }
    let entry = table
        .entry((*first).to_string())
        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
    match entry {
        toml::Value::Table(sub) => insert(sub, rest, value, full),
        _ => Err(ScenarioError::new_err(format!(
            "{full}: `{first}` is given both as a value and as a group of keys"
        ))),
    }
}

fn cell_table(model: &str) -> PyResult<&'static ParamTable> {
    match model {
        "suspended" => Ok(&cellmech::cell::suspended::params::SUSPENDED_CELL),
        "adherent" => Ok(&cellmech::cell::adherent::params::ADHERENT_CELL),
        other => Err(ScenarioError::new_err(format!(
            "`cell.model`: expected \"{}\"; found \"{other}\"",
            cellmech::scenario::cell::MODELS.join("\" or \"")
        ))),
    }
}

fn protocol_table(kind: &str) -> PyResult<&'static ParamTable> {
    cellmech::protocol::Protocol::table(kind).ok_or_else(|| {
        ScenarioError::new_err(format!(
            "`protocol.kind`: expected one of \"{}\"; found \"{kind}\"",
            cellmech::protocol::KINDS.join("\", \"")
        ))
    })
}

/// Checks `values` of one section against its declared table, as the scenario parser does.
fn check_section(
    origin: &str,
    table: &ParamTable,
    skip: &[&str],
    others: &[&ParamTable],
    section: toml::Table,
) -> PyResult<()> {
    let mut root = toml::Table::new();
    root.insert(table.section.to_string(), toml::Value::Table(section));
    let text = toml::to_string(&root)
        .map_err(|e| ScenarioError::new_err(format!("{origin}: cannot write TOML: {e}")))?;
    let parsed = toml::de::DeTable::parse(&text)
        .map_err(|e| ScenarioError::new_err(format!("{origin}: {e}")))?;
    read_section(parsed.get_ref(), table, skip, others).map_err(|e| {
        scenario_err(RustScenarioError::Invalid {
            path: origin.into(),
            line: None,
            key: e.key,
            message: e.message,
        })
    })?;
    Ok(())
}

/// Checks the parameters of a cell model (`"suspended"`, `"adherent"`) against its declared
/// table; returns them as a nested dict (dotted keys split). Raises `ScenarioError`.
#[pyfunction]
fn check_cell(py: Python<'_>, model: &str, params: &Bound<'_, PyDict>) -> PyResult<Py<PyAny>> {
    let table = cell_table(model)?;
    let origin = format!("<cellmech.{model}_cell>");
    let mut section = dict_to_table(&origin, "cell", params)?;
    if section.contains_key("model") {
        return Err(ScenarioError::new_err(format!(
            "{origin}: `cell.model`: given by the constructor (use suspended_cell or adherent_cell)"
        )));
    }
    check_section(&origin, table, &["model"], &[], section.clone())?;
    section.insert("model".into(), toml::Value::String(model.into()));
    toml_to_py(py, &toml::Value::Table(section))
}

/// Checks the parameters of a protocol of kind `kind` against its declared table.
#[pyfunction]
fn check_protocol(py: Python<'_>, kind: &str, params: &Bound<'_, PyDict>) -> PyResult<Py<PyAny>> {
    let table = protocol_table(kind)?;
    let origin = format!("<cellmech.{}>", kind.replace('-', "_"));
    let mut section = dict_to_table(&origin, "protocol", params)?;
    if section.contains_key("kind") {
        return Err(ScenarioError::new_err(format!(
            "{origin}: `protocol.kind`: given by the constructor"
        )));
    }
    check_section(
        &origin,
        table,
        &["kind"],
        &cellmech::protocol::TABLES,
        section.clone(),
    )?;
    section.insert("kind".into(), toml::Value::String(kind.into()));
    toml_to_py(py, &toml::Value::Table(section))
}

fn toml_to_py(py: Python<'_>, v: &toml::Value) -> PyResult<Py<PyAny>> {
    Ok(match v {
        toml::Value::String(s) => s.into_pyobject(py)?.into_any().unbind(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any().unbind(),
        toml::Value::Float(x) => x.into_pyobject(py)?.into_any().unbind(),
        toml::Value::Boolean(b) => b.into_pyobject(py)?.to_owned().into_any().unbind(),
        toml::Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any().unbind(),
        toml::Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(toml_to_py(py, item)?)?;
            }
            list.into_any().unbind()
        }
        toml::Value::Table(t) => {
            let dict = PyDict::new(py);
            for (k, item) in t {
                dict.set_item(k, toml_to_py(py, item)?)?;
            }
            dict.into_any().unbind()
        }
    })
}

/// The origin of a keyword-built experiment in messages.
const ORIGIN: &str = "<cellmech.experiment>";

/// Composes a scenario from a checked `[cell]` and `[protocol]` (nested dicts with `model`
/// and `kind`), an optional title and optional `[output]` and `[families]` sections, and
/// resolves it with the scenario parser (the CLI's path). The TOML is kept on the result.
#[pyfunction]
#[pyo3(signature = (cell, protocol, title=None, output=None, families=None))]
fn experiment(
    cell: &Bound<'_, PyDict>,
    protocol: &Bound<'_, PyDict>,
    title: Option<String>,
    output: Option<&Bound<'_, PyDict>>,
    families: Option<&Bound<'_, PyDict>>,
) -> PyResult<NativeAnalysis> {
    let mut root = toml::Table::new();
    let kind: String = protocol
        .get_item("kind")?
        .map(|k| k.extract())
        .transpose()?
        .unwrap_or_default();
    root.insert(
        "title".into(),
        toml::Value::String(title.unwrap_or_else(|| format!("cellmech experiment: {kind}"))),
    );
    root.insert(
        "cell".into(),
        toml::Value::Table(dict_to_table(ORIGIN, "cell", cell)?),
    );
    root.insert(
        "protocol".into(),
        toml::Value::Table(dict_to_table(ORIGIN, "protocol", protocol)?),
    );
    if let Some(families) = families {
        root.insert(
            "families".into(),
            toml::Value::Table(dict_to_table(ORIGIN, "families", families)?),
        );
    }
    if let Some(output) = output {
        root.insert(
            "output".into(),
            toml::Value::Table(dict_to_table(ORIGIN, "output", output)?),
        );
    }
    let text =
        toml::to_string(&root).map_err(|e| ScenarioError::new_err(format!("{ORIGIN}: {e}")))?;
    let inner = cellmech::scenario::parse(&text, ORIGIN, Path::new(".")).map_err(scenario_err)?;
    Ok(NativeAnalysis {
        inner,
        toml: Some(text),
    })
}

/// The declared parameters of a cell model or protocol (`"suspended-cell"`,
/// `"adherent-cell"`, `"micropipette-tension"`, ...) as commented TOML with every default,
/// as `cellmech params NAME --toml` prints them.
#[pyfunction]
fn parameters(name: &str) -> PyResult<String> {
    cellmech::experiment::parameter_tables()
        .into_iter()
        .find(|t| t.name == name)
        .map(|t| t.toml_template())
        .ok_or_else(|| {
            let names: Vec<&str> = cellmech::experiment::parameter_tables()
                .iter()
                .map(|t| t.name)
                .collect();
            PyValueError::new_err(format!(
                "no parameter table `{name}`; the tables are: {}",
                names.join(", ")
            ))
        })
}

/// Runs a fit (from a file when `text` is `None`, else from `text` with `origin` and
/// `base_dir`) with the GIL released; `progress(event)` after every FE run. Returns
/// `fit.json` as text.
fn run_fit_native(
    py: Python<'_>,
    spec: cellmech::fit::FitSpec,
    out_dir: PathBuf,
    progress: Option<Py<PyAny>>,
    threads: usize,
) -> PyResult<String> {
    use cellmech::fit::{FitError, FitOptions, RunEvent};
    if let Some(p) = &progress {
        if !p.bind(py).is_callable() {
            return Err(PyTypeError::new_err("`progress` must be callable or None"));
        }
    }
    let mut callback_error: Option<PyErr> = None;
    let options = FitOptions {
        out: out_dir,
        threads,
    };
    let outcome = py.detach(|| {
        let mut on_run = |e: &RunEvent| {
            let Some(callback) = &progress else {
                return;
            };
            if callback_error.is_some() {
                return;
            }
            let result = Python::attach(|py| -> PyResult<()> {
                let info = PyDict::new(py);
                info.set_item("evaluation", e.evaluation)?;
                info.set_item("values", e.values.clone())?;
                info.set_item("hash", &e.hash)?;
                info.set_item("cached", e.cached)?;
                info.set_item("status", &e.status)?;
                info.set_item("rejected", e.rejected.clone())?;
                info.set_item("rms", e.rms)?;
                info.set_item("wall_time_s", e.wall_time_s)?;
                callback.call1(py, (info,))?;
                Ok(())
            });
            if let Err(err) = result {
                callback_error = Some(err);
            }
        };
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            cellmech::fit::run_fit(&spec, &options, &mut on_run)
        }))
    });
    if let Some(e) = callback_error {
        return Err(e);
    }
    let outcome = match outcome {
        Err(_) => {
            return Err(RunError::new_err(format!(
                "fitting {}: internal error (please report it)",
                spec.origin
            )))
        }
        Ok(Err(e @ (FitError::Invalid { .. } | FitError::Experiment(_)))) => {
            return Err(ScenarioError::new_err(e.to_string()))
        }
        Ok(Err(e)) => return Err(RunError::new_err(chain(&e))),
        Ok(Ok(outcome)) => outcome,
    };
    serde_json::to_string(&outcome)
        .map_err(|e| RunError::new_err(format!("cannot encode the fit: {e}")))
}

/// Fits the parameters of a fit file (`cellmech fit FILE --out out_dir`); returns
/// `fit.json` as text.
#[pyfunction]
#[pyo3(signature = (path, out_dir, progress=None, threads=0))]
fn fit_file(
    py: Python<'_>,
    path: PathBuf,
    out_dir: PathBuf,
    progress: Option<Py<PyAny>>,
    threads: usize,
) -> PyResult<String> {
    let spec = cellmech::fit::load(&path).map_err(|e| ScenarioError::new_err(e.to_string()))?;
    run_fit_native(py, spec, out_dir, progress, threads)
}

/// The same from fit TOML text (`base_dir` anchors `base` and `data` paths).
#[pyfunction]
#[pyo3(signature = (text, out_dir, origin="<string>", base_dir=None, progress=None, threads=0))]
fn fit_text(
    py: Python<'_>,
    text: &str,
    out_dir: PathBuf,
    origin: &str,
    base_dir: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
    threads: usize,
) -> PyResult<String> {
    let dir = base_dir.unwrap_or_else(|| PathBuf::from("."));
    let spec = cellmech::fit::spec::parse(text, origin, &dir)
        .map_err(|e| ScenarioError::new_err(e.to_string()))?;
    run_fit_native(py, spec, out_dir, progress, threads)
}

/// The native module.
#[pymodule]
fn _cellmech(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("ScenarioError", py.get_type::<ScenarioError>())?;
    m.add("RunError", py.get_type::<RunError>())?;
    m.add("AnalysisError", py.get_type::<AnalysisError>())?;
    m.add_class::<NativeAnalysis>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(parse, m)?)?;
    m.add_function(wrap_pyfunction!(check_cell, m)?)?;
    m.add_function(wrap_pyfunction!(check_protocol, m)?)?;
    m.add_function(wrap_pyfunction!(experiment, m)?)?;
    m.add_function(wrap_pyfunction!(parameters, m)?)?;
    m.add_function(wrap_pyfunction!(fit_file, m)?)?;
    m.add_function(wrap_pyfunction!(fit_text, m)?)?;
    Ok(())
}
