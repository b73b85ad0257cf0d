"""What every sigmaheart plot module shares: matplotlib set-up, the common style, reading strings
and datasets with their units from a results file (HDF5), trajectory readers, panel grids, titles
with provenance, and figure saving.

Imports nothing from the other sigmaplot modules, so any of them can import it (no cycles):
sigmaplot.py dispatches on the file's ``kind``; sigmaplot_simulate.py, sigmaplot_calibrate.py,
sigmaplot_regional.py and sigmaplot_studies.py draw.

Curves are stored in the unit their ``units`` attribute names (clinical units: mL, mmHg, s), so
labels come from the file, never from guesses.
"""
from __future__ import annotations

import math
import os
from typing import List

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

STYLE = {
    "figure.dpi": 110,
    "savefig.dpi": 150,
    "font.size": 10,
    "axes.titlesize": 12,
    "axes.labelsize": 10,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "legend.frameon": False,
}


def text(value) -> str:
    """An HDF5 string (attribute or dataset item) as str."""
    if isinstance(value, bytes):
        return value.decode("utf-8")
    if isinstance(value, np.ndarray) and value.shape == ():
        return text(value[()])
    return str(value)


def strings(ds) -> List[str]:
    """A 1-D dataset of HDF5 strings as a list of str."""
    return [text(v) for v in ds[()]]


def curve(group, name: str):
    """(values, unit) of dataset ``name`` in ``group``; None when absent."""
    if name not in group:
        return None
    ds = group[name]
    return np.asarray(ds[()], dtype=float), text(ds.attrs.get("units", ""))


def trajectory_curve(f, which, name):
    """(time [s], values, unit) of channel ``name`` in /trajectories/<which>; None when absent."""
    g = f.get(f"trajectories/{which}")
    if g is None:
        return None
    t = curve(g, "time")
    c = curve(g, name)
    if t is None or c is None:
        return None
    return t[0], c[0], c[1]


def title_of(f, what: str) -> str:
    name = text(f.attrs.get("name", "")) or os.path.basename(f.filename)
    return f"{what} \u2014 {name}"


def provenance_note(f) -> str:
    version = text(f.attrs.get("sigmaheart_version", "?"))
    git = text(f.attrs.get("git_describe", "?"))
    end = text(f.attrs.get("end_utc", ""))
    return f"sigmaheart {version} ({git}) {end}"


def grid(n: int, max_cols: int, width: float, height: float, sharex: bool = False):
    """A figure with n panels in rows of at most max_cols (each width x height inches); the unused
    panels of the last row are hidden. Returns (fig, axes) with axes 2-D (rows x cols)."""
    cols = min(n, max_cols)
    rows = int(math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows), squeeze=False,
                             sharex=sharex)
    for k in range(n, rows * cols):
        axes.flat[k].set_visible(False)
    return fig, axes


def save(fig, out_dir: str, stem: str, suffix: str) -> str:
    """Writes <out_dir>/<stem>-<suffix>.png, closes the figure and returns the path."""
    path = os.path.join(out_dir, f"{stem}-{suffix}.png")
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
    return path
