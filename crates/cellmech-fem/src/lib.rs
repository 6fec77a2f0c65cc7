//! # cellmech-fem: the finite-element engine
//!
//! Data flow: [`mesh::Mesh`] → [`dof::DofMap`] → element kernels ([`element`]) wrapped as
//! [`term::Term`]s → [`assembly::Assembler`] (parallel, pattern built once) →
//! [`linsolve::LinearSolver`] → [`solve`] (Newton–Raphson, load stepping with cutback).
//!
//! Internal units: µm, nN, kPa (= nN/µm²), s. The engine knows nothing about cells.

pub mod assembly;
pub mod constraint;
pub mod contact;
pub mod continuum;
pub mod dof;
pub mod element;
pub mod linsolve;
pub mod material;
pub mod math;
pub mod mesh;
pub mod rezone;
pub mod solve;
pub mod term;
pub mod verify;
