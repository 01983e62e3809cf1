"""The same well-conditioned falls with two revisions: do they agree to round-off?

    python benchmarks/probes/equivalence.py --base 889ef58            # this checkout against a base
    python benchmarks/probes/equivalence.py --base 889ef58 --tol 1e-9

A refactoring must not move the physics.  Chaotic falls cannot be compared run by run
(round-off puts them on other branches), so the cases are those that are well conditioned:
alpha = pi falls (no lock events), the first lock of pi/4 falls (up to and including the
first event instant), short runs before any event, both floor models.  Each revision runs
every case in its own process (``--base`` checked out as a temporary git worktree); the
table gives the largest relative difference per case and whether it is within ``--tol``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1]))  # benchmarks/: machine.py, compare_revisions.py
from compare_revisions import base_worktree  # noqa: E402
from machine import machine_info  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent

# (name, ChainParams kwargs, InitialCondition kwargs, SolverOptions kwargs, stop at first lock?)
CASES = [
    ("pi N=16 all", dict(segments=16, alpha=math.pi), dict(), dict(), False),
    ("pi N=64 all", dict(segments=64, alpha=math.pi), dict(), dict(), False),
    ("pi N=32 pivot", dict(segments=32, alpha=math.pi, floor="pivot"), dict(), dict(), False),
    ("pi N=24 random", dict(segments=24, alpha=math.pi), dict(kind="random", seed=3), dict(), False),
    ("pi/4 N=16 first lock", dict(segments=16, alpha=math.pi / 4), dict(), dict(), True),
    ("pi/4 N=64 first lock", dict(segments=64, alpha=math.pi / 4), dict(), dict(), True),
    ("pi/2 N=32 random first lock", dict(segments=32, alpha=math.pi / 2), dict(kind="random", seed=5), dict(), True),
    ("pi/4 N=32 pivot first lock", dict(segments=32, alpha=math.pi / 4, floor="pivot"), dict(), dict(), True),
    ("pi/3 N=8 short", dict(segments=8, alpha=math.pi / 3), dict(eps=0.1), dict(until=0.2), False),
    # chaotic (thousands of lock events): equal only where the arithmetic is unchanged; reported, not judged
    ("pi/4 N=128 whole fall (chaotic)", dict(segments=128, alpha=math.pi / 4), dict(), dict(), False),
]
CHAOTIC = "(chaotic)"

RUNNER = r"""
import json, sys
import numpy as np
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
out = {}
for name, p, ic, o, first in json.loads(sys.argv[1]):
    if first:
        r0 = simulate(ChainParams(**p), InitialCondition(**ic), SolverOptions(**o))
        t1 = float(r0.event_t[r0.event_kind == 1][0])
        r = simulate(ChainParams(**p), InitialCondition(**ic), SolverOptions(until=t1 / r0.t_ff * (1 + 1e-6)))
        vals = {"first_lock": t1, "e_end": r.frame_e[-1].ravel().tolist() if len(r.frame_e) else [],
                "kinetic_end": float(r.energy["kinetic"]), "lost_locking": float(r.energy["lost_locking"])}
    else:
        r = simulate(ChainParams(**p), InitialCondition(**ic), SolverOptions(**o))
        vals = {"t_fall": float(r.t_fall), "t_landed": float(r.t_landed) if r.t_landed == r.t_landed else None,
                "lost_landing": float(r.energy["lost_landing"]), "kinetic": float(r.energy["kinetic"]),
                "e_end": r.frame_e[-1].ravel().tolist(), "n_events": int(len(r.event_t)),
                "floor_impulse_total": [float(v) for v in r.floor_impulse_total]}
    out[name] = vals
print(json.dumps(out))
"""


def run_cases(src: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src))
    payload = json.dumps([[n, p, ic, o, f] for n, p, ic, o, f in CASES])
    res = subprocess.run([sys.executable, "-c", RUNNER, payload], env=env, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit(f"the cases failed with the sources in {src}:\n{res.stderr[-3000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def max_rel(a, b) -> float:
    """Largest difference between two values (or lists), relative to max(|a|, 1e-3)."""
    if a is None or b is None:
        return 0.0 if a is b else math.inf
    if isinstance(a, float) and (math.isnan(a) or math.isnan(b)):
        return 0.0 if math.isnan(a) and math.isnan(b) else math.inf
    if isinstance(a, list):
        if len(a) != len(b):
            return math.inf
        return max((max_rel(x, y) for x, y in zip(a, b)), default=0.0)
    return abs(a - b) / max(abs(a), 1e-3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="git revision to compare this checkout with")
    ap.add_argument("--base-src", help="an existing checkout of the base's src/ (its compiled kernels reused)")
    ap.add_argument("--tol", type=float, default=1e-9)
    args = ap.parse_args()
    print(machine_info())
    head = run_cases(ROOT / "src")
    if args.base_src:
        base = run_cases(Path(args.base_src))
    else:
        with base_worktree(args.base) as wt:
            base = run_cases(wt / "src")
    print(f"\n| case | quantity | base | head | max rel. difference | within {args.tol:g} |")
    print("|---|---|---|---|---|---|")
    worst = 0.0
    for name, *_ in CASES:
        for key in base[name]:
            d = max_rel(base[name][key], head[name][key])
            if CHAOTIC not in name:
                worst = max(worst, d)
            show = lambda v: f"{v:.12g}" if isinstance(v, float) else ("[...]" if isinstance(v, list) else str(v))
            print(
                f"| {name} | {key} | {show(base[name][key])} | {show(head[name][key])} | {d:.2e} | "
                f"{'yes' if d <= args.tol else ('NO' if CHAOTIC not in name else '(not judged)')} |"
            )
    print(f"\nlargest difference: {worst:.2e} ({'within' if worst <= args.tol else 'OUTSIDE'} {args.tol:g})")
    sys.exit(0 if worst <= args.tol else 1)


if __name__ == "__main__":
    main()
