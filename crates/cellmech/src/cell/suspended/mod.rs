//! The suspended-cell bendo-tensegrity model: the geometry of [`SuspendedCellGeometry`]
//! turned into the parts every cellmech model is made of (mesh with node sets, continuum
//! materials, filament and membrane structures), plus minimal supports and the prestress
//! step. The same parts feed both the scenario path (`[cell]` in a scenario file) and
//! [`build_suspended_cell`] for library users, so there is one definition of the model.
//!
//! Defaults follow `shared/spec/cell-models.md` (internal units µm, nN, kPa):
//! cytoplasm G = 0.17 kPa, nucleus G = 1.7 kPa (ν = 0.49 for both, a parameter); CM
//! G = 333 kPa (E = 1 MPa, incompressible), thickness 0.01 µm; AF E = 2.6e6 kPa, d = 7 nm,
//! tension-only, prestrain 24 %; MT E = 1.2e6 kPa, 25/17 nm hollow, ν = 0.3; IF
//! E = 7.6e3 kPa, d = 10 nm, tension-only, slack 20 %.

use cellmech_fem::continuum::ContinuumBlock;
use cellmech_fem::dof::DofMap;
use cellmech_fem::element::beam::BeamSection;
use cellmech_fem::element::hex8::Hex8Formulation;
use cellmech_fem::material::{AxialLaw, NeoHookean};
use cellmech_fem::mesh::surface::boundary_quads;
use cellmech_fem::mesh::Mesh;
use cellmech_fem::solve::{Motion, Step};
use cellmech_fem::term::Term;

pub mod cytoskeleton;
pub mod density;
pub mod geometry;
mod layout;
mod materials;
pub mod params;
#[cfg(test)]
mod tests;

pub use cytoskeleton::{IfAnchorRule, MicrotubulePath};
pub use density::DensityParams;
pub use geometry::{
    icosidodecahedron_edges, icosidodecahedron_unit_vertices, FaOrientation, AF_COUNT, FA_COUNT,
    GOLDEN_RATIO,
};
pub use layout::*;
pub use materials::*;

use crate::model::filaments::{Filament, FilamentEnd};
use crate::model::structures::{FilamentElement, FilamentSpec, MembraneSpec, StructuresSpec};
use crate::model::MaterialAssignment;

/// Family names of the suspended cell's components (curve-column prefixes and
/// `[families.<name>]` keys).
pub mod family {
    /// Cell membrane.
    pub const MEMBRANE: &str = "membrane";
    /// Actin filaments.
    pub const ACTIN: &str = "actin";
    /// Microtubules.
    pub const MICROTUBULE: &str = "microtubule";
    /// Intermediate filaments.
    pub const INTERMEDIATE: &str = "intermediate";
}

/// Filament group of the density variant's extra AFs (family `actin`).
pub const EXTRA_ACTIN: &str = "actin-extra";
/// Filament group of the density variant's extra MTs (family `microtubule`).
pub const EXTRA_MICROTUBULE: &str = "microtubule-extra";
/// Filament group of the density variant's extra IFs (family `intermediate`).
pub const EXTRA_INTERMEDIATE: &str = "intermediate-extra";

/// Node sets of the 3-2-1 supports: all three components, y and z, z only.
pub const SUPPORT_SETS: [(&str, [bool; 3]); 3] = [
    ("support_xyz", [true, true, true]),
    ("support_yz", [false, true, true]),
    ("support_z", [false, false, true]),
];

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

/// The suspended cell as model parts: what a scenario resolves into.
#[derive(Debug, Clone)]
pub struct SuspendedCellParts {
    /// Geometry it was built from (FA nodes, routing, quality report).
    pub geometry: SuspendedCellGeometry,
    /// Mesh with the MT interior and centrosome nodes appended; node sets of the geometry
    /// plus `centrosome` and the support sets of [`SUPPORT_SETS`].
    pub mesh: Mesh,
    /// Cytoplasm and nucleus laws (mean dilatation).
    pub materials: Vec<MaterialAssignment>,
    /// Membrane and the AF, MT and IF families (switched-off components are disabled).
    pub structures: StructuresSpec,
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

pub(crate) fn component<E: std::fmt::Display>(
    component: &'static str,
) -> impl Fn(E) -> CellModelError {
    move |e| CellModelError::Component {
        component,
        message: e.to_string(),
    }
}

/// `solver.damping = "filament-drag"` damps the slip of filament nodes tied to the gel, so it
/// needs such ties (MTs on an elastic foundation): without them nothing but the filaments'
/// rotations would be damped.
pub(crate) fn check_damping(
    stabilization: Option<cellmech_fem::solve::Stabilization>,
    coupling: &Coupling,
) -> Result<(), CellModelError> {
    let relative =
        stabilization.is_some_and(|s| s.damping == cellmech_fem::solve::Damping::Relative);
    if relative && coupling.microtubule_foundation.is_none() {
        return Err(CellModelError::Component {
            component: "solver.damping",
            message: "expected filaments tied to the gel for \"filament-drag\" (it damps their \
                      slip): set `microtubules.coupling = \"foundation\"`, or \
                      `solver.damping = \"nodal\"`; found MTs that are not on an elastic \
                      foundation"
                .into(),
        });
    }
    Ok(())
}

fn positive(component: &'static str, what: &str, value: f64) -> Result<f64, CellModelError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(CellModelError::Component {
            component,
            message: format!("expected {what} > 0; found {value}"),
        })
    }
}

/// A tension-only truss law of a solid circular section (checked positive).
pub(crate) fn tension_only_law(
    component: &'static str,
    youngs_modulus: f64,
    diameter: f64,
) -> Result<AxialLaw, CellModelError> {
    let area = AxialLaw::solid_circle_area(positive(component, "diameter", diameter)?);
    Ok(AxialLaw::tension_only(
        positive(component, "Young's modulus", youngs_modulus)?,
        area,
    ))
}

/// Adds node sets `microtubule_interior` (every MT node but the centrosome and the FA) and
/// `microtubule_anchors` (every second interior node counted from the FA: the FA is a mesh
/// node, so the node next to it stays free and no two nodes held by the continuum are
/// neighbours on a chain; the node next to the centrosome is left out too, so that a tied
/// centrosome has a free neighbour, see [`EmbeddedNodes`]). `chains` run from the
/// centrosome to the FA.
pub(crate) fn insert_microtubule_node_sets(mesh: &mut Mesh, chains: &[Vec<usize>]) {
    let interior: Vec<usize> = chains
        .iter()
        .flat_map(|c| c[1..c.len().saturating_sub(1)].iter().copied())
        .collect();
    mesh.insert_node_set("microtubule_interior", interior);
    let anchors: Vec<usize> = chains
        .iter()
        .flat_map(|c| {
            let n = c.len() - 1;
            (2..n).filter(move |k| (n - k) % 2 == 0).map(move |k| c[k])
        })
        .collect();
    mesh.insert_node_set("microtubule_anchors", anchors);
}

/// The neo-Hookean, mean-dilatation laws of blocks `cytoplasm` and `nucleus` from their
/// (shear modulus, Poisson's ratio).
pub(crate) fn continuum_materials(
    cytoplasm: (f64, f64),
    nucleus: (f64, f64),
) -> Result<Vec<MaterialAssignment>, CellModelError> {
    [("cytoplasm", cytoplasm), ("nucleus", nucleus)]
        .into_iter()
        .map(|(name, (g, nu))| {
            Ok(MaterialAssignment {
                element_set: name.into(),
                law: NeoHookean::from_shear_poisson(g, nu).map_err(component("continuum"))?,
                formulation: Hex8Formulation::MeanDilatation,
            })
        })
        .collect()
}

/// The MT family: one hollow-section beam chain per MT, `chains` running from the
/// centrosome to the FA (the FA is each filament's anchored end).
pub(crate) fn microtubule_filaments(
    t: &MicrotubuleMaterial,
    chains: &[Vec<usize>],
    enabled: bool,
) -> Result<FilamentSpec, CellModelError> {
    let section = BeamSection::hollow_circular(
        t.youngs_modulus,
        t.poisson_ratio,
        t.outer_diameter,
        t.inner_diameter,
    )
    .map_err(component("microtubule"))?;
    Ok(FilamentSpec {
        name: family::MICROTUBULE.into(),
        family: family::MICROTUBULE.into(),
        filaments: Filament::consecutive(
            &chains.iter().map(|c| c.len() - 1).collect::<Vec<_>>(),
            Some(FilamentEnd::End),
        ),
        pairs: chains
            .iter()
            .flat_map(|c| c.windows(2).map(|w| [w[0], w[1]]))
            .collect(),
        element: FilamentElement::Beam(section),
        enabled,
    })
}

/// The IF family: one slack tension-only truss per IF, `pairs` running from the FA (each
/// filament's anchored start) to the nucleus surface.
pub(crate) fn intermediate_filaments(
    i: &IntermediateMaterial,
    pairs: &[[usize; 2]],
    enabled: bool,
) -> Result<FilamentSpec, CellModelError> {
    let law = tension_only_law("intermediate", i.youngs_modulus, i.diameter)?.with_slack(i.slack);
    Ok(FilamentSpec {
        name: family::INTERMEDIATE.into(),
        family: family::INTERMEDIATE.into(),
        filaments: Filament::one_per_element(pairs.len(), Some(FilamentEnd::Start)),
        pairs: pairs.to_vec(),
        element: FilamentElement::Truss(law),
        enabled,
    })
}

/// Node set of the AFs' interior nodes (when split into several trusses).
pub const ACTIN_INTERIOR: &str = "actin_interior";
/// Node set of the IFs' interior nodes (when split into several trusses).
pub const INTERMEDIATE_INTERIOR: &str = "intermediate_interior";

/// Splits each straight filament `[a, b]` into `elements` trusses: appends the interior
/// points (equally spaced on the chord) to `mesh.nodes` and returns the chained pairs, in
/// filament order, and the interior nodes. `elements` of 1 returns the pairs unchanged.
pub(crate) fn split_straight_filaments(
    mesh: &mut Mesh,
    pairs: &[[usize; 2]],
    elements: usize,
) -> (Vec<[usize; 2]>, Vec<usize>) {
    let elements = elements.max(1);
    let mut out = Vec::with_capacity(pairs.len() * elements);
    let mut interior = Vec::with_capacity(pairs.len() * (elements - 1));
    for &[a, b] in pairs {
        let (pa, pb) = (mesh.nodes[a], mesh.nodes[b]);
        let mut previous = a;
        for k in 1..elements {
            let t = k as f64 / elements as f64;
            let node = mesh.nodes.len();
            mesh.nodes
                .push(std::array::from_fn(|c| pa[c] + t * (pb[c] - pa[c])));
            interior.push(node);
            out.push([previous, node]);
            previous = node;
        }
        out.push([previous, b]);
    }
    (out, interior)
}

/// Builds the parts of the suspended cell: geometry, mesh, materials and structures.
pub fn suspended_cell_parts(
    params: &SuspendedCellParams,
    materials: &SuspendedCellMaterials,
    components: Components,
) -> Result<SuspendedCellParts, CellModelError> {
    let geometry = SuspendedCellGeometry::build(params)?;
    let mut mesh = geometry.mesh.clone();
    let chains = geometry.append_microtubule_nodes(&mut mesh);
    insert_microtubule_node_sets(&mut mesh, &chains);
    let m = materials;
    let assignments = continuum_materials(
        (m.cytoplasm_shear_modulus, m.cytoplasm_poisson_ratio),
        (m.nucleus_shear_modulus, m.nucleus_poisson_ratio),
    )?;
    let mut structures = StructuresSpec::default();
    // A pole refinement lists its outer faces (a coarse face covered by finer ones is
    // interior); a conforming mesh's are found from the mesh.
    let faces = if geometry.hanging.is_empty() {
        boundary_quads(&mesh, None).map_err(component("membrane"))?
    } else {
        geometry.boundary_faces.clone()
    };
    structures.membranes.push(MembraneSpec {
        name: family::MEMBRANE.into(),
        family: family::MEMBRANE.into(),
        faces,
        shear_modulus: positive("membrane", "shear modulus", m.membrane_shear_modulus)?,
        thickness: positive("membrane", "thickness", m.membrane_thickness)?,
        law: m.membrane_law,
        enabled: components.membrane,
    });
    let a = m.actin;
    let actin =
        tension_only_law("actin", a.youngs_modulus, a.diameter)?.with_prestrain(a.prestrain);
    // Filament identity: one AF per edge (both ends on FAs), one MT per chain (centrosome
    // first, FA last), one IF per [FA, nucleus anchor] pair.
    // AFs and IFs split for embedding (one truss each otherwise): their interior nodes
    // come after the MTs' (node sets `actin_interior`, `intermediate_interior`).
    let (af_pairs, af_interior) =
        split_straight_filaments(&mut mesh, &geometry.af_edges, params.af_elements);
    let (if_pairs, if_interior) = split_straight_filaments(
        &mut mesh,
        &geometry.intermediate_filaments,
        params.if_elements,
    );
    if params.af_elements > 1 {
        mesh.insert_node_set(ACTIN_INTERIOR, af_interior);
    }
    if params.if_elements > 1 {
        mesh.insert_node_set(INTERMEDIATE_INTERIOR, if_interior);
    }
    structures.filaments.push(FilamentSpec {
        name: family::ACTIN.into(),
        family: family::ACTIN.into(),
        filaments: Filament::consecutive(
            &vec![params.af_elements; geometry.af_edges.len()],
            Some(FilamentEnd::Both),
        ),
        pairs: af_pairs,
        element: FilamentElement::Truss(actin),
        enabled: components.actin,
    });
    let fa_mts = geometry.microtubules.len();
    structures.filaments.push(microtubule_filaments(
        &m.microtubule,
        &chains[..fa_mts],
        components.microtubules,
    )?);
    let mut ifs = intermediate_filaments(&m.intermediate, &if_pairs, components.intermediate)?;
    ifs.filaments = Filament::consecutive(
        &vec![params.if_elements; geometry.intermediate_filaments.len()],
        Some(FilamentEnd::Start),
    );
    structures.filaments.push(ifs);
    // The density variant's extra filaments: groups of their own after the published ones
    // (whose filament ids therefore do not change), in the same families (so `[families]`
    // switches and scales them too), with the same materials. None by default.
    let extra = &geometry.extra;
    if !extra.actin.is_empty() {
        structures.filaments.push(FilamentSpec {
            name: EXTRA_ACTIN.into(),
            family: family::ACTIN.into(),
            filaments: Filament::one_per_element(extra.actin.len(), Some(FilamentEnd::Both)),
            pairs: extra.actin.clone(),
            element: FilamentElement::Truss(actin),
            enabled: components.actin,
        });
    }
    if chains.len() > fa_mts {
        let mut group =
            microtubule_filaments(&m.microtubule, &chains[fa_mts..], components.microtubules)?;
        group.name = EXTRA_MICROTUBULE.into();
        structures.filaments.push(group);
    }
    if !extra.intermediate.is_empty() {
        let mut group = intermediate_filaments(
            &m.intermediate,
            &extra.intermediate,
            components.intermediate,
        )?;
        group.name = EXTRA_INTERMEDIATE.into();
        structures.filaments.push(group);
    }
    for (set, nodes) in SUPPORT_SETS
        .iter()
        .zip(minimal_support_nodes(&mesh, 0.5 * params.nucleus_diameter))
    {
        mesh.insert_node_set(set.0, vec![nodes]);
    }
    Ok(SuspendedCellParts {
        geometry,
        mesh,
        materials: assignments,
        structures,
    })
}

/// The built model for library use: mesh, DOF map, engine terms and support DOFs.
pub struct SuspendedCellModel {
    /// Geometry it was built from.
    pub geometry: SuspendedCellGeometry,
    /// Mesh with the MT interior and centrosome nodes appended.
    pub mesh: Mesh,
    /// DOF map (6 DOFs on MT nodes, 3 elsewhere).
    pub dof_map: DofMap,
    /// Engine terms: cytoplasm, nucleus, then the enabled structures.
    pub terms: Vec<Box<dyn Term>>,
    /// Statically determinate supports (3-2-1 on nucleus nodes): they carry no load when
    /// the model is self-equilibrated.
    pub supports: Vec<usize>,
    /// The FA plaques' ties (each reference node = Σ w·plaque node, in every translation),
    /// `None` with single-node FAs: build the engine problem with
    /// [`cellmech_fem::solve::Problem::with_constraints`] (see [`SuspendedCellModel::problem`]).
    pub constraints: Option<cellmech_fem::constraint::LinearConstraints>,
}

impl SuspendedCellModel {
    /// The engine problem of this model (its terms and, with FA plaques, their ties),
    /// solved by `solver`. Consumes the terms.
    pub fn problem(
        self,
        solver: Box<dyn cellmech_fem::linsolve::LinearSolver>,
    ) -> Result<cellmech_fem::solve::Problem, cellmech_fem::solve::SolveError> {
        match self.constraints {
            Some(c) => {
                cellmech_fem::solve::Problem::with_constraints(self.dof_map, self.terms, c, solver)
            }
            None => cellmech_fem::solve::Problem::new(self.dof_map, self.terms, solver),
        }
    }
}

/// Builds the suspended cell as engine terms (the AF prestrain ramps in during step 0).
pub fn build_suspended_cell(
    params: &SuspendedCellParams,
    materials: &SuspendedCellMaterials,
    components: Components,
) -> Result<SuspendedCellModel, CellModelError> {
    if params.pole_refinement.levels > 0 {
        return Err(CellModelError::Component {
            component: "mesh",
            message: "expected refinement.levels = 0 for the engine-term builder, which has no \
                      hanging-node ties; build a refined cell with `SuspendedCell::build`"
                .into(),
        });
    }
    if params.af_elements > 1 || params.if_elements > 1 {
        return Err(CellModelError::Component {
            component: "filaments",
            message: format!(
                "expected one truss per AF and IF for the engine-term builder, which has no \
                 embedding (split ones would be free collinear trusses, a mechanism); found \
                 {} per AF and {} per IF: build the embedded cell with `SuspendedCell::build`",
                params.af_elements, params.if_elements
            ),
        });
    }
    let parts = suspended_cell_parts(params, materials, components)?;
    let mesh = parts.mesh;
    let dof_map = DofMap::with_counts(&crate::model::structures::dofs_per_node(
        mesh.num_nodes(),
        &parts.structures,
    ));
    let mut terms: Vec<Box<dyn Term>> = Vec::new();
    for assignment in &parts.materials {
        let block = mesh
            .block(&assignment.element_set)
            .ok_or(CellModelError::Component {
                component: "continuum",
                message: format!("the mesh has no block '{}'", assignment.element_set),
            })?;
        let term = ContinuumBlock::new(block, &mesh.nodes, assignment.law, assignment.formulation)
            .map_err(component("continuum"))?;
        terms.push(Box::new(term));
    }
    terms.extend(
        crate::model::structures::structure_terms(&mesh, &parts.structures, &dof_map)
            .map_err(component("structures"))?,
    );
    let supports = SUPPORT_SETS
        .iter()
        .flat_map(|(set, comps)| {
            let node = mesh.node_sets[*set][0];
            (0..3)
                .filter(|&c| comps[c])
                .map(move |c| (node, c))
                .collect::<Vec<_>>()
        })
        .map(|(n, c)| dof_map.dof(n, c))
        .collect();
    // Without a pole refinement (refused above) the only ties are the FA plaques'.
    let constraints = if parts.geometry.ties.is_empty() {
        None
    } else {
        let mut c = cellmech_fem::constraint::LinearConstraints::new(dof_map.num_dofs());
        cellmech_fem::constraint::hanging::tie_hanging_nodes(
            &mut c,
            &dof_map,
            &parts.geometry.ties,
        )
        .map_err(|e| CellModelError::Component {
            component: "focal adhesions",
            message: format!("the FA plaques could not be tied: {e}"),
        })?;
        Some(c)
    };
    Ok(SuspendedCellModel {
        geometry: parts.geometry,
        mesh,
        dof_map,
        terms,
        supports,
        constraints,
    })
}

/// 3-2-1 support nodes inside the nucleus: the node nearest the centre (x, y, z), the one
/// nearest half-way to the nucleus surface on +x (y, z) and on +y (z).
fn minimal_support_nodes(mesh: &Mesh, nucleus_radius: f64) -> [usize; 3] {
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
    [
        nearest([0.0; 3]),
        nearest([r, 0.0, 0.0]),
        nearest([0.0, r, 0.0]),
    ]
}

/// The first step of every analysis: the AF prestrain ramps in and the free cell finds its
/// prestressed equilibrium, held only by the minimal supports.
pub fn prestress_step(model: &SuspendedCellModel) -> Step {
    let mut step = Step::new("prestress");
    step.prescribed = model.supports.iter().map(|&d| (d, Motion::Hold)).collect();
    step.control.initial_increment = 0.5;
    step.control.max_increment = 1.0;
    step
}

/// How the cytoskeleton is tied to the continuum (`shared/spec/cell-models.md`, "The
/// hybrid model idea": a modelling choice the published findings decide).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Coupling {
    /// The MTs' interior nodes follow the cytoplasm they lie in (embedded elements).
    pub microtubules_embedded: bool,
    /// The MTs' interior nodes are tied to the material points they lie in by elastic ties
    /// with this foundation modulus (kPa = nN/µm², per µm of MT): an elastic foundation
    /// (`microtubules.coupling = "foundation"`). Excludes `microtubules_embedded`.
    pub microtubule_foundation: Option<f64>,
    /// Which interior nodes are embedded when `microtubules_embedded`.
    pub embedded_nodes: EmbeddedNodes,
    /// The centrosome node follows the cytoplasm it lies in.
    pub centrosome_tied: bool,
    /// With `centrosome_tied`: the radius (µm) of the ball of gel whose mean displacement
    /// the centrosome follows (`microtubules.centrosome_radius`; 0: the point it sits at).
    pub centrosome_radius: f64,
    /// The MTs are stress-free in the prestressed cell (`microtubules.stress_free =
    /// "prestressed-cell"`) instead of in the mesh: see
    /// [`crate::model::prestressed_reference`].
    pub microtubules_prestressed: bool,
}

/// Which interior MT nodes follow the continuum (`[cell.microtubules] embedded_nodes`).
///
/// A beam element whose two end nodes are both held by the continuum is a straight column
/// between fixed points: its translations cannot move, only its end rotations can, and
/// under compression it buckles in a perfect bifurcation at its own Euler load
/// (≈ 12 EI/L² ≈ 0.03 nN for the 2.7 µm elements of the default MT). With every interior
/// node embedded all 240 elements are such columns; the gel's contraction in the prestress
/// compresses them past that load within the first percent of the ramp, and the tangent
/// then has ~300 negative pivots (measured: docs/embedded-elements.md, "The embedded
/// cell"). With every second node embedded, each span between two held nodes is two
/// elements meeting at the MT's curvature: it bends like a free MT segment (no
/// bifurcation, positive-definite tangent), and it carries tension once the gel between
/// its anchors stretches it straight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EmbeddedNodes {
    /// Every second interior node counted from the FA, never the centrosome's neighbour
    /// (node set `microtubule_anchors`, 90 nodes for 8 elements per MT).
    #[default]
    Alternate,
    /// Every interior node (node set `microtubule_interior`).
    All,
}

impl Coupling {
    /// The MT family stress-free in the prestressed cell, when chosen.
    pub fn prestressed_reference(&self) -> Option<crate::model::PrestressedReference> {
        self.microtubules_prestressed
            .then(|| crate::model::PrestressedReference {
                families: vec![family::MICROTUBULE.into()],
                host_blocks: vec!["cytoplasm".into(), "nucleus".into()],
                tolerance: EMBED_TOLERANCE,
            })
    }

    /// The model's embeddings (node sets `microtubule_anchors` or `microtubule_interior`,
    /// and `centrosome`; `microtubule_interior` with elastic ties for the foundation).
    pub fn embeddings(&self) -> Vec<crate::model::EmbedSpec> {
        let spec = continuum_embedding;
        let mut out = Vec::new();
        if let Some(k) = self.microtubule_foundation {
            out.push(crate::model::EmbedSpec {
                foundation_modulus: Some(k),
                ..spec("microtubule_interior")
            });
        } else if self.microtubules_embedded {
            out.push(spec(match self.embedded_nodes {
                EmbeddedNodes::Alternate => "microtubule_anchors",
                EmbeddedNodes::All => "microtubule_interior",
            }));
        }
        if self.centrosome_tied {
            out.push(crate::model::EmbedSpec {
                radius: self.centrosome_radius,
                ..spec("centrosome")
            });
        }
        out
    }
}

/// The node set `name` embedded in the cell's continuum (cytoplasm and nucleus).
fn continuum_embedding(name: &str) -> crate::model::EmbedSpec {
    crate::model::EmbedSpec {
        name: name.into(),
        node_set: name.into(),
        host_blocks: vec!["cytoplasm".into(), "nucleus".into()],
        tolerance: EMBED_TOLERANCE,
        foundation_modulus: None,
        radius: 0.0,
    }
}

/// The interior nodes of split AFs and IFs, embedded in the continuum: a family is split
/// (`actin.elements`, `intermediate.elements` > 1) only to be embedded.
fn split_filament_embeddings(params: &SuspendedCellParams) -> Vec<crate::model::EmbedSpec> {
    [
        (params.af_elements, ACTIN_INTERIOR),
        (params.if_elements, INTERMEDIATE_INTERIOR),
    ]
    .into_iter()
    .filter(|&(elements, _)| elements > 1)
    .map(|(_, set)| continuum_embedding(set))
    .collect()
}

/// Largest overshoot (in natural coordinates) of an embedded node outside its host: MT
/// points near the cell surface can lie just outside the faceted mesh of the sphere.
pub const EMBED_TOLERANCE: f64 = 0.25;

/// The suspended cell as a library value: its declared parameters resolved
/// ([`params::SUSPENDED_CELL`]), materials, and which components are in.
#[derive(Debug, Clone, PartialEq)]
pub struct SuspendedCell {
    /// Geometry, mesh and routing parameters.
    pub params: SuspendedCellParams,
    /// Materials and sections.
    pub materials: SuspendedCellMaterials,
    /// Components present (all by default; `[families]` in a scenario switches them off).
    pub components: Components,
    /// How the cytoskeleton is tied to the continuum.
    pub coupling: Coupling,
    /// How every analysis step is solved (`[cell.solver]`).
    pub solver: crate::cell::SolverSettings,
}

impl Default for SuspendedCell {
    /// The published model with the spec's values.
    fn default() -> Self {
        Self::from_values(&crate::param::ParamValues::defaults(
            &params::SUSPENDED_CELL,
        ))
    }
}

impl SuspendedCell {
    /// The base control of every step: default increments and criteria with the cell's
    /// stabilisation and iteration method.
    pub fn step_control(&self) -> cellmech_fem::solve::StepControl {
        self.solver.step_control()
    }

    /// The cell from resolved values of [`params::SUSPENDED_CELL`].
    pub fn from_values(values: &crate::param::ParamValues) -> Self {
        let (params, materials) = params::from_values(values);
        SuspendedCell {
            params,
            materials,
            components: Components::default(),
            coupling: params::coupling_from_values(values),
            solver: crate::cell::SolverSettings::from_values(values),
        }
    }

    /// The cell refined under a protocol's tools (`refinement`, from
    /// `crate::protocol::Protocol::pole_refinement`) unless its own `refinement.levels` is
    /// above 0, which then replaces the protocol's.
    pub fn with_tool_refinement(
        &self,
        refinement: Option<PoleRefinement>,
    ) -> std::borrow::Cow<'_, Self> {
        match refinement {
            Some(refinement) if self.params.pole_refinement.levels == 0 => {
                let mut cell = self.clone();
                cell.params.pole_refinement = refinement;
                std::borrow::Cow::Owned(cell)
            }
            _ => std::borrow::Cow::Borrowed(self),
        }
    }

    /// Builds the cell: mesh, materials, structures, 3-2-1 supports, the nucleus shape
    /// probe, and the prestress step every protocol starts with.
    pub fn build(&self) -> Result<crate::cell::BuiltCell, CellModelError> {
        check_damping(self.solver.stabilization, &self.coupling)?;
        let parts = suspended_cell_parts(&self.params, &self.materials, self.components)?;
        let params = &self.params;
        let report = &parts.geometry.report;
        let supports: Vec<(String, [bool; 3])> = SUPPORT_SETS
            .iter()
            .map(|(name, comps)| (name.to_string(), *comps))
            .collect();
        let mut description = crate::cell::CellDescription {
            model: "suspended".into(),
            seed: params.seed,
            cell_diameter: params.cell_diameter,
            nucleus_diameter: params.nucleus_diameter,
            axis: 0,
            params: serde_json::json!({
                "cell_diameter_um": params.cell_diameter,
                "nucleus_diameter_um": params.nucleus_diameter,
                "mesh": {
                    "core_divisions": params.mesh.core_divisions,
                    "shell_layers": params.mesh.shell_layers,
                    "outer_layers": params.mesh.outer_layers,
                    "hex8_elements": params.mesh.elements(),
                },
                "fa_orientation": format!("{:?}", params.fa_orientation),
                "fa_radius_um": params.fa_radius,
                "fa_coupling": params.fa_coupling,
                "mt_elements": params.mt_elements,
                "mt_bow": [params.mt_bow_min, params.mt_bow_max],
                "mt_clearance_margin_um": params.mt_clearance_margin,
                "centrosome_gap_um": params.centrosome_gap,
                "centrosome_direction": params.centrosome_direction,
                "ifs_per_fa": params.ifs_per_fa,
                "if_phase_rad": params.if_phase,
                "if_anchor_rule": format!("{:?}", params.if_anchor_rule),
            }),
            materials: serde_json::to_value(self.materials).unwrap_or_default(),
            geometry: serde_json::json!({
                "max_fa_snap_um": report.max_snap_distance,
                "fa_plaque_nodes": report.fa_plaque_nodes,
                "max_relative_fa_snap": report.max_relative_snap_distance,
                "min_scaled_jacobian_after_snap": report.min_scaled_jacobian_after_snap,
                "af_length_um": report.af_length,
                "min_mt_clearance_um": report.min_mt_clearance,
                "mt_curvature_range_per_um": [report.mt_curvature_range.0, report.mt_curvature_range.1],
                "max_if_anchor_error_um": report.max_if_anchor_error,
                "max_if_tangency_error_deg": report.max_if_tangency_error_deg,
                "max_if_nucleus_penetration_um": report.max_if_nucleus_penetration,
            }),
        };
        if !params.density.is_empty() {
            // Recorded only for a density variant, so that the published model's record
            // is unchanged; the extras are drawn from `seed` (recorded above).
            description.params["density"] = serde_json::json!(params.density);
        }
        let surface_faces = parts
            .structures
            .membranes
            .iter()
            .find(|m| m.family == family::MEMBRANE)
            .map(|m| m.faces.clone())
            .unwrap_or_default();
        // The prestress ramp in two increments when the MT nodes are free: 22 Newton
        // iterations on the default mesh instead of 64 in ten (each increment took 6-7, so
        // 0.1 never grew), the same equilibrium to 3e-10 (docs/performance.md); a whole ramp
        // in one increment fails and is cut back, which costs more. MTs held by the gel
        // (embedded, foundation) buckle with the gel's contraction: their prestress keeps
        // the small increments it converges with (with 0.5 it ends out of equilibrium).
        // MTs stress-free in the prestressed cell follow the gel without buckling.
        let held_mts = (self.coupling.microtubules_embedded
            || self.coupling.microtubule_foundation.is_some())
            && !self.coupling.microtubules_prestressed;
        let (initial_increment, max_increment) = if held_mts { (0.1, 0.2) } else { (0.5, 1.0) };
        let prestress = crate::model::StepSpec {
            name: "prestress".into(),
            control: cellmech_fem::solve::StepControl {
                initial_increment,
                max_increment,
                ..self.step_control()
            },
            fixes: supports.clone(),
            displacements: Vec::new(),
            forces: Vec::new(),
            tools: Vec::new(),
        };
        let rotation_hold = vec![supports[2].clone()];
        Ok(crate::cell::BuiltCell {
            model: crate::model::ModelSpec {
                mesh: parts.mesh,
                materials: parts.materials,
                structures: parts.structures,
                tools: Vec::new(),
                steps: Vec::new(),
                output: crate::model::OutputSpec::default(),
                supports,
                shape_probes: vec![crate::model::ShapeProbeSpec {
                    name: "nucleus".into(),
                    node_set: "inner_surface".into(),
                    axis: 0,
                }],
                embedded: [
                    self.coupling.embeddings(),
                    split_filament_embeddings(&self.params),
                ]
                .concat(),
                hanging: parts.geometry.ties.clone(),
                prestressed_reference: self.coupling.prestressed_reference(),
                rezone: None,
            },
            description,
            surface_set: "surface".into(),
            surface_faces,
            prestress,
            rotation_hold,
            step_control: self.step_control(),
            auto_iteration: self.solver.iteration.is_none(),
            bfgs: self.solver.bfgs,
            site: None,
        })
    }
}
