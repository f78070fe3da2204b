"""Toolpath preview: side and top views of the extruding moves, coloured by porosity."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from porosense.files import save_figure
from porosense.infoam.gcode import PrintJob


def plot_toolpath(job: PrintJob, path=None):
    """Draw the toolpath of ``job`` (mm) coloured by target porosity (%); save it if ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import cm, colors
    from matplotlib.collections import LineCollection

    seg = job.segments
    norm = colors.Normalize(vmin=0.0, vmax=100.0)
    cmap = plt.get_cmap("viridis")
    x_extent = float(np.ptp(seg[:, [0, 3]])) if len(seg) else 1.0
    z_extent = float(np.ptp(seg[:, 7])) + 1.0 if len(seg) else 1.0
    if x_extent > 2.5 * z_extent:  # long flat parts read better stacked
        fig, (side, top) = plt.subplots(2, 1, figsize=(10, 6), layout="constrained")
    else:
        fig, (side, top) = plt.subplots(1, 2, figsize=(11, 4.8), layout="constrained")
    # Side view: where the material lands (mid-layer), as thick as the layer; top view: nozzle paths.
    side_lines = [[(s[0], s[7]), (s[3], s[7])] for s in seg]
    side.add_collection(LineCollection(side_lines, colors=cmap(norm(seg[:, 6])), linewidths=seg[:, 8] * 2.5))
    top_lines = [[(s[0], s[1]), (s[3], s[4])] for s in seg]
    top.add_collection(LineCollection(top_lines, colors=cmap(norm(seg[:, 6])), linewidths=0.5))
    for ax, j, title in ((side, 2, "side (x-z), deposited layers"), (top, 1, "top (x-y), nozzle paths")):
        ax.autoscale()
        ax.set_aspect("equal")
        ax.set_title(title)
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("z (mm)" if j == 2 else "y (mm)")
    fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), ax=(side, top), label="target porosity (%)", shrink=0.8)
    fig.suptitle(f"{job.design.name}: nozzle paths of extruding moves")
    if path is not None:
        save_figure(fig, Path(path), dpi=130)
        plt.close(fig)
    return fig
