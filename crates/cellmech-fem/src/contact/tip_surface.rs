//! The second pass of a two-pass contact: points of the rigid tool's own surface against the
//! body's surface faces ([`super::RigidContact::with_tool_points_on_faces`]).
//!
//! Node contact keeps the body's nodes out of the tool; it cannot keep the tool out of the
//! body's faces. An AFM tip of radius 0.2 µm that has stretched the faces under it to a
//! few tenths of a micrometre pokes through them between their nodes, and the material
//! under the face ends up inside the tip (`docs/adherent-cell.md`). The second pass treats
//! the tool as the slave: a set of points on the tool's surface, moving with it, each kept
//! on the outer side of the faces it lies behind.
//!
//! No scenario key reaches this pass yet: in the adherent cell, points on the tip's flank
//! stiffened the response far beyond the faceting error below (the cause is not settled),
//! and the apex point alone changed nothing (`docs/tools.md`, "Two-pass contact (engine
//! only)").
//!
//! **Geometry.** Each bilinear face is split into four triangles through its centroid
//! (corner k, corner k+1, centroid), so the surface seen by the tool is piecewise flat and
//! the gap of a tool point `s` from triangle t is the closed form
//! `g = (s − a)·m/|m|`, `m = (b − a) × (c − a)`, positive on the outer side (the face's
//! corners run counter-clockwise seen from outside). The centroid is the mean of the four
//! corners, so every triangle depends on all twelve translations of its face.
//!
//! **Law.** The same augmented-Lagrangian law as the first pass, per (face, tool point)
//! pair: `Π = p²/(2ε)`, `p = λ − ε g`, residual `−p ∇g` on the face's nodes, tangent
//! `ε ∇g∇gᵀ − p ∇²g`. The gradient and Hessian of g with respect to the face's twelve
//! translations are exact: g is written once over [`Scalar`] and evaluated with a
//! twelve-variable hyper-dual number. The pressure in the curvature term follows the
//! contact's [`super::CurvatureTangent`] as for the nodes.
//!
//! **Status.** As for the nodes: pairs are held during Newton and updated at a converged
//! state. A tool point enters a face's pairs when it projects inside one of the face's
//! triangles and lies behind it by more than the tolerance (and less than the reach, so a
//! face on the far side of the body is never paired). A pair keeps its triangle while the
//! point projects within [`KEEP_MARGIN`] of it (the margin stops a point on an edge from
//! cycling between the planes on either side), then moves to the face's triangle the point
//! projects into. A point that has slid off its face altogether goes on pressing on the
//! face it is over now, multiplier and all: the material under an indenter slides outwards
//! along it, its points cross face edges at every increment, and a multiplier dropped at
//! each crossing (and rebuilt from the penalty alone) made the augmentations jump and the
//! increments crawl. A pair leaves when it pulls harder than ε·tolerance.
//!
//! **Accuracy.** The faces' triangles are kept outside the tool's points, where node
//! contact lets them cut into the tool by their sag h²/(8R). So two passes are stiffer than
//! one where the nodes resolve the tool, by an error that falls like the sag: on a bed of
//! springs under a paraboloid, +21 % at h = R/2 and +4 % at h = R/4 of the Winkler force
//! (node contact: −2.3 % and −0.04 %; `two_passes_on_a_spring_bed_converge_to_the_winkler_force_from_above`).

use crate::math::vec3::{cross, dot, sub};
use crate::math::{HyperDualN, Scalar};

/// Hyper-dual number over a face's twelve translations.
pub(super) type FaceDual = HyperDualN<12, 78>;

/// One tool point pressing on one triangle of a face, held during Newton.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct TipPair {
    /// Index of the tool point.
    pub point: usize,
    /// Triangle of the face (0–3: corner k, corner k+1, centroid).
    pub triangle: usize,
    /// Augmented-Lagrangian multiplier (nN).
    pub lambda: f64,
    /// Pressure at the last converged Newton state (the curvature term's cap).
    pub equilibrium_pressure: f64,
    /// Entered at the last status update: its multiplier is not updated from that state.
    pub fresh: bool,
}

/// The tool's surface points and how they meet the body's faces.
#[derive(Debug, Clone)]
pub(super) struct ToolPoints {
    /// First contact element that is a face of this pass.
    pub first_element: usize,
    /// The tool's surface points in its reference position (µm).
    pub points: Vec<[f64; 3]>,
    /// Penalty ε of one pair (nN/µm).
    pub penalty: f64,
    /// Deepest a point may lie behind a face to enter a pair (µm).
    pub reach: f64,
    /// The points binned in cubes of side `cell` (reference position): the search for the
    /// points near a face visits the cubes its box meets, not every point.
    grid: std::collections::HashMap<[i64; 3], Vec<usize>>,
    cell: f64,
}

impl ToolPoints {
    /// The points, binned in cubes of side `reach`.
    pub fn new(first_element: usize, points: Vec<[f64; 3]>, penalty: f64, reach: f64) -> Self {
        let cell = reach;
        let mut grid: std::collections::HashMap<[i64; 3], Vec<usize>> = Default::default();
        for (q, x) in points.iter().enumerate() {
            grid.entry(x.map(|v| (v / cell).floor() as i64))
                .or_default()
                .push(q);
        }
        ToolPoints {
            first_element,
            points,
            penalty,
            reach,
            grid,
            cell,
        }
    }

    /// Calls `visit` with every point that may lie in the box `lo..hi` when the tool is
    /// displaced by `offset` (the points of every cube the box meets).
    pub fn points_near(
        &self,
        lo: &[f64; 3],
        hi: &[f64; 3],
        offset: &[f64; 3],
        mut visit: impl FnMut(usize),
    ) {
        let a: [i64; 3] = std::array::from_fn(|i| ((lo[i] - offset[i]) / self.cell).floor() as i64);
        let b: [i64; 3] = std::array::from_fn(|i| ((hi[i] - offset[i]) / self.cell).floor() as i64);
        if (0..3).any(|i| b[i] - a[i] > 10_000) {
            // A box far larger than the tool: every point.
            (0..self.points.len()).for_each(visit);
            return;
        }
        for i in a[0]..=b[0] {
            for j in a[1]..=b[1] {
                for k in a[2]..=b[2] {
                    if let Some(points) = self.grid.get(&[i, j, k]) {
                        points.iter().copied().for_each(&mut visit);
                    }
                }
            }
        }
    }
}

/// The corners of triangle `t` of a face with corners `x`: corner t, corner t+1, centroid.
fn triangle<S: Scalar>(x: &[[S; 3]; 4], t: usize) -> [[S; 3]; 3] {
    let c: [S; 3] = std::array::from_fn(|i| (x[0][i] + x[1][i] + x[2][i] + x[3][i]) * 0.25);
    [x[t % 4], x[(t + 1) % 4], c]
}

/// Signed distance of the point `s` from the plane of triangle `t` of the face with corners
/// `x` (positive on the outer side).
pub(super) fn triangle_gap<S: Scalar>(s: &[f64; 3], x: &[[S; 3]; 4], t: usize) -> S {
    let [a, b, c] = triangle(x, t);
    let m = cross(&sub(&b, &a), &sub(&c, &a));
    let length = dot(&m, &m).sqrt();
    let d: [S; 3] = std::array::from_fn(|i| S::constant(s[i]) - a[i]);
    dot(&d, &m) / length
}

/// Barycentric coordinates of the projection of `s` on triangle `t` (all ≥ 0 inside), its
/// gap, and the triangle's outer unit normal; `None` for a degenerate triangle.
pub(super) fn triangle_projection(
    s: &[f64; 3],
    x: &[[f64; 3]; 4],
    t: usize,
) -> Option<([f64; 3], f64, [f64; 3])> {
    let [a, b, c] = triangle(x, t);
    let m = cross(&sub(&b, &a), &sub(&c, &a));
    let area2 = dot(&m, &m);
    if !(area2 > 0.0) {
        return None;
    }
    let length = area2.sqrt();
    let n = m.map(|v| v / length);
    let gap = dot(&sub(s, &a), &n);
    let p: [f64; 3] = std::array::from_fn(|i| s[i] - gap * n[i]);
    let weight = |u: &[f64; 3], v: &[f64; 3]| dot(&cross(&sub(v, u), &sub(&p, u)), &m) / area2;
    Some(([weight(&b, &c), weight(&c, &a), weight(&a, &b)], gap, n))
}

/// Whether barycentric coordinates lie inside their triangle (edges included, with a
/// round-off margin so a point on an edge between two triangles belongs to both).
pub(super) fn inside(bary: &[f64; 3]) -> bool {
    within(bary, 1e-9)
}

/// How far beyond its triangle's edges (in barycentric coordinates) a pressing point keeps
/// its pair: a point that enters strictly inside a triangle and leaves only this far out
/// cannot cycle between two triangles or faces whose planes push it back across the edge
/// (it pressed on both sides of the edge for a while instead).
pub(super) const KEEP_MARGIN: f64 = 0.1;

/// Whether barycentric coordinates lie within `margin` of their triangle.
pub(super) fn within(bary: &[f64; 3], margin: f64) -> bool {
    bary.iter().all(|&w| w >= -margin)
}

/// The first triangle of the face with corners `x` that `s` projects into, with its gap.
pub(super) fn projecting_triangle(s: &[f64; 3], x: &[[f64; 3]; 4]) -> Option<(usize, f64)> {
    (0..4).find_map(|t| {
        let (bary, gap, _) = triangle_projection(s, x, t)?;
        inside(&bary).then_some((t, gap))
    })
}

/// Gap of `s` from triangle `t` with its exact gradient and Hessian with respect to the
/// face's twelve translations (corner-major, x/y/z).
pub(super) fn triangle_gap_derivatives(s: &[f64; 3], x: &[[f64; 3]; 4], t: usize) -> FaceDual {
    let xd: [[FaceDual; 3]; 4] =
        std::array::from_fn(|a| std::array::from_fn(|i| FaceDual::variable(3 * a + i, x[a][i])));
    triangle_gap(s, &xd, t)
}

/// Points on a paraboloid tip of radius `tip_radius` with apex `apex` and unit `axis`
/// (towards the body), about `spacing` apart along the surface, out to `extent` from the
/// axis: the apex, then rings at arc-length steps of `spacing` along the meridian, each
/// with as many points as fit at `spacing` round its circumference.
pub(super) fn paraboloid_points(
    apex: &[f64; 3],
    axis: &[f64; 3],
    tip_radius: f64,
    spacing: f64,
    extent: f64,
) -> Vec<[f64; 3]> {
    // Two unit vectors across the axis.
    let helper = if axis[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let e1 = {
        let v = cross(axis, &helper);
        let l = dot(&v, &v).sqrt();
        v.map(|c| c / l)
    };
    let e2 = cross(axis, &e1);
    let mut points = vec![*apex];
    let mut r: f64 = 0.0;
    let mut ring = 0usize;
    loop {
        // Step the meridian's arc length by `spacing`: dr = ds / √(1 + (r/R)²).
        r += spacing / (1.0 + (r / tip_radius).powi(2)).sqrt();
        ring += 1;
        if r > extent || ring > 100_000 {
            break;
        }
        let behind = r * r / (2.0 * tip_radius);
        let count = ((std::f64::consts::TAU * r / spacing).ceil() as usize).max(3);
        // Alternate rings are turned by half a step, so the points tile the surface.
        let turn = if ring % 2 == 0 { 0.5 } else { 0.0 };
        for k in 0..count {
            let theta = std::f64::consts::TAU * (k as f64 + turn) / count as f64;
            let (sin, cos) = theta.sin_cos();
            points.push(std::array::from_fn(|i| {
                apex[i] + r * (cos * e1[i] + sin * e2[i]) - behind * axis[i]
            }));
        }
    }
    points
}
