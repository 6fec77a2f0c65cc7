//! `cellmech bench`.

use std::process::ExitCode;

use anyhow::Context;

use crate::args::BenchArgs;

pub fn bench(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    if let Some(names) = &args.analyses {
        return analyses(args, names);
    }
    if let Some(dir) = &args.export_matrices {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut cases = Vec::new();
    if !args.json {
        out!(
            "{:>8} {:>8} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>8}",
            "elements",
            "dofs",
            "nnz(L)",
            "analyse s",
            "assemble s",
            "factor s",
            "solve s",
            "Newton s",
            "(a+s)/f"
        );
    }
    for &target in &args.sizes {
        let matrix = args
            .export_matrices
            .as_ref()
            .map(|d| d.join(format!("sphere_{target}.mtx")));
        let case = cellmech::bench::bench_case(target, matrix.as_deref())
            .map_err(|e| anyhow::anyhow!("benchmark at {target} elements: {e}"))?;
        if !args.json {
            out!(
                "{:>8} {:>8} {:>10} {:>10.3} {:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>8.3}",
                case.elements,
                case.dofs,
                case.factor_nonzeros.unwrap_or(0),
                case.analysis_s,
                case.assembly_s,
                case.factorization_s,
                case.solve_s,
                case.newton_iteration_s,
                case.assembly_and_solve_over_factorization
            );
        }
        cases.push(case);
    }
    if args.json {
        out!("{}", serde_json::to_string(&cases)?);
    }
    Ok(ExitCode::SUCCESS)
}

fn analyses(args: &BenchArgs, names: &[String]) -> anyhow::Result<ExitCode> {
    use cellmech::bench::{bench_analysis, AnalysisBench, ANALYSES};
    let names: Vec<String> = if names.is_empty() {
        ANALYSES.iter().map(|(n, _, _)| n.to_string()).collect()
    } else {
        names.to_vec()
    };
    let baseline: Vec<AnalysisBench> = match &args.baseline {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading the baseline {}", path.display()))?;
            serde_json::from_str(&text).with_context(|| {
                format!(
                    "{}: expected a JSON list of analysis figures",
                    path.display()
                )
            })?
        }
        None => Vec::new(),
    };
    let scratch = std::env::temp_dir().join(format!("cellmech-bench-{}", std::process::id()));
    let mut results = Vec::new();
    for name in &names {
        let r = bench_analysis(name, args.coarse, &scratch)
            .map_err(|e| anyhow::anyhow!("benchmark {name}: {e}"))?;
        if !args.json {
            out!(
                "{} ({} hex8, {} dofs{}): wall {:.2} s, {} iterations, {} factorisations; assembly {:.2} s ({}) + residual-only {:.2} s ({}), factorisation {:.2} s, solve {:.2} s, relaxation {:.2} s, other {:.2} s; result {:.6} nN",
                r.name, r.elements, r.dofs, if r.coarse { ", coarse" } else { "" }, r.wall_s, r.iterations,
                r.factorizations, r.assembly_s, r.assemblies, r.residual_only_s, r.residual_evaluations, r.factorization_s, r.solve_s, r.relaxation_s, r.other_s, r.result
            );
            for (i, (step, increments, iterations, cutbacks, wall)) in r.steps.iter().enumerate() {
                out!("    {step:<14} {increments:>4} increments {iterations:>5} iterations {cutbacks:>3} cutbacks {wall:>8.2} s");
                if let Some(s) = r.step_splits.get(i) {
                    out!(
                        "    {:<14} assembly {:.2} s ({}), residual-only {:.2} s ({}), factorisation {:.2} s ({}), solve {:.2} s, relaxation {:.2} s, contact/augmentation rounds {}, output {:.2} s",
                        "", s.assembly_s, s.assemblies, s.residual_only_s, s.residual_evaluations,
                        s.factorization_s, s.factorizations, s.solve_s, s.relaxation_s,
                        s.augmentations, s.output_s
                    );
                }
            }
            if let Some(b) = baseline
                .iter()
                .find(|b| b.name == r.name && b.coarse == r.coarse)
            {
                out!(
                    "    vs baseline: wall x{:.3}, iterations x{:.3}, factorisations x{:.3}, factorisation time x{:.3}, result {:+.2e} relative",
                    r.wall_s / b.wall_s,
                    r.iterations as f64 / b.iterations as f64,
                    r.factorizations as f64 / b.factorizations as f64,
                    r.factorization_s / b.factorization_s,
                    (r.result - b.result) / b.result.abs().max(f64::MIN_POSITIVE)
                );
            }
        }
        results.push(r);
    }
    let _ = std::fs::remove_dir_all(&scratch);
    if let Some(path) = &args.save {
        cellmech_io::write_json_atomic(path, &results)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if args.json {
        out!("{}", serde_json::to_string(&results)?);
    }
    Ok(ExitCode::SUCCESS)
}
