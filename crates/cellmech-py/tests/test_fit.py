"""cellmech.fit from Python: a one-parameter fit of the coarse suspended cell in tension to
a synthetic curve (seeded noise) gives back the cytoplasm modulus within its reported
error, as numpy; a second call on the same output directory solves no FE run; a misspelt
key is a ScenarioError. Kept short: the coarse cell stretched 2 um in 8 increments."""

import numpy as np
import pytest

import cellmech

TRUE_G_KPA = 0.17
NOISE_NN = 0.05
SEED = 3

FIT = """
title = "python round trip"
base = "suspended-tension"
data = "curve.csv"
[set]
"cell.core_divisions" = 4
"cell.shell_layers" = 2
"cell.outer_layers" = 2
"protocol.elongation" = "2 um"
"protocol.max_increment" = 0.125
"output.vtk_every" = 0
[[parameter]]
key = "cell.cytoplasm.shear_modulus"
start = "0.24 kPa"
lower = "0.02 kPa"
upper = "2 kPa"
[optimizer]
max_runs = 15
"""


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    d = tmp_path_factory.mktemp("fit")
    truth = cellmech.SuspendedCell(core_divisions=4, shell_layers=2, outer_layers=2,
                                   cytoplasm__shear_modulus=f"{TRUE_G_KPA} kPa")
    protocol = cellmech.MicropipetteTension(elongation="2 um", max_increment=0.125)
    result = cellmech.experiment(truth, protocol, output={"vtk_every": 0}).run(d / "truth", check=True)
    rng = np.random.default_rng(SEED)
    force = result.force + rng.normal(0.0, NOISE_NN, result.force.shape)
    lines = ["# synthetic: coarse cell, G = 0.17 kPa, noise 0.05 nN (numpy seed 3)",
             "elongation [um],force [nN]"]
    lines += [f"{float(x)!r},{float(f)!r}" for x, f in zip(result.displacement, force)]
    (d / "curve.csv").write_text("\n".join(lines) + "\n")
    events = []
    fit = cellmech.fit(FIT, d / "out", progress=events.append, base_dir=d)
    return {"dir": d, "fit": fit, "events": events}


def test_the_modulus_comes_back_within_its_error(fitted):
    fit = fitted["fit"]
    assert fit.keys == ["cell.cytoplasm.shear_modulus"] and fit.units == ["kPa"]
    assert isinstance(fit.values, np.ndarray) and fit.values.shape == (1,)
    value, error = fit.values[0], fit.errors[0]
    print(f"\nG = {value:.5f} ± {error:.5f} kPa (true {TRUE_G_KPA}); {fit.evaluations} evaluations, {fit.wall_time_s:.1f} s")
    assert fit.converged
    assert 0 < error < 0.1 * value
    assert abs(value - TRUE_G_KPA) < 3 * error
    assert fit.correlation.shape == (1, 1) and fit.correlation[0, 0] == pytest.approx(1.0)
    assert fit.runs == fit.evaluations == len(fitted["events"])
    assert fitted["events"][0]["values"] == [0.24] and not fitted["events"][0]["cached"]
    c = fit.curve
    assert c["x"].shape == c["measured"].shape == c["fitted"].shape
    assert np.all(np.isfinite(c["fitted"])) and c["in_range"].all()
    assert fit.history["values"].shape[1] == 1
    assert fit.parameters["cell.cytoplasm.shear_modulus"][0] == value


def test_a_second_call_reuses_every_run(fitted):
    again = cellmech.fit(FIT, fitted["dir"] / "out", base_dir=fitted["dir"])
    assert again.runs == 0
    assert again.values[0] == fitted["fit"].values[0]


def test_a_misspelt_key_is_a_scenario_error(fitted):
    bad = FIT.replace("shear_modulus", "shear_modulos")
    with pytest.raises(cellmech.ScenarioError, match="did you mean"):
        cellmech.fit(bad, fitted["dir"] / "bad", base_dir=fitted["dir"])
    with pytest.raises(cellmech.ScenarioError, match="no such file"):
        cellmech.fit(fitted["dir"] / "missing.toml", fitted["dir"] / "bad")
