//! One filament's identity: which run of its group's elements it is and which end sits on
//! a focal adhesion. Plain data, used by the structure specs ([`super::structures`]) and
//! indexed for the writers by [`super::filaments::FilamentIndex`].

use std::ops::Range;

/// Which end(s) of a filament sit on a focal adhesion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FilamentEnd {
    /// The first node of the chain (e.g. an IF from its FA to the nucleus).
    Start,
    /// The last node of the chain (e.g. an MT from the centrosome to its FA).
    End,
    /// Both ends (an AF between two FAs); forces are reported at the start.
    Both,
}

/// One filament of a group: a run of the group's elements from one end to the other.
#[derive(Debug, Clone, PartialEq)]
pub struct Filament {
    /// Indices into the group's `pairs`, in order from the start node to the end node; each
    /// element starts at the node where the previous one ends.
    pub elements: Range<usize>,
    /// Which end is on a focal adhesion, if any.
    pub fa_end: Option<FilamentEnd>,
}

impl Filament {
    /// One filament per element (e.g. the AFs or IFs of a cell), all with the same FA end.
    pub fn one_per_element(count: usize, fa_end: Option<FilamentEnd>) -> Vec<Filament> {
        (0..count)
            .map(|e| Filament {
                elements: e..e + 1,
                fa_end,
            })
            .collect()
    }

    /// Consecutive filaments of `counts[k]` elements each (e.g. the MTs of a cell, whose
    /// chains are concatenated in the group's pairs), all with the same FA end.
    pub fn consecutive(counts: &[usize], fa_end: Option<FilamentEnd>) -> Vec<Filament> {
        let mut start = 0;
        counts
            .iter()
            .map(|&m| {
                let f = Filament {
                    elements: start..start + m,
                    fa_end,
                };
                start += m;
                f
            })
            .collect()
    }

    /// The generic rule for a group without known filaments: maximal runs of consecutive
    /// elements in which each element starts at the node the previous one ends at; no FA end.
    pub fn chains(pairs: &[[usize; 2]]) -> Vec<Filament> {
        let mut out = Vec::new();
        let mut start = 0;
        for e in 1..=pairs.len() {
            if e == pairs.len() || pairs[e][0] != pairs[e - 1][1] {
                out.push(Filament {
                    elements: start..e,
                    fa_end: None,
                });
                start = e;
            }
        }
        out
    }
}
