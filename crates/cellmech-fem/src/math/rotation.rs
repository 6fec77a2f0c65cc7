//! Rotations of SO(3) parametrised by the rotation vector θ (axis × angle), written once
//! over any [`Scalar`] so that kernels get exact derivatives by automatic differentiation.
//!
//! - [`exp_so3`]: `R = exp(θ̂) = cos φ I + (sin φ/φ) θ̂ + ((1 − cos φ)/φ²) θθᵀ`, φ = |θ|
//!   (Rodrigues). The three coefficients are evaluated as smooth functions of `s = θ·θ`
//!   (series for small `s`), so the map and its first two derivatives are exact and finite
//!   at θ = 0.
//! - [`log_so3`]: the inverse for rotation angles φ < π: via the unit quaternion
//!   `w = cos(φ/2) = ½√(1 + tr R)`, `v = sin(φ/2) n = vee(R − Rᵀ)/(4w)` and
//!   `θ = (2/w) · atan(√τ)/√τ · v` with `τ = |v|²/w² = tan²(φ/2)`, again smooth at θ = 0.
//!
//! Matrices are `[[S; 3]; 3]`, indexed `[row][column]`.

use super::hyperdual::Scalar;

/// A 3×3 matrix of scalars, `[row][column]`.
pub type Mat3<S> = [[S; 3]; 3];

/// Below this `s = φ²` the Rodrigues coefficients are evaluated by their Taylor series
/// (which avoids the cancellation of the closed forms' derivatives near 0).
const SERIES_LIMIT: f64 = 0.5;
/// Below this `τ` the function `atan(√τ)/√τ` is evaluated by its Taylor series.
const ATAN_SERIES_LIMIT: f64 = 0.1;
/// Terms of the Taylor series (truncation error of f, f′, f″ far below 1e-16).
const SERIES_TERMS: usize = 12;
/// Terms of the (slowly converging) series of `atan(√τ)/√τ`.
const ATAN_SERIES_TERMS: usize = 24;

/// A function value with its first two derivatives.
#[derive(Debug, Clone, Copy)]
struct Jet {
    f: f64,
    df: f64,
    d2f: f64,
}

impl Jet {
    fn apply<S: Scalar>(&self, x: S) -> S {
        x.chain(self.f, self.df, self.d2f)
    }
}

/// `Σₖ cₖ (−s)ᵏ` (k < `terms`) and its first two derivatives in `s`.
fn alternating_series(s: f64, terms: usize, c: impl Fn(usize) -> f64) -> Jet {
    let mut jet = Jet {
        f: 0.0,
        df: 0.0,
        d2f: 0.0,
    };
    for k in 0..terms {
        let ck = if k % 2 == 0 { c(k) } else { -c(k) };
        let kf = k as f64;
        jet.f += ck * s.powi(k as i32);
        if k >= 1 {
            jet.df += ck * kf * s.powi(k as i32 - 1);
        }
        if k >= 2 {
            jet.d2f += ck * kf * (kf - 1.0) * s.powi(k as i32 - 2);
        }
    }
    jet
}

fn factorial(n: usize) -> f64 {
    (1..=n).map(|i| i as f64).product()
}

/// `cos√s`, `sin√s/√s`, `(1 − cos√s)/s` with their derivatives in `s ≥ 0`.
fn rodrigues_coefficients(s: f64) -> [Jet; 3] {
    if s < SERIES_LIMIT {
        return [
            alternating_series(s, SERIES_TERMS, |k| 1.0 / factorial(2 * k)),
            alternating_series(s, SERIES_TERMS, |k| 1.0 / factorial(2 * k + 1)),
            alternating_series(s, SERIES_TERMS, |k| 1.0 / factorial(2 * k + 2)),
        ];
    }
    let r = s.sqrt();
    let (f0, f1) = (r.cos(), r.sin() / r);
    let f2 = (1.0 - f0) / s;
    let df0 = -0.5 * f1;
    let df1 = (f0 - f1) / (2.0 * s);
    let d2f0 = -0.5 * df1;
    let d2f1 = (df0 - df1) / (2.0 * s) - df1 / s;
    let df2 = (-df0 - f2) / s;
    let d2f2 = (-d2f0 - 2.0 * df2) / s;
    [
        Jet {
            f: f0,
            df: df0,
            d2f: d2f0,
        },
        Jet {
            f: f1,
            df: df1,
            d2f: d2f1,
        },
        Jet {
            f: f2,
            df: df2,
            d2f: d2f2,
        },
    ]
}

/// `atan(√τ)/√τ` with its derivatives in `τ ≥ 0`.
fn atan_ratio(t: f64) -> Jet {
    if t < ATAN_SERIES_LIMIT {
        return alternating_series(t, ATAN_SERIES_TERMS, |k| 1.0 / (2 * k + 1) as f64);
    }
    let q = t.sqrt();
    let h = q.atan() / q;
    let dh = (1.0 / (1.0 + t) - h) / (2.0 * t);
    let d2h = (-1.0 / ((1.0 + t) * (1.0 + t)) - dh) / (2.0 * t) - dh / t;
    Jet {
        f: h,
        df: dh,
        d2f: d2h,
    }
}

/// The rotation matrix `exp(θ̂)` of the rotation vector `theta` (any magnitude; the map is
/// a local diffeomorphism for |θ| < 2π).
pub fn exp_so3<S: Scalar>(theta: &[S; 3]) -> Mat3<S> {
    let s = theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2];
    let [j0, j1, j2] = rodrigues_coefficients(s.value());
    let (c0, c1, c2) = (j0.apply(s), j1.apply(s), j2.apply(s));
    let zero = S::constant(0.0);
    let w = [
        [zero, -theta[2], theta[1]],
        [theta[2], zero, -theta[0]],
        [-theta[1], theta[0], zero],
    ];
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let outer = c2 * theta[i] * theta[j];
            let skew = if i == j { outer } else { outer + c1 * w[i][j] };
            if i == j {
                skew + c0
            } else {
                skew
            }
        })
    })
}

/// Smallest `1 + tr R` (= 4 cos²(φ/2)) [`log_so3`] accepts: rotation angles up to about
/// 179.9°; beyond, the rotation vector of a rotation by ≈ π is not a smooth function of R.
pub const LOG_MIN_ONE_PLUS_TRACE: f64 = 1e-6;

/// The rotation vector θ (|θ| < π) of the rotation matrix `r`, or `None` when the rotation
/// angle is too close to π (`1 + tr R <` [`LOG_MIN_ONE_PLUS_TRACE`]).
pub fn log_so3<S: Scalar>(r: &Mat3<S>) -> Option<[S; 3]> {
    let one_plus_trace = r[0][0] + r[1][1] + r[2][2] + 1.0;
    if !(one_plus_trace.value() >= LOG_MIN_ONE_PLUS_TRACE) {
        return None;
    }
    let w = one_plus_trace.sqrt() * 0.5;
    let inv4w = (w * 4.0).recip();
    let v = [
        (r[2][1] - r[1][2]) * inv4w,
        (r[0][2] - r[2][0]) * inv4w,
        (r[1][0] - r[0][1]) * inv4w,
    ];
    let inv_w = w.recip();
    let tau = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) * inv_w * inv_w;
    let factor = atan_ratio(tau.value()).apply(tau) * inv_w * 2.0;
    Some([v[0] * factor, v[1] * factor, v[2] * factor])
}

/// Plain product `a · b` of two `f64` matrices.
pub fn mat_mul(a: &Mat3<f64>, b: &Mat3<f64>) -> Mat3<f64> {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{HyperDual, HD_N};

    #[test]
    fn rotation_exp_log_round_trip_and_orthogonality() {
        for (k, angle) in [0.0, 1e-9, 1e-4, 0.3, 0.7, 1.0, 2.0, 3.0, 3.1]
            .iter()
            .enumerate()
        {
            let axis = [0.3 + k as f64 * 0.1, -0.5, 0.8];
            let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
            let theta = axis.map(|c| c / n * angle);
            let r = exp_so3(&theta);
            let rtr = mat_mul(
                &r,
                &std::array::from_fn(|i| std::array::from_fn(|j| r[j][i])),
            );
            for i in 0..3 {
                for j in 0..3 {
                    let id = if i == j { 1.0 } else { 0.0 };
                    assert!((rtr[i][j] - id).abs() < 1e-15);
                }
            }
            // R θ = θ (the axis is fixed).
            let rt: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| r[i][j] * theta[j]).sum());
            assert!((0..3).all(|i| (rt[i] - theta[i]).abs() < 1e-15));
            let back = log_so3(&r).unwrap();
            for c in 0..3 {
                assert!(
                    (back[c] - theta[c]).abs() < 1e-13,
                    "angle {angle}: {back:?}"
                );
            }
        }
    }

    /// Second derivatives of exp/log by AD agree with finite differences of AD first
    /// derivatives, including across the series/closed-form switch and at θ = 0.
    #[test]
    fn rotation_maps_have_exact_first_and_second_derivatives() {
        let f = |x: &[HyperDual; 3]| -> HyperDual {
            let r = exp_so3(x);
            // A scalar mixing all entries, then log of a product with a fixed rotation.
            let fixed = exp_so3(&[0.2, -0.1, 0.3]);
            let m: Mat3<HyperDual> = std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    r[i][0] * fixed[0][j] + r[i][1] * fixed[1][j] + r[i][2] * fixed[2][j]
                })
            });
            let l = log_so3(&m).unwrap();
            r[0][1] * 0.7 + r[2][0] * r[1][2] + l[0] * l[1] + l[2] * 1.3
        };
        let eval = |p: [f64; 3]| f(&std::array::from_fn(|i| HyperDual::variable(i, p[i])));
        for p in [
            [0.0, 0.0, 0.0],
            [1e-5, 0.0, -2e-5],
            [0.4, 0.3, -0.45],
            [0.41, 0.3, -0.45],
            [1.5, -1.0, 0.8],
        ] {
            let v = eval(p);
            let h = 1e-6;
            for j in 0..3 {
                let (mut pp, mut pm) = (p, p);
                pp[j] += h;
                pm[j] -= h;
                let (a, b) = (eval(pp), eval(pm));
                assert!(((a.v - b.v) / (2.0 * h) - v.g[j]).abs() < 1e-8);
                for i in 0..3 {
                    let fd = (a.g[i] - b.g[i]) / (2.0 * h);
                    assert!((fd - v.hessian(i, j)).abs() < 1e-7, "{p:?} H{i}{j}");
                }
            }
            assert!(v.g[3..HD_N].iter().all(|&g| g == 0.0));
        }
    }
}
