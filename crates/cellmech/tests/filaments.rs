//! Per-filament outputs on a hand-built model whose answers are known exactly.
//!
//! GOAL: the per-filament force at the FA end, the state, the family counts, the chord/arc
//! straightness and the filament strain of `summary.json`, `curve.csv`, `filaments.csv`, and
//! the `filament_id`/`filament_family` cell data of the VTU frames.
//! MODEL (no continuum, every translation prescribed except the axial one of the truss
//! middle nodes):
//! * family `cables` (linear trusses, EA = 6 nN): `pull`, two collinear elements of length 1
//!   µm whose middle node moves by 0.02 µm and end node by 0.1 µm (FA at the end):
//!   N = EA·0.02 and EA·0.08; `push`, the same with a free middle node shortened by 0.05 µm
//!   (FA at the start): both elements −EA·0.025;
//! * family `wavy` (tension-only truss, slack 20 %): one element of 1 µm stretched to 1.1 µm,
//!   below its stress-free length 1.2 µm: N = 0, strain 1.1/1.2 − 1;
//! * family `rods` (beams): two chains (0,0)–(1,1)–(2,0) whose middle node is moved to
//!   (1.3, 0.2) and (1, 0.1) (ends held): chord 2, arc √1.73 + √0.53 and 2√1.01, so
//!   chord/arc = 2/(√1.73 + √0.53) (not straight) and 1/√1.01 (straight, > 0.99); both
//!   shorten (compression), the first one most in its second element (its FA end).
//!
//! REFERENCE: the closed forms above (exact to round-off: the truss problem is linear along
//! its axis, the beam positions are prescribed).

use std::path::PathBuf;

use cellmech::analysis::Analysis;
use cellmech::model::filaments::{Filament, FilamentEnd};
use cellmech::model::structures::{FilamentElement, FilamentSpec, StructuresSpec};
use cellmech::model::{ModelSpec, OutputSpec, StepSpec};
use cellmech::output::filaments::FilamentState;
use cellmech_fem::element::beam::BeamSection;
use cellmech_fem::material::AxialLaw;
use cellmech_fem::mesh::Mesh;
use cellmech_fem::solve::{NullObserver, StepControl};

const EA: f64 = 6.0;

fn group(
    name: &str,
    family: &str,
    pairs: Vec<[usize; 2]>,
    element: FilamentElement,
    ends: &[Option<FilamentEnd>],
) -> FilamentSpec {
    let mut filaments = Filament::chains(&pairs);
    assert_eq!(filaments.len(), ends.len());
    for (f, &end) in filaments.iter_mut().zip(ends) {
        f.fa_end = end;
    }
    FilamentSpec {
        name: name.into(),
        family: family.into(),
        pairs,
        filaments,
        element,
        enabled: true,
    }
}

fn model() -> Analysis {
    let mut mesh = Mesh::default();
    let p = |x: f64, y: f64| [x, y, 0.0];
    mesh.nodes = vec![
        // cables: pull 0-1-2, push 3-4-5
        p(0.0, 0.0),
        p(1.0, 0.0),
        p(2.0, 0.0),
        p(0.0, 1.0),
        p(1.0, 1.0),
        p(2.0, 1.0),
        // wavy 6-7
        p(0.0, 2.0),
        p(1.0, 2.0),
        // rods 8-9-10, 11-12-13
        p(0.0, 5.0),
        p(1.0, 6.0),
        p(2.0, 5.0),
        p(0.0, 8.0),
        p(1.0, 9.0),
        p(2.0, 8.0),
    ];
    for (name, nodes) in [
        ("held", vec![0, 3, 6, 8, 10, 11, 13]),
        ("axial", vec![4]),
        ("pull_middle", vec![1]),
        ("pull", vec![2]),
        ("push", vec![5]),
        ("wavy", vec![7]),
        ("rod_a", vec![9]),
        ("rod_b", vec![12]),
    ] {
        mesh.insert_node_set(name, nodes);
    }
    let cable = FilamentElement::Truss(AxialLaw::linear(2.0, 3.0));
    let wavy = FilamentElement::Truss(AxialLaw::tension_only(2.0, 3.0).with_slack(0.2));
    let rod = FilamentElement::Beam(BeamSection::solid_circular(1e3, 0.3, 0.1).unwrap());
    let structures = StructuresSpec {
        filaments: vec![
            group(
                "cables",
                "cables",
                vec![[0, 1], [1, 2], [3, 4], [4, 5]],
                cable,
                &[Some(FilamentEnd::End), Some(FilamentEnd::Start)],
            ),
            group("wavy", "wavy", vec![[6, 7]], wavy, &[None]),
            group(
                "rods",
                "rods",
                vec![[8, 9], [9, 10], [11, 12], [12, 13]],
                rod,
                &[Some(FilamentEnd::End), None],
            ),
        ],
        membranes: Vec::new(),
    };
    let all = [true; 3];
    let yz = [false, true, true];
    let step = StepSpec {
        name: "load".into(),
        control: StepControl {
            initial_increment: 0.25,
            max_increment: 0.25,
            ..StepControl::default()
        },
        fixes: ["held", "rod_a", "rod_b"]
            .iter()
            .map(|s| (s.to_string(), all))
            .chain(
                ["axial", "pull_middle", "pull", "push", "wavy"]
                    .iter()
                    .map(|s| (s.to_string(), yz)),
            )
            .collect(),
        displacements: vec![
            ("pull_middle".into(), 0, 0.02),
            ("pull".into(), 0, 0.1),
            ("push".into(), 0, -0.05),
            ("wavy".into(), 0, 0.1),
            ("rod_a".into(), 0, 0.3),
            ("rod_a".into(), 1, -0.8),
            ("rod_b".into(), 1, -0.9),
        ],
        forces: Vec::new(),
        tools: Vec::new(),
    };
    Analysis {
        title: "filaments".into(),
        origin: "<test>".into(),
        model: ModelSpec {
            mesh,
            materials: Vec::new(),
            structures,
            tools: Vec::new(),
            steps: vec![step],
            output: OutputSpec::default(),
            supports: Vec::new(),
            shape_probes: Vec::new(),
            embedded: Vec::new(),
            hanging: Vec::new(),
            prestressed_reference: None,
            rezone: None,
        },
        cell: None,
        echo: toml::Table::new(),
    }
}

fn out_dir(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("cellmech-filaments-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1e-300)
}

#[test]
fn filaments_report_analytic_forces_states_counts_and_straightness() {
    let dir = out_dir("analytic");
    let summary = cellmech::run::run(&model(), &dir, &mut NullObserver).unwrap();
    let snap = summary.filaments.as_ref().expect("filament table");
    assert_eq!(snap.family_names, ["cables", "wavy", "rods"]);
    let f = &snap.filaments;
    assert_eq!(f.iter().map(|r| r.id).collect::<Vec<_>>(), [0, 1, 2, 3, 4]);
    // pull: tension EA·0.08 at its FA (the end node 2), EA·0.02 at the other end.
    let pull = &f[0];
    assert_eq!(
        (pull.fa_node, pull.state),
        (Some(2), FilamentState::Tension)
    );
    assert!(
        close(pull.fa_force_nn.unwrap(), 0.08 * EA, 1e-9),
        "{pull:?}"
    );
    assert!(close(pull.max_force_nn, 0.08 * EA, 1e-9), "{pull:?}");
    assert!(close(pull.min_force_nn, 0.02 * EA, 1e-9), "{pull:?}");
    assert!(close(pull.arc_um, 2.1, 1e-12) && close(pull.chord_um, 2.1, 1e-12));
    assert!(close(pull.strain, 0.05, 1e-9));
    assert_eq!(pull.straight, None, "trusses have no straightness flag");
    // push: compression −EA·0.025 at its FA (the start node 3).
    let push = &f[1];
    assert_eq!(
        (push.fa_node, push.state),
        (Some(3), FilamentState::Compression)
    );
    assert!(
        close(push.fa_force_nn.unwrap(), -0.025 * EA, 1e-9),
        "{push:?}"
    );
    // wavy: below its stress-free length, exactly zero force: slack.
    let wavy = &f[2];
    assert_eq!((wavy.fa_node, wavy.fa_force_nn), (None, None));
    assert_eq!((wavy.max_force_nn, wavy.state), (0.0, FilamentState::Slack));
    assert!(close(wavy.strain, 1.1 / 1.2 - 1.0, 1e-12), "{wavy:?}");
    // rods: chord/arc in the current configuration.
    let (a, b) = (&f[3], &f[4]);
    let arc_a = 1.73f64.sqrt() + 0.53f64.sqrt();
    assert!(close(a.chord_over_arc, 2.0 / arc_a, 1e-12), "{a:?}");
    assert!(
        close(b.chord_over_arc, 1.0 / 1.01f64.sqrt(), 1e-12),
        "{b:?}"
    );
    assert!(close(a.arc_um, arc_a, 1e-12) && close(a.chord_um, 2.0, 1e-12));
    assert_eq!((a.straight, b.straight), (Some(false), Some(true)));
    assert_eq!((a.fa_node, b.fa_node), (Some(10), None));
    assert!(close(a.strain, arc_a / 8f64.sqrt() - 1.0, 1e-12));
    assert_eq!(a.state, FilamentState::Compression);
    assert_eq!(b.state, FilamentState::Compression);
    // The FA end is the more shortened second element: its force is the minimum.
    assert!(a.fa_force_nn.unwrap() < 0.0 && a.min_force_nn == a.fa_force_nn.unwrap());
    assert!(a.max_force_nn > 0.5 * a.min_force_nn, "{a:?}");
    // Family counts, in summary.json and as the last curve.csv row.
    let c = &snap.families;
    assert_eq!(
        (
            c[0].in_tension,
            c[0].in_compression,
            c[0].slack,
            c[0].filaments
        ),
        (1, 1, 0, 2)
    );
    assert!(close(c[0].fa_force_sum_nn.unwrap(), 0.055 * EA, 1e-9));
    assert_eq!((c[1].slack, c[1].fa_force_sum_nn), (1, None));
    assert_eq!((c[2].in_compression, c[2].straight), (2, Some(1)));
    let fv = &summary.final_values;
    for (column, value) in [
        ("cables_filaments_in_tension", 1.0),
        ("cables_filaments_in_compression", 1.0),
        ("cables_filaments_slack", 0.0),
        ("wavy_filaments_slack", 1.0),
        ("rods_filaments_in_compression", 2.0),
        ("rods_filaments_straight", 1.0),
    ] {
        assert_eq!(fv[column], value, "{column}");
    }
    assert!(close(fv["cables_fa_force_sum_nN"], 0.055 * EA, 1e-9));
    assert!(close(
        fv["rods_fa_force_sum_nN"],
        a.fa_force_nn.unwrap(),
        1e-15
    ));
    assert!(!fv.contains_key("wavy_fa_force_sum_nN"));
    assert!(!fv.contains_key("cables_filaments_straight"));
    // The initial state: nothing loaded, the bent rods at chord/arc 1/√2.
    let csv = std::fs::read_to_string(dir.join("filaments.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let curve_rows = std::fs::read_to_string(dir.join("curve.csv"))
        .unwrap()
        .lines()
        .count()
        - 1;
    assert_eq!(rows.len(), 5 * curve_rows, "one row per filament per state");
    assert_eq!(
        rows[3][..13],
        ["0", "0", "0.0", "rods", "3", "0", "8", "10", "10", "0.0", "0.0", "0.0", "slack"]
    );
    let ratio: f64 = rows[3][15].parse().unwrap();
    assert!(close(ratio, 0.5f64.sqrt(), 1e-12), "{ratio}");
    let last = &rows[rows.len() - 5..];
    assert_eq!(last[0][3..9], ["cables", "0", "0", "0", "2", "2"]);
    assert_eq!(last[0][12], "tension");
    assert_eq!((last[0][16], last[3][16], last[4][16]), ("", "0", "1"));
    assert_eq!((last[2][8], last[2][9], last[2][12]), ("", "", "slack"));
    let force: f64 = last[0][9].parse().unwrap();
    assert_eq!(force, pull.fa_force_nn.unwrap());
    // VTU: every line cell carries its filament id and family index.
    let frames = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| {
            let name = e.as_ref().unwrap().file_name();
            name.to_string_lossy().ends_with(".vtu")
        })
        .count();
    assert_eq!(frames, curve_rows, "a frame per converged increment");
    let vtu = std::fs::read_to_string(dir.join(format!("fields_{:04}.vtu", frames - 1))).unwrap();
    assert_eq!(
        float64_array(&vtu, "filament_id"),
        [0.0, 0.0, 1.0, 1.0, 2.0, 3.0, 3.0, 4.0, 4.0]
    );
    assert_eq!(
        float64_array(&vtu, "filament_family"),
        [0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 2.0, 2.0, 2.0]
    );
    // The FA-end forces are those of the elements at the FA ends (cells 1, 2 and 6).
    let n = float64_array(&vtu, "axial_force_nN");
    assert_eq!(
        [n[1], n[2], n[6]],
        [
            pull.fa_force_nn.unwrap(),
            push.fa_force_nn.unwrap(),
            a.fa_force_nn.unwrap()
        ]
    );
    assert!(n[5] != n[6], "{n:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_filament_list_that_does_not_match_the_elements_is_a_build_error() {
    let mut analysis = model();
    analysis.model.structures.filaments[0].filaments[1].elements = 2..3;
    let err = cellmech::model::build(&analysis.model)
        .err()
        .expect("rejected")
        .to_string();
    assert!(err.contains("cover 3 of 4 elements"), "{err}");
}

/// A Float64 DataArray of a binary VTU file.
fn float64_array(vtu: &str, name: &str) -> Vec<f64> {
    cellmech_io::read_f64_array(vtu, name).unwrap_or_else(|| panic!("no array {name}"))
}
