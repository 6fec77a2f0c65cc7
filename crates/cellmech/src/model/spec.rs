//! The model as plain data: what the scenario parser and the cell builders produce and
//! [`super::build`] turns into an engine problem. No parsing, no engine objects.

use cellmech_fem::element::hex8::Hex8Formulation;
use cellmech_fem::material::NeoHookean;
use cellmech_fem::mesh::refine::HangingNode;
use cellmech_fem::mesh::Mesh;
use cellmech_fem::solve::StepControl;

use super::structures::StructuresSpec;
use super::tools::{ToolMotion, ToolSpec};

/// A complete model in internal units (µm, nN, kPa): mesh, materials, structures, tools,
/// steps and the outputs wanted.
#[derive(Debug, Clone)]
pub struct ModelSpec {
    /// The mesh with its element and node sets.
    pub mesh: Mesh,
    /// Material of every element set, in mesh block order.
    pub materials: Vec<MaterialAssignment>,
    /// Filaments, membranes and family switches (see [`super::structures`]).
    pub structures: StructuresSpec,
    /// Rigid tools.
    pub tools: Vec<ToolSpec>,
    /// Analysis steps in order.
    pub steps: Vec<StepSpec>,
    /// Output requests.
    pub output: OutputSpec,
    /// Supports that only remove rigid-body modes (node set, components): their largest
    /// reaction is reported per increment as `support_reaction_max_nN` and must stay ~0.
    pub supports: Vec<(String, [bool; 3])>,
    /// Shape probes (e.g. a cell's nucleus): extent along and across a test axis.
    pub shape_probes: Vec<ShapeProbeSpec>,
    /// Nodes whose translations follow the continuum they lie in (embedded elements).
    pub embedded: Vec<EmbedSpec>,
    /// Hanging nodes of a locally refined mesh (`cellmech_fem::mesh::refine`), each tied to
    /// its masters in every translation (see `docs/local-refinement.md`). Empty for a
    /// conforming mesh.
    pub hanging: Vec<HangingNode>,
    /// Beam families stress-free in the state the first step carries the continuum to
    /// (see [`super::prestressed_reference`]); `None`: stress-free in the mesh.
    pub prestressed_reference: Option<super::PrestressedReference>,
    /// ALE rezoning of a continuum region between steps (`None`: a Lagrangian mesh).
    pub rezone: Option<super::RezoneSpec>,
}

/// Nodes embedded in host continuum blocks: each node's translations follow the host
/// element's interpolation at the node's reference position (exact linear constraints,
/// see `docs/embedded-elements.md`), or, with a `foundation_modulus`, are tied to that
/// material point by an elastic tie (`cellmech_fem::element::host_tie`) of stiffness
/// modulus × the length of enabled structure elements the node stands for (half of each
/// element through it). Rotations of beam nodes stay free. Nodes that no enabled structure
/// uses (a switched-off family) are skipped.
#[derive(Debug, Clone, PartialEq)]
pub struct EmbedSpec {
    /// Name for reports (e.g. `microtubule_interior`).
    pub name: String,
    /// Node set of the embedded nodes.
    pub node_set: String,
    /// Element sets (hex8 blocks) that host them.
    pub host_blocks: Vec<String>,
    /// Largest accepted overshoot of a node outside its host, in the host's natural
    /// coordinates (`max|ξ| − 1`): points just outside a faceted curved boundary.
    pub tolerance: f64,
    /// `None`: exact embedding. `Some(k)`: elastic ties with foundation modulus `k`
    /// (nN/µm², force per length of fibre per µm of slip).
    pub foundation_modulus: Option<f64>,
    /// Radius (µm) of the ball of host material whose mean displacement an exactly
    /// embedded node follows (a distributing coupling: a load on the node spreads over the
    /// ball); 0 ties the node at its point ([`cellmech_fem::constraint::embed`]).
    pub radius: f64,
}

/// A node set whose shape along a test axis is reported per increment.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeProbeSpec {
    /// Column prefix (e.g. `nucleus`).
    pub name: String,
    /// Node set measured.
    pub node_set: String,
    /// Test axis (0, 1, 2).
    pub axis: usize,
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
    pub tools: Vec<ToolMotion>,
}

/// The `curve.csv` columns of a reaction curve `name` in `component` (0, 1, 2): the mean
/// displacement of its node set (`<name>_u<c>_um`) and the sum of its reactions
/// (`<name>_f<c>_nN`). The one place these names are formatted.
pub fn curve_columns(name: &str, component: usize) -> [String; 2] {
    let c = ['x', 'y', 'z'][component];
    [format!("{name}_u{c}_um"), format!("{name}_f{c}_nN")]
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

impl Default for OutputSpec {
    /// No extra curves, a VTU frame per converged increment, PNG plots.
    fn default() -> Self {
        OutputSpec {
            curves: Vec::new(),
            vtk_every: 1,
            plot_format: PlotFormat::Png,
        }
    }
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
