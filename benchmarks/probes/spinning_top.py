"""An airborne top end spinning on its anchored point, read as a heavy top; and how each
method holds one.

    python benchmarks/probes/spinning_top.py RUN.h5
    python benchmarks/probes/spinning_top.py --state tests/data/top3-state.txt [--max-time 0.2] [--dts 0.004,0.002,0.001,0.0005]

A run of the exact method whose last events leave its top end airborne, its hinges locked
at their limits, hung on one landed point (an anchor: a frictionless ball joint), has a
rigid body spinning on a pivot: nothing in the model takes its energy, and no event
happens before the time cap.  With a result file, prints over the frames after the run's
last event (``measures.top_invariants``): the piece, its kinetic energy, and the spread
of the top's two invariants, its energy T + U and its angular momentum L_z about the
vertical through the pivot, with the lowest height its points reach.

With ``--state`` (N x 6: axes, then angular velocities; ``tests/data/top3-state.txt`` is
such a top, three segments taken from a fall) it starts a chain of N segments there, its
lower end on the floor as the pivot, and runs it to ``--max-time`` (t_ff) by the exact
method and by the time-stepper (theta = 1) at each ``--dts``: a Markdown table of the
top's energy T + U at the end over its start (1 for the exact top), E_lock/E0 and the
books' imbalance over E0 per run.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from ballchain.engine import simulate
from ballchain.model import ChainParams, SolverOptions
from ballchain.records.files import load_result
from ballchain.records.measures import top_invariants


def _spread(x) -> float:
    return float(np.ptp(x)) / max(abs(float(np.mean(x))), 1e-300)


def report_run(path: str) -> None:
    r = load_result(path)
    ti = top_invariants(r)
    e0 = r.energy["initial"]
    locked = np.asarray(r.frame_locked)[-1, : max(ti.segments - 1, 0)]
    w = np.linalg.norm(np.asarray(r.frame_omega)[-1, : ti.segments], axis=1)
    print(f"{path}: status {r.status}, t_ff = {r.t_ff:.6g}, N = {r.params.segments}")
    print(f"last event at {ti.t_from / r.t_ff:.4f} t_ff; {ti.t.size} frames after it, to {ti.t[-1] / r.t_ff:.3f} t_ff")
    print(
        f"top end: segments 0..{ti.segments - 1} airborne on anchored point {ti.pivot}; "
        f"hinges between them locked at the last frame: {int(locked.sum())} of {locked.size}; "
        f"|w| at the last frame {', '.join(f'{x:.3g}' for x in w)}"
    )
    print(
        f"kinetic energy: mean {ti.kinetic.mean():.6g} ({ti.kinetic.mean() / e0:.2e} E0), "
        f"from {ti.kinetic.min():.6g} to {ti.kinetic.max():.6g}"
    )
    for name, x in (("energy T + U", ti.energy), ("angular momentum L_z", ti.angular_momentum_z)):
        print(f"{name}: mean {np.mean(x):.10g}, spread (max - min) / |mean| = {_spread(x):.2e}")
    print(f"lowest point of the piece above the floor: {ti.lowest.min():.3g} b (highest {ti.lowest.max():.3g} b)")


def compare_methods(state_path: str, max_time: float, dts: list[float]) -> None:
    s = np.loadtxt(state_path)
    e, w = s[:, :3], s[:, 3:]
    p = ChainParams(segments=e.shape[0], alpha=math.pi / 4, floor="all")
    print(f"{state_path}: N = {p.segments}, alpha = 45 deg, to {max_time} t_ff\n")
    print("| method | dt (t_ff/N) | steps | status | top's T + U: end / start | E_lock/E0 | imbalance/E0 |")
    print("|---|---|---|---|---|---|---|")
    runs = [("event", None)] + [("timestep", dt) for dt in dts]
    for method, dt in runs:
        if method == "event":
            o = SolverOptions(max_time=max_time)
        else:
            o = SolverOptions(method="timestep", dt=dt, theta=1.0, max_time=max_time)
        r = simulate(p, state=(e, w), options=o)
        e0 = r.energy["initial"]
        tu = np.asarray(r.frame_kinetic) + np.asarray(r.frame_potential)  # the chain's T + U: the top's
        print(
            f"| {method} | {'' if dt is None else dt} | {r.n_steps} | {r.status} | {tu[-1] / tu[0]:.4f} | "
            f"{r.energy['lost_locking'] / e0:.3g} | {r.energy['imbalance'] / e0:+.3g} |"
        )
        if method == "event":
            try:
                ti = top_invariants(r)
                print(
                    f"|  | (after its last event, {ti.t_from / r.t_ff:.2g} t_ff: T + U within "
                    f"{_spread(ti.energy):.1e}, L_z within {_spread(ti.angular_momentum_z):.1e}) |  |  |  |  |  |"
                )
            except ValueError as err:  # the exact run ended its top (a lock opened, a point landed)
                print(f"|  | (no top after its last event: {err}) |  |  |  |  |  |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", nargs="?", help="a result file (ballchain simulate -o)")
    ap.add_argument("--state", help="N x 6 text file: axes and angular velocities of a top, its lower end the pivot")
    ap.add_argument("--max-time", type=float, default=0.2, help="t_ff (with --state)")
    ap.add_argument("--dts", default="0.004,0.002,0.001,0.0005", help="the time-stepper's dt values (with --state)")
    args = ap.parse_args()
    if (args.run is None) == (args.state is None):
        ap.error("give a result file or --state, not both")
    if args.run is not None:
        report_run(args.run)
    else:
        compare_methods(args.state, args.max_time, [float(x) for x in args.dts.split(",") if x.strip()])


if __name__ == "__main__":
    main()
