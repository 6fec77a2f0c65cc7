//! The suspended-cell bendo-tensegrity model: the geometry of [`SuspendedCellGeometry`]
//! turned into engine terms (continuum, membrane, AF/MT/IF families) with minimal supports
//! and a prestress step.
//!
//! Defaults follow `shared/spec/cell-models.md` (internal units µm, nN, kPa):
//! cytoplasm G = 0.17 kPa, nucleus G = 1.7 kPa (ν = 0.49 for both, a parameter); CM
//! G = 333 kPa (E = 1 MPa, incompressible), thickness 0.01 µm; AF E = 2.6e6 kPa, d = 7 nm,
//! tension-only, prestrain 24 %; MT E = 1.2e6 kPa, 25/17 nm hollow, ν = 0.3; IF
//! E = 7.6e3 kPa, d = 10 nm, tension-only, slack 20 %.

use cellmech_fem::continuum::ContinuumBlock;
use cellmech_fem::dof::DofMap;
use cellmech_fem::element::beam::{BeamSection, BeamSet};
use cellmech_fem::element::hex8::Hex8Formulation;
use cellmech_fem::element::membrane::MembraneSet;
use cellmech_fem::element::truss::TrussSet;
use cellmech_fem::material::{AxialLaw, NeoHookean};
use cellmech_fem::mesh::surface::boundary_quads;
use cellmech_fem::mesh::{ElementKind, Mesh};
use cellmech_fem::solve::{Motion, Step};
use cellmech_fem::term::Term;

use super::{CellGeometryError, SuspendedCellGeometry, SuspendedCellParams};

/// Material and section parameters of the suspended cell (internal units).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SuspendedCellMaterials {
    /// Cytoplasm shear modulus (kPa).
    pub cytoplasm_shear_modulus: f64,
    /// Nucleus shear modulus (kPa).
    pub nucleus_shear_modulus: f64,
    /// Poisson's ratio of cytoplasm and nucleus (compressibility switch).
    pub continuum_poisson_ratio: f64,
    /// Cell-membrane shear modulus (kPa).
    pub membrane_shear_modulus: f64,
    /// Cell-membrane thickness (µm).
    pub membrane_thickness: f64,
    /// AF Young's modulus (kPa), diameter (µm) and prestrain.
    pub actin: (f64, f64, f64),
    /// MT Young's modulus (kPa), outer and inner diameter (µm), Poisson's ratio.
    pub microtubule: (f64, f64, f64, f64),
    /// IF Young's modulus (kPa), diameter (µm) and slack.
    pub intermediate: (f64, f64, f64),
}

impl Default for SuspendedCellMaterials {
    fn default() -> Self {
        SuspendedCellMaterials {
            cytoplasm_shear_modulus: 0.17,
            nucleus_shear_modulus: 1.7,
            continuum_poisson_ratio: 0.49,
            membrane_shear_modulus: 1000.0 / 3.0,
            membrane_thickness: 0.01,
            actin: (2.6e6, 0.007, 0.24),
            microtubule: (1.2e6, 0.025, 0.017, 0.3),
            intermediate: (7.6e3, 0.010, 0.20),
        }
    }
}

/// Which components are in the model (the disruption studies switch them off).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Components {
    /// Cell membrane.
    pub membrane: bool,
    /// Actin filaments.
    pub actin: bool,
    /// Microtubules.
    pub microtubules: bool,
    /// Intermediate filaments.
    pub intermediate: bool,
}

impl Default for Components {
    fn default() -> Self {
        Components {
            membrane: true,
            actin: true,
            microtubules: true,
            intermediate: true,
        }
    }
}

/// The built model: mesh (MT nodes appended), DOF map, terms and supports.
pub struct SuspendedCellModel {
    /// Geometry it was built from.
    pub geometry: SuspendedCellGeometry,
    /// Mesh with the MT interior and centrosome nodes appended.
    pub mesh: Mesh,
    /// DOF map (6 DOFs on MT nodes, 3 elsewhere).
    pub dof_map: DofMap,
    /// Engine terms: cytoplasm, nucleus, then membrane, AFs, MTs, IFs when present.
    pub terms: Vec<Box<dyn Term>>,
    /// Statically determinate supports (3-2-1 on nucleus nodes): they carry no load when
    /// the model is self-equilibrated.
    pub supports: Vec<usize>,
}

/// Why the model could not be built.
#[derive(Debug, thiserror::Error)]
pub enum CellModelError {
    /// The geometry is impossible.
    #[error(transparent)]
    Geometry(#[from] CellGeometryError),
    /// A component could not be built.
    #[error("{component}: {message}")]
    Component {
        /// Which component.
        component: &'static str,
        /// What went wrong.
        message: String,
    },
}

fn component<E: std::fmt::Display>(component: &'static str) -> impl Fn(E) -> CellModelError {
    move |e| CellModelError::Component {
        component,
        message: e.to_string(),
    }
}

/// Builds the suspended cell.
pub fn build_suspended_cell(
    params: &SuspendedCellParams,
    materials: &SuspendedCellMaterials,
    components: Components,
) -> Result<SuspendedCellModel, CellModelError> {
    let geometry = SuspendedCellGeometry::build(params)?;
    let mut mesh = geometry.mesh.clone();
    let chains = if components.microtubules {
        geometry.append_microtubule_nodes(&mut mesh)
    } else {
        Vec::new()
    };
    let m = materials;
    let nu = m.continuum_poisson_ratio;
    let mut terms: Vec<Box<dyn Term>> = Vec::new();
    for (name, g) in [
        ("cytoplasm", m.cytoplasm_shear_modulus),
        ("nucleus", m.nucleus_shear_modulus),
    ] {
        let law = NeoHookean::from_shear_poisson(g, nu).map_err(component("continuum"))?;
        let block = mesh.block(name).ok_or(CellModelError::Component {
            component: "continuum",
            message: format!("the mesh has no block '{name}'"),
        })?;
        let term = ContinuumBlock::new(block, &mesh.nodes, law, Hex8Formulation::MeanDilatation)
            .map_err(component("continuum"))?;
        terms.push(Box::new(term));
    }
    if components.membrane {
        let faces = boundary_quads(&mesh, None).map_err(component("membrane"))?;
        let connectivity = faces.iter().flatten().copied().collect();
        let set = MembraneSet::new(
            "membrane",
            ElementKind::Quad4,
            connectivity,
            &mesh.nodes,
            m.membrane_shear_modulus,
            m.membrane_thickness,
        )
        .map_err(component("membrane"))?;
        terms.push(Box::new(set));
    }
    if components.actin {
        let (e, d, prestrain) = m.actin;
        let law =
            AxialLaw::tension_only(e, AxialLaw::solid_circle_area(d)).with_prestrain(prestrain);
        let mut set = TrussSet::new(
            "actin",
            "actin",
            &mesh.nodes,
            geometry.af_edges.clone(),
            law,
        )
        .map_err(component("actin"))?;
        set.ramp_prestrain_in_step(0);
        terms.push(Box::new(set));
    }
    let mut dofs_per_node = vec![3; mesh.num_nodes()];
    if components.microtubules {
        let (e, d_out, d_in, nu_mt) = m.microtubule;
        let section = BeamSection::hollow_circular(e, nu_mt, d_out, d_in)
            .map_err(component("microtubule"))?;
        let pairs: Vec<[usize; 2]> = chains
            .iter()
            .flat_map(|c| c.windows(2).map(|w| [w[0], w[1]]))
            .collect();
        let set = BeamSet::from_coordinates(
            "microtubules",
            "microtubule",
            &mesh.nodes,
            &pairs,
            None,
            section,
        )
        .map_err(component("microtubule"))?;
        set.mark_rotational_nodes(&mut dofs_per_node)
            .map_err(component("microtubule"))?;
        terms.push(Box::new(set));
    }
    if components.intermediate {
        let (e, d, slack) = m.intermediate;
        let law = AxialLaw::tension_only(e, AxialLaw::solid_circle_area(d)).with_slack(slack);
        let set = TrussSet::new(
            "intermediate",
            "intermediate",
            &mesh.nodes,
            geometry.intermediate_filaments.clone(),
            law,
        )
        .map_err(component("intermediate"))?;
        terms.push(Box::new(set));
    }
    let dof_map = DofMap::with_counts(&dofs_per_node);
    let supports = minimal_supports(&mesh, &dof_map, 0.5 * params.nucleus_diameter);
    Ok(SuspendedCellModel {
        geometry,
        mesh,
        dof_map,
        terms,
        supports,
    })
}

/// 3-2-1 supports on nucleus nodes: the centre (x, y, z), a node on the +x axis (y, z) and
/// one on the +y axis (z).
fn minimal_supports(mesh: &Mesh, dofs: &DofMap, nucleus_radius: f64) -> Vec<usize> {
    let nearest = |p: [f64; 3]| {
        (0..mesh.num_nodes())
            .min_by(|&a, &b| {
                let d = |n: usize| {
                    (0..3)
                        .map(|k| (mesh.nodes[n][k] - p[k]).powi(2))
                        .sum::<f64>()
                };
                d(a).total_cmp(&d(b))
            })
            .unwrap_or(0)
    };
    let r = 0.5 * nucleus_radius;
    let (a, b, c) = (
        nearest([0.0; 3]),
        nearest([r, 0.0, 0.0]),
        nearest([0.0, r, 0.0]),
    );
    vec![
        dofs.dof(a, 0),
        dofs.dof(a, 1),
        dofs.dof(a, 2),
        dofs.dof(b, 1),
        dofs.dof(b, 2),
        dofs.dof(c, 2),
    ]
}

/// The first step of every analysis: the AF prestrain ramps in and the free cell finds its
/// prestressed equilibrium, held only by the minimal supports.
pub fn prestress_step(model: &SuspendedCellModel) -> Step {
    let mut step = Step::new("prestress");
    step.prescribed = model.supports.iter().map(|&d| (d, Motion::Hold)).collect();
    step.control.initial_increment = 0.1;
    step.control.max_increment = 0.2;
    step
}
