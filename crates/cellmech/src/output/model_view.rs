//! Looking at a model before solving it (`cellmech build`): the model in its reference
//! state as a ParaView file (`model.pvd` + `model_0000.vtu`: continuum, membrane and line
//! cells with their fields, node sets as 0/1 point fields `set_<name>`), a picture made by the program (`model.png`: the surface mesh
//! in grey and each filament family in its colour, in an oblique and a front view), and
//! `model.json` (sizes, node and element sets, the cell model's parameters and geometry
//! quality).

use std::path::Path;

use cellmech_fem::mesh::surface::boundary_quads;
use cellmech_io::{plot_model_picture, Field, LineGroup, ModelPicture, PvdSeries, View3d};
use serde::Serialize;

use crate::model::structures::FilamentElement;
use crate::model::BuiltModel;
use crate::model::ModelSpec;

/// Colours of well-known families (others cycle through a palette).
fn family_color(family: &str, k: usize) -> (u8, u8, u8) {
    match family {
        "actin" => (214, 39, 40),
        "microtubule" => (44, 160, 44),
        "intermediate" => (148, 103, 189),
        _ => [
            (31, 119, 180),
            (255, 127, 14),
            (140, 86, 75),
            (227, 119, 194),
        ][k % 4],
    }
}

/// The picture of a scenario's model in its reference configuration: the outer surface
/// mesh, the nucleus surface and every enabled filament group, coloured by family.
pub fn model_picture(model: &ModelSpec, title: &str) -> ModelPicture {
    model_picture_at(model, &model.mesh.nodes, title.to_string())
}

/// The same picture with the nodes at `positions` (e.g. the deformed configuration).
pub fn model_picture_at(model: &ModelSpec, positions: &[[f64; 3]], title: String) -> ModelPicture {
    let mesh = &model.mesh;
    let x = |n: usize| positions[n];
    let mut groups = Vec::new();
    let outlines: [(Option<&[&str]>, &str, (u8, u8, u8)); 2] = [
        (None, "surface mesh", (170, 170, 170)),
        (Some(&["nucleus"]), "nucleus surface", (120, 170, 220)),
    ];
    for (filter, label, color) in outlines {
        if filter.is_some() && mesh.block("nucleus").is_none() {
            continue;
        }
        let Ok(faces) = boundary_quads(mesh, filter) else {
            continue;
        };
        // Each surface edge is shared by two faces: draw it once.
        let edges: std::collections::BTreeSet<(usize, usize)> = faces
            .iter()
            .flat_map(|f| (0..4).map(move |k| (f[k].min(f[(k + 1) % 4]), f[k].max(f[(k + 1) % 4]))))
            .collect();
        groups.push(LineGroup {
            label: format!("{label} ({} faces)", faces.len()),
            color,
            width: 1,
            segments: edges.into_iter().map(|(a, b)| [x(a), x(b)]).collect(),
        });
    }
    let mut families: Vec<(&str, Vec<[[f64; 3]; 2]>, &str)> = Vec::new();
    for f in model.structures.filaments.iter().filter(|f| f.enabled) {
        let kind = match f.element {
            FilamentElement::Truss(_) => "trusses",
            FilamentElement::Beam(_) => "beams",
        };
        let segments = f.pairs.iter().map(|&[a, b]| [x(a), x(b)]);
        match families.iter_mut().find(|(name, _, _)| *name == f.family) {
            Some(entry) => entry.1.extend(segments),
            None => families.push((&f.family, segments.collect(), kind)),
        }
    }
    for (k, (family, segments, kind)) in families.into_iter().enumerate() {
        groups.push(LineGroup {
            label: format!("{family} ({} {kind})", segments.len()),
            color: family_color(family, k),
            width: 2,
            segments,
        });
    }
    // Ties whose tied node is no element's corner (an FA plaque's reference node, not a
    // hanging node): a spoke from it to each of its masters shows the plaque.
    let corners: std::collections::HashSet<usize> = mesh
        .blocks
        .iter()
        .flat_map(|b| b.connectivity.iter().copied())
        .collect();
    let plaques: Vec<_> = model
        .hanging
        .iter()
        .filter(|t| !corners.contains(&t.node))
        .collect();
    if !plaques.is_empty() {
        groups.push(LineGroup {
            label: format!("FA plaque ties ({})", plaques.len()),
            color: (255, 127, 14),
            width: 1,
            segments: plaques
                .iter()
                .flat_map(|t| t.masters.iter().map(|&(m, _)| [x(t.node), x(m)]))
                .collect(),
        });
    }
    ModelPicture {
        title,
        views: vec![
            ("oblique".into(), View3d::new(-60.0, 25.0)),
            ("front (x right, z up)".into(), View3d::new(-90.0, 0.0)),
        ],
        groups,
    }
}

/// Sizes and sets of a built model, for `model.json`.
#[derive(Debug, Serialize)]
struct ModelDescription<'a> {
    title: &'a str,
    scenario: &'a str,
    nodes: usize,
    hex8_elements: usize,
    dofs: usize,
    element_sets: Vec<(String, usize)>,
    node_sets: Vec<(String, usize)>,
    terms: Vec<(String, usize)>,
    steps: Vec<&'a str>,
    seed: Option<u64>,
    cell: Option<&'a serde_json::Value>,
}

/// What a model is, for `model.json` and the picture's title.
pub struct ModelAbout<'a> {
    /// Title.
    pub title: &'a str,
    /// Where the model came from (a scenario path or `<built-in: name>`).
    pub origin: &'a str,
    /// Seed of its random choices.
    pub seed: Option<u64>,
    /// The cell model's description, when it is one.
    pub cell: Option<&'a serde_json::Value>,
    /// Plot format.
    pub plot_format: crate::model::PlotFormat,
}

/// Writes `model.pvd`/`model_0000.vtu`, `model.<png|svg>` and `model.json` into `dir`
/// (created if needed) and returns the file names.
pub fn write_model(
    spec: &ModelSpec,
    model: &BuiltModel,
    about: &ModelAbout<'_>,
    dir: &Path,
) -> Result<Vec<String>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let mut pvd = PvdSeries::new(dir, "model").map_err(|e| e.to_string())?;
    // Node sets as 0/1 point fields `set_<name>` (the 30 one-node `fa_<k>` sets are covered
    // by `set_focal_adhesions`).
    let sets = spec
        .mesh
        .node_sets
        .iter()
        .filter(|(name, _)| !(name.starts_with("fa_") && name[3..].parse::<usize>().is_ok()))
        .map(|(name, nodes)| {
            let mut flag = vec![0.0; spec.mesh.num_nodes()];
            for &n in nodes {
                flag[n] = 1.0;
            }
            Field::new(format!("set_{name}"), 1, flag)
        })
        .collect();
    crate::output::write_frame(
        &mut pvd,
        0.0,
        &model.problem,
        &spec.mesh.nodes,
        sets,
        &model.filaments,
    )?;
    let picture = format!("model.{}", about.plot_format.extension());
    plot_model_picture(&dir.join(&picture), &model_picture(spec, about.title))
        .map_err(|e| e.to_string())?;
    let p = &model.problem;
    let description = ModelDescription {
        title: about.title,
        scenario: about.origin,
        nodes: spec.mesh.num_nodes(),
        hex8_elements: spec.mesh.num_elements(),
        dofs: p.dof_map().num_dofs(),
        element_sets: spec
            .mesh
            .blocks
            .iter()
            .map(|b| (b.name.clone(), b.len()))
            .collect(),
        node_sets: spec
            .mesh
            .node_sets
            .iter()
            .map(|(k, v)| (k.clone(), v.len()))
            .collect(),
        terms: p
            .terms()
            .iter()
            .map(|t| (t.name().to_string(), t.num_elements()))
            .collect(),
        steps: spec.steps.iter().map(|s| s.name.as_str()).collect(),
        seed: about.seed,
        cell: about.cell,
    };
    cellmech_io::write_json_atomic(&dir.join("model.json"), &description)
        .map_err(|e| e.to_string())?;
    Ok(vec![
        "model.pvd".into(),
        "model_0000.vtu".into(),
        picture,
        "model.json".into(),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn picture(cell: &str) -> ModelPicture {
        let text = format!(
            "title = \"t\"\n[cell]\nmodel = \"suspended\"\nresolution = \"fast\"\n{cell}\n\
             [protocol]\nkind = \"micropipette-tension\"\n"
        );
        let s = crate::scenario::parse(&text, "t.toml", Path::new(".")).unwrap();
        model_picture(&s.model, "t")
    }

    /// The default FA plaques are drawn as spokes from each reference node to its plaque
    /// nodes; single-node FAs have none.
    #[test]
    fn the_picture_draws_each_fa_plaque_as_spokes_to_its_nodes() {
        let with = picture("");
        let spokes = with
            .groups
            .iter()
            .find(|g| g.label == "FA plaque ties (30)")
            .expect("a group of 30 plaques");
        // Every FA node and at least one plaque node per FA.
        assert!(spokes.segments.len() >= 60, "{}", spokes.segments.len());
        let without = picture("fa_radius = \"0 um\"");
        assert!(without
            .groups
            .iter()
            .all(|g| !g.label.starts_with("FA plaque")));
    }
}
