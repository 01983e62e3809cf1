"""A frictionless floor against the anchor (the numbers of docs/friction-floor.md).

    python studies/friction_study.py docs/data/friction-floor.parquet [--plot FILE]
    python studies/friction_study.py --methods [--restitution-floor E] TABLE [TABLE ...]

The table holds falls of the same starts with ``--friction 0`` and ``--friction inf``
(the anchor, the model's law), by one method.  Per (N, mu), over the runs that landed (a
run that ended otherwise is listed and not counted): the runs and how many landed; the
mean t_fall/t_ff with its 95% bootstrap interval (``sweeps.stats.mean_interval``); the
braking coefficient gamma measured from the floor's momentum record and inferred from
t_fall/t_ff (the Hamm-Geminard formula), means with their intervals; the medians of
E_lock/E0 and E_land/E0 (what the locks and the floor's impacts dissipate) and of the
wall time of a fall; the worst |imbalance|/E0 and the deepest point.  Then, paired by
start (mu 0 minus inf), the mean differences of t_fall/t_ff, of gamma measured and of
E_lock/E0, with their 95% bootstrap intervals, and the median difference of t_fall/t_ff.  ``--plot``: t_fall/t_ff against N for
both floors, every fall and the means with their intervals.

``--methods``: the frictionless falls (mu 0) of the tables joined, the exact method's
against RATTLE's paired by start (the same N, seed and spawn key): per N the pairs, each
method's mean t_fall/t_ff with its interval, the paired differences (exact minus RATTLE)
of t_fall/t_ff, E_lock/E0, E_land/E0 and their sum with their intervals, the two-sample
Kolmogorov-Smirnov p of t_fall/t_ff, each method's worst |imbalance|/E0 and its median
wall time of a fall; the paired t_fall/t_ff's median and each method's slowest fall; and the
exact method's median counts per fall of instants, lift-offs and the accumulation rule's
``pin`` rows.  ``--restitution-floor E``: the falls on a
frictionless floor that bounces at E instead (their bounces counted too).
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import pandas as pd

from ballchain.sweeps.stats import mean_interval


def _interval(x, digits: int = 3) -> str:
    """Mean [95% bootstrap interval] of the finite values (gamma inferred is NaN for a fall
    slower than the Hamm-Geminard formula reaches: their number is given)."""
    x = np.asarray(x, dtype=float)
    ok = x[np.isfinite(x)]
    if ok.size == 0:
        return "n/a"
    lo, hi = mean_interval(ok)
    f = f"{{:+.{digits}f}}" if np.any(ok < 0) else f"{{:.{digits}f}}"
    text = f"{f.format(ok.mean())} [{f.format(lo)}, {f.format(hi)}]"
    return text + (f" ({ok.size} of {x.size})" if ok.size < x.size else "")


def _mu(v: float) -> str:
    return "inf" if math.isinf(v) else f"{v:g}"


def methods(tables: list[str], e_floor: float = 0.0) -> None:
    """The exact method against RATTLE on a frictionless floor, bouncing at ``e_floor``
    (module docstring)."""
    from scipy.stats import ks_2samp

    df = pd.concat([pd.read_parquet(t) for t in tables], ignore_index=True)
    if "restitution_floor" not in df:
        df["restitution_floor"] = 0.0
    df = df[(df.friction == 0.0) & (df.restitution_floor.fillna(0.0) == e_floor)]
    for n, g in df.groupby(["segments", "method"]):
        if (g.status != "landed").any():
            print(f"N = {n[0]}, {n[1]}: {(g.status != 'landed').sum()} of {len(g)} did not land, not counted")
    df = df[df.status == "landed"].copy()
    for col, src in (("elock", "energy_lost_locking"), ("eland", "energy_lost_landing")):
        df[col] = df[src] / df.energy_initial
    df["elost"] = df.elock + df.eland
    df["imb"] = (df.energy_imbalance / df.energy_initial).abs()
    bounce = f", bouncing at E = {e_floor:g}" if e_floor else ""
    print(f"Frictionless floor{bounce}, the exact method (event) against RATTLE, paired by start (event minus rattle):")
    print()
    print(
        "| N | pairs | event t_fall/t_ff [95%] | rattle t_fall/t_ff [95%] | paired t_fall/t_ff [95%] | KS p "
        "| paired E_lock/E0 [95%] | paired E_land/E0 [95%] | paired E_lock + E_land [95%] "
        "| worst imbalance/E0 (event, rattle) | wall per fall (event, rattle) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    key = ["seed", "spawn_key"]
    spread = []  # the paired t_fall/t_ff's median and each method's slowest fall, per N
    for n, g in df.groupby("segments"):
        ev = g[g.method == "event"].set_index(key)
        ra = g[g.method == "rattle"].set_index(key)
        idx = ev.index.intersection(ra.index)
        if idx.empty:
            continue
        e, r = ev.loc[idx], ra.loc[idx]
        spread.append(
            f"N = {n}: the paired t_fall/t_ff's median {(e.ratio - r.ratio).median():+.4f}; the slowest "
            f"fall {e.ratio.max():.3f} (event), {r.ratio.max():.3f} (rattle)"
        )
        print(
            f"| {n} | {len(idx)} | {_interval(e.ratio)} | {_interval(r.ratio)} | {_interval(e.ratio - r.ratio, 4)} "
            f"| {ks_2samp(e.ratio, r.ratio).pvalue:.2f} | {_interval(e.elock - r.elock, 4)} "
            f"| {_interval(e.eland - r.eland, 4)} | {_interval(e.elost - r.elost, 4)} "
            f"| {e.imb.max():.1e}, {r.imb.max():.1e} | {e.wall_seconds.median():.1f} s, {r.wall_seconds.median():.1f} s |"
        )
    print()
    print("\n".join(spread))
    for n, g in df[df.method == "event"].groupby("segments"):
        print(
            f"N = {n}, the exact method: {int(g.n_instants.median())} instants, {int(g.events_lift.median())} "
            "lift-offs"
            + (f", {int(g.events_bounce.median())} bounces" if e_floor else "")
            + f" and {int(g.events_pin.median())} pin rows per fall (medians); deepest point "
            f"{g.max_depth.max():.1e} b"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tables", nargs="+")
    ap.add_argument("--plot")
    ap.add_argument("--methods", action="store_true", help="the exact method against RATTLE at mu 0, paired")
    ap.add_argument("--restitution-floor", type=float, default=0.0, help="with --methods: the falls bouncing at E")
    a = ap.parse_args()
    if a.methods:
        methods(a.tables, a.restitution_floor)
        return
    df = pd.read_parquet(a.tables[0])
    df["friction"] = df["friction"].fillna(math.inf)  # (tables written before the column: the anchor)
    df["elock"] = df.energy_lost_locking / df.energy_initial
    df["eland"] = df.energy_lost_landing / df.energy_initial
    df["imb"] = (df.energy_imbalance / df.energy_initial).abs()
    print(f"{len(df)} runs ({', '.join(sorted(df.method.unique()))}): "
          + ", ".join(f"{v} {k}" for k, v in df.status.value_counts().items()))  # fmt: skip
    for _, r in df[df.status != "landed"].iterrows():
        print(f"  not counted: {r.run_id} ({r.status}): {r.message}")
    ok = df[df.status == "landed"]
    print()
    print(
        "| N | friction | runs (landed) | t_fall/t_ff [95%] | t_fall/t_ff (median) | slower than free fall "
        "| gamma measured [95%] | gamma inferred [95%] | E_lock/E0 (median) | E_land/E0 (median) "
        "| worst imbalance/E0 | deepest point (b) | wall per fall |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for (n, mu), g in df.groupby(["segments", "friction"]):
        gl = g[g.status == "landed"]
        print(
            f"| {n} | {_mu(mu)} | {len(g)} ({len(gl)}) | {_interval(gl.ratio)} | {gl.ratio.median():.3f} "
            f"| {int((gl.ratio > 1.0).sum())} | {_interval(gl.gamma_measured)} "
            f"| {_interval(gl.gamma_inferred)} | {gl.elock.median():.3f} | {gl.eland.median():.3f} "
            f"| {gl.imb.max():.1e} | {gl.max_depth.max():.1e} | {gl.wall_seconds.median():.1f} s |"
        )
    print()
    for (n, mu), g in ok.groupby(["segments", "friction"]):
        per_point = (g.events_landing / (g.segments + 1)).median()
        late = ", ".join(f"start {int(r.run_index)}: {r.ratio:.3f}" for _, r in g[g.ratio > 1.0].iterrows())
        print(f"N = {n}, friction {_mu(mu)}: {per_point:.1f} landings per point (median)"
              + (f"; slower than free fall: {late}" if late and n >= 512 else ""))  # fmt: skip
    print()
    print("Paired by start, frictionless minus the anchor:")
    print()
    print("| N | pairs | t_fall/t_ff [95%] | t_fall/t_ff (median) | gamma measured [95%] | E_lock/E0 [95%] |")
    print("|---|---|---|---|---|---|")
    for n, g in ok.groupby("segments"):
        base = g[np.isinf(g.friction)].set_index("run_index")
        free = g[g.friction == 0.0].set_index("run_index")
        idx = base.index.intersection(free.index)
        if idx.empty:
            continue
        d = free.loc[idx]
        b = base.loc[idx]
        print(
            f"| {n} | {len(idx)} | {_interval(d.ratio - b.ratio, 4)} | {(d.ratio - b.ratio).median():+.4f} "
            f"| {_interval(d.gamma_measured - b.gamma_measured)} | {_interval(d.elock - b.elock, 4)} |"
        )
    if a.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.0, 4.0))
        for k, (_, g) in enumerate(ok.groupby("friction")):  # every fall, a little apart by floor
            shift = 0.92 if k == 0 else 1.08
            ax.scatter(g.segments * shift, g.ratio, s=6, alpha=0.35, color=f"C{k}", lw=0)
        for k, (mu, g) in enumerate(ok.groupby("friction")):
            ns, mean, lo, hi = [], [], [], []
            for n, h in g.groupby("segments"):
                lo_, hi_ = mean_interval(h.ratio.to_numpy(dtype=float))
                ns.append(n * (0.97 if k == 0 else 1.03))
                mean.append(h.ratio.mean())
                lo.append(lo_)
                hi.append(hi_)
            mean, lo, hi = map(np.asarray, (mean, lo, hi))
            label = "anchor (friction inf)" if math.isinf(mu) else f"frictionless (friction {_mu(mu)})"
            ax.errorbar(ns, mean, yerr=[mean - lo, hi - mean], marker="o", capsize=3, label=label)
        ax.axhline(1.0, color="0.6", lw=0.8, ls="--")
        ax.set_xscale("log", base=2)
        ax.set_xlabel("N (segments)")
        ax.set_ylabel("t_fall / t_ff (each fall; mean, 95% interval)")
        ax.legend()
        fig.tight_layout()
        fig.savefig(a.plot, dpi=120)
        print(f"\nwrote {a.plot}")


if __name__ == "__main__":
    main()
