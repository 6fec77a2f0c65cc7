//! Fitting model parameters to a measured curve (`cellmech fit FIT.toml`): which values
//! of declared parameters (moduli, prestrain, …) make the simulated force curve of an
//! experiment match a measured one. See `docs/fitting.md`.
//!
//! * [`spec`]: the fit file (experiment as in a study, measured curve, parameters, bounds);
//! * [`curve`]: reading the measured and simulated curves, interpolation;
//! * [`lm`]: the bounded Levenberg–Marquardt optimiser and the covariance;
//! * [`runs`]: FE runs cached by their parameter values (`OUT/runs/<hash>/`);
//! * [`report`]: `fit.json`, `fit-history.csv`, `fit.csv`, `fit.svg`/`fit.png`, `fit.md`.

pub mod curve;
pub mod lm;
pub mod report;
pub mod runs;
pub mod spec;
pub mod synthetic;

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

pub use runs::RunEvent;
pub use spec::{FitParameter, FitSpec, Residual, Scale};

use crate::study::StudyError;

/// A fit that cannot be read or run.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// The fit file (or its data) is not what is expected.
    #[error("{path}: {message}")]
    Invalid {
        /// File.
        path: String,
        /// What was expected and found, with the key.
        message: String,
    },
    /// The experiment (base, `[set]`, a parameter key) is rejected.
    #[error(transparent)]
    Experiment(#[from] StudyError),
    /// The optimiser could not proceed (the start run does not reach the range, …).
    #[error("{0}")]
    Optimizer(String),
    /// Writing or reading a run's files failed.
    #[error("{0}")]
    Output(String),
}

/// How to run a fit.
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Output directory (runs in `OUT/runs/`, the report in `OUT/`).
    pub out: PathBuf,
    /// Solver threads per FE run (0: all cores).
    pub threads: usize,
}

/// A fitted parameter with its uncertainty.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FittedParameter {
    /// Dotted scenario key.
    pub key: String,
    /// Internal unit of the values.
    pub unit: String,
    /// How the optimiser saw it.
    pub scale: Scale,
    /// Start value.
    pub start: f64,
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
    /// Fitted value.
    pub value: f64,
    /// Standard error (delta method through the scale); `None` when the data do not
    /// determine the parameters (singular JᵀJ, or no degrees of freedom).
    pub standard_error: Option<f64>,
    /// Whether the value is on a bound (its standard error is then not meaningful).
    pub at_bound: bool,
}

/// One iteration of the optimiser, in parameter values.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HistoryRow {
    /// Iteration (0: the start).
    pub iteration: usize,
    /// Evaluations (FE runs, cached or not) so far.
    pub evaluations: usize,
    /// Parameter values.
    pub values: Vec<f64>,
    /// Cost ½ Σ r².
    pub cost: f64,
    /// RMS residual.
    pub rms: f64,
    /// Damping λ.
    pub damping: f64,
    /// Whether the iteration's step was accepted.
    pub accepted: bool,
}

/// What a fit found: written to `fit.json`.
#[derive(Debug, Clone, Serialize)]
pub struct FitOutcome {
    /// Title.
    pub title: String,
    /// The fit file.
    pub origin: String,
    /// The measured curve's file.
    pub data: String,
    /// Protocol of the experiment.
    pub protocol: String,
    /// Simulated columns compared (x, y) and their units.
    pub simulated: [String; 2],
    /// Units of x and y (internal).
    pub units: [String; 2],
    /// Residual kind.
    pub residual: Residual,
    /// The fitted x range.
    pub range: Option<[f64; 2]>,
    /// The parameters.
    pub parameters: Vec<FittedParameter>,
    /// Correlation matrix of the estimates (`None` when not determined).
    pub correlation: Option<Vec<Vec<f64>>>,
    /// Covariance matrix in parameter units.
    pub covariance: Option<Vec<Vec<f64>>>,
    /// Measured points fitted.
    pub points: usize,
    /// Sum of squared residuals.
    pub ssr: f64,
    /// RMS residual (y unit, or a fraction with relative residuals).
    pub rms: f64,
    /// σ = √(SSR / (m − p)).
    pub sigma: Option<f64>,
    /// Coefficient of determination of the fitted points, 1 − SSR/SST (absolute residuals).
    pub r_squared: f64,
    /// Evaluations (FE runs needed by the optimiser, cached or not).
    pub evaluations: usize,
    /// FE runs solved in this invocation (the rest came from `OUT/runs/`).
    pub fe_runs_solved: usize,
    /// Optimiser iterations.
    pub iterations: usize,
    /// Why it stopped (`cost-change`, `step-size`, `gradient`, `no-progress`,
    /// `max-evaluations`, `max-iterations`).
    pub stop: lm::StopReason,
    /// Whether that is a convergence.
    pub converged: bool,
    /// Wall time of this invocation (s).
    pub wall_time_s: f64,
    /// The run at the fitted values (folder under `OUT/runs/`).
    pub best_run: String,
    /// Iteration history.
    pub history: Vec<HistoryRow>,
    /// Every evaluation in order.
    pub runs: Vec<RunEvent>,
    /// The measured curve (all points) and the fitted model at those x (`NaN` where the
    /// simulated curve does not reach).
    pub curve: FittedCurve,
    /// Files written (relative to the output directory).
    pub files: Vec<String>,
}

/// Measured against fitted curve.
#[derive(Debug, Clone, Serialize)]
pub struct FittedCurve {
    /// Measured x (internal units).
    pub x: Vec<f64>,
    /// Measured y.
    pub measured: Vec<f64>,
    /// Model at the fitted values, interpolated at x.
    pub fitted: Vec<f64>,
    /// Whether the point is inside the range (fitted).
    pub in_range: Vec<bool>,
    /// The model's own curve at the fitted values (x, y).
    pub model_x: Vec<f64>,
    /// The model's y.
    pub model_y: Vec<f64>,
    /// The model's curve at the start values (x, y).
    pub start_x: Vec<f64>,
    /// Its y.
    pub start_y: Vec<f64>,
}

/// Reads a fit file: see [`spec::load`].
pub fn load(path: &Path) -> Result<FitSpec, FitError> {
    spec::load(path)
}

/// Runs a fit: the optimiser over cached FE runs, then the report. `on_run` is told about
/// every evaluation (solved now or read from `OUT/runs/`).
pub fn run_fit(
    spec: &FitSpec,
    options: &FitOptions,
    on_run: &mut dyn FnMut(&RunEvent),
) -> Result<FitOutcome, FitError> {
    let start_time = Instant::now();
    let out = &options.out;
    std::fs::create_dir_all(out.join(runs::RUNS_DIR))
        .map_err(|e| FitError::Output(format!("{}: {e}", out.display())))?;
    cellmech_io::write_atomic(&out.join("fit.toml"), spec.text.as_bytes())
        .map_err(|e| FitError::Output(e.to_string()))?;
    let params = &spec.parameters;
    let x0: Vec<f64> = params.iter().map(|p| p.to_variable(p.start)).collect();
    // The start maps back to the start exactly (ln then exp may not), so the start run's
    // document says what the fit file says.
    let values_of = |x: &[f64]| -> Vec<f64> {
        params
            .iter()
            .zip(x)
            .zip(&x0)
            .map(|((p, v), v0)| {
                if v == v0 {
                    p.start
                } else {
                    p.to_value(*v).clamp(p.lower, p.upper)
                }
            })
            .collect()
    };
    let lower: Vec<f64> = params.iter().map(|p| p.to_variable(p.lower)).collect();
    let upper: Vec<f64> = params.iter().map(|p| p.to_variable(p.upper)).collect();
    // Log variables: an absolute step of fd_step is a relative change of the value.
    // Linear ones: fd_step of the start's magnitude (or of the box, for a start at 0).
    let steps: Vec<f64> = params
        .iter()
        .zip(&x0)
        .map(|(p, x)| match p.scale {
            Scale::Log => spec.fd_step,
            Scale::Linear => spec.fd_step * x.abs().max(1e-2 * (p.upper - p.lower)),
        })
        .collect();
    let mut cache = runs::RunCache::new(spec, out, options.threads, on_run);
    let mut model = |x: &[f64]| -> Result<lm::Evaluation, FitError> {
        Ok(cache.evaluate(&values_of(x))?.residuals)
    };
    let result = lm::minimize(&x0, &lower, &upper, &steps, &spec.optimizer, &mut model).map_err(
        |e| match e {
            lm::LmError::Model(e) => e,
            other => FitError::Optimizer(format!("{}: {other}", spec.origin)),
        },
    )?;
    // The curves at the fitted and start values (both cached: no FE run).
    let best = values_of(&result.x);
    cache.silent = true;
    let fitted_run = cache.evaluate(&best)?;
    let start_run = cache.evaluate(&values_of(&x0))?;
    let log = std::mem::take(&mut cache.log);
    let solved = cache.solved;
    let m = result.residuals.len();
    let n = params.len();
    let cov_x = lm::covariance(&result.jacobian, &result.residuals);
    // Delta method: value = g(x), cov_value = G cov_x G with G = diag(g'(x)).
    let g: Vec<f64> = params
        .iter()
        .zip(&best)
        .map(|(p, v)| p.derivative(*v))
        .collect();
    let covariance = cov_x.as_ref().map(|c| {
        (0..n)
            .map(|i| (0..n).map(|j| g[i] * c[(i, j)] * g[j]).collect())
            .collect::<Vec<Vec<f64>>>()
    });
    let correlation = cov_x.as_ref().map(|c| {
        let r = lm::correlation(c);
        (0..n)
            .map(|i| (0..n).map(|j| r[(i, j)]).collect())
            .collect()
    });
    let parameters = params
        .iter()
        .enumerate()
        .map(|(i, p)| FittedParameter {
            key: p.key.clone(),
            unit: p.unit().into(),
            scale: p.scale,
            start: p.start,
            lower: p.lower,
            upper: p.upper,
            value: best[i],
            standard_error: covariance.as_ref().map(|c| c[i][i].sqrt()),
            at_bound: result.x[i] <= lower[i] || result.x[i] >= upper[i],
        })
        .collect();
    let ssr: f64 = result.residuals.iter().map(|r| r * r).sum();
    let points = spec.fitted_points();
    let mean = points.iter().map(|&i| spec.data.y[i]).sum::<f64>() / points.len().max(1) as f64;
    let sst: f64 = points
        .iter()
        .map(|&i| (spec.data.y[i] - mean).powi(2))
        .sum();
    let abs_ssr: f64 = points
        .iter()
        .map(|&i| {
            fitted_run
                .curve
                .interpolate(spec.data.x[i])
                .map_or(f64::NAN, |f| (f - spec.data.y[i]).powi(2))
        })
        .sum();
    let rms_of = |cost: f64| (2.0 * cost / m.max(1) as f64).sqrt();
    let mut history = vec![HistoryRow {
        iteration: 0,
        evaluations: 1,
        values: values_of(&x0),
        cost: log
            .first()
            .and_then(|e| e.rms)
            .map_or(f64::NAN, |r| 0.5 * r * r * m as f64),
        rms: log.first().and_then(|e| e.rms).unwrap_or(f64::NAN),
        damping: spec.optimizer.initial_damping,
        accepted: true,
    }];
    history.extend(result.history.iter().map(|h| HistoryRow {
        iteration: h.iteration,
        evaluations: h.evaluations,
        values: values_of(&h.x),
        cost: h.cost,
        rms: rms_of(h.cost),
        damping: h.damping,
        accepted: h.accepted,
    }));
    let curve = FittedCurve {
        x: spec.data.x.clone(),
        measured: spec.data.y.clone(),
        fitted: spec
            .data
            .x
            .iter()
            .map(|&x| fitted_run.curve.interpolate(x).unwrap_or(f64::NAN))
            .collect(),
        in_range: (0..spec.data.x.len())
            .map(|i| points.contains(&i))
            .collect(),
        model_x: fitted_run.curve.x.clone(),
        model_y: fitted_run.curve.y.clone(),
        start_x: start_run.curve.x.clone(),
        start_y: start_run.curve.y.clone(),
    };
    let mut outcome = FitOutcome {
        title: spec.title.clone(),
        origin: spec.origin.clone(),
        data: spec.data_path.display().to_string(),
        protocol: spec.protocol.clone(),
        simulated: spec.simulated.clone(),
        units: [
            spec.data.x_dim.internal_unit().into(),
            spec.data.y_dim.internal_unit().into(),
        ],
        residual: spec.residual,
        range: spec.range,
        parameters,
        correlation,
        covariance,
        points: m,
        ssr,
        rms: rms_of(result.cost),
        sigma: (m > n).then(|| (ssr / (m - n) as f64).sqrt()),
        r_squared: if sst > 0.0 {
            1.0 - abs_ssr / sst
        } else {
            f64::NAN
        },
        evaluations: result.evaluations,
        fe_runs_solved: solved,
        iterations: result.history.len(),
        stop: result.stop,
        converged: result.stop.converged(),
        wall_time_s: 0.0,
        best_run: fitted_run
            .dir
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        history,
        runs: log,
        curve,
        files: Vec::new(),
    };
    outcome.wall_time_s = start_time.elapsed().as_secs_f64();
    outcome.files = report::write_report(&outcome, spec, out)?;
    Ok(outcome)
}
