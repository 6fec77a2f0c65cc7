//! Vector norms over the free or the prescribed DOFs, shared by the Newton loop and the
//! step driver.

/// Euclidean norm of the entries of `v` whose `mask` is `want` (e.g. `false`: the free
/// DOFs when `mask` marks the prescribed ones).
pub(super) fn norm_where(v: &[f64], mask: &[bool], want: bool) -> f64 {
    v.iter()
        .zip(mask)
        .filter(|(_, &m)| m == want)
        .map(|(x, _)| x * x)
        .sum::<f64>()
        .sqrt()
}
