//! A dense reference solver.

use nalgebra::{DMatrix, DVector, Dyn, LU};

use super::{FactorInfo, FactorMethod, LinSolveError, LinearSolver, SparsityPattern};

/// Dense LU with partial pivoting (nalgebra): an independent reference solver for small
/// systems and tests (O(n³) time, O(n²) memory; use the sparse solver for real models).
/// It also reports the inertia of the symmetric matrix (number of negative eigenvalues,
/// from a symmetric eigen-decomposition), which buckling tests use to detect the loss of
/// stability.
#[derive(Debug, Default, Clone)]
pub struct DenseSolver {
    pattern: Option<SparsityPattern>,
    lu: Option<LU<f64, Dyn, Dyn>>,
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
        let mut a = DMatrix::zeros(p.n, p.n);
        for c in 0..p.n {
            for k in p.col_ptr[c]..p.col_ptr[c + 1] {
                a[(p.row_idx[k], c)] = values[k];
                a[(c, p.row_idx[k])] = values[k];
            }
        }
        let negative = a
            .clone()
            .symmetric_eigenvalues()
            .iter()
            .filter(|&&l| l < 0.0)
            .count();
        let lu = a.lu();
        if !lu.is_invertible() {
            return Err(LinSolveError::Singular("dense LU: zero pivot".into()));
        }
        self.lu = Some(lu);
        Ok(FactorInfo {
            method: FactorMethod::Lu,
            negative_pivots: Some(negative),
        })
    }

    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinSolveError> {
        let lu = self
            .lu
            .as_ref()
            .ok_or(LinSolveError::Usage("not factorised".into()))?;
        let x = lu
            .solve(&DVector::from_column_slice(rhs))
            .ok_or(LinSolveError::Singular("dense LU".into()))?;
        rhs.copy_from_slice(x.as_slice());
        Ok(())
    }
}
