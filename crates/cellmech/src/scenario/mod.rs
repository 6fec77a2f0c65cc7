//! Scenarios: the TOML file a user writes, resolved into a complete, validated description
//! of a model and its analysis steps in internal units.
//!
//! Two levels, as in FEBio/ripgrep: [`file::ScenarioFile`] is the raw file (serde, unknown
//! keys rejected, quantities with units), [`Scenario`] the total, checked result.

pub mod cell;
mod context;
pub mod file;
mod resolve;
pub mod structures;
pub mod tools;

use std::path::{Path, PathBuf};

use cellmech_fem::element::hex8::Hex8Formulation;
use cellmech_fem::material::NeoHookean;
use cellmech_fem::mesh::Mesh;
use cellmech_fem::solve::StepControl;

pub use resolve::resolve;

/// A validated scenario in internal units (µm, nN, kPa).
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Title for outputs and plots.
    pub title: String,
    /// Where the scenario came from (a path or `<built-in: name>`).
    pub origin: String,
    /// The mesh with its element and node sets.
    pub mesh: Mesh,
    /// Material of every element set, in mesh block order.
    pub materials: Vec<MaterialAssignment>,
    /// Filaments, membranes and family switches (see [`structures`]).
    pub structures: structures::StructuresSpec,
    /// Analysis steps in order.
    pub steps: Vec<StepSpec>,
    /// Output requests.
    pub output: OutputSpec,
    /// Rigid tools.
    pub tools: Vec<tools::ToolSpec>,
    /// The built-in cell model and experiment, when the scenario has `[cell]`.
    pub cell: Option<cell::CellStudy>,
    /// The scenario file as parsed, for echoing into `summary.json`.
    pub echo: toml::Table,
}

/// The law of one element set.
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialAssignment {
    /// Element set.
    pub element_set: String,
    /// Neo-Hookean parameters (kPa).
    pub law: NeoHookean,
    /// Element formulation.
    pub formulation: Hex8Formulation,
}

/// One analysis step on node sets.
#[derive(Debug, Clone, PartialEq)]
pub struct StepSpec {
    /// Step name.
    pub name: String,
    /// Increment control and convergence criteria.
    pub control: StepControl,
    /// Node sets held in place, with the components held.
    pub fixes: Vec<(String, [bool; 3])>,
    /// Prescribed displacement changes over the step: node set, component, value (µm).
    pub displacements: Vec<(String, usize, f64)>,
    /// Total forces at step end: node set, component, value (nN).
    pub forces: Vec<(String, usize, f64)>,
    /// Tool motions over the step (tools not listed hold).
    pub tools: Vec<tools::ToolMotion>,
}

/// Output requests.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputSpec {
    /// Force–displacement curves.
    pub curves: Vec<CurveSpec>,
    /// VTU frame every this many converged increments (0: step ends only).
    pub vtk_every: usize,
    /// Plot file format.
    pub plot_format: PlotFormat,
}

/// A reaction-force vs displacement curve of one node set and component.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveSpec {
    /// Column prefix.
    pub name: String,
    /// Node set.
    pub node_set: String,
    /// Component 0, 1, 2 (x, y, z).
    pub component: usize,
    /// +1, or -1 to report the reaction with the opposite sign.
    pub sign: f64,
}

/// Plot file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlotFormat {
    /// Portable Network Graphics.
    Png,
    /// Scalable Vector Graphics.
    Svg,
}

impl PlotFormat {
    /// File extension.
    pub fn extension(self) -> &'static str {
        match self {
            PlotFormat::Png => "png",
            PlotFormat::Svg => "svg",
        }
    }
}

/// A scenario that could not be read or is inconsistent. Says which file, which line and
/// key where known, what was expected and what was found.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The file could not be read.
    #[error("{path}: cannot read the scenario: {error}")]
    Read {
        /// Scenario path.
        path: String,
        /// The I/O error.
        error: std::io::Error,
    },
    /// The TOML is malformed, has unknown keys, or a value of the wrong form or unit.
    #[error("{path}: {message}")]
    Parse {
        /// Scenario path.
        path: String,
        /// The parser's message (with line and column).
        message: String,
    },
    /// A value is out of range or refers to something that does not exist.
    #[error("{path}{}: `{key}`: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Invalid {
        /// Scenario path.
        path: String,
        /// 1-based line of the key, where known.
        line: Option<usize>,
        /// The key (dotted path).
        key: String,
        /// What was expected and what was found.
        message: String,
    },
    /// The mesh file could not be read.
    #[error("{path}: mesh: {message}")]
    Mesh {
        /// Scenario path.
        path: String,
        /// What went wrong (names the mesh file and its line).
        message: String,
    },
}

/// Reads, parses and resolves a scenario file. Relative mesh paths are relative to it.
pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
    let text = std::fs::read_to_string(path).map_err(|error| ScenarioError::Read {
        path: path.display().to_string(),
        error,
    })?;
    let base = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    parse(&text, &path.display().to_string(), &base)
}

/// Parses and resolves scenario text; `origin` names it in messages, `base_dir` anchors
/// relative mesh paths.
pub fn parse(text: &str, origin: &str, base_dir: &Path) -> Result<Scenario, ScenarioError> {
    let raw: file::ScenarioFile = toml::from_str(text).map_err(|e| ScenarioError::Parse {
        path: origin.into(),
        message: e.to_string(),
    })?;
    let echo: toml::Table = toml::from_str(text).map_err(|e| ScenarioError::Parse {
        path: origin.into(),
        message: e.to_string(),
    })?;
    resolve(raw, echo, text, origin, base_dir)
}
