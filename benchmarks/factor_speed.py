"""Is the time-stepper's O(N) factorisation bound by arithmetic or by memory?

    python benchmarks/factor_speed.py                          # N = 128 .. 65536
    python benchmarks/factor_speed.py --segments 1024,16384 --reps 7

One factorisation of J W J^T and one solve (``core.blocks.factor4`` and ``solve4``, the
fixed-size path every step of a fall takes) for a chain of N random unit axes with every
hinge locked (four rows per point: the largest common block), repeated on the same
arrays.  Two timings per N, in ns per point (the median of --reps):

- ``warm``: back to back, so the factors stay in cache as far as they fit (S and G take
  about 950 B per point);
- ``cold``: a pass over a buffer of the step's whole footprint (the kernels' arrays,
  about 2.2 KB per segment, ``state.new_work`` and the stepper's scratch) before each
  factorisation, as the other passes of a step do between two factorisations.

If ``warm`` is flat in N the kernel is bound by arithmetic; where ``cold`` rises above
it, the step's data no longer fits the caches and a tighter layout would pay.  Machine
and versions are printed first.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).parent))
from machine import machine_info  # noqa: E402

from ballchain.core.blocks import factor4, solve4  # noqa: E402
from ballchain.core.rows import ROW_HINGE, ROW_LOCK  # noqa: E402
from ballchain.core.state import new_work  # noqa: E402

FOOTPRINT = 2200  # bytes per segment a step touches (docs/timestep.md)


@njit(cache=True)
def _factor_solve(e, anchored, kind, nrow, S, G, drop, rhs, x, reps, evict):
    acc = 0.0
    for _ in range(reps):
        for i in range(evict.shape[0]):  # empty when warm
            evict[i] += 1.0
        factor4(e, anchored, kind, nrow, S, G, drop)
        solve4(nrow, S, G, rhs, x)
        acc += x[1, 0]
    return acc


@njit(cache=True)
def _evict_only(evict, reps):
    for _ in range(reps):
        for i in range(evict.shape[0]):
            evict[i] += 1.0
    return evict[0]


def locked_chain(n: int, seed: int = 1):
    """Random unit axes, every hinge locked: rows 3 + 1 at every inner point."""
    ws = new_work(n)
    rng = np.random.default_rng(seed)
    e = rng.normal(size=(n, 3))
    e /= np.linalg.norm(e, axis=1)[:, None]
    anchored = np.zeros(n + 1, np.uint8)
    ws.nrow[:] = 4
    ws.nrow[0] = 0  # the free bottom end
    ws.nrow[n] = 3  # the top end held (an anchor)
    ws.kind[:, 0] = ROW_HINGE
    ws.kind[:, 3] = ROW_LOCK
    ws.rhs[:] = rng.normal(size=ws.rhs.shape)
    return e, anchored, ws


def time_per_point(n: int, reps: int, cold: bool) -> float:
    e, anchored, ws = locked_chain(n)
    evict = np.zeros(n * FOOTPRINT // 8 if cold else 0)
    inner = max(1, 4_000_000 // n)
    args = (e, anchored, ws.kind, ws.nrow, ws.S, ws.G, ws.drop, ws.rhs, ws.x)
    _factor_solve(*args, 1, evict)
    out = []
    for _ in range(reps):
        t0 = time.perf_counter()
        _factor_solve(*args, inner, evict)
        t1 = time.perf_counter()
        t_evict = 0.0
        if cold:  # the pass over the buffer alone, subtracted
            _evict_only(evict, inner)
            t_evict = time.perf_counter() - t1
        out.append((t1 - t0 - t_evict) / inner / n * 1e9)
    return statistics.median(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", default="128,1024,4096,16384,65536")
    ap.add_argument("--reps", type=int, default=5)
    a = ap.parse_args(argv)
    print(machine_info())
    print("| N | warm (ns / point) | cold (ns / point) | cold / warm |")
    print("|---|---|---|---|")
    for n in (int(s) for s in a.segments.split(",")):
        w = time_per_point(n, a.reps, cold=False)
        c = time_per_point(n, a.reps, cold=True)
        print(f"| {n} | {w:.1f} | {c:.1f} | {c / w:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
