//! The interface between a continuum element and an isotropic hyperelastic law with a
//! decoupled (isochoric + volumetric) energy, ψ(F) = ψ_iso(b, J) + U(J).
//!
//! The hex8 kernel ([`crate::element::hex8`]) is generic over [`Hyperelastic`] and needs
//! exactly these six functions, for both of its formulations:
//!
//! * mean dilatation (Q1P0): ψ_iso, τ_iso and 𝕔_iso at every Gauss point, and U, U', U''
//!   at the element volume ratio θ;
//! * plain displacement: the same isochoric part and U, U', U'' at every point's J.
//!
//! Everything is in the spatial (Kirchhoff, push-forward) form the kernel assembles: the
//! kernel adds the volumetric part 𝕔_vol = J(p + J p')1⊗1 − 2Jp𝕀 itself from U' and U''.
//! A law therefore implements the isochoric energy, its Kirchhoff stress and its spatial
//! tangent from b = F Fᵀ and J = det F, and its volumetric function. It must be a plain
//! `Copy` value: the kernel is monomorphised per law (no dynamic dispatch).
//!
//! # Adding a law
//! Write a new file next to `neo_hookean.rs` with a `Copy` struct and
//! `impl Hyperelastic for MyLaw`; check it as `neo_hookean.rs` does (the isochoric
//! stress against the energy, the tangent against the stress by finite differences) and add
//! a hex8 block with the law to `tests/tangent_all_terms.rs`. Nothing in the element changes.

use nalgebra::{Matrix3, Matrix6};

/// A decoupled isotropic hyperelastic law as the hex8 kernel uses it (units kPa).
pub trait Hyperelastic: Copy + std::fmt::Debug + Send + Sync {
    /// Isochoric energy density ψ_iso (per unit reference volume) from b = F Fᵀ and J.
    fn isochoric_energy_from_b(&self, b: &Matrix3<f64>, j: f64) -> f64;

    /// Isochoric Kirchhoff stress τ_iso(b, J) (deviatoric).
    fn isochoric_kirchhoff(&self, b: &Matrix3<f64>, j: f64) -> Matrix3<f64>;

    /// Isochoric Kirchhoff-based spatial tangent 𝕔_iso in Voigt form (order xx, yy, zz,
    /// xy, yz, xz, engineering shear strains); `tau_iso` is
    /// [`Hyperelastic::isochoric_kirchhoff`] of the same (b, J).
    fn isochoric_spatial_tangent(
        &self,
        b: &Matrix3<f64>,
        j: f64,
        tau_iso: &Matrix3<f64>,
    ) -> Matrix6<f64>;

    /// Volumetric energy U(J).
    fn volumetric_energy(&self, j: f64) -> f64;

    /// U'(J), the pressure-like quantity (positive in tension).
    fn volumetric_derivative(&self, j: f64) -> f64;

    /// U''(J).
    fn volumetric_second_derivative(&self, j: f64) -> f64;
}
