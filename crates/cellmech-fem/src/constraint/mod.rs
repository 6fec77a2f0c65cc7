//! Linear multipoint constraints `u_s = Σ_k w_k u_{m_k}` eliminated exactly from the system.
//!
//! A constraint makes one **slave** DOF a fixed linear combination of **master** DOFs. It
//! knows nothing about elements or meshes: the embedded-element technique
//! ([`embed::embed_translations`]) produces one constraint per translational DOF of an
//! embedded node, with the host hex8's shape-function values as weights; the hanging nodes
//! of a locally refined mesh ([`hanging::tie_hanging_nodes`]) are tied the same way, and any
//! linear, homogeneous tie can be expressed so.
//!
//! Rules, checked when a constraint is added (clear errors, never panics):
//! * DOF indices exist, weights are finite, a slave is constrained once;
//! * a master is never a slave (no chains), so `u = T ū` with `ū` the unconstrained DOFs
//!   is explicit and the reduced system is `Tᵀ K T`, `Tᵀ r` ([`condense`]);
//!   [`LinearConstraints::add_resolved`] substitutes tied masters by their own masters.
//!
//! Weights that are exactly zero are dropped, and repeated masters are merged.

pub mod condense;
pub mod embed;
pub mod hanging;

/// Why a constraint could not be added.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConstraintError {
    /// A DOF index is beyond the DOF map.
    #[error("constraint on DOF {slave}: DOF {dof} does not exist ({num_dofs} DOFs)")]
    UnknownDof {
        /// The slave of the constraint.
        slave: usize,
        /// The offending index.
        dof: usize,
        /// Number of DOFs.
        num_dofs: usize,
    },
    /// A weight is NaN or infinite.
    #[error(
        "constraint on DOF {slave}: the weight of master DOF {master} is not finite ({weight})"
    )]
    NotFinite {
        /// The slave.
        slave: usize,
        /// The master.
        master: usize,
        /// The weight.
        weight: f64,
    },
    /// The slave is already constrained.
    #[error("DOF {slave} is already constrained (a DOF can be the slave of one constraint only)")]
    AlreadySlave {
        /// The slave.
        slave: usize,
    },
    /// The slave is a master of an existing constraint, or a master is already a slave.
    #[error(
        "constraint on DOF {slave}: DOF {dof} would be both a master and a slave (masters must \
         be unconstrained DOFs)"
    )]
    MasterIsSlave {
        /// The slave of the constraint being added.
        slave: usize,
        /// The DOF that would be both.
        dof: usize,
    },
    /// A constraint with no (non-zero) master would fix the slave at zero.
    #[error("constraint on DOF {slave} has no master with a non-zero weight")]
    NoMaster {
        /// The slave.
        slave: usize,
    },
    /// The constraint set was built for another number of DOFs.
    #[error("the constraints were built for {constraints} DOFs but the model has {model}")]
    SizeMismatch {
        /// DOFs of the constraint set.
        constraints: usize,
        /// DOFs of the model.
        model: usize,
    },
}

/// A set of linear constraints `u_s = Σ w_k u_{m_k}` over `num_dofs` DOFs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LinearConstraints {
    num_dofs: usize,
    /// Constraint index of each DOF that is a slave (`u32::MAX` otherwise).
    slave_index: Vec<u32>,
    /// Number of constraints each DOF is a master of.
    master_count: Vec<u32>,
    slaves: Vec<usize>,
    /// Constraint `c` has masters `masters[offsets[c]..offsets[c+1]]`.
    offsets: Vec<usize>,
    masters: Vec<usize>,
    weights: Vec<f64>,
}

const NOT_SLAVE: u32 = u32::MAX;

impl LinearConstraints {
    /// An empty set over `num_dofs` DOFs.
    pub fn new(num_dofs: usize) -> Self {
        LinearConstraints {
            num_dofs,
            slave_index: vec![NOT_SLAVE; num_dofs],
            master_count: vec![0; num_dofs],
            slaves: Vec::new(),
            offsets: vec![0],
            masters: Vec::new(),
            weights: Vec::new(),
        }
    }

    /// Adds `u_slave = Σ w u_master` over `(master, w)` pairs. Nothing is added on error.
    pub fn add(&mut self, slave: usize, masters: &[(usize, f64)]) -> Result<(), ConstraintError> {
        let n = self.num_dofs;
        let unknown = |dof| ConstraintError::UnknownDof {
            slave,
            dof,
            num_dofs: n,
        };
        if slave >= n {
            return Err(unknown(slave));
        }
        if self.slave_index[slave] != NOT_SLAVE {
            return Err(ConstraintError::AlreadySlave { slave });
        }
        if self.master_count[slave] > 0 {
            return Err(ConstraintError::MasterIsSlave { slave, dof: slave });
        }
        let mut merged: Vec<(usize, f64)> = Vec::with_capacity(masters.len());
        for &(master, weight) in masters {
            if master >= n {
                return Err(unknown(master));
            }
            if !weight.is_finite() {
                return Err(ConstraintError::NotFinite {
                    slave,
                    master,
                    weight,
                });
            }
            if master == slave || self.slave_index[master] != NOT_SLAVE {
                return Err(ConstraintError::MasterIsSlave { slave, dof: master });
            }
            match merged.iter_mut().find(|(m, _)| *m == master) {
                Some(entry) => entry.1 += weight,
                None => merged.push((master, weight)),
            }
        }
        merged.retain(|&(_, w)| w != 0.0);
        if merged.is_empty() {
            return Err(ConstraintError::NoMaster { slave });
        }
        merged.sort_unstable_by_key(|&(m, _)| m);
        self.slave_index[slave] = self.slaves.len() as u32;
        self.slaves.push(slave);
        for (m, w) in merged {
            self.master_count[m] += 1;
            self.masters.push(m);
            self.weights.push(w);
        }
        self.offsets.push(self.masters.len());
        Ok(())
    }

    /// Like [`LinearConstraints::add`], but a master that is already a slave is replaced by
    /// its own masters, weights multiplied (`u_s = Σ w u_m` with `u_m = Σ v u_k`). Use it to
    /// tie a node to DOFs that may be tied themselves, e.g. an embedded node whose host has
    /// hanging corner nodes. The slave must still not be a master of an existing tie.
    pub fn add_resolved(
        &mut self,
        slave: usize,
        masters: &[(usize, f64)],
    ) -> Result<(), ConstraintError> {
        let mut expanded: Vec<(usize, f64)> = Vec::with_capacity(masters.len());
        for &(master, weight) in masters {
            match self.masters_of(master) {
                Some((ms, ws)) if master != slave => {
                    expanded.extend(ms.iter().zip(ws).map(|(&m, &w)| (m, w * weight)))
                }
                _ => expanded.push((master, weight)),
            }
        }
        self.add(slave, &expanded)
    }

    /// Number of DOFs of the model the set is built for.
    pub fn num_dofs(&self) -> usize {
        self.num_dofs
    }

    /// Number of constraints (= constrained DOFs).
    pub fn len(&self) -> usize {
        self.slaves.len()
    }

    /// True when there is no constraint.
    pub fn is_empty(&self) -> bool {
        self.slaves.is_empty()
    }

    /// Whether `dof` is a slave.
    pub fn is_slave(&self, dof: usize) -> bool {
        self.slave_index.get(dof).is_some_and(|&c| c != NOT_SLAVE)
    }

    /// Whether `dof` is a master of at least one constraint.
    pub fn is_master(&self, dof: usize) -> bool {
        self.master_count.get(dof).is_some_and(|&c| c > 0)
    }

    /// The slave DOFs, in the order the constraints were added.
    pub fn slaves(&self) -> &[usize] {
        &self.slaves
    }

    /// Masters and weights of the constraint on `slave` (`None` if it is not a slave).
    pub fn masters_of(&self, slave: usize) -> Option<(&[usize], &[f64])> {
        let c = *self.slave_index.get(slave)?;
        (c != NOT_SLAVE).then(|| self.constraint(c as usize))
    }

    /// Masters and weights of constraint `c`.
    pub fn constraint(&self, c: usize) -> (&[usize], &[f64]) {
        let range = self.offsets[c]..self.offsets[c + 1];
        (&self.masters[range.clone()], &self.weights[range])
    }

    /// Total number of (slave, master) weights.
    pub fn num_weights(&self) -> usize {
        self.masters.len()
    }

    /// Overwrites every slave entry of `u` with `Σ w u_m` (`u = T ū`). Works for values,
    /// increments and corrections alike (the constraints are homogeneous).
    pub fn expand(&self, u: &mut [f64]) {
        for (c, &s) in self.slaves.iter().enumerate() {
            let (masters, weights) = self.constraint(c);
            u[s] = masters.iter().zip(weights).map(|(&m, &w)| w * u[m]).sum();
        }
    }

    /// Moves every slave entry of the force-like vector `r` to its masters
    /// (`r_m += w r_s`, then `r_s = 0`): `Tᵀ r` written on the full DOF vector.
    pub fn condense(&self, r: &mut [f64]) {
        for (c, &s) in self.slaves.iter().enumerate() {
            let value = std::mem::take(&mut r[s]);
            let (masters, weights) = self.constraint(c);
            for (&m, &w) in masters.iter().zip(weights) {
                r[m] += w * value;
            }
        }
    }

    /// The nodal forces on the masters equivalent to a force `value` on `dof`: `[(dof,
    /// value)]` for an unconstrained DOF, `[(m, w·value)]` for a slave. Use it to apply a
    /// load at an embedded node (the solver rejects loads on slave DOFs).
    pub fn distribute(&self, dof: usize, value: f64) -> Vec<(usize, f64)> {
        match self.masters_of(dof) {
            Some((masters, weights)) => masters
                .iter()
                .zip(weights)
                .map(|(&m, &w)| (m, w * value))
                .collect(),
            None => vec![(dof, value)],
        }
    }

    /// Sets every slave to `Σ w u_m` of its masters (masters are never slaves, so one
    /// pass satisfies every constraint).
    pub fn enforce(&self, u: &mut [f64]) {
        for c in 0..self.slaves.len() {
            u[self.slaves[c]] = self.interpolated(c, u);
        }
    }

    /// Largest |u_s − Σ w u_m| over the constraints (0 when `u` satisfies them exactly).
    pub fn violation(&self, u: &[f64]) -> f64 {
        (0..self.slaves.len())
            .map(|c| (u[self.slaves[c]] - self.interpolated(c, u)).abs())
            .fold(0.0, f64::max)
    }

    /// `Σ w u_m` of constraint `c`'s masters.
    fn interpolated(&self, c: usize, u: &[f64]) -> f64 {
        let (masters, weights) = self.constraint(c);
        masters.iter().zip(weights).map(|(&m, &w)| w * u[m]).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constraints_reject_chains_duplicates_and_bad_indices_with_clear_errors() {
        let mut c = LinearConstraints::new(6);
        c.add(0, &[(1, 0.25), (2, 0.75), (1, 0.0)]).unwrap();
        assert_eq!(c.masters_of(0), Some((&[1, 2][..], &[0.25, 0.75][..])));
        let mut u = [5.0, 2.0, 4.0, 0.0, 0.0, 0.0];
        assert!(c.violation(&u) > 1.0);
        c.enforce(&mut u);
        assert_eq!(u[0], 0.25 * 2.0 + 0.75 * 4.0);
        assert_eq!(c.violation(&u), 0.0);
        assert_eq!(
            c.add(0, &[(3, 1.0)]),
            Err(ConstraintError::AlreadySlave { slave: 0 })
        );
        let e = c.add(1, &[(3, 1.0)]).unwrap_err();
        assert_eq!(e, ConstraintError::MasterIsSlave { slave: 1, dof: 1 });
        assert!(e.to_string().contains("both a master and a slave"), "{e}");
        let e = c.add(3, &[(0, 1.0)]).unwrap_err();
        assert_eq!(e, ConstraintError::MasterIsSlave { slave: 3, dof: 0 });
        let e = c.add(3, &[(9, 1.0)]).unwrap_err();
        assert!(
            e.to_string().contains("DOF 9 does not exist (6 DOFs)"),
            "{e}"
        );
        assert!(matches!(
            c.add(3, &[(4, f64::NAN)]),
            Err(ConstraintError::NotFinite { .. })
        ));
        assert_eq!(
            c.add(3, &[(4, 0.5), (4, -0.5)]),
            Err(ConstraintError::NoMaster { slave: 3 })
        );
        assert_eq!(c.len(), 1, "failed additions leave the set unchanged");
        c.add(3, &[(4, 0.5), (2, 0.5)]).unwrap();
        let mut u = vec![9.0, 1.0, 2.0, 9.0, 4.0, 5.0];
        c.expand(&mut u);
        assert_eq!(u, vec![1.75, 1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(c.violation(&u), 0.0);
        let mut r = vec![4.0, 0.0, 0.0, 2.0, 0.0, 0.0];
        c.condense(&mut r);
        assert_eq!(r, vec![0.0, 1.0, 4.0, 0.0, 1.0, 0.0]);
        assert_eq!(c.distribute(3, 2.0), vec![(2, 1.0), (4, 1.0)]);
        assert_eq!(c.distribute(5, 2.0), vec![(5, 2.0)]);
    }

    #[test]
    fn constraints_add_resolved_substitutes_tied_masters() {
        let mut c = LinearConstraints::new(6);
        c.add(2, &[(0, 0.5), (1, 0.5)]).unwrap();
        // u5 = 0.5 u2 + 0.5 u1 = 0.25 u0 + 0.75 u1.
        c.add_resolved(5, &[(2, 0.5), (1, 0.5)]).unwrap();
        assert_eq!(c.masters_of(5), Some((&[0, 1][..], &[0.25, 0.75][..])));
        let mut u = vec![4.0, 8.0, 0.0, 0.0, 0.0, 0.0];
        c.expand(&mut u);
        assert_eq!((u[2], u[5]), (6.0, 7.0));
        // A master of an existing tie still cannot become a slave.
        assert_eq!(
            c.add_resolved(0, &[(3, 1.0)]),
            Err(ConstraintError::MasterIsSlave { slave: 0, dof: 0 })
        );
        assert_eq!(
            c.add_resolved(3, &[(3, 1.0)]),
            Err(ConstraintError::MasterIsSlave { slave: 3, dof: 3 })
        );
    }
}
