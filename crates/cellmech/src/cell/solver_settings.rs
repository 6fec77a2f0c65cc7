//! The nonlinear solver's settings every cell model declares (`[cell.solver]`): viscous
//! stabilisation, iteration method, filament relaxation, chord steps, the rotations' trust
//! region and the convergence tolerances. One struct for both cell models, so that each
//! builds its steps' base [`StepControl`] the same way.

use cellmech_fem::solve::{Convergence, IterationMethod, Stabilization, StepControl};

use crate::param::ParamValues;

use super::suspended::params as p;

/// How every analysis step of a cell model is solved (`[cell.solver]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    /// Viscous stabilisation of every step (`None`: off; `solver.stabilization`,
    /// `solver.damping`).
    pub stabilization: Option<Stabilization>,
    /// How Newton's corrections after the first are computed in every step (`None`:
    /// `auto`, full Newton except where a protocol measured BFGS to pay:
    /// [`crate::cell::BuiltCell::auto_iteration`]).
    pub iteration: Option<IterationMethod>,
    /// BFGS as this cell iterates by it (`solver.bfgs_updates`): in every step with
    /// `solver.iteration = "bfgs"`, and where `auto` chooses it.
    pub bfgs: IterationMethod,
    /// Whether every step relaxes the beam filaments by their own Newton solves
    /// (`solver.relaxation`, nonlinear elimination).
    pub relaxation: bool,
    /// Whether full Newton solves with the last factorisation near convergence
    /// (`solver.chord`).
    pub chord: bool,
    /// The rotations' trust region of every step (rad, 0: none; `solver.rotation_step`).
    pub rotation_step: f64,
    /// Newton's residual criterion, relative to the force scale
    /// (`solver.residual_tolerance`; [`Convergence::residual_tolerance`]).
    pub residual_tolerance: f64,
    /// Newton's energy criterion, relative to the increment's first correction
    /// (`solver.energy_tolerance`; [`Convergence::energy_tolerance`]).
    pub energy_tolerance: f64,
}

impl SolverSettings {
    /// The settings from resolved values of a cell model's table (both declare the same
    /// `solver.*` keys).
    pub fn from_values(v: &ParamValues) -> Self {
        SolverSettings {
            stabilization: p::stabilization_from_values(v),
            iteration: p::iteration_from_values(v),
            bfgs: p::bfgs_from_values(v),
            relaxation: p::relaxation_from_values(v),
            chord: p::chord_from_values(v),
            rotation_step: p::rotation_step_from_values(v),
            residual_tolerance: v.number("solver.residual_tolerance"),
            energy_tolerance: v.number("solver.energy_tolerance"),
        }
    }

    /// The base control of every step: default increments, these criteria, this
    /// stabilisation and iteration method (full Newton where `auto` leaves it to the
    /// protocol).
    pub fn step_control(&self) -> StepControl {
        StepControl {
            stabilization: self.stabilization,
            convergence: Convergence {
                method: self.iteration.unwrap_or(IterationMethod::Newton),
                relaxation: self.relaxation,
                chord_near_convergence: self.chord,
                max_rotation_step: self.rotation_step,
                residual_tolerance: self.residual_tolerance,
                energy_tolerance: self.energy_tolerance,
                ..Convergence::default()
            },
            ..StepControl::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell::{adherent, suspended};
    use crate::param::ParamValue;

    #[test]
    fn the_defaults_are_the_engines_criteria_and_the_keys_reach_the_step_control() {
        let engine = Convergence::default();
        for table in [
            &suspended::params::SUSPENDED_CELL,
            &adherent::params::ADHERENT_CELL,
        ] {
            let defaults = SolverSettings::from_values(&ParamValues::defaults(table));
            let control = defaults.step_control();
            assert_eq!(
                control.convergence.residual_tolerance,
                engine.residual_tolerance
            );
            assert_eq!(
                control.convergence.energy_tolerance,
                engine.energy_tolerance
            );
            assert_eq!(control.convergence.method, IterationMethod::Newton);
            assert!(control.convergence.relaxation && control.convergence.chord_near_convergence);
            let loose = SolverSettings {
                residual_tolerance: 1e-6,
                energy_tolerance: 1e-10,
                chord: false,
                ..defaults
            }
            .step_control();
            assert_eq!(loose.convergence.residual_tolerance, 1e-6);
            assert_eq!(loose.convergence.energy_tolerance, 1e-10);
            assert!(!loose.convergence.chord_near_convergence);
            // `solver.bfgs_updates` reaches BFGS, chosen by `auto` or by `bfgs`.
            assert_eq!(defaults.bfgs, IterationMethod::Bfgs { max_updates: 20 });
            let mut values = ParamValues::defaults(table);
            values
                .set(table, "solver.bfgs_updates", ParamValue::Count(7))
                .unwrap();
            values
                .set(table, "solver.iteration", ParamValue::Word("bfgs".into()))
                .unwrap();
            let settings = SolverSettings::from_values(&values);
            assert_eq!(settings.bfgs, IterationMethod::Bfgs { max_updates: 7 });
            assert_eq!(settings.step_control().convergence.method, settings.bfgs);
        }
    }
}
