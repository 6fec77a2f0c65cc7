//! Decoupled (isochoric/volumetric) compressible neo-Hookean law.
//! TODO(helper: hex8+material): implement and verify.

/// ψ(F) = G/2 (J^{-2/3} I₁ − 3) + K/2 (J − 1)², internal units kPa.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct NeoHookean {
    /// Shear modulus G (kPa).
    pub shear_modulus: f64,
    /// Bulk modulus K (kPa).
    pub bulk_modulus: f64,
}
