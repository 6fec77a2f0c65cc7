//! # cellmech: mechanical tests on single living cells
//!
//! The domain layer over the `cellmech-fem` engine. Layers, each importing only those
//! below it (see `docs/architecture.md`):
//!
//! ```text
//! scenario/ (TOML files)  ─┐
//! experiment (cell + protocol as a value) ─► protocol/ (steps, tools, results)
//!                                           └► cell/ (cell models and their parameters)
//!                                                 └► model/ (ModelSpec → engine problem)
//! run, output, plots (observers that write as increments converge)  ─► model/
//! param, units (declared parameters, quantities with units)
//! ```
//!
//! Internal units: µm, nN, kPa (= nN/µm²), s; see [`units`].

pub mod analysis;
pub mod bench;
pub mod cell;
pub mod examples;
pub mod experiment;
pub mod fit;
pub mod mesh_file;
pub mod model;
pub mod output;
pub mod param;
pub mod plots;
pub mod protocol;
pub mod run;
pub mod scenario;
pub mod study;
pub mod units;

/// The README's Rust snippet, compiled and run as a doc test.
#[doc = include_str!("../../../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
