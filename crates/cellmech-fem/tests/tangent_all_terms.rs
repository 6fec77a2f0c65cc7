//! One finite-difference harness ([`check_term`]) over every `Term` type of the engine:
//! the residual must be the gradient of the energy, the tangent the Jacobian of the
//! residual (and symmetric), element by element, at large deformed states.
//!
//! Relative errors are `max |analytic − FD| / max |analytic|` per element (see
//! `verify::tangent`). A new element or material law gets a block here.

use cellmech_fem::contact::{ContactKind, CurvatureTangent, RigidContact, ToolShape};
use cellmech_fem::continuum::ContinuumBlock;
use cellmech_fem::dof::DofMap;
use cellmech_fem::element::beam::{BeamSection, BeamSet};
use cellmech_fem::element::hex8::Hex8Formulation;
use cellmech_fem::element::membrane::MembraneSet;
use cellmech_fem::element::pressure::{PressureLoad, SurfaceVolume, VolumeControl};
use cellmech_fem::element::spring::SpringSet;
use cellmech_fem::element::truss::TrussSet;
use cellmech_fem::material::{AxialLaw, NeoHookean};
use cellmech_fem::mesh::generate::{box_mesh, perturb_interior_nodes};
use cellmech_fem::mesh::ElementKind;
use cellmech_fem::term::{LoadState, Term};
use cellmech_fem::verify::tangent::{check_term, TermCheck};

/// Seeded numbers in [-1, 1) (64-bit LCG, top 53 bits).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// Step and tolerances of one check: relative errors below `rel`, symmetry below `sym`,
/// and (when given) absolute errors below `abs`.
struct Fd {
    h: f64,
    rel: f64,
    sym: f64,
    abs: Option<f64>,
}

/// Checks every element of `term` at `u` with `fd`; returns the number of elements checked.
fn assert_term(what: &str, term: &dyn Term, dof_map: &DofMap, u: &[f64], fd: Fd) -> usize {
    let checks: Vec<TermCheck> = check_term(term, dof_map, u, fd.h).expect("evaluable state");
    assert!(!checks.is_empty(), "{what}: no element");
    for c in &checks {
        assert!(
            c.passes(fd.rel, fd.sym),
            "{what}: element {}: {c:?}",
            c.element
        );
        if let Some(a) = fd.abs {
            assert!(
                c.gradient.max_abs_error < a && c.jacobian.max_abs_error < a,
                "{what}: element {}: {c:?}",
                c.element
            );
        }
    }
    let worst = |f: fn(&TermCheck) -> f64| checks.iter().map(f).fold(0.0, f64::max);
    eprintln!(
        "{what}: {} elements, worst relative errors: residual {:.1e}, tangent {:.1e}, symmetry {:.1e}",
        checks.len(),
        worst(|c| c.gradient.relative_error),
        worst(|c| c.jacobian.relative_error),
        worst(|c| c.symmetry)
    );
    checks.len()
}

#[test]
fn hex8_both_formulations() {
    let mut mesh = box_mesh([0.0; 3], [2.0, 1.5, 1.0], [2, 2, 2], "block").unwrap();
    perturb_interior_nodes(&mut mesh, 0.2, 3).unwrap();
    let mut rng = Lcg(11);
    let u: Vec<f64> = (0..3 * mesh.num_nodes())
        .map(|_| 0.08 * rng.next())
        .collect();
    let map = DofMap::translational(mesh.num_nodes());
    for ratio in [1.0, 1000.0] {
        let law = NeoHookean::new(0.7, 0.7 * ratio).unwrap();
        for form in [
            Hex8Formulation::MeanDilatation,
            Hex8Formulation::Displacement,
        ] {
            let block = ContinuumBlock::new(&mesh.blocks[0], &mesh.nodes, law, form).unwrap();
            let what = format!("hex8 {form:?} K/G={ratio}");
            assert_term(
                &what,
                &block,
                &map,
                &u,
                Fd {
                    h: 1e-6,
                    rel: 1e-6,
                    sym: 1e-13,
                    abs: None,
                },
            );
        }
    }
}

/// Rotation by `angle` about `axis` (Rodrigues).
fn rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let k = axis.map(|c| c / n);
    let (s, c) = angle.sin_cos();
    let skew = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let delta = if i == j { 1.0 } else { 0.0 };
            c * delta + s * skew[i][j] + (1.0 - c) * k[i] * k[j]
        })
    })
}

#[test]
fn membrane_quad4_and_tri3() {
    let nodes = vec![
        [0.0, 0.0, 0.0],
        [1.2, 0.1, 0.15],
        [1.4, 1.1, -0.1],
        [-0.1, 0.9, 0.2],
        [0.1, 0.0, 0.3],
        [1.3, 0.2, -0.2],
        [0.4, 1.0, 0.5],
    ];
    let map = DofMap::translational(nodes.len());
    for seed in 1..4 {
        let mut rng = Lcg(seed);
        // A large stretch and shear, an out-of-plane rotation (63° about a skew axis),
        // plus nodal noise.
        let f = [[1.6, 0.3, 0.1], [-0.2, 0.7, 0.2], [0.1, 0.25, 1.2]];
        let q = rotation([0.3, -1.0, 0.6], 1.1);
        let qf: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| (0..3).map(|k| q[i][k] * f[k][j]).sum::<f64>())
        });
        let u: Vec<f64> = nodes
            .iter()
            .flat_map(|x| {
                let y: [f64; 3] =
                    std::array::from_fn(|i| (0..3).map(|k| qf[i][k] * x[k]).sum::<f64>());
                (0..3).map(move |i| y[i] - x[i]).collect::<Vec<_>>()
            })
            .map(|v| v + 0.1 * rng.next())
            .collect();
        let quad =
            MembraneSet::new("q", ElementKind::Quad4, vec![0, 1, 2, 3], &nodes, 3.0, 0.2).unwrap();
        assert_term(
            "membrane quad4",
            &quad,
            &map,
            &u,
            Fd {
                h: 1e-6,
                rel: 1e-7,
                sym: 1e-12,
                abs: None,
            },
        );
        let tri =
            MembraneSet::new("t", ElementKind::Tri3, vec![4, 5, 6], &nodes, 2.0, 0.01).unwrap();
        assert_term(
            "membrane tri3",
            &tri,
            &map,
            &u,
            Fd {
                h: 1e-6,
                rel: 1e-7,
                sym: 1e-12,
                abs: None,
            },
        );
    }
}

/// Every axial law (linear, tension-only with prestrain, slack IF, smoothed tension-only)
/// on every branch: compression, slack, just below and above the switch, tension.
#[test]
fn truss_all_axial_laws_on_every_branch() {
    let laws = [
        AxialLaw::linear(1.2e6, AxialLaw::hollow_circle_area(0.025, 0.017)),
        AxialLaw::tension_only(2.6e6, AxialLaw::solid_circle_area(0.007)).with_prestrain(0.24),
        AxialLaw::tension_only(7.6e3, AxialLaw::solid_circle_area(0.010)).with_slack(0.2),
        AxialLaw::tension_only(340.0, AxialLaw::solid_circle_area(0.25))
            .with_prestrain(0.24)
            .with_transition_band(1e-3),
    ];
    let ratios = [0.6, 0.95, 0.995, 1.005, 1.05, 1.4];
    let mut rng = Lcg(0x7255);
    let mut checked = 0;
    for law in laws {
        // One element per ratio, each with its own free node pair.
        let (mut x, mut u, mut pairs) = (Vec::new(), Vec::new(), Vec::new());
        for (k, ratio) in ratios.iter().enumerate() {
            let dir = unit(&mut rng);
            let new_dir = unit(&mut rng);
            let l0 = 3.0 + 2.0 * rng.next();
            let xa = [rng.next(), rng.next(), rng.next()];
            x.push(xa);
            x.push(std::array::from_fn(|i| xa[i] + l0 * dir[i]));
            let l = ratio * law.stress_free_length(l0);
            let shift = [rng.next(), rng.next(), rng.next()];
            u.extend(shift);
            u.extend((0..3).map(|i| shift[i] + l * new_dir[i] - l0 * dir[i]));
            pairs.push([2 * k, 2 * k + 1]);
        }
        let set = TrussSet::new("f", "family", &x, pairs, law).unwrap();
        let map = DofMap::translational(x.len());
        let what = format!("truss {law:?}");
        checked += assert_term(
            &what,
            &set,
            &map,
            &u,
            Fd {
                h: 1e-6 * 3.0,
                rel: 1e-6,
                sym: 1e-15,
                abs: None,
            },
        );
    }
    assert_eq!(checked, 4 * 6);
}

fn unit(rng: &mut Lcg) -> [f64; 3] {
    loop {
        let v = [rng.next(), rng.next(), rng.next()];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 0.1 && n <= 1.0 {
            return v.map(|c| c / n);
        }
    }
}

#[test]
fn beam_at_large_rotations() {
    let nodes = vec![[0.1, -0.2, 0.3], [1.0, 0.4, 0.8], [1.9, 0.6, 1.5]];
    let section = BeamSection::new(100.0, 40.0, 0.3, 0.02, 0.05, 0.03).unwrap();
    let set = BeamSet::from_coordinates(
        "b",
        "filament",
        &nodes,
        &[[0, 1], [1, 2]],
        Some([0.0, 0.0, 1.0]),
        section,
    )
    .unwrap();
    let map = DofMap::with_counts(&[6, 6, 6]);
    let mut rng = Lcg(7);
    for _ in 0..10 {
        // Every node turns by up to ~2.5 rad about its own axis, plus moderate strains.
        let common: [f64; 3] = std::array::from_fn(|_| 1.4 * rng.next());
        let u: Vec<f64> = (0..18)
            .map(|k| match k % 6 {
                0..=2 => 0.25 * rng.next(),
                c => common[c - 3] + 0.3 * rng.next(),
            })
            .collect();
        assert_term(
            "beam",
            &set,
            &map,
            &u,
            Fd {
                h: 1e-6,
                rel: 1e-6,
                sym: 1e-12,
                abs: None,
            },
        );
    }
}

#[test]
fn spring() {
    let nodes = [[0.0, 0.0, 0.0], [1.0, 0.5, -0.2], [0.3, 1.1, 0.4]];
    let set = SpringSet {
        name: "s".into(),
        nodes: vec![[0, 1], [1, 2]],
        reference: vec![[nodes[0], nodes[1]], [nodes[1], nodes[2]]],
        stiffness: vec![2.0, 5.0],
        rest_length: vec![0.7, 1.4],
    };
    let u = [0.1, -0.2, 0.05, 0.3, 0.1, 0.4, -0.2, 0.3, 0.1];
    let map = DofMap::translational(3);
    assert_term(
        "spring",
        &set,
        &map,
        &u,
        Fd {
            h: 1e-6,
            rel: 1e-7,
            sym: 1e-15,
            abs: Some(1e-6),
        },
    );
}

fn cube_surface() -> (Vec<[f64; 3]>, Vec<usize>) {
    let nodes: Vec<[f64; 3]> = (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect();
    let faces = vec![
        0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 1, 3, 7, 5, 3, 2, 6, 7, 2, 0, 4, 6,
    ];
    (nodes, faces)
}

#[test]
fn pressure_load_and_volume_control() {
    let (mut nodes, faces) = cube_surface();
    let u: Vec<f64> = (0..24)
        .map(|i| 0.3 * ((i as f64 * 1.7).sin() + 0.3 * (i as f64 * 0.37).cos()) + 0.02 * i as f64)
        .collect();
    for kind in [ElementKind::Quad4, ElementKind::Tri3] {
        let conn: Vec<usize> = if kind == ElementKind::Quad4 {
            faces.clone()
        } else {
            faces.chunks(4).flat_map(|q| [q[0], q[1], q[2]]).collect()
        };
        let load = PressureLoad::new(SurfaceVolume::new("p", kind, conn, &nodes).unwrap(), 2.5);
        let map = DofMap::translational(8);
        let what = format!("pressure {kind:?}");
        assert_term(
            &what,
            &load,
            &map,
            &u,
            Fd {
                h: 1e-6,
                rel: 1e-8,
                sym: 1e-14,
                abs: Some(1e-8),
            },
        );
    }
    nodes.push([0.0; 3]);
    let s = SurfaceVolume::new("vc", ElementKind::Quad4, faces, &nodes).unwrap();
    let vc = VolumeControl::new(s, 8).unwrap();
    let mut u = u;
    u.extend([1.7, 0.4, 0.0]);
    let map = DofMap::translational(9);
    assert_term(
        "volume control",
        &vc,
        &map,
        &u,
        Fd {
            h: 1e-6,
            rel: 1e-8,
            sym: 1e-14,
            abs: Some(1e-8),
        },
    );
}

fn tool(shape: ToolShape, kind: ContactKind, x: &[[f64; 3]]) -> RigidContact {
    RigidContact::new(
        "t",
        shape,
        kind,
        (0..x.len()).collect(),
        x.to_vec(),
        7.0,
        1e-6,
        vec![[0.0; 3]],
    )
    .unwrap()
}

/// Finite-difference settings of the contact checks.
const CONTACT_FD: Fd = Fd {
    h: 1e-7,
    rel: 1e-6,
    sym: 1e-15,
    abs: Some(1e-6),
};

/// A sphere, a paraboloid tip and a plate just below z = 1.1, their bodies above.
fn contact_tools() -> [ToolShape; 3] {
    [
        ToolShape::Sphere {
            center: [0.0, 0.0, 2.0],
            radius: 1.0,
        },
        ToolShape::Paraboloid {
            apex: [0.1, 0.0, 1.05],
            axis: [0.0, 0.0, -1.0],
            tip_radius: 0.3,
        },
        ToolShape::Plate {
            point: [0.0, 0.0, 1.02],
            normal: [0.0, 0.0, -1.0],
        },
    ]
}

/// Three nodes (reference positions) that [`PUSHED_U`] pushes into every tool of
/// [`contact_tools`].
const PUSHED_X: [[f64; 3]; 3] = [[0.2, 0.1, 1.1], [0.05, -0.1, 1.1], [-0.1, 0.15, 1.11]];
/// Their displacements.
const PUSHED_U: [f64; 9] = [0.01, -0.02, 0.04, 0.0, 0.01, 0.03, 0.02, 0.0, 0.05];

/// The frictionless contact of [`PUSHED_X`] with `curvature`, committed and moved to
/// mid-step, the status predictor activating every node from [`PUSHED_U`].
fn pushed_frictionless(shape: ToolShape, curvature: CurvatureTangent) -> RigidContact {
    let map = DofMap::translational(3);
    let mut c = tool(shape, ContactKind::Frictionless, &PUSHED_X).with_curvature_tangent(curvature);
    c.commit(&PUSHED_U, &map);
    c.set_load_state(&LoadState {
        step_index: 0,
        step_time: 0.5,
    });
    c.predict(&PUSHED_U, &map);
    c
}

#[test]
fn contact_frictionless_active_and_bonded() {
    let shapes = contact_tools();
    // Nodes pushed into the tool: every one is active.
    let (x, u) = (PUSHED_X, PUSHED_U);
    let map = DofMap::translational(3);
    for shape in shapes {
        // The consistent tangent (the default lags the curvature term's pressure to the last
        // equilibrium's). Predicted from u, the status predictor activates every node.
        let c = pushed_frictionless(shape, CurvatureTangent::Consistent);
        let mut r = [0.0; 3];
        for e in 0..3 {
            c.evaluate(e, &u[3 * e..3 * e + 3], &mut r, None).unwrap();
            assert!(
                r.iter().any(|&v| v != 0.0),
                "{shape:?}: node {e} must be active"
            );
        }
        let what = format!("frictionless {shape:?}");
        assert_term(&what, &c, &map, &u, CONTACT_FD);
        // Bonded: the touching nodes are tied at commit, then pulled away.
        let mut b = tool(shape, ContactKind::Bonded, &x);
        b.set_load_state(&LoadState {
            step_index: 0,
            step_time: 1.0,
        });
        b.commit(&u, &map);
        assert_eq!(b.bonded_count(), 3, "{shape:?}");
        let pulled: Vec<f64> = u
            .iter()
            .enumerate()
            .map(|(i, v)| v - 0.1 * (i % 3) as f64)
            .collect();
        let what = format!("bonded {shape:?}");
        assert_term(&what, &b, &map, &pulled, CONTACT_FD);
    }
}

/// The default lagged curvature term caps the pressure at the last equilibrium's (0 for a
/// node just predicted into contact), so far from equilibrium its tangent is not the
/// derivative on a curved tool; once Newton says it is near equilibrium the term takes the
/// trial pressure and the tangent is exact again (finite differences), which is what makes
/// the last iterations quadratic.
#[test]
fn lagged_contact_is_exact_near_equilibrium() {
    let shapes = contact_tools();
    let u = PUSHED_U;
    let map = DofMap::translational(3);
    for shape in &shapes[..2] {
        let mut c = pushed_frictionless(*shape, CurvatureTangent::Lagged);
        let tangent = |c: &RigidContact| {
            let (mut r, mut k) = ([0.0; 3], [0.0; 9]);
            c.evaluate(0, &u[..3], &mut r, Some(&mut k)).unwrap();
            k
        };
        let far = tangent(&c);
        c.set_near_equilibrium(true);
        let near = tangent(&c);
        let differ = far
            .iter()
            .zip(&near)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            differ > 1e-3,
            "{shape:?}: the lag must matter here ({differ})"
        );
        assert_term(
            &format!("lagged near equilibrium {shape:?}"),
            &c,
            &map,
            &u,
            CONTACT_FD,
        );
    }
}

#[test]
fn contact_on_faces_frictionless() {
    let shapes = contact_tools();
    // Two warped faces sharing an edge, pushed into the tool.
    let x = [
        [-0.3, -0.2, 1.1],
        [0.0, -0.25, 1.12],
        [0.05, 0.2, 1.09],
        [-0.25, 0.15, 1.1],
        [0.3, -0.2, 1.08],
        [0.28, 0.22, 1.11],
    ];
    let faces = [[0, 1, 2, 3], [1, 4, 5, 2]];
    let u: Vec<f64> = (0..18).map(|i| 0.01 * ((i * 7 % 5) as f64 - 2.0)).collect();
    let map = DofMap::translational(6);
    for shape in shapes {
        for per_side in [2, 3] {
            let mut c = RigidContact::on_faces(
                "t",
                shape,
                ContactKind::Frictionless,
                &faces,
                &x,
                per_side,
                7.0,
                1e-6,
                vec![[0.0; 3]],
            )
            .unwrap()
            .with_curvature_tangent(CurvatureTangent::Consistent);
            c.commit(&u, &map);
            c.set_load_state(&LoadState {
                step_index: 0,
                step_time: 0.5,
            });
            c.predict(&u, &map);
            let what = format!("frictionless faces ({per_side}²) {shape:?}");
            let mut r = [0.0; 12];
            let u_face_1: Vec<f64> = faces[1]
                .iter()
                .flat_map(|&n| u[3 * n..3 * n + 3].to_vec())
                .collect();
            c.evaluate(1, &u_face_1, &mut r, None).unwrap();
            assert!(r.iter().any(|&v| v != 0.0), "{what}: face 1 must be active");
            assert_term(&what, &c, &map, &u, CONTACT_FD);
        }
    }
}
