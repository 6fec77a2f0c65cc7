//! Per-filament results at a converged state: the axial force at the FA end, the extremes
//! along the filament, its state (tension, compression, slack), its straightness and its
//! strain; per family the counts and the FA-end force sum as `curve.csv` columns, one row
//! per filament in `filaments.csv`, and the table of the last state in `summary.json`.
//!
//! Definitions (current configuration `x = X + u`):
//!
//! * forces are the engine's element axial forces N (nN, tension positive); the FA-end force
//!   is that of the element at the FA end (the start element for an AF with two FA ends);
//! * **state**: the force that decides is the FA-end force, or for a filament without an FA
//!   end the length-weighted mean force. `|N| ≤ ZERO_FORCE_STRAIN · EA` ([`ZERO_FORCE_STRAIN`]
//!   = 1e-9, EA the filament's axial stiffness) is **slack** (zero force); above it the sign
//!   decides **tension** or **compression**. The threshold is an axial strain, so it scales
//!   with each family (EA = 100 nN for an AF: 1e-7 nN; 317 nN for an MT: 3e-7 nN; 0.6 nN for
//!   an IF); a tension-only truss below its stress-free length carries exactly 0;
//! * **chord / arc**: distance between the end nodes over the sum of the current element
//!   lengths; a beam filament is **straight** when it exceeds [`STRAIGHT_CHORD_RATIO`] = 0.99;
//! * **strain**: arc length over the stress-free length minus 1 (stress-free length:
//!   `Σ L0·(1 + slack)/(1 + prestrain)` for trusses, `Σ L0` for beams), the engineering strain
//!   of the whole filament (the IF measure: an IF carries force once it exceeds 0).

use cellmech_fem::solve::Problem;
use cellmech_io::{CsvCell, CurveWriter};
use serde::Serialize;

use crate::model::filaments::{FilamentEnd, FilamentIndex};

/// Axial strain below which a filament's force counts as zero (slack): `|N| ≤ 1e-9·EA`
/// (the engine's per-element counts use the same threshold).
pub use cellmech_fem::element::ZERO_FORCE_STRAIN;

/// Chord over arc length above which a beam filament counts as straight.
pub const STRAIGHT_CHORD_RATIO: f64 = 0.99;

/// Tension, compression or no force.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FilamentState {
    /// N > threshold.
    Tension,
    /// N < −threshold.
    Compression,
    /// |N| ≤ threshold.
    Slack,
}

impl FilamentState {
    /// The state of force `n` for a filament of axial stiffness `ea`.
    pub fn of(n: f64, ea: f64) -> Self {
        let zero = ZERO_FORCE_STRAIN * ea;
        if n > zero {
            FilamentState::Tension
        } else if n < -zero {
            FilamentState::Compression
        } else {
            FilamentState::Slack
        }
    }

    /// Lower-case name (`filaments.csv`).
    pub fn name(self) -> &'static str {
        match self {
            FilamentState::Tension => "tension",
            FilamentState::Compression => "compression",
            FilamentState::Slack => "slack",
        }
    }
}

/// One filament at one state.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FilamentResult {
    /// Family name.
    pub family: String,
    /// Unique id (the VTU cell data `filament_id`).
    pub id: usize,
    /// Position among the filaments of its family.
    pub index: usize,
    /// First node of the chain.
    pub start_node: usize,
    /// Last node of the chain.
    pub end_node: usize,
    /// Which end is on a focal adhesion.
    pub fa_end: Option<FilamentEnd>,
    /// The FA node.
    pub fa_node: Option<usize>,
    /// Axial force at the FA end (nN, tension positive).
    pub fa_force_nn: Option<f64>,
    /// Largest element axial force (nN).
    pub max_force_nn: f64,
    /// Smallest element axial force (nN).
    pub min_force_nn: f64,
    /// Tension, compression or slack (see the module docs).
    pub state: FilamentState,
    /// Distance between the end nodes (µm).
    pub chord_um: f64,
    /// Sum of the current element lengths (µm).
    pub arc_um: f64,
    /// `chord_um / arc_um`.
    pub chord_over_arc: f64,
    /// Beams: `chord_over_arc > 0.99`; `None` for trusses.
    pub straight: Option<bool>,
    /// Arc length over the stress-free length minus 1.
    pub strain: f64,
}

/// Per-family counts at one state.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FamilyCounts {
    /// Family name.
    pub family: String,
    /// Number of filaments.
    pub filaments: usize,
    /// Filaments in tension.
    pub in_tension: usize,
    /// Filaments in compression.
    pub in_compression: usize,
    /// Slack filaments (zero force).
    pub slack: usize,
    /// Straight filaments (beam families only).
    pub straight: Option<usize>,
    /// Sum of the FA-end forces (nN; families with FA ends only; an AF counted once).
    pub fa_force_sum_nn: Option<f64>,
}

/// Every filament at one converged state (`summary.json` → `filaments`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FilamentSnapshot {
    /// Step index.
    pub step: usize,
    /// Increment in the step.
    pub increment: usize,
    /// Analysis time.
    pub time: f64,
    /// Every filament family of the model; the VTU cell data `filament_family` indexes it.
    pub family_names: Vec<String>,
    /// Counts of each enabled family.
    pub families: Vec<FamilyCounts>,
    /// Every enabled filament, by id.
    pub filaments: Vec<FilamentResult>,
}

/// The per-filament results at the problem's current state; `reference` are the nodes' initial
/// positions.
pub fn evaluate(
    index: &FilamentIndex,
    problem: &Problem,
    reference: &[[f64; 3]],
) -> Result<Vec<FilamentResult>, String> {
    let (u, map) = (problem.u(), problem.dof_map());
    let x = |n: usize| -> [f64; 3] { std::array::from_fn(|c| reference[n][c] + u[map.dof(n, c)]) };
    let dist = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt();
    let mut out = Vec::with_capacity(index.filaments.len());
    for (k, family) in index.families.iter().enumerate() {
        let Some(t) = family.term else { continue };
        let term = problem
            .terms()
            .get(t)
            .ok_or_else(|| format!("filament family '{}': no term {t}", family.name))?;
        let output = term
            .outputs(u, map)
            .map_err(|e| format!("outputs of '{}': {e}", family.name))?;
        let forces = output
            .as_ref()
            .and_then(|o| o.fields.iter().find(|f| f.name == "axial_force_nN"))
            .map(|f| f.values.as_slice())
            .ok_or_else(|| format!("term '{}' has no axial_force_nN", family.name))?;
        for f in index.filaments.iter().filter(|f| f.family == k) {
            let n = forces.get(f.elements.clone()).ok_or_else(|| {
                format!(
                    "filament {} of '{}': elements {:?} beyond the term's {}",
                    f.id,
                    family.name,
                    f.elements,
                    forces.len()
                )
            })?;
            let positions: Vec<[f64; 3]> = f.nodes.iter().map(|&v| x(v)).collect();
            let lengths: Vec<f64> = positions.windows(2).map(|w| dist(w[0], w[1])).collect();
            let arc: f64 = lengths.iter().sum();
            let chord = dist(positions[0], positions[positions.len() - 1]);
            let fa_force = f.fa_element().map(|e| forces[e]);
            let decisive = fa_force
                .unwrap_or_else(|| n.iter().zip(&lengths).map(|(n, l)| n * l).sum::<f64>() / arc);
            let ratio = chord / arc;
            out.push(FilamentResult {
                family: family.name.clone(),
                id: f.id,
                index: f.index,
                start_node: f.nodes[0],
                end_node: f.nodes[f.nodes.len() - 1],
                fa_end: f.fa_end,
                fa_node: f.fa_node(),
                fa_force_nn: fa_force,
                max_force_nn: n.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                min_force_nn: n.iter().copied().fold(f64::INFINITY, f64::min),
                state: FilamentState::of(decisive, f.axial_stiffness),
                chord_um: chord,
                arc_um: arc,
                chord_over_arc: ratio,
                straight: family.beams.then_some(ratio > STRAIGHT_CHORD_RATIO),
                strain: arc / f.stress_free_length - 1.0,
            });
        }
    }
    Ok(out)
}

/// Counts per enabled family.
pub fn family_counts(index: &FilamentIndex, results: &[FilamentResult]) -> Vec<FamilyCounts> {
    index
        .families
        .iter()
        .filter(|f| f.term.is_some())
        .map(|family| {
            let of = || results.iter().filter(|r| r.family == family.name);
            let state = |s: FilamentState| of().filter(|r| r.state == s).count();
            FamilyCounts {
                family: family.name.clone(),
                filaments: of().count(),
                in_tension: state(FilamentState::Tension),
                in_compression: state(FilamentState::Compression),
                slack: state(FilamentState::Slack),
                straight: family
                    .beams
                    .then(|| of().filter(|r| r.straight == Some(true)).count()),
                fa_force_sum_nn: family
                    .has_fa_end
                    .then(|| of().filter_map(|r| r.fa_force_nn).sum()),
            }
        })
        .collect()
}

/// `curve.csv` columns: per enabled family `<family>_filaments_in_tension`,
/// `_filaments_in_compression`, `_filaments_slack`, for beams `_filaments_straight`, and with
/// FA ends `<family>_fa_force_sum_nN`.
pub fn curve_columns(index: &FilamentIndex) -> Vec<String> {
    let mut columns = Vec::new();
    for f in index.families.iter().filter(|f| f.term.is_some()) {
        let n = &f.name;
        columns.push(format!("{n}_filaments_in_tension"));
        columns.push(format!("{n}_filaments_in_compression"));
        columns.push(format!("{n}_filaments_slack"));
        if f.beams {
            columns.push(format!("{n}_filaments_straight"));
        }
        if f.has_fa_end {
            columns.push(format!("{n}_fa_force_sum_nN"));
        }
    }
    columns
}

/// The values of [`curve_columns`], in the same order.
pub fn curve_values(counts: &[FamilyCounts]) -> Vec<f64> {
    let mut values = Vec::new();
    for c in counts {
        values.push(c.in_tension as f64);
        values.push(c.in_compression as f64);
        values.push(c.slack as f64);
        if let Some(s) = c.straight {
            values.push(s as f64);
        }
        if let Some(f) = c.fa_force_sum_nn {
            values.push(f);
        }
    }
    values
}

/// Columns of `filaments.csv`.
pub const CSV_COLUMNS: [&str; 18] = [
    "step",
    "increment",
    "time",
    "family",
    "id",
    "index",
    "start_node",
    "end_node",
    "fa_node",
    "fa_force_nN",
    "max_force_nN",
    "min_force_nN",
    "state",
    "chord_um",
    "arc_um",
    "chord_over_arc",
    "straight",
    "strain",
];

/// Appends one `filaments.csv` row per filament (empty `fa_node`/`fa_force_nN` without an
/// FA end, empty `straight` for trusses, 1/0 for beams).
pub fn push_csv_rows(
    csv: &mut CurveWriter,
    step: usize,
    increment: usize,
    time: f64,
    results: &[FilamentResult],
) -> Result<(), cellmech_io::CsvError> {
    let int = |v: usize| CsvCell::Integer(v as i64);
    let rows: Vec<Vec<CsvCell<'_>>> = results
        .iter()
        .map(|r| {
            vec![
                int(step),
                int(increment),
                CsvCell::Number(time),
                CsvCell::Text(&r.family),
                int(r.id),
                int(r.index),
                int(r.start_node),
                int(r.end_node),
                r.fa_node.map_or(CsvCell::Empty, int),
                r.fa_force_nn.map_or(CsvCell::Empty, CsvCell::Number),
                CsvCell::Number(r.max_force_nn),
                CsvCell::Number(r.min_force_nn),
                CsvCell::Text(r.state.name()),
                CsvCell::Number(r.chord_um),
                CsvCell::Number(r.arc_um),
                CsvCell::Number(r.chord_over_arc),
                r.straight.map_or(CsvCell::Empty, |s| int(usize::from(s))),
                CsvCell::Number(r.strain),
            ]
        })
        .collect();
    csv.push_records(&rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn states_use_a_threshold_relative_to_the_axial_stiffness() {
        assert_eq!(FilamentState::of(1e-6, 100.0), FilamentState::Tension);
        assert_eq!(FilamentState::of(-1e-6, 100.0), FilamentState::Compression);
        assert_eq!(FilamentState::of(0.9e-7, 100.0), FilamentState::Slack);
        assert_eq!(FilamentState::of(-0.9e-7, 100.0), FilamentState::Slack);
        assert_eq!(FilamentState::of(0.0, 0.6), FilamentState::Slack);
        // The same force is slack for a stiff family and tension for a soft one.
        assert_eq!(FilamentState::of(1e-8, 317.0), FilamentState::Slack);
        assert_eq!(FilamentState::of(1e-8, 0.6), FilamentState::Tension);
    }
}
