//! Sparse direct solver benchmark on 3-D elasticity matrices of structured hex8 grids (3 DOFs per
//! node, 27-node stencil, lower triangle): ordering + symbolic analysis, numeric Cholesky and
//! solve, nested dissection (METIS) versus faer's AMD.
//!
//! Run: `cargo bench -p cellmech-fem --bench linsolve` (about 3 minutes on 2 cores). Sizes can be
//! chosen with `CELLMECH_BENCH_SIZES=3k,10k,30k` and the thread count with `CELLMECH_BENCH_THREADS` (default:
//! rayon's pool). Every matrix is also written to
//! `target/bench-matrices/hex_<elements>.mtx` (Matrix Market, symmetric, lower triangle) for
//! `benches/cholmod_compare.py`, which times CHOLMOD on the identical matrices.
//!
//! The 3k and 10k grids go through criterion (10 samples); the 30k grid, whose factorisation
//! takes seconds, is timed directly (best of 3) and printed with the fill summary.

use std::fs::File;
use std::hint::black_box;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use cellmech_fem::linsolve::test_matrices::{hex_elasticity, TestMatrix};
use cellmech_fem::linsolve::{FaerSparseSolver, FillOrdering, LinearSolver};
use criterion::{criterion_group, criterion_main, Criterion};

/// Grids with about 3k, 10k and 30k elements.
const GRIDS: [(&str, [usize; 3]); 3] = [
    ("3k", [14, 14, 15]),
    ("10k", [22, 22, 21]),
    ("30k", [31, 31, 31]),
];

fn selected_grids() -> Vec<(&'static str, [usize; 3])> {
    let wanted = std::env::var("CELLMECH_BENCH_SIZES").unwrap_or_else(|_| "3k,10k,30k".into());
    GRIDS
        .iter()
        .copied()
        .filter(|(name, _)| wanted.split(',').any(|w| w.trim() == *name))
        .collect()
}

/// Thread count from `CELLMECH_BENCH_THREADS` (default 0: rayon's pool).
fn threads() -> usize {
    std::env::var("CELLMECH_BENCH_THREADS")
        .ok()
        .and_then(|t| t.parse().ok())
        .unwrap_or(0)
}

fn matrix_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target"))
        .join("bench-matrices")
}

/// Writes the lower triangle as a symmetric Matrix Market coordinate file (1-based).
fn write_matrix_market(m: &TestMatrix, path: &PathBuf) -> std::io::Result<()> {
    let mut w = BufWriter::new(File::create(path)?);
    writeln!(w, "%%MatrixMarket matrix coordinate real symmetric")?;
    writeln!(
        w,
        "% cellmech hex8 elasticity benchmark matrix (lower triangle)"
    )?;
    writeln!(w, "{} {} {}", m.pattern.n, m.pattern.n, m.pattern.nnz())?;
    for c in 0..m.pattern.n {
        for k in m.pattern.col_ptr[c]..m.pattern.col_ptr[c + 1] {
            writeln!(
                w,
                "{} {} {:.17e}",
                m.pattern.row_idx[k] + 1,
                c + 1,
                m.values[k]
            )?;
        }
    }
    w.flush()
}

fn best_of(repeats: usize, mut f: impl FnMut()) -> Duration {
    (0..repeats)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed()
        })
        .min()
        .unwrap_or_default()
}

fn bench(c: &mut Criterion) {
    let dir = matrix_dir();
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("cannot create {}: {e}", dir.display());
    }
    let mut summary = Vec::new();
    for (name, [nx, ny, nz]) in selected_grids() {
        let m = hex_elasticity(nx, ny, nz, 1.0, 0.3);
        let path = dir.join(format!("hex_{}.mtx", nx * ny * nz));
        if let Err(e) = write_matrix_market(&m, &path) {
            eprintln!("cannot write {}: {e}", path.display());
        }
        let b: Vec<f64> = (0..m.pattern.n).map(|i| (i % 7) as f64 - 3.0).collect();
        for ordering in [FillOrdering::NestedDissection, FillOrdering::Amd] {
            let label = format!("{name}/{ordering:?}");
            let mut solver = FaerSparseSolver::new(threads()).with_ordering(ordering);
            let analyze = best_of(1, || solver.analyze(&m.pattern).expect("analyze"));
            let info = solver.analysis_info().cloned().expect("analysed");
            let small = name != "30k";
            let mut group = c.benchmark_group(format!("linsolve/{label}"));
            group
                .sample_size(10)
                .warm_up_time(Duration::from_millis(500));
            if small {
                group.bench_function("analyze", |bench| {
                    bench.iter(|| solver.analyze(black_box(&m.pattern)).expect("analyze"))
                });
                group.bench_function("factorize", |bench| {
                    bench.iter(|| solver.factorize(black_box(&m.values)).expect("factorize"))
                });
                group.bench_function("solve", |bench| {
                    bench.iter(|| {
                        let mut x = b.clone();
                        solver.solve_in_place(&mut x).expect("solve");
                        x
                    })
                });
            }
            group.finish();
            let repeats = if small { 5 } else { 3 };
            let numeric = best_of(repeats, || {
                solver.factorize(&m.values).expect("factorize");
            });
            let solve = best_of(repeats, || {
                let mut x = b.clone();
                solver.solve_in_place(&mut x).expect("solve");
            });
            summary.push(format!(
                "| {name} ({nx}x{ny}x{nz}) | {ord:?} | {n} | {nnz_a} | {nnz_l:.2} | {stored:.2} \
                 | {ord_s:.3} | {an:.3} | {num:.3} | {sol:.4} |",
                ord = ordering,
                n = m.pattern.n,
                nnz_a = m.pattern.nnz(),
                nnz_l = info.nnz_l as f64 / 1e6,
                stored = info.stored_l as f64 / 1e6,
                ord_s = info.ordering_seconds,
                an = analyze.as_secs_f64(),
                num = numeric.as_secs_f64(),
                sol = solve.as_secs_f64(),
            ));
        }
    }
    eprintln!(
        "\n| grid | ordering | n | nnz(A) lower | nnz(L) 1e6 | stored L 1e6 | ordering s \
         | analyze s | numeric s | solve s |"
    );
    eprintln!("|---|---|---|---|---|---|---|---|---|---|");
    for line in summary {
        eprintln!("{line}");
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
