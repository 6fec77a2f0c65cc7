//! ALE rezoning of a hyperelastic hex8 region: the nodes move relative to the material.
//!
//! A Lagrangian mesh follows the material, so where the material's deformation
//! concentrates without bound (the stagnation point under an indenter's nose: the material
//! on the axis is crushed against the tip and never passes it) the elements fold however
//! fine the mesh. Commercial codes rezone there (the "ALE adaptive meshing" of Abaqus/
//! Explicit and Standard): between increments the nodes of a region are moved to a
//! smoother mesh of the *current* body and the solution is mapped onto them.
//!
//! For a hyperelastic material without internal variables the state is the deformation
//! map φ alone, and mapping it is exact at the nodes: a node moved to the current point
//! x′ becomes the material point X′ = φ⁻¹(x′), found in the old current element that
//! contains x′ (its natural coordinates ξ′, then X′ = Σ N_a(ξ′) X_a). Every nodal field
//! (reference positions, displacements, earlier states' displacements) is interpolated
//! with the same weights ([`NodeRemap`]), so the new mesh carries the same trilinear
//! interpolation of φ at its nodes; what changes is only the interpolation between them.
//!
//! The new current positions ([`mesh_motion`]): free-surface nodes slide along the
//! current surface, their surface displacement made harmonic along it (`surface`); the
//! interior follows by carrying the reference mesh onto the current boundary in
//! [`MOTION_SUBSTEPS`] harmonic increments, stiffened where the moving mesh is compressed
//! (Stein, Tezduyar & Benney 2003). The mesh keeps its grading, hanging nodes stay on their
//! masters' edges and faces in both configurations, and a uniform stretch is reproduced
//! exactly (nothing moves).
//!
//! [`rezone`] maps the motion and its halvings (up to [`MAX_HALVINGS`]) and applies one
//! by its [`Acceptance`]; [`remap_to`] maps any given targets;
//! [`crate::solve::Problem::remap_nodes`] applies a rezoning to a problem. What it does
//! on the adherent cell, and why it is off by default: `docs/rezoning.md`.

use crate::element::hex8::Hex8Reference;
use crate::mesh::generate::quality::hex8_corner_jacobians;
use crate::mesh::locate::HostLocator;

/// The mesh motion (and a target outside the material) is halved at most this many times.
pub const MAX_HALVINGS: usize = 4;

/// The mesh motion carries the reference mesh to the current boundary in this many
/// substeps, each a harmonic increment on the mesh as moved so far.
pub const MOTION_SUBSTEPS: usize = 8;

/// Relative residual of the mesh-motion solve (conjugate gradients).
const CG_TOLERANCE: f64 = 1e-10;

/// A node's new values as weights of old nodal values: every nodal field f becomes
/// f′(node) = Σ w f(source).
#[derive(Debug, Clone, PartialEq)]
pub struct NodeRemap {
    /// The node.
    pub node: usize,
    /// Old nodes and their weights (they sum to 1).
    pub sources: Vec<(usize, f64)>,
}

impl NodeRemap {
    /// The remapped value of a nodal vector field.
    pub fn apply(&self, field: &[[f64; 3]]) -> [f64; 3] {
        let mut v = [0.0; 3];
        for &(n, w) in &self.sources {
            for i in 0..3 {
                v[i] += w * field[n][i];
            }
        }
        v
    }
}

/// What to rezone: a hex8 mesh in its reference and current configurations.
#[derive(Debug, Clone, Copy)]
pub struct RezoneInput<'a> {
    /// Reference (stress-free) node coordinates (µm).
    pub reference: &'a [[f64; 3]],
    /// Current node coordinates (µm).
    pub current: &'a [[f64; 3]],
    /// The hex8 elements of the material that may be rezoned (one material, or several
    /// whose interfaces hold no movable node).
    pub elements: &'a [[usize; 8]],
    /// Per node: may it move? Nodes of other terms, prescribed nodes, interfaces between
    /// materials, the free surface and hanging nodes must not.
    pub movable: &'a [bool],
    /// Hanging nodes among the elements' nodes, each with its masters and weights.
    pub hanging: &'a [(usize, Vec<(usize, f64)>)],
    /// Quad faces of the free surface (leaf faces, outward or not): where `sliding` nodes
    /// stay. Empty when no node slides.
    pub surface_faces: &'a [[usize; 4]],
    /// Per node (or empty: none): a free-surface node that may slide along the surface
    /// (not `movable`: a surface node must stay on the surface).
    pub sliding: &'a [bool],
}

/// Which rezonings [`rezone`] applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Acceptance {
    /// Only one that leaves the worst element it touches better than before (the mesh
    /// is left alone where the Lagrangian mesh is still as good).
    #[default]
    Better,
    /// The largest motion (halved up to [`MAX_HALVINGS`] times) that leaves every element
    /// it touches valid (the fixed-frequency rezoning of ALE codes).
    Valid,
}

/// A computed rezoning.
#[derive(Debug, Clone, PartialEq)]
pub struct Rezoning {
    /// The nodes that move (free nodes, then the hanging nodes that follow them).
    pub remaps: Vec<NodeRemap>,
    /// Smallest corner Jacobian ratio (current / reference) over the elements touched,
    /// before.
    pub min_corner_ratio_before: f64,
    /// The same after the rezoning.
    pub min_corner_ratio_after: f64,
    /// Elements touched (holding a moved node).
    pub elements_touched: usize,
    /// Movable nodes left in place because their new position lay outside the material
    /// even with its motion halved [`MAX_HALVINGS`] times.
    pub unlocated: usize,
    /// Fraction of the harmonic mesh motion applied (1, or halved for validity).
    pub motion_fraction: f64,
    /// Conjugate-gradient iterations of the mesh-motion solve (all three components).
    pub cg_iterations: usize,
}

/// Why a rezoning could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RezoneError {
    /// Arrays of different lengths, or a node index out of range.
    #[error("rezoning: {0}")]
    Input(String),
    /// The mesh-motion solve did not converge.
    #[error("rezoning: the mesh-motion solve did not converge ({iterations} iterations, relative residual {residual:.2e})")]
    MotionSolve {
        /// Iterations done.
        iterations: usize,
        /// Relative residual reached.
        residual: f64,
    },
}

/// The role of a node in the mesh-motion problem.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    Fixed,
    Free(usize),
    Hanging(usize),
}

/// Smallest ratio of current to reference corner Jacobian of one element (≤ 0: folded or
/// inverted in either configuration, `-inf` when the reference itself is inverted).
fn corner_ratio(x0: &[[f64; 3]; 8], x: &[[f64; 3]; 8]) -> f64 {
    let (j, j0) = (hex8_corner_jacobians(x), hex8_corner_jacobians(x0));
    (0..8).fold(f64::INFINITY, |m, a| {
        if j0[a] <= 0.0 {
            f64::NEG_INFINITY
        } else {
            m.min(j[a] / j0[a])
        }
    })
}

/// Computes the rezoning of `input`'s movable nodes, or `None` when no node can move or
/// the motion would not improve the mesh.
pub fn rezone(
    input: &RezoneInput<'_>,
    acceptance: Acceptance,
) -> Result<Option<Rezoning>, RezoneError> {
    let Some(motion) = mesh_motion(input)? else {
        return Ok(None);
    };
    // For the halved motions: the faces around the slid nodes, and the old current mesh.
    let slid: std::collections::HashSet<usize> = motion.surface.iter().map(|(n, _)| *n).collect();
    let projector = surface::SurfaceProjector::new(
        input
            .surface_faces
            .iter()
            .copied()
            .filter(|f| f.iter().any(|a| slid.contains(a)))
            .collect(),
        input.current,
    );
    let locator = old_mesh_locator(input)?;
    // The motion and its halvings: with `Better`, the one that leaves the best worst
    // element, if it is better than before; with `Valid`, the largest that leaves every
    // element valid.
    let mut best: Option<Rezoning> = None;
    for halving in 0..=MAX_HALVINGS {
        let fraction = 0.5f64.powi(halving as i32);
        let surface_remaps: Vec<NodeRemap> = motion
            .surface
            .iter()
            .filter_map(|(node, point)| {
                if halving == 0 {
                    return Some(point.remap(*node));
                }
                let x = input.current[*node];
                let p = std::array::from_fn(|c| x[c] + fraction * (point.x[c] - x[c]));
                projector.project(p).map(|q| q.remap(*node))
            })
            .collect();
        let targets: Vec<(usize, [f64; 3])> = motion
            .interior
            .iter()
            .map(|&(node, target)| {
                let x = input.current[node];
                (
                    node,
                    std::array::from_fn(|c| x[c] + fraction * (target[c] - x[c])),
                )
            })
            .collect();
        let mut rezoning = remap_located(input, &locator, &targets, surface_remaps)?;
        rezoning.motion_fraction = fraction;
        rezoning.cg_iterations = motion.cg_iterations;
        let (before, after) = (
            rezoning.min_corner_ratio_before,
            rezoning.min_corner_ratio_after,
        );
        if acceptance == Acceptance::Valid && after > 0.0 {
            // The largest valid motion.
            return Ok(Some(rezoning));
        }
        if after > before
            && after > 0.0
            && best
                .as_ref()
                .is_none_or(|b| after > b.min_corner_ratio_after)
        {
            best = Some(rezoning);
        }
    }
    Ok(best)
}

/// The smooth mesh of the current body that [`rezone`] moves the nodes towards.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshMotion {
    /// Sliding surface nodes and their new points on the current surface.
    pub surface: Vec<(usize, SurfacePoint)>,
    /// Movable interior nodes and their new current positions.
    pub interior: Vec<(usize, [f64; 3])>,
    /// Conjugate-gradient iterations of the interior's harmonic extension.
    pub cg_iterations: usize,
}

/// The new current positions of the movable and sliding nodes of `input` (`None` when
/// none may move, or when the moving mesh inverts an element on its way): the surface displacement made harmonic along the surface, then the
/// interior's harmonic extension of every fixed and slid node's mesh motion.
pub fn mesh_motion(input: &RezoneInput<'_>) -> Result<Option<MeshMotion>, RezoneError> {
    let n = input.reference.len();
    if input.current.len() != n || input.movable.len() != n {
        return Err(RezoneError::Input(format!(
            "{} reference, {} current positions and {} movable flags; expected one each per node",
            n,
            input.current.len(),
            input.movable.len()
        )));
    }
    let out_of_range = input
        .elements
        .iter()
        .flatten()
        .chain(input.hanging.iter().map(|(h, _)| h))
        .chain(
            input
                .hanging
                .iter()
                .flat_map(|(_, m)| m.iter().map(|(n, _)| n)),
        )
        .find(|&&node| node >= n);
    if let Some(node) = out_of_range {
        return Err(RezoneError::Input(format!(
            "node {node} out of range ({n} nodes)"
        )));
    }
    // Roles: hanging nodes follow their masters, whatever the flags say.
    let mut role = vec![Role::Fixed; n];
    let mut in_elements = vec![false; n];
    for &node in input.elements.iter().flatten() {
        in_elements[node] = true;
    }
    let is_hanging: std::collections::HashSet<usize> =
        input.hanging.iter().map(|(h, _)| *h).collect();
    let sliding: Vec<bool> = (0..n)
        .map(|node| {
            input.sliding.get(node).copied().unwrap_or(false)
                && in_elements[node]
                && !is_hanging.contains(&node)
        })
        .collect();
    // The surface first: its new points are the Dirichlet data of the interior's motion.
    let slid = if sliding.iter().any(|&s| s) {
        surface::slide(
            input.reference,
            input.current,
            input.surface_faces,
            &sliding,
            input.hanging,
        )
    } else {
        Vec::new()
    };
    let mut free = Vec::new();
    for node in 0..n {
        if input.movable[node] && in_elements[node] && !sliding[node] {
            role[node] = Role::Free(free.len());
            free.push(node);
        }
    }
    for (t, (h, _)) in input.hanging.iter().enumerate() {
        role[*h] = Role::Hanging(t);
    }
    free.retain(|&node| matches!(role[node], Role::Free(_)));
    for (i, &node) in free.iter().enumerate() {
        role[node] = Role::Free(i);
    }
    for (h, masters) in input.hanging {
        if let Some((m, _)) = masters
            .iter()
            .find(|(m, _)| matches!(role[*m], Role::Hanging(_)))
        {
            return Err(RezoneError::Input(format!(
                "hanging node {h} has a hanging master {m}; expected masters that are mesh nodes"
            )));
        }
    }
    if free.is_empty() && slid.is_empty() {
        return Ok(None);
    }
    // Hanging nodes that follow a free node.
    let follows_free = |t: usize| {
        input.hanging[t]
            .1
            .iter()
            .any(|(m, _)| matches!(role[*m], Role::Free(_)))
    };
    let depends = |node: usize| match role[node] {
        Role::Free(_) => true,
        Role::Hanging(t) => follows_free(t),
        Role::Fixed => false,
    };
    // Elements of the mesh-motion problem.
    let active: Vec<usize> = (0..input.elements.len())
        .filter(|&e| input.elements[e].iter().any(|&node| depends(node)))
        .collect();
    for &e in &active {
        let conn = &input.elements[e];
        let x0: [[f64; 3]; 8] = std::array::from_fn(|a| input.reference[conn[a]]);
        if Hex8Reference::new(&x0).is_err() {
            return Err(RezoneError::Input(format!(
                "element {e} (nodes {conn:?}) is inverted in the reference configuration"
            )));
        }
    }
    // Where every fixed node ends: where it is, or where a sliding node slid to.
    let mut target = input.current.to_vec();
    for (node, point) in &slid {
        target[*node] = point.x;
    }
    // The mesh being moved, from the reference mesh to the current boundary in substeps.
    let mut y = input.reference.to_vec();
    let follow_hanging = |y: &mut [[f64; 3]]| {
        for (h, masters) in input.hanging {
            y[*h] = std::array::from_fn(|c| masters.iter().map(|&(m, w)| w * y[m][c]).sum());
        }
    };
    let mut cg_iterations = 0;
    let mut laplacians = vec![[[0.0; 8]; 8]; active.len()];
    for _ in 0..MOTION_SUBSTEPS {
        // Laplacians on the moving mesh, stiffened where it is compressed: the coefficient
        // (V₀ / V)^χ with χ = 1 (Stein, Tezduyar & Benney 2003), so the small and the
        // squeezed elements move more rigidly. Uniform under a uniform stretch, so linear
        // motions stay exact.
        for (k, &e) in laplacians.iter_mut().zip(&active) {
            let conn = &input.elements[e];
            let xe: [[f64; 3]; 8] = std::array::from_fn(|a| y[conn[a]]);
            let x0: [[f64; 3]; 8] = std::array::from_fn(|a| input.reference[conn[a]]);
            let (Ok(now), Ok(then)) = (Hex8Reference::new(&xe), Hex8Reference::new(&x0)) else {
                return Ok(None);
            };
            let stiffening = then.volume() / now.volume();
            *k = [[0.0; 8]; 8];
            for q in 0..8 {
                let (g, w) = (now.gradients(q), stiffening * now.weight(q));
                for a in 0..8 {
                    for b in 0..8 {
                        k[a][b] += w * (0..3).map(|i| g[a][i] * g[b][i]).sum::<f64>();
                    }
                }
            }
        }
        // This substep's motion of the fixed nodes.
        let step: Vec<[f64; 3]> = (0..n)
            .map(|node| {
                std::array::from_fn(|c| {
                    (target[node][c] - input.reference[node][c]) / MOTION_SUBSTEPS as f64
                })
            })
            .collect();
        let v = harmonic_increment(
            input,
            &role,
            &free,
            &active,
            &laplacians,
            &step,
            &mut cg_iterations,
        )?;
        for (i, &node) in free.iter().enumerate() {
            for c in 0..3 {
                y[node][c] += v[i][c];
            }
        }
        for node in 0..n {
            if role[node] == Role::Fixed {
                for c in 0..3 {
                    y[node][c] += step[node][c];
                }
            }
        }
        follow_hanging(&mut y);
    }
    Ok(Some(MeshMotion {
        surface: slid,
        interior: free.iter().map(|&node| (node, y[node])).collect(),
        cg_iterations,
    }))
}

/// One substep of the mesh motion: the free nodes' increment that makes the motion
/// harmonic (Σ_e K_e v = 0 at free nodes, hanging nodes tied) given the fixed nodes'
/// increments `step`; preconditioned conjugate gradients, per component.
fn harmonic_increment(
    input: &RezoneInput<'_>,
    role: &[Role],
    free: &[usize],
    active: &[usize],
    laplacians: &[[[f64; 8]; 8]],
    step: &[[f64; 3]],
    cg_iterations: &mut usize,
) -> Result<Vec<[f64; 3]>, RezoneError> {
    let n = role.len();
    // Full nodal values from free values x (one component) and the fixed values.
    let expand = |x: &[f64], fixed: Option<usize>, full: &mut [f64]| {
        for &e in active {
            for &node in &input.elements[e] {
                full[node] = match role[node] {
                    Role::Free(i) => x[i],
                    Role::Fixed => fixed.map_or(0.0, |c| step[node][c]),
                    Role::Hanging(t) => input.hanging[t]
                        .1
                        .iter()
                        .map(|&(m, w)| {
                            w * match role[m] {
                                Role::Free(i) => x[i],
                                _ => fixed.map_or(0.0, |c| step[m][c]),
                            }
                        })
                        .sum(),
                };
            }
        }
    };
    // The hanging nodes in the active elements: their rows go to their free masters.
    let mut followers: Vec<usize> = active
        .iter()
        .flat_map(|&e| input.elements[e].iter())
        .filter_map(|&node| match role[node] {
            Role::Hanging(t) => Some(t),
            _ => None,
        })
        .collect();
    followers.sort_unstable();
    followers.dedup();
    // y = Eᵀ K full.
    let multiply = |full: &[f64], scratch: &mut [f64], y: &mut [f64]| {
        for &e in active {
            for &node in &input.elements[e] {
                scratch[node] = 0.0;
            }
        }
        for (k, &e) in laplacians.iter().zip(active) {
            let conn = &input.elements[e];
            for a in 0..8 {
                let v: f64 = (0..8).map(|b| k[a][b] * full[conn[b]]).sum();
                scratch[conn[a]] += v;
            }
        }
        for (yi, &node) in y.iter_mut().zip(free) {
            *yi = scratch[node];
        }
        for &t in &followers {
            let (h, masters) = &input.hanging[t];
            for &(m, w) in masters {
                if let Role::Free(i) = role[m] {
                    y[i] += w * scratch[*h];
                }
            }
        }
    };
    // Jacobi preconditioner: the diagonal of K on free nodes, plus w² K_hh of hanging ones.
    let mut diagonal = vec![0.0; free.len()];
    for (k, &e) in laplacians.iter().zip(active) {
        for (a, &node) in input.elements[e].iter().enumerate() {
            match role[node] {
                Role::Free(i) => diagonal[i] += k[a][a],
                Role::Hanging(t) => {
                    for &(m, w) in &input.hanging[t].1 {
                        if let Role::Free(i) = role[m] {
                            diagonal[i] += w * w * k[a][a];
                        }
                    }
                }
                Role::Fixed => {}
            }
        }
    }
    let mut full = vec![0.0; n];
    let mut scratch = vec![0.0; n];
    let mut motion = vec![[0.0; 3]; free.len()];
    for c in 0..3 {
        // b = −Eᵀ K g.
        expand(&vec![0.0; free.len()], Some(c), &mut full);
        let mut b = vec![0.0; free.len()];
        multiply(&full, &mut scratch, &mut b);
        b.iter_mut().for_each(|v| *v = -*v);
        let b_norm = b.iter().map(|v| v * v).sum::<f64>().sqrt();
        let mut x = vec![0.0; free.len()];
        let mut r = b.clone();
        let mut ax = vec![0.0; free.len()];
        let mut z: Vec<f64> = r.iter().zip(&diagonal).map(|(r, d)| r / d).collect();
        let mut p = z.clone();
        let mut rz: f64 = r.iter().zip(&z).map(|(r, z)| r * z).sum();
        let max_iterations = 20 * free.len() + 100;
        let mut residual = b_norm;
        let mut iterations = 0;
        while residual > CG_TOLERANCE * b_norm && residual > 0.0 {
            if iterations >= max_iterations {
                return Err(RezoneError::MotionSolve {
                    iterations,
                    residual: residual / b_norm,
                });
            }
            iterations += 1;
            expand(&p, None, &mut full);
            multiply(&full, &mut scratch, &mut ax);
            let pap: f64 = p.iter().zip(&ax).map(|(p, a)| p * a).sum();
            let alpha = rz / pap;
            for i in 0..x.len() {
                x[i] += alpha * p[i];
                r[i] -= alpha * ax[i];
            }
            residual = r.iter().map(|v| v * v).sum::<f64>().sqrt();
            for i in 0..z.len() {
                z[i] = r[i] / diagonal[i];
            }
            let rz_new: f64 = r.iter().zip(&z).map(|(r, z)| r * z).sum();
            let beta = rz_new / rz;
            rz = rz_new;
            for i in 0..p.len() {
                p[i] = z[i] + beta * p[i];
            }
        }
        *cg_iterations += iterations;
        for (i, m) in motion.iter_mut().enumerate() {
            m[c] = x[i];
        }
    }
    Ok(motion)
}

/// Moves the nodes of `targets` to the given current positions: each becomes the material
/// point found there in the old current mesh (a target outside every element leaves its
/// node in place, counted in [`Rezoning::unlocated`]); hanging nodes follow their masters.
/// The building block of [`rezone`], public for tests and for other mesh motions.
pub fn remap_to(
    input: &RezoneInput<'_>,
    targets: &[(usize, [f64; 3])],
    surface_remaps: Vec<NodeRemap>,
) -> Result<Rezoning, RezoneError> {
    let n = input.reference.len();
    if input.current.len() != n {
        return Err(RezoneError::Input(format!(
            "{n} reference and {} current positions",
            input.current.len()
        )));
    }
    let hanging_node: std::collections::HashSet<usize> =
        input.hanging.iter().map(|(h, _)| *h).collect();
    if let Some((node, _)) = targets
        .iter()
        .find(|(node, _)| *node >= n || hanging_node.contains(node))
    {
        return Err(RezoneError::Input(format!(
            "node {node} cannot be moved: out of range or a hanging node"
        )));
    }
    let locator = old_mesh_locator(input)?;
    remap_located(input, &locator, targets, surface_remaps)
}

/// The old current mesh, for finding the material under each new position.
fn old_mesh_locator(input: &RezoneInput<'_>) -> Result<HostLocator, RezoneError> {
    let block = crate::mesh::ElementBlock {
        name: "rezoned".into(),
        kind: crate::mesh::ElementKind::Hex8,
        connectivity: input.elements.iter().flatten().copied().collect(),
    };
    HostLocator::from_blocks(input.current, &[&block])
        .map_err(|e| RezoneError::Input(e.to_string()))
}

/// [`remap_to`] with the old mesh's locator built.
fn remap_located(
    input: &RezoneInput<'_>,
    locator: &HostLocator,
    targets: &[(usize, [f64; 3])],
    surface_remaps: Vec<NodeRemap>,
) -> Result<Rezoning, RezoneError> {
    let n = input.reference.len();
    let mut remaps = Vec::with_capacity(targets.len());
    let mut unlocated = 0;
    for &(node, target) in targets {
        // A target outside the material (past a thin layer under the surface) is brought
        // back towards where the node is, halving its motion, until it lies inside.
        let x = input.current[node];
        let mut found = None;
        for halving in 0..=MAX_HALVINGS {
            let f = 0.5f64.powi(halving as i32);
            let p = std::array::from_fn(|c| x[c] + f * (target[c] - x[c]));
            if let Ok(location) = locator.locate(p, 1e-9) {
                found = Some(location);
                break;
            }
        }
        match found {
            Some(location) => remaps.push(NodeRemap {
                node,
                sources: location
                    .nodes
                    .iter()
                    .copied()
                    .zip(location.weights())
                    .filter(|&(_, w)| w != 0.0)
                    .collect(),
            }),
            None => {
                unlocated += 1;
                remaps.push(NodeRemap {
                    node,
                    sources: vec![(node, 1.0)],
                });
            }
        }
    }
    remaps.extend(surface_remaps);
    // Hanging nodes that follow a moved node: their masters' remaps, weighted.
    let index_of: std::collections::HashMap<usize, usize> = remaps
        .iter()
        .enumerate()
        .map(|(i, remap)| (remap.node, i))
        .collect();
    for (h, masters) in input.hanging {
        if !masters.iter().any(|(m, _)| index_of.contains_key(m)) {
            continue;
        }
        let mut sources: Vec<(usize, f64)> = Vec::new();
        for &(m, w) in masters {
            match index_of.get(&m) {
                Some(&i) => sources.extend(remaps[i].sources.iter().map(|&(s, v)| (s, w * v))),
                None => sources.push((m, w)),
            }
        }
        remaps.push(NodeRemap { node: *h, sources });
    }
    let mut moved = vec![false; n];
    for remap in &remaps {
        moved[remap.node] = true;
    }
    let touched: Vec<usize> = (0..input.elements.len())
        .filter(|&e| input.elements[e].iter().any(|&node| moved[node]))
        .collect();
    let mut reference = input.reference.to_vec();
    let mut current = input.current.to_vec();
    for remap in &remaps {
        reference[remap.node] = remap.apply(input.reference);
        current[remap.node] = remap.apply(input.current);
    }
    let ratio_of = |reference: &[[f64; 3]], current: &[[f64; 3]]| {
        touched
            .iter()
            .map(|&e| {
                let conn = &input.elements[e];
                corner_ratio(
                    &std::array::from_fn(|a| reference[conn[a]]),
                    &std::array::from_fn(|a| current[conn[a]]),
                )
            })
            .fold(f64::INFINITY, f64::min)
    };
    Ok(Rezoning {
        min_corner_ratio_before: ratio_of(input.reference, input.current),
        min_corner_ratio_after: ratio_of(&reference, &current),
        remaps,
        elements_touched: touched.len(),
        unlocated,
        motion_fraction: 1.0,
        cg_iterations: 0,
    })
}

mod surface;

pub use surface::FacePoint as SurfacePoint;

#[cfg(test)]
mod tests;
