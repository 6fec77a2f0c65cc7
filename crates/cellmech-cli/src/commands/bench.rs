//! `cellmech bench`.

use std::process::ExitCode;

use anyhow::Context;

use crate::args::BenchArgs;

pub fn bench(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    if let Some(dir) = &args.export_matrices {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut cases = Vec::new();
    if !args.json {
        println!(
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
            println!(
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
        println!("{}", serde_json::to_string(&cases)?);
    }
    Ok(ExitCode::SUCCESS)
}
