#!/usr/bin/env python3
"""Time CHOLMOD (SuiteSparse, via scikit-sparse) on the matrices of the cellmech linsolve bench.

The Rust benchmark `cargo bench -p cellmech-fem --bench linsolve` writes the hex8 elasticity
matrices to `target/bench-matrices/hex_<elements>.mtx` (symmetric, lower triangle). This script
reads each one and prints, per matrix and ordering (METIS nested dissection, AMD): CHOLMOD's
symbolic analysis time, its numeric supernodal Cholesky time (best of N) and nnz(L).

Setup (installs nothing by itself), on Debian/Ubuntu:

    apt-get install -y libsuitesparse-dev libopenblas0-pthread
    pip install scikit-sparse==0.4.16      # builds against the system CHOLMOD; pulls numpy/scipy

Run with the same thread count as the Rust bench (CHOLMOD's supernodal factorisation runs in
the BLAS, so OpenBLAS threads are what matters):

    OPENBLAS_NUM_THREADS=2 python3 benches/cholmod_compare.py [matrix.mtx ...] [--repeats 3]

nnz(L) is `Factor.L().nnz` of the supernodal factor converted to simplicial form, i.e. the
entries CHOLMOD stores including the explicit zeros of its relaxed supernodes (compare with the
"stored L" column of the Rust bench; its "nnz(L)" column is the exact structural count).
"""

import argparse
import glob
import os
import sys
import time


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("matrices", nargs="*", help="Matrix Market files (default: bench set)")
    parser.add_argument("--repeats", type=int, default=3, help="numeric factorisations timed")
    args = parser.parse_args()

    try:
        import numpy as np
        import scipy.io
        import scipy.sparse as sp
        from sksparse.cholmod import analyze
    except ImportError as err:
        sys.exit(f"missing Python dependency ({err}); see the setup notes at the top of {__file__}")

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    paths = args.matrices or sorted(
        glob.glob(os.path.join(root, "target", "bench-matrices", "hex_*.mtx")),
        key=lambda p: int("".join(c for c in os.path.basename(p) if c.isdigit()) or 0),
    )
    if not paths:
        sys.exit("no matrices: run `cargo bench -p cellmech-fem --bench linsolve` first")

    print(f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    print("| matrix | n | ordering | symbolic s | numeric s (best) | nnz(L) 1e6 stored |")
    print("|---|---|---|---|---|---|")
    for path in paths:
        a = scipy.io.mmread(path)  # symmetric files come back with both triangles
        a = sp.csc_matrix(a, dtype=np.float64)
        a.sort_indices()
        for ordering in ("metis", "amd"):
            t0 = time.perf_counter()
            factor = analyze(a, mode="supernodal", ordering_method=ordering)
            symbolic = time.perf_counter() - t0
            numeric = float("inf")
            for _ in range(max(1, args.repeats)):
                t0 = time.perf_counter()
                factor.cholesky_inplace(a)
                numeric = min(numeric, time.perf_counter() - t0)
            x = factor(np.ones(a.shape[0]))
            residual = np.linalg.norm(a @ x - 1.0) / np.sqrt(a.shape[0])
            if not residual < 1e-8:
                sys.exit(f"{path}: CHOLMOD residual {residual:e} too large")
            nnz_l = factor.L().nnz
            name = os.path.basename(path)
            print(
                f"| {name} | {a.shape[0]} | {ordering} | {symbolic:.3f} | {numeric:.3f} "
                f"| {nnz_l / 1e6:.2f} |"
            )
            sys.stdout.flush()


if __name__ == "__main__":
    main()
