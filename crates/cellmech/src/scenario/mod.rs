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

pub use crate::analysis::{Analysis, CellStudy};
pub use crate::model::{
    CurveSpec, MaterialAssignment, ModelSpec, OutputSpec, PlotFormat, ShapeProbeSpec, StepSpec,
};

pub use resolve::resolve;

/// A validated scenario in internal units (µm, nN, kPa): an [`Analysis`] ready to run.
pub type Scenario = crate::analysis::Analysis;

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

/// Adds "did you mean" to toml's "unknown field `x`, expected one of `a`, `b`" message.
fn with_suggestion(message: String) -> String {
    let Some(rest) = message.split("unknown field `").nth(1) else {
        return message;
    };
    let Some((unknown, expected)) = rest.split_once('`') else {
        return message;
    };
    let candidates: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
    match crate::param::suggestion(candidates.iter().copied(), unknown) {
        Some(k) => format!("{}\ndid you mean `{k}`?", message.trim_end()),
        None => message,
    }
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
        message: with_suggestion(e.to_string()),
    })?;
    let echo: toml::Table = toml::from_str(text).map_err(|e| ScenarioError::Parse {
        path: origin.into(),
        message: e.to_string(),
    })?;
    resolve(raw, echo, text, origin, base_dir)
}
