"""The time-stepping method (``--method timestep``) against the event-driven one and an
analytic truth: the tables of docs/timestep.md.

    python studies/timestep_convergence.py                       # all tables (about 10 min)
    python studies/timestep_convergence.py --only rod
    python studies/timestep_convergence.py --only pi --segments 16
    python studies/timestep_convergence.py --only ensembles --segments 64,128 --starts 16 --dts 0.04,0.02,0.01
    python studies/timestep_convergence.py --thetas 0.5,1      # each table for both position updates

1. ``rod``: a rod (N = 1) falling over from 0.3 rad, t_fall against the quadrature of its
   energy equation, and the energy imbalance, for dt = 0.08 .. 0.005 (first order: each
   halving of dt halves both).
2. ``pi``: a chain with no bend limit (alpha = pi; N = ``--segments``, the first; a
   random start, seed 1, spawn key 0) falling onto floor all, against the event-driven
   run of the same start: the first landing time, the energy lost at landings, the
   imbalance, and t_fall, for dt = 0.08 .. 0.0025.  No lock: one run is well conditioned
   up to its first landings; after them the order of landings can change with dt.
3. ``ensembles``: N = 64, 128 (``--segments``), alpha = pi/4, floor all, random starts
   (seed 1, spawn keys 0 .. starts-1, the same for both methods): the mean of t_fall/t_ff,
   t_landed/t_ff and E_lock/E0 per method and dt, the difference of means with its 95%
   interval, the two-sample Kolmogorov-Smirnov p value, the imbalance, the deepest point,
   and the median wall time of a run, side by side in one process.

4. ``books``: where the imbalance comes from, N = ``--segments`` (``--starts`` random
   starts, seed 2026, alpha = pi/4, floor all, dt = the first of ``--dts``): per theta,
   the means over the starts of the imbalance, of the steps' error in gravity's work
   (``work_error_in_steps``: gravity's kick on T plus the position update's change of U),
   of the projections' change of U, and of the rest (the impacts' unbooked share).

``--thetas``: the time-stepper's position update (``SolverOptions.theta``): each table
for each value (rod and pi: one table per theta; ensembles: one row per theta and dt).

Machine and versions are printed first.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats
from scipy.integrate import quad

sys.path.insert(0, str(Path(__file__).parents[1] / "benchmarks"))  # machine.py, shared with the speed benchmarks
from machine import machine_info  # noqa: E402

from ballchain.core.kinds import EVENT_CODES  # noqa: E402
from ballchain.engine import load_kernels, simulate  # noqa: E402
from ballchain.model import ChainParams, InitialCondition, SolverOptions  # noqa: E402

THETA0 = 0.3


def rod_table(dts, theta: float = 0.5) -> None:
    exact = quad(lambda th: 1.0 / math.sqrt(1.5 * (math.cos(THETA0) - math.cos(th))), THETA0, math.pi / 2)[0]
    e0 = np.array([[math.sin(THETA0), 0.0, math.cos(THETA0)]])
    print(
        f"\n## A rod falling over from {THETA0} rad, theta = {theta:g}: t_fall against the quadrature ({exact:.10f})\n"
    )
    print("| dt (t_ff/N) | steps | t_fall error / t_fall | ratio | imbalance / E0 | ratio |")
    print("|---|---|---|---|---|---|")
    prev = None
    for dt in dts:
        r = simulate(
            ChainParams(segments=1, alpha=math.pi),
            None,
            SolverOptions(method="timestep", dt=dt, frames_per_tff=1, theta=theta),
            state=(e0, None),
        )
        err = (r.t_fall - exact) / exact
        imb = r.energy["imbalance"] / r.energy["initial"]
        ratios = ("", "") if prev is None else (f"{prev[0] / err:.2f}", f"{prev[1] / imb:.2f}")
        print(f"| {dt:g} | {r.n_steps} | {err:.3e} | {ratios[0]} | {imb:.3e} | {ratios[1]} |")
        prev = (err, imb)


def pi_table(n: int, dts, theta: float = 0.5) -> None:
    p = ChainParams(segments=n, alpha=math.pi)
    ic = InitialCondition(kind="random", seed=1, spawn_key=(0,))
    ref = simulate(p, ic, SolverOptions(frames_per_tff=1))
    e0 = ref.energy["initial"]
    land0 = ref.event_t[ref.event_kind == EVENT_CODES["landing"]][0] / ref.t_ff
    print(
        f"\n## N = {n}, alpha = pi (no bend limit), floor all, one random start, theta = {theta:g}: against the "
        f"event-driven run "
        f"(first landing {land0:.8f} t_ff, E_land {ref.energy['lost_landing'] / e0:.6f} E0, "
        f"t_fall {ref.t_fall / ref.t_ff:.6f} t_ff)\n"
    )
    print(
        "| dt (t_ff/N) | steps | first landing: error (t_ff) | ratio | E_land: error / E0 | ratio "
        "| imbalance / E0 | t_fall: error (t_ff) | status |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    prev = None
    for dt in dts:
        r = simulate(p, ic, SolverOptions(method="timestep", dt=dt, frames_per_tff=1, theta=theta))
        land = r.event_t[r.event_kind == EVENT_CODES["landing"]][0] / r.t_ff
        err = (land - land0, (r.energy["lost_landing"] - ref.energy["lost_landing"]) / e0)
        ratios = ("", "") if prev is None else (f"{prev[0] / err[0]:.2f}", f"{prev[1] / err[1]:.2f}")
        print(
            f"| {dt:g} | {r.n_steps} | {err[0]:+.3e} | {ratios[0]} | {err[1]:+.3e} | {ratios[1]} "
            f"| {r.energy['imbalance'] / e0:+.3e} | {r.t_fall / r.t_ff - ref.t_fall / ref.t_ff:+.2e} | {r.status} |"
        )
        prev = err


def _ensemble(n: int, starts: int, options: SolverOptions) -> dict:
    rows = []
    for k in range(starts):
        ic = InitialCondition(kind="random", seed=1, spawn_key=(k,))
        r = simulate(ChainParams(segments=n, alpha=math.pi / 4), ic, options)
        e0 = r.energy["initial"]
        rows.append(
            (
                r.t_fall / r.t_ff,
                r.t_landed / r.t_ff,
                r.energy["lost_locking"] / e0,
                r.energy["imbalance"] / e0,
                r.max_depth,
                r.wall_seconds,
                r.status,
            )
        )
    cols = list(zip(*rows))
    return {
        "t_fall": np.array(cols[0]),
        "t_landed": np.array(cols[1]),
        "E_lock": np.array(cols[2]),
        "imbalance": np.array(cols[3]),
        "depth": np.array(cols[4]),
        "wall": np.array(cols[5]),
        "status": cols[6],
    }


def _diff(a: np.ndarray, b: np.ndarray) -> str:
    """mean(a) - mean(b) [95% interval] (Welch), and the KS p value."""
    a, b = a[np.isfinite(a)], b[np.isfinite(b)]
    if len(a) < 2 or len(b) < 2:
        return "n/a | n/a"
    d = a.mean() - b.mean()
    se = math.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b))
    return f"{d:+.4f} [{d - 1.96 * se:+.4f}, {d + 1.96 * se:+.4f}] | {stats.ks_2samp(a, b).pvalue:.2f}"


def ensemble_tables(segments, starts: int, dts, thetas=(0.5,)) -> None:
    for n in segments:
        print(f"\n## N = {n}, alpha = pi/4, floor all: {starts} random starts (seed 1, spawn keys 0..{starts - 1})\n")
        ref = _ensemble(n, starts, SolverOptions(frames_per_tff=2))
        print(
            "| method | t_fall/t_ff | t_landed/t_ff | E_lock/E0 | t_fall: difference [95%] | KS p | "
            "E_lock: difference [95%] | KS p | imbalance/E0 (max) | depth (b, max) | median wall (s) | errors |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for label, ens in [("event", ref)] + [
            (
                f"timestep dt={dt:g}" + ("" if thetas == (0.5,) else f" theta={theta:g}"),
                _ensemble(n, starts, SolverOptions(method="timestep", dt=dt, frames_per_tff=2, theta=theta)),
            )
            for theta in thetas
            for dt in dts
        ]:
            errors = sum(s == "error" and not math.isfinite(t) for s, t in zip(ens["status"], ens["t_fall"]))
            print(
                f"| {label} | {np.nanmean(ens['t_fall']):.4f} | {np.nanmean(ens['t_landed']):.4f} | "
                f"{np.mean(ens['E_lock']):.4f} | {_diff(ens['t_fall'], ref['t_fall'])} | "
                f"{_diff(ens['E_lock'], ref['E_lock'])} | {np.max(np.abs(ens['imbalance'])):.3g} | "
                f"{np.max(ens['depth']):.3g} | {np.median(ens['wall']):.3f} | {errors} |",
                flush=True,
            )


def books_table(segments, starts: int, dt: float, thetas) -> None:
    print(
        f"\n## Where the imbalance comes from: alpha = pi/4, floor all, dt = {dt:g}, {starts} random starts "
        f"(seed 2026) per N; means over the starts, in units of E0\n"
    )
    print(
        "| N | theta | imbalance | work error in steps | projected in steps | rest (impacts) | E_lock | t_fall/t_ff |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for n in segments:
        for theta in thetas:
            rows = []
            for k in range(starts):
                ic = InitialCondition(kind="random", seed=2026, spawn_key=(k,))
                r = simulate(ChainParams(segments=n), ic, SolverOptions(method="timestep", dt=dt, theta=theta))
                e = r.energy
                e0 = e["initial"]
                imb, work, proj = e["imbalance"] / e0, e["work_error_in_steps"] / e0, e["projected_in_steps"] / e0
                rows.append((imb, work, proj, imb + work + proj, e["lost_locking"] / e0, r.t_fall / r.t_ff))
            m = np.mean(rows, axis=0)
            print(
                f"| {n} | {theta:g} | {m[0]:+.4f} | {m[1]:+.4f} | {m[2]:+.5f} | {m[3]:+.4f} | {m[4]:.4f} | "
                f"{m[5]:.4f} |",
                flush=True,
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", choices=("rod", "pi", "ensembles", "books"), default=None)
    ap.add_argument("--segments", default="64,128")
    ap.add_argument("--starts", type=int, default=16)
    ap.add_argument("--dts", default="0.04,0.02,0.01")
    ap.add_argument("--thetas", default="0.5", help="position updates of the time-stepper (SolverOptions.theta)")
    a = ap.parse_args()
    thetas = tuple(float(x) for x in a.thetas.split(","))
    print(machine_info())
    t0 = time.perf_counter()
    load_kernels("event")
    load_kernels("timestep")
    print(f"(kernels loaded in {time.perf_counter() - t0:.1f} s)")
    for theta in thetas:
        if a.only in (None, "rod"):
            rod_table([0.08, 0.04, 0.02, 0.01, 0.005], theta)
        if a.only in (None, "pi"):
            n = int(a.segments.split(",")[0]) if a.only == "pi" else 16
            pi_table(n, [0.08, 0.04, 0.02, 0.01, 0.005, 0.0025], theta)
    if a.only == "books":
        segments = [int(x) for x in a.segments.split(",")]
        books_table(segments, a.starts, float(a.dts.split(",")[0]), thetas)
    if a.only in (None, "ensembles"):
        ensemble_tables([int(x) for x in a.segments.split(",")], a.starts, [float(x) for x in a.dts.split(",")], thetas)


if __name__ == "__main__":
    main()
