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
    /// End the step early where a monitored quantity reaches a target (e.g. "retract the
    /// pipette until its force is zero"); the motions are then applied only up to there.
    pub stop: Option<StopCondition>,
    /// Where each increment's Newton iterations start: the DOF values of a known nearby
    /// path (e.g. the same step solved on a simpler model) instead of the last converged
    /// state. Prescribed DOFs keep their motion. `None`: the last converged state.
    pub guess: Option<GuessPath>,
}

/// DOF values along a step, piecewise linear in the step time between knots (the first
/// knot's values before it, the last's after it).
#[derive(Debug, Clone, PartialEq)]
pub struct GuessPath {
    /// Knot times, increasing.
    pub times: Vec<f64>,
    /// DOF values at each knot (one value per DOF of the problem).
    pub values: Vec<Vec<f64>>,
}

impl GuessPath {
    /// Writes the interpolated values at step time `t` into `u` (DOFs where `skip` is true
    /// are left alone).
    pub fn write_at(&self, t: f64, skip: &[bool], u: &mut [f64]) {
        if self.values.is_empty() {
            return;
        }
        let (i0, i1, w) = crate::math::knot_bracket(&self.times, t);
        let (a, b) = (&self.values[i0], &self.values[i1]);
        for (d, value) in u.iter_mut().enumerate() {
            if !skip[d] {
                *value = a[d] + w * (b[d] - a[d]);
            }
        }
    }
}

/// A scalar quantity of a converged state.
#[derive(Debug, Clone, PartialEq)]
pub enum Monitor {
    /// A named scalar output of a term (see [`crate::term::Term::scalar_outputs`]), e.g.
    /// `pipette_force_along_motion_nN`.
    TermScalar(String),
    /// The sum of the reactions on these DOFs (nN).
    ReactionSum(Vec<usize>),
}

/// Ends a step where `monitor` reaches `target` within `tolerance`. The stepper locates the
/// crossing by regula falsi on the increment size: an increment that overshoots is rolled
/// back and retried shorter, so only states on the near side are committed.
#[derive(Debug, Clone, PartialEq)]
pub struct StopCondition {
    /// The monitored quantity.
    pub monitor: Monitor,
    /// Its target value.
    pub target: f64,
    /// Accepted distance from the target (same unit as the quantity, > 0).
    pub tolerance: f64,
    /// The monitor's value at a trial time is known before the increment is solved (it
    /// depends on the load program and the committed state only, e.g. a tool's smallest
    /// gap measured from the committed positions): a trial that overshoots the target is
    /// then rejected before Newton runs on it.
    pub known_before_solving: bool,
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
            stop: None,
            guess: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_guess_path_interpolates_between_its_knots_and_holds_its_ends() {
        let path = GuessPath {
            times: vec![0.5, 1.0],
            values: vec![vec![1.0, 10.0], vec![3.0, 20.0]],
        };
        let mut u = [0.0, -7.0];
        let skip = [false, true];
        // Before the first knot: its values; between knots: linear; after: the last.
        path.write_at(0.2, &skip, &mut u);
        assert_eq!(u, [1.0, -7.0], "a skipped DOF is left alone");
        path.write_at(0.75, &[false, false], &mut u);
        assert_eq!(u, [2.0, 15.0]);
        path.write_at(1.0, &[false, false], &mut u);
        assert_eq!(u, [3.0, 20.0]);
    }
}
