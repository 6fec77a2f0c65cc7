//! A dense reference solver.

use super::{FactorInfo, FactorMethod, LinSolveError, LinearSolver, SparsityPattern};

/// Dense LU with partial pivoting: an independent reference solver for small systems and
/// tests (O(n³) time, O(n²) memory; use the sparse solver for real models).
#[derive(Debug, Default, Clone)]
pub struct DenseSolver {
    pattern: Option<SparsityPattern>,
    lu: Vec<f64>,
    pivots: Vec<usize>,
}

impl LinearSolver for DenseSolver {
    fn analyze(&mut self, pattern: &SparsityPattern) -> Result<(), LinSolveError> {
        self.pattern = Some(pattern.clone());
        Ok(())
    }

    fn factorize(&mut self, values: &[f64]) -> Result<FactorInfo, LinSolveError> {
        let p = self
            .pattern
            .as_ref()
            .ok_or(LinSolveError::Usage("not analysed".into()))?;
        let n = p.n;
        self.lu = vec![0.0; n * n];
        for c in 0..n {
            for k in p.col_ptr[c]..p.col_ptr[c + 1] {
                let r = p.row_idx[k];
                self.lu[r * n + c] = values[k];
                self.lu[c * n + r] = values[k];
            }
        }
        self.pivots = (0..n).collect();
        for k in 0..n {
            let (piv, max) = (k..n)
                .map(|i| (i, self.lu[i * n + k].abs()))
                .fold((k, -1.0), |a, b| if b.1 > a.1 { b } else { a });
            if max == 0.0 {
                return Err(LinSolveError::Singular(format!("zero pivot in column {k}")));
            }
            if piv != k {
                for j in 0..n {
                    self.lu.swap(k * n + j, piv * n + j);
                }
                self.pivots.swap(k, piv);
            }
            for i in k + 1..n {
                let f = self.lu[i * n + k] / self.lu[k * n + k];
                self.lu[i * n + k] = f;
                for j in k + 1..n {
                    self.lu[i * n + j] -= f * self.lu[k * n + j];
                }
            }
        }
        Ok(FactorInfo {
            method: FactorMethod::Lu,
            negative_pivots: None,
        })
    }

    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinSolveError> {
        let n = rhs.len();
        let b: Vec<f64> = self.pivots.iter().map(|&p| rhs[p]).collect();
        let mut y = b;
        for i in 0..n {
            for j in 0..i {
                y[i] -= self.lu[i * n + j] * y[j];
            }
        }
        for i in (0..n).rev() {
            for j in i + 1..n {
                y[i] -= self.lu[i * n + j] * y[j];
            }
            y[i] /= self.lu[i * n + i];
        }
        rhs.copy_from_slice(&y);
        Ok(())
    }
}
