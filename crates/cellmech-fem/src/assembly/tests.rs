use super::*;
use crate::element::spring::SpringSet;

/// A small random-ish spring network: 5 nodes, 7 springs.
fn network() -> (DofMap, Vec<Box<dyn Term>>) {
    let nodes = [
        [0.0, 0.0, 0.0],
        [1.0, 0.1, 0.0],
        [0.2, 1.0, 0.3],
        [1.1, 1.2, -0.2],
        [0.5, 0.4, 1.0],
    ];
    let pairs = [[0, 1], [1, 2], [2, 3], [3, 0], [0, 4], [1, 4], [3, 4]];
    let set = SpringSet {
        name: "net".into(),
        nodes: pairs.to_vec(),
        reference: pairs.iter().map(|&[a, b]| [nodes[a], nodes[b]]).collect(),
        stiffness: (0..7).map(|i| 1.0 + i as f64).collect(),
        rest_length: vec![0.8; 7],
    };
    (DofMap::translational(5), vec![Box::new(set)])
}

fn dense(pattern: &SparsityPattern, values: &[f64]) -> Vec<Vec<f64>> {
    let mut a = vec![vec![0.0; pattern.n]; pattern.n];
    for c in 0..pattern.n {
        for k in pattern.col_ptr[c]..pattern.col_ptr[c + 1] {
            a[pattern.row_idx[k]][c] = values[k];
            a[c][pattern.row_idx[k]] = values[k];
        }
    }
    a
}

#[test]
fn assembled_tangent_matches_finite_differences_of_assembled_residual() {
    let (dofs, terms) = network();
    let asm = Assembler::new(&dofs, &terms);
    let n = dofs.num_dofs();
    let u: Vec<f64> = (0..n).map(|i| 0.05 * ((i * 7 % 5) as f64 - 2.0)).collect();
    let free = vec![false; n];
    let mut r = vec![0.0; n];
    let mut values = vec![0.0; asm.pattern().nnz()];
    asm.assemble(
        &terms,
        &u,
        &free,
        AssemblyOutput {
            residual: &mut r,
            magnitude: None,
            tangent: Some(&mut values),
            predictor: None,
        },
    )
    .unwrap();
    let k = dense(asm.pattern(), &values);
    let h = 1e-6;
    for j in 0..n {
        let (mut up, mut um) = (u.clone(), u.clone());
        up[j] += h;
        um[j] -= h;
        let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
        let ep = asm
            .assemble(
                &terms,
                &up,
                &free,
                AssemblyOutput {
                    residual: &mut rp,
                    magnitude: None,
                    tangent: None,
                    predictor: None,
                },
            )
            .unwrap();
        let em = asm
            .assemble(
                &terms,
                &um,
                &free,
                AssemblyOutput {
                    residual: &mut rm,
                    magnitude: None,
                    tangent: None,
                    predictor: None,
                },
            )
            .unwrap();
        assert!(((ep - em) / (2.0 * h) - r[j]).abs() < 1e-6);
        for i in 0..n {
            assert!(
                ((rp[i] - rm[i]) / (2.0 * h) - k[i][j]).abs() < 1e-5,
                "K[{i}][{j}]"
            );
        }
    }
}

#[test]
fn prescribed_dofs_get_unit_diagonal_and_their_coupling_goes_to_the_predictor() {
    let (dofs, terms) = network();
    let asm = Assembler::new(&dofs, &terms);
    let n = dofs.num_dofs();
    let u = vec![0.01; n];
    let mut mask = vec![false; n];
    mask[4] = true;
    mask[9] = true;
    let du: Vec<f64> = (0..n)
        .map(|i| if mask[i] { 0.1 * i as f64 } else { 0.0 })
        .collect();
    let (mut r, mut pred) = (vec![0.0; n], vec![0.0; n]);
    let mut values = vec![0.0; asm.pattern().nnz()];
    asm.assemble(
        &terms,
        &u,
        &mask,
        AssemblyOutput {
            residual: &mut r,
            magnitude: None,
            tangent: Some(&mut values),
            predictor: Some((&du, &mut pred)),
        },
    )
    .unwrap();
    let masked = dense(asm.pattern(), &values);
    let mut full_values = vec![0.0; asm.pattern().nnz()];
    let none = vec![false; n];
    asm.assemble(
        &terms,
        &u,
        &none,
        AssemblyOutput {
            residual: &mut r,
            magnitude: None,
            tangent: Some(&mut full_values),
            predictor: None,
        },
    )
    .unwrap();
    let full = dense(asm.pattern(), &full_values);
    for i in 0..n {
        for j in 0..n {
            let expected = match (mask[i], mask[j]) {
                (false, false) => full[i][j],
                _ if i == j => 1.0,
                _ => 0.0,
            };
            assert_eq!(masked[i][j], expected);
        }
        if !mask[i] {
            let coupling: f64 = (0..n)
                .filter(|&j| mask[j])
                .map(|j| full[i][j] * du[j])
                .sum();
            assert!((pred[i] - coupling).abs() < 1e-14);
        }
    }
    assert_eq!(asm.untouched_dofs(), vec![false; n]);
}
