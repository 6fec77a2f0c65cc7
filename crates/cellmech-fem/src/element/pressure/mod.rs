//! Uniform pressure on a surface of quads or triangles, as the potential of the enclosed
//! volume: `Π = −p V(x)`.
//!
//! # Volume of a surface
//! By the divergence theorem the volume enclosed by a closed surface with outward normals is
//! `V = 1/3 ∮ x·n dA`, a sum of face contributions
//! `V_e = 1/3 ∫ x·(x_ξ × x_η) dξ dη`. For a bilinear quad the integrand is a polynomial of
//! degree 2 in ξ and in η, so 2×2 Gauss is exact; for a triangle `V_e = x₀·(x₁×x₂)/6`.
//! Either way `V_e` is a cubic form of the nodal positions,
//! `V_e = Σ_abc s_abc ε_ijk x_a^i x_b^j x_c^k`, with `s` antisymmetric in `(a, b, c)`
//! (precomputed once per element kind). Hence
//! `∂V_e/∂x_a^i = 3 Σ_bc s_abc ε_ijk x_b^j x_c^k` and
//! `∂²V_e/∂x_a^i∂x_b^j = 6 Σ_c s_abc ε_ijk x_c^k`,
//! a symmetric Hessian. The residual of `Π` is `−p ∂V/∂x` (the follower pressure load) and
//! its tangent `−p ∂²V/∂x²` (the load stiffness).
//!
//! # Closed and open surfaces
//! The sum of `V_e` equals the enclosed volume, and `−p ∂V/∂x` the nodal pressure forces
//! `p ∫ N_a n da`, only when the surface is closed. For an open surface the two differ by
//! terms from the missing closing faces: the load is then conservative and exact only when the
//! boundary nodes are fixed, or when the boundary lies in planes through the origin and its
//! nodes stay in them (symmetry planes through the centre: closing faces there add
//! `x·n = 0`). Then the tangent is the exact, symmetric Hessian of the true potential.
//!
//! # Load control
//! [`PressureLoad`] applies a prescribed pressure held in a [`PressureHandle`] that the caller
//! may change between steps (the solver ramps only nodal loads and motions, so a new pressure
//! is applied in full at the first increment of a step). [`VolumeControl`] instead prescribes
//! the enclosed volume through an auxiliary node and makes the pressure a Lagrange multiplier,
//! which passes limit points (balloon inflation) with the ordinary displacement control.

mod load;
mod surface;
#[cfg(test)]
mod tests;

pub use load::{PressureHandle, PressureLoad, VolumeControl};
pub use surface::{PressureError, SurfaceVolume};
