//! Property tests of the mesh readers (issue 9): random and mutated Gmsh and Abaqus text gives
//! a mesh or a `ReadError` that names the file, never a panic or a hang.
//!
//! Every property runs a fixed number of cases from a fixed seed (see `support/mutate.rs`),
//! so CI is fast and a failure reproduces. Longer local runs, with other cases:
//!
//! ```text
//! PROPTEST_CASES=20000 PROPTEST_RNG_SEED=7 cargo test --release -p cellmech-io --test parser_properties
//! ```
//!
//! A failure prints the shrunk list of mutations and the mutated text; proptest also saves
//! the failing seed in `parser_properties.proptest-regressions` beside this file, which is
//! replayed first on the next run (commit it with the fix).

#[path = "support/mutate.rs"]
mod mutate;

use std::time::Duration;

use cellmech_io::{parse_abaqus, parse_gmsh, AbaqusDeck, ReadError};
use mutate::{apply_all, generic_mutation, guarded, line_text, Mutation};
use proptest::prelude::*;

/// The name the inputs are given; every error message must contain it.
const GMSH_FILE: &str = "fuzz-input.msh";
const ABAQUS_FILE: &str = "fuzz-input.inp";

/// A parse of the small seeds takes microseconds; this catches hangs and runaway loops.
const TIMEOUT: Duration = Duration::from_secs(10);

const GMSH_SEEDS: &[&str] = &[
    include_str!("data/cube_entities.msh"),
    include_str!("data/meshio_two_hexes.msh"),
    include_str!("data/tet10.msh"),
];

const ABAQUS_SEEDS: &[&str] = &[include_str!("data/sets_deck.inp")];

/// The CalculiX reference deck of shared/ (3000 lines), when this machine has it.
fn reference_deck() -> Option<String> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/reference/sphere_compression/problem.inp");
    std::fs::read_to_string(path).ok()
}

/// An error must name the input.
fn check_error(err: &ReadError, file: &str, input: &str) -> Result<(), TestCaseError> {
    let message = err.to_string();
    prop_assert!(
        message.contains(file),
        "the error '{message}' does not name the file {file}; {}",
        mutate::describe(input)
    );
    Ok(())
}

/// A mesh that parsed must be consistent (every index in range).
fn check_mesh(mesh: &cellmech_fem::mesh::Mesh, input: &str) -> Result<(), TestCaseError> {
    if let Err(e) = mesh.validate() {
        return Err(TestCaseError::fail(format!(
            "the reader returned an inconsistent mesh ({e}) for {}",
            mutate::describe(input)
        )));
    }
    for (k, p) in mesh.nodes.iter().enumerate() {
        prop_assert!(
            p.iter().all(|c| c.is_finite()),
            "node {k} has a non-finite coordinate {p:?}; {}",
            mutate::describe(input)
        );
    }
    Ok(())
}

fn check_gmsh(text: String) -> Result<(), TestCaseError> {
    let input = text.clone();
    let result = guarded("parse_gmsh", &text, TIMEOUT, move || {
        parse_gmsh(&input, GMSH_FILE)
    })?;
    match result {
        Ok(mesh) => check_mesh(&mesh, &text),
        Err(err) => check_error(&err, GMSH_FILE, &text),
    }
}

fn check_deck(deck: &AbaqusDeck, input: &str) -> Result<(), TestCaseError> {
    check_mesh(&deck.mesh, input)?;
    prop_assert_eq!(deck.node_labels.len(), deck.mesh.num_nodes());
    for (name, refs) in &deck.element_sets {
        for r in refs {
            prop_assert!(
                r.block < deck.mesh.blocks.len() && r.element < deck.mesh.blocks[r.block].len(),
                "element set {name} holds {r:?}, which is not an element; {}",
                mutate::describe(input)
            );
        }
    }
    Ok(())
}

fn check_abaqus(text: String) -> Result<(), TestCaseError> {
    let input = text.clone();
    let result = guarded("parse_abaqus", &text, TIMEOUT, move || {
        parse_abaqus(&input, ABAQUS_FILE)
    })?;
    match result {
        Ok(deck) => check_deck(&deck, &text),
        Err(err) => check_error(&err, ABAQUS_FILE, &text),
    }
}

fn mutations() -> impl Strategy<Value = Vec<Mutation>> {
    prop::collection::vec(generic_mutation(), 1..6)
}

proptest! {
    #![proptest_config(mutate::config(512))]

    #[test]
    fn gmsh_random_bytes_are_an_error_not_a_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        check_gmsh(String::from_utf8_lossy(&bytes).into_owned())?;
    }

    #[test]
    fn gmsh_random_lines_are_an_error_not_a_panic(lines in prop::collection::vec(line_text(), 0..40)) {
        // Start like a real file half of the time, so the sections get read.
        let mut text = String::new();
        if lines.len() % 2 == 0 {
            text.push_str("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
        }
        text.push_str(&lines.join("\n"));
        check_gmsh(text)?;
    }

    #[test]
    fn abaqus_random_bytes_are_an_error_not_a_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        check_abaqus(String::from_utf8_lossy(&bytes).into_owned())?;
    }

    #[test]
    fn abaqus_random_lines_are_an_error_not_a_panic(lines in prop::collection::vec(line_text(), 0..40)) {
        check_abaqus(lines.join("\n"))?;
    }
}

proptest! {
    #![proptest_config(mutate::config(2048))]

    #[test]
    fn gmsh_mutated_files_are_an_error_not_a_panic(
        seed in prop::sample::select(GMSH_SEEDS),
        mutations in mutations(),
    ) {
        check_gmsh(apply_all(seed, &mutations))?;
    }

    #[test]
    fn abaqus_mutated_decks_are_an_error_not_a_panic(
        seed in prop::sample::select(ABAQUS_SEEDS),
        mutations in mutations(),
    ) {
        check_abaqus(apply_all(seed, &mutations))?;
    }
}

proptest! {
    #![proptest_config(mutate::config(128))]

    #[test]
    fn abaqus_mutated_reference_deck_is_an_error_not_a_panic(mutations in mutations()) {
        let Some(deck) = reference_deck() else { return Ok(()) };
        check_abaqus(apply_all(&deck, &mutations))?;
    }
}

#[test]
fn seeds_parse_unmutated() {
    for seed in GMSH_SEEDS {
        parse_gmsh(seed, GMSH_FILE).unwrap().validate().unwrap();
    }
    for seed in ABAQUS_SEEDS {
        parse_abaqus(seed, ABAQUS_FILE)
            .unwrap()
            .mesh
            .validate()
            .unwrap();
    }
}

#[test]
fn mutations_do_what_they_say() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    // Any index picks the only candidate of these one-candidate texts.
    let any_index = || {
        any::<proptest::sample::Index>()
            .new_tree(&mut TestRunner::deterministic())
            .unwrap()
            .current()
    };
    let text = "a = 1\nb = \"2.5 um\"\n[s]\nc = C3D8\n";
    assert_eq!(
        mutate::number_spans(text)
            .iter()
            .map(|&(s, e)| &text[s..e])
            .collect::<Vec<_>>(),
        vec!["1", "2.5"]
    );
    assert_eq!(
        Mutation::ReplaceNumber(any_index(), "nan".into()).apply("x = 1 # C3D8\n"),
        "x = nan # C3D8\n"
    );
    assert_eq!(
        Mutation::ReplaceUnit(any_index(), "furlong".into()).apply(text),
        "a = 1\nb = \"2.5 furlong\"\n[s]\nc = C3D8\n"
    );
    assert_eq!(
        Mutation::ReplaceValue(any_index(), "[]".into()).apply("[s]\na = 1\n"),
        "[s]\na = []\n"
    );
    assert_eq!(
        Mutation::DuplicateSection(any_index()).apply(text),
        "a = 1\nb = \"2.5 um\"\n[s]\nc = C3D8\n[s]\nc = C3D8\n"
    );
    assert_eq!(Mutation::DeleteLine(any_index()).apply("only\n"), "");
}

// Regressions: inputs the properties found, each once a panic, an unbounded allocation or a
// non-finite coordinate let through.

fn gmsh_error(text: &str) -> String {
    parse_gmsh(text, GMSH_FILE).unwrap_err().to_string()
}

fn abaqus_error(text: &str) -> String {
    parse_abaqus(text, ABAQUS_FILE).unwrap_err().to_string()
}

#[test]
fn issue_9_gmsh_huge_physical_tag_count_is_an_error() {
    // The count 2^64 - 1 overflowed `first + 1 + n` (a panic in debug builds; in release a
    // slice with start > end and a `Vec::with_capacity(usize::MAX)`: capacity overflow).
    let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n1 0 0 0\n\
                1 0 0 0 18446744073709551615 7\n$EndEntities\n";
    let err = gmsh_error(text);
    assert_eq!(
        err,
        "fuzz-input.msh line 6: expected 18446744073709551615 physical tags, found 1"
    );
}

#[test]
fn issue_9_gmsh_huge_node_count_reserves_no_memory_for_it() {
    let text = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n0 18446744073709551615 1 1\n\
                $EndNodes\n";
    let err = gmsh_error(text);
    assert!(
        err.contains("line 5") && err.contains("announces 18446744073709551615 nodes"),
        "{err}"
    );
}

#[test]
fn issue_9_gmsh_non_finite_coordinates_are_errors() {
    let seed = include_str!("data/meshio_two_hexes.msh");
    for bad in ["NaN", "inf", "-inf", "1e400"] {
        let text = seed.replacen("0.0000000000000000e+00", bad, 1);
        let err = gmsh_error(&text);
        assert_eq!(
            err,
            format!(
                "fuzz-input.msh line 23: expected a coordinate, found '{bad}', which is not finite"
            )
        );
    }
}

#[test]
fn issue_9_abaqus_non_finite_coordinates_are_errors() {
    let seed = include_str!("data/sets_deck.inp");
    for bad in ["NaN", "inf", "1e400"] {
        let text = seed.replacen("2, 1, 0, 0", &format!("2, 1, {bad}, 0"), 1);
        let err = abaqus_error(&text);
        assert_eq!(
            err,
            format!(
                "fuzz-input.inp line 5: expected a number for coordinate 2, found '{bad}', \
                 which is not finite"
            )
        );
    }
}

#[test]
fn issue_9_abaqus_generate_over_the_whole_i64_range_is_an_error() {
    // `end - start` overflowed i64 (a panic in debug builds; in release a wrapped count
    // passed the size check and collecting the range panicked: capacity overflow).
    let text = "*NSET, NSET=A, GENERATE\n-9223372036854775808, 9223372036854775807\n";
    assert_eq!(
        abaqus_error(text),
        "fuzz-input.inp line 2: GENERATE range of 18446744073709551616 labels, but only 0 nodes \
         are defined, found '-9223372036854775808, 9223372036854775807'"
    );
    // A range just under the old limit of 10^8 labels no longer allocates 10^8 entries
    // before it finds that they are not defined.
    let text = "*NODE\n1, 0, 0, 0\n*ELSET, ELSET=B, GENERATE\n1, 99999999\n";
    assert!(abaqus_error(text).contains("only 0 elements are defined"));
    // A range of defined labels still works.
    let deck = parse_abaqus(
        "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 2, 0, 0\n*NSET, NSET=A, GENERATE\n1, 3\n",
        ABAQUS_FILE,
    )
    .unwrap();
    assert_eq!(deck.mesh.node_sets["A"], vec![0, 1, 2]);
}

#[test]
fn issue_9_abaqus_sets_naming_themselves_do_not_double_per_line() {
    // Each line `A` appended A to itself: 2^60 entries after 60 lines (out of memory).
    let mut text = String::from("*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n*NSET, NSET=A\n1, 2\n");
    text.push_str(&"A\n".repeat(60));
    text.push_str("*NSET, NSET=B\nA\n*NSET, NSET=A\nB\n".repeat(30).as_str());
    text.push_str("*ELEMENT, TYPE=T3D2, ELSET=E\n10, 1, 2\n*ELSET, ELSET=E\n");
    text.push_str(&"E\n".repeat(60));
    text.push_str(&"*NSET, NSET=C, ELSET=E\n".repeat(100));
    let deck = parse_abaqus(&text, ABAQUS_FILE).unwrap();
    assert_eq!(deck.mesh.node_sets["A"], vec![0, 1]);
    assert_eq!(deck.mesh.node_sets["B"], vec![0, 1]);
    assert_eq!(deck.mesh.node_sets["C"], vec![0, 1]);
    assert_eq!(deck.element_sets["E"].len(), 1);
}
