//! Closed-form references of frictionless indentation of a linear elastic half-space by a
//! rigid axisymmetric indenter (Hertz 1882; Sneddon 1965, Int. J. Eng. Sci. 3:47), in terms
//! of the reduced modulus E* = E/(1 − ν²) and the depth d of the tip below the undeformed
//! surface (the indenter's travel from first contact):
//!
//! ```text
//! paraboloid, tip radius R:  a = sqrt(R d),          F = 4/3 E* sqrt(R) d^{3/2}
//! sphere, radius R (exact):  d = a/2 ln((R+a)/(R−a)), F = E*/2 [(a²+R²) ln((R+a)/(R−a)) − 2aR]
//! cone, half-angle α:        a = 2 d tanα / π,       F = 2/π E* tanα d²
//! ```
//!
//! With t = a/R the sphere relations read d/R = t artanh t and
//! F = E* R² [(1 + t²) artanh t − t] = E* R² Σ_{k≥1} 4k/(4k² − 1) t^{2k+1}; for small d/R
//! the sphere force is the paraboloid's times (1 − d/(10R) + O(d²/R²)), and a → sqrt(R d).
//! The force is linear in E*: F = E* g(d), with g the [`Indenter::force_per_reduced_modulus`]
//! that a least-squares fit of the modulus uses. Negative depths (the tip above the surface)
//! give no contact: a = 0, F = 0.
//!
//! Units: µm, kPa, nN (kPa·µm² = nN); angles in radians. Besides the tests, the
//! apparent-modulus fit of `cellmech::protocol::apparent_modulus` uses these formulas, so
//! the fit and its verification share one definition.

use std::f64::consts::FRAC_PI_2;

/// A rigid axisymmetric indenter of a half-space.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(tag = "shape", rename_all = "kebab-case")]
pub enum Indenter {
    /// Paraboloid of revolution with tip radius of curvature `radius` (Hertz).
    Paraboloid {
        /// Tip radius of curvature R (µm).
        #[serde(rename = "radius_um")]
        radius: f64,
    },
    /// Sphere of radius `radius` (Sneddon's exact relation, valid while a < R).
    Sphere {
        /// Radius R (µm).
        #[serde(rename = "radius_um")]
        radius: f64,
    },
    /// Cone (sharp pyramid approximated as a cone) of half-angle `half_angle`.
    Cone {
        /// Half-angle α between the axis and the flank, in (0, π/2) (radians).
        #[serde(rename = "half_angle_rad")]
        half_angle: f64,
    },
}

/// Invalid input of a contact reference.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IndenterError {
    /// A radius is not a positive finite number.
    #[error("expected the {shape} radius to be a positive finite number (um); found {found}")]
    Radius {
        /// `paraboloid` or `sphere`.
        shape: &'static str,
        /// The value given.
        found: f64,
    },
    /// The cone half-angle is outside (0, π/2).
    #[error("expected the cone half-angle in (0, pi/2) radians; found {found}")]
    HalfAngle {
        /// The value given (radians).
        found: f64,
    },
    /// A depth is not finite.
    #[error("expected a finite indentation depth (um); found {found}")]
    Depth {
        /// The value given.
        found: f64,
    },
    /// The sphere's depth is so large (d/R ≳ 18) that its contact radius equals R to
    /// machine precision: Sneddon's relation no longer resolves it.
    #[error(
        "sphere of radius {radius} um at depth {depth} um: the contact radius is R to machine \
         precision (Sneddon's relation needs a < R; expected d/R below about 18)"
    )]
    SphereTooDeep {
        /// Sphere radius (µm).
        radius: f64,
        /// The depth given (µm).
        depth: f64,
    },
    /// Young's modulus or Poisson's ratio out of range.
    #[error("expected {what}; found {found}")]
    Elastic {
        /// What was expected.
        what: &'static str,
        /// The value given.
        found: f64,
    },
}

/// The reduced (plane-strain) modulus E* = E/(1 − ν²) of a half-space indented by a rigid
/// tip, from Young's modulus E > 0 (kPa) and Poisson's ratio ν in (−1, 0.5].
pub fn reduced_modulus(young: f64, poisson: f64) -> Result<f64, IndenterError> {
    if !(young.is_finite() && young > 0.0) {
        return Err(IndenterError::Elastic {
            what: "a Young's modulus > 0 (kPa)",
            found: young,
        });
    }
    if !(poisson > -1.0 && poisson <= 0.5) {
        return Err(IndenterError::Elastic {
            what: "a Poisson's ratio in (-1, 0.5]",
            found: poisson,
        });
    }
    Ok(young / (1.0 - poisson * poisson))
}

impl Indenter {
    /// Checks the geometry: positive finite radius, cone half-angle in (0, π/2).
    pub fn validate(&self) -> Result<(), IndenterError> {
        match *self {
            Indenter::Paraboloid { radius } | Indenter::Sphere { radius } => {
                if radius.is_finite() && radius > 0.0 {
                    Ok(())
                } else {
                    Err(IndenterError::Radius {
                        shape: self.name(),
                        found: radius,
                    })
                }
            }
            Indenter::Cone { half_angle } => {
                if half_angle > 0.0 && half_angle < FRAC_PI_2 {
                    Ok(())
                } else {
                    Err(IndenterError::HalfAngle { found: half_angle })
                }
            }
        }
    }

    /// `paraboloid`, `sphere` or `cone`.
    pub fn name(&self) -> &'static str {
        match self {
            Indenter::Paraboloid { .. } => "paraboloid",
            Indenter::Sphere { .. } => "sphere",
            Indenter::Cone { .. } => "cone",
        }
    }

    /// The validated geometry and depth; `None` for a depth ≤ 0 (no contact).
    fn contact_depth(&self, depth: f64) -> Result<Option<f64>, IndenterError> {
        self.validate()?;
        if !depth.is_finite() {
            return Err(IndenterError::Depth { found: depth });
        }
        Ok((depth > 0.0).then_some(depth))
    }

    /// Radius of the contact circle at depth `depth` (µm); 0 for depth ≤ 0.
    pub fn contact_radius(&self, depth: f64) -> Result<f64, IndenterError> {
        let Some(d) = self.contact_depth(depth)? else {
            return Ok(0.0);
        };
        Ok(match *self {
            Indenter::Paraboloid { radius } => (radius * d).sqrt(),
            Indenter::Sphere { radius } => radius * sphere_contact_ratio(radius, d)?,
            Indenter::Cone { half_angle } => 2.0 * d * half_angle.tan() / std::f64::consts::PI,
        })
    }

    /// g(d) = F/E* (µm²): the force at depth `depth` per unit reduced modulus; 0 for depth
    /// ≤ 0. The force on a half-space of Young's modulus E and Poisson's ratio ν is
    /// E/(1 − ν²) · g(d).
    pub fn force_per_reduced_modulus(&self, depth: f64) -> Result<f64, IndenterError> {
        let Some(d) = self.contact_depth(depth)? else {
            return Ok(0.0);
        };
        Ok(match *self {
            Indenter::Paraboloid { radius } => 4.0 / 3.0 * radius.sqrt() * d.powf(1.5),
            Indenter::Sphere { radius } => {
                let t = sphere_contact_ratio(radius, d)?;
                radius * radius * sphere_force_factor(t)
            }
            Indenter::Cone { half_angle } => 2.0 / std::f64::consts::PI * half_angle.tan() * d * d,
        })
    }

    /// Force (nN) at depth `depth` (µm) on a half-space of reduced modulus
    /// `reduced_modulus` (kPa, see [`reduced_modulus`]).
    pub fn force(&self, reduced_modulus: f64, depth: f64) -> Result<f64, IndenterError> {
        if !(reduced_modulus.is_finite() && reduced_modulus > 0.0) {
            return Err(IndenterError::Elastic {
                what: "a reduced modulus > 0 (kPa)",
                found: reduced_modulus,
            });
        }
        Ok(reduced_modulus * self.force_per_reduced_modulus(depth)?)
    }
}

/// t = a/R of a sphere at depth d > 0: the root of t artanh t = d/R in (0, 1), by bisection
/// to machine precision (the left side increases from 0 to ∞ on [0, 1)).
fn sphere_contact_ratio(radius: f64, depth: f64) -> Result<f64, IndenterError> {
    let target = depth / radius;
    let depth_ratio = |t: f64| t * t.atanh();
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    // Start from the paraboloid's sqrt(d/R) when it lies below the root's bound.
    let guess = target.sqrt();
    if guess < 1.0 && depth_ratio(guess) < target {
        lo = guess;
    }
    for _ in 0..2000 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if depth_ratio(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    if hi >= 1.0 {
        // The upper bracket never moved: the root is within rounding of 1.
        return Err(IndenterError::SphereTooDeep { radius, depth });
    }
    Ok(0.5 * (lo + hi))
}

/// (1 + t²) artanh t − t, by its series Σ_{k≥1} 4k/(4k² − 1) t^{2k+1} for t < 0.5 (the
/// closed form cancels there) and directly above.
fn sphere_force_factor(t: f64) -> f64 {
    if t >= 0.5 {
        return (1.0 + t * t) * t.atanh() - t;
    }
    let t2 = t * t;
    let mut power = t * t2;
    let mut sum = 0.0;
    for k in 1..200 {
        let k = k as f64;
        let term = 4.0 * k / (4.0 * k * k - 1.0) * power;
        sum += term;
        if term <= 1e-17 * sum {
            break;
        }
        power *= t2;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 0.2;

    #[test]
    fn paraboloid_and_cone_match_hand_computed_values() {
        // E = 1 kPa, ν = 0.5: E* = 4/3 kPa. R = 0.2 um, d = 0.02 um:
        // F = 4/3 · 4/3 · sqrt(0.2) · 0.02^1.5 = 16/9 · 0.4472136 · 0.0028284271 nN.
        let e_star = reduced_modulus(1.0, 0.5).unwrap();
        assert!((e_star - 4.0 / 3.0).abs() < 1e-15);
        let tip = Indenter::Paraboloid { radius: R };
        let f = tip.force(e_star, 0.02).unwrap();
        assert!((f - 16.0 / 9.0 * 0.447_213_595_5 * 0.002_828_427_125).abs() < 1e-12);
        // a = sqrt(R d) = sqrt(0.004) um.
        assert!((tip.contact_radius(0.02).unwrap() - 0.063_245_553_203).abs() < 1e-12);
        // Cone of half-angle 45°: F = 2/π E* d², a = 2d/π.
        let cone = Indenter::Cone {
            half_angle: std::f64::consts::FRAC_PI_4,
        };
        let f = cone.force(3.0, 0.5).unwrap();
        assert!((f - 2.0 / std::f64::consts::PI * 3.0 * 0.25).abs() < 1e-14);
        assert!((cone.contact_radius(0.5).unwrap() - 1.0 / std::f64::consts::PI).abs() < 1e-15);
        // F ∝ d^{3/2} and d²: doubling the depth multiplies by 2^{3/2} and 4.
        let ratio = tip.force(1.0, 0.04).unwrap() / tip.force(1.0, 0.02).unwrap();
        assert!((ratio - 2f64.powf(1.5)).abs() < 1e-12);
        let ratio = cone.force(1.0, 0.04).unwrap() / cone.force(1.0, 0.02).unwrap();
        assert!((ratio - 4.0).abs() < 1e-12);
    }

    #[test]
    fn sphere_satisfies_sneddon_and_tends_to_the_paraboloid() {
        let sphere = Indenter::Sphere { radius: R };
        let paraboloid = Indenter::Paraboloid { radius: R };
        for &ratio in &[1e-8, 1e-4, 0.01, 0.1, 0.5, 2.0] {
            let d = ratio * R;
            // The contact radius satisfies d = a/2 ln((R+a)/(R−a)).
            let a = sphere.contact_radius(d).unwrap();
            let depth = a / 2.0 * ((R + a) / (R - a)).ln();
            assert!(
                (depth - d).abs() < 1e-12 * d,
                "d/R = {ratio}: {depth} vs {d}"
            );
            // The force is Sneddon's closed form (where it does not cancel).
            let f = sphere.force(1.0, d).unwrap();
            if ratio >= 0.01 {
                let closed = 0.5 * ((a * a + R * R) * ((R + a) / (R - a)).ln() - 2.0 * a * R);
                assert!((f - closed).abs() < 1e-9 * closed, "d/R = {ratio}");
            }
            // Small depth: F_sphere/F_paraboloid = 1 − d/(10R) + O((d/R)²); a → sqrt(R d).
            if ratio <= 0.1 {
                let r = f / paraboloid.force(1.0, d).unwrap();
                let expected = 1.0 - ratio / 10.0;
                assert!(
                    (r - expected).abs() < 0.05 * ratio * ratio + 1e-12,
                    "d/R = {ratio}: ratio {r} vs {expected}"
                );
                let ar = a / paraboloid.contact_radius(d).unwrap();
                assert!((ar - 1.0 + ratio / 6.0).abs() < ratio * ratio + 1e-12);
            }
        }
        // d/R = 0.5: t artanh t = 0.5 at t = 0.6392… (hand check: 0.6392 × artanh 0.6392 ≈
        // 0.6392 × 0.7570 = 0.4839 < 0.5 < 0.65 × 0.7753 = 0.5039).
        let t = sphere.contact_radius(0.5 * R).unwrap() / R;
        assert!(t > 0.6392 && t < 0.65, "a/R = {t}");
        // A sphere is softer than the paraboloid of the same tip radius at depth.
        assert!(sphere.force(1.0, R).unwrap() < paraboloid.force(1.0, R).unwrap());
    }

    #[test]
    fn no_contact_above_the_surface_and_clear_errors_on_bad_input() {
        let tip = Indenter::Paraboloid { radius: R };
        assert_eq!(tip.force(1.0, -0.1).unwrap(), 0.0);
        assert_eq!(tip.contact_radius(0.0).unwrap(), 0.0);
        let err = Indenter::Sphere { radius: -1.0 }
            .force(1.0, 0.1)
            .unwrap_err();
        assert!(err.to_string().contains("sphere radius"), "{err}");
        assert!(err.to_string().contains("-1"), "{err}");
        let err = Indenter::Cone { half_angle: 2.0 }
            .contact_radius(0.1)
            .unwrap_err();
        assert_eq!(err, IndenterError::HalfAngle { found: 2.0 });
        assert!(matches!(
            tip.force(1.0, f64::NAN),
            Err(IndenterError::Depth { .. })
        ));
        assert!(tip.force(0.0, 0.1).is_err());
        assert!(reduced_modulus(1.0, 0.6).is_err());
        assert!(reduced_modulus(-1.0, 0.3).is_err());
        let deep = Indenter::Sphere { radius: 1.0 }.force(1.0, 100.0);
        assert!(
            matches!(deep, Err(IndenterError::SphereTooDeep { .. })),
            "{deep:?}"
        );
    }

    #[test]
    fn indenter_serialises_with_units_in_the_keys() {
        let json = serde_json::to_string(&Indenter::Sphere { radius: 2.5 }).unwrap();
        assert_eq!(json, r#"{"shape":"sphere","radius_um":2.5}"#);
    }
}
