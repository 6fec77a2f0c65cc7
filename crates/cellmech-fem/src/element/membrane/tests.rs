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
    let e = membrane_evaluate(&rq, MembraneLaw::Elastic, 5.0, 0.3, &u, &mut res, None).unwrap();
    assert!(e.abs() < 1e-13, "quad energy {e:e}");
    assert!(res.iter().all(|r| r.abs() < 1e-13), "quad residual {res:?}");
    let u: Vec<f64> = TILTED_TRI
        .iter()
        .flat_map(|x| {
            let y = apply(&q, x);
            (0..3).map(move |i| y[i] - x[i])
        })
        .collect();
    let e = membrane_evaluate(&rt, MembraneLaw::Elastic, 5.0, 0.3, &u, &mut res, None).unwrap();
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
    let e = membrane_evaluate(&r, MembraneLaw::Elastic, mu, h, &u, &mut res, None).unwrap();
    let w = 0.5 * mu * (l1 * l1 + l2 * l2 + 1.0 / (l1 * l1 * l2 * l2) - 3.0);
    assert!(
        (e - 4.0 * h * w).abs() < 1e-12 * e,
        "energy {e} vs {}",
        4.0 * h * w
    );
    let s = membrane_state(&r, MembraneLaw::Elastic, mu, h, &u).unwrap();
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

/// Displacements of a flat unit square (z = 0) stretched by `l1` along x and `l2` along y.
fn stretched_square(l1: f64, l2: f64) -> (Quad4Reference, Vec<f64>) {
    let x0 = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let u = x0
        .iter()
        .flat_map(|x| [(l1 - 1.0) * x[0], (l2 - 1.0) * x[1], 0.0])
        .collect();
    (Quad4Reference::new(x0).unwrap(), u)
}

#[test]
fn tension_field_membrane_is_taut_wrinkled_or_slack_with_the_closed_form_energies() {
    let (mu, h) = (2.0, 0.1);
    let law = MembraneLaw::TensionField;
    let energy = |l1: f64, l2: f64, law| {
        let (r, u) = stretched_square(l1, l2);
        let mut res = [0.0; 12];
        membrane_evaluate(&r, law, mu, h, &u, &mut res, None).unwrap()
    };
    // Taut (λ₂ = 0.9 above the natural width 1.5^(−1/2) = 0.816): the elastic energy.
    let elastic =
        |l1: f64, l2: f64| h * mu / 2.0 * (l1 * l1 + l2 * l2 + 1.0 / (l1 * l2).powi(2) - 3.0);
    assert!((energy(1.5, 0.9, law) - elastic(1.5, 0.9)).abs() < 1e-14);
    // Wrinkled (λ₂ = 0.7, 0.5): the uniaxial energy, whatever the width; the elastic sheet
    // would store more (it is compressed across).
    let uniaxial = h * mu / 2.0 * (1.5f64.powi(2) + 2.0 / 1.5 - 3.0);
    for l2 in [0.7, 0.5] {
        let w = energy(1.5, l2, law);
        assert!((w - uniaxial).abs() < 1e-14, "{l2}: {w} vs {uniaxial}");
        assert!(energy(1.5, l2, MembraneLaw::Elastic) > w + 1e-3);
    }
    // At the natural width both branches give the same energy and force.
    let natural = 1.5f64.powf(-0.5);
    assert!((elastic(1.5, natural) - uniaxial).abs() < 1e-14);
    let force = |l2: f64| {
        let (r, u) = stretched_square(1.5, l2);
        let mut res = [0.0; 12];
        membrane_evaluate(&r, law, mu, h, &u, &mut res, None).unwrap();
        res
    };
    let (below, above) = (force(natural - 1e-9), force(natural + 1e-9));
    for (a, b) in below.iter().zip(&above) {
        assert!((a - b).abs() < 1e-7, "{below:?} vs {above:?}");
    }
    // The uniaxial force along x: t₁ × current width with t₁ = h₁ μ (λ² − 1/λ) and the
    // sheet's own width λ^(−1/2): H μ (λ − λ⁻²) per unit reference width, on each end.
    let wrinkled = force(0.6);
    let pull: f64 = [1, 2].iter().map(|&a| wrinkled[3 * a]).sum();
    assert!((pull - h * mu * (1.5 - 1.0 / 2.25)).abs() < 1e-12, "{pull}");
    // Slack: compressed both ways, or stretched less than 1 along its larger stretch.
    for (l1, l2) in [(0.9, 0.8), (1.0, 0.5), (0.95, 0.95)] {
        let (r, u) = stretched_square(l1, l2);
        let mut res = [0.0; 12];
        let mut k = [0.0; 144];
        let w = membrane_evaluate(&r, law, mu, h, &u, &mut res, Some(&mut k)).unwrap();
        assert!(w == 0.0 && res.iter().chain(&k).all(|&x| x == 0.0));
    }
}

#[test]
fn tension_field_membrane_tangent_and_residual_match_finite_differences() {
    // A warped quad deformed into each state; central differences of the energy (residual)
    // and of the residual (tangent).
    let x0 = [
        [0.0, 0.0, 0.0],
        [1.1, 0.1, 0.05],
        [1.0, 0.9, -0.1],
        [-0.1, 1.0, 0.08],
    ];
    let r = Quad4Reference::new(x0).unwrap();
    let (mu, h) = (1.3, 0.2);
    let law = MembraneLaw::TensionField;
    let cases: [(&str, [f64; 2]); 3] = [
        ("taut", [1.4, 1.2]),
        ("wrinkled", [1.5, 0.55]),
        ("slack", [0.8, 0.7]),
    ];
    for (name, [l1, l2]) in cases {
        // Stretch along a rotated in-plane direction, plus a small smooth perturbation.
        let (c, s) = (0.6f64.cos(), 0.6f64.sin());
        let u: Vec<f64> = x0
            .iter()
            .enumerate()
            .flat_map(|(a, x)| {
                let p = c * x[0] + s * x[1];
                let q = -s * x[0] + c * x[1];
                let (p2, q2) = (l1 * p, l2 * q);
                let y = [c * p2 - s * q2, s * p2 + c * q2];
                let wobble = 0.01 * (a as f64 + 1.0);
                [
                    y[0] - x[0] + wobble,
                    y[1] - x[1] - 0.5 * wobble,
                    0.3 * wobble,
                ]
            })
            .collect();
        let mut res = [0.0; 12];
        let mut k = [0.0; 144];
        membrane_evaluate(&r, law, mu, h, &u, &mut res, Some(&mut k)).unwrap();
        let eps = 1e-6;
        let scale = res.iter().map(|x| x.abs()).fold(1e-12, f64::max);
        let kscale = k.iter().map(|x| x.abs()).fold(1e-12, f64::max);
        for j in 0..12 {
            let mut up = u.clone();
            let mut um = u.clone();
            up[j] += eps;
            um[j] -= eps;
            let (mut rp, mut rm) = ([0.0; 12], [0.0; 12]);
            let ep = membrane_evaluate(&r, law, mu, h, &up, &mut rp, None).unwrap();
            let em = membrane_evaluate(&r, law, mu, h, &um, &mut rm, None).unwrap();
            let fd = (ep - em) / (2.0 * eps);
            assert!(
                (fd - res[j]).abs() < 1e-6 * scale,
                "{name}: residual {j}: {fd} vs {}",
                res[j]
            );
            for i in 0..12 {
                let fd = (rp[i] - rm[i]) / (2.0 * eps);
                assert!(
                    (fd - k[i * 12 + j]).abs() < 1e-5 * kscale,
                    "{name}: K[{i}][{j}] {} vs {fd}",
                    k[i * 12 + j]
                );
            }
        }
        let state = membrane_state(&r, law, mu, h, &u).unwrap();
        match name {
            "taut" => assert!(state.principal_tensions[1] > 0.0),
            "wrinkled" => {
                assert!(state.principal_tensions[0] > 0.0 && state.principal_tensions[1] == 0.0)
            }
            _ => assert_eq!(state.principal_tensions, [0.0, 0.0]),
        }
    }
}
