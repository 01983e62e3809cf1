"""Sweep throughput: runs per hour with 1 and 2 dask workers, and the sweep's overhead
against the same runs done one by one in one process.

    python benchmarks/sweep_throughput.py --segments 64 --runs 8
    python benchmarks/sweep_throughput.py --segments 128 --runs 8

The same K random starts (alpha = pi/4, floor all) three ways, measured side by side in
one invocation: (a) one by one with ``engine.simulate`` in this process (kernels loaded
first), (b) ``ballchain sweep --workers 1``, (c) ``--workers 2``.  Wall times include the
cluster's start and stop.  Prints the machine, the versions, and a Markdown table.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from machine import machine_info  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=64)
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--alpha", default="pi/4")
    ap.add_argument("--seed", type=int, default=11)
    args = ap.parse_args()

    from ballchain.engine import simulate
    from ballchain.sweeps import SweepSpec, parse_alphas
    from ballchain.sweeps.execute import run_sweep, warm_kernels

    print(machine_info(("numpy", "numba", "scipy", "dask", "distributed", "pyarrow", "ballchain")))
    warm_kernels()
    spec = SweepSpec(segments=(args.segments,), alphas=tuple(parse_alphas(args.alpha)), runs=args.runs, seed=args.seed)
    tasks = spec.tasks()
    t0 = time.perf_counter()
    single = [simulate(t.params, t.ic, t.options) for t in tasks]
    one_by_one = time.perf_counter() - t0
    rows = [("one by one, 1 process", one_by_one)]
    with tempfile.TemporaryDirectory() as tmp:
        for w in (1, 2):
            t0 = time.perf_counter()
            rep = run_sweep(spec, os.path.join(tmp, f"w{w}.parquet"), workers=w, progress=False)
            assert rep.ran == len(tasks) and rep.failed == 0
            rows.append((f"sweep, {w} worker{'s' if w > 1 else ''}", time.perf_counter() - t0))
    ratios = [r.ratio for r in single]
    print(
        f"N = {args.segments}, alpha = {args.alpha}, {len(tasks)} random starts (seed {args.seed}); "
        f"t_fall/t_ff mean {statistics.mean(ratios):.4f}; per-run wall: median "
        f"{statistics.median(r.wall_seconds for r in single):.2f} s"
    )
    print("\n| how | wall (s) | runs per hour | vs one by one |\n|---|---|---|---|")
    for name, wall in rows:
        print(f"| {name} | {wall:.1f} | {len(tasks) * 3600 / wall:.0f} | {wall / one_by_one:.2f}x |")


if __name__ == "__main__":
    main()
