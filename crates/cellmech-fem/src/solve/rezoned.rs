//! The parts of [`Problem`] that apply an ALE rezoning ([`crate::rezone`]) between steps.

use super::problem::Problem;
use crate::dof::DofMap;
use crate::rezone::NodeRemap;

/// Remaps the translations of a nodal DOF vector (`u`, or an earlier state's) in place:
/// each remapped node takes the weighted old values of its sources.
pub fn remap_translations(remaps: &[NodeRemap], dof_map: &DofMap, values: &mut [f64]) {
    let new: Vec<[f64; 3]> = remaps
        .iter()
        .map(|remap| {
            let mut v = [0.0; 3];
            for &(source, w) in &remap.sources {
                for (i, vi) in v.iter_mut().enumerate() {
                    *vi += w * values[dof_map.dof(source, i)];
                }
            }
            v
        })
        .collect();
    for (remap, v) in remaps.iter().zip(new) {
        for (i, vi) in v.into_iter().enumerate() {
            values[dof_map.dof(remap.node, i)] = vi;
        }
    }
}

impl Problem {
    /// Per node: whether every term that uses it follows moved reference positions
    /// ([`crate::term::Term::follows_reference_moves`]: continuum blocks, membranes,
    /// frictionless contact), and it is not a master of a constraint whose slave is not
    /// such a node (an embedded filament node: its host weights were computed in the old
    /// reference). Only these nodes can be moved by an ALE rezoning.
    pub fn nodes_following_reference_moves(&self) -> Vec<bool> {
        let n = self.dof_map.num_nodes();
        let (mut used, mut pinned) = (vec![false; n], vec![false; n]);
        let mut dofs = [0usize; crate::term::MAX_ELEMENT_DOFS];
        for term in &self.terms {
            let follows = term.follows_reference_moves();
            for e in 0..term.num_elements() {
                let k = term.element_dofs(e, &self.dof_map, &mut dofs);
                for &dof in &dofs[..k] {
                    let node = self.dof_map.node_of(dof).0;
                    used[node] = true;
                    pinned[node] |= !follows;
                }
            }
        }
        if let Some(c) = self.constraints() {
            for (k, &slave) in c.slaves().iter().enumerate() {
                let (slave_node, _) = self.dof_map.node_of(slave);
                if used[slave_node] && !pinned[slave_node] {
                    continue;
                }
                for &master in c.constraint(k).0 {
                    pinned[self.dof_map.node_of(master).0] = true;
                }
            }
        }
        (0..n).map(|node| used[node] && !pinned[node]).collect()
    }

    /// Applies an ALE rezoning: the remapped nodes' displacements become the weighted
    /// old ones ([`NodeRemap`]), and every term is told the new reference positions
    /// (`reference`, all nodes). A node that [`Problem::nodes_following_reference_moves`]
    /// excludes is refused, before anything changes. The state is then that of the same deformation on the new
    /// mesh; the next step re-equilibrates it.
    pub fn remap_nodes(
        &mut self,
        remaps: &[NodeRemap],
        reference: &[[f64; 3]],
    ) -> Result<(), String> {
        let n = self.dof_map.num_nodes();
        if reference.len() != n {
            return Err(format!(
                "rezoning: {} reference positions for {n} nodes",
                reference.len()
            ));
        }
        let mut moved = vec![false; n];
        for remap in remaps {
            if remap.node >= n || remap.sources.iter().any(|&(s, _)| s >= n) {
                return Err(format!("rezoning: node {} out of range", remap.node));
            }
            moved[remap.node] = true;
        }
        let movable = self.nodes_following_reference_moves();
        if let Some(remap) = remaps.iter().find(|r| !movable[r.node]) {
            return Err(format!(
                "rezoning: node {} is used by a term that does not follow moved reference \
                 positions (a filament, a bonded contact, ...) and cannot be moved",
                remap.node
            ));
        }
        remap_translations(remaps, &self.dof_map, &mut self.u);
        for term in &mut self.terms {
            term.move_reference(reference, &moved, &mut self.u, &self.dof_map)?;
        }
        if let Some(c) = &self.condensation {
            c.constraints().enforce(&mut self.u);
        }
        Ok(())
    }
}
