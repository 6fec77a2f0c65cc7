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

/// Replaces the body of every `<!-- generated: NAME -->` … `<!-- /generated -->` block with
/// the table `NAME`.
fn fill_generated_blocks(text: &str) -> String {
    let tables = cellmech::experiment::parameter_tables();
    let mut out = String::new();
    let mut rest = text;
    while let Some(start) = rest.find("<!-- generated: ") {
        let (head, tail) = rest.split_at(start);
        out.push_str(head);
        let name_end = tail.find(" -->").expect("a closed marker");
        let name = &tail["<!-- generated: ".len()..name_end];
        let close = tail.find("<!-- /generated -->").expect("a closing marker");
        let table = tables
            .iter()
            .find(|t| t.name == name)
            .unwrap_or_else(|| panic!("docs name an unknown table {name}"));
        out.push_str(&format!("<!-- generated: {name} -->\n{}", table.markdown()));
        rest = &tail[close..];
    }
    out.push_str(rest);
    out
}

#[test]
fn generated_tables_in_the_docs_match_the_code() {
    let docs = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs");
    let mut checked = 0;
    for entry in std::fs::read_dir(&docs).expect("docs/") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|e| e != "md") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("read");
        if !text.contains("<!-- generated: ") {
            continue;
        }
        let expected = fill_generated_blocks(&text);
        if std::env::var_os("CELLMECH_BLESS").is_some() {
            std::fs::write(&path, &expected).expect("write");
        }
        assert!(
            std::fs::read_to_string(&path).expect("read") == expected,
            "{}: a generated parameter table differs from the code; run `CELLMECH_BLESS=1 cargo test --release -p cellmech --test parameter_docs`",
            path.display()
        );
        checked += 1;
    }
    assert!(checked >= 1, "no docs page embeds a generated table");
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
            assert!(
                !p.doc.is_empty() && !p.source.is_empty(),
                "{}: {} undocumented",
                table.name,
                p.key
            );
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
    let e = cellmech::scenario::parse(typo, "typo.toml", base)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("typo.toml:6")
            && e.contains("cell.cytoplasm.shear_modulos")
            && e.contains("did you mean `cytoplasm.shear_modulus`"),
        "{e}"
    );
    let wrong_unit = "[cell]\ncell_diameter = \"30 kPa\"\n[protocol]\nkind = \"prestress\"\n";
    let e = cellmech::scenario::parse(wrong_unit, "unit.toml", base)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unit.toml:2") && e.contains("cell.cell_diameter") && e.contains("length"),
        "{e}"
    );
    let misplaced = "[cell]\ncore_divisions = 4\nshell_layers = 2\nouter_layers = 2\n[protocol]\nkind = \"microplate-compression\"\npinch = \"1 um\"\n";
    let e = cellmech::scenario::parse(misplaced, "m.toml", base)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("does not apply") && e.contains("micropipette-tension"),
        "{e}"
    );
}

#[test]
fn unknown_keys_of_the_generic_sections_get_a_suggestion_too() {
    let text = "[mesh]\nsource = \"sphere\"\nradus = \"5 um\"\n";
    let e = cellmech::scenario::parse(text, "mesh.toml", std::path::Path::new("."))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 3") && e.contains("did you mean `radius`"),
        "{e}"
    );
}

#[test]
fn shipped_cell_examples_show_the_declared_defaults() {
    // The cell examples say "every key below is optional and shows its default": check it
    // against the tables, so an example cannot silently override a changed default.
    use cellmech::protocol::Protocol;
    for example in cellmech::examples::EXAMPLES {
        let root = toml::de::DeTable::parse(example.text).expect("example parses");
        let root = root.get_ref();
        if root.get("cell").is_none() {
            continue;
        }
        let adherent = matches!(
            root.get("cell").map(|c| c.get_ref()),
            Some(toml::de::DeValue::Table(t))
                if t.get("model").and_then(|m| m.get_ref().as_str()) == Some("adherent")
        );
        let table = if adherent {
            &cellmech::cell::adherent::params::ADHERENT_CELL
        } else {
            &cellmech::cell::suspended::params::SUSPENDED_CELL
        };
        let given = cellmech::param::read_section(root, table, &["model"], &[])
            .unwrap_or_else(|e| panic!("{}: {e:?}", example.name));
        let defaults = ParamValues::defaults(table);
        for key in given.spans.keys() {
            assert_eq!(
                given.values.get(key),
                defaults.values.get(key),
                "{}: [cell] {key}",
                example.name
            );
        }
        let kind = match root.get("protocol").map(|p| p.get_ref()) {
            Some(toml::de::DeValue::Table(t)) => t
                .get("kind")
                .and_then(|k| k.get_ref().as_str())
                .expect("a protocol kind")
                .to_string(),
            _ => continue,
        };
        let table = Protocol::table(&kind).expect("a known kind");
        let given = cellmech::param::read_section(root, table, &["kind"], &[])
            .unwrap_or_else(|e| panic!("{}: {e:?}", example.name));
        let defaults = ParamValues::defaults(table);
        // The receptor example exists to set the site; its comment says so.
        for key in given
            .spans
            .keys()
            .filter(|k| !(example.name == "adherent-afm-receptor" && **k == "site"))
        {
            assert_eq!(
                given.values.get(key),
                defaults.values.get(key),
                "{}: [protocol] {key}",
                example.name
            );
        }
    }
}
