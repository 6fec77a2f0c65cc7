//! Diagnostics of the suspended cell with embedded microtubules (issue 10): a plain
//! Newton loop over the prestress ramp that reports, per iteration, the condensed
//! residual, the tangent's inertia (negative pivots of LDLᵀ when LLᵀ fails) and where the
//! correction goes (host translations, MT rotations, centrosome), and per converged state
//! the MT strains. Ignored (a tool, not a check):
//! `cargo test --release -p cellmech --test mt_embedded_diagnostics -- --ignored --nocapture`
//! Environment: `MT_ELEMENTS` (beam elements per MT), `MT_EMBED_EVERY` (embed every k-th
//! interior node), `MT_DT` (ramp increment), `MT_TIED=1` (tie the centrosome).

use cellmech::cell::suspended::{build_suspended_cell, Components, SuspendedCellMaterials};
use cellmech::cell::SuspendedCellParams;
use cellmech_fem::assembly::{Assembler, AssemblyOutput};
use cellmech_fem::constraint::condense::Condensation;
use cellmech_fem::constraint::embed::embed_translations;
use cellmech_fem::constraint::LinearConstraints;
use cellmech_fem::linsolve::{FaerSparseSolver, LinearSolver};
use cellmech_fem::mesh::locate::HostLocator;
use cellmech_fem::term::LoadState;

fn env(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

#[test]
#[ignore]
fn embedded_prestress_newton_diagnostics() {
    let mut params = SuspendedCellParams::default();
    // Single-node FAs: the problem below is built without the plaques' ties.
    params.fa_radius = 0.0;
    params.mesh.core_divisions = env("MT_CORE", 4.0) as usize;
    params.mesh.shell_layers = env("MT_SHELL", 2.0) as usize;
    params.mesh.outer_layers = env("MT_OUTER", 2.0) as usize;
    params.mt_elements = env("MT_ELEMENTS", 8.0) as usize;
    let every = env("MT_EMBED_EVERY", 1.0) as usize;
    let dt = env("MT_DT", 0.05);
    let mut model = build_suspended_cell(
        &params,
        &SuspendedCellMaterials::default(),
        Components::default(),
    )
    .unwrap();
    if env("MT_CHORD", 0.0) > 0.0 {
        // Rebuild the terms with the MT beams' local strain = chord (no bowing term).
        let mut parts = cellmech::cell::suspended::suspended_cell_parts(
            &params,
            &SuspendedCellMaterials::default(),
            Components::default(),
        )
        .unwrap();
        let mut mt = None;
        for f in parts.structures.filaments.iter_mut() {
            if f.family == "microtubule" {
                if let cellmech::model::structures::FilamentElement::Beam(s) = f.element {
                    mt = Some((f.pairs.clone(), s));
                }
                f.enabled = false;
            }
        }
        let (pairs, section) = mt.unwrap();
        let mut terms: Vec<Box<dyn cellmech_fem::term::Term>> = model.terms.drain(..2).collect();
        terms.extend(
            cellmech::model::structures::structure_terms(
                &model.mesh,
                &parts.structures,
                &model.dof_map,
            )
            .unwrap(),
        );
        let mut set = cellmech_fem::element::beam::BeamSet::from_coordinates(
            "microtubule",
            "microtubule",
            &model.mesh.nodes,
            &pairs,
            None,
            section,
        )
        .unwrap();
        set.local_strain = cellmech_fem::element::beam::LocalStrain::Chord;
        terms.push(Box::new(set));
        model.terms = terms;
        println!("MT local strain: chord");
    }
    let mesh = &model.mesh;
    let n = model.dof_map.num_dofs();
    let interior = mesh.node_sets["microtubule_interior"].clone();
    let centrosome = mesh.node_sets["centrosome"][0];
    // Interior nodes in chain order: embed every `every`-th.
    let embedded: Vec<usize> = interior
        .iter()
        .enumerate()
        .filter(|(i, _)| (i % (params.mt_elements - 1) + 1) % every == 0)
        .map(|(_, &n)| n)
        .collect();
    let mut nodes = embedded.clone();
    if env("MT_TIED", 0.0) > 0.0 {
        nodes.push(centrosome);
    }
    let locator = HostLocator::new(mesh, &["cytoplasm", "nucleus"]).unwrap();
    let mut constraints = LinearConstraints::new(n);
    let report = embed_translations(
        &mut constraints,
        &locator,
        &model.dof_map,
        &mesh.nodes,
        &nodes,
        0.25,
    )
    .unwrap();
    report.require_all_hosted().unwrap();
    let mut per_host = std::collections::BTreeMap::<usize, usize>::new();
    for e in &report.embedded {
        *per_host.entry(e.host.element).or_default() += 1;
    }
    let mut hist = std::collections::BTreeMap::<usize, usize>::new();
    for &c in per_host.values() {
        *hist.entry(c).or_default() += 1;
    }
    println!(
        "embedded {} nodes in {} hosts; histogram (nodes per host: hosts) {:?}",
        report.embedded.len(),
        per_host.len(),
        hist
    );
    // MT element pairs and lengths.
    let mt_pairs: Vec<[usize; 2]> = {
        let mut v = Vec::new();
        let parts = cellmech::cell::suspended::suspended_cell_parts(
            &params,
            &SuspendedCellMaterials::default(),
            Components::default(),
        )
        .unwrap();
        for f in &parts.structures.filaments {
            if f.family == "microtubule" {
                v.extend_from_slice(&f.pairs);
            }
        }
        v
    };
    let x0 = mesh.nodes.clone();
    let dist = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let dof_map = model.dof_map.clone();
    let assembler = Assembler::new(&dof_map, &model.terms);
    let mut cond = Condensation::new(constraints.clone(), assembler.pattern()).unwrap();
    let mut solver = FaerSparseSolver::default();
    solver.analyze(cond.reduced_pattern()).unwrap();
    let mut prescribed = vec![false; n];
    for &d in &model.supports {
        prescribed[d] = true;
    }
    let mut values = vec![0.0; cond.reduced_pattern().nnz()];
    let mut r = vec![0.0; n];
    let mut u = vec![0.0; n];
    let classify = |d: usize| -> usize {
        let (node, comp) = dof_map.node_of(d);
        if node == centrosome {
            2
        } else if comp >= 3 {
            1
        } else {
            0
        }
    };
    let mut t = 0.0;
    while t < 1.0 - 1e-12 {
        t = (t + dt).min(1.0);
        for term in model.terms.iter_mut() {
            term.set_load_state(&LoadState {
                step_index: 0,
                step_time: t,
            });
            term.predict(&u, &dof_map);
        }
        let mut converged = false;
        for it in 0..30 {
            solver.reset_fallback();
            let energy = cond
                .assemble(
                    &assembler,
                    &model.terms,
                    &u,
                    &prescribed,
                    AssemblyOutput {
                        residual: &mut r,
                        magnitude: None,
                        tangent: Some(&mut values),
                        predictor: None,
                    },
                )
                .unwrap();
            for d in 0..n {
                if prescribed[d] || constraints.is_slave(d) {
                    r[d] = 0.0;
                }
            }
            let rn = r.iter().map(|v| v * v).sum::<f64>().sqrt();
            let info = solver.factorize(&values).unwrap();
            let mut delta: Vec<f64> = r.iter().map(|v| -v).collect();
            solver.solve_in_place(&mut delta).unwrap();
            constraints.expand(&mut delta);
            let mut max = [0.0f64; 3];
            for d in 0..n {
                if !prescribed[d] {
                    let c = classify(d);
                    max[c] = max[c].max(delta[d].abs());
                }
            }
            println!(
                "t={t:.3} it={it} |R|={rn:.3e} E={energy:.4e} {:?} neg={:?} max|δ| host/MT-rot/centrosome = {:.3e} {:.3e} {:.3e}",
                info.method, info.negative_pivots, max[0], max[1], max[2]
            );
            if rn < 1e-8 {
                converged = true;
                break;
            }
            // Backtracking on |R| (crude) to stay near the path.
            let mut s = 1.0;
            let mut trial = u.clone();
            for _ in 0..8 {
                for d in 0..n {
                    trial[d] = u[d] + s * delta[d];
                }
                let mut rt = vec![0.0; n];
                let ok = cond.assemble(
                    &assembler,
                    &model.terms,
                    &trial,
                    &prescribed,
                    AssemblyOutput {
                        residual: &mut rt,
                        magnitude: None,
                        tangent: None,
                        predictor: None,
                    },
                );
                for d in 0..n {
                    if prescribed[d] || constraints.is_slave(d) {
                        rt[d] = 0.0;
                    }
                }
                let rtn = rt.iter().map(|v| v * v).sum::<f64>().sqrt();
                if ok.is_ok() && rtn < rn {
                    break;
                }
                s *= 0.5;
            }
            if s < 1.0 {
                println!("   line search {s}");
            }
            u.copy_from_slice(&trial);
        }
        // MT strains at this state.
        let pos = |node: usize| {
            let mut p = x0[node];
            for (k, pk) in p.iter_mut().enumerate() {
                *pk += u[dof_map.dof(node, k)];
            }
            p
        };
        let strains: Vec<f64> = mt_pairs
            .iter()
            .map(|&[a, b]| dist(pos(a), pos(b)) / dist(x0[a], x0[b]) - 1.0)
            .collect();
        let (mn, mx) = strains
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &s| (a.min(s), b.max(s)));
        println!(
            "t={t:.3} converged={converged} MT strain min {mn:.3e} max {mx:.3e} (EA·max = {:.2} nN)",
            317.0 * mx
        );
        if !converged {
            break;
        }
        for term in model.terms.iter_mut() {
            term.commit(&u, &dof_map);
        }
    }
}
