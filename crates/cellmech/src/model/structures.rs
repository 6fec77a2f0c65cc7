//! Engine terms for the structures of a scenario: filament families as truss or beam sets,
//! membrane layers as membrane sets, and the DOF counts they need (6 at beam nodes).
//!
//! Prestrained truss families ramp their prestrain in over the first analysis step
//! (linear in the step time), so the first step finds the prestressed equilibrium.
//!
//! One engine set per family: all enabled truss groups of a family become one
//! [`TrussSet`] (one law per element), all beam groups of a family one [`BeamSet`], both
//! named after the family so that their curve columns are `<family>_...`. Disabled groups
//! are not built at all: DOFs that only they touched (interior filament nodes, beam
//! rotations) are held automatically by the engine.

use cellmech_fem::dof::DofMap;
use cellmech_fem::element::beam::{BeamError, BeamSet};
pub use cellmech_fem::element::membrane::MembraneLaw;
use cellmech_fem::element::membrane::{MembraneError, MembraneSet};
use cellmech_fem::element::truss::{TrussError, TrussSet};
use cellmech_fem::mesh::{ElementKind, Mesh};
use cellmech_fem::term::Term;

use cellmech_fem::element::beam::BeamSection;
use cellmech_fem::material::AxialLaw;

use super::filament::Filament;

/// The element and material of a resolved filament group.
#[derive(Debug, Clone, PartialEq)]
pub enum FilamentElement {
    /// Two-node trusses with this law.
    Truss(AxialLaw),
    /// Two-node corotational beams with this section (nodes carry 6 DOFs).
    Beam(BeamSection),
}

/// A resolved filament group: node pairs and their element, in internal units.
#[derive(Debug, Clone, PartialEq)]
pub struct FilamentSpec {
    /// Group name.
    pub name: String,
    /// Family name (curve-column prefix).
    pub family: String,
    /// Mesh node pairs of the elements.
    pub pairs: Vec<[usize; 2]>,
    /// The filaments the elements form: consecutive runs of `pairs` covering every element
    /// once, each a chain from its start to its end node, with its FA end if any (see
    /// [`super::filaments`]; [`Filament::chains`] when nothing more is known).
    pub filaments: Vec<Filament>,
    /// Element and material (family scale and prestrain override applied).
    pub element: FilamentElement,
    /// False when the family is switched off: the group is not built.
    pub enabled: bool,
}

/// A resolved membrane layer.
#[derive(Debug, Clone, PartialEq)]
pub struct MembraneSpec {
    /// Layer name.
    pub name: String,
    /// Family name.
    pub family: String,
    /// Quad4 faces (outward normals).
    pub faces: Vec<[usize; 4]>,
    /// Shear modulus G (kPa), family scale applied.
    pub shear_modulus: f64,
    /// Reference thickness (µm).
    pub thickness: f64,
    /// How the layer answers compression (carries it, or wrinkles: a tension field).
    pub law: MembraneLaw,
    /// False when the family is switched off.
    pub enabled: bool,
}

/// Every structure of a scenario besides the continuum blocks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StructuresSpec {
    /// Filament groups in file order.
    pub filaments: Vec<FilamentSpec>,
    /// Membrane layers in file order.
    pub membranes: Vec<MembraneSpec>,
}

impl StructuresSpec {
    /// Whether any enabled filament group is made of beams (then some nodes carry 6 DOFs).
    pub fn has_beams(&self) -> bool {
        self.filaments
            .iter()
            .any(|f| f.enabled && matches!(f.element, FilamentElement::Beam(_)))
    }
}

/// Why the structures could not be turned into engine terms.
#[derive(Debug, thiserror::Error)]
pub enum StructureBuildError {
    /// A truss set was rejected.
    #[error("filaments: {0}")]
    Truss(#[from] TrussError),
    /// A beam set was rejected.
    #[error("filaments: {0}")]
    Beam(#[from] BeamError),
    /// A membrane set was rejected.
    #[error("membrane: {0}")]
    Membrane(#[from] MembraneError),
}

/// DOFs per node: 6 at every node of an enabled beam group, 3 elsewhere (input for
/// [`DofMap::with_counts`]).
pub fn dofs_per_node(num_nodes: usize, spec: &StructuresSpec) -> Vec<usize> {
    let mut counts = vec![3; num_nodes];
    for f in spec.filaments.iter().filter(|f| f.enabled) {
        if let FilamentElement::Beam(_) = f.element {
            for &[a, b] in &f.pairs {
                for n in [a, b] {
                    if let Some(c) = counts.get_mut(n) {
                        *c = 6;
                    }
                }
            }
        }
    }
    counts
}

/// Which nodes an enabled filament or membrane uses.
pub fn enabled_structure_nodes(spec: &StructuresSpec, num_nodes: usize) -> Vec<bool> {
    let mut used = vec![false; num_nodes];
    for f in spec.filaments.iter().filter(|f| f.enabled) {
        for n in f.pairs.iter().flatten() {
            if let Some(u) = used.get_mut(*n) {
                *u = true;
            }
        }
    }
    for m in spec.membranes.iter().filter(|m| m.enabled) {
        for n in m.faces.iter().flatten() {
            if let Some(u) = used.get_mut(*n) {
                *u = true;
            }
        }
    }
    used
}

/// Per node, half the reference length of every enabled filament element through it (µm):
/// the length of fibre the node stands for (0 for nodes of no enabled filament).
pub fn enabled_tributary_lengths(spec: &StructuresSpec, mesh: &Mesh) -> Vec<f64> {
    let mut length = vec![0.0; mesh.num_nodes()];
    for f in spec.filaments.iter().filter(|f| f.enabled) {
        for &[a, b] in &f.pairs {
            let (Some(xa), Some(xb)) = (mesh.nodes.get(a), mesh.nodes.get(b)) else {
                continue;
            };
            let l = (0..3).map(|i| (xb[i] - xa[i]).powi(2)).sum::<f64>().sqrt();
            length[a] += 0.5 * l;
            length[b] += 0.5 * l;
        }
    }
    length
}

/// The family names of the enabled groups, in order of first appearance: the order of the
/// family terms [`structure_terms`] makes.
pub fn filament_families(spec: &StructuresSpec) -> Vec<&str> {
    let mut names: Vec<&str> = Vec::new();
    for f in spec.filaments.iter().filter(|f| f.enabled) {
        if !names.contains(&f.family.as_str()) {
            names.push(&f.family);
        }
    }
    names
}

/// Engine terms for every enabled filament family and membrane layer. `dof_map` must come
/// from [`dofs_per_node`] (beam nodes are checked).
pub fn structure_terms(
    mesh: &Mesh,
    spec: &StructuresSpec,
    dof_map: &DofMap,
) -> Result<Vec<Box<dyn Term>>, StructureBuildError> {
    structure_terms_carried(mesh, spec, dof_map, None)
}

/// [`structure_terms`] with beam families whose stress-free geometry moves in the first
/// step (`carried`).
pub fn structure_terms_carried(
    mesh: &Mesh,
    spec: &StructuresSpec,
    dof_map: &DofMap,
    carried: Option<&CarriedFamilies>,
) -> Result<Vec<Box<dyn Term>>, StructureBuildError> {
    let mut terms = filament_terms(mesh, spec, dof_map, carried)?;
    terms.extend(membrane_terms(mesh, spec)?);
    Ok(terms)
}

/// Beam families whose stress-free geometry moves during the first step to these node
/// positions ([`super::prestressed_reference`]).
pub struct CarriedFamilies<'a> {
    /// The families.
    pub families: &'a [String],
    /// Knots of the move: step time and the position of every node (µm).
    pub knots: &'a [(f64, Vec<[f64; 3]>)],
}

/// Engine terms for every enabled filament family, in family order.
fn filament_terms(
    mesh: &Mesh,
    spec: &StructuresSpec,
    dof_map: &DofMap,
    carried: Option<&CarriedFamilies>,
) -> Result<Vec<Box<dyn Term>>, StructureBuildError> {
    let mut terms: Vec<Box<dyn Term>> = Vec::new();
    for family in filament_families(spec) {
        let groups = spec
            .filaments
            .iter()
            .filter(|f| f.enabled && f.family == family);
        let mut pairs = Vec::new();
        let mut laws = Vec::new();
        let mut section = None;
        for g in groups {
            pairs.extend_from_slice(&g.pairs);
            match g.element {
                FilamentElement::Truss(law) => laws.extend(std::iter::repeat_n(law, g.pairs.len())),
                // resolve() guarantees one section per beam family.
                FilamentElement::Beam(s) => section = Some(s),
            }
        }
        match section {
            Some(section) => {
                let mut set =
                    BeamSet::from_coordinates(family, family, &mesh.nodes, &pairs, None, section)?;
                set.check_dof_map(dof_map)?;
                if let Some(c) = carried.filter(|c| c.families.iter().any(|f| f == family)) {
                    let knots: Vec<(f64, &[[f64; 3]])> =
                        c.knots.iter().map(|(t, x)| (*t, x.as_slice())).collect();
                    set.morph_reference_through(0, &knots)?;
                }
                terms.push(Box::new(set));
            }
            None => {
                let prestressed = laws.iter().any(|l| l.prestrain != 0.0);
                let mut set =
                    TrussSet::with_element_laws(family, family, &mesh.nodes, pairs, laws)?;
                if prestressed {
                    // A prestrained network is not in equilibrium with its initial geometry:
                    // the first step ramps the prestrain in so that Newton follows the
                    // equilibrium path instead of starting from the full imbalance.
                    set.ramp_prestrain_in_step(0);
                }
                terms.push(Box::new(set));
            }
        }
    }
    Ok(terms)
}

/// Engine terms for every enabled membrane layer.
fn membrane_terms(
    mesh: &Mesh,
    spec: &StructuresSpec,
) -> Result<Vec<Box<dyn Term>>, StructureBuildError> {
    let mut terms: Vec<Box<dyn Term>> = Vec::new();
    for m in spec.membranes.iter().filter(|m| m.enabled) {
        let set = MembraneSet::new(
            m.name.clone(),
            ElementKind::Quad4,
            m.faces.iter().flatten().copied().collect(),
            &mesh.nodes,
            m.shear_modulus,
            m.thickness,
        )?
        .with_law(m.law);
        terms.push(Box::new(set));
    }
    Ok(terms)
}

/// Relaxation blocks (`cellmech_fem::solve::Problem::set_relaxation_blocks`): for every
/// filament chain of an enabled beam group, the DOFs that only that chain's beams touch:
/// all six DOFs of an interior node that no continuum element, membrane face, truss or
/// other chain uses, and the rotations of a node no other chain uses (an FA end: its
/// translations belong to the cell surface). A hub shared by several chains (the
/// centrosome) stays global. Other terms that touch a block DOF (a tool's contact with the
/// filament, a foundation tie) take part in its local solve; the engine leaves out DOFs
/// that are prescribed or constrained.
pub fn relaxation_blocks(mesh: &Mesh, spec: &StructuresSpec, dof_map: &DofMap) -> Vec<Vec<usize>> {
    const SHARED: usize = usize::MAX;
    const NONE: usize = usize::MAX - 1;
    let n = mesh.num_nodes().min(dof_map.num_nodes());
    // Per node: the one chain whose beams use it (NONE, or SHARED when two do).
    let mut chain_of = vec![NONE; n];
    // Per node: used by anything translational other than beams.
    let mut other = vec![false; n];
    for block in &mesh.blocks {
        for &node in &block.connectivity {
            if node < n {
                other[node] = true;
            }
        }
    }
    for m in spec.membranes.iter().filter(|m| m.enabled) {
        for &node in m.faces.iter().flatten() {
            if node < n {
                other[node] = true;
            }
        }
    }
    let mut chains = 0;
    for f in spec.filaments.iter().filter(|f| f.enabled) {
        match f.element {
            FilamentElement::Truss(_) => {
                for &node in f.pairs.iter().flatten() {
                    if node < n {
                        other[node] = true;
                    }
                }
            }
            FilamentElement::Beam(_) => {
                for filament in &f.filaments {
                    let id = chains;
                    chains += 1;
                    for e in filament.elements.clone() {
                        let Some(pair) = f.pairs.get(e) else { continue };
                        for &node in pair {
                            if node < n {
                                chain_of[node] = match chain_of[node] {
                                    NONE => id,
                                    c if c == id => id,
                                    _ => SHARED,
                                };
                            }
                        }
                    }
                }
            }
        }
    }
    let mut blocks = vec![Vec::new(); chains];
    for node in 0..n {
        let c = chain_of[node];
        if c == NONE || c == SHARED || dof_map.count(node) != 6 {
            continue;
        }
        let first = if other[node] { 3 } else { 0 };
        blocks[c].extend((first..6).map(|k| dof_map.dof(node, k)));
    }
    blocks.retain(|b| !b.is_empty());
    blocks
}
