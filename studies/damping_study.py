"""Viscous damping at the hinges against the fall, in the three methods (the numbers of
docs/hinge-damping.md).

    ballchain sweep -N 64,256 --alpha pi/4 --ic random --runs 16 --hinge-damping 0,0.1 \\
        --method M --out docs/data/damping-M.parquet            # M = event, rattle, timestep
    python studies/damping_study.py docs/data/damping-event.parquet docs/data/damping-rattle.parquet \\
        docs/data/damping-timestep.parquet

The first table is the reference (the exact method's).  Per table and (N, C), over the
runs that landed (a run that ended in error, its books or constraints broken, is listed and
not counted): the runs, the mean t_fall/t_ff with its 95% bootstrap interval
(``sweeps.stats.mean_interval``), the median energy the damping removed (E_damp/E0) and the
worst |imbalance|/E0; the paired difference of t_fall/t_ff from C = 0 on the same starts.
Then each other table against the reference on the same starts, per (N, C): the mean paired
differences of t_fall/t_ff and of E_damp/E0 with their 95% intervals, and the two-sample KS
p of the fall times.  ``--plot FILE``: the mean t_fall/t_ff with its interval, per method, at
C = 0 and C, one panel per N.
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from ballchain.sweeps.stats import mean_interval

KEY = ["segments", "hinge_damping", "run_index"]


def _read(path: str) -> pd.DataFrame:
    df = pd.read_parquet(path)
    df["edamp"] = df.energy_lost_damping / df.energy_initial
    df["imb"] = (df.energy_imbalance / df.energy_initial).abs()
    return df


def _mean(x, fmt: str = "+.3f") -> str:
    """Mean [95% bootstrap interval]."""
    x = np.asarray(x, dtype=float)
    lo, hi = mean_interval(x)
    return f"{x.mean():{fmt}} [{lo:{fmt}}, {hi:{fmt}}]"


def per_table(df: pd.DataFrame) -> None:
    method = ", ".join(sorted(set(df.method)))
    print(f"\n{method}: {len(df)} runs: " + ", ".join(f"{v} {k}" for k, v in df.status.value_counts().items()))
    for _, r in df[df.status != "landed"].iterrows():
        print(f"  not counted: {r.run_id} ({r.status}): {r.message}")
    ok = df[df.status == "landed"]
    base = ok[ok.hinge_damping == 0.0].set_index(["segments", "run_index"]).ratio
    print(
        "\n| N | C | landed | t_fall/t_ff [95%] | paired difference from C = 0 [95%] | E_damp/E0 (median) | worst imbalance/E0 |"
    )
    print("|---|---|---|---|---|---|---|")
    for (n, c), g in ok.groupby(["segments", "hinge_damping"]):
        x = g.ratio.to_numpy(dtype=float)
        lo, hi = mean_interval(x)
        d = (g.set_index(["segments", "run_index"]).ratio - base).dropna().to_numpy(dtype=float)
        diff = "" if c == 0.0 or d.size < 2 else _mean(d)  # (a table without C = 0: none)
        print(
            f"| {n} | {c:g} | {len(g)} | {x.mean():.3f} [{lo:.3f}, {hi:.3f}] | {diff} | {g.edamp.median():.4f} | "
            f"{g.imb.max():.1e} |"
        )


def against(df: pd.DataFrame, ref: pd.DataFrame) -> None:
    from scipy.stats import ks_2samp

    m = df[df.status == "landed"].merge(ref[ref.status == "landed"], on=KEY, suffixes=("", "_ref"))
    method, other = ", ".join(sorted(set(df.method))), ", ".join(sorted(set(ref.method)))
    print(f"\n{method} minus {other}, paired on the same starts:")
    print("\n| N | C | pairs | t_fall/t_ff difference [95%] | KS p | E_damp/E0 difference [95%] |")
    print("|---|---|---|---|---|---|")
    for (n, c), g in m.groupby(["segments", "hinge_damping"]):
        dt = (g.ratio - g.ratio_ref).to_numpy(dtype=float)
        p = ks_2samp(g.ratio.to_numpy(dtype=float), g.ratio_ref.to_numpy(dtype=float)).pvalue
        de = (g.edamp - g.edamp_ref).to_numpy(dtype=float)
        damp = "" if c == 0.0 else _mean(de, "+.4f")
        print(f"| {n} | {c:g} | {len(g)} | {_mean(dt)} | {p:.2f} | {damp} |")


def plot(tables: list[pd.DataFrame], path: str) -> None:
    """Mean t_fall/t_ff [95%] against C, one line per method, one panel per N."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = sorted(set().union(*(set(df.segments) for df in tables)))
    fig, axes = plt.subplots(1, len(sizes), figsize=(3.2 * len(sizes), 3.4), sharey=True, squeeze=False)
    for ax, n in zip(axes[0], sizes, strict=True):
        for k, df in enumerate(tables):
            ok = df[(df.status == "landed") & (df.segments == n)]
            pts = []
            for c, g in ok.groupby("hinge_damping"):
                x = g.ratio.to_numpy(dtype=float)
                lo, hi = mean_interval(x)
                pts.append((c, x.mean(), lo, hi))
            c, m, lo, hi = (np.array(v) for v in zip(*pts))
            shift = 0.004 * (k - (len(tables) - 1) / 2) * max(c.max(), 1e-9) / 0.1
            ax.errorbar(c + shift, m, yerr=[m - lo, hi - m], marker="o", capsize=3, label=", ".join(set(df.method)))
        ax.axhline(1.0, color="0.5", lw=0.8, ls="--")
        ax.set_title(f"N = {n}")
        ax.set_xlabel("hinge damping C, m g b sqrt(b/g)")
    axes[0, 0].set_ylabel("t_fall / t_ff (mean, 95%)")
    axes[0, 0].legend(frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    print(f"\nplot: {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tables", nargs="+", help="the reference's table first")
    ap.add_argument("--plot")
    a = ap.parse_args()
    tables = [_read(t) for t in a.tables]
    for df in tables:
        per_table(df)
    for df in tables[1:]:
        against(df, tables[0])
    if a.plot:
        plot(tables, a.plot)


if __name__ == "__main__":
    main()
