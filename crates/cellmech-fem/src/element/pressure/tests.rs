//! Pressure and volume-control tests.

use super::*;
use crate::dof::DofMap;
use crate::mesh::ElementKind;
use crate::term::Term;

fn cube_surface() -> (Vec<[f64; 3]>, Vec<usize>) {
    let nodes: Vec<[f64; 3]> = (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect();
    // Outward faces of the unit cube (node = x + 2y + 4z).
    let faces = vec![
        0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 1, 3, 7, 5, 3, 2, 6, 7, 2, 0, 4, 6,
    ];
    (nodes, faces)
}

fn warped(u_scale: f64) -> Vec<f64> {
    (0..24)
        .map(|i| u_scale * ((i as f64 * 1.7).sin() + 0.3 * (i as f64 * 0.37).cos()))
        .collect()
}

#[test]
fn pressure_volume_of_closed_surfaces_is_exact() {
    let (nodes, faces) = cube_surface();
    let s = SurfaceVolume::new("cube", ElementKind::Quad4, faces.clone(), &nodes).unwrap();
    assert!((s.reference_volume() - 1.0).abs() < 1e-15);
    // Translation invariance and scaling by an affine map: V = det F for the unit cube.
    let f = [[1.3, 0.2, -0.1], [0.1, 0.8, 0.3], [0.05, -0.2, 1.1]];
    let det = f[0][0] * (f[1][1] * f[2][2] - f[1][2] * f[2][1])
        - f[0][1] * (f[1][0] * f[2][2] - f[1][2] * f[2][0])
        + f[0][2] * (f[1][0] * f[2][1] - f[1][1] * f[2][0]);
    let u: Vec<f64> = nodes
        .iter()
        .flat_map(|x| (0..3).map(move |i| (0..3).map(|j| f[i][j] * x[j]).sum::<f64>() - x[i] + 5.0))
        .collect();
    let v = s.volume(&u, &DofMap::translational(8));
    assert!((v - det).abs() < 1e-13, "volume {v} vs det F {det}");
    // Triangulated cube: split each quad along its 0-2 diagonal.
    let tris: Vec<usize> = faces
        .chunks(4)
        .flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]])
        .collect();
    let t = SurfaceVolume::new("cube", ElementKind::Tri3, tris, &nodes).unwrap();
    let v = t.volume(&u, &DofMap::translational(8));
    assert!((v - det).abs() < 1e-13);
    // Warped bilinear faces: volume is independent of the origin (closed surface).
    let w = warped(0.2);
    let shifted: Vec<f64> = w
        .iter()
        .enumerate()
        .map(|(i, x)| x + [3.0, -2.0, 7.0][i % 3])
        .collect();
    let (v1, v2) = (
        s.volume(&w, &DofMap::translational(8)),
        s.volume(&shifted, &DofMap::translational(8)),
    );
    assert!(
        (v1 - v2).abs() < 1e-13 && (v1 - 1.0).abs() > 1e-3,
        "{v1} {v2}"
    );
}

#[test]
fn pressure_on_closed_surface_gives_follower_nodal_forces() {
    // Unit cube, p = 3: each corner node carries p·(1/4) of each of its three faces, so the
    // assembled residual −p ∂V/∂x is −(3/4)(±1, ±1, ±1), outward at every corner. (A
    // single face's contribution is not p∫N n dA: only the closed sum is.)
    let (nodes, faces) = cube_surface();
    let load = PressureLoad::new(
        SurfaceVolume::new("p", ElementKind::Quad4, faces, &nodes).unwrap(),
        3.0,
    );
    let mut total = vec![0.0; 24];
    let mut r = [0.0; 12];
    let mut dofs = [0; 24];
    let map = DofMap::translational(8);
    for e in 0..6 {
        load.evaluate(e, &[0.0; 12], &mut r, None).unwrap();
        load.element_dofs(e, &map, &mut dofs);
        for a in 0..12 {
            total[dofs[a]] += r[a];
        }
    }
    for (node, x) in nodes.iter().enumerate() {
        for i in 0..3 {
            let expected = -0.75 * (2.0 * x[i] - 1.0);
            assert!(
                (total[3 * node + i] - expected).abs() < 1e-14,
                "node {node}"
            );
        }
    }
}

#[test]
fn pressure_volume_control_checks_its_auxiliary_node_and_dofs() {
    let (nodes, faces) = cube_surface();
    let mut all = nodes.clone();
    all.push([0.0; 3]);
    let s = SurfaceVolume::new("vc", ElementKind::Quad4, faces.clone(), &all).unwrap();
    assert!(matches!(
        VolumeControl::new(s.clone(), 3),
        Err(PressureError::AuxiliaryNodeOnSurface { .. })
    ));
    let vc = VolumeControl::new(s, 8).unwrap();
    let map = DofMap::translational(9);
    assert_eq!(
        (vc.pressure_dof(&map), vc.volume_change_dof(&map)),
        (24, 25)
    );
    let mut dofs = [0; 24];
    assert_eq!(vc.element_dofs(2, &map, &mut dofs), 14);
}
