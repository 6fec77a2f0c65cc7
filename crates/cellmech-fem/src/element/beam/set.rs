//! A set of corotational beam elements as an [`ElementSet`], with per-element results.

use super::{
    beam_deformation, beam_evaluate_with, BeamError, BeamReference, BeamSection, LocalStrain,
    BEAM_DOFS,
};
use crate::dof::DofMap;
use crate::element::{ElementSet, KernelError};
use crate::mesh::ElementKind;
use crate::term::{CellField, TermOutput};

/// A set of two-node corotational beams sharing one section (e.g. all microtubules).
///
/// Every node of the set must carry 6 DOFs in the [`DofMap`] (3 translations, then the 3
/// components of the total rotation vector); see [`BeamSet::mark_rotational_nodes`] and
/// [`BeamSet::check_dof_map`]. When `enabled` is false the set contributes nothing (zero
/// energy, residual and tangent), so the rotations of nodes only beams stiffen must then
/// be held by the caller.
#[derive(Debug, Clone, PartialEq)]
pub struct BeamSet {
    /// Name of the set (messages, outputs).
    pub name: String,
    /// Filament family, e.g. `microtubule`.
    pub family: String,
    /// Node pairs (a, b) of the elements.
    pub nodes: Vec<[usize; 2]>,
    /// Reference geometry of each element.
    pub reference: Vec<BeamReference>,
    /// Cross-section of all elements.
    pub section: BeamSection,
    /// Axial strain measure of the local element.
    pub local_strain: LocalStrain,
    /// Whether the set contributes to the problem.
    pub enabled: bool,
    /// A stress-free geometry that moves during one analysis step, if any
    /// ([`BeamSet::morph_reference_through`]).
    pub morph: Option<ReferenceMorph>,
}

/// The stress-free geometry of a beam set moving from the mesh to target positions during
/// one analysis step (and staying at the last one after it): beams that are stress-free in
/// a deformed state of the model that the step reaches, e.g. filaments that polymerised in
/// a cell after its prestress contracted it. The move is piecewise linear in the step time
/// through knots `(tₖ, Yₖ)` (from `(0, X)`), so that it can follow a path recorded in an
/// earlier run. Positions stay measured from the mesh: at step time `t` element `e` is
/// evaluated on the reference through `X + s(t)` with its translations `u − s(t)`, where
/// `s(t)` interpolates the knots' moves `Yₖ − X`.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceMorph {
    /// Analysis step during which the geometry moves.
    pub step: usize,
    /// Element references on the mesh (t = 0).
    pub start: Vec<BeamReference>,
    /// Knot times: 0 (the mesh), then increasing in (0, 1]; the last is the end of the
    /// move.
    pub times: Vec<f64>,
    /// Per knot and element, the move `Yₖ − X` of nodes a and b (µm; zero at time 0).
    pub shifts: Vec<Vec<[[f64; 3]; 2]>>,
    /// Step time the references are at now (−1: not yet positioned).
    pub time: f64,
    /// Per element, the current move `s(t)`.
    pub current: Vec<[[f64; 3]; 2]>,
}

impl ReferenceMorph {
    /// The move of element `e` at step time `t`, interpolated between the knots.
    fn shift_at(&self, e: usize, t: f64) -> [[f64; 3]; 2] {
        let (i0, i1, w) = crate::math::knot_bracket(&self.times, t);
        let (s0, s1) = (self.shifts[i0][e], self.shifts[i1][e]);
        std::array::from_fn(|n| std::array::from_fn(|i| s0[n][i] + w * (s1[n][i] - s0[n][i])))
    }
}

/// Per-element results at a state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamElementResult {
    /// Axial force N = EA ε (nN; > 0 tension).
    pub axial_force: f64,
    /// Axial strain ε (ū/L, plus the bowing term for [`LocalStrain::ShallowArch`]).
    pub axial_strain: f64,
    /// Torque T = GJ (θ̄_b1 − θ̄ₐ1)/L (nN·µm).
    pub torque: f64,
    /// Resultant bending moments |(M₂, M₃)| at ends a and b, `M = EI/L (4θ̄ₐ + 2θ̄_b)` etc.
    /// (nN·µm).
    pub bending_moment: [f64; 2],
}

/// Summary of the axial forces of a set.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ForceStatistics {
    /// Number of elements.
    pub count: usize,
    /// Smallest axial force (nN).
    pub min: f64,
    /// Largest axial force (nN).
    pub max: f64,
    /// Mean axial force (nN).
    pub mean: f64,
    /// Elements with N > ZERO_FORCE_STRAIN·EA ([`crate::element::ZERO_FORCE_STRAIN`]).
    pub tension: usize,
    /// Elements with N < −ZERO_FORCE_STRAIN·EA.
    pub compression: usize,
}

impl BeamSet {
    /// A set from node pairs and reference coordinates of all nodes; element references
    /// use `up` (or the automatic choice of [`BeamReference::new`]).
    pub fn from_coordinates(
        name: impl Into<String>,
        family: impl Into<String>,
        coordinates: &[[f64; 3]],
        pairs: &[[usize; 2]],
        up: Option<[f64; 3]>,
        section: BeamSection,
    ) -> Result<Self, BeamError> {
        let name = name.into();
        let mut reference = Vec::with_capacity(pairs.len());
        for (e, pair) in pairs.iter().enumerate() {
            for &node in pair {
                if node >= coordinates.len() {
                    return Err(BeamError::NodeOutOfRange {
                        set: name.clone(),
                        element: e,
                        node,
                        num_nodes: coordinates.len(),
                    });
                }
            }
            let r = BeamReference::new(coordinates[pair[0]], coordinates[pair[1]], up).map_err(
                |source| BeamError::Element {
                    set: name.clone(),
                    element: e,
                    source: Box::new(source),
                },
            )?;
            reference.push(r);
        }
        Ok(BeamSet {
            name,
            family: family.into(),
            nodes: pairs.to_vec(),
            reference,
            section,
            local_strain: LocalStrain::default(),
            enabled: true,
            morph: None,
        })
    }

    /// Makes the stress-free geometry move during analysis step `step` through the knots
    /// `(time, coordinates of every node)`, times increasing in (0, 1]: see
    /// [`ReferenceMorph`]. Each element keeps its reference triad's e₂ direction as `up`,
    /// so the triad turns with the element instead of jumping between global axes.
    pub fn morph_reference_through(
        &mut self,
        step: usize,
        knots: &[(f64, &[[f64; 3]])],
    ) -> Result<(), BeamError> {
        let start = self.reference.clone();
        let mut times = vec![0.0];
        let mut shifts = vec![vec![[[0.0; 3]; 2]; start.len()]];
        for &(time, target) in knots {
            if !(time > times.last().copied().unwrap_or(0.0) && time <= 1.0) {
                return Err(BeamError::Morph {
                    set: self.name.clone(),
                    message: format!(
                        "knot times must increase within (0, 1]; found {time} after {:?}",
                        times.last()
                    ),
                });
            }
            let mut shift = Vec::with_capacity(self.nodes.len());
            for (e, (pair, r)) in self.nodes.iter().zip(&start).enumerate() {
                let mut s = [[0.0; 3]; 2];
                for (k, (&node, x)) in pair.iter().zip([r.x_a, r.x_b]).enumerate() {
                    let y = target.get(node).ok_or(BeamError::NodeOutOfRange {
                        set: self.name.clone(),
                        element: e,
                        node,
                        num_nodes: target.len(),
                    })?;
                    s[k] = std::array::from_fn(|i| y[i] - x[i]);
                }
                // Every knot's geometry must itself be a valid element.
                Self::reference_at(r, &s).map_err(|source| BeamError::Element {
                    set: self.name.clone(),
                    element: e,
                    source: Box::new(source),
                })?;
                shift.push(s);
            }
            times.push(time);
            shifts.push(shift);
        }
        self.morph = Some(ReferenceMorph {
            step,
            current: vec![[[0.0; 3]; 2]; start.len()],
            start,
            times,
            shifts,
            time: -1.0,
        });
        Ok(())
    }

    /// The reference of an element whose start reference is `r`, moved by `shift`.
    fn reference_at(r: &BeamReference, shift: &[[f64; 3]; 2]) -> Result<BeamReference, BeamError> {
        let up = [r.triad[0][1], r.triad[1][1], r.triad[2][1]];
        BeamReference::new(
            std::array::from_fn(|i| r.x_a[i] + shift[0][i]),
            std::array::from_fn(|i| r.x_b[i] + shift[1][i]),
            Some(up),
        )
    }

    /// Element `e`'s DOF values relative to its current reference (the morph's move taken
    /// off the translations).
    fn relative_dofs(&self, e: usize, u_e: &[f64]) -> [f64; BEAM_DOFS] {
        let mut u: [f64; BEAM_DOFS] = std::array::from_fn(|i| u_e.get(i).copied().unwrap_or(0.0));
        if let Some(m) = &self.morph {
            for i in 0..3 {
                u[i] -= m.current[e][0][i];
                u[6 + i] -= m.current[e][1][i];
            }
        }
        u
    }

    /// Sets `dofs_per_node[n] = 6` for every node of the set (input for
    /// [`DofMap::with_counts`]).
    pub fn mark_rotational_nodes(&self, dofs_per_node: &mut [usize]) -> Result<(), BeamError> {
        for (e, pair) in self.nodes.iter().enumerate() {
            for &node in pair {
                let num_nodes = dofs_per_node.len();
                let slot = dofs_per_node
                    .get_mut(node)
                    .ok_or(BeamError::NodeOutOfRange {
                        set: self.name.clone(),
                        element: e,
                        node,
                        num_nodes,
                    })?;
                *slot = 6;
            }
        }
        Ok(())
    }

    /// Checks that the per-element lists agree and every beam node carries 6 DOFs.
    pub fn check_dof_map(&self, dof_map: &DofMap) -> Result<(), BeamError> {
        if self.nodes.len() != self.reference.len() {
            return Err(BeamError::LengthMismatch {
                set: self.name.clone(),
                pairs: self.nodes.len(),
                references: self.reference.len(),
            });
        }
        for (e, pair) in self.nodes.iter().enumerate() {
            for &node in pair {
                if node >= dof_map.num_nodes() {
                    return Err(BeamError::NodeOutOfRange {
                        set: self.name.clone(),
                        element: e,
                        node,
                        num_nodes: dof_map.num_nodes(),
                    });
                }
                if dof_map.count(node) < 6 {
                    return Err(BeamError::NodeWithoutRotations {
                        set: self.name.clone(),
                        node,
                        count: dof_map.count(node),
                    });
                }
            }
        }
        Ok(())
    }

    /// Axial force, strain, torque and end moments of every element at DOF values `u`
    /// (zeros when the set is disabled). Requires [`BeamSet::check_dof_map`] to pass.
    pub fn element_results(
        &self,
        u: &[f64],
        dof_map: &DofMap,
    ) -> Result<Vec<BeamElementResult>, KernelError> {
        let s = &self.section;
        let (ei2, ei3) = s.bending_stiffness();
        (0..self.nodes.len())
            .map(|e| {
                if !self.enabled {
                    return Ok(BeamElementResult {
                        axial_force: 0.0,
                        axial_strain: 0.0,
                        torque: 0.0,
                        bending_moment: [0.0; 2],
                    });
                }
                let r = &self.reference[e];
                let mut u_e = [0.0; BEAM_DOFS];
                self.gather(e, u, dof_map, &mut u_e);
                let d = beam_deformation::<f64>(r, &self.relative_dofs(e, &u_e))?;
                let l = r.length;
                let (ta, tb) = (d.theta_a, d.theta_b);
                let moment = |x: &[f64; 3], y: &[f64; 3]| {
                    let m2 = ei2 / l * (4.0 * x[1] + 2.0 * y[1]);
                    let m3 = ei3 / l * (4.0 * x[2] + 2.0 * y[2]);
                    m2.hypot(m3)
                };
                let strain = self.local_strain.strain(l, &d);
                Ok(BeamElementResult {
                    axial_force: s.axial_stiffness() * strain,
                    axial_strain: strain,
                    torque: s.shear_modulus * s.torsion_j * (tb[0] - ta[0]) / l,
                    bending_moment: [moment(&ta, &tb), moment(&tb, &ta)],
                })
            })
            .collect()
    }

    /// Count, extremes and mean of the axial forces, and how many elements are in tension
    /// (N > 0) and in compression (N < 0). An empty set gives zeros.
    pub fn force_statistics(
        &self,
        u: &[f64],
        dof_map: &DofMap,
    ) -> Result<ForceStatistics, KernelError> {
        let results = self.element_results(u, dof_map)?;
        let forces = results.iter().map(|r| r.axial_force);
        let count = results.len();
        let zero = crate::element::ZERO_FORCE_STRAIN * self.section.axial_stiffness();
        if count == 0 {
            return Ok(ForceStatistics {
                count,
                min: 0.0,
                max: 0.0,
                mean: 0.0,
                tension: 0,
                compression: 0,
            });
        }
        Ok(ForceStatistics {
            count,
            min: forces.clone().fold(f64::INFINITY, f64::min),
            max: forces.clone().fold(f64::NEG_INFINITY, f64::max),
            mean: forces.clone().sum::<f64>() / count as f64,
            tension: forces.clone().filter(|&n| n > zero).count(),
            compression: forces.filter(|&n| n < -zero).count(),
        })
    }
}

/// Element DOFs `[uₐ(3), θₐ(3), u_b(3), θ_b(3)]`: components 0..6 of both nodes (which must
/// carry 6 DOFs, see [`BeamSet::check_dof_map`]).
impl ElementSet for BeamSet {
    const ELEMENT_DOFS: usize = BEAM_DOFS;
    const NODE_DOFS: usize = 6;

    /// Moves the stress-free geometry of a [`ReferenceMorph`] to the increment's step time.
    fn on_load_state(&mut self, state: &crate::term::LoadState) {
        let Some(m) = &mut self.morph else {
            return;
        };
        let t = match state.step_index.cmp(&m.step) {
            std::cmp::Ordering::Less => 0.0,
            std::cmp::Ordering::Equal => state.step_time.clamp(0.0, 1.0),
            std::cmp::Ordering::Greater => 1.0,
        };
        if t == m.time {
            return;
        }
        for (e, (r, current)) in m.start.iter().zip(&mut self.reference).enumerate() {
            let shift = m.shift_at(e, t);
            // Validated at every knot; an element degenerate in between keeps its last
            // reference.
            if let Ok(moved) = Self::reference_at(r, &shift) {
                *current = moved;
                m.current[e] = shift;
            }
        }
        m.time = t;
    }

    fn set_name(&self) -> &str {
        &self.name
    }

    fn element_count(&self) -> usize {
        self.nodes.len()
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
        if !self.enabled {
            residual.iter_mut().for_each(|r| *r = 0.0);
            if let Some(t) = tangent {
                t.iter_mut().for_each(|k| *k = 0.0);
            }
            return Ok(0.0);
        }
        let u = self.relative_dofs(e, u_e);
        beam_evaluate_with(
            self.local_strain,
            &self.section,
            &self.reference[e],
            &u,
            residual,
            tangent,
        )
    }

    /// Line2 cells with `axial_force_nN`, `axial_stress_kPa`, `axial_strain` and
    /// `bending_moment_nN_um` (the larger of the two ends' resultant moments).
    fn cell_outputs(&self, u: &[f64], dof_map: &DofMap) -> Result<Option<TermOutput>, KernelError> {
        let results = self.element_results(u, dof_map)?;
        let field = |name: &str, f: &dyn Fn(&BeamElementResult) -> f64| CellField {
            name: name.to_string(),
            components: 1,
            values: results.iter().map(f).collect(),
        };
        let area = self.section.area;
        Ok(Some(TermOutput {
            kind: ElementKind::Line2,
            connectivity: self.nodes.iter().flatten().copied().collect(),
            fields: vec![
                field("axial_force_nN", &|r| r.axial_force),
                field("axial_stress_kPa", &|r| r.axial_force / area),
                field("axial_strain", &|r| r.axial_strain),
                field("bending_moment_nN_um", &|r| {
                    r.bending_moment[0].max(r.bending_moment[1])
                }),
            ],
        }))
    }

    /// Family statistics as curve columns, prefixed with the family name:
    /// `<family>_axial_force_{min,max,mean}_nN`, `_axial_stress_max_kPa`,
    /// `_bending_moment_max_nN_um`, `_in_tension` and `_in_compression` (counts). Nothing for
    /// a disabled set; NaN values if an element cannot be evaluated.
    fn curve_outputs(&self, u: &[f64], dof_map: &DofMap) -> Vec<(String, f64)> {
        if !self.enabled {
            return Vec::new();
        }
        let f = &self.family;
        let names = [
            "axial_force_min_nN",
            "axial_force_max_nN",
            "axial_force_mean_nN",
            "axial_stress_max_kPa",
            "bending_moment_max_nN_um",
            "in_tension",
            "in_compression",
        ];
        let values = match (
            self.force_statistics(u, dof_map),
            self.element_results(u, dof_map),
        ) {
            (Ok(s), Ok(results)) => {
                let moment = results
                    .iter()
                    .map(|r| r.bending_moment[0].max(r.bending_moment[1]))
                    .fold(0.0, f64::max);
                [
                    s.min,
                    s.max,
                    s.mean,
                    s.max / self.section.area,
                    moment,
                    s.tension as f64,
                    s.compression as f64,
                ]
            }
            _ => [f64::NAN; 7],
        };
        names
            .iter()
            .zip(values)
            .map(|(n, v)| (format!("{f}_{n}"), v))
            .collect()
    }
}
