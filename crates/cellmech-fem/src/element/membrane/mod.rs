//! Large-strain membranes (no bending stiffness): incompressible neo-Hookean plane stress on
//! 4-node bilinear quadrilaterals (2×2 Gauss) and 3-node triangles (1 point).
//!
//! # Formulation
//! At each quadrature point an orthonormal tangent basis `(e₁, e₂)` of the *reference* surface
//! is built from `G_ξ = ∂X/∂ξ`, `G_η = ∂X/∂η` (`e₁ = G_ξ/|G_ξ|`, `n = G_ξ×G_η/|G_ξ×G_η|`,
//! `e₂ = n×e₁`), so curved or warped reference elements are allowed. With local coordinates
//! `s_α` along `e_α`, the current covariant tangents are `g_α = ∂x/∂s_α = Σ_a N_{a,α} x_a` and
//! the in-plane right Cauchy–Green tensor is `C_{αβ} = g_α·g_β` (2×2). Its eigenvalues are the
//! squared principal stretches `λ₁², λ₂²`, and `det C = λ₁²λ₂²`.
//!
//! Incompressibility (`λ₃ = 1/(λ₁λ₂)`) with the plane-stress condition eliminates the
//! pressure, leaving the strain energy per unit reference volume
//!
//! `W(C) = μ/2 (tr C + 1/det C − 3) = μ/2 (λ₁² + λ₂² + λ₁⁻²λ₂⁻² − 3)`,
//!
//! and the element energy `Π_e = ∫ H W dA₀` (reference thickness `H`). The current thickness
//! is `h = H/(λ₁λ₂) = H/√det C`.
//!
//! Residual and tangent are the exact first and second derivatives of `Π_e`. Writing
//! `v = (C₁₁, C₂₂, C₁₂)` and `D = det C = v₁v₂ − v₃²`:
//! `∂W/∂v = μ/2 (1 − C₂₂/D², 1 − C₁₁/D², 2C₁₂/D²)`,
//! `∂²W/∂v² = μ/2 (2 D_v D_vᵀ/D³ − D_vv/D²)` with `D_v = (C₂₂, C₁₁, −2C₁₂)`, and
//! `∂v/∂x_a = (2N_{a,1} g₁, 2N_{a,2} g₂, N_{a,1} g₂ + N_{a,2} g₁)`, whose second derivatives
//! are multiples of the identity (the geometric stiffness). Hence
//! `R_a = Σ_q w_q H Σ_m W_m ∂v_m/∂x_a` and
//! `K_ab = Σ_q w_q H [Σ_mn W_mn ∂v_m/∂x_a ⊗ ∂v_n/∂x_b + Σ_m W_m ∂²v_m/∂x_a∂x_b]`.
//!
//! Principal Cauchy stresses of the incompressible sheet are `σ_i = μ(λ_i² − 1/(λ₁λ₂)²)` and
//! the true tensions (force per current length) `t_i = h σ_i`.
//!
//! With [`MembraneLaw::TensionField`] the sheet carries no compression (a wrinkling
//! membrane): its relaxed energy is the elastic one where both principal stresses are
//! tensile, `μ/2 (λ₁² + 2/λ₁ − 3)` (uniaxial tension along the larger stretch, the width
//! contracting freely to `λ₂ = λ₁^(−1/2)`) where the smaller would be compressive, and 0
//! where `λ₁ ≤ 1`. With `a = λ₁²` the larger eigenvalue of C and
//! `s = √((C₁₁ − C₂₂)² + 4C₁₂²)`: `∂a/∂v = (½(1 + (C₁₁−C₂₂)/s), ½(1 − (C₁₁−C₂₂)/s), 2C₁₂/s)`
//! and `∂²a/∂v²` = (2/s³) [[C₁₂², −C₁₂², −(C₁₁−C₂₂)C₁₂], [·, C₁₂², (C₁₁−C₂₂)C₁₂],
//! [·, ·, (C₁₁−C₂₂)²]], so `W_v = W'(a) a_v`, `W_vv = W''(a) a_v a_vᵀ + W'(a) a_vv`.

mod kernel;
mod set;
#[cfg(test)]
mod tests;

pub use kernel::{
    membrane_evaluate, membrane_state, MembraneLaw, MembranePoint, MembraneReference,
    MembraneState, Quad4Reference, Tri3Reference,
};
pub use set::{MembraneError, MembraneSet};
