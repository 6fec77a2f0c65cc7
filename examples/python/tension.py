"""The coarse suspended cell in micropipette tension, from Python.

Runs the published suspended bendo-tensegrity cell on the coarse 448-element mesh (a few
seconds), stretched 6.3 um between two micropipettes, prints the force curve and plots
force vs elongation with matplotlib when it is installed.

    pip install maturin && maturin develop --release -m crates/cellmech-py/Cargo.toml
    python examples/python/tension.py [OUT_DIR]
"""

import sys

import cellmech


def main(out_dir: str = "cellmech-out/python-tension") -> None:
    cell = cellmech.SuspendedCell(
        core_divisions=4,  # the coarse mesh: 448 hex8 instead of 6912
        shell_layers=2,
        outer_layers=2,
        cytoplasm__shear_modulus="0.17 kPa",  # the spec value, written out as an example
    )
    analysis = cellmech.experiment(
        cell,
        cellmech.MicropipetteTension(elongation="6.3 um"),
        title="coarse suspended cell: micropipette tension",
        output={"vtk_every": 0},  # no ParaView frames
    )
    print(analysis)

    def progress(info):
        print(
            f"  step {info['step_name']:<10} increment {info['increment']:>3}"
            f"  t = {info['step_time']:.3f}  ({info['iterations']} iterations)",
            flush=True,
        )

    result = analysis.run(out_dir, progress=progress)
    print(result)
    if not result.ok:
        sys.exit(f"the analysis stopped: {result.error}")
    print(f"{'elongation (um)':>16} {'force (nN)':>12}")
    for d, f in zip(result.displacement, result.force):
        print(f"{d:16.3f} {f:12.3f}")
    print(f"outputs in {result.out_dir}: {', '.join(result.files)}")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("(pip install matplotlib for the plot)")
        return
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot(result.displacement, result.force, "o-")
    ax.set_xlabel("elongation (µm)")
    ax.set_ylabel("force (nN)")
    ax.set_title("coarse suspended cell, micropipette tension")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path = f"{out_dir}/force-elongation-matplotlib.png"
    fig.savefig(path, dpi=120)
    print(f"plot: {path}")


if __name__ == "__main__":
    main(*sys.argv[1:2])
