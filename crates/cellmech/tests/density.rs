//! Density variants of the suspended cell (`[cell] density.*`) through the scenario layer,
//! on the coarse cell of the CI tests (448 hex8: core_divisions 4, 2 + 2 layers).
//!
//! GOAL: the spec's density study ("more AFs/IFs in the cell interior at new orientations,
//! more MTs from the centrosome to randomly chosen surface nodes"). MESH: the coarse
//! suspended cell (30 FAs, 60 AFs, 30 MTs, 60 IFs) plus 30 extra filaments of one family.
//! BCS: the built-in micropipette tensile test (cap grip) to 6.3 µm. REFERENCE: qualitative:
//! 30 more prestressed AFs stiffen the cell (each pulls 24 nN between two surface nodes);
//! the extra filaments are in the per-filament outputs of their family; zero extras are the
//! published model, digit for digit; bad counts are errors naming the key.

use std::path::PathBuf;

use cellmech::run::{run, RunSummary};
use cellmech::scenario::{parse, Scenario, ScenarioError};
use cellmech_fem::solve::NullObserver;

const COARSE_CELL: &str = "[cell]\ncore_divisions = 4\nshell_layers = 2\nouter_layers = 2\n";

fn scenario(density: &str) -> Result<Scenario, ScenarioError> {
    let text = format!(
        "title = \"density\"\n{COARSE_CELL}{density}\n[protocol]\nkind = \"micropipette-tension\"\n\n[output]\nvtk_every = 0\n"
    );
    parse(&text, "test.toml", std::path::Path::new("."))
}

fn out_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cellmech-density-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn run_case(name: &str, density: &str) -> RunSummary {
    let s = scenario(density).unwrap_or_else(|e| panic!("{name}: {e}"));
    let dir = out_dir(name);
    let summary = run(&s, &dir, &mut NullObserver).unwrap_or_else(|e| panic!("{name}: {e}"));
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(summary.status, "completed", "{name}: {:?}", summary.error);
    summary
}

/// Force at the end of the stretch (nN) and the number of filaments of each family.
fn force_and_counts(s: &RunSummary) -> (f64, Vec<(String, usize)>) {
    let curve = &s.protocol.as_ref().expect("protocol results").curve;
    let last = curve.last().expect("a curve");
    assert!((last.displacement_um - 6.3).abs() < 1e-9);
    let counts = s
        .filaments
        .as_ref()
        .expect("filaments")
        .families
        .iter()
        .map(|f| (f.family.clone(), f.filaments))
        .collect();
    (last.force_nn, counts)
}

fn counts(actin: usize, microtubule: usize, intermediate: usize) -> Vec<(String, usize)> {
    vec![
        ("actin".into(), actin),
        ("microtubule".into(), microtubule),
        ("intermediate".into(), intermediate),
    ]
}

#[test]
fn thirty_extra_filaments_of_each_family_run_and_extra_actin_stiffens_the_cell() {
    let (control, c) = force_and_counts(&run_case("control", ""));
    assert_eq!(c, counts(60, 30, 60));
    // Zero extras written out are the published model, digit for digit.
    let (zero, _) = force_and_counts(&run_case(
        "zero",
        "density.extra_actin = 0\ndensity.extra_microtubules = 0\ndensity.extra_intermediate = 0\n",
    ));
    assert_eq!(zero.to_bits(), control.to_bits());
    let (actin, c) = force_and_counts(&run_case("actin", "density.extra_actin = 30\n"));
    assert_eq!(c, counts(90, 30, 60));
    let (mts, c) = force_and_counts(&run_case("mts", "density.extra_microtubules = 30\n"));
    assert_eq!(c, counts(60, 60, 60));
    let (ifs, c) = force_and_counts(&run_case("ifs", "density.extra_intermediate = 30\n"));
    assert_eq!(c, counts(60, 30, 90));
    eprintln!(
        "force at 6.3 um (coarse): control {control:.3} nN, +30 AF {actin:.3}, +30 MT {mts:.3}, \
         +30 IF {ifs:.3}"
    );
    // Measured: 92.35, 125.50, 92.36, 92.41 nN.
    assert!(
        actin > 1.2 * control,
        "30 more prestressed AFs: {actin} nN vs control {control} nN"
    );
    // Free MTs and slack IFs add little, and never take stiffness away.
    for (name, f) in [("MT", mts), ("IF", ifs)] {
        assert!(
            f >= control * (1.0 - 1e-6) && f < 1.1 * control,
            "+30 {name}: {f} nN vs control {control} nN"
        );
    }
}

#[test]
fn extra_microtubules_follow_the_coupling_mode() {
    // Embedded MTs: the extra MTs' interior nodes join the embedding like the FA MTs'.
    let s =
        scenario("density.extra_microtubules = 10\n[cell.microtubules]\ncoupling = \"embedded\"\n")
            .unwrap();
    let plain = scenario("[cell.microtubules]\ncoupling = \"embedded\"\n").unwrap();
    let anchors = |s: &Scenario| s.model.mesh.node_sets["microtubule_anchors"].len();
    // 8 elements per MT: interior nodes 1..7, every second counted from the FA (3 per MT).
    assert_eq!(anchors(&s), anchors(&plain) + 10 * 3);
    assert_eq!(
        s.model.mesh.node_sets["extra_microtubule_ends"].len(),
        10,
        "node set of the extra MTs' surface ends"
    );
}

#[test]
fn bad_density_counts_are_errors_naming_the_key() {
    let message = |density: &str| match scenario(density) {
        Ok(_) => panic!("accepted: {density}"),
        Err(e) => e.to_string(),
    };
    let e = message("density.extra_actin = -3\n");
    assert!(e.contains("density.extra_actin") && e.contains("-3"), "{e}");
    let e = message("density.extra_microtubules = 2.5\n");
    assert!(e.contains("density.extra_microtubules"), "{e}");
    let e = message("density.extra_intermediate = 20000\n");
    assert!(e.contains("density.extra_intermediate"), "{e}");
    let e = message("density.extra_actins = 3\n");
    assert!(e.contains("did you mean"), "{e}");
    // More than the coarse mesh has room for: 68 non-FA surface nodes.
    let e = message("density.extra_actin = 40\n");
    assert!(
        e.contains("cell.density.extra_actin") && e.contains("at most"),
        "{e}"
    );
    let e = message("density.extra_microtubules = 100\n");
    assert!(e.contains("cell.density.extra_microtubules"), "{e}");
}

/// The adherent cell's base mesh of the CI tests (8/2/2: 2048 hex8), no refinement.
fn adherent(extra: usize, seed: u64) -> cellmech::cell::adherent::AdherentCellParams {
    let mut cell = cellmech::cell::adherent::AdherentCell::default();
    cell.params.mesh.core_divisions = 8;
    cell.params.mesh.shell_layers = 2;
    cell.params.mesh.outer_layers = 2;
    cell.params.extra_bundles = extra;
    cell.params.seed = seed;
    cell.params
}

#[test]
fn extra_actin_bundles_are_seeded_chords_between_new_dome_nodes_clear_of_the_nucleus() {
    use cellmech::cell::adherent::AdherentCellGeometry;
    let build = |extra, seed| AdherentCellGeometry::build(&adherent(extra, seed), None);
    let g = build(12, 2024).unwrap();
    assert_eq!(g.extra_bundles.len(), 12);
    let base = build(0, 2024).unwrap();
    assert!(base.extra_bundles.is_empty());
    assert!(!base.mesh.node_sets.contains_key("extra_bundle_ends"));
    assert_eq!(g.bundles, base.bundles);
    assert_eq!(g.fa_nodes, base.fa_nodes);
    let params = adherent(12, 2024);
    let shape = params.shape;
    let (c, e) = (shape.nucleus_centre(), shape.nucleus_semi_axes);
    let inside_nucleus =
        |p: [f64; 3]| (0..3).map(|k| ((p[k] - c[k]) / e[k]).powi(2)).sum::<f64>() < 1.0;
    let dome: std::collections::BTreeSet<usize> =
        g.mesh.node_sets["dome"].iter().copied().collect();
    let mut used = std::collections::BTreeSet::new();
    let shortest = base
        .bundles
        .iter()
        .map(|&[a, b]| dist(base.mesh.nodes[a], base.mesh.nodes[b]))
        .fold(f64::INFINITY, f64::min);
    for &[a, b] in &g.extra_bundles {
        for n in [a, b] {
            assert!(
                dome.contains(&n) && g.mesh.nodes[n][2] > 0.0,
                "node {n} not on the dome"
            );
            assert!(!g.fa_nodes.contains(&n), "node {n} is an FA");
            assert!(used.insert(n), "node {n} reused");
        }
        let (pa, pb) = (g.mesh.nodes[a], g.mesh.nodes[b]);
        assert!(dist(pa, pb) >= 0.5 * shortest);
        for i in 0..=200 {
            let t = i as f64 / 200.0;
            let p = [0, 1, 2].map(|k| pa[k] + t * (pb[k] - pa[k]));
            assert!(!inside_nucleus(p), "AB {a}-{b} enters the nucleus");
            assert!(
                shape.level(p) <= 1.0 + 1e-9 && p[2] >= 0.0,
                "AB {a}-{b} leaves the cell"
            );
        }
    }
    // Reproducible, and another seed gives other bundles.
    assert_eq!(build(12, 2024).unwrap().extra_bundles, g.extra_bundles);
    assert_ne!(build(12, 7).unwrap().extra_bundles, g.extra_bundles);
    // Too many: an error naming the key.
    let err = build(2000, 2024).unwrap_err().to_string();
    assert!(
        err.contains("cell.bundles.extra") && err.contains("at most"),
        "{err}"
    );
}

#[test]
fn extra_adherent_microtubules_and_intermediate_filaments_are_seeded_and_clear_of_the_nucleus() {
    use cellmech::cell::adherent::AdherentCellGeometry;
    let with = |bundles, mts, ifs, seed| {
        let mut p = adherent(bundles, seed);
        p.extra_microtubules = mts;
        p.extra_intermediate = ifs;
        p
    };
    let build =
        |bundles, mts, ifs, seed| AdherentCellGeometry::build(&with(bundles, mts, ifs, seed), None);
    let base = build(0, 0, 0, 2024).unwrap();
    assert!(base.extra_microtubules.is_empty() && base.extra_intermediate.is_empty());
    let g = build(4, 10, 12, 2024).unwrap();
    assert_eq!(
        (g.extra_microtubules.len(), g.extra_intermediate.len()),
        (10, 12)
    );
    // The published cytoskeleton is untouched.
    assert_eq!(g.fa_nodes, base.fa_nodes);
    assert_eq!(g.microtubules, base.microtubules);
    assert_eq!(g.intermediate_filaments, base.intermediate_filaments);
    let params = with(4, 10, 12, 2024);
    let shape = params.shape;
    let (c, e) = (shape.nucleus_centre(), shape.nucleus_semi_axes);
    let nucleus_level = |p: [f64; 3]| (0..3).map(|k| ((p[k] - c[k]) / e[k]).powi(2)).sum::<f64>();
    let dome: std::collections::BTreeSet<usize> =
        g.mesh.node_sets["dome"].iter().copied().collect();
    let inner: std::collections::BTreeSet<usize> = g.mesh.node_sets["nucleus_surface"]
        .iter()
        .copied()
        .collect();
    // Every extra end: a dome node above the substrate, no FA, no other extra filament's
    // end, farther than two plaque radii from every FA.
    let mut used: std::collections::BTreeSet<usize> =
        g.extra_bundles.iter().flatten().copied().collect();
    let new_end = |n: usize, used: &mut std::collections::BTreeSet<usize>| {
        assert!(
            dome.contains(&n) && g.mesh.nodes[n][2] > 0.0,
            "node {n} not on the dome"
        );
        assert!(
            g.fa_nodes
                .iter()
                .all(|&f| dist(g.mesh.nodes[f], g.mesh.nodes[n]) > 2.0 * params.fa_radius),
            "node {n} on an FA's plaque"
        );
        assert!(used.insert(n), "node {n} reused");
    };
    let margin = params.mt_clearance_margin;
    for mt in &g.extra_microtubules {
        new_end(mt.fa_node, &mut used);
        assert_eq!(mt.points[0], g.centrosome);
        assert_eq!(*mt.points.last().unwrap(), g.mesh.nodes[mt.fa_node]);
        assert_eq!(mt.points.len(), params.mt_elements + 1);
        assert!(mt.bow.abs() >= params.mt_bow_min && mt.bow.abs() <= params.mt_bow_max);
        for p in &mt.points[1..mt.points.len() - 1] {
            assert!(
                shape.level(*p) < 1.0 && p[2] > 0.0,
                "MT point {p:?} outside the cell"
            );
            // Clear of the nucleus by the margin (measured, like the layout, in the frame
            // where the nucleus is the unit sphere, scaled by its smallest semi-axis).
            assert!(
                nucleus_level(*p).sqrt() - 1.0 >= margin / e[2] - 1e-9,
                "MT point {p:?}"
            );
        }
    }
    let mut anchors = std::collections::BTreeSet::new();
    for &[a, b] in &g.extra_intermediate {
        new_end(a, &mut used);
        assert!(inner.contains(&b) && anchors.insert(b), "anchor {b}");
        let (pa, pb) = (g.mesh.nodes[a], g.mesh.nodes[b]);
        for i in 0..200 {
            let t = i as f64 / 200.0;
            let p = [0, 1, 2].map(|k| pa[k] + t * (pb[k] - pa[k]));
            assert!(
                nucleus_level(p) > 1.0 - 1e-6,
                "IF {a}-{b} enters the nucleus at t = {t}"
            );
        }
    }
    // Reproducible; another seed gives other filaments; the MTs' stream is their own (more
    // IFs do not move them).
    let again = build(4, 10, 12, 2024).unwrap();
    assert_eq!(again.extra_microtubules, g.extra_microtubules);
    assert_eq!(again.extra_intermediate, g.extra_intermediate);
    assert_ne!(
        build(4, 10, 12, 7).unwrap().extra_microtubules,
        g.extra_microtubules
    );
    assert_eq!(
        build(4, 10, 0, 2024).unwrap().extra_microtubules,
        g.extra_microtubules
    );
    // Too many: errors naming the key.
    for (mts, ifs, key) in [
        (5000, 0, "cell.microtubules.extra"),
        (0, 5000, "cell.intermediate.extra"),
    ] {
        let err = build(0, mts, ifs, 2024).unwrap_err().to_string();
        assert!(err.contains(key) && err.contains("at most"), "{err}");
    }
    // In the built cell: groups of their own in the families `microtubule` and
    // `intermediate`, after the published ones.
    let mut cell = cellmech::cell::adherent::AdherentCell::default();
    cell.params = with(0, 10, 12, 2024);
    let built = cell.build().unwrap();
    let group = |name: &str| {
        built
            .model
            .structures
            .filaments
            .iter()
            .find(|f| f.name == name)
            .unwrap_or_else(|| panic!("no group {name}"))
    };
    let (mt, ifs) = (group("microtubule-extra"), group("intermediate-extra"));
    assert_eq!(
        (mt.family.as_str(), mt.filaments.len()),
        ("microtubule", 10)
    );
    assert_eq!(mt.pairs.len(), 10 * params.mt_elements);
    assert_eq!(
        (ifs.family.as_str(), ifs.filaments.len()),
        ("intermediate", 12)
    );
    assert_eq!(built.description.params["extra_microtubules"], 10);
}

#[test]
fn the_adherent_cell_with_extra_bundles_finds_its_prestressed_equilibrium() {
    let text = |extra: usize| {
        format!(
            "title = \"adherent\"\n[cell]\nmodel = \"adherent\"\nmesh.core_divisions = 8\nmesh.shell_layers = 2\nmesh.outer_layers = 2\nbundles.extra = {extra}\n[protocol]\nkind = \"prestress\"\n[output]\nvtk_every = 0\n"
        )
    };
    let mut sums = Vec::new();
    for extra in [0, 8] {
        let s = parse(&text(extra), "adherent.toml", std::path::Path::new(".")).unwrap();
        let dir = out_dir(&format!("adherent-{extra}"));
        let summary = run(&s, &dir, &mut NullObserver).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(summary.status, "completed", "{:?}", summary.error);
        let f = summary.filaments.expect("filaments");
        let bundles = f.families.iter().find(|x| x.family == "bundles").unwrap();
        assert_eq!(bundles.filaments, 8 + extra);
        assert_eq!(bundles.in_tension, 8 + extra);
        sums.push(bundles.fa_force_sum_nn.expect("FA-end force sum"));
    }
    eprintln!(
        "AB force sums at the FA ends: published {:.3} nN, +8 ABs {:.3} nN",
        sums[0], sums[1]
    );
    assert!(sums[1] > sums[0]);
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}
