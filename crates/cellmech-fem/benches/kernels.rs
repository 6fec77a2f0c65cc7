//! Element kernel benchmark: one evaluation of the corotational beam (with and without its
//! tangent) and, for scale, of the mean-dilatation hex8 with a neo-Hookean material.
//!
//! Run: `cargo bench -p cellmech-fem --bench kernels` (about half a minute). The figures
//! are quoted in `docs/performance.md` ("The beam kernel in nine variables").

use std::hint::black_box;

use cellmech_fem::element::beam::{beam_evaluate, BeamReference, BeamSection};
use cellmech_fem::element::hex8::{hex8_evaluate, Hex8Formulation, Hex8Reference};
use cellmech_fem::material::NeoHookean;
use criterion::{criterion_group, criterion_main, Criterion};

/// A bent, stretched and twisted microtubule element (rotations of about 0.4 rad).
fn beam_case() -> (BeamSection, BeamReference, [f64; 12]) {
    let section = BeamSection::hollow_circular(1.2e6, 0.3, 0.025, 0.017).expect("section");
    let reference =
        BeamReference::new([0.1, -0.2, 0.3], [1.0, 0.4, 0.8], Some([0.0, 0.0, 1.0])).expect("ref");
    let u = [
        0.003, -0.002, 0.001, 0.21, -0.33, 0.12, -0.004, 0.006, 0.002, -0.15, 0.27, 0.4,
    ];
    (section, reference, u)
}

/// A distorted unit hex8 of cytoplasm under a finite strain.
fn hex8_case() -> (Hex8Reference, NeoHookean, [f64; 24]) {
    let corners = [
        [0.0, 0.0, 0.0],
        [1.0, 0.1, 0.0],
        [1.1, 1.0, 0.05],
        [0.0, 0.9, 0.0],
        [0.05, 0.0, 1.0],
        [1.0, 0.0, 1.1],
        [1.0, 1.0, 1.0],
        [0.0, 1.05, 0.95],
    ];
    let reference = Hex8Reference::new(&corners).expect("hex8");
    let material = NeoHookean::new(0.17, 17.0).expect("material");
    let u: [f64; 24] = std::array::from_fn(|i| 0.02 * ((i * 7 % 11) as f64 - 5.0) / 5.0);
    (reference, material, u)
}

fn kernels(c: &mut Criterion) {
    let (section, reference, u) = beam_case();
    let mut residual = [0.0; 12];
    let mut tangent = [0.0; 144];
    c.bench_function("beam_evaluate with tangent", |b| {
        b.iter(|| {
            beam_evaluate(
                &section,
                &reference,
                black_box(&u),
                &mut residual,
                Some(&mut tangent),
            )
            .expect("evaluates")
        })
    });
    c.bench_function("beam_evaluate residual only", |b| {
        b.iter(|| {
            beam_evaluate(&section, &reference, black_box(&u), &mut residual, None)
                .expect("evaluates")
        })
    });
    let (hex, material, uh) = hex8_case();
    let mut r24 = [0.0; 24];
    let mut k576 = [0.0; 576];
    for with_tangent in [true, false] {
        let name = if with_tangent {
            "hex8_evaluate with tangent (mean dilatation)"
        } else {
            "hex8_evaluate residual only (mean dilatation)"
        };
        c.bench_function(name, |b| {
            b.iter(|| {
                let tangent = with_tangent.then_some(&mut k576);
                hex8_evaluate(
                    &hex,
                    &material,
                    Hex8Formulation::MeanDilatation,
                    black_box(&uh),
                    &mut r24,
                    tangent,
                )
                .expect("evaluates")
            })
        });
    }
}

criterion_group!(benches, kernels);
criterion_main!(benches);
