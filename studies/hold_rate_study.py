"""Convergence study of the accumulation threshold ``SolverOptions.hold_rate``.

    python studies/hold_rate_study.py --output docs/hold_rate_study.md

A hinge released at an instant that accelerates back to its limit and would return
slower than ``hold_rate``, or after an excursion smaller than ``hold_apex``, is held
there (the limit of the converging series of impacts it would start).  The study runs
well-conditioned falls (short enough that the event sequence does not depend on
round-off) at several thresholds and tolerances and shows that the energy lost to
locking converges as the thresholds go to zero, and that they move it less than the
tolerance does.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))  # machine.py, shared with the speed benchmarks
from machine import machine_info  # noqa: E402  (benchmarks/machine.py)

CASES = [  # (N, alpha, until in t_ff, rtol)
    (8, math.pi / 4, 0.8, 1e-12),
    (16, math.pi / 4, 0.55, 1e-12),
    (32, math.pi / 3, 0.45, 1e-12),
]
HOLD = [
    (1e-4, 1e-11),
    (1e-5, 1e-11),
    (1e-6, 1e-11),
    (1e-7, 1e-11),
    (1e-8, 1e-11),
    (1e-6, 1e-9),
    (1e-6, 1e-10),
    (1e-8, 2e-12),
]  # (hold_rate, hold_apex), the last the finest


def run(n, alpha, until, rtol, hold, apex=1e-11):
    from ballchain.engine import simulate
    from ballchain.model import ChainParams, InitialCondition, SolverOptions

    return simulate(
        ChainParams(segments=n, alpha=alpha),
        InitialCondition(),
        SolverOptions(rtol=rtol, until=until, hold_rate=hold, hold_apex=apex),
    )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--output", help="write the Markdown table here too")
    a = ap.parse_args(argv)
    lines = [
        "# Accumulation threshold: convergence study",
        "",
        "Command: `python studies/hold_rate_study.py --output docs/hold_rate_study.md`",
        "",
        machine_info(),
        "",
        "Helix start (eps 0.02, q 1), floor `all`. `E_lock`: kinetic energy lost to hinge locking (m g b) "
        "up to `until`; `dE/E`: its relative difference to the run with the smallest threshold; "
        "`tol`: the same difference between rtol and rtol x 100 at the default threshold, for scale.",
        "",
        "| N | alpha | until (t_ff) | rtol | hold_rate, hold_apex | locks | holds | event instants | E_lock | dE/E |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for n, alpha, until, rtol in CASES:
        rows = [(h, run(n, alpha, until, rtol, *h)) for h in HOLD]
        ref = rows[-1][1].energy["lost_locking"]
        for h, r in rows:
            c = r.event_counts()
            el = r.energy["lost_locking"]
            lines.append(
                f"| {n} | {math.degrees(alpha):.0f} deg | {until} | {rtol:g} | {h[0]:g}, {h[1]:g} "
                f"| {c['lock']} | "
                f"{c['hold']} | {r.n_instants} | {el:.10f} | {abs(el - ref) / ref:.1e} |"
            )
        loose = run(n, alpha, until, rtol * 100, 1e-6).energy["lost_locking"]
        mid = [r for h, r in rows if h == (1e-6, 1e-11)][0].energy["lost_locking"]
        lines.append(
            f"| {n} | | | tol: {rtol * 100:g} vs {rtol:g} | 1e-06, 1e-11 | | | | {loose:.10f} | "
            f"{abs(loose - mid) / mid:.1e} |"
        )
        print("\n".join(lines[-len(HOLD) - 1 :]), flush=True)
    text = "\n".join(lines) + "\n"
    if a.output:
        with open(a.output, "w") as f:
            f.write(text)
    print(text)


if __name__ == "__main__":
    main()
