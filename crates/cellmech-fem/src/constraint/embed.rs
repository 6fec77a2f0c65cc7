//! The embedded-element technique (Abaqus *EMBEDDED ELEMENT, ANSYS MESH200+REINF264):
//! the translations of a node lying inside a hex8 host follow the host's interpolation at
//! the node's natural coordinates ξ, found once in the reference configuration:
//!
//! ```text
//! u_s = Σ_a N_a(ξ) u_a        (one constraint per translational component)
//! ```
//!
//! The tie is linear in the DOFs, hence exact at any deformation (ξ stays fixed). Rotational
//! DOFs of beam nodes are not touched (they stay free). Nodes that are themselves host nodes
//! are already part of the continuum and are skipped (listed as `shared`). A host node that
//! is tied itself (a hanging node of a refined mesh, tied first) is replaced by its masters
//! ([`LinearConstraints::add_resolved`]), so the embedded node's masters are never slaves.

use crate::dof::DofMap;
use crate::mesh::locate::{HostLocation, HostLocator, LocateError};

use super::{ConstraintError, LinearConstraints};

/// One embedded node and where it lies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmbeddedNode {
    /// The node.
    pub node: usize,
    /// Its host element and natural coordinates.
    pub host: HostLocation,
}

/// What [`embed_translations`] did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EmbedReport {
    /// Nodes whose translations now follow a host, with their hosts.
    pub embedded: Vec<EmbeddedNode>,
    /// Nodes that are nodes of a host element (already part of the continuum): skipped.
    pub shared: Vec<usize>,
    /// Nodes no host contains within the tolerance, with the locator's reason: skipped
    /// (their translations stay free).
    pub unhosted: Vec<(usize, LocateError)>,
    /// Largest overshoot `max|ξ| − 1` over the embedded nodes (0 when all lie inside).
    pub max_overshoot: f64,
}

impl EmbedReport {
    /// `Ok` when every requested node is embedded or shared; otherwise an error naming the
    /// first nodes that no host contains.
    pub fn require_all_hosted(&self) -> Result<(), EmbedError> {
        if self.unhosted.is_empty() {
            return Ok(());
        }
        let listed: Vec<String> = self
            .unhosted
            .iter()
            .take(5)
            .map(|(n, e)| format!("node {n}: {e}"))
            .collect();
        Err(EmbedError::Unhosted {
            count: self.unhosted.len(),
            first: listed.join("; "),
        })
    }
}

/// Why nodes could not be embedded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EmbedError {
    /// A node index is beyond the coordinates or the DOF map.
    #[error("embedded node {node} does not exist ({num_nodes} nodes)")]
    UnknownNode {
        /// The node.
        node: usize,
        /// Number of nodes.
        num_nodes: usize,
    },
    /// A node or host node carries fewer than 3 DOFs.
    #[error("node {node} carries {count} DOFs; embedding needs 3 translations")]
    NoTranslations {
        /// The node.
        node: usize,
        /// Its DOF count.
        count: usize,
    },
    /// The constraint could not be added (e.g. the node is already embedded, or it is a
    /// host node of another embedding).
    #[error("embedding node {node}: {source}")]
    Constraint {
        /// The node.
        node: usize,
        /// The constraint error.
        source: ConstraintError,
    },
    /// The radius of a ball embedding is negative or not finite.
    #[error("expected a finite radius of 0 or more for the embedding's ball; found {0}")]
    BadRadius(f64),
    /// The tolerance is invalid.
    #[error(transparent)]
    Locate(#[from] LocateError),
    /// Some nodes lie in no host ([`EmbedReport::require_all_hosted`]).
    #[error("{count} node(s) lie in no host element: {first}")]
    Unhosted {
        /// How many.
        count: usize,
        /// The first few, with reasons.
        first: String,
    },
}

/// Embeds the translational DOFs of `nodes` (reference coordinates `coordinates`) in the
/// host elements of `locator`, adding three constraints per embedded node to
/// `constraints`. A node outside every host by more than `tolerance` (in ξ, see
/// [`HostLocator::locate`]) is reported in `unhosted` and left free; check with
/// [`EmbedReport::require_all_hosted`] when every node must be embedded. Duplicate nodes in
/// `nodes` are embedded once. On an error, constraints added before it remain.
pub fn embed_translations(
    constraints: &mut LinearConstraints,
    locator: &HostLocator,
    dof_map: &DofMap,
    coordinates: &[[f64; 3]],
    nodes: &[usize],
    tolerance: f64,
) -> Result<EmbedReport, EmbedError> {
    embed_translations_over_ball(
        constraints,
        locator,
        dof_map,
        coordinates,
        nodes,
        0.0,
        tolerance,
    )
}

/// Sample points per ball radius of [`embed_translations_over_ball`]: a lattice of spacing
/// `radius / BALL_SAMPLES_PER_RADIUS`, offset by half a spacing so that it is symmetric
/// about the centre (the mean of a linear field is then exactly its value at the centre).
pub const BALL_SAMPLES_PER_RADIUS: usize = 6;

/// How far outside a host (in ξ) a ball's sample point is still taken to lie in it: round-off
/// only (the hosts are a conforming mesh; points beyond the body's surface stay out).
const SAMPLE_TOLERANCE: f64 = 1e-9;

/// Like [`embed_translations`], but each node follows the **mean displacement of the host
/// material within a ball** of `radius` around it instead of the host's interpolation at
/// its own point (a distributing coupling, as Abaqus's *COUPLING, DISTRIBUTING with
/// uniform weights, translations only):
///
/// ```text
/// u_s = (1/|B|) ∫_B u dV ≈ (1/Q) Σ_q Σ_a N_a(ξ_q) u_a
/// ```
///
/// over the `Q` lattice points of the ball that lie in a host (points outside every host,
/// e.g. beyond the body's surface, are left out: the mean is over the part of the ball
/// inside the body). A force on the node is spread over the ball's material with the same
/// weights, so a point load on a continuum (singular: its local strain grows without bound
/// as the mesh is refined) becomes a load spread over a finite volume. `radius` = 0 is
/// [`embed_translations`]. The node itself must lie in a host (reported in `embedded` with
/// its own host) or it is `unhosted`.
pub fn embed_translations_over_ball(
    constraints: &mut LinearConstraints,
    locator: &HostLocator,
    dof_map: &DofMap,
    coordinates: &[[f64; 3]],
    nodes: &[usize],
    radius: f64,
    tolerance: f64,
) -> Result<EmbedReport, EmbedError> {
    if !(radius.is_finite() && radius >= 0.0) {
        return Err(EmbedError::BadRadius(radius));
    }
    let lattice = (radius > 0.0).then(|| ball_lattice(radius));
    embed_with(
        constraints,
        locator,
        dof_map,
        coordinates,
        nodes,
        tolerance,
        |centre, host| {
            let ball = lattice
                .as_ref()
                .map(|lattice| ball_weights_on_lattice(locator, centre, lattice))
                .unwrap_or_default();
            if ball.is_empty() {
                point_weights(host)
            } else {
                ball
            }
        },
    )
}

/// The offsets of the sample lattice of a ball of `radius` (see
/// [`BALL_SAMPLES_PER_RADIUS`]).
fn ball_lattice(radius: f64) -> Vec<[f64; 3]> {
    let n = BALL_SAMPLES_PER_RADIUS as i64;
    let h = radius / BALL_SAMPLES_PER_RADIUS as f64;
    (-n..n)
        .flat_map(|i| (-n..n).flat_map(move |j| (-n..n).map(move |k| [i, j, k])))
        .map(|ijk| ijk.map(|i| (i as f64 + 0.5) * h))
        .filter(|p| p.iter().map(|x| x * x).sum::<f64>() <= radius * radius)
        .collect()
}

fn ball_weights_on_lattice(
    locator: &HostLocator,
    centre: [f64; 3],
    lattice: &[[f64; 3]],
) -> Vec<(usize, f64)> {
    // Σ_q N_a(ξ_q) per host node over the samples inside a host, then / Q.
    let mut weights: std::collections::BTreeMap<usize, f64> = Default::default();
    let mut inside = 0usize;
    for offset in lattice {
        let point = std::array::from_fn(|c| centre[c] + offset[c]);
        // A sample on a face between two hosts must not be lost to round-off in ξ.
        let Ok(host) = locator.locate(point, SAMPLE_TOLERANCE) else {
            continue;
        };
        inside += 1;
        for (&h, w) in host.nodes.iter().zip(host.weights()) {
            *weights.entry(h).or_default() += w;
        }
    }
    let q = inside.max(1) as f64;
    weights.into_iter().map(|(h, w)| (h, w / q)).collect()
}

/// The host nodes and weights of the mean over the ball of `radius` around `centre`, the
/// weights [`embed_translations_over_ball`] ties a node with (empty when no sample lies in
/// a host). Use it to move a point with the material the way a ball-tied node moves.
pub fn ball_weights(locator: &HostLocator, centre: [f64; 3], radius: f64) -> Vec<(usize, f64)> {
    ball_weights_on_lattice(locator, centre, &ball_lattice(radius))
}

/// The host interpolation at the point itself: `(node, N_a(ξ))`.
fn point_weights(host: &HostLocation) -> Vec<(usize, f64)> {
    host.nodes.iter().copied().zip(host.weights()).collect()
}

/// Ties the translations of each node of `nodes` to `Σ w_a u_a` over the host nodes and
/// weights `weights(point, host of the point)` gives (see [`embed_translations`] for the
/// rules on shared, unhosted and duplicate nodes).
fn embed_with(
    constraints: &mut LinearConstraints,
    locator: &HostLocator,
    dof_map: &DofMap,
    coordinates: &[[f64; 3]],
    nodes: &[usize],
    tolerance: f64,
    weights: impl Fn([f64; 3], &HostLocation) -> Vec<(usize, f64)>,
) -> Result<EmbedReport, EmbedError> {
    let num_nodes = coordinates.len().min(dof_map.num_nodes());
    let translations = |node: usize| -> Result<[usize; 3], EmbedError> {
        if node >= num_nodes {
            return Err(EmbedError::UnknownNode { node, num_nodes });
        }
        let count = dof_map.count(node);
        if count < 3 {
            return Err(EmbedError::NoTranslations { node, count });
        }
        Ok(std::array::from_fn(|c| dof_map.dof(node, c)))
    };
    let mut report = EmbedReport::default();
    let mut sorted = nodes.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    for node in sorted {
        let slave = translations(node)?;
        if locator.is_host_node(node) {
            report.shared.push(node);
            continue;
        }
        let host = match locator.locate(coordinates[node], tolerance) {
            Ok(h) => h,
            Err(e @ LocateError::Outside { .. }) => {
                report.unhosted.push((node, e));
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        let mut masters = Vec::new();
        for (h, w) in weights(coordinates[node], &host) {
            masters.push((translations(h)?, w));
        }
        for c in 0..3 {
            let row: Vec<(usize, f64)> = masters.iter().map(|(d, w)| (d[c], *w)).collect();
            constraints
                .add_resolved(slave[c], &row)
                .map_err(|source| EmbedError::Constraint { node, source })?;
        }
        report.max_overshoot = report.max_overshoot.max(host.overshoot);
        report.embedded.push(EmbeddedNode { node, host });
    }
    Ok(report)
}
