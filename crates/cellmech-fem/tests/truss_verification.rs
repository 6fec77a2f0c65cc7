//! Truss verification through the full solver (`Problem`/`Step`): prestrain, slack, a
//! prestressed cable–strut structure, a cable that goes slack under load, and the spec's
//! range of axial stiffnesses (EA from 0.6 to 317 nN) in one model.
//!
//! Every reference value is a closed-form equilibrium computed here by hand, never by the
//! element under test.

use cellmech_fem::dof::DofMap;
use cellmech_fem::element::truss::TrussSet;
use cellmech_fem::linsolve::DenseSolver;
use cellmech_fem::material::AxialLaw;
use cellmech_fem::solve::{
    FailureReason, IncrementReport, IterationReport, Motion, NodalLoad, Observer, Problem, Step,
};
use cellmech_fem::term::Term;

/// Converged increments (time, iterations, DOF values, reactions) and cutbacks.
#[derive(Default)]
struct Recorder {
    increments: Vec<Converged>,
    iterations: Vec<IterationReport>,
    cutbacks: usize,
}

struct Converged {
    step: usize,
    time: f64,
    iterations: usize,
    u: Vec<f64>,
    reaction: Vec<f64>,
}

impl Observer for Recorder {
    fn on_iteration(&mut self, report: &IterationReport) {
        self.iterations.push(*report);
    }
    fn on_increment(&mut self, problem: &Problem, report: &IncrementReport<'_>) {
        let n = problem.u().len();
        self.increments.push(Converged {
            step: report.step_index,
            time: report.step_time,
            iterations: report.iterations,
            u: problem.u().to_vec(),
            reaction: (0..n).map(|d| problem.reaction(d)).collect(),
        });
    }
    fn on_cutback(&mut self, _t: f64, _dt: f64, _reason: &FailureReason) {
        self.cutbacks += 1;
    }
}

fn problem(num_nodes: usize, terms: Vec<Box<dyn Term>>) -> Problem {
    Problem::new(
        DofMap::translational(num_nodes),
        terms,
        Box::new(DenseSolver::default()),
    )
    .expect("the problem builds")
}

/// A step solved as one increment. The prestress steps change no load or motion: after the
/// first increment, a second one would start at equilibrium, where the solver's relative
/// criteria have no scale (energy ratio against δ₀·R₀ ≈ 1e-30; and for a self-equilibrated
/// prestress the reactions are 0 too), so they are run as a single increment.
fn single_increment(name: &str) -> Step {
    let mut step = Step::new(name);
    step.control.initial_increment = 1.0;
    step.control.max_increment = 1.0;
    step
}

fn hold(dofs: &[usize]) -> Vec<(usize, Motion)> {
    dofs.iter().map(|&d| (d, Motion::Hold)).collect()
}

/// Actin filament, suspended cell: E = 2.6 GPa, d = 7 nm, tension-only, prestrain 24 %.
fn actin() -> AxialLaw {
    AxialLaw::tension_only(2.6e6, AxialLaw::solid_circle_area(0.007)).with_prestrain(0.24)
}

/// Microtubule as a straight linear truss: E = 1.2 GPa, hollow 25/17 nm.
fn microtubule() -> AxialLaw {
    AxialLaw::linear(1.2e6, AxialLaw::hollow_circle_area(0.025, 0.017))
}

/// Intermediate filament: E = 7.6 MPa, d = 10 nm, tension-only, slack 20 %.
fn intermediate() -> AxialLaw {
    AxialLaw::tension_only(7.6e3, AxialLaw::solid_circle_area(0.010)).with_slack(0.2)
}

/// Actin bundle, adherent cell: E = 0.34 MPa, d = 250 nm (EA = 16.7 nN).
fn bundle_linear() -> AxialLaw {
    AxialLaw::linear(340.0, AxialLaw::solid_circle_area(0.25))
}

// GOAL: a prestrained filament between fixed nodes carries N = EA·0.24 through the solver.
// MESH: one AF, 16 µm, oblique. BCS: both nodes held. REFERENCE: N = EA·prestrain.
#[test]
fn truss_prestrained_actin_between_fixed_nodes_reacts_with_ea_times_prestrain() {
    let dir = [2.0 / 7.0, 3.0 / 7.0, 6.0 / 7.0];
    let x = [
        [1.0, -2.0, 0.5],
        [
            1.0 + 16.0 * dir[0],
            -2.0 + 16.0 * dir[1],
            0.5 + 16.0 * dir[2],
        ],
    ];
    let set = TrussSet::new("af", "actin", &x, vec![[0, 1]], actin()).unwrap();
    let mut p = problem(2, vec![Box::new(set)]);
    let mut step = single_increment("prestress");
    step.prescribed = hold(&[0, 1, 2, 3, 4, 5]);
    p.run_step(&step, &mut Recorder::default()).unwrap();
    let ea = actin().axial_stiffness();
    for i in 0..3 {
        // The support at b holds the filament back: reaction = N·n at b, −N·n at a.
        assert!((p.reaction(3 + i) - ea * 0.24 * dir[i]).abs() <= 1e-12 * ea);
        assert!((p.reaction(i) + ea * 0.24 * dir[i]).abs() <= 1e-12 * ea);
    }
}

/// Node positions of the three-strut octahedral cross.
fn octahedron(radius: f64) -> Vec<[f64; 3]> {
    let r = radius;
    vec![
        [r, 0.0, 0.0],
        [-r, 0.0, 0.0],
        [0.0, r, 0.0],
        [0.0, -r, 0.0],
        [0.0, 0.0, r],
        [0.0, 0.0, -r],
    ]
}

// GOAL: prestressed cable net in equilibrium with compression struts (tensegrity).
// MESH: 6 nodes at ±R0 on the axes; 3 struts join opposite nodes (MT, linear, stress-free at
//   the initial geometry); 12 cables along the octahedron edges (AF, tension-only, 24 %).
// BCS: statically determinate: node +x all, node −x (y, z), node +y (z); they take no load.
// REFERENCE: by symmetry the net shrinks to radius ρ = r·R0. A node sees 4 cables whose unit
//   vectors sum to 2√2 inward and one strut: 2√2·N_c + N_s = 0 with
//   N_c = EA_c((1+p)·r − 1) (ℓ_c = √2 ρ, L_free = √2 R0/(1+p)), N_s = EA_s(r − 1), so
//   r = (2√2 EA_c + EA_s)/(2√2 EA_c (1+p) + EA_s).
#[test]
fn truss_tensegrity_octahedron_prestress_matches_closed_form_equilibrium() {
    let r0 = 5.0;
    let x = octahedron(r0);
    let struts = vec![[0, 1], [2, 3], [4, 5]];
    let cables: Vec<[usize; 2]> = (0..6)
        .flat_map(|a| (a + 1..6).map(move |b| [a, b]))
        .filter(|&[a, b]| a / 2 != b / 2)
        .collect();
    assert_eq!(cables.len(), 12);
    let strut_set = TrussSet::new("struts", "microtubule", &x, struts, microtubule()).unwrap();
    let cable_set = TrussSet::new("cables", "actin", &x, cables, actin()).unwrap();
    let mut p = problem(
        6,
        vec![Box::new(strut_set.clone()), Box::new(cable_set.clone())],
    );
    let mut step = single_increment("prestress");
    step.prescribed = hold(&[0, 1, 2, 4, 5, 8]);
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();

    let (ea_c, ea_s, pre) = (
        actin().axial_stiffness(),
        microtubule().axial_stiffness(),
        0.24,
    );
    let s2 = 2.0 * 2f64.sqrt();
    let ratio = (s2 * ea_c + ea_s) / (s2 * ea_c * (1.0 + pre) + ea_s);
    let rho = ratio * r0;
    let n_cable = ea_c * ((1.0 + pre) * ratio - 1.0);
    let n_strut = ea_s * (ratio - 1.0);
    assert!(n_cable > 0.0 && n_strut < 0.0);
    // Node +x is held, so the centre moves to (R0 − ρ, 0, 0).
    let centre = [r0 - rho, 0.0, 0.0];
    let u = p.u();
    for (node, x0) in octahedron(r0).iter().enumerate() {
        for c in 0..3 {
            let expected = centre[c] + x0[c] * ratio;
            let got = x0[c] + u[3 * node + c];
            assert!(
                (got - expected).abs() <= 1e-8 * r0,
                "node {node} component {c}: {got} vs {expected}"
            );
        }
    }
    let map = p.dof_map().clone();
    let cs = cable_set.force_statistics(u, &map).unwrap();
    let ss = strut_set.force_statistics(u, &map).unwrap();
    assert_eq!((cs.count, cs.in_tension, ss.in_tension), (12, 12, 0));
    for (stats, n) in [(cs, n_cable), (ss, n_strut)] {
        let f = stats.force.unwrap();
        for v in [f.min, f.max, f.mean] {
            assert!(
                (v - n).abs() <= 1e-8 * n.abs(),
                "{}: {v} vs {n}",
                stats.family
            );
        }
    }
    // The supports take no load (statically determinate, self-equilibrated prestress).
    let max_reaction = [0, 1, 2, 4, 5, 8]
        .iter()
        .map(|&d| p.reaction(d).abs())
        .fold(0.0, f64::max);
    assert!(
        max_reaction <= 1e-8 * n_cable,
        "support reaction {max_reaction}"
    );
    // Along the symmetric shrinking path every element keeps its direction, so the energy is
    // quadratic in the scale and Newton is exact in one iteration.
    assert_eq!(rec.cutbacks, 0);
    assert_eq!(rec.increments[0].iterations, 1);

    // Step 2: pull the ±z nodes apart with ±F. The D4h symmetry keeps the equator nodes at
    // radius ρ1 and the poles at ρ2 about the centre; by hand (ℓ2 = √(ρ1² + ρ2²)):
    //   pole:    4 N_c2 ρ2/ℓ2 + N_s2 = F
    //   equator: √2 N_c1 + 2 N_c2 ρ1/ℓ2 + N_s1 = 0
    // solved below by a 2×2 Newton iteration independent of the element code.
    let force = 40.0;
    let mut pull = Step::new("pull poles");
    pull.prescribed = hold(&[0, 1, 2, 4, 5, 8]);
    pull.loads = vec![
        NodalLoad {
            dof: 14,
            value: force,
        },
        NodalLoad {
            dof: 17,
            value: -force,
        },
    ];
    p.run_step(&pull, &mut rec).unwrap();
    let cable_force = |l: f64| ea_c * (l * (1.0 + pre) / (2f64.sqrt() * r0) - 1.0).max(0.0);
    let equations = |r1: f64, r2: f64| {
        let l2 = (r1 * r1 + r2 * r2).sqrt();
        let (nc1, nc2) = (cable_force(2f64.sqrt() * r1), cable_force(l2));
        let (ns1, ns2) = (ea_s * (r1 / r0 - 1.0), ea_s * (r2 / r0 - 1.0));
        [
            4.0 * nc2 * r2 / l2 + ns2 - force,
            2f64.sqrt() * nc1 + 2.0 * nc2 * r1 / l2 + ns1,
        ]
    };
    let (mut r1, mut r2) = (rho, rho);
    for _ in 0..50 {
        let g = equations(r1, r2);
        let h = 1e-7 * r0;
        let (ga, gb) = (equations(r1 + h, r2), equations(r1, r2 + h));
        let j = [
            [(ga[0] - g[0]) / h, (gb[0] - g[0]) / h],
            [(ga[1] - g[1]) / h, (gb[1] - g[1]) / h],
        ];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        r1 -= (j[1][1] * g[0] - j[0][1] * g[1]) / det;
        r2 -= (-j[1][0] * g[0] + j[0][0] * g[1]) / det;
    }
    let g = equations(r1, r2);
    assert!(
        g[0].abs() < 1e-10 && g[1].abs() < 1e-10,
        "reference solve {g:?}"
    );
    let u = p.u();
    let centre = [r0 - r1, 0.0, 0.0];
    for (node, x0) in octahedron(r0).iter().enumerate() {
        let radius = if node < 4 { r1 } else { r2 };
        for c in 0..3 {
            let expected = centre[c] + x0[c] / r0 * radius;
            let got = x0[c] + u[3 * node + c];
            assert!(
                (got - expected).abs() <= 1e-8 * r0,
                "pulled node {node} component {c}: {got} vs {expected}"
            );
        }
    }
    assert!(
        r2 > rho && r1 < rho,
        "poles move out ({r2}), equator in ({r1})"
    );
    let pull_iterations: Vec<usize> = rec
        .increments
        .iter()
        .filter(|i| i.step == 1)
        .map(|i| i.iterations)
        .collect();
    assert!(
        pull_iterations.iter().all(|&n| n <= 6),
        "iterations {pull_iterations:?}"
    );
    assert_eq!(rec.cutbacks, 0);
}

/// Node P on a V of two linear trusses (supports (∓3, −4)), pulled up by a prestrained
/// tension-only cable to B = (0, 5).
struct CableOnV {
    coords: Vec<[f64; 3]>,
    ea_v: f64,
    cable: AxialLaw,
}

impl CableOnV {
    fn new(cable: AxialLaw) -> Self {
        CableOnV {
            coords: vec![
                [0.0; 3],
                [-3.0, -4.0, 0.0],
                [3.0, -4.0, 0.0],
                [0.0, 5.0, 0.0],
            ],
            ea_v: bundle_linear().axial_stiffness(),
            cable,
        }
    }

    fn problem(&self) -> Problem {
        let v = TrussSet::new(
            "v",
            "bundle",
            &self.coords,
            vec![[1, 0], [2, 0]],
            bundle_linear(),
        )
        .unwrap();
        let c = TrussSet::new("cable", "actin", &self.coords, vec![[0, 3]], self.cable).unwrap();
        problem(4, vec![Box::new(v), Box::new(c)])
    }

    /// The vertical load on P (nN) in equilibrium with P at (0, y), by hand:
    /// F = 2 N_v (y + 4)/ℓ_v − N_c, ℓ_v = √(9 + (y+4)²), N_v = EA_v(ℓ_v/5 − 1),
    /// N_c = EA_c·max(0, (5 − y)(1 + p)/5 − 1).
    fn load_for(&self, y: f64) -> f64 {
        let lv = (9.0 + (y + 4.0).powi(2)).sqrt();
        let nv = self.ea_v * (lv / 5.0 - 1.0);
        let nc = self.cable.axial_stiffness()
            * ((5.0 - y) * (1.0 + self.cable.prestrain) / 5.0 - 1.0).max(0.0);
        2.0 * nv * (y + 4.0) / lv - nc
    }

    /// Steps: find the prestressed equilibrium, push P up by 10 nN (the cable goes slack at
    /// about 4.6 nN), release to 0 (it becomes taut again).
    fn run(&self) -> (Problem, Recorder) {
        let mut p = self.problem();
        let supports = hold(&[2, 3, 4, 5, 6, 7, 8, 9, 10, 11]);
        let mut rec = Recorder::default();
        for (name, load) in [("prestress", 0.0), ("push", 10.0), ("release", 0.0)] {
            let mut step = if load == 0.0 && name == "prestress" {
                single_increment(name)
            } else {
                Step::new(name)
            };
            step.prescribed = supports.clone();
            step.loads = vec![NodalLoad {
                dof: 1,
                value: load,
            }];
            p.run_step(&step, &mut rec).unwrap();
        }
        (p, rec)
    }
}

// GOAL: a tension-only cable that goes slack under load carries exactly zero force and
//   Newton crosses the kink both ways without stalling or cutting the increment.
// REFERENCE: the hand-derived load–position relation CableOnV::load_for.
#[test]
fn truss_tension_only_cable_goes_slack_and_newton_crosses_the_kink_without_stalling() {
    let model = CableOnV::new(actin());
    let (p, rec) = model.run();
    let slack_y = 5.0 - 5.0 / 1.24;
    let (mut slack_states, mut taut_states) = (0, 0);
    let cable = TrussSet::new("c", "actin", &model.coords, vec![[0, 3]], actin()).unwrap();
    for inc in &rec.increments {
        let (x, y) = (inc.u[0], inc.u[1]);
        assert!(x.abs() < 1e-12, "symmetric: x = {x}");
        let load = match inc.step {
            0 => 0.0,
            1 => 10.0 * inc.time,
            _ => 10.0 * (1.0 - inc.time),
        };
        // The hand formula gives the applied load at the converged position (the scale is
        // the prestress force EA·0.24 ≈ 24 nN), and the supports balance it.
        let by_hand = model.load_for(y);
        assert!(
            (by_hand - load).abs() <= 1e-8 * 24.0,
            "y = {y}: hand {by_hand} vs applied {load}"
        );
        let support_y: f64 = [4, 7, 10].iter().map(|&d| inc.reaction[d]).sum();
        assert!((support_y + load).abs() <= 1e-8 * 24.0);
        let (r, _) = cable.element_response(0, &inc.u, p.dof_map()).unwrap();
        if y > slack_y {
            assert_eq!(r.force, 0.0, "slack cable at y = {y}");
            slack_states += 1;
        } else {
            assert!(r.force > 0.0);
            taut_states += 1;
        }
    }
    assert!(
        slack_states >= 2 && taut_states >= 4,
        "{slack_states} slack, {taut_states} taut"
    );
    assert_eq!(rec.cutbacks, 0, "no increment was cut");
    let most = rec.increments.iter().map(|i| i.iterations).max().unwrap();
    assert!(
        most <= 6,
        "at most 6 Newton iterations per increment, found {most}"
    );
    // Release restores the prestressed equilibrium of step 0 (path independence, elastic).
    let first = &rec.increments.iter().rfind(|i| i.step == 0).unwrap().u;
    let last = &rec.increments.last().unwrap().u;
    assert!(
        (first[1] - last[1]).abs() < 1e-9,
        "{} vs {}",
        first[1],
        last[1]
    );
}

// GOAL: the optional C¹ transition band (δ = 1e-6) does not change results beyond EA·δ/8
//   in force (the law's bound), and Newton behaves the same.
#[test]
fn truss_transition_band_changes_the_slack_cable_results_by_less_than_its_bound() {
    let delta = 1e-6;
    let exact = CableOnV::new(actin());
    let smooth = CableOnV::new(actin().with_transition_band(delta));
    let (pe, re) = exact.run();
    let (ps, rs) = smooth.run();
    assert_eq!(re.increments.len(), rs.increments.len());
    let ea = actin().axial_stiffness();
    // Stiffness of P vertically is at least the V's (2 EA_v (4/5)²/5 at the start), so a
    // force change of EA·δ/8 moves P by at most that over this stiffness.
    let k_min = 2.0 * exact.ea_v * 0.64 / 5.0;
    let bound = ea * delta / 8.0 / k_min;
    for (a, b) in re.increments.iter().zip(&rs.increments) {
        assert!(
            (a.u[1] - b.u[1]).abs() <= bound + 1e-12,
            "{} vs {}",
            a.u[1],
            b.u[1]
        );
    }
    assert!((pe.u()[1] - ps.u()[1]).abs() <= bound + 1e-12);
    let total = |r: &Recorder| r.increments.iter().map(|i| i.iterations).sum::<usize>();
    assert!(
        total(&rs) <= total(&re) + 2,
        "{} vs {}",
        total(&rs),
        total(&re)
    );
}

/// Series chain along x: IF (slack 20 %) – AB (linear, prestrain 24 %) – AF (linear) – MT
/// (linear), node 0 held, node 4 pulled; lateral DOFs held.
fn chain() -> (Vec<[f64; 3]>, Vec<f64>, Vec<AxialLaw>) {
    let lengths = vec![4.0, 3.0, 2.0, 5.0];
    let mut x = vec![[0.0; 3]];
    for l in &lengths {
        let last = x[x.len() - 1][0];
        x.push([last + l, 0.0, 0.0]);
    }
    let laws = vec![
        intermediate(),
        bundle_linear().with_prestrain(0.24),
        AxialLaw::linear(2.6e6, AxialLaw::solid_circle_area(0.007)),
        microtubule(),
    ];
    (x, lengths, laws)
}

// GOAL: the spec's stiffness range (EA 0.6 … 317 nN, ratio 530) in one model converges with
//   relative criteria, and the slack IF carries nothing until 20 % strain, EA(ℓ/(1.2 L0) − 1)
//   after.
// REFERENCE: in series every element carries the same N; for end position X:
//   N = max(0, (X − Σ L_free,i)/Σ(L_free,i/EA_i)) with L_free,IF = 1.2·L0,IF; with N = 0 the
//   IF length is X − Σ_{others} L_free,i.
#[test]
fn truss_stiffness_range_chain_with_slack_filament_matches_series_closed_form() {
    let (x, lengths, laws) = chain();
    let pairs = [[0, 1], [1, 2], [2, 3], [3, 4]];
    let families = ["intermediate", "bundle", "actin", "microtubule"];
    let terms: Vec<Box<dyn Term>> = (0..4)
        .map(|i| {
            let set = TrussSet::new(families[i], families[i], &x, vec![pairs[i]], laws[i]);
            Box::new(set.unwrap()) as Box<dyn Term>
        })
        .collect();
    let ea: Vec<f64> = laws.iter().map(|l| l.axial_stiffness()).collect();
    assert!(ea[0] < 0.61 && ea[3] > 316.0, "EA range {ea:?}");
    let l_free: Vec<f64> = (0..4)
        .map(|i| laws[i].stress_free_length(lengths[i]))
        .collect();
    // Pull until the IF is at ℓ/L0 = 1.5: N = EA_IF·(1.5/1.2 − 1).
    let n_end = ea[0] * 0.25;
    let x_end: f64 = 1.5 * lengths[0]
        + (1..4)
            .map(|i| l_free[i] * (1.0 + n_end / ea[i]))
            .sum::<f64>();
    let x0_end = 14.0;
    let mut p = problem(5, terms);
    let mut step = Step::new("pull");
    step.prescribed = hold(&[0, 1, 2]);
    step.prescribed.push((12, Motion::To(x_end - x0_end)));
    for node in 1..5 {
        step.prescribed.extend(hold(&[3 * node + 1, 3 * node + 2]));
    }
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();

    let compliance: f64 = (0..4).map(|i| l_free[i] / ea[i]).sum();
    let (mut slack_states, mut taut_states) = (0, 0);
    for inc in &rec.increments {
        let x_now = x0_end + inc.u[12];
        let n = ((x_now - l_free.iter().sum::<f64>()) / compliance).max(0.0);
        let reaction = inc.reaction[12];
        assert!(
            (reaction - n).abs() <= 1e-8 * n_end,
            "X = {x_now}: reaction {reaction} vs {n}"
        );
        // IF length and force from the converged positions.
        let l_if = x[1][0] + inc.u[3];
        let ratio = l_if / lengths[0];
        if n == 0.0 {
            assert!(ratio <= 1.2, "slack IF at ratio {ratio}");
            let expected = x_now - (1..4).map(|i| l_free[i]).sum::<f64>();
            assert!(
                (l_if - expected).abs() < 1e-9 * x_now,
                "IF length {l_if} vs {expected}"
            );
            slack_states += 1;
        } else {
            let if_force = ea[0] * (ratio / 1.2 - 1.0);
            assert!(
                (if_force - n).abs() <= 1e-8 * n_end,
                "IF force {if_force} vs {n}"
            );
            taut_states += 1;
        }
    }
    assert!(
        slack_states >= 1 && taut_states >= 1,
        "{slack_states} slack, {taut_states} taut"
    );
    assert_eq!(rec.cutbacks, 0);
    let last = rec.increments.last().unwrap();
    assert!((last.reaction[12] - n_end).abs() <= 1e-8 * n_end);
}

// GOAL: the prestrain is ramped in over an analysis step (as the cell models' first step
// does). MESH: one AF between held nodes. REFERENCE: N(t) = EA·0.24·t during the step.
#[test]
fn truss_prestrain_ramps_in_linearly_over_its_step() {
    let x = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]];
    let mut set = TrussSet::new("af", "actin", &x, vec![[0, 1]], actin()).unwrap();
    set.ramp_prestrain_in_step(0);
    let mut p = problem(2, vec![Box::new(set)]);
    let mut step = Step::new("prestress");
    step.prescribed = hold(&[0, 1, 2, 3, 4, 5]);
    let mut rec = Recorder::default();
    p.run_step(&step, &mut rec).unwrap();
    let ea = actin().axial_stiffness();
    assert!(rec.increments.len() > 2);
    for c in &rec.increments {
        assert!(
            (c.reaction[3] - ea * 0.24 * c.time).abs() <= 1e-12 * ea,
            "t = {}",
            c.time
        );
    }
}
