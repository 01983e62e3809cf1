"""Measures of the paper's qualitative claims on the saved runs of a sweep.

    python studies/reproduction_study.py TABLE.parquet RUNS_DIR [--measures-out M.parquet]
    python studies/reproduction_study.py TABLE.parquet --measures M.parquet [--scatter]

For every run of the table whose result file is in RUNS_DIR (``ballchain sweep
--save-runs RUNS_DIR``) and that landed (or, with ``--measures``, from a table of per-run
measures written earlier by ``--measures-out``, so the numbers can be regenerated without
the runs):

* ``departure``, ``departure5``: the first t/t_ff at which the top end is 0.01 z0
  (0.05 z0) away from a particle falling freely from z0 (|z_top/z0 - (1 - (t/t_ff)^2)|);
  ``lag06``: z_top/z0 - (1 - 0.36) at t = 0.6 t_ff (> 0: behind free fall);
* ``lock_z95``: the 95th percentile of the heights (in z0) of the hinges at the instants
  they lock, over locks after 0.1 t_ff; ``lock_below_0.1``: the fraction of those below
  0.1 z0;
* ``pull_down``: over the frames with 0.5 <= t/t_ff <= t_fall/t_ff, the fraction in
  which the pile pulls the hanging chain down (vertical pull < 0), and ``pull_mean``,
  its mean vertical component in units of one segment's weight m g;
* ``depth``: the deepest airborne point below the floor (``max_depth``), in units of
  the chain's length 2 N b; ``depth_fall``: the depth at the last frame before t_fall,
  same unit (floor ``all`` keeps every point at z >= 0);
* ``coil_before``, ``coil_after``: how much the pile coils, as turns per 10 landed
  segments: |sum of the signed turning angles between successive landed segments in
  the horizontal plane| / 2 pi, for the segments landed before and after 0.55 t_ff.

With ``--scatter``, the numerical scatter of one start: for the starts of a point run at
several ``rtol`` (the same start, other numerical realizations of its chaotic fall), the
standard deviation of t_fall/t_ff across the tolerances, pooled over the starts, beside
the standard deviation across the starts at each tolerance (from the sweep table alone).

With ``--paired``, also the same starts on both floors: the mean difference of t_fall/t_ff
(pivot - all) per (N, alpha), with its standard error.

Prints, per (N, alpha, floor), the mean and the range of each measure over the runs, as
a Markdown table (or one JSON object).  Reads the files' datasets directly (their layout
is documented in docs/measures.md, section 6).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import h5py
import numpy as np
import pandas as pd

THRESH = 0.01


def measures(path: str) -> dict:
    with h5py.File(path, "r") as f:
        s = f["summary"]
        t_ff, z0, t_fall = float(s["t_ff"][()]), float(s["z0"][()]), float(s["t_fall"][()])
        max_depth = float(s["max_depth"][()])
        n = int(json.loads(f.attrs["params_json"])["segments"])
        b = float(json.loads(f.attrs["params_json"])["half_length"])
        tau = f["trace/t"][()] / t_ff
        z = f["trace/z_top"][()] / z0
        kind = f["events/event_kind"][()]
        lock = np.flatnonzero(kind == 1)
        lt = f["events/event_t"][()][lock] / t_ff
        lz = f["events/event_pos"][()][lock, 2] / z0
        ft = f["frames/frame_t"][()] / t_ff
        pull = f["frames/frame_pile_pull"][()][:, 2]
        fe = f["frames/frame_e"][()]
        at = f["anchors/anchor_t"][()] / t_ff
        apos = f["anchors/anchor_pos"][()]
    # depth: the lowest point of the chain at the last frame before t_fall (z of point j:
    # 2 b sum_{i >= j} e_i,z, point n at 0)
    k = max(0, int(np.searchsorted(ft, t_fall / t_ff)) - 1)
    zpts = 2.0 * b * np.cumsum(fe[k, ::-1, 2])[::-1]
    depth_fall = max(0.0, -float(np.min(zpts))) / (2 * n * b)
    # coiling: signed turning between successive landed segments, in order of landing
    landed = np.maximum(at[:-1], at[1:])
    ok = np.isfinite(landed)
    idx = np.flatnonzero(ok)
    idx = idx[np.argsort(landed[idx])]
    d = apos[idx, :2] - apos[idx + 1, :2]
    ang = np.arctan2(d[:, 1], d[:, 0])
    turn = np.angle(np.exp(1j * np.diff(ang)))
    late_seg = landed[idx][1:] >= 0.55

    def coil(sel):
        return abs(float(np.sum(turn[sel]))) / (2 * math.pi) * 10.0 / max(1, int(np.sum(sel)))

    dev = z - (1.0 - tau**2)
    off = np.flatnonzero(np.abs(dev) > THRESH)
    off5 = np.flatnonzero(np.abs(dev) > 0.05)
    late = lt > 0.1
    win = (ft >= 0.5) & (ft <= t_fall / t_ff)
    p = pull[win]
    p = p[np.isfinite(p)]
    return {
        "departure": float(tau[off[0]]) if off.size else math.nan,
        "departure5": float(tau[off5[0]]) if off5.size else math.nan,
        "lag06": float(np.interp(0.6, tau, dev)),
        "lock_z95": float(np.quantile(lz[late], 0.95)) if np.any(late) else math.nan,
        "lock_below_0.1": float(np.mean(lz[late] < 0.1)) if np.any(late) else math.nan,
        "pull_down": float(np.mean(p < 0.0)) if p.size else math.nan,
        "pull_mean": float(np.mean(p)) if p.size else math.nan,  # run's force unit: m g
        "depth": max_depth / (2 * n * b),
        "depth_fall": depth_fall,
        "coil_before": coil(~late_seg),
        "coil_after": coil(late_seg),
    }


def _measure_runs(df: pd.DataFrame, runs: str) -> list[dict]:
    """The measures of every run of ``df`` whose file is in ``runs``, one dict per run."""
    rows = []
    for _, r in df.iterrows():
        path = os.path.join(runs, r["run_id"] + ".h5")
        if os.path.exists(path):
            rows.append(
                {
                    "run_id": r["run_id"],
                    "segments": r["segments"],
                    "alpha_deg": round(r["alpha_deg"], 6),
                    "floor": r["floor"],
                    "rtol": r["rtol"],
                    "method": r.get("method") if isinstance(r.get("method"), str) else "event",
                    "dt": r.get("dt", math.nan),
                    "theta": r.get("theta", math.nan),
                    "run_index": r["run_index"],
                    "engine": r.get("engine", "unknown"),
                    "ratio": r["ratio"],
                    **measures(path),
                }
            )
    return rows


def _step(r) -> str:
    """A run's method and its tolerance (event-driven) or step (time-stepping, t_ff/N)."""
    if r.get("method", "event") == "timestep":
        theta = r.get("theta", math.nan)  # NaN: a table from before the option (1/2)
        return f"timestep dt {r['dt']:g}" + (f", theta {theta:g}" if not math.isnan(theta) and theta != 0.5 else "")
    return f"event rtol {r['rtol']:g}"


def _scatter(df: pd.DataFrame) -> list[dict]:
    """Per (N, alpha, floor): the sd of t_fall/t_ff of one start across rtol (pooled over
    the starts run at every rtol of the point) and the sd across starts at each rtol."""
    out = []
    for (n, a, fl), g in df.groupby(["segments", "alpha_deg", "floor"]):
        rtols = sorted(g["rtol"].unique())
        if len(rtols) < 2:
            continue
        p = g.pivot_table(index="run_index", columns="rtol", values="ratio", aggfunc="first").dropna()
        if len(p) < 2:
            continue
        pooled = float(np.sqrt(np.mean(p.var(axis=1, ddof=1))))
        out.append(
            {
                "segments": int(n),
                "alpha_deg": round(float(a), 6),
                "floor": fl,
                "starts": int(len(p)),
                "rtols": [float(r) for r in rtols],
                "sd_rtol": pooled,
                "sd_starts": [
                    (float(r), float(g[g["rtol"] == r]["ratio"].std(ddof=1)), int((g["rtol"] == r).sum()))
                    for r in rtols
                ],
            }
        )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table")
    ap.add_argument("runs", nargs="?", help="the directory of the saved runs (or give --measures)")
    ap.add_argument("--measures", help="read the per-run measures from this table instead of the runs")
    ap.add_argument("--measures-out", help="write the per-run measures to this Parquet table")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--paired", action="store_true", help="also the same starts on both floors")
    ap.add_argument("--scatter", action="store_true", help="also the scatter of one start across rtol")
    args = ap.parse_args()
    if (args.runs is None) == (args.measures is None):
        sys.exit("give either RUNS_DIR or --measures M.parquet")
    df = pd.read_parquet(args.table)
    df = df[df["status"] == "landed"]
    if args.measures:
        m = pd.read_parquet(args.measures)
        m = m[m["run_id"].isin(df["run_id"])]
    else:
        m = pd.DataFrame(_measure_runs(df, args.runs))
    if m.empty:
        sys.exit("no measures of the table's runs found")
    if args.measures_out:
        m.to_parquet(args.measures_out, index=False)
    cols = [
        "ratio",
        "departure",
        "departure5",
        "lag06",
        "lock_z95",
        "lock_below_0.1",
        "pull_down",
        "pull_mean",
        "depth",
        "depth_fall",
        "coil_before",
        "coil_after",
    ]
    out = []
    m = m.assign(step=[_step(r) for _, r in m.iterrows()])
    for key, g in m.groupby(["segments", "alpha_deg", "floor", "step"]):
        out.append(
            {
                "segments": int(key[0]),
                "alpha_deg": key[1],
                "floor": key[2],
                "step": key[3],
                "rtol": float(g["rtol"].iloc[0]),
                "runs": int(len(g)),
                **{c: {"mean": float(g[c].mean()), "min": float(g[c].min()), "max": float(g[c].max())} for c in cols},
            }
        )
    paired = []
    if args.paired:
        for (n, a), g in df.groupby(["segments", "alpha_deg"]):
            p = g.pivot_table(index="run_index", columns="floor", values="ratio", aggfunc="first")
            if {"all", "pivot"} <= set(p.columns):
                dlt = (p["pivot"] - p["all"]).dropna()
                if len(dlt) > 1:
                    paired.append(
                        {
                            "segments": int(n),
                            "alpha_deg": round(float(a), 6),
                            "pairs": int(len(dlt)),
                            "mean_diff": float(dlt.mean()),
                            "se": float(dlt.std(ddof=1) / math.sqrt(len(dlt))),
                        }
                    )
    scatter = _scatter(df) if args.scatter else []
    if args.json:
        print(json.dumps({"groups": out, "paired": paired, "scatter": scatter}))
        return
    print("| N | alpha | floor | method, rtol or dt | runs | " + " | ".join(cols) + " |")
    print("|---|---|---|---|---|" + "---|" * len(cols))
    for o in out:
        cells = [f"{o[c]['mean']:.3g} ({o[c]['min']:.3g}..{o[c]['max']:.3g})" for c in cols]
        head = f"| {o['segments']} | {o['alpha_deg']:g} | {o['floor']} | {o['step']} | {o['runs']} | "
        print(head + " | ".join(cells) + " |")
    if scatter:
        print("\n| N | alpha | floor | starts at every rtol | rtols | sd across rtol (one start) | sd across starts |")
        print("|---|---|---|---|---|---|---|")
        for c in scatter:
            across = ", ".join(f"{k:g}: {v:.3f} ({n})" for k, v, n in c["sd_starts"])
            print(
                f"| {c['segments']} | {c['alpha_deg']:g} | {c['floor']} | {c['starts']} | "
                f"{', '.join(f'{r:g}' for r in c['rtols'])} | {c['sd_rtol']:.3f} | {across} |"
            )
    if paired:
        print("\n| N | alpha | pairs | t_fall/t_ff, pivot - all (mean +- s.e.) |\n|---|---|---|---|")
        for p in paired:
            print(f"| {p['segments']} | {p['alpha_deg']:g} | {p['pairs']} | {p['mean_diff']:+.4f} +- {p['se']:.4f} |")


if __name__ == "__main__":
    main()
