//! The truss kernel: energy, residual and tangent of one two-node element under an
//! [`AxialLaw`] (see the module notes of [`crate::element::truss`]).

use crate::element::KernelError;
use crate::material::{AxialLaw, AxialResponse};
use crate::math::vec3::{distance, norm};

/// Energy (nN·µm), residual (6) and row-major tangent (6×6) of one truss.
///
/// `x0a`, `x0b`: initial node positions (µm); `u`: displacements `(u_a, u_b)` (µm). Fails
/// with [`KernelError::DegenerateReference`] when `L0 = 0` (`det_j0` holds `L0`) and with
/// [`KernelError::InvertedElement`] when the current length is 0 (`det_f` holds `ℓ/L0`).
#[allow(non_snake_case)]
pub fn truss_evaluate(
    law: &AxialLaw,
    x0a: &[f64; 3],
    x0b: &[f64; 3],
    u: &[f64],
    residual: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> Result<f64, KernelError> {
    let (response, n, l) = truss_state(law, x0a, x0b, u)?;
    let N = response.force;
    for i in 0..3 {
        residual[i] = -N * n[i];
        residual[3 + i] = N * n[i];
    }
    if let Some(t) = tangent {
        let geometric = N / l;
        for i in 0..3 {
            for j in 0..3 {
                let nn = n[i] * n[j];
                let delta = if i == j { 1.0 } else { 0.0 };
                let kij = response.stiffness * nn + geometric * (delta - nn);
                t[i * 6 + j] = kij;
                t[(i + 3) * 6 + j + 3] = kij;
                t[i * 6 + j + 3] = -kij;
                t[(i + 3) * 6 + j] = -kij;
            }
        }
    }
    Ok(response.energy)
}

/// The law's response, the unit vector `n` and the current length `ℓ` of one truss.
pub(super) fn truss_state(
    law: &AxialLaw,
    x0a: &[f64; 3],
    x0b: &[f64; 3],
    u: &[f64],
) -> Result<(AxialResponse, [f64; 3], f64), KernelError> {
    let l0 = distance(x0a, x0b);
    if l0.is_nan() || l0 <= 0.0 {
        return Err(KernelError::DegenerateReference { qp: 0, det_j0: l0 });
    }
    let d: [f64; 3] = std::array::from_fn(|i| x0b[i] + u[3 + i] - x0a[i] - u[i]);
    let l = norm(&d);
    if l.is_nan() || l <= 0.0 {
        return Err(KernelError::InvertedElement {
            qp: 0,
            det_f: l / l0,
        });
    }
    let n = std::array::from_fn(|i| d[i] / l);
    Ok((law.evaluate(l, l0), n, l))
}
