//! Times the parallel assembly (residual + tangent, and residual only) of a neo-Hookean hex8
//! sphere on 1 and 2 threads for several chunk sizes, to choose
//! `DEFAULT_MIN_CHUNK_ELEMENTS` (see `docs/performance.md`, section "Threads").
//!
//! Run: `cargo run --release -p cellmech-fem --example assembly_threads [REPEATS]`
//! (default 40 assemblies per configuration and thread count, alternating; medians, and the
//! median of the pair-by-pair ratio; the mean CPU time of the process per assembly).

use std::time::Instant;

use cellmech_fem::assembly::{Assembler, AssemblyOutput};
use cellmech_fem::continuum::ContinuumBlock;
use cellmech_fem::dof::DofMap;
use cellmech_fem::element::hex8::Hex8Formulation;
use cellmech_fem::material::NeoHookean;
use cellmech_fem::mesh::generate::{sphere_mesh, SphereMeshSpec};
use cellmech_fem::term::Term;

fn main() {
    let repeats: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(40)
        .max(1);
    let mesh = sphere_mesh(&SphereMeshSpec {
        radius: 16.132,
        core_divisions: 8,
        shell_layers: 6,
        ..SphereMeshSpec::default()
    })
    .expect("sphere mesh");
    let law = NeoHookean {
        shear_modulus: 0.17,
        bulk_modulus: 17.0,
    };
    let block = ContinuumBlock::new(
        &mesh.blocks[0],
        &mesh.nodes,
        law,
        Hex8Formulation::MeanDilatation,
    )
    .expect("block");
    let terms: Vec<Box<dyn Term>> = vec![Box::new(block)];
    let dofs = DofMap::translational(mesh.num_nodes());
    let n = dofs.num_dofs();
    let u: Vec<f64> = (0..n)
        .map(|i| 0.01 * ((i * 7919 % 23) as f64 - 11.0))
        .collect();
    let prescribed = vec![false; n];
    let base = Assembler::new(&dofs, &terms);
    println!(
        "{} hex8, {n} DOFs, colour sizes {:?}",
        mesh.num_elements(),
        base.color_sizes()
    );
    println!(
        "{:>7} | {:>8} {:>8} {:>6} {:>8} {:>8} | {:>8} {:>8} {:>6} {:>8} {:>8}",
        "chunk",
        "full 1t",
        "full 2t",
        "2t/1t",
        "cpu 1t",
        "cpu 2t",
        "res 1t",
        "res 2t",
        "2t/1t",
        "cpu 1t",
        "cpu 2t"
    );
    let pools = [1, 2].map(|t| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .expect("pool")
    });
    for min_chunk in [1, 4, 16, 64, 1_000_000] {
        let assembler = base.clone().with_min_chunk_elements(min_chunk);
        let mut residual = vec![0.0; n];
        let mut tangent = vec![0.0; assembler.pattern().nnz()];
        // [kind][threads] medians, and the median of the pair-by-pair ratio 2t/1t (1 and 2
        // threads alternate, so drift of the machine's speed cancels in the ratio).
        let mut times = [[0.0; 2]; 2];
        let mut ratios = [0.0; 2];
        let mut cpu = [[0.0; 2]; 2];
        for (kind, with_tangent) in [(0, true), (1, false)] {
            let mut samples = [Vec::with_capacity(repeats), Vec::with_capacity(repeats)];
            let mut pair = Vec::with_capacity(repeats);
            for _ in 0..repeats {
                for (t, pool) in pools.iter().enumerate() {
                    let (start, cpu_start) = (Instant::now(), process_cpu_seconds());
                    pool.install(|| {
                        assembler.assemble(
                            &terms,
                            &u,
                            &prescribed,
                            AssemblyOutput {
                                residual: &mut residual,
                                magnitude: None,
                                tangent: with_tangent.then_some(&mut tangent[..]),
                                predictor: None,
                            },
                        )
                    })
                    .expect("assembly");
                    samples[t].push(start.elapsed().as_secs_f64());
                    cpu[kind][t] += process_cpu_seconds() - cpu_start;
                }
                pair.push(samples[1][samples[1].len() - 1] / samples[0][samples[0].len() - 1]);
            }
            for t in 0..2 {
                times[kind][t] = median(&mut samples[t]);
            }
            ratios[kind] = median(&mut pair);
        }
        let r = repeats as f64;
        println!(
            "{:>7} | {:>8.5} {:>8.5} {:>6.2} {:>8.5} {:>8.5} | {:>8.5} {:>8.5} {:>6.2} {:>8.5} {:>8.5}",
            min_chunk,
            times[0][0],
            times[0][1],
            ratios[0],
            cpu[0][0] / r,
            cpu[0][1] / r,
            times[1][0],
            times[1][1],
            ratios[1],
            cpu[1][0] / r,
            cpu[1][1] / r
        );
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// User + system CPU time of the whole process (all threads), s, from /proc (Linux; 0
/// elsewhere). Clock-tick resolution: meaningful summed over many calls.
fn process_cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the command name (which is in parentheses): utime is the 12th, stime the
    // 13th, in clock ticks (100 per second on Linux).
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (ticks(11) + ticks(12)) / 100.0
}
