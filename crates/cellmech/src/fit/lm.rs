//! A compact Levenberg–Marquardt least-squares optimiser with bounds, for models whose
//! residuals are expensive (one finite-element run per evaluation) and may fail to
//! evaluate at some parameters.
//!
//! Minimises `C(x) = ½ Σ rᵢ(x)²` over a box `lower ≤ x ≤ upper`:
//!
//! * the Jacobian is taken by forward differences with a fixed absolute step per variable
//!   (backward when the forward point is outside the box or cannot be evaluated);
//! * the step solves `(JᵀJ + λ D) δ = −Jᵀr` with Marquardt's scaling `D = diag(JᵀJ)`
//!   (invariant to the units of the variables), is projected onto the box, and is accepted
//!   when the gain ratio `ρ = (C(x) − C(x+δ)) / (predicted decrease)` exceeds 1e-3. The
//!   damping λ follows Nielsen's rule (a trust-region radius in disguise): shrink by
//!   `max(1/3, 1 − (2ρ − 1)³)` after an accepted step, grow by ν (doubling) after a
//!   rejected one. A point that cannot be evaluated is a rejected step;
//! * it stops when an accepted step lowers the cost by less than `cost_tolerance` of the
//!   cost, when the step is below `step_tolerance` (relative to `|x| + step_tolerance`),
//!   when the gradient vanishes, or when the evaluation or iteration budget is spent.
//!
//! No geodesic acceleration: every evaluation is an FE run, and the second-order
//! correction would cost one more per iteration.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// When to stop and how to differentiate.
#[derive(Debug, Clone, PartialEq)]
pub struct LmSettings {
    /// Most residual evaluations (Jacobian columns included).
    pub max_evaluations: usize,
    /// Most iterations (Jacobians).
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction of it.
    pub cost_tolerance: f64,
    /// Stop when the step is below this fraction of `|x| + step_tolerance`.
    pub step_tolerance: f64,
    /// Damping at the start, relative to the largest diagonal entry of `JᵀJ`.
    pub initial_damping: f64,
}

impl Default for LmSettings {
    fn default() -> Self {
        LmSettings {
            max_evaluations: 60,
            max_iterations: 30,
            cost_tolerance: 1e-6,
            step_tolerance: 1e-6,
            initial_damping: 1e-3,
        }
    }
}

/// One iteration of the optimiser (a Jacobian and the steps tried with it).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LmIteration {
    /// 1-based iteration number.
    pub iteration: usize,
    /// Variables at the end of the iteration.
    pub x: Vec<f64>,
    /// Cost ½ Σ r² there.
    pub cost: f64,
    /// Damping λ used by the last step tried.
    pub damping: f64,
    /// Steps tried in this iteration (1 when the first was accepted).
    pub steps_tried: usize,
    /// Whether a step was accepted.
    pub accepted: bool,
    /// Evaluations so far.
    pub evaluations: usize,
}

/// Why the optimiser stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StopReason {
    /// An accepted step lowered the cost by less than `cost_tolerance`.
    CostChange,
    /// The step became smaller than `step_tolerance`.
    StepSize,
    /// The gradient is zero (or the cost is).
    Gradient,
    /// No step lowered the cost even with very large damping.
    NoProgress,
    /// `max_evaluations` reached.
    MaxEvaluations,
    /// `max_iterations` reached.
    MaxIterations,
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            StopReason::CostChange => "cost-change",
            StopReason::StepSize => "step-size",
            StopReason::Gradient => "gradient",
            StopReason::NoProgress => "no-progress",
            StopReason::MaxEvaluations => "max-evaluations",
            StopReason::MaxIterations => "max-iterations",
        })
    }
}

impl StopReason {
    /// Whether the stop is a convergence (not a spent budget).
    pub fn converged(self) -> bool {
        matches!(
            self,
            StopReason::CostChange | StopReason::StepSize | StopReason::Gradient
        )
    }
}

/// The optimiser's result.
#[derive(Debug, Clone)]
pub struct LmOutcome {
    /// Best variables found.
    pub x: Vec<f64>,
    /// Residuals there.
    pub residuals: Vec<f64>,
    /// Jacobian of the residuals at `x` (m × n).
    pub jacobian: DMatrix<f64>,
    /// Cost ½ Σ r² at `x`.
    pub cost: f64,
    /// Evaluations made (including the Jacobian columns).
    pub evaluations: usize,
    /// Why it stopped.
    pub stop: StopReason,
    /// Every iteration.
    pub history: Vec<LmIteration>,
}

/// Why the optimiser could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LmError<E> {
    /// The model's own error (not a point it cannot evaluate: an I/O failure, …).
    #[error("{0}")]
    Model(E),
    /// The start cannot be evaluated.
    #[error("the start point cannot be evaluated: {0}")]
    Start(String),
    /// A Jacobian column cannot be evaluated on either side.
    #[error(
        "the derivative with respect to variable {variable} cannot be evaluated at {x:?}: {reason}"
    )]
    Derivative {
        /// 0-based variable.
        variable: usize,
        /// Where.
        x: Vec<f64>,
        /// Why the last point failed.
        reason: String,
    },
    /// Inconsistent input (sizes, bounds, steps).
    #[error("{0}")]
    Input(String),
}

/// What one evaluation of the model gives: the residuals, or why the point cannot be
/// evaluated (a penalised, rejected point, e.g. an FE run that stopped early).
pub type Evaluation = Result<Vec<f64>, String>;

/// One evaluation inside the optimiser: the point, counted.
type Evaluator<'a, E> = dyn FnMut(&DVector<f64>) -> Result<Evaluation, LmError<E>> + 'a;

/// Minimises ½ Σ r(x)² from `x0` within `[lower, upper]`. `steps[j]` is the absolute
/// finite-difference step of variable j. `model` returns `Ok(Ok(r))`, `Ok(Err(why))` for
/// a point it cannot evaluate, or `Err(e)` to abort.
pub fn minimize<E>(
    x0: &[f64],
    lower: &[f64],
    upper: &[f64],
    steps: &[f64],
    settings: &LmSettings,
    model: &mut dyn FnMut(&[f64]) -> Result<Evaluation, E>,
) -> Result<LmOutcome, LmError<E>> {
    let n = x0.len();
    if n == 0 || lower.len() != n || upper.len() != n || steps.len() != n {
        return Err(LmError::Input(format!(
            "expected {n} > 0 variables with as many bounds and steps; found {} lower, {} upper, {} steps",
            lower.len(),
            upper.len(),
            steps.len()
        )));
    }
    for j in 0..n {
        let ok = lower[j] <= upper[j]
            && (lower[j]..=upper[j]).contains(&x0[j])
            && steps[j] > 0.0
            && steps[j].is_finite();
        if !ok {
            return Err(LmError::Input(format!(
                "variable {j}: expected lower ≤ start ≤ upper and a positive step; found {} ≤ {} ≤ {}, step {}",
                lower[j], x0[j], upper[j], steps[j]
            )));
        }
    }
    let project = |x: &DVector<f64>| -> DVector<f64> {
        DVector::from_iterator(n, (0..n).map(|j| x[j].clamp(lower[j], upper[j])))
    };
    let mut evaluations = 0usize;
    let mut eval = |x: &DVector<f64>, evaluations: &mut usize| -> Result<Evaluation, LmError<E>> {
        *evaluations += 1;
        model(x.as_slice()).map_err(LmError::Model)
    };
    let mut x = DVector::from_column_slice(x0);
    let mut r = match eval(&x, &mut evaluations)? {
        Ok(r) => DVector::from_vec(r),
        Err(why) => return Err(LmError::Start(why)),
    };
    let m = r.len();
    let cost_of = |r: &DVector<f64>| 0.5 * r.norm_squared();
    let mut cost = cost_of(&r);
    let mut history = Vec::new();
    let mut lambda = f64::NAN;
    let mut nu = 2.0;
    let mut jacobian: DMatrix<f64>;
    let mut iteration = 0usize;
    let stop = loop {
        jacobian = fd_jacobian(&x, &r, lower, upper, steps, &mut |x| {
            eval(x, &mut evaluations)
        })?;
        iteration += 1;
        let a = jacobian.transpose() * &jacobian;
        let g = jacobian.transpose() * &r;
        if cost == 0.0 || g.amax() == 0.0 {
            break StopReason::Gradient;
        }
        let largest = (0..n).map(|j| a[(j, j)]).fold(0.0, f64::max);
        let scale: Vec<f64> = (0..n).map(|j| a[(j, j)].max(1e-12 * largest)).collect();
        if lambda.is_nan() {
            lambda = settings.initial_damping;
        }
        let mut tried = 0usize;
        let mut accepted = None;
        let mut out_of_budget = false;
        let mut tiny_step = false;
        while tried < 30 {
            if evaluations >= settings.max_evaluations {
                out_of_budget = true;
                break;
            }
            tried += 1;
            let mut damped = a.clone();
            for j in 0..n {
                damped[(j, j)] += lambda * scale[j];
            }
            let Some(delta) = damped.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= nu;
                nu *= 2.0;
                continue;
            };
            let x_new = project(&(&x + &delta));
            let step = &x_new - &x;
            if step.norm() <= settings.step_tolerance * (x.norm() + settings.step_tolerance) {
                tiny_step = true;
                break;
            }
            let predicted = -(g.dot(&step) + 0.5 * step.dot(&(&a * &step)));
            let rho = match eval(&x_new, &mut evaluations)? {
                Ok(r_new) if r_new.len() == m => {
                    let r_new = DVector::from_vec(r_new);
                    let c = cost_of(&r_new);
                    let rho = if predicted > 0.0 {
                        (cost - c) / predicted
                    } else {
                        -1.0
                    };
                    if rho > 1e-3 {
                        accepted = Some((x_new, r_new, c));
                    }
                    rho
                }
                _ => -1.0,
            };
            if accepted.is_some() {
                lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                nu = 2.0;
                break;
            }
            lambda *= nu;
            nu *= 2.0;
        }
        let was_accepted = accepted.is_some();
        let mut converged = None;
        if let Some((x_new, r_new, c)) = accepted {
            let decrease = cost - c;
            let step = (&x_new - &x).norm();
            x = x_new;
            r = r_new;
            if decrease <= settings.cost_tolerance * cost {
                converged = Some(StopReason::CostChange);
            } else if step <= settings.step_tolerance * (x.norm() + settings.step_tolerance) {
                converged = Some(StopReason::StepSize);
            }
            cost = c;
        }
        history.push(LmIteration {
            iteration,
            x: x.as_slice().to_vec(),
            cost,
            damping: lambda,
            steps_tried: tried,
            accepted: was_accepted,
            evaluations,
        });
        if tiny_step {
            // A step that is tiny from the start is convergence; one that only became tiny
            // because rejected trials grew the damping is a failure to descend (a false
            // minimum otherwise: measured on a tension fit that stopped at rms 0.74 nN
            // against 0.3 nN of noise).
            break if tried > 1 {
                StopReason::NoProgress
            } else {
                StopReason::StepSize
            };
        }
        if out_of_budget {
            break StopReason::MaxEvaluations;
        }
        if !was_accepted {
            break StopReason::NoProgress;
        }
        if let Some(reason) = converged {
            // The Jacobian at the accepted point, for the standard errors.
            jacobian = fd_jacobian(&x, &r, lower, upper, steps, &mut |x| {
                eval(x, &mut evaluations)
            })?;
            break reason;
        }
        if iteration >= settings.max_iterations {
            jacobian = fd_jacobian(&x, &r, lower, upper, steps, &mut |x| {
                eval(x, &mut evaluations)
            })?;
            break StopReason::MaxIterations;
        }
        if evaluations >= settings.max_evaluations {
            jacobian = fd_jacobian(&x, &r, lower, upper, steps, &mut |x| {
                eval(x, &mut evaluations)
            })?;
            break StopReason::MaxEvaluations;
        }
    };
    Ok(LmOutcome {
        x: x.as_slice().to_vec(),
        residuals: r.as_slice().to_vec(),
        jacobian,
        cost,
        evaluations,
        stop,
        history,
    })
}

/// Forward-difference Jacobian at `x` (residuals `r` there); a column whose forward point
/// is outside the box or cannot be evaluated is taken backwards.
fn fd_jacobian<E>(
    x: &DVector<f64>,
    r: &DVector<f64>,
    lower: &[f64],
    upper: &[f64],
    steps: &[f64],
    eval: &mut Evaluator<'_, E>,
) -> Result<DMatrix<f64>, LmError<E>> {
    let (m, n) = (r.len(), x.len());
    let mut jacobian = DMatrix::zeros(m, n);
    for j in 0..n {
        let mut reason = String::from("both sides are outside the bounds");
        let mut column = None;
        for sign in [1.0, -1.0] {
            let target = x[j] + sign * steps[j];
            if target > upper[j] || target < lower[j] {
                continue;
            }
            let mut xj = x.clone();
            xj[j] = target;
            let h = xj[j] - x[j];
            match eval(&xj)? {
                Ok(rj) if rj.len() == m => {
                    column = Some(DVector::from_iterator(
                        m,
                        (0..m).map(|i| (rj[i] - r[i]) / h),
                    ));
                    break;
                }
                Ok(rj) => reason = format!("expected {m} residuals; found {}", rj.len()),
                Err(why) => reason = why,
            }
        }
        let Some(column) = column else {
            return Err(LmError::Derivative {
                variable: j,
                x: x.as_slice().to_vec(),
                reason,
            });
        };
        jacobian.set_column(j, &column);
    }
    Ok(jacobian)
}

/// Covariance of least-squares estimates: `σ² (JᵀJ)⁻¹` with `σ² = Σ r² / (m − n)`.
/// `None` when there are no degrees of freedom or `JᵀJ` is singular (a parameter the
/// data do not determine).
pub fn covariance(jacobian: &DMatrix<f64>, residuals: &[f64]) -> Option<DMatrix<f64>> {
    let (m, n) = jacobian.shape();
    if m <= n || residuals.len() != m {
        return None;
    }
    let sigma2 = residuals.iter().map(|r| r * r).sum::<f64>() / (m - n) as f64;
    let a = jacobian.transpose() * jacobian;
    // Scale to unit diagonal before inverting, so very different units do not spoil it.
    let d: Vec<f64> = (0..n).map(|j| a[(j, j)].sqrt()).collect();
    if d.iter().any(|&v| !(v > 0.0) || !v.is_finite()) {
        return None;
    }
    let scaled = DMatrix::from_fn(n, n, |i, j| a[(i, j)] / (d[i] * d[j]));
    let svd = scaled.clone().svd(false, false);
    let (smax, smin) = (svd.singular_values.max(), svd.singular_values.min());
    if !(smin > 1e-12 * smax) {
        return None;
    }
    let inv = scaled.try_inverse()?;
    Some(DMatrix::from_fn(n, n, |i, j| {
        sigma2 * inv[(i, j)] / (d[i] * d[j])
    }))
}

/// Correlation matrix of a covariance matrix.
pub fn correlation(covariance: &DMatrix<f64>) -> DMatrix<f64> {
    let n = covariance.nrows();
    DMatrix::from_fn(n, n, |i, j| {
        covariance[(i, j)] / (covariance[(i, i)] * covariance[(j, j)]).sqrt()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    type Model<'a> = dyn FnMut(&[f64]) -> Result<Evaluation, String> + 'a;

    fn run(x0: &[f64], lower: &[f64], upper: &[f64], model: &mut Model<'_>) -> LmOutcome {
        let settings = LmSettings {
            max_evaluations: 500,
            max_iterations: 100,
            cost_tolerance: 1e-12,
            step_tolerance: 1e-12,
            ..LmSettings::default()
        };
        let steps = vec![1e-7; x0.len()];
        minimize(x0, lower, upper, &steps, &settings, model).expect("the fit runs")
    }

    /// A straight line y = a + b x: LM must give the normal-equation solution and the
    /// closed-form standard errors of ordinary least squares.
    #[test]
    fn a_linear_model_gives_the_normal_equations_and_their_standard_errors() {
        let xs: Vec<f64> = (0..12).map(|i| i as f64 * 0.5).collect();
        // Deterministic "noise".
        let ys: Vec<f64> = xs
            .iter()
            .enumerate()
            .map(|(i, x)| 1.5 + 0.8 * x + 0.1 * ((i * 7 % 5) as f64 - 2.0))
            .collect();
        let mut model = |p: &[f64]| -> Result<Evaluation, String> {
            Ok(Ok(xs
                .iter()
                .zip(&ys)
                .map(|(x, y)| p[0] + p[1] * x - y)
                .collect()))
        };
        let out = run(
            &[10.0, -3.0],
            &[-100.0, -100.0],
            &[100.0, 100.0],
            &mut model,
        );
        // Closed form.
        let m = xs.len() as f64;
        let mx = xs.iter().sum::<f64>() / m;
        let my = ys.iter().sum::<f64>() / m;
        let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
        let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
        let b = sxy / sxx;
        let a = my - b * mx;
        assert!(
            (out.x[0] - a).abs() < 1e-6 && (out.x[1] - b).abs() < 1e-6,
            "{:?} vs {a}, {b}",
            out.x
        );
        let ssr: f64 = xs
            .iter()
            .zip(&ys)
            .map(|(x, y)| (y - a - b * x).powi(2))
            .sum();
        let s2 = ssr / (m - 2.0);
        let se_b = (s2 / sxx).sqrt();
        let se_a = (s2 * (1.0 / m + mx * mx / sxx)).sqrt();
        let cov_ab = -mx * s2 / sxx;
        let cov = covariance(&out.jacobian, &out.residuals).expect("identifiable");
        assert!(
            (cov[(0, 0)].sqrt() / se_a - 1.0).abs() < 1e-5,
            "{} vs {se_a}",
            cov[(0, 0)].sqrt()
        );
        assert!(
            (cov[(1, 1)].sqrt() / se_b - 1.0).abs() < 1e-5,
            "{} vs {se_b}",
            cov[(1, 1)].sqrt()
        );
        assert!((cov[(0, 1)] / cov_ab - 1.0).abs() < 1e-5);
        let corr = correlation(&cov);
        assert!((corr[(0, 1)] - cov_ab / (se_a * se_b)).abs() < 1e-6);
        assert!(out.stop.converged(), "{:?}", out.stop);
    }

    /// y = a x^b from a start far off: the generating values come back (no noise), with
    /// the damping doing its job on the way.
    #[test]
    fn a_power_law_is_recovered_from_a_wrong_start() {
        let xs: Vec<f64> = (1..=15).map(|i| i as f64 * 0.4).collect();
        let (a, b) = (2.5, 1.5);
        let ys: Vec<f64> = xs.iter().map(|x| a * x.powf(b)).collect();
        let mut model = |p: &[f64]| -> Result<Evaluation, String> {
            Ok(Ok(xs
                .iter()
                .zip(&ys)
                .map(|(x, y)| p[0] * x.powf(p[1]) - y)
                .collect()))
        };
        let out = run(&[0.5, 0.3], &[1e-3, 0.0], &[100.0, 5.0], &mut model);
        assert!(
            (out.x[0] - a).abs() < 1e-6 && (out.x[1] - b).abs() < 1e-6,
            "{:?}",
            out.x
        );
        assert!(out.history.len() > 2, "a real iteration: {:?}", out.history);
    }

    /// Bounds hold: the unconstrained optimum is outside, the fit stops on the bound.
    #[test]
    fn bounds_are_respected() {
        let mut model = |p: &[f64]| -> Result<Evaluation, String> {
            Ok(Ok(vec![p[0] - 3.0, 0.1 * (p[0] - 3.0), p[0] - 2.9]))
        };
        let out = run(&[0.0], &[-1.0], &[1.0], &mut model);
        assert_eq!(out.x, vec![1.0]);
    }

    /// Points that cannot be evaluated (an FE run that stops early) are rejected steps,
    /// never a panic; a start that cannot be evaluated is a clear error.
    #[test]
    fn points_that_cannot_be_evaluated_are_rejected() {
        let mut model = |p: &[f64]| -> Result<Evaluation, String> {
            if p[0] > 2.0 {
                return Ok(Err(format!("the run stopped early at {}", p[0])));
            }
            Ok(Ok(vec![p[0] - 1.5, 2.0 * (p[0] - 1.5)]))
        };
        let out = run(&[0.0], &[-10.0], &[10.0], &mut model);
        assert!((out.x[0] - 1.5).abs() < 1e-6, "{:?}", out.x);
        let e = minimize(
            &[3.0],
            &[-10.0],
            &[10.0],
            &[1e-6],
            &LmSettings::default(),
            &mut model,
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("start point cannot be evaluated"),
            "{e}"
        );
        let bad = minimize(
            &[3.0],
            &[5.0],
            &[10.0],
            &[1e-6],
            &LmSettings::default(),
            &mut model,
        )
        .unwrap_err();
        assert!(bad.to_string().contains("lower ≤ start ≤ upper"), "{bad}");
    }

    /// A point away from the minimum where every trial step fails (each neighbouring FE run
    /// stops early): the damping grows until the steps are tiny, and that is reported as
    /// no progress, not as convergence.
    #[test]
    fn steps_made_tiny_by_rejections_are_no_progress_not_convergence() {
        // Evaluable only at the start and its finite-difference neighbour (2e-7 away).
        let start = 1.0;
        let mut model = |p: &[f64]| -> Result<Evaluation, String> {
            if (p[0] - start).abs() > 2e-7 {
                return Ok(Err(format!("the run stopped early at {}", p[0])));
            }
            Ok(Ok(vec![p[0] - 1.5, 2.0 * (p[0] - 1.5)]))
        };
        let settings = LmSettings {
            max_evaluations: 500,
            step_tolerance: 1e-6,
            ..LmSettings::default()
        };
        let out = minimize(&[start], &[-10.0], &[10.0], &[1e-7], &settings, &mut model).unwrap();
        assert_eq!(out.x, vec![start]);
        assert_eq!(out.stop, StopReason::NoProgress, "{:?}", out.history);
        assert!(!out.stop.converged());
    }
}
