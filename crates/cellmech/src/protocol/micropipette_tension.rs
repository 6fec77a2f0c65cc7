//! Micropipette tension: prestress → approach until the moving pipette feels
//! `contact_force` → pinch → retract until its force is zero (the unloaded reference
//! state) → stretch by `elongation` along the test axis. Bonded contact on the poles.

use cellmech_fem::contact::ToolShape;

use super::{PoleTest, ProtocolError, ProtocolPlan};
use crate::cell::BuiltCell;
use crate::param::{Bounds, ParamDef, ParamDefault as D, ParamKind as K, ParamTable, ParamValues};
use crate::units::Dimension::Length;

/// Largest end elongation accepted, as a multiple of the cell diameter: beyond it the
/// pipettes would pull the cell into a thread the model does not describe.
pub const MAX_ELONGATION_PER_DIAMETER: f64 = 1.5;

/// The parameters of `kind = "micropipette-tension"`.
pub const MICROPIPETTE_TENSION: ParamTable = ParamTable {
    name: "micropipette-tension",
    section: "protocol",
    params: &[
        ParamDef { key: "pipette_radius", kind: K::Quantity(Length), default: D::Number(4.0), bounds: Bounds::POSITIVE, doc: "radius of the pipettes' contact disks (below the cell radius)", source: "choice: a holding pipette of 8 µm bore, a quarter of D" },
        ParamDef { key: "pinch", kind: K::Quantity(Length), default: D::Number(1.0), bounds: Bounds::POSITIVE, doc: "how far the pipettes press the cell together after touching (below D/4)", source: "choice: \"slightly compressing\" (3 % of D)" },
        ParamDef { key: "elongation", kind: K::Quantity(Length), default: D::Number(6.3), bounds: Bounds::POSITIVE, doc: "end elongation from the unloaded reference state (up to 1.5 D; `\"32 um\"` ≈ 100 %)", source: "spec (≈ 20 %)" },
        super::CONTACT_FORCE,
        super::MAX_INCREMENT,
    ],
};

/// Micropipette tension settings (µm, nN).
#[derive(Debug, Clone, PartialEq)]
pub struct MicropipetteTension {
    /// Radius of the pipettes' contact disks.
    pub pipette_radius: f64,
    /// Pinch after touching.
    pub pinch: f64,
    /// End elongation from the reference state.
    pub elongation: f64,
    /// Force that counts as touching.
    pub contact_force: f64,
    /// Largest increment of the loading steps.
    pub max_increment: f64,
}

impl Default for MicropipetteTension {
    /// The defaults declared in [`MICROPIPETTE_TENSION`].
    fn default() -> Self {
        Self::from_values(&ParamValues::defaults(&MICROPIPETTE_TENSION))
    }
}

impl MicropipetteTension {
    /// Settings from resolved values of [`MICROPIPETTE_TENSION`].
    pub fn from_values(v: &ParamValues) -> Self {
        MicropipetteTension {
            pipette_radius: v.number("pipette_radius"),
            pinch: v.number("pinch"),
            elongation: v.number("elongation"),
            contact_force: v.number("contact_force"),
            max_increment: v.number("max_increment"),
        }
    }

    /// Places the pipettes and writes the steps after the prestress.
    pub(super) fn apply(&self, cell: &mut BuiltCell) -> Result<ProtocolPlan, ProtocolError> {
        let d = cell.description.cell_diameter;
        let r = 0.5 * d;
        if self.pipette_radius >= r {
            return Err(ProtocolError {
                key: "pipette_radius",
                message: format!(
                    "expected a pipette radius below the cell radius {r} um (a pipette holds one pole); found {} um",
                    self.pipette_radius
                ),
            });
        }
        if self.elongation > MAX_ELONGATION_PER_DIAMETER * d {
            return Err(ProtocolError {
                key: "elongation",
                message: format!(
                    "expected an elongation up to {MAX_ELONGATION_PER_DIAMETER} cell diameters ({:.1} um); found {} um",
                    MAX_ELONGATION_PER_DIAMETER * d,
                    self.elongation
                ),
            });
        }
        if self.pinch >= 0.25 * d {
            return Err(ProtocolError {
                key: "pinch",
                message: format!(
                    "expected a slight pinch, below a quarter diameter ({:.2} um); found {} um",
                    0.25 * d,
                    self.pinch
                ),
            });
        }
        let radius = self.pipette_radius;
        let test = PoleTest::approach(
            cell,
            ["fixed_pipette", "moving_pipette"],
            |center, normal| ToolShape::Disk {
                center,
                normal,
                radius,
            },
            self.contact_force,
            self.max_increment,
        );
        let (fixed, moving) = (&test.fixed, &test.moving);
        let travel = 0.25 * d;
        let steps = &mut cell.model.steps;
        steps.push(test.step(
            "pinch",
            true,
            vec![
                test.motion(fixed, 0.5 * self.pinch, None),
                test.motion(moving, -0.5 * self.pinch, None),
            ],
        ));
        // Retract the moving pipette until its force is zero: the unloaded reference state.
        let reference_step = steps.len();
        steps.push(test.step(
            "retract",
            false,
            vec![test.motion(moving, travel, Some(0.0))],
        ));
        let stretch_step = steps.len();
        steps.push(test.step(
            "stretch",
            false,
            vec![test.motion(moving, self.elongation, None)],
        ));
        Ok(ProtocolPlan::MicropipetteTension {
            moving_tool: test.moving,
            reference_step,
            stretch_step,
            elongation: self.elongation,
            pipette_radius: self.pipette_radius,
        })
    }
}
