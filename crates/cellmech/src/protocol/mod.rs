//! Protocols: one file per virtual experiment. A protocol turns a [`BuiltCell`] plus its
//! settings (declared parameters, see each file's table) into the model's tools and steps
//! and a [`ProtocolPlan`] that refers to what it placed by typed handles (the moving tool,
//! the reference step, the loading steps), from which [`results`] derives the test's own
//! curve. Nothing here parses files.

pub mod micropipette_tension;
pub mod microplate_compression;
pub mod results;

use cellmech_fem::contact::ContactKind;

use crate::cell::BuiltCell;
use crate::model::tools::{default_penalty, default_tolerance, ForceTarget, ToolMotion, ToolSpec};
use crate::model::StepSpec;
use crate::param::{ParamTable, ParamValues};

pub use micropipette_tension::MicropipetteTension;
pub use microplate_compression::MicroplateCompression;

/// A virtual experiment on a cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Protocol {
    /// Only the prestress step: the free cell finds its prestressed equilibrium.
    Prestress,
    /// Two micropipettes hold the cell's poles and pull it apart.
    MicropipetteTension(MicropipetteTension),
    /// Two parallel plates compress the cell.
    MicroplateCompression(MicroplateCompression),
}

/// The `kind` names of the protocols, in documentation order.
pub const KINDS: [&str; 3] = [
    "micropipette-tension",
    "microplate-compression",
    "prestress",
];

/// The parameter table of each protocol that has parameters.
pub const TABLES: [&ParamTable; 2] = [
    &micropipette_tension::MICROPIPETTE_TENSION,
    &microplate_compression::MICROPLATE_COMPRESSION,
];

/// The prestress protocol has no parameters.
pub const PRESTRESS: ParamTable = ParamTable {
    name: "prestress",
    section: "protocol",
    params: &[],
};

impl Protocol {
    /// The parameter table of the protocol of kind `kind` (`None`: unknown kind).
    pub fn table(kind: &str) -> Option<&'static ParamTable> {
        match kind {
            "micropipette-tension" => Some(&micropipette_tension::MICROPIPETTE_TENSION),
            "microplate-compression" => Some(&microplate_compression::MICROPLATE_COMPRESSION),
            "prestress" => Some(&PRESTRESS),
            _ => None,
        }
    }

    /// The protocol of kind `kind` from resolved values of its table.
    pub fn from_values(kind: &str, values: &ParamValues) -> Option<Protocol> {
        Some(match kind {
            "micropipette-tension" => {
                Protocol::MicropipetteTension(MicropipetteTension::from_values(values))
            }
            "microplate-compression" => {
                Protocol::MicroplateCompression(MicroplateCompression::from_values(values))
            }
            "prestress" => Protocol::Prestress,
            _ => return None,
        })
    }

    /// The protocol's `kind` name.
    pub fn kind(&self) -> &'static str {
        match self {
            Protocol::Prestress => "prestress",
            Protocol::MicropipetteTension(_) => "micropipette-tension",
            Protocol::MicroplateCompression(_) => "microplate-compression",
        }
    }

    /// Adds the protocol's node sets, tools and steps to `cell.model` (which must have none
    /// yet) and returns the plan. The error names the parameter and says what was expected.
    pub fn apply(&self, cell: &mut BuiltCell) -> Result<ProtocolPlan, ProtocolError> {
        cell.model.steps.push(cell.prestress.clone());
        match self {
            Protocol::Prestress => Ok(ProtocolPlan::Prestress),
            Protocol::MicropipetteTension(p) => p.apply(cell),
            Protocol::MicroplateCompression(p) => p.apply(cell),
        }
    }
}

/// A protocol setting that does not fit the cell.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct ProtocolError {
    /// The parameter's key in the protocol's table.
    pub key: &'static str,
    /// What was expected and what was found.
    pub message: String,
}

/// A tool placed by a protocol: its index in the model's tools and its name.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct ToolHandle {
    /// Index in [`crate::model::ModelSpec::tools`].
    pub index: usize,
    /// Name (the prefix of its curve columns).
    pub name: String,
}

impl ToolHandle {
    /// The `curve.csv` column of the force the tool exerts on the body along `axis`.
    pub fn force_column(&self, axis: usize) -> String {
        cellmech_fem::contact::scalar_name(
            &self.name,
            cellmech_fem::contact::ToolScalar::Force(axis),
        )
    }

    /// The `curve.csv` column of the tool's displacement along `axis`.
    pub fn displacement_column(&self, axis: usize) -> String {
        cellmech_fem::contact::scalar_name(
            &self.name,
            cellmech_fem::contact::ToolScalar::Displacement(axis),
        )
    }
}

/// What a protocol placed, by typed handles: enough to derive its results.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ProtocolPlan {
    /// Prestress only.
    Prestress,
    /// Micropipette tension along the cell's test axis.
    MicropipetteTension {
        /// The moving pipette.
        moving_tool: ToolHandle,
        /// Step that ends in the unloaded reference state.
        reference_step: usize,
        /// Step that stretches.
        stretch_step: usize,
        /// End elongation (µm).
        elongation: f64,
        /// Pipette radius (µm).
        pipette_radius: f64,
    },
    /// Microplate compression along the cell's test axis.
    MicroplateCompression {
        /// The moving plate.
        moving_tool: ToolHandle,
        /// Step that ends with the plates touching.
        contact_step: usize,
        /// Compression steps, in order, with their target deformation of the diameter.
        deformations: Vec<(usize, f64)>,
    },
}

/// Places two bonded tools of the given shapes at the two poles of the cell along its test
/// axis (node sets `pole_minus`, `pole_plus`: surface nodes beyond half the radius).
pub(crate) fn place_pole_tools(
    cell: &mut BuiltCell,
    names: [&str; 2],
    shapes: [cellmech_fem::contact::ToolShape; 2],
) -> [ToolHandle; 2] {
    let axis = cell.description.axis;
    let r = 0.5 * cell.description.cell_diameter;
    let mesh = &mut cell.model.mesh;
    let surface = mesh
        .node_sets
        .get(&cell.surface_set)
        .cloned()
        .unwrap_or_default();
    for (name, side) in [("pole_minus", -1.0), ("pole_plus", 1.0)] {
        let nodes: Vec<usize> = surface
            .iter()
            .copied()
            .filter(|&n| mesh.nodes[n][axis] * side > 0.5 * r)
            .collect();
        mesh.insert_node_set(name, nodes);
    }
    let mut handles = Vec::new();
    for ((name, shape), set) in names.iter().zip(shapes).zip(["pole_minus", "pole_plus"]) {
        let nodes = &cell.model.mesh.node_sets[set];
        handles.push(ToolHandle {
            index: cell.model.tools.len(),
            name: name.to_string(),
        });
        cell.model.tools.push(ToolSpec {
            name: name.to_string(),
            shape,
            kind: ContactKind::Bonded,
            node_set: set.into(),
            penalty: default_penalty(&cell.model.materials, &cell.model.mesh, nodes),
            tolerance: default_tolerance(&cell.model.mesh),
        });
    }
    let moving = handles.pop().expect("two tools");
    let fixed = handles.pop().expect("two tools");
    [fixed, moving]
}

/// A tool's move along the cell's test axis over a step, optionally until its force
/// reaches `until` (tolerance 5 % of `contact_force`).
pub(crate) fn axial_motion(
    tool: &ToolHandle,
    axis: usize,
    distance: f64,
    until: Option<f64>,
    contact_force: f64,
) -> ToolMotion {
    let mut movement = [0.0; 3];
    movement[axis] = distance;
    ToolMotion {
        tool: tool.name.clone(),
        movement,
        until_force: until.map(|value| ForceTarget {
            value,
            tolerance: 0.05 * contact_force,
        }),
    }
}

/// A loading step with the given supports and tool motions.
pub(crate) fn loading_step(
    name: &str,
    control: cellmech_fem::solve::StepControl,
    fixes: &[(String, [bool; 3])],
    tools: Vec<ToolMotion>,
) -> StepSpec {
    StepSpec {
        name: name.into(),
        control,
        fixes: fixes.to_vec(),
        displacements: Vec::new(),
        forces: Vec::new(),
        tools,
    }
}
