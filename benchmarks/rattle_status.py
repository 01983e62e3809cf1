"""Where the nonsmooth RATTLE method (``--method rattle``, experimental) stands: its order
where the motion is smooth, a fall with no limits, a fall with limits, and the spinning top.

    python benchmarks/rattle_status.py

Prints Markdown tables (the numbers of ``docs/rattle.md``):

1. the axes of an 8-segment chain with no limits (alpha = pi, helix eps 0.2) at 0.25 t_ff,
   before its first landing, against the exact method at rtol 1e-12, for dt = 0.4 .. 0.025
   (units of t_ff / N): the error, its ratio per halving (second order: 4), the books;
2. whole falls at N = 8 (helix, eps 0.02) with and without limits at dt 0.05: status, books,
   the deepest point, t_fall against the exact method's;
3. the top of ``tests/data/top3-state.txt`` run to 1 t_ff: its kinetic energy at the end over
   its start (1 for the exact top), the locks and unlocks, the books.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from machine import machine_info

from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions

TOP3 = Path(__file__).parent.parent / "tests" / "data" / "top3-state.txt"


def convergence() -> None:
    params, ic = ChainParams(segments=8, alpha=math.pi), InitialCondition(eps=0.2)
    ref = simulate(params, ic, SolverOptions(until=0.3, rtol=1e-12, frames_per_tff=4))
    print("| dt (t_ff/N) | max error of the axes at 0.25 t_ff | ratio | imbalance / E0 at 0.3 t_ff |")
    print("|---|---|---|---|")
    prev = None
    for dt in (0.4, 0.2, 0.1, 0.05, 0.025):
        r = simulate(params, ic, SolverOptions(method="rattle", dt=dt, until=0.3, frames_per_tff=4, step_energy_tol=0))
        err = float(np.abs(r.frame_e[1] - ref.frame_e[1]).max())
        ratio = f"{prev / err:.2f}" if prev else ""
        print(f"| {dt:g} | {err:.3g} | {ratio} | {r.energy['imbalance'] / r.energy['initial']:+.2e} |")
        prev = err


def falls() -> None:
    print("\n| alpha | method | status | t_fall / t_ff | imbalance / E0 | E_lock / E0 | deepest point (b) |")
    print("|---|---|---|---|---|---|---|")
    for alpha, name in ((math.pi, "pi"), (math.pi / 4, "pi/4")):
        for method, kw in (("event", {}), ("rattle", {"dt": 0.05})):
            r = simulate(ChainParams(segments=8, alpha=alpha), options=SolverOptions(method=method, **kw))
            e = r.energy
            print(
                f"| {name} | {method} | {r.status} | {r.t_fall / r.t_ff:.4f} | {e['imbalance'] / e['initial']:+.2e} "
                f"| {e['lost_locking'] / e['initial']:.4f} | {r.max_depth:.1e} |"
            )


def top() -> None:
    s = np.loadtxt(TOP3)
    print("\n| method | dt | status | T end / T start | locks, unlocks | imbalance / E0 |")
    print("|---|---|---|---|---|---|")
    for method, dt in (("event", None), ("rattle", 0.05), ("rattle", 0.0125)):
        kw = {"dt": dt} if dt else {}
        r = simulate(
            ChainParams(segments=3, alpha=math.pi / 4),
            state=(s[:, :3], s[:, 3:]),
            options=SolverOptions(method=method, max_time=1.0, **kw),
        )
        c = r.event_counts()
        ratio = r.energy["kinetic"] / r.frame_kinetic[0]
        print(
            f"| {method} | {dt or ''} | {r.status} | {ratio:.6f} | {c['lock']}, {c['unlock']} "
            f"| {r.energy['imbalance'] / r.energy['initial']:+.2e} |"
        )


if __name__ == "__main__":
    print(machine_info())
    convergence()
    falls()
    top()
