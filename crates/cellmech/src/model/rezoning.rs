//! ALE rezoning between the steps of a model: the nodes of a continuum region near a
//! point (an indenter's contact) move to a smooth mesh of the current body and the
//! solution is mapped onto them (`cellmech_fem::rezone`, `docs/rezoning.md`).
//!
//! Only nodes of the rezoned blocks whose every term follows moved reference positions
//! may move (continuum, membrane, frictionless contact): not an interface to another
//! material, not a filament node, not a node prescribed in any step, not a host of an
//! embedded node. Free-surface nodes slide along the surface.

use cellmech_fem::rezone::{rezone, Acceptance, RezoneInput};
use cellmech_fem::solve::Problem;

use super::spec::ModelSpec;
use super::BuiltModel;

/// Where and when to rezone (plain data, part of [`ModelSpec`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RezoneSpec {
    /// The continuum blocks whose nodes may move (one material, e.g. `cytoplasm`).
    pub blocks: Vec<String>,
    /// Node set of the free surface: its nodes only slide along the surface.
    pub surface_set: String,
    /// The free surface's quad faces (leaf faces), along which its nodes slide.
    pub surface_faces: Vec<[usize; 4]>,
    /// The region is centred on this node's current position (a surface node, which stays:
    /// the indenter's stagnation point)...
    pub center_node: usize,
    /// ...and holds the nodes within this distance of it, in the current configuration (µm).
    pub radius: f64,
    /// Rezone after these steps (indices into the model's steps).
    pub after_steps: Vec<usize>,
    /// Whether the free surface's nodes slide along it (else they stay material).
    pub slide_surface: bool,
    /// Which rezonings are applied.
    pub acceptance: Acceptance,
}

/// What one rezoning did, for `summary.json`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RezoneRecord {
    /// The step after which it ran.
    pub after_step: String,
    /// Nodes moved (hanging nodes that followed their masters included).
    pub nodes_moved: usize,
    /// Elements whose reference changed.
    pub elements_touched: usize,
    /// Smallest corner Jacobian ratio of those elements, before and after.
    pub min_corner_ratio_before: f64,
    /// The same after.
    pub min_corner_ratio_after: f64,
    /// Fraction of the harmonic mesh motion applied (halved until it improved the mesh).
    pub motion_fraction: f64,
    /// Nodes whose new position lay outside the material (left in place).
    pub unlocated: usize,
    /// Conjugate-gradient iterations of the mesh-motion solve.
    pub cg_iterations: usize,
    /// Wall time (s).
    pub time_s: f64,
}

impl RezoneRecord {
    /// Columns of `rezonings.csv`, one row per rezoning.
    pub const COLUMNS: [&'static str; 9] = [
        "after_step",
        "nodes_moved",
        "elements_touched",
        "min_corner_ratio_before",
        "min_corner_ratio_after",
        "motion_fraction",
        "unlocated",
        "cg_iterations",
        "time_s",
    ];

    /// This record as a row of [`RezoneRecord::COLUMNS`] (`step`: the step's index).
    pub fn row(&self, step: usize) -> [f64; 9] {
        [
            step as f64,
            self.nodes_moved as f64,
            self.elements_touched as f64,
            self.min_corner_ratio_before,
            self.min_corner_ratio_after,
            self.motion_fraction,
            self.unlocated as f64,
            self.cg_iterations as f64,
            self.time_s,
        ]
    }
}

/// A model's rezoning, ready to run between steps.
pub struct Rezoner {
    spec: RezoneSpec,
    elements: Vec<[usize; 8]>,
    hanging: Vec<(usize, Vec<(usize, f64)>)>,
    /// Nodes that may move wherever the region is.
    eligible: Vec<bool>,
    /// Free-surface nodes (they slide).
    surface: Vec<bool>,
}

impl Rezoner {
    /// The rezoning of `model` as built in `built` (`None` when the model asks for none).
    pub fn new(model: &ModelSpec, built: &BuiltModel) -> Result<Option<Self>, String> {
        let Some(spec) = &model.rezone else {
            return Ok(None);
        };
        let mut elements = Vec::new();
        for name in &spec.blocks {
            let block = model
                .mesh
                .block(name)
                .ok_or_else(|| format!("rezoning: no element block '{name}' in the mesh"))?;
            if block.kind != cellmech_fem::mesh::ElementKind::Hex8 {
                return Err(format!(
                    "rezoning: block '{name}' holds {} elements; only hex8 can be rezoned",
                    block.kind.name()
                ));
            }
            elements.extend(block.elements().map(|e| std::array::from_fn(|a| e[a])));
        }
        let problem = &built.problem;
        let mut eligible = problem.nodes_following_reference_moves();
        let mut in_blocks = vec![false; eligible.len()];
        for &n in elements.iter().flatten() {
            in_blocks[n] = true;
        }
        for block in &model.mesh.blocks {
            if block.kind == cellmech_fem::mesh::ElementKind::Hex8
                && !spec.blocks.contains(&block.name)
            {
                for &n in &block.connectivity {
                    in_blocks[n] = false;
                }
            }
        }
        for (e, ok) in eligible.iter_mut().zip(&in_blocks) {
            *e &= *ok;
        }
        let mut surface = vec![false; eligible.len()];
        for &n in
            model.mesh.node_sets.get(&spec.surface_set).ok_or_else(|| {
                format!("rezoning: no node set '{}' in the mesh", spec.surface_set)
            })?
        {
            surface[n] = true;
        }
        for step in &built.steps {
            for &(dof, _) in &step.prescribed {
                eligible[problem.dof_map().node_of(dof).0] = false;
            }
        }
        let hanging = model
            .hanging
            .iter()
            .map(|h| (h.node, h.masters.clone()))
            .collect();
        Ok(Some(Self {
            spec: spec.clone(),
            elements,
            hanging,
            eligible,
            surface,
        }))
    }

    /// Whether to rezone after step `index`.
    pub fn after(&self, index: usize) -> bool {
        self.spec.after_steps.contains(&index)
    }

    /// Rezones the problem's region now: moves the nodes, maps the solution, updates
    /// `reference` (every node's reference position) and returns what it did, or `None`
    /// when the mesh there could not be improved.
    pub fn rezone(
        &self,
        step_name: &str,
        problem: &mut Problem,
        reference: &mut [[f64; 3]],
    ) -> Result<Option<(RezoneRecord, Vec<cellmech_fem::rezone::NodeRemap>)>, String> {
        let start = std::time::Instant::now();
        let map = problem.dof_map();
        let current: Vec<[f64; 3]> = (0..reference.len())
            .map(|n| std::array::from_fn(|c| reference[n][c] + problem.u()[map.dof(n, c)]))
            .collect();
        let center = current[self.spec.center_node];
        let in_region: Vec<bool> = (0..reference.len())
            .map(|n| {
                self.eligible[n]
                    && (0..3)
                        .map(|c| (current[n][c] - center[c]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                        <= self.spec.radius
            })
            .collect();
        let movable: Vec<bool> = (0..reference.len())
            .map(|n| in_region[n] && !self.surface[n])
            .collect();
        // The centre node stays: under an indenter it is the stagnation point, the one
        // material point of the surface that never moves relative to the tip (slid off the
        // axis it would leave the tip's nose between nodes).
        let sliding: Vec<bool> = (0..reference.len())
            .map(|n| {
                self.spec.slide_surface
                    && in_region[n]
                    && self.surface[n]
                    && n != self.spec.center_node
            })
            .collect();
        let input = RezoneInput {
            reference,
            current: &current,
            elements: &self.elements,
            movable: &movable,
            hanging: &self.hanging,
            surface_faces: &self.spec.surface_faces,
            sliding: &sliding,
        };
        let Some(rezoning) = rezone(&input, self.spec.acceptance).map_err(|e| e.to_string())?
        else {
            return Ok(None);
        };
        let new_reference: Vec<[f64; 3]> = {
            let mut r = reference.to_vec();
            for remap in &rezoning.remaps {
                r[remap.node] = remap.apply(reference);
            }
            r
        };
        problem.remap_nodes(&rezoning.remaps, &new_reference)?;
        reference.copy_from_slice(&new_reference);
        let record = RezoneRecord {
            after_step: step_name.to_string(),
            nodes_moved: rezoning.remaps.len(),
            elements_touched: rezoning.elements_touched,
            min_corner_ratio_before: rezoning.min_corner_ratio_before,
            min_corner_ratio_after: rezoning.min_corner_ratio_after,
            motion_fraction: rezoning.motion_fraction,
            unlocated: rezoning.unlocated,
            cg_iterations: rezoning.cg_iterations,
            time_s: start.elapsed().as_secs_f64(),
        };
        Ok(Some((record, rezoning.remaps)))
    }
}
