//! Central finite-difference checks of gradients (energy → residual) and Jacobians
//! (residual → tangent), usable for any kernel or term: [`check_gradient`] and
//! [`check_jacobian`] for plain functions, [`check_term_element`] and [`check_term`] for
//! one or every element of any [`Term`] (the checks of `tests/tangent_all_terms.rs`).
//!
//! For a function f and step h, the central difference
//! (f(x + h eₖ) − f(x − h eₖ)) / 2h has truncation error O(h² f''') and round-off error
//! O(ε |f| / h); h ≈ 1e-6 · (scale of x) is a good default for double precision.
//!
//! The error measure is relative to the largest entry of the analytic quantity:
//! `relative_error = max |analytic − fd| / max(max |analytic|, tiny)`, so that entries that
//! are zero by structure do not blow the measure up.

use crate::dof::DofMap;
use crate::element::KernelError;
use crate::term::{Term, MAX_ELEMENT_DOFS};

/// Outcome of a finite-difference comparison.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FdReport {
    /// max over entries of |analytic − finite difference|.
    pub max_abs_error: f64,
    /// max over entries of |analytic| (the normalisation of `relative_error`).
    pub max_reference: f64,
    /// `max_abs_error / max_reference` (or `max_abs_error` if the reference is zero).
    pub relative_error: f64,
    /// Flat index (row-major for Jacobians) of the worst entry.
    pub worst_index: usize,
    /// Analytic value at the worst entry.
    pub worst_analytic: f64,
    /// Finite-difference value at the worst entry.
    pub worst_fd: f64,
}

impl FdReport {
    fn from_pairs(pairs: impl Iterator<Item = (f64, f64)>) -> Self {
        let mut rep = FdReport {
            max_abs_error: 0.0,
            max_reference: 0.0,
            relative_error: 0.0,
            worst_index: 0,
            worst_analytic: 0.0,
            worst_fd: 0.0,
        };
        let mut any_nan = false;
        for (k, (analytic, fd)) in pairs.enumerate() {
            let err = (analytic - fd).abs();
            any_nan |= err.is_nan();
            rep.max_reference = rep.max_reference.max(analytic.abs());
            if err > rep.max_abs_error || (err.is_nan() && !rep.max_abs_error.is_nan()) {
                rep.max_abs_error = err;
                rep.worst_index = k;
                rep.worst_analytic = analytic;
                rep.worst_fd = fd;
            }
        }
        if any_nan {
            rep.max_abs_error = f64::NAN;
        }
        rep.relative_error = if rep.max_reference > 0.0 {
            rep.max_abs_error / rep.max_reference
        } else {
            rep.max_abs_error
        };
        rep
    }

    /// True when `relative_error < tol` (false for NaN).
    pub fn passes(&self, tol: f64) -> bool {
        self.relative_error < tol
    }
}

/// Compares `grad` with the central-difference gradient of the scalar `f` at `x`, step `h`.
///
/// `grad.len()` must equal `x.len()`; extra entries of the longer slice are ignored.
pub fn check_gradient(f: impl Fn(&[f64]) -> f64, grad: &[f64], x: &[f64], h: f64) -> FdReport {
    let mut xp = x.to_vec();
    let n = x.len().min(grad.len());
    let fd: Vec<f64> = (0..n)
        .map(|k| {
            xp[k] = x[k] + h;
            let fp = f(&xp);
            xp[k] = x[k] - h;
            let fm = f(&xp);
            xp[k] = x[k];
            (fp - fm) / (2.0 * h)
        })
        .collect();
    FdReport::from_pairs(grad.iter().copied().zip(fd))
}

/// Compares the row-major Jacobian `jac_row_major` (m × n, n = `x.len()`, m =
/// `jac_row_major.len() / n`) with central differences of `residual(x, out)` (out has
/// length m) at `x`, step `h`.
pub fn check_jacobian(
    residual: impl Fn(&[f64], &mut [f64]),
    jac_row_major: &[f64],
    x: &[f64],
    h: f64,
) -> FdReport {
    let n = x.len();
    let m = jac_row_major.len().checked_div(n).unwrap_or(0);
    let mut fd = vec![0.0; m * n];
    let mut xp = x.to_vec();
    let mut rp = vec![0.0; m];
    let mut rm = vec![0.0; m];
    for k in 0..n {
        xp[k] = x[k] + h;
        residual(&xp, &mut rp);
        xp[k] = x[k] - h;
        residual(&xp, &mut rm);
        xp[k] = x[k];
        for i in 0..m {
            fd[i * n + k] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
    FdReport::from_pairs(jac_row_major.iter().copied().zip(fd))
}

/// Largest |A − Aᵀ| / max |A| of a square row-major matrix of order n.
pub fn symmetry_error(a_row_major: &[f64], n: usize) -> f64 {
    let mut max_a: f64 = 0.0;
    let mut max_d: f64 = 0.0;
    for i in 0..n {
        for j in 0..n {
            max_a = max_a.max(a_row_major[i * n + j].abs());
            max_d = max_d.max((a_row_major[i * n + j] - a_row_major[j * n + i]).abs());
        }
    }
    if max_a > 0.0 {
        max_d / max_a
    } else {
        max_d
    }
}

/// Finite-difference check of one element of a term.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TermCheck {
    /// Element index.
    pub element: usize,
    /// Residual against central differences of the energy.
    pub gradient: FdReport,
    /// Tangent against central differences of the residual.
    pub jacobian: FdReport,
    /// [`symmetry_error`] of the tangent.
    pub symmetry: f64,
}

impl TermCheck {
    /// True when the gradient and Jacobian relative errors are below `tol` and the symmetry
    /// error below `sym_tol`.
    pub fn passes(&self, tol: f64, sym_tol: f64) -> bool {
        self.gradient.passes(tol) && self.jacobian.passes(tol) && self.symmetry < sym_tol
    }
}

/// Checks element `e` of `term` at its DOF values `u_e` with central differences of step
/// `h`: the residual against the energy, the tangent against the residual, and the tangent's
/// symmetry. Errors if the term cannot evaluate the element at `u_e`; a failure at a
/// perturbed state shows as NaN in the report.
pub fn check_term_element(
    term: &dyn Term,
    e: usize,
    u_e: &[f64],
    h: f64,
) -> Result<TermCheck, KernelError> {
    let n = u_e.len();
    let mut residual = vec![0.0; n];
    let mut tangent = vec![0.0; n * n];
    term.evaluate(e, u_e, &mut residual, Some(&mut tangent))?;
    let gradient = check_gradient(
        |x| {
            let mut r = vec![0.0; n];
            term.evaluate(e, x, &mut r, None).unwrap_or(f64::NAN)
        },
        &residual,
        u_e,
        h,
    );
    let jacobian = check_jacobian(
        |x, out| {
            if term.evaluate(e, x, out, None).is_err() {
                out.fill(f64::NAN);
            }
        },
        &tangent,
        u_e,
        h,
    );
    Ok(TermCheck {
        element: e,
        gradient,
        jacobian,
        symmetry: symmetry_error(&tangent, n),
    })
}

/// [`check_term_element`] for every element of `term` at the global DOF values `u`.
pub fn check_term(
    term: &dyn Term,
    dof_map: &DofMap,
    u: &[f64],
    h: f64,
) -> Result<Vec<TermCheck>, KernelError> {
    let mut dofs = [0usize; MAX_ELEMENT_DOFS];
    (0..term.num_elements())
        .map(|e| {
            let n = term.element_dofs(e, dof_map, &mut dofs);
            let u_e: Vec<f64> = dofs[..n].iter().map(|&d| u[d]).collect();
            check_term_element(term, e, &u_e, h)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(x: &[f64]) -> f64 {
        x[0].sin() * x[1] + x[2].powi(3)
    }

    #[test]
    fn gradient_check_accepts_right_and_rejects_wrong() {
        let x: [f64; 3] = [0.3, -1.2, 0.7];
        let good = [x[0].cos() * x[1], x[0].sin(), 3.0 * x[2] * x[2]];
        let rep = check_gradient(f, &good, &x, 1e-5);
        assert!(rep.passes(1e-9), "{rep:?}");
        let bad = [good[0], good[1] * 1.001, good[2]];
        let rep = check_gradient(f, &bad, &x, 1e-5);
        assert!(!rep.passes(1e-5), "{rep:?}");
        assert_eq!(rep.worst_index, 1);
    }

    #[test]
    fn jacobian_check_accepts_right_and_rejects_wrong() {
        let x: [f64; 2] = [0.3, -1.2];
        let r = |x: &[f64], out: &mut [f64]| {
            out[0] = x[0] * x[1];
            out[1] = x[0].exp();
            out[2] = x[1] * x[1];
        };
        let good = [x[1], x[0], x[0].exp(), 0.0, 0.0, 2.0 * x[1]];
        let rep = check_jacobian(r, &good, &x, 1e-6);
        assert!(rep.passes(1e-9), "{rep:?}");
        let mut bad = good;
        bad[3] = 1e-3;
        let rep = check_jacobian(r, &bad, &x, 1e-6);
        assert_eq!(rep.worst_index, 3);
        assert!(!rep.passes(1e-5));
        assert!(symmetry_error(&[1.0, 2.0, 2.0, 1.0], 2) == 0.0);
        assert!((symmetry_error(&[1.0, 2.0, 1.0, 1.0], 2) - 0.5).abs() < 1e-15);
    }
}
