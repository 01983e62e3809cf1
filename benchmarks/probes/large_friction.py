"""Does a large finite friction approach the anchor?  Paired falls at MU = inf and at large
finite MU (RATTLE, the only method that takes a finite MU).

    python benchmarks/probes/large_friction.py --segments 64 --starts 16 --mu 1e3,1e6
    python benchmarks/probes/large_friction.py --segments 128 --mu 0.2 --dt 0.025 --landing-step whole

Random starts of seeds 1..starts, alpha = pi/4, floor all, time cap 4 t_ff.  For each MU:
how many falls landed (the others reached the cap or stopped with an error, each named),
the mean t_fall/t_ff and E_lock/E0, the paired difference from the anchor's (MU = inf) with a
bootstrap 95% interval over the starts, and the median counts of lift-offs, slips and
sticks a fall.  The anchor holds a point that touched the floor for good, pulling it down
when the chain above pulls it up; a finite MU cannot pull: where the anchor would, the
point lifts off (``lift``).  Machine first.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parents[1]))  # benchmarks/: machine.py
from machine import machine_info  # noqa: E402

import ballchain as bc  # noqa: E402


def fall(n: int, seed: int, mu: float, **options) -> dict:
    r = bc.simulate(
        segments=n,
        alpha=math.pi / 4,
        floor="all",
        ic="random",
        seed=seed,
        method="rattle",
        friction=mu,
        max_time=4.0,
        **options,
    )
    counts, e0 = r.event_counts(), r.energy["initial"]
    return dict(
        status=r.status,
        tfall=r.t_fall / r.t_ff,
        elock=r.energy["lost_locking"] / e0,
        lift=counts.get("lift", 0),
        slip=counts.get("slip", 0),
        stick=counts.get("stick", 0),
    )


def interval(x: np.ndarray, reps: int = 4000) -> tuple[float, float]:
    rng = np.random.default_rng(0)
    means = [rng.choice(x, len(x)).mean() for _ in range(reps)]
    return tuple(np.percentile(means, [2.5, 97.5]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=64)
    ap.add_argument("--starts", type=int, default=16)
    ap.add_argument("--mu", default="1e3,1e6", help="the finite coefficients, comma-separated")
    ap.add_argument("--dt", type=float, help="RATTLE's --dt (default: its own)")
    ap.add_argument("--landing-step", choices=("whole", "cut"), help="RATTLE's --landing-step (default: its own)")
    args = ap.parse_args()
    options = {k: v for k, v in (("dt", args.dt), ("landing_step", args.landing_step)) if v is not None}
    print(machine_info())
    seeds = range(1, args.starts + 1)
    anchor = {s: fall(args.segments, s, math.inf, **options) for s in seeds}
    said = ", ".join(f"{k} {v}" for k, v in options.items()) or "its defaults"
    print(f"\nN = {args.segments}, {args.starts} starts, alpha = pi/4, floor all, RATTLE at {said}\n")
    print(
        "| MU | landed | t_fall/t_ff | paired difference [95%] | E_lock/E0 | paired difference [95%] | lifts | slips | sticks |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    a_t = np.array([anchor[s]["tfall"] for s in seeds])
    a_e = np.array([anchor[s]["elock"] for s in seeds])
    landed = sum(anchor[s]["status"] == "landed" for s in seeds)
    print(f"| inf | {landed} | {a_t.mean():.3f} | | {a_e.mean():.3f} | | 0 | 0 | 0 |")
    for mu in (float(m) for m in args.mu.split(",")):
        runs = {s: fall(args.segments, s, mu, **options) for s in seeds}
        ok = [s for s in seeds if math.isfinite(runs[s]["tfall"])]
        dt = np.array([runs[s]["tfall"] - anchor[s]["tfall"] for s in ok])
        de = np.array([runs[s]["elock"] - anchor[s]["elock"] for s in ok])
        lo, hi = interval(dt)
        elo, ehi = interval(de)
        med = {k: int(np.median([runs[s][k] for s in seeds])) for k in ("lift", "slip", "stick")}
        landed = sum(runs[s]["status"] == "landed" for s in seeds)
        print(
            f"| {mu:g} | {landed} | {np.mean([runs[s]['tfall'] for s in ok]):.3f} | {dt.mean():+.3f} [{lo:+.3f}, {hi:+.3f}] "
            f"| {np.mean([runs[s]['elock'] for s in ok]):.3f} | {de.mean():+.3f} [{elo:+.3f}, {ehi:+.3f}] "
            f"| {med['lift']} | {med['slip']} | {med['stick']} |"
        )
        others = [f"seed {s}: {runs[s]['status']}" for s in seeds if runs[s]["status"] != "landed"]
        if others:
            print(f"|   | not landed: {', '.join(others)} | | | | | | | |")


if __name__ == "__main__":
    main()
