//! Large-strain membranes (no bending stiffness): incompressible neo-Hookean plane stress on
//! 4-node bilinear quadrilaterals (2×2 Gauss) and 3-node triangles (1 point).
//!
//! # Formulation
//! At each quadrature point an orthonormal tangent basis `(e₁, e₂)` of the *reference* surface
//! is built from `G_ξ = ∂X/∂ξ`, `G_η = ∂X/∂η` (`e₁ = G_ξ/|G_ξ|`, `n = G_ξ×G_η/|G_ξ×G_η|`,
//! `e₂ = n×e₁`), so curved or warped reference elements are allowed. With local coordinates
//! `s_α` along `e_α`, the current covariant tangents are `g_α = ∂x/∂s_α = Σ_a N_{a,α} x_a` and
//! the in-plane right Cauchy–Green tensor is `C_{αβ} = g_α·g_β` (2×2). Its eigenvalues are the
//! squared principal stretches `λ₁², λ₂²`, and `det C = λ₁²λ₂²`.
//!
//! Incompressibility (`λ₃ = 1/(λ₁λ₂)`) with the plane-stress condition eliminates the
//! pressure, leaving the strain energy per unit reference volume
//!
//! `W(C) = μ/2 (tr C + 1/det C − 3) = μ/2 (λ₁² + λ₂² + λ₁⁻²λ₂⁻² − 3)`,
//!
//! and the element energy `Π_e = ∫ H W dA₀` (reference thickness `H`). The current thickness
//! is `h = H/(λ₁λ₂) = H/√det C`.
//!
//! Residual and tangent are the exact first and second derivatives of `Π_e`. Writing
//! `v = (C₁₁, C₂₂, C₁₂)` and `D = det C = v₁v₂ − v₃²`:
//! `∂W/∂v = μ/2 (1 − C₂₂/D², 1 − C₁₁/D², 2C₁₂/D²)`,
//! `∂²W/∂v² = μ/2 (2 D_v D_vᵀ/D³ − D_vv/D²)` with `D_v = (C₂₂, C₁₁, −2C₁₂)`, and
//! `∂v/∂x_a = (2N_{a,1} g₁, 2N_{a,2} g₂, N_{a,1} g₂ + N_{a,2} g₁)`, whose second derivatives
//! are multiples of the identity (the geometric stiffness). Hence
//! `R_a = Σ_q w_q H Σ_m W_m ∂v_m/∂x_a` and
//! `K_ab = Σ_q w_q H [Σ_mn W_mn ∂v_m/∂x_a ⊗ ∂v_n/∂x_b + Σ_m W_m ∂²v_m/∂x_a∂x_b]`.
//!
//! Principal Cauchy stresses of the incompressible sheet are `σ_i = μ(λ_i² − 1/(λ₁λ₂)²)` and
//! the true tensions (force per current length) `t_i = h σ_i`.

use super::KernelError;
use crate::dof::DofMap;
use crate::mesh::{ElementBlock, ElementKind};
use crate::term::{CellField, Term, TermOutput};

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

fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

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

/// Invalid input when building a [`MembraneSet`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MembraneError {
    /// The element kind is not a surface kind.
    #[error("membrane set '{set}': expected quad4 or tri3 elements, found {kind}")]
    UnsupportedKind { set: String, kind: &'static str },
    /// A material or geometric parameter is out of range.
    #[error("membrane set '{set}': {parameter} must be a finite number > 0, found {value}")]
    InvalidParameter {
        set: String,
        parameter: &'static str,
        value: f64,
    },
    /// The connectivity length is not a multiple of the nodes per element.
    #[error("membrane set '{set}': connectivity length {len} is not a multiple of {per}")]
    RaggedConnectivity { set: String, len: usize, per: usize },
    /// A connectivity entry refers to a missing node.
    #[error("membrane set '{set}': element {element} refers to node {node}, but there are only {num_nodes} nodes")]
    MissingNode {
        set: String,
        element: usize,
        node: usize,
        num_nodes: usize,
    },
    /// The reference geometry of an element is degenerate.
    #[error("membrane set '{set}': element {element}: {source}")]
    DegenerateElement {
        set: String,
        element: usize,
        source: KernelError,
    },
}

#[derive(Debug, Clone)]
enum References {
    Quad4(Vec<Quad4Reference>),
    Tri3(Vec<Tri3Reference>),
}

/// A set of membrane elements of one kind (quad4 or tri3) with one shear modulus `μ` (kPa)
/// and one reference thickness `H` (µm). A disabled set contributes nothing (no elements)
/// and writes no output, so a model can switch a layer off without changing its mesh.
#[derive(Debug, Clone)]
pub struct MembraneSet {
    name: String,
    kind: ElementKind,
    connectivity: Vec<usize>,
    shear_modulus: f64,
    thickness: f64,
    enabled: bool,
    references: References,
}

impl MembraneSet {
    /// Builds the set and precomputes every element's reference data from `nodes`.
    pub fn new(
        name: impl Into<String>,
        kind: ElementKind,
        connectivity: Vec<usize>,
        nodes: &[[f64; 3]],
        shear_modulus: f64,
        thickness: f64,
    ) -> Result<Self, MembraneError> {
        let set: String = name.into();
        if kind != ElementKind::Quad4 && kind != ElementKind::Tri3 {
            return Err(MembraneError::UnsupportedKind {
                set,
                kind: kind.name(),
            });
        }
        for (parameter, value) in [("shear modulus", shear_modulus), ("thickness", thickness)] {
            if !(value > 0.0 && value.is_finite()) {
                return Err(MembraneError::InvalidParameter {
                    set,
                    parameter,
                    value,
                });
            }
        }
        let per = kind.nodes_per_element();
        if !connectivity.len().is_multiple_of(per) {
            return Err(MembraneError::RaggedConnectivity {
                set,
                len: connectivity.len(),
                per,
            });
        }
        let mut coords = Vec::with_capacity(connectivity.len());
        for (i, &node) in connectivity.iter().enumerate() {
            match nodes.get(node) {
                Some(x) => coords.push(*x),
                None => {
                    return Err(MembraneError::MissingNode {
                        set,
                        element: i / per,
                        node,
                        num_nodes: nodes.len(),
                    })
                }
            }
        }
        let wrap = |element: usize, source: KernelError| MembraneError::DegenerateElement {
            set: set.clone(),
            element,
            source,
        };
        let references = if kind == ElementKind::Quad4 {
            let refs = coords
                .chunks_exact(4)
                .enumerate()
                .map(|(e, c)| Quad4Reference::new([c[0], c[1], c[2], c[3]]).map_err(|s| wrap(e, s)))
                .collect::<Result<Vec<_>, _>>()?;
            References::Quad4(refs)
        } else {
            let refs = coords
                .chunks_exact(3)
                .enumerate()
                .map(|(e, c)| Tri3Reference::new([c[0], c[1], c[2]]).map_err(|s| wrap(e, s)))
                .collect::<Result<Vec<_>, _>>()?;
            References::Tri3(refs)
        };
        Ok(MembraneSet {
            name: set,
            kind,
            connectivity,
            shear_modulus,
            thickness,
            enabled: true,
            references,
        })
    }

    /// Builds the set from a quad4 or tri3 mesh block (e.g. from
    /// [`crate::mesh::surface::quad_block`]), keeping the block's name.
    pub fn from_block(
        block: &ElementBlock,
        nodes: &[[f64; 3]],
        shear_modulus: f64,
        thickness: f64,
    ) -> Result<Self, MembraneError> {
        Self::new(
            block.name.clone(),
            block.kind,
            block.connectivity.clone(),
            nodes,
            shear_modulus,
            thickness,
        )
    }

    /// Switches the whole set on or off.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// Whether the set contributes to the model.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Element kind (quad4 or tri3).
    pub fn kind(&self) -> ElementKind {
        self.kind
    }

    /// Shear modulus μ (kPa).
    pub fn shear_modulus(&self) -> f64 {
        self.shear_modulus
    }

    /// Reference thickness H (µm).
    pub fn thickness(&self) -> f64 {
        self.thickness
    }

    /// Flat node connectivity.
    pub fn connectivity(&self) -> &[usize] {
        &self.connectivity
    }

    fn per(&self) -> usize {
        self.kind.nodes_per_element()
    }

    /// State of element `e` at its displacements `u_e` (see [`membrane_state`]).
    pub fn element_state(&self, e: usize, u_e: &[f64]) -> Result<MembraneState, KernelError> {
        let (mu, h) = (self.shear_modulus, self.thickness);
        match &self.references {
            References::Quad4(r) => membrane_state(&r[e], mu, h, u_e),
            References::Tri3(r) => membrane_state(&r[e], mu, h, u_e),
        }
    }
}

impl Term for MembraneSet {
    fn name(&self) -> &str {
        &self.name
    }

    fn num_elements(&self) -> usize {
        if self.enabled {
            self.connectivity.len() / self.per()
        } else {
            0
        }
    }

    fn element_dofs(&self, e: usize, dof_map: &DofMap, dofs: &mut [usize]) -> usize {
        let per = self.per();
        for (a, &node) in self.connectivity[e * per..(e + 1) * per].iter().enumerate() {
            for c in 0..3 {
                dofs[3 * a + c] = dof_map.dof(node, c);
            }
        }
        3 * per
    }

    fn evaluate(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let (mu, h) = (self.shear_modulus, self.thickness);
        match &self.references {
            References::Quad4(r) => membrane_quad4_evaluate(&r[e], mu, h, u_e, residual, tangent),
            References::Tri3(r) => membrane_tri3_evaluate(&r[e], mu, h, u_e, residual, tangent),
        }
    }

    /// Cells with `membrane_tension_nN_per_um` (2 principal true tensions, largest first),
    /// `thickness_um` and `area_stretch`, averaged over each element's quadrature points.
    fn outputs(&self, u: &[f64], dof_map: &DofMap) -> Result<Option<TermOutput>, KernelError> {
        if !self.enabled {
            return Ok(None);
        }
        let per = self.per();
        let count = self.connectivity.len() / per;
        let mut tension = Vec::with_capacity(2 * count);
        let mut thickness = Vec::with_capacity(count);
        let mut area = Vec::with_capacity(count);
        let mut u_e = [0.0; 12];
        for e in 0..count {
            for (a, &node) in self.connectivity[e * per..(e + 1) * per].iter().enumerate() {
                for c in 0..3 {
                    u_e[3 * a + c] = u[dof_map.dof(node, c)];
                }
            }
            let s = self.element_state(e, &u_e[..3 * per])?;
            tension.extend(s.principal_tensions);
            thickness.push(s.thickness);
            area.push(s.area_stretch);
        }
        let field = |name: &str, components, values| CellField {
            name: name.into(),
            components,
            values,
        };
        Ok(Some(TermOutput {
            kind: self.kind,
            connectivity: self.connectivity.clone(),
            fields: vec![
                field("membrane_tension_nN_per_um", 2, tension),
                field("thickness_um", 1, thickness),
                field("area_stretch", 1, area),
            ],
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Small deterministic generator in [-1, 1).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
    }

    fn rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
        let n = norm(&axis);
        let k = [axis[0] / n, axis[1] / n, axis[2] / n];
        let (s, c) = angle.sin_cos();
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let delta = if i == j { 1.0 } else { 0.0 };
                let skew = match (i, j) {
                    (0, 1) => -k[2],
                    (0, 2) => k[1],
                    (1, 0) => k[2],
                    (1, 2) => -k[0],
                    (2, 0) => -k[1],
                    (2, 1) => k[0],
                    _ => 0.0,
                };
                c * delta + s * skew + (1.0 - c) * k[i] * k[j]
            })
        })
    }

    fn apply(m: &[[f64; 3]; 3], x: &[f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| dot(&m[i], x))
    }

    type Eval<'a> = dyn Fn(&[f64], &mut [f64], Option<&mut [f64]>) -> Result<f64, KernelError> + 'a;

    /// Central-difference check of residual (from energy) and tangent (from residual);
    /// returns the largest relative errors.
    fn fd_check(eval: &Eval<'_>, u: &[f64]) -> (f64, f64) {
        let nd = u.len();
        let mut r = vec![0.0; nd];
        let mut k = vec![0.0; nd * nd];
        eval(u, &mut r, Some(&mut k)).unwrap();
        let rs = r.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let ks = k.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let h = 1e-6;
        let (mut er, mut ek) = (0.0f64, 0.0f64);
        for j in 0..nd {
            let (mut up, mut um) = (u.to_vec(), u.to_vec());
            up[j] += h;
            um[j] -= h;
            let (mut rp, mut rm) = (vec![0.0; nd], vec![0.0; nd]);
            let ep = eval(&up, &mut rp, None).unwrap();
            let em = eval(&um, &mut rm, None).unwrap();
            er = er.max(((ep - em) / (2.0 * h) - r[j]).abs() / rs);
            for i in 0..nd {
                ek = ek.max(((rp[i] - rm[i]) / (2.0 * h) - k[i * nd + j]).abs() / ks);
            }
        }
        for i in 0..nd {
            for j in 0..nd {
                assert!(
                    (k[i * nd + j] - k[j * nd + i]).abs() <= 1e-12 * ks,
                    "tangent not symmetric"
                );
            }
        }
        (er, ek)
    }

    /// A warped quad and a tilted triangle, deformed by a large stretch, shear and an
    /// out-of-plane rotation plus random nodal noise.
    fn deformed<const N: usize>(x0: &[[f64; 3]; N], seed: u64) -> Vec<f64> {
        let mut rng = Lcg(seed);
        let q = rotation([0.3, -1.0, 0.6], 1.1);
        let f = [[1.6, 0.3, 0.1], [-0.2, 0.7, 0.2], [0.1, 0.25, 1.2]];
        (0..N)
            .flat_map(|a| {
                let x = apply(&q, &apply(&f, &x0[a]));
                let noise: [f64; 3] = std::array::from_fn(|_| 0.1 * rng.next());
                (0..3)
                    .map(move |i| x[i] + noise[i] - x0[a][i])
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    const WARPED_QUAD: [[f64; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.2, 0.1, 0.15],
        [1.4, 1.1, -0.1],
        [-0.1, 0.9, 0.2],
    ];
    const TILTED_TRI: [[f64; 3]; 3] = [[0.1, 0.0, 0.3], [1.3, 0.2, -0.2], [0.4, 1.0, 0.5]];

    #[test]
    fn membrane_quad4_residual_and_tangent_match_finite_differences() {
        let r = Quad4Reference::new(WARPED_QUAD).unwrap();
        let eval = |u: &[f64], res: &mut [f64], t: Option<&mut [f64]>| {
            membrane_quad4_evaluate(&r, 3.0, 0.2, u, res, t)
        };
        for seed in 1..4 {
            let (er, ek) = fd_check(&eval, &deformed(&WARPED_QUAD, seed));
            assert!(
                er < 1e-7 && ek < 1e-7,
                "quad4 FD errors: residual {er:e} tangent {ek:e}"
            );
        }
    }

    #[test]
    fn membrane_tri3_residual_and_tangent_match_finite_differences() {
        let r = Tri3Reference::new(TILTED_TRI).unwrap();
        let eval = |u: &[f64], res: &mut [f64], t: Option<&mut [f64]>| {
            membrane_tri3_evaluate(&r, 2.0, 0.01, u, res, t)
        };
        for seed in 1..4 {
            let (er, ek) = fd_check(&eval, &deformed(&TILTED_TRI, seed));
            assert!(
                er < 1e-7 && ek < 1e-7,
                "tri3 FD errors: residual {er:e} tangent {ek:e}"
            );
        }
    }

    #[test]
    fn membrane_rigid_rotation_gives_zero_energy_and_residual() {
        let q = rotation([1.0, 2.0, -0.5], 2.3);
        let rq = Quad4Reference::new(WARPED_QUAD).unwrap();
        let rt = Tri3Reference::new(TILTED_TRI).unwrap();
        let u: Vec<f64> = WARPED_QUAD
            .iter()
            .flat_map(|x| {
                let y = apply(&q, x);
                (0..3).map(move |i| y[i] + 0.7 - x[i])
            })
            .collect();
        let mut res = [0.0; 12];
        let e = membrane_quad4_evaluate(&rq, 5.0, 0.3, &u, &mut res, None).unwrap();
        assert!(e.abs() < 1e-13, "quad energy {e:e}");
        assert!(res.iter().all(|r| r.abs() < 1e-13), "quad residual {res:?}");
        let u: Vec<f64> = TILTED_TRI
            .iter()
            .flat_map(|x| {
                let y = apply(&q, x);
                (0..3).map(move |i| y[i] - x[i])
            })
            .collect();
        let e = membrane_tri3_evaluate(&rt, 5.0, 0.3, &u, &mut res, None).unwrap();
        assert!(e.abs() < 1e-13 && res[..9].iter().all(|r| r.abs() < 1e-13));
    }

    #[test]
    fn membrane_homogeneous_biaxial_state_matches_closed_form() {
        // A tilted square of side 2 stretched by (l1, l2) in its own plane, then rotated.
        let q = rotation([0.2, 0.5, 1.0], 0.8);
        let flat = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 2.0, 0.0],
            [0.0, 2.0, 0.0],
        ];
        let x0: [[f64; 3]; 4] = std::array::from_fn(|a| apply(&q, &flat[a]));
        let (l1, l2, mu, h) = (1.7, 1.2, 4.0, 0.25);
        let u: Vec<f64> = (0..4)
            .flat_map(|a| {
                let y = apply(&q, &[l1 * flat[a][0], l2 * flat[a][1], 0.0]);
                (0..3).map(move |i| y[i] - x0[a][i])
            })
            .collect();
        let r = Quad4Reference::new(x0).unwrap();
        let mut res = [0.0; 12];
        let e = membrane_quad4_evaluate(&r, mu, h, &u, &mut res, None).unwrap();
        let w = 0.5 * mu * (l1 * l1 + l2 * l2 + 1.0 / (l1 * l1 * l2 * l2) - 3.0);
        assert!(
            (e - 4.0 * h * w).abs() < 1e-12 * e,
            "energy {e} vs {}",
            4.0 * h * w
        );
        let s = membrane_state(&r, mu, h, &u).unwrap();
        let j = l1 * l2;
        let t1 = h / j * mu * (l1 * l1 - 1.0 / (j * j));
        let t2 = h / j * mu * (l2 * l2 - 1.0 / (j * j));
        assert!(
            (s.principal_tensions[0] - t1).abs() < 1e-12
                && (s.principal_tensions[1] - t2).abs() < 1e-12
        );
        assert!((s.thickness - h / j).abs() < 1e-14 && (s.area_stretch - j).abs() < 1e-13);
        // Nodal force at node 2 along the stretched axis: nominal tension × half the edge.
        let fx = apply(&q, &[1.0, 0.0, 0.0]);
        let f2 = dot(&fx, &[res[6], res[7], res[8]]);
        let nominal = mu * h * (l1 - 1.0 / (l1 * l1 * l1 * l2 * l2));
        assert!((f2 - nominal).abs() < 1e-12 * nominal, "{f2} vs {nominal}");
    }

    #[test]
    fn membrane_rejects_degenerate_elements_and_bad_parameters() {
        let line = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert!(matches!(
            Tri3Reference::new(line),
            Err(KernelError::DegenerateReference { .. })
        ));
        let bowtie = [
            [0.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        assert!(Quad4Reference::new(bowtie).is_err());
        let nodes = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
        let err = MembraneSet::new("cm", ElementKind::Tri3, vec![0, 1, 2], &nodes, 1.0, 0.0);
        assert!(matches!(
            err,
            Err(MembraneError::InvalidParameter {
                parameter: "thickness",
                ..
            })
        ));
        let err = MembraneSet::new("cm", ElementKind::Tri3, vec![0, 1, 2], &nodes, -1.0, 0.1);
        assert!(matches!(err, Err(MembraneError::InvalidParameter { .. })));
        let err = MembraneSet::new("cm", ElementKind::Tri3, vec![0, 1, 5], &nodes, 1.0, 0.1);
        assert!(matches!(
            err,
            Err(MembraneError::MissingNode { node: 5, .. })
        ));
        let err = MembraneSet::new("cm", ElementKind::Hex8, vec![0; 8], &nodes, 1.0, 0.1);
        assert!(matches!(err, Err(MembraneError::UnsupportedKind { .. })));
        // A current configuration collapsed to a line is reported, not a NaN.
        let set =
            MembraneSet::new("cm", ElementKind::Tri3, vec![0, 1, 2], &nodes, 1.0, 0.1).unwrap();
        let u = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, -1.0, 0.0];
        let mut r = [0.0; 9];
        assert!(matches!(
            set.evaluate(0, &u, &mut r, None),
            Err(KernelError::InvertedElement { .. })
        ));
    }

    #[test]
    fn membrane_set_outputs_report_uniaxial_thinning() {
        let nodes = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let mut set = MembraneSet::new(
            "ac",
            ElementKind::Quad4,
            vec![0, 1, 2, 3],
            &nodes,
            0.67,
            0.2,
        )
        .unwrap();
        let l: f64 = 1.5;
        let l2 = l.powf(-0.5);
        let u: Vec<f64> = nodes
            .iter()
            .flat_map(|x| [(l - 1.0) * x[0], (l2 - 1.0) * x[1], 0.0])
            .collect();
        let out = set.outputs(&u, &DofMap::translational(4)).unwrap().unwrap();
        assert_eq!(out.kind, ElementKind::Quad4);
        let t = &out.fields[0].values;
        let expected = 0.2 / l.sqrt() * 0.67 * (l * l - 1.0 / l); // h σ₁ with h = H/√λ
        assert!(
            (t[0] - expected).abs() < 1e-13 && t[1].abs() < 1e-13,
            "{t:?}"
        );
        assert!((out.fields[1].values[0] - 0.2 / l.sqrt()).abs() < 1e-14);
        set.set_enabled(false);
        assert_eq!(set.num_elements(), 0);
        assert!(set
            .outputs(&u, &DofMap::translational(4))
            .unwrap()
            .is_none());
    }
}
