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
        let weights = host.weights();
        let mut host_dofs = [[0usize; 3]; 8];
        for (a, &h) in host.nodes.iter().enumerate() {
            host_dofs[a] = translations(h)?;
        }
        for c in 0..3 {
            let masters: [(usize, f64); 8] = std::array::from_fn(|a| (host_dofs[a][c], weights[a]));
            constraints
                .add_resolved(slave[c], &masters)
                .map_err(|source| EmbedError::Constraint { node, source })?;
        }
        report.max_overshoot = report.max_overshoot.max(host.overshoot);
        report.embedded.push(EmbeddedNode { node, host });
    }
    Ok(report)
}
