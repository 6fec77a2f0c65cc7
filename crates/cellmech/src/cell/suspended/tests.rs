//! Tests of the suspended-cell geometry. Each asserts a property that a wrong geometry
//! would break; the measured numbers are printed with `--nocapture`.

use std::collections::{BTreeMap, BTreeSet};

use cellmech_fem::mesh::generate::hex8_quality;

use super::cytoskeleton::{polyline_distance_to_origin, segment_distance_to_origin};
use super::*;
use crate::cell::vec3::{distance, dot, norm, sub};

const R: f64 = 16.132;
const R_N: f64 = 6.45;

/// The FA pattern itself: every FA one node, no plaque (the defaults before 2026-12-07,
/// `fa_radius = "0 um"`). The FA node is then where the filaments end, which the pattern
/// tests below check; the default plaques are tested at the end of this file.
fn single_node_fas() -> SuspendedCellParams {
    use crate::cell::fa_plaque::{FaCoupling, FaReference};
    SuspendedCellParams {
        fa_radius: 0.0,
        fa_coupling: FaCoupling::Rigid,
        fa_reference: FaReference::FaNode,
        ..SuspendedCellParams::default()
    }
}

fn single_node_geometry() -> SuspendedCellGeometry {
    SuspendedCellGeometry::build(&single_node_fas()).unwrap()
}

fn print_report(label: &str, g: &SuspendedCellGeometry) {
    eprintln!("{label}: {:#?}", g.report);
}

#[test]
fn default_geometry_has_30_distinct_fa_nodes_on_the_sphere() {
    let g = single_node_geometry();
    print_report("default", &g);
    assert_eq!(g.report.hex8_elements, 6912);
    assert_eq!(g.report.hex8_elements, MeshResolution::default().elements());
    assert_eq!(g.fa_nodes.len(), 30);
    let distinct: BTreeSet<usize> = g.fa_nodes.iter().cloned().collect();
    assert_eq!(distinct.len(), 30);
    let surface = &g.mesh.node_sets["surface"];
    let sites = icosidodecahedron_unit_vertices();
    for (k, &n) in g.fa_nodes.iter().enumerate() {
        assert!(
            surface.binary_search(&n).is_ok(),
            "FA {k} not a surface node"
        );
        let p = g.mesh.nodes[n];
        assert!((norm(p) - R).abs() < 1e-12, "FA {k} at radius {}", norm(p));
        // Symmetric orientation: the FA is the canonical vertex scaled to R.
        assert!(distance(p, sites[k].map(|c| c * R)) < 1e-12);
        assert_eq!(g.mesh.node_sets[&format!("fa_{k}")], vec![n]);
    }
    let mut sorted = g.fa_nodes.clone();
    sorted.sort_unstable();
    assert_eq!(g.mesh.node_sets["focal_adhesions"], sorted);
    g.mesh.validate().unwrap();
}

#[test]
fn af_edges_are_60_equal_edges_of_length_r_over_phi_with_degree_4() {
    let g = single_node_geometry();
    assert_eq!(g.af_edges.len(), 60);
    let mut degree: BTreeMap<usize, usize> = BTreeMap::new();
    let unique: BTreeSet<[usize; 2]> = g.af_edges.iter().cloned().collect();
    assert_eq!(unique.len(), 60);
    for &[a, b] in &g.af_edges {
        *degree.entry(a).or_default() += 1;
        *degree.entry(b).or_default() += 1;
        let length = distance(g.mesh.nodes[a], g.mesh.nodes[b]);
        assert!(
            (length - R / GOLDEN_RATIO).abs() < 1e-12,
            "AF length {length}"
        );
        assert!((length - g.report.af_length).abs() < 1e-12);
    }
    assert_eq!(degree.len(), 30);
    assert!(degree.values().all(|&d| d == 4), "{degree:?}");
    // The edge is R/φ ≈ 9.97 µm, not R (that would be the cuboctahedron).
    assert!((g.report.af_length - 9.970).abs() < 1e-3);
}

#[test]
fn snapping_keeps_positive_jacobians_and_moves_nodes_by_a_fraction_of_an_element() {
    for (label, mesh) in [
        ("default", MeshResolution::default()),
        ("fast", MeshResolution::fast()),
        ("fine", MeshResolution::fine()),
    ] {
        let params = SuspendedCellParams {
            mesh,
            ..single_node_fas()
        };
        let g = SuspendedCellGeometry::build(&params).unwrap();
        print_report(label, &g);
        let q = hex8_quality(&g.mesh);
        eprintln!("{label}: whole mesh {q:?}");
        assert_eq!(q.elements, mesh.elements());
        assert!(q.min_gauss_jacobian > 0.0);
        assert!(g.report.min_gauss_jacobian_after_snap > 0.0);
        assert!(g.report.max_relative_snap_distance < 0.5);
        assert!(g.report.min_scaled_jacobian_after_snap > 0.5);
        // Volume of the cell is still close to 4/3 π R³ (the snap moved nodes on the sphere).
        let exact = 4.0 / 3.0 * std::f64::consts::PI * R.powi(3);
        assert!((q.volume - exact).abs() / exact < 0.02);
    }
}

#[test]
fn symmetric_orientation_snaps_axis_fas_exactly_and_the_other_24_equally() {
    let params = single_node_fas();
    let res = params.mesh;
    let unsnapped =
        cellmech_fem::mesh::generate::sphere_mesh(&cellmech_fem::mesh::generate::SphereMeshSpec {
            radius: R,
            inner_radius: Some(R_N),
            core_divisions: res.core_divisions,
            shell_layers: res.shell_layers,
            outer_layers: res.outer_layers,
            core_fraction: res.core_fraction,
        })
        .unwrap();
    let g = SuspendedCellGeometry::build(&params).unwrap();
    let moves: Vec<f64> = g
        .fa_nodes
        .iter()
        .map(|&n| distance(g.mesh.nodes[n], unsnapped.nodes[n]))
        .collect();
    assert!(moves[..6].iter().all(|&d| d < 1e-12), "{moves:?}");
    for d in &moves[6..] {
        assert!((d - moves[6]).abs() < 1e-9, "{moves:?}");
    }
    assert!((moves[6] - g.report.max_snap_distance).abs() < 1e-12);
    assert!(moves[6] > 0.1);
    // Nucleus surface untouched.
    for &n in &g.mesh.node_sets["inner_surface"] {
        assert_eq!(g.mesh.nodes[n], unsnapped.nodes[n]);
    }
}

#[test]
fn optimized_orientation_is_no_worse_than_symmetric_and_seeded() {
    let symmetric = single_node_geometry();
    let params = SuspendedCellParams {
        fa_orientation: FaOrientation::Optimized { trials: 200 },
        ..single_node_fas()
    };
    let g = SuspendedCellGeometry::build(&params).unwrap();
    print_report("optimized", &g);
    assert!(
        g.report.max_relative_snap_distance <= symmetric.report.max_relative_snap_distance + 1e-12
    );
    for &n in &g.fa_nodes {
        assert!((norm(g.mesh.nodes[n]) - R).abs() < 1e-12);
    }
    assert!(hex8_quality(&g.mesh).min_gauss_jacobian > 0.0);
    assert_eq!(g, SuspendedCellGeometry::build(&params).unwrap());
    let fine = |fa_orientation| {
        SuspendedCellGeometry::build(&SuspendedCellParams {
            mesh: MeshResolution::fine(),
            fa_orientation,
            ..single_node_fas()
        })
        .unwrap()
    };
    let (sym, opt) = (
        fine(FaOrientation::Symmetric),
        fine(FaOrientation::Optimized { trials: 200 }),
    );
    print_report("fine optimized", &opt);
    assert!(opt.report.max_relative_snap_distance <= sym.report.max_relative_snap_distance + 1e-12);
    assert!(hex8_quality(&opt.mesh).min_gauss_jacobian > 0.0);
}

#[test]
fn microtubules_run_from_the_centrosome_to_each_fa_and_clear_the_nucleus() {
    let params = single_node_fas();
    let g = single_node_geometry();
    assert_eq!(g.microtubules.len(), 30);
    let c = params.centrosome();
    assert!((norm(c) - (R_N + 0.75)).abs() < 1e-12);
    let mut chords_through_nucleus = 0;
    for (k, mt) in g.microtubules.iter().enumerate() {
        assert_eq!(mt.fa_node, g.fa_nodes[k]);
        assert_eq!(mt.elements(), 8);
        assert_eq!(mt.points[0], c);
        assert_eq!(*mt.points.last().unwrap(), g.mesh.nodes[mt.fa_node]);
        let clearance = polyline_distance_to_origin(&mt.points) - R_N;
        assert!(clearance >= 0.25, "MT {k} clearance {clearance}");
        assert!(clearance >= g.report.min_mt_clearance - 1e-12);
        for p in &mt.points {
            assert!(norm(*p) <= R + 1e-12, "MT {k} leaves the cell");
        }
        if segment_distance_to_origin(c, g.mesh.nodes[mt.fa_node]) < R_N {
            chords_through_nucleus += 1;
        }
        assert!(mt.length() > mt.chord(), "MT {k} is straight");
        assert!(mt.max_curvature() > 0.0);
        for (t, w) in mt.segment_normals().iter().zip(mt.points.windows(2)) {
            assert!((norm(*t) - 1.0).abs() < 1e-12);
            assert!(dot(*t, sub(w[1], w[0])).abs() < 1e-9);
        }
    }
    // The test is meaningful: many straight chords would cross the nucleus.
    eprintln!("straight chords through the nucleus: {chords_through_nucleus} of 30");
    assert!(chords_through_nucleus >= 10);
    let (lo, hi) = g.report.mt_curvature_range;
    assert!(hi > 1.5 * lo, "curvatures do not vary: {lo}..{hi}");
    let bows: Vec<f64> = g.microtubules.iter().map(|m| m.bow.abs()).collect();
    assert!(bows.iter().all(|&b| (0.05..=0.20).contains(&b)));
    assert!(
        g.microtubules.iter().any(|m| m.bow > 0.0) && g.microtubules.iter().any(|m| m.bow < 0.0)
    );
}

#[test]
fn microtubule_nodes_are_appended_as_chains() {
    let g = single_node_geometry();
    let mut mesh = g.mesh.clone();
    let before = mesh.num_nodes();
    let chains = g.append_microtubule_nodes(&mut mesh);
    assert_eq!(mesh.num_nodes(), before + 1 + 30 * 7);
    assert_eq!(mesh.node_sets["centrosome"], vec![before]);
    assert_eq!(chains.len(), 30);
    for (mt, chain) in g.microtubules.iter().zip(&chains) {
        assert_eq!(chain.len(), 9);
        assert_eq!(chain[0], before);
        assert_eq!(*chain.last().unwrap(), mt.fa_node);
        for (&n, p) in chain.iter().zip(&mt.points) {
            assert_eq!(mesh.nodes[n], *p);
        }
    }
    let interior: BTreeSet<usize> = chains.iter().flat_map(|c| c[1..8].to_vec()).collect();
    assert_eq!(interior.len(), 30 * 7);
    mesh.validate().unwrap();
}

#[test]
fn intermediate_filaments_are_tangent_to_the_nucleus_and_anchored_on_distinct_nodes() {
    for rule in [IfAnchorRule::Nearest, IfAnchorRule::NearestVisible] {
        let mut previous_error = f64::INFINITY;
        for (label, mesh) in [
            ("default", MeshResolution::default()),
            ("fine", MeshResolution::fine()),
        ] {
            let params = SuspendedCellParams {
                mesh,
                if_anchor_rule: rule,
                ..single_node_fas()
            };
            let g = SuspendedCellGeometry::build(&params).unwrap();
            assert_eq!(g.intermediate_filaments.len(), 60);
            let inner = &g.mesh.node_sets["inner_surface"];
            let mut worst: f64 = 0.0;
            let mut depth: f64 = 0.0;
            for (i, &[fa, anchor]) in g.intermediate_filaments.iter().enumerate() {
                assert_eq!(fa, g.fa_nodes[i / 2]);
                assert!(inner.binary_search(&anchor).is_ok());
                let (f, a) = (g.mesh.nodes[fa], g.mesh.nodes[anchor]);
                let angle = if_radius_angle_deg(f, a);
                worst = worst.max((angle - 90.0).abs());
                depth = depth.max(R_N - segment_distance_to_origin(f, a));
                if rule == IfAnchorRule::NearestVisible {
                    // Visible anchor: the IF leaves the nucleus outwards (angle ≤ 90°) and
                    // never enters it.
                    assert!(angle <= 90.0 + 1e-9, "IF {i}: angle {angle}");
                    assert!(segment_distance_to_origin(f, a) >= R_N * (1.0 - 1e-9));
                }
            }
            let anchors: BTreeSet<usize> = g.intermediate_filaments.iter().map(|f| f[1]).collect();
            assert_eq!(anchors.len(), 60, "{label}: anchors shared");
            assert_eq!(g.report.shared_if_anchors, 0);
            assert!((worst - g.report.max_if_tangency_error_deg).abs() < 1e-9);
            assert!((depth.max(0.0) - g.report.max_if_nucleus_penetration).abs() < 1e-12);
            eprintln!(
                "{rule:?} {label}: IF anchor error max {:.3} mean {:.3} µm, tangency error \
                 {worst:.2}°, penetration {:.4} µm",
                g.report.max_if_anchor_error,
                g.report.mean_if_anchor_error,
                g.report.max_if_nucleus_penetration
            );
            // Anchor error: at most one nucleus-surface element (≈ 1.3 µm default, 0.65 µm
            // fine) beyond the unconstrained nearest-node distance (the price of distinct
            // and, for NearestVisible, visible anchors), and it shrinks with the mesh.
            let spacing = R_N * std::f64::consts::FRAC_PI_2 / mesh.core_divisions as f64;
            let mut nearest: f64 = 0.0;
            for &fa in &g.fa_nodes {
                for t in super::cytoskeleton::tangent_points(g.mesh.nodes[fa], R_N, 2, 0.0) {
                    let d = inner
                        .iter()
                        .map(|&n| distance(g.mesh.nodes[n], t))
                        .fold(f64::INFINITY, f64::min);
                    nearest = nearest.max(d);
                }
            }
            eprintln!("{label}: unconstrained nearest-node distance max {nearest:.3} µm");
            assert!(nearest < 0.75 * spacing);
            assert!(g.report.max_if_anchor_error >= nearest - 1e-12);
            assert!(
                g.report.max_if_anchor_error < nearest + 1.5 * spacing,
                "{label} {rule:?}"
            );
            assert!(g.report.max_if_anchor_error < previous_error);
            previous_error = g.report.max_if_anchor_error;
            // Tangency within the snapping error: |angle − 90°| ≲ anchor error / r_n.
            let bound = (2.0 * g.report.max_if_anchor_error / R_N).to_degrees();
            assert!(
                worst < bound,
                "{label} {rule:?}: {worst}° vs bound {bound}°"
            );
        }
    }
}

#[test]
fn ifs_per_fa_sets_the_count_and_the_spacing_on_the_tangent_circle() {
    for m in [1, 3] {
        let g = SuspendedCellGeometry::build(&SuspendedCellParams {
            ifs_per_fa: m,
            ..single_node_fas()
        })
        .unwrap();
        assert_eq!(g.intermediate_filaments.len(), 30 * m);
        for (i, f) in g.intermediate_filaments.iter().enumerate() {
            assert_eq!(f[0], g.fa_nodes[i / m]);
        }
    }
}

#[test]
fn same_seed_gives_identical_geometry_and_another_seed_other_curvatures() {
    let a = single_node_geometry();
    let b = single_node_geometry();
    assert_eq!(a, b);
    let c = SuspendedCellGeometry::build(&SuspendedCellParams {
        seed: 7,
        ..single_node_fas()
    })
    .unwrap();
    assert_eq!(
        a.mesh, c.mesh,
        "symmetric orientation does not use the seed"
    );
    let bows = |g: &SuspendedCellGeometry| g.microtubules.iter().map(|m| m.bow).collect::<Vec<_>>();
    assert_ne!(bows(&a), bows(&c));
    assert_ne!(a.report.mt_curvature_range, c.report.mt_curvature_range);
    // A fixed bow (min = max) leaves only the sides to the seed.
    let fixed = |seed| {
        SuspendedCellGeometry::build(&SuspendedCellParams {
            seed,
            mt_bow_min: 0.1,
            mt_bow_max: 0.1,
            ..single_node_fas()
        })
        .unwrap()
    };
    assert!(bows(&fixed(1))
        .iter()
        .all(|b| (b.abs() - 0.1).abs() < 1e-15));
}

#[test]
fn invalid_parameters_are_rejected_with_clear_errors() {
    let base = single_node_fas();
    let check = |p: SuspendedCellParams, needle: &str| {
        let err = SuspendedCellGeometry::build(&p).unwrap_err();
        assert!(err.to_string().contains(needle), "{err}");
        err
    };
    let e = check(
        SuspendedCellParams {
            nucleus_diameter: 40.0,
            ..base.clone()
        },
        "smaller than the cell diameter",
    );
    assert!(matches!(e, CellGeometryError::NucleusNotInsideCell { .. }));
    check(
        SuspendedCellParams {
            nucleus_diameter: base.cell_diameter,
            ..base.clone()
        },
        "found 32.264",
    );
    let e = check(
        SuspendedCellParams {
            ifs_per_fa: 0,
            ..base.clone()
        },
        "at least 1 intermediate filament",
    );
    assert_eq!(e, CellGeometryError::TooFewIfsPerFa { found: 0 });
    check(
        SuspendedCellParams {
            centrosome_gap: -0.5,
            ..base.clone()
        },
        "centrosome_gap to be a positive",
    );
    let e = check(
        SuspendedCellParams {
            centrosome_gap: 10.0,
            ..base.clone()
        },
        "inside the cell",
    );
    assert!(matches!(e, CellGeometryError::CentrosomeOutsideCell { .. }));
    check(
        SuspendedCellParams {
            cell_diameter: f64::NAN,
            ..base.clone()
        },
        "cell_diameter",
    );
    check(
        SuspendedCellParams {
            nucleus_diameter: 0.0,
            ..base.clone()
        },
        "nucleus_diameter",
    );
    check(
        SuspendedCellParams {
            mt_elements: 1,
            ..base.clone()
        },
        "mt_elements between 2 and 1000; found 1",
    );
    check(
        SuspendedCellParams {
            mt_bow_min: 0.3,
            mt_bow_max: 0.2,
            ..base.clone()
        },
        "mt_bow_min = 0.3",
    );
    check(
        SuspendedCellParams {
            mt_clearance_margin: 1.0,
            ..base.clone()
        },
        "mt_clearance_margin",
    );
    check(
        SuspendedCellParams {
            centrosome_direction: [0.0; 3],
            ..base.clone()
        },
        "centrosome_direction",
    );
    check(
        SuspendedCellParams {
            ifs_per_fa: 1000,
            ..base.clone()
        },
        "ifs_per_fa between 1 and 64",
    );
    let e = check(
        SuspendedCellParams {
            mesh: MeshResolution {
                core_divisions: 7,
                ..MeshResolution::default()
            },
            ..base.clone()
        },
        "even core_divisions",
    );
    assert!(matches!(e, CellGeometryError::Mesh(_)));
    // 26 surface nodes cannot carry 30 FAs.
    let e = check(
        SuspendedCellParams {
            mesh: MeshResolution {
                core_divisions: 2,
                shell_layers: 1,
                outer_layers: 1,
                core_fraction: 0.5,
            },
            ..base.clone()
        },
        "snap to node",
    );
    assert!(matches!(e, CellGeometryError::FaSnapCollision { .. }));
}

#[test]
fn centrosome_direction_towards_an_fa_or_its_antipode_still_routes() {
    // The first canonical vertex is +z: MT 0 is radial (θ = 0), MT 1 antipodal (θ = π).
    let g = SuspendedCellGeometry::build(&SuspendedCellParams {
        centrosome_direction: [0.0, 0.0, 1.0],
        ..single_node_fas()
    })
    .unwrap();
    assert!(g.report.min_mt_clearance >= 0.25);
    for mt in &g.microtubules[..2] {
        assert!(mt.length() > mt.chord());
        assert!(polyline_distance_to_origin(&mt.points) > R_N + 0.25);
    }
}

#[test]
fn pole_refinement_splits_only_near_the_poles_and_keeps_the_fas_and_the_sphere() {
    let base = single_node_geometry();
    let g = SuspendedCellGeometry::build(&SuspendedCellParams {
        pole_refinement: PoleRefinement {
            levels: 1,
            radius: 8.0,
        },
        ..single_node_fas()
    })
    .unwrap();
    g.mesh.validate().unwrap();
    let n0 = base.mesh.num_nodes();
    // The base nodes keep their indices and positions, so every filament is unchanged.
    assert_eq!(&g.mesh.nodes[..n0], &base.mesh.nodes[..]);
    assert_eq!(g.fa_nodes, base.fa_nodes);
    assert_eq!(g.af_edges, base.af_edges);
    assert_eq!(g.intermediate_filaments, base.intermediate_filaments);
    let elements = g.mesh.num_elements();
    assert!(
        elements > base.mesh.num_elements() + 7 * 20 && elements < 2 * base.mesh.num_elements(),
        "{elements} hex8"
    );
    assert!(!g.hanging.is_empty());
    // Every new node lies near a pole; the new surface nodes that do not hang lie on the
    // sphere, the hanging ones on their coarse edge or face (inside it).
    let hanging: BTreeSet<usize> = g.hanging.iter().map(|h| h.node).collect();
    let surface: BTreeSet<usize> = g.mesh.node_sets["surface"].iter().copied().collect();
    let mut on_sphere = 0;
    for n in n0..g.mesh.num_nodes() {
        let p = g.mesh.nodes[n];
        let to_pole = distance(p, [R, 0.0, 0.0]).min(distance(p, [-R, 0.0, 0.0]));
        // Within the radius plus one split element (the 2:1 balance may reach a little
        // further; 6 µm is two surface elements of the default mesh).
        assert!(
            to_pole < 8.0 + 6.0,
            "node {n} at {p:?}, {to_pole} µm from a pole"
        );
        if surface.contains(&n) && !hanging.contains(&n) {
            assert!((norm(p) - R).abs() < 1e-9, "node {n} at radius {}", norm(p));
            on_sphere += 1;
        }
        if hanging.contains(&n) {
            assert!(norm(p) < R + 1e-9);
        }
    }
    assert!(
        on_sphere > 20,
        "{on_sphere} new surface nodes on the sphere"
    );
    // The outer faces: each refined surface face is replaced by four, none repeated, and
    // every one has its nodes on the surface.
    let faces: BTreeSet<[usize; 4]> = g
        .boundary_faces
        .iter()
        .map(|f| {
            let mut s = *f;
            s.sort_unstable();
            s
        })
        .collect();
    assert_eq!(faces.len(), g.boundary_faces.len());
    assert!(g
        .boundary_faces
        .iter()
        .all(|f| f.iter().all(|n| surface.contains(n))));
    let base_faces = cellmech_fem::mesh::generate::boundary_faces(&base.mesh).len();
    assert_eq!((g.boundary_faces.len() - base_faces) % 3, 0);
    assert!(g.boundary_faces.len() > base_faces);
    // Levels off: the mesh is unchanged and conforming (no faces listed, no ties).
    assert!(base.hanging.is_empty() && base.boundary_faces.is_empty());
    let q = hex8_quality(&g.mesh);
    assert!(q.min_scaled_jacobian > 0.0, "{q:?}");
}

#[test]
fn pole_refinement_out_of_range_is_a_clear_error() {
    for (levels, radius, want) in [(4, 8.0, "refinement.levels"), (1, 0.0, "refinement.radius")] {
        let e = SuspendedCellGeometry::build(&SuspendedCellParams {
            pole_refinement: PoleRefinement { levels, radius },
            ..single_node_fas()
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains(want), "{e}");
    }
}

/// Area of a quad (half the cross product of its diagonals, exact for a flat one) and
/// whether it points away from the cell centre.
fn quad_area_and_outward(nodes: &[[f64; 3]], f: &[usize; 4]) -> (f64, bool) {
    let p = f.map(|n| nodes[n]);
    let n = crate::cell::vec3::cross(sub(p[2], p[0]), sub(p[3], p[1]));
    let centre: [f64; 3] = std::array::from_fn(|k| p.iter().map(|q| q[k]).sum::<f64>() / 4.0);
    (0.5 * norm(n), dot(n, centre) > 0.0)
}

#[test]
fn a_refined_cell_ties_its_hanging_nodes_and_its_membrane_covers_the_sphere_once() {
    // Coarse CI mesh refined once everywhere: every outer face is split in four.
    let coarse = MeshResolution {
        core_divisions: 4,
        shell_layers: 2,
        outer_layers: 2,
        core_fraction: 0.5,
    };
    let cell = |levels: u8| {
        let mut c = SuspendedCell {
            params: single_node_fas(),
            ..SuspendedCell::default()
        };
        c.params.mesh = coarse;
        c.params.pole_refinement = PoleRefinement {
            levels,
            radius: 100.0,
        };
        c.build().unwrap()
    };
    let (base, refined) = (cell(0), cell(1));
    assert!(base.model.hanging.is_empty());
    // Refined everywhere: no hanging node at all (every leaf has the same level).
    assert!(refined.model.hanging.is_empty());
    assert_eq!(refined.model.mesh.num_elements(), 8 * 448);
    let area = |b: &crate::cell::BuiltCell| {
        let nodes = &b.model.mesh.nodes;
        let mut total = 0.0;
        for f in &b.surface_faces {
            let (a, outward) = quad_area_and_outward(nodes, f);
            assert!(outward, "face {f:?} points inwards");
            total += a;
        }
        total
    };
    let sphere = 4.0 * std::f64::consts::PI * R * R;
    let (a0, a1) = (area(&base), area(&refined));
    assert_eq!(refined.surface_faces.len(), 4 * base.surface_faces.len());
    // Finer facets inscribed in the sphere: more area, still below the sphere's.
    assert!(a0 < a1 && a1 < sphere, "{a0} {a1} {sphere}");
    assert!((sphere - a1) < 0.5 * (sphere - a0), "{a0} {a1} {sphere}");

    // Refined at the poles only: hanging nodes, passed to the model for tying, and the
    // membrane is the leaf faces (a coarse face under four fine ones is not listed).
    let mut c = SuspendedCell {
        params: single_node_fas(),
        ..SuspendedCell::default()
    };
    c.params.mesh = coarse;
    c.params.pole_refinement = PoleRefinement {
        levels: 1,
        radius: 8.0,
    };
    let poles = c.build().unwrap();
    assert!(!poles.model.hanging.is_empty());
    let geometry = SuspendedCellGeometry::build(&c.params).unwrap();
    assert_eq!(poles.model.hanging, geometry.hanging);
    let a2 = area(&poles);
    assert!(a0 < a2 && a2 < a1, "{a0} {a2} {a1}");
    let grew = poles.surface_faces.len() - base.surface_faces.len();
    assert!(grew > 0 && grew % 3 == 0, "{grew}");
}

#[test]
fn split_filaments_are_embedded_on_their_chords_and_the_engine_term_builder_refuses_them() {
    let mut cell = SuspendedCell {
        params: single_node_fas(),
        ..SuspendedCell::default()
    };
    cell.params.mesh = MeshResolution {
        core_divisions: 4,
        shell_layers: 2,
        outer_layers: 2,
        core_fraction: 0.5,
    };
    // The engine-term builder has no embedding: split filaments would be free collinear
    // trusses (a mechanism), so it refuses them.
    cell.params.af_elements = 4;
    let e = build_suspended_cell(&cell.params, &cell.materials, cell.components)
        .err()
        .expect("free split AFs are a mechanism")
        .to_string();
    assert!(
        e.contains("one truss per AF") && e.contains("mechanism"),
        "{e}"
    );
    // Split AFs and IFs: their interior nodes are embedded in the continuum.
    cell.params.if_elements = 3;
    let built = cell.build().unwrap();
    let mesh = &built.model.mesh;
    assert_eq!(mesh.node_sets[ACTIN_INTERIOR].len(), 60 * 3);
    assert_eq!(mesh.node_sets[INTERMEDIATE_INTERIOR].len(), 60 * 2);
    let embedded: Vec<&str> = built
        .model
        .embedded
        .iter()
        .map(|e| e.node_set.as_str())
        .collect();
    assert_eq!(embedded, [ACTIN_INTERIOR, INTERMEDIATE_INTERIOR]);
    // Interior points equally spaced on each chord.
    let actin = &built.model.structures.filaments[0];
    assert_eq!(actin.pairs.len(), 240);
    for f in actin.pairs.chunks(4) {
        let (a, b) = (mesh.nodes[f[0][0]], mesh.nodes[f[3][1]]);
        for (k, pair) in f.iter().enumerate() {
            let p = mesh.nodes[pair[0]];
            let t = k as f64 / 4.0;
            let want: [f64; 3] = std::array::from_fn(|c| a[c] + t * (b[c] - a[c]));
            assert!(distance(p, want) < 1e-12);
        }
    }
}

#[test]
fn fa_plaques_tie_the_surface_nodes_near_each_fa_and_nothing_else() {
    use crate::cell::fa_plaque::FaCoupling;
    let plain = single_node_geometry();
    assert_eq!(plain.report.fa_plaque_nodes, 0);
    assert_eq!(
        plain.ties, plain.hanging,
        "no plaque: the ties are the hanging nodes'"
    );
    let surface: std::collections::HashSet<usize> =
        plain.mesh.node_sets["surface"].iter().copied().collect();
    let radius = 3.5;
    for coupling in [
        FaCoupling::Rigid,
        FaCoupling::Distributing,
        FaCoupling::DistributingLinear,
    ] {
        let g = SuspendedCellGeometry::build(&SuspendedCellParams {
            fa_radius: radius,
            fa_coupling: coupling,
            ..single_node_fas()
        })
        .unwrap();
        // The plaques change ties only: the mesh and the FAs stay where they were.
        assert_eq!(g.mesh.nodes, plain.mesh.nodes);
        assert_eq!(g.fa_nodes, plain.fa_nodes);
        // Every surface node within the radius of an FA (other than the FA) is in a plaque:
        // the default mesh's surface spacing (~2.1 µm) puts several in each.
        let near: usize = plain.mesh.node_sets["surface"]
            .iter()
            .filter(|&&n| {
                !plain.fa_nodes.contains(&n)
                    && plain
                        .fa_nodes
                        .iter()
                        .any(|&f| distance(plain.mesh.nodes[n], plain.mesh.nodes[f]) <= radius)
            })
            .count();
        assert_eq!(g.report.fa_plaque_nodes, near, "{coupling:?}");
        assert!(near >= 4 * 30, "{near} plaque nodes for 30 FAs");
        let tied: Vec<usize> = g.ties.iter().map(|t| t.node).collect();
        for t in &g.ties {
            let weights: f64 = t.masters.iter().map(|m| m.1).sum();
            assert!((weights - 1.0).abs() < 1e-12, "{t:?}");
            for &(m, _) in &t.masters {
                assert!(!tied.contains(&m), "no chains: {t:?}");
            }
            match coupling {
                // Each plaque node follows its FA node.
                FaCoupling::Rigid => {
                    assert!(surface.contains(&t.node) && !g.fa_nodes.contains(&t.node));
                    assert_eq!(t.masters.len(), 1);
                    assert!(g.fa_nodes.contains(&t.masters[0].0));
                }
                // Each FA node follows the mean of its plaque's nodes.
                FaCoupling::Distributing => {
                    assert!(g.fa_nodes.contains(&t.node));
                    assert!(t.masters.iter().all(|&(m, _)| surface.contains(&m)));
                    let w = 1.0 / t.masters.len() as f64;
                    assert!(t.masters.iter().all(|m| (m.1 - w).abs() < 1e-15));
                }
                // Weights falling to the rim: the weighted mean distance from the FA is
                // below the plain mean.
                FaCoupling::DistributingLinear => {
                    assert!(g.fa_nodes.contains(&t.node));
                    let d = |m: usize| distance(g.mesh.nodes[m], g.mesh.nodes[t.node]);
                    let weighted: f64 = t.masters.iter().map(|&(m, w)| w * d(m)).sum();
                    let plain =
                        t.masters.iter().map(|&(m, _)| d(m)).sum::<f64>() / t.masters.len() as f64;
                    assert!(weighted < plain, "{weighted} vs {plain}: {t:?}");
                    assert!(t.masters.iter().all(|&(m, w)| w > 0.0 && d(m) < radius));
                }
            }
        }
        let expected_ties = match coupling {
            FaCoupling::Rigid => near,
            FaCoupling::Distributing | FaCoupling::DistributingLinear => 30,
        };
        assert_eq!(g.ties.len(), expected_ties, "{coupling:?}");
    }
}

/// `fa_reference = "separate"`: each FA gets one node of its own, appended after the mesh's
/// nodes at its plaque's weighted centroid (the tie's masters: the plaque and the FA node),
/// and every AF, MT and IF of that FA ends on it; the FA mesh node stays free and in the
/// FA node sets. The centroid lies inside the sphere (the plaque is a cap), within a
/// fraction of the plaque radius of the FA node.
#[test]
fn a_separate_fa_reference_node_carries_the_filaments_from_the_plaques_centroid() {
    use crate::cell::fa_plaque::{FaCoupling, FaReference};
    let radius = 3.5;
    let plain = SuspendedCellGeometry::build(&SuspendedCellParams {
        fa_radius: radius,
        fa_coupling: FaCoupling::DistributingLinear,
        ..single_node_fas()
    })
    .unwrap();
    let g = SuspendedCellGeometry::build(&SuspendedCellParams {
        fa_radius: radius,
        fa_coupling: FaCoupling::DistributingLinear,
        fa_reference: FaReference::Separate,
        ..single_node_fas()
    })
    .unwrap();
    assert_eq!(g.fa_nodes, plain.fa_nodes);
    let mut sorted = plain.fa_nodes.clone();
    sorted.sort_unstable();
    assert_eq!(g.mesh.node_sets["focal_adhesions"], sorted);
    let base = plain.mesh.nodes.len();
    assert_eq!(g.mesh.nodes.len(), base + 30);
    // FA node -> its reference node, read off the ties.
    let mut reference = BTreeMap::new();
    for t in &g.ties {
        if t.node >= base {
            let fa = t
                .masters
                .iter()
                .map(|&(m, _)| m)
                .find(|m| g.fa_nodes.contains(m))
                .expect("the FA node is a master of its reference node");
            assert!(
                !g.ties.iter().any(|h| h.node == fa),
                "the FA node stays free"
            );
            assert!(distance(t.tied_position(&g.mesh.nodes), g.mesh.nodes[t.node]) < 1e-12);
            let inward = norm(g.mesh.nodes[fa]) - norm(g.mesh.nodes[t.node]);
            assert!(
                inward > 0.0 && distance(g.mesh.nodes[fa], g.mesh.nodes[t.node]) < 0.2 * radius
            );
            reference.insert(fa, t.node);
        }
    }
    assert_eq!(reference.len(), 30);
    for (k, (&[a, b], &[pa, pb])) in g.af_edges.iter().zip(&plain.af_edges).enumerate() {
        assert_eq!([a, b], [reference[&pa], reference[&pb]], "AF {k}");
    }
    for (mt, p) in g.microtubules.iter().zip(&plain.microtubules) {
        assert_eq!(mt.fa_node, reference[&p.fa_node]);
        assert_eq!(*mt.points.last().unwrap(), g.mesh.nodes[mt.fa_node]);
    }
    for (f, p) in g
        .intermediate_filaments
        .iter()
        .zip(&plain.intermediate_filaments)
    {
        assert_eq!(*f, [reference[&p[0]], p[1]]);
    }
}

/// The default FAs (since 2026-12-07) are 3.5 µm plaques with linear weights and a
/// separate reference node each, the configuration tested above: with single-node FAs the
/// default compression folds the elements at the FAs from 16–20 % (docs/
/// suspended-cell-validation.md, "The default FAs").
#[test]
fn the_default_fas_are_linear_plaques_with_separate_reference_nodes() {
    use crate::cell::fa_plaque::{FaCoupling, FaReference};
    let d = SuspendedCellParams::default();
    assert_eq!(d.fa_radius, 3.5);
    assert_eq!(d.fa_coupling, FaCoupling::DistributingLinear);
    assert_eq!(d.fa_reference, FaReference::Separate);
    let g = SuspendedCellGeometry::build(&d).unwrap();
    let plain = single_node_geometry();
    assert_eq!(g.mesh.nodes.len(), plain.mesh.nodes.len() + 30);
    assert!(
        g.report.fa_plaque_nodes >= 4 * 30,
        "{}",
        g.report.fa_plaque_nodes
    );
}

/// `fa_snap = "none"`: no mesh node moves; each FA node is the nearest surface node of its
/// site, and its plaque is centred on the site, so the plaque's reference node lies (in
/// direction from the centre) nearer the site than the FA node does. Measured on the turned
/// pattern, whose sites lie up to 0.93 µm from the nearest node.
#[test]
fn unsnapped_fas_move_no_node_and_centre_their_plaques_on_the_sites() {
    let turned = SuspendedCellParams {
        fa_orientation: geometry::FaOrientation::PentagonOnAxis,
        ..SuspendedCellParams::default()
    };
    let snapped = SuspendedCellGeometry::build(&turned).unwrap();
    let g = SuspendedCellGeometry::build(&SuspendedCellParams {
        fa_snap: false,
        ..turned.clone()
    })
    .unwrap();
    assert!(snapped.report.moved_nodes > 0);
    assert_eq!(g.report.moved_nodes, 0);
    // The unsnapped mesh is the sphere mesh as generated: the snapped one differs from it
    // only at the moved nodes.
    let base = snapped.mesh.nodes.len() - 30;
    let differ = (0..base)
        .filter(|&n| g.mesh.nodes[n] != snapped.mesh.nodes[n])
        .count();
    assert_eq!(differ, snapped.report.moved_nodes);
    let r = 0.5 * turned.cell_diameter;
    let sites = geometry::fa_sites(&g.fa_rotation, r);
    let angle =
        |a: [f64; 3], b: [f64; 3]| (dot(a, b) / (norm(a) * norm(b))).clamp(-1.0, 1.0).acos();
    let (mut node_off, mut reference_off) = (0.0, 0.0);
    for (k, &fa) in g.fa_nodes.iter().enumerate() {
        assert_eq!(fa, snapped.fa_nodes[k]);
        let reference = g
            .ties
            .iter()
            .find(|t| t.node >= base && t.masters.iter().any(|m| m.0 == fa))
            .expect("a reference node per FA");
        node_off += angle(g.mesh.nodes[fa], sites[k]);
        reference_off += angle(g.mesh.nodes[reference.node], sites[k]);
    }
    eprintln!(
        "mean angular offset from the sites: FA nodes {:.4} rad, reference nodes {:.4} rad",
        node_off / 30.0,
        reference_off / 30.0
    );
    assert!(
        reference_off < 0.5 * node_off,
        "{reference_off} vs {node_off}"
    );
}
