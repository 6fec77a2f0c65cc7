//! Nonlinear elimination: blocks of DOFs re-equilibrated by their own small Newton solve
//! after every global Newton update.
//!
//! Some parts of a model are nearly mechanisms: a free microtubule is a chain of beams held
//! only at its two ends, EI = 0.018 nN·µm², and its interior nodes swing by microns when the
//! ends move a little. The global Newton linearises them with everything else and the
//! linearisation is poor, so it spends iterations on their swing while the rest has long
//! converged. Nonlinear elimination (Lanzkron, Rose & Wilkes 1996; Cai & Li 2011) removes
//! that: after each global update the DOFs of each block are moved, with the rest held, to
//! the block's own equilibrium (`R_b = 0`) by a local Newton on the block's few DOFs.
//!
//! Why the global linear algebra does not change: at a state where `R_b = 0`, the full
//! Newton step `K δ = −R` has the global part of the Newton step of the condensed problem,
//! `(K_gg − K_gb K_bb⁻¹ K_bg) δ_g = −R_g`, because block elimination of the linear system
//! with a zero right-hand side in the block rows is exactly that Schur complement. So the
//! global iteration is Newton on the condensed residual `R_g(u_g, u_b(u_g))`, whose
//! tangent is the consistent one, and the block's nonlinearity is resolved exactly by the
//! local solves instead of approximately by the global step. The converged state is the
//! same equilibrium (`R = 0` on every free DOF, checked by the unchanged global criteria).
//!
//! A block is a set of global DOFs; every element of every term that touches one of them
//! takes part in the block's local problem (the others' DOFs held). A block DOF that is
//! prescribed in the running step, or tied by a linear constraint, is left out for that
//! solve. A local solve that does not converge puts its block back where the global step
//! left it: the global Newton then proceeds as it would without elimination.

use crate::dof::DofMap;
use crate::term::{Term, MAX_ELEMENT_DOFS};

/// Most local Newton iterations of one block solve.
const MAX_LOCAL_ITERATIONS: usize = 30;
/// A block is relaxed to `‖R_b‖ ≤` this fraction of the global residual target.
const LOCAL_TOLERANCE_FRACTION: f64 = 1e-2;

/// One block: its DOFs and the elements that touch them.
#[derive(Debug, Clone)]
struct Block {
    dofs: Vec<usize>,
    /// (term index, element index) of every element touching a block DOF.
    elements: Vec<(usize, usize)>,
}

/// What the relaxation did, summed over the problem's life (for logs and tests).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct RelaxationStats {
    /// Block solves started.
    pub solves: usize,
    /// Local Newton iterations in all of them.
    pub iterations: usize,
    /// Block solves that did not converge and were undone.
    pub undone: usize,
}

/// The blocks of a problem and the scratch space of their local solves.
#[derive(Debug, Clone)]
pub(super) struct Relaxation {
    blocks: Vec<Block>,
    /// Local position of each global DOF in the block being solved (`usize::MAX`: not in it).
    local: Vec<usize>,
    /// Active DOFs of the block being solved.
    active: Vec<usize>,
    residual: Vec<f64>,
    tangent: Vec<f64>,
    start: Vec<f64>,
    pub stats: RelaxationStats,
}

/// A viscous stabiliser's damping: its weights `m_d`, the increment's start values and
/// its rate `c/Δt` (force `rate·m_d·(u_d − u_start,d)`).
pub(super) type Damping<'a> = Option<(&'a [f64], &'a [f64], f64)>;

impl Relaxation {
    /// Blocks of global DOFs; each element touching a block is found once here.
    pub fn new(blocks: Vec<Vec<usize>>, terms: &[Box<dyn Term>], dof_map: &DofMap) -> Self {
        let n = dof_map.num_dofs();
        let mut owner = vec![usize::MAX; n];
        let blocks: Vec<Vec<usize>> = blocks
            .into_iter()
            .map(|mut b| {
                b.retain(|&d| d < n);
                b.sort_unstable();
                b.dedup();
                b
            })
            .filter(|b| !b.is_empty())
            .collect();
        for (i, b) in blocks.iter().enumerate() {
            for &d in b {
                owner[d] = i;
            }
        }
        let mut elements = vec![Vec::new(); blocks.len()];
        let mut dofs = [0usize; MAX_ELEMENT_DOFS];
        for (t, term) in terms.iter().enumerate() {
            for e in 0..term.num_elements() {
                let k = term.element_dofs(e, dof_map, &mut dofs);
                let mut last = usize::MAX;
                for &d in &dofs[..k] {
                    let b = owner[d];
                    if b != usize::MAX && b != last {
                        if elements[b].last() != Some(&(t, e)) {
                            elements[b].push((t, e));
                        }
                        last = b;
                    }
                }
            }
        }
        let largest = blocks.iter().map(Vec::len).max().unwrap_or(0);
        Relaxation {
            blocks: blocks
                .into_iter()
                .zip(elements)
                .map(|(dofs, elements)| Block { dofs, elements })
                .collect(),
            local: vec![usize::MAX; n],
            active: Vec::with_capacity(largest),
            residual: vec![0.0; largest],
            tangent: vec![0.0; largest * largest],
            start: vec![0.0; largest],
            stats: RelaxationStats::default(),
        }
    }

    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.blocks.len()
    }

    /// Moves every block of `u` to its local equilibrium `R_b(u) = f_ext,b` (internal forces
    /// of `terms`, plus the viscous forces of `damping` when a stabiliser is on), holding
    /// all other DOFs. `excluded(d)`: DOFs that must not move (prescribed, constrained).
    /// `tolerance`: the global residual target (nN); a block is solved to a hundredth of it.
    #[allow(clippy::too_many_arguments)]
    pub fn relax(
        &mut self,
        terms: &[Box<dyn Term>],
        dof_map: &DofMap,
        u: &mut [f64],
        f_ext: &[f64],
        excluded: impl Fn(usize) -> bool,
        damping: Damping<'_>,
        tolerance: f64,
    ) {
        if !(tolerance > 0.0) {
            return;
        }
        let target = LOCAL_TOLERANCE_FRACTION * tolerance;
        for b in 0..self.blocks.len() {
            self.active.clear();
            for &d in &self.blocks[b].dofs {
                if !excluded(d) {
                    self.local[d] = self.active.len();
                    self.active.push(d);
                }
            }
            if !self.active.is_empty() {
                self.solve_block(b, terms, dof_map, u, f_ext, damping, target);
            }
            for &d in &self.blocks[b].dofs {
                self.local[d] = usize::MAX;
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn solve_block(
        &mut self,
        b: usize,
        terms: &[Box<dyn Term>],
        dof_map: &DofMap,
        u: &mut [f64],
        f_ext: &[f64],
        damping: Damping<'_>,
        target: f64,
    ) {
        let m = self.active.len();
        for (i, &d) in self.active.iter().enumerate() {
            self.start[i] = u[d];
        }
        self.stats.solves += 1;
        let mut first = f64::INFINITY;
        for iteration in 0..=MAX_LOCAL_ITERATIONS {
            let Some(norm) = self.assemble(b, terms, dof_map, u, f_ext, damping) else {
                break;
            };
            if iteration == 0 {
                first = norm;
            }
            if norm <= target {
                return;
            }
            // A local solve that grows the residual past its start has left the basin:
            // give up rather than carry the block onto another branch.
            if iteration == MAX_LOCAL_ITERATIONS || !(norm <= 10.0 * first) {
                break;
            }
            self.stats.iterations += 1;
            if !solve_dense(&mut self.tangent[..m * m], &mut self.residual[..m], m) {
                break;
            }
            for (i, &d) in self.active.iter().enumerate() {
                u[d] -= self.residual[i];
            }
        }
        self.stats.undone += 1;
        for (i, &d) in self.active.iter().enumerate() {
            u[d] = self.start[i];
        }
    }

    /// The block's residual `R_b − f_ext,b` (into `residual`) and tangent `K_bb` at `u`;
    /// returns ‖R_b − f_ext,b‖, or `None` when an element cannot be evaluated there.
    fn assemble(
        &mut self,
        b: usize,
        terms: &[Box<dyn Term>],
        dof_map: &DofMap,
        u: &[f64],
        f_ext: &[f64],
        damping: Damping<'_>,
    ) -> Option<f64> {
        let m = self.active.len();
        self.residual[..m].fill(0.0);
        self.tangent[..m * m].fill(0.0);
        let mut dofs = [0usize; MAX_ELEMENT_DOFS];
        let mut u_e = [0.0; MAX_ELEMENT_DOFS];
        let mut r_e = [0.0; MAX_ELEMENT_DOFS];
        let mut k_e = [0.0; MAX_ELEMENT_DOFS * MAX_ELEMENT_DOFS];
        for &(t, e) in &self.blocks[b].elements {
            let term = &terms[t];
            let k = term.element_dofs(e, dof_map, &mut dofs);
            for i in 0..k {
                u_e[i] = u[dofs[i]];
            }
            r_e[..k].fill(0.0);
            k_e[..k * k].fill(0.0);
            term.evaluate(e, &u_e[..k], &mut r_e[..k], Some(&mut k_e[..k * k]))
                .ok()?;
            for i in 0..k {
                let li = self.local[dofs[i]];
                if li == usize::MAX {
                    continue;
                }
                self.residual[li] += r_e[i];
                for j in 0..k {
                    let lj = self.local[dofs[j]];
                    if lj != usize::MAX {
                        self.tangent[li * m + lj] += k_e[i * k + j];
                    }
                }
            }
        }
        for (i, &d) in self.active.iter().enumerate() {
            if let Some((weight, u_start, rate)) = damping {
                if weight[d] > 0.0 {
                    self.residual[i] += rate * weight[d] * (u[d] - u_start[d]);
                    self.tangent[i * m + i] += rate * weight[d];
                }
            }
            self.residual[i] -= f_ext[d];
        }
        let norm = self.residual[..m].iter().map(|x| x * x).sum::<f64>().sqrt();
        norm.is_finite().then_some(norm)
    }
}

/// Solves `A x = r` in place (`r` becomes `x`) by Gaussian elimination with partial
/// pivoting; `a` (row-major, `m × m`) is overwritten. False when `A` is singular.
fn solve_dense(a: &mut [f64], r: &mut [f64], m: usize) -> bool {
    let scale = a.iter().fold(0.0f64, |s, x| s.max(x.abs()));
    if !(scale > 0.0) {
        return false;
    }
    for col in 0..m {
        let (pivot, largest) = (col..m)
            .map(|row| (row, a[row * m + col].abs()))
            .fold((col, -1.0), |best, x| if x.1 > best.1 { x } else { best });
        if !(largest > 1e-14 * scale) {
            return false;
        }
        if pivot != col {
            for j in 0..m {
                a.swap(pivot * m + j, col * m + j);
            }
            r.swap(pivot, col);
        }
        let diagonal = a[col * m + col];
        for row in col + 1..m {
            let factor = a[row * m + col] / diagonal;
            if factor != 0.0 {
                for j in col..m {
                    a[row * m + j] -= factor * a[col * m + j];
                }
                r[row] -= factor * r[col];
            }
        }
    }
    for row in (0..m).rev() {
        let mut x = r[row];
        for j in row + 1..m {
            x -= a[row * m + j] * r[j];
        }
        r[row] = x / a[row * m + row];
    }
    r.iter().all(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::solve_dense;

    #[test]
    fn dense_solve_with_pivoting_matches_the_known_solution() {
        // A zero on the first diagonal needs the row swap.
        let mut a = vec![0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let x = [1.0, -2.0, 0.5];
        let mut r: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| a[i * 3 + j] * x[j]).sum())
            .collect();
        assert!(solve_dense(&mut a, &mut r, 3));
        for i in 0..3 {
            assert!((r[i] - x[i]).abs() < 1e-14, "{r:?}");
        }
        let mut singular = vec![1.0, 2.0, 2.0, 4.0];
        assert!(!solve_dense(&mut singular, &mut [1.0, 1.0], 2));
    }
}
