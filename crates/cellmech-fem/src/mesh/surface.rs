//! Surfaces of hexahedral meshes: the boundary faces of hex8 blocks, oriented outward, and
//! quad4 element blocks built on them. The faces reuse the solid's nodes, so a membrane or a
//! pressure load on them is tied to the continuum without extra constraints.
//!
//! Faces of a hex8 in Abaqus order (nodes 0-3 bottom, counter-clockwise seen from +ζ, 4-7
//! top), each listed so that the right-hand normal points out of the element:
//! `ζ=−1: (0,3,2,1)`, `ζ=+1: (4,5,6,7)`, `η=−1: (0,1,5,4)`, `ξ=+1: (1,2,6,5)`,
//! `η=+1: (2,3,7,6)`, `ξ=−1: (3,0,4,7)`. Elements with a negative Jacobian (mirrored node
//! order) get their faces reversed, so the normals still point out of the solid.

use std::collections::HashMap;

use super::{ElementBlock, ElementKind, Mesh};

/// Natural coordinates of the eight hex8 corners (Abaqus/Gmsh node order).
pub const HEX8_CORNERS: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// Local node lists of the six faces of a hex8, outward for a positively oriented element.
pub const HEX8_FACES: [[usize; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 0, 4, 7],
];

/// Problems when extracting a surface.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SurfaceError {
    /// A requested block does not exist.
    #[error("surface: expected an element block named '{name}', found none (blocks: {available})")]
    UnknownBlock { name: String, available: String },
    /// A requested block is not made of hex8 elements.
    #[error("surface: block '{name}' must hold hex8 elements, found {kind}")]
    NotHex8 { name: String, kind: &'static str },
    /// A requested node set does not exist.
    #[error("surface: expected a node set named '{name}', found none")]
    UnknownNodeSet { name: String },
    /// A connectivity entry refers to a missing node.
    #[error("surface: element {element} of block '{block}' refers to node {node}, but the mesh has {num_nodes} nodes")]
    MissingNode {
        block: String,
        element: usize,
        node: usize,
        num_nodes: usize,
    },
}

/// Sign of the trilinear Jacobian at the element centre (mixed product of the mean edge
/// vectors along ξ, η, ζ).
pub(crate) fn orientation(nodes: &[[f64; 3]], hex: &[usize]) -> f64 {
    let x = |a: usize| nodes[hex[a]];
    let mean_diff = |pairs: [(usize, usize); 4]| -> [f64; 3] {
        std::array::from_fn(|i| pairs.iter().map(|&(p, m)| x(p)[i] - x(m)[i]).sum::<f64>())
    };
    let dxi = mean_diff([(1, 0), (2, 3), (5, 4), (6, 7)]);
    let deta = mean_diff([(3, 0), (2, 1), (7, 4), (6, 5)]);
    let dzeta = mean_diff([(4, 0), (5, 1), (6, 2), (7, 3)]);
    let c = [
        deta[1] * dzeta[2] - deta[2] * dzeta[1],
        deta[2] * dzeta[0] - deta[0] * dzeta[2],
        deta[0] * dzeta[1] - deta[1] * dzeta[0],
    ];
    dxi[0] * c[0] + dxi[1] * c[1] + dxi[2] * c[2]
}

/// Area of the quadrilateral `face` of `nodes` (µm²): half the norm of its diagonals'
/// cross product, exact when the quad is flat.
pub fn quad_area(nodes: &[[f64; 3]], face: &[usize; 4]) -> f64 {
    let x = |a: usize| nodes[face[a]];
    let d1: [f64; 3] = std::array::from_fn(|i| x(2)[i] - x(0)[i]);
    let d2: [f64; 3] = std::array::from_fn(|i| x(3)[i] - x(1)[i]);
    let n = [
        d1[1] * d2[2] - d1[2] * d2[1],
        d1[2] * d2[0] - d1[0] * d2[2],
        d1[0] * d2[1] - d1[1] * d2[0],
    ];
    0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
}

/// The faces of the hex8 elements of the selected blocks (all hex8 blocks when
/// `block_filter` is `None`) that belong to exactly one of those elements, ordered so that
/// the right-hand normal points out of the solid, in element order. Faces shared by two
/// selected elements are interior; with a filter, faces shared with unselected blocks (e.g.
/// a nucleus–cytoplasm interface) count as boundary of the selection.
pub fn boundary_quads(
    mesh: &Mesh,
    block_filter: Option<&[&str]>,
) -> Result<Vec<[usize; 4]>, SurfaceError> {
    let blocks: Vec<&ElementBlock> = match block_filter {
        None => mesh
            .blocks
            .iter()
            .filter(|b| b.kind == ElementKind::Hex8)
            .collect(),
        Some(names) => names
            .iter()
            .map(|&name| {
                let block = mesh.block(name).ok_or_else(|| SurfaceError::UnknownBlock {
                    name: name.to_string(),
                    available: mesh
                        .blocks
                        .iter()
                        .map(|b| b.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                })?;
                if block.kind != ElementKind::Hex8 {
                    return Err(SurfaceError::NotHex8 {
                        name: name.to_string(),
                        kind: block.kind.name(),
                    });
                }
                Ok(block)
            })
            .collect::<Result<_, _>>()?,
    };
    let mut faces: Vec<[usize; 4]> = Vec::new();
    let mut count: HashMap<[usize; 4], usize> = HashMap::new();
    for block in blocks {
        for (e, hex) in block.elements().enumerate() {
            if let Some(&node) = hex.iter().find(|&&n| n >= mesh.nodes.len()) {
                return Err(SurfaceError::MissingNode {
                    block: block.name.clone(),
                    element: e,
                    node,
                    num_nodes: mesh.nodes.len(),
                });
            }
            let flip = orientation(&mesh.nodes, hex) < 0.0;
            for local in HEX8_FACES {
                let mut face = local.map(|a| hex[a]);
                if flip {
                    face.swap(1, 3);
                }
                let mut key = face;
                key.sort_unstable();
                *count.entry(key).or_insert(0) += 1;
                faces.push(face);
            }
        }
    }
    Ok(faces
        .into_iter()
        .filter(|f| {
            let mut key = *f;
            key.sort_unstable();
            count[&key] == 1
        })
        .collect())
}

/// The boundary faces of all hex8 blocks whose four nodes all belong to node set
/// `node_set` (e.g. the free surface of an adherent cell, excluding the substrate contact).
pub fn faces_on_node_set(mesh: &Mesh, node_set: &str) -> Result<Vec<[usize; 4]>, SurfaceError> {
    let set = mesh
        .node_sets
        .get(node_set)
        .ok_or_else(|| SurfaceError::UnknownNodeSet {
            name: node_set.to_string(),
        })?;
    Ok(boundary_quads(mesh, None)?
        .into_iter()
        .filter(|f| f.iter().all(|n| set.binary_search(n).is_ok()))
        .collect())
}

/// A quad4 element block named `name` made of `faces` (e.g. for a membrane set).
pub fn quad_block(name: impl Into<String>, faces: &[[usize; 4]]) -> ElementBlock {
    ElementBlock {
        name: name.into(),
        kind: ElementKind::Quad4,
        connectivity: faces.iter().flatten().copied().collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_by_one_by_one() -> Mesh {
        // Two unit cubes side by side along x; nodes on a 3×2×2 grid.
        let mut nodes = Vec::new();
        for k in 0..2 {
            for j in 0..2 {
                for i in 0..3 {
                    nodes.push([i as f64, j as f64, k as f64]);
                }
            }
        }
        let id = |i: usize, j: usize, k: usize| i + 3 * j + 6 * k;
        let hex = |i: usize| {
            vec![
                id(i, 0, 0),
                id(i + 1, 0, 0),
                id(i + 1, 1, 0),
                id(i, 1, 0),
                id(i, 0, 1),
                id(i + 1, 0, 1),
                id(i + 1, 1, 1),
                id(i, 1, 1),
            ]
        };
        Mesh {
            nodes,
            blocks: vec![
                ElementBlock {
                    name: "left".into(),
                    kind: ElementKind::Hex8,
                    connectivity: hex(0),
                },
                ElementBlock {
                    name: "right".into(),
                    kind: ElementKind::Hex8,
                    // mirrored node order: must still give outward faces
                    connectivity: {
                        let h = hex(1);
                        vec![h[4], h[5], h[6], h[7], h[0], h[1], h[2], h[3]]
                    },
                },
            ],
            node_sets: Default::default(),
        }
    }

    fn outward_area_vector(mesh: &Mesh, f: &[usize; 4]) -> ([f64; 3], [f64; 3]) {
        let x = |a: usize| mesh.nodes[f[a]];
        let d1: [f64; 3] = std::array::from_fn(|i| x(2)[i] - x(0)[i]);
        let d2: [f64; 3] = std::array::from_fn(|i| x(3)[i] - x(1)[i]);
        let n = [
            0.5 * (d1[1] * d2[2] - d1[2] * d2[1]),
            0.5 * (d1[2] * d2[0] - d1[0] * d2[2]),
            0.5 * (d1[0] * d2[1] - d1[1] * d2[0]),
        ];
        let c = std::array::from_fn(|i| (0..4).map(|a| x(a)[i]).sum::<f64>() / 4.0);
        (n, c)
    }

    #[test]
    fn surface_boundary_quads_of_two_cubes_point_outward() {
        let mesh = two_by_one_by_one();
        let faces = boundary_quads(&mesh, None).unwrap();
        assert_eq!(
            faces.len(),
            10,
            "12 faces minus the shared one counted twice"
        );
        let centre = [1.0, 0.5, 0.5];
        let mut total = [0.0; 3];
        for f in &faces {
            let (n, c) = outward_area_vector(&mesh, f);
            let out: f64 = (0..3).map(|i| n[i] * (c[i] - centre[i])).sum();
            assert!(out > 0.0, "face {f:?} points inward");
            assert!(((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() - 1.0).abs() < 1e-14);
            (0..3).for_each(|i| total[i] += n[i]);
        }
        assert!(
            total.iter().all(|t| t.abs() < 1e-14),
            "closed surface: Σ n dA = 0"
        );
        // Selecting one block keeps the interface as its boundary.
        let left = boundary_quads(&mesh, Some(&["left"])).unwrap();
        assert_eq!(left.len(), 6);
        // The outward faces enclose the solid: V = 1/3 ∮ x·n dA = 2 (and 1 for one cube).
        for (faces, volume) in [(&faces, 2.0), (&left, 1.0)] {
            let block = quad_block("skin", faces);
            let surface = crate::element::pressure::SurfaceVolume::new(
                "skin",
                block.kind,
                block.connectivity,
                &mesh.nodes,
            )
            .unwrap();
            assert!((surface.reference_volume() - volume).abs() < 1e-14);
        }
        assert!(matches!(
            boundary_quads(&mesh, Some(&["nucleus"])),
            Err(SurfaceError::UnknownBlock { .. })
        ));
    }

    #[test]
    fn surface_faces_on_node_set_and_block_builder() {
        let mut mesh = two_by_one_by_one();
        let top = mesh.select_nodes(|x| x[2] > 0.5);
        mesh.insert_node_set("top", top);
        let faces = faces_on_node_set(&mesh, "top").unwrap();
        assert_eq!(faces.len(), 2);
        for f in &faces {
            assert!(outward_area_vector(&mesh, f).0[2] > 0.99);
        }
        let block = quad_block("cortex", &faces);
        assert_eq!((block.kind, block.len()), (ElementKind::Quad4, 2));
        assert!(faces_on_node_set(&mesh, "bottom").is_err());
    }
}
