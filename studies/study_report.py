"""Markdown tables of a sweep table's statistics (the numbers of docs/optimal-alpha.md).

    python studies/study_report.py docs/data/optimal-alpha.parquet

Prints, from ``ballchain.sweeps.stats`` (the same numbers as ``ballchain stats --json``):
the points (mean, 95% interval, median of t_fall/t_ff and t_landed/t_ff, the fraction
faster than free fall with its Wilson interval), the optimal alpha per (N, floor), and
the crossover: for each (alpha, floor) measured at several N, the N where the mean
t_fall/t_ff crosses 1 (linear in log N between the two sizes that bracket it), with a
95% bootstrap interval (the runs of every N resampled, 2000 times, seed 1).
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pandas as pd

from ballchain.sweeps.stats import table_stats


def f(x, spec=".3f"):
    return "-" if x is None else format(x, spec)


def main() -> None:
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    res = table_stats(sys.argv[1])
    print(f"{res['rows']} runs: " + ", ".join(f"{v} {k}" for k, v in res["status"].items()) + "\n")
    print(
        "| N | alpha (deg) | floor | runs | t_fall/t_ff mean [95%] | median | t_landed/t_ff mean | "
        "faster than free fall [95%] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for p in res["points"]:
        r, lr, fa = p["ratio"], p["landed_ratio"], p["faster_than_free_fall"]
        print(
            f"| {p['segments']} | {p['alpha_deg']:.4g} | {p['floor']} | {p['n_runs']} | {f(r['mean'])} "
            f"[{f(r['ci_low'])}, {f(r['ci_high'])}] | {f(r['median'])} | {f(lr['mean'])} | "
            f"{fa['k']}/{fa['n']} [{f(fa['ci_low'], '.2f')}, {f(fa['ci_high'], '.2f')}] |"
        )
    print("\n| N | floor | alphas | optimal alpha (deg) [95%] | mean t_fall/t_ff there | share of resamples |")
    print("|---|---|---|---|---|---|")
    for o in res["optimal_alpha"]:
        if o["n_alpha"] > 1 and o["alpha_deg"] is not None:
            print(
                f"| {o['segments']} | {o['floor']} | {o['n_alpha']} | {o['alpha_deg']:.4g} "
                f"[{o['ci_low_deg']:.4g}, {o['ci_high_deg']:.4g}] | {o['mean']:.3f} | {o['share_best']:.2f} |"
            )
    print("\n| alpha (deg) | floor | N measured | crossover N (mean t_fall/t_ff = 1) | 95% interval |")
    print("|---|---|---|---|---|")
    df = pd.read_parquet(sys.argv[1])
    df = df[np.isfinite(df["ratio"])]
    keys = sorted({(p["alpha_deg"], p["floor"]) for p in res["points"]})
    rng = np.random.default_rng(1)
    for a, fl in keys:
        g = df[(np.abs(df["alpha_deg"] - a) < 1e-9) & (df["floor"] == fl)]
        sizes = sorted(g["segments"].unique())
        if len(sizes) < 3:
            continue
        samples = [g.loc[g["segments"] == n, "ratio"].to_numpy() for n in sizes]
        best = crossing(sizes, [x.mean() for x in samples])
        boot = [crossing(sizes, [rng.choice(x, x.size).mean() for x in samples]) for _ in range(2000)]
        boot = np.array([b for b in boot if b is not None])
        if best is None:
            cell, ci = "not bracketed", "-"
        else:
            cell = f"{best:.0f}"
            ci = (
                f"[{np.quantile(boot, 0.025):.0f}, {np.quantile(boot, 0.975):.0f}] "
                f"({boot.size / 20:.0f}% of resamples cross)"
                if boot.size
                else "-"
            )
        print(f"| {a:.4g} | {fl} | {', '.join(str(n) for n in sizes)} | {cell} | {ci} |")


def crossing(sizes, means):
    """The first N where the mean goes from above 1 to at or below it (log-linear)."""
    for n0, n1, y0, y1 in zip(sizes, sizes[1:], means, means[1:]):
        if y0 > 1.0 >= y1:
            x0, x1 = math.log(n0), math.log(n1)
            return math.exp(x0 + (x1 - x0) * (y0 - 1.0) / (y0 - y1))
    return None


if __name__ == "__main__":
    main()
