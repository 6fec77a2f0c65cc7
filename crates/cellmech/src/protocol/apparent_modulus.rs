//! The apparent Young's modulus of an indentation curve: what an AFM user reports after
//! fitting a Hertz/Sneddon model to the force–indentation curve over a depth range.
//!
//! The model is F(d) = E/(1 − ν²) · g(d − d₀), g the force per unit reduced modulus of the
//! tip ([`Indenter::force_per_reduced_modulus`]: paraboloid 4/3 √R d^{3/2}, sphere
//! Sneddon's exact relation, cone 2/π tanα d²; zero for d ≤ d₀) and d₀ the contact point.
//! The samples used are those whose depth lies in the range [d_min, d_max] (inclusive,
//! measured depths, before any contact-point shift).
//!
//! * For a given contact point the force is linear in E, and least squares gives it in
//!   closed form: E* = Σ fᵢ gᵢ / Σ gᵢ², E = (1 − ν²) E*.
//! * Optionally ([`ContactPoint::Fitted`]) d₀ is fitted too: the residual after the
//!   closed-form E, S(d₀) = Σ (fᵢ − E*(d₀) gᵢ(d₀))², is minimised over a search interval by a
//!   scan of [`CONTACT_POINT_SCAN`] points followed by a golden-section refinement around
//!   the best one (robust to the kinks where a sample enters contact).
//!
//! The quality of the fit is its relative RMS residual √(Σ (fᵢ − F(dᵢ))² / Σ fᵢ²).
//! Units: µm, nN, kPa.

use std::path::Path;

use cellmech_fem::verify::contact::{reduced_modulus, Indenter, IndenterError};
use cellmech_io::{plot_xy, PlotError, PlotSpec, Series, SeriesStyle};
use serde::Serialize;

/// Number of equally spaced trial contact points scanned before the golden-section search.
pub const CONTACT_POINT_SCAN: usize = 101;

/// Fewest samples in the depth range for a fit.
pub const MIN_POINTS: usize = 3;

/// Where the tip first touches the sample.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ContactPoint {
    /// The depths are already indentations from the contact point (d₀ = 0).
    #[default]
    Given,
    /// d₀ is fitted with the modulus, searched in `search_um` = [lo, hi] (µm). Depths may
    /// then be negative (samples before contact).
    Fitted {
        /// Search interval of the contact point (µm), lo < hi.
        search_um: [f64; 2],
    },
}

/// What to fit: the tip model, the sample's Poisson ratio, the depth range and the contact
/// point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FitSettings {
    /// Tip model (paraboloid or sphere with radius, cone with half-angle).
    pub tip: Indenter,
    /// Poisson's ratio assumed for the sample, in (−1, 0.5]; 0.5 (incompressible) by
    /// default, as AFM users commonly assume.
    pub poisson_ratio: f64,
    /// Depths [d_min, d_max] (µm) of the samples used, inclusive.
    pub depth_range_um: [f64; 2],
    /// The contact point: given (default) or fitted.
    pub contact_point: ContactPoint,
}

impl FitSettings {
    /// Settings with the defaults: ν = 0.5, contact point given (d₀ = 0).
    pub fn new(tip: Indenter, depth_range_um: [f64; 2]) -> Self {
        FitSettings {
            tip,
            poisson_ratio: 0.5,
            depth_range_um,
            contact_point: ContactPoint::Given,
        }
    }
}

/// The result of the fit, for `summary.json`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ApparentModulusFit {
    /// The apparent Young's modulus E (kPa).
    pub young_modulus_kpa: f64,
    /// The reduced modulus E* = E/(1 − ν²) (kPa) that the force fixes.
    pub reduced_modulus_kpa: f64,
    /// The contact point d₀ (µm): 0 when given, else the fitted value.
    pub contact_point_um: f64,
    /// Whether d₀ was fitted.
    pub contact_point_fitted: bool,
    /// √(Σ (fᵢ − F(dᵢ))² / Σ fᵢ²) over the samples used.
    pub relative_rms_residual: f64,
    /// Number of samples in the depth range.
    pub points_used: usize,
    /// The settings of the fit (tip, ν, range, contact point).
    pub settings: FitSettings,
}

impl ApparentModulusFit {
    /// The fitted model's force (nN) at measured depth `depth` (µm): E* g(depth − d₀);
    /// NaN for a non-finite depth.
    pub fn model_force(&self, depth: f64) -> f64 {
        self.settings
            .tip
            .force_per_reduced_modulus(depth - self.contact_point_um)
            .map_or(f64::NAN, |g| self.reduced_modulus_kpa * g)
    }
}

/// Why an indentation curve could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// The depth and force samples differ in number.
    #[error("expected as many forces as depths; found {depths} depths and {forces} forces")]
    LengthMismatch {
        /// Number of depths.
        depths: usize,
        /// Number of forces.
        forces: usize,
    },
    /// A sample is NaN or infinite.
    #[error("expected finite samples; {quantity}[{index}] = {found}")]
    NotFinite {
        /// `depth` or `force`.
        quantity: &'static str,
        /// Sample index.
        index: usize,
        /// The value found.
        found: f64,
    },
    /// The depths do not increase strictly (e.g. an unloading branch was included).
    #[error(
        "expected strictly increasing depths (the loading branch only); depth[{index}] = \
         {found} um follows {previous} um"
    )]
    NotIncreasing {
        /// Sample index.
        index: usize,
        /// The depth before it (µm).
        previous: f64,
        /// The depth found (µm).
        found: f64,
    },
    /// A depth is negative while the contact point is given (depths are indentations).
    #[error(
        "expected indentation depths >= 0 with a given contact point (fit it to use \
         samples before contact); depth[{index}] = {found} um"
    )]
    NegativeDepth {
        /// Sample index.
        index: usize,
        /// The depth found (µm).
        found: f64,
    },
    /// The depth range is not an interval of finite depths (≥ 0 with a given contact
    /// point).
    #[error("expected a depth range [d_min, d_max] with {expected}; found [{d_min}, {d_max}] um")]
    BadRange {
        /// What the range must satisfy.
        expected: &'static str,
        /// d_min given (µm).
        d_min: f64,
        /// d_max given (µm).
        d_max: f64,
    },
    /// Too few samples in the depth range.
    #[error(
        "expected at least {MIN_POINTS} samples with depth in [{d_min}, {d_max}] um; found \
         {found}"
    )]
    TooFewPoints {
        /// Samples in range.
        found: usize,
        /// d_min (µm).
        d_min: f64,
        /// d_max (µm).
        d_max: f64,
    },
    /// Every force in the range is zero: no modulus can be fitted.
    #[error("expected a non-zero force in the depth range [{d_min}, {d_max}] um; all are 0")]
    ZeroForce {
        /// d_min (µm).
        d_min: f64,
        /// d_max (µm).
        d_max: f64,
    },
    /// The force in the range does not push on the tip (Σ f g ≤ 0): no positive modulus
    /// fits it.
    #[error(
        "expected a compressive (positive) force in the depth range [{d_min}, {d_max}] um; \
         the best fitting modulus is not positive"
    )]
    NoPositiveModulus {
        /// d_min (µm).
        d_min: f64,
        /// d_max (µm).
        d_max: f64,
    },
    /// The contact-point search interval is not usable.
    #[error(
        "expected a contact-point search interval lo < hi of finite depths with lo below the \
         deepest sample in range ({deepest} um); found [{lo}, {hi}] um"
    )]
    BadContactSearch {
        /// lo (µm).
        lo: f64,
        /// hi (µm).
        hi: f64,
        /// Deepest sample in the depth range (µm).
        deepest: f64,
    },
    /// The tip model or the Poisson ratio is invalid.
    #[error("apparent-modulus fit: {0}")]
    Model(#[from] IndenterError),
}

/// Fits the apparent Young's modulus to the samples (`depth[i]` µm, `force[i]` nN, force
/// positive when the tip pushes) as the module documentation describes.
pub fn fit_apparent_modulus(
    depth: &[f64],
    force: &[f64],
    settings: &FitSettings,
) -> Result<ApparentModulusFit, FitError> {
    settings.tip.validate()?;
    // E* per unit E: validates ν.
    let reduction = reduced_modulus(1.0, settings.poisson_ratio)?;
    let given = settings.contact_point == ContactPoint::Given;
    check_samples(depth, force, given)?;
    let [d_min, d_max] = settings.depth_range_um;
    if !(d_min.is_finite() && d_max.is_finite() && d_min < d_max) {
        return Err(FitError::BadRange {
            expected: "finite d_min < d_max",
            d_min,
            d_max,
        });
    }
    if given && d_min < 0.0 {
        return Err(FitError::BadRange {
            expected: "d_min >= 0 (a given contact point at depth 0)",
            d_min,
            d_max,
        });
    }
    let (d, f): (Vec<f64>, Vec<f64>) = depth
        .iter()
        .zip(force)
        .filter(|(&x, _)| (d_min..=d_max).contains(&x))
        .map(|(&x, &y)| (x, y))
        .unzip();
    if d.len() < MIN_POINTS {
        return Err(FitError::TooFewPoints {
            found: d.len(),
            d_min,
            d_max,
        });
    }
    let f2: f64 = f.iter().map(|y| y * y).sum();
    if f2 == 0.0 {
        return Err(FitError::ZeroForce { d_min, d_max });
    }
    let tip = settings.tip;
    // Least squares in E* for contact point d0: (E*, residual sum of squares).
    // (The residual is summed directly: Σ f² − (Σ f g)²/Σ g² would cancel near a good fit.)
    let solve = |d0: f64| -> Result<(f64, f64), IndenterError> {
        let g = d
            .iter()
            .map(|&x| tip.force_per_reduced_modulus(x - d0))
            .collect::<Result<Vec<f64>, _>>()?;
        let fg: f64 = f.iter().zip(&g).map(|(y, g)| y * g).sum();
        let gg: f64 = g.iter().map(|g| g * g).sum();
        let e_star = if fg > 0.0 && gg > 0.0 { fg / gg } else { 0.0 };
        let residual = f
            .iter()
            .zip(&g)
            .map(|(y, g)| (y - e_star * g).powi(2))
            .sum();
        Ok((e_star, residual))
    };
    let d0 = match settings.contact_point {
        ContactPoint::Given => 0.0,
        ContactPoint::Fitted {
            search_um: [lo, hi],
        } => {
            let deepest = d[d.len() - 1];
            if !(lo.is_finite() && hi.is_finite() && lo < hi && lo < deepest) {
                return Err(FitError::BadContactSearch { lo, hi, deepest });
            }
            // Contact points at or beyond the deepest sample leave no sample in contact.
            let hi = hi.min(deepest);
            minimise(|x| solve(x).map_or(f64::INFINITY, |(_, s)| s), lo, hi)
        }
    };
    let (e_star, residual) = solve(d0)?;
    if e_star <= 0.0 {
        return Err(FitError::NoPositiveModulus { d_min, d_max });
    }
    Ok(ApparentModulusFit {
        young_modulus_kpa: e_star / reduction,
        reduced_modulus_kpa: e_star,
        contact_point_um: d0,
        contact_point_fitted: !given,
        relative_rms_residual: (residual / f2).sqrt(),
        points_used: d.len(),
        settings: *settings,
    })
}

/// Equal lengths, finite values, strictly increasing depths (≥ 0 when `given`).
fn check_samples(depth: &[f64], force: &[f64], given: bool) -> Result<(), FitError> {
    if depth.len() != force.len() {
        return Err(FitError::LengthMismatch {
            depths: depth.len(),
            forces: force.len(),
        });
    }
    for (index, (&x, &y)) in depth.iter().zip(force).enumerate() {
        for (quantity, found) in [("depth", x), ("force", y)] {
            if !found.is_finite() {
                return Err(FitError::NotFinite {
                    quantity,
                    index,
                    found,
                });
            }
        }
        if given && x < 0.0 {
            return Err(FitError::NegativeDepth { index, found: x });
        }
        if index > 0 && x <= depth[index - 1] {
            return Err(FitError::NotIncreasing {
                index,
                previous: depth[index - 1],
                found: x,
            });
        }
    }
    Ok(())
}

/// Minimiser of `s` on [lo, hi]: the best of [`CONTACT_POINT_SCAN`] equally spaced points,
/// refined by golden-section search between its neighbours.
fn minimise(s: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    let n = CONTACT_POINT_SCAN;
    let step = (hi - lo) / (n - 1) as f64;
    let at = |k: usize| if k == n - 1 { hi } else { lo + step * k as f64 };
    let best = (0..n)
        .map(|k| (k, s(at(k))))
        .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a })
        .0;
    let (mut a, mut b) = (at(best.saturating_sub(1)), at((best + 1).min(n - 1)));
    let ratio = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (b - ratio * (b - a), a + ratio * (b - a));
    let (mut s1, mut s2) = (s(x1), s(x2));
    for _ in 0..200 {
        if b - a <= 1e-14 * (hi - lo) {
            break;
        }
        if s1 <= s2 {
            b = x2;
            (x2, s2) = (x1, s1);
            x1 = b - ratio * (b - a);
            s1 = s(x1);
        } else {
            a = x1;
            (x1, s1) = (x2, s2);
            x2 = a + ratio * (b - a);
            s2 = s(x2);
        }
    }
    let candidate = 0.5 * (a + b);
    // Keep the scanned point if the refinement did not improve on it (flat residual).
    if s(candidate) <= s(at(best)) {
        candidate
    } else {
        at(best)
    }
}

/// The force–indentation plot of a fit: the samples (markers) and the fitted model over the
/// depth range (line), with E in the legend.
pub fn fit_plot_spec(
    title: &str,
    depth: &[f64],
    force: &[f64],
    fit: &ApparentModulusFit,
) -> PlotSpec {
    let [d_min, d_max] = fit.settings.depth_range_um;
    let from = d_min.max(fit.contact_point_um);
    let model: Vec<(f64, f64)> = (0..=100)
        .map(|k| {
            let x = from + (d_max - from) * k as f64 / 100.0;
            (x, fit.model_force(x))
        })
        .collect();
    PlotSpec {
        title: title.into(),
        x_label: "indentation (µm)".into(),
        y_label: "force (nN)".into(),
        series: vec![
            Series {
                label: "simulation".into(),
                points: depth.iter().copied().zip(force.iter().copied()).collect(),
                style: SeriesStyle::Markers,
            },
            Series {
                label: format!(
                    "{} fit, E = {:.4} kPa (nu = {})",
                    fit.settings.tip.name(),
                    fit.young_modulus_kpa,
                    fit.settings.poisson_ratio
                ),
                points: model,
                style: SeriesStyle::Line,
            },
        ],
    }
}

/// Writes [`fit_plot_spec`] to `path` (`.png` or `.svg`).
pub fn write_fit_plot(
    path: &Path,
    title: &str,
    depth: &[f64],
    force: &[f64],
    fit: &ApparentModulusFit,
) -> Result<(), PlotError> {
    plot_xy(path, &fit_plot_spec(title, depth, force, fit))
}

#[cfg(test)]
mod tests {
    use super::*;

    const R: f64 = 0.2;

    fn paraboloid() -> Indenter {
        Indenter::Paraboloid { radius: R }
    }

    /// Samples of the exact model with E (kPa), ν, contact point d0, at depths `depths`.
    fn samples(tip: Indenter, e: f64, nu: f64, d0: f64, depths: &[f64]) -> Vec<f64> {
        let e_star = e / (1.0 - nu * nu);
        depths
            .iter()
            .map(|&d| e_star * tip.force_per_reduced_modulus(d - d0).unwrap())
            .collect()
    }

    fn depths(from: f64, to: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| from + (to - from) * k as f64 / (n - 1) as f64)
            .collect()
    }

    #[test]
    fn exact_curves_of_each_tip_give_back_the_modulus() {
        let tips = [
            paraboloid(),
            Indenter::Sphere { radius: R },
            Indenter::Cone {
                half_angle: 35f64.to_radians(),
            },
        ];
        let d = depths(0.0, 0.1, 21);
        for tip in tips {
            let f = samples(tip, 0.5, 0.49, 0.0, &d);
            let mut settings = FitSettings::new(tip, [0.0, 0.1]);
            settings.poisson_ratio = 0.49;
            let fit = fit_apparent_modulus(&d, &f, &settings).unwrap();
            assert!(
                (fit.young_modulus_kpa - 0.5).abs() < 1e-12,
                "{tip:?}: {}",
                fit.young_modulus_kpa
            );
            assert!(fit.relative_rms_residual < 1e-12);
            assert_eq!(fit.points_used, 21);
            // The default ν = 0.5 reads a smaller E for the same E*: E ∝ (1 − ν²).
            let default = fit_apparent_modulus(&d, &f, &FitSettings::new(tip, [0.0, 0.1]));
            let e = default.unwrap().young_modulus_kpa;
            assert!((e - 0.5 * 0.75 / (1.0 - 0.49 * 0.49)).abs() < 1e-12, "{e}");
        }
    }

    #[test]
    fn least_squares_weights_the_range_and_reports_the_residual() {
        // F = E* g (1 + 0.5 d/R): a stiffening curve. Over [0, 0.02] the fit is nearly
        // Hertz; over [0, 0.1] it reads a larger modulus and a larger residual.
        let d = depths(0.0, 0.1, 41);
        let tip = paraboloid();
        let f: Vec<f64> = samples(tip, 1.0, 0.5, 0.0, &d)
            .iter()
            .zip(&d)
            .map(|(f, x)| f * (1.0 + 0.5 * x / R))
            .collect();
        let shallow = fit_apparent_modulus(&d, &f, &FitSettings::new(tip, [0.0, 0.02])).unwrap();
        let deep = fit_apparent_modulus(&d, &f, &FitSettings::new(tip, [0.0, 0.1])).unwrap();
        assert_eq!(shallow.points_used, 9);
        assert!(shallow.young_modulus_kpa > 1.0 && shallow.young_modulus_kpa < 1.05);
        assert!(deep.young_modulus_kpa > shallow.young_modulus_kpa + 0.1);
        assert!(deep.relative_rms_residual > shallow.relative_rms_residual);
        // The closed form: E* = Σ f g / Σ g² over the samples in range, by hand.
        let (mut fg, mut gg) = (0.0, 0.0);
        for (x, y) in d.iter().zip(&f) {
            let g = tip.force_per_reduced_modulus(*x).unwrap();
            fg += y * g;
            gg += g * g;
        }
        assert!((deep.reduced_modulus_kpa - fg / gg).abs() < 1e-12 * fg / gg);
        let r2: f64 = d
            .iter()
            .zip(&f)
            .map(|(x, y)| (y - deep.model_force(*x)).powi(2))
            .sum();
        let f2: f64 = f.iter().map(|y| y * y).sum();
        assert!((deep.relative_rms_residual - (r2 / f2).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn fitted_contact_point_recovers_an_offset_curve() {
        // The tip touches at d0 = 0.013 um; samples start 0.02 um before.
        let tip = paraboloid();
        let d = depths(-0.007, 0.1, 60);
        let f = samples(tip, 0.34, 0.5, 0.013, &d);
        // With d0 = 0 assumed (depths ≥ 0 only), the modulus is off.
        let positive: Vec<usize> = (0..d.len()).filter(|&k| d[k] >= 0.0).collect();
        let dp: Vec<f64> = positive.iter().map(|&k| d[k]).collect();
        let fp: Vec<f64> = positive.iter().map(|&k| f[k]).collect();
        let fixed = fit_apparent_modulus(&dp, &fp, &FitSettings::new(tip, [0.0, 0.1])).unwrap();
        assert!((fixed.young_modulus_kpa / 0.34 - 1.0).abs() > 0.1);
        assert!(fixed.relative_rms_residual > 0.01);
        let mut settings = FitSettings::new(tip, [-0.007, 0.1]);
        settings.contact_point = ContactPoint::Fitted {
            search_um: [-0.05, 0.05],
        };
        let fit = fit_apparent_modulus(&d, &f, &settings).unwrap();
        assert!(fit.contact_point_fitted);
        assert!((fit.contact_point_um - 0.013).abs() < 1e-7, "{fit:?}");
        assert!((fit.young_modulus_kpa / 0.34 - 1.0).abs() < 1e-5, "{fit:?}");
        assert!(fit.relative_rms_residual < 1e-5);
        // With 2 % noise-like wiggle, still within a few percent.
        let wiggly: Vec<f64> = f
            .iter()
            .enumerate()
            .map(|(k, y)| y * (1.0 + 0.02 * (k as f64 * 1.7).sin()))
            .collect();
        let fit = fit_apparent_modulus(&d, &wiggly, &settings).unwrap();
        assert!((fit.young_modulus_kpa / 0.34 - 1.0).abs() < 0.03, "{fit:?}");
        assert!((fit.contact_point_um - 0.013).abs() < 0.002, "{fit:?}");
    }

    #[test]
    fn bad_input_is_rejected_with_what_was_expected_and_found() {
        let tip = paraboloid();
        let settings = FitSettings::new(tip, [0.0, 0.1]);
        let d = depths(0.0, 0.1, 5);
        let f = samples(tip, 1.0, 0.5, 0.0, &d);
        let fit = |d: &[f64], f: &[f64], s: &FitSettings| fit_apparent_modulus(d, f, s);

        let err = fit(&d, &f[..4], &settings).unwrap_err();
        assert_eq!(
            err,
            FitError::LengthMismatch {
                depths: 5,
                forces: 4
            }
        );
        // Too few points in range.
        let err = fit(&d, &f, &FitSettings::new(tip, [0.06, 0.1])).unwrap_err();
        assert!(
            err.to_string()
                .contains("at least 3 samples with depth in [0.06, 0.1] um; found 2"),
            "{err}"
        );
        // Non-monotonic depths.
        let mut back = d.clone();
        back[3] = 0.04;
        let err = fit(&back, &f, &settings).unwrap_err();
        assert!(
            matches!(err, FitError::NotIncreasing { index: 3, .. }),
            "{err}"
        );
        assert!(err
            .to_string()
            .contains("depth[3] = 0.04 um follows 0.05 um"));
        // Negative depth with a given contact point.
        let mut negative = d.clone();
        negative[0] = -0.01;
        let err = fit(&negative, &f, &settings).unwrap_err();
        assert_eq!(
            err,
            FitError::NegativeDepth {
                index: 0,
                found: -0.01
            }
        );
        // Zero force.
        let err = fit(&d, &[0.0; 5], &settings).unwrap_err();
        assert!(matches!(err, FitError::ZeroForce { .. }), "{err}");
        // Pulling (negative) forces.
        let pulling: Vec<f64> = f.iter().map(|y| -y).collect();
        let err = fit(&d, &pulling, &settings).unwrap_err();
        assert!(matches!(err, FitError::NoPositiveModulus { .. }), "{err}");
        // Bad ranges.
        for range in [[0.1, 0.0], [0.0, f64::NAN], [-0.1, 0.1]] {
            let err = fit(&d, &f, &FitSettings::new(tip, range)).unwrap_err();
            assert!(matches!(err, FitError::BadRange { .. }), "{range:?}: {err}");
        }
        // Non-finite sample, bad tip, bad ν, bad contact search.
        let err = fit(&d, &[1.0, f64::NAN, 1.0, 1.0, 1.0], &settings).unwrap_err();
        assert!(err.to_string().contains("force[1] = NaN"), "{err}");
        let err = fit(
            &d,
            &f,
            &FitSettings::new(Indenter::Sphere { radius: 0.0 }, [0.0, 0.1]),
        )
        .unwrap_err();
        assert!(err.to_string().contains("sphere radius"), "{err}");
        let mut nu = settings;
        nu.poisson_ratio = 0.7;
        let err = fit(&d, &f, &nu).unwrap_err();
        assert!(err
            .to_string()
            .contains("Poisson's ratio in (-1, 0.5]; found 0.7"));
        let mut search = settings;
        search.contact_point = ContactPoint::Fitted {
            search_um: [0.2, 0.3],
        };
        let err = fit(&d, &f, &search).unwrap_err();
        assert!(matches!(err, FitError::BadContactSearch { .. }), "{err}");
    }

    #[test]
    fn result_serialises_for_the_summary_and_plots() {
        let tip = paraboloid();
        let d = depths(0.0, 0.1, 6);
        let f = samples(tip, 1.0, 0.5, 0.0, &d);
        let fit = fit_apparent_modulus(&d, &f, &FitSettings::new(tip, [0.0, 0.1])).unwrap();
        let json = serde_json::to_value(fit).unwrap();
        assert!((json["young_modulus_kpa"].as_f64().unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(json["points_used"], 6);
        assert_eq!(json["settings"]["tip"]["shape"], "paraboloid");
        assert_eq!(json["settings"]["tip"]["radius_um"], 0.2);
        assert_eq!(json["settings"]["contact_point"]["kind"], "given");
        let spec = fit_plot_spec("t", &d, &f, &fit);
        assert_eq!(spec.series.len(), 2);
        assert!(spec.series[1].label.contains("E = 1.0000 kPa"));
        let (x, y) = *spec.series[1].points.last().unwrap();
        assert!((x - 0.1).abs() < 1e-15 && (y - f[5]).abs() < 1e-12 * f[5]);
        let dir = std::env::temp_dir().join(format!("cellmech-fit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("fit.svg");
        write_fit_plot(&path, "t", &d, &f, &fit).unwrap();
        assert!(std::fs::metadata(&path).unwrap().len() > 0);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
