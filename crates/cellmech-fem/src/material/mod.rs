//! Material laws, separate from the elements that carry them.
//!
//! A law is a plain `Copy` data struct with no hidden state. Continuum laws map the
//! deformation gradient to energy, stress and tangent; axial laws (trusses, beams) map a
//! stretch to an axial force and its derivative.

mod neo_hookean;
pub use neo_hookean::{NeoHookean, NeoHookeanError, VOIGT_PAIRS};

pub mod axial;
pub use axial::{AxialLaw, AxialLawError, AxialResponse};
