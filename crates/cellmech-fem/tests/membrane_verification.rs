//! Membrane verification against closed-form solutions, solved with the full Newton driver.
//!
//! GOAL: the incompressible neo-Hookean membrane reproduces uniaxial and equibiaxial stretch,
//! passes the patch test on distorted meshes under large out-of-plane rotation, and inflates
//! a spherical balloon along the analytic pressure–stretch curve through its limit point.
//! REFERENCE: W = μ/2 (λ₁² + λ₂² + λ₁⁻²λ₂⁻² − 3); uniaxial nominal tension μH(λ − λ⁻²) with
//! λ₂ = λ^(−1/2); equibiaxial μH(λ − λ⁻⁵); balloon p = 2μH/R₀ (λ⁻¹ − λ⁻⁷), maximum at
//! λ = 7^(1/6) with p = (12/7) 7^(−1/6) μH/R₀ ≈ 1.2394 μH/R₀.

use std::collections::HashMap;

use cellmech_fem::dof::DofMap;
use cellmech_fem::element::membrane::MembraneSet;
use cellmech_fem::element::pressure::{PressureLoad, SurfaceVolume, VolumeControl};
use cellmech_fem::linsolve::DenseSolver;
use cellmech_fem::mesh::ElementKind;
use cellmech_fem::solve::{IncrementReport, Motion, NullObserver, Observer, Problem, Step};
use cellmech_fem::term::Term;

/// A flat sheet [0, lx] × [0, ly] of nx × ny quads (or two triangles per quad) with interior
/// nodes displaced by `distortion` times a fixed pattern.
fn sheet(
    nx: usize,
    ny: usize,
    lx: f64,
    ly: f64,
    distortion: f64,
    kind: ElementKind,
) -> (Vec<[f64; 3]>, Vec<usize>) {
    let id = |i: usize, j: usize| i + (nx + 1) * j;
    let mut nodes = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            let interior = i > 0 && i < nx && j > 0 && j < ny;
            let s = if interior { distortion } else { 0.0 };
            let (dx, dy) = (
                (1.3 * (i * 7 + j * 3) as f64).sin(),
                (0.9 * (i * 5 + j * 11) as f64).cos(),
            );
            nodes.push([
                lx * (i as f64 + s * dx) / nx as f64,
                ly * (j as f64 + s * dy) / ny as f64,
                0.0,
            ]);
        }
    }
    let mut conn = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let q = [id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)];
            if kind == ElementKind::Quad4 {
                conn.extend(q);
            } else {
                conn.extend([q[0], q[1], q[2], q[0], q[2], q[3]]);
            }
        }
    }
    (nodes, conn)
}

fn membrane_problem(
    nodes: &[[f64; 3]],
    kind: ElementKind,
    conn: Vec<usize>,
    mu: f64,
    h: f64,
) -> Problem {
    let set = MembraneSet::new("sheet", kind, conn, nodes, mu, h).unwrap();
    let terms: Vec<Box<dyn Term>> = vec![Box::new(set)];
    Problem::new(
        DofMap::translational(nodes.len()),
        terms,
        Box::new(DenseSolver::default()),
    )
    .unwrap()
}

#[test]
fn membrane_uniaxial_stretch_matches_incompressible_closed_form() {
    // GOAL: a 4 × 2 µm sheet pulled to λ = 2.5 along x, free laterally.
    // BCS: x = 0 edge u_x = 0, node (0,0) u_y = 0, x = L edge u_x = (λ−1)L, all u_z = 0.
    let (mu, h, lx, ly, lambda) = (0.67, 0.2, 4.0, 2.0, 2.5);
    for kind in [ElementKind::Quad4, ElementKind::Tri3] {
        let (nodes, conn) = sheet(4, 2, lx, ly, 0.0, kind);
        let mut p = membrane_problem(&nodes, kind, conn, mu, h);
        let mut step = Step::new("pull");
        let mut right = Vec::new();
        for (n, x) in nodes.iter().enumerate() {
            step.prescribed.push((3 * n + 2, Motion::Hold));
            if x[0] == 0.0 {
                step.prescribed.push((3 * n, Motion::Hold));
            } else if x[0] == lx {
                step.prescribed
                    .push((3 * n, Motion::To((lambda - 1.0) * lx)));
                right.push(3 * n);
            }
        }
        step.prescribed.push((1, Motion::Hold));
        p.run_step(&step, &mut NullObserver).unwrap();
        let force = p.reaction_sum(right.iter().copied());
        let expected = mu * h * ly * (lambda - lambda.powi(-2));
        let lateral = lambda.powf(-0.5);
        let mut worst = 0.0f64;
        for (n, x) in nodes.iter().enumerate() {
            worst = worst.max((p.u()[3 * n + 1] - (lateral - 1.0) * x[1]).abs());
        }
        eprintln!(
            "uniaxial {kind:?}: force rel. error {:.2e}, lateral displacement error {worst:.2e}",
            ((force - expected) / expected).abs()
        );
        assert!(
            ((force - expected) / expected).abs() < 1e-8 && worst < 1e-9,
            "{kind:?}: force {force} vs {expected}, lateral error {worst:e}"
        );
    }
}

#[test]
fn membrane_equibiaxial_stretch_matches_closed_form_on_distorted_mesh() {
    // GOAL: equibiaxial λ = 1.8 imposed on the boundary of a distorted 3 × 3 mesh.
    let (mu, h, l, lambda) = (2.0, 0.1, 3.0, 1.8);
    let (nodes, conn) = sheet(3, 3, l, l, 0.25, ElementKind::Quad4);
    let mut p = membrane_problem(&nodes, ElementKind::Quad4, conn, mu, h);
    let mut step = Step::new("biaxial");
    let mut right = Vec::new();
    for (n, x) in nodes.iter().enumerate() {
        step.prescribed.push((3 * n + 2, Motion::Hold));
        let boundary = x[0] == 0.0 || x[0] == l || x[1] == 0.0 || x[1] == l;
        if boundary {
            for c in 0..2 {
                step.prescribed
                    .push((3 * n + c, Motion::To((lambda - 1.0) * x[c])));
            }
        }
        if x[0] == l {
            right.push(3 * n);
        }
    }
    p.run_step(&step, &mut NullObserver).unwrap();
    let tension = p.reaction_sum(right.iter().copied()) / l;
    let expected = mu * h * (lambda - lambda.powi(-5));
    eprintln!(
        "equibiaxial: tension rel. error {:.2e}",
        ((tension - expected) / expected).abs()
    );
    assert!(
        ((tension - expected) / expected).abs() < 1e-8,
        "tension per reference length {tension} vs {expected}"
    );
}

fn rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let k = axis.map(|a| a / n);
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
fn membrane_patch_test_reproduces_homogeneous_deformation_under_large_rotation() {
    // GOAL: x = Q F X + c on the boundary of a distorted mesh is reproduced inside exactly.
    // Step 1 stretches in plane (interior u_z held: a flat unstressed membrane has no
    // out-of-plane stiffness); step 2 rotates the tensioned patch 70° out of plane with all
    // interior DOFs free.
    let f = [[1.5, 0.3], [-0.1, 1.3]];
    let q = rotation([1.0, -0.5, 0.3], 70f64.to_radians());
    let shift = [0.4, -0.2, 1.1];
    for kind in [ElementKind::Quad4, ElementKind::Tri3] {
        let (nodes, conn) = sheet(4, 3, 4.0, 3.0, 0.3, kind);
        let mut p = membrane_problem(&nodes, kind, conn, 1.0, 0.2);
        let boundary = |x: &[f64; 3]| x[0] == 0.0 || x[0] == 4.0 || x[1] == 0.0 || x[1] == 3.0;
        let stretched = |x: &[f64; 3]| -> [f64; 3] {
            [
                f[0][0] * x[0] + f[0][1] * x[1],
                f[1][0] * x[0] + f[1][1] * x[1],
                0.0,
            ]
        };
        let mut s1 = Step::new("stretch");
        let mut s2 = Step::new("rotate");
        for (n, x) in nodes.iter().enumerate() {
            let y = stretched(x);
            let z: [f64; 3] =
                std::array::from_fn(|i| (0..3).map(|j| q[i][j] * y[j]).sum::<f64>() + shift[i]);
            if boundary(x) {
                for c in 0..3 {
                    s1.prescribed.push((3 * n + c, Motion::To(y[c] - x[c])));
                    s2.prescribed.push((3 * n + c, Motion::To(z[c] - x[c])));
                }
            } else {
                s1.prescribed.push((3 * n + 2, Motion::Hold));
            }
        }
        p.run_step(&s1, &mut NullObserver).unwrap();
        p.run_step(&s2, &mut NullObserver).unwrap();
        let mut worst = 0.0f64;
        let mut worst_residual = 0.0f64;
        for (n, x) in nodes.iter().enumerate().filter(|(_, x)| !boundary(x)) {
            let y = stretched(x);
            for i in 0..3 {
                let exact = (0..3).map(|j| q[i][j] * y[j]).sum::<f64>() + shift[i] - x[i];
                worst = worst.max((p.u()[3 * n + i] - exact).abs());
                worst_residual = worst_residual.max(p.reaction(3 * n + i).abs());
            }
        }
        eprintln!("patch {kind:?}: interior error {worst:.2e}, residual {worst_residual:.2e}");
        assert!(
            worst < 1e-10 && worst_residual < 1e-10,
            "{kind:?}: interior displacement error {worst:e}, residual {worst_residual:e}"
        );
    }
}

/// One octant of a cubed sphere of radius `r0`: the three quarter faces x, y, z = 1 of the
/// cube [−1, 1]³, each split into m × m cells with equiangular spacing, projected on the
/// sphere. Returns nodes, outward quads and, per node, which coordinates are zero (on a
/// symmetry plane).
fn cubed_sphere_octant(m: usize, r0: f64) -> (Vec<[f64; 3]>, Vec<usize>, Vec<[bool; 3]>) {
    let mut index: HashMap<[usize; 3], usize> = HashMap::new();
    let mut nodes = Vec::new();
    let mut on_plane = Vec::new();
    let mut conn = Vec::new();
    let t = |i: usize| (std::f64::consts::FRAC_PI_4 * i as f64 / m as f64).tan();
    for axis in 0..3 {
        // (axis, d1, d2) cyclic so that d1 × d2 = +axis.
        let (d1, d2) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut id = |i: usize, j: usize| -> usize {
            let mut key = [0; 3];
            key[axis] = m;
            key[d1] = i;
            key[d2] = j;
            *index.entry(key).or_insert_with(|| {
                let mut p = [0.0; 3];
                p[axis] = 1.0;
                p[d1] = t(i);
                p[d2] = t(j);
                let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                nodes.push(p.map(|c| r0 * c / n));
                on_plane.push(key.map(|k| k == 0));
                nodes.len() - 1
            })
        };
        for j in 0..m {
            for i in 0..m {
                conn.extend([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    (nodes, conn, on_plane)
}

/// Records (λ, p) at each converged increment: λ = (V/V₀)^(1/3) from the enclosed volume.
struct Inflation {
    surface: SurfaceVolume,
    v0: f64,
    pressure_dof: usize,
    curve: Vec<(f64, f64)>,
}

impl Observer for Inflation {
    fn on_increment(&mut self, problem: &Problem, _report: &IncrementReport<'_>) {
        let v = self.surface.volume(problem.u(), problem.dof_map());
        self.curve
            .push(((v / self.v0).cbrt(), problem.u()[self.pressure_dof]));
    }
}

#[test]
fn membrane_balloon_inflation_follows_analytic_curve_through_limit_point() {
    // GOAL: volume-controlled inflation of a neo-Hookean spherical membrane to λ = 1.9.
    // MESH: octant of a cubed sphere, 3 × 8 × 8 quads; symmetry planes x, y, z = 0.
    // PARAMETERS: R₀ = 5 µm, H = 0.01 µm, μ = 1000 kPa (μH/R₀ = 2 kPa).
    // BCS: u_k = 0 on the plane k = 0; the pressure is the Lagrange multiplier of the volume.
    let (m, r0, h, mu) = (8, 5.0, 0.01, 1000.0);
    let (nodes, conn, on_plane) = cubed_sphere_octant(m, r0);
    let aux = nodes.len();
    let mut all = nodes.clone();
    all.push([0.0; 3]);
    let membrane =
        MembraneSet::new("balloon", ElementKind::Quad4, conn.clone(), &all, mu, h).unwrap();
    let surface = SurfaceVolume::new("balloon", ElementKind::Quad4, conn, &all).unwrap();
    let control = VolumeControl::new(surface.clone(), aux).unwrap();
    let map = DofMap::translational(all.len());
    let (p_dof, dv_dof) = (control.pressure_dof(&map), control.volume_change_dof(&map));
    let v0 = control.reference_volume();
    let terms: Vec<Box<dyn Term>> = vec![Box::new(membrane), Box::new(control)];
    let mut problem = Problem::new(map, terms, Box::new(DenseSolver::default())).unwrap();
    let lambda_max: f64 = 1.9;
    let mut step = Step::new("inflate");
    step.prescribed
        .push((dv_dof, Motion::To(v0 * (lambda_max.powi(3) - 1.0))));
    for (n, planes) in on_plane.iter().enumerate() {
        for c in 0..3 {
            if planes[c] {
                step.prescribed.push((3 * n + c, Motion::Hold));
            }
        }
    }
    step.control.initial_increment = 0.005;
    step.control.max_increment = 0.01;
    let mut rec = Inflation {
        surface,
        v0,
        pressure_dof: p_dof,
        curve: Vec::new(),
    };
    problem.run_step(&step, &mut rec).unwrap();
    // The multiplier is the pressure, and so is the reaction on the volume DOF.
    let p_end = problem.u()[p_dof];
    assert!((problem.reaction(dv_dof) - p_end).abs() < 1e-12 * p_end.abs());

    let scale = mu * h / r0;
    let analytic = |l: f64| 2.0 * scale * (1.0 / l - l.powi(-7));
    let mut worst = 0.0f64;
    for &(l, p) in &rec.curve {
        worst = worst.max(((p - analytic(l)) / analytic(l)).abs());
    }
    let last = rec.curve.last().unwrap().0;
    assert!((last - lambda_max).abs() < 1e-9, "final stretch {last}");
    assert!(worst < 0.01, "largest relative pressure error {worst:e}");
    // Limit point: parabola through the largest recorded pressure and its neighbours.
    let k = (1..rec.curve.len() - 1)
        .max_by(|&a, &b| rec.curve[a].1.total_cmp(&rec.curve[b].1))
        .unwrap();
    let [(x0, y0), (x1, y1), (x2, y2)] = [rec.curve[k - 1], rec.curve[k], rec.curve[k + 1]];
    let d01 = (y1 - y0) / (x1 - x0);
    let d12 = (y2 - y1) / (x2 - x1);
    let curvature = (d12 - d01) / (x2 - x0);
    let l_peak = 0.5 * (x0 + x1) - d01 / (2.0 * curvature);
    let p_peak = y1 + d01 * (l_peak - x1) + curvature * (l_peak - x0) * (l_peak - x1);
    let (l_exact, p_exact) = (
        7f64.powf(1.0 / 6.0),
        12.0 / 7.0 * 7f64.powf(-1.0 / 6.0) * scale,
    );
    assert!(
        ((l_peak - l_exact) / l_exact).abs() < 0.01 && ((p_peak - p_exact) / p_exact).abs() < 0.01,
        "limit point at λ = {l_peak:.5} (exact {l_exact:.5}), p = {p_peak:.5} (exact {p_exact:.5}); worst curve error {worst:e}"
    );
    // Report the numbers on failure-free runs too (visible with --nocapture).
    eprintln!(
        "balloon: {} increments, worst |Δp|/p = {worst:.3e}, peak λ = {l_peak:.5} (exact {l_exact:.5}), p_max/(μH/R₀) = {:.5} (exact {:.5})",
        rec.curve.len(),
        p_peak / scale,
        p_exact / scale
    );
}

#[test]
fn membrane_balloon_under_prescribed_pressure_reaches_analytic_stretch() {
    // GOAL: pressure control below the limit point, pressure changed between steps through
    // the term's handle (each step applies its pressure in full).
    // MESH/BCS as the volume-controlled balloon; p = 0.3, 0.6, 0.9 of the analytic maximum.
    let (m, r0, h, mu) = (8, 5.0, 0.01, 1000.0);
    let (nodes, conn, on_plane) = cubed_sphere_octant(m, r0);
    let membrane =
        MembraneSet::new("balloon", ElementKind::Quad4, conn.clone(), &nodes, mu, h).unwrap();
    let surface = SurfaceVolume::new("balloon", ElementKind::Quad4, conn, &nodes).unwrap();
    let v0 = surface.reference_volume();
    let load = PressureLoad::new(surface.clone(), 0.0);
    let handle = load.pressure_handle();
    let terms: Vec<Box<dyn Term>> = vec![Box::new(membrane), Box::new(load)];
    let map = DofMap::translational(nodes.len());
    let mut problem = Problem::new(map, terms, Box::new(DenseSolver::default())).unwrap();
    let scale = mu * h / r0;
    let analytic = |l: f64| 2.0 * scale * (1.0 / l - l.powi(-7));
    let l_peak = 7f64.powf(1.0 / 6.0);
    for fraction in [0.3, 0.6, 0.9] {
        let p = fraction * analytic(l_peak);
        handle.set(p);
        let mut step = Step::new(format!("p = {fraction} p_max"));
        // The pressure is not ramped within a step, so the step is one increment: later
        // increments would start in equilibrium, where the relative energy criterion
        // |δ·R|/|δ₀·R₀| compares round-off with round-off and never converges.
        step.control.initial_increment = 1.0;
        step.control.max_increment = 1.0;
        for (n, planes) in on_plane.iter().enumerate() {
            for c in (0..3).filter(|&c| planes[c]) {
                step.prescribed.push((3 * n + c, Motion::Hold));
            }
        }
        problem.run_step(&step, &mut NullObserver).unwrap();
        // Analytic stretch on the stable branch 1 < λ < 7^(1/6), by bisection.
        let (mut lo, mut hi) = (1.0, l_peak);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if analytic(mid) < p {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let lambda = (surface.volume(problem.u(), problem.dof_map()) / v0).cbrt();
        let error = ((lambda - lo) / lo).abs();
        eprintln!("pressure control: p = {fraction} p_max, λ = {lambda:.5} (exact {lo:.5}), rel. error {error:.2e}");
        assert!(error < 0.005, "λ = {lambda} vs analytic {lo}");
    }
}
