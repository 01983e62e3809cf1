"""Which steps book RATTLE's losses: E_lock and E_land of a fall summed by the kind of
step that booked them (a new anchor and a new lock in the same step, a new lock alone, a
landing alone, neither), at two steps, on the same starts.

    python benchmarks/probes/lock_steps.py --segments 512 --starts 0-3 --dt 0.05,0.1:1e-6

For each start (random, seed 2026, alpha = pi/4, floor all) and step (``dt`` or
``dt:step_energy_tol``), the fall is watched attempt by attempt
(``engine.simulate(observer=)``), and each accepted step's change of the books' losses is read
with its new anchors (its ledger's ``new_anchors``) and its new locks (hinges locked after it, not
before).  Prints the machine, then per step the means
over the starts, in E0: the losses at the hinges and at the landings booked by steps of
each kind, and the number of such steps per N.  A diagnostic of where the longer step's
E_lock deficit is booked (``docs/notes/rattle-elock.md``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1]))  # benchmarks/: machine.py, compare_revisions.py
from lock_distance import _keys  # noqa: E402
from machine import machine_info  # noqa: E402
from rattle_steps import fall_by_attempts  # noqa: E402

from ballchain.model import SolverOptions  # noqa: E402

KINDS = ("a landing and a new lock", "a new lock, no landing", "a landing, no new lock", "neither")


class _Booked:
    """Each accepted step's new anchors, new locks and losses (E_lock, E_land)."""

    def __init__(self):
        self.rows = []

    def before(self, t, seen):
        books = seen.books
        self.steps, self.lock, self.land = (
            int(books.n_steps[0]),
            float(books.lost_locking[0]),
            float(books.lost_landing[0]),
        )
        self.locked = seen.fall.motion.locked.copy()

    def after(self, t, seen, code):
        books, locked = seen.books, seen.fall.motion.locked
        if int(books.n_steps[0]) > self.steps:
            new = int(np.count_nonzero((locked != 0) & (self.locked == 0)))
            lost = (books.lost_locking[0] - self.lock, books.lost_landing[0] - self.land)
            self.rows.append((seen.fall.scratch.ledger.new_anchors[0], new, *lost))


def booked_by_kind(n: int, key: int, dt: float, etol: float | None) -> dict:
    """One fall: {kind: (E_lock, E_land, steps)} in E0 and per N."""
    seen = _Booked()
    r = fall_by_attempts(n, key, SolverOptions(method="rattle", dt=dt, step_energy_tol=etol), seen)
    a = np.array(seen.rows, dtype=float)
    e0 = r.energy["initial"]
    na, new, lock, land = a[:, 0] > 0, a[:, 1] > 0, a[:, 2] / e0, a[:, 3] / e0
    masks = {KINDS[0]: na & new, KINDS[1]: ~na & new, KINDS[2]: na & ~new, KINDS[3]: ~na & ~new}
    out = {k: (lock[m].sum(), land[m].sum(), m.sum() / n) for k, m in masks.items()}
    out["all"] = (lock.sum(), land.sum(), len(a) / n)
    out["status"] = r.status
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=512)
    ap.add_argument("--starts", default="0-3", help="spawn keys: 0-3 or 0,2")
    ap.add_argument("--dt", default="0.05,0.1:1e-6", help="steps: dt or dt:step_energy_tol")
    a = ap.parse_args()
    keys = _keys(a.starts)
    print(machine_info())
    print(f"\nN = {a.segments}, starts {keys}: losses booked by kind of step (E0, means over the starts)\n")
    print("| step | kind of step | E_lock | E_land | steps / N |")
    print("|---|---|---|---|---|")
    for spec in a.dt.split(","):
        dt, _, etol = spec.partition(":")
        falls = [booked_by_kind(a.segments, k, float(dt), float(etol) if etol else None) for k in keys]
        for kind in (*KINDS, "all"):
            v = np.mean([f[kind] for f in falls], axis=0)
            print(f"| {spec} | {kind} | {v[0]:.4f} | {v[1]:.4f} | {v[2]:.2f} |")


if __name__ == "__main__":
    main()
