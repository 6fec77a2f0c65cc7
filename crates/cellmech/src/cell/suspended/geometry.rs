//! The focal-adhesion (FA) sites: the 30 vertices of an icosidodecahedron inscribed in the
//! cell surface, oriented against the surface mesh and snapped onto surface nodes.
//!
//! Canonical coordinates (circumradius φ, edge 1): the cyclic permutations of `(0, 0, ±φ)`
//! and `(±1/2, ±φ/2, ±φ²/2)`, φ = (1 + √5)/2. Scaled to circumradius `R`, every edge has
//! length `R/φ` (≈ 0.618 R), and every vertex has four neighbours.

use std::collections::BTreeSet;

use cellmech_fem::mesh::generate::quality::{
    hex8_coordinates, hex8_min_gauss_jacobian, hex8_scaled_jacobian,
};
use cellmech_fem::mesh::generate::{boundary_faces, SplitMix64};
use cellmech_fem::mesh::{ElementKind, Mesh};

use super::CellGeometryError;
use crate::cell::vec3::{
    angle, apply, compose, cross, distance, normalize, quaternion_matrix, rotate_about, scale,
    IDENTITY, M3, V3,
};

/// The golden ratio φ = (1 + √5)/2.
pub const GOLDEN_RATIO: f64 = 1.618_033_988_749_895;

/// Number of icosidodecahedron vertices (focal adhesions).
pub const FA_COUNT: usize = 30;

/// Number of icosidodecahedron edges (actin filaments).
pub const AF_COUNT: usize = 60;

/// How the icosidodecahedron is oriented against the cubed-sphere surface mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaOrientation {
    /// Canonical coordinates, unrotated: six FAs sit exactly on the ±x, ±y, ±z poles and
    /// the other 24 are images of one another under the mesh's symmetries, so all snap by
    /// the same distance and the model keeps the mesh's three mirror planes.
    Symmetric,
    /// The rotation (among the canonical one, `trials` seeded uniform random rotations and a
    /// seeded local refinement of the best) that minimises the largest snap distance
    /// relative to the local surface element size. Uses the parameters' seed.
    Optimized {
        /// Number of random rotations tried before the local refinement.
        trials: usize,
    },
    /// The test axis (x) through the centres of two opposite pentagonal faces, so that no
    /// FA lies within 31.7° of it (a 4 µm grip on the default cell spans 14.4°): the
    /// pattern has five-fold symmetry about the axis. Of the spins about x (every 0.5° over
    /// one 72° period) the one with the smallest largest snap distance is kept.
    PentagonOnAxis,
}

/// The 30 icosidodecahedron vertices on the unit sphere, in the fixed order used
/// throughout (FA index k): first the six `(0, 0, ±φ)` vertices for the cyclic
/// permutations placing φ on z, x, y (+ then −), then the 24 `(±1/2, ±φ/2, ±φ²/2)`
/// vertices, permutation by permutation, signs in binary order (+ before −, first
/// component slowest).
pub fn icosidodecahedron_unit_vertices() -> [V3; FA_COUNT] {
    let phi = GOLDEN_RATIO;
    let place = |shift: usize, t: V3| -> V3 {
        let mut v = [0.0; 3];
        for (i, c) in t.iter().enumerate() {
            v[(i + shift) % 3] = *c;
        }
        scale(v, 1.0 / phi)
    };
    let mut out = Vec::with_capacity(FA_COUNT);
    for shift in 0..3 {
        for s in [1.0, -1.0] {
            out.push(place(shift, [0.0, 0.0, s * phi]));
        }
    }
    for shift in 0..3 {
        for sa in [1.0, -1.0] {
            for sb in [1.0, -1.0] {
                for sc in [1.0, -1.0] {
                    out.push(place(
                        shift,
                        [sa * 0.5, sb * 0.5 * phi, sc * 0.5 * phi * phi],
                    ));
                }
            }
        }
    }
    std::array::from_fn(|k| out[k])
}

/// The 60 edges of an icosidodecahedron given by its vertices (any circumradius): the
/// vertex pairs at the shortest distance, `[i, j]` with `i < j`, in lexicographic order.
pub fn icosidodecahedron_edges(vertices: &[V3; FA_COUNT]) -> Vec<[usize; 2]> {
    let radius = crate::cell::vec3::norm(vertices[0]);
    let edge = radius / GOLDEN_RATIO;
    let mut edges = Vec::with_capacity(AF_COUNT);
    for i in 0..FA_COUNT {
        for j in i + 1..FA_COUNT {
            if (distance(vertices[i], vertices[j]) - edge).abs() < 1e-6 * radius {
                edges.push([i, j]);
            }
        }
    }
    edges
}

/// The surface nodes of a mesh with the mean length of the surface-mesh edges at each.
pub(crate) struct SurfaceNodes {
    /// Mesh node indices of the outer surface.
    pub nodes: Vec<usize>,
    /// Their coordinates.
    pub positions: Vec<V3>,
    /// Mean length of the boundary-quad edges meeting at each (µm).
    pub sizes: Vec<f64>,
}

impl SurfaceNodes {
    /// Collects the nodes of set `surface` and their local edge length from the boundary
    /// quads of the hex8 mesh.
    pub fn new(mesh: &Mesh, surface: &[usize]) -> Self {
        let slot: std::collections::HashMap<usize, usize> =
            surface.iter().enumerate().map(|(i, &n)| (n, i)).collect();
        let mut sum = vec![0.0; surface.len()];
        let mut count = vec![0usize; surface.len()];
        let mut seen = BTreeSet::new();
        for face in boundary_faces(mesh) {
            for e in 0..4 {
                let (a, b) = (face[e], face[(e + 1) % 4]);
                if !seen.insert((a.min(b), a.max(b))) {
                    continue;
                }
                let length = distance(mesh.nodes[a], mesh.nodes[b]);
                for n in [a, b] {
                    if let Some(&i) = slot.get(&n) {
                        sum[i] += length;
                        count[i] += 1;
                    }
                }
            }
        }
        Self {
            nodes: surface.to_vec(),
            positions: surface.iter().map(|&n| mesh.nodes[n]).collect(),
            sizes: (0..surface.len())
                .map(|i| sum[i] / count[i].max(1) as f64)
                .collect(),
        }
    }

    /// Slot of the surface node nearest to `p`, and its distance.
    pub fn nearest(&self, p: V3) -> (usize, f64) {
        let mut best = (0, f64::INFINITY);
        for (i, &q) in self.positions.iter().enumerate() {
            let d = distance(p, q);
            if d < best.1 {
                best = (i, d);
            }
        }
        best
    }

    /// Largest relative snap distance for these sites, or `None` if two sites share their
    /// nearest node.
    fn relative_snap(&self, sites: &[V3]) -> Option<f64> {
        let mut used = BTreeSet::new();
        let mut worst: f64 = 0.0;
        for &p in sites {
            let (slot, d) = self.nearest(p);
            if !used.insert(slot) {
                return None;
            }
            worst = worst.max(d / self.sizes[slot]);
        }
        Some(worst)
    }
}

/// FA sites (radius `radius`) for the rotation `rotation` of the unit vertices.
pub(crate) fn fa_sites(rotation: &M3, radius: f64) -> Vec<V3> {
    icosidodecahedron_unit_vertices()
        .iter()
        .map(|&v| scale(normalize(apply(rotation, v)), radius))
        .collect()
}

/// A seeded uniform random rotation (Shoemake's method).
fn random_rotation(rng: &mut SplitMix64) -> M3 {
    let (u1, u2, u3) = (rng.next_f64(), rng.next_f64(), rng.next_f64());
    let tau = std::f64::consts::TAU;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    quaternion_matrix([
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
        b * (tau * u3).cos(),
    ])
}

/// Local refinement steps after the random trials of [`FaOrientation::Optimized`].
const REFINEMENT_STEPS: usize = 400;

/// The rotation of the canonical icosidodecahedron chosen by `orientation`.
pub(crate) fn choose_orientation(
    surface: &SurfaceNodes,
    radius: f64,
    orientation: FaOrientation,
    seed: u64,
) -> M3 {
    let score = |m: &M3| {
        surface
            .relative_snap(&fa_sites(m, radius))
            .unwrap_or(f64::INFINITY)
    };
    let trials = match orientation {
        FaOrientation::Symmetric => return IDENTITY,
        FaOrientation::PentagonOnAxis => return pentagon_on_axis(score),
        FaOrientation::Optimized { trials } => trials,
    };
    let mut rng = SplitMix64::new(seed);
    let mut best = (IDENTITY, score(&IDENTITY));
    for _ in 0..trials {
        let m = random_rotation(&mut rng);
        let s = score(&m);
        if s < best.1 {
            best = (m, s);
        }
    }
    let mut step = 0.05;
    for _ in 0..REFINEMENT_STEPS {
        let axis = normalize([
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0) + 1e-12,
        ]);
        let turn = rng.uniform(-step, step);
        let (s, c) = (0.5 * turn).sin_cos();
        let m = compose(
            &quaternion_matrix([c, s * axis[0], s * axis[1], s * axis[2]]),
            &best.0,
        );
        let sm = score(&m);
        if sm < best.1 {
            best = (m, sm);
        } else {
            step *= 0.99;
        }
    }
    best.0
}

/// Spin steps of [`FaOrientation::PentagonOnAxis`] over its 72° period.
const PENTAGON_SPINS: usize = 144;

/// The rotation taking the pentagon-centre direction `(0, φ, 1)` onto `+x`, followed by
/// the spin about `x` (of [`PENTAGON_SPINS`] over 72°) with the smallest `score`.
fn pentagon_on_axis(score: impl Fn(&M3) -> f64) -> M3 {
    let u = normalize([0.0, GOLDEN_RATIO, 1.0]);
    let x = [1.0, 0.0, 0.0];
    let axis = normalize(cross(u, x));
    let half = 0.5 * angle(u, x);
    let (s, c) = half.sin_cos();
    let onto = quaternion_matrix([c, s * axis[0], s * axis[1], s * axis[2]]);
    let period = 72f64.to_radians();
    (0..PENTAGON_SPINS)
        .map(|k| {
            let (s, c) = (0.5 * period * k as f64 / PENTAGON_SPINS as f64).sin_cos();
            compose(&quaternion_matrix([c, s, 0.0, 0.0]), &onto)
        })
        .map(|m| (score(&m), m))
        .fold((f64::INFINITY, IDENTITY), |best, next| {
            if next.0 < best.0 {
                next
            } else {
                best
            }
        })
        .1
}

/// What snapping the FA sites onto the surface did.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SnapOutcome {
    /// FA node per site, in site order.
    pub fa_nodes: Vec<usize>,
    /// Largest distance a surface node moved (µm).
    pub max_snap_distance: f64,
    /// Largest snap distance over the mean surface edge length at that node.
    pub max_relative_snap: f64,
    /// Number of nodes moved (surface nodes and the cytoplasm columns beneath them).
    pub moved_nodes: usize,
    /// Smallest Gauss-point Jacobian determinant of the elements touching moved nodes.
    pub min_gauss_jacobian: f64,
    /// Smallest scaled Jacobian of those elements before and after the snap.
    pub min_scaled_jacobian: (f64, f64),
}

/// The nearest surface node of each site (distinct: two sites on one node is an error),
/// the largest distance and the largest distance over the local surface edge length.
fn nearest_surface_nodes(
    surface: &SurfaceNodes,
    sites: &[V3],
) -> Result<(Vec<usize>, f64, f64), CellGeometryError> {
    let mut owner = std::collections::HashMap::new();
    let mut fa_nodes = Vec::with_capacity(sites.len());
    let (mut max_d, mut max_rel) = (0.0f64, 0.0f64);
    for (k, &p) in sites.iter().enumerate() {
        let (slot, d) = surface.nearest(p);
        let node = surface.nodes[slot];
        if let Some(&first) = owner.get(&node) {
            return Err(CellGeometryError::FaSnapCollision {
                first,
                second: k,
                node,
            });
        }
        owner.insert(node, k);
        fa_nodes.push(node);
        max_d = max_d.max(d);
        max_rel = max_rel.max(d / surface.sizes[slot]);
    }
    Ok((fa_nodes, max_d, max_rel))
}

/// Moves the nearest surface node onto each site. The cytoplasm nodes of the same radial
/// column (same direction from the centre, radius between the nucleus and the cell) turn
/// with it by a fraction `(r − r_n)/(R − r_n)` of the surface node's rotation, so the
/// radial element columns shear smoothly instead of only the top layer.
pub(crate) fn snap_sites(
    mesh: &mut Mesh,
    surface: &SurfaceNodes,
    sites: &[V3],
    nucleus_radius: f64,
) -> Result<SnapOutcome, CellGeometryError> {
    let (fa_nodes, max_d, max_rel) = nearest_surface_nodes(surface, sites)?;
    let mut moved = BTreeSet::new();
    let before = mesh.nodes.clone();
    for (&node, &p) in fa_nodes.iter().zip(sites) {
        let s = before[node];
        let cell_radius = crate::cell::vec3::norm(s);
        let theta = angle(s, p);
        let axis_raw = cross(s, p);
        if theta > 0.0 && crate::cell::vec3::norm(axis_raw) > 0.0 {
            let axis = normalize(axis_raw);
            let dir = normalize(s);
            for (n, &q) in before.iter().enumerate() {
                let r = crate::cell::vec3::norm(q);
                if r <= nucleus_radius * (1.0 + 1e-9) || r >= cell_radius * (1.0 - 1e-12) {
                    continue;
                }
                if distance(scale(q, 1.0 / r), dir) < 1e-9 {
                    let w = (r - nucleus_radius) / (cell_radius - nucleus_radius);
                    mesh.nodes[n] = rotate_about(q, axis, w * theta);
                    moved.insert(n);
                }
            }
        }
        mesh.nodes[node] = p;
        moved.insert(node);
    }
    let (min_j, sj_before, sj_after) = check_touched_elements(mesh, &before, &moved)?;
    Ok(SnapOutcome {
        fa_nodes,
        max_snap_distance: max_d,
        max_relative_snap: max_rel,
        moved_nodes: moved.len(),
        min_gauss_jacobian: min_j,
        min_scaled_jacobian: (sj_before, sj_after),
    })
}

/// The nearest surface node of each site, nothing moved (`fa_snap = "none"`): the
/// outcome's snap distances are the sites' offsets from their FA nodes, and its scaled
/// Jacobians (before = after) those of the elements at the FA nodes.
pub(crate) fn nearest_sites(
    mesh: &Mesh,
    surface: &SurfaceNodes,
    sites: &[V3],
) -> Result<SnapOutcome, CellGeometryError> {
    let (fa_nodes, max_d, max_rel) = nearest_surface_nodes(surface, sites)?;
    let touched: BTreeSet<usize> = fa_nodes.iter().copied().collect();
    let (min_j, sj, _) = check_touched_elements(mesh, &mesh.nodes, &touched)?;
    Ok(SnapOutcome {
        fa_nodes,
        max_snap_distance: max_d,
        max_relative_snap: max_rel,
        moved_nodes: 0,
        min_gauss_jacobian: min_j,
        min_scaled_jacobian: (sj, sj),
    })
}

/// Gauss-point Jacobians of every hex8 element touching a moved node must stay positive.
/// Returns (min Gauss Jacobian, min scaled Jacobian before, after) over those elements.
fn check_touched_elements(
    mesh: &Mesh,
    before: &[V3],
    moved: &BTreeSet<usize>,
) -> Result<(f64, f64, f64), CellGeometryError> {
    let old = Mesh {
        nodes: before.to_vec(),
        ..Mesh::default()
    };
    let (mut min_j, mut sj_before, mut sj_after) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
    for block in mesh.blocks.iter().filter(|b| b.kind == ElementKind::Hex8) {
        for (e, element) in block.elements().enumerate() {
            if !element.iter().any(|n| moved.contains(n)) {
                continue;
            }
            let x = hex8_coordinates(mesh, element);
            let j = hex8_min_gauss_jacobian(&x);
            if !(j > 0.0) {
                return Err(CellGeometryError::InvertedAfterSnap {
                    block: block.name.clone(),
                    element: e,
                    min_jacobian: j,
                });
            }
            min_j = min_j.min(j);
            sj_after = sj_after.min(hex8_scaled_jacobian(&x));
            sj_before = sj_before.min(hex8_scaled_jacobian(&hex8_coordinates(&old, element)));
        }
    }
    Ok((min_j, sj_before, sj_after))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell::vec3::{dot, norm};

    #[test]
    fn pentagon_on_axis_puts_five_fas_at_equal_distance_around_each_pole_and_none_nearer() {
        // Any spin about x keeps the property: score by the spin's own angle only.
        let m = pentagon_on_axis(|_| 1.0);
        let sites = fa_sites(&m, 1.0);
        for pole in [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]] {
            let mut angles: Vec<f64> = sites.iter().map(|&s| angle(s, pole)).collect();
            angles.sort_by(f64::total_cmp);
            // A pentagon of unit edge has circumradius 0.8507; the vertices lie at
            // circumradius φ: asin(0.8507 / φ) = 31.72°.
            let expected = (0.850_650_808_352_039_9 / GOLDEN_RATIO).asin();
            for a in &angles[..5] {
                assert!((a - expected).abs() < 1e-12, "{angles:?}");
            }
            assert!(angles[5] > expected + 0.1, "{angles:?}");
            assert!((expected.to_degrees() - 31.717).abs() < 1e-3);
        }
        // The spin chosen scores (nearly: 0.5° grid) as well as the best of a fine sweep.
        let score = |m: &M3| apply(m, [0.0, 1.0, 0.0])[2];
        let spun = pentagon_on_axis(score);
        let sweep: Vec<f64> = (0..2000)
            .map(|k| {
                let half = 0.5 * 72f64.to_radians() * k as f64 / 2000.0;
                score(&compose(
                    &quaternion_matrix([half.cos(), half.sin(), 0.0, 0.0]),
                    &m,
                ))
            })
            .collect();
        let best = sweep.iter().copied().fold(f64::INFINITY, f64::min);
        let worst = sweep.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert!(
            worst - best > 0.5,
            "the sweep must discriminate: {best}..{worst}"
        );
        assert!(score(&spun) - best < 0.01, "{} vs {best}", score(&spun));
    }

    #[test]
    fn icosidodecahedron_has_30_unit_vertices_60_equal_edges_degree_4() {
        let v = icosidodecahedron_unit_vertices();
        for p in &v {
            assert!((norm(*p) - 1.0).abs() < 1e-15);
        }
        let edges = icosidodecahedron_edges(&v);
        assert_eq!(edges.len(), AF_COUNT);
        let mut degree = [0; FA_COUNT];
        for [a, b] in &edges {
            degree[*a] += 1;
            degree[*b] += 1;
            // Edge length is 1/φ of the circumradius, not the circumradius.
            assert!((distance(v[*a], v[*b]) - 1.0 / GOLDEN_RATIO).abs() < 1e-14);
        }
        assert!(degree.iter().all(|&d| d == 4), "{degree:?}");
        // Distinct vertices; the nearest non-neighbour is farther than an edge.
        for i in 0..FA_COUNT {
            for j in i + 1..FA_COUNT {
                let d = distance(v[i], v[j]);
                assert!(d > 0.6, "vertices {i} and {j} at {d}");
            }
        }
        // Every vertex's antipode is a vertex (centrally symmetric).
        for p in &v {
            assert!(v.iter().any(|q| distance(*q, scale(*p, -1.0)) < 1e-14));
        }
        // 20 triangles and 12 pentagons: count edge triangles.
        let set: BTreeSet<[usize; 2]> = edges.iter().cloned().collect();
        let mut triangles = 0;
        for &[a, b] in &edges {
            for c in b + 1..FA_COUNT {
                if set.contains(&[a, c]) && set.contains(&[b, c]) {
                    triangles += 1;
                }
            }
        }
        assert_eq!(triangles, 20);
        let _ = dot;
    }
}
