//! # cellmech: mechanical tests on single living cells
//!
//! The domain layer over the `cellmech-fem` engine. Data flow:
//! scenario file ([`scenario`]) → model ([`model`]) → engine problem and steps →
//! [`run`] (observers write [`output`]s as increments converge) → summary.
//!
//! Internal units: µm, nN, kPa (= nN/µm²), s; see [`units`].

pub mod bench;
pub mod cell;
pub mod examples;
pub mod mesh_file;
pub mod model;
pub mod output;
pub mod param;
pub mod plots;
pub mod protocol;
pub mod run;
pub mod scenario;
pub mod units;
