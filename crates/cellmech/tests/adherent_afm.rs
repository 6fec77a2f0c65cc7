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
    let protocol = AfmIndentation {
        site,
        depths,
        max_increment: 0.5,
        ..AfmIndentation::default()
    };
    let result = run_coarse(protocol, dir);
    result.protocol().cloned().expect("AFM results")
}

/// Runs `protocol` on the coarse cell (0.3 µm at the site) in `dir`.
fn run_coarse(protocol: AfmIndentation, dir: &str) -> cellmech::experiment::ExperimentResult {
    let mut cell = coarse_cell();
    cell.params.refinement.element_size = 0.3;
    cell.params.refinement.fine_radius = 0.3;
    let mut experiment = Experiment::new(
        CellModel::Adherent(cell),
        Protocol::AfmIndentation(protocol),
    );
    experiment.output.vtk_every = 0;
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(dir);
    let _ = std::fs::remove_dir_all(&out);
    experiment.run(&out).expect("the coarse AFM test runs")
}

/// ALE rezoning under the tip (`rezone = "on"`, every 0.1 µm, `rezone_accept = "valid"`
/// so that it is applied even where the Lagrangian mesh is still good): the whole path
/// runs on the cell (sliding cortex and contact nodes, hanging nodes, the writer's mapped
/// reference state), every applied rezoning leaves all the elements it touches valid,
/// and the force stays on the Lagrangian curve within the coarse mesh's discretisation
/// error (measured 2026-12-06: 0.0557 against 0.0575 nN at 0.2 µm, −3.1 %): a rezoning
/// that lost or displaced material would show as a jump. The exactness of the mapping is
/// verified in `cellmech-fem/tests/rezone_verification.rs`; whether rezoning lets the tip
/// go deeper is measured in docs/rezoning.md (not yet: it does not).
#[test]
fn rezoning_under_the_tip_keeps_the_apex_curve() {
    let plain = indent(IndentationSite::Apex, vec![0.2], "afm-apex-lagrangian");
    let rezoned = run_coarse(
        AfmIndentation {
            site: IndentationSite::Apex,
            depths: vec![0.2],
            max_increment: 0.5,
            rezone: Some(cellmech::protocol::afm_indentation::Rezoning {
                radius: 2.0,
                every: 0.1,
                slide_surface: true,
                acceptance: cellmech_fem::rezone::Acceptance::Valid,
            }),
            ..AfmIndentation::default()
        },
        "afm-apex-rezoned",
    );
    let records = &rezoned.summary.rezonings;
    eprintln!("{records:#?}");
    assert_eq!(records.len(), 1, "rezoned once, after 0.1 µm");
    for r in records {
        assert!(
            r.nodes_moved > 100 && r.min_corner_ratio_after > 0.0 && r.unlocated == 0,
            "{r:?}"
        );
    }
    let force = |p: &cellmech::protocol::results::ProtocolResults| p.at_deformations[0].1.force_nn;
    let (a, b) = (
        force(&plain),
        force(rezoned.protocol().expect("AFM results")),
    );
    eprintln!("Lagrangian {a} nN, rezoned {b} nN");
    assert!(
        (b / a - 1.0).abs() < 0.05,
        "Lagrangian {a} nN, rezoned {b} nN"
    );
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("afm-apex-rezoned");
    assert_eq!(
        csv_column(&out.join("rezonings.csv"), "nodes_moved"),
        vec![records[0].nodes_moved as f64]
    );
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

/// The apex of the coarse cell stiffens like Hertz. At the receptor the tip comes down over
/// the FA where the prestress has put it (`aim = "prestressed"`): the AB pulls the FA about
/// 2 µm inwards, and the tip follows it there, touches the FA's plaque and is pushed back
/// more and more. Whether the receptor is stiffer than the apex is measured on the default
/// mesh (docs/adherent-cell.md): on this coarse one the plaque slides out from under the
/// tip beyond 0.27 µm (measured 2026-12-05: 0.0303 nN at 0.2 µm against the apex's 0.0575
/// nN), so the comparison is not asserted here. About 5 minutes on 2 cores.
#[test]
fn the_apex_stiffens_and_the_tip_follows_the_receptor_fa_in() {
    stiffening_forces(IndentationSite::Apex, "afm-apex");
    let dir = "afm-receptor";
    let r = indent(IndentationSite::Receptor, vec![0.1, 0.2], dir);
    let at: Vec<f64> = r.at_deformations.iter().map(|(_, p)| p.force_nn).collect();
    eprintln!("{dir}: {at:?}");
    assert_eq!(at.len(), 2, "both depths reached: {at:?}");
    assert!(at[0] > 0.005 && at[1] > 1.3 * at[0], "{at:?}");
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(dir);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let site_x = summary["cell"]["protocol"]["site_point"][0]
        .as_f64()
        .unwrap();
    let tip_x = *csv_column(&out.join("curve.csv"), "tip_displacement_x_um")
        .last()
        .unwrap();
    eprintln!("FA at x = {site_x} um in the reference; the tip moved {tip_x} um along x");
    assert!(
        site_x.abs() > 5.0 && tip_x * site_x < 0.0 && tip_x.abs() > 1.0,
        "the tip follows the FA inwards: site x {site_x}, tip moved {tip_x}"
    );
}

/// Inertia of the tangent at the end of each prestress increment of the coarse cell
/// (`increments.csv`, column `negative_pivots`).
fn prestress_negative_pivots(cell: AdherentCell, dir: &str) -> Vec<f64> {
    let mut experiment = Experiment::new(CellModel::Adherent(cell), Protocol::Prestress);
    experiment.output.vtk_every = 0;
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(dir);
    let _ = std::fs::remove_dir_all(&out);
    experiment.run(&out).expect("the coarse prestress runs");
    csv_column(&out.join("increments.csv"), "negative_pivots")
}

/// The values of the column `name` of the CSV file at `path`.
fn csv_column(path: &std::path::Path, name: &str) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let column = lines
        .next()
        .unwrap()
        .split(',')
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("{}: no column {name}", path.display()));
    lines
        .map(|l| l.split(',').nth(column).unwrap().parse().unwrap())
        .collect()
}

/// The prestressed cell is a stable equilibrium, not a saddle. The ABs pull their FAs in
/// and compress the 16 MTs; a free centrosome held only by those struts is then unstable
/// sideways, and Newton converges to it anyway: the tangent at every converged state has
/// one negative eigenvalue (measured on this mesh and on the default apex mesh). The
/// default ties the centrosome to the gel around it, and then none has
/// (docs/adherent-cell.md, "The centrosome tied by default").
#[test]
fn the_prestressed_adherent_cell_is_a_minimum_with_the_centrosome_tied_by_default() {
    let cell = coarse_cell();
    assert!(cell.coupling.centrosome_tied, "tied by default");
    let tied = prestress_negative_pivots(cell, "prestress-tied");
    eprintln!("tied: {tied:?}");
    assert!(!tied.is_empty());
    assert!(tied.iter().all(|&n| n == 0.0), "tied: {tied:?}");

    let mut free = coarse_cell();
    free.coupling.centrosome_tied = false;
    let free = prestress_negative_pivots(free, "prestress-free");
    eprintln!("free: {free:?}");
    assert_eq!(*free.last().unwrap(), 1.0, "free: {free:?}");
}
