"""Whole falls by both methods against N, side by side in one process: the speed table
of docs/timestep.md.

    python benchmarks/timestep_speed.py                                   # N = 64 .. 2048
    python benchmarks/timestep_speed.py --segments 64,256,1024,4096 --event-max 512 --dt 0.02
    python benchmarks/timestep_speed.py --segments 512,1024 --event-max 1024 --dt 0.02 --theta 1
    python benchmarks/timestep_speed.py --segments 1024 --event-max 1024 --dt 0.02 --theta 1 --dt-rule landing,fixed

One random start per N (seed 1, spawn key 0), alpha = pi/4, floor all, two frames per t_ff
(frames do not change either fall).  ``--dt-rule``: the time-stepper's step rules
(``SolverOptions.dt_rule``), comma-separated, each timed on the same start.  Per run: wall seconds (the median of --reps), the
time-stepper's steps and its cost per step and per step and segment, the event-driven
method's wall time where N <= --event-max, their ratio, and the peak memory the run
added (tracemalloc).  Machine and versions are printed first.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tracemalloc
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from machine import machine_info  # noqa: E402

from ballchain.engine import load_kernels, simulate  # noqa: E402
from ballchain.model import ChainParams, InitialCondition, SolverOptions  # noqa: E402


def _run(n: int, options: SolverOptions, reps: int):
    walls, peak, r = [], 0, None
    for _ in range(reps):
        tracemalloc.start()
        r = simulate(
            ChainParams(segments=n, alpha=math.pi / 4), InitialCondition(kind="random", seed=1, spawn_key=(0,)), options
        )
        peak = max(peak, tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        walls.append(r.wall_seconds)
    return statistics.median(walls), r, peak


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--segments", default="64,128,256,512,1024,2048")
    ap.add_argument("--event-max", type=int, default=512)
    ap.add_argument("--dt", type=float, default=None, help="the time-stepper's step (default: by N, as simulate)")
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument(
        "--theta", type=float, default=None, help="the time-stepper's position update (default: by N, as simulate)"
    )
    ap.add_argument("--dt-rule", default=SolverOptions.dt_rule, help="the time-stepper's step rules, comma-separated")
    a = ap.parse_args()
    print(machine_info())
    load_kernels("event")
    load_kernels("timestep")
    print(
        "\n| N | step rule | timestep wall (s) | steps | us / step | ns / step / segment | t_fall/t_ff | status | "
        "event wall (s) | event t_fall/t_ff | event / timestep | peak memory (MB) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in (int(x) for x in a.segments.split(",")):
        ev_wall, rev = None, None
        if n <= a.event_max:
            ev_wall, rev, _ = _run(n, SolverOptions(frames_per_tff=2), a.reps)
        for rule in a.dt_rule.split(","):
            o = SolverOptions(method="timestep", dt=a.dt, frames_per_tff=2, theta=a.theta, dt_rule=rule)
            ts_wall, r, peak = _run(n, o, a.reps)
            us = 1e6 * ts_wall / max(r.n_steps, 1)
            ev = ("", "", "")
            if rev is not None:
                ev = (f"{ev_wall:.2f}", f"{rev.t_fall / rev.t_ff:.4f}", f"{ev_wall / ts_wall:.1f}")
            print(
                f"| {n} | {rule} | {ts_wall:.2f} | {r.n_steps} | {us:.1f} | {1e3 * us / n:.0f} | "
                f"{r.t_fall / r.t_ff:.4f} | {r.status} | {ev[0]} | {ev[1]} | {ev[2]} | {peak / 2**20:.0f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
