//! The parts of [`Problem`] that deal with linear constraints (see [`crate::constraint`]).

use super::problem::Problem;
use super::reduced::solver_pattern;
use super::step::Step;
use crate::constraint::LinearConstraints;
use crate::linsolve::SparsityPattern;

impl Problem {
    /// The linear constraints eliminated from the system, if any.
    pub fn constraints(&self) -> Option<&LinearConstraints> {
        self.condensation.as_ref().map(|c| c.constraints())
    }

    /// Number of constrained (slave) DOFs.
    pub fn num_constrained_dofs(&self) -> usize {
        self.constraints().map_or(0, LinearConstraints::len)
    }

    /// The pattern of the matrix the linear solver factorises (lower triangle): the element
    /// pattern, or with constraints the reduced pattern with the master–master couplings.
    pub fn tangent_pattern(&self) -> &SparsityPattern {
        solver_pattern(&self.condensation, &self.assembler)
    }

    /// Stored nonzeros (lower triangle, diagonal included) of the factorised tangent.
    pub fn tangent_nonzeros(&self) -> usize {
        self.tangent_pattern().nnz()
    }

    /// Stored nonzeros of the element pattern alone (the tangent before condensation).
    pub fn element_nonzeros(&self) -> usize {
        self.assembler.pattern().nnz()
    }

    /// Slaves can be neither prescribed nor loaded.
    pub(super) fn check_step_constraints(&self, step: &Step) -> Result<(), String> {
        let Some(c) = self.constraints() else {
            return Ok(());
        };
        if let Some(&(dof, _)) = step.prescribed.iter().find(|(d, _)| c.is_slave(*d)) {
            let (node, comp) = self.dof_map.node_of(dof);
            return Err(format!(
                "DOF {dof} (node {node}, component {comp}) is constrained (an embedded or hanging \
                 node) and cannot be prescribed; prescribe its masters instead"
            ));
        }
        if let Some(load) = step.loads.iter().find(|l| c.is_slave(l.dof)) {
            let (node, comp) = self.dof_map.node_of(load.dof);
            return Err(format!(
                "DOF {} (node {node}, component {comp}) is constrained (an embedded or hanging \
                 node) and cannot be loaded; apply the equivalent master loads \
                 (LinearConstraints::distribute)",
                load.dof
            ));
        }
        Ok(())
    }

    /// After a solve: the slaves' corrections follow the masters' (`δ = T δ̄`), so that every
    /// update `u + s δ` (predictor, Newton step, line-search trial) satisfies the
    /// constraints.
    pub(super) fn expand_correction(&mut self) {
        if let Some(c) = &self.condensation {
            c.constraints().expand(&mut self.work.delta);
        }
    }
}
