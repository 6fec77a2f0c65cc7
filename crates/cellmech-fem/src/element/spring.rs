//! Two-node axial spring with a linear force–elongation law under large displacement:
//! Π = k/2 (ℓ − L)², ℓ = |x₂ − x₁|. Used as elastic supports and as the simplest
//! geometrically nonlinear term for solver tests.

use super::ElementSet;
use super::KernelError;
use crate::math::vec3::norm;

/// Energy, residual (6) and tangent (6×6, row-major) of a spring of stiffness `k` (nN/µm)
/// and rest length `rest_length` between reference points `x0a`, `x0b`, displaced by `u`.
#[allow(non_snake_case)]
pub fn spring_evaluate(
    k: f64,
    rest_length: f64,
    x0a: &[f64; 3],
    x0b: &[f64; 3],
    u: &[f64],
    residual: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> Result<f64, KernelError> {
    let d: [f64; 3] = std::array::from_fn(|i| x0b[i] + u[3 + i] - x0a[i] - u[i]);
    let l = norm(&d);
    if l == 0.0 {
        return Err(KernelError::InvertedElement { qp: 0, det_f: 0.0 });
    }
    let n: [f64; 3] = std::array::from_fn(|i| d[i] / l);
    let N = k * (l - rest_length);
    for i in 0..3 {
        residual[i] = -N * n[i];
        residual[3 + i] = N * n[i];
    }
    if let Some(t) = tangent {
        for i in 0..3 {
            for j in 0..3 {
                let delta = if i == j { 1.0 } else { 0.0 };
                let kij = k * n[i] * n[j] + N / l * (delta - n[i] * n[j]);
                t[i * 6 + j] = kij;
                t[(i + 3) * 6 + j + 3] = kij;
                t[i * 6 + j + 3] = -kij;
                t[(i + 3) * 6 + j] = -kij;
            }
        }
    }
    Ok(0.5 * k * (l - rest_length).powi(2))
}

/// A set of two-node springs, each with its stiffness (nN/µm) and rest length (µm).
#[derive(Debug, Clone)]
pub struct SpringSet {
    /// Name of the set.
    pub name: String,
    /// Node pairs.
    pub nodes: Vec<[usize; 2]>,
    /// Reference coordinates of the node pairs.
    pub reference: Vec<[[f64; 3]; 2]>,
    /// Stiffness of each spring.
    pub stiffness: Vec<f64>,
    /// Rest length of each spring.
    pub rest_length: Vec<f64>,
}

impl ElementSet for SpringSet {
    const ELEMENT_DOFS: usize = 6;

    fn set_name(&self) -> &str {
        &self.name
    }

    fn element_count(&self) -> usize {
        self.nodes.len()
    }

    fn element_nodes(&self, e: usize) -> &[usize] {
        &self.nodes[e]
    }

    fn evaluate_element(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let [a, b] = &self.reference[e];
        spring_evaluate(
            self.stiffness[e],
            self.rest_length[e],
            a,
            b,
            u_e,
            residual,
            tangent,
        )
    }
}
