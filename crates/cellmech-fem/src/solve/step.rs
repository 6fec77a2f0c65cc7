//! Analysis steps: prescribed motions and nodal loads ramped over pseudo-time 0 → 1.

use super::control::StepControl;

/// How a prescribed DOF moves during a step (linear ramp in step time).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// Keep the value it has at the start of the step.
    Hold,
    /// Reach this total displacement at the end of the step.
    To(f64),
    /// Change by this much over the step.
    By(f64),
}

/// A nodal force on one DOF, reaching `value` (nN) at the end of the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodalLoad {
    /// Global DOF.
    pub dof: usize,
    /// Total value at the end of the step (ramped linearly from its value at the start).
    pub value: f64,
}

/// One analysis step. DOFs listed in `prescribed` are prescribed during the step; all
/// others are free. Loads not listed keep their value from the previous step.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// Name used in messages and outputs.
    pub name: String,
    /// Pseudo-time length of the step (output time axis), > 0.
    pub duration: f64,
    /// Prescribed DOFs and their motion.
    pub prescribed: Vec<(usize, Motion)>,
    /// Nodal loads at the end of the step.
    pub loads: Vec<NodalLoad>,
    /// Increment control and convergence criteria.
    pub control: StepControl,
}

impl Step {
    /// A step with no prescribed DOFs or loads and default control.
    pub fn new(name: impl Into<String>) -> Self {
        Step {
            name: name.into(),
            duration: 1.0,
            prescribed: Vec::new(),
            loads: Vec::new(),
            control: StepControl::default(),
        }
    }
}
