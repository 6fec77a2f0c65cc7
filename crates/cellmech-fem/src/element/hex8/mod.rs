//! 8-node trilinear hexahedron, total Lagrangian, 2×2×2 Gauss quadrature, carrying any
//! decoupled hyperelastic law ([`Hyperelastic`], e.g. [`NeoHookean`](crate::material::NeoHookean)).
//! The kernel is generic over the law (monomorphised, no dynamic dispatch).
//!
//! Node order (Abaqus C3D8 / Gmsh): nodes 0–3 are the ζ = −1 face counter-clockwise seen
//! from +ζ, nodes 4–7 the ζ = +1 face in the same order; natural coordinates
//! (−1,−1,−1), (1,−1,−1), (1,1,−1), (−1,1,−1), then the same with ζ = +1.
//!
//! # Formulations
//!
//! With w₀ the quadrature weight times det J₀ (reference volume weight), F_q the deformation
//! gradient at Gauss point q, J_q = det F_q, V₀ = Σ w₀ and v = Σ J_q w₀ (current volume):
//!
//! * [`Hex8Formulation::MeanDilatation`] (Q1P0, energy-consistent, locking-free):
//!   Π = Σ_q ψ_iso(F_q) w₀ + V₀ U(θ), θ = v / V₀.
//! * [`Hex8Formulation::Displacement`] (plain, locks for K ≫ G):
//!   Π = Σ_q (ψ_iso(F_q) + U(J_q)) w₀.
//!
//! # Residual and tangent (exact derivatives of Π)
//!
//! With spatial gradients ∇N_a = F⁻ᵀ ∇₀N_a and Kirchhoff stress τ_q = τ_iso + J_q p_q 1:
//!
//! ```text
//! f_a = Σ_q τ_q ∇N_a w₀
//! K_ab = Σ_q [ B_aᵀ 𝔻_q B_b + (∇N_a · τ_q ∇N_b) 1 ] w₀  (+ U''(θ)/V₀ g gᵀ for Q1P0)
//! 𝔻_q = 𝕔_iso + J(p + J p̂') 1⊗1 − 2 J p 𝕀       (Voigt, Kirchhoff-based)
//! ```
//!
//! where B_a is the 6×3 symmetric-gradient matrix of ∇N_a. Displacement: p_q = U'(J_q),
//! p̂' = U''(J_q). Mean dilatation: p = U'(θ) at every point, p̂' = 0, and the coupling term
//! uses g_a = ∂v/∂x_a = Σ_q J_q ∇N_a w₀. For p constant, the volumetric part of the
//! pointwise formula equals p ∂²v/∂x_ai∂x_bj = p Σ J [(∇N_a)_i(∇N_b)_j − (∇N_a)_j(∇N_b)_i]w₀,
//! so the tangent is the exact Hessian (symmetric). See `docs/continuum-element.md`.

mod response;
#[cfg(test)]
mod tests;

pub use response::{
    hex8_max_log_strain_between, hex8_min_corner_jacobian_ratio, hex8_response, Hex8Response,
};

use super::KernelError;
use crate::material::Hyperelastic;
use nalgebra::Matrix3;

/// Which treatment of the volumetric energy the hex8 uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Hex8Formulation {
    /// Q1P0 mean dilatation: U evaluated once per element at θ = v/V₀ (locking-free).
    #[default]
    MeanDilatation,
    /// Plain fully integrated displacement element: U(J) at each Gauss point (locks).
    Displacement,
}

/// Natural coordinates of the 8 nodes (Abaqus/Gmsh order).
pub use crate::mesh::surface::HEX8_CORNERS as NODE_NATURAL;

/// Precomputed reference data of one element: ∇₀N_a = ∂N_a/∂X at the 8 Gauss points,
/// the weights w·det J₀ (µm³) and the reference volume V₀ (µm³).
#[derive(Debug, Clone, PartialEq)]
pub struct Hex8Reference {
    /// grads[q][a] = ∂N_a/∂X at Gauss point q (1/µm).
    grads: [[[f64; 3]; 8]; 8],
    /// weights[q] = w_q det J₀(ξ_q) (µm³); the 2×2×2 rule has w_q = 1.
    weights: [f64; 8],
    /// V₀ = Σ_q weights[q] (µm³).
    volume: f64,
}

impl Hex8Reference {
    /// Precomputes reference gradients from the reference node coordinates `x0` (µm).
    ///
    /// Gauss points ξ_q = NODE_NATURAL[q] / √3. Fails with
    /// [`KernelError::DegenerateReference`] when det J₀ ≤ 0 (or is not finite) at a point,
    /// typically a wrong node order or a collapsed element.
    pub fn new(x0: &[[f64; 3]; 8]) -> Result<Self, KernelError> {
        let g = 1.0 / 3f64.sqrt();
        let mut grads = [[[0.0; 3]; 8]; 8];
        let mut weights = [0.0; 8];
        for q in 0..8 {
            let xi = NODE_NATURAL[q].map(|s| s * g);
            let dn = natural_gradients(xi);
            // J0_ij = ∂X_i/∂ξ_j
            let mut j0 = Matrix3::<f64>::zeros();
            for a in 0..8 {
                for i in 0..3 {
                    for j in 0..3 {
                        j0[(i, j)] += x0[a][i] * dn[a][j];
                    }
                }
            }
            let det = j0.determinant();
            let inv = if det.is_finite() && det > 0.0 {
                j0.try_inverse()
            } else {
                None
            };
            let Some(inv) = inv else {
                return Err(KernelError::DegenerateReference { qp: q, det_j0: det });
            };
            // ∂N/∂X_k = Σ_j ∂N/∂ξ_j (J0⁻¹)_jk
            for a in 0..8 {
                for k in 0..3 {
                    grads[q][a][k] = (0..3).map(|j| dn[a][j] * inv[(j, k)]).sum();
                }
            }
            weights[q] = det;
        }
        let volume = weights.iter().sum();
        Ok(Self {
            grads,
            weights,
            volume,
        })
    }

    /// Reference volume V₀ (µm³), exact for a trilinear hexahedron.
    pub fn volume(&self) -> f64 {
        self.volume
    }

    /// Reference gradients ∂N_a/∂X at Gauss point `q` (1/µm), indexed `[a][k]`.
    pub fn gradients(&self, q: usize) -> &[[f64; 3]; 8] {
        &self.grads[q % 8]
    }

    /// Quadrature weight times det J₀ at Gauss point `q` (µm³).
    pub fn weight(&self, q: usize) -> f64 {
        self.weights[q % 8]
    }

    /// Deformation gradients and their determinants at the 8 Gauss points, plus the current
    /// volume v = Σ J w₀; errors with [`KernelError::InvertedElement`] when some J ≤ 0.
    pub(crate) fn kinematics(&self, u: &[f64; 24]) -> Result<Kinematics, KernelError> {
        let mut fs = [Matrix3::<f64>::identity(); 8];
        let mut js = [0.0; 8];
        let mut v = 0.0;
        for q in 0..8 {
            let f = &mut fs[q];
            for (a, ga) in self.grads[q].iter().enumerate() {
                for i in 0..3 {
                    let ui = u[3 * a + i];
                    for k in 0..3 {
                        f[(i, k)] += ui * ga[k];
                    }
                }
            }
            let j = f.determinant();
            if j.is_nan() || j <= 0.0 {
                return Err(KernelError::InvertedElement { qp: q, det_f: j });
            }
            js[q] = j;
            v += j * self.weights[q];
        }
        Ok((fs, js, v))
    }
}

/// Deformation gradients F_q, determinants J_q at the 8 Gauss points and the current
/// element volume v = Σ J_q w₀_q (µm³).
pub(crate) type Kinematics = ([Matrix3<f64>; 8], [f64; 8], f64);

/// ∂N_a/∂ξ at natural point `xi` for the trilinear shape functions
/// N_a = (1 + ξ ξ_a)(1 + η η_a)(1 + ζ ζ_a) / 8.
fn natural_gradients(xi: [f64; 3]) -> [[f64; 3]; 8] {
    let mut out = [[0.0; 3]; 8];
    for (a, n) in NODE_NATURAL.iter().enumerate() {
        let f = [1.0 + xi[0] * n[0], 1.0 + xi[1] * n[1], 1.0 + xi[2] * n[2]];
        out[a] = [
            n[0] * f[1] * f[2] / 8.0,
            f[0] * n[1] * f[2] / 8.0,
            f[0] * f[1] * n[2] / 8.0,
        ];
    }
    out
}

/// Spatial gradients ∇N_a = F⁻ᵀ ∇₀N_a, i.e. (∇N_a)_i = Σ_k (∇₀N_a)_k (F⁻¹)_ki.
#[inline]
pub(crate) fn spatial_gradients(grads: &[[f64; 3]; 8], finv: &Matrix3<f64>) -> [[f64; 3]; 8] {
    let mut out = [[0.0; 3]; 8];
    for a in 0..8 {
        let g0 = grads[a];
        for i in 0..3 {
            out[a][i] = g0[0] * finv[(0, i)] + g0[1] * finv[(1, i)] + g0[2] * finv[(2, i)];
        }
    }
    out
}

/// Volumetric pressure p (= U') used at a Gauss point and its local derivative p̂'.
#[inline]
pub(crate) fn point_pressure<M: Hyperelastic>(
    material: &M,
    formulation: Hex8Formulation,
    j: f64,
    theta: f64,
) -> (f64, f64) {
    match formulation {
        Hex8Formulation::Displacement => (
            material.volumetric_derivative(j),
            material.volumetric_second_derivative(j),
        ),
        Hex8Formulation::MeanDilatation => (material.volumetric_derivative(theta), 0.0),
    }
}

/// Energy, internal force and (optionally) the exact tangent of one hex8 element.
///
/// * `u`: nodal displacements (µm), node-major `[u0x, u0y, u0z, u1x, …]`.
/// * `residual` (overwritten): internal force f = ∂Π/∂u (nN), same layout.
/// * `tangent` (overwritten when `Some`): K = ∂²Π/∂u² (nN/µm), row-major 24×24,
///   entry (3a+i, 3b+j).
///
/// Returns the element strain energy Π (nN·µm). Errors with
/// [`KernelError::InvertedElement`] when det F ≤ 0 at a Gauss point (the outputs are then
/// unspecified). No heap allocation.
pub fn hex8_evaluate<M: Hyperelastic>(
    reference: &Hex8Reference,
    material: &M,
    formulation: Hex8Formulation,
    u: &[f64; 24],
    residual: &mut [f64; 24],
    mut tangent: Option<&mut [f64; 576]>,
) -> Result<f64, KernelError> {
    let (fs, js, v) = reference.kinematics(u)?;
    let v0 = reference.volume;
    let theta = v / v0;
    if theta.is_nan() || theta <= 0.0 {
        return Err(KernelError::InvertedElement {
            qp: 0,
            det_f: theta,
        });
    }
    residual.fill(0.0);
    if let Some(k) = tangent.as_deref_mut() {
        k.fill(0.0);
    }
    let mut energy = 0.0;
    let mut dvdx = [0.0; 24];
    for q in 0..8 {
        let f = &fs[q];
        let j = js[q];
        let w = reference.weights[q];
        let Some(finv) = f.try_inverse() else {
            return Err(KernelError::InvertedElement { qp: q, det_f: j });
        };
        let g = spatial_gradients(&reference.grads[q], &finv);
        let b = f * f.transpose();
        let tau_iso = material.isochoric_kirchhoff(&b, j);
        energy += material.isochoric_energy_from_b(&b, j) * w;
        if formulation == Hex8Formulation::Displacement {
            energy += material.volumetric_energy(j) * w;
        }
        let (p, dp) = point_pressure(material, formulation, j, theta);
        let mut tau = tau_iso;
        for i in 0..3 {
            tau[(i, i)] += j * p;
        }
        let tw = tau * w;
        for a in 0..8 {
            let ga = g[a];
            for i in 0..3 {
                residual[3 * a + i] += tw[(i, 0)] * ga[0] + tw[(i, 1)] * ga[1] + tw[(i, 2)] * ga[2];
                dvdx[3 * a + i] += j * w * ga[i];
            }
        }
        if let Some(k) = tangent.as_deref_mut() {
            let iso = material.isochoric_spatial_tangent(&b, j, &tau_iso);
            let mut d = [[0.0; 6]; 6];
            let vol_11 = j * (p + j * dp);
            for r in 0..6 {
                for c in 0..6 {
                    d[r][c] = iso[(r, c)] * w;
                }
            }
            for r in 0..3 {
                for c in 0..3 {
                    d[r][c] += vol_11 * w;
                }
                d[r][r] -= 2.0 * j * p * w;
                d[r + 3][r + 3] -= j * p * w;
            }
            accumulate_tangent(k, &g, &d, &tw);
        }
    }
    if formulation == Hex8Formulation::MeanDilatation {
        energy += v0 * material.volumetric_energy(theta);
    }
    if let Some(k) = tangent {
        if formulation == Hex8Formulation::MeanDilatation {
            let s = material.volumetric_second_derivative(theta) / v0;
            for r in 0..24 {
                let sr = s * dvdx[r];
                // upper blocks only (b ≥ a): columns from the start of row's node block
                for c in (3 * (r / 3))..24 {
                    k[24 * r + c] += sr * dvdx[c];
                }
            }
        }
        mirror_blocks(k);
    }
    Ok(energy)
}

/// Adds B_aᵀ D B_b + (∇N_a·τ∇N_b) 1 into the upper node blocks (a ≤ b) of `k`;
/// `d` and `tw` already carry the weight.
#[inline]
fn accumulate_tangent(k: &mut [f64; 576], g: &[[f64; 3]; 8], d: &[[f64; 6]; 6], tw: &Matrix3<f64>) {
    // DB_b (6×3) for all b, and τ∇N_b.
    let mut db = [[[0.0; 3]; 6]; 8];
    let mut tg = [[0.0; 3]; 8];
    for b in 0..8 {
        let [x, y, z] = g[b];
        for r in 0..6 {
            let dr = &d[r];
            db[b][r] = [
                dr[0] * x + dr[3] * y + dr[5] * z,
                dr[1] * y + dr[3] * x + dr[4] * z,
                dr[2] * z + dr[4] * y + dr[5] * x,
            ];
        }
        for i in 0..3 {
            tg[b][i] = tw[(i, 0)] * x + tw[(i, 1)] * y + tw[(i, 2)] * z;
        }
    }
    for a in 0..8 {
        let [x, y, z] = g[a];
        for b in a..8 {
            let m = &db[b];
            let geo = x * tg[b][0] + y * tg[b][1] + z * tg[b][2];
            let base = 24 * 3 * a + 3 * b;
            for jj in 0..3 {
                k[base + jj] += x * m[0][jj] + y * m[3][jj] + z * m[5][jj];
                k[base + 24 + jj] += y * m[1][jj] + x * m[3][jj] + z * m[4][jj];
                k[base + 48 + jj] += z * m[2][jj] + y * m[4][jj] + x * m[5][jj];
            }
            k[base] += geo;
            k[base + 25] += geo;
            k[base + 50] += geo;
        }
    }
}

/// Copies the upper node blocks (a < b) into the lower ones: K_ba = K_abᵀ.
#[inline]
fn mirror_blocks(k: &mut [f64; 576]) {
    for a in 0..8 {
        for b in (a + 1)..8 {
            for i in 0..3 {
                for j in 0..3 {
                    k[24 * (3 * b + j) + 3 * a + i] = k[24 * (3 * a + i) + 3 * b + j];
                }
            }
        }
    }
}
