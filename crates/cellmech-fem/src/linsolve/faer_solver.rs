//! [`FaerSparseSolver`]: supernodal sparse direct solver on faer 0.24 with a nested-dissection
//! ordering, Cholesky → Bunch-Kaufman LDLᵀ → LU fallback, and inertia reporting.

use std::time::Instant;

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::cholesky::supernodal::{
    SupernodalIntranodeLbltRef, SupernodalLltRef, SymbolicSupernodalCholesky,
};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, IntranodeLbltRef, LltRef,
    SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::solvers::Lu;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMatRef, Triplet};
use faer::{Conj, MatMut, Par, Side, Spec};

use super::ordering::{cholesky_fill, is_permutation, nested_dissection, FillOrdering};
use super::tree_cholesky::{FactorFailure, TreeCholesky, TreeScalar, WorkspacePool};
use super::{FactorInfo, FactorMethod, LinSolveError, LinearSolver, SparsityPattern};

/// Facts about the ordering and symbolic factorisation of the last `analyze`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AnalysisInfo {
    /// Ordering used.
    pub ordering: FillOrdering,
    /// Matrix dimension.
    pub n: usize,
    /// Stored entries of the lower triangle of A.
    pub nnz_a: usize,
    /// Exact nonzeros of L (structural, diagonal included) for the chosen permutation.
    pub nnz_l: usize,
    /// Entries faer stores for L (supernodal blocks, including explicit zeros of relaxed
    /// supernodes; counted as lower triangles of the diagonal blocks).
    pub stored_l: usize,
    /// Number of supernodes.
    pub supernodes: usize,
    /// Wall time of the ordering, s (for [`FillOrdering::Amd`], which faer computes inside its
    /// symbolic step, this is ordering + symbolic and `symbolic_seconds` is 0).
    pub ordering_seconds: f64,
    /// Wall time of the symbolic factorisation, s.
    pub symbolic_seconds: f64,
    /// Floating-point operations of one numeric Cholesky, `Σ_j c_j²` over the columns of L
    /// (`c_j`: stored entries of column j, diagonal included); decides whether the
    /// pivoted factorisation and the solves run in parallel (see
    /// [`FaerSparseSolver::with_parallel_min_flops`]).
    pub factor_flops: f64,
    /// Whether the Cholesky factorisations run on the elimination tree's subtrees
    /// concurrently (`tree_cholesky`: the subtrees' tasks on faer's symbolic factor; false
    /// only if the symbolic factor is not one it can walk, then faer's own numeric step).
    pub tree_factorisation: bool,
}

/// Mixed precision: a solve is refined until the preconditioned residual `M⁻¹(b − A x)` (the
/// correction a step of stationary refinement would make) is at most this fraction of the
/// solution (a Newton direction to 1e-6 relative is as good as an exact one: the
/// chord steps of `solve::newton` use far older tangents).
pub const MIXED_SOLVE_TOLERANCE: f64 = 1e-6;

/// Mixed precision: most conjugate-gradient iterations of one solve before the solver
/// falls back to a double-precision factorisation. The cell tangents (23.5k DOFs) took 6 to
/// 11; at about 12 ms an iteration (one single-precision solve and one product with A)
/// against 0.16–0.23 s saved by the single-precision factorisation, a solve stops paying
/// for itself between 13 and 19 iterations. 20 is about twice the cells' count and still
/// near a factorisation's saving, so one slow tangent does not switch a whole analysis to
/// double precision, while
/// a preconditioner that leaves many eigenvalues of `M⁻¹A` spread (CG needs about one
/// iteration per outlier) does.
pub const MIXED_MAX_ITERATIONS: usize = 20;

/// Mixed precision: a single-precision Cholesky pivot `L_kk²` of the unit-diagonal scaled
/// matrix below this is no larger than its own rounding error (about 1.7 units of single
/// precision's roundoff 2⁻²⁴ ≈ 6e-8, against a unit diagonal): not even its sign is known,
/// so the factorisation is redone in double precision (which also gets the inertia right).
/// Pivots above it but with few correct digits only make a few eigenvalues of `M⁻¹A`
/// outliers, which the conjugate gradients of the solve handle; whether single precision
/// resolves the matrix is decided there. (Until the PCG solve, this floor was 1e-6; the cell
/// tangents have pivots down to 3.5e-7, and every one of them solved in 6–11 iterations.)
const MIXED_PIVOT_FLOOR: f64 = 1e-7;

/// A single-precision Cholesky that stops at a pivot below minus this (of the matrix scaled
/// to a unit diagonal) met an indefinite matrix, not its own rounding: a pivot is 1 minus a
/// sum of k squares, each at most 1, rounded to about k·ε₃₂ ≈ 6e-8·k, under 1e-4 for the
/// widest supernodes of the cell models (k ≈ 2000).
const INDEFINITE_SINGLE_PIVOT: f64 = 1e-3;

/// Largest relative forward error of the probe solve for an LU, or an LBLᵀ with a pivot
/// below the tolerance, to be accepted.
const LU_PROBE_TOLERANCE: f64 = 1e-6;

/// The fixed solution of the probe solves `A x = A z` (entries in [1, 2)).
fn probe_vector(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 1.0 + ((i * 7919) % 13) as f64 / 13.0)
        .collect()
}

/// Default of [`FaerSparseSolver::with_parallel_min_flops`]: pivoted (LDLᵀ) factorisations
/// and solves with fewer flops (`AnalysisInfo::factor_flops`) run sequentially even inside
/// a pool of several threads (the Cholesky runs on the elimination tree at every size,
/// `tree_cholesky`). 1e10: on the project's 2-core machine, idle, faer's parallel supernodal
/// factorisation took 0.60x the sequential time at 1.7e10 flops (30k DOFs) and 0.69x at
/// 3.7e10 (45k DOFs), but 0.86x at 4.8e9, 1.03x at 1.7e9 and more below (the default cell
/// mesh's 10k DOFs stay sequential). Its solutions differ from the sequential ones by
/// ~1e-15 relative, so curves above the threshold are not bitwise the same at 1 and 2
/// threads (bounded in `tests/threads.rs`). Measured with
/// `cargo run --release -p cellmech-fem --example parallel_threshold`
/// (`docs/performance.md`, section "Threads").
pub const DEFAULT_PARALLEL_MIN_FLOPS: f64 = 1e10;

/// Everything `analyze` computes once per pattern, plus reusable numeric buffers.
struct Analysis {
    n: usize,
    /// The analysed pattern (values of `factorize` follow its `row_idx`).
    pattern: SparsityPattern,
    /// Position of each diagonal entry in the value array.
    diag_pos: Vec<usize>,
    /// Fill-reducing permutation, `perm[new] = old`.
    perm: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
    /// The tree-parallel numeric Cholesky on `symbolic` (None: faer's numeric step), and
    /// the LLᵀ solves on it.
    tree: Option<TreeCholesky>,
    /// faer's column order of the factor (`tree_perm[new] = old`), the permuted vectors of
    /// the tree's solves (empty without a tree) and the threads of the current factor's
    /// solves (those its factorisation used).
    tree_perm: Vec<usize>,
    tree_y: Vec<f64>,
    tree_y32: Vec<f32>,
    tree_products: Vec<f64>,
    tree_products32: Vec<f32>,
    solve_threads: usize,
    tree_workspaces: WorkspacePool<f64>,
    tree_workspaces32: WorkspacePool<f32>,
    l_values: Vec<f64>,
    subdiag: Vec<f64>,
    bk_fwd: Vec<usize>,
    bk_inv: Vec<usize>,
    mem: MemBuffer,
    /// Threads the workspace `mem` was sized for.
    max_threads: usize,
    /// Copy of the last factorised values (for iterative refinement of pivoted solves).
    values: Vec<f64>,
    info: AnalysisInfo,
    /// Mixed precision: the values and L in single precision, and the buffers of the
    /// refinement by conjugate gradients (empty unless mixed precision is on).
    values32: Vec<f32>,
    l_values32: Vec<f32>,
    /// The single-precision LDLᵀ's 2x2 pivots' off-diagonal entries (its Bunch–Kaufman
    /// permutation shares `bk_fwd` / `bk_inv`: one factor is current at a time).
    subdiag32: Vec<f32>,
    x32: Vec<f32>,
    /// Mixed precision: 1/√|A_jj|, the symmetric scaling that gives the single-precision
    /// matrix a unit diagonal.
    scale: Vec<f64>,
    /// Mixed precision, the preconditioned conjugate gradients of a solve: the saved
    /// right-hand side, the residual, the search direction and A times it.
    refine_b: Vec<f64>,
    refine_r: Vec<f64>,
    cg_p: Vec<f64>,
    cg_ap: Vec<f64>,
    /// The flexible GMRES of the single-precision LDLᵀ's solves: its basis and the
    /// basis' preconditioned images, `(2m + 1) n` values for `m` =
    /// [`MIXED_MAX_ITERATIONS`] (allocated at the first such solve).
    krylov: Vec<f64>,
}

/// Which numeric factor is currently valid.
enum Numeric {
    Llt,
    /// Cholesky in single precision, solves refined in double by preconditioned CG
    /// ([`FaerSparseSolver::with_mixed_precision`]).
    Llt32,
    Lblt,
    /// Bunch–Kaufman LDLᵀ in single precision on the elimination tree, solves refined in
    /// double by flexible GMRES ([`FaerSparseSolver::try_lblt32`]).
    Lblt32,
    Lu(Box<Lu<usize, f64>>),
}

/// Why a double-precision LDLᵀ was not kept.
#[derive(Debug)]
struct LbltFailure {
    message: String,
    /// It completed with a pivot below the tolerance, and its refined probe solve had a
    /// forward error above [`LU_PROBE_TOLERANCE`] but below 1: the matrix is singular to
    /// working accuracy (LU is not tried).
    near_null_space_only: bool,
}

impl From<String> for LbltFailure {
    fn from(message: String) -> Self {
        LbltFailure {
            message,
            near_null_space_only: false,
        }
    }
}

impl From<&str> for LbltFailure {
    fn from(message: &str) -> Self {
        message.to_string().into()
    }
}

/// Sparse direct solver (faer supernodal Cholesky) for the symmetric tangent matrices of the
/// engine. See the module docs of [`super`] for the contract and `docs/linear-solver.md` for
/// the design.
///
/// Fallback policy of [`LinearSolver::factorize`]: LLᵀ first; if a pivot is not positive (or
/// smaller than `pivot_tolerance` times the largest diagonal entry of A in its supernode), the
/// supernodal LDLᵀ with Bunch-Kaufman pivoting inside each supernode (faer's *intranode
/// LBLᵀ*); if its D has a pivot block that is tiny or not finite, a general sparse LU with
/// partial pivoting. When LLᵀ has failed once, later calls start with LBLᵀ; as soon as an LBLᵀ
/// finds the matrix positive definite (no negative and no 2x2 pivots) the next call tries LLᵀ
/// again, which costs nothing extra.
pub struct FaerSparseSolver {
    /// Most threads a factorisation may use (0: the size of the calling rayon pool).
    threads: usize,
    /// Factorisations below this many flops run sequentially.
    parallel_min_flops: f64,
    ordering: FillOrdering,
    pivot_tolerance: f64,
    analysis: Option<Analysis>,
    numeric: Option<Numeric>,
    /// How many factorisations in a row were not positive definite (pivoted or LU); while
    /// it is above 0 a failed Cholesky goes straight to the pivoted factorisation, and
    /// Cholesky is tried at all only while [`FaerSparseSolver::cholesky_worth_trying`].
    indefinite_streak: usize,
    /// Factorise positive definite matrices in single precision first.
    mixed: bool,
    /// Single precision failed once on a positive definite matrix (pivot or conjugate
    /// gradients): double precision from then on.
    mixed_off: bool,
    /// A single-precision LDLᵀ did not resolve an indefinite matrix (a GMRES solve that
    /// ran out of iterations): indefinite matrices in double precision from then on.
    pivoted_single_off: bool,
    /// Factorise indefinite matrices in single precision too (off by default).
    pivoted_single: bool,
    /// Most conjugate-gradient iterations of a mixed-precision solve
    /// ([`MIXED_MAX_ITERATIONS`]; lowered by tests to reach the fallback in a solve).
    mixed_max_iterations: usize,
    stats: MixedPrecisionStats,
}

/// What mixed precision did over a solver's life ([`FaerSparseSolver::with_mixed_precision`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct MixedPrecisionStats {
    /// Factorisations done in single precision.
    pub single_factorizations: usize,
    /// Indefinite matrices factorised in single precision (Bunch–Kaufman LDLᵀ on the
    /// elimination tree; their solves refined by GMRES).
    pub single_pivoted_factorizations: usize,
    /// Single-precision LDLᵀ factorisations that did not resolve their matrix (a pivot
    /// below the floor): the double-precision one followed.
    pub single_pivoted_refused: usize,
    /// Conjugate-gradient iterations of the refined solves (each one double-precision
    /// product with A and one single-precision solve; a solve also does one
    /// single-precision solve before its first iteration).
    pub refinement_steps: usize,
    /// Solves left unrefined because the caller asked for an approximate direction
    /// ([`LinearSolver::solve_approximately_in_place`]: quasi-Newton and chord steps).
    pub unrefined_solves: usize,
    /// Times single precision did not resolve a positive definite matrix (a pivot below
    /// the floor, or conjugate gradients that broke down or ran out of iterations) and
    /// double precision took over for the rest of the
    /// solver's life; or GMRES did not resolve an indefinite matrix's single-precision
    /// LDLᵀ, and indefinite matrices went to double precision for the rest of it.
    /// (Indefiniteness itself is no fallback: the next positive definite matrix is tried
    /// in single precision.)
    pub fallbacks: usize,
}

impl Default for FaerSparseSolver {
    fn default() -> Self {
        Self::new(0)
    }
}

impl FaerSparseSolver {
    /// New solver with nested-dissection ordering and pivot tolerance `1e-12`. A numeric
    /// factorisation runs on at most `threads` threads of the rayon pool it is called in
    /// (`0`: all of them; `1`: always sequential), and sequentially when it has fewer flops
    /// than [`FaerSparseSolver::with_parallel_min_flops`] (default
    /// [`DEFAULT_PARALLEL_MIN_FLOPS`], see there). Triangular solves
    /// follow the same choice.
    /// Run it inside the pool (`ThreadPool::install`, as [`crate::solve::Problem`] does):
    /// called from outside, every parallel section goes through rayon's cross-thread latch.
    pub fn new(threads: usize) -> Self {
        FaerSparseSolver {
            threads,
            parallel_min_flops: DEFAULT_PARALLEL_MIN_FLOPS,
            ordering: FillOrdering::NestedDissection,
            pivot_tolerance: 1e-12,
            analysis: None,
            numeric: None,
            indefinite_streak: 0,
            mixed: false,
            mixed_off: false,
            pivoted_single_off: false,
            pivoted_single: false,
            mixed_max_iterations: MIXED_MAX_ITERATIONS,
            stats: MixedPrecisionStats::default(),
        }
    }

    /// Mixed precision (off by default): a matrix that Cholesky can factorise is scaled to a
    /// unit diagonal and factorised in single precision (about two thirds of the time, half
    /// the memory traffic of the solves), and every solve is refined in double precision by
    /// conjugate gradients preconditioned with that factor, until the preconditioned
    /// residual is at most [`MIXED_SOLVE_TOLERANCE`] of `x` (2 to 11 iterations on the
    /// matrices measured); [`LinearSolver::solve_approximately_in_place`] skips the
    /// refinement. When single precision does not resolve the matrix (a pivot `L_kk²` below
    /// 1e-7 of the unit diagonal, or conjugate gradients that break down or take more than
    /// [`MIXED_MAX_ITERATIONS`]), the matrix is factorised again in double precision, and
    /// the solver stays in double precision from then on. Indefinite matrices go to the
    /// double-precision LDLᵀ unless [`Self::with_single_precision_pivoted`] is on. See
    /// `docs/linear-solver.md`, "Mixed precision" and "Indefinite matrices in single
    /// precision".
    pub fn with_mixed_precision(mut self, on: bool) -> Self {
        self.mixed = on;
        self
    }

    /// Test hook: at most `iterations` conjugate-gradient iterations per mixed-precision
    /// solve, so that a test can make a solve fall back to double precision.
    #[cfg(test)]
    pub(crate) fn with_mixed_max_iterations(mut self, iterations: usize) -> Self {
        self.mixed_max_iterations = iterations;
        self
    }

    /// With mixed precision, factorise indefinite matrices in single precision too (off by
    /// default): the pivoted LDLᵀ on the elimination tree in `f32`, its solves refined by
    /// flexible GMRES (`try_lblt32`). Measured on the compression cell it is not yet a
    /// gain on every case (`docs/linear-solver.md`, "Indefinite matrices in single
    /// precision"), so the cell analyses do not use it.
    pub fn with_single_precision_pivoted(mut self, on: bool) -> Self {
        self.pivoted_single = on;
        self
    }

    /// What mixed precision did so far.
    pub fn mixed_precision_stats(&self) -> MixedPrecisionStats {
        self.stats
    }

    /// Factorisations with fewer flops than this ([`AnalysisInfo::factor_flops`]) run
    /// sequentially; `0` makes every factorisation parallel when there are threads.
    pub fn with_parallel_min_flops(mut self, flops: f64) -> Self {
        self.parallel_min_flops = flops;
        self
    }

    /// The parallelism of the next numeric factorisation: sequential when the solver is
    /// limited to one thread, the calling pool has one, the factorisation is below the
    /// threshold, or the workspace was sized for one thread.
    fn factor_par(&self, a: &Analysis) -> Par {
        let available = rayon::current_num_threads();
        let threads = match self.threads {
            0 => available,
            t => t.min(available),
        }
        .min(a.max_threads);
        if threads <= 1 || a.info.factor_flops < self.parallel_min_flops {
            Par::Seq
        } else {
            Par::rayon(threads)
        }
    }

    /// Threads the tree-parallel Cholesky may use: the solver's limit and the calling pool's
    /// size (its arithmetic, hence its result, is the same for any count).
    fn tree_threads(&self, a: &Analysis) -> usize {
        let available = rayon::current_num_threads();
        match self.threads {
            0 => available,
            t => t.min(available),
        }
        .min(a.max_threads)
        .max(1)
    }

    /// Chooses the fill-reducing ordering (takes effect at the next `analyze`).
    pub fn with_ordering(mut self, ordering: FillOrdering) -> Self {
        self.ordering = ordering;
        self
    }

    /// Relative pivot size (|pivot| / largest diagonal entry of A in the supernode) below which
    /// a factorisation counts as failed (the matrix is treated as singular).
    pub fn with_pivot_tolerance(mut self, tolerance: f64) -> Self {
        self.pivot_tolerance = tolerance;
        self
    }

    /// Ordering and symbolic facts of the last `analyze`, if any.
    pub fn analysis_info(&self) -> Option<&AnalysisInfo> {
        self.analysis.as_ref().map(|a| &a.info)
    }

    /// The fill-reducing permutation of the last `analyze` (`perm[new] = old`).
    pub fn permutation(&self) -> Option<&[usize]> {
        self.analysis.as_ref().map(|a| a.perm.as_slice())
    }

    /// Forgets that Cholesky failed before: the next `factorize` starts with LLᵀ.
    pub fn reset_fallback(&mut self) {
        self.indefinite_streak = 0;
    }

    /// Whether the next factorisation tries Cholesky first, after `indefinite_streak`
    /// indefinite ones in a row: always after a definite one; after 1 to 3 indefinite ones
    /// too (a failed Cholesky stops at its first bad pivot: 0.07 s against the pivoted
    /// factorisation's 0.9 s (faer's, sequential) on the 27 645-DOF compression cell, and a
    /// definite matrix saves 0.6 s;
    /// the default compression's buckling MTs give runs of 1 to 3 indefinite tangents),
    /// then only at streaks that are powers of two (a long run of indefinite tangents, as
    /// at the AFM tip, pays for a few failed tries at most).
    fn cholesky_worth_trying(&self) -> bool {
        let n = self.indefinite_streak;
        n < 4 || n.is_power_of_two()
    }

    fn try_llt(&mut self, values: &[f64]) -> Result<FactorInfo, String> {
        let analysis = self.analysis.as_ref().ok_or("not analysed")?;
        let (par, threads) = (self.factor_par(analysis), self.tree_threads(analysis));
        let a = self.analysis.as_mut().ok_or("not analysed")?;
        a.solve_threads = threads;
        let factor = LltFactor {
            symbolic: &a.symbolic,
            tree: a.tree.as_ref(),
            pattern: &a.pattern,
            par,
            threads,
        };
        factor
            .numeric(values, &mut a.l_values, &a.tree_workspaces, &mut a.mem)
            .map_err(|f| f.message)?;
        let sym = supernodal(&a.symbolic)?;
        let l = SupernodalLltRef::new(sym, &a.l_values);
        for s in 0..sym.n_supernodes() {
            let block = l.supernode(s).val();
            let scale = supernode_diag_scale(a, sym, s, values);
            for k in 0..block.ncols() {
                let pivot = block[(k, k)] * block[(k, k)];
                if !(pivot > self.pivot_tolerance * scale) {
                    return Err(format!("Cholesky pivot {pivot:e} tiny (scale {scale:e})"));
                }
            }
        }
        Ok(FactorInfo {
            method: FactorMethod::Cholesky,
            negative_pivots: Some(0),
        })
    }

    /// Returns the factor info and whether the matrix proved positive definite.
    ///
    /// On the elimination tree ([`TreeCholesky::factorize_pivoted`]) when there is one:
    /// faer's own supernodal Bunch–Kaufman runs its supernodes in order, and its threaded
    /// dense kernels cost more than they gained on 2 threads (the adherent apex: 122.2 s
    /// wall and 14 s of system time threaded, 105.4 s sequential; docs/performance.md,
    /// "Bunch–Kaufman on one thread"), so without a tree it runs sequentially.
    fn try_lblt(&mut self, values: &[f64]) -> Result<(FactorInfo, bool), LbltFailure> {
        let threads = self.tree_threads(self.analysis.as_ref().ok_or("not analysed")?);
        let a = self.analysis.as_mut().ok_or("not analysed")?;
        match a.tree.as_ref() {
            Some(tree) => tree
                .factorize_pivoted(
                    &mut a.l_values,
                    &mut a.subdiag,
                    &mut a.bk_fwd,
                    &mut a.bk_inv,
                    values,
                    threads,
                    &a.tree_workspaces,
                )
                .map_err(|f| f.message)?,
            _ => {
                let mat = csc_ref(&a.pattern, values);
                let mut stack = MemStack::new(&mut a.mem);
                a.symbolic.factorize_numeric_intranode_lblt(
                    &mut a.l_values,
                    &mut a.subdiag,
                    &mut a.bk_fwd,
                    &mut a.bk_inv,
                    mat,
                    Side::Lower,
                    Par::Seq,
                    &mut stack,
                    Spec::default(),
                );
            }
        }
        let sym = supernodal(&a.symbolic)?;
        let perm = faer::perm::PermRef::new_checked(&a.bk_fwd, &a.bk_inv, a.n);
        let tolerance = self.pivot_tolerance;
        let (negative, two_by_two, tiny_pivot) =
            lblt_inertia(sym, &a.l_values, &a.subdiag, perm, |s| {
                tolerance * supernode_diag_scale(a, sym, s, values)
            })?;
        let info = FactorInfo {
            method: FactorMethod::Ldlt,
            negative_pivots: Some(negative),
        };
        if let Some(message) = tiny_pivot {
            // A pivot below the tolerance need not mean a singular matrix: pivoting stays
            // inside each supernode, and the tolerance is relative to the supernode's
            // largest diagonal entry. The solve decides, as for LU: the factor is kept when
            // it solves A x = A z to the probe's forward error (with the pivoted solve's
            // refinement). Before, such a matrix went to LU, 12-14 s per factorisation on
            // the 27 645-DOF compression cell against 0.8 s here.
            self.numeric = Some(Numeric::Lblt);
            let error = self.probe_forward_error(values);
            self.numeric = None;
            if !(error <= LU_PROBE_TOLERANCE) {
                return Err(LbltFailure {
                    message: format!("{message}; probe forward error {error:e}"),
                    near_null_space_only: error < 1.0,
                });
            }
            return Ok((info, false));
        }
        Ok((info, negative == 0 && two_by_two == 0))
    }

    /// ‖x − z‖/‖z‖ for `x` solved by the current factor (with its solve's refinement) from
    /// `A z`, for a fixed `z`: small when the factor resolves A, large along a null space
    /// (a singular A still solves this consistent system with a small residual).
    fn probe_forward_error(&mut self, values: &[f64]) -> f64 {
        let Some(a) = self.analysis.as_ref() else {
            return f64::INFINITY;
        };
        let z = probe_vector(a.n);
        let mut x = vec![0.0; a.n];
        a.pattern.sym_mul(values, &z, &mut x);
        if self.solve_in_place(&mut x).is_err() {
            return f64::INFINITY;
        }
        dist(&x, &z) / norm(&z)
    }

    fn try_lu(&mut self, values: &[f64]) -> Result<FactorInfo, String> {
        let a = self.analysis.as_mut().ok_or("not analysed")?;
        let mut triplets = Vec::with_capacity(2 * values.len());
        for c in 0..a.n {
            for k in a.pattern.col_ptr[c]..a.pattern.col_ptr[c + 1] {
                let r = a.pattern.row_idx[k];
                triplets.push(Triplet::new(r, c, values[k]));
                if r != c {
                    triplets.push(Triplet::new(c, r, values[k]));
                }
            }
        }
        let full = SparseColMat::<usize, f64>::try_new_from_triplets(a.n, a.n, &triplets)
            .map_err(|e| format!("LU: {e:?}"))?;
        let lu = full.sp_lu().map_err(|e| format!("LU: {e:?}"))?;
        // Probe: solve A x = A z for a fixed z. A singular A still solves this consistent
        // system with a small residual, but x drifts from z along the null space, so the
        // forward error is what is checked (accepts condition numbers up to about 1e10).
        let z = probe_vector(a.n);
        let mut x = vec![0.0; a.n];
        a.pattern.sym_mul(values, &z, &mut x);
        lu.solve_in_place(MatMut::from_column_major_slice_mut(&mut x, a.n, 1));
        let (err, nz) = (dist(&x, &z), norm(&z));
        if !(err <= LU_PROBE_TOLERANCE * nz) {
            return Err(format!("LU: probe forward error {:e}", err / nz));
        }
        self.numeric = Some(Numeric::Lu(Box::new(lu)));
        Ok(FactorInfo {
            method: FactorMethod::Lu,
            negative_pivots: None,
        })
    }

    /// One solve with the current factor, no refinement.
    fn raw_solve(&mut self, rhs: &mut [f64]) -> Result<(), LinSolveError> {
        let par = self.solve_par()?;
        let a = self
            .analysis
            .as_mut()
            .ok_or_else(|| usage("solve before analyze"))?;
        let n = a.n;
        let mut stack = MemStack::new(&mut a.mem);
        let rhs_mat = MatMut::from_column_major_slice_mut(rhs, n, 1);
        match self.numeric.as_ref() {
            None => return Err(usage("solve before a successful factorize")),
            Some(Numeric::Llt) => match a.tree.as_ref() {
                Some(tree) => {
                    for (y, &old) in a.tree_y.iter_mut().zip(&a.tree_perm) {
                        *y = rhs_mat[(old, 0)];
                    }
                    tree.solve_in_place(
                        &a.l_values,
                        &mut a.tree_y,
                        &mut a.tree_products,
                        a.solve_threads,
                    );
                    for (&y, &old) in a.tree_y.iter().zip(&a.tree_perm) {
                        rhs[old] = y;
                    }
                }
                None => LltRef::new(&a.symbolic, &a.l_values).solve_in_place_with_conj(
                    Conj::No,
                    rhs_mat,
                    par,
                    &mut stack,
                ),
            },
            Some(Numeric::Lblt) => {
                let perm = faer::perm::PermRef::new_checked(&a.bk_fwd, &a.bk_inv, n);
                IntranodeLbltRef::new(&a.symbolic, &a.l_values, &a.subdiag, perm)
                    .solve_in_place_with_conj(Conj::No, rhs_mat, par, &mut stack)
            }
            Some(Numeric::Lu(lu)) => lu.solve_in_place(rhs_mat),
            Some(Numeric::Llt32 | Numeric::Lblt32) => {
                return Err(usage("raw_solve with a single-precision factor"));
            }
        }
        Ok(())
    }
}

impl LinearSolver for FaerSparseSolver {
    fn analyze(&mut self, pattern: &SparsityPattern) -> Result<(), LinSolveError> {
        validate_pattern(pattern)?;
        self.numeric = None;
        self.analysis = None;
        self.indefinite_streak = 0;
        let n = pattern.n;
        let t0 = Instant::now();
        let perm: Vec<usize> = match self.ordering {
            FillOrdering::NestedDissection => nested_dissection(pattern)?,
            FillOrdering::Natural => (0..n).collect(),
            FillOrdering::Amd => Vec::new(), // computed by faer below
        };
        let ordering_seconds = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let inv = super::ordering::inverse_permutation(&perm);
        let structure =
            SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
        let ord = match self.ordering {
            FillOrdering::Amd => SymmetricOrdering::Amd,
            _ => SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(&perm, &inv, n)),
        };
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let symbolic = factorize_symbolic_cholesky(structure, Side::Lower, ord, params)
            .map_err(|e| usage(&format!("symbolic factorisation failed: {e:?}")))?;
        let mut symbolic_seconds = t1.elapsed().as_secs_f64();
        let perm = match (self.ordering, symbolic.perm()) {
            (FillOrdering::Amd, Some(p)) => {
                let amd = p.arrays().0.to_vec();
                symbolic_seconds = 0.0; // faer's AMD runs inside the symbolic step
                amd
            }
            _ => perm,
        };
        let ordering_seconds = if self.ordering == FillOrdering::Amd {
            t1.elapsed().as_secs_f64()
        } else {
            ordering_seconds
        };
        if !is_permutation(&perm, n) {
            return Err(usage("the fill-reducing ordering is not a permutation"));
        }
        let sym = supernodal(&symbolic).map_err(|e| usage(&e))?;
        let widths = (0..sym.n_supernodes()).map(|s| {
            let w = sym.supernode_end()[s] - sym.supernode_begin()[s];
            let below = sym.col_ptr_for_row_idx()[s + 1] - sym.col_ptr_for_row_idx()[s];
            (w, below)
        });
        let stored_l = widths
            .clone()
            .map(|(w, below)| w * (w + 1) / 2 + w * below)
            .sum();
        // Column k of a supernode of width w stores (w - k) + below entries.
        let factor_flops = widths
            .flat_map(|(w, below)| (0..w).map(move |k| ((w - k + below) as f64).powi(2)))
            .sum();
        // The tree walks faer's symbolic factor, in faer's own order of the columns.
        let factor_perm: Vec<usize> = match symbolic.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..n).collect(),
        };
        let tree = TreeCholesky::new(pattern, &factor_perm, sym).ok();
        let tree_len = |len: usize| if tree.is_some() { len } else { 0 };
        let tree_scratch = tree.as_ref().map_or(0, TreeCholesky::solve_scratch_len);
        let info = AnalysisInfo {
            tree_factorisation: tree.is_some(),
            ordering: self.ordering,
            n,
            nnz_a: pattern.nnz(),
            nnz_l: cholesky_fill(pattern, &perm),
            stored_l,
            supernodes: sym.n_supernodes(),
            ordering_seconds,
            symbolic_seconds,
            factor_flops,
        };
        // The workspace covers the widest parallelism a later factorisation may pick.
        let max_threads = match self.threads {
            0 => rayon::current_num_threads(),
            t => t,
        }
        .max(1);
        let widest = if max_threads > 1 {
            Par::rayon(max_threads)
        } else {
            Par::Seq
        };
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(widest, Spec::default()),
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Spec::default()),
            // The LDLᵀ always runs sequentially (`try_lblt`).
            symbolic.factorize_numeric_intranode_lblt_scratch::<f64>(Par::Seq, Spec::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
            symbolic.solve_in_place_scratch::<f64>(1, widest),
            symbolic.factorize_numeric_llt_scratch::<f32>(widest, Spec::default()),
            symbolic.factorize_numeric_llt_scratch::<f32>(Par::Seq, Spec::default()),
            symbolic.solve_in_place_scratch::<f32>(1, Par::Seq),
            symbolic.solve_in_place_scratch::<f32>(1, widest),
        ]);
        let mixed_len = |len: usize| if self.mixed { len } else { 0 };
        let len_val = symbolic.len_val();
        let mem = MemBuffer::try_new(req)
            .map_err(|_| usage("out of memory for the factorisation workspace"))?;
        let diag_pos = (0..n).map(|c| pattern.col_ptr[c]).collect();
        self.analysis = Some(Analysis {
            n,
            pattern: pattern.clone(),
            diag_pos,
            perm,
            l_values: vec![0.0; symbolic.len_val()],
            subdiag: vec![0.0; n],
            bk_fwd: vec![0; n],
            bk_inv: vec![0; n],
            symbolic,
            tree_y: vec![0.0; tree_len(n)],
            tree_y32: vec![0.0; mixed_len(tree_len(n))],
            tree_products: vec![0.0; tree_scratch],
            tree_products32: vec![0.0; mixed_len(tree_scratch)],
            tree_perm: if tree.is_some() {
                factor_perm
            } else {
                Vec::new()
            },
            solve_threads: 1,
            tree,
            tree_workspaces: WorkspacePool::default(),
            tree_workspaces32: WorkspacePool::default(),
            mem,
            max_threads,
            values: Vec::new(),
            info,
            values32: vec![0.0; mixed_len(pattern.nnz())],
            l_values32: vec![0.0; mixed_len(len_val)],
            subdiag32: vec![0.0; mixed_len(n)],
            x32: vec![0.0; mixed_len(n)],
            scale: vec![0.0; mixed_len(n)],
            refine_b: vec![0.0; mixed_len(n)],
            refine_r: vec![0.0; mixed_len(n)],
            cg_p: vec![0.0; mixed_len(n)],
            cg_ap: vec![0.0; mixed_len(n)],
            krylov: Vec::new(),
        });
        Ok(())
    }

    fn factorize(&mut self, values: &[f64]) -> Result<FactorInfo, LinSolveError> {
        let a = self
            .analysis
            .as_mut()
            .ok_or_else(|| usage("factorize before analyze"))?;
        if values.len() != a.pattern.nnz() {
            return Err(usage(&format!(
                "factorize: expected {} values (pattern nnz), found {}",
                a.pattern.nnz(),
                values.len()
            )));
        }
        a.values.clear();
        a.values.extend_from_slice(values);
        self.numeric = None;
        if self.mixed && !self.mixed_off && self.cholesky_worth_trying() {
            match self.try_llt32(values) {
                Ok(info) => {
                    self.numeric = Some(Numeric::Llt32);
                    self.stats.single_factorizations += 1;
                    self.indefinite_streak = 0;
                    return Ok(info);
                }
                Err(failure) => {
                    // A pivot clearly below zero, or a failure right after an indefinite
                    // matrix, says this one is indefinite: no double-precision Cholesky.
                    // Otherwise single precision may just not have resolved it.
                    let indefinite = failure.pivot.is_some_and(|p| p < -INDEFINITE_SINGLE_PIVOT);
                    let cholesky = !indefinite && self.indefinite_streak == 0;
                    if !cholesky {
                        if let Some(info) = self.try_pivoted_single(values) {
                            return Ok(info);
                        }
                    }
                    let info = self.factorize_double(values, cholesky)?;
                    if info.method == FactorMethod::Cholesky {
                        // Positive definite after all: single precision did not resolve it.
                        self.fall_back_to_double();
                    }
                    return Ok(info);
                }
            }
        }
        let cholesky = self.cholesky_worth_trying();
        if !cholesky && self.mixed && !self.mixed_off {
            if let Some(info) = self.try_pivoted_single(values) {
                return Ok(info);
            }
        }
        self.factorize_double(values, cholesky)
    }

    fn mixed_precision_stats(&self) -> Option<MixedPrecisionStats> {
        Some(self.stats)
    }

    fn factor_size(&self) -> Option<super::FactorSize> {
        self.analysis_info().map(|i| super::FactorSize {
            nonzeros: i.nnz_l,
            flops: i.factor_flops,
        })
    }

    fn solve_approximately_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinSolveError> {
        let pivoted = match self.numeric {
            Some(Numeric::Llt32) => false,
            Some(Numeric::Lblt32) => true,
            _ => return self.solve_in_place(rhs),
        };
        let (par, a) = self.solve_setup()?;
        if rhs.len() != a.n {
            return Err(usage(&format!(
                "solve: expected rhs of length {}, found {}",
                a.n,
                rhs.len()
            )));
        }
        if pivoted {
            pivoted_single_solve(a, rhs);
        } else {
            single_precision_solve(a, rhs, par);
        }
        for (x, &y) in rhs.iter_mut().zip(&a.x32) {
            *x = f64::from(y);
        }
        self.stats.unrefined_solves += 1;
        Ok(())
    }

    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinSolveError> {
        self.solve_to_in_place(rhs, MIXED_SOLVE_TOLERANCE)
    }

    /// Mixed precision: the conjugate gradients stop at `tolerance` of the solution (at
    /// least [`MIXED_SOLVE_TOLERANCE`]); they run at least one iteration, so a factor that
    /// does not resolve the matrix still breaks them down or runs them out and falls back.
    /// Double-precision factors solve in full.
    fn solve_to_in_place(&mut self, rhs: &mut [f64], tolerance: f64) -> Result<(), LinSolveError> {
        let tolerance = tolerance.max(MIXED_SOLVE_TOLERANCE);
        let a = self
            .analysis
            .as_ref()
            .ok_or_else(|| usage("solve before analyze"))?;
        let n = a.n;
        if rhs.len() != n {
            return Err(usage(&format!(
                "solve: expected rhs of length {n}, found {}",
                rhs.len()
            )));
        }
        match self.numeric {
            Some(Numeric::Llt) => return self.raw_solve(rhs),
            Some(Numeric::Llt32) => {
                if self.refined_single_solve(rhs, tolerance)? {
                    return Ok(());
                }
                // The conjugate gradients did not get there: double precision from the saved
                // right-hand side.
                self.fall_back_to_double();
                return self.solve_again_in_double(rhs, true);
            }
            Some(Numeric::Lblt32) => {
                let max_iterations = self.mixed_max_iterations;
                let a = self
                    .analysis
                    .as_mut()
                    .ok_or_else(|| usage("not analysed"))?;
                let (steps, resolved) = gmres_single_solve(a, rhs, tolerance, max_iterations);
                self.stats.refinement_steps += steps;
                if resolved {
                    return Ok(());
                }
                // GMRES did not get there: this matrix, and the indefinite ones after it, in
                // double precision (the positive definite ones stay in single precision).
                self.pivoted_single_off = true;
                self.stats.fallbacks += 1;
                return self.solve_again_in_double(rhs, false);
            }
            _ => {}
        }
        // Pivoted factorisations: up to two steps of iterative refinement, x += A⁻¹ (b − A x).
        let b = rhs.to_vec();
        self.raw_solve(rhs)?;
        let mut r = vec![0.0; n];
        for _ in 0..2 {
            let a = self
                .analysis
                .as_ref()
                .ok_or_else(|| usage("solve before analyze"))?;
            a.pattern.sym_mul(&a.values, rhs, &mut r);
            r.iter_mut().zip(&b).for_each(|(ri, bi)| *ri = bi - *ri);
            if norm(&r) <= 1e-15 * norm(&b) {
                break;
            }
            self.raw_solve(&mut r)?;
            rhs.iter_mut().zip(&r).for_each(|(x, d)| *x += d);
        }
        Ok(())
    }
}

impl FaerSparseSolver {
    /// The parallelism of the current factor's solves and the analysis they use.
    fn solve_setup(&mut self) -> Result<(Par, &mut Analysis), LinSolveError> {
        let par = self.solve_par()?;
        let a = self
            .analysis
            .as_mut()
            .ok_or_else(|| usage("solve before analyze"))?;
        Ok((par, a))
    }

    /// The parallelism of the current factor's solves: always sequential. faer's parallel
    /// triangular solves sum in another order than its sequential ones, so above
    /// `parallel_min_flops` the results depended on the thread count (8.8e-16 relative on
    /// the fine suspended mesh); sequential solves make them bitwise the same on any number
    /// of threads and cost 0.5 s of 48 s there (docs/performance.md, eighth session).
    fn solve_par(&self) -> Result<Par, LinSolveError> {
        self.analysis
            .as_ref()
            .ok_or_else(|| usage("solve before analyze"))?;
        Ok(Par::Seq)
    }

    /// A single-precision solve that did not get there: the kept matrix factorised in
    /// double precision (LLᵀ first when `cholesky`) and solved from the right-hand side
    /// saved in `refine_b` (once per solver: a copy of the values keeps the borrows
    /// simple).
    fn solve_again_in_double(
        &mut self,
        rhs: &mut [f64],
        cholesky: bool,
    ) -> Result<(), LinSolveError> {
        let a = self
            .analysis
            .as_mut()
            .ok_or_else(|| usage("not analysed"))?;
        rhs.copy_from_slice(&a.refine_b);
        let values = a.values.clone();
        self.factorize_double(&values, cholesky)?;
        self.solve_in_place(rhs)
    }

    /// Single precision did not resolve the matrix: double precision from now on.
    fn fall_back_to_double(&mut self) {
        self.mixed_off = true;
        self.stats.fallbacks += 1;
        if let Some(a) = self.analysis.as_mut() {
            // The buffers are not needed any more.
            a.values32 = Vec::new();
            a.l_values32 = Vec::new();
        }
    }

    /// LLᵀ in single precision of the matrix scaled to a unit diagonal (`a.scale` =
    /// 1/√A_jj); fails on a diagonal entry that is not positive or a pivot `L_kk²` below
    /// [`MIXED_PIVOT_FLOOR`] (or the solver's pivot tolerance, if larger).
    fn try_llt32(&mut self, values: &[f64]) -> Result<FactorInfo, FactorFailure> {
        let analysis = self.analysis.as_ref().ok_or("not analysed")?;
        let (par, threads) = (self.factor_par(analysis), self.tree_threads(analysis));
        let a = self.analysis.as_mut().ok_or("not analysed")?;
        a.solve_threads = threads;
        for c in 0..a.n {
            let d = values[a.diag_pos[c]];
            if !(d > 0.0) {
                return Err(FactorFailure {
                    message: format!("diagonal entry {d:e} not positive"),
                    // As a pivot of the unit-diagonal matrix: -1 when negative.
                    pivot: (d < 0.0).then_some(-1.0),
                });
            }
            a.scale[c] = 1.0 / d.sqrt();
        }
        scale_into_values32(a, values);
        let factor = LltFactor {
            symbolic: &a.symbolic,
            tree: a.tree.as_ref(),
            pattern: &a.pattern,
            par,
            threads,
        };
        factor
            .numeric(
                &a.values32,
                &mut a.l_values32,
                &a.tree_workspaces32,
                &mut a.mem,
            )
            .map_err(|f| FactorFailure {
                message: format!("single-precision {}", f.message),
                ..f
            })?;
        let sym = supernodal(&a.symbolic)?;
        let l = SupernodalLltRef::new(sym, &a.l_values32);
        let floor = self.pivot_tolerance.max(MIXED_PIVOT_FLOOR);
        for s in 0..sym.n_supernodes() {
            let block = l.supernode(s).val();
            for k in 0..block.ncols() {
                // The scaled matrix has a unit diagonal, so the pivot is the share of its
                // column's stiffness left after the elimination (that many digits cancelled).
                let pivot = f64::from(block[(k, k)]).powi(2);
                if !(pivot > floor) {
                    return Err(
                        format!("single-precision pivot {pivot:e} of a unit diagonal").into(),
                    );
                }
            }
        }
        Ok(FactorInfo {
            method: FactorMethod::Cholesky,
            negative_pivots: Some(0),
        })
    }

    /// An indefinite matrix in single precision ([`Self::try_lblt32`]); `None` (nothing
    /// changed but scratch) when that does not resolve it, for the double-precision path.
    fn try_pivoted_single(&mut self, values: &[f64]) -> Option<FactorInfo> {
        if !self.pivoted_single || self.pivoted_single_off {
            return None;
        }
        let Ok((info, definite)) = self.try_lblt32(values) else {
            self.stats.single_pivoted_refused += 1;
            return None;
        };
        self.numeric = Some(Numeric::Lblt32);
        self.stats.single_pivoted_factorizations += 1;
        self.indefinite_streak = if definite {
            0
        } else {
            self.indefinite_streak + 1
        };
        Some(info)
    }

    /// Bunch–Kaufman LDLᵀ in single precision on the elimination tree
    /// ([`TreeCholesky::factorize_pivoted`]) of the matrix scaled to a unit |diagonal|
    /// (`a.scale` = 1/√|A_jj|). Fails without a tree, on a zero diagonal entry, and on a
    /// pivot (or a 2x2 block's eigenvalue) below [`MIXED_PIVOT_FLOOR`] in magnitude: not
    /// even its sign is known in single precision, so the inertia would not be either.
    /// Returns the inertia as [`Self::try_lblt`] does and whether the matrix proved
    /// positive definite.
    fn try_lblt32(&mut self, values: &[f64]) -> Result<(FactorInfo, bool), String> {
        let threads = self.tree_threads(self.analysis.as_ref().ok_or("not analysed")?);
        let floor = self.pivot_tolerance.max(MIXED_PIVOT_FLOOR);
        let a = self.analysis.as_mut().ok_or("not analysed")?;
        if a.tree.is_none() {
            return Err("no elimination tree".into());
        }
        for c in 0..a.n {
            let d = values[a.diag_pos[c]].abs();
            if !(d > 0.0 && d.is_finite()) {
                return Err(format!("diagonal entry {d:e}"));
            }
            a.scale[c] = 1.0 / d.sqrt();
        }
        scale_into_values32(a, values);
        let tree = a.tree.as_ref().ok_or("no elimination tree")?;
        tree.factorize_pivoted(
            &mut a.l_values32,
            &mut a.subdiag32,
            &mut a.bk_fwd,
            &mut a.bk_inv,
            &a.values32,
            threads,
            &a.tree_workspaces32,
        )
        .map_err(|f| format!("single-precision {}", f.message))?;
        let sym = supernodal(&a.symbolic)?;
        let perm = faer::perm::PermRef::new_checked(&a.bk_fwd, &a.bk_inv, a.n);
        let (negative, two_by_two, tiny_pivot) =
            lblt_inertia(sym, &a.l_values32, &a.subdiag32, perm, |_| floor)?;
        if let Some(message) = tiny_pivot {
            return Err(format!("single-precision {message}"));
        }
        let info = FactorInfo {
            method: FactorMethod::Ldlt,
            negative_pivots: Some(negative),
        };
        Ok((info, negative == 0 && two_by_two == 0))
    }

    /// Solves by conjugate gradients in double precision preconditioned with the
    /// single-precision factor ([`pcg_single_solve`]) to `tolerance` of the solution. False
    /// (with `rhs` garbage, the right-hand side kept in `refine_b`) when they break down or
    /// the iterations run out.
    fn refined_single_solve(
        &mut self,
        rhs: &mut [f64],
        tolerance: f64,
    ) -> Result<bool, LinSolveError> {
        let max_iterations = self.mixed_max_iterations;
        let (par, a) = self.solve_setup()?;
        let (steps, resolved) = pcg_single_solve(a, rhs, par, tolerance, max_iterations);
        self.stats.refinement_steps += steps;
        Ok(resolved)
    }

    /// LLᵀ (when `cholesky`), then Bunch-Kaufman LDLᵀ, then LU, in double precision.
    fn factorize_double(
        &mut self,
        values: &[f64],
        cholesky: bool,
    ) -> Result<FactorInfo, LinSolveError> {
        let mut failures = Vec::new();
        if cholesky {
            match self.try_llt(values) {
                Ok(info) => {
                    self.numeric = Some(Numeric::Llt);
                    self.indefinite_streak = 0;
                    return Ok(info);
                }
                Err(e) => failures.push(e),
            }
        }
        match self.try_lblt(values) {
            Ok((info, definite)) => {
                self.numeric = Some(Numeric::Lblt);
                self.indefinite_streak = if definite {
                    0
                } else {
                    self.indefinite_streak + 1
                };
                return Ok(info);
            }
            Err(e) if e.near_null_space_only => {
                // The pivoted factor, refined, solved the probe to a forward error below 1:
                // it resolves the matrix except along a near-null space, so the matrix is
                // singular to working accuracy, and an LU (no refinement, no better pivots
                // for a symmetric matrix) cannot do better. On the suspended battery's 9
                // such tangents LU's error was 1.2e-3 to 1.5 against LDLᵀ's 6e-6 to 2.2e-3,
                // never accepted, at about 25 s each on one thread (docs/linear-solver.md,
                // "LU only where it can help").
                failures.push(e.message);
                failures
                    .push("LU not tried: the refined LDLᵀ leaves only a near-null space".into());
                return Err(LinSolveError::Singular(failures.join("; ")));
            }
            Err(e) => failures.push(e.message),
        }
        match self.try_lu(values) {
            Ok(info) => {
                self.indefinite_streak += 1;
                Ok(info)
            }
            Err(e) => {
                failures.push(e);
                Err(LinSolveError::Singular(failures.join("; ")))
            }
        }
    }
}

/// `A x = rhs` by conjugate gradients in double precision preconditioned with the
/// single-precision factor `M = L₃₂L₃₂ᵀ` (scaled back from the unit diagonal), from
/// `x = 0`, until the preconditioned residual `z = M⁻¹(b − A x)` (the correction the
/// stationary refinement would take) is at most `tolerance` of `x`. Returns the
/// iterations (each one product with A and one single-precision solve) and whether it got
/// there within `max_iterations` (false also when CG breaks down: a non-positive curvature
/// `pᵀAp` or `rᵀz`, or a value that is not finite; `rhs` is then garbage and the
/// right-hand side is kept in `a.refine_b`).
///
/// β is the flexible (Polak–Ribière) one, `zₖ₊₁ᵀ(rₖ₊₁ − rₖ)/(zₖᵀrₖ)`: the rounding of the
/// single-precision solves makes `M⁻¹` slightly different at every application, which the
/// Fletcher–Reeves β of plain PCG assumes it is not (Notay 2000, "Flexible conjugate
/// gradients"). With `rₖ₊₁ − rₖ = −α A p` it needs no further vector.
fn pcg_single_solve(
    a: &mut Analysis,
    rhs: &mut [f64],
    par: Par,
    tolerance: f64,
    max_iterations: usize,
) -> (usize, bool) {
    a.refine_b.copy_from_slice(rhs);
    a.refine_r.copy_from_slice(rhs);
    rhs.fill(0.0);
    let r = std::mem::take(&mut a.refine_r);
    single_precision_solve(a, &r, par);
    a.refine_r = r;
    let mut rz = 0.0;
    for ((p, &z), &r) in a.cg_p.iter_mut().zip(&a.x32).zip(&a.refine_r) {
        *p = f64::from(z);
        rz += r * *p;
    }
    if rz == 0.0 && a.refine_b.iter().all(|&b| b == 0.0) {
        return (0, true);
    }
    for iteration in 1..=max_iterations {
        a.pattern.sym_mul(&a.values, &a.cg_p, &mut a.cg_ap);
        let pap: f64 = a.cg_p.iter().zip(&a.cg_ap).map(|(p, q)| p * q).sum();
        if !(rz > 0.0 && pap > 0.0 && rz.is_finite() && pap.is_finite()) {
            return (iteration, false);
        }
        let alpha = rz / pap;
        for (x, &p) in rhs.iter_mut().zip(&a.cg_p) {
            *x += alpha * p;
        }
        for (r, &q) in a.refine_r.iter_mut().zip(&a.cg_ap) {
            *r -= alpha * q;
        }
        let r = std::mem::take(&mut a.refine_r);
        single_precision_solve(a, &r, par);
        a.refine_r = r;
        let (mut rz_next, mut zq, mut zz, mut xx) = (0.0, 0.0, 0.0, 0.0);
        for (((&z, &r), &q), &x) in a.x32.iter().zip(&a.refine_r).zip(&a.cg_ap).zip(&*rhs) {
            let z = f64::from(z);
            rz_next += r * z;
            zq += z * q;
            zz += z * z;
            xx += x * x;
        }
        if !(zz.is_finite() && xx.is_finite()) {
            return (iteration, false);
        }
        if zz.sqrt() <= tolerance * xx.sqrt() {
            // z is the stationary refinement's correction of x, already computed: adding
            // it costs nothing and leaves an error well below the one z estimates.
            for (x, &z) in rhs.iter_mut().zip(&a.x32) {
                *x += f64::from(z);
            }
            return (iteration, true);
        }
        let beta = -alpha * zq / rz;
        for (p, &z) in a.cg_p.iter_mut().zip(&a.x32) {
            *p = f64::from(z) + beta * *p;
        }
        rz = rz_next;
    }
    (max_iterations, false)
}

/// How the numeric LLᵀ runs: on the elimination tree when `tree` is there (with up to
/// `threads` tasks), else faer's numeric step with parallelism `par`.
struct LltFactor<'a> {
    symbolic: &'a SymbolicCholesky<usize>,
    tree: Option<&'a TreeCholesky>,
    pattern: &'a SparsityPattern,
    par: Par,
    threads: usize,
}

impl LltFactor<'_> {
    /// The LLᵀ of the lower triangle `values` into `l`, in either precision (`workspaces`:
    /// the tree's, `mem`: faer's).
    fn numeric<T: TreeScalar>(
        &self,
        values: &[T],
        l: &mut [T],
        workspaces: &WorkspacePool<T>,
        mem: &mut MemBuffer,
    ) -> Result<(), FactorFailure> {
        if let Some(tree) = self.tree {
            return tree.factorize(l, values, self.threads, workspaces);
        }
        self.symbolic
            .factorize_numeric_llt(
                l,
                csc_ref(self.pattern, values),
                Side::Lower,
                Default::default(),
                self.par,
                MemStack::new(mem),
                Spec::default(),
            )
            .map(|_| ())
            .map_err(|e| format!("Cholesky: {e:?}").into())
    }
}

/// `a.x32` ← the single-precision factor's solution for `v` (scaled to and from the unit
/// diagonal the factor was computed for).
fn single_precision_solve(a: &mut Analysis, v: &[f64], par: Par) {
    let n = a.n;
    if let Some(tree) = a.tree.as_ref() {
        for (y, &old) in a.tree_y32.iter_mut().zip(&a.tree_perm) {
            *y = (v[old] * a.scale[old]) as f32;
        }
        tree.solve_in_place(
            &a.l_values32,
            &mut a.tree_y32,
            &mut a.tree_products32,
            a.solve_threads,
        );
        for (&y, &old) in a.tree_y32.iter().zip(&a.tree_perm) {
            a.x32[old] = (f64::from(y) * a.scale[old]) as f32;
        }
        return;
    }
    scaled_into_x32(a, v);
    let mut stack = MemStack::new(&mut a.mem);
    LltRef::new(&a.symbolic, &a.l_values32).solve_in_place_with_conj(
        Conj::No,
        MatMut::from_column_major_slice_mut(&mut a.x32, n, 1),
        par,
        &mut stack,
    );
    unscale_x32(a);
}

/// `a.values32` ← `values` scaled symmetrically by `a.scale` (`D^{-1/2} A D^{-1/2}`), in
/// single precision: the matrix the single-precision factorisations take.
fn scale_into_values32(a: &mut Analysis, values: &[f64]) {
    for c in 0..a.n {
        for k in a.pattern.col_ptr[c]..a.pattern.col_ptr[c + 1] {
            let scaled = values[k] * a.scale[c] * a.scale[a.pattern.row_idx[k]];
            a.values32[k] = scaled as f32;
        }
    }
}

/// `a.x32` ← `v` scaled to the unit diagonal the single-precision factor was computed for.
fn scaled_into_x32(a: &mut Analysis, v: &[f64]) {
    for ((x, &b), &d) in a.x32.iter_mut().zip(v).zip(&a.scale) {
        *x = (b * d) as f32;
    }
}

/// `a.x32` scaled back from the unit diagonal.
fn unscale_x32(a: &mut Analysis) {
    for (x, &d) in a.x32.iter_mut().zip(&a.scale) {
        *x = (f64::from(*x) * d) as f32;
    }
}

/// Inertia of a Bunch–Kaufman factor `l`, `subdiag`, `perm` on `sym`: the negative
/// eigenvalues of D, its 2x2 blocks, and the first pivot (or 2x2 block eigenvalue) not
/// above `tiny(s)` in magnitude in supernode `s`, if any. Fails on a value that is not
/// finite.
fn lblt_inertia<T: TreeScalar>(
    sym: &SymbolicSupernodalCholesky<usize>,
    l: &[T],
    subdiag: &[T],
    perm: faer::perm::PermRef<'_, usize>,
    tiny: impl Fn(usize) -> f64,
) -> Result<(usize, usize, Option<String>), String> {
    let f = SupernodalIntranodeLbltRef::new(sym, l, subdiag, perm);
    let (mut negative, mut two_by_two) = (0usize, 0usize);
    let mut tiny_pivot: Option<String> = None;
    for s in 0..sym.n_supernodes() {
        let node = f.supernode(s);
        let d = node.val();
        let start = node.start();
        let tiny = tiny(s);
        let mut k = 0;
        while k < d.ncols() {
            let b = subdiag[start + k].to_f64();
            if b == 0.0 {
                let p = d[(k, k)].to_f64();
                if !p.is_finite() {
                    return Err(format!("LDLt pivot {p:e}"));
                }
                if !(p.abs() > tiny) && tiny_pivot.is_none() {
                    tiny_pivot = Some(format!("LDLt pivot {p:e} tiny (below {tiny:e})"));
                }
                negative += usize::from(p < 0.0);
                k += 1;
            } else {
                let (p, q) = (d[(k, k)].to_f64(), d[(k + 1, k + 1)].to_f64());
                // Eigenvalues of [[p, b], [b, q]].
                let (mean, radius) = (0.5 * (p + q), (0.25 * (p - q).powi(2) + b * b).sqrt());
                let (lo, hi) = (mean - radius, mean + radius);
                if !(lo.is_finite() && hi.is_finite()) {
                    return Err(format!("LDLt 2x2 pivot block {lo:e}/{hi:e}"));
                }
                if !(lo.abs() > tiny && hi.abs() > tiny) && tiny_pivot.is_none() {
                    tiny_pivot = Some(format!(
                        "LDLt 2x2 pivot block {lo:e}/{hi:e} tiny (below {tiny:e})"
                    ));
                }
                negative += usize::from(lo < 0.0) + usize::from(hi < 0.0);
                two_by_two += 1;
                k += 2;
            }
        }
    }
    Ok((negative, two_by_two, tiny_pivot))
}

/// `a.x32` ← the single-precision LDLᵀ's solution for `v` (scaled to and from the unit
/// |diagonal| the factor was computed for); faer's sequential supernodal solve.
fn pivoted_single_solve(a: &mut Analysis, v: &[f64]) {
    let n = a.n;
    scaled_into_x32(a, v);
    let mut stack = MemStack::new(&mut a.mem);
    let perm = faer::perm::PermRef::new_checked(&a.bk_fwd, &a.bk_inv, n);
    IntranodeLbltRef::new(&a.symbolic, &a.l_values32, &a.subdiag32, perm).solve_in_place_with_conj(
        Conj::No,
        MatMut::from_column_major_slice_mut(&mut a.x32, n, 1),
        Par::Seq,
        &mut stack,
    );
    unscale_x32(a);
}

/// `A x = rhs` in double precision with the single-precision LDLᵀ `M`
/// ([`pivoted_single_solve`]) as preconditioner, for indefinite matrices (conjugate
/// gradients need a definite matrix and preconditioner). It starts from the unrefined
/// solve `x = M⁻¹b` and stops, as [`pcg_single_solve`] does, when the correction a step of
/// stationary refinement would take, `z = M⁻¹(b − A x)`, is at most `tolerance` of `x`
/// (then adds it). Until then it runs cycles of flexible GMRES (Saad 1993) on the residual
/// equation, each reducing `‖b − A x‖` by `tolerance`: the preconditioned vectors
/// `M⁻¹vⱼ` are kept, so the single-precision solves' rounding (a slightly different `M⁻¹`
/// at every application) does not corrupt the residual the cycle minimises, which it did
/// with a left-preconditioned GMRES (estimates of 1e-6 for true residuals of 3e-2 on a
/// nearly incompressible matrix). Returns the GMRES iterations (each one product with A
/// and one single-precision solve) and whether it got there within `max_iterations` (false
/// also on a value that is not finite; `rhs` is then garbage and the right-hand side is
/// kept in `a.refine_b`).
fn gmres_single_solve(
    a: &mut Analysis,
    rhs: &mut [f64],
    tolerance: f64,
    max_iterations: usize,
) -> (usize, bool) {
    let n = a.n;
    let m = max_iterations.max(1);
    a.refine_b.copy_from_slice(rhs);
    a.refine_r.copy_from_slice(rhs);
    // Basis V (m + 1 vectors) and its preconditioned images Z (m vectors).
    a.krylov.resize((2 * m + 1) * n, 0.0);
    rhs.fill(0.0);
    let mut steps = 0;
    let mut started = false;
    loop {
        let r = std::mem::take(&mut a.refine_r);
        pivoted_single_solve(a, &r);
        a.refine_r = r;
        let (mut zz, mut xx) = (0.0, 0.0);
        for (&z, &x) in a.x32.iter().zip(&*rhs) {
            zz += f64::from(z).powi(2);
            xx += x * x;
        }
        if !(zz.is_finite() && xx.is_finite()) {
            return (steps, false);
        }
        if zz == 0.0 || (started && zz.sqrt() <= tolerance * xx.sqrt()) {
            for (x, &z) in rhs.iter_mut().zip(&a.x32) {
                *x += f64::from(z);
            }
            return (steps, true);
        }
        if !started {
            // The unrefined solve is the start.
            for (x, &z) in rhs.iter_mut().zip(&a.x32) {
                *x = f64::from(z);
            }
            started = true;
        } else {
            if steps >= max_iterations {
                return (steps, false);
            }
            let Some(cycle) = fgmres_cycle(a, rhs, tolerance, max_iterations - steps) else {
                return (steps, false);
            };
            steps += cycle;
        }
        // r = b − A x
        a.pattern.sym_mul(&a.values, rhs, &mut a.refine_r);
        for (r, &b) in a.refine_r.iter_mut().zip(&a.refine_b) {
            *r = b - *r;
        }
    }
}

/// One cycle of flexible GMRES on `A e = r` (`r` in `a.refine_r`) from `e = 0`, at most
/// `iterations` iterations, until `‖r − A e‖ ≤ tolerance ‖r‖`; adds `e` to `x`. The
/// iterations it took, or `None` on a value that is not finite or a breakdown.
fn fgmres_cycle(
    a: &mut Analysis,
    x: &mut [f64],
    tolerance: f64,
    iterations: usize,
) -> Option<usize> {
    let mut krylov = std::mem::take(&mut a.krylov);
    let result = fgmres_cycle_in(a, &mut krylov, x, tolerance, iterations);
    a.krylov = krylov;
    result
}

/// [`fgmres_cycle`] with the basis and its images in `krylov` (`(2m + 1) n` values).
fn fgmres_cycle_in(
    a: &mut Analysis,
    krylov: &mut [f64],
    x: &mut [f64],
    tolerance: f64,
    iterations: usize,
) -> Option<usize> {
    let n = a.n;
    let m = (krylov.len() / n - 1) / 2;
    let iterations = iterations.min(m);
    let beta = a.refine_r.iter().map(|r| r * r).sum::<f64>().sqrt();
    if !(beta > 0.0 && beta.is_finite()) {
        return None;
    }
    let (basis, images) = krylov.split_at_mut((m + 1) * n);
    for (v, &r) in basis[..n].iter_mut().zip(&a.refine_r) {
        *v = r / beta;
    }
    // The Hessenberg matrix by columns (column j: rows 0..=j+1), the Givens rotations, and
    // g = Qᵀ β e₁.
    let rows = m + 1;
    let mut h = vec![0.0; rows * m];
    let (mut cs, mut sn) = (vec![0.0; m], vec![0.0; m]);
    let mut g = vec![0.0; rows];
    g[0] = beta;
    let mut k = 0;
    for j in 0..iterations {
        k = j + 1;
        // z_j = M⁻¹ v_j (kept), w = A z_j in v_{j+1}.
        pivoted_single_solve(a, &basis[j * n..(j + 1) * n]);
        let z = &mut images[j * n..(j + 1) * n];
        for (z, &y) in z.iter_mut().zip(&a.x32) {
            *z = f64::from(y);
        }
        let (done, rest) = basis.split_at_mut((j + 1) * n);
        let w = &mut rest[..n];
        a.pattern.sym_mul(&a.values, z, w);
        // Modified Gram–Schmidt against the basis so far.
        let col = &mut h[j * rows..(j + 1) * rows];
        for (i, hij) in col.iter_mut().enumerate().take(j + 1) {
            let v = &done[i * n..(i + 1) * n];
            *hij = v.iter().zip(w.iter()).map(|(v, w)| v * w).sum();
            w.iter_mut().zip(v).for_each(|(w, v)| *w -= *hij * v);
        }
        let norm = w.iter().map(|w| w * w).sum::<f64>().sqrt();
        if !norm.is_finite() {
            return None;
        }
        col[j + 1] = norm;
        if norm > 0.0 {
            w.iter_mut().for_each(|w| *w /= norm);
        }
        for i in 0..j {
            let (p, q) = (col[i], col[i + 1]);
            col[i] = cs[i] * p + sn[i] * q;
            col[i + 1] = -sn[i] * p + cs[i] * q;
        }
        let r = col[j].hypot(col[j + 1]);
        if !(r > 0.0) {
            return None;
        }
        (cs[j], sn[j]) = (col[j] / r, col[j + 1] / r);
        col[j] = r;
        col[j + 1] = 0.0;
        g[j + 1] = -sn[j] * g[j];
        g[j] *= cs[j];
        if g[j + 1].abs() <= tolerance * beta || norm == 0.0 {
            break;
        }
    }
    // e = Z y with H y = g (upper triangular, k x k).
    let mut y = g[..k].to_vec();
    for i in (0..k).rev() {
        let mut sum = y[i];
        for c in i + 1..k {
            sum -= h[c * rows + i] * y[c];
        }
        y[i] = sum / h[i * rows + i];
    }
    if !y.iter().all(|y| y.is_finite()) {
        return None;
    }
    for (i, &yi) in y.iter().enumerate() {
        let z = &images[i * n..(i + 1) * n];
        x.iter_mut().zip(z).for_each(|(x, z)| *x += yi * z);
    }
    Some(k)
}

fn usage(msg: &str) -> LinSolveError {
    LinSolveError::Usage(msg.to_string())
}

/// faer view of the lower triangle (the pattern was validated in `analyze`).
fn csc_ref<'a, T>(p: &'a SparsityPattern, values: &'a [T]) -> SparseColMatRef<'a, usize, T> {
    let structure = SymbolicSparseColMatRef::new_checked(p.n, p.n, &p.col_ptr, None, &p.row_idx);
    SparseColMatRef::new(structure, values)
}

fn supernodal(
    symbolic: &SymbolicCholesky<usize>,
) -> Result<&SymbolicSupernodalCholesky<usize>, String> {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Supernodal(s) => Ok(s),
        SymbolicCholeskyRaw::Simplicial(_) => Err("expected a supernodal symbolic factor".into()),
    }
}

/// Largest |A_jj| over the original columns of supernode `s` (its columns in permuted order
/// are `begin..end`; Bunch-Kaufman pivoting only permutes inside the supernode).
fn supernode_diag_scale(
    a: &Analysis,
    sym: &SymbolicSupernodalCholesky<usize>,
    s: usize,
    values: &[f64],
) -> f64 {
    (sym.supernode_begin()[s]..sym.supernode_end()[s])
        .map(|k| values[a.diag_pos[a.perm[k]]].abs())
        .fold(f64::MIN_POSITIVE, f64::max)
}

/// Checks the lower-triangle CSC invariants, naming the first violation.
fn validate_pattern(p: &SparsityPattern) -> Result<(), LinSolveError> {
    if p.col_ptr.len() != p.n + 1 || p.col_ptr.first() != Some(&0) {
        return Err(usage(&format!(
            "pattern: col_ptr must have n + 1 = {} entries starting at 0, found {}",
            p.n + 1,
            p.col_ptr.len()
        )));
    }
    if p.col_ptr[p.n] != p.row_idx.len() {
        return Err(usage("pattern: col_ptr[n] differs from row_idx.len()"));
    }
    for c in 0..p.n {
        let (lo, hi) = (p.col_ptr[c], p.col_ptr[c + 1]);
        if hi < lo {
            return Err(usage(&format!("pattern: col_ptr decreases at column {c}")));
        }
        let rows = &p.row_idx[lo..hi];
        if rows.first() != Some(&c) {
            return Err(usage(&format!(
                "pattern: column {c} must start with its diagonal"
            )));
        }
        if rows.windows(2).any(|w| w[0] >= w[1]) || rows.last().is_some_and(|&r| r >= p.n) {
            return Err(usage(&format!(
                "pattern: rows of column {c} unsorted or out of range"
            )));
        }
    }
    Ok(())
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}
