//! Synthetic measured curves: the experiment of a fit run at chosen parameter values, its
//! curve interpolated at evenly spaced points and Gaussian noise of a given standard
//! deviation added from a seeded generator. What the round-trip tests and the shipped
//! examples' curves are made from (`cellmech fit FIT --synthetic FILE --at V ...`).

use std::fmt::Write as _;
use std::path::Path;

use cellmech_fem::mesh::generate::SplitMix64;

use super::runs::{RunCache, RunEvent};
use super::spec::FitSpec;
use super::FitError;

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct SyntheticSettings {
    /// Parameter values (internal units, in the fit file's order).
    pub values: Vec<f64>,
    /// Number of points, evenly spaced over the fit's `range` (or from 0 to the end of
    /// the simulated curve).
    pub points: usize,
    /// Standard deviation of the noise added to y (y's internal unit).
    pub noise: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// Solver threads (0: all cores).
    pub threads: usize,
}

/// A standard normal number from two uniforms (Box–Muller).
fn standard_normal(rng: &mut SplitMix64) -> f64 {
    let u1 = 1.0 - rng.next_f64(); // in (0, 1]
    let u2 = rng.next_f64();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Runs the experiment at `settings.values` (cached in `work/runs/`) and writes the
/// synthetic curve to `file`, with a header saying how it was made. Returns (x, y).
pub fn write_synthetic(
    spec: &FitSpec,
    settings: &SyntheticSettings,
    work: &Path,
    file: &Path,
    on_run: &mut dyn FnMut(&RunEvent),
) -> Result<(Vec<f64>, Vec<f64>), FitError> {
    let invalid = |message: String| FitError::Invalid {
        path: spec.origin.clone(),
        message,
    };
    if settings.values.len() != spec.parameters.len() {
        return Err(invalid(format!(
            "synthetic curve: expected {} parameter values (one per [[parameter]]); found {}",
            spec.parameters.len(),
            settings.values.len()
        )));
    }
    if settings.points < 2 || !(settings.noise >= 0.0) {
        return Err(invalid(format!(
            "synthetic curve: expected at least 2 points and a noise ≥ 0; found {} and {}",
            settings.points, settings.noise
        )));
    }
    let mut cache = RunCache::new(spec, work, settings.threads, on_run);
    let run = cache.evaluate(&settings.values)?;
    let curve = run.curve;
    let [from, to] = spec.range.unwrap_or([
        0.0_f64.max(curve.x.first().copied().unwrap_or(0.0)),
        curve.x_max(),
    ]);
    let mut rng = SplitMix64::new(settings.seed);
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for k in 0..settings.points {
        let x = from + (to - from) * k as f64 / (settings.points - 1) as f64;
        let y = curve.interpolate(x).ok_or_else(|| {
            invalid(format!(
                "synthetic curve: the run at the given values reaches {} = {} but the curve needs {x}",
                curve.x_name,
                curve.x_max()
            ))
        })?;
        xs.push(x);
        ys.push(y + settings.noise * standard_normal(&mut rng));
    }
    let name = |column: &str| {
        column
            .rsplit_once('_')
            .map_or(column.to_string(), |(n, _)| n.to_string())
    };
    let (xu, yu) = (curve.x_dim.internal_unit(), curve.y_dim.internal_unit());
    let mut text = format!(
        "# Synthetic curve, not a measurement: the experiment of {} run with\n",
        spec.origin
    );
    for (p, v) in spec.parameters.iter().zip(&settings.values) {
        let _ = writeln!(text, "#   {} = {v} {}", p.key, p.unit());
    }
    let _ = writeln!(
        text,
        "# (run {}/{}), its {} interpolated at {} evenly spaced points, plus Gaussian noise of\n# standard deviation {} {yu} (SplitMix64 seed {}, Box-Muller). Made by `cellmech fit --synthetic`.",
        super::runs::RUNS_DIR,
        run.dir.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        spec.simulated[1],
        settings.points,
        settings.noise,
        settings.seed
    );
    let _ = writeln!(
        text,
        "{} [{xu}],{} [{yu}]",
        name(&spec.simulated[0]),
        name(&spec.simulated[1])
    );
    for (x, y) in xs.iter().zip(&ys) {
        let _ = writeln!(text, "{x:?},{y:?}");
    }
    cellmech_io::write_atomic(file, text.as_bytes())
        .map_err(|e| FitError::Output(e.to_string()))?;
    Ok((xs, ys))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_noise_is_standard_normal() {
        let mut rng = SplitMix64::new(7);
        let n = 200_000;
        let v: Vec<f64> = (0..n).map(|_| standard_normal(&mut rng)).collect();
        let mean = v.iter().sum::<f64>() / n as f64;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.01 && (var - 1.0).abs() < 0.01,
            "{mean} {var}"
        );
    }
}
