use super::*;
use crate::continuum::ContinuumBlock;
use crate::dof::DofMap;
use crate::element::hex8::Hex8Formulation;
use crate::material::NeoHookean;
use crate::mesh::generate::{box_mesh, perturb_interior_nodes};
use crate::mesh::Mesh;
use crate::term::Term;

fn hexes(mesh: &Mesh) -> Vec<[usize; 8]> {
    let block = &mesh.blocks[0];
    block
        .elements()
        .map(|e| std::array::from_fn(|a| e[a]))
        .collect()
}

fn boundary(mesh: &Mesh) -> Vec<bool> {
    let mut on = vec![false; mesh.nodes.len()];
    for set in ["x_min", "x_max", "y_min", "y_max", "z_min", "z_max"] {
        for &n in &mesh.node_sets[set] {
            on[n] = true;
        }
    }
    on
}

/// Reference and current positions of every node after `rezoning`.
fn rezoned(
    rezoning: &Rezoning,
    reference: &[[f64; 3]],
    current: &[[f64; 3]],
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let (mut x0, mut x) = (reference.to_vec(), current.to_vec());
    for remap in &rezoning.remaps {
        x0[remap.node] = remap.apply(reference);
        x[remap.node] = remap.apply(current);
    }
    (x0, x)
}

/// Asserts that every target of `motion` is where `expected` puts its node (to 1e-9).
fn assert_motion_is(motion: &MeshMotion, expected: &[[f64; 3]], what: &str) {
    let targets = motion
        .surface
        .iter()
        .map(|(n, p)| (*n, p.x))
        .chain(motion.interior.iter().copied());
    for (n, x) in targets {
        for c in 0..3 {
            assert!(
                (x[c] - expected[n][c]).abs() < 1e-9,
                "{what}: node {n} at {x:?}, expected {:?}",
                expected[n]
            );
        }
    }
}

/// A top surface (z = 1) dented round the z axis and swept outwards, as the flow round an
/// indenter's nose leaves it: x, y spread by 1 + `spread`·e^(−r²/0.1)·zᵖ, z lowered by
/// `dip`·e^(−r²/`dip_width`)·zᵖ (p = `power`: the deformation fades with depth).
fn dent(spread: f64, dip: f64, dip_width: f64, power: i32) -> impl Fn([f64; 3]) -> [f64; 3] {
    move |x| {
        let r2 = x[0] * x[0] + x[1] * x[1];
        let depth = x[2].powi(power);
        let s = 1.0 + spread * (-r2 / 0.1).exp() * depth;
        [
            x[0] * s,
            x[1] * s,
            x[2] - dip * (-r2 / dip_width).exp() * depth,
        ]
    }
}

fn apply(f: &[[f64; 3]; 3], x: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|j| f[i][j] * x[j]).sum())
}

/// Internal nodal forces of a neo-Hookean block on `elements` at reference `x0`, current `x`.
fn nodal_forces(x0: &[[f64; 3]], x: &[[f64; 3]], mesh: &Mesh) -> Vec<[f64; 3]> {
    let mut block_mesh = mesh.clone();
    block_mesh.nodes = x0.to_vec();
    let block = ContinuumBlock::new(
        &block_mesh.blocks[0],
        x0,
        NeoHookean::new(1.0, 50.0).unwrap(),
        Hex8Formulation::MeanDilatation,
    )
    .unwrap();
    let dof_map = DofMap::translational(x0.len());
    let u: Vec<f64> = (0..x0.len())
        .flat_map(|n| (0..3).map(move |i| (n, i)))
        .map(|(n, i)| x[n][i] - x0[n][i])
        .collect();
    let mut forces = vec![[0.0; 3]; x0.len()];
    let mut dofs = [0usize; crate::term::MAX_ELEMENT_DOFS];
    for e in 0..block.num_elements() {
        let k = block.element_dofs(e, &dof_map, &mut dofs);
        let u_e: Vec<f64> = dofs[..k].iter().map(|&d| u[d]).collect();
        let mut r = vec![0.0; k];
        block.evaluate(e, &u_e, &mut r, None).unwrap();
        for (a, &d) in dofs[..k].iter().enumerate() {
            let (n, i) = dof_map.node_of(d);
            forces[n][i] += r[a];
        }
    }
    forces
}

/// The rezoning patch test: under a homogeneous deformation every mesh carries the exact
/// solution, so moving the nodes of a distorted mesh anywhere (here: back onto the regular
/// grid, with a hanging node among them) must give x′ = F X′ at every node and a state
/// still in equilibrium. A wrong location, wrong weights or a hanging node not following its
/// masters would break both.
#[test]
fn a_rezoned_homogeneous_state_stays_exact_and_in_equilibrium() {
    let divisions = [4, 4, 4];
    let mut mesh = box_mesh([0.0; 3], [1.0, 1.2, 0.8], divisions, "gel").unwrap();
    let regular = mesh.nodes.clone();
    assert!(perturb_interior_nodes(&mut mesh, 0.3, 11).unwrap() > 0);
    let index = |i: usize, j: usize, k: usize| i + 5 * (j + 5 * k);
    // Node (2, 2, 2) hangs on (1, 2, 2) and (3, 2, 2), at their midpoint in both meshes.
    let (h, m1, m2) = (index(2, 2, 2), index(1, 2, 2), index(3, 2, 2));
    mesh.nodes[h] = std::array::from_fn(|c| 0.5 * (mesh.nodes[m1][c] + mesh.nodes[m2][c]));
    let f = [[1.3, 0.1, 0.0], [0.05, 0.85, 0.02], [0.0, -0.04, 0.92]];
    let reference = mesh.nodes.clone();
    let current: Vec<[f64; 3]> = reference.iter().map(|&x| apply(&f, x)).collect();
    let elements = hexes(&mesh);
    let on_boundary = boundary(&mesh);
    let movable: Vec<bool> = on_boundary.iter().map(|b| !b).collect();
    let hanging = vec![(h, vec![(m1, 0.5), (m2, 0.5)])];
    let input = RezoneInput {
        reference: &reference,
        current: &current,
        elements: &elements,
        movable: &movable,
        hanging: &hanging,
        surface_faces: &[],
        sliding: &[],
    };
    // Targets: the regular grid, deformed.
    let targets: Vec<(usize, [f64; 3])> = (0..reference.len())
        .filter(|&n| movable[n] && n != h)
        .map(|n| (n, apply(&f, regular[n])))
        .collect();
    let rezoning = remap_to(&input, &targets, Vec::new()).unwrap();
    assert_eq!(rezoning.unlocated, 0);
    assert_eq!(rezoning.remaps.len(), targets.len() + 1);
    for remap in &rezoning.remaps {
        let weight: f64 = remap.sources.iter().map(|s| s.1).sum();
        assert!((weight - 1.0).abs() < 1e-12, "{remap:?}");
    }
    let (x0, x) = rezoned(&rezoning, &reference, &current);
    for n in 0..reference.len() {
        let fx = apply(&f, x0[n]);
        for c in 0..3 {
            assert!(
                (x[n][c] - fx[c]).abs() < 1e-12,
                "node {n}: {:?} vs {fx:?}",
                x[n]
            );
        }
        if movable[n] && n != h {
            // Back on the regular grid in the reference configuration.
            for c in 0..3 {
                assert!((x0[n][c] - regular[n][c]).abs() < 1e-10, "node {n}");
            }
        }
    }
    // The hanging node is still its masters' midpoint.
    for c in 0..3 {
        assert!((x0[h][c] - 0.5 * (x0[m1][c] + x0[m2][c])).abs() < 1e-12);
    }
    // Equilibrium: interior nodal forces vanish against the boundary's.
    let forces = nodal_forces(&x0, &x, &mesh);
    let scale = forces
        .iter()
        .zip(&on_boundary)
        .filter(|(_, &b)| b)
        .map(|(f, _)| f.iter().map(|v| v.abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    assert!(scale > 1e-2, "the stretch loads the boundary: {scale}");
    let interior = forces
        .iter()
        .zip(&on_boundary)
        .filter(|(_, &b)| !b)
        .map(|(f, _)| f.iter().map(|v| v.abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    assert!(
        interior < 1e-10 * scale,
        "interior force {interior:e} of {scale:e}"
    );
    // The block's own update gives the elements a fresh block on the new reference would have.
    let mut moved_block = ContinuumBlock::new(
        &mesh.blocks[0],
        &reference,
        NeoHookean::new(1.0, 50.0).unwrap(),
        Hex8Formulation::MeanDilatation,
    )
    .unwrap();
    let moved: Vec<bool> = (0..x0.len()).map(|n| x0[n] != reference[n]).collect();
    let dof_map = DofMap::translational(x0.len());
    moved_block
        .move_reference(&x0, &moved, &mut vec![0.0; 3 * x0.len()], &dof_map)
        .unwrap();
    let fresh = ContinuumBlock::new(
        &mesh.blocks[0],
        &x0,
        NeoHookean::new(1.0, 50.0).unwrap(),
        Hex8Formulation::MeanDilatation,
    )
    .unwrap();
    let u_e = [0.01; 24];
    for e in 0..fresh.num_elements() {
        let (mut r1, mut r2) = ([0.0; 24], [0.0; 24]);
        moved_block.evaluate(e, &u_e, &mut r1, None).unwrap();
        fresh.evaluate(e, &u_e, &mut r2, None).unwrap();
        assert_eq!(r1, r2, "element {e}");
    }
}

/// A top layer crushed to a fifth of its thickness under the centre (the stagnation point
/// under an indenter, in miniature): the harmonic mesh motion opens it again, the moved
/// nodes are material points of the old interpolation, and a motion is refused where it
/// would not help (a homogeneous deformation, whose mesh nothing can improve).
#[test]
fn the_harmonic_mesh_motion_opens_a_crushed_layer() {
    let (size, divisions) = ([2.0, 2.0, 1.0], [8, 8, 6]);
    let mesh = box_mesh([-1.0, -1.0, 0.0], size, divisions, "gel").unwrap();
    let reference = mesh.nodes.clone();
    let crush = |x: [f64; 3]| -> [f64; 3] {
        let r2 = x[0] * x[0] + x[1] * x[1];
        let uz = -0.16 * (-r2 / 0.15).exp() * x[2].powi(12);
        [x[0], x[1], x[2] + uz]
    };
    let current: Vec<[f64; 3]> = reference.iter().map(|&x| crush(x)).collect();
    let elements = hexes(&mesh);
    let movable: Vec<bool> = boundary(&mesh).iter().map(|b| !b).collect();
    let input = RezoneInput {
        reference: &reference,
        current: &current,
        elements: &elements,
        movable: &movable,
        hanging: &[],
        surface_faces: &[],
        sliding: &[],
    };
    let rezoning = rezone(&input, Acceptance::Better)
        .unwrap()
        .expect("the crushed layer is rezoned");
    assert!(
        rezoning.min_corner_ratio_before < 0.3,
        "{}",
        rezoning.min_corner_ratio_before
    );
    assert!(
        rezoning.min_corner_ratio_after > 1.5 * rezoning.min_corner_ratio_before,
        "{} -> {}",
        rezoning.min_corner_ratio_before,
        rezoning.min_corner_ratio_after
    );
    assert_eq!(rezoning.unlocated, 0);
    assert!(rezoning.cg_iterations > 0);
    for remap in &rezoning.remaps {
        let (x0, x) = (remap.apply(&reference), remap.apply(&current));
        // A material point of the block, mapped by the old interpolation of the crush:
        // close to the exact map (interpolation error only).
        assert!(x0[2] > 0.0 && x0[2] < 1.0 && x0[0].abs() < 1.0, "{x0:?}");
        let exact = crush(x0);
        let h = 1.0 / 6.0;
        for c in 0..3 {
            assert!((x[c] - exact[c]).abs() < 0.05 * h, "{x:?} vs {exact:?}");
        }
    }
    // Homogeneous: nothing to improve, nothing moves.
    let f = [[1.1, 0.0, 0.0], [0.0, 0.95, 0.0], [0.0, 0.0, 0.9]];
    let homogeneous: Vec<[f64; 3]> = reference.iter().map(|&x| apply(&f, x)).collect();
    let input = RezoneInput {
        current: &homogeneous,
        ..input
    };
    assert_eq!(rezone(&input, Acceptance::Better).unwrap(), None);
}

#[test]
fn bad_rezoning_input_is_an_error_not_a_panic() {
    let mesh = box_mesh([0.0; 3], [1.0; 3], [2, 2, 2], "gel").unwrap();
    let elements = hexes(&mesh);
    let movable = vec![true; mesh.nodes.len()];
    let short = &mesh.nodes[..5];
    let input = RezoneInput {
        reference: &mesh.nodes,
        current: short,
        elements: &elements,
        movable: &movable,
        hanging: &[],
        surface_faces: &[],
        sliding: &[],
    };
    assert!(rezone(&input, Acceptance::Better)
        .unwrap_err()
        .to_string()
        .contains("expected one each per node"));
    let input = RezoneInput {
        current: &mesh.nodes,
        ..input
    };
    let err = remap_to(&input, &[(999, [0.0; 3])], Vec::new()).unwrap_err();
    assert!(err.to_string().contains("node 999"), "{err}");
}

/// The free surface swept outwards round a dent (the flow round an indenter's nose, in
/// miniature): the sliding surface nodes move back along the surface, each staying a
/// material point of the surface (its reference on the flat reference top to round-off,
/// its current position on the dented surface), the longest surface edge shrinks, and the
/// worst element improves.
#[test]
fn surface_nodes_slide_along_the_surface_and_stay_on_it() {
    let (size, divisions) = ([2.0, 2.0, 1.0], [10, 10, 5]);
    let mesh = box_mesh([-1.0, -1.0, 0.0], size, divisions, "gel").unwrap();
    let reference = mesh.nodes.clone();
    let sweep = dent(1.2, 0.15, 0.3, 6);
    let current: Vec<[f64; 3]> = reference.iter().map(|&x| sweep(x)).collect();
    let elements = hexes(&mesh);
    let on_boundary = boundary(&mesh);
    let top: Vec<bool> = (0..reference.len())
        .map(|n| reference[n][2] == 1.0)
        .collect();
    let rim = |n: usize| reference[n][0].abs() == 1.0 || reference[n][1].abs() == 1.0;
    let movable: Vec<bool> = on_boundary.iter().map(|b| !b).collect();
    let sliding: Vec<bool> = (0..reference.len()).map(|n| top[n] && !rim(n)).collect();
    let faces: Vec<[usize; 4]> = elements
        .iter()
        .map(|e| [e[4], e[5], e[6], e[7]])
        .filter(|f| f.iter().all(|&n| top[n]))
        .collect();
    assert_eq!(faces.len(), 100);
    let longest = |x: &[[f64; 3]]| {
        faces
            .iter()
            .flat_map(|f| (0..4).map(move |a| (f[a], f[(a + 1) % 4])))
            .map(|(i, j)| {
                (0..3)
                    .map(|c| (x[i][c] - x[j][c]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max)
    };
    let input = RezoneInput {
        reference: &reference,
        current: &current,
        elements: &elements,
        movable: &movable,
        hanging: &[],
        surface_faces: &faces,
        sliding: &sliding,
    };
    // Undeformed, or stretched uniformly: the surface and the interior stay where they are.
    for f in [
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        [[1.2, 0.1, 0.0], [0.0, 0.9, 0.0], [0.0, 0.05, 0.95]],
    ] {
        let stretched: Vec<[f64; 3]> = reference.iter().map(|&x| apply(&f, x)).collect();
        let still = RezoneInput {
            current: &stretched,
            ..input
        };
        let motion = mesh_motion(&still).unwrap().expect("nodes may move");
        assert!(motion.surface.len() > 50 && motion.interior.len() > 100);
        assert_motion_is(&motion, &stretched, &format!("{f:?}"));
        assert_eq!(rezone(&still, Acceptance::Better).unwrap(), None, "{f:?}");
    }
    let rezoning = rezone(&input, Acceptance::Better)
        .unwrap()
        .expect("the swept surface is rezoned");
    let (x0, x) = rezoned(&rezoning, &reference, &current);
    let slid = (0..reference.len())
        .filter(|&n| sliding[n] && x0[n] != reference[n])
        .count();
    assert!(slid > 20, "{slid} surface nodes slid");
    for n in (0..reference.len()).filter(|&n| sliding[n]) {
        assert!(
            (x0[n][2] - 1.0).abs() < 1e-12,
            "node {n} left the surface: {:?}",
            x0[n]
        );
        // The old interpolation of the sweep at its material point: the exact map up to
        // the interpolation error (a wrong face or weights would be off by an element).
        let exact = sweep(x0[n]);
        for c in 0..3 {
            assert!((x[n][c] - exact[c]).abs() < 0.05, "{:?} vs {exact:?}", x[n]);
        }
    }
    let (before, after) = (longest(&current), longest(&x));
    assert!(
        after < 0.8 * before,
        "longest surface edge {before} -> {after}"
    );
    assert!(
        rezoning.min_corner_ratio_after > rezoning.min_corner_ratio_before,
        "{rezoning:?}"
    );
}

/// A locally refined block (tied hanging nodes inside and on the surface): the mesh
/// motion of a uniformly stretched block is the block itself (the harmonic extension and
/// the surface's harmonic sliding reproduce a linear field through the hanging-node ties),
/// and the crushed top is rezoned into a valid mesh whose hanging nodes stay on their
/// masters' edges and faces.
#[test]
fn the_mesh_motion_is_exact_through_hanging_nodes() {
    let base = box_mesh([-1.0, -1.0, 0.0], [2.0, 2.0, 1.0], [6, 6, 3], "gel").unwrap();
    let refined = crate::mesh::refine::refine_hex8(&base, |corners| {
        let c: [f64; 3] = std::array::from_fn(|i| corners.iter().map(|p| p[i]).sum::<f64>() / 8.0);
        let d = (c[0] * c[0] + c[1] * c[1] + (c[2] - 1.0).powi(2)).sqrt();
        if d < 0.5 {
            2
        } else if d < 0.9 {
            1
        } else {
            0
        }
    })
    .unwrap();
    let mesh = &refined.mesh;
    assert!(
        refined.hanging.len() > 20,
        "{} hanging nodes",
        refined.hanging.len()
    );
    let hanging: Vec<(usize, Vec<(usize, f64)>)> = refined
        .hanging
        .iter()
        .map(|h| (h.node, h.masters.clone()))
        .collect();
    let reference = mesh.nodes.clone();
    let elements = hexes(mesh);
    let top = |n: usize| reference[n][2] == 1.0;
    let side = |n: usize| {
        reference[n][0].abs() == 1.0 || reference[n][1].abs() == 1.0 || reference[n][2] == 0.0
    };
    let movable: Vec<bool> = (0..reference.len()).map(|n| !top(n) && !side(n)).collect();
    let sliding: Vec<bool> = (0..reference.len()).map(|n| top(n) && !side(n)).collect();
    let faces: Vec<[usize; 4]> = refined
        .boundary_faces
        .iter()
        .copied()
        .filter(|f| f.iter().all(|&n| top(n)))
        .collect();
    let f = [[1.2, 0.1, 0.0], [0.0, 0.9, 0.0], [0.0, 0.05, 0.95]];
    let stretched: Vec<[f64; 3]> = reference.iter().map(|&x| apply(&f, x)).collect();
    let input = RezoneInput {
        reference: &reference,
        current: &stretched,
        elements: &elements,
        movable: &movable,
        hanging: &hanging,
        surface_faces: &faces,
        sliding: &sliding,
    };
    let motion = mesh_motion(&input).unwrap().expect("nodes may move");
    assert!(motion.surface.len() > 20 && motion.interior.len() > 50);
    assert_motion_is(&motion, &stretched, "uniform stretch");
    // The crushed and swept top.
    let flow = dent(0.8, 0.2, 0.2, 8);
    // As a solver leaves it: hanging nodes on their masters.
    let mut current: Vec<[f64; 3]> = reference.iter().map(|&x| flow(x)).collect();
    for (h, masters) in &hanging {
        current[*h] =
            std::array::from_fn(|c| masters.iter().map(|&(m, w)| w * current[m][c]).sum());
    }
    let input = RezoneInput {
        current: &current,
        ..input
    };
    let rezoning = rezone(&input, Acceptance::Better)
        .unwrap()
        .expect("the flow is rezoned");
    assert!(rezoning.min_corner_ratio_after > rezoning.min_corner_ratio_before.max(0.0));
    let (x0, x) = rezoned(&rezoning, &reference, &current);
    for (h, masters) in &hanging {
        for (p, name) in [(&x0, "reference"), (&x, "current")] {
            let on: [f64; 3] =
                std::array::from_fn(|c| masters.iter().map(|&(m, w)| w * p[m][c]).sum());
            for c in 0..3 {
                assert!(
                    (p[*h][c] - on[c]).abs() < 1e-12,
                    "{name}: hanging node {h} off its masters"
                );
            }
        }
    }
}
