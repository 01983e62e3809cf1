"""Where a RATTLE fall's steps go: how long they are, through the fall, with and without
the energy bound.

    python benchmarks/probes/rattle_steps.py --segments 256,1024 --starts 0 --etol default,0
    python benchmarks/probes/rattle_steps.py --segments 256,1024 --starts 0 --attempts
    python benchmarks/probes/rattle_steps.py --segments 256,512 --starts 0,1 --landings
    python benchmarks/probes/rattle_steps.py --segments 1024,4096 --starts 0 --dt 0.2 --etol default,1e-6,0

For each N, random start (seed 2026, spawn key k, alpha = pi/4, floor ``all``) and bound
(``default``: the method's ``--step-energy-tol``; ``0``: no bound, the steps shortened only
by the turn limit, the landing cuts and by stages that fail), at the ceiling ``--dt``
(t_ff/N; default: the method's): the steps a fall takes per segment, the share
of its steps at the longest size (``--dt`` t_ff/N) and the share of its time they cover,
and the mean step over the longest in each tenth of t_ff.  The step sizes are the
differences of the result's trace times (one per accepted step).  Machine and versions
first.

``--attempts``: instead, the fall's attempts of a step by kind (accepted without an impact,
accepted with one, refused and taken again shorter), each kind's number per segment, its
block factorisations (whole or partial, counted alike) and stage 1's Newton evaluations,
the share of each kind that the turn limit shortened (its test, made before each attempt),
stage 1's active-set rounds (and how many of them ended early, a limit or the floor found
passed by far more than the iterate's residual: ``stage1``), and for the smooth steps how
many took 1, 2, 3 or 4 factorisations.  A diagnostic of the method's internals: the fall is
watched attempt by attempt (``engine.simulate(observer=)``, ``methods.rattle.driver.StepObserver``),
and its counters (the step's ledger, ``state.StepLedger``) are read after each.

``--landings``: instead, one fall with each ``--landing-step`` (whole, cut): the points
anchored, how many of them in a step taken again cut at its touch, the accepted steps and
the Newton evaluations per segment, their ratio cut / whole, t_fall/t_ff (the two
falls part: single falls are chaotic), and the attempts of a step that follow a landing's
own short step (cut): the share refused and their Newton evaluations each.  Read at each attempt of a step, as ``--attempts``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1]))  # benchmarks/: machine.py, compare_revisions.py
from machine import machine_info  # noqa: E402

from ballchain.engine import simulate  # noqa: E402
from ballchain.model import ChainParams, InitialCondition, SolverOptions  # noqa: E402


def _options(dt: float | None, **kw) -> SolverOptions:
    """The method's options, its ceiling ``dt`` (t_ff/N; None: its default)."""
    return SolverOptions(method="rattle", **kw) if dt is None else SolverOptions(method="rattle", dt=dt, **kw)


def steps_of(n: int, key: int, etol: float | None, dt: float | None = None) -> dict:
    """One fall's step sizes, summarised."""
    options = _options(dt, step_energy_tol=etol)
    r = simulate(
        ChainParams(segments=n, alpha=np.pi / 4), InitialCondition(kind="random", seed=2026, spawn_key=(key,)), options
    )
    h = np.diff(r.t)
    h_max = options.for_segments(n).dt * r.t_ff / n
    q = h / h_max
    tt = r.t[1:] / r.t_ff
    by_tenth = [float(q[(tt >= a / 10) & (tt < (a + 1) / 10)].mean()) for a in range(10)]
    full = q >= 0.999
    return dict(
        status=r.status,
        ratio=r.t_fall / r.t_ff,
        steps_per_n=h.size / n,
        full_steps=float(full.mean()),
        full_time=float(h[full].sum() / h.sum()),
        by_tenth=by_tenth,
        imbalance=r.energy["imbalance"] / r.energy["initial"],
    )


def fall_by_attempts(n: int, key: int, options: SolverOptions, observer):
    """One fall (random start of seed 2026, spawn key ``key``, alpha = pi/4) watched attempt
    by attempt by ``observer`` (``methods.rattle.driver.StepObserver``: read-only views of
    the fall's bundles before and after each attempt of a step).  Returns the result."""
    return simulate(
        ChainParams(segments=n, alpha=np.pi / 4),
        InitialCondition(kind="random", seed=2026, spawn_key=(key,)),
        options,
        observer=observer,
    )


def _turn_limited(seen) -> bool:
    """Will the next attempt be shortened by the turn limit (``stepper.step``: the step
    h / 2^level turns the fastest segment not landed by more than TURN_MAX)?"""
    from ballchain.methods.rattle.state import active_points
    from ballchain.methods.rattle.stepper import TURN_MAX, _fastest_turn

    mo = seen.fall.motion
    return (
        seen.h / 2.0 ** seen.fall.control.level[0] * _fastest_turn(mo.ve[: active_points(mo.anchored) - 1]) > TURN_MAX
    )


class _Attempts:
    """Each attempt's row (``--attempts``): accepted, its factorisations and Newton
    iterations, whether it had an impact, whether the turn limit shortened it, stage 1's
    rounds and those ended early."""

    def __init__(self):
        self.rows, self.steps, self.turn = [], 0, False

    def before(self, t, seen):
        self.steps, self.turn = int(seen.books.n_steps[0]), _turn_limited(seen)

    def after(self, t, seen, code):
        lg = seen.fall.scratch.ledger
        accepted = int(seen.books.n_steps[0]) > self.steps
        counts = (lg.factorisations[0], lg.newton_iterations[0], lg.impact[0] > 0, self.turn)
        self.rows.append((accepted, *counts, lg.stage1_rounds[0], lg.rounds_ended_early[0]))


def attempts_of(n: int, key: int, dt: float | None = None) -> dict:
    """One fall at the defaults (but the ceiling ``dt``), its attempts of a step by kind
    (``--attempts``), and which of them the turn limit shortened."""
    seen = _Attempts()
    r = fall_by_attempts(n, key, _options(dt), seen)
    a = np.array(seen.rows, dtype=float)
    ok, impact, turn = a[:, 0] > 0, a[:, 3] > 0, a[:, 4] > 0
    fac, evals, rounds, early = a[:, 1], a[:, 2], a[:, 5], a[:, 6]
    kinds = {"smooth": ok & ~impact, "impact": ok & impact, "refused": ~ok}
    return dict(
        status=r.status,
        per_step=fac.sum() / ok.sum(),
        kinds={
            k: (
                m.sum() / n,
                fac[m].mean(),
                fac[m].sum() / fac.sum(),
                evals[m].mean(),
                turn[m].mean(),
                rounds[m].mean(),
                early[m].mean(),
            )
            for k, m in kinds.items()
        },
        smooth_split=[float((fac[kinds["smooth"]] == f).mean()) for f in (1, 2, 3, 4)],
    )


def _header(*cells: str) -> None:
    """A markdown table's head, after a blank line."""
    print("\n| " + " | ".join(cells) + " |")
    print("|" + "---|" * len(cells))


def landings_of(n: int, key: int, how: str) -> dict:
    """One fall with ``--landing-step how``: its points anchored, those anchored in a step
    cut at a touch (the accepted step's control.last_how > 0), the steps taken again to be
    cut at their touch (a landing not foreseen), its accepted steps and Newton evaluations,
    and the attempts that follow a landing's own short step (last_how = 2 before them):
    their number, how many were refused, and their Newton evaluations."""
    seen = _Landings()
    r = fall_by_attempts(n, key, SolverOptions(method="rattle", landing_step=how), seen)
    return dict(status=r.status, ratio=r.t_fall / r.t_ff, steps=r.n_steps, evals=r.n_evals, **seen.count)


class _Landings:
    """The counts of ``landings_of``, attempt by attempt."""

    def __init__(self):
        self.count = {"anchored": 0, "in_cut": 0, "retaken": 0, "after": 0, "after_refused": 0, "after_evals": 0.0}

    def before(self, t, seen):
        control = seen.fall.control
        self.anchored = int((seen.fall.motion.anchored > 0).sum())
        self.steps = int(seen.books.n_steps[0])
        self.pending, self.after_landing = control.touch_cut[0], control.last_how[0] == 2

    def after(self, t, seen, code):
        count, control = self.count, seen.fall.control
        accepted = int(seen.books.n_steps[0]) > self.steps
        if accepted:
            new = int((seen.fall.motion.anchored > 0).sum()) - self.anchored
            count["anchored"] += new
            count["in_cut"] += new if control.last_how[0] > 0 else 0
        elif control.touch_cut[0] > 0.0 and self.pending == 0.0 and code == 0:
            count["retaken"] += 1
        if self.after_landing:
            count["after"] += 1
            count["after_refused"] += 0 if accepted else 1
            count["after_evals"] += seen.fall.scratch.ledger.newton_iterations[0]


def print_landings(segments, starts) -> None:
    _header(
        "N",
        "start",
        "landing step",
        "status",
        "t_fall/t_ff",
        "points anchored",
        "in a cut step",
        "steps taken again at a touch",
        "steps / N",
        "evaluations / N",
        "steps, cut / whole",
        "evaluations, cut / whole",
        "attempts after a landing's own step: refused, evaluations each",
    )
    for n in segments:
        for key in starts:
            w = landings_of(n, key, "whole")
            for how, s in (("whole", w), ("cut", landings_of(n, key, "cut"))):
                print(
                    f"| {n} | {key} | {how} | {s['status']} | {s['ratio']:.4f} | {s['anchored']} | {s['in_cut']} | {s['retaken']} | "
                    f"{s['steps'] / n:.1f} | {s['evals'] / n:.1f} | {s['steps'] / w['steps']:.3f} | "
                    f"{s['evals'] / w['evals']:.3f} | "
                    + (
                        f"{s['after_refused'] / s['after']:.2f}, {s['after_evals'] / s['after']:.1f} |"
                        if s["after"]
                        else " |"
                    )
                )


def print_attempts(segments, starts, dt) -> None:
    _header(
        "N",
        "start",
        "factorisations per accepted step",
        "kind",
        "per N",
        "factorisations each",
        "share of all",
        "Newton evaluations each",
        "shortened by the turn limit",
        "stage 1's rounds each, ended early",
        "smooth: 1, 2, 3, 4 factorisations",
    )
    for n in segments:
        for key in starts:
            s = attempts_of(n, key, dt)
            for kind, (per_n, each, share, ev, turn, rnds, early) in s["kinds"].items():
                split = ", ".join(f"{v:.2f}" for v in s["smooth_split"]) if kind == "smooth" else ""
                print(
                    f"| {n} | {key} | {s['per_step']:.2f} | {kind} | {per_n:.1f} | {each:.2f} | {share:.2f} | {ev:.2f} | "
                    f"{turn:.2f} | {rnds:.2f}, {early:.2f} | {split} |"
                )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", default="256")
    ap.add_argument("--starts", default="0", help="spawn keys: 0 or 0,1")
    ap.add_argument("--etol", default="default,0", help="bounds: default (the method's) and/or numbers (E0)")
    ap.add_argument("--attempts", action="store_true", help="the attempts of a step by kind, at the defaults")
    ap.add_argument("--landings", action="store_true", help="the landings with each --landing-step")
    ap.add_argument("--dt", type=float, default=None, help="the ceiling (t_ff/N; default: the method's)")
    a = ap.parse_args()
    print(machine_info())
    if a.landings:
        print_landings([int(s) for s in a.segments.split(",")], [int(s) for s in a.starts.split(",")])
        return
    if a.attempts:
        print_attempts([int(s) for s in a.segments.split(",")], [int(s) for s in a.starts.split(",")], a.dt)
        return
    print(
        "\n| N | start | bound | status | t_fall/t_ff | steps / N | steps at the longest | their time | imbalance / E0 | "
        + " | ".join(f"h/h_max at {k / 10:.1f}" for k in range(10))
        + " |"
    )
    print("|" + "---|" * 19)
    for n in (int(s) for s in a.segments.split(",")):
        for key in (int(s) for s in a.starts.split(",")):
            for e in a.etol.split(","):
                s = steps_of(n, key, None if e == "default" else float(e), a.dt)
                tenths = " | ".join(f"{v:.2f}" for v in s["by_tenth"])
                print(
                    f"| {n} | {key} | {e} | {s['status']} | {s['ratio']:.4f} | {s['steps_per_n']:.1f} | "
                    f"{s['full_steps']:.2f} | {s['full_time']:.2f} | {s['imbalance']:+.1e} | {tenths} |"
                )


if __name__ == "__main__":
    main()
