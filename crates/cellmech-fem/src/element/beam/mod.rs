//! Geometrically nonlinear 3-D beam: two nodes, six DOFs each (3 translations, then the 3
//! components of the nodal rotation vector), corotational formulation with an exact
//! large-rotation kinematics and a linear-elastic (small-strain) local element.
//!
//! # Parametrisation of the rotations
//! The engine's [`Term::evaluate`](crate::term::Term::evaluate) is a pure function of the
//! current DOF values, with no per-iteration state update. The rotational DOFs of a node
//! are therefore its **total** rotation vector θ (axis × angle) from the reference state:
//! the current triad of element `e` at that node is `T = exp(θ̂) T₀ₑ`, where `T₀ₑ` is the
//! element's reference triad. Newton updates of θ are then additive and legitimate, and
//! cutback simply restores the DOF vector. The map θ ↦ exp(θ̂) is smooth everywhere and a
//! local diffeomorphism for |θ| < 2π (a nodal rotation of up to 360° from the reference),
//! which covers the bending and buckling of filaments; a node that turns past 2π loses the
//! rank of the parametrisation (the limit is documented in `docs/beam.md`).
//!
//! # Corotational frame (Battini & Pacoste 2002, Crisfield 1990)
//! With `xₐ = Xₐ + uₐ`, `x_b = X_b + u_b`, `ℓ = |x_b − xₐ|`:
//! - `r₁ = (x_b − xₐ)/ℓ`,
//! - `q = ½ (Tₐ e₂ + T_b e₂)` (mean of the nodal triads' second axes),
//! - `r₃ = r₁ × q / |r₁ × q|`, `r₂ = r₃ × r₁`, `Rᵣ = [r₁ r₂ r₃]`.
//!
//! Local (deformational) quantities, exact for any rigid motion:
//! - extension `ū = ℓ − L`,
//! - end rotations `θ̄ₐ = log(Rᵣᵀ Tₐ)`, `θ̄_b = log(Rᵣᵀ T_b)` (the exact SO(3) logarithm,
//!   not a small-angle approximation; components along r₁ (twist), r₂, r₃ (bending)).
//!
//! # Local energy (Euler–Bernoulli, linear elastic)
//! `Πₑ = EA L/2 ε² + GJ/(2L) (θ̄_b1 − θ̄ₐ1)²
//!      + 2EI₂/L (θ̄ₐ2² + θ̄ₐ2 θ̄_b2 + θ̄_b2²) + 2EI₃/L (θ̄ₐ3² + θ̄ₐ3 θ̄_b3 + θ̄_b3²)`
//! (the classical end-moment relation `M = EI/L [4 2; 2 4] θ̄` in each plane), with the
//! axial strain ε of [`LocalStrain`]: the chord strain ū/L (`EA L/2 ε² = EA/(2L) ū²`) or,
//! by default, the shallow-arch strain that adds the bowing of the deflected element. Rigid
//! motions leave ū and θ̄ unchanged, so large rotations with small strains are exact.
//!
//! # Derivatives by automatic differentiation
//! The kinematics and the energy are written once over [`Scalar`]; evaluated with
//! [`HyperDual`] they give the residual `∂Πₑ/∂uₑ` and the consistent tangent `∂²Πₑ/∂uₑ²`
//! to rounding error, with no hand-derived geometric stiffness. The derivatives are taken
//! in 9 variables, not 12: Πₑ depends on the translations only through `u_b − uₐ`
//! (translation invariance), and each nodal triad `exp(θ̂)T₀` is evaluated in three
//! variables and embedded. Both are exact; together they make an evaluation with the
//! tangent about three times cheaper than 12-variable hyper-duals throughout.

mod set;
#[cfg(test)]
mod tests;

pub use set::{BeamElementResult, BeamSet, ForceStatistics};

use super::KernelError;
use crate::math::rotation::{exp_so3, log_so3, Mat3};
use crate::math::vec3::{cross, dot, norm};
use crate::math::{Dual, HyperDual, Scalar, Seeded, HD_N};

/// Number of DOFs of one beam element: `[uₐ(3), θₐ(3), u_b(3), θ_b(3)]`.
pub const BEAM_DOFS: usize = 12;

/// Invalid beam input (section, reference geometry, set definition).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BeamError {
    /// A moving stress-free geometry is malformed.
    #[error("beam set '{set}': moving reference: {message}")]
    Morph {
        /// Set name.
        set: String,
        /// What is wrong.
        message: String,
    },
    /// A section or geometric quantity must be finite and positive.
    #[error("beam: {name} must be finite and > 0, found {value}")]
    NonPositive {
        /// Which quantity.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A hollow section's inner diameter is not smaller than its outer diameter.
    #[error(
        "beam section: inner diameter {inner} must be smaller than the outer diameter {outer}"
    )]
    InnerNotSmaller {
        /// Inner diameter (µm).
        inner: f64,
        /// Outer diameter (µm).
        outer: f64,
    },
    /// Poisson's ratio outside (−1, 0.5].
    #[error("beam section: Poisson's ratio must lie in (-1, 0.5], found {0}")]
    PoissonRatio(f64),
    /// The reference "up" vector is (nearly) parallel to the element axis.
    #[error("beam reference: the up vector {up:?} is parallel to the element axis {axis:?}")]
    UpParallelToAxis {
        /// The up vector given.
        up: [f64; 3],
        /// The element axis.
        axis: [f64; 3],
    },
    /// The set's per-element lists differ in length.
    #[error("beam set '{set}': {pairs} node pairs but {references} references")]
    LengthMismatch {
        /// Set name.
        set: String,
        /// Number of node pairs.
        pairs: usize,
        /// Number of references.
        references: usize,
    },
    /// A node index is outside the coordinate list or the DOF map.
    #[error(
        "beam set '{set}': element {element} uses node {node}, but there are {num_nodes} nodes"
    )]
    NodeOutOfRange {
        /// Set name.
        set: String,
        /// Element index.
        element: usize,
        /// Node index.
        node: usize,
        /// Number of nodes.
        num_nodes: usize,
    },
    /// A beam node carries fewer than 6 DOFs in the DOF map.
    #[error("beam set '{set}': node {node} carries {count} DOFs; beam nodes need 6 (3 translations, 3 rotations)")]
    NodeWithoutRotations {
        /// Set name.
        set: String,
        /// Node index.
        node: usize,
        /// DOFs it carries.
        count: usize,
    },
    /// An element's reference geometry is invalid.
    #[error("beam set '{set}': element {element}: {source}")]
    Element {
        /// Set name.
        set: String,
        /// Element index.
        element: usize,
        /// What is wrong.
        source: Box<BeamError>,
    },
}

fn positive(name: &'static str, value: f64) -> Result<f64, BeamError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(BeamError::NonPositive { name, value })
    }
}

/// Elastic cross-section of a beam (units µm, kPa = nN/µm²).
///
/// `i2`, `i3` are the second moments of area about the element's local axes e₂, e₃
/// (bending by rotation about e₂ uses EI₂), `torsion_j` the torsion constant.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct BeamSection {
    /// Young's modulus E (kPa).
    pub youngs_modulus: f64,
    /// Shear modulus G (kPa).
    pub shear_modulus: f64,
    /// Area A (µm²).
    pub area: f64,
    /// Second moment of area about e₂, I₂ (µm⁴).
    pub i2: f64,
    /// Second moment of area about e₃, I₃ (µm⁴).
    pub i3: f64,
    /// Torsion constant J (µm⁴).
    pub torsion_j: f64,
}

impl BeamSection {
    /// A section from its six constants, all finite and > 0.
    pub fn new(
        youngs_modulus: f64,
        shear_modulus: f64,
        area: f64,
        i2: f64,
        i3: f64,
        torsion_j: f64,
    ) -> Result<Self, BeamError> {
        Ok(BeamSection {
            youngs_modulus: positive("Young's modulus", youngs_modulus)?,
            shear_modulus: positive("shear modulus", shear_modulus)?,
            area: positive("area", area)?,
            i2: positive("I2", i2)?,
            i3: positive("I3", i3)?,
            torsion_j: positive("torsion constant J", torsion_j)?,
        })
    }

    /// Solid circle of diameter `d`: `A = πd²/4`, `I₂ = I₃ = πd⁴/64`, `J = πd⁴/32`,
    /// `G = E/(2(1 + ν))`.
    pub fn solid_circular(
        youngs_modulus: f64,
        poisson_ratio: f64,
        diameter: f64,
    ) -> Result<Self, BeamError> {
        let d = positive("diameter", diameter)?;
        Self::circular(youngs_modulus, poisson_ratio, d, 0.0)
    }

    /// Hollow circle (tube) of diameters `outer > inner > 0`:
    /// `A = π(D² − d²)/4`, `I₂ = I₃ = π(D⁴ − d⁴)/64`, `J = π(D⁴ − d⁴)/32`,
    /// `G = E/(2(1 + ν))`. A microtubule (E = 1.2e6 kPa, D = 0.025 µm, d = 0.017 µm) has
    /// EA ≈ 317 nN and EI ≈ 0.018 nN·µm².
    pub fn hollow_circular(
        youngs_modulus: f64,
        poisson_ratio: f64,
        outer_diameter: f64,
        inner_diameter: f64,
    ) -> Result<Self, BeamError> {
        let outer = positive("outer diameter", outer_diameter)?;
        let inner = positive("inner diameter", inner_diameter)?;
        if inner >= outer {
            return Err(BeamError::InnerNotSmaller { inner, outer });
        }
        Self::circular(youngs_modulus, poisson_ratio, outer, inner)
    }

    fn circular(e: f64, nu: f64, outer: f64, inner: f64) -> Result<Self, BeamError> {
        let e = positive("Young's modulus", e)?;
        if !(nu > -1.0 && nu <= 0.5) {
            return Err(BeamError::PoissonRatio(nu));
        }
        let pi = std::f64::consts::PI;
        let area = pi * (outer.powi(2) - inner.powi(2)) / 4.0;
        let i = pi * (outer.powi(4) - inner.powi(4)) / 64.0;
        Self::new(e, e / (2.0 * (1.0 + nu)), area, i, i, 2.0 * i)
    }

    /// Axial stiffness EA (nN).
    pub fn axial_stiffness(&self) -> f64 {
        self.youngs_modulus * self.area
    }

    /// Bending stiffnesses (EI₂, EI₃) (nN·µm²).
    pub fn bending_stiffness(&self) -> (f64, f64) {
        (self.youngs_modulus * self.i2, self.youngs_modulus * self.i3)
    }
}

/// Reference geometry of one element: end points, length and reference triad
/// `T₀ = [e₁ e₂ e₃]` (columns: `triad[i][j]` is component `i` of axis `j`), with e₁ along
/// the element axis and e₂ the "up" vector made orthogonal to e₁. An initially curved
/// filament is several straight elements along the curve, each with its own triad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamReference {
    /// Reference position of node a (µm).
    pub x_a: [f64; 3],
    /// Reference position of node b (µm).
    pub x_b: [f64; 3],
    /// Reference length L (µm).
    pub length: f64,
    /// Reference triad, columns e₁, e₂, e₃.
    pub triad: Mat3<f64>,
}

impl BeamReference {
    /// The reference of an element from `x_a` to `x_b`. `up` fixes e₂ (made orthogonal to
    /// the axis); `None` picks the global axis least aligned with the element (ties: x, y, z
    /// order), which gives the same e₂ = z for every element of a curve in the x–y plane.
    pub fn new(x_a: [f64; 3], x_b: [f64; 3], up: Option<[f64; 3]>) -> Result<Self, BeamError> {
        let d: [f64; 3] = std::array::from_fn(|i| x_b[i] - x_a[i]);
        let length = positive("element length", norm(&d))?;
        let e1 = d.map(|c| c / length);
        let up = up.unwrap_or_else(|| {
            let k = (0..3).fold(0, |k, i| if e1[i].abs() < e1[k].abs() { i } else { k });
            std::array::from_fn(|i| if i == k { 1.0 } else { 0.0 })
        });
        let along = dot(&up, &e1);
        let p: [f64; 3] = std::array::from_fn(|i| up[i] - along * e1[i]);
        let n = norm(&p);
        if !(n > 1e-8 * norm(&up)) {
            return Err(BeamError::UpParallelToAxis { up, axis: e1 });
        }
        let e2 = p.map(|c| c / n);
        let e3 = cross(&e1, &e2);
        let triad = std::array::from_fn(|i| [e1[i], e2[i], e3[i]]);
        Ok(BeamReference {
            x_a,
            x_b,
            length,
            triad,
        })
    }
}

/// Deformational quantities of one element in its corotated frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamDeformation<S> {
    /// Current chord length ℓ (µm).
    pub length: S,
    /// Extension ū = ℓ − L (µm).
    pub extension: S,
    /// Local end rotation θ̄ₐ (twist, bending about r₂, bending about r₃; rad).
    pub theta_a: [S; 3],
    /// Local end rotation θ̄_b (rad).
    pub theta_b: [S; 3],
}

/// Smallest |r₁ × q| accepted for the corotated frame (the nodal triads' mean e₂ axis must
/// not turn into the chord).
const MIN_FRAME_SINE: f64 = 1e-6;

/// The corotational kinematics: chord length, extension and local end rotations of an
/// element with DOF values `u` (order `[uₐ, θₐ, u_b, θ_b]`), as functions of the
/// [`HD_N`] = 9 reduced variables `[u_b − uₐ, θₐ, θ_b]` when `S` carries derivatives (the
/// kinematics depend on the translations only through their difference; `expand_gradient`
/// and `expand_hessian` map the derivatives back to the 12 DOFs).
///
/// Errors ([`KernelError::InvertedElement`] with `det_f` the offending measure, so the
/// solver cuts the increment): a chord shorter than 1e-9 L (`det_f = ℓ/L`), a degenerate
/// frame (`det_f = |r₁ × q|`), or a local rotation within ~0.1° of π
/// (`det_f = 1 + tr(Rᵣᵀ T)`), which no small-strain state reaches.
pub fn beam_deformation<S: Seeded>(
    reference: &BeamReference,
    u: &[f64; BEAM_DOFS],
) -> Result<BeamDeformation<S>, KernelError> {
    let bad = |measure: f64| KernelError::InvertedElement {
        qp: 0,
        det_f: measure,
    };
    // ℓ − L = (2D·Δ + Δ·Δ)/(ℓ + L) with D = X_b − Xₐ, Δ = u_b − uₐ: the extension keeps
    // full relative precision even when it is 1e-10 of the length (stiff filaments under
    // piconewton loads), where ℓ − L would lose it to cancellation.
    let big_d: [f64; 3] = std::array::from_fn(|i| reference.x_b[i] - reference.x_a[i]);
    let delta: [S; 3] = std::array::from_fn(|i| S::variable(i, u[6 + i] - u[i]));
    let d: [S; 3] = std::array::from_fn(|i| delta[i] + big_d[i]);
    let length = dot(&d, &d).sqrt();
    if !(length.value() > 1e-9 * reference.length) {
        return Err(bad(length.value() / reference.length));
    }
    let two_d_delta = (delta[0] * big_d[0] + delta[1] * big_d[1] + delta[2] * big_d[2]) * 2.0;
    let extension = (two_d_delta + dot(&delta, &delta)) / (length + reference.length);
    let inv_length = length.recip();
    let r1 = d.map(|c| c * inv_length);
    // A nodal triad depends on that node's rotation vector alone: it is evaluated in the
    // three-variable companion scalar and embedded (exact, and far cheaper than carrying
    // all the variables through the exponential map).
    let triad = |first: usize, dof: usize| -> Mat3<S> {
        let theta: [S::Three; 3] = std::array::from_fn(|i| S::variable3(i, u[dof + i]));
        let r = exp_so3(&theta);
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                S::embed3(
                    r[i][0] * reference.triad[0][j]
                        + r[i][1] * reference.triad[1][j]
                        + r[i][2] * reference.triad[2][j],
                    first,
                )
            })
        })
    };
    let t_a = triad(3, 3);
    let t_b = triad(6, 9);
    let q: [S; 3] = std::array::from_fn(|i| (t_a[i][1] + t_b[i][1]) * 0.5);
    let r3 = cross(&r1, &q);
    let n3 = dot(&r3, &r3).sqrt();
    if !(n3.value() > MIN_FRAME_SINE) {
        return Err(bad(n3.value()));
    }
    let inv_n3 = n3.recip();
    let r3 = r3.map(|c| c * inv_n3);
    let r2 = cross(&r3, &r1);
    let frame = [r1, r2, r3];
    let local = |t: &Mat3<S>| -> Result<[S; 3], KernelError> {
        let m: Mat3<S> = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                frame[i][0] * t[0][j] + frame[i][1] * t[1][j] + frame[i][2] * t[2][j]
            })
        });
        log_so3(&m).ok_or_else(|| bad(m[0][0].value() + m[1][1].value() + m[2][2].value() + 1.0))
    };
    Ok(BeamDeformation {
        length,
        extension,
        theta_a: local(&t_a)?,
        theta_b: local(&t_b)?,
    })
}

/// The axial strain measure of the local element.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum LocalStrain {
    /// Chord strain `ε = ū/L` (the plain linear local element). Its only geometric
    /// stiffness is the chord rotation's ("string") term, so Euler loads converge slowly
    /// from above (+3 % for a cantilever in 10 elements).
    Chord,
    /// Shallow-arch strain (Crisfield 1991, §7.2; Battini 2002): the chord strain plus the
    /// bowing of the cubic deflection between the end rotations, the mean of
    /// `½ w′²` over the element:
    /// `ε = ū/L + (1/30) Σ_{k=2,3} (2θ̄ₐₖ² − θ̄ₐₖ θ̄_bₖ + 2θ̄_bₖ²)`.
    /// Its linearisation contains the consistent geometric stiffness `N L/30 [4 −1; −1 4]`
    /// of the end rotations, so Euler loads are accurate to ≪ 1 % with ~10 elements.
    #[default]
    ShallowArch,
}

impl LocalStrain {
    /// The axial strain ε of a deformation (see the variants).
    pub fn strain<S: Scalar>(self, length: f64, d: &BeamDeformation<S>) -> S {
        let chord = d.extension * (1.0 / length);
        match self {
            LocalStrain::Chord => chord,
            LocalStrain::ShallowArch => {
                let (a, b) = (&d.theta_a, &d.theta_b);
                let bow = |k: usize| (a[k] * a[k] + b[k] * b[k]) * 2.0 - a[k] * b[k];
                chord + (bow(1) + bow(2)) * (1.0 / 30.0)
            }
        }
    }
}

/// The local elastic energy of the module documentation, with the axial term written
/// `EA L/2 ε²` for the strain measure `strain` (for [`LocalStrain::Chord`] this is
/// `EA/(2L) ū²`).
pub fn local_energy<S: Scalar>(
    section: &BeamSection,
    strain: LocalStrain,
    length: f64,
    d: &BeamDeformation<S>,
) -> S {
    let (ta, tb) = (&d.theta_a, &d.theta_b);
    let (ei2, ei3) = section.bending_stiffness();
    let twist = tb[0] - ta[0];
    let eps = strain.strain(length, d);
    eps * eps * (0.5 * section.axial_stiffness() * length)
        + twist * twist * (0.5 * section.shear_modulus * section.torsion_j / length)
        + (ta[1] * ta[1] + ta[1] * tb[1] + tb[1] * tb[1]) * (2.0 * ei2 / length)
        + (ta[2] * ta[2] + ta[2] * tb[2] + tb[2] * tb[2]) * (2.0 * ei3 / length)
}

/// Energy Πₑ (nN·µm), residual `∂Πₑ/∂u` (12; nN and nN·µm) and optionally the row-major
/// tangent `∂²Πₑ/∂u²` (12 × 12) of one corotational beam element with DOF values `u`
/// (`[uₐ(3), θₐ(3), u_b(3), θ_b(3)]`, θ total rotation vectors), with the default
/// [`LocalStrain::ShallowArch`]. Derivatives are exact (forward-mode automatic
/// differentiation with [`HyperDual`]). `residual` must hold at least 12 and `tangent` at
/// least 144 values.
pub fn beam_evaluate(
    section: &BeamSection,
    reference: &BeamReference,
    u: &[f64; BEAM_DOFS],
    residual: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> Result<f64, KernelError> {
    beam_evaluate_with(
        LocalStrain::default(),
        section,
        reference,
        u,
        residual,
        tangent,
    )
}

/// [`beam_evaluate`] with an explicit axial strain measure.
pub fn beam_evaluate_with(
    strain: LocalStrain,
    section: &BeamSection,
    reference: &BeamReference,
    u: &[f64; BEAM_DOFS],
    residual: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> Result<f64, KernelError> {
    let Some(t) = tangent else {
        // The residual alone: first-order derivatives (a fraction of the work).
        let d = beam_deformation::<Dual>(reference, u)?;
        let pi = local_energy(section, strain, reference.length, &d);
        expand_gradient(&pi.g, &mut residual[..BEAM_DOFS]);
        return Ok(pi.v);
    };
    let d = beam_deformation::<HyperDual>(reference, u)?;
    let pi = local_energy(section, strain, reference.length, &d);
    expand_gradient(&pi.g, &mut residual[..BEAM_DOFS]);
    let mut hessian = [0.0; HD_N * HD_N];
    pi.write_hessian(&mut hessian);
    expand_hessian(&hessian, &mut t[..BEAM_DOFS * BEAM_DOFS]);
    Ok(pi.v)
}

/// For each of the 12 DOFs `[uₐ, θₐ, u_b, θ_b]`, its reduced variable (`[u_b − uₐ, θₐ,
/// θ_b]`) and the sign of its derivative: `∂/∂uₐ = −∂/∂Δ`, `∂/∂u_b = ∂/∂Δ`.
const REDUCED: [(usize, f64); BEAM_DOFS] = [
    (0, -1.0),
    (1, -1.0),
    (2, -1.0),
    (3, 1.0),
    (4, 1.0),
    (5, 1.0),
    (0, 1.0),
    (1, 1.0),
    (2, 1.0),
    (6, 1.0),
    (7, 1.0),
    (8, 1.0),
];

/// The gradient in the 12 DOFs of a function of the reduced variables: `r = Aᵀ g` with the
/// 0/±1 map `A` of [`REDUCED`] (exact: sign flips only).
fn expand_gradient(gradient: &[f64; HD_N], residual: &mut [f64]) {
    for (r, &(m, sign)) in residual.iter_mut().zip(&REDUCED) {
        *r = sign * gradient[m];
    }
}

/// The Hessian in the 12 DOFs of a function of the reduced variables: `K = Aᵀ H A`, from
/// the full row-major `H` (`HD_N × HD_N`).
fn expand_hessian(hessian: &[f64; HD_N * HD_N], tangent: &mut [f64]) {
    for (p, &(mp, sp)) in REDUCED.iter().enumerate() {
        for (q, &(mq, sq)) in REDUCED.iter().enumerate() {
            tangent[p * BEAM_DOFS + q] = sp * sq * hessian[mp * HD_N + mq];
        }
    }
}

/// Energy only (plain `f64`, no derivatives).
pub fn beam_energy(
    strain: LocalStrain,
    section: &BeamSection,
    reference: &BeamReference,
    u: &[f64; BEAM_DOFS],
) -> Result<f64, KernelError> {
    let d = beam_deformation::<f64>(reference, u)?;
    Ok(local_energy(section, strain, reference.length, &d))
}
