//! The sparsity pattern of a symmetric matrix: lower triangle in compressed sparse columns.

/// Lower triangle (row >= col) of a symmetric `n x n` matrix in CSC form, with sorted,
/// unique row indices in every column. Built once per model from the element DOF lists.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SparsityPattern {
    /// Matrix dimension.
    pub n: usize,
    /// Column pointers, length `n + 1`.
    pub col_ptr: Vec<usize>,
    /// Row indices, length `col_ptr[n]`, sorted within each column, all `>= col`.
    pub row_idx: Vec<usize>,
}

impl SparsityPattern {
    /// Builds the pattern from cliques of coupled equations (e.g. the free equations of each
    /// element). Entries outside `0..n` are ignored (prescribed DOFs are passed as `usize::MAX`).
    pub fn from_cliques<'a>(n: usize, cliques: impl Iterator<Item = &'a [usize]>) -> Self {
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n];
        for clique in cliques {
            for &i in clique.iter().filter(|&&i| i < n) {
                for &j in clique.iter().filter(|&&j| j < n && j >= i) {
                    cols[i].push(j);
                }
            }
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for (c, col) in cols.iter_mut().enumerate() {
            col.push(c); // the diagonal is always present
            col.sort_unstable();
            col.dedup();
            row_idx.extend_from_slice(col);
            col_ptr.push(row_idx.len());
        }
        SparsityPattern {
            n,
            col_ptr,
            row_idx,
        }
    }

    /// Number of stored entries (lower triangle including the diagonal).
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Position of entry `(row, col)` in the value array; `row >= col` is required.
    pub fn position(&self, row: usize, col: usize) -> Option<usize> {
        let (lo, hi) = (self.col_ptr[col], self.col_ptr[col + 1]);
        self.row_idx[lo..hi]
            .binary_search(&row)
            .ok()
            .map(|k| lo + k)
    }

    /// `y = A x` for the symmetric matrix whose lower triangle `values` holds.
    pub fn sym_mul(&self, values: &[f64], x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for c in 0..self.n {
            for k in self.col_ptr[c]..self.col_ptr[c + 1] {
                let r = self.row_idx[k];
                y[r] += values[k] * x[c];
                if r != c {
                    y[c] += values[k] * x[r];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pattern_from_cliques_holds_lower_triangle_and_skips_prescribed() {
        let cliques = [vec![0, 2, usize::MAX], vec![1, 2]];
        let p = SparsityPattern::from_cliques(3, cliques.iter().map(|c| c.as_slice()));
        assert_eq!(p.col_ptr, vec![0, 2, 4, 5]);
        assert_eq!(p.row_idx, vec![0, 2, 1, 2, 2]);
        assert_eq!(p.position(2, 0), Some(1));
        assert_eq!(p.position(1, 0), None);
    }
}
