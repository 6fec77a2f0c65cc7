//! Resolution of the raw file: defaults, ranges, units, and references to mesh sets.

use std::path::Path;

use cellmech_fem::element::hex8::Hex8Formulation;
use cellmech_fem::material::NeoHookean;
use cellmech_fem::mesh::generate::{box_mesh, sphere_mesh, SphereMeshSpec};
use cellmech_fem::mesh::{ElementKind, Mesh};
use cellmech_fem::solve::{
    Activation, Convergence, Extrapolation, IterationMethod, Stabilization, StepControl,
};
use toml::Spanned;

use super::context::Ctx;
use super::file::{MaterialSection, MeshSection, NodeSetSection, ScenarioFile, StepSection};
use super::{
    CurveSpec, MaterialAssignment, ModelSpec, OutputSpec, PlotFormat, Scenario, ScenarioError,
    StepSpec,
};

/// Resolves a parsed file into a [`Scenario`].
pub fn resolve(
    raw: ScenarioFile,
    echo: toml::Table,
    text: &str,
    origin: &str,
    base_dir: &Path,
) -> Result<Scenario, ScenarioError> {
    let ctx = Ctx { origin, text };
    let (mut mesh, mut cell) = match (&raw.mesh, &raw.cell) {
        (Some(m), None) => (resolve_mesh(&ctx, m, base_dir)?, None),
        (None, Some(c)) => {
            let built = super::cell::resolve_cell(&ctx, c.span())?;
            (built.model.mesh.clone(), Some(built))
        }
        (Some(m), Some(_)) => {
            return Err(ctx.invalid(
                Some(m.source.span()),
                "mesh",
                "give either [mesh] (with [[material]] and filaments) or [cell] (a built-in cell model), not both",
            ))
        }
        (None, None) => {
            return Err(ctx.invalid(
                None,
                "mesh",
                "expected a [mesh] section (or [cell] for a built-in cell model); found neither",
            ))
        }
    };
    for section in &raw.node_sets {
        select_node_set(&ctx, section, &mut mesh)?;
    }
    let materials = match &cell {
        Some(c) => {
            if let Some(m) = raw.materials.first() {
                return Err(ctx.invalid(
                    Some(m.element_set.span()),
                    "material[0]",
                    "a [cell] model sets its materials in [cell.cytoplasm] and [cell.nucleus]; remove [[material]]",
                ));
            }
            c.model.materials.clone()
        }
        None => resolve_materials(&ctx, &raw.materials, &mesh)?,
    };
    let initial = cell
        .as_ref()
        .map(|c| c.model.structures.clone())
        .unwrap_or_default();
    let structures = super::structures::resolve_structures(
        initial,
        &raw.filaments,
        &raw.membranes,
        &raw.families,
        &mesh,
        text,
        origin,
    )?;
    let mut output = resolve_output(&ctx, &raw.output, &mesh)?;
    let mut plan = None;
    let (tools, steps) = match (&raw.protocol, &mut cell) {
        (Some(p), Some(built)) => {
            if !raw.steps.is_empty() {
                return Err(ctx.invalid(
                    Some(p.span()),
                    "step",
                    "[protocol] writes the analysis steps; remove the [[step]] sections (or the [protocol])",
                ));
            }
            if let Some(t) = raw.tools.first() {
                return Err(ctx.invalid(
                    Some(t.name.span()),
                    "tool[0]",
                    "[protocol] places its own tools; remove the [[tool]] sections (or the [protocol])",
                ));
            }
            built.model.mesh = mesh;
            built.model.materials = materials.clone();
            plan = Some(super::cell::resolve_protocol(&ctx, p.span(), built)?);
            mesh = built.model.mesh.clone();
            // The protocol's own reaction curves (its handles index them) come first.
            let protocol_curves = std::mem::take(&mut built.model.output.curves);
            output.curves.splice(0..0, protocol_curves);
            (
                std::mem::take(&mut built.model.tools),
                std::mem::take(&mut built.model.steps),
            )
        }
        (Some(p), None) => {
            return Err(ctx.invalid(
                Some(p.span()),
                "protocol",
                "a [protocol] runs on a built-in cell model: add a [cell] section",
            ))
        }
        (None, _) => {
            if raw.steps.is_empty() {
                return Err(ctx.invalid(
                    None,
                    "step",
                    "at least one [[step]] (or a [protocol] on a [cell]) is required; found none",
                ));
            }
            let steps = raw
                .steps
                .iter()
                .enumerate()
                .map(|(i, s)| resolve_step(&ctx, i, s, &mesh))
                .collect::<Result<Vec<_>, _>>()?;
            super::tools::resolve(origin, text, &raw, &mesh, &materials, steps)?
        }
    };
    let (supports, shape_probes, embedded, hanging, prestressed_reference, rezone) = match &cell {
        Some(c) => (
            c.model.supports.clone(),
            c.model.shape_probes.clone(),
            c.model.embedded.clone(),
            c.model.hanging.clone(),
            c.model.prestressed_reference.clone(),
            c.model.rezone.clone(),
        ),
        None => Default::default(),
    };
    let study = cell.map(|c| crate::analysis::CellStudy {
        description: c.description,
        protocol: plan,
    });
    Ok(Scenario {
        title: raw.title.unwrap_or_else(|| "cellmech analysis".into()),
        origin: origin.into(),
        model: ModelSpec {
            mesh,
            materials,
            structures,
            tools,
            steps,
            output,
            supports,
            shape_probes,
            embedded,
            hanging,
            prestressed_reference,
            rezone,
        },
        cell: study,
        echo,
    })
}

fn resolve_mesh(ctx: &Ctx, m: &MeshSection, base_dir: &Path) -> Result<Mesh, ScenarioError> {
    let source = m.source.get_ref().as_str();
    let span = Some(m.source.span());
    let given = |name: &str, present: bool| present.then(|| name.to_string());
    let box_keys = [
        given("origin", m.origin.is_some()),
        given("size", m.size.is_some()),
        given("divisions", m.divisions.is_some()),
        given("element_set", m.element_set.is_some()),
    ];
    let sphere_keys = [
        given("radius", m.radius.is_some()),
        given("inner_radius", m.inner_radius.is_some()),
        given("core_divisions", m.core_divisions.is_some()),
        given("shell_layers", m.shell_layers.is_some()),
        given("outer_layers", m.outer_layers.is_some()),
    ];
    let file_keys = [given("path", m.path.is_some())];
    let reject = |keys: &[Option<String>]| -> Result<(), ScenarioError> {
        match keys.iter().flatten().next() {
            Some(k) => Err(ctx.invalid(
                span.clone(),
                &format!("mesh.{k}"),
                format!("`{k}` does not apply to a mesh with source = \"{source}\""),
            )),
            None => Ok(()),
        }
    };
    let mesh = match source {
        "box" => {
            reject(&sphere_keys)?;
            reject(&file_keys)?;
            let size = m.size.ok_or_else(|| {
                ctx.invalid(
                    span.clone(),
                    "mesh.size",
                    "a box needs `size = [\"10 um\", \"10 um\", \"10 um\"]`",
                )
            })?;
            let divisions = m.divisions.ok_or_else(|| {
                ctx.invalid(
                    span.clone(),
                    "mesh.divisions",
                    "a box needs `divisions = [nx, ny, nz]`",
                )
            })?;
            let origin = m.origin.map(|o| o.map(|l| l.0)).unwrap_or([0.0; 3]);
            let name = m.element_set.clone().unwrap_or_else(|| "solid".into());
            box_mesh(origin, size.map(|l| l.0), divisions, &name)
                .map_err(|e| ctx.invalid(span.clone(), "mesh", e.to_string()))?
        }
        "sphere" => {
            reject(&box_keys)?;
            reject(&file_keys)?;
            let radius = m.radius.ok_or_else(|| {
                ctx.invalid(
                    span.clone(),
                    "mesh.radius",
                    "a sphere needs `radius = \"16.132 um\"`",
                )
            })?;
            let defaults = SphereMeshSpec::default();
            let spec = SphereMeshSpec {
                radius: radius.0,
                inner_radius: m.inner_radius.map(|r| r.0),
                core_divisions: m.core_divisions.unwrap_or(defaults.core_divisions),
                shell_layers: m.shell_layers.unwrap_or(defaults.shell_layers),
                outer_layers: m.outer_layers.unwrap_or(defaults.outer_layers),
                ..defaults
            };
            sphere_mesh(&spec).map_err(|e| ctx.invalid(span.clone(), "mesh", e.to_string()))?
        }
        "file" => {
            reject(&box_keys)?;
            reject(&sphere_keys)?;
            let rel = m.path.as_ref().ok_or_else(|| {
                ctx.invalid(
                    span.clone(),
                    "mesh.path",
                    "a mesh file needs `path = \"cell.msh\"`",
                )
            })?;
            let path = base_dir.join(rel);
            crate::mesh_file::read_mesh(&path).map_err(|message| ScenarioError::Mesh {
                path: ctx.origin.into(),
                message,
            })?
        }
        other => {
            return Err(ctx.invalid(
                span,
                "mesh.source",
                format!("expected \"box\", \"sphere\" or \"file\"; found \"{other}\""),
            ))
        }
    };
    mesh.validate().map_err(|e| ScenarioError::Mesh {
        path: ctx.origin.into(),
        message: e.to_string(),
    })?;
    Ok(mesh)
}

fn resolve_materials(
    ctx: &Ctx,
    sections: &[MaterialSection],
    mesh: &Mesh,
) -> Result<Vec<MaterialAssignment>, ScenarioError> {
    let mut out = Vec::new();
    for (i, s) in sections.iter().enumerate() {
        let key = |k: &str| format!("material[{i}].{k}");
        let set = s.element_set.get_ref();
        let span = Some(s.element_set.span());
        if mesh.block(set).is_none() {
            let known: Vec<&str> = mesh.blocks.iter().map(|b| b.name.as_str()).collect();
            return Err(ctx.invalid(
                span,
                &key("element_set"),
                format!("no element set \"{set}\" in the mesh; it has {known:?}"),
            ));
        }
        if out
            .iter()
            .any(|m: &MaterialAssignment| &m.element_set == set)
        {
            return Err(ctx.invalid(
                span,
                &key("element_set"),
                format!("element set \"{set}\" already has a material"),
            ));
        }
        if s.model.get_ref() != "neo-hookean" {
            return Err(ctx.invalid(
                Some(s.model.span()),
                &key("model"),
                format!("expected \"neo-hookean\"; found \"{}\"", s.model.get_ref()),
            ));
        }
        let law =
            material_law(s).map_err(|m| ctx.invalid(span.clone(), &key("shear_modulus"), m))?;
        let formulation = match s
            .formulation
            .as_ref()
            .map(|f| (f.get_ref().as_str(), f.span()))
        {
            None | Some(("mean-dilatation", _)) => Hex8Formulation::MeanDilatation,
            Some(("displacement", _)) => Hex8Formulation::Displacement,
            Some((other, sp)) => {
                return Err(ctx.invalid(
                    Some(sp),
                    &key("formulation"),
                    format!("expected \"mean-dilatation\" or \"displacement\"; found \"{other}\""),
                ))
            }
        };
        out.push(MaterialAssignment {
            element_set: set.clone(),
            law,
            formulation,
        });
    }
    // Surface and line blocks of a mesh file (e.g. Gmsh physical surfaces) need no
    // continuum material; volume blocks do.
    let is_volume = |k: ElementKind| {
        matches!(
            k,
            ElementKind::Hex8
                | ElementKind::Tet4
                | ElementKind::Tet10
                | ElementKind::Wedge6
                | ElementKind::Hex20
        )
    };
    for block in mesh.blocks.iter().filter(|b| is_volume(b.kind)) {
        if !out.iter().any(|m| m.element_set == block.name) {
            return Err(ctx.invalid(
                None,
                "material",
                format!("element set \"{}\" has no [[material]]", block.name),
            ));
        }
    }
    Ok(out)
}

/// G and K from any consistent pair of (G, E, K, ν).
fn material_law(s: &MaterialSection) -> Result<NeoHookean, String> {
    let nu = s.poisson_ratio;
    if let Some(nu) = nu {
        if !(nu > -1.0 && nu < 0.5) {
            return Err(format!("poisson_ratio must lie in (-1, 0.5); found {nu}"));
        }
    }
    let g =
        match (s.shear_modulus, s.youngs_modulus, nu) {
            (Some(g), None, _) => g.0,
            (None, Some(e), Some(nu)) => e.0 / (2.0 * (1.0 + nu)),
            (None, Some(_), None) => return Err("youngs_modulus needs poisson_ratio".into()),
            (Some(_), Some(_), _) => {
                return Err("give shear_modulus or youngs_modulus, not both".into())
            }
            (None, None, _) => return Err(
                "a neo-Hookean material needs shear_modulus (or youngs_modulus with poisson_ratio)"
                    .into(),
            ),
        };
    let k = match (s.bulk_modulus, nu) {
        (Some(k), None) => k.0,
        (None, Some(nu)) => 2.0 * g * (1.0 + nu) / (3.0 * (1.0 - 2.0 * nu)),
        (Some(_), Some(_)) if s.youngs_modulus.is_none() => {
            return Err("give bulk_modulus or poisson_ratio, not both".into())
        }
        (Some(k), Some(_)) => k.0,
        (None, None) => {
            return Err("a neo-Hookean material needs bulk_modulus or poisson_ratio".into())
        }
    };
    if !(g > 0.0 && k > 0.0) {
        return Err(format!(
            "moduli must be positive; found G = {g} kPa, K = {k} kPa"
        ));
    }
    Ok(NeoHookean {
        shear_modulus: g,
        bulk_modulus: k,
    })
}

/// `stabilization`, `stabilization_energy_fraction`, `stabilization_accuracy` of a step.
fn stabilization(
    ctx: &Ctx,
    s: &StepSection,
    key: &dyn Fn(&str) -> String,
) -> Result<Option<Stabilization>, ScenarioError> {
    let activation = match &s.stabilization {
        None => None,
        Some(word) => match word.get_ref().as_str() {
            "off" => None,
            "on-difficulty" => Some(Activation::OnDifficulty),
            "always" => Some(Activation::Always),
            other => {
                return Err(ctx.invalid(
                    Some(word.span()),
                    &key("stabilization"),
                    format!("expected \"off\", \"on-difficulty\" or \"always\"; found \"{other}\""),
                ))
            }
        },
    };
    let tuned = s.stabilization_energy_fraction.is_some() || s.stabilization_accuracy.is_some();
    let Some(activation) = activation else {
        if tuned {
            return Err(ctx.invalid(
                None,
                &key("stabilization"),
                "stabilization_energy_fraction / stabilization_accuracy need stabilization = \"on-difficulty\" or \"always\"; found none",
            ));
        }
        return Ok(None);
    };
    let defaults = Stabilization::default();
    let settings = Stabilization {
        activation,
        energy_fraction: s
            .stabilization_energy_fraction
            .unwrap_or(defaults.energy_fraction),
        accuracy_tolerance: s
            .stabilization_accuracy
            .unwrap_or(defaults.accuracy_tolerance),
        ..defaults
    };
    settings
        .validate()
        .map_err(|message| ctx.invalid(None, &key("stabilization"), message))?;
    Ok(Some(settings))
}

fn component(ctx: &Ctx, c: &Spanned<String>, key: &str) -> Result<usize, ScenarioError> {
    match c.get_ref().as_str() {
        "x" => Ok(0),
        "y" => Ok(1),
        "z" => Ok(2),
        other => Err(ctx.invalid(
            Some(c.span()),
            key,
            format!("expected \"x\", \"y\" or \"z\"; found \"{other}\""),
        )),
    }
}

fn node_set(
    ctx: &Ctx,
    mesh: &Mesh,
    set: &Spanned<String>,
    key: &str,
) -> Result<String, ScenarioError> {
    let name = set.get_ref();
    match mesh.node_sets.get(name) {
        Some(nodes) if !nodes.is_empty() => Ok(name.clone()),
        Some(_) => Err(ctx.invalid(
            Some(set.span()),
            key,
            format!("node set \"{name}\" is empty"),
        )),
        None => {
            let known: Vec<&str> = mesh.node_sets.keys().map(String::as_str).collect();
            Err(ctx.invalid(
                Some(set.span()),
                key,
                format!("no node set \"{name}\" in the mesh; it has {known:?}"),
            ))
        }
    }
}

/// A switch written as a word: absent or `on` (the default) is true, `"off"` false, anything
/// else an error naming the key.
fn on_or_off(
    ctx: &Ctx,
    word: Option<&Spanned<String>>,
    on: &str,
    key: &str,
) -> Result<bool, ScenarioError> {
    let Some(word) = word else {
        return Ok(true);
    };
    match word.get_ref().as_str() {
        w if w == on => Ok(true),
        "off" => Ok(false),
        other => Err(ctx.invalid(
            Some(word.span()),
            key,
            format!("expected \"{on}\" or \"off\"; found \"{other}\""),
        )),
    }
}

fn resolve_step(
    ctx: &Ctx,
    i: usize,
    s: &StepSection,
    mesh: &Mesh,
) -> Result<StepSpec, ScenarioError> {
    let key = |k: &str| format!("step[{i}].{k}");
    let defaults = StepControl::default();
    let conv_defaults = Convergence::default();
    let control = StepControl {
        initial_increment: s.initial_increment.unwrap_or(defaults.initial_increment),
        min_increment: s.min_increment.unwrap_or(defaults.min_increment),
        max_increment: s.max_increment.unwrap_or(
            defaults
                .max_increment
                .max(s.initial_increment.unwrap_or(0.0)),
        ),
        convergence: Convergence {
            max_iterations: s.max_iterations.unwrap_or(conv_defaults.max_iterations),
            residual_tolerance: s
                .residual_tolerance
                .unwrap_or(conv_defaults.residual_tolerance),
            energy_tolerance: s.energy_tolerance.unwrap_or(conv_defaults.energy_tolerance),
            ..conv_defaults
        },
        ..defaults
    };
    let c = &control;
    if !(c.min_increment > 0.0
        && c.min_increment <= c.initial_increment
        && c.initial_increment <= c.max_increment
        && c.max_increment <= 1.0)
    {
        return Err(ctx.invalid(
            None,
            &key("initial_increment"),
            format!(
            "need 0 < min_increment <= initial_increment <= max_increment <= 1; found {}, {}, {}",
            c.min_increment, c.initial_increment, c.max_increment),
        ));
    }
    let mut control = control;
    control.stabilization = stabilization(ctx, s, &key)?;
    control.extrapolation = match &s.extrapolation {
        // A continuum with contact takes a third fewer iterations from an extrapolated
        // start (docs/performance.md, "Extrapolated starts").
        None => Extrapolation::Linear,
        Some(word) => match word.get_ref().as_str() {
            "linear" => Extrapolation::Linear,
            "none" => Extrapolation::None,
            other => {
                return Err(ctx.invalid(
                    Some(word.span()),
                    &key("extrapolation"),
                    format!("expected \"linear\" or \"none\"; found \"{other}\""),
                ))
            }
        },
    };
    // Free filaments in fewer global iterations, to the same equilibrium
    // (docs/performance.md, "Nonlinear elimination of the free filaments").
    control.convergence.relaxation =
        on_or_off(ctx, s.relaxation.as_ref(), "filaments", &key("relaxation"))?;
    // Fewer factorisations to the same criteria (docs/performance.md, "Chord steps near
    // convergence").
    control.convergence.chord_near_convergence =
        on_or_off(ctx, s.chord.as_ref(), "near-convergence", &key("chord"))?;
    // Full Newton unless asked (docs/performance.md, "Quasi-Newton (BFGS)").
    if let Some(word) = &s.iteration {
        control.convergence.method = match word.get_ref().as_str() {
            "newton" => IterationMethod::Newton,
            "bfgs" => IterationMethod::bfgs(),
            other => {
                return Err(ctx.invalid(
                    Some(word.span()),
                    &key("iteration"),
                    format!("expected \"newton\" or \"bfgs\"; found \"{other}\""),
                ))
            }
        };
    }
    let c = &control;
    let tol = &c.convergence;
    if !(tol.residual_tolerance > 0.0
        && tol.residual_tolerance < 1.0
        && tol.energy_tolerance > 0.0
        && tol.energy_tolerance < 1.0
        && tol.max_iterations > 0)
    {
        return Err(ctx.invalid(
            None,
            &key("residual_tolerance"),
            "tolerances must lie in (0, 1) and max_iterations be >= 1",
        ));
    }
    let mut fixes = Vec::new();
    for (j, f) in s.fix.iter().enumerate() {
        let set = node_set(ctx, mesh, &f.node_set, &key(&format!("fix[{j}].node_set")))?;
        let mut comps = [f.components.is_none(); 3];
        for c in f.components.iter().flatten() {
            comps[component(ctx, c, &key(&format!("fix[{j}].components")))?] = true;
        }
        fixes.push((set, comps));
    }
    let mut displacements = Vec::new();
    for (j, d) in s.displace.iter().enumerate() {
        let set = node_set(
            ctx,
            mesh,
            &d.node_set,
            &key(&format!("displace[{j}].node_set")),
        )?;
        for (c, v) in [d.x, d.y, d.z].iter().enumerate() {
            if let Some(v) = v {
                displacements.push((set.clone(), c, v.0));
            }
        }
    }
    let mut forces = Vec::new();
    for (j, f) in s.force.iter().enumerate() {
        let set = node_set(
            ctx,
            mesh,
            &f.node_set,
            &key(&format!("force[{j}].node_set")),
        )?;
        for (c, v) in [f.x, f.y, f.z].iter().enumerate() {
            if let Some(v) = v {
                forces.push((set.clone(), c, v.0));
            }
        }
    }
    Ok(StepSpec {
        name: s.name.clone().unwrap_or_else(|| format!("step-{}", i + 1)),
        control,
        fixes,
        displacements,
        forces,
        tools: Vec::new(),
    })
}

fn resolve_output(
    ctx: &Ctx,
    o: &super::file::OutputSection,
    mesh: &Mesh,
) -> Result<OutputSpec, ScenarioError> {
    let mut curves = Vec::new();
    for (i, c) in o.curves.iter().enumerate() {
        let set = node_set(
            ctx,
            mesh,
            &c.node_set,
            &format!("output.curve[{i}].node_set"),
        )?;
        let component = component(ctx, &c.component, &format!("output.curve[{i}].component"))?;
        curves.push(CurveSpec {
            name: c.name.clone().unwrap_or_else(|| set.clone()),
            node_set: set,
            component,
            sign: if c.reverse_sign { -1.0 } else { 1.0 },
        });
    }
    let plot_format = match o
        .plot_format
        .as_ref()
        .map(|f| (f.get_ref().as_str(), f.span()))
    {
        None | Some(("png", _)) => PlotFormat::Png,
        Some(("svg", _)) => PlotFormat::Svg,
        Some((other, sp)) => {
            return Err(ctx.invalid(
                Some(sp),
                "output.plot_format",
                format!("expected \"png\" or \"svg\"; found \"{other}\""),
            ))
        }
    };
    Ok(OutputSpec {
        curves,
        vtk_every: o.vtk_every.unwrap_or(1),
        plot_format,
    })
}

fn select_node_set(ctx: &Ctx, s: &NodeSetSection, mesh: &mut Mesh) -> Result<(), ScenarioError> {
    let name = s.name.get_ref();
    if mesh.node_sets.contains_key(name) {
        return Err(ctx.invalid(
            Some(s.name.span()),
            "node_set.name",
            format!("a node set \"{name}\" already exists"),
        ));
    }
    let candidates: Vec<usize> = match &s.from {
        Some(from) => mesh.node_sets.get(from.get_ref()).cloned().ok_or_else(|| {
            ctx.invalid(
                Some(from.span()),
                "node_set.from",
                format!("no node set \"{}\" in the mesh", from.get_ref()),
            )
        })?,
        None => (0..mesh.num_nodes()).collect(),
    };
    let lo = [s.x_min, s.y_min, s.z_min].map(|b| b.map_or(f64::NEG_INFINITY, |l| l.0));
    let hi = [s.x_max, s.y_max, s.z_max].map(|b| b.map_or(f64::INFINITY, |l| l.0));
    let selected: Vec<usize> = candidates
        .into_iter()
        .filter(|&n| (0..3).all(|k| mesh.nodes[n][k] >= lo[k] && mesh.nodes[n][k] <= hi[k]))
        .collect();
    if selected.is_empty() {
        return Err(ctx.invalid(
            Some(s.name.span()),
            "node_set",
            format!("node set \"{name}\" selects no node: check its bounds"),
        ));
    }
    mesh.insert_node_set(name.clone(), selected);
    Ok(())
}
