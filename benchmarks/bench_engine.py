"""Benchmarks of the engine (not tests): cost of one evaluation of the equations of
motion vs N, and wall time of whole falls.

    python benchmarks/bench_engine.py                 # all, writes docs/benchmarks.md
    python benchmarks/bench_engine.py --evals-only
    python benchmarks/bench_engine.py --falls 32,128 --alphas pi/4,pi

Prints the machine and library versions; quotes medians of repeated runs.
"""

from __future__ import annotations

import argparse
import functools
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


@functools.cache
def _compiled_loop():
    """A compiled loop calling the kernel k times (no Python call overhead per call)."""
    from numba import njit

    from ballchain.core.dynamics import accelerations

    @njit(cache=False)
    def loop(k, e, w, anchored, locked, ws, de, dw):
        J, kind, nrow, S, G, drop, rhs, x, gf = ws
        for _ in range(k):
            accelerations(e, w, anchored, locked, J, kind, nrow, S, G, drop, rhs, x, gf, de, dw)

    return loop


def bench_evals(sizes, repeats=7, quiet=False) -> list[tuple[int, float, float, float]]:
    """Median wall time of one call of dynamics.accelerations (with locked hinges):
    called from Python, and inside a compiled loop (as the integrator calls it)."""
    from ballchain.core.dynamics import accelerations
    from ballchain.core.state import new_work

    loop = _compiled_loop()

    rng = np.random.default_rng(1)
    rows = []
    for n in sizes:
        e, w, anchored, locked = random_state(n, rng)
        ws = new_work(n)
        de = np.zeros((n, 3))
        dw = np.zeros((n, 3))
        args = (e, w, anchored, locked, ws, de, dw)
        accelerations(*args)  # compile / warm up
        inner = max(1, int(2e5 // n))
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            for _ in range(inner):
                accelerations(*args)
            times.append((time.perf_counter() - t0) / inner)
        med = statistics.median(times)
        loop(1, e, w, anchored, locked, ws, de, dw)
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            loop(inner, e, w, anchored, locked, ws, de, dw)
            times.append((time.perf_counter() - t0) / inner)
        medc = statistics.median(times)
        rows.append((n, med * 1e6, med / n * 1e6, medc / n * 1e6))
        if not quiet:
            print(
                f"  eval N={n:6d}: {med * 1e6:10.2f} us  ({med / n * 1e9:7.1f} ns/segment; "
                f"in a compiled loop {medc / n * 1e9:7.1f} ns/segment)",
                flush=True,
            )
    return rows


def eval_cost_us(n: int) -> float:
    """Median cost of one evaluation (us) at size n (used to split a run's wall time)."""
    r = bench_evals([n], repeats=5, quiet=True)[0]
    return r[3] * n


def bench_interval(n: int, until: float, frames_per_tff: float, alpha: str = "pi/4"):
    """A fixed simulated interval at large N, with thinned frames: wall time, peak memory
    and the size of the result file."""
    import resource
    import tempfile

    from ballchain.engine import simulate
    from ballchain.model import ChainParams, InitialCondition, SolverOptions, parse_angle
    from ballchain.records.files import save_result

    r = simulate(
        ChainParams(segments=n, alpha=parse_angle(alpha)),
        InitialCondition(),
        SolverOptions(until=until, frames_per_tff=frames_per_tff),
    )
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "run.h5")
        save_result(r, path)
        size = os.path.getsize(path)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # MiB (Linux: kB)
    c = r.event_counts()
    row = (
        n,
        alpha,
        until,
        frames_per_tff,
        r.wall_seconds,
        r.n_steps,
        r.n_evals,
        c["lock"],
        len(r.frame_t),
        size / 2**20,
        rss,
        r.status,
    )
    print(
        f"  interval N={n} alpha={alpha} until={until} t_ff: {r.wall_seconds:.1f} s, steps={r.n_steps}, "
        f"evals={r.n_evals}, locks={c['lock']}, frames={len(r.frame_t)}, file {size / 2**20:.1f} MiB, "
        f"peak RSS {rss:.0f} MiB",
        flush=True,
    )
    return row


def bench_falls(sizes, alphas, repeats=3):
    from ballchain.engine import simulate
    from ballchain.model import ChainParams, InitialCondition, SolverOptions, parse_angle

    simulate(ChainParams(segments=4), InitialCondition(), SolverOptions())  # compile
    rows = []
    for a in alphas:
        for n in sizes:
            walls = []
            for _ in range(repeats if n <= 128 else 1):
                r = simulate(ChainParams(segments=n, alpha=parse_angle(a)), InitialCondition(), SolverOptions())
                walls.append(r.wall_seconds)
            c = r.event_counts()
            instants = r.n_instants
            eval_s = r.n_evals * eval_cost_us(n) * 1e-6  # the evaluations' share of the wall time
            row = (
                n,
                a,
                statistics.median(walls),
                r.ratio,
                r.t_landed / r.t_ff,
                c["lock"],
                c["unlock"],
                r.n_steps,
                r.n_evals,
                r.energy["imbalance"] / r.energy["initial"],
                r.status,
                instants,
                eval_s / statistics.median(walls),
                c["hold"],
            )
            rows.append(row)
            print(
                f"  fall N={n:5d} alpha={a:5s}: {row[2]:8.2f} s  t_fall/t_ff={row[3]:.4f} "
                f"locks={row[5]} holds={row[13]} steps={row[7]} evals={row[8]} event instants={row[11]} "
                f"evaluations {100 * row[12]:.0f}% of wall, imbalance={row[9]:.1e} {row[10]}",
                flush=True,
            )
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--evals", default="16,64,256,1024,4096,16384")
    ap.add_argument("--falls", default="16,32,64,128,512")
    ap.add_argument("--alphas", default="pi/4,pi")
    ap.add_argument("--evals-only", action="store_true")
    ap.add_argument(
        "--interval",
        default="16384:0.05",
        help="N:T, a fixed interval of T t_ff at size N with 10 frames per t_ff ('' to skip)",
    )
    ap.add_argument("--output", default=None, help="markdown file to write (default: print only)")
    a = ap.parse_args(argv)
    info = machine_info()
    print(info)
    cmd = "python benchmarks/bench_engine.py " + " ".join(sys.argv[1:] if argv is None else argv)
    ev = bench_evals([int(x) for x in a.evals.split(",")])
    falls = [] if a.evals_only else bench_falls([int(x) for x in a.falls.split(",")], a.alphas.split(","))
    intervals = []
    if a.interval and not a.evals_only:
        n_i, t_i = a.interval.split(":")
        intervals.append(bench_interval(int(n_i), float(t_i), 10.0))
    if a.output:
        lines = [
            "# Engine benchmarks",
            "",
            f"Command: `{cmd.strip()}`",
            "",
            info,
            "",
            "One evaluation of the equations of motion "
            "(hinge forces with ~30% of hinges locked; median of 7 repeats; called from Python, and in a "
            "compiled loop as the integrator calls it):",
            "",
            "| N | us per evaluation | ns per segment | ns per segment, compiled loop |",
            "|---:|---:|---:|---:|",
        ]
        lines += [f"| {n} | {us:.2f} | {per * 1e3:.1f} | {perc * 1e3:.1f} |" for n, us, per, perc in ev]
        if falls:
            lines += [
                "",
                "Whole falls (helix eps = 0.02, floor = all, rtol = 1e-9; wall: median of 3 runs for "
                "N <= 128, one run above):",
                "",
                "| N | alpha | wall s | t_fall/t_ff | t_landed/t_ff | locks | unlocks | holds | event instants "
                "| steps | evaluations | evaluations' share of wall | energy imbalance / E0 | status |",
                "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
            ]
            lines += [
                f"| {r[0]} | {r[1]} | {r[2]:.2f} | {r[3]:.4f} | {r[4]:.4f} | {r[5]} | {r[6]} | {r[13]} | {r[11]} "
                f"| {r[7]} | {r[8]} | {100 * r[12]:.0f}% | {r[9]:.1e} | {r[10]} |"
                for r in falls
            ]
            by = {(r[0], r[1]): r for r in falls}
            al = a.alphas.split(",")
            if len(al) >= 2:
                lines += [
                    "",
                    f"A fall at alpha = {al[0]} against the same chain at alpha = {al[1]} (no locking), "
                    "measured in the same run: the ratio of wall times, of evaluations, and of the "
                    f"evaluations that the alpha = {al[0]} fall needs whatever the treatment of its events "
                    "(with this integrator and tolerance): 6 for each Dormand-Prince step that ends at no "
                    "event (steps - event instants; sized by the error control where the motion is smooth), "
                    "and 7 for each event instant (the step that contains it, which must be integrated to "
                    "find it, and the derivative at the restart), counting nothing for locating the events, "
                    "the state at the event, the impact and lock-set solves or the projection.",
                    "",
                    "| N | wall ratio | evaluations ratio | unavoidable evaluations ratio |",
                    "|---:|---:|---:|---:|",
                ]
                for n in sorted({r[0] for r in falls}):
                    if (n, al[0]) in by and (n, al[1]) in by:
                        f0, f1 = by[(n, al[0])], by[(n, al[1])]
                        unavoidable = 6 * (f0[7] - f0[11]) + 7 * f0[11]
                        lines.append(f"| {n} | {f0[2] / f1[2]:.1f} | {f0[8] / f1[8]:.1f} | {unavoidable / f1[8]:.1f} |")
            lines += [
                "",
                "The evaluations' share is (evaluations x the median cost of one evaluation at that N) / "
                "wall time; the rest is event location, impact and lock-set solves, projection and output.",
            ]
        if intervals:
            lines += [
                "",
                "Fixed interval at large N (helix, floor = all, 10 frames per t_ff):",
                "",
                "| N | alpha | until (t_ff) | frames per t_ff | wall s | steps | evaluations | locks | frames "
                "| result file MiB | peak RSS MiB | status |",
                "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
            ]
            lines += [
                f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.0f} | {r[4]:.1f} | {r[5]} | {r[6]} | {r[7]} | {r[8]} "
                f"| {r[9]:.1f} | {r[10]:.0f} | {r[11]} |"
                for r in intervals
            ]
        with open(a.output, "w") as f:
            f.write("\n".join(lines) + "\n")
        print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
