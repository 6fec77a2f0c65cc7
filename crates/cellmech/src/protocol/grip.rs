//! The geometric grip of the micropipette tension (`grip = "cap"`): on each pole, the
//! cell-surface nodes within `grip_radius` of the test axis are tied to their pipette
//! (prescribed DOFs, exact elimination). So that the gripped patch is the same disk on
//! every mesh, the surface-node ring of the cubed sphere nearest the grip radius is first
//! moved onto it ([`resolve_cap_ring`]); [`cap_nodes`] then selects the cap and
//! [`gripped_area`] measures it. Pure geometry on the reference mesh: no solve.

use cellmech_fem::mesh::generate::quality::{
    boundary_faces, hex8_coordinates, hex8_min_gauss_jacobian, hex8_volume,
};
use cellmech_fem::mesh::refine::HangingNode;
use cellmech_fem::mesh::{ElementKind, Mesh};

/// One pole of the test axis: `axis` (0, 1, 2) and `side` (+1 or −1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pole {
    /// Test axis.
    pub axis: usize,
    /// +1 for the pole at +axis, −1 for the one at −axis.
    pub side: f64,
}

impl Pole {
    /// Distance of `p` from the test axis.
    pub fn axis_distance(&self, p: [f64; 3]) -> f64 {
        let [j, k] = self.transverse();
        p[j].hypot(p[k])
    }

    /// The two transverse components.
    fn transverse(&self) -> [usize; 2] {
        [(self.axis + 1) % 3, (self.axis + 2) % 3]
    }

    /// Equi-angular coordinates `(a, b)` of the direction of `p` on the cube face this pole
    /// lies on (the cubed-sphere grid is uniform in them) and its polar angle from the
    /// pole; `None` on the other half of the sphere.
    fn face_coordinates(&self, p: [f64; 3]) -> Option<(f64, f64, f64)> {
        let along = self.side * p[self.axis];
        if along <= 0.0 {
            return None;
        }
        let [j, k] = self.transverse();
        let a = p[j].atan2(along);
        let b = p[k].atan2(along);
        Some((a, b, p[j].hypot(p[k]).atan2(along)))
    }
}

/// What [`resolve_cap_ring`] did on one pole.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CapRing {
    /// Angular position (face coordinate, degrees) of the ring that was moved.
    pub ring_angle_deg: f64,
    /// The grip radius's polar angle on the cell surface (degrees).
    pub grip_angle_deg: f64,
    /// Surface nodes of the ring (now at the grip radius, except kept nodes).
    pub ring_nodes: usize,
    /// Nodes moved (surface and interior).
    pub moved_nodes: usize,
    /// Nodes of the ring left in place because they must stay (focal adhesions).
    pub kept_ring_nodes: usize,
    /// Smallest Gauss-point Jacobian determinant of the touched hex8 elements, relative
    /// to the element's mean (1: undistorted parallelepiped; must stay > 0).
    pub min_relative_jacobian: f64,
}

/// Why the cap ring could not be placed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CapRingError {
    /// No ring of surface nodes lies between the pole and the cube-face edge at a usable
    /// angle.
    #[error("the mesh has no ring of surface nodes near the grip radius on this pole (grip angle {grip_angle_deg:.1}°, rings at {rings_deg:?}°)")]
    NoRing {
        /// The grip radius's polar angle (degrees).
        grip_angle_deg: f64,
        /// The rings found (degrees).
        rings_deg: Vec<f64>,
    },
    /// Moving the ring inverted an element.
    #[error("moving the surface ring to the grip radius inverts an element (relative Jacobian {0:.3}); choose a grip radius nearer a ring of the mesh")]
    Inverted(f64),
}

/// Moves the cubed-sphere ring of surface nodes nearest the grip radius onto it: every node
/// of that ring (a square of nodes on the cube face, all at the same equi-angular distance
/// `s_k` from the pole) ends at distance `grip_radius` from the axis, on the sphere. The
/// map changes only polar angles about the test axis (radii and azimuths are kept): inside
/// the ring the polar angle is scaled (θ·θ_g/θ_k), between the ring and the next one out
/// the change fades linearly to zero, and radially it fades from the full change at the
/// cell surface to none at `inner_radius` (the nucleus surface stays put). It is applied
/// to every node of the mesh (filament nodes follow the continuum they lie in) except the
/// `keep` nodes (focal adhesions). `surface` lists the cell-surface nodes.
///
/// The map is not affine, so it would move a tied node (`ties`: a hanging node, an FA
/// plaque's reference node) off the weighted position of its masters, Σ wᵢ Xᵢ, where it
/// was built. A tie x = Σ wᵢ xᵢ follows rigid rotations only from there (off it, the pull
/// on the node gains a moment nothing balances: a plaque reference node moved 0.046 µm off
/// gave the prestressed cell's supports 0.55 nN), and a hanging node off it opens the mesh.
/// So every tied node not in `keep` is put back at Σ wᵢ Xᵢ of its moved masters.
#[allow(clippy::too_many_arguments)]
pub fn resolve_cap_ring(
    mesh: &mut Mesh,
    surface: &[usize],
    keep: &[usize],
    ties: &[HangingNode],
    pole: Pole,
    cell_radius: f64,
    inner_radius: f64,
    grip_radius: f64,
) -> Result<CapRing, CapRingError> {
    let grip_angle = (grip_radius / cell_radius).clamp(-1.0, 1.0).asin();
    let quarter = std::f64::consts::FRAC_PI_4;
    let tol = 1e-9;
    // Rings: equi-angular distances s = max(|a|, |b|) shared by at least 4 surface nodes.
    let mut values: Vec<f64> = surface
        .iter()
        .filter_map(|&n| pole.face_coordinates(mesh.nodes[n]))
        .map(|(a, b, _)| a.abs().max(b.abs()))
        .filter(|&s| s > tol && s <= quarter + tol)
        .collect();
    values.sort_by(f64::total_cmp);
    let mut rings: Vec<(f64, usize)> = Vec::new();
    for s in values {
        match rings.last_mut() {
            Some((v, count)) if (s - *v).abs() < 1e-7 => *count += 1,
            _ => rings.push((s, 1)),
        }
    }
    let rings: Vec<f64> = rings
        .into_iter()
        .filter(|&(_, c)| c >= 4)
        .map(|(s, _)| s)
        .collect();
    let no_ring = || CapRingError::NoRing {
        grip_angle_deg: grip_angle.to_degrees(),
        rings_deg: rings.iter().map(|s| s.to_degrees()).collect(),
    };
    let k = (0..rings.len())
        .filter(|&k| rings[k] < quarter - tol)
        .min_by(|&i, &j| {
            (rings[i] - grip_angle)
                .abs()
                .total_cmp(&(rings[j] - grip_angle).abs())
        })
        .ok_or_else(no_ring)?;
    let ring = rings[k];
    let outer = rings.get(k + 1).copied().unwrap_or(quarter);
    let keep: std::collections::BTreeSet<usize> = keep.iter().copied().collect();
    let on_ring = |p: [f64; 3]| {
        pole.face_coordinates(p)
            .is_some_and(|(a, b, _)| (a.abs().max(b.abs()) - ring).abs() < 1e-7)
    };
    let ring_nodes: Vec<usize> = surface
        .iter()
        .copied()
        .filter(|&n| on_ring(mesh.nodes[n]))
        .collect();
    let kept_ring_nodes = ring_nodes.iter().filter(|n| keep.contains(n)).count();
    let mut moved = vec![false; mesh.nodes.len()];
    for (n, p) in mesh.nodes.iter_mut().enumerate() {
        if keep.contains(&n) {
            continue;
        }
        let Some((a, b, theta)) = pole.face_coordinates(*p) else {
            continue;
        };
        let s = a.abs().max(b.abs());
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        // The nucleus surface (and everything inside it) stays put, round-off included.
        if s <= tol || s >= outer || r <= inner_radius * (1.0 + 1e-9) {
            continue;
        }
        // Polar angle of the ring point on this node's ray in face coordinates.
        let (ta, tb) = ((a * ring / s).tan(), (b * ring / s).tan());
        let ring_theta = ta.hypot(tb).atan();
        let full = if s <= ring {
            theta * grip_angle / ring_theta
        } else {
            theta + (grip_angle - ring_theta) * (outer - s) / (outer - ring)
        };
        let w = ((r - inner_radius) / (cell_radius - inner_radius)).clamp(0.0, 1.0);
        let new_theta = theta + w * (full - theta);
        let [j, kk] = pole.transverse();
        let rho = p[j].hypot(p[kk]);
        let (cj, ck) = (p[j] / rho, p[kk] / rho);
        p[pole.axis] = pole.side * r * new_theta.cos();
        p[j] = r * new_theta.sin() * cj;
        p[kk] = r * new_theta.sin() * ck;
        moved[n] = true;
    }
    for tie in ties {
        let touched = moved[tie.node] || tie.masters.iter().any(|&(m, _)| moved[m]);
        if keep.contains(&tie.node) || !touched {
            continue;
        }
        mesh.nodes[tie.node] = tie.tied_position(&mesh.nodes);
        moved[tie.node] = true;
    }
    let mut min_relative_jacobian = f64::INFINITY;
    for block in &mesh.blocks {
        if block.kind != ElementKind::Hex8 {
            continue;
        }
        for element in block.connectivity.chunks(8) {
            if !element.iter().any(|&n| moved[n]) {
                continue;
            }
            let x = hex8_coordinates(mesh, element);
            let volume = hex8_volume(&x);
            min_relative_jacobian =
                min_relative_jacobian.min(8.0 * hex8_min_gauss_jacobian(&x) / volume);
        }
    }
    if min_relative_jacobian <= 0.0 {
        return Err(CapRingError::Inverted(min_relative_jacobian));
    }
    Ok(CapRing {
        ring_angle_deg: ring.to_degrees(),
        grip_angle_deg: grip_angle.to_degrees(),
        ring_nodes: ring_nodes.len(),
        moved_nodes: moved.iter().filter(|&&m| m).count(),
        kept_ring_nodes,
        min_relative_jacobian,
    })
}

/// Tolerance of the cap selection: a node counts as inside when its distance from the axis
/// is at most `grip_radius + CAP_TOLERANCE · cell_radius` (the ring nodes sit on the grip
/// radius up to round-off).
pub const CAP_TOLERANCE: f64 = 1e-9;

/// The cap of `pole`: the `surface` nodes on the pole's half (beyond the cell's centre
/// plane) within `grip_radius` of the test axis, in the mesh's reference configuration.
pub fn cap_nodes(
    mesh: &Mesh,
    surface: &[usize],
    pole: Pole,
    cell_radius: f64,
    grip_radius: f64,
) -> Vec<usize> {
    surface
        .iter()
        .copied()
        .filter(|&n| {
            let p = mesh.nodes[n];
            pole.side * p[pole.axis] > 0.0
                && pole.axis_distance(p) <= grip_radius + CAP_TOLERANCE * cell_radius
        })
        .collect()
}

/// Area of the surface facets (boundary quadrilaterals of the hex8 mesh) whose four nodes
/// are all in `cap` (each facet's vector area: exact for planar facets).
pub fn gripped_area(mesh: &Mesh, cap: &[usize]) -> f64 {
    let inside: std::collections::BTreeSet<usize> = cap.iter().copied().collect();
    boundary_faces(mesh)
        .iter()
        .filter(|f| f.iter().all(|n| inside.contains(n)))
        .map(|f| cellmech_fem::mesh::surface::quad_area(&mesh.nodes, f))
        .sum()
}

/// Area of the spherical cap of a sphere of radius `cell_radius` cut at distance
/// `grip_radius` from its axis: 2πR²(1 − cos θ), sin θ = r/R.
pub fn spherical_cap_area(cell_radius: f64, grip_radius: f64) -> f64 {
    let theta = (grip_radius / cell_radius).asin();
    2.0 * std::f64::consts::PI * cell_radius * cell_radius * (1.0 - theta.cos())
}

/// The two caps of a `grip = "cap"` tension test, for `summary.json`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CapReport {
    /// Grip radius (µm).
    pub grip_radius_um: f64,
    /// Nodes in the fixed (−axis) and the moving (+axis) cap.
    pub cap_nodes: [usize; 2],
    /// Area of the surface facets fully inside each cap (µm²), reference configuration.
    pub gripped_area_um2: [f64; 2],
    /// The spherical-cap area 2πR²(1 − cos θ) of the grip radius (µm²).
    pub spherical_cap_area_um2: f64,
    /// The ring moved onto the grip radius, per pole (fixed, moving).
    pub rings: [CapRing; 2],
}
