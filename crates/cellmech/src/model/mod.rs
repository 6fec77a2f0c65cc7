//! The model layer: the domain's description of a model as plain data ([`ModelSpec`]:
//! mesh, materials, structures, tools, steps, outputs wanted), produced by the scenario
//! parser and by the cell builders and protocols, and [`build`], which turns it into an
//! engine problem (DOFs, terms, steps, curve DOFs). Nothing here imports `scenario`,
//! `cell` or `protocol`.

pub mod filament;
pub mod filaments;
pub mod prestressed_reference;
pub mod rezoning;
mod spec;
pub mod structures;
pub mod tools;

pub use prestressed_reference::{PrestressedReference, PrestressedReferenceReport};
pub use rezoning::{RezoneRecord, RezoneSpec, Rezoner};
pub use spec::{
    curve_columns, CurveSpec, EmbedSpec, MaterialAssignment, ModelSpec, OutputSpec, PlotFormat,
    ShapeProbeSpec, StepSpec,
};

use cellmech_fem::constraint::embed::embed_translations_over_ball;
use cellmech_fem::constraint::hanging::{tie_hanging_nodes, HangingTieError};
use cellmech_fem::constraint::LinearConstraints;
use cellmech_fem::continuum::ContinuumBlock;
use cellmech_fem::dof::DofMap;
use cellmech_fem::element::host_tie::{HostTie, HostTieSet};
use cellmech_fem::linsolve::FaerSparseSolver;
use cellmech_fem::mesh::locate::HostLocator;
use cellmech_fem::solve::{Motion, NodalLoad, Problem, SolveError, Step};
use cellmech_fem::term::Term;

/// A curve request turned into DOFs.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveDofs {
    /// Column prefix.
    pub name: String,
    /// Component name (`x`, `y`, `z`).
    pub component: char,
    /// The DOFs of the node set in that component.
    pub dofs: Vec<usize>,
    /// +1 or -1.
    pub sign: f64,
}

impl CurveDofs {
    /// Its `curve.csv` columns (displacement, force): [`curve_columns`].
    pub fn columns(&self) -> [String; 2] {
        let component = match self.component {
            'x' => 0,
            'y' => 1,
            _ => 2,
        };
        curve_columns(&self.name, component)
    }
}

/// The shape of a node set along a test axis, reported per converged increment: its
/// extent along `axis`, its mean extent across it, and their ratio (columns
/// `<name>_length_axial_um`, `<name>_length_transverse_um`, `<name>_aspect_ratio`).
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeProbe {
    /// Column prefix.
    pub name: String,
    /// Nodes whose current positions are measured.
    pub nodes: Vec<usize>,
    /// Test axis (0, 1, 2).
    pub axis: usize,
}

impl ShapeProbe {
    /// Column names.
    pub fn columns(&self) -> [String; 3] {
        [
            format!("{}_length_axial_um", self.name),
            format!("{}_length_transverse_um", self.name),
            format!("{}_aspect_ratio", self.name),
        ]
    }

    /// Axial extent, mean transverse extent and aspect ratio in the current configuration
    /// `X + u` (NaN for an empty node set).
    pub fn measure(&self, reference: &[[f64; 3]], problem: &Problem) -> [f64; 3] {
        let map = problem.dof_map();
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for &n in &self.nodes {
            for c in 0..3 {
                let x = reference[n][c] + problem.u()[map.dof(n, c)];
                lo[c] = lo[c].min(x);
                hi[c] = hi[c].max(x);
            }
        }
        if self.nodes.is_empty() {
            return [f64::NAN; 3];
        }
        let extent = |c: usize| hi[c] - lo[c];
        let axial = extent(self.axis);
        let transverse = (0..3).filter(|&c| c != self.axis).map(extent).sum::<f64>() / 2.0;
        [axial, transverse, axial / transverse]
    }
}

/// An engine problem ready to run, with its steps.
pub struct BuiltModel {
    /// The problem (pattern and symbolic factorisation done).
    pub problem: Problem,
    /// Engine steps in order.
    pub steps: Vec<Step>,
    /// Curve DOFs.
    pub curves: Vec<CurveDofs>,
    /// Shape probes (the nucleus of a cell model).
    pub probes: Vec<ShapeProbe>,
    /// DOFs of a cell model's minimal supports: their largest reaction is reported as
    /// `support_reaction_max_nN` (it must stay ~0: the supports only remove rigid modes).
    pub support_dofs: Vec<usize>,
    /// What each embedding did.
    pub embedding: Vec<EmbedSummary>,
    /// Number of hanging nodes tied to their masters (a locally refined mesh).
    pub hanging_nodes: usize,
    /// Every enabled filament and where its elements are in the family terms.
    pub filaments: filaments::FilamentIndex,
    /// Filament families stress-free in the prestressed cell: what the first pass did.
    pub prestressed_reference: Option<PrestressedReferenceReport>,
}

/// The outcome of one [`EmbedSpec`], for `summary.json`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EmbedSummary {
    /// The spec's name.
    pub name: String,
    /// Nodes whose translations now follow a host.
    pub embedded_nodes: usize,
    /// Nodes that are host nodes themselves (already part of the continuum).
    pub shared_nodes: usize,
    /// Largest overshoot `max|ξ| − 1` of an embedded node outside its host (0: all inside).
    pub max_overshoot: f64,
}

/// Why a model could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// A continuum block is unsupported or has a bad element.
    #[error(transparent)]
    Continuum(#[from] cellmech_fem::continuum::ContinuumBlockError),
    /// A filament or membrane set was rejected.
    #[error(transparent)]
    Structures(#[from] structures::StructureBuildError),
    /// A rigid tool could not be set up.
    #[error(transparent)]
    Contact(#[from] cellmech_fem::contact::ContactError),
    /// The engine rejected the problem.
    #[error(transparent)]
    Solve(#[from] SolveError),
    /// A group's filament list does not match its elements.
    #[error("filaments: {0}")]
    Filaments(String),
    /// Embedded nodes could not be placed in their hosts.
    #[error("embedding '{name}': {message}")]
    Embed {
        /// The spec's name.
        name: String,
        /// What went wrong.
        message: String,
    },
    /// The prestressed geometry of filaments could not be found.
    #[error("filaments stress-free in the prestressed cell: {0}")]
    PrestressedReference(String),
    /// The hanging nodes of a refined mesh could not be tied.
    #[error("hanging nodes: {0}")]
    Hanging(#[from] HangingTieError),
    /// A tied node (hanging or embedded) is prescribed, but not all its masters move the
    /// same way, so the prescription would contradict the tie.
    #[error(
        "step '{step}': node {node} is tied to other nodes (a hanging or embedded node) and \
         its component {component} is prescribed, but its masters (nodes {masters:?}) do not \
         all get the same motion; prescribe that motion on them too (add them to the node \
         set) or leave the node out of the set"
    )]
    TiedNodePrescribed {
        /// The step.
        step: String,
        /// The tied node.
        node: usize,
        /// The component (0, 1, 2).
        component: usize,
        /// Its masters' nodes.
        masters: Vec<usize>,
    },
}

/// Builds the engine problem for `model`.
pub fn build(model: &ModelSpec) -> Result<BuiltModel, BuildError> {
    let mesh = &model.mesh;
    let structures = &model.structures;
    let dof_map = DofMap::with_counts(&structures::dofs_per_node(mesh.num_nodes(), structures));
    let mut terms: Vec<Box<dyn Term>> = Vec::new();
    for assignment in &model.materials {
        // The parser and the cell builders guarantee the block exists.
        if let Some(block) = mesh.block(&assignment.element_set) {
            terms.push(Box::new(ContinuumBlock::new(
                block,
                &mesh.nodes,
                assignment.law,
                assignment.formulation,
            )?));
        }
    }
    terms.extend(tools::contact_terms(model)?);
    let filaments = filaments::FilamentIndex::new(structures, mesh, terms.len())
        .map_err(BuildError::Filaments)?;
    let first_pass = model
        .prestressed_reference
        .as_ref()
        .map(|spec| prestressed_reference::first_pass(model, spec))
        .transpose()?
        .flatten();
    terms.extend(structures::structure_terms_carried(
        mesh,
        structures,
        &dof_map,
        first_pass.as_ref().map(|p| p.carried()).as_ref(),
    )?);
    let (ties, tie_summaries) = foundation_ties(model)?;
    terms.extend(ties);
    let (constraints, mut embedding) = constraints(model, &dof_map)?;
    embedding.extend(tie_summaries);
    let set = |name: &str| mesh.node_sets.get(name).map(Vec::as_slice).unwrap_or(&[]);
    let mut steps: Vec<Step> = model
        .steps
        .iter()
        .map(|s| {
            let mut step = engine_step(s, &set, &dof_map, constraints.as_ref())?;
            tools::apply_to_step(&mut step, s);
            Ok(step)
        })
        .collect::<Result<_, BuildError>>()?;
    if let (Some(pass), Some(first)) = (&first_pass, steps.first_mut()) {
        // Each increment of the first step starts from the first pass's state at its time,
        // in which the carried filaments sit on their moving stress-free geometry.
        first.guess = Some(pass.guess(&dof_map));
    }
    let curves = model
        .output
        .curves
        .iter()
        .map(|c| CurveDofs {
            name: c.name.clone(),
            component: ['x', 'y', 'z'][c.component],
            dofs: set(&c.node_set)
                .iter()
                .map(|&n| dof_map.dof(n, c.component))
                .collect(),
            sign: c.sign,
        })
        .collect();
    let probes = model
        .shape_probes
        .iter()
        .map(|p| ShapeProbe {
            name: p.name.clone(),
            nodes: set(&p.node_set).to_vec(),
            axis: p.axis,
        })
        .collect();
    let support_dofs = model
        .supports
        .iter()
        .flat_map(|(name, comps)| {
            set(name)
                .iter()
                .flat_map(|&n| (0..3).filter(|&c| comps[c]).map(move |c| (n, c)))
                .collect::<Vec<_>>()
        })
        .map(|(n, c)| dof_map.dof(n, c))
        .collect();
    let solver = Box::new(FaerSparseSolver::default().with_mixed_precision(true));
    let mut problem = match constraints {
        Some(c) => Problem::with_constraints(dof_map, terms, c, solver)?,
        None => Problem::new(dof_map, terms, solver)?,
    };
    problem.set_relaxation_blocks(structures::relaxation_blocks(
        mesh,
        structures,
        problem.dof_map(),
    ));
    let (lo, hi) = mesh.bounding_box();
    problem.set_length_scale((0..3).map(|i| (hi[i] - lo[i]).powi(2)).sum::<f64>().sqrt());
    Ok(BuiltModel {
        problem,
        steps,
        curves,
        probes,
        support_dofs,
        embedding,
        hanging_nodes: model.hanging.len(),
        filaments,
        prestressed_reference: first_pass.map(|p| p.report),
    })
}

/// The linear constraints of the model (`None` without any): the hanging-node ties first,
/// then the embeddings, whose host weights on hanging nodes are expanded through the ties
/// (masters are never slaves).
fn constraints(
    model: &ModelSpec,
    dof_map: &DofMap,
) -> Result<(Option<LinearConstraints>, Vec<EmbedSummary>), BuildError> {
    let exact = || {
        model
            .embedded
            .iter()
            .filter(|s| s.foundation_modulus.is_none())
    };
    if exact().next().is_none() && model.hanging.is_empty() {
        return Ok((None, Vec::new()));
    }
    let mut constraints = LinearConstraints::new(dof_map.num_dofs());
    tie_hanging_nodes(&mut constraints, dof_map, &model.hanging)?;
    let mesh = &model.mesh;
    let used = structures::enabled_structure_nodes(&model.structures, mesh.num_nodes());
    let mut summaries = Vec::new();
    for spec in exact() {
        let fail = |message: String| BuildError::Embed {
            name: spec.name.clone(),
            message,
        };
        let (locator, nodes) = embedding_hosts(mesh, spec, &used).map_err(fail)?;
        let report = embed_translations_over_ball(
            &mut constraints,
            &locator,
            dof_map,
            &mesh.nodes,
            &nodes,
            spec.radius,
            spec.tolerance,
        )
        .map_err(|e| fail(e.to_string()))?;
        report
            .require_all_hosted()
            .map_err(|e| fail(e.to_string()))?;
        summaries.push(EmbedSummary {
            name: spec.name.clone(),
            embedded_nodes: report.embedded.len(),
            shared_nodes: report.shared.len(),
            max_overshoot: report.max_overshoot,
        });
    }
    Ok((Some(constraints), summaries))
}

/// The host locator of an embedding and the nodes of its node set that an enabled structure
/// uses (the nodes of a switched-off family are not embedded).
fn embedding_hosts(
    mesh: &cellmech_fem::mesh::Mesh,
    spec: &EmbedSpec,
    used: &[bool],
) -> Result<(HostLocator, Vec<usize>), String> {
    let blocks: Vec<&str> = spec.host_blocks.iter().map(String::as_str).collect();
    let locator = HostLocator::new(mesh, &blocks).map_err(|e| e.to_string())?;
    let nodes = mesh
        .node_sets
        .get(&spec.node_set)
        .map(|set| set.iter().copied().filter(|&n| used[n]).collect())
        .unwrap_or_default();
    Ok((locator, nodes))
}

/// The elastic ties of the embeddings with a foundation modulus, one [`HostTieSet`] per
/// spec, with their summaries. A tie's stiffness is the modulus times half the reference
/// length of every enabled structure element through the node.
fn foundation_ties(
    model: &ModelSpec,
) -> Result<(Vec<Box<dyn Term>>, Vec<EmbedSummary>), BuildError> {
    let mesh = &model.mesh;
    let mut terms: Vec<Box<dyn Term>> = Vec::new();
    let mut summaries = Vec::new();
    let specs: Vec<&EmbedSpec> = model
        .embedded
        .iter()
        .filter(|s| s.foundation_modulus.is_some())
        .collect();
    if specs.is_empty() {
        return Ok((terms, summaries));
    }
    let used = structures::enabled_structure_nodes(&model.structures, mesh.num_nodes());
    let tributary = structures::enabled_tributary_lengths(&model.structures, mesh);
    for spec in specs {
        let modulus = spec.foundation_modulus.unwrap_or(0.0);
        let fail = |message: String| BuildError::Embed {
            name: spec.name.clone(),
            message,
        };
        if !(modulus.is_finite() && modulus > 0.0) {
            return Err(fail(format!(
                "expected a positive foundation modulus; found {modulus} kPa"
            )));
        }
        let (locator, nodes) = embedding_hosts(mesh, spec, &used).map_err(fail)?;
        let mut ties = Vec::with_capacity(nodes.len());
        let (mut shared, mut max_overshoot) = (0, 0.0f64);
        for &n in &nodes {
            if locator.is_host_node(n) {
                // Already part of the continuum: it moves with it.
                shared += 1;
                continue;
            }
            let host = locator
                .locate(mesh.nodes[n], spec.tolerance)
                .map_err(|e| fail(e.to_string()))?;
            max_overshoot = max_overshoot.max(host.overshoot);
            ties.push(HostTie::new(
                n,
                host.nodes,
                host.weights(),
                modulus * tributary[n],
            ));
        }
        summaries.push(EmbedSummary {
            name: spec.name.clone(),
            embedded_nodes: ties.len(),
            shared_nodes: shared,
            max_overshoot,
        });
        terms.push(Box::new(HostTieSet::new(
            format!("{}_ties", spec.name),
            ties,
        )));
    }
    Ok((terms, summaries))
}

/// The engine step of `spec`. A prescribed tied DOF (slave) is dropped when all its masters
/// get the same motion (it then follows them exactly: the weights sum to 1), and is an
/// error otherwise; a load on a slave goes to its masters.
fn engine_step<'a>(
    spec: &StepSpec,
    set: &impl Fn(&str) -> &'a [usize],
    dofs: &DofMap,
    constraints: Option<&LinearConstraints>,
) -> Result<Step, BuildError> {
    let mut step = Step::new(spec.name.clone());
    step.control = spec.control;
    let mut motion: std::collections::BTreeMap<usize, Motion> = Default::default();
    for (name, comps) in &spec.fixes {
        for &node in set(name) {
            for c in (0..3).filter(|&c| comps[c]) {
                motion.entry(dofs.dof(node, c)).or_insert(Motion::Hold);
            }
        }
    }
    for (name, c, value) in &spec.displacements {
        for &node in set(name) {
            motion.insert(dofs.dof(node, *c), Motion::By(*value));
        }
    }
    if let Some(constraints) = constraints {
        let slaves: Vec<(usize, Motion)> = motion
            .iter()
            .filter(|(&d, _)| constraints.is_slave(d))
            .map(|(&d, &m)| (d, m))
            .collect();
        for (slave, m) in slaves {
            let Some((masters, weights)) = constraints.masters_of(slave) else {
                continue;
            };
            let follows = masters.iter().all(|d| motion.get(d) == Some(&m))
                && (weights.iter().sum::<f64>() - 1.0).abs() <= 1e-12;
            if !follows {
                let (node, component) = dofs.node_of(slave);
                let mut nodes: Vec<usize> = masters.iter().map(|&d| dofs.node_of(d).0).collect();
                nodes.dedup();
                return Err(BuildError::TiedNodePrescribed {
                    step: spec.name.clone(),
                    node,
                    component,
                    masters: nodes,
                });
            }
            motion.remove(&slave);
        }
    }
    step.prescribed = motion.into_iter().collect();
    for (name, c, total) in &spec.forces {
        let nodes = set(name);
        for &node in nodes {
            let dof = dofs.dof(node, *c);
            let value = total / nodes.len() as f64;
            match constraints {
                Some(t) => step.loads.extend(
                    t.distribute(dof, value)
                        .into_iter()
                        .map(|(dof, value)| NodalLoad { dof, value }),
                ),
                None => step.loads.push(NodalLoad { dof, value }),
            }
        }
    }
    Ok(step)
}
