//! Protocols: one file per virtual experiment. A protocol turns a [`BuiltCell`] plus its
//! settings (declared parameters, see each file's table) into the model's tools and steps
//! and a [`ProtocolPlan`] that refers to what it placed by typed handles (the moving tool,
//! the reference step, the loading steps), from which [`results`] derives the test's own
//! curve. Nothing here parses files.

pub mod afm_indentation;
pub mod apparent_modulus;
pub mod grip;
pub mod micropipette_tension;
pub mod microplate_compression;
pub mod results;

use cellmech_fem::contact::{ContactKind, ToolShape};
use cellmech_fem::solve::{Extrapolation, StepControl};

use crate::cell::BuiltCell;
use crate::model::tools::{default_penalty, default_tolerance, ForceTarget, ToolMotion, ToolSpec};
use crate::model::StepSpec;
use crate::param::{Bounds, ParamDef, ParamDefault, ParamKind, ParamTable, ParamValues};
use crate::units::Dimension;

pub use afm_indentation::{AfmIndentation, TipShape};
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
    /// An AFM tip indents the adherent cell.
    AfmIndentation(AfmIndentation),
}

/// The `kind` names of the protocols, in documentation order.
pub const KINDS: [&str; 4] = [
    "micropipette-tension",
    "microplate-compression",
    "afm-indentation",
    "prestress",
];

/// The parameter table of each protocol that has parameters.
pub const TABLES: [&ParamTable; 3] = [
    &micropipette_tension::MICROPIPETTE_TENSION,
    &microplate_compression::MICROPLATE_COMPRESSION,
    &afm_indentation::AFM_INDENTATION,
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
            "afm-indentation" => Some(&afm_indentation::AFM_INDENTATION),
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
            "afm-indentation" => Protocol::AfmIndentation(AfmIndentation::from_values(values)),
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
            Protocol::AfmIndentation(_) => "afm-indentation",
        }
    }

    /// Where the protocol indents the cell (the cell refines its mesh there), if it does.
    pub fn indentation_site(&self) -> Option<crate::cell::adherent::IndentationSite> {
        match self {
            Protocol::AfmIndentation(p) => Some(p.site),
            _ => None,
        }
    }

    /// The refinement a suspended cell's mesh gets under the protocol's tools (compression:
    /// under the plates), if any.
    pub fn pole_refinement(&self) -> Option<crate::cell::suspended::PoleRefinement> {
        match self {
            Protocol::MicroplateCompression(p) if p.refinement.levels > 0 => Some(p.refinement),
            _ => None,
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
            Protocol::AfmIndentation(p) => p.apply(cell),
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

    /// The `curve.csv` column of how deep the deepest watched body node lies inside the tool.
    pub fn deepest_node_inside_column(&self) -> String {
        cellmech_fem::contact::scalar_name(
            &self.name,
            cellmech_fem::contact::ToolScalar::DeepestWatchedNode,
        )
    }

    /// The `curve.csv` column of an indenter's contact radius (paraboloid or sphere).
    pub fn contact_radius_column(&self) -> String {
        cellmech_fem::contact::scalar_name(
            &self.name,
            cellmech_fem::contact::ToolScalar::ContactRadius,
        )
    }
}

/// A node set whose DOFs a protocol prescribes, with the reaction curve that reads its
/// force: the sum of the reactions on its DOFs along `component` (the curve request at
/// index `curve` of [`crate::model::OutputSpec::curves`]).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct NodeSetHandle {
    /// Index in [`crate::model::OutputSpec::curves`].
    pub curve: usize,
    /// Curve name (the prefix of its columns).
    pub name: String,
    /// The node set.
    pub node_set: String,
    /// The component the curve reads (the test axis).
    pub component: usize,
}

impl NodeSetHandle {
    /// The `curve.csv` columns (mean displacement, reaction sum) along its component.
    fn columns(&self, axis: usize) -> [String; 2] {
        debug_assert_eq!(axis, self.component, "a node-set curve reads one component");
        crate::model::curve_columns(&self.name, self.component)
    }
}

/// What holds one pole of the cell and measures the force there: a rigid tool with
/// contact, or a node set of prescribed DOFs (a geometric grip).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Holder {
    /// A rigid tool: its force is the tool's contact force.
    Tool(ToolHandle),
    /// Prescribed nodes: the force is the sum of their reactions.
    NodeSet(NodeSetHandle),
}

impl Holder {
    /// The `curve.csv` column of the force the holder exerts on the body along `axis`.
    pub fn force_column(&self, axis: usize) -> String {
        match self {
            Holder::Tool(t) => t.force_column(axis),
            Holder::NodeSet(n) => {
                let [_, force] = n.columns(axis);
                force
            }
        }
    }

    /// The `curve.csv` column of the holder's displacement along `axis` (the node set's
    /// mean displacement).
    pub fn displacement_column(&self, axis: usize) -> String {
        match self {
            Holder::Tool(t) => t.displacement_column(axis),
            Holder::NodeSet(n) => {
                let [displacement, _] = n.columns(axis);
                displacement
            }
        }
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
        /// What holds the moving pole: the moving pipette (contact grip) or its cap.
        moving: Holder,
        /// What holds the fixed pole.
        fixed: Holder,
        /// Step that ends in the unloaded reference state.
        reference_step: usize,
        /// Step that stretches.
        stretch_step: usize,
        /// End elongation (µm).
        elongation: f64,
        /// Pipette radius (µm).
        pipette_radius: f64,
        /// The geometric caps (`None` for the contact grip).
        caps: Option<grip::CapReport>,
    },
    /// Microplate compression along the cell's test axis.
    MicroplateCompression {
        /// The moving plate.
        moving_tool: ToolHandle,
        /// The plate that stays.
        fixed_tool: ToolHandle,
        /// Step that ends with the plates touching.
        contact_step: usize,
        /// Compression steps, in order, with their target deformation of the diameter.
        deformations: Vec<(usize, f64)>,
    },
    /// AFM indentation of the adherent cell along −z.
    AfmIndentation {
        /// The tip.
        tip: ToolHandle,
        /// Step that ends at first contact.
        contact_step: usize,
        /// Indentation steps, in order, with their target depth from first contact (µm).
        depths: Vec<(usize, f64)>,
        /// The retract step, if any.
        retract_step: Option<usize>,
        /// `apex`, `receptor` or `point`.
        site: String,
        /// The site on the undeformed dome (µm).
        site_point: [f64; 3],
        /// Tip shape.
        tip_shape: afm_indentation::TipShape,
        /// Tip radius (µm).
        tip_radius: f64,
        /// The apparent-modulus fit of the curve.
        fit: apparent_modulus::FitSettings,
        /// A watched mesh node (not a contact candidate) deeper inside the tip than this
        /// (µm) means the tip has passed between the surface nodes into the cell: the
        /// results report the first depth where that happens.
        pierce_tolerance: f64,
    },
}

/// The declared `contact_force` of the two-tool protocols.
impl ProtocolPlan {
    /// The step at whose end the test's reference state is reached (tension: the unloaded
    /// reference state; compression: first contact), if the protocol has one.
    pub fn reference_step(&self) -> Option<usize> {
        match self {
            ProtocolPlan::Prestress => None,
            ProtocolPlan::MicropipetteTension { reference_step, .. } => Some(*reference_step),
            ProtocolPlan::MicroplateCompression { contact_step, .. }
            | ProtocolPlan::AfmIndentation { contact_step, .. } => Some(*contact_step),
        }
    }
}

pub(crate) const CONTACT_FORCE: ParamDef = ParamDef {
    key: "contact_force",
    kind: ParamKind::Quantity(Dimension::Force),
    default: ParamDefault::Number(0.1),
    bounds: Bounds::POSITIVE,
    doc: "force on the moving tool that counts as touching in the approach",
    source: "choice (0.2 % of the tensile force at 6.3 µm)",
};

/// The declared `max_increment` of the two-tool protocols.
pub(crate) const MAX_INCREMENT: ParamDef = ParamDef {
    key: "max_increment",
    kind: ParamKind::Number,
    default: ParamDefault::Number(0.1),
    bounds: Bounds::new(0.0, false, 1.0, true),
    doc: "largest increment of the loading steps, fraction of the step",
    source: "choice (a curve point every 10 %)",
};

/// How the two-tool protocols establish contact before loading (`approach`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Approach {
    /// Each tool moves in until its smallest gap to the body is 0, one after the other: both
    /// touch, the cell is not deformed, and the reference state does not depend on how the
    /// approach is stepped.
    FirstContact,
    /// Both tools move in together until the moving one feels `contact_force`.
    ContactForce,
}

impl Approach {
    /// The keyword of the scenario file.
    pub fn from_word(word: &str) -> Self {
        match word {
            "contact-force" => Approach::ContactForce,
            _ => Approach::FirstContact,
        }
    }
}

/// The declared `approach` of the compression protocol.
pub(crate) const APPROACH: ParamDef = ParamDef {
    key: "approach",
    kind: ParamKind::Choice(&["first-contact", "contact-force"]),
    default: ParamDefault::Word("first-contact"),
    bounds: Bounds::ANY,
    doc: "how the tools reach the cell: `first-contact` moves each tool until its smallest gap to the cell is 0 (both touch, nothing deformed; independent of the stepping); `contact-force` moves both until the moving one feels `contact_force`",
    source: "spec (\"establish contact without deforming the cell\")",
};

/// Two bonded tools on the cell's poles along its test axis, after the common approach
/// step: what the two-tool protocols (tension, compression) build their own steps on.
pub(crate) struct PoleTest {
    /// The tool that stays (at −axis).
    pub fixed: ToolHandle,
    /// The tool that moves (at +axis).
    pub moving: ToolHandle,
    /// Step control of the loading steps.
    pub loading: StepControl,
    /// Supports kept once the tools hold the cell.
    pub hold: Vec<(String, [bool; 3])>,
    /// The cell's minimal supports.
    pub supports: Vec<(String, [bool; 3])>,
    /// Index of the approach step.
    pub approach_step: usize,
    axis: usize,
    contact_force: f64,
    /// The frictionless tools on the free filament nodes that follow the fixed and the
    /// moving tool (`<tool>_mt_nodes`), if any.
    companions: [Option<String>; 2],
}

/// The node set of the filament nodes only the filaments hold (interior MT nodes).
const FREE_FILAMENT_NODES: &str = "microtubule_interior";

impl PoleTest {
    /// Places the tools (`shape(center, normal)` for each pole, the normal pointing into the
    /// cell; node sets `pole_minus`, `pole_plus`: surface nodes beyond half the radius), with
    /// frictionless companions on the free MT nodes when `filament_contact`, and writes the
    /// approach, the supports still holding the cell: with [`Approach::FirstContact`] the
    /// moving tool (`approach`) and then the fixed one (`seat`) move in until their smallest
    /// gap to the cell is 0; with [`Approach::ContactForce`] both move in together (up to a
    /// quarter diameter each) until the moving one feels `contact_force`.
    pub fn approach(
        cell: &mut BuiltCell,
        names: [&str; 2],
        shape: impl Fn([f64; 3], [f64; 3]) -> ToolShape,
        approach: Approach,
        filament_contact: bool,
        contact_force: f64,
        max_increment: f64,
    ) -> Self {
        let axis = cell.description.axis;
        let r = 0.5 * cell.description.cell_diameter;
        let mesh = &mut cell.model.mesh;
        let surface = mesh
            .node_sets
            .get(&cell.surface_set)
            .cloned()
            .unwrap_or_default();
        let sides = [("pole_minus", -1.0), ("pole_plus", 1.0)];
        for (name, side) in sides {
            let nodes: Vec<usize> = surface
                .iter()
                .copied()
                .filter(|&n| mesh.nodes[n][axis] * side > 0.5 * r)
                .collect();
            mesh.insert_node_set(name, nodes);
        }
        let [fixed, moving] = std::array::from_fn(|k| {
            let (set, side) = sides[k];
            let (mut center, mut normal) = ([0.0; 3], [0.0; 3]);
            center[axis] = side * r;
            normal[axis] = -side;
            let nodes = &cell.model.mesh.node_sets[set];
            let handle = ToolHandle {
                index: cell.model.tools.len(),
                name: names[k].to_string(),
            };
            cell.model.tools.push(ToolSpec {
                name: names[k].to_string(),
                shape: shape(center, normal),
                kind: ContactKind::Bonded,
                node_set: set.into(),
                faces: Vec::new(),
                penalty: default_penalty(&cell.model.materials, &cell.model.mesh, nodes),
                tolerance: default_tolerance(&cell.model.mesh),
                curvature_tangent: Default::default(),
                aim: None,
                watch: Vec::new(),
            });
            handle
        });
        // Free filament nodes (the interior MT nodes, held only by their beams) meet the
        // tools too: frictionless companions that move with each tool.
        let free_nodes = cell
            .model
            .mesh
            .node_sets
            .get(FREE_FILAMENT_NODES)
            .filter(|set| !set.is_empty())
            .cloned();
        let companions = std::array::from_fn(|k| {
            let set = free_nodes.as_ref().filter(|_| filament_contact)?;
            let tool = &cell.model.tools[[&fixed, &moving][k].index];
            let companion = ToolSpec {
                name: format!("{}_mt_nodes", tool.name),
                kind: ContactKind::Frictionless,
                node_set: FREE_FILAMENT_NODES.into(),
                faces: Vec::new(),
                penalty: default_penalty(&cell.model.materials, &cell.model.mesh, set),
                ..tool.clone()
            };
            let name = companion.name.clone();
            cell.model.tools.push(companion);
            Some(name)
        });
        let test = PoleTest {
            fixed,
            moving,
            loading: StepControl {
                initial_increment: max_increment.min(0.1),
                max_increment,
                ..cell.step_control
            },
            hold: cell.rotation_hold.clone(),
            supports: cell.model.supports.clone(),
            approach_step: cell.model.steps.len(),
            axis,
            contact_force,
            companions,
        };
        let travel = 0.25 * cell.description.cell_diameter;
        match approach {
            Approach::ContactForce => {
                let step = test.step(
                    "approach",
                    true,
                    vec![
                        test.motion(&test.fixed, travel, None),
                        test.motion(&test.moving, -travel, Some(contact_force)),
                    ],
                );
                cell.model.steps.push(step);
                test
            }
            Approach::FirstContact => {
                // Each tool alone, the cell held by its supports: the moving tool in until its
                // smallest gap to the body is 0, then the fixed one. The gap is measured from
                // the body's committed position, so it falls linearly with the travel and the
                // stop is found in one or two increments; the body is not deformed.
                let tolerance = default_tolerance(&cell.model.mesh);
                let mut steps = Vec::new();
                for (name, tool, distance) in [
                    ("approach", &test.moving, -travel),
                    ("seat", &test.fixed, travel),
                ] {
                    let mut motion = test.motion(tool, distance, None);
                    motion.until_contact = Some(tolerance);
                    steps.push(test.step(name, true, vec![motion]));
                }
                cell.model.steps.extend(steps);
                PoleTest {
                    approach_step: cell.model.steps.len() - 1,
                    ..test
                }
            }
        }
    }

    /// A tool's move along the test axis over a step, optionally until its force reaches
    /// `until` (tolerance 5 % of `contact_force`).
    pub fn motion(&self, tool: &ToolHandle, distance: f64, until: Option<f64>) -> ToolMotion {
        let mut movement = [0.0; 3];
        movement[self.axis] = distance;
        ToolMotion {
            tool: tool.name.clone(),
            movement,
            until_force: until.map(|value| ForceTarget {
                value,
                tolerance: 0.05 * self.contact_force,
            }),
            until_contact: None,
        }
    }

    /// A loading step held by the minimal supports (`supported`) or only by the rotation hold.
    /// The companions of the moved tools make the same moves.
    pub fn step(&self, name: &str, supported: bool, mut tools: Vec<ToolMotion>) -> StepSpec {
        let handles = [&self.fixed, &self.moving];
        let follow: Vec<ToolMotion> = tools
            .iter()
            .filter_map(|m| {
                let k = handles.iter().position(|h| h.name == m.tool)?;
                let companion = self.companions[k].as_ref()?;
                Some(ToolMotion {
                    tool: companion.clone(),
                    movement: m.movement,
                    until_force: None,
                    until_contact: None,
                })
            })
            .collect();
        tools.extend(follow);
        StepSpec {
            name: name.into(),
            control: self.loading,
            fixes: if supported {
                &self.supports
            } else {
                &self.hold
            }
            .to_vec(),
            displacements: Vec::new(),
            forces: Vec::new(),
            tools,
        }
    }
}

/// The `extrapolation` choice of a protocol's table ("linear" or "none").
fn extrapolation(v: &ParamValues) -> Extrapolation {
    match v.word("extrapolation") {
        "none" => Extrapolation::None,
        _ => Extrapolation::Linear,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell::suspended::SuspendedCell;
    use cellmech_fem::solve::Activation;

    /// `cell` on a coarse mesh, with filaments tied to the gel, built and given `protocol`'s
    /// steps.
    fn compression_on_a_coarse_cell(
        mut cell: SuspendedCell,
        protocol: &Protocol,
    ) -> crate::cell::BuiltCell {
        cell.params.mesh.core_divisions = 4;
        cell.params.mesh.shell_layers = 2;
        cell.params.mesh.outer_layers = 2;
        let mut built = cell.build().unwrap();
        assert!(built.auto_iteration && !built.model.embedded.is_empty());
        protocol.apply(&mut built).unwrap();
        built
    }

    /// Every step of `built` iterates by BFGS where `bfgs_in_loading` and the step is a
    /// compression's loading step, by full Newton elsewhere, with the rotation bound `bound`.
    fn assert_compression_solver(
        built: &crate::cell::BuiltCell,
        bfgs_in_loading: bool,
        bound: f64,
        case: &str,
    ) {
        for step in &built.model.steps {
            let expected = if bfgs_in_loading && step.name.starts_with("compress-") {
                built.bfgs
            } else {
                cellmech_fem::solve::IterationMethod::Newton
            };
            let convergence = &step.control.convergence;
            assert_eq!(convergence.method, expected, "{case}: step {}", step.name);
            assert_eq!(
                convergence.max_rotation_step, bound,
                "{case}: step {}",
                step.name
            );
        }
    }

    /// Every step a protocol writes carries the cell's stabilisation setting (a step that
    /// forgot it would run without, silently).
    #[test]
    fn every_protocol_step_carries_the_cells_solver_settings() {
        for &kind in KINDS.iter() {
            let table = Protocol::table(kind).unwrap();
            for grip in ["cap", "contact"] {
                #[allow(unused_mut)]
                let mut values = crate::param::ParamValues::defaults(table);
                if kind == "micropipette-tension" {
                    values
                        .set(table, "grip", crate::param::ParamValue::Word(grip.into()))
                        .unwrap();
                }
                let protocol = Protocol::from_values(kind, &values).unwrap();
                let mut built = if kind == "afm-indentation" {
                    let mut cell = crate::cell::adherent::AdherentCell::default();
                    cell.params.mesh.shell_layers = 2;
                    cell.params.mesh.outer_layers = 2;
                    cell.params.refinement.element_size = 0.5;
                    cell.params.refinement.grading = 1.0;
                    cell.site = protocol.indentation_site();
                    cell.solver.residual_tolerance = 2e-7;
                    cell.solver.energy_tolerance = 3e-11;
                    cell.build().unwrap()
                } else {
                    let mut cell = SuspendedCell::default();
                    cell.params.mesh.core_divisions = 4;
                    cell.params.mesh.shell_layers = 2;
                    cell.params.mesh.outer_layers = 2;
                    cell.solver.residual_tolerance = 2e-7;
                    cell.solver.energy_tolerance = 3e-11;
                    cell.build().unwrap()
                };
                assert_eq!(
                    built.step_control.stabilization.map(|s| s.activation),
                    Some(Activation::OnDifficulty)
                );
                protocol.apply(&mut built).unwrap();
                assert_eq!(
                    built.prestress.control.stabilization,
                    built.step_control.stabilization
                );
                // `solver.iteration = "auto"` (the default): full Newton, except BFGS in the
                // compression's loading steps.
                use cellmech_fem::solve::IterationMethod;
                assert!(built.auto_iteration);
                assert_eq!(
                    built.step_control.convergence.method,
                    IterationMethod::Newton
                );
                for step in std::iter::once(&built.prestress).chain(&built.model.steps) {
                    assert_eq!(
                        step.control.stabilization, built.step_control.stabilization,
                        "{kind} ({grip}): step {}",
                        step.name
                    );
                    // `solver.residual_tolerance` / `energy_tolerance` reach every step.
                    let c = &step.control.convergence;
                    assert_eq!(
                        (c.residual_tolerance, c.energy_tolerance),
                        (2e-7, 3e-11),
                        "{kind} ({grip}): step {}",
                        step.name
                    );
                    // `solver.bfgs_updates`: 20 updates before a reform by default.
                    assert_eq!(built.bfgs, IterationMethod::Bfgs { max_updates: 20 });
                    let expected = if step.name.starts_with("compress-") {
                        built.bfgs
                    } else {
                        IterationMethod::Newton
                    };
                    assert_eq!(
                        step.control.convergence.method, expected,
                        "{kind} ({grip}): step {}",
                        step.name
                    );
                }
            }
        }
        // With filament nodes tied to the gel, `auto` keeps full Newton in the compression.
        let table = Protocol::table("microplate-compression").unwrap();
        let values = crate::param::ParamValues::defaults(table);
        let protocol = Protocol::from_values("microplate-compression", &values).unwrap();
        let mut cell = SuspendedCell::default();
        cell.coupling.microtubules_embedded = true;
        let built = compression_on_a_coarse_cell(cell, &protocol);
        assert_compression_solver(&built, false, 0.0, "embedded MTs");
        // MTs on the elastic foundation: BFGS in the compression's loading steps, with the
        // rotations' trust region in every step.
        let mut values =
            crate::param::ParamValues::defaults(&crate::cell::suspended::params::SUSPENDED_CELL);
        values
            .set(
                &crate::cell::suspended::params::SUSPENDED_CELL,
                "microtubules.coupling",
                crate::param::ParamValue::Word("foundation".into()),
            )
            .unwrap();
        let built = compression_on_a_coarse_cell(SuspendedCell::from_values(&values), &protocol);
        assert_compression_solver(
            &built,
            true,
            crate::cell::suspended::params::FOUNDATION_ROTATION_STEP,
            "foundation",
        );
        // With the trust region switched off, BFGS is not taken there (it did not end the
        // 50 % step in equilibrium).
        values
            .set(
                &crate::cell::suspended::params::SUSPENDED_CELL,
                "solver.rotation_step",
                crate::param::ParamValue::Number(0.0),
            )
            .unwrap();
        let built = compression_on_a_coarse_cell(SuspendedCell::from_values(&values), &protocol);
        assert_compression_solver(&built, false, 0.0, "foundation without the bound");
    }

    #[test]
    fn a_compression_refines_the_suspended_cell_under_the_plates_unless_the_cell_sets_its_own() {
        use crate::cell::suspended::PoleRefinement;
        let compression = Protocol::MicroplateCompression(MicroplateCompression::default());
        let tension = Protocol::MicropipetteTension(MicropipetteTension::default());
        let cell = SuspendedCell::default();
        assert_eq!(cell.params.pole_refinement.levels, 0);
        let under_plates = PoleRefinement {
            levels: 1,
            radius: 6.0,
        };
        assert_eq!(compression.pole_refinement(), Some(under_plates));
        assert_eq!(
            cell.with_tool_refinement(compression.pole_refinement())
                .params
                .pole_refinement,
            under_plates
        );
        assert_eq!(tension.pole_refinement(), None);
        assert_eq!(*cell.with_tool_refinement(tension.pole_refinement()), cell);
        // The cell's own refinement (a convergence check) replaces the protocol's.
        let mut own = cell.clone();
        own.params.pole_refinement = PoleRefinement {
            levels: 1,
            radius: 100.0,
        };
        assert_eq!(
            *own.with_tool_refinement(compression.pole_refinement()),
            own
        );
        // `refinement.levels = 0` in [protocol]: none.
        let table = Protocol::table("microplate-compression").unwrap();
        let mut values = crate::param::ParamValues::defaults(table);
        values
            .set(
                table,
                "refinement.levels",
                crate::param::ParamValue::Count(0),
            )
            .unwrap();
        let unrefined = Protocol::from_values("microplate-compression", &values).unwrap();
        assert_eq!(unrefined.pole_refinement(), None);
        assert_eq!(
            *cell.with_tool_refinement(unrefined.pole_refinement()),
            cell
        );
    }

    #[test]
    fn the_compression_scenario_builds_its_cell_refined_under_the_plates() {
        // The scenario file and the library build the same mesh: split near the poles,
        // hanging nodes tied, the FAs where the unrefined cell has them.
        let coarse = "[cell]\ncore_divisions = 4\nshell_layers = 2\nouter_layers = 2\n";
        let parse = |protocol: &str| {
            let text = format!("title = \"t\"\n{coarse}[protocol]\n{protocol}\n");
            crate::scenario::parse(&text, "t.toml", std::path::Path::new(".")).unwrap()
        };
        let hex8 = |s: &crate::scenario::Scenario| -> usize {
            s.model.mesh.blocks.iter().map(|b| b.len()).sum()
        };
        let refined = parse("kind = \"microplate-compression\"");
        let unrefined = parse("kind = \"microplate-compression\"\nrefinement.levels = 0");
        let tension = parse("kind = \"micropipette-tension\"");
        assert_eq!(hex8(&unrefined), hex8(&tension));
        assert!(hex8(&refined) > hex8(&unrefined) + 7, "{}", hex8(&refined));
        let mut cell = SuspendedCell::default();
        cell.params.mesh.core_divisions = 4;
        cell.params.mesh.shell_layers = 2;
        cell.params.mesh.outer_layers = 2;
        let compression = Protocol::MicroplateCompression(MicroplateCompression::default());
        let library = crate::experiment::CellModel::Suspended(cell)
            .build_for(&compression)
            .unwrap();
        assert!(library.model.mesh.nodes == refined.model.mesh.nodes);
        // Every node of the unrefined model (the FAs' and the filaments' among them) is a
        // node of the refined one, where it was.
        let key = |p: &[f64; 3]| p.map(f64::to_bits);
        let refined_nodes: std::collections::HashSet<[u64; 3]> =
            refined.model.mesh.nodes.iter().map(key).collect();
        let moved = unrefined
            .model
            .mesh
            .nodes
            .iter()
            .filter(|p| !refined_nodes.contains(&key(p)))
            .count();
        assert_eq!(
            moved, 0,
            "nodes of the unrefined cell moved by the refinement"
        );
    }
}
