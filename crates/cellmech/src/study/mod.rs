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

use std::path::Path;

pub use run::{CaseEvent, CaseRecord, StudyOptions};
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

/// Runs a study (its shard when `options.shard` is set), then writes the report over every
/// case recorded in `options.out` so far.
pub fn run_study(
    spec: &StudySpec,
    study_text: &str,
    options: &StudyOptions,
    on_case: &(dyn Fn(&CaseRecord, CaseEvent) + Sync),
) -> Result<StudyOutcome, StudyError> {
    let io = |e: std::io::Error| StudyError::Output(format!("{}: {e}", options.out.display()));
    std::fs::create_dir_all(options.out.join("cases")).map_err(io)?;
    let cases = spec.cases();
    // The study as run, next to its results (the first writer wins: a shard does not
    // overwrite another's copy with a different study silently).
    let copy = options.out.join("study.toml");
    match std::fs::read_to_string(&copy) {
        Ok(existing) if existing != study_text => {
            return Err(StudyError::Invalid {
                path: copy.display().to_string(),
                message: "expected the same study as the one already in this output directory; found a different one (use another --out)".into(),
            })
        }
        Ok(_) => {}
        Err(_) => cellmech_io::write_atomic(&copy, study_text.as_bytes())
            .map_err(|e| StudyError::Output(e.to_string()))?,
    }
    let before: usize = cases
        .iter()
        .filter(|c| run::read_record(&run::case_dir(&options.out, &c.name)).is_some())
        .count();
    run::run_cases(spec, &cases, options, on_case)?;
    let mut outcome = collect(spec, &options.out)?;
    let recorded = outcome.records.iter().flatten().count();
    outcome.ran = recorded.saturating_sub(before);
    outcome.skipped = before;
    Ok(outcome)
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

fn copy_dir(from: &Path, to: &Path) -> std::io::Result<()> {
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
