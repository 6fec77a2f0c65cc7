//! Pressure terms on a [`SurfaceVolume`]: a prescribed pressure ([`PressureLoad`]) and a
//! prescribed volume with the pressure as a multiplier ([`VolumeControl`]).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use super::surface::{PressureError, SurfaceVolume};
use crate::dof::DofMap;
use crate::element::{ElementSet, KernelError};

/// A pressure value shared between a [`PressureLoad`] and its caller, who may change it
/// between steps after the term has been moved into a problem.
#[derive(Debug, Clone, Default)]
pub struct PressureHandle(Arc<AtomicU64>);

impl PressureHandle {
    /// Sets the pressure (kPa; positive pushes along the outward normal, inflating a closed
    /// surface).
    pub fn set(&self, pressure: f64) {
        self.0.store(pressure.to_bits(), Ordering::Relaxed);
    }

    /// The current pressure (kPa).
    pub fn get(&self) -> f64 {
        f64::from_bits(self.0.load(Ordering::Relaxed))
    }
}

/// A prescribed uniform pressure `p` on a surface: `Π = −p V(x)`, residual `−p ∂V/∂x`,
/// tangent `−p ∂²V/∂x²` (see the module notes for open surfaces).
#[derive(Debug, Clone)]
pub struct PressureLoad {
    surface: SurfaceVolume,
    pressure: PressureHandle,
}

impl PressureLoad {
    /// A pressure term on `surface`, starting at pressure `pressure` (kPa).
    pub fn new(surface: SurfaceVolume, pressure: f64) -> Self {
        let handle = PressureHandle::default();
        handle.set(pressure);
        PressureLoad {
            surface,
            pressure: handle,
        }
    }

    /// Sets the pressure (kPa) used from the next evaluation on.
    pub fn set_pressure(&self, pressure: f64) {
        self.pressure.set(pressure);
    }

    /// The current pressure (kPa).
    pub fn pressure(&self) -> f64 {
        self.pressure.get()
    }

    /// A handle to change the pressure after the term is boxed into a problem.
    pub fn pressure_handle(&self) -> PressureHandle {
        self.pressure.clone()
    }

    /// The loaded surface.
    pub fn surface(&self) -> &SurfaceVolume {
        &self.surface
    }
}

impl ElementSet for PressureLoad {
    const ELEMENT_DOFS: usize = 12;

    fn set_name(&self) -> &str {
        &self.surface.name
    }

    fn element_count(&self) -> usize {
        self.surface.num_faces()
    }

    fn element_nodes(&self, e: usize) -> &[usize] {
        self.surface.face(e)
    }

    fn evaluate_element(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let p = self.pressure.get();
        let nd = 3 * self.surface.nodes_per_face();
        let mut tangent = tangent;
        let volume = self
            .surface
            .face_volume(e, u_e, residual, tangent.as_deref_mut());
        residual[..nd].iter_mut().for_each(|r| *r *= -p);
        if let Some(t) = tangent {
            t[..nd * nd].iter_mut().for_each(|k| *k *= -p);
        }
        Ok(-p * volume)
    }
}

/// Volume control of a closed surface: the enclosed volume change `ΔV` is a DOF that the
/// caller prescribes (e.g. `Motion::To`), and the pressure `p` is a free DOF (a Lagrange
/// multiplier), both on an auxiliary node that no other term uses:
/// `Π = −p (V(x) − V(X) − ΔV)`, split per face as `−p (V_e(x) − V_e(X) − ΔV/n_faces)`.
///
/// Stationarity in `p` enforces `V(x) = V(X) + ΔV`; in `x` it gives the pressure load
/// `p ∂V/∂x`. At a converged state the DOF value `p` (and the reaction on the `ΔV` DOF) is
/// the pressure that holds the volume. The tangent is symmetric but indefinite (saddle point):
/// use an LDLᵀ or LU solver. Component 2 of the auxiliary node is unused (the solver holds it).
#[derive(Debug, Clone)]
pub struct VolumeControl {
    surface: SurfaceVolume,
    auxiliary_node: usize,
    face_reference_volume: Vec<f64>,
}

impl VolumeControl {
    /// Volume control of `surface` with pressure and volume-change DOFs on `auxiliary_node`
    /// (components 0 and 1), which must exist in the DOF map and carry no element.
    pub fn new(surface: SurfaceVolume, auxiliary_node: usize) -> Result<Self, PressureError> {
        if let Some(e) =
            (0..surface.num_faces()).find(|&e| surface.face(e).contains(&auxiliary_node))
        {
            return Err(PressureError::AuxiliaryNodeOnSurface {
                set: surface.name.clone(),
                node: auxiliary_node,
                face: e,
            });
        }
        let n = surface.nodes_per_face();
        let zero = [0.0; 12];
        let mut grad = [0.0; 12];
        let face_reference_volume = (0..surface.num_faces())
            .map(|e| surface.face_volume(e, &zero[..3 * n], &mut grad, None))
            .collect();
        Ok(VolumeControl {
            surface,
            auxiliary_node,
            face_reference_volume,
        })
    }

    /// Global DOF of the pressure multiplier `p` (kPa).
    pub fn pressure_dof(&self, dof_map: &DofMap) -> usize {
        dof_map.dof(self.auxiliary_node, 0)
    }

    /// Global DOF of the prescribed volume change `ΔV` (µm³).
    pub fn volume_change_dof(&self, dof_map: &DofMap) -> usize {
        dof_map.dof(self.auxiliary_node, 1)
    }

    /// The reference enclosed volume `V(X)` (µm³).
    pub fn reference_volume(&self) -> f64 {
        self.face_reference_volume.iter().sum()
    }

    /// The controlled surface.
    pub fn surface(&self) -> &SurfaceVolume {
        &self.surface
    }
}

impl ElementSet for VolumeControl {
    const ELEMENT_DOFS: usize = 14;

    fn set_name(&self) -> &str {
        &self.surface.name
    }

    fn element_count(&self) -> usize {
        self.surface.num_faces()
    }

    /// The face's nodes; the element's DOFs add the auxiliary node's pressure and volume
    /// change (see [`ElementSet::element_dofs_into`] below).
    fn element_nodes(&self, e: usize) -> &[usize] {
        self.surface.face(e)
    }

    /// The face nodes' translations, then `p` and `ΔV` of the auxiliary node.
    fn element_dofs_into(&self, e: usize, dof_map: &DofMap, dofs: &mut [usize]) -> usize {
        let mut nd = 0;
        for &node in self.surface.face(e) {
            for c in 0..3 {
                dofs[nd] = dof_map.dof(node, c);
                nd += 1;
            }
        }
        dofs[nd] = self.pressure_dof(dof_map);
        dofs[nd + 1] = self.volume_change_dof(dof_map);
        nd + 2
    }

    fn evaluate_element(
        &self,
        e: usize,
        u_e: &[f64],
        residual: &mut [f64],
        tangent: Option<&mut [f64]>,
    ) -> Result<f64, KernelError> {
        let nd = 3 * self.surface.nodes_per_face();
        let m = nd + 2;
        let (p, dv) = (u_e[nd], u_e[nd + 1]);
        let share = 1.0 / self.surface.num_faces() as f64;
        let mut grad = [0.0; 12];
        let mut hess = [0.0; 144];
        let want = tangent.is_some();
        let v = self.surface.face_volume(
            e,
            &u_e[..nd],
            &mut grad,
            if want {
                Some(&mut hess[..nd * nd])
            } else {
                None
            },
        );
        let constraint = v - self.face_reference_volume[e] - share * dv;
        for i in 0..nd {
            residual[i] = -p * grad[i];
        }
        residual[nd] = -constraint;
        residual[nd + 1] = p * share;
        if let Some(t) = tangent {
            t[..m * m].fill(0.0);
            for i in 0..nd {
                for j in 0..nd {
                    t[i * m + j] = -p * hess[i * nd + j];
                }
                t[i * m + nd] = -grad[i];
                t[nd * m + i] = -grad[i];
            }
            t[nd * m + nd + 1] = share;
            t[(nd + 1) * m + nd] = share;
        }
        Ok(-p * constraint)
    }
}
