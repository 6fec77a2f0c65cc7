//! Contact on spring-supported nodes, where the exact answers are known.

use super::*;
use crate::element::spring::SpringSet;
use crate::linsolve::DenseSolver;
use crate::solve::{Motion, Problem, Step};
use crate::term::Term;

/// Node 1 hangs on a spring (k = 2 nN/um) from the fixed node 0 above it, 1 um apart.
fn spring_and_tool(kind: ContactKind, program: Vec<[f64; 3]>) -> Problem {
    let nodes = [[0.0, 0.0, 2.0], [0.0, 0.0, 1.0]];
    let springs = SpringSet {
        name: "spring".into(),
        nodes: vec![[0, 1]],
        reference: vec![[nodes[0], nodes[1]]],
        stiffness: vec![2.0],
        rest_length: vec![1.0],
    };
    // A plate below node 1, touching it, normal +z (towards the body).
    let plate = ToolShape::Plate {
        point: [0.0, 0.0, 1.0],
        normal: [0.0, 0.0, 1.0],
    };
    let contact = RigidContact::new(
        "plate",
        plate,
        kind,
        vec![1],
        vec![nodes[1]],
        50.0,
        1e-9,
        program,
    )
    .unwrap();
    let terms: Vec<Box<dyn Term>> = vec![Box::new(springs), Box::new(contact)];
    Problem::new(
        DofMap::translational(2),
        terms,
        Box::new(DenseSolver::default()),
    )
    .unwrap()
}

fn fixed_top_and_lateral() -> Vec<(usize, Motion)> {
    vec![
        (0, Motion::Hold),
        (1, Motion::Hold),
        (2, Motion::Hold),
        (3, Motion::Hold),
        (4, Motion::Hold),
    ]
}

fn contact_term(p: &Problem) -> Vec<(String, f64)> {
    p.terms()[1].scalar_outputs(p.u(), p.dof_map())
}

fn value(outputs: &[(String, f64)], name: &str) -> f64 {
    outputs
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, v)| *v)
        .unwrap()
}

#[test]
fn frictionless_plate_pushes_spring_node_with_penetration_below_tolerance() {
    // The plate rises by 0.3 um: the spring is compressed by 0.3 (force 0.6 nN).
    let mut p = spring_and_tool(ContactKind::Frictionless, vec![[0.0, 0.0, 0.3]]);
    let mut step = Step::new("push");
    step.prescribed = fixed_top_and_lateral();
    p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
    let out = contact_term(&p);
    assert!(
        (p.u()[5] - 0.3).abs() < 1e-8,
        "node displacement {}",
        p.u()[5]
    );
    assert!((value(&out, "plate_force_z_nN") - 0.6).abs() < 1e-7);
    assert!((value(&out, "plate_force_along_motion_nN") - 0.6).abs() < 1e-7);
    assert!(value(&out, "plate_max_penetration_um") <= 1e-9);
    // The reaction at the spring's fixed end balances the plate force.
    assert!((p.reaction(2) + 0.6).abs() < 1e-7);
}

#[test]
fn frictionless_plate_lets_the_node_go_when_it_retracts() {
    let mut p = spring_and_tool(
        ContactKind::Frictionless,
        vec![[0.0, 0.0, 0.3], [0.0, 0.0, -0.5]],
    );
    let mut step = Step::new("push");
    step.prescribed = fixed_top_and_lateral();
    p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
    step.name = "retract".into();
    p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
    assert!(
        p.u()[5].abs() < 1e-9,
        "the spring returns to its rest length"
    );
    assert_eq!(value(&contact_term(&p), "plate_force_z_nN"), 0.0);
}

#[test]
fn bonded_plate_transmits_tension_after_touching() {
    // Touch (push 0.1 um up), then pull down by 0.4 um: the node follows the plate.
    let mut p = spring_and_tool(ContactKind::Bonded, vec![[0.0, 0.0, 0.1], [0.0, 0.0, -0.3]]);
    let mut step = Step::new("touch");
    step.prescribed = fixed_top_and_lateral();
    p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
    step.name = "pull".into();
    p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
    let out = contact_term(&p);
    assert!(
        (p.u()[5] + 0.3).abs() < 1e-8,
        "node follows the plate: {}",
        p.u()[5]
    );
    assert!(
        (value(&out, "plate_force_z_nN") + 0.6).abs() < 1e-7,
        "tension 0.6 nN"
    );
    assert!(value(&out, "plate_force_along_motion_nN") > 0.59);
}

#[test]
fn contact_adds_no_entries_to_the_sparsity_pattern() {
    let with_contact = spring_and_tool(ContactKind::Frictionless, vec![[0.0; 3]]);
    let nodes = [[0.0, 0.0, 2.0], [0.0, 0.0, 1.0]];
    let springs = SpringSet {
        name: "spring".into(),
        nodes: vec![[0, 1]],
        reference: vec![[nodes[0], nodes[1]]],
        stiffness: vec![2.0],
        rest_length: vec![1.0],
    };
    let alone = crate::assembly::Assembler::new(
        &DofMap::translational(2),
        &[Box::new(springs) as Box<dyn Term>],
    );
    assert_eq!(with_contact.assembler().pattern(), alone.pattern());
}
