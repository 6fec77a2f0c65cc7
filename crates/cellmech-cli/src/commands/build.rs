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
    let model = cellmech::model::build(&scenario.model)
        .with_context(|| format!("building the model of {}", scenario.origin))?;
    let cell_json = scenario
        .cell
        .as_ref()
        .map(|c| serde_json::to_value(c))
        .transpose()
        .context("describing the cell")?;
    let files = cellmech::output::model_view::write_model(
        &scenario.model,
        &model,
        &cellmech::output::model_view::ModelAbout {
            title: &scenario.title,
            origin: &scenario.origin,
            seed: scenario.cell.as_ref().map(|c| c.description.seed),
            cell: cell_json.as_ref(),
            plot_format: scenario.model.output.plot_format,
        },
        &args.out,
    )
    .map_err(anyhow::Error::msg)
    .with_context(|| format!("writing the model into {}", args.out.display()))?;
    let paths: Vec<String> = files
        .iter()
        .map(|f| args.out.join(f).display().to_string())
        .collect();
    if args.report.json {
        let value = serde_json::json!({
            "scenario": scenario.origin,
            "nodes": scenario.model.mesh.num_nodes(),
            "elements": scenario.model.mesh.num_elements(),
            "dofs": model.problem.dof_map().num_dofs(),
            "files": paths,
        });
        out!("{value}");
    } else if !args.report.quiet {
        out!(
            "{}: {} nodes, {} hex8, {} DOFs",
            scenario.origin,
            scenario.model.mesh.num_nodes(),
            scenario.model.mesh.num_elements(),
            model.problem.dof_map().num_dofs()
        );
        for p in paths {
            out!("  {p}");
        }
    }
    Ok(ExitCode::SUCCESS)
}
