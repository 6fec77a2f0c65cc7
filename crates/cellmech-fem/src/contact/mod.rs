//! Contact between surface nodes and rigid tools whose pilot point follows a load program.
//!
//! Node-to-rigid-surface contact, enforced by the augmented Lagrangian method (a penalty
//! with Uzawa multiplier updates until the penetration is below a stated tolerance):
//!
//! * frictionless: Π_i = ⟨λ_i − ε φ(x_i)⟩₊² / (2ε), φ the tool's gap function; the
//!   multiplier update is λ ← ⟨λ − ε φ⟩₊; separation is allowed;
//! * bonded: a node that touches the tool at a converged increment is tied from then on to
//!   the tool point it touched: Π_i = λ_i·d_i + ε|d_i|²/2, d_i = x_i − (ξ_i + c(t)), the
//!   update λ ← λ + ε d; it transmits tension.
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

/// The state that changes as a transaction (trial → commit, or rollback).
#[derive(Debug, Clone, PartialEq)]
struct ContactState {
    offset: [f64; 3],
    lambda: Vec<f64>,
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
            anchors: vec![None; n],
            bond_lambda: vec![[0.0; 3]; n],
        };
        Ok(RigidContact {
            name,
            shape,
            kind,
            nodes,
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
        let Some(gap) = self.shape.gap(&x, &self.trial.offset) else {
            return Ok(0.0);
        };
        let p = self.trial.lambda[e] - eps * gap.value;
        if p <= 0.0 {
            return Ok(0.0);
        }
        for i in 0..3 {
            r[i] = -p * gap.gradient[i];
        }
        if let Some(k) = k {
            for i in 0..3 {
                for j in 0..3 {
                    k[3 * i + j] = eps * gap.gradient[i] * gap.gradient[j] - p * gap.hessian[i][j];
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
    }

    fn on_converged(&mut self, u: &[f64], dof_map: &DofMap) -> Augmentation {
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
                None => {
                    if let Some(g) = self.shape.gap(&x, &self.trial.offset) {
                        self.trial.lambda[e] = (self.trial.lambda[e] - eps * g.value).max(0.0);
                    }
                }
            }
        }
        Augmentation::Updated(format!(
            "largest violation {violation:.3e} um > tolerance {:.3e} um",
            self.tolerance
        ))
    }

    fn on_commit(&mut self, u: &[f64], dof_map: &DofMap) {
        if self.kind == ContactKind::Bonded {
            for e in 0..self.nodes.len() {
                if self.trial.anchors[e].is_some() {
                    continue;
                }
                let x = self.position(e, u, dof_map);
                let Some(g) = self.shape.gap(&x, &self.trial.offset) else {
                    continue;
                };
                let p = (self.trial.lambda[e] - self.penalty * g.value).max(0.0);
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
