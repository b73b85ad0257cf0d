"""Figures of `sigmaheart observe` results (kind "observe"; app/commands/observe.cpp): the
observation curves it extracted from tracked meshes or label images.

- <stem>-volume.png: V_lv over the frames (times after the ECG trigger) with end-diastole and
  end-systole marked, P_lv on a second axis when merged, the checks' findings below;
- <stem>-regional-volumes.png: the 17 regional volume curves per AHA level and the bull's-eye of
  the regional ejection fraction (V_s(ED) - V_s(ES)) / V_s(ED), drawn by the simulate figure's
  function (sigmaplot_simulate.regional_volumes).
"""
from __future__ import annotations

from typing import List

import numpy as np

import sigmaplot_common as sp
import sigmaplot_simulate
from sigmaplot_common import STYLE, curve, plt, strings, text


def _volume(f, g, t, t_unit):
    c = f["checks"]
    ed, es = int(c.attrs["end_diastole"]), int(c.attrs["end_systole"])
    fig, ax = plt.subplots(figsize=(7, 4))
    v, unit = curve(g, "V_lv")
    ax.plot(t, v, "o-", color="black", ms=3, label="V_lv")
    ax.axvline(t[ed], color="tab:blue", ls="--", lw=0.8, label=f"ED (frame {ed})")
    ax.axvline(t[es], color="tab:red", ls="--", lw=0.8, label=f"ES (frame {es})")
    ax.set_xlabel(f"time after the ECG trigger [{t_unit}]")
    ax.set_ylabel(f"V_lv [{unit}]")
    if "P_lv" in g:
        p, punit = curve(g, "P_lv")
        ax2 = ax.twinx()
        ax2.plot(t, p, color="tab:purple", lw=1)
        ax2.set_ylabel(f"P_lv [{punit}]", color="tab:purple")
        ax2.grid(False)
    ax.legend(loc="lower left", fontsize=7)
    ax.set_title(sp.title_of(f, f"observed V_lv: EDV {float(c.attrs['edv']):.1f} mL, ESV {float(c.attrs['esv']):.1f} mL, "
                                f"EF {100 * float(c.attrs['ef']):.1f} %"), fontsize=9)
    findings = strings(c["findings"]) if "findings" in c else []
    note = f"checks: {text(c.attrs.get('status', ''))}" + ("" if not findings else "; " + "; ".join(findings[:3]))
    fig.text(0.01, 0.0, note, fontsize=6, color="tab:red" if findings else "0.5")
    fig.tight_layout()
    return fig


def plot_observe(f, out_dir: str, stem: str) -> List[str]:
    g = f["observed"]
    time, t_unit = curve(g, "time")
    segments = sorted(int(k[5:]) for k in g.keys() if k.startswith("V_seg") and k[5:].isdigit())
    ef = 100.0 * np.asarray(f["checks/regional_ef"][()], dtype=float)
    with plt.rc_context(STYLE):
        written = [sp.save(_volume(f, g, time, t_unit), out_dir, stem, "volume")]
        fig = sigmaplot_simulate.regional_volumes(
            f, g, time, t_unit, None, segments, regional_ef=ef,
            ef_label="(V_seg(ED) - V_seg(ES)) / V_seg(ED) [%]", title="Regional cavity volumes observed")
        written.append(sp.save(fig, out_dir, stem, "regional-volumes"))
    return written
