//! The adherent cell and AFM indentation at the apex and at a receptor, on a coarse base
//! mesh (CI size): the layout is what the spec describes, the mesh is refined at the site,
//! and both sites give a stiffening force–indentation curve that differs between them.

use cellmech::cell::adherent::{AdherentCell, IndentationSite};
use cellmech::experiment::{CellModel, Experiment};
use cellmech::protocol::{AfmIndentation, Protocol};

/// A coarse cell (base 8/2/2: 2048 hex8; coarser bases crowd the 16 FAs) refined to
/// 0.15 µm within 0.6 µm of the site, growing 1:1 beyond (the default refinement before
/// 2026-12-05: CI size).
fn coarse_cell() -> AdherentCell {
    let mut cell = AdherentCell::default();
    cell.params.mesh.core_divisions = 8;
    cell.params.mesh.shell_layers = 2;
    cell.params.mesh.outer_layers = 2;
    cell.params.refinement.element_size = 0.15;
    cell.params.refinement.fine_radius = 0.6;
    cell.params.refinement.grading = 1.0;
    cell
}

#[test]
fn the_layout_follows_the_spec_and_the_mesh_is_refined_at_the_site() {
    for site in [IndentationSite::Apex, IndentationSite::Receptor] {
        let mut cell = coarse_cell();
        cell.site = Some(site);
        let built = cell.build().expect("the coarse adherent cell builds");
        let g = &built.description.geometry;
        let mesh = &built.model.mesh;
        let fas = &mesh.node_sets["focal_adhesions"];
        assert_eq!(fas.len(), 16, "8 bundles, 2 FAs each");
        // Every FA on the dome, off the substrate; every base node on z = 0.
        for &n in fas {
            assert!(mesh.nodes[n][2] > 0.5, "FA {n} at {:?}", mesh.nodes[n]);
        }
        for &n in &mesh.node_sets["bottom"] {
            assert!(mesh.nodes[n][2].abs() < 1e-12);
        }
        let s = &built.model.structures;
        let count = |name: &str| {
            s.filaments
                .iter()
                .find(|f| f.name == name)
                .map(|f| f.filaments.len())
                .unwrap()
        };
        assert_eq!(count("bundles"), 8);
        assert_eq!(count("microtubule"), 16);
        assert_eq!(count("intermediate"), 32);
        // The refinement reached the wanted size and left tied hanging nodes.
        let min_edge = g["mesh"]["min_edge"].as_f64().unwrap();
        assert!(min_edge < 0.16, "smallest edge {min_edge} µm");
        assert!(!built.model.hanging.is_empty());
        assert!(g["mesh"]["min_scaled_jacobian"].as_f64().unwrap() > 0.05);
        let (point, normal) = built.site.expect("a site");
        match site {
            IndentationSite::Apex => {
                assert!((point[2] - 8.0).abs() < 1e-9 && point[0].abs() < 1e-9);
                // Between FAs: ABs on both sides of y = 0.
                let ys: Vec<f64> = fas.iter().map(|&n| mesh.nodes[n][1]).collect();
                assert!(ys.iter().any(|&y| y > 0.0) && ys.iter().any(|&y| y < 0.0));
            }
            IndentationSite::Receptor => {
                assert!(fas.iter().any(|&n| mesh.nodes[n] == point));
                assert!(normal[2] > 0.5, "the receptor is indentable from above");
            }
            IndentationSite::Point { .. } => unreachable!(),
        }
    }
}

#[test]
fn bad_sites_and_tips_are_clear_errors_before_solving() {
    let mut cell = coarse_cell();
    cell.site = Some(IndentationSite::Point { x: 30.0, y: 0.0 });
    let e = cell.build().unwrap_err().to_string();
    assert!(e.contains("off the cell"), "{e}");
    let mut protocol = AfmIndentation::default();
    protocol.tip_radius = 20.0;
    let experiment = Experiment::new(
        CellModel::Adherent(coarse_cell()),
        Protocol::AfmIndentation(protocol),
    );
    let e = experiment.analysis().unwrap_err().to_string();
    assert!(
        e.contains("tip_radius") && e.contains("smaller than the cell"),
        "{e}"
    );
    let mut protocol = AfmIndentation::default();
    protocol.depths = vec![1.0, 9.0];
    let experiment = Experiment::new(
        CellModel::Adherent(coarse_cell()),
        Protocol::AfmIndentation(protocol),
    );
    let e = experiment.analysis().unwrap_err().to_string();
    assert!(e.contains("shallower than the cell"), "{e}");
    // AFM on the suspended cell: no site.
    let experiment = Experiment::new(
        CellModel::Suspended(Default::default()),
        Protocol::AfmIndentation(AfmIndentation::default()),
    );
    let e = experiment.analysis().unwrap_err().to_string();
    assert!(e.contains("adherent"), "{e}");
}

#[test]
fn the_contact_tangent_key_reaches_the_tip() {
    use cellmech_fem::contact::CurvatureTangent;
    let tip_tangent = |protocol: AfmIndentation| {
        let experiment = Experiment::new(
            CellModel::Adherent(coarse_cell()),
            Protocol::AfmIndentation(protocol),
        );
        let analysis = experiment.analysis().unwrap();
        let tip = analysis
            .model
            .tools
            .iter()
            .find(|t| t.name == "tip")
            .unwrap();
        tip.curvature_tangent
    };
    assert_eq!(
        tip_tangent(AfmIndentation::default()),
        CurvatureTangent::Lagged
    );
    let mut consistent = AfmIndentation::default();
    consistent.contact_tangent = CurvatureTangent::Consistent;
    assert_eq!(tip_tangent(consistent), CurvatureTangent::Consistent);
}

/// Runs the coarse cell's AFM test at `site` to `depth` (µm) and returns the results.
fn indent(
    site: IndentationSite,
    depths: Vec<f64>,
    dir: &str,
) -> cellmech::protocol::results::ProtocolResults {
    let mut cell = coarse_cell();
    cell.params.refinement.element_size = 0.3;
    cell.params.refinement.fine_radius = 0.3;
    let protocol = AfmIndentation {
        site,
        depths,
        max_increment: 0.5,
        ..AfmIndentation::default()
    };
    let mut experiment = Experiment::new(
        CellModel::Adherent(cell),
        Protocol::AfmIndentation(protocol),
    );
    experiment.output.vtk_every = 0;
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(dir);
    let _ = std::fs::remove_dir_all(&out);
    let result = experiment.run(&out).expect("the coarse AFM test runs");
    result.protocol().cloned().expect("AFM results")
}

/// Force at each depth of a coarse AFM run, checked for a stiffening, Hertz-like curve.
fn stiffening_forces(site: IndentationSite, dir: &str) -> Vec<f64> {
    let r = indent(site, vec![0.2, 0.4], dir);
    let at: Vec<(f64, f64)> = r
        .at_deformations
        .iter()
        .map(|(d, p)| (*d, p.force_nn))
        .collect();
    eprintln!("{dir}: {at:?}, fit {:?}", r.apparent_modulus);
    assert_eq!(at.len(), 2, "{dir}: both depths reached");
    let (f1, f2) = (at[0].1, at[1].1);
    // Stiffening: doubling the depth more than doubles the force (Hertz: 2^1.5 = 2.83).
    assert!(
        f1 > 0.0 && f2 > 2.2 * f1,
        "{dir}: F(0.2) = {f1}, F(0.4) = {f2}"
    );
    // A fraction of a nN at these depths: Hertz on the cytoplasm alone (E = 0.5 kPa) gives
    // 0.05 nN at 0.4 µm under a 200 nm tip; the cortex and the cytoskeleton add to it.
    assert!(f2 > 0.02 && f2 < 2.0, "{dir}: F(0.4) = {f2} nN");
    let fit = r
        .apparent_modulus
        .clone()
        .expect("a fit")
        .expect("the fit succeeds");
    assert!(
        fit.young_modulus_kpa > 0.3 && fit.young_modulus_kpa < 20.0,
        "{fit:?}"
    );
    vec![f1, f2]
}

/// Both sites on the coarse cell: each curve stiffens like Hertz, and the receptor (an FA,
/// where the load goes straight into the bundle) is stiffer than the apex, as published
/// (measured 2026-12-04: 0.0579 / 0.1419 nN at the apex, 0.0775 / 0.1871 nN at the
/// receptor at 0.2 / 0.4 µm: 1.32 times). About 5 minutes on 2 cores: at the receptor the
/// prestress needs 23 increments (154 iterations) and the approach finds the FA plaque
/// only after the tip has travelled 1.7 µm (the AB pulls the FA in).
#[test]
fn both_sites_stiffen_and_the_receptor_is_stiffer_than_the_apex() {
    let apex = stiffening_forces(IndentationSite::Apex, "afm-apex");
    let receptor = stiffening_forces(IndentationSite::Receptor, "afm-receptor");
    let ratio = receptor[1] / apex[1];
    eprintln!("receptor / apex at 0.4 µm: {ratio:.3}");
    assert!(ratio > 1.1, "the receptor is stiffer: ratio {ratio}");
}
