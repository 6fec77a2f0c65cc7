//! An [`Analysis`]: a model with its title and provenance, ready to run. What a scenario
//! file resolves into and what an experiment builds; the run and the writers read it.

use serde::Serialize;

use crate::model::ModelSpec;

/// A model with its title and provenance, ready to run: what a scenario file resolves into
/// and what an [`crate::experiment::Experiment`] builds.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// Title for outputs and plots.
    pub title: String,
    /// Where it came from (a scenario path, `<built-in: name>` or `<library>`).
    pub origin: String,
    /// The model: mesh, materials, structures, tools, steps, outputs.
    pub model: ModelSpec,
    /// The built-in cell model and its experiment, when there is one.
    pub cell: Option<CellStudy>,
    /// The scenario file as parsed, for echoing into `summary.json` (empty from Rust).
    pub echo: toml::Table,
}

/// A cell model and the protocol run on it, for outputs and summaries.
#[derive(Debug, Clone, Serialize)]
pub struct CellStudy {
    /// The cell.
    #[serde(flatten)]
    pub description: crate::cell::CellDescription,
    /// The experiment's plan (typed handles to its tools and steps), when there is one.
    pub protocol: Option<crate::protocol::ProtocolPlan>,
}
