//! The cellmech domain layer.
pub mod units;
