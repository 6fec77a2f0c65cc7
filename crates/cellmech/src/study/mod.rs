//! Parameter studies in one command: a base experiment and axes of variants (disruption,
//! moduli, layer thickness, compressibility, parameter grids, named cases), every case a
//! complete scenario run in its own folder, resumable, parallel and shardable; the results
//! as `study.csv`, figures and a self-contained report. See `docs/studies.md`.
//!
//! Layout of a study's output directory:
//!
//! ```text
//! OUT/study.toml            the study as given (built-in studies are written out)
//! OUT/cases/NAME/case.toml  the case's complete scenario (re-run it alone with `cellmech run`)
//! OUT/cases/NAME/...        the case's usual outputs (curve.csv, summary.json, fields.pvd, …)
//! OUT/cases/NAME/record.json  written last, atomically: the case is done
//! OUT/study.csv, study.json, force-over-control.svg, curves.svg, report.md, report.html
//! ```

pub mod builtin;
pub mod report;
pub mod run;
pub mod spec;

use std::path::{Path, PathBuf};

pub use run::{CaseEvent, CaseRecord, PoolOptions};
pub use spec::{Case, StudyError, StudySpec};

/// A study's outcome in this invocation.
#[derive(Debug, Clone)]
pub struct StudyOutcome {
    /// Every case of the study, in order.
    pub cases: Vec<Case>,
    /// The record of each case, when it has one (run now, earlier, or by another shard).
    pub records: Vec<Option<CaseRecord>>,
    /// Cases run in this invocation.
    pub ran: usize,
    /// Cases skipped because they were already recorded.
    pub skipped: usize,
    /// Report files written (relative to the output directory).
    pub files: Vec<String>,
}

impl StudyOutcome {
    /// Cases that failed.
    pub fn failed(&self) -> Vec<&CaseRecord> {
        self.records
            .iter()
            .flatten()
            .filter(|r| r.status != "completed")
            .collect()
    }
}

/// Reads a study: a built-in name (`cellmech study --list`) or a study file.
pub fn load(name_or_path: &str) -> Result<(StudySpec, String), StudyError> {
    if let Some(b) = builtin::find(name_or_path) {
        let spec = spec::parse(b.text, &format!("<built-in: {}>", b.name), Path::new("."))?;
        return Ok((spec, b.text.to_string()));
    }
    let path = Path::new(name_or_path);
    if !path.exists() {
        return Err(StudyError::Invalid {
            path: name_or_path.into(),
            message: format!(
                "expected a study file or a built-in study ({}); found neither",
                builtin::BUILTIN
                    .iter()
                    .map(|b| b.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        });
    }
    let text = std::fs::read_to_string(path).map_err(|error| StudyError::Read {
        path: path.display().to_string(),
        error,
    })?;
    Ok((spec::load(path)?, text))
}

/// Runs a study into `out` (cases go to `OUT/cases/NAME`; its shard when `options.shard`
/// is set), then writes the report over every case recorded in `out` so far.
pub fn run_study(
    spec: &StudySpec,
    study_text: &str,
    out: &Path,
    options: &PoolOptions,
    on_case: &(dyn Fn(&CaseRecord, CaseEvent) + Sync),
) -> Result<StudyOutcome, StudyError> {
    let run = StudyRun {
        spec,
        text: study_text,
        out: out.to_path_buf(),
    };
    let mut outcomes = run_studies(&[run], options, on_case)?;
    Ok(outcomes.remove(0))
}

/// One study of a [`run_studies`] call, with its own output directory.
#[derive(Debug, Clone)]
pub struct StudyRun<'a> {
    /// The study.
    pub spec: &'a StudySpec,
    /// Its text as given (written to `OUT/study.toml`).
    pub text: &'a str,
    /// Its output directory.
    pub out: PathBuf,
}

/// Runs several studies in one pool of `options.jobs` workers (their shard when
/// `options.shard` is set), each into its own output directory, then writes
/// each study's report. One pool keeps every worker busy until the last case of all the
/// studies, where studies run one after another each leave cores idle at their end; and a
/// case that two studies share (their controls) is computed once
/// ([`run::run_jobs`]). Cases are taken in the order of the studies and of their cases.
pub fn run_studies(
    runs: &[StudyRun<'_>],
    options: &PoolOptions,
    on_case: &(dyn Fn(&CaseRecord, CaseEvent) + Sync),
) -> Result<Vec<StudyOutcome>, StudyError> {
    let mut cases = Vec::with_capacity(runs.len());
    for (i, run) in runs.iter().enumerate() {
        if runs[..i].iter().any(|r| r.out == run.out) {
            return Err(StudyError::Invalid {
                path: run.out.display().to_string(),
                message: "expected a separate output directory for each study; found two studies writing here".into(),
            });
        }
        prepare_output(run)?;
        let study_cases = run.spec.cases();
        run::check_cases(run.spec, &study_cases)?;
        cases.push(study_cases);
    }
    let mut before = Vec::with_capacity(runs.len());
    let mut jobs = Vec::new();
    for (run, study_cases) in runs.iter().zip(&cases) {
        before.push(
            study_cases
                .iter()
                .filter(|c| run::read_record(&run::case_dir(&run.out, &c.name)).is_some())
                .count(),
        );
        jobs.extend(
            study_cases
                .iter()
                .filter(|c| {
                    options
                        .shard
                        .is_none_or(|(k, n)| run::shard_of(&c.name, n) == k)
                })
                .map(|case| run::CaseJob {
                    spec: run.spec,
                    case,
                    dir: run::case_dir(&run.out, &case.name),
                }),
        );
    }
    for result in run::run_jobs(&jobs, options.jobs, options.threads_per_case, on_case) {
        result?;
    }
    runs.iter()
        .zip(before)
        .map(|(run, before)| {
            let mut outcome = collect(run.spec, &run.out)?;
            let recorded = outcome.records.iter().flatten().count();
            outcome.ran = recorded.saturating_sub(before);
            outcome.skipped = before;
            Ok(outcome)
        })
        .collect()
}

/// Creates a study's output directory and writes the study as run next to its results
/// (the first writer wins: a shard does not overwrite another's copy with a different
/// study silently).
fn prepare_output(run: &StudyRun<'_>) -> Result<(), StudyError> {
    let io = |e: std::io::Error| StudyError::Output(format!("{}: {e}", run.out.display()));
    std::fs::create_dir_all(run.out.join("cases")).map_err(io)?;
    let copy = run.out.join("study.toml");
    match std::fs::read_to_string(&copy) {
        Ok(existing) if existing != run.text => Err(StudyError::Invalid {
            path: copy.display().to_string(),
            message: "expected the same study as the one already in this output directory; found a different one (use another --out)".into(),
        }),
        Ok(_) => Ok(()),
        Err(_) => cellmech_io::write_atomic(&copy, run.text.as_bytes())
            .map_err(|e| StudyError::Output(e.to_string())),
    }
}

/// Gathers every case recorded in `out` (from any shard) and writes the study's report.
pub fn collect(spec: &StudySpec, out: &Path) -> Result<StudyOutcome, StudyError> {
    let cases = spec.cases();
    let records: Vec<Option<CaseRecord>> = cases
        .iter()
        .map(|c| run::read_record(&run::case_dir(out, &c.name)))
        .collect();
    let files = report::write_report(spec, &cases, &records, out)?;
    Ok(StudyOutcome {
        cases,
        records,
        ran: 0,
        skipped: 0,
        files,
    })
}

/// Merges the case folders of several output directories (the shards of one study run on
/// different machines) into `out`, then collects. A case recorded in more than one shard
/// keeps the first copy.
pub fn merge_shards(
    spec: &StudySpec,
    shards: &[&Path],
    out: &Path,
) -> Result<StudyOutcome, StudyError> {
    let io = |e: std::io::Error| StudyError::Output(e.to_string());
    std::fs::create_dir_all(out.join("cases")).map_err(io)?;
    for case in spec.cases() {
        let target = run::case_dir(out, &case.name);
        if run::read_record(&target).is_some() {
            continue;
        }
        if let Some(source) = shards
            .iter()
            .map(|s| run::case_dir(s, &case.name))
            .find(|d| run::read_record(d).is_some())
        {
            if target.exists() {
                std::fs::remove_dir_all(&target).map_err(io)?;
            }
            copy_dir(&source, &target).map_err(io)?;
        }
    }
    collect(spec, out)
}

pub(crate) fn copy_dir(from: &Path, to: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(to)?;
    let mut record = None;
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        let path = entry.path();
        let target = to.join(entry.file_name());
        if entry.file_type()?.is_dir() {
            copy_dir(&path, &target)?;
        } else if entry.file_name() == run::RECORD {
            record = Some((path, target));
        } else {
            std::fs::copy(&path, &target)?;
        }
    }
    // The record last, so an interrupted merge leaves the case unrecorded.
    if let Some((path, target)) = record {
        std::fs::copy(path, target)?;
    }
    Ok(())
}
