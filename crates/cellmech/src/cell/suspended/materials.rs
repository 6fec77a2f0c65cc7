//! Materials and sections of the suspended cell (internal units: kPa, µm). Their defaults
//! are declared in [`super::params::SUSPENDED_CELL`].

/// Actin filament material: Young's modulus (kPa), diameter (µm), prestrain.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ActinMaterial {
    /// Young's modulus (kPa).
    pub youngs_modulus: f64,
    /// Solid circular section diameter (µm).
    pub diameter: f64,
    /// Prestrain (0.24 = 24 %): stress-free length L0/(1 + prestrain).
    pub prestrain: f64,
}

/// Microtubule material and hollow section.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MicrotubuleMaterial {
    /// Young's modulus (kPa).
    pub youngs_modulus: f64,
    /// Outer diameter (µm).
    pub outer_diameter: f64,
    /// Inner diameter (µm).
    pub inner_diameter: f64,
    /// Poisson's ratio (shear modulus of the section).
    pub poisson_ratio: f64,
}

/// Intermediate filament material: tension only with slack.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct IntermediateMaterial {
    /// Young's modulus (kPa).
    pub youngs_modulus: f64,
    /// Solid circular section diameter (µm).
    pub diameter: f64,
    /// Slack (0.2 = 20 %): no force until the length exceeds (1 + slack) L0.
    pub slack: f64,
}

/// Material and section parameters of the suspended cell (internal units).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SuspendedCellMaterials {
    /// Cytoplasm shear modulus (kPa).
    pub cytoplasm_shear_modulus: f64,
    /// Cytoplasm Poisson's ratio (compressibility switch).
    pub cytoplasm_poisson_ratio: f64,
    /// Nucleus shear modulus (kPa).
    pub nucleus_shear_modulus: f64,
    /// Nucleus Poisson's ratio.
    pub nucleus_poisson_ratio: f64,
    /// Cell-membrane shear modulus (kPa).
    pub membrane_shear_modulus: f64,
    /// Cell-membrane thickness (µm).
    pub membrane_thickness: f64,
    /// Whether the cell membrane carries compression or wrinkles.
    pub membrane_law: crate::model::structures::MembraneLaw,
    /// Actin filaments.
    pub actin: ActinMaterial,
    /// Microtubules.
    pub microtubule: MicrotubuleMaterial,
    /// Intermediate filaments.
    pub intermediate: IntermediateMaterial,
}
