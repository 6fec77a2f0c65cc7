//! The suspended-cell model finds its prestressed equilibrium.
//!
//! GOAL: the first step of every suspended-cell analysis. MESH: the default geometry
//! (2816 hex8, 30 FAs, 60 AFs, 30 MTs of 8 beams, 60 IFs). BCS: 3-2-1 supports on nucleus
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
    let mut p = Problem::new(
        model.dof_map,
        model.terms,
        Box::new(FaerSparseSolver::default()),
    )
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
