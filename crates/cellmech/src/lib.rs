//! The cellmech domain layer.
