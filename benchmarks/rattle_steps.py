"""Where a RATTLE fall's steps go: how long they are, through the fall, with and without
the energy bound.

    python benchmarks/rattle_steps.py --segments 256,1024 --starts 0 --etol default,0

For each N, random start (seed 2026, spawn key k, alpha = pi/4, floor ``all``) and bound
(``default``: the method's ``--step-energy-tol``; ``0``: no bound, the steps shortened only
by the turn limit and by stages that fail): the steps a fall takes per segment, the share
of its steps at the longest size (``--dt`` t_ff/N) and the share of its time they cover,
and the mean step over the longest in each tenth of t_ff.  The step sizes are the
differences of the result's trace times (one per accepted step).  Machine and versions
first.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from machine import machine_info  # noqa: E402

from ballchain.engine import simulate  # noqa: E402
from ballchain.model import ChainParams, InitialCondition, SolverOptions  # noqa: E402


def steps_of(n: int, key: int, etol: float | None) -> dict:
    """One fall's step sizes, summarised."""
    options = SolverOptions(method="rattle", step_energy_tol=etol)
    r = simulate(
        ChainParams(segments=n, alpha=np.pi / 4), InitialCondition(kind="random", seed=2026, spawn_key=(key,)), options
    )
    h = np.diff(r.t)
    h_max = options.for_segments(n).dt * r.t_ff / n
    q = h / h_max
    tt = r.t[1:] / r.t_ff
    by_tenth = [float(q[(tt >= a / 10) & (tt < (a + 1) / 10)].mean()) for a in range(10)]
    full = q >= 0.999
    return dict(
        status=r.status,
        ratio=r.t_fall / r.t_ff,
        steps_per_n=h.size / n,
        full_steps=float(full.mean()),
        full_time=float(h[full].sum() / h.sum()),
        by_tenth=by_tenth,
        imbalance=r.energy["imbalance"] / r.energy["initial"],
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", default="256")
    ap.add_argument("--starts", default="0", help="spawn keys: 0 or 0,1")
    ap.add_argument("--etol", default="default,0", help="bounds: default (the method's) and/or numbers (E0)")
    a = ap.parse_args()
    print(machine_info())
    print(
        "\n| N | start | bound | status | t_fall/t_ff | steps / N | steps at the longest | their time | imbalance / E0 | "
        + " | ".join(f"h/h_max at {k / 10:.1f}" for k in range(10))
        + " |"
    )
    print("|" + "---|" * 19)
    for n in (int(s) for s in a.segments.split(",")):
        for key in (int(s) for s in a.starts.split(",")):
            for e in a.etol.split(","):
                s = steps_of(n, key, None if e == "default" else float(e))
                tenths = " | ".join(f"{v:.2f}" for v in s["by_tenth"])
                print(
                    f"| {n} | {key} | {e} | {s['status']} | {s['ratio']:.4f} | {s['steps_per_n']:.1f} | "
                    f"{s['full_steps']:.2f} | {s['full_time']:.2f} | {s['imbalance']:+.1e} | {tenths} |"
                )


if __name__ == "__main__":
    main()
