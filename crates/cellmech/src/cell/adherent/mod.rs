//! The adherent bendo-tensegrity cell (`shared/spec/cell-models.md`, "Adherent cell"): a
//! half-ellipsoid on a rigid substrate (every base node fixed) with an ellipsoidal nucleus,
//! an actin cortex (AC) on its free surface, peripheral actin bundles (ABs) between focal
//! adhesions (FAs), microtubules (MTs) from a centrosome to the FAs and intermediate
//! filaments (IFs) tangential to the nucleus. The mesh is refined at the indentation site
//! an AFM protocol chooses ([`AdherentCell::site`]).
//!
//! Defaults (internal units µm, nN, kPa): cytoplasm G = 0.17 kPa, nucleus G = 1.7 kPa
//! (ν = 0.49), AC E = 2 kPa (G = 0.67 kPa, incompressible) 0.2 µm thick, AB E = 0.34 MPa,
//! d = 250 nm, prestrain 24 %, MTs and IFs as in the suspended cell.

use std::collections::HashSet;

pub mod geometry;
pub mod layout;
pub mod params;

pub use geometry::{AdherentMeshResolution, AdherentShape};
pub use layout::{AdherentCellGeometry, AdherentCellParams, IndentationSite, LocalRefinement};

use crate::cell::suspended::{
    component, tension_only_law, ActinMaterial, CellModelError, Coupling, IntermediateMaterial,
    MicrotubuleMaterial,
};
use crate::model::filaments::{Filament, FilamentEnd};
use crate::model::structures::{FilamentElement, FilamentSpec, MembraneSpec, StructuresSpec};

/// Filament group of the density variant's extra ABs (family `bundles`).
pub const EXTRA_BUNDLES: &str = "bundles-extra";

/// Family names of the adherent cell's components (curve-column prefixes and
/// `[families.<name>]` keys).
pub mod family {
    /// Actin cortex.
    pub const CORTEX: &str = "cortex";
    /// Actin bundles.
    pub const BUNDLES: &str = "bundles";
    /// Microtubules.
    pub const MICROTUBULE: &str = "microtubule";
    /// Intermediate filaments.
    pub const INTERMEDIATE: &str = "intermediate";
}

/// Materials and sections of the adherent cell (internal units).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AdherentCellMaterials {
    /// Cytoplasm shear modulus (kPa).
    pub cytoplasm_shear_modulus: f64,
    /// Cytoplasm Poisson's ratio.
    pub cytoplasm_poisson_ratio: f64,
    /// Nucleus shear modulus (kPa).
    pub nucleus_shear_modulus: f64,
    /// Nucleus Poisson's ratio.
    pub nucleus_poisson_ratio: f64,
    /// Actin-cortex shear modulus (kPa).
    pub cortex_shear_modulus: f64,
    /// Actin-cortex thickness (µm).
    pub cortex_thickness: f64,
    /// Whether the cortex carries compression or wrinkles.
    pub cortex_law: crate::model::structures::MembraneLaw,
    /// Actin bundles.
    pub bundle: ActinMaterial,
    /// Microtubules.
    pub microtubule: MicrotubuleMaterial,
    /// Intermediate filaments.
    pub intermediate: IntermediateMaterial,
}

/// Which components are in the model (the disruption studies switch them off).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct AdherentComponents {
    /// Actin cortex.
    pub cortex: bool,
    /// Actin bundles.
    pub bundles: bool,
    /// Microtubules.
    pub microtubules: bool,
    /// Intermediate filaments.
    pub intermediate: bool,
}

impl Default for AdherentComponents {
    fn default() -> Self {
        AdherentComponents {
            cortex: true,
            bundles: true,
            microtubules: true,
            intermediate: true,
        }
    }
}

/// The adherent cell as a library value.
#[derive(Debug, Clone, PartialEq)]
pub struct AdherentCell {
    /// Geometry, mesh and routing parameters.
    pub params: AdherentCellParams,
    /// Materials and sections.
    pub materials: AdherentCellMaterials,
    /// Components present.
    pub components: AdherentComponents,
    /// How the cytoskeleton is tied to the continuum (as in the suspended cell).
    pub coupling: Coupling,
    /// How every analysis step is solved (`[cell.solver]`).
    pub solver: crate::cell::SolverSettings,
    /// Where the mesh is refined for an indenter (`None`: the base mesh). The AFM protocol
    /// sets it to its site.
    pub site: Option<IndentationSite>,
}

impl Default for AdherentCell {
    /// The published model with the spec's values.
    fn default() -> Self {
        Self::from_values(&crate::param::ParamValues::defaults(&params::ADHERENT_CELL))
    }
}

impl AdherentCell {
    /// The cell from resolved values of [`params::ADHERENT_CELL`].
    pub fn from_values(values: &crate::param::ParamValues) -> Self {
        let (params, materials) = params::from_values(values);
        use crate::cell::suspended::params as s;
        AdherentCell {
            params,
            materials,
            components: AdherentComponents::default(),
            coupling: s::coupling_from_values(values),
            solver: crate::cell::SolverSettings::from_values(values),
            site: None,
        }
    }

    /// The base control of every step.
    pub fn step_control(&self) -> cellmech_fem::solve::StepControl {
        self.solver.step_control()
    }

    /// Builds the cell: refined mesh, materials, structures, the clamped base, and the
    /// prestress step.
    pub fn build(&self) -> Result<crate::cell::BuiltCell, CellModelError> {
        crate::cell::suspended::check_damping(self.solver.stabilization, &self.coupling)?;
        let geometry = AdherentCellGeometry::build(&self.params, self.site)
            .map_err(component("adherent cell"))?;
        let mut mesh = geometry.mesh.clone();
        let chains = geometry.append_microtubule_nodes(&mut mesh);
        let m = &self.materials;
        let on = &self.components;
        let materials = crate::cell::suspended::continuum_materials(
            (m.cytoplasm_shear_modulus, m.cytoplasm_poisson_ratio),
            (m.nucleus_shear_modulus, m.nucleus_poisson_ratio),
        )?;
        let mut structures = StructuresSpec::default();
        let bottom: HashSet<usize> = mesh.node_sets["bottom"].iter().copied().collect();
        let dome_faces: Vec<[usize; 4]> = geometry
            .boundary_faces
            .iter()
            .copied()
            .filter(|f| !f.iter().all(|n| bottom.contains(n)))
            .collect();
        if !(m.cortex_shear_modulus > 0.0 && m.cortex_thickness > 0.0) {
            return Err(CellModelError::Component {
                component: "cortex",
                message: format!(
                    "expected a positive modulus and thickness; found G = {} kPa, {} µm",
                    m.cortex_shear_modulus, m.cortex_thickness
                ),
            });
        }
        structures.membranes.push(MembraneSpec {
            name: family::CORTEX.into(),
            family: family::CORTEX.into(),
            faces: dome_faces.clone(),
            shear_modulus: m.cortex_shear_modulus,
            thickness: m.cortex_thickness,
            law: m.cortex_law,
            enabled: on.cortex,
        });
        let b = m.bundle;
        structures.filaments.push(FilamentSpec {
            name: family::BUNDLES.into(),
            family: family::BUNDLES.into(),
            filaments: Filament::one_per_element(geometry.bundles.len(), Some(FilamentEnd::Both)),
            pairs: geometry.bundles.clone(),
            element: FilamentElement::Truss(
                tension_only_law("bundles", b.youngs_modulus, b.diameter)?
                    .with_prestrain(b.prestrain),
            ),
            enabled: on.bundles,
        });
        let fa_mts = geometry.microtubules.len();
        structures
            .filaments
            .push(crate::cell::suspended::microtubule_filaments(
                &m.microtubule,
                &chains[..fa_mts],
                on.microtubules,
            )?);
        structures
            .filaments
            .push(crate::cell::suspended::intermediate_filaments(
                &m.intermediate,
                &geometry.intermediate_filaments,
                on.intermediate,
            )?);
        // The density variant's extra ABs: a group of its own after the published ones, in
        // the family `bundles` (switched and scaled with it), same material. None by default.
        if !geometry.extra_bundles.is_empty() {
            structures.filaments.push(FilamentSpec {
                name: EXTRA_BUNDLES.into(),
                family: family::BUNDLES.into(),
                filaments: Filament::one_per_element(
                    geometry.extra_bundles.len(),
                    Some(FilamentEnd::Both),
                ),
                pairs: geometry.extra_bundles.clone(),
                element: FilamentElement::Truss(
                    tension_only_law("bundles", b.youngs_modulus, b.diameter)?
                        .with_prestrain(b.prestrain),
                ),
                enabled: on.bundles,
            });
        }
        // The density variant's extra MTs and IFs: groups of their own after the published
        // ones (whose filament ids do not change), in the same families, same materials.
        if chains.len() > fa_mts {
            let mut group = crate::cell::suspended::microtubule_filaments(
                &m.microtubule,
                &chains[fa_mts..],
                on.microtubules,
            )?;
            group.name = crate::cell::suspended::EXTRA_MICROTUBULE.into();
            structures.filaments.push(group);
        }
        if !geometry.extra_intermediate.is_empty() {
            let mut group = crate::cell::suspended::intermediate_filaments(
                &m.intermediate,
                &geometry.extra_intermediate,
                on.intermediate,
            )?;
            group.name = crate::cell::suspended::EXTRA_INTERMEDIATE.into();
            structures.filaments.push(group);
        }
        let report = &geometry.report;
        let p = &self.params;
        let supports = vec![("bottom".to_string(), [true, true, true])];
        let mut description = crate::cell::CellDescription {
            model: "adherent".into(),
            seed: p.seed,
            cell_diameter: 2.0 * p.shape.semi_axes[0],
            nucleus_diameter: 2.0 * p.shape.nucleus_semi_axes[0],
            axis: 2,
            params: serde_json::json!({
                "shape": p.shape,
                "mesh": p.mesh,
                "refinement": p.refinement,
                "site": self.site,
                "bundles": p.bundles,
                "bundle_height_um": p.bundle_height,
                "bundle_spread": p.bundle_spread,
                "receptor_fa": geometry.receptor,
                "mt_elements": p.mt_elements,
                "mt_bow": [p.mt_bow_min, p.mt_bow_max],
                "centrosome_um": geometry.centrosome,
                "ifs_per_fa": p.ifs_per_fa,
                "coupling": format!("{:?}", self.coupling),
            }),
            materials: serde_json::to_value(self.materials).unwrap_or_default(),
            geometry: serde_json::to_value(report).unwrap_or_default(),
        };
        // Recorded only for a density variant (drawn from `seed`, recorded above).
        for (key, count) in [
            ("extra_bundles", p.extra_bundles),
            ("extra_microtubules", p.extra_microtubules),
            ("extra_intermediate", p.extra_intermediate),
        ] {
            if count > 0 {
                description.params[key] = serde_json::json!(count);
            }
        }
        let prestress = crate::model::StepSpec {
            name: "prestress".into(),
            control: cellmech_fem::solve::StepControl {
                initial_increment: 0.25,
                max_increment: 0.5,
                ..self.step_control()
            },
            fixes: supports.clone(),
            displacements: Vec::new(),
            forces: Vec::new(),
            tools: Vec::new(),
        };
        Ok(crate::cell::BuiltCell {
            model: crate::model::ModelSpec {
                mesh,
                materials,
                structures,
                tools: Vec::new(),
                steps: Vec::new(),
                output: crate::model::OutputSpec::default(),
                supports: Vec::new(),
                shape_probes: vec![crate::model::ShapeProbeSpec {
                    name: "nucleus".into(),
                    node_set: "nucleus_surface".into(),
                    axis: 2,
                }],
                embedded: self.coupling.embeddings(),
                hanging: geometry.hanging.clone(),
                prestressed_reference: self.coupling.prestressed_reference(),
                rezone: None,
            },
            description,
            surface_set: "dome".into(),
            surface_faces: dome_faces,
            prestress,
            rotation_hold: supports,
            step_control: self.step_control(),
            auto_iteration: self.solver.iteration.is_none(),
            bfgs: self.solver.bfgs,
            site: report.site,
        })
    }
}
