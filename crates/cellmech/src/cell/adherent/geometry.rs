//! The adherent cell's shape and its hex8 mesh.
//!
//! **Shape.** A half-ellipsoid `x²/a² + y²/b² + z²/c² ≤ 1, z ≥ 0` (semi-axes `a` along the
//! cell's length, `b` across, `c` its height) on the substrate `z = 0`, and an ellipsoidal
//! nucleus of semi-axes `(n_a, n_b, n_c)` centred at `c_n = (0, 0, h_n)`, fully inside.
//!
//! **Mesh by mapping.** The mesh is a cubed-sphere ball of radius 1 with a concentric inner
//! ball of radius `r_ref` (`cellmech_fem::mesh::generate::sphere_mesh`, the suspended cell's
//! generator), mapped onto the cell. With `ρ = |p|` and `n̂ = p/ρ` for a reference point `p`:
//! * inside the inner ball (`ρ ≤ r_ref`): `x = c_n + E_n p / r_ref` (`E_n` the diagonal of
//!   the nucleus semi-axes): the inner ball becomes the nucleus, affinely;
//! * in the shell: `x = (1 − t) (c_n + E_n n̂) + t P(n̂)` with `t = (ρ − r_ref)/(1 − r_ref)`:
//!   straight lines from the nucleus surface to the cell surface point `P(n̂)`;
//! * `P(n̂)` sends the upper reference hemisphere to the dome, `(a n_x, b n_y, c n_z)`, and
//!   the lower one to the base disc by an azimuthal equidistant map: polar angle `θ` from
//!   the south pole becomes the radius fraction `θ / (π/2)` of the ellipse `(a, b)` at
//!   `z = 0`. Both agree on the equator, which (even core divisions) is a ring of element
//!   edges: the rim where the dome meets the substrate is an edge ring of the mesh.
//!
//! The domain is convex and star-shaped from `c_n`, and the map is continuous across the
//! nucleus surface and the equator, so the mapped mesh is conforming; its quality is
//! measured ([`AdherentMeshReport`]). Nodes on the outer reference sphere are placed on the
//! cell surface exactly (`t = 1`), also those a local refinement adds on a reference facet,
//! so the surface under an AFM tip is the smooth ellipsoid sampled at the fine nodes.

use cellmech_fem::mesh::generate::{sphere_mesh, SphereMeshSpec};
use cellmech_fem::mesh::Mesh;

use crate::cell::vec3::{norm, V3};

/// Radius of the inner (nucleus) ball of the reference mesh (the outer ball has radius 1).
pub const REFERENCE_NUCLEUS_RADIUS: f64 = 0.5;

/// Shape of the adherent cell and its nucleus (µm).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AdherentShape {
    /// Semi-axes `(a, b, c)`: half length, half width, height.
    pub semi_axes: V3,
    /// Nucleus semi-axes.
    pub nucleus_semi_axes: V3,
    /// Height of the nucleus centre above the substrate.
    pub nucleus_height: f64,
}

impl AdherentShape {
    /// Checks that every size is positive and the nucleus lies inside the cell, off the
    /// substrate. The message says what was expected and what was found.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("semi_axes", self.semi_axes),
            ("nucleus_semi_axes", self.nucleus_semi_axes),
        ] {
            if !v.iter().all(|x| x.is_finite() && *x > 0.0) {
                return Err(format!(
                    "expected {name} to be three positive lengths; found {v:?} µm"
                ));
            }
        }
        let [na, nb, nc] = self.nucleus_semi_axes;
        let h = self.nucleus_height;
        if !(h.is_finite() && h - nc > 0.0) {
            return Err(format!(
                "expected the nucleus to clear the substrate (nucleus height {h} µm > its \
                 vertical semi-axis {nc} µm); found a nucleus reaching z = {:.3} µm",
                h - nc
            ));
        }
        // The nucleus lies inside the dome if every point of its surface does; sampled
        // densely (the test is of two ellipsoids, no closed form needed for a check).
        let mut worst: f64 = 0.0;
        for i in 0..=36 {
            let theta = std::f64::consts::PI * i as f64 / 36.0;
            for j in 0..72 {
                let phi = std::f64::consts::TAU * j as f64 / 72.0;
                let p = [
                    na * theta.sin() * phi.cos(),
                    nb * theta.sin() * phi.sin(),
                    h + nc * theta.cos(),
                ];
                worst = worst.max(self.level(p));
            }
        }
        if worst >= 0.95 {
            return Err(format!(
                "expected the nucleus (semi-axes {:?} µm, centre {h} µm above the substrate) to \
                 fit inside the cell (semi-axes {:?} µm) with room for cytoplasm; it reaches \
                 {:.0} % of the way to the cell surface",
                self.nucleus_semi_axes,
                self.semi_axes,
                100.0 * worst.sqrt()
            ));
        }
        Ok(())
    }

    /// `x²/a² + y²/b² + z²/c²`: below 1 inside the cell's ellipsoid.
    pub fn level(&self, p: V3) -> f64 {
        let [a, b, c] = self.semi_axes;
        (p[0] / a).powi(2) + (p[1] / b).powi(2) + (p[2] / c).powi(2)
    }

    /// Height of the dome above `(x, y)`; `None` outside the footprint.
    pub fn dome_height(&self, x: f64, y: f64) -> Option<f64> {
        let [a, b, c] = self.semi_axes;
        let s = 1.0 - (x / a).powi(2) - (y / b).powi(2);
        (s > 0.0).then(|| c * s.sqrt())
    }

    /// Outward unit normal of the dome at a point on it.
    pub fn dome_normal(&self, p: V3) -> V3 {
        let [a, b, c] = self.semi_axes;
        let g = [p[0] / (a * a), p[1] / (b * b), p[2] / (c * c)];
        let l = norm(g);
        [g[0] / l, g[1] / l, g[2] / l]
    }

    /// Nucleus centre.
    pub fn nucleus_centre(&self) -> V3 {
        [0.0, 0.0, self.nucleus_height]
    }

    /// The point of the nucleus surface in reference direction `n` (unit).
    fn nucleus_point(&self, n: V3) -> V3 {
        let e = self.nucleus_semi_axes;
        [e[0] * n[0], e[1] * n[1], self.nucleus_height + e[2] * n[2]]
    }

    /// The cell-surface point of reference direction `n` (unit): dome above the equator,
    /// base disc below it (azimuthal equidistant).
    pub fn surface_point(&self, n: V3) -> V3 {
        let [a, b, c] = self.semi_axes;
        if n[2] >= 0.0 {
            [a * n[0], b * n[1], c * n[2]]
        } else {
            let from_south_pole = (-n[2]).clamp(-1.0, 1.0).acos();
            let r = from_south_pole / std::f64::consts::FRAC_PI_2;
            let h = (n[0] * n[0] + n[1] * n[1]).sqrt();
            if h == 0.0 {
                [0.0, 0.0, 0.0]
            } else {
                [a * r * n[0] / h, b * r * n[1] / h, 0.0]
            }
        }
    }

    /// Maps a point of the reference ball (radius 1, inner ball `r_ref`) into the cell. With
    /// `on_surface` the point is put on the cell surface whatever its radius.
    ///
    /// The shell's paths from the nucleus to the surface are straight. This flat cell's
    /// rows therefore meet the base near the rim at a shallow angle: the element row just
    /// below the rim is a wedge of about 7° (min scaled Jacobian ≈ 0.1, measured by the
    /// tests). Curved paths that meet the surface square-on were tried (quadratic Bézier
    /// with the inward normal as end tangent): the rows above and below the rim then cross
    /// near the nucleus, because a right-angled rim cannot be fanned from one centre. The
    /// wedges lie on the clamped base, where the material barely deforms.
    pub fn map(&self, p: V3, on_surface: bool) -> V3 {
        let r_ref = REFERENCE_NUCLEUS_RADIUS;
        let rho = norm(p);
        if rho == 0.0 {
            return self.nucleus_centre();
        }
        let n = [p[0] / rho, p[1] / rho, p[2] / rho];
        if !on_surface && rho <= r_ref {
            let e = self.nucleus_semi_axes;
            return [
                e[0] * p[0] / r_ref,
                e[1] * p[1] / r_ref,
                self.nucleus_height + e[2] * p[2] / r_ref,
            ];
        }
        let outer = self.surface_point(n);
        if on_surface {
            return outer;
        }
        let t = ((rho - r_ref) / (1.0 - r_ref)).clamp(0.0, 1.0);
        let inner = self.nucleus_point(n);
        std::array::from_fn(|k| (1.0 - t) * inner[k] + t * outer[k])
    }
}

/// Divisions of the reference cubed-sphere mesh.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AdherentMeshResolution {
    /// Elements along an edge of the central cube (even).
    pub core_divisions: usize,
    /// Radial layers between the central cube and the nucleus surface.
    pub shell_layers: usize,
    /// Radial layers of cytoplasm between the nucleus and the cell surface.
    pub outer_layers: usize,
}

impl AdherentMeshResolution {
    /// Number of hex8 elements before local refinement.
    pub fn elements(&self) -> usize {
        let n = self.core_divisions;
        n * n * n + 6 * n * n * (self.shell_layers + self.outer_layers)
    }

    /// The reference ball mesh (radius 1, inner ball [`REFERENCE_NUCLEUS_RADIUS`]).
    pub fn reference_mesh(&self) -> Result<Mesh, String> {
        if self.core_divisions < 2 || self.core_divisions % 2 != 0 {
            return Err(format!(
                "expected mesh.core_divisions to be even and at least 2 (the rim must be a \
                 ring of element edges); found {}",
                self.core_divisions
            ));
        }
        sphere_mesh(&SphereMeshSpec {
            radius: 1.0,
            inner_radius: Some(REFERENCE_NUCLEUS_RADIUS),
            core_divisions: self.core_divisions,
            shell_layers: self.shell_layers,
            outer_layers: self.outer_layers,
            core_fraction: 0.5,
        })
        .map_err(|e| e.to_string())
    }
}

/// Maps every node of a reference mesh into the cell (nodes of set `surface` onto the cell
/// surface, of `inner_surface` onto the nucleus surface) and renames the sets: `surface` becomes the whole outer boundary, `bottom` its
/// nodes on the substrate (rim included), `dome` the others plus the rim, `apex` the top
/// node, `nucleus_surface` the nucleus surface.
pub fn map_reference_mesh(reference: &Mesh, shape: &AdherentShape) -> Mesh {
    let mut mesh = reference.clone();
    let mut on_surface = vec![false; mesh.num_nodes()];
    for &n in mesh.node_sets.get("surface").into_iter().flatten() {
        on_surface[n] = true;
    }
    let mut on_nucleus = vec![false; mesh.num_nodes()];
    for &n in mesh.node_sets.get("inner_surface").into_iter().flatten() {
        on_nucleus[n] = true;
    }
    for (n, x) in mesh.nodes.iter_mut().enumerate() {
        if on_nucleus[n] {
            // On the nucleus surface exactly (nodes a refinement added on a facet too).
            *x = crate::cell::vec3::scale(*x, REFERENCE_NUCLEUS_RADIUS / norm(*x));
        }
        *x = shape.map(*x, on_surface[n]);
    }
    let surface = mesh.node_sets.get("surface").cloned().unwrap_or_default();
    // The rim and the base have reference z ≤ 0 exactly (the equator ring is at z = 0).
    let bottom: Vec<usize> = surface
        .iter()
        .copied()
        .filter(|&n| reference.nodes[n][2] <= 1e-12)
        .collect();
    let dome: Vec<usize> = surface
        .iter()
        .copied()
        .filter(|&n| reference.nodes[n][2] >= -1e-12)
        .collect();
    mesh.insert_node_set("bottom", bottom);
    mesh.insert_node_set("dome", dome);
    if let Some(top) = mesh.node_sets.get("top_pole").cloned() {
        mesh.insert_node_set("apex", top);
    }
    if let Some(inner) = mesh.node_sets.get("inner_surface").cloned() {
        mesh.insert_node_set("nucleus_surface", inner);
    }
    for set in ["bottom_pole", "equator_x_plus", "axis_z", "top_pole"] {
        mesh.node_sets.remove(set);
    }
    mesh
}

/// Measured quality of the mapped mesh.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AdherentMeshReport {
    /// Hex8 elements.
    pub hex8_elements: usize,
    /// Smallest scaled Jacobian (1 for a cube, ≤ 0 inverted).
    pub min_scaled_jacobian: f64,
    /// Largest edge ratio of an element.
    pub max_edge_ratio: f64,
    /// Total volume (µm³) and the analytic `(2/3) π a b c`.
    pub volume: f64,
    /// Analytic volume of the half-ellipsoid.
    pub exact_volume: f64,
    /// Smallest element edge near the refinement site (µm), the mesh's smallest edge.
    pub min_edge: f64,
}

/// Quality of a mapped adherent mesh.
pub fn mesh_report(mesh: &Mesh, shape: &AdherentShape) -> AdherentMeshReport {
    use cellmech_fem::mesh::generate::quality::{hex8_coordinates, hex8_quality, hex8_volume};
    let q = hex8_quality(mesh);
    let mut volume = 0.0;
    let mut min_edge = f64::INFINITY;
    for block in &mesh.blocks {
        for e in block.elements() {
            let x = hex8_coordinates(mesh, e);
            volume += hex8_volume(&x);
            for (i, j) in HEX_EDGES {
                min_edge = min_edge.min(crate::cell::vec3::distance(x[i], x[j]));
            }
        }
    }
    let [a, b, c] = shape.semi_axes;
    AdherentMeshReport {
        hex8_elements: mesh.num_elements(),
        min_scaled_jacobian: q.min_scaled_jacobian,
        max_edge_ratio: q.max_edge_ratio,
        volume,
        exact_volume: 2.0 / 3.0 * std::f64::consts::PI * a * b * c,
        min_edge,
    }
}

/// The longest of a hex8's 12 edges (corners in `x`).
pub fn longest_edge(x: &[[f64; 3]; 8]) -> f64 {
    HEX_EDGES
        .iter()
        .map(|&(i, j)| crate::cell::vec3::distance(x[i], x[j]))
        .fold(0.0, f64::max)
}

/// The 12 edges of a hex8 by corner index.
pub const HEX_EDGES: [(usize, usize); 12] = [
    (0, 1),
    (1, 2),
    (2, 3),
    (3, 0),
    (4, 5),
    (5, 6),
    (6, 7),
    (7, 4),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

#[cfg(test)]
mod tests {
    use super::*;

    fn shape() -> AdherentShape {
        AdherentShape {
            semi_axes: [19.0, 12.66, 8.0],
            nucleus_semi_axes: [2.5, 2.5, 1.5],
            nucleus_height: 2.0,
        }
    }

    #[test]
    fn mapped_mesh_is_valid_and_fills_the_half_ellipsoid() {
        let res = AdherentMeshResolution {
            core_divisions: 8,
            shell_layers: 3,
            outer_layers: 4,
        };
        let mesh = map_reference_mesh(&res.reference_mesh().unwrap(), &shape());
        let report = mesh_report(&mesh, &shape());
        assert!(
            report.min_scaled_jacobian > 0.09,
            "min scaled Jacobian {}",
            report.min_scaled_jacobian
        );
        // Faceted curved boundary: the volume is slightly below the exact one.
        let rel = report.volume / report.exact_volume - 1.0;
        assert!(rel < 0.0 && rel > -0.03, "volume error {rel}");
        // Every surface node lies on the cell surface: the dome on the ellipsoid, the base
        // at z = 0, and the rim on both.
        for &n in &mesh.node_sets["dome"] {
            assert!((shape().level(mesh.nodes[n]) - 1.0).abs() < 1e-12);
        }
        for &n in &mesh.node_sets["bottom"] {
            assert!(mesh.nodes[n][2].abs() < 1e-12);
            assert!(shape().level(mesh.nodes[n]) <= 1.0 + 1e-12);
        }
        // Nucleus-surface nodes on the nucleus ellipsoid.
        for &n in &mesh.node_sets["nucleus_surface"] {
            let p = mesh.nodes[n];
            let l = (p[0] / 2.5).powi(2) + (p[1] / 2.5).powi(2) + ((p[2] - 2.0) / 1.5).powi(2);
            assert!((l - 1.0).abs() < 1e-12);
        }
        let apex = mesh.node_sets["apex"][0];
        assert!((mesh.nodes[apex][2] - 8.0).abs() < 1e-12);
        // Nucleus volume: (4/3) π 2.5 · 2.5 · 1.5 within the faceting error.
        let block = mesh.block("nucleus").unwrap();
        let v: f64 = block
            .elements()
            .map(|e| {
                cellmech_fem::mesh::generate::quality::hex8_volume(
                    &cellmech_fem::mesh::generate::quality::hex8_coordinates(&mesh, e),
                )
            })
            .sum();
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 2.5 * 2.5 * 1.5;
        assert!(
            (v / exact - 1.0).abs() < 0.03,
            "nucleus volume {v} vs {exact}"
        );
    }

    #[test]
    fn a_nucleus_that_does_not_fit_is_rejected() {
        let mut s = shape();
        s.nucleus_height = 1.0;
        assert!(s.validate().unwrap_err().contains("clear the substrate"));
        let mut s = shape();
        s.nucleus_semi_axes = [12.0, 12.0, 3.0];
        s.nucleus_height = 3.5;
        assert!(s.validate().unwrap_err().contains("fit inside the cell"));
        assert!(shape().validate().is_ok());
    }
}
