"""Figures of the study commands: results of kind "sensitivity" and "specificity".

sensitivity (app/commands/sensitivity.cpp), depending on /analysis@method:
  oat     tornado per output (bars: z(low) - z(nominal), z(high) - z(nominal)), elasticity heat map
  morris  mu*-sigma plane per output (with bootstrap intervals), heat map of mu* / max per output
  sobol   S1 / ST bars +- S1_conf / ST_conf (SALib's names) per output, heat map of S1 (main
          effect), S2 heat maps (second_order), convergence of S1 and ST with N
specificity (app/commands/specificity.cpp): one strip per parameter, every case's posterior mean
with +-1 posterior std, group means, the true value when the cohort lists it.
"""
from __future__ import annotations

import math
from typing import List

import numpy as np

import sigmaplot_common as sp
from sigmaplot_common import plt, strings


def _grid(n: int, width: float = 3.6, height: float = 3.0, max_cols: int = 4):
    """n panels, returned as a flat list."""
    fig, axes = sp.grid(n, max_cols, width, height)
    return fig, axes.ravel()[:n]


def _common(f):
    a = f["analysis"]
    params = strings(a["parameters/names"])
    outputs = strings(a["outputs/names"])
    units = strings(a["outputs/units"])
    return a, params, outputs, units


def _label(name: str, unit: str) -> str:
    return f"{name} [{unit}]" if unit and unit != "1" else name


def _heatmap(ax, M, params, outputs, title, cbar_label, cmap="viridis", vmin=0.0, vmax=1.0):
    im = ax.imshow(np.ma.masked_invalid(M), aspect="auto", cmap=cmap, vmin=vmin, vmax=vmax)
    ax.set_xticks(range(len(outputs)))
    ax.set_xticklabels(outputs, rotation=60, ha="right")
    ax.set_yticks(range(len(params)))
    ax.set_yticklabels(params)
    ax.grid(False)
    for i in range(M.shape[0]):
        for j in range(M.shape[1]):
            v = M[i, j]
            if np.isfinite(v) and abs(v) >= 0.05 * (vmax - vmin):
                ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=6,
                        color="white" if v < 0.6 * vmax else "black")
    ax.set_xlabel("output")
    ax.set_ylabel("parameter")
    ax.set_title(title)
    plt.colorbar(im, ax=ax, label=cbar_label, fraction=0.04, pad=0.02)


def _heatmap_figure(f, M, params, outputs, title, cbar_label, out_dir, stem, **kw) -> str:
    """One heat map (parameter x output) in a figure sized to the table, saved as <stem>-heatmap."""
    fig, ax = plt.subplots(figsize=(1.0 + 0.55 * len(outputs), 1.5 + 0.35 * len(params)))
    _heatmap(ax, M, params, outputs, sp.title_of(f, title), cbar_label, **kw)
    fig.tight_layout()
    return sp.save(fig, out_dir, stem, "heatmap")


def _plot_oat(f, out_dir, stem) -> List[str]:
    a, params, outputs, units = _common(f)
    g = a["oat"]
    dl, dh = np.asarray(g["delta_low"][()]), np.asarray(g["delta_high"][()])
    z0 = np.asarray(g["z_nominal"][()])
    el = np.asarray(g["normalised"][()])
    mode = sp.text(g.attrs.get("mode", ""))
    if mode == "relative":
        mode = f"nominal -+{100 * float(g.attrs.get('relative_change', 0)):.0f} %"
    elif mode == "range":
        mode = "low / high = the study's range of each parameter"
    paths = []
    with plt.rc_context(sp.STYLE):
        fig, axes = _grid(len(outputs), 3.8, 3.2)
        for k, ax in enumerate(axes):
            swing = np.abs(dh[:, k] - dl[:, k])
            swing = np.where(np.isfinite(swing), swing, -1)
            order = np.argsort(-swing)[: min(8, len(params))][::-1]
            y = np.arange(len(order))
            ax.barh(y, dl[order, k], color="#3182bd", label="low")
            ax.barh(y, dh[order, k], color="#e6550d", label="high")
            ax.axvline(0, color="0.2", lw=0.8)
            ax.set_yticks(y)
            ax.set_yticklabels([params[i] for i in order], fontsize=8)
            ax.set_xlabel(f"change of {_label(outputs[k], units[k])}")
            ax.set_title(f"{outputs[k]} (nominal {z0[k]:.4g} {units[k]})", fontsize=10)
            if k == 0:
                ax.legend(loc="lower right", fontsize=7, title="parameter at", title_fontsize=7)
        fig.suptitle(sp.title_of(f, f"One-at-a-time tornado per output ({mode})"))
        fig.tight_layout(rect=(0, 0, 1, 0.97))
        paths.append(sp.save(fig, out_dir, stem, "tornado"))

        paths.append(_heatmap_figure(
            f, np.abs(el), params, outputs, "Elasticity |d ln output / d ln parameter|",
            "|elasticity| [1]", out_dir, stem,
            vmax=max(1.0, float(np.nanmax(np.abs(el))) if np.isfinite(el).any() else 1.0)))
    return paths


def _plot_morris(f, out_dir, stem) -> List[str]:
    a, params, outputs, units = _common(f)
    g = a["morris"]
    mus, sig = np.asarray(g["mu_star"][()]), np.asarray(g["sigma"][()])
    lo, hi = np.asarray(g["mu_star_low"][()]), np.asarray(g["mu_star_high"][()])
    r = int(g.attrs.get("used_trajectories", g.attrs.get("trajectories", 0)))
    paths = []
    colors = plt.cm.tab20(np.linspace(0, 1, max(len(params), 2)))
    with plt.rc_context(sp.STYLE):
        fig, axes = _grid(len(outputs), 3.8, 3.4)
        for k, ax in enumerate(axes):
            for i, name in enumerate(params):
                xerr = None
                if np.isfinite(lo[i, k]) and np.isfinite(hi[i, k]):
                    xerr = [[max(0.0, mus[i, k] - lo[i, k])], [max(0.0, hi[i, k] - mus[i, k])]]
                ax.errorbar(mus[i, k], sig[i, k], xerr=xerr, fmt="o", ms=4, color=colors[i],
                            elinewidth=0.8, label=name)
            top = np.argsort(-np.nan_to_num(mus[:, k]))[:4]
            for i in top:
                ax.annotate(params[i], (mus[i, k], sig[i, k]), fontsize=7, xytext=(3, 3),
                            textcoords="offset points")
            m = np.nanmax(np.concatenate([mus[:, k], sig[:, k]])) if np.isfinite(mus[:, k]).any() else 1
            ax.plot([0, m], [0, m], ls=":", color="0.5", lw=0.8)
            ax.set_xlabel(f"mu* [{units[k]}]")
            ax.set_ylabel(f"sigma [{units[k]}]")
            ax.set_title(outputs[k], fontsize=10)
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="lower center", ncol=min(9, len(params)), fontsize=7,
                   bbox_to_anchor=(0.5, 0.0))
        fig.suptitle(sp.title_of(f, f"Morris mu*-sigma per output (r = {r}; change over the whole "
                                    "range; dotted: sigma = mu*)"))
        fig.tight_layout(rect=(0, 0.05, 1, 0.97))
        paths.append(sp.save(fig, out_dir, stem, "morris"))

        norm = mus / np.nanmax(mus, axis=0, keepdims=True)
        paths.append(_heatmap_figure(f, norm, params, outputs,
                                     "Morris mu* relative to the largest per output",
                                     "mu* / max mu* [1]", out_dir, stem))
    return paths


def _plot_sobol(f, out_dir, stem) -> List[str]:
    a, params, outputs, units = _common(f)
    g = a["sobol"]
    paths = []
    if "S1" not in g:
        return paths  # invalid study: nothing to draw (the failed runs are in /analysis/failed)
    # SALib's names: S1_conf / ST_conf are half-widths of the bootstrap interval.
    S1, ST = np.asarray(g["S1"][()]), np.asarray(g["ST"][()])
    S1c, STc = np.asarray(g["S1_conf"][()]), np.asarray(g["ST_conf"][()])
    N = int(g.attrs.get("N", 0))
    second = int(g.attrs.get("second_order", 0)) == 1
    level = 100.0 * float(g.attrs.get("confidence", 0.95))
    exact = None
    if "exact" in a:
        exact = (np.asarray(a["exact/S1"][()]), np.asarray(a["exact/ST"][()]))
    with plt.rc_context(sp.STYLE):
        fig, axes = _grid(len(outputs), 4.2 if len(params) > 6 else 3.6, 3.2)
        x = np.arange(len(params))
        w = 0.4
        for k, ax in enumerate(axes):
            ax.bar(x - w / 2, S1[:, k], w, yerr=np.nan_to_num(S1c[:, k]),
                   color="#3182bd", capsize=2, error_kw={"lw": 0.8}, label="S1 (first order)")
            ax.bar(x + w / 2, ST[:, k], w, yerr=np.nan_to_num(STc[:, k]),
                   color="#e6550d", capsize=2, error_kw={"lw": 0.8}, label="ST (total)")
            if exact is not None and len(outputs) == 1:
                ax.scatter(x - w / 2, exact[0], marker="_", s=200, color="k", zorder=5, label="exact S1")
                ax.scatter(x + w / 2, exact[1], marker="_", s=200, color="0.4", zorder=5, label="exact ST")
            ax.set_xticks(x)
            ax.set_xticklabels(params, rotation=70 if len(params) > 6 else 0, fontsize=7)
            low = S1[:, k] - S1c[:, k]
            ax.set_ylim(min(0.0, float(np.nanmin(low)) if np.isfinite(low).any() else 0.0) - 0.02, 1.05)
            ax.set_ylabel("Sobol' index [1]")
            ax.set_title(_label(outputs[k], units[k]), fontsize=10)
            if k == 0:
                ax.legend(fontsize=7, loc="upper right")
        runs = N * (2 * len(params) + 2 if second else len(params) + 2)
        fig.suptitle(sp.title_of(f, f"Sobol' indices +- S1_conf / ST_conf ({level:g} % bootstrap, "
                                    f"N = {N}, {runs} runs)"))
        fig.tight_layout(rect=(0, 0, 1, 0.97))
        paths.append(sp.save(fig, out_dir, stem, "sobol-bars"))

        paths.append(_heatmap_figure(f, np.clip(S1, 0, 1), params, outputs,
                                     "Main effect: first-order Sobol' index S1", "S1 [1]",
                                     out_dir, stem))

        if second and "S2" in g:
            # One p x p heat map per output: S2(i, k) above the diagonal.
            fig, axes = _grid(len(outputs), 3.8, 3.4)
            for k, ax in enumerate(axes):
                S2 = np.asarray(g[f"S2/{outputs[k]}"][()])
                im = ax.imshow(np.ma.masked_invalid(S2), cmap="viridis", vmin=0.0,
                               vmax=max(0.05, float(np.nanmax(S2)) if np.isfinite(S2).any() else 0.05))
                ax.set_xticks(range(len(params)))
                ax.set_xticklabels(params, rotation=70, fontsize=6)
                ax.set_yticks(range(len(params)))
                ax.set_yticklabels(params, fontsize=6)
                ax.set_title(outputs[k], fontsize=10)
                fig.colorbar(im, ax=ax, label="S2 [1]")
            fig.suptitle(sp.title_of(f, "Second-order Sobol' indices S2 (Saltelli 2002)"))
            fig.tight_layout(rect=(0, 0, 1, 0.96))
            paths.append(sp.save(fig, out_dir, stem, "sobol-second-order"))

        if "convergence" in g and "n" in g["convergence"]:
            # Groups are named n<size> zero-padded to the width of N ("n0128"): map size -> name.
            groups = {int(name[1:]): name for name in g["convergence"]
                      if name.startswith("n") and name[1:].isdigit()}
            ns = sorted(int(n) for n in g["convergence/n"][()] if int(n) in groups)
            fig, axes = _grid(len(outputs), 3.6, 3.0)
            colors = plt.cm.tab10(np.linspace(0, 1, 10))
            for k, ax in enumerate(axes):
                top = np.argsort(-np.nan_to_num(ST[:, k]))[: min(4, len(params))]
                for c, i in enumerate(top):
                    st = np.array([g[f"convergence/{groups[n]}/ST"][()][i, k] for n in ns])
                    s1 = [g[f"convergence/{groups[n]}/S1"][()][i, k] for n in ns]
                    conf = np.array([g[f"convergence/{groups[n]}/ST_conf"][()][i, k] for n in ns])
                    lo, hi = st - conf, st + conf
                    ax.plot(ns, st, "-o", ms=3, color=colors[c], label=f"{params[i]} ST")
                    ax.fill_between(ns, lo, hi, color=colors[c], alpha=0.15, lw=0)
                    ax.plot(ns, s1, "--", color=colors[c], lw=1, label=f"{params[i]} S1")
                ax.set_xscale("log", base=2)
                ax.set_xlabel("N (base samples)")
                ax.set_ylabel("index [1]")
                ax.set_title(outputs[k], fontsize=10)
                ax.legend(fontsize=6, ncol=2)
            fig.suptitle(sp.title_of(f, f"Convergence of the Sobol' indices with N (solid ST +- ST_conf "
                                        f"at {level:g} %, dashed S1; top 4 by ST)"))
            fig.tight_layout(rect=(0, 0, 1, 0.96))
            paths.append(sp.save(fig, out_dir, stem, "sobol-convergence"))
    return paths


def plot_sensitivity(f, out_dir: str, stem: str) -> List[str]:
    """Tornado (OAT), mu*-sigma (Morris) or S1/ST bars and convergence (Sobol'), and a heat map."""
    method = sp.text(f["analysis"].attrs.get("method", ""))
    if method == "oat":
        return _plot_oat(f, out_dir, stem)
    if method == "morris":
        return _plot_morris(f, out_dir, stem)
    if method == "sobol":
        return _plot_sobol(f, out_dir, stem)
    raise ValueError(f"unknown sensitivity method '{method}'")


def plot_specificity(f, out_dir: str, stem: str) -> List[str]:
    """Per parameter: every case's posterior mean +- std by group, group means, truth if known."""
    params = strings(f["parameters/names"])
    units = strings(f["parameters/units"])
    names = strings(f["cases/names"])
    groups = strings(f["cases/groups"])
    mean = np.asarray(f["cases/mean"][()])
    std = np.asarray(f["cases/std"][()])
    truth = np.asarray(f["cases/truth"][()]) if "cases/truth" in f else None
    st = f["statistics"]
    valid = int(st.attrs.get("valid", 0)) == 1
    order = [sp.text(st.attrs["group_a"]), sp.text(st.attrs["group_b"])] if valid else sorted(set(groups))
    ranking = strings(st["ranking"]) if valid and "ranking" in st else params
    idx = {p: j for j, p in enumerate(params)}
    colors = {order[0]: "#3182bd", order[1] if len(order) > 1 else "": "#e6550d"}
    paths = []
    with plt.rc_context(sp.STYLE):
        fig, axes = _grid(len(params), 3.2, 3.4, max_cols=3)
        for ax, name in zip(axes, ranking):
            j = idx[name]
            scale, unit = 1.0, units[j]
            finite = mean[:, j][np.isfinite(mean[:, j])]
            if unit == "Pa" and finite.size and np.nanmax(np.abs(finite)) >= 1e3:
                scale, unit = 1e-3, "kPa"
            elif unit == "m" and finite.size and np.nanmax(np.abs(finite)) < 0.5:
                scale, unit = 100.0, "cm"
            elif finite.size and np.nanmax(np.abs(finite)) >= 1e5:
                e = int(math.floor(math.log10(np.nanmax(np.abs(finite)))))
                scale, unit = 10.0 ** -e, f"1e{e} {unit}"
            for gi, gname in enumerate(order):
                rows = [i for i, g in enumerate(groups) if g == gname]
                xs = gi + np.linspace(-0.18, 0.18, len(rows)) if len(rows) > 1 else np.array([gi])
                c = colors.get(gname, "0.4")
                ax.errorbar(xs, mean[rows, j] * scale, yerr=std[rows, j] * scale, fmt="o", ms=4,
                            color=c, elinewidth=1, capsize=2,
                            label="posterior mean +- std" if gi == 0 else None)
                if truth is not None:
                    ax.scatter(xs, truth[rows, j] * scale, marker="x", color="k", s=18, zorder=5,
                               label="truth" if gi == 0 else None)
                m = np.nanmean(mean[rows, j]) * scale
                ax.hlines(m, gi - 0.3, gi + 0.3, color=c, lw=2, alpha=0.6,
                          label="group mean" if gi == 0 else None)
            ax.set_xticks(range(len(order)))
            ax.set_xticklabels([f"{g}\n(n={groups.count(g)})" for g in order])
            ax.set_xlim(-0.6, len(order) - 0.4)
            ax.set_ylabel(f"{name} [{unit}]")
            title = name
            if valid:
                auc = st["auc"][()][j]
                p = st["mann_whitney_p"][()][j]
                pw = st["welch_p"][()][j]
                title = f"{name}: AUC {auc:.2f}, U p {p:.2g}, Welch p {pw:.2g}"
            ax.set_title(title, fontsize=9)
        axes[0].legend(fontsize=7, loc="best")
        note = ""
        if "classifier" in f and int(f["classifier"].attrs.get("valid", 0)) == 1:
            c = f["classifier"].attrs
            note = f"; leave-one-out LDA accuracy {100 * float(c['accuracy']):.0f} % " \
                   f"({int(c['correct'])}/{int(c['total'])})"
        fig.suptitle(sp.title_of(f, "Calibrated parameters by group, most separating first" + note))
        fig.tight_layout(rect=(0, 0, 1, 0.95))
        paths.append(sp.save(fig, out_dir, stem, "strips"))
    return paths
