//! Microplate compression: prestress → approach (each plate until it touches the cell, or
//! both until the moving plate feels `contact_force`) → compress to each deformation of the
//! diameter in turn. Bonded plates. A suspended cell's mesh is refined under the plates
//! (`refinement.levels`, `refinement.radius`).

use cellmech_fem::contact::ToolShape;
use cellmech_fem::solve::Extrapolation;

use super::{Approach, PoleTest, ProtocolError, ProtocolPlan};
use crate::cell::suspended::{PoleRefinement, MAX_POLE_REFINEMENT_LEVELS};
use crate::cell::BuiltCell;
use crate::param::{Bounds, ParamDef, ParamDefault as D, ParamKind as K, ParamTable, ParamValues};
use crate::units::Dimension::{Dimensionless, Length};

/// The parameters of `kind = "microplate-compression"`.
pub const MICROPLATE_COMPRESSION: ParamTable = ParamTable {
    name: "microplate-compression",
    section: "protocol",
    params: &[
        ParamDef {
            key: "deformations",
            kind: K::QuantityList(Dimensionless),
            default: D::List(&[0.1, 0.3, 0.5]),
            bounds: Bounds::new(0.0, false, 0.9, false),
            doc: "deformations of the diameter at which to report, increasing",
            source: "spec",
        },
        super::APPROACH,
        ParamDef {
            key: "filament_contact",
            kind: K::Choice(&["on", "off"]),
            default: D::Word("off"),
            bounds: Bounds::ANY,
            doc: "`on`: the plates also push the free filament nodes (interior MT nodes, held only by their beams), frictionless, so no filament passes through a plate; `off`: free MTs pass through the plates as they pass through the gel",
            source: "choice: with free MTs the forces are the same to 0.01 nN, `on` costs 38 % more Newton iterations and made one study case stall ([validation](suspended-cell-validation.md))",
        },
        super::CONTACT_FORCE,
        super::MAX_INCREMENT,
        ParamDef {
            key: "extrapolation",
            kind: K::Choice(&["linear", "none"]),
            default: D::Word("linear"),
            bounds: Bounds::ANY,
            doc: "where Newton starts each compression increment: `linear`, the last increment extrapolated (the plate contacts the cell is carried onto are found within the increment they occur in); `none`, the converged state",
            source: "choice, measured ([performance](performance.md#extrapolated-starts)): with `linear` the default increments give the forces of 4x smaller increments within 0.4 / 0.7 / 0.07 % at 10 / 30 / 50 % (`none`: +3.5 / +1.9 / +0.5 %), in 14-27 % fewer Newton iterations; with embedded MTs it costs 34 % more",
        },
        ParamDef {
            key: "refinement.levels",
            kind: K::Count,
            default: D::Count(1),
            bounds: Bounds::new(0.0, true, MAX_POLE_REFINEMENT_LEVELS as f64, true),
            doc: "levels of octree refinement of a suspended cell's mesh under the plates: every hex8 with a corner within `refinement.radius` of a pole of the test axis is split (hanging nodes tied; the FAs and filaments stay where they are); the cell's own `[cell] refinement.levels`, when above 0, replaces it; 0: none",
            source: "choice, measured ([validation](suspended-cell-validation.md#refined-under-the-plates-2026-12-07-stop-51)): the plates first meet the ring around the polar FA's plaque, which the default mesh's 2 µm surface spacing samples with nodes 0.07-0.18 µm apart in height; unrefined, the 10 % force is 5.6 % below the fine mesh's, refined once within 6 µm it is within 2.2 % at 10 / 30 / 50 %",
        },
        ParamDef {
            key: "refinement.radius",
            kind: K::Quantity(Length),
            default: D::Number(6.0),
            bounds: Bounds::POSITIVE,
            doc: "radius of the refined region around each pole point (on the cell surface) under the plates",
            source: "choice: it covers the first contact ring (4.2-4.7 µm from the axis) and the bonded patch at 10 %",
        },
    ],
};

/// Microplate compression settings.
#[derive(Debug, Clone, PartialEq)]
pub struct MicroplateCompression {
    /// Deformations of the diameter, increasing, in (0, 0.9).
    pub deformations: Vec<f64>,
    /// How the plates reach the cell.
    pub approach: Approach,
    /// Whether the plates push the free filament nodes.
    pub filament_contact: bool,
    /// Force that counts as touching with `Approach::ContactForce` (nN).
    pub contact_force: f64,
    /// Largest increment of the loading steps.
    pub max_increment: f64,
    /// Where Newton starts each compression increment.
    pub extrapolation: Extrapolation,
    /// Refinement of a suspended cell's mesh under the plates (`levels` 0: none).
    pub refinement: PoleRefinement,
}

impl Default for MicroplateCompression {
    /// The defaults declared in [`MICROPLATE_COMPRESSION`].
    fn default() -> Self {
        Self::from_values(&ParamValues::defaults(&MICROPLATE_COMPRESSION))
    }
}

impl MicroplateCompression {
    /// Settings from resolved values of [`MICROPLATE_COMPRESSION`].
    pub fn from_values(v: &ParamValues) -> Self {
        MicroplateCompression {
            deformations: v.list("deformations").to_vec(),
            approach: Approach::from_word(v.word("approach")),
            filament_contact: v.word("filament_contact") == "on",
            contact_force: v.number("contact_force"),
            max_increment: v.number("max_increment"),
            extrapolation: super::extrapolation(v),
            refinement: PoleRefinement {
                levels: v.count("refinement.levels").min(u8::MAX as usize) as u8,
                radius: v.number("refinement.radius"),
            },
        }
    }

    /// Places the plates and writes the steps after the prestress.
    pub(super) fn apply(&self, cell: &mut BuiltCell) -> Result<ProtocolPlan, ProtocolError> {
        let list = &self.deformations;
        let ok = !list.is_empty()
            && list.iter().all(|&e| e > 0.0 && e < 0.9)
            && list.windows(2).all(|w| w[1] > w[0]);
        if !ok {
            return Err(ProtocolError {
                key: "deformations",
                message: format!(
                    "expected increasing deformations of the diameter in (0 %, 90 %), e.g. [\"10%\", \"30%\", \"50%\"]; found {list:?}"
                ),
            });
        }
        let d = cell.description.cell_diameter;
        let test = PoleTest::approach(
            cell,
            ["bottom_plate", "top_plate"],
            |point, normal| ToolShape::Plate { point, normal },
            self.approach,
            self.filament_contact,
            self.contact_force,
            self.max_increment,
        );
        // `auto`: BFGS in the loading steps unless filament nodes are embedded (tied
        // exactly to the gel). Embedded MTs snap through under compression; there BFGS was
        // not reliably cheaper than full Newton and needed more viscously stabilised
        // increments. MTs on the elastic foundation snap through too, but with the
        // rotations' trust region BFGS takes their compression from 288 to 217
        // factorisations (docs/performance.md, "A trust region on the rotations"; 154 since
        // it bounds the first correction too); without it BFGS did not end the 50 % step in
        // equilibrium.
        let bounded = cell.step_control.convergence.max_rotation_step > 0.0;
        let quasi_newton = cell.auto_iteration
            && cell
                .model
                .embedded
                .iter()
                .all(|e| e.foundation_modulus.is_some() && bounded);
        let steps = &mut cell.model.steps;
        let mut previous = 0.0;
        let mut targets = Vec::new();
        for (k, e) in list.iter().enumerate() {
            targets.push((steps.len(), *e));
            let mut step = test.step(
                &format!("compress-{:.0}", 100.0 * e),
                false,
                vec![test.motion(&test.moving, -(e - previous) * d, None)],
            );
            step.control.extrapolation = self.extrapolation;
            if k > 0 {
                // The z-hold only stops the rotation about the axis that two point contacts
                // leave free at first contact. After the first loading step each plate has
                // bonded a disc of the surface, which holds that rotation, and the hold,
                // kept, becomes a redundant support inside the nucleus: an asymmetric cell
                // (MTs on the foundation) then drifts against it and it pushes 1.5 nN into
                // one nucleus node by 50 % (a column of strain 0.62 there, against 0.20
                // around it; docs/suspended-cell-validation.md).
                step.fixes.clear();
            }
            if quasi_newton {
                // BFGS where it was measured to pay: half the factorisations, the same
                // forces (docs/performance.md, "BFGS where it pays").
                step.control.convergence.method = cell.bfgs;
            }
            steps.push(step);
            previous = *e;
        }
        Ok(ProtocolPlan::MicroplateCompression {
            moving_tool: test.moving,
            fixed_tool: test.fixed,
            contact_step: test.approach_step,
            deformations: targets,
        })
    }
}
