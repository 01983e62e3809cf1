"""When does the top end start to fall faster than g?  Candidate definitions of the onset
of its excess acceleration, side by side on a few falls (the exact method, N = 128,
alpha = pi/4): from its lag behind free fall's velocity, D(t) = (v_z + g t) / (g t_ff) at
the frames before t_fall, the time D is largest before its minimum (the top furthest ahead
of free fall's speed, just before the final whip), and the first times D drops 0.02, 0.05
and 0.1 below its running maximum; each with the fraction of the chain landed then.

    python benchmarks/probes/excess_onset.py --starts 6

The helix start (the README's main job) and random starts of seed 2026 (spawn keys
0..starts-1).  Machine first.  (docs/notes/pull-record.md.)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parents[1]))  # benchmarks/: machine.py
from machine import machine_info  # noqa: E402

from ballchain import api  # noqa: E402
from ballchain.records.measures import top_velocity  # noqa: E402


def onsets(r) -> str:
    t = np.asarray(r.frame_t)
    ok = t < r.t_fall
    t, v = t[ok], top_velocity(r)[ok, 2]
    d = (v + r.params.gravity * t) / (r.params.gravity * r.t_ff)
    held = np.asarray(r.frame_anchored, bool)
    landed = lambda i: np.mean(held[i, :-1] & held[i, 1:])  # noqa: E731
    m = int(np.argmin(d))
    k = int(np.argmax(d[: m + 1]))
    run_max = np.maximum.accumulate(d[: m + 1])
    drops = []
    for margin in (0.02, 0.05, 0.1):
        below = np.flatnonzero(d[: m + 1] < run_max - margin)
        drops.append(f"{t[below[0]] / r.t_ff:.3f}/{landed(below[0]):.3f}" if below.size else "-")
    return (
        f"t_fall/t_ff {r.t_fall / r.t_ff:.3f}, D least at {t[m] / r.t_ff:.3f} ({d[m]:+.3f}); D largest before it at "
        f"{t[k] / r.t_ff:.3f} (landed {landed(k):.3f}); D drops 0.02, 0.05, 0.1 (t/t_ff / landed): " + " ".join(drops)
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=128)
    ap.add_argument("--starts", type=int, default=6)
    a = ap.parse_args()
    print(machine_info())
    print("helix:", onsets(api.simulate(segments=a.segments)))
    for key in range(a.starts):
        r = api.simulate(segments=a.segments, alpha="45deg", ic="random", seed=2026, spawn_key=str(key))
        print(f"random {key}:", onsets(r))


if __name__ == "__main__":
    main()
