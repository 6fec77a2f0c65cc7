//! Running a study's cases: each in its own folder, ending with a completion record written
//! atomically; a rerun skips recorded cases and redoes interrupted ones. Cases run in
//! parallel (`jobs`) and split into stable shards for a cluster's job array.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use cellmech_fem::solve::NullObserver;
use serde::{Deserialize, Serialize};

use super::spec::{Case, StudyError, StudySpec};

/// Name of a case's completion record.
pub const RECORD: &str = "record.json";
/// Name of a case's scenario file.
pub const CASE_FILE: &str = "case.toml";

/// How a pool runs cases, whatever study they come from.
#[derive(Debug, Clone, Copy)]
pub struct PoolOptions {
    /// Cases run at once (≥ 1).
    pub jobs: usize,
    /// Solver threads per case (0: the machine's cores divided by `jobs`, at least 1).
    pub threads_per_case: usize,
    /// Run only shard `k` of `n` (0-based): a stable subset by case name.
    pub shard: Option<(usize, usize)>,
}

/// A point of a case's test curve (for the overlaid curves).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct CurvePoint {
    /// Elongation or plate travel from the reference state (µm).
    pub displacement_um: f64,
    /// Force on the moving tool (nN).
    pub force_nn: f64,
}

/// What one case did: written to `record.json` when the case has finished (converged to
/// the end, or stopped with a reason).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct CaseRecord {
    /// Case name.
    pub name: String,
    /// Member label on every axis.
    pub labels: Vec<String>,
    /// Keys the case sets, as `key = value`.
    pub set: Vec<String>,
    /// `completed` or `failed`.
    pub status: String,
    /// Why it failed.
    pub error: Option<String>,
    /// Seed of the case's cell.
    pub seed: Option<u64>,
    /// Force at the last converged point (nN).
    pub force_nn: Option<f64>,
    /// Displacement at the last converged point (µm).
    pub displacement_um: Option<f64>,
    /// Nucleus max principal log strain at the last point, from the unstressed mesh.
    pub nucleus_strain: Option<f64>,
    /// The same from the test's reference state.
    #[serde(default)]
    pub nucleus_strain_from_reference: Option<f64>,
    /// Per-family filament counts and FA-end force sums at the last point (the
    /// `*_filaments_*` and `*_fa_force_sum_nN` columns of `curve.csv`).
    #[serde(default)]
    pub filaments: std::collections::BTreeMap<String, f64>,
    /// Compression: (deformation, force nN) at each target.
    pub at_deformations: Vec<(f64, f64)>,
    /// Newton iterations over all steps.
    pub iterations: usize,
    /// Numeric factorisations.
    pub factorizations: usize,
    /// Increments solved with viscous stabilisation on, over all steps (0: none).
    #[serde(default)]
    pub stabilized_increments: usize,
    /// The largest fraction of a step's strain energy that the stabilisation dissipated
    /// (0: none). A completed case with a large value ended in equilibrium, but its path
    /// was carried by the viscosity.
    #[serde(default)]
    pub dissipated_fraction: f64,
    /// Tension and compression: the largest imbalance of the two tools' forces over the
    /// test curve (`ProtocolResults::largest_tool_force_imbalance`): round-off in
    /// equilibrium, the viscous forces' resultant where increments were stabilised.
    #[serde(default)]
    pub tool_force_imbalance: Option<f64>,
    /// The first point at which an element of the cell's continuum had folded over
    /// (`ProtocolResults::continuum_folds_at_um`, µm of the test's displacement).
    #[serde(default)]
    pub folds_at_um: Option<f64>,
    /// AFM: the first indentation at which the tip had passed between the surface nodes
    /// (`ProtocolResults::tip_passes_between_nodes_at_um`, µm).
    #[serde(default)]
    pub tip_passes_between_nodes_at_um: Option<f64>,
    /// Wall time of the case (s).
    pub wall_time_s: f64,
    /// The test curve.
    pub curve: Vec<CurvePoint>,
    /// The case folder this record and its outputs were copied from, when an identical
    /// case of another study was run in the same pool (the numbers, wall time included,
    /// are that case's, and the outputs name it in their titles); `None` when the case was
    /// computed in its own folder.
    #[serde(default)]
    pub shared_from: Option<String>,
}

/// What happened to one case in this invocation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CaseEvent {
    /// Already recorded: skipped.
    Skipped,
    /// Run now and recorded.
    Ran,
    /// Recorded now from an identical case of another study run in the same pool
    /// ([`run_jobs`]): its folder copied, not computed again.
    Shared,
}

/// Stable 64-bit hash of `bytes` (FNV-1a): the same on every machine, build and run.
pub fn stable_hash(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf29ce484222325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x100000001b3);
    }
    h
}

/// Stable shard of a case name (FNV-1a), so a case stays in its shard when cases are added.
pub fn shard_of(name: &str, shards: usize) -> usize {
    (stable_hash(name.as_bytes()) % shards.max(1) as u64) as usize
}

/// What a case computes, as a stable hash: its scenario without the title (a label that
/// changes no number) and the directory its relative paths resolve against. Two cases
/// with the same key give the same results, so [`run_jobs`] runs them once.
pub fn scenario_key(spec: &StudySpec, case: &Case) -> Result<u64, StudyError> {
    let mut doc = spec.case_scenario(case)?;
    doc.remove("title");
    let text = toml::to_string(&doc).map_err(|e| StudyError::Case {
        case: case.name.clone(),
        message: e.to_string(),
    })?;
    let resolved = format!("{text}\n# resolved against {}", spec.base_dir.display());
    Ok(stable_hash(resolved.as_bytes()))
}

/// The folder of a case.
pub fn case_dir(out: &Path, name: &str) -> PathBuf {
    out.join("cases").join(name)
}

/// Reads a case's record, if it has one that parses.
pub fn read_record(dir: &Path) -> Option<CaseRecord> {
    let text = std::fs::read_to_string(dir.join(RECORD)).ok()?;
    serde_json::from_str(&text).ok()
}

/// Checks every case's scenario (writing nothing): unknown keys and bad values are reported
/// before any case runs.
pub fn check_cases(spec: &StudySpec, cases: &[Case]) -> Result<(), StudyError> {
    for case in cases {
        let text = spec.case_document(case)?;
        crate::scenario::parse(&text, &format!("case `{}`", case.name), &spec.base_dir).map_err(
            |e| StudyError::Case {
                case: case.name.clone(),
                message: e.to_string(),
            },
        )?;
    }
    Ok(())
}

/// One case to run into its folder (of any study).
#[derive(Debug, Clone)]
pub struct CaseJob<'a> {
    /// The case's study.
    pub spec: &'a StudySpec,
    /// The case.
    pub case: &'a Case,
    /// Its folder.
    pub dir: PathBuf,
}

/// Runs cases of one or several studies in one pool of `jobs` workers, each case with
/// `threads_per_case` solver threads (0: the cores divided by the workers). Cases whose
/// scenarios are the same ([`scenario_key`]: the controls of a disruption and a
/// modulus study, for example) are computed once: the first unrecorded one runs, and the
/// others get a copy of its folder with their own `case.toml` and a record naming the
/// source (`shared_from`); an identical case recorded earlier is copied instead of run.
/// Work is taken in the order of the jobs, so the pool's tail is the last jobs'.
/// Returns each job's record (or error), in job order.
pub fn run_jobs(
    jobs: &[CaseJob<'_>],
    workers: usize,
    threads_per_case: usize,
    on_case: &(dyn Fn(&CaseRecord, CaseEvent) + Sync),
) -> Vec<Result<CaseRecord, StudyError>> {
    // Groups of identical cases, in the order of their first job.
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut keys: Vec<Option<u64>> = Vec::new();
    for (i, job) in jobs.iter().enumerate() {
        // A case whose scenario does not resolve runs alone (and reports why it fails).
        let key = scenario_key(job.spec, job.case).ok();
        match keys.iter().position(|k| key.is_some() && *k == key) {
            Some(g) => groups[g].push(i),
            None => {
                keys.push(key);
                groups.push(vec![i]);
            }
        }
    }
    let workers = workers.max(1).min(groups.len().max(1));
    let threads = if threads_per_case > 0 {
        threads_per_case
    } else {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        (cores / workers).max(1)
    };
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Result<CaseRecord, StudyError>>>> =
        Mutex::new((0..jobs.len()).map(|_| None).collect());
    let finish = |i: usize, result: Result<(CaseRecord, CaseEvent), StudyError>| {
        if let Ok((record, event)) = &result {
            on_case(record, *event);
        }
        results.lock().expect("no worker panics holding the lock")[i] =
            Some(result.map(|(r, _)| r));
    };
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| loop {
                let g = next.fetch_add(1, Ordering::SeqCst);
                let Some(group) = groups.get(g) else {
                    break;
                };
                run_group(jobs, group, threads, &finish);
            });
        }
    });
    results
        .into_inner()
        .expect("no worker panicked")
        .into_iter()
        .map(|r| r.expect("every job ran"))
        .collect()
}

/// Runs a group of identical cases: copies an existing record, or runs the first case
/// that has none, then copies it to the others that have none.
fn run_group(
    jobs: &[CaseJob<'_>],
    group: &[usize],
    threads: usize,
    finish: &(dyn Fn(usize, Result<(CaseRecord, CaseEvent), StudyError>) + Sync),
) {
    let mut source: Option<(PathBuf, CaseRecord)> = None;
    let mut pending = Vec::new();
    for &i in group {
        match read_record(&jobs[i].dir) {
            Some(record) => {
                if source.is_none() {
                    source = Some((jobs[i].dir.clone(), record.clone()));
                }
                finish(i, Ok((record, CaseEvent::Skipped)));
            }
            None => pending.push(i),
        }
    }
    let mut pending = pending.into_iter();
    if source.is_none() {
        let Some(first) = pending.next() else {
            return;
        };
        let job = &jobs[first];
        let result = run_case_in(job.spec, job.case, &job.dir, threads);
        if let Ok((record, _)) = &result {
            source = Some((job.dir.clone(), record.clone()));
        }
        finish(first, result);
    }
    for i in pending {
        let job = &jobs[i];
        let result = match &source {
            Some((dir, record)) => share_case(dir, record, job),
            // The first case could not even be set up: the others say why on their own.
            None => run_case_in(job.spec, job.case, &job.dir, threads),
        };
        finish(i, result);
    }
}

/// Records `job` from the identical case computed in `from`: its outputs copied, its own
/// `case.toml`, and its record (its name, labels and keys; the numbers of the source),
/// written last.
fn share_case(
    from: &Path,
    source: &CaseRecord,
    job: &CaseJob<'_>,
) -> Result<(CaseRecord, CaseEvent), StudyError> {
    let dir = &job.dir;
    let io = |e: std::io::Error| StudyError::Output(format!("{}: {e}", dir.display()));
    if dir.exists() {
        std::fs::remove_dir_all(dir).map_err(io)?;
    }
    copy_outputs(from, dir).map_err(io)?;
    let text = job.spec.case_document(job.case)?;
    cellmech_io::write_atomic(&dir.join(CASE_FILE), text.as_bytes())
        .map_err(|e| StudyError::Output(e.to_string()))?;
    let record = CaseRecord {
        name: job.case.name.clone(),
        labels: job.case.labels.clone(),
        set: job
            .case
            .set
            .iter()
            .map(|(k, v)| format!("{k} = {v}"))
            .collect(),
        shared_from: Some(from.display().to_string()),
        ..source.clone()
    };
    write_record(dir, &record)?;
    Ok((record, CaseEvent::Shared))
}

/// Copies a case folder's outputs (everything but its record and its `case.toml`).
fn copy_outputs(from: &Path, to: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(to)?;
    for entry in std::fs::read_dir(from)? {
        let entry = entry?;
        let name = entry.file_name();
        if name == RECORD || name == CASE_FILE {
            continue;
        }
        if entry.file_type()?.is_dir() {
            super::copy_dir(&entry.path(), &to.join(&name))?;
        } else {
            std::fs::copy(entry.path(), to.join(&name))?;
        }
    }
    Ok(())
}

/// Writes a case's record, atomically: from now on the case is done.
fn write_record(dir: &Path, record: &CaseRecord) -> Result<(), StudyError> {
    let json =
        serde_json::to_string_pretty(record).map_err(|e| StudyError::Output(e.to_string()))?;
    cellmech_io::write_atomic(&dir.join(RECORD), json.as_bytes())
        .map_err(|e| StudyError::Output(e.to_string()))
}

/// Runs one case in `dir` unless `dir` holds its record: writes `case.toml`, runs it with
/// `threads` solver threads (0: all cores) and writes `record.json` last, atomically. A
/// folder without a record is the remains of an interrupted run: it is emptied and the
/// case run again. A failed analysis is a record with `status = "failed"`, not an error.
pub fn run_case_in(
    spec: &StudySpec,
    case: &Case,
    dir: &Path,
    threads: usize,
) -> Result<(CaseRecord, CaseEvent), StudyError> {
    let dir = dir.to_path_buf();
    if let Some(record) = read_record(&dir) {
        return Ok((record, CaseEvent::Skipped));
    }
    let io = |e: std::io::Error| StudyError::Output(format!("{}: {e}", dir.display()));
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(io)?;
    }
    std::fs::create_dir_all(&dir).map_err(io)?;
    let text = spec.case_document(case)?;
    cellmech_io::write_atomic(&dir.join(CASE_FILE), text.as_bytes())
        .map_err(|e| StudyError::Output(e.to_string()))?;
    let scenario = crate::scenario::parse(
        &text,
        &dir.join(CASE_FILE).display().to_string(),
        &spec.base_dir,
    )
    .map_err(|e| StudyError::Case {
        case: case.name.clone(),
        message: e.to_string(),
    })?;
    let start = Instant::now();
    let outcome = crate::run::run_with_threads(&scenario, &dir, &mut NullObserver, threads);
    let (summary, error) = match outcome {
        Ok(summary) => (Some(summary), None),
        Err(crate::run::RunError::Analysis { error, summary, .. }) => {
            (Some(*summary), Some(error.to_string()))
        }
        Err(other) => (None, Some(other.to_string())),
    };
    let protocol = summary.as_ref().and_then(|s| s.protocol.as_ref());
    let last = protocol.and_then(|p| p.last);
    let record = CaseRecord {
        name: case.name.clone(),
        labels: case.labels.clone(),
        set: case.set.iter().map(|(k, v)| format!("{k} = {v}")).collect(),
        status: if error.is_none() {
            "completed"
        } else {
            "failed"
        }
        .into(),
        error,
        seed: summary.as_ref().and_then(|s| s.seed),
        force_nn: last.map(|p| p.force_nn),
        displacement_um: last.map(|p| p.displacement_um),
        nucleus_strain: last.map(|p| p.nucleus_max_principal_log_strain),
        nucleus_strain_from_reference: last
            .map(|p| p.nucleus_max_principal_log_strain_from_reference),
        filaments: summary
            .as_ref()
            .map(|s| {
                s.final_values
                    .iter()
                    .filter(|(k, _)| k.contains("_filaments_") || k.ends_with("_fa_force_sum_nN"))
                    .map(|(k, v)| (k.clone(), *v))
                    .collect()
            })
            .unwrap_or_default(),
        at_deformations: protocol
            .map(|p| {
                p.at_deformations
                    .iter()
                    .map(|(d, p)| (*d, p.force_nn))
                    .collect()
            })
            .unwrap_or_default(),
        iterations: summary
            .as_ref()
            .map_or(0, |s| s.steps.iter().map(|s| s.iterations).sum()),
        factorizations: summary
            .as_ref()
            .map_or(0, |s| s.solver_timings.factorizations),
        stabilized_increments: summary
            .as_ref()
            .map_or(0, |s| s.steps.iter().map(|s| s.stabilized_increments).sum()),
        dissipated_fraction: summary.as_ref().map_or(0.0, |s| {
            s.steps
                .iter()
                .filter_map(|s| s.stabilization.map(|st| st.dissipated_fraction))
                .fold(0.0, f64::max)
        }),
        tool_force_imbalance: protocol.and_then(|p| p.largest_tool_force_imbalance.map(|x| x.0)),
        folds_at_um: protocol.and_then(|p| p.continuum_folds_at_um),
        tip_passes_between_nodes_at_um: protocol.and_then(|p| p.tip_passes_between_nodes_at_um),
        wall_time_s: start.elapsed().as_secs_f64(),
        curve: protocol
            .map(|p| {
                p.curve
                    .iter()
                    .map(|t| CurvePoint {
                        displacement_um: t.displacement_um,
                        force_nn: t.force_nn,
                    })
                    .collect()
            })
            .unwrap_or_default(),
        shared_from: None,
    };
    write_record(&dir, &record)?;
    Ok((record, CaseEvent::Ran))
}
