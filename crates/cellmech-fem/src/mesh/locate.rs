//! Point location in hex8 meshes: which element contains a point, and at which natural
//! (parametric) coordinates ξ ∈ [−1, 1]³.
//!
//! A [`HostLocator`] bins the (slightly inflated) bounding boxes of the host elements on a
//! uniform grid once; a query visits the elements of the point's bin, inverts the trilinear
//! map of each candidate by Newton's method ([`hex8_inverse_map`]) and keeps the candidate
//! with the smallest overshoot `max(0, max_i |ξ_i| − 1)`. A point on a face, edge or node
//! shared by several elements is therefore found in one of them (the first with the least
//! overshoot, deterministic), with ξ on the element boundary. A point outside every host
//! by more than the tolerance is an error naming the point.

use super::surface::HEX8_CORNERS;
use super::{ElementBlock, ElementKind, Mesh};

/// Trilinear shape functions `N_a(ξ) = ⅛ Π (1 + ξ_i ξ_ai)` in Abaqus/Gmsh node order.
pub fn hex8_shape(xi: [f64; 3]) -> [f64; 8] {
    std::array::from_fn(|a| {
        let n = HEX8_CORNERS[a];
        (1.0 + xi[0] * n[0]) * (1.0 + xi[1] * n[1]) * (1.0 + xi[2] * n[2]) / 8.0
    })
}

/// `x(ξ) = Σ N_a(ξ) x_a`.
pub fn hex8_map(x: &[[f64; 3]; 8], xi: [f64; 3]) -> [f64; 3] {
    let n = hex8_shape(xi);
    std::array::from_fn(|i| (0..8).map(|a| n[a] * x[a][i]).sum())
}

/// Natural coordinates ξ of `point` in the hex8 with corners `x` (Newton on the trilinear
/// map from the centre). `None` when Newton does not converge (a singular Jacobian, or a
/// point so far outside that the map folds). ξ may lie outside [−1, 1]³: the caller judges.
pub fn hex8_inverse_map(x: &[[f64; 3]; 8], point: [f64; 3]) -> Option<[f64; 3]> {
    let size = (0..3)
        .map(|i| {
            let (lo, hi) = x
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                    (l.min(p[i]), h.max(p[i]))
                });
            hi - lo
        })
        .fold(0.0, f64::max);
    if !(size > 0.0 && size.is_finite()) || point.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mut xi = [0.0; 3];
    for _ in 0..50 {
        let current = hex8_map(x, xi);
        let r: [f64; 3] = std::array::from_fn(|i| current[i] - point[i]);
        // J_ij = ∂x_i/∂ξ_j
        let mut j = [[0.0; 3]; 3];
        for (a, n) in HEX8_CORNERS.iter().enumerate() {
            let f = [1.0 + xi[0] * n[0], 1.0 + xi[1] * n[1], 1.0 + xi[2] * n[2]];
            let dn = [
                n[0] * f[1] * f[2] / 8.0,
                f[0] * n[1] * f[2] / 8.0,
                f[0] * f[1] * n[2] / 8.0,
            ];
            for i in 0..3 {
                for k in 0..3 {
                    j[i][k] += x[a][i] * dn[k];
                }
            }
        }
        let step = solve3(&j, &r)?;
        for k in 0..3 {
            xi[k] -= step[k];
        }
        if xi.iter().any(|v| !v.is_finite() || v.abs() > 1e3) {
            return None;
        }
        let step_norm = step.iter().fold(0.0f64, |m, s| m.max(s.abs()));
        if step_norm <= 1e-14 {
            return Some(xi);
        }
    }
    // Newton stalls at round-off without meeting the step test: accept if the map hits
    // the point to round-off of the element size.
    let current = hex8_map(x, xi);
    let miss = (0..3).fold(0.0f64, |m, i| m.max((current[i] - point[i]).abs()));
    (miss <= 1e-12 * size).then_some(xi)
}

fn solve3(a: &[[f64; 3]; 3], b: &[f64; 3]) -> Option<[f64; 3]> {
    let det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    if !(det.is_finite() && det != 0.0) {
        return None;
    }
    let col = |k: usize| -> f64 {
        let mut m = *a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    Some([col(0) / det, col(1) / det, col(2) / det])
}

/// Why a locator could not be built or a point not located.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LocateError {
    /// A named host block does not exist.
    #[error("host element set '{0}' does not exist")]
    UnknownBlock(String),
    /// A host block is not made of hex8 elements.
    #[error("host element set '{block}' holds {kind} elements; hosts must be hex8")]
    NotHex8 {
        /// Block name.
        block: String,
        /// Its element kind.
        kind: &'static str,
    },
    /// A host element refers to a node that does not exist.
    #[error(
        "host element {element} of set '{block}' uses node {node}, but there are {num_nodes} nodes"
    )]
    UnknownNode {
        /// Block name.
        block: String,
        /// Element index in the block.
        element: usize,
        /// The node.
        node: usize,
        /// Number of nodes.
        num_nodes: usize,
    },
    /// No host element at all.
    #[error("no host elements to locate points in")]
    NoHosts,
    /// The tolerance is negative or not finite.
    #[error("the location tolerance must be finite and >= 0, found {0}")]
    BadTolerance(f64),
    /// The point lies in no host element (within the tolerance).
    #[error(
        "point ({:.6}, {:.6}, {:.6}) lies in no host element{}",
        point[0], point[1], point[2],
        match nearest { Some(o) => format!(
            " (nearest candidate: |ξ| exceeds 1 by {o:.3e}, tolerance {tolerance:.1e})"),
            None => String::from(" (not even near one)") }
    )]
    Outside {
        /// The point (µm).
        point: [f64; 3],
        /// Least overshoot `max|ξ| − 1` among the candidates whose inverse map converged.
        nearest: Option<f64>,
        /// The tolerance that was used.
        tolerance: f64,
    },
}

/// Where a point lies: host element, its nodes and the natural coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HostLocation {
    /// Index of the host block in the list the locator was built from.
    pub block: usize,
    /// Element index within that block.
    pub element: usize,
    /// The element's 8 nodes.
    pub nodes: [usize; 8],
    /// Natural coordinates in the element.
    pub xi: [f64; 3],
    /// `max(0, max_i |ξ_i| − 1)`: how far outside the element the point is (0 inside).
    pub overshoot: f64,
}

impl HostLocation {
    /// Shape-function values (the interpolation weights of the 8 nodes).
    pub fn weights(&self) -> [f64; 8] {
        hex8_shape(self.xi)
    }
}

#[derive(Debug, Clone)]
struct HostElement {
    block: usize,
    element: usize,
    nodes: [usize; 8],
    x: [[f64; 3]; 8],
    lo: [f64; 3],
    hi: [f64; 3],
}

/// Bins of host elements for point location (built once, read-only afterwards).
#[derive(Debug, Clone)]
pub struct HostLocator {
    elements: Vec<HostElement>,
    origin: [f64; 3],
    cell: [f64; 3],
    dims: [usize; 3],
    bin_offsets: Vec<usize>,
    bin_elements: Vec<u32>,
    host_node: Vec<bool>,
    inflation: f64,
}

impl HostLocator {
    /// A locator over the hex8 blocks of `mesh` named in `block_names`.
    pub fn new(mesh: &Mesh, block_names: &[&str]) -> Result<Self, LocateError> {
        let blocks = block_names
            .iter()
            .map(|&name| {
                mesh.block(name)
                    .ok_or_else(|| LocateError::UnknownBlock(name.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Self::from_blocks(&mesh.nodes, &blocks)
    }

    /// A locator over `blocks` (all hex8) with node coordinates `nodes`. Points up to the
    /// largest tolerance of later queries outside an element are found when that
    /// tolerance is ≤ 0.5 (bounding boxes are inflated by half an element).
    pub fn from_blocks(nodes: &[[f64; 3]], blocks: &[&ElementBlock]) -> Result<Self, LocateError> {
        let inflation = 0.5;
        let mut elements = Vec::new();
        let mut host_node = vec![false; nodes.len()];
        for (b, block) in blocks.iter().enumerate() {
            if block.kind != ElementKind::Hex8 {
                return Err(LocateError::NotHex8 {
                    block: block.name.clone(),
                    kind: block.kind.name(),
                });
            }
            for (e, conn) in block.elements().enumerate() {
                if let Some(&node) = conn.iter().find(|&&n| n >= nodes.len()) {
                    return Err(LocateError::UnknownNode {
                        block: block.name.clone(),
                        element: e,
                        node,
                        num_nodes: nodes.len(),
                    });
                }
                let conn: [usize; 8] = std::array::from_fn(|a| conn[a]);
                let x: [[f64; 3]; 8] = std::array::from_fn(|a| nodes[conn[a]]);
                let mut lo = [f64::INFINITY; 3];
                let mut hi = [f64::NEG_INFINITY; 3];
                for p in &x {
                    for i in 0..3 {
                        lo[i] = lo[i].min(p[i]);
                        hi[i] = hi[i].max(p[i]);
                    }
                }
                // Inflate so that points slightly outside (overshoot ≤ inflation) are seen.
                for i in 0..3 {
                    let pad = inflation * (hi[i] - lo[i]).max(1e-300);
                    lo[i] -= pad;
                    hi[i] += pad;
                }
                for &n in &conn {
                    host_node[n] = true;
                }
                elements.push(HostElement {
                    block: b,
                    element: e,
                    nodes: conn,
                    x,
                    lo,
                    hi,
                });
            }
        }
        if elements.is_empty() {
            return Err(LocateError::NoHosts);
        }
        let mut origin = [f64::INFINITY; 3];
        let mut top = [f64::NEG_INFINITY; 3];
        for el in &elements {
            for i in 0..3 {
                origin[i] = origin[i].min(el.lo[i]);
                top[i] = top[i].max(el.hi[i]);
            }
        }
        // About one element per bin: bins as large as the mean element box.
        let mean_extent: [f64; 3] = std::array::from_fn(|i| {
            elements.iter().map(|e| e.hi[i] - e.lo[i]).sum::<f64>() / elements.len() as f64
        });
        let max_bins_per_axis = 1usize << 10;
        let dims: [usize; 3] = std::array::from_fn(|i| {
            let d = ((top[i] - origin[i]) / mean_extent[i].max(1e-300)).ceil();
            (d as usize).clamp(1, max_bins_per_axis)
        });
        let cell: [f64; 3] = std::array::from_fn(|i| (top[i] - origin[i]) / dims[i] as f64);
        let bin_range = |lo: f64, hi: f64, i: usize| -> (usize, usize) {
            let f = |v: f64| {
                let c = ((v - origin[i]) / cell[i]).floor();
                (c.max(0.0) as usize).min(dims[i] - 1)
            };
            (f(lo), f(hi))
        };
        let num_bins = dims[0] * dims[1] * dims[2];
        let mut counts = vec![0usize; num_bins + 1];
        let each_bin = |el: &HostElement, f: &mut dyn FnMut(usize)| {
            let r: [(usize, usize); 3] = std::array::from_fn(|i| bin_range(el.lo[i], el.hi[i], i));
            for k in r[2].0..=r[2].1 {
                for j in r[1].0..=r[1].1 {
                    for i in r[0].0..=r[0].1 {
                        f(i + dims[0] * (j + dims[1] * k));
                    }
                }
            }
        };
        for el in &elements {
            each_bin(el, &mut |b| counts[b + 1] += 1);
        }
        for b in 0..num_bins {
            counts[b + 1] += counts[b];
        }
        let mut fill = counts.clone();
        let mut bin_elements = vec![0u32; counts[num_bins]];
        for (index, el) in elements.iter().enumerate() {
            each_bin(el, &mut |b| {
                bin_elements[fill[b]] = index as u32;
                fill[b] += 1;
            });
        }
        Ok(HostLocator {
            elements,
            origin,
            cell,
            dims,
            bin_offsets: counts,
            bin_elements,
            host_node,
            inflation,
        })
    }

    /// Whether `node` is a node of a host element.
    pub fn is_host_node(&self, node: usize) -> bool {
        self.host_node.get(node).copied().unwrap_or(false)
    }

    /// Number of host elements.
    pub fn num_elements(&self) -> usize {
        self.elements.len()
    }

    /// The host element containing `point`, accepting points outside an element by an
    /// overshoot `max|ξ| − 1 ≤ tolerance` (for points on a faceted curved boundary; the
    /// interpolation is then a mild extrapolation). `tolerance` must lie in [0, 0.5].
    pub fn locate(&self, point: [f64; 3], tolerance: f64) -> Result<HostLocation, LocateError> {
        if !(tolerance.is_finite() && (0.0..=self.inflation).contains(&tolerance)) {
            return Err(LocateError::BadTolerance(tolerance));
        }
        let outside = |nearest| LocateError::Outside {
            point,
            nearest,
            tolerance,
        };
        let mut bin = 0;
        for i in (0..3).rev() {
            let c = (point[i] - self.origin[i]) / self.cell[i];
            if !(c >= 0.0 && c <= self.dims[i] as f64) {
                return Err(outside(None));
            }
            bin = bin * self.dims[i] + (c.floor() as usize).min(self.dims[i] - 1);
        }
        let mut best: Option<HostLocation> = None;
        for &index in &self.bin_elements[self.bin_offsets[bin]..self.bin_offsets[bin + 1]] {
            let el = &self.elements[index as usize];
            if (0..3).any(|i| point[i] < el.lo[i] || point[i] > el.hi[i]) {
                continue;
            }
            let Some(xi) = hex8_inverse_map(&el.x, point) else {
                continue;
            };
            let overshoot = (xi.iter().fold(0.0f64, |m, v| m.max(v.abs())) - 1.0).max(0.0);
            if best.is_none_or(|b| overshoot < b.overshoot) {
                best = Some(HostLocation {
                    block: el.block,
                    element: el.element,
                    nodes: el.nodes,
                    xi,
                    overshoot,
                });
            }
        }
        match best {
            Some(b) if b.overshoot <= tolerance => Ok(b),
            Some(b) => Err(outside(Some(b.overshoot))),
            None => Err(outside(None)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::{box_mesh, perturb_interior_nodes};

    #[test]
    fn locator_inverts_distorted_hexes_and_finds_faces_nodes_and_outside_points() {
        let mut mesh = box_mesh([0.0; 3], [2.0, 3.0, 1.5], [4, 5, 3], "host").unwrap();
        perturb_interior_nodes(&mut mesh, 0.3, 7).unwrap();
        let locator = HostLocator::new(&mesh, &["host"]).unwrap();
        let mut state = 12345u64;
        let mut rand = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..500 {
            let p = [2.0 * rand(), 3.0 * rand(), 1.5 * rand()];
            let loc = locator.locate(p, 0.0).unwrap();
            let x: [[f64; 3]; 8] = std::array::from_fn(|a| mesh.nodes[loc.nodes[a]]);
            let back = hex8_map(&x, loc.xi);
            for i in 0..3 {
                assert!((back[i] - p[i]).abs() < 1e-13, "{p:?} -> {back:?}");
            }
            assert_eq!(loc.overshoot, 0.0);
            let w = loc.weights();
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        }
        // Every node of the mesh (shared by up to 8 elements) is found, at a corner.
        for (n, &p) in mesh.nodes.iter().enumerate() {
            let loc = locator.locate(p, 1e-12).unwrap();
            let a = loc.nodes.iter().position(|&m| m == n).unwrap();
            assert!((loc.weights()[a] - 1.0).abs() < 1e-12, "node {n}");
        }
        // Slightly outside a face: found with the overshoot, rejected without tolerance.
        let p = [2.0 + 0.01, 1.3, 0.7];
        let loc = locator.locate(p, 0.05).unwrap();
        assert!(loc.overshoot > 0.02 && loc.overshoot < 0.08, "{loc:?}");
        let e = locator.locate(p, 0.0).unwrap_err();
        assert!(e
            .to_string()
            .contains("point (2.010000, 1.300000, 0.700000) lies in no host"));
        let e = locator.locate([9.0, 0.0, 0.0], 0.1).unwrap_err();
        assert!(e.to_string().contains("not even near"), "{e}");
        assert!(matches!(
            locator.locate(p, -1.0),
            Err(LocateError::BadTolerance(_))
        ));
        assert!(matches!(
            HostLocator::new(&mesh, &["nope"]),
            Err(LocateError::UnknownBlock(_))
        ));
    }
}
