//! `cellmech fit`.

use std::process::ExitCode;

use std::path::Path;

use anyhow::Context;
use cellmech::fit::synthetic::{write_synthetic, SyntheticSettings};
use cellmech::fit::{self, report::format_estimate, FitOptions, RunEvent};
use cellmech::units::parse_quantity;

use crate::args::FitArgs;

pub fn fit(args: &FitArgs) -> anyhow::Result<ExitCode> {
    if let Some(file) = &args.synthetic {
        return synthetic(args, file);
    }
    let spec = fit::load(&args.fit)?;
    let quiet = args.report.quiet || args.report.json;
    if args.dry_run {
        if !args.report.quiet {
            out!(
                "fit \"{}\": {} ({}) against {} points of {}",
                spec.title,
                spec.experiment.base_origin,
                spec.protocol,
                spec.fitted_points().len(),
                spec.data_path.display()
            );
            for p in &spec.parameters {
                out!(
                    "    {} start {} {u} in [{}, {}] {u} ({} scale)",
                    p.key,
                    p.start,
                    p.lower,
                    p.upper,
                    match p.scale {
                        fit::Scale::Log => "log",
                        fit::Scale::Linear => "linear",
                    },
                    u = p.unit()
                );
            }
        }
        return Ok(ExitCode::SUCCESS);
    }
    if !quiet {
        eprintln!(
            "cellmech {}: fit \"{}\": {} parameters, {} measured points, at most {} runs, into {}",
            env!("CARGO_PKG_VERSION"),
            spec.title,
            spec.parameters.len(),
            spec.fitted_points().len(),
            spec.optimizer.max_evaluations,
            args.out.display()
        );
    }
    let names: Vec<String> = spec
        .parameters
        .iter()
        .map(|p| {
            p.key
                .rsplit('.')
                .take(2)
                .collect::<Vec<_>>()
                .into_iter()
                .rev()
                .collect::<Vec<_>>()
                .join(".")
        })
        .collect();
    let units: Vec<&str> = spec.parameters.iter().map(|p| p.unit()).collect();
    let mut on_run = |e: &RunEvent| {
        if quiet {
            return;
        }
        let values: Vec<String> = e
            .values
            .iter()
            .zip(&names)
            .zip(&units)
            .map(|((v, n), u)| format!("{n} = {v:.6} {u}"))
            .collect();
        let what = match (&e.rejected, e.rms) {
            (Some(why), _) => format!("rejected: {why}"),
            (None, Some(rms)) => format!("rms {rms:.4e}"),
            (None, None) => String::new(),
        };
        eprintln!(
            "run {:>3} {} {:>6.1} s  {}  {}  [{}]",
            e.evaluation,
            if e.cached { "cached" } else { "solved" },
            e.wall_time_s,
            values.join(", "),
            what,
            e.hash
        );
    };
    let options = FitOptions {
        out: args.out.clone(),
        threads: args.threads,
    };
    let outcome = fit::run_fit(&spec, &options, &mut on_run)?;
    if args.report.json {
        out!(
            "{}",
            serde_json::to_string(&serde_json::json!({
                "title": outcome.title,
                "converged": outcome.converged,
                "stop": outcome.stop,
                "parameters": outcome.parameters,
                "correlation": outcome.correlation,
                "rms": outcome.rms,
                "r_squared": outcome.r_squared,
                "evaluations": outcome.evaluations,
                "fe_runs_solved": outcome.fe_runs_solved,
                "wall_time_s": outcome.wall_time_s,
                "files": outcome.files,
            }))?
        );
    } else if !args.report.quiet {
        for p in &outcome.parameters {
            eprintln!(
                "{:<40} {}{}",
                p.key,
                format_estimate(p.value, p.standard_error, &p.unit),
                if p.at_bound { " (at a bound)" } else { "" }
            );
        }
        if let Some(c) = &outcome.correlation {
            for row in c {
                let cells: Vec<String> = row.iter().map(|v| format!("{v:+.4}")).collect();
                eprintln!("  correlation  {}", cells.join("  "));
            }
        }
        eprintln!(
            "rms {:.4e}, R² {:.6}; {} evaluations ({} solved, {} from runs/), {} iterations, {}{}; {:.1} s",
            outcome.rms,
            outcome.r_squared,
            outcome.evaluations,
            outcome.fe_runs_solved,
            outcome.runs.len() - outcome.fe_runs_solved,
            outcome.iterations,
            outcome.stop,
            if outcome.converged { "" } else { " (not converged)" },
            outcome.wall_time_s
        );
        eprintln!("report in {}:", args.out.display());
        for f in &outcome.files {
            eprintln!("  {}", args.out.join(f).display());
        }
    }
    Ok(if outcome.converged {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// `--synthetic FILE`: a synthetic measured curve from the fit's experiment.
fn synthetic(args: &FitArgs, file: &Path) -> anyhow::Result<ExitCode> {
    let text = std::fs::read_to_string(&args.fit)
        .with_context(|| format!("cannot read {}", args.fit.display()))?;
    let dir = args.fit.parent().unwrap_or(Path::new("."));
    let spec = fit::spec::parse_with(&text, &args.fit.display().to_string(), dir, false)?;
    anyhow::ensure!(
        args.at.len() == spec.parameters.len(),
        "--at: expected {} values (one per [[parameter]]: {}); found {}",
        spec.parameters.len(),
        spec.parameters
            .iter()
            .map(|p| p.key.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        args.at.len()
    );
    let values = spec
        .parameters
        .iter()
        .zip(&args.at)
        .map(|(p, v)| {
            parse_quantity(v, p.dimension).map_err(|e| anyhow::anyhow!("--at `{}`: {e}", p.key))
        })
        .collect::<anyhow::Result<Vec<f64>>>()?;
    let noise = parse_quantity(&args.noise, spec.data.y_dim)
        .map_err(|e| anyhow::anyhow!("--noise: {e}"))?;
    let settings = SyntheticSettings {
        values,
        points: args.points,
        noise,
        seed: args.seed,
        threads: args.threads,
    };
    let quiet = args.report.quiet || args.report.json;
    let mut on_run = |e: &RunEvent| {
        if !quiet {
            eprintln!(
                "run {} {:.1} s [{}] {}",
                if e.cached { "cached" } else { "solved" },
                e.wall_time_s,
                e.hash,
                e.status
            );
        }
    };
    let (x, _) = write_synthetic(&spec, &settings, &args.out, file, &mut on_run)?;
    if args.report.json {
        out!(
            "{}",
            serde_json::json!({"file": file.display().to_string(), "points": x.len()})
        );
    } else if !args.report.quiet {
        eprintln!("wrote {} ({} points)", file.display(), x.len());
    }
    Ok(ExitCode::SUCCESS)
}
