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
    let axis = |a: usize| -> Vec<f64> {
        (0..=divisions[a])
            .map(|i| {
                if i == divisions[a] {
                    origin[a] + size[a]
                } else {
                    origin[a] + size[a] * (i as f64 / divisions[a] as f64)
                }
            })
            .collect()
    };
    Ok(tensor_product_mesh(
        [&axis(0), &axis(1), &axis(2)],
        block_name,
    ))
}

/// A tensor-product hex8 mesh whose nodes are all `(xs[i], ys[j], zs[k])`: element sizes
/// vary along each axis as the given coordinates do (a graded box, e.g. fine under an
/// indenter and coarse far from it; see [`AxisGrading`]). One block named `block_name`.
///
/// Each axis needs at least 2 finite, strictly increasing coordinates. Node numbering and
/// node sets are those of [`box_mesh`] (`x_min` … `z_max`, `all`).
pub fn graded_box_mesh(
    xs: &[f64],
    ys: &[f64],
    zs: &[f64],
    block_name: &str,
) -> Result<Mesh, GenerateError> {
    for (name, coordinates) in [("xs", xs), ("ys", ys), ("zs", zs)] {
        require_at_least(&format!("the number of {name}"), coordinates.len(), 2)?;
        for (i, &c) in coordinates.iter().enumerate() {
            if !c.is_finite() {
                return Err(GenerateError::NotFinite {
                    parameter: format!("{name}[{i}]"),
                    found: c,
                });
            }
            if i > 0 && c <= coordinates[i - 1] {
                return Err(GenerateError::NotIncreasing {
                    parameter: format!("{name}[{i}]"),
                    previous: coordinates[i - 1],
                    found: c,
                });
            }
        }
    }
    require_reasonable_size((xs.len() * ys.len()) as f64 * zs.len() as f64)?;
    Ok(tensor_product_mesh([xs, ys, zs], block_name))
}

/// The mesh of [`graded_box_mesh`] from checked coordinates.
fn tensor_product_mesh(axes: [&[f64]; 3], block_name: &str) -> Mesh {
    let divisions = axes.map(|a| a.len() - 1);
    let [nx, ny, nz] = divisions;
    let index = |i: usize, j: usize, k: usize| i + (nx + 1) * (j + (ny + 1) * k);
    let mut mesh = Mesh::default();
    for &z in axes[2] {
        for &y in axes[1] {
            for &x in axes[0] {
                mesh.nodes.push([x, y, z]);
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
    mesh
}

/// Node coordinates along one axis, fine at one end and growing geometrically towards the
/// other: cells of `fine_size` over the first `uniform_length` (at least one cell), then
/// each cell at most `growth` times the previous one. For [`graded_box_mesh`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisGrading {
    /// Size of the cells at the fine end (µm, > 0).
    pub fine_size: f64,
    /// Length from the fine end covered by cells of `fine_size` (µm, ≥ 0; rounded to a
    /// whole number of cells).
    pub uniform_length: f64,
    /// Largest ratio of a cell to its neighbour nearer the fine end (≥ 1; 1 is uniform).
    pub growth: f64,
}

impl AxisGrading {
    /// The coordinates from `fine_end` to `coarse_end` (either may be the larger), in
    /// increasing order, ending exactly at both. The growing part uses the smallest number
    /// of cells whose ratio does not exceed `growth`, with one common ratio (found by
    /// bisection) so that the cells exactly fill it.
    pub fn coordinates(&self, fine_end: f64, coarse_end: f64) -> Result<Vec<f64>, GenerateError> {
        for (parameter, value) in [("fine_end", fine_end), ("coarse_end", coarse_end)] {
            if !value.is_finite() {
                return Err(GenerateError::NotFinite {
                    parameter: parameter.into(),
                    found: value,
                });
            }
        }
        let length = (coarse_end - fine_end).abs();
        require_positive("the length |coarse_end - fine_end|", length)?;
        let h = self.fine_size;
        require_positive("fine_size", h)?;
        if !(self.uniform_length.is_finite() && self.uniform_length >= 0.0) {
            return Err(GenerateError::Negative {
                parameter: "uniform_length".into(),
                found: self.uniform_length,
            });
        }
        if !(self.growth.is_finite() && self.growth >= 1.0) {
            return Err(GenerateError::GrowthOutOfRange { found: self.growth });
        }
        let uniform = |l: f64| -> Result<Vec<f64>, GenerateError> {
            // The fewest equal cells of at most `h` (up to round-off).
            let n = ((l / h) * (1.0 - 1e-12)).ceil().max(1.0);
            require_reasonable_size(n + 1.0)?;
            Ok(vec![l / n; n as usize])
        };
        let n_uniform = (self.uniform_length.min(length) / h + 1e-9)
            .floor()
            .max(1.0);
        require_reasonable_size(n_uniform + 1.0)?;
        let rest = length - n_uniform * h;
        let sizes = if self.growth == 1.0 || rest <= 1e-12 * length {
            uniform(length)?
        } else {
            // Fewest growing cells h r, h r², …, h r^m (r ≤ growth) that reach `rest`.
            let total = |r: f64, m: usize| (1..=m).map(|k| h * r.powi(k as i32)).sum::<f64>();
            let (mut m, mut reached, mut cell) = (0, 0.0, h);
            while reached < rest {
                m += 1;
                cell *= self.growth;
                reached += cell;
                require_reasonable_size(n_uniform + m as f64 + 1.0)?;
            }
            if m as f64 * h >= rest {
                // Too short to grow: equal cells of at most `h` over the whole length.
                uniform(length)?
            } else {
                let (mut lo, mut hi) = (1.0, self.growth);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if total(mid, m) < rest {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let r = 0.5 * (lo + hi);
                let mut sizes = vec![h; n_uniform as usize];
                sizes.extend((1..=m).map(|k| h * r.powi(k as i32)));
                sizes
            }
        };
        let direction = if coarse_end > fine_end { 1.0 } else { -1.0 };
        let mut coordinates = Vec::with_capacity(sizes.len() + 1);
        let mut at = 0.0;
        coordinates.push(fine_end);
        for (k, size) in sizes.iter().enumerate() {
            at += size;
            coordinates.push(if k + 1 == sizes.len() {
                coarse_end
            } else {
                fine_end + direction * at
            });
        }
        if direction < 0.0 {
            coordinates.reverse();
        }
        Ok(coordinates)
    }
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
    fn graded_box_places_nodes_on_the_given_coordinates() {
        let (xs, ys, zs) = ([0.0, 0.1, 0.3, 1.0], [-1.0, 0.0, 2.0], [0.0, 0.5]);
        let mesh = graded_box_mesh(&xs, &ys, &zs, "b").unwrap();
        mesh.validate().unwrap();
        assert_eq!(mesh.num_nodes(), 4 * 3 * 2);
        assert_eq!(mesh.num_elements(), 3 * 2);
        // Node (i, j, k) sits at (xs[i], ys[j], zs[k]) with box_mesh's numbering.
        assert_eq!(mesh.nodes[2 + 4 * (1 + 3)], [0.3, 0.0, 0.5]);
        assert!(mesh.node_sets["x_max"]
            .iter()
            .all(|&n| mesh.nodes[n][0] == 1.0));
        assert_eq!(mesh.node_sets["z_min"].len(), 12);
        let q = hex8_quality(&mesh);
        assert!((q.volume - 1.0 * 3.0 * 0.5).abs() < 1e-12);
        assert!(q.min_gauss_jacobian > 0.0);
        // Uniform coordinates give exactly the box_mesh.
        let uniform = box_mesh([0.0; 3], [1.0, 2.0, 3.0], [2, 2, 3], "b").unwrap();
        let graded = graded_box_mesh(
            &[0.0, 0.5, 1.0],
            &[0.0, 1.0, 2.0],
            &[0.0, 1.0, 2.0, 3.0],
            "b",
        )
        .unwrap();
        assert_eq!(graded, uniform);
    }

    #[test]
    fn graded_box_rejects_bad_coordinates() {
        let err = graded_box_mesh(&[0.0, 1.0], &[0.0, 1.0, 1.0], &[0.0, 1.0], "b").unwrap_err();
        assert_eq!(
            err,
            GenerateError::NotIncreasing {
                parameter: "ys[2]".into(),
                previous: 1.0,
                found: 1.0
            }
        );
        let err = graded_box_mesh(&[0.0, 1.0], &[0.0, 1.0], &[0.0], "b").unwrap_err();
        assert!(
            err.to_string()
                .contains("the number of zs to be at least 2; found 1"),
            "{err}"
        );
        let err = graded_box_mesh(&[0.0, f64::INFINITY], &[0.0, 1.0], &[0.0, 1.0], "b");
        assert!(matches!(err, Err(GenerateError::NotFinite { .. })));
    }

    #[test]
    fn axis_grading_is_fine_at_one_end_and_grows_at_most_by_the_ratio() {
        let grading = AxisGrading {
            fine_size: 0.01,
            uniform_length: 0.07,
            growth: 1.5,
        };
        let x = grading.coordinates(0.0, 8.0).unwrap();
        let cells: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        assert_eq!((x[0], *x.last().unwrap()), (0.0, 8.0));
        assert!(cells[..7].iter().all(|&c| (c - 0.01).abs() < 1e-15));
        let ratios: Vec<f64> = cells.windows(2).map(|w| w[1] / w[0]).collect();
        assert!(ratios
            .iter()
            .all(|&r| (1.0 - 1e-9..=1.5 + 1e-9).contains(&r)));
        // One common ratio in the growing part, and the fewest cells: at ratio 1.5 one cell
        // fewer would not reach the end.
        let growing = &ratios[7..];
        assert!(growing.iter().all(|&r| (r - growing[0]).abs() < 1e-9));
        let m = cells.len() - 7;
        let short: f64 = (1..m).map(|k| 0.01 * 1.5f64.powi(k as i32)).sum();
        assert!(0.07 + short < 8.0, "{m} growing cells");
        // Fine end at the top: coordinates still increase, the small cells at the top.
        let z = grading.coordinates(0.0, -8.0).unwrap();
        assert_eq!((z[0], *z.last().unwrap()), (-8.0, 0.0));
        assert!((z[z.len() - 1] - z[z.len() - 2] - 0.01).abs() < 1e-15);
        let mirrored: Vec<f64> = x.iter().rev().map(|v| -v).collect();
        for (a, b) in z.iter().zip(&mirrored) {
            assert!((a - b).abs() < 1e-12);
        }
        // Growth 1, or a length shorter than the growth would need: equal cells ≤ fine size.
        let uniform = AxisGrading {
            growth: 1.0,
            ..grading
        };
        assert_eq!(uniform.coordinates(1.0, 1.1).unwrap().len(), 11);
        let short = grading.coordinates(0.0, 0.075).unwrap();
        assert_eq!(short.len(), 9);
        assert!((short[1] - 0.075 / 8.0).abs() < 1e-15);
    }

    #[test]
    fn axis_grading_rejects_bad_parameters() {
        let good = AxisGrading {
            fine_size: 0.1,
            uniform_length: 0.0,
            growth: 1.2,
        };
        let bad = |g: AxisGrading| g.coordinates(0.0, 1.0).unwrap_err();
        assert_eq!(
            bad(AxisGrading {
                growth: 0.9,
                ..good
            }),
            GenerateError::GrowthOutOfRange { found: 0.9 }
        );
        assert!(matches!(
            bad(AxisGrading {
                fine_size: 0.0,
                ..good
            }),
            GenerateError::NotPositive { .. }
        ));
        let err = bad(AxisGrading {
            uniform_length: -1.0,
            ..good
        });
        assert!(
            err.to_string()
                .contains("uniform_length to be a finite number ≥ 0; found -1"),
            "{err}"
        );
        assert!(good.coordinates(1.0, 1.0).is_err());
        assert!(good.coordinates(f64::NAN, 1.0).is_err());
        let tiny = AxisGrading {
            fine_size: 1e-12,
            uniform_length: 1.0,
            growth: 1.0,
        };
        assert!(matches!(
            tiny.coordinates(0.0, 1.0),
            Err(GenerateError::TooLarge { .. })
        ));
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
