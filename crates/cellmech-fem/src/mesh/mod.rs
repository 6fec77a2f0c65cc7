//! The mesh: nodes, blocks of elements of one kind, and named node and element sets.
//!
//! A [`Mesh`] is pure topology and geometry in the internal unit system (µm). It says nothing
//! about materials: a scenario maps element-set names to materials.

pub mod generate;
pub mod locate;
pub mod refine;
pub mod surface;

use std::collections::BTreeMap;

/// Kinds of element a mesh can hold. Readers may produce kinds the engine cannot solve yet
/// (e.g. [`ElementKind::Tet4`]); the model builder rejects them with a clear message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub enum ElementKind {
    /// 8-node trilinear hexahedron, Abaqus/Gmsh node order (bottom face counter-clockwise
    /// seen from +ζ, then the top face).
    Hex8,
    /// 4-node linear tetrahedron (read, not yet solved).
    Tet4,
    /// 10-node quadratic tetrahedron (read, not yet solved).
    Tet10,
    /// 6-node wedge (read, not yet solved).
    Wedge6,
    /// 20-node serendipity hexahedron (read, not yet solved).
    Hex20,
    /// 4-node quadrilateral surface element.
    Quad4,
    /// 3-node triangle surface element.
    Tri3,
    /// 2-node line element.
    Line2,
}

impl ElementKind {
    /// Number of nodes of one element of this kind.
    pub fn nodes_per_element(self) -> usize {
        match self {
            ElementKind::Hex8 => 8,
            ElementKind::Tet4 => 4,
            ElementKind::Tet10 => 10,
            ElementKind::Wedge6 => 6,
            ElementKind::Hex20 => 20,
            ElementKind::Quad4 => 4,
            ElementKind::Tri3 => 3,
            ElementKind::Line2 => 2,
        }
    }

    /// A readable name, as used in error messages.
    pub fn name(self) -> &'static str {
        match self {
            ElementKind::Hex8 => "hex8",
            ElementKind::Tet4 => "tet4",
            ElementKind::Tet10 => "tet10",
            ElementKind::Wedge6 => "wedge6",
            ElementKind::Hex20 => "hex20",
            ElementKind::Quad4 => "quad4",
            ElementKind::Tri3 => "tri3",
            ElementKind::Line2 => "line2",
        }
    }
}

/// A block of elements of one kind with a name (an element set).
#[derive(Debug, Clone, PartialEq)]
pub struct ElementBlock {
    /// Element-set name (e.g. `cytoplasm`, `nucleus`, or the Gmsh physical name).
    pub name: String,
    /// Kind of every element in the block.
    pub kind: ElementKind,
    /// Flat connectivity, `kind.nodes_per_element()` 0-based node indices per element.
    pub connectivity: Vec<usize>,
}

impl ElementBlock {
    /// Number of elements in the block.
    pub fn len(&self) -> usize {
        self.connectivity.len() / self.kind.nodes_per_element()
    }

    /// True when the block holds no element.
    pub fn is_empty(&self) -> bool {
        self.connectivity.is_empty()
    }

    /// Node indices of element `e`.
    pub fn element(&self, e: usize) -> &[usize] {
        let n = self.kind.nodes_per_element();
        &self.connectivity[e * n..(e + 1) * n]
    }

    /// Iterator over the elements' node lists.
    pub fn elements(&self) -> impl Iterator<Item = &[usize]> {
        self.connectivity
            .chunks_exact(self.kind.nodes_per_element())
    }
}

/// Nodes, element blocks and named node sets.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Reference coordinates of every node (µm).
    pub nodes: Vec<[f64; 3]>,
    /// Element blocks; each is a named element set of one kind.
    pub blocks: Vec<ElementBlock>,
    /// Named node sets (0-based node indices, sorted, unique).
    pub node_sets: BTreeMap<String, Vec<usize>>,
}

impl Mesh {
    /// Number of nodes.
    pub fn num_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Total number of elements over all blocks.
    pub fn num_elements(&self) -> usize {
        self.blocks.iter().map(ElementBlock::len).sum()
    }

    /// The block with this name, if any.
    pub fn block(&self, name: &str) -> Option<&ElementBlock> {
        self.blocks.iter().find(|b| b.name == name)
    }

    /// Adds (or replaces) a node set, sorting and de-duplicating its nodes.
    pub fn insert_node_set(&mut self, name: impl Into<String>, mut nodes: Vec<usize>) {
        nodes.sort_unstable();
        nodes.dedup();
        self.node_sets.insert(name.into(), nodes);
    }

    /// Nodes whose coordinate satisfies `pred`, in increasing order.
    pub fn select_nodes(&self, pred: impl Fn(&[f64; 3]) -> bool) -> Vec<usize> {
        (0..self.nodes.len())
            .filter(|&i| pred(&self.nodes[i]))
            .collect()
    }

    /// Axis-aligned bounding box `(min, max)` of the nodes.
    pub fn bounding_box(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.nodes {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }

    /// Checks that every connectivity entry and node-set entry refers to an existing node.
    pub fn validate(&self) -> Result<(), MeshError> {
        let n = self.nodes.len();
        for b in &self.blocks {
            if b.connectivity.len() % b.kind.nodes_per_element() != 0 {
                return Err(MeshError::RaggedConnectivity {
                    block: b.name.clone(),
                });
            }
            if let Some((i, &node)) = b.connectivity.iter().enumerate().find(|(_, &v)| v >= n) {
                return Err(MeshError::MissingNode {
                    place: format!(
                        "element {} of block '{}'",
                        i / b.kind.nodes_per_element(),
                        b.name
                    ),
                    node,
                    num_nodes: n,
                });
            }
        }
        for (name, set) in &self.node_sets {
            if let Some(&node) = set.iter().find(|&&v| v >= n) {
                return Err(MeshError::MissingNode {
                    place: format!("node set '{name}'"),
                    node,
                    num_nodes: n,
                });
            }
        }
        Ok(())
    }
}

/// Structural problems of a mesh.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    /// A connectivity or set entry names a node that does not exist.
    #[error("{place} refers to node index {node}, but the mesh has only {num_nodes} nodes")]
    MissingNode {
        place: String,
        node: usize,
        num_nodes: usize,
    },
    /// A block's connectivity length is not a multiple of its nodes per element.
    #[error(
        "block '{block}' has a connectivity length that is not a multiple of its nodes per element"
    )]
    RaggedConnectivity { block: String },
}
