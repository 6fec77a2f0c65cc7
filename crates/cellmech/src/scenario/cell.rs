//! `[cell]` and `[protocol]`: a built-in cell model and a built-in virtual experiment.
//!
//! `[cell]` replaces `[mesh]`, `[[material]]` and the filament sections: it builds the
//! suspended cell of `shared/spec/cell-models.md` (see [`crate::cell`]) with every
//! dimension, count and material a key whose default is the spec's value. `[protocol]`
//! replaces `[[tool]]` and `[[step]]`: it places the rigid tools and writes the steps of
//! the micropipette tension test or the microplate compression test (or only the prestress
//! step). `[families.<name>]` (`membrane`, `actin`, `microtubule`, `intermediate`) still
//! switches components off or scales them. See `docs/suspended-cell.md`.

use cellmech_fem::contact::{ContactKind, ToolShape};
use cellmech_fem::mesh::Mesh;
use cellmech_fem::solve::StepControl;
use serde::Deserialize;
use toml::Spanned;

use super::context::Ctx;
use super::tools::{ForceTarget, ToolMotion, ToolSpec};
use super::{MaterialAssignment, ScenarioError, StepSpec};
use crate::cell::suspended::{
    suspended_cell_parts, Components, SuspendedCellMaterials, SuspendedCellParts, SUPPORT_SETS,
};
use crate::cell::{FaOrientation, IfAnchorRule, MeshResolution, SuspendedCellParams};
use crate::units::{Force, Length, Pressure, Ratio};

/// `[cell]`: the suspended-cell model. Every key is optional; defaults are the spec's.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CellSection {
    /// `"suspended"` (the only model so far; default).
    pub model: Option<Spanned<String>>,
    /// Cell diameter (default 32.264 µm).
    pub cell_diameter: Option<Spanned<Length>>,
    /// Nucleus diameter, concentric (default 12.9 µm).
    pub nucleus_diameter: Option<Spanned<Length>>,
    /// Seed of every random choice (MT bows, orientation search; default 2024).
    pub seed: Option<u64>,
    /// `"default"` (2816 hex8) or `"fine"` (14 504 hex8); the three counts below override.
    pub resolution: Option<Spanned<String>>,
    /// Elements along the central cube's edge (even).
    pub core_divisions: Option<Spanned<usize>>,
    /// Radial layers inside the nucleus surface.
    pub shell_layers: Option<Spanned<usize>>,
    /// Radial layers of cytoplasm.
    pub outer_layers: Option<Spanned<usize>>,
    /// `"symmetric"` (default: FAs on the ±x, ±y, ±z poles) or `"optimized"`.
    pub fa_orientation: Option<Spanned<String>>,
    /// Random rotations tried by `fa_orientation = "optimized"` (default 2000).
    pub orientation_trials: Option<usize>,
    /// Cytoplasm material.
    #[serde(default)]
    pub cytoplasm: ContinuumPart,
    /// Nucleus material.
    #[serde(default)]
    pub nucleus: ContinuumPart,
    /// Cell membrane.
    #[serde(default)]
    pub membrane: MembranePart,
    /// Actin filaments.
    #[serde(default)]
    pub actin: ActinPart,
    /// Microtubules.
    #[serde(default)]
    pub microtubules: MicrotubulePart,
    /// Intermediate filaments.
    #[serde(default)]
    pub intermediate: IntermediatePart,
}

/// `[cell.cytoplasm]`, `[cell.nucleus]`: neo-Hookean with mean dilatation.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContinuumPart {
    /// Shear modulus G.
    pub shear_modulus: Option<Spanned<Pressure>>,
    /// Poisson's ratio (compressibility; default 0.49).
    pub poisson_ratio: Option<Spanned<f64>>,
}

/// `[cell.membrane]`: incompressible neo-Hookean membrane on the outer surface.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MembranePart {
    /// Young's modulus (default 1 MPa; G = E/3).
    pub youngs_modulus: Option<Spanned<Pressure>>,
    /// Thickness (default 10 nm).
    pub thickness: Option<Spanned<Length>>,
}

/// `[cell.actin]`: tension-only prestrained trusses on the icosidodecahedron's edges.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActinPart {
    /// Young's modulus (default 2.6 GPa).
    pub youngs_modulus: Option<Spanned<Pressure>>,
    /// Diameter (default 7 nm).
    pub diameter: Option<Spanned<Length>>,
    /// Prestrain (default 24 %).
    pub prestrain: Option<Spanned<Ratio>>,
}

/// `[cell.microtubules]`: curved hollow corotational beams from the centrosome to the FAs.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MicrotubulePart {
    /// Young's modulus (default 1.2 GPa).
    pub youngs_modulus: Option<Spanned<Pressure>>,
    /// Outer diameter (default 25 nm).
    pub outer_diameter: Option<Spanned<Length>>,
    /// Inner diameter (default 17 nm).
    pub inner_diameter: Option<Spanned<Length>>,
    /// Poisson's ratio of the section (default 0.3).
    pub poisson_ratio: Option<Spanned<f64>>,
    /// Beam elements per MT (default 8).
    pub elements: Option<Spanned<usize>>,
    /// Smallest sideways bow at mid-length, fraction of the chord (default 5 %).
    pub bow_min: Option<Spanned<Ratio>>,
    /// Largest bow (default 20 %).
    pub bow_max: Option<Spanned<Ratio>>,
    /// Smallest distance of an MT from the nucleus surface (default 0.25 µm).
    pub clearance_margin: Option<Spanned<Length>>,
    /// Distance of the centrosome from the nucleus surface (default 0.75 µm).
    pub centrosome_gap: Option<Spanned<Length>>,
    /// Direction of the centrosome from the cell centre (default [1, 1, 1]).
    pub centrosome_direction: Option<Spanned<[f64; 3]>>,
}

/// `[cell.intermediate]`: slack tension-only trusses from the FAs, tangent to the nucleus.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntermediatePart {
    /// Young's modulus (default 7.6 MPa).
    pub youngs_modulus: Option<Spanned<Pressure>>,
    /// Diameter (default 10 nm).
    pub diameter: Option<Spanned<Length>>,
    /// Slack (default 20 %).
    pub slack: Option<Spanned<Ratio>>,
    /// IFs per FA (default 2, at least 1).
    pub per_fa: Option<Spanned<usize>>,
    /// Angle of the first IF on the FA's tangent circle, in degrees (default 0).
    pub phase_deg: Option<Spanned<f64>>,
    /// `"nearest"` (default) or `"nearest-visible"` nucleus node to the tangent point.
    pub anchor: Option<Spanned<String>>,
}

/// `[protocol]`: the virtual experiment on the `[cell]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProtocolSection {
    /// `"micropipette-tension"`, `"microplate-compression"` or `"prestress"`.
    pub kind: Spanned<String>,
    /// Tension: radius of the pipettes' contact disks (default 4 µm).
    pub pipette_radius: Option<Spanned<Length>>,
    /// Tension: how far the pipettes press the cell together after touching (default 1 µm).
    pub pinch: Option<Spanned<Length>>,
    /// Tension: end elongation from the unloaded reference state (default 6.3 µm).
    pub elongation: Option<Spanned<Length>>,
    /// Compression: deformations of the diameter at which to report (default 10, 30, 50 %).
    pub deformations: Option<Spanned<Vec<Ratio>>>,
    /// Force on the moving tool that counts as "touching" in the approach (default 0.1 nN).
    pub contact_force: Option<Spanned<Force>>,
    /// Largest increment of the loading steps, fraction of the step (default 0.1).
    pub max_increment: Option<Spanned<f64>>,
}

/// The virtual experiment that was resolved.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ProtocolSpec {
    /// Prestress only.
    Prestress,
    /// Micropipette tension along x.
    MicropipetteTension {
        /// Moving tool (at +x).
        moving_tool: String,
        /// Step that ends in the unloaded reference state.
        reference_step: usize,
        /// Step that stretches.
        stretch_step: usize,
        /// End elongation (µm).
        elongation: f64,
        /// Pipette radius (µm).
        pipette_radius: f64,
    },
    /// Microplate compression along x.
    MicroplateCompression {
        /// Moving plate (at +x).
        moving_tool: String,
        /// Step that ends with the plates touching.
        contact_step: usize,
        /// Compression steps, in order, with their target deformation of the diameter.
        deformations: Vec<(usize, f64)>,
    },
}

/// What the scenario knows about its cell model, for outputs and summaries.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CellStudy {
    /// Model name (`suspended`).
    pub model: String,
    /// Seed of every random choice.
    pub seed: u64,
    /// Cell diameter D (µm).
    pub cell_diameter: f64,
    /// Nucleus diameter (µm).
    pub nucleus_diameter: f64,
    /// Axis of the test (0 = x).
    pub axis: usize,
    /// Nucleus-surface nodes (for its aspect ratio).
    #[serde(skip)]
    pub nucleus_surface: Vec<usize>,
    /// Resolved parameters, echoed in `summary.json`.
    pub params: serde_json::Value,
    /// Materials, echoed.
    pub materials: SuspendedCellMaterials,
    /// Geometry quality (snap distances, MT clearance, IF tangency).
    pub geometry: serde_json::Value,
    /// The experiment, when `[protocol]` is given.
    pub protocol: Option<ProtocolSpec>,
}

/// The cell's parts resolved from `[cell]`.
pub(super) struct ResolvedCell {
    pub mesh: Mesh,
    pub materials: Vec<MaterialAssignment>,
    pub structures: super::structures::StructuresSpec,
    pub study: CellStudy,
}

impl Ctx<'_> {
    /// A positive finite quantity, or the default.
    fn positive(
        &self,
        value: &Option<Spanned<impl Copy + Into<f64> + std::fmt::Display>>,
        key: &str,
        default: f64,
    ) -> Result<f64, ScenarioError> {
        match value {
            None => Ok(default),
            Some(v) => {
                let x: f64 = (*v.get_ref()).into();
                if x.is_finite() && x > 0.0 {
                    Ok(x)
                } else {
                    Err(self.invalid(
                        Some(v.span()),
                        key,
                        format!("expected a value > 0; found {}", v.get_ref()),
                    ))
                }
            }
        }
    }
}

macro_rules! into_f64 {
    ($($t:ty),*) => {$(impl From<$t> for f64 { fn from(v: $t) -> f64 { v.0 } })*};
}
into_f64!(Length, Pressure, Ratio, Force);

fn ratio(v: &Option<Spanned<Ratio>>, default: f64) -> f64 {
    v.as_ref().map_or(default, |r| r.get_ref().0)
}

fn plain(v: &Option<Spanned<f64>>, default: f64) -> f64 {
    v.as_ref().map_or(default, |r| *r.get_ref())
}

/// Resolves `[cell]` into a mesh, materials and structures (before `[families]`).
pub(super) fn resolve_cell(
    origin: &str,
    text: &str,
    section: &Spanned<CellSection>,
) -> Result<ResolvedCell, ScenarioError> {
    let ctx = Ctx { origin, text };
    let span = Some(section.span());
    let c = section.get_ref();
    if let Some(m) = &c.model {
        if m.get_ref() != "suspended" {
            return Err(ctx.invalid(
                Some(m.span()),
                "cell.model",
                format!("expected \"suspended\"; found \"{}\"", m.get_ref()),
            ));
        }
    }
    let defaults = SuspendedCellParams::default();
    let mut mesh = match c
        .resolution
        .as_ref()
        .map(|r| (r.get_ref().as_str(), r.span()))
    {
        None | Some(("default", _)) => MeshResolution::default(),
        Some(("fine", _)) => MeshResolution::fine(),
        Some((other, s)) => {
            return Err(ctx.invalid(
                Some(s),
                "cell.resolution",
                format!("expected \"default\" or \"fine\"; found \"{other}\""),
            ))
        }
    };
    for (value, target, key) in [
        (
            &c.core_divisions,
            &mut mesh.core_divisions,
            "cell.core_divisions",
        ),
        (&c.shell_layers, &mut mesh.shell_layers, "cell.shell_layers"),
        (&c.outer_layers, &mut mesh.outer_layers, "cell.outer_layers"),
    ] {
        if let Some(v) = value {
            if *v.get_ref() == 0 {
                return Err(ctx.invalid(Some(v.span()), key, "expected at least 1; found 0"));
            }
            *target = *v.get_ref();
        }
    }
    let fa_orientation = match c
        .fa_orientation
        .as_ref()
        .map(|r| (r.get_ref().as_str(), r.span()))
    {
        None | Some(("symmetric", _)) => FaOrientation::Symmetric,
        Some(("optimized", _)) => FaOrientation::Optimized {
            trials: c.orientation_trials.unwrap_or(2000),
        },
        Some((other, s)) => {
            return Err(ctx.invalid(
                Some(s),
                "cell.fa_orientation",
                format!("expected \"symmetric\" or \"optimized\"; found \"{other}\""),
            ))
        }
    };
    let mt = &c.microtubules;
    let ifs = &c.intermediate;
    let if_anchor_rule = match ifs
        .anchor
        .as_ref()
        .map(|r| (r.get_ref().as_str(), r.span()))
    {
        None | Some(("nearest", _)) => IfAnchorRule::Nearest,
        Some(("nearest-visible", _)) => IfAnchorRule::NearestVisible,
        Some((other, s)) => {
            return Err(ctx.invalid(
                Some(s),
                "cell.intermediate.anchor",
                format!("expected \"nearest\" or \"nearest-visible\"; found \"{other}\""),
            ))
        }
    };
    let params = SuspendedCellParams {
        cell_diameter: ctx.positive(&c.cell_diameter, "cell.cell_diameter", defaults.cell_diameter)?,
        nucleus_diameter: ctx.positive(
            &c.nucleus_diameter,
            "cell.nucleus_diameter",
            defaults.nucleus_diameter,
        )?,
        mesh,
        fa_orientation,
        mt_elements: mt.elements.as_ref().map_or(defaults.mt_elements, |v| *v.get_ref()),
        mt_bow_min: ratio(&mt.bow_min, defaults.mt_bow_min),
        mt_bow_max: ratio(&mt.bow_max, defaults.mt_bow_max),
        mt_clearance_margin: mt
            .clearance_margin
            .as_ref()
            .map_or(defaults.mt_clearance_margin, |v| v.get_ref().0),
        centrosome_gap: match &mt.centrosome_gap {
            Some(g) if !(g.get_ref().0 > 0.0) => {
                return Err(ctx.invalid(
                    Some(g.span()),
                    "cell.microtubules.centrosome_gap",
                    format!(
                        "the centrosome must lie outside the nucleus: centrosome_gap is its distance from the nucleus surface, expected > 0; found {} (a centrosome inside the nucleus)",
                        g.get_ref()
                    ),
                ))
            }
            g => g.as_ref().map_or(defaults.centrosome_gap, |v| v.get_ref().0),
        },
        centrosome_direction: mt
            .centrosome_direction
            .as_ref()
            .map_or(defaults.centrosome_direction, |v| *v.get_ref()),
        ifs_per_fa: ifs.per_fa.as_ref().map_or(defaults.ifs_per_fa, |v| *v.get_ref()),
        if_phase: ifs
            .phase_deg
            .as_ref()
            .map_or(defaults.if_phase, |v| v.get_ref().to_radians()),
        if_anchor_rule,
        seed: c.seed.unwrap_or(defaults.seed),
    };
    let d = SuspendedCellMaterials::default();
    let nu = |v: &Option<Spanned<f64>>, key: &str, default: f64| match v {
        Some(p) if !(*p.get_ref() > -1.0 && *p.get_ref() < 0.5) => Err(ctx.invalid(
            Some(p.span()),
            key,
            format!(
                "expected a Poisson's ratio in (-1, 0.5); found {}",
                p.get_ref()
            ),
        )),
        _ => Ok(plain(v, default)),
    };
    let materials = SuspendedCellMaterials {
        cytoplasm_shear_modulus: ctx.positive(
            &c.cytoplasm.shear_modulus,
            "cell.cytoplasm.shear_modulus",
            d.cytoplasm_shear_modulus,
        )?,
        cytoplasm_poisson_ratio: nu(
            &c.cytoplasm.poisson_ratio,
            "cell.cytoplasm.poisson_ratio",
            d.cytoplasm_poisson_ratio,
        )?,
        nucleus_shear_modulus: ctx.positive(
            &c.nucleus.shear_modulus,
            "cell.nucleus.shear_modulus",
            d.nucleus_shear_modulus,
        )?,
        nucleus_poisson_ratio: nu(
            &c.nucleus.poisson_ratio,
            "cell.nucleus.poisson_ratio",
            d.nucleus_poisson_ratio,
        )?,
        membrane_shear_modulus: ctx.positive(
            &c.membrane.youngs_modulus,
            "cell.membrane.youngs_modulus",
            3.0 * d.membrane_shear_modulus,
        )? / 3.0,
        membrane_thickness: ctx.positive(
            &c.membrane.thickness,
            "cell.membrane.thickness",
            d.membrane_thickness,
        )?,
        actin: crate::cell::suspended::ActinMaterial {
            youngs_modulus: ctx.positive(
                &c.actin.youngs_modulus,
                "cell.actin.youngs_modulus",
                d.actin.youngs_modulus,
            )?,
            diameter: ctx.positive(&c.actin.diameter, "cell.actin.diameter", d.actin.diameter)?,
            prestrain: match &c.actin.prestrain {
                Some(p) if !(p.get_ref().0 > -1.0 && p.get_ref().0.is_finite()) => {
                    return Err(ctx.invalid(
                        Some(p.span()),
                        "cell.actin.prestrain",
                        format!("expected a prestrain > -100 %; found {}", p.get_ref()),
                    ))
                }
                p => ratio(p, d.actin.prestrain),
            },
        },
        microtubule: crate::cell::suspended::MicrotubuleMaterial {
            youngs_modulus: ctx.positive(
                &mt.youngs_modulus,
                "cell.microtubules.youngs_modulus",
                d.microtubule.youngs_modulus,
            )?,
            outer_diameter: ctx.positive(
                &mt.outer_diameter,
                "cell.microtubules.outer_diameter",
                d.microtubule.outer_diameter,
            )?,
            inner_diameter: ctx.positive(
                &mt.inner_diameter,
                "cell.microtubules.inner_diameter",
                d.microtubule.inner_diameter,
            )?,
            poisson_ratio: nu(
                &mt.poisson_ratio,
                "cell.microtubules.poisson_ratio",
                d.microtubule.poisson_ratio,
            )?,
        },
        intermediate: crate::cell::suspended::IntermediateMaterial {
            youngs_modulus: ctx.positive(
                &ifs.youngs_modulus,
                "cell.intermediate.youngs_modulus",
                d.intermediate.youngs_modulus,
            )?,
            diameter: ctx.positive(
                &ifs.diameter,
                "cell.intermediate.diameter",
                d.intermediate.diameter,
            )?,
            slack: match &ifs.slack {
                Some(s) if !(s.get_ref().0 >= 0.0 && s.get_ref().0.is_finite()) => {
                    return Err(ctx.invalid(
                        Some(s.span()),
                        "cell.intermediate.slack",
                        format!("expected a slack ≥ 0 %; found {}", s.get_ref()),
                    ))
                }
                s => ratio(s, d.intermediate.slack),
            },
        },
    };
    let SuspendedCellParts {
        geometry,
        mesh,
        materials: assignments,
        structures,
    } = suspended_cell_parts(&params, &materials, Components::default())
        .map_err(|e| ctx.invalid(span.clone(), "cell", e.to_string()))?;
    let study = CellStudy {
        model: "suspended".into(),
        seed: params.seed,
        cell_diameter: params.cell_diameter,
        nucleus_diameter: params.nucleus_diameter,
        axis: 0,
        nucleus_surface: mesh
            .node_sets
            .get("inner_surface")
            .cloned()
            .unwrap_or_default(),
        params: serde_json::json!({
            "cell_diameter_um": params.cell_diameter,
            "nucleus_diameter_um": params.nucleus_diameter,
            "mesh": {
                "core_divisions": params.mesh.core_divisions,
                "shell_layers": params.mesh.shell_layers,
                "outer_layers": params.mesh.outer_layers,
                "hex8_elements": params.mesh.elements(),
            },
            "fa_orientation": format!("{:?}", params.fa_orientation),
            "mt_elements": params.mt_elements,
            "mt_bow": [params.mt_bow_min, params.mt_bow_max],
            "mt_clearance_margin_um": params.mt_clearance_margin,
            "centrosome_gap_um": params.centrosome_gap,
            "centrosome_direction": params.centrosome_direction,
            "ifs_per_fa": params.ifs_per_fa,
            "if_phase_rad": params.if_phase,
            "if_anchor_rule": format!("{:?}", params.if_anchor_rule),
        }),
        materials,
        geometry: serde_json::json!({
            "max_fa_snap_um": geometry.report.max_snap_distance,
            "max_relative_fa_snap": geometry.report.max_relative_snap_distance,
            "min_scaled_jacobian_after_snap": geometry.report.min_scaled_jacobian_after_snap,
            "af_length_um": geometry.report.af_length,
            "min_mt_clearance_um": geometry.report.min_mt_clearance,
            "mt_curvature_range_per_um": [geometry.report.mt_curvature_range.0, geometry.report.mt_curvature_range.1],
            "max_if_anchor_error_um": geometry.report.max_if_anchor_error,
            "max_if_tangency_error_deg": geometry.report.max_if_tangency_error_deg,
            "max_if_nucleus_penetration_um": geometry.report.max_if_nucleus_penetration,
        }),
        protocol: None,
    };
    Ok(ResolvedCell {
        mesh,
        materials: assignments,
        structures,
        study,
    })
}

/// Largest end elongation accepted, as a multiple of the cell diameter: beyond it the
/// pipettes would pull the cell into a thread the model does not describe.
pub const MAX_ELONGATION_PER_DIAMETER: f64 = 1.5;

/// Tools, steps and the resolved protocol of `[protocol]` on a resolved cell. `mesh` gains
/// the contact node sets `pole_minus` and `pole_plus` (surface nodes with |x| > R/2).
pub(super) fn resolve_protocol(
    origin: &str,
    text: &str,
    section: &Spanned<ProtocolSection>,
    study: &CellStudy,
    mesh: &mut Mesh,
    materials: &[MaterialAssignment],
) -> Result<(Vec<ToolSpec>, Vec<StepSpec>, ProtocolSpec), ScenarioError> {
    let ctx = Ctx { origin, text };
    let p = section.get_ref();
    let kind = p.kind.get_ref().as_str();
    let only = |allowed: &[&str]| -> Result<(), ScenarioError> {
        let given = [
            (
                "pipette_radius",
                p.pipette_radius.as_ref().map(|v| v.span()),
            ),
            ("pinch", p.pinch.as_ref().map(|v| v.span())),
            ("elongation", p.elongation.as_ref().map(|v| v.span())),
            ("deformations", p.deformations.as_ref().map(|v| v.span())),
            ("contact_force", p.contact_force.as_ref().map(|v| v.span())),
            ("max_increment", p.max_increment.as_ref().map(|v| v.span())),
        ];
        match given
            .into_iter()
            .find(|(k, s)| s.is_some() && !allowed.contains(k))
        {
            Some((k, s)) => Err(ctx.invalid(
                s,
                &format!("protocol.{k}"),
                format!("`{k}` does not apply to kind = \"{kind}\""),
            )),
            None => Ok(()),
        }
    };
    let d = study.cell_diameter;
    let r = 0.5 * d;
    let supports_fixed: Vec<(String, [bool; 3])> = SUPPORT_SETS
        .iter()
        .map(|(s, c)| (s.to_string(), *c))
        .collect();
    let prestress = StepSpec {
        name: "prestress".into(),
        control: StepControl {
            initial_increment: 0.1,
            max_increment: 0.2,
            ..StepControl::default()
        },
        fixes: supports_fixed.clone(),
        displacements: Vec::new(),
        forces: Vec::new(),
        tools: Vec::new(),
    };
    if kind == "prestress" {
        only(&[])?;
        return Ok((Vec::new(), vec![prestress], ProtocolSpec::Prestress));
    }
    let tension = match kind {
        "micropipette-tension" => {
            only(&["pipette_radius", "pinch", "elongation", "contact_force", "max_increment"])?;
            true
        }
        "microplate-compression" => {
            only(&["deformations", "contact_force", "max_increment"])?;
            false
        }
        other => {
            return Err(ctx.invalid(
                Some(p.kind.span()),
                "protocol.kind",
                format!(
                    "expected \"micropipette-tension\", \"microplate-compression\" or \"prestress\"; found \"{other}\""
                ),
            ))
        }
    };
    let surface = mesh.node_sets.get("surface").cloned().unwrap_or_default();
    for (name, side) in [("pole_minus", -1.0), ("pole_plus", 1.0)] {
        let nodes: Vec<usize> = surface
            .iter()
            .copied()
            .filter(|&n| mesh.nodes[n][0] * side > 0.5 * r)
            .collect();
        mesh.insert_node_set(name, nodes);
    }
    let max_increment = match &p.max_increment {
        Some(v) if !(*v.get_ref() > 0.0 && *v.get_ref() <= 1.0) => {
            return Err(ctx.invalid(
                Some(v.span()),
                "protocol.max_increment",
                format!(
                    "expected a fraction of the step in (0, 1]; found {}",
                    v.get_ref()
                ),
            ))
        }
        v => plain(v, 0.1),
    };
    let contact_force = ctx.positive(&p.contact_force, "protocol.contact_force", 0.1)?;
    let (names, shapes) = if tension {
        let radius = ctx.positive(&p.pipette_radius, "protocol.pipette_radius", 4.0)?;
        if radius >= r {
            return Err(ctx.invalid(
                p.pipette_radius.as_ref().map(|v| v.span()),
                "protocol.pipette_radius",
                format!(
                    "expected a pipette radius below the cell radius {r} um (a pipette holds one pole); found {radius} um"
                ),
            ));
        }
        let disk = |side: f64| ToolShape::Disk {
            center: [side * r, 0.0, 0.0],
            normal: [-side, 0.0, 0.0],
            radius,
        };
        (["fixed_pipette", "moving_pipette"], [disk(-1.0), disk(1.0)])
    } else {
        let plate = |side: f64| ToolShape::Plate {
            point: [side * r, 0.0, 0.0],
            normal: [-side, 0.0, 0.0],
        };
        (["bottom_plate", "top_plate"], [plate(-1.0), plate(1.0)])
    };
    let mut tools = Vec::new();
    for ((name, shape), set) in names.iter().zip(shapes).zip(["pole_minus", "pole_plus"]) {
        let nodes = &mesh.node_sets[set];
        tools.push(ToolSpec {
            name: name.to_string(),
            shape,
            kind: ContactKind::Bonded,
            node_set: set.into(),
            penalty: super::tools::default_penalty(materials, mesh, nodes),
            tolerance: super::tools::default_tolerance(mesh),
        });
    }
    let [fixed, moving] = names.map(String::from);
    let motion = |tool: &str, dx: f64, until: Option<f64>| ToolMotion {
        tool: tool.into(),
        movement: [dx, 0.0, 0.0],
        until_force: until.map(|value| ForceTarget {
            value,
            tolerance: 0.05 * contact_force,
        }),
    };
    let loading = StepControl {
        initial_increment: max_increment.min(0.1),
        max_increment,
        ..StepControl::default()
    };
    // Once the tools hold the cell, the supports are released except the z-hold of the
    // node on the +y axis: bonded patches close to the test axis (a coarse mesh, a small
    // pipette) can leave the rotation about that axis free, which that single DOF removes.
    // It carries (almost) no load; its reaction is reported with the others.
    let axial_rotation_hold = vec![(SUPPORT_SETS[2].0.to_string(), SUPPORT_SETS[2].1)];
    let step = |name: &str, fixes: &[(String, [bool; 3])], tools: Vec<ToolMotion>| StepSpec {
        name: name.into(),
        control: loading,
        fixes: fixes.to_vec(),
        displacements: Vec::new(),
        forces: Vec::new(),
        tools,
    };
    // Approach: both tools move in (up to a quarter diameter each) until the moving one
    // feels `contact_force`; the supports still hold the cell.
    let approach_travel = 0.25 * d;
    let approach = step(
        "approach",
        &supports_fixed,
        vec![
            motion(&fixed, approach_travel, None),
            motion(&moving, -approach_travel, Some(contact_force)),
        ],
    );
    let mut steps = vec![prestress, approach];
    let spec = if tension {
        let pinch = ctx.positive(&p.pinch, "protocol.pinch", 1.0)?;
        let elongation = ctx.positive(&p.elongation, "protocol.elongation", 6.3)?;
        if elongation > MAX_ELONGATION_PER_DIAMETER * d {
            return Err(ctx.invalid(
                p.elongation.as_ref().map(|v| v.span()),
                "protocol.elongation",
                format!(
                    "expected an elongation up to {MAX_ELONGATION_PER_DIAMETER} cell diameters ({:.1} um); found {elongation} um",
                    MAX_ELONGATION_PER_DIAMETER * d
                ),
            ));
        }
        if pinch >= 0.25 * d {
            return Err(ctx.invalid(
                p.pinch.as_ref().map(|v| v.span()),
                "protocol.pinch",
                format!("expected a slight pinch, below a quarter diameter ({:.2} um); found {pinch} um", 0.25 * d),
            ));
        }
        steps.push(step(
            "pinch",
            &supports_fixed,
            vec![
                motion(&fixed, 0.5 * pinch, None),
                motion(&moving, -0.5 * pinch, None),
            ],
        ));
        // Retract the moving pipette until its force is zero: the unloaded reference state.
        steps.push(step(
            "retract",
            &axial_rotation_hold,
            vec![motion(&moving, approach_travel, Some(0.0))],
        ));
        steps.push(step(
            "stretch",
            &axial_rotation_hold,
            vec![motion(&moving, elongation, None)],
        ));
        ProtocolSpec::MicropipetteTension {
            moving_tool: moving,
            reference_step: 3,
            stretch_step: 4,
            elongation,
            pipette_radius: match &tools[0].shape {
                ToolShape::Disk { radius, .. } => *radius,
                _ => 0.0,
            },
        }
    } else {
        let deformations: Vec<f64> = match &p.deformations {
            None => vec![0.1, 0.3, 0.5],
            Some(v) => {
                let list: Vec<f64> = v.get_ref().iter().map(|r| r.0).collect();
                let ok = !list.is_empty()
                    && list.iter().all(|&e| e > 0.0 && e < 0.9)
                    && list.windows(2).all(|w| w[1] > w[0]);
                if !ok {
                    return Err(ctx.invalid(
                        Some(v.span()),
                        "protocol.deformations",
                        format!(
                            "expected increasing deformations of the diameter in (0 %, 90 %), e.g. [\"10%\", \"30%\", \"50%\"]; found {list:?}"
                        ),
                    ));
                }
                list
            }
        };
        let mut previous = 0.0;
        let mut targets = Vec::new();
        for e in &deformations {
            targets.push((steps.len(), *e));
            steps.push(step(
                &format!("compress-{:.0}", 100.0 * e),
                &axial_rotation_hold,
                vec![motion(&moving, -(e - previous) * d, None)],
            ));
            previous = *e;
        }
        ProtocolSpec::MicroplateCompression {
            moving_tool: moving,
            contact_step: 1,
            deformations: targets,
        }
    };
    Ok((tools, steps, spec))
}
