"""Where the nonsmooth RATTLE method (``--method rattle``, experimental) stands: its order
where the motion is smooth, a fall with no limits, a fall with limits, and the spinning top.

    python studies/rattle_status.py           # tables 1-3 and 5
    python studies/rattle_status.py --cost    # table 4

Prints Markdown tables (the numbers of ``docs/rattle.md``; tables 1-3 and 5 are items 1-3
and 6 of ``docs/notes/rattle-record.md``, table 4 its "Cost"):

1. the axes of an 8-segment chain with no limits (alpha = pi, helix eps 0.2) at 0.25 t_ff,
   before its first landing, against the exact method at rtol 1e-12, for dt = 0.4 .. 0.025
   (units of t_ff / N): the error, its ratio per halving (second order: 4), the books;
2. whole falls at N = 8 and 32 (helix, eps 0.02) with and without limits at the defaults:
   status, books, the deepest point, t_fall against the exact method's, RATTLE with its
   landing steps whole (``--landing-step whole``) and without its energy bound
   (``--step-energy-tol 0``) where there are limits (single falls with
   locks are chaotic: their t_fall and E_lock differ by the chaos, not by the method);
3. the top of ``tests/data/top3-state.txt`` run to 1 t_ff at the defaults: its kinetic
   energy at the end over its start, the locks and unlocks, E_lock, the books;
4. the cost of a step (``--cost``, alone; slow at large N): whole falls at N = 128, 256 and
   512 (random starts of seed 2026, the first two) -- steps per fall over N, block
   factorisations per step (refused steps' included), ns per segment and step -- and the
   first 2000 steps of a fall at N = 256 .. 4096: ns per segment and step (flat in N: the
   step is O(N)) and factorisations per step;
5. the floor "pivot": the first landing of an 8-segment chain with no limits (helix eps
   0.02) against the exact method's at rtol 1e-12 for dt = 0.1 .. 0.0125 (the step control
   off): the error and its ratio per halving; whole falls at N = 16 with and without limits
   at the defaults, beside the exact method's; a rod (N = 1, released at rest at 0.1 rad)
   against its closed-form fall time (``theory.rod_fall_time``).
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))  # machine.py, shared with the speed benchmarks
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


FALL_VARIANTS = (  # (method, options, label) of table 2's rows
    ("event", {}, ""),
    ("rattle", {}, ""),
    ("rattle", {"landing_step": "whole"}, ", landing steps whole"),
    ("rattle", {"step_energy_tol": 0.0}, ", no energy bound"),
)


def falls() -> None:
    print(
        "\n| N | alpha | method | status | t_fall / t_ff | imbalance / E0 | E_lock / E0 | deepest point (b) | steps |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for n, alpha, name in ((8, math.pi, "pi"), (8, math.pi / 4, "pi/4"), (32, math.pi / 4, "pi/4")):
        for method, options, label in FALL_VARIANTS:
            if "step_energy_tol" in options and alpha == math.pi:
                continue
            opts = SolverOptions(method=method, **options)
            r = simulate(ChainParams(segments=n, alpha=alpha), options=opts)
            e = r.energy
            print(
                f"| {n} | {name} | {method}{label} | {r.status} | {r.t_fall / r.t_ff:.4f} | {e['imbalance'] / e['initial']:+.2e} "
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


def _kind_times(r, kind: str) -> np.ndarray:
    from ballchain.core.kinds import EVENT_CODES

    return np.asarray(r.event_t)[np.asarray(r.event_kind) == EVENT_CODES[kind]]


def pivot() -> None:
    from ballchain.theory import rod_fall_time

    params = ChainParams(segments=8, alpha=math.pi, floor="pivot")
    ref = simulate(params, options=SolverOptions(rtol=1e-12))
    first = _kind_times(ref, "landing")[0]
    print("\n| dt (t_ff/N) | first landing: error (t_ff) | ratio | imbalance / E0 at the end |")
    print("|---|---|---|---|")
    prev = None
    for dt in (0.1, 0.05, 0.025, 0.0125):
        r = simulate(params, options=SolverOptions(method="rattle", dt=dt, step_energy_tol=0))
        err = abs(_kind_times(r, "landing")[0] - first) / r.t_ff
        ratio = f"{prev / err:.2f}" if prev else ""
        print(f"| {dt:g} | {err:.3g} | {ratio} | {r.energy['imbalance'] / r.energy['initial']:+.2e} |")
        prev = err
    print("\n| N | alpha | method | status | t_fall / t_ff | imbalance / E0 | E_lock / E0 | steps |")
    print("|---|---|---|---|---|---|---|---|")
    for alpha, name in ((math.pi, "pi"), (math.pi / 4, "pi/4")):
        for method in ("event", "rattle"):
            r = simulate(ChainParams(segments=16, alpha=alpha, floor="pivot"), options=SolverOptions(method=method))
            e = r.energy
            print(
                f"| 16 | {name} | {method} | {r.status} | {r.t_fall / r.t_ff:.4f} | {e['imbalance'] / e['initial']:+.2e} "
                f"| {e['lost_locking'] / e['initial']:.4f} | {r.n_steps} |"
            )
    theta0 = 0.1
    e0 = np.array([[math.sin(theta0), 0.0, math.cos(theta0)]])
    r = simulate(
        ChainParams(segments=1, floor="pivot"), options=SolverOptions(method="rattle"), state=(e0, np.zeros((1, 3)))
    )
    exact = rod_fall_time(theta0)
    print(
        f"\nA rod on its pivot (N = 1, from rest at {theta0} rad): t_fall {r.t_fall:.6f} sqrt(b/g) "
        f"against the closed form's {exact:.6f} (relative error {(r.t_fall - exact) / exact:+.1e})."
    )


def _timed(n: int, key: int, **options):
    start = InitialCondition(kind="random", seed=2026, spawn_key=(key,))
    t0 = time.perf_counter()
    r = simulate(ChainParams(segments=n, alpha=math.pi / 4), start, SolverOptions(method="rattle", **options))
    return r, time.perf_counter() - t0


def cost() -> None:
    simulate(ChainParams(segments=8, alpha=math.pi / 4), options=SolverOptions(method="rattle"))  # compiled first
    print("\n| N | start | status | steps / N | factorisations / step | ns / segment / step | wall (s) |")
    print("|---|---|---|---|---|---|---|")
    for n in (128, 256, 512):
        for key in (0, 1):
            r, wall = _timed(n, key)
            print(
                f"| {n} | {key} | {r.status} | {r.n_steps / n:.1f} | {r.n_evals / r.n_steps:.2f} "
                f"| {wall / r.n_steps / n * 1e9:.0f} | {wall:.1f} |"
            )
    print("\n| N | steps | factorisations / step | ns / segment / step (median of 3) |")
    print("|---|---|---|---|")
    for n in (256, 1024, 4096):
        runs = [_timed(n, 0, max_steps=2000, frames_per_tff=1) for _ in range(3)]
        r = runs[0][0]
        per = statistics.median(w / x.n_steps / n * 1e9 for x, w in runs)
        print(f"| {n} | {r.n_steps} | {r.n_evals / r.n_steps:.2f} | {per:.0f} |")


if __name__ == "__main__":
    print(machine_info())
    if "--cost" in sys.argv[1:]:
        cost()
    else:
        convergence()
        falls()
        top()
        pivot()
