"""Where the nonsmooth RATTLE method (``--method rattle``, experimental) stands: its order
where the motion is smooth, a fall with no limits, a fall with limits, and the spinning top.

    python benchmarks/rattle_status.py

Prints Markdown tables (the numbers of ``docs/rattle.md``):

1. the axes of an 8-segment chain with no limits (alpha = pi, helix eps 0.2) at 0.25 t_ff,
   before its first landing, against the exact method at rtol 1e-12, for dt = 0.4 .. 0.025
   (units of t_ff / N): the error, its ratio per halving (second order: 4), the books;
2. whole falls at N = 8 and 32 (helix, eps 0.02) with and without limits at the defaults:
   status, books, the deepest point, t_fall against the exact method's, and RATTLE without
   its energy bound (``--step-energy-tol 0``) where there are limits (single falls with
   locks are chaotic: their t_fall and E_lock differ by the chaos, not by the method);
3. the top of ``tests/data/top3-state.txt`` run to 1 t_ff at the defaults: its kinetic
   energy at the end over its start, the locks and unlocks, E_lock, the books.
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
    print(
        "\n| N | alpha | method | status | t_fall / t_ff | imbalance / E0 | E_lock / E0 | deepest point (b) | steps |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for n, alpha, name in ((8, math.pi, "pi"), (8, math.pi / 4, "pi/4"), (32, math.pi / 4, "pi/4")):
        for method, etol in (("event", None), ("rattle", None), ("rattle", 0.0)):
            if etol is not None and alpha == math.pi:
                continue
            opts = SolverOptions(method=method, step_energy_tol=etol)
            r = simulate(ChainParams(segments=n, alpha=alpha), options=opts)
            e = r.energy
            print(
                f"| {n} | {name} | {method}{', no energy bound' if etol == 0.0 else ''} | {r.status} | {r.t_fall / r.t_ff:.4f} | {e['imbalance'] / e['initial']:+.2e} "
                f"| {e['lost_locking'] / e['initial']:.4f} | {r.max_depth:.1e} | {r.n_steps} |"
            )


def top() -> None:
    s = np.loadtxt(TOP3)
    print("\n| method | status | T end / T start | locks, unlocks | E_lock / E0 | imbalance / E0 | steps |")
    print("|---|---|---|---|---|---|---|")
    for method in ("event", "rattle"):
        r = simulate(
            ChainParams(segments=3, alpha=math.pi / 4),
            state=(s[:, :3], s[:, 3:]),
            options=SolverOptions(method=method, max_time=1.0),
        )
        c = r.event_counts()
        ratio = r.energy["kinetic"] / r.frame_kinetic[0]
        e = r.energy
        print(
            f"| {method} | {r.status} | {ratio:.6f} | {c['lock']}, {c['unlock']} | {e['lost_locking'] / e['initial']:.2e} "
            f"| {e['imbalance'] / e['initial']:+.2e} | {r.n_steps} |"
        )


if __name__ == "__main__":
    print(machine_info())
    convergence()
    falls()
    top()
