"""The event method's step loop (numba): Dormand-Prince 5(4) steps with dense output
(``dopri``), the events on each step found and located (``locate``), frames, projection
and re-arming after each step.

The whole step loop runs compiled (``advance``); it returns to Python only at an
event, at the stop time, when an output buffer is full, or on failure.  Nondimensional
units throughout (m = b = g = 1).

State: ``Y`` of shape (2, N, 3): ``Y[0]`` the unit axes e, ``Y[1]`` the angular
velocities w.

Event functions (each located by Brent's method on the dense output to ``xtol``):

  kind 1  lock       g_k = e_k . e_{k+1} - cos(alpha)     unlocked hinge whose limit is in force
  kind 2  unlock     lambda_k                              locked hinge
  kind 3  landing    rules.floor_value (floor "all": the height of every free point;
                     floor "pivot": e_M . e_z of the bottom airborne segment M)
  kind 4  top        z_0 (floor "pivot" only: t_fall, no state change)

How each function is watched is its arm state (``rules.arm_state``, arrays ``arm_*``):
ARMED functions are positive and fire when they reach zero; a DEPARTING function sits at
its zero after the event that put it there and is known to leave it (the event
handler has made its rate non-negative), so it fires only when it returns to zero
after having been positive, and that return is located like any other crossing: no
penetration margin delays an event.  A departing function becomes armed once a step
ends with it above ``rules.ZERO_BAND``.  One that has not yet been above it (a
constraint hovering at its limit: rate and acceleration both about zero) fires when it
sinks below ``-rules.ZERO_BAND``.  A step is checked at its end and its midpoint (armed
functions; an armed hinge also where the cubic through its gap and rate at the step's
ends has an interior minimum, ``_closest_approach``: a dip through the limit that
begins and ends inside the step), or at 16 points and at its predicted apex (departing functions that were
triggered; the event handler predicts where a departing constraint that accelerates
back peaks, ``events.apex_times``, so that a return within one step is seen positive
first and located as a crossing).  The sinking level is measured from where the
function started (``ref_*``: min(f, 0) after the event), since an event leaves it only
within round-off of its zero.

The step error is the largest component error over the state (a max norm), so its
meaning does not change with N.

``advance`` is the loop over the steps: ``_why_stop`` (a reason to return first),
``_try_step`` (one step and its error), ``locate.detect_events`` (each kind of event
function in turn), ``_emit_frames`` (frames up to the step's end or the event), then
``_stop_at_event`` or ``_accept_step`` (projection, re-arming, the trace).  Its state
travels in named bundles: ``core.state`` (Model, Chain, Work, Books, Frames, Trace),
``watch.Watch`` and this module's buffers, ``Stepper``.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ...contacts.coulomb import slides
from ...core.base import floor_z
from ...core.blocks import reuse_factors
from ...core.books import PROJECTED_IN_STEPS, lowest_above_floor, mechanical_energy
from ...core.dynamics import anchor_force_total, chain_tension, lock_multipliers, pile_pull
from ...core.kinematics import kinetic_energy, potential_energy, project_state, projection_tol
from ...core.rules import landed_or_landing, point_height
from ...core.unilateral import vertical_multipliers
from ...jit import njit
from .dopri import (
    chain_rhs,
    copy_state,
    dense_state,
    event_state,
    floor_impulse_dense,
    floor_impulse_step,
    nonfinite,
    rk_stages,
    smooth_loss_step,
    stage_rhs,
    step_error,
)
from .locate import detect_events
from .slides import frame_state, mechanical
from .watch import arm_departed

ADV_STOP, ADV_EVENT, ADV_BUFFER, ADV_FAIL_STEP, ADV_FAIL_NAN, ADV_MAX_STEPS = 0, 1, 2, 3, 4, 5
ADV_GO = -1  # (internal) no reason to return: take the step


Found = namedtuple(
    "Found",
    [
        "kind",  # kind of each event found in the last step (watch.EV_*)
        "idx",  # its hinge or point
        "time",  # where in the step (theta in [0, 1]); after _stop_at_event: the absolute time, inf if not
        "n",  # (1,) int64: events found
    ],
)

# The integrator's buffers, in bundles by purpose (each step function receives only the
# bundles it uses):
Stages = namedtuple(
    "Stages",
    [
        "K",  # (7, 2, N, 3): the stages of the step (K[0] = f(Y), K[6] = f(Y1))
        "F",  # (7, 4): the anchors' total force at the stages of K (0:3), the smooth laws' power (3)
        "Y1",  # (2, N, 3): the step's 5th-order end
        "Ytmp",  # (2, N, 3): scratch state (stages, the midpoint, dense output)
        "dYtmp",  # (2, N, 3): scratch derivative
    ],
)
Hermite = namedtuple("Hermite", ["K2", "F2"])  # f and the anchors' force at the event-state quintic's nodes
Detect = namedtuple(
    "Detect",
    [
        "lam1",  # lock multipliers at the step's end
        "pz1",  # (N+1,): the floor's vertical force on each point at the step's end (a frictionless floor's lift-offs)
        "fv_mid",  # (N+1,): floor event functions at the step's midpoint
        "fv_end",  # (N+1,): and at its end
        "found",  # the events found in the last step (Found)
    ],
)
Scratch = namedtuple(
    "Scratch",
    [
        "lam",  # lock multipliers (scratch of event_value)
        "pair",  # (2, 3): the two axes of a hinge on the dense output
        "fpart",  # (4,): the floor's impulse (0:3) and the smooth laws' loss (3) from the step's start to a frame
        "pts",  # (N+1, 3): point positions or velocities
        "vel",  # (N, 3): centre velocities
        "pz",  # (N+1,): the floor's vertical force on each point (scratch of event_value)
        "pv",  # (N+1, 3): point velocities (a frictionless floor's energies)
        "en",  # (2,): U, T
        "t0",  # (1,): the step's start (the floor's height in flight: ``base.floor_z``)
    ],
)
Stepper = namedtuple(
    "Stepper",
    [
        "sg",  # Stages
        "hb",  # Hermite
        "det",  # Detect
        "scr",  # Scratch
        "fsal",  # (1,) int64: 1 when K[0], F[0] hold f(Y) of a step to redo (after ADV_BUFFER)
    ],
)

# What locating an event needs: the step's start Y and stages K (its dense output),
# scratch (Yt, dYt, lam, pair) and the constraint state (for the lock multipliers).
Dense = namedtuple("Dense", ["Y", "K", "Yt", "dYt", "lam", "pair", "anchored", "locked", "pz", "base", "t0"])


def new_stepper(n: int) -> Stepper:
    """The integrator's buffers for an N-segment chain."""
    nh = max(n - 1, 1)
    m = 4 * n + 6  # (every event function at most once a step: hinges twice, points twice, the top)
    found = Found(np.zeros(m, np.int64), np.zeros(m, np.int64), np.zeros(m), np.zeros(1, np.int64))
    sg = Stages(np.zeros((7, 2, n, 3)), np.zeros((7, 4)), np.zeros((2, n, 3)), np.zeros((2, n, 3)), np.zeros((2, n, 3)))
    hb = Hermite(np.zeros((7, 2, n, 3)), np.zeros((7, 4)))
    det = Detect(np.zeros(nh), np.zeros(n + 1), np.zeros(n + 1), np.zeros(n + 1), found)
    scr = Scratch(
        np.zeros(nh),
        np.zeros((2, 3)),
        np.zeros(4),
        np.zeros((n + 1, 3)),
        np.zeros((n, 3)),
        np.zeros(n + 1),
        np.zeros((n + 1, 3)),
        np.zeros(2),
        np.zeros(1),
    )
    return Stepper(sg, hb, det, scr, np.zeros(1, np.int64))


@njit(cache=True, _nrt=False)
def _record_frame(Yt, dYt, tf, n_landed, model, chain, ws, scr, frames):
    """Frame frames.count[0] at time tf from the state Yt: the state, the anchors' force
    on the airborne chain, the pile's pull (``pile_pull``), the tension at every point
    (``chain_tension``), the vertical force a scale under the floor reads (anchors' z
    force + the weight of the landed segments), energies."""
    k = frames.count[0]
    n = Yt.shape[1]
    frames.t[k] = tf
    for i in range(n):
        for q in range(3):
            frames.e[k, i, q] = Yt[0, i, q]
            frames.omega[k, i, q] = Yt[1, i, q]
    for j in range(n + 1):
        frames.anchored[k, j] = chain.anchored[j]
    for j in range(n - 1):
        frames.locked[k, j] = chain.locked[j]
    chain_rhs(Yt, chain.anchored, chain.locked, ws, dYt)
    anchor_force_total(ws.kind, ws.nrow, ws.x, frames.floor_force[k])
    pile_pull(chain.anchored, ws.kind, ws.nrow, ws.x, frames.pile_pull[k])
    chain_tension(Yt[0], ws.kind, ws.nrow, ws.x, frames.tension[k])
    frames.scale_force[k] = frames.floor_force[k, 2] + n_landed
    if slides(model.friction):  # (point N moves: ``slides``)
        frame_state(Yt[0], Yt[1], tf, chain, scr.pts, scr.pv, scr.vel, scr.en, frames.base[k], frames.base_velocity[k])
        frames.potential[k], frames.kinetic[k] = scr.en[0], scr.en[1]
    else:
        frames.kinetic[k] = kinetic_energy(Yt[0], Yt[1], scr.pts, scr.vel)
        frames.potential[k] = potential_energy(Yt[0])


@njit(cache=True, _nrt=False)
def _emit_frames(t, h, t_end, n_landed, model, chain, ws, sg, scr, books, frames):
    """The frames due up to t_end, from the step's dense output; False if the buffers
    filled first (the caller returns ADV_BUFFER and redoes the step once they are
    emptied)."""
    cap = frames.t.shape[0]
    while frames.next[0] <= t_end + 1e-300:
        if frames.count[0] >= cap:
            return False
        th = (frames.next[0] - t) / h
        dense_state(chain.Y, sg.K, h, th, sg.Ytmp)
        _record_frame(sg.Ytmp, sg.dYtmp, frames.next[0], n_landed, model, chain, ws, scr, frames)
        floor_impulse_dense(h, th, sg.F, n_landed, scr.fpart)
        for q in range(3):
            frames.floor_impulse[frames.count[0], q] = books.floor_flow[q] + scr.fpart[q]
        frames.lost_damping[frames.count[0]] = books.lost_damping[0] + scr.fpart[3]
        books.n_evals[0] += 1
        frames.count[0] += 1
        frames.next[0] += frames.dt
    return True


@njit(cache=True, _nrt=False)
def _trace_point(trace, t, e, anchored, base):
    """The top end's height above the floor at t (``base.floor_z``: point N's, but where a
    frictionless floor has let it leave)."""
    k = trace.count[0]
    trace.t[k] = t
    z = point_height(e, 0)
    trace.z[k] = z if anchored[e.shape[0]] != 0 else z - floor_z(e, anchored, base, t)
    trace.count[0] = k + 1


@njit(cache=True, _nrt=False)
def _stop_at_event(t, h, theta_stop, n_landed, chain, ws, sg, hb, found, books, trace):
    """End the step at its first event: the state at the event time to the step's order
    (the 4th-order interpolant is good enough to locate the event, not to restart
    from), the floor's impulse to that time, the found events' absolute times (inf: not
    confirmed in this step); returns the event time."""
    Y = chain.Y
    if theta_stop < 1.0:
        if theta_stop > 0.0:
            event_state(
                Y,
                sg,
                hb,
                h,
                theta_stop,
                chain.anchored,
                chain.locked,
                ws,
                n_landed,
                books.floor_flow,
                books.lost_damping,
            )
            books.n_evals[0] += 2
    else:
        floor_impulse_step(h, sg.F, n_landed, books.floor_flow)
        smooth_loss_step(h, sg.F, books.lost_damping)
        copy_state(Y, sg.Y1)
    for r in range(found.n[0]):
        found.time[r] = t + found.time[r] * h if found.time[r] <= 1.0 else math.inf
    t_event = t + theta_stop * h
    _trace_point(trace, t_event, Y[0], chain.anchored, chain.base)
    return t_event


@njit(cache=True, _nrt=False)
def _accept_step(t_end, h, n_landed, model, chain, watch, ws, sg, det, scr, books, trace):
    """Accept the full step: the state at its end, the floor's impulse, the projection
    onto the constraints (f(Y) recomputed if it moved the state, else the last stage
    reused), departing functions armed, the lowest point and the trace."""
    Y = chain.Y
    floor_impulse_step(h, sg.F, n_landed, books.floor_flow)
    smooth_loss_step(h, sg.F, books.lost_damping)
    copy_state(Y, sg.Y1)
    slide = slides(model.friction)
    before = (
        mechanical(t_end, chain, scr.pts, scr.pv, scr.vel) if slide else mechanical_energy(Y[0], Y[1], scr.pts, scr.vel)
    )
    tol = projection_tol(Y.shape[1])
    res, _ = project_state(chain, ws, scr.pts, scr.vel, tol, np.int64(3))
    after = (
        mechanical(t_end, chain, scr.pts, scr.pv, scr.vel) if slide else mechanical_energy(Y[0], Y[1], scr.pts, scr.vel)
    )
    books.projected[PROJECTED_IN_STEPS] += after - before
    if res > tol:
        stage_rhs(Y, chain.anchored, chain.locked, ws, sg.K[0], sg.F[0])
        books.n_evals[0] += 1
    else:
        copy_state(sg.K[0], sg.K[6])
        for q in range(4):
            sg.F[0, q] = sg.F[6, q]
    zf = floor_z(Y[0], chain.anchored, chain.base, t_end)
    arm_departed(model, chain, watch, det.lam1, det.pz1, zf, det.fv_end)
    lowest_above_floor(Y[0], chain.anchored, zf, books.lowest)
    _trace_point(trace, t_end, Y[0], chain.anchored, chain.base)


@njit(cache=True, _nrt=False)
def _count_landed(anchored):
    """Segments whose both ends are anchored (the floor holds up their weight)."""
    n_landed = np.int64(0)
    for i in range(anchored.shape[0] - 1):
        if landed_or_landing(anchored, i):
            n_landed += 1
    return n_landed


@njit(cache=True, _nrt=False)
def _why_stop(t, h, model, fsal, n_steps, trace):
    """A reason to return before the next step (ADV_*), or ADV_GO."""
    if n_steps[0] >= model.max_steps:
        return ADV_MAX_STEPS
    if trace.count[0] >= trace.t.shape[0] - 2:
        fsal[0] = 1
        return ADV_BUFFER
    if t >= model.t_stop:
        return ADV_STOP
    if min(h, model.t_stop - t) < 1e-14 * max(1.0, abs(t)):
        return ADV_FAIL_STEP
    return ADV_GO


@njit(cache=True, _nrt=False)
def _try_step(h, model, chain, ws, sg, lam1, pz1, n_evals):
    """One Dormand-Prince step of size h (sg.Y1, sg.K, sg.F); returns its error in units
    of the tolerance (inf: non-finite); the lock multipliers at its end in lam1, the floor's
    vertical forces in pz1 (a frictionless floor's)."""
    rk_stages(chain.Y, h, sg, chain.anchored, chain.locked, ws)
    n_evals[0] += 6
    err = step_error(chain.Y, sg.Y1, sg.K, h, model.rtol, model.rtol)
    if not math.isfinite(err) or nonfinite(sg.Y1):
        return math.inf
    lock_multipliers(ws.kind, ws.nrow, ws.x, lam1)  # lambda at Y1 (last stage)
    if slides(model.friction):
        vertical_multipliers(ws.kind, ws.nrow, ws.x, pz1)
    return err


@njit(cache=True, _nrt=False)
def advance(t, h, model, chain, watch, ws, st, books, frames, trace):
    """Integrate from t until model.t_stop or the first event.

    Returns (code, t, h).  On ADV_EVENT, chain.Y holds the state at the event time t,
    and st.det.found (its n[0] rows) the triggered events with their located times (absolute; inf: not confirmed).  books: steps, evaluations, the lowest
    point, the floor's continuous impulse (``floor_impulse_step``).  Frames fill the
    buffers; a step with more frames than fit returns ADV_BUFFER before it is accepted
    (the caller empties the buffers and calls again: the step is redone from the same
    state and goes on where the frames stopped); st.fsal[0] = 1 then: st.sg.K[0], st.sg.F[0]
    still hold f(Y) of the step in progress, and the next call starts from them (so
    buffer sizes change no number).
    """
    n_landed = _count_landed(chain.anchored)
    sg, hb, det, scr = st.sg, st.hb, st.det, st.scr
    dense = Dense(
        chain.Y, sg.K, sg.Ytmp, sg.dYtmp, scr.lam, scr.pair, chain.anchored, chain.locked, scr.pz, chain.base, scr.t0
    )
    if st.fsal[0] == 0:  # FSAL: derivative at the current state (kept across an ADV_BUFFER return)
        stage_rhs(chain.Y, chain.anchored, chain.locked, ws, sg.K[0], sg.F[0])
        books.n_evals[0] += 1
    st.fsal[0] = 0
    reuse_factors(ws.S, np.bool_(False))  # the steps have new axes at every stage
    nfail = 0
    while True:
        code = _why_stop(t, h, model, st.fsal, books.n_steps, trace)
        if code != ADV_GO:
            return code, t, h
        h = min(h, model.t_stop - t)
        err = _try_step(h, model, chain, ws, sg, det.lam1, det.pz1, books.n_evals)
        if err == math.inf:
            nfail += 1
            if nfail > 20:
                return ADV_FAIL_NAN, t, h
            h *= 0.1
            continue
        if err > 1.0:
            h *= max(0.2, 0.9 * err**-0.2)
            continue
        nfail = 0
        dense.t0[0] = t
        theta_stop, fire = detect_events(t, h, model, watch, dense, ws, sg, det, books.n_evals)
        books.n_steps[0] += 1
        t_end = t + theta_stop * h
        if not _emit_frames(t, h, t_end, n_landed, model, chain, ws, sg, scr, books, frames):
            books.n_steps[0] -= 1  # buffers full: redo this step once they are emptied
            st.fsal[0] = 1
            return ADV_BUFFER, t, h
        if fire:
            t_event = _stop_at_event(t, h, theta_stop, n_landed, chain, ws, sg, hb, det.found, books, trace)
            return ADV_EVENT, t_event, h
        _accept_step(t_end, h, n_landed, model, chain, watch, ws, sg, det, scr, books, trace)
        t = t_end
        h *= 10.0 if err == 0.0 else min(10.0, max(0.2, 0.9 * err**-0.2))
