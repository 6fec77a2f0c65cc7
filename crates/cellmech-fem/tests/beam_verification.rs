//! Verification of the corotational beam through the nonlinear solver (`Problem`/`Step`
//! with load stepping): Euler buckling loads, the large-deflection elastica, a curved
//! cantilever against Castigliano, rigid rotations past 180° and back, and the spec's
//! microtubule numbers.

use cellmech_fem::dof::DofMap;
use cellmech_fem::element::beam::{BeamSection, BeamSet, LocalStrain};
use cellmech_fem::linsolve::DenseSolver;
use cellmech_fem::math::rotation::exp_so3;
use cellmech_fem::solve::{Motion, NodalLoad, NullObserver, Problem, Step, StepControl};
use cellmech_fem::term::Term;
use std::f64::consts::PI;

/// A model of beams on `coords` (all nodes with 6 DOFs).
fn model(coords: &[[f64; 3]], pairs: &[[usize; 2]], section: BeamSection) -> Problem {
    model_with(coords, pairs, section, LocalStrain::default())
}

fn model_with(
    coords: &[[f64; 3]],
    pairs: &[[usize; 2]],
    section: BeamSection,
    strain: LocalStrain,
) -> Problem {
    let mut set = BeamSet::from_coordinates(
        "filament",
        "microtubule",
        coords,
        pairs,
        Some([0.0, 0.0, 1.0]),
        section,
    )
    .unwrap();
    set.local_strain = strain;
    let mut counts = vec![3; coords.len()];
    set.mark_rotational_nodes(&mut counts).unwrap();
    let dof_map = DofMap::with_counts(&counts);
    set.check_dof_map(&dof_map).unwrap();
    let terms: Vec<Box<dyn Term>> = vec![Box::new(set)];
    Problem::new(dof_map, terms, Box::new(DenseSolver::default())).unwrap()
}

/// Straight filament along x from 0 to `length` in `n` elements.
fn straight(n: usize, length: f64) -> (Vec<[f64; 3]>, Vec<[usize; 2]>) {
    let coords = (0..=n)
        .map(|i| [length * i as f64 / n as f64, 0.0, 0.0])
        .collect();
    let pairs = (0..n).map(|i| [i, i + 1]).collect();
    (coords, pairs)
}

/// Section with bending stiffness `ei` about both axes and a very stiff axis (EA L²/EI =
/// 1e6, like a microtubule's 4.5e6), so axial shortening does not shift the buckling load.
fn section(ei: f64, length: f64) -> BeamSection {
    let e = 1.0e3;
    let i = ei / e;
    BeamSection::new(e, e / 2.6, 1e6 * i / (length * length), i, i, 2.0 * i).unwrap()
}

fn hold(step: &mut Step, node: usize, components: &[usize]) {
    for &c in components {
        step.prescribed.push((6 * node + c, Motion::Hold));
    }
}

fn control(max_increment: f64) -> StepControl {
    let mut c = StepControl::default();
    c.initial_increment = max_increment;
    c.max_increment = max_increment;
    c.min_increment = 1e-6;
    c
}

#[derive(Clone, Copy, PartialEq)]
enum Support {
    ClampedFree,
    PinnedPinned,
}

/// Whether a perfect column under axial compression `p` is unstable: the tangent at the
/// converged (straight) state has a negative eigenvalue, reported by the linear solver.
fn column_is_unstable(support: Support, strain: LocalStrain, n: usize, p: f64) -> bool {
    let (length, ei) = (LENGTH, EI);
    let (coords, pairs) = straight(n, length);
    let mut problem = model_with(&coords, &pairs, section(ei, length), strain);
    let mut step = Step::new("compress");
    match support {
        Support::ClampedFree => hold(&mut step, 0, &[0, 1, 2, 3, 4, 5]),
        Support::PinnedPinned => {
            hold(&mut step, 0, &[0, 1, 2, 3]);
            hold(&mut step, n, &[1, 2]);
        }
    }
    step.loads = vec![NodalLoad {
        dof: 6 * n,
        value: -p * (1.0 - 1e-7),
    }];
    step.control = control(1.0);
    problem.run_step(&step, &mut NullObserver).unwrap();
    // A second, tiny step factorises the tangent at (almost exactly) the loaded state.
    step.name = "to p".into();
    step.loads[0].value = -p;
    problem.run_step(&step, &mut NullObserver).unwrap();
    // Straight and uniformly compressed: N = −p exactly.
    let shortening = -problem.u()[6 * n];
    let ea = section(ei, length).axial_stiffness();
    assert!((shortening - p * length / ea).abs() < 1e-9 * shortening.abs().max(1e-12));
    problem.last_factor().unwrap().negative_pivots.unwrap() > 0
}

/// Critical load by bisection on the sign of the tangent's lowest eigenvalue.
fn critical_load(support: Support, strain: LocalStrain, n: usize, guess: f64) -> f64 {
    let (mut lo, mut hi) = (0.5 * guess, 1.5 * guess);
    assert!(!column_is_unstable(support, strain, n, lo));
    assert!(column_is_unstable(support, strain, n, hi));
    while hi - lo > 1e-5 * guess {
        let mid = 0.5 * (lo + hi);
        if column_is_unstable(support, strain, n, mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

const LENGTH: f64 = 2.0;
const EI: f64 = 3.0;

#[test]
fn beam_euler_buckling_loads_from_the_tangent_inertia_match_within_one_percent() {
    let cantilever = PI * PI * EI / (4.0 * LENGTH * LENGTH);
    let pinned = PI * PI * EI / (LENGTH * LENGTH);
    let cases = [
        ("clamped-free", Support::ClampedFree, 10, cantilever),
        ("pinned-pinned", Support::PinnedPinned, 16, pinned),
    ];
    for (name, support, n, exact) in cases {
        let found = critical_load(support, LocalStrain::ShallowArch, n, exact);
        let chord = critical_load(support, LocalStrain::Chord, n, exact);
        eprintln!(
            "{name}, {n} elements: P_cr/exact = {:.5} (shallow arch), {:.5} (chord strain)",
            found / exact,
            chord / exact
        );
        assert!(
            (found / exact - 1.0).abs() < 0.01,
            "{name}: {found} vs {exact}"
        );
        // The chord-strain element converges from above and is visibly worse.
        assert!(
            chord > found && chord / exact - 1.0 < 0.05,
            "{name}: chord {chord}"
        );
    }
}

/// The planar elastica of a cantilever (clamped at s = 0) under a transverse tip load,
/// θ″ = −k cos θ, θ(0) = 0, θ′(1) = 0, k = PL²/EI, solved by shooting on θ′(0) with RK4.
/// Returns the tip deflections (δ_v/L, δ_h/L).
fn elastica(k: f64) -> (f64, f64) {
    let steps = 4000;
    let h = 1.0 / steps as f64;
    // state: θ, θ′, x, y
    let shoot = |m: f64| {
        let f = |s: [f64; 4]| [s[1], -k * s[0].cos(), s[0].cos(), s[0].sin()];
        let mut s = [0.0, m, 0.0, 0.0];
        for _ in 0..steps {
            let k1 = f(s);
            let k2 = f(std::array::from_fn(|i| s[i] + 0.5 * h * k1[i]));
            let k3 = f(std::array::from_fn(|i| s[i] + 0.5 * h * k2[i]));
            let k4 = f(std::array::from_fn(|i| s[i] + h * k3[i]));
            s = std::array::from_fn(|i| {
                s[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            });
        }
        s
    };
    let (mut lo, mut hi) = (0.0, k);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if shoot(mid)[1] < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let s = shoot(0.5 * (lo + hi));
    (s[3], 1.0 - s[2])
}

#[test]
fn beam_elastica_shooting_reference_reproduces_the_classical_tables() {
    // Bisshopp & Drucker (1945) / Mattiasson (1981): PL²/EI = 1 and 10.
    let (v, h) = elastica(1.0);
    assert!(
        (v - 0.30172).abs() < 2e-4 && (h - 0.05643).abs() < 2e-4,
        "{v} {h}"
    );
    let (v, h) = elastica(10.0);
    assert!(
        (v - 0.81061).abs() < 2e-4 && (h - 0.55500).abs() < 2e-4,
        "{v} {h}"
    );
}

#[test]
fn beam_large_deflection_cantilever_matches_the_elastica_within_one_percent() {
    let (n, length, ei) = (20, 1.5, 0.7);
    let (coords, pairs) = straight(n, length);
    let mut problem = model(&coords, &pairs, section(ei, length));
    let mut step = Step::new("clamp");
    hold(&mut step, 0, &[0, 1, 2, 3, 4, 5]);
    for node in 1..=n {
        hold(&mut step, node, &[2, 3, 4]); // planar problem in x–y
    }
    step.control = control(0.1);
    for k in [1.0, 2.0, 5.0, 10.0] {
        step.name = format!("tip load PL²/EI = {k}");
        step.loads = vec![NodalLoad {
            dof: 6 * n + 1,
            value: k * ei / (length * length),
        }];
        problem.run_step(&step, &mut NullObserver).unwrap();
        let (v, h) = elastica(k);
        let fe_v = problem.u()[6 * n + 1] / length;
        let fe_h = -problem.u()[6 * n] / length;
        eprintln!("PL²/EI = {k}: δv/L {fe_v:.5} (elastica {v:.5}), δh/L {fe_h:.5} ({h:.5})");
        assert!((fe_v / v - 1.0).abs() < 0.01, "k {k}: δv/L {fe_v} vs {v}");
        assert!((fe_h / h - 1.0).abs() < 0.01, "k {k}: δh/L {fe_h} vs {h}");
        // The tip rotation equals the elastica's tip slope: tan θ = dy/dx at the end is
        // checked through the vertical deflection; its sign must be positive (counter-
        // clockwise about z) and below π/2.
        let tip_rotation = problem.u()[6 * n + 5];
        assert!(tip_rotation > 0.0 && tip_rotation < PI / 2.0);
    }
}

#[test]
fn beam_quarter_circle_cantilever_matches_castigliano_at_small_load() {
    // Arc of radius R from (R, 0) (clamped) to (0, R) (free), in 32 straight elements.
    // Free-end loads Fx (along the free end's tangent) and Fy (along the clamp's tangent):
    // Castigliano with bending energy only (EA very large):
    //   δx = (3π/4 − 2) Fx R³/EI + Fy R³/(2EI),   δy = Fx R³/(2EI) + (π/4) Fy R³/EI.
    let (n, radius, ei) = (32, 1.3, 0.5);
    let coords: Vec<[f64; 3]> = (0..=n)
        .map(|i| {
            let phi = PI / 2.0 * i as f64 / n as f64;
            [radius * phi.cos(), radius * phi.sin(), 0.0]
        })
        .collect();
    let pairs: Vec<[usize; 2]> = (0..n).map(|i| [i, i + 1]).collect();
    let c = radius.powi(3) / ei;
    // EA R²/EI = 1e4: axial shortening changes δ by ~1e-4 (Castigliano neglects it).
    let i = ei / 1e3;
    let sec = BeamSection::new(1e3, 1e3 / 2.6, 1e4 * i / (radius * radius), i, i, 2.0 * i).unwrap();
    let load = 1e-4 * ei / (radius * radius); // PR²/EI = 1e-4: linear regime
    for (fx, fy) in [(load, 0.0), (0.0, load)] {
        let mut problem = model(&coords, &pairs, sec);
        let mut step = Step::new("load");
        hold(&mut step, 0, &[0, 1, 2, 3, 4, 5]);
        step.loads = vec![
            NodalLoad {
                dof: 6 * n,
                value: fx,
            },
            NodalLoad {
                dof: 6 * n + 1,
                value: fy,
            },
        ];
        step.control = control(1.0);
        problem.run_step(&step, &mut NullObserver).unwrap();
        let dx = (3.0 * PI / 4.0 - 2.0) * fx * c + fy * c / 2.0;
        let dy = fx * c / 2.0 + PI / 4.0 * fy * c;
        let (ux, uy) = (problem.u()[6 * n], problem.u()[6 * n + 1]);
        eprintln!("quarter circle F = ({fx}, {fy}): δ = ({ux:.6e}, {uy:.6e}), Castigliano ({dx:.6e}, {dy:.6e})");
        assert!((ux / dx - 1.0).abs() < 0.01, "δx {ux} vs {dx}");
        assert!((uy / dy - 1.0).abs() < 0.01, "δy {uy} vs {dy}");
        assert!(problem.u()[6 * n + 2].abs() < 1e-12 * c, "out of plane");
    }
}

#[test]
fn beam_filament_turned_rigidly_past_180_degrees_and_back_keeps_zero_internal_force() {
    // A curved filament (5 elements along a helix-like curve); node 0 is turned about an
    // oblique axis through itself by 0 → 1.8 rad → 3.6 rad (206°) → 0; all other nodes are
    // free and unloaded, so they must follow rigidly with zero energy.
    let coords: Vec<[f64; 3]> = (0..6)
        .map(|i| {
            let t = i as f64 * 0.4;
            [t, 0.3 * t.sin(), 0.1 * t * t]
        })
        .collect();
    let pairs: Vec<[usize; 2]> = (0..5).map(|i| [i, i + 1]).collect();
    let sec = BeamSection::hollow_circular(1.2e6, 0.3, 0.025, 0.017).unwrap();
    let mut problem = model(&coords, &pairs, sec);
    let axis = {
        let a = [1.0, -2.0, 0.5];
        let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) as f64;
        a.map(|c| c / n.sqrt())
    };
    for (name, angle) in [("to 103°", 1.8), ("to 206°", 3.6), ("back", 0.0)] {
        let mut step = Step::new(name);
        hold(&mut step, 0, &[0, 1, 2]);
        for c in 0..3 {
            step.prescribed.push((3 + c, Motion::To(angle * axis[c])));
        }
        step.control = control(0.1);
        problem.run_step(&step, &mut NullObserver).unwrap();
        let q = exp_so3(&axis.map(|c| c * angle));
        let u = problem.u();
        for (node, x) in coords.iter().enumerate() {
            for i in 0..3 {
                let rotated: f64 = (0..3).map(|k| q[i][k] * x[k]).sum();
                assert!(
                    (u[6 * node + i] - (rotated - x[i])).abs() < 1e-9,
                    "{name}: node {node} position"
                );
                assert!(
                    (u[6 * node + 3 + i] - angle * axis[i]).abs() < 1e-9,
                    "{name}: node {node} rotation"
                );
            }
        }
        assert!(
            problem.energy().abs() < 1e-15,
            "{name}: energy {}",
            problem.energy()
        );
        let reaction = (0..6)
            .map(|d| problem.reaction(d).abs())
            .fold(0.0, f64::max);
        assert!(reaction < 1e-9, "{name}: reaction {reaction}");
    }
}

/// Complete elliptic integral of the first kind K(p) = ∫₀^{π/2} dφ/√(1 − p² sin²φ)
/// (arithmetic–geometric mean).
fn elliptic_k(p: f64) -> f64 {
    let (mut a, mut b) = (1.0, (1.0 - p * p).sqrt());
    for _ in 0..30 {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    PI / (2.0 * a)
}

#[test]
fn beam_microtubule_buckles_at_the_euler_load_and_newton_converges_on_piconewtons() {
    // Spec: EI = 0.018 nN·µm², L = 16 µm. Euler loads: clamped–free π²EI/(4L²) = 0.174 pN,
    // pinned–pinned π²EI/L² = 0.70 pN, clamped–clamped 4π²EI/L² = 2.79 pN.
    let sec = BeamSection::hollow_circular(1.2e6, 0.3, 0.025, 0.017).unwrap();
    let (ei, _) = sec.bending_stiffness();
    let (n, length) = (16, 16.0);
    let p_cr = PI * PI * ei / (4.0 * length * length);
    assert!((p_cr * 1e3 - 0.1744).abs() < 1e-3, "P_cr {} pN", p_cr * 1e3);
    assert!((4.0 * p_cr * 1e3 - 0.6975).abs() < 2e-3);
    let (mut coords, pairs) = straight(n, length);
    // Initial bow of L/1000 in the buckling mode shape (the imperfection).
    for x in coords.iter_mut() {
        x[1] = 1e-3 * length * (1.0 - (PI * x[0] / (2.0 * length)).cos());
    }
    let mut problem = model(&coords, &pairs, sec);
    // Clamped at x = 0; the tip is pushed axially (displacement control, which follows
    // the stable post-buckling branch).
    let mut step = Step::new("compress");
    hold(&mut step, 0, &[0, 1, 2, 3, 4, 5]);
    for node in 1..=n {
        hold(&mut step, node, &[2, 3, 4]);
    }
    step.prescribed.push((6 * n, Motion::To(-0.05 * length)));
    step.control = control(0.05);
    step.control.initial_increment = 1e-3;
    problem.run_step(&step, &mut NullObserver).unwrap();
    let u = problem.u();
    let (tip_rotation, deflection) = (u[6 * n + 5], u[6 * n + 1] / length);
    let axial = -problem.reaction(6 * n);
    // Elastica of the buckled cantilever with tip slope α: P/P_cr = (2K(sin(α/2))/π)².
    let exact = p_cr * (2.0 * elliptic_k((tip_rotation / 2.0).sin()) / PI).powi(2);
    eprintln!(
        "MT: shortening 5% L: P = {:.5} pN (P_cr {:.5} pN, elastica at α = {tip_rotation:.4}: {:.5}), δ/L = {deflection:.4}",
        axial * 1e3,
        p_cr * 1e3,
        exact * 1e3
    );
    assert!(
        deflection > 0.2 && tip_rotation > 0.4,
        "buckled: δ/L {deflection}"
    );
    assert!(
        (axial / exact - 1.0).abs() < 0.01,
        "P {axial} vs elastica {exact}"
    );
    assert!(axial > p_cr && axial < 1.05 * p_cr);
    let stats = match problem.terms()[0].outputs(u, problem.dof_map()).unwrap() {
        Some(out) => out.fields[0].values.clone(),
        None => panic!("beam outputs missing"),
    };
    // Every element is in compression and carries about P cos(local slope).
    assert!(
        stats.iter().all(|&f| f < 0.0 && f > -1.05 * axial),
        "{stats:?}"
    );
}

/// Counts a step's iterations and cut-backs.
#[derive(Default)]
struct Counts {
    iterations: usize,
    cutbacks: usize,
    /// The step length of each attempt's first correction.
    first_steps: Vec<f64>,
}

impl cellmech_fem::solve::Observer for Counts {
    fn on_iteration(&mut self, report: &cellmech_fem::solve::IterationReport) {
        self.iterations += 1;
        if report.iteration == 0 {
            self.first_steps.push(report.line_search);
        }
    }
    fn on_cutback(
        &mut self,
        _step_time: f64,
        _increment: f64,
        _reason: &cellmech_fem::solve::FailureReason,
    ) {
        self.cutbacks += 1;
    }
}

/// A cantilever rolled up by an end moment M = φ·EI/L, applied as one step, bends into a
/// circular arc of radius L/φ (pure bending: the corotational element's nodes lie on it
/// exactly). Returns (tip error / L, iterations, cut-backs, shortened corrections, the
/// step length of the first correction).
fn roll_up(max_rotation_step: f64) -> (f64, usize, usize, usize, f64) {
    let (n, length, ei) = (24, 2.0, 3.0);
    let phi = 1.5 * PI;
    let (coords, pairs) = straight(n, length);
    let mut problem = model(&coords, &pairs, section(ei, length));
    let mut step = Step::new("roll up");
    hold(&mut step, 0, &[0, 1, 2, 3, 4, 5]);
    for node in 1..=n {
        hold(&mut step, node, &[2, 3, 4]); // planar problem in x–y
    }
    step.loads = vec![NodalLoad {
        dof: 6 * n + 5,
        value: phi * ei / length,
    }];
    step.control = control(1.0);
    step.control.convergence.max_rotation_step = max_rotation_step;
    let mut counts = Counts::default();
    problem.run_step(&step, &mut counts).unwrap();
    let rho = length / phi;
    let exact = [rho * phi.sin() - length, rho * (1.0 - phi.cos())];
    let u = problem.u();
    let error = ((u[6 * n] - exact[0]).powi(2) + (u[6 * n + 1] - exact[1]).powi(2)).sqrt();
    assert!(
        (u[6 * n + 5] - phi).abs() < 1e-6,
        "tip rotation {} against {phi}",
        u[6 * n + 5]
    );
    (
        error / length,
        counts.iterations,
        counts.cutbacks,
        problem.timings().rotation_limited_steps,
        counts.first_steps[0],
    )
}

/// The rotations' trust region changes Newton's path, not the equilibrium it converges to:
/// the 270° arc is reached with and without it, the tip within 1e-6 L of the exact one, and with it
/// the corrections were shortened (so the bound acted on this problem).
///
/// The bound holds for the first correction too, which moves no prescribed DOF here (the
/// load is a moment): on the straight cantilever the linearised tip rotation is exactly
/// M·L/EI = 1.5π, the largest of the correction, so the first step is 0.5 / 1.5π.
#[test]
fn a_trust_region_on_the_rotations_shortens_newton_steps_and_keeps_the_equilibrium() {
    let (error, iterations, cutbacks, shortened, first) = roll_up(0.5);
    let expected = 0.5 / (1.5 * PI);
    assert!(
        (first - expected).abs() < 1e-9,
        "first correction's step {first}, expected {expected}"
    );
    eprintln!(
        "trust region 0.5 rad: tip error {error:.2e} L, {iterations} iterations, \
         {cutbacks} cut-backs, {shortened} shortened corrections"
    );
    assert!(error < 1e-6, "tip {error} L off the arc");
    assert!(shortened > 0, "the trust region never acted");
    let (free_error, iterations, cutbacks, shortened, first) = roll_up(0.0);
    assert_eq!(first, 1.0, "the unbounded first correction is the full one");
    eprintln!(
        "no trust region: tip error {free_error:.2e} L, {iterations} iterations, \
         {cutbacks} cut-backs, {shortened} shortened corrections"
    );
    assert!(free_error < 1e-6, "tip {free_error} L off the arc");
    assert_eq!(shortened, 0);
}
