//! The raw scenario file as written by the user: serde structs with optional fields,
//! unknown keys rejected (toml reports the line), quantities with units.

use serde::Deserialize;
use toml::Spanned;

use crate::units::{Force, Length, Pressure, Stiffness};

/// The whole scenario file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    /// A one-line title for outputs and plots.
    pub title: Option<String>,
    /// Where the mesh comes from (or give `[cell]` to build a cell model).
    pub mesh: Option<MeshSection>,
    /// A built-in cell model (mesh, materials and cytoskeleton), read against its declared
    /// parameters; see `scenario::cell`.
    pub cell: Option<Spanned<toml::Table>>,
    /// A built-in virtual experiment on the `[cell]` (tools, steps and outputs).
    pub protocol: Option<Spanned<toml::Table>>,
    /// Extra node sets selected from the mesh's nodes by position.
    #[serde(default, rename = "node_set")]
    pub node_sets: Vec<NodeSetSection>,
    /// Material of each element set.
    #[serde(default, rename = "material")]
    pub materials: Vec<MaterialSection>,
    /// Discrete filaments (trusses or beams), see `docs/structures.md`.
    #[serde(default, rename = "filament")]
    pub filaments: Vec<super::structures::FilamentSection>,
    /// Membrane layers on surfaces of the continuum.
    #[serde(default, rename = "membrane")]
    pub membranes: Vec<super::structures::MembraneSection>,
    /// Study switches per family (`[families.actin]`).
    #[serde(default)]
    pub families: std::collections::BTreeMap<String, Spanned<super::structures::FamilySection>>,
    /// Analysis steps, run in order.
    #[serde(default, rename = "step")]
    pub steps: Vec<StepSection>,
    /// What to write.
    #[serde(default)]
    pub output: OutputSection,
    /// Rigid tools (plates, pipettes, AFM tips, probes); see `scenario::tools`.
    #[serde(default, rename = "tool")]
    pub tools: Vec<ToolSection>,
}

/// `[mesh]`: a generator (`source = "box"` or `"sphere"`) or a file (`source = "file"`).
/// Keys that do not belong to the chosen source are rejected when the scenario is resolved.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSection {
    /// `box`, `sphere` or `file`.
    pub source: Spanned<String>,
    /// Box: corner with the smallest coordinates (default the origin).
    pub origin: Option<[Length; 3]>,
    /// Box: edge lengths.
    pub size: Option<[Length; 3]>,
    /// Box: elements along each edge.
    pub divisions: Option<[usize; 3]>,
    /// Box: element-set name (default `solid`).
    pub element_set: Option<String>,
    /// Sphere: outer radius.
    pub radius: Option<Length>,
    /// Sphere: radius of a concentric inner ball (element set `nucleus`, shell `cytoplasm`).
    pub inner_radius: Option<Length>,
    /// Sphere: elements along an edge of the central cube (even).
    pub core_divisions: Option<usize>,
    /// Sphere: radial layers from the cube to the (inner) sphere.
    pub shell_layers: Option<usize>,
    /// Sphere: radial layers between the inner and the outer sphere.
    pub outer_layers: Option<usize>,
    /// File: path of a Gmsh `.msh` (4.1 ASCII) or Abaqus/CalculiX `.inp`, relative to the
    /// scenario file.
    pub path: Option<String>,
}

/// `[[node_set]]`: the nodes of an existing set (default: all nodes) whose coordinates lie
/// within the given bounds (each bound optional, inclusive).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeSetSection {
    /// Name of the new set.
    pub name: Spanned<String>,
    /// Set to select from (default: every node).
    pub from: Option<Spanned<String>>,
    /// Lower bound on x.
    pub x_min: Option<Length>,
    /// Upper bound on x.
    pub x_max: Option<Length>,
    /// Lower bound on y.
    pub y_min: Option<Length>,
    /// Upper bound on y.
    pub y_max: Option<Length>,
    /// Lower bound on z.
    pub z_min: Option<Length>,
    /// Upper bound on z.
    pub z_max: Option<Length>,
}

/// `[[material]]`: the law of one element set.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSection {
    /// Element set (block) the law applies to.
    pub element_set: Spanned<String>,
    /// Law name; only `neo-hookean` so far.
    #[serde(default = "neo_hookean")]
    pub model: Spanned<String>,
    /// Shear modulus G (or give `youngs_modulus`).
    pub shear_modulus: Option<Pressure>,
    /// Young's modulus E (with `poisson_ratio`).
    pub youngs_modulus: Option<Pressure>,
    /// Bulk modulus K (or give `poisson_ratio`).
    pub bulk_modulus: Option<Pressure>,
    /// Poisson's ratio ν (dimensionless, < 0.5).
    pub poisson_ratio: Option<f64>,
    /// `mean-dilatation` (default, locking-free) or `displacement` (plain hex8).
    pub formulation: Option<Spanned<String>>,
}

fn neo_hookean() -> Spanned<String> {
    Spanned::new(0..0, "neo-hookean".into())
}

/// `[[step]]`: one analysis step.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepSection {
    /// Step name (default `step-N`).
    pub name: Option<String>,
    /// First increment as a fraction of the step (default 0.1).
    pub initial_increment: Option<f64>,
    /// Smallest increment before giving up (default 1e-5).
    pub min_increment: Option<f64>,
    /// Largest increment (default 0.25).
    pub max_increment: Option<f64>,
    /// Newton iterations per increment (default 25).
    pub max_iterations: Option<usize>,
    /// Relative residual tolerance (default 1e-8).
    pub residual_tolerance: Option<f64>,
    /// Relative energy tolerance (default 1e-12).
    pub energy_tolerance: Option<f64>,
    /// Where Newton starts each increment after the step's first: `"linear"` (default:
    /// the last increment's displacement extrapolated) or `"none"` (the converged state).
    pub extrapolation: Option<Spanned<String>>,
    /// `"filaments"` (default) or `"off"`: whether beam filaments are relaxed by their
    /// own Newton solves after every global update (nonlinear elimination).
    pub relaxation: Option<Spanned<String>>,
    /// `"near-convergence"` (default) or `"off"`: whether full Newton solves with the last
    /// factorisation once the residual is close to the tolerance (chord steps).
    pub chord: Option<Spanned<String>>,
    /// `"newton"` (default: a new tangent at every iteration, chord steps near convergence)
    /// or `"bfgs"` (quasi-Newton: the increment's factorisation kept and corrected by up to
    /// 10 rank-two updates, as FEBio's default).
    pub iteration: Option<Spanned<String>>,
    /// Viscous stabilisation: `"off"` (default), `"on-difficulty"` or `"always"`.
    pub stabilization: Option<Spanned<String>>,
    /// Fraction of the first increment's strain energy the calibrated viscosity dissipates
    /// (default 2e-4).
    pub stabilization_energy_fraction: Option<f64>,
    /// Largest ratio of dissipated to strain energy before the viscosity is reduced
    /// (default 0.05).
    pub stabilization_accuracy: Option<f64>,
    /// Node sets held in place (components default to all).
    #[serde(default)]
    pub fix: Vec<FixSection>,
    /// Node sets moved by a prescribed displacement over the step.
    #[serde(default)]
    pub displace: Vec<DisplaceSection>,
    /// Forces on node sets (total over the set, split equally between its nodes).
    #[serde(default)]
    pub force: Vec<ForceSection>,
    /// Tool motions over the step (tools not listed hold).
    #[serde(default)]
    pub tool: Vec<StepToolSection>,
}

/// `[[step.fix]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FixSection {
    /// Node set.
    pub node_set: Spanned<String>,
    /// Components to hold: any of `x`, `y`, `z` (default all three).
    pub components: Option<Vec<Spanned<String>>>,
}

/// `[[step.displace]]`: displacement of every node of a set, reached at the end of the step
/// (relative to the start of the step).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisplaceSection {
    /// Node set.
    pub node_set: Spanned<String>,
    /// Change of the x component over the step.
    pub x: Option<Length>,
    /// Change of the y component over the step.
    pub y: Option<Length>,
    /// Change of the z component over the step.
    pub z: Option<Length>,
}

/// `[[step.force]]`: a total force on a node set at the end of the step.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceSection {
    /// Node set.
    pub node_set: Spanned<String>,
    /// Total x force on the set.
    pub x: Option<Force>,
    /// Total y force on the set.
    pub y: Option<Force>,
    /// Total z force on the set.
    pub z: Option<Force>,
}

/// `[output]`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSection {
    /// Curves: reaction force of a node set vs its mean displacement.
    #[serde(default, rename = "curve")]
    pub curves: Vec<CurveSection>,
    /// Write a VTU frame every this many converged increments (default 1; 0 = only step ends).
    pub vtk_every: Option<usize>,
    /// Plot format: `png` (default) or `svg`.
    pub plot_format: Option<Spanned<String>>,
}

/// `[[output.curve]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurveSection {
    /// Column prefix (default the node set).
    pub name: Option<String>,
    /// Node set whose reaction is summed and whose displacement is averaged.
    pub node_set: Spanned<String>,
    /// Component `x`, `y` or `z`.
    pub component: Spanned<String>,
    /// Report the force with the opposite sign (e.g. compression as positive).
    #[serde(default)]
    pub reverse_sign: bool,
}

/// `[[tool]]`: a rigid tool acting on a node set through contact.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolSection {
    /// Unique name; prefixes the tool's `curve.csv` columns.
    pub name: Spanned<String>,
    /// `plate`, `disk`, `paraboloid` or `sphere`.
    pub shape: Spanned<String>,
    /// Plate: a point of its surface.
    pub point: Option<Spanned<[Length; 3]>>,
    /// Disk or sphere: centre.
    pub center: Option<Spanned<[Length; 3]>>,
    /// Paraboloid: apex.
    pub apex: Option<Spanned<[Length; 3]>>,
    /// Plate or disk: normal pointing towards the body (numbers; normalised).
    pub normal: Option<Spanned<[f64; 3]>>,
    /// Paraboloid: axis pointing from the tip towards the body (numbers; normalised).
    pub axis: Option<Spanned<[f64; 3]>>,
    /// Disk or sphere: radius.
    pub radius: Option<Spanned<Length>>,
    /// Paraboloid: tip radius of curvature.
    pub tip_radius: Option<Spanned<Length>>,
    /// `frictionless` (default) or `bonded`.
    pub contact: Option<Spanned<String>>,
    /// The contact candidates (e.g. `surface`, or a set selected with `[[node_set]]`).
    pub node_set: Spanned<String>,
    /// Penalty ε (force per length); default chosen from the model.
    pub penalty: Option<Spanned<Stiffness>>,
    /// Penetration / bond-gap tolerance; default 1e-4 × the model size.
    pub tolerance: Option<Spanned<Length>>,
}

/// `[[step.tool]]`: how a tool moves during a step (tools not listed hold their position).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepToolSection {
    /// The tool's name.
    pub name: Spanned<String>,
    /// Pilot-point displacement over this step (default no motion).
    #[serde(rename = "move")]
    pub movement: Option<Spanned<[Length; 3]>>,
    /// End the step where the tool's force along its motion reaches this value.
    pub until_force: Option<Spanned<Force>>,
    /// Accepted distance from `until_force` (default from the model's force scale).
    pub force_tolerance: Option<Spanned<Force>>,
}
