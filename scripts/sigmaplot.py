"""Figures of sigmaheart results files (HDF5), one plot function per result kind.

Every results file carries a root attribute ``kind`` ("simulate", "calibrate", ...); ``PLOTTERS``
maps each kind to a function ``plot(f, out_dir, stem) -> list of PNG paths`` defined in its own
module. A new command adds its module and one entry here. The helpers every module shares (file
reading with units, trajectory readers, styling, saving) are in sigmaplot_common.py, which
imports none of the others, so there are no import cycles.

Needs Debian's python3 (matplotlib, numpy, h5py): run through scripts/plot.
"""
from __future__ import annotations

import os
from typing import Callable, Dict, List

import sigmaplot_calibrate
import sigmaplot_observe
import sigmaplot_regional
import sigmaplot_simulate
import sigmaplot_studies
import sigmaplot_therapy
from sigmaplot_common import text

PLOTTERS: Dict[str, Callable] = {
    "simulate": sigmaplot_simulate.plot_simulate,
    "calibrate": sigmaplot_calibrate.plot_calibrate,
    "personalize": sigmaplot_regional.plot_personalize,
    "sensitivity": sigmaplot_studies.plot_sensitivity,
    "specificity": sigmaplot_studies.plot_specificity,
    "therapy": sigmaplot_therapy.plot_therapy,
    "observe": sigmaplot_observe.plot_observe,
}


def plot_file(path: str, out_dir: str | None = None) -> List[str]:
    """Draws the figures of one results file; returns the PNG paths written."""
    import h5py

    out_dir = out_dir or os.path.dirname(os.path.abspath(path))
    os.makedirs(out_dir, exist_ok=True)
    stem = os.path.splitext(os.path.basename(path))[0]
    with h5py.File(path, "r") as f:
        kind = text(f.attrs.get("kind", ""))
        if kind not in PLOTTERS:
            known = ", ".join(sorted(PLOTTERS))
            raise ValueError(f"{path}: no plots for results of kind '{kind}' (known: {known})")
        return PLOTTERS[kind](f, out_dir, stem)
