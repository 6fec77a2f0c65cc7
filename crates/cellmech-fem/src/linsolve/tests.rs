//! Tests of [`FaerSparseSolver`] against the [`LinearSolver`] contract.

use super::ordering::is_permutation;
use super::test_matrices::{hex_elasticity, relative_residual, TestMatrix};
use super::*;

fn rhs(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| ((i * 37 + 11) % 101) as f64 / 101.0 - 0.4)
        .collect()
}

fn solve(solver: &mut FaerSparseSolver, m: &TestMatrix) -> (FactorInfo, f64, Vec<f64>) {
    let info = solver.factorize(&m.values).expect("factorize");
    let b = rhs(m.pattern.n);
    let mut x = b.clone();
    solver.solve_in_place(&mut x).expect("solve");
    (info, relative_residual(&m.pattern, &m.values, &x, &b), x)
}

fn dense(m: &TestMatrix) -> nalgebra::DMatrix<f64> {
    let p = &m.pattern;
    let mut a = nalgebra::DMatrix::zeros(p.n, p.n);
    for c in 0..p.n {
        for k in p.col_ptr[c]..p.col_ptr[c + 1] {
            a[(p.row_idx[k], c)] = m.values[k];
            a[(c, p.row_idx[k])] = m.values[k];
        }
    }
    a
}

fn shift_diagonal(m: &TestMatrix, sigma: f64) -> TestMatrix {
    let mut s = m.clone();
    for c in 0..m.pattern.n {
        s.values[m.pattern.col_ptr[c]] -= sigma;
    }
    s
}

#[test]
fn spd_elasticity_solves_to_machine_precision_with_every_ordering() {
    let m = hex_elasticity(8, 7, 6, 3.0, 0.45);
    for ordering in [
        FillOrdering::NestedDissection,
        FillOrdering::Amd,
        FillOrdering::Natural,
    ] {
        let mut solver = FaerSparseSolver::new(2).with_ordering(ordering);
        solver.analyze(&m.pattern).expect("analyze");
        let perm = solver.permutation().expect("permutation");
        assert!(is_permutation(perm, m.pattern.n), "{ordering:?}");
        let (info, res, _) = solve(&mut solver, &m);
        assert_eq!(
            info,
            FactorInfo {
                method: FactorMethod::Cholesky,
                negative_pivots: Some(0)
            }
        );
        assert!(res < 1e-10, "{ordering:?}: residual {res:e}");
    }
}

#[test]
fn solution_matches_dense_reference() {
    let m = hex_elasticity(3, 3, 3, 1.0, 0.3);
    let mut solver = FaerSparseSolver::new(1);
    solver.analyze(&m.pattern).expect("analyze");
    let (_, _, x) = solve(&mut solver, &m);
    let reference = dense(&m)
        .cholesky()
        .expect("SPD")
        .solve(&nalgebra::DVector::from_vec(rhs(m.pattern.n)));
    let err = x
        .iter()
        .zip(reference.iter())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let scale = reference.iter().map(|v| v.abs()).fold(0.0, f64::max);
    assert!(err < 1e-10 * scale, "max error {err:e} vs |x| {scale:e}");
}

#[test]
fn indefinite_matrix_falls_back_to_ldlt_and_reports_the_inertia() {
    let spd = hex_elasticity(3, 3, 2, 1.0, 0.3);
    // Shift between two well-separated eigenvalues so that the inertia is unambiguous.
    let mut eig: Vec<f64> = dense(&spd)
        .symmetric_eigenvalues()
        .iter()
        .copied()
        .collect();
    eig.sort_by(f64::total_cmp);
    let k = (eig.len() / 3..eig.len() / 2)
        .max_by(|&i, &j| (eig[i + 1] - eig[i]).total_cmp(&(eig[j + 1] - eig[j])))
        .expect("non-empty range");
    let sigma = 0.5 * (eig[k] + eig[k + 1]);
    let m = shift_diagonal(&spd, sigma);
    let mut solver = FaerSparseSolver::new(2);
    solver.analyze(&m.pattern).expect("analyze");
    let (info, res, _) = solve(&mut solver, &m);
    assert_eq!(info.method, FactorMethod::Ldlt);
    assert_eq!(
        info.negative_pivots,
        Some(k + 1),
        "eigenvalues below the shift: {}",
        k + 1
    );
    assert!(res < 1e-10, "residual {res:e}");
}

/// A small hex-elasticity matrix and the same shifted by 0.37 of its mean diagonal
/// (indefinite, well conditioned).
fn definite_and_indefinite() -> (TestMatrix, TestMatrix) {
    let spd = hex_elasticity(4, 3, 3, 1.0, 0.3);
    let diag_mean = (0..spd.pattern.n)
        .map(|c| spd.values[spd.pattern.col_ptr[c]])
        .sum::<f64>()
        / spd.pattern.n as f64;
    let indefinite = shift_diagonal(&spd, 0.37 * diag_mean);
    (spd, indefinite)
}

/// The methods a sequence of definite (`true`) and indefinite matrices is factorised with.
fn methods_of(solver: &mut FaerSparseSolver, definite: &[bool]) -> Vec<FactorMethod> {
    let (spd, indefinite) = definite_and_indefinite();
    solver.analyze(&spd.pattern).expect("analyze");
    definite
        .iter()
        .map(|&d| {
            let m = if d { &spd } else { &indefinite };
            let (info, res, _) = solve(solver, m);
            assert!(res < 1e-10, "residual {res:e} with {:?}", info.method);
            info.method
        })
        .collect()
}

#[test]
fn after_up_to_three_indefinite_matrices_a_definite_one_gets_cholesky_again() {
    use FactorMethod::{Cholesky, Ldlt};
    for mixed in [false, true] {
        let mut solver = FaerSparseSolver::new(2).with_mixed_precision(mixed);
        let methods = methods_of(&mut solver, &[true, false, true, true]);
        assert_eq!(
            methods,
            vec![Cholesky, Ldlt, Cholesky, Cholesky],
            "mixed {mixed}"
        );
        let mut solver = FaerSparseSolver::new(2).with_mixed_precision(mixed);
        let methods = methods_of(&mut solver, &[false, false, false, true]);
        assert_eq!(methods, vec![Ldlt, Ldlt, Ldlt, Cholesky], "mixed {mixed}");
        // A definite matrix tried in single precision and resolved there: no fallback.
        if mixed {
            let stats = solver.mixed_precision_stats();
            assert_eq!((stats.single_factorizations, stats.fallbacks), (1, 0));
        }
    }
}

#[test]
fn a_long_run_of_indefinite_matrices_tries_cholesky_only_at_powers_of_two() {
    use FactorMethod::{Cholesky, Ldlt};
    for mixed in [false, true] {
        // Five indefinite in a row: the sixth matrix (definite) is not tried with Cholesky
        // (streak 5), the pivoted factorisation finds it definite, and the next is Cholesky.
        let mut solver = FaerSparseSolver::new(2).with_mixed_precision(mixed);
        let seq = [false, false, false, false, false, true, true];
        let methods = methods_of(&mut solver, &seq);
        assert_eq!(
            methods,
            vec![Ldlt, Ldlt, Ldlt, Ldlt, Ldlt, Ldlt, Cholesky],
            "mixed {mixed}"
        );
        // Four in a row: the fifth (streak 4, a power of two) is tried, and is Cholesky.
        let mut solver = FaerSparseSolver::new(2).with_mixed_precision(mixed);
        let methods = methods_of(&mut solver, &[false, false, false, false, true]);
        assert_eq!(
            methods,
            vec![Ldlt, Ldlt, Ldlt, Ldlt, Cholesky],
            "mixed {mixed}"
        );
    }
}

#[test]
fn repeated_factorizations_on_one_pattern_give_the_right_answer_each_time() {
    let base = hex_elasticity(6, 5, 4, 1.0, 0.3);
    let mut solver = FaerSparseSolver::new(2);
    solver.analyze(&base.pattern).expect("analyze");
    let (_, _, x1) = solve(&mut solver, &base);
    for (scale, sigma) in [(2.0, 0.0), (0.25, -0.1), (7.0, -0.3), (1.0, 0.0)] {
        let mut m = base.clone();
        m.values.iter_mut().for_each(|v| *v *= scale);
        let m = shift_diagonal(&m, sigma);
        let (info, res, x) = solve(&mut solver, &m);
        assert!(
            res < 1e-10,
            "scale {scale}, shift {sigma}: residual {res:e}"
        );
        assert_eq!(info.method, FactorMethod::Cholesky);
        if sigma == 0.0 {
            // Scaling A by s scales the solution by 1/s.
            let err = x
                .iter()
                .zip(&x1)
                .map(|(a, b)| (a * scale - b).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-10 * x1.iter().map(|v| v.abs()).fold(0.0, f64::max));
        }
    }
}

#[test]
fn a_pivot_below_the_tolerance_keeps_the_pivoted_factor_when_it_solves_accurately() {
    // A well-conditioned indefinite matrix with a tolerance so strict that some pivots of
    // the intranode LDLᵀ fall below it: the probe solve shows the factor resolves the
    // matrix, so it is kept (before: LU, about 15 times slower on the cell models).
    let (spd, m) = definite_and_indefinite();
    let mut strict = FaerSparseSolver::new(2).with_pivot_tolerance(0.5);
    strict.analyze(&m.pattern).expect("analyze");
    let (info, res, x) = solve(&mut strict, &m);
    assert_eq!(info.method, FactorMethod::Ldlt);
    assert!(res < 1e-10, "residual {res:e}");
    // The same solution and inertia as with the default tolerance.
    let mut plain = FaerSparseSolver::new(2);
    plain.analyze(&m.pattern).expect("analyze");
    let (plain_info, _, plain_x) = solve(&mut plain, &m);
    assert_eq!(info.negative_pivots, plain_info.negative_pivots);
    let diff = x
        .iter()
        .zip(&plain_x)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(diff < 1e-10 * plain_x.iter().map(|v| v.abs()).fold(0.0, f64::max));
    // The strict tolerance did flag a pivot: with it, Cholesky of the SPD matrix fails.
    let mut spd_strict = FaerSparseSolver::new(2).with_pivot_tolerance(0.5);
    spd_strict.analyze(&spd.pattern).expect("analyze");
    let (spd_info, spd_res, _) = solve(&mut spd_strict, &spd);
    assert_eq!(spd_info.method, FactorMethod::Ldlt, "{spd_info:?}");
    assert!(spd_res < 1e-10, "residual {spd_res:e}");
}

#[test]
fn singular_matrices_return_singular_not_panic() {
    // Graph Laplacian of a 3-D grid (rows sum to zero): singular positive semi-definite.
    let (nx, ny, nz) = (5, 4, 3);
    let id = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
    let mut edges = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if i + 1 < nx {
                    edges.push([id(i, j, k), id(i + 1, j, k)]);
                }
                if j + 1 < ny {
                    edges.push([id(i, j, k), id(i, j + 1, k)]);
                }
                if k + 1 < nz {
                    edges.push([id(i, j, k), id(i, j, k + 1)]);
                }
            }
        }
    }
    let n = nx * ny * nz;
    let pattern = SparsityPattern::from_cliques(n, edges.iter().map(|e| &e[..]));
    let mut values = vec![0.0; pattern.nnz()];
    for [a, b] in &edges {
        let (lo, hi) = (*a.min(b), *a.max(b));
        for (r, c, v) in [(lo, lo, 1.0), (hi, hi, 1.0), (hi, lo, -1.0)] {
            values[pattern.position(r, c).expect("in pattern")] += v;
        }
    }
    let mut solver = FaerSparseSolver::new(2);
    solver.analyze(&pattern).expect("analyze");
    let result = solver.factorize(&values);
    assert!(
        matches!(result, Err(LinSolveError::Singular(_))),
        "{result:?}"
    );
    let mut x = vec![1.0; n];
    assert!(matches!(
        solver.solve_in_place(&mut x),
        Err(LinSolveError::Usage(_))
    ));

    // An SPD matrix with one equation decoupled and zero: exactly singular.
    let m = hex_elasticity(3, 3, 3, 1.0, 0.3);
    let mut values = m.values.clone();
    let dead = 17;
    for c in 0..m.pattern.n {
        for k in m.pattern.col_ptr[c]..m.pattern.col_ptr[c + 1] {
            if c == dead || m.pattern.row_idx[k] == dead {
                values[k] = 0.0;
            }
        }
    }
    solver.analyze(&m.pattern).expect("analyze");
    match solver.factorize(&values) {
        Err(LinSolveError::Singular(msg)) => {
            // A zero pivot leaves the pivoted factor no finite solve: LU is tried.
            assert!(
                msg.contains("Cholesky") && msg.contains("LU: ") && !msg.contains("LU not tried"),
                "{msg}"
            )
        }
        other => panic!("expected Singular, got {other:?}"),
    }
    // The solver stays usable: the original matrix factorises again.
    let (info, res, _) = solve(&mut solver, &m);
    assert!(
        res < 1e-10 && info.method != FactorMethod::Lu,
        "{info:?} {res:e}"
    );
}

/// A 60-equation chain (tridiagonal 2, −1, held at both ends: positive definite) beside a
/// separate 2x2 block `[[1, 1], [1, 1 + δ]]`: one eigenvalue about δ/2, the rest O(1).
fn chain_beside_near_singular_block(delta: f64) -> (SparsityPattern, Vec<f64>) {
    let chain = 60;
    let mut cliques: Vec<Vec<usize>> = (0..chain - 1).map(|i| vec![i, i + 1]).collect();
    cliques.push(vec![chain, chain + 1]);
    let pattern = SparsityPattern::from_cliques(chain + 2, cliques.iter().map(|c| &c[..]));
    let mut values = vec![0.0; pattern.nnz()];
    let mut add = |r: usize, c: usize, v: f64| {
        values[pattern.position(r.max(c), r.min(c)).expect("in pattern")] += v;
    };
    for i in 0..chain {
        add(i, i, 2.0);
        if i + 1 < chain {
            add(i + 1, i, -1.0);
        }
    }
    add(chain, chain, 1.0);
    add(chain + 1, chain, 1.0);
    add(chain + 1, chain + 1, 1.0 + delta);
    (pattern, values)
}

#[test]
fn a_matrix_singular_to_working_accuracy_is_reported_without_trying_lu() {
    // δ = 1e-13: the pivoted factor completes with a pivot of about 1e-13 (below the
    // 1e-12 tolerance) and its refined probe solve is off by about 1e-16/1e-13 along the
    // near-null vector: above the 1e-6 acceptance, far below 1. The matrix is singular
    // to working accuracy; LU could not do better and is not tried.
    let (pattern, values) = chain_beside_near_singular_block(1e-13);
    let mut solver = FaerSparseSolver::new(1);
    solver.analyze(&pattern).expect("analyze");
    match solver.factorize(&values) {
        Err(LinSolveError::Singular(msg)) => {
            assert!(msg.contains("probe forward error"), "{msg}");
            assert!(
                msg.contains("LU not tried") && !msg.contains("LU: "),
                "{msg}"
            );
        }
        other => panic!("expected Singular, got {other:?}"),
    }
    // With δ = 1e-6 the same structure is merely ill-conditioned (4e6): factorised.
    let (pattern, values) = chain_beside_near_singular_block(1e-6);
    solver.analyze(&pattern).expect("analyze");
    let info = solver.factorize(&values).expect("factorize");
    assert_ne!(info.method, FactorMethod::Lu, "{info:?}");
}

#[test]
fn misuse_returns_usage_errors() {
    let m = hex_elasticity(2, 2, 2, 1.0, 0.3);
    let mut solver = FaerSparseSolver::default();
    assert!(matches!(
        solver.factorize(&m.values),
        Err(LinSolveError::Usage(_))
    ));
    let mut x = vec![0.0; m.pattern.n];
    assert!(matches!(
        solver.solve_in_place(&mut x),
        Err(LinSolveError::Usage(_))
    ));
    solver.analyze(&m.pattern).expect("analyze");
    assert!(matches!(
        solver.solve_in_place(&mut x),
        Err(LinSolveError::Usage(_))
    ));
    assert!(matches!(
        solver.factorize(&m.values[1..]),
        Err(LinSolveError::Usage(_))
    ));
    solver.factorize(&m.values).expect("factorize");
    assert!(matches!(
        solver.solve_in_place(&mut x[1..]),
        Err(LinSolveError::Usage(_))
    ));
    // Malformed patterns: upper-triangle entry, missing diagonal.
    let bad = SparsityPattern {
        n: 2,
        col_ptr: vec![0, 1, 3],
        row_idx: vec![0, 0, 1],
    };
    assert!(matches!(solver.analyze(&bad), Err(LinSolveError::Usage(_))));
    let bad = SparsityPattern {
        n: 2,
        col_ptr: vec![0, 1, 1],
        row_idx: vec![1],
    };
    assert!(matches!(solver.analyze(&bad), Err(LinSolveError::Usage(_))));
}

#[test]
fn one_and_two_threads_agree() {
    let m = hex_elasticity(7, 6, 6, 1.0, 0.3);
    let mut solutions = Vec::new();
    for threads in [1, 2] {
        let mut solver = FaerSparseSolver::new(threads);
        solver.analyze(&m.pattern).expect("analyze");
        solutions.push(solve(&mut solver, &m).2);
    }
    let err = solutions[0]
        .iter()
        .zip(&solutions[1])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(err < 1e-10 * solutions[0].iter().map(|v| v.abs()).fold(0.0, f64::max));
}

#[test]
fn nested_dissection_fills_less_than_amd_on_a_3d_grid() {
    let m = hex_elasticity(14, 14, 14, 1.0, 0.3);
    let mut fill = Vec::new();
    for ordering in [FillOrdering::NestedDissection, FillOrdering::Amd] {
        let mut solver = FaerSparseSolver::new(2).with_ordering(ordering);
        solver.analyze(&m.pattern).expect("analyze");
        let info = solver.analysis_info().expect("info");
        assert!(
            info.nnz_l <= info.stored_l,
            "exact count below the stored count"
        );
        fill.push(info.nnz_l);
    }
    assert!(
        fill[0] < fill[1],
        "ND nnz(L) {} vs AMD {}",
        fill[0],
        fill[1]
    );
}

fn relative_distance(x: &[f64], y: &[f64]) -> f64 {
    let d: f64 = x.iter().zip(y).map(|(a, b)| (a - b).powi(2)).sum();
    let s: f64 = y.iter().map(|b| b * b).sum();
    (d / s).sqrt()
}

fn double_and_mixed(m: &TestMatrix) -> (Vec<f64>, Vec<f64>, FactorInfo, MixedPrecisionStats) {
    let mut double = FaerSparseSolver::new(1);
    double.analyze(&m.pattern).expect("analyze");
    let (_, _, x64) = solve(&mut double, m);
    let mut mixed = FaerSparseSolver::new(1).with_mixed_precision(true);
    mixed.analyze(&m.pattern).expect("analyze");
    let (info, _, x) = solve(&mut mixed, m);
    (x64, x, info, mixed.mixed_precision_stats())
}

#[test]
fn mixed_precision_refines_a_single_precision_solve_to_the_tolerance() {
    // Nearly incompressible (K/G = 5000): a single-precision solve alone is off by ~1e-3.
    let m = hex_elasticity(8, 7, 6, 3.0, 0.4999);
    let (x64, x, info, stats) = double_and_mixed(&m);
    assert_eq!(info.method, FactorMethod::Cholesky);
    assert_eq!(stats.single_factorizations, 1, "{stats:?}");
    assert_eq!(stats.fallbacks, 0, "{stats:?}");
    // The first correction was above the tolerance (so the refinement was needed), and the
    // refined solution is the double-precision one to within it.
    assert!(stats.refinement_steps >= 2, "{stats:?}");
    let error = relative_distance(&x, &x64);
    assert!(error <= MIXED_SOLVE_TOLERANCE, "error {error:e}");
    assert!(error > 1e-14, "single precision left no trace: {error:e}");
}

/// Relative errors (against `x64`) of the single-precision factor's solution and of `steps`
/// steps of stationary iterative refinement `x += M⁻¹(b − A x)` after it, `M⁻¹` being the
/// unrefined single-precision solve (what the mixed-precision solver did before it
/// refined with conjugate gradients).
fn stationary_refinement_errors(m: &TestMatrix, x64: &[f64], steps: usize) -> Vec<f64> {
    let mut single = FaerSparseSolver::new(1).with_mixed_precision(true);
    single.analyze(&m.pattern).expect("analyze");
    single.factorize(&m.values).expect("factorize");
    let b = rhs(m.pattern.n);
    let mut x = b.clone();
    single.solve_approximately_in_place(&mut x).expect("solve");
    let mut errors = vec![relative_distance(&x, x64)];
    let mut r = vec![0.0; b.len()];
    for _ in 0..steps {
        m.pattern.sym_mul(&m.values, &x, &mut r);
        r.iter_mut().zip(&b).for_each(|(r, b)| *r = b - *r);
        single.solve_approximately_in_place(&mut r).expect("solve");
        x.iter_mut().zip(&r).for_each(|(x, d)| *x += d);
        errors.push(relative_distance(&x, x64));
    }
    assert_eq!(single.mixed_precision_stats().single_factorizations, 1);
    errors
}

#[test]
fn conjugate_gradients_keep_single_precision_where_stationary_refinement_stalls() {
    // K/G = 1e6: single precision still factorises the block, but its solve is off by
    // ~2e-1 and stationary refinement gains less than the 4x per step the solver used to
    // demand (it fell back to double precision here); conjugate gradients with the
    // single-precision factor as preconditioner get to the tolerance in a few iterations.
    let m = hex_elasticity(8, 7, 6, 3.0, 0.4999995);
    let (x64, x, info, stats) = double_and_mixed(&m);
    let stationary = stationary_refinement_errors(&m, &x64, 2);
    assert!(stationary[0] > 1e-2, "{stationary:?}");
    for w in stationary.windows(2) {
        assert!(
            w[1] * 4.0 > w[0],
            "stationary refinement contracts 4x: {stationary:?}"
        );
    }
    assert_eq!(info.method, FactorMethod::Cholesky);
    assert_eq!(stats.single_factorizations, 1, "{stats:?}");
    assert_eq!(stats.fallbacks, 0, "{stats:?}");
    assert!(
        (3..=MIXED_MAX_ITERATIONS).contains(&stats.refinement_steps),
        "{stats:?}"
    );
    let error = relative_distance(&x, &x64);
    assert!(error <= MIXED_SOLVE_TOLERANCE, "error {error:e}");
}

/// Uncoupled pairs of unknowns, pair k with the matrix `[[s², −c s t], [−c s t, t²]]`,
/// `c = √(1 − pivots[k])`: scaled to a unit diagonal, its Cholesky pivots are 1 and
/// `pivots[k]` (a pair of stiff springs in series, nearly a mechanism).
fn near_mechanism_pairs(pivots: &[f64]) -> TestMatrix {
    let n = 2 * pivots.len();
    let pairs: Vec<[usize; 2]> = (0..pivots.len()).map(|k| [2 * k, 2 * k + 1]).collect();
    let pattern = SparsityPattern::from_cliques(n, pairs.iter().map(|e| &e[..]));
    let mut values = vec![0.0; pattern.nnz()];
    for (k, &pivot) in pivots.iter().enumerate() {
        let (s, t) = (1.0 + k as f64 * 0.37, 3.0 - k as f64 * 0.011);
        let first = pattern.col_ptr[2 * k];
        assert_eq!(pattern.row_idx[first + 1], 2 * k + 1);
        values[first] = s * s;
        values[first + 1] = -(1.0 - pivot).sqrt() * s * t;
        values[pattern.col_ptr[2 * k + 1]] = t * t;
    }
    TestMatrix { pattern, values }
}

#[test]
fn single_precision_pivots_of_a_few_roundoffs_are_left_to_the_conjugate_gradients() {
    // Pivots from 2e-7 to 1e-6 of the unit diagonal (the cell tangents have them down to
    // 3.5e-7): single precision resolves each to a few units of its roundoff (6e-8), so
    // M⁻¹A has eigenvalues from about 0.7 to 1.3, which CG takes in a few iterations. The
    // solver used to refuse such a factor (a floor of 1e-6 on the pivots).
    let pivots: Vec<f64> = (0..100)
        .map(|k| 2e-7 * 5f64.powf(k as f64 / 99.0))
        .collect();
    let m = near_mechanism_pairs(&pivots);
    let (x64, x, info, stats) = double_and_mixed(&m);
    assert_eq!(info.method, FactorMethod::Cholesky);
    assert_eq!(stats.single_factorizations, 1, "{stats:?}");
    assert_eq!(stats.fallbacks, 0, "{stats:?}");
    assert!(stats.refinement_steps >= 3, "{stats:?}");
    let error = relative_distance(&x, &x64);
    assert!(error <= MIXED_SOLVE_TOLERANCE, "error {error:e}");
    // Pivots of half a roundoff: single precision rounds them to zero or nothing it can
    // use, and the double factorisation takes over.
    let m = near_mechanism_pairs(&[0.5, 3e-8, 1e-3]);
    let (x64, x, info, stats) = double_and_mixed(&m);
    assert_eq!(info.method, FactorMethod::Cholesky);
    assert_eq!(
        (stats.single_factorizations, stats.fallbacks),
        (0, 1),
        "{stats:?}"
    );
    let error = relative_distance(&x, &x64);
    assert!(
        error <= 1e-12,
        "the fallback solves in double precision: {error:e}"
    );
}

#[test]
fn mixed_precision_falls_back_to_double_where_single_precision_cannot_resolve_the_matrix() {
    // K/G = 5e6: a condition number near 1/ε₃₂; the single-precision Cholesky breaks down.
    let m = hex_elasticity(8, 7, 6, 3.0, 0.4999999);
    let (x64, x, info, stats) = double_and_mixed(&m);
    assert_eq!(info.method, FactorMethod::Cholesky);
    assert_eq!(stats.single_factorizations, 0, "{stats:?}");
    assert_eq!(stats.fallbacks, 1, "{stats:?}");
    let error = relative_distance(&x, &x64);
    assert!(
        error <= 1e-12,
        "the fallback solves in double precision: {error:e}"
    );
}

#[test]
fn conjugate_gradients_that_run_out_of_iterations_fall_back_to_double_precision() {
    // The K/G = 1e6 block takes more than 3 iterations (above): with at most 3, the solve
    // is redone in double precision from its right-hand side, and so are later ones.
    let m = hex_elasticity(8, 7, 6, 3.0, 0.4999995);
    let mut double = FaerSparseSolver::new(1);
    double.analyze(&m.pattern).expect("analyze");
    let (_, _, x64) = solve(&mut double, &m);
    let mut mixed = FaerSparseSolver::new(1)
        .with_mixed_precision(true)
        .with_mixed_max_iterations(3);
    mixed.analyze(&m.pattern).expect("analyze");
    let (info, _, x) = solve(&mut mixed, &m);
    assert_eq!(info.method, FactorMethod::Cholesky);
    let stats = mixed.mixed_precision_stats();
    assert_eq!(
        (
            stats.single_factorizations,
            stats.refinement_steps,
            stats.fallbacks
        ),
        (1, 3, 1),
        "{stats:?}"
    );
    assert_eq!(x, x64, "the fallback is the double-precision solve");
    let (_, _, x) = solve(&mut mixed, &m);
    assert_eq!(x, x64);
    assert_eq!(
        mixed.mixed_precision_stats(),
        stats,
        "double precision from then on"
    );
}

#[test]
fn mixed_precision_on_an_indefinite_matrix_takes_the_pivoted_path() {
    let m = shift_diagonal(&hex_elasticity(5, 5, 5, 1.0, 0.3), 0.5);
    let mut mixed = FaerSparseSolver::new(1).with_mixed_precision(true);
    mixed.analyze(&m.pattern).expect("analyze");
    let (info, residual, _) = solve(&mut mixed, &m);
    assert_eq!(info.method, FactorMethod::Ldlt);
    assert!(info.negative_pivots.unwrap_or(0) > 0);
    assert!(residual < 1e-10, "residual {residual:e}");
    // Indefiniteness is no failure of single precision: the next positive definite
    // matrix is factorised in single precision (the fallback policy).
    assert_eq!(mixed.mixed_precision_stats().fallbacks, 0);
    let spd = hex_elasticity(5, 5, 5, 1.0, 0.3);
    let (info, residual, _) = solve(&mut mixed, &spd);
    assert_eq!(info.method, FactorMethod::Cholesky);
    assert!(residual < 1e-6, "residual {residual:e}");
    assert_eq!(mixed.mixed_precision_stats().single_factorizations, 1);
    assert_eq!(mixed.mixed_precision_stats().fallbacks, 0);
}

#[test]
fn an_approximate_solve_skips_the_refinement_of_a_single_precision_factor_only() {
    let m = hex_elasticity(8, 7, 6, 3.0, 0.49);
    let b = rhs(m.pattern.n);
    let (x64, x, _, _) = double_and_mixed(&m);
    let mut mixed = FaerSparseSolver::new(1).with_mixed_precision(true);
    mixed.analyze(&m.pattern).expect("analyze");
    mixed.factorize(&m.values).expect("factorize");
    let mut approx = b.clone();
    mixed
        .solve_approximately_in_place(&mut approx)
        .expect("solve");
    let stats = mixed.mixed_precision_stats();
    assert_eq!((stats.unrefined_solves, stats.refinement_steps), (1, 0));
    // The factor's own error: far from round-off, far below what a direction tolerates.
    let error = relative_distance(&approx, &x64);
    assert!(
        error > 100.0 * relative_distance(&x, &x64) && error < 1e-2,
        "{error:e}"
    );
    // A double-precision factor solves in full.
    let mut double = FaerSparseSolver::new(1);
    double.analyze(&m.pattern).expect("analyze");
    double.factorize(&m.values).expect("factorize");
    let mut full = b.clone();
    double
        .solve_approximately_in_place(&mut full)
        .expect("solve");
    assert_eq!(full, x64);
}

#[test]
fn the_factor_size_is_the_fill_of_the_ordering_and_only_a_sparse_solver_reports_it() {
    // A path graph in its natural order does not fill: L has the diagonal and one
    // sub-diagonal, 2n - 1 entries.
    let n = 40;
    let edges: Vec<[usize; 2]> = (0..n - 1).map(|i| [i, i + 1]).collect();
    let pattern = SparsityPattern::from_cliques(n, edges.iter().map(|e| &e[..]));
    let mut sparse: Box<dyn LinearSolver> =
        Box::new(FaerSparseSolver::new(1).with_ordering(FillOrdering::Natural));
    assert_eq!(
        sparse.factor_size(),
        None,
        "nothing planned before the analysis"
    );
    sparse.analyze(&pattern).expect("analyze");
    let size = sparse
        .factor_size()
        .expect("a sparse solver reports its factor");
    assert_eq!(size.nonzeros, 2 * n - 1);
    // One numeric factorisation costs Σ c_j² over the stored columns: at least the exact
    // columns' 4 (n - 1) + 1.
    assert!(size.flops >= (4 * (n - 1) + 1) as f64, "{}", size.flops);
    // On a 3-D grid the fill of nested dissection is what the analysis counted.
    let m = hex_elasticity(6, 6, 6, 1.0, 0.3);
    let mut grid = FaerSparseSolver::new(1);
    grid.analyze(&m.pattern).expect("analyze");
    let info = grid.analysis_info().expect("info").clone();
    let size = LinearSolver::factor_size(&grid).expect("size");
    assert_eq!(size.nonzeros, info.nnz_l);
    assert!(size.nonzeros > m.pattern.nnz(), "a 3-D grid fills in");
    assert_eq!(size.flops, info.factor_flops);
    let mut dense: Box<dyn LinearSolver> = Box::new(DenseSolver::default());
    dense.analyze(&pattern).expect("analyze");
    assert_eq!(dense.factor_size(), None);
}

#[test]
fn a_solve_to_a_looser_tolerance_stops_refining_there_and_still_falls_back() {
    // K/G = 1e6: the single-precision solve alone is off by ~2e-1.
    let m = hex_elasticity(8, 7, 6, 3.0, 0.4999995);
    let mut double = FaerSparseSolver::new(1);
    double.analyze(&m.pattern).expect("analyze");
    let (_, _, x64) = solve(&mut double, &m);
    let b = rhs(m.pattern.n);
    let mut errors = Vec::new();
    let mut steps = Vec::new();
    for tolerance in [MIXED_SOLVE_TOLERANCE, 1e-2] {
        let mut mixed = FaerSparseSolver::new(1).with_mixed_precision(true);
        mixed.analyze(&m.pattern).expect("analyze");
        mixed.factorize(&m.values).expect("factorize");
        let mut x = b.clone();
        mixed.solve_to_in_place(&mut x, tolerance).expect("solve");
        let stats = mixed.mixed_precision_stats();
        assert_eq!((stats.single_factorizations, stats.fallbacks), (1, 0));
        errors.push(relative_distance(&x, &x64));
        steps.push(stats.refinement_steps);
    }
    // The loose solve is within its tolerance, and stops earlier than the full one (whose
    // error is below the full tolerance).
    assert!(errors[0] <= MIXED_SOLVE_TOLERANCE, "{errors:?}");
    assert!(errors[1] <= 1e-2 && errors[1] > errors[0], "{errors:?}");
    assert!(steps[1] >= 1 && steps[1] < steps[0], "{steps:?}");
    // A tolerance tighter than the solver's own is the full solve, bit for bit.
    let mut mixed = FaerSparseSolver::new(1).with_mixed_precision(true);
    mixed.analyze(&m.pattern).expect("analyze");
    mixed.factorize(&m.values).expect("factorize");
    let (mut tight, mut full) = (b.clone(), b.clone());
    mixed.solve_to_in_place(&mut tight, 1e-12).expect("solve");
    mixed.solve_in_place(&mut full).expect("solve");
    assert_eq!(tight, full);
    // CG that cannot reach even the loose tolerance within its iterations still falls
    // back to double precision and returns the double-precision solve.
    let mut short = FaerSparseSolver::new(1)
        .with_mixed_precision(true)
        .with_mixed_max_iterations(1);
    short.analyze(&m.pattern).expect("analyze");
    short.factorize(&m.values).expect("factorize");
    let mut x = b.clone();
    short.solve_to_in_place(&mut x, 1e-2).expect("solve");
    assert_eq!(short.mixed_precision_stats().fallbacks, 1);
    assert_eq!(x, x64, "the fallback is the double-precision solve");
}

/// Nearly incompressible (K/G = 5000) and shifted by a fifth of the mean diagonal: an
/// indefinite matrix whose single-precision solve alone is off by far more than
/// [`MIXED_SOLVE_TOLERANCE`].
fn nearly_incompressible_indefinite() -> TestMatrix {
    let spd = hex_elasticity(8, 7, 6, 3.0, 0.4999);
    let diag_mean = (0..spd.pattern.n)
        .map(|c| spd.values[spd.pattern.col_ptr[c]])
        .sum::<f64>()
        / spd.pattern.n as f64;
    shift_diagonal(&spd, 0.2 * diag_mean)
}

#[test]
fn an_indefinite_matrix_in_single_precision_has_the_double_inertia_and_solves_by_gmres() {
    let m = nearly_incompressible_indefinite();
    let mut double = FaerSparseSolver::new(1);
    double.analyze(&m.pattern).expect("analyze");
    let (info64, _, x64) = solve(&mut double, &m);
    assert_eq!(info64.method, FactorMethod::Ldlt);
    let mut mixed = FaerSparseSolver::new(1)
        .with_mixed_precision(true)
        .with_single_precision_pivoted(true);
    mixed.analyze(&m.pattern).expect("analyze");
    let (info, residual, x) = solve(&mut mixed, &m);
    let stats = mixed.mixed_precision_stats();
    assert_eq!(info.method, FactorMethod::Ldlt);
    assert_eq!(
        (stats.single_pivoted_factorizations, stats.fallbacks),
        (1, 0),
        "{stats:?}"
    );
    // The same inertia as in double precision: single precision resolved every pivot.
    assert!(info64.negative_pivots.unwrap_or(0) > 0);
    assert_eq!(info.negative_pivots, info64.negative_pivots);
    // GMRES was needed and got the double-precision solution to the tolerance.
    assert!(stats.refinement_steps >= 2, "{stats:?}");
    let error = relative_distance(&x, &x64);
    assert!(error <= 10.0 * MIXED_SOLVE_TOLERANCE, "error {error:e}");
    assert!(error > 1e-14, "single precision left no trace: {error:e}");
    assert!(residual < 1e-6, "residual {residual:e}");
    // The factor alone, as quasi-Newton uses it: no refinement, off by more than the
    // refined solve but usable as a direction.
    let b = rhs(m.pattern.n);
    let mut approx = b.clone();
    mixed
        .solve_approximately_in_place(&mut approx)
        .expect("solve");
    let unrefined = relative_distance(&approx, &x64);
    assert!(unrefined > error && unrefined < 0.5, "{unrefined:e}");
    assert_eq!(mixed.mixed_precision_stats().unrefined_solves, 1);
}

#[test]
fn gmres_that_runs_out_of_iterations_falls_back_to_the_double_precision_ldlt() {
    let m = nearly_incompressible_indefinite();
    let mut double = FaerSparseSolver::new(1);
    double.analyze(&m.pattern).expect("analyze");
    let (_, _, x64) = solve(&mut double, &m);
    // One GMRES iteration cannot reach the tolerance from an unrefined single-precision
    // solve; the matrix is factorised again in double precision and solved there, and so
    // are the indefinite matrices after it.
    let mut short = FaerSparseSolver::new(1)
        .with_mixed_precision(true)
        .with_single_precision_pivoted(true)
        .with_mixed_max_iterations(1);
    short.analyze(&m.pattern).expect("analyze");
    let (info, _, x) = solve(&mut short, &m);
    assert_eq!(info.method, FactorMethod::Ldlt);
    let stats = short.mixed_precision_stats();
    assert_eq!(
        (stats.single_pivoted_factorizations, stats.fallbacks),
        (1, 1),
        "{stats:?}"
    );
    assert_eq!(x, x64, "the fallback is the double-precision solve");
    let (_, _, x) = solve(&mut short, &m);
    assert_eq!(x, x64);
    assert_eq!(
        short.mixed_precision_stats().single_pivoted_factorizations,
        1,
        "indefinite matrices in double precision from then on"
    );
}
