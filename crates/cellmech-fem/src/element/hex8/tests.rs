//! Verification of the hex8 kernel: finite-difference consistency, invariance, exactness
//! for homogeneous deformations, analytic uniaxial stress, volumetric-constraint count.

use super::*;
use crate::material::NeoHookean;
use crate::verify::analytic::uniaxial_stress;
use crate::verify::tangent::{check_gradient, check_jacobian, symmetry_error};
use nalgebra::{DMatrix, Rotation3, Vector3};

const FORMS: [Hex8Formulation; 2] = [
    Hex8Formulation::MeanDilatation,
    Hex8Formulation::Displacement,
];

/// Small deterministic generator (xorshift64*), uniform in [-1, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let v = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
        2.0 * (v as f64 / (1u64 << 53) as f64) - 1.0
    }
}

/// A distorted (non-parallelepiped) element of size ~2 µm, positively oriented.
fn distorted() -> [[f64; 3]; 8] {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut x = [[0.0; 3]; 8];
    for (a, n) in NODE_NATURAL.iter().enumerate() {
        for i in 0..3 {
            x[a][i] = n[i] + 0.25 * rng.next() + 0.3 * i as f64;
        }
    }
    x
}

fn homogeneous_u(x0: &[[f64; 3]; 8], f: &Matrix3<f64>) -> [f64; 24] {
    let mut u = [0.0; 24];
    for a in 0..8 {
        let xa = Vector3::from(x0[a]);
        let ua = f * xa - xa;
        for i in 0..3 {
            u[3 * a + i] = ua[i];
        }
    }
    u
}

fn random_large_u(seed: u64) -> [f64; 24] {
    let mut rng = Rng(seed);
    let x0 = distorted();
    let f = Matrix3::new(1.35, 0.25, -0.1, -0.15, 0.8, 0.2, 0.1, -0.2, 1.1);
    let rot = Rotation3::from_scaled_axis(Vector3::new(0.4, -0.3, 0.7));
    let mut u = homogeneous_u(&x0, &(rot.matrix() * f));
    for v in u.iter_mut() {
        *v += 0.15 * rng.next();
    }
    u
}

fn material(ratio: f64) -> NeoHookean {
    NeoHookean::new(0.8, 0.8 * ratio).expect("valid material")
}

fn eval(
    r: &Hex8Reference,
    m: &NeoHookean,
    form: Hex8Formulation,
    u: &[f64],
    res: &mut [f64; 24],
    k: Option<&mut [f64; 576]>,
) -> f64 {
    let mut uu = [0.0; 24];
    uu.copy_from_slice(u);
    hex8_evaluate(r, m, form, &uu, res, k).expect("admissible state")
}

#[test]
fn finite_difference_consistency_both_formulations() {
    let r = Hex8Reference::new(&distorted()).expect("valid reference");
    for ratio in [1.0, 1000.0] {
        let m = material(ratio);
        for form in FORMS {
            for seed in [7u64, 12345] {
                let u = random_large_u(seed);
                let mut res = [0.0; 24];
                let mut k = [0.0; 576];
                eval(&r, &m, form, &u, &mut res, Some(&mut k));
                let h = 1e-6;
                let g =
                    check_gradient(|x| eval(&r, &m, form, x, &mut [0.0; 24], None), &res, &u, h);
                assert!(
                    g.passes(1e-6),
                    "{form:?} K/G={ratio}: energy→residual {g:?}"
                );
                let j = check_jacobian(
                    |x, out| {
                        let mut rr = [0.0; 24];
                        eval(&r, &m, form, x, &mut rr, None);
                        out.copy_from_slice(&rr);
                    },
                    &k,
                    &u,
                    h,
                );
                assert!(
                    j.passes(1e-6),
                    "{form:?} K/G={ratio}: residual→tangent {j:?}"
                );
                let s = symmetry_error(&k, 24);
                eprintln!(
                    "{form:?} K/G={ratio} seed={seed}: grad rel {:.2e}, jac rel {:.2e}, sym {s:.1e}",
                    g.relative_error, j.relative_error
                );
                assert!(s < 1e-13, "{form:?}: symmetry error {s:e}");
                // Residual without tangent equals residual with tangent.
                let mut res2 = [0.0; 24];
                eval(&r, &m, form, &u, &mut res2, None);
                assert_eq!(res, res2);
            }
        }
    }
}

#[test]
fn formulations_differ_under_nonhomogeneous_deformation() {
    let r = Hex8Reference::new(&distorted()).expect("valid reference");
    let m = material(1000.0);
    let u = random_large_u(99);
    let e_md = eval(
        &r,
        &m,
        Hex8Formulation::MeanDilatation,
        &u,
        &mut [0.0; 24],
        None,
    );
    let e_d = eval(
        &r,
        &m,
        Hex8Formulation::Displacement,
        &u,
        &mut [0.0; 24],
        None,
    );
    // Jensen: V0 U(mean J) ≤ Σ U(J_q) w0 for convex U, strict for non-constant J.
    assert!(e_md < e_d, "MD {e_md} vs displacement {e_d}");
}

#[test]
fn zero_state_and_rigid_rotations() {
    let x0 = distorted();
    let r = Hex8Reference::new(&x0).expect("valid reference");
    let m = material(1000.0);
    let scale = m.bulk_modulus * r.volume();
    let rotations = [
        Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2),
        Rotation3::from_scaled_axis(Vector3::new(1.1, -0.7, 2.3)),
        Rotation3::identity(),
    ];
    for form in FORMS {
        for rot in &rotations {
            let u = homogeneous_u(&x0, rot.matrix());
            let mut res = [0.0; 24];
            let e = eval(&r, &m, form, &u, &mut res, None);
            let fmax = res.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            assert!(e.abs() < 1e-13 * scale, "{form:?}: energy {e:e}");
            assert!(fmax < 1e-12 * scale, "{form:?}: residual {fmax:e}");
        }
        let mut res = [1.0; 24];
        let e = eval(&r, &m, form, &[0.0; 24], &mut res, None);
        assert_eq!(e, 0.0);
        assert!(res.iter().all(|v| v.abs() < 1e-14 * scale));
    }
}

#[test]
fn homogeneous_deformation_is_exact_on_distorted_element() {
    let x0 = distorted();
    let r = Hex8Reference::new(&x0).expect("valid reference");
    let m = material(50.0);
    let f = Matrix3::new(1.4, 0.3, -0.2, 0.1, 0.7, 0.15, -0.25, 0.05, 1.2);
    let u = homogeneous_u(&x0, &f);
    let sigma = m.cauchy_stress(&f);
    // Independent closed form: σ = G J^{-5/3} dev(b) + K (J − 1) 1.
    let j = f.determinant();
    let b = f * f.transpose();
    let closed = (b - Matrix3::identity() * (b.trace() / 3.0))
        * (m.shear_modulus * j.powf(-5.0 / 3.0))
        + Matrix3::identity() * (m.bulk_modulus * (j - 1.0));
    assert!((sigma - closed).norm() < 1e-13 * closed.norm());
    let psi = 0.5 * m.shear_modulus * (j.powf(-2.0 / 3.0) * b.trace() - 3.0)
        + 0.5 * m.bulk_modulus * (j - 1.0).powi(2);
    for form in FORMS {
        let resp = hex8_response(&r, &m, form, &u).expect("admissible");
        let c = resp.cauchy;
        let got = Matrix3::new(c[0], c[3], c[5], c[3], c[1], c[4], c[5], c[4], c[2]);
        let err = (got - closed).norm() / closed.norm();
        eprintln!("{form:?}: homogeneous Cauchy rel error {err:.2e}");
        assert!(err < 1e-10, "{form:?}: Cauchy relative error {err:e}");
        assert!((resp.volume_ratio - j).abs() < 1e-12);
        assert!((resp.pressure + closed.trace() / 3.0).abs() < 1e-10 * closed.norm());
        let mut res = [0.0; 24];
        let e = eval(&r, &m, form, &u, &mut res, None);
        let rel = (e - psi * r.volume()).abs() / (psi * r.volume());
        assert!(rel < 1e-12, "{form:?}: energy relative error {rel:e}");
        // Internal forces are self-equilibrated.
        for i in 0..3 {
            let s: f64 = (0..8).map(|a| res[3 * a + i]).sum();
            assert!(s.abs() < 1e-12 * m.bulk_modulus * r.volume());
        }
    }
}

#[test]
fn reference_volume_is_exact() {
    // Parallelepiped with edge vectors e1, e2, e3: V = det[e1 e2 e3].
    let e = Matrix3::new(2.0, 0.3, 0.1, 0.0, 1.5, -0.2, 0.2, 0.0, 3.0);
    let mut x0 = [[0.0; 3]; 8];
    for (a, n) in NODE_NATURAL.iter().enumerate() {
        let p = e * Vector3::new(0.5 * (n[0] + 1.0), 0.5 * (n[1] + 1.0), 0.5 * (n[2] + 1.0));
        x0[a] = [p[0], p[1], p[2]];
    }
    let r = Hex8Reference::new(&x0).expect("valid");
    assert!((r.volume() - e.determinant()).abs() < 1e-13 * e.determinant());
}

#[test]
fn uniaxial_response_matches_analytic() {
    let x0 = distorted();
    let r = Hex8Reference::new(&x0).expect("valid reference");
    let m = material(20.0);
    for lam in [0.7, 1.5, 2.2] {
        let s = uniaxial_stress(&m, lam).expect("valid");
        let f = Matrix3::from_diagonal(&Vector3::new(lam, s.free_stretch, s.free_stretch));
        let u = homogeneous_u(&x0, &f);
        for form in FORMS {
            let resp = hex8_response(&r, &m, form, &u).expect("admissible");
            let rel = (resp.cauchy[0] - s.cauchy).abs() / s.cauchy.abs();
            eprintln!("{form:?} λ={lam}: uniaxial σ_xx rel error {rel:.2e}");
            assert!(rel < 1e-10, "{form:?} λ={lam}: σ_xx rel error {rel:e}");
            for k in 1..6 {
                assert!(
                    resp.cauchy[k].abs() < 1e-10 * s.cauchy.abs(),
                    "component {k}"
                );
            }
            assert!((resp.von_mises - s.cauchy.abs()).abs() < 1e-10 * s.cauchy.abs());
            let expected_log = lam.ln().max(s.free_stretch.ln());
            assert!((resp.max_principal_log_strain - expected_log).abs() < 1e-12);
            assert!((resp.volume_ratio - s.volume_ratio).abs() < 1e-12);
            assert!((resp.pressure + s.cauchy / 3.0).abs() < 1e-10 * s.cauchy.abs());
        }
    }
}

/// Number of eigenvalues of the u = 0 tangent above `threshold`.
fn stiff_count(form: Hex8Formulation, ratio: f64, threshold: f64) -> (usize, Vec<f64>) {
    let r = Hex8Reference::new(&distorted()).expect("valid reference");
    let m = material(ratio);
    let mut k = [0.0; 576];
    eval(&r, &m, form, &[0.0; 24], &mut [0.0; 24], Some(&mut k));
    let mat = DMatrix::from_row_slice(24, 24, &k);
    let mut ev: Vec<f64> = mat.symmetric_eigen().eigenvalues.iter().copied().collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    (ev.iter().filter(|&&e| e > threshold).count(), ev)
}

#[test]
fn mean_dilatation_has_exactly_one_volumetric_constraint() {
    let ratio = 1e6;
    let g = 0.8;
    // Shear eigenvalues scale like G·L ≈ 1; volumetric ones like K·L ≈ 1e6.
    let threshold = 1e3 * g;
    let (n_md, ev_md) = stiff_count(Hex8Formulation::MeanDilatation, ratio, threshold);
    let (n_d, ev_d) = stiff_count(Hex8Formulation::Displacement, ratio, threshold);
    eprintln!(
        "stiff eigenvalues: MD {n_md} (largest {:.3e}, next {:.3e}); displacement {n_d}",
        ev_md[0], ev_md[1]
    );
    assert_eq!(n_md, 1, "MD eigenvalues {ev_md:?}");
    assert!(n_d > 1, "displacement eigenvalues {ev_d:?}");
    // Six rigid-body modes: six (numerically) zero eigenvalues, the rest positive.
    for ev in [&ev_md, &ev_d] {
        let zeros = ev.iter().filter(|e| e.abs() < 1e-8 * ev[0]).count();
        assert_eq!(zeros, 6, "{ev:?}");
        assert!(ev.iter().all(|&e| e > -1e-8 * ev[0]));
    }
}

#[test]
fn inverted_and_degenerate_elements_are_reported() {
    let x0 = distorted();
    let r = Hex8Reference::new(&x0).expect("valid reference");
    let m = material(10.0);
    // Push node 6 through the opposite corner: the element turns inside out there.
    let mut u = [0.0; 24];
    for i in 0..3 {
        u[18 + i] = 2.5 * (x0[0][i] - x0[6][i]);
    }
    for form in FORMS {
        let err = hex8_evaluate(&r, &m, form, &u, &mut [0.0; 24], None).unwrap_err();
        assert!(
            matches!(err, KernelError::InvertedElement { .. }),
            "{err:?}"
        );
        let err = hex8_response(&r, &m, form, &u).unwrap_err();
        assert!(matches!(err, KernelError::InvertedElement { .. }));
    }
    // Mirror image (wrong node order) and collapsed element.
    let mut mirrored = x0;
    mirrored.swap(0, 4);
    mirrored.swap(1, 5);
    mirrored.swap(2, 6);
    mirrored.swap(3, 7);
    assert!(matches!(
        Hex8Reference::new(&mirrored),
        Err(KernelError::DegenerateReference { .. })
    ));
    let mut flat = x0;
    for x in flat.iter_mut() {
        x[2] = 0.0;
    }
    assert!(matches!(
        Hex8Reference::new(&flat),
        Err(KernelError::DegenerateReference { .. })
    ));
    let mut nan = x0;
    nan[3][1] = f64::NAN;
    assert!(Hex8Reference::new(&nan).is_err());
    let mut un = [0.0; 24];
    un[5] = f64::NAN;
    assert!(hex8_evaluate(
        &r,
        &m,
        Hex8Formulation::Displacement,
        &un,
        &mut [0.0; 24],
        None
    )
    .is_err());
}

#[test]
fn formulation_serde_names() {
    assert_eq!(Hex8Formulation::default(), Hex8Formulation::MeanDilatation);
    let s = serde_json::to_string(&Hex8Formulation::MeanDilatation).expect("serialize");
    assert_eq!(s, "\"mean-dilatation\"");
    let d: Hex8Formulation = serde_json::from_str("\"displacement\"").expect("deserialize");
    assert_eq!(d, Hex8Formulation::Displacement);
    assert!(serde_json::from_str::<Hex8Formulation>("\"q1p0\"").is_err());
}

/// Timing of one evaluation with tangent: `cargo test --release -p cellmech-fem
/// hex8_timing -- --ignored --nocapture`.
#[test]
#[ignore]
fn hex8_timing() {
    let r = Hex8Reference::new(&distorted()).expect("valid reference");
    let m = material(100.0);
    let u = random_large_u(3);
    let mut res = [0.0; 24];
    let mut k = [0.0; 576];
    let n = 200_000;
    for form in FORMS {
        let t = std::time::Instant::now();
        let mut acc = 0.0;
        for _ in 0..n {
            acc += hex8_evaluate(
                &r,
                &m,
                form,
                std::hint::black_box(&u),
                &mut res,
                Some(&mut k),
            )
            .expect("admissible");
            acc += k[100];
        }
        let per = t.elapsed().as_secs_f64() / n as f64;
        let t2 = std::time::Instant::now();
        for _ in 0..n {
            acc += hex8_evaluate(&r, &m, form, std::hint::black_box(&u), &mut res, None)
                .expect("admissible");
        }
        let per2 = t2.elapsed().as_secs_f64() / n as f64;
        eprintln!(
            "{form:?}: {:.2} µs with tangent, {:.2} µs residual only (checksum {acc:e})",
            per * 1e6,
            per2 * 1e6
        );
        assert!(acc.is_finite());
    }
}

#[test]
fn log_strain_between_two_states_is_that_of_the_relative_deformation() {
    // From a prestretched state F₁ = diag(1.2, 1, 0.9) to F₂: the strain measured from F₁
    // is that of F₂F₁⁻¹, whatever F₁ was; a rigid rotation after F₁ strains nothing.
    let x0 = distorted();
    let r = Hex8Reference::new(&x0).expect("valid reference");
    let f1 = Matrix3::from_diagonal(&Vector3::new(1.2, 1.0, 0.9));
    let u1 = homogeneous_u(&x0, &f1);
    let f2 = Matrix3::from_diagonal(&Vector3::new(1.5, 1.0, 0.9));
    let strain = hex8_max_log_strain_between(&r, &u1, &homogeneous_u(&x0, &f2)).unwrap();
    assert!((strain - (1.5f64 / 1.2).ln()).abs() < 1e-12, "{strain}");
    let rotation = *Rotation3::from_euler_angles(0.3, -0.2, 0.7).matrix();
    let rotated = homogeneous_u(&x0, &(rotation * f1));
    let strain = hex8_max_log_strain_between(&r, &u1, &rotated).unwrap();
    assert!(strain.abs() < 1e-12, "{strain}");
    // From the mesh (u_from = 0) it is the ordinary measure.
    let zero = [0.0; 24];
    let strain = hex8_max_log_strain_between(&r, &zero, &u1).unwrap();
    assert!((strain - 1.2f64.ln()).abs() < 1e-12);
}

#[test]
fn corner_jacobians_see_a_fold_the_gauss_points_miss() {
    // Unit cube with its corner node 6 at (1, 1, 1) pushed down to z = −0.2, below the
    // bottom face. At corner 6 the columns of ∂x/∂ξ are half its edges to nodes 7, 5 and 2:
    // (1, 0, −1.2)/2, (0, 1, −1.2)/2 and (0, 0, −0.2)/2, so det = −0.2/8 against 1/8 in the
    // reference: the map folds over there (ratio −0.2), while det F stays positive at every
    // Gauss point.
    let x0: [[f64; 3]; 8] = std::array::from_fn(|a| NODE_NATURAL[a].map(|s| 0.5 * (s + 1.0)));
    let reference = Hex8Reference::new(&x0).expect("unit cube");
    let mut u = [0.0; 24];
    u[3 * 6 + 2] = -1.2;
    let response = hex8_response(
        &reference,
        &material(10.0),
        Hex8Formulation::MeanDilatation,
        &u,
    )
    .expect("det F > 0 at every Gauss point");
    assert!(response.volume_ratio > 0.0);
    let ratio = hex8_min_corner_jacobian_ratio(&x0, &u);
    assert!((ratio - (-0.2)).abs() < 1e-12, "ratio {ratio}");
    // A homogeneous deformation of a distorted element: det F at every corner; a rigid
    // motion: 1.
    let x0 = distorted();
    let f = Matrix3::new(1.35, 0.25, -0.1, -0.15, 0.8, 0.2, 0.1, -0.2, 1.1);
    let ratio = hex8_min_corner_jacobian_ratio(&x0, &homogeneous_u(&x0, &f));
    assert!(
        (ratio - f.determinant()).abs() < 1e-12,
        "{ratio} against {}",
        f.determinant()
    );
    let rot = Rotation3::from_scaled_axis(Vector3::new(0.4, -0.3, 0.7));
    let ratio = hex8_min_corner_jacobian_ratio(&x0, &homogeneous_u(&x0, rot.matrix()));
    assert!((ratio - 1.0).abs() < 1e-12);
}

/// The element's nodal forces are self-equilibrated in any state: they sum to zero and
/// their moment about the origin, Σ xₐ × fₐ with xₐ the current positions, vanishes (the
/// energy depends on the deformation through b = F Fᵀ and J only, so it is unchanged by a
/// rigid rotation). An element that breaks this loads a free body's supports.
#[test]
fn nodal_forces_have_no_resultant_and_no_moment() {
    let x0 = distorted();
    let r = Hex8Reference::new(&x0).expect("valid reference");
    for form in FORMS {
        for seed in [3, 17, 99] {
            let u = random_large_u(seed);
            let mut res = [0.0; 24];
            eval(&r, &material(50.0), form, &u, &mut res, None);
            let scale = res.iter().map(|v| v.abs()).fold(0.0, f64::max);
            let mut force = Vector3::zeros();
            let mut moment = Vector3::zeros();
            for a in 0..8 {
                let x = Vector3::new(
                    x0[a][0] + u[3 * a],
                    x0[a][1] + u[3 * a + 1],
                    x0[a][2] + u[3 * a + 2],
                );
                let f = Vector3::new(res[3 * a], res[3 * a + 1], res[3 * a + 2]);
                force += f;
                moment += x.cross(&f);
            }
            assert!(
                force.norm() < 1e-12 * scale,
                "{form:?}: resultant {force:?}"
            );
            assert!(
                moment.norm() < 1e-12 * scale,
                "{form:?} seed {seed}: moment {moment:?} (force scale {scale})"
            );
        }
    }
}
