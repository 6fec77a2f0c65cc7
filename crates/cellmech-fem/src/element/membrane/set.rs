//! A membrane set (quad4 or tri3, one law and thickness) as an [`ElementSet`], with
//! per-element outputs.

use super::kernel::{
    membrane_evaluate, membrane_state, MembraneLaw, MembraneState, Quad4Reference, Tri3Reference,
};
use crate::dof::DofMap;
use crate::element::{ElementSet, KernelError};
use crate::mesh::{ElementBlock, ElementKind};
use crate::term::{CellField, TermOutput};

/// Invalid input when building a [`MembraneSet`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MembraneError {
    /// The element kind is not a surface kind.
    #[error("membrane set '{set}': expected quad4 or tri3 elements, found {kind}")]
    UnsupportedKind { set: String, kind: &'static str },
    /// A material or geometric parameter is out of range.
    #[error("membrane set '{set}': {parameter} must be a finite number > 0, found {value}")]
    InvalidParameter {
        set: String,
        parameter: &'static str,
        value: f64,
    },
    /// The connectivity length is not a multiple of the nodes per element.
    #[error("membrane set '{set}': connectivity length {len} is not a multiple of {per}")]
    RaggedConnectivity { set: String, len: usize, per: usize },
    /// A connectivity entry refers to a missing node.
    #[error(
        "membrane set '{set}': element {element} refers to node {node}, but there are only {num_nodes} nodes"
    )]
    MissingNode {
        set: String,
        element: usize,
        node: usize,
        num_nodes: usize,
    },
    /// The reference geometry of an element is degenerate.
    #[error("membrane set '{set}': element {element}: {source}")]
    DegenerateElement {
        set: String,
        element: usize,
        source: KernelError,
    },
}

#[derive(Debug, Clone)]
enum References {
    Quad4(Vec<Quad4Reference>),
    Tri3(Vec<Tri3Reference>),
}

/// A set of membrane elements of one kind (quad4 or tri3) with one shear modulus `μ` (kPa)
/// and one reference thickness `H` (µm). A disabled set contributes nothing (no elements)
/// and writes no output, so a model can switch a layer off without changing its mesh.
#[derive(Debug, Clone)]
pub struct MembraneSet {
    name: String,
    kind: ElementKind,
    connectivity: Vec<usize>,
    shear_modulus: f64,
    thickness: f64,
    law: MembraneLaw,
    enabled: bool,
    references: References,
}

impl MembraneSet {
    /// Builds the set and precomputes every element's reference data from `nodes`.
    pub fn new(
        name: impl Into<String>,
        kind: ElementKind,
        connectivity: Vec<usize>,
        nodes: &[[f64; 3]],
        shear_modulus: f64,
        thickness: f64,
    ) -> Result<Self, MembraneError> {
        let set: String = name.into();
        if kind != ElementKind::Quad4 && kind != ElementKind::Tri3 {
            return Err(MembraneError::UnsupportedKind {
                set,
                kind: kind.name(),
            });
        }
        for (parameter, value) in [("shear modulus", shear_modulus), ("thickness", thickness)] {
            if !(value > 0.0 && value.is_finite()) {
                return Err(MembraneError::InvalidParameter {
                    set,
                    parameter,
                    value,
                });
            }
        }
        let per = kind.nodes_per_element();
        if !connectivity.len().is_multiple_of(per) {
            return Err(MembraneError::RaggedConnectivity {
                set,
                len: connectivity.len(),
                per,
            });
        }
        let mut coords = Vec::with_capacity(connectivity.len());
        for (i, &node) in connectivity.iter().enumerate() {
            match nodes.get(node) {
                Some(x) => coords.push(*x),
                None => {
                    return Err(MembraneError::MissingNode {
                        set,
                        element: i / per,
                        node,
                        num_nodes: nodes.len(),
                    });
                }
            }
        }
        let wrap = |element: usize, source: KernelError| MembraneError::DegenerateElement {
            set: set.clone(),
            element,
            source,
        };
        let references = if kind == ElementKind::Quad4 {
            let refs = coords
                .chunks_exact(4)
                .enumerate()
                .map(|(e, c)| Quad4Reference::new([c[0], c[1], c[2], c[3]]).map_err(|s| wrap(e, s)))
                .collect::<Result<Vec<_>, _>>()?;
            References::Quad4(refs)
        } else {
            let refs = coords
                .chunks_exact(3)
                .enumerate()
                .map(|(e, c)| Tri3Reference::new([c[0], c[1], c[2]]).map_err(|s| wrap(e, s)))
                .collect::<Result<Vec<_>, _>>()?;
            References::Tri3(refs)
        };
        Ok(MembraneSet {
            name: set,
            kind,
            connectivity,
            shear_modulus,
            thickness,
            law: MembraneLaw::Elastic,
            enabled: true,
            references,
        })
    }

    /// Builds the set from a quad4 or tri3 mesh block (e.g. from
    /// [`crate::mesh::surface::quad_block`]), keeping the block's name.
    pub fn from_block(
        block: &ElementBlock,
        nodes: &[[f64; 3]],
        shear_modulus: f64,
        thickness: f64,
    ) -> Result<Self, MembraneError> {
        Self::new(
            block.name.clone(),
            block.kind,
            block.connectivity.clone(),
            nodes,
            shear_modulus,
            thickness,
        )
    }

    /// The same set under `law` (default [`MembraneLaw::Elastic`]).
    pub fn with_law(mut self, law: MembraneLaw) -> Self {
        self.law = law;
        self
    }

    /// How the sheet answers compression.
    pub fn law(&self) -> MembraneLaw {
        self.law
    }

    /// Switches the whole set on or off.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// Whether the set contributes to the model.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Element kind (quad4 or tri3).
    pub fn kind(&self) -> ElementKind {
        self.kind
    }

    /// Shear modulus μ (kPa).
    pub fn shear_modulus(&self) -> f64 {
        self.shear_modulus
    }

    /// Reference thickness H (µm).
    pub fn thickness(&self) -> f64 {
        self.thickness
    }

    /// Flat node connectivity.
    pub fn connectivity(&self) -> &[usize] {
        &self.connectivity
    }

    fn per(&self) -> usize {
        self.kind.nodes_per_element()
    }

    /// State of element `e` at its displacements `u_e` (see [`membrane_state`]).
    pub fn element_state(&self, e: usize, u_e: &[f64]) -> Result<MembraneState, KernelError> {
        let (mu, h) = (self.shear_modulus, self.thickness);
        match &self.references {
            References::Quad4(r) => membrane_state(&r[e], self.law, mu, h, u_e),
            References::Tri3(r) => membrane_state(&r[e], self.law, mu, h, u_e),
        }
    }
}

impl ElementSet for MembraneSet {
    const ELEMENT_DOFS: usize = 12;

    fn set_name(&self) -> &str {
        &self.name
    }

    fn element_count(&self) -> usize {
        if self.enabled {
            self.connectivity.len() / self.per()
        } else {
            0
        }
    }

    fn element_nodes(&self, e: usize) -> &[usize] {
        let per = self.per();
        &self.connectivity[e * per..(e + 1) * per]
    }

    fn follows_reference_moves(&self) -> bool {
        true
    }

    /// Recomputes the reference data of every element with a moved node (the membrane is
    /// hyperelastic: its state is its deformation alone).
    fn on_reference_moved(
        &mut self,
        reference: &[[f64; 3]],
        moved: &[bool],
        _u: &mut [f64],
        _dof_map: &DofMap,
    ) -> Result<(), String> {
        let per = self.per();
        let name = &self.name;
        let is_moved = |n: usize| moved.get(n).copied().unwrap_or(false);
        for (e, conn) in self.connectivity.chunks_exact(per).enumerate() {
            if !conn.iter().any(|&n| is_moved(n)) {
                continue;
            }
            let wrap = |error: KernelError| format!("element {e} of membrane '{name}': {error}");
            match &mut self.references {
                References::Quad4(r) => {
                    r[e] = Quad4Reference::new(std::array::from_fn(|a| reference[conn[a]]))
                        .map_err(wrap)?;
                }
                References::Tri3(r) => {
                    r[e] = Tri3Reference::new(std::array::from_fn(|a| reference[conn[a]]))
                        .map_err(wrap)?;
                }
            }
        }
        Ok(())
    }

    fn evaluate_element(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let (mu, h) = (self.shear_modulus, self.thickness);
        match &self.references {
            References::Quad4(r) => {
                membrane_evaluate(&r[e], self.law, mu, h, u_e, residual, tangent)
            }
            References::Tri3(r) => {
                membrane_evaluate(&r[e], self.law, mu, h, u_e, residual, tangent)
            }
        }
    }

    /// Cells with `membrane_tension_nN_per_um` (2 principal true tensions, largest first),
    /// `thickness_um` and `area_stretch`, averaged over each element's quadrature points.
    fn cell_outputs(&self, u: &[f64], dof_map: &DofMap) -> Result<Option<TermOutput>, KernelError> {
        if !self.enabled {
            return Ok(None);
        }
        let per = self.per();
        let count = self.connectivity.len() / per;
        let mut tension = Vec::with_capacity(2 * count);
        let mut thickness = Vec::with_capacity(count);
        let mut area = Vec::with_capacity(count);
        let mut u_e = [0.0; 12];
        for e in 0..count {
            self.gather(e, u, dof_map, &mut u_e);
            let s = self.element_state(e, &u_e[..3 * per])?;
            tension.extend(s.principal_tensions);
            thickness.push(s.thickness);
            area.push(s.area_stretch);
        }
        let field = |name: &str, components, values| CellField {
            name: name.into(),
            components,
            values,
        };
        Ok(Some(TermOutput {
            kind: self.kind,
            connectivity: self.connectivity.clone(),
            fields: vec![
                field("membrane_tension_nN_per_um", 2, tension),
                field("thickness_um", 1, thickness),
                field("area_stretch", 1, area),
            ],
        }))
    }
}
