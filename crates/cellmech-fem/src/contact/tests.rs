//! Contact on spring-supported nodes, where the exact answers are known.

use super::*;
use crate::element::spring::SpringSet;
use crate::linsolve::DenseSolver;
use crate::solve::{Motion, Problem, Step};
use crate::term::Term;

/// Node 1 hangs on a spring (k = 2 nN/um) from the fixed node 0 above it, 1 um apart.
fn spring_and_tool(kind: ContactKind, program: Vec<[f64; 3]>) -> Problem {
    // A plate below node 1, touching it.
    spring_over_plate(kind, 1.0, (50.0, 1e-9), program)
}

/// The spring (k = 2 nN/um, rest length 1 um) between nodes 0 and 1 at `nodes`.
fn spring(nodes: [[f64; 3]; 2]) -> SpringSet {
    SpringSet {
        name: "spring".into(),
        nodes: vec![[0, 1]],
        reference: vec![[nodes[0], nodes[1]]],
        stiffness: vec![2.0],
        rest_length: vec![1.0],
    }
}

/// Node 1 hangs on a spring (k = 2 nN/um) from node 0 at (0, 0, 2), 1 um above it; a plate
/// at height `plate_z`, normal +z (towards the body), with `(penalty, tolerance)`.
fn spring_over_plate(
    kind: ContactKind,
    plate_z: f64,
    (penalty, tolerance): (f64, f64),
    program: Vec<[f64; 3]>,
) -> Problem {
    let nodes = [[0.0, 0.0, 2.0], [0.0, 0.0, 1.0]];
    let springs = spring(nodes);
    let plate = ToolShape::Plate {
        point: [0.0, 0.0, plate_z],
        normal: [0.0, 0.0, 1.0],
    };
    let contact = RigidContact::new(
        "plate",
        plate,
        kind,
        vec![1],
        vec![nodes[1]],
        penalty,
        tolerance,
        program,
    )
    .unwrap();
    springs_and_tool(2, springs, contact, Box::new(DenseSolver::default()))
}

/// A problem of `nodes` translational nodes with the spring set and the tool's contact
/// (terms 0 and 1).
fn springs_and_tool(
    nodes: usize,
    springs: SpringSet,
    contact: RigidContact,
    solver: Box<dyn crate::linsolve::LinearSolver>,
) -> Problem {
    let terms: Vec<Box<dyn Term>> = vec![Box::new(springs), Box::new(contact)];
    Problem::new(DofMap::translational(nodes), terms, solver).unwrap()
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

/// The plate's 0.3 um push: the node moved 0.3 um (1e-8), the plate carries the spring's
/// 0.6 nN (1e-7) and nothing penetrates beyond 1e-9 um. Returns the contact outputs.
fn assert_pushed_0_3_um(p: &Problem) -> Vec<(String, f64)> {
    let out = contact_term(p);
    assert!(
        (p.u()[5] - 0.3).abs() < 1e-8,
        "node displacement {}",
        p.u()[5]
    );
    assert!((value(&out, "plate_force_z_nN") - 0.6).abs() < 1e-7);
    assert!(value(&out, "plate_max_penetration_um") <= 1e-9);
    out
}

#[test]
fn frictionless_plate_pushes_spring_node_with_penetration_below_tolerance() {
    // The plate rises by 0.3 um: the spring is compressed by 0.3 (force 0.6 nN).
    let mut p = spring_and_tool(ContactKind::Frictionless, vec![[0.0, 0.0, 0.3]]);
    let mut step = Step::new("push");
    step.prescribed = fixed_top_and_lateral();
    p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
    let out = assert_pushed_0_3_um(&p);
    assert!((value(&out, "plate_force_along_motion_nN") - 0.6).abs() < 1e-7);
    // The reaction at the spring's fixed end balances the plate force.
    assert!((p.reaction(2) + 0.6).abs() < 1e-7);
}

#[test]
fn augmentations_that_keep_the_active_set_reuse_the_factorisation() {
    // The same push with and without chord steps: each multiplier update on the unchanged
    // active set costs a solve with the factorisation Newton has instead of a new one
    // (the tangent does not depend on the multipliers of a flat frictionless plate).
    let run = |chord: bool| {
        let mut p = spring_and_tool(ContactKind::Frictionless, vec![[0.0, 0.0, 0.3]]);
        let mut step = Step::new("push");
        step.prescribed = fixed_top_and_lateral();
        step.control.convergence.chord_near_convergence = chord;
        p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
        let t = p.timings();
        let force = value(&contact_term(&p), "plate_force_z_nN");
        (p.u()[5], force, t.factorizations, t.chord_steps)
    };
    let (u_fresh, f_fresh, fresh, none) = run(false);
    let (u, f, factorizations, chords) = run(true);
    assert_eq!(none, 0);
    assert!(chords > 0, "no chord step after an augmentation");
    assert!(
        factorizations < fresh,
        "{factorizations} factorisations with chord steps, {fresh} without"
    );
    for (x, force) in [(u_fresh, f_fresh), (u, f)] {
        assert!((x - 0.3).abs() < 1e-8, "node displacement {x}");
        assert!((force - 0.6).abs() < 1e-7, "force {force}");
    }
}

/// Counts Newton iterations.
struct IterationCounter(usize);

impl crate::solve::Observer for IterationCounter {
    fn on_iteration(&mut self, _report: &crate::solve::IterationReport) {
        self.0 += 1;
    }
}

/// Node 2 between two inclined springs (k = 2 nN/um, unstressed, rest length sqrt 2 um)
/// from the held nodes 0 at (-1, 0, 1) and 1 at (1, 0, 1), pushed 0.3 um up by a
/// frictionless plate with a penalty of 50 and a tolerance of 1e-9 um: a geometrically
/// nonlinear contact problem, so Newton takes several iterations per round and the
/// multipliers several Uzawa rounds. Returns the node's rise, the plate's force and the
/// Newton iterations.
fn inclined_springs_pushed(early_augmentation: f64) -> (f64, f64, usize) {
    let nodes = [[-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 0.0, 0.0]];
    let springs = SpringSet {
        name: "springs".into(),
        nodes: vec![[0, 2], [1, 2]],
        reference: vec![[nodes[0], nodes[2]], [nodes[1], nodes[2]]],
        stiffness: vec![2.0; 2],
        rest_length: vec![2f64.sqrt(); 2],
    };
    let plate = ToolShape::Plate {
        point: [0.0; 3],
        normal: [0.0, 0.0, 1.0],
    };
    let contact = RigidContact::new(
        "plate",
        plate,
        ContactKind::Frictionless,
        vec![2],
        vec![nodes[2]],
        50.0,
        1e-9,
        vec![[0.0, 0.0, 0.3]],
    )
    .unwrap();
    let mut p = springs_and_tool(3, springs, contact, Box::new(DenseSolver::default()));
    let mut step = Step::new("push");
    step.prescribed = (0..6).chain([7]).map(|d| (d, Motion::Hold)).collect();
    step.control.convergence.early_augmentation = early_augmentation;
    let mut counter = IterationCounter(0);
    p.run_step(&step, &mut counter).unwrap();
    let force = value(&contact_term(&p), "plate_force_z_nN");
    (p.u()[8], force, counter.0)
}

#[test]
fn augmenting_near_equilibrium_reaches_the_same_state_in_fewer_iterations() {
    // At a rise of 0.3 um each spring is sqrt(1 + 0.7^2) long, compressed by
    // sqrt 2 - that; the plate carries both springs' vertical components.
    let length = (1.0f64 + 0.7 * 0.7).sqrt();
    let exact = 2.0 * 2.0 * (2f64.sqrt() - length) * 0.7 / length;
    let (rise_late, force_late, late) = inclined_springs_pushed(0.0);
    let (rise, force, early) =
        inclined_springs_pushed(crate::solve::Convergence::default().early_augmentation);
    for (x, f) in [(rise_late, force_late), (rise, force)] {
        assert!((x - 0.3).abs() < 1e-8, "rise {x}");
        assert!(
            (f - exact).abs() < 1e-7 * exact,
            "force {f} against {exact}"
        );
    }
    assert!(
        early < late,
        "{early} Newton iterations augmenting near equilibrium, {late} only at convergence"
    );
}

#[test]
fn bfgs_keeps_its_factorisation_through_multiplier_updates() {
    // With penalty 50 against the spring's 2 the multiplier needs several Uzawa rounds to
    // bring the penetration under 1e-9 um; only the start and the activation (a status
    // change) may factorise.
    let mut p = spring_and_tool(ContactKind::Frictionless, vec![[0.0, 0.0, 0.3]]);
    let mut step = Step::new("push");
    step.prescribed = fixed_top_and_lateral();
    step.control.convergence.method = crate::solve::IterationMethod::bfgs();
    step.control.initial_increment = 1.0;
    step.control.max_increment = 1.0;
    let mut counter = IterationCounter(0);
    p.run_step(&step, &mut counter).unwrap();
    let iterations = counter.0;
    assert_pushed_0_3_um(&p);
    assert!(
        iterations >= 5,
        "{iterations} iterations: no multiplier rounds?"
    );
    assert!(p.timings().factorizations <= 2, "{:?}", p.timings());
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
fn a_node_bonded_at_the_commit_keeps_the_force_it_had_pull_included() {
    // An active node inside the status band that pulls a little on the plate (the active
    // law is bilateral until the status check) is bonded at the commit. The bond must start
    // with that force, or the converged equilibrium changes under the reported forces (the
    // compression's plates were up to 5 nN out of balance when the pull was dropped).
    let (penalty, tolerance) = (50.0, 1e-3);
    let node = [0.0, 0.0, 1.0];
    let plate = ToolShape::Plate {
        point: [0.0, 0.0, 1.0],
        normal: [0.0, 0.0, 1.0],
    };
    let mut c = RigidContact::new(
        "plate",
        plate,
        ContactKind::Bonded,
        vec![0],
        vec![node],
        penalty,
        tolerance,
        vec![[0.0; 3]],
    )
    .unwrap();
    let dof_map = DofMap::translational(1);
    for (gap, pull) in [
        (0.3 * tolerance, true),
        (-0.2 * tolerance, false),
        (0.5 * tolerance, false),
    ] {
        let u = [0.0, 0.0, gap];
        let x = [node[0], node[1], node[2] + gap];
        let g = c.shape.gap(&x, &c.trial.offset).unwrap();
        let eps = penalty * c.scale[0];
        c.trial.anchors[0] = None;
        c.trial.active[0] = true;
        // p = λ − ε g: a pull of 0.4 ε·tol, or a push of 0.4 ε·tol.
        let p = if pull { -0.4 } else { 0.4 } * eps * tolerance;
        c.trial.lambda[0] = p + eps * g.value;
        let mut before = [0.0; 3];
        c.element_evaluate(0, &u, &mut before, None).unwrap();
        assert!(
            (before[2] + p * g.gradient[2]).abs() < 1e-12 * eps,
            "{before:?}"
        );
        c.on_commit(&u, &dof_map);
        assert!(c.trial.anchors[0].is_some(), "bonded at gap {gap}");
        let mut after = [0.0; 3];
        c.element_evaluate(0, &u, &mut after, None).unwrap();
        for i in 0..3 {
            assert!(
                (after[i] - before[i]).abs() <= 1e-12 * eps * tolerance,
                "gap {gap}: force {before:?} before the commit, {after:?} after"
            );
        }
    }
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

/// A plate pressed uniformly δ into a rectangular face: every Gauss point carries ε·share·δ,
/// the face as a whole ε·δ (the penalty of one node), a quarter on each corner; a second,
/// four times larger face takes four times the force.
#[test]
fn face_contact_spreads_a_uniform_pressure_by_area() {
    let x = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.5, 0.0],
        [0.0, 0.5, 0.0],
        [3.0, 0.0, 0.0],
        [3.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    // Face 0: 1 × 0.5; face 1: 2 × 1 (a trapezoid would do as well; rectangles are exact).
    let faces = [[0, 1, 2, 3], [1, 4, 5, 6]];
    let delta = 0.01;
    // The plate's face at z = δ, its body below (the normal +z points to the body it
    // pushes): both faces penetrate it by δ.
    let plate = ToolShape::Plate {
        point: [0.0, 0.0, delta],
        normal: [0.0, 0.0, 1.0],
    };
    for per_side in 1..=4 {
        let eps = 20.0;
        let mut c = RigidContact::on_faces(
            "plate",
            plate,
            ContactKind::Frictionless,
            &faces,
            &x,
            per_side,
            eps,
            1e-9,
            vec![[0.0; 3]],
        )
        .unwrap();
        assert_eq!(c.point_count(), 2 * per_side * per_side);
        c.set_load_state(&LoadState {
            step_index: 0,
            step_time: 1.0,
        });
        let u = vec![0.0; 21];
        let map = DofMap::translational(7);
        c.predict(&u, &map);
        // The mean face area is (0.5 + 2) / 2 = 1.25: the faces take 0.4 and 1.6 ε δ.
        let f = c.force_on_body(&u, &map);
        assert!(
            (f[2] - 2.0 * eps * delta).abs() < 1e-12,
            "{per_side}: {f:?}"
        );
        let mut r = [0.0; 12];
        for (face, share) in [(0, 0.4), (1, 1.6)] {
            c.evaluate(face, &[0.0; 12], &mut r, None).unwrap();
            for a in 0..4 {
                let expected = -0.25 * share * eps * delta;
                assert!((r[3 * a + 2] - expected).abs() < 1e-12, "{per_side}: {r:?}");
                assert_eq!((r[3 * a], r[3 * a + 1]), (0.0, 0.0));
            }
        }
    }
    // Bad input is an error, not a panic.
    let bad = |faces: &[[usize; 4]], per_side| {
        RigidContact::on_faces(
            "plate",
            plate,
            ContactKind::Frictionless,
            faces,
            &x,
            per_side,
            1.0,
            1e-9,
            vec![],
        )
        .unwrap_err()
        .to_string()
    };
    assert!(bad(&[[0, 1, 2, 9]], 2).contains("finite coordinates"));
    assert!(bad(&[[0, 1, 1, 0]], 2).contains("positive area"));
    assert!(bad(&[[0, 1, 2, 3]], 5).contains("1 to 4 points"));
    assert!(bad(&[], 2).contains("empty"));
}

#[test]
fn a_restored_trial_state_is_the_saved_one_after_an_augmentation_changed_it() {
    // The solver keeps the trial state of a converged, damped increment before it tries to
    // remove the viscosity; a failed try must return the contact to exactly that state.
    let nodes = [[0.0, 0.0, 1.0]];
    let plate = ToolShape::Plate {
        point: [0.0, 0.0, 1.0],
        normal: [0.0, 0.0, 1.0],
    };
    let mut contact = RigidContact::new(
        "plate",
        plate,
        ContactKind::Frictionless,
        vec![0],
        nodes.to_vec(),
        50.0,
        1e-9,
        vec![[0.0, 0.0, 0.2]],
    )
    .unwrap();
    let map = DofMap::translational(1);
    contact.set_load_state(&LoadState {
        step_index: 0,
        step_time: 0.5,
    });
    // The plate is 0.1 um into the node: the first augmentation activates it, the second
    // raises its multiplier.
    let u = [0.0; 3];
    assert!(matches!(
        contact.augment(&u, &map),
        Augmentation::Updated(_)
    ));
    contact.save_trial();
    let saved = contact.trial.clone();
    // Same active set, larger multiplier: the tangent is unchanged.
    assert!(matches!(
        contact.augment(&u, &map),
        Augmentation::Multipliers(_)
    ));
    assert_ne!(
        contact.trial, saved,
        "the second augmentation changed the state"
    );
    contact.restore_trial();
    assert_eq!(contact.trial, saved);
}

/// A node carried onto a plate at rest: with an extrapolated start the solver predicts it
/// in contact at the increment it arrives (`Term::predict`), so that increment needs no
/// contact-status round; the end state is the same.
#[test]
fn a_node_heading_onto_a_plate_at_rest_is_predicted_in_contact() {
    let run = |extrapolation: crate::solve::Extrapolation| {
        // The plate is 0.55 um below node 1 and stays there while node 0 is lowered by
        // 1 um.
        let mut p = spring_over_plate(ContactKind::Frictionless, 0.45, (1e4, 1e-3), vec![[0.0; 3]]);
        // The model's size: a correction below 1e-13 of it is round-off (an exact start
        // leaves nothing else to correct).
        p.set_length_scale(2.0);
        let mut step = Step::new("lower");
        step.prescribed = vec![
            (0, Motion::Hold),
            (1, Motion::Hold),
            (2, Motion::By(-1.0)),
            (3, Motion::Hold),
            (4, Motion::Hold),
        ];
        step.control.initial_increment = 0.1;
        step.control.max_increment = 0.1;
        step.control.extrapolation = extrapolation;
        // Newton iterations of each increment.
        let mut iterations = Vec::new();
        struct Increments<'a>(&'a mut Vec<usize>);
        impl crate::solve::Observer for Increments<'_> {
            fn on_increment(&mut self, _p: &Problem, r: &crate::solve::IncrementReport<'_>) {
                self.0.push(r.iterations);
            }
        }
        p.run_step(&step, &mut Increments(&mut iterations)).unwrap();
        let force = value(&contact_term(&p), "plate_force_z_nN");
        (p.u()[5], force, iterations)
    };
    let (z_plain, f_plain, plain) = run(crate::solve::Extrapolation::None);
    let (z, f, predicted) = run(crate::solve::Extrapolation::Linear);
    // Node 1 rests on the plate (within the penalty's 0.9/1e4 um); the spring is shortened
    // by 0.45 um: 0.9 nN.
    assert!((z + 0.55).abs() < 1e-4, "node 1 moved {z}");
    assert!((f - 0.9).abs() < 1e-3, "force {f}");
    assert!((z - z_plain).abs() < 1e-9 && (f - f_plain).abs() < 1e-6);
    // Node 1 reaches the plate in the sixth increment (step time 0.6, where it would be at
    // z = 0.4 without the plate). Predicted in contact from the extrapolated start, that
    // increment is one linear solve; from the converged start Newton first converges
    // without the contact and needs a contact-status round.
    assert_eq!(predicted.len(), 10, "{predicted:?}");
    assert_eq!(
        predicted[5], 1,
        "{predicted:?} predicted, {plain:?} without"
    );
    assert!(plain[5] > 1, "{predicted:?} predicted, {plain:?} without");
}

#[test]
fn an_approach_known_before_solving_rejects_overshoots_without_newton() {
    // The plate starts 0.5 um below the node and may rise by 1 um; the step ends where its
    // smallest gap (from the committed positions: linear in the travel) is 0. Rejecting
    // the trials that overshoot before solving them gives the same stop for fewer
    // factorisations.
    let run = |known: bool| {
        let mut p = spring_over_plate(
            ContactKind::Frictionless,
            0.5,
            (50.0, 1e-9),
            vec![[0.0, 0.0, 1.0]],
        );
        let mut step = Step::new("approach");
        step.prescribed = fixed_top_and_lateral();
        step.control.initial_increment = 0.4;
        step.control.max_increment = 1.0;
        step.stop = Some(crate::solve::StopCondition {
            monitor: crate::solve::Monitor::TermScalar("plate_min_gap_um".into()),
            target: 0.0,
            tolerance: 1e-6,
            known_before_solving: known,
        });
        p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
        let out = contact_term(&p);
        (
            value(&out, "plate_min_gap_um"),
            value(&out, "plate_displacement_z_um"),
            p.u()[5],
            p.timings().factorizations,
        )
    };
    let (gap_solved, travel_solved, u_solved, solved) = run(false);
    let (gap, travel, u, known) = run(true);
    for (g, z, x) in [(gap_solved, travel_solved, u_solved), (gap, travel, u)] {
        assert!(g.abs() <= 1e-6, "gap {g}");
        assert!((z - 0.5).abs() <= 1e-6, "plate travel {z}");
        assert!(x.abs() <= 1e-6, "the node did not move: {x}");
    }
    assert!(known < solved, "{known} factorisations against {solved}");
}

#[test]
fn a_tool_aimed_at_a_node_comes_down_over_where_the_node_has_moved() {
    // Node 1 hangs on the spring 1 um below node 0. A sphere of radius 0.5 um, centred at the
    // origin, stays put while the node is carried 0.7 um along x and -0.2 um along y
    // (step 0), then rises by 0.8 um (step 1): centred under the node it pushes it up by
    // 0.3 um against the spring (0.6 nN, straight up); left where it was, 0.73 um off the
    // node's line, it never touches it.
    let run = |aimed: bool| {
        let nodes = [[0.0, 0.0, 2.0], [0.0, 0.0, 1.0]];
        let springs = spring(nodes);
        let sphere = ToolShape::Sphere {
            center: [0.0, 0.0, 0.0],
            radius: 0.5,
        };
        let mut contact = RigidContact::new(
            "tip",
            sphere,
            ContactKind::Frictionless,
            vec![1],
            vec![nodes[1]],
            50.0,
            1e-9,
            vec![[0.0; 3], [0.0, 0.0, 0.8]],
        )
        .unwrap();
        if aimed {
            contact = contact.aimed_at(1, 1);
        }
        let terms: Vec<Box<dyn Term>> = vec![Box::new(springs), Box::new(contact)];
        let mut p = Problem::new(
            DofMap::translational(2),
            terms,
            Box::new(DenseSolver::default()),
        )
        .unwrap();
        let mut carry = Step::new("carry");
        carry.prescribed = vec![
            (0, Motion::By(0.7)),
            (1, Motion::By(-0.2)),
            (2, Motion::Hold),
            (3, Motion::By(0.7)),
            (4, Motion::By(-0.2)),
        ];
        p.run_step(&carry, &mut crate::solve::NullObserver).unwrap();
        let mut rise = Step::new("rise");
        rise.prescribed = fixed_top_and_lateral();
        p.run_step(&rise, &mut crate::solve::NullObserver).unwrap();
        let out = contact_term(&p);
        let v = |n: &str| value(&out, &format!("tip_{n}"));
        (
            [
                v("displacement_x_um"),
                v("displacement_y_um"),
                v("displacement_z_um"),
            ],
            [v("force_x_nN"), v("force_y_nN"), v("force_z_nN")],
            p.u()[5],
        )
    };
    let (offset, force, lift) = run(true);
    assert!(
        (offset[0] - 0.7).abs() < 1e-12 && (offset[1] + 0.2).abs() < 1e-12,
        "the aimed tip moved across by {offset:?}"
    );
    assert!((offset[2] - 0.8).abs() < 1e-12, "and up by {}", offset[2]);
    assert!((lift - 0.3).abs() < 1e-6, "the node was lifted by {lift}");
    // The force the tip exerts on the body: up.
    assert!((force[2] - 0.6).abs() < 1e-5, "{force:?}");
    assert!(force[0].abs() < 1e-6 && force[1].abs() < 1e-6, "{force:?}");
    let (offset, force, lift) = run(false);
    assert_eq!([offset[0], offset[1]], [0.0, 0.0]);
    assert!(lift.abs() < 1e-12 && force[2] == 0.0, "{lift} {force:?}");
}

/// A watched node gets no contact force but reports how deep it lies inside the tool: a
/// sphere of radius 1 centred at (0, 0, 2) holds the watched node 1 at (0, 0, 1.1) 0.1 deep,
/// and once the node has moved 0.2 down it is outside (0); the contact node 0 far away
/// is untouched, so the tool exerts no force at all, and the curve column appears only with
/// watched nodes.
#[test]
fn a_watched_node_inside_the_tool_is_measured_not_pushed() {
    let sphere = ToolShape::Sphere {
        center: [0.0, 0.0, 2.0],
        radius: 1.0,
    };
    let make = || {
        RigidContact::new(
            "tip",
            sphere,
            ContactKind::Frictionless,
            vec![0],
            vec![[5.0, 5.0, 0.0]],
            10.0,
            1e-6,
            vec![[0.0; 3]],
        )
        .unwrap()
    };
    let map = DofMap::translational(2);
    let column = scalar_name("tip", ToolScalar::DeepestWatchedNode);
    let plain = make();
    let u = [0.0; 6];
    assert!(plain
        .curve_outputs(&u, &map)
        .iter()
        .all(|(n, _)| *n != column));
    let watched = make().with_watched_nodes(vec![(1, [0.0, 0.0, 1.1])]);
    let out = watched.curve_outputs(&u, &map);
    let deepest = out.iter().find(|(n, _)| *n == column).unwrap().1;
    assert!((deepest - 0.1).abs() < 1e-12, "{deepest}");
    let force: f64 = (0..3)
        .map(|a| {
            out.iter()
                .find(|(n, _)| *n == scalar_name("tip", ToolScalar::Force(a)))
                .unwrap()
                .1
                .abs()
        })
        .sum();
    assert_eq!(force, 0.0);
    let moved = [0.0, 0.0, 0.0, 0.0, 0.0, -0.2];
    assert_eq!(watched.deepest_watched_node(&moved, &map), 0.0);
}

/// A unit square face at z = 0 (outer normal +z, the body below), each corner on a vertical
/// spring (k = 2 nN/um, rest length 1 um) to an anchor 1 um below it, and a paraboloid tip
/// of radius 0.05 um, axis −z, its apex touching the face's centre, pushed down by `depth`.
/// With `two_pass` the tip's surface points also press on the face.
fn face_on_springs_under_a_sharp_tip(depth: f64, two_pass: bool) -> Problem {
    let corners = [
        [-0.5, -0.5, 0.0],
        [0.5, -0.5, 0.0],
        [0.5, 0.5, 0.0],
        [-0.5, 0.5, 0.0],
    ];
    let mut coordinates = corners.to_vec();
    coordinates.extend(corners.iter().map(|c| [c[0], c[1], -1.0]));
    let springs = SpringSet {
        name: "springs".into(),
        nodes: (0..4).map(|a| [a, a + 4]).collect(),
        reference: (0..4).map(|a| [corners[a], coordinates[a + 4]]).collect(),
        stiffness: vec![2.0; 4],
        rest_length: vec![1.0; 4],
    };
    let tip = ToolShape::Paraboloid {
        apex: [0.0, 0.0, 0.0],
        axis: [0.0, 0.0, -1.0],
        tip_radius: 0.05,
    };
    let contact = RigidContact::new(
        "tip",
        tip,
        ContactKind::Frictionless,
        (0..4).collect(),
        corners.to_vec(),
        50.0,
        1e-7,
        vec![[0.0, 0.0, -depth]],
    )
    .unwrap();
    let contact = if two_pass {
        contact
            .with_tool_points_on_faces(&[[0, 1, 2, 3]], &coordinates, 0.0125, 0.1)
            .unwrap()
    } else {
        contact
    };
    springs_and_tool(8, springs, contact, Box::new(DenseSolver::default()))
}

/// Supports of `surface` nodes on springs to anchors (nodes `surface..2 surface`): the
/// anchors held, the surface nodes free only vertically.
fn vertical_only(surface: usize) -> Vec<(usize, Motion)> {
    let mut fixed: Vec<(usize, Motion)> = (3 * surface..6 * surface)
        .map(|d| (d, Motion::Hold))
        .collect();
    for a in 0..surface {
        fixed.push((3 * a, Motion::Hold));
        fixed.push((3 * a + 1, Motion::Hold));
    }
    fixed
}

#[test]
fn a_tip_sharper_than_a_face_passes_through_it_with_node_contact_and_not_with_two_passes() {
    let depth = 0.1;
    // Node contact: the corners lie 0.5√2 um from the axis, where the 0.05 um tip is 5 um
    // high; the tip passes through the face and carries nothing.
    let mut p = face_on_springs_under_a_sharp_tip(depth, false);
    let mut step = Step::new("push");
    step.prescribed = vertical_only(4);
    p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
    let out = contact_term(&p);
    assert_eq!(value(&out, "tip_force_z_nN"), 0.0);
    assert!(p.u()[2].abs() < 1e-12);
    // Two passes: the tip's apex point pushes the face's centre down by the depth; by
    // symmetry the face moves down flat, and the four springs carry 4 k d = 0.8 nN.
    let mut p = face_on_springs_under_a_sharp_tip(depth, true);
    p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
    let out = contact_term(&p);
    let force = value(&out, "tip_force_z_nN");
    assert!(
        (force + 4.0 * 2.0 * depth).abs() < 1e-5,
        "force {force} u {:?} out {out:?}",
        p.u()
    );
    for a in 0..4 {
        let w = p.u()[3 * a + 2];
        assert!((w + depth).abs() < 1e-6, "corner {a} moved {w}");
    }
    assert!(value(&out, "tip_max_penetration_um") <= 1e-7);
    // The contact radius is that of the tool points pressing (the apex only: the face is
    // flat and the tip's other points lie above it).
    assert!(value(&out, "tip_contact_radius_um") < 1e-9);
}

#[test]
fn the_second_pass_tangent_is_the_derivative_of_its_residual() {
    // A skewed, warped face with the tip pressed into it off its centre, so that several
    // tool points press on several of its four triangles.
    let x = [
        [-0.4, -0.5, 0.02],
        [0.55, -0.45, -0.03],
        [0.5, 0.6, 0.05],
        [-0.45, 0.4, 0.0],
    ];
    let tip = ToolShape::Paraboloid {
        apex: [0.08, -0.05, 0.1],
        axis: [0.0, 0.0, -1.0],
        tip_radius: 0.2,
    };
    let mut c = RigidContact::new(
        "tip",
        tip,
        ContactKind::Frictionless,
        vec![0],
        vec![x[0]],
        30.0,
        1e-9,
        vec![[0.0, 0.0, -0.16]],
    )
    .unwrap()
    .with_tool_points_on_faces(&[[0, 1, 2, 3]], &x, 0.05, 0.4)
    .unwrap()
    .with_curvature_tangent(CurvatureTangent::Consistent);
    assert!(c.tool_point_count() > 100);
    c.set_load_state(&LoadState {
        step_index: 0,
        step_time: 1.0,
    });
    let map = DofMap::translational(4);
    let u0 = vec![0.0; 12];
    c.predict(&u0, &map);
    let pairs = c.tool_pair_count();
    assert!(pairs > 5, "{pairs} pairs");
    let triangles: std::collections::HashSet<usize> =
        c.trial.pairs[0].iter().map(|p| p.triangle).collect();
    assert!(triangles.len() >= 3, "{triangles:?}");
    // Multipliers as an augmentation would leave them.
    for (i, pair) in c.trial.pairs[0].iter_mut().enumerate() {
        pair.lambda = 0.01 * (i % 3) as f64;
    }
    // A state off the reference, the face element is element 1 (after the node).
    let u: Vec<f64> = (0..12)
        .map(|i| 0.003 * ((i * 7 % 5) as f64 - 2.0))
        .collect();
    let (mut r, mut k) = ([0.0; 12], vec![0.0; 144]);
    let energy = c.evaluate(1, &u, &mut r, Some(&mut k)).unwrap();
    assert!(energy > 0.0);
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    let scale = k.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for j in 0..12 {
        let (mut up, mut down) = (u.clone(), u.clone());
        up[j] += h;
        down[j] -= h;
        let (mut rp, mut rm) = ([0.0; 12], [0.0; 12]);
        let ep = c.evaluate(1, &up, &mut rp, None).unwrap();
        let em = c.evaluate(1, &down, &mut rm, None).unwrap();
        // The residual is the energy's gradient…
        let de = (ep - em) / (2.0 * h);
        assert!(
            (de - r[j]).abs() < 1e-6 * (1.0 + r[j].abs()),
            "dof {j}: {de} vs {}",
            r[j]
        );
        // …and the tangent the residual's.
        for i in 0..12 {
            let fd = (rp[i] - rm[i]) / (2.0 * h);
            worst = worst.max((fd - k[i * 12 + j]).abs());
        }
    }
    assert!(worst < 1e-6 * scale, "worst {worst:.3e} of {scale:.3e}");
    // The force on the body is the sum of the face nodes' residual, reversed.
    let map12 = DofMap::translational(4);
    let mut global = vec![0.0; 12];
    global.copy_from_slice(&u);
    let f = c.force_on_body(&global, &map12);
    for i in 0..3 {
        let sum: f64 = (0..4).map(|a| r[3 * a + i]).sum();
        assert!(
            (f[i] + sum).abs() < 1e-9 * (1.0 + sum.abs()),
            "{f:?} vs {sum}"
        );
    }
    // Only a paraboloid has surface points.
    let plate = ToolShape::Plate {
        point: [0.0; 3],
        normal: [0.0, 0.0, 1.0],
    };
    let err = RigidContact::new(
        "plate",
        plate,
        ContactKind::Frictionless,
        vec![0],
        vec![x[0]],
        1.0,
        1e-9,
        vec![],
    )
    .unwrap()
    .with_tool_points_on_faces(&[[0, 1, 2, 3]], &x, 0.05, 0.4)
    .unwrap_err()
    .to_string();
    assert!(err.contains("paraboloid"), "{err}");
}

/// A grid of `n` × `n` faces of side `h` at z = 0 (centred on the axis), each node on a
/// vertical spring (k = `k` nN/um) to an anchor 1 um below, held laterally; a paraboloid
/// tip of radius R = 0.2 um pushed down by `depth`, one pass or two.
fn grid_under_tip(
    n: usize,
    h: f64,
    k: f64,
    depth: f64,
    two_pass: bool,
) -> (Problem, Vec<(usize, Motion)>) {
    let m = n + 1;
    let half = 0.5 * h * n as f64;
    let mut x = Vec::new();
    for j in 0..m {
        for i in 0..m {
            x.push([i as f64 * h - half, j as f64 * h - half, 0.0]);
        }
    }
    let surface = x.len();
    for a in 0..surface {
        x.push([x[a][0], x[a][1], -1.0]);
    }
    let springs = SpringSet {
        name: "springs".into(),
        nodes: (0..surface).map(|a| [a, a + surface]).collect(),
        reference: (0..surface).map(|a| [x[a], x[a + surface]]).collect(),
        stiffness: vec![k; surface],
        rest_length: vec![1.0; surface],
    };
    let mut faces = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * m + i;
            faces.push([a, a + 1, a + m + 1, a + m]);
        }
    }
    let tip = ToolShape::Paraboloid {
        apex: [0.013, 0.007, 0.0],
        axis: [0.0, 0.0, -1.0],
        tip_radius: 0.2,
    };
    let contact = RigidContact::new(
        "tip",
        tip,
        ContactKind::Frictionless,
        (0..surface).collect(),
        x[..surface].to_vec(),
        50.0 * k,
        1e-6,
        vec![[0.0, 0.0, -depth]],
    )
    .unwrap();
    let contact = if two_pass {
        contact
            .with_tool_points_on_faces(&faces, &x, 0.05, 0.4)
            .unwrap()
    } else {
        contact
    };
    let problem = springs_and_tool(
        x.len(),
        springs,
        contact,
        Box::new(crate::linsolve::FaerSparseSolver::default()),
    );
    let fixed = vertical_only(surface);
    (problem, fixed)
}

/// Winkler foundation (springs of k = k_a h² per node) under a paraboloid: F = π k_a R d²
/// while the contact radius √(2 R d) is small against the grid.
#[test]
fn two_passes_on_a_spring_bed_converge_to_the_winkler_force_from_above() {
    let (k_a, r, depth) = (50.0, 0.2, 0.1);
    let exact = std::f64::consts::PI * k_a * r * depth * depth;
    let mut errors = Vec::new();
    for (n, h) in [(8, 0.1), (16, 0.05)] {
        let mut forces = [0.0; 2];
        for (slot, two) in [false, true].into_iter().enumerate() {
            let (mut p, fixed) = grid_under_tip(n, h, k_a * h * h, depth, two);
            let mut step = Step::new("push");
            step.prescribed = fixed;
            step.control.initial_increment = 0.1;
            step.control.max_increment = 0.1;
            p.run_step(&step, &mut crate::solve::NullObserver).unwrap();
            let out = contact_term(&p);
            forces[slot] = -value(&out, "tip_force_z_nN");
            assert!(value(&out, "tip_max_penetration_um") <= 1e-6);
        }
        let [nodes, two] = forces.map(|f| f / exact - 1.0);
        eprintln!("h = {h}: node contact {nodes:+.4}, two passes {two:+.4} (relative to Winkler)");
        // Node contact lets the faces cut into the tip between the nodes (low); two passes
        // keep the faces' triangles outside the tip's points (high).
        assert!(nodes.abs() < 0.03, "h = {h}: node contact {nodes}");
        assert!(two > nodes, "h = {h}: {two} vs {nodes}");
        errors.push(two);
    }
    // The two-pass excess falls with the face size (the faces' sag h²/(8R)): 4 % at R/4.
    assert!(
        errors[1] < 0.3 * errors[0] && errors[1] < 0.05,
        "{errors:?}"
    );
}
