//! Uniform pressure on a surface of quads or triangles, as the potential of the enclosed
//! volume: `Π = −p V(x)`.
//!
//! # Volume of a surface
//! By the divergence theorem the volume enclosed by a closed surface with outward normals is
//! `V = 1/3 ∮ x·n dA`, a sum of face contributions
//! `V_e = 1/3 ∫ x·(x_ξ × x_η) dξ dη`. For a bilinear quad the integrand is a polynomial of
//! degree 2 in ξ and in η, so 2×2 Gauss is exact; for a triangle `V_e = x₀·(x₁×x₂)/6`.
//! Either way `V_e` is a cubic form of the nodal positions,
//! `V_e = Σ_abc s_abc ε_ijk x_a^i x_b^j x_c^k`, with `s` antisymmetric in `(a, b, c)`
//! (precomputed once per element kind). Hence
//! `∂V_e/∂x_a^i = 3 Σ_bc s_abc ε_ijk x_b^j x_c^k` and
//! `∂²V_e/∂x_a^i∂x_b^j = 6 Σ_c s_abc ε_ijk x_c^k`,
//! a symmetric Hessian. The residual of `Π` is `−p ∂V/∂x` (the follower pressure load) and
//! its tangent `−p ∂²V/∂x²` (the load stiffness).
//!
//! # Closed and open surfaces
//! The sum of `V_e` equals the enclosed volume, and `−p ∂V/∂x` the nodal pressure forces
//! `p ∫ N_a n da`, only when the surface is closed. For an open surface the two differ by
//! terms from the missing closing faces: the load is then conservative and exact only when the
//! boundary nodes are fixed, or when the boundary lies in planes through the origin and its
//! nodes stay in them (symmetry planes through the centre: closing faces there add
//! `x·n = 0`). Then the tangent is the exact, symmetric Hessian of the true potential.
//!
//! # Load control
//! [`PressureLoad`] applies a prescribed pressure held in a [`PressureHandle`] that the caller
//! may change between steps (the solver ramps only nodal loads and motions, so a new pressure
//! is applied in full at the first increment of a step). [`VolumeControl`] instead prescribes
//! the enclosed volume through an auxiliary node and makes the pressure a Lagrange multiplier,
//! which passes limit points (balloon inflation) with the ordinary displacement control.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use super::KernelError;
use crate::dof::DofMap;
use crate::mesh::ElementKind;
use crate::term::Term;

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
    name: String,
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

    fn node_dofs(&self, e: usize, dof_map: &DofMap, dofs: &mut [usize]) -> usize {
        for (a, &node) in self.face(e).iter().enumerate() {
            for c in 0..3 {
                dofs[3 * a + c] = dof_map.dof(node, c);
            }
        }
        3 * self.nodes_per_face()
    }
}

/// A pressure value shared between a [`PressureLoad`] and its caller, who may change it
/// between steps after the term has been moved into a problem.
#[derive(Debug, Clone, Default)]
pub struct PressureHandle(Arc<AtomicU64>);

impl PressureHandle {
    /// Sets the pressure (kPa; positive pushes along the outward normal, inflating a closed
    /// surface).
    pub fn set(&self, pressure: f64) {
        self.0.store(pressure.to_bits(), Ordering::Relaxed);
    }

    /// The current pressure (kPa).
    pub fn get(&self) -> f64 {
        f64::from_bits(self.0.load(Ordering::Relaxed))
    }
}

/// A prescribed uniform pressure `p` on a surface: `Π = −p V(x)`, residual `−p ∂V/∂x`,
/// tangent `−p ∂²V/∂x²` (see the module notes for open surfaces).
#[derive(Debug, Clone)]
pub struct PressureLoad {
    surface: SurfaceVolume,
    pressure: PressureHandle,
}

impl PressureLoad {
    /// A pressure term on `surface`, starting at pressure `pressure` (kPa).
    pub fn new(surface: SurfaceVolume, pressure: f64) -> Self {
        let handle = PressureHandle::default();
        handle.set(pressure);
        PressureLoad {
            surface,
            pressure: handle,
        }
    }

    /// Sets the pressure (kPa) used from the next evaluation on.
    pub fn set_pressure(&self, pressure: f64) {
        self.pressure.set(pressure);
    }

    /// The current pressure (kPa).
    pub fn pressure(&self) -> f64 {
        self.pressure.get()
    }

    /// A handle to change the pressure after the term is boxed into a problem.
    pub fn pressure_handle(&self) -> PressureHandle {
        self.pressure.clone()
    }

    /// The loaded surface.
    pub fn surface(&self) -> &SurfaceVolume {
        &self.surface
    }
}

impl Term for PressureLoad {
    fn name(&self) -> &str {
        &self.surface.name
    }

    fn num_elements(&self) -> usize {
        self.surface.num_faces()
    }

    fn element_dofs(&self, e: usize, dof_map: &DofMap, dofs: &mut [usize]) -> usize {
        self.surface.node_dofs(e, dof_map, dofs)
    }

    fn evaluate(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let p = self.pressure.get();
        let nd = 3 * self.surface.nodes_per_face();
        let mut tangent = tangent;
        let volume = self
            .surface
            .face_volume(e, u_e, residual, tangent.as_deref_mut());
        residual[..nd].iter_mut().for_each(|r| *r *= -p);
        if let Some(t) = tangent {
            t[..nd * nd].iter_mut().for_each(|k| *k *= -p);
        }
        Ok(-p * volume)
    }
}

/// Volume control of a closed surface: the enclosed volume change `ΔV` is a DOF that the
/// caller prescribes (e.g. `Motion::To`), and the pressure `p` is a free DOF (a Lagrange
/// multiplier), both on an auxiliary node that no other term uses:
/// `Π = −p (V(x) − V(X) − ΔV)`, split per face as `−p (V_e(x) − V_e(X) − ΔV/n_faces)`.
///
/// Stationarity in `p` enforces `V(x) = V(X) + ΔV`; in `x` it gives the pressure load
/// `p ∂V/∂x`. At a converged state the DOF value `p` (and the reaction on the `ΔV` DOF) is
/// the pressure that holds the volume. The tangent is symmetric but indefinite (saddle point):
/// use an LDLᵀ or LU solver. Component 2 of the auxiliary node is unused (the solver holds it).
#[derive(Debug, Clone)]
pub struct VolumeControl {
    surface: SurfaceVolume,
    auxiliary_node: usize,
    face_reference_volume: Vec<f64>,
}

impl VolumeControl {
    /// Volume control of `surface` with pressure and volume-change DOFs on `auxiliary_node`
    /// (components 0 and 1), which must exist in the DOF map and carry no element.
    pub fn new(surface: SurfaceVolume, auxiliary_node: usize) -> Result<Self, PressureError> {
        if let Some(e) =
            (0..surface.num_faces()).find(|&e| surface.face(e).contains(&auxiliary_node))
        {
            return Err(PressureError::AuxiliaryNodeOnSurface {
                set: surface.name.clone(),
                node: auxiliary_node,
                face: e,
            });
        }
        let n = surface.nodes_per_face();
        let zero = [0.0; 12];
        let mut grad = [0.0; 12];
        let face_reference_volume = (0..surface.num_faces())
            .map(|e| surface.face_volume(e, &zero[..3 * n], &mut grad, None))
            .collect();
        Ok(VolumeControl {
            surface,
            auxiliary_node,
            face_reference_volume,
        })
    }

    /// Global DOF of the pressure multiplier `p` (kPa).
    pub fn pressure_dof(&self, dof_map: &DofMap) -> usize {
        dof_map.dof(self.auxiliary_node, 0)
    }

    /// Global DOF of the prescribed volume change `ΔV` (µm³).
    pub fn volume_change_dof(&self, dof_map: &DofMap) -> usize {
        dof_map.dof(self.auxiliary_node, 1)
    }

    /// The reference enclosed volume `V(X)` (µm³).
    pub fn reference_volume(&self) -> f64 {
        self.face_reference_volume.iter().sum()
    }

    /// The controlled surface.
    pub fn surface(&self) -> &SurfaceVolume {
        &self.surface
    }
}

impl Term for VolumeControl {
    fn name(&self) -> &str {
        &self.surface.name
    }

    fn num_elements(&self) -> usize {
        self.surface.num_faces()
    }

    fn element_dofs(&self, e: usize, dof_map: &DofMap, dofs: &mut [usize]) -> usize {
        let nd = self.surface.node_dofs(e, dof_map, dofs);
        dofs[nd] = self.pressure_dof(dof_map);
        dofs[nd + 1] = self.volume_change_dof(dof_map);
        nd + 2
    }

    fn evaluate(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let nd = 3 * self.surface.nodes_per_face();
        let m = nd + 2;
        let (p, dv) = (u_e[nd], u_e[nd + 1]);
        let share = 1.0 / self.surface.num_faces() as f64;
        let mut grad = [0.0; 12];
        let mut hess = [0.0; 144];
        let want = tangent.is_some();
        let v = self.surface.face_volume(
            e,
            &u_e[..nd],
            &mut grad,
            if want {
                Some(&mut hess[..nd * nd])
            } else {
                None
            },
        );
        let constraint = v - self.face_reference_volume[e] - share * dv;
        for i in 0..nd {
            residual[i] = -p * grad[i];
        }
        residual[nd] = -constraint;
        residual[nd + 1] = p * share;
        if let Some(t) = tangent {
            t[..m * m].fill(0.0);
            for i in 0..nd {
                for j in 0..nd {
                    t[i * m + j] = -p * hess[i * nd + j];
                }
                t[i * m + nd] = -grad[i];
                t[nd * m + i] = -grad[i];
            }
            t[nd * m + nd + 1] = share;
            t[(nd + 1) * m + nd] = share;
        }
        Ok(-p * constraint)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube_surface() -> (Vec<[f64; 3]>, Vec<usize>) {
        let nodes: Vec<[f64; 3]> = (0..8)
            .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
            .collect();
        // Outward faces of the unit cube (node = x + 2y + 4z).
        let faces = vec![
            0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 1, 3, 7, 5, 3, 2, 6, 7, 2, 0, 4, 6,
        ];
        (nodes, faces)
    }

    fn warped(u_scale: f64) -> Vec<f64> {
        (0..24)
            .map(|i| u_scale * ((i as f64 * 1.7).sin() + 0.3 * (i as f64 * 0.37).cos()))
            .collect()
    }

    #[test]
    fn pressure_volume_of_closed_surfaces_is_exact() {
        let (nodes, faces) = cube_surface();
        let s = SurfaceVolume::new("cube", ElementKind::Quad4, faces.clone(), &nodes).unwrap();
        assert!((s.reference_volume() - 1.0).abs() < 1e-15);
        // Translation invariance and scaling by an affine map: V = det F for the unit cube.
        let f = [[1.3, 0.2, -0.1], [0.1, 0.8, 0.3], [0.05, -0.2, 1.1]];
        let det = f[0][0] * (f[1][1] * f[2][2] - f[1][2] * f[2][1])
            - f[0][1] * (f[1][0] * f[2][2] - f[1][2] * f[2][0])
            + f[0][2] * (f[1][0] * f[2][1] - f[1][1] * f[2][0]);
        let u: Vec<f64> = nodes
            .iter()
            .flat_map(|x| {
                (0..3).map(move |i| (0..3).map(|j| f[i][j] * x[j]).sum::<f64>() - x[i] + 5.0)
            })
            .collect();
        let v = s.volume(&u, &DofMap::translational(8));
        assert!((v - det).abs() < 1e-13, "volume {v} vs det F {det}");
        // Triangulated cube: split each quad along its 0-2 diagonal.
        let tris: Vec<usize> = faces
            .chunks(4)
            .flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]])
            .collect();
        let t = SurfaceVolume::new("cube", ElementKind::Tri3, tris, &nodes).unwrap();
        let v = t.volume(&u, &DofMap::translational(8));
        assert!((v - det).abs() < 1e-13);
        // Warped bilinear faces: volume is independent of the origin (closed surface).
        let w = warped(0.2);
        let shifted: Vec<f64> = w
            .iter()
            .enumerate()
            .map(|(i, x)| x + [3.0, -2.0, 7.0][i % 3])
            .collect();
        let (v1, v2) = (
            s.volume(&w, &DofMap::translational(8)),
            s.volume(&shifted, &DofMap::translational(8)),
        );
        assert!(
            (v1 - v2).abs() < 1e-13 && (v1 - 1.0).abs() > 1e-3,
            "{v1} {v2}"
        );
    }

    #[test]
    fn pressure_residual_and_tangent_match_finite_differences() {
        let (nodes, faces) = cube_surface();
        for kind in [ElementKind::Quad4, ElementKind::Tri3] {
            let conn = if kind == ElementKind::Quad4 {
                faces.clone()
            } else {
                faces.chunks(4).flat_map(|q| [q[0], q[1], q[2]]).collect()
            };
            let load = PressureLoad::new(SurfaceVolume::new("p", kind, conn, &nodes).unwrap(), 0.5);
            load.pressure_handle().set(2.5);
            assert_eq!(load.pressure(), 2.5);
            let nd = 3 * kind.nodes_per_element();
            let w = warped(0.3);
            let u0: Vec<f64> = (0..nd).map(|i| w[i] + 0.1 * i as f64).collect();
            let (mut r, mut k) = (vec![0.0; nd], vec![0.0; nd * nd]);
            load.evaluate(1, &u0, &mut r, Some(&mut k)).unwrap();
            let h = 1e-6;
            for j in 0..nd {
                let (mut up, mut um) = (u0.clone(), u0.clone());
                up[j] += h;
                um[j] -= h;
                let (mut rp, mut rm) = (vec![0.0; nd], vec![0.0; nd]);
                let ep = load.evaluate(1, &up, &mut rp, None).unwrap();
                let em = load.evaluate(1, &um, &mut rm, None).unwrap();
                assert!(
                    ((ep - em) / (2.0 * h) - r[j]).abs() < 1e-8,
                    "{kind:?} residual {j}"
                );
                for i in 0..nd {
                    let fd = (rp[i] - rm[i]) / (2.0 * h);
                    assert!(
                        (fd - k[i * nd + j]).abs() < 1e-8,
                        "{kind:?} tangent ({i},{j})"
                    );
                    assert!((k[i * nd + j] - k[j * nd + i]).abs() < 1e-14);
                }
            }
        }
    }

    #[test]
    fn pressure_on_closed_surface_gives_follower_nodal_forces() {
        // Unit cube, p = 3: each corner node carries p·(1/4) of each of its three faces, so the
        // assembled residual −p ∂V/∂x is −(3/4)(±1, ±1, ±1), outward at every corner. (A
        // single face's contribution is not p∫N n dA: only the closed sum is.)
        let (nodes, faces) = cube_surface();
        let load = PressureLoad::new(
            SurfaceVolume::new("p", ElementKind::Quad4, faces, &nodes).unwrap(),
            3.0,
        );
        let mut total = vec![0.0; 24];
        let mut r = [0.0; 12];
        let mut dofs = [0; 24];
        let map = DofMap::translational(8);
        for e in 0..6 {
            load.evaluate(e, &[0.0; 12], &mut r, None).unwrap();
            load.element_dofs(e, &map, &mut dofs);
            for a in 0..12 {
                total[dofs[a]] += r[a];
            }
        }
        for (node, x) in nodes.iter().enumerate() {
            for i in 0..3 {
                let expected = -0.75 * (2.0 * x[i] - 1.0);
                assert!(
                    (total[3 * node + i] - expected).abs() < 1e-14,
                    "node {node}"
                );
            }
        }
    }

    #[test]
    fn pressure_volume_control_tangent_matches_finite_differences() {
        let (nodes, faces) = cube_surface();
        let mut all = nodes.clone();
        all.push([0.0; 3]);
        let s = SurfaceVolume::new("vc", ElementKind::Quad4, faces.clone(), &all).unwrap();
        assert!(matches!(
            VolumeControl::new(s.clone(), 3),
            Err(PressureError::AuxiliaryNodeOnSurface { .. })
        ));
        let vc = VolumeControl::new(s, 8).unwrap();
        let map = DofMap::translational(9);
        assert_eq!(
            (vc.pressure_dof(&map), vc.volume_change_dof(&map)),
            (24, 25)
        );
        let mut dofs = [0; 24];
        assert_eq!(vc.element_dofs(2, &map, &mut dofs), 14);
        let w = warped(0.2);
        let mut u0: Vec<f64> = w[..12].to_vec();
        u0.extend([1.7, 0.4]);
        let (mut r, mut k) = (vec![0.0; 14], vec![0.0; 196]);
        vc.evaluate(2, &u0, &mut r, Some(&mut k)).unwrap();
        let h = 1e-6;
        for j in 0..14 {
            let (mut up, mut um) = (u0.clone(), u0.clone());
            up[j] += h;
            um[j] -= h;
            let (mut rp, mut rm) = (vec![0.0; 14], vec![0.0; 14]);
            let ep = vc.evaluate(2, &up, &mut rp, None).unwrap();
            let em = vc.evaluate(2, &um, &mut rm, None).unwrap();
            assert!(((ep - em) / (2.0 * h) - r[j]).abs() < 1e-8);
            for i in 0..14 {
                assert!(((rp[i] - rm[i]) / (2.0 * h) - k[i * 14 + j]).abs() < 1e-8);
            }
        }
    }
}
