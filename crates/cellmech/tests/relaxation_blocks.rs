//! Which DOFs the model layer hands to the solver's nonlinear elimination: per beam chain,
//! the DOFs only that chain's beams touch (docs/performance.md, "Nonlinear elimination of
//! the free filaments").

use cellmech::model::filaments::Filament;
use cellmech::model::structures::{
    dofs_per_node, relaxation_blocks, FilamentElement, FilamentSpec, StructuresSpec,
};
use cellmech_fem::dof::DofMap;
use cellmech_fem::element::beam::BeamSection;
use cellmech_fem::material::AxialLaw;
use cellmech_fem::mesh::{ElementBlock, ElementKind, Mesh};

#[test]
fn each_chain_gets_its_own_interior_nodes_and_end_rotations_and_no_shared_hub() {
    // Nodes 0-7: a hex8 (the "cell"; node 0 is an FA on it, node 1 another). Two MTs run
    // from the FAs through interior nodes 8 and 9 to the hub 10 (the centrosome); an actin
    // truss 1-11 and a lone beam 11-12 hang off node 1 and node 11.
    let mut nodes: Vec<[f64; 3]> = (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect();
    nodes.extend([
        [2.0, 0.0, 0.0],
        [2.0, 1.0, 0.0],
        [3.0, 0.5, 0.0],
        [0.0, 3.0, 0.0],
        [0.0, 4.0, 0.0],
    ]);
    let mesh = Mesh {
        nodes,
        blocks: vec![ElementBlock {
            name: "cell".into(),
            kind: ElementKind::Hex8,
            connectivity: vec![0, 1, 3, 2, 4, 5, 7, 6],
        }],
        ..Mesh::default()
    };
    let section = BeamSection::hollow_circular(1.2e6, 0.3, 0.025, 0.017).unwrap();
    let mts = vec![[0, 8], [8, 10], [1, 9], [9, 10]];
    let lone = vec![[11, 12]];
    let actin = vec![[1, 11]];
    let spec = StructuresSpec {
        filaments: vec![
            FilamentSpec {
                name: "mt".into(),
                family: "microtubule".into(),
                filaments: Filament::chains(&mts),
                pairs: mts,
                element: FilamentElement::Beam(section),
                enabled: true,
            },
            FilamentSpec {
                name: "af".into(),
                family: "actin".into(),
                filaments: Filament::chains(&actin),
                pairs: actin,
                element: FilamentElement::Truss(AxialLaw::tension_only(100.0, 0.0)),
                enabled: true,
            },
            FilamentSpec {
                name: "lone".into(),
                family: "lone".into(),
                filaments: Filament::chains(&lone),
                pairs: lone,
                element: FilamentElement::Beam(section),
                enabled: true,
            },
        ],
        membranes: Vec::new(),
    };
    let dof_map = DofMap::with_counts(&dofs_per_node(mesh.num_nodes(), &spec));
    let mut blocks = relaxation_blocks(&mesh, &spec, &dof_map);
    blocks.sort();
    let range = |n: usize, from: usize| (from..6).map(|k| dof_map.dof(n, k)).collect::<Vec<_>>();
    let all = |n: usize| range(n, 0);
    let rotations = |n: usize| range(n, 3);
    // MT 0-8-10: FA 0's rotations and all of node 8; MT 1-9-10: FA 1's rotations and
    // node 9; the hub 10 in neither; the lone beam: its free end 12 whole, and only the
    // rotations of node 11, which the actin truss also uses.
    let mut expected: Vec<Vec<usize>> = vec![
        [rotations(0), all(8)].concat(),
        [rotations(1), all(9)].concat(),
        [rotations(11), all(12)].concat(),
    ];
    expected.sort();
    assert_eq!(blocks, expected);
    // A switched-off family has no block.
    let mut off = spec.clone();
    off.filaments[0].enabled = false;
    let dof_map = DofMap::with_counts(&dofs_per_node(mesh.num_nodes(), &off));
    assert_eq!(relaxation_blocks(&mesh, &off, &dof_map).len(), 1);
}
