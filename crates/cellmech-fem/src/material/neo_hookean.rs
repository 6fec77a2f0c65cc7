//! Decoupled (isochoric/volumetric) compressible neo-Hookean law.
//!
//! # Energy
//!
//! With F the deformation gradient, J = det F, b = F Fᵀ, I₁ = tr b and the isochoric
//! left Cauchy–Green tensor b̄ = J^{-2/3} b,
//!
//! ```text
//! ψ(F) = ψ_iso(F) + U(J),   ψ_iso = G/2 (J^{-2/3} I₁ − 3),   U(J) = K/2 (J − 1)²
//! ```
//!
//! (FEBio "uncoupled neo-Hookean"/CalculiX hyperelastic neo-Hookean; units kPa = nN/µm²).
//! U' (J) = K (J − 1) is the pressure-like quantity (positive in tension), U''(J) = K.
//!
//! # Stress (derivation)
//!
//! ∂J/∂F = J F^{-T}, ∂I₁/∂F = 2F, hence the first Piola–Kirchhoff stress
//! P_iso = G J^{-2/3} (F − I₁/3 F^{-T}) and the Kirchhoff stress τ = P Fᵀ
//!
//! ```text
//! τ_iso = G dev(b̄) = G (b̄ − tr(b̄)/3 · 1),      τ_vol = J U'(J) · 1,      σ = τ / J.
//! ```
//!
//! # Tangent (spatial, Kirchhoff-based)
//!
//! The kernels work in the spatial (push-forward) form: with the Kirchhoff-based spatial
//! tangent 𝕔 = J 𝕔_σ (a_{ijkl} = F_{jJ} F_{lL} ∂P_{iJ}/∂F_{kL} = 𝕔_{ijkl} + δ_{ik} τ_{jl}):
//!
//! ```text
//! 𝕔_iso = 2/3 tr(τ̄) (𝕀 − 1/3 1⊗1) − 2/3 (τ_iso⊗1 + 1⊗τ_iso),   τ̄ = G b̄
//! 𝕔_vol = J (p + J p') 1⊗1 − 2 J p 𝕀,                         p = U'(J), p' = U''(J)
//! ```
//!
//! with 𝕀 the symmetric fourth-order identity (Simo & Hughes 1998, §9; Holzapfel 2000,
//! §6.6). In Voigt notation (order xx, yy, zz, xy, yz, xz, engineering shear strains)
//! 𝕀 = diag(1, 1, 1, ½, ½, ½) and 1 = (1, 1, 1, 0, 0, 0).

use nalgebra::{Matrix3, Matrix6};

/// Invalid material parameters (names the parameter, the value found and the constraint).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NeoHookeanError {
    /// A parameter is outside its admissible range (or not finite).
    #[error("neo-Hookean parameter `{name}` = {value} is invalid: expected {expected}")]
    InvalidParameter {
        /// Parameter name (`shear_modulus`, `bulk_modulus`, `young_modulus`, `poisson_ratio`).
        name: &'static str,
        /// The value found.
        value: f64,
        /// The admissible range, in words.
        expected: &'static str,
    },
}

/// ψ(F) = G/2 (J^{-2/3} I₁ − 3) + K/2 (J − 1)², internal units kPa.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct NeoHookean {
    /// Shear modulus G (kPa).
    pub shear_modulus: f64,
    /// Bulk modulus K (kPa).
    pub bulk_modulus: f64,
}

/// Voigt index pairs in the order xx, yy, zz, xy, yz, xz.
pub const VOIGT_PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2)];

/// J^{-2/3}, to a few ulp.
///
/// Near J = 1 (|J − 1| < 1/16, where nearly every Gauss point of a nearly incompressible
/// body is): y ≈ J^{-1/3} from its Taylor cubic (relative error below 2.2e-6), then two
/// Newton steps on y⁻³ = J, y ← y (4 − J y³)/3 (quadratic: 2e-6 → 1e-11 → 1e-22),
/// and J^{-2/3} = y². Several times cheaper than `cbrt`, which Rust's runtime implements
/// correctly rounded (measured: `benches/kernels.rs`). Elsewhere through `cbrt`.
#[inline]
fn j_pow_minus_two_thirds(j: f64) -> f64 {
    let t = j - 1.0;
    if t.abs() < 0.0625 {
        let mut y = 1.0 + t * (-1.0 / 3.0 + t * (2.0 / 9.0 + t * (-14.0 / 81.0)));
        y *= (4.0 - j * (y * y * y)) * (1.0 / 3.0);
        y *= (4.0 - j * (y * y * y)) * (1.0 / 3.0);
        y * y
    } else {
        let c = j.cbrt();
        1.0 / (c * c)
    }
}

fn positive(name: &'static str, value: f64) -> Result<f64, NeoHookeanError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(NeoHookeanError::InvalidParameter {
            name,
            value,
            expected: "a finite value > 0",
        })
    }
}

fn poisson(value: f64) -> Result<f64, NeoHookeanError> {
    if value.is_finite() && value > -1.0 && value < 0.5 {
        Ok(value)
    } else {
        Err(NeoHookeanError::InvalidParameter {
            name: "poisson_ratio",
            value,
            expected: "-1 < nu < 0.5",
        })
    }
}

impl NeoHookean {
    /// Validated constructor from G (kPa) and K (kPa); both must be finite and > 0.
    pub fn new(shear_modulus: f64, bulk_modulus: f64) -> Result<Self, NeoHookeanError> {
        Ok(Self {
            shear_modulus: positive("shear_modulus", shear_modulus)?,
            bulk_modulus: positive("bulk_modulus", bulk_modulus)?,
        })
    }

    /// From the small-strain Young modulus E (kPa) and Poisson ratio ν ∈ (−1, ½):
    /// G = E / (2(1 + ν)), K = E / (3(1 − 2ν)).
    pub fn from_young_poisson(young: f64, nu: f64) -> Result<Self, NeoHookeanError> {
        let e = positive("young_modulus", young)?;
        let nu = poisson(nu)?;
        Self::new(e / (2.0 * (1.0 + nu)), e / (3.0 * (1.0 - 2.0 * nu)))
    }

    /// From the shear modulus G (kPa) and Poisson ratio ν ∈ (−1, ½):
    /// K = 2G(1 + ν) / (3(1 − 2ν)).
    pub fn from_shear_poisson(shear: f64, nu: f64) -> Result<Self, NeoHookeanError> {
        let g = positive("shear_modulus", shear)?;
        let nu = poisson(nu)?;
        Self::new(g, 2.0 * g * (1.0 + nu) / (3.0 * (1.0 - 2.0 * nu)))
    }

    /// Checks G > 0 and K > 0 (finite) on an already built value (e.g. deserialized).
    pub fn validate(&self) -> Result<(), NeoHookeanError> {
        positive("shear_modulus", self.shear_modulus)?;
        positive("bulk_modulus", self.bulk_modulus)?;
        Ok(())
    }

    /// Volumetric energy U(J) = K/2 (J − 1)² (kPa).
    #[inline]
    pub fn volumetric_energy(&self, j: f64) -> f64 {
        0.5 * self.bulk_modulus * (j - 1.0) * (j - 1.0)
    }

    /// U'(J) = K (J − 1) (kPa); the Cauchy pressure is −U'(J).
    #[inline]
    pub fn volumetric_derivative(&self, j: f64) -> f64 {
        self.bulk_modulus * (j - 1.0)
    }

    /// U''(J) = K (kPa).
    #[inline]
    pub fn volumetric_second_derivative(&self, _j: f64) -> f64 {
        self.bulk_modulus
    }

    /// Isochoric energy density ψ_iso = G/2 (J^{-2/3} tr b − 3) from b = F Fᵀ and J = det F
    /// (kPa per unit reference volume).
    #[inline]
    pub fn isochoric_energy_from_b(&self, b: &Matrix3<f64>, j: f64) -> f64 {
        0.5 * self.shear_modulus * (j_pow_minus_two_thirds(j) * b.trace() - 3.0)
    }

    /// Isochoric energy density ψ_iso(F) (kPa). Undefined (NaN) for det F ≤ 0.
    pub fn isochoric_energy(&self, f: &Matrix3<f64>) -> f64 {
        self.isochoric_energy_from_b(&(f * f.transpose()), f.determinant())
    }

    /// Isochoric Kirchhoff stress τ_iso = G (b̄ − tr(b̄)/3 · 1), b̄ = J^{-2/3} b (kPa).
    #[inline]
    pub fn isochoric_kirchhoff(&self, b: &Matrix3<f64>, j: f64) -> Matrix3<f64> {
        let bbar = b * j_pow_minus_two_thirds(j);
        let mean = bbar.trace() / 3.0;
        let mut tau = bbar * self.shear_modulus;
        for i in 0..3 {
            tau[(i, i)] -= self.shear_modulus * mean;
        }
        tau
    }

    /// Isochoric first Piola–Kirchhoff stress P_iso = τ_iso F^{-T} = G J^{-2/3}(F − I₁/3 F^{-T})
    /// (kPa). Returns `None` when F is singular.
    pub fn isochoric_pk1(&self, f: &Matrix3<f64>) -> Option<Matrix3<f64>> {
        let inv = f.try_inverse()?;
        let b = f * f.transpose();
        Some(self.isochoric_kirchhoff(&b, f.determinant()) * inv.transpose())
    }

    /// Isochoric Kirchhoff-based spatial tangent in Voigt form (kPa), order xx,yy,zz,xy,yz,xz:
    /// 𝕔_iso = 2/3 tr(τ̄)(𝕀 − 1/3 1⊗1) − 2/3(τ_iso⊗1 + 1⊗τ_iso), τ̄ = G J^{-2/3} b.
    /// `tau_iso` must be [`Self::isochoric_kirchhoff`] of the same (b, J).
    #[inline]
    pub fn isochoric_spatial_tangent(
        &self,
        b: &Matrix3<f64>,
        j: f64,
        tau_iso: &Matrix3<f64>,
    ) -> Matrix6<f64> {
        let tr_taubar = self.shear_modulus * j_pow_minus_two_thirds(j) * b.trace();
        let c = 2.0 / 3.0 * tr_taubar;
        let mut d = Matrix6::zeros();
        for i in 0..3 {
            d[(i, i)] = c;
            d[(i + 3, i + 3)] = 0.5 * c;
            for k in 0..3 {
                d[(i, k)] -= c / 3.0;
            }
        }
        for (a, &(i, j2)) in VOIGT_PAIRS.iter().enumerate() {
            let t = 2.0 / 3.0 * tau_iso[(i, j2)];
            for k in 0..3 {
                d[(a, k)] -= t;
                d[(k, a)] -= t;
            }
        }
        d
    }

    /// Total energy density ψ(F) = ψ_iso + U(J) (kPa). NaN-free only for det F > 0.
    pub fn energy(&self, f: &Matrix3<f64>) -> f64 {
        let j = f.determinant();
        self.isochoric_energy(f) + self.volumetric_energy(j)
    }

    /// Cauchy stress σ = G J^{-5/3} dev(b) + U'(J) 1 (kPa).
    pub fn cauchy_stress(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        let j = f.determinant();
        let b = f * f.transpose();
        (self.isochoric_kirchhoff(&b, j)
            + Matrix3::identity() * (j * self.volumetric_derivative(j)))
            / j
    }

    /// Total first Piola–Kirchhoff stress P = ∂ψ/∂F (kPa); `None` when F is singular.
    pub fn pk1(&self, f: &Matrix3<f64>) -> Option<Matrix3<f64>> {
        let inv = f.try_inverse()?;
        let j = f.determinant();
        let b = f * f.transpose();
        let tau = self.isochoric_kirchhoff(&b, j)
            + Matrix3::identity() * (j * self.volumetric_derivative(j));
        Some(tau * inv.transpose())
    }

    /// Principal Cauchy stresses (kPa) for principal stretches λ = (λ₁, λ₂, λ₃):
    /// σ_i = G J^{-5/3} (λ_i² − (λ₁² + λ₂² + λ₃²)/3) + K (J − 1), J = λ₁λ₂λ₃.
    pub fn principal_cauchy(&self, stretches: [f64; 3]) -> [f64; 3] {
        let j = stretches[0] * stretches[1] * stretches[2];
        let i1: f64 = stretches.iter().map(|l| l * l).sum();
        let s = self.shear_modulus * j.powf(-5.0 / 3.0);
        let p = self.volumetric_derivative(j);
        stretches.map(|l| s * (l * l - i1 / 3.0) + p)
    }
}

/// The hex8 kernel's view of the law (the inherent methods of the same names).
impl super::Hyperelastic for NeoHookean {
    #[inline]
    fn isochoric_energy_from_b(&self, b: &Matrix3<f64>, j: f64) -> f64 {
        NeoHookean::isochoric_energy_from_b(self, b, j)
    }

    #[inline]
    fn isochoric_kirchhoff(&self, b: &Matrix3<f64>, j: f64) -> Matrix3<f64> {
        NeoHookean::isochoric_kirchhoff(self, b, j)
    }

    #[inline]
    fn isochoric_spatial_tangent(
        &self,
        b: &Matrix3<f64>,
        j: f64,
        tau_iso: &Matrix3<f64>,
    ) -> Matrix6<f64> {
        NeoHookean::isochoric_spatial_tangent(self, b, j, tau_iso)
    }

    #[inline]
    fn volumetric_energy(&self, j: f64) -> f64 {
        NeoHookean::volumetric_energy(self, j)
    }

    #[inline]
    fn volumetric_derivative(&self, j: f64) -> f64 {
        NeoHookean::volumetric_derivative(self, j)
    }

    #[inline]
    fn volumetric_second_derivative(&self, j: f64) -> f64 {
        NeoHookean::volumetric_second_derivative(self, j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::verify::tangent::{check_gradient, check_jacobian};

    #[test]
    fn j_to_the_minus_two_thirds_is_accurate_to_a_few_ulp_on_both_branches() {
        // Against the correctly rounded cbrt on a fine sweep through the fast branch
        // (|J - 1| < 1/16), its edges and the cbrt branch far from 1.
        let mut worst = 0.0f64;
        let mut j = 0.5f64;
        while j < 2.0 {
            let exact = 1.0 / j.cbrt().powi(2);
            let rel = (j_pow_minus_two_thirds(j) - exact).abs() / exact;
            worst = worst.max(rel);
            j += 1.0 / 4099.0;
        }
        for j in [1.0f64 - 0.0625, 1.0 + 0.0625, 1.0, 1e-3, 7.5, 1e3] {
            let exact = 1.0 / j.cbrt().powi(2);
            worst = worst.max((j_pow_minus_two_thirds(j) - exact).abs() / exact);
        }
        assert!(worst < 1e-15, "largest relative error {worst:e}");
        // Against powf as a second, independent reference (the Newton steps correct a
        // slightly wrong series start, so this checks the result, not the coefficients):
        assert!((j_pow_minus_two_thirds(1.05) - 1.05f64.powf(-2.0 / 3.0)).abs() < 1e-15);
    }

    fn sample_f() -> Matrix3<f64> {
        Matrix3::new(1.3, 0.2, -0.1, 0.05, 0.8, 0.3, -0.2, 0.1, 1.1)
    }

    fn flat(f: &Matrix3<f64>) -> Vec<f64> {
        (0..9).map(|k| f[(k / 3, k % 3)]).collect()
    }

    fn unflat(x: &[f64]) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| x[3 * i + j])
    }

    #[test]
    fn constructors_and_validation() {
        let m = NeoHookean::from_young_poisson(3.0, 0.25).expect("valid");
        assert!((m.shear_modulus - 1.2).abs() < 1e-14);
        assert!((m.bulk_modulus - 2.0).abs() < 1e-14);
        let m2 = NeoHookean::from_shear_poisson(1.2, 0.25).expect("valid");
        assert!((m2.bulk_modulus - 2.0).abs() < 1e-14);
        assert!(NeoHookean::new(0.0, 1.0).is_err());
        assert!(NeoHookean::new(1.0, -1.0).is_err());
        assert!(NeoHookean::new(f64::NAN, 1.0).is_err());
        assert!(NeoHookean::from_shear_poisson(1.0, 0.5).is_err());
        let err = NeoHookean::from_young_poisson(1.0, 0.7).unwrap_err();
        assert!(err.to_string().contains("poisson_ratio"));
        assert!(NeoHookean {
            shear_modulus: 1.0,
            bulk_modulus: 0.0
        }
        .validate()
        .is_err());
    }

    #[test]
    fn pk1_is_energy_gradient_and_stress_free_reference() {
        let m = NeoHookean::new(0.7, 300.0).expect("valid");
        let f = sample_f();
        let p = m.pk1(&f).expect("invertible");
        let rep = check_gradient(|x| m.energy(&unflat(x)), &flat(&p), &flat(&f), 1e-6);
        assert!(rep.relative_error < 1e-8, "{rep:?}");
        let pi = m.isochoric_pk1(&f).expect("invertible");
        let rep = check_gradient(
            |x| m.isochoric_energy(&unflat(x)),
            &flat(&pi),
            &flat(&f),
            1e-6,
        );
        assert!(rep.relative_error < 1e-8, "{rep:?}");
        let id = Matrix3::identity();
        assert!(m.energy(&id).abs() < 1e-15);
        assert!(m.cauchy_stress(&id).norm() < 1e-13);
        // Cauchy = P Fᵀ / J and principal formula on a diagonal F.
        let sig = m.cauchy_stress(&f);
        assert!((sig - p * f.transpose() / f.determinant()).norm() < 1e-12 * sig.norm());
        let d = Matrix3::from_diagonal(&nalgebra::Vector3::new(1.4, 0.9, 0.8));
        let s = m.cauchy_stress(&d);
        let pc = m.principal_cauchy([1.4, 0.9, 0.8]);
        for i in 0..3 {
            assert!((s[(i, i)] - pc[i]).abs() < 1e-12 * pc[i].abs().max(1.0));
        }
    }

    /// Push-forward check: F_jJ F_lL ∂P_iJ/∂F_kL − δ_ik τ_jl must equal the Voigt tangent.
    #[test]
    fn spatial_tangent_matches_finite_difference_of_pk1() {
        let m = NeoHookean::new(0.7, 5.0).expect("valid");
        let f = sample_f();
        let j = f.determinant();
        let b = f * f.transpose();
        let tau = m.isochoric_kirchhoff(&b, j);
        let d = m.isochoric_spatial_tangent(&b, j, &tau);
        // A_(iJ),(kL) by central differences.
        let h = 1e-6;
        let mut a = [[0.0; 9]; 9];
        for c in 0..9 {
            let mut fp = f;
            let mut fm = f;
            fp[(c / 3, c % 3)] += h;
            fm[(c / 3, c % 3)] -= h;
            let dp = (m.isochoric_pk1(&fp).expect("inv") - m.isochoric_pk1(&fm).expect("inv"))
                / (2.0 * h);
            for r in 0..9 {
                a[r][c] = dp[(r / 3, r % 3)];
            }
        }
        let mut max_err: f64 = 0.0;
        for (p, &(i, jj)) in VOIGT_PAIRS.iter().enumerate() {
            for (q, &(k, l)) in VOIGT_PAIRS.iter().enumerate() {
                let mut spatial = 0.0;
                for big_j in 0..3 {
                    for big_l in 0..3 {
                        spatial += f[(jj, big_j)] * f[(l, big_l)] * a[3 * i + big_j][3 * k + big_l];
                    }
                }
                if i == k {
                    spatial -= tau[(jj, l)];
                }
                max_err = max_err.max((spatial - d[(p, q)]).abs());
            }
        }
        assert!(
            max_err < 1e-7 * d.norm(),
            "max error {max_err:e} vs |D| {}",
            d.norm()
        );
        // Jacobian harness on the isochoric PK1 as well (reference for the FD tools).
        let pflat = |x: &[f64], out: &mut [f64]| {
            let p = m.isochoric_pk1(&unflat(x)).unwrap_or_else(Matrix3::zeros);
            out.copy_from_slice(&flat(&p));
        };
        let jac: Vec<f64> = (0..81).map(|k| a[k / 9][k % 9]).collect();
        let rep = check_jacobian(pflat, &jac, &flat(&f), 1e-5);
        assert!(rep.relative_error < 1e-6, "{rep:?}");
    }
}
