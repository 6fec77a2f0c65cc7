//! `[cell.microtubules] coupling = "foundation"`: every interior MT node is tied to the
//! material point of the cytoplasm or nucleus it lies in by an elastic tie
//! (`cellmech_fem::element::host_tie`, verified against the beam-on-elastic-foundation
//! buckling load in `cellmech-fem/tests/host_tie_verification.rs`). Here: the ties are
//! built for exactly the enabled MT interior nodes, add no constraints, and are unloaded in
//! the reference state; the default modulus is the cytoplasm's Young's modulus, and the
//! default MT discretisation 48 beams instead of 8.

use cellmech::model::build;
use cellmech::scenario::parse;

fn coarse(coupling: &str, families: &str) -> cellmech::model::BuiltModel {
    let text = format!(
        "title = \"foundation\"\n[cell]\ncore_divisions = 4\nshell_layers = 2\nouter_layers = 2\n\
         [cell.microtubules]\n{coupling}\n[protocol]\nkind = \"prestress\"\n{families}\
         [output]\nvtk_every = 0\n"
    );
    let s = parse(&text, "test.toml", std::path::Path::new(".")).unwrap();
    build(&s.model).unwrap()
}

#[test]
fn foundation_ties_hold_every_enabled_interior_mt_node_and_start_unloaded() {
    let tied = coarse("coupling = \"foundation\"", "");
    assert_eq!(tied.embedding.len(), 1);
    let e = &tied.embedding[0];
    // 30 MTs of 48 elements (the foundation's default): 47 interior nodes each.
    assert_eq!((e.embedded_nodes, e.shared_nodes), (1410, 0), "{e:?}");
    // A count given in the file wins: 8 elements, 7 interior nodes each.
    let eight = coarse("coupling = \"foundation\"\nelements = 8", "");
    assert_eq!(eight.embedding[0].embedded_nodes, 210);
    assert_eq!(
        tied.problem.num_constrained_dofs(),
        0,
        "ties are elements, not constraints"
    );
    let free = coarse("coupling = \"free\"", "");
    assert!(free.embedding.is_empty());
    assert!(
        tied.problem.tangent_nonzeros() > free.problem.tangent_nonzeros(),
        "the ties couple MT nodes to their hosts"
    );
    // Unloaded at the reference state: the ties add no force and no energy there.
    let n = tied.problem.u().len();
    let mut r = vec![0.0; n];
    let mask = vec![false; n];
    let energy = tied
        .problem
        .assembler()
        .assemble(
            tied.problem.terms(),
            tied.problem.u(),
            &mask,
            cellmech_fem::assembly::AssemblyOutput {
                residual: &mut r,
                magnitude: None,
                tangent: None,
                predictor: None,
            },
        )
        .unwrap();
    assert!(energy.abs() < 1e-12, "{energy}");
    assert!(r.iter().all(|v| v.abs() < 1e-9));
    // Without MTs there is nothing to tie.
    let no_mt = coarse(
        "coupling = \"foundation\"",
        "[families.microtubule]\nenabled = false\n",
    );
    assert!(no_mt.embedding.iter().all(|e| e.embedded_nodes == 0));
}

#[test]
fn the_default_foundation_modulus_is_the_cytoplasm_youngs_modulus() {
    let modulus = |text: &str| {
        let s = parse(text, "test.toml", std::path::Path::new(".")).unwrap();
        assert_eq!(s.model.embedded.len(), 1);
        s.model.embedded[0].foundation_modulus.unwrap()
    };
    let text = "title = \"k\"\n[cell]\n[cell.cytoplasm]\nshear_modulus = \"0.2 kPa\"\n\
                poisson_ratio = 0.4\n[cell.microtubules]\ncoupling = \"foundation\"\n\
                [protocol]\nkind = \"prestress\"\n";
    let k = modulus(text);
    assert!((k - 2.0 * 0.2 * 1.4).abs() < 1e-12, "{k}");
    let given = text.replace(
        "coupling = \"foundation\"",
        "coupling = \"foundation\"\nfoundation_modulus = \"50 Pa\"",
    );
    assert!((modulus(&given) - 0.05).abs() < 1e-15);
}

#[test]
fn filament_drag_needs_filaments_on_the_foundation_and_is_their_default() {
    // The drag acts on the tie slips: with free MTs there is none, and the scenario is
    // refused before anything is solved, naming the key and the fix.
    let text = "title = \"drag\"\n[cell]\ncore_divisions = 4\nshell_layers = 2\nouter_layers = 2\n\
                [cell.solver]\ndamping = \"filament-drag\"\n[protocol]\nkind = \"prestress\"\n";
    let error = match parse(text, "drag.toml", std::path::Path::new(".")) {
        Ok(s) => build(&s.model).err().map(|e| e.to_string()),
        Err(e) => Some(e.to_string()),
    }
    .expect("refused");
    assert!(error.contains("drag.toml"), "{error}");
    assert!(error.contains("solver.damping"), "{error}");
    assert!(error.contains("coupling = \"foundation\""), "{error}");
    // With the foundation it builds, and the viscosity is the relative one.
    let tied = parse(
        &text.replace(
            "[cell.solver]",
            "[cell.microtubules]\ncoupling = \"foundation\"\n[cell.solver]",
        ),
        "drag.toml",
        std::path::Path::new("."),
    )
    .unwrap();
    let built = build(&tied.model).unwrap();
    assert_eq!(built.embedding.len(), 1);
    for step in &built.steps {
        let damping = step.control.stabilization.map(|s| s.damping);
        assert_eq!(
            damping,
            Some(cellmech_fem::solve::Damping::Relative),
            "{}",
            step.name
        );
    }
}
