//! Continuum blocks: an [`ElementSet`] (hence a [`Term`](crate::term::Term)) over a block of
//! hex8 elements with one hyperelastic law, [`NeoHookean`] unless another [`Hyperelastic`]
//! law is given (the kernel is monomorphised per law).

use crate::dof::DofMap;
use crate::element::hex8::{
    hex8_evaluate, hex8_max_log_strain_between, hex8_min_corner_jacobian_ratio, hex8_response,
    Hex8Formulation, Hex8Reference,
};
use crate::element::{ElementSet, KernelError};
use crate::material::{Hyperelastic, NeoHookean};
use crate::mesh::{ElementBlock, ElementKind};
use crate::term::{CellField, TermOutput};

/// A block of hexahedra sharing one material law `M` and formulation.
#[derive(Debug, Clone)]
pub struct ContinuumBlock<M: Hyperelastic = NeoHookean> {
    name: String,
    connectivity: Vec<[usize; 8]>,
    references: Vec<Hex8Reference>,
    /// Reference node coordinates per element (µm), for the corner Jacobians of
    /// [`hex8_min_corner_jacobian_ratio`] (outputs only, not the kernel's hot data).
    reference_nodes: Vec<[[f64; 3]; 8]>,
    material: M,
    formulation: Hex8Formulation,
}

/// Why a continuum block could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContinuumBlockError {
    /// The block holds elements that have no continuum kernel yet.
    #[error("element set '{block}' holds {kind} elements; only hex8 continuum elements are supported so far")]
    UnsupportedKind {
        /// Block name.
        block: String,
        /// Element kind name.
        kind: &'static str,
    },
    /// An element's reference geometry is degenerate or inverted.
    #[error("element {element} of set '{block}': {error}")]
    BadElement {
        /// Block name.
        block: String,
        /// Element index in the block.
        element: usize,
        /// The kernel's complaint.
        error: KernelError,
    },
}

impl<M: Hyperelastic> ContinuumBlock<M> {
    /// Precomputes the reference geometry of every element of `block`.
    pub fn new(
        block: &ElementBlock,
        nodes: &[[f64; 3]],
        material: M,
        formulation: Hex8Formulation,
    ) -> Result<Self, ContinuumBlockError> {
        if block.kind != ElementKind::Hex8 {
            return Err(ContinuumBlockError::UnsupportedKind {
                block: block.name.clone(),
                kind: block.kind.name(),
            });
        }
        let mut connectivity = Vec::with_capacity(block.len());
        let mut references = Vec::with_capacity(block.len());
        let mut reference_nodes = Vec::with_capacity(block.len());
        for (e, element) in block.elements().enumerate() {
            let conn: [usize; 8] = std::array::from_fn(|a| element[a]);
            let x0: [[f64; 3]; 8] = std::array::from_fn(|a| nodes[conn[a]]);
            let reference =
                Hex8Reference::new(&x0).map_err(|error| ContinuumBlockError::BadElement {
                    block: block.name.clone(),
                    element: e,
                    error,
                })?;
            connectivity.push(conn);
            references.push(reference);
            reference_nodes.push(x0);
        }
        Ok(ContinuumBlock {
            name: block.name.clone(),
            connectivity,
            references,
            reference_nodes,
            material,
            formulation,
        })
    }

    /// The material law.
    pub fn material(&self) -> M {
        self.material
    }

    /// Reference volume of the block (µm³).
    pub fn volume(&self) -> f64 {
        self.references.iter().map(Hex8Reference::volume).sum()
    }

    /// Element node lists.
    pub fn connectivity(&self) -> &[[usize; 8]] {
        &self.connectivity
    }

    /// Element `e`'s nodal displacements from the global DOF values `u`.
    fn element_displacements(&self, e: usize, u: &[f64], dof_map: &DofMap) -> [f64; 24] {
        let mut u_e = [0.0; 24];
        self.gather(e, u, dof_map, &mut u_e);
        u_e
    }
}

impl<M: Hyperelastic> ElementSet for ContinuumBlock<M> {
    const ELEMENT_DOFS: usize = 24;

    fn set_name(&self) -> &str {
        &self.name
    }

    fn element_count(&self) -> usize {
        self.connectivity.len()
    }

    fn element_nodes(&self, e: usize) -> &[usize] {
        &self.connectivity[e]
    }

    #[inline]
    fn evaluate_element(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let u: &[f64; 24] = u_e.try_into().expect("hex8 elements have 24 DOFs");
        let r: &mut [f64; 24] = residual.try_into().expect("hex8 residual has 24 entries");
        let k = tangent.map(|t| <&mut [f64; 576]>::try_from(t).expect("hex8 tangent is 24x24"));
        hex8_evaluate(
            &self.references[e],
            &self.material,
            self.formulation,
            u,
            r,
            k,
        )
    }

    fn follows_reference_moves(&self) -> bool {
        true
    }

    /// Recomputes the reference data of every element with a moved node.
    fn on_reference_moved(
        &mut self,
        reference: &[[f64; 3]],
        moved: &[bool],
        _u: &mut [f64],
        _dof_map: &DofMap,
    ) -> Result<(), String> {
        for (e, conn) in self.connectivity.iter().enumerate() {
            if !conn.iter().any(|&n| moved.get(n).copied().unwrap_or(false)) {
                continue;
            }
            let x0: [[f64; 3]; 8] = std::array::from_fn(|a| reference[conn[a]]);
            self.references[e] = Hex8Reference::new(&x0)
                .map_err(|error| format!("element {e} of set '{}': {error}", self.name))?;
            self.reference_nodes[e] = x0;
        }
        Ok(())
    }

    fn cell_outputs(&self, u: &[f64], dof_map: &DofMap) -> Result<Option<TermOutput>, KernelError> {
        let n = self.connectivity.len();
        let mut cauchy = Vec::with_capacity(6 * n);
        let mut von_mises = Vec::with_capacity(n);
        let mut log_strain = Vec::with_capacity(n);
        let mut volume_ratio = Vec::with_capacity(n);
        let mut pressure = Vec::with_capacity(n);
        let mut corner_ratio = Vec::with_capacity(n);
        for e in 0..n {
            let u_e = self.element_displacements(e, u, dof_map);
            corner_ratio.push(hex8_min_corner_jacobian_ratio(
                &self.reference_nodes[e],
                &u_e,
            ));
            let response =
                hex8_response(&self.references[e], &self.material, self.formulation, &u_e)?;
            cauchy.extend_from_slice(&response.cauchy);
            von_mises.push(response.von_mises);
            log_strain.push(response.max_principal_log_strain);
            volume_ratio.push(response.volume_ratio);
            pressure.push(response.pressure);
        }
        let field = |name: &str, components, values| CellField {
            name: name.into(),
            components,
            values,
        };
        Ok(Some(TermOutput {
            kind: ElementKind::Hex8,
            connectivity: self.connectivity.iter().flatten().copied().collect(),
            fields: vec![
                field("cauchy_stress_kPa", 6, cauchy),
                field("von_mises_kPa", 1, von_mises),
                field("max_principal_log_strain", 1, log_strain),
                field("volume_ratio", 1, volume_ratio),
                field("pressure_kPa", 1, pressure),
                field("min_corner_jacobian_ratio", 1, corner_ratio),
            ],
        }))
    }

    /// `<block>_max_principal_log_strain` and `<block>_max_von_mises_kPa`: the largest
    /// element values over the block (the element value is the volume average of the
    /// element's state; see `hex8_response`). NaN when an element cannot be evaluated.
    /// `<block>_min_corner_jacobian_ratio`: the smallest [`hex8_min_corner_jacobian_ratio`]
    /// over the block; ≤ 0 once an element has folded over (its map is no longer
    /// one-to-one), which the Gauss points alone do not see.
    fn curve_outputs(&self, u: &[f64], dof_map: &DofMap) -> Vec<(String, f64)> {
        let (mut strain, mut mises) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        let mut corner_ratio = f64::INFINITY;
        let mut failed = false;
        for e in 0..self.connectivity.len() {
            let u_e = self.element_displacements(e, u, dof_map);
            corner_ratio = corner_ratio.min(hex8_min_corner_jacobian_ratio(
                &self.reference_nodes[e],
                &u_e,
            ));
            match hex8_response(&self.references[e], &self.material, self.formulation, &u_e) {
                Ok(r) => {
                    strain = strain.max(r.max_principal_log_strain);
                    mises = mises.max(r.von_mises);
                }
                Err(_) => failed = true,
            }
        }
        if failed {
            (strain, mises) = (f64::NAN, f64::NAN);
        }
        vec![
            (format!("{}_max_principal_log_strain", self.name), strain),
            (format!("{}_max_von_mises_kPa", self.name), mises),
            (
                format!("{}_min_corner_jacobian_ratio", self.name),
                corner_ratio,
            ),
        ]
    }

    /// `<block>_max_principal_log_strain_from_reference`: the largest principal log strain
    /// of the deformation from the state `u_from` (e.g. a test's prestressed reference
    /// state), over the block's Gauss points. NaN when an element cannot be evaluated.
    fn curve_outputs_from(
        &self,
        u: &[f64],
        u_from: &[f64],
        dof_map: &DofMap,
    ) -> Vec<(String, f64)> {
        let mut strain = f64::NEG_INFINITY;
        for e in 0..self.connectivity.len() {
            match hex8_max_log_strain_between(
                &self.references[e],
                &self.element_displacements(e, u_from, dof_map),
                &self.element_displacements(e, u, dof_map),
            ) {
                Ok(s) => strain = strain.max(s),
                Err(_) => {
                    strain = f64::NAN;
                    break;
                }
            }
        }
        vec![(
            format!("{}_max_principal_log_strain_from_reference", self.name),
            strain,
        )]
    }
}
