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

/// How a membrane answers in-plane compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MembraneLaw {
    /// The neo-Hookean sheet as it is: it carries compressive stresses (and, having no
    /// bending stiffness, can only be kept from buckling by what it lies on).
    #[default]
    Elastic,
    /// Tension field (wrinkling): the relaxed energy of the sheet, which carries no
    /// compression. Where the smaller principal stress of the elastic law would be
    /// compressive the sheet wrinkles across it and is in uniaxial tension along the larger
    /// stretch, `W = μ/2 (λ₁² + 2/λ₁ − 3)` (the width contracts freely to `λ₂ = λ₁^(−1/2)`);
    /// where `λ₁ ≤ 1` too it is slack (`W = 0`). Continuous with its first derivatives at
    /// both boundaries.
    TensionField,
}

/// The state of the sheet at one point under a law.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SheetState {
    Taut,
    Wrinkled,
    Slack,
}

/// Below this spread of the two eigenvalues of C (relative to their mean) the larger one's
/// second derivatives are singular; the sheet is then taut or slack, never wrinkled
/// (wrinkling needs `λ₂ < λ₁^(−1/2) < λ₁`, i.e. distinct eigenvalues away from `λ₁ = 1`).
const EQUAL_EIGENVALUES: f64 = 1e-12;

/// The state of the sheet at `v = (C₁₁, C₂₂, C₁₂)`, and the larger eigenvalue `a = λ₁²` of C
/// with the root `s = √((C₁₁ − C₂₂)² + 4C₁₂²)` of the eigenvalue spread.
fn sheet_state(law: MembraneLaw, v: &[f64; 3], d: f64) -> (SheetState, f64, f64) {
    let s = ((v[0] - v[1]).powi(2) + 4.0 * v[2] * v[2]).sqrt();
    let a = 0.5 * (v[0] + v[1] + s);
    if law == MembraneLaw::Elastic {
        return (SheetState::Taut, a, s);
    }
    // Smaller principal stress of the elastic law, S₂ ∝ 1 − 1/(λ₂² D), with λ₂² = D/a.
    let b = d / a;
    if b * d > 1.0 || s <= EQUAL_EIGENVALUES * (v[0] + v[1]) {
        if a <= 1.0 && b * d <= 1.0 {
            return (SheetState::Slack, a, s);
        }
        return (SheetState::Taut, a, s);
    }
    if a > 1.0 {
        (SheetState::Wrinkled, a, s)
    } else {
        (SheetState::Slack, a, s)
    }
}

/// Strain energy per unit reference volume `W` of the sheet under `law`, with its first and
/// second derivatives with respect to `v = (C₁₁, C₂₂, C₁₂)` (the tangent's material part
/// when `second` is asked).
fn sheet_energy(
    law: MembraneLaw,
    mu: f64,
    v: &[f64; 3],
    qp: usize,
    second: bool,
) -> Result<(f64, [f64; 3], [[f64; 3]; 3]), KernelError> {
    let d = det_c(v, qp)?;
    let half_mu = 0.5 * mu;
    let mut w_vv = [[0.0; 3]; 3];
    match sheet_state(law, v, d) {
        (SheetState::Taut, _, _) => {
            let d2 = d * d;
            let w_v = [
                half_mu * (1.0 - v[1] / d2),
                half_mu * (1.0 - v[0] / d2),
                half_mu * 2.0 * v[2] / d2,
            ];
            if second {
                let d_v = [v[1], v[0], -2.0 * v[2]];
                let d_vv = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -2.0]];
                w_vv = std::array::from_fn(|m| {
                    std::array::from_fn(|n| {
                        half_mu * (2.0 * d_v[m] * d_v[n] / (d2 * d) - d_vv[m][n] / d2)
                    })
                });
            }
            Ok((half_mu * (v[0] + v[1] + 1.0 / d - 3.0), w_v, w_vv))
        }
        (SheetState::Wrinkled, a, s) => {
            // W(a) = μ/2 (a + 2 a^(−1/2) − 3) with a the larger eigenvalue of C.
            let dw = half_mu * (1.0 - a.powf(-1.5));
            let diff = v[0] - v[1];
            let a_v = [
                0.5 * (1.0 + diff / s),
                0.5 * (1.0 - diff / s),
                2.0 * v[2] / s,
            ];
            let w_v = a_v.map(|x| dw * x);
            if second {
                let ddw = half_mu * 1.5 * a.powf(-2.5);
                let s3 = s * s * s;
                let (c, e) = (2.0 * v[2] * v[2] / s3, 2.0 * diff * v[2] / s3);
                let a_vv = [[c, -c, -e], [-c, c, e], [-e, e, 2.0 * diff * diff / s3]];
                w_vv = std::array::from_fn(|m| {
                    std::array::from_fn(|n| ddw * a_v[m] * a_v[n] + dw * a_vv[m][n])
                });
            }
            Ok((half_mu * (a + 2.0 / a.sqrt() - 3.0), w_v, w_vv))
        }
        (SheetState::Slack, _, _) => Ok((0.0, [0.0; 3], w_vv)),
    }
}

/// Energy, residual (`3N`) and tangent (`3N × 3N`, row-major) of a membrane element with `N`
/// nodes and `Q` quadrature points under `law`: `Π_e = Σ_q w_q H W(C_q)` with shear modulus
/// `mu` (kPa), reference thickness `thickness` (µm) and nodal displacements `u` (µm,
/// node-major).
pub fn membrane_evaluate<const N: usize, const Q: usize>(
    reference: &MembraneReference<N, Q>,
    law: MembraneLaw,
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
        let scale = point.weight * thickness;
        let (w, w_v, w_vv) = sheet_energy(law, mu, &v, qp, tangent.is_some())?;
        energy += scale * w;
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

/// Averages the state of an element under `law` over its quadrature points (weights
/// `w_q dA₀`). A wrinkled point has the tension of the uniaxial sheet, `t₁ = h μ (λ₁² − 1/λ₁)`
/// with `h = H λ₁^(−1/2)`, and `t₂ = 0`; a slack one none; the thickness is that of the sheet
/// between the wrinkles, the area stretch the surface's.
pub fn membrane_state<const N: usize, const Q: usize>(
    reference: &MembraneReference<N, Q>,
    law: MembraneLaw,
    mu: f64,
    thickness: f64,
    u: &[f64],
) -> Result<MembraneState, KernelError> {
    let mut acc = [0.0; 4];
    let mut total = 0.0;
    for (qp, point) in reference.points.iter().enumerate() {
        let (_, v) = tangents(&reference.x0, point, u);
        let d = det_c(&v, qp)?;
        let values = match sheet_state(law, &v, d) {
            (SheetState::Taut, _, _) => {
                let mean = 0.5 * (v[0] + v[1]);
                let radius = (0.25 * (v[0] - v[1]).powi(2) + v[2] * v[2]).sqrt();
                let h = thickness / d.sqrt();
                [
                    h * mu * (mean + radius - 1.0 / d),
                    h * mu * (mean - radius - 1.0 / d),
                    h,
                    d.sqrt(),
                ]
            }
            (SheetState::Wrinkled, a, _) => {
                let h = thickness * a.powf(-0.25);
                [h * mu * (a - 1.0 / a.sqrt()), 0.0, h, d.sqrt()]
            }
            (SheetState::Slack, _, _) => [0.0, 0.0, thickness, d.sqrt()],
        };
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
