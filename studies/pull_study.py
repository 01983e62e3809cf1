"""The pile's pull against the chain's length and its bend limit (the numbers of
docs/pull.md).

    ballchain sweep -N 64,128,256,512 --alpha 45deg --ic random --seed 2026 --runs 16 --floor all \\
        --workers 1 --out docs/data/pull.parquet
    ballchain sweep -N 128 --alpha 30deg,60deg,90deg --ic random --seed 2026 --runs 16 --floor all \\
        --workers 1 --out docs/data/pull.parquet
    python studies/pull_study.py docs/data/pull.parquet --plot docs/figures/pull.png

Per (N, alpha), over the runs that landed (one that ended in error is listed and not
counted): the runs, the mean t_fall/t_ff, the mean ``pull_median`` (the median tension
just above the pile from the first landed segment to t_fall, in m g) and the same over the
chain's weight N m g, each with its 95% bootstrap interval (``sweeps.stats.mean_interval``);
and Spearman's rank correlation between a start's pull and its fall time, with its p
(negative: the starts that the pile pulls harder fall faster).  ``--plot FILE``: the mean
pull over N m g against N (alpha = 45 deg), and against alpha (N = 128).
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import pandas as pd

from ballchain.sweeps.stats import mean_interval


def _read(path: str) -> pd.DataFrame:
    df = pd.read_parquet(path)
    df["alpha_deg"] = np.round(np.degrees(df.alpha.astype(float)), 6)
    df["pull"] = df.pull_median.astype(float)
    df["pull_weight"] = df.pull / df.segments
    return df


def _mean(x, fmt: str) -> str:
    """Mean [95% bootstrap interval]."""
    x = np.asarray(x, dtype=float)
    lo, hi = mean_interval(x)
    return f"{x.mean():{fmt}} [{lo:{fmt}}, {hi:{fmt}}]"


def table(df: pd.DataFrame) -> None:
    from scipy.stats import spearmanr

    print(f"{len(df)} runs: " + ", ".join(f"{v} {k}" for k, v in df.status.value_counts().items()))
    for _, r in df[df.status != "landed"].iterrows():
        print(f"  not counted: {r.run_id} ({r.status}): {r.message}")
    ok = df[df.status == "landed"]
    print("\n| N | alpha | landed | t_fall/t_ff [95%] | pull / m g [95%] | pull / N m g [95%] | Spearman rho (p) |")
    print("|---|---|---|---|---|---|---|")
    for (n, a), g in ok.groupby(["segments", "alpha_deg"]):
        rho, p = spearmanr(g.pull, g.ratio)
        rho_text = "" if not math.isfinite(rho) else f"{rho:+.2f} ({p:.2f})"
        print(
            f"| {n} | {a:g} | {len(g)} | {_mean(g.ratio, '.3f')} | {_mean(g.pull, '.2f')} | "
            f"{_mean(g.pull_weight, '.4f')} | {rho_text} |"
        )


def plot(df: pd.DataFrame, path: str) -> None:
    """The mean pull over N m g [95%] against N at 45 deg, and against alpha at N = 128."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = df[df.status == "landed"]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(7.5, 3.4), sharey=True)
    for ax, sel, key, label in (
        (a1, ok[ok.alpha_deg == 45.0], "segments", "N (alpha = 45 deg)"),
        (a2, ok[ok.segments == 128], "alpha_deg", "alpha, deg (N = 128)"),
    ):
        pts = []
        for x, g in sel.groupby(key):
            lo, hi = mean_interval(g.pull_weight.to_numpy(dtype=float))
            pts.append((x, g.pull_weight.mean(), lo, hi))
        x, m, lo, hi = (np.array(v, dtype=float) for v in zip(*pts))
        ax.errorbar(x, m, yerr=[m - lo, hi - m], marker="o", capsize=3)
        ax.set_xlabel(label)
        if key == "segments":
            ax.set_xscale("log", base=2)
    a1.set_ylabel("pull above the pile / N m g\n(mean of the starts, 95%)")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    print(f"\nplot: {path}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table")
    ap.add_argument("--plot")
    a = ap.parse_args()
    df = _read(a.table)
    table(df)
    if a.plot:
        plot(df, a.plot)


if __name__ == "__main__":
    main()
