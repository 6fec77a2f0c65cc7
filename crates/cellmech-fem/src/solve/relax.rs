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

use rayon::prelude::*;

use crate::dof::DofMap;
use crate::term::{Term, MAX_ELEMENT_DOFS};

/// Most local Newton iterations of one block solve.
const MAX_LOCAL_ITERATIONS: usize = 30;
/// A block is relaxed to `‖R_b‖ ≤` this fraction of the global residual target.
const LOCAL_TOLERANCE_FRACTION: f64 = 1e-2;

/// One block: its DOFs, the elements that touch them, and the scratch space of its solve.
///
/// The block works on a compact copy of the DOFs its elements touch: `dofs` (global
/// indices) lists the block's own DOFs first (`own` of them), then the held ones.
#[derive(Debug, Clone)]
struct Block {
    dofs: Vec<usize>,
    own: usize,
    /// (term index, element index, first entry in `slots`) of every element touching it.
    elements: Vec<(usize, usize, usize)>,
    /// Per element, its DOFs as positions in `dofs`.
    slots: Vec<usize>,
    /// Compact DOF values.
    values: Vec<f64>,
    /// Which own DOFs move in this solve.
    moving: Vec<bool>,
    residual: Vec<f64>,
    tangent: Vec<f64>,
    /// Per own DOF: external force, viscous weight × rate, increment-start value.
    load: Vec<f64>,
    damping: Vec<f64>,
    damping_start: Vec<f64>,
    /// Outcome of the last solve: local iterations, and whether it was undone.
    iterations: usize,
    undone: bool,
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
    /// Wall time in the block solves (s).
    pub seconds: f64,
}

/// The blocks of a problem.
#[derive(Debug, Clone)]
pub(super) struct Relaxation {
    blocks: Vec<Block>,
    /// Whether no element touches two blocks: then the blocks are solved in parallel.
    independent: bool,
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
        let mut own: Vec<Vec<usize>> = Vec::new();
        for mut b in blocks {
            b.retain(|&d| d < n && owner[d] == usize::MAX);
            b.sort_unstable();
            b.dedup();
            if b.is_empty() {
                continue;
            }
            for &d in &b {
                owner[d] = own.len();
            }
            own.push(b);
        }
        let mut touching: Vec<Vec<(usize, usize)>> = vec![Vec::new(); own.len()];
        let mut independent = true;
        let mut dofs = [0usize; MAX_ELEMENT_DOFS];
        for (t, term) in terms.iter().enumerate() {
            for e in 0..term.num_elements() {
                let k = term.element_dofs(e, dof_map, &mut dofs);
                let mut first = usize::MAX;
                for &d in &dofs[..k] {
                    let b = owner[d];
                    if b == usize::MAX {
                        continue;
                    }
                    if first == usize::MAX {
                        first = b;
                        touching[b].push((t, e));
                    } else if b != first {
                        independent = false;
                        if touching[b].last() != Some(&(t, e)) {
                            touching[b].push((t, e));
                        }
                    }
                }
            }
        }
        let blocks = own
            .into_iter()
            .zip(touching)
            .map(|(own_dofs, elements)| {
                let m = own_dofs.len();
                let mut all = own_dofs;
                let mut slots = Vec::new();
                let mut listed = Vec::with_capacity(elements.len());
                for (t, e) in elements {
                    let k = terms[t].element_dofs(e, dof_map, &mut dofs);
                    listed.push((t, e, slots.len()));
                    for &d in &dofs[..k] {
                        let position = match all.iter().position(|&x| x == d) {
                            Some(p) => p,
                            None => {
                                all.push(d);
                                all.len() - 1
                            }
                        };
                        slots.push(position);
                    }
                }
                Block {
                    values: vec![0.0; all.len()],
                    dofs: all,
                    own: m,
                    elements: listed,
                    slots,
                    moving: vec![false; m],
                    residual: vec![0.0; m],
                    tangent: vec![0.0; m * m],
                    load: vec![0.0; m],
                    damping: vec![0.0; m],
                    damping_start: vec![0.0; m],
                    iterations: 0,
                    undone: false,
                }
            })
            .collect();
        Relaxation {
            blocks,
            independent,
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
    /// Independent blocks are solved in parallel on the calling rayon pool; each block's
    /// solve is the same whatever the thread count.
    #[allow(clippy::too_many_arguments)]
    pub fn relax(
        &mut self,
        terms: &[Box<dyn Term>],
        u: &mut [f64],
        f_ext: &[f64],
        excluded: impl Fn(usize) -> bool + Sync,
        damping: Damping<'_>,
        tolerance: f64,
    ) {
        if !(tolerance > 0.0) {
            return;
        }
        let clock = std::time::Instant::now();
        let target = LOCAL_TOLERANCE_FRACTION * tolerance;
        if self.independent {
            let u_read: &[f64] = u;
            self.blocks
                .par_iter_mut()
                .with_min_len(4)
                .for_each(|b| b.solve(terms, u_read, f_ext, &excluded, damping, target));
            for b in &self.blocks {
                b.scatter(u);
            }
        } else {
            for b in &mut self.blocks {
                b.solve(terms, u, f_ext, &excluded, damping, target);
                b.scatter(u);
            }
        }
        for b in &self.blocks {
            self.stats.solves += usize::from(b.moving.iter().any(|&x| x));
            self.stats.iterations += b.iterations;
            self.stats.undone += usize::from(b.undone);
        }
        self.stats.seconds += clock.elapsed().as_secs_f64();
    }
}

impl Block {
    /// Writes the block's own values back into `u`.
    fn scatter(&self, u: &mut [f64]) {
        for i in 0..self.own {
            if self.moving[i] {
                u[self.dofs[i]] = self.values[i];
            }
        }
    }

    /// Local Newton on the block's moving DOFs, from `u`; the result stays in `values`
    /// (the start again when the solve did not converge).
    fn solve(
        &mut self,
        terms: &[Box<dyn Term>],
        u: &[f64],
        f_ext: &[f64],
        excluded: &(impl Fn(usize) -> bool + Sync),
        damping: Damping<'_>,
        target: f64,
    ) {
        self.iterations = 0;
        self.undone = false;
        for (value, &d) in self.values.iter_mut().zip(&self.dofs) {
            *value = u[d];
        }
        for i in 0..self.own {
            let d = self.dofs[i];
            self.moving[i] = !excluded(d);
            self.load[i] = f_ext[d];
            (self.damping[i], self.damping_start[i]) = match damping {
                Some((weight, start, rate)) if weight[d] > 0.0 => (rate * weight[d], start[d]),
                _ => (0.0, 0.0),
            };
        }
        if !self.moving.iter().any(|&x| x) {
            return;
        }
        let mut first = f64::INFINITY;
        for iteration in 0..=MAX_LOCAL_ITERATIONS {
            // After an update, check the residual alone first (the tangent costs six times
            // as much and is wasted when the block has converged).
            if iteration > 0 {
                match self.assemble(terms, false) {
                    Some(norm) if norm <= target => return,
                    Some(norm) if norm <= 10.0 * first && iteration < MAX_LOCAL_ITERATIONS => {}
                    // A local solve that grows the residual past its start has left the
                    // basin: give up rather than carry the block onto another branch.
                    _ => break,
                }
            }
            let Some(norm) = self.assemble(terms, true) else {
                break;
            };
            if iteration == 0 {
                first = norm;
                if norm <= target {
                    return;
                }
            }
            self.iterations += 1;
            let m = self.own;
            if !solve_dense(&mut self.tangent, &mut self.residual, m) {
                break;
            }
            for i in 0..m {
                self.values[i] -= self.residual[i];
            }
        }
        self.undone = true;
        for i in 0..self.own {
            self.values[i] = u[self.dofs[i]];
        }
    }

    /// The residual `R_b − f_ext,b` (into `residual`) and, when asked, the tangent `K_bb` of
    /// the moving DOFs at `values` (held DOFs get an identity row and no residual); returns
    /// the norm, or `None` when an element cannot be evaluated there.
    fn assemble(&mut self, terms: &[Box<dyn Term>], with_tangent: bool) -> Option<f64> {
        let m = self.own;
        self.residual.fill(0.0);
        self.tangent.fill(0.0);
        let mut u_e = [0.0; MAX_ELEMENT_DOFS];
        let mut r_e = [0.0; MAX_ELEMENT_DOFS];
        let mut k_e = [0.0; MAX_ELEMENT_DOFS * MAX_ELEMENT_DOFS];
        for (index, &(t, e, first)) in self.elements.iter().enumerate() {
            let end = match self.elements.get(index + 1) {
                Some(&(_, _, next)) => next,
                None => self.slots.len(),
            };
            let slots = &self.slots[first..end];
            let k = slots.len();
            for (value, &s) in u_e.iter_mut().zip(slots) {
                *value = self.values[s];
            }
            r_e[..k].fill(0.0);
            k_e[..k * k].fill(0.0);
            let tangent = with_tangent.then_some(&mut k_e[..k * k]);
            terms[t]
                .evaluate(e, &u_e[..k], &mut r_e[..k], tangent)
                .ok()?;
            for (i, &si) in slots.iter().enumerate() {
                if si >= m || !self.moving[si] {
                    continue;
                }
                self.residual[si] += r_e[i];
                if !with_tangent {
                    continue;
                }
                for (j, &sj) in slots.iter().enumerate() {
                    if sj < m && self.moving[sj] {
                        self.tangent[si * m + sj] += k_e[i * k + j];
                    }
                }
            }
        }
        for i in 0..m {
            if self.moving[i] {
                self.residual[i] +=
                    self.damping[i] * (self.values[i] - self.damping_start[i]) - self.load[i];
                self.tangent[i * m + i] += self.damping[i];
            } else {
                self.tangent[i * m + i] = 1.0;
            }
        }
        let norm = self.residual.iter().map(|x| x * x).sum::<f64>().sqrt();
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
