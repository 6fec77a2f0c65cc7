//! The declared parameters of the suspended cell (`[cell]` with `model = "suspended"`):
//! one line per parameter. The defaults of [`SuspendedCellParams`] and
//! [`SuspendedCellMaterials`] come from this table, the scenario parser reads `[cell]`
//! against it, and `docs/suspended-cell.md` shows the table generated from it (a test
//! fails when they differ). Sources: `shared/spec/cell-models.md` ("Suspended cell");
//! "choice" marks a documented modelling or numerical choice (docs/suspended-cell.md).

use crate::param::{Bounds, ParamDef, ParamDefault as D, ParamKind as K, ParamTable, ParamValues};
use crate::units::Dimension::{Dimensionless, Length, Pressure};
use cellmech_fem::solve::{Activation, Damping, IterationMethod, Stabilization};

use super::cytoskeleton::IfAnchorRule;
use super::density::{DensityParams, MAX_EXTRA_FILAMENTS};
use super::geometry::FaOrientation;
use super::layout::{
    MeshResolution, SuspendedCellParams, MAX_IFS_PER_FA, MAX_MT_BOW, MAX_MT_ELEMENTS,
    MAX_ORIENTATION_TRIALS,
};
use super::materials::{
    ActinMaterial, IntermediateMaterial, MicrotubuleMaterial, SuspendedCellMaterials,
};

/// A parameter definition in one line (the tables' rows).
pub(crate) const fn p(
    key: &'static str,
    kind: K,
    default: D,
    bounds: Bounds,
    doc: &'static str,
    source: &'static str,
) -> ParamDef {
    ParamDef {
        key,
        kind,
        default,
        bounds,
        doc,
        source,
    }
}

const POS: Bounds = Bounds::POSITIVE;
const NONNEG: Bounds = Bounds::NON_NEGATIVE;
const ANY: Bounds = Bounds::ANY;
/// Mesh counts: at least 1, at most 64 (64 core divisions with 64 + 64 layers is ~3.4 million
/// hex8, beyond what one machine solves; larger values are typos).
const MESH_COUNT: Bounds = Bounds::new(1.0, true, 64.0, true);
/// Extra filaments of the density variant (the mesh limits the count further).
const EXTRA: Bounds = Bounds::new(0.0, true, MAX_EXTRA_FILAMENTS as f64, true);
const POISSON: Bounds = Bounds::new(-1.0, false, 0.5, false);
/// A relative convergence tolerance: in (0, 1).
const TOLERANCE: Bounds = Bounds::new(0.0, false, 1.0, false);
const SPEC: &str = "spec";
const CHOICE: &str = "choice";

// Parameters the adherent cell declares the same way.
/// `cytoplasm.shear_modulus` (shared by the cell models).
pub(crate) const CYTOPLASM_SHEAR_MODULUS: ParamDef = p(
    "cytoplasm.shear_modulus",
    K::Quantity(Pressure),
    D::Number(0.17),
    POS,
    "cytoplasm shear modulus G (neo-Hookean)",
    "spec (E = 0.5 kPa)",
);
/// `cytoplasm.poisson_ratio` (shared by the cell models).
pub(crate) const CYTOPLASM_POISSON_RATIO: ParamDef = p(
    "cytoplasm.poisson_ratio",
    K::Number,
    D::Number(0.49),
    POISSON,
    "cytoplasm Poisson's ratio (compressibility)",
    "spec (a parameter, as the spec asks)",
);
/// `nucleus.shear_modulus` (shared by the cell models).
pub(crate) const NUCLEUS_SHEAR_MODULUS: ParamDef = p(
    "nucleus.shear_modulus",
    K::Quantity(Pressure),
    D::Number(1.7),
    POS,
    "nucleus shear modulus G",
    "spec (E = 5 kPa)",
);
/// `nucleus.poisson_ratio` (shared by the cell models).
pub(crate) const NUCLEUS_POISSON_RATIO: ParamDef = p(
    "nucleus.poisson_ratio",
    K::Number,
    D::Number(0.49),
    POISSON,
    "nucleus Poisson's ratio",
    SPEC,
);
/// `microtubules.youngs_modulus` (shared by the cell models).
pub(crate) const MICROTUBULES_YOUNGS_MODULUS: ParamDef = p(
    "microtubules.youngs_modulus",
    K::Quantity(Pressure),
    D::Number(1.2e6),
    POS,
    "microtubule Young's modulus",
    "spec (EA = 317 nN, EI = 0.018 nN·µm²)",
);
/// `microtubules.outer_diameter` (shared by the cell models).
pub(crate) const MICROTUBULES_OUTER_DIAMETER: ParamDef = p(
    "microtubules.outer_diameter",
    K::Quantity(Length),
    D::Number(0.025),
    POS,
    "microtubule outer diameter (hollow)",
    SPEC,
);
/// `microtubules.inner_diameter` (shared by the cell models).
pub(crate) const MICROTUBULES_INNER_DIAMETER: ParamDef = p(
    "microtubules.inner_diameter",
    K::Quantity(Length),
    D::Number(0.017),
    POS,
    "microtubule inner diameter",
    SPEC,
);
/// `microtubules.poisson_ratio` (shared by the cell models).
pub(crate) const MICROTUBULES_POISSON_RATIO: ParamDef = p(
    "microtubules.poisson_ratio",
    K::Number,
    D::Number(0.3),
    POISSON,
    "Poisson's ratio of the MT section (its shear modulus)",
    CHOICE,
);
/// `microtubules.elements` (shared by the cell models).
pub(crate) const MICROTUBULES_ELEMENTS: ParamDef = p(
    "microtubules.elements",
    K::Count,
    D::Absent("8; 48 with `coupling = \"foundation\"`"),
    Bounds::new(2.0, true, MAX_MT_ELEMENTS as f64, true),
    "beam elements per MT; on an elastic foundation each beam must be shorter than the foundation's buckling waves (2.7 µm at the default modulus), or the beam between two ties buckles as a column first (8 beams of 1–3 µm: the tension test fails)",
    "choice (\"several\"; foundation: [validation](suspended-cell-validation.md#mts-on-an-elastic-foundation-2026-12-05), 24 and 48 beams within 0.1 %)",
);

/// Beams per MT when `microtubules.elements` is not given: 8, or 48 on an elastic
/// foundation (beams of 0.2–0.5 µm, a fraction of the foundation's 2.7 µm buckling wave;
/// measured: docs/suspended-cell-validation.md, "MTs on an elastic foundation").
pub(crate) fn mt_elements_from_values(v: &ParamValues) -> usize {
    v.optional_count("microtubules.elements").unwrap_or(
        if v.word("microtubules.coupling") == "foundation" {
            FOUNDATION_MT_ELEMENTS
        } else {
            DEFAULT_MT_ELEMENTS
        },
    )
}

/// Beams per MT by default.
pub(crate) const DEFAULT_MT_ELEMENTS: usize = 8;
/// Beams per MT by default on an elastic foundation.
pub(crate) const FOUNDATION_MT_ELEMENTS: usize = 48;
/// `microtubules.bow_min` (shared by the cell models).
pub(crate) const MICROTUBULES_BOW_MIN: ParamDef = p(
    "microtubules.bow_min",
    K::Quantity(Dimensionless),
    D::Number(0.05),
    Bounds::new(0.0, true, MAX_MT_BOW, true),
    "smallest sideways bow at mid-length, fraction of the chord",
    "choice (\"varying curvature\")",
);
/// `microtubules.bow_max` (shared by the cell models).
pub(crate) const MICROTUBULES_BOW_MAX: ParamDef = p(
    "microtubules.bow_max",
    K::Quantity(Dimensionless),
    D::Number(0.20),
    Bounds::new(0.0, true, MAX_MT_BOW, true),
    "largest bow, fraction of the chord",
    CHOICE,
);
/// `microtubules.clearance_margin` (shared by the cell models).
pub(crate) const MICROTUBULES_CLEARANCE_MARGIN: ParamDef = p(
    "microtubules.clearance_margin",
    K::Quantity(Length),
    D::Number(0.25),
    NONNEG,
    "smallest distance of an MT from the nucleus surface",
    "choice (\"never through the nucleus\")",
);
/// `microtubules.coupling` (shared by the cell models).
pub(crate) const MICROTUBULES_COUPLING: ParamDef = p("microtubules.coupling", K::Choice(&["free", "embedded", "foundation"]), D::Word("free"), ANY, "MT interior nodes: free (only the beams hold them), embedded in the cytoplasm/nucleus they lie in (they follow it exactly), or on an elastic foundation (each tied to the material point it lies at by a spring of `foundation_modulus` × its length of MT)", "choice (spec: \"The hybrid model idea\")");
/// `microtubules.foundation_modulus` (shared by the cell models).
pub(crate) const MICROTUBULES_FOUNDATION_MODULUS: ParamDef = p(
    "microtubules.foundation_modulus",
    K::Quantity(Pressure),
    D::Absent("the cytoplasm's Young's modulus 2G(1 + ν)"),
    POS,
    "with `coupling = \"foundation\"`: force per length of MT per µm of slip between an MT node and the gel around it; an MT under compression then buckles at 2√(k EI) in waves of 2π(EI/k)^¼ (2.7 µm at the default: the in-vivo wavelength)",
    "choice (Brangwynne et al. 2006, J Cell Biol 173:733: MTs laterally reinforced by the elastic cytoskeleton, k of the order of its modulus)",
);
/// `microtubules.embedded_nodes` (shared by the cell models).
pub(crate) const MICROTUBULES_EMBEDDED_NODES: ParamDef = p("microtubules.embedded_nodes", K::Choice(&["alternate", "all"]), D::Word("alternate"), ANY, "with `coupling = \"embedded\"`: which interior MT nodes follow the continuum: every second one counted from the FA (no two held nodes adjacent: each span between them is two elements that bend like a free MT segment) or all (each element is a straight column between held nodes that buckles at its own Euler load, 0.03 nN: Newton fails in the prestress)", "choice ([embedded cell](embedded-elements.md#the-embedded-cell))");
/// `microtubules.centrosome` (shared by the cell models).
pub(crate) const MICROTUBULES_CENTROSOME: ParamDef = p(
    "microtubules.centrosome",
    K::Choice(&["free", "tied"]),
    D::Word("free"),
    ANY,
    "centrosome node: free, or tied to the cytoplasm where it sits",
    "choice (spec: \"The hybrid model idea\")",
);
/// `microtubules.centrosome_radius` (shared by the cell models).
pub(crate) const MICROTUBULES_CENTROSOME_RADIUS: ParamDef = p(
    "microtubules.centrosome_radius",
    K::Quantity(Length),
    D::Number(1.0),
    Bounds::NON_NEGATIVE,
    "with `centrosome = \"tied\"`: the centrosome follows the mean displacement of the gel within this radius of it, and the MTs' pull on it spreads over that ball (a distributing coupling); 0 ties it at its point, where the pull is a point load on the gel (its local strain grows as the mesh or the MTs are refined)",
    "choice, measured: a centrosome with its pericentriolar material is of the order of 1 µm across; with MTs on the foundation the nucleus strain beside it then changes by 8 % from 24 to 48 beams per MT (a free hub's by 78 %), and the tension test completes where a point tie stalls it ([suspended cell validation](suspended-cell-validation.md#the-centrosomes-pull-on-the-nucleus-2026-12-06))",
);
/// `microtubules.stress_free` (the suspended cell; the adherent cell has no first pass yet).
pub(crate) const MICROTUBULES_STRESS_FREE: ParamDef = p(
    "microtubules.stress_free",
    K::Choice(&["unstressed-cell", "prestressed-cell"]),
    D::Word("unstressed-cell"),
    ANY,
    "where the MTs are stress-free: in the unstressed cell (the mesh: the prestress contraction shortens and bends them with the gel, and MTs held by the gel buckle) or in the prestressed cell (as if they polymerised after the contraction: their stress-free shape is the mesh shape carried by the gel's contraction; they carry none of the actin prestress)",
    "choice ([suspended cell](suspended-cell.md#microtubules-stress-free-in-the-prestressed-cell))",
);
/// `solver.stabilization` (shared by the cell models).
pub(crate) const SOLVER_STABILIZATION: ParamDef = p("solver.stabilization", K::Choice(&["off", "on-difficulty", "always"]), D::Word("on-difficulty"), ANY, "viscous stabilisation of every step ([stabilisation](stabilization.md)): off; switched on at a step's first failed increment (a step that converges without it is unchanged); or from each step's start", "choice (Abaqus `*STATIC, STABILIZE`)");
/// `solver.damping` (shared by the cell models).
pub(crate) const SOLVER_DAMPING: ParamDef = p("solver.damping", K::Choice(&["auto", "nodal", "filament-drag"]), D::Word("auto"), ANY, "what the viscous stabilisation resists: `nodal`, every free node's motion over the increment (Abaqus); `filament-drag`, only the slip of the filament nodes tied to the gel relative to their material points, and the filaments' rotations (the drag of a viscous cytoplasm on a filament moving through it: rigid motion and the gel's own deformation are not damped; needs `microtubules.coupling = \"foundation\"`; a step with every tied family switched off gets `nodal`); `auto`, `filament-drag` with MTs on the foundation, `nodal` otherwise", "choice, measured ([stabilisation](stabilization.md#relative-damping)): on the suspended-cell compression with MTs on the foundation the drag dissipates 0.71 % of the last step's strain energy where the nodal viscosity takes 11 %, with the same forces within 0.3 %");
/// `solver.iteration` (shared by the cell models).
pub(crate) const SOLVER_ITERATION: ParamDef = p("solver.iteration", K::Choice(&["auto", "newton", "bfgs"]), D::Word("auto"), ANY, "corrections after each increment's first: `newton`, full Newton in every step (a factorisation per iteration, chord steps near convergence); `bfgs`, quasi-Newton in every step (the increment's factorisation kept, up to `solver.bfgs_updates` rank-two updates; a failed increment is retried with full Newton); `auto`, BFGS in the microplate compression's loading steps unless filament nodes are embedded (free filaments, or MTs on the elastic foundation with `rotation_step` above 0), full Newton everywhere else", "choice, measured ([performance](performance.md#bfgs-where-it-pays-2026-12-04-sixth-session)): BFGS halves the free cell's compression factorisations (fast mesh 86 -> 50, default mesh 111 -> 59; forces within 2e-8, 4e-5 where a cut-back changed the path) but is not reliably cheaper with embedded filaments, costs cut-backs in tension without AFs and at ~100 % elongation, and moves the AFM curve by 0.8 % (FEBio's default is BFGS); with MTs on the foundation and the rotations' trust region it takes the compression from 288 to 217 factorisations ([performance](performance.md#a-trust-region-on-the-rotations-2026-12-06)), 154 since the trust region also bounds an increment's first correction; a BFGS increment is easy (the next grows) within 10 iterations, full Newton's within 5");
/// `solver.bfgs_updates` (shared by the cell models).
pub(crate) const SOLVER_BFGS_UPDATES: ParamDef = p("solver.bfgs_updates", K::Count, D::Count(20), Bounds::new(1.0, true, 200.0, true), "where BFGS iterates (`solver.iteration`), the rank-two updates of the kept factorisation before the tangent is reformed (it is reformed earlier when the residual grows or an update would lose positive curvature)", "choice, measured ([performance](performance.md#fewer-reforms-in-the-compressions-bfgs-cheaper-solves-2026-12-07-stop-52)): on the default compression 20 instead of FEBio's 10 takes 75 instead of 88 factorisations and 446 instead of 397 Newton iterations, 0.957 of the wall time (farm-bench, 2 cores), forces within 1e-9; a reform costs about ten BFGS iterations there");
/// `solver.relaxation` (shared by the cell models).
pub(crate) const SOLVER_RELAXATION: ParamDef = p("solver.relaxation", K::Choice(&["filaments", "off"]), D::Word("filaments"), ANY, "after every global Newton update, each beam filament's own DOFs (the interior nodes of a free MT, the rotations at its ends) are moved to their equilibrium by a local Newton solve with the rest held (nonlinear elimination); the same equilibrium in fewer global iterations, or off", "choice, measured ([performance](performance.md#nonlinear-elimination-of-the-free-filaments)): default tension 74 -> 41 factorisations, compression 258 -> 160, forces within 2e-9");
/// `solver.chord` (shared by the cell models).
pub(crate) const SOLVER_CHORD: ParamDef = p("solver.chord", K::Choice(&["near-convergence", "off"]), D::Word("near-convergence"), ANY, "full Newton near convergence (residual within 1000 times the tolerance, the last step having divided it at least 100-fold) solves with the last factorisation instead of a new one, while each such chord step divides the residual at least 10-fold; the same convergence criteria, or off (a factorisation at every iteration)", "choice, measured ([performance](performance.md#chord-steps-near-convergence)): default tension 41 -> 31 factorisations, compression 160 -> 109, forces within 8e-9");
/// `solver.rotation_step` (shared by the cell models).
pub(crate) const SOLVER_ROTATION_STEP: ParamDef = p("solver.rotation_step", K::Quantity(crate::units::Dimension::Angle), D::Absent("0.2 rad with `microtubules.coupling = \"foundation\"`; no bound otherwise"), NONNEG, "trust region of the beams' rotations: a Newton correction that would turn a filament node by more than this is shortened along its own direction until it does not (an increment's first too, unless it carries a prescribed motion); the same equilibria, a different path; `\"0 rad\"` switches it off", "choice, measured ([performance](performance.md#a-trust-region-on-the-rotations-2026-12-06)): in the compression with MTs on the foundation Newton proposed rotation corrections of 10-900 rad where tied MTs snap through; with full Newton 0.2 rad takes the 50 % step from 257 to 201 factorisations (0.5 rad: no gain, 0.1 rad: 250), forces within 0.03 %; with it BFGS pays there (the whole compression 344 -> 217), and bounding the first correction too takes it to 154 ([performance](performance.md#the-first-correction-too-2026-12-06-stop-43))");
/// `solver.residual_tolerance` (shared by the cell models).
pub(crate) const SOLVER_RESIDUAL_TOLERANCE: ParamDef = p("solver.residual_tolerance", K::Number, D::Number(1e-8), TOLERANCE, "Newton's residual criterion: the out-of-balance force at the free DOFs at most this fraction of the force scale (the largest of the external forces, the reactions, the increment's first residual and the internal forces that balance at the free DOFs, so a prestressed cell with no load has one); an increment converges when this and `energy_tolerance` both hold", "choice (tight: the engine's verification default; measured ([performance](performance.md#the-convergence-tolerances-2026-12-06-stop-48)): 1e-6 with `energy_tolerance = 1e-10` takes the default compression from 330 to 254 Newton iterations and moves its forces by at most 1.1e-7 of their value)");
/// `solver.energy_tolerance` (shared by the cell models).
pub(crate) const SOLVER_ENERGY_TOLERANCE: ParamDef = p("solver.energy_tolerance", K::Number, D::Number(1e-12), TOLERANCE, "Newton's energy criterion: the work of the last correction against the residual at most this fraction of the increment's first (or of a contact round's first when larger)", "choice (the engine's verification default; see `residual_tolerance`)");
/// `intermediate.youngs_modulus` (shared by the cell models).
pub(crate) const INTERMEDIATE_YOUNGS_MODULUS: ParamDef = p(
    "intermediate.youngs_modulus",
    K::Quantity(Pressure),
    D::Number(7.6e3),
    POS,
    "intermediate filament Young's modulus",
    "spec (EA = 0.60 nN)",
);
/// `intermediate.diameter` (shared by the cell models).
pub(crate) const INTERMEDIATE_DIAMETER: ParamDef = p(
    "intermediate.diameter",
    K::Quantity(Length),
    D::Number(0.010),
    POS,
    "intermediate filament diameter",
    SPEC,
);
/// `intermediate.slack` (shared by the cell models).
pub(crate) const INTERMEDIATE_SLACK: ParamDef = p(
    "intermediate.slack",
    K::Quantity(Dimensionless),
    D::Number(0.20),
    NONNEG,
    "slack: no force below (1 + slack) × the initial length",
    SPEC,
);
/// `intermediate.per_fa` (shared by the cell models).
pub(crate) const INTERMEDIATE_PER_FA: ParamDef = p(
    "intermediate.per_fa",
    K::Count,
    D::Count(2),
    Bounds::new(1.0, true, MAX_IFS_PER_FA as f64, true),
    "IFs per FA",
    "spec (\"at least two\")",
);
/// `intermediate.phase_deg` (shared by the cell models).
pub(crate) const INTERMEDIATE_PHASE_DEG: ParamDef = p(
    "intermediate.phase_deg",
    K::Number,
    D::Number(0.0),
    ANY,
    "angle (degrees) of the first IF on the FA's tangent circle",
    CHOICE,
);
/// `intermediate.anchor` (shared by the cell models).
pub(crate) const INTERMEDIATE_ANCHOR: ParamDef = p(
    "intermediate.anchor",
    K::Choice(&["nearest", "nearest-visible"]),
    D::Word("nearest"),
    ANY,
    "which nucleus node anchors an IF: nearest to the tangent point, or nearest visible",
    "spec (\"nearest to that circle\")",
);

/// Every parameter of the suspended cell.
pub const SUSPENDED_CELL: ParamTable = ParamTable {
    name: "suspended-cell",
    section: "cell",
    params: &[
        p(
            "cell_diameter",
            K::Quantity(Length),
            D::Number(32.264),
            POS,
            "cell diameter D",
            "spec",
        ),
        p(
            "nucleus_diameter",
            K::Quantity(Length),
            D::Number(12.9),
            POS,
            "nucleus diameter (concentric)",
            "spec (the comparable published model)",
        ),
        p(
            "seed",
            K::Seed,
            D::Seed(2024),
            ANY,
            "seed of every random choice (MT bows, orientation search, the `density.*` extra filaments)",
            CHOICE,
        ),
        p(
            "resolution",
            K::Choice(&["default", "fast", "fine"]),
            D::Word("default"),
            ANY,
            "mesh: 6912 hex8 (core 12 divisions, 3 + 3 layers), 2816 (`fast`: 8, 3 + 3; the default until 2026-12-04, its 10 % compression force 7 % low) or 14 504 (`fine`: 14, 5 + 5)",
            "choice: the coarsest mesh measured within 5 % of the fine one at every reported compression and tension point ([validation](suspended-cell-validation.md#mesh-convergence))",
        ),
        p(
            "core_divisions",
            K::Count,
            D::Absent("from `resolution`"),
            MESH_COUNT,
            "elements along the central cube's edge (even; the CI tests use 4, 2, 2: 448 hex8)",
            CHOICE,
        ),
        p(
            "shell_layers",
            K::Count,
            D::Absent("from `resolution`"),
            MESH_COUNT,
            "radial element layers inside the nucleus surface",
            CHOICE,
        ),
        p(
            "outer_layers",
            K::Count,
            D::Absent("from `resolution`"),
            MESH_COUNT,
            "radial element layers of cytoplasm",
            CHOICE,
        ),
        p(
            "fa_orientation",
            K::Choice(&["symmetric", "optimized", "pentagon-on-axis"]),
            D::Word("symmetric"),
            ANY,
            "FA pattern: on the ±x, ±y, ±z poles (an FA on the test axis, inside the grip), rotated to fit the mesh, or with the test axis x through two opposite pentagon centres (no FA within 31.7° of the axis)",
            "choice ([geometry](suspended-cell-geometry.md))",
        ),
        p(
            "fa_radius",
            K::Quantity(Length),
            D::Number(3.5),
            NONNEG,
            "radius of an FA plaque: the surface nodes within it carry the FA's filaments, as `fa_coupling` says (0: the FA is one node, the literal reading; a radius below the mesh spacing at the FAs also leaves one node)",
            "choice (spec: \"if a single node cannot carry the load, an FA may be a small patch of surface nodes tied together\"; with one node the elements at the FAs fold over in every compression from 16–20 %, with 3.5 um plaques none folds in the control to 50 %: [validation](suspended-cell-validation.md#the-default-fas-are-plaques-2026-12-07-stop-50))",
        ),
        p(
            "fa_coupling",
            K::Choice(&["rigid", "distributing", "distributing-linear"]),
            D::Word("distributing-linear"),
            ANY,
            "how an FA's plaque carries its filaments' pull: `rigid`, every plaque node moves with the FA node (Abaqus kinematic coupling); `distributing`, the FA node moves with the plaque nodes' mean and its load is shared among them equally (Abaqus distributing coupling); `distributing-linear`, the same with weights falling linearly to zero at the plaque's rim, times each node's surface area (a traction that does not change with the mesh)",
            CHOICE,
        ),
        p(
            "fa_reference",
            K::Choice(&["fa-node", "separate"]),
            D::Word("separate"),
            ANY,
            "with a distributing `fa_coupling`: where the FA's filaments end and the coupling's reference point is: the FA mesh node (tied to the plaque's weighted mean, though it is not at the plaque's weighted centroid, so a rotation strains the tie), or a separate node at the plaque's weighted centroid, tied to the plaque nodes and the FA node, which stays a free surface node (the tie then follows every rigid motion exactly)",
            "choice ([validation](suspended-cell-validation.md#fa-plaques-re-run-and-an-objective-coupling-2026-12-07-stop-49): with the FA node as reference the pentagon-on-axis prestress loads the supports with 1.49 nN and folds the nucleus's centre)",
        ),
        p(
            "fa_snap",
            K::Choice(&["move-node", "none"]),
            D::Word("move-node"),
            ANY,
            "how an FA site goes onto the mesh: `move-node`, the nearest surface node is moved onto the site (and the radial column of cytoplasm nodes beneath it turned with it); `none`, nothing moves: the FA node is the nearest surface node where it is, and a plaque (`fa_radius` > 0) is centred on the site itself (its members, weights and reference node measured from the site)",
            "choice ([validation](suspended-cell-validation.md#fas-centred-on-their-sites-2026-12-07-stop-50): with the pattern turned, the move distorts two FAs' elements to a scaled Jacobian of 0.25 and they fold from 12.8 um of stretch)",
        ),
        p(
            "orientation_trials",
            K::Count,
            D::Count(2000),
            Bounds::new(0.0, true, MAX_ORIENTATION_TRIALS as f64, true),
            "random rotations tried by `fa_orientation = \"optimized\"`",
            CHOICE,
        ),
        CYTOPLASM_SHEAR_MODULUS,
        CYTOPLASM_POISSON_RATIO,
        NUCLEUS_SHEAR_MODULUS,
        NUCLEUS_POISSON_RATIO,
        p(
            "membrane.youngs_modulus",
            K::Quantity(Pressure),
            D::Number(1000.0),
            POS,
            "cell membrane (CM) Young's modulus (incompressible, G = E/3)",
            "spec (CM)",
        ),
        p(
            "membrane.thickness",
            K::Quantity(Length),
            D::Number(0.01),
            POS,
            "cell membrane thickness",
            SPEC,
        ),
        p(
            "membrane.law",
            K::Choice(&["elastic", "tension-field"]),
            D::Word("tension-field"),
            Bounds::ANY,
            "how the membrane answers in-plane compression: `tension-field` wrinkles (the relaxed energy: no compressive stress); `elastic` carries it (a sheet without bending stiffness, held only by the cytoplasm under it)",
            "choice: a lipid membrane does not carry compression; with `elastic` the 50 % compression needs 14 cutbacks and viscous stabilisation ([membranes](membrane.md#tension-field))",
        ),
        p(
            "actin.youngs_modulus",
            K::Quantity(Pressure),
            D::Number(2.6e6),
            POS,
            "actin filament Young's modulus",
            "spec (EA = 100 nN)",
        ),
        p(
            "actin.diameter",
            K::Quantity(Length),
            D::Number(0.007),
            POS,
            "actin filament diameter",
            SPEC,
        ),
        p(
            "actin.prestrain",
            K::Quantity(Dimensionless),
            D::Number(0.24),
            Bounds::new(-1.0, false, f64::INFINITY, false),
            "actin prestrain (tension-only trusses)",
            SPEC,
        ),
        p(
            "actin.coupling",
            K::Choice(&["free", "embedded"]),
            D::Word("free"),
            ANY,
            "AF interior: `free`, one straight truss between its two FAs; `embedded`, each AF split into `actin.elements` trusses whose interior nodes follow the cytoplasm they lie in (the AF becomes a fibre of the gel)",
            "choice (spec: \"The hybrid model idea\"; the `all-embedded` mode of the validation)",
        ),
        p(
            "actin.elements",
            K::Count,
            D::Count(4),
            Bounds::new(2.0, true, MAX_MT_ELEMENTS as f64, true),
            "with `actin.coupling = \"embedded\"`: trusses per AF (each with the AF's prestrain); unused when free",
            CHOICE,
        ),
        p(
            "intermediate.coupling",
            K::Choice(&["free", "embedded"]),
            D::Word("free"),
            ANY,
            "IF interior: `free`, one slack truss from its FA to its nucleus anchor; `embedded`, each IF split into `intermediate.elements` trusses (each with the IF's slack) whose interior nodes follow the cytoplasm",
            "choice (spec: \"The hybrid model idea\"; the `all-embedded` mode of the validation)",
        ),
        p(
            "intermediate.elements",
            K::Count,
            D::Count(4),
            Bounds::new(2.0, true, MAX_MT_ELEMENTS as f64, true),
            "with `intermediate.coupling = \"embedded\"`: trusses per IF; unused when free",
            CHOICE,
        ),
        MICROTUBULES_YOUNGS_MODULUS,
        MICROTUBULES_OUTER_DIAMETER,
        MICROTUBULES_INNER_DIAMETER,
        MICROTUBULES_POISSON_RATIO,
        MICROTUBULES_ELEMENTS,
        MICROTUBULES_BOW_MIN,
        MICROTUBULES_BOW_MAX,
        MICROTUBULES_CLEARANCE_MARGIN,
        p(
            "microtubules.centrosome_gap",
            K::Quantity(Length),
            D::Number(0.75),
            POS,
            "distance of the centrosome from the nucleus surface (> 0: outside the nucleus)",
            "choice (\"near the nucleus\")",
        ),
        p(
            "microtubules.centrosome_direction",
            K::Vector3,
            D::Vector3([1.0, 1.0, 1.0]),
            ANY,
            "direction of the centrosome from the cell centre",
            CHOICE,
        ),
        MICROTUBULES_COUPLING,
        MICROTUBULES_FOUNDATION_MODULUS,
        MICROTUBULES_EMBEDDED_NODES,
        MICROTUBULES_CENTROSOME,
        MICROTUBULES_CENTROSOME_RADIUS,
        MICROTUBULES_STRESS_FREE,
        SOLVER_STABILIZATION,
        SOLVER_DAMPING,
        SOLVER_ITERATION,
        SOLVER_BFGS_UPDATES,
        SOLVER_RELAXATION,
        SOLVER_CHORD,
        SOLVER_ROTATION_STEP,
        SOLVER_RESIDUAL_TOLERANCE,
        SOLVER_ENERGY_TOLERANCE,
        INTERMEDIATE_YOUNGS_MODULUS,
        INTERMEDIATE_DIAMETER,
        INTERMEDIATE_SLACK,
        INTERMEDIATE_PER_FA,
        INTERMEDIATE_PHASE_DEG,
        INTERMEDIATE_ANCHOR,
        p(
            "density.extra_actin",
            K::Count,
            D::Count(0),
            EXTRA,
            "density variant: extra prestressed AFs (same material and prestrain) through the interior, between seeded random pairs of non-FA surface nodes (each node once) whose chord misses the nucleus and is at least as long as the cortical AFs",
            "spec (\"Studies\": density)",
        ),
        p(
            "density.extra_intermediate",
            K::Count,
            D::Count(0),
            EXTRA,
            "density variant: extra slack IFs (same material and slack), straight from seeded random non-FA surface nodes to visible nucleus-surface nodes (each node once)",
            "spec (\"Studies\": density)",
        ),
        p(
            "refinement.levels",
            K::Count,
            D::Count(0),
            Bounds::new(0.0, true, super::layout::MAX_POLE_REFINEMENT_LEVELS as f64, true),
            "levels of octree refinement (hanging nodes tied) of every hex8 with a corner within `refinement.radius` of a pole of the test axis (±x); a radius larger than the cell refines the whole mesh while the FAs and filaments stay where they are (a mesh-convergence check that does not move the cytoskeleton); 0: none",
            "choice: off by default; the compression protocol refines under its plates (`[protocol] refinement.levels`, which this replaces when above 0); on the fast mesh refining only the poles overshot the 10 % compression force (+6 % against the whole mesh refined, [validation](suspended-cell-validation.md#mesh-convergence)), on the default mesh with the FA plaques it brings it within 1.4 % of the fine mesh ([validation](suspended-cell-validation.md#refined-under-the-plates-2026-12-07-stop-51))",
        ),
        p(
            "refinement.radius",
            K::Quantity(Length),
            D::Number(8.0),
            POS,
            "radius of the refined region around each pole point (on the cell surface)",
            CHOICE,
        ),
        p(
            "density.extra_microtubules",
            K::Count,
            D::Count(0),
            EXTRA,
            "density variant: extra MTs from the centrosome to seeded random non-FA surface nodes (each once), curved and coupled like the FA MTs",
            "spec (\"Studies\": density)",
        ),
    ],
};

/// Geometry and materials of the suspended cell from resolved parameter values.
pub fn from_values(v: &ParamValues) -> (SuspendedCellParams, SuspendedCellMaterials) {
    let mut mesh = match v.word("resolution") {
        "fine" => MeshResolution::fine(),
        "fast" => MeshResolution::fast(),
        _ => MeshResolution::default(),
    };
    for (key, target) in [
        ("core_divisions", &mut mesh.core_divisions),
        ("shell_layers", &mut mesh.shell_layers),
        ("outer_layers", &mut mesh.outer_layers),
    ] {
        if let Some(n) = v.optional_count(key) {
            *target = n;
        }
    }
    let params = SuspendedCellParams {
        cell_diameter: v.number("cell_diameter"),
        nucleus_diameter: v.number("nucleus_diameter"),
        mesh,
        fa_orientation: match v.word("fa_orientation") {
            "optimized" => FaOrientation::Optimized {
                trials: v.count("orientation_trials"),
            },
            "pentagon-on-axis" => FaOrientation::PentagonOnAxis,
            _ => FaOrientation::Symmetric,
        },
        mt_elements: mt_elements_from_values(v),
        mt_bow_min: v.number("microtubules.bow_min"),
        mt_bow_max: v.number("microtubules.bow_max"),
        mt_clearance_margin: v.number("microtubules.clearance_margin"),
        centrosome_gap: v.number("microtubules.centrosome_gap"),
        centrosome_direction: v.vector3("microtubules.centrosome_direction"),
        ifs_per_fa: v.count("intermediate.per_fa"),
        if_phase: v.number("intermediate.phase_deg").to_radians(),
        if_anchor_rule: if_anchor_rule_from_values(v),
        seed: v.seed("seed"),
        density: DensityParams {
            extra_actin: v.count("density.extra_actin"),
            extra_intermediate: v.count("density.extra_intermediate"),
            extra_microtubules: v.count("density.extra_microtubules"),
        },
        af_elements: if v.word("actin.coupling") == "embedded" {
            v.count("actin.elements")
        } else {
            1
        },
        if_elements: if v.word("intermediate.coupling") == "embedded" {
            v.count("intermediate.elements")
        } else {
            1
        },
        pole_refinement: super::layout::PoleRefinement {
            levels: v.count("refinement.levels").min(u8::MAX as usize) as u8,
            radius: v.number("refinement.radius"),
        },
        fa_radius: v.number("fa_radius"),
        fa_coupling: match v.word("fa_coupling") {
            "distributing" => crate::cell::fa_plaque::FaCoupling::Distributing,
            "distributing-linear" => crate::cell::fa_plaque::FaCoupling::DistributingLinear,
            _ => crate::cell::fa_plaque::FaCoupling::Rigid,
        },
        fa_reference: match v.word("fa_reference") {
            "separate" => crate::cell::fa_plaque::FaReference::Separate,
            _ => crate::cell::fa_plaque::FaReference::FaNode,
        },
        fa_snap: v.word("fa_snap") != "none",
    };
    let materials = SuspendedCellMaterials {
        cytoplasm_shear_modulus: v.number("cytoplasm.shear_modulus"),
        cytoplasm_poisson_ratio: v.number("cytoplasm.poisson_ratio"),
        nucleus_shear_modulus: v.number("nucleus.shear_modulus"),
        nucleus_poisson_ratio: v.number("nucleus.poisson_ratio"),
        membrane_shear_modulus: v.number("membrane.youngs_modulus") / 3.0,
        membrane_thickness: v.number("membrane.thickness"),
        membrane_law: membrane_law(v.word("membrane.law")),
        actin: ActinMaterial {
            youngs_modulus: v.number("actin.youngs_modulus"),
            diameter: v.number("actin.diameter"),
            prestrain: v.number("actin.prestrain"),
        },
        microtubule: microtubule_from_values(v),
        intermediate: intermediate_from_values(v),
    };
    (params, materials)
}

/// The MT material of the shared `microtubules.*` keys.
pub(crate) fn microtubule_from_values(v: &ParamValues) -> MicrotubuleMaterial {
    MicrotubuleMaterial {
        youngs_modulus: v.number("microtubules.youngs_modulus"),
        outer_diameter: v.number("microtubules.outer_diameter"),
        inner_diameter: v.number("microtubules.inner_diameter"),
        poisson_ratio: v.number("microtubules.poisson_ratio"),
    }
}

/// The IF material of the shared `intermediate.*` keys.
pub(crate) fn intermediate_from_values(v: &ParamValues) -> IntermediateMaterial {
    IntermediateMaterial {
        youngs_modulus: v.number("intermediate.youngs_modulus"),
        diameter: v.number("intermediate.diameter"),
        slack: v.number("intermediate.slack"),
    }
}

/// The IF anchor rule of the shared `intermediate.anchor` key.
pub(crate) fn if_anchor_rule_from_values(v: &ParamValues) -> IfAnchorRule {
    match v.word("intermediate.anchor") {
        "nearest-visible" => IfAnchorRule::NearestVisible,
        _ => IfAnchorRule::Nearest,
    }
}

/// The viscous stabilisation of every step from resolved values of [`SUSPENDED_CELL`].
pub fn stabilization_from_values(v: &ParamValues) -> Option<Stabilization> {
    let activation = match v.word("solver.stabilization") {
        "always" => Activation::Always,
        "on-difficulty" => Activation::OnDifficulty,
        _ => return None,
    };
    let damping = match v.word("solver.damping") {
        "filament-drag" => Damping::Relative,
        "auto" if v.word("microtubules.coupling") == "foundation" => Damping::Relative,
        _ => Damping::Nodal,
    };
    Some(Stabilization {
        activation,
        damping,
        ..Stabilization::default()
    })
}

/// BFGS with `solver.bfgs_updates` updates before a reform, from resolved values of a
/// cell model's table: what `bfgs` and `auto` (where it chooses BFGS) iterate by.
pub fn bfgs_from_values(v: &ParamValues) -> IterationMethod {
    IterationMethod::Bfgs {
        max_updates: v.count("solver.bfgs_updates"),
    }
}

/// The iteration method of every step from resolved values of a cell model's table
/// (`None`: `auto`, each protocol's measured choice).
pub fn iteration_from_values(v: &ParamValues) -> Option<IterationMethod> {
    match v.word("solver.iteration") {
        "bfgs" => Some(bfgs_from_values(v)),
        "newton" => Some(IterationMethod::Newton),
        _ => None,
    }
}

/// The rotations' trust region of every step (rad, 0: none) from resolved values of a cell
/// model's table: `solver.rotation_step`, or when absent 0.2 rad with MTs on the elastic
/// foundation (where tied MTs snap through) and none otherwise.
pub fn rotation_step_from_values(v: &ParamValues) -> f64 {
    match v.optional_number("solver.rotation_step") {
        Some(bound) => bound,
        None if v.word("microtubules.coupling") == "foundation" => FOUNDATION_ROTATION_STEP,
        None => 0.0,
    }
}

/// The rotations' trust region where MTs lie on the elastic foundation (rad).
pub const FOUNDATION_ROTATION_STEP: f64 = 0.2;

/// Whether full Newton takes chord steps near convergence, from resolved values of
/// [`SUSPENDED_CELL`].
pub fn chord_from_values(v: &ParamValues) -> bool {
    v.word("solver.chord") != "off"
}

/// Whether the filaments are relaxed (nonlinear elimination) in every step, from resolved
/// values of [`SUSPENDED_CELL`].
pub fn relaxation_from_values(v: &ParamValues) -> bool {
    v.word("solver.relaxation") != "off"
}

/// The cytoskeleton's coupling from resolved values of [`SUSPENDED_CELL`].
pub fn coupling_from_values(v: &ParamValues) -> super::Coupling {
    let cytoplasm_youngs_modulus =
        2.0 * v.number("cytoplasm.shear_modulus") * (1.0 + v.number("cytoplasm.poisson_ratio"));
    super::Coupling {
        microtubules_embedded: v.word("microtubules.coupling") == "embedded",
        microtubule_foundation: (v.word("microtubules.coupling") == "foundation").then(|| {
            v.optional_number("microtubules.foundation_modulus")
                .unwrap_or(cytoplasm_youngs_modulus)
        }),
        embedded_nodes: match v.word("microtubules.embedded_nodes") {
            "all" => super::EmbeddedNodes::All,
            _ => super::EmbeddedNodes::Alternate,
        },
        centrosome_tied: v.word("microtubules.centrosome") == "tied",
        centrosome_radius: v.number("microtubules.centrosome_radius"),
        microtubules_prestressed: v.word("microtubules.stress_free") == "prestressed-cell",
    }
}

/// The defaults of the table.
pub fn defaults() -> (SuspendedCellParams, SuspendedCellMaterials) {
    from_values(&ParamValues::defaults(&SUSPENDED_CELL))
}

impl Default for SuspendedCellParams {
    /// The defaults declared in [`SUSPENDED_CELL`].
    fn default() -> Self {
        defaults().0
    }
}

impl Default for SuspendedCellMaterials {
    /// The defaults declared in [`SUSPENDED_CELL`].
    fn default() -> Self {
        defaults().1
    }
}

/// The membrane law of a `law` choice (`"elastic"` or `"tension-field"`).
pub(crate) fn membrane_law(word: &str) -> crate::model::structures::MembraneLaw {
    match word {
        "tension-field" => crate::model::structures::MembraneLaw::TensionField,
        _ => crate::model::structures::MembraneLaw::Elastic,
    }
}
