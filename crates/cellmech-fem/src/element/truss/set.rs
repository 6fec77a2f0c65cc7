//! A named family of trusses as an [`ElementSet`], with per-element outputs and family
//! statistics.

use super::kernel::{truss_evaluate, truss_state};
use crate::dof::DofMap;
use crate::element::{ElementSet, KernelError};
use crate::material::{AxialLaw, AxialLawError, AxialResponse};
use crate::math::vec3::distance;
use crate::mesh::ElementKind;
use crate::term::{CellField, LoadState, TermOutput};

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
        self.gather(e, u, dof_map, &mut u_e);
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

impl ElementSet for TrussSet {
    const ELEMENT_DOFS: usize = 6;

    fn set_name(&self) -> &str {
        &self.name
    }

    fn element_count(&self) -> usize {
        if self.enabled {
            self.nodes.len()
        } else {
            0
        }
    }

    fn element_nodes(&self, e: usize) -> &[usize] {
        &self.nodes[e]
    }

    fn evaluate_element(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let [a, b] = &self.reference[e];
        truss_evaluate(&self.effective_law(e), a, b, u_e, residual, tangent)
    }

    fn on_load_state(&mut self, state: &LoadState) {
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
    fn cell_outputs(&self, u: &[f64], dof_map: &DofMap) -> Result<Option<TermOutput>, KernelError> {
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
    fn curve_outputs(&self, u: &[f64], dof_map: &DofMap) -> Vec<(String, f64)> {
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
