//! The cellmech domain layer.
pub mod cell;
pub mod units;
