//! `cellmech build`: build a scenario's model and write it for viewing, without solving.

use std::process::ExitCode;

use anyhow::Context;

use crate::args::BuildArgs;

pub fn build(args: &BuildArgs) -> anyhow::Result<ExitCode> {
    let scenario = match &args.scenario {
        Some(path) => cellmech::scenario::load(path)
            .with_context(|| format!("reading scenario {}", path.display()))?,
        None => cellmech::examples::default_scenario().context("the built-in default scenario")?,
    };
    let model = cellmech::model::build(&scenario)
        .with_context(|| format!("building the model of {}", scenario.origin))?;
    let files = cellmech::model_view::write_model(&scenario, &model, &args.out)
        .map_err(anyhow::Error::msg)
        .with_context(|| format!("writing the model into {}", args.out.display()))?;
    let paths: Vec<String> = files
        .iter()
        .map(|f| args.out.join(f).display().to_string())
        .collect();
    if args.report.json {
        let value = serde_json::json!({
            "scenario": scenario.origin,
            "nodes": scenario.mesh.num_nodes(),
            "elements": scenario.mesh.num_elements(),
            "dofs": model.problem.dof_map().num_dofs(),
            "files": paths,
        });
        println!("{value}");
    } else if !args.report.quiet {
        println!(
            "{}: {} nodes, {} hex8, {} DOFs",
            scenario.origin,
            scenario.mesh.num_nodes(),
            scenario.mesh.num_elements(),
            model.problem.dof_map().num_dofs()
        );
        for p in paths {
            println!("  {p}");
        }
    }
    Ok(ExitCode::SUCCESS)
}
