//! Contact between a body's surface and rigid tools whose pilot point follows a load program.
//!
//! Point-to-rigid-surface contact, the points being the surface nodes
//! ([`RigidContact::new`]) or Gauss points of the surface faces ([`RigidContact::on_faces`],
//! each point x = Σ N_a x_a spread on its face's nodes), enforced by the augmented Lagrangian method (a penalty
//! with Uzawa multiplier updates until the penetration is below a stated tolerance):
//!
//! * frictionless: Π_i = (λ_i − ε φ(x_i))² / (2ε) for the nodes of the active set, φ the
//!   tool's gap function; the multiplier update is λ ← ⟨λ − ε φ⟩₊; separation is allowed;
//! * bonded: a node that touches the tool at a converged increment is tied from then on to
//!   the tool point it touched: Π_i = λ_i·d_i + ε|d_i|²/2, d_i = x_i − (ξ_i + c(t)), the
//!   update λ ← λ + ε d; it transmits tension.
//!
//! The frictionless active set is held fixed during Newton's iterations and updated between
//! them, in the same pass as the multipliers (the contact-status iterations of implicit FE codes): a free
//! node enters it when it penetrates deeper than the tolerance, an active node leaves it
//! when it pulls on the tool harder than the penalty force of that tolerance (ε·tol).
//! Inside one Newton solve the contact law is then smooth and Newton converges
//! quadratically; with the law re-evaluated at every iteration instead, a node on the
//! steep flank of a sharp AFM tip was pushed out in one iteration and fell back in at the
//! next, and Newton cycled. Before each increment, the free nodes the moved tool reaches
//! from where they were join the set (a status predictor). The band of ±tolerance between
//! entering and leaving is the same accuracy the penetration tolerance already grants, and
//! stops status cycles.
//!
//! The tangent of an active frictionless node is ε∇φ⊗∇φ − p̄∇²φ with p̄ = min(p, p_eq),
//! p_eq the node's pressure at the last converged Newton state (0 for a node that was free
//! there). The curvature term −p∇²φ is a negative stiffness across the normal of a curved
//! tool (a node pressed onto a convex tip would slide off if the material did not hold it);
//! with a trial pressure far above equilibrium it outweighed the material under the AFM tip
//! and Newton's corrections inverted elements. Capped at p_eq it is exact at equilibrium
//! and never more negative than at a state known to be stable. The cap is lifted once
//! Newton reports the residual near equilibrium ([`crate::term::Term::set_near_equilibrium`]): the
//! trial pressures are then close to their converged values, and the exact term makes the
//! last iterations quadratic where the cap left them linear (a rate of 0.7–0.9 per
//! iteration under the AFM tip, where the material's hold across the normal is small).
//! `docs/tools.md` has the measurements.
//!
//! Each node couples only with itself, so contact opening or closing never changes the
//! sparsity pattern or the symbolic factorisation.
//!
//! [`RigidContact`] is an [`ElementSet`] with one element per contact node or face; its load
//! program, multipliers and bonds are moved by the set's hooks (`on_load_state`,
//! `on_converged`, `on_commit`, `on_rollback`), which the `Term` adapter forwards.

mod tip_surface;
mod tool;

pub use tool::{Gap, ToolShape};

use tip_surface::{TipPair, ToolPoints};

use crate::dof::DofMap;
use crate::element::{ElementSet, KernelError};
use crate::math::vec3::{dot, norm};
use crate::term::{Augmentation, LoadState};

/// How the tool holds the nodes it touches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum ContactKind {
    /// Unilateral, no friction, separation allowed.
    Frictionless,
    /// A node that has touched sticks to the tool from then on.
    Bonded,
}

/// Which pressure the tangent's curvature term −p∇²φ of an active node uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum CurvatureTangent {
    /// min(p, p_eq), p_eq the node's pressure at the last converged Newton state: exact at
    /// equilibrium, never more negative than there; p itself once Newton is near
    /// equilibrium (module notes). The default.
    #[default]
    Lagged,
    /// The current trial pressure p: the exact derivative of the residual everywhere.
    Consistent,
}

/// The state that changes as a transaction (trial → commit, or rollback).
#[derive(Debug, Clone, PartialEq)]
struct ContactState {
    offset: [f64; 3],
    lambda: Vec<f64>,
    /// Frictionless active set (held during Newton, updated in `on_converged`).
    active: Vec<bool>,
    /// Contact pressure of each node at the last converged Newton state (0 for a node that
    /// was not active there): caps the pressure in the tangent's curvature term.
    equilibrium_pressure: Vec<f64>,
    anchors: Vec<Option<[f64; 3]>>,
    bond_lambda: Vec<[f64; 3]>,
    /// Second pass: per face of [`RigidContact::with_tool_points_on_faces`], the tool points
    /// pressing on it (held during Newton, updated in `on_converged`).
    pairs: Vec<Vec<TipPair>>,
}

/// A rigid tool in contact with a node set.
#[derive(Debug, Clone)]
pub struct RigidContact {
    name: String,
    shape: ToolShape,
    kind: ContactKind,
    /// The nodes of every contact element, flat: element e owns
    /// `nodes[node_starts[e]..node_starts[e + 1]]` (one node, or a face's four).
    nodes: Vec<usize>,
    /// Reference coordinates of `nodes`.
    reference: Vec<[f64; 3]>,
    node_starts: Vec<usize>,
    /// Contact points of element e: `point_starts[e]..point_starts[e + 1]`.
    point_starts: Vec<usize>,
    /// The element of each contact point.
    point_element: Vec<usize>,
    /// Shape-function weights of each point on its element's nodes (the first
    /// `node_starts[e + 1] − node_starts[e]` are used).
    weights: Vec<[f64; 4]>,
    /// Penalty factor of each point: its share of the surface (1 for a node).
    scale: Vec<f64>,
    penalty: f64,
    tolerance: f64,
    program: Vec<[f64; 3]>,
    trial: ContactState,
    committed: ContactState,
    /// A trial state kept within an increment ([`Term::save_trial`]).
    saved_trial: Option<ContactState>,
    /// Positions of the contact points at the last committed increment (the reference ones
    /// before the first): what [`RigidContact::min_gap`] measures against.
    committed_positions: Vec<[f64; 3]>,
    curvature_tangent: CurvatureTangent,
    /// Newton is near equilibrium ([`crate::term::Term::set_near_equilibrium`]): the lagged curvature
    /// term takes the trial pressure (exact) instead of its cap.
    near_equilibrium: bool,
    /// Body nodes watched for lying inside the tool, without contact forces
    /// ([`RigidContact::with_watched_nodes`]): node and reference position.
    watched: Vec<(usize, [f64; 3])>,
    last_step: usize,
    /// The step whose start offset is recorded in `step_start`.
    started_step: Option<usize>,
    /// Pilot-point displacement where the current step started: a step may have ended early
    /// (stop condition), so the next one moves on from there by its own program increment.
    step_start: [f64; 3],
    /// Where the tool is aimed ([`RigidContact::aimed_at`]), if anywhere.
    aim: Option<Aim>,
    /// The second pass: the tool's own surface points against body faces
    /// ([`RigidContact::with_tool_points_on_faces`]), if any.
    tool_points: Option<ToolPoints>,
}

/// A tool aimed at a body node: at the start of `step` the pilot point is moved across the
/// step's motion by the node's displacement across it, so the tool comes down over where
/// the node is then rather than where it was in the reference configuration (an AFM tip
/// positioned over a focal adhesion of the prestressed cell).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Aim {
    node: usize,
    step: usize,
    /// The node's displacement at the last committed increment (µm).
    committed: [f64; 3],
}

/// Why a contact could not be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContactError {
    /// The contact node set is empty.
    #[error("tool '{0}': the contact node set is empty")]
    NoNodes(String),
    /// Bad tool geometry.
    #[error("tool '{tool}': {message}")]
    Shape {
        /// Tool name.
        tool: String,
        /// What is wrong.
        message: String,
    },
    /// A contact face is degenerate or names a node without coordinates.
    #[error("tool '{tool}': contact face {face}: {message}")]
    Face {
        /// Tool name.
        tool: String,
        /// Index of the face.
        face: usize,
        /// What is wrong.
        message: String,
    },
    /// Bad penalty or tolerance.
    #[error(
        "tool '{tool}': the penalty ({penalty} nN/um) and tolerance ({tolerance} um) must be > 0"
    )]
    Parameters {
        /// Tool name.
        tool: String,
        /// Penalty ε.
        penalty: f64,
        /// Penetration tolerance.
        tolerance: f64,
    },
}

impl RigidContact {
    /// A tool `shape` acting on `nodes` (with reference coordinates `reference`), with
    /// penalty ε (nN/µm), penetration tolerance (µm), and the pilot-point displacement at the
    /// end of each analysis step (`program[k]`; steps past the end hold the last value).
    /// Step k moves the tool by `program[k] - program[k-1]` from where step k-1 actually
    /// ended (earlier than its program when a stop condition ended it).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: impl Into<String>,
        shape: ToolShape,
        kind: ContactKind,
        nodes: Vec<usize>,
        reference: Vec<[f64; 3]>,
        penalty: f64,
        tolerance: f64,
        program: Vec<[f64; 3]>,
    ) -> Result<Self, ContactError> {
        let name = name.into();
        check_setup(&name, nodes.is_empty(), &shape, penalty, tolerance)?;
        let n = nodes.len();
        Ok(Self::assemble(
            name,
            shape,
            kind,
            (nodes, reference, (0..=n).collect()),
            (
                (0..=n).collect(),
                vec![[1.0, 0.0, 0.0, 0.0]; n],
                vec![1.0; n],
            ),
            (penalty, tolerance),
            program,
        ))
    }

    /// A tool `shape` acting on the surface `faces` (bilinear quads, corners in cyclic
    /// order, `coordinates[node]` their reference positions) through `points_per_side`²
    /// Gauss points per face (1 to 4): a point-to-rigid-surface contact whose points lie
    /// between the nodes too, so a tool sharper than the mesh cannot slip between the nodes
    /// of a face into the body, as it does with node contact. Each point's penalty is
    /// `penalty` × its share of the surface (its Gauss weight × area over the mean face
    /// area): a face takes about the penalty of one node. Other arguments as in
    /// [`RigidContact::new`].
    #[allow(clippy::too_many_arguments)]
    pub fn on_faces(
        name: impl Into<String>,
        shape: ToolShape,
        kind: ContactKind,
        faces: &[[usize; 4]],
        coordinates: &[[f64; 3]],
        points_per_side: usize,
        penalty: f64,
        tolerance: f64,
        program: Vec<[f64; 3]>,
    ) -> Result<Self, ContactError> {
        let name = name.into();
        check_setup(&name, faces.is_empty(), &shape, penalty, tolerance)?;
        let face_error = |face: usize, message: String| ContactError::Face {
            tool: name.clone(),
            face,
            message,
        };
        let rule = gauss_rule(points_per_side).ok_or_else(|| {
            face_error(
                0,
                format!("expected 1 to 4 points per side; found {points_per_side}"),
            )
        })?;
        let mut nodes = Vec::with_capacity(4 * faces.len());
        let mut reference = Vec::with_capacity(4 * faces.len());
        let mut node_starts = vec![0];
        let mut point_starts = vec![0];
        let (mut weights, mut areas) = (Vec::new(), Vec::new());
        for (f, face) in faces.iter().enumerate() {
            let x: [[f64; 3]; 4] =
                std::array::from_fn(|a| coordinates.get(face[a]).copied().unwrap_or([f64::NAN; 3]));
            if x.iter().flatten().any(|v| !v.is_finite()) {
                return Err(face_error(
                    f,
                    format!("expected nodes with finite coordinates; found {face:?}"),
                ));
            }
            for (&(xi, wx), &(eta, wy)) in
                rule.iter().flat_map(|a| rule.iter().map(move |b| (a, b)))
            {
                let (n, dxi, deta) = quad_shape(xi, eta);
                let t1: [f64; 3] = std::array::from_fn(|i| (0..4).map(|a| dxi[a] * x[a][i]).sum());
                let t2: [f64; 3] = std::array::from_fn(|i| (0..4).map(|a| deta[a] * x[a][i]).sum());
                let area = norm(&crate::math::vec3::cross(&t1, &t2));
                if !(area > 0.0) {
                    return Err(face_error(
                        f,
                        format!("expected a face of positive area; found {face:?} at {x:?}"),
                    ));
                }
                weights.push(n);
                areas.push(wx * wy * area);
            }
            nodes.extend_from_slice(face);
            reference.extend_from_slice(&x);
            node_starts.push(nodes.len());
            point_starts.push(weights.len());
        }
        let mean_face = areas.iter().sum::<f64>() / faces.len() as f64;
        let scale = areas.iter().map(|a| a / mean_face).collect();
        Ok(Self::assemble(
            name,
            shape,
            kind,
            (nodes, reference, node_starts),
            (point_starts, weights, scale),
            (penalty, tolerance),
            program,
        ))
    }

    #[allow(clippy::type_complexity)]
    fn assemble(
        name: String,
        shape: ToolShape,
        kind: ContactKind,
        (nodes, reference, node_starts): (Vec<usize>, Vec<[f64; 3]>, Vec<usize>),
        (point_starts, weights, scale): (Vec<usize>, Vec<[f64; 4]>, Vec<f64>),
        (penalty, tolerance): (f64, f64),
        program: Vec<[f64; 3]>,
    ) -> Self {
        let n = weights.len();
        let state = ContactState {
            offset: [0.0; 3],
            lambda: vec![0.0; n],
            active: vec![false; n],
            equilibrium_pressure: vec![0.0; n],
            anchors: vec![None; n],
            bond_lambda: vec![[0.0; 3]; n],
            pairs: Vec::new(),
        };
        let point_element = (0..node_starts.len() - 1)
            .flat_map(|e| std::iter::repeat_n(e, point_starts[e + 1] - point_starts[e]))
            .collect();
        let mut contact = RigidContact {
            name,
            shape,
            kind,
            nodes,
            reference,
            node_starts,
            point_starts,
            point_element,
            weights,
            scale,
            committed_positions: Vec::new(),
            curvature_tangent: CurvatureTangent::default(),
            near_equilibrium: false,
            watched: Vec::new(),
            penalty,
            tolerance,
            program,
            trial: state.clone(),
            committed: state,
            saved_trial: None,
            last_step: 0,
            started_step: None,
            step_start: [0.0; 3],
            aim: None,
            tool_points: None,
        };
        contact.committed_positions = (0..n)
            .map(|q| contact.point_position(q, |_, _| 0.0))
            .collect();
        contact
    }

    /// The same contact, also watching `nodes` (node, reference position; typically the
    /// interior nodes near where the tool presses) for lying inside the tool: they get no
    /// contact force, but [`ToolScalar::DeepestWatchedNode`] reports how deep the deepest of
    /// them is. A node inside a frictionless tool that only meets the surface means the
    /// tool has passed between the surface's contact points into the body: the
    /// discretisation's limit, not the physics.
    pub fn with_watched_nodes(mut self, nodes: Vec<(usize, [f64; 3])>) -> Self {
        self.watched = nodes;
        self
    }

    /// The same contact made two-pass: besides the body's points on the tool, points of the
    /// tool's own surface about `spacing` apart, out to `extent` from its axis, are kept out
    /// of the body's `faces` (bilinear quads, corners counter-clockwise seen from outside the
    /// body, `coordinates[node]` their reference positions). A tool sharper than the faces
    /// it has stretched then cannot pass between their nodes into the body (module
    /// `tip_surface`). Each tool point has the penalty of one contact node; a point enters
    /// a face's pairs when it lies behind the face by less than the tool's radius. Only an
    /// indenter with an axis (the paraboloid) has surface points.
    pub fn with_tool_points_on_faces(
        mut self,
        faces: &[[usize; 4]],
        coordinates: &[[f64; 3]],
        spacing: f64,
        extent: f64,
    ) -> Result<Self, ContactError> {
        let shape_error = |message: String| ContactError::Shape {
            tool: self.name.clone(),
            message,
        };
        let ToolShape::Paraboloid {
            apex,
            axis,
            tip_radius,
        } = self.shape
        else {
            return Err(shape_error(
                "only a paraboloid tip has surface points for a two-pass contact".into(),
            ));
        };
        if !(spacing > 0.0 && spacing.is_finite() && extent >= 0.0 && extent.is_finite()) {
            return Err(shape_error(format!(
                "expected a tool-point spacing > 0 and an extent >= 0; found {spacing} and \
                 {extent} um"
            )));
        }
        if self.tool_points.is_some() {
            return Err(shape_error("the tool already has surface points".into()));
        }
        let first_element = self.element_count();
        for (f, face) in faces.iter().enumerate() {
            let x: [[f64; 3]; 4] =
                std::array::from_fn(|a| coordinates.get(face[a]).copied().unwrap_or([f64::NAN; 3]));
            if x.iter().flatten().any(|v| !v.is_finite()) {
                return Err(ContactError::Face {
                    tool: self.name.clone(),
                    face: f,
                    message: format!("expected nodes with finite coordinates; found {face:?}"),
                });
            }
            self.nodes.extend_from_slice(face);
            self.reference.extend_from_slice(&x);
            self.node_starts.push(self.nodes.len());
            self.point_starts.push(self.weights.len());
        }
        let pairs = vec![Vec::new(); faces.len()];
        self.trial.pairs = pairs.clone();
        self.committed.pairs = pairs;
        self.tool_points = Some(ToolPoints::new(
            first_element,
            tip_surface::paraboloid_points(&apex, &axis, tip_radius, spacing, extent),
            self.penalty,
            tip_radius,
        ));
        Ok(self)
    }

    /// Number of points on the tool's own surface (0 without a second pass).
    pub fn tool_point_count(&self) -> usize {
        self.tool_points.as_ref().map_or(0, |t| t.points.len())
    }

    /// Number of (face, tool point) pairs of the second pass pressing now (trial state).
    pub fn tool_pair_count(&self) -> usize {
        self.trial.pairs.iter().map(Vec::len).sum()
    }

    /// Current corners of second-pass face `f`.
    fn tool_face_corners(
        &self,
        tool: &ToolPoints,
        f: usize,
        u: &[f64],
        dof_map: &DofMap,
    ) -> [[f64; 3]; 4] {
        let first = self.node_starts[tool.first_element + f];
        std::array::from_fn(|a| {
            std::array::from_fn(|i| {
                self.reference[first + a][i] + u[dof_map.dof(self.nodes[first + a], i)]
            })
        })
    }

    /// Current position of tool point `q`.
    fn tool_point(&self, tool: &ToolPoints, q: usize) -> [f64; 3] {
        std::array::from_fn(|i| tool.points[q][i] + self.trial.offset[i])
    }

    /// Second-pass status update at `u` (see `tip_surface`). With `settle` (a converged
    /// state), each pair's pressure is recorded, pairs that pull or whose point projects onto none of their face's
    /// triangles leave, and pairs move to the triangle their point now projects into; then
    /// tool points behind a face by more than the tolerance (and less than the reach) enter.
    /// Returns how many pairs entered, left or moved.
    fn update_tool_pairs(&mut self, u: &[f64], dof_map: &DofMap, settle: bool) -> usize {
        let Some(tool) = self.tool_points.take() else {
            return 0;
        };
        let (eps, tol) = (tool.penalty, self.tolerance);
        let mut changed = 0;
        let mut pairs = std::mem::take(&mut self.trial.pairs);
        let corners: Vec<[[f64; 3]; 4]> = (0..pairs.len())
            .map(|f| self.tool_face_corners(&tool, f, u, dof_map))
            .collect();
        // Boxes of the faces, grown by the reach.
        let boxes: Vec<([f64; 3], [f64; 3])> = corners
            .iter()
            .map(|x| {
                let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for c in x {
                    for i in 0..3 {
                        lo[i] = lo[i].min(c[i] - tool.reach);
                        hi[i] = hi[i].max(c[i] + tool.reach);
                    }
                }
                (lo, hi)
            })
            .collect();
        // Pairs whose point has slid off their face, to be handed to the face it is on now.
        let mut sliding: Vec<(usize, TipPair)> = Vec::new();
        for (f, face_pairs) in pairs.iter_mut().enumerate() {
            if !settle || face_pairs.is_empty() {
                continue;
            }
            let x = &corners[f];
            let mut kept = Vec::with_capacity(face_pairs.len());
            for mut pair in face_pairs.drain(..) {
                let s = self.tool_point(&tool, pair.point);
                let projection = tip_surface::triangle_projection(&s, x, pair.triangle);
                let gap = projection.map_or(f64::INFINITY, |(_, g, _)| g);
                let p = pair.lambda - eps * gap;
                pair.equilibrium_pressure = p.max(0.0);
                if !(p >= -eps * tol) {
                    changed += 1;
                    continue;
                }
                let keeps = projection
                    .is_some_and(|(bary, ..)| tip_surface::within(&bary, tip_surface::KEEP_MARGIN));
                if !keeps {
                    changed += 1;
                    match tip_surface::projecting_triangle(&s, x) {
                        Some((t, _)) => pair.triangle = t,
                        None => {
                            sliding.push((f, pair));
                            continue;
                        }
                    }
                }
                kept.push(pair);
            }
            *face_pairs = kept;
        }
        // A point that has slid onto another face keeps pressing there with its multiplier
        // (where that face already has the point, with the larger of the two): the load it
        // carried is not dropped and picked up again from the penalty alone.
        for (from, pair) in sliding {
            let s = self.tool_point(&tool, pair.point);
            // The face it is over now: of those it projects into, the nearest.
            let onto = (0..corners.len())
                .filter_map(|f| {
                    let (lo, hi) = &boxes[f];
                    if f == from || (0..3).any(|i| s[i] < lo[i] || s[i] > hi[i]) {
                        return None;
                    }
                    let (t, g) = tip_surface::projecting_triangle(&s, &corners[f])?;
                    (g.abs() < tool.reach).then_some((f, t, g.abs()))
                })
                .min_by(|a, b| a.2.total_cmp(&b.2));
            if let Some((f, t, _)) = onto {
                match pairs[f].iter_mut().find(|p| p.point == pair.point) {
                    Some(existing) => existing.lambda = existing.lambda.max(pair.lambda),
                    None => pairs[f].push(TipPair {
                        triangle: t,
                        ..pair
                    }),
                }
            }
        }
        // Tool points that have gone behind a face enter its pairs.
        let offset = self.trial.offset;
        for (f, face_pairs) in pairs.iter_mut().enumerate() {
            let x = &corners[f];
            let (lo, hi) = &boxes[f];
            tool.points_near(lo, hi, &offset, |q| {
                if face_pairs.iter().any(|p| p.point == q) {
                    return;
                }
                let s: [f64; 3] = std::array::from_fn(|i| tool.points[q][i] + offset[i]);
                if (0..3).any(|i| s[i] < lo[i] || s[i] > hi[i]) {
                    return;
                }
                if let Some((t, g)) = tip_surface::projecting_triangle(&s, x) {
                    if g < -tol && g > -tool.reach {
                        face_pairs.push(TipPair {
                            point: q,
                            triangle: t,
                            lambda: 0.0,
                            equilibrium_pressure: 0.0,
                            // Pairs predicted before Newton take their first Uzawa update
                            // at its converged state.
                            fresh: settle,
                        });
                        changed += 1;
                    }
                }
            });
        }
        self.trial.pairs = pairs;
        self.tool_points = Some(tool);
        changed
    }

    /// Uzawa update of the second pass's multipliers at `u`, for the pairs that were
    /// already pressing before the last status update.
    fn augment_tool_pairs(&mut self, u: &[f64], dof_map: &DofMap) {
        let Some(tool) = self.tool_points.take() else {
            return;
        };
        let mut pairs = std::mem::take(&mut self.trial.pairs);
        for (f, face_pairs) in pairs.iter_mut().enumerate() {
            if face_pairs.is_empty() {
                continue;
            }
            let x = self.tool_face_corners(&tool, f, u, dof_map);
            for pair in face_pairs.iter_mut() {
                if std::mem::take(&mut pair.fresh) {
                    continue;
                }
                let s = self.tool_point(&tool, pair.point);
                if let Some((_, g, _)) = tip_surface::triangle_projection(&s, &x, pair.triangle) {
                    pair.lambda = (pair.lambda - tool.penalty * g).max(0.0);
                }
            }
        }
        self.trial.pairs = pairs;
        self.tool_points = Some(tool);
    }

    /// For each second-pass pair: its gap (µm; negative where the tool point lies behind
    /// its face), its pressure (nN, ≥ 0), the face's outer normal and the tool point.
    fn tool_pair_states(&self, u: &[f64], dof_map: &DofMap) -> Vec<(f64, f64, [f64; 3], [f64; 3])> {
        let Some(tool) = &self.tool_points else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for (f, face_pairs) in self.trial.pairs.iter().enumerate() {
            if face_pairs.is_empty() {
                continue;
            }
            let x = self.tool_face_corners(tool, f, u, dof_map);
            for pair in face_pairs {
                let s = self.tool_point(tool, pair.point);
                if let Some((_, g, n)) = tip_surface::triangle_projection(&s, &x, pair.triangle) {
                    let p = (pair.lambda - tool.penalty * g).max(0.0);
                    out.push((g, p, n, s));
                }
            }
        }
        out
    }

    /// How deep the deepest watched node lies inside the tool (µm; 0 when none is inside
    /// or none is watched).
    pub fn deepest_watched_node(&self, u: &[f64], dof_map: &DofMap) -> f64 {
        self.watched
            .iter()
            .map(|&(n, x0)| {
                self.depth_inside(&std::array::from_fn(|i| x0[i] + u[dof_map.dof(n, i)]))
            })
            .fold(0.0, f64::max)
    }

    /// The same contact with the curvature term of its tangent taken as `curvature`.
    pub fn with_curvature_tangent(mut self, curvature: CurvatureTangent) -> Self {
        self.curvature_tangent = curvature;
        self
    }

    /// The same contact, aimed at body node `node` from analysis step `step` on: when that
    /// step starts, the pilot point is moved across the step's motion (perpendicular to
    /// it) by the node's committed displacement across it, and the step's motion goes on
    /// from there. The tool's own displacement outputs show the move.
    pub fn aimed_at(mut self, node: usize, step: usize) -> Self {
        self.aim = Some(Aim {
            node,
            step,
            committed: [0.0; 3],
        });
        self
    }

    /// The pilot point where step `step` starts: the committed offset, moved across the
    /// step's motion onto the aimed node when this is the aimed step.
    fn start_of_step(&self, step: usize) -> [f64; 3] {
        let mut start = self.committed.offset;
        let (Some(aim), Some(m)) = (self.aim, self.motion_direction(step)) else {
            return start;
        };
        if aim.step != step {
            return start;
        }
        let d: [f64; 3] = std::array::from_fn(|i| aim.committed[i] - start[i]);
        let along = dot(&d, &m);
        for i in 0..3 {
            start[i] += d[i] - along * m[i];
        }
        start
    }

    /// Current pilot-point displacement (µm).
    pub fn offset(&self) -> [f64; 3] {
        self.trial.offset
    }

    /// The tool shape.
    pub fn shape(&self) -> &ToolShape {
        &self.shape
    }

    /// The penetration tolerance (µm).
    pub fn tolerance(&self) -> f64 {
        self.tolerance
    }

    /// Number of nodes bonded to the tool (committed).
    pub fn bonded_count(&self) -> usize {
        self.committed
            .anchors
            .iter()
            .filter(|a| a.is_some())
            .count()
    }

    /// Number of contact points.
    pub fn point_count(&self) -> usize {
        self.weights.len()
    }

    /// Position of point q, with `u_of(k, i)` the displacement of its element's k-th node
    /// (component i).
    fn point_position(&self, q: usize, u_of: impl Fn(usize, usize) -> f64) -> [f64; 3] {
        let e = self.point_element[q];
        let (first, count) = (
            self.node_starts[e],
            self.node_starts[e + 1] - self.node_starts[e],
        );
        let w = &self.weights[q];
        std::array::from_fn(|i| {
            (0..count)
                .map(|k| w[k] * (self.reference[first + k][i] + u_of(k, i)))
                .sum()
        })
    }

    fn position(&self, q: usize, u: &[f64], dof_map: &DofMap) -> [f64; 3] {
        let first = self.node_starts[self.point_element[q]];
        self.point_position(q, |k, i| u[dof_map.dof(self.nodes[first + k], i)])
    }

    fn program_at(&self, step: usize) -> [f64; 3] {
        match self.program.get(step).or(self.program.last()) {
            Some(p) => *p,
            None => [0.0; 3],
        }
    }

    /// Direction of the current step's motion (unit), or the tool axis when it does not move.
    fn motion_direction(&self, step: usize) -> Option<[f64; 3]> {
        let start = if step == 0 {
            [0.0; 3]
        } else {
            self.program_at(step - 1)
        };
        let end = self.program_at(step);
        let d: [f64; 3] = std::array::from_fn(|i| end[i] - start[i]);
        let l = norm(&d);
        if l > 0.0 {
            Some(d.map(|x| x / l))
        } else {
            self.shape.axis()
        }
    }

    /// Largest penetration (µm, ≥ 0) of a free node, or bond gap of a bonded node.
    pub fn max_violation(&self, u: &[f64], dof_map: &DofMap) -> f64 {
        (0..self.point_count())
            .map(|e| {
                let x = self.position(e, u, dof_map);
                match self.trial.anchors[e] {
                    Some(a) => norm(&std::array::from_fn(|i| x[i] - a[i] - self.trial.offset[i])),
                    None => self.depth_inside(&x),
                }
            })
            .chain(
                self.tool_pair_states(u, dof_map)
                    .iter()
                    .map(|&(gap, ..)| -gap),
            )
            .fold(0.0, f64::max)
    }

    /// How deep the point `x` lies inside the tool where it is now (µm; 0 outside or out of
    /// its reach).
    fn depth_inside(&self, x: &[f64; 3]) -> f64 {
        self.shape
            .gap(x, &self.trial.offset)
            .map_or(0.0, |g| (-g.value).max(0.0))
    }

    /// Smallest signed gap between the tool where it is now and its contact points where
    /// they were at the last committed increment, bonded or not (`None` when no point is in
    /// the tool's reach). At a committed state it is the actual gap. During a trial it is
    /// the gap the tool's motion alone makes, without the body's response to the contact:
    /// a tool moving onto a body at rest sees it fall linearly through 0 at first contact,
    /// which is what a step's stop condition needs (the actual gap stays near 0 once the
    /// contact holds the body, whatever the tool's travel).
    pub fn min_gap(&self) -> Option<f64> {
        self.committed_positions
            .iter()
            .filter_map(|x| self.shape.gap(x, &self.trial.offset).map(|g| g.value))
            .reduce(f64::min)
    }

    /// Radius (µm) of the contact zone of an indenter (paraboloid or sphere): the largest
    /// distance from the tool's axis of a contact point that presses on the tool at `u`
    /// (positive pressure λ − εφ of an active point, or a bond). The axis passes through
    /// the displaced apex (centre) along the tool's axis, or for a sphere along its current
    /// motion. 0 when nothing presses; `None` for plates and disks, and for a sphere that
    /// has not moved. With node contact the zone's edge lies between the outermost loaded
    /// node and the next one out, so this under-estimates by up to one node spacing there.
    pub fn contact_radius(&self, u: &[f64], dof_map: &DofMap) -> Option<f64> {
        let origin = self.shape.axis_point()?;
        let axis = self
            .shape
            .axis()
            .or_else(|| self.motion_direction(self.last_step))?;
        let centre: [f64; 3] = std::array::from_fn(|i| origin[i] + self.trial.offset[i]);
        let mut radius: f64 = 0.0;
        for e in 0..self.point_count() {
            let x = self.position(e, u, dof_map);
            let presses = match self.trial.anchors[e] {
                Some(_) => true,
                None if self.trial.active[e] => {
                    self.shape.gap(&x, &self.trial.offset).is_some_and(|g| {
                        self.trial.lambda[e] - self.penalty * self.scale[e] * g.value > 0.0
                    })
                }
                None => false,
            };
            if presses {
                let d: [f64; 3] = std::array::from_fn(|i| x[i] - centre[i]);
                let along = dot(&d, &axis);
                let across = (dot(&d, &d) - along * along).max(0.0).sqrt();
                radius = radius.max(across);
            }
        }
        for (_, p, _, s) in self.tool_pair_states(u, dof_map) {
            if p > 0.0 {
                let d: [f64; 3] = std::array::from_fn(|i| s[i] - centre[i]);
                let along = dot(&d, &axis);
                radius = radius.max((dot(&d, &d) - along * along).max(0.0).sqrt());
            }
        }
        Some(radius)
    }

    /// The violation the augmentations must bring below the tolerance: per element, the
    /// largest bond gap, or the penetration averaged over the element's points with their
    /// surface shares (for a node, its own penetration). A bilinear face cannot follow a
    /// tool curved on the scale of the face at all nine points: their penetrations differ
    /// by up to the sag h²/(8R) however the multipliers are set, and asking each of them to
    /// be below the tolerance made the augmentations crawl. The largest point value is
    /// still reported ([`RigidContact::max_violation`]).
    fn settling_violation(&self, u: &[f64], dof_map: &DofMap) -> f64 {
        let mut worst: f64 = 0.0;
        for e in 0..self.element_count() {
            let (mut sum, mut weight, mut bond): (f64, f64, f64) = (0.0, 0.0, 0.0);
            for q in self.point_starts[e]..self.point_starts[e + 1] {
                let x = self.position(q, u, dof_map);
                match self.trial.anchors[q] {
                    Some(a) => {
                        bond = bond.max(norm(&std::array::from_fn(|i| {
                            x[i] - a[i] - self.trial.offset[i]
                        })));
                    }
                    None => {
                        let pen = self.depth_inside(&x);
                        sum += self.scale[q] * pen;
                        weight += self.scale[q];
                    }
                }
            }
            worst = worst.max(bond);
            if weight > 0.0 {
                worst = worst.max(sum / weight);
            }
        }
        // A pair violates by its penetration, and by its gap where it still presses (a
        // multiplier grown larger than the contact force holds the face off the tool: the
        // tool's other points shared the load in the augmentations before they left).
        self.tool_pair_states(u, dof_map)
            .iter()
            .fold(worst, |w, &(gap, p, ..)| {
                w.max(if p > 0.0 { gap.abs() } else { -gap })
            })
    }

    /// Contact-status check at a converged Newton state: records each active node's
    /// pressure there (the curvature term's cap; 0 for the others), then free nodes that
    /// penetrate deeper than the tolerance enter the active set and active nodes that pull
    /// on the tool harder than ε·tolerance (or left a disk's face) leave it with their
    /// multiplier reset. Returns how many changed.
    fn update_active_set(&mut self, u: &[f64], dof_map: &DofMap) -> usize {
        let (eps, tol) = (self.penalty, self.tolerance);
        let mut changed = 0;
        for e in 0..self.point_count() {
            if self.trial.anchors[e].is_some() {
                continue;
            }
            let x = self.position(e, u, dof_map);
            let gap = self.shape.gap(&x, &self.trial.offset);
            let eps = eps * self.scale[e];
            self.trial.equilibrium_pressure[e] = match gap {
                Some(g) if self.trial.active[e] => (self.trial.lambda[e] - eps * g.value).max(0.0),
                _ => 0.0,
            };
            let active = &mut self.trial.active[e];
            let next = match gap {
                None => false,
                Some(g) if *active => self.trial.lambda[e] - eps * g.value >= -eps * tol,
                Some(g) => g.value < -tol,
            };
            if next != *active {
                *active = next;
                if !next {
                    self.trial.lambda[e] = 0.0;
                }
                changed += 1;
            }
        }
        changed + self.update_tool_pairs(u, dof_map, true)
    }

    /// Status predictor for the increment about to be attempted: free points that the tool,
    /// at its new position, reaches deeper than the tolerance where Newton starts from (`u`:
    /// the last converged state, or the solver's prediction of the increment's end) enter
    /// the active set now, so that Newton's first correction moves the whole contact patch
    /// with the tool instead of pushing the old patch alone (an apex node driven one element
    /// size into the mesh inverts its elements), and points the body is predicted to carry
    /// onto a tool at rest need no extra contact-status round.
    fn predict_active_set(&mut self, u: &[f64], dof_map: &DofMap) {
        for e in 0..self.point_count() {
            if self.trial.active[e] || self.trial.anchors[e].is_some() {
                continue;
            }
            let x = self.position(e, u, dof_map);
            if let Some(g) = self.shape.gap(&x, &self.trial.offset) {
                if g.value < -self.tolerance {
                    self.trial.active[e] = true;
                }
            }
        }
        self.update_tool_pairs(u, dof_map, false);
    }

    /// Total force the tool exerts on the body (nN).
    pub fn force_on_body(&self, u: &[f64], dof_map: &DofMap) -> [f64; 3] {
        let mut total = [0.0; 3];
        for q in 0..self.point_count() {
            let x = self.position(q, u, dof_map);
            if let Some((_, r, _)) = self.point_law(q, &x, false) {
                for i in 0..3 {
                    total[i] -= r[i];
                }
            }
        }
        // A tool point pressing with p on a face of outer normal n pushes the body by −p n.
        for (_, p, n, _) in self.tool_pair_states(u, dof_map) {
            for i in 0..3 {
                total[i] -= p * n[i];
            }
        }
        total
    }

    /// The contact law of point q at position x: energy, force on the point (the residual
    /// `∂Π/∂x`) and, if asked, its 3×3 tangent; `None` where the point carries nothing.
    fn point_law(
        &self,
        q: usize,
        x: &[f64; 3],
        with_tangent: bool,
    ) -> Option<(f64, [f64; 3], [[f64; 3]; 3])> {
        let eps = self.penalty * self.scale[q];
        let mut k = [[0.0; 3]; 3];
        if let Some(anchor) = self.trial.anchors[q] {
            let l = self.trial.bond_lambda[q];
            let d: [f64; 3] = std::array::from_fn(|i| x[i] - anchor[i] - self.trial.offset[i]);
            if with_tangent {
                for (i, row) in k.iter_mut().enumerate() {
                    row[i] = eps;
                }
            }
            let energy = (0..3).map(|i| l[i] * d[i] + 0.5 * eps * d[i] * d[i]).sum();
            return Some((energy, std::array::from_fn(|i| l[i] + eps * d[i]), k));
        }
        if !self.trial.active[q] {
            return None;
        }
        let gap = self.shape.gap(x, &self.trial.offset)?;
        // Active: the bilateral penalty law (a small pull is allowed until the status check).
        let p = self.trial.lambda[q] - eps * gap.value;
        if with_tangent {
            // The curvature term with the pressure capped at the last equilibrium's (module
            // notes): a lagged, never more negative stiffness.
            let p_curvature = match self.curvature_tangent {
                CurvatureTangent::Lagged if !self.near_equilibrium => {
                    p.min(self.trial.equilibrium_pressure[q])
                }
                CurvatureTangent::Lagged | CurvatureTangent::Consistent => p,
            };
            for (i, row) in k.iter_mut().enumerate() {
                for (j, kij) in row.iter_mut().enumerate() {
                    *kij =
                        eps * gap.gradient[i] * gap.gradient[j] - p_curvature * gap.hessian[i][j];
                }
            }
        }
        Some((p * p / (2.0 * eps), gap.gradient.map(|g| -p * g), k))
    }

    /// Energy, residual and tangent of element e (a node or a face): the sum over its
    /// points of the point law, spread on the nodes by the points' shape functions.
    fn element_evaluate(
        &self,
        e: usize,
        u: &[f64],
        r: &mut [f64],
        k: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        if let Some(tool) = &self.tool_points {
            if e >= tool.first_element {
                return self.tool_face_evaluate(tool, e - tool.first_element, u, r, k);
            }
        }
        let count = self.node_starts[e + 1] - self.node_starts[e];
        let n = 3 * count;
        r[..n].fill(0.0);
        let mut k = k;
        if let Some(k) = k.as_deref_mut() {
            k[..n * n].fill(0.0);
        }
        let mut energy = 0.0;
        for q in self.point_starts[e]..self.point_starts[e + 1] {
            let x = self.point_position(q, |a, i| u[3 * a + i]);
            let Some((pi, rq, kq)) = self.point_law(q, &x, k.is_some()) else {
                continue;
            };
            energy += pi;
            let w = &self.weights[q];
            for a in 0..count {
                for i in 0..3 {
                    r[3 * a + i] += w[a] * rq[i];
                }
            }
            if let Some(k) = k.as_deref_mut() {
                for a in 0..count {
                    for b in 0..count {
                        let wab = w[a] * w[b];
                        for i in 0..3 {
                            for j in 0..3 {
                                k[(3 * a + i) * n + 3 * b + j] += wab * kq[i][j];
                            }
                        }
                    }
                }
            }
        }
        Ok(energy)
    }
}

impl RigidContact {
    /// Energy, residual and tangent of second-pass face `f` (its 12 translations): the sum
    /// over the tool points pressing on it of the pair law (module `tip_surface`).
    fn tool_face_evaluate(
        &self,
        tool: &ToolPoints,
        f: usize,
        u: &[f64],
        r: &mut [f64],
        k: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        const N: usize = 12;
        r[..N].fill(0.0);
        let mut k = k;
        if let Some(k) = k.as_deref_mut() {
            k[..N * N].fill(0.0);
        }
        let pairs = &self.trial.pairs[f];
        if pairs.is_empty() {
            return Ok(0.0);
        }
        let first = self.node_starts[tool.first_element + f];
        let x: [[f64; 3]; 4] = std::array::from_fn(|a| {
            std::array::from_fn(|i| self.reference[first + a][i] + u[3 * a + i])
        });
        let eps = tool.penalty;
        let mut energy = 0.0;
        for pair in pairs {
            let s = self.tool_point(tool, pair.point);
            let g = tip_surface::triangle_gap_derivatives(&s, &x, pair.triangle);
            if !g.v.is_finite() {
                // The triangle has collapsed: the face is inverted.
                return Err(KernelError::InvertedElement {
                    qp: pair.triangle,
                    det_f: 0.0,
                });
            }
            let p = pair.lambda - eps * g.v;
            energy += p * p / (2.0 * eps);
            for (ri, gi) in r[..N].iter_mut().zip(g.g) {
                *ri -= p * gi;
            }
            if let Some(k) = k.as_deref_mut() {
                let p_curvature = match self.curvature_tangent {
                    CurvatureTangent::Lagged if !self.near_equilibrium => {
                        p.min(pair.equilibrium_pressure)
                    }
                    CurvatureTangent::Lagged | CurvatureTangent::Consistent => p,
                };
                for i in 0..N {
                    for j in 0..N {
                        k[i * N + j] += eps * g.g[i] * g.g[j] - p_curvature * g.hessian(i, j);
                    }
                }
            }
        }
        Ok(energy)
    }
}

/// One element per contact node (its 3 translations) or face (its 4 nodes' 12); the
/// tool's program, multipliers and bonds are the set's state, moved by the hooks.
impl ElementSet for RigidContact {
    const ELEMENT_DOFS: usize = 12;

    fn follows_reference_moves(&self) -> bool {
        self.kind == ContactKind::Frictionless
    }

    /// Moved nodes take their new reference positions (contact nodes, face nodes and
    /// watched nodes); the contact points' committed positions and the aim follow the
    /// remapped state. The pressures stay with their points (frictionless contact has no
    /// other history).
    fn on_reference_moved(
        &mut self,
        reference: &[[f64; 3]],
        moved: &[bool],
        u: &mut [f64],
        dof_map: &DofMap,
    ) -> Result<(), String> {
        let is_moved = |n: usize| moved.get(n).copied().unwrap_or(false);
        if self.kind != ContactKind::Frictionless && self.nodes.iter().any(|&n| is_moved(n)) {
            return Err(format!(
                "contact '{}': only frictionless contact nodes can be rezoned",
                self.name
            ));
        }
        // A moved node lands on the old bilinear surface: under a convex tool that is a
        // chord inside it (by ℓ²/8R for faces of length ℓ). Put it back on the tool's
        // surface along the gap's gradient (a few Newton steps on φ = 0).
        let offset = self.committed.offset;
        for (k, &node) in self.nodes.iter().enumerate() {
            if !is_moved(node) {
                continue;
            }
            self.reference[k] = reference[node];
            let dofs: [usize; 3] = std::array::from_fn(|i| dof_map.dof(node, i));
            for _ in 0..5 {
                let x: [f64; 3] = std::array::from_fn(|i| reference[node][i] + u[dofs[i]]);
                let Some(g) = self.shape.gap(&x, &offset) else {
                    break;
                };
                let norm2: f64 = g.gradient.iter().map(|v| v * v).sum();
                if g.value >= 0.0 || !(norm2 > 0.0) {
                    break;
                }
                for i in 0..3 {
                    u[dofs[i]] -= g.value * g.gradient[i] / norm2;
                }
            }
        }
        for (node, x0) in &mut self.watched {
            if is_moved(*node) {
                *x0 = reference[*node];
            }
        }
        for e in 0..self.point_count() {
            self.committed_positions[e] = self.position(e, u, dof_map);
        }
        if let Some(aim) = &mut self.aim {
            aim.committed = std::array::from_fn(|i| u[dof_map.dof(aim.node, i)]);
        }
        Ok(())
    }

    fn set_name(&self) -> &str {
        &self.name
    }

    fn element_count(&self) -> usize {
        self.node_starts.len() - 1
    }

    fn element_nodes(&self, e: usize) -> &[usize] {
        &self.nodes[self.node_starts[e]..self.node_starts[e + 1]]
    }

    fn evaluate_element(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        self.element_evaluate(e, u_e, residual, tangent)
    }

    fn curve_outputs(&self, u: &[f64], dof_map: &DofMap) -> Vec<(String, f64)> {
        let f = self.force_on_body(u, dof_map);
        let o = self.trial.offset;
        let mut out = vec![
            (scalar_name(&self.name, ToolScalar::Displacement(0)), o[0]),
            (scalar_name(&self.name, ToolScalar::Displacement(1)), o[1]),
            (scalar_name(&self.name, ToolScalar::Displacement(2)), o[2]),
            (scalar_name(&self.name, ToolScalar::Force(0)), f[0]),
            (scalar_name(&self.name, ToolScalar::Force(1)), f[1]),
            (scalar_name(&self.name, ToolScalar::Force(2)), f[2]),
        ];
        if let Some(m) = self.motion_direction(self.last_step) {
            out.push((
                scalar_name(&self.name, ToolScalar::ForceAlongMotion),
                dot(&f, &m),
            ));
        }
        out.push((
            scalar_name(&self.name, ToolScalar::MaxPenetration),
            self.max_violation(u, dof_map),
        ));
        let gap = self.min_gap().unwrap_or(f64::NAN);
        out.push((scalar_name(&self.name, ToolScalar::MinGap), gap));
        if self.shape.axis_point().is_some() {
            let radius = self.contact_radius(u, dof_map).unwrap_or(0.0);
            out.push((scalar_name(&self.name, ToolScalar::ContactRadius), radius));
        }
        if !self.watched.is_empty() {
            out.push((
                scalar_name(&self.name, ToolScalar::DeepestWatchedNode),
                self.deepest_watched_node(u, dof_map),
            ));
        }
        out
    }

    fn on_load_state(&mut self, state: &LoadState) {
        let start = if state.step_index == 0 {
            [0.0; 3]
        } else {
            self.program_at(state.step_index - 1)
        };
        let end = self.program_at(state.step_index);
        if self.started_step != Some(state.step_index) {
            self.started_step = Some(state.step_index);
            self.step_start = self.start_of_step(state.step_index);
        }
        let from = self.step_start;
        self.trial.offset =
            std::array::from_fn(|i| from[i] + state.step_time * (end[i] - start[i]));
        self.last_step = state.step_index;
        self.near_equilibrium = false;
    }

    fn on_predict(&mut self, u: &[f64], dof_map: &DofMap) {
        self.predict_active_set(u, dof_map);
    }

    fn on_near_equilibrium(&mut self, near: bool) {
        self.near_equilibrium = near;
    }

    fn on_converged(&mut self, u: &[f64], dof_map: &DofMap) -> Augmentation {
        // Status and multipliers are updated in the same pass (one more Newton solve for
        // both): the points that stay active take their Uzawa update from this state, the
        // points that just entered start from λ = 0 (the penalty alone first; starting them
        // at ε|ψ| pushed many out again at the next solve).
        let was_active = self.trial.active.clone();
        let changed = self.update_active_set(u, dof_map);
        let violation = self.settling_violation(u, dof_map);
        if changed == 0 && violation <= self.tolerance {
            return Augmentation::Settled;
        }
        for e in 0..self.point_count() {
            let x = self.position(e, u, dof_map);
            let eps = self.penalty * self.scale[e];
            match self.trial.anchors[e] {
                Some(a) => {
                    for i in 0..3 {
                        self.trial.bond_lambda[e][i] += eps * (x[i] - a[i] - self.trial.offset[i]);
                    }
                }
                None if self.trial.active[e] && was_active[e] => {
                    if let Some(g) = self.shape.gap(&x, &self.trial.offset) {
                        self.trial.lambda[e] = (self.trial.lambda[e] - eps * g.value).max(0.0);
                    }
                }
                None => {}
            }
        }
        self.augment_tool_pairs(u, dof_map);
        let message = format!(
            "{changed} contact points changed status, largest violation {violation:.3e} um \
             (tolerance {:.3e} um)",
            self.tolerance
        );
        if changed == 0 {
            Augmentation::Multipliers(message)
        } else {
            Augmentation::Updated(message)
        }
    }

    fn on_commit(&mut self, u: &[f64], dof_map: &DofMap) {
        for e in 0..self.point_count() {
            self.committed_positions[e] = self.position(e, u, dof_map);
        }
        if let Some(aim) = &mut self.aim {
            aim.committed = std::array::from_fn(|i| u[dof_map.dof(aim.node, i)]);
        }
        if self.kind == ContactKind::Bonded {
            for e in 0..self.point_count() {
                if self.trial.anchors[e].is_some() {
                    continue;
                }
                let x = self.position(e, u, dof_map);
                let Some(g) = self.shape.gap(&x, &self.trial.offset) else {
                    continue;
                };
                // The active law's pressure as the converged state has it: bilateral, so a
                // node inside the status band may pull a little (`point_law`).
                let p = if self.trial.active[e] {
                    self.trial.lambda[e] - self.penalty * self.scale[e] * g.value
                } else {
                    0.0
                };
                if p > 0.0 || g.value <= self.tolerance {
                    // Tie the node where it is now; start the bond with the contact force it
                    // carried, pull included, so the converged equilibrium is unchanged.
                    // (With the pull clamped to zero, the bonded nodes' forces jumped at the
                    // commit: the compression's plates reported forces up to 5 nN out of
                    // balance at converged increments, 82 % of the force at 1 %.)
                    self.trial.anchors[e] =
                        Some(std::array::from_fn(|i| x[i] - self.trial.offset[i]));
                    self.trial.bond_lambda[e] = std::array::from_fn(|i| -p * g.gradient[i]);
                }
            }
        }
        self.committed = self.trial.clone();
    }

    fn on_rollback(&mut self) {
        self.trial = self.committed.clone();
    }

    fn on_save_trial(&mut self) {
        self.saved_trial = Some(self.trial.clone());
    }

    fn on_restore_trial(&mut self) {
        if let Some(saved) = &self.saved_trial {
            self.trial = saved.clone();
        }
    }
}

/// A scalar result of a rigid tool, per converged increment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ToolScalar {
    /// Pilot-point displacement along axis 0, 1, 2 (µm).
    Displacement(usize),
    /// Force the tool exerts on the body along axis 0, 1, 2 (nN).
    Force(usize),
    /// Force along the tool's current direction of motion (nN).
    ForceAlongMotion,
    /// Largest penetration or bond gap of its contact nodes (µm).
    MaxPenetration,
    /// Smallest signed gap between the tool and its contact points (µm; negative:
    /// penetration; NaN when no point is in the tool's reach), measured from where the
    /// points were at the last committed increment ([`RigidContact::min_gap`]): linear in
    /// the tool's travel until first contact, so a step can stop exactly there.
    MinGap,
    /// Radius of the contact zone of an indenter (paraboloid or sphere; µm, 0 without
    /// contact): [`RigidContact::contact_radius`].
    ContactRadius,
    /// How deep the deepest watched body node lies inside the tool (µm;
    /// [`RigidContact::with_watched_nodes`]).
    DeepestWatchedNode,
}

/// The name (with its unit) of a tool's scalar result: the one definition of the
/// `curve.csv` column and of the [`crate::solve::Monitor::TermScalar`] key.
pub fn scalar_name(tool: &str, scalar: ToolScalar) -> String {
    const AXES: [&str; 3] = ["x", "y", "z"];
    match scalar {
        ToolScalar::Displacement(a) => format!("{tool}_displacement_{}_um", AXES[a.min(2)]),
        ToolScalar::Force(a) => format!("{tool}_force_{}_nN", AXES[a.min(2)]),
        ToolScalar::ForceAlongMotion => format!("{tool}_force_along_motion_nN"),
        ToolScalar::MaxPenetration => format!("{tool}_max_penetration_um"),
        ToolScalar::MinGap => format!("{tool}_min_gap_um"),
        ToolScalar::ContactRadius => format!("{tool}_contact_radius_um"),
        ToolScalar::DeepestWatchedNode => format!("{tool}_deepest_node_inside_um"),
    }
}

/// The checks every contact constructor makes: candidates, tool shape, penalty and tolerance.
fn check_setup(
    name: &str,
    empty: bool,
    shape: &ToolShape,
    penalty: f64,
    tolerance: f64,
) -> Result<(), ContactError> {
    if empty {
        return Err(ContactError::NoNodes(name.to_string()));
    }
    shape.validate().map_err(|message| ContactError::Shape {
        tool: name.to_string(),
        message,
    })?;
    if !(penalty > 0.0 && tolerance > 0.0) {
        return Err(ContactError::Parameters {
            tool: name.to_string(),
            penalty,
            tolerance,
        });
    }
    Ok(())
}

/// Gauss–Legendre points and weights on [−1, 1] with `n` points (1 to 4).
fn gauss_rule(n: usize) -> Option<Vec<(f64, f64)>> {
    let rule = match n {
        1 => vec![(0.0, 2.0)],
        2 => {
            let g = 1.0 / 3f64.sqrt();
            vec![(-g, 1.0), (g, 1.0)]
        }
        3 => {
            let g = 0.6f64.sqrt();
            vec![(-g, 5.0 / 9.0), (0.0, 8.0 / 9.0), (g, 5.0 / 9.0)]
        }
        4 => {
            let (a, b) = (
                (3.0 / 7.0 - 2.0 / 7.0 * 1.2f64.sqrt()).sqrt(),
                (3.0 / 7.0 + 2.0 / 7.0 * 1.2f64.sqrt()).sqrt(),
            );
            let (wa, wb) = ((18.0 + 30f64.sqrt()) / 36.0, (18.0 - 30f64.sqrt()) / 36.0);
            vec![(-b, wb), (-a, wa), (a, wa), (b, wb)]
        }
        _ => return None,
    };
    Some(rule)
}

/// Bilinear quad shape functions at (ξ, η) (corners (−1,−1), (1,−1), (1,1), (−1,1)) and
/// their ξ and η derivatives.
fn quad_shape(xi: f64, eta: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    const CORNERS: [(f64, f64); 4] = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    let n = CORNERS.map(|(a, b)| 0.25 * (1.0 + a * xi) * (1.0 + b * eta));
    let dxi = CORNERS.map(|(a, b)| 0.25 * a * (1.0 + b * eta));
    let deta = CORNERS.map(|(a, b)| 0.25 * b * (1.0 + a * xi));
    (n, dxi, deta)
}

#[cfg(test)]
mod tests;
