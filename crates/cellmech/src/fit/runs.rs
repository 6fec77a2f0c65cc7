//! The FE runs of a fit, cached by their parameters: the run at parameter values `v` is
//! the case document with `v` set, run in `OUT/runs/<hash of that document>/` by the study
//! machinery (`study::run::run_case_in`), which writes `record.json` last and atomically.
//! A run with a record is never repeated, so an interrupted fit resumes where it stopped,
//! and a second fit of the same experiment reuses every run the two share.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::curve::{read_simulated, Curve};
use super::spec::{FitSpec, Residual};
use super::FitError;
use crate::study::run::{read_record, run_case_in, stable_hash};
use crate::study::CaseEvent;

/// Folder of the runs inside a fit's output directory.
pub const RUNS_DIR: &str = "runs";

/// One FE run of a fit, as reported to the caller and kept in the log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunEvent {
    /// 1-based evaluation number in this fit (cached runs included).
    pub evaluation: usize,
    /// Parameter values (internal units, in the order of the fit file).
    pub values: Vec<f64>,
    /// Folder name under `OUT/runs/`.
    pub hash: String,
    /// Whether the run was already recorded (no FE solve now).
    pub cached: bool,
    /// `completed` or `failed` (the analysis stopped early).
    pub status: String,
    /// Why the point cannot be used (a failed run that does not reach the range), if so.
    pub rejected: Option<String>,
    /// RMS of the residuals, when the point could be used.
    pub rms: Option<f64>,
    /// Wall time of the FE run when it ran (s; the recorded time for a cached run).
    pub wall_time_s: f64,
}

/// Runs the experiment at given parameter values, or reads the recorded run.
pub struct RunCache<'a> {
    spec: &'a FitSpec,
    dir: PathBuf,
    threads: usize,
    on_run: &'a mut dyn FnMut(&RunEvent),
    /// Every evaluation, in order.
    pub log: Vec<RunEvent>,
    /// FE runs solved in this invocation.
    pub solved: usize,
    /// When set, evaluations are neither logged nor reported (re-reading cached runs for
    /// the report).
    pub silent: bool,
}

/// The residuals of a run, or why it cannot be used; and its simulated curve.
pub struct Evaluated {
    /// Residuals at the fitted points, or why the run cannot be used.
    pub residuals: Result<Vec<f64>, String>,
    /// The run's curve (loading part).
    pub curve: Curve,
    /// Its folder.
    pub dir: PathBuf,
}

impl<'a> RunCache<'a> {
    /// A cache in `out/runs/`; `threads` solver threads per run (0: all cores).
    pub fn new(
        spec: &'a FitSpec,
        out: &Path,
        threads: usize,
        on_run: &'a mut dyn FnMut(&RunEvent),
    ) -> Self {
        RunCache {
            spec,
            dir: out.join(RUNS_DIR),
            threads,
            on_run,
            log: Vec::new(),
            solved: 0,
            silent: false,
        }
    }

    /// The folder of the run at `values` (whether or not it exists yet).
    pub fn run_dir(&self, values: &[f64]) -> Result<PathBuf, FitError> {
        Ok(self.dir.join(run_hash(&self.spec.document(values)?)))
    }

    /// Evaluates the experiment at `values` (internal units): runs it unless recorded,
    /// then compares its curve with the measured points in the range.
    pub fn evaluate(&mut self, values: &[f64]) -> Result<Evaluated, FitError> {
        let hash = run_hash(&self.spec.document(values)?);
        let dir = self.dir.join(&hash);
        let case = self.spec.case(values, &hash);
        let start = Instant::now();
        let (record, event) = run_case_in(&self.spec.experiment, &case, &dir, self.threads)?;
        let cached = event == CaseEvent::Skipped;
        if !cached {
            self.solved += 1;
        }
        // Always read the curve back from the file, so a fresh run and a cached one give
        // the same numbers bit for bit (and a resumed fit takes the same path).
        let file = dir.join(&self.spec.simulated_file);
        let [x, y] = &self.spec.simulated;
        let curve = if file.exists() {
            read_simulated(&file, x, y).map_err(FitError::Output)?
        } else {
            Curve::empty(x, y)
        };
        let residuals = residuals(self.spec, &curve).map_err(|why| match &record.error {
            Some(e) => format!("{why} (the run stopped: {e})"),
            None => why,
        });
        let rms = residuals
            .as_ref()
            .ok()
            .map(|r| (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt());
        let event = RunEvent {
            evaluation: self.log.len() + 1,
            values: values.to_vec(),
            hash,
            cached,
            status: record.status.clone(),
            rejected: residuals.as_ref().err().cloned(),
            rms,
            wall_time_s: if cached {
                record.wall_time_s
            } else {
                start.elapsed().as_secs_f64()
            },
        };
        if !self.silent {
            (self.on_run)(&event);
            self.log.push(event);
        }
        Ok(Evaluated {
            residuals,
            curve,
            dir,
        })
    }
}

/// The folder name of a run: the stable hash of its scenario document (16 hex digits).
pub fn run_hash(document: &str) -> String {
    format!("{:016x}", stable_hash(document.as_bytes()))
}

/// Whether `dir` holds a finished run.
pub fn is_recorded(dir: &Path) -> bool {
    read_record(dir).is_some()
}

/// Residuals of a simulated curve at the measured points in the range; an error when the
/// curve does not reach one of them (a run that stopped early).
pub fn residuals(spec: &FitSpec, curve: &Curve) -> Result<Vec<f64>, String> {
    let points = spec.fitted_points();
    let floor = 1e-3
        * points
            .iter()
            .map(|&i| spec.data.y[i].abs())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
    points
        .iter()
        .map(|&i| {
            let (x, y) = (spec.data.x[i], spec.data.y[i]);
            let sim = curve.interpolate(x).ok_or_else(|| {
                format!(
                    "the simulated curve reaches {} = {:.6} {} but the fit needs {:.6}",
                    curve.x_name,
                    curve.x_max(),
                    curve.x_dim.internal_unit(),
                    x
                )
            })?;
            Ok(match spec.residual {
                Residual::Absolute => sim - y,
                Residual::Relative => (sim - y) / y.abs().max(floor),
            })
        })
        .collect()
}
