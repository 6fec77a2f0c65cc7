//! Rigid tools of a model: their resolved description ([`ToolSpec`], [`ToolMotion`]),
//! the defaults of their penalty and tolerances, and their engine contact terms, load
//! programs and step stop conditions. Defaults (see `docs/tools.md`):
//!
//! * penalty ε = [`PENALTY_FACTOR`] × G_max × h, G_max the largest shear modulus of the
//!   model's materials and h the mean spacing of the tool's contact nodes: a surface node of
//!   an element of size h resists with a stiffness of order G h, so ε is 50 times stiffer
//!   than the body there (the penalty part of the penetration is ~2 % of the node's elastic
//!   displacement, so few augmentations are needed) yet only ~10² times stiffer (the tangent
//!   stays well conditioned). The augmented Lagrangian iterations remove the dependence of
//!   the result on ε: the converged penetration is below the tolerance whatever ε is.
//! * tolerance = [`TOLERANCE_FACTOR`] × the diagonal of the mesh's bounding box (5.6 nm for
//!   the 32 µm suspended cell): far below any measured displacement, above round-off.
//! * `until_force` tolerance = [`FORCE_TOLERANCE_FACTOR`] × G_max × diagonal², a force scale
//!   of the whole body.

use cellmech_fem::contact::{
    scalar_name, ContactError, ContactKind, CurvatureTangent, RigidContact, ToolScalar, ToolShape,
};
use cellmech_fem::mesh::Mesh;
use cellmech_fem::solve::{Monitor, Step, StopCondition};
use cellmech_fem::term::Term;

use super::{MaterialAssignment, ModelSpec, StepSpec};

/// Default penalty = this × largest shear modulus × mean contact-node spacing.
pub const PENALTY_FACTOR: f64 = 50.0;
/// Default penetration / bond-gap tolerance = this × bounding-box diagonal.
pub const TOLERANCE_FACTOR: f64 = 1e-4;
/// Default `until_force` tolerance = this × largest shear modulus × diagonal².
pub const FORCE_TOLERANCE_FACTOR: f64 = 1e-6;

/// A resolved tool in internal units (µm, nN/µm).
#[derive(Debug, Clone, PartialEq)]
pub struct ToolSpec {
    /// Name.
    pub name: String,
    /// Shape in its reference position (unit normals/axes).
    pub shape: ToolShape,
    /// Frictionless or bonded.
    pub kind: ContactKind,
    /// Node set of the contact candidates (non-empty).
    pub node_set: String,
    /// Surface faces the tool acts on through Gauss points ([`FACE_POINTS_PER_SIDE`]² per
    /// face; `RigidContact::on_faces`); empty: node contact on `node_set`.
    pub faces: Vec<[usize; 4]>,
    /// Penalty ε (nN/µm).
    pub penalty: f64,
    /// Penetration / bond-gap tolerance (µm).
    pub tolerance: f64,
    /// Which pressure the tangent's curvature term of a frictionless contact uses.
    pub curvature_tangent: CurvatureTangent,
    /// Aim the tool at a node from a step on (`RigidContact::aimed_at`): `None` keeps it
    /// where its shape puts it.
    pub aim: Option<ToolAim>,
    /// Body nodes watched for lying inside the tool, without contact forces
    /// (`RigidContact::with_watched_nodes`; the curve gets `<tool>_deepest_node_inside_um`);
    /// empty: none.
    pub watch: Vec<usize>,
}

/// A tool aimed at a body node: when step `step` starts, the tool is moved across that
/// step's motion onto the node as it has moved so far.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolAim {
    /// The body node (a mesh node).
    pub node: usize,
    /// The analysis step it applies to (0-based index into the model's steps).
    pub step: usize,
}

/// A tool's motion over one step.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolMotion {
    /// Tool name (exists).
    pub tool: String,
    /// Pilot-point displacement over the step (µm).
    pub movement: [f64; 3],
    /// Stop the step where the force along the motion reaches this value.
    pub until_force: Option<ForceTarget>,
    /// Stop the step where the tool first touches the body: its smallest gap
    /// (`<tool>_min_gap_um`) reaches 0 within this tolerance (µm). The gap is linear in the
    /// travel until then, so the stop is found in one or two increments, where a force
    /// target sees only zeros until contact.
    pub until_contact: Option<f64>,
}

/// A force target ending a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceTarget {
    /// Target force along the motion (nN).
    pub value: f64,
    /// Accepted distance from it (nN, > 0).
    pub tolerance: f64,
}

pub fn largest_shear_modulus(materials: &[MaterialAssignment]) -> f64 {
    materials
        .iter()
        .map(|m| m.law.shear_modulus)
        .fold(0.0, f64::max)
}

pub fn mesh_diagonal(mesh: &Mesh) -> f64 {
    let (lo, hi) = mesh.bounding_box();
    (0..3).map(|i| (hi[i] - lo[i]).powi(2)).sum::<f64>().sqrt()
}

/// Mean distance from a contact node to its nearest neighbour in the set (sampled over at
/// most 400 nodes); the model diagonal for a single node.
fn mean_spacing(mesh: &Mesh, nodes: &[usize]) -> f64 {
    if nodes.len() < 2 {
        return mesh_diagonal(mesh);
    }
    let stride = nodes.len().div_ceil(400);
    let mut total = 0.0;
    let mut count = 0;
    for &a in nodes.iter().step_by(stride) {
        let pa = mesh.nodes[a];
        let nearest = nodes
            .iter()
            .filter(|&&b| b != a)
            .map(|&b| {
                let pb = mesh.nodes[b];
                (0..3).map(|i| (pa[i] - pb[i]).powi(2)).sum::<f64>().sqrt()
            })
            .filter(|&d| d > 0.0)
            .fold(f64::INFINITY, f64::min);
        if nearest.is_finite() {
            total += nearest;
            count += 1;
        }
    }
    if count == 0 {
        mesh_diagonal(mesh)
    } else {
        total / count as f64
    }
}

/// Gauss points per side of a contact face (3 × 3 per face): a point every third of a face,
/// so a paraboloid tip of radius R between points protrudes at most (h/3)²/(8R) into a face
/// of size h.
pub const FACE_POINTS_PER_SIDE: usize = 3;

/// The default penalty of a tool on `nodes`: [`PENALTY_FACTOR`] × the largest shear
/// modulus × the mean spacing of the contact nodes (0 when no material has a modulus).
pub fn default_penalty(materials: &[MaterialAssignment], mesh: &Mesh, nodes: &[usize]) -> f64 {
    PENALTY_FACTOR * largest_shear_modulus(materials) * mean_spacing(mesh, nodes)
}

/// The default penetration / bond-gap tolerance: [`TOLERANCE_FACTOR`] × the mesh diagonal.
pub fn default_tolerance(mesh: &Mesh) -> f64 {
    TOLERANCE_FACTOR * mesh_diagonal(mesh)
}

/// The pilot-point displacement of `tool` at the end of each step (cumulative moves).
pub fn tool_program(tool: &str, steps: &[Vec<ToolMotion>]) -> Vec<[f64; 3]> {
    let mut at = [0.0; 3];
    steps
        .iter()
        .map(|motions| {
            if let Some(m) = motions.iter().find(|m| m.tool == tool) {
                for (a, d) in at.iter_mut().zip(m.movement) {
                    *a += d;
                }
            }
            at
        })
        .collect()
}

/// One contact term per `[[tool]]`, with its pilot-point program (the cumulative moves of
/// the steps; tools not moved in a step hold).
pub fn contact_terms(model: &ModelSpec) -> Result<Vec<Box<dyn Term>>, ContactError> {
    let motions: Vec<Vec<ToolMotion>> = model.steps.iter().map(|s| s.tools.clone()).collect();
    let held = nodes_with_stiffness(model);
    // Node sets hold mesh nodes (a `Mesh` invariant), so `get` never misses.
    let is_held = |n: usize| held.get(n).copied().unwrap_or(false);
    model
        .tools
        .iter()
        .filter(|tool| {
            // A tool on the nodes of a switched-off filament family only (e.g. the plates'
            // companions on the MT nodes without MTs) has nothing to touch.
            let nodes = contact_nodes(&model.mesh, &tool.node_set);
            !tool.faces.is_empty() || nodes.is_empty() || nodes.iter().any(|&n| is_held(n))
        })
        .map(|tool| {
            let program = tool_program(&tool.name, &motions);
            let watched: Vec<(usize, [f64; 3])> = tool
                .watch
                .iter()
                .filter_map(|&n| Some((n, *model.mesh.nodes.get(n)?)))
                .collect();
            let term = if tool.faces.is_empty() {
                let nodes: Vec<usize> = contact_nodes(&model.mesh, &tool.node_set)
                    .into_iter()
                    .filter(|&n| is_held(n))
                    .collect();
                let reference = nodes.iter().map(|&n| model.mesh.nodes[n]).collect();
                RigidContact::new(
                    tool.name.clone(),
                    tool.shape,
                    tool.kind,
                    nodes,
                    reference,
                    tool.penalty,
                    tool.tolerance,
                    program,
                )?
                .with_curvature_tangent(tool.curvature_tangent)
                .with_watched_nodes(watched)
            } else {
                RigidContact::on_faces(
                    tool.name.clone(),
                    tool.shape,
                    tool.kind,
                    &tool.faces,
                    &model.mesh.nodes,
                    FACE_POINTS_PER_SIDE,
                    tool.penalty,
                    tool.tolerance,
                    program,
                )?
                .with_curvature_tangent(tool.curvature_tangent)
                .with_watched_nodes(watched)
            };
            let term = match tool.aim {
                Some(aim) => term.aimed_at(aim.node, aim.step),
                None => term,
            };
            Ok(Box::new(term) as Box<dyn Term>)
        })
        .collect()
}

/// Per node, whether an element holds it: a continuum element or an enabled filament or
/// membrane (the nodes of a switched-off family are held by nothing).
fn nodes_with_stiffness(model: &ModelSpec) -> Vec<bool> {
    let mesh = &model.mesh;
    let mut held = super::structures::enabled_structure_nodes(&model.structures, mesh.num_nodes());
    for block in &mesh.blocks {
        for &n in &block.connectivity {
            if let Some(h) = held.get_mut(n) {
                *h = true;
            }
        }
    }
    held
}

fn contact_nodes(mesh: &Mesh, set: &str) -> Vec<usize> {
    mesh.node_sets.get(set).cloned().unwrap_or_default()
}

/// The stop condition of a step whose tool has `until_contact` (the step ends where the
/// tool first touches) or `until_force`: the step ends where the tool's force along its
/// motion reaches the target.
///
/// When the motion is along a coordinate axis the monitor is the force component on that
/// axis (`<tool>_force_z_nN`, target multiplied by the motion's sign): unlike
/// `<tool>_force_along_motion_nN` it does not change meaning between the end of the
/// previous step and the first increment of this one, where the direction of motion may
/// reverse (retraction after a push).
pub fn stop_condition(spec: &StepSpec) -> Option<StopCondition> {
    spec.tools.iter().find_map(|m| {
        if let Some(tolerance) = m.until_contact {
            return Some(StopCondition {
                monitor: Monitor::TermScalar(scalar_name(&m.tool, ToolScalar::MinGap)),
                target: 0.0,
                tolerance,
                // Measured from the committed positions: linear in the tool's travel.
                known_before_solving: true,
            });
        }
        let target = m.until_force?;
        let nonzero: Vec<usize> = (0..3).filter(|&c| m.movement[c] != 0.0).collect();
        let (monitor, value) = match nonzero.as_slice() {
            [c] => (
                scalar_name(&m.tool, ToolScalar::Force(*c)),
                target.value * m.movement[*c].signum(),
            ),
            _ => (
                scalar_name(&m.tool, ToolScalar::ForceAlongMotion),
                target.value,
            ),
        };
        Some(StopCondition {
            monitor: Monitor::TermScalar(monitor),
            target: value,
            tolerance: target.tolerance,
            known_before_solving: false,
        })
    })
}

/// Adds the tool part of a step (its stop condition) to an engine step.
pub fn apply_to_step(step: &mut Step, spec: &StepSpec) {
    step.stop = stop_condition(spec);
}

/// The direction a tool pushes the body along: its normal/axis, or for a sphere the
/// direction of its first move (`None` for a sphere that never moves).
pub fn push_direction(model: &ModelSpec, tool: &str) -> Option<[f64; 3]> {
    let spec = model.tools.iter().find(|t| t.name == tool)?;
    spec.shape.axis().or_else(|| {
        model.steps.iter().find_map(|s| {
            let m = s.tools.iter().find(|m| m.tool == tool)?.movement;
            let l = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
            (l > 0.0).then(|| m.map(|x| x / l))
        })
    })
}
