//! `cellmech study`.

use std::process::ExitCode;
use std::sync::Mutex;

use anyhow::Context;
use cellmech::study::{self, builtin, CaseEvent, CaseRecord, StudyOptions};
use indicatif::{ProgressBar, ProgressStyle};

use crate::args::StudyArgs;

pub fn study(args: &StudyArgs) -> anyhow::Result<ExitCode> {
    if args.list {
        for b in builtin::BUILTIN {
            out!("{:<36} {}", b.name, b.summary);
        }
        return Ok(ExitCode::SUCCESS);
    }
    let name = args.study.as_deref().context("a study name or file")?;
    let (spec, text) = study::load(name)?;
    let quiet = args.report.quiet || args.report.json;
    let cases = spec.cases();
    if args.dry_run {
        study::run::check_cases(&spec, &cases)?;
        for c in &cases {
            let shard = args
                .shard
                .map(|(_, n)| format!(" (shard {})", study::run::shard_of(&c.name, n)))
                .unwrap_or_default();
            out!("{}{shard}", c.name);
            for (k, v) in &c.set {
                out!("    {k} = {v}");
            }
        }
        return Ok(ExitCode::SUCCESS);
    }
    let outcome = if args.collect {
        let from: Vec<&std::path::Path> = args.from.iter().map(|p| p.as_path()).collect();
        if from.is_empty() {
            study::collect(&spec, &args.out)?
        } else {
            study::merge_shards(&spec, &from, &args.out)?
        }
    } else {
        if !quiet {
            eprintln!(
                "cellmech {}: study \"{}\": {} cases{} into {}",
                env!("CARGO_PKG_VERSION"),
                spec.title,
                cases.len(),
                args.shard
                    .map(|(k, n)| format!(" (shard {k}/{n})"))
                    .unwrap_or_default(),
                args.out.display()
            );
        }
        let selected = cases
            .iter()
            .filter(|c| {
                args.shard
                    .is_none_or(|(k, n)| study::run::shard_of(&c.name, n) == k)
            })
            .count();
        let bar = (!quiet).then(|| {
            let bar = ProgressBar::new(selected as u64);
            bar.set_style(
                ProgressStyle::with_template(
                    "{prefix:>8} [{bar:30}] {pos}/{len} cases, ETA {eta} {msg}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            bar.set_prefix("study");
            bar
        });
        let failures = Mutex::new(Vec::<String>::new());
        let on_case = |record: &CaseRecord, event: CaseEvent| {
            if let Some(bar) = &bar {
                bar.inc(1);
                let what = match event {
                    CaseEvent::Skipped => "skipped (done)",
                    CaseEvent::Ran => record.status.as_str(),
                };
                bar.set_message(format!("{}: {what}", record.name));
            }
            if record.status != "completed" {
                if let Ok(mut f) = failures.lock() {
                    f.push(record.name.clone());
                }
            }
        };
        let options = StudyOptions {
            out: args.out.clone(),
            jobs: args.jobs.max(1),
            threads_per_case: 0,
            shard: args.shard,
        };
        let outcome = study::run_study(&spec, &text, &options, &on_case)?;
        if let Some(bar) = bar {
            bar.finish();
        }
        outcome
    };
    let failed = outcome.failed();
    if args.report.json {
        let json = serde_json::json!({
            "title": spec.title,
            "cases": outcome.cases.len(),
            "recorded": outcome.records.iter().flatten().count(),
            "ran": outcome.ran,
            "skipped": outcome.skipped,
            "failed": failed.iter().map(|r| serde_json::json!({"case": r.name, "error": r.error})).collect::<Vec<_>>(),
            "files": outcome.files,
        });
        out!("{json}");
    } else if !args.report.quiet {
        let rows = study::report::rows(&spec, &outcome.cases, &outcome.records);
        eprintln!(
            "{:<40} {:>10} {:>12} {:>14}",
            "case", "status", "force (nN)", "force/control"
        );
        for r in &rows {
            eprintln!(
                "{:<40} {:>10} {:>12} {:>14}",
                r.case,
                r.status,
                r.force_nn.map_or("-".into(), |f| format!("{f:.3}")),
                r.force_over_control
                    .map_or("-".into(), |f| format!("{f:.4}"))
            );
        }
        for r in &failed {
            eprintln!(
                "failed: {}: {}",
                r.name,
                r.error.as_deref().unwrap_or("no reason recorded")
            );
        }
        eprintln!("report in {}:", args.out.display());
        for f in &outcome.files {
            eprintln!("  {}", args.out.join(f).display());
        }
    }
    Ok(if failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
