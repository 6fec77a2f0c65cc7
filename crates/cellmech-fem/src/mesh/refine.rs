//! Local octree refinement of hex8 meshes with hanging nodes tied by exact linear
//! constraints (no transition templates). Design note: `docs/local-refinement.md`.
//!
//! Every hex8 element is the root of an octree. A cell is split into 8 children by the
//! trilinear map of its corners: new nodes at the 12 edge midpoints (mean of the 2 edge
//! ends), the 6 face centres (mean of the 4 face corners) and the centre (mean of the 8
//! corners). Each child is therefore exactly the image of a sub-cube of its parent, node
//! order and orientation included, and the refined elements fill the original ones.
//!
//! Rules:
//! * a cell is split until its level reaches `wanted_level(its corner coordinates)`
//!   (evaluated on every cell, at most [`MAX_REFINEMENT_LEVEL`]);
//! * 2:1 balance across faces **and** edges: a leaf with a face or edge neighbour two or more
//!   levels finer is split (repeated until no leaf is);
//! * new nodes are shared: edge midpoints are keyed by the edge's two node ids, face centres
//!   by the face's four;
//! * in a 2:1 balanced octree a node is *hanging* exactly when it is the midpoint of an
//!   unsplit edge of a leaf (tie `½ a + ½ b`) or the centre of an unsplit face of a leaf
//!   (tie `¼` of each corner). Corners of a tie may hang themselves; they are substituted
//!   (masters of a [`HangingNode`] are never hanging, repeated masters are merged, the
//!   weights sum to 1). The ties reproduce the coarse side's trilinear trace exactly, so
//!   the refined displacement field is continuous.
//!
//! Only hex8 blocks are accepted: a quad4 or line block cannot follow its solid's refinement
//! without re-deriving it, so it is rejected ([`RefineError::NotHex8`]); build surface
//! blocks afterwards from [`RefinedMesh::boundary_faces`].

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use super::generate::quality::HEX8_EDGES;
use super::surface::{orientation, SurfaceError, HEX8_CORNERS, HEX8_FACES};
use super::{ElementBlock, ElementKind, Mesh, MeshError};

/// Largest level [`refine_hex8`] accepts from its callback (each level halves the element
/// size: level 10 is 1024 times finer than the input; the AFM tip's apex in the adherent
/// cell wants 7 to 8 levels below its 3.4 µm base elements).
pub const MAX_REFINEMENT_LEVEL: u8 = 10;

/// Largest number of elements [`refine_hex8`] will produce.
pub const MAX_REFINED_ELEMENTS: usize = 20_000_000;

/// Largest number of input nodes [`refine_hex8`] accepts.
pub const MAX_INPUT_NODES: usize = 1 << 31;

/// A node tied to others: `u_node = Σ w u_master` (each displacement component).
#[derive(Debug, Clone, PartialEq)]
pub struct HangingNode {
    /// The hanging node.
    pub node: usize,
    /// Masters (never hanging themselves) and weights (summing to 1), by increasing node.
    pub masters: Vec<(usize, f64)>,
}

impl HangingNode {
    /// Where the tie puts the node among `nodes`: Σ w Xₘ over its masters. A tied node
    /// must sit there in the reference configuration, or the tie does not follow rigid
    /// rotations (docs/design.md, "Linear constraints").
    pub fn tied_position(&self, nodes: &[[f64; 3]]) -> [f64; 3] {
        weighted_position(&self.masters, nodes)
    }
}

/// Σ w Xₙ over `(node, weight)` pairs, positions from `nodes`.
pub fn weighted_position(pairs: &[(usize, f64)], nodes: &[[f64; 3]]) -> [f64; 3] {
    let mut x = [0.0; 3];
    for &(n, w) in pairs {
        for (c, v) in x.iter_mut().zip(nodes[n]) {
            *c += w * v;
        }
    }
    x
}

/// A refined mesh and what the solver needs to keep it conforming.
#[derive(Debug, Clone, PartialEq)]
pub struct RefinedMesh {
    /// The refined mesh: the input's nodes first (same indices), then the new nodes; the
    /// same blocks in the same order, each element replaced by its leaves (depth first);
    /// every node set kept and completed (see [`refine_hex8`]).
    pub mesh: Mesh,
    /// Hanging nodes with their ties, by increasing node index.
    pub hanging: Vec<HangingNode>,
    /// The outer boundary quads of the refined mesh, outward oriented like
    /// [`super::surface::boundary_quads`], in element order. A coarse face covered by four
    /// finer faces is interior and is not listed.
    pub boundary_faces: Vec<[usize; 4]>,
    /// Refinement level of each element, per block (0: an input element).
    pub levels: Vec<Vec<u8>>,
    /// Index of the input element each element comes from, per block.
    pub parents: Vec<Vec<usize>>,
}

impl RefinedMesh {
    /// The boundary faces whose four nodes all belong to node set `name` (e.g. the free
    /// surface of a cell), like [`super::surface::faces_on_node_set`] but without the
    /// coarse–fine interfaces.
    pub fn faces_on_node_set(&self, name: &str) -> Result<Vec<[usize; 4]>, SurfaceError> {
        let set = self
            .mesh
            .node_sets
            .get(name)
            .ok_or_else(|| SurfaceError::UnknownNodeSet {
                name: name.to_string(),
            })?;
        Ok(self
            .boundary_faces
            .iter()
            .filter(|f| f.iter().all(|n| set.binary_search(n).is_ok()))
            .copied()
            .collect())
    }

    /// Largest element level.
    pub fn max_level(&self) -> u8 {
        self.levels.iter().flatten().copied().max().unwrap_or(0)
    }
}

/// Why a mesh could not be refined.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum RefineError {
    /// A block is not made of hex8 elements.
    #[error(
        "refine: block '{block}' holds {kind} elements; only hex8 blocks can be refined \
         (build surface or line blocks after refining, e.g. from the boundary faces)"
    )]
    NotHex8 {
        /// The block.
        block: String,
        /// Its element kind.
        kind: &'static str,
    },
    /// The mesh refers to missing nodes.
    #[error("refine: {0}")]
    Mesh(#[from] MeshError),
    /// A node coordinate is NaN or infinite.
    #[error("refine: node {node} has a non-finite coordinate {coordinate:?}")]
    NonFiniteNode {
        /// The node.
        node: usize,
        /// Its coordinates.
        coordinate: [f64; 3],
    },
    /// The callback asked for a level above [`MAX_REFINEMENT_LEVEL`].
    #[error(
        "refine: the wanted level {wanted} for a level-{level} part of element {element} of \
         block '{block}' is above the maximum {max}"
    )]
    LevelTooHigh {
        /// Block of the input element.
        block: String,
        /// The input element.
        element: usize,
        /// Level of the cell the callback was asked about.
        level: u8,
        /// What it returned.
        wanted: u8,
        /// [`MAX_REFINEMENT_LEVEL`].
        max: u8,
    },
    /// The input has too many nodes.
    #[error("refine: the input mesh has {nodes} nodes, more than the {max} refine accepts")]
    TooManyNodes {
        /// Nodes of the input.
        nodes: usize,
        /// [`MAX_INPUT_NODES`].
        max: usize,
    },
    /// The refined mesh would be too large.
    #[error("refine: the refined mesh would have more than {max} elements")]
    TooManyElements {
        /// The limit: [`MAX_REFINED_ELEMENTS`] or the caller's smaller one.
        max: usize,
    },
}

/// Refines every element of every hex8 block of `mesh` until its level reaches
/// `wanted_level(corner coordinates)` (asked again on every child), then 2:1-balances the
/// octrees across faces and edges and ties the hanging nodes (see the module docs).
///
/// Node sets: every set is kept. A set that holds every input node (e.g. `all`) gets every
/// new node. Otherwise a new node joins a set when it lies on an edge or face that lies on
/// the mesh boundary or on an interface between two blocks and whose corner nodes all belong
/// to the set (so `z_min`, `surface`, `inner_surface` stay complete).
///
/// A `wanted_level` of 0 everywhere returns the mesh unchanged. The input must be a
/// conforming hex8 mesh (neighbours share their corner nodes).
pub fn refine_hex8(
    mesh: &Mesh,
    wanted_level: impl Fn(&[[f64; 3]; 8]) -> u8,
) -> Result<RefinedMesh, RefineError> {
    refine_hex8_by_level(mesh, |corners, _| wanted_level(corners))
}

/// [`refine_hex8`] with the cell's current level passed to `wanted_level` as well (0 for an
/// input element, +1 per split): a size criterion can then return the absolute level it
/// wants, `level + ⌈log2(size / target)⌉`, from the cell it is asked about.
pub fn refine_hex8_by_level(
    mesh: &Mesh,
    wanted_level: impl Fn(&[[f64; 3]; 8], u8) -> u8,
) -> Result<RefinedMesh, RefineError> {
    refine_hex8_within(mesh, wanted_level, MAX_REFINED_ELEMENTS)
}

/// [`refine_hex8_by_level`] that stops with [`RefineError::TooManyElements`] as soon as the
/// refined mesh would pass `max_elements` (at most [`MAX_REFINED_ELEMENTS`]): a caller that
/// knows its sensible size fails in the time that many splits take, not the time of the
/// engine's own limit.
pub fn refine_hex8_within(
    mesh: &Mesh,
    wanted_level: impl Fn(&[[f64; 3]; 8], u8) -> u8,
    max_elements: usize,
) -> Result<RefinedMesh, RefineError> {
    let max_elements = max_elements.min(MAX_REFINED_ELEMENTS);
    mesh.validate()?;
    if let Some(b) = mesh.blocks.iter().find(|b| b.kind != ElementKind::Hex8) {
        return Err(RefineError::NotHex8 {
            block: b.name.clone(),
            kind: b.kind.name(),
        });
    }
    if let Some((node, &coordinate)) = mesh
        .nodes
        .iter()
        .enumerate()
        .find(|(_, p)| p.iter().any(|c| !c.is_finite()))
    {
        return Err(RefineError::NonFiniteNode { node, coordinate });
    }
    if mesh.num_elements() > max_elements {
        return Err(RefineError::TooManyElements { max: max_elements });
    }
    // Node ids are packed in 32 bits in the edge and face keys; new nodes are at most
    // 19 per split, under 6·10⁷ within the element limit.
    if mesh.num_nodes() > MAX_INPUT_NODES {
        return Err(RefineError::TooManyNodes {
            nodes: mesh.num_nodes(),
            max: MAX_INPUT_NODES,
        });
    }

    let mut refiner = Refiner::new(mesh, max_elements);
    // 1. Wanted levels, root by root.
    let mut root = 0;
    let mut stack = Vec::new();
    for block in &mesh.blocks {
        for element in 0..block.len() {
            stack.push(root);
            while let Some(cell) = stack.pop() {
                let corners = refiner.cells[cell].corners;
                let level = refiner.cells[cell].level;
                let wanted = wanted_level(&corners.map(|n| refiner.nodes[n]), level);
                if wanted > MAX_REFINEMENT_LEVEL {
                    return Err(RefineError::LevelTooHigh {
                        block: block.name.clone(),
                        element,
                        level,
                        wanted,
                        max: MAX_REFINEMENT_LEVEL,
                    });
                }
                if level < wanted {
                    let first = refiner.split(cell)?;
                    stack.extend(first..first + 8);
                }
            }
            root += 1;
        }
    }
    // 2. 2:1 balance across faces and edges.
    refiner.balance()?;
    // 3. Output.
    Ok(refiner.finish(mesh))
}

/// Node ids of a leaf or an inner cell of an octree.
#[derive(Debug, Clone, Copy)]
struct Cell {
    corners: [usize; 8],
    level: u8,
    /// Index of the first of the 8 children (consecutive), or [`NO_CHILD`].
    first_child: usize,
}

const NO_CHILD: usize = usize::MAX;

/// What a new node is the mean of.
#[derive(Debug, Clone, Copy)]
enum Origin {
    Edge([usize; 2]),
    Face([usize; 4]),
    Centre,
}

/// A face on the mesh boundary (`outer`) or on an interface between two blocks.
#[derive(Debug, Clone, Copy)]
struct SurfaceFace {
    nodes: [usize; 4],
    outer: bool,
}

/// Multiplicative hashing of node-id keys, finished by the MurmurHash3 mixer (the default
/// SipHash costs more than the rest of the refinement).
#[derive(Default, Clone, Copy)]
struct IdHasher(u64);

impl IdHasher {
    fn add(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
}

impl Hasher for IdHasher {
    fn finish(&self) -> u64 {
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        h
    }
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.add(u64::from_le_bytes(word));
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.add(v);
    }
    fn write_u128(&mut self, v: u128) {
        self.add(v as u64);
        self.add((v >> 64) as u64);
    }
}

type IdMap<K, V> = HashMap<K, V, BuildHasherDefault<IdHasher>>;

/// Key of an undirected edge (node ids fit in 32 bits, checked on entry).
fn edge_key(a: usize, b: usize) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    ((lo as u64) << 32) | hi as u64
}

/// Key of a face: its sorted node ids.
fn face_key(face: [usize; 4]) -> u128 {
    let mut f = face;
    f.sort_unstable();
    f.iter().fold(0u128, |k, &n| (k << 32) | n as u128)
}

/// Lattice position (0 or 1 per axis) of hex8 corner `a`.
fn corner_bits(a: usize) -> [usize; 3] {
    HEX8_CORNERS[a].map(|c| usize::from(c > 0.0))
}

/// For each of the 27 points `i + 3j + 9k` of the 3×3×3 lattice of a split cell, the
/// parent corners it is the mean of (1, 2, 4 or 8 of them).
fn lattice_parents() -> [([usize; 8], usize); 27] {
    std::array::from_fn(|p| {
        let q = [p % 3, (p / 3) % 3, p / 9];
        let mut corners = [0; 8];
        let mut count = 0;
        for a in 0..8 {
            let bits = corner_bits(a);
            if (0..3).all(|k| q[k] == 1 || q[k] == 2 * bits[k]) {
                corners[count] = a;
                count += 1;
            }
        }
        (corners, count)
    })
}

struct Refiner {
    nodes: Vec<[f64; 3]>,
    num_original: usize,
    /// Origin of node `num_original + i`.
    origins: Vec<Origin>,
    edge_mid: IdMap<u64, usize>,
    face_centre: IdMap<u128, usize>,
    /// Faces on the boundary or on a block interface, at every level.
    surface: IdMap<u128, SurfaceFace>,
    /// Octree cells; the first `num_roots` are the input elements in block order.
    cells: Vec<Cell>,
    num_roots: usize,
    leaves: usize,
    /// Most leaves allowed.
    max_leaves: usize,
    lattice: [([usize; 8], usize); 27],
}

impl Refiner {
    fn new(mesh: &Mesh, max_leaves: usize) -> Self {
        let mut cells = Vec::with_capacity(mesh.num_elements());
        let mut uses: IdMap<u128, (SurfaceFace, usize, usize)> = IdMap::default();
        for (b, block) in mesh.blocks.iter().enumerate() {
            for element in block.elements() {
                let corners: [usize; 8] = std::array::from_fn(|a| element[a]);
                cells.push(Cell {
                    corners,
                    level: 0,
                    first_child: NO_CHILD,
                });
                for face in HEX8_FACES {
                    let nodes = face.map(|a| corners[a]);
                    let entry = uses.entry(face_key(nodes)).or_insert((
                        SurfaceFace { nodes, outer: true },
                        b,
                        0,
                    ));
                    entry.2 += 1;
                    if entry.1 != b {
                        entry.0.outer = false;
                    }
                }
            }
        }
        // Faces used once are on the boundary; faces shared by two blocks are interfaces.
        let surface = uses
            .into_iter()
            .filter(|(_, (face, _, count))| *count == 1 || (*count == 2 && !face.outer))
            .map(|(key, (face, _, _))| (key, face))
            .collect();
        let num_roots = cells.len();
        Refiner {
            nodes: mesh.nodes.clone(),
            num_original: mesh.nodes.len(),
            origins: Vec::new(),
            edge_mid: IdMap::default(),
            face_centre: IdMap::default(),
            surface,
            cells,
            num_roots,
            leaves: num_roots,
            max_leaves,
            lattice: lattice_parents(),
        }
    }

    fn new_node(&mut self, origin: Origin, corners: &[usize]) -> usize {
        let scale = 1.0 / corners.len() as f64;
        let mut p = [0.0; 3];
        for &c in corners {
            for (sum, x) in p.iter_mut().zip(self.nodes[c]) {
                *sum += x;
            }
        }
        self.nodes.push(p.map(|x| x * scale));
        self.origins.push(origin);
        self.nodes.len() - 1
    }

    fn edge_node(&mut self, a: usize, b: usize) -> usize {
        let key = edge_key(a, b);
        if let Some(&m) = self.edge_mid.get(&key) {
            return m;
        }
        let m = self.new_node(Origin::Edge([a, b]), &[a, b]);
        self.edge_mid.insert(key, m);
        m
    }

    fn face_node(&mut self, face: [usize; 4]) -> usize {
        let key = face_key(face);
        if let Some(&f) = self.face_centre.get(&key) {
            return f;
        }
        let f = self.new_node(Origin::Face(face), &face);
        self.face_centre.insert(key, f);
        f
    }

    /// Splits leaf `cell` into 8 children; returns the index of the first.
    fn split(&mut self, cell: usize) -> Result<usize, RefineError> {
        if self.leaves + 7 > self.max_leaves {
            return Err(RefineError::TooManyElements {
                max: self.max_leaves,
            });
        }
        let Cell { corners, level, .. } = self.cells[cell];
        let mut lattice = [0usize; 27];
        for (node, (parents, count)) in lattice.iter_mut().zip(self.lattice) {
            let ids = parents.map(|a| corners[a]);
            *node = match count {
                1 => ids[0],
                2 => self.edge_node(ids[0], ids[1]),
                4 => self.face_node([ids[0], ids[1], ids[2], ids[3]]),
                _ => self.new_node(Origin::Centre, &ids),
            };
        }
        let first = self.cells.len();
        for d in 0..8 {
            let offset = corner_bits(d);
            let child: [usize; 8] = std::array::from_fn(|a| {
                let q: [usize; 3] = std::array::from_fn(|k| offset[k] + corner_bits(a)[k]);
                lattice[q[0] + 3 * q[1] + 9 * q[2]]
            });
            self.cells.push(Cell {
                corners: child,
                level: level + 1,
                first_child: NO_CHILD,
            });
        }
        self.cells[cell].first_child = first;
        self.leaves += 7;
        // The children's faces on a surface face of the parent are surface faces.
        for face in HEX8_FACES {
            let key = face_key(face.map(|a| corners[a]));
            if let Some(&SurfaceFace { outer, .. }) = self.surface.get(&key) {
                for &d in &face {
                    let nodes = face.map(|a| self.cells[first + d].corners[a]);
                    self.surface
                        .insert(face_key(nodes), SurfaceFace { nodes, outer });
                }
            }
        }
        Ok(first)
    }

    /// Whether a leaf has a face or edge neighbour two or more levels finer. Such a
    /// neighbour has an ancestor one level finer than the leaf with a half of one of the
    /// leaf's edges as its own edge (a face neighbour's ancestor covers a quarter of the
    /// face, which touches two of the face's edges), and splitting that ancestor created the
    /// half-edge's midpoint: the test looks for midpoints of half-edges.
    fn unbalanced(&self, corners: &[usize; 8]) -> bool {
        HEX8_EDGES.iter().any(|&[a, b]| {
            let (a, b) = (corners[a], corners[b]);
            self.edge_mid.get(&edge_key(a, b)).is_some_and(|&m| {
                self.edge_mid.contains_key(&edge_key(a, m))
                    || self.edge_mid.contains_key(&edge_key(m, b))
            })
        })
    }

    /// Splits unbalanced leaves until none is left. Only a leaf two levels coarser than the
    /// finest can be unbalanced.
    fn balance(&mut self) -> Result<(), RefineError> {
        loop {
            let finest = self.cells.iter().map(|c| c.level).max().unwrap_or(0);
            let unbalanced: Vec<usize> = (0..self.cells.len())
                .filter(|&c| {
                    let cell = &self.cells[c];
                    cell.first_child == NO_CHILD
                        && cell.level + 2 <= finest
                        && self.unbalanced(&cell.corners)
                })
                .collect();
            if unbalanced.is_empty() {
                return Ok(());
            }
            for c in unbalanced {
                self.split(c)?;
            }
        }
    }

    /// The leaves of root `root`, depth first.
    fn leaves_of(&self, root: usize, out: &mut Vec<usize>) {
        let mut stack = vec![root];
        while let Some(c) = stack.pop() {
            match self.cells[c].first_child {
                NO_CHILD => out.push(c),
                first => stack.extend((first..first + 8).rev()),
            }
        }
    }

    fn finish(self, input: &Mesh) -> RefinedMesh {
        // Elements, block by block, leaves of each input element depth first.
        let mut blocks = Vec::with_capacity(input.blocks.len());
        let mut levels = Vec::with_capacity(input.blocks.len());
        let mut parents = Vec::with_capacity(input.blocks.len());
        let mut boundary_faces = Vec::new();
        let mut hanging = vec![false; self.nodes.len()];
        let mut root = 0;
        let mut leaves = Vec::new();
        for block in &input.blocks {
            let mut connectivity = Vec::new();
            let mut block_levels = Vec::new();
            let mut block_parents = Vec::new();
            for element in 0..block.len() {
                leaves.clear();
                self.leaves_of(root, &mut leaves);
                root += 1;
                for &leaf in &leaves {
                    let Cell { corners, level, .. } = self.cells[leaf];
                    connectivity.extend_from_slice(&corners);
                    block_levels.push(level);
                    block_parents.push(element);
                    for [a, b] in HEX8_EDGES {
                        if let Some(&m) = self.edge_mid.get(&edge_key(corners[a], corners[b])) {
                            hanging[m] = true;
                        }
                    }
                    let flip = orientation(&self.nodes, &corners) < 0.0;
                    for face in HEX8_FACES {
                        let mut nodes = face.map(|a| corners[a]);
                        let key = face_key(nodes);
                        if let Some(&f) = self.face_centre.get(&key) {
                            hanging[f] = true;
                        }
                        if self.surface.get(&key).is_some_and(|s| s.outer) {
                            if flip {
                                nodes.swap(1, 3);
                            }
                            boundary_faces.push(nodes);
                        }
                    }
                }
            }
            blocks.push(ElementBlock {
                name: block.name.clone(),
                kind: ElementKind::Hex8,
                connectivity,
            });
            levels.push(block_levels);
            parents.push(block_parents);
        }
        debug_assert_eq!(root, self.num_roots);
        let hanging = self.ties(&hanging);
        let node_sets = self.node_sets(input);
        RefinedMesh {
            mesh: Mesh {
                nodes: self.nodes,
                blocks,
                node_sets,
            },
            hanging,
            boundary_faces,
            levels,
            parents,
        }
    }

    /// The ties of the hanging nodes, chains resolved. A node's origin corners were created
    /// before it, so in increasing node order they are resolved when it is reached.
    fn ties(&self, hanging: &[bool]) -> Vec<HangingNode> {
        let mut resolved: Vec<Option<usize>> = vec![None; self.nodes.len()];
        let mut out: Vec<HangingNode> = Vec::new();
        for node in self.num_original..self.nodes.len() {
            if !hanging[node] {
                continue;
            }
            let direct: &[usize] = match &self.origins[node - self.num_original] {
                Origin::Edge(ends) => ends,
                Origin::Face(corners) => corners,
                // A cell centre is inside its cell: never on a leaf's edge or face.
                Origin::Centre => continue,
            };
            let w = 1.0 / direct.len() as f64;
            let mut masters: Vec<(usize, f64)> = Vec::with_capacity(8);
            for &d in direct {
                match resolved[d] {
                    Some(t) => masters.extend(out[t].masters.iter().map(|&(m, v)| (m, v * w))),
                    None => masters.push((d, w)),
                }
            }
            masters.sort_unstable_by_key(|&(m, _)| m);
            let mut merged: Vec<(usize, f64)> = Vec::with_capacity(masters.len());
            for (m, v) in masters {
                match merged.last_mut() {
                    Some(last) if last.0 == m => last.1 += v,
                    _ => merged.push((m, v)),
                }
            }
            resolved[node] = Some(out.len());
            out.push(HangingNode {
                node,
                masters: merged,
            });
        }
        out
    }

    /// The input's node sets, completed with the new nodes (see [`refine_hex8`]).
    fn node_sets(&self, input: &Mesh) -> std::collections::BTreeMap<String, Vec<usize>> {
        let mut surface_edges: IdMap<u64, ()> = IdMap::default();
        for face in self.surface.values() {
            for i in 0..4 {
                surface_edges.insert(edge_key(face.nodes[i], face.nodes[(i + 1) % 4]), ());
            }
        }
        let n = self.nodes.len();
        let mut member = vec![false; n];
        let mut sets = std::collections::BTreeMap::new();
        for (name, set) in &input.node_sets {
            let mut nodes = set.clone();
            if set.len() == self.num_original {
                nodes.extend(self.num_original..n);
            } else {
                member.iter_mut().for_each(|m| *m = false);
                set.iter().for_each(|&s| member[s] = true);
                for node in self.num_original..n {
                    let joins = match &self.origins[node - self.num_original] {
                        Origin::Edge([a, b]) => {
                            member[*a]
                                && member[*b]
                                && surface_edges.contains_key(&edge_key(*a, *b))
                        }
                        Origin::Face(corners) => {
                            corners.iter().all(|&c| member[c])
                                && self.surface.contains_key(&face_key(*corners))
                        }
                        Origin::Centre => false,
                    };
                    if joins {
                        member[node] = true;
                        nodes.push(node);
                    }
                }
            }
            sets.insert(name.clone(), nodes);
        }
        sets
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::box_mesh;

    #[test]
    fn refine_one_cube_once_gives_27_nodes_and_no_hanging_node() {
        let mesh = box_mesh([0.0; 3], [2.0; 3], [1, 1, 1], "b").unwrap();
        let r = refine_hex8(&mesh, |_| 1).unwrap();
        assert_eq!((r.mesh.num_nodes(), r.mesh.num_elements()), (27, 8));
        assert!(r.hanging.is_empty());
        assert_eq!(r.boundary_faces.len(), 24);
        assert_eq!(r.levels, vec![vec![1; 8]]);
        assert_eq!(r.parents, vec![vec![0; 8]]);
        // Children keep the parent's node order: child 0 is the octant at corner 0.
        let child0: Vec<[f64; 3]> = r.mesh.blocks[0]
            .element(0)
            .iter()
            .map(|&n| r.mesh.nodes[n])
            .collect();
        let expect: Vec<[f64; 3]> = HEX8_CORNERS
            .iter()
            .map(|c| c.map(|x| 0.5 * (x + 1.0)))
            .collect();
        assert_eq!(child0, expect);
        for name in ["x_min", "z_max"] {
            assert_eq!(r.mesh.node_sets[name].len(), 9, "{name}");
        }
        assert_eq!(r.mesh.node_sets["all"].len(), 27);
        // Level 0 everywhere: unchanged.
        let same = refine_hex8(&mesh, |_| 0).unwrap();
        assert_eq!(same.mesh, mesh);
    }

    #[test]
    fn refine_one_of_two_cubes_ties_the_five_nodes_on_the_shared_face() {
        let mesh = box_mesh([0.0; 3], [2.0, 1.0, 1.0], [2, 1, 1], "b").unwrap();
        let r = refine_hex8(&mesh, |x| u8::from(x[0][0] < 0.5)).unwrap();
        assert_eq!(r.mesh.num_elements(), 9);
        let tied: Vec<usize> = r.hanging.iter().map(|h| h.node).collect();
        assert_eq!(
            tied.len(),
            5,
            "4 edge midpoints and the centre of the face x = 1"
        );
        for h in &r.hanging {
            let p = r.mesh.nodes[h.node];
            assert_eq!(p[0], 1.0);
            let weights: Vec<f64> = h.masters.iter().map(|m| m.1).collect();
            let on_edge = p[1].fract() == 0.0 || p[2].fract() == 0.0;
            assert_eq!(weights, if on_edge { vec![0.5; 2] } else { vec![0.25; 4] });
        }
        // 6 faces of the coarse cube minus the shared one, 4 × 5 fine ones.
        assert_eq!(r.boundary_faces.len(), 5 + 20);
    }

    #[test]
    fn a_refinement_stops_at_the_callers_limit() {
        // Two levels of a 2-element box make 128 leaves: allowed at 128, an error at 100.
        let mesh = box_mesh([0.0; 3], [2.0, 1.0, 1.0], [2, 1, 1], "b").unwrap();
        let fine = refine_hex8_within(&mesh, |_, _| 2, 128).unwrap();
        assert_eq!(fine.mesh.num_elements(), 128);
        assert_eq!(
            refine_hex8_within(&mesh, |_, _| 2, 100).unwrap_err(),
            RefineError::TooManyElements { max: 100 }
        );
    }

    #[test]
    fn refine_ties_resolve_chains_through_hanging_corners() {
        // Unbalanced on purpose (balance is skipped): the right cube is split and its child
        // at the shared face's corner 0 split again. The midpoint of the edge between the
        // face's edge midpoint m01 and its centre f hangs on a level-1 leaf whose corners m01
        // and f hang on the left cube: ½ m01 + ½ f = 3/8 c0 + 3/8 c1 + 1/8 c2 + 1/8 c3.
        let mesh = box_mesh([0.0; 3], [2.0, 1.0, 1.0], [2, 1, 1], "b").unwrap();
        let mut refiner = Refiner::new(&mesh, MAX_REFINED_ELEMENTS);
        let first = refiner.split(1).unwrap();
        refiner.split(first).unwrap();
        let r = refiner.finish(&mesh);
        let at = |p: [f64; 3]| r.mesh.nodes.iter().position(|&x| x == p).unwrap();
        let tie = r
            .hanging
            .iter()
            .find(|h| r.mesh.nodes[h.node] == [1.0, 0.5, 0.25])
            .expect("the level-2 node on the shared face hangs");
        let mut expect = vec![
            (at([1.0, 0.0, 0.0]), 0.375),
            (at([1.0, 1.0, 0.0]), 0.375),
            (at([1.0, 0.0, 1.0]), 0.125),
            (at([1.0, 1.0, 1.0]), 0.125),
        ];
        expect.sort_by_key(|m| m.0);
        assert_eq!(tie.masters, expect);
        let hanging: Vec<usize> = r.hanging.iter().map(|h| h.node).collect();
        for h in &r.hanging {
            assert!(h.masters.iter().all(|(m, _)| !hanging.contains(m)));
            assert_eq!(h.masters.iter().map(|m| m.1).sum::<f64>(), 1.0);
        }
    }

    #[test]
    fn refine_rejects_bad_input_with_clear_errors() {
        let mut mesh = box_mesh([0.0; 3], [1.0; 3], [1, 1, 1], "b").unwrap();
        let e = refine_hex8(&mesh, |_| MAX_REFINEMENT_LEVEL + 1).unwrap_err();
        assert!(
            e.to_string().contains("wanted level 11") && e.to_string().contains("maximum 10"),
            "{e}"
        );
        mesh.blocks.push(ElementBlock {
            name: "skin".into(),
            kind: ElementKind::Quad4,
            connectivity: vec![0, 1, 2, 3],
        });
        let e = refine_hex8(&mesh, |_| 1).unwrap_err();
        assert!(e.to_string().contains("block 'skin' holds quad4"), "{e}");
        mesh.blocks.pop();
        mesh.nodes[3][1] = f64::NAN;
        assert!(matches!(
            refine_hex8(&mesh, |_| 1),
            Err(RefineError::NonFiniteNode { node: 3, .. })
        ));
        mesh.nodes[3][1] = 1.0;
        mesh.blocks[0].connectivity[5] = 99;
        assert!(matches!(
            refine_hex8(&mesh, |_| 1),
            Err(RefineError::Mesh(_))
        ));
    }
}
