//! Closed-form and one-dimensional-root references for the decoupled neo-Hookean law
//! ψ = G/2 (J^{-2/3} I₁ − 3) + K/2 (J − 1)² under homogeneous principal stretches.
//!
//! Principal Cauchy stresses for stretches (λ₁, λ₂, λ₃), J = λ₁λ₂λ₃, I₁ = Σλᵢ²:
//!
//! ```text
//! σᵢ = G J^{-5/3} (λᵢ² − I₁/3) + K (J − 1)
//! ```
//!
//! * **Uniaxial stress**: λ₁ = λ, λ₂ = λ₃ = μ with σ₂ = 0, i.e.
//!   g(μ) = G J^{-5/3} (μ² − λ²)/3 + K (λμ² − 1) = 0, J = λμ².
//!   g < 0 as μ → 0⁺ and g ≥ 0 at μ = max(λ, λ^{-1/2}); the root is found by bisection to
//!   the resolution of f64 (relative width below 1e-15). Then σ₁ = G J^{-5/3}·(2/3)(λ² − μ²)
//!   + K(J − 1) and the nominal (first Piola–Kirchhoff) stress is P₁ = σ₁ μ² = σ₁ J/λ.
//! * **Equibiaxial stress**: λ₁ = λ₂ = λ, λ₃ = μ with σ₃ = 0:
//!   g(μ) = G J^{-5/3}·2(μ² − λ²)/3 + K (λ²μ − 1) = 0, J = λ²μ, upper bracket
//!   max(λ, λ^{-2}); in-plane σ = G J^{-5/3}(λ² − μ²)/3 + K(J − 1), nominal P = σ λμ.
//! * **Incompressible limits** (K → ∞): uniaxial (λ, λ^{-1/2}, λ^{-1/2}):
//!   σ = G(λ² − 1/λ), P = G(λ − λ^{-2}); equibiaxial (λ, λ, λ^{-2}):
//!   σ = G(λ² − λ^{-4}), P = G(λ − λ^{-5}).

use crate::material::NeoHookean;

/// Homogeneous state with two equal principal stretches and a free (stress-free) direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HomogeneousState {
    /// Prescribed stretch (axial for uniaxial, in-plane for equibiaxial).
    pub prescribed_stretch: f64,
    /// Stretch of the stress-free direction(s) (lateral for uniaxial, thickness for
    /// equibiaxial).
    pub free_stretch: f64,
    /// J = det F.
    pub volume_ratio: f64,
    /// Cauchy stress in the loaded direction(s) (kPa).
    pub cauchy: f64,
    /// Nominal (first Piola–Kirchhoff) stress in the loaded direction(s) (kPa = nN/µm² of
    /// reference area).
    pub nominal: f64,
}

/// Bisection for an increasing-sign function g with g(lo) < 0 ≤ g(hi); stops when the
/// interval cannot be halved any more in f64 (relative width < 1e-15) or after 400 steps.
fn bisect(g: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..400 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi || (hi - lo) <= 1e-16 * hi {
            break;
        }
        if g(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Uniaxial Cauchy stress state for axial stretch `stretch` > 0 (lateral stretch solved
/// from σ_lateral = 0). Returns `None` for a non-positive or non-finite stretch or invalid
/// material.
pub fn uniaxial_stress(material: &NeoHookean, stretch: f64) -> Option<HomogeneousState> {
    if !(stretch.is_finite() && stretch > 0.0) || material.validate().is_err() {
        return None;
    }
    let lateral = |mu: f64| material.principal_cauchy([stretch, mu, mu])[1];
    let hi = stretch.max(stretch.powf(-0.5));
    let mu = bisect(lateral, 0.0, hi);
    let sig = material.principal_cauchy([stretch, mu, mu])[0];
    let j = stretch * mu * mu;
    Some(HomogeneousState {
        prescribed_stretch: stretch,
        free_stretch: mu,
        volume_ratio: j,
        cauchy: sig,
        nominal: sig * mu * mu,
    })
}

/// Equibiaxial stress state for in-plane stretch `stretch` > 0 (thickness stretch solved
/// from σ₃ = 0). Returns `None` for a non-positive stretch or invalid material.
pub fn equibiaxial_stress(material: &NeoHookean, stretch: f64) -> Option<HomogeneousState> {
    if !(stretch.is_finite() && stretch > 0.0) || material.validate().is_err() {
        return None;
    }
    let thickness = |mu: f64| material.principal_cauchy([stretch, stretch, mu])[2];
    let hi = stretch.max(stretch.powi(-2));
    let mu = bisect(thickness, 0.0, hi);
    let sig = material.principal_cauchy([stretch, stretch, mu])[0];
    Some(HomogeneousState {
        prescribed_stretch: stretch,
        free_stretch: mu,
        volume_ratio: stretch * stretch * mu,
        cauchy: sig,
        nominal: sig * stretch * mu,
    })
}

/// Incompressible uniaxial Cauchy stress σ = G(λ² − 1/λ) (kPa).
pub fn incompressible_uniaxial_cauchy(shear_modulus: f64, stretch: f64) -> f64 {
    shear_modulus * (stretch * stretch - 1.0 / stretch)
}

/// Incompressible uniaxial nominal stress P = G(λ − λ^{-2}) (kPa).
pub fn incompressible_uniaxial_nominal(shear_modulus: f64, stretch: f64) -> f64 {
    shear_modulus * (stretch - stretch.powi(-2))
}

/// Incompressible equibiaxial Cauchy stress σ = G(λ² − λ^{-4}) (kPa).
pub fn incompressible_equibiaxial_cauchy(shear_modulus: f64, stretch: f64) -> f64 {
    shear_modulus * (stretch * stretch - stretch.powi(-4))
}

/// Incompressible equibiaxial nominal stress P = G(λ − λ^{-5}) (kPa).
pub fn incompressible_equibiaxial_nominal(shear_modulus: f64, stretch: f64) -> f64 {
    shear_modulus * (stretch - stretch.powi(-5))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniaxial_lateral_stress_vanishes_and_small_strain_limit() {
        let m = NeoHookean::from_young_poisson(3.0, 0.3).expect("valid");
        for &l in &[0.5, 0.9, 1.0, 1.3, 2.5] {
            let s = uniaxial_stress(&m, l).expect("valid");
            let lat = m.principal_cauchy([l, s.free_stretch, s.free_stretch])[1];
            assert!(lat.abs() < 1e-12 * m.bulk_modulus, "λ={l}: σ_lat = {lat:e}");
        }
        // Small strain: σ ≈ E ε, lateral strain ≈ −ν ε.
        let eps = 1e-6;
        let s = uniaxial_stress(&m, 1.0 + eps).expect("valid");
        assert!(
            (s.cauchy / eps - 3.0).abs() < 1e-4,
            "E_eff = {}",
            s.cauchy / eps
        );
        assert!(((1.0 - s.free_stretch) / eps - 0.3).abs() < 1e-4);
        assert!(uniaxial_stress(&m, -1.0).is_none());
    }

    #[test]
    fn nearly_incompressible_matches_incompressible_limits() {
        let g = 0.5;
        let m = NeoHookean::new(g, 1e7 * g).expect("valid");
        for &l in &[0.6, 1.5, 2.0] {
            let s = uniaxial_stress(&m, l).expect("valid");
            let r = incompressible_uniaxial_cauchy(g, l);
            assert!(
                (s.cauchy - r).abs() < 1e-5 * r.abs(),
                "λ={l}: {} vs {r}",
                s.cauchy
            );
            let rn = incompressible_uniaxial_nominal(g, l);
            assert!((s.nominal - rn).abs() < 1e-5 * rn.abs());
            let b = equibiaxial_stress(&m, l).expect("valid");
            let rb = incompressible_equibiaxial_cauchy(g, l);
            assert!(
                (b.cauchy - rb).abs() < 1e-5 * rb.abs(),
                "λ={l}: {} vs {rb}",
                b.cauchy
            );
            let rbn = incompressible_equibiaxial_nominal(g, l);
            assert!((b.nominal - rbn).abs() < 1e-5 * rbn.abs());
            let thick = m.principal_cauchy([l, l, b.free_stretch])[2];
            assert!(thick.abs() < 1e-12 * m.bulk_modulus);
        }
    }
}
