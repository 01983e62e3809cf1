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


class _Samples:
    """The base fall of ``loss_tiles.py``, paused on the windows' times i t_ff/N, and the
    state at each step's start: (t, level, e, anchored, locked, anchor_pos, vc, ve)."""

    def __init__(self, n: int):
        self.n, self.next, self.unit, self.samples = n, None, None, []

    def before(self, t, seen):
        if self.unit is None:
            self.unit, self.next = seen.h / DEFAULT.for_segments(self.n).dt, 0.0
        if t >= self.next * (1.0 - 1e-14) - 1e-14:
            self.next = t + self.unit
        samples = self.samples
        if not samples or samples[-1][0] != t:
            mo = seen.fall.motion
            level = int(seen.fall.control.level[0])
            samples.append((t, level, *(a.copy() for a in (mo.e, mo.anchored, mo.locked, mo.anchor_pos, mo.vc, mo.ve))))
            if len(samples) > 4000:
                del samples[:2000]
        return self.next

    def after(self, t, seen, code):
        pass


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=128)
    ap.add_argument("--start", type=int, default=5)
    ap.add_argument("--span", type=float, default=0.01, help="the time before the end whose twists are shown")
    a = ap.parse_args()
    print(machine_info())
    n = a.segments
    seen = _Samples(n)
    r = fall_by_attempts(n, a.start, DEFAULT, seen)
    samples = seen.samples
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
