//! Hanging-node ties of a locally refined hex8 mesh ([`crate::mesh::refine`]): each
//! translational component of a hanging node follows its masters,
//! `u_h = Σ w u_m`, with the weights of the coarse side's trilinear trace (½ on an edge, ¼
//! on a face, products after chains are resolved). Rotational DOFs of a node shared with a
//! beam stay free.

use crate::dof::DofMap;
use crate::mesh::refine::HangingNode;

use super::{ConstraintError, LinearConstraints};

/// Why a hanging node could not be tied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HangingTieError {
    /// A hanging node or a master does not exist in the DOF map.
    #[error("hanging node {hanging}: node {node} does not exist ({num_nodes} nodes)")]
    UnknownNode {
        /// The hanging node.
        hanging: usize,
        /// The missing node.
        node: usize,
        /// Number of nodes of the DOF map.
        num_nodes: usize,
    },
    /// A node carries fewer than 3 DOFs.
    #[error(
        "hanging node {hanging}: node {node} carries {count} DOFs; a tie needs 3 translations"
    )]
    NoTranslations {
        /// The hanging node.
        hanging: usize,
        /// The node.
        node: usize,
        /// Its DOF count.
        count: usize,
    },
    /// The constraint was refused (e.g. a master is itself tied, or the node is tied twice).
    #[error("hanging node {hanging}: {source}")]
    Constraint {
        /// The hanging node.
        hanging: usize,
        /// The constraint error.
        source: ConstraintError,
    },
}

/// Adds three constraints per hanging node (one per translation) to `constraints`. Add
/// them before any other tie whose masters may be hanging nodes (embedded nodes: see
/// [`LinearConstraints::add_resolved`]). On an error, ties added before it remain.
pub fn tie_hanging_nodes(
    constraints: &mut LinearConstraints,
    dof_map: &DofMap,
    hanging: &[HangingNode],
) -> Result<(), HangingTieError> {
    for h in hanging {
        let translations = |node: usize| -> Result<[usize; 3], HangingTieError> {
            if node >= dof_map.num_nodes() {
                return Err(HangingTieError::UnknownNode {
                    hanging: h.node,
                    node,
                    num_nodes: dof_map.num_nodes(),
                });
            }
            let count = dof_map.count(node);
            if count < 3 {
                return Err(HangingTieError::NoTranslations {
                    hanging: h.node,
                    node,
                    count,
                });
            }
            Ok(std::array::from_fn(|c| dof_map.dof(node, c)))
        };
        let slave = translations(h.node)?;
        let masters = h
            .masters
            .iter()
            .map(|&(m, w)| Ok((translations(m)?, w)))
            .collect::<Result<Vec<_>, HangingTieError>>()?;
        for c in 0..3 {
            let tie: Vec<(usize, f64)> = masters.iter().map(|&(d, w)| (d[c], w)).collect();
            constraints
                .add(slave[c], &tie)
                .map_err(|source| HangingTieError::Constraint {
                    hanging: h.node,
                    source,
                })?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hanging_ties_constrain_three_translations_and_refuse_chains() {
        let dof_map = DofMap::with_counts(&[3, 3, 6, 3]);
        let mut c = LinearConstraints::new(dof_map.num_dofs());
        let ties = [HangingNode {
            node: 2,
            masters: vec![(0, 0.5), (1, 0.5)],
        }];
        tie_hanging_nodes(&mut c, &dof_map, &ties).unwrap();
        assert_eq!(c.len(), 3);
        assert_eq!(
            c.masters_of(dof_map.dof(2, 1)),
            Some((&[1, 4][..], &[0.5, 0.5][..]))
        );
        assert!(!c.is_slave(dof_map.dof(2, 3)), "rotations stay free");
        // A master that is tied itself is refused (ties must have chains resolved).
        let chained = [HangingNode {
            node: 3,
            masters: vec![(2, 0.5), (0, 0.5)],
        }];
        let e = tie_hanging_nodes(&mut c, &dof_map, &chained).unwrap_err();
        assert!(
            e.to_string().contains("hanging node 3")
                && e.to_string().contains("both a master and a slave"),
            "{e}"
        );
        let unknown = [HangingNode {
            node: 3,
            masters: vec![(9, 1.0)],
        }];
        let e = tie_hanging_nodes(&mut c, &dof_map, &unknown).unwrap_err();
        assert!(e.to_string().contains("node 9 does not exist"), "{e}");
    }
}
