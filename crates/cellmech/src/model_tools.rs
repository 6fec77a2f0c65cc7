//! Rigid tools of a scenario turned into engine contact terms, load programs and step stop
//! conditions.

use cellmech_fem::contact::{ContactError, RigidContact};
use cellmech_fem::mesh::Mesh;
use cellmech_fem::solve::{Monitor, Step, StopCondition};
use cellmech_fem::term::Term;

use crate::scenario::tools::{tool_program, ToolMotion};
use crate::scenario::{Scenario, StepSpec};

/// One contact term per `[[tool]]`, with its pilot-point program (the cumulative moves of
/// the steps; tools not moved in a step hold).
pub fn contact_terms(scenario: &Scenario) -> Result<Vec<Box<dyn Term>>, ContactError> {
    let motions: Vec<Vec<ToolMotion>> = scenario.steps.iter().map(|s| s.tools.clone()).collect();
    scenario
        .tools
        .iter()
        .map(|tool| {
            let nodes = contact_nodes(&scenario.mesh, &tool.node_set);
            let reference = nodes.iter().map(|&n| scenario.mesh.nodes[n]).collect();
            let term = RigidContact::new(
                tool.name.clone(),
                tool.shape,
                tool.kind,
                nodes,
                reference,
                tool.penalty,
                tool.tolerance,
                tool_program(&tool.name, &motions),
            )?;
            Ok(Box::new(term) as Box<dyn Term>)
        })
        .collect()
}

fn contact_nodes(mesh: &Mesh, set: &str) -> Vec<usize> {
    mesh.node_sets.get(set).cloned().unwrap_or_default()
}

/// The stop condition of a step whose tool has `until_force`: the step ends where the
/// tool's force along its motion reaches the target.
///
/// When the motion is along a coordinate axis the monitor is the force component on that
/// axis (`<tool>_force_z_nN`, target multiplied by the motion's sign): unlike
/// `<tool>_force_along_motion_nN` it does not change meaning between the end of the
/// previous step and the first increment of this one, where the direction of motion may
/// reverse (retraction after a push).
pub fn stop_condition(spec: &StepSpec) -> Option<StopCondition> {
    spec.tools.iter().find_map(|m| {
        let target = m.until_force?;
        let nonzero: Vec<usize> = (0..3).filter(|&c| m.movement[c] != 0.0).collect();
        let (monitor, value) = match nonzero.as_slice() {
            [c] => (
                format!("{}_force_{}_nN", m.tool, ["x", "y", "z"][*c]),
                target.value * m.movement[*c].signum(),
            ),
            _ => (format!("{}_force_along_motion_nN", m.tool), target.value),
        };
        Some(StopCondition {
            monitor: Monitor::TermScalar(monitor),
            target: value,
            tolerance: target.tolerance,
        })
    })
}

/// Adds the tool part of a step (its stop condition) to an engine step.
pub fn apply_to_step(step: &mut Step, spec: &StepSpec) {
    step.stop = stop_condition(spec);
}

/// The direction a tool pushes the body along: its normal/axis, or for a sphere the
/// direction of its first move (`None` for a sphere that never moves).
pub fn push_direction(scenario: &Scenario, tool: &str) -> Option<[f64; 3]> {
    let spec = scenario.tools.iter().find(|t| t.name == tool)?;
    spec.shape.axis().or_else(|| {
        scenario.steps.iter().find_map(|s| {
            let m = s.tools.iter().find(|m| m.tool == tool)?.movement;
            let l = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
            (l > 0.0).then(|| m.map(|x| x / l))
        })
    })
}
