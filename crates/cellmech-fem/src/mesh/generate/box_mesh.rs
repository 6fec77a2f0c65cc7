//! Structured hex8 boxes, and seeded distortion of interior nodes for patch tests.

use std::collections::BTreeSet;

use super::quality::{hex8_coordinates, hex8_min_gauss_jacobian, HEX8_CORNERS, HEX8_EDGES};
use super::{
    boundary_faces, require_at_least, require_positive, require_reasonable_size, GenerateError,
    SplitMix64,
};
use crate::mesh::generate::quality::{det3, hex8_jacobian};
use crate::mesh::{ElementBlock, ElementKind, Mesh};

/// A structured mesh of `divisions[0] × divisions[1] × divisions[2]` hex8 elements filling
/// the box `[origin, origin + size]`, in one block named `block_name`.
///
/// Node `(i, j, k)` has index `i + (nx + 1) * (j + (ny + 1) * k)`. Node sets: `x_min`,
/// `x_max`, `y_min`, `y_max`, `z_min`, `z_max` (the six faces) and `all`.
pub fn box_mesh(
    origin: [f64; 3],
    size: [f64; 3],
    divisions: [usize; 3],
    block_name: &str,
) -> Result<Mesh, GenerateError> {
    for k in 0..3 {
        if !origin[k].is_finite() {
            return Err(GenerateError::NotFinite {
                parameter: format!("origin[{k}]"),
                found: origin[k],
            });
        }
        require_positive(&format!("size[{k}]"), size[k])?;
        require_at_least(&format!("divisions[{k}]"), divisions[k], 1)?;
    }
    require_reasonable_size(divisions.iter().map(|&d| d as f64 + 1.0).product())?;
    let [nx, ny, nz] = divisions;
    let index = |i: usize, j: usize, k: usize| i + (nx + 1) * (j + (ny + 1) * k);
    let coordinate = |axis: usize, i: usize| {
        if i == divisions[axis] {
            origin[axis] + size[axis]
        } else {
            origin[axis] + size[axis] * (i as f64 / divisions[axis] as f64)
        }
    };
    let mut mesh = Mesh::default();
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                mesh.nodes
                    .push([coordinate(0, i), coordinate(1, j), coordinate(2, k)]);
            }
        }
    }
    let mut connectivity = Vec::with_capacity(8 * nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                for corner in HEX8_CORNERS {
                    let step = |c: f64| usize::from(c > 0.0);
                    connectivity.push(index(
                        i + step(corner[0]),
                        j + step(corner[1]),
                        k + step(corner[2]),
                    ));
                }
            }
        }
    }
    mesh.blocks.push(ElementBlock {
        name: block_name.to_string(),
        kind: ElementKind::Hex8,
        connectivity,
    });
    let grid: Vec<[usize; 3]> = (0..=nz)
        .flat_map(|k| (0..=ny).flat_map(move |j| (0..=nx).map(move |i| [i, j, k])))
        .collect();
    let face_set = |axis: usize, at: usize| -> Vec<usize> {
        (0..grid.len()).filter(|&n| grid[n][axis] == at).collect()
    };
    for (axis, letter) in ["x", "y", "z"].iter().enumerate() {
        mesh.insert_node_set(format!("{letter}_min"), face_set(axis, 0));
        mesh.insert_node_set(format!("{letter}_max"), face_set(axis, divisions[axis]));
    }
    mesh.insert_node_set("all", (0..mesh.nodes.len()).collect());
    Ok(mesh)
}

/// Moves every node that is not on the boundary of a hex8 mesh by a seeded pseudo-random
/// vector whose components are uniform in `±amplitude_fraction × h`, where `h` is the
/// shortest element edge at that node. Elements that would get a non-positive Jacobian at a
/// Gauss point or corner have their nodes put back, so all Jacobians stay positive.
///
/// Returns the number of nodes that were moved. The boundary (and therefore the total
/// volume) is unchanged. `amplitude_fraction` must lie in `[0, 0.5)`.
pub fn perturb_interior_nodes(
    mesh: &mut Mesh,
    amplitude_fraction: f64,
    seed: u64,
) -> Result<usize, GenerateError> {
    if !(0.0..0.5).contains(&amplitude_fraction) {
        return Err(GenerateError::AmplitudeOutOfRange {
            found: amplitude_fraction,
        });
    }
    if let Some(b) = mesh.blocks.iter().find(|b| b.kind != ElementKind::Hex8) {
        return Err(GenerateError::UnsupportedElementKind {
            block: b.name.clone(),
            kind: b.kind.name(),
        });
    }
    let spacing = shortest_edge_at_nodes(mesh);
    let boundary: BTreeSet<usize> = boundary_faces(mesh).into_iter().flatten().collect();
    let original = mesh.nodes.clone();
    let mut rng = SplitMix64::new(seed);
    for (n, p) in mesh.nodes.iter_mut().enumerate() {
        let h = spacing[n];
        if boundary.contains(&n) || !h.is_finite() {
            continue;
        }
        for c in p.iter_mut() {
            *c += amplitude_fraction * h * rng.uniform(-1.0, 1.0);
        }
    }
    restore_inverted_elements(mesh, &original);
    Ok(mesh
        .nodes
        .iter()
        .zip(&original)
        .filter(|(a, b)| a != b)
        .count())
}

/// Shortest hex8 edge touching each node (infinity for nodes in no element).
fn shortest_edge_at_nodes(mesh: &Mesh) -> Vec<f64> {
    let mut h = vec![f64::INFINITY; mesh.nodes.len()];
    for element in mesh.blocks.iter().flat_map(|b| b.elements()) {
        for [a, b] in HEX8_EDGES {
            let (na, nb) = (element[a], element[b]);
            let (pa, pb) = (mesh.nodes[na], mesh.nodes[nb]);
            let len = ((pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2) + (pa[2] - pb[2]).powi(2))
                .sqrt();
            h[na] = h[na].min(len);
            h[nb] = h[nb].min(len);
        }
    }
    h
}

/// True when the element's Jacobian is positive at every Gauss point and corner.
fn element_is_valid(x: &[[f64; 3]; 8]) -> bool {
    hex8_min_gauss_jacobian(x) > 0.0
        && HEX8_CORNERS
            .iter()
            .all(|&c| det3(&hex8_jacobian(x, c)) > 0.0)
}

/// Puts back the nodes of invalid elements until no element that can be repaired is invalid.
fn restore_inverted_elements(mesh: &mut Mesh, original: &[[f64; 3]]) {
    loop {
        let mut restored = false;
        let elements: Vec<Vec<usize>> = mesh
            .blocks
            .iter()
            .flat_map(|b| b.elements().map(<[usize]>::to_vec))
            .collect();
        for element in elements {
            if element_is_valid(&hex8_coordinates(mesh, &element)) {
                continue;
            }
            for &n in &element {
                if mesh.nodes[n] != original[n] {
                    mesh.nodes[n] = original[n];
                    restored = true;
                }
            }
        }
        if !restored {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::quality::{hex8_quality, hex8_volume};
    use super::*;

    #[test]
    fn box_counts_sets_and_quality() {
        let mesh = box_mesh([1.0, -2.0, 0.5], [2.0, 3.0, 1.5], [4, 3, 5], "cube").unwrap();
        mesh.validate().unwrap();
        assert_eq!(mesh.num_nodes(), 5 * 4 * 6);
        assert_eq!(mesh.num_elements(), 60);
        assert_eq!(mesh.block("cube").unwrap().len(), 60);
        let q = hex8_quality(&mesh);
        // Elements 0.5 × 1 × 0.3: Jacobian det = volume / 8 = 0.01875, perfect angles.
        assert!((q.min_gauss_jacobian - 0.15 / 8.0).abs() < 1e-14);
        assert!((q.min_scaled_jacobian - 1.0).abs() < 1e-12);
        assert!((q.max_edge_ratio - 1.0 / 0.3).abs() < 1e-12);
        assert!((q.volume - 9.0).abs() < 1e-12);
        let expect = [("x_min", 0, 1.0), ("x_max", 0, 3.0), ("y_min", 1, -2.0)];
        for (name, axis, value) in expect {
            let set = &mesh.node_sets[name];
            assert!(set.iter().all(|&n| mesh.nodes[n][axis] == value), "{name}");
            assert_eq!(mesh.select_nodes(|p| p[axis] == value), *set, "{name}");
        }
        assert_eq!(mesh.node_sets["y_max"].len(), 5 * 6);
        assert_eq!(mesh.node_sets["z_min"].len(), 5 * 4);
        assert!(mesh.node_sets["z_max"]
            .iter()
            .all(|&n| mesh.nodes[n][2] == 2.0));
        assert_eq!(mesh.node_sets["all"].len(), mesh.num_nodes());
        assert_eq!(boundary_faces(&mesh).len(), 2 * (4 * 3 + 3 * 5 + 4 * 5));
    }

    #[test]
    fn box_rejects_bad_parameters() {
        let err = box_mesh([0.0; 3], [1.0, -1.0, 1.0], [1, 1, 1], "b").unwrap_err();
        assert_eq!(
            err,
            GenerateError::NotPositive {
                parameter: "size[1]".into(),
                found: -1.0
            }
        );
        let err = box_mesh([0.0; 3], [1.0; 3], [1, 1, 0], "b").unwrap_err();
        assert!(
            err.to_string()
                .contains("divisions[2] to be at least 1; found 0"),
            "{err}"
        );
        let err = box_mesh([f64::NAN, 0.0, 0.0], [1.0; 3], [1, 1, 1], "b").unwrap_err();
        assert!(matches!(err, GenerateError::NotFinite { .. }));
        let err = box_mesh([0.0; 3], [1.0; 3], [100_000, 100_000, 1], "b").unwrap_err();
        assert!(matches!(err, GenerateError::TooLarge { .. }));
    }

    #[test]
    fn perturbation_moves_only_interior_nodes_and_keeps_jacobians_positive() {
        let reference = box_mesh([0.0; 3], [1.0, 2.0, 1.0], [4, 4, 4], "b").unwrap();
        let mut mesh = reference.clone();
        let moved = perturb_interior_nodes(&mut mesh, 0.3, 7).unwrap();
        let boundary: BTreeSet<usize> = boundary_faces(&reference).into_iter().flatten().collect();
        assert_eq!(boundary.len(), 5 * 5 * 5 - 3 * 3 * 3);
        assert_eq!(moved, 27, "every interior node moves at amplitude 0.3");
        for (n, (p, q)) in mesh.nodes.iter().zip(&reference.nodes).enumerate() {
            let d: Vec<f64> = (0..3).map(|k| (p[k] - q[k]).abs()).collect();
            if boundary.contains(&n) {
                assert_eq!(p, q, "boundary node {n} moved");
            } else {
                assert!(
                    d.iter().all(|&x| x <= 0.3 * 0.25 + 1e-15),
                    "node {n} moved {d:?}"
                );
                assert!(d.iter().any(|&x| x > 0.0));
            }
        }
        let q = hex8_quality(&mesh);
        assert!(q.min_gauss_jacobian > 0.0);
        assert!(q.min_scaled_jacobian < 0.95, "mesh is visibly distorted");
        // The boundary is unchanged, so the total volume is exactly preserved.
        assert!((q.volume - 2.0).abs() < 1e-12, "volume {}", q.volume);
        // Deterministic in the seed.
        let mut again = reference.clone();
        perturb_interior_nodes(&mut again, 0.3, 7).unwrap();
        assert_eq!(again, mesh);
        let mut other = reference.clone();
        perturb_interior_nodes(&mut other, 0.3, 8).unwrap();
        assert_ne!(other, mesh);
    }

    #[test]
    fn perturbation_restores_elements_it_would_invert() {
        // A strongly graded mesh: tiny amplitude relative to thick layers can still invert a
        // thin neighbouring layer; all elements must stay valid whatever happens.
        let mut mesh = box_mesh([0.0; 3], [1.0; 3], [3, 3, 3], "b").unwrap();
        for p in &mut mesh.nodes {
            p[2] = p[2].powi(4);
        }
        perturb_interior_nodes(&mut mesh, 0.49, 3).unwrap();
        for e in mesh.blocks[0].elements() {
            let x = hex8_coordinates(&mesh, e);
            assert!(element_is_valid(&x));
            assert!(hex8_volume(&x) > 0.0);
        }
        let err = perturb_interior_nodes(&mut mesh, 0.5, 3).unwrap_err();
        assert_eq!(err, GenerateError::AmplitudeOutOfRange { found: 0.5 });
    }
}
