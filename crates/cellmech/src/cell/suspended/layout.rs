//! The geometry of the suspended cell (continuum mesh with a nucleus, focal
//! adhesions, and the routing of the discrete cytoskeleton).
//!
//! [`SuspendedCellGeometry::build`] turns [`SuspendedCellParams`] into a hex8 mesh of
//! cytoplasm and nucleus whose outer surface carries the 30 focal adhesions (FAs) at the
//! vertices of an icosidodecahedron, plus the actin filaments (AFs, its 60 edges), one
//! curved microtubule (MT) per FA from a single centrosome, and intermediate filaments
//! (IFs) from each FA tangential to the nucleus. It is pure geometry: materials,
//! prestrain and solving belong to the model builder. See `docs/suspended-cell-geometry.md`.

use cellmech_fem::mesh::generate::{sphere_mesh, GenerateError, SphereMeshSpec};
use cellmech_fem::mesh::Mesh;

use super::cytoskeleton::{self, IfAnchorRule, MicrotubulePath};
use super::density::{self, DensityParams, MAX_EXTRA_FILAMENTS};
use super::geometry::{self, icosidodecahedron_edges, FaOrientation, GOLDEN_RATIO};

use crate::cell::vec3::{angle, norm, normalize, scale, sub, M3, V3};

/// Largest accepted number of beam elements per MT.
pub const MAX_MT_ELEMENTS: usize = 1000;
/// Largest accepted number of IFs per FA.
pub const MAX_IFS_PER_FA: usize = 64;
/// Largest accepted number of random orientation trials.
pub const MAX_ORIENTATION_TRIALS: usize = 100_000;
/// Largest accepted MT bow (fraction of the chord).
pub const MAX_MT_BOW: f64 = 0.5;

/// Resolution of the cubed-sphere mesh (see `cellmech_fem::mesh::generate::SphereMeshSpec`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshResolution {
    /// Elements along the central cube's edge and per cube-face patch (even, ≥ 2).
    pub core_divisions: usize,
    /// Radial element layers from the central cube to the nucleus surface.
    pub shell_layers: usize,
    /// Radial element layers from the nucleus surface to the cell surface (cytoplasm).
    pub outer_layers: usize,
    /// Half-size of the central cube relative to the nucleus radius.
    pub core_fraction: f64,
}

impl Default for MeshResolution {
    /// The default: 12 divisions, 3 + 3 layers, 6912 hex8 (surface element ≈ 2.1 µm): the
    /// coarsest of the meshes measured whose compression forces at 10 / 30 / 50 % and
    /// tensile force at 6.3 µm are within 5 % of the fine mesh's
    /// (docs/suspended-cell-validation.md, "Mesh convergence").
    fn default() -> Self {
        Self {
            core_divisions: 12,
            shell_layers: 3,
            outer_layers: 3,
            core_fraction: 0.5,
        }
    }
}

impl MeshResolution {
    /// The fast setting, the default until 2026-12-04: 8 divisions, 3 + 3 layers, 2816 hex8
    /// (surface element ≈ 3.2 µm). Its compression force at 10 % is 7 % below the
    /// converged value (the 30 and 50 % points and the tension are within 3 %).
    pub fn fast() -> Self {
        Self {
            core_divisions: 8,
            shell_layers: 3,
            outer_layers: 3,
            core_fraction: 0.5,
        }
    }

    /// The finer setting: 14 divisions, 5 + 5 layers, 14 504 hex8 (surface element
    /// ≈ 1.8 µm). 14 rather than 16 divisions because the symmetric FA sites fall closer to
    /// its nodes (largest snap 0.26 of an element instead of 0.42; see the docs).
    pub fn fine() -> Self {
        Self {
            core_divisions: 14,
            shell_layers: 5,
            outer_layers: 5,
            core_fraction: 0.5,
        }
    }

    /// Number of hex8 elements this resolution produces.
    pub fn elements(&self) -> usize {
        let n = self.core_divisions;
        n * n * n + 6 * n * n * (self.shell_layers + self.outer_layers)
    }
}

/// Parameters of the suspended-cell geometry. Lengths in µm. Defaults from
/// `spec/cell-models.md` ("Suspended cell") where it gives them, else documented choices.
#[derive(Debug, Clone, PartialEq)]
pub struct SuspendedCellParams {
    /// Cell diameter (spec: 32.264 µm).
    pub cell_diameter: f64,
    /// Nucleus diameter, concentric (spec default: 12.9 µm).
    pub nucleus_diameter: f64,
    /// Continuum mesh resolution.
    pub mesh: MeshResolution,
    /// Orientation of the FA icosidodecahedron against the mesh.
    pub fa_orientation: FaOrientation,
    /// Beam elements per MT (≥ 2 so an MT can be curved; default 8).
    pub mt_elements: usize,
    /// Smallest MT sideways bow at mid-length, as a fraction of the chord (default 0.05).
    pub mt_bow_min: f64,
    /// Largest MT bow, fraction of the chord, at most [`MAX_MT_BOW`] (default 0.20).
    pub mt_bow_max: f64,
    /// Smallest accepted distance of any MT element from the nucleus surface (default 0.25 µm).
    pub mt_clearance_margin: f64,
    /// Distance of the centrosome from the nucleus surface (default 0.75 µm).
    pub centrosome_gap: f64,
    /// Direction of the centrosome from the cell centre (normalised; default (1, 1, 1)).
    pub centrosome_direction: V3,
    /// IFs per FA: the spec asks for at least 2 (default); 1 is accepted for studies.
    pub ifs_per_fa: usize,
    /// Angle (rad) of the first IF's tangent point on the FA's tangent circle, measured
    /// from the direction of +z projected onto the circle's plane (default 0).
    pub if_phase: f64,
    /// Which nucleus-surface nodes may anchor an IF (default: the nearest to the tangent
    /// point, as the spec says).
    pub if_anchor_rule: IfAnchorRule,
    /// Seed of every random choice (MT bows and sides, orientation search, the density
    /// variant's extra filaments).
    pub seed: u64,
    /// Extra filaments of the density variant (none by default).
    pub density: DensityParams,
    /// Local refinement of the mesh at both ends of the test axis, where the pipettes
    /// grip and the plates press (none when `levels` is 0).
    pub pole_refinement: PoleRefinement,
    /// Radius of an FA plaque (µm): the surface nodes within it carry the filaments
    /// anchored at the FA node, as `fa_coupling` says (0: the FA is one node).
    pub fa_radius: f64,
    /// How a plaque carries its FA's filaments (rigid or distributing).
    pub fa_coupling: crate::cell::fa_plaque::FaCoupling,
    /// Where a distributing plaque's filaments end: the FA node, or a separate node at the
    /// plaque's weighted centroid ([`crate::cell::fa_plaque::FaReference`]).
    pub fa_reference: crate::cell::fa_plaque::FaReference,
    /// Whether the nearest surface node is moved onto each FA site (`fa_snap =
    /// "move-node"`); otherwise nothing moves and a plaque is centred on the site.
    pub fa_snap: bool,
    /// Truss elements per AF: 1, one straight truss between its FAs; more, the AF split
    /// along its chord with the interior nodes embedded in the cytoplasm
    /// (`actin.coupling = "embedded"`).
    pub af_elements: usize,
    /// Truss elements per IF: 1, or more, split and embedded
    /// (`intermediate.coupling = "embedded"`).
    pub if_elements: usize,
}

/// Local refinement at the poles of the test axis (`±x`): every hex8 with a corner within
/// `radius` of a pole point `(±R, 0, 0)` is split `levels` times (octree, 2:1 balanced
/// across faces and edges, hanging nodes tied; `cellmech_fem::mesh::refine`). The nodes it
/// adds on the cell surface (not hanging) are moved radially onto the sphere, so the
/// surface a plate or a pipette meets is the sphere sampled at the finer spacing. Done
/// after the FAs are snapped: the FA nodes and the filaments do not move.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct PoleRefinement {
    /// Levels of splitting (0: none; each halves the element size).
    pub levels: u8,
    /// Radius of the refined region around each pole point (µm).
    pub radius: f64,
}

/// Most levels of pole refinement accepted (each multiplies the refined elements by 8).
pub const MAX_POLE_REFINEMENT_LEVELS: u8 = 3;

/// Most hex8 a pole refinement may make (refined once everywhere, the fast mesh has
/// 22 528, the default 55 296, the fine one 116 032): the octree stops with an error as
/// soon as it would pass it.
pub const MAX_POLE_REFINED_ELEMENTS: usize = 1_000_000;

impl SuspendedCellParams {
    /// Checks every parameter; the error says what was expected and what was found.
    pub fn validate(&self) -> Result<(), CellGeometryError> {
        positive("cell_diameter", self.cell_diameter)?;
        positive("nucleus_diameter", self.nucleus_diameter)?;
        positive("centrosome_gap", self.centrosome_gap)?;
        if self.nucleus_diameter >= self.cell_diameter {
            return Err(CellGeometryError::NucleusNotInsideCell {
                nucleus_diameter: self.nucleus_diameter,
                cell_diameter: self.cell_diameter,
            });
        }
        let room = 0.5 * (self.cell_diameter - self.nucleus_diameter);
        if self.centrosome_gap >= room {
            return Err(CellGeometryError::CentrosomeOutsideCell {
                gap: self.centrosome_gap,
                max: room,
            });
        }
        if !(self.mt_clearance_margin >= 0.0 && self.mt_clearance_margin < self.centrosome_gap) {
            return Err(CellGeometryError::ClearanceMarginOutOfRange {
                margin: self.mt_clearance_margin,
                gap: self.centrosome_gap,
            });
        }
        let d = self.centrosome_direction;
        if !(d.iter().all(|c| c.is_finite()) && norm(d) > 0.0) {
            return Err(CellGeometryError::InvalidDirection {
                parameter: "centrosome_direction",
                found: d,
            });
        }
        if self.ifs_per_fa < 1 {
            return Err(CellGeometryError::TooFewIfsPerFa {
                found: self.ifs_per_fa,
            });
        }
        in_count_range("ifs_per_fa", self.ifs_per_fa, 1, MAX_IFS_PER_FA)?;
        in_count_range("mt_elements", self.mt_elements, 2, MAX_MT_ELEMENTS)?;
        in_count_range("actin.elements", self.af_elements, 1, MAX_MT_ELEMENTS)?;
        in_count_range(
            "intermediate.elements",
            self.if_elements,
            1,
            MAX_MT_ELEMENTS,
        )?;
        let r = self.pole_refinement;
        if r.levels > MAX_POLE_REFINEMENT_LEVELS {
            return Err(CellGeometryError::Refinement(format!(
                "expected refinement.levels from 0 to {MAX_POLE_REFINEMENT_LEVELS}; found {}",
                r.levels
            )));
        }
        if r.levels > 0 && !(r.radius.is_finite() && r.radius > 0.0) {
            return Err(CellGeometryError::Refinement(format!(
                "expected refinement.radius to be a positive length when refinement.levels > 0; \
                 found {} µm",
                r.radius
            )));
        }
        let d = self.density;
        for (key, n) in [
            ("density.extra_actin", d.extra_actin),
            ("density.extra_intermediate", d.extra_intermediate),
            ("density.extra_microtubules", d.extra_microtubules),
        ] {
            in_count_range(key, n, 0, MAX_EXTRA_FILAMENTS)?;
        }
        if let FaOrientation::Optimized { trials } = self.fa_orientation {
            in_count_range("fa_orientation.trials", trials, 0, MAX_ORIENTATION_TRIALS)?;
        }
        let (lo, hi) = (self.mt_bow_min, self.mt_bow_max);
        if !(lo >= 0.0 && lo <= hi && hi <= MAX_MT_BOW) {
            return Err(CellGeometryError::BowOutOfRange { min: lo, max: hi });
        }
        if !self.if_phase.is_finite() {
            return Err(CellGeometryError::NotFinite {
                parameter: "if_phase",
                found: self.if_phase,
            });
        }
        Ok(())
    }

    /// The centrosome position: `centrosome_gap` outside the nucleus surface along
    /// `centrosome_direction`.
    pub fn centrosome(&self) -> V3 {
        scale(
            normalize(self.centrosome_direction),
            0.5 * self.nucleus_diameter + self.centrosome_gap,
        )
    }
}

fn positive(parameter: &'static str, value: f64) -> Result<(), CellGeometryError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(CellGeometryError::NotPositive {
            parameter,
            found: value,
        })
    }
}

fn in_count_range(
    parameter: &'static str,
    value: usize,
    min: usize,
    max: usize,
) -> Result<(), CellGeometryError> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(CellGeometryError::CountOutOfRange {
            parameter,
            min,
            max,
            found: value,
        })
    }
}

/// Why a suspended-cell geometry could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CellGeometryError {
    /// The pole refinement is out of range or could not be made.
    #[error("refinement: {0}")]
    Refinement(String),
    /// A size is zero, negative or not finite.
    #[error("expected {parameter} to be a positive finite length in µm; found {found}")]
    NotPositive {
        /// Parameter name.
        parameter: &'static str,
        /// Value given.
        found: f64,
    },
    /// A number is not finite.
    #[error("expected {parameter} to be a finite number; found {found}")]
    NotFinite {
        /// Parameter name.
        parameter: &'static str,
        /// Value given.
        found: f64,
    },
    /// The nucleus does not fit inside the cell.
    #[error(
        "expected the nucleus diameter to be smaller than the cell diameter ({cell_diameter} µm); \
         found {nucleus_diameter} µm"
    )]
    NucleusNotInsideCell {
        /// Nucleus diameter given (µm).
        nucleus_diameter: f64,
        /// Cell diameter given (µm).
        cell_diameter: f64,
    },
    /// The centrosome would be on or outside the cell surface.
    #[error(
        "expected centrosome_gap (distance of the centrosome from the nucleus surface) below \
         {max} µm so that the centrosome is inside the cell; found {gap} µm"
    )]
    CentrosomeOutsideCell {
        /// Gap given (µm).
        gap: f64,
        /// Distance from the nucleus to the cell surface (µm).
        max: f64,
    },
    /// The MT clearance margin is negative or not below the centrosome gap.
    #[error(
        "expected mt_clearance_margin in [0, centrosome_gap = {gap} µm) (the MTs start at the \
         centrosome); found {margin} µm"
    )]
    ClearanceMarginOutOfRange {
        /// Margin given (µm).
        margin: f64,
        /// Centrosome gap (µm).
        gap: f64,
    },
    /// A direction is zero or not finite.
    #[error("expected {parameter} to be a non-zero finite vector; found {found:?}")]
    InvalidDirection {
        /// Parameter name.
        parameter: &'static str,
        /// Value given.
        found: [f64; 3],
    },
    /// No IF per FA.
    #[error(
        "expected at least 1 intermediate filament per focal adhesion (the spec asks for 2); \
         found {found}"
    )]
    TooFewIfsPerFa {
        /// Value given.
        found: usize,
    },
    /// A count is outside its accepted range.
    #[error("expected {parameter} between {min} and {max}; found {found}")]
    CountOutOfRange {
        /// Parameter name.
        parameter: &'static str,
        /// Smallest accepted value.
        min: usize,
        /// Largest accepted value.
        max: usize,
        /// Value given.
        found: usize,
    },
    /// The MT bow range is invalid.
    #[error(
        "expected 0 ≤ mt_bow_min ≤ mt_bow_max ≤ {MAX_MT_BOW} (fractions of the chord); found \
         mt_bow_min = {min}, mt_bow_max = {max}"
    )]
    BowOutOfRange {
        /// Lower bound given.
        min: f64,
        /// Upper bound given.
        max: f64,
    },
    /// The continuum mesh could not be generated.
    #[error("continuum mesh: {0}")]
    Mesh(#[from] GenerateError),
    /// Two FA sites have the same nearest surface node (mesh too coarse).
    #[error(
        "expected every focal adhesion to snap to its own surface node; FAs {first} and \
         {second} both snap to node {node} (refine the mesh: more core_divisions)"
    )]
    FaSnapCollision {
        /// First FA index.
        first: usize,
        /// Second FA index.
        second: usize,
        /// The shared node.
        node: usize,
    },
    /// Snapping inverted an element.
    #[error(
        "expected positive Jacobians after snapping the focal adhesions; element {element} of \
         block '{block}' has {min_jacobian} at a Gauss point"
    )]
    InvertedAfterSnap {
        /// Block name.
        block: String,
        /// Element index in the block.
        element: usize,
        /// Smallest Gauss-point Jacobian found.
        min_jacobian: f64,
    },
    /// An MT element comes too close to the nucleus.
    #[error(
        "expected every microtubule to stay at least {required} µm from the nucleus surface; \
         MT {microtubule} comes within {clearance} µm"
    )]
    MicrotubuleTooClose {
        /// MT index (= FA index).
        microtubule: usize,
        /// Its smallest distance from the nucleus surface (µm).
        clearance: f64,
        /// The margin required (µm).
        required: f64,
    },
    /// No nucleus-surface node is visible from an FA.
    #[error(
        "expected nucleus-surface nodes visible from focal adhesion node {fa_node}; found none"
    )]
    NoVisibleNucleusNode {
        /// The FA node.
        fa_node: usize,
    },
    /// The mesh has fewer places for extra filaments than asked for.
    #[error(
        "expected {key} at most {available} on this mesh ({what}); found {requested} (lower \
         it or refine the mesh)"
    )]
    TooManyExtraFilaments {
        /// The scenario key.
        key: &'static str,
        /// Count asked for.
        requested: usize,
        /// Count that could be placed.
        available: usize,
        /// What the candidates are.
        what: &'static str,
    },
}

/// Measured quality of a built geometry (lengths in µm).
#[derive(Debug, Clone, PartialEq)]
pub struct GeometryReport {
    /// Number of hex8 elements.
    pub hex8_elements: usize,
    /// Largest distance a surface node moved to become an FA.
    pub max_snap_distance: f64,
    /// Largest snap distance over the mean surface edge length at that node.
    pub max_relative_snap_distance: f64,
    /// Nodes moved by the snap (FA nodes and the cytoplasm columns beneath them).
    pub moved_nodes: usize,
    /// Smallest Gauss-point Jacobian of the elements touching moved nodes (> 0).
    pub min_gauss_jacobian_after_snap: f64,
    /// Smallest scaled Jacobian of those elements before the snap.
    pub min_scaled_jacobian_before_snap: f64,
    /// Smallest scaled Jacobian of those elements after the snap.
    pub min_scaled_jacobian_after_snap: f64,
    /// Length of every AF (all equal: the icosidodecahedron edge, `R/φ`).
    pub af_length: f64,
    /// Smallest distance of any MT element from the nucleus surface.
    pub min_mt_clearance: f64,
    /// Smallest and largest per-MT maximum discrete curvature (1/µm).
    pub mt_curvature_range: (f64, f64),
    /// Largest distance from an IF anchor node to its ideal tangent point.
    pub max_if_anchor_error: f64,
    /// Mean of those distances.
    pub mean_if_anchor_error: f64,
    /// Largest deviation from 90° of the angle between an IF and the nucleus radius at its
    /// anchor (degrees).
    pub max_if_tangency_error_deg: f64,
    /// Largest depth by which a straight IF enters the nucleus sphere (0 with
    /// [`IfAnchorRule::NearestVisible`]).
    pub max_if_nucleus_penetration: f64,
    /// IFs sharing their anchor node with another IF.
    pub shared_if_anchors: usize,
    /// Surface nodes tied into FA plaques (0 with `fa_radius` 0 or a plaque smaller than
    /// the mesh spacing at the FAs).
    pub fa_plaque_nodes: usize,
}

/// The suspended cell's geometry: continuum mesh with FA nodes and the discrete
/// cytoskeleton's routing. Lengths in µm; the cell centre is the origin.
#[derive(Debug, Clone, PartialEq)]
pub struct SuspendedCellGeometry {
    /// Hex8 mesh: blocks `nucleus`, `cytoplasm`; node sets of `sphere_mesh` plus
    /// `focal_adhesions`, `fa_<k>` (k = 0..29, one node each) and `if_anchors`.
    pub mesh: Mesh,
    /// FA node per icosidodecahedron vertex, in vertex order.
    pub fa_nodes: Vec<usize>,
    /// Rotation applied to the canonical icosidodecahedron (rows first).
    pub fa_rotation: M3,
    /// AFs: the 60 edges as `[FA node, FA node]`.
    pub af_edges: Vec<[usize; 2]>,
    /// Centrosome position (not a mesh node; see [`Self::append_microtubule_nodes`]).
    pub centrosome: V3,
    /// One MT per FA, in FA order.
    pub microtubules: Vec<MicrotubulePath>,
    /// IFs as `[FA node, nucleus-surface node]`, `ifs_per_fa` consecutive ones per FA.
    pub intermediate_filaments: Vec<[usize; 2]>,
    /// The density variant's extra AFs, IFs and MTs (empty by default; see
    /// [`density`]).
    pub extra: density::DensityLayout,
    /// Measured quality.
    pub report: GeometryReport,
    /// Ties of the hanging nodes of a pole refinement (empty without one).
    pub hanging: Vec<cellmech_fem::mesh::refine::HangingNode>,
    /// Every linear tie of the mesh: the hanging nodes' and the FA plaques' (`fa_radius`),
    /// with no chains (equal to `hanging` without plaques).
    pub ties: Vec<cellmech_fem::mesh::refine::HangingNode>,
    /// The outer boundary quads of a pole refinement, outward (a coarse face covered by
    /// finer ones excluded); empty without one (then the mesh is conforming).
    pub boundary_faces: Vec<[usize; 4]>,
}

impl SuspendedCellGeometry {
    /// Builds the geometry (deterministic for given parameters, seed included).
    pub fn build(params: &SuspendedCellParams) -> Result<Self, CellGeometryError> {
        params.validate()?;
        let cell_radius = 0.5 * params.cell_diameter;
        let nucleus_radius = 0.5 * params.nucleus_diameter;
        let res = params.mesh;
        let mut mesh = sphere_mesh(&SphereMeshSpec {
            radius: cell_radius,
            inner_radius: Some(nucleus_radius),
            core_divisions: res.core_divisions,
            shell_layers: res.shell_layers,
            outer_layers: res.outer_layers,
            core_fraction: res.core_fraction,
        })?;
        let surface_set = mesh.node_sets.get("surface").cloned().unwrap_or_default();
        let surface = geometry::SurfaceNodes::new(&mesh, &surface_set);
        let rotation =
            geometry::choose_orientation(&surface, cell_radius, params.fa_orientation, params.seed);
        let sites = geometry::fa_sites(&rotation, cell_radius);
        let snap = if params.fa_snap {
            geometry::snap_sites(&mut mesh, &surface, &sites, nucleus_radius)?
        } else {
            geometry::nearest_sites(&mesh, &surface, &sites)?
        };
        let fa_nodes = snap.fa_nodes.clone();
        let af_edges: Vec<[usize; 2]> = icosidodecahedron_edges(&std::array::from_fn(|k| sites[k]))
            .into_iter()
            .map(|[a, b]| [fa_nodes[a], fa_nodes[b]])
            .collect();
        let centrosome = params.centrosome();
        let routing = cytoskeleton::MicrotubuleRouting {
            centrosome,
            cell_radius,
            nucleus_radius,
            elements: params.mt_elements,
            bow_min: params.mt_bow_min,
            bow_max: params.mt_bow_max,
            clearance_margin: params.mt_clearance_margin,
            seed: params.seed,
        };
        let (microtubules, min_mt_clearance) =
            cytoskeleton::route_microtubules(&routing, &fa_nodes, &sites)?;
        let inner = mesh
            .node_sets
            .get("inner_surface")
            .cloned()
            .unwrap_or_default();
        let ifs = cytoskeleton::anchor_intermediate_filaments(
            &mesh,
            &inner,
            &fa_nodes,
            nucleus_radius,
            params.ifs_per_fa,
            params.if_phase,
            params.if_anchor_rule,
        )?;
        let extra = density::place(
            &density::DensityInput {
                mesh: &mesh,
                surface: &surface_set,
                inner: &inner,
                fa_nodes: &fa_nodes,
                nucleus_radius,
                min_actin_length: cell_radius / GOLDEN_RATIO,
                routing: &routing,
                seed: params.seed,
            },
            params.density,
        )?;
        let (mut mesh, hanging, boundary_faces) =
            refine_poles(mesh, params.pole_refinement, cell_radius, nucleus_radius)?;
        // The surface quads, for the linear plaque weights only (a pole refinement lists
        // them; a conforming mesh's are found, which cannot fail on this sphere mesh).
        let surface_faces = match params.fa_coupling {
            crate::cell::fa_plaque::FaCoupling::DistributingLinear if boundary_faces.is_empty() => {
                cellmech_fem::mesh::surface::boundary_quads(&mesh, None).unwrap_or_default()
            }
            crate::cell::fa_plaque::FaCoupling::DistributingLinear => boundary_faces.clone(),
            _ => Vec::new(),
        };
        let surface = mesh.node_sets["surface"].clone();
        let mut plaques = crate::cell::fa_plaque::tie_fa_plaques(
            &mut mesh,
            hanging.clone(),
            &surface,
            |_| false,
            &fa_nodes,
            params.fa_radius,
            params.fa_coupling,
            &surface_faces,
            params.fa_reference,
            &sites,
        );
        let (ties, fa_plaque_nodes) = (std::mem::take(&mut plaques.ties), plaques.plaque_nodes);
        // Where the filaments of each FA end: the FA node, or its coupling's reference node
        // (the mesh node itself stays in the FA node sets).
        let end = |fa: usize| plaques.filament_end(fa);
        let af_edges: Vec<[usize; 2]> = af_edges.iter().map(|&[a, b]| [end(a), end(b)]).collect();
        let mut microtubules = microtubules;
        for mt in &mut microtubules {
            mt.fa_node = end(mt.fa_node);
            if let Some(last) = mt.points.last_mut() {
                *last = mesh.nodes[mt.fa_node];
            }
        }
        let mut ifs = ifs;
        for f in &mut ifs.filaments {
            f[0] = end(f[0]);
        }
        mesh.insert_node_set("focal_adhesions", fa_nodes.clone());
        for (k, &n) in fa_nodes.iter().enumerate() {
            mesh.insert_node_set(format!("fa_{k}"), vec![n]);
        }
        mesh.insert_node_set("if_anchors", ifs.filaments.iter().map(|f| f[1]).collect());
        // Node sets of the extra filaments' ends, only when there are any (the default
        // model's mesh is unchanged).
        for (name, nodes) in [
            (
                "extra_actin_ends",
                extra.actin.iter().flatten().copied().collect::<Vec<_>>(),
            ),
            (
                "extra_intermediate_ends",
                extra.intermediate.iter().map(|f| f[0]).collect(),
            ),
            (
                "extra_intermediate_anchors",
                extra.intermediate.iter().map(|f| f[1]).collect(),
            ),
            (
                "extra_microtubule_ends",
                extra.microtubules.iter().map(|m| m.fa_node).collect(),
            ),
        ] {
            if !nodes.is_empty() {
                let mut nodes = nodes;
                nodes.sort_unstable();
                mesh.insert_node_set(name, nodes);
            }
        }
        let report = GeometryReport {
            hex8_elements: mesh.num_elements(),
            max_snap_distance: snap.max_snap_distance,
            max_relative_snap_distance: snap.max_relative_snap,
            moved_nodes: snap.moved_nodes,
            min_gauss_jacobian_after_snap: snap.min_gauss_jacobian,
            min_scaled_jacobian_before_snap: snap.min_scaled_jacobian.0,
            min_scaled_jacobian_after_snap: snap.min_scaled_jacobian.1,
            af_length: cell_radius / GOLDEN_RATIO,
            min_mt_clearance,
            mt_curvature_range: curvature_range(&microtubules),
            max_if_anchor_error: ifs.anchor_errors.iter().cloned().fold(0.0, f64::max),
            mean_if_anchor_error: ifs.anchor_errors.iter().sum::<f64>()
                / ifs.anchor_errors.len().max(1) as f64,
            max_if_tangency_error_deg: max_tangency_error_deg(&mesh, &ifs.filaments),
            max_if_nucleus_penetration: ifs
                .filaments
                .iter()
                .map(|&[f, a]| {
                    let d = cytoskeleton::segment_distance_to_origin(mesh.nodes[f], mesh.nodes[a]);
                    (nucleus_radius - d).max(0.0)
                })
                .fold(0.0, f64::max),
            shared_if_anchors: ifs.shared_anchors,
            fa_plaque_nodes,
        };
        Ok(Self {
            mesh,
            fa_nodes,
            fa_rotation: rotation,
            af_edges,
            centrosome,
            microtubules,
            intermediate_filaments: ifs.filaments,
            extra,
            report,
            hanging,
            ties,
            boundary_faces,
        })
    }

    /// Appends the centrosome and every MT's interior points to `mesh.nodes` (meant for a
    /// copy of [`Self::mesh`]), adds node set `centrosome`, and returns each MT's node chain:
    /// centrosome, interior nodes from the centrosome outwards, FA node. The FA MTs come
    /// first, then the density variant's extra MTs (their nodes after all of the FA MTs'),
    /// ending on their surface node.
    pub fn append_microtubule_nodes(&self, mesh: &mut Mesh) -> Vec<Vec<usize>> {
        let centrosome = mesh.nodes.len();
        mesh.nodes.push(self.centrosome);
        mesh.insert_node_set("centrosome", vec![centrosome]);
        self.microtubules
            .iter()
            .chain(&self.extra.microtubules)
            .map(|mt| {
                let mut chain = Vec::with_capacity(mt.points.len());
                chain.push(centrosome);
                let interior = mt.points.get(1..mt.points.len().saturating_sub(1));
                for &p in interior.unwrap_or(&[]) {
                    chain.push(mesh.nodes.len());
                    mesh.nodes.push(p);
                }
                chain.push(mt.fa_node);
                chain
            })
            .collect()
    }
}

/// Splits the elements near the poles ([`PoleRefinement`]); returns the mesh, its hanging
/// nodes and its outer boundary quads (the input unchanged with `levels` 0).
fn refine_poles(
    mesh: Mesh,
    refinement: PoleRefinement,
    cell_radius: f64,
    nucleus_radius: f64,
) -> Result<
    (
        Mesh,
        Vec<cellmech_fem::mesh::refine::HangingNode>,
        Vec<[usize; 4]>,
    ),
    CellGeometryError,
> {
    if refinement.levels == 0 {
        return Ok((mesh, Vec::new(), Vec::new()));
    }
    let poles = [[cell_radius, 0.0, 0.0], [-cell_radius, 0.0, 0.0]];
    let near = |corners: &[[f64; 3]; 8]| {
        corners
            .iter()
            .any(|c| poles.iter().any(|p| norm(sub(*c, *p)) <= refinement.radius))
    };
    let refined = cellmech_fem::mesh::refine::refine_hex8_within(
        &mesh,
        |corners, _| if near(corners) { refinement.levels } else { 0 },
        MAX_POLE_REFINED_ELEMENTS,
    )
    .map_err(|e| match e {
        cellmech_fem::mesh::refine::RefineError::TooManyElements { max } => {
            CellGeometryError::Refinement(format!(
                "expected at most {max} hex8 after refinement; refinement.levels = {} within \
                 {} µm of the poles makes more: lower refinement.levels or refinement.radius",
                refinement.levels, refinement.radius
            ))
        }
        e => CellGeometryError::Refinement(e.to_string()),
    })?;
    let mut out = refined.mesh;
    let hanging: std::collections::HashSet<usize> =
        refined.hanging.iter().map(|h| h.node).collect();
    for (set, radius) in [("surface", cell_radius), ("inner_surface", nucleus_radius)] {
        for &n in out.node_sets.get(set).cloned().unwrap_or_default().iter() {
            if n >= mesh.num_nodes() && !hanging.contains(&n) {
                let x = out.nodes[n];
                out.nodes[n] = scale(x, radius / norm(x));
            }
        }
    }
    Ok((out, refined.hanging, refined.boundary_faces))
}

/// Smallest and largest per-MT maximum curvature.
fn curvature_range(mts: &[MicrotubulePath]) -> (f64, f64) {
    mts.iter()
        .map(MicrotubulePath::max_curvature)
        .fold((f64::INFINITY, 0.0), |(lo, hi), k| (lo.min(k), hi.max(k)))
}

/// The angle between an IF and the nucleus radius at its anchor, in degrees.
pub fn if_radius_angle_deg(fa: V3, anchor: V3) -> f64 {
    angle(sub(fa, anchor), anchor).to_degrees()
}

/// Largest |angle − 90°| over the IFs.
fn max_tangency_error_deg(mesh: &Mesh, ifs: &[[usize; 2]]) -> f64 {
    ifs.iter()
        .map(|&[f, a]| (if_radius_angle_deg(mesh.nodes[f], mesh.nodes[a]) - 90.0).abs())
        .fold(0.0, f64::max)
}
