//! The membrane kernels: reference geometry of quadrature points, energy, residual and
//! tangent of one quad4 or tri3, and the element state for outputs (see the module notes
//! of [`crate::element::membrane`]).

use crate::element::KernelError;
use crate::math::vec3::{cross, dot, norm, sub};

/// Reference data of one membrane quadrature point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MembranePoint<const N: usize> {
    /// `∂N_a/∂s_α`: shape-function gradients along the local orthonormal tangent basis.
    pub grad: [[f64; 2]; N],
    /// Quadrature weight times the reference area Jacobian, `w_q |G_ξ × G_η|` (µm²).
    pub weight: f64,
}

/// Precomputed reference geometry of one membrane element with `N` nodes and `Q` points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MembraneReference<const N: usize, const Q: usize> {
    /// Reference node coordinates (µm).
    pub x0: [[f64; 3]; N],
    /// Quadrature points.
    pub points: [MembranePoint<N>; Q],
}

/// Reference data of a bilinear quadrilateral (2×2 Gauss).
pub type Quad4Reference = MembraneReference<4, 4>;
/// Reference data of a linear triangle (1 point).
pub type Tri3Reference = MembraneReference<3, 1>;

const QUAD_CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Builds the local basis at one point from the parametric derivatives `dn[a] = (N_ξ, N_η)`,
/// returning the gradients along the basis and `|G_ξ × G_η|`. `reference_normal` (the
/// element's mean normal) detects folded (bow-tie) elements.
fn reference_point<const N: usize>(
    x0: &[[f64; 3]; N],
    dn: &[[f64; 2]; N],
    reference_normal: &[f64; 3],
    qp: usize,
) -> Result<([[f64; 2]; N], f64), KernelError> {
    let mut gx = [0.0; 3];
    let mut ge = [0.0; 3];
    for a in 0..N {
        for i in 0..3 {
            gx[i] += dn[a][0] * x0[a][i];
            ge[i] += dn[a][1] * x0[a][i];
        }
    }
    let normal = cross(&gx, &ge);
    let area = norm(&normal);
    let scale = norm(&gx) * norm(&ge);
    let degenerate = KernelError::DegenerateReference { qp, det_j0: area };
    if area.is_nan() || area <= 1e-12 * scale || !area.is_finite() {
        return Err(degenerate);
    }
    let alignment = dot(&normal, reference_normal);
    if alignment.is_nan() || alignment <= 0.0 {
        return Err(KernelError::DegenerateReference {
            qp,
            det_j0: alignment / norm(reference_normal).max(f64::MIN_POSITIVE),
        });
    }
    let e1: [f64; 3] = std::array::from_fn(|i| gx[i] / norm(&gx));
    let n: [f64; 3] = std::array::from_fn(|i| normal[i] / area);
    let e2 = cross(&n, &e1);
    // J[α][j] = ∂s_α/∂ξ_j; gradients along s: J⁻ᵀ (N_ξ, N_η).
    let (j11, j12, j21, j22) = (dot(&gx, &e1), dot(&ge, &e1), dot(&gx, &e2), dot(&ge, &e2));
    let det = j11 * j22 - j12 * j21;
    let mut grad = [[0.0; 2]; N];
    for a in 0..N {
        let (nx, ne) = (dn[a][0], dn[a][1]);
        grad[a] = [(j22 * nx - j21 * ne) / det, (-j12 * nx + j11 * ne) / det];
    }
    Ok((grad, area))
}

impl Quad4Reference {
    /// Precomputes the 2×2 Gauss points of a quadrilateral with nodes `x0` (counter-clockwise
    /// around its normal). Errors with [`KernelError::DegenerateReference`] when the area
    /// Jacobian vanishes or the element folds over (normal reversing inside it).
    pub fn new(x0: [[f64; 3]; 4]) -> Result<Self, KernelError> {
        let g = 1.0 / 3f64.sqrt();
        let mean_normal = cross(&sub(&x0[2], &x0[0]), &sub(&x0[3], &x0[1]));
        let mut points = [MembranePoint {
            grad: [[0.0; 2]; 4],
            weight: 0.0,
        }; 4];
        for (qp, point) in points.iter_mut().enumerate() {
            let [xi, eta] = [QUAD_CORNERS[qp][0] * g, QUAD_CORNERS[qp][1] * g];
            let dn: [[f64; 2]; 4] = std::array::from_fn(|a| {
                let [xa, ea] = QUAD_CORNERS[a];
                [0.25 * xa * (1.0 + eta * ea), 0.25 * ea * (1.0 + xi * xa)]
            });
            let (grad, area) = reference_point(&x0, &dn, &mean_normal, qp)?;
            *point = MembranePoint { grad, weight: area };
        }
        Ok(MembraneReference { x0, points })
    }
}

impl Tri3Reference {
    /// Precomputes the single centroid point of a triangle with nodes `x0`. Errors with
    /// [`KernelError::DegenerateReference`] when the three nodes are (nearly) collinear.
    pub fn new(x0: [[f64; 3]; 3]) -> Result<Self, KernelError> {
        let dn = [[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]];
        let mean_normal = cross(&sub(&x0[1], &x0[0]), &sub(&x0[2], &x0[0]));
        let (grad, area) = reference_point(&x0, &dn, &mean_normal, 0)?;
        Ok(MembraneReference {
            x0,
            points: [MembranePoint {
                grad,
                weight: 0.5 * area,
            }],
        })
    }
}

/// Current tangents `g₁, g₂` and `v = (C₁₁, C₂₂, C₁₂)` at one point.
fn tangents<const N: usize>(
    x0: &[[f64; 3]; N],
    point: &MembranePoint<N>,
    u: &[f64],
) -> ([[f64; 3]; 2], [f64; 3]) {
    let mut g = [[0.0; 3]; 2];
    for a in 0..N {
        for i in 0..3 {
            let x = x0[a][i] + u[3 * a + i];
            g[0][i] += point.grad[a][0] * x;
            g[1][i] += point.grad[a][1] * x;
        }
    }
    let v = [dot(&g[0], &g[0]), dot(&g[1], &g[1]), dot(&g[0], &g[1])];
    (g, v)
}

fn det_c(v: &[f64; 3], qp: usize) -> Result<f64, KernelError> {
    let d = v[0] * v[1] - v[2] * v[2];
    if d > 0.0 && d.is_finite() {
        Ok(d)
    } else {
        Err(KernelError::InvertedElement {
            qp,
            det_f: d.max(0.0).sqrt(),
        })
    }
}

fn membrane_evaluate<const N: usize, const Q: usize>(
    reference: &MembraneReference<N, Q>,
    mu: f64,
    thickness: f64,
    u: &[f64],
    residual: &mut [f64],
    mut tangent: Option<&mut [f64]>,
) -> Result<f64, KernelError> {
    let nd = 3 * N;
    residual[..nd].fill(0.0);
    if let Some(t) = tangent.as_deref_mut() {
        t[..nd * nd].fill(0.0);
    }
    let mut energy = 0.0;
    for (qp, point) in reference.points.iter().enumerate() {
        let (g, v) = tangents(&reference.x0, point, u);
        let d = det_c(&v, qp)?;
        let scale = point.weight * thickness;
        let half_mu = 0.5 * mu;
        energy += scale * half_mu * (v[0] + v[1] + 1.0 / d - 3.0);
        let d2 = d * d;
        let w_v = [
            half_mu * (1.0 - v[1] / d2),
            half_mu * (1.0 - v[0] / d2),
            half_mu * 2.0 * v[2] / d2,
        ];
        // b[m][a] = ∂v_m/∂x_a
        let mut b = [[[0.0; 3]; N]; 3];
        for a in 0..N {
            let [n1, n2] = point.grad[a];
            for i in 0..3 {
                b[0][a][i] = 2.0 * n1 * g[0][i];
                b[1][a][i] = 2.0 * n2 * g[1][i];
                b[2][a][i] = n1 * g[1][i] + n2 * g[0][i];
                residual[3 * a + i] += scale * (0..3).map(|m| w_v[m] * b[m][a][i]).sum::<f64>();
            }
        }
        if let Some(t) = tangent.as_deref_mut() {
            let d_v = [v[1], v[0], -2.0 * v[2]];
            let d_vv = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -2.0]];
            let w_vv: [[f64; 3]; 3] = std::array::from_fn(|m| {
                std::array::from_fn(|n| {
                    half_mu * (2.0 * d_v[m] * d_v[n] / (d2 * d) - d_vv[m][n] / d2)
                })
            });
            for a in 0..N {
                let [a1, a2] = point.grad[a];
                // B_m(a) contracted with W_vv once, reused for every b.
                let wb: [[f64; 3]; 3] = std::array::from_fn(|n| {
                    std::array::from_fn(|i| (0..3).map(|m| w_vv[m][n] * b[m][a][i]).sum())
                });
                for bn in 0..N {
                    let [b1, b2] = point.grad[bn];
                    let geometric = 2.0 * w_v[0] * a1 * b1
                        + 2.0 * w_v[1] * a2 * b2
                        + w_v[2] * (a1 * b2 + a2 * b1);
                    for i in 0..3 {
                        for j in 0..3 {
                            let mut k: f64 = (0..3).map(|n| wb[n][i] * b[n][bn][j]).sum();
                            if i == j {
                                k += geometric;
                            }
                            t[(3 * a + i) * nd + 3 * bn + j] += scale * k;
                        }
                    }
                }
            }
        }
    }
    Ok(energy)
}

/// Energy, residual (12) and tangent (12×12, row-major) of a bilinear membrane quadrilateral:
/// `Π_e = Σ_q w_q H μ/2 (tr C + 1/det C − 3)` with shear modulus `mu` (kPa), reference
/// thickness `thickness` (µm) and nodal displacements `u` (µm, node-major).
pub fn membrane_quad4_evaluate(
    reference: &Quad4Reference,
    mu: f64,
    thickness: f64,
    u: &[f64],
    residual: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> Result<f64, KernelError> {
    membrane_evaluate(reference, mu, thickness, u, residual, tangent)
}

/// Energy, residual (9) and tangent (9×9, row-major) of a constant-strain membrane triangle;
/// same law and arguments as [`membrane_quad4_evaluate`].
pub fn membrane_tri3_evaluate(
    reference: &Tri3Reference,
    mu: f64,
    thickness: f64,
    u: &[f64],
    residual: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> Result<f64, KernelError> {
    membrane_evaluate(reference, mu, thickness, u, residual, tangent)
}

/// Area-weighted element averages of the membrane state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MembraneState {
    /// True principal tensions `t_i = h μ (λ_i² − 1/(λ₁λ₂)²)` (nN/µm), largest first.
    pub principal_tensions: [f64; 2],
    /// Current thickness `h = H/(λ₁λ₂)` (µm).
    pub thickness: f64,
    /// Area stretch `λ₁λ₂ = √det C`.
    pub area_stretch: f64,
}

/// Averages the state of an element over its quadrature points (weights `w_q dA₀`).
pub fn membrane_state<const N: usize, const Q: usize>(
    reference: &MembraneReference<N, Q>,
    mu: f64,
    thickness: f64,
    u: &[f64],
) -> Result<MembraneState, KernelError> {
    let mut acc = [0.0; 4];
    let mut total = 0.0;
    for (qp, point) in reference.points.iter().enumerate() {
        let (_, v) = tangents(&reference.x0, point, u);
        let d = det_c(&v, qp)?;
        let mean = 0.5 * (v[0] + v[1]);
        let radius = (0.25 * (v[0] - v[1]).powi(2) + v[2] * v[2]).sqrt();
        let h = thickness / d.sqrt();
        let values = [
            h * mu * (mean + radius - 1.0 / d),
            h * mu * (mean - radius - 1.0 / d),
            h,
            d.sqrt(),
        ];
        for (s, x) in acc.iter_mut().zip(values) {
            *s += point.weight * x;
        }
        total += point.weight;
    }
    Ok(MembraneState {
        principal_tensions: [acc[0] / total, acc[1] / total],
        thickness: acc[2] / total,
        area_stretch: acc[3] / total,
    })
}
