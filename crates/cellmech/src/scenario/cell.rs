//! `[cell]` and `[protocol]`: a built-in cell model and a built-in virtual experiment,
//! read against their declared parameter tables ([`crate::param`]): units converted,
//! ranges checked, unknown keys rejected with a suggestion, errors with line and key.
//!
//! `[cell]` replaces `[mesh]`, `[[material]]` and the filament sections (the suspended or
//! adherent cell of `shared/spec/cell-models.md`, see [`crate::cell`]); `[protocol]` replaces
//! `[[tool]]` and `[[step]]` (see [`crate::protocol`]). `[families.<name>]` (`membrane`,
//! `actin`, `microtubule`, `intermediate`) still switches components off or scales them.

use toml::de::{DeTable, DeValue};
use toml::Spanned;

use super::context::Ctx;
use super::ScenarioError;
use crate::cell::adherent::{params::ADHERENT_CELL, AdherentCell};
use crate::cell::suspended::{params::SUSPENDED_CELL, SuspendedCell};
use crate::cell::BuiltCell;
use crate::param::{read_section, ParamError};
use crate::protocol::afm_indentation::AFM_INDENTATION;
use crate::protocol::AfmIndentation;
use crate::protocol::{Protocol, ProtocolPlan, KINDS, TABLES};

/// The cell models `[cell] model = ...` accepts.
pub const MODELS: [&str; 2] = ["suspended", "adherent"];

fn param_error(ctx: &Ctx, e: ParamError) -> ScenarioError {
    ctx.invalid(e.span, &e.key, e.message)
}

fn root<'i>(ctx: &Ctx<'i>) -> Result<Spanned<DeTable<'i>>, ScenarioError> {
    DeTable::parse(ctx.text).map_err(|e| ScenarioError::Parse {
        path: ctx.origin.into(),
        message: e.to_string(),
    })
}

/// A word-valued key of a section, with its span.
fn word<'a>(
    table: &'a DeTable<'_>,
    section: &str,
    key: &str,
) -> Option<(&'a Spanned<DeValue<'a>>, Option<&'a str>)> {
    let DeValue::Table(t) = table.get(section)?.get_ref() else {
        return None;
    };
    let v = t.get(key)?;
    Some((v, v.get_ref().as_str()))
}

/// Builds the cell of `[cell]` (before `[families]` and `[protocol]`).
pub(super) fn resolve_cell(
    ctx: &Ctx,
    section_span: std::ops::Range<usize>,
) -> Result<BuiltCell, ScenarioError> {
    let root = root(ctx)?;
    let mut adherent = false;
    if let Some((v, model)) = word(root.get_ref(), "cell", "model") {
        match model {
            Some("suspended") => {}
            Some("adherent") => adherent = true,
            _ => {
                return Err(ctx.invalid(
                    Some(v.span()),
                    "cell.model",
                    format!(
                        "expected \"{}\"; found {}",
                        MODELS.join("\" or \""),
                        v.get_ref().as_str().map_or_else(
                            || v.get_ref().type_str().to_string(),
                            |s| format!("\"{s}\"")
                        )
                    ),
                ))
            }
        }
    }
    let built = if adherent {
        let values = read_section(root.get_ref(), &ADHERENT_CELL, &["model"], &[])
            .map_err(|e| param_error(ctx, e))?;
        let mut cell = AdherentCell::from_values(&values);
        // The mesh is refined where the protocol indents.
        if let Some((_, Some("afm-indentation"))) = word(root.get_ref(), "protocol", "kind") {
            let values = read_section(root.get_ref(), &AFM_INDENTATION, &["kind"], &TABLES)
                .map_err(|e| param_error(ctx, e))?;
            cell.site = Some(AfmIndentation::from_values(&values).site);
        }
        cell.build()
    } else {
        let values = read_section(root.get_ref(), &SUSPENDED_CELL, &["model"], &[])
            .map_err(|e| param_error(ctx, e))?;
        let cell = SuspendedCell::from_values(&values);
        // The mesh is refined under the protocol's tools (compression: the plates).
        let protocol = match word(root.get_ref(), "protocol", "kind") {
            Some((_, Some(kind))) => match Protocol::table(kind) {
                Some(table) => {
                    let values = read_section(root.get_ref(), table, &["kind"], &TABLES)
                        .map_err(|e| param_error(ctx, e))?;
                    Protocol::from_values(kind, &values)
                }
                None => None,
            },
            _ => None,
        };
        match protocol {
            Some(p) => cell.with_tool_refinement(p.pole_refinement()).build(),
            None => cell.build(),
        }
    };
    built.map_err(|e| ctx.invalid(Some(section_span), "cell", e.to_string()))
}

/// Reads `[protocol]` and applies it to `cell` (which gains the protocol's node sets, tools
/// and steps).
pub(super) fn resolve_protocol(
    ctx: &Ctx,
    section_span: std::ops::Range<usize>,
    cell: &mut BuiltCell,
) -> Result<ProtocolPlan, ScenarioError> {
    let root = root(ctx)?;
    let (kind_span, kind) = match word(root.get_ref(), "protocol", "kind") {
        Some((v, Some(k))) => (v.span(), k.to_string()),
        Some((v, None)) => {
            return Err(ctx.invalid(
                Some(v.span()),
                "protocol.kind",
                format!(
                    "expected one of \"{}\"; found a {}",
                    KINDS.join("\", \""),
                    v.get_ref().type_str()
                ),
            ))
        }
        None => {
            return Err(ctx.invalid(
                Some(section_span),
                "protocol.kind",
                format!("expected one of \"{}\"; found none", KINDS.join("\", \"")),
            ))
        }
    };
    let Some(table) = Protocol::table(&kind) else {
        return Err(ctx.invalid(
            Some(kind_span),
            "protocol.kind",
            format!("expected \"{}\"; found \"{kind}\"", KINDS.join("\", \"")),
        ));
    };
    let values =
        read_section(root.get_ref(), table, &["kind"], &TABLES).map_err(|e| param_error(ctx, e))?;
    let protocol = Protocol::from_values(&kind, &values).expect("the kind has a table");
    protocol.apply(cell).map_err(|e| {
        let key = e.key;
        ctx.invalid(
            values.span(key).or(Some(section_span)),
            &format!("protocol.{key}"),
            e.message,
        )
    })
}
