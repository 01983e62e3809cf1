"""Where along the chain the locks dissipate, method against method: the energy lost at
the hinges, binned by the hinge's distance (in points) above the pile's top at the lock's
time, summed over each fall and averaged over the starts.

    python benchmarks/probes/lock_distance.py --segments 1024 --starts 0-7
    python benchmarks/probes/lock_distance.py --segments 512 --starts 0-5 --methods event,rattle,rattle:dt=0.025

The pile's top at time t is the highest point (lowest index) anchored before t; a lock at
hinge k (at point k + 1) is top - (k + 1) points above it: 0 is the hinge at the top
itself, 1 the one at the point above it (the last airborne segment's upper end).  Every method on the same random starts
(seed 2026, spawn keys ``--starts``), alpha = pi/4, floor all, at its defaults unless
given options (``method:option=value``, SolverOptions' names).  Prints the machine, a
table of E_lock/E0 per distance bin (means over the starts) and, for every method after
the first, its paired difference from the first (mean and standard error over the starts:
single falls are chaotic, so only the mean over starts says something).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1]))  # benchmarks/: machine.py, compare_revisions.py
from machine import machine_info  # noqa: E402

from ballchain.core.kinds import EVENT_CODES  # noqa: E402
from ballchain.engine import simulate  # noqa: E402
from ballchain.model import ChainParams, InitialCondition, SolverOptions  # noqa: E402

BINS = (0, 1, 2, 3, 4, 5, 6, 8, 10, 13, 17, 25, 50, 100)


def _keys(spec: str) -> list[int]:
    if "-" in spec:
        a, b = spec.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in spec.split(",")]


def _options(spec: str) -> dict:
    method, *rest = spec.split(":")
    out = {} if method == "event" else {"method": method}
    for kv in rest:
        k, v = kv.split("=", 1)
        out[k] = float(v)
    return out


def lock_energy_by_distance(r) -> np.ndarray:
    """E_lock/E0 of one fall, per bin of BINS (the last open): the lock and impulse rows of
    its event log, each at its hinge's distance above the pile's top at its time."""
    codes = (EVENT_CODES["lock"], EVENT_CODES["impulse"])
    landed_at = np.where(np.isnan(r.anchor_t), np.inf, r.anchor_t)
    out = np.zeros(len(BINS))
    for kind, k, t, energy in zip(r.event_kind, r.event_index, r.event_t, r.event_energy):
        if kind not in codes:
            continue
        below = np.nonzero(landed_at < t - 1e-12 * max(t, 1.0))[0]
        top = below.min() if len(below) else len(landed_at)
        b = np.searchsorted(BINS, top - (k + 1), side="right") - 1
        out[max(b, 0)] += energy / r.energy["initial"]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=1024)
    ap.add_argument("--starts", default="0-7", help="spawn keys: 0-7 or 1,4,9")
    ap.add_argument("--methods", default="event,rattle", help="the first is the reference")
    a = ap.parse_args()
    print(machine_info())
    methods, keys = a.methods.split(","), _keys(a.starts)
    params = ChainParams(segments=a.segments, alpha=math.pi / 4)
    bins, totals = {m: [] for m in methods}, {m: [] for m in methods}
    for key in keys:
        start = InitialCondition(kind="random", seed=2026, spawn_key=(key,))
        for m in methods:
            r = simulate(params, start, SolverOptions(frames_per_tff=1, **_options(m)))
            if r.status != "landed":
                raise SystemExit(f"{m}, start {key}: {r.status} ({r.message})")
            bins[m].append(lock_energy_by_distance(r))
            totals[m].append(r.energy["lost_locking"] / r.energy["initial"])
            print(f"  start {key} {m}: t_fall/t_ff {r.t_fall / r.t_ff:.4f}, E_lock/E0 {totals[m][-1]:.4f}", flush=True)
    ref = methods[0]
    head = " | ".join(methods) + "".join(f" | {m} - {ref}" for m in methods[1:])
    print(f"\nN = {a.segments}, {len(keys)} starts: E_lock/E0 by the hinge's distance above the pile's top\n")
    print(f"| distance | {head} |")
    print("|---" * (1 + 2 * len(methods) - 1) + "|")
    labels = [f"{lo}" if hi - lo == 1 else f"{lo}-{hi - 1}" for lo, hi in zip(BINS[:-1], BINS[1:])] + [f"{BINS[-1]}+"]

    for i, label in enumerate(labels):
        diffs = ""
        for m in methods[1:]:
            d = np.array(bins[m])[:, i] - np.array(bins[ref])[:, i]
            diffs += f" | {d.mean():+.4f} +- {d.std(ddof=1) / math.sqrt(len(d)):.4f}"
        means = " | ".join(f"{np.mean(np.array(bins[m])[:, i]):.4f}" for m in methods)
        print(f"| {label} | {means}{diffs} |")
    diffs = ""
    for m in methods[1:]:
        d = np.array(totals[m]) - np.array(totals[ref])
        diffs += f" | {d.mean():+.4f} +- {d.std(ddof=1) / math.sqrt(len(d)):.4f}"
    print(f"| all | {' | '.join(f'{np.mean(totals[m]):.4f}' for m in methods)}{diffs} |")


if __name__ == "__main__":
    main()
