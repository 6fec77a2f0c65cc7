//! Cubed-sphere (O-grid) hex8 mesh of a ball, optionally with a concentric inner ball.
//!
//! Layout: a central "cube" of `n × n × n` elements (its faces slightly rounded), six
//! cube-face patches of `n × n` elements extruded radially in `shell_layers` layers out to
//! the sphere of radius `r_in` (the inner radius if given, else the radius), then, with an
//! inner sphere, `outer_layers` spherical layers out to the radius.
//!
//! Every node has a logical key: a point `(i, j, k)` of the integer lattice `[-h, h]³`
//! (`h = n / 2`) and a radial layer `l`. Core nodes have `l = 0`; shell nodes have their
//! lattice point on the cube surface (`max |i|, |j|, |k| = h`) and `l ≥ 0`, so the core's
//! surface nodes and the shell's first layer are the same keys. Positions are a function of
//! the key alone, which makes the mesh conforming with exactly shared nodes.
//!
//! Coordinates along the cube are equi-angular, `tan(π/4 · i/h)`, so the surface grid is the
//! equi-angular cubed sphere. A point of the core at cube level `m` along direction `d` sits at
//! radius `m · ρ₀(d)`, where `ρ₀ = (1 − c)·|cube point| + c·a` blends the flat cube face
//! (`c = 0`) towards the sphere of radius `a` (half-size of the cube) with the rounding
//! [`CORE_ROUNDING`]. Shell layers interpolate the radius linearly from `ρ₀(d)` to `r_in`.

use std::collections::HashMap;
use std::f64::consts::FRAC_PI_4;

use super::quality::HEX8_CORNERS;
use super::{require_at_least, require_positive, require_reasonable_size, GenerateError};
use crate::mesh::{ElementBlock, ElementKind, Mesh};

/// How much the central cube's faces are rounded towards a sphere (0 = flat cube faces).
/// 0.6 balances the core corners against the shell angles at the cube edges: with the
/// default spec the min scaled Jacobian is 0.58 at 0, 0.71 at 0.5, 0.745 at 0.6 (chosen), 0.74 at 0.65, 0.53 at 0.8.
pub const CORE_ROUNDING: f64 = 0.6;

/// Parameters of [`sphere_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct SphereMeshSpec {
    /// Outer radius (µm).
    pub radius: f64,
    /// Radius of a concentric inner sphere; the inner ball becomes block `nucleus` and the
    /// shell block `cytoplasm`. Without it, one block `solid`.
    pub inner_radius: Option<f64>,
    /// Elements along an edge of the central cube, also the divisions of each cube-face
    /// patch. Must be even (so that nodes sit at the poles) and at least 2.
    pub core_divisions: usize,
    /// Radial element layers between the central cube and the (inner) sphere.
    pub shell_layers: usize,
    /// Radial element layers between the inner and the outer sphere (used only with
    /// `inner_radius`).
    pub outer_layers: usize,
    /// Half-size of the central cube relative to the radius of the sphere it sits in.
    pub core_fraction: f64,
}

impl Default for SphereMeshSpec {
    /// A unit ball without inner sphere: 8 core divisions, 3 shell and 3 outer layers,
    /// core fraction 0.5 (1664 elements; 2816 with an inner sphere).
    fn default() -> Self {
        Self {
            radius: 1.0,
            inner_radius: None,
            core_divisions: 8,
            shell_layers: 3,
            outer_layers: 3,
            core_fraction: 0.5,
        }
    }
}

/// Largest accepted core fraction: the rounded cube's corner must stay inside its sphere.
fn max_core_fraction() -> f64 {
    1.0 / ((1.0 - CORE_ROUNDING) * 3f64.sqrt() + CORE_ROUNDING)
}

/// A validated geometry with the radial layout.
struct SphereGeometry {
    /// Half the core divisions.
    h: i64,
    /// Half-size of the central cube.
    a: f64,
    /// Radius of the sphere the cube sits in.
    r_in: f64,
    /// Outer radius.
    r_out: f64,
    /// Layers from the cube to `r_in`.
    shell: usize,
    /// Layers from `r_in` to `r_out` (0 without inner sphere).
    outer: usize,
}

impl SphereGeometry {
    /// Checks the spec and derives the layout.
    fn new(spec: &SphereMeshSpec) -> Result<Self, GenerateError> {
        require_positive("radius", spec.radius)?;
        require_at_least("core_divisions", spec.core_divisions, 2)?;
        if spec.core_divisions & 1 == 1 {
            return Err(GenerateError::OddCoreDivisions {
                found: spec.core_divisions,
            });
        }
        require_at_least("shell_layers", spec.shell_layers, 1)?;
        let r_in = match spec.inner_radius {
            Some(r) if !(r.is_finite() && r > 0.0 && r < spec.radius) => {
                return Err(GenerateError::InnerRadiusOutOfRange {
                    radius: spec.radius,
                    inner_radius: r,
                })
            }
            Some(r) => {
                require_at_least("outer_layers", spec.outer_layers, 1)?;
                r
            }
            None => spec.radius,
        };
        let f = spec.core_fraction;
        if !(f.is_finite() && f > 0.0 && f < max_core_fraction()) {
            return Err(GenerateError::CoreFractionOutOfRange {
                max: max_core_fraction(),
                found: f,
            });
        }
        let outer = if spec.inner_radius.is_some() {
            spec.outer_layers
        } else {
            0
        };
        let n = spec.core_divisions as f64;
        require_reasonable_size(
            (n + 1.0).powi(3) + 6.0 * (n + 1.0).powi(2) * (spec.shell_layers + outer) as f64,
        )?;
        Ok(Self {
            h: (spec.core_divisions / 2) as i64,
            a: f * r_in,
            r_in,
            r_out: spec.radius,
            shell: spec.shell_layers,
            outer,
        })
    }

    /// Index of the last layer (the outer sphere).
    fn last_layer(&self) -> usize {
        self.shell + self.outer
    }

    /// Equi-angular cube coordinate of lattice index `c`, in `[-1, 1]`, exactly odd in `c`.
    fn cube_coordinate(&self, c: i64) -> f64 {
        let t = if c.abs() == self.h {
            1.0
        } else {
            (FRAC_PI_4 * c.abs() as f64 / self.h as f64).tan()
        };
        if c < 0 {
            -t
        } else {
            t
        }
    }

    /// Position of the node with lattice point `key` and layer `layer`.
    fn position(&self, key: [i64; 3], layer: usize) -> [f64; 3] {
        let xi = key.map(|c| self.cube_coordinate(c));
        let level = xi.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if level == 0.0 {
            return [0.0; 3];
        }
        let length = (xi[0] * xi[0] + xi[1] * xi[1] + xi[2] * xi[2]).sqrt();
        let direction = xi.map(|x| x / length);
        let rho_cube = (1.0 - CORE_ROUNDING) * self.a * length / level + CORE_ROUNDING * self.a;
        let rho = if layer == 0 {
            level * rho_cube
        } else if layer < self.shell {
            let s = layer as f64 / self.shell as f64;
            (1.0 - s) * rho_cube + s * self.r_in
        } else if layer == self.shell {
            self.r_in
        } else if layer < self.last_layer() {
            let s = (layer - self.shell) as f64 / self.outer as f64;
            self.r_in + s * (self.r_out - self.r_in)
        } else {
            self.r_out
        };
        direction.map(|d| d * rho)
    }
}

/// Node keys to indices, creating nodes on first use.
struct NodeTable<'g> {
    geometry: &'g SphereGeometry,
    index: HashMap<([i64; 3], usize), usize>,
    nodes: Vec<[f64; 3]>,
    keys: Vec<([i64; 3], usize)>,
}

impl NodeTable<'_> {
    /// Index of the node with this key, created if new.
    fn node(&mut self, key: [i64; 3], layer: usize) -> usize {
        if let Some(&n) = self.index.get(&(key, layer)) {
            return n;
        }
        let n = self.nodes.len();
        self.nodes.push(self.geometry.position(key, layer));
        self.keys.push((key, layer));
        self.index.insert((key, layer), n);
        n
    }
}

/// A cubed-sphere hex8 mesh of a ball of radius `spec.radius` centred at the origin.
///
/// Blocks: `solid`, or `nucleus` (the inner ball) and `cytoplasm` (the shell) when
/// `spec.inner_radius` is given; they are conforming at the inner sphere. Node sets:
/// `surface` (outer sphere), `inner_surface` (inner sphere, if any), `top_pole` and
/// `bottom_pole` (the nodes at (0, 0, ±R)), `axis_z` (nodes with x = y = 0),
/// `equator_x_plus` (the node at (R, 0, 0)) and `all`. Surface nodes lie on their sphere up
/// to rounding; the mesh is symmetric under x → −x, y → −y and z → −z.
pub fn sphere_mesh(spec: &SphereMeshSpec) -> Result<Mesh, GenerateError> {
    let geometry = SphereGeometry::new(spec)?;
    let mut table = NodeTable {
        geometry: &geometry,
        index: HashMap::new(),
        nodes: Vec::new(),
        keys: Vec::new(),
    };
    let mut inner = core_elements(&mut table);
    let mut outer = Vec::new();
    for (axis, sign) in [(0, 1), (0, -1), (1, 1), (1, -1), (2, 1), (2, -1)] {
        patch_elements(&mut table, axis, sign, &mut inner, &mut outer);
    }
    let mut mesh = Mesh {
        nodes: table.nodes,
        ..Mesh::default()
    };
    let hex = |name: &str, connectivity| ElementBlock {
        name: name.to_string(),
        kind: ElementKind::Hex8,
        connectivity,
    };
    if spec.inner_radius.is_some() {
        mesh.blocks.push(hex("nucleus", inner));
        mesh.blocks.push(hex("cytoplasm", outer));
    } else {
        mesh.blocks.push(hex("solid", inner));
    }
    add_sphere_node_sets(&mut mesh, &table.keys, &geometry);
    Ok(mesh)
}

/// Elements of the central cube (layer 0 of the lattice), x index fastest.
fn core_elements(table: &mut NodeTable) -> Vec<usize> {
    let h = table.geometry.h;
    let mut connectivity = Vec::new();
    for k in -h..h {
        for j in -h..h {
            for i in -h..h {
                for c in HEX8_CORNERS {
                    let step = |x: f64| i64::from(x > 0.0);
                    connectivity
                        .push(table.node([i + step(c[0]), j + step(c[1]), k + step(c[2])], 0));
                }
            }
        }
    }
    connectivity
}

/// Elements of the cube-face patch normal to `axis` on side `sign`, all radial layers.
/// Layers inside `r_in` go to `inner`, the others to `outer`. The in-face axes are chosen
/// so that (u, v, outward) is right-handed, which gives positive Jacobians.
fn patch_elements(
    table: &mut NodeTable,
    axis: usize,
    sign: i64,
    inner: &mut Vec<usize>,
    outer: &mut Vec<usize>,
) {
    let g = table.geometry;
    let (h, shell, last) = (g.h, g.shell, g.last_layer());
    let (u_axis, v_axis) = if sign > 0 {
        ((axis + 1) % 3, (axis + 2) % 3)
    } else {
        ((axis + 2) % 3, (axis + 1) % 3)
    };
    let lattice = |u: i64, v: i64| {
        let mut key = [0i64; 3];
        key[axis] = sign * h;
        key[u_axis] = u;
        key[v_axis] = v;
        key
    };
    for layer in 0..last {
        let target = if layer < shell {
            &mut *inner
        } else {
            &mut *outer
        };
        for v in -h..h {
            for u in -h..h {
                for c in HEX8_CORNERS {
                    let step = |x: f64| i64::from(x > 0.0);
                    let key = lattice(u + step(c[0]), v + step(c[1]));
                    target.push(table.node(key, layer + usize::from(c[2] > 0.0)));
                }
            }
        }
    }
}

/// Adds the named node sets of [`sphere_mesh`] from the node keys.
fn add_sphere_node_sets(mesh: &mut Mesh, keys: &[([i64; 3], usize)], g: &SphereGeometry) {
    let select = |pred: &dyn Fn([i64; 3], usize) -> bool| -> Vec<usize> {
        (0..keys.len())
            .filter(|&n| pred(keys[n].0, keys[n].1))
            .collect()
    };
    let (h, last) = (g.h, g.last_layer());
    let on_cube_surface = |k: [i64; 3]| k.iter().any(|c| c.abs() == h);
    mesh.insert_node_set("surface", select(&|k, l| l == last && on_cube_surface(k)));
    if g.outer > 0 {
        let shell = g.shell;
        mesh.insert_node_set(
            "inner_surface",
            select(&|k, l| l == shell && on_cube_surface(k)),
        );
    }
    mesh.insert_node_set("top_pole", select(&|k, l| l == last && k == [0, 0, h]));
    mesh.insert_node_set("bottom_pole", select(&|k, l| l == last && k == [0, 0, -h]));
    mesh.insert_node_set(
        "equator_x_plus",
        select(&|k, l| l == last && k == [h, 0, 0]),
    );
    mesh.insert_node_set("axis_z", select(&|k, _| k[0] == 0 && k[1] == 0));
    mesh.insert_node_set("all", (0..keys.len()).collect());
}

#[cfg(test)]
mod tests {
    use std::collections::{BTreeSet, HashMap};
    use std::f64::consts::PI;

    use super::super::quality::{hex8_face_uses, hex8_quality, MeshQuality};
    use super::super::{boundary_faces, hex8_quality as quality_of};
    use super::*;

    fn radius_of(p: [f64; 3]) -> f64 {
        (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
    }

    fn spec(n: usize, shell: usize, outer: usize, inner: Option<f64>) -> SphereMeshSpec {
        SphereMeshSpec {
            radius: 16.132,
            inner_radius: inner,
            core_divisions: n,
            shell_layers: shell,
            outer_layers: outer,
            core_fraction: 0.5,
        }
    }

    /// Quantised coordinates, for looking nodes up by position.
    fn grid_key(p: [f64; 3], scale: f64) -> [i64; 3] {
        p.map(|x| (x / scale * 1e9).round() as i64)
    }

    fn block_quality(mesh: &Mesh, name: &str) -> MeshQuality {
        let block = mesh.block(name).unwrap().clone();
        quality_of(&Mesh {
            nodes: mesh.nodes.clone(),
            blocks: vec![block],
            ..Mesh::default()
        })
    }

    #[test]
    fn default_sphere_is_conforming_closed_and_on_the_sphere() {
        let mesh = sphere_mesh(&SphereMeshSpec::default()).unwrap();
        mesh.validate().unwrap();
        assert_eq!(mesh.num_elements(), 8 * 8 * 8 + 6 * 8 * 8 * 3);
        assert_eq!(mesh.num_nodes(), 9 * 9 * 9 + (6 * 8 * 8 + 2) * 3);
        assert_eq!(mesh.blocks.len(), 1);
        assert_eq!(mesh.blocks[0].name, "solid");
        let uses = hex8_face_uses(&mesh);
        assert!(
            uses.values().all(|&(_, n)| n == 1 || n == 2),
            "a face has > 2 elements"
        );
        let faces = boundary_faces(&mesh);
        assert_eq!(
            faces.len(),
            6 * 8 * 8,
            "closed surface of the 6 cube-face patches"
        );
        let on_boundary: BTreeSet<usize> = faces.iter().flatten().cloned().collect();
        assert_eq!(
            on_boundary.iter().cloned().collect::<Vec<_>>(),
            mesh.node_sets["surface"]
        );
        for &n in &on_boundary {
            assert!(
                (radius_of(mesh.nodes[n]) - 1.0).abs() < 1e-14,
                "node {n} off the sphere"
            );
        }
        // Boundary faces are oriented outwards: their normal points away from the centre.
        for f in &faces {
            let [a, b, _, d] = f.map(|n| mesh.nodes[n]);
            let (e1, e2) = (
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [d[0] - a[0], d[1] - a[1], d[2] - a[2]],
            );
            let normal = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            assert!(normal[0] * a[0] + normal[1] * a[1] + normal[2] * a[2] > 0.0);
        }
        // No duplicate nodes: all positions distinct.
        let positions: BTreeSet<[i64; 3]> = mesh.nodes.iter().map(|&p| grid_key(p, 1.0)).collect();
        assert_eq!(positions.len(), mesh.num_nodes());
    }

    #[test]
    fn element_quality_is_good() {
        for inner in [None, Some(6.45)] {
            let mesh = sphere_mesh(&spec(8, 3, 3, inner)).unwrap();
            let q = hex8_quality(&mesh);
            eprintln!(
                "sphere n=8 inner={inner:?}: {} elements, min scaled Jacobian {:.3}, max edge ratio {:.2}",
                q.elements, q.min_scaled_jacobian, q.max_edge_ratio
            );
            assert!(q.min_gauss_jacobian > 0.0);
            assert!(
                q.min_scaled_jacobian > 0.7,
                "min scaled Jacobian {}",
                q.min_scaled_jacobian
            );
            assert!(
                q.max_edge_ratio < 4.0,
                "max edge ratio {}",
                q.max_edge_ratio
            );
        }
        let fine = hex8_quality(&sphere_mesh(&spec(16, 6, 6, Some(6.45))).unwrap());
        assert!(fine.min_gauss_jacobian > 0.0 && fine.min_scaled_jacobian > 0.7);
    }

    #[test]
    fn volume_converges_at_second_order() {
        let exact = 4.0 / 3.0 * PI * 16.132f64.powi(3);
        let exact_nucleus = 4.0 / 3.0 * PI * 6.45f64.powi(3);
        let mut errors = Vec::new();
        let mut nucleus_errors = Vec::new();
        for n in [4, 8, 16] {
            let mesh = sphere_mesh(&spec(n, n / 2, n / 2, Some(6.45))).unwrap();
            let total = hex8_quality(&mesh).volume;
            let nucleus = block_quality(&mesh, "nucleus").volume;
            errors.push((exact - total).abs() / exact);
            nucleus_errors.push((exact_nucleus - nucleus).abs() / exact_nucleus);
        }
        eprintln!("relative volume errors {errors:?}, nucleus {nucleus_errors:?}");
        for e in [&errors, &nucleus_errors] {
            let rate = [(e[0] / e[1]).log2(), (e[1] / e[2]).log2()];
            assert!(rate.iter().all(|&r| r > 1.8 && r < 2.3), "rates {rate:?}");
            assert!(e[2] < 0.01);
        }
    }

    #[test]
    fn inner_sphere_is_conforming_with_named_blocks() {
        let mesh = sphere_mesh(&spec(6, 2, 3, Some(6.45))).unwrap();
        let names: Vec<&str> = mesh.blocks.iter().map(|b| b.name.as_str()).collect();
        assert_eq!(names, ["nucleus", "cytoplasm"]);
        assert_eq!(mesh.block("nucleus").unwrap().len(), 216 + 6 * 36 * 2);
        assert_eq!(mesh.block("cytoplasm").unwrap().len(), 6 * 36 * 3);
        let inner = &mesh.node_sets["inner_surface"];
        assert_eq!(inner.len(), 6 * 36 + 2);
        assert!(inner
            .iter()
            .all(|&n| (radius_of(mesh.nodes[n]) - 6.45).abs() < 1e-13));
        // The nucleus boundary is exactly the inner surface, and each of its faces is shared
        // with one cytoplasm element (conforming interface).
        let nucleus = Mesh {
            nodes: mesh.nodes.clone(),
            blocks: vec![mesh.block("nucleus").unwrap().clone()],
            ..Mesh::default()
        };
        let interface = boundary_faces(&nucleus);
        let interface_nodes: BTreeSet<usize> = interface.iter().flatten().cloned().collect();
        assert_eq!(interface_nodes.into_iter().collect::<Vec<_>>(), *inner);
        let uses = hex8_face_uses(&mesh);
        for f in &interface {
            let mut key = *f;
            key.sort_unstable();
            assert_eq!(uses[&key].1, 2);
        }
        let outer = &mesh.node_sets["surface"];
        assert!(outer
            .iter()
            .all(|&n| (radius_of(mesh.nodes[n]) - 16.132).abs() < 1e-13));
        assert!(inner.iter().all(|n| !outer.contains(n)));
    }

    #[test]
    fn poles_axis_and_equator_sets() {
        let r = 16.132;
        let mesh = sphere_mesh(&spec(8, 3, 2, Some(6.45))).unwrap();
        let single = |name: &str| {
            let set = &mesh.node_sets[name];
            assert_eq!(set.len(), 1, "{name}");
            mesh.nodes[set[0]]
        };
        assert_eq!(single("top_pole"), [0.0, 0.0, r]);
        assert_eq!(single("bottom_pole"), [0.0, 0.0, -r]);
        assert_eq!(single("equator_x_plus"), [r, 0.0, 0.0]);
        let axis = &mesh.node_sets["axis_z"];
        assert_eq!(*axis, mesh.select_nodes(|p| p[0] == 0.0 && p[1] == 0.0));
        // Core column of 9 nodes plus 2 × 5 shell layers above and below.
        assert_eq!(axis.len(), 9 + 2 * 5);
        assert_eq!(mesh.node_sets["all"].len(), mesh.num_nodes());
    }

    #[test]
    fn mesh_is_mirror_symmetric() {
        let mesh = sphere_mesh(&spec(6, 2, 2, Some(6.45))).unwrap();
        let lookup: HashMap<[i64; 3], usize> = mesh
            .nodes
            .iter()
            .enumerate()
            .map(|(n, &p)| (grid_key(p, 16.132), n))
            .collect();
        for axis in 0..3 {
            let mirror: Vec<usize> = mesh
                .nodes
                .iter()
                .map(|&p| {
                    let mut q = p;
                    q[axis] = -q[axis];
                    lookup[&grid_key(q, 16.132)]
                })
                .collect();
            for (name, set) in &mesh.node_sets {
                let mut image: Vec<usize> = set.iter().map(|&n| mirror[n]).collect();
                image.sort_unstable();
                let expected = match (name.as_str(), axis) {
                    ("top_pole", 2) => &mesh.node_sets["bottom_pole"],
                    ("bottom_pole", 2) => &mesh.node_sets["top_pole"],
                    ("equator_x_plus", 0) => {
                        assert_eq!(mesh.nodes[image[0]], [-16.132, 0.0, 0.0]);
                        continue;
                    }
                    _ => set,
                };
                assert_eq!(image, *expected, "set {name} under mirror of axis {axis}");
            }
            // Elements map onto elements.
            let elements: BTreeSet<Vec<usize>> = mesh
                .blocks
                .iter()
                .flat_map(|b| {
                    b.elements().map(|e| {
                        let mut v = e.to_vec();
                        v.sort_unstable();
                        v
                    })
                })
                .collect();
            for e in &elements {
                let mut image: Vec<usize> = e.iter().map(|&n| mirror[n]).collect();
                image.sort_unstable();
                assert!(elements.contains(&image));
            }
        }
    }

    #[test]
    fn invalid_specs_are_rejected_with_clear_errors() {
        let odd = sphere_mesh(&spec(7, 2, 2, None)).unwrap_err();
        assert_eq!(odd, GenerateError::OddCoreDivisions { found: 7 });
        assert!(odd.to_string().contains("even core_divisions"));
        let err = sphere_mesh(&spec(8, 2, 2, Some(20.0))).unwrap_err();
        assert!(
            matches!(err, GenerateError::InnerRadiusOutOfRange { .. }),
            "{err}"
        );
        let err = sphere_mesh(&spec(8, 0, 2, None)).unwrap_err();
        assert!(
            err.to_string()
                .contains("shell_layers to be at least 1; found 0"),
            "{err}"
        );
        let err = sphere_mesh(&spec(8, 2, 0, Some(5.0))).unwrap_err();
        assert!(err.to_string().contains("outer_layers"), "{err}");
        assert!(
            sphere_mesh(&spec(8, 2, 0, None)).is_ok(),
            "outer_layers unused without inner"
        );
        let err = sphere_mesh(&SphereMeshSpec {
            core_fraction: 0.9,
            ..Default::default()
        });
        assert!(matches!(
            err,
            Err(GenerateError::CoreFractionOutOfRange { .. })
        ));
        let err = sphere_mesh(&SphereMeshSpec {
            radius: -1.0,
            ..Default::default()
        });
        assert!(matches!(err, Err(GenerateError::NotPositive { .. })));
        let err = sphere_mesh(&SphereMeshSpec {
            core_divisions: 100_000,
            ..Default::default()
        });
        assert!(matches!(err, Err(GenerateError::TooLarge { .. })));
    }
}
