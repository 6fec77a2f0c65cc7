//! Verification tools shared by the tests of every crate: a finite-difference harness for
//! energies, residuals and tangents ([`tangent`]), closed-form references for the
//! continuum law ([`analytic`]) and for indentation of an elastic half-space by rigid tips
//! ([`contact`]: Hertz, Sneddon). Public (not `cfg(test)`) so that other crates' tests use
//! the same oracle.

pub mod analytic;
pub mod contact;
pub mod tangent;
