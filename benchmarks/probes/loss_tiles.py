"""The bias of RATTLE's losses at a step, without the chaos: a fall cut into short windows,
each window stepped again from the same state at several steps, the differences summed.

    python benchmarks/probes/loss_tiles.py --segments 512 --starts 0-3 --dts 0.1:1e-6,0.05,0.025 --ref 0.003125

Single falls are chaotic: two falls from one start at two steps part after a few locks,
and ensembles compare their losses only to the chaos's scale (0.01 E0 at 64 starts).  Here
one RATTLE fall at the default step (random start, seed 2026, spawn key k, alpha = pi/4,
floor all) is the base, its steps cut to end on the times i L (L = ``--window`` t_ff/N),
until it has landed.  At each i L the method's bundles are copied, and the copy is stepped
to (i + 1) L at every step of ``--dts`` and at the reference ``--ref`` (``dt`` in t_ff/N,
or ``dt:step_energy_tol``, else the method's bound; the copy's first step no longer than the
base fall's step there, as a fall at that step would have sized it, or whole with ``--whole``).  Each
window's losses at the hinges (E_lock) and at the floor (E_land) are read from the copy's
books (a window in which some step failed even at its shortest is left out, and counted).  A window is short, so the copies stay together, and the sum over the windows of a
step's losses minus the reference's is the step's bias over one fall, with the chaos's
part left out: what a window's error does to the falls after it is not in it (in the mean
over many falls those differences are the chaos's; the energy books close in each window).

Prints the machine, then per start and step, in E0: the windows' sums of E_lock, E_land
and both, minus the reference's (with the standard error of the sum, the windows taken as
independent), then per step the mean over the starts and its standard error over them.
With ``--dts`` holding ``--ref``/2 the reference's own error shows.  ``--biggest K``: each
sum split into the K windows whose E_land differs most from the reference's and the rest.
A step written ``dt:cut`` or ``dt:step_energy_tol:cut`` takes its landing steps cut at the
touch (``--landing-step cut``, the method's default), one without ``:cut`` whole
(``--landing-step whole``); the base fall takes its landing steps whole.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1]))  # benchmarks/: machine.py, compare_revisions.py
from lock_distance import _keys  # noqa: E402
from machine import machine_info  # noqa: E402
from rattle_steps import fall_by_attempts  # noqa: E402

from ballchain.core.kinds import LOG_LANDING, LOG_LOCK, LOG_UNLOCK  # noqa: E402
from ballchain.core.state import new_frames, new_log, new_trace  # noqa: E402
from ballchain.methods.rattle import STEP_ENERGY_TOL  # noqa: E402
from ballchain.methods.rattle.codes import RT_LANDED, RT_STOP  # noqa: E402
from ballchain.methods.rattle.state import new_frame_books, new_step_control  # noqa: E402
from ballchain.methods.rattle.stepper import run_steps  # noqa: E402
from ballchain.model import SolverOptions  # noqa: E402

DEFAULT = SolverOptions(method="rattle", landing_step="whole")  # the base fall (its windows' copies: by their specs)


def _copy(x):
    """A deep copy of a bundle (namedtuples or tuples of arrays, nested; a plain tuple is
    copied too, not passed through: a copy that shares arrays would step the fall itself)."""
    if isinstance(x, np.ndarray):
        return x.copy()
    if isinstance(x, tuple):
        items = [_copy(v) for v in x]
        return type(x)(*items) if hasattr(x, "_fields") else tuple(items)
    return x


def window_losses(
    snap,
    t0: float,
    h: float,
    t_end: float,
    etol_abs: float | None,
    h_now: float | None,
    cut: bool = False,
    events: list | None = None,
) -> tuple[float, float]:
    """Copies of the bundles ``snap`` (model, fall, books: ``driver.ObservedFall``'s) stepped
    from t0 to t_end at step h, with a step control of their own: (E_lock, E_land) over
    the window (m g b), NaN if a step failed.  ``etol_abs``: the energy bound per step (None:
    the fall's); ``h_now``: the first step is no longer than this (the base fall's step at
    t0), None: the first step is h; ``cut``: landing steps cut at the touch (``--landing-step cut``);
    ``events``: a list that gets the window's locks, unlocks and landings (t, kind, index, energy)."""
    model, fall, books = (_copy(x) for x in snap)
    model = model._replace(t_stop=t_end, return_every=np.int64(10**9))
    n = fall.motion.e.shape[0]
    c = fall.control
    level = 0.0 if h_now is None else max(0.0, math.log2(h / h_now))  # (the step is h / 2^level)
    bound = c.energy_bound[0] if etol_abs is None else etol_abs
    control = new_step_control(bound, cut, c.extra_cuts[0], level)  # (no cut pending, none before)
    fall = fall._replace(control=control, frame_books=new_frame_books(fall.motion.e.shape[0]))  # (no frame pending)
    frames = new_frames(n, math.inf, 16)
    frames.next[0] = math.inf
    trace, log = new_trace(1 << 16), new_log(1 << 16)
    lk0, ld0 = float(books.lost_locking[0]), float(books.lost_landing[0])
    t = t0
    while True:
        code, t = run_steps(t, h, model, fall, books, frames, trace, log)
        if events is not None:
            events += [
                (float(log.t[i]), int(log.kind[i]), int(log.index[i]), float(log.energy[i]))
                for i in range(int(log.n[0]))
                if log.kind[i] in (LOG_LOCK, LOG_UNLOCK, LOG_LANDING)
            ]
        if code in (RT_STOP, RT_LANDED):
            break
        if code < 0:  # (a step that failed even at its shortest: the window is left out)
            return math.nan, math.nan
        trace.count[0], log.n[0] = 0, 0
    return float(books.lost_locking[0]) - lk0, float(books.lost_landing[0]) - ld0


def _step(spec: str) -> tuple[float, float | None, bool]:
    """``dt``, ``dt:step_energy_tol`` (t_ff/N; E0), either followed by ``:cut`` (landing
    steps cut at the touch): (dt, the bound or None, cut)."""
    parts = spec.split(":")
    cut = parts[-1] == "cut"
    if cut:
        parts = parts[:-1]
    etol = parts[1] if len(parts) > 1 else ""
    return float(parts[0]), float(etol) if etol else None, cut


def tiles(
    n: int, key: int, steps: list[str], window: float, whole: bool, events: list | None = None
) -> tuple[np.ndarray, float]:
    """One start's windows: an array (windows, steps, 2) of (E_lock, E_land) / E0 at each
    step of ``steps`` (``_step``), and the base fall's t_fall / t_ff.  ``whole``: each
    window's first step is the step compared, whole (else no longer than the base's there).
    ``events``: a list that gets, per window, the hinges locked at its start and per step
    its events (``window_losses``), times in t_ff/N from the window's start, energies in E0."""
    seen = _Windows(n, steps, window, whole, events)
    r = fall_by_attempts(n, key, DEFAULT, seen)
    if r.status != "landed":
        raise SystemExit(f"start {key}: the base fall ended {r.status} ({r.message})")
    return np.array(seen.rows) / r.energy["initial"], r.t_fall / r.t_ff


class _Windows:
    """The base fall paused on the windows' times (the pause ``before`` names: the window's
    end), each window stepped again from its start at every step of ``steps`` (``tiles``)."""

    def __init__(self, n: int, steps: list[str], window: float, whole: bool, events: list | None):
        self.n, self.steps, self.window, self.whole, self.events = n, steps, window, whole, events
        self.rows, self.next, self.unit = [], None, None

    def before(self, t, seen):
        if self.unit is None:  # (the first attempt: h is the default dt in t_ff / N)
            self.unit, self.next = seen.h / DEFAULT.for_segments(self.n).dt, 0.0
        if t >= self.next * (1.0 - 1e-14) - 1e-14:  # a window starts here: step copies through it
            self.next = self._window(t, seen)
        return self.next

    def after(self, t, seen, code):
        pass

    def _window(self, t, seen) -> float:
        """The window from t: its losses at each step; returns its end."""
        t_end = t + self.window * self.unit
        snap = (seen.model, seen.fall, seen.books)
        control = seen.fall.control
        e0 = control.energy_bound[0] / STEP_ENERGY_TOL  # (the fall's bound: the default's times E0)
        row, logs = [], []
        for dt, etol, cut_at_touch in map(_step, self.steps):
            bound = None if etol is None else etol * e0
            h_now = None if self.whole else seen.h / 2.0 ** control.level[0]
            logs.append([])
            row.append(window_losses(snap, t, dt * self.unit, t_end, bound, h_now, cut_at_touch, logs[-1]))
        if self.events is not None:
            rel = [[((u - t) / self.unit, k, j, en / abs(e0)) for u, k, j, en in log] for log in logs]
            self.events.append((seen.fall.motion.locked.copy(), rel))
        self.rows.append(row)
        return t_end


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=512)
    ap.add_argument("--starts", default="0", help="spawn keys: 0-3 or 0,2")
    ap.add_argument(
        "--dts",
        default="0.1:1e-6,0.05,0.025",
        help="steps compared: dt or dt:step_energy_tol (t_ff/N), either with :cut (landing steps cut)",
    )
    ap.add_argument("--ref", default="0.003125", help="the reference step, dt or dt:step_energy_tol")
    ap.add_argument(
        "--events",
        action="store_true",
        help="with --biggest: the landings in those windows by what the hinge above the landed point does",
    )
    ap.add_argument("--window", type=float, default=1.0, help="the windows' length (t_ff/N)")
    ap.add_argument(
        "--whole",
        action="store_true",
        help="start each window's steps whole (default: at most the base fall's step there)",
    )
    ap.add_argument(
        "--biggest",
        type=int,
        default=0,
        help="also split each sum: the K windows whose E_land differs most from the reference's, and the rest",
    )
    a = ap.parse_args()
    print(machine_info())
    dts = a.dts.split(",")
    keys = _keys(a.starts)
    print(
        f"\nN = {a.segments}, windows of {a.window} t_ff/N: the windows' losses summed over the fall, each step's "
        f"minus the reference's ({a.ref} t_ff/N), in E0 (+- the sum's standard error)\n"
    )
    print("| start | t_fall/t_ff | windows | step | E_lock | E_land | both |")
    print("|---|---|---|---|---|---|---|")
    per_start = {dt: [] for dt in dts}
    split_rows, seq_rows = [], []
    for key in keys:
        logs = [] if a.events else None
        w, ratio = tiles(a.segments, key, [*dts, a.ref], a.window, a.whole, logs)
        failed = np.isnan(w).any(axis=(1, 2))
        if failed.any():
            print(f"  start {key}: {failed.sum()} of {len(w)} windows left out (a step failed in them)", flush=True)
        w = w[~failed]
        ref = w[:, -1, :]
        for i, dt in enumerate(dts):
            d = w[:, i, :] - ref
            d = np.column_stack([d, d.sum(axis=1)])
            s, se = d.sum(axis=0), d.std(axis=0, ddof=1) * math.sqrt(len(d))
            per_start[dt].append(s)
            if a.biggest > 0:
                split_rows.append((key, dt, *_biggest_windows(d, ref, a.biggest)))
                if logs is not None:
                    few = np.flatnonzero(~failed)[np.argsort(-np.abs(d[:, 1]))[: a.biggest]]
                    seq_rows.append(
                        (key, dt, *(sum(landing_sequences(logs[f][0], logs[f][1][c]) for f in few) for c in (i, -1)))
                    )
            cells = " | ".join(f"{x:+.5f} +- {e:.5f}" for x, e in zip(s, se))
            print(f"| {key} | {ratio:.4f} | {len(w)} | {dt} | {cells} |", flush=True)
    if len(keys) > 1:
        print(f"\nMeans over the {len(keys)} starts (+- their standard error), in E0:\n")
        print("| step | E_lock | E_land | both |")
        print("|---|---|---|---|")
        for dt in dts:
            v = np.array(per_start[dt])
            m, se = v.mean(axis=0), v.std(axis=0, ddof=1) / math.sqrt(len(v))
            print(f"| {dt} | " + " | ".join(f"{x:+.5f} +- {e:.5f}" for x, e in zip(m, se)) + " |")
    if split_rows:
        print(
            f"\nThe {a.biggest} windows of each fall whose E_land differs most from the reference's, and the "
            "rest: the sums minus the reference's (E0), where the few lie in the fall (their windows' mean "
            "position, 0 its start, 1 its end) and their share of the reference's E_land\n"
        )
        print(
            "| start | step | few: E_lock | few: E_land | few: both | rest: E_lock | rest: E_land | rest: both | where | share |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|")
        for key, dt, few, rest, where, share in split_rows:
            cells = " | ".join(f"{x:+.5f}" for x in (*few, *rest))
            print(f"| {key} | {dt} | {cells} | {where:.2f} | {share:.2f} |")
    if seq_rows:
        print(
            "\nIn those windows, the landings by what the hinge just above the landed point does, at the step "
            "and at the reference: (a) open at the touch, locked within 0.1 t_ff/N after (number, that lock's "
            "loss, E0); (b) locked at the touch (number, the landings' loss); (c) open, no lock after (number, "
            "the landings' loss)\n"
        )
        print("| start | step | (a) | (b) | (c) | reference: (a) | (b) | (c) |")
        print("|---|---|---|---|---|---|---|---|")
        total = {}
        for key, dt, at_step, at_ref in seq_rows:
            total[dt] = total.get(dt, 0) + np.stack([at_step, at_ref])
            print(f"| {key} | {dt} | {_sequence_cells(at_step)} | {_sequence_cells(at_ref)} |")
        for dt, (at_step, at_ref) in total.items():
            print(f"| all | {dt} | {_sequence_cells(at_step)} | {_sequence_cells(at_ref)} |")


def _sequence_cells(c: np.ndarray) -> str:
    """``landing_sequences``' three classes as table cells: number, loss."""
    return " | ".join(f"{int(n)}, {e:.4f}" for n, e in c)


def landing_sequences(locked0: np.ndarray, events: list, reach: float = 0.1) -> np.ndarray:
    """A window's landings by what the hinge just above the landed point (hinge j - 2, at
    point j - 1) does: [number, its loss] for (a) open at the touch and locked within
    ``reach`` t_ff/N after it (the lock the landing makes: its E_lock), (b) locked at the
    touch (its loss in the landing's impact: the landing's E_land), (c) open and not locked
    within ``reach`` (the landing's E_land).  ``events``: (t, kind, index, energy), in order."""
    out = np.zeros((3, 2))
    for i, (t_land, kind, j, e_land) in enumerate(events):
        k = j - 2
        if kind != LOG_LANDING or k < 0:
            continue
        locked = bool(locked0[k])
        for u, kk, idx, _ in events[:i]:
            if idx == k and kk in (LOG_LOCK, LOG_UNLOCK) and u <= t_land:
                locked = kk == LOG_LOCK
        after = [en for u, kk, idx, en in events[i + 1 :] if idx == k and kk == LOG_LOCK and u - t_land <= reach]
        c = 1 if locked else (0 if after else 2)
        out[c] += (1.0, after[0] if c == 0 else e_land)
    return out


def _biggest_windows(d: np.ndarray, ref: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The windows' differences d (windows, 3: E_lock, E_land, both) split into the k windows
    with the largest |E_land| difference and the rest: the two sums, the few's mean position
    in the fall (window index / windows) and their share of the reference's E_land."""
    few = np.argsort(-np.abs(d[:, 1]))[:k]
    rest = np.setdiff1d(np.arange(len(d)), few)
    return (
        d[few].sum(axis=0),
        d[rest].sum(axis=0),
        float(few.mean() / len(d)),
        float(ref[few, 1].sum() / ref[:, 1].sum()),
    )


if __name__ == "__main__":
    main()
