//! The suspended cell's virtual experiments through the scenario layer, on a coarse cell
//! (448 hex8: core_divisions 4, 2 + 2 layers) so that CI stays fast.
//!
//! GOAL: the physics the issue asks both tests to show. MESH: the suspended cell of the
//! spec with a coarse continuum (all 30 FAs, 60 AFs, 30 MTs of 8 beams, 60 IFs). BCS: the
//! built-in protocols (bonded pipettes or plates on the x axis). REFERENCE: qualitative
//! physics with quantitative checks: supports unloaded, zero-force reference state, force
//! curves that rise and stiffen without jumps, the nucleus elongating along the stretch and
//! flattening under the plates, every family removable.

use std::path::PathBuf;

use cellmech::protocol::results::{ProtocolResults, TestPoint};
use cellmech::run::{run, RunSummary};
use cellmech::scenario::{parse, Scenario, ScenarioError};
use cellmech_fem::solve::NullObserver;

const COARSE_CELL: &str = "[cell]\ncore_divisions = 4\nshell_layers = 2\nouter_layers = 2\n";

fn scenario(cell_extra: &str, protocol: &str, extra: &str) -> Result<Scenario, ScenarioError> {
    let text = format!(
        "title = \"test\"\n{COARSE_CELL}{cell_extra}\n[protocol]\n{protocol}\n{extra}\n[output]\nvtk_every = 0\n"
    );
    parse(&text, "test.toml", std::path::Path::new("."))
}

fn out_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cellmech-cell-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn run_case(name: &str, s: &Scenario) -> (RunSummary, ProtocolResults, PathBuf) {
    let dir = out_dir(name);
    let summary = run(s, &dir, &mut NullObserver).unwrap_or_else(|e| panic!("{name}: {e}"));
    let results = summary.protocol.clone().expect("protocol results");
    (summary, results, dir)
}

/// EA·prestrain of one AF (nN): the scale of the prestress forces.
fn af_prestress_force() -> f64 {
    2.6e6 * std::f64::consts::PI * 0.007f64.powi(2) / 4.0 * 0.24
}

/// The slopes of the force curve between successive points (nN/µm).
fn slopes(curve: &[TestPoint]) -> Vec<f64> {
    curve
        .windows(2)
        .map(|w| (w[1].force_nn - w[0].force_nn) / (w[1].displacement_um - w[0].displacement_um))
        .collect()
}

/// Successive slopes of the force curve never change by more than a factor `ratio`:
/// no jumps from solver artefacts.
fn assert_smooth(curve: &[TestPoint], ratio: f64) {
    let slopes = slopes(curve);
    for w in slopes.windows(2) {
        assert!(
            w[1] > 0.0 && w[1] / w[0] < ratio && w[0] / w[1] < ratio,
            "force curve jumps: slopes {slopes:?}"
        );
    }
}

/// Successive slopes of the force curve never spike: no slope rises (or falls) by more than
/// `ratio` against both its neighbours, the signature of a solver artefact. A step to a new
/// level, where the slope stays, is a change of the contact and passes.
fn assert_no_spike(curve: &[TestPoint], ratio: f64) {
    let slopes = slopes(curve);
    for w in slopes.windows(3) {
        let (a, b, c) = (w[0], w[1], w[2]);
        assert!(
            !(b > ratio * a && b > ratio * c) && !(b * ratio < a && b * ratio < c),
            "force curve spikes: slopes {slopes:?}"
        );
    }
}

#[test]
fn tension_test_stiffens_and_elongates_the_nucleus_along_the_stretch() {
    let s = scenario("", "kind = \"micropipette-tension\"", "").unwrap();
    let (summary, r, dir) = run_case("tension", &s);
    assert_eq!(summary.status, "completed");
    assert_eq!(summary.seed, Some(2024));
    // Supports: free-cell equilibrium, and negligible next to the test force.
    let prestress = r.prestress_support_reaction_max_nn.unwrap();
    assert!(prestress < 1e-6 * af_prestress_force(), "{prestress}");
    let last = r.last.unwrap();
    let support = r.support_reaction_max_nn.unwrap();
    assert!(
        support < 1e-4 * last.force_nn,
        "supports carry {support} nN"
    );
    // Reference state: the moving pipette's force is zero within the target tolerance.
    let reference = r.reference_force_nn.unwrap();
    assert!(reference.abs() <= 0.005 + 1e-12, "{reference}");
    assert!((last.displacement_um - 6.3).abs() < 1e-9);
    assert!(last.force_nn > 10.0, "{last:?}");
    // Stiffening: the normalised (secant) stiffness rises along the stretch.
    let k: Vec<f64> = r.curve[1..]
        .iter()
        .map(|p| p.normalised_stiffness_kpa)
        .collect();
    assert!(k.windows(2).all(|w| w[1] > w[0]), "not stiffening: {k:?}");
    // Last over first secant stiffness with the cap grip: 1.11 on this coarse cell (its
    // 5-node caps hold a star, not a disk), 1.32 on the default mesh, 1.38 on the fine one
    // (the contact grip's 1.39 here came partly from patches that grew with the stretch).
    assert!(k.last().unwrap() > &(1.08 * k[0]), "{k:?}");
    assert_smooth(&r.curve, 1.5);
    // The nucleus elongates along the stretch (x), more at every increment.
    let aspect: Vec<f64> = r.curve.iter().map(|p| p.nucleus_aspect_ratio).collect();
    assert!(aspect.windows(2).all(|w| w[1] > w[0]), "{aspect:?}");
    assert!(last.nucleus_aspect_ratio > 1.01, "{aspect:?}");
    // Nucleus strain from the reference state: 0 there, growing with the stretch, and the
    // test's own part of the strain measured from the mesh (which includes the prestress).
    let from_reference: Vec<f64> = r
        .curve
        .iter()
        .map(|p| p.nucleus_max_principal_log_strain_from_reference)
        .collect();
    assert_eq!(from_reference[0], 0.0);
    assert!(
        from_reference.windows(2).all(|w| w[1] > w[0]),
        "{from_reference:?}"
    );
    assert!(
        *from_reference.last().unwrap() < last.nucleus_max_principal_log_strain + 1e-12,
        "{from_reference:?} vs {}",
        last.nucleus_max_principal_log_strain
    );
    // Every MT element is counted as in tension or in compression.
    let mts = summary.final_values["microtubule_in_tension"]
        + summary.final_values["microtubule_in_compression"];
    assert_eq!(mts, 240.0);
    for file in [
        "tension.csv",
        "tension-force.png",
        "tension-nucleus.png",
        "tension-stiffness.png",
        "fields.pvd",
    ] {
        assert!(dir.join(file).exists(), "{file}");
    }
    assert_filament_outputs(&summary, &dir);
    eprintln!(
        "tension (448 hex8): F(6.3 um) = {:.2} nN, K = {:.3} kPa, nucleus aspect {:.4}, {:.1} s",
        last.force_nn,
        last.normalised_stiffness_kpa,
        last.nucleus_aspect_ratio,
        summary.wall_time_s
    );
}

#[test]
fn compression_test_stiffens_and_flattens_the_nucleus() {
    // Unrefined under the plates: on this 448-element cell the default refinement (one level
    // within 6 µm of the poles) leaves 8 µm elements beside 4 µm ones and overshoots the 10 %
    // force (48.0 nN against 40.7 nN on the fine mesh refined the same way), so the secant
    // stiffness grows only 1.17x to 30 %. The refinement is for the production meshes
    // (docs/suspended-cell-validation.md, "Refined under the plates").
    let s = scenario(
        "",
        "kind = \"microplate-compression\"\nrefinement.levels = 0",
        "",
    )
    .unwrap();
    let (summary, r, dir) = run_case("compression", &s);
    assert_eq!(summary.status, "completed");
    // Contact without deforming: each plate moves until its smallest gap to the cell is 0
    // (`approach` for the top plate, `seat` for the bottom one), one or two increments each
    // (the gap falls linearly with the travel), and nothing is pushed.
    let steps: Vec<(&str, usize)> = summary
        .steps
        .iter()
        .map(|st| (st.name.as_str(), st.increments))
        .collect();
    assert_eq!(steps[1].0, "approach");
    assert_eq!(steps[2].0, "seat");
    assert!(steps[1].1 <= 2 && steps[2].1 <= 2, "{steps:?}");
    let reference = r.reference_force_nn.unwrap();
    assert!(reference.abs() < 1e-3, "{reference}");
    // Every reported state is an equilibrium: the plates' forces balance (until stop 53 the
    // nodes bonded at a commit lost their small pulls, and the default compression's plates
    // were 82 % out of balance at 1 %).
    let largest = r.largest_tool_force_imbalance.unwrap();
    assert!(largest.0 < 1e-5, "plates out of balance: {largest:?}");
    let rows = curve_rows(&dir);
    let seated = rows.iter().rfind(|row| row["step"] == 2.0).unwrap();
    let tolerance = 1e-4 * 32.264 * 3f64.sqrt(); // TOLERANCE_FACTOR x mesh diagonal, loosely
    for plate in ["top_plate", "bottom_plate"] {
        let gap = seated[&format!("{plate}_min_gap_um")];
        assert!(
            gap.abs() <= 2.0 * tolerance,
            "{plate} gap {gap} um at contact"
        );
    }
    // Free MTs pass through the plates by default: no companion tools.
    assert!(rows[0].keys().all(|k| !k.contains("_mt_nodes_")));
    let at: Vec<(f64, TestPoint)> = r.at_deformations.clone();
    assert_eq!(
        at.iter().map(|(e, _)| *e).collect::<Vec<_>>(),
        vec![0.1, 0.3, 0.5]
    );
    for (e, p) in &at {
        assert!((p.strain - e).abs() < 1e-9, "{e}: {p:?}");
    }
    let f: Vec<f64> = at.iter().map(|(_, p)| p.force_nn).collect();
    // Stiffening: the secant stiffness F/e grows from 10 to 30 to 50 %.
    let secant: Vec<f64> = at.iter().map(|(e, p)| p.force_nn / e).collect();
    assert!(secant.windows(2).all(|w| w[1] > 1.2 * w[0]), "{f:?}");
    // On this 448-element cell a new ring of surface nodes reaching the plate raises the
    // slope between two increments (a contact-discretisation event, not a solver artefact:
    // the slope stays at its new level, the curve is monotone and every increment
    // converges). Measured: 2.4x with the contact status re-decided at every Newton
    // iteration, 3.6x (10.8 -> 38.6 nN/um, near 30 %) since the status is held within a
    // Newton solve and predicted per increment (docs/tools.md): the ring now engages within
    // one increment instead of two. So: steps up to 4x, no spike of 2.5x.
    assert_smooth(&r.curve, 4.0);
    assert_no_spike(&r.curve, 2.5);
    // The nucleus flattens: shorter along the load (x) than across it, more and more.
    let aspect: Vec<f64> = at.iter().map(|(_, p)| p.nucleus_aspect_ratio).collect();
    assert!(aspect.windows(2).all(|w| w[1] < w[0]), "{aspect:?}");
    assert!(aspect[2] < 0.9, "{aspect:?}");
    let support = r.support_reaction_max_nn.unwrap();
    assert!(support < 1e-4 * f[2], "supports carry {support} nN");
    eprintln!(
        "compression (448 hex8): F = {f:?} nN at 10/30/50 %, nucleus aspect {aspect:?}, {:.1} s",
        summary.wall_time_s
    );
}

#[test]
fn with_filament_contact_no_free_mt_node_passes_through_a_plate() {
    let s = scenario(
        "",
        "kind = \"microplate-compression\"\ndeformations = [\"10%\", \"30%\"]\nfilament_contact = \"on\"",
        "",
    )
    .unwrap();
    let (summary, _r, dir) = run_case("compression-filament-contact", &s);
    assert_eq!(summary.status, "completed");
    // The frictionless companions hold the interior MT nodes to the penetration tolerance,
    // and they do touch (MTs reach the plates by 30 %).
    let tolerance = 1e-4 * 32.264 * 3f64.sqrt();
    let mut touched = 0.0f64;
    for row in &curve_rows(&dir) {
        for plate in ["top_plate", "bottom_plate"] {
            let pen = row[&format!("{plate}_mt_nodes_max_penetration_um")];
            assert!(pen <= 2.0 * tolerance, "{plate}: MT node {pen} um inside");
            touched = touched.max(row[&format!("{plate}_mt_nodes_force_x_nN")].abs());
        }
    }
    assert!(touched > 0.0, "no MT node reached a plate");
}

#[test]
fn plates_that_touch_a_cell_without_prestress_at_once_still_give_a_reference_state() {
    // Without AFs the cell does not contract: the plates placed at +-D/2 already touch it,
    // `approach` and `seat` end at their start without an increment, and the reference
    // state is where the prestress ended.
    let s = scenario(
        "",
        "kind = \"microplate-compression\"\ndeformations = [\"10%\"]",
        "[families.actin]\nenabled = false\n",
    )
    .unwrap();
    let (summary, r, _dir) = run_case("compression-no-actin", &s);
    assert_eq!(summary.status, "completed");
    let increments: Vec<usize> = summary.steps.iter().map(|st| st.increments).collect();
    assert_eq!(&increments[1..3], &[0, 0], "{increments:?}");
    assert!(r.reference_force_nn.unwrap().abs() < 1e-9);
    let at = &r.at_deformations;
    assert_eq!(at.len(), 1);
    assert!(
        (at[0].1.strain - 0.1).abs() < 1e-9 && at[0].1.force_nn > 0.0,
        "{at:?}"
    );
    assert_eq!(
        r.curve[0].nucleus_max_principal_log_strain_from_reference,
        0.0
    );
}

/// The rows of `curve.csv` by column name (blank cells: NaN).
fn curve_rows(dir: &std::path::Path) -> Vec<std::collections::HashMap<String, f64>> {
    let text = std::fs::read_to_string(dir.join("curve.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    lines
        .map(|line| {
            header
                .iter()
                .cloned()
                .zip(line.split(',').map(|v| v.parse().unwrap_or(f64::NAN)))
                .collect()
        })
        .collect()
}

#[test]
fn a_compression_step_that_fails_is_not_reported_at_its_target() {
    // 85 % without stabilisation fails on this cell (at about 71 %, inverted elements, then
    // the increment falls below its minimum). Its last converged increment is kept in the
    // curve, but it is not "the force at 85 %": only the 10 % step that finished is.
    let s = scenario(
        "[cell.solver]\nstabilization = \"off\"\n",
        "kind = \"microplate-compression\"\ndeformations = [\"10%\", \"85%\"]",
        "",
    )
    .unwrap();
    let dir = out_dir("compression-fails");
    let summary = match run(&s, &dir, &mut NullObserver) {
        Err(cellmech::run::RunError::Analysis { summary, .. }) => *summary,
        other => panic!(
            "expected the 85 % step to fail, got {:?}",
            other.map(|_| ())
        ),
    };
    assert_eq!(summary.status, "failed");
    let r = summary.protocol.expect("protocol results");
    let at: Vec<f64> = r.at_deformations.iter().map(|(e, _)| *e).collect();
    assert_eq!(
        at,
        vec![0.1],
        "only the finished step is reported at its target"
    );
    let last = r.last.expect("the converged increments are kept");
    assert!(last.strain > 0.1 && last.strain < 0.85, "{last:?}");
}

#[test]
fn removing_any_cytoskeletal_family_still_converges() {
    let mut forces = Vec::new();
    for family in ["actin", "microtubule", "intermediate", "membrane"] {
        let s = scenario(
            "",
            "kind = \"micropipette-tension\"",
            &format!("[families.{family}]\nenabled = false\n"),
        )
        .unwrap();
        let (summary, r, _) = run_case(&format!("no-{family}"), &s);
        assert_eq!(summary.status, "completed", "without {family}");
        let last = r.last.unwrap();
        assert!((last.displacement_um - 6.3).abs() < 1e-9);
        assert!(last.force_nn > 0.0, "without {family}: {last:?}");
        assert!(
            summary.final_values.keys().all(|k| !k.starts_with(family)),
            "{family} columns remain"
        );
        forces.push((family, last.force_nn));
    }
    eprintln!("tension force at 6.3 um without each family: {forces:?}");
}

fn error_of(cell_extra: &str, protocol: &str) -> String {
    match scenario(cell_extra, protocol, "") {
        Ok(_) => panic!("accepted: {cell_extra} / {protocol}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn impossible_geometry_and_protocols_are_rejected_before_solving() {
    let tension = "kind = \"micropipette-tension\"";
    let cases = [
        (
            "nucleus_diameter = \"40 um\"\n",
            tension,
            "nucleus diameter",
        ),
        (
            "[cell.intermediate]\nper_fa = 0\n",
            tension,
            "cell.intermediate.per_fa",
        ),
        (
            "[cell.microtubules]\ncentrosome_gap = \"-1 um\"\n",
            tension,
            "cell.microtubules.centrosome_gap",
        ),
        (
            "",
            "kind = \"micropipette-tension\"\nelongation = \"100 um\"",
            "protocol.elongation",
        ),
        (
            "",
            "kind = \"micropipette-tension\"\npipette_radius = \"20 um\"",
            "protocol.pipette_radius",
        ),
        (
            "",
            "kind = \"microplate-compression\"\ndeformations = [\"30%\", \"10%\"]",
            "protocol.deformations",
        ),
        (
            "",
            "kind = \"microplate-compression\"\nelongation = \"5 um\"",
            "does not apply",
        ),
        ("", "kind = \"bending\"", "protocol.kind"),
        ("resolution = \"ultra\"\n", tension, "cell.resolution"),
    ];
    for (cell, protocol, expected) in cases {
        let message = error_of(cell, protocol);
        assert!(
            message.contains(expected) && message.starts_with("test.toml"),
            "{cell} / {protocol}: {message}"
        );
    }
    // A [cell] with a [mesh], or a [protocol] without a [cell].
    let both = "[mesh]\nsource = \"sphere\"\nradius = \"5 um\"\n[cell]\n[protocol]\nkind = \"prestress\"\n";
    let e = parse(both, "both.toml", std::path::Path::new(".")).unwrap_err();
    assert!(e.to_string().contains("not both"), "{e}");
    let orphan = "[mesh]\nsource = \"sphere\"\nradius = \"5 um\"\n[[material]]\nelement_set = \"solid\"\nmodel = \"neo-hookean\"\nshear_modulus = \"1 kPa\"\npoisson_ratio = 0.3\n[protocol]\nkind = \"prestress\"\n";
    let e = parse(orphan, "orphan.toml", std::path::Path::new(".")).unwrap_err();
    assert!(e.to_string().contains("add a [cell]"), "{e}");
}

/// The suspended cell's filaments as filaments, not elements: 60 AFs between two FAs, 30 MTs
/// of 8 beams ending on the 30 FAs, 60 IFs starting at an FA (two per FA); counts that add up
/// to those totals in summary.json and curve.csv; one filaments.csv row per filament per
/// state; `filament_id` on every line cell of the last VTU frame.
fn assert_filament_outputs(summary: &RunSummary, dir: &std::path::Path) {
    use cellmech::model::filaments::FilamentEnd;
    let snap = summary.filaments.as_ref().expect("filament table");
    assert_eq!(snap.family_names, ["actin", "microtubule", "intermediate"]);
    let fv = &summary.final_values;
    for (c, (total, end)) in snap.families.iter().zip([
        (60, FilamentEnd::Both),
        (30, FilamentEnd::End),
        (60, FilamentEnd::Start),
    ]) {
        assert_eq!(c.filaments, total, "{c:?}");
        assert_eq!(c.in_tension + c.in_compression + c.slack, total, "{c:?}");
        let of: Vec<_> = snap
            .filaments
            .iter()
            .filter(|r| r.family == c.family)
            .collect();
        assert_eq!(of.len(), total);
        assert!(of
            .iter()
            .all(|r| r.fa_end == Some(end) && r.fa_node.is_some()));
        // Every FA holds filaments of each family (an AF at both of its ends).
        let fa_nodes: std::collections::BTreeSet<_> = of
            .iter()
            .flat_map(|r| match r.fa_end {
                Some(FilamentEnd::Both) => vec![r.start_node, r.end_node],
                _ => vec![r.fa_node.unwrap()],
            })
            .collect();
        assert_eq!(fa_nodes.len(), 30, "{}: every FA", c.family);
        let n = &c.family;
        let sum: f64 = of.iter().map(|r| r.fa_force_nn.unwrap()).sum();
        assert_eq!(fv[&format!("{n}_fa_force_sum_nN")], sum);
        assert_eq!(c.fa_force_sum_nn, Some(sum));
        for (k, v) in [
            ("in_tension", c.in_tension),
            ("in_compression", c.in_compression),
            ("slack", c.slack),
        ] {
            assert_eq!(fv[&format!("{n}_filaments_{k}")], v as f64, "{n} {k}");
        }
    }
    // One-element AFs: the FA-end forces are the element forces.
    let af_sum = snap.families[0].fa_force_sum_nn.unwrap();
    let af_mean = fv["actin_axial_force_mean_nN"];
    assert!(
        (af_sum - 60.0 * af_mean).abs() < 1e-12 * af_sum,
        "{af_sum} vs {af_mean}"
    );
    let mts = &snap.families[1];
    assert_eq!(
        fv["microtubule_filaments_straight"],
        mts.straight.unwrap() as f64
    );
    // Tension-only IFs far below their slack length carry exactly nothing.
    assert_eq!(snap.families[2].slack, 60);
    let csv = std::fs::read_to_string(dir.join("filaments.csv")).unwrap();
    let curve = std::fs::read_to_string(dir.join("curve.csv")).unwrap();
    assert_eq!(csv.lines().count() - 1, 150 * (curve.lines().count() - 1));
    let last = (0..)
        .map(|k| dir.join(format!("fields_{k:04}.vtu")))
        .take_while(|p| p.exists())
        .last()
        .unwrap();
    let vtu = std::fs::read_to_string(last).unwrap();
    let ids = float64_array(&vtu, "filament_id");
    let count = |id: f64| ids.iter().filter(|&&v| v == id).count();
    assert_eq!(ids.iter().filter(|v| !v.is_nan()).count(), 60 + 240 + 60);
    assert!((0..60).all(|id| count(id as f64) == 1), "AFs");
    assert!((60..90).all(|id| count(id as f64) == 8), "MTs of 8 beams");
    assert!((90..150).all(|id| count(id as f64) == 1), "IFs");
    eprintln!(
        "filaments at the last state: MTs in tension {}, compression {}, straight {}; \
         AF FA-end force sum {af_sum:.3} nN; IFs slack {}",
        mts.in_tension,
        mts.in_compression,
        mts.straight.unwrap(),
        snap.families[2].slack
    );
}

/// A Float64 DataArray of a binary VTU file.
fn float64_array(vtu: &str, name: &str) -> Vec<f64> {
    cellmech_io::read_f64_array(vtu, name).unwrap_or_else(|| panic!("no array {name}"))
}

#[test]
fn bfgs_iterations_give_the_newton_tension_force_with_fewer_factorisations() {
    // The same coarse tension test with `[cell.solver] iteration = "bfgs"`: the same
    // equilibrium (both converge to the relative tolerance 1e-8), fewer factorisations.
    // Without the MTs: their free beam nodes are nearly mechanistic modes that the secant
    // updates lose, so with them BFGS reforms so often that it needs more factorisations
    // than Newton (coarse cell, 2026-12-02: 96 against 69; docs/performance.md).
    let no_mts = "[families.microtubule]\nenabled = false\n";
    let newton = scenario("", "kind = \"micropipette-tension\"", no_mts).unwrap();
    let bfgs = scenario(
        "[cell.solver]\niteration = \"bfgs\"\n",
        "kind = \"micropipette-tension\"",
        no_mts,
    )
    .unwrap();
    let (sn, rn, _) = run_case("newton", &newton);
    let (sb, rb, _) = run_case("bfgs", &bfgs);
    let (fn_, fb) = (rn.last.unwrap().force_nn, rb.last.unwrap().force_nn);
    assert!(
        (fn_ - fb).abs() <= 1e-6 * fn_,
        "Newton {fn_} nN, BFGS {fb} nN"
    );
    let (kn, kb) = (
        sn.solver_timings.factorizations,
        sb.solver_timings.factorizations,
    );
    eprintln!("coarse tension without MTs: Newton {kn}, BFGS {kb} factorisations");
    assert!(kb < kn, "BFGS {kb} factorisations, Newton {kn}");
}

#[test]
fn auto_iteration_gives_the_newton_compression_forces_with_fewer_factorisations() {
    // `solver.iteration = "auto"` (the default) takes BFGS in the compression's loading
    // steps: the same forces as full Newton everywhere (both converge to the relative
    // tolerance 1e-8), with fewer factorisations.
    let protocol = "kind = \"microplate-compression\"";
    let newton = scenario("[cell.solver]\niteration = \"newton\"\n", protocol, "").unwrap();
    let auto = scenario("", protocol, "").unwrap();
    let (sn, rn, _) = run_case("compression-newton", &newton);
    let (sa, ra, _) = run_case("compression-auto", &auto);
    for ((e, pn), (_, pa)) in rn.at_deformations.iter().zip(&ra.at_deformations) {
        assert!(
            (pn.force_nn - pa.force_nn).abs() <= 1e-6 * pn.force_nn,
            "{e}: Newton {} nN, auto {} nN",
            pn.force_nn,
            pa.force_nn
        );
    }
    let (kn, ka) = (
        sn.solver_timings.factorizations,
        sa.solver_timings.factorizations,
    );
    eprintln!("coarse compression: Newton {kn}, auto {ka} factorisations");
    assert!(ka < kn, "auto {ka} factorisations, Newton {kn}");
}

#[test]
fn a_viscously_stabilised_curve_shows_its_drag_as_a_tool_force_imbalance() {
    // The viscous forces' resultant is what the two pipettes' forces then differ by: the
    // stabilisation's own norm-based ratio understated it 15-fold on the turned pattern
    // (docs/suspended-cell-validation.md, "FAs centred on their sites").
    let imbalances = |stabilization: &str| {
        let s = scenario(
            &format!("[cell.solver]\nstabilization = \"{stabilization}\"\n"),
            "kind = \"micropipette-tension\"",
            "",
        )
        .unwrap();
        let (summary, r, dir) = run_case(&format!("imbalance-{stabilization}"), &s);
        assert_eq!(summary.status, "completed");
        // The same ratio from curve.csv's two pipette columns, at the curve's last point.
        let rows = curve_rows(&dir);
        let last = rows.last().unwrap();
        let (moving, fixed) = (last["moving_cap_fx_nN"], last["fixed_cap_fx_nN"]);
        let p = r.last.unwrap();
        assert!(
            (moving - p.force_nn).abs() < 1e-9 * moving.abs(),
            "{moving} {p:?}"
        );
        let expected = (moving + fixed).abs() / moving.abs().max(fixed.abs());
        assert!(
            (p.tool_force_imbalance - expected).abs() <= 1e-12,
            "{} against {expected}",
            p.tool_force_imbalance
        );
        let largest = r.largest_tool_force_imbalance.unwrap();
        let curve: Vec<f64> = r.curve.iter().map(|p| p.tool_force_imbalance).collect();
        (largest, curve)
    };
    // In equilibrium the pipettes' forces balance to round-off.
    let (largest, _) = imbalances("off");
    assert!(largest.0 < 1e-7, "{largest:?}");
    // Damped from the first increment: every increment before the step's end carries drag;
    // the end is re-solved without viscosity and balances again.
    let (largest, curve) = imbalances("always");
    assert!(largest.0 > 1e-4, "{largest:?}");
    let interior = &curve[1..curve.len() - 1];
    assert!(interior.iter().all(|&x| x > 1e-5), "{curve:?}");
    assert!(*curve.last().unwrap() < 1e-7, "{curve:?}");
}
