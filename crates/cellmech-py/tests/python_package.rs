//! The Python package, built and tested as a user would get it, from `cargo test`.
//!
//! GOAL: the README's test command also runs the Python tests on a fresh machine. This test
//! creates a venv under `target/tmp/`, installs maturin, pytest and numpy from PyPI, builds
//! the wheel with `maturin build --release` (into the workspace's target directory, so the
//! dependencies built for the Rust tests are reused), installs it and runs
//! `crates/cellmech-py/tests/test_cellmech.py` with pytest; it fails with pytest's output.
//! It is skipped, saying so, only when no `python3` is found (`CELLMECH_PYTHON` names
//! another interpreter).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Instant;

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("the workspace root exists")
}

fn run(what: &str, cmd: &mut Command) -> Output {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot start {cmd:?}: {e}"));
    if !out.status.success() {
        panic!(
            "{what} failed ({}):\n--- stdout ---\n{}\n--- stderr ---\n{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    out
}

/// The target directory cargo builds into (maturin builds the wheel there too).
fn target_dir(root: &Path) -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map(|p| if p.is_absolute() { p } else { root.join(p) })
        .unwrap_or_else(|| root.join("target"))
}

#[test]
fn python_package_builds_installs_and_passes_pytest() {
    let total = Instant::now();
    let python = std::env::var("CELLMECH_PYTHON").unwrap_or_else(|_| "python3".into());
    match Command::new(&python).arg("--version").output() {
        Ok(o) if o.status.success() => {}
        _ => {
            println!(
                "SKIPPED: no `{python}` found: the Python package (crates/cellmech-py) is not \
                 built or tested on this machine"
            );
            return;
        }
    }
    let root = workspace_root();
    let target = target_dir(&root);
    let venv = Path::new(env!("CARGO_TARGET_TMPDIR")).join("python-venv");
    let bin = venv.join("bin");
    let vpython = bin.join("python");
    let mut times = Vec::new();
    let t = Instant::now();
    if !vpython.exists() {
        run(
            "creating the venv",
            Command::new(&python).args(["-m", "venv"]).arg(&venv),
        );
    }
    run(
        "pip install maturin pytest numpy",
        Command::new(&vpython).args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "maturin>=1.9,<2",
            "pytest",
            "numpy",
        ]),
    );
    times.push(("venv + pip", t.elapsed().as_secs_f64()));

    // The CLI, for the tests that compare with `cellmech run` (already built by
    // `cargo test --workspace`; built here when this test runs alone).
    let cli = target.join("release").join("cellmech");
    if !cli.exists() {
        let t = Instant::now();
        run(
            "building the CLI",
            Command::new(env!("CARGO"))
                .args(["build", "--release", "-p", "cellmech-cli"])
                .current_dir(&root),
        );
        times.push(("cargo build cellmech-cli", t.elapsed().as_secs_f64()));
    }

    let t = Instant::now();
    let wheels = Path::new(env!("CARGO_TARGET_TMPDIR")).join("python-wheels");
    let _ = std::fs::remove_dir_all(&wheels);
    run(
        "maturin build",
        Command::new(bin.join("maturin"))
            .args(["build", "--release", "--quiet", "-m"])
            .arg(root.join("crates/cellmech-py/Cargo.toml"))
            .arg("--interpreter")
            .arg(&vpython)
            .arg("--out")
            .arg(&wheels)
            .current_dir(&root),
    );
    times.push(("maturin build --release", t.elapsed().as_secs_f64()));
    let wheel = std::fs::read_dir(&wheels)
        .expect("maturin wrote the wheel directory")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.extension().is_some_and(|x| x == "whl"))
        .expect("maturin wrote a wheel");
    let t = Instant::now();
    run(
        "pip install the wheel",
        Command::new(&vpython)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
                "--force-reinstall",
                "--no-deps",
            ])
            .arg(&wheel),
    );
    times.push(("pip install the wheel", t.elapsed().as_secs_f64()));

    let t = Instant::now();
    let pytest = Command::new(&vpython)
        .args(["-m", "pytest", "-p", "no:cacheprovider", "-q", "-rs", "-s"])
        .arg(root.join("crates/cellmech-py/tests"))
        .env("CELLMECH_BIN", &cli)
        .current_dir(std::env::temp_dir())
        .output()
        .expect("pytest starts");
    times.push(("pytest", t.elapsed().as_secs_f64()));
    let stdout = String::from_utf8_lossy(&pytest.stdout);
    let stderr = String::from_utf8_lossy(&pytest.stderr);
    assert!(
        pytest.status.success(),
        "pytest failed ({}):\n{stdout}\n{stderr}",
        pytest.status
    );
    println!("{stdout}");
    for (what, s) in &times {
        println!("{what}: {s:.1} s");
    }
    println!(
        "Python package test: {:.1} s in all ({})",
        total.elapsed().as_secs_f64(),
        wheel.display()
    );
}
