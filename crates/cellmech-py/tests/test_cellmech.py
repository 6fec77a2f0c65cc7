"""Tests of the Python package `cellmech` (run by tests/python_package.rs, which builds and
installs the wheel in a venv under target/, as part of `cargo test --workspace --release`).

The coarse suspended cell (448 hex8: core_divisions = 4, shell_layers = 2, outer_layers = 2)
in micropipette tension is run once per session from a file, once from keywords, and once
with the CLI (`CELLMECH_BIN`, set by the harness) to compare.
"""

import csv
import json
import math
import os
import shutil
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import cellmech

COARSE_TENSION = """\
title = "coarse tension"

[cell]
core_divisions = 4
shell_layers = 2
outer_layers = 2

[protocol]
kind = "micropipette-tension"

[output]
vtk_every = 0
"""

# A block squeezed beyond zero length with at most 2 Newton iterations: the analysis stops.
DIVERGING_BLOCK = """\
title = "diverging block"

[mesh]
source = "box"
size = ["10 um", "10 um", "10 um"]
divisions = [1, 1, 1]

[[material]]
element_set = "solid"
shear_modulus = "0.17 kPa"
poisson_ratio = 0.45

[[step]]
name = "squeeze"
initial_increment = 0.25
min_increment = 0.1
max_iterations = 2
  [[step.fix]]
  node_set = "x_min"
  components = ["x"]
  [[step.fix]]
  node_set = "y_min"
  components = ["y"]
  [[step.fix]]
  node_set = "z_min"
  components = ["z"]
  [[step.displace]]
  node_set = "x_max"
  x = "-15 um"

[output]
vtk_every = 0
"""


def cli_binary():
    path = os.environ.get("CELLMECH_BIN")
    if path and os.path.exists(path):
        return path
    found = shutil.which("cellmech")
    if found is None:
        pytest.skip("the cellmech CLI is not built (set CELLMECH_BIN)")
    return found


@pytest.fixture(scope="session")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("cellmech")


@pytest.fixture(scope="session")
def scenario_file(workdir):
    path = workdir / "coarse-tension.toml"
    path.write_text(COARSE_TENSION)
    return path


@pytest.fixture(scope="session")
def tension(workdir, scenario_file):
    """The coarse tension run from the file, with a progress callback and a thread that
    counts while the solver works."""
    analysis = cellmech.load(scenario_file)
    calls = []
    ticks = [0]
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            ticks[0] += 1
            time.sleep(0.002)

    thread = threading.Thread(target=ticker)
    thread.start()
    start = time.perf_counter()
    result = analysis.run(workdir / "py-out", progress=calls.append)
    seconds = time.perf_counter() - start
    stop.set()
    thread.join()
    print(f"\ncoarse tension from Python: {seconds:.2f} s")
    return {"result": result, "calls": calls, "ticks": ticks[0], "seconds": seconds}


# --- errors ------------------------------------------------------------------------------


def test_parse_error_is_a_value_error_naming_the_key():
    with pytest.raises(cellmech.ScenarioError) as e:
        cellmech.parse('[cell]\ncytoplasm.shear_modulos = "1 kPa"\n', origin="bad.toml")
    assert isinstance(e.value, ValueError)
    message = str(e.value)
    assert "bad.toml:2" in message
    assert "`cell.cytoplasm.shear_modulos`" in message
    assert "did you mean `cytoplasm.shear_modulus`?" in message


def test_parse_error_wrong_unit_names_the_key():
    with pytest.raises(cellmech.ScenarioError, match=r"`cell\.cytoplasm\.shear_modulus`"):
        cellmech.parse('[cell]\ncytoplasm.shear_modulus = "1 um"\n')


def test_unknown_top_level_key_suggests():
    with pytest.raises(cellmech.ScenarioError, match="did you mean `title`"):
        cellmech.parse('titel = "x"\n')


def test_load_missing_file():
    with pytest.raises(cellmech.ScenarioError, match="cannot read the scenario"):
        cellmech.load("/nonexistent/cellmech.toml")


def test_error_message_is_the_cli_message(workdir):
    bad = workdir / "bad.toml"
    bad.write_text('[cell]\ncore_divisions = 4\nnucleus.shear_modulus = "-1 kPa"\n')
    with pytest.raises(cellmech.ScenarioError) as e:
        cellmech.load(bad)
    cli = subprocess.run([cli_binary(), "check", str(bad)], capture_output=True, text=True)
    assert cli.returncode != 0
    assert str(e.value) in cli.stderr, (str(e.value), cli.stderr)


def test_keyword_unknown_name_rejected_with_the_table_message():
    with pytest.raises(cellmech.ScenarioError) as e:
        cellmech.SuspendedCell(cytoplasm__shear_modulos="0.17 kPa")
    message = str(e.value)
    assert "`cell.cytoplasm.shear_modulos`" in message
    assert "unknown key for suspended-cell; did you mean `cytoplasm.shear_modulus`?" in message


def test_keyword_values_checked():
    with pytest.raises(cellmech.ScenarioError, match=r"`cell\.core_divisions`"):
        cellmech.suspended_cell(core_divisions="four")
    with pytest.raises(cellmech.ScenarioError, match=r"`cell\.cytoplasm\.shear_modulus`"):
        cellmech.suspended_cell({"cytoplasm.shear_modulus": "-0.17 kPa"})
    with pytest.raises(cellmech.ScenarioError, match=r"`protocol\.elongation`"):
        cellmech.MicropipetteTension(elongation="6.3 kPa")
    with pytest.raises(cellmech.ScenarioError, match="is a key of"):
        cellmech.MicropipetteTension(site="apex")
    with pytest.raises(cellmech.ScenarioError, match="given twice"):
        cellmech.suspended_cell({"cytoplasm.shear_modulus": "1 kPa"}, cytoplasm__shear_modulus="1 kPa")


def test_keyword_cell_params_are_nested():
    cell = cellmech.SuspendedCell({"cytoplasm.poisson_ratio": 0.45}, core_divisions=4)
    assert cell.params == {"model": "suspended", "cytoplasm": {"poisson_ratio": 0.45}, "core_divisions": 4}


def test_parameters_table():
    text = cellmech.parameters("suspended-cell")
    assert "cytoplasm.shear_modulus" in text
    with pytest.raises(ValueError, match="micropipette-tension"):
        cellmech.parameters("nope")


def test_non_callable_progress_is_rejected(workdir):
    with pytest.raises(TypeError, match="progress"):
        cellmech.parse(DIVERGING_BLOCK).run(workdir / "x", progress=3)


# --- the coarse tension test -------------------------------------------------------------


def test_run_returns_numpy_arrays(tension):
    r = tension["result"]
    assert r.status == "completed" and r.ok and r.error is None
    assert isinstance(r.force, np.ndarray) and r.force.dtype == np.float64
    assert r.force.shape == r.displacement.shape and len(r.force) > 5
    assert r.displacement[-1] == pytest.approx(6.3, rel=1e-9)
    assert set(r.curve) == set(r.curve_columns)
    rows = {len(a) for a in r.curve.values()}
    assert len(rows) == 1 and rows.pop() > len(r.force)
    assert all(a.dtype == np.float64 for a in r.curve.values())
    # The coarse cell's force at 6.3 um is a few tens of nN.
    assert 5.0 < r.force[-1] < 200.0


def test_last_force_equals_summary_json_and_csv_files(tension):
    r = tension["result"]
    out = r.out_dir
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    assert summary["protocol"]["last"]["force_nn"] == r.force[-1] == r.last_force_nn
    assert summary == r.summary
    with open(os.path.join(out, "curve.csv")) as f:
        rows = list(csv.reader(f))
    header, last = rows[0], rows[-1]
    assert header == r.curve_columns
    for name, text in zip(header, last):
        value = float(text) if text else math.nan
        assert value == r.curve[name][-1] or (math.isnan(value) and math.isnan(r.curve[name][-1])), name
    for name, value in summary["final_values"].items():
        assert r.curve[name][-1] == value, name


def test_progress_callback_called_per_converged_increment(tension):
    calls = tension["calls"]
    increments = sum(s["increments"] for s in tension["result"].summary["steps"])
    assert len(calls) == increments > 0
    assert set(calls[0]) == {"step", "step_name", "increment", "step_time", "total_time", "iterations", "energy"}
    assert calls[-1]["step_time"] == pytest.approx(1.0)
    assert [c["step_name"] for c in calls][-1] == tension["result"].summary["steps"][-1]["name"]


def test_gil_released_during_the_run(tension):
    # The ticker sleeps 2 ms per tick: with the GIL held by the solver it would only run
    # during the progress callbacks.
    expected = tension["seconds"] / 0.002
    assert tension["ticks"] > 0.3 * expected, (tension["ticks"], expected)


def test_filaments_table(tension):
    r = tension["result"]
    f = r.filaments
    assert f is not None and list(f) == r.filament_columns
    n = len(f["family"])
    assert all(len(a) == n for a in f.values())
    assert set(f["family"]) >= {"actin", "microtubule", "intermediate"} or len(set(f["family"])) >= 3
    assert f["fa_force_nN"].dtype == np.float64
    assert f["state"].dtype.kind == "U"


def test_to_pandas(tension):
    r = tension["result"]
    try:
        import pandas  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match="pip install pandas"):
            r.to_pandas()
        return
    df = r.to_pandas()
    assert list(df.columns) == r.curve_columns
    assert r.to_pandas("test")["force_nn"].iloc[-1] == r.force[-1]


def test_same_numbers_as_the_cli(tension, scenario_file, workdir):
    out = workdir / "cli-out"
    start = time.perf_counter()
    cli = subprocess.run(
        [cli_binary(), "run", str(scenario_file), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
    )
    seconds = time.perf_counter() - start
    print(f"\ncoarse tension from the CLI: {seconds:.2f} s (Python: {tension['seconds']:.2f} s)")
    assert cli.returncode == 0, cli.stderr
    py_out = tension["result"].out_dir
    for name in ["curve.csv", "tension.csv", "filaments.csv", "increments.csv"]:
        with open(out / name) as a, open(os.path.join(py_out, name)) as b:
            assert a.read() == b.read(), name


def test_keyword_experiment_runs_like_the_file(tension, workdir):
    analysis = cellmech.experiment(
        cellmech.SuspendedCell(core_divisions=4, shell_layers=2, outer_layers=2),
        cellmech.MicropipetteTension(),
        title="coarse tension",
        output={"vtk_every": 0},
    )
    assert "[protocol]" in analysis.toml and 'kind = "micropipette-tension"' in analysis.toml
    assert analysis.steps == cellmech.parse(COARSE_TENSION).steps
    r = analysis.run(workdir / "kw-out")
    assert np.array_equal(r.force, tension["result"].force)
    assert np.array_equal(r.displacement, tension["result"].displacement)


def test_experiment_protocol_must_fit_the_cell():
    with pytest.raises(cellmech.ScenarioError):
        cellmech.experiment(cellmech.AdherentCell(), cellmech.MicropipetteTension())


# --- a diverging analysis ----------------------------------------------------------------


def test_diverging_analysis_returns_a_failed_result(workdir):
    r = cellmech.parse(DIVERGING_BLOCK).run(workdir / "diverge")
    assert r.status == "failed" and not r.ok
    assert r.error.startswith("the analysis stopped:")
    assert r.summary["status"] == "failed" and r.summary["error"] in r.error
    with pytest.raises(cellmech.AnalysisError) as e:
        cellmech.parse(DIVERGING_BLOCK).run(workdir / "diverge-check", check=True)
    assert isinstance(e.value, cellmech.RunError)
    assert e.value.result.status == "failed"


def test_progress_exception_is_raised_after_the_run(workdir):
    def boom(info):
        raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        cellmech.parse(DIVERGING_BLOCK.replace('x = "-15 um"', 'x = "2 um"')).run(workdir / "boom", progress=boom)


def test_example_script_runs(workdir):
    script = os.path.join(os.path.dirname(__file__), "..", "..", "..", "examples", "python", "tension.py")
    out = workdir / "example"
    run = subprocess.run([sys.executable, script, str(out)], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "completed" in run.stdout and "6.300" in run.stdout
    assert (out / "summary.json").exists()
