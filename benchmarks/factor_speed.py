"""Is the time-stepper's O(N) factorisation bound by arithmetic or by memory?

    python benchmarks/factor_speed.py                          # N = 128 .. 65536
    python benchmarks/factor_speed.py --segments 1024,16384 --reps 7
    python benchmarks/factor_speed.py --rattle                 # RATTLE's block LU

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

With ``--rattle``: the RATTLE method's block LU (``methods.rattle.blocks``) on a chain of N
random unit axes, every point free (its 3 joint rows and the axis row below it, the
common block of a fall): one factorisation of J W J^T, one of stage 1's Newton matrix
J(q+) W J(q)^T (q+ the axes turned by about 0.01 rad) and one solve, warm, in ns per point
(the median of --reps, timed by the thread's CPU clock: a sweep on another core does not
count).
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
from ballchain.methods.rattle.blocks import factor_blocks, solve_blocks  # noqa: E402
from ballchain.methods.rattle.rows import layout, new_rows, row_gradients  # noqa: E402

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


@njit(cache=True)
def _rattle_factor(anchored, J1, J0, kind, nrow, drops, F, symmetric, reps):
    nd = 0
    for _ in range(reps):
        nd += factor_blocks(anchored, J1, J0, kind, nrow, drops, F, symmetric, 0)
    return nd


@njit(cache=True)
def _rattle_solve(nrow, F, b, x, reps):
    acc = 0.0
    for _ in range(reps):
        solve_blocks(nrow, F, b, x)
        acc += x[1, 0]
    return acc


def rattle_times(n: int, reps: int, seed: int = 0) -> tuple[float, float, float]:
    """ns per point: factor J W J^T, factor J(q+) W J(q)^T, solve (free points)."""
    rng = np.random.default_rng(seed)
    e = np.array([0.0, 0.0, 1.0]) + 0.3 * rng.standard_normal((n, 3))
    e /= np.linalg.norm(e, axis=1)[:, None]
    e1 = e + 0.01 * rng.standard_normal((n, 3))
    e1 /= np.linalg.norm(e1, axis=1)[:, None]
    anchored = np.zeros(n + 1, np.uint8)
    ws = new_rows(n)
    layout(anchored, np.zeros(n - 1, np.uint8), np.zeros(n + 1, np.uint8), ws.kind, ws.nrow)
    row_gradients(e, ws.kind, ws.nrow, ws.J, 0)
    row_gradients(e1, ws.kind, ws.nrow, ws.J1, 0)
    b = rng.standard_normal(ws.rhs.shape)
    x = np.zeros_like(b)
    inner = max(1, 400_000 // n)
    sym = (anchored, ws.J, ws.J, ws.kind, ws.nrow, ws.sym.drop, ws.sym, True)
    newt = (anchored, ws.J1, ws.J, ws.kind, ws.nrow, ws.sym.drop, ws.newt, False)
    if _rattle_factor(*sym, 1) != 0 or _rattle_factor(*newt, 1) != 0:
        raise RuntimeError("a row was dropped or a pivot was small: not the common case")
    _rattle_solve(ws.nrow, ws.newt, b, x, 1)
    out = {"sym": [], "newt": [], "solve": []}
    for _ in range(reps):
        for name, run in (
            ("sym", lambda: _rattle_factor(*sym, inner)),
            ("newt", lambda: _rattle_factor(*newt, inner)),
            ("solve", lambda: _rattle_solve(ws.nrow, ws.newt, b, x, inner)),
        ):
            t0 = time.thread_time()
            run()
            out[name].append((time.thread_time() - t0) / inner / (n + 1) * 1e9)
    return tuple(statistics.median(out[k]) for k in ("sym", "newt", "solve"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", default="128,1024,4096,16384,65536")
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--rattle", action="store_true", help="the RATTLE method's block LU instead")
    a = ap.parse_args(argv)
    print(machine_info())
    if a.rattle:
        print("| N | factor J W J^T (ns / point) | factor J(q+) W J(q)^T | solve |")
        print("|---|---|---|---|")
        for n in (int(s) for s in a.segments.split(",")):
            t = rattle_times(n, a.reps)
            print(f"| {n} | {t[0]:.1f} | {t[1]:.1f} | {t[2]:.1f} |", flush=True)
        return 0
    print("| N | warm (ns / point) | cold (ns / point) | cold / warm |")
    print("|---|---|---|---|")
    for n in (int(s) for s in a.segments.split(",")):
        w = time_per_point(n, a.reps, cold=False)
        c = time_per_point(n, a.reps, cold=True)
        print(f"| {n} | {w:.1f} | {c:.1f} | {c / w:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
