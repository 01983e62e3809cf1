"""Restitution at the bend limit against the fall (the numbers of docs/restitution.md).

    python benchmarks/restitution_study.py docs/data/restitution-lock.parquet [--plot FILE]

Per (N, restitution E), over the runs that landed (a run that ended as an error, its
books or constraints broken, is listed and not counted): the runs and how many landed;
the mean t_fall/t_ff with its 95%
bootstrap interval (``sweeps.stats.mean_interval``); the fraction faster than free fall
with its Wilson interval; the medians of E_lock/E0 (what the lock impacts dissipate), of
E_land/E0, of the lock events per segment and of the wall time of a fall; the worst
|imbalance|/E0.  Then the mean
difference of t_fall/t_ff from E = 0, paired by start (the same 16 starts at every E),
with its 95% bootstrap interval.  ``--plot``: the mean t_fall/t_ff against E, one line per N, with its intervals.
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from ballchain.sweeps.stats import mean_interval, wilson_interval


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table")
    ap.add_argument("--plot")
    a = ap.parse_args()
    df = pd.read_parquet(a.table)
    df["elock"] = df.energy_lost_locking / df.energy_initial
    df["eland"] = df.energy_lost_landing / df.energy_initial
    df["imb"] = (df.energy_imbalance / df.energy_initial).abs()
    df["locks_per_seg"] = df.events_lock / df.segments
    print(f"{len(df)} runs: " + ", ".join(f"{v} {k}" for k, v in df.status.value_counts().items()))
    for _, r in df[df.status != "landed"].iterrows():
        print(f"  not counted: {r.run_id} ({r.status}): {r.message}")
    print()
    print(
        "| N | E | runs | landed | t_fall/t_ff [95%] | faster than free fall [95%] | E_lock/E0 (median) | "
        "E_land/E0 (median) | lock events per segment (median) | worst imbalance/E0 | wall per fall (median) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    curves = {}
    for (n, e), g in df.groupby(["segments", "restitution_lock"]):
        x = g[g.status == "landed"].ratio.to_numpy(dtype=float)  # (a run that broke the model: not counted)
        lo, hi = mean_interval(x)
        k = int(np.sum(x < 1.0))
        flo, fhi = wilson_interval(k, x.size)
        print(
            f"| {n} | {e:g} | {len(g)} | {(g.status == 'landed').sum()} | {x.mean():.3f} [{lo:.3f}, {hi:.3f}] | "
            f"{k / x.size:.2f} [{flo:.2f}, {fhi:.2f}] | {g.elock.median():.3f} | {g.eland.median():.3f} | "
            f"{g.locks_per_seg.median():.0f} | {g.imb.max():.1e} | {g.wall_seconds.median():.1f} s |"
        )
        curves.setdefault(n, []).append((e, x.mean(), lo, hi))
    print("\nPaired by start, t_fall/t_ff minus at E = 0 (mean [95%]):\n")
    print("| N | E | pairs | difference [95%] |")
    print("|---|---|---|---|")
    for n, g in df.groupby("segments"):
        g = g[g.status == "landed"]
        base = g[g.restitution_lock == 0.0].set_index("run_index").ratio
        for e, h in g[g.restitution_lock > 0.0].groupby("restitution_lock"):
            d = (h.set_index("run_index").ratio - base).dropna().to_numpy()
            lo, hi = mean_interval(d)
            print(f"| {n} | {e:g} | {d.size} | {d.mean():+.3f} [{lo:+.3f}, {hi:+.3f}] |")
    if a.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        for n, pts in sorted(curves.items()):
            e, m, lo, hi = (np.array(v) for v in zip(*pts))
            ax.errorbar(e, m, yerr=[m - lo, hi - m], marker="o", capsize=3, label=f"N = {n}")
        ax.axhline(1.0, color="0.5", lw=0.8, ls="--")
        ax.set_xlabel("restitution at the bend limit, E")
        ax.set_ylabel("t_fall / t_ff (mean, 95%)")
        ax.legend(frameon=False)
        fig.tight_layout()
        fig.savefig(a.plot, dpi=130)
        print(f"\nplot: {a.plot}")


if __name__ == "__main__":
    main()
