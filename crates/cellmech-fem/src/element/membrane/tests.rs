//! Membrane kernel and set tests.

use super::*;
use crate::dof::DofMap;
use crate::element::KernelError;
use crate::math::vec3::{dot, norm};
use crate::mesh::ElementKind;
use crate::term::Term;

fn rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let n = norm(&axis);
    let k = [axis[0] / n, axis[1] / n, axis[2] / n];
    let (s, c) = angle.sin_cos();
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let delta = if i == j { 1.0 } else { 0.0 };
            let skew = match (i, j) {
                (0, 1) => -k[2],
                (0, 2) => k[1],
                (1, 0) => k[2],
                (1, 2) => -k[0],
                (2, 0) => -k[1],
                (2, 1) => k[0],
                _ => 0.0,
            };
            c * delta + s * skew + (1.0 - c) * k[i] * k[j]
        })
    })
}

fn apply(m: &[[f64; 3]; 3], x: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| dot(&m[i], x))
}

const WARPED_QUAD: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.2, 0.1, 0.15],
    [1.4, 1.1, -0.1],
    [-0.1, 0.9, 0.2],
];
const TILTED_TRI: [[f64; 3]; 3] = [[0.1, 0.0, 0.3], [1.3, 0.2, -0.2], [0.4, 1.0, 0.5]];

#[test]
fn membrane_rigid_rotation_gives_zero_energy_and_residual() {
    let q = rotation([1.0, 2.0, -0.5], 2.3);
    let rq = Quad4Reference::new(WARPED_QUAD).unwrap();
    let rt = Tri3Reference::new(TILTED_TRI).unwrap();
    let u: Vec<f64> = WARPED_QUAD
        .iter()
        .flat_map(|x| {
            let y = apply(&q, x);
            (0..3).map(move |i| y[i] + 0.7 - x[i])
        })
        .collect();
    let mut res = [0.0; 12];
    let e = membrane_quad4_evaluate(&rq, 5.0, 0.3, &u, &mut res, None).unwrap();
    assert!(e.abs() < 1e-13, "quad energy {e:e}");
    assert!(res.iter().all(|r| r.abs() < 1e-13), "quad residual {res:?}");
    let u: Vec<f64> = TILTED_TRI
        .iter()
        .flat_map(|x| {
            let y = apply(&q, x);
            (0..3).map(move |i| y[i] - x[i])
        })
        .collect();
    let e = membrane_tri3_evaluate(&rt, 5.0, 0.3, &u, &mut res, None).unwrap();
    assert!(e.abs() < 1e-13 && res[..9].iter().all(|r| r.abs() < 1e-13));
}

#[test]
fn membrane_homogeneous_biaxial_state_matches_closed_form() {
    // A tilted square of side 2 stretched by (l1, l2) in its own plane, then rotated.
    let q = rotation([0.2, 0.5, 1.0], 0.8);
    let flat = [
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [2.0, 2.0, 0.0],
        [0.0, 2.0, 0.0],
    ];
    let x0: [[f64; 3]; 4] = std::array::from_fn(|a| apply(&q, &flat[a]));
    let (l1, l2, mu, h) = (1.7, 1.2, 4.0, 0.25);
    let u: Vec<f64> = (0..4)
        .flat_map(|a| {
            let y = apply(&q, &[l1 * flat[a][0], l2 * flat[a][1], 0.0]);
            (0..3).map(move |i| y[i] - x0[a][i])
        })
        .collect();
    let r = Quad4Reference::new(x0).unwrap();
    let mut res = [0.0; 12];
    let e = membrane_quad4_evaluate(&r, mu, h, &u, &mut res, None).unwrap();
    let w = 0.5 * mu * (l1 * l1 + l2 * l2 + 1.0 / (l1 * l1 * l2 * l2) - 3.0);
    assert!(
        (e - 4.0 * h * w).abs() < 1e-12 * e,
        "energy {e} vs {}",
        4.0 * h * w
    );
    let s = membrane_state(&r, mu, h, &u).unwrap();
    let j = l1 * l2;
    let t1 = h / j * mu * (l1 * l1 - 1.0 / (j * j));
    let t2 = h / j * mu * (l2 * l2 - 1.0 / (j * j));
    assert!(
        (s.principal_tensions[0] - t1).abs() < 1e-12
            && (s.principal_tensions[1] - t2).abs() < 1e-12
    );
    assert!((s.thickness - h / j).abs() < 1e-14 && (s.area_stretch - j).abs() < 1e-13);
    // Nodal force at node 2 along the stretched axis: nominal tension × half the edge.
    let fx = apply(&q, &[1.0, 0.0, 0.0]);
    let f2 = dot(&fx, &[res[6], res[7], res[8]]);
    let nominal = mu * h * (l1 - 1.0 / (l1 * l1 * l1 * l2 * l2));
    assert!((f2 - nominal).abs() < 1e-12 * nominal, "{f2} vs {nominal}");
}

#[test]
fn membrane_rejects_degenerate_elements_and_bad_parameters() {
    let line = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
    assert!(matches!(
        Tri3Reference::new(line),
        Err(KernelError::DegenerateReference { .. })
    ));
    let bowtie = [
        [0.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    assert!(Quad4Reference::new(bowtie).is_err());
    let nodes = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
    let err = MembraneSet::new("cm", ElementKind::Tri3, vec![0, 1, 2], &nodes, 1.0, 0.0);
    assert!(matches!(
        err,
        Err(MembraneError::InvalidParameter {
            parameter: "thickness",
            ..
        })
    ));
    let err = MembraneSet::new("cm", ElementKind::Tri3, vec![0, 1, 2], &nodes, -1.0, 0.1);
    assert!(matches!(err, Err(MembraneError::InvalidParameter { .. })));
    let err = MembraneSet::new("cm", ElementKind::Tri3, vec![0, 1, 5], &nodes, 1.0, 0.1);
    assert!(matches!(
        err,
        Err(MembraneError::MissingNode { node: 5, .. })
    ));
    let err = MembraneSet::new("cm", ElementKind::Hex8, vec![0; 8], &nodes, 1.0, 0.1);
    assert!(matches!(err, Err(MembraneError::UnsupportedKind { .. })));
    // A current configuration collapsed to a line is reported, not a NaN.
    let set = MembraneSet::new("cm", ElementKind::Tri3, vec![0, 1, 2], &nodes, 1.0, 0.1).unwrap();
    let u = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, -1.0, 0.0];
    let mut r = [0.0; 9];
    assert!(matches!(
        set.evaluate(0, &u, &mut r, None),
        Err(KernelError::InvertedElement { .. })
    ));
}

#[test]
fn membrane_set_outputs_report_uniaxial_thinning() {
    let nodes = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let mut set = MembraneSet::new(
        "ac",
        ElementKind::Quad4,
        vec![0, 1, 2, 3],
        &nodes,
        0.67,
        0.2,
    )
    .unwrap();
    let l: f64 = 1.5;
    let l2 = l.powf(-0.5);
    let u: Vec<f64> = nodes
        .iter()
        .flat_map(|x| [(l - 1.0) * x[0], (l2 - 1.0) * x[1], 0.0])
        .collect();
    let out = set.outputs(&u, &DofMap::translational(4)).unwrap().unwrap();
    assert_eq!(out.kind, ElementKind::Quad4);
    let t = &out.fields[0].values;
    let expected = 0.2 / l.sqrt() * 0.67 * (l * l - 1.0 / l); // h σ₁ with h = H/√λ
    assert!(
        (t[0] - expected).abs() < 1e-13 && t[1].abs() < 1e-13,
        "{t:?}"
    );
    assert!((out.fields[1].values[0] - 0.2 / l.sqrt()).abs() < 1e-14);
    set.set_enabled(false);
    assert_eq!(set.num_elements(), 0);
    assert!(set
        .outputs(&u, &DofMap::translational(4))
        .unwrap()
        .is_none());
}
