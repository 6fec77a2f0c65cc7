//! Solver behaviour on small spring systems with closed-form answers.

use super::*;
use crate::dof::DofMap;
use crate::element::spring::SpringSet;
use crate::linsolve::DenseSolver;
use crate::term::Term;

fn springs(nodes: &[[f64; 3]], pairs: &[[usize; 2]], k: f64) -> SpringSet {
    SpringSet {
        name: "springs".into(),
        nodes: pairs.to_vec(),
        reference: pairs.iter().map(|&[a, b]| [nodes[a], nodes[b]]).collect(),
        stiffness: vec![k; pairs.len()],
        rest_length: pairs
            .iter()
            .map(|&[a, b]| {
                (0..3)
                    .map(|i| (nodes[b][i] - nodes[a][i]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .collect(),
    }
}

fn problem(nodes: &[[f64; 3]], pairs: &[[usize; 2]], k: f64) -> Problem {
    let terms: Vec<Box<dyn Term>> = vec![Box::new(springs(nodes, pairs, k))];
    Problem::new(
        DofMap::translational(nodes.len()),
        terms,
        Box::new(DenseSolver::default()),
    )
    .unwrap()
}

#[derive(Default)]
struct Recorder {
    iterations: Vec<IterationReport>,
    increments: Vec<(f64, usize)>,
    cutbacks: usize,
}

impl Observer for Recorder {
    fn on_iteration(&mut self, report: &IterationReport) {
        self.iterations.push(*report);
    }
    fn on_increment(&mut self, _problem: &Problem, report: &IncrementReport<'_>) {
        self.increments.push((report.step_time, report.iterations));
    }
    fn on_cutback(&mut self, _t: f64, _dt: f64, _reason: &FailureReason) {
        self.cutbacks += 1;
    }
}

#[test]
fn newton_prescribed_stretch_of_spring_chain_gives_series_stiffness_reaction() {
    // Three collinear springs of stiffness 2 nN/um; node 0 fixed, node 3 pulled by 0.9 um.
    let nodes = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [3.0, 0.0, 0.0],
    ];
    let mut p = problem(&nodes, &[[0, 1], [1, 2], [2, 3]], 2.0);
    let mut step = Step::new("pull");
    step.prescribed = (0..3).map(|c| (c, Motion::Hold)).collect();
    step.prescribed
        .extend([(9, Motion::To(0.9)), (10, Motion::Hold), (11, Motion::Hold)]);
    for node in 1..3 {
        step.prescribed
            .extend([(3 * node + 1, Motion::Hold), (3 * node + 2, Motion::Hold)]);
    }
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();
    assert!(
        (p.reaction(9) - 2.0 / 3.0 * 0.9).abs() < 1e-10,
        "reaction {}",
        p.reaction(9)
    );
    assert!((p.reaction(0) + 2.0 / 3.0 * 0.9).abs() < 1e-10);
    assert!((p.u()[3] - 0.3).abs() < 1e-10 && (p.u()[6] - 0.6).abs() < 1e-10);
    assert!((rec.increments.last().unwrap().0 - 1.0).abs() < 1e-12);
}

/// A spring fixed at the origin, its free end loaded sideways by (4, 3) nN: large rotation.
/// Equilibrium: the spring aligns with the load, N = 5 = k (l - 0.8), so l = 1.3.
fn large_rotation_spring() -> (Problem, Step) {
    large_rotation_spring_with(Vec::new())
}

/// [`large_rotation_spring`] with more terms on its two nodes.
fn large_rotation_spring_with(extra: Vec<Box<dyn Term>>) -> (Problem, Step) {
    let nodes = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
    let mut set = springs(&nodes, &[[0, 1]], 10.0);
    set.rest_length[0] = 0.8; // prestretched, so the lateral stiffness N/l is not zero
    let mut terms: Vec<Box<dyn Term>> = vec![Box::new(set)];
    terms.extend(extra);
    let p = Problem::new(
        DofMap::translational(2),
        terms,
        Box::new(DenseSolver::default()),
    )
    .unwrap();
    let mut step = Step::new("load");
    step.prescribed = vec![
        (0, Motion::Hold),
        (1, Motion::Hold),
        (2, Motion::Hold),
        (5, Motion::Hold),
    ];
    step.loads = vec![
        NodalLoad { dof: 3, value: 4.0 },
        NodalLoad { dof: 4, value: 3.0 },
    ];
    (p, step)
}

#[test]
fn newton_converges_quadratically_on_a_large_rotation_spring_problem() {
    let (mut p, mut step) = large_rotation_spring();
    step.control.initial_increment = 1.0;
    step.control.max_increment = 1.0;
    // Every correction from a fresh tangent (no chord steps near convergence).
    step.control.convergence.chord_near_convergence = false;
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();
    // Equilibrium: the spring aligns with the load (4, 3), N = 5 = k (l - 0.8) -> l = 1.3.
    let (x, y) = (1.0 + p.u()[3], p.u()[4]);
    assert!(
        (x - 1.3 * 0.8).abs() < 1e-9 && (y - 1.3 * 0.6).abs() < 1e-9,
        "x {x} y {y}"
    );
    // Quadratic convergence: once below 1e-2, each ratio is below ~C * previous^2.
    let ratios: Vec<f64> = rec.iterations.iter().map(|r| r.residual_ratio).collect();
    let tail: Vec<&[f64]> = ratios
        .windows(2)
        .filter(|w| w[0] < 1e-2 && w[1] > 0.0)
        .collect();
    assert!(!tail.is_empty(), "ratios {ratios:?}");
    for w in tail {
        assert!(w[1] < 10.0 * w[0] * w[0], "not quadratic: {ratios:?}");
    }
}

#[test]
fn chord_steps_near_convergence_reach_the_same_equilibrium_with_fewer_factorisations() {
    // The large-rotation spring in one increment, with and without chord steps: the same
    // closed-form equilibrium to the tolerance, fewer factorisations, and chord steps only
    // where the residual was already within the chord window.
    let solve = |chord: bool| {
        let (mut p, mut step) = large_rotation_spring();
        step.control.initial_increment = 1.0;
        step.control.max_increment = 1.0;
        step.control.convergence.chord_near_convergence = chord;
        let mut rec = Recorder::default();
        p.run_step(&step, &mut rec).unwrap();
        let t = p.timings();
        (p.u()[3], p.u()[4], t.factorizations, t.chord_steps, rec)
    };
    let (x, y, fresh, none, _) = solve(false);
    let (xc, yc, factorizations, chords, rec) = solve(true);
    assert_eq!(none, 0);
    assert!(chords > 0, "no chord step taken");
    assert!(
        factorizations < fresh,
        "{factorizations} factorisations with chord steps, {fresh} without"
    );
    for (a, b) in [(x, xc), (y, yc)] {
        assert!((a - b).abs() < 1e-8, "{a} vs {b}");
    }
    assert!((1.0 + xc - 1.04).abs() < 1e-8 && (yc - 0.78).abs() < 1e-8);
    let tolerance = crate::solve::Convergence::default().residual_tolerance;
    let window = crate::solve::CHORD_WINDOW * tolerance;
    for w in rec.iterations.windows(2) {
        if w[1].chord {
            assert!(
                w[0].residual_ratio <= window,
                "chord step from {:e}",
                w[0].residual_ratio
            );
        }
    }
    let last = rec.iterations.last().unwrap();
    assert!(last.residual_ratio <= tolerance, "{last:?}");
}

/// One DOF on a nonlinear support: `law(u, tangent wanted)` gives (force, stiffness,
/// energy).
struct OneDofSupport<L: Fn(f64, bool) -> (f64, f64, f64) + Send + Sync> {
    law: L,
}

impl<L: Fn(f64, bool) -> (f64, f64, f64) + Send + Sync> Term for OneDofSupport<L> {
    fn name(&self) -> &str {
        "support"
    }
    fn num_elements(&self) -> usize {
        1
    }
    fn element_dofs(&self, _e: usize, _m: &DofMap, dofs: &mut [usize]) -> usize {
        dofs[0] = 0;
        1
    }
    fn evaluate(
        &self,
        _e: usize,
        u: &[f64],
        r: &mut [f64],
        k: Option<&mut [f64]>,
    ) -> Result<f64, crate::element::KernelError> {
        let (force, stiffness, energy) = (self.law)(u[0], k.is_some());
        r[0] = force;
        if let Some(k) = k {
            k[0] = stiffness;
        }
        Ok(energy)
    }
}

/// One DOF on a softening support: force sin(u), so no equilibrium exists beyond 1 nN.
fn softening_support() -> Box<dyn Term> {
    Box::new(OneDofSupport {
        law: |u: f64, _| (u.sin(), u.cos(), 1.0 - u.cos()),
    })
}

#[test]
fn past_a_limit_point_load_control_stops_cleanly_and_keeps_converged_increments() {
    let terms: Vec<Box<dyn Term>> = vec![softening_support()];
    let dofs = DofMap::with_counts(&[1]);
    let mut p = Problem::new(dofs, terms, Box::new(DenseSolver::default())).unwrap();
    let mut step = Step::new("beyond-limit");
    step.loads = vec![NodalLoad { dof: 0, value: 1.5 }];
    step.control.min_increment = 1e-4;
    let mut rec = Recorder::default();
    let err = p.run_step(&step, &mut rec).unwrap_err();
    let last = rec.increments.last().unwrap().0;
    match &err {
        SolveError::IncrementTooSmall { step, time, .. } => {
            assert_eq!(step, "beyond-limit");
            assert!((time - last).abs() < 1e-12);
        }
        other => panic!("unexpected error {other}"),
    }
    // The limit load 1 nN is reached at t = 2/3: the last converged increment is just below.
    assert!(last > 0.6 && last < 2.0 / 3.0, "last converged time {last}");
    assert!(
        (p.u()[0] - (1.5 * last).asin()).abs() < 1e-8,
        "state kept at the last converged increment"
    );
    assert!(rec.cutbacks > 0);
    assert!(err
        .to_string()
        .contains("step 'beyond-limit' stopped at step time"));
}

#[test]
fn a_step_that_starts_in_equilibrium_converges_at_once() {
    // A prestressed spring chain held at both ends: nothing changes during the step, the
    // residual is round-off relative to the internal forces, and no iteration limit is hit.
    let nodes = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
    let mut set = springs(&nodes, &[[0, 1], [1, 2]], 100.0);
    set.rest_length = vec![0.8, 0.8]; // 20 nN of tension in both springs
    let terms: Vec<Box<dyn Term>> = vec![Box::new(set)];
    let mut p = Problem::new(
        DofMap::translational(3),
        terms,
        Box::new(DenseSolver::default()),
    )
    .unwrap();
    let mut step = Step::new("hold");
    step.prescribed = (0..3)
        .chain(6..9)
        .chain([4, 5])
        .map(|d| (d, Motion::Hold))
        .collect();
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();
    assert!(
        rec.increments
            .iter()
            .all(|&(_, iterations)| iterations == 1),
        "{:?}",
        rec.increments
    );
    assert!((p.reaction(6) - 20.0).abs() < 1e-10);
}

/// Four collinear nodes 1 um apart: the spring chain of the stop-condition tests.
const CHAIN: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [2.0, 0.0, 0.0],
    [3.0, 0.0, 0.0],
];

/// A step pulling the chain's end (DOF 9) by up to 1 um along x, node 0 held, the rest held
/// across the chain.
fn pull_end_step(name: &str) -> Step {
    let mut step = Step::new(name);
    step.prescribed = (0..3).map(|c| (c, Motion::Hold)).collect();
    step.prescribed
        .extend([(9, Motion::By(1.0)), (10, Motion::Hold), (11, Motion::Hold)]);
    for node in 1..3 {
        step.prescribed
            .extend([(3 * node + 1, Motion::Hold), (3 * node + 2, Motion::Hold)]);
    }
    step
}

#[test]
fn a_stop_condition_ends_the_step_where_the_reaction_reaches_its_target() {
    // Three springs in series (2 nN/um each, series stiffness 2/3): pulling the end by up to
    // 1 um, stop where the end reaction is 0.4 nN, i.e. at an end displacement of 0.6 um.
    let mut p = problem(&CHAIN, &[[0, 1], [1, 2], [2, 3]], 2.0);
    let mut step = pull_end_step("pull-to-force");
    step.stop = Some(StopCondition {
        monitor: Monitor::ReactionSum(vec![9]),
        target: 0.4,
        tolerance: 1e-9,
        known_before_solving: false,
    });
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();
    assert!(
        (p.reaction(9) - 0.4).abs() <= 1e-9,
        "reaction {}",
        p.reaction(9)
    );
    assert!(
        (p.u()[9] - 0.6).abs() < 1e-8,
        "end displacement {}",
        p.u()[9]
    );
    // A target beyond the step's motion is a clear error, with the state kept.
    step.stop = Some(StopCondition {
        monitor: Monitor::ReactionSum(vec![9]),
        target: 5.0,
        tolerance: 1e-9,
        known_before_solving: false,
    });
    let err = p.run_step(&step, &mut rec).unwrap_err();
    assert!(matches!(err, SolveError::TargetNotReached { .. }), "{err}");
    assert!((p.u()[9] - 1.6).abs() < 1e-9);
}

#[test]
fn bfgs_reaches_the_same_equilibrium_with_fewer_factorisations() {
    // The large-rotation spring solved by full Newton and by BFGS: the same answer to the
    // tolerance, fewer factorisations.
    let solve = |method: IterationMethod| {
        let (mut p, mut step) = large_rotation_spring();
        step.control.initial_increment = 0.25;
        step.control.convergence.method = method;
        let mut rec = Recorder::default();
        p.run_step(&step, &mut rec).unwrap();
        (p.u()[3], p.u()[4], p.timings().factorizations)
    };
    let (x, y, newton) = solve(IterationMethod::Newton);
    let (xb, yb, bfgs) = solve(IterationMethod::Bfgs { max_updates: 10 });
    assert!(
        (x - xb).abs() < 1e-7 && (y - yb).abs() < 1e-7,
        "{x} {y} vs {xb} {yb}"
    );
    // Both at the closed-form equilibrium (1.3·0.8, 1.3·0.6).
    assert!((1.0 + xb - 1.04).abs() < 1e-7 && (yb - 0.78).abs() < 1e-7);
    assert!(bfgs < newton, "BFGS {bfgs} factorisations, Newton {newton}");
}

#[test]
fn a_quasi_newton_step_retries_a_failed_increment_with_full_newton() {
    // The large-rotation spring in one increment with few iterations allowed: BFGS fails
    // it, the increment is halved and retried. The retry must be full Newton: its iterations
    // equal, bit for bit, those of a full-Newton step started with the halved increment.
    let run = |method: IterationMethod, initial: f64| {
        let (mut p, mut step) = large_rotation_spring();
        step.control.initial_increment = initial;
        step.control.max_increment = 1.0;
        step.control.convergence.max_iterations = 5;
        step.control.convergence.method = method;
        let mut rec = Recorder::default();
        p.run_step(&step, &mut rec).unwrap();
        (p.u()[3], p.u()[4], rec)
    };
    let (x, y, quasi) = run(IterationMethod::Bfgs { max_updates: 10 }, 1.0);
    let (_, _, newton) = run(IterationMethod::Newton, 0.5);
    assert_eq!(
        quasi.cutbacks, 1,
        "BFGS fails the whole step in 5 iterations"
    );
    assert_eq!(newton.cutbacks, 0);
    let failed = quasi.iterations.len() - quasi.increments.iter().map(|i| i.1).sum::<usize>();
    let retry = &quasi.iterations[failed..failed + newton.increments[0].1];
    let reference = &newton.iterations[..newton.increments[0].1];
    let ratios = |r: &[IterationReport]| {
        r.iter()
            .map(|x| (x.residual_ratio, x.energy_ratio))
            .collect::<Vec<_>>()
    };
    assert_eq!(ratios(retry), ratios(reference));
    assert_eq!(quasi.increments[0], newton.increments[0]);
    // And the step still ends at the closed-form equilibrium.
    assert!(
        (1.0 + x - 1.04).abs() < 1e-7 && (y - 0.78).abs() < 1e-7,
        "{x} {y}"
    );
}

/// A monitor that jumps: 1 below `at`, 10 from there on, read from DOF `dof`.
struct Staircase {
    dof: usize,
    at: f64,
}

impl Term for Staircase {
    fn name(&self) -> &str {
        "staircase"
    }
    fn num_elements(&self) -> usize {
        0
    }
    fn element_dofs(&self, _e: usize, _dof_map: &DofMap, _dofs: &mut [usize]) -> usize {
        0
    }
    fn evaluate(
        &self,
        _e: usize,
        _u_e: &[f64],
        _residual: &mut [f64],
        _tangent: Option<&mut [f64]>,
    ) -> Result<f64, crate::element::KernelError> {
        Ok(0.0)
    }
    fn scalar_outputs(&self, u: &[f64], _dof_map: &DofMap) -> Vec<(String, f64)> {
        let value = if u[self.dof] < self.at { 1.0 } else { 10.0 };
        vec![("stairs".into(), value)]
    }
}

#[test]
fn a_stop_condition_across_a_jump_ends_at_the_first_state_beyond_it() {
    // The monitor jumps from 1 to 10 at an end displacement of 0.37 um; the target 5 lies in
    // the jump. The step ends just beyond it (within JUMP_WIDTH of the 1 um travel), in a
    // few dozen increments: the bracket is halved once the regula falsi creeps.
    let terms: Vec<Box<dyn Term>> = vec![
        Box::new(springs(&CHAIN, &[[0, 1], [1, 2], [2, 3]], 2.0)),
        Box::new(Staircase { dof: 9, at: 0.37 }),
    ];
    let mut p = Problem::new(
        DofMap::translational(4),
        terms,
        Box::new(DenseSolver::default()),
    )
    .unwrap();
    let mut step = pull_end_step("to-the-jump");
    step.control.initial_increment = 0.1;
    step.control.max_increment = 0.1;
    step.stop = Some(StopCondition {
        monitor: Monitor::TermScalar("stairs".into()),
        target: 5.0,
        tolerance: 0.1,
        known_before_solving: false,
    });
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();
    let end = p.u()[9];
    assert!(
        (0.37..=0.37 + 2.0 * JUMP_WIDTH).contains(&end),
        "ended at {end}"
    );
    assert!(
        rec.increments.len() < 40,
        "{} increments",
        rec.increments.len()
    );
}

/// A guess path only moves where Newton starts: from the exact state or from a wrong one,
/// a step ends in the same equilibrium as without it.
#[test]
fn a_guess_path_changes_where_newton_starts_not_where_it_ends() {
    use crate::solve::GuessPath;
    let run = |guess: Option<GuessPath>| {
        let mut p = problem(&CHAIN, &[[0, 1], [1, 2], [2, 3]], 2.0);
        let mut step = pull_end_step("pull");
        step.guess = guess;
        let mut rec = Recorder::default();
        p.run_step(&step, &mut rec).unwrap();
        (p.u().to_vec(), rec.iterations.len())
    };
    let (exact, _) = run(None);
    // Interior nodes of the chain at 1/3 and 2/3 of the end's 1 um.
    assert!((exact[3] - 1.0 / 3.0).abs() < 1e-12 && (exact[6] - 2.0 / 3.0).abs() < 1e-12);
    let wrong: Vec<f64> = exact.iter().map(|v| 3.0 * v - 0.2).collect();
    for values in [exact.clone(), wrong] {
        let (u, _) = run(Some(GuessPath {
            times: vec![1.0],
            values: vec![values],
        }));
        for (a, b) in exact.iter().zip(&u) {
            assert!((a - b).abs() <= 1e-12, "{a} vs {b}");
        }
    }
    // A path with the wrong number of values is a clear error before any increment.
    let mut p = problem(&CHAIN, &[[0, 1], [1, 2], [2, 3]], 2.0);
    let mut step = pull_end_step("pull");
    step.guess = Some(GuessPath {
        times: vec![1.0],
        values: vec![vec![0.0; 5]],
    });
    let msg = p
        .run_step(&step, &mut Recorder::default())
        .unwrap_err()
        .to_string();
    assert!(msg.contains("guess path"), "{msg}");
}

/// On a linear path an extrapolated start is the exact solution from a step's second
/// increment on, also when the increments grow (the extrapolation is scaled by their
/// ratio); without it Newton's first correction is the whole increment. Both end in the
/// same equilibrium.
#[test]
fn an_extrapolated_start_is_exact_on_a_linear_path_and_changes_no_result() {
    let run = |extrapolation: Extrapolation| {
        let mut p = problem(&CHAIN, &[[0, 1], [1, 2], [2, 3]], 2.0);
        let mut step = pull_end_step("pull");
        step.control.initial_increment = 0.1;
        step.control.max_increment = 0.4;
        step.control.extrapolation = extrapolation;
        let mut rec = Recorder::default();
        p.run_step(&step, &mut rec).unwrap();
        (p.u().to_vec(), rec)
    };
    let (plain, plain_rec) = run(Extrapolation::None);
    let (extrapolated, rec) = run(Extrapolation::Linear);
    for (a, b) in plain.iter().zip(&extrapolated) {
        assert!((a - b).abs() <= 1e-12, "{a} vs {b}");
    }
    // Increments of 0.1, 0.15, 0.225, ...: the sizes change.
    let times: Vec<f64> = rec.increments.iter().map(|&(t, _)| t).collect();
    assert!(
        times.len() >= 4 && (times[1] - times[0] - 0.15).abs() < 1e-12,
        "{times:?}"
    );
    let first_corrections = |rec: &Recorder| -> Vec<f64> {
        rec.iterations
            .iter()
            .filter(|r| r.iteration == 0)
            .map(|r| r.correction_norm)
            .collect()
    };
    let with = first_corrections(&rec);
    let without = first_corrections(&plain_rec);
    assert!(with[1..].iter().all(|&c| c < 1e-12), "{with:?}");
    assert!(without[1..].iter().all(|&c| c > 0.01), "{without:?}");
}

/// The large-rotation spring loaded along its axis (4 nN), then swung by a lateral load
/// growing to 6 nN (it turns by atan(6/4) = 56 degrees while it stretches) in increments of
/// `dt`, each started as `extrapolation` says (`newton`: full Newton, else the default
/// method). The swing's equilibrium is checked against the closed form; returns the
/// problem.
fn swing(
    dt: f64,
    extrapolation: Extrapolation,
    newton: bool,
    observer: &mut dyn Observer,
) -> Problem {
    let (mut p, mut step) = large_rotation_spring();
    step.loads = vec![NodalLoad { dof: 3, value: 4.0 }];
    p.run_step(&step, &mut Recorder::default()).unwrap();
    let mut swing = step.clone();
    swing.name = "swing".into();
    swing.loads = vec![NodalLoad { dof: 4, value: 6.0 }];
    swing.control.initial_increment = dt;
    swing.control.max_increment = dt;
    swing.control.extrapolation = extrapolation;
    if newton {
        swing.control.convergence.method = IterationMethod::Newton;
    }
    p.run_step(&swing, observer).unwrap();
    // Equilibrium: the spring along the load (4, 6), N = |F| = k (l - 0.8).
    let f = (4.0f64 * 4.0 + 6.0 * 6.0).sqrt();
    let l = 0.8 + f / 10.0;
    let (x, y) = (1.0 + p.u()[3], p.u()[4]);
    assert!(
        (x - l * 4.0 / f).abs() < 1e-9 && (y - l * 6.0 / f).abs() < 1e-9,
        "x {x} y {y}"
    );
    p
}

/// On a smooth nonlinear path (a pulled spring swung round by a growing lateral load)
/// the extrapolated start reaches the same equilibrium in fewer iterations.
#[test]
fn an_extrapolated_start_saves_iterations_on_a_smooth_nonlinear_path() {
    let mut plain = Recorder::default();
    swing(0.1, Extrapolation::None, false, &mut plain);
    let mut extrapolated = Recorder::default();
    swing(0.1, Extrapolation::Linear, false, &mut extrapolated);
    let (iterations, plain_iterations) = (extrapolated.iterations.len(), plain.iterations.len());
    assert!(
        iterations < plain_iterations,
        "{iterations} iterations extrapolated, {plain_iterations} without"
    );
}

/// A stiff spring holds node 1 against a load; a taut two-spring string hangs from node 1
/// to a wall with its middle node 2 pulled 0.6 to the side: the string must swing onto the
/// axis, a large rotation of soft springs, while node 1 barely moves.
fn hanging_string() -> (Problem, Step) {
    let nodes = [
        [2.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 0.6, 0.0],
        [-1.0, 0.0, 0.0],
    ];
    let mut wall = springs(&nodes, &[[0, 1]], 10.0);
    wall.name = "wall".into();
    let mut string = springs(&nodes, &[[1, 2], [2, 3]], 1.0);
    string.rest_length = vec![0.8, 0.8];
    let terms: Vec<Box<dyn Term>> = vec![Box::new(wall), Box::new(string)];
    let p = Problem::new(
        DofMap::translational(nodes.len()),
        terms,
        Box::new(DenseSolver::default()),
    )
    .unwrap();
    let mut step = Step::new("load");
    step.prescribed = [0, 1, 2, 4, 5, 8, 9, 10, 11]
        .into_iter()
        .map(|d| (d, Motion::Hold))
        .collect();
    step.loads = vec![NodalLoad { dof: 3, value: 2.0 }];
    step.control.initial_increment = 1.0;
    step.control.max_increment = 1.0;
    (p, step)
}

#[test]
fn relaxed_blocks_reach_the_same_equilibrium_in_fewer_global_iterations() {
    let run = |relax: bool| {
        let (mut p, step) = hanging_string();
        if relax {
            // All of node 2's DOFs: its held z is left out by the solver.
            p.set_relaxation_blocks(vec![vec![6, 7, 8]]);
        }
        let mut rec = Recorder::default();
        p.run_step(&step, &mut rec).unwrap();
        // A relaxed iteration that takes the full step evaluates once, where it ends (with
        // the tangent, for Newton): no residual-only evaluation at an unrelaxed trial point.
        if relax {
            assert!(rec.iterations.iter().all(|r| r.line_search == 1.0));
            assert_eq!(p.timings().residual_evaluations, 0);
        }
        (p.u().to_vec(), rec.iterations, p.relaxation_stats())
    };
    let (plain, plain_iterations, none) = run(false);
    let (relaxed, iterations, stats) = run(true);
    // With BFGS the updates act on the condensed problem: the same equilibrium.
    let (mut p, mut step) = hanging_string();
    p.set_relaxation_blocks(vec![vec![6, 7, 8]]);
    step.control.convergence.method = IterationMethod::Bfgs { max_updates: 10 };
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();
    // BFGS evaluates residuals only: one per iteration (two before, when every relaxed
    // iteration also evaluated its unrelaxed trial point).
    assert!(rec.iterations.iter().all(|r| r.line_search == 1.0));
    assert_eq!(p.timings().residual_evaluations, rec.iterations.len());
    // Each factorisation is reported once, on the iteration whose correction it solved.
    let reformed = rec.iterations.iter().filter(|r| r.reformed).count();
    assert!(rec.iterations[0].reformed);
    assert_eq!(reformed, p.timings().factorizations);
    let quasi = p.u().to_vec();
    // Closed form: node 2 on the axis midway, string tension (2 + u1)/2 - 0.8, and node 1
    // in balance: 2 = 10 u1 + (2 + u1)/2 - 0.8, so u1 = 1.8 / 10.5.
    let u1 = 1.8 / 10.5;
    for u in [&plain, &relaxed, &quasi] {
        assert!((u[3] - u1).abs() < 1e-9, "u1 {}", u[3]);
        assert!(
            (u[6] - (u1 / 2.0)).abs() < 1e-9 && (u[7] + 0.6).abs() < 1e-9,
            "{u:?}"
        );
        assert_eq!(u[8], 0.0);
    }
    assert_eq!(none.solves, 0);
    assert!(stats.solves > 0 && stats.undone == 0, "{stats:?}");
    assert!(
        iterations.len() < plain_iterations.len(),
        "{} global iterations relaxed, {} without",
        iterations.len(),
        plain_iterations.len()
    );
    // After every global update the block is in equilibrium, so what is left of the
    // residual sits on node 1: the global iteration is Newton on the condensed problem.
    // The last iterations converge quadratically.
    let ratios: Vec<f64> = iterations.iter().map(|r| r.residual_ratio).collect();
    for w in ratios.windows(2).filter(|w| w[0] < 1e-2 && w[1] > 0.0) {
        assert!(w[1] < 10.0 * w[0] * w[0], "not quadratic: {ratios:?}");
    }
}

#[test]
fn a_relaxed_full_step_that_fails_the_line_search_is_put_back_and_searched() {
    // Node 0's x on a support whose force atan(u³) + 0.1 u stiffens and then saturates, node
    // 1 hanging from it by a unit spring along x (relaxed as a block, or not): at 1.4 nN
    // both sit at the root u* ≈ 1.45. The predictor (stiffness 0.1 at u = 0) throws node 0
    // to u = 14, where the support is flat again, so Newton's next correction lands at
    // u ≈ -1.7, where δ·R is larger than before: the full step is rejected and the line
    // search (secant steps from the start state) takes over.
    let law = |u: f64, _| {
        let u3 = u.powi(3);
        (
            u3.atan() + 0.1 * u,
            3.0 * u * u / (1.0 + u3 * u3) + 0.1,
            0.0,
        )
    };
    let root = {
        let (mut lo, mut hi) = (0.0f64, 3.0f64);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if law(mid, false).0 < 1.4 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    let run = |relax: bool| {
        let nodes = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let terms: Vec<Box<dyn Term>> = vec![
            Box::new(OneDofSupport { law }),
            Box::new(springs(&nodes, &[[0, 1]], 1.0)),
        ];
        let mut p = Problem::new(
            DofMap::translational(nodes.len()),
            terms,
            Box::new(DenseSolver::default()),
        )
        .unwrap();
        if relax {
            p.set_relaxation_blocks(vec![vec![3, 4, 5]]);
        }
        let mut step = Step::new("load");
        step.prescribed = [1, 2, 4, 5]
            .into_iter()
            .map(|d| (d, Motion::Hold))
            .collect();
        step.loads = vec![NodalLoad { dof: 0, value: 1.4 }];
        step.control.initial_increment = 1.0;
        step.control.max_increment = 1.0;
        // A strict test: the full step must cut δ·R to a tenth.
        step.control.convergence.line_search_threshold = 0.1;
        let mut rec = Recorder::default();
        p.run_step(&step, &mut rec).unwrap();
        (p.u().to_vec(), rec, p.timings().residual_evaluations)
    };
    let (plain, plain_rec, plain_evaluations) = run(false);
    let (relaxed, rec, evaluations) = run(true);
    for u in [&plain, &relaxed] {
        assert!(
            (u[0] - root).abs() < 1e-6 && (u[3] - root).abs() < 1e-6,
            "{u:?} root {root}"
        );
    }
    assert_eq!(plain_rec.cutbacks + rec.cutbacks, 0);
    // Without relaxation every Newton iteration after the predictor evaluates its trial
    // point once; more means the line search ran.
    assert!(plain_evaluations > plain_rec.iterations.len() - 1);
    // With it, an iteration whose relaxed full step passes evaluates no residual alone:
    // any residual-only evaluation is the line search after a full step was put back.
    assert!(evaluations > 0, "no full step was rejected");
}

/// A load on one DOF that appears at the first augmentation after `arm_after` committed
/// increments (as a contact status change adds a force late in an increment).
struct LateLoad {
    dof: usize,
    force: f64,
    arm_after: usize,
    commits: usize,
    on: bool,
}

impl Term for LateLoad {
    fn name(&self) -> &str {
        "late-load"
    }
    fn num_elements(&self) -> usize {
        1
    }
    fn element_dofs(&self, _e: usize, _m: &DofMap, dofs: &mut [usize]) -> usize {
        dofs[0] = self.dof;
        1
    }
    fn evaluate(
        &self,
        _e: usize,
        u: &[f64],
        r: &mut [f64],
        k: Option<&mut [f64]>,
    ) -> Result<f64, crate::element::KernelError> {
        let f = if self.on { self.force } else { 0.0 };
        r[0] = -f;
        if let Some(k) = k {
            k[0] = 0.0;
        }
        Ok(-f * u[0])
    }
    fn augment(&mut self, _u: &[f64], _m: &DofMap) -> crate::term::Augmentation {
        if !self.on && self.commits >= self.arm_after {
            self.on = true;
            crate::term::Augmentation::Updated("late load on".into())
        } else {
            crate::term::Augmentation::Settled
        }
    }
    fn commit(&mut self, _u: &[f64], _m: &DofMap) {
        self.commits += 1;
    }
}

/// An extrapolated start leaves an increment's first correction tiny; when an augmentation
/// later in the increment moves the body by far more, that round's energy criterion is
/// measured against its own first correction, not against the tiny start (which would ask
/// for an energy ratio many orders below what the residual criterion needs).
#[test]
fn a_round_after_a_late_augmentation_measures_energy_against_its_own_start() {
    let late = LateLoad {
        dof: 4,
        force: 2.0,
        arm_after: 4,
        commits: 0,
        on: false,
    };
    let (mut p, mut step) = large_rotation_spring_with(vec![Box::new(late)]);
    step.loads = vec![
        NodalLoad { dof: 3, value: 4.0 },
        NodalLoad { dof: 4, value: 6.0 },
    ];
    step.control.initial_increment = 0.1;
    step.control.max_increment = 0.1;
    step.control.extrapolation = Extrapolation::Linear;
    step.control.convergence.chord_near_convergence = false;
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();
    // Equilibrium under (4, 6 + 2): the spring along the load, N = |F| = k (l - 0.8).
    let f = (4.0f64 * 4.0 + 8.0 * 8.0).sqrt();
    let l = 0.8 + f / 10.0;
    let (x, y) = (1.0 + p.u()[3], p.u()[4]);
    assert!(
        (x - l * 4.0 / f).abs() < 1e-9 && (y - l * 8.0 / f).abs() < 1e-9,
        "x {x} y {y}"
    );
    // Every iteration's energy ratio is measured against a correction at least as large
    // as its round's first: none exceeds 1 (against the increment's tiny first correction
    // the late round's first iterations had ratios far above 1).
    let worst = rec
        .iterations
        .iter()
        .map(|r| r.energy_ratio)
        .fold(0.0f64, f64::max);
    assert!(worst <= 1.0, "largest energy ratio {worst}");
}

#[test]
fn a_bfgs_increment_within_ten_iterations_grows_the_next() {
    // The large-rotation spring by BFGS from a small first increment: an increment that
    // converged within `easy_quasi_newton_iterations` (10) grows the next by `growth`, also
    // when it took more than full Newton's `easy_iterations` (5); the rule is exercised only
    // if some increment took 6-10 iterations, which is asserted too.
    let (mut p, mut step) = large_rotation_spring();
    step.control.initial_increment = 0.02;
    step.control.max_increment = 1.0;
    step.control.convergence.method = IterationMethod::Bfgs { max_updates: 10 };
    step.control.convergence.residual_tolerance = 1e-12;
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();
    assert_eq!(rec.cutbacks, 0);
    eprintln!("increments (end time, iterations): {:?}", rec.increments);
    let mut times = vec![0.0];
    times.extend(rec.increments.iter().map(|i| i.0));
    let dts: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    let mut between_easy_limits = 0;
    for i in 0..dts.len().saturating_sub(2) {
        let iterations = rec.increments[i].1;
        let expected = if iterations <= 10 {
            1.5 * dts[i]
        } else {
            dts[i]
        };
        assert!(
            (dts[i + 1] - expected).abs() < 1e-12,
            "increment {i}: {iterations} iterations, next {} against {expected}",
            dts[i + 1]
        );
        between_easy_limits += usize::from(iterations > 5 && iterations <= 10);
    }
    assert!(between_easy_limits > 0, "no increment took 6-10 iterations");
    assert!((1.0 + p.u()[3] - 1.04).abs() < 1e-7 && (p.u()[4] - 0.78).abs() < 1e-7);
}

/// One DOF on a saturating support, force atan(u): Newton from beyond |u| ≈ 1.39 diverges
/// with a bounded residual (below π/2 + the load), so only `max_iterations` or an overflow
/// ends it. The first tangent asked for within `trap` of `root` is scaled by 1e-5: a
/// correction that throws a nearly converged state far away, as a lost quasi-Newton
/// tangent did in the refined cell compression (docs/performance.md).
fn saturating_support_with_one_bad_tangent(root: f64, trap: f64) -> Box<dyn Term> {
    let sprung = std::sync::atomic::AtomicBool::new(false);
    Box::new(OneDofSupport {
        law: move |u: f64, tangent: bool| {
            let mut k = 1.0 / (1.0 + u * u);
            let near = (u - root).abs() < trap && (u - root).abs() > 1e-6;
            if tangent && near && !sprung.swap(true, std::sync::atomic::Ordering::Relaxed) {
                k *= 1e-5;
            }
            (u.atan(), k, u * u.atan() - 0.5 * (1.0 + u * u).ln())
        },
    })
}

#[test]
fn an_increment_whose_residual_rebounds_near_equilibrium_is_cut_at_once() {
    // Load 0.5 on atan(u): equilibrium at u = tan(0.5). Newton's third correction uses the
    // bad tangent and lands near u = 90, where atan saturates: the residual rises from
    // about 1e-3 to 1.06, above the first one (0.5). Without the rebound criterion the
    // attempt then wanders (|R| stays below 2.1, far from the 1e6-fold divergence limit)
    // until its corrections overflow (10 iterations); with it the attempt is cut at that
    // iteration. Both retry at half the increment and end at the same equilibrium.
    let run = |rebound_ratio: f64| {
        let terms = vec![saturating_support_with_one_bad_tangent(0.5f64.tan(), 1e-2)];
        let mut p = Problem::new(
            DofMap::with_counts(&[1]),
            terms,
            Box::new(DenseSolver::default()),
        )
        .unwrap();
        let mut step = Step::new("saturating");
        step.loads = vec![NodalLoad { dof: 0, value: 0.5 }];
        step.control.initial_increment = 1.0;
        step.control.max_increment = 1.0;
        step.control.convergence.chord_near_convergence = false;
        step.control.convergence.rebound_ratio = rebound_ratio;
        let mut rec = Recorder::default();
        p.run_step(&step, &mut rec).unwrap();
        let converged: usize = rec.increments.iter().map(|i| i.1).sum();
        let failed = rec.iterations.len() - converged;
        (p.u()[0], rec.cutbacks, failed)
    };
    let (u, cutbacks, failed) = run(Convergence::default().rebound_ratio);
    let (u_off, cutbacks_off, failed_off) = run(0.0);
    for x in [u, u_off] {
        assert!((x - 0.5f64.tan()).abs() < 1e-9, "{x}");
    }
    assert_eq!((cutbacks, cutbacks_off), (1, 1));
    assert!(failed <= 4, "the failed attempt took {failed} iterations");
    assert!(
        failed_off >= failed + 5,
        "without the criterion: {failed_off} iterations, with it {failed}"
    );
}

/// Refuses (as an inverted element would) any state whose DOF `dof` moved more than
/// `max_jump` from its last committed value: an increment longer than that fails.
struct LongStepRefuser {
    dof: usize,
    max_jump: f64,
    committed: f64,
}

impl Term for LongStepRefuser {
    fn name(&self) -> &str {
        "long-step-refuser"
    }
    fn num_elements(&self) -> usize {
        1
    }
    fn element_dofs(&self, _e: usize, _dof_map: &DofMap, dofs: &mut [usize]) -> usize {
        dofs[0] = self.dof;
        1
    }
    fn evaluate(
        &self,
        _e: usize,
        u_e: &[f64],
        _residual: &mut [f64],
        _tangent: Option<&mut [f64]>,
    ) -> Result<f64, crate::element::KernelError> {
        if (u_e[0] - self.committed).abs() > self.max_jump {
            return Err(crate::element::KernelError::InvertedElement { qp: 0, det_f: -1.0 });
        }
        Ok(0.0)
    }
    fn commit(&mut self, u: &[f64], _dof_map: &DofMap) {
        self.committed = u[self.dof];
    }
}

/// The chain's end pulled by 1 µm in increments starting at `initial` (growth 1.5,
/// cut-back `cutback`), increments moving the end by more than `max_jump` refused.
fn pull_chain_in_increments(initial: f64, cutback: f64, max_jump: f64) -> Recorder {
    let terms: Vec<Box<dyn Term>> = vec![
        Box::new(springs(&CHAIN, &[[0, 1], [1, 2], [2, 3]], 2.0)),
        Box::new(LongStepRefuser {
            dof: 9,
            max_jump,
            committed: 0.0,
        }),
    ];
    let mut p = Problem::new(
        DofMap::translational(4),
        terms,
        Box::new(DenseSolver::default()),
    )
    .unwrap();
    let mut step = pull_end_step("pull");
    step.control.initial_increment = initial;
    step.control.max_increment = 1.0;
    step.control.cutback = cutback;
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();
    assert!(
        (p.reaction(9) - 2.0 / 3.0).abs() < 1e-10,
        "{}",
        p.reaction(9)
    );
    rec
}

fn increment_ends(rec: &Recorder) -> Vec<f64> {
    rec.increments.iter().map(|i| i.0).collect()
}

#[test]
fn an_increment_within_one_growth_of_the_step_end_goes_to_the_end() {
    // 0.35, then 0.525 would leave 0.125: the second increment takes the rest (0.65 ≤
    // 1.5 × 0.525) instead of leaving a sliver for a third.
    let rec = pull_chain_in_increments(0.35, 0.5, f64::INFINITY);
    let ends = increment_ends(&rec);
    assert_eq!(rec.cutbacks, 0);
    assert_eq!(ends.len(), 2, "{ends:?}");
    assert!((ends[0] - 0.35).abs() < 1e-12 && (ends[1] - 1.0).abs() < 1e-12);
}

#[test]
fn a_cut_back_increment_is_not_stretched_back_to_the_size_that_failed() {
    // Increments moving the end by more than 0.35 µm are refused; cut-back 0.8. 0.3
    // passes, 0.45 and 0.36 are refused, 0.288 passes (t = 0.588). The next, grown to
    // 0.432, is stretched to the rest (0.412) and refused; its retry, 0.3296, lies within
    // one growth of the end too, but stretched it would be the refused 0.412 again, and
    // again after every cut: it stays 0.3296, and the last 0.0824 follows.
    let rec = pull_chain_in_increments(0.3, 0.8, 0.35);
    let ends = increment_ends(&rec);
    assert_eq!(rec.cutbacks, 3, "{ends:?}");
    let expected = [0.3, 0.588, 0.9176, 1.0];
    assert_eq!(ends.len(), expected.len(), "{ends:?}");
    for (end, want) in ends.iter().zip(expected) {
        assert!((end - want).abs() < 1e-12, "{ends:?}");
    }
}

/// [`swing`] in increments of `dt` from extrapolated starts, full Newton: the iteration
/// reports of each increment.
fn swing_in_small_increments(dt: f64) -> Vec<Vec<IterationReport>> {
    let mut rec = Recorder::default();
    swing(dt, Extrapolation::Linear, true, &mut rec);
    let mut increments: Vec<Vec<IterationReport>> = Vec::new();
    for r in &rec.iterations {
        if r.iteration == 0 {
            increments.push(Vec::new());
        }
        increments.last_mut().unwrap().push(*r);
    }
    assert_eq!(increments.len(), rec.increments.len());
    increments
}

/// From an extrapolated start the first correction can leave the residual within the chord
/// window, already contracted far below the start's: the rest of the increment is chord
/// steps on that factorisation, one factorisation per increment instead of two (the
/// suspended tension's stretch: 31 -> 23 factorisations).
#[test]
fn an_extrapolated_increment_finishes_on_its_first_factorisation() {
    let window = CHORD_WINDOW * Convergence::default().residual_tolerance;
    let increments = swing_in_small_increments(0.05);
    let mut finished = 0;
    for (k, inc) in increments.iter().enumerate().skip(1) {
        if inc[0].residual_ratio <= window {
            let factorizations = inc.iter().filter(|r| r.reformed).count();
            assert_eq!(factorizations, 1, "increment {k}: {inc:?}");
            assert!(inc[1..].iter().all(|r| r.chord), "increment {k}: {inc:?}");
            finished += 1;
        }
    }
    assert!(finished >= 10, "{finished} of {}", increments.len());
}

/// Records the energy criterion's reference of each converged increment.
#[derive(Default)]
struct EnergyReferences(Vec<f64>);

impl Observer for EnergyReferences {
    fn on_increment(&mut self, problem: &Problem, _report: &IncrementReport<'_>) {
        self.0.push(problem.work.increment_energy);
    }
}

/// The energy criterion of an extrapolated increment is measured against the work a
/// converged start's first correction would have done (the last increment's, scaled by the
/// square of the increments' ratio), not against the extrapolation's error, which is
/// orders of magnitude smaller: against that, the criterion asked for digits far below the
/// residual criterion's (the suspended tension's stretch spent a chord step per increment
/// on them).
#[test]
fn an_extrapolated_increment_measures_energy_against_a_converged_starts_scale() {
    let references = |extrapolation: Extrapolation| {
        let mut rec = EnergyReferences::default();
        swing(0.05, extrapolation, true, &mut rec);
        rec.0
    };
    let converged = references(Extrapolation::None);
    let extrapolated = references(Extrapolation::Linear);
    assert_eq!(converged.len(), 20);
    assert_eq!(extrapolated.len(), 20);
    assert_eq!(converged[0], extrapolated[0]);
    for k in 1..20 {
        let ratio = extrapolated[k] / converged[k];
        assert!(
            (0.2..=5.0).contains(&ratio),
            "increment {k}: {extrapolated:?} against {converged:?}"
        );
    }
}
