//! Axial laws of line elements (trusses): linear elastic, optionally tension-only, with a
//! prestrain and a slack that both move the stress-free length.
//!
//! # Strain measure
//!
//! With `L0` the element's length in the initial (mesh) geometry and `ℓ` its current length,
//! the **stress-free length** is
//!
//! ```text
//! L_free = L0 · (1 + slack) / (1 + prestrain)
//! ```
//!
//! and the axial strain is the engineering strain relative to it, `ε = ℓ / L_free − 1`. The
//! axial force is `N = EA · g(ε)` with `g(ε) = ε` for a law that carries compression and
//! `g(ε) = max(0, ε)` for a tension-only law.
//!
//! This is exactly the specification's wording: "prestrain 24 % means the stress-free length
//! is L0/1.24, so at the initial geometry it carries N = E·A·0.24" (`ℓ = L0` gives
//! `ε = 1.24 − 1 = 0.24`), and "slack 20 % means no force until the length exceeds 1.2·L0"
//! (`L_free = 1.2·L0`, `N = EA·(ℓ/(1.2 L0) − 1)` beyond). A Green–Lagrange or logarithmic
//! strain would not give `N = EA·0.24` at the initial geometry. `A` is the undeformed section
//! (no lateral contraction), so the axial stress is the nominal stress `σ = N / A`.
//!
//! # Energy
//!
//! `W(ℓ) = EA · L_free · φ(ε)` with `φ' = g`, so `dW/dℓ = EA·g(ε) = N` exactly and the element
//! built on it is energy-consistent: on the active branch `W = EA·L_free·ε²/2`.
//!
//! # The tension/compression kink
//!
//! For a tension-only law `N(ℓ)` is continuous (W is C¹) but `dN/dℓ` jumps from `EA/L_free`
//! to 0 at `ε = 0`. The default (`transition_band = 0`) keeps the exact law and uses the
//! tangent of the branch the element is on; exactly at `ε = 0` the loaded (tension) branch is
//! used, so an unprestrained tension-only element at its initial length stabilises the first
//! tangent. The residual is piecewise linear in `ε`, i.e. semismooth, and Newton with the
//! solver's line search converges once the active set settles (see `docs/truss.md` for the
//! measured iteration counts). A positive `transition_band = δ` replaces the kink by a C¹
//! force (C² energy) over `|ε| < δ/2`:
//!
//! ```text
//! g(ε) = (ε + δ/2)² / (2δ),   φ(ε) = (ε + δ/2)³ / (6δ)          for |ε| < δ/2
//! g(ε) = ε,                   φ(ε) = ε²/2 + δ²/24               for ε ≥ δ/2
//! ```
//!
//! which changes the force only inside the band, by at most `EA·δ/8` (at `ε = 0`); it never
//! produces compression.

/// A parameter of an [`AxialLaw`] is outside its valid range.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum AxialLawError {
    /// Young's modulus must be a finite number > 0.
    #[error("Young's modulus must be > 0 kPa, found {found}")]
    NonPositiveModulus {
        /// The value given (kPa).
        found: f64,
    },
    /// The section area must be a finite number > 0.
    #[error("section area must be > 0 µm², found {found}")]
    NonPositiveArea {
        /// The value given (µm²).
        found: f64,
    },
    /// A prestrain of −100 % or less has no positive stress-free length.
    #[error("prestrain must be > -1 (-100 %), found {found}")]
    PrestrainNotAboveMinusOne {
        /// The value given (0.24 = 24 %).
        found: f64,
    },
    /// Slack must be a finite number ≥ 0.
    #[error("slack must be >= 0, found {found}")]
    NegativeSlack {
        /// The value given (0.2 = 20 %).
        found: f64,
    },
    /// A slack (wavy) filament cannot carry compression: declare it tension-only.
    #[error("slack {slack} needs a tension-only law (a wavy filament carries no compression)")]
    SlackRequiresTensionOnly {
        /// The slack given.
        slack: f64,
    },
    /// The transition band must be a finite number in [0, 0.1).
    #[error("transition band must be in [0, 0.1), found {found}")]
    InvalidTransitionBand {
        /// The value given (strain).
        found: f64,
    },
}

/// Linear elastic axial law of a line element: `N = EA·g(ε)`, `ε = ℓ/L_free − 1`,
/// `L_free = L0·(1 + slack)/(1 + prestrain)` (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AxialLaw {
    /// Young's modulus E (kPa = nN/µm²).
    pub youngs_modulus: f64,
    /// Section area A (µm²).
    pub area: f64,
    /// Prestrain p: the stress-free length is `L0/(1 + p)` (0.24 = 24 %). Must be > −1.
    pub prestrain: f64,
    /// Slack s: the stress-free length is `(1 + s)·L0` (0.2 = 20 %). Must be ≥ 0; a positive
    /// slack requires `tension_only`.
    pub slack: f64,
    /// When true the law carries no compression: `N = EA·max(0, ε)`.
    pub tension_only: bool,
    /// Strain width δ of the C¹ force blend at the tension-only kink (0 = exact kink).
    pub transition_band: f64,
}

/// Everything an axial law gives at one length.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AxialResponse {
    /// Stored energy W (nN·µm), with `dW/dℓ = force`.
    pub energy: f64,
    /// Axial force N (nN), positive in tension.
    pub force: f64,
    /// `dN/dℓ` (nN/µm).
    pub stiffness: f64,
    /// Strain relative to the stress-free length, `ε = ℓ/L_free − 1`.
    pub strain: f64,
    /// Nominal axial stress `σ = N/A` (kPa).
    pub stress: f64,
}

impl AxialLaw {
    /// A law carrying tension and compression, no prestrain, no slack.
    pub fn linear(youngs_modulus: f64, area: f64) -> Self {
        AxialLaw {
            youngs_modulus,
            area,
            prestrain: 0.0,
            slack: 0.0,
            tension_only: false,
            transition_band: 0.0,
        }
    }

    /// A tension-only law, no prestrain, no slack, exact kink.
    pub fn tension_only(youngs_modulus: f64, area: f64) -> Self {
        AxialLaw {
            tension_only: true,
            ..Self::linear(youngs_modulus, area)
        }
    }

    /// Area of a solid circular section of diameter `d` (µm): `π d²/4`.
    pub fn solid_circle_area(diameter: f64) -> f64 {
        std::f64::consts::PI * diameter * diameter / 4.0
    }

    /// Area of a hollow circular section: `π (d_o² − d_i²)/4`.
    pub fn hollow_circle_area(outer_diameter: f64, inner_diameter: f64) -> f64 {
        std::f64::consts::PI * (outer_diameter.powi(2) - inner_diameter.powi(2)) / 4.0
    }

    /// The same law with prestrain `p`.
    pub fn with_prestrain(self, prestrain: f64) -> Self {
        AxialLaw { prestrain, ..self }
    }

    /// The same law with slack `s`.
    pub fn with_slack(self, slack: f64) -> Self {
        AxialLaw { slack, ..self }
    }

    /// The same law with a C¹ transition band δ at the kink.
    pub fn with_transition_band(self, transition_band: f64) -> Self {
        AxialLaw {
            transition_band,
            ..self
        }
    }

    /// Checks every parameter range; returns the first violation.
    pub fn validate(&self) -> Result<(), AxialLawError> {
        let finite_positive = |x: f64| x.is_finite() && x > 0.0;
        if !finite_positive(self.youngs_modulus) {
            return Err(AxialLawError::NonPositiveModulus {
                found: self.youngs_modulus,
            });
        }
        if !finite_positive(self.area) {
            return Err(AxialLawError::NonPositiveArea { found: self.area });
        }
        if !(self.prestrain.is_finite() && self.prestrain > -1.0) {
            return Err(AxialLawError::PrestrainNotAboveMinusOne {
                found: self.prestrain,
            });
        }
        if !(self.slack.is_finite() && self.slack >= 0.0) {
            return Err(AxialLawError::NegativeSlack { found: self.slack });
        }
        if self.slack > 0.0 && !self.tension_only {
            return Err(AxialLawError::SlackRequiresTensionOnly { slack: self.slack });
        }
        if !(self.transition_band >= 0.0 && self.transition_band < 0.1) {
            return Err(AxialLawError::InvalidTransitionBand {
                found: self.transition_band,
            });
        }
        Ok(())
    }

    /// Axial stiffness EA (nN).
    pub fn axial_stiffness(&self) -> f64 {
        self.youngs_modulus * self.area
    }

    /// Stress-free length `L_free = L0·(1 + slack)/(1 + prestrain)` (µm).
    pub fn stress_free_length(&self, reference_length: f64) -> f64 {
        reference_length * (1.0 + self.slack) / (1.0 + self.prestrain)
    }

    /// Strain relative to the stress-free length, `ε = ℓ/L_free − 1`.
    pub fn strain(&self, length: f64, reference_length: f64) -> f64 {
        length / self.stress_free_length(reference_length) - 1.0
    }

    /// Axial force N (nN) and `dN/dℓ` (nN/µm) at current length `ℓ` for an element of
    /// initial length `L0 > 0`.
    pub fn force_and_stiffness(&self, length: f64, reference_length: f64) -> (f64, f64) {
        let r = self.evaluate(length, reference_length);
        (r.force, r.stiffness)
    }

    /// Stored energy `W(ℓ) = EA·L_free·φ(ε)` (nN·µm); `dW/dℓ = N`.
    pub fn energy(&self, length: f64, reference_length: f64) -> f64 {
        self.evaluate(length, reference_length).energy
    }

    /// Energy, force, stiffness, strain and stress at current length `ℓ` for an element of
    /// initial length `L0 > 0` (the caller guarantees `L0 > 0`; elements check it).
    pub fn evaluate(&self, length: f64, reference_length: f64) -> AxialResponse {
        let l_free = self.stress_free_length(reference_length);
        let strain = length / l_free - 1.0;
        let (g, dg, phi) = self.branch(strain);
        let ea = self.axial_stiffness();
        AxialResponse {
            energy: ea * l_free * phi,
            force: ea * g,
            stiffness: ea * dg / l_free,
            strain,
            stress: self.youngs_modulus * g,
        }
    }

    /// `(g(ε), g'(ε), φ(ε))` of the module documentation.
    fn branch(&self, e: f64) -> (f64, f64, f64) {
        if !self.tension_only {
            return (e, 1.0, 0.5 * e * e);
        }
        let d = self.transition_band;
        if d == 0.0 {
            // Exact kink; at ε = 0 the loaded branch's tangent.
            return if e > 0.0 {
                (e, 1.0, 0.5 * e * e)
            } else if e == 0.0 {
                (0.0, 1.0, 0.0)
            } else {
                (0.0, 0.0, 0.0)
            };
        }
        let h = 0.5 * d;
        if e <= -h {
            (0.0, 0.0, 0.0)
        } else if e < h {
            let s = e + h;
            (s * s / (2.0 * d), s / d, s * s * s / (6.0 * d))
        } else {
            (e, 1.0, 0.5 * e * e + d * d / 24.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn af() -> AxialLaw {
        // Actin filament of the suspended cell: E = 2.6 GPa, d = 7 nm, prestrain 24 %.
        AxialLaw::tension_only(2.6e6, AxialLaw::solid_circle_area(0.007)).with_prestrain(0.24)
    }

    fn fd_check(law: &AxialLaw, l0: f64, l: f64) {
        let h = 1e-6 * l0;
        let r = law.evaluate(l, l0);
        let (wp, wm) = (law.energy(l + h, l0), law.energy(l - h, l0));
        let (np, _) = law.force_and_stiffness(l + h, l0);
        let (nm, _) = law.force_and_stiffness(l - h, l0);
        let scale = law.axial_stiffness();
        assert!(
            ((wp - wm) / (2.0 * h) - r.force).abs() < 1e-7 * scale,
            "dW/dl {} vs N {} at l = {l}",
            (wp - wm) / (2.0 * h),
            r.force
        );
        assert!(
            ((np - nm) / (2.0 * h) - r.stiffness).abs() < 1e-6 * scale / l0,
            "dN/dl {} vs k {} at l = {l}",
            (np - nm) / (2.0 * h),
            r.stiffness
        );
    }

    #[test]
    fn axial_law_prestrain_gives_ea_times_prestrain_at_initial_length() {
        let law = af();
        let ea = law.axial_stiffness();
        assert!((ea - 100.06).abs() < 0.01, "EA(AF) = {ea} nN (spec: 100)");
        let r = law.evaluate(16.0, 16.0);
        assert!((r.force - ea * 0.24).abs() <= 1e-12 * ea, "N = {}", r.force);
        assert!((r.strain - 0.24).abs() < 1e-15);
        assert!((r.stress - 2.6e6 * 0.24).abs() < 1e-12 * 2.6e6);
        assert!((law.stress_free_length(16.0) - 16.0 / 1.24).abs() < 1e-14);
        // Energy on the active branch: EA·L_free·ε²/2.
        assert!((r.energy - ea * (16.0 / 1.24) * 0.24 * 0.24 / 2.0).abs() < 1e-12 * r.energy);
    }

    #[test]
    fn axial_law_slack_carries_nothing_until_twenty_percent_strain() {
        // Intermediate filament: 7.6 MPa, d = 10 nm, slack 20 %.
        let law = AxialLaw::tension_only(7.6e3, AxialLaw::solid_circle_area(0.010)).with_slack(0.2);
        let ea = law.axial_stiffness();
        assert!((ea - 0.597).abs() < 1e-3, "EA(IF) = {ea}");
        let l0 = 5.0;
        for ratio in [0.5, 0.9, 1.0, 1.1, 1.19, 1.1999999] {
            let (n, k) = law.force_and_stiffness(ratio * l0, l0);
            assert_eq!((n, k), (0.0, 0.0), "ratio {ratio}");
            assert_eq!(law.energy(ratio * l0, l0), 0.0);
        }
        for ratio in [1.2000001, 1.3, 1.5, 2.0] {
            let (n, k) = law.force_and_stiffness(ratio * l0, l0);
            let expected = ea * (ratio / 1.2 - 1.0);
            assert!(
                (n - expected).abs() < 1e-14 * ea,
                "ratio {ratio}: {n} vs {expected}"
            );
            assert!((k - ea / (1.2 * l0)).abs() < 1e-14 * ea);
        }
    }

    #[test]
    fn axial_law_tension_only_is_exactly_zero_in_compression() {
        let law = AxialLaw::tension_only(1.0e3, 0.1);
        for l in [0.1, 0.5, 0.99999, 1.0 - 1e-12] {
            let r = law.evaluate(l, 1.0);
            assert_eq!((r.force, r.stiffness, r.energy), (0.0, 0.0, 0.0), "l = {l}");
        }
        // At the switch the loaded branch's tangent, zero force.
        assert_eq!(law.force_and_stiffness(1.0, 1.0), (0.0, 100.0));
        // The linear law carries compression with the same stiffness.
        let lin = AxialLaw::linear(1.0e3, 0.1);
        let (n, k) = lin.force_and_stiffness(0.5, 1.0);
        assert!((n + 50.0).abs() < 1e-12 && (k - 100.0).abs() < 1e-12);
    }

    #[test]
    fn axial_law_force_is_energy_derivative_on_every_branch() {
        let laws = [
            af(),
            AxialLaw::linear(1.2e6, AxialLaw::hollow_circle_area(0.025, 0.017)),
            AxialLaw::tension_only(7.6e3, 7.85e-5).with_slack(0.2),
            AxialLaw::tension_only(340.0, 0.049).with_prestrain(0.24),
            af().with_transition_band(1e-3),
            AxialLaw::tension_only(100.0, 1.0).with_transition_band(1e-2),
        ];
        for law in &laws {
            let l0 = 3.0;
            let taut = law.stress_free_length(l0);
            // Compression, near the switch on both sides, inside a band, tension.
            for f in [
                0.5, 0.9, 0.996, 0.999, 0.9999, 1.0001, 1.001, 1.004, 1.1, 1.6,
            ] {
                fd_check(law, l0, f * taut);
            }
        }
    }

    #[test]
    fn axial_law_transition_band_changes_force_by_at_most_ea_delta_over_8() {
        let d = 1e-6;
        let exact = af();
        let smooth = af().with_transition_band(d);
        let ea = exact.axial_stiffness();
        let l0 = 2.0;
        let lf = exact.stress_free_length(l0);
        let mut worst: f64 = 0.0;
        for i in 0..=2000 {
            let e = -2e-6 + 4e-6 * i as f64 / 2000.0;
            let l = lf * (1.0 + e);
            let (n0, _) = exact.force_and_stiffness(l, l0);
            let (n1, k1) = smooth.force_and_stiffness(l, l0);
            assert!(n1 >= 0.0 && k1 >= 0.0);
            worst = worst.max((n1 - n0).abs());
            if e.abs() > 0.5 * d * (1.0 + 1e-6) {
                assert!((n1 - n0).abs() < 1e-12 * ea, "outside the band at e = {e}");
            }
        }
        assert!(worst <= ea * d / 8.0 * (1.0 + 1e-6), "worst {worst}");
        assert!(
            worst > 0.9 * ea * d / 8.0,
            "the bound is attained at e = 0: {worst}"
        );
        // The band makes the tangent continuous: no jump across the switch.
        let (_, km) = smooth.force_and_stiffness(lf * (1.0 - 1e-9), l0);
        let (_, kp) = smooth.force_and_stiffness(lf * (1.0 + 1e-9), l0);
        assert!((kp - km).abs() < 1e-2 * ea / lf, "{km} {kp}");
    }

    #[test]
    fn axial_law_rejects_out_of_range_parameters() {
        use AxialLawError::*;
        let ok = AxialLaw::tension_only(1.0, 1.0);
        assert_eq!(ok.validate(), Ok(()));
        let cases = [
            (
                AxialLaw {
                    youngs_modulus: 0.0,
                    ..ok
                },
                NonPositiveModulus { found: 0.0 },
            ),
            (
                AxialLaw { area: -1.0, ..ok },
                NonPositiveArea { found: -1.0 },
            ),
            (
                ok.with_prestrain(-1.0),
                PrestrainNotAboveMinusOne { found: -1.0 },
            ),
            (ok.with_slack(-0.1), NegativeSlack { found: -0.1 }),
            (
                AxialLaw::linear(1.0, 1.0).with_slack(0.2),
                SlackRequiresTensionOnly { slack: 0.2 },
            ),
            (
                ok.with_transition_band(0.5),
                InvalidTransitionBand { found: 0.5 },
            ),
        ];
        for (law, expected) in cases {
            assert_eq!(law.validate(), Err(expected));
        }
        assert!(matches!(
            AxialLaw {
                youngs_modulus: f64::NAN,
                ..ok
            }
            .validate(),
            Err(NonPositiveModulus { .. })
        ));
        let msg = ok.with_prestrain(-1.5).validate().unwrap_err().to_string();
        assert!(msg.contains("> -1") && msg.contains("-1.5"), "{msg}");
    }
}
