//! Command-line arguments.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

/// Virtual mechanical tests on single living cells (finite elements).
///
/// A scenario file (TOML, quantities with units like "0.5 kPa" or "2 um") describes the model
/// (a mesh with materials and filaments, or a built-in cell model with `[cell]`), the
/// experiment (rigid tools and analysis steps, or a built-in `[protocol]`) and the outputs.
/// `cellmech run` solves it and writes the force curve (curve.csv and a plot), the
/// convergence table, a ParaView series (fields.pvd) and summary.json into the output
/// directory.
///
/// Examples:
///   cellmech run                                  # the built-in default: suspended-cell tension
///   cellmech build examples/suspended-compression.toml   # look at the model before solving
///   cellmech run examples/sphere-compression.toml --out results/sphere
///   cellmech check my-cell.toml                    # validate without solving
///   cellmech example sphere-compression > my.toml  # start from a shipped scenario
///   cellmech params suspended-cell                 # every [cell] key: default, range, source
#[derive(Debug, Parser)]
#[command(name = "cellmech", version, about, long_about, verbatim_doc_comment)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Solve a scenario and write its outputs.
    ///
    /// Without a scenario, runs the built-in default. Every converged increment is written
    /// as it is produced (curve.csv, convergence.csv, fields/*.vtu + fields.pvd); a diverging
    /// analysis stops cleanly with exit code 1 and keeps them.
    Run(RunArgs),
    /// Read and validate a scenario (mesh, sets, materials, steps) without solving.
    Check(CheckArgs),
    /// Build a scenario's model and write it for viewing, without solving.
    ///
    /// Writes model.pvd (+ model_0000.vtu: continuum, membrane and filaments as line cells
    /// for ParaView), model.png (a picture: surface mesh and filament families in two views)
    /// and model.json (sizes, sets, the cell model's parameters and geometry quality).
    Build(BuildArgs),
    /// Print a built-in example scenario (list them without a name).
    Example(ExampleArgs),
    /// Time the hot paths on sphere meshes, or whole analyses with --analyses.
    ///
    /// Default: assembly, factorisation, solve and a Newton iteration on sphere meshes. With
    /// --export-matrices DIR the final tangent of each size is written as Matrix Market
    /// (sphere_<size>.mtx) for `benches/cholmod_compare.py`, which times CHOLMOD on it.
    ///
    /// With --analyses, runs whole analyses (suspended-tension, suspended-tension-fine,
    /// suspended-compression, plates, and sphere-50 / sphere-50-bfgs: the FEBio
    /// side-by-side case, 2816 hex8 to 50 % in 50 increments) and prints wall time, Newton iterations,
    /// factorisations and the time split per analysis and per step; --save FILE stores
    /// the figures as a baseline and --baseline FILE prints each figure's ratio to it, so
    /// a regression is visible.
    ///
    /// Examples:
    ///   cellmech bench --analyses                       # all six (the fine mesh: ~70 s)
    ///   cellmech bench --analyses plates --coarse       # the short CI variant
    ///   cellmech bench --analyses --save base.json      # later: --baseline base.json
    #[command(verbatim_doc_comment)]
    Bench(BenchArgs),
    /// The declared parameters of a cell model or protocol: key, default, range, source.
    ///
    /// Without a name, lists the tables. `--toml` prints a commented section with every
    /// key at its default, ready to paste into a scenario.
    ///
    /// Examples:
    ///   cellmech params                          # the tables
    ///   cellmech params suspended-cell           # the [cell] keys of the suspended cell
    ///   cellmech params micropipette-tension --toml
    #[command(verbatim_doc_comment)]
    Params(ParamsArgs),
    /// Run a parameter study: a base experiment and its variants, one case per folder.
    ///
    /// STUDY is a built-in study (list them with --list) or a study file (docs/studies.md):
    /// a base scenario and axes of variants (disruption, modulus, thickness,
    /// compressibility, density, grid, cases), crossed. Every case is checked before any runs;
    /// each writes OUT/cases/NAME/ and ends with record.json, so a rerun skips finished
    /// cases and redoes interrupted ones. Failed cases are recorded with their reason and
    /// the study goes on. The report (study.csv, study.json, force-over-control.svg,
    /// tornado.svg for modulus axes, curves.svg, report.md, report.html) covers every
    /// case recorded in OUT.
    ///
    /// Several studies share one pool of --jobs workers: each writes OUT/STUDY/ (STUDY:
    /// the built-in name or the file's stem), the workers stay busy until the last case of
    /// all of them, and a case that two studies share (their controls) runs once and is
    /// copied to the other (its record says `shared_from`). Give the slowest study first.
    ///
    /// Examples:
    ///   cellmech study --list
    ///   cellmech study suspended-tension-disruption --out out/disruption --jobs 2
    ///   cellmech study suspended-compression-modulus suspended-tension-modulus --out out/battery --jobs 2
    ///   cellmech study my-study.toml --shard 3/8 --out shared/study   # one array task
    ///   cellmech study my-study.toml --collect --out shared/study     # report only
    ///   cellmech study my-study.toml --collect --from a/ --from b/ --out merged/
    #[command(verbatim_doc_comment)]
    Study(StudyArgs),
    /// Fit model parameters to a measured force curve (docs/fitting.md).
    ///
    /// FIT is a TOML file: the experiment (`base` = a built-in example or a scenario file,
    /// and a `[set]` table of dotted keys, as in a study), the measured curve (`data`, a CSV
    /// file whose header gives each column's unit), the parameters to fit with start and
    /// bounds, and optionally the fitted range. A bounded Levenberg-Marquardt optimiser
    /// runs the experiment once per evaluation; every run is kept in OUT/runs/HASH/ with a
    /// completion record, so a rerun into the same OUT resumes without solving again.
    /// Writes fit.json, fit-history.csv, fit.csv, fit.svg/png and fit.md. Exit code 1 when
    /// the optimiser stops without converging.
    ///
    /// Example (examples/fit-tension.toml):
    ///   base = "suspended-tension"
    ///   data = "fit-tension-curve.csv"        # header: elongation [um],force [nN]
    ///   range = ["0 um", "10 um"]
    ///   [set]
    ///   "cell.core_divisions" = 4             # (and shell/outer layers: the coarse cell)
    ///   "protocol.elongation" = "10 um"
    ///   [[parameter]]
    ///   key = "cell.cytoplasm.shear_modulus"
    ///   start = "0.24 kPa"
    ///   lower = "0.02 kPa"
    ///   upper = "2 kPa"
    ///   [[parameter]]
    ///   key = "cell.membrane.youngs_modulus"
    ///   start = "650 kPa"
    ///   lower = "50 kPa"
    ///   upper = "20000 kPa"
    ///
    ///   cellmech fit examples/fit-tension.toml --out out/fit        # ~18 runs, 1-2 min
    ///   cellmech fit examples/fit-tension.toml --out out/fit        # again: all cached
    ///   cellmech fit examples/fit-tension.toml --dry-run            # check only
    ///   cellmech fit examples/fit-tension.toml --out out/fit --json --quiet
    ///   cellmech fit examples/fit-tension.toml --synthetic my.csv --at "0.17 kPa" \
    ///       --at "1000 kPa" --noise "0.3 nN" --seed 14             # a test curve
    #[command(verbatim_doc_comment)]
    Fit(FitArgs),
}

#[derive(Debug, Args)]
pub struct FitArgs {
    /// Fit file (TOML).
    pub fit: PathBuf,
    /// Output directory (the runs go to OUT/runs/).
    #[arg(short, long, default_value = "cellmech-fit")]
    pub out: PathBuf,
    /// Solver threads per FE run (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Check the fit file, its data and every parameter key (at the start and both
    /// bounds) and print what would be fitted, without running anything.
    #[arg(long)]
    pub dry_run: bool,
    /// Instead of fitting, write a synthetic curve to FILE: the experiment run at --at
    /// values, interpolated at --points evenly spaced points over `range` (or the whole
    /// curve), plus Gaussian noise (--noise, --seed). The fit's `data` need not exist.
    #[arg(long, value_name = "FILE")]
    pub synthetic: Option<PathBuf>,
    /// With --synthetic: a parameter value with its unit, once per [[parameter]] in order
    /// (e.g. --at "0.17 kPa" --at "1000 kPa").
    #[arg(long, value_name = "VALUE")]
    pub at: Vec<String>,
    /// With --synthetic: standard deviation of the noise, in the force's unit (e.g. "0.3 nN").
    #[arg(long, default_value = "0 nN")]
    pub noise: String,
    /// With --synthetic: seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// With --synthetic: number of points.
    #[arg(long, default_value_t = 40)]
    pub points: usize,
    #[command(flatten)]
    pub report: ReportArgs,
}

#[derive(Debug, Args)]
pub struct StudyArgs {
    /// Built-in study names or study files (several: one pool, OUT/STUDY/ each).
    #[arg(required_unless_present = "list")]
    pub study: Vec<String>,
    /// List the built-in studies.
    #[arg(long)]
    pub list: bool,
    /// Output directory.
    #[arg(short, long, default_value = "cellmech-study")]
    pub out: PathBuf,
    /// Cases run at once (each gets the cores divided by N solver threads).
    #[arg(short, long, default_value_t = 1)]
    pub jobs: usize,
    /// Run only shard K of N (0-based, e.g. 3/8): a stable subset of the cases by name,
    /// for a cluster's job array (`--shard $SLURM_ARRAY_TASK_ID/N`).
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    pub shard: Option<(usize, usize)>,
    /// Run nothing: write the report over the cases recorded in --out (and --from).
    #[arg(long)]
    pub collect: bool,
    /// With --collect: also take recorded cases from these output directories (shards run
    /// elsewhere), copying them into --out.
    #[arg(long, value_name = "DIR")]
    pub from: Vec<PathBuf>,
    /// Print the cases without running them.
    #[arg(long)]
    pub dry_run: bool,
    #[command(flatten)]
    pub report: ReportArgs,
}

fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let (k, n) = s
        .split_once('/')
        .ok_or_else(|| format!("expected K/N such as 3/8; found \"{s}\""))?;
    let k: usize = k
        .trim()
        .parse()
        .map_err(|_| format!("expected a shard number K in K/N; found \"{k}\""))?;
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| format!("expected a shard count N in K/N; found \"{n}\""))?;
    if n == 0 || k >= n {
        return Err(format!("expected 0 <= K < N; found {k}/{n}"));
    }
    Ok((k, n))
}

#[derive(Debug, Args)]
pub struct ParamsArgs {
    /// Table name (`suspended-cell`, `micropipette-tension`, `microplate-compression`).
    pub name: Option<String>,
    /// Print a commented TOML section with the defaults.
    #[arg(long, conflicts_with = "json")]
    pub toml: bool,
    /// Print the table as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Approximate element counts of the sphere meshes.
    #[arg(long, value_delimiter = ',', default_value = "3000,10000,30000")]
    pub sizes: Vec<usize>,
    /// Write each final tangent to DIR/sphere_<size>.mtx.
    #[arg(long, value_name = "DIR")]
    pub export_matrices: Option<PathBuf>,
    /// Time whole analyses instead (all when no name is given).
    #[arg(long, value_delimiter = ',', num_args = 0.., value_name = "NAMES")]
    pub analyses: Option<Vec<String>>,
    /// With --analyses: cell tests on a 448-element cell (the CI variant).
    #[arg(long)]
    pub coarse: bool,
    /// With --analyses: write the figures to FILE (JSON) as a baseline.
    #[arg(long, value_name = "FILE")]
    pub save: Option<PathBuf>,
    /// With --analyses: print each figure's ratio to the baseline in FILE.
    #[arg(long, value_name = "FILE")]
    pub baseline: Option<PathBuf>,
    /// Print the timings as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct RunArgs {
    /// Scenario file (TOML). Default: the built-in default scenario.
    pub scenario: Option<PathBuf>,
    /// Output directory.
    #[arg(short, long, default_value = "cellmech-out")]
    pub out: PathBuf,
    #[command(flatten)]
    pub report: ReportArgs,
}

#[derive(Debug, Args)]
pub struct BuildArgs {
    /// Scenario file (TOML). Default: the built-in default scenario.
    pub scenario: Option<PathBuf>,
    /// Output directory.
    #[arg(short, long, default_value = "cellmech-model")]
    pub out: PathBuf,
    #[command(flatten)]
    pub report: ReportArgs,
}

#[derive(Debug, Args)]
pub struct CheckArgs {
    /// Scenario file (TOML).
    pub scenario: PathBuf,
    #[command(flatten)]
    pub report: ReportArgs,
}

#[derive(Debug, Args)]
pub struct ExampleArgs {
    /// Name of the example.
    pub name: Option<String>,
}

#[derive(Debug, Args, Clone, Copy)]
pub struct ReportArgs {
    /// No progress bars or messages; errors still go to stderr.
    #[arg(short, long)]
    pub quiet: bool,
    /// Print a machine-readable JSON result on stdout (implies --quiet for progress).
    #[arg(long)]
    pub json: bool,
}
