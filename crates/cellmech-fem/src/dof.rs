//! Degrees of freedom: which global DOF belongs to which node component.
//!
//! Nodes carry 3 translational DOFs; nodes of beam elements carry 3 more rotational DOFs.
//! The global DOFs of a node are contiguous: `first(node) .. first(node) + count(node)`.
//! The DOF map is topology only; which DOFs are prescribed is decided per analysis step
//! (see [`crate::solve`]) so that a change of boundary conditions never changes the
//! sparsity pattern or the symbolic factorisation.

/// Numbering of the global degrees of freedom.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DofMap {
    first: Vec<usize>,
}

impl DofMap {
    /// Three translational DOFs on each of `num_nodes` nodes.
    pub fn translational(num_nodes: usize) -> Self {
        DofMap {
            first: (0..=num_nodes).map(|i| 3 * i).collect(),
        }
    }

    /// A DOF map where node `i` carries `dofs_per_node[i]` DOFs (3 or 6).
    pub fn with_counts(dofs_per_node: &[usize]) -> Self {
        let mut first = Vec::with_capacity(dofs_per_node.len() + 1);
        let mut next = 0;
        first.push(0);
        for &c in dofs_per_node {
            next += c;
            first.push(next);
        }
        DofMap { first }
    }

    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.first.len() - 1
    }

    /// Total number of DOFs.
    pub fn num_dofs(&self) -> usize {
        self.first[self.first.len() - 1]
    }

    /// Number of DOFs of `node`.
    pub fn count(&self, node: usize) -> usize {
        self.first[node + 1] - self.first[node]
    }

    /// Global index of component `component` (0..count) of `node`.
    pub fn dof(&self, node: usize, component: usize) -> usize {
        debug_assert!(component < self.count(node));
        self.first[node] + component
    }

    /// The rotational DOFs, in increasing order: components 3..6 of every node that
    /// carries six (a beam node's rotation vector follows its translations).
    pub fn rotation_dofs(&self) -> Vec<usize> {
        (0..self.num_nodes())
            .filter(|&node| self.count(node) == 6)
            .flat_map(|node| (3..6).map(move |c| self.first[node] + c))
            .collect()
    }

    /// The node that owns global DOF `dof` and its component.
    pub fn node_of(&self, dof: usize) -> (usize, usize) {
        let node = self.first.partition_point(|&f| f <= dof) - 1;
        (node, dof - self.first[node])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dof_map_numbers_mixed_nodes_contiguously() {
        let map = DofMap::with_counts(&[3, 6, 3]);
        assert_eq!(map.num_dofs(), 12);
        assert_eq!(map.dof(1, 5), 8);
        assert_eq!(map.dof(2, 0), 9);
        assert_eq!(map.node_of(8), (1, 5));
        assert_eq!(map.node_of(9), (2, 0));
        assert_eq!(map.node_of(0), (0, 0));
        assert_eq!(map.rotation_dofs(), vec![6, 7, 8]);
        assert!(DofMap::translational(4).rotation_dofs().is_empty());
    }
}
