"""Restitution at the bend limit, or at the floor, against the fall (the numbers of
docs/restitution.md and docs/restitution-floor.md).

    python studies/restitution_study.py docs/data/restitution-lock.parquet [--plot FILE]
    python studies/restitution_study.py docs/data/restitution-floor.parquet --law restitution_floor [--plot FILE]

Per (N, restitution E), over the runs that landed (a run that ended as an error, its
books or constraints broken, is listed and not counted): the runs and how many landed;
the mean t_fall/t_ff with its 95%
bootstrap interval (``sweeps.stats.mean_interval``); the fraction faster than free fall
with its Wilson interval; the medians of E_lock/E0 (what the lock impacts dissipate), of
E_land/E0, of the lock events per segment and of the wall time of a fall; the worst
|imbalance|/E0.  Then the mean
difference of t_fall/t_ff from E = 0, paired by start (the same 16 starts at every E),
with its 95% bootstrap interval.  ``--law restitution_floor``: the same per restitution
at the floor, with the bounces per segment instead of the lock events, and the braking
coefficient gamma measured from the floor (mean, 95%) and inferred from t_fall/t_ff (the
Hamm-Geminard formula), with their paired differences too.  ``--plot``: the mean
t_fall/t_ff against E, one line per N, with its intervals.  ``--against TABLE``: the
table's runs (another method's) minus TABLE's on the same starts, per (N, E): the pairs,
the mean paired difference of t_fall/t_ff and of E_lock/E0 with their 95% bootstrap
intervals, and the two-sample KS p of the fall times; then, over every start, how many land
by the time cap in each table (McNemar's test of the starts only one lands) and the medians
with the falls past the cap counted as longer:

    python studies/restitution_study.py docs/data/rattle-restitution-lock.parquet --against docs/data/restitution-lock.parquet
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from ballchain.sweeps.stats import mean_interval, wilson_interval

GAMMAS = ("gamma_measured", "gamma_inferred")


def _interval(x) -> str:
    """Mean [95% bootstrap interval] of a column's finite values (gamma_inferred is NaN for a
    fall slower than the Hamm-Geminard formula reaches: their number is given)."""
    x = x.to_numpy(dtype=float)
    ok = x[np.isfinite(x)]
    lo, hi = mean_interval(ok)
    return f"{ok.mean():.3f} [{lo:.3f}, {hi:.3f}]" + (f" ({ok.size} of {x.size})" if ok.size < x.size else "")


def against(df, ref, law) -> None:
    """df's runs minus ref's on the same starts (N, E, run_index), per (N, E)."""
    from scipy.stats import ks_2samp

    for d in (df, ref):
        d["elock"] = d.energy_lost_locking / d.energy_initial
    print(
        f"{len(df)} runs ({', '.join(sorted(set(df.method)))}) against {len(ref)} ({', '.join(sorted(set(ref.method)))})"
    )
    for _, r in df[df.status != "landed"].iterrows():
        print(f"  not counted: {r.run_id} ({r.status}): {r.message}")
    print(
        "\n| N | E | pairs | t_fall/t_ff, this | against | paired difference [95%] | KS p | E_lock/E0 paired difference [95%] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    key = ["segments", law, "run_index"]
    m = df[df.status == "landed"].merge(ref[ref.status == "landed"], on=key, suffixes=("", "_ref"))
    for (n, e), g in m.groupby(["segments", law]):
        if e == 0.0 and g.empty:
            continue
        dt = (g.ratio - g.ratio_ref).to_numpy(dtype=float)
        de = (g.elock - g.elock_ref).to_numpy(dtype=float)
        (tlo, thi), (elo, ehi) = mean_interval(dt), mean_interval(de)
        p = ks_2samp(g.ratio.to_numpy(dtype=float), g.ratio_ref.to_numpy(dtype=float)).pvalue
        print(
            f"| {n} | {e:g} | {len(g)} | {g.ratio.mean():.3f} | {g.ratio_ref.mean():.3f} | {dt.mean():+.3f} "
            f"[{tlo:+.3f}, {thi:+.3f}] | {p:.2f} | {de.mean():+.4f} [{elo:+.4f}, {ehi:+.4f}] |"
        )
    landed_by_the_cap(df, ref, law)


def landed_by_the_cap(df, ref, law) -> None:
    """The pairs above are the starts both runs land by the time cap: where many do not,
    that choice is biased.  Per (N, E), over every start of both tables: how many land by
    the cap in each, the starts only one of them lands (McNemar's exact test of the two
    counts), and the median t_fall/t_ff with a run that did not land counted as longer
    than any that did."""
    from scipy.stats import binomtest

    key = ["segments", law, "run_index"]
    m = df.merge(ref, on=key, suffixes=("", "_ref"))
    print(
        "\n| N | E | starts | landed, this | against | only this lands | only against | McNemar p | median, this | against |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for (n, e), g in m.groupby(["segments", law]):
        a, b = (g.status == "landed").to_numpy(), (g.status_ref == "landed").to_numpy()
        ab, ba = int((a & ~b).sum()), int((~a & b).sum())
        p = binomtest(ab, ab + ba).pvalue if ab + ba else 1.0
        med = [np.median(np.where(ok, r.to_numpy(dtype=float), np.inf)) for ok, r in ((a, g.ratio), (b, g.ratio_ref))]
        text = [f"{v:.3f}" if np.isfinite(v) else "past the cap" for v in med]
        print(f"| {n} | {e:g} | {len(g)} | {a.sum()} | {b.sum()} | {ab} | {ba} | {p:.2f} | {text[0]} | {text[1]} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table")
    ap.add_argument("--plot")
    ap.add_argument("--law", default="restitution_lock", choices=["restitution_lock", "restitution_floor"])
    ap.add_argument("--against", help="another method's table of the same starts: paired differences")
    a = ap.parse_args()
    law, floor = a.law, a.law == "restitution_floor"
    df = pd.read_parquet(a.table)
    if a.against:
        against(df, pd.read_parquet(a.against), law)
        return
    df["elock"] = df.energy_lost_locking / df.energy_initial
    df["eland"] = df.energy_lost_landing / df.energy_initial
    df["imb"] = (df.energy_imbalance / df.energy_initial).abs()
    df["per_seg"] = (df.events_bounce if floor else df.events_lock) / df.segments
    print(f"{len(df)} runs: " + ", ".join(f"{v} {k}" for k, v in df.status.value_counts().items()))
    for _, r in df[df.status != "landed"].iterrows():
        print(f"  not counted: {r.run_id} ({r.status}): {r.message}")
    print()
    what = "bounces" if floor else "lock events"
    print(
        "| N | E | runs | landed | t_fall/t_ff [95%] | faster than free fall [95%] | E_lock/E0 (median) | "
        f"E_land/E0 (median) | {what} per segment (median) | worst imbalance/E0 | wall per fall (median) |"
        + (" gamma measured [95%] | gamma inferred [95%] |" if floor else "")
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|" + ("---|---|" if floor else ""))
    curves = {}
    for (n, e), g in df.groupby(["segments", law]):
        x = g[g.status == "landed"].ratio.to_numpy(dtype=float)  # (a run that broke the model: not counted)
        lo, hi = mean_interval(x)
        k = int(np.sum(x < 1.0))
        flo, fhi = wilson_interval(k, x.size)
        print(
            f"| {n} | {e:g} | {len(g)} | {(g.status == 'landed').sum()} | {x.mean():.3f} [{lo:.3f}, {hi:.3f}] | "
            f"{k / x.size:.2f} [{flo:.2f}, {fhi:.2f}] | {g.elock.median():.3f} | {g.eland.median():.3f} | "
            f"{g.per_seg.median():.0f} | {g.imb.max():.1e} | {g.wall_seconds.median():.1f} s |"
            + "".join(f" {_interval(g[g.status == 'landed'][c])} |" for c in GAMMAS if floor)
        )
        curves.setdefault(n, []).append((e, x.mean(), lo, hi))
    cols = ["ratio"] + (list(GAMMAS) if floor else [])
    print("\nPaired by start, minus at E = 0 (mean [95%]):\n")
    print("| N | E | pairs | " + " | ".join(f"{c if c != 'ratio' else 't_fall/t_ff'} [95%]" for c in cols) + " |")
    print("|---|---|---|" + "---|" * len(cols))
    for n, g in df.groupby("segments"):
        g = g[g.status == "landed"]
        base = g[g[law] == 0.0].set_index("run_index")
        for e, h in g[g[law] > 0.0].groupby(law):
            h = h.set_index("run_index")
            cells, pairs = [], 0
            for c in cols:
                d = (h[c] - base[c]).dropna().to_numpy(dtype=float)
                d = d[np.isfinite(d)]
                lo, hi = mean_interval(d)
                cells.append(f"{d.mean():+.3f} [{lo:+.3f}, {hi:+.3f}]" + ("" if c == "ratio" else f" ({d.size})"))
                pairs = d.size if c == "ratio" else pairs  # (the fall times' pairs)
            print(f"| {n} | {e:g} | {pairs} | " + " | ".join(cells) + " |")
    if a.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        for n, pts in sorted(curves.items()):
            e, m, lo, hi = (np.array(v) for v in zip(*pts))
            ax.errorbar(e, m, yerr=[m - lo, hi - m], marker="o", capsize=3, label=f"N = {n}")
        ax.axhline(1.0, color="0.5", lw=0.8, ls="--")
        ax.set_xlabel("restitution at the floor, E" if floor else "restitution at the bend limit, E")
        ax.set_ylabel("t_fall / t_ff (mean, 95%)")
        ax.legend(frameon=False)
        fig.tight_layout()
        fig.savefig(a.plot, dpi=130)
        print(f"\nplot: {a.plot}")


if __name__ == "__main__":
    main()
