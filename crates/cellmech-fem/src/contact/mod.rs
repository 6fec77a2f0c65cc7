//! Contact between surface nodes and rigid tools whose pilot point follows a load program.
//!
//! Node-to-rigid-surface contact, enforced by the augmented Lagrangian method (a penalty
//! with Uzawa multiplier updates until the penetration is below a stated tolerance):
//!
//! * frictionless: Π_i = (λ_i − ε φ(x_i))² / (2ε) for the nodes of the active set, φ the
//!   tool's gap function; the multiplier update is λ ← ⟨λ − ε φ⟩₊; separation is allowed;
//! * bonded: a node that touches the tool at a converged increment is tied from then on to
//!   the tool point it touched: Π_i = λ_i·d_i + ε|d_i|²/2, d_i = x_i − (ξ_i + c(t)), the
//!   update λ ← λ + ε d; it transmits tension.
//!
//! The frictionless active set is held fixed during Newton's iterations and updated between
//! them, like the multipliers (the contact-status iterations of implicit FE codes): a free
//! node enters it when it penetrates deeper than the tolerance, an active node leaves it
//! when it pulls on the tool harder than the penalty force of that tolerance (ε·tol).
//! Inside one Newton solve the contact law is then smooth and Newton converges
//! quadratically; with the law re-evaluated at every iteration instead, a node on the
//! steep flank of a sharp AFM tip was pushed out in one iteration and fell back in at the
//! next, and Newton cycled. Before each increment, the free nodes the moved tool reaches
//! from where they were join the set (a status predictor). The band of ±tolerance between
//! entering and leaving is the same accuracy the penetration tolerance already grants, and
//! stops status cycles.
//!
//! The tangent of an active frictionless node is ε∇φ⊗∇φ − p̄∇²φ with p̄ = min(p, p_eq),
//! p_eq the node's pressure at the last converged Newton state (0 for a node that was free
//! there). The curvature term −p∇²φ is a negative stiffness across the normal of a curved
//! tool (a node pressed onto a convex tip would slide off if the material did not hold it);
//! with a trial pressure far above equilibrium it outweighed the material under the AFM tip
//! and Newton's corrections inverted elements. Capped at p_eq it is exact at equilibrium
//! and never more negative than at a state known to be stable (`docs/tools.md` has the
//! measurements).
//!
//! Each node couples only with itself, so contact opening or closing never changes the
//! sparsity pattern or the symbolic factorisation.
//!
//! [`RigidContact`] is an [`ElementSet`] with one element per contact node; its load
//! program, multipliers and bonds are moved by the set's hooks (`on_load_state`,
//! `on_converged`, `on_commit`, `on_rollback`), which the `Term` adapter forwards.

mod tool;

pub use tool::{Gap, ToolShape};

use crate::dof::DofMap;
use crate::element::{ElementSet, KernelError};
use crate::math::vec3::{dot, norm};
use crate::term::{Augmentation, LoadState};

/// How the tool holds the nodes it touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum ContactKind {
    /// Unilateral, no friction, separation allowed.
    Frictionless,
    /// A node that has touched sticks to the tool from then on.
    Bonded,
}

/// Which pressure the tangent's curvature term −p∇²φ of an active node uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum CurvatureTangent {
    /// min(p, p_eq), p_eq the node's pressure at the last converged Newton state: exact at
    /// equilibrium, never more negative than there (module notes). The default.
    #[default]
    Lagged,
    /// The current trial pressure p: the exact derivative of the residual everywhere.
    Consistent,
}

/// The state that changes as a transaction (trial → commit, or rollback).
#[derive(Debug, Clone, PartialEq)]
struct ContactState {
    offset: [f64; 3],
    lambda: Vec<f64>,
    /// Frictionless active set (held during Newton, updated in `on_converged`).
    active: Vec<bool>,
    /// Contact pressure of each node at the last converged Newton state (0 for a node that
    /// was not active there): caps the pressure in the tangent's curvature term.
    equilibrium_pressure: Vec<f64>,
    anchors: Vec<Option<[f64; 3]>>,
    bond_lambda: Vec<[f64; 3]>,
}

/// A rigid tool in contact with a node set.
#[derive(Debug, Clone)]
pub struct RigidContact {
    name: String,
    shape: ToolShape,
    kind: ContactKind,
    nodes: Vec<usize>,
    reference: Vec<[f64; 3]>,
    penalty: f64,
    tolerance: f64,
    program: Vec<[f64; 3]>,
    trial: ContactState,
    committed: ContactState,
    /// Positions of the contact nodes at the last committed increment (the reference ones
    /// before the first): where the status predictor looks for nodes the tool will reach.
    committed_positions: Vec<[f64; 3]>,
    curvature_tangent: CurvatureTangent,
    last_step: usize,
    /// The step whose start offset is recorded in `step_start`.
    started_step: Option<usize>,
    /// Pilot-point displacement where the current step started: a step may have ended early
    /// (stop condition), so the next one moves on from there by its own program increment.
    step_start: [f64; 3],
}

/// Why a contact could not be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContactError {
    /// The contact node set is empty.
    #[error("tool '{0}': the contact node set is empty")]
    NoNodes(String),
    /// Bad tool geometry.
    #[error("tool '{tool}': {message}")]
    Shape {
        /// Tool name.
        tool: String,
        /// What is wrong.
        message: String,
    },
    /// Bad penalty or tolerance.
    #[error(
        "tool '{tool}': the penalty ({penalty} nN/um) and tolerance ({tolerance} um) must be > 0"
    )]
    Parameters {
        /// Tool name.
        tool: String,
        /// Penalty ε.
        penalty: f64,
        /// Penetration tolerance.
        tolerance: f64,
    },
}

impl RigidContact {
    /// A tool `shape` acting on `nodes` (with reference coordinates `reference`), with
    /// penalty ε (nN/µm), penetration tolerance (µm), and the pilot-point displacement at the
    /// end of each analysis step (`program[k]`; steps past the end hold the last value).
    /// Step k moves the tool by `program[k] - program[k-1]` from where step k-1 actually
    /// ended (earlier than its program when a stop condition ended it).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: impl Into<String>,
        shape: ToolShape,
        kind: ContactKind,
        nodes: Vec<usize>,
        reference: Vec<[f64; 3]>,
        penalty: f64,
        tolerance: f64,
        program: Vec<[f64; 3]>,
    ) -> Result<Self, ContactError> {
        let name = name.into();
        if nodes.is_empty() {
            return Err(ContactError::NoNodes(name));
        }
        shape.validate().map_err(|message| ContactError::Shape {
            tool: name.clone(),
            message,
        })?;
        if !(penalty > 0.0 && tolerance > 0.0) {
            return Err(ContactError::Parameters {
                tool: name,
                penalty,
                tolerance,
            });
        }
        let n = nodes.len();
        let state = ContactState {
            offset: [0.0; 3],
            lambda: vec![0.0; n],
            active: vec![false; n],
            equilibrium_pressure: vec![0.0; n],
            anchors: vec![None; n],
            bond_lambda: vec![[0.0; 3]; n],
        };
        Ok(RigidContact {
            name,
            shape,
            kind,
            nodes,
            committed_positions: reference.clone(),
            curvature_tangent: CurvatureTangent::default(),
            reference,
            penalty,
            tolerance,
            program,
            trial: state.clone(),
            committed: state,
            last_step: 0,
            started_step: None,
            step_start: [0.0; 3],
        })
    }

    /// The same contact with the curvature term of its tangent taken as `curvature`.
    pub fn with_curvature_tangent(mut self, curvature: CurvatureTangent) -> Self {
        self.curvature_tangent = curvature;
        self
    }

    /// Current pilot-point displacement (µm).
    pub fn offset(&self) -> [f64; 3] {
        self.trial.offset
    }

    /// The tool shape.
    pub fn shape(&self) -> &ToolShape {
        &self.shape
    }

    /// The penetration tolerance (µm).
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// Number of nodes bonded to the tool (committed).
    pub fn bonded_count(&self) -> usize {
        self.committed
            .anchors
            .iter()
            .filter(|a| a.is_some())
            .count()
    }

    fn position(&self, e: usize, u: &[f64], dof_map: &DofMap) -> [f64; 3] {
        std::array::from_fn(|i| self.reference[e][i] + u[dof_map.dof(self.nodes[e], i)])
    }

    fn program_at(&self, step: usize) -> [f64; 3] {
        match self.program.get(step).or(self.program.last()) {
            Some(p) => *p,
            None => [0.0; 3],
        }
    }

    /// Direction of the current step's motion (unit), or the tool axis when it does not move.
    fn motion_direction(&self, step: usize) -> Option<[f64; 3]> {
        let start = if step == 0 {
            [0.0; 3]
        } else {
            self.program_at(step - 1)
        };
        let end = self.program_at(step);
        let d: [f64; 3] = std::array::from_fn(|i| end[i] - start[i]);
        let l = norm(&d);
        if l > 0.0 {
            Some(d.map(|x| x / l))
        } else {
            self.shape.axis()
        }
    }

    /// Largest penetration (µm, ≥ 0) of a free node, or bond gap of a bonded node.
    pub fn max_violation(&self, u: &[f64], dof_map: &DofMap) -> f64 {
        (0..self.nodes.len())
            .map(|e| {
                let x = self.position(e, u, dof_map);
                match self.trial.anchors[e] {
                    Some(a) => norm(&std::array::from_fn(|i| x[i] - a[i] - self.trial.offset[i])),
                    None => self
                        .shape
                        .gap(&x, &self.trial.offset)
                        .map_or(0.0, |g| (-g.value).max(0.0)),
                }
            })
            .fold(0.0, f64::max)
    }

    /// Contact-status check at a converged Newton state: records each active node's
    /// pressure there (the curvature term's cap; 0 for the others), then free nodes that
    /// penetrate deeper than the tolerance enter the active set and active nodes that pull
    /// on the tool harder than ε·tolerance (or left a disk's face) leave it with their
    /// multiplier reset. Returns how many changed.
    fn update_active_set(&mut self, u: &[f64], dof_map: &DofMap) -> usize {
        let (eps, tol) = (self.penalty, self.tolerance);
        let mut changed = 0;
        for e in 0..self.nodes.len() {
            if self.trial.anchors[e].is_some() {
                continue;
            }
            let x = self.position(e, u, dof_map);
            let gap = self.shape.gap(&x, &self.trial.offset);
            self.trial.equilibrium_pressure[e] = match gap {
                Some(g) if self.trial.active[e] => (self.trial.lambda[e] - eps * g.value).max(0.0),
                _ => 0.0,
            };
            let active = &mut self.trial.active[e];
            let next = match gap {
                None => false,
                Some(g) if *active => self.trial.lambda[e] - eps * g.value >= -eps * tol,
                Some(g) => g.value < -tol,
            };
            if next != *active {
                *active = next;
                if !next {
                    self.trial.lambda[e] = 0.0;
                }
                changed += 1;
            }
        }
        changed
    }

    /// Status predictor for the increment about to be attempted: free nodes that the tool,
    /// at its new position, reaches deeper than the tolerance where they were at the last
    /// committed increment enter the active set now, so that Newton's first correction moves
    /// the whole contact patch with the tool instead of pushing the old patch alone (an
    /// apex node driven one element size into the mesh inverts its elements).
    fn predict_active_set(&mut self) {
        for e in 0..self.nodes.len() {
            if self.trial.active[e] || self.trial.anchors[e].is_some() {
                continue;
            }
            if let Some(g) = self
                .shape
                .gap(&self.committed_positions[e], &self.trial.offset)
            {
                if g.value < -self.tolerance {
                    self.trial.active[e] = true;
                }
            }
        }
    }

    /// Total force the tool exerts on the body (nN).
    pub fn force_on_body(&self, u: &[f64], dof_map: &DofMap) -> [f64; 3] {
        let mut total = [0.0; 3];
        let mut r = [0.0; 3];
        for e in 0..self.nodes.len() {
            let u_e: [f64; 3] = std::array::from_fn(|i| u[dof_map.dof(self.nodes[e], i)]);
            if self.node_evaluate(e, &u_e, &mut r, None).is_ok() {
                for i in 0..3 {
                    total[i] -= r[i];
                }
            }
        }
        total
    }

    fn node_evaluate(
        &self,
        e: usize,
        u: &[f64],
        r: &mut [f64],
        k: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let x: [f64; 3] = std::array::from_fn(|i| self.reference[e][i] + u[i]);
        let eps = self.penalty;
        r[..3].fill(0.0);
        let mut k = k;
        if let Some(k) = k.as_deref_mut() {
            k[..9].fill(0.0);
        }
        if let Some(anchor) = self.trial.anchors[e] {
            let l = self.trial.bond_lambda[e];
            let d: [f64; 3] = std::array::from_fn(|i| x[i] - anchor[i] - self.trial.offset[i]);
            for i in 0..3 {
                r[i] = l[i] + eps * d[i];
            }
            if let Some(k) = k {
                for i in 0..3 {
                    k[4 * i] = eps;
                }
            }
            return Ok((0..3).map(|i| l[i] * d[i] + 0.5 * eps * d[i] * d[i]).sum());
        }
        if !self.trial.active[e] {
            return Ok(0.0);
        }
        let Some(gap) = self.shape.gap(&x, &self.trial.offset) else {
            return Ok(0.0);
        };
        // Active: the bilateral penalty law (a small pull is allowed until the status check).
        let p = self.trial.lambda[e] - eps * gap.value;
        // The curvature term with the pressure capped at the last equilibrium's (module
        // notes): a lagged, never more negative stiffness.
        let p_curvature = match self.curvature_tangent {
            CurvatureTangent::Lagged => p.min(self.trial.equilibrium_pressure[e]),
            CurvatureTangent::Consistent => p,
        };
        for i in 0..3 {
            r[i] = -p * gap.gradient[i];
        }
        if let Some(k) = k {
            for i in 0..3 {
                for j in 0..3 {
                    k[3 * i + j] =
                        eps * gap.gradient[i] * gap.gradient[j] - p_curvature * gap.hessian[i][j];
                }
            }
        }
        Ok(p * p / (2.0 * eps))
    }
}

/// One element per contact node (its 3 translations); the tool's program, multipliers and
/// bonds are the set's state, moved by the hooks.
impl ElementSet for RigidContact {
    const ELEMENT_DOFS: usize = 3;

    fn set_name(&self) -> &str {
        &self.name
    }

    fn element_count(&self) -> usize {
        self.nodes.len()
    }

    fn element_nodes(&self, e: usize) -> &[usize] {
        std::slice::from_ref(&self.nodes[e])
    }

    fn evaluate_element(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        self.node_evaluate(e, u_e, residual, tangent)
    }

    fn curve_outputs(&self, u: &[f64], dof_map: &DofMap) -> Vec<(String, f64)> {
        let f = self.force_on_body(u, dof_map);
        let o = self.trial.offset;
        let mut out = vec![
            (scalar_name(&self.name, ToolScalar::Displacement(0)), o[0]),
            (scalar_name(&self.name, ToolScalar::Displacement(1)), o[1]),
            (scalar_name(&self.name, ToolScalar::Displacement(2)), o[2]),
            (scalar_name(&self.name, ToolScalar::Force(0)), f[0]),
            (scalar_name(&self.name, ToolScalar::Force(1)), f[1]),
            (scalar_name(&self.name, ToolScalar::Force(2)), f[2]),
        ];
        if let Some(m) = self.motion_direction(self.last_step) {
            out.push((
                scalar_name(&self.name, ToolScalar::ForceAlongMotion),
                dot(&f, &m),
            ));
        }
        out.push((
            scalar_name(&self.name, ToolScalar::MaxPenetration),
            self.max_violation(u, dof_map),
        ));
        out
    }

    fn on_load_state(&mut self, state: &LoadState) {
        let start = if state.step_index == 0 {
            [0.0; 3]
        } else {
            self.program_at(state.step_index - 1)
        };
        let end = self.program_at(state.step_index);
        if self.started_step != Some(state.step_index) {
            self.started_step = Some(state.step_index);
            self.step_start = self.committed.offset;
        }
        let from = self.step_start;
        self.trial.offset =
            std::array::from_fn(|i| from[i] + state.step_time * (end[i] - start[i]));
        self.last_step = state.step_index;
        self.predict_active_set();
    }

    fn on_converged(&mut self, u: &[f64], dof_map: &DofMap) -> Augmentation {
        let changed = self.update_active_set(u, dof_map);
        if changed > 0 {
            return Augmentation::Updated(format!("{changed} contact nodes changed status"));
        }
        let violation = self.max_violation(u, dof_map);
        if violation <= self.tolerance {
            return Augmentation::Settled;
        }
        let eps = self.penalty;
        for e in 0..self.nodes.len() {
            let x = self.position(e, u, dof_map);
            match self.trial.anchors[e] {
                Some(a) => {
                    for i in 0..3 {
                        self.trial.bond_lambda[e][i] += eps * (x[i] - a[i] - self.trial.offset[i]);
                    }
                }
                None if self.trial.active[e] => {
                    if let Some(g) = self.shape.gap(&x, &self.trial.offset) {
                        self.trial.lambda[e] = (self.trial.lambda[e] - eps * g.value).max(0.0);
                    }
                }
                None => {}
            }
        }
        Augmentation::Updated(format!(
            "largest violation {violation:.3e} um > tolerance {:.3e} um",
            self.tolerance
        ))
    }

    fn on_commit(&mut self, u: &[f64], dof_map: &DofMap) {
        for e in 0..self.nodes.len() {
            self.committed_positions[e] = self.position(e, u, dof_map);
        }
        if self.kind == ContactKind::Bonded {
            for e in 0..self.nodes.len() {
                if self.trial.anchors[e].is_some() {
                    continue;
                }
                let x = self.position(e, u, dof_map);
                let Some(g) = self.shape.gap(&x, &self.trial.offset) else {
                    continue;
                };
                let p = if self.trial.active[e] {
                    (self.trial.lambda[e] - self.penalty * g.value).max(0.0)
                } else {
                    0.0
                };
                if p > 0.0 || g.value <= self.tolerance {
                    // Tie the node where it is now; start the bond with the contact force so
                    // the converged equilibrium is unchanged.
                    self.trial.anchors[e] =
                        Some(std::array::from_fn(|i| x[i] - self.trial.offset[i]));
                    self.trial.bond_lambda[e] = std::array::from_fn(|i| -p * g.gradient[i]);
                }
            }
        }
        self.committed = self.trial.clone();
    }

    fn on_rollback(&mut self) {
        self.trial = self.committed.clone();
    }
}

/// A scalar result of a rigid tool, per converged increment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ToolScalar {
    /// Pilot-point displacement along axis 0, 1, 2 (µm).
    Displacement(usize),
    /// Force the tool exerts on the body along axis 0, 1, 2 (nN).
    Force(usize),
    /// Force along the tool's current direction of motion (nN).
    ForceAlongMotion,
    /// Largest penetration or bond gap of its contact nodes (µm).
    MaxPenetration,
}

/// The name (with its unit) of a tool's scalar result: the one definition of the
/// `curve.csv` column and of the [`crate::solve::Monitor::TermScalar`] key.
pub fn scalar_name(tool: &str, scalar: ToolScalar) -> String {
    const AXES: [&str; 3] = ["x", "y", "z"];
    match scalar {
        ToolScalar::Displacement(a) => format!("{tool}_displacement_{}_um", AXES[a.min(2)]),
        ToolScalar::Force(a) => format!("{tool}_force_{}_nN", AXES[a.min(2)]),
        ToolScalar::ForceAlongMotion => format!("{tool}_force_along_motion_nN"),
        ToolScalar::MaxPenetration => format!("{tool}_max_penetration_um"),
    }
}

#[cfg(test)]
mod tests;
