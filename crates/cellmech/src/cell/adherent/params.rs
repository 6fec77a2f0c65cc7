//! The declared parameters of the adherent cell (`[cell]` with `model = "adherent"`): one
//! line per parameter, the defaults of [`AdherentCellParams`] and
//! [`AdherentCellMaterials`]. Sources: `shared/spec/cell-models.md` ("Adherent cell");
//! "choice" marks a documented modelling or numerical choice (`docs/adherent-cell.md`).
//! Parameters the suspended cell declares the same way (cytoplasm, nucleus, MTs, IFs,
//! coupling, solver) are shared with its table.

use crate::param::{Bounds, ParamDefault as D, ParamKind as K, ParamTable, ParamValues};
use crate::units::Dimension::{Dimensionless, Length, Pressure};

use super::geometry::{AdherentMeshResolution, AdherentShape};
use super::layout::{AdherentCellParams, LocalRefinement};
use super::AdherentCellMaterials;
use crate::cell::suspended::params::{self as shared, p};
use crate::cell::suspended::ActinMaterial;
use crate::cell::suspended::MAX_MT_BOW;

const POS: Bounds = Bounds::POSITIVE;
const NONNEG: Bounds = Bounds::NON_NEGATIVE;
const ANY: Bounds = Bounds::ANY;
const MESH_COUNT: Bounds = Bounds::new(1.0, true, 64.0, true);
const SPEC: &str = "spec";
const CHOICE: &str = "choice";

/// Every parameter of the adherent cell.
pub const ADHERENT_CELL: ParamTable = ParamTable {
    name: "adherent-cell",
    section: "cell",
    params: &[
        p("semi_axes", K::QuantityList(Length), D::List(&[19.0, 12.66, 8.0]), POS, "half length, half width and height of the half-ellipsoid", SPEC),
        p("nucleus.semi_axes", K::QuantityList(Length), D::List(&[2.5, 2.5, 1.5]), POS, "nucleus semi-axes (x, y, height)", SPEC),
        p("nucleus.height", K::Quantity(Length), D::Number(2.0), POS, "height of the nucleus centre above the substrate (centred in the top view)", SPEC),
        p("seed", K::Seed, D::Seed(2024), ANY, "seed of every random choice (MT bows, the extra ABs of `bundles.extra`)", CHOICE),
        p("mesh.core_divisions", K::Count, D::Count(8), MESH_COUNT, "elements along the reference cube's edge (even); the base mesh has core³ + 6 core² (shell + outer) hex8", "choice ([adherent cell](adherent-cell.md#mesh))"),
        p("mesh.shell_layers", K::Count, D::Count(3), MESH_COUNT, "radial layers inside the nucleus surface", CHOICE),
        p("mesh.outer_layers", K::Count, D::Count(3), MESH_COUNT, "radial layers of cytoplasm from the nucleus to the cell surface", CHOICE),
        p("refinement.element_size", K::Quantity(Length), D::Number(0.05), POS, "largest element edge wanted at the indentation site; the octree halves the base elements (up to `max_levels` times), so at the apex, under base elements of up to 3.4 µm, 0.05 gives 0.053 µm (6 levels)", "choice, measured ([adherent cell](adherent-cell.md#how-deep-the-tip-gets-2026-12-05-ninth-session)): graded from the site, the 200 nm tip reaches 1.75 µm with a smooth curve where 0.15 µm within 0.6 µm stalled near 1.1 µm, at the same size (11 944 against 10 712 hex8)"),
        p("refinement.fine_radius", K::Quantity(Length), D::Number(0.0), NONNEG, "radius around the site kept at the finest size (0: the size grows from the site on)", CHOICE),
        p("refinement.grading", K::Number, D::Number(0.5), POS, "growth of the element size with distance beyond the fine radius (size ≤ grading × distance), over `graded_width`: the tip's circumferential curvature is 1/r at distance r from its axis, and a coarser grading lets the contact nodes there slide round the tip", "choice, measured ([adherent cell](adherent-cell.md#how-deep-the-tip-gets-2026-12-05-ninth-session))"),
        p("refinement.graded_width", K::Quantity(Length), D::Number(1000.0), NONNEG, "width of the band beyond the fine radius in which the element size grows with slope `grading`; beyond it the slope is `far_grading`", CHOICE),
        p("refinement.far_grading", K::Number, D::Number(1.0), POS, "growth of the element size with distance beyond fine_radius + graded_width", CHOICE),
        p("refinement.max_levels", K::Count, D::Count(6), Bounds::new(0.0, true, 10.0, true), "most octree levels of splitting at the site (each halves the base element, whose edge under the apex is up to 3.4 µm); an `element_size` it leaves more than twice too coarse is an error (0.025 µm needs 7, 0.0125 µm needs 8)", CHOICE),
        shared::CYTOPLASM_SHEAR_MODULUS,
        shared::CYTOPLASM_POISSON_RATIO,
        shared::NUCLEUS_SHEAR_MODULUS,
        shared::NUCLEUS_POISSON_RATIO,
        p("cortex.youngs_modulus", K::Quantity(Pressure), D::Number(2.0), POS, "actin cortex (AC) Young's modulus (incompressible membrane, G = E/3)", "spec (AC)"),
        p("cortex.thickness", K::Quantity(Length), D::Number(0.2), POS, "actin cortex thickness (membrane on the free surface, no bending)", SPEC),
        p("cortex.law", K::Choice(&["elastic", "tension-field"]), D::Word("tension-field"), crate::param::Bounds::ANY, "how the cortex answers in-plane compression: `tension-field` wrinkles instead (no compressive stress); `elastic` carries it", "choice since 2026-12-04: a membrane without bending stiffness that carries compression wrinkles at the element scale on a refined mesh, and the prestress does not converge on the 0.1 um apex mesh; with `tension-field` it converges in 3-5 Newton iterations per increment ([adherent cell](adherent-cell.md#the-cortex-law))"),
        p("bundles.count", K::Count, D::Count(8), Bounds::new(1.0, true, 64.0, true), "actin bundles (ABs), each between two FAs, along the long axis", "choice (spec: \"roughly uniformly\")"),
        p("bundles.height", K::Quantity(Length), D::Number(4.0), POS, "height of the ABs and their FAs above the substrate", "choice ([adherent cell](adherent-cell.md#cytoskeleton))"),
        p("bundles.spread", K::Quantity(Dimensionless), D::Number(0.8), Bounds::new(0.0, false, 1.0, false), "fraction of the dome's half width at that height the ABs span", CHOICE),
        p("bundles.extra", K::Count, D::Count(0), Bounds::new(0.0, true, crate::cell::suspended::density::MAX_EXTRA_FILAMENTS as f64, true), "density variant: extra ABs (same material and prestrain) between seeded random pairs of dome nodes away from the FAs (each node once, with a plaque like an FA's), at the periphery or through the interior, clear of the nucleus", "spec (\"Studies\": density)"),
        p("bundles.youngs_modulus", K::Quantity(Pressure), D::Number(340.0), POS, "actin bundle Young's modulus", "spec (EA = 16.7 nN)"),
        p("bundles.diameter", K::Quantity(Length), D::Number(0.25), POS, "actin bundle diameter", SPEC),
        p("bundles.prestrain", K::Quantity(Dimensionless), D::Number(0.24), Bounds::new(-1.0, false, f64::INFINITY, false), "actin bundle prestrain (tension-only trusses)", SPEC),
        p("bundles.fa_radius", K::Quantity(Length), D::Number(0.5), NONNEG, "radius of an FA plaque: the dome nodes within it carry the FA's filaments, as `fa_coupling` says (0: one node)", "choice (spec suspended cell: \"an FA may be a small patch of surface nodes tied together\")"),
        p("bundles.fa_coupling", K::Choice(&["rigid", "distributing", "distributing-linear"]), D::Word("rigid"), ANY, "how an FA's plaque carries its filaments' pull: `rigid`, every plaque node moves with the FA node (a rigid disc, Abaqus kinematic coupling); `distributing`, the FA node moves with the plaque nodes' mean and its load is shared among them equally (Abaqus distributing coupling), so the plaque deforms with the cortex; `distributing-linear`, the same with weights falling linearly to zero at the plaque's rim, times each node's surface area (a traction that does not change with the mesh)", "choice ([adherent cell](adherent-cell.md#fa-plaques-rigid-or-distributing-2026-12-05-eleventh-session): under the AFM tip the rigid plaque acts as a flat punch)"),
        p("bundles.fa_reference", K::Choice(&["fa-node", "separate"]), D::Word("fa-node"), ANY, "with a distributing `fa_coupling`: where the FA's filaments end and the coupling's reference point is: the FA mesh node, which then moves with the plaque's weighted mean while it is still a corner of the elements around it, or a separate node at the plaque's weighted centroid, tied to the plaque nodes and the FA node (which stays a free surface node), as a commercial code's distributing coupling has its own reference node (at the centroid the tie follows rigid rotations exactly; since stop 49, before at the FA node)", "choice ([adherent cell](adherent-cell.md): with the FA node as reference the receptor folds in the prestress)"),
        p("receptor", K::Count, D::Absent("the FA farthest from the nucleus centre"), Bounds::new(0.0, true, 127.0, true), "index of the FA indented by `site = \"receptor\"` (FA 2k and 2k + 1 end AB k)", "spec (\"an FA away from the nucleus\")"),
        shared::MICROTUBULES_YOUNGS_MODULUS,
        shared::MICROTUBULES_OUTER_DIAMETER,
        shared::MICROTUBULES_INNER_DIAMETER,
        shared::MICROTUBULES_POISSON_RATIO,
        shared::MICROTUBULES_ELEMENTS,
        p("microtubules.bow_min", K::Quantity(Dimensionless), D::Number(0.25), Bounds::new(0.0, true, MAX_MT_BOW, true), "smallest sideways bow at mid-length, fraction of the chord", "choice (bows of 5-20 % make the prestress take 92 Newton iterations instead of 31: docs/adherent-cell.md)"),
        p("microtubules.bow_max", K::Quantity(Dimensionless), D::Number(0.45), Bounds::new(0.0, true, MAX_MT_BOW, true), "largest bow, fraction of the chord", CHOICE),
        p("microtubules.extra", K::Count, D::Count(0), Bounds::new(0.0, true, crate::cell::suspended::density::MAX_EXTRA_FILAMENTS as f64, true), "density variant: extra MTs (same section and routing as the FA MTs: the chord from the centrosome bowed sideways by a seeded bow in the same range) to seeded random dome nodes that are not FAs, lie farther than two plaque radii from every FA and end no extra AB; one MT per node, a node whose MT would leave the cell or pass closer to the nucleus than the clearance margin is skipped", "spec (\"more MTs from the centrosome to seeded random surface nodes\"; [adherent cell](adherent-cell.md#density-more-abs-mts-or-ifs))"),
        shared::MICROTUBULES_CLEARANCE_MARGIN,
        p("microtubules.centrosome_gap", K::Quantity(Length), D::Number(0.5), POS, "distance of the centrosome from the nucleus surface", "choice (\"near the nucleus\")"),
        p("microtubules.centrosome_direction", K::Vector3, D::Vector3([0.0, 0.0, 1.0]), ANY, "direction of the centrosome from the nucleus centre", CHOICE),
        p("microtubules.coupling", K::Choice(&["free", "embedded", "foundation"]), D::Word("free"), ANY, "MT interior nodes: free (only the beams hold them), embedded in the cytoplasm/nucleus they lie in, or on an elastic foundation (tied to their material points by springs of `foundation_modulus` × their length of MT)", "choice ([adherent cell](adherent-cell.md#coupling): embedded MTs stall the prestress)"),
        shared::MICROTUBULES_FOUNDATION_MODULUS,
        shared::MICROTUBULES_EMBEDDED_NODES,
        p("microtubules.centrosome", K::Choice(&["free", "tied"]), D::Word("tied"), ANY, "centrosome node: free, or tied to the cytoplasm where it sits", "choice, measured ([adherent cell](adherent-cell.md#the-centrosome-tied-by-default-2026-12-06): a free centrosome held by the 16 MTs the prestress compresses is an unstable equilibrium, one negative pivot at every converged state; tied, none, and the apex force is the same to 5 digits)"),
        shared::MICROTUBULES_CENTROSOME_RADIUS,
        p("microtubules.stress_free", K::Choice(&["unstressed-cell", "prestressed-cell"]), D::Word("unstressed-cell"), ANY, "where the MTs are stress-free: in the unstressed cell (the mesh) or in the prestressed cell (their stress-free shape is the mesh shape carried by the prestress's contraction of the gel, recorded in a first pass without them)", "choice ([adherent cell](adherent-cell.md#coupling): with the elastic cortex the first pass, the cell without MTs, does not reach a prestressed equilibrium, and the analysis fails)"),
        shared::SOLVER_STABILIZATION,
        shared::SOLVER_DAMPING,
        shared::SOLVER_ITERATION,
        shared::SOLVER_BFGS_UPDATES,
        shared::SOLVER_RELAXATION,
        shared::SOLVER_CHORD,
        shared::SOLVER_ROTATION_STEP,
        shared::SOLVER_RESIDUAL_TOLERANCE,
        shared::SOLVER_ENERGY_TOLERANCE,
        shared::INTERMEDIATE_YOUNGS_MODULUS,
        shared::INTERMEDIATE_DIAMETER,
        shared::INTERMEDIATE_SLACK,
        shared::INTERMEDIATE_PER_FA,
        p("intermediate.extra", K::Count, D::Count(0), Bounds::new(0.0, true, crate::cell::suspended::density::MAX_EXTRA_FILAMENTS as f64, true), "density variant: extra IFs (same material and slack) from seeded random dome nodes (not FAs, farther than two plaque radii from every FA, no extra AB or MT end) to nucleus-surface nodes they see past the nucleus, at new orientations; each node used once at either end", "spec (\"more AFs/IFs in the cell interior at new orientations\"; [adherent cell](adherent-cell.md#density-more-abs-mts-or-ifs))"),
        shared::INTERMEDIATE_PHASE_DEG,
        shared::INTERMEDIATE_ANCHOR,
    ],
};

/// Three values of a list parameter (the reader checks the unit; the count is checked here
/// by the builder through [`AdherentShape::validate`]).
fn triple(v: &ParamValues, key: &str) -> [f64; 3] {
    let l = v.list(key);
    [0, 1, 2].map(|i| l.get(i).copied().unwrap_or(f64::NAN))
}

/// Geometry and materials from resolved values of [`ADHERENT_CELL`].
pub fn from_values(v: &ParamValues) -> (AdherentCellParams, AdherentCellMaterials) {
    let params = AdherentCellParams {
        shape: AdherentShape {
            semi_axes: triple(v, "semi_axes"),
            nucleus_semi_axes: triple(v, "nucleus.semi_axes"),
            nucleus_height: v.number("nucleus.height"),
        },
        mesh: AdherentMeshResolution {
            core_divisions: v.count("mesh.core_divisions"),
            shell_layers: v.count("mesh.shell_layers"),
            outer_layers: v.count("mesh.outer_layers"),
        },
        refinement: LocalRefinement {
            element_size: v.number("refinement.element_size"),
            fine_radius: v.number("refinement.fine_radius"),
            grading: v.number("refinement.grading"),
            graded_width: v.number("refinement.graded_width"),
            far_grading: v.number("refinement.far_grading"),
            max_levels: v.count("refinement.max_levels") as u8,
        },
        bundles: v.count("bundles.count"),
        extra_bundles: v.count("bundles.extra"),
        extra_microtubules: v.count("microtubules.extra"),
        extra_intermediate: v.count("intermediate.extra"),
        bundle_height: v.number("bundles.height"),
        bundle_spread: v.number("bundles.spread"),
        receptor: v.optional_count("receptor"),
        fa_radius: v.number("bundles.fa_radius"),
        fa_coupling: match v.word("bundles.fa_coupling") {
            "distributing" => super::layout::FaCoupling::Distributing,
            "distributing-linear" => super::layout::FaCoupling::DistributingLinear,
            _ => super::layout::FaCoupling::Rigid,
        },
        fa_reference: match v.word("bundles.fa_reference") {
            "separate" => crate::cell::fa_plaque::FaReference::Separate,
            _ => crate::cell::fa_plaque::FaReference::FaNode,
        },
        mt_elements: shared::mt_elements_from_values(v),
        mt_bow_min: v.number("microtubules.bow_min"),
        mt_bow_max: v.number("microtubules.bow_max"),
        mt_clearance_margin: v.number("microtubules.clearance_margin"),
        centrosome_gap: v.number("microtubules.centrosome_gap"),
        centrosome_direction: v.vector3("microtubules.centrosome_direction"),
        ifs_per_fa: v.count("intermediate.per_fa"),
        if_phase: v.number("intermediate.phase_deg").to_radians(),
        if_anchor_rule: shared::if_anchor_rule_from_values(v),
        seed: v.seed("seed"),
    };
    let materials = AdherentCellMaterials {
        cytoplasm_shear_modulus: v.number("cytoplasm.shear_modulus"),
        cytoplasm_poisson_ratio: v.number("cytoplasm.poisson_ratio"),
        nucleus_shear_modulus: v.number("nucleus.shear_modulus"),
        nucleus_poisson_ratio: v.number("nucleus.poisson_ratio"),
        cortex_shear_modulus: v.number("cortex.youngs_modulus") / 3.0,
        cortex_thickness: v.number("cortex.thickness"),
        cortex_law: crate::cell::suspended::params::membrane_law(v.word("cortex.law")),
        bundle: ActinMaterial {
            youngs_modulus: v.number("bundles.youngs_modulus"),
            diameter: v.number("bundles.diameter"),
            prestrain: v.number("bundles.prestrain"),
        },
        microtubule: shared::microtubule_from_values(v),
        intermediate: shared::intermediate_from_values(v),
    };
    (params, materials)
}

/// The defaults of the table.
pub fn defaults() -> (AdherentCellParams, AdherentCellMaterials) {
    from_values(&ParamValues::defaults(&ADHERENT_CELL))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_spec_values() {
        let (p, m) = defaults();
        assert_eq!(p.shape.semi_axes, [19.0, 12.66, 8.0]);
        assert_eq!(p.shape.nucleus_semi_axes, [2.5, 2.5, 1.5]);
        assert_eq!(p.shape.nucleus_height, 2.0);
        assert!((m.cortex_shear_modulus - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(m.cortex_thickness, 0.2);
        // EA(AB) = 16.7 nN.
        let ea = m.bundle.youngs_modulus * std::f64::consts::PI * 0.25 * m.bundle.diameter.powi(2);
        assert!((ea - 16.69).abs() < 0.01, "EA {ea}");
        assert_eq!(m.bundle.prestrain, 0.24);
        assert_eq!(m.cytoplasm_shear_modulus, 0.17);
    }
}
