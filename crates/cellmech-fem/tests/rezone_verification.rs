//! Verification of ALE rezoning through the whole engine (`cellmech_fem::rezone`,
//! `Problem::remap_nodes`).
//!
//! GOAL: a rezoning between steps maps an equilibrium onto moved nodes without losing it.
//! For a hyperelastic body the equilibrium depends on the mesh and the boundary values
//! only, not on the path: re-equilibrated after the rezoning, the state must be the one a
//! fresh solve on the rezoned mesh finds.
//! MESH: a 1 µm cube of 4 × 4 × 4 hex8 (neo-Hookean, G = 1 kPa, ν = 0.45).
//! BCS: bottom face held; top face moved by (0.15, 0.05, −0.12) µm (shear and
//! compression: a non-uniform state); interior nodes moved in the current configuration by
//! a seeded fifth of an element.
//! REFERENCE: the same mesh (the rezoned reference positions) solved from scratch.

use cellmech_fem::continuum::ContinuumBlock;
use cellmech_fem::dof::DofMap;
use cellmech_fem::element::hex8::Hex8Formulation;
use cellmech_fem::linsolve::DenseSolver;
use cellmech_fem::material::NeoHookean;
use cellmech_fem::mesh::generate::box_mesh;
use cellmech_fem::mesh::Mesh;
use cellmech_fem::rezone::{remap_to, RezoneInput};
use cellmech_fem::solve::{Motion, NullObserver, Problem, Step};

const TOP_MOTION: [f64; 3] = [0.15, 0.05, -0.12];

fn problem(mesh: &Mesh) -> Problem {
    let law = NeoHookean::from_shear_poisson(1.0, 0.45).unwrap();
    let block = ContinuumBlock::new(
        &mesh.blocks[0],
        &mesh.nodes,
        law,
        Hex8Formulation::MeanDilatation,
    )
    .unwrap();
    Problem::new(
        DofMap::translational(mesh.num_nodes()),
        vec![Box::new(block)],
        Box::new(DenseSolver::default()),
    )
    .unwrap()
}

/// The bottom held and the top moved by `TOP_MOTION` (`moving`) or held where it is.
fn step(mesh: &Mesh, moving: bool) -> Step {
    let mut step = Step::new(if moving { "load" } else { "hold" });
    for &n in &mesh.node_sets["z_min"] {
        step.prescribed
            .extend((0..3).map(|c| (3 * n + c, Motion::Hold)));
    }
    for &n in &mesh.node_sets["z_max"] {
        step.prescribed.extend((0..3).map(|c| {
            (
                3 * n + c,
                if moving {
                    Motion::By(TOP_MOTION[c])
                } else {
                    Motion::Hold
                },
            )
        }));
    }
    step
}

fn top_reaction(p: &Problem, mesh: &Mesh) -> [f64; 3] {
    std::array::from_fn(|c| p.reaction_sum(mesh.node_sets["z_max"].iter().map(|&n| 3 * n + c)))
}

#[test]
fn a_rezoned_equilibrium_re_solves_to_the_fresh_solution_on_the_new_mesh() {
    let mesh = box_mesh([0.0; 3], [1.0; 3], [4, 4, 4], "gel").unwrap();
    let mut p = problem(&mesh);
    p.run_step(&step(&mesh, true), &mut NullObserver).unwrap();
    let before = top_reaction(&p, &mesh);
    assert!(before[0] > 0.01 && before[2] < -0.01, "{before:?}");
    // Rezone: interior nodes moved by a seeded fifth of an element in the current mesh.
    let n = mesh.num_nodes();
    let current: Vec<[f64; 3]> = (0..n)
        .map(|i| std::array::from_fn(|c| mesh.nodes[i][c] + p.u()[3 * i + c]))
        .collect();
    let boundary: std::collections::HashSet<usize> =
        ["x_min", "x_max", "y_min", "y_max", "z_min", "z_max"]
            .iter()
            .flat_map(|s| mesh.node_sets[*s].iter().copied())
            .collect();
    let mut state = 2024u64;
    let mut rand = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let targets: Vec<(usize, [f64; 3])> = (0..n)
        .filter(|i| !boundary.contains(i))
        .map(|i| {
            (
                i,
                std::array::from_fn(|c| current[i][c] + 0.4 * 0.25 * rand()),
            )
        })
        .collect();
    let elements: Vec<[usize; 8]> = mesh.blocks[0]
        .elements()
        .map(|e| std::array::from_fn(|a| e[a]))
        .collect();
    let movable: Vec<bool> = (0..n).map(|i| !boundary.contains(&i)).collect();
    let input = RezoneInput {
        reference: &mesh.nodes,
        current: &current,
        elements: &elements,
        movable: &movable,
        hanging: &[],
        surface_faces: &[],
        sliding: &[],
    };
    let rezoning = remap_to(&input, &targets, Vec::new()).unwrap();
    assert_eq!(rezoning.unlocated, 0);
    assert_eq!(rezoning.remaps.len(), 27);
    let mut reference = mesh.nodes.clone();
    for remap in &rezoning.remaps {
        reference[remap.node] = remap.apply(&mesh.nodes);
    }
    p.remap_nodes(&rezoning.remaps, &reference).unwrap();
    // The mapped state: the moved nodes are where they were sent.
    for &(i, target) in &targets {
        for c in 0..3 {
            let x = reference[i][c] + p.u()[3 * i + c];
            assert!((x - target[c]).abs() < 1e-12, "node {i}");
        }
    }
    p.run_step(&step(&mesh, false), &mut NullObserver).unwrap();
    let after = top_reaction(&p, &mesh);
    // The fresh solve on the rezoned mesh.
    let mut fresh_mesh = mesh.clone();
    fresh_mesh.nodes = reference.clone();
    let mut fresh = problem(&fresh_mesh);
    fresh
        .run_step(&step(&fresh_mesh, true), &mut NullObserver)
        .unwrap();
    let expected = top_reaction(&fresh, &fresh_mesh);
    eprintln!(
        "before {before:?}, rezoned and re-solved {after:?}, fresh on the new mesh {expected:?}"
    );
    for c in 0..3 {
        assert!(
            (after[c] - expected[c]).abs() < 1e-6 * expected[c].abs().max(1e-3),
            "component {c}: {} against {}",
            after[c],
            expected[c]
        );
        // And the mesh change itself moves the answer only by a discretisation error.
        assert!(
            (after[c] - before[c]).abs() < 0.05 * before[c].abs().max(0.01),
            "{c}"
        );
    }
    for i in 0..n {
        for c in 0..3 {
            assert!(
                (p.u()[3 * i + c] - fresh.u()[3 * i + c]).abs() < 1e-7,
                "node {i}"
            );
        }
    }
}
