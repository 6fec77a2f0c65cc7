//! Density variants of the suspended cell (`[cell.density]`, `shared/spec/cell-models.md`,
//! "Studies the model exists for": "more AFs/IFs in the cell interior at new orientations,
//! more MTs from the centrosome to randomly chosen surface nodes (seeded, reproducible)").
//!
//! Every extra filament ends on *new* surface nodes: outer-surface nodes that are not FAs
//! (FA-like anchors of the extra filaments), each used by at most one extra filament of a
//! family, chosen at random from a SplitMix64 stream seeded by the cell's `seed` mixed with
//! a per-family constant (so the extras of one family do not change when another family's
//! count, the MT bows or the orientation search change, and zero extras consume nothing).
//!
//! * **Actin** (`extra_actin`): straight chords between two such nodes. A pair is a
//!   candidate when its chord does not cross the nucleus sphere (smallest distance from the
//!   centre above the nucleus radius) and is at least as long as the cortical AFs (the
//!   icosidodecahedron edge `R/φ`), so that it runs through the interior and not along the
//!   surface. The candidate pairs (every pair of nodes, in node order) are shuffled and
//!   taken greedily, skipping a pair with a node already used.
//! * **Intermediate filaments** (`extra_intermediate`): straight from such a node to a
//!   nucleus-surface node that is not the anchor of another extra IF; the segment must not
//!   enter the nucleus sphere (the anchor is visible from the surface node). Shuffled and
//!   taken greedily the same way.
//! * **Microtubules** (`extra_microtubules`): from the centrosome to such a node, routed
//!   by the same curved path as the FA microtubules ([`super::cytoskeleton`]), with a bow
//!   drawn from the same range (from the density stream). The nodes are shuffled; a node
//!   whose path would come closer to the nucleus than the clearance margin is skipped.
//!
//! When the mesh has fewer candidates than asked for, the build fails with an error naming
//! the key and the number that fits.

use cellmech_fem::mesh::generate::SplitMix64;
use cellmech_fem::mesh::Mesh;

use super::cytoskeleton::{self, MicrotubulePath, MicrotubuleRouting};
use super::CellGeometryError;
use crate::cell::vec3::{distance, V3};

/// Stream constant of the extra AFs (mixed into the cell's seed).
const ACTIN_STREAM: u64 = 0x4445_4E53_5F41_4354;
/// Stream constant of the extra IFs.
const INTERMEDIATE_STREAM: u64 = 0x4445_4E53_5F49_4E54;
/// Stream constant of the extra MTs.
const MICROTUBULE_STREAM: u64 = 0x4445_4E53_5F4D_5442;

/// Largest accepted extra count per family (a mesh limits it further).
pub const MAX_EXTRA_FILAMENTS: usize = 10_000;

/// How many filaments the density variant adds to each family (all 0 by default: the
/// published model).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct DensityParams {
    /// Extra prestressed AFs through the interior between new surface nodes.
    pub extra_actin: usize,
    /// Extra IFs from new surface nodes to the nucleus surface.
    pub extra_intermediate: usize,
    /// Extra MTs from the centrosome to new surface nodes.
    pub extra_microtubules: usize,
}

impl DensityParams {
    /// True when nothing is added.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }
}

/// The extra filaments placed by `place`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DensityLayout {
    /// Extra AFs as `[surface node, surface node]` (lower node first).
    pub actin: Vec<[usize; 2]>,
    /// Extra IFs as `[surface node, nucleus-surface node]`.
    pub intermediate: Vec<[usize; 2]>,
    /// Extra MTs from the centrosome to a surface node (`fa_node` is that node).
    pub microtubules: Vec<MicrotubulePath>,
}

/// A fresh stream for one family.
fn stream(seed: u64, family: u64) -> SplitMix64 {
    SplitMix64::new(seed ^ family)
}

/// Fisher–Yates shuffle.
pub(crate) fn shuffle<T>(items: &mut [T], rng: &mut SplitMix64) {
    for i in (1..items.len()).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        items.swap(i, j);
    }
}

/// Takes shuffled candidate pairs greedily, skipping a pair with a node already used
/// (`shared`: both ends come from the same pool, so a node is used once at either end;
/// otherwise the first and the second ends are counted separately).
pub(crate) fn take_pairs(pairs: &[[usize; 2]], wanted: usize, shared: bool) -> Vec<[usize; 2]> {
    let mut used = [
        std::collections::HashSet::new(),
        std::collections::HashSet::new(),
    ];
    let pool = |end: usize| if shared { 0 } else { end };
    let mut out = Vec::with_capacity(wanted);
    for &[a, b] in pairs {
        if out.len() == wanted {
            break;
        }
        if used[pool(0)].contains(&a) || used[pool(1)].contains(&b) || a == b {
            continue;
        }
        used[pool(0)].insert(a);
        used[pool(1)].insert(b);
        out.push([a, b]);
    }
    out
}

fn too_many(
    key: &'static str,
    requested: usize,
    available: usize,
    what: &'static str,
) -> CellGeometryError {
    CellGeometryError::TooManyExtraFilaments {
        key,
        requested,
        available,
        what,
    }
}

/// What `place` needs besides the counts.
pub(crate) struct DensityInput<'a> {
    /// The mesh with the FAs snapped.
    pub mesh: &'a Mesh,
    /// Outer-surface nodes.
    pub surface: &'a [usize],
    /// Nucleus-surface nodes.
    pub inner: &'a [usize],
    /// FA nodes (never ends of extra filaments).
    pub fa_nodes: &'a [usize],
    /// Nucleus radius (µm).
    pub nucleus_radius: f64,
    /// Shortest extra AF (µm): the cortical AF length.
    pub min_actin_length: f64,
    /// The FA MTs' routing (centrosome, elements, bow range, clearance margin).
    pub routing: &'a MicrotubuleRouting,
    /// The cell's seed.
    pub seed: u64,
}

/// Places the extra filaments of `density` (see the module docs).
pub(crate) fn place(
    input: &DensityInput,
    density: DensityParams,
) -> Result<DensityLayout, CellGeometryError> {
    let mut out = DensityLayout::default();
    if density.is_empty() {
        return Ok(out);
    }
    let fa: std::collections::HashSet<usize> = input.fa_nodes.iter().copied().collect();
    let mut ends: Vec<usize> = input
        .surface
        .iter()
        .copied()
        .filter(|n| !fa.contains(n))
        .collect();
    ends.sort_unstable();
    ends.dedup();
    let x = |n: usize| -> V3 { input.mesh.nodes[n] };
    let outside_nucleus = |a: V3, b: V3| {
        cytoskeleton::segment_distance_to_origin(a, b) > input.nucleus_radius * (1.0 - 1e-12)
    };
    if density.extra_actin > 0 {
        let mut pairs = Vec::new();
        for (i, &a) in ends.iter().enumerate() {
            for &b in &ends[i + 1..] {
                let (pa, pb) = (x(a), x(b));
                if distance(pa, pb) >= input.min_actin_length && outside_nucleus(pa, pb) {
                    pairs.push([a, b]);
                }
            }
        }
        shuffle(&mut pairs, &mut stream(input.seed, ACTIN_STREAM));
        let chosen = take_pairs(&pairs, density.extra_actin, true);
        if chosen.len() < density.extra_actin {
            return Err(too_many(
                "cell.density.extra_actin",
                density.extra_actin,
                chosen.len(),
                "actin filaments between distinct non-FA surface nodes, through the \
                 interior and clear of the nucleus",
            ));
        }
        out.actin = chosen;
    }
    if density.extra_intermediate > 0 {
        let mut inner = input.inner.to_vec();
        inner.sort_unstable();
        inner.dedup();
        let mut pairs = Vec::new();
        for &a in &ends {
            for &b in &inner {
                if outside_nucleus(x(a), x(b)) {
                    pairs.push([a, b]);
                }
            }
        }
        shuffle(&mut pairs, &mut stream(input.seed, INTERMEDIATE_STREAM));
        let chosen = take_pairs(&pairs, density.extra_intermediate, false);
        if chosen.len() < density.extra_intermediate {
            return Err(too_many(
                "cell.density.extra_intermediate",
                density.extra_intermediate,
                chosen.len(),
                "intermediate filaments from distinct non-FA surface nodes to distinct \
                 visible nucleus-surface nodes",
            ));
        }
        out.intermediate = chosen;
    }
    if density.extra_microtubules > 0 {
        let r = input.routing;
        let mut rng = stream(input.seed, MICROTUBULE_STREAM);
        let mut order = ends.clone();
        shuffle(&mut order, &mut rng);
        for node in order {
            if out.microtubules.len() == density.extra_microtubules {
                break;
            }
            let bow = rng.uniform(r.bow_min, r.bow_max.max(r.bow_min));
            let side = if rng.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
            let path = cytoskeleton::route_one(r, node, x(node), side * bow);
            let clearance =
                cytoskeleton::polyline_distance_to_origin(&path.points) - r.nucleus_radius;
            if clearance >= r.clearance_margin {
                out.microtubules.push(path);
            }
        }
        if out.microtubules.len() < density.extra_microtubules {
            return Err(too_many(
                "cell.density.extra_microtubules",
                density.extra_microtubules,
                out.microtubules.len(),
                "microtubules from the centrosome to distinct non-FA surface nodes, clear \
                 of the nucleus",
            ));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use super::super::{
        suspended_cell_parts, Components, SuspendedCellGeometry, SuspendedCellMaterials,
        SuspendedCellParams, EXTRA_ACTIN, EXTRA_INTERMEDIATE, EXTRA_MICROTUBULE,
    };
    use super::*;
    use crate::cell::vec3::norm;
    use crate::model::structures::FilamentElement;

    const R: f64 = 16.132;
    const R_N: f64 = 6.45;

    fn with(density: DensityParams) -> SuspendedCellParams {
        SuspendedCellParams {
            density,
            ..SuspendedCellParams::default()
        }
    }

    fn dense(actin: usize, intermediate: usize, microtubules: usize) -> DensityParams {
        DensityParams {
            extra_actin: actin,
            extra_intermediate: intermediate,
            extra_microtubules: microtubules,
        }
    }

    #[test]
    fn extra_filaments_are_built_in_their_families_with_the_counts_asked_for() {
        let params = with(dense(20, 15, 12));
        let m = SuspendedCellMaterials::default();
        let parts = suspended_cell_parts(&params, &m, Components::default()).unwrap();
        let base = suspended_cell_parts(&SuspendedCellParams::default(), &m, Components::default())
            .unwrap();
        let extra = &parts.geometry.extra;
        assert_eq!(
            (
                extra.actin.len(),
                extra.intermediate.len(),
                extra.microtubules.len()
            ),
            (20, 15, 12)
        );
        let group = |name: &str| {
            parts
                .structures
                .filaments
                .iter()
                .find(|f| f.name == name)
                .unwrap_or_else(|| panic!("no group {name}"))
        };
        let (a, mt, i) = (
            group(EXTRA_ACTIN),
            group(EXTRA_MICROTUBULE),
            group(EXTRA_INTERMEDIATE),
        );
        assert_eq!(
            (a.family.as_str(), a.pairs.len(), a.filaments.len()),
            ("actin", 20, 20)
        );
        let elements = params.mt_elements;
        assert_eq!(
            (mt.family.as_str(), mt.pairs.len(), mt.filaments.len()),
            ("microtubule", 12 * elements, 12)
        );
        assert_eq!(
            (i.family.as_str(), i.pairs.len(), i.filaments.len()),
            ("intermediate", 15, 15)
        );
        // Same materials as the published filaments of their family.
        let published = |family: &str| {
            base.structures
                .filaments
                .iter()
                .find(|f| f.name == family)
                .unwrap()
                .element
                .clone()
        };
        assert_eq!(a.element, published("actin"));
        assert_eq!(mt.element, published("microtubule"));
        assert_eq!(i.element, published("intermediate"));
        assert!(matches!(a.element, FilamentElement::Truss(l) if l.prestrain > 0.2));
        // Every extra MT adds its interior nodes; the centrosome is shared.
        assert_eq!(
            parts.mesh.num_nodes(),
            base.mesh.num_nodes() + 12 * (elements - 1)
        );
        assert_eq!(parts.structures.filaments.len(), 6);
        crate::model::filaments::FilamentIndex::new(&parts.structures, &parts.mesh, 0).unwrap();
    }

    #[test]
    fn extras_only_append_to_the_published_model() {
        let m = SuspendedCellMaterials::default();
        let base = suspended_cell_parts(&SuspendedCellParams::default(), &m, Components::default())
            .unwrap();
        assert_eq!(base.structures.filaments.len(), 3);
        assert!(base.geometry.extra == DensityLayout::default());
        assert!(!base.mesh.node_sets.keys().any(|k| k.starts_with("extra_")));
        let parts =
            suspended_cell_parts(&with(dense(10, 10, 10)), &m, Components::default()).unwrap();
        // The published nodes, groups and supports are untouched; the extras come after.
        let n = base.mesh.num_nodes();
        assert_eq!(parts.mesh.nodes[..n], base.mesh.nodes[..]);
        assert_eq!(
            parts.structures.filaments[..3],
            base.structures.filaments[..]
        );
        assert_eq!(parts.mesh.blocks, base.mesh.blocks);
        for (name, nodes) in &base.mesh.node_sets {
            if name != "microtubule_interior" && name != "microtubule_anchors" {
                assert_eq!(&parts.mesh.node_sets[name], nodes, "node set {name}");
            }
        }
        // The extra MTs' interior nodes join the embedding sets (coupling applies to them).
        let interior = &parts.mesh.node_sets["microtubule_interior"];
        assert_eq!(
            interior.len(),
            base.mesh.node_sets["microtubule_interior"].len() + 10 * 7
        );
        assert!(interior.iter().any(|&k| k >= n));
        assert!(parts.mesh.node_sets["microtubule_anchors"]
            .iter()
            .any(|&k| k >= n));
    }

    #[test]
    fn the_seeded_choice_is_reproducible_and_changes_with_the_seed() {
        let build = |seed: u64, d: DensityParams| {
            SuspendedCellGeometry::build(&SuspendedCellParams { seed, ..with(d) })
                .unwrap()
                .extra
        };
        let a = build(7, dense(25, 25, 25));
        assert_eq!(a, build(7, dense(25, 25, 25)));
        let b = build(8, dense(25, 25, 25));
        assert_ne!(a.actin, b.actin);
        assert_ne!(a.intermediate, b.intermediate);
        let ends = |e: &DensityLayout| e.microtubules.iter().map(|m| m.fa_node).collect::<Vec<_>>();
        assert_ne!(ends(&a), ends(&b));
        // One family's count does not move another's choice (separate streams).
        let c = build(7, dense(25, 0, 5));
        assert_eq!(c.actin, a.actin);
        assert!(c.intermediate.is_empty());
        assert_eq!(c.microtubules[..], a.microtubules[..5]);
    }

    #[test]
    fn extra_filaments_end_on_distinct_new_surface_nodes_clear_of_the_nucleus() {
        let g = SuspendedCellGeometry::build(&with(dense(60, 60, 60))).unwrap();
        let surface: BTreeSet<usize> = g.mesh.node_sets["surface"].iter().copied().collect();
        let inner: BTreeSet<usize> = g.mesh.node_sets["inner_surface"].iter().copied().collect();
        let fa: BTreeSet<usize> = g.fa_nodes.iter().copied().collect();
        let x = |n: usize| g.mesh.nodes[n];
        let new_end = |n: usize| surface.contains(&n) && !fa.contains(&n);
        // AFs: chords through the interior, not crossing the nucleus, each node once.
        let mut used = BTreeSet::new();
        for &[a, b] in &g.extra.actin {
            assert!(new_end(a) && new_end(b));
            assert!(used.insert(a) && used.insert(b), "node reused");
            let d = cytoskeleton::segment_distance_to_origin(x(a), x(b));
            assert!(d > R_N, "chord {a}-{b} passes {d} um from the centre");
            assert!(distance(x(a), x(b)) >= g.report.af_length);
            // A chord, not a surface path: its midpoint lies inside the cell.
            let mid = [0, 1, 2].map(|k| 0.5 * (x(a)[k] + x(b)[k]));
            assert!(norm(mid) < 0.96 * R);
        }
        // IFs: new surface node to a nucleus node visible from it, each node once.
        let (mut ends, mut anchors) = (BTreeSet::new(), BTreeSet::new());
        for &[s, n] in &g.extra.intermediate {
            assert!(new_end(s) && inner.contains(&n));
            assert!(ends.insert(s) && anchors.insert(n));
            let d = cytoskeleton::segment_distance_to_origin(x(s), x(n));
            assert!(
                d > R_N * (1.0 - 1e-9),
                "IF {s}-{n} enters the nucleus ({d})"
            );
        }
        // MTs: centrosome to new surface nodes, curved like the FA MTs, clear of the nucleus.
        let mut mt_ends = BTreeSet::new();
        for mt in &g.extra.microtubules {
            assert!(new_end(mt.fa_node), "MT ends on FA or non-surface node");
            assert!(mt_ends.insert(mt.fa_node));
            assert_eq!(mt.points[0], g.centrosome);
            assert_eq!(*mt.points.last().unwrap(), x(mt.fa_node));
            assert_eq!(mt.elements(), 8);
            assert!((0.05..=0.20).contains(&mt.bow.abs()));
            assert!(mt.length() > mt.chord());
            assert!(cytoskeleton::polyline_distance_to_origin(&mt.points) >= R_N + 0.25);
        }
        let mut sorted: Vec<usize> = mt_ends.into_iter().collect();
        sorted.sort_unstable();
        assert_eq!(g.mesh.node_sets["extra_microtubule_ends"], sorted);
    }

    #[test]
    fn more_extras_than_the_mesh_has_room_for_is_an_error_naming_the_key() {
        let coarse = |d: DensityParams| {
            SuspendedCellGeometry::build(&SuspendedCellParams {
                mesh: super::super::MeshResolution {
                    core_divisions: 4,
                    shell_layers: 2,
                    outer_layers: 2,
                    core_fraction: 0.5,
                },
                ..with(d)
            })
        };
        // 98 surface nodes, 30 of them FAs: at most 34 AFs, 68 IFs or 68 MTs.
        for (d, key) in [
            (dense(35, 0, 0), "cell.density.extra_actin"),
            (dense(0, 69, 0), "cell.density.extra_intermediate"),
            (dense(0, 0, 69), "cell.density.extra_microtubules"),
        ] {
            let e = coarse(d).unwrap_err();
            assert!(
                matches!(e, CellGeometryError::TooManyExtraFilaments { key: k, .. } if k == key),
                "{e}"
            );
            assert!(e.to_string().contains(key), "{e}");
        }
        let g = coarse(dense(30, 30, 30)).unwrap();
        assert_eq!(g.extra.actin.len(), 30);
        let e =
            SuspendedCellGeometry::build(&with(dense(MAX_EXTRA_FILAMENTS + 1, 0, 0))).unwrap_err();
        assert!(e.to_string().contains("density.extra_actin"), "{e}");
    }
}
