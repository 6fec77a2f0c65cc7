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

/// Successive slopes of the force curve never change by more than a factor `ratio`:
/// no jumps from solver artefacts.
fn assert_smooth(curve: &[TestPoint], ratio: f64) {
    let slopes: Vec<f64> = curve
        .windows(2)
        .map(|w| (w[1].force_nn - w[0].force_nn) / (w[1].displacement_um - w[0].displacement_um))
        .collect();
    for w in slopes.windows(2) {
        assert!(
            w[1] > 0.0 && w[1] / w[0] < ratio && w[0] / w[1] < ratio,
            "force curve jumps: slopes {slopes:?}"
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
    // Every MT element is counted as in tension or in compression.
    let mts = summary.final_values["microtubule_in_tension"]
        + summary.final_values["microtubule_in_compression"];
    assert_eq!(mts, 240.0);
    for file in [
        "tension.csv",
        "tension-force.png",
        "tension-nucleus.png",
        "fields.pvd",
    ] {
        assert!(dir.join(file).exists(), "{file}");
    }
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
    let s = scenario("", "kind = \"microplate-compression\"", "").unwrap();
    let (summary, r, _dir) = run_case("compression", &s);
    assert_eq!(summary.status, "completed");
    // Contact without deforming: the approach stops at the contact force (0.1 nN).
    let reference = r.reference_force_nn.unwrap();
    assert!((reference - 0.1).abs() <= 0.005 + 1e-12, "{reference}");
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
    // slope by up to 2.4x between increments (a contact-discretisation event, not a solver
    // artefact: the curve stays monotone and every increment converges).
    assert_smooth(&r.curve, 2.5);
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
