//! Scenario sections for the discrete and surface structures of a cell model: filaments
//! (`[[filament]]`, trusses or beams), membranes (`[[membrane]]`) and the per-family study
//! switches (`[families.<name>]`). Raw serde structs and their resolution into checked,
//! internal-unit descriptions; `docs/structures.md` documents every key.

use std::collections::BTreeMap;
use std::ops::Range;

use cellmech_fem::element::beam::BeamSection;
use cellmech_fem::material::AxialLaw;
use cellmech_fem::mesh::surface::{boundary_quads, faces_on_node_set};
use cellmech_fem::mesh::{ElementKind, Mesh};
use serde::Deserialize;
use toml::Spanned;

use super::context::Ctx;
use super::ScenarioError;
pub use crate::model::structures::{FilamentElement, FilamentSpec, MembraneSpec, StructuresSpec};

use crate::model::filaments::Filament;
use crate::units::{Length, Pressure, Ratio};

/// Default distance within which a `points` end snaps to the nearest mesh node (µm).
pub const DEFAULT_SNAP_TOLERANCE: f64 = 0.01;
/// Default Poisson's ratio of a beam section (spec: 0.3 where a section needs it).
pub const DEFAULT_BEAM_POISSON_RATIO: f64 = 0.3;

/// `[[filament]]`: a group of two-node line elements of one family, as trusses or beams.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilamentSection {
    /// Name of the group (messages).
    pub name: Spanned<String>,
    /// Family (free name; standard: `actin`, `microtubule`, `intermediate`, `bundle`).
    /// Default: the group's name.
    pub family: Option<Spanned<String>>,
    /// `truss` or `beam`.
    pub element: Spanned<String>,
    /// Node pairs from a line2 element set of the mesh file.
    pub element_set: Option<Spanned<String>>,
    /// Node pairs given as point pairs `[[x, y, z], [x, y, z]]` with units, each snapped to
    /// the nearest mesh node.
    pub points: Option<Spanned<Vec<[[Length; 3]; 2]>>>,
    /// Node pairs as 0-based mesh node indices.
    pub node_pairs: Option<Spanned<Vec<[usize; 2]>>>,
    /// Largest distance from a point to the node it snaps to (default 0.01 µm).
    pub snap_tolerance: Option<Spanned<Length>>,
    /// Young's modulus E.
    pub youngs_modulus: Option<Spanned<Pressure>>,
    /// Outer diameter of the circular section.
    pub diameter: Option<Spanned<Length>>,
    /// Inner diameter of a hollow section (a tube such as a microtubule).
    pub inner_diameter: Option<Spanned<Length>>,
    /// Poisson's ratio of a beam section (default 0.3; shear modulus G = E/(2(1+ν))).
    pub poisson_ratio: Option<Spanned<f64>>,
    /// Trusses: prestrain (`"24%"`): the stress-free length is L0/(1 + prestrain).
    pub prestrain: Option<Spanned<Ratio>>,
    /// Trusses: slack (`"20%"`): no force until the length exceeds (1 + slack) L0.
    pub slack: Option<Spanned<Ratio>>,
    /// Trusses: carry tension only (default false).
    pub tension_only: Option<Spanned<bool>>,
}

/// `[[membrane]]`: a membrane layer (incompressible neo-Hookean, no bending) on a surface.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MembraneSection {
    /// Name of the layer (term name in outputs).
    pub name: Spanned<String>,
    /// Family for `[families.<name>]` switches (default: the layer's name).
    pub family: Option<Spanned<String>>,
    /// `outer`: the boundary faces of all hex8 blocks.
    pub surface: Option<Spanned<String>>,
    /// The boundary faces whose four nodes belong to this node set.
    pub node_set: Option<Spanned<String>>,
    /// Shear modulus G (or give `youngs_modulus`).
    pub shear_modulus: Option<Spanned<Pressure>>,
    /// Young's modulus E; incompressible, so G = E/3.
    pub youngs_modulus: Option<Spanned<Pressure>>,
    /// Reference thickness of the layer.
    pub thickness: Option<Spanned<Length>>,
    /// `elastic` (default: carries compression) or `tension-field` (wrinkles instead).
    pub law: Option<Spanned<String>>,
}

/// `[families.<name>]`: study switches applied to every filament and membrane of a family.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FamilySection {
    /// `false` removes the whole family from the model (default true).
    pub enabled: Option<bool>,
    /// Multiplies the family's Young's and shear moduli (default 1).
    pub modulus_scale: Option<Spanned<f64>>,
    /// Replaces the prestrain of every truss of the family.
    pub prestrain: Option<Spanned<Ratio>>,
}

fn valid_family_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// Resolves the `[[filament]]`, `[[membrane]]` and `[families.*]` sections against `mesh`,
/// adding to the structures a model builder already made (`initial`, e.g. the suspended
/// cell's families; empty for a plain mesh). `text` and `origin` locate errors.
pub fn resolve_structures(
    initial: StructuresSpec,
    filaments: &[FilamentSection],
    membranes: &[MembraneSection],
    families: &BTreeMap<String, Spanned<FamilySection>>,
    mesh: &Mesh,
    text: &str,
    origin: &str,
) -> Result<StructuresSpec, ScenarioError> {
    let ctx = Ctx { origin, text };
    let mut spec = initial;
    // Where each family was first declared, for messages (built-in families: nowhere).
    let mut family_spans: BTreeMap<String, Option<Range<usize>>> = spec
        .filaments
        .iter()
        .map(|f| &f.family)
        .chain(spec.membranes.iter().map(|m| &m.family))
        .map(|f| (f.clone(), None))
        .collect();
    for (i, s) in filaments.iter().enumerate() {
        let f = resolve_filament(&ctx, i, s, mesh)?;
        if spec.filaments.iter().any(|g| g.name == f.name) {
            return Err(ctx.invalid(
                Some(s.name.span()),
                &format!("filament[{i}].name"),
                format!("a filament group named \"{}\" already exists", f.name),
            ));
        }
        let span = s.family.as_ref().map_or(s.name.span(), |f| f.span());
        check_family_consistency(&ctx, i, span.clone(), &f, &spec)?;
        family_spans.entry(f.family.clone()).or_insert(Some(span));
        spec.filaments.push(f);
    }
    for (i, s) in membranes.iter().enumerate() {
        let m = resolve_membrane(&ctx, i, s, mesh)?;
        let span = s.family.as_ref().map_or(s.name.span(), |f| f.span());
        if spec.filaments.iter().any(|f| f.family == m.family) {
            return Err(ctx.invalid(
                Some(span),
                &format!("membrane[{i}].family"),
                format!(
                    "family \"{}\" already holds filaments; a membrane needs a family of its own",
                    m.family
                ),
            ));
        }
        if spec.membranes.iter().any(|o| o.name == m.name) {
            return Err(ctx.invalid(
                Some(s.name.span()),
                &format!("membrane[{i}].name"),
                format!("a membrane named \"{}\" already exists", m.name),
            ));
        }
        family_spans.entry(m.family.clone()).or_insert(Some(span));
        spec.membranes.push(m);
    }
    for (name, section) in families {
        apply_family(&ctx, name, section, &family_spans, &mut spec)?;
    }
    Ok(spec)
}

fn resolve_filament(
    ctx: &Ctx,
    i: usize,
    s: &FilamentSection,
    mesh: &Mesh,
) -> Result<FilamentSpec, ScenarioError> {
    let key = |k: &str| format!("filament[{i}].{k}");
    let name = s.name.get_ref().clone();
    if name.is_empty() {
        return Err(ctx.invalid(
            Some(s.name.span()),
            &key("name"),
            "expected a non-empty name",
        ));
    }
    let family = s
        .family
        .as_ref()
        .map_or_else(|| name.clone(), |f| f.get_ref().clone());
    if !valid_family_name(&family) {
        let span = s.family.as_ref().map_or(s.name.span(), |f| f.span());
        return Err(ctx.invalid(
            Some(span),
            &key("family"),
            format!(
                "a family name (a curve-column prefix) is letters, digits, '_' and '-'; \
                 found \"{family}\""
            ),
        ));
    }
    let pairs = filament_pairs(ctx, i, s, mesh)?;
    let modulus = s.youngs_modulus.as_ref().ok_or_else(|| {
        ctx.invalid(
            Some(s.name.span()),
            &key("youngs_modulus"),
            "a filament needs `youngs_modulus` (e.g. \"2.6 GPa\")",
        )
    })?;
    let e = modulus.get_ref().0;
    if !(e.is_finite() && e > 0.0) {
        return Err(ctx.invalid(
            Some(modulus.span()),
            &key("youngs_modulus"),
            format!("expected a Young's modulus > 0; found {e} kPa"),
        ));
    }
    let diameter = s.diameter.as_ref().ok_or_else(|| {
        ctx.invalid(
            Some(s.name.span()),
            &key("diameter"),
            "a filament needs a section: `diameter` (e.g. \"7 nm\"), and `inner_diameter` for \
             a tube",
        )
    })?;
    let d = diameter.get_ref().0;
    if !(d.is_finite() && d > 0.0) {
        return Err(ctx.invalid(
            Some(diameter.span()),
            &key("diameter"),
            format!("expected a diameter > 0; found {d} µm"),
        ));
    }
    let inner = match &s.inner_diameter {
        None => None,
        Some(inner) => {
            let di = inner.get_ref().0;
            if !(di.is_finite() && di > 0.0 && di < d) {
                return Err(ctx.invalid(
                    Some(inner.span()),
                    &key("inner_diameter"),
                    format!("expected 0 < inner_diameter < diameter = {d} µm; found {di} µm"),
                ));
            }
            Some(di)
        }
    };
    let element = match s.element.get_ref().as_str() {
        "truss" => {
            if let Some(nu) = &s.poisson_ratio {
                return Err(ctx.invalid(
                    Some(nu.span()),
                    &key("poisson_ratio"),
                    "`poisson_ratio` applies to beams only (a truss has no shear)",
                ));
            }
            let area = match inner {
                Some(di) => AxialLaw::hollow_circle_area(d, di),
                None => AxialLaw::solid_circle_area(d),
            };
            let tension_only = s.tension_only.as_ref().is_some_and(|t| *t.get_ref());
            let mut law = if tension_only {
                AxialLaw::tension_only(e, area)
            } else {
                AxialLaw::linear(e, area)
            };
            if let Some(p) = &s.prestrain {
                law.prestrain = p.get_ref().0;
                if !(law.prestrain.is_finite() && law.prestrain > -1.0) {
                    return Err(ctx.invalid(
                        Some(p.span()),
                        &key("prestrain"),
                        format!(
                            "expected a prestrain > -100 % (the stress-free length L0/(1 + p) \
                             must be positive); found {}",
                            law.prestrain
                        ),
                    ));
                }
            }
            if let Some(sl) = &s.slack {
                law.slack = sl.get_ref().0;
                if !(law.slack.is_finite() && law.slack >= 0.0) {
                    return Err(ctx.invalid(
                        Some(sl.span()),
                        &key("slack"),
                        format!("expected a slack >= 0; found {}", law.slack),
                    ));
                }
                if law.slack > 0.0 && !tension_only {
                    return Err(ctx.invalid(
                        Some(sl.span()),
                        &key("slack"),
                        "a slack (wavy) filament carries no compression: add \
                         `tension_only = true`",
                    ));
                }
            }
            law.validate().map_err(|err| {
                ctx.invalid(Some(s.name.span()), &key("element"), err.to_string())
            })?;
            FilamentElement::Truss(law)
        }
        "beam" => {
            for (k, given) in [
                ("prestrain", s.prestrain.as_ref().map(|p| p.span())),
                ("slack", s.slack.as_ref().map(|p| p.span())),
                ("tension_only", s.tension_only.as_ref().map(|p| p.span())),
            ] {
                if let Some(span) = given {
                    return Err(ctx.invalid(
                        Some(span),
                        &key(k),
                        format!("`{k}` applies to trusses only; beams are linear elastic"),
                    ));
                }
            }
            let (nu, nu_span) = match &s.poisson_ratio {
                Some(nu) => (*nu.get_ref(), Some(nu.span())),
                None => (DEFAULT_BEAM_POISSON_RATIO, None),
            };
            if !(nu > -1.0 && nu <= 0.5) {
                return Err(ctx.invalid(
                    nu_span,
                    &key("poisson_ratio"),
                    format!("expected a Poisson's ratio in (-1, 0.5]; found {nu}"),
                ));
            }
            let section = match inner {
                Some(di) => BeamSection::hollow_circular(e, nu, d, di),
                None => BeamSection::solid_circular(e, nu, d),
            }
            .map_err(|err| ctx.invalid(Some(diameter.span()), &key("diameter"), err.to_string()))?;
            FilamentElement::Beam(section)
        }
        other => {
            return Err(ctx.invalid(
                Some(s.element.span()),
                &key("element"),
                format!("expected \"truss\" or \"beam\"; found \"{other}\""),
            ))
        }
    };
    Ok(FilamentSpec {
        name,
        family,
        filaments: Filament::chains(&pairs),
        pairs,
        element,
        enabled: true,
    })
}

/// The node pairs of a filament group from exactly one of its three sources.
fn filament_pairs(
    ctx: &Ctx,
    i: usize,
    s: &FilamentSection,
    mesh: &Mesh,
) -> Result<Vec<[usize; 2]>, ScenarioError> {
    let key = |k: &str| format!("filament[{i}].{k}");
    let given = [
        s.element_set.is_some(),
        s.points.is_some(),
        s.node_pairs.is_some(),
    ];
    if given.iter().filter(|&&g| g).count() != 1 {
        return Err(ctx.invalid(
            Some(s.name.span()),
            &key("element_set"),
            format!(
                "give exactly one of `element_set` (a line2 set of the mesh file), `points` \
                 or `node_pairs`; found {}",
                given.iter().filter(|&&g| g).count()
            ),
        ));
    }
    if s.snap_tolerance.is_some() && s.points.is_none() {
        let span = s.snap_tolerance.as_ref().map(|t| t.span());
        return Err(ctx.invalid(
            span,
            &key("snap_tolerance"),
            "`snap_tolerance` applies to `points` only",
        ));
    }
    let n = mesh.num_nodes();
    let (pairs, span, source) = if let Some(set) = &s.element_set {
        let name = set.get_ref();
        let block = mesh.block(name).ok_or_else(|| {
            let known: Vec<&str> = mesh.blocks.iter().map(|b| b.name.as_str()).collect();
            ctx.invalid(
                Some(set.span()),
                &key("element_set"),
                format!("no element set \"{name}\" in the mesh; it has {known:?}"),
            )
        })?;
        if block.kind != ElementKind::Line2 {
            return Err(ctx.invalid(
                Some(set.span()),
                &key("element_set"),
                format!(
                    "element set \"{name}\" holds {} elements; a filament needs line2 elements",
                    block.kind.name()
                ),
            ));
        }
        let pairs: Vec<[usize; 2]> = block.elements().map(|e| [e[0], e[1]]).collect();
        (pairs, set.span(), "element_set")
    } else if let Some(points) = &s.points {
        let tol = match &s.snap_tolerance {
            Some(t) if !(t.get_ref().0 >= 0.0) => {
                return Err(ctx.invalid(
                    Some(t.span()),
                    &key("snap_tolerance"),
                    format!("expected a distance >= 0; found {} µm", t.get_ref().0),
                ))
            }
            Some(t) => t.get_ref().0,
            None => DEFAULT_SNAP_TOLERANCE,
        };
        let mut pairs = Vec::with_capacity(points.get_ref().len());
        for (j, pair) in points.get_ref().iter().enumerate() {
            let mut ends = [0usize; 2];
            for (end, point) in pair.iter().enumerate() {
                let p = point.map(|l| l.0);
                if !p.iter().all(|c| c.is_finite() && c.abs() < 1e12) {
                    return Err(ctx.invalid(
                        Some(points.span()),
                        &key(&format!("points[{j}][{end}]")),
                        format!(
                            "expected a point with finite coordinates within the model; found ({}, {}, {}) µm",
                            p[0], p[1], p[2]
                        ),
                    ));
                }
                let (node, dist) = nearest_node(mesh, p);
                if mesh.nodes.is_empty() {
                    return Err(ctx.invalid(
                        Some(points.span()),
                        &key(&format!("points[{j}][{end}]")),
                        "the mesh has no nodes to attach the filament to",
                    ));
                }
                if !(dist <= tol) {
                    return Err(ctx.invalid(
                        Some(points.span()),
                        &key(&format!("points[{j}][{end}]")),
                        format!(
                            "point ({}, {}, {}) µm is {dist:.4} µm from the nearest mesh node \
                             ({node}); expected a node within snap_tolerance = {tol} µm",
                            p[0], p[1], p[2]
                        ),
                    ));
                }
                ends[end] = node;
            }
            pairs.push(ends);
        }
        (pairs, points.span(), "points")
    } else if let Some(np) = &s.node_pairs {
        (np.get_ref().clone(), np.span(), "node_pairs")
    } else {
        // Unreachable: exactly one source was checked above.
        (Vec::new(), s.name.span(), "node_pairs")
    };
    if pairs.is_empty() {
        return Err(ctx.invalid(
            Some(span),
            &key(source),
            "expected at least one element; found none",
        ));
    }
    for (e, &[a, b]) in pairs.iter().enumerate() {
        if let Some(&bad) = [a, b].iter().find(|&&x| x >= n) {
            return Err(ctx.invalid(
                Some(span),
                &key(source),
                format!("element {e}: node {bad} does not exist (the mesh has {n} nodes)"),
            ));
        }
        let (xa, xb) = (mesh.nodes[a], mesh.nodes[b]);
        let length = (0..3).map(|k| (xb[k] - xa[k]).powi(2)).sum::<f64>().sqrt();
        if !(length > 0.0) {
            return Err(ctx.invalid(
                Some(span),
                &key(source),
                format!(
                    "element {e}: both ends are mesh node {a} (or coincide); a filament needs \
                     two distinct nodes"
                ),
            ));
        }
    }
    Ok(pairs)
}

/// The mesh node nearest to `p` and its distance (µm).
fn nearest_node(mesh: &Mesh, p: [f64; 3]) -> (usize, f64) {
    let mut best = (usize::MAX, f64::INFINITY);
    for (n, x) in mesh.nodes.iter().enumerate() {
        let d2 = (0..3).map(|k| (x[k] - p[k]).powi(2)).sum::<f64>();
        if d2 < best.1 {
            best = (n, d2);
        }
    }
    (best.0, best.1.sqrt())
}

/// A family is either trusses or beams, and all beams of a family share one section (one
/// engine set per family, so one set of curve columns).
fn check_family_consistency(
    ctx: &Ctx,
    i: usize,
    span: Range<usize>,
    f: &FilamentSpec,
    spec: &StructuresSpec,
) -> Result<(), ScenarioError> {
    for other in spec.filaments.iter().filter(|o| o.family == f.family) {
        let problem = match (&other.element, &f.element) {
            (FilamentElement::Truss(_), FilamentElement::Beam(_))
            | (FilamentElement::Beam(_), FilamentElement::Truss(_)) => {
                "mixes trusses and beams; give each kind its own family"
            }
            (FilamentElement::Beam(a), FilamentElement::Beam(b)) if a != b => {
                "has beams with different sections; all beams of a family share one section"
            }
            _ => continue,
        };
        return Err(ctx.invalid(
            Some(span),
            &format!("filament[{i}].family"),
            format!(
                "family \"{}\" {problem} (also used by filament group \"{}\")",
                f.family, other.name
            ),
        ));
    }
    Ok(())
}

fn resolve_membrane(
    ctx: &Ctx,
    i: usize,
    s: &MembraneSection,
    mesh: &Mesh,
) -> Result<MembraneSpec, ScenarioError> {
    let key = |k: &str| format!("membrane[{i}].{k}");
    let name = s.name.get_ref().clone();
    let family = s
        .family
        .as_ref()
        .map_or_else(|| name.clone(), |f| f.get_ref().clone());
    if !valid_family_name(&family) {
        let span = s.family.as_ref().map_or(s.name.span(), |f| f.span());
        return Err(ctx.invalid(
            Some(span),
            &key("family"),
            format!("a family name is letters, digits, '_' and '-'; found \"{family}\""),
        ));
    }
    let faces = match (&s.surface, &s.node_set) {
        (Some(surface), None) => {
            if surface.get_ref() != "outer" {
                return Err(ctx.invalid(
                    Some(surface.span()),
                    &key("surface"),
                    format!(
                        "expected \"outer\" (or give `node_set`); found \"{}\"",
                        surface.get_ref()
                    ),
                ));
            }
            boundary_quads(mesh, None)
                .map_err(|e| ctx.invalid(Some(surface.span()), &key("surface"), e.to_string()))?
        }
        (None, Some(set)) => {
            if !mesh.node_sets.contains_key(set.get_ref()) {
                let known: Vec<&str> = mesh.node_sets.keys().map(String::as_str).collect();
                return Err(ctx.invalid(
                    Some(set.span()),
                    &key("node_set"),
                    format!(
                        "no node set \"{}\" in the mesh; it has {known:?}",
                        set.get_ref()
                    ),
                ));
            }
            faces_on_node_set(mesh, set.get_ref())
                .map_err(|e| ctx.invalid(Some(set.span()), &key("node_set"), e.to_string()))?
        }
        _ => {
            return Err(ctx.invalid(
                Some(s.name.span()),
                &key("surface"),
                "give exactly one of `surface = \"outer\"` or `node_set = \"...\"`",
            ))
        }
    };
    if faces.is_empty() {
        return Err(ctx.invalid(
            Some(s.name.span()),
            &key("surface"),
            "the surface has no boundary quad faces of hex8 elements; found none",
        ));
    }
    let shear_modulus = match (&s.shear_modulus, &s.youngs_modulus) {
        (Some(g), None) => (g.get_ref().0, g.span()),
        (None, Some(e)) => (e.get_ref().0 / 3.0, e.span()),
        (Some(g), Some(_)) => {
            return Err(ctx.invalid(
                Some(g.span()),
                &key("shear_modulus"),
                "give `shear_modulus` or `youngs_modulus` (E = 3G), not both",
            ))
        }
        (None, None) => {
            return Err(ctx.invalid(
                Some(s.name.span()),
                &key("shear_modulus"),
                "a membrane needs `shear_modulus` (or `youngs_modulus`, E = 3G)",
            ))
        }
    };
    if !(shear_modulus.0.is_finite() && shear_modulus.0 > 0.0) {
        return Err(ctx.invalid(
            Some(shear_modulus.1),
            &key("shear_modulus"),
            format!("expected a modulus > 0; found G = {} kPa", shear_modulus.0),
        ));
    }
    let thickness = s.thickness.as_ref().ok_or_else(|| {
        ctx.invalid(
            Some(s.name.span()),
            &key("thickness"),
            "a membrane needs `thickness` (e.g. \"10 nm\")",
        )
    })?;
    let h = thickness.get_ref().0;
    if !(h.is_finite() && h > 0.0) {
        return Err(ctx.invalid(
            Some(thickness.span()),
            &key("thickness"),
            format!("expected a thickness > 0; found {h} µm"),
        ));
    }
    let law = match s.law.as_ref().map(|l| (l.get_ref().as_str(), l.span())) {
        None | Some(("elastic", _)) => crate::model::structures::MembraneLaw::Elastic,
        Some(("tension-field", _)) => crate::model::structures::MembraneLaw::TensionField,
        Some((other, span)) => {
            return Err(ctx.invalid(
                Some(span),
                &key("law"),
                format!("expected \"elastic\" or \"tension-field\"; found \"{other}\""),
            ))
        }
    };
    Ok(MembraneSpec {
        name,
        family,
        faces,
        shear_modulus: shear_modulus.0,
        thickness: h,
        law,
        enabled: true,
    })
}

fn apply_family(
    ctx: &Ctx,
    name: &str,
    section: &Spanned<FamilySection>,
    known: &BTreeMap<String, Option<Range<usize>>>,
    spec: &mut StructuresSpec,
) -> Result<(), ScenarioError> {
    let key = |k: &str| format!("families.{name}.{k}");
    let span = Some(section.span());
    if !known.contains_key(name) {
        let names: Vec<&str> = known.keys().map(String::as_str).collect();
        return Err(ctx.invalid(
            span,
            &format!("families.{name}"),
            format!(
                "no filament or membrane belongs to family \"{name}\"; the families are {names:?}"
            ),
        ));
    }
    let s = section.get_ref();
    let enabled = s.enabled.unwrap_or(true);
    let scale = match &s.modulus_scale {
        None => 1.0,
        Some(f) => {
            let v = *f.get_ref();
            if !(v.is_finite() && v > 0.0) {
                return Err(ctx.invalid(
                    Some(f.span()),
                    &key("modulus_scale"),
                    format!("expected a factor > 0 (e.g. 0.5 or 1.5); found {v}"),
                ));
            }
            v
        }
    };
    let prestrain = match &s.prestrain {
        None => None,
        Some(p) => {
            let v = p.get_ref().0;
            if !(v.is_finite() && v > -1.0) {
                return Err(ctx.invalid(
                    Some(p.span()),
                    &key("prestrain"),
                    format!("expected a prestrain > -100 %; found {v}"),
                ));
            }
            let not_truss = spec.membranes.iter().any(|m| m.family == name)
                || spec
                    .filaments
                    .iter()
                    .any(|f| f.family == name && matches!(f.element, FilamentElement::Beam(_)));
            if not_truss {
                return Err(ctx.invalid(
                    Some(p.span()),
                    &key("prestrain"),
                    format!(
                        "family \"{name}\" is not made of trusses; a prestrain applies to trusses only"
                    ),
                ));
            }
            Some(v)
        }
    };
    for f in spec.filaments.iter_mut().filter(|f| f.family == name) {
        f.enabled = enabled;
        match &mut f.element {
            FilamentElement::Truss(law) => {
                law.youngs_modulus *= scale;
                if let Some(p) = prestrain {
                    law.prestrain = p;
                }
            }
            FilamentElement::Beam(sec) => {
                sec.youngs_modulus *= scale;
                sec.shear_modulus *= scale;
            }
        }
    }
    for m in spec.membranes.iter_mut().filter(|m| m.family == name) {
        m.enabled = enabled;
        m.shear_modulus *= scale;
    }
    Ok(())
}
