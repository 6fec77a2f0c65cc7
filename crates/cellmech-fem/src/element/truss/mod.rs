//! Two-node truss under large displacement, carrying an [`AxialLaw`] (linear, tension-only,
//! prestrained, slack: all laws, one element).
//!
//! Kinematics: with reference nodes `X_a`, `X_b`, displacements `u_a`, `u_b`,
//! `d = X_b + u_b − X_a − u_a`, current length `ℓ = |d|`, unit vector `n = d/ℓ`, initial
//! length `L0 = |X_b − X_a|`. The energy is the law's `W(ℓ; L0)`, so with `N = dW/dℓ` and
//! `k = dN/dℓ`:
//!
//! ```text
//! residual = ∂W/∂(u_a, u_b) = N · (−n, n)
//! tangent  = [ K  −K ]      K = k · n⊗n + (N/ℓ) · (I − n⊗n)
//!            [ −K  K ]
//! ```
//!
//! `K` is the material part `k n⊗n` plus the geometric (stress) part `(N/ℓ)(I − n⊗n)`,
//! which gives a prestressed cable its lateral stiffness. A slack or compressed tension-only
//! element contributes exactly nothing.

mod kernel;
mod set;
#[cfg(test)]
mod tests;

pub use kernel::truss_evaluate;
pub use set::{FamilyStatistics, TrussError, TrussSet, ValueRange};
