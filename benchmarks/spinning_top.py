"""The airborne top end of a run that did not land, as a heavy top on its anchored point.

    python benchmarks/spinning_top.py RUN.h5

A run of the exact method whose last events leave its top end airborne, its hinges locked
at their limits, hung on one landed point (an anchor: a frictionless ball joint), has a
rigid body spinning on a pivot: nothing in the model takes its energy, and no event
happens before the time cap.  Prints, over the frames after the run's last event
(``measures.top_invariants``): the piece, its kinetic energy, and the spread of the
top's two invariants, its energy T + U and its angular momentum about the vertical
through the pivot, with the lowest height its points reach.
"""

from __future__ import annotations

import argparse

import numpy as np

from ballchain.records.files import load_result
from ballchain.records.measures import top_invariants


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", help="a result file (ballchain simulate -o)")
    args = ap.parse_args()
    r = load_result(args.run)
    ti = top_invariants(r)
    e0 = r.energy["initial"]
    locked = np.asarray(r.frame_locked)[-1, : max(ti.segments - 1, 0)]
    w = np.linalg.norm(np.asarray(r.frame_omega)[-1, : ti.segments], axis=1)
    print(f"{args.run}: status {r.status}, t_ff = {r.t_ff:.6g}, N = {r.params.segments}")
    print(f"last event at {ti.t_from / r.t_ff:.4f} t_ff; {ti.t.size} frames after it, to {ti.t[-1] / r.t_ff:.3f} t_ff")
    print(
        f"top end: segments 0..{ti.segments - 1} airborne on anchored point {ti.pivot}; "
        f"hinges between them locked at the last frame: {int(locked.sum())} of {locked.size}; "
        f"|w| at the last frame {', '.join(f'{x:.3g}' for x in w)}"
    )
    print(
        f"kinetic energy: mean {ti.kinetic.mean():.6g} ({ti.kinetic.mean() / e0:.2e} E0), from {ti.kinetic.min():.6g} to {ti.kinetic.max():.6g}"
    )
    for name, x in (("energy T + U", ti.energy), ("angular momentum L_z", ti.angular_momentum_z)):
        spread = float(np.ptp(x)) / max(abs(float(np.mean(x))), 1e-300)
        print(f"{name}: mean {np.mean(x):.10g}, spread (max - min) / |mean| = {spread:.2e}")
    print(f"lowest point of the piece above the floor: {ti.lowest.min():.3g} b (highest {ti.lowest.max():.3g} b)")


if __name__ == "__main__":
    main()
