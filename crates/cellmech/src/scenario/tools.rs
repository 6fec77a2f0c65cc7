//! `[[tool]]` sections (plates, micropipette disks, AFM tips, colloidal probes) and their
//! per-step motion `[[step.tool]]`, resolved into [`ToolSpec`]s and [`ToolMotion`]s (see
//! [`crate::model::tools`] for the defaults).

use cellmech_fem::contact::{ContactKind, ToolShape};
use cellmech_fem::mesh::Mesh;
use toml::Spanned;

use super::context::Ctx;
use super::file::{StepToolSection, ToolSection};
use super::{MaterialAssignment, ScenarioError};
pub use crate::model::tools::{
    default_penalty, default_tolerance, largest_shear_modulus, mesh_diagonal, tool_program,
    ForceTarget, ToolMotion, ToolSpec, FORCE_TOLERANCE_FACTOR, PENALTY_FACTOR, TOLERANCE_FACTOR,
};
use crate::units::Length;

/// Resolves the `[[tool]]` sections against the mesh and materials.
pub(super) fn resolve_tools(
    ctx: &Ctx,
    sections: &[ToolSection],
    mesh: &Mesh,
    materials: &[MaterialAssignment],
) -> Result<Vec<ToolSpec>, ScenarioError> {
    let mut tools: Vec<ToolSpec> = Vec::new();
    for (i, s) in sections.iter().enumerate() {
        let key = |k: &str| format!("tool[{i}].{k}");
        let name = s.name.get_ref().clone();
        if name.is_empty() {
            return Err(ctx.invalid(
                Some(s.name.span()),
                &key("name"),
                "expected a non-empty tool name; found \"\"",
            ));
        }
        if tools.iter().any(|t| t.name == name) {
            return Err(ctx.invalid(
                Some(s.name.span()),
                &key("name"),
                format!("a tool named \"{name}\" is already defined; tool names must be unique"),
            ));
        }
        let shape_name = s.shape.get_ref().as_str();
        let shape_span = Some(s.shape.span());
        // Keys that belong to each shape; any other geometry key is rejected.
        let allowed: &[&str] = match shape_name {
            "plate" => &["point", "normal"],
            "disk" => &["center", "normal", "radius"],
            "paraboloid" => &["apex", "axis", "tip_radius"],
            "sphere" => &["center", "radius"],
            other => {
                return Err(ctx.invalid(
                    shape_span,
                    &key("shape"),
                    format!(
                    "expected \"plate\", \"disk\", \"paraboloid\" or \"sphere\"; found \"{other}\""
                ),
                ))
            }
        };
        let given = [
            ("point", s.point.as_ref().map(|v| v.span())),
            ("center", s.center.as_ref().map(|v| v.span())),
            ("apex", s.apex.as_ref().map(|v| v.span())),
            ("normal", s.normal.as_ref().map(|v| v.span())),
            ("axis", s.axis.as_ref().map(|v| v.span())),
            ("radius", s.radius.as_ref().map(|v| v.span())),
            ("tip_radius", s.tip_radius.as_ref().map(|v| v.span())),
        ];
        for (k, span) in &given {
            if let Some(span) = span {
                if !allowed.contains(k) {
                    return Err(ctx.invalid(
                        Some(span.clone()),
                        &key(k),
                        format!(
                            "`{k}` does not apply to a tool with shape = \"{shape_name}\"; it takes {}",
                            allowed.join(", ")
                        ),
                    ));
                }
            }
        }
        let missing = |k: &str, example: &str| {
            ctx.invalid(
                shape_span.clone(),
                &key(k),
                format!("a {shape_name} tool needs `{k} = {example}`; found none"),
            )
        };
        let point3 = |v: &Option<Spanned<[Length; 3]>>, k: &str| {
            v.as_ref()
                .map(|p| p.get_ref().map(|l| l.0))
                .ok_or_else(|| missing(k, "[\"0 um\", \"0 um\", \"16 um\"]"))
        };
        let unit = |v: &Option<Spanned<[f64; 3]>>, k: &str| {
            let v = v.as_ref().ok_or_else(|| missing(k, "[0, 0, -1]"))?;
            let d = *v.get_ref();
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            if !(n > 0.0 && n.is_finite()) {
                return Err(ctx.invalid(
                    Some(v.span()),
                    &key(k),
                    format!("expected a non-zero direction; found {d:?}"),
                ));
            }
            Ok(d.map(|x| x / n))
        };
        let positive = |v: &Option<Spanned<Length>>, k: &str| {
            let v = v.as_ref().ok_or_else(|| missing(k, "\"5 um\""))?;
            let r = v.get_ref().0;
            if !(r > 0.0 && r.is_finite()) {
                return Err(ctx.invalid(
                    Some(v.span()),
                    &key(k),
                    format!("expected a length > 0; found {}", v.get_ref()),
                ));
            }
            Ok(r)
        };
        let shape = match shape_name {
            "plate" => ToolShape::Plate {
                point: point3(&s.point, "point")?,
                normal: unit(&s.normal, "normal")?,
            },
            "disk" => ToolShape::Disk {
                center: point3(&s.center, "center")?,
                normal: unit(&s.normal, "normal")?,
                radius: positive(&s.radius, "radius")?,
            },
            "paraboloid" => ToolShape::Paraboloid {
                apex: point3(&s.apex, "apex")?,
                axis: unit(&s.axis, "axis")?,
                tip_radius: positive(&s.tip_radius, "tip_radius")?,
            },
            _ => ToolShape::Sphere {
                center: point3(&s.center, "center")?,
                radius: positive(&s.radius, "radius")?,
            },
        };
        let kind = match s.contact.as_ref().map(|c| (c.get_ref().as_str(), c.span())) {
            None | Some(("frictionless", _)) => ContactKind::Frictionless,
            Some(("bonded", _)) => ContactKind::Bonded,
            Some((other, span)) => {
                return Err(ctx.invalid(
                    Some(span),
                    &key("contact"),
                    format!("expected \"frictionless\" or \"bonded\"; found \"{other}\""),
                ))
            }
        };
        let set_name = s.node_set.get_ref();
        let nodes = match mesh.node_sets.get(set_name) {
            Some(nodes) if !nodes.is_empty() => nodes,
            Some(_) => {
                return Err(ctx.invalid(
                    Some(s.node_set.span()),
                    &key("node_set"),
                    format!("expected a node set with contact candidates; \"{set_name}\" is empty"),
                ))
            }
            None => {
                let known: Vec<&str> = mesh.node_sets.keys().map(String::as_str).collect();
                return Err(ctx.invalid(
                    Some(s.node_set.span()),
                    &key("node_set"),
                    format!("no node set \"{set_name}\" in the mesh; it has {known:?}"),
                ));
            }
        };
        let penalty = match &s.penalty {
            Some(p) => {
                let v = p.get_ref().0;
                if !(v > 0.0 && v.is_finite()) {
                    return Err(ctx.invalid(
                        Some(p.span()),
                        &key("penalty"),
                        format!("expected a stiffness > 0; found {}", p.get_ref()),
                    ));
                }
                v
            }
            None => {
                let g = largest_shear_modulus(materials);
                if !(g > 0.0) {
                    return Err(ctx.invalid(
                        Some(s.name.span()),
                        &key("penalty"),
                        "no material gives a shear modulus to choose the default penalty from; \
                         give `penalty = \"1 nN/um\"`",
                    ));
                }
                default_penalty(materials, mesh, nodes)
            }
        };
        let tolerance = match &s.tolerance {
            Some(t) => {
                let v = t.get_ref().0;
                if !(v > 0.0 && v.is_finite()) {
                    return Err(ctx.invalid(
                        Some(t.span()),
                        &key("tolerance"),
                        format!("expected a length > 0; found {}", t.get_ref()),
                    ));
                }
                v
            }
            None => default_tolerance(mesh),
        };
        // Initial penetration: the body's reference shape must not start inside the tool.
        let deepest = nodes
            .iter()
            .filter_map(|&n| shape.gap(&mesh.nodes[n], &[0.0; 3]))
            .map(|g| g.value)
            .fold(f64::INFINITY, f64::min);
        if deepest < -10.0 * tolerance {
            return Err(ctx.invalid(
                Some(s.name.span()),
                &key("name"),
                format!(
                    "tool \"{name}\" starts inside the body: a node of \"{set_name}\" lies {:.4} um \
                     inside it (tolerance {tolerance:.3e} um); place the tool at or outside the surface",
                    -deepest
                ),
            ));
        }
        tools.push(ToolSpec {
            name,
            shape,
            kind,
            node_set: set_name.clone(),
            faces: Vec::new(),
            penalty,
            tolerance,
            curvature_tangent: Default::default(),
            aim: None,
            watch: Vec::new(),
        });
    }
    Ok(tools)
}

/// Resolves the `[[step.tool]]` entries of step `i`.
pub(super) fn resolve_step_tools(
    ctx: &Ctx,
    i: usize,
    sections: &[StepToolSection],
    tools: &[ToolSpec],
    mesh: &Mesh,
    materials: &[MaterialAssignment],
) -> Result<Vec<ToolMotion>, ScenarioError> {
    let mut out: Vec<ToolMotion> = Vec::new();
    let mut stop_key: Option<String> = None;
    for (j, s) in sections.iter().enumerate() {
        let key = |k: &str| format!("step[{i}].tool[{j}].{k}");
        let name = s.name.get_ref();
        if !tools.iter().any(|t| &t.name == name) {
            let known: Vec<&str> = tools.iter().map(|t| t.name.as_str()).collect();
            return Err(ctx.invalid(
                Some(s.name.span()),
                &key("name"),
                format!("no [[tool]] named \"{name}\"; the tools are {known:?}"),
            ));
        }
        if out.iter().any(|m| &m.tool == name) {
            return Err(ctx.invalid(
                Some(s.name.span()),
                &key("name"),
                format!("tool \"{name}\" is listed twice in this step"),
            ));
        }
        let movement = s
            .movement
            .as_ref()
            .map(|m| m.get_ref().map(|l| l.0))
            .unwrap_or([0.0; 3]);
        let until_force = match &s.until_force {
            None => {
                if let Some(t) = &s.force_tolerance {
                    return Err(ctx.invalid(
                        Some(t.span()),
                        &key("force_tolerance"),
                        "`force_tolerance` applies only with `until_force`",
                    ));
                }
                None
            }
            Some(f) => {
                if let Some(previous) = &stop_key {
                    return Err(ctx.invalid(
                        Some(f.span()),
                        &key("until_force"),
                        format!(
                            "a step can stop on one condition only; {previous} already sets one"
                        ),
                    ));
                }
                stop_key = Some(key("until_force"));
                if movement.iter().all(|&m| m == 0.0) {
                    return Err(ctx.invalid(
                        Some(f.span()),
                        &key("until_force"),
                        format!(
                            "tool \"{name}\" must move to reach a force: give `move = [\"0 um\", \"0 um\", \"1 um\"]`; found no motion"
                        ),
                    ));
                }
                let tolerance = match &s.force_tolerance {
                    Some(t) => {
                        let v = t.get_ref().0;
                        if !(v > 0.0 && v.is_finite()) {
                            return Err(ctx.invalid(
                                Some(t.span()),
                                &key("force_tolerance"),
                                format!("expected a force > 0; found {}", t.get_ref()),
                            ));
                        }
                        v
                    }
                    None => {
                        let d = mesh_diagonal(mesh);
                        let scale = largest_shear_modulus(materials) * d * d;
                        if scale > 0.0 {
                            FORCE_TOLERANCE_FACTOR * scale
                        } else {
                            1e-6
                        }
                    }
                };
                Some(ForceTarget {
                    value: f.get_ref().0,
                    tolerance,
                })
            }
        };
        out.push(ToolMotion {
            tool: name.clone(),
            movement,
            until_force,
            until_contact: None,
        });
    }
    Ok(out)
}

/// Checks, before solving, that each tool reaches the body in the first step where it
/// moves: the smallest gap of its contact nodes (in their reference position) must not
/// exceed the tool's travel towards the body in that step.
pub(super) fn check_reach(
    ctx: &Ctx,
    tools: &[ToolSpec],
    step_names: &[String],
    motions: &[Vec<ToolMotion>],
    raw_steps: &[Vec<StepToolSection>],
    mesh: &Mesh,
) -> Result<(), ScenarioError> {
    for tool in tools {
        let program = tool_program(&tool.name, motions);
        let Some(k) = motions.iter().position(|ms| {
            ms.iter()
                .any(|m| m.tool == tool.name && m.movement.iter().any(|&d| d != 0.0))
        }) else {
            continue;
        };
        let start = if k == 0 { [0.0; 3] } else { program[k - 1] };
        let movement: [f64; 3] = std::array::from_fn(|c| program[k][c] - start[c]);
        let length = movement.iter().map(|d| d * d).sum::<f64>().sqrt();
        let travel = match tool.shape.axis() {
            Some(axis) => (0..3).map(|c| movement[c] * axis[c]).sum::<f64>(),
            None => length,
        };
        let nodes = &mesh.node_sets[&tool.node_set];
        let gap = nodes
            .iter()
            .filter_map(|&n| tool.shape.gap(&mesh.nodes[n], &start))
            .map(|g| g.value)
            .fold(f64::INFINITY, f64::min);
        let j = motions[k]
            .iter()
            .position(|m| m.tool == tool.name)
            .unwrap_or(0);
        let span = raw_steps[k]
            .get(j)
            .map(|s| s.movement.as_ref().map_or(s.name.span(), |m| m.span()));
        let key = format!("step[{k}].tool[{j}].move");
        if gap.is_infinite() {
            return Err(ctx.invalid(
                span,
                &key,
                format!(
                    "tool \"{}\" never touches the body in step \"{}\": no node of \"{}\" lies within its radius",
                    tool.name, step_names[k], tool.node_set
                ),
            ));
        }
        if gap > travel + tool.tolerance {
            return Err(ctx.invalid(
                span,
                &key,
                format!(
                    "tool \"{}\" never touches the body in step \"{}\": the smallest gap to \"{}\" is {gap:.4} um \
                     but the tool travels {travel:.4} um towards the body; move it further or place it closer",
                    tool.name, step_names[k], tool.node_set
                ),
            ));
        }
    }
    Ok(())
}

/// Resolves the tools of `raw` and fills in the tool motions of the resolved `steps`
/// (called by `resolve` after the steps), then checks that every moving tool reaches the
/// body.
pub(super) fn resolve(
    origin: &str,
    text: &str,
    raw: &super::file::ScenarioFile,
    mesh: &Mesh,
    materials: &[MaterialAssignment],
    mut steps: Vec<super::StepSpec>,
) -> Result<(Vec<ToolSpec>, Vec<super::StepSpec>), ScenarioError> {
    let ctx = Ctx { origin, text };
    let tools = resolve_tools(&ctx, &raw.tools, mesh, materials)?;
    for (i, (spec, section)) in steps.iter_mut().zip(&raw.steps).enumerate() {
        spec.tools = resolve_step_tools(&ctx, i, &section.tool, &tools, mesh, materials)?;
    }
    let names: Vec<String> = steps.iter().map(|s| s.name.clone()).collect();
    let motions: Vec<Vec<ToolMotion>> = steps.iter().map(|s| s.tools.clone()).collect();
    let raw_steps: Vec<Vec<StepToolSection>> = raw.steps.iter().map(|s| s.tool.clone()).collect();
    check_reach(&ctx, &tools, &names, &motions, &raw_steps, mesh)?;
    Ok((tools, steps))
}
