"""Von Mises stress on a vertical section through the AFM site, with the filaments near it.

Usage: python3 stress_under_tip.py OUT.png RUN_DIR:WHICH[:LABEL] [RUN_DIR:WHICH[:LABEL] ...]

WHICH is an output index (the INDEX-th file of RUN_DIR/fields.pvd; -1 for the last) or
@DEPTH, the output nearest that indentation depth in um (tip travel past first contact).
Each panel cuts the deformed hexahedra with the vertical plane through the tip's axis
(the site recorded in RUN_DIR/summary.json, `cell.geometry.site`, moved across by the
tip's x/y displacement when the tip was aimed at where the prestress took the site),
colours the cut by the element's von Mises stress (kPa, one colour scale for every panel),
draws the filament segments within 0.75 um of the plane in black (width by their axial
force), and the paraboloid tip where curve.csv puts it (tip radius from summary.json,
approach gap 1 um, the protocol's default).
Needs pyvista and matplotlib (`pip install pyvista matplotlib`). Used for
docs/adherent-cell.md ("Apex and receptor side by side").
"""
import csv
import json
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import LogNorm

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mesh_under_tip import output  # noqa: E402  (the same run reader)

HALF_WIDTH = 3.0  # um either side of the site
SLAB = 0.75  # um: filament segments this close to the plane are drawn


def nearest_depth(run, depth):
    """Index in fields.pvd of the output nearest indentation DEPTH (um)."""
    summary = json.load(open(os.path.join(run, "summary.json")))
    contact_step = summary["cell"]["protocol"]["contact_step"]
    curve = list(csv.DictReader(open(os.path.join(run, "curve.csv"))))
    at_contact = [r for r in curve if int(float(r["step"])) == contact_step][-1]
    z0 = float(at_contact["tip_displacement_z_um"])
    times = [float(t) for t in re.findall(r'timestep="([^"]*)"', open(os.path.join(run, "fields.pvd")).read())]
    def depth_at(time):
        row = min(curve, key=lambda c: abs(float(c["time"]) - time))
        return z0 - float(row["tip_displacement_z_um"])
    return min(range(len(times)), key=lambda i: abs(depth_at(times[i]) - depth))


def load(run, which):
    index = nearest_depth(run, float(which[1:])) if which.startswith("@") else int(which)
    path, row = output(run, index)
    summary = json.load(open(os.path.join(run, "summary.json")))
    site, _normal = summary["cell"]["geometry"]["site"]
    site = [site[0] + float(row["tip_displacement_x_um"]), site[1] + float(row["tip_displacement_y_um"]), site[2]]
    radius = summary.get("input", {}).get("protocol", {}).get("tip_radius_um", 0.2)
    mesh = pv.read(path).warp_by_vector("displacement_um")
    return mesh, site, radius, row


def panel(ax, run, which, label, norm):
    mesh, site, radius, row = load(run, which)
    hexes = [i for i in range(mesh.n_cells) if mesh.get_cell(i).type == pv.CellType.HEXAHEDRON]
    cut = mesh.extract_cells(hexes).slice(normal="y", origin=(site[0], site[1], site[2]))
    polys, values = [], []
    stress = cut.cell_data["von_mises_kPa"]
    for i in range(cut.n_cells):
        pts = cut.get_cell(i).points
        polys.append(pts[:, [0, 2]])
        values.append(stress[i])
    coll = PolyCollection(polys, array=np.maximum(np.array(values), norm.vmin), cmap="viridis", norm=norm)
    coll.set_edgecolor("face")
    ax.add_collection(coll)
    has_filaments = "axial_force_nN" in mesh.cell_data
    lines = [i for i in range(mesh.n_cells) if has_filaments and mesh.get_cell(i).type == pv.CellType.LINE]
    segments, widths = [], []
    force = mesh.cell_data["axial_force_nN"] if has_filaments else []
    for i in lines:
        p = mesh.get_cell(i).points
        if np.all(np.abs(p[:, 1] - site[1]) < SLAB):
            segments.append(p[:, [0, 2]])
            widths.append(0.5 + 2.0 * min(abs(force[i]), 4.0) / 4.0)
    ax.add_collection(LineCollection(segments, colors="k", linewidths=widths))
    apex_z = site[2] + 1.0 + float(row["tip_displacement_z_um"])
    x = np.linspace(site[0] - HALF_WIDTH, site[0] + HALF_WIDTH, 300)
    ax.plot(x, apex_z + (x - site[0]) ** 2 / (2 * radius), "r-", lw=1.2)
    ax.set_xlim(site[0] - HALF_WIDTH, site[0] + HALF_WIDTH)
    ax.set_ylim(site[2] - 5.0, site[2] + 1.0)
    ax.set_aspect("equal")
    ax.set_xlabel("x (µm)")
    ax.set_ylabel("z (µm)")
    force = float(row["tip_force_along_motion_nN"])
    ax.set_title(f"{label}\ntip force {force:.3f} nN", fontsize=9)
    return coll


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    specs = [s.split(":", 2) for s in sys.argv[2:]]
    norm = LogNorm(vmin=1e-3, vmax=1.0)
    fig, axes = plt.subplots(1, len(specs), figsize=(5.5 * len(specs), 5), squeeze=False)
    coll = None
    for ax, spec in zip(axes[0], specs):
        run, which = spec[0], spec[1]
        label = spec[2] if len(spec) > 2 else run
        coll = panel(ax, run, which, label, norm)
    fig.colorbar(coll, ax=axes[0].tolist(), label="von Mises stress (kPa)", shrink=0.8)
    fig.savefig(sys.argv[1], dpi=130, bbox_inches="tight")


if __name__ == "__main__":
    main()
