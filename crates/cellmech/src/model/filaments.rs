//! Filament identity: which elements of a filament group make up one filament (one MT from
//! the centrosome to its FA, one AF between two FAs, one IF from an FA to the nucleus), and
//! where those elements end up in the engine's family terms, so that the writers can report
//! per-filament results.
//!
//! A [`FilamentSpec`] group lists its filaments as consecutive runs of its elements
//! ([`Filament`]), each run a chain from the filament's start node to its end node. The
//! builder that creates the group knows the filaments (the suspended cell: one MT per
//! chain, one AF per edge, one IF per FA–anchor pair) and which end sits on a focal
//! adhesion; a scenario's `[[filament]]` group gets [`Filament::chains`]: maximal runs of
//! consecutive elements in which each element starts where the previous one ends, with no
//! FA end.
//!
//! Ids are assigned by [`FilamentIndex::new`] over all groups in spec order (switched-off
//! groups included, so switching a family off does not renumber the others): `id` is unique
//! in the model, `index` counts the filaments of one family.

use std::ops::Range;

use cellmech_fem::mesh::Mesh;

pub use super::filament::{Filament, FilamentEnd};
use super::structures::{filament_families, FilamentElement, FilamentSpec, StructuresSpec};

/// Checks that `group.filaments` cover its elements exactly once, in order, each as a
/// connected chain.
pub fn check_filaments(group: &FilamentSpec) -> Result<(), String> {
    let mut next = 0;
    for (k, f) in group.filaments.iter().enumerate() {
        if f.elements.start != next || f.elements.end <= f.elements.start {
            return Err(format!(
                "group '{}': filament {k} has elements {:?}; expected a non-empty run starting \
                 at element {next} (the filaments must cover the elements in order)",
                group.name, f.elements
            ));
        }
        if f.elements.end > group.pairs.len() {
            return Err(format!(
                "group '{}': filament {k} has elements {:?}; the group has {}",
                group.name,
                f.elements,
                group.pairs.len()
            ));
        }
        for e in f.elements.start + 1..f.elements.end {
            if group.pairs[e][0] != group.pairs[e - 1][1] {
                return Err(format!(
                    "group '{}': filament {k} is not a chain: element {e} starts at node {}, \
                     element {} ends at node {}",
                    group.name,
                    group.pairs[e][0],
                    e - 1,
                    group.pairs[e - 1][1]
                ));
            }
        }
        next = f.elements.end;
    }
    if next != group.pairs.len() {
        return Err(format!(
            "group '{}': the filaments cover {next} of {} elements",
            group.name,
            group.pairs.len()
        ));
    }
    Ok(())
}

/// A filament family of the model.
#[derive(Debug, Clone, PartialEq)]
pub struct FilamentFamily {
    /// Family name (curve-column prefix).
    pub name: String,
    /// Beams (straightness is reported) or trusses.
    pub beams: bool,
    /// Index of the family's engine term in the problem's terms (`None`: switched off).
    pub term: Option<usize>,
    /// Whether any of its filaments has an FA end (then its FA-end force sum is reported).
    pub has_fa_end: bool,
}

/// One enabled filament, located in its family's engine term.
#[derive(Debug, Clone, PartialEq)]
pub struct IndexedFilament {
    /// Unique in the model.
    pub id: usize,
    /// Index into [`FilamentIndex::families`].
    pub family: usize,
    /// Position among the filaments of its family.
    pub index: usize,
    /// Elements of the family's engine term, in order from start to end.
    pub elements: Range<usize>,
    /// Mesh nodes from the start to the end (`elements.len() + 1`).
    pub nodes: Vec<usize>,
    /// Which end is on a focal adhesion.
    pub fa_end: Option<FilamentEnd>,
    /// Largest axial stiffness EA of its elements (nN): the family's force scale.
    pub axial_stiffness: f64,
    /// Sum of the elements' stress-free lengths (µm): `L0·(1 + slack)/(1 + prestrain)` for
    /// trusses, `L0` for beams.
    pub stress_free_length: f64,
}

impl IndexedFilament {
    /// The FA node (the start node for [`FilamentEnd::Both`]).
    pub fn fa_node(&self) -> Option<usize> {
        match self.fa_end? {
            FilamentEnd::Start | FilamentEnd::Both => self.nodes.first().copied(),
            FilamentEnd::End => self.nodes.last().copied(),
        }
    }

    /// Element of the family term at the FA end.
    pub fn fa_element(&self) -> Option<usize> {
        match self.fa_end? {
            FilamentEnd::Start | FilamentEnd::Both => Some(self.elements.start),
            FilamentEnd::End => Some(self.elements.end - 1),
        }
    }
}

/// Every enabled filament of a built model and its place in the engine terms.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FilamentIndex {
    /// Every filament family of the spec (enabled or not), in order of first appearance.
    pub families: Vec<FilamentFamily>,
    /// The enabled filaments, by id.
    pub filaments: Vec<IndexedFilament>,
}

impl FilamentIndex {
    /// Locates the filaments of `spec`; the family terms made by
    /// [`super::structures::structure_terms`] start at term index `first_term`.
    pub fn new(spec: &StructuresSpec, mesh: &Mesh, first_term: usize) -> Result<Self, String> {
        let enabled = filament_families(spec);
        let mut families: Vec<FilamentFamily> = Vec::new();
        for g in &spec.filaments {
            check_filaments(g)?;
            if families.iter().all(|f| f.name != g.family) {
                families.push(FilamentFamily {
                    name: g.family.clone(),
                    beams: matches!(g.element, FilamentElement::Beam(_)),
                    term: enabled
                        .iter()
                        .position(|&n| n == g.family)
                        .map(|k| first_term + k),
                    has_fa_end: false,
                });
            }
        }
        let mut filaments = Vec::new();
        let mut per_family = vec![0usize; families.len()];
        // Offset of the next enabled group's elements in its family term.
        let mut offsets = vec![0usize; families.len()];
        let mut id = 0;
        for g in &spec.filaments {
            let family = families
                .iter()
                .position(|f| f.name == g.family)
                .unwrap_or(0);
            for f in &g.filaments {
                let index = per_family[family];
                per_family[family] += 1;
                id += 1;
                if !g.enabled {
                    continue;
                }
                families[family].has_fa_end |= f.fa_end.is_some();
                let pairs = &g.pairs[f.elements.clone()];
                let mut nodes: Vec<usize> = pairs.iter().map(|p| p[0]).collect();
                nodes.extend(pairs.last().map(|p| p[1]));
                let length = |p: &[usize; 2]| {
                    let (a, b) = (mesh.nodes[p[0]], mesh.nodes[p[1]]);
                    (0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt()
                };
                let (axial_stiffness, stress_free_length) = match &g.element {
                    FilamentElement::Truss(law) => (
                        law.axial_stiffness(),
                        pairs
                            .iter()
                            .map(|p| law.stress_free_length(length(p)))
                            .sum(),
                    ),
                    FilamentElement::Beam(s) => {
                        (s.axial_stiffness(), pairs.iter().map(length).sum())
                    }
                };
                let start = offsets[family] + f.elements.start;
                filaments.push(IndexedFilament {
                    id: id - 1,
                    family,
                    index,
                    elements: start..start + f.elements.len(),
                    nodes,
                    fa_end: f.fa_end,
                    axial_stiffness,
                    stress_free_length,
                });
            }
            if g.enabled {
                offsets[family] += g.pairs.len();
            }
        }
        Ok(FilamentIndex {
            families,
            filaments,
        })
    }

    /// Per element of engine term `term`: the filament id and the family index (as cell data
    /// for a viewer); `None` for a term that is not a filament family.
    pub fn term_cell_ids(&self, term: usize) -> Option<(Vec<f64>, Vec<f64>)> {
        let family = self.families.iter().position(|f| f.term == Some(term))?;
        let mut ids = Vec::new();
        let mut families = Vec::new();
        for f in self.filaments.iter().filter(|f| f.family == family) {
            if ids.len() < f.elements.end {
                ids.resize(f.elements.end, f64::NAN);
                families.resize(f.elements.end, family as f64);
            }
            for e in f.elements.clone() {
                ids[e] = f.id as f64;
            }
        }
        Some((ids, families))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cellmech_fem::element::beam::BeamSection;
    use cellmech_fem::material::AxialLaw;

    fn group(name: &str, family: &str, pairs: Vec<[usize; 2]>, beam: bool) -> FilamentSpec {
        FilamentSpec {
            name: name.into(),
            family: family.into(),
            filaments: Filament::chains(&pairs),
            pairs,
            element: if beam {
                FilamentElement::Beam(BeamSection::solid_circular(1.0, 0.3, 0.1).unwrap())
            } else {
                FilamentElement::Truss(AxialLaw::linear(2.0, 3.0).with_prestrain(0.25))
            },
            enabled: true,
        }
    }

    #[test]
    fn chains_split_where_an_element_does_not_continue_the_previous_one() {
        let f = Filament::chains(&[[0, 1], [1, 2], [5, 6], [6, 7], [7, 8], [2, 3]]);
        let runs: Vec<_> = f.iter().map(|f| f.elements.clone()).collect();
        assert_eq!(runs, vec![0..2, 2..5, 5..6]);
        assert!(f.iter().all(|f| f.fa_end.is_none()));
        assert!(Filament::chains(&[]).is_empty());
        let c = Filament::consecutive(&[2, 3], Some(FilamentEnd::End));
        assert_eq!(c[1].elements, 2..5);
    }

    #[test]
    fn bad_filament_lists_are_rejected() {
        let mut g = group("g", "g", vec![[0, 1], [1, 2], [3, 4]], false);
        assert!(check_filaments(&g).is_ok());
        g.filaments = Filament::one_per_element(2, None);
        assert!(check_filaments(&g).unwrap_err().contains("cover 2 of 3"));
        g.filaments = vec![Filament {
            elements: 0..3,
            fa_end: None,
        }];
        assert!(check_filaments(&g).unwrap_err().contains("not a chain"));
    }

    #[test]
    fn ids_count_disabled_groups_and_elements_are_located_in_the_family_term() {
        let mesh = Mesh {
            nodes: (0..10).map(|i| [i as f64, 0.0, 0.0]).collect(),
            ..Mesh::default()
        };
        let a = group("a", "cables", vec![[0, 1], [1, 2], [4, 5]], false);
        let mut off = group("off", "rods", vec![[5, 6]], true);
        off.enabled = false;
        let b = group("b", "cables", vec![[6, 7], [8, 9]], false);
        let spec = StructuresSpec {
            filaments: vec![a, off, b],
            membranes: Vec::new(),
        };
        let index = FilamentIndex::new(&spec, &mesh, 3).unwrap();
        assert_eq!(index.families.len(), 2);
        assert_eq!(index.families[0].term, Some(3));
        assert_eq!(index.families[1].term, None);
        let ids: Vec<usize> = index.filaments.iter().map(|f| f.id).collect();
        assert_eq!(ids, vec![0, 1, 3, 4]);
        let f = &index.filaments[2];
        assert_eq!((f.index, f.elements.clone()), (2, 3..4));
        assert_eq!(f.nodes, vec![6, 7]);
        // Two elements of length 1 with prestrain 25 %: stress-free 2/1.25.
        assert!((index.filaments[0].stress_free_length - 1.6).abs() < 1e-15);
        assert_eq!(index.filaments[0].axial_stiffness, 6.0);
        let (cell_ids, fam) = index.term_cell_ids(3).unwrap();
        assert_eq!(cell_ids, vec![0.0, 0.0, 1.0, 3.0, 4.0]);
        assert_eq!(fam, vec![0.0; 5]);
        assert!(index.term_cell_ids(4).is_none());
    }
}
