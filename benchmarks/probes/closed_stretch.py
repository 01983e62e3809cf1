"""The one RATTLE fall known to end in error: a locked stretch closed between two anchors,
curled to within a hair of its tightest, whose twists circle faster than a step can follow.

    python benchmarks/probes/closed_stretch.py --segments 128 --start 5

The fall is the base fall of ``loss_tiles.py`` (random start of seed 2026, spawn key
``--start``, alpha = pi/4, floor all, landing steps whole), its steps cut to end on the
windows' times i t_ff/N.  It is run to its end; if it ends in error, its message is
printed, then the stretch it names, at the last accepted step: its segments, the anchors'
distance D and the chord of the planar arc its locked hinges make (their relative gap),
the two dihedral twists of its hinges over the last ``--span`` (sqrt(b/g)) sampled at each
step (their largest size, the time between two passes of the first through zero
downwards, i.e. one turn around the room left), the step sizes used (2^-level of the
fall's step), the fall's step and the stretch's kinetic energy (m g b).  Machine first.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1]))  # benchmarks/: machine.py, compare_revisions.py
from loss_tiles import DEFAULT  # noqa: E402
from machine import machine_info  # noqa: E402
from rattle_steps import fall_by_attempts  # noqa: E402

from ballchain.methods.outputs import stretch_chord_extremes  # noqa: E402
from ballchain.methods.rattle.codes import RT_RETURN, RT_STOP  # noqa: E402


def closed_stretches(anchored, locked) -> list[tuple[int, int]]:
    """(a, b): anchored points a < b with free points between, every hinge between locked."""
    held = np.flatnonzero(anchored != 0)
    return [(int(a), int(b)) for a, b in zip(held[:-1], held[1:]) if b - a >= 2 and np.all(locked[a : b - 1] != 0)]


def dihedrals(e: np.ndarray, a: int, b: int) -> list[float]:
    """The twists of the stretch's inner hinges: the signed angle between the planes of two
    neighbouring hinges' bends (0: those three axes in one plane, bent the same way)."""
    normals = [np.cross(e[i], e[i + 1]) for i in range(a, b - 1)]
    normals = [v / np.linalg.norm(v) for v in normals]
    return [
        math.atan2(float(np.cross(normals[i], normals[i + 1]) @ e[a + i + 1]), float(normals[i] @ normals[i + 1]))
        for i in range(len(normals) - 1)
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=128)
    ap.add_argument("--start", type=int, default=5)
    ap.add_argument("--span", type=float, default=0.01, help="the time before the end whose twists are shown")
    a = ap.parse_args()
    print(machine_info())
    n = a.segments
    state = {"next": None, "unit": None}
    samples = []  # (t, level, e, anchored, locked, anchor_pos, vc, ve) at each step's start

    def one_attempt(loop, t, h, model, mo, ws, sc, fr, fb, books, frames, trace, log):
        if state["unit"] is None:
            state["unit"], state["next"] = h / DEFAULT.for_segments(n).dt, 0.0
        if t >= state["next"] * (1.0 - 1e-14) - 1e-14:
            state["next"] = t + state["unit"]
        if not samples or samples[-1][0] != t:
            samples.append(
                (
                    t,
                    int(fb[19]),
                    mo.e.copy(),
                    mo.anchored.copy(),
                    mo.locked.copy(),
                    mo.anchor_pos.copy(),
                    mo.vc.copy(),
                    mo.ve.copy(),
                )
            )
            if len(samples) > 4000:
                del samples[:2000]
        cut = model._replace(t_stop=min(state["next"], model.t_stop))
        code, t = loop(t, h, cut, mo, ws, sc, fr, fb, books, frames, trace, log)
        if code == RT_STOP and cut.t_stop < model.t_stop:
            code = RT_RETURN
        return code, t

    r = fall_by_attempts(n, a.start, DEFAULT, one_attempt)
    print(f"\nN = {n}, start {a.start}: status {r.status}, at t/t_ff = {r.t[-1] / r.t_ff:.6f}")
    print(f"message: {r.message}")
    if r.status != "error":
        return
    t_end, _, e, anchored, locked, anchor_pos, vc, ve = samples[-1]
    alpha = math.pi / 4
    for pa, pb in closed_stretches(anchored, locked):
        k = pb - pa
        d = float(np.linalg.norm(anchor_pos[pb] - anchor_pos[pa]))
        arc, _ = stretch_chord_extremes(k, alpha)
        ke = 0.5 * float((vc[pa:pb] ** 2).sum()) + float((ve[pa:pb] ** 2).sum()) / 6.0
        print(
            f"\nstretch: segments {pa}-{pb - 1} between anchored points {pa} and {pb}, {k - 1} hinges locked; "
            f"D = {d:.6f} b, planar arc's chord {arc:.6f} b, gap {(d - arc) / arc:.2e}; kinetic energy "
            f"{ke:.4g} m g b ({ke / r.energy['initial']:.2g} E0)"
        )
        recent = [s for s in samples if s[0] >= t_end - a.span]
        tw = np.array([dihedrals(s[2], pa, pb) for s in recent])
        ts = np.array([s[0] for s in recent])
        levels = [s[1] for s in recent]
        if tw.shape[1]:
            down = ts[1:][(tw[:-1, 0] > 0) & (tw[1:, 0] <= 0)]
            turn = f"{float(np.median(np.diff(down))):.4g} sqrt(b/g)" if down.size > 1 else "not seen"
            print(
                f"over the last {a.span} sqrt(b/g) ({len(recent)} steps): twists up to "
                f"{float(np.abs(tw).max()):.3f} rad; one turn around the room left in {turn}; steps at "
                f"2^-{min(levels)} to 2^-{max(levels)} of the fall's step {DEFAULT.for_segments(n).dt * r.t_ff / n:.3g} sqrt(b/g)"
            )


if __name__ == "__main__":
    main()
