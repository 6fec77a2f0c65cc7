//! Numeric supernodal Cholesky that runs the independent subtrees of the elimination tree
//! concurrently, on faer's symbolic factor and into faer's value layout (so faer's solves
//! use the result unchanged).
//!
//! faer 0.24's supernodal numeric factorisation is a sequential loop over the supernodes;
//! its `Par` only splits the dense kernels inside each supernode, which does not pay on
//! 2 cores below about 1e10 flops (`docs/performance.md`, "Threads"). The parallelism a
//! nested-dissection factorisation offers is the tree's: a supernode is updated only by
//! its descendants (left-looking), so two subtrees share nothing until their common
//! ancestor. Here each supernode `s` is computed left-looking, as faer does:
//!
//! 1. its block (`m × w`: the diagonal block, then the rows of its pattern) gets A's
//!    entries of its columns;
//! 2. every descendant `d` whose pattern has rows among `s`'s columns subtracts
//!    `L_d[rows ≥ begin(s)] · L_d[rows in s]ᵀ`, formed by a dense product into a workspace
//!    and scattered into the block (faer gathers inside its product; that kernel is not
//!    public);
//! 3. the diagonal block is factorised densely and the rows below are solved against it.
//!
//! The schedule walks the tree: a subtree with enough flops forks its children into two
//! groups of about equal flops (`rayon::join`), smaller subtrees are done in order. Each
//! supernode's arithmetic is the same whatever the schedule, so the factor is bitwise the
//! same on any number of threads.
//!
//! The same schedule runs faer's intranode Bunch–Kaufman LBLᵀ for indefinite matrices
//! ([`TreeCholesky::factorize_pivoted`]): step 2 subtracts `L_d[rows] (L_d[columns] B_d)ᵀ`
//! and step 3 factorises the diagonal block with pivoting inside it, into faer's layout.

use std::sync::Mutex;

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::lblt::factor as lblt;
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::{Accum, ColMut, MatMut, MatRef, Par, Spec};

use super::SparsityPattern;

/// Scalars the factorisation runs in (double, and single for mixed precision).
pub(crate) trait TreeScalar:
    faer::traits::RealField + Copy + Send + Sync + std::ops::SubAssign + std::ops::AddAssign
{
    const ZERO: Self;
    const ONE: Self;
    fn to_f64(self) -> f64;
}

impl TreeScalar for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    fn to_f64(self) -> f64 {
        self
    }
}

impl TreeScalar for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}

/// Why a factorisation on the tree stopped.
#[derive(Debug)]
pub(crate) struct FactorFailure {
    pub(crate) message: String,
    /// The Cholesky's first pivot that was not positive (its value before the square
    /// root), when that is what stopped it.
    pub(crate) pivot: Option<f64>,
}

impl From<String> for FactorFailure {
    fn from(message: String) -> Self {
        FactorFailure {
            message,
            pivot: None,
        }
    }
}

impl From<&str> for FactorFailure {
    fn from(message: &str) -> Self {
        message.to_string().into()
    }
}

/// Subtrees with fewer flops (`Σ c_j²` of their columns) are factorised by one task.
const MIN_FORK_FLOPS: f64 = 2e6;

/// Updates into one supernode with at least this many flops are split by columns into
/// two tasks (recursively, [`MAX_UPDATE_SPLITS`] times at most).
const MIN_SPLIT_UPDATE_FLOPS: f64 = 2e7;

/// Rows of an update product formed at once (bounds the product buffer to this many rows
/// times the widest update).
const ROW_BLOCK: usize = 256;

/// Most halvings of one supernode's update columns (at most 2^this tasks, each with its
/// own product buffer).
const MAX_UPDATE_SPLITS: usize = 2;

/// A supernode of the top of the tree (factorised while nothing else runs) with at least
/// this many flops of its own uses the pool's threads in its dense kernels. Measured
/// (docs/performance.md, eighth session): at 5e7 the 9k-DOF sphere's top kernels split
/// into so many tasks that a run made 346 000 futex calls (7 000 with 1e9) for the same
/// factorisation time; at 32k and 100k DOFs 1e9 and 5e7 factorise equally fast.
const MIN_DENSE_PARALLEL_FLOPS: f64 = 1e9;

/// Subtrees whose solve reads fewer entries of L are solved by one task.
const MIN_FORK_SOLVE_ENTRIES: usize = 200_000;

/// What the tasks of one solve share: the solution, the supernodes' products, the factor.
struct SolveShared<'a, T> {
    x: SharedValues<T>,
    t: SharedValues<T>,
    l: &'a [T],
}

/// Siblings (sorted by decreasing subtree flops) split into two groups of about equal
/// `weight` (of `total`): the shortest prefix with half of it, and the rest (never empty).
fn halves(roots: &[usize], weight: impl Fn(usize) -> f64, total: f64) -> (&[usize], &[usize]) {
    let mut prefix = 0.0;
    let mut k = 1;
    for (i, &r) in roots.iter().enumerate() {
        prefix += weight(r);
        k = i + 1;
        if prefix >= 0.5 * total {
            break;
        }
    }
    roots.split_at(k.min(roots.len() - 1))
}

/// `y += a x`.
fn axpy<T: TreeScalar>(y: &mut [T], a: &[T], x: T) {
    if x == T::ZERO {
        return;
    }
    for (y, &a) in y.iter_mut().zip(a) {
        *y += a * x;
    }
}

/// `Σ a_i b_i` in eight interleaved partial sums added in a fixed order (the compiler can
/// vectorise it; the result does not depend on the schedule).
fn dot<T: TreeScalar>(a: &[T], b: &[T]) -> T {
    let mut acc = [T::ZERO; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut sum = T::ZERO;
    for (&x, &y) in ra.iter().zip(rb) {
        sum += x * y;
    }
    for v in acc {
        sum += v;
    }
    sum
}

/// The structure, computed once per pattern.
pub(crate) struct TreeCholesky {
    n: usize,
    /// Lower triangle of the permuted matrix by column: row and position in the caller's
    /// value array.
    a_ptr: Vec<usize>,
    a_row: Vec<usize>,
    a_src: Vec<usize>,
    begin: Vec<usize>,
    end: Vec<usize>,
    pat_ptr: Vec<usize>,
    pat: Vec<usize>,
    val_ptr: Vec<usize>,
    /// Updates into supernode s: `(d, i0, i1)`, rows `i0..i1` of d's pattern are columns
    /// of s (and rows `i0..` are the rows the update reaches).
    upd_ptr: Vec<usize>,
    upd: Vec<(usize, usize, usize)>,
    /// Children of each supernode and the roots, by decreasing subtree flops.
    children: Vec<Vec<usize>>,
    roots: Vec<usize>,
    parent: Vec<Option<usize>>,
    /// A postorder of the supernodes; the subtree of s is `post[first[s]..=position[s]]`.
    post: Vec<usize>,
    first: Vec<usize>,
    position: Vec<usize>,
    own_flops: Vec<f64>,
    subtree_flops: Vec<f64>,
    /// Entries of L in each supernode's subtree (what a solve of it reads).
    subtree_entries: Vec<usize>,
    /// Flops of the updates each supernode receives (`2 · rows · columns · width`).
    update_flops: Vec<f64>,
    /// Largest update product (rows × columns) and largest supernode width.
    max_product: usize,
    /// Largest `columns × width` of an update's rows scaled by its source's block diagonal
    /// (the pivoted factorisation's `L_d D_d`).
    max_scaled: usize,
    max_width: usize,
    /// Longest supernode pattern (rows below the diagonal block).
    max_pattern: usize,
}

/// One task's scratch: the row map, the updates' scratch and the dense kernels' stack.
pub(crate) struct Workspace<T> {
    map: Vec<usize>,
    scratch: UpdateScratch<T>,
    mem: MemBuffer,
    /// The pivoted factorisation's dense kernels' stack (made at its first use: the
    /// Cholesky never needs it).
    pivot_mem: Option<MemBuffer>,
}

/// Scratch of one task's updates: the product buffer, and where each row of the update
/// lands in the target block.
struct UpdateScratch<T> {
    product: Vec<T>,
    local: Vec<usize>,
    /// `L_d D_d` of an update's columns (pivoted factorisation only; sized at first use).
    scaled: Vec<T>,
}

/// Workspaces kept between factorisations (one per concurrent task).
pub(crate) struct WorkspacePool<T> {
    free: Mutex<Vec<Workspace<T>>>,
}

impl<T> Default for WorkspacePool<T> {
    fn default() -> Self {
        WorkspacePool {
            free: Mutex::new(Vec::new()),
        }
    }
}

/// The factor's values, shared by the tasks: each supernode writes only its own block, and
/// reads only the blocks of its descendants, which are complete before it starts.
struct SharedValues<T> {
    ptr: *mut T,
    len: usize,
}

// SAFETY: the blocks written concurrently are disjoint (one per supernode, each written by
// the one task that factorises it), and a block is read only by its ancestors, which run
// after the task that wrote it has joined.
unsafe impl<T: Send> Sync for SharedValues<T> {}

impl<T> SharedValues<T> {
    /// SAFETY: `range` must be the block of a supernode whose task is the caller.
    // A mutable block from a shared handle is the point: the tasks share the factor, and
    // the schedule, not the borrow checker, keeps their blocks apart.
    #[allow(clippy::mut_from_ref)]
    unsafe fn block_mut(&self, range: std::ops::Range<usize>) -> &mut [T] {
        debug_assert!(range.end <= self.len);
        // SAFETY: in bounds, and no other task touches this block now (caller's contract).
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(range.start), range.len()) }
    }

    /// SAFETY: `i` must be outside every block written now (a finished supernode's).
    unsafe fn get(&self, i: usize) -> T
    where
        T: Copy,
    {
        debug_assert!(i < self.len);
        // SAFETY: in bounds, and its writer has finished (caller's contract).
        unsafe { *self.ptr.add(i) }
    }

    /// SAFETY: `range` must be the block of a finished descendant of the caller's supernode.
    unsafe fn block(&self, range: std::ops::Range<usize>) -> &[T] {
        debug_assert!(range.end <= self.len);
        // SAFETY: in bounds, and its writer has finished (caller's contract).
        unsafe { std::slice::from_raw_parts(self.ptr.add(range.start), range.len()) }
    }
}

/// What every task of one factorisation shares.
struct Context<'a, T> {
    shared: SharedValues<T>,
    values: &'a [T],
    pool: &'a WorkspacePool<T>,
    /// Whether tasks may run concurrently (more than one thread).
    forking: bool,
    /// The dense kernels' parallelism for the large supernodes of the top chain.
    dense: Par,
    /// Where the pivoted factorisation writes its pivots (`None`: Cholesky).
    pivots: Option<Pivots<T>>,
}

/// The outputs of the pivoted factorisation besides L, in faer's intranode LBLᵀ layout:
/// the sub-diagonal of B's 2x2 blocks, and the permutation inside each supernode (global
/// indices). Each supernode's task writes its own columns' range.
struct Pivots<T> {
    subdiag: SharedValues<T>,
    forward: SharedValues<usize>,
    inverse: SharedValues<usize>,
}

impl<T: Send> Context<'_, T> {
    /// `a` and `b`, concurrently when forking (the same arithmetic either way).
    fn join<A: Send, B: Send>(
        &self,
        a: impl FnOnce() -> A + Send,
        b: impl FnOnce() -> B + Send,
    ) -> (A, B) {
        if self.forking {
            rayon::join(a, b)
        } else {
            (a(), b())
        }
    }
}

fn column_flops(width: usize, below: usize) -> f64 {
    (0..width)
        .map(|k| ((width - k + below) as f64).powi(2))
        .sum()
}

impl TreeCholesky {
    /// The structure for `pattern` (lower CSC, original order) whose supernodal symbolic
    /// factor faer computed as `sym` with the permutation `perm` (`perm[new] = old`).
    pub(crate) fn new(
        pattern: &SparsityPattern,
        perm: &[usize],
        sym: &SymbolicSupernodalCholesky<usize>,
    ) -> Result<Self, String> {
        let n = pattern.n;
        let mut inv = vec![0usize; n];
        for (new, &old) in perm.iter().enumerate() {
            inv[old] = new;
        }
        let mut entries: Vec<(usize, usize, usize)> = Vec::with_capacity(pattern.nnz());
        for c in 0..n {
            for k in pattern.col_ptr[c]..pattern.col_ptr[c + 1] {
                let (p, q) = (inv[pattern.row_idx[k]], inv[c]);
                entries.push((p.min(q), p.max(q), k));
            }
        }
        entries.sort_unstable();
        let mut a_ptr = vec![0usize; n + 1];
        for &(j, _, _) in &entries {
            a_ptr[j + 1] += 1;
        }
        for j in 0..n {
            a_ptr[j + 1] += a_ptr[j];
        }
        let a_row = entries.iter().map(|e| e.1).collect();
        let a_src = entries.iter().map(|e| e.2).collect();
        let ns = sym.n_supernodes();
        let begin = sym.supernode_begin().to_vec();
        let end = sym.supernode_end().to_vec();
        let mut pat = Vec::new();
        let mut pat_ptr = Vec::with_capacity(ns + 1);
        for s in 0..ns {
            pat_ptr.push(pat.len());
            pat.extend_from_slice(sym.supernode(s).pattern());
        }
        pat_ptr.push(pat.len());
        let val_ptr = sym.col_ptr_for_val().to_vec();
        let mut col_to_sn = vec![0usize; n];
        for s in 0..ns {
            col_to_sn[begin[s]..end[s]].fill(s);
        }
        // Updates: each run of a pattern's rows inside one ancestor's columns.
        let mut lists: Vec<Vec<(usize, usize, usize)>> = vec![Vec::new(); ns];
        let mut parent = vec![None; ns];
        let (mut max_product, mut max_width, mut max_scaled) = (0usize, 0usize, 0usize);
        for d in 0..ns {
            let p = &pat[pat_ptr[d]..pat_ptr[d + 1]];
            let mut i0 = 0;
            while i0 < p.len() {
                let s = col_to_sn[p[i0]];
                if s <= d {
                    return Err(format!(
                        "supernode {d} updates supernode {s}: not a postorder"
                    ));
                }
                let mut i1 = i0;
                while i1 < p.len() && p[i1] < end[s] {
                    i1 += 1;
                }
                if parent[d].is_none() {
                    parent[d] = Some(s);
                }
                lists[s].push((d, i0, i1));
                max_product = max_product.max((p.len() - i0).min(ROW_BLOCK) * (i1 - i0));
                max_scaled = max_scaled.max((i1 - i0) * (end[d] - begin[d]));
                i0 = i1;
            }
            max_width = max_width.max(end[d] - begin[d]);
        }
        let mut update_flops = vec![0.0; ns];
        for (s, list) in lists.iter().enumerate() {
            for &(d, i0, i1) in list {
                let rows = pat_ptr[d + 1] - pat_ptr[d] - i0;
                update_flops[s] += 2.0 * (rows * (i1 - i0) * (end[d] - begin[d])) as f64;
            }
        }
        let mut upd_ptr = vec![0usize; ns + 1];
        let mut upd = Vec::new();
        for (s, list) in lists.into_iter().enumerate() {
            upd.extend(list);
            upd_ptr[s + 1] = upd.len();
        }
        let mut children = vec![Vec::new(); ns];
        let mut roots = Vec::new();
        let own_flops: Vec<f64> = (0..ns)
            .map(|s| column_flops(end[s] - begin[s], pat_ptr[s + 1] - pat_ptr[s]))
            .collect();
        let mut subtree_flops = own_flops.clone();
        let mut subtree_entries: Vec<usize> =
            (0..ns).map(|s| val_ptr[s + 1] - val_ptr[s]).collect();
        for s in 0..ns {
            match parent[s] {
                Some(p) => {
                    children[p].push(s);
                    subtree_flops[p] += subtree_flops[s];
                    subtree_entries[p] += subtree_entries[s];
                }
                None => roots.push(s),
            }
        }
        // A postorder of the supernodal tree (faer's numbering need not be one), so that
        // every subtree is a contiguous range of it.
        let mut post = Vec::with_capacity(ns);
        let mut position = vec![0usize; ns];
        let mut first = vec![0usize; ns];
        let mut stack: Vec<(usize, usize)> = roots.iter().rev().map(|&r| (r, 0)).collect();
        while let Some((s, next)) = stack.pop() {
            if next == 0 {
                first[s] = post.len();
            }
            if let Some(&c) = children[s].get(next) {
                stack.push((s, next + 1));
                stack.push((c, 0));
            } else {
                position[s] = post.len();
                post.push(s);
            }
        }
        let by_flops = |list: &mut Vec<usize>| {
            list.sort_by(|a, b| {
                subtree_flops[*b]
                    .total_cmp(&subtree_flops[*a])
                    .then(a.cmp(b))
            });
        };
        children.iter_mut().for_each(by_flops);
        by_flops(&mut roots);
        // Every update must come from inside the supernode's subtree (the tasks' contract).
        for s in 0..ns {
            for &(d, _, _) in &upd[upd_ptr[s]..upd_ptr[s + 1]] {
                if position[d] < first[s] || position[d] >= position[s] {
                    return Err(format!(
                        "supernode {d} updates {s} from outside its subtree"
                    ));
                }
            }
        }
        let max_pattern = (0..ns)
            .map(|s| pat_ptr[s + 1] - pat_ptr[s])
            .max()
            .unwrap_or(0);
        Ok(TreeCholesky {
            n,
            a_ptr,
            a_row,
            a_src,
            begin,
            end,
            pat_ptr,
            pat,
            val_ptr,
            upd_ptr,
            upd,
            children,
            roots,
            parent,
            post,
            first,
            position,
            own_flops,
            subtree_flops,
            subtree_entries,
            update_flops,
            max_product,
            max_scaled,
            max_width,
            max_pattern,
        })
    }

    fn workspace<T: TreeScalar>(&self, pool: &WorkspacePool<T>) -> Result<Workspace<T>, String> {
        if let Some(ws) = pool
            .free
            .lock()
            .map_err(|_| "workspace pool poisoned")?
            .pop()
        {
            return Ok(ws);
        }
        let req = StackReq::any_of(&[
            cholesky_in_place_scratch::<T>(self.max_width, Par::Seq, Spec::default()),
            cholesky_in_place_scratch::<T>(self.max_width, Par::rayon(0), Spec::default()),
        ]);
        Ok(Workspace {
            map: vec![usize::MAX; self.n],
            scratch: UpdateScratch {
                product: vec![T::ZERO; self.max_product],
                local: vec![0; self.max_pattern],
                scaled: Vec::new(),
            },
            mem: MemBuffer::try_new(req).map_err(|_| "out of memory for the factorisation")?,
            pivot_mem: None,
        })
    }

    fn give_back<T>(pool: &WorkspacePool<T>, ws: Workspace<T>) {
        if let Ok(mut free) = pool.free.lock() {
            free.push(ws);
        }
    }

    /// Factorises the matrix with lower-triangle `values` (the pattern's order) into `l`
    /// (faer's supernodal layout of the symbolic factor this was built from). `threads`:
    /// most tasks at once (1: in order on the calling thread). Fails on a pivot that is
    /// not positive (the matrix is not positive definite).
    pub(crate) fn factorize<T: TreeScalar>(
        &self,
        l: &mut [T],
        values: &[T],
        threads: usize,
        pool: &WorkspacePool<T>,
    ) -> Result<(), FactorFailure> {
        self.run(l, values, threads, pool, None)
    }

    /// The pivoted factorisation `P A Pᵀ = L B Lᵀ` of the (symmetric, possibly indefinite)
    /// matrix with lower-triangle `values`, into faer's intranode Bunch–Kaufman layout, so
    /// that faer's `SupernodalIntranodeLbltRef` solves with it: `l` (unit lower triangular
    /// blocks, B's diagonal on their diagonal), `subdiag` (B's 2x2 blocks' sub-diagonal,
    /// zero for 1x1 pivots) and the permutation `forward`/`inverse` (pivoting inside each
    /// supernode only). The same left-looking algorithm as faer's sequential
    /// `factorize_supernodal_numeric_intranode_lblt` (each descendant's update is
    /// `L_d[rows] (L_d[columns] B_d)ᵀ`, and the rows of a descendant stay in the unpivoted
    /// order, which faer's solve maps through `inverse`), scheduled on the tree like the
    /// Cholesky. Pivot sizes are the caller's to check (`l`'s diagonal and `subdiag`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn factorize_pivoted<T: TreeScalar>(
        &self,
        l: &mut [T],
        subdiag: &mut [T],
        forward: &mut [usize],
        inverse: &mut [usize],
        values: &[T],
        threads: usize,
        pool: &WorkspacePool<T>,
    ) -> Result<(), FactorFailure> {
        if subdiag.len() != self.n || forward.len() != self.n || inverse.len() != self.n {
            return Err("pivot storage of the wrong size".into());
        }
        let pivots = Pivots {
            subdiag: SharedValues {
                ptr: subdiag.as_mut_ptr(),
                len: subdiag.len(),
            },
            forward: SharedValues {
                ptr: forward.as_mut_ptr(),
                len: forward.len(),
            },
            inverse: SharedValues {
                ptr: inverse.as_mut_ptr(),
                len: inverse.len(),
            },
        };
        self.run(l, values, threads, pool, Some(pivots))
    }

    fn run<T: TreeScalar>(
        &self,
        l: &mut [T],
        values: &[T],
        threads: usize,
        pool: &WorkspacePool<T>,
        pivots: Option<Pivots<T>>,
    ) -> Result<(), FactorFailure> {
        if l.len() != self.val_ptr[self.val_ptr.len() - 1] {
            return Err("factor storage of the wrong size".into());
        }
        let shared = SharedValues {
            ptr: l.as_mut_ptr(),
            len: l.len(),
        };
        let mut ws = self.workspace(pool)?;
        let forking = threads > 1;
        let cx = Context {
            shared,
            values,
            pool,
            forking,
            dense: if forking {
                Par::rayon(threads)
            } else {
                Par::Seq
            },
            pivots,
        };
        let result = self.group(&self.roots, &cx, &mut ws);
        Self::give_back(pool, ws);
        result
    }

    /// Factorises the subtrees rooted at `roots` (none an ancestor of another).
    fn group<T: TreeScalar>(
        &self,
        roots: &[usize],
        cx: &Context<'_, T>,
        ws: &mut Workspace<T>,
    ) -> Result<(), FactorFailure> {
        let flops: f64 = roots.iter().map(|&r| self.subtree_flops[r]).sum();
        if !cx.forking || flops < MIN_FORK_FLOPS {
            for &r in roots {
                for &s in &self.post[self.first[r]..=self.position[r]] {
                    self.supernode(s, cx, ws, Par::Seq)?;
                }
            }
            return Ok(());
        }
        if roots.len() == 1 {
            let r = roots[0];
            // Down the chain of single children, fork below it, then back up the chain.
            let mut top = r;
            while self.children[top].len() == 1 {
                top = self.children[top][0];
            }
            self.group(&self.children[top], cx, ws)?;
            let mut s = top;
            loop {
                let par = if self.own_flops[s] >= MIN_DENSE_PARALLEL_FLOPS {
                    cx.dense
                } else {
                    Par::Seq
                };
                self.supernode(s, cx, ws, par)?;
                match self.parent[s] {
                    Some(p) if s != r => s = p,
                    _ => break,
                }
            }
            return Ok(());
        }
        // Two groups of about equal flops.
        let (left, right) = halves(roots, |r| self.subtree_flops[r], flops);
        let (a, b) = rayon::join(
            || self.group(left, cx, ws),
            || {
                let mut own = self.workspace(cx.pool)?;
                let r = self.group(right, cx, &mut own);
                Self::give_back(cx.pool, own);
                r
            },
        );
        a.and(b)
    }

    /// Supernode `s`, left-looking (module notes).
    fn supernode<T: TreeScalar>(
        &self,
        s: usize,
        cx: &Context<'_, T>,
        ws: &mut Workspace<T>,
        par: Par,
    ) -> Result<(), FactorFailure> {
        let values = cx.values;
        let (b, e) = (self.begin[s], self.end[s]);
        let w = e - b;
        let pattern = &self.pat[self.pat_ptr[s]..self.pat_ptr[s + 1]];
        let m = w + pattern.len();
        // SAFETY: this task factorises s; nobody else touches its block now.
        let block = unsafe { cx.shared.block_mut(self.val_ptr[s]..self.val_ptr[s + 1]) };
        block.fill(T::ZERO);
        for (t, &r) in pattern.iter().enumerate() {
            ws.map[r] = w + t;
        }
        for j in b..e {
            let column = &mut block[(j - b) * m..(j - b + 1) * m];
            for idx in self.a_ptr[j]..self.a_ptr[j + 1] {
                let i = self.a_row[idx];
                let local = if i < e { i - b } else { ws.map[i] };
                column[local] += values[self.a_src[idx]];
            }
        }
        let Workspace {
            map,
            scratch,
            mem,
            pivot_mem,
        } = ws;
        self.updates(s, 0, w, MAX_UPDATE_SPLITS, block, map, scratch, cx)?;
        for &r in pattern {
            map[r] = usize::MAX;
        }
        let mat = MatMut::from_column_major_slice_mut(block, m, w);
        if let Some(pivots) = &cx.pivots {
            Self::pivoted_block(b, e, mat, pivots, self.pivot_stack::<T>(pivot_mem)?, par);
            return Ok(());
        }
        let (mut top, bottom) = mat.split_at_row_mut(w);
        if let Err(err) = cholesky_in_place(
            top.as_mut(),
            Default::default(),
            par,
            MemStack::new(mem),
            Spec::default(),
        ) {
            // faer leaves the pivot that was not positive on the diagonal.
            let faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } = err;
            return Err(FactorFailure {
                message: format!("Cholesky: supernode {s}: {err:?}"),
                pivot: Some(top[(index, index)].to_f64()),
            });
        }
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
            top.as_ref(),
            bottom.transpose_mut(),
            par,
        );
        Ok(())
    }

    /// The pivoted factorisation's dense stack in `slot`, made at its first use.
    fn pivot_stack<'m, T: TreeScalar>(
        &self,
        slot: &'m mut Option<MemBuffer>,
    ) -> Result<&'m mut MemBuffer, FactorFailure> {
        if slot.is_none() {
            let req = StackReq::any_of(&[
                lblt::cholesky_in_place_scratch::<usize, T>(
                    self.max_width,
                    Par::Seq,
                    Spec::default(),
                ),
                lblt::cholesky_in_place_scratch::<usize, T>(
                    self.max_width,
                    Par::rayon(0),
                    Spec::default(),
                ),
            ])
            .and(faer::perm::permute_cols_in_place_scratch::<usize, T>(
                self.max_pattern,
                self.max_width,
            ));
            *slot =
                Some(MemBuffer::try_new(req).map_err(|_| "out of memory for the factorisation")?);
        }
        slot.as_mut().ok_or_else(|| "no pivot workspace".into())
    }

    /// The pivoted supernode `b..e` whose block `mat` holds A's entries minus every
    /// descendant's update: Bunch–Kaufman on the diagonal block, the rows below permuted
    /// the same way and solved against `L` and then `B` (faer's intranode step).
    fn pivoted_block<T: TreeScalar>(
        b: usize,
        e: usize,
        mat: MatMut<'_, T>,
        pivots: &Pivots<T>,
        mem: &mut MemBuffer,
        par: Par,
    ) {
        let w = e - b;
        let (mut top, mut bottom) = mat.split_at_row_mut(w);
        // SAFETY: columns b..e are this task's supernode.
        let (subdiag, forward, inverse) = unsafe {
            (
                pivots.subdiag.block_mut(b..e),
                pivots.forward.block_mut(b..e),
                pivots.inverse.block_mut(b..e),
            )
        };
        let stack = MemStack::new(mem);
        {
            let (_, perm) = lblt::cholesky_in_place(
                top.rb_mut(),
                ColMut::from_slice_mut(subdiag).as_diagonal_mut(),
                forward,
                inverse,
                par,
                stack,
                Spec::default(),
            );
            faer::perm::permute_cols_in_place(bottom.rb_mut(), perm, stack);
        }
        for j in 0..w {
            for i in 0..j {
                top[(i, j)] = T::ZERO;
            }
        }
        for p in forward.iter_mut().chain(inverse.iter_mut()) {
            *p += b;
        }
        faer::linalg::triangular_solve::solve_unit_lower_triangular_in_place(
            top.rb(),
            bottom.rb_mut().transpose_mut(),
            par,
        );
        // The rows below times B⁻¹, block by block.
        let rows = bottom.nrows();
        let mut j = 0;
        while j < w {
            if subdiag[j] == T::ZERO {
                let d = T::ONE / top[(j, j)];
                for i in 0..rows {
                    bottom[(i, j)] *= d;
                }
                j += 1;
            } else {
                // [x_k x_k+1] [[a, c], [c, d]]⁻¹, scaled by 1/c as faer does.
                let c = T::ONE / subdiag[j];
                let a = c * top[(j, j)];
                let d = c * top[(j + 1, j + 1)];
                let denom = T::ONE / (a * d - T::ONE);
                for i in 0..rows {
                    let xk = bottom[(i, j)] * c;
                    let xk1 = bottom[(i, j + 1)] * c;
                    bottom[(i, j)] = (d * xk - xk1) * denom;
                    bottom[(i, j + 1)] = (a * xk1 - xk) * denom;
                }
                j += 2;
            }
        }
    }

    /// `out` (`nc × w_d`, column-major) = the rows `w_d + j0..` of descendant `d`'s finished
    /// block `ld` times its block diagonal B_d (1x1 pivots on `ld`'s diagonal, 2x2 blocks
    /// with their sub-diagonal in `pivots`).
    fn scale_by_block_diagonal<T: TreeScalar>(
        &self,
        d: usize,
        ld: MatRef<'_, T>,
        j0: usize,
        nc: usize,
        pivots: &Pivots<T>,
        out: &mut [T],
    ) {
        let b = self.begin[d];
        let wd = self.end[d] - b;
        let rows = ld.subrows(wd + j0, nc);
        let mut k = 0;
        while k < wd {
            // SAFETY: d is finished (a descendant of the supernode being updated).
            let sub = unsafe { pivots.subdiag.get(b + k) };
            if sub == T::ZERO {
                let a = ld[(k, k)];
                for (i, o) in out[k * nc..(k + 1) * nc].iter_mut().enumerate() {
                    *o = rows[(i, k)] * a;
                }
                k += 1;
            } else {
                let (a, c) = (ld[(k, k)], ld[(k + 1, k + 1)]);
                let (left, right) = out[k * nc..(k + 2) * nc].split_at_mut(nc);
                for i in 0..nc {
                    let (x, y) = (rows[(i, k)], rows[(i, k + 1)]);
                    left[i] = x * a + y * sub;
                    right[i] = y * c + x * sub;
                }
                k += 2;
            }
        }
    }

    /// Subtracts every descendant's update from the columns `lo..hi` of supernode `s`'s
    /// block (`part` holds those columns). A range with many update flops is halved and
    /// the halves run as two tasks (they write disjoint columns); the halving depends on
    /// the structure only, so the arithmetic is the same on any number of threads.
    #[allow(clippy::too_many_arguments)]
    fn updates<T: TreeScalar>(
        &self,
        s: usize,
        lo: usize,
        hi: usize,
        splits: usize,
        part: &mut [T],
        map: &[usize],
        scratch: &mut UpdateScratch<T>,
        cx: &Context<'_, T>,
    ) -> Result<(), FactorFailure> {
        let (b, e) = (self.begin[s], self.end[s]);
        let w = e - b;
        let m = w + self.pat_ptr[s + 1] - self.pat_ptr[s];
        let share = self.update_flops[s] * (hi - lo) as f64 / w as f64;
        if splits > 0 && share >= MIN_SPLIT_UPDATE_FLOPS && hi - lo >= 2 {
            // Halve the work, not the columns: column j receives rows from j down (m - j).
            let total: usize = (lo..hi).map(|j| m - j).sum();
            let (mut mid, mut done) = (lo, 0);
            while mid < hi - 1 && 2 * (done + m - mid) <= total {
                done += m - mid;
                mid += 1;
            }
            let mid = mid.max(lo + 1);
            let (left, right) = part.split_at_mut((mid - lo) * m);
            let mut other = self.workspace(cx.pool)?;
            let (a, c) = cx.join(
                || self.updates(s, lo, mid, splits - 1, left, map, scratch, cx),
                || {
                    let other = &mut other.scratch;
                    self.updates(s, mid, hi, splits - 1, right, map, other, cx)
                },
            );
            Self::give_back(cx.pool, other);
            return a.and(c);
        }
        for &(d, i0, i1) in &self.upd[self.upd_ptr[s]..self.upd_ptr[s + 1]] {
            let wd = self.end[d] - self.begin[d];
            let pd = &self.pat[self.pat_ptr[d]..self.pat_ptr[d + 1]];
            // The rows of d's pattern that are columns lo..hi of s.
            let j0 = i0 + pd[i0..i1].partition_point(|&r| r < b + lo);
            let j1 = i0 + pd[i0..i1].partition_point(|&r| r < b + hi);
            if j0 == j1 {
                continue;
            }
            let md = wd + pd.len();
            // SAFETY: d is a descendant of s (checked in `new`), finished before s started.
            let ld = unsafe { cx.shared.block(self.val_ptr[d]..self.val_ptr[d + 1]) };
            let ld = MatRef::from_column_major_slice(ld, md, wd);
            let (nr, nc) = (pd.len() - j0, j1 - j0);
            // Where each row lands in s's block, once per update (not once per column), and
            // whether they land on consecutive rows (then each column's subtraction is one
            // slice operation, which vectorises). Every entry still receives the same one
            // subtraction, so the factor is bitwise the same.
            let local = &mut scratch.local[..nr];
            for (l, &row) in local.iter_mut().zip(&pd[j0..]) {
                *l = if row < e { row - b } else { map[row] };
            }
            let consecutive = local[nr - 1] - local[0] == nr - 1;
            // The right factor: L_d's rows that are these columns, times B_d when pivoted.
            let columns = match &cx.pivots {
                None => ld.subrows(wd + j0, nc),
                Some(pivots) => {
                    if scratch.scaled.len() < self.max_scaled {
                        scratch.scaled.resize(self.max_scaled, T::ZERO);
                    }
                    let scaled = &mut scratch.scaled[..nc * wd];
                    self.scale_by_block_diagonal(d, ld, j0, nc, pivots, scaled);
                    MatRef::from_column_major_slice(&scratch.scaled[..nc * wd], nc, wd)
                }
            };
            // In blocks of rows (a bounded buffer); row r meets the columns c ≤ r.
            let mut r0 = 0;
            while r0 < nr {
                let rb = ROW_BLOCK.min(nr - r0);
                let ncb = nc.min(r0 + rb);
                let product = &mut scratch.product[..rb * ncb];
                faer::linalg::matmul::matmul(
                    MatMut::from_column_major_slice_mut(product, rb, ncb),
                    Accum::Replace,
                    ld.subrows(wd + j0 + r0, rb),
                    columns.subrows(0, ncb).transpose(),
                    T::ONE,
                    Par::Seq,
                );
                for c in 0..ncb {
                    let col = pd[j0 + c] - b - lo;
                    let column = &mut part[col * m..(col + 1) * m];
                    let first = c.max(r0);
                    let source = &product[c * rb + first - r0..(c + 1) * rb];
                    if consecutive {
                        let start = local[first];
                        for (t, &v) in column[start..start + source.len()].iter_mut().zip(source) {
                            *t -= v;
                        }
                    } else {
                        for (&l, &v) in local[first..r0 + rb].iter().zip(source) {
                            column[l] -= v;
                        }
                    }
                }
                r0 += rb;
            }
        }
        Ok(())
    }

    /// Solves `L Lᵀ y = c` in place (`y`: the right-hand side `c` in the factor's permuted
    /// order on entry, the solution on return) with the factor `l` this structure's
    /// `factorize` wrote; `products` is scratch of [`TreeCholesky::solve_scratch_len`]
    /// entries. Forward, each supernode subtracts from its rows the products
    /// `L_d[rows] x_d` its descendants left in `products` (in its update list's order),
    /// solves with its diagonal block and leaves its own product `L_s[below] x_s` for its
    /// ancestors; so independent subtrees run as concurrent tasks, as in the
    /// factorisation. Backward, each supernode gathers its ancestors' solution into its
    /// share of `products` and goes down the tree. Every supernode sums in the same order
    /// on any schedule, so the solution is bitwise the same on any number of `threads`
    /// (faer's parallel solves are not, which is why they are not used).
    pub(crate) fn solve_in_place<T: TreeScalar>(
        &self,
        l: &[T],
        y: &mut [T],
        products: &mut [T],
        threads: usize,
    ) {
        debug_assert_eq!(y.len(), self.n);
        debug_assert_eq!(l.len(), self.val_ptr[self.val_ptr.len() - 1]);
        debug_assert_eq!(products.len(), self.solve_scratch_len());
        let x = SharedValues {
            ptr: y.as_mut_ptr(),
            len: y.len(),
        };
        let t = SharedValues {
            ptr: products.as_mut_ptr(),
            len: products.len(),
        };
        let sx = SolveShared { x, t, l };
        let forking = threads > 1;
        self.solve_group(&self.roots, &sx, forking, true);
        self.solve_group(&self.roots, &sx, forking, false);
    }

    /// Entries of the scratch [`TreeCholesky::solve_in_place`] needs (one per row of every
    /// supernode's pattern).
    pub(crate) fn solve_scratch_len(&self) -> usize {
        self.pat.len()
    }

    /// The forward (`up`: children before parents) or backward (parents before children)
    /// solve of the subtrees rooted at `roots` (none an ancestor of another). Below
    /// [`MIN_FORK_SOLVE_ENTRIES`] one task walks them in (reverse) postorder; a single root
    /// walks its chain of single children around the subtrees below it; several roots
    /// split into two concurrent groups.
    fn solve_group<T: TreeScalar>(
        &self,
        roots: &[usize],
        sx: &SolveShared<'_, T>,
        forking: bool,
        up: bool,
    ) {
        let visit = |s: usize| {
            if up {
                self.forward_supernode(s, sx)
            } else {
                self.backward_supernode(s, sx)
            }
        };
        let work: usize = roots.iter().map(|&r| self.subtree_entries[r]).sum();
        if !forking || work < MIN_FORK_SOLVE_ENTRIES {
            for &r in roots {
                let subtree = &self.post[self.first[r]..=self.position[r]];
                if up {
                    subtree.iter().for_each(|&s| visit(s));
                } else {
                    subtree.iter().rev().for_each(|&s| visit(s));
                }
            }
            return;
        }
        if let [r] = *roots {
            // The chain of single children from r down to `top` (no allocation: down by
            // the children, up by the parents).
            let mut top = r;
            while let [child] = self.children[top][..] {
                top = child;
            }
            if up {
                self.solve_group(&self.children[top], sx, forking, up);
                let mut s = top;
                visit(s);
                while s != r {
                    s = self.parent[s].unwrap_or(r);
                    visit(s);
                }
            } else {
                let mut s = r;
                visit(s);
                while s != top {
                    s = self.children[s][0];
                    visit(s);
                }
                self.solve_group(&self.children[top], sx, forking, up);
            }
            return;
        }
        let (left, right) = halves(roots, |r| self.subtree_entries[r] as f64, work as f64);
        rayon::join(
            || self.solve_group(left, sx, forking, up),
            || self.solve_group(right, sx, forking, up),
        );
    }

    /// Forward solve of supernode `s`: `x_s -= L_d[rows in s] x_d` over its descendants
    /// (their products), `x_s = L_ss⁻¹ x_s`, then its own product `t_s = L_s[below] x_s`.
    fn forward_supernode<T: TreeScalar>(&self, s: usize, sx: &SolveShared<'_, T>) {
        let (b, e) = (self.begin[s], self.end[s]);
        let w = e - b;
        // SAFETY: this task solves s, whose rows and product nobody else writes; the
        // descendants' products it reads are finished (they come before s in every
        // schedule).
        let xs = unsafe { sx.x.block_mut(b..e) };
        for &(d, i0, i1) in &self.upd[self.upd_ptr[s]..self.upd_ptr[s + 1]] {
            let (p0, p1) = (self.pat_ptr[d] + i0, self.pat_ptr[d] + i1);
            let rows = &self.pat[p0..p1];
            // SAFETY: d is a finished descendant of s.
            let td = unsafe { sx.t.block(p0..p1) };
            for (&r, &v) in rows.iter().zip(td) {
                xs[r - b] -= v;
            }
        }
        let (p0, p1) = (self.pat_ptr[s], self.pat_ptr[s + 1]);
        let m = w + p1 - p0;
        let ls = &sx.l[self.val_ptr[s]..self.val_ptr[s + 1]];
        for j in 0..w {
            let column = &ls[j * m..j * m + w];
            let xj = xs[j] / column[j];
            xs[j] = xj;
            axpy(&mut xs[j + 1..], &column[j + 1..], -xj);
        }
        // SAFETY: s's own product, written by this task only.
        let ts = unsafe { sx.t.block_mut(p0..p1) };
        ts.fill(T::ZERO);
        for (j, &xj) in xs.iter().enumerate() {
            axpy(ts, &ls[j * m + w..(j + 1) * m], xj);
        }
    }

    /// Backward solve of supernode `s`: `x_s -= L_s[below]ᵀ x[pattern]` (its ancestors'
    /// solution, gathered into its share of the products), then `x_s = L_ssᵀ⁻¹ x_s`.
    fn backward_supernode<T: TreeScalar>(&self, s: usize, sx: &SolveShared<'_, T>) {
        let (b, e) = (self.begin[s], self.end[s]);
        let w = e - b;
        let (p0, p1) = (self.pat_ptr[s], self.pat_ptr[s + 1]);
        let pattern = &self.pat[p0..p1];
        let m = w + pattern.len();
        let ls = &sx.l[self.val_ptr[s]..self.val_ptr[s + 1]];
        // SAFETY: s's share of the products is written by this task only; the pattern's
        // rows belong to ancestors of s, finished before s in every schedule, and lie
        // outside s's rows, which this task alone writes.
        let g = unsafe { sx.t.block_mut(p0..p1) };
        for (g, &r) in g.iter_mut().zip(pattern) {
            *g = unsafe { sx.x.get(r) };
        }
        let xs = unsafe { sx.x.block_mut(b..e) };
        for (j, xj) in xs.iter_mut().enumerate() {
            *xj -= dot(&ls[j * m + w..(j + 1) * m], g);
        }
        for j in (0..w).rev() {
            let column = &ls[j * m..j * m + w];
            let sum = dot(&column[j + 1..], &xs[j + 1..]);
            xs[j] = (xs[j] - sum) / column[j];
        }
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::linsolve::ordering::{inverse_permutation, nested_dissection};
    use crate::linsolve::test_matrices::{hex_elasticity, relative_residual};
    use faer::sparse::linalg::cholesky::{
        factorize_symbolic_cholesky, supernodal::SupernodalLltRef, CholeskySymbolicParams,
        IntranodeLbltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    };
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
    use faer::Side;

    fn symbolic(pattern: &SparsityPattern) -> (SymbolicCholesky<usize>, Vec<usize>) {
        let perm = nested_dissection(pattern).unwrap();
        let inv = inverse_permutation(&perm);
        let n = pattern.n;
        let structure =
            SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let ord = SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(&perm, &inv, n));
        let sym = factorize_symbolic_cholesky(structure, Side::Lower, ord, params).unwrap();
        let perm = sym.perm().unwrap().arrays().0.to_vec();
        (sym, perm)
    }

    fn supernodal(sym: &SymbolicCholesky<usize>) -> &SymbolicSupernodalCholesky<usize> {
        match sym.raw() {
            SymbolicCholeskyRaw::Supernodal(s) => s,
            SymbolicCholeskyRaw::Simplicial(_) => panic!("supernodal expected"),
        }
    }

    /// Scratch for [`faer_factor_into`].
    fn faer_scratch<T: TreeScalar>(sym: &SymbolicCholesky<usize>) -> MemBuffer {
        MemBuffer::new(sym.factorize_numeric_llt_scratch::<T>(Par::Seq, Spec::default()))
    }

    /// faer's sequential numeric Cholesky of `values` into `l` (the reference).
    fn faer_factor_into<T: TreeScalar>(
        sym: &SymbolicCholesky<usize>,
        pattern: &SparsityPattern,
        values: &[T],
        l: &mut [T],
        mem: &mut MemBuffer,
    ) {
        let structure = SymbolicSparseColMatRef::new_checked(
            pattern.n,
            pattern.n,
            &pattern.col_ptr,
            None,
            &pattern.row_idx,
        );
        sym.factorize_numeric_llt(
            l,
            SparseColMatRef::new(structure, values),
            Side::Lower,
            Default::default(),
            Par::Seq,
            &mut MemStack::new(mem),
            Spec::default(),
        )
        .unwrap();
    }

    fn faer_factor(
        sym: &SymbolicCholesky<usize>,
        pattern: &SparsityPattern,
        values: &[f64],
    ) -> Vec<f64> {
        let mut l = vec![0.0; sym.len_val()];
        faer_factor_into(sym, pattern, values, &mut l, &mut faer_scratch::<f64>(sym));
        l
    }

    /// A hex-elasticity grid, faer's symbolic factor of it and the tree on that factor.
    fn grid(
        nx: usize,
        ny: usize,
        nz: usize,
    ) -> (
        crate::linsolve::test_matrices::TestMatrix,
        SymbolicCholesky<usize>,
        TreeCholesky,
    ) {
        let m = hex_elasticity(nx, ny, nz, 1.0, 0.3);
        let (sym, perm) = symbolic(&m.pattern);
        let tree = TreeCholesky::new(&m.pattern, &perm, supernodal(&sym)).unwrap();
        (m, sym, tree)
    }

    /// The grid's values with `fraction` of the mean diagonal taken off the diagonal
    /// (indefinite for the fractions used here).
    fn shifted(m: &crate::linsolve::test_matrices::TestMatrix, fraction: f64) -> Vec<f64> {
        let mut values = m.values.clone();
        let mean = (0..m.pattern.n)
            .map(|c| values[m.pattern.col_ptr[c]])
            .sum::<f64>()
            / m.pattern.n as f64;
        for c in 0..m.pattern.n {
            values[m.pattern.col_ptr[c]] -= fraction * mean;
        }
        values
    }

    /// `f` run inside a fresh pool of `threads` threads.
    fn in_pool<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(f)
    }

    fn bitwise_equal(a: &[f64], b: &[f64]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
    }

    fn max_relative_difference(a: &[f64], b: &[f64]) -> f64 {
        let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
            / scale
    }

    #[test]
    fn the_tree_factor_equals_faers_and_is_the_same_on_one_and_two_threads() {
        let (m, sym, tree) = grid(11, 10, 9);
        let reference = faer_factor(&sym, &m.pattern, &m.values);
        let pool = WorkspacePool::default();
        let run = |threads: usize| {
            in_pool(threads, || {
                let mut l = vec![0.0; sym.len_val()];
                tree.factorize(&mut l, &m.values, threads, &pool).unwrap();
                l
            })
        };
        let one = run(1);
        let d1 = max_relative_difference(&one, &reference);
        assert!(d1 < 1e-12, "1 thread against faer: {d1:e}");
        let two = run(2);
        let d = max_relative_difference(&two, &reference);
        assert!(d < 1e-12, "against faer: {d:e}");
        assert!(bitwise_equal(&one, &two));
    }

    #[test]
    fn the_tree_factor_works_in_single_precision() {
        let (m, sym, tree) = grid(8, 9, 10);
        let values32: Vec<f32> = m.values.iter().map(|&v| v as f32).collect();
        let mut reference = vec![0.0f32; sym.len_val()];
        let mut mem = faer_scratch::<f32>(&sym);
        faer_factor_into(&sym, &m.pattern, &values32, &mut reference, &mut mem);
        let reference: Vec<f64> = reference.iter().map(|&v| f64::from(v)).collect();
        let mut l = vec![0.0f32; sym.len_val()];
        tree.factorize(&mut l, &values32, 2, &WorkspacePool::default())
            .unwrap();
        let l: Vec<f64> = l.iter().map(|&v| f64::from(v)).collect();
        let d = max_relative_difference(&l, &reference);
        assert!(d < 1e-5, "against faer's single-precision factor: {d:e}");
    }

    #[test]
    fn the_solver_uses_the_tree_and_solves_the_same_bits_on_one_and_two_threads() {
        use crate::linsolve::{FaerSparseSolver, LinearSolver};
        let m = hex_elasticity(10, 9, 9, 1.0, 0.3);
        let b: Vec<f64> = (0..m.pattern.n)
            .map(|i| ((i * 7919) % 13) as f64 - 6.0)
            .collect();
        let solve = |threads: usize| {
            in_pool(threads, || {
                let mut solver = FaerSparseSolver::new(0);
                solver.analyze(&m.pattern).unwrap();
                assert!(solver.analysis_info().unwrap().tree_factorisation);
                solver.factorize(&m.values).unwrap();
                let mut x = b.clone();
                solver.solve_in_place(&mut x).unwrap();
                x
            })
        };
        let (one, two) = (solve(1), solve(2));
        let residual = relative_residual(&m.pattern, &m.values, &two, &b);
        assert!(residual < 1e-10, "relative residual {residual:e}");
        assert!(bitwise_equal(&one, &two));
    }

    /// faer's single-precision factor of the test matrix `m`.
    fn faer_factor32(
        sym: &SymbolicCholesky<usize>,
        m: &crate::linsolve::test_matrices::TestMatrix,
    ) -> Vec<f32> {
        let values32: Vec<f32> = m.values.iter().map(|&v| v as f32).collect();
        let mut l = vec![0.0f32; sym.len_val()];
        let mut mem = faer_scratch::<f32>(sym);
        faer_factor_into(sym, &m.pattern, &values32, &mut l, &mut mem);
        l
    }

    /// faer's solve of `L Lᵀ x = b` (original order) with the factor `l`.
    fn faer_solve<T: TreeScalar>(sym: &SymbolicCholesky<usize>, l: &[T], b: &[T]) -> Vec<T> {
        use faer::sparse::linalg::cholesky::LltRef;
        let n = b.len();
        let mut x = b.to_vec();
        let mut mem = MemBuffer::new(sym.solve_in_place_scratch::<T>(1, Par::Seq));
        LltRef::new(sym, l).solve_in_place_with_conj(
            faer::Conj::No,
            MatMut::from_column_major_slice_mut(&mut x, n, 1),
            Par::Seq,
            &mut MemStack::new(&mut mem),
        );
        x
    }

    /// The tree's solve of `L Lᵀ x = b` (original order): permuted in, solved, permuted out.
    fn tree_solve<T: TreeScalar>(
        tree: &TreeCholesky,
        perm: &[usize],
        l: &[T],
        b: &[T],
        threads: usize,
    ) -> Vec<T> {
        let mut y: Vec<T> = perm.iter().map(|&old| b[old]).collect();
        let mut products = vec![T::ZERO; tree.solve_scratch_len()];
        tree.solve_in_place(l, &mut y, &mut products, threads);
        let mut x = vec![T::ZERO; b.len()];
        for (new, &old) in perm.iter().enumerate() {
            x[old] = y[new];
        }
        x
    }

    #[test]
    fn the_tree_solve_equals_faers_and_is_the_same_bits_on_one_two_and_four_threads() {
        let m = hex_elasticity(12, 11, 10, 1.0, 0.3);
        let (sym, perm) = symbolic(&m.pattern);
        let tree = TreeCholesky::new(&m.pattern, &perm, supernodal(&sym)).unwrap();
        let l = faer_factor(&sym, &m.pattern, &m.values);
        let b: Vec<f64> = (0..m.pattern.n)
            .map(|i| ((i * 7919) % 13) as f64 - 6.0)
            .collect();
        let reference = faer_solve(&sym, &l, &b);
        let solves: Vec<Vec<f64>> = [1, 2, 4]
            .into_iter()
            .map(|t| in_pool(t, || tree_solve(&tree, &perm, &l, &b, t)))
            .collect();
        let d = max_relative_difference(&solves[0], &reference);
        assert!(d < 1e-12, "against faer's solve: {d:e}");
        assert!(bitwise_equal(&solves[0], &solves[1]) && bitwise_equal(&solves[0], &solves[2]));
        // The subtrees were solved as concurrent tasks: the tree is large enough to fork.
        assert!(tree.subtree_entries[tree.roots[0]] > 4 * MIN_FORK_SOLVE_ENTRIES);
        // Single precision, against faer's single-precision solve of the same factor.
        let l32 = faer_factor32(&sym, &m);
        let b32: Vec<f32> = b.iter().map(|&v| v as f32).collect();
        let widen = |v: Vec<f32>| v.into_iter().map(f64::from).collect::<Vec<_>>();
        let reference32 = widen(faer_solve(&sym, &l32, &b32));
        let one = widen(in_pool(1, || tree_solve(&tree, &perm, &l32, &b32, 1)));
        let two = widen(in_pool(2, || tree_solve(&tree, &perm, &l32, &b32, 2)));
        let d = max_relative_difference(&one, &reference32);
        assert!(d < 1e-4, "single precision against faer's: {d:e}");
        assert!(bitwise_equal(&one, &two));
    }

    #[test]
    #[ignore = "times the tree's single-precision solve against faer's sequential one"]
    fn time_tree_solve_against_faer() {
        use std::time::Instant;
        for k in [14, 20] {
            let m = hex_elasticity(k, k, k, 1.0, 0.3);
            let (sym, perm) = symbolic(&m.pattern);
            let tree = TreeCholesky::new(&m.pattern, &perm, supernodal(&sym)).unwrap();
            let l = faer_factor32(&sym, &m);
            let b: Vec<f32> = (0..m.pattern.n)
                .map(|i| ((i * 7919) % 13) as f32 - 6.0)
                .collect();
            let mut best = [f64::INFINITY; 3];
            for _ in 0..10 {
                for (slot, threads) in [(0, 1), (1, 2)] {
                    let t = Instant::now();
                    in_pool(threads, || tree_solve(&tree, &perm, &l, &b, threads));
                    best[slot] = best[slot].min(t.elapsed().as_secs_f64());
                }
                let t = Instant::now();
                faer_solve(&sym, &l, &b);
                best[2] = best[2].min(t.elapsed().as_secs_f64());
            }
            eprintln!(
                "n {} L {}: tree 1 thread {:.2} ms, 2 threads {:.2} ms, faer {:.2} ms",
                m.pattern.n,
                sym.len_val(),
                best[0] * 1e3,
                best[1] * 1e3,
                best[2] * 1e3
            );
        }
    }

    /// The pivoted factor of `values` by faer's sequential supernodal Bunch–Kaufman:
    /// (L, sub-diagonal, forward and inverse permutation).
    fn faer_pivoted(
        sym: &SymbolicCholesky<usize>,
        pattern: &SparsityPattern,
        values: &[f64],
    ) -> (Vec<f64>, Vec<f64>, Vec<usize>, Vec<usize>) {
        let n = pattern.n;
        let (mut l, mut sub, mut fwd, mut inv) = (
            vec![0.0; sym.len_val()],
            vec![0.0; n],
            vec![0; n],
            vec![0; n],
        );
        let mut mem = MemBuffer::new(
            sym.factorize_numeric_intranode_lblt_scratch::<f64>(Par::Seq, Spec::default()),
        );
        let structure =
            SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
        sym.factorize_numeric_intranode_lblt(
            &mut l,
            &mut sub,
            &mut fwd,
            &mut inv,
            SparseColMatRef::new(structure, values),
            Side::Lower,
            Par::Seq,
            &mut MemStack::new(&mut mem),
            Spec::default(),
        );
        (l, sub, fwd, inv)
    }

    /// ‖A x − b‖ / ‖b‖ for x from the pivoted factor (faer's solve, no refinement).
    fn pivoted_residual(
        sym: &SymbolicCholesky<usize>,
        pattern: &SparsityPattern,
        values: &[f64],
        factor: &(Vec<f64>, Vec<f64>, Vec<usize>, Vec<usize>),
    ) -> f64 {
        let n = pattern.n;
        let b: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 101) as f64 / 50.0 - 1.0)
            .collect();
        let mut x = b.clone();
        let perm = faer::perm::PermRef::new_checked(&factor.2, &factor.3, n);
        let f = IntranodeLbltRef::new(sym, &factor.0, &factor.1, perm);
        let mut mem = MemBuffer::new(sym.solve_in_place_scratch::<f64>(1, Par::Seq));
        f.solve_in_place_with_conj(
            faer::Conj::No,
            MatMut::from_column_major_slice_mut(&mut x, n, 1),
            Par::Seq,
            &mut MemStack::new(&mut mem),
        );
        relative_residual(pattern, values, &x, &b)
    }

    /// The tree's pivoted factor of `values` on `threads` threads: (L, sub-diagonal,
    /// forward and inverse permutation).
    fn tree_pivoted(
        tree: &TreeCholesky,
        sym: &SymbolicCholesky<usize>,
        values: &[f64],
        threads: usize,
        pool: &WorkspacePool<f64>,
    ) -> (Vec<f64>, Vec<f64>, Vec<usize>, Vec<usize>) {
        let n = tree.n;
        let (mut l, mut sub, mut fwd, mut inv) = (
            vec![0.0; sym.len_val()],
            vec![0.0; n],
            vec![0; n],
            vec![0; n],
        );
        in_pool(threads, || {
            tree.factorize_pivoted(&mut l, &mut sub, &mut fwd, &mut inv, values, threads, pool)
        })
        .unwrap();
        (l, sub, fwd, inv)
    }

    /// The inertia of B: (negative eigenvalues, 2x2 blocks).
    fn inertia(sym: &SymbolicCholesky<usize>, l: &[f64], sub: &[f64]) -> (usize, usize) {
        let sn = supernodal(sym);
        let f = SupernodalLltRef::new(sn, l);
        let (mut negative, mut blocks) = (0, 0);
        for s in 0..sn.n_supernodes() {
            let node = f.supernode(s);
            let d = node.val();
            let start = sn.supernode_begin()[s];
            let mut k = 0;
            while k < d.ncols() {
                let c = sub[start + k];
                if c == 0.0 {
                    negative += usize::from(d[(k, k)] < 0.0);
                    k += 1;
                } else {
                    let (p, q) = (d[(k, k)], d[(k + 1, k + 1)]);
                    // det < 0: one negative eigenvalue; else both have the sign of the trace.
                    let det = p * q - c * c;
                    negative += if det < 0.0 {
                        1
                    } else if p + q < 0.0 {
                        2
                    } else {
                        0
                    };
                    blocks += 1;
                    k += 2;
                }
            }
        }
        (negative, blocks)
    }

    #[test]
    fn the_pivoted_tree_factor_is_faers_and_the_same_bits_on_one_and_two_threads() {
        let (m, sym, tree) = grid(11, 10, 9);
        let values = shifted(&m, 0.3);
        let reference = faer_pivoted(&sym, &m.pattern, &values);
        let pool = WorkspacePool::default();
        let one = tree_pivoted(&tree, &sym, &values, 1, &pool);
        let two = tree_pivoted(&tree, &sym, &values, 2, &pool);
        assert!(bitwise_equal(&one.0, &two.0) && bitwise_equal(&one.1, &two.1));
        assert_eq!((&one.2, &one.3), (&two.2, &two.3));
        // The same pivots as faer's (the same algorithm), the same values to round-off.
        assert_eq!(one.2, reference.2, "permutation");
        let blocks = one.1.iter().filter(|&&c| c != 0.0).count();
        assert!(blocks > 0, "the shift must make 2x2 pivots happen");
        assert!(max_relative_difference(&one.0, &reference.0) < 1e-12);
        assert!(max_relative_difference(&one.1, &reference.1) < 1e-12);
        let (negative, _) = inertia(&sym, &one.0, &one.1);
        assert_eq!(negative, inertia(&sym, &reference.0, &reference.1).0);
        assert!(negative > 100, "{negative} negative eigenvalues");
        let residual = pivoted_residual(&sym, &m.pattern, &values, &one);
        let faers = pivoted_residual(&sym, &m.pattern, &values, &reference);
        assert!(
            residual < 1e-9 && residual < 10.0 * faers,
            "{residual:e} (faer {faers:e})"
        );
    }

    #[test]
    fn the_pivoted_tree_factor_of_a_definite_matrix_has_no_negative_pivot() {
        let (m, sym, tree) = grid(9, 8, 8);
        let factor = tree_pivoted(&tree, &sym, &m.values, 2, &WorkspacePool::default());
        assert_eq!(inertia(&sym, &factor.0, &factor.1).0, 0);
        let residual = pivoted_residual(&sym, &m.pattern, &m.values, &factor);
        assert!(residual < 1e-10, "{residual:e}");
    }

    #[test]
    fn an_indefinite_matrix_fails() {
        let (m, sym, tree) = grid(9, 8, 8);
        let values = shifted(&m, 0.3);
        let mut l = vec![0.0; sym.len_val()];
        assert!(tree
            .factorize(&mut l, &values, 2, &WorkspacePool::default())
            .is_err());
    }

    #[test]
    #[ignore = "times the pivoted tree factorisation against faer's sequential one"]
    fn time_pivoted_tree_against_faer() {
        use std::time::Instant;
        for k in [14, 18, 22] {
            let (m, sym, tree) = grid(k, k, k);
            let n = m.pattern.n;
            let values = shifted(&m, 0.05);
            let pool = WorkspacePool::default();
            let (mut l, mut sub, mut fwd, mut inv) = (
                vec![0.0; sym.len_val()],
                vec![0.0; n],
                vec![0; n],
                vec![0; n],
            );
            let mut times = [f64::INFINITY; 3];
            for _ in 0..3 {
                for (slot, threads) in [(0, 1), (1, 2)] {
                    let t = Instant::now();
                    in_pool(threads, || {
                        tree.factorize_pivoted(
                            &mut l, &mut sub, &mut fwd, &mut inv, &values, threads, &pool,
                        )
                    })
                    .unwrap();
                    times[slot] = times[slot].min(t.elapsed().as_secs_f64());
                }
                let t = Instant::now();
                let _ = faer_pivoted(&sym, &m.pattern, &values);
                times[2] = times[2].min(t.elapsed().as_secs_f64());
            }
            eprintln!(
                "n {n}: faer sequential {:.4} s, tree 1 thread {:.4} s, 2 threads {:.4} s; {} negative",
                times[2],
                times[0],
                times[1],
                inertia(&sym, &l, &sub).0
            );
        }
    }

    #[test]
    #[ignore = "times the tree factorisation against faer's sequential one"]
    fn time_tree_against_faer() {
        use std::time::Instant;
        for k in [14, 18, 22] {
            let (m, sym, tree) = grid(k, k, k);
            let pool = WorkspacePool::default();
            let mut l = vec![0.0; sym.len_val()];
            let mut mem = faer_scratch::<f64>(&sym);
            let two = rayon::ThreadPoolBuilder::new()
                .num_threads(2)
                .build()
                .unwrap();
            let one = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap();
            let (mut t1, mut t2, mut tf) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
            for _ in 0..5 {
                let t = Instant::now();
                one.install(|| tree.factorize(&mut l, &m.values, 1, &pool).unwrap());
                t1 = t1.min(t.elapsed().as_secs_f64());
                let t = Instant::now();
                two.install(|| tree.factorize(&mut l, &m.values, 2, &pool).unwrap());
                t2 = t2.min(t.elapsed().as_secs_f64());
                let t = Instant::now();
                faer_factor_into(&sym, &m.pattern, &m.values, &mut l, &mut mem);
                tf = tf.min(t.elapsed().as_secs_f64());
            }
            let mut l1 = vec![0.0; sym.len_val()];
            one.install(|| tree.factorize(&mut l1, &m.values, 1, &pool).unwrap());
            let mut l2 = vec![0.0; sym.len_val()];
            two.install(|| tree.factorize(&mut l2, &m.values, 2, &pool).unwrap());
            let same = bitwise_equal(&l1, &l2);
            eprintln!("n {}: 1 and 2 threads bitwise equal: {same}", m.pattern.n);
            eprintln!(
                "n {}: faer sequential {tf:.4} s, tree 1 thread {t1:.4} s ({:.3}), tree 2 threads {t2:.4} s ({:.3})",
                m.pattern.n,
                t1 / tf,
                t2 / tf
            );
        }
    }
}
