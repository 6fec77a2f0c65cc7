//! AFM indentation of the adherent cell: prestress → approach (the tip comes down from
//! above the site until it touches the surface) → touch (on until it feels
//! `contact_force`: first contact) → indent to each depth in
//! turn → optionally retract to the contact position. A rigid paraboloid tip (or a sphere,
//! a colloidal probe) moves along −z; frictionless augmented-Lagrangian contact with the
//! dome nodes around the site; the base stays clamped throughout.

use cellmech_fem::contact::{ContactKind, CurvatureTangent, ToolShape};
use cellmech_fem::solve::{Extrapolation, StepControl};

use super::apparent_modulus::FitSettings;
use super::{ProtocolError, ProtocolPlan, ToolHandle};
use crate::cell::adherent::IndentationSite;
use crate::cell::BuiltCell;
use crate::model::tools::{
    default_penalty, default_tolerance, ForceTarget, ToolAim, ToolMotion, ToolSpec,
};
use crate::model::{RezoneSpec, StepSpec};
use crate::param::{Bounds, ParamDef, ParamDefault as D, ParamKind as K, ParamTable, ParamValues};
use crate::units::Dimension::{Force, Length};
use cellmech_fem::verify::contact::Indenter;

/// The parameters of `kind = "afm-indentation"`.
pub const AFM_INDENTATION: ParamTable = ParamTable {
    name: "afm-indentation",
    section: "protocol",
    params: &[
        ParamDef {
            key: "site",
            kind: K::Choice(&["apex", "receptor", "point"]),
            default: D::Word("apex"),
            bounds: Bounds::ANY,
            doc: "where the tip indents: the apex (over the nucleus, between FAs), the receptor FA, or the dome point above `point`",
            source: "spec",
        },
        ParamDef {
            key: "point",
            kind: K::QuantityList(Length),
            default: D::Absent("with site = \"point\": [x, y]"),
            bounds: Bounds::ANY,
            doc: "with `site = \"point\"`: the (x, y) the tip comes down on",
            source: "choice",
        },
        ParamDef {
            key: "aim",
            kind: K::Choice(&["prestressed", "reference"]),
            default: D::Word("prestressed"),
            bounds: Bounds::ANY,
            doc: "where the tip comes down: over the site's surface node where the prestress has moved it (as an AFM user aims at the cell they see), or over the site of the unstressed cell",
            source: "choice (the receptor FA moves 2.1 µm inwards in the prestress: aimed at its reference position the tip missed its plaque by 1.2 µm; docs/adherent-cell.md)",
        },
        ParamDef {
            key: "tip",
            kind: K::Choice(&["paraboloid", "sphere"]),
            default: D::Word("paraboloid"),
            bounds: Bounds::ANY,
            doc: "tip shape: a paraboloid (sharp AFM tip) or a sphere (colloidal probe)",
            source: "spec (paraboloid); choice (sphere)",
        },
        ParamDef {
            key: "tip_radius",
            kind: K::Quantity(Length),
            default: D::Number(0.2),
            bounds: Bounds::POSITIVE,
            doc: "tip radius of curvature (sphere: its radius)",
            source: "spec (200 nm)",
        },
        ParamDef {
            key: "depths",
            kind: K::QuantityList(Length),
            default: D::List(&[0.5, 1.0, 1.5, 2.0, 2.5]),
            bounds: Bounds::POSITIVE,
            doc: "indentations from first contact at which to report, increasing",
            source: "spec (up to 2.5 µm)",
        },
        ParamDef {
            key: "retract",
            kind: K::Choice(&["no", "yes"]),
            default: D::Word("no"),
            bounds: Bounds::ANY,
            doc: "after the deepest indentation, move the tip back to first contact (the retract curve)",
            source: "choice",
        },
        ParamDef {
            key: "contact",
            kind: K::Choice(&["nodes", "faces"]),
            default: D::Word("nodes"),
            bounds: Bounds::ANY,
            doc: "where the tip acts: the surface nodes, or 3 × 3 Gauss points on each surface face (a tip sharper than the stretched faces cannot slip between their nodes; slower: more contact-status solves per increment)",
            source: "choice ([tools](tools.md#face-contact))",
        },
        ParamDef {
            key: "contact_tangent",
            kind: K::Choice(&["lagged", "consistent"]),
            default: D::Word("lagged"),
            bounds: Bounds::ANY,
            doc: "pressure in the contact tangent's curvature term −p∇²ψ (a negative stiffness across the tip's surface): `lagged`, min(p, p at the last converged solve), never more negative than at a stable state, until Newton's residual is within 1e-5 of the force scale, then p (exact, so the last iterations converge quadratically); `consistent`, the trial pressure, the exact derivative (quadratic convergence, but large trial pressures can invert the elements under the tip)",
            source: "choice, measured ([tools](tools.md#contact-formulation)): lagged 14 increments / 217 iterations on the sharp-tip block against 86 / 716 with the full term",
        },
        ParamDef {
            key: "extrapolation",
            kind: K::Choice(&["linear", "none"]),
            default: D::Word("linear"),
            bounds: Bounds::ANY,
            doc: "where Newton starts each increment of the approach, indentation and retract steps: `linear`, the last increment extrapolated (the contact points the surface is carried onto are predicted from where it is heading, not from where it was); `none`, the converged state",
            source: "choice, measured ([adherent cell](adherent-cell.md#extrapolated-starts)): half the Newton iterations with face contact, forces within 0.3 %",
        },
        ParamDef {
            key: "rezone",
            kind: K::Choice(&["off", "on"]),
            default: D::Word("off"),
            bounds: Bounds::ANY,
            doc: "ALE rezoning of the cytoplasm under the tip: between indentation steps the nodes within `rezone_radius` of the site's surface node move to a smooth mesh of the current body (surface nodes slide along it, the interior follows) and the solution is mapped onto them exactly; the nucleus and every filament node stay. Experimental: it keeps the force within 0.8 % but does not yet take the tip past the Lagrangian mesh's first fold",
            source: "choice, measured ([rezoning](rezoning.md)): off, since the rezoned meshes degrade faster than the Lagrangian one (first fold at the apex 1.05–1.55 µm against 1.675 µm)",
        },
        ParamDef {
            key: "rezone_radius",
            kind: K::Quantity(Length),
            default: D::Number(2.0),
            bounds: Bounds::POSITIVE,
            doc: "with `rezone = \"on\"`: the rezoned region, nodes within this distance of the site's surface node in the current configuration",
            source: "choice (the crushed zone reaches about 1 µm below the tip at 2 µm depth)",
        },
        ParamDef {
            key: "rezone_surface",
            kind: K::Choice(&["slide", "fixed"]),
            default: D::Word("slide"),
            bounds: Bounds::ANY,
            doc: "with `rezone = \"on\"`: the free surface's nodes slide along the surface (their surface displacement made harmonic along it; the site's node stays, the stagnation point under the tip), or stay material points",
            source: "choice ([rezoning](rezoning.md))",
        },
        ParamDef {
            key: "rezone_accept",
            kind: K::Choice(&["better", "valid"]),
            default: D::Word("better"),
            bounds: Bounds::ANY,
            doc: "with `rezone = \"on\"`: apply a rezoning only when it leaves the worst element it touches better than before (`better`), or whenever it leaves them all valid (`valid`, the fixed-frequency rezoning of ALE codes)",
            source: "choice ([rezoning](rezoning.md))",
        },
        ParamDef {
            key: "rezone_every",
            kind: K::Quantity(Length),
            default: D::Number(0.25),
            bounds: Bounds::POSITIVE,
            doc: "with `rezone = \"on\"`: the indentation steps are split so that at most this much tip travel passes between two rezonings",
            source: "choice",
        },
        ParamDef {
            key: "contact_force",
            kind: K::Quantity(Force),
            default: D::Number(0.005),
            bounds: Bounds::POSITIVE,
            doc: "force on the tip that counts as first contact (the zero of the indentation): the touch step after the geometric first contact ends there",
            source: "choice (5 pN, an AFM contact-point threshold)",
        },
        ParamDef {
            key: "approach_gap",
            kind: K::Quantity(Length),
            default: D::Number(1.0),
            bounds: Bounds::POSITIVE,
            doc: "start height of the tip above the undeformed site",
            source: "choice",
        },
        ParamDef {
            key: "max_increment",
            kind: K::Number,
            default: D::Number(0.2),
            bounds: Bounds::new(0.0, false, 1.0, true),
            doc: "largest increment of the indentation steps, fraction of the step (0.2 of a 0.5 µm step: a curve point every 100 nm)",
            source: "choice",
        },
        ParamDef {
            key: "fit_range",
            kind: K::QuantityList(Length),
            default: D::List(&[0.0, 1.0]),
            bounds: Bounds::NON_NEGATIVE,
            doc: "depths [from, to] of the apparent-modulus fit (Hertz/Sneddon)",
            source: "choice (issue: \"a Hertz fit over a chosen depth range\")",
        },
        ParamDef {
            key: "fit_model",
            kind: K::Choice(&["tip", "paraboloid", "sphere", "cone"]),
            default: D::Word("tip"),
            bounds: Bounds::ANY,
            doc: "contact model of the fit: the tip's own shape, a paraboloid (Hertz), a sphere (Sneddon) of the tip radius, or a cone (Sneddon) of half-angle `fit_cone_half_angle_deg`",
            source: "choice",
        },
        ParamDef {
            key: "fit_cone_half_angle_deg",
            kind: K::Number,
            default: D::Number(20.0),
            bounds: Bounds::new(0.0, false, 90.0, false),
            doc: "half-angle of the cone model (degrees)",
            source: "choice (a common pyramidal tip)",
        },
        ParamDef {
            key: "fit_poisson_ratio",
            kind: K::Number,
            default: D::Number(0.5),
            bounds: Bounds::new(-1.0, false, 0.5, true),
            doc: "Poisson's ratio assumed by the fit (AFM users assume incompressible)",
            source: "choice",
        },
    ],
};

/// The indenter's shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TipShape {
    /// Paraboloid of revolution (Hertz).
    Paraboloid,
    /// Sphere (colloidal probe).
    Sphere,
}

/// AFM indentation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct AfmIndentation {
    /// Where the tip indents.
    pub site: IndentationSite,
    /// Aim the tip at the site's node as the prestress has moved it (else at the reference
    /// site).
    pub aim_prestressed: bool,
    /// Tip shape.
    pub tip: TipShape,
    /// Tip radius (µm).
    pub tip_radius: f64,
    /// Depths from first contact, increasing (µm).
    pub depths: Vec<f64>,
    /// Retract to first contact after the deepest indentation.
    pub retract: bool,
    /// Contact on Gauss points of the surface faces instead of the surface nodes.
    pub on_faces: bool,
    /// Which pressure the contact tangent's curvature term uses.
    pub contact_tangent: CurvatureTangent,
    /// Force that counts as contact (nN).
    pub contact_force: f64,
    /// Start height of the tip above the undeformed site (µm).
    pub approach_gap: f64,
    /// Largest increment of the loading steps.
    pub max_increment: f64,
    /// Where Newton starts each increment of the approach, indentation and retract steps.
    pub extrapolation: Extrapolation,
    /// How the apparent modulus is fitted to the curve.
    pub fit: FitSettings,
    /// ALE rezoning under the tip: region radius and the tip travel between rezonings (µm).
    pub rezone: Option<Rezoning>,
}

/// ALE rezoning settings of the indentation (`rezone = "on"`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rezoning {
    /// Nodes within this distance of the site's surface node move (µm).
    pub radius: f64,
    /// Largest tip travel between two rezonings (µm).
    pub every: f64,
    /// The free surface's nodes slide along it.
    pub slide_surface: bool,
    /// Which rezonings are applied.
    pub acceptance: cellmech_fem::rezone::Acceptance,
}

impl Default for AfmIndentation {
    /// The defaults declared in [`AFM_INDENTATION`].
    fn default() -> Self {
        Self::from_values(&ParamValues::defaults(&AFM_INDENTATION))
    }
}

/// The touch step (from geometric first contact until the tip feels `contact_force`) moves
/// the tip by at most this many tip radii, between MIN_TOUCH_TRAVEL and MAX_TOUCH_TRAVEL
/// (µm): 0.2 µm for the 0.2 µm tip, where the cytoplasm alone (Hertz, E = 0.5 kPa) pushes
/// back with about 30 pN, six times the default contact force.
const TOUCH_TRAVEL_RADII: f64 = 1.0;
const MIN_TOUCH_TRAVEL: f64 = 0.05;
const MAX_TOUCH_TRAVEL: f64 = 0.5;

/// A mesh node that is not a contact candidate and lies deeper inside the tip than this
/// many penetration tolerances means the tip has passed between the surface's contact
/// points (`ProtocolResults::tip_passes_between_nodes_at_um`): the contact nodes themselves
/// stay within one tolerance, so five is clear of round-off and of the surface's own sag
/// between its nodes on the finest meshes measured (at most 4.4 nm with the 2 nm tolerance).
pub const PIERCE_TOLERANCES: f64 = 5.0;

/// Contact candidates: dome nodes within this many tip-to-depth contact radii
/// `√(2 R d_max)` of the site, and at least [`MIN_CONTACT_RADIUS`].
const CONTACT_RADII: f64 = 3.0;
/// Smallest radius of the contact-candidate region (µm).
const MIN_CONTACT_RADIUS: f64 = 2.0;

impl AfmIndentation {
    /// Settings from resolved values of [`AFM_INDENTATION`].
    pub fn from_values(v: &ParamValues) -> Self {
        let site = match v.word("site") {
            "receptor" => IndentationSite::Receptor,
            "point" => {
                let p = if v.given("point") {
                    v.list("point")
                } else {
                    &[]
                };
                IndentationSite::Point {
                    x: p.first().copied().unwrap_or(f64::NAN),
                    y: p.get(1).copied().unwrap_or(f64::NAN),
                }
            }
            _ => IndentationSite::Apex,
        };
        AfmIndentation {
            site,
            aim_prestressed: v.word("aim") == "prestressed",
            tip: match v.word("tip") {
                "sphere" => TipShape::Sphere,
                _ => TipShape::Paraboloid,
            },
            tip_radius: v.number("tip_radius"),
            depths: v.list("depths").to_vec(),
            retract: v.word("retract") == "yes",
            on_faces: v.word("contact") == "faces",
            contact_tangent: match v.word("contact_tangent") {
                "consistent" => CurvatureTangent::Consistent,
                _ => CurvatureTangent::Lagged,
            },
            contact_force: v.number("contact_force"),
            approach_gap: v.number("approach_gap"),
            max_increment: v.number("max_increment"),
            extrapolation: super::extrapolation(v),
            rezone: (v.word("rezone") == "on").then(|| Rezoning {
                radius: v.number("rezone_radius"),
                every: v.number("rezone_every"),
                slide_surface: v.word("rezone_surface") == "slide",
                acceptance: match v.word("rezone_accept") {
                    "valid" => cellmech_fem::rezone::Acceptance::Valid,
                    _ => cellmech_fem::rezone::Acceptance::Better,
                },
            }),
            fit: {
                let r = v.number("tip_radius");
                let tip = match (v.word("fit_model"), v.word("tip")) {
                    ("sphere", _) | ("tip", "sphere") => Indenter::Sphere { radius: r },
                    ("cone", _) => Indenter::Cone {
                        half_angle: v.number("fit_cone_half_angle_deg").to_radians(),
                    },
                    _ => Indenter::Paraboloid { radius: r },
                };
                let range = v.list("fit_range");
                let mut fit = FitSettings::new(
                    tip,
                    [
                        range.first().copied().unwrap_or(f64::NAN),
                        range.get(1).copied().unwrap_or(f64::NAN),
                    ],
                );
                fit.poisson_ratio = v.number("fit_poisson_ratio");
                fit
            },
        }
    }

    /// The site's name for outputs.
    pub fn site_name(&self) -> &'static str {
        match self.site {
            IndentationSite::Apex => "apex",
            IndentationSite::Receptor => "receptor",
            IndentationSite::Point { .. } => "point",
        }
    }

    /// Checks the settings that do not depend on the cell.
    fn check(&self) -> Result<(), ProtocolError> {
        if let IndentationSite::Point { x, y } = self.site {
            if !(x.is_finite() && y.is_finite()) {
                return Err(ProtocolError {
                    key: "point",
                    message: "expected point = [\"x um\", \"y um\"] with site = \"point\"; found \
                              none or fewer than two lengths"
                        .into(),
                });
            }
        }
        let [lo, hi] = self.fit.depth_range_um;
        if !(lo >= 0.0 && hi > lo) {
            return Err(ProtocolError {
                key: "fit_range",
                message: format!(
                    "expected two depths [from, to] with 0 ≤ from < to, e.g. [\"0 um\", \"1 um\"]; \
                     found [{lo}, {hi}] µm"
                ),
            });
        }
        let list = &self.depths;
        if list.is_empty()
            || list.iter().any(|d| !(*d > 0.0))
            || list.windows(2).any(|w| w[1] <= w[0])
        {
            return Err(ProtocolError {
                key: "depths",
                message: format!(
                    "expected increasing positive depths, e.g. [\"0.5 um\", \"1 um\", \"2.5 um\"]; \
                     found {list:?} µm"
                ),
            });
        }
        Ok(())
    }

    /// Places the tip and writes the steps after the prestress.
    pub(super) fn apply(&self, cell: &mut BuiltCell) -> Result<ProtocolPlan, ProtocolError> {
        self.check()?;
        let Some((site, _normal)) = cell.site else {
            return Err(ProtocolError {
                key: "site",
                message: format!(
                    "afm-indentation needs a cell refined at an indentation site (the adherent \
                     cell, `[cell] model = \"adherent\"`); found the {} cell",
                    cell.description.model
                ),
            });
        };
        let r = self.tip_radius;
        let (lo, hi) = cell.model.mesh.bounding_box();
        let height = hi[2] - lo[2];
        let width = (hi[0] - lo[0]).min(hi[1] - lo[1]);
        if r >= 0.5 * width || r >= height {
            return Err(ProtocolError {
                key: "tip_radius",
                message: format!(
                    "expected a tip smaller than the cell (height {height:.2} µm, width \
                     {width:.2} µm); found a radius of {r} µm"
                ),
            });
        }
        let deepest = *self.depths.last().expect("checked non-empty");
        if deepest >= site[2] {
            return Err(ProtocolError {
                key: "depths",
                message: format!(
                    "expected indentations shallower than the cell at the site ({:.2} µm above \
                     the substrate); found {deepest} µm",
                    site[2]
                ),
            });
        }
        // Contact candidates around the site.
        let reach = (CONTACT_RADII * (2.0 * r * deepest).sqrt()).max(MIN_CONTACT_RADIUS);
        let mesh = &mut cell.model.mesh;
        let dome = mesh
            .node_sets
            .get(&cell.surface_set)
            .cloned()
            .unwrap_or_default();
        let candidates: Vec<usize> = dome
            .into_iter()
            .filter(|&n| crate::cell::vec3::distance(mesh.nodes[n], site) <= reach)
            .collect();
        // The site's surface node (the site is a node of the refined mesh).
        let aim_node = candidates.iter().copied().min_by(|&a, &b| {
            let d = |n: usize| crate::cell::vec3::distance(mesh.nodes[n], site);
            d(a).total_cmp(&d(b))
        });
        mesh.insert_node_set("tip_contact", candidates.clone());
        // Every other mesh node in the same reach is watched for lying inside the tip: the
        // sign that the tip has passed between the surface's contact points.
        let watch: Vec<usize> = {
            let contact: std::collections::HashSet<usize> = candidates.iter().copied().collect();
            (0..mesh.nodes.len())
                .filter(|n| !contact.contains(n))
                .filter(|&n| crate::cell::vec3::distance(mesh.nodes[n], site) <= reach)
                .collect()
        };
        // With `contact = "faces"` the tip acts on the surface faces among the candidates
        // (Gauss points between the nodes): with node contact the 0.2 µm tip slips between
        // the nodes of the faces it has stretched and sinks into the cytoplasm beyond about
        // 1 µm of indentation (docs/tools.md).
        let inside: std::collections::HashSet<usize> = candidates.iter().copied().collect();
        let faces: Vec<[usize; 4]> = if self.on_faces {
            cell.surface_faces
                .iter()
                .copied()
                .filter(|f| f.iter().all(|n| inside.contains(n)))
                .collect()
        } else {
            Vec::new()
        };
        let apex = [site[0], site[1], site[2] + self.approach_gap];
        let axis = [0.0, 0.0, -1.0];
        // The penetration tolerance also resolves the tip: 1 % of its radius at most.
        let contact_tolerance = default_tolerance(&cell.model.mesh).min(0.01 * r);
        let shape = match self.tip {
            TipShape::Paraboloid => ToolShape::Paraboloid {
                apex,
                axis,
                tip_radius: r,
            },
            TipShape::Sphere => ToolShape::Sphere {
                center: [apex[0], apex[1], apex[2] + r],
                radius: r,
            },
        };
        let tip = ToolHandle {
            index: cell.model.tools.len(),
            name: "tip".into(),
        };
        cell.model.tools.push(ToolSpec {
            name: tip.name.clone(),
            shape,
            kind: ContactKind::Frictionless,
            node_set: "tip_contact".into(),
            faces,
            penalty: default_penalty(&cell.model.materials, &cell.model.mesh, &candidates),
            tolerance: contact_tolerance,
            curvature_tangent: self.contact_tangent,
            aim: None,
            watch,
        });
        let loading = StepControl {
            initial_increment: self.max_increment.min(0.1),
            max_increment: self.max_increment,
            extrapolation: self.extrapolation,
            ..cell.step_control
        };
        let hold = cell.rotation_hold.clone();
        let step = |name: String, dz: f64, until: Option<f64>| StepSpec {
            name,
            control: loading,
            fixes: hold.clone(),
            displacements: Vec::new(),
            forces: Vec::new(),
            tools: vec![ToolMotion {
                tool: "tip".into(),
                movement: [0.0, 0.0, dz],
                until_force: until.map(|value| ForceTarget {
                    value,
                    tolerance: 0.05 * value,
                }),
                until_contact: None,
            }],
        };
        let steps = &mut cell.model.steps;
        // Down by the gap and as deep again (the surface may have risen or sunk in the
        // prestress) until the tip's smallest gap to the surface is 0: that gap is known
        // from the committed state before anything is solved, so the free travel costs no
        // Newton iteration and no trial is pressed into the cell and rejected.
        let mut approach = step(
            "approach".into(),
            -(2.0 * self.approach_gap + deepest),
            None,
        );
        approach.tools[0].until_contact = Some(contact_tolerance);
        // Aimed: the approach starts over the site's node where the prestress has put it.
        if let Some(node) = aim_node.filter(|_| self.aim_prestressed) {
            cell.model.tools[tip.index].aim = Some(ToolAim {
                node,
                step: steps.len(),
            });
        }
        steps.push(approach);
        // Then on until the tip feels `contact_force` (first contact, the zero of the
        // indentation), at most TOUCH_TRAVEL_RADII tip radii further.
        let contact_step = steps.len();
        steps.push(step(
            "touch".into(),
            -(TOUCH_TRAVEL_RADII * r).clamp(MIN_TOUCH_TRAVEL, MAX_TOUCH_TRAVEL),
            Some(self.contact_force),
        ));
        let mut depths = Vec::new();
        let mut previous = 0.0;
        let mut rezone_after = Vec::new();
        for &d in &self.depths {
            // With rezoning, the step is split into parts of at most `every` (a rezoning
            // after each); without, one step per reported depth.
            let parts = self.rezone.map_or(1, |z| {
                ((d - previous) / z.every - 1e-9).ceil().max(1.0) as usize
            });
            for k in 1..=parts {
                let to = previous + (d - previous) * k as f64 / parts as f64;
                let from = previous + (d - previous) * (k - 1) as f64 / parts as f64;
                if self.rezone.is_some() {
                    rezone_after.push(steps.len());
                }
                steps.push(step(
                    format!("indent-{}nm", (1000.0 * to).round()),
                    -(to - from),
                    None,
                ));
            }
            depths.push((steps.len() - 1, d));
            previous = d;
        }
        if let Some(z) = self.rezone {
            let Some(center_node) = aim_node else {
                return Err(ProtocolError {
                    key: "rezone",
                    message:
                        "expected a surface node at the site to centre the rezoned region on; \
                              found none"
                            .into(),
                });
            };
            // Not after the deepest step: nothing follows it but the retract.
            rezone_after.pop();
            cell.model.rezone = Some(RezoneSpec {
                blocks: vec!["cytoplasm".into()],
                surface_set: cell.surface_set.clone(),
                surface_faces: cell.surface_faces.clone(),
                center_node,
                radius: z.radius,
                after_steps: rezone_after,
                slide_surface: z.slide_surface,
                acceptance: z.acceptance,
            });
        }
        let retract_step = self.retract.then(|| {
            steps.push(step("retract".into(), previous, None));
            steps.len() - 1
        });
        Ok(ProtocolPlan::AfmIndentation {
            tip,
            contact_step,
            depths,
            retract_step,
            site: self.site_name().into(),
            site_point: site,
            tip_shape: self.tip,
            tip_radius: r,
            fit: self.fit,
            pierce_tolerance: PIERCE_TOLERANCES * contact_tolerance,
        })
    }
}
