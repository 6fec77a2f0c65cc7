//! Verification of rigid-tool contact through the whole engine.
//!
//! Each test opens with GOAL / MESH / BCS / REFERENCE and fails if the physics were wrong.

use cellmech_fem::contact::{ContactKind, RigidContact, ToolShape};
use cellmech_fem::continuum::ContinuumBlock;
use cellmech_fem::dof::DofMap;
use cellmech_fem::element::hex8::Hex8Formulation;
use cellmech_fem::linsolve::{DenseSolver, LinearSolver};
use cellmech_fem::material::NeoHookean;
use cellmech_fem::mesh::generate::box_mesh;
use cellmech_fem::mesh::Mesh;
use cellmech_fem::solve::{Motion, NullObserver, Problem, Step};
use cellmech_fem::term::Term;

fn dense() -> Box<dyn LinearSolver> {
    Box::new(DenseSolver::default())
}

fn block_term(mesh: &Mesh, law: NeoHookean) -> Box<dyn Term> {
    Box::new(
        ContinuumBlock::new(
            &mesh.blocks[0],
            &mesh.nodes,
            law,
            Hex8Formulation::MeanDilatation,
        )
        .unwrap(),
    )
}

fn plate(
    mesh: &Mesh,
    set: &str,
    kind: ContactKind,
    point: [f64; 3],
    normal: [f64; 3],
    program: Vec<[f64; 3]>,
) -> Box<dyn Term> {
    let nodes = mesh.node_sets[set].clone();
    let reference = nodes.iter().map(|&n| mesh.nodes[n]).collect();
    Box::new(
        RigidContact::new(
            set,
            ToolShape::Plate { point, normal },
            kind,
            nodes,
            reference,
            10.0,
            1e-8,
            program,
        )
        .unwrap(),
    )
}

fn scalar(p: &Problem, term: usize, name: &str) -> f64 {
    let outputs = p.terms()[term].scalar_outputs(p.u(), p.dof_map());
    outputs
        .iter()
        .find(|(n, _)| n.ends_with(name))
        .map(|(_, v)| *v)
        .unwrap()
}

/// A 4 um cube (2x2x2 hex8), G = 0.17 kPa, nu = 0.3, bottom face on a fixed bonded plate,
/// top face under a bonded plate moving by `dz` over one step (after a touch step).
fn cube_between_bonded_plates(dz: f64) -> (f64, f64) {
    let law = NeoHookean::from_shear_poisson(0.17, 0.3).unwrap();
    let mesh = box_mesh([0.0; 3], [4.0; 3], [2, 2, 2], "solid").unwrap();
    let terms = vec![
        block_term(&mesh, law),
        plate(
            &mesh,
            "z_min",
            ContactKind::Bonded,
            [0.0; 3],
            [0.0, 0.0, 1.0],
            vec![[0.0; 3]],
        ),
        plate(
            &mesh,
            "z_max",
            ContactKind::Bonded,
            [0.0, 0.0, 4.0],
            [0.0, 0.0, -1.0],
            vec![[0.0; 3], [0.0, 0.0, dz]],
        ),
    ];
    let mut p = Problem::new(DofMap::translational(mesh.num_nodes()), terms, dense()).unwrap();
    // Step 1: the plates touch the faces (zero motion) and bond them at the first increment.
    let mut touch = Step::new("touch");
    touch.control.initial_increment = 1.0;
    touch.control.max_increment = 1.0;
    p.run_step(&touch, &mut NullObserver).unwrap();
    p.run_step(&Step::new("move"), &mut NullObserver).unwrap();
    (
        scalar(&p, 2, "_force_z_nN"),
        scalar(&p, 2, "max_penetration_um"),
    )
}

/// The same cube with its top and bottom faces prescribed (all components).
fn cube_with_prescribed_faces(dz: f64) -> f64 {
    let law = NeoHookean::from_shear_poisson(0.17, 0.3).unwrap();
    let mesh = box_mesh([0.0; 3], [4.0; 3], [2, 2, 2], "solid").unwrap();
    let mut p = Problem::new(
        DofMap::translational(mesh.num_nodes()),
        vec![block_term(&mesh, law)],
        dense(),
    )
    .unwrap();
    let mut step = Step::new("move");
    for &n in &mesh.node_sets["z_min"] {
        step.prescribed
            .extend((0..3).map(|c| (3 * n + c, Motion::Hold)));
    }
    for &n in &mesh.node_sets["z_max"] {
        step.prescribed.extend([
            (3 * n, Motion::Hold),
            (3 * n + 1, Motion::Hold),
            (3 * n + 2, Motion::By(dz)),
        ]);
    }
    p.run_step(&step, &mut NullObserver).unwrap();
    // Force the top face's support applies on the body.
    mesh.node_sets["z_max"]
        .iter()
        .map(|&n| p.reaction(3 * n + 2))
        .sum::<f64>()
}

#[test]
fn bonded_plates_give_the_same_force_as_prescribed_faces_in_compression_and_tension() {
    // GOAL: bonded plates are equivalent to prescribed face displacements. MESH: 4 um cube,
    // 2x2x2 hex8. BCS: bottom plate fixed, top plate moved by -1.2 um (compression) and
    // +1.2 um (tension: the bond must transmit it). REFERENCE: the same cube with the two
    // faces prescribed; forces agree to 1e-6 relative, bond gaps below the 1e-8 um tolerance.
    for dz in [-1.2, 1.2] {
        let (plate_force, gap) = cube_between_bonded_plates(dz);
        let reference = cube_with_prescribed_faces(dz);
        // Pushing down (dz < 0) the plate's force on the body points down; pulling, up.
        assert_eq!(reference.signum(), dz.signum(), "reference {reference}");
        assert!(reference.abs() > 0.1, "a real load: {reference} nN");
        let err = (plate_force - reference).abs() / reference.abs();
        assert!(
            err <= 1e-6,
            "dz {dz}: plate {plate_force} vs prescribed {reference} ({err:e})"
        );
        assert!(gap <= 1e-8, "bond gap {gap}");
    }
}
