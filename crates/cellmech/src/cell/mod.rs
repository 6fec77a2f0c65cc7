//! Cell models: one folder per model ([`suspended`], [`adherent`]), each with
//! its declared parameters (`params.rs`: defaults, units, ranges, sources), validation,
//! geometry and builder. A builder turns its parameters into a [`BuiltCell`]: the model
//! parts every cellmech model is made of ([`crate::model::ModelSpec`] without tools or
//! steps) plus what a protocol needs to know about the cell (its size, its test axis, its
//! surface, its supports). Nothing here knows about protocols or scenario files.

pub mod adherent;
pub mod fa_plaque;
pub mod solver_settings;
pub mod suspended;
pub(crate) mod vec3;

pub use solver_settings::SolverSettings;
pub use suspended::{
    cytoskeleton, geometry, CellGeometryError, FaOrientation, GeometryReport, IfAnchorRule,
    MeshResolution, MicrotubulePath, SuspendedCellGeometry, SuspendedCellParams,
};

use crate::model::ModelSpec;

/// A cell model ready for a protocol.
#[derive(Debug, Clone)]
pub struct BuiltCell {
    /// Mesh, materials and structures; supports and shape probes set, no tools or steps.
    pub model: ModelSpec,
    /// What the cell is, for outputs and summaries.
    pub description: CellDescription,
    /// Node set of the outer surface (contact candidates for tools).
    pub surface_set: String,
    /// The outer surface's quad faces (free surface only; with a local refinement, its leaf
    /// faces): where a face contact acts.
    pub surface_faces: Vec<[usize; 4]>,
    /// The first analysis step every protocol starts with (the prestress, held by the
    /// model's minimal supports).
    pub prestress: crate::model::StepSpec,
    /// The supports kept once tools hold the cell: they remove the rotation about the test
    /// axis that bonded patches near the axis can leave free, and carry (almost) no load.
    pub rotation_hold: Vec<(String, [bool; 3])>,
    /// The base control of every step (viscous stabilisation, iteration method): the
    /// prestress and every protocol step start from it and set their increments.
    pub step_control: cellmech_fem::solve::StepControl,
    /// Whether the cell's `solver.iteration` is `auto`: a protocol then sets BFGS in the
    /// loading steps it was measured to pay in (full Newton stays in `step_control`).
    pub auto_iteration: bool,
    /// BFGS as the cell iterates by it (`solver.bfgs_updates`), for the protocols' `auto`.
    pub bfgs: cellmech_fem::solve::IterationMethod,
    /// The point where an indenter may press (µm) and the surface's outward normal there:
    /// the site the mesh is refined at (`None`: the cell has none).
    pub site: Option<([f64; 3], [f64; 3])>,
}

/// What is known about a built cell, for outputs and summaries (`summary.json`).
#[derive(Debug, Clone, serde::Serialize)]
pub struct CellDescription {
    /// Model name (`suspended`).
    pub model: String,
    /// Seed of every random choice.
    pub seed: u64,
    /// Cell diameter D (µm): the length that normalises the protocols' strains.
    pub cell_diameter: f64,
    /// Nucleus diameter (µm).
    pub nucleus_diameter: f64,
    /// Axis of the test (0 = x).
    pub axis: usize,
    /// Resolved parameters, echoed.
    pub params: serde_json::Value,
    /// Materials, echoed.
    pub materials: serde_json::Value,
    /// Geometry quality (snap distances, MT clearance, IF tangency).
    pub geometry: serde_json::Value,
}
