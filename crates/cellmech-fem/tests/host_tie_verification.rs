//! Elastic node-to-host ties (`element::host_tie`) verified as a Winkler foundation: a
//! microtubule beam tied at every node to a host whose material points move affinely buckles
//! at the load of a beam on an elastic foundation.
//!
//! The host is one hex8 block around the beam whose nodes are prescribed the motion
//! `u = (−ε x, 0, 0)`; its trilinear interpolation reproduces that affine field exactly, so
//! the material point under every beam node moves axially with the beam's uniform shortening
//! (no axial slip, uniform axial force `P = EA ε` before buckling) and not laterally. A tie
//! of stiffness `k h` per node (h the node spacing, half at the ends) is then a lateral
//! foundation of modulus `k` (nN/µm²). For a pinned–pinned beam of length L the critical load
//! is `P_cr = min_m [EI q_m² + k / q_m²]`, `q_m = mπ/L`, which tends to `2√(k EI)` at the
//! half-wavelength `π (EI/k)^{1/4}`. The test finds the critical strain by bisection on the
//! tangent's inertia (LDLᵀ negative pivots) and checks the load against the formula, the
//! mode number against the minimising `m`, and that the free beam (no ties) buckles two
//! orders of magnitude lower, at Euler's load.

use cellmech_fem::assembly::AssemblyOutput;
use cellmech_fem::dof::DofMap;
use cellmech_fem::element::beam::{BeamSection, BeamSet};
use cellmech_fem::element::host_tie::{HostTie, HostTieSet};
use cellmech_fem::linsolve::{FaerSparseSolver, LinearSolver};
use cellmech_fem::mesh::locate::hex8_inverse_map;
use cellmech_fem::mesh::locate::hex8_shape;
use cellmech_fem::mesh::surface::HEX8_CORNERS;
use cellmech_fem::solve::{
    Damping, IncrementReport, Motion, NullObserver, Observer, Problem, Stabilization,
    StabilizationReport, Step,
};
use cellmech_fem::term::Term;
use std::f64::consts::PI;

const LENGTH: f64 = 20.0;
const ELEMENTS: usize = 160;
/// Foundation modulus (nN/µm²): of the order of the cytoplasm's Young's modulus.
const K_FOUNDATION: f64 = 0.5;

fn mt_section() -> BeamSection {
    BeamSection::hollow_circular(1.2e6, 0.3, 0.025, 0.017).unwrap()
}

struct Model {
    coords: Vec<[f64; 3]>,
    beam_nodes: Vec<usize>,
    host_nodes: [usize; 8],
    beams: BeamSet,
    ties: Option<HostTieSet>,
    dof_map: DofMap,
}

fn model(tied: bool) -> Model {
    model_with_imperfection(tied, 0.0)
}

/// The model with the beam's nodes moved sideways (y) by `amplitude` × sin(15πx/L), the
/// shape of the 15 half-waves the tied beam buckles into (the `m` that minimises
/// `EI q_m² + k / q_m²`).
fn model_with_imperfection(tied: bool, amplitude: f64) -> Model {
    // Host box nodes first (corners of [−1, L+1] × [−1, 1]²), then the beam along the x axis.
    let mut coords: Vec<[f64; 3]> = HEX8_CORNERS
        .iter()
        .map(|c| [0.5 * (c[0] + 1.0) * (LENGTH + 2.0) - 1.0, c[1], c[2]])
        .collect();
    let host_nodes: [usize; 8] = std::array::from_fn(|a| a);
    let host_x: [[f64; 3]; 8] = std::array::from_fn(|a| coords[a]);
    let h = LENGTH / ELEMENTS as f64;
    let beam_nodes: Vec<usize> = (0..=ELEMENTS)
        .map(|i| {
            let x = i as f64 * h;
            coords.push([x, amplitude * (15.0 * PI * x / LENGTH).sin(), 0.0]);
            coords.len() - 1
        })
        .collect();
    let pairs: Vec<[usize; 2]> = beam_nodes.windows(2).map(|w| [w[0], w[1]]).collect();
    let beams = BeamSet::from_coordinates(
        "mt",
        "microtubule",
        &coords,
        &pairs,
        Some([0.0, 0.0, 1.0]),
        mt_section(),
    )
    .unwrap();
    let ties = tied.then(|| {
        let ties = beam_nodes
            .iter()
            .enumerate()
            .map(|(i, &n)| {
                let xi = hex8_inverse_map(&host_x, coords[n]).unwrap();
                let share = if i == 0 || i == ELEMENTS { 0.5 } else { 1.0 };
                HostTie::new(n, host_nodes, hex8_shape(xi), K_FOUNDATION * h * share)
            })
            .collect();
        HostTieSet::new("ties", ties)
    });
    let mut counts = vec![3; coords.len()];
    beams.mark_rotational_nodes(&mut counts).unwrap();
    Model {
        dof_map: DofMap::with_counts(&counts),
        coords,
        beam_nodes,
        host_nodes,
        beams,
        ties,
    }
}

fn terms(m: &Model) -> Vec<Box<dyn Term>> {
    let mut t: Vec<Box<dyn Term>> = vec![Box::new(m.beams.clone())];
    if let Some(ties) = &m.ties {
        t.push(Box::new(ties.clone()));
    }
    t
}

/// Host nodes and beam ends follow u = (−ε x, 0, 0); pinned ends; twist held at one end.
fn compression(m: &Model, strain: f64) -> Step {
    let mut step = Step::new("compress");
    step.control.initial_increment = 1.0;
    step.control.max_increment = 1.0;
    let (first, last) = (m.beam_nodes[0], *m.beam_nodes.last().unwrap());
    for &n in m.host_nodes.iter().chain([first, last].iter()) {
        let d = &m.dof_map;
        step.prescribed
            .push((d.dof(n, 0), Motion::To(-strain * m.coords[n][0])));
        step.prescribed.push((d.dof(n, 1), Motion::Hold));
        step.prescribed.push((d.dof(n, 2), Motion::Hold));
    }
    step.prescribed
        .push((m.dof_map.dof(first, 3), Motion::Hold));
    step
}

/// Negative pivots of the tangent after solving the compression to `strain` from rest
/// (fresh problem: the straight state is an equilibrium on both sides of the critical load),
/// and optionally the eigenvector nearest to zero (inverse iteration).
fn inertia(m: &Model, strain: f64, mode: Option<&mut Vec<f64>>) -> usize {
    let mut problem = Problem::new(
        m.dof_map.clone(),
        terms(m),
        Box::new(FaerSparseSolver::new(1)),
    )
    .unwrap();
    problem
        .run_step(&compression(m, strain), &mut NullObserver)
        .unwrap();
    let (mut linear, mask, negative_pivots) = factorized_tangent(&problem);
    let n = mask.len();
    if let Some(x) = mode {
        let mut seed = 7u64;
        for v in x.iter_mut() {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            *v = (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        }
        for _ in 0..60 {
            for d in 0..n {
                if mask[d] {
                    x[d] = 0.0;
                }
            }
            linear.solve_in_place(x).unwrap();
            let s = x.iter().map(|v| v * v).sum::<f64>().sqrt();
            x.iter_mut().for_each(|v| *v /= s);
        }
    }
    negative_pivots
}

/// The tangent at the problem's state, factorised (LDLᵀ), with the prescribed-DOF mask and
/// the number of negative pivots (0 for a stable equilibrium).
fn factorized_tangent(problem: &Problem) -> (FaerSparseSolver, Vec<bool>, usize) {
    let n = problem.u().len();
    let mask: Vec<bool> = (0..n).map(|d| problem.is_prescribed(d)).collect();
    let pattern = problem.tangent_pattern().clone();
    let mut values = vec![0.0; pattern.nnz()];
    let mut r = vec![0.0; n];
    problem
        .assembler()
        .assemble(
            problem.terms(),
            problem.u(),
            &mask,
            AssemblyOutput {
                residual: &mut r,
                magnitude: None,
                tangent: Some(&mut values),
                predictor: None,
            },
        )
        .unwrap();
    let mut linear = FaerSparseSolver::new(1);
    linear.analyze(&pattern).unwrap();
    let negative_pivots = linear
        .factorize(&values)
        .unwrap()
        .negative_pivots
        .expect("LDLT reports its inertia");
    (linear, mask, negative_pivots)
}

/// Critical strain by bisection on the inertia, starting from a bracket guess.
fn critical_strain(m: &Model, guess: f64) -> f64 {
    assert_eq!(inertia(m, 0.0, None), 0, "stable at rest");
    let (mut lo, mut hi) = (0.5 * guess, 1.5 * guess);
    assert_eq!(inertia(m, lo, None), 0, "stable at half the expected load");
    let mut widenings = 0;
    while inertia(m, hi, None) == 0 {
        widenings += 1;
        assert!(widenings < 8, "no buckling below {hi:e}");
        (lo, hi) = (hi, 1.5 * hi);
    }
    while hi - lo > 1e-3 * lo {
        let mid = 0.5 * (lo + hi);
        if inertia(m, mid, None) > 0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

#[test]
fn a_tied_microtubule_buckles_at_the_elastic_foundation_load_in_short_waves() {
    let section = mt_section();
    let (ei, _) = section.bending_stiffness();
    let ea = section.axial_stiffness();
    let m = model(true);
    let p_asymptotic = 2.0 * (K_FOUNDATION * ei).sqrt();
    let (m_best, p_theory) = (1..200)
        .map(|m| {
            let q = m as f64 * PI / LENGTH;
            (m, ei * q * q + K_FOUNDATION / (q * q))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    let strain = critical_strain(&m, p_theory / ea);
    let p_cr = ea * strain;
    let error = p_cr / p_theory - 1.0;
    println!(
        "tied MT: P_cr = {p_cr:.5} nN, theory {p_theory:.5} nN (m = {m_best}), 2√(kEI) = \
         {p_asymptotic:.5} nN, error {:.3} %",
        100.0 * error
    );
    assert!(error.abs() < 0.02, "P_cr {p_cr} vs {p_theory}");
    assert!((p_cr / p_asymptotic - 1.0).abs() < 0.05);
    // The mode: lateral shape sin(mπx/L) with m within one of the minimising m.
    let mut x = vec![0.0; m.dof_map.num_dofs()];
    inertia(&m, strain * 1.002, Some(&mut x));
    let mut best = (0usize, 0.0);
    for k in 1..=60usize {
        let (mut sy, mut sz, mut den) = (0.0, 0.0, 0.0);
        for &n in &m.beam_nodes {
            let phi = (k as f64 * PI * m.coords[n][0] / LENGTH).sin();
            sy += x[m.dof_map.dof(n, 1)] * phi;
            sz += x[m.dof_map.dof(n, 2)] * phi;
            den += phi * phi;
        }
        let power = (sy * sy + sz * sz) / den;
        if power > best.1 {
            best = (k, power);
        }
    }
    println!("buckling mode: {} half-waves (theory {m_best})", best.0);
    assert!(best.0.abs_diff(m_best) <= 1, "mode {} vs {m_best}", best.0);
}

#[test]
fn without_ties_the_same_microtubule_buckles_at_the_euler_load() {
    let section = mt_section();
    let (ei, _) = section.bending_stiffness();
    let ea = section.axial_stiffness();
    let m = model(false);
    let euler = PI * PI * ei / (LENGTH * LENGTH);
    let p_cr = ea * critical_strain(&m, euler / ea);
    println!("free MT: P_cr = {p_cr:.3e} nN, Euler {euler:.3e} nN");
    assert!((p_cr / euler - 1.0).abs() < 0.01, "{p_cr} vs {euler}");
    assert!(2.0 * (K_FOUNDATION * ei).sqrt() > 50.0 * p_cr);
}

/// Amplitude (µm) of the tied MT's initial waviness in the buckling test with viscosity.
const IMPERFECTION: f64 = 1e-3;
/// An explicit damping factor: the calibrated one depends on the whole predictor motion,
/// rigid part included, and this test compares the drag itself with and without one.
const DAMPING_FACTOR: f64 = 1e-7;

#[derive(Default)]
struct Reports(Vec<StabilizationReport>);

impl Observer for Reports {
    fn on_increment(&mut self, _problem: &Problem, report: &IncrementReport<'_>) {
        if let Some(r) = report.stabilization {
            self.0.push(r);
        }
    }
}

/// What one stabilised buckling run ended with.
struct Buckled {
    /// Energy the viscosity dissipated over the step (nN·µm).
    dissipated: f64,
    /// The last increment's stabilisation report.
    last: StabilizationReport,
    /// Largest lateral deflection of the beam relative to the host (µm).
    deflection: f64,
    /// Negative pivots of the tangent at the end: 0 for a stable equilibrium.
    negative_pivots: usize,
}

/// Compresses the wavy tied MT (in the x-y plane: out-of-plane motion held) to 0.9 of its
/// critical strain in one viscously stabilised step, which amplifies the waviness
/// (by 1 / (1 − P/P_cr) for the buckling shape), while the host also moves sideways by `shift` (rigidly).
fn buckle_with(damping: Damping, shift: f64) -> Buckled {
    let section = mt_section();
    let (ei, _) = section.bending_stiffness();
    let strain = 0.9 * 2.0 * (K_FOUNDATION * ei).sqrt() / section.axial_stiffness();
    let m = model_with_imperfection(true, IMPERFECTION);
    let mut step = compression(&m, strain);
    step.control.initial_increment = 0.1;
    step.control.max_increment = 0.1;
    step.control.stabilization = Some(Stabilization {
        damping,
        factor: Some(DAMPING_FACTOR),
        ..Stabilization::default()
    });
    let (first, last) = (m.beam_nodes[0], *m.beam_nodes.last().unwrap());
    for &n in m.host_nodes.iter().chain([first, last].iter()) {
        let dof = m.dof_map.dof(n, 1);
        for p in step.prescribed.iter_mut().filter(|p| p.0 == dof) {
            p.1 = Motion::To(shift);
        }
    }
    for &n in &m.beam_nodes {
        for c in [2, 3, 4] {
            let dof = m.dof_map.dof(n, c);
            if !step.prescribed.iter().any(|p| p.0 == dof) {
                step.prescribed.push((dof, Motion::Hold));
            }
        }
    }
    let mut problem = Problem::new(
        m.dof_map.clone(),
        terms(&m),
        Box::new(FaerSparseSolver::new(1)),
    )
    .unwrap();
    let mut reports = Reports::default();
    problem.run_step(&step, &mut reports).unwrap();
    let last = *reports
        .0
        .last()
        .expect("stabilised increments are reported");
    let deflection = m
        .beam_nodes
        .iter()
        .map(|&n| (problem.u()[m.dof_map.dof(n, 1)] - shift).abs())
        .fold(0.0, f64::max);
    let (_, _, negative_pivots) = factorized_tangent(&problem);
    Buckled {
        dissipated: last.step_dissipated,
        last,
        deflection,
        negative_pivots,
    }
}

#[test]
fn the_drag_of_the_gel_damps_a_tied_microtubule_bending_and_ignores_rigid_motion() {
    // Damping::Relative resists only the slip of the tied nodes relative to their material
    // points (and the rotations): the beam's growing waviness is damped, the step ends in
    // the stable equilibrium, and moving the whole assembly sideways by 5 µm changes
    // nothing. The nodal viscosity (Abaqus's) resists that rigid motion too and dissipates
    // far more energy on it.
    let still = buckle_with(Damping::Relative, 0.0);
    let moved = buckle_with(Damping::Relative, 5.0);
    let nodal = buckle_with(Damping::Nodal, 0.0);
    let nodal_moved = buckle_with(Damping::Nodal, 5.0);
    for (name, b) in [
        ("relative", &still),
        ("relative, moved", &moved),
        ("nodal", &nodal),
        ("nodal, moved", &nodal_moved),
    ] {
        println!(
            "{name}: dissipated {:.4e} nN·µm, deflection {:.5} µm, negative pivots {}",
            b.dissipated, b.deflection, b.negative_pivots
        );
        assert!(
            b.last.equilibrated,
            "{name}: ends in equilibrium: {:?}",
            b.last
        );
        assert_eq!(b.negative_pivots, 0, "{name}: a stable equilibrium");
        // Near buckling the waviness grows several times (measured 4.7: the discrete
        // critical load is a little above 2√(kEI)).
        assert!(
            b.deflection > 3.0 * IMPERFECTION,
            "{name}: {}",
            b.deflection
        );
    }
    assert!((moved.deflection / still.deflection - 1.0).abs() < 1e-6);
    assert!(still.dissipated > 0.0, "the buckling is damped");
    assert!(
        (moved.dissipated / still.dissipated - 1.0).abs() < 1e-6,
        "{} vs {}",
        moved.dissipated,
        still.dissipated
    );
    assert!(nodal_moved.dissipated > 100.0 * moved.dissipated);
}
