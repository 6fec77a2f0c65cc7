//! Geometric quality of hex8 elements: Jacobian determinants at the 2×2×2 Gauss points,
//! scaled Jacobian (Verdict definition: corners and centre), edge ratio, volume, and the
//! boundary faces of a hex8 mesh.

use std::collections::HashMap;

use crate::mesh::{ElementKind, Mesh};

pub use crate::mesh::surface::{HEX8_CORNERS, HEX8_FACES};

/// The twelve edges of a hex8 as local node pairs.
pub const HEX8_EDGES: [[usize; 2]; 12] = [
    [0, 1],
    [1, 2],
    [2, 3],
    [3, 0],
    [4, 5],
    [5, 6],
    [6, 7],
    [7, 4],
    [0, 4],
    [1, 5],
    [2, 6],
    [3, 7],
];

/// For each corner, its three neighbours along the ξ, η, ζ edges in right-handed order.
const CORNER_NEIGHBOURS: [[usize; 3]; 8] = [
    [1, 3, 4],
    [2, 0, 5],
    [3, 1, 6],
    [0, 2, 7],
    [7, 5, 0],
    [4, 6, 1],
    [5, 7, 2],
    [6, 4, 3],
];

/// Gauss abscissa of the 2-point rule.
const GAUSS_2: f64 = 0.577_350_269_189_625_8;

/// Node coordinates of one hex8 element.
pub fn hex8_coordinates(mesh: &Mesh, element: &[usize]) -> [[f64; 3]; 8] {
    std::array::from_fn(|a| mesh.nodes[element[a]])
}

/// Jacobian matrix `J[i][j] = ∂x_i/∂ξ_j` of the trilinear map at natural point `xi`.
pub fn hex8_jacobian(x: &[[f64; 3]; 8], xi: [f64; 3]) -> [[f64; 3]; 3] {
    let mut jac = [[0.0; 3]; 3];
    for (a, corner) in HEX8_CORNERS.iter().enumerate() {
        let f = [
            1.0 + corner[0] * xi[0],
            1.0 + corner[1] * xi[1],
            1.0 + corner[2] * xi[2],
        ];
        let grad = [
            0.125 * corner[0] * f[1] * f[2],
            0.125 * corner[1] * f[0] * f[2],
            0.125 * corner[2] * f[0] * f[1],
        ];
        for i in 0..3 {
            for j in 0..3 {
                jac[i][j] += x[a][i] * grad[j];
            }
        }
    }
    jac
}

/// Determinant of a 3×3 matrix.
pub fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// The 2×2×2 Gauss points (all weights are 1).
pub fn hex8_gauss_points() -> [[f64; 3]; 8] {
    HEX8_CORNERS.map(|c| [c[0] * GAUSS_2, c[1] * GAUSS_2, c[2] * GAUSS_2])
}

/// Smallest Jacobian determinant over the 2×2×2 Gauss points.
pub fn hex8_min_gauss_jacobian(x: &[[f64; 3]; 8]) -> f64 {
    hex8_gauss_points()
        .iter()
        .map(|&p| det3(&hex8_jacobian(x, p)))
        .fold(f64::INFINITY, f64::min)
}

/// Volume by 2×2×2 Gauss quadrature of det J (exact for a trilinear hexahedron).
pub fn hex8_volume(x: &[[f64; 3]; 8]) -> f64 {
    hex8_gauss_points()
        .iter()
        .map(|&p| det3(&hex8_jacobian(x, p)))
        .sum()
}

/// Difference `b - a`.
fn sub(b: [f64; 3], a: [f64; 3]) -> [f64; 3] {
    [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
}

/// Euclidean norm.
fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Determinant of three column vectors, each scaled to unit length (0 if one is zero).
fn normalized_det(cols: [[f64; 3]; 3]) -> f64 {
    let lengths = cols.map(norm);
    if lengths.contains(&0.0) {
        return 0.0;
    }
    let m = std::array::from_fn(|i| std::array::from_fn(|j| cols[j][i] / lengths[j]));
    det3(&m)
}

/// Determinant of the three edge vectors from each corner to its ξ, η, ζ neighbours: 8
/// times det(∂x/∂ξ) at that corner of the trilinear map (≤ 0 where the element has folded
/// over or collapsed there).
pub fn hex8_corner_jacobians(x: &[[f64; 3]; 8]) -> [f64; 8] {
    std::array::from_fn(|a| {
        let nb = CORNER_NEIGHBOURS[a];
        let cols = nb.map(|b| sub(x[b], x[a]));
        det3(&std::array::from_fn(|i| {
            std::array::from_fn(|j| cols[j][i])
        }))
    })
}

/// Scaled Jacobian: the smallest determinant of unit edge vectors over the eight corners
/// and the centre (1 for a cube, ≤ 0 for an inverted or degenerate element).
pub fn hex8_scaled_jacobian(x: &[[f64; 3]; 8]) -> f64 {
    let corners = CORNER_NEIGHBOURS.iter().enumerate().map(|(a, nb)| {
        normalized_det([
            sub(x[nb[0]], x[a]),
            sub(x[nb[1]], x[a]),
            sub(x[nb[2]], x[a]),
        ])
    });
    let j = hex8_jacobian(x, [0.0; 3]);
    let centre = normalized_det(std::array::from_fn(|c| [j[0][c], j[1][c], j[2][c]]));
    corners.fold(centre, f64::min)
}

/// Edge ratio: longest over shortest edge (1 for a cube). Used as the aspect ratio.
pub fn hex8_edge_ratio(x: &[[f64; 3]; 8]) -> f64 {
    let lengths = HEX8_EDGES.map(|[a, b]| norm(sub(x[b], x[a])));
    let max = lengths.iter().cloned().fold(0.0, f64::max);
    let min = lengths.iter().cloned().fold(f64::INFINITY, f64::min);
    max / min
}

/// Summary of the quality of all hex8 elements of a mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshQuality {
    /// Number of hex8 elements measured.
    pub elements: usize,
    /// Smallest Jacobian determinant at any 2×2×2 Gauss point (µm³ per unit natural volume).
    pub min_gauss_jacobian: f64,
    /// Smallest scaled Jacobian (1 = perfect cube).
    pub min_scaled_jacobian: f64,
    /// Largest edge ratio (1 = all edges equal).
    pub max_edge_ratio: f64,
    /// Total volume of the hex8 elements.
    pub volume: f64,
}

/// Quality summary over every hex8 block of `mesh` (other kinds are ignored).
pub fn hex8_quality(mesh: &Mesh) -> MeshQuality {
    let mut q = MeshQuality {
        elements: 0,
        min_gauss_jacobian: f64::INFINITY,
        min_scaled_jacobian: f64::INFINITY,
        max_edge_ratio: 0.0,
        volume: 0.0,
    };
    for block in mesh.blocks.iter().filter(|b| b.kind == ElementKind::Hex8) {
        for element in block.elements() {
            let x = hex8_coordinates(mesh, element);
            q.elements += 1;
            q.min_gauss_jacobian = q.min_gauss_jacobian.min(hex8_min_gauss_jacobian(&x));
            q.min_scaled_jacobian = q.min_scaled_jacobian.min(hex8_scaled_jacobian(&x));
            q.max_edge_ratio = q.max_edge_ratio.max(hex8_edge_ratio(&x));
            q.volume += hex8_volume(&x);
        }
    }
    q
}

/// Counts how many hex8 elements use each face (keyed by its sorted node indices), and
/// remembers the outward-ordered face of its first user.
pub fn hex8_face_uses(mesh: &Mesh) -> HashMap<[usize; 4], ([usize; 4], usize)> {
    let mut uses: HashMap<[usize; 4], ([usize; 4], usize)> = HashMap::new();
    for block in mesh.blocks.iter().filter(|b| b.kind == ElementKind::Hex8) {
        for element in block.elements() {
            for face in HEX8_FACES {
                let nodes = face.map(|a| element[a]);
                let mut key = nodes;
                key.sort_unstable();
                uses.entry(key).or_insert((nodes, 0)).1 += 1;
            }
        }
    }
    uses
}

/// Faces of hex8 elements used by exactly one element, ordered counter-clockwise seen from
/// outside, sorted for reproducibility.
pub fn boundary_faces(mesh: &Mesh) -> Vec<[usize; 4]> {
    let mut faces: Vec<[usize; 4]> = hex8_face_uses(mesh)
        .into_values()
        .filter(|&(_, n)| n == 1)
        .map(|(f, _)| f)
        .collect();
    faces.sort_unstable();
    faces
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_cube() -> [[f64; 3]; 8] {
        HEX8_CORNERS.map(|c| [0.5 * (c[0] + 1.0), 0.5 * (c[1] + 1.0), 0.5 * (c[2] + 1.0)])
    }

    #[test]
    fn unit_cube_measures() {
        let x = unit_cube();
        assert!((hex8_volume(&x) - 1.0).abs() < 1e-14);
        assert!((hex8_min_gauss_jacobian(&x) - 0.125).abs() < 1e-14);
        assert!((hex8_scaled_jacobian(&x) - 1.0).abs() < 1e-14);
        assert!((hex8_edge_ratio(&x) - 1.0).abs() < 1e-14);
    }

    #[test]
    fn stretched_and_sheared_elements() {
        let mut x = unit_cube();
        for p in &mut x {
            p[0] *= 4.0; // 4 × 1 × 1 brick
        }
        assert!((hex8_volume(&x) - 4.0).abs() < 1e-13);
        assert!((hex8_edge_ratio(&x) - 4.0).abs() < 1e-13);
        assert!((hex8_scaled_jacobian(&x) - 1.0).abs() < 1e-13);
        // Shear the top face by 1 in x: 45° corners, scaled Jacobian sin 45°.
        let mut s = unit_cube();
        for p in &mut s {
            p[0] += p[2];
        }
        assert!((hex8_scaled_jacobian(&s) - 0.5f64.sqrt()).abs() < 1e-13);
        assert!((hex8_volume(&s) - 1.0).abs() < 1e-13);
    }

    #[test]
    fn inverted_element_is_detected() {
        let mut x = unit_cube();
        x.swap(0, 4);
        x.swap(1, 5);
        x.swap(2, 6);
        x.swap(3, 7);
        assert!(hex8_min_gauss_jacobian(&x) < 0.0);
        assert!(hex8_scaled_jacobian(&x) < 0.0);
    }
}
