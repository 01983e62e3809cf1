"""Where do RATTLE's locks lose energy near an elastic limit?  Its registry refuses
``--restitution-lock`` above 0.75 (``methods.rattle.CONTACT_BOUNDS``); this probe lets the
law through and sums each fall's event log by row kind (rows, the energy they book over
E0, how many are negative), beside the exact method's on the same start.

    python benchmarks/probes/rattle_elastic_locks.py --segments 64 --restitution 1 --keys 0

Random starts of seed 2026 (the sweeps' starts, spawn keys --keys), alpha = pi/4, floor
all, each method's defaults.  Machine first.  (docs/notes/restitution-record.md, "Where
RATTLE's locks lose energy at E = 1".)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parents[1]))  # benchmarks/: machine.py
from machine import machine_info  # noqa: E402

import ballchain.methods.rattle as rattle  # noqa: E402
from ballchain import api  # noqa: E402
from ballchain.core.kinds import EVENT_KINDS  # noqa: E402


def by_kind(r) -> list[str]:
    """One line per row kind of the run's log: rows, energy over E0, negative rows."""
    e0 = r.energy["initial"]
    lines = []
    for code, name in EVENT_KINDS.items():
        sel = np.asarray(r.event_kind) == code
        if sel.any():
            en = np.asarray(r.event_energy)[sel]
            lines.append(
                f"    {name:8s} rows {sel.sum():7d}  energy/E0 {en.sum() / e0:+.4f}  negative {np.sum(en < 0)}"
            )
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=64)
    ap.add_argument("--restitution", type=float, default=1.0)
    ap.add_argument("--keys", default="0", help="spawn keys, comma-separated")
    ap.add_argument("--methods", default="rattle,event")
    a = ap.parse_args()
    print(machine_info())
    rattle.CONTACT_BOUNDS = {}  # (the law let through)
    for key in a.keys.split(","):
        for method in a.methods.split(","):
            r = api.simulate(segments=a.segments, alpha="45deg", ic="random", seed=2026, spawn_key=key,
                             method=method, restitution_lock=a.restitution)  # fmt: skip
            en = r.energy
            print(f"key {key} {method}: {r.status}, t_fall/t_ff {r.t_fall / r.t_ff:.4f}, "
                  f"E_lock/E0 {en['lost_locking'] / en['initial']:.4f}, E_land/E0 {en['lost_landing'] / en['initial']:.4f}")  # fmt: skip
            print("\n".join(by_kind(r)))


if __name__ == "__main__":
    main()
