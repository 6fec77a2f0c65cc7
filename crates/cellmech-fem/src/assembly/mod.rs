//! Parallel assembly of residual and tangent from any set of [`Term`]s.
//!
//! The pattern, the per-element scatter maps and an element colouring are built once per
//! model ([`Assembler::new`]). Each assembly then evaluates elements colour by colour with
//! fixed-size stack buffers: no allocation per iteration, no locks. Each colour is cut into
//! chunks of consecutive elements ([`chunk_length`], a function of the colour's size only);
//! inside a rayon pool of several threads the chunks of a colour run in parallel, one task
//! per chunk, elsewhere in order on the calling thread.
//!
//! Determinism: elements of one colour share no DOF and colours run in order, so every
//! residual and tangent entry receives its contributions in the same order whatever the
//! thread count; the energy is summed per chunk and the chunk sums in chunk order. The
//! result is bitwise identical on any number of threads.
//!
//! Prescribed DOFs (a mask that may change between analysis steps) keep their rows and
//! columns in the pattern: the assembler skips their couplings and puts 1 on their diagonal,
//! so changing boundary conditions never changes the pattern or the symbolic factorisation.
//! The full residual (including prescribed DOFs) is returned, which gives the reactions.

mod coloring;

use rayon::prelude::*;

use crate::dof::DofMap;
use crate::element::KernelError;
use crate::linsolve::SparsityPattern;
use crate::term::{Term, MAX_ELEMENT_DOFS};

/// An element kernel failed during assembly.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("element {element} of '{term}': {error}")]
pub struct AssemblyError {
    /// Name of the term (element set).
    pub term: String,
    /// Element index within the term.
    pub element: usize,
    /// What went wrong.
    pub error: KernelError,
}

/// Scatter layout of one term.
#[derive(Debug, Clone)]
struct TermLayout {
    /// Element `e` owns `dofs[dof_offsets[e]..dof_offsets[e+1]]`.
    dof_offsets: Vec<usize>,
    dofs: Vec<u32>,
    /// Element `e`'s lower-triangle value positions start at `map_offsets[e]`
    /// (local pairs (a, b), b <= a, row by row).
    map_offsets: Vec<usize>,
    map: Vec<u32>,
    colors: Vec<Vec<u32>>,
}

/// What one assembly call must produce.
pub struct AssemblyOutput<'a> {
    /// Full residual (internal forces) for all DOFs; overwritten.
    pub residual: &'a mut [f64],
    /// Sum of the absolute element contributions to each residual entry (the size of the
    /// internal forces that balance there, e.g. prestress); overwritten when `Some`.
    pub magnitude: Option<&'a mut [f64]>,
    /// Tangent values in the pattern's order; overwritten when `Some`.
    pub tangent: Option<&'a mut [f64]>,
    /// `K_fp · du_p` for the free rows (prescribed-motion predictor): `(du_p, out)`, where
    /// `du_p` holds the increments of prescribed DOFs (others ignored); `out` overwritten.
    pub predictor: Option<(&'a [f64], &'a mut [f64])>,
}

/// Builds the pattern once and assembles residual and tangent of any terms into it.
#[derive(Debug, Clone)]
pub struct Assembler {
    pattern: SparsityPattern,
    layouts: Vec<TermLayout>,
    /// Least elements per chunk ([`DEFAULT_MIN_CHUNK_ELEMENTS`]).
    min_chunk: usize,
}

/// Raw pointer that may be shared across threads because colouring guarantees that
/// concurrent writes go to disjoint indices.
#[derive(Clone, Copy)]
struct SharedMut(*mut f64);
unsafe impl Send for SharedMut {}
unsafe impl Sync for SharedMut {}

impl SharedMut {
    /// # Safety
    /// `i` is in bounds and no other thread accesses index `i` concurrently.
    unsafe fn add(self, i: usize, v: f64) {
        *self.0.add(i) += v;
    }
}

/// Default of [`Assembler::with_min_chunk_elements`]: a chunk holds at least this many
/// elements (unless the colour is smaller). Measured with
/// `cargo run --release -p cellmech-fem --example assembly_threads`
/// (`docs/performance.md`, section "Threads").
pub const DEFAULT_MIN_CHUNK_ELEMENTS: usize = 16;
/// A colour is cut into at most this many chunks (the chunk sums live on the stack).
const MAX_CHUNKS: usize = 64;

/// Elements per chunk for a colour of `len` elements: independent of the thread count, so
/// that the chunk sums (and hence the energy) are the same on any number of threads.
fn chunk_length(len: usize, min_chunk: usize) -> usize {
    min_chunk.max(1).max(len.div_ceil(MAX_CHUNKS))
}

impl Assembler {
    /// Builds the sparsity pattern over all DOFs of `dof_map`, the scatter maps and the
    /// colouring for `terms`. Call once per model.
    pub fn new(dof_map: &DofMap, terms: &[Box<dyn Term>]) -> Self {
        let n = dof_map.num_dofs();
        let mut layouts: Vec<TermLayout> = terms
            .iter()
            .map(|t| layout_dofs(t.as_ref(), dof_map))
            .collect();
        let cliques: Vec<Vec<usize>> = layouts
            .iter()
            .flat_map(|l| {
                (0..l.dof_offsets.len() - 1).map(move |e| {
                    l.dofs[l.dof_offsets[e]..l.dof_offsets[e + 1]]
                        .iter()
                        .map(|&d| d as usize)
                        .collect()
                })
            })
            .collect();
        let pattern = SparsityPattern::from_cliques(n, cliques.iter().map(Vec::as_slice));
        for layout in &mut layouts {
            fill_scatter_map(layout, &pattern);
            layout.colors = coloring::color_elements(n, &layout.dof_offsets, &layout.dofs);
        }
        Assembler {
            pattern,
            layouts,
            min_chunk: DEFAULT_MIN_CHUNK_ELEMENTS,
        }
    }

    /// Sets the least number of elements per parallel chunk (at most 64 chunks per colour
    /// whatever this is). The result does not depend on it except for the energy's
    /// round-off, which is the same on any thread count for a given value.
    pub fn with_min_chunk_elements(mut self, elements: usize) -> Self {
        self.min_chunk = elements.max(1);
        self
    }

    /// The sparsity pattern (lower triangle over all DOFs).
    pub fn pattern(&self) -> &SparsityPattern {
        &self.pattern
    }

    /// DOFs that no element couples (e.g. nodes of a removed filament family). The solver
    /// holds them fixed so the tangent stays non-singular.
    pub fn untouched_dofs(&self) -> Vec<bool> {
        let mut touched = vec![false; self.pattern.n];
        for layout in &self.layouts {
            for &d in &layout.dofs {
                touched[d as usize] = true;
            }
        }
        touched.iter().map(|t| !t).collect()
    }

    /// Number of elements of each colour, term by term (for diagnostics).
    pub fn color_sizes(&self) -> Vec<Vec<usize>> {
        self.layouts
            .iter()
            .map(|l| l.colors.iter().map(Vec::len).collect())
            .collect()
    }

    /// Number of colours of each term (for diagnostics).
    pub fn color_counts(&self) -> Vec<usize> {
        self.layouts.iter().map(|l| l.colors.len()).collect()
    }

    /// Assembles at DOF values `u` with prescribed-DOF mask `prescribed`. Returns the total
    /// internal energy. `terms` must be the same terms, in the same order, as in `new`.
    ///
    /// Runs in parallel on the rayon pool it is called in (call it inside
    /// `ThreadPool::install`, as [`crate::solve::Problem`] does; outside any pool rayon's
    /// global pool is used). The result does not depend on the number of threads. When
    /// elements fail, the error is the first failing element in colour order.
    pub fn assemble(
        &self,
        terms: &[Box<dyn Term>],
        u: &[f64],
        prescribed: &[bool],
        out: AssemblyOutput<'_>,
    ) -> Result<f64, AssemblyError> {
        debug_assert_eq!(terms.len(), self.layouts.len());
        out.residual.fill(0.0);
        let residual = SharedMut(out.residual.as_mut_ptr());
        let magnitude = out.magnitude.map(|m| {
            m.fill(0.0);
            SharedMut(m.as_mut_ptr())
        });
        let tangent = out.tangent.map(|t| {
            t.fill(0.0);
            SharedMut(t.as_mut_ptr())
        });
        let predictor = out.predictor.map(|(du, p)| {
            p.fill(0.0);
            (du, SharedMut(p.as_mut_ptr()))
        });
        let parallel = rayon::current_num_threads() > 1;
        let mut energy = 0.0;
        for (term, layout) in terms.iter().zip(&self.layouts) {
            let sink = Sink {
                residual,
                magnitude,
                tangent,
                predictor,
                prescribed,
            };
            for color in &layout.colors {
                let chunk_len = chunk_length(color.len(), self.min_chunk);
                let chunks = color.len().div_ceil(chunk_len);
                let mut sums = [0.0f64; MAX_CHUNKS];
                // Each chunk stops at its first failing element; the first chunk's failure
                // is reported, so the error does not depend on the schedule either.
                let run = |(sum, chunk): (&mut f64, &[u32])| -> Option<AssemblyError> {
                    for &e in chunk {
                        match assemble_element(term.as_ref(), layout, e as usize, u, &sink) {
                            Ok(energy) => *sum += energy,
                            Err(error) => return Some(error),
                        }
                    }
                    None
                };
                let failure = if parallel && chunks > 1 {
                    sums[..chunks]
                        .par_iter_mut()
                        .zip(color.par_chunks(chunk_len))
                        .with_max_len(1)
                        .map(run)
                        .reduce(|| None, |a, b| a.or(b))
                } else {
                    sums[..chunks]
                        .iter_mut()
                        .zip(color.chunks(chunk_len))
                        .find_map(run)
                };
                if let Some(error) = failure {
                    return Err(error);
                }
                energy += sums[..chunks].iter().sum::<f64>();
            }
        }
        if let Some(t) = tangent {
            for (d, _) in prescribed.iter().enumerate().filter(|(_, &p)| p) {
                let k = self.pattern.col_ptr[d]; // the diagonal is the first entry of its column
                                                 // SAFETY: single-threaded here, index in bounds.
                unsafe { *t.0.add(k) = 1.0 };
            }
        }
        Ok(energy)
    }
}

/// Where one element's results go.
struct Sink<'a> {
    residual: SharedMut,
    magnitude: Option<SharedMut>,
    tangent: Option<SharedMut>,
    predictor: Option<(&'a [f64], SharedMut)>,
    prescribed: &'a [bool],
}

fn assemble_element(
    term: &dyn Term,
    layout: &TermLayout,
    e: usize,
    u: &[f64],
    sink: &Sink<'_>,
) -> Result<f64, AssemblyError> {
    let dofs = &layout.dofs[layout.dof_offsets[e]..layout.dof_offsets[e + 1]];
    let n = dofs.len();
    let mut u_e = [0.0; MAX_ELEMENT_DOFS];
    let mut r_e = [0.0; MAX_ELEMENT_DOFS];
    let mut k_e = [0.0; MAX_ELEMENT_DOFS * MAX_ELEMENT_DOFS];
    for (ue, &d) in u_e.iter_mut().zip(dofs) {
        *ue = u[d as usize];
    }
    let want_tangent = sink.tangent.is_some() || sink.predictor.is_some();
    let energy = term
        .evaluate(
            e,
            &u_e[..n],
            &mut r_e[..n],
            want_tangent.then_some(&mut k_e[..n * n]),
        )
        .map_err(|error| AssemblyError {
            term: term.name().to_string(),
            element: e,
            error,
        })?;
    // SAFETY (all writes below): elements of one colour share no DOF, so no other thread
    // touches these residual entries or the pattern entries coupling these DOFs.
    for (a, &d) in dofs.iter().enumerate() {
        unsafe { sink.residual.add(d as usize, r_e[a]) };
    }
    if let Some(m) = sink.magnitude {
        for (a, &d) in dofs.iter().enumerate() {
            unsafe { m.add(d as usize, r_e[a].abs()) };
        }
    }
    if let Some(t) = sink.tangent {
        let map = &layout.map[layout.map_offsets[e]..];
        let mut k = 0;
        for a in 0..n {
            let free_a = !sink.prescribed[dofs[a] as usize];
            for b in 0..=a {
                if free_a && !sink.prescribed[dofs[b] as usize] {
                    unsafe { t.add(map[k] as usize, k_e[a * n + b]) };
                }
                k += 1;
            }
        }
    }
    if let Some((du, p)) = sink.predictor {
        for a in (0..n).filter(|&a| !sink.prescribed[dofs[a] as usize]) {
            let coupling: f64 = (0..n)
                .filter(|&b| sink.prescribed[dofs[b] as usize])
                .map(|b| k_e[a * n + b] * du[dofs[b] as usize])
                .sum();
            unsafe { p.add(dofs[a] as usize, coupling) };
        }
    }
    Ok(energy)
}

fn layout_dofs(term: &dyn Term, dof_map: &DofMap) -> TermLayout {
    let mut dof_offsets = Vec::with_capacity(term.num_elements() + 1);
    let mut dofs = Vec::new();
    let mut buffer = [0usize; MAX_ELEMENT_DOFS];
    dof_offsets.push(0);
    for e in 0..term.num_elements() {
        let n = term.element_dofs(e, dof_map, &mut buffer);
        dofs.extend(buffer[..n].iter().map(|&d| d as u32));
        dof_offsets.push(dofs.len());
    }
    TermLayout {
        dof_offsets,
        dofs,
        map_offsets: Vec::new(),
        map: Vec::new(),
        colors: Vec::new(),
    }
}

fn fill_scatter_map(layout: &mut TermLayout, pattern: &SparsityPattern) {
    let num_elements = layout.dof_offsets.len() - 1;
    layout.map_offsets = Vec::with_capacity(num_elements + 1);
    layout.map_offsets.push(0);
    for e in 0..num_elements {
        let dofs = &layout.dofs[layout.dof_offsets[e]..layout.dof_offsets[e + 1]];
        for a in 0..dofs.len() {
            for b in 0..=a {
                let (row, col) = if dofs[a] >= dofs[b] {
                    (dofs[a], dofs[b])
                } else {
                    (dofs[b], dofs[a])
                };
                let position = pattern
                    .position(row as usize, col as usize)
                    .expect("pattern built from the same element DOF lists");
                layout.map.push(position as u32);
            }
        }
        layout.map_offsets.push(layout.map.len());
    }
}

#[cfg(test)]
mod tests;
