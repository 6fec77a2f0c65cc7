//! The parameter documentation is generated from the code's tables: this test fails when
//! `docs/parameters.md` and the code disagree (`CELLMECH_BLESS=1 cargo test` rewrites it),
//! and checks that every table's defaults pass its own validation and build a model.

use std::path::PathBuf;

use cellmech::param::{ParamKind, ParamValues};

fn docs_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/parameters.md")
}

#[test]
fn parameters_doc_matches_the_code_tables() {
    let generated = cellmech::experiment::parameters_markdown();
    let path = docs_path();
    if std::env::var_os("CELLMECH_BLESS").is_some() {
        std::fs::write(&path, &generated).expect("write docs/parameters.md");
    }
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        on_disk == generated,
        "docs/parameters.md differs from the parameter tables; run `CELLMECH_BLESS=1 cargo test --release -p cellmech --test parameter_docs` and review the diff"
    );
}

#[test]
fn every_default_is_within_its_declared_range_and_keys_are_unique() {
    for table in cellmech::experiment::parameter_tables() {
        let values = ParamValues::defaults(table);
        for p in table.params {
            let mut keys = table.params.iter().filter(|q| q.key == p.key);
            keys.next();
            assert!(keys.next().is_none(), "{}: key {} twice", table.name, p.key);
            if let Some(v) = values.values.get(p.key) {
                let mut again = ParamValues::defaults(table);
                again
                    .set(table, p.key, v.clone())
                    .unwrap_or_else(|e| panic!("{}: default of {}: {e}", table.name, p.key));
            }
            assert!(!p.doc.is_empty() && !p.source.is_empty(), "{}: {} undocumented", table.name, p.key);
            if let ParamKind::Choice(words) = p.kind {
                assert!(!words.is_empty());
            }
        }
    }
}

#[test]
fn the_declared_defaults_are_the_library_defaults() {
    use cellmech::cell::suspended::params::{from_values, SUSPENDED_CELL};
    let (params, materials) = from_values(&ParamValues::defaults(&SUSPENDED_CELL));
    let cell = cellmech::cell::suspended::SuspendedCell::default();
    assert_eq!(params, cell.params);
    assert_eq!(materials, cell.materials);
    // The spec's headline values, so that a slip in the table cannot pass silently.
    assert_eq!(params.cell_diameter, 32.264);
    assert_eq!(materials.cytoplasm_shear_modulus, 0.17);
    assert_eq!(materials.actin.prestrain, 0.24);
    assert_eq!(materials.intermediate.slack, 0.20);
}

#[test]
fn unknown_keys_get_a_suggestion_and_misplaced_protocol_keys_are_named() {
    let base = std::path::Path::new(".");
    let typo = "[cell]\ncore_divisions = 4\nshell_layers = 2\nouter_layers = 2\n[cell.cytoplasm]\nshear_modulos = \"0.2 kPa\"\n[protocol]\nkind = \"prestress\"\n";
    let e = cellmech::scenario::parse(typo, "typo.toml", base).unwrap_err().to_string();
    assert!(e.contains("typo.toml:6") && e.contains("cell.cytoplasm.shear_modulos") && e.contains("did you mean `cytoplasm.shear_modulus`"), "{e}");
    let wrong_unit = "[cell]\ncell_diameter = \"30 kPa\"\n[protocol]\nkind = \"prestress\"\n";
    let e = cellmech::scenario::parse(wrong_unit, "unit.toml", base).unwrap_err().to_string();
    assert!(e.contains("unit.toml:2") && e.contains("cell.cell_diameter") && e.contains("length"), "{e}");
    let misplaced = "[cell]\ncore_divisions = 4\nshell_layers = 2\nouter_layers = 2\n[protocol]\nkind = \"microplate-compression\"\npinch = \"1 um\"\n";
    let e = cellmech::scenario::parse(misplaced, "m.toml", base).unwrap_err().to_string();
    assert!(e.contains("does not apply") && e.contains("micropipette-tension"), "{e}");
}
