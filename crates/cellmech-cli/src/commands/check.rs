//! `cellmech check`.

use std::process::ExitCode;

use anyhow::Context;

use crate::args::CheckArgs;

pub fn check(args: &CheckArgs) -> anyhow::Result<ExitCode> {
    let scenario = cellmech::scenario::load(&args.scenario)
        .with_context(|| format!("checking scenario {}", args.scenario.display()))?;
    cellmech::model::build(&scenario.model)
        .with_context(|| format!("building the model of {}", scenario.origin))?;
    let blocks: Vec<_> = scenario
        .model
        .mesh
        .blocks
        .iter()
        .map(|b| (b.name.clone(), b.len()))
        .collect();
    if args.report.json {
        let value = serde_json::json!({
            "scenario": scenario.origin,
            "valid": true,
            "nodes": scenario.model.mesh.num_nodes(),
            "element_sets": blocks,
            "node_sets": scenario.model.mesh.node_sets.keys().collect::<Vec<_>>(),
            "steps": scenario.model.steps.iter().map(|s| &s.name).collect::<Vec<_>>(),
        });
        out!("{value}");
    } else if !args.report.quiet {
        out!("{}: valid", scenario.origin);
        out!(
            "  mesh: {} nodes, {} elements",
            scenario.model.mesh.num_nodes(),
            scenario.model.mesh.num_elements()
        );
        for (name, n) in &blocks {
            out!("  element set {name}: {n} elements");
        }
        let steps: Vec<&str> = scenario
            .model
            .steps
            .iter()
            .map(|s| s.name.as_str())
            .collect();
        out!("  steps: {}", steps.join(", "));
    }
    Ok(ExitCode::SUCCESS)
}
