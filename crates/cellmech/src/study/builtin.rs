//! The built-in studies (`cellmech study --list`): the published batteries of the
//! suspended and the adherent cell. Their text is in `studies/*.toml` of the repository.

/// A built-in study.
#[derive(Debug, Clone, Copy)]
pub struct BuiltinStudy {
    /// Name (`cellmech study NAME`).
    pub name: &'static str,
    /// One line on what it shows.
    pub summary: &'static str,
    /// The study file.
    pub text: &'static str,
}

/// Every built-in study.
pub const BUILTIN: &[BuiltinStudy] = &[
    BuiltinStudy {
        name: "suspended-tension-disruption",
        summary: "tension to 6.3 um with every combination of AF, MT and IF removed (8 cases)",
        text: include_str!("../../../../studies/suspended-tension-disruption.toml"),
    },
    BuiltinStudy {
        name: "suspended-compression-disruption",
        summary: "compression to 50 % with every combination of AF, MT and IF removed (8 cases)",
        text: include_str!("../../../../studies/suspended-compression-disruption.toml"),
    },
    BuiltinStudy {
        name: "suspended-tension-modulus",
        summary: "tension to 6.3 um with each component's modulus at 50 % and 150 % (13 cases)",
        text: include_str!("../../../../studies/suspended-tension-modulus.toml"),
    },
    BuiltinStudy {
        name: "suspended-compression-modulus",
        summary: "compression to 50 % with each component's modulus at 50 % and 150 % (13 cases)",
        text: include_str!("../../../../studies/suspended-compression-modulus.toml"),
    },
    BuiltinStudy {
        name: "suspended-tension-thickness",
        summary: "tension to 6.3 um with the cell membrane half and twice as thick (3 cases)",
        text: include_str!("../../../../studies/suspended-tension-thickness.toml"),
    },
    BuiltinStudy {
        name: "suspended-tension-compressibility",
        summary: "tension to 6.3 um with compressible cytoplasm and nucleus (nu 0.3) (2 cases)",
        text: include_str!("../../../../studies/suspended-tension-compressibility.toml"),
    },
    BuiltinStudy {
        name: "suspended-tension-density",
        summary: "tension to 6.3 um with 30 extra AFs, MTs or IFs at seeded new sites (4 cases)",
        text: include_str!("../../../../studies/suspended-tension-density.toml"),
    },
    BuiltinStudy {
        name: "suspended-tension-coupling",
        summary: "tension to 6.3 um: each cytoskeleton coupling mode x the 8 disruption models",
        text: include_str!("../../../../studies/suspended-tension-coupling.toml"),
    },
    BuiltinStudy {
        name: "suspended-tension-large",
        summary: "tension to 31.5 um (~100 %), no FA in the grips: free, centrosome-tied and embedded MTs x AF and MT removed (12 cases)",
        text: include_str!("../../../../studies/suspended-tension-large.toml"),
    },
    BuiltinStudy {
        name: "suspended-compression-coupling",
        summary: "compression to 50 %: free MTs, embedded (prestressed-cell) MTs and all filaments embedded x the 8 disruption models (24 cases)",
        text: include_str!("../../../../studies/suspended-compression-coupling.toml"),
    },
    BuiltinStudy {
        name: "adherent-afm-disruption",
        summary: "adherent cell, AFM at the apex to 1 um with 10 combinations of AC, AB, MT and IF removed (11 cases)",
        text: include_str!("../../../../studies/adherent-afm-disruption.toml"),
    },
    BuiltinStudy {
        name: "adherent-afm-modulus",
        summary: "adherent cell, AFM at the apex to 1 um with each component's modulus at 50 % and 150 % (13 cases)",
        text: include_str!("../../../../studies/adherent-afm-modulus.toml"),
    },
    BuiltinStudy {
        name: "adherent-afm-density",
        summary: "adherent cell, AFM at the apex to 1 um with 16 extra ABs, MTs or IFs at seeded new sites (4 cases)",
        text: include_str!("../../../../studies/adherent-afm-density.toml"),
    },
    BuiltinStudy {
        name: "adherent-afm-thickness",
        summary: "adherent cell, AFM at the apex to 1 um with the cortex half and twice as thick (3 cases)",
        text: include_str!("../../../../studies/adherent-afm-thickness.toml"),
    },
    BuiltinStudy {
        name: "adherent-afm-sites",
        summary: "adherent cell, AFM at the apex and at a receptor to 1 um, each with ABs, MTs or every filament removed (8 cases)",
        text: include_str!("../../../../studies/adherent-afm-sites.toml"),
    },
];

/// The built-in study with this name.
pub fn find(name: &str) -> Option<&'static BuiltinStudy> {
    BUILTIN.iter().find(|b| b.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_density_study_is_built_in_with_its_four_cases() {
        let b = find("suspended-tension-density").expect("built in");
        let spec =
            super::super::spec::parse(b.text, b.name, std::path::Path::new(".")).expect("parses");
        let names: Vec<String> = spec.cases().into_iter().map(|c| c.name).collect();
        assert_eq!(
            names,
            [
                "control",
                "extra-actin-30",
                "extra-microtubule-30",
                "extra-intermediate-30"
            ]
        );
        assert!(b.summary.contains("4 cases"));
    }
}
