"""Fit the cytoplasm and cortex moduli of the adherent cell to an AFM curve, from Python.

Notebook-style: each block below is a cell. The measured curve is the synthetic one
shipped as examples/fit-afm-curve.csv (made from known moduli plus seeded noise, as its
header says), so the answer is known: 0.17 kPa and 2 kPa. The fit runs the coarse
adherent cell about 15 times (13-25 s each on 2 cores); every run is kept in
OUT/runs/, so running the script again (or after an interruption) reuses them.

    pip install maturin && maturin develop --release -m crates/cellmech-py/Cargo.toml
    python examples/python/fit_afm.py [FIT_FILE] [OUT_DIR]

With FIT_FILE = examples/fit-tension.toml it fits the tensile curve instead (cytoplasm
and membrane moduli of the suspended cell, about 18 runs of 3 s).
"""

import os
import sys

import cellmech

HERE = os.path.dirname(os.path.abspath(__file__))

# %% The fit file: experiment, measured curve, parameters with start and bounds.
fit_file = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "..", "fit-afm.toml")
out_dir = sys.argv[2] if len(sys.argv) > 2 else "cellmech-out/python-fit"
print(open(fit_file).read())

# %% Fit, printing one line per FE run.
def progress(run):
    values = ", ".join(f"{v:.5g}" for v in run["values"])
    what = "cached" if run["cached"] else f"{run['wall_time_s']:.1f} s"
    rms = "rejected" if run["rms"] is None else f"rms {run['rms']:.3g}"
    print(f"run {run['evaluation']:>3} [{values}] {what} {rms}", flush=True)


result = cellmech.fit(fit_file, out_dir, progress=progress)
print(result)

# %% The fitted values, their standard errors and correlation (numpy arrays).
for key, value, error, unit in zip(result.keys, result.values, result.errors, result.units):
    print(f"{key:<32} {value:.5g} ± {error:.2g} {unit}  ({100 * error / value:.1f} %)")
print("correlation:\n", result.correlation)
print(f"RMS residual {result.rms:.3g}, R² {result.r_squared:.6f}, "
      f"{result.evaluations} evaluations ({result.runs} solved now), {result.wall_time_s:.0f} s")

# %% Measured vs fitted, with matplotlib when it is installed (fit.svg is written anyway).
try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print(f"(pip install matplotlib for the plot; {out_dir}/fit.svg has it)")
    sys.exit(0)
c = result.curve
fig, ax = plt.subplots(figsize=(5, 3.5))
ax.plot(c["x"], c["measured"], "o", ms=3, label="measured (synthetic)")
ax.plot(c["model_x"], c["model_y"], "-", label="fitted model")
ax.plot(c["start_x"], c["start_y"], "--", label="start")
ax.set_xlabel(f"{result.raw['simulated'][0]} ({result.raw['units'][0]})")
ax.set_ylabel(f"{result.raw['simulated'][1]} ({result.raw['units'][1]})")
ax.legend()
ax.grid(alpha=0.3)
fig.tight_layout()
path = os.path.join(out_dir, "fit-matplotlib.png")
fig.savefig(path, dpi=120)
print(f"plot: {path}")
