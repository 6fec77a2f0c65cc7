//! Viscous stabilisation verified on the snap-through of a shallow two-bar (von Mises)
//! truss under a dead load, whose equilibrium path and limit load are known in closed form.
//!
//! Two bars from the supports (∓a, 0) meet at the apex (0, h). With the truss law
//! `N = EA (ℓ/L0 − 1)` (`material::axial`), the downward apex load that holds the apex at
//! height y is
//!
//! ```text
//! P(y) = 2 EA y (1/ℓ − 1/L0),   ℓ = √(a² + y²),  L0 = √(a² + h²)
//! ```
//!
//! `dP/dy = 0` at `ℓ³ = a² L0`: the limit load `P_max = P(y_lim)`, `y_lim = √(ℓ² − a²)`.
//! Past it the load-controlled structure snaps to the inverted branch `y < −h` (bars in
//! tension), where `P(y)` rises again. With stabilisation the solve must (1) follow the
//! stable branch up to the limit load, (2) snap there (within one load increment, 1 % of
//! `P_max`) and not earlier, (3) end the step on the inverted branch in exact equilibrium,
//! and report the energy it dissipated. Without stabilisation the same increments stall at
//! the limit load. (With increments ten times larger, full Newton with the line search can
//! jump to the far branch of this one-DOF structure; it cannot be relied on to.)

use cellmech_fem::dof::DofMap;
use cellmech_fem::element::truss::TrussSet;
use cellmech_fem::linsolve::DenseSolver;
use cellmech_fem::material::AxialLaw;
use cellmech_fem::solve::{
    Activation, Damping, IncrementReport, Motion, NodalLoad, Observer, Problem, Stabilization,
    StabilizationReport, Step,
};

const A: f64 = 1.0;
const H: f64 = 0.1;
const EA: f64 = 100.0;
/// The apex's vertical DOF (node 2, component y).
const APEX_Y: usize = 7;

fn l0() -> f64 {
    (A * A + H * H).sqrt()
}

/// Downward apex load in equilibrium with the apex at height `y`.
fn load_at(y: f64) -> f64 {
    2.0 * EA * y * (1.0 / (A * A + y * y).sqrt() - 1.0 / l0())
}

/// (y_lim, P_max): the limit point.
fn limit_point() -> (f64, f64) {
    let l = (A * A * l0()).cbrt();
    let y = (l * l - A * A).sqrt();
    (y, load_at(y))
}

/// The apex height on the inverted branch (y < −h) that carries load `p`, by bisection.
fn inverted_branch(p: f64) -> f64 {
    let (mut lo, mut hi) = (-10.0, -H);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        // On y < −h the load falls from +large (y → −∞) to 0 (y = −h).
        if load_at(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[derive(Default)]
struct Path {
    /// (step time, apex height, stabilisation report)
    points: Vec<(f64, f64, Option<StabilizationReport>)>,
}

impl Observer for Path {
    fn on_increment(&mut self, problem: &Problem, report: &IncrementReport<'_>) {
        self.points.push((
            report.step_time,
            H + problem.u()[APEX_Y],
            report.stabilization,
        ));
    }
}

fn truss() -> Problem {
    let x = [[-A, 0.0, 0.0], [A, 0.0, 0.0], [0.0, H, 0.0]];
    let law = AxialLaw::linear(EA, 1.0);
    let bars = TrussSet::new("bars", "strut", &x, vec![[0, 2], [1, 2]], law).unwrap();
    Problem::new(
        DofMap::translational(3),
        vec![Box::new(bars)],
        Box::new(DenseSolver::default()),
    )
    .unwrap()
}

/// Load the apex down to `p`, supports and the apex's x/z held.
fn load_step(p: f64, stabilization: Option<Stabilization>) -> Step {
    let mut step = Step::new("load");
    step.prescribed = [0, 1, 2, 3, 4, 5, 6, 8]
        .iter()
        .map(|&d| (d, Motion::Hold))
        .collect();
    step.loads = vec![NodalLoad {
        dof: APEX_Y,
        value: -p,
    }];
    step.control.initial_increment = 0.005;
    step.control.max_increment = 0.005;
    step.control.min_increment = 1e-4;
    step.control.stabilization = stabilization;
    step
}

#[test]
fn full_newton_stalls_at_the_limit_load() {
    let (y_lim, p_max) = limit_point();
    let target = 2.0 * p_max;
    let mut p = truss();
    let mut path = Path::default();
    let result = p.run_step(&load_step(target, None), &mut path);
    assert!(
        result.is_err(),
        "load control passed the limit point unaided"
    );
    // It got to the limit load and no further, on the near branch.
    let &(t, y, _) = path.points.last().unwrap();
    assert!(y > y_lim);
    assert!(
        t * target <= p_max * (1.0 + 1e-9) && t * target > 0.99 * p_max,
        "stopped at {t}"
    );
}

#[test]
fn stabilised_load_control_snaps_through_at_the_limit_load() {
    let (y_lim, p_max) = limit_point();
    let target = 2.0 * p_max;
    let mut p = truss();
    let mut path = Path::default();
    p.run_step(
        &load_step(target, Some(Stabilization::default())),
        &mut path,
    )
    .expect("the stabilised step passes the snap-through");

    // (1) The stable branch before the limit point is the equilibrium path.
    let mut worst_on_branch = 0.0f64;
    for &(t, y, _) in path.points.iter().filter(|&&(_, y, _)| y > y_lim) {
        let error = (load_at(y) - t * target).abs() / p_max;
        worst_on_branch = worst_on_branch.max(error);
    }
    assert!(
        worst_on_branch < 1e-3,
        "near branch off the equilibrium path by {worst_on_branch:.2e} P_max"
    );
    // (2) The snap happens at the limit load: no state short of the snap carries more than
    // P_max, and the first state past it was reached within one increment (1 % of P_max)
    // beyond P_max.
    let near_max = path
        .points
        .iter()
        .filter(|&&(_, y, _)| y > y_lim)
        .map(|&(t, _, _)| t * target)
        .fold(0.0f64, f64::max);
    let snapped_at = path
        .points
        .iter()
        .find(|&&(_, y, _)| y < y_lim)
        .map(|&(t, _, _)| t * target)
        .expect("the apex snapped");
    assert!(
        near_max <= p_max * (1.0 + 1e-3),
        "held {near_max} > P_max {p_max}"
    );
    assert!(
        snapped_at >= p_max && snapped_at <= 1.0101 * p_max,
        "snapped at {snapped_at}, P_max {p_max}"
    );
    // (3) The step ends on the inverted branch, in equilibrium without viscosity.
    let &(t, y, report) = path.points.last().unwrap();
    assert_eq!(t, 1.0);
    let expected = inverted_branch(target);
    assert!(
        (y - expected).abs() <= 1e-8 * A,
        "final apex {y}, expected {expected}"
    );
    let report = report.expect("a stabilised step reports its dissipation");
    assert!(report.equilibrated);
    assert_eq!(report.viscous_force_ratio, 0.0);
    // The snap dissipates energy; it is reported.
    assert!(report.step_dissipated > 0.0);
    eprintln!(
        "P_max {p_max:.5}, snapped at {:.4} P_max, near-branch error {worst_on_branch:.2e}, \
         dissipated {:.3e} nN·µm ({:.3} of the strain energy), {} increments",
        snapped_at / p_max,
        report.step_dissipated,
        report.dissipated_fraction,
        path.points.len()
    );
}

#[test]
fn stabilisation_leaves_a_stable_answer_unchanged_and_dissipates_little() {
    // Half the limit load: no instability. The stabilised step must end at the exact
    // equilibrium of the near branch and dissipate a tiny fraction of the strain energy.
    let (y_lim, p_max) = limit_point();
    let target = 0.5 * p_max;
    let mut p = truss();
    let mut path = Path::default();
    p.run_step(
        &load_step(target, Some(Stabilization::default())),
        &mut path,
    )
    .unwrap();
    let &(_, y, report) = path.points.last().unwrap();
    assert!(y > y_lim);
    assert!((load_at(y) - target).abs() <= 1e-8 * p_max);
    let report = report.unwrap();
    assert!(report.equilibrated);
    assert!(
        report.dissipated_fraction < Stabilization::default().accuracy_tolerance,
        "dissipated {} of the strain energy",
        report.dissipated_fraction
    );
}

#[test]
fn invalid_stabilisation_settings_are_rejected_with_the_field_named() {
    let mut p = truss();
    let settings = Stabilization {
        energy_fraction: -1.0,
        ..Stabilization::default()
    };
    let error = p
        .run_step(&load_step(1.0, Some(settings)), &mut Path::default())
        .unwrap_err()
        .to_string();
    assert!(error.contains("energy_fraction"), "{error}");
}

#[test]
fn on_difficulty_is_exact_until_the_limit_point_then_snaps_through() {
    // Switched on at the first failure only: up to the limit load the path is bit for bit
    // the unstabilised one; then the step passes the snap and ends in equilibrium.
    let (y_lim, p_max) = limit_point();
    let target = 2.0 * p_max;
    let mut plain = Path::default();
    let _ = truss().run_step(&load_step(target, None), &mut plain);
    let settings = Stabilization {
        activation: Activation::OnDifficulty,
        ..Stabilization::default()
    };
    let mut path = Path::default();
    truss()
        .run_step(&load_step(target, Some(settings)), &mut path)
        .expect("passes the snap");
    let before: Vec<(f64, f64)> = plain.points.iter().map(|&(t, y, _)| (t, y)).collect();
    let same: Vec<(f64, f64)> = path.points[..before.len()]
        .iter()
        .map(|&(t, y, _)| (t, y))
        .collect();
    assert_eq!(before, same);
    assert!(path.points[..before.len()]
        .iter()
        .all(|(_, _, r)| r.is_some_and(|r| r.factor == 0.0)));
    let &(t, y, report) = path.points.last().unwrap();
    assert_eq!(t, 1.0);
    assert!(y < y_lim);
    assert!((y - inverted_branch(target)).abs() <= 1e-8 * A);
    assert!(report.unwrap().equilibrated);
}

#[test]
fn a_stabilised_step_without_an_equilibrium_at_its_end_fails_instead_of_reporting_it() {
    // A bar free to slide along its axis (only its transverse motion held) and pulled
    // along it: a rigid-body mechanism with no equilibrium, so only the viscosity can carry
    // the load. The step must not end as if it had converged.
    let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
    let bar = TrussSet::new("bar", "strut", &x, vec![[0, 1]], AxialLaw::linear(EA, 1.0)).unwrap();
    let mut p = Problem::new(
        DofMap::translational(2),
        vec![Box::new(bar)],
        Box::new(DenseSolver::default()),
    )
    .unwrap();
    let mut step = Step::new("pull a free bar");
    step.prescribed = [1, 2, 4, 5].iter().map(|&d| (d, Motion::Hold)).collect();
    step.loads = vec![NodalLoad { dof: 3, value: 1.0 }];
    step.control.stabilization = Some(Stabilization::default());
    let mut times = Times::default();
    let error = p.run_step(&step, &mut times).unwrap_err();
    // The viscosity carries it through the step, but the end is no equilibrium.
    assert!(
        matches!(
            error,
            cellmech_fem::solve::SolveError::NotEquilibrated { viscous_force_ratio, .. }
                if viscous_force_ratio > 0.5
        ),
        "{error}"
    );
    // Nothing past the last equilibrium was reported as converged at the step's end.
    assert!(times.0.iter().all(|&t| t < 1.0), "{:?}", times.0);
}

/// Step times of the converged increments.
#[derive(Default)]
struct Times(Vec<f64>);

impl Observer for Times {
    fn on_increment(&mut self, _problem: &Problem, report: &IncrementReport<'_>) {
        self.0.push(report.step_time);
    }
}

#[test]
fn a_step_whose_re_solve_fails_relaxes_at_its_final_load_into_the_equilibrium() {
    // The whole load, twice the limit load, in one heavily damped increment (c = 10, so
    // the viscosity is ten times the tangent's diagonal): the damped state stays near the
    // start, far from the only equilibrium (the inverted branch), and Newton without
    // viscosity cannot get there within 5 iterations. Relaxation increments at the final
    // load must carry it there; without them the step fails.
    let target = 2.0 * limit_point().1;
    let step = |relaxations: usize| {
        let settings = Stabilization {
            factor: Some(10.0),
            end_relaxation_increments: relaxations,
            ..Stabilization::default()
        };
        let mut step = load_step(target, Some(settings));
        step.control.initial_increment = 1.0;
        step.control.max_increment = 1.0;
        step.control.convergence.max_iterations = 5;
        step
    };
    let error = truss()
        .run_step(&step(0), &mut Path::default())
        .unwrap_err();
    assert!(
        matches!(
            error,
            cellmech_fem::solve::SolveError::NotEquilibrated { viscous_force_ratio, .. }
                if viscous_force_ratio > 0.1
        ),
        "{error}"
    );
    let mut path = Path::default();
    truss()
        .run_step(&step(20), &mut path)
        .expect("relaxes into the equilibrium");
    let &(t, y, report) = path.points.last().unwrap();
    let report = report.unwrap();
    assert_eq!(t, 1.0);
    assert!((y - inverted_branch(target)).abs() <= 1e-9 * A, "{y}");
    assert!(report.equilibrated);
    assert_eq!(report.viscous_force_ratio, 0.0);
    // The relaxation's dissipation is booked: the snap releases energy a static model can
    // only dissipate, of the order of the strain energy at the end.
    assert!(report.increment_dissipated > 0.0);
}

#[test]
fn relative_damping_without_relative_motions_is_the_nodal_viscosity() {
    // The truss has no tied fibres: `Damping::Relative` would damp nothing, so the step gets
    // the nodal viscosity, and the snap-through is the same to the last bit.
    let target = 2.0 * limit_point().1;
    let run = |damping| {
        let mut p = truss();
        let mut path = Path::default();
        let settings = Stabilization {
            damping,
            ..Stabilization::default()
        };
        p.run_step(&load_step(target, Some(settings)), &mut path)
            .expect("the stabilised step passes the snap-through");
        path.points
    };
    let nodal = run(Damping::Nodal);
    let relative = run(Damping::Relative);
    assert_eq!(nodal.len(), relative.len());
    for (a, b) in nodal.iter().zip(&relative) {
        assert_eq!((a.0, a.1), (b.0, b.1));
        assert_eq!(a.2, b.2);
    }
}
