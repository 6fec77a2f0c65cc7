//! Measures where a parallel numeric factorisation starts to pay: for 3-D elasticity matrices
//! of growing size, times the sequential and the 2-thread factorisation (and solve) inside one
//! 2-thread rayon pool, as `Problem` runs them, and checks whether both give bitwise the same
//! solution. The crossing sets `DEFAULT_PARALLEL_MIN_FLOPS` (see `docs/performance.md`).
//!
//! Run: `cargo run --release -p cellmech-fem --example parallel_threshold [REPEATS]`
//! (default 5 repeats; the median and the minimum of each are printed).

use std::time::Instant;

use cellmech_fem::linsolve::test_matrices::hex_elasticity;
use cellmech_fem::linsolve::{FaerSparseSolver, LinearSolver};

fn main() {
    let repeats: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(5)
        .max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("a 2-thread pool");
    println!(
        "{:>6} {:>9} {:>10} | {:>9} {:>9} {:>9} {:>9} {:>6} | {:>8} {:>8} | {}",
        "n",
        "nnz(L)",
        "flops",
        "seq med",
        "seq min",
        "par med",
        "par min",
        "par/seq",
        "solve s",
        "solve p",
        "bitwise"
    );
    for (nx, ny, nz) in [
        (4, 4, 4),
        (6, 6, 6),
        (8, 8, 8),
        (10, 10, 10),
        (12, 12, 12),
        (14, 14, 15),
        (17, 17, 17),
        (21, 21, 21),
        (24, 24, 24),
    ] {
        let m = hex_elasticity(nx, ny, nz, 1.0, 0.45);
        let n = m.pattern.n;
        let b: Vec<f64> = (0..n)
            .map(|i| ((i * 37 + 11) % 101) as f64 / 101.0 - 0.4)
            .collect();
        pool.install(|| {
            let mut seq = FaerSparseSolver::new(1);
            let mut par = FaerSparseSolver::new(0).with_parallel_min_flops(0.0);
            seq.analyze(&m.pattern).expect("analyze");
            par.analyze(&m.pattern).expect("analyze");
            let info = seq.analysis_info().expect("info").clone();
            let (mut ts, mut tp, mut ss, mut sp) = (vec![], vec![], vec![], vec![]);
            let (mut xs, mut xp) = (b.clone(), b.clone());
            for _ in 0..repeats {
                for (solver, t, s, x) in [
                    (&mut seq, &mut ts, &mut ss, &mut xs),
                    (&mut par, &mut tp, &mut sp, &mut xp),
                ] {
                    let start = Instant::now();
                    solver.factorize(&m.values).expect("factorize");
                    t.push(start.elapsed().as_secs_f64());
                    x.copy_from_slice(&b);
                    let start = Instant::now();
                    solver.solve_in_place(x).expect("solve");
                    s.push(start.elapsed().as_secs_f64());
                }
            }
            let bitwise = xs.iter().zip(&xp).all(|(a, b)| a.to_bits() == b.to_bits());
            let scale = xs.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = xs.iter().zip(&xp).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            println!(
                "{:>6} {:>9} {:>10.3e} | {:>9.5} {:>9.5} {:>9.5} {:>9.5} {:>6.2} | {:>8.5} {:>8.5} | {} (max diff {:.1e} rel)",
                n,
                info.nnz_l,
                info.factor_flops,
                median(&mut ts),
                min(&ts),
                median(&mut tp),
                min(&tp),
                median(&mut tp.clone()) / median(&mut ts.clone()),
                median(&mut ss),
                median(&mut sp),
                if bitwise { "yes" } else { "no" },
                diff / scale
            );
        });
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn min(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}
