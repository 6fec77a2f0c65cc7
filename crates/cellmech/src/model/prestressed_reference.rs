//! Filaments that are stress-free in the prestressed cell.
//!
//! By default every part of a model is stress-free in the mesh, and the first step's
//! prestress contracts the cell: filaments held by the gel (embedded MTs, MTs on an elastic
//! foundation) are shortened with it and buckle long before the cell is loaded (the
//! suspended cell's foundation-coupled MTs buckle at 0.19 nN and its prestress does not
//! reach equilibrium). With a [`PrestressedReference`] the listed beam families are
//! instead stress-free in the state the prestress carries the gel to, as if they had
//! polymerised in the contracted cell (Abaqus adds such elements with `*MODEL CHANGE,
//! ADD = STRAIN FREE`):
//!
//! 1. **Where the gel goes.** The model without those families runs its first step alone
//!    (their nodes are then held by nothing and not in the problem). Each of their nodes
//!    is carried as the model moves it: a continuum node with its own displacement, a
//!    node the model ties to others (an FA plaque's reference node, where the filaments
//!    end) with its masters', a node tied over a ball with the ball's mean, any other node
//!    with the interpolated displacement of the hex8 it lies in.
//! 2. **Filaments born there.** In the model itself the families' stress-free geometry
//!    follows the recorded path during the first step, piecewise linear in its time through
//!    the recorded increments (`cellmech_fem::element::beam::ReferenceMorph`), while the
//!    prestress ramps in; and every increment of that step starts Newton from the recorded
//!    state (`cellmech_fem::solve::Step::guess`), in which the filaments sit exactly on
//!    their moving reference. Measured on the suspended cell: the MTs end the prestress at
//!    1e-11 nN, free or embedded, in 3 Newton iterations. The first pass must end in a true
//!    equilibrium (an end held by viscous stabilisation is an error).
//!
//! The filaments then carry nothing of the actin prestress (the tensegrity reading, in
//! which MTs balance part of it, needs them compressed), but they keep their designed shape
//! as the gel carries it, and held ones are load-bearing from the first µm of a test.
//! Why both the moving reference and the starting path are needed: a reference that jumps
//! ahead of its nodes overloads the corotational beams (6119 nN of imbalance in the first
//! iteration on the coarse cell), and nodes prescribed along it make the elements at the
//! FAs columns between held points that buckle at 0.03 nN (`docs/design.md`).

use cellmech_fem::constraint::embed::ball_weights;
use cellmech_fem::mesh::locate::HostLocator;

use super::{BuildError, ModelSpec};

/// Beam families whose stress-free geometry is the prestressed one (module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct PrestressedReference {
    /// Beam families, e.g. `["microtubule"]`.
    pub families: Vec<String>,
    /// Hex8 blocks whose material points carry their nodes.
    pub host_blocks: Vec<String>,
    /// Largest overshoot (natural coordinates) of a node outside its host (nodes on the
    /// faceted surface of a curved mesh).
    pub tolerance: f64,
}

/// What the first pass did, for `summary.json`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PrestressedReferenceReport {
    /// The families stress-free in the prestressed cell.
    pub families: Vec<String>,
    /// Largest distance the first step carries one of their nodes (µm).
    pub max_carried_um: f64,
    /// Wall time of the first pass (s).
    pub wall_time_s: f64,
}

/// The first pass: its recorded states and the node positions they give.
pub(super) struct FirstPass {
    knots: Vec<Knot>,
    positions: Vec<(f64, Vec<[f64; 3]>)>,
    pub report: PrestressedReferenceReport,
}

impl FirstPass {
    /// The carried families and their moving positions, for the beam sets.
    pub fn carried(&self) -> super::structures::CarriedFamilies<'_> {
        super::structures::CarriedFamilies {
            families: &self.report.families,
            knots: &self.positions,
        }
    }

    /// The recorded states as the first step's guess path, in `dof_map`'s numbering.
    pub fn guess(&self, dof_map: &cellmech_fem::dof::DofMap) -> cellmech_fem::solve::GuessPath {
        cellmech_fem::solve::GuessPath {
            times: self.knots.iter().map(|k| k.time).collect(),
            values: self.knots.iter().map(|k| k.dof_values(dof_map)).collect(),
        }
    }
}

/// Runs the first pass of `model` for `spec` (module documentation).
///
/// `None` when the families have no enabled filament (switched off): there is nothing to
/// carry, and the first step runs as it would without a prestressed reference. (A guess
/// path would make every increment start from the unstressed state: the suspended cell's
/// prestress with its MTs switched off then crawled at 0.0005 of the step from 85 % of
/// the ramp, with FA plaques.)
pub(super) fn first_pass(
    model: &ModelSpec,
    spec: &PrestressedReference,
) -> Result<Option<FirstPass>, BuildError> {
    let start = std::time::Instant::now();
    let Some((knots, farthest)) = carried_positions(model, spec)? else {
        return Ok(None);
    };
    let positions = knots
        .iter()
        .map(|k| (k.time, k.positions(&model.mesh.nodes)))
        .collect();
    Ok(Some(FirstPass {
        knots,
        positions,
        report: PrestressedReferenceReport {
            families: spec.families.clone(),
            max_carried_um: farthest,
            wall_time_s: start.elapsed().as_secs_f64(),
        },
    }))
}

/// The first pass's state at each converged increment of its first step (see [`Knot`]),
/// and the largest distance a filament node is carried (µm); `None` without an enabled
/// filament of the families.
fn carried_positions(
    model: &ModelSpec,
    spec: &PrestressedReference,
) -> Result<Option<(Vec<Knot>, f64)>, BuildError> {
    let fail = |message: String| BuildError::PrestressedReference(message);
    let mut first = model.clone();
    first.prestressed_reference = None;
    first.tools.clear();
    first.steps.truncate(1);
    let Some(step) = first.steps.first_mut() else {
        return Err(fail(
            "the model has no first step to carry the filaments".into(),
        ));
    };
    step.tools.clear();
    let mut nodes = Vec::new();
    for f in first
        .structures
        .filaments
        .iter_mut()
        .filter(|f| spec.families.contains(&f.family))
    {
        if f.enabled {
            nodes.extend(f.pairs.iter().flatten().copied());
        }
        f.enabled = false;
    }
    nodes.sort_unstable();
    nodes.dedup();
    let mesh = &model.mesh;
    if nodes.is_empty() {
        return Ok(None);
    }
    let blocks: Vec<&str> = spec.host_blocks.iter().map(String::as_str).collect();
    let locator = HostLocator::new(mesh, &blocks).map_err(|e| fail(e.to_string()))?;
    // Nodes the model ties over a ball follow the ball's mean, not their point.
    let ball_radius = |n: usize| {
        model
            .embedded
            .iter()
            .filter(|e| e.foundation_modulus.is_none() && e.radius > 0.0)
            .find(|e| {
                mesh.node_sets
                    .get(&e.node_set)
                    .is_some_and(|s| s.contains(&n))
            })
            .map(|e| e.radius)
    };
    // Nodes the model ties to others (an FA plaque's reference node, where the filaments
    // end) move with their masters in the model itself, not with the material point they
    // happen to lie in.
    let tied = |n: usize| model.hanging.iter().find(|h| h.node == n);
    // Each node's host nodes and weights (itself with weight 1 for a continuum node).
    let mut hosts: Vec<(usize, Vec<(usize, f64)>)> = Vec::with_capacity(nodes.len());
    for &n in &nodes {
        if locator.is_host_node(n) {
            hosts.push((n, vec![(n, 1.0)]));
        } else if let Some(tie) = tied(n) {
            hosts.push((n, tie.masters.clone()));
        } else if let Some(weights) = ball_radius(n)
            .map(|r| ball_weights(&locator, mesh.nodes[n], r))
            .filter(|w| !w.is_empty())
        {
            hosts.push((n, weights));
        } else {
            let host = locator
                .locate(mesh.nodes[n], spec.tolerance)
                .map_err(|e| fail(format!("node {n}: {e}")))?;
            hosts.push((n, host.nodes.iter().copied().zip(host.weights()).collect()));
        }
    }
    let mut built = super::build(&first)?;
    let step = built.steps[0].clone();
    let mut recorder = Recorder {
        hosts: &hosts,
        num_nodes: mesh.num_nodes(),
        knots: Vec::new(),
        farthest: 0.0,
        end_viscous_force_ratio: None,
    };
    built
        .problem
        .run_step(&step, &mut recorder)
        .map_err(|e| fail(format!("the first step without {:?}: {e}", spec.families)))?;
    if recorder.knots.last().map(|k| k.time) != Some(1.0) {
        return Err(fail("the first step did not reach its end".into()));
    }
    if let Some(ratio) = recorder.end_viscous_force_ratio {
        // The recorded state becomes the filaments' stress-free geometry and the analysis's
        // starting path: it must be an equilibrium, not a stabilised approximation of one.
        return Err(fail(format!(
            "the first step without {:?} ends only with viscous stabilisation (viscous \
             forces {ratio:.2e} of the force scale, not re-solved in equilibrium): that \
             model has no prestressed equilibrium to carry the filaments to; use \
             `stress_free = \"unstressed-cell\"`",
            spec.families
        )));
    }
    Ok(Some((recorder.knots, recorder.farthest)))
}

/// Records the carried state at every converged increment.
struct Recorder<'a> {
    hosts: &'a [(usize, Vec<(usize, f64)>)],
    num_nodes: usize,
    knots: Vec<Knot>,
    farthest: f64,
    /// The last increment's viscous force ratio when it was stabilised and not re-solved
    /// in equilibrium.
    end_viscous_force_ratio: Option<f64>,
}

/// The first pass's state at one converged increment of the first step.
struct Knot {
    /// Step time.
    time: f64,
    /// Per node, its displacement and rotation (µm, rad): the first pass's values, with the
    /// carried families' nodes moved with their material points and their rotations 0.
    dofs: Vec<[f64; 6]>,
}

impl Knot {
    /// Node positions: the mesh moved by the knot's displacements.
    fn positions(&self, mesh_nodes: &[[f64; 3]]) -> Vec<[f64; 3]> {
        mesh_nodes
            .iter()
            .zip(&self.dofs)
            .map(|(x, d)| std::array::from_fn(|c| x[c] + d[c]))
            .collect()
    }

    /// The values in the order of `dof_map` (components a node does not have are dropped).
    fn dof_values(&self, dof_map: &cellmech_fem::dof::DofMap) -> Vec<f64> {
        let mut u = vec![0.0; dof_map.num_dofs()];
        for (n, d) in self.dofs.iter().enumerate() {
            for (c, &v) in d.iter().enumerate().take(dof_map.count(n)) {
                u[dof_map.dof(n, c)] = v;
            }
        }
        u
    }
}

impl cellmech_fem::solve::Observer for Recorder<'_> {
    fn on_increment(
        &mut self,
        problem: &cellmech_fem::solve::Problem,
        report: &cellmech_fem::solve::IncrementReport<'_>,
    ) {
        let u = problem.u();
        let dofs = problem.dof_map();
        let mut state = vec![[0.0; 6]; self.num_nodes];
        for (n, d) in state.iter_mut().enumerate() {
            for (c, v) in d.iter_mut().enumerate().take(dofs.count(n)) {
                *v = u[dofs.dof(n, c)];
            }
        }
        for (n, weights) in self.hosts {
            let moved: [f64; 3] =
                std::array::from_fn(|c| weights.iter().map(|&(h, w)| w * u[dofs.dof(h, c)]).sum());
            self.farthest = self
                .farthest
                .max(moved.iter().map(|v| v * v).sum::<f64>().sqrt());
            state[*n] = [moved[0], moved[1], moved[2], 0.0, 0.0, 0.0];
        }
        self.knots.push(Knot {
            time: report.step_time,
            dofs: state,
        });
        self.end_viscous_force_ratio = report
            .stabilization
            .filter(|st| !st.equilibrated && st.viscous_force_ratio > 0.0)
            .map(|st| st.viscous_force_ratio);
    }
}
