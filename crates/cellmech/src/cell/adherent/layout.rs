//! The adherent cell's layout: mesh (with local refinement at an indentation site), focal
//! adhesions (FAs), actin bundles (ABs), microtubules (MTs) and intermediate filaments
//! (IFs). Lengths in µm, the substrate is `z = 0`, the cell's long axis is `x`.
//!
//! * **FAs and ABs.** `bundles` ABs run along the long axis at the height `bundle_height`:
//!   AB `k` is a straight tension-only truss between two FAs at `(∓x_k, y_k, h)` on the dome,
//!   with `y_k` spread evenly over `bundle_spread` of the dome's half width at that height
//!   (`y_k = s b_h (2k + 1 − n)/n`, `k = 0..n`), so the apex lies between the two middle
//!   ABs. Each FA's node is the dome node nearest its site, moved onto it (in the reference
//!   mesh, so refinement keeps it; the distance moved is reported).
//! * **MTs** (one per FA): the chord from the centrosome (above the nucleus) to the FA,
//!   bowed sideways in the horizontal plane by `bow × chord × sin(πt)` with `bow` uniform in
//!   `[bow_min, bow_max]` and a random side (seeded): curved, with varying curvature; every
//!   point is checked to lie inside the cell and clear of the nucleus.
//! * **IFs** (`per_fa` per FA) are anchored as in the suspended cell
//!   (`cell::suspended::cytoskeleton`), in the frame where the ellipsoidal nucleus is the
//!   unit sphere: `T(x) = (x − c_n) / E_n` (componentwise). Tangency is affine-invariant,
//!   so an IF tangent to the unit sphere in that frame is tangent to the nucleus. The MT
//!   clearance is measured in that frame too: times `min(E_n)` it bounds the physical
//!   clearance from below.
//! * **Indentation site.** The apex (top node), the receptor (an FA, by default the one
//!   farthest from the nucleus centre, ties to the larger x) or the dome point above given
//!   `(x, y)`. The mesh is refined there (see [`LocalRefinement`]).

use std::collections::HashSet;

use cellmech_fem::mesh::Mesh;

use super::geometry::{
    map_reference_mesh, mesh_report, AdherentMeshReport, AdherentMeshResolution, AdherentShape,
};
use crate::cell::fa_plaque::{tie_fa_plaques, FaReference};
use crate::cell::suspended::cytoskeleton::{
    anchor_intermediate_filaments, IfAnchorRule, MicrotubulePath,
};
use crate::cell::vec3::{distance, norm, V3};

/// Where an AFM tip indents the adherent cell.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum IndentationSite {
    /// The top of the dome, over the nucleus, between the FAs.
    Apex,
    /// An FA away from the nucleus ([`AdherentCellParams::receptor`]).
    Receptor,
    /// The dome point above `(x, y)` (µm).
    Point {
        /// x (along the cell's length).
        x: f64,
        /// y (across).
        y: f64,
    },
}

/// Local refinement at the indentation site: every hex8 is split (octree, 2:1 balanced,
/// hanging nodes tied) until its longest edge is at most the wanted size
/// [`LocalRefinement::target_size`] at its distance from the site (measured to the
/// element's nearest point of its bounding sphere): `element_size` within `fine_radius`,
/// then growing with slope `grading` over `graded_width`, then with slope `far_grading`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LocalRefinement {
    /// Element size wanted within `fine_radius` of the site (µm).
    pub element_size: f64,
    /// Radius of the region of finest elements (µm): the material the tip touches.
    pub fine_radius: f64,
    /// Growth of the element size with the distance beyond `fine_radius` (size per
    /// distance), over `graded_width`.
    pub grading: f64,
    /// Width of the band beyond `fine_radius` in which the size grows with slope
    /// `grading` (µm); beyond it the slope is `far_grading`.
    pub graded_width: f64,
    /// Growth of the element size beyond `fine_radius + graded_width`.
    pub far_grading: f64,
    /// Most levels of splitting.
    pub max_levels: u8,
}

impl LocalRefinement {
    /// Further levels of splitting wanted for an element with physical corners `x` (its
    /// longest edge over the wanted size, rounded up in powers of two), for a site.
    pub fn extra_levels(&self, x: &[V3; 8], site: V3) -> u8 {
        let ratio = self.size_ratio(x, site);
        if ratio <= 1.0 {
            return 0;
        }
        ratio.log2().ceil().min(16.0) as u8
    }

    /// The element's longest edge over the size wanted where it lies (above 1: too coarse).
    pub fn size_ratio(&self, x: &[V3; 8], site: V3) -> f64 {
        let longest = super::geometry::longest_edge(x);
        let centroid: V3 = std::array::from_fn(|k| x.iter().map(|p| p[k]).sum::<f64>() / 8.0);
        let radius = x.iter().map(|p| distance(*p, centroid)).fold(0.0, f64::max);
        let d = (distance(centroid, site) - radius).max(0.0);
        longest / self.target_size(d)
    }

    /// The largest element edge wanted at distance `d` (µm) from the site: `element_size`
    /// within `fine_radius`; beyond it `grading × (d − fine_radius)` up to `graded_width`,
    /// then growing with slope `far_grading`; never below `element_size`. Continuous and
    /// non-decreasing in `d`.
    pub fn target_size(&self, d: f64) -> f64 {
        let beyond = (d - self.fine_radius).max(0.0);
        let near = beyond.min(self.graded_width);
        let far = (beyond - self.graded_width).max(0.0);
        self.element_size
            .max(self.grading * near + self.far_grading * far)
    }
}

/// Most hex8 elements a local refinement of the adherent cell may make (the default mesh
/// has about 11 000, the finest one in the docs about 28 000): the octree stops with an
/// error as soon as it would pass it.
pub const MAX_REFINED_CELL_ELEMENTS: usize = 2_000_000;

/// Largest ratio of an element's edge to the size wanted where it lies that the octree's
/// level cap (`refinement.max_levels`) may leave before the build stops with an error: up
/// to one halving short is accepted (the defaults reach 0.053 µm at the apex for 0.05, and
/// up to 1.55 times the size at the receptor), a whole level or more is not.
pub const MAX_CAPPED_SIZE_RATIO: f64 = 2.0;

/// The error for a mapped mesh with an inverted element (`min_scaled_jacobian ≤ 0`).
fn check_not_inverted(min_scaled_jacobian: f64) -> Result<(), AdherentLayoutError> {
    if min_scaled_jacobian > 0.0 {
        return Ok(());
    }
    Err(fail(
        "mesh",
        format!(
            "the mapped mesh has an inverted element (min scaled Jacobian {min_scaled_jacobian:.3}): \
             FAs closer than the mesh spacing crowd its elements; raise mesh.core_divisions \
             (8 for the default 8 bundles) or lower bundles.count"
        ),
    ))
}

pub use crate::cell::fa_plaque::FaCoupling;

/// Parameters of the adherent-cell layout (µm).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AdherentCellParams {
    /// Cell and nucleus shape.
    pub shape: AdherentShape,
    /// Base mesh.
    pub mesh: AdherentMeshResolution,
    /// Refinement at the indentation site.
    pub refinement: LocalRefinement,
    /// Number of ABs (≥ 1).
    pub bundles: usize,
    /// Extra ABs of the density variant (0 by default).
    pub extra_bundles: usize,
    /// Extra MTs of the density variant, from the centrosome to new dome nodes (0 by
    /// default).
    pub extra_microtubules: usize,
    /// Extra IFs of the density variant, from new dome nodes to the nucleus (0 by default).
    pub extra_intermediate: usize,
    /// Height of the ABs and their FAs above the substrate.
    pub bundle_height: f64,
    /// Fraction of the dome's half width at `bundle_height` the ABs are spread over.
    pub bundle_spread: f64,
    /// The receptor FA (index into the FAs; `None`: the one farthest from the nucleus).
    pub receptor: Option<usize>,
    /// Radius of an FA's plaque: the dome nodes within it carry the FA's filaments (0: the
    /// FA is one node).
    pub fa_radius: f64,
    /// How the plaque carries them ([`FaCoupling`]).
    pub fa_coupling: FaCoupling,
    /// Where a distributing plaque's filaments end ([`FaReference`]).
    pub fa_reference: FaReference,
    /// Beam elements per MT.
    pub mt_elements: usize,
    /// Smallest MT bow (fraction of the chord).
    pub mt_bow_min: f64,
    /// Largest MT bow.
    pub mt_bow_max: f64,
    /// Smallest distance of an MT from the nucleus surface.
    pub mt_clearance_margin: f64,
    /// Distance of the centrosome from the nucleus surface.
    pub centrosome_gap: f64,
    /// Direction of the centrosome from the nucleus centre.
    pub centrosome_direction: V3,
    /// IFs per FA.
    pub ifs_per_fa: usize,
    /// Angle (rad) of the first IF on its FA's tangent circle.
    pub if_phase: f64,
    /// Which nucleus node anchors an IF.
    pub if_anchor_rule: IfAnchorRule,
    /// Seed of every random choice (MT bows).
    pub seed: u64,
}

/// Measured quality of the layout.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AdherentLayoutReport {
    /// Mesh quality after mapping and refinement.
    pub mesh: AdherentMeshReport,
    /// Hex8 elements before refinement.
    pub base_elements: usize,
    /// Hanging nodes of the local refinement.
    pub hanging_nodes: usize,
    /// Dome nodes tied to an FA node by its plaque (`fa_radius`).
    pub fa_plaque_nodes: usize,
    /// Largest distance an FA's node was moved along the dome to reach its site (µm).
    pub max_fa_snap: f64,
    /// AB lengths (µm): shortest, longest.
    pub bundle_length_range: (f64, f64),
    /// Smallest MT clearance from the nucleus, in the unit-nucleus frame (times the
    /// smallest nucleus semi-axis: a lower bound in µm).
    pub min_mt_clearance_scaled: f64,
    /// Largest IF anchor error in the unit-nucleus frame.
    pub max_if_anchor_error_scaled: f64,
    /// The indentation site (µm) and the dome's outward normal there.
    pub site: Option<(V3, V3)>,
}

/// Why the adherent cell's layout could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{parameter}: {message}")]
pub struct AdherentLayoutError {
    /// The parameter (or part) at fault.
    pub parameter: &'static str,
    /// What was expected and what was found.
    pub message: String,
}

fn fail(parameter: &'static str, message: impl Into<String>) -> AdherentLayoutError {
    AdherentLayoutError {
        parameter,
        message: message.into(),
    }
}

/// The adherent cell's geometry: mesh and routing.
#[derive(Debug, Clone)]
pub struct AdherentCellGeometry {
    /// Hex8 mesh (blocks `nucleus`, `cytoplasm`); node sets `surface`, `dome`, `bottom`,
    /// `apex`, `nucleus_surface`, `focal_adhesions`, `fa_<k>`, `if_anchors`.
    pub mesh: Mesh,
    /// Ties of the hanging nodes of the local refinement and of the FA plaques (a plaque
    /// node follows its FA node with weight 1).
    pub hanging: Vec<cellmech_fem::mesh::refine::HangingNode>,
    /// Outer boundary faces (outward), dome and base.
    pub boundary_faces: Vec<[usize; 4]>,
    /// FA nodes: AB `k` has FAs `2k` (x < 0) and `2k + 1` (x > 0).
    pub fa_nodes: Vec<usize>,
    /// ABs as `[FA node, FA node]`.
    pub bundles: Vec<[usize; 2]>,
    /// The density variant's extra ABs as `[dome node, dome node]` (none by default; see
    /// `choose_extra_bundles`).
    pub extra_bundles: Vec<[usize; 2]>,
    /// Centrosome position (appended as a node by [`Self::append_microtubule_nodes`]).
    pub centrosome: V3,
    /// One MT per FA.
    pub microtubules: Vec<MicrotubulePath>,
    /// The density variant's extra MTs, from the centrosome to new dome nodes (none by
    /// default; routed like the FA MTs in [`Self::build`]).
    pub extra_microtubules: Vec<MicrotubulePath>,
    /// IFs as `[FA node, nucleus-surface node]`.
    pub intermediate_filaments: Vec<[usize; 2]>,
    /// The density variant's extra IFs as `[dome node, nucleus-surface node]` (none by
    /// default; see `choose_extra_intermediate`).
    pub extra_intermediate: Vec<[usize; 2]>,
    /// Index of the receptor FA.
    pub receptor: usize,
    /// Measured quality.
    pub report: AdherentLayoutReport,
}

impl AdherentCellParams {
    /// Checks the parameters that the builders do not check themselves.
    pub fn validate(&self) -> Result<(), AdherentLayoutError> {
        self.shape.validate().map_err(|m| fail("shape", m))?;
        let [_, _, c] = self.shape.semi_axes;
        if self.bundles == 0 {
            return Err(fail(
                "bundles.count",
                "expected at least 1 actin bundle; found 0",
            ));
        }
        if !(self.bundle_height > 0.0 && self.bundle_height < c) {
            return Err(fail(
                "bundles.height",
                format!(
                    "expected a height above the substrate below the cell height {c} µm; found \
                     {} µm",
                    self.bundle_height
                ),
            ));
        }
        if !(self.bundle_spread > 0.0 && self.bundle_spread < 1.0) {
            return Err(fail(
                "bundles.spread",
                format!(
                    "expected a fraction in (0, 1) of the dome's half width; found {}",
                    self.bundle_spread
                ),
            ));
        }
        let r = self.refinement;
        if !(r.element_size > 0.0
            && r.fine_radius >= 0.0
            && r.grading > 0.0
            && r.graded_width >= 0.0
            && r.far_grading > 0.0)
        {
            return Err(fail(
                "refinement",
                format!(
                    "expected element_size > 0, fine_radius ≥ 0, grading > 0, graded_width ≥ 0, \
                     far_grading > 0; found {}, {}, {}, {}, {}",
                    r.element_size, r.fine_radius, r.grading, r.graded_width, r.far_grading
                ),
            ));
        }
        let d = self.centrosome_direction;
        if !(d.iter().all(|x| x.is_finite()) && norm(d) > 0.0) {
            return Err(fail(
                "microtubules.centrosome_direction",
                format!("expected a non-zero vector; found {d:?}"),
            ));
        }
        Ok(())
    }

    /// The FA sites `(∓x_k, y_k, h)` on the dome, AB by AB.
    pub fn fa_sites(&self) -> Vec<V3> {
        let [a, b, c] = self.shape.semi_axes;
        let h = self.bundle_height;
        let f = (1.0 - (h / c).powi(2)).sqrt();
        let (a_h, b_h) = (a * f, b * f);
        let n = self.bundles as f64;
        (0..self.bundles)
            .flat_map(|k| {
                let y = self.bundle_spread * b_h * (2.0 * k as f64 + 1.0 - n) / n;
                let x = a_h * (1.0 - (y / b_h).powi(2)).sqrt();
                [[-x, y, h], [x, y, h]]
            })
            .collect()
    }

    /// The centrosome: on the ray from the nucleus centre along `centrosome_direction`,
    /// `centrosome_gap` beyond the nucleus surface.
    pub fn centrosome(&self) -> V3 {
        let d = crate::cell::vec3::normalize(self.centrosome_direction);
        let e = self.shape.nucleus_semi_axes;
        let s =
            1.0 / ((d[0] / e[0]).powi(2) + (d[1] / e[1]).powi(2) + (d[2] / e[2]).powi(2)).sqrt();
        let c = self.shape.nucleus_centre();
        std::array::from_fn(|k| c[k] + d[k] * (s + self.centrosome_gap))
    }

    /// To the frame where the nucleus is the unit sphere at the origin.
    fn to_unit_nucleus(&self, x: V3) -> V3 {
        let e = self.shape.nucleus_semi_axes;
        let c = self.shape.nucleus_centre();
        std::array::from_fn(|k| (x[k] - c[k]) / e[k])
    }
}

/// Turns the reference mesh's radial line of direction `from` (unit) towards `to` (unit):
/// the surface node moves onto `to`, the nodes below it by a share that falls linearly to
/// zero at the nucleus surface, so the shear of moving an FA onto its site is spread over
/// the cytoplasm's layers instead of the outermost one.
fn turn_radial_line(reference: &mut Mesh, from: V3, to: V3) {
    let r_ref = super::geometry::REFERENCE_NUCLEUS_RADIUS;
    for x in reference.nodes.iter_mut() {
        let rho = norm(*x);
        if rho <= r_ref + 1e-12 {
            continue;
        }
        let n = [x[0] / rho, x[1] / rho, x[2] / rho];
        if distance(n, from) > 1e-9 {
            continue;
        }
        let w = ((rho - r_ref) / (1.0 - r_ref)).min(1.0);
        let d: V3 = std::array::from_fn(|k| from[k] + w * (to[k] - from[k]));
        *x = crate::cell::vec3::scale(crate::cell::vec3::normalize(d), rho);
    }
}

/// The dome nodes the density variant's extra filaments may end on: base-mesh dome nodes
/// (a local refinement keeps them) above the substrate that are not FAs, lie farther than
/// two plaque radii from every FA and are not in `taken`; sorted.
fn free_dome_nodes(
    params: &AdherentCellParams,
    mesh: &Mesh,
    base_nodes: usize,
    fa_nodes: &[usize],
    taken: &[usize],
) -> Vec<usize> {
    let x = |n: usize| mesh.nodes[n];
    let taken: HashSet<usize> = taken.iter().copied().collect();
    let mut ends: Vec<usize> = mesh.node_sets["dome"]
        .iter()
        .copied()
        .filter(|&n| {
            n < base_nodes
                && x(n)[2] > 1e-9
                && !taken.contains(&n)
                && fa_nodes
                    .iter()
                    .all(|&f| f != n && distance(x(f), x(n)) > 2.0 * params.fa_radius)
        })
        .collect();
    ends.sort_unstable();
    ends.dedup();
    ends
}

/// Mixed into the seed for the extra MTs of the density variant.
const EXTRA_MT_STREAM: u64 = 0x4445_4E53_5F41_4D54;
/// Mixed into the seed for the extra IFs of the density variant.
const EXTRA_IF_STREAM: u64 = 0x4445_4E53_5F41_4946;

/// The density variant's `extra_intermediate` IFs: `[dome node, nucleus-surface node]`
/// pairs whose segment passes outside the nucleus (in the unit-nucleus frame: the surface
/// node sees the anchor), `ends` the candidate dome nodes; shuffled by a SplitMix64 stream
/// of `seed` mixed with a constant and taken greedily, each node used once at either end
/// (`cell::suspended::density`, as the suspended cell's extra IFs).
fn choose_extra_intermediate(
    params: &AdherentCellParams,
    mesh: &Mesh,
    ends: &[usize],
) -> Result<Vec<[usize; 2]>, AdherentLayoutError> {
    if params.extra_intermediate == 0 {
        return Ok(Vec::new());
    }
    let mut inner = mesh.node_sets["nucleus_surface"].clone();
    inner.sort_unstable();
    inner.dedup();
    let unit = |n: usize| params.to_unit_nucleus(mesh.nodes[n]);
    let mut pairs = Vec::new();
    for &a in ends {
        for &b in &inner {
            // Strictly outside but for the anchor itself, which lies on the unit sphere.
            if crate::cell::suspended::cytoskeleton::segment_distance_to_origin(unit(a), unit(b))
                > 1.0 - 1e-9
            {
                pairs.push([a, b]);
            }
        }
    }
    take_seeded_pairs(
        params.seed ^ EXTRA_IF_STREAM,
        pairs,
        (params.extra_intermediate, false),
        "intermediate.extra",
        "IFs from distinct dome nodes away from the FAs to distinct nucleus-surface nodes \
         they see",
    )
}

/// Shuffles candidate `pairs` by a SplitMix64 stream of `seed` and takes `wanted` of them
/// greedily (`shared`: a node is used once at either end; else each end has its own pool,
/// `cell::suspended::density::take_pairs`). Fewer candidates than wanted is an error naming
/// `key` and saying what a candidate is.
fn take_seeded_pairs(
    seed: u64,
    mut pairs: Vec<[usize; 2]>,
    (wanted, shared): (usize, bool),
    key: &'static str,
    what: &str,
) -> Result<Vec<[usize; 2]>, AdherentLayoutError> {
    use crate::cell::suspended::density::{shuffle, take_pairs};
    shuffle(
        &mut pairs,
        &mut cellmech_fem::mesh::generate::SplitMix64::new(seed),
    );
    let chosen = take_pairs(&pairs, wanted, shared);
    if chosen.len() < wanted {
        return Err(fail(
            key,
            format!(
                "expected cell.{key} at most {} on this mesh ({what}); found {wanted} (lower it \
                 or refine the mesh)",
                chosen.len()
            ),
        ));
    }
    Ok(chosen)
}

/// Mixed into the seed for the extra ABs of the density variant.
const EXTRA_BUNDLE_STREAM: u64 = 0x4445_4E53_5F41_4253;

/// The density variant's `extra_bundles` ABs: straight tension-only trusses between seeded
/// random pairs of base-mesh dome nodes (so that a local refinement keeps them) that are
/// not FAs and lie farther than two plaque radii from every FA, each node used once. A
/// pair is a candidate when its chord misses the nucleus (in the unit-nucleus frame) and is
/// at least half as long as the shortest published AB; both ends lie on the convex dome
/// above the substrate, so the chord runs inside the cell, at the periphery or through the
/// interior. The candidates (pairs in node order) are shuffled by a SplitMix64 stream of
/// `seed` mixed with a constant and taken greedily (`cell::suspended::density`).
fn choose_extra_bundles(
    params: &AdherentCellParams,
    mesh: &Mesh,
    base_nodes: usize,
    fa_nodes: &[usize],
    lengths: &[f64],
) -> Result<Vec<[usize; 2]>, AdherentLayoutError> {
    if params.extra_bundles == 0 {
        return Ok(Vec::new());
    }
    let x = |n: usize| mesh.nodes[n];
    let ends = free_dome_nodes(params, mesh, base_nodes, fa_nodes, &[]);
    let min_length = 0.5 * lengths.iter().cloned().fold(f64::INFINITY, f64::min);
    let mut pairs = Vec::new();
    for (i, &a) in ends.iter().enumerate() {
        for &b in &ends[i + 1..] {
            let (pa, pb) = (params.to_unit_nucleus(x(a)), params.to_unit_nucleus(x(b)));
            if distance(x(a), x(b)) >= min_length
                && crate::cell::suspended::cytoskeleton::segment_distance_to_origin(pa, pb) > 1.0
            {
                pairs.push([a, b]);
            }
        }
    }
    take_seeded_pairs(
        params.seed ^ EXTRA_BUNDLE_STREAM,
        pairs,
        (params.extra_bundles, true),
        "bundles.extra",
        &format!(
            "actin bundles between distinct dome nodes away from the FAs, at least \
             {min_length:.2} µm long and clear of the nucleus"
        ),
    )
}

/// Mixed into the seed for the MT bows.
const MT_STREAM: u64 = 0x4D54_5F41_4448_4552;

/// One MT from the centrosome `c` to the FA at `f`: the chord bowed sideways in the
/// horizontal plane, `p(t) = c + t (f − c) + bow |f − c| sin(π t) e`, `e` the horizontal unit
/// vector perpendicular to the chord (x for a vertical chord), sampled at `t = i/m`.
fn route_microtubule(c: V3, fa_node: usize, f: V3, bow: f64, m: usize) -> MicrotubulePath {
    let d = crate::cell::vec3::sub(f, c);
    let h = (d[0] * d[0] + d[1] * d[1]).sqrt();
    let e = if h > 1e-9 {
        [-d[1] / h, d[0] / h, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let chord = norm(d);
    let points = (0..=m)
        .map(|i| {
            let t = i as f64 / m as f64;
            let s = bow * chord * (std::f64::consts::PI * t).sin();
            if i == m {
                f
            } else {
                std::array::from_fn(|k| c[k] + t * d[k] + s * e[k])
            }
        })
        .collect();
    let plane_normal = crate::cell::vec3::normalize(crate::cell::vec3::cross(d, e));
    MicrotubulePath {
        fa_node,
        points,
        plane_normal,
        bow,
    }
}

/// The node nearest `p` among `nodes`, excluding `taken`, and its distance.
fn nearest_node(mesh: &Mesh, nodes: &[usize], p: V3, taken: &[usize]) -> Option<(usize, f64)> {
    nodes
        .iter()
        .filter(|n| !taken.contains(n))
        .map(|&n| (n, distance(mesh.nodes[n], p)))
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
}

impl AdherentCellGeometry {
    /// Builds the layout, refined at `site` when given.
    pub fn build(
        params: &AdherentCellParams,
        site: Option<IndentationSite>,
    ) -> Result<Self, AdherentLayoutError> {
        params.validate()?;
        let shape = &params.shape;
        let mut reference = params.mesh.reference_mesh().map_err(|m| fail("mesh", m))?;
        // Each FA is the reference surface node nearest to its site's reference direction
        // `(x/a, y/b, z/c)`, moved onto that direction: the FA lands on its site exactly
        // and the local refinement (done in the reference space) keeps it.
        let [a, b, c] = shape.semi_axes;
        let dome_ref: Vec<usize> = reference.node_sets["surface"]
            .iter()
            .copied()
            .filter(|&n| reference.nodes[n][2] > 1e-9)
            .collect();
        let mut fa_nodes = Vec::new();
        let mut max_snap: f64 = 0.0;
        for p in params.fa_sites() {
            let direction = [p[0] / a, p[1] / b, p[2] / c];
            let (n, _) =
                nearest_node(&reference, &dome_ref, direction, &fa_nodes).ok_or_else(|| {
                    fail(
                        "bundles.count",
                        "more FAs than dome nodes: refine the base mesh",
                    )
                })?;
            max_snap = max_snap.max(distance(shape.map(reference.nodes[n], true), p));
            let from = reference.nodes[n];
            turn_radial_line(&mut reference, from, direction);
            fa_nodes.push(n);
        }
        let base = map_reference_mesh(&reference, shape);
        let base_elements = base.num_elements();
        let base_nodes = base.num_nodes();
        let receptor = match params.receptor {
            Some(k) if k < fa_nodes.len() => k,
            Some(k) => {
                return Err(fail(
                    "receptor",
                    format!(
                        "expected an FA index below {} (2 per actin bundle); found {k}",
                        fa_nodes.len()
                    ),
                ))
            }
            None => {
                let c = shape.nucleus_centre();
                let mut best = 0;
                for k in 1..fa_nodes.len() {
                    let (pk, pb) = (base.nodes[fa_nodes[k]], base.nodes[fa_nodes[best]]);
                    let (dk, db) = (distance(pk, c), distance(pb, c));
                    if dk > db + 1e-9 || ((dk - db).abs() <= 1e-9 && pk[0] > pb[0]) {
                        best = k;
                    }
                }
                best
            }
        };
        let site_point = match site {
            None => None,
            Some(IndentationSite::Apex) => Some(base.nodes[base.node_sets["apex"][0]]),
            Some(IndentationSite::Receptor) => Some(base.nodes[fa_nodes[receptor]]),
            Some(IndentationSite::Point { x, y }) => {
                let z = shape.dome_height(x, y).ok_or_else(|| {
                    fail(
                        "site",
                        format!(
                            "expected a point over the cell's footprint (x²/{a}² + y²/{b}² < 1); \
                             found ({x}, {y}) µm, off the cell",
                            a = shape.semi_axes[0],
                            b = shape.semi_axes[1]
                        ),
                    )
                })?;
                let p = [x, y, z];
                if shape.dome_normal(p)[2] < 0.5 {
                    return Err(fail(
                        "site",
                        format!(
                            "expected a point where the dome is less steep than 60° (a vertical \
                             tip would slide off); found a slope of {:.0}° at ({x}, {y}) µm",
                            shape.dome_normal(p)[2].acos().to_degrees()
                        ),
                    ));
                }
                Some(p)
            }
        };
        // A base mesh that is already inverted fails before any refinement work.
        check_not_inverted(
            cellmech_fem::mesh::generate::quality::hex8_quality(&base).min_scaled_jacobian,
        )?;
        let (mut mesh, hanging, boundary_faces) = match site_point {
            Some(s) => {
                let refinement = params.refinement;
                // How much coarser than wanted the level cap leaves the finest elements,
                // to tell a user whose element_size the cap would silently coarsen.
                let capped_ratio = std::cell::Cell::new(0.0f64);
                let refined = cellmech_fem::mesh::refine::refine_hex8_within(
                    &reference,
                    |corners, level| {
                        let x = corners.map(|p| shape.map(p, false));
                        if level >= refinement.max_levels {
                            let ratio = refinement.size_ratio(&x, s);
                            capped_ratio.set(capped_ratio.get().max(ratio));
                        }
                        (level + refinement.extra_levels(&x, s)).min(refinement.max_levels)
                    },
                    MAX_REFINED_CELL_ELEMENTS,
                )
                .map_err(|e| match e {
                    cellmech_fem::mesh::refine::RefineError::TooManyElements { max } => fail(
                        "refinement",
                        format!(
                            "expected a refinement of at most {max} hex8 elements; found one \
                             of more (element_size {} µm, grading {} on a cell of semi-axes \
                             {:?} µm): raise refinement.element_size or refinement.grading, \
                             or lower refinement.max_levels",
                            refinement.element_size, refinement.grading, shape.semi_axes
                        ),
                    ),
                    e => fail("refinement", e.to_string()),
                })?;
                if capped_ratio.get() > MAX_CAPPED_SIZE_RATIO {
                    return Err(fail(
                        "refinement.max_levels",
                        format!(
                            "expected enough octree levels for refinement.element_size = {} µm; \
                             found max_levels = {}, which leaves elements near the site {:.1} \
                             times larger than asked: raise refinement.max_levels (each level \
                             halves the elements, at most 10) or raise refinement.element_size",
                            refinement.element_size,
                            refinement.max_levels,
                            capped_ratio.get()
                        ),
                    ));
                }
                let mut mesh = map_reference_mesh(&refined.mesh, shape);
                // The base mesh's nodes keep their indices and positions.
                debug_assert!(fa_nodes.iter().all(|&n| mesh.nodes[n] == base.nodes[n]));
                mesh.node_sets.retain(|_, v| !v.is_empty());
                (mesh, refined.hanging, refined.boundary_faces)
            }
            None => {
                let faces = cellmech_fem::mesh::generate::boundary_faces(&base);
                (base, Vec::new(), faces)
            }
        };
        let mesh_quality = mesh_report(&mesh, shape);
        check_not_inverted(mesh_quality.min_scaled_jacobian)?;
        // ABs.
        let bundles: Vec<[usize; 2]> = (0..params.bundles)
            .map(|k| [fa_nodes[2 * k], fa_nodes[2 * k + 1]])
            .collect();
        for (k, &[a, b]) in bundles.iter().enumerate() {
            let (pa, pb) = (
                params.to_unit_nucleus(mesh.nodes[a]),
                params.to_unit_nucleus(mesh.nodes[b]),
            );
            if crate::cell::suspended::cytoskeleton::segment_distance_to_origin(pa, pb) <= 1.0 {
                return Err(fail(
                    "bundles.height",
                    format!(
                        "actin bundle {k} (y = {:.2} µm, height {} µm) passes through the \
                         nucleus; raise bundles.height or narrow bundles.spread",
                        mesh.nodes[a][1], params.bundle_height
                    ),
                ));
            }
        }
        let lengths: Vec<f64> = bundles
            .iter()
            .map(|&[a, b]| distance(mesh.nodes[a], mesh.nodes[b]))
            .collect();
        // The density variant's extra ABs, and a plaque at each of their ends too.
        let extra_bundles = choose_extra_bundles(params, &mesh, base_nodes, &fa_nodes, &lengths)?;
        let extra_bundle_ends: Vec<usize> = extra_bundles.iter().flatten().copied().collect();
        let plaque_owners: Vec<usize> = fa_nodes
            .iter()
            .chain(extra_bundles.iter().flatten())
            .copied()
            .collect();
        let refinement_hanging = hanging.len();
        let dome = mesh.node_sets["dome"].clone();
        let on_base: Vec<bool> = mesh.nodes.iter().map(|x| x[2] <= 1e-9).collect();
        let mut plaques = tie_fa_plaques(
            &mut mesh,
            hanging,
            &dome,
            |n| on_base[n],
            &plaque_owners,
            params.fa_radius,
            params.fa_coupling,
            &boundary_faces,
            params.fa_reference,
            &[],
        );
        let (hanging, plaque_nodes) = (std::mem::take(&mut plaques.ties), plaques.plaque_nodes);
        // Where the filaments of each FA end: the FA node, or its coupling's reference node.
        let end = |fa: usize| plaques.filament_end(fa);
        let bundles: Vec<[usize; 2]> = bundles.iter().map(|&[a, b]| [end(a), end(b)]).collect();
        let extra_bundles: Vec<[usize; 2]> = extra_bundles
            .iter()
            .map(|&[a, b]| [end(a), end(b)])
            .collect();
        // MTs: the chord from the centrosome to the FA bowed sideways (horizontally).
        let centrosome = params.centrosome();
        if shape.level(centrosome) >= 1.0 || centrosome[2] <= 0.0 {
            return Err(fail(
                "microtubules.centrosome_gap",
                format!("the centrosome at {centrosome:?} µm lies outside the cell"),
            ));
        }
        let mut rng = cellmech_fem::mesh::generate::SplitMix64::new(params.seed ^ MT_STREAM);
        let mut microtubules = Vec::with_capacity(fa_nodes.len());
        let mut min_clearance = f64::INFINITY;
        let min_axis = shape
            .nucleus_semi_axes
            .iter()
            .cloned()
            .fold(f64::INFINITY, f64::min);
        // Where an MT leaves the cell (`Err`), else its clearance from the nucleus (µm, the
        // unit-nucleus frame's distance scaled by the smallest semi-axis).
        let mt_clearance = |mt: &MicrotubulePath| -> Result<f64, V3> {
            if let Some(p) = mt.points[1..mt.points.len() - 1]
                .iter()
                .find(|p| shape.level(**p) >= 1.0 || p[2] <= 0.0)
            {
                return Err(*p);
            }
            let scaled: Vec<V3> = mt
                .points
                .iter()
                .map(|&p| params.to_unit_nucleus(p))
                .collect();
            Ok(
                (crate::cell::suspended::cytoskeleton::polyline_distance_to_origin(&scaled) - 1.0)
                    * min_axis,
            )
        };
        for (k, &fa) in fa_nodes.iter().enumerate() {
            let bow = rng.uniform(params.mt_bow_min, params.mt_bow_max.max(params.mt_bow_min));
            let side = if rng.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
            let mt = route_microtubule(
                centrosome,
                fa,
                mesh.nodes[fa],
                side * bow,
                params.mt_elements,
            );
            let clearance = mt_clearance(&mt).map_err(|p| {
                fail(
                    "microtubules",
                    format!(
                        "MT {k} leaves the cell at {p:.2?} µm; lower microtubules.bow_max or \
                         move the centrosome"
                    ),
                )
            })?;
            if !(clearance >= params.mt_clearance_margin) {
                return Err(fail(
                    "microtubules",
                    format!(
                        "MT {k} passes within {clearance:.3} µm of the nucleus (at least {} µm \
                         wanted); raise microtubules.centrosome_gap or lower the bow",
                        params.mt_clearance_margin
                    ),
                ));
            }
            min_clearance = min_clearance.min(clearance / min_axis);
            microtubules.push(MicrotubulePath {
                fa_node: end(fa),
                ..mt
            });
        }
        // The density variant's extra MTs: the same routing from the centrosome to new dome
        // nodes, in an order shuffled by their own stream (bows drawn from it too); a node
        // whose MT would leave the cell or pass too close to the nucleus is skipped.
        let mut extra_microtubules: Vec<MicrotubulePath> = Vec::new();
        if params.extra_microtubules > 0 {
            use crate::cell::suspended::density::shuffle;
            let mut order =
                free_dome_nodes(params, &mesh, base_nodes, &fa_nodes, &extra_bundle_ends);
            let mut rng =
                cellmech_fem::mesh::generate::SplitMix64::new(params.seed ^ EXTRA_MT_STREAM);
            shuffle(&mut order, &mut rng);
            for node in order {
                if extra_microtubules.len() == params.extra_microtubules {
                    break;
                }
                let bow = rng.uniform(params.mt_bow_min, params.mt_bow_max.max(params.mt_bow_min));
                let side = if rng.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
                let mt = route_microtubule(
                    centrosome,
                    node,
                    mesh.nodes[node],
                    side * bow,
                    params.mt_elements,
                );
                if mt_clearance(&mt).is_ok_and(|c| c >= params.mt_clearance_margin) {
                    extra_microtubules.push(mt);
                }
            }
            if extra_microtubules.len() < params.extra_microtubules {
                return Err(fail(
                    "microtubules.extra",
                    format!(
                        "expected cell.microtubules.extra at most {} on this mesh (MTs from the \
                         centrosome to distinct dome nodes away from the FAs, inside the cell \
                         and clear of the nucleus); found {} (lower it or refine the mesh)",
                        extra_microtubules.len(),
                        params.extra_microtubules
                    ),
                ));
            }
        }
        let taken: Vec<usize> = extra_bundle_ends
            .iter()
            .copied()
            .chain(extra_microtubules.iter().map(|mt| mt.fa_node))
            .collect();
        let extra_intermediate = choose_extra_intermediate(
            params,
            &mesh,
            &free_dome_nodes(params, &mesh, base_nodes, &fa_nodes, &taken),
        )?;
        // IFs in the unit-nucleus frame.
        let inner = mesh.node_sets["nucleus_surface"].clone();
        let scaled = Mesh {
            nodes: mesh
                .nodes
                .iter()
                .map(|&x| params.to_unit_nucleus(x))
                .collect(),
            ..Mesh::default()
        };
        let ifs = anchor_intermediate_filaments(
            &scaled,
            &inner,
            &fa_nodes,
            1.0,
            params.ifs_per_fa,
            params.if_phase,
            params.if_anchor_rule,
        )
        .map_err(|e| fail("intermediate", e.to_string()))?;
        mesh.insert_node_set("focal_adhesions", fa_nodes.clone());
        for (k, &n) in fa_nodes.iter().enumerate() {
            mesh.insert_node_set(format!("fa_{k}"), vec![n]);
        }
        mesh.insert_node_set("receptor", vec![fa_nodes[receptor]]);
        mesh.insert_node_set("if_anchors", ifs.filaments.iter().map(|f| f[1]).collect());
        if !extra_bundles.is_empty() {
            let mut ends: Vec<usize> = extra_bundles.iter().flatten().copied().collect();
            ends.sort_unstable();
            mesh.insert_node_set("extra_bundle_ends", ends);
        }
        let report = AdherentLayoutReport {
            mesh: mesh_quality,
            base_elements,
            hanging_nodes: refinement_hanging,
            fa_plaque_nodes: plaque_nodes,
            max_fa_snap: max_snap,
            bundle_length_range: lengths
                .iter()
                .fold((f64::INFINITY, 0.0), |(lo, hi), &l| (lo.min(l), hi.max(l))),
            min_mt_clearance_scaled: min_clearance,
            max_if_anchor_error_scaled: ifs.anchor_errors.iter().cloned().fold(0.0, f64::max),
            site: site_point.map(|p| (p, shape.dome_normal(p))),
        };
        Ok(Self {
            mesh,
            hanging,
            boundary_faces,
            fa_nodes,
            bundles,
            extra_bundles,
            centrosome,
            microtubules,
            extra_microtubules,
            intermediate_filaments: ifs.filaments.iter().map(|&[a, b]| [end(a), b]).collect(),
            extra_intermediate,
            receptor,
            report,
        })
    }

    /// Appends the centrosome and the MTs' interior points as nodes (node sets
    /// `centrosome`, `microtubule_interior`, `microtubule_anchors`) and returns each MT's
    /// chain: centrosome, interior nodes, FA node; the FA MTs first, then the density
    /// variant's extra MTs (ending on their dome nodes).
    pub fn append_microtubule_nodes(&self, mesh: &mut Mesh) -> Vec<Vec<usize>> {
        let centrosome = mesh.nodes.len();
        mesh.nodes.push(self.centrosome);
        mesh.insert_node_set("centrosome", vec![centrosome]);
        let chains: Vec<Vec<usize>> = self
            .microtubules
            .iter()
            .chain(&self.extra_microtubules)
            .map(|mt| {
                let mut chain = vec![centrosome];
                for &p in &mt.points[1..mt.points.len() - 1] {
                    chain.push(mesh.nodes.len());
                    mesh.nodes.push(p);
                }
                chain.push(mt.fa_node);
                chain
            })
            .collect();
        crate::cell::suspended::insert_microtubule_node_sets(mesh, &chains);
        chains
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cell 1000 times longer asks the octree at the tip for ~10⁸ elements: the refinement
    /// stops at the cell's limit with an error naming the refinement keys.
    #[test]
    fn a_refinement_beyond_the_cell_limit_is_an_error() {
        let (mut params, _) = super::super::params::defaults();
        params.shape.semi_axes[0] *= 1000.0;
        let err = AdherentCellGeometry::build(&params, Some(IndentationSite::Apex))
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("refinement") && err.contains("element_size"),
            "{err}"
        );
    }

    /// An element size the level cap cannot reach is an error naming `max_levels`, not a
    /// silently coarser mesh: 0.025 µm at the apex needs 7 halvings of its 3.4 µm base
    /// element, and 6 leave it 2.3 times too coarse. With 7 levels the same size builds.
    #[test]
    fn an_element_size_the_level_cap_cannot_reach_is_an_error() {
        let (mut params, _) = super::super::params::defaults();
        params.refinement.element_size = 0.025;
        params.refinement.max_levels = 6;
        let err = AdherentCellGeometry::build(&params, Some(IndentationSite::Apex))
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("max_levels") && err.contains("0.025 µm") && err.contains("2.3 times"),
            "{err}"
        );
        params.refinement.max_levels = 7;
        let built = AdherentCellGeometry::build(&params, Some(IndentationSite::Apex)).unwrap();
        let finest = built
            .mesh
            .blocks
            .iter()
            .flat_map(|b| b.connectivity.chunks(8))
            .map(|e| {
                super::super::geometry::longest_edge(&std::array::from_fn(|k| {
                    built.mesh.nodes[e[k]]
                }))
            })
            .fold(f64::INFINITY, f64::min);
        assert!(finest < 0.03, "finest element edge {finest} µm");
    }

    /// The two FA couplings on a 4 × 4 × 1 box whose top face is the dome: an FA at the
    /// top's centre node, a plaque of radius 0.6 (its four edge neighbours, 0.5 away), and a hanging
    /// node tied half to the FA node and half to a plaque node. Rigid: each plaque node is
    /// tied to the FA node, and the hanging tie names only free nodes. Distributing: the
    /// FA node is tied to its four plaque nodes with weight 1/4 each, and the hanging tie
    /// is rewritten onto them with its weights summing to 1; no master is tied itself.
    /// Separate reference: a new node carries the coupling, the FA node joins the plaque.
    #[test]
    fn the_fa_plaque_is_rigid_or_distributing() {
        use cellmech_fem::mesh::refine::HangingNode;
        let mut mesh = crate::cell::fa_plaque::plaque_test_box();
        mesh.node_sets
            .insert("dome".into(), mesh.node_sets["z_max"].clone());
        let fa = mesh.node_sets["dome"]
            .iter()
            .copied()
            .find(|&n| distance(mesh.nodes[n], [0.0, 0.0, 1.0]) < 1e-12)
            .unwrap();
        let plaque: Vec<usize> = mesh.node_sets["dome"]
            .iter()
            .copied()
            .filter(|&n| n != fa && distance(mesh.nodes[n], mesh.nodes[fa]) <= 0.6)
            .collect();
        assert_eq!(plaque.len(), 4);
        let bottom = mesh.node_sets["z_min"][0];
        let hanging = vec![HangingNode {
            node: bottom,
            masters: vec![(fa, 0.5), (plaque[0], 0.5)],
        }];
        let dome = mesh.node_sets["dome"].clone();
        let on_base: Vec<bool> = mesh.nodes.iter().map(|x| x[2] <= 1e-9).collect();
        let base = |n: usize| on_base[n];
        let tie = |mesh: &mut Mesh, coupling, reference| {
            tie_fa_plaques(
                mesh,
                hanging.clone(),
                &dome,
                base,
                &[fa],
                0.6,
                coupling,
                &[],
                reference,
                &[],
            )
        };
        let rigid = tie(&mut mesh.clone(), FaCoupling::Rigid, FaReference::FaNode);
        assert_eq!(rigid.plaque_nodes, 4);
        for &n in &plaque {
            let t = rigid.ties.iter().find(|h| h.node == n).unwrap();
            assert_eq!(t.masters, vec![(fa, 1.0)]);
        }
        let h = rigid.ties.iter().find(|h| h.node == bottom).unwrap();
        assert_eq!(h.masters, vec![(fa, 1.0)]);
        let distributing = tie(
            &mut mesh.clone(),
            FaCoupling::Distributing,
            FaReference::FaNode,
        );
        let distributing_ties = &distributing.ties;
        assert_eq!(distributing.plaque_nodes, 4);
        assert_eq!(distributing_ties.len(), 2);
        assert!(distributing.references.is_empty());
        let t = distributing_ties.iter().find(|h| h.node == fa).unwrap();
        assert_eq!(
            t.masters,
            plaque.iter().map(|&n| (n, 0.25)).collect::<Vec<_>>()
        );
        let h = distributing_ties.iter().find(|h| h.node == bottom).unwrap();
        let sum: f64 = h.masters.iter().map(|m| m.1).sum();
        assert!((sum - 1.0).abs() < 1e-15, "{:?}", h.masters);
        let weight = |n: usize| h.masters.iter().find(|m| m.0 == n).map_or(0.0, |m| m.1);
        assert!((weight(plaque[0]) - (0.5 + 0.125)).abs() < 1e-15);
        assert!((weight(plaque[1]) - 0.125).abs() < 1e-15);
        let slaves: Vec<usize> = distributing_ties.iter().map(|h| h.node).collect();
        assert!(distributing_ties
            .iter()
            .all(|h| h.masters.iter().all(|m| !slaves.contains(&m.0))));
        // A separate reference node: appended at the plaque's centroid, tied to the plaque and the FA node
        // (1/5 each); the FA node stays free, and the hanging tie is left as it was.
        let mut separate_mesh = mesh.clone();
        let separate = tie(
            &mut separate_mesh,
            FaCoupling::Distributing,
            FaReference::Separate,
        );
        let r = mesh.nodes.len();
        assert_eq!(separate.references.get(&fa), Some(&r));
        assert_eq!(separate_mesh.nodes.len(), r + 1);
        // At the plaque's weighted centroid: on this flat, symmetric plaque, the FA.
        assert!(distance(separate_mesh.nodes[r], mesh.nodes[fa]) < 1e-15);
        let t = separate.ties.iter().find(|h| h.node == r).unwrap();
        let mut expected: Vec<(usize, f64)> =
            plaque.iter().chain([&fa]).map(|&n| (n, 0.2)).collect();
        expected.sort_by_key(|m| m.0);
        assert_eq!(t.masters.len(), 5);
        for (m, e) in t.masters.iter().zip(&expected) {
            assert!(m.0 == e.0 && (m.1 - e.1).abs() < 1e-15, "{:?}", t.masters);
        }
        assert!(separate.ties.iter().all(|h| h.node != fa));
        let h = separate.ties.iter().find(|h| h.node == bottom).unwrap();
        let mut unchanged = vec![(fa, 0.5), (plaque[0], 0.5)];
        unchanged.sort_by_key(|m| m.0);
        assert_eq!(h.masters, unchanged);
    }

    /// The wanted size: the plateau, the near slope over the graded band, the far slope
    /// beyond it, continuous at both kinks; an infinite band is the single-slope rule.
    #[test]
    fn the_wanted_size_has_a_plateau_then_two_slopes() {
        let r = LocalRefinement {
            element_size: 0.05,
            fine_radius: 0.2,
            grading: 0.25,
            graded_width: 1.0,
            far_grading: 1.0,
            max_levels: 8,
        };
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(r.target_size(0.0), 0.05) && close(r.target_size(0.3), 0.05));
        assert!(close(r.target_size(0.2 + 0.8), 0.2)); // 0.25 × 0.8
        assert!(close(r.target_size(1.2), 0.25)); // the band's end
        assert!(close(r.target_size(3.2), 0.25 + 2.0)); // far slope 1
        for k in 0..400 {
            let d = 0.01 * k as f64;
            assert!(r.target_size(d + 0.01) >= r.target_size(d));
            assert!(r.target_size(d + 0.01) - r.target_size(d) <= 0.01 + 1e-12);
        }
        let single = LocalRefinement {
            graded_width: 1000.0,
            ..r
        };
        assert!(close(single.target_size(5.2), 0.25 * 5.0));
    }
}
