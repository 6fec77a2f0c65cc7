//! Reference matrices for tests and benchmarks of the linear solvers: linear-elastic stiffness
//! of structured hexahedral grids (3 DOFs per node, 27-node stencil), independent of the
//! element module so the solver can be verified on its own.

use super::SparsityPattern;

/// A symmetric matrix given by its lower-triangle pattern and values.
#[derive(Debug, Clone, PartialEq)]
pub struct TestMatrix {
    /// Lower-triangle CSC pattern.
    pub pattern: SparsityPattern,
    /// Values following `pattern.row_idx`.
    pub values: Vec<f64>,
}

/// ‖A x − b‖ / ‖b‖ for the symmetric A of lower-triangle `pattern` and `values`.
pub fn relative_residual(pattern: &SparsityPattern, values: &[f64], x: &[f64], b: &[f64]) -> f64 {
    let mut ax = vec![0.0; pattern.n];
    pattern.sym_mul(values, x, &mut ax);
    let r: f64 = ax
        .iter()
        .zip(b)
        .map(|(p, q)| (p - q).powi(2))
        .sum::<f64>()
        .sqrt();
    r / b.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// Stiffness matrix of a unit-spaced `nx x ny x nz` grid of trilinear hexahedra (hex8, 2x2x2
/// Gauss points) of an isotropic linear-elastic material (Young's modulus `young`, Poisson
/// ratio `poisson`), with the nodes of the `z = 0` face clamped (removed), so the matrix is
/// symmetric positive definite. Free node `(i, j, k)` (`k >= 1`) carries equations
/// `3 p .. 3 p + 3` with `p = ((k - 1) * (ny + 1) + j) * (nx + 1) + i`.
///
/// Element matrix: `K_ab[r][s] = ∫ (λ ∂_r N_a ∂_s N_b + μ ∂_s N_a ∂_r N_b
/// + μ δ_rs ∇N_a·∇N_b) dV` with `λ = Eν/((1+ν)(1−2ν))`, `μ = E/(2(1+ν))`.
pub fn hex_elasticity(nx: usize, ny: usize, nz: usize, young: f64, poisson: f64) -> TestMatrix {
    let ke = hex8_unit_stiffness(young, poisson);
    let (px, py) = (nx + 1, ny + 1);
    let n = 3 * px * py * nz;
    let dof = |i: usize, j: usize, k: usize, c: usize| {
        if k == 0 {
            usize::MAX
        } else {
            3 * (((k - 1) * py + j) * px + i) + c
        }
    };
    let mut elements: Vec<[usize; 24]> = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let mut dofs = [0usize; 24];
                for (a, corner) in CORNERS.iter().enumerate() {
                    let (ci, cj, ck) = (corner[0] > 0.0, corner[1] > 0.0, corner[2] > 0.0);
                    for c in 0..3 {
                        dofs[3 * a + c] = dof(
                            i + usize::from(ci),
                            j + usize::from(cj),
                            k + usize::from(ck),
                            c,
                        );
                    }
                }
                elements.push(dofs);
            }
        }
    }
    let pattern = SparsityPattern::from_cliques(n, elements.iter().map(|e| &e[..]));
    let mut values = vec![0.0; pattern.nnz()];
    for dofs in &elements {
        for (p, &gp) in dofs.iter().enumerate() {
            for (q, &gq) in dofs.iter().enumerate() {
                if gp < n && gq < n && gp >= gq {
                    if let Some(pos) = pattern.position(gp, gq) {
                        values[pos] += ke[p][q];
                    }
                }
            }
        }
    }
    TestMatrix { pattern, values }
}

use crate::mesh::surface::HEX8_CORNERS as CORNERS;

/// 24x24 stiffness of a unit cube hex8 (DOF order: node-major, x/y/z within a node).
fn hex8_unit_stiffness(young: f64, poisson: f64) -> [[f64; 24]; 24] {
    let lambda = young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
    let mu = young / (2.0 * (1.0 + poisson));
    let g = 1.0 / 3f64.sqrt();
    // Unit cube: x = (ξ + 1) / 2, so ∂/∂x = 2 ∂/∂ξ and dV = dξ / 8 (Gauss weights are 1).
    let mut ke = [[0.0; 24]; 24];
    for gx in [-g, g] {
        for gy in [-g, g] {
            for gz in [-g, g] {
                let xi = [gx, gy, gz];
                let mut grad = [[0.0; 3]; 8];
                for (a, c) in CORNERS.iter().enumerate() {
                    let f = [1.0 + c[0] * xi[0], 1.0 + c[1] * xi[1], 1.0 + c[2] * xi[2]];
                    for d in 0..3 {
                        let others: f64 = (0..3).filter(|&e| e != d).map(|e| f[e]).product();
                        grad[a][d] = 2.0 * c[d] * others / 8.0;
                    }
                }
                let w = 1.0 / 8.0;
                for a in 0..8 {
                    for b in 0..8 {
                        let dot: f64 = (0..3).map(|d| grad[a][d] * grad[b][d]).sum();
                        for r in 0..3 {
                            for s in 0..3 {
                                let mut v =
                                    lambda * grad[a][r] * grad[b][s] + mu * grad[a][s] * grad[b][r];
                                if r == s {
                                    v += mu * dot;
                                }
                                ke[3 * a + r][3 * b + s] += w * v;
                            }
                        }
                    }
                }
            }
        }
    }
    ke
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn element_stiffness_is_symmetric_with_six_rigid_modes() {
        let ke = hex8_unit_stiffness(1.0, 0.3);
        for p in 0..24 {
            for q in 0..24 {
                assert!((ke[p][q] - ke[q][p]).abs() < 1e-14);
            }
        }
        // Rigid translations and a rotation about z produce no force.
        let mut modes: Vec<[f64; 24]> = Vec::new();
        for c in 0..3 {
            let mut u = [0.0; 24];
            (0..8).for_each(|a| u[3 * a + c] = 1.0);
            modes.push(u);
        }
        let mut rot = [0.0; 24];
        for (a, x) in CORNERS.iter().enumerate() {
            rot[3 * a] = -x[1];
            rot[3 * a + 1] = x[0];
        }
        modes.push(rot);
        for u in &modes {
            let f: f64 = (0..24)
                .map(|p| (0..24).map(|q| ke[p][q] * u[q]).sum::<f64>().abs())
                .sum();
            assert!(f < 1e-13, "rigid mode force {f}");
        }
        // Uniform uniaxial strain ε_xx = 1 (u_x = x on the unit cube, x in {0, 1}) stores the
        // energy (λ + 2μ) / 2 per unit volume.
        let (lambda, mu) = (0.3 / (1.3 * 0.4), 1.0 / 2.6);
        let mut u = [0.0; 24];
        (0..8).for_each(|a| u[3 * a] = (CORNERS[a][0] + 1.0) / 2.0);
        let energy: f64 = 0.5
            * (0..24)
                .map(|p| u[p] * (0..24).map(|q| ke[p][q] * u[q]).sum::<f64>())
                .sum::<f64>();
        assert!(
            (energy - 0.5 * (lambda + 2.0 * mu)).abs() < 1e-12,
            "energy {energy}"
        );
    }

    #[test]
    fn grid_matrix_has_expected_size_and_stencil() {
        let m = hex_elasticity(2, 2, 2, 1.0, 0.3);
        assert_eq!(m.pattern.n, 3 * 9 * 2);
        // Node-level 27-point stencil: a top-centre node couples to 3x3x2 nodes.
        let centre_top = 3 * 13; // k = 2, j = 1, i = 1: p = ((2 - 1) * 3 + 1) * 3 + 1
        let col_nnz_full = (0..m.pattern.n)
            .filter(|&r| {
                let (a, b) = (r.max(centre_top), r.min(centre_top));
                m.pattern.position(a, b).is_some()
            })
            .count();
        assert_eq!(col_nnz_full, 3 * 18);
    }
}
