"""The model against the experiment: the floor's laws at N = 512 and 1024 (the numbers of
docs/experiment.md).

    python studies/experiment_study.py docs/data/experiment.parquet [--plot FILE] [--step-check TABLE]

The table holds falls of the same starts on several floors, by one method: the anchor
(``--friction inf``, ``--restitution-floor 0``: the model's law), a frictionless floor
(``--friction 0``), Coulomb's friction at a finite coefficient (``--friction MU``) and a
rough floor that gives back part of each landing (``--restitution-floor E``).  Per (N, floor), over the runs that landed (a run that ended
otherwise is listed and not counted): the mean t_fall/t_ff, the braking coefficient gamma
measured from the floor's momentum record and inferred from t_fall/t_ff by the
Hamm-Geminard formula, and the pile's radius of gyration seen from above
(``records.measures.pile_shape``), each with its 95% bootstrap interval
(``sweeps.stats.mean_interval``).  Then, paired by start, each floor minus the anchor
(t_fall/t_ff, gamma measured, the pile's radius); and, fall by fall, gamma measured minus
gamma inferred: zero where the Hamm-Geminard picture (the floor takes gamma times the
momentum the landing chain brings, and that sets the fall time) describes the chain.
Last, the experiment (Hamm and Geminard: gamma 0.83, which their formula maps to
t_fall/t_ff = ``theory.hamm_geminard_time_ratio(0.83)``): which floors' intervals hold
either number, and which hold both.  ``--plot``: gamma measured against t_fall/t_ff, the
means with their intervals, on the Hamm-Geminard curve, with the experiment's point.
``--step-check TABLE``: falls of the same starts at another ``--dt`` minus the table's,
paired by start; and, where TABLE has the anchor too, each of its floors minus the anchor
at that step.
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import pandas as pd

from ballchain.sweeps.stats import mean_interval
from ballchain.theory import hamm_geminard_time_ratio

GAMMA_EXPERIMENT = 0.83  # Hamm and Geminard's measured braking coefficient


def _floor(r) -> str:
    """The floor's law of a row, named."""
    if r.friction == 0.0:
        return "frictionless"
    if math.isfinite(r.friction):
        return f"mu = {r.friction:g}"
    if r.restitution_floor > 0.0:
        return f"E = {r.restitution_floor:g}"
    return "anchor"


def _order(law: str) -> tuple:
    """The floors in the tables' order: the anchor, then by grip (frictionless, mu = ...),
    then the restitution floors by E."""
    if law == "anchor":
        return (0, 0.0)
    if law == "frictionless":
        return (1, 0.0)
    kind, value = law.split(" = ")
    return (1 if kind == "mu" else 2, float(value))


def _interval(x, digits: int = 3) -> tuple[str, float, float, float]:
    """'mean [lo, hi]' of the finite values (their number when some are not), and the three numbers."""
    x = np.asarray(x, dtype=float)
    ok = x[np.isfinite(x)]
    if ok.size == 0:
        return "n/a", math.nan, math.nan, math.nan
    lo, hi = mean_interval(ok)
    f = f"{{:+.{digits}f}}" if np.any(ok < 0) else f"{{:.{digits}f}}"
    text = f"{f.format(ok.mean())} [{f.format(lo)}, {f.format(hi)}]"
    return text + (f" ({ok.size} of {x.size})" if ok.size < x.size else ""), float(ok.mean()), lo, hi


def _paired(g, base, col) -> str:
    d = (g.set_index("run_index")[col] - base.set_index("run_index")[col]).dropna().to_numpy(dtype=float)
    d = d[np.isfinite(d)]
    if d.size < 2:
        return "n/a"
    lo, hi = mean_interval(d)
    return f"{d.mean():+.3f} [{lo:+.3f}, {hi:+.3f}]"


def _load(path) -> pd.DataFrame:
    """A table with its floors named (``floor_law``)."""
    df = pd.read_parquet(path)
    df["friction"] = df["friction"].fillna(math.inf)
    df["restitution_floor"] = df["restitution_floor"].fillna(0.0)
    df["floor_law"] = [_floor(r) for r in df.itertuples()]
    return df


def _step_check(df, path) -> None:
    """The falls of ``path`` (the same starts and floors at another step) minus those of df,
    paired by start: mean [95%] and median, for t_fall/t_ff and gamma measured."""
    other = _load(path)
    print(f"\nThe step: {path} minus the table, paired by start (mean [95%]; median):\n")
    print("| N | floor | --dt (table, other) | pairs | t_fall/t_ff [95%] | median | gamma measured [95%] | median |")
    print("|---|---|---|---|---|---|---|---|")
    for (n, law), g in other.groupby(["segments", "floor_law"]):
        base = df[(df.segments == n) & (df.floor_law == law) & (df.status == "landed")]
        g = g[g.status == "landed"]
        cells = []
        for col in ("ratio", "gamma_measured"):
            d = (g.set_index("run_index")[col] - base.set_index("run_index")[col]).dropna().to_numpy(dtype=float)
            cells += [_paired(g, base, col), f"{np.median(d):+.4f}"]
        dts = f"{base.dt.iloc[0]:g}, {g.dt.iloc[0]:g}"
        pairs = len(set(g.run_index) & set(base.run_index))
        print(f"| {n} | {law} | {dts} | {pairs} | " + " | ".join(cells) + " |")
    ok = other[other.status == "landed"]
    if "anchor" not in set(ok.floor_law):
        return
    print(f"\nAt the step of {path}: each floor minus the anchor, paired by start (mean [95%]):\n")
    print("| N | floor | --dt | pairs | t_fall/t_ff [95%] | gamma measured [95%] |")
    print("|---|---|---|---|---|---|")
    for n, gn in ok.groupby("segments"):
        anchor = gn[gn.floor_law == "anchor"]
        for law in sorted(set(gn.floor_law) - {"anchor"}, key=_order):
            g = gn[gn.floor_law == law]
            pairs = len(set(g.run_index) & set(anchor.run_index))
            cells = " | ".join(_paired(g, anchor, c) for c in ("ratio", "gamma_measured"))
            print(f"| {n} | {law} | {g.dt.iloc[0]:g} | {pairs} | {cells} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table")
    ap.add_argument("--plot")
    ap.add_argument("--step-check", help="a table of some of the same falls at another --dt: paired differences")
    a = ap.parse_args()
    df = _load(a.table)
    df["imb"] = (df.energy_imbalance / df.energy_initial).abs()
    ratio_exp = hamm_geminard_time_ratio(GAMMA_EXPERIMENT)
    print(f"{len(df)} runs ({', '.join(sorted(df.method.unique()))}): "
          + ", ".join(f"{v} {k}" for k, v in df.status.value_counts().items()))  # fmt: skip
    for _, r in df[df.status != "landed"].iterrows():
        print(f"  not counted: {r.run_id} ({r.status}): {r.message}")
    ok = df[df.status == "landed"]
    key = _order
    print()
    print(
        "| N | floor | runs (landed) | t_fall/t_ff [95%] | gamma measured [95%] | gamma inferred [95%] "
        "| pile radius / b [95%] | pile offset / b [95%] | worst imbalance/E0 | wall per fall (median) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    rows = []
    for n in sorted(df.segments.unique()):
        for law in sorted(df[df.segments == n].floor_law.unique(), key=key):
            g = df[(df.segments == n) & (df.floor_law == law)]
            gl = g[g.status == "landed"]
            cols = ("ratio", "gamma_measured", "gamma_inferred", "pile_radius", "pile_offset")
            t, gm, gi, pr, po = (_interval(gl[c]) for c in cols)
            print(
                f"| {n} | {law} | {len(g)} ({len(gl)}) | {t[0]} | {gm[0]} | {gi[0]} | {pr[0]} | {po[0]} "
                f"| {gl.imb.max():.1e} | {gl.wall_seconds.median():.1f} s |"
            )
            rows.append((n, law, t, gm))
    print("\nPaired by start, minus the anchor (mean [95%]):\n")
    print("| N | floor | pairs | t_fall/t_ff [95%] | gamma measured [95%] | pile radius / b [95%] |")
    print("|---|---|---|---|---|---|")
    for n, gn in ok.groupby("segments"):
        base = gn[gn.floor_law == "anchor"]
        for law in sorted(gn.floor_law.unique(), key=key):
            if law == "anchor":
                continue
            g = gn[gn.floor_law == law]
            pairs = len(set(g.run_index) & set(base.run_index))
            cells = " | ".join(_paired(g, base, c) for c in ("ratio", "gamma_measured", "pile_radius"))
            print(f"| {n} | {law} | {pairs} | {cells} |")
    print("\nThe Hamm-Geminard picture, fall by fall: gamma measured minus gamma inferred (mean [95%]):\n")
    for n, gn in ok.groupby("segments"):
        cells = []
        for law in sorted(gn.floor_law.unique(), key=key):
            g = gn[gn.floor_law == law]
            d = (g.gamma_measured - g.gamma_inferred).to_numpy(dtype=float)
            cells.append(f"{law} {_interval(d)[0]}")
        print(f"N = {n}: " + "; ".join(cells))
    print(f"\nThe experiment: gamma {GAMMA_EXPERIMENT:g} measured, t_fall/t_ff {ratio_exp:.4f} by its formula.")
    for n, law, t, gm in rows:
        holds_t = t[2] <= ratio_exp <= t[3]
        holds_g = gm[2] <= GAMMA_EXPERIMENT <= gm[3]
        verdict = "both" if holds_t and holds_g else "the time" if holds_t else "gamma" if holds_g else "neither"
        print(
            f"N = {n}, {law}: holds {verdict} (t_fall/t_ff {t[1] - ratio_exp:+.3f} from it, "
            f"gamma measured {gm[1] - GAMMA_EXPERIMENT:+.3f})"
        )
    if a.step_check:
        _step_check(df, a.step_check)
    if a.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import matplotlib.ticker

        fig, ax = plt.subplots(figsize=(8.0, 4.2))
        gam = np.linspace(0.5, 1.49, 200)  # (the formula holds for gamma < 3/2)
        ax.plot([hamm_geminard_time_ratio(x) for x in gam], gam, color="0.6", lw=1.0,
                label="Hamm-Geminard: gamma that sets the time")  # fmt: skip
        markers = {512: "s", 1024: "o"}
        colors = {}
        for n, law, t, gm in rows:
            c = colors.setdefault(law, f"C{len(colors)}")
            ax.errorbar(t[1], gm[1], xerr=[[t[1] - t[2]], [t[3] - t[1]]], yerr=[[gm[1] - gm[2]], [gm[3] - gm[1]]],
                        marker=markers.get(n, "^"), ms=6, color=c, capsize=2, ls="none",
                        mfc="white" if n == 512 else c,
                        label=f"{law}, N = {n}")  # fmt: skip
        ax.plot([ratio_exp], [GAMMA_EXPERIMENT], marker="*", ms=14, color="k", ls="none",
                label="experiment (Hamm and Geminard)")  # fmt: skip
        ax.set_xlabel("t_fall / t_ff (mean, 95%)")
        ax.set_ylabel("gamma measured from the floor (mean, 95%)")
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
        ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_yticks([0.5, 0.83, 1, 2, 5, 10, 20])
        ax.set_xlim(0.88, 1.0)
        ax.set_ylim(0.45, 30.0)
        ax.legend(frameon=False, fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
        fig.tight_layout()
        fig.savefig(a.plot, dpi=130)
        print(f"\nplot: {a.plot}")


if __name__ == "__main__":
    main()
