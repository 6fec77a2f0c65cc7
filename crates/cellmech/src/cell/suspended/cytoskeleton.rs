//! Routing of the discrete cytoskeleton between the FA nodes, the centrosome and the
//! nucleus surface: curved microtubules (MTs) and tangential intermediate filaments (IFs).
//!
//! **MTs.** Let `C` be the centrosome (radius `r_c` from the cell centre `O`), `F` an FA
//! (radius `R`), `u_C`, `u_F` their directions and `θ` the angle between them. In the plane
//! through `O`, `C` and `F` (normal `n`; any deterministic plane through `O` and `C` when
//! `θ` is 0 or π) the base path is the spiral `g(t) = cos(tθ) u_C + sin(tθ) e` with radius
//! `r(t) = r_c + (R − r_c) t`. The bow turns the direction sideways:
//! `p(t) = r(t) · normalize(g(t) + s β sin(πt) n)` with `s = ±1` and
//! `β = b |F − C| / r(1/2)`, so the sideways bow at mid-length is about `b` times the chord.
//! `b` is drawn per MT, uniform in `[bow_min, bow_max]`, and `s` is a fair coin, both from
//! a SplitMix64 stream seeded by the parameters' seed. Because `|p(t)| = r(t)` grows from
//! `r_c` to `R`, the curve never enters the nucleus nor leaves the cell; the straight beam
//! elements between the samples `t = i/m` are checked explicitly.
//!
//! **IFs.** From `F`, the lines touching the nucleus sphere (radius `r_n`) touch it on the
//! circle of centre `(r_n²/R) u_F` and radius `r_n √(1 − r_n²/R²)`. The `k`-th of `m` IFs
//! aims at the circle point at angle `phase + 2πk/m`, measured from the projection of `+z`
//! on the circle's plane (of `+x` for an FA on the z-axis). Its anchor is the nucleus
//! surface node nearest to that point ([`IfAnchorRule::Nearest`], the spec's wording), or
//! nearest among the nodes visible from `F` (`F·A ≥ r_n²`, so the straight IF never
//! crosses the nucleus; [`IfAnchorRule::NearestVisible`]), and not already used by another
//! IF. The distinct anchors are a bottleneck assignment over each IF's 16 nearest
//! candidates (the largest anchor error is minimised); an IF falls back to its nearest
//! candidate (shared) only when no assignment of distinct nodes exists.

use cellmech_fem::mesh::generate::SplitMix64;
use cellmech_fem::mesh::Mesh;

use super::CellGeometryError;
use crate::cell::vec3::{
    add, any_perpendicular, cross, distance, dot, norm, normalize, scale, sub, V3,
};

/// Mixed into the seed for the MT stream, so MT bows do not depend on the orientation
/// search's consumption of random numbers.
const MT_STREAM: u64 = 0x4D54_5F42_4F57_5321;

/// One microtubule: a polyline from the centrosome to its FA, split into beam elements.
#[derive(Debug, Clone, PartialEq)]
pub struct MicrotubulePath {
    /// Mesh index of the node the MT ends on: its FA node, or with `fa_reference =
    /// "separate"` the FA plaque's reference node.
    pub fa_node: usize,
    /// Points from the centrosome (first) to the FA (last), inclusive; consecutive points
    /// are the ends of one beam element.
    pub points: Vec<V3>,
    /// Unit normal of the plane through the cell centre, the centrosome and the FA: a
    /// reference "up" direction for the beam sections (see [`Self::segment_normals`]).
    pub plane_normal: V3,
    /// Sideways bow at mid-length as a fraction of the chord `|F − C|` (signed: the sign is
    /// the side of the plane the MT bows to).
    pub bow: f64,
}

impl MicrotubulePath {
    /// Number of beam elements.
    pub fn elements(&self) -> usize {
        self.points.len().saturating_sub(1)
    }

    /// Arc length of the polyline (µm).
    pub fn length(&self) -> f64 {
        self.points.windows(2).map(|w| distance(w[0], w[1])).sum()
    }

    /// Straight distance from the centrosome to the FA (µm).
    pub fn chord(&self) -> f64 {
        match (self.points.first(), self.points.last()) {
            (Some(&a), Some(&b)) => distance(a, b),
            _ => 0.0,
        }
    }

    /// Largest discrete curvature (turning angle at an interior node over the mean length
    /// of its two elements, 1/µm).
    pub fn max_curvature(&self) -> f64 {
        self.points
            .windows(3)
            .map(|w| {
                let (a, b) = (sub(w[1], w[0]), sub(w[2], w[1]));
                crate::cell::vec3::angle(a, b) / (0.5 * (norm(a) + norm(b)))
            })
            .fold(0.0, f64::max)
    }

    /// For each element, a unit vector perpendicular to it: the plane normal with its
    /// component along the element removed (a beam section's reference vector).
    pub fn segment_normals(&self) -> Vec<V3> {
        self.points
            .windows(2)
            .map(|w| {
                let t = normalize(sub(w[1], w[0]));
                let v = sub(self.plane_normal, scale(t, dot(self.plane_normal, t)));
                if norm(v) > 1e-6 {
                    normalize(v)
                } else {
                    any_perpendicular(t)
                }
            })
            .collect()
    }
}

/// Parameters of the MT routing (lengths in µm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct MicrotubuleRouting {
    pub centrosome: V3,
    pub cell_radius: f64,
    pub nucleus_radius: f64,
    pub elements: usize,
    pub bow_min: f64,
    pub bow_max: f64,
    pub clearance_margin: f64,
    pub seed: u64,
}

/// Routes one MT per FA (in FA order) and checks the clearance of every element from the
/// nucleus. Returns the paths and the smallest distance of any element from the nucleus
/// surface.
pub(crate) fn route_microtubules(
    routing: &MicrotubuleRouting,
    fa_nodes: &[usize],
    fa_points: &[V3],
) -> Result<(Vec<MicrotubulePath>, f64), CellGeometryError> {
    let mut rng = SplitMix64::new(routing.seed ^ MT_STREAM);
    let mut paths = Vec::with_capacity(fa_nodes.len());
    let mut min_clearance = f64::INFINITY;
    for (k, (&node, &fa)) in fa_nodes.iter().zip(fa_points).enumerate() {
        let bow = rng.uniform(routing.bow_min, routing.bow_max.max(routing.bow_min));
        let side = if rng.next_u64() & 1 == 0 { 1.0 } else { -1.0 };
        let path = route_one(routing, node, fa, side * bow);
        let clearance = polyline_distance_to_origin(&path.points) - routing.nucleus_radius;
        if !(clearance >= routing.clearance_margin) {
            return Err(CellGeometryError::MicrotubuleTooClose {
                microtubule: k,
                clearance,
                required: routing.clearance_margin,
            });
        }
        min_clearance = min_clearance.min(clearance);
        paths.push(path);
    }
    Ok((paths, min_clearance))
}

/// The curve of one MT with signed bow `bow` (fraction of the chord).
pub(crate) fn route_one(
    routing: &MicrotubuleRouting,
    fa_node: usize,
    fa: V3,
    bow: f64,
) -> MicrotubulePath {
    let c = routing.centrosome;
    let (r_c, r_f) = (norm(c), norm(fa));
    let (u_c, u_f) = (normalize(c), normalize(fa));
    let theta = crate::cell::vec3::angle(u_c, u_f);
    let normal_raw = cross(u_c, u_f);
    let n = if norm(normal_raw) > 1e-9 {
        normalize(normal_raw)
    } else {
        any_perpendicular(u_c)
    };
    let e = cross(n, u_c);
    let radius = |t: f64| r_c + (r_f - r_c) * t;
    let beta = bow * distance(fa, c) / radius(0.5);
    let m = routing.elements;
    let mut points = Vec::with_capacity(m + 1);
    points.push(c);
    for i in 1..m {
        let t = i as f64 / m as f64;
        let (s, co) = (t * theta).sin_cos();
        let g = add(scale(u_c, co), scale(e, s));
        let d = normalize(add(g, scale(n, beta * (std::f64::consts::PI * t).sin())));
        points.push(scale(d, radius(t)));
    }
    points.push(fa);
    MicrotubulePath {
        fa_node,
        points,
        plane_normal: n,
        bow,
    }
}

/// Smallest distance from the origin to a polyline.
pub(crate) fn polyline_distance_to_origin(points: &[V3]) -> f64 {
    points
        .windows(2)
        .map(|w| segment_distance_to_origin(w[0], w[1]))
        .fold(f64::INFINITY, f64::min)
}

/// Distance from the origin to the segment `[a, b]`.
pub(crate) fn segment_distance_to_origin(a: V3, b: V3) -> f64 {
    let d = sub(b, a);
    let dd = dot(d, d);
    let t = if dd > 0.0 {
        (-dot(a, d) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    norm(add(a, scale(d, t)))
}

/// Which nucleus-surface nodes may anchor an IF.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum IfAnchorRule {
    /// The node nearest to the tangent point (the IF may graze the nucleus by a small
    /// depth, reported as `max_if_nucleus_penetration`).
    Nearest,
    /// The nearest node visible from the FA: the IF never enters the nucleus, at the cost
    /// of a larger anchor error (the tangent circle bounds the visible cap).
    NearestVisible,
}

/// Candidate anchors looked at per IF before it may share a node.
const ANCHOR_CANDIDATES: usize = 16;

/// Assigns distinct nodes to items, each with candidates `(distance, node)` sorted by
/// distance, minimising the largest distance used (bottleneck assignment: bisection on
/// the threshold, Kuhn's augmenting paths for the matching, nearest candidates tried
/// first). Items left unmatched even with every candidate get `None`.
fn bottleneck_assignment(lists: &[Vec<(f64, usize)>]) -> Vec<Option<(usize, f64)>> {
    let mut thresholds: Vec<f64> = lists.iter().flatten().map(|c| c.0).collect();
    thresholds.sort_by(f64::total_cmp);
    thresholds.dedup();
    let matching = |limit: f64| {
        let mut owner: std::collections::HashMap<usize, usize> = Default::default();
        for i in 0..lists.len() {
            let mut visited = std::collections::HashSet::new();
            augment(i, lists, limit, &mut owner, &mut visited);
        }
        owner
    };
    let full = |owner: &std::collections::HashMap<usize, usize>| owner.len() == lists.len();
    let (mut lo, mut hi) = (0, thresholds.len().saturating_sub(1));
    let mut best = matching(thresholds.last().copied().unwrap_or(0.0));
    if full(&best) {
        while lo < hi {
            let mid = (lo + hi) / 2;
            let m = matching(thresholds[mid]);
            if full(&m) {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        best = matching(thresholds[hi]);
    }
    let mut out = vec![None; lists.len()];
    for (&node, &i) in &best {
        let d = lists[i]
            .iter()
            .find(|c| c.1 == node)
            .map_or(f64::INFINITY, |c| c.0);
        out[i] = Some((node, d));
    }
    out
}

/// Kuhn's augmenting path from item `i` using candidates within `limit`.
fn augment(
    i: usize,
    lists: &[Vec<(f64, usize)>],
    limit: f64,
    owner: &mut std::collections::HashMap<usize, usize>,
    visited: &mut std::collections::HashSet<usize>,
) -> bool {
    for &(d, node) in &lists[i] {
        if d > limit || !visited.insert(node) {
            continue;
        }
        let free = match owner.get(&node) {
            None => true,
            Some(&j) => augment(j, lists, limit, owner, visited),
        };
        if free {
            owner.insert(node, i);
            return true;
        }
    }
    false
}

/// IFs from FAs to the nucleus surface with their anchor errors.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct IntermediateFilamentLayout {
    /// `[FA node, nucleus-surface node]`, FA by FA, `per_fa` consecutive IFs each.
    pub filaments: Vec<[usize; 2]>,
    /// Distance from each anchor to its ideal tangent point (µm).
    pub anchor_errors: Vec<f64>,
    /// IFs whose anchor is also used by another IF.
    pub shared_anchors: usize,
}

/// Ideal tangent points of the IFs of one FA at `fa` (see the module docs).
pub(crate) fn tangent_points(fa: V3, nucleus_radius: f64, per_fa: usize, phase: f64) -> Vec<V3> {
    let r_f = norm(fa);
    let u = normalize(fa);
    let z = [0.0, 0.0, 1.0];
    let zp = sub(z, scale(u, dot(z, u)));
    let a = if norm(zp) > 1e-9 {
        normalize(zp)
    } else {
        let x = [1.0, 0.0, 0.0];
        normalize(sub(x, scale(u, dot(x, u))))
    };
    let b = cross(u, a);
    let centre = scale(u, nucleus_radius * nucleus_radius / r_f);
    let rho = nucleus_radius * (1.0 - (nucleus_radius / r_f).powi(2)).sqrt();
    (0..per_fa)
        .map(|k| {
            let alpha = phase + std::f64::consts::TAU * k as f64 / per_fa as f64;
            add(
                centre,
                add(scale(a, rho * alpha.cos()), scale(b, rho * alpha.sin())),
            )
        })
        .collect()
}

/// Anchors `per_fa` IFs per FA on the nucleus-surface nodes `inner`.
pub(crate) fn anchor_intermediate_filaments(
    mesh: &Mesh,
    inner: &[usize],
    fa_nodes: &[usize],
    nucleus_radius: f64,
    per_fa: usize,
    phase: f64,
    rule: IfAnchorRule,
) -> Result<IntermediateFilamentLayout, CellGeometryError> {
    // (fa node, ideal point, candidate anchors sorted by distance)
    let mut wanted = Vec::new();
    for &fa in fa_nodes {
        let f = mesh.nodes[fa];
        for t in tangent_points(f, nucleus_radius, per_fa, phase) {
            let mut candidates: Vec<(f64, usize)> = inner
                .iter()
                .filter(|&&n| {
                    rule == IfAnchorRule::Nearest
                        || dot(f, mesh.nodes[n]) >= nucleus_radius * nucleus_radius * (1.0 - 1e-12)
                })
                .map(|&n| (distance(mesh.nodes[n], t), n))
                .collect();
            candidates.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            candidates.truncate(ANCHOR_CANDIDATES);
            if candidates.is_empty() {
                return Err(CellGeometryError::NoVisibleNucleusNode { fa_node: fa });
            }
            wanted.push((fa, candidates));
        }
    }
    let lists: Vec<Vec<(f64, usize)>> = wanted.iter().map(|(_, c)| c.clone()).collect();
    let anchor = bottleneck_assignment(&lists);
    let mut shared = 0;
    let mut filaments = Vec::with_capacity(wanted.len());
    let mut errors = Vec::with_capacity(wanted.len());
    for (i, (fa, candidates)) in wanted.iter().enumerate() {
        let (n, d) = match anchor[i] {
            Some(a) => a,
            None => {
                shared += 1;
                let (d, n) = candidates[0];
                (n, d)
            }
        };
        filaments.push([*fa, n]);
        errors.push(d);
    }
    Ok(IntermediateFilamentLayout {
        filaments,
        anchor_errors: errors,
        shared_anchors: shared,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangent_points_are_tangent_and_evenly_spaced() {
        let fa = [3.0, -9.0, 12.0];
        let r_n = 6.45;
        let points = tangent_points(fa, r_n, 3, 0.3);
        for t in &points {
            assert!((norm(*t) - r_n).abs() < 1e-12);
            // (T − F) ⟂ T: the line from the FA touches the sphere at T.
            assert!(dot(sub(*t, fa), *t).abs() < 1e-10);
        }
        let d01 = distance(points[0], points[1]);
        let d12 = distance(points[1], points[2]);
        assert!((d01 - d12).abs() < 1e-12);
        // Phase 0 starts towards +z.
        let first = tangent_points(fa, r_n, 1, 0.0)[0];
        let others = tangent_points(fa, r_n, 4, 0.0);
        assert!(others.iter().all(|p| p[2] <= first[2] + 1e-12));
    }

    #[test]
    fn segment_distance_handles_ends_and_interior() {
        assert!(
            (segment_distance_to_origin([-1.0, 2.0, 0.0], [1.0, 2.0, 0.0]) - 2.0).abs() < 1e-15
        );
        assert!(
            (segment_distance_to_origin([1.0, 2.0, 0.0], [3.0, 2.0, 0.0]) - 5f64.sqrt()).abs()
                < 1e-15
        );
        assert_eq!(
            segment_distance_to_origin([0.0, 3.0, 4.0], [0.0, 3.0, 4.0]),
            5.0
        );
    }
}
