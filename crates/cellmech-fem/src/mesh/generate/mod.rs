//! Built-in mesh generators: structured boxes and cubed-sphere (O-grid) balls, all of
//! 8-node hexahedra in Abaqus node order, plus the quality measures used to check them.
//!
//! - [`box_mesh`]: a structured brick of hex8 elements with face node sets;
//!   [`perturb_interior_nodes`] distorts its interior for patch tests.
//! - [`graded_box_mesh`]: the same from node coordinates per axis (a tensor-product mesh
//!   graded as [`AxisGrading`] says: fine at one end, growing geometrically).
//! - [`sphere_mesh`]: a ball (optionally with a concentric inner ball) meshed as a central
//!   cube surrounded by six radially extruded, equi-angular cube-face patches.
//! - [`quality`]: Jacobians, scaled Jacobian, edge ratio, volume, boundary faces.

mod box_mesh;
pub mod quality;
mod random;
mod sphere;

pub use box_mesh::{box_mesh, graded_box_mesh, perturb_interior_nodes, AxisGrading};
pub use quality::{boundary_faces, hex8_quality, MeshQuality};
pub use random::SplitMix64;
pub use sphere::{sphere_mesh, SphereMeshSpec};

/// Largest number of nodes a generator will create (guards against absurd divisions).
pub const MAX_GENERATED_NODES: usize = 50_000_000;

/// Invalid generator parameters.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GenerateError {
    /// A length-like parameter is not a positive finite number.
    #[error("expected {parameter} to be a positive finite number; found {found}")]
    NotPositive {
        /// Name of the parameter, e.g. `size[0]` or `radius`.
        parameter: String,
        /// The value given.
        found: f64,
    },
    /// A length that may be zero is negative or not finite.
    #[error("expected {parameter} to be a finite number ≥ 0; found {found}")]
    Negative {
        /// Name of the parameter.
        parameter: String,
        /// The value given.
        found: f64,
    },
    /// A coordinate is not finite.
    #[error("expected {parameter} to be a finite number; found {found}")]
    NotFinite {
        /// Name of the parameter.
        parameter: String,
        /// The value given.
        found: f64,
    },
    /// A number of divisions or layers is zero.
    #[error("expected {parameter} to be at least {min}; found {found}")]
    TooFewDivisions {
        /// Name of the parameter.
        parameter: String,
        /// Smallest accepted value.
        min: usize,
        /// The value given.
        found: usize,
    },
    /// The sphere's core divisions must be even so that a node sits at each pole.
    #[error(
        "expected an even core_divisions (so that nodes sit exactly at the poles and on the \
         axes); found {found}"
    )]
    OddCoreDivisions {
        /// The value given.
        found: usize,
    },
    /// The inner sphere is not strictly inside the outer one.
    #[error("expected inner_radius between 0 and radius ({radius}); found {inner_radius}")]
    InnerRadiusOutOfRange {
        /// The outer radius.
        radius: f64,
        /// The inner radius given.
        inner_radius: f64,
    },
    /// The central cube does not fit inside the sphere it sits in.
    #[error("expected core_fraction in (0, {max:.4}) so that the central cube fits inside its sphere; found {found}")]
    CoreFractionOutOfRange {
        /// Largest accepted value (exclusive).
        max: f64,
        /// The value given.
        found: f64,
    },
    /// The requested mesh would be too large.
    #[error("the requested mesh would have about {nodes} nodes, more than the limit of {max}")]
    TooLarge {
        /// Estimated number of nodes.
        nodes: f64,
        /// The limit ([`MAX_GENERATED_NODES`]).
        max: usize,
    },
    /// Coordinates along an axis are not strictly increasing.
    #[error("expected strictly increasing coordinates; {parameter} = {found} follows {previous}")]
    NotIncreasing {
        /// The offending entry, e.g. `xs[3]`.
        parameter: String,
        /// The entry before it.
        previous: f64,
        /// The value given.
        found: f64,
    },
    /// A grading's growth ratio is below 1 or not finite.
    #[error("expected a grading growth ratio ≥ 1 (1 is uniform); found {found}")]
    GrowthOutOfRange {
        /// The value given.
        found: f64,
    },
    /// The perturbation amplitude is outside `[0, 0.5)`.
    #[error("expected amplitude_fraction in [0, 0.5); found {found}")]
    AmplitudeOutOfRange {
        /// The value given.
        found: f64,
    },
    /// The operation supports only hex8 blocks.
    #[error("expected only hex8 element blocks; block '{block}' holds {kind} elements")]
    UnsupportedElementKind {
        /// The offending block.
        block: String,
        /// Its element kind's name.
        kind: &'static str,
    },
}

/// Checks that `value` is a positive finite number.
fn require_positive(parameter: &str, value: f64) -> Result<(), GenerateError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(GenerateError::NotPositive {
            parameter: parameter.to_string(),
            found: value,
        })
    }
}

/// Checks that `value` is at least `min`.
fn require_at_least(parameter: &str, value: usize, min: usize) -> Result<(), GenerateError> {
    if value >= min {
        Ok(())
    } else {
        Err(GenerateError::TooFewDivisions {
            parameter: parameter.to_string(),
            min,
            found: value,
        })
    }
}

/// Checks an estimated node count against [`MAX_GENERATED_NODES`].
fn require_reasonable_size(estimated_nodes: f64) -> Result<(), GenerateError> {
    if estimated_nodes <= MAX_GENERATED_NODES as f64 {
        Ok(())
    } else {
        Err(GenerateError::TooLarge {
            nodes: estimated_nodes,
            max: MAX_GENERATED_NODES,
        })
    }
}
