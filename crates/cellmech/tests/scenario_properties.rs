//! Property tests of the scenario parser (issue 9): mutations of the shipped examples and of
//! scenarios with mesh files give a `Scenario` or a `ScenarioError` that names the scenario,
//! never a panic or a hang.
//!
//! Mutations: dropped and duplicated lines (keys, section headers), values of another type,
//! bad units (`"1 furlong"`), negative, zero, NaN, overflowing and huge numbers (counts of
//! 1e9 that must be rejected before allocating), empty arrays, unknown keys, duplicated
//! sections, truncation; and, for `source = "file"`, the same edits of the mesh file.
//!
//! Every property runs a fixed number of cases from a fixed seed (see
//! `crates/cellmech-io/tests/support/mutate.rs`), so CI is fast and a failure reproduces.
//! A `[cell]` scenario builds the cell geometry and mesh (tens of ms), so it gets fewer cases.
//! Longer local runs, with other cases:
//!
//! ```text
//! PROPTEST_CASES=5000 PROPTEST_RNG_SEED=7 cargo test --release -p cellmech --test scenario_properties
//! ```
//!
//! `FUZZ_STATS=1` (with `-- --nocapture`) prints how each case ended, to check that the
//! mutations reach the scenario checks rather than stopping at TOML syntax errors.

#[path = "../../cellmech-io/tests/support/mutate.rs"]
mod mutate;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use cellmech::examples::EXAMPLES;
use cellmech::scenario::parse;
use mutate::{apply_all, generic_mutation, guarded, strip_comment_lines, toml_mutation, Mutation};
use proptest::prelude::*;

/// The name the scenarios are given; every error message must contain it.
const ORIGIN: &str = "fuzz-scenario.toml";

/// Far above the tens of ms of a case: catches hangs and runaway allocations.
const TIMEOUT: Duration = Duration::from_secs(60);

fn is_cell(text: &str) -> bool {
    text.lines().any(|l| l.trim() == "[cell]")
}

/// The shipped examples without `[cell]`, comment lines stripped.
fn mesh_examples() -> Vec<String> {
    EXAMPLES
        .iter()
        .map(|e| e.text)
        .filter(|t| !is_cell(t))
        .map(strip_comment_lines)
        .collect()
}

/// The shipped examples with `[cell]` (slow to build), comment lines stripped.
fn cell_examples() -> Vec<String> {
    EXAMPLES
        .iter()
        .map(|e| e.text)
        .filter(|t| is_cell(t))
        .map(strip_comment_lines)
        .collect()
}

/// A fresh directory for one case's files.
fn case_dir() -> PathBuf {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "cellmech-scenario-props-{}-{}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).expect("create a scratch directory");
    dir
}

/// Parses `text` on a guarded thread; an error must name [`ORIGIN`].
fn check_scenario(text: String, base_dir: &Path, extra: &str) -> Result<(), TestCaseError> {
    let input = text.clone();
    let base = base_dir.to_path_buf();
    let shown = format!("{text}\n{extra}");
    let result = guarded("scenario::parse", &shown, TIMEOUT, move || {
        parse(&input, ORIGIN, &base).map(|s| s.model.mesh.num_nodes())
    })?;
    if std::env::var_os("FUZZ_STATS").is_some() {
        match &result {
            Ok(nodes) => eprintln!("FUZZ_STATS ok {nodes} nodes"),
            Err(e) => eprintln!(
                "FUZZ_STATS err {}",
                e.to_string().lines().next().unwrap_or("")
            ),
        }
    }
    if let Err(err) = result {
        let message = err.to_string();
        prop_assert!(
            message.contains(ORIGIN),
            "the error '{message}' does not name the scenario {ORIGIN}; {}",
            mutate::describe(&shown)
        );
    }
    Ok(())
}

/// A scenario on the two-hex Gmsh mesh of cellmech-io's test data.
const GMSH_SCENARIO: &str = r#"title = "two hexes from a Gmsh file"

[mesh]
source = "file"
path = "mesh.msh"

[[material]]
element_set = "entity_3_1"
shear_modulus = "1 kPa"
poisson_ratio = 0.3

[[node_set]]
name = "left"
x_max = "0.1 um"

[[node_set]]
name = "right"
x_min = "1.9 um"

[[step]]
name = "pull"

  [[step.fix]]
  node_set = "left"

  [[step.displace]]
  node_set = "right"
  x = "0.5 um"

[[output.curve]]
name = "right"
node_set = "right"
component = "x"
"#;

/// A scenario on the small Abaqus deck of cellmech-io's test data (a hex8 and a truss).
const ABAQUS_SCENARIO: &str = r#"title = "a hex from an Abaqus deck"

[mesh]
source = "file"
path = "mesh.inp"

[[material]]
element_set = "Body"
shear_modulus = "1 kPa"
bulk_modulus = "10 kPa"

[[step]]
name = "press"

  [[step.fix]]
  node_set = "BOTTOM"

  [[step.displace]]
  node_set = "ODD"
  z = "-0.1 um"
"#;

const GMSH_MESH: &str = include_str!("../../cellmech-io/tests/data/meshio_two_hexes.msh");
const ABAQUS_MESH: &str = include_str!("../../cellmech-io/tests/data/sets_deck.inp");

fn toml_mutations(max: usize) -> impl Strategy<Value = Vec<Mutation>> {
    prop::collection::vec(toml_mutation(), 1..max)
}

proptest! {
    #![proptest_config(mutate::config(1024))]

    #[test]
    fn mutated_mesh_examples_are_an_error_not_a_panic(
        seed in prop::sample::select(mesh_examples()),
        mutations in toml_mutations(5),
    ) {
        let dir = case_dir();
        check_scenario(apply_all(&seed, &mutations), &dir, "")?;
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn mutated_mesh_files_are_an_error_not_a_panic(
        gmsh in any::<bool>(),
        mesh_mutations in prop::collection::vec(generic_mutation(), 0..4),
        scenario_mutations in prop::collection::vec(toml_mutation(), 0..3),
    ) {
        let (scenario, mesh, name) = if gmsh {
            (GMSH_SCENARIO, GMSH_MESH, "mesh.msh")
        } else {
            (ABAQUS_SCENARIO, ABAQUS_MESH, "mesh.inp")
        };
        let dir = case_dir();
        let mesh = apply_all(mesh, &mesh_mutations);
        std::fs::write(dir.join(name), &mesh).expect("write the mesh file");
        let shown_mesh = format!("with {name}:\n{mesh}");
        check_scenario(apply_all(scenario, &scenario_mutations), &dir, &shown_mesh)?;
        let _ = std::fs::remove_dir_all(&dir);
    }
}

proptest! {
    #![proptest_config(mutate::config(256))]

    #[test]
    fn mutated_cell_examples_are_an_error_not_a_panic(
        seed in prop::sample::select(cell_examples()),
        mutations in toml_mutations(3),
    ) {
        let dir = case_dir();
        check_scenario(apply_all(&seed, &mutations), &dir, "")?;
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn seeds_parse_unmutated() {
    let dir = case_dir();
    std::fs::write(dir.join("mesh.msh"), GMSH_MESH).unwrap();
    std::fs::write(dir.join("mesh.inp"), ABAQUS_MESH).unwrap();
    for text in [GMSH_SCENARIO, ABAQUS_SCENARIO] {
        parse(text, ORIGIN, &dir).unwrap();
    }
    for text in mesh_examples() {
        parse(&text, ORIGIN, &dir).unwrap();
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The shipped example `name`, with `from` replaced by `to` (which must occur).
fn edited_example(name: &str, from: &str, to: &str) -> String {
    let text = cellmech::examples::find(name)
        .expect("a shipped example")
        .text;
    assert!(text.contains(from), "{name} has no '{from}'");
    text.replacen(from, to, 1)
}

#[test]
fn huge_counts_are_rejected_before_allocating() {
    const HUGE: &str = "1000000000";
    let cases = [
        (
            "block-uniaxial",
            "divisions = [3, 3, 3]",
            format!("divisions = [{HUGE}, {HUGE}, {HUGE}]"),
        ),
        (
            "block-uniaxial",
            "divisions = [3, 3, 3]",
            format!("divisions = [{HUGE}, 1, 1]"),
        ),
        (
            "block-uniaxial",
            "divisions = [3, 3, 3]",
            "divisions = [18446744073709551615, 2, 2]".into(),
        ),
        (
            "sphere-compression",
            "core_divisions = 4",
            format!("core_divisions = {HUGE}"),
        ),
        (
            "sphere-compression",
            "shell_layers = 4",
            format!("shell_layers = {HUGE}"),
        ),
        (
            "sphere-compression",
            "shell_layers = 4",
            "shell_layers = 18446744073709551615".into(),
        ),
        (
            "suspended-tension",
            // The example shows the key commented (its default depends on the coupling).
            "# elements = 8",
            format!("elements = {HUGE} #"),
        ),
        (
            "suspended-tension",
            "per_fa = 2",
            format!("per_fa = {HUGE}"),
        ),
        (
            "suspended-tension",
            "seed = 2024",
            format!("seed = 2024\ncore_divisions = {HUGE}"),
        ),
        (
            "suspended-tension",
            "seed = 2024",
            format!("seed = 2024\nshell_layers = {HUGE}"),
        ),
        (
            "suspended-tension",
            "seed = 2024",
            format!("seed = 2024\nouter_layers = {HUGE}"),
        ),
        (
            "suspended-tension",
            "seed = 2024",
            format!("seed = 2024\nfa_orientation = \"optimized\"\norientation_trials = {HUGE}"),
        ),
        (
            // A cell 1000 times longer asks the octree for ~10⁸ elements at the tip.
            "adherent-afm-apex",
            "\"19 um\"",
            "\"19 mm\"".into(),
        ),
        (
            "suspended-compression",
            "deformations = [\"10%\", \"30%\", \"50%\"]",
            format!("deformations = [{}]", vec!["\"10%\""; 10_000].join(", ")),
        ),
    ];
    for (name, from, to) in cases {
        let text = edited_example(name, from, &to);
        let dir = case_dir();
        let input = text.clone();
        let base = dir.clone();
        let result = guarded(
            "scenario::parse",
            &text,
            Duration::from_secs(20),
            move || parse(&input, ORIGIN, &base).map(|s| s.model.mesh.num_nodes()),
        );
        let _ = std::fs::remove_dir_all(&dir);
        match result {
            Ok(Err(e)) => assert!(e.to_string().contains(ORIGIN), "{e}"),
            Ok(Ok(nodes)) => panic!(
                "{name} with '{}' was accepted ({nodes} nodes)",
                to.chars().take(80).collect::<String>()
            ),
            Err(failure) => panic!("{failure}"),
        }
    }
}

/// An `Index` that picks position `k` of `n`, found by sampling (`Index` is opaque).
fn index_for(
    k: usize,
    n: usize,
    runner: &mut proptest::test_runner::TestRunner,
) -> proptest::sample::Index {
    use proptest::strategy::ValueTree;
    loop {
        let i = any::<proptest::sample::Index>()
            .new_tree(runner)
            .unwrap()
            .current();
        if i.index(n) == k {
            return i;
        }
    }
}

/// Every single-number edit of every shipped example: each number (in a quantity or bare)
/// replaced by each value of the pools (about 6000 parses, 30 s in release); run it with
/// `cargo test --release -p cellmech --test scenario_properties -- --ignored`.
#[test]
#[ignore = "exhaustive, about 30 s: run on demand"]
fn every_single_number_edit_of_the_examples_is_an_error_not_a_panic() {
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let dir = case_dir();
    let mut cases = 0;
    for example in EXAMPLES {
        let text = strip_comment_lines(example.text);
        for (quoted, pool) in [
            (true, mutate::QUANTITY_NUMBERS),
            (false, mutate::TOML_NUMBERS),
        ] {
            let n = mutate::count_numbers(&text, quoted);
            for k in 0..n {
                let i = index_for(k, n, &mut runner);
                for value in pool {
                    let m = if quoted {
                        Mutation::ReplaceQuotedNumber(i.clone(), value.to_string())
                    } else {
                        Mutation::ReplaceBareNumber(i.clone(), value.to_string())
                    };
                    let edited = m.apply(&text);
                    cases += 1;
                    if let Err(e) = check_scenario(edited, &dir, "") {
                        panic!("{} position {k} -> {value}: {e}", example.name);
                    }
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("{cases} single-number edits");
}

/// Every single-value edit of every shipped example: the value of each `key = value` line
/// replaced by each value of `TOML_VALUES` (wrong types, bad units, out-of-range numbers,
/// empty arrays; about 11 000 parses, 25 s in release); run it with `-- --ignored`.
#[test]
#[ignore = "exhaustive, about 30 s: run on demand"]
fn every_single_value_edit_of_the_examples_is_an_error_not_a_panic() {
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let dir = case_dir();
    let mut cases = 0;
    for example in EXAMPLES {
        let text = strip_comment_lines(example.text);
        let n = mutate::count_key_values(&text);
        for k in 0..n {
            let i = index_for(k, n, &mut runner);
            for value in mutate::TOML_VALUES {
                let edited = Mutation::ReplaceValue(i.clone(), value.to_string()).apply(&text);
                cases += 1;
                if let Err(e) = check_scenario(edited, &dir, "") {
                    panic!("{} key line {k} -> {value}: {e}", example.name);
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("{cases} single-value edits");
}
