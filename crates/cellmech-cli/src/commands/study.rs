//! `cellmech study`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use cellmech::study::{
    self, builtin, CaseEvent, CaseRecord, PoolOptions, StudyOutcome, StudyRun, StudySpec,
};
use indicatif::{ProgressBar, ProgressStyle};

use crate::args::StudyArgs;

/// A study named on the command line.
struct Named {
    /// The built-in name or the file's stem: its folder under --out when several run.
    label: String,
    spec: StudySpec,
    text: String,
    out: PathBuf,
}

/// The folder name of a study argument: a built-in study's name or a file's stem.
fn label_of(arg: &str) -> String {
    if builtin::find(arg).is_some() {
        return arg.to_string();
    }
    Path::new(arg)
        .file_stem()
        .map_or_else(|| arg.to_string(), |s| s.to_string_lossy().into_owned())
}

fn load_all(args: &StudyArgs) -> anyhow::Result<Vec<Named>> {
    let several = args.study.len() > 1;
    let mut named: Vec<Named> = Vec::with_capacity(args.study.len());
    for arg in &args.study {
        let (spec, text) = study::load(arg)?;
        let label = label_of(arg);
        if let Some(other) = named.iter().find(|n| n.label == label) {
            anyhow::bail!(
                "study `{arg}`: expected studies with distinct names (each writes {}/NAME/); \
                 found `{}` twice",
                args.out.display(),
                other.label
            );
        }
        let out = if several {
            args.out.join(&label)
        } else {
            args.out.clone()
        };
        named.push(Named {
            label,
            spec,
            text,
            out,
        });
    }
    Ok(named)
}

pub fn study(args: &StudyArgs) -> anyhow::Result<ExitCode> {
    if args.list {
        for b in builtin::BUILTIN {
            out!("{:<36} {}", b.name, b.summary);
        }
        return Ok(ExitCode::SUCCESS);
    }
    anyhow::ensure!(!args.study.is_empty(), "a study name or file");
    let studies = load_all(args)?;
    let several = studies.len() > 1;
    let quiet = args.report.quiet || args.report.json;
    let selected = |spec: &StudySpec| -> Vec<study::Case> {
        spec.cases()
            .into_iter()
            .filter(|c| {
                args.shard
                    .is_none_or(|(k, n)| study::run::shard_of(&c.name, n) == k)
            })
            .collect()
    };
    if args.dry_run {
        for s in &studies {
            if several {
                out!("# {} -> {}", s.label, s.out.display());
            }
            let cases = s.spec.cases();
            study::run::check_cases(&s.spec, &cases).context(format!("study `{}`", s.label))?;
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
        }
        return Ok(ExitCode::SUCCESS);
    }
    let outcomes: Vec<StudyOutcome> = if args.collect {
        let mut outcomes = Vec::with_capacity(studies.len());
        for s in &studies {
            let from: Vec<PathBuf> = args
                .from
                .iter()
                .map(|p| if several { p.join(&s.label) } else { p.clone() })
                .collect();
            let from: Vec<&Path> = from.iter().map(|p| p.as_path()).collect();
            outcomes.push(if from.is_empty() {
                study::collect(&s.spec, &s.out)?
            } else {
                study::merge_shards(&s.spec, &from, &s.out)?
            });
        }
        outcomes
    } else {
        let total: usize = studies.iter().map(|s| selected(&s.spec).len()).sum();
        if !quiet {
            for s in &studies {
                eprintln!(
                    "cellmech {}: study \"{}\": {} cases{} into {}",
                    env!("CARGO_PKG_VERSION"),
                    s.spec.title,
                    s.spec.cases().len(),
                    args.shard
                        .map(|(k, n)| format!(" (shard {k}/{n})"))
                        .unwrap_or_default(),
                    s.out.display()
                );
            }
        }
        let bar = (!quiet).then(|| {
            let bar = ProgressBar::new(total as u64);
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
        let on_case = |record: &CaseRecord, event: CaseEvent| {
            if let Some(bar) = &bar {
                bar.inc(1);
                let what = match event {
                    CaseEvent::Skipped => "skipped (done)",
                    CaseEvent::Shared => "shared (identical case)",
                    CaseEvent::Ran => record.status.as_str(),
                };
                bar.set_message(format!("{}: {what}", record.name));
            }
        };
        let options = PoolOptions {
            jobs: args.jobs.max(1),
            threads_per_case: 0,
            shard: args.shard,
        };
        let runs: Vec<StudyRun> = studies
            .iter()
            .map(|s| StudyRun {
                spec: &s.spec,
                text: &s.text,
                out: s.out.clone(),
            })
            .collect();
        let outcomes = study::run_studies(&runs, &options, &on_case)?;
        if let Some(bar) = bar {
            bar.finish();
        }
        outcomes
    };
    let mut failures = 0;
    let mut json = Vec::with_capacity(studies.len());
    for (s, outcome) in studies.iter().zip(&outcomes) {
        let failed = outcome.failed();
        failures += failed.len();
        if args.report.json {
            json.push(serde_json::json!({
                "title": s.spec.title,
                "out": s.out,
                "cases": outcome.cases.len(),
                "recorded": outcome.records.iter().flatten().count(),
                "ran": outcome.ran,
                "skipped": outcome.skipped,
                "shared": outcome.records.iter().flatten().filter(|r| r.shared_from.is_some()).count(),
                "failed": failed.iter().map(|r| serde_json::json!({"case": r.name, "error": r.error})).collect::<Vec<_>>(),
                "files": outcome.files,
            }));
        } else if !args.report.quiet {
            print_table(&s.spec, outcome, &failed, &s.out, several);
        }
    }
    if args.report.json {
        if several {
            out!("{}", serde_json::json!({ "studies": json }));
        } else if let Some(one) = json.pop() {
            out!("{one}");
        }
    }
    Ok(if failures == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// The human-readable result of one study on stderr.
fn print_table(
    spec: &StudySpec,
    outcome: &StudyOutcome,
    failed: &[&CaseRecord],
    out: &Path,
    several: bool,
) {
    if several {
        eprintln!("\n{}", spec.title);
    }
    let rows = study::report::rows(spec, &outcome.cases, &outcome.records);
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
    for r in failed {
        eprintln!(
            "failed: {}: {}",
            r.name,
            r.error.as_deref().unwrap_or("no reason recorded")
        );
    }
    eprintln!("report in {}:", out.display());
    for f in &outcome.files {
        eprintln!("  {}", out.join(f).display());
    }
}
