//! The enclosed volume of a surface of faces and its first two derivatives, face by face:
//! the kernel shared by [`PressureLoad`](super::PressureLoad) and
//! [`VolumeControl`](super::VolumeControl).

use crate::dof::DofMap;
use crate::mesh::ElementKind;

/// Invalid input when building a pressure term.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PressureError {
    /// The element kind is not a surface kind.
    #[error("pressure surface '{set}': expected quad4 or tri3 faces, found {kind}")]
    UnsupportedKind { set: String, kind: &'static str },
    /// The connectivity length is not a multiple of the nodes per face.
    #[error("pressure surface '{set}': connectivity length {len} is not a multiple of {per}")]
    RaggedConnectivity { set: String, len: usize, per: usize },
    /// A connectivity entry (or the auxiliary node) refers to a missing node.
    #[error("pressure surface '{set}': {place} refers to node {node}, but there are only {num_nodes} nodes")]
    MissingNode {
        set: String,
        place: String,
        node: usize,
        num_nodes: usize,
    },
    /// The auxiliary node of a volume control is also a node of the surface.
    #[error("pressure surface '{set}': the auxiliary node must carry no face, but node {node} belongs to face {face}")]
    AuxiliaryNodeOnSurface {
        set: String,
        node: usize,
        face: usize,
    },
    /// The surface has no face.
    #[error("pressure surface '{set}': expected at least one face, found none")]
    Empty { set: String },
}

/// The antisymmetric coefficients `s_abc` (row-major `n×n×n`) of `V_e` for a face kind.
fn volume_coefficients(kind: ElementKind) -> Vec<f64> {
    let n = kind.nodes_per_element();
    let mut c = vec![0.0; n * n * n];
    if kind == ElementKind::Tri3 {
        c[3 + 2] = 1.0 / 6.0; // (a, b, c) = (0, 1, 2): index (a·3 + b)·3 + c
    } else {
        let g = 1.0 / 3f64.sqrt();
        let corners = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
        for q in corners {
            let (xi, eta) = (q[0] * g, q[1] * g);
            let shape: Vec<[f64; 3]> = corners
                .iter()
                .map(|&[xa, ea]| {
                    [
                        0.25 * (1.0 + xi * xa) * (1.0 + eta * ea),
                        0.25 * xa * (1.0 + eta * ea),
                        0.25 * ea * (1.0 + xi * xa),
                    ]
                })
                .collect();
            for a in 0..4 {
                for b in 0..4 {
                    for d in 0..4 {
                        c[(a * 4 + b) * 4 + d] += shape[a][0] * shape[b][1] * shape[d][2] / 3.0;
                    }
                }
            }
        }
    }
    let mut s = vec![0.0; n * n * n];
    for a in 0..n {
        for b in 0..n {
            for d in 0..n {
                let idx = |x: usize, y: usize, z: usize| c[(x * n + y) * n + z];
                s[(a * n + b) * n + d] = (idx(a, b, d) + idx(b, d, a) + idx(d, a, b)
                    - idx(b, a, d)
                    - idx(a, d, b)
                    - idx(d, b, a))
                    / 6.0;
            }
        }
    }
    s
}

fn levi_civita(i: usize, j: usize, k: usize) -> f64 {
    match (i, j, k) {
        (0, 1, 2) | (1, 2, 0) | (2, 0, 1) => 1.0,
        (0, 2, 1) | (2, 1, 0) | (1, 0, 2) => -1.0,
        _ => 0.0,
    }
}

/// A surface of quad4 or tri3 faces (outward right-hand normals) with the data to evaluate
/// the enclosed volume `V = Σ_e V_e` and its first two derivatives face by face.
#[derive(Debug, Clone)]
pub struct SurfaceVolume {
    pub(super) name: String,
    kind: ElementKind,
    connectivity: Vec<usize>,
    x0: Vec<[f64; 3]>,
    coefficients: Vec<f64>,
}

impl SurfaceVolume {
    /// Builds the surface from faces `connectivity` of `kind` over reference `nodes` (µm).
    pub fn new(
        name: impl Into<String>,
        kind: ElementKind,
        connectivity: Vec<usize>,
        nodes: &[[f64; 3]],
    ) -> Result<Self, PressureError> {
        let set: String = name.into();
        if kind != ElementKind::Quad4 && kind != ElementKind::Tri3 {
            return Err(PressureError::UnsupportedKind {
                set,
                kind: kind.name(),
            });
        }
        let per = kind.nodes_per_element();
        if !connectivity.len().is_multiple_of(per) {
            return Err(PressureError::RaggedConnectivity {
                set,
                len: connectivity.len(),
                per,
            });
        }
        if connectivity.is_empty() {
            return Err(PressureError::Empty { set });
        }
        let mut x0 = Vec::with_capacity(connectivity.len());
        for (i, &node) in connectivity.iter().enumerate() {
            match nodes.get(node) {
                Some(x) => x0.push(*x),
                None => {
                    return Err(PressureError::MissingNode {
                        set,
                        place: format!("face {}", i / per),
                        node,
                        num_nodes: nodes.len(),
                    })
                }
            }
        }
        Ok(SurfaceVolume {
            name: set,
            kind,
            connectivity,
            x0,
            coefficients: volume_coefficients(kind),
        })
    }

    /// Face kind.
    pub fn kind(&self) -> ElementKind {
        self.kind
    }

    /// Nodes per face.
    pub fn nodes_per_face(&self) -> usize {
        self.kind.nodes_per_element()
    }

    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.connectivity.len() / self.nodes_per_face()
    }

    /// Nodes of face `e`.
    pub fn face(&self, e: usize) -> &[usize] {
        let n = self.nodes_per_face();
        &self.connectivity[e * n..(e + 1) * n]
    }

    /// Volume contribution `V_e` of face `e` at displacements `u_e` (node-major, 3 per node),
    /// writing `∂V_e/∂u_e` into `grad` and, if given, `∂²V_e/∂u_e²` (row-major) into `hess`.
    pub fn face_volume(
        &self,
        e: usize,
        u_e: &[f64],
        grad: &mut [f64],
        hess: Option<&mut [f64]>,
    ) -> f64 {
        let n = self.nodes_per_face();
        let s = &self.coefficients;
        let mut x = [[0.0; 3]; 4];
        for a in 0..n {
            for i in 0..3 {
                x[a][i] = self.x0[e * n + a][i] + u_e[3 * a + i];
            }
        }
        let nd = 3 * n;
        grad[..nd].fill(0.0);
        let mut volume = 0.0;
        for a in 0..n {
            for b in 0..n {
                for c in 0..n {
                    let sabc = s[(a * n + b) * n + c];
                    if sabc == 0.0 {
                        continue;
                    }
                    let (xb, xc) = (&x[b], &x[c]);
                    let cross = [
                        xb[1] * xc[2] - xb[2] * xc[1],
                        xb[2] * xc[0] - xb[0] * xc[2],
                        xb[0] * xc[1] - xb[1] * xc[0],
                    ];
                    for i in 0..3 {
                        volume += sabc * x[a][i] * cross[i];
                        grad[3 * a + i] += 3.0 * sabc * cross[i];
                    }
                }
            }
        }
        if let Some(h) = hess {
            h[..nd * nd].fill(0.0);
            for a in 0..n {
                for b in 0..n {
                    for c in 0..n {
                        let sabc = 6.0 * s[(a * n + b) * n + c];
                        if sabc == 0.0 {
                            continue;
                        }
                        for i in 0..3 {
                            for j in 0..3 {
                                let m: f64 = (0..3).map(|k| levi_civita(i, j, k) * x[c][k]).sum();
                                h[(3 * a + i) * nd + 3 * b + j] += sabc * m;
                            }
                        }
                    }
                }
            }
        }
        volume
    }

    /// The volume `V(x) = Σ_e V_e` at global DOF values `u` (µm³); the enclosed volume when the
    /// surface is closed with outward normals.
    pub fn volume(&self, u: &[f64], dof_map: &DofMap) -> f64 {
        let n = self.nodes_per_face();
        let mut u_e = [0.0; 12];
        let mut grad = [0.0; 12];
        (0..self.num_faces())
            .map(|e| {
                for (a, &node) in self.face(e).iter().enumerate() {
                    for c in 0..3 {
                        u_e[3 * a + c] = u[dof_map.dof(node, c)];
                    }
                }
                self.face_volume(e, &u_e[..3 * n], &mut grad, None)
            })
            .sum()
    }

    /// The reference volume `V(X)`.
    pub fn reference_volume(&self) -> f64 {
        let n = self.nodes_per_face();
        let zero = [0.0; 12];
        let mut grad = [0.0; 12];
        (0..self.num_faces())
            .map(|e| self.face_volume(e, &zero[..3 * n], &mut grad, None))
            .sum()
    }
}
