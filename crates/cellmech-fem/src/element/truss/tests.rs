//! Truss kernel and set tests.

use super::*;
use crate::dof::DofMap;
use crate::element::KernelError;
use crate::material::AxialLaw;
use crate::mesh::ElementKind;
use crate::term::Term;

/// Seeded uniform numbers in [0, 1) (64-bit LCG, top 53 bits).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn unit(&mut self) -> [f64; 3] {
        loop {
            let v: [f64; 3] = std::array::from_fn(|_| 2.0 * self.next() - 1.0);
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if n > 0.1 && n <= 1.0 {
                return v.map(|x| x / n);
            }
        }
    }
}

fn laws() -> Vec<AxialLaw> {
    vec![
        AxialLaw::linear(1.2e6, AxialLaw::hollow_circle_area(0.025, 0.017)),
        AxialLaw::tension_only(2.6e6, AxialLaw::solid_circle_area(0.007)).with_prestrain(0.24),
        AxialLaw::tension_only(7.6e3, AxialLaw::solid_circle_area(0.010)).with_slack(0.2),
        AxialLaw::tension_only(340.0, AxialLaw::solid_circle_area(0.25))
            .with_prestrain(0.24)
            .with_transition_band(1e-3),
    ]
}

/// Displacements putting a truss from `x0a` along `dir` with length `l0` at length `l`
/// in direction `new_dir`, node a moved by `shift`.
fn placed(l0: f64, dir: [f64; 3], l: f64, new_dir: [f64; 3], shift: [f64; 3]) -> [f64; 6] {
    std::array::from_fn(|i| {
        if i < 3 {
            shift[i]
        } else {
            shift[i - 3] + l * new_dir[i - 3] - l0 * dir[i - 3]
        }
    })
}

#[test]
fn truss_tension_only_contributes_exactly_nothing_in_compression() {
    let law = AxialLaw::tension_only(2.6e6, 3.85e-5).with_prestrain(0.24);
    let (x0a, x0b) = ([0.0, 0.0, 0.0], [1.0, 2.0, 2.0]);
    // Shorten from L0 = 3 to 2.0 < L_free = 3/1.24 = 2.419, and rotate.
    let u = placed(
        3.0,
        [1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0],
        2.0,
        [0.0, 0.6, 0.8],
        [0.1; 3],
    );
    let (mut r, mut t) = ([1.0; 6], [1.0; 36]);
    let w = truss_evaluate(&law, &x0a, &x0b, &u, &mut r, Some(&mut t)).unwrap();
    assert_eq!(w, 0.0);
    assert!(r.iter().all(|&x| x == 0.0), "{r:?}");
    assert!(t.iter().all(|&x| x == 0.0));
}

#[test]
fn truss_prestrained_at_initial_geometry_pulls_with_ea_times_prestrain() {
    let mut rng = Lcg(42);
    let law =
        AxialLaw::tension_only(2.6e6, AxialLaw::solid_circle_area(0.007)).with_prestrain(0.24);
    let ea = law.axial_stiffness();
    for _ in 0..20 {
        let dir = rng.unit();
        let x0a = [rng.next(), rng.next(), rng.next()];
        let x0b = std::array::from_fn(|i| x0a[i] + 16.0 * dir[i]);
        let (mut r, mut t) = ([0.0; 6], [0.0; 36]);
        truss_evaluate(&law, &x0a, &x0b, &[0.0; 6], &mut r, Some(&mut t)).unwrap();
        for i in 0..3 {
            assert!((r[3 + i] - ea * 0.24 * dir[i]).abs() <= 1e-12 * ea);
            assert!((r[i] + r[3 + i]).abs() <= 1e-15 * ea);
        }
        // Lateral (geometric) stiffness N/ℓ: a unit transverse move of b.
        let perp = {
            let c = [dir[1], -dir[0], 0.0];
            let n = (c[0] * c[0] + c[1] * c[1]).sqrt();
            c.map(|x| x / n)
        };
        let kt: f64 = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| perp[i] * t[(3 + i) * 6 + 3 + j] * perp[j])
            .sum();
        assert!((kt - ea * 0.24 / 16.0).abs() < 1e-12 * ea, "lateral {kt}");
    }
}

#[test]
fn truss_energy_is_invariant_under_rigid_rotation() {
    let law = laws()[1];
    let (x0a, x0b) = ([0.0, 0.0, 0.0], [3.0, 0.0, 0.0]);
    let (mut r, mut r2) = ([0.0; 6], [0.0; 6]);
    let w1 = truss_evaluate(&law, &x0a, &x0b, &[0.0; 6], &mut r, None).unwrap();
    // Rotate by 90° about z and translate.
    let u = [1.0, 1.0, 1.0, 1.0 - 3.0, 1.0 + 3.0, 1.0];
    let w2 = truss_evaluate(&law, &x0a, &x0b, &u, &mut r2, None).unwrap();
    assert!((w1 - w2).abs() < 1e-12 * w1 && w1 > 0.0);
    assert!((r2[4] - r[3]).abs() < 1e-12 * r[3].abs());
}

#[test]
fn truss_kernel_reports_zero_lengths_as_errors() {
    let law = AxialLaw::linear(1.0, 1.0);
    let (mut r, x) = ([0.0; 6], [1.0, 2.0, 3.0]);
    let e = truss_evaluate(&law, &x, &x, &[0.0; 6], &mut r, None).unwrap_err();
    assert_eq!(e, KernelError::DegenerateReference { qp: 0, det_j0: 0.0 });
    let u = [0.0, 0.0, 0.0, -1.0, 0.0, 0.0];
    let e = truss_evaluate(&law, &[0.0; 3], &[1.0, 0.0, 0.0], &u, &mut r, None).unwrap_err();
    assert_eq!(e, KernelError::InvertedElement { qp: 0, det_f: 0.0 });
}

fn square() -> Vec<[f64; 3]> {
    vec![[0.0; 3], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0], [0.0, 2.0, 0.0]]
}

#[test]
fn truss_set_rejects_bad_input_with_located_messages() {
    let law = AxialLaw::tension_only(1.0e3, 0.01);
    let x = square();
    let e = TrussSet::new("af", "actin", &x, vec![[0, 1], [2, 7]], law).unwrap_err();
    assert!(matches!(
        e,
        TrussError::UnknownNode {
            element: 1,
            node: 7,
            num_nodes: 4,
            ..
        }
    ));
    assert!(
        e.to_string().contains("node 7 does not exist (4 nodes)"),
        "{e}"
    );
    let e = TrussSet::new("af", "actin", &x, vec![[3, 3]], law).unwrap_err();
    assert!(matches!(
        e,
        TrussError::ZeroLength {
            element: 0,
            nodes: [3, 3],
            ..
        }
    ));
    let e = TrussSet::new("af", "actin", &x, vec![[0, 1]], law.with_prestrain(-1.0)).unwrap_err();
    assert!(e.to_string().contains("prestrain must be > -1"), "{e}");
    let e = TrussSet::with_element_laws(
        "af",
        "actin",
        &x,
        vec![[0, 1], [1, 2], [2, 3]],
        vec![law, law],
    )
    .unwrap_err();
    assert!(matches!(
        e,
        TrussError::LawCount {
            expected: 3,
            found: 2,
            ..
        }
    ));
    let mut set = TrussSet::new("af", "actin", &x, vec![[0, 1], [1, 2]], law).unwrap();
    assert!(matches!(
        set.scale_modulus(0.0),
        Err(TrussError::InvalidScale { .. })
    ));
    assert!(set.set_prestrain(-2.0).is_err());
    assert_eq!(set.laws()[0].prestrain, 0.0, "unchanged after the error");
}

#[test]
fn truss_set_outputs_and_statistics_report_each_element() {
    let law = AxialLaw::tension_only(1.0e3, 0.01).with_prestrain(0.24);
    let x = square();
    let mut set =
        TrussSet::new("af", "actin", &x, vec![[0, 1], [1, 2], [2, 3], [3, 0]], law).unwrap();
    set.scale_modulus(1.5).unwrap();
    set.set_prestrain(0.1).unwrap();
    let map = DofMap::translational(4);
    let mut u = vec![0.0; 12];
    // Node 1 moves +0.5 in x, node 3 −1 in y: lengths 2.5, √4.25, √5 (taut) and 1 (slack,
    // ℓ < L_free = 2/1.1).
    u[3] = 0.5;
    u[10] = -1.0;
    let out = set.outputs(&u, &map).unwrap().unwrap();
    assert_eq!(out.kind, ElementKind::Line2);
    assert_eq!(out.connectivity, vec![0, 1, 1, 2, 2, 3, 3, 0]);
    let names: Vec<&str> = out.fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "axial_force_nN",
            "axial_stress_kPa",
            "axial_strain",
            "length_ratio"
        ]
    );
    let ea = 1.5e3 * 0.01;
    let e0 = 2.5 * 1.1 / 2.0 - 1.0;
    assert!((out.fields[0].values[0] - ea * e0).abs() < 1e-12);
    assert!((out.fields[1].values[0] - 1.5e3 * e0).abs() < 1e-9);
    assert!((out.fields[2].values[0] - e0).abs() < 1e-15);
    assert!((out.fields[3].values[0] - 1.25).abs() < 1e-15);
    assert_eq!(out.fields[0].values[3], 0.0);
    assert!((out.fields[2].values[3] - (1.0 * 1.1 / 2.0 - 1.0)).abs() < 1e-15);
    let stats = set.force_statistics(&u, &map).unwrap();
    assert_eq!(
        (stats.family.as_str(), stats.count, stats.in_tension),
        ("actin", 4, 3)
    );
    let f = stats.force.unwrap();
    let forces = &out.fields[0].values;
    assert_eq!(f.max, forces[0]);
    assert_eq!(f.min, 0.0);
    assert!((f.mean - forces.iter().sum::<f64>() / 4.0).abs() < 1e-14);
    let columns = set.scalar_outputs(&u, &map);
    let names: Vec<&str> = columns.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "actin_axial_force_min_nN",
            "actin_axial_force_max_nN",
            "actin_axial_force_mean_nN",
            "actin_axial_stress_max_kPa",
            "actin_axial_strain_max",
            "actin_in_tension"
        ]
    );
    let values: Vec<f64> = columns.iter().map(|(_, v)| *v).collect();
    assert_eq!(values[..3], [f.min, f.max, f.mean]);
    assert!((values[3] - 1.5e3 * e0).abs() < 1e-9);
    assert!((values[4] - e0).abs() < 1e-15);
    assert_eq!(values[5], 3.0);
    set.set_enabled(false);
    assert!(set.scalar_outputs(&u, &map).is_empty());
    assert_eq!(set.num_elements(), 0);
    assert_eq!(set.outputs(&u, &map).unwrap(), None);
    let empty = TrussSet::new("none", "bundle", &x, vec![], law).unwrap();
    assert_eq!(empty.force_statistics(&u, &map).unwrap().force, None);
}
