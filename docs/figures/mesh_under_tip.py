"""Cross-sections of the mesh under the AFM tip, from a run's VTU series.

Usage: python3 mesh_under_tip.py OUT.png RUN_DIR:INDEX[:LABEL] [RUN_DIR:INDEX[:LABEL] ...]

Each panel is the plane y = 0 through the apex site of the deformed hexahedra of output
INDEX (the INDEX-th file of RUN_DIR/fields.pvd), with the paraboloid tip drawn where
curve.csv puts it at that time. It assumes the apex site at x = y = 0 on the top of the
undeformed mesh and the protocol's defaults (tip radius 0.2 um, approach gap 1 um), as in
`examples/adherent-afm-apex.toml`. Needs pyvista and matplotlib (`pip install pyvista matplotlib`). Used for
docs/adherent-cell.md ("The mesh under the tip").
"""
import csv
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv


def output(run, index):
    """The INDEX-th VTU file of RUN/fields.pvd (path) and the curve.csv row at its time."""
    pvd = open(os.path.join(run, "fields.pvd")).read()
    entries = re.findall(r'timestep="([^"]*)"[^>]*file="([^"]*)"', pvd)
    time, name = entries[index]
    curve = list(csv.DictReader(open(os.path.join(run, "curve.csv"))))
    row = min(curve, key=lambda c: abs(float(c["time"]) - float(time)))
    return os.path.join(run, name), row


def panel(ax, run, index, label):
    path, row = output(run, index)
    radius = 0.2
    reference = pv.read(path)
    top = float(reference.bounds[5])
    mesh = reference.warp_by_vector("displacement_um")
    hexes = [i for i in range(mesh.n_cells) if mesh.get_cell(i).type == pv.CellType.HEXAHEDRON]
    site = [0.0, 0.0, top + 1.0]
    cut = mesh.extract_cells(hexes).slice(normal="y", origin=(site[0], site[1], 0.0))
    edges = cut.extract_all_edges()
    points = edges.points
    for a, b in edges.lines.reshape(-1, 3)[:, 1:]:
        ax.plot(points[[a, b], 0], points[[a, b], 2], "k-", lw=0.4)
    apex_z = site[2] + float(row["tip_displacement_z_um"])
    x = np.linspace(site[0] - 1.5, site[0] + 1.5, 200)
    ax.plot(x, apex_z + (x - site[0]) ** 2 / (2 * radius), "r-", lw=1.2)
    ax.set_xlim(site[0] - 1.5, site[0] + 1.5)
    ax.set_ylim(apex_z - 1.2, apex_z + 1.3)
    ax.set_aspect("equal")
    ax.set_xlabel("x (µm)")
    ax.set_ylabel("z (µm)")
    force = float(row["tip_force_along_motion_nN"])
    ax.set_title(f"{label}\nforce {force:.3f} nN", fontsize=9)


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    specs = [s.split(":") for s in sys.argv[2:]]
    fig, axes = plt.subplots(1, len(specs), figsize=(5 * len(specs), 5), squeeze=False)
    for ax, spec in zip(axes[0], specs):
        run, index = spec[0], int(spec[1])
        label = spec[2] if len(spec) > 2 else f"{os.path.basename(run)} #{index}"
        panel(ax, run, index, label)
    fig.tight_layout()
    fig.savefig(sys.argv[1], dpi=110)


if __name__ == "__main__":
    main()
