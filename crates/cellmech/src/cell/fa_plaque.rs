//! FA plaques: the surface nodes within a radius of a focal adhesion's node, tied to it so
//! that the filaments anchored there pull on a patch rather than on one node (the spec,
//! suspended cell: "if a single node cannot carry the load, an FA may be a small patch of
//! surface nodes tied together"). Shared by the adherent and the suspended cell.

use cellmech_fem::mesh::Mesh;

/// How an FA's plaque (the surface nodes within `fa_radius` of the FA node) carries the pull
/// of the filaments anchored at the FA node: the couplings of commercial codes (Abaqus
/// `*COUPLING`, `KINEMATIC` or `DISTRIBUTING` with uniform or linear weights).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaCoupling {
    /// Kinematic: every plaque node moves with the FA node, a rigid disc in translation.
    Rigid,
    /// Distributing: the FA node moves with the plaque nodes' mean (uniform weights) and
    /// its load is shared among them equally; the plaque deforms with the surface.
    Distributing,
    /// Distributing with weights that fall linearly from the FA node to the plaque's rim
    /// (as the linear weighting method of Abaqus's distributing coupling), each times the
    /// surface area the node stands for: the load becomes a traction that is largest at the
    /// FA and vanishes at the rim, the same on every mesh as the mesh is refined, where
    /// equal weights per node change with the number of nodes in the plaque.
    DistributingLinear,
}

/// Couples every node of `surface` within `radius` of an FA node (the nearest FA when
/// several; nodes for which `skip` holds are left alone) to it, so that the FA is a plaque
/// rather than one node: a single node cannot carry a filament's pull where the mesh is
/// refined (a point force on ever smaller elements; the adherent receptor's prestress
/// stalls at 1 % of the ramp, and the suspended cell's elements at its FA nodes fold over in
/// compression). [`FaCoupling::Rigid`] ties each plaque node to
/// the FA node, and hanging-node ties whose masters fall in a plaque are rewritten onto
/// the FA node; [`FaCoupling::Distributing`] ties the FA node to its plaque nodes with
/// equal weights ([`FaCoupling::DistributingLinear`]: weights ∝ the node's share of
/// `faces`' area × (1 − distance / `radius`)), and hanging-node ties whose masters include
/// an FA node are rewritten onto its plaque nodes (an FA whose plaque holds no free node,
/// or none of positive weight, stays a single node). No
/// chains either way; hanging nodes keep their own ties. With [`FaReference::Separate`] a
/// distributing coupling gets its own reference node per FA instead (appended to `mesh`,
/// tied to the plaque and the FA node, which stays free; no tie is rewritten), and the
/// caller re-points the FA's filaments onto it. Returns the ties, the number of plaque nodes
/// and the reference nodes ([`FaPlaques`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn tie_fa_plaques(
    mesh: &mut Mesh,
    hanging: Vec<cellmech_fem::mesh::refine::HangingNode>,
    surface: &[usize],
    skip: impl Fn(usize) -> bool,
    fa_nodes: &[usize],
    radius: f64,
    coupling: FaCoupling,
    faces: &[[usize; 4]],
    reference: FaReference,
) -> FaPlaques {
    use cellmech_fem::mesh::refine::HangingNode;
    use std::collections::{BTreeMap, HashSet};
    if radius <= 0.0 {
        return FaPlaques {
            ties: hanging,
            plaque_nodes: 0,
            references: BTreeMap::new(),
        };
    }
    let tied: HashSet<usize> = hanging.iter().map(|h| h.node).collect();
    let fas: HashSet<usize> = fa_nodes.iter().copied().collect();
    let mut plaque: BTreeMap<usize, usize> = BTreeMap::new();
    for &n in surface {
        if fas.contains(&n) || tied.contains(&n) || skip(n) {
            continue;
        }
        let nearest = fa_nodes
            .iter()
            .map(|&f| (crate::cell::vec3::distance(mesh.nodes[n], mesh.nodes[f]), f))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((d, f)) = nearest {
            if d <= radius {
                plaque.insert(n, f);
            }
        }
    }
    let count = plaque.len();
    // What each node a tie may name stands for: (node, weight) pairs of free nodes.
    let stands_for: BTreeMap<usize, Vec<(usize, f64)>> = match coupling {
        FaCoupling::Rigid => plaque.iter().map(|(&n, &f)| (n, vec![(f, 1.0)])).collect(),
        FaCoupling::Distributing | FaCoupling::DistributingLinear => {
            let area = match coupling {
                FaCoupling::DistributingLinear => nodal_areas(mesh, faces),
                _ => BTreeMap::new(),
            };
            let weight = |n: usize, f: usize| match coupling {
                FaCoupling::DistributingLinear => {
                    let d = crate::cell::vec3::distance(mesh.nodes[n], mesh.nodes[f]);
                    area.get(&n).copied().unwrap_or(0.0) * (1.0 - d / radius).max(0.0)
                }
                _ => 1.0,
            };
            let mut members: BTreeMap<usize, Vec<(usize, f64)>> = BTreeMap::new();
            for (&n, &f) in &plaque {
                let w = weight(n, f);
                if w > 0.0 {
                    members.entry(f).or_default().push((n, w));
                }
            }
            if reference == FaReference::Separate {
                // The FA node joins its plaque with its full weight (distance 0).
                for (&f, nodes) in members.iter_mut() {
                    let own = match coupling {
                        FaCoupling::DistributingLinear => area.get(&f).copied().unwrap_or(0.0),
                        _ => 1.0,
                    };
                    nodes.push((f, own));
                    nodes.sort_by_key(|p| p.0);
                }
            }
            members
                .into_iter()
                .map(|(f, nodes)| {
                    let total: f64 = nodes.iter().map(|p| p.1).sum();
                    (f, nodes.into_iter().map(|(n, w)| (n, w / total)).collect())
                })
                .collect()
        }
    };
    // A separate reference node per FA: appended at the FA node's position and tied to the
    // plaque (FA node included); the FA node stays a free node, so no tie is rewritten.
    let mut references = BTreeMap::new();
    let stands_for: BTreeMap<usize, Vec<(usize, f64)>> =
        if reference == FaReference::Separate && coupling != FaCoupling::Rigid {
            stands_for
                .into_iter()
                .map(|(f, masters)| {
                    let r = mesh.nodes.len();
                    mesh.nodes.push(mesh.nodes[f]);
                    references.insert(f, r);
                    (r, masters)
                })
                .collect()
        } else {
            stands_for
        };
    let rewrite: &BTreeMap<usize, Vec<(usize, f64)>> = if references.is_empty() {
        &stands_for
    } else {
        &BTreeMap::new()
    };
    let mut ties: Vec<HangingNode> = hanging
        .into_iter()
        .map(|h| {
            let mut masters: BTreeMap<usize, f64> = BTreeMap::new();
            for (m, w) in h.masters {
                match rewrite.get(&m) {
                    Some(parts) => {
                        for &(p, v) in parts {
                            *masters.entry(p).or_insert(0.0) += w * v;
                        }
                    }
                    None => *masters.entry(m).or_insert(0.0) += w,
                }
            }
            HangingNode {
                node: h.node,
                masters: masters.into_iter().collect(),
            }
        })
        .collect();
    ties.extend(
        stands_for
            .into_iter()
            .map(|(node, masters)| HangingNode { node, masters }),
    );
    FaPlaques {
        ties,
        plaque_nodes: count,
        references,
    }
}

/// Where a distributing FA plaque's filaments end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FaReference {
    /// On the FA mesh node, which the coupling ties to its plaque's weighted mean (while it
    /// stays a corner of the elements around it).
    FaNode,
    /// On a separate reference node at the FA's position, tied to the plaque nodes and the
    /// FA node itself, which stays a free node of the surface (as a commercial code's
    /// distributing coupling has its own reference node).
    Separate,
}

/// What [`tie_fa_plaques`] made.
#[derive(Debug, Clone)]
pub(crate) struct FaPlaques {
    /// The hanging-node ties, rewritten where needed, and the plaques' ties.
    pub ties: Vec<cellmech_fem::mesh::refine::HangingNode>,
    /// Surface nodes in a plaque.
    pub plaque_nodes: usize,
    /// With [`FaReference::Separate`]: FA node → its reference node (appended to the
    /// mesh), on which the FA's filaments must end.
    pub references: std::collections::BTreeMap<usize, usize>,
}

/// The surface area each node of `faces` stands for: a quarter of each quad around it (µm²).
fn nodal_areas(mesh: &Mesh, faces: &[[usize; 4]]) -> std::collections::BTreeMap<usize, f64> {
    let mut area = std::collections::BTreeMap::new();
    for f in faces {
        let a = cellmech_fem::mesh::surface::quad_area(&mesh.nodes, f);
        for &n in f {
            *area.entry(n).or_insert(0.0) += 0.25 * a;
        }
    }
    area
}
