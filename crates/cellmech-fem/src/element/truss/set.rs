//! Two-node truss under large displacement, carrying an [`AxialLaw`] (linear, tension-only,
//! prestrained, slack: all laws, one element).
//!
//! Kinematics: with reference nodes `X_a`, `X_b`, displacements `u_a`, `u_b`,
//! `d = X_b + u_b − X_a − u_a`, current length `ℓ = |d|`, unit vector `n = d/ℓ`, initial
//! length `L0 = |X_b − X_a|`. The energy is the law's `W(ℓ; L0)`, so with `N = dW/dℓ` and
//! `k = dN/dℓ`:
//!
//! ```text
//! residual = ∂W/∂(u_a, u_b) = N · (−n, n)
//! tangent  = [ K  −K ]      K = k · n⊗n + (N/ℓ) · (I − n⊗n)
//!            [ −K  K ]
//! ```
//!
//! `K` is the material part `k n⊗n` plus the geometric (stress) part `(N/ℓ)(I − n⊗n)`,
//! which gives a prestressed cable its lateral stiffness. A slack or compressed tension-only
//! element contributes exactly nothing.

use super::KernelError;
use crate::dof::DofMap;
use crate::material::{AxialLaw, AxialLawError, AxialResponse};
use crate::mesh::ElementKind;
use crate::term::{CellField, LoadState, Term, TermOutput};

/// Energy (nN·µm), residual (6) and row-major tangent (6×6) of one truss.
///
/// `x0a`, `x0b`: initial node positions (µm); `u`: displacements `(u_a, u_b)` (µm). Fails
/// with [`KernelError::DegenerateReference`] when `L0 = 0` (`det_j0` holds `L0`) and with
/// [`KernelError::InvertedElement`] when the current length is 0 (`det_f` holds `ℓ/L0`).
#[allow(non_snake_case)]
pub fn truss_evaluate(
    law: &AxialLaw,
    x0a: &[f64; 3],
    x0b: &[f64; 3],
    u: &[f64],
    residual: &mut [f64],
    tangent: Option<&mut [f64]>,
) -> Result<f64, KernelError> {
    let (response, n, l) = truss_state(law, x0a, x0b, u)?;
    let N = response.force;
    for i in 0..3 {
        residual[i] = -N * n[i];
        residual[3 + i] = N * n[i];
    }
    if let Some(t) = tangent {
        let geometric = N / l;
        for i in 0..3 {
            for j in 0..3 {
                let nn = n[i] * n[j];
                let delta = if i == j { 1.0 } else { 0.0 };
                let kij = response.stiffness * nn + geometric * (delta - nn);
                t[i * 6 + j] = kij;
                t[(i + 3) * 6 + j + 3] = kij;
                t[i * 6 + j + 3] = -kij;
                t[(i + 3) * 6 + j] = -kij;
            }
        }
    }
    Ok(response.energy)
}

/// The law's response, the unit vector `n` and the current length `ℓ` of one truss.
fn truss_state(
    law: &AxialLaw,
    x0a: &[f64; 3],
    x0b: &[f64; 3],
    u: &[f64],
) -> Result<(AxialResponse, [f64; 3], f64), KernelError> {
    let l0 = distance(x0a, x0b);
    if l0.is_nan() || l0 <= 0.0 {
        return Err(KernelError::DegenerateReference { qp: 0, det_j0: l0 });
    }
    let d: [f64; 3] = std::array::from_fn(|i| x0b[i] + u[3 + i] - x0a[i] - u[i]);
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if l.is_nan() || l <= 0.0 {
        return Err(KernelError::InvertedElement {
            qp: 0,
            det_f: l / l0,
        });
    }
    let n = std::array::from_fn(|i| d[i] / l);
    Ok((law.evaluate(l, l0), n, l))
}

fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
}

/// Why a [`TrussSet`] could not be built or changed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrussError {
    /// An element refers to a node beyond the coordinate list.
    #[error(
        "truss set '{set}', element {element}: node {node} does not exist ({num_nodes} nodes)"
    )]
    UnknownNode {
        /// Set name.
        set: String,
        /// Element index in the set.
        element: usize,
        /// The node index given.
        node: usize,
        /// Number of nodes available.
        num_nodes: usize,
    },
    /// Both nodes of an element are at the same place (or a coordinate is not finite).
    #[error(
        "truss set '{set}', element {element}: nodes {nodes:?} are {length:e} µm apart; \
         an element needs a finite length > 0"
    )]
    ZeroLength {
        /// Set name.
        set: String,
        /// Element index in the set.
        element: usize,
        /// The two nodes.
        nodes: [usize; 2],
        /// Their distance (µm).
        length: f64,
    },
    /// The number of laws is neither 1 nor the number of elements.
    #[error("truss set '{set}': expected 1 law or {expected} (one per element), found {found}")]
    LawCount {
        /// Set name.
        set: String,
        /// Number of elements.
        expected: usize,
        /// Number of laws given.
        found: usize,
    },
    /// A law parameter is out of range.
    #[error("truss set '{set}', element {element}: {source}")]
    InvalidLaw {
        /// Set name.
        set: String,
        /// Element index in the set.
        element: usize,
        /// What is wrong.
        #[source]
        source: AxialLawError,
    },
    /// A scale factor must be finite and > 0.
    #[error("truss set '{set}': modulus scale factor must be > 0, found {found}")]
    InvalidScale {
        /// Set name.
        set: String,
        /// The factor given.
        found: f64,
    },
}

/// Min, max and mean of one quantity over a set.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ValueRange {
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Arithmetic mean.
    pub mean: f64,
}

/// Summary of one truss set (one cytoskeletal family) at a state.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FamilyStatistics {
    /// Family name (e.g. "actin").
    pub family: String,
    /// Number of elements.
    pub count: usize,
    /// Number of elements with `N > 0`.
    pub in_tension: usize,
    /// Axial force N (nN); `None` for an empty set.
    pub force: Option<ValueRange>,
    /// Nominal axial stress N/A (kPa); `None` for an empty set.
    pub stress: Option<ValueRange>,
}

/// A named set of two-node trusses of one family (e.g. "actin", "intermediate"), each with
/// its [`AxialLaw`], as a [`Term`] of the total potential.
///
/// A disabled set has no elements for the assembler (its nodes, if used by nothing else,
/// become untouched DOFs), so a family can be removed without changing any other term.
/// Enabling is decided before the problem is built.
#[derive(Debug, Clone, PartialEq)]
pub struct TrussSet {
    name: String,
    family: String,
    nodes: Vec<[usize; 2]>,
    reference: Vec<[[f64; 3]; 2]>,
    laws: Vec<AxialLaw>,
    enabled: bool,
    /// Analysis step during which the prestrain ramps from 0 to the laws' value.
    prestrain_ramp_step: Option<usize>,
    /// Fraction of the laws' prestrain currently applied (1 without a ramp).
    prestrain_factor: f64,
}

impl TrussSet {
    /// A set in which every element carries `law`. `coordinates` are all node positions
    /// (µm, indexed by node); `pairs` the elements' node pairs.
    pub fn new(
        name: impl Into<String>,
        family: impl Into<String>,
        coordinates: &[[f64; 3]],
        pairs: Vec<[usize; 2]>,
        law: AxialLaw,
    ) -> Result<Self, TrussError> {
        let laws = vec![law; pairs.len()];
        Self::with_element_laws(name, family, coordinates, pairs, laws)
    }

    /// A set with one law per element (`laws.len() == pairs.len()`), or one law for all
    /// (`laws.len() == 1`).
    pub fn with_element_laws(
        name: impl Into<String>,
        family: impl Into<String>,
        coordinates: &[[f64; 3]],
        pairs: Vec<[usize; 2]>,
        mut laws: Vec<AxialLaw>,
    ) -> Result<Self, TrussError> {
        let name = name.into();
        if laws.len() == 1 && pairs.len() != 1 {
            laws = vec![laws[0]; pairs.len()];
        }
        if laws.len() != pairs.len() {
            return Err(TrussError::LawCount {
                set: name,
                expected: pairs.len(),
                found: laws.len(),
            });
        }
        let mut reference = Vec::with_capacity(pairs.len());
        for (element, (&[a, b], law)) in pairs.iter().zip(&laws).enumerate() {
            for node in [a, b] {
                if node >= coordinates.len() {
                    return Err(TrussError::UnknownNode {
                        set: name,
                        element,
                        node,
                        num_nodes: coordinates.len(),
                    });
                }
            }
            let length = distance(&coordinates[a], &coordinates[b]);
            if !(length.is_finite() && length > 0.0) {
                return Err(TrussError::ZeroLength {
                    set: name,
                    element,
                    nodes: [a, b],
                    length,
                });
            }
            if let Err(source) = law.validate() {
                return Err(TrussError::InvalidLaw {
                    set: name,
                    element,
                    source,
                });
            }
            reference.push([coordinates[a], coordinates[b]]);
        }
        Ok(TrussSet {
            name,
            family: family.into(),
            nodes: pairs,
            reference,
            laws,
            enabled: true,
            prestrain_ramp_step: None,
            prestrain_factor: 1.0,
        })
    }

    /// Ramps the prestrain in during analysis step `step` (0 before it, the laws' value after
    /// it, linear in the step time during it), so that a prestressed structure can find its
    /// equilibrium gradually.
    pub fn ramp_prestrain_in_step(&mut self, step: usize) {
        self.prestrain_ramp_step = Some(step);
        self.prestrain_factor = 0.0;
    }

    /// The law of element `e` with the prestrain currently applied.
    fn effective_law(&self, e: usize) -> AxialLaw {
        let law = self.laws[e];
        if self.prestrain_factor == 1.0 {
            law
        } else {
            law.with_prestrain(law.prestrain * self.prestrain_factor)
        }
    }

    /// The family this set belongs to.
    pub fn family(&self) -> &str {
        &self.family
    }

    /// Node pairs of the elements.
    pub fn node_pairs(&self) -> &[[usize; 2]] {
        &self.nodes
    }

    /// The law of each element.
    pub fn laws(&self) -> &[AxialLaw] {
        &self.laws
    }

    /// Initial length `L0` of element `e` (µm).
    pub fn reference_length(&self, e: usize) -> f64 {
        let [a, b] = &self.reference[e];
        distance(a, b)
    }

    /// Whether the set takes part in the analysis.
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// Includes or removes the whole set (before building the problem).
    pub fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// Multiplies every element's Young's modulus by `factor` (> 0), e.g. 0.5 or 1.5 in a
    /// sensitivity study; prestrain and slack are kept.
    pub fn scale_modulus(&mut self, factor: f64) -> Result<(), TrussError> {
        if !(factor.is_finite() && factor > 0.0) {
            return Err(TrussError::InvalidScale {
                set: self.name.clone(),
                found: factor,
            });
        }
        for law in &mut self.laws {
            law.youngs_modulus *= factor;
        }
        Ok(())
    }

    /// Sets every element's prestrain to `prestrain` (> −1). Nothing changes on error.
    pub fn set_prestrain(&mut self, prestrain: f64) -> Result<(), TrussError> {
        for (element, law) in self.laws.iter().enumerate() {
            if let Err(source) = law.with_prestrain(prestrain).validate() {
                return Err(TrussError::InvalidLaw {
                    set: self.name.clone(),
                    element,
                    source,
                });
            }
        }
        for law in &mut self.laws {
            law.prestrain = prestrain;
        }
        Ok(())
    }

    /// Law response and current length of element `e` at the global state `u`.
    pub fn element_response(
        &self,
        e: usize,
        u: &[f64],
        dof_map: &DofMap,
    ) -> Result<(AxialResponse, f64), KernelError> {
        let mut u_e = [0.0; 6];
        for (a, &node) in self.nodes[e].iter().enumerate() {
            for c in 0..3 {
                u_e[3 * a + c] = u[dof_map.dof(node, c)];
            }
        }
        let [xa, xb] = &self.reference[e];
        let (response, _, l) = truss_state(&self.effective_law(e), xa, xb, &u_e)?;
        Ok((response, l))
    }

    /// Count, number in tension, and min/max/mean of axial force and stress of the set.
    pub fn force_statistics(
        &self,
        u: &[f64],
        dof_map: &DofMap,
    ) -> Result<FamilyStatistics, KernelError> {
        let mut forces = Vec::with_capacity(self.nodes.len());
        let mut stresses = Vec::with_capacity(self.nodes.len());
        for e in 0..self.nodes.len() {
            let (r, _) = self.element_response(e, u, dof_map)?;
            forces.push(r.force);
            stresses.push(r.stress);
        }
        Ok(FamilyStatistics {
            family: self.family.clone(),
            count: forces.len(),
            in_tension: forces.iter().filter(|&&f| f > 0.0).count(),
            force: value_range(&forces),
            stress: value_range(&stresses),
        })
    }
}

fn value_range(values: &[f64]) -> Option<ValueRange> {
    if values.is_empty() {
        return None;
    }
    Some(ValueRange {
        min: values.iter().copied().fold(f64::INFINITY, f64::min),
        max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        mean: values.iter().sum::<f64>() / values.len() as f64,
    })
}

impl Term for TrussSet {
    fn name(&self) -> &str {
        &self.name
    }

    fn num_elements(&self) -> usize {
        if self.enabled {
            self.nodes.len()
        } else {
            0
        }
    }

    fn element_dofs(&self, e: usize, dof_map: &DofMap, dofs: &mut [usize]) -> usize {
        for (a, &node) in self.nodes[e].iter().enumerate() {
            for c in 0..3 {
                dofs[3 * a + c] = dof_map.dof(node, c);
            }
        }
        6
    }

    fn evaluate(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let [a, b] = &self.reference[e];
        truss_evaluate(&self.effective_law(e), a, b, u_e, residual, tangent)
    }

    fn set_load_state(&mut self, state: &LoadState) {
        if let Some(step) = self.prestrain_ramp_step {
            self.prestrain_factor = match state.step_index.cmp(&step) {
                std::cmp::Ordering::Less => 0.0,
                std::cmp::Ordering::Equal => state.step_time,
                std::cmp::Ordering::Greater => 1.0,
            };
        }
    }

    /// Line cells with `axial_force_nN`, `axial_stress_kPa`, `axial_strain` (relative to the
    /// stress-free length) and `length_ratio` (ℓ/L0, the useful measure for slack IFs).
    fn outputs(&self, u: &[f64], dof_map: &DofMap) -> Result<Option<TermOutput>, KernelError> {
        if !self.enabled {
            return Ok(None);
        }
        let m = self.nodes.len();
        let mut fields: Vec<CellField> = ["axial_force_nN", "axial_stress_kPa", "axial_strain"]
            .iter()
            .chain(&["length_ratio"])
            .map(|name| CellField {
                name: (*name).to_string(),
                components: 1,
                values: Vec::with_capacity(m),
            })
            .collect();
        for e in 0..m {
            let (r, l) = self.element_response(e, u, dof_map)?;
            let values = [r.force, r.stress, r.strain, l / self.reference_length(e)];
            for (field, v) in fields.iter_mut().zip(values) {
                field.values.push(v);
            }
        }
        Ok(Some(TermOutput {
            kind: ElementKind::Line2,
            connectivity: self.nodes.iter().flatten().copied().collect(),
            fields,
        }))
    }

    /// Family statistics as curve columns, prefixed with the family name:
    /// `<family>_axial_force_{min,max,mean}_nN`, `_axial_stress_max_kPa`, `_axial_strain_max`
    /// (strain relative to the stress-free length, the measure for slack IFs) and
    /// `_in_tension` (count). Nothing for a disabled set; zeros for an empty one.
    fn scalar_outputs(&self, u: &[f64], dof_map: &DofMap) -> Vec<(String, f64)> {
        if !self.enabled {
            return Vec::new();
        }
        let mut force = ValueRange {
            min: 0.0,
            max: 0.0,
            mean: 0.0,
        };
        let (mut stress_max, mut strain_max, mut in_tension) = (0.0, 0.0, 0usize);
        let mut responses = Vec::with_capacity(self.nodes.len());
        for e in 0..self.nodes.len() {
            // A kernel error (zero current length) shows as NaN rather than a missing column.
            responses.push(self.element_response(e, u, dof_map).map(|(r, _)| r).ok());
        }
        if !responses.is_empty() {
            let forces: Vec<f64> = responses
                .iter()
                .map(|r| r.map_or(f64::NAN, |r| r.force))
                .collect();
            force = value_range(&forces).unwrap_or(force);
            stress_max = responses
                .iter()
                .map(|r| r.map_or(f64::NAN, |r| r.stress))
                .fold(f64::NEG_INFINITY, f64::max);
            strain_max = responses
                .iter()
                .map(|r| r.map_or(f64::NAN, |r| r.strain))
                .fold(f64::NEG_INFINITY, f64::max);
            in_tension = forces.iter().filter(|&&f| f > 0.0).count();
        }
        let f = &self.family;
        vec![
            (format!("{f}_axial_force_min_nN"), force.min),
            (format!("{f}_axial_force_max_nN"), force.max),
            (format!("{f}_axial_force_mean_nN"), force.mean),
            (format!("{f}_axial_stress_max_kPa"), stress_max),
            (format!("{f}_axial_strain_max"), strain_max),
            (format!("{f}_in_tension"), in_tension as f64),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seeded uniform numbers in [0, 1) (64-bit LCG, top 53 bits).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn unit(&mut self) -> [f64; 3] {
            loop {
                let v: [f64; 3] = std::array::from_fn(|_| 2.0 * self.next() - 1.0);
                let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                if n > 0.1 && n <= 1.0 {
                    return v.map(|x| x / n);
                }
            }
        }
    }

    fn laws() -> Vec<AxialLaw> {
        vec![
            AxialLaw::linear(1.2e6, AxialLaw::hollow_circle_area(0.025, 0.017)),
            AxialLaw::tension_only(2.6e6, AxialLaw::solid_circle_area(0.007)).with_prestrain(0.24),
            AxialLaw::tension_only(7.6e3, AxialLaw::solid_circle_area(0.010)).with_slack(0.2),
            AxialLaw::tension_only(340.0, AxialLaw::solid_circle_area(0.25))
                .with_prestrain(0.24)
                .with_transition_band(1e-3),
        ]
    }

    /// Displacements putting a truss from `x0a` along `dir` with length `l0` at length `l`
    /// in direction `new_dir`, node a moved by `shift`.
    fn placed(l0: f64, dir: [f64; 3], l: f64, new_dir: [f64; 3], shift: [f64; 3]) -> [f64; 6] {
        std::array::from_fn(|i| {
            if i < 3 {
                shift[i]
            } else {
                shift[i - 3] + l * new_dir[i - 3] - l0 * dir[i - 3]
            }
        })
    }

    #[test]
    fn truss_residual_and_tangent_match_finite_differences_on_every_branch() {
        let mut rng = Lcg(0x7255);
        let mut checked = 0;
        for law in laws() {
            for _ in 0..8 {
                let x0a = [rng.next(), rng.next(), rng.next()];
                let dir = rng.unit();
                let l0 = 0.5 + 10.0 * rng.next();
                let x0b = std::array::from_fn(|i| x0a[i] + l0 * dir[i]);
                let taut = law.stress_free_length(l0);
                // Compression, slack, just below/above the switch, tension.
                for ratio in [0.6, 0.95, 0.995, 1.005, 1.05, 1.4] {
                    let shift = [rng.next(), rng.next(), rng.next()];
                    let u = placed(l0, dir, ratio * taut, rng.unit(), shift);
                    let (mut r, mut t) = ([0.0; 6], [0.0; 36]);
                    truss_evaluate(&law, &x0a, &x0b, &u, &mut r, Some(&mut t)).unwrap();
                    let h = 1e-6 * l0;
                    let ea = law.axial_stiffness();
                    for j in 0..6 {
                        let (mut up, mut um) = (u, u);
                        up[j] += h;
                        um[j] -= h;
                        let (mut rp, mut rm) = ([0.0; 6], [0.0; 6]);
                        let ep = truss_evaluate(&law, &x0a, &x0b, &up, &mut rp, None).unwrap();
                        let em = truss_evaluate(&law, &x0a, &x0b, &um, &mut rm, None).unwrap();
                        let fd = (ep - em) / (2.0 * h);
                        assert!(
                            (fd - r[j]).abs() < 1e-6 * ea,
                            "dW/du[{j}] {fd} vs {} ({law:?}, ratio {ratio})",
                            r[j]
                        );
                        for i in 0..6 {
                            let fd = (rp[i] - rm[i]) / (2.0 * h);
                            assert!(
                                (fd - t[i * 6 + j]).abs() < 1e-5 * ea / l0,
                                "K[{i}][{j}] {fd} vs {} ({law:?}, ratio {ratio})",
                                t[i * 6 + j]
                            );
                            assert_eq!(t[i * 6 + j], t[j * 6 + i], "symmetric");
                        }
                    }
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 4 * 8 * 6);
    }

    #[test]
    fn truss_tension_only_contributes_exactly_nothing_in_compression() {
        let law = AxialLaw::tension_only(2.6e6, 3.85e-5).with_prestrain(0.24);
        let (x0a, x0b) = ([0.0, 0.0, 0.0], [1.0, 2.0, 2.0]);
        // Shorten from L0 = 3 to 2.0 < L_free = 3/1.24 = 2.419, and rotate.
        let u = placed(
            3.0,
            [1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0],
            2.0,
            [0.0, 0.6, 0.8],
            [0.1; 3],
        );
        let (mut r, mut t) = ([1.0; 6], [1.0; 36]);
        let w = truss_evaluate(&law, &x0a, &x0b, &u, &mut r, Some(&mut t)).unwrap();
        assert_eq!(w, 0.0);
        assert!(r.iter().all(|&x| x == 0.0), "{r:?}");
        assert!(t.iter().all(|&x| x == 0.0));
    }

    #[test]
    fn truss_prestrained_at_initial_geometry_pulls_with_ea_times_prestrain() {
        let mut rng = Lcg(42);
        let law =
            AxialLaw::tension_only(2.6e6, AxialLaw::solid_circle_area(0.007)).with_prestrain(0.24);
        let ea = law.axial_stiffness();
        for _ in 0..20 {
            let dir = rng.unit();
            let x0a = [rng.next(), rng.next(), rng.next()];
            let x0b = std::array::from_fn(|i| x0a[i] + 16.0 * dir[i]);
            let (mut r, mut t) = ([0.0; 6], [0.0; 36]);
            truss_evaluate(&law, &x0a, &x0b, &[0.0; 6], &mut r, Some(&mut t)).unwrap();
            for i in 0..3 {
                assert!((r[3 + i] - ea * 0.24 * dir[i]).abs() <= 1e-12 * ea);
                assert!((r[i] + r[3 + i]).abs() <= 1e-15 * ea);
            }
            // Lateral (geometric) stiffness N/ℓ: a unit transverse move of b.
            let perp = {
                let c = [dir[1], -dir[0], 0.0];
                let n = (c[0] * c[0] + c[1] * c[1]).sqrt();
                c.map(|x| x / n)
            };
            let kt: f64 = (0..3)
                .flat_map(|i| (0..3).map(move |j| (i, j)))
                .map(|(i, j)| perp[i] * t[(3 + i) * 6 + 3 + j] * perp[j])
                .sum();
            assert!((kt - ea * 0.24 / 16.0).abs() < 1e-12 * ea, "lateral {kt}");
        }
    }

    #[test]
    fn truss_energy_is_invariant_under_rigid_rotation() {
        let law = laws()[1];
        let (x0a, x0b) = ([0.0, 0.0, 0.0], [3.0, 0.0, 0.0]);
        let (mut r, mut r2) = ([0.0; 6], [0.0; 6]);
        let w1 = truss_evaluate(&law, &x0a, &x0b, &[0.0; 6], &mut r, None).unwrap();
        // Rotate by 90° about z and translate.
        let u = [1.0, 1.0, 1.0, 1.0 - 3.0, 1.0 + 3.0, 1.0];
        let w2 = truss_evaluate(&law, &x0a, &x0b, &u, &mut r2, None).unwrap();
        assert!((w1 - w2).abs() < 1e-12 * w1 && w1 > 0.0);
        assert!((r2[4] - r[3]).abs() < 1e-12 * r[3].abs());
    }

    #[test]
    fn truss_kernel_reports_zero_lengths_as_errors() {
        let law = AxialLaw::linear(1.0, 1.0);
        let (mut r, x) = ([0.0; 6], [1.0, 2.0, 3.0]);
        let e = truss_evaluate(&law, &x, &x, &[0.0; 6], &mut r, None).unwrap_err();
        assert_eq!(e, KernelError::DegenerateReference { qp: 0, det_j0: 0.0 });
        let u = [0.0, 0.0, 0.0, -1.0, 0.0, 0.0];
        let e = truss_evaluate(&law, &[0.0; 3], &[1.0, 0.0, 0.0], &u, &mut r, None).unwrap_err();
        assert_eq!(e, KernelError::InvertedElement { qp: 0, det_f: 0.0 });
    }

    fn square() -> Vec<[f64; 3]> {
        vec![[0.0; 3], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0], [0.0, 2.0, 0.0]]
    }

    #[test]
    fn truss_set_rejects_bad_input_with_located_messages() {
        let law = AxialLaw::tension_only(1.0e3, 0.01);
        let x = square();
        let e = TrussSet::new("af", "actin", &x, vec![[0, 1], [2, 7]], law).unwrap_err();
        assert!(matches!(
            e,
            TrussError::UnknownNode {
                element: 1,
                node: 7,
                num_nodes: 4,
                ..
            }
        ));
        assert!(
            e.to_string().contains("node 7 does not exist (4 nodes)"),
            "{e}"
        );
        let e = TrussSet::new("af", "actin", &x, vec![[3, 3]], law).unwrap_err();
        assert!(matches!(
            e,
            TrussError::ZeroLength {
                element: 0,
                nodes: [3, 3],
                ..
            }
        ));
        let e =
            TrussSet::new("af", "actin", &x, vec![[0, 1]], law.with_prestrain(-1.0)).unwrap_err();
        assert!(e.to_string().contains("prestrain must be > -1"), "{e}");
        let e = TrussSet::with_element_laws(
            "af",
            "actin",
            &x,
            vec![[0, 1], [1, 2], [2, 3]],
            vec![law, law],
        )
        .unwrap_err();
        assert!(matches!(
            e,
            TrussError::LawCount {
                expected: 3,
                found: 2,
                ..
            }
        ));
        let mut set = TrussSet::new("af", "actin", &x, vec![[0, 1], [1, 2]], law).unwrap();
        assert!(matches!(
            set.scale_modulus(0.0),
            Err(TrussError::InvalidScale { .. })
        ));
        assert!(set.set_prestrain(-2.0).is_err());
        assert_eq!(set.laws()[0].prestrain, 0.0, "unchanged after the error");
    }

    #[test]
    fn truss_set_outputs_and_statistics_report_each_element() {
        let law = AxialLaw::tension_only(1.0e3, 0.01).with_prestrain(0.24);
        let x = square();
        let mut set =
            TrussSet::new("af", "actin", &x, vec![[0, 1], [1, 2], [2, 3], [3, 0]], law).unwrap();
        set.scale_modulus(1.5).unwrap();
        set.set_prestrain(0.1).unwrap();
        let map = DofMap::translational(4);
        let mut u = vec![0.0; 12];
        // Node 1 moves +0.5 in x, node 3 −1 in y: lengths 2.5, √4.25, √5 (taut) and 1 (slack,
        // ℓ < L_free = 2/1.1).
        u[3] = 0.5;
        u[10] = -1.0;
        let out = set.outputs(&u, &map).unwrap().unwrap();
        assert_eq!(out.kind, ElementKind::Line2);
        assert_eq!(out.connectivity, vec![0, 1, 1, 2, 2, 3, 3, 0]);
        let names: Vec<&str> = out.fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "axial_force_nN",
                "axial_stress_kPa",
                "axial_strain",
                "length_ratio"
            ]
        );
        let ea = 1.5e3 * 0.01;
        let e0 = 2.5 * 1.1 / 2.0 - 1.0;
        assert!((out.fields[0].values[0] - ea * e0).abs() < 1e-12);
        assert!((out.fields[1].values[0] - 1.5e3 * e0).abs() < 1e-9);
        assert!((out.fields[2].values[0] - e0).abs() < 1e-15);
        assert!((out.fields[3].values[0] - 1.25).abs() < 1e-15);
        assert_eq!(out.fields[0].values[3], 0.0);
        assert!((out.fields[2].values[3] - (1.0 * 1.1 / 2.0 - 1.0)).abs() < 1e-15);
        let stats = set.force_statistics(&u, &map).unwrap();
        assert_eq!(
            (stats.family.as_str(), stats.count, stats.in_tension),
            ("actin", 4, 3)
        );
        let f = stats.force.unwrap();
        let forces = &out.fields[0].values;
        assert_eq!(f.max, forces[0]);
        assert_eq!(f.min, 0.0);
        assert!((f.mean - forces.iter().sum::<f64>() / 4.0).abs() < 1e-14);
        let columns = set.scalar_outputs(&u, &map);
        let names: Vec<&str> = columns.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "actin_axial_force_min_nN",
                "actin_axial_force_max_nN",
                "actin_axial_force_mean_nN",
                "actin_axial_stress_max_kPa",
                "actin_axial_strain_max",
                "actin_in_tension"
            ]
        );
        let values: Vec<f64> = columns.iter().map(|(_, v)| *v).collect();
        assert_eq!(values[..3], [f.min, f.max, f.mean]);
        assert!((values[3] - 1.5e3 * e0).abs() < 1e-9);
        assert!((values[4] - e0).abs() < 1e-15);
        assert_eq!(values[5], 3.0);
        set.set_enabled(false);
        assert!(set.scalar_outputs(&u, &map).is_empty());
        assert_eq!(set.num_elements(), 0);
        assert_eq!(set.outputs(&u, &map).unwrap(), None);
        let empty = TrussSet::new("none", "bundle", &x, vec![], law).unwrap();
        assert_eq!(empty.force_statistics(&u, &map).unwrap().force, None);
    }
}
