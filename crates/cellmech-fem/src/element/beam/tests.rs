//! Kernel tests: section constants, linear limit, derivatives, rigid-motion invariance.

use super::*;
use crate::math::rotation::{exp_so3, log_so3, mat_mul};
use crate::verify::tangent::{check_gradient, check_jacobian, symmetry_error};

/// Deterministic uniform numbers in [−1, 1) (64-bit LCG; fixed seed).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
    fn vec3(&mut self, scale: f64) -> [f64; 3] {
        [
            self.next() * scale,
            self.next() * scale,
            self.next() * scale,
        ]
    }
}

fn mt() -> BeamSection {
    BeamSection::hollow_circular(1.2e6, 0.3, 0.025, 0.017).unwrap()
}

/// Two microtubule beams through the three points `x`, with the chord-strain local law.
fn two_element_microtubule(x: &[[f64; 3]; 3]) -> BeamSet {
    let mut set =
        BeamSet::from_coordinates("mts", "microtubule", x, &[[0, 1], [1, 2]], None, mt()).unwrap();
    set.local_strain = LocalStrain::Chord;
    set
}

/// A section with distinct stiffnesses so that a mixed-up index shows.
fn test_section() -> BeamSection {
    BeamSection::new(100.0, 40.0, 0.3, 0.02, 0.05, 0.03).unwrap()
}

fn test_reference() -> BeamReference {
    BeamReference::new([0.1, -0.2, 0.3], [1.0, 0.4, 0.8], Some([0.0, 0.0, 1.0])).unwrap()
}

#[test]
fn beam_section_of_a_microtubule_has_the_spec_stiffnesses() {
    let s = mt();
    assert!(
        (s.axial_stiffness() - 316.67).abs() < 0.01,
        "EA {}",
        s.axial_stiffness()
    );
    let (ei2, ei3) = s.bending_stiffness();
    assert!((ei2 - 0.018090).abs() < 1e-5 && ei2 == ei3, "EI {ei2}");
    assert!((s.shear_modulus - 1.2e6 / 2.6).abs() < 1e-6);
    assert!((s.torsion_j - 2.0 * s.i2).abs() < 1e-20);
    let solid = BeamSection::solid_circular(1.0, 0.0, 2.0).unwrap();
    assert!((solid.area - std::f64::consts::PI).abs() < 1e-14);
    assert!((solid.i3 - std::f64::consts::PI / 4.0).abs() < 1e-14);
}

#[test]
fn beam_section_rejects_invalid_dimensions() {
    assert!(matches!(
        BeamSection::hollow_circular(1.0, 0.3, 0.017, 0.025),
        Err(BeamError::InnerNotSmaller { .. })
    ));
    assert!(matches!(
        BeamSection::hollow_circular(1.0, 0.3, 0.025, 0.0),
        Err(BeamError::NonPositive { .. })
    ));
    assert!(matches!(
        BeamSection::solid_circular(1.0, 0.3, -1.0),
        Err(BeamError::NonPositive { .. })
    ));
    assert!(matches!(
        BeamSection::solid_circular(1.0, 0.7, 1.0),
        Err(BeamError::PoissonRatio(_))
    ));
    assert!(matches!(
        BeamSection::solid_circular(f64::NAN, 0.3, 1.0),
        Err(BeamError::NonPositive { .. })
    ));
    assert!(matches!(
        BeamReference::new([0.0; 3], [1.0, 0.0, 0.0], Some([2.0, 0.0, 0.0])),
        Err(BeamError::UpParallelToAxis { .. })
    ));
    assert!(matches!(
        BeamReference::new([1.0; 3], [1.0; 3], None),
        Err(BeamError::NonPositive { .. })
    ));
}

#[test]
fn beam_reference_triad_is_orthonormal_and_follows_the_axis() {
    let r = BeamReference::new([0.0; 3], [3.0, 4.0, 0.0], None).unwrap();
    assert!((r.length - 5.0).abs() < 1e-15);
    let col = |j: usize| [r.triad[0][j], r.triad[1][j], r.triad[2][j]];
    assert!((col(0)[0] - 0.6).abs() < 1e-15 && (col(0)[1] - 0.8).abs() < 1e-15);
    assert_eq!(col(1), [0.0, 0.0, 1.0]); // automatic up: z, least aligned
    for i in 0..3 {
        for j in 0..3 {
            let d = dot(&col(i), &col(j));
            assert!((d - if i == j { 1.0 } else { 0.0 }).abs() < 1e-15);
        }
    }
    assert!((dot(&cross(&col(0), &col(1)), &col(2)) - 1.0).abs() < 1e-15);
}

#[test]
fn beam_tangent_at_reference_is_the_linear_euler_bernoulli_stiffness() {
    // Element along x, up = y: e2 = y, e3 = z. Bending in the x–y plane uses I3.
    let s = test_section();
    let l = 2.0;
    let r = BeamReference::new([0.0; 3], [l, 0.0, 0.0], Some([0.0, 1.0, 0.0])).unwrap();
    let (mut res, mut k) = ([0.0; 12], [0.0; 144]);
    let energy = beam_evaluate(&s, &r, &[0.0; 12], &mut res, Some(&mut k)).unwrap();
    assert_eq!(energy, 0.0);
    assert!(res.iter().all(|&x| x.abs() < 1e-15));
    let (e, g) = (s.youngs_modulus, s.shear_modulus);
    let kk = |i: usize, j: usize| k[i * 12 + j];
    let close = |a: f64, b: f64| (a - b).abs() < 1e-10 * b.abs().max(1.0);
    assert!(close(kk(0, 0), e * s.area / l) && close(kk(0, 6), -e * s.area / l));
    assert!(close(kk(3, 3), g * s.torsion_j / l) && close(kk(3, 9), -g * s.torsion_j / l));
    // x–y plane: v (1, 7) and θz (5, 11), EI3.
    let ei3 = e * s.i3;
    assert!(close(kk(7, 7), 12.0 * ei3 / l.powi(3)), "{}", kk(7, 7));
    assert!(close(kk(1, 7), -12.0 * ei3 / l.powi(3)));
    assert!(close(kk(5, 5), 4.0 * ei3 / l) && close(kk(5, 11), 2.0 * ei3 / l));
    assert!(close(kk(1, 5), 6.0 * ei3 / l.powi(2)) && close(kk(7, 11), -6.0 * ei3 / l.powi(2)));
    // x–z plane: w (2, 8) and θy (4, 10), EI2; the sign of the coupling flips.
    let ei2 = e * s.i2;
    assert!(close(kk(8, 8), 12.0 * ei2 / l.powi(3)));
    assert!(close(kk(4, 4), 4.0 * ei2 / l) && close(kk(4, 10), 2.0 * ei2 / l));
    assert!(close(kk(2, 4), -6.0 * ei2 / l.powi(2)));
    // No coupling between the planes, axial and torsion at the reference state.
    for (i, j) in [(0, 1), (1, 2), (3, 4), (1, 4), (2, 5), (0, 3), (3, 5)] {
        assert!(kk(i, j).abs() < 1e-12, "K[{i}][{j}] = {}", kk(i, j));
    }
}

fn random_state(rng: &mut Lcg, rot: f64, disp: f64) -> [f64; 12] {
    let mut u = [0.0; 12];
    for (n, range) in [(0, disp), (3, rot), (6, disp), (9, rot)] {
        let v = rng.vec3(range);
        u[n..n + 3].copy_from_slice(&v);
    }
    u
}

#[test]
fn beam_residual_and_tangent_match_finite_differences_at_large_rotations() {
    let (s, r) = (test_section(), test_reference());
    let mut rng = Lcg(7);
    let mut checked = 0;
    for _ in 0..40 {
        // Both nodes turn by up to ~2.5 rad about different axes, plus moderate strains.
        let common = rng.vec3(1.4);
        let mut u = random_state(&mut rng, 0.25, 0.3);
        for c in 0..3 {
            u[3 + c] += common[c];
            u[9 + c] += common[c];
        }
        let (mut res, mut k) = ([0.0; 12], [0.0; 144]);
        if beam_evaluate(&s, &r, &u, &mut res, Some(&mut k)).is_err() {
            continue;
        }
        checked += 1;
        let h = 1e-6;
        let scale = res.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        let kscale = k.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        let energy = |x: &[f64]| {
            let x: [f64; 12] = x.try_into().expect("12 DOFs");
            let e = beam_evaluate(&s, &r, &x, &mut [0.0; 12], None).unwrap();
            // The plain f64 energy agrees with the AD value.
            assert!(
                (beam_energy(LocalStrain::ShallowArch, &s, &r, &x).unwrap() - e).abs()
                    < 1e-12 * e.abs().max(1.0)
            );
            e
        };
        let g = check_gradient(energy, &res, &u, h);
        assert!(g.max_abs_error < 1e-7 * scale, "{g:?}");
        let residual = |x: &[f64], out: &mut [f64]| {
            let x: [f64; 12] = x.try_into().expect("12 DOFs");
            beam_evaluate(&s, &r, &x, out, None).unwrap();
        };
        let j = check_jacobian(residual, &k, &u, h);
        assert!(j.max_abs_error < 1e-6 * kscale, "{j:?}");
        assert!(
            symmetry_error(&k, 12) * k.iter().fold(0.0f64, |m, x| m.max(x.abs())) < 1e-12 * kscale
        );
    }
    assert!(checked >= 35, "only {checked} states evaluated");
}

fn rotate(q: &Mat3<f64>, x: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|k| q[i][k] * x[k]).sum())
}

#[test]
fn beam_rigid_motion_gives_zero_energy_and_residual_and_preserves_deformed_energy() {
    let (s, r) = (test_section(), test_reference());
    let mut rng = Lcg(11);
    for trial in 0..30 {
        // Rigid rotation by up to 3 rad (172°) about a random axis, plus a translation.
        let mut psi = rng.vec3(1.0);
        let n = dot(&psi, &psi).sqrt();
        let angle = 3.0 * (trial as f64 + 1.0) / 30.0;
        psi = psi.map(|c| c / n * angle);
        let q = exp_so3(&psi);
        let t = rng.vec3(2.0);
        let mut u = [0.0; 12];
        for (off, x) in [(0, r.x_a), (6, r.x_b)] {
            let y = rotate(&q, &x);
            for c in 0..3 {
                u[off + c] = y[c] + t[c] - x[c];
                u[off + 3 + c] = psi[c];
            }
        }
        let mut res = [0.0; 12];
        let energy = beam_evaluate(&s, &r, &u, &mut res, None).unwrap();
        assert!(energy.abs() < 1e-20, "angle {angle}: energy {energy}");
        assert!(
            res.iter().all(|x| x.abs() < 1e-11),
            "angle {angle}: {res:?}"
        );

        // A deformed state, then the same rigid motion superposed: same energy.
        let u0 = random_state(&mut rng, 0.3, 0.1);
        let e0 = beam_energy(LocalStrain::ShallowArch, &s, &r, &u0).unwrap();
        let mut u1 = [0.0; 12];
        for (off, x) in [(0, r.x_a), (6, r.x_b)] {
            let x0: [f64; 3] = std::array::from_fn(|c| x[c] + u0[off + c]);
            let y = rotate(&q, &x0);
            let node_rotation = mat_mul(&q, &exp_so3(&[u0[off + 3], u0[off + 4], u0[off + 5]]));
            let theta = log_so3(&node_rotation).unwrap();
            for c in 0..3 {
                u1[off + c] = y[c] + t[c] - x[c];
                u1[off + 3 + c] = theta[c];
            }
        }
        let e1 = beam_energy(LocalStrain::ShallowArch, &s, &r, &u1).unwrap();
        assert!(
            e0 > 1e-3 && (e1 - e0).abs() < 1e-12 * e0,
            "angle {angle}: {e0} vs {e1}"
        );
    }
}

#[test]
fn beam_pure_stretch_and_pure_twist_give_the_closed_form_energies() {
    let s = test_section();
    let l = 1.5;
    let r = BeamReference::new([0.0; 3], [0.0, 0.0, l], None).unwrap();
    let mut u = [0.0; 12];
    u[8] = 0.2; // stretch along z
    let e = beam_energy(LocalStrain::ShallowArch, &s, &r, &u).unwrap();
    let exact = 0.5 * s.axial_stiffness() / l * 0.04;
    assert!((e - exact).abs() < 1e-13 * exact);
    // Twist by a large angle: the log keeps it exact (|θ̄| = 1.2 rad, symmetric ±0.6).
    let mut u = [0.0; 12];
    u[11] = 1.2;
    let e = beam_energy(LocalStrain::ShallowArch, &s, &r, &u).unwrap();
    let exact = 0.5 * s.shear_modulus * s.torsion_j / l * 1.44;
    assert!((e - exact).abs() < 1e-12 * exact, "{e} vs {exact}");
}

#[test]
fn beam_kernel_reports_a_collapsed_chord_as_an_error() {
    let (s, r) = (test_section(), test_reference());
    let mut u = [0.0; 12];
    for c in 0..3 {
        u[6 + c] = r.x_a[c] - r.x_b[c];
    }
    let mut res = [0.0; 12];
    assert!(matches!(
        beam_evaluate(&s, &r, &u, &mut res, None),
        Err(KernelError::InvertedElement { .. })
    ));
    // A local rotation of π about the chord's normal at one end: rejected, not NaN.
    let mut u = [0.0; 12];
    let axis = [r.triad[0][1], r.triad[1][1], r.triad[2][1]];
    for c in 0..3 {
        u[9 + c] = std::f64::consts::PI * axis[c];
    }
    assert!(beam_evaluate(&s, &r, &u, &mut res, None).is_err());
}

#[test]
fn beam_evaluation_time_is_measured() {
    let (s, r) = (mt(), test_reference());
    let mut rng = Lcg(3);
    let u = random_state(&mut rng, 0.5, 0.01);
    let (mut res, mut k) = ([0.0; 12], [0.0; 144]);
    let n = 2000;
    let start = std::time::Instant::now();
    let mut sum = 0.0;
    for _ in 0..n {
        sum += beam_evaluate(&s, &r, &u, &mut res, Some(&mut k)).unwrap();
    }
    let per = start.elapsed().as_secs_f64() / n as f64;
    assert!(sum.is_finite() && sum > 0.0);
    // Generous bound (shared CI cores); the measured value is in docs/beam.md.
    assert!(per < 2e-3, "{per} s per element");
    eprintln!(
        "beam_evaluate with tangent: {:.2} µs per element",
        per * 1e6
    );
}

#[test]
fn beam_set_scalar_outputs_report_the_family_statistics() {
    use crate::dof::DofMap;
    use crate::term::Term;
    // Two collinear elements along x of a microtubule section: stretch the first by 1 %,
    // compress the second by 0.5 %.
    let x = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [4.0, 0.0, 0.0]];
    let section = mt();
    let mut set = two_element_microtubule(&x);
    let map = DofMap::with_counts(&[6, 6, 6]);
    let mut u = vec![0.0; 18];
    u[map.dof(1, 0)] = 0.02;
    u[map.dof(2, 0)] = 0.02 - 0.01;
    let columns = set.scalar_outputs(&u, &map);
    let get = |name: &str| {
        columns
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("no column {name} in {columns:?}"))
            .1
    };
    let ea = section.axial_stiffness();
    assert!((get("microtubule_axial_force_max_nN") - 0.01 * ea).abs() < 1e-9 * ea);
    assert!((get("microtubule_axial_force_min_nN") + 0.005 * ea).abs() < 1e-9 * ea);
    assert!((get("microtubule_axial_force_mean_nN") - 0.0025 * ea).abs() < 1e-9 * ea);
    let stress = get("microtubule_axial_stress_max_kPa");
    assert!((stress - 0.01 * section.youngs_modulus).abs() < 1e-6 * section.youngs_modulus);
    assert_eq!(get("microtubule_in_tension"), 1.0);
    assert_eq!(get("microtubule_in_compression"), 1.0);
    assert!(get("microtubule_bending_moment_max_nN_um").abs() < 1e-12);
    // Round-off-sized strains (1e-14) count as neither tension nor compression.
    let tiny: Vec<f64> = u.iter().map(|v| v * 1e-12).collect();
    let counts = set.force_statistics(&tiny, &map).unwrap();
    assert_eq!((counts.tension, counts.compression), (0, 0));
    set.enabled = false;
    assert!(set.scalar_outputs(&u, &map).is_empty());
}

#[test]
fn a_beam_whose_reference_morphs_in_a_step_is_stress_free_at_the_target_and_stiff_from_there() {
    use crate::dof::DofMap;
    use crate::linsolve::FaerSparseSolver;
    use crate::solve::{Motion, NullObserver, Problem, Step};
    // A bent two-element cantilever along x, clamped at node 0. Its stress-free geometry
    // moves in step 0 to a longer, differently bent one (the target); nothing else loads
    // it, so it must end exactly there, unstressed. In step 1 its tip is pulled along the
    // target's last chord: the force is EA·δ/L of the target element (a chord-strain law).
    let x = [[0.0, 0.0, 0.0], [2.0, 0.3, 0.0], [4.0, 0.0, 0.0]];
    let y = [[0.0, 0.0, 0.0], [2.2, 0.1, 0.2], [4.5, 0.4, 0.1]];
    let section = mt();
    let mut set = two_element_microtubule(&x);
    set.morph_reference_through(0, &[(1.0, &y[..])]).unwrap();
    let map = DofMap::with_counts(&[6, 6, 6]);
    let mut problem = Problem::new(
        map.clone(),
        vec![Box::new(set)],
        Box::new(FaerSparseSolver::default()),
    )
    .unwrap();
    problem.set_length_scale(5.0);
    let mut grow = Step::new("grow");
    grow.prescribed = (0..6).map(|c| (map.dof(0, c), Motion::Hold)).collect();
    grow.control.initial_increment = 0.25;
    problem.run_step(&grow, &mut NullObserver).unwrap();
    for n in 1..3 {
        for c in 0..3 {
            let moved = x[n][c] + problem.u()[map.dof(n, c)];
            assert!(
                (moved - y[n][c]).abs() < 1e-9,
                "node {n} component {c}: {moved} vs {}",
                y[n][c]
            );
        }
    }
    let set = problem.terms()[0].scalar_outputs(problem.u(), &map);
    let max_force = set
        .iter()
        .filter(|(n, _)| n.contains("axial_force"))
        .map(|(_, v)| v.abs())
        .fold(0.0, f64::max);
    assert!(max_force < 1e-9 * section.axial_stiffness(), "{set:?}");
    // Step 1: pull the tip by δ along the last target chord.
    let chord: [f64; 3] = std::array::from_fn(|i| y[2][i] - y[1][i]);
    let length = chord.iter().map(|c| c * c).sum::<f64>().sqrt();
    let delta = 1e-4;
    let mut pull = Step::new("pull");
    pull.prescribed = (0..6).map(|c| (map.dof(0, c), Motion::Hold)).collect();
    pull.prescribed
        .extend((0..3).map(|c| (map.dof(2, c), Motion::By(delta * chord[c] / length))));
    pull.prescribed
        .extend((0..3).map(|c| (map.dof(1, c), Motion::Hold)));
    pull.control.initial_increment = 1.0;
    problem.run_step(&pull, &mut NullObserver).unwrap();
    let force: f64 = (0..3)
        .map(|c| problem.reaction(map.dof(2, c)) * chord[c] / length)
        .sum();
    let expected = section.axial_stiffness() * delta / length;
    assert!(
        (force - expected).abs() < 1e-3 * expected,
        "tip force {force} vs EA·δ/L {expected} (L = {length} of the target)"
    );
}

#[test]
fn the_residual_alone_equals_the_residual_computed_with_the_tangent() {
    // Residual-only evaluations use first-order duals, the tangent's hyperduals: the same
    // derivatives, on random large deformations with both local strain measures.
    let (section, reference) = (test_section(), test_reference());
    let mut rng = Lcg(11);
    for strain in [LocalStrain::ShallowArch, LocalStrain::Chord] {
        for _ in 0..20 {
            let mut u = [0.0; BEAM_DOFS];
            for (i, x) in u.iter_mut().enumerate() {
                *x = rng.next() * if i % 6 < 3 { 0.3 } else { 1.2 };
            }
            let (mut alone, mut with) = ([0.0; BEAM_DOFS], [0.0; BEAM_DOFS]);
            let mut tangent = [0.0; BEAM_DOFS * BEAM_DOFS];
            let e1 =
                beam_evaluate_with(strain, &section, &reference, &u, &mut alone, None).unwrap();
            let e2 = beam_evaluate_with(
                strain,
                &section,
                &reference,
                &u,
                &mut with,
                Some(&mut tangent),
            )
            .unwrap();
            assert_eq!(e1, e2);
            let scale = with.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for i in 0..BEAM_DOFS {
                assert!(
                    (alone[i] - with[i]).abs() <= 1e-13 * scale,
                    "{i}: {alone:?} {with:?}"
                );
            }
        }
    }
}
