"""One run of the nonsmooth RATTLE method, driven from Python: the bundles allocated, the
compiled loop (``stepper.run_steps``) called until the fall ends, its codes turned into a
status and a message.  The step is ``SolverOptions.dt`` in units of t_ff / N.

A run can be watched step by step: ``engine.simulate(..., observer=)`` takes a
``StepObserver``, whose ``before`` and ``after`` are called around every attempt of a
step (accepted or refused: the compiled loop then returns after each), with the fall's
bundles as read-only views (``ObservedFall``: they show the state as it is at the call).
The observer reads; it cannot write.  Its one say in the fall: ``before`` may name a time
at which the fall pauses, as at a stop time (its steps cut to end there), and goes on at
the next call: a fall so paused is not the fall without pauses.  Without pauses the fall
is the same, to every digit, observed or not (``benchmarks/probes``: ``rattle_steps.py``,
``lock_steps.py``, ``loss_tiles.py``, ``closed_stretch.py``)."""

from __future__ import annotations

from collections import namedtuple
from typing import Protocol

import numpy as np

from ...contacts.coulomb import grips, slides
from ...core.kinematics import rates_for_axes
from ...core.state import new_books, new_chain, new_model
from ...floors.registry import FLOOR_CODES
from ..outputs import (
    FrameBuffer,
    LogBuffer,
    LoopCodes,
    RunOutput,
    TraceBuffer,
    closed_stretch_note,
    drive,
    loop_verdict,
)
from . import STEP_ENERGY_TOL
from .codes import (
    ERR_ACTIVE_SET,
    ERR_NAN,
    ERR_NEWTON,
    ERR_STEP_ENERGY,
    ERR_STEP_NAN,
    RT_BUFFER,
    RT_LANDED,
    RT_MAX_STEPS,
    RT_RETURN,
    RT_STOP,
)
from .rows import new_rows
from .scheme import CUTS_MAX, extra_cuts
from .state import (
    Fall,
    Motion,
    base_at_origin,
    kinetic_energy_rattle,
    maximal_state,
    new_frame_books,
    new_frame_work,
    new_scratch,
    new_step_control,
)
from .stepper import run_steps

ROW_NAMES = {0: "joint", 1: "joint", 2: "joint", 3: "anchor", 4: "anchor", 5: "anchor", 6: "anchor", 7: "anchor",
             8: "anchor", 9: "axis", 10: "bend", 11: "floor", 12: "floor"}  # fmt: skip
RETURN_EVERY = 2048  # steps taken in compiled code between returns to Python (progress)

LOOP_CODES = LoopCodes(RT_STOP, RT_BUFFER, RT_RETURN, RT_LANDED, RT_MAX_STEPS)
ERROR_MESSAGES = {
    ERR_NEWTON: "stage 1 (the positions) did not meet its constraints within its Newton iterations",
    ERR_STEP_ENERGY: "a step changed U + T beyond --step-energy-tol even at its shortest",
    ERR_STEP_NAN: "a step's state was not finite even at its shortest (a singular stage)",
    ERR_ACTIVE_SET: "a stage's active set of limits and floor contacts did not settle",
    ERR_NAN: "non-finite state (blow-up)",
}

# What an observer is shown: read-only views of a fall's bundles (``state.Fall``), its books
# (``core.state.Books``), its model (``core.state.Model``) and its longest step h (dt t_ff/N,
# sqrt(b/g): a step is h / 2^fall.control.level at most).
ObservedFall = namedtuple("ObservedFall", ["h", "model", "fall", "books"])


class StepObserver(Protocol):
    """Watches a RATTLE fall step by step (``engine.simulate(..., observer=)``)."""

    def before(self, t: float, seen: ObservedFall) -> float | None:
        """Before an attempt of a step from t.  Returns None, or a time at which the fall
        is to pause (its steps cut to end there; it goes on at the next call)."""

    def after(self, t: float, seen: ObservedFall, code: int) -> None:
        """After it: t the time reached (the step's end if it was accepted, which
        ``seen.books.n_steps`` counts), ``code`` the loop's (``codes``: RT_*, or a negative ERR_*)."""


def read_only(bundle):
    """A bundle (namedtuples of arrays, nested) with every array a read-only view of its own."""
    if isinstance(bundle, np.ndarray):
        view = bundle.view()
        view.flags.writeable = False
        return view
    if isinstance(bundle, tuple) and hasattr(bundle, "_fields"):
        return type(bundle)(*(read_only(x) for x in bundle))
    return bundle


def observed_loop(observer: StepObserver, seen: ObservedFall):
    """``stepper.run_steps`` with ``observer`` called around it (the model returns after every attempt)."""

    def loop(t, h, model, fall, books, frames, trace, log):
        pause = observer.before(t, seen)
        paused = pause is not None and pause < model.t_stop
        code, t = run_steps(t, h, model._replace(t_stop=pause) if paused else model, fall, books, frames, trace, log)
        observer.after(t, seen, code)
        return (RT_RETURN if paused and code == RT_STOP else code), t

    return loop


def _control(setup):
    """The step control of a fall's first step (``state.StepControl``)."""
    o = setup.options
    etol = STEP_ENERGY_TOL if o.step_energy_tol is None else o.step_energy_tol
    return new_step_control(etol * abs(setup.E0), o.landing_step == "cut", extra_cuts(o.dt))


def _new_fall(setup, chain) -> Fall:
    """The fall's own bundles at its start: its motion in maximal coordinates beside the
    chain's axes, anchors and locks (their arrays), the rows, scratch and step control."""
    p, n = setup.params, setup.params.segments
    c, vc, ve = (np.zeros((n, 3)) for _ in range(3))
    maximal_state(chain.Y[0], chain.Y[1], c, vc, ve)
    touching, grip = np.zeros(n + 1, np.uint8), np.zeros((n + 1, 3))
    if slides(p.friction):  # a frictionless floor: the bottom end stands on it, free to slide
        chain.anchored[n], chain.anchor_pos[n], touching[n] = 0, np.nan, 1
    mo = Motion(c, chain.Y[0], vc, ve, chain.anchored, chain.anchor_pos, chain.anchor_t, chain.locked, touching, grip)
    return Fall(mo, new_rows(n), new_scratch(n), new_frame_work(n), _control(setup), new_frame_books(n))


def run(setup, progress, stop) -> RunOutput:
    """The fall of ``setup`` (``engine.Setup``) by nonsmooth RATTLE.
    ``progress(t, chain, log, books)`` is called on each return from compiled code;
    ``stop.reason`` (not None) asks the run to stop there (status ``interrupted``)."""
    p, o, n = setup.params, setup.options, setup.params.segments
    observer = getattr(setup, "observer", None)
    every = RETURN_EVERY if observer is None else 1
    model = new_model(
        p.alpha, FLOOR_CODES[p.floor], p.anchor_cone or grips(p.friction), o, setup.t_stop, 0.0, every, 0, setup.t_ff,
        laws=p,
    )  # fmt: skip
    chain = new_chain(setup.e0, setup.w0, p.alpha)
    fall = _new_fall(setup, chain)
    mo, sc = fall.motion, fall.scratch
    books = new_books()
    frames = FrameBuffer(n, setup.t_ff / o.frames_per_tff, setup.t_stop * o.frames_per_tff / setup.t_ff)
    trace, log = TraceBuffer(setup.z0), LogBuffer()
    h = o.dt * setup.t_ff / n
    loop = run_steps
    if observer is not None:
        loop = observed_loop(observer, ObservedFall(h, read_only(model), read_only(fall), read_only(books)))

    def advance(t):
        code, t = loop(t, h, model, fall, books, frames.compiled, trace.compiled, log.compiled)
        rates_for_axes(mo.e, mo.ve, chain.Y[1])  # w = e x de/dt
        where = f"at t/t_ff = {t / setup.t_ff:.6f}"
        shortest = f"--dt / 2^{CUTS_MAX + int(fall.control.extra_cuts[0])}"
        if code == ERR_NEWTON:
            j, kind, value = sc.unmet
            where += f" (point {int(j)}, its {ROW_NAMES.get(int(kind), 'row')} row off by {value:.3g}, the step at its shortest, {shortest})"
        elif code == ERR_STEP_ENERGY:
            where += f" ({shortest})" + closed_stretch_note(mo.e, mo.anchored, mo.locked, mo.anchor_pos, p.alpha)
        elif code == ERR_STEP_NAN:
            where += f" ({shortest})"
        elif code == ERR_ACTIVE_SET and sc.unmet[0] >= 0:
            where += f" (the last row it switched: point {int(sc.unmet[0])}, its {ROW_NAMES.get(int(sc.unmet[1]), 'row')} row)"
        return loop_verdict(code, t, LOOP_CODES, ERROR_MESSAGES, where, o.max_steps)

    out = RunOutput("landed", "", 0.0, chain, books, frames, trace, log)
    own = {"c": mo.c, "vc": mo.vc, "ve": mo.ve, "touching": mo.touching, "grip": mo.grip}  # (the rest: the chain's)
    state = {"chain": chain, "motion": own, "scratch": sc}
    state["rows"] = fall.rows  # (the last stage 2's rows and factors: the next stage 1 iterates on them)
    state["frame_scratch"] = fall.frame_work.sc
    state.update({"books": books, "control": fall.control, "frame_books": fall.frame_books})
    out = drive(setup, progress, stop, advance, out, 4 * (4 * n + 8), state)
    out.kinetic = float(kinetic_energy_rattle(mo.vc, mo.ve))
    if not base_at_origin(mo):  # (a floor that let the bottom end slide: it may have left the origin)
        out.potential = float(np.sum(mo.c[:, 2]))
    return out


__all__ = ["ObservedFall", "StepObserver", "observed_loop", "read_only", "run"]
