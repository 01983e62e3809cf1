"""Benchmarks of the engine (not tests): cost of one evaluation of the equations of
motion vs N, and wall time of whole falls.

    python benchmarks/bench_engine.py                 # all, writes docs/benchmarks.md
    python benchmarks/bench_engine.py --evals-only
    python benchmarks/bench_engine.py --falls 32,128 --alphas pi/4,pi

Prints the machine and library versions; quotes medians of repeated runs.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from machine import machine_info  # noqa: E402


def random_state(n: int, rng, locked_fraction: float = 0.3):
    """A near-vertical chain with random spin and a random locked set (bottom anchored)."""
    e = np.zeros((n, 3))
    e[:, 2] = 1.0
    e[:, :2] = 0.3 * rng.standard_normal((n, 2))
    e /= np.linalg.norm(e, axis=1)[:, None]
    w = rng.standard_normal((n, 3))
    w -= np.einsum("ij,ij->i", w, e)[:, None] * e
    anchored = np.zeros(n + 1, np.uint8)
    anchored[n] = 1
    locked = (rng.random(max(n - 1, 0)) < locked_fraction).astype(np.uint8)
    return e, w, anchored, locked


def bench_evals(sizes, repeats=7) -> list[tuple[int, float, float]]:
    """Median wall time of one call of dynamics.accelerations (with locked hinges)."""
    from ballchain.dynamics import Workspace, accelerations

    rng = np.random.default_rng(1)
    rows = []
    for n in sizes:
        e, w, anchored, locked = random_state(n, rng)
        ws = Workspace(n)
        de = np.zeros((n, 3))
        dw = np.zeros((n, 3))
        args = (e, w, anchored, locked, False, *ws.arrays(), de, dw)
        accelerations(*args)  # compile / warm up
        inner = max(1, int(2e5 // n))
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            for _ in range(inner):
                accelerations(*args)
            times.append((time.perf_counter() - t0) / inner)
        med = statistics.median(times)
        rows.append((n, med * 1e6, med / n * 1e6))
        print(f"  eval N={n:6d}: {med * 1e6:10.2f} us  ({med / n * 1e9:7.1f} ns/segment)", flush=True)
    return rows


def bench_falls(sizes, alphas, repeats=1):
    from ballchain.engine import simulate
    from ballchain.model import ChainParams, InitialCondition, SolverOptions, parse_angle

    simulate(ChainParams(segments=4), InitialCondition(), SolverOptions())  # compile
    rows = []
    for a in alphas:
        for n in sizes:
            walls = []
            for _ in range(repeats):
                r = simulate(ChainParams(segments=n, alpha=parse_angle(a)), InitialCondition(), SolverOptions())
                walls.append(r.wall_seconds)
            c = r.event_counts()
            row = (n, a, statistics.median(walls), r.ratio, r.t_landed / r.t_ff, c["lock"], c["unlock"], r.n_steps,
                   r.n_evals, r.energy["imbalance"] / r.energy["initial"], r.status)
            rows.append(row)
            print(f"  fall N={n:5d} alpha={a:5s}: {row[2]:8.2f} s  t_fall/t_ff={row[3]:.4f} "
                  f"locks={row[5]} steps={row[7]} evals={row[8]} imbalance={row[9]:.1e} {row[10]}", flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--evals", default="16,64,256,1024,4096,16384")
    ap.add_argument("--falls", default="32,128,512")
    ap.add_argument("--alphas", default="pi/4,pi")
    ap.add_argument("--evals-only", action="store_true")
    ap.add_argument("--output", default=None, help="markdown file to write (default: print only)")
    a = ap.parse_args(argv)
    info = machine_info()
    print(info)
    cmd = "python benchmarks/bench_engine.py " + " ".join(sys.argv[1:] if argv is None else argv)
    ev = bench_evals([int(x) for x in a.evals.split(",")])
    falls = [] if a.evals_only else bench_falls([int(x) for x in a.falls.split(",")], a.alphas.split(","))
    if a.output:
        lines = [f"Command: `{cmd.strip()}`", "", info, "", "One evaluation of the equations of motion "
                 "(hinge forces with ~30% of hinges locked; median of 7 repeats):", "",
                 "| N | us per evaluation | ns per segment |", "|---:|---:|---:|"]
        lines += [f"| {n} | {us:.2f} | {per * 1e3:.1f} |" for n, us, per in ev]
        if falls:
            lines += ["", "Whole falls (helix eps = 0.02, floor = all, rtol = 1e-9):", "",
                      "| N | alpha | wall s | t_fall/t_ff | t_landed/t_ff | locks | unlocks | steps | evaluations "
                      "| energy imbalance / E0 | status |", "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
            lines += [f"| {r[0]} | {r[1]} | {r[2]:.2f} | {r[3]:.4f} | {r[4]:.4f} | {r[5]} | {r[6]} | {r[7]} | {r[8]} "
                      f"| {r[9]:.1e} | {r[10]} |" for r in falls]
        with open(a.output, "w") as f:
            f.write("\n".join(lines) + "\n")
        print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
