"""A small ensemble of falls, one JSON summary per line (the numbers quoted in issues).

    python benchmarks/probes/ensemble.py --segments 128 --alpha pi/4 --seeds 0-4 --floors all,pivot --jobs 2

Runs the ``random`` initial-condition family (seeded) plus the helix, on ``--jobs``
processes, and prints per-run lines and per-floor mean +- standard error of t_fall/t_ff.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
from concurrent.futures import ProcessPoolExecutor


def one(args):
    n, alpha, floor, kind, seed, eps, rtol = args
    from ballchain.engine import simulate
    from ballchain.model import ChainParams, InitialCondition, SolverOptions, parse_angle

    r = simulate(
        ChainParams(segments=n, alpha=parse_angle(alpha), floor=floor),
        InitialCondition(kind=kind, seed=seed, eps=eps),
        SolverOptions(rtol=rtol),
    )
    s = r.summary()
    return {
        k: s[k]
        for k in (
            "segments",
            "alpha",
            "floor",
            "status",
            "ratio",
            "landed_ratio",
            "events",
            "max_depth",
            "wall_seconds",
        )
    } | {"ic": kind, "seed": seed, "imbalance_rel": r.energy["imbalance"] / r.energy["initial"]}


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--segments", type=int, default=128)
    ap.add_argument("--alpha", default="pi/4")
    ap.add_argument("--seeds", default="0-4")
    ap.add_argument("--floors", default="all,pivot")
    ap.add_argument("--eps", type=float, default=0.02)
    ap.add_argument("--rtol", type=float, default=1e-9)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    lo, _, hi = a.seeds.partition("-")
    seeds = list(range(int(lo), int(hi or lo) + 1))
    tasks = []
    for floor in a.floors.split(","):
        tasks.append((a.segments, a.alpha, floor, "helix", 0, a.eps, a.rtol))
        tasks += [(a.segments, a.alpha, floor, "random", s, a.eps, a.rtol) for s in seeds]
    with ProcessPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(one, tasks))
    for r in rows:
        print(json.dumps(r), flush=True)
    for floor in a.floors.split(","):
        x = [r["ratio"] for r in rows if r["floor"] == floor and r["ic"] == "random" and r["ratio"] is not None]
        y = [
            r["landed_ratio"]
            for r in rows
            if r["floor"] == floor and r["ic"] == "random" and r["landed_ratio"] is not None
        ]
        if len(x) > 1:
            print(
                f"floor={floor}: t_fall/t_ff = {statistics.mean(x):.4f} +- {statistics.stdev(x) / math.sqrt(len(x)):.4f}"
                f" (n={len(x)}), t_landed/t_ff = {statistics.mean(y):.4f} +- "
                f"{statistics.stdev(y) / math.sqrt(len(y)):.4f}"
            )


if __name__ == "__main__":
    main()
