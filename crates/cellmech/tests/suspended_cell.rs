//! The suspended-cell model finds its prestressed equilibrium.
//!
//! GOAL: the first step of every suspended-cell analysis. MESH: the default geometry
//! (6912 hex8, 30 FAs as 3.5 µm plaques, 60 AFs, 30 MTs of 8 beams, 60 IFs). BCS: 3-2-1 supports on nucleus
//! nodes. REFERENCE: self-equilibrium: the supports carry no load (relative to the AF
//! forces); the AFs lose part of their initial prestress force EA·0.24 as the cell
//! contracts at the FAs; FAs move inward.

use cellmech::cell::suspended::{
    build_suspended_cell, prestress_step, Components, SuspendedCellMaterials,
};
use cellmech::cell::SuspendedCellParams;
use cellmech_fem::linsolve::FaerSparseSolver;
use cellmech_fem::solve::{NullObserver, Problem};

#[test]
fn suspended_cell_finds_its_prestressed_equilibrium_with_unloaded_supports() {
    let model = build_suspended_cell(
        &SuspendedCellParams::default(),
        &SuspendedCellMaterials::default(),
        Components::default(),
    )
    .unwrap();
    let step = prestress_step(&model);
    let supports = model.supports.clone();
    let fa_nodes = model.geometry.fa_nodes.clone();
    let nodes = model.mesh.nodes.clone();
    // With the default FA plaques the model carries their ties (30 reference nodes).
    assert!(model.constraints.is_some());
    let mut p = model
        .problem(Box::new(FaerSparseSolver::default()))
        .unwrap();
    let start = std::time::Instant::now();
    p.run_step(&step, &mut NullObserver).unwrap();
    let elapsed = start.elapsed().as_secs_f64();
    let support_force = supports
        .iter()
        .map(|&d| p.reaction(d).abs())
        .fold(0.0, f64::max);
    let ea = 2.6e6 * std::f64::consts::PI * 0.007f64.powi(2) / 4.0;
    let inward: Vec<f64> = fa_nodes
        .iter()
        .map(|&n| {
            let x = nodes[n];
            let r = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
            -(0..3)
                .map(|k| p.u()[p.dof_map().dof(n, k)] * x[k] / r)
                .sum::<f64>()
        })
        .collect();
    let actin = p.terms().iter().find(|t| t.name() == "actin").unwrap();
    let out = actin.outputs(p.u(), p.dof_map()).unwrap().unwrap();
    let forces = &out
        .fields
        .iter()
        .find(|f| f.name == "axial_force_nN")
        .unwrap()
        .values;
    let (fmin, fmax) = forces
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &f| (a.min(f), b.max(f)));
    eprintln!(
        "prestress: {elapsed:.1} s; support reaction max {support_force:.2e} nN; FA inward displacement {:.3}..{:.3} um; AF force {fmin:.2}..{fmax:.2} nN (EA*0.24 = {:.2})",
        inward.iter().cloned().fold(f64::MAX, f64::min),
        inward.iter().cloned().fold(f64::MIN, f64::max),
        ea * 0.24
    );
    assert!(
        support_force < 1e-6 * ea * 0.24,
        "supports carry {support_force} nN"
    );
    assert!(
        inward.iter().all(|&d| d > 0.0),
        "every FA moves inward: {inward:?}"
    );
    assert!(
        fmax < ea * 0.24 && fmin > 0.0,
        "AFs stay in tension below their initial force"
    );
}

#[test]
#[ignore = "exploratory: the tension protocol on the default cell (minutes)"]
fn suspended_cell_tension_protocol_runs() {
    use cellmech_fem::contact::{ContactKind, RigidContact, ToolShape};
    use cellmech_fem::solve::{Monitor, Motion, Step, StopCondition};
    use cellmech_fem::term::Term;
    let params = SuspendedCellParams::default();
    let mut model = build_suspended_cell(
        &params,
        &SuspendedCellMaterials::default(),
        Components::default(),
    )
    .unwrap();
    let radius = 0.5 * params.cell_diameter;
    let surface = model.mesh.node_sets["surface"].clone();
    let pipette_radius = 4.0;
    // Measured on this machine (350 s): contact force -18.2 nN, zero-force reference state
    // found to 1e-6 nN, 55.4 nN at 6.3 um (normalised stiffness 0.35 kPa).
    let (retract_max, stretch) = (5.3, 6.3);
    // Pipettes end-on at the poles on the x axis, just touching the undeformed surface;
    // the prestressed cell is smaller, so they first close the gap (step 2).
    let pipette = |name: &str, side: f64, program: Vec<[f64; 3]>| -> Box<dyn Term> {
        let nodes: Vec<usize> = surface
            .iter()
            .copied()
            .filter(|&n| model.mesh.nodes[n][0] * side > 0.5 * radius)
            .collect();
        let reference = nodes.iter().map(|&n| model.mesh.nodes[n]).collect();
        let shape = ToolShape::Disk {
            center: [side * radius, 0.0, 0.0],
            normal: [-side, 0.0, 0.0],
            radius: pipette_radius,
        };
        Box::new(
            RigidContact::new(
                name,
                shape,
                ContactKind::Bonded,
                nodes,
                reference,
                5.0,
                1e-4,
                program,
            )
            .unwrap(),
        )
    };
    // Programs: step 0 prestress (hold), step 1 pinch to contact, step 2 retract moving
    // pipette (+x) until zero force, step 3 stretch.
    let close = 2.5; // the FA poles moved in by about 2.2 um: close the gap and press
    model.terms.push(pipette(
        "fixed",
        -1.0,
        vec![
            [0.0; 3],
            [close, 0.0, 0.0],
            [close, 0.0, 0.0],
            [close, 0.0, 0.0],
        ],
    ));
    model.terms.push(pipette(
        "moving",
        1.0,
        vec![
            [0.0; 3],
            [-close, 0.0, 0.0],
            [-close + retract_max, 0.0, 0.0],
            [-close + retract_max + stretch, 0.0, 0.0],
        ],
    ));
    let supports = model.supports.clone();
    let mut p = model
        .problem(Box::new(FaerSparseSolver::default()))
        .unwrap();
    let mut s0 = Step::new("prestress");
    s0.prescribed = supports.iter().map(|&d| (d, Motion::Hold)).collect();
    p.run_step(&s0, &mut NullObserver).unwrap();
    let mut s1 = Step::new("contact");
    s1.prescribed = s0.prescribed.clone();
    p.run_step(&s1, &mut NullObserver).unwrap();
    let force = |p: &Problem| {
        p.monitor(&Monitor::TermScalar("moving_force_x_nN".into()))
            .unwrap()
    };
    eprintln!(
        "after contact: moving pipette force x = {:.3} nN",
        force(&p)
    );
    let mut s2 = Step::new("retract");
    s2.stop = Some(StopCondition {
        monitor: Monitor::TermScalar("moving_force_x_nN".into()),
        target: 0.0,
        tolerance: 1e-3,
        known_before_solving: false,
    });
    p.run_step(&s2, &mut NullObserver).unwrap();
    eprintln!("reference state: force {:.2e} nN", force(&p));
    let mut s3 = Step::new("stretch");
    s3.control.max_increment = 0.1;
    p.run_step(&s3, &mut NullObserver).unwrap();
    let f = force(&p);
    let d = 2.0 * radius;
    eprintln!(
        "stretch {stretch} um: force {f:.2} nN, normalised stiffness {:.3} kPa",
        f / (std::f64::consts::PI * d * d / 4.0) / (stretch / d)
    );
    assert!(f > 0.0);
}
