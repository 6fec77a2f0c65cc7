//! Scenarios with filaments, membranes and family switches: the mixed prestressed sphere,
//! beam families on and off, a membrane layer, line elements from a mesh file, outputs, and
//! located validation errors. `structures_newton_iteration_cost` (ignored) measures the cost
//! of ~2000 line elements on a ~20k-element continuum.

use std::path::{Path, PathBuf};

use cellmech::model::build;
use cellmech::scenario::{parse, Scenario};
use cellmech_fem::solve::{NullObserver, Problem};

fn scenario(text: &str) -> Scenario {
    parse(text, "test.toml", Path::new(".")).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

fn temp_dir(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("cellmech-structures-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Builds and runs every step; returns the problem at the end.
fn solve(s: &Scenario) -> Problem {
    let mut model = build(&s.model).unwrap_or_else(|e| panic!("{e}"));
    for step in &model.steps {
        model
            .problem
            .run_step(step, &mut NullObserver)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    model.problem
}

fn scalar(problem: &Problem, name: &str) -> Option<f64> {
    problem
        .terms()
        .iter()
        .flat_map(|t| t.scalar_outputs(problem.u(), problem.dof_map()))
        .find(|(n, _)| n == name)
        .map(|(_, v)| v)
}

const SPHERE: &str = r#"
title = "mixed"
[mesh]
source = "sphere"
radius = "16 um"
core_divisions = 4
shell_layers = 3

[[material]]
element_set = "solid"
shear_modulus = "0.17 kPa"
bulk_modulus = "17 kPa"
"#;

/// The 3-2-1 supports of a floating sphere: −x pole (x, y, z), +x pole (y, z), +y pole (z).
const SUPPORTS: &str = r#"
[[node_set]]
name = "a"
from = "surface"
x_max = "-15.99 um"
[[node_set]]
name = "b"
from = "surface"
x_min = "15.99 um"
[[node_set]]
name = "c"
from = "surface"
y_min = "15.99 um"

[[step]]
name = "prestress"
initial_increment = 1.0
max_increment = 1.0
  [[step.fix]]
  node_set = "a"
  [[step.fix]]
  node_set = "b"
  components = ["y", "z"]
  [[step.fix]]
  node_set = "c"
  components = ["z"]
"#;

/// Surface nodes nearest to the 12 icosahedron vertices and the 30 edges between them,
/// written as `points` pairs.
fn icosahedron_points(mesh_nodes: &[[f64; 3]], surface: &[usize]) -> (String, Vec<[usize; 2]>) {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v = Vec::new();
    for s1 in [-1.0, 1.0] {
        for s2 in [-1.0, 1.0] {
            v.push([0.0, s1, s2 * phi]);
            v.push([s1, s2 * phi, 0.0]);
            v.push([s2 * phi, 0.0, s1]);
        }
    }
    let dist = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    let sites: Vec<usize> = v
        .iter()
        .map(|d| {
            let n = dist(*d, [0.0; 3]);
            let p = d.map(|x| 16.0 * x / n);
            *surface
                .iter()
                .min_by(|&&a, &&b| dist(mesh_nodes[a], p).total_cmp(&dist(mesh_nodes[b], p)))
                .unwrap()
        })
        .collect();
    let mut pairs = Vec::new();
    for i in 0..12 {
        for j in i + 1..12 {
            if (dist(v[i], v[j]) - 2.0).abs() < 1e-9 {
                pairs.push([sites[i], sites[j]]);
            }
        }
    }
    assert_eq!(pairs.len(), 30);
    let fmt = |n: usize| {
        let x = mesh_nodes[n];
        format!(
            "[\"{:.6} um\", \"{:.6} um\", \"{:.6} um\"]",
            x[0], x[1], x[2]
        )
    };
    let text = pairs
        .iter()
        .map(|&[a, b]| format!("[{}, {}]", fmt(a), fmt(b)))
        .collect::<Vec<_>>()
        .join(",\n  ");
    (format!("[\n  {text}\n]"), pairs)
}

/// EA of the cables: E = 20 kPa, d = 0.25 µm.
fn cable_ea() -> f64 {
    20.0 * std::f64::consts::PI * 0.25f64.powi(2) / 4.0
}

fn prestressed_sphere(families: &str) -> (Scenario, Vec<[usize; 2]>) {
    let base = scenario(&format!("{SPHERE}{SUPPORTS}"));
    let (points, pairs) = icosahedron_points(
        &base.model.mesh.nodes,
        &base.model.mesh.node_sets["surface"],
    );
    let text = format!(
        r#"{SPHERE}
[[filament]]
name = "cortical cables"
family = "cables"
element = "truss"
points = {points}
youngs_modulus = "20 kPa"
diameter = "0.25 um"
prestrain = "24%"
tension_only = true
{families}
{SUPPORTS}"#
    );
    (scenario(&text), pairs)
}

#[test]
fn structures_prestressed_sphere_finds_its_self_equilibrium_with_unloaded_supports() {
    let (s, pairs) = prestressed_sphere("");
    for set in ["a", "b", "c"] {
        assert_eq!(
            s.model.mesh.node_sets[set].len(),
            1,
            "support {set} is one node"
        );
    }
    assert_eq!(
        s.model.structures.filaments[0].pairs, pairs,
        "points snapped to the FA nodes"
    );
    let problem = solve(&s);
    let ea = cable_ea();
    let n0 = ea * 0.24;
    // Supports take no load: the prestress is self-equilibrated.
    let map = problem.dof_map();
    let mut largest: f64 = 0.0;
    for (set, comps) in [("a", 0..3), ("b", 1..3), ("c", 2..3)] {
        let node = s.model.mesh.node_sets[set][0];
        for c in comps {
            largest = largest.max(problem.reaction(map.dof(node, c)).abs());
        }
    }
    assert!(
        largest < 1e-6 * n0,
        "support reaction {largest:e} nN vs N0 = {n0} nN"
    );
    // The continuum shortened the cables: every cable carries less than EA·p, still > 0.
    let max = scalar(&problem, "cables_axial_force_max_nN").unwrap();
    let min = scalar(&problem, "cables_axial_force_min_nN").unwrap();
    let mean = scalar(&problem, "cables_axial_force_mean_nN").unwrap();
    assert_eq!(scalar(&problem, "cables_in_tension"), Some(30.0));
    assert!(
        max < n0 && min > 0.0 && mean < max,
        "{min} {mean} {max} vs {n0}"
    );
    assert!(max < 0.99 * n0, "the sphere gave way: max {max} vs {n0}");
    println!("cable force min/mean/max {min:.4}/{mean:.4}/{max:.4} nN, EA·p = {n0:.4} nN");
    // The FA nodes moved inward (the surface dimples under the cables).
    let fa: std::collections::BTreeSet<usize> = pairs.iter().flatten().copied().collect();
    let radial: f64 = fa
        .iter()
        .map(|&n| {
            let x = s.model.mesh.nodes[n];
            let r = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
            (0..3)
                .map(|c| problem.u()[map.dof(n, c)] * x[c] / r)
                .sum::<f64>()
        })
        .sum::<f64>()
        / fa.len() as f64;
    assert!(
        radial < -1e-3,
        "mean radial displacement of the FAs {radial} µm"
    );
    println!("mean radial FA displacement {radial:.4} µm");

    // The same model with the family switched off: nothing moves, no cable columns.
    let (off, _) = prestressed_sphere("[families.cables]\nenabled = false\n");
    assert!(!off.model.structures.filaments[0].enabled);
    let problem = solve(&off);
    assert!(problem.u().iter().all(|&u| u == 0.0));
    assert_eq!(scalar(&problem, "cables_axial_force_max_nN"), None);
    assert_eq!(problem.terms().len(), 1, "only the continuum");

    // A family override: half the prestrain and 1.5 × the modulus gives 0.75 × EA·p at the
    // initial geometry; the solution pulls less than that.
    let (scaled, _) =
        prestressed_sphere("[families.cables]\nmodulus_scale = 1.5\nprestrain = \"12%\"\n");
    match &scaled.model.structures.filaments[0].element {
        cellmech::scenario::structures::FilamentElement::Truss(law) => {
            assert!((law.youngs_modulus - 30.0).abs() < 1e-12);
            assert_eq!(law.prestrain, 0.12);
        }
        other => panic!("{other:?}"),
    }
    let problem = solve(&scaled);
    let max_scaled = scalar(&problem, "cables_axial_force_max_nN").unwrap();
    assert!(
        max_scaled < 0.75 * n0 && max_scaled > 0.5 * max,
        "{max_scaled}"
    );
}

#[test]
fn structures_run_writes_family_columns_and_line_cells() {
    let (s, _) = prestressed_sphere("");
    let dir = temp_dir("run");
    let summary = cellmech::run::run(&s, &dir, &mut NullObserver).unwrap();
    let csv = std::fs::read_to_string(dir.join("curve.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for column in [
        "cables_axial_force_min_nN",
        "cables_axial_force_max_nN",
        "cables_axial_force_mean_nN",
        "cables_axial_stress_max_kPa",
        "cables_axial_strain_max",
        "cables_in_tension",
    ] {
        assert!(header.contains(column), "{column} in {header}");
    }
    // Final state: every cable at EA·p; the initial row has no prestress yet (the
    // prestrain ramps in over the first step).
    assert!((summary.final_values["cables_axial_force_max_nN"] - cable_ea() * 0.24).abs() < 0.05);
    let initial: Vec<f64> = csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let k = header
        .split(',')
        .position(|h| h == "cables_axial_stress_max_kPa")
        .unwrap();
    assert!(initial[k].abs() < 1e-12, "{}", initial[k]);
    let last_row: Vec<f64> = csv
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    // At equilibrium the sphere has contracted a little: the cables keep most of E·p.
    assert!(
        last_row[k] < 20.0 * 0.24 && last_row[k] > 0.8 * 20.0 * 0.24,
        "{}",
        last_row[k]
    );
    // The last frame holds the 352 hex8 cells and the 30 line cells with axial forces.
    let frames = std::fs::read_dir(&dir).unwrap();
    let last = frames
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "vtu"))
        .max()
        .unwrap();
    let vtu = std::fs::read_to_string(&last).unwrap();
    assert!(
        vtu.contains("Name=\"axial_force_nN\""),
        "{}",
        last.display()
    );
    assert!(vtu.contains("NumberOfCells=\"382\""));
    let types = data_array(&vtu, "types");
    assert_eq!(types.iter().filter(|&&t| t == 3).count(), 30, "line2 cells");
    assert_eq!(
        types.iter().filter(|&&t| t == 12).count(),
        352,
        "hex8 cells"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The bytes of a binary (base64, UInt64 header) DataArray of a VTU file.
fn data_array(vtu: &str, name: &str) -> Vec<u8> {
    cellmech_io::read_data_array(vtu, name).unwrap_or_else(|| panic!("no array {name}"))
}

const CAPS: &str = r#"
[[node_set]]
name = "top"
from = "surface"
z_min = "13 um"
[[node_set]]
name = "bottom"
from = "surface"
z_max = "-13 um"

[[step]]
name = "squeeze"
initial_increment = 0.5
max_increment = 0.5
  [[step.fix]]
  node_set = "top"
  components = ["x", "y"]
  [[step.fix]]
  node_set = "bottom"
  [[step.displace]]
  node_set = "top"
  z = "-0.2 um"

[[output.curve]]
name = "top"
node_set = "top"
component = "z"
reverse_sign = true
"#;

#[test]
fn structures_beam_family_on_and_off_both_solve_and_add_exactly_their_axial_forces() {
    let base = scenario(&format!("{SPHERE}{CAPS}"));
    let nodes = &base.model.mesh.nodes;
    // A fan of beams from the top pole to every bottom-cap node: the shared pole couples
    // their rotations (a lone straight beam between held nodes could spin about its axis).
    let bottom = &base.model.mesh.node_sets["bottom"];
    let pole = base.model.mesh.node_sets["top_pole"][0];
    let pairs: Vec<[usize; 2]> = bottom.iter().map(|&b| [pole, b]).collect();
    assert!(pairs.len() >= 5, "{} beams", pairs.len());
    let with = |families: &str| {
        scenario(&format!(
            r#"{SPHERE}
[[filament]]
name = "mts"
family = "microtubule"
element = "beam"
node_pairs = {pairs:?}
youngs_modulus = "1.2 GPa"
diameter = "25 nm"
inner_diameter = "17 nm"
{families}
{CAPS}"#
        ))
    };
    let on = with("");
    let off = with("[families.microtubule]\nenabled = false");
    let plain = solve(&base);
    let n = base.model.mesh.num_nodes();
    assert_eq!(plain.dof_map().num_dofs(), 3 * n);
    let p_on = solve(&on);
    assert_eq!(
        p_on.dof_map().num_dofs(),
        3 * n + 3 * (pairs.len() + 1),
        "6 DOFs at beam nodes"
    );
    let p_off = solve(&off);
    assert_eq!(
        p_off.dof_map().num_dofs(),
        3 * n,
        "no rotations without beams"
    );
    let top = |p: &Problem, s: &Scenario| {
        -p.reaction_sum(
            s.model.mesh.node_sets["top"]
                .iter()
                .map(|&t| p.dof_map().dof(t, 2)),
        )
    };
    let (f_plain, f_on, f_off) = (top(&plain, &base), top(&p_on, &on), top(&p_off, &off));
    assert_eq!(f_off, f_plain, "a disabled family is exactly absent");
    // Both ends of every beam are prescribed: the beams add their axial forces
    // N = EA (ℓ/L − 1) along the chords (bending and bowing are below 1e-4 of it).
    let section =
        cellmech_fem::element::beam::BeamSection::hollow_circular(1.2e6, 0.3, 0.025, 0.017)
            .unwrap();
    let ea = section.axial_stiffness();
    let chord = |[t, b]: [usize; 2]| {
        let d0: [f64; 3] = std::array::from_fn(|k| nodes[t][k] - nodes[b][k]);
        let d = [d0[0], d0[1], d0[2] - 0.2];
        let (l0, l) = (norm(d0), norm(d));
        (ea * (l / l0 - 1.0), d[2] / l)
    };
    let expected: f64 = pairs.iter().map(|&p| chord(p)).map(|(n, dz)| -n * dz).sum();
    assert!(
        ((f_on - f_plain) - expected).abs() < 1e-4 * expected,
        "beams add {} nN, expected {expected} nN (continuum {f_plain} nN)",
        f_on - f_plain
    );
    assert_eq!(
        scalar(&p_on, "microtubule_in_compression"),
        Some(pairs.len() as f64)
    );
    let n_min = pairs
        .iter()
        .map(|&p| chord(p).0)
        .fold(f64::INFINITY, f64::min);
    let got = scalar(&p_on, "microtubule_axial_force_min_nN").unwrap();
    assert!((got - n_min).abs() < 1e-4 * n_min.abs(), "{got} vs {n_min}");
    println!(
        "continuum {f_plain:.4} nN, with {} beams {f_on:.4} nN",
        pairs.len()
    );
}

#[test]
fn structures_membrane_on_the_outer_surface_stiffens_the_sphere() {
    let membrane = |families: &str| {
        scenario(&format!(
            r#"{SPHERE}
[[membrane]]
name = "cortex"
surface = "outer"
youngs_modulus = "2 kPa"
thickness = "0.2 um"
{families}
{CAPS}"#
        ))
    };
    let on = membrane("");
    assert_eq!(on.model.structures.membranes[0].faces.len(), 6 * 4 * 4);
    assert!((on.model.structures.membranes[0].shear_modulus - 2.0 / 3.0).abs() < 1e-12);
    let base = scenario(&format!("{SPHERE}{CAPS}"));
    let top = |s: &Scenario| {
        let p = solve(s);
        -p.reaction_sum(
            s.model.mesh.node_sets["top"]
                .iter()
                .map(|&t| p.dof_map().dof(t, 2)),
        )
    };
    let (f_plain, f_on) = (top(&base), top(&on));
    let f_off = top(&membrane("[families.cortex]\nenabled = false"));
    let f_soft = top(&membrane("[families.cortex]\nmodulus_scale = 0.5"));
    assert_eq!(f_off, f_plain);
    assert!(f_on > 1.02 * f_plain, "membrane {f_on} vs {f_plain}");
    assert!(
        f_soft > f_plain && f_soft < f_on,
        "{f_plain} < {f_soft} < {f_on}"
    );
    println!("cap force: plain {f_plain:.4}, cortex×0.5 {f_soft:.4}, cortex {f_on:.4} nN");
}

#[test]
fn structures_filaments_from_a_line2_element_set_of_an_abaqus_file() {
    let dir = temp_dir("inp");
    let inp = "*NODE\n1, 0, 0, 0\n2, 2, 0, 0\n3, 2, 2, 0\n4, 0, 2, 0\n5, 0, 0, 2\n6, 2, 0, 2\n\
               7, 2, 2, 2\n8, 0, 2, 2\n*ELEMENT, TYPE=C3D8, ELSET=solid\n1, 1, 2, 3, 4, 5, 6, 7, 8\n\
               *ELEMENT, TYPE=T3D2, ELSET=diagonals\n2, 1, 7\n3, 2, 8\n\
               *NSET, NSET=bottom\n1, 2, 3, 4\n";
    std::fs::write(dir.join("cube.inp"), inp).unwrap();
    let text = r#"
[mesh]
source = "file"
path = "cube.inp"
[[material]]
element_set = "solid"
shear_modulus = "1 kPa"
bulk_modulus = "100 kPa"
[[filament]]
name = "diagonals"
family = "actin"
element = "truss"
element_set = "diagonals"
youngs_modulus = "100 kPa"
diameter = "0.1 um"
prestrain = "10%"
tension_only = true
[[step]]
  [[step.fix]]
  node_set = "bottom"
"#;
    let s = parse(text, "cube.toml", &dir).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.model.structures.filaments[0].pairs.len(), 2);
    let p = solve(&s);
    let n0 = 100.0 * std::f64::consts::PI * 0.01 / 4.0 * 0.1;
    let max = scalar(&p, "actin_axial_force_max_nN").unwrap();
    assert!(max > 0.0 && max < n0, "{max} vs {n0}");
    assert_eq!(scalar(&p, "actin_in_tension"), Some(2.0));
    // The diagonals pull the top face down.
    let top_z: f64 = (4..8).map(|n| p.u()[p.dof_map().dof(n, 2)]).sum::<f64>() / 4.0;
    assert!(top_z < 0.0, "{top_z}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Each bad input gives an error naming the line, the key and what was expected.
#[test]
fn structures_reject_bad_input_with_located_messages() {
    let filament = |body: &str| format!("{SPHERE}\n[[filament]]\nname = \"f\"\n{body}\n{CAPS}");
    let pts = "points = [[[\"0 um\", \"0 um\", \"16 um\"], [\"0 um\", \"0 um\", \"-16 um\"]]]";
    let cases: Vec<(String, &str, &str)> = vec![
        (
            filament(&format!("element = \"truss\"\n{pts}\nyoungs_modulus = \"0 kPa\"\ndiameter = \"7 nm\"")),
            "filament[0].youngs_modulus",
            "expected a Young's modulus > 0",
        ),
        (
            filament(&format!("element = \"truss\"\n{pts}\nyoungs_modulus = \"1 GPa\"\ndiameter = \"-7 nm\"")),
            "filament[0].diameter",
            "expected a diameter > 0",
        ),
        (
            filament(&format!("element = \"beam\"\n{pts}\nyoungs_modulus = \"1 GPa\"")),
            "filament[0].diameter",
            "a filament needs a section",
        ),
        (
            filament(&format!(
                "element = \"truss\"\n{pts}\nyoungs_modulus = \"1 GPa\"\ndiameter = \"7 nm\"\nprestrain = \"-100%\""
            )),
            "filament[0].prestrain",
            "expected a prestrain > -100 %",
        ),
        (
            filament(&format!(
                "element = \"beam\"\n{pts}\nyoungs_modulus = \"1 GPa\"\ndiameter = \"17 nm\"\ninner_diameter = \"25 nm\""
            )),
            "filament[0].inner_diameter",
            "expected 0 < inner_diameter < diameter",
        ),
        (
            filament("element = \"truss\"\nnode_pairs = [[0, 99999]]\nyoungs_modulus = \"1 GPa\"\ndiameter = \"7 nm\""),
            "filament[0].node_pairs",
            "node 99999 does not exist",
        ),
        (
            filament("element = \"truss\"\npoints = [[[\"0 um\", \"0 um\", \"15 um\"], [\"0 um\", \"0 um\", \"-16 um\"]]]\nyoungs_modulus = \"1 GPa\"\ndiameter = \"7 nm\""),
            "filament[0].points[0][0]",
            "is 1.0000 µm from the nearest mesh node",
        ),
        (
            filament("element = \"truss\"\nelement_set = \"solid\"\nyoungs_modulus = \"1 GPa\"\ndiameter = \"7 nm\""),
            "filament[0].element_set",
            "holds hex8 elements; a filament needs line2",
        ),
        (
            filament(&format!("element = \"cable\"\n{pts}\nyoungs_modulus = \"1 GPa\"\ndiameter = \"7 nm\"")),
            "filament[0].element",
            "expected \"truss\" or \"beam\"",
        ),
        (
            filament(&format!(
                "element = \"beam\"\n{pts}\nyoungs_modulus = \"1 GPa\"\ndiameter = \"7 nm\"\nprestrain = \"24%\""
            )),
            "filament[0].prestrain",
            "applies to trusses only",
        ),
        (
            filament(&format!(
                "element = \"truss\"\n{pts}\nyoungs_modulus = \"1 GPa\"\ndiameter = \"7 nm\"\n\
                 [families.actin]\nenabled = false"
            )),
            "families.actin",
            "no filament or membrane belongs to family \"actin\"",
        ),
        (
            filament(&format!(
                "element = \"truss\"\n{pts}\nyoungs_modulus = \"1 GPa\"\ndiameter = \"7 nm\"\n\
                 [families.f]\nmodulus_scale = -1.5"
            )),
            "families.f.modulus_scale",
            "expected a factor > 0",
        ),
        (
            format!("{SPHERE}\n[[membrane]]\nname = \"cm\"\nsurface = \"outer\"\nshear_modulus = \"0.33 MPa\"\nthickness = \"-10 nm\"\n{CAPS}"),
            "membrane[0].thickness",
            "expected a thickness > 0",
        ),
        (
            format!("{SPHERE}\n[[membrane]]\nname = \"cm\"\nnode_set = \"nope\"\nshear_modulus = \"0.33 MPa\"\nthickness = \"10 nm\"\n{CAPS}"),
            "membrane[0].node_set",
            "no node set \"nope\"",
        ),
    ];
    for (text, key, fragment) in cases {
        let err = parse(&text, "bad.toml", Path::new("."))
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("bad.toml:"), "{err}");
        assert!(err.contains(&format!("`{key}`")), "key {key}: {err}");
        assert!(err.contains(fragment), "{fragment}: {err}");
        // The line points into the offending section (after the [[filament]]/[[membrane]]
        // header, which follows the 13 lines of SPHERE).
        let line: usize = err["bad.toml:".len()..]
            .split(':')
            .next()
            .unwrap()
            .parse()
            .unwrap_or_else(|_| panic!("no line in {err}"));
        assert!(line > 13, "line {line}: {err}");
    }
    // A bare number where a length is needed is a parse error naming the unit.
    let err = parse(
        &filament(&format!(
            "element = \"truss\"\n{pts}\nyoungs_modulus = \"1 GPa\"\ndiameter = 0.007"
        )),
        "bad.toml",
        Path::new("."),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("line") || err.contains("bad.toml"), "{err}");
    assert!(err.contains("length"), "{err}");
}

/// Time per Newton iteration on a ~20k-element sphere with and without ~2000 trusses
/// between random surface node pairs (seeded). Run with
/// `cargo test --release -p cellmech --test structures -- --ignored --nocapture`.
#[test]
#[ignore]
fn structures_newton_iteration_cost() {
    let sphere = r#"
[mesh]
source = "sphere"
radius = "16 um"
core_divisions = 16
shell_layers = 10
[[material]]
element_set = "solid"
shear_modulus = "0.17 kPa"
bulk_modulus = "17 kPa"
"#;
    let base = scenario(&format!("{sphere}{CAPS}"));
    let surface = &base.model.mesh.node_sets["surface"];
    let mut state: u64 = 0x5eed;
    let mut next = |n: usize| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) as usize) % n
    };
    let mut pairs = Vec::new();
    while pairs.len() < 2000 {
        let (a, b) = (surface[next(surface.len())], surface[next(surface.len())]);
        if a != b {
            pairs.push([a, b]);
        }
    }
    let with = scenario(&format!(
        r#"{sphere}
[[filament]]
name = "random"
family = "actin"
element = "truss"
node_pairs = {pairs:?}
youngs_modulus = "20 kPa"
diameter = "0.1 um"
{CAPS}"#
    ));
    // The same count of short cables: each between a random surface node and a random
    // surface node within 4 µm (local couplings, like a cortical network).
    let nodes = &base.model.mesh.nodes;
    let mut local = Vec::new();
    while local.len() < 2000 {
        let a = surface[next(surface.len())];
        let near: Vec<usize> = surface
            .iter()
            .copied()
            .filter(|&b| b != a && norm(std::array::from_fn(|k| nodes[a][k] - nodes[b][k])) < 4.0)
            .collect();
        if !near.is_empty() {
            local.push([a, near[next(near.len())]]);
        }
    }
    let with_local = scenario(&format!(
        r#"{sphere}
[[filament]]
name = "local"
family = "actin"
element = "truss"
node_pairs = {local:?}
youngs_modulus = "20 kPa"
diameter = "0.1 um"
{CAPS}"#
    ));
    let mut report = Vec::new();
    for (label, s) in [
        ("continuum", &base),
        ("continuum + 2000 random chords", &with),
        ("continuum + 2000 local cables", &with_local),
    ] {
        let mut model = build(&s.model).unwrap();
        let mut counter = Counter(0);
        let start = std::time::Instant::now();
        for step in &model.steps {
            model.problem.run_step(step, &mut counter).unwrap();
        }
        let t = start.elapsed().as_secs_f64();
        let nnz = model.problem.assembler().pattern().nnz();
        let fill = model
            .problem
            .last_factor()
            .map(|f| format!("{f:?}"))
            .unwrap_or_default();
        println!(
            "{label}: {} elements, {} dofs, nnz {nnz}, {} iterations, {t:.2} s, {:.3} s/iteration, timings {:?}, factor {fill}",
            s.model.mesh.num_elements(),
            model.problem.dof_map().num_dofs(),
            counter.0,
            t / counter.0 as f64,
            model.problem.timings()
        );
        report.push(t / counter.0 as f64);
    }
    println!(
        "ratio random {:.3}, local {:.3}",
        report[1] / report[0],
        report[2] / report[0]
    );
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

struct Counter(usize);
impl cellmech_fem::solve::Observer for Counter {
    fn on_iteration(&mut self, _r: &cellmech_fem::solve::IterationReport) {
        self.0 += 1;
    }
}

/// The shipped tutorial runs in seconds and shows the prestressed equilibrium.
#[test]
fn structures_prestressed_sphere_example_reaches_its_equilibrium() {
    let example = cellmech::examples::find("prestressed-sphere").unwrap();
    let s = cellmech::examples::scenario(example).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.model.structures.filaments[0].pairs.len(), 24);
    let start = std::time::Instant::now();
    let problem = solve(&s);
    let elapsed = start.elapsed().as_secs_f64();
    let n0 = 340.0 * std::f64::consts::PI * 0.25f64.powi(2) / 4.0 * 0.24;
    let max = scalar(&problem, "bundle_axial_force_max_nN").unwrap();
    let min = scalar(&problem, "bundle_axial_force_min_nN").unwrap();
    assert!(min > 0.0 && max < n0, "{min} {max} vs N0 {n0}");
    let map = problem.dof_map();
    let mut largest: f64 = 0.0;
    for (set, comps) in [("a", 0..3), ("b", 1..3), ("c", 2..3)] {
        let node = s.model.mesh.node_sets[set][0];
        for c in comps {
            largest = largest.max(problem.reaction(map.dof(node, c)).abs());
        }
    }
    assert!(largest < 1e-6 * n0, "support reaction {largest:e}");
    println!("example: N0 {n0:.4} nN, cables {min:.4}..{max:.4} nN, {elapsed:.2} s");
    assert!(elapsed < 30.0, "{elapsed} s");
}
