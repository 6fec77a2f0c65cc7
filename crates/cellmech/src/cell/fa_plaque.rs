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
///
/// `centres` (one per FA node, or empty) are the points the plaques are centred on: which
/// FA a surface node belongs to and its linear weight are measured from them (an FA site
/// the FA node was not moved onto, `fa_snap = "none"`). Empty: the FA nodes themselves.
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
    centres: &[[f64; 3]],
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
    let centre_of: BTreeMap<usize, [f64; 3]> = fa_nodes
        .iter()
        .enumerate()
        .map(|(k, &f)| (f, centres.get(k).copied().unwrap_or(mesh.nodes[f])))
        .collect();
    let from_centre =
        |n: usize, f: usize| crate::cell::vec3::distance(mesh.nodes[n], centre_of[&f]);
    let mut plaque: BTreeMap<usize, usize> = BTreeMap::new();
    for &n in surface {
        if fas.contains(&n) || tied.contains(&n) || skip(n) {
            continue;
        }
        let nearest = fa_nodes
            .iter()
            .map(|&f| (from_centre(n, f), f))
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
                    area.get(&n).copied().unwrap_or(0.0)
                        * (1.0 - from_centre(n, f) / radius).max(0.0)
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
                // The FA node joins its plaque with its own weight (full at its centre).
                for (&f, nodes) in members.iter_mut() {
                    let own = weight(f, f);
                    if own > 0.0 {
                        nodes.push((f, own));
                        nodes.sort_by_key(|p| p.0);
                    }
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
    // A separate reference node per FA, tied to the plaque (FA node included); the FA node
    // stays a free node, so no tie is rewritten. The node is placed at the weighted centroid
    // of its masters, Σ wᵢ Xᵢ: only there does the tie x_ref = Σ wᵢ xᵢ follow every rigid
    // motion (it is then exact for any affine one). Anywhere else a rotation by Q moves it
    // by (Q − I)(Σ wᵢ Xᵢ − X_ref) off the rigid motion, so the filaments' pull gains a
    // spurious moment (on the default suspended mesh the centroid lies 0.13–0.25 µm from
    // the FA node, mostly inwards: the plaque is a spherical cap).
    let mut references = BTreeMap::new();
    let stands_for: BTreeMap<usize, Vec<(usize, f64)>> = if reference == FaReference::Separate
        && coupling != FaCoupling::Rigid
    {
        stands_for
            .into_iter()
            .map(|(f, masters)| {
                let r = mesh.nodes.len();
                let centroid = cellmech_fem::mesh::refine::weighted_position(&masters, &mesh.nodes);
                mesh.nodes.push(centroid);
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
    /// On a separate reference node at the plaque's weighted centroid (the FA node itself
    /// included), tied to the plaque nodes and the FA node, which stays a free node of the
    /// surface (as a commercial code's distributing coupling has its own reference node).
    /// At the centroid the tie follows rigid rotations exactly; the FA node is off it (the
    /// plaque is curved, and on an irregular mesh lopsided), so with [`Self::FaNode`] a
    /// rotation strains the tie.
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

impl FaPlaques {
    /// The node the filaments of the FA at mesh node `fa` end on: its separate reference
    /// node, or the FA node itself.
    pub fn filament_end(&self, fa: usize) -> usize {
        self.references.get(&fa).copied().unwrap_or(fa)
    }
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

/// The 2 × 2 × 1 box of 4 × 4 × 1 hex8 (x, y in [−1, 1], z in [0, 1]) whose top face
/// (`z_max`) the plaque tests use as the surface.
#[cfg(test)]
pub(crate) fn plaque_test_box() -> Mesh {
    cellmech_fem::mesh::generate::box_mesh([-1.0, -1.0, 0.0], [2.0, 2.0, 1.0], [4, 4, 1], "b")
        .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Is a plaque's tie objective? A curved, lopsided plaque (an FA on the edge of a
    /// bent 4 × 4 × 1 box's top face, its plaque all on one side), every node moved by a
    /// 40° rigid rotation: the reference node's tie, x_ref = Σ wᵢ xᵢ, must put it where
    /// the rotation puts it. With a separate reference node at the plaque's weighted
    /// centroid it does, to rounding; with the FA node as the reference (off the centroid)
    /// it misses by |(Q − I)(Σ wᵢ Xᵢ − X_FA)|, which is what this test measures.
    #[test]
    fn a_separate_reference_node_follows_rigid_rotations_and_the_fa_node_does_not() {
        let mut mesh = plaque_test_box();
        let top = mesh.node_sets["z_max"].clone();
        for &n in &top {
            let [x, y, _] = mesh.nodes[n];
            mesh.nodes[n][2] -= 0.2 * (x * x + y * y);
        }
        let fa = top
            .iter()
            .copied()
            .find(|&n| {
                (mesh.nodes[n][0] - 1.0).abs() < 1e-12 && (mesh.nodes[n][1] - 0.5).abs() < 1e-12
            })
            .unwrap();
        // Rotation by 40° about (1, 2, 3)/√14 (Rodrigues).
        let (k, t) = {
            let n = 14f64.sqrt();
            ([1.0 / n, 2.0 / n, 3.0 / n], 40f64.to_radians())
        };
        let rotate = |x: [f64; 3]| -> [f64; 3] {
            let kx = [
                k[1] * x[2] - k[2] * x[1],
                k[2] * x[0] - k[0] * x[2],
                k[0] * x[1] - k[1] * x[0],
            ];
            let kd = k[0] * x[0] + k[1] * x[1] + k[2] * x[2];
            std::array::from_fn(|i| x[i] * t.cos() + kx[i] * t.sin() + k[i] * kd * (1.0 - t.cos()))
        };
        let miss = |mesh: &Mesh, tie: &cellmech_fem::mesh::refine::HangingNode| -> f64 {
            let rotated: Vec<[f64; 3]> = mesh.nodes.iter().map(|&x| rotate(x)).collect();
            crate::cell::vec3::distance(tie.tied_position(&rotated), rotated[tie.node])
        };
        for reference in [FaReference::FaNode, FaReference::Separate] {
            let mut m = mesh.clone();
            let plaques = tie_fa_plaques(
                &mut m,
                Vec::new(),
                &top,
                |_| false,
                &[fa],
                0.8,
                FaCoupling::Distributing,
                &[],
                reference,
                &[],
            );
            // The FA at x = 1 has plaque nodes at x = 0.5 and x = 1 only: lopsided.
            assert_eq!(plaques.plaque_nodes, 5);
            let owner = plaques.filament_end(fa);
            let tie = plaques.ties.iter().find(|h| h.node == owner).unwrap();
            let sum: f64 = tie.masters.iter().map(|p| p.1).sum();
            assert!((sum - 1.0).abs() < 1e-14);
            let e = miss(&m, tie);
            match reference {
                FaReference::Separate => assert!(e < 1e-14, "separate reference misses by {e}"),
                // The plaque's centroid (0.7, 0.5, 0.8) lies 0.30 from the FA node
                // (1, 0.5, 0.75), inboard; a 40° rotation puts the tie's FA node
                // 2 sin 20° × 0.30 (its part across the axis) = 0.21 off.
                FaReference::FaNode => assert!(e > 0.1, "the FA node's tie misses by {e} only"),
            }
        }
    }
}
