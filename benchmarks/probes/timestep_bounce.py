"""Does the time-stepper hold restitution at the floor on whole falls?  Its kernels take the
law (``methods.timestep.stepper``: ``_aim_rebounds``, ``_leave_floor``, ``_let_go``,
``_hold_sinking``) but its registry refuses it (``methods.timestep.CONTACT_REFUSALS``);
this probe lets it through, as the rod's test does, and runs an ensemble.

    python benchmarks/probes/timestep_bounce.py --segments 64 --starts 32
    python benchmarks/probes/timestep_bounce.py --segments 128 --starts 16

Random starts of seed 2026, spawn keys 0..starts-1 (the sweeps' starts), alpha = pi/4,
floor all, the default step.  For each E in --restitution (default 0.3, 0.6, 0.9): how
many falls landed, reached the cap (3 t_ff) or ended in error (each error named), the
deepest point of any fall and the median of the falls' deepest, and the median and worst
|imbalance|/E0.  Machine first.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parents[1]))  # benchmarks/: machine.py
from machine import machine_info  # noqa: E402

import ballchain.methods.timestep as ts  # noqa: E402
from ballchain.engine import simulate  # noqa: E402
from ballchain.model import ChainParams, InitialCondition, SolverOptions  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=64)
    ap.add_argument("--starts", type=int, default=32)
    ap.add_argument("--restitution", default="0.3,0.6,0.9")
    a = ap.parse_args()
    print(machine_info())
    ts.CONTACTS = (*ts.CONTACTS, "restitution_floor")  # (the probe's only change: the law let through)
    for e_floor in (float(x) for x in a.restitution.split(",")):
        status, depth, imb = [], [], []
        for k in range(a.starts):
            r = simulate(
                ChainParams(segments=a.segments, alpha=math.pi / 4, restitution_floor=e_floor),
                InitialCondition(kind="random", seed=2026, spawn_key=(k,)),
                SolverOptions(method="timestep"),
            )
            status.append(r.status)
            depth.append(r.max_depth)
            imb.append(abs(r.energy["imbalance"]) / r.energy["initial"])
            if r.status not in ("landed", "max_time"):
                print(f"  start {k}: {r.status}: {r.message[:200]}")
        counts = ", ".join(f"{status.count(s)} {s}" for s in sorted(set(status)))
        print(
            f"N = {a.segments}, E = {e_floor:g}: {counts} of {a.starts}; deepest point {max(depth):.1e} b "
            f"(median of the falls' {np.median(depth):.1e}); |imbalance|/E0 median {np.median(imb):.3f}, "
            f"worst {max(imb):.3f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
