//! Material laws, separate from the elements that carry them.
//!
//! A law is a plain `Copy` data struct with no hidden state. Continuum laws implement
//! [`Hyperelastic`] (energy, Kirchhoff stress and spatial tangent of the isochoric part,
//! and the volumetric function), which is all the hex8 kernel uses: a new continuum law is
//! a new file here with one `impl Hyperelastic`. Axial laws (trusses, beams) map a stretch
//! to an axial force and its derivative.

mod hyperelastic;
mod neo_hookean;
pub use hyperelastic::Hyperelastic;
pub use neo_hookean::{NeoHookean, NeoHookeanError, VOIGT_PAIRS};

pub mod axial;
pub use axial::{AxialLaw, AxialLawError, AxialResponse};
