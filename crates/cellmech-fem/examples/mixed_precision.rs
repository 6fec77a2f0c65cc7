//! Measures what single precision buys in faer's supernodal Cholesky (the basis of
//! `FaerSparseSolver::with_mixed_precision`): on a 3-D elasticity matrix of nx × ny × nz
//! hex8 (Poisson's ratio from the environment variable NU, default 0.49), the median of 5
//! sequential numeric factorisations in f64 and f32, one solve of each, and the relative
//! error of the f32 solution against the f64 one before and after each of three steps of
//! iterative refinement in double precision (`docs/linear-solver.md`, "Mixed precision").
//!
//! Run: `cargo run --release -p cellmech-fem --example mixed_precision -- 14 14 15`
use std::time::Instant;

use cellmech_fem::linsolve::test_matrices::hex_elasticity;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side, Spec};

/// Sequential numeric LLᵀ in either precision.
fn factorize<T: faer::traits::ComplexField>(
    sym: &SymbolicCholesky<usize>,
    l: &mut [T],
    a: SparseColMatRef<'_, usize, T>,
    mem: &mut MemBuffer,
) {
    sym.factorize_numeric_llt(
        l,
        a,
        Side::Lower,
        Default::default(),
        Par::Seq,
        MemStack::new(mem),
        Spec::default(),
    )
    .expect("positive definite");
}

/// Wall time of `f`, s.
fn time(f: impl FnOnce()) -> f64 {
    let t = Instant::now();
    f();
    t.elapsed().as_secs_f64()
}

fn main() {
    let dims: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let (nx, ny, nz) = (dims[0], dims[1], dims[2]);
    let m = hex_elasticity(
        nx,
        ny,
        nz,
        1.0,
        std::env::var("NU")
            .map(|s| s.parse().unwrap())
            .unwrap_or(0.49),
    );
    let p = &m.pattern;
    let n = p.n;
    let perm = cellmech_fem::linsolve::ordering::nested_dissection(p).unwrap();
    let inv = cellmech_fem::linsolve::ordering::inverse_permutation(&perm);
    let structure = SymbolicSparseColMatRef::new_checked(n, n, &p.col_ptr, None, &p.row_idx);
    let ord = SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(&perm, &inv, n));
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    };
    let sym = factorize_symbolic_cholesky(structure, Side::Lower, ord, params).unwrap();
    let req = StackReq::any_of(&[
        sym.factorize_numeric_llt_scratch::<f64>(Par::Seq, Spec::default()),
        sym.factorize_numeric_llt_scratch::<f32>(Par::Seq, Spec::default()),
        sym.solve_in_place_scratch::<f64>(1, Par::Seq),
    ]);
    let mut mem = MemBuffer::new(req);
    let v64: Vec<f64> = m.values.clone();
    let v32: Vec<f32> = v64.iter().map(|&x| x as f32).collect();
    let a64 = SparseColMatRef::new(structure, &v64);
    let a32 = SparseColMatRef::new(structure, &v32);
    let mut l64 = vec![0.0f64; sym.len_val()];
    let mut l32 = vec![0.0f32; sym.len_val()];
    let mut t64 = vec![];
    let mut t32 = vec![];
    for _ in 0..5 {
        t64.push(time(|| factorize(&sym, &mut l64, a64, &mut mem)));
        t32.push(time(|| factorize(&sym, &mut l32, a32, &mut mem)));
    }
    t64.sort_by(|a, b| a.partial_cmp(b).unwrap());
    t32.sort_by(|a, b| a.partial_cmp(b).unwrap());
    // Solves.
    let b: Vec<f64> = (0..n)
        .map(|i| ((i * 37 + 11) % 101) as f64 / 101.0 - 0.4)
        .collect();
    let f64l = LltRef::new(&sym, &l64);
    let f32l = LltRef::new(&sym, &l32);
    let mut x = b.clone();
    let mut x32: Vec<f32> = b.iter().map(|&v| v as f32).collect();
    let ts64 = time(|| {
        f64l.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut x, n, 1),
            Par::Seq,
            MemStack::new(&mut mem),
        )
    });
    let ts32 = time(|| {
        f32l.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut x32, n, 1),
            Par::Seq,
            MemStack::new(&mut mem),
        )
    });
    // Error of the f32 solution relative to the f64 one, and after refinement steps.
    let matvec = |x: &[f64]| -> Vec<f64> {
        let mut y = vec![0.0; n];
        for c in 0..n {
            for k in p.col_ptr[c]..p.col_ptr[c + 1] {
                let r = p.row_idx[k];
                y[r] += v64[k] * x[c];
                if r != c {
                    y[c] += v64[k] * x[r];
                }
            }
        }
        y
    };
    let mut y: Vec<f64> = x32.iter().map(|&v| v as f64).collect();
    let err = |y: &[f64]| {
        (y.iter()
            .zip(&x)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            / x.iter().map(|a| a * a).sum::<f64>())
        .sqrt()
    };
    print!("n {n} lval {} f64 fact {:.4} s f32 fact {:.4} s ratio {:.2} | solve {:.4} / {:.4} | err0 {:.2e}", sym.len_val(), t64[2], t32[2], t32[2] / t64[2], ts64, ts32, err(&y));
    for _ in 0..3 {
        let ky = matvec(&y);
        let mut r: Vec<f32> = b.iter().zip(&ky).map(|(a, c)| (a - c) as f32).collect();
        f32l.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut r, n, 1),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        for i in 0..n {
            y[i] += r[i] as f64;
        }
        print!(" {:.2e}", err(&y));
    }
    println!();
}
