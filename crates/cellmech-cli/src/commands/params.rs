//! `cellmech params`: the declared parameters of the cell models and protocols.

use std::process::ExitCode;

use crate::args::ParamsArgs;

pub fn params(args: &ParamsArgs) -> anyhow::Result<ExitCode> {
    let tables = cellmech::experiment::parameter_tables();
    let Some(name) = &args.name else {
        for t in &tables {
            out!(
                "{:<26} [{}] {} parameters",
                t.name,
                t.section,
                t.params.len()
            );
        }
        return Ok(ExitCode::SUCCESS);
    };
    let table = tables.iter().find(|t| t.name == name).ok_or_else(|| {
        let names: Vec<&str> = tables.iter().map(|t| t.name).collect();
        let hint = cellmech::param::suggestion(names.iter().copied(), name)
            .map(|s| format!(" (did you mean \"{s}\"?)"))
            .unwrap_or_default();
        anyhow::anyhow!(
            "no parameter table named \"{name}\"{hint}; available: {}",
            names.join(", ")
        )
    })?;
    if args.json {
        let rows: Vec<_> = table
            .params
            .iter()
            .map(|p| {
                serde_json::json!({
                    "key": p.key,
                    "kind": format!("{:?}", p.kind),
                    "default": format!("{:?}", p.default),
                    "min": p.bounds.min, "min_inclusive": p.bounds.min_inclusive,
                    "max": p.bounds.max, "max_inclusive": p.bounds.max_inclusive,
                    "doc": p.doc, "source": p.source,
                })
            })
            .collect();
        out!("{}", serde_json::to_string_pretty(&rows)?);
    } else if args.toml {
        out_text!("{}", table.toml_template());
    } else {
        out_text!("{}", table.markdown());
    }
    Ok(ExitCode::SUCCESS)
}
