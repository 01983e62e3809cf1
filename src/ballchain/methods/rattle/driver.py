"""One run of the nonsmooth RATTLE method, driven from Python: the bundles allocated, the
compiled loop (``stepper.run_steps``) called until the fall ends, its codes turned into a
status and a message.  The step is ``SolverOptions.dt`` in units of t_ff / N."""

from __future__ import annotations

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
from .frames import FB_SIZE
from .rows import new_rows
from .scheme import CUTS_MAX, extra_cuts
from .state import Motion, base_at_origin, kinetic_energy_rattle, maximal_state, new_frame_work, new_scratch
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


def run(setup, progress, stop) -> RunOutput:
    """The fall of ``setup`` (``engine.Setup``) by nonsmooth RATTLE.
    ``progress(t, chain, log, books)`` is called on each return from compiled code;
    ``stop.reason`` (not None) asks the run to stop there (status ``interrupted``)."""
    p, o, n = setup.params, setup.options, setup.params.segments
    model = new_model(
        p.alpha, FLOOR_CODES[p.floor], p.anchor_cone or grips(p.friction), o, setup.t_stop, 0.0, RETURN_EVERY, 0, setup.t_ff,
        laws=p,
    )  # fmt: skip
    chain = new_chain(setup.e0, setup.w0, p.alpha)
    c, vc, ve = (np.zeros((n, 3)) for _ in range(3))
    maximal_state(chain.Y[0], chain.Y[1], c, vc, ve)
    touching, grip = np.zeros(n + 1, np.uint8), np.zeros((n + 1, 3))
    if slides(p.friction):  # a frictionless floor: the bottom end stands on it, free to slide
        chain.anchored[n], chain.anchor_pos[n], touching[n] = 0, np.nan, 1
    mo = Motion(c, chain.Y[0], vc, ve, chain.anchored, chain.anchor_pos, chain.anchor_t, chain.locked, touching, grip)
    ws, sc, fr = new_rows(n), new_scratch(n), new_frame_work(n)
    fb = np.zeros(FB_SIZE)
    etol = STEP_ENERGY_TOL if o.step_energy_tol is None else o.step_energy_tol
    fb[21] = etol * abs(setup.E0)
    fb[22] = 1.0 if o.landing_step == "cut" else 0.0
    fb[26] = extra_cuts(o.dt)
    books = new_books()
    frames = FrameBuffer(n, setup.t_ff / o.frames_per_tff, setup.t_stop * o.frames_per_tff / setup.t_ff)
    trace, log = TraceBuffer(setup.z0), LogBuffer()
    h = o.dt * setup.t_ff / n

    def advance(t):
        code, t = run_steps(t, h, model, mo, ws, sc, fr, fb, books, frames.compiled, trace.compiled, log.compiled)
        rates_for_axes(mo.e, mo.ve, chain.Y[1])  # w = e x de/dt
        where = f"at t/t_ff = {t / setup.t_ff:.6f}"
        shortest = f"--dt / 2^{CUTS_MAX + int(fb[26])}"
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
    state = {"chain": chain, "motion": {"c": c, "vc": vc, "ve": ve, "touching": touching, "grip": grip}, "scratch": sc}
    state["rows"] = ws  # (the last stage 2's rows and factors: the next stage 1 iterates on them)
    state["frame_scratch"] = fr.sc
    state.update({"books": books, "frame_info": fb})
    out = drive(setup, progress, stop, advance, out, 4 * (4 * n + 8), state)
    out.kinetic = float(kinetic_energy_rattle(vc, ve))
    if not base_at_origin(mo):  # (a floor that let the bottom end slide: it may have left the origin)
        out.potential = float(np.sum(c[:, 2]))
    return out


__all__ = ["run"]
