"""One run of the Moreau-Jean time-stepping method, driven from Python: the bundles
allocated, the compiled loop (``stepper.run_steps``) called until the fall ends, its
codes turned into a status and a message.  The step is ``SolverOptions.dt`` in units of
t_ff / N (the time a segment takes to land at the end of the fall is about t_ff / 2N)."""

from __future__ import annotations

from ...core.state import new_books, new_chain, new_model, new_work
from ...floors.registry import FLOOR_CODES
from ..outputs import (
    FrameBuffer,
    LogBuffer,
    LoopCodes,
    RunOutput,
    TraceBuffer,
    drive,
    loop_verdict,
)
from . import DT_RULES
from .stepper import (
    ERR_ENERGY,
    ERR_IMPACT,
    ERR_NAN,
    TS_BUFFER,
    TS_LANDED,
    TS_MAX_STEPS,
    TS_RETURN,
    TS_STOP,
    kinetic_energy_maximal,
    new_frame_work,
    new_scratch,
    run_steps,
)

RETURN_EVERY = 2048  # steps taken in compiled code between returns to Python (progress)

LOOP_CODES = LoopCodes(TS_STOP, TS_BUFFER, TS_RETURN, TS_LANDED, TS_MAX_STEPS)
ERROR_MESSAGES = {
    ERR_IMPACT: "the impact problem of a step did not converge",
    ERR_ENERGY: "a step's impact raised the kinetic energy",
    ERR_NAN: "non-finite state (blow-up)",
}


def step_size(setup) -> float:
    """The step h (sqrt(b/g)) of ``setup``: dt t_ff / N (under dt_rule landing, the step
    at the end of a free fall; the stepper scales it with the chain's speed)."""
    return setup.options.dt * setup.t_ff / setup.params.segments


def run(setup, progress, stop) -> RunOutput:
    """The fall of ``setup`` (``engine.Setup``) by Moreau-Jean time-stepping.
    ``progress(t, chain, log, books)`` is called on each return from compiled code;
    ``stop.reason`` (not None) asks the run to stop there (status ``interrupted``)."""
    p, o, n = setup.params, setup.options, setup.params.segments
    model = new_model(
        p.alpha,
        FLOOR_CODES[p.floor],
        p.anchor_cone,
        o,
        setup.t_stop,
        0.0,
        RETURN_EVERY,
        DT_RULES[o.dt_rule],
        setup.t_ff,
        laws=p,
    )
    chain = new_chain(setup.e0, setup.w0, p.alpha)
    ws, sc, books = new_work(n), new_scratch(n, setup.w0, setup.e0), new_books()
    fw = new_frame_work(n)
    frames = FrameBuffer(n, setup.t_ff / o.frames_per_tff, setup.t_stop * o.frames_per_tff / setup.t_ff)
    trace, log = TraceBuffer(setup.z0), LogBuffer()
    h = step_size(setup)

    def advance(t):
        code, t = run_steps(t, h, model, chain, ws, sc, fw, books, frames.compiled, trace.compiled, log.compiled)
        where = f"at t/t_ff = {t / setup.t_ff:.6f}"
        if code == ERR_ENERGY:
            where = f"by {-sc.removed[0]:.3g} (units m g b) {where}"
        return loop_verdict(code, t, LOOP_CODES, ERROR_MESSAGES, where, o.max_steps)

    out = RunOutput("landed", "", 0.0, chain, books, frames, trace, log)
    state = {"chain": chain, "work": ws, "scratch": sc, "frame_work": fw, "books": books}
    out = drive(setup, progress, stop, advance, out, 4 * (3 * n + 8), state)
    out.kinetic = float(kinetic_energy_maximal(sc.vmax, chain.Y[1]))
    return out


__all__ = ["run", "step_size"]
