//! Elastic ties of nodes to material points of host elements: an elastic foundation for
//! fibres embedded in a continuum.
//!
//! A tied node `s` sits at natural coordinates `ξ` of a hex8 host element with nodes
//! `x_1 … x_8`; the host material point under it is `p = Σ_i N_i(ξ) x_i`, and
//!
//! ```text
//! Π = k/2 |x_s − p − d₀|²,   d₀ = X_s − Σ_i N_i(ξ) X_i
//! ```
//!
//! with `k` (nN/µm) the tie's stiffness: a foundation modulus (nN/µm², force per length of
//! fibre per unit relative displacement) times the fibre length the node stands for. The
//! offset `d₀` is zero when `ξ` is the exact inverse map of the reference position (it is
//! kept so that a node found a little outside a faceted boundary starts unloaded). The
//! energy depends only on the relative position of the node and the material point, so a
//! rigid translation of the whole costs nothing; it is exact under rigid rotation when
//! `d₀ = 0`, and otherwise wrong by `k |d₀| |R − I|`, at the level of the location tolerance.
//!
//! Compared with the exact embedding of `constraint::embed` (the node *is* the material
//! point), the tie lets the fibre move relative to the gel by `force / k`: a fibre under
//! axial compression buckles in short waves of length `2π (EI/k)^{1/4}` at the load
//! `2 √(k EI)` of a beam on an elastic foundation instead of being forced to shorten with the
//! gel, and a fibre's load enters the gel along its length instead of at anchor points.
//!
//! Energy, residual and tangent are exact (the energy is quadratic in the positions).

use super::ElementSet;
use super::KernelError;

/// DOFs of one tie: the tied node's 3 translations, then the 8 host nodes' (node-major).
pub const HOST_TIE_DOFS: usize = 27;

/// Energy, residual (27) and tangent (27×27, row-major) of one tie of stiffness `k` with
/// host weights `weights`, its tied node and host nodes displaced by `u` (tied node first).
/// Since `X_s − Σ N_i X_i = d₀`, the gap `x_s − p − d₀` is `u_s − Σ N_i u_i`.
pub fn host_tie_evaluate(
    k: f64,
    weights: &[f64; 8],
    u: &[f64],
    residual: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> Result<f64, KernelError> {
    residual[..HOST_TIE_DOFS].fill(0.0);
    let tangent = tangent.map(|t| {
        t[..HOST_TIE_DOFS * HOST_TIE_DOFS].fill(0.0);
        t
    });
    Ok(0.5 * k * add_gap_spring(k, weights, &[0.0; 3], u, residual, tangent))
}

/// Adds to `residual` and `tangent` the viscous drag of one tie: a force `k_drag (g − g₀)`
/// against the change of its gap `g = u_s − Σ N_i u_i` since the increment's start (`g₀`),
/// shared between the node and the host nodes as the tie's own force is. Returns the energy
/// it dissipates over that change, `k_drag |g − g₀|²`.
pub fn host_tie_drag(
    k_drag: f64,
    weights: &[f64; 8],
    gap_start: &[f64; 3],
    u: &[f64],
    residual: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> f64 {
    k_drag * add_gap_spring(k_drag, weights, gap_start, u, residual, tangent)
}

/// Adds the force `k (g − g₀)` of a spring on the tie's gap `g = u_s − Σ N_i u_i` to the
/// node (coefficient 1) and the host nodes (coefficients `−N_i`), and its tangent
/// `k c_a c_b I`; returns `|g − g₀|²`.
fn add_gap_spring(
    k: f64,
    weights: &[f64; 8],
    g0: &[f64; 3],
    u: &[f64],
    residual: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> f64 {
    // Coefficient of each node in the gap.
    let c = |a: usize| if a == 0 { 1.0 } else { -weights[a - 1] };
    let mut g = [0.0; 3];
    for (i, gi) in g.iter_mut().enumerate() {
        *gi = -g0[i];
        for a in 0..9 {
            *gi += c(a) * u[3 * a + i];
        }
    }
    for a in 0..9 {
        for i in 0..3 {
            residual[3 * a + i] += k * c(a) * g[i];
        }
    }
    if let Some(t) = tangent {
        let n = HOST_TIE_DOFS;
        for a in 0..9 {
            for b in 0..9 {
                let kab = k * c(a) * c(b);
                for i in 0..3 {
                    t[(3 * a + i) * n + 3 * b + i] += kab;
                }
            }
        }
    }
    g[0] * g[0] + g[1] * g[1] + g[2] * g[2]
}

/// One tie of a node to a host element's material point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HostTie {
    /// Tied node (first) and the host element's 8 nodes.
    pub nodes: [usize; 9],
    /// Host shape-function values at the tied node's natural coordinates.
    pub weights: [f64; 8],
    /// Stiffness of the tie (nN/µm).
    pub stiffness: f64,
}

impl HostTie {
    /// A tie of node `node` to the host element with nodes `host_nodes`, with interpolation
    /// weights `weights` (at the node's natural coordinates) and stiffness `stiffness`. The
    /// reference offset `d₀` never enters the kernel (the gap is `u_s − Σ N_i u_i`), so it is
    /// not stored.
    pub fn new(node: usize, host_nodes: [usize; 8], weights: [f64; 8], stiffness: f64) -> Self {
        let mut nodes = [node; 9];
        nodes[1..].copy_from_slice(&host_nodes);
        HostTie {
            nodes,
            weights,
            stiffness,
        }
    }
}

/// A set of elastic node-to-host ties (a `Term` through [`ElementSet`]).
#[derive(Debug, Clone)]
pub struct HostTieSet {
    /// Name of the set.
    pub name: String,
    /// The ties.
    pub ties: Vec<HostTie>,
    /// Whether the set takes part (a family switched off keeps its ties out).
    pub enabled: bool,
    /// The viscous drag of a stabilised increment ([`crate::term::Term::set_drag`]): per
    /// tie, its drag stiffness and its gap at the increment's start.
    drag: Option<Vec<(f64, [f64; 3])>>,
}

impl HostTieSet {
    /// A set named `name` of the ties `ties`, taking part.
    pub fn new(name: impl Into<String>, ties: Vec<HostTie>) -> Self {
        HostTieSet {
            name: name.into(),
            ties,
            enabled: true,
            drag: None,
        }
    }

    /// Gap `x_s − p − d₀ = u_s − Σ N_i u_i` of tie `e` at the global displacement `u` (µm), for outputs.
    pub fn gap(&self, e: usize, u: &[f64], dof_map: &crate::dof::DofMap) -> [f64; 3] {
        let t = &self.ties[e];
        std::array::from_fn(|i| {
            let mut g = u[dof_map.dof(t.nodes[0], i)];
            for a in 0..8 {
                g -= t.weights[a] * u[dof_map.dof(t.nodes[a + 1], i)];
            }
            g
        })
    }

    /// Largest relative displacement between a tied node and its material point (µm).
    pub fn max_gap(&self, u: &[f64], dof_map: &crate::dof::DofMap) -> f64 {
        (0..self.ties.len())
            .map(|e| {
                let g = self.gap(e, u, dof_map);
                (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt()
            })
            .fold(0.0, f64::max)
    }
}

impl ElementSet for HostTieSet {
    const ELEMENT_DOFS: usize = HOST_TIE_DOFS;

    fn set_name(&self) -> &str {
        &self.name
    }

    fn element_count(&self) -> usize {
        if self.enabled {
            self.ties.len()
        } else {
            0
        }
    }

    fn element_nodes(&self, e: usize) -> &[usize] {
        &self.ties[e].nodes
    }

    fn evaluate_element(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let t = &self.ties[e];
        match &self.drag {
            Some(drag) => {
                let mut tangent = tangent;
                let energy = host_tie_evaluate(
                    t.stiffness,
                    &t.weights,
                    u_e,
                    residual,
                    tangent.as_deref_mut(),
                )?;
                let (k_drag, gap_start) = &drag[e];
                host_tie_drag(*k_drag, &t.weights, gap_start, u_e, residual, tangent);
                Ok(energy)
            }
            None => host_tie_evaluate(t.stiffness, &t.weights, u_e, residual, tangent),
        }
    }

    /// The drag stiffness of a tie is `rate` times the mean weight of the tied node's three
    /// translations: the tied node is damped against its material point as the nodal
    /// viscosity would damp it against its place.
    fn on_drag(
        &mut self,
        drag: Option<&crate::term::Drag<'_>>,
        dof_map: &crate::dof::DofMap,
    ) -> bool {
        self.drag = drag.filter(|_| self.enabled).map(|d| {
            (0..self.ties.len())
                .map(|e| {
                    let node = self.ties[e].nodes[0];
                    let weight = (0..3).map(|i| d.weight[dof_map.dof(node, i)]).sum::<f64>() / 3.0;
                    (d.rate * weight, self.gap(e, d.u_start, dof_map))
                })
                .collect()
        });
        self.enabled && !self.ties.is_empty()
    }

    fn drag_forces_of_set(&self, u: &[f64], dof_map: &crate::dof::DofMap, out: &mut [f64]) -> f64 {
        let Some(drag) = &self.drag else {
            return 0.0;
        };
        let mut dofs = [0usize; HOST_TIE_DOFS];
        let (mut u_e, mut r) = ([0.0; HOST_TIE_DOFS], [0.0; HOST_TIE_DOFS]);
        let mut dissipated = 0.0;
        for (e, (k_drag, gap_start)) in drag.iter().enumerate() {
            self.element_dofs_into(e, dof_map, &mut dofs);
            for (value, &dof) in u_e.iter_mut().zip(&dofs) {
                *value = u[dof];
            }
            r.fill(0.0);
            let weights = &self.ties[e].weights;
            dissipated += host_tie_drag(*k_drag, weights, gap_start, &u_e, &mut r, None);
            for (force, &dof) in r.iter().zip(&dofs) {
                out[dof] += force;
            }
        }
        dissipated
    }

    fn curve_outputs(&self, u: &[f64], dof_map: &crate::dof::DofMap) -> Vec<(String, f64)> {
        if !self.enabled || self.ties.is_empty() {
            return Vec::new();
        }
        vec![(
            format!("{}_max_slip_um", self.name),
            self.max_gap(u, dof_map),
        )]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::locate::hex8_shape;

    fn cube() -> [[f64; 3]; 8] {
        // The natural-coordinate corners, in the order of `hex8_shape`.
        crate::mesh::surface::HEX8_CORNERS
    }

    fn tie_at(xi: [f64; 3], k: f64) -> (HostTie, [[f64; 3]; 9]) {
        let host = cube().map(|p| [2.0 * p[0] + 1.0, 1.5 * p[1], 0.5 * p[2] - 0.3]);
        let w = hex8_shape(xi);
        let xs: [f64; 3] = std::array::from_fn(|i| (0..8).map(|a| w[a] * host[a][i]).sum());
        let tie = HostTie::new(0, [1, 2, 3, 4, 5, 6, 7, 8], w, k);
        let mut x = [[0.0; 3]; 9];
        x[0] = xs;
        x[1..].copy_from_slice(&host);
        (tie, x)
    }

    fn energy_and_residual(tie: &HostTie, u: &[f64]) -> (f64, [f64; 27], [f64; 729]) {
        let mut r = [0.0; 27];
        let mut t = [0.0; 729];
        let e = host_tie_evaluate(tie.stiffness, &tie.weights, u, &mut r, Some(&mut t)).unwrap();
        (e, r, t)
    }

    #[test]
    fn a_node_that_follows_its_material_point_is_unloaded() {
        // Any affine motion of the host, with the node moved to where the host's
        // interpolation takes its material point (rotation included): no energy, no force.
        let (tie, x) = tie_at([0.3, -0.6, 0.1], 7.0);
        let (c, s) = (0.6f64.cos(), 0.6f64.sin());
        let map = |p: [f64; 3]| {
            [
                c * p[0] - s * p[1] + 0.2 * p[2] + 3.0,
                s * p[0] + c * p[1] - 1.0,
                1.4 * p[2] + 0.1 * p[0],
            ]
        };
        let mut u = [0.0; 27];
        for a in 0..9 {
            let y = map(x[a]);
            for i in 0..3 {
                u[3 * a + i] = y[i] - x[a][i];
            }
        }
        let (e, r, _) = energy_and_residual(&tie, &u);
        assert!(e.abs() < 1e-24, "{e}");
        assert!(r.iter().all(|v| v.abs() < 1e-12), "{r:?}");
    }

    #[test]
    fn a_slip_is_resisted_by_the_stiffness_and_balanced_by_the_host() {
        // Move the node alone by d: force −k d on it, +k N_i d on the host nodes.
        let k = 3.0;
        let (tie, _) = tie_at([-0.2, 0.5, 0.7], k);
        let d = [0.1, -0.2, 0.05];
        let mut u = [0.0; 27];
        u[..3].copy_from_slice(&d);
        let (e, r, _) = energy_and_residual(&tie, &u);
        let dd = d.iter().map(|v| v * v).sum::<f64>();
        assert!((e - 0.5 * k * dd).abs() < 1e-14);
        for i in 0..3 {
            // Residual = internal force = −(external force needed): k d on the node.
            assert!((r[i] - k * d[i]).abs() < 1e-14);
            let host: f64 = (1..9).map(|a| r[3 * a + i]).sum();
            assert!(
                (host + k * d[i]).abs() < 1e-13,
                "the host takes the reaction"
            );
        }
    }

    #[test]
    fn the_tangent_is_the_derivative_of_the_residual() {
        let (tie, _) = tie_at([0.9, 0.1, -0.4], 2.5);
        let u: Vec<f64> = (0..27)
            .map(|i| 0.01 * ((i * 7 % 11) as f64 - 5.0))
            .collect();
        let (_, r0, t) = energy_and_residual(&tie, &u);
        let h = 1e-6;
        for b in 0..27 {
            let mut up = u.clone();
            up[b] += h;
            let (_, rp, _) = energy_and_residual(&tie, &up);
            for a in 0..27 {
                let fd = (rp[a] - r0[a]) / h;
                assert!((fd - t[a * 27 + b]).abs() < 1e-6, "K[{a}][{b}]");
            }
        }
    }

    #[test]
    fn the_drag_resists_the_change_of_the_gap_only_and_its_tangent_is_exact() {
        let (tie, _) = tie_at([0.4, -0.3, 0.2], 2.0);
        let g0 = [0.01, -0.02, 0.005];
        let k_drag = 1.7;
        let u: Vec<f64> = (0..27)
            .map(|i| 0.02 * ((i * 5 % 13) as f64 - 6.0))
            .collect();
        let drag = |u: &[f64]| {
            let mut r = [0.0; 27];
            let mut t = [0.0; 729];
            let d = host_tie_drag(k_drag, &tie.weights, &g0, u, &mut r, Some(&mut t));
            (d, r, t)
        };
        let (d0, r0, t) = drag(&u);
        // The dissipation is k_drag |g − g0|², the force k_drag (g − g0) on the node and
        // its reaction spread over the host nodes by the weights.
        let mut g = [0.0; 3];
        for (i, gi) in g.iter_mut().enumerate() {
            *gi = u[i]
                - (0..8)
                    .map(|a| tie.weights[a] * u[3 * (a + 1) + i])
                    .sum::<f64>()
                - g0[i];
        }
        let gg: f64 = g.iter().map(|v| v * v).sum();
        assert!((d0 - k_drag * gg).abs() < 1e-14);
        for i in 0..3 {
            assert!((r0[i] - k_drag * g[i]).abs() < 1e-14);
            let host: f64 = (1..9).map(|a| r0[3 * a + i]).sum();
            assert!((host + r0[i]).abs() < 1e-13, "balanced");
        }
        // A rigid translation of node and host together changes nothing.
        let shifted: Vec<f64> = u
            .iter()
            .enumerate()
            .map(|(j, v)| v + [0.3, -1.1, 2.0][j % 3])
            .collect();
        let (d1, r1, _) = drag(&shifted);
        assert!((d1 - d0).abs() < 1e-13);
        assert!(r1.iter().zip(&r0).all(|(a, b)| (a - b).abs() < 1e-12));
        // The tangent against central differences.
        let h = 1e-6;
        for b in 0..27 {
            let (mut up, mut um) = (u.clone(), u.clone());
            up[b] += h;
            um[b] -= h;
            let (_, rp, _) = drag(&up);
            let (_, rm, _) = drag(&um);
            for a in 0..27 {
                let fd = (rp[a] - rm[a]) / (2.0 * h);
                assert!((fd - t[a * 27 + b]).abs() < 1e-7, "K[{a}][{b}]");
            }
        }
    }
}
