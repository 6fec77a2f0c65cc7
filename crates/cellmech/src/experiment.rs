//! An [`Experiment`]: a cell model with a protocol, as a value that Rust code builds, varies
//! and runs. The scenario files (`[cell]` + `[protocol]`) and the CLI are thin layers over
//! the same pieces; a study is a list of experiments.
//!
//! ```no_run
//! use cellmech::experiment::{CellModel, Experiment};
//! use cellmech::protocol::{MicropipetteTension, Protocol};
//!
//! let mut cell = cellmech::cell::suspended::SuspendedCell::default();
//! cell.components.microtubules = false; // the "−MT" disruption model
//! let experiment = Experiment::new(
//!     CellModel::Suspended(cell),
//!     Protocol::MicropipetteTension(MicropipetteTension::default()),
//! );
//! let result = experiment.run(std::path::Path::new("out/no-mt"))?;
//! println!("{:.2} nN", result.last_force_nn().unwrap_or(f64::NAN));
//! # Ok::<(), cellmech::experiment::ExperimentError>(())
//! ```

use std::path::Path;

use cellmech_fem::solve::{NullObserver, Observer};

use crate::analysis::{Analysis, CellStudy};
use crate::cell::adherent::AdherentCell;
use crate::cell::suspended::{CellModelError, SuspendedCell};
use crate::cell::BuiltCell;
use crate::model::OutputSpec;
use crate::protocol::results::ProtocolResults;
use crate::protocol::{Protocol, ProtocolError};
use crate::run::{RunError, RunSummary};

/// The cell models.
#[derive(Debug, Clone, PartialEq)]
pub enum CellModel {
    /// The suspended bendo-tensegrity cell (`cell::suspended`).
    Suspended(SuspendedCell),
    /// The adherent bendo-tensegrity cell (`cell::adherent`).
    Adherent(AdherentCell),
}

impl CellModel {
    /// Builds the cell's model parts.
    pub fn build(&self) -> Result<BuiltCell, CellModelError> {
        match self {
            CellModel::Suspended(c) => c.build(),
            CellModel::Adherent(c) => c.build(),
        }
    }

    /// Builds the cell for `protocol`: an adherent cell is refined at the protocol's
    /// indentation site, a suspended one under the protocol's tools
    /// ([`SuspendedCell::with_tool_refinement`]).
    pub fn build_for(&self, protocol: &Protocol) -> Result<BuiltCell, CellModelError> {
        match (self, protocol.indentation_site()) {
            (CellModel::Adherent(c), Some(site)) => {
                let mut c = c.clone();
                c.site = Some(site);
                c.build()
            }
            (CellModel::Suspended(c), _) => {
                c.with_tool_refinement(protocol.pole_refinement()).build()
            }
            _ => self.build(),
        }
    }
}

impl From<AdherentCell> for CellModel {
    fn from(cell: AdherentCell) -> Self {
        CellModel::Adherent(cell)
    }
}

impl From<SuspendedCell> for CellModel {
    fn from(cell: SuspendedCell) -> Self {
        CellModel::Suspended(cell)
    }
}

/// A cell model, a protocol and the outputs wanted.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiment {
    /// Title for outputs and plots.
    pub title: String,
    /// The cell.
    pub cell: CellModel,
    /// The virtual experiment.
    pub protocol: Protocol,
    /// Output requests (extra curves, VTU frequency, plot format).
    pub output: OutputSpec,
}

/// Why an experiment could not be built or run.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// The cell could not be built.
    #[error("cell: {0}")]
    Cell(#[from] CellModelError),
    /// The protocol does not fit the cell.
    #[error("protocol: `{}`: {}", .0.key, .0.message)]
    Protocol(#[from] ProtocolError),
    /// The run failed (model, outputs, or an analysis that stopped early: every converged
    /// increment is on disk).
    #[error(transparent)]
    Run(#[from] RunError),
}

/// What a run of an experiment gives back.
#[derive(Debug, Clone)]
pub struct ExperimentResult {
    /// Everything written to `summary.json`.
    pub summary: RunSummary,
}

impl ExperimentResult {
    /// The protocol's results (test curve, reference state, reported points).
    pub fn protocol(&self) -> Option<&ProtocolResults> {
        self.summary.protocol.as_ref()
    }

    /// Force on the moving tool at the last point of the test curve (nN).
    pub fn last_force_nn(&self) -> Option<f64> {
        self.protocol()?.last.map(|p| p.force_nn)
    }
}

impl Experiment {
    /// An experiment with default outputs.
    pub fn new(cell: impl Into<CellModel>, protocol: Protocol) -> Self {
        let protocol_name = protocol.kind();
        Experiment {
            title: format!("cellmech experiment: {protocol_name}"),
            cell: cell.into(),
            protocol,
            output: OutputSpec::default(),
        }
    }

    /// Builds the cell, applies the protocol and returns the analysis ready to run.
    pub fn analysis(&self) -> Result<Analysis, ExperimentError> {
        let mut cell = self.cell.build_for(&self.protocol)?;
        let plan = self.protocol.apply(&mut cell)?;
        // The protocol's own reaction curves (its handles index them) come first.
        let protocol_curves = std::mem::take(&mut cell.model.output.curves);
        cell.model.output = self.output.clone();
        cell.model.output.curves.splice(0..0, protocol_curves);
        Ok(Analysis {
            title: self.title.clone(),
            origin: "<library>".into(),
            model: cell.model,
            cell: Some(CellStudy {
                description: cell.description,
                protocol: Some(plan),
            }),
            echo: toml::Table::new(),
        })
    }

    /// Runs the experiment, writing every output into `out_dir` as increments converge.
    pub fn run(&self, out_dir: &Path) -> Result<ExperimentResult, ExperimentError> {
        self.run_with(out_dir, &mut NullObserver)
    }

    /// Runs with an extra observer of every solver event (e.g. a progress bar).
    pub fn run_with(
        &self,
        out_dir: &Path,
        observer: &mut dyn Observer,
    ) -> Result<ExperimentResult, ExperimentError> {
        let analysis = self.analysis()?;
        let summary = crate::run::run(&analysis, out_dir, observer)?;
        Ok(ExperimentResult { summary })
    }
}

/// Every declared parameter table: the cell models', then the protocols'.
pub fn parameter_tables() -> Vec<&'static crate::param::ParamTable> {
    let mut tables = vec![
        &crate::cell::suspended::params::SUSPENDED_CELL,
        &crate::cell::adherent::params::ADHERENT_CELL,
    ];
    tables.extend(crate::protocol::TABLES);
    tables
}

/// The text of `docs/parameters.md`: every table, generated (a test checks that the file
/// in `docs/` is this text; `CELLMECH_BLESS=1 cargo test` rewrites it).
pub fn parameters_markdown() -> String {
    let mut s = String::from(
        "# Parameters\n\n\
         Generated from the parameter tables in the code (`cellmech params NAME` prints one;\n\
         a test fails when this page and the code disagree). Quantities are written with\n\
         their unit; any unit of the same dimension is accepted (`\"500 Pa\"`, `\"0.5 kPa\"`).\n\
         \"spec\" means `shared/spec/cell-models.md`; \"choice\" a documented modelling or\n\
         numerical choice (see the model's page).\n",
    );
    for table in parameter_tables() {
        let scope = if table.section == "protocol" {
            format!("`[protocol]` with `kind = \"{}\"`", table.name)
        } else {
            format!("`[{}]` (`{}`)", table.section, table.name)
        };
        s.push_str(&format!(
            "\n## {}\n\n{scope}\n\n{}",
            table.name,
            table.markdown()
        ));
    }
    s
}
