//! Micropipette tension along the cell's test axis. Two grips (`grip`):
//!
//! * `cap` (default): after the prestress, the cell-surface nodes within `grip_radius` of
//!   the axis on each pole are tied to their pipette (prescribed DOFs): the fixed cap is
//!   held, the moving cap is moved by `elongation` along the axis (its transverse motion
//!   held); the prestressed state is the unloaded reference; the force is the sum of the
//!   moving cap's reactions. See [`super::grip`].
//! * `contact`: prestress → approach until the moving pipette feels `contact_force` →
//!   pinch → retract until its force is zero (the reference state) → stretch by
//!   `elongation`. Bonded contact on the poles.

use cellmech_fem::contact::ToolShape;

use super::grip::{self, CapReport, Pole};
use super::{Holder, NodeSetHandle, PoleTest, ProtocolError, ProtocolPlan};
use crate::cell::BuiltCell;
use crate::model::{CurveSpec, StepSpec};
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
        ParamDef { key: "grip", kind: K::Choice(&["cap", "contact"]), default: D::Word("cap"), bounds: Bounds::ANY, doc: "how the pipettes hold the poles: `cap` ties the surface nodes within `grip_radius` of the axis to the pipette (prescribed, mesh-converged); `contact` is bonded contact after approach, pinch and retract", source: "choice ([the grip](suspended-cell.md#the-grip))" },
        ParamDef { key: "grip_radius", kind: K::Quantity(Length), default: D::Absent("= `pipette_radius`"), bounds: Bounds::POSITIVE, doc: "`grip = \"cap\"`: radius of the gripped cap, measured from the test axis (below the cell radius)", source: "choice: the pipette's contact disk" },
        ParamDef { key: "pinch", kind: K::Quantity(Length), default: D::Number(1.0), bounds: Bounds::POSITIVE, doc: "how far the pipettes press the cell together after touching (below D/4)", source: "choice: \"slightly compressing\" (3 % of D)" },
        ParamDef { key: "elongation", kind: K::Quantity(Length), default: D::Number(6.3), bounds: Bounds::POSITIVE, doc: "end elongation from the unloaded reference state (up to 1.5 D; `\"32 um\"` ≈ 100 %)", source: "spec (≈ 20 %)" },
        super::CONTACT_FORCE,
        super::MAX_INCREMENT,
        ParamDef {
            key: "extrapolation",
            kind: K::Choice(&["linear", "none"]),
            default: D::Word("linear"),
            bounds: Bounds::ANY,
            doc: "where Newton starts each stretch increment: `linear`, the last increment extrapolated (the first correction then leaves the residual within the chord window, and chord steps on that one factorisation finish the increment); `none`, the converged state",
            source: "choice, measured ([performance](performance.md#extrapolated-stretch-increments-2026-12-08-stop-56)): the 21 tension battery cases 620 -> 480 factorisations, every force within 1.3e-8; the centrosome-tied and embedded-MT modes also take fewer",
        },
    ],
};

/// How the pipettes hold the cell's poles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Grip {
    /// The surface nodes within the grip radius of the axis are prescribed (tied to the
    /// pipette): no contact, no approach.
    Cap,
    /// Bonded rigid contact after approach, pinch and retract.
    Contact,
}

/// Micropipette tension settings (µm, nN).
#[derive(Debug, Clone, PartialEq)]
pub struct MicropipetteTension {
    /// How the pipettes hold the poles.
    pub grip: Grip,
    /// Radius of the pipettes' contact disks.
    pub pipette_radius: f64,
    /// `Grip::Cap`: radius of the gripped caps (`None`: the pipette radius).
    pub grip_radius: Option<f64>,
    /// Pinch after touching.
    pub pinch: f64,
    /// End elongation from the reference state.
    pub elongation: f64,
    /// Force that counts as touching.
    pub contact_force: f64,
    /// Largest increment of the loading steps.
    pub max_increment: f64,
    /// Where Newton starts each stretch increment.
    pub extrapolation: cellmech_fem::solve::Extrapolation,
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
            grip: match v.word("grip") {
                "contact" => Grip::Contact,
                _ => Grip::Cap,
            },
            pipette_radius: v.number("pipette_radius"),
            grip_radius: v.optional_number("grip_radius"),
            pinch: v.number("pinch"),
            elongation: v.number("elongation"),
            contact_force: v.number("contact_force"),
            max_increment: v.number("max_increment"),
            extrapolation: super::extrapolation(v),
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
        let grip_radius = self.grip_radius.unwrap_or(self.pipette_radius);
        if grip_radius >= r {
            return Err(ProtocolError {
                key: "grip_radius",
                message: format!(
                    "expected a grip radius below the cell radius {r} um (a cap holds one pole); found {grip_radius} um"
                ),
            });
        }
        match self.grip {
            Grip::Cap => self.apply_cap(cell, grip_radius),
            Grip::Contact => Ok(self.apply_contact(cell)),
        }
    }

    /// The geometric grip: caps of prescribed nodes, one stretch step from the prestressed
    /// state.
    fn apply_cap(
        &self,
        cell: &mut BuiltCell,
        grip_radius: f64,
    ) -> Result<ProtocolPlan, ProtocolError> {
        let axis = cell.description.axis;
        let r = 0.5 * cell.description.cell_diameter;
        let inner = 0.5 * cell.description.nucleus_diameter;
        let mesh = &mut cell.model.mesh;
        let surface = mesh
            .node_sets
            .get(&cell.surface_set)
            .cloned()
            .unwrap_or_default();
        let keep = mesh
            .node_sets
            .get("focal_adhesions")
            .cloned()
            .unwrap_or_default();
        let poles = [-1.0, 1.0].map(|side| Pole { axis, side });
        let mut rings = Vec::new();
        for pole in poles {
            let ring = grip::resolve_cap_ring(
                mesh,
                &surface,
                &keep,
                &cell.model.hanging,
                pole,
                r,
                inner,
                grip_radius,
            )
            .map_err(|e| ProtocolError {
                key: "grip_radius",
                message: format!("grip radius {grip_radius} um: {e}"),
            })?;
            rings.push(ring);
        }
        let caps = poles.map(|pole| grip::cap_nodes(mesh, &surface, pole, r, grip_radius));
        let names = [("fixed_cap", "cap_minus"), ("moving_cap", "cap_plus")];
        let mut holders = Vec::new();
        for ((name, set), nodes) in names.iter().zip(&caps) {
            mesh.insert_node_set(*set, nodes.clone());
            holders.push(Holder::NodeSet(NodeSetHandle {
                curve: cell.model.output.curves.len(),
                name: name.to_string(),
                node_set: set.to_string(),
                component: axis,
            }));
            cell.model.output.curves.push(CurveSpec {
                name: name.to_string(),
                node_set: set.to_string(),
                component: axis,
                sign: 1.0,
            });
        }
        let report = CapReport {
            grip_radius_um: grip_radius,
            cap_nodes: [caps[0].len(), caps[1].len()],
            gripped_area_um2: [0, 1].map(|k| grip::gripped_area(mesh, &caps[k])),
            spherical_cap_area_um2: grip::spherical_cap_area(r, grip_radius),
            rings: [rings[0].clone(), rings[1].clone()],
        };
        let reference_step = cell.model.steps.len() - 1;
        let stretch_step = cell.model.steps.len();
        // The caps hold the cell; the minimal supports of the prestress are released.
        cell.model.steps.push(StepSpec {
            name: "stretch".into(),
            control: cellmech_fem::solve::StepControl {
                initial_increment: self.max_increment.min(0.1),
                max_increment: self.max_increment,
                extrapolation: self.extrapolation,
                ..cell.step_control
            },
            fixes: vec![
                ("cap_minus".into(), [true; 3]),
                ("cap_plus".into(), [true; 3]),
            ],
            displacements: vec![("cap_plus".into(), axis, self.elongation)],
            forces: Vec::new(),
            tools: Vec::new(),
        });
        let mut holders = holders.into_iter();
        let (Some(fixed), Some(moving)) = (holders.next(), holders.next()) else {
            unreachable!("two caps");
        };
        Ok(ProtocolPlan::MicropipetteTension {
            moving,
            fixed,
            reference_step,
            stretch_step,
            elongation: self.elongation,
            pipette_radius: self.pipette_radius,
            caps: Some(report),
        })
    }

    /// Bonded contact: approach, pinch, retract to zero force, stretch.
    fn apply_contact(&self, cell: &mut BuiltCell) -> ProtocolPlan {
        let d = cell.description.cell_diameter;
        let radius = self.pipette_radius;
        let test = PoleTest::approach(
            cell,
            ["fixed_pipette", "moving_pipette"],
            |center, normal| ToolShape::Disk {
                center,
                normal,
                radius,
            },
            super::Approach::ContactForce,
            false,
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
        let mut stretch = test.step(
            "stretch",
            false,
            vec![test.motion(moving, self.elongation, None)],
        );
        stretch.control.extrapolation = self.extrapolation;
        steps.push(stretch);
        ProtocolPlan::MicropipetteTension {
            moving: Holder::Tool(test.moving),
            fixed: Holder::Tool(test.fixed),
            reference_step,
            stretch_step,
            elongation: self.elongation,
            pipette_radius: self.pipette_radius,
            caps: None,
        }
    }
}
