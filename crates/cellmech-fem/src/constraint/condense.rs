//! Exact elimination of linear constraints from the assembled system (condensation).
//!
//! With `u = T ū` (ū: the unconstrained DOFs, slaves `u_s = Σ w u_m`), the reduced
//! equations are `r̄ = Tᵀ r(T ū)` and `K̄ = Tᵀ K T`. They are written on the full DOF vector
//! (same numbering as the model): a slave keeps its row and column, with 1 on the diagonal,
//! 0 elsewhere and a zero residual, exactly as a prescribed DOF; its value is recovered from
//! the masters after every solve ([`super::LinearConstraints::expand`]).
//!
//! # Procedure (per assembly, no allocation)
//! 1. The ordinary [`Assembler`] assembles the element contributions **unmasked** into the
//!    element pattern (all DOFs free).
//! 2. Predictor (first iteration of an increment): `Δu = T Δū_p` (prescribed increments,
//!    carried to the slaves of prescribed masters), `p = Tᵀ (K Δu)`.
//! 3. Tangent: every stored entry `K_ij` (i ≥ j) is scattered through a precomputed map to
//!    the reduced pattern: `K̄_ab += T_ia T_jb K_ij` over the masters a of i and b of j
//!    (`T_ii = 1` for an unconstrained i); an off-diagonal entry stands for `K_ij` and
//!    `K_ji`, so a target on the diagonal (a = b) receives it twice. Entries whose target
//!    row or column is prescribed are skipped, then prescribed and slave diagonals get 1.
//! 4. Residual and magnitudes: `r_m += w r_s`, `r_s = 0`.
//!
//! The reduced pattern (built once) holds the element couplings between unconstrained DOFs,
//! the couplings the constraints induce between masters (e.g. all 8 nodes of the hosts of
//! the two ends of an embedded fibre element), and the slave diagonals — and no slave
//! off-diagonal, so slaves add no fill to the factorisation.

use crate::assembly::{Assembler, AssemblyError, AssemblyOutput};
use crate::linsolve::SparsityPattern;
use crate::term::Term;

use super::{ConstraintError, LinearConstraints};

/// The condensation of one model's constraints: reduced pattern, scatter map and buffers.
#[derive(Debug, Clone)]
pub struct Condensation {
    constraints: LinearConstraints,
    full: SparsityPattern,
    reduced: SparsityPattern,
    /// Column of every reduced entry.
    reduced_col: Vec<u32>,
    /// Full entry `k` goes to `target_pos[target_offsets[k]..target_offsets[k+1]]` with
    /// factors `target_w[..]`.
    target_offsets: Vec<usize>,
    target_pos: Vec<u32>,
    target_w: Vec<f64>,
    no_mask: Vec<bool>,
    full_values: Vec<f64>,
    du_full: Vec<f64>,
    pred_full: Vec<f64>,
}

/// Targets of one matrix entry merged by a linear search; beyond, by a map.
const LINEAR_MERGE: usize = 32;

impl Condensation {
    /// Builds the reduced pattern and the scatter map for the element pattern `full` (from
    /// [`Assembler::pattern`]).
    pub fn new(
        constraints: LinearConstraints,
        full: &SparsityPattern,
    ) -> Result<Self, ConstraintError> {
        let n = full.n;
        if constraints.num_dofs() != n {
            return Err(ConstraintError::SizeMismatch {
                constraints: constraints.num_dofs(),
                model: n,
            });
        }
        let one = [1.0];
        let expansion = |d: usize, own: &[usize; 1]| -> (Vec<usize>, Vec<f64>) {
            match constraints.masters_of(d) {
                Some((m, w)) => (m.to_vec(), w.to_vec()),
                None => (own.to_vec(), one.to_vec()),
            }
        };
        // Pass 1: the reduced pattern's columns.
        let mut cols: Vec<Vec<usize>> = (0..n).map(|c| vec![c]).collect();
        let for_targets = |i: usize, j: usize, f: &mut dyn FnMut(usize, usize, f64)| {
            if !constraints.is_slave(i) && !constraints.is_slave(j) {
                return f(i, j, 1.0);
            }
            let (pi, wi) = expansion(i, &[i]);
            let (pj, wj) = expansion(j, &[j]);
            if i == j {
                for (x, (&a, &wa)) in pi.iter().zip(&wi).enumerate() {
                    for (&b, &wb) in pi[..=x].iter().zip(&wi[..=x]) {
                        f(a.max(b), a.min(b), wa * wb);
                    }
                }
            } else {
                for (&a, &wa) in pi.iter().zip(&wi) {
                    for (&b, &wb) in pj.iter().zip(&wj) {
                        let twice = if a == b { 2.0 } else { 1.0 };
                        f(a.max(b), a.min(b), twice * wa * wb);
                    }
                }
            }
        };
        for j in 0..n {
            for k in full.col_ptr[j]..full.col_ptr[j + 1] {
                let i = full.row_idx[k];
                for_targets(i, j, &mut |row, col, _| cols[col].push(row));
            }
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        let mut reduced_col = Vec::new();
        col_ptr.push(0);
        for (c, col) in cols.iter_mut().enumerate() {
            col.sort_unstable();
            col.dedup();
            row_idx.extend_from_slice(col);
            reduced_col.extend(std::iter::repeat_n(c as u32, col.len()));
            col_ptr.push(row_idx.len());
        }
        drop(cols);
        let reduced = SparsityPattern {
            n,
            col_ptr,
            row_idx,
        };
        // Pass 2: the scatter map (merging repeated targets of one entry).
        let mut target_offsets = Vec::with_capacity(full.nnz() + 1);
        let mut target_pos: Vec<u32> = Vec::with_capacity(full.nnz());
        let mut target_w = Vec::with_capacity(full.nnz());
        target_offsets.push(0);
        // An entry of a slave with many masters (a distributing coupling over hundreds of
        // nodes) has as many targets as pairs of masters: merging them by a linear search
        // took minutes, so beyond a few targets they are looked up in a map.
        let mut index: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
        for j in 0..n {
            for k in full.col_ptr[j]..full.col_ptr[j + 1] {
                let i = full.row_idx[k];
                let start = target_pos.len();
                // Clearing costs the map's capacity: only after an entry that used it.
                if !index.is_empty() {
                    index.clear();
                }
                for_targets(i, j, &mut |row, col, w| {
                    let pos = reduced
                        .position(row, col)
                        .expect("the reduced pattern holds every target")
                        as u32;
                    let found = if target_pos.len() - start <= LINEAR_MERGE {
                        target_pos[start..]
                            .iter()
                            .position(|&p| p == pos)
                            .map(|x| start + x)
                    } else {
                        if index.is_empty() {
                            index.extend((start..target_pos.len()).map(|x| (target_pos[x], x)));
                        }
                        index.get(&pos).copied()
                    };
                    match found {
                        Some(x) => target_w[x] += w,
                        None => {
                            if !index.is_empty() {
                                index.insert(pos, target_pos.len());
                            }
                            target_pos.push(pos);
                            target_w.push(w);
                        }
                    }
                });
                target_offsets.push(target_pos.len());
            }
        }
        let nnz = full.nnz();
        Ok(Condensation {
            constraints,
            full: full.clone(),
            reduced,
            reduced_col,
            target_offsets,
            target_pos,
            target_w,
            no_mask: vec![false; n],
            full_values: vec![0.0; nnz],
            du_full: vec![0.0; n],
            pred_full: vec![0.0; n],
        })
    }

    /// The constraints.
    pub fn constraints(&self) -> &LinearConstraints {
        &self.constraints
    }

    /// The pattern of the reduced tangent (what the linear solver factorises).
    pub fn reduced_pattern(&self) -> &SparsityPattern {
        &self.reduced
    }

    /// The element pattern the assembler writes (before condensation).
    pub fn element_pattern(&self) -> &SparsityPattern {
        &self.full
    }

    /// Assembles the reduced system at `u` (which must satisfy the constraints) with the
    /// prescribed mask `prescribed` (slaves must not be prescribed). Same contract as
    /// [`Assembler::assemble`], with `out.tangent` in the order of
    /// [`Condensation::reduced_pattern`], and `out.residual`/`out.magnitude`/`out.predictor`
    /// condensed onto the masters (zero at slaves). Returns the internal energy.
    pub fn assemble(
        &mut self,
        assembler: &Assembler,
        terms: &[Box<dyn Term>],
        u: &[f64],
        prescribed: &[bool],
        out: AssemblyOutput<'_>,
    ) -> Result<f64, AssemblyError> {
        let AssemblyOutput {
            residual,
            mut magnitude,
            tangent,
            predictor,
        } = out;
        let want_k = tangent.is_some() || predictor.is_some();
        let energy = assembler.assemble(
            terms,
            u,
            &self.no_mask,
            AssemblyOutput {
                residual: &mut *residual,
                magnitude: magnitude.as_deref_mut(),
                tangent: want_k.then_some(self.full_values.as_mut_slice()),
                predictor: None,
            },
        )?;
        let c = &self.constraints;
        if let Some((du_p, p)) = predictor {
            for (d, du) in self.du_full.iter_mut().enumerate() {
                *du = if prescribed[d] { du_p[d] } else { 0.0 };
            }
            c.expand(&mut self.du_full);
            self.full
                .sym_mul(&self.full_values, &self.du_full, &mut self.pred_full);
            p.copy_from_slice(&self.pred_full);
            c.condense(p);
        }
        if let Some(t) = tangent {
            t.fill(0.0);
            for (k, &value) in self.full_values.iter().enumerate() {
                if value == 0.0 {
                    continue;
                }
                for x in self.target_offsets[k]..self.target_offsets[k + 1] {
                    let pos = self.target_pos[x] as usize;
                    let (row, col) = (self.reduced.row_idx[pos], self.reduced_col[pos] as usize);
                    if !prescribed[row] && !prescribed[col] {
                        t[pos] += self.target_w[x] * value;
                    }
                }
            }
            for d in 0..self.reduced.n {
                if prescribed[d] || c.is_slave(d) {
                    t[self.reduced.col_ptr[d]] = 1.0; // the diagonal leads its column
                }
            }
        }
        c.condense(residual);
        if let Some(m) = magnitude {
            for (x, &s) in c.slaves().iter().enumerate() {
                let value = std::mem::take(&mut m[s]);
                let (masters, weights) = c.constraint(x);
                for (&mm, &w) in masters.iter().zip(weights) {
                    m[mm] += w.abs() * value;
                }
            }
        }
        Ok(energy)
    }
}
