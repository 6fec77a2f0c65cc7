//! A locally refined mesh through the model layer: `ModelSpec::hanging` becomes exact ties in
//! `model::build`, combined with an embedding whose hosts have hanging corners.
//!
//! GOAL: node-set boundary conditions on sets holding hanging nodes, a slack embedded truss
//! through refined elements, and the hanging-node count in `summary.json`.
//! MODEL: block [0, 4] × [0, 3] × [0, 2] (4 × 3 × 2 hex8, neo-Hookean G = 0.5 kPa, ν = 0.4),
//! refined by 2 levels around (2, 1.5, 2) and around (4, 1.5, 1) (hanging nodes inside, on
//! the top and on the loaded face x = 4); faces x = 0, y = 0, z = 0 on rollers, face x = 4
//! moved by 0.4 µm (stretch 1.1); a tension-only truss chain with 50 % slack embedded
//! through the refined region (it stays slack, so it must not change anything).
//! REFERENCE: homogeneous uniaxial stress, `verify::analytic::uniaxial_stress`: every node
//! (hanging, embedded or not) on u = ((λ−1)x, (μ−1)y, (μ−1)z) and the x = 4 reaction P·A.

use cellmech::analysis::Analysis;
use cellmech::model::filament::Filament;
use cellmech::model::structures::{FilamentElement, FilamentSpec, StructuresSpec};
use cellmech::model::{
    build, BuildError, CurveSpec, EmbedSpec, MaterialAssignment, ModelSpec, OutputSpec, StepSpec,
};
use cellmech_fem::element::hex8::Hex8Formulation;
use cellmech_fem::material::{AxialLaw, NeoHookean};
use cellmech_fem::mesh::generate::box_mesh;
use cellmech_fem::mesh::locate::HostLocator;
use cellmech_fem::mesh::refine::refine_hex8;
use cellmech_fem::solve::{NullObserver, StepControl};
use cellmech_fem::verify::analytic::uniaxial_stress;

const STRETCH: f64 = 1.1;

fn law() -> NeoHookean {
    NeoHookean::from_shear_poisson(0.5, 0.4).unwrap()
}

fn distance_to_cell(x: &[[f64; 3]; 8], p: [f64; 3]) -> f64 {
    (0..3)
        .map(|k| {
            let lo = x.iter().map(|q| q[k]).fold(f64::INFINITY, f64::min);
            let hi = x.iter().map(|q| q[k]).fold(f64::NEG_INFINITY, f64::max);
            (lo - p[k]).max(p[k] - hi).max(0.0).powi(2)
        })
        .sum::<f64>()
        .sqrt()
}

fn model() -> (ModelSpec, usize) {
    let coarse = box_mesh([0.0; 3], [4.0, 3.0, 2.0], [4, 3, 2], "cube").unwrap();
    let refined = refine_hex8(&coarse, |x| {
        let near = |p: [f64; 3]| distance_to_cell(x, p) < 0.6;
        if near([2.0, 1.5, 2.0]) || near([4.0, 1.5, 1.0]) {
            2
        } else {
            0
        }
    })
    .unwrap();
    let mut mesh = refined.mesh;
    // A straight chain of 16 trusses through the refined region.
    let first = mesh.num_nodes();
    let (a, b) = ([0.3, 0.41, 1.93], [3.97, 2.2, 0.77]);
    for i in 0..=16 {
        let t = i as f64 / 16.0;
        mesh.nodes
            .push(std::array::from_fn(|k| a[k] + t * (b[k] - a[k])));
    }
    let bar: Vec<usize> = (first..mesh.num_nodes()).collect();
    mesh.insert_node_set("bar", bar.clone());
    let pairs: Vec<[usize; 2]> = bar.windows(2).map(|w| [w[0], w[1]]).collect();
    let structures = StructuresSpec {
        filaments: vec![FilamentSpec {
            name: "bar".into(),
            family: "bar".into(),
            filaments: Filament::chains(&pairs),
            pairs,
            element: FilamentElement::Truss(AxialLaw::tension_only(1.0e3, 0.01).with_slack(0.5)),
            enabled: true,
        }],
        membranes: Vec::new(),
    };
    let x = [true, false, false];
    let y = [false, true, false];
    let z = [false, false, true];
    let step = StepSpec {
        name: "stretch".into(),
        control: StepControl {
            initial_increment: 0.5,
            max_increment: 0.5,
            ..StepControl::default()
        },
        fixes: vec![
            ("x_min".into(), x),
            ("y_min".into(), y),
            ("z_min".into(), z),
        ],
        displacements: vec![("x_max".into(), 0, 4.0 * (STRETCH - 1.0))],
        forces: Vec::new(),
        tools: Vec::new(),
    };
    let hanging = refined.hanging.len();
    let spec = ModelSpec {
        mesh,
        materials: vec![MaterialAssignment {
            element_set: "cube".into(),
            law: law(),
            formulation: Hex8Formulation::MeanDilatation,
        }],
        structures,
        tools: Vec::new(),
        steps: vec![step],
        output: OutputSpec {
            curves: vec![CurveSpec {
                name: "pull".into(),
                node_set: "x_max".into(),
                component: 0,
                sign: 1.0,
            }],
            vtk_every: 0,
            ..OutputSpec::default()
        },
        supports: Vec::new(),
        shape_probes: Vec::new(),
        embedded: vec![EmbedSpec {
            radius: 0.0,
            name: "bar".into(),
            node_set: "bar".into(),
            host_blocks: vec!["cube".into()],
            tolerance: 1e-9,
            foundation_modulus: None,
        }],
        hanging: refined.hanging,
        prestressed_reference: None,
        rezone: None,
    };
    (spec, hanging)
}

#[test]
fn refined_model_with_hanging_and_embedded_nodes_reproduces_uniaxial_stress() {
    let (spec, hanging) = model();
    let on_x_max = spec
        .hanging
        .iter()
        .filter(|h| spec.mesh.node_sets["x_max"].contains(&h.node))
        .count();
    println!(
        "refined model: {} elements, {} nodes, {hanging} hanging ({on_x_max} on x = 4)",
        spec.mesh.num_elements(),
        spec.mesh.num_nodes()
    );
    assert!(on_x_max > 0, "the loaded face has hanging nodes");
    let locator = HostLocator::new(&spec.mesh, &["cube"]).unwrap();
    let tied: Vec<usize> = spec.hanging.iter().map(|h| h.node).collect();
    let next_to_hanging = spec.mesh.node_sets["bar"]
        .iter()
        .filter(|&&n| {
            let host = locator.locate(spec.mesh.nodes[n], 1e-9).unwrap();
            host.nodes.iter().any(|c| tied.contains(c))
        })
        .count();
    assert!(
        next_to_hanging > 0,
        "some bar nodes lie in hosts with hanging corners"
    );
    let state = uniaxial_stress(&law(), STRETCH).unwrap();
    let mu = state.free_stretch;
    // In-process: every node on the exact field.
    let mut built = build(&spec).unwrap();
    assert_eq!(built.hanging_nodes, hanging);
    assert_eq!(built.embedding[0].embedded_nodes, 17);
    assert_eq!(
        built.problem.num_constrained_dofs(),
        3 * (hanging + 17),
        "3 ties per hanging and per embedded node"
    );
    // Full Newton to round-off (no chord steps near convergence, which stop once the
    // residual meets its 1e-8 tolerance: a few 1e-9 µm here), so that the field is checked
    // at the discretisation's exactness, not at the solver's tolerance.
    let mut step = built.steps[0].clone();
    step.control.convergence.chord_near_convergence = false;
    built.problem.run_step(&step, &mut NullObserver).unwrap();
    let u = built.problem.u();
    let map = built.problem.dof_map();
    let mut worst: f64 = 0.0;
    for (n, p) in spec.mesh.nodes.iter().enumerate() {
        let exact = [(STRETCH - 1.0) * p[0], (mu - 1.0) * p[1], (mu - 1.0) * p[2]];
        for k in 0..3 {
            worst = worst.max((u[map.dof(n, k)] - exact[k]).abs());
        }
    }
    println!("largest deviation from the homogeneous field: {worst:.1e} µm");
    assert!(worst < 1e-10, "field off by {worst:e}");
    // Through the runner: reaction and summary.
    let dir = std::env::temp_dir().join(format!("cellmech-refined-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // Full Newton to round-off here too (the reaction is checked to 1e-9; chord steps stop
    // at the residual tolerance, 1e-8 of a force scale that includes the internal forces,
    // which left it 2.7e-8 off).
    let mut spec = spec;
    spec.steps[0].control.convergence.chord_near_convergence = false;
    let analysis = Analysis {
        title: "refined block".into(),
        origin: "<test>".into(),
        model: spec,
        cell: None,
        echo: toml::Table::new(),
    };
    let summary = cellmech::run::run(&analysis, &dir, &mut NullObserver).unwrap();
    assert_eq!(summary.size.hanging_nodes, hanging);
    let json = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    assert!(
        json.contains(&format!("\"hanging_nodes\": {hanging}")),
        "summary.json"
    );
    let reaction = summary.final_values["pull_fx_nN"];
    let exact = state.nominal * 3.0 * 2.0;
    println!("x = 4 reaction {reaction:.12} nN, P·A {exact:.12} nN");
    assert!(
        (reaction - exact).abs() < 1e-9 * exact,
        "{reaction} vs {exact}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn refined_model_rejects_a_hanging_node_prescribed_without_its_masters_and_spreads_loads() {
    let (mut spec, _) = model();
    // A set with one hanging node but none of its masters cannot be held.
    let lonely = spec.hanging[0].node;
    spec.mesh.insert_node_set("lonely", vec![lonely]);
    spec.steps[0].fixes.push(("lonely".into(), [true; 3]));
    let e = build(&spec).err().unwrap();
    assert!(matches!(e, BuildError::TiedNodePrescribed { .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains(&format!("node {lonely} is tied")) && text.contains("masters"),
        "{text}"
    );
    // A force on a set with hanging nodes goes to their masters, same total.
    spec.steps[0].fixes.pop();
    spec.steps[0].displacements.clear();
    spec.steps[0].forces.push(("x_max".into(), 0, 2.5));
    let built = build(&spec).unwrap();
    let constraints = built.problem.constraints().unwrap();
    let loads = &built.steps[0].loads;
    assert!(loads.iter().all(|l| !constraints.is_slave(l.dof)));
    let total: f64 = loads.iter().map(|l| l.value).sum();
    assert!((total - 2.5).abs() < 1e-12, "total load {total}");
}
