//! Sliding the free surface's nodes along the current surface: the surface part of a
//! rezoning. A node in contact with an indenter near its nose is carried far along the
//! flank while the node at the stagnation point stays, so the surface faces there are
//! stretched into a few long faces wrapped round the nose; sliding the nodes back spreads
//! them again.
//!
//! The new positions make the surface mesh's displacement w = x′ − X (from the reference)
//! harmonic along the surface, each node held on the current (bilinear) surface:
//! Gauss–Seidel sweeps set each node's w to the weighted mean of its neighbours' (weights
//! 1 / reference edge length, the 1-D finite-element Laplacian along each edge) and project
//! X + w back onto the surface, which absorbs the normal part. An undeformed or uniformly
//! stretched surface is left where it is, and the surface keeps its grading. A node's new
//! material point is the same bilinear point of the face it lies on, in the reference
//! configuration.

use super::NodeRemap;

/// Gauss–Seidel sweeps at most.
const MAX_SWEEPS: usize = 200;
/// The sweeps stop once no node moves more than this fraction of the mean edge length.
const SWEEP_TOLERANCE: f64 = 1e-5;

/// Natural corners of a quad face's four nodes, in face order.
const CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Bilinear shape functions of a quad face at (ξ, η).
pub(super) fn quad_shape(xi: f64, eta: f64) -> [f64; 4] {
    std::array::from_fn(|a| 0.25 * (1.0 + CORNERS[a][0] * xi) * (1.0 + CORNERS[a][1] * eta))
}

/// A point of a surface face: the face's nodes, its natural coordinates and its current
/// position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FacePoint {
    /// The face's four nodes.
    pub face: [usize; 4],
    /// Natural coordinates (ξ, η) in [−1, 1]².
    pub xi: [f64; 2],
    /// Current position (µm).
    pub x: [f64; 3],
}

impl FacePoint {
    /// The remap of `node` onto this point: the face's nodes with bilinear weights.
    pub fn remap(&self, node: usize) -> NodeRemap {
        let w = quad_shape(self.xi[0], self.xi[1]);
        NodeRemap {
            node,
            sources: self
                .face
                .iter()
                .copied()
                .zip(w)
                .filter(|&(_, w)| w != 0.0)
                .collect(),
        }
    }
}

/// Closest points on a set of bilinear faces in their current positions.
pub(super) struct SurfaceProjector<'a> {
    faces: Vec<[usize; 4]>,
    current: &'a [[f64; 3]],
    /// Bins of faces (by their inflated boxes) on a uniform grid of this spacing from the
    /// origin.
    cell: f64,
    bins: std::collections::HashMap<[i64; 3], Vec<usize>>,
}

impl<'a> SurfaceProjector<'a> {
    /// A projector onto `faces` at the node positions `current`.
    pub fn new(faces: Vec<[usize; 4]>, current: &'a [[f64; 3]]) -> Self {
        let size = |f: &[usize; 4]| {
            (0..4)
                .map(|a| distance(current[f[a]], current[f[(a + 1) % 4]]))
                .fold(0.0, f64::max)
        };
        let cell = faces.iter().map(size).fold(0.0, f64::max).max(1e-12);
        let mut bins: std::collections::HashMap<[i64; 3], Vec<usize>> = Default::default();
        for (k, f) in faces.iter().enumerate() {
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for &n in f {
                for i in 0..3 {
                    lo[i] = lo[i].min(current[n][i]);
                    hi[i] = hi[i].max(current[n][i]);
                }
            }
            let key = |v: f64| (v / cell).floor() as i64;
            for a in key(lo[0] - cell)..=key(hi[0] + cell) {
                for b in key(lo[1] - cell)..=key(hi[1] + cell) {
                    for c in key(lo[2] - cell)..=key(hi[2] + cell) {
                        bins.entry([a, b, c]).or_default().push(k);
                    }
                }
            }
        }
        Self {
            faces,
            current,
            cell,
            bins,
        }
    }

    /// The closest point to `p` on the faces within about one face size of it (`None`
    /// when no face is that near).
    pub fn project(&self, p: [f64; 3]) -> Option<FacePoint> {
        let key: [i64; 3] = std::array::from_fn(|i| (p[i] / self.cell).floor() as i64);
        let mut best: Option<(f64, FacePoint)> = None;
        for &k in self.bins.get(&key)? {
            let face = self.faces[k];
            let x: [[f64; 3]; 4] = std::array::from_fn(|a| self.current[face[a]]);
            let xi = closest_natural(&x, p);
            let w = quad_shape(xi[0], xi[1]);
            let point: [f64; 3] = std::array::from_fn(|i| (0..4).map(|a| w[a] * x[a][i]).sum());
            let d = distance(point, p);
            if best.is_none_or(|(b, _)| d < b) {
                best = Some((d, FacePoint { face, xi, x: point }));
            }
        }
        best.map(|(_, point)| point)
    }
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

/// Natural coordinates of the point of the bilinear face `x` closest to `p`, within
/// [−1, 1]² (Gauss–Newton with the bounds enforced by clamping).
fn closest_natural(x: &[[f64; 3]; 4], p: [f64; 3]) -> [f64; 2] {
    let mut xi = [0.0, 0.0];
    for _ in 0..20 {
        let w = quad_shape(xi[0], xi[1]);
        let s: [f64; 3] = std::array::from_fn(|i| (0..4).map(|a| w[a] * x[a][i]).sum());
        let r: [f64; 3] = std::array::from_fn(|i| s[i] - p[i]);
        // ∂S/∂ξ, ∂S/∂η.
        let d: [[f64; 3]; 2] = std::array::from_fn(|k| {
            std::array::from_fn(|i| {
                (0..4)
                    .map(|a| {
                        let c = CORNERS[a];
                        let g = if k == 0 {
                            0.25 * c[0] * (1.0 + c[1] * xi[1])
                        } else {
                            0.25 * c[1] * (1.0 + c[0] * xi[0])
                        };
                        g * x[a][i]
                    })
                    .sum()
            })
        });
        let dot = |a: [f64; 3], b: [f64; 3]| (0..3).map(|i| a[i] * b[i]).sum::<f64>();
        let (a11, a12, a22) = (dot(d[0], d[0]), dot(d[0], d[1]), dot(d[1], d[1]));
        let (b1, b2) = (-dot(d[0], r), -dot(d[1], r));
        let det = a11 * a22 - a12 * a12;
        if !(det.abs() > 0.0) {
            break;
        }
        let step = [(a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det];
        let next = [
            (xi[0] + step[0]).clamp(-1.0, 1.0),
            (xi[1] + step[1]).clamp(-1.0, 1.0),
        ];
        let moved = (next[0] - xi[0]).abs().max((next[1] - xi[1]).abs());
        xi = next;
        if moved < 1e-12 {
            break;
        }
    }
    xi
}

/// The surface Laplacian ∫ ∇ₛN_a · ∇ₛN_b dA of a bilinear face at reference positions
/// `x0` (2 × 2 Gauss points).
fn face_laplacian(x0: &[[f64; 3]; 4]) -> [[f64; 4]; 4] {
    let g = 1.0 / 3f64.sqrt();
    let mut k = [[0.0; 4]; 4];
    for (xi, eta) in [(-g, -g), (g, -g), (g, g), (-g, g)] {
        // ∂N_a/∂ξ, ∂N_a/∂η.
        let dn: [[f64; 2]; 4] = std::array::from_fn(|a| {
            let c = CORNERS[a];
            [
                0.25 * c[0] * (1.0 + c[1] * eta),
                0.25 * c[1] * (1.0 + c[0] * xi),
            ]
        });
        let t: [[f64; 3]; 2] = std::array::from_fn(|d| {
            std::array::from_fn(|i| (0..4).map(|a| dn[a][d] * x0[a][i]).sum())
        });
        let dot = |a: [f64; 3], b: [f64; 3]| (0..3).map(|i| a[i] * b[i]).sum::<f64>();
        let (g11, g12, g22) = (dot(t[0], t[0]), dot(t[0], t[1]), dot(t[1], t[1]));
        let det = g11 * g22 - g12 * g12;
        if !(det > 0.0) {
            continue;
        }
        let area = det.sqrt();
        let inv = [[g22 / det, -g12 / det], [-g12 / det, g11 / det]];
        for a in 0..4 {
            for b in 0..4 {
                let mut v = 0.0;
                for p in 0..2 {
                    for q in 0..2 {
                        v += dn[a][p] * inv[p][q] * dn[b][q];
                    }
                }
                k[a][b] += area * v;
            }
        }
    }
    k
}

/// New surface points of the `sliding` nodes: their surface displacement w = x′ − X
/// harmonic along the surface (the bilinear faces' surface Laplacian on the reference
/// surface, hanging nodes tied to their masters), each node kept on the current surface:
/// projected Gauss–Seidel, each sweep relaxing a node's w to zero residual and projecting
/// X + w back onto the surface. A linear w (an undeformed or uniformly stretched flat
/// surface) has zero residual and is left exactly where it is. Returns each sliding node
/// that could be projected and its point (one that could not is left where it is).
pub(super) fn slide(
    reference: &[[f64; 3]],
    current: &[[f64; 3]],
    faces: &[[usize; 4]],
    sliding: &[bool],
    hanging: &[(usize, Vec<(usize, f64)>)],
) -> Vec<(usize, FacePoint)> {
    let n = current.len();
    let is_sliding = |node: usize| sliding.get(node).copied().unwrap_or(false);
    let mut masters_of: std::collections::HashMap<usize, &[(usize, f64)]> = Default::default();
    for (h, masters) in hanging {
        masters_of.insert(*h, masters);
    }
    // Each sliding node's rows: (face, local node, weight), its own (1) and through the
    // hanging nodes it is a master of (the tie's weight).
    let mut rows: std::collections::BTreeMap<usize, Vec<(usize, usize, f64)>> = Default::default();
    let mut used = Vec::new();
    for f in faces {
        let mut hit = false;
        for (a, &node) in f.iter().enumerate() {
            if is_sliding(node) {
                rows.entry(node).or_default().push((used.len(), a, 1.0));
                hit = true;
            } else if let Some(masters) = masters_of.get(&node) {
                for &(m, c) in masters.iter() {
                    if is_sliding(m) {
                        rows.entry(m).or_default().push((used.len(), a, c));
                        hit = true;
                    }
                }
            }
        }
        if hit {
            used.push(*f);
        }
    }
    if rows.is_empty() {
        return Vec::new();
    }
    let laplacians: Vec<[[f64; 4]; 4]> = used
        .iter()
        .map(|f| face_laplacian(&std::array::from_fn(|a| reference[f[a]])))
        .collect();
    // Projection onto the faces of the rows and their neighbours (not the whole surface:
    // the bins are as large as the largest face they hold).
    let mut near = vec![false; n];
    for f in &used {
        for &a in f {
            near[a] = true;
        }
    }
    let nearby: Vec<[usize; 4]> = faces
        .iter()
        .copied()
        .filter(|f| f.iter().any(|&a| near[a]))
        .collect();
    let projector = SurfaceProjector::new(nearby, current);
    let mean_edge = used
        .iter()
        .map(|f| distance(current[f[0]], current[f[1]]))
        .sum::<f64>()
        / used.len() as f64;
    // Current positions as they slide; hanging nodes follow their masters.
    let mut x = current.to_vec();
    let w_of = |x: &[[f64; 3]], node: usize| -> [f64; 3] {
        std::array::from_fn(|i| x[node][i] - reference[node][i])
    };
    let mut points: std::collections::BTreeMap<usize, FacePoint> = Default::default();
    for _ in 0..MAX_SWEEPS {
        let mut largest = 0.0f64;
        for (&node, entries) in &rows {
            // Residual and diagonal of the tied system at this node.
            let (mut r, mut d) = ([0.0; 3], 0.0);
            for &(f, a, c) in entries {
                let (face, k) = (&used[f], &laplacians[f]);
                for b in 0..4 {
                    let w = w_of(&x, face[b]);
                    for i in 0..3 {
                        r[i] += c * k[a][b] * w[i];
                    }
                }
                d += c * c * k[a][a];
            }
            if !(d > 0.0) {
                continue;
            }
            let target: [f64; 3] = std::array::from_fn(|i| x[node][i] - r[i] / d);
            let Some(point) = projector.project(target) else {
                continue;
            };
            largest = largest.max(distance(point.x, x[node]));
            x[node] = point.x;
            points.insert(node, point);
            // Hanging nodes this node is a master of follow at once.
            for &(f, a, c) in entries {
                let h = used[f][a];
                if h != node && c != 1.0 {
                    if let Some(masters) = masters_of.get(&h) {
                        x[h] = std::array::from_fn(|i| {
                            masters.iter().map(|&(m, w)| w * x[m][i]).sum()
                        });
                    }
                }
            }
        }
        if largest < SWEEP_TOLERANCE * mean_edge {
            break;
        }
    }
    points.into_iter().collect()
}
