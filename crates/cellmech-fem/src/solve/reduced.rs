//! The linear system under linear constraints: which pattern the solver factorises and
//! which DOFs it must hold (free functions, so that [`super::Problem`]'s construction and
//! its Newton iterations share them without importing each other).

use crate::assembly::Assembler;
use crate::constraint::condense::Condensation;
use crate::constraint::LinearConstraints;
use crate::linsolve::SparsityPattern;

/// DOFs the solver must hold because nothing couples them, once constraints are eliminated:
/// a slave is never held (its row is the identity and its value follows the masters); a
/// master is coupled as soon as one of its slaves is.
pub(super) fn reduce_untouched(constraints: &LinearConstraints, untouched: &mut [bool]) {
    let mut coupled = vec![false; untouched.len()];
    for (c, &s) in constraints.slaves().iter().enumerate() {
        if !untouched[s] {
            for &m in constraints.constraint(c).0 {
                coupled[m] = true;
            }
        }
    }
    for (d, held) in untouched.iter_mut().enumerate() {
        if constraints.is_slave(d) || coupled[d] {
            *held = false;
        }
    }
}

/// The pattern the linear solver factorises: the reduced one when constraints are
/// condensed, else the assembler's (a free function so that callers can borrow other
/// fields of [`Problem`] mutably at the same time).
pub(super) fn solver_pattern<'a>(
    condensation: &'a Option<Condensation>,
    assembler: &'a Assembler,
) -> &'a SparsityPattern {
    match condensation {
        Some(c) => c.reduced_pattern(),
        None => assembler.pattern(),
    }
}
