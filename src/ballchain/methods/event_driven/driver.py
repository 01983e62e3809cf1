"""One run of the event-driven method, driven from Python: the bundles allocated, the
compiled loop (``events.run_events``) called until the fall ends, its codes turned into
a status and a message.  The compiled loop returns here every ``RETURN_EVERY`` event
instants (progress, a stop request), when a buffer fills, or at the end."""

from __future__ import annotations

import math

import numpy as np

from ...contacts.coulomb import slides
from ...core.base import set_base
from ...core.dynamics import accelerations
from ...core.impacts import hinge_gaps
from ...core.rules import SLIDING
from ...core.state import new_books, new_chain, new_model, new_work
from ...core.unilateral import vertical_multipliers
from ...floors.registry import FLOOR_CODES
from ..outputs import (
    FLUSH,
    GO_ON,
    LANDED,
    STOPPED,
    FrameBuffer,
    LogBuffer,
    RunOutput,
    SimulationError,
    TraceBuffer,
    drive,
)
from .events import (
    ERR_ENERGY,
    ERR_IMPACT_LCP,
    ERR_LOCK_LCP,
    ERR_MAX_EVENTS,
    ERR_ZENO,
    EV_LANDED,
    EV_RETURN,
    ZENO_EVENTS,
    log_room,
    new_instant,
    run_events,
)
from .integrator import ADV_BUFFER, ADV_FAIL_NAN, ADV_FAIL_STEP, ADV_MAX_STEPS, ADV_STOP, new_stepper
from .slides import energies
from .watch import arm_functions, new_watch

LOOSE_RTOL = 1e-7  # an impact that fails above this tolerance gets a hint to tighten it
RETURN_EVERY = 256  # events handled in compiled code between returns to Python (progress)
ZENO_WINDOW = 1e-9  # in units of t_ff: ZENO_EVENTS event instants within it stop the run
H0 = 1e-3  # first step size tried (sqrt(b/g))

ERROR_MESSAGES = {
    ERR_IMPACT_LCP: "impact LCP did not converge",
    ERR_ENERGY: "an impact raised the kinetic energy",
    ERR_LOCK_LCP: "lock-set LCP did not converge",
}


def _failure(code: int, t: float, h: float, t_ff: float, options) -> str | None:
    """The message of a code that ends the run in failure (None: not a failure)."""
    at = f"at t/t_ff = {t / t_ff:.6f}"
    if code == ADV_FAIL_NAN:
        return f"non-finite state (blow-up) {at}"
    if code == ADV_FAIL_STEP:
        return f"step size underflow (h = {h:.3g}) {at}"
    if code == ADV_MAX_STEPS:
        return f"more than max_steps = {options.max_steps} steps {at}"
    if code == ERR_ZENO:
        return (
            f"event accumulation: {ZENO_EVENTS} events within {ZENO_WINDOW:.3g} t_ff before t/t_ff = "
            f"{t / t_ff:.6f} (Zeno); stopping"
        )
    if code == ERR_MAX_EVENTS:
        return f"more than max_events = {options.max_events} events; stopping"
    if code in ERROR_MESSAGES:
        hint = (
            f" (rtol = {options.rtol:g} is loose: the state reaching the impact is not accurate "
            f"enough; tighten it, e.g. --rtol 1e-9)"
            if options.rtol > LOOSE_RTOL
            else ""
        )
        return f"{ERROR_MESSAGES[code]} at t = {t:.17g}{hint}"
    return None


def _arm(model, chain, watch, ws, sc, books) -> None:
    """Arm the event functions of the starting state (on a frictionless floor the floor's
    force on the sliding bottom end too)."""
    hinge_gaps(chain.Y[0], model.cos_alpha, sc.hs.gaps)
    pz = np.zeros(chain.anchored.shape[0])
    if slides(model.friction):
        n = chain.Y.shape[1]
        accelerations(chain.Y[0], chain.Y[1], chain.anchored, chain.locked, ws, np.zeros((n, 3)), np.zeros((n, 3)))
        vertical_multipliers(ws.kind, ws.nrow, ws.x, pz)
    arm_functions(
        model,
        chain,
        watch,
        sc.hs.gaps,
        np.zeros_like(sc.acc.lam),
        pz,
        0.0,
        not math.isnan(books.t_fall[0]),
        np.zeros(chain.anchored.shape[0]),
    )


def _on_the_floor(chain, sc) -> None:
    """A frictionless floor: the bottom end slides (``rules.SLIDING``, not anchored), the
    chain's centre of mass moves as the state's (point N at the origin, at rest)."""
    n = chain.Y.shape[1]
    chain.anchored[n] = SLIDING
    chain.anchor_pos[n] = np.nan
    pt = sc.pt
    set_base(chain.Y[0], chain.Y[1], chain.anchored, chain.base, 0.0, pt.pts, pt.pv, pt.vel, np.zeros(3), np.zeros(3))


def run(setup, progress, stop) -> RunOutput:
    """The fall of ``setup`` (``engine.Setup``) by the event-driven method.  ``progress(t,
    chain, log, books)`` is called on each return from compiled code; ``stop.reason``
    (not None) asks the run to stop there (status ``interrupted``)."""
    p, o, n = setup.params, setup.options, setup.params.segments
    model = new_model(
        p.alpha,
        FLOOR_CODES[p.floor],
        p.anchor_cone,
        o,
        setup.t_stop,
        ZENO_WINDOW * setup.t_ff,
        RETURN_EVERY,
        laws=p,
    )
    chain = new_chain(setup.e0, setup.w0, p.alpha)
    watch, ws, st, sc, books = new_watch(n), new_work(n, model), new_stepper(n), new_instant(n), new_books()
    frames = FrameBuffer(n, setup.t_ff / o.frames_per_tff, setup.t_stop * o.frames_per_tff / setup.t_ff)
    trace, log = TraceBuffer(setup.z0), LogBuffer()
    if slides(model.friction):
        _on_the_floor(chain, sc)
    _arm(model, chain, watch, ws, sc, books)
    h = np.array([H0])  # the step size carried from one call of the compiled loop to the next

    def advance(t):
        code, t, h[0] = run_events(
            t, h[0], model, chain, watch, ws, st, sc, books, frames.compiled, trace.compiled, log.compiled
        )
        if code == ADV_BUFFER:
            return FLUSH, t
        if code == EV_LANDED:
            return LANDED, t
        failure = _failure(code, t, h[0], setup.t_ff, o)
        if failure is not None:
            raise SimulationError(failure)
        if code == ADV_STOP:
            return STOPPED, t
        if code != EV_RETURN:  # pragma: no cover - every code is handled above
            raise SimulationError(f"unknown code {code} from the compiled loop")
        return GO_ON, t

    out = RunOutput("landed", "", 0.0, chain, books, frames, trace, log)
    state = {"chain": chain, "watch": watch, "work": ws, "stepper": st, "instant": sc, "books": books, "h": h}
    out = drive(setup, progress, stop, advance, out, 4 * log_room(n), state)
    if slides(model.friction):  # (the energies at the end where point N is)
        en = np.zeros(2)
        energies(out.t, chain, sc.pt.pts, sc.pt.pv, sc.pt.vel, np.zeros((2, 3)), en)
        out.potential, out.kinetic = float(en[0]), float(en[1])
    return out
