//! Fill-reducing orderings of a symmetric sparsity pattern.
//!
//! The nested-dissection ordering works on the *node graph*: finite-element matrices carry
//! several equations per mesh node (3 for solids, 6 for beams) whose rows have identical
//! adjacency. Equations with identical closed neighbourhoods (the set of coupled equations
//! including themselves) are merged into one weighted vertex, the compressed graph is ordered
//! by METIS (`METIS_NodeND`, multilevel nested dissection with vertex separators, vendored C
//! sources compiled by `metis-sys`), and the node order is expanded back to equations, keeping
//! the equations of one node consecutive (they end up in the same supernode of L).

use std::collections::HashMap;
use std::sync::Mutex;

use super::{LinSolveError, SparsityPattern};

/// Which fill-reducing ordering [`super::FaerSparseSolver`] computes in `analyze`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum FillOrdering {
    /// Nested dissection (METIS `NodeND`) of the compressed node graph. Default: on 3-D meshes
    /// it gives less fill and fewer flops than minimum degree.
    #[default]
    NestedDissection,
    /// faer's approximate minimum degree (AMD) on the equation graph.
    Amd,
    /// No reordering (for tests and tiny systems).
    Natural,
}

/// Equations grouped into indistinguishable sets ("supervariables", usually one per mesh node)
/// and the adjacency graph between the groups, in the CSR form METIS expects.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CompressedGraph {
    /// `members[g]` lists the equations of group `g` (ascending).
    pub members: Vec<Vec<usize>>,
    /// Adjacency pointers, length `members.len() + 1`.
    pub xadj: Vec<usize>,
    /// Neighbouring groups of each group (no self loops, symmetric).
    pub adjncy: Vec<usize>,
}

/// Full symmetric adjacency (closed neighbourhoods, self included, sorted) of each equation.
pub(crate) fn closed_neighbourhoods(pattern: &SparsityPattern) -> Vec<Vec<usize>> {
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); pattern.n];
    for c in 0..pattern.n {
        for &r in &pattern.row_idx[pattern.col_ptr[c]..pattern.col_ptr[c + 1]] {
            adj[c].push(r);
            if r != c {
                adj[r].push(c);
            }
        }
    }
    // Columns are visited in increasing order, so each list is already sorted except that the
    // diagonal may be missing from a malformed pattern: sort + dedup keeps the invariant cheap.
    for (j, list) in adj.iter_mut().enumerate() {
        if list.binary_search(&j).is_err() {
            list.push(j);
        }
        list.sort_unstable();
        list.dedup();
    }
    adj
}

/// Merges equations with identical closed neighbourhoods and builds the quotient graph.
pub fn compress_graph(pattern: &SparsityPattern) -> CompressedGraph {
    let adj = closed_neighbourhoods(pattern);
    let mut group_of = vec![usize::MAX; pattern.n];
    let mut members: Vec<Vec<usize>> = Vec::new();
    let mut buckets: HashMap<(u64, usize), Vec<usize>> = HashMap::new();
    for (j, list) in adj.iter().enumerate() {
        let key = (neighbourhood_hash(list), list.len());
        let candidates = buckets.entry(key).or_default();
        let found = candidates
            .iter()
            .copied()
            .find(|&g| adj[members[g][0]] == *list);
        match found {
            Some(g) => {
                members[g].push(j);
                group_of[j] = g;
            }
            None => {
                let g = members.len();
                members.push(vec![j]);
                candidates.push(g);
                group_of[j] = g;
            }
        }
    }
    let mut xadj = Vec::with_capacity(members.len() + 1);
    let mut adjncy = Vec::new();
    xadj.push(0);
    for (g, group) in members.iter().enumerate() {
        let start = adjncy.len();
        adjncy.extend(
            adj[group[0]]
                .iter()
                .map(|&k| group_of[k])
                .filter(|&h| h != g),
        );
        adjncy[start..].sort_unstable();
        let mut w = start;
        for r in start..adjncy.len() {
            if w == start || adjncy[w - 1] != adjncy[r] {
                adjncy[w] = adjncy[r];
                w += 1;
            }
        }
        adjncy.truncate(w);
        xadj.push(adjncy.len());
    }
    CompressedGraph {
        members,
        xadj,
        adjncy,
    }
}

/// Order-independent hash of a sorted index list (splitmix64 finaliser, summed).
fn neighbourhood_hash(list: &[usize]) -> u64 {
    list.iter().fold(0u64, |acc, &i| {
        let mut z = (i as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        acc.wrapping_add(z ^ (z >> 31))
    })
}

/// METIS keeps no global state in 5.1, but its memory tracker is only thread-local when the
/// compiler supports it; orderings are computed once per model, so serialising is free.
static METIS_LOCK: Mutex<()> = Mutex::new(());

/// Nested-dissection permutation of the equations: `perm[new] = old`.
pub fn nested_dissection(pattern: &SparsityPattern) -> Result<Vec<usize>, LinSolveError> {
    let graph = compress_graph(pattern);
    let nv = graph.members.len();
    if nv <= 2 || graph.adjncy.is_empty() {
        return Ok(expand(&graph.members, &(0..nv).collect::<Vec<_>>()));
    }
    let to_idx = |v: usize| {
        metis_sys::idx_t::try_from(v).map_err(|_| {
            LinSolveError::Usage(format!("graph too large for 32-bit METIS indices ({v})"))
        })
    };
    let mut nvtxs = to_idx(nv)?;
    let mut xadj = graph
        .xadj
        .iter()
        .map(|&v| to_idx(v))
        .collect::<Result<Vec<_>, _>>()?;
    let mut adjncy = graph
        .adjncy
        .iter()
        .map(|&v| to_idx(v))
        .collect::<Result<Vec<_>, _>>()?;
    let mut vwgt = graph
        .members
        .iter()
        .map(|m| to_idx(m.len()))
        .collect::<Result<Vec<_>, _>>()?;
    let mut perm = vec![0 as metis_sys::idx_t; nv];
    let mut iperm = vec![0 as metis_sys::idx_t; nv];
    let status = {
        let _guard = METIS_LOCK
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        // SAFETY: all arrays are valid for the lengths METIS reads (xadj: nv+1, adjncy:
        // xadj[nv], vwgt/perm/iperm: nv); a null options pointer selects the defaults.
        unsafe {
            metis_sys::METIS_NodeND(
                &mut nvtxs,
                xadj.as_mut_ptr(),
                adjncy.as_mut_ptr(),
                vwgt.as_mut_ptr(),
                std::ptr::null_mut(),
                perm.as_mut_ptr(),
                iperm.as_mut_ptr(),
            )
        }
    };
    if status != metis_sys::rstatus_et_METIS_OK {
        return Err(LinSolveError::Usage(format!(
            "METIS_NodeND failed with status {status}"
        )));
    }
    let node_perm: Vec<usize> = perm.iter().map(|&p| p as usize).collect();
    if !is_permutation(&node_perm, nv) {
        return Err(LinSolveError::Usage(
            "METIS_NodeND returned an invalid permutation".into(),
        ));
    }
    Ok(expand(&graph.members, &node_perm))
}

/// Expands a permutation of groups into a permutation of equations.
fn expand(members: &[Vec<usize>], group_perm: &[usize]) -> Vec<usize> {
    group_perm
        .iter()
        .flat_map(|&g| members[g].iter().copied())
        .collect()
}

/// `true` if `perm` holds every index `0..n` exactly once.
pub fn is_permutation(perm: &[usize], n: usize) -> bool {
    if perm.len() != n {
        return false;
    }
    let mut seen = vec![false; n];
    perm.iter()
        .all(|&p| p < n && !std::mem::replace(&mut seen[p], true))
}

/// Inverse of a permutation: `inv[perm[k]] = k`.
pub fn inverse_permutation(perm: &[usize]) -> Vec<usize> {
    let mut inv = vec![0; perm.len()];
    for (k, &p) in perm.iter().enumerate() {
        inv[p] = k;
    }
    inv
}

/// Exact number of nonzeros of the Cholesky factor L (diagonal included) of the pattern
/// permuted by `perm` (`perm[new] = old`), without cancellation.
///
/// Computes the elimination tree (Liu's algorithm with path compression) and counts, for each
/// row `i`, the nodes of its row subtree (union of the tree paths from each `j < i` with
/// `A[i, j] != 0` up to `i`). Cost O(nnz(L)).
pub fn cholesky_fill(pattern: &SparsityPattern, perm: &[usize]) -> usize {
    let n = pattern.n;
    let inv = inverse_permutation(perm);
    let adj = closed_neighbourhoods(pattern);
    // Lower-triangle rows of the permuted matrix: for new row i, the new columns j < i.
    let rows: Vec<Vec<usize>> = (0..n)
        .map(|i| {
            adj[perm[i]]
                .iter()
                .map(|&o| inv[o])
                .filter(|&j| j < i)
                .collect()
        })
        .collect();
    let mut parent = vec![usize::MAX; n];
    let mut ancestor = vec![usize::MAX; n];
    for (i, row) in rows.iter().enumerate() {
        for &j0 in row {
            let mut j = j0;
            while ancestor[j] != usize::MAX && ancestor[j] != i {
                let next = ancestor[j];
                ancestor[j] = i;
                j = next;
            }
            if ancestor[j] == usize::MAX {
                ancestor[j] = i;
                parent[j] = i;
            }
        }
    }
    let mut mark = vec![usize::MAX; n];
    let mut nnz = 0;
    for (i, row) in rows.iter().enumerate() {
        mark[i] = i;
        nnz += 1;
        for &j0 in row {
            let mut j = j0;
            while mark[j] != i {
                mark[j] = i;
                nnz += 1;
                j = parent[j];
            }
        }
    }
    nnz
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linsolve::test_matrices::hex_elasticity;

    #[test]
    fn compression_finds_one_group_per_node_with_three_dofs() {
        let m = hex_elasticity(3, 2, 3, 1.0, 0.3);
        let g = compress_graph(&m.pattern);
        // Free nodes: the z = 0 layer is clamped, so (4 * 3 * 3) nodes remain, 3 DOFs each, and
        // no two nodes of this grid have the same closed neighbourhood.
        assert_eq!(g.members.len(), m.pattern.n / 3);
        assert!(g
            .members
            .iter()
            .all(|grp| grp.len() == 3 && grp[2] == grp[0] + 2));
        // 27-point node stencil: an interior node has 26 neighbours.
        let max_deg = (0..g.members.len())
            .map(|k| g.xadj[k + 1] - g.xadj[k])
            .max();
        assert_eq!(max_deg, Some(26));
        for a in 0..g.members.len() {
            for &b in &g.adjncy[g.xadj[a]..g.xadj[a + 1]] {
                assert!(
                    g.adjncy[g.xadj[b]..g.xadj[b + 1]].contains(&a),
                    "asymmetric"
                );
            }
        }
        // With only two free layers, the nodes above each other couple to exactly the same
        // equations, so each vertical pair of nodes merges into one group of 6 equations.
        let thin = hex_elasticity(3, 2, 2, 1.0, 0.3);
        let g = compress_graph(&thin.pattern);
        assert_eq!(g.members.len(), thin.pattern.n / 6);
        assert!(g.members.iter().all(|grp| grp.len() == 6));
    }

    #[test]
    fn nested_dissection_is_a_valid_permutation_with_nodes_contiguous() {
        let m = hex_elasticity(5, 4, 3, 1.0, 0.3);
        let perm = nested_dissection(&m.pattern).expect("ordering");
        assert!(is_permutation(&perm, m.pattern.n));
        for node in perm.chunks(3) {
            assert_eq!(node[0] % 3, 0);
            assert_eq!((node[1], node[2]), (node[0] + 1, node[0] + 2));
        }
    }

    #[test]
    fn fill_count_matches_dense_and_tridiagonal_cases() {
        // Dense 4x4: L is full lower triangle, 10 entries, whatever the order.
        let dense = SparsityPattern::from_cliques(4, std::iter::once(&[0usize, 1, 2, 3][..]));
        assert_eq!(cholesky_fill(&dense, &[3, 1, 0, 2]), 10);
        // Path graph 0-1-2-3-4 in natural order: no fill (9 entries). Ordering the middle node
        // first creates one fill entry between its two neighbours.
        let edges: Vec<[usize; 2]> = (0..4).map(|i| [i, i + 1]).collect();
        let path = SparsityPattern::from_cliques(5, edges.iter().map(|e| &e[..]));
        assert_eq!(cholesky_fill(&path, &[0, 1, 2, 3, 4]), 9);
        assert_eq!(cholesky_fill(&path, &[2, 0, 1, 3, 4]), 10);
    }

    #[test]
    fn nested_dissection_fills_less_than_natural_order_on_a_3d_grid() {
        let m = hex_elasticity(10, 10, 10, 1.0, 0.3);
        let natural: Vec<usize> = (0..m.pattern.n).collect();
        let nd = nested_dissection(&m.pattern).expect("ordering");
        let (f_nat, f_nd) = (
            cholesky_fill(&m.pattern, &natural),
            cholesky_fill(&m.pattern, &nd),
        );
        assert!(f_nd * 10 < f_nat * 7, "ND fill {f_nd} vs natural {f_nat}");
    }

    #[test]
    fn inverse_permutation_round_trips() {
        let p = vec![2, 0, 3, 1];
        let inv = inverse_permutation(&p);
        assert_eq!(inv, vec![1, 3, 0, 2]);
        assert!(is_permutation(&p, 4) && !is_permutation(&[0, 0, 1], 3));
        assert!(!is_permutation(&[0, 5], 2));
    }
}
