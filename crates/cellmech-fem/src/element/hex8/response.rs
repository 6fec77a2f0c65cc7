//! Post-processing of one hex8: volume-averaged Cauchy stress, von Mises stress, maximum
//! principal logarithmic strain, volume ratio and pressure.

use super::{point_pressure, Hex8Formulation, Hex8Reference};
use crate::element::KernelError;
use crate::material::Hyperelastic;
use crate::math::eigen3::max_symmetric_eigenvalue;
use crate::mesh::generate::quality::hex8_corner_jacobians;
use nalgebra::Matrix3;

/// Element-level stress and strain measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hex8Response {
    /// Volume-averaged Cauchy stress σ̄ = (1/v) Σ_q σ_q J_q w₀ = (1/v) Σ_q τ_q w₀ (kPa),
    /// order xx, yy, zz, xy, yz, xz. With mean dilatation the pressure part uses U'(θ).
    pub cauchy: [f64; 6],
    /// von Mises stress of σ̄: √(3/2 s:s), s = dev σ̄ (kPa).
    pub von_mises: f64,
    /// max over Gauss points of ln λ_max, λ_max² the largest eigenvalue of b = F Fᵀ
    /// (the largest principal Hencky strain of V).
    pub max_principal_log_strain: f64,
    /// θ = v / V₀, current over reference element volume.
    pub volume_ratio: f64,
    /// p = −tr(σ̄)/3 (kPa), positive in compression.
    pub pressure: f64,
}

/// Stress and strain measures of one element at displacement `u` (µm, node-major).
/// Errors with [`KernelError::InvertedElement`] when det F ≤ 0 at a Gauss point.
pub fn hex8_response<M: Hyperelastic>(
    reference: &Hex8Reference,
    material: &M,
    formulation: Hex8Formulation,
    u: &[f64; 24],
) -> Result<Hex8Response, KernelError> {
    let (fs, js, v) = reference.kinematics(u)?;
    let theta = v / reference.volume();
    let mut tau_sum = Matrix3::zeros();
    let mut max_log: f64 = f64::NEG_INFINITY;
    for q in 0..8 {
        let j = js[q];
        let b = fs[q] * fs[q].transpose();
        let (p, _) = point_pressure(material, formulation, j, theta);
        let mut tau = material.isochoric_kirchhoff(&b, j);
        for i in 0..3 {
            tau[(i, i)] += j * p;
        }
        tau_sum += tau * reference.weight(q);
        let lam2 = max_symmetric_eigenvalue(&b);
        max_log = max_log.max(0.5 * lam2.ln());
    }
    let s = tau_sum / v;
    let cauchy = [
        s[(0, 0)],
        s[(1, 1)],
        s[(2, 2)],
        s[(0, 1)],
        s[(1, 2)],
        s[(0, 2)],
    ];
    let mean = s.trace() / 3.0;
    let dev = s - Matrix3::identity() * mean;
    let von_mises = (1.5 * dev.component_mul(&dev).sum()).sqrt();
    Ok(Hex8Response {
        cauchy,
        von_mises,
        max_principal_log_strain: max_log,
        volume_ratio: theta,
        pressure: -mean,
    })
}

/// Largest principal logarithmic strain over the Gauss points of the deformation from the
/// state `u_from` to the state `u` (both displacements from the mesh, µm): with
/// `F_rel = F(u) · F(u_from)⁻¹`, the max over Gauss points of `½ ln λ_max(F_rel F_relᵀ)`.
/// Errors when either state inverts the element.
pub fn hex8_max_log_strain_between(
    reference: &Hex8Reference,
    u_from: &[f64; 24],
    u: &[f64; 24],
) -> Result<f64, KernelError> {
    let (fs, _, _) = reference.kinematics(u)?;
    let (fs_from, _, _) = reference.kinematics(u_from)?;
    let mut max_log = f64::NEG_INFINITY;
    for q in 0..8 {
        let inverse = fs_from[q]
            .try_inverse()
            .ok_or(KernelError::InvertedElement { qp: q, det_f: 0.0 })?;
        let f = fs[q] * inverse;
        let b = f * f.transpose();
        max_log = max_log.max(0.5 * max_symmetric_eigenvalue(&b).ln());
    }
    Ok(max_log)
}

/// Smallest ratio, over the 8 corners, of the current to the reference Jacobian determinant
/// det(∂x/∂ξ) / det(∂X/∂ξ) at the corner, for reference node coordinates `x0` (µm) and
/// displacements `u` (µm, node-major): the element's validity as a map.
///
/// The quadrature sees det F only at the Gauss points, which can all stay positive while
/// the trilinear map folds over near a corner (a node pushed past the opposite face); a
/// ratio ≤ 0 means the element's deformed shape is no longer one-to-one, and its stresses
/// are those of an invalid shape. 1 in the reference state and under any rigid motion;
/// det F under a homogeneous deformation.
pub fn hex8_min_corner_jacobian_ratio(x0: &[[f64; 3]; 8], u: &[f64; 24]) -> f64 {
    let x: [[f64; 3]; 8] =
        std::array::from_fn(|a| std::array::from_fn(|i| x0[a][i] + u[3 * a + i]));
    let (current, reference) = (hex8_corner_jacobians(&x), hex8_corner_jacobians(x0));
    (0..8)
        .map(|a| current[a] / reference[a])
        .fold(f64::INFINITY, f64::min)
}
