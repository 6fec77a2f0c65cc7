//! Rigid tool shapes as gap functions.
//!
//! Each shape gives a gap function φ(x) that is zero on the tool surface, positive outside
//! the tool (where the body may be) and negative inside, with its gradient and Hessian. For
//! the plate and the sphere φ is the signed distance; for the paraboloid it is the axial
//! level set s + r²/(2R) (s the axial coordinate from the apex towards the body, r the
//! lateral distance) divided by its gradient's length: a first-order signed distance whose
//! gradient is the unit normal on the surface, so the frictionless contact force is normal
//! where it acts and the penalty is as stiff on the tip's flank as at its apex.

use crate::math::vec3::{dot, sub};

/// Shape of a rigid tool in its reference position (moved by the pilot-point displacement).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub enum ToolShape {
    /// Infinite flat plate through `point` with unit `normal` pointing towards the body.
    Plate {
        /// A point of the plate surface (µm).
        point: [f64; 3],
        /// Unit normal, out of the plate towards the body.
        normal: [f64; 3],
    },
    /// Flat disk of `radius` (a micropipette tip seen end-on): a plate limited to the nodes
    /// whose projection on it lies within the radius.
    Disk {
        /// Centre of the disk face (µm).
        center: [f64; 3],
        /// Unit normal towards the body.
        normal: [f64; 3],
        /// Radius (µm).
        radius: f64,
    },
    /// Paraboloid tip (AFM) with apex `apex`, unit `axis` pointing from the tip towards the
    /// body, and tip radius `tip_radius`.
    Paraboloid {
        /// Apex (µm).
        apex: [f64; 3],
        /// Unit axis towards the body.
        axis: [f64; 3],
        /// Tip radius of curvature (µm).
        tip_radius: f64,
    },
    /// Rigid sphere (colloidal probe).
    Sphere {
        /// Centre (µm).
        center: [f64; 3],
        /// Radius (µm).
        radius: f64,
    },
}

/// Gap, gradient and Hessian of φ at a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gap {
    /// φ (µm); negative means penetration.
    pub value: f64,
    /// ∇φ.
    pub gradient: [f64; 3],
    /// ∇²φ (row-major 3×3).
    pub hessian: [[f64; 3]; 3],
}

impl ToolShape {
    /// Checks the parameters: unit-length normals/axes, positive radii.
    pub fn validate(&self) -> Result<(), String> {
        let unit = |v: &[f64; 3], what: &str| {
            let n = dot(v, v).sqrt();
            if (n - 1.0).abs() > 1e-9 {
                Err(format!(
                    "the {what} must be a unit vector; its length is {n}"
                ))
            } else {
                Ok(())
            }
        };
        let positive = |r: f64, what: &str| {
            if r > 0.0 && r.is_finite() {
                Ok(())
            } else {
                Err(format!("the {what} must be > 0; found {r} um"))
            }
        };
        match self {
            ToolShape::Plate { normal, .. } => unit(normal, "plate normal"),
            ToolShape::Disk { normal, radius, .. } => {
                unit(normal, "disk normal")?;
                positive(*radius, "disk radius")
            }
            ToolShape::Paraboloid {
                axis, tip_radius, ..
            } => {
                unit(axis, "tip axis")?;
                positive(*tip_radius, "tip radius")
            }
            ToolShape::Sphere { radius, .. } => positive(*radius, "sphere radius"),
        }
    }

    /// Unit direction along which the tool acts on the body (normal/axis; for the sphere
    /// `None`: it acts along its motion).
    pub fn axis(&self) -> Option<[f64; 3]> {
        match self {
            ToolShape::Plate { normal, .. } | ToolShape::Disk { normal, .. } => Some(*normal),
            ToolShape::Paraboloid { axis, .. } => Some(*axis),
            ToolShape::Sphere { .. } => None,
        }
    }

    /// The point on an indenter's axis from which a contact radius is measured (the
    /// paraboloid's apex, the sphere's centre), undisplaced; `None` for plates and disks,
    /// which have no contact radius.
    pub fn axis_point(&self) -> Option<[f64; 3]> {
        match self {
            ToolShape::Plate { .. } | ToolShape::Disk { .. } => None,
            ToolShape::Paraboloid { apex, .. } => Some(*apex),
            ToolShape::Sphere { center, .. } => Some(*center),
        }
    }

    /// Gap of point `x` when the tool is displaced by `offset`. `None` where the tool cannot
    /// act (outside a disk's radius).
    pub fn gap(&self, x: &[f64; 3], offset: &[f64; 3]) -> Option<Gap> {
        let zero = [[0.0; 3]; 3];
        match self {
            ToolShape::Plate { point, normal } => {
                let d = sub(&sub(x, point), offset);
                Some(Gap {
                    value: dot(&d, normal),
                    gradient: *normal,
                    hessian: zero,
                })
            }
            ToolShape::Disk {
                center,
                normal,
                radius,
            } => {
                let d = sub(&sub(x, center), offset);
                let s = dot(&d, normal);
                let lateral: [f64; 3] = std::array::from_fn(|i| d[i] - s * normal[i]);
                (dot(&lateral, &lateral) <= radius * radius).then_some(Gap {
                    value: s,
                    gradient: *normal,
                    hessian: zero,
                })
            }
            ToolShape::Paraboloid {
                apex,
                axis,
                tip_radius,
            } => Some(paraboloid_gap(
                &sub(&sub(x, apex), offset),
                axis,
                1.0 / tip_radius,
            )),
            ToolShape::Sphere { center, radius } => {
                let d = sub(&sub(x, center), offset);
                let l = dot(&d, &d).sqrt().max(1e-300);
                let n: [f64; 3] = std::array::from_fn(|i| d[i] / l);
                let hessian = std::array::from_fn(|i| {
                    std::array::from_fn(|j| {
                        let delta = if i == j { 1.0 } else { 0.0 };
                        (delta - n[i] * n[j]) / l
                    })
                });
                Some(Gap {
                    value: l - radius,
                    gradient: n,
                    hessian,
                })
            }
        }
    }
}

/// The paraboloid's normalised gap ψ = φ/|∇φ| at `d` (the point relative to the displaced
/// apex), with φ = s + κ r²/2 the axial level set (s = d·a, r the lateral distance,
/// κ = 1/R). ψ has the sign of φ, equals the signed distance to first order near the
/// surface, and its gradient on the surface is the unit normal, so the penalty acts with
/// the same stiffness on the flank as at the apex. (φ itself grows like κ r times the
/// distance on the flank: at the contact edge of a 2.5 µm indentation by a 0.2 µm tip that
/// is a 5× longer gap and a 26× stiffer penalty, and the flank nodes chatter.)
///
/// With m = |∇φ| = √(1 + κ² r²), q = 1/m, L the lateral vector and P = I − a⊗a:
/// ∇φ = a + κL, ∇²φ = κP, ∇q = −κ² q³ L, ∇²q = 3κ⁴q⁵ L⊗L − κ²q³ P, and
/// ∇ψ = q∇φ + φ∇q, ∇²ψ = q∇²φ + ∇φ⊗∇q + ∇q⊗∇φ + φ∇²q.
fn paraboloid_gap(d: &[f64; 3], axis: &[f64; 3], curvature: f64) -> Gap {
    let k = curvature;
    let s = dot(d, axis);
    let lateral: [f64; 3] = std::array::from_fn(|i| d[i] - s * axis[i]);
    let r2 = dot(&lateral, &lateral);
    let phi = s + 0.5 * k * r2;
    let grad_phi: [f64; 3] = std::array::from_fn(|i| axis[i] + k * lateral[i]);
    let q = 1.0 / (1.0 + k * k * r2).sqrt();
    let q3 = q * q * q;
    let grad_q: [f64; 3] = std::array::from_fn(|i| -k * k * q3 * lateral[i]);
    let projector = |i: usize, j: usize| {
        let delta = if i == j { 1.0 } else { 0.0 };
        delta - axis[i] * axis[j]
    };
    let hessian = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let hess_phi = k * projector(i, j);
            let hess_q = 3.0 * k.powi(4) * q3 * q * q * lateral[i] * lateral[j]
                - k * k * q3 * projector(i, j);
            q * hess_phi + grad_phi[i] * grad_q[j] + grad_q[i] * grad_phi[j] + phi * hess_q
        })
    });
    Gap {
        value: phi * q,
        gradient: std::array::from_fn(|i| q * grad_phi[i] + phi * grad_q[i]),
        hessian,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_derivatives(shape: ToolShape, x: [f64; 3], offset: [f64; 3]) {
        let g = shape.gap(&x, &offset).unwrap();
        let h = 1e-6;
        for j in 0..3 {
            let (mut xp, mut xm) = (x, x);
            xp[j] += h;
            xm[j] -= h;
            let (gp, gm) = (
                shape.gap(&xp, &offset).unwrap(),
                shape.gap(&xm, &offset).unwrap(),
            );
            assert!(((gp.value - gm.value) / (2.0 * h) - g.gradient[j]).abs() < 1e-7);
            for i in 0..3 {
                let fd = (gp.gradient[i] - gm.gradient[i]) / (2.0 * h);
                assert!((fd - g.hessian[i][j]).abs() < 1e-6, "{shape:?} H[{i}][{j}]");
            }
        }
    }

    #[test]
    fn tool_gap_gradients_and_hessians_match_finite_differences() {
        let off = [0.1, -0.2, 0.3];
        check_derivatives(
            ToolShape::Plate {
                point: [0.0, 0.0, 1.0],
                normal: [0.0, 0.0, -1.0],
            },
            [0.3, 0.2, 0.5],
            off,
        );
        check_derivatives(
            ToolShape::Sphere {
                center: [0.0, 0.0, 3.0],
                radius: 2.0,
            },
            [0.5, 0.2, 0.7],
            off,
        );
        let axis = [0.0, 0.6, -0.8];
        check_derivatives(
            ToolShape::Paraboloid {
                apex: [0.0, 0.0, 1.0],
                axis,
                tip_radius: 0.2,
            },
            [0.3, -0.1, 0.4],
            off,
        );
        // On the flank, far from the apex (r = 5 R), inside and outside the tip.
        let flank = ToolShape::Paraboloid {
            apex: [0.0; 3],
            axis: [0.0, 0.0, -1.0],
            tip_radius: 0.2,
        };
        check_derivatives(flank, [1.0, 0.1, -2.4], [0.0; 3]);
        check_derivatives(flank, [0.9, -0.3, -2.6], [0.0; 3]);
    }

    #[test]
    fn paraboloid_gap_is_a_first_order_distance_with_a_unit_normal_on_the_surface() {
        let (r_tip, axis) = (0.2, [0.0, 0.0, -1.0]);
        let tip = ToolShape::Paraboloid {
            apex: [0.0; 3],
            axis,
            tip_radius: r_tip,
        };
        for r in [0.0, 0.1, 0.5, 1.0, 2.0] {
            // The surface point at lateral distance r (the tip points down, its body is
            // above the apex), and the unit normal there, out of the tip.
            let on = [r, 0.0, r * r / (2.0 * r_tip)];
            let g = tip.gap(&on, &[0.0; 3]).unwrap();
            assert!(g.value.abs() < 1e-14, "r = {r}: gap {}", g.value);
            let m = (1.0 + (r / r_tip).powi(2)).sqrt();
            let normal = [r / r_tip / m, 0.0, -1.0 / m];
            for i in 0..3 {
                assert!((g.gradient[i] - normal[i]).abs() < 1e-14, "r = {r}: {g:?}");
            }
            // A step h along the normal changes the gap by h to first order.
            let h = 1e-4;
            let off: [f64; 3] = std::array::from_fn(|i| on[i] + h * normal[i]);
            let g_off = tip.gap(&off, &[0.0; 3]).unwrap().value;
            assert!((g_off / h - 1.0).abs() < 1e-2, "r = {r}: {g_off} for {h}");
        }
    }

    #[test]
    fn tool_gap_is_zero_on_the_surface_and_positive_outside() {
        let sphere = ToolShape::Sphere {
            center: [0.0, 0.0, 5.0],
            radius: 2.0,
        };
        assert!(sphere.gap(&[0.0, 0.0, 3.0], &[0.0; 3]).unwrap().value.abs() < 1e-15);
        assert!(sphere.gap(&[0.0, 0.0, 2.5], &[0.0; 3]).unwrap().value > 0.0);
        let tip = ToolShape::Paraboloid {
            apex: [0.0, 0.0, 1.0],
            axis: [0.0, 0.0, -1.0],
            tip_radius: 0.5,
        };
        // A point on the paraboloid: lateral r = 1, axial offset behind the apex r²/(2R) = 1.
        assert!(tip.gap(&[1.0, 0.0, 2.0], &[0.0; 3]).unwrap().value.abs() < 1e-15);
        assert!(tip.gap(&[0.0, 0.0, 0.9], &[0.0; 3]).unwrap().value > 0.0);
        let disk = ToolShape::Disk {
            center: [0.0; 3],
            normal: [1.0, 0.0, 0.0],
            radius: 1.0,
        };
        assert!(disk.gap(&[0.5, 0.0, 2.0], &[0.0; 3]).is_none());
        assert_eq!(disk.gap(&[0.5, 0.5, 0.5], &[0.0; 3]).unwrap().value, 0.5);
        assert!(ToolShape::Sphere {
            center: [0.0; 3],
            radius: 0.0
        }
        .validate()
        .is_err());
    }
}
