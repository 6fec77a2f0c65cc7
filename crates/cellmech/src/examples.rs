//! Scenarios shipped with cellmech (the files in `examples/`), embedded in the binary.

use std::path::Path;

use crate::scenario::{parse, Scenario, ScenarioError};

/// A shipped example scenario.
#[derive(Debug, Clone, Copy)]
pub struct Example {
    /// Name (the file stem in `examples/`).
    pub name: &'static str,
    /// One line on what it models.
    pub summary: &'static str,
    /// The scenario text.
    pub text: &'static str,
}

/// Every shipped example.
pub const EXAMPLES: &[Example] = &[
    Example {
        name: "suspended-tension",
        summary: "suspended bendo-tensegrity cell pulled by micropipettes to 6.3 um (default)",
        text: include_str!("../../../examples/suspended-tension.toml"),
    },
    Example {
        name: "suspended-compression",
        summary: "suspended bendo-tensegrity cell between microplates to 10, 30 and 50 %",
        text: include_str!("../../../examples/suspended-compression.toml"),
    },
    Example {
        name: "sphere-compression",
        summary: "soft neo-Hookean sphere squeezed by its polar caps to 30 %",
        text: include_str!("../../../examples/sphere-compression.toml"),
    },
    Example {
        name: "prestressed-sphere",
        summary: "prestressed tension-only cable network finding its equilibrium in a soft sphere",
        text: include_str!("../../../examples/prestressed-sphere.toml"),
    },
    Example {
        name: "block-uniaxial",
        summary: "neo-Hookean block stretched to twice its length (closed-form check)",
        text: include_str!("../../../examples/block-uniaxial.toml"),
    },
    Example {
        name: "plate-compression",
        summary: "sphere between two rigid frictionless plates, 30 % compression",
        text: include_str!("../../../examples/plate-compression.toml"),
    },
    Example {
        name: "adherent-afm-apex",
        summary: "adherent cell indented by a 200 nm AFM tip at the apex",
        text: include_str!("../../../examples/adherent-afm-apex.toml"),
    },
    Example {
        name: "adherent-afm-receptor",
        summary: "adherent cell indented by a 200 nm AFM tip at a receptor (FA)",
        text: include_str!("../../../examples/adherent-afm-receptor.toml"),
    },
    Example {
        name: "afm-indentation",
        summary: "paraboloid AFM tip indenting a soft layer (quarter model)",
        text: include_str!("../../../examples/afm-indentation.toml"),
    },
    Example {
        name: "colloidal-probe",
        summary: "rigid bead indenting a soft layer, against Hertz (quarter model)",
        text: include_str!("../../../examples/colloidal-probe.toml"),
    },
    Example {
        name: "pipette-tension",
        summary: "bonded micropipettes: contact, unload to zero force, stretch",
        text: include_str!("../../../examples/pipette-tension.toml"),
    },
];

/// The example run by `cellmech run` without a scenario.
pub const DEFAULT_EXAMPLE: &str = "suspended-tension";

/// The example with this name.
pub fn find(name: &str) -> Option<&'static Example> {
    EXAMPLES.iter().find(|e| e.name == name)
}

/// Parses a shipped example.
pub fn scenario(example: &Example) -> Result<Scenario, ScenarioError> {
    parse(
        example.text,
        &format!("<built-in: {}>", example.name),
        Path::new("."),
    )
}

/// The built-in default scenario.
pub fn default_scenario() -> Result<Scenario, ScenarioError> {
    let example = find(DEFAULT_EXAMPLE).ok_or_else(|| ScenarioError::Parse {
        path: "<built-in>".into(),
        message: format!("no example named {DEFAULT_EXAMPLE}"),
    })?;
    scenario(example)
}
