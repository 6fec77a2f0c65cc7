//! Verification tools shared by the tests of every crate: a finite-difference harness for
//! energies, residuals and tangents ([`tangent`]) and closed-form references for the
//! continuum law ([`analytic`]). Public (not `cfg(test)`) so that other crates' tests use
//! the same oracle.

pub mod analytic;
pub mod tangent;
