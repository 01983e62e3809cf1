"""Moreau-Jean time-stepping over the compiled core (numba, nondimensional: m = b = g = 1).

The velocity state is that of maximal coordinates: each segment's centre velocity V_i
(kept in ``Scratch.vmax``) and angular velocity w_i; the positions are the axes e, so
the chain is joined by construction.  One step from t to t + h (``step``), each part O(N):

1. **Step size**: h = min(dt, the stop time), dt as the rule
   ``SolverOptions.dt_rule`` gives it (``_step_by_rule``), cut at the first
   predicted landing (the floor functions after a free turn of the axes by h w, linear
   in the step) so that a landing starts the next step on the floor, not above it.
2. **Touches** (the floor model's rule, ``floors.dispatch.floor_contacts``): a watched
   point at the floor (its floor function at most ``TOUCH_TOL``, or reaching zero within
   ``TOUCH_FRACTION`` of a step) is anchored where it is, for good.
3. **Free velocity**: V_free = V - h g e_z on every airborne segment, w_free = w (gravity
   exerts no torque about a rod's centre) plus h W tau(e, w), the smooth laws' torques
   at the step's start (``core.forces``: the hinges' damping), explicit; what their kick
   removed, -h tau . (w + w+) / 2 (the impulse h tau's work, as the lock rows'), is booked
   as lost_damping.
4. **One velocity-level problem** (Moreau; ``impacts.velocity_impact``, the one that
   resolves an event instant, with ``ImpactWork.dv`` = V_free - V(e, w)): the hinge and
   anchor rows as equalities, J (V+, w+) = 0, and over the index set (the hinges whose
   limit is in force and whose predicted bend g + h dg/dt reaches the limit) the
   inelastic law: dg/dt+ >= 0, impulse >= 0, complementary (a hinge is released when its
   impulse would pull); with restitution at the limits (``--restitution-lock E``) Newton's
   law in Moreau-Jean's form, dg/dt+ + E min(dg/dt-, 0) >= 0, dg/dt- the rate at the
   step's start (``_solve``; a hinge that rebounds is not locked); warm-started with the whole index set active, each trial's
   factorisation redone only from the first point whose rows changed
   (``blocks.reuse_factors``).  Every force of
   the step is an impulse of this problem: the tension, the floor's support, the locks.
   The energy it removes at the lock rows is booked per row from the impulses,
   -1/2 P (u- + u+), to the hinges; in a step that anchors a point, the rest of what it
   removes is booked to the landing (per row it is not defined: a segment anchored at
   both ends has one redundant row).  What the other steps' hinge and anchor rows
   remove is not booked: it is the method's own error (gravity's kick on anchored
   points, the turn of the axes), part of the imbalance, which shrinks with dt.
5. **Positions**: each airborne axis turns exactly (Rodrigues) by h (theta w+ + (1 - theta) w),
   theta = ``SolverOptions.theta`` (by default 1/2 below N = 1024, 1 from it); V+ is kept.
6. **Projection** (positions only): any hinge found past its limit is put back on it,
   the anchors at their points (``kinematics.project_state``: Gauss-Newton to ``projection_tol``,
   J W J^T factored at each iteration; a projection factored once, or stopped at 1e-9,
   left the books' imbalance larger).

A hinge *locks* in the log when it starts to take impulse and *unlocks* when it stops;
a *landing* row carries its step's floor impulse (over all anchors) and loss to landing,
shared equally by the points that land in that step;
``Chain.locked`` is the set that took impulse in the last step.

**Frames never change a fall**: no step is cut at a frame time, so the steps, and all
the run's own numbers, are those of a run without frames.  A frame due at a step's
start is its state; one at a time strictly inside a step is filled from that step
(``fill_frames``).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ...contacts.newton import bounce_resolved, floor_rebound, rebounds
from ...core.blocks import fits4, forces4, generalized_forces, reuse_factors
from ...core.books import PROJECTED_IN_STEPS, log_row, lowest_point
from ...core.dynamics import chain_tension, pile_pull
from ...core.forces import any_smooth_law, smooth_torques
from ...core.impacts import clear_rebounds, hinge_gaps, hinge_rates, new_impact_work, stepped_impact, velocity_impact
from ...core.kinematics import (
    drift_removable,
    point_positions,
    potential_energy,
    project_state,
    projection_tol,
    velocities,
)
from ...core.rows import W_V, W_W
from ...core.rules import (
    LOG_BOUNCE,
    LOG_LANDING,
    LOG_LOCK,
    LOG_PIN,
    LOG_RELEASE,
    LOG_TOP,
    LOG_UNLOCK,
    RATE_TOL,
    all_anchored,
    fall_ended,
    hold_at,
    is_landed,
    landed_count,
    limit_in_force,
    settle_anchors,
)
from ...core.state import new_books, new_chain, new_work
from ...floors.dispatch import floor_contacts, floor_values, top_event
from ...jit import entry, njit
from .. import DT_RULES, LANDING_STEP_RANGE

TOUCH_TOL = 1e-9  # a floor function at or below this touches (b, or e_z under floor "pivot")
TOUCH_FRACTION = 1e-6  # ... or one predicted to reach zero within this fraction of a step
LAND_SLACK = 1e-3  # a point that ends a step this close to the floor (in units of its travel) is due
MAX_CUTS = 4  # a step is cut at most this many times at a landing (then taken as it is)
TURN_MAX = 0.1  # rad: no segment turns more than this in a step (a whip gets shorter steps)
DT_LANDING = DT_RULES["landing"]  # the code of dt_rule landing
MIN_CUT = 1e-3  # a landing predicted within this fraction of dt touches at once (no shorter step)
ANCHOR_RATE_TOL = 1e-6  # an anchored point faster than this after the impact problem: its rows were not met
HOLD_RATE = (
    1e-6  # sqrt(g b): restitution at the floor, a bounce slower than this is not made (``newton.bounce_resolved``)
)
LEAVING = 3  # Chain.anchored of a point that bounces off the floor in this step (``_leave_floor``, ``_let_go``)
KE_RTOL = 1e-9  # an impact problem may raise the kinetic energy by this fraction at most (round-off)
REBOUND_SLACK = 0.02  # ... and with restitution by this fraction of what its rebounds give back (the kick's share)
PROJ_ITERS = 25  # Gauss-Newton iterations of the projection at most
PROJ_MOVE_MAX = 0.1  # b: a projection that moves a point further is undone
PROJ_MOVE_RATIO = 1e3  # ... or further than this many times the largest residual it removes
PROJ_UNMET = 1e3  # ... or one with the hinges that leaves a residual above this many tolerances

# run_steps codes (negative: the run cannot go on)
TS_STOP, TS_BUFFER, TS_RETURN, TS_LANDED, TS_MAX_STEPS = 0, 2, 11, 10, 5
ERR_IMPACT, ERR_ENERGY, ERR_NAN = -1, -2, -6

# The stepper's state beyond the chain, and its scratch.
Scratch = namedtuple(
    "Scratch",
    [
        "vmax",  # (N, 3): the centres' velocities V (maximal coordinates; state)
        "e_pred",  # (N, 3): the axes after a free turn by h w
        "fv",  # (N+1,): floor functions now
        "fv_pred",  # (N+1,): ... after the free turn
        "gaps",  # (N-1,): g_k
        "rates",  # (N-1,): dg_k/dt before the impact
        "cand",  # (N-1,) uint8: the index set (hinges in the impact problem)
        "active",  # (N-1,) uint8: hinges that take impulse (warm start on entry)
        "forced",  # (N-1,) uint8: all zero (no hold rule: accumulations are stepped through)
        "was",  # (N-1,) uint8: took impulse in the last step
        "pts",  # (N+1, 3): point positions
        "pv",  # (N+1, 3): point velocities
        "vel",  # (N, 3): centre velocities (scratch)
        "due",  # (N+1,) uint8: points the last step was cut to land (they touch in this one)
        "w_pre",  # (N, 3): w at the start of the step (a cut step is solved again)
        "w_mid",  # (N, 3): the rates the axes turn at, (w + w+) / 2
        "v_pre",  # (N, 3): V at the start of the step
        "new_anchor",  # (N+1,) int64: points anchored in this step
        "removed",  # (1,): the kinetic energy the last impact problem removed (negative: it rose)
        "e_used",  # (1,): the restitution at the limits the last impact problem took (0: Moreau's law)
        "force",  # (3,): the anchors' mean force on the airborne chain over the last step
        "pull",  # (3,): the pile's mean pull on the hanging chain over the last step
        "tension",  # (N+1,): the mean tension at every point over the last step (``dynamics.chain_tension``)
        "held",  # (N+1,) uint8: free points the projection holds at the floor (``_hold_sinking``)
        "iw",  # the impact problem's scratch (impacts.ImpactWork)
    ],
)

# What fills the frames inside a step: its start, and a state of their own (the run's is never touched).
# A bundle of its own beside ``Scratch``, passed only to the kernels that fill frames: the
# kernels that take ``Scratch`` would otherwise each take its ~40 arrays as well (compile time).
FrameWork = namedtuple(
    "FrameWork",
    [
        "t0",  # (1,): the last step's start
        "h",  # (1,): its size (0: no frame inside it)
        "e0",  # (N, 3): the axes at its start
        "start",  # (8,): T, the lost energies (locking, landing), the floor's impulse (3), lost to damping and to
        #   sliding, at its start
        "end",  # (8,): ... at its end
        "chain",  # the frame's state (state.Chain): axes, rates, anchors and locks
        "books",  # the frame's books (state.Books: losses, floor impulse; and its projection's ledger)
        "ws",  # the frame's projection's workspace (state.Work)
        "gaps",  # ... and its scratch (``_project``)
        "pv",
        "pts",
        "vel",
        "was",
        "e_pred",
        "held",
    ],
)


# What the projection (``_project``) works in: the run's scratch (``Scratch``) or a frame's
# (``FrameWork``) hold these arrays; passed alone, its kernel compiles once for both.
Projection = namedtuple("Projection", ["gaps", "pv", "pts", "vel", "was", "e_pred", "held"])


def projection_scratch(b) -> Projection:
    """The projection's arrays of a ``Scratch`` or a ``FrameWork`` (from Python; compiled
    code builds the bundle where it calls ``_project``)."""
    return Projection(b.gaps, b.pv, b.pts, b.vel, b.was, b.e_pred, b.held)


def new_frame_work(n: int) -> FrameWork:
    """The frames' workspace of an N-segment chain."""
    nh = max(n - 1, 0)
    v3 = lambda m: np.zeros((m, 3))  # noqa: E731
    chain = new_chain(np.zeros((n, 3)), np.zeros((n, 3)), math.pi)
    return FrameWork(
        np.zeros(1), np.zeros(1), v3(n), np.zeros(8), np.zeros(8), chain, new_books(),
        new_work(n), np.zeros(nh), v3(n + 1), v3(n + 1), v3(n), np.zeros(nh, np.uint8), v3(n),
        np.zeros(n + 1, np.uint8),
    )  # fmt: skip


def new_scratch(n: int, w0: np.ndarray | None = None, e0: np.ndarray | None = None) -> Scratch:
    """The stepper's state and scratch for an N-segment chain (V from e0, w0 if given)."""
    nh = max(n - 1, 0)
    u8 = lambda: np.zeros(nh, np.uint8)  # noqa: E731
    v3 = lambda m: np.zeros((m, 3))  # noqa: E731
    sc = Scratch(
        v3(n), v3(n), np.zeros(n + 1), np.zeros(n + 1), np.zeros(nh), np.zeros(nh),
        u8(), u8(), u8(), u8(), v3(n + 1), v3(n + 1), v3(n), np.zeros(n + 1, np.uint8), v3(n), v3(n), v3(n),
        np.zeros(n + 1, np.int64),
        np.zeros(1), np.zeros(1), np.zeros(3), np.zeros(3), np.zeros(n + 1), np.zeros(n + 1, np.uint8),
        new_impact_work(n),
    )  # fmt: skip
    if w0 is not None and e0 is not None:
        velocities(e0, w0, sc.pv, sc.vmax)
    return sc


@njit(cache=True, _nrt=False)
def rotate_axes(e, w, h, anchored, out):
    """out_i = R(h w_i) e_i, the exact rotation by the angle h |w_i| about w_i
    (Rodrigues); landed segments do not turn.  ``out`` may be ``e``."""
    for i in range(e.shape[0]):
        ex, ey, ez = e[i, 0], e[i, 1], e[i, 2]
        wn = math.sqrt(w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2)
        if is_landed(anchored, i) or wn == 0.0:
            out[i, 0], out[i, 1], out[i, 2] = ex, ey, ez
            continue
        kx, ky, kz = w[i, 0] / wn, w[i, 1] / wn, w[i, 2] / wn
        c, s = math.cos(h * wn), math.sin(h * wn)
        kd = (kx * ex + ky * ey + kz * ez) * (1.0 - c)
        out[i, 0] = ex * c + (ky * ez - kz * ey) * s + kx * kd
        out[i, 1] = ey * c + (kz * ex - kx * ez) * s + ky * kd
        out[i, 2] = ez * c + (kx * ey - ky * ex) * s + kz * kd


@njit(cache=True, _nrt=False)
def _touches(t, r0, model, chain, sc, books):
    """Part 2: anchor where they are the points at the floor: a floor function at most
    TOUCH_TOL, or that of a point the last step was cut to land (marked 2 during the
    impact), listed from sc.new_anchor[r0]; returns their number.  With restitution at the
    floor, a point due that rises at the step's start (one that has bounced: ``_let_go``)
    touches too: it is due because the step's impulses turn it down (``_turned_down``)."""
    e, anchored = chain.Y[0], chain.anchored
    floor_values(model.floor, e, anchored, 0.0, sc.fv)
    ztol = TOUCH_TOL
    for j in range(sc.fv.shape[0]):
        if sc.due[j] and math.isfinite(sc.fv[j]):
            ztol = max(ztol, sc.fv[j])
    point_positions(e, sc.pts)
    _point_velocities(e, chain.Y[1], sc.v_pre, sc.pv)
    na = floor_contacts(model.floor, e, sc.pts, sc.pv, anchored, True, ztol, sc.new_anchor[r0:])
    for r in range(r0, r0 + na):
        _touch(t, chain, sc.new_anchor[r], sc)
    for j in range(sc.fv.shape[0]):
        if model.e_floor > 0.0 and sc.due[j] and anchored[j] == 0:  # (due, rising at the step's start: turned down)
            sc.new_anchor[r0 + na] = j
            na += 1
            _touch(t, chain, j, sc)
        sc.due[j] = 0
    fall_ended(books, t, False, not top_event(model.floor) and anchored[0] != 0)
    return na


@njit(cache=True, _nrt=False)
def _touch(t, chain, j, sc):
    """Point j touches the floor at t: anchored where it is (sc.pts; marked 2 during the
    impact)."""
    hold_at(chain, j, sc.pts)
    chain.anchored[j] = 2
    chain.anchor_t[j] = t


@njit(cache=True, _nrt=False)
def _aim_rebounds(r0, na, e_floor, sc):
    """Restitution at the floor (``contacts.newton.floor_rebound``): each point that lands
    in this step (sc.new_anchor[r0:r0 + na]) is aimed to leave the floor at -e v_z, v_z its
    vertical velocity at the step's start (sc.pv, ``_touches``): Newton's law in
    Moreau-Jean's form; its horizontal velocity stopped (the rough floor)."""
    iw = sc.iw
    if r0 == 0:
        clear_rebounds(iw)
    for r in range(r0, r0 + na):
        j = sc.new_anchor[r]
        iw.rebound[j] = floor_rebound(sc.pv[j, 2], e_floor)
        iw.n_rebound[0] += 1 if iw.rebound[j] > 0.0 else 0


@njit(cache=True, _nrt=False)
def _leave_floor(h, na, chain, sc):
    """After the step's impact problem, with restitution at the floor: a point that landed
    in it, was aimed up (``_aim_rebounds``; an impact the law would make create energy was
    solved without: ``impacts.velocity_impact``) and leaves faster than RATE_TOL on a flight
    the steps resolve (``contacts.newton.bounce_resolved``) is free again: not anchored."""
    e, w, anchored = chain.Y[0], chain.Y[1], chain.anchored
    iw = sc.iw
    if iw.n_rebound[0] == 0:
        return
    _point_velocities(e, w, sc.vmax, sc.pv)
    for r in range(na):
        j = sc.new_anchor[r]
        v = sc.pv[j, 2]
        pushed = iw.anchor_impulse[j, 2] >= 0.0  # (a floor that would pull it up to its rebound holds it)
        if iw.rebound[j] > 0.0 and pushed and rebounds(v, 1.0, RATE_TOL) and bounce_resolved(v, h, HOLD_RATE):
            anchored[j] = LEAVING  # (its velocity kept, its place held through this step's position update)
        iw.rebound[j] = 0.0
    iw.n_rebound[0] = 0


@njit(cache=True, _nrt=False)
def _let_go(chain):
    """At the end of a step: the points that bounced in it (``LEAVING``, held at the floor
    through its position update and projection, so that the mean of the velocities before
    and after, theta = 1/2, does not carry them below it) are free."""
    anchored = chain.anchored
    for j in range(anchored.shape[0]):
        if anchored[j] == LEAVING:
            anchored[j] = 0
            chain.anchor_t[j] = np.nan
            for q in range(3):
                chain.anchor_pos[j, q] = np.nan


@njit(cache=True, _nrt=False)
def _point_velocities(e, w, vmax, pv):
    """pv_j: the velocity of point j in maximal coordinates, the upper end of segment j
    (V_j - e_j x w_j; point N: the lower end of segment N-1, V + e x w)."""
    n = e.shape[0]
    for j in range(n):
        pv[j, 0] = vmax[j, 0] - (e[j, 1] * w[j, 2] - e[j, 2] * w[j, 1])
        pv[j, 1] = vmax[j, 1] - (e[j, 2] * w[j, 0] - e[j, 0] * w[j, 2])
        pv[j, 2] = vmax[j, 2] - (e[j, 0] * w[j, 1] - e[j, 1] * w[j, 0])
    i = n - 1
    pv[n, 0] = vmax[i, 0] + (e[i, 1] * w[i, 2] - e[i, 2] * w[i, 1])
    pv[n, 1] = vmax[i, 1] + (e[i, 2] * w[i, 0] - e[i, 0] * w[i, 2])
    pv[n, 2] = vmax[i, 2] + (e[i, 0] * w[i, 1] - e[i, 1] * w[i, 0])


@njit(cache=True, _nrt=False)
def _landing_cut(h, model, chain, sc):
    """Part 5: the fraction of the step at which the first watched point reaches the
    floor when the axes turn by h w+ (linear in the step; 1: none does).  The points
    that end the step at the floor (within LAND_SLACK of the step's travel) are marked
    due: they touch at the start of the next step."""
    e, anchored = chain.Y[0], chain.anchored
    _mid_rates(model.theta, chain.Y[1], sc)
    rotate_axes(e, sc.w_mid, h, anchored, sc.e_pred)
    floor_values(model.floor, e, anchored, 0.0, sc.fv)
    floor_values(model.floor, sc.e_pred, anchored, 0.0, sc.fv_pred)
    s = 1.0
    for j in range(sc.fv.shape[0]):
        f, fp = sc.fv[j], sc.fv_pred[j]
        sc.due[j] = 0
        if math.isfinite(f) and f > 0.0 and fp <= 0.0:
            s = min(s, f / (f - fp))
        elif _turned_down(model.e_floor, f, fp):  # (at the floor, a bounced point turned down: it lands now)
            s = 0.0
        if math.isfinite(f) and fp < f and fp <= LAND_SLACK * (f - fp):
            sc.due[j] = 1
    return max(s, TOUCH_FRACTION)


@njit(cache=True, _nrt=False)
def _mid_rates(theta, w, sc):
    """sc.w_mid = theta w+ + (1 - theta) w0: the rates the axes turn at, between those
    before (sc.w_pre) and after (w) the step's impulses (theta = 1/2: their mean)."""
    for i in range(w.shape[0]):
        for q in range(3):
            sc.w_mid[i, q] = theta * w[i, q] + (1.0 - theta) * sc.w_pre[i, q]


@njit(cache=True, _nrt=False)
def _turn_cut(h, w):
    """The fraction of the step h within which no segment turns more than TURN_MAX
    (1: none does) at the rates w."""
    wmax = 0.0
    for i in range(w.shape[0]):
        wmax = max(wmax, w[i, 0] ** 2 + w[i, 1] ** 2 + w[i, 2] ** 2)
    wmax = math.sqrt(wmax)
    if h * wmax <= TURN_MAX:
        return 1.0
    return 0.95 * TURN_MAX / (h * wmax)


@njit(cache=True, _nrt=False)
def _copy3(src, dst):
    for i in range(src.shape[0]):
        for q in range(3):
            dst[i, q] = src[i, q]


@njit(cache=True, _nrt=False)
def _first_to_land(s, e_floor, sc):
    """Mark due the points predicted to reach the floor first (at the fraction s), and
    those at it that the step turns down (``_turned_down``)."""
    for j in range(sc.fv.shape[0]):
        f, fp = sc.fv[j], sc.fv_pred[j]
        first = math.isfinite(f) and f > 0.0 and fp <= 0.0 and f / (f - fp) <= s * (1.0 + 1e-9)
        sc.due[j] = 1 if (first or _turned_down(e_floor, f, fp)) else 0


@njit(cache=True, _nrt=False)
def _turned_down(e_floor, f, fp):
    """With restitution at the floor: a free point at the floor (floor function f <= 0: one
    that has bounced, let go there by ``_let_go``) that the step turns down (its predicted
    fp below f) lands at once, in this step (Moreau's law: it was rising), not a step's
    travel below the floor at the next."""
    return e_floor > 0.0 and math.isfinite(f) and f <= 0.0 and fp < f


@njit(cache=True, _nrt=False)
def _free_velocity(h, model, chain, ws, sc):
    """Part 3: the free velocity V_free = V - h g e_z on airborne segments (0 on landed
    ones) in sc.vmax, w_free = w + h W tau (the smooth laws' torques at the step's start,
    ws.tau, into w), and its difference from the velocities of w, iw.dv = V_free - V(e, w)."""
    e, w, anchored = chain.Y[0], chain.Y[1], chain.anchored
    if any_smooth_law(model):
        smooth_torques(model, e, w, anchored, ws.tau)
        for i in range(e.shape[0]):
            for q in range(3):
                w[i, q] += h * W_W * ws.tau[i, q]
    dv = sc.iw.dv
    velocities(e, w, sc.pv, sc.vel)
    for i in range(e.shape[0]):
        if is_landed(anchored, i):
            for q in range(3):
                dv[i, q] = 0.0
                sc.vmax[i, q] = sc.vel[i, q]
            continue
        for q in range(3):
            dv[i, q] = sc.v_pre[i, q] - sc.vel[i, q]
        dv[i, 2] -= h
        for q in range(3):
            sc.vmax[i, q] = sc.vel[i, q] + dv[i, q]


@njit(cache=True, _nrt=False)
def _smooth_work(h, w_pre, w, tau):
    """What the smooth laws' kick removed in the step: -h tau . (w + w+) / 2, its impulse's
    work with the rates before and after the step (landed segments: tau 0)."""
    s = 0.0
    for i in range(w.shape[0]):
        for q in range(3):
            s -= 0.5 * h * tau[i, q] * (w_pre[i, q] + w[i, q])
    return s


@njit(cache=True, _nrt=False)
def _kick_energy(h, anchored, v_pre):
    """The kinetic energy gravity's kick gave the airborne segments in the step (part 3):
    sum 1/2 |V - h e_z|^2 - 1/2 |V|^2 = sum (h^2 / 2 - h V_z), V the velocities at its
    start.  With the position update's change of U it is the step's error in gravity's
    work (books.work_error): of order h (V+ - V) h, it does not vanish with theta = 1/2
    (the kick takes V, the turn (V + V+) / 2) nor with theta = 1 (the exact turn's
    second-order, centripetal, part)."""
    s = 0.0
    for i in range(v_pre.shape[0]):
        if not is_landed(anchored, i):
            s += 0.5 * h * h - h * v_pre[i, 2]
    return s


@njit(cache=True, _nrt=False)
def _index_set(h, model, chain, sc):
    """Part 4, the index set: hinges in force whose predicted bend g + h dg/dt reaches
    the limit; the warm start: all of them (fewer trials than from those that took
    impulse last step or approach)."""
    e, w, anchored, locked = chain.Y[0], chain.Y[1], chain.anchored, chain.locked
    hinge_gaps(e, model.cos_alpha, sc.gaps)
    hinge_rates(e, w, sc.rates)
    for k in range(locked.shape[0]):
        sc.was[k] = locked[k]
        c = limit_in_force(anchored, k, model.cone, model.alpha) and sc.gaps[k] + h * sc.rates[k] <= 0.0
        sc.cand[k] = 1 if c else 0
        sc.active[k] = sc.cand[k]


@njit(cache=True, _nrt=False)
def kinetic_energy_maximal(vmax, w):
    """T = sum 1/2 |V_i|^2 + |w_i|^2 / 6 of the centres' velocities V (the time-stepper's
    own, maximal coordinates) and the rates w (units m g b)."""
    t = 0.0
    for i in range(w.shape[0]):
        for q in range(3):
            t += 0.5 * vmax[i, q] ** 2 + w[i, q] ** 2 / 6.0
    return t


@njit(cache=True, _nrt=False)
def _solve(model, chain, ws, sc):
    """Part 4: the step's velocity-level problem: w <- w+, and the centres' velocities
    V+ = V_free + (the impulses' force) kept in maximal coordinates (sc.vmax; a loop of
    chain between two anchors can hold rows that are dependent in the new configuration
    and not met by the last step's velocities: V+ then differs from V(e, w+) by what the
    dropped row could not remove).  With restitution at the limits (``model.e_lock``,
    ``contacts.newton``) the law on the index set is Newton's in Moreau-Jean's form,
    gamma+ + e min(gamma-, 0) >= 0 with gamma- the rate at the step's start
    (``impacts.stepped_impact``); an impact in which it would raise the kinetic energy by
    more than REBOUND_SLACK of what its rebounds give back, R = 1/2 sum P_k dg_k/dt+
    (Newton's law at several limits at once can create energy; the free velocity's kick
    moves the balance by O(h) of it either way), is solved again inelastic, as the exact
    method takes such an impact (sc.e_used: the law taken).  Returns 0, or ERR_IMPACT /
    ERR_ENERGY (the kinetic energy rose: the projection was not exact)."""
    e, w, anchored = chain.Y[0], chain.Y[1], chain.anchored
    iw = sc.iw
    t0 = kinetic_energy_maximal(sc.vmax, w)  # sc.vmax holds V_free (_free_velocity)
    hinge_rates(e, w, iw.rates_before)
    e_lock = model.e_lock
    if e_lock > 0.0:
        for k in range(iw.rates_before.shape[0]):
            iw.rates_before[k] = min(iw.rates_before[k], 0.0)  # (restitution acts on an approach)
    t1 = t0
    allowed = t0 * (1.0 + KE_RTOL) + 1e-12
    newton = e_lock > 0.0 or iw.n_rebound[0] > 0  # (restitution at a limit or at the floor: ``_aim_rebounds``)
    for _ in range(2):  # Newton's law, then (if it raised the energy) Moreau's
        if newton:
            it = stepped_impact(e, w, anchored, sc.cand, sc.forced, sc.active, e_lock, ws, iw)
        else:
            it = velocity_impact(e, w, anchored, sc.cand, sc.forced, sc.active, 0.0, ws, iw)
        if it < 0:
            return ERR_IMPACT
        if fits4(ws.kind, ws.nrow):
            forces4(ws.kind, ws.nrow, ws.x, ws.gf)
        else:
            generalized_forces(anchored, ws.J, ws.nrow, ws.x, ws.gf)
        t1 = 0.0
        for i in range(e.shape[0]):
            landed = is_landed(anchored, i)
            for q in range(3):
                v = 0.0 if landed else sc.vmax[i, q] + W_V * ws.gf[i, q]
                t1 += 0.5 * v * v + w[i, q] ** 2 / 6.0
        if not newton:
            break
        given_back = 0.0
        for k in range(sc.active.shape[0]):
            if sc.active[k]:
                given_back += 0.5 * iw.impulse[k] * max(iw.rates_after[k], 0.0)
        for j in range(iw.rebound.shape[0] if iw.n_rebound[0] > 0 else 0):  # (the floor's rebounds too)
            given_back += 0.5 * max(iw.anchor_impulse[j, 2], 0.0) * iw.rebound[j]
        if t1 <= allowed + REBOUND_SLACK * given_back:
            allowed += REBOUND_SLACK * given_back
            break
        e_lock = 0.0  # Newton's law raised the energy: the step's impact inelastic
        newton = False
        clear_rebounds(iw)
        _copy3(sc.w_pre, w)
        for k in range(sc.cand.shape[0]):
            sc.active[k] = sc.cand[k]
    sc.e_used[0] = e_lock
    for i in range(e.shape[0]):
        landed = is_landed(anchored, i)
        for q in range(3):
            sc.vmax[i, q] = 0.0 if landed else sc.vmax[i, q] + W_V * ws.gf[i, q]
    sc.removed[0] = t0 - t1
    if t1 > allowed:
        return ERR_ENERGY
    return 0


@njit(cache=True, _nrt=False)
def _book(t, h, na, e_floor, chain, ws, sc, books, log):
    """The step's impulses into the books: the energy removed at the lock and anchor
    rows, the floor's impulse, the anchors' mean force (for the frames); the locks,
    unlocks and landings logged.  The floor's impulse of a step is the sum over all its
    anchors: a segment lying between two anchors is held by rows that are (nearly)
    dependent, and how their impulses split between its two ends is not determined (one
    end can take +6e5 and the other -6e5).  A step in which a point lands puts it all
    into the impacts' account (books.floor_impulse); any other step into the flow, and
    its mean force, divided by h, is what the frames record (kept through a landing
    step)."""
    anchored, locked = chain.anchored, chain.locked
    iw = sc.iw
    books.lost_locking[0] += iw.split[0]
    if na > 0:  # a landing: what the impulses removed beyond the locks' share
        books.lost_landing[0] += sc.removed[0] - iw.split[0]
    px, py, pz = 0.0, 0.0, 0.0
    for j in range(anchored.shape[0]):
        px += iw.anchor_impulse[j, 0]
        py += iw.anchor_impulse[j, 1]
        pz += iw.anchor_impulse[j, 2]
    account = books.floor_impulse if na > 0 else books.floor_flow
    account[0] += px
    account[1] += py
    account[2] += pz
    if na == 0:
        sc.force[0], sc.force[1], sc.force[2] = px / h, py / h, pz / h
    pile_pull(anchored, ws.kind, ws.nrow, ws.x, sc.pull)
    for q in range(3):
        sc.pull[q] /= h
    chain_tension(chain.Y[0], ws.kind, ws.nrow, ws.x, sc.tension)
    for j in range(sc.tension.shape[0]):
        sc.tension[j] /= h
    for k in range(locked.shape[0]):
        bounced = sc.active[k] == 1 and rebounds(iw.rates_after[k], sc.e_used[0], RATE_TOL)
        if sc.active[k] and not sc.was[k]:
            lost = -0.5 * iw.impulse[k] * (sc.rates[k] + iw.rates_after[k])
            log_row(log, t, LOG_LOCK, k, iw.impulse[k], 0.0, 0.0, lost, sc.pts, k + 1)
        elif sc.was[k] and not sc.active[k]:
            log_row(log, t, LOG_UNLOCK, k, 0.0, 0.0, 0.0, 0.0, sc.pts, k + 1)
        if bounced:  # restitution: it took an impulse and leaves its limit (not locked)
            log_row(log, t, LOG_RELEASE, k, 0.0, 0.0, 0.0, 0.0, sc.pts, k + 1)
        locked[k] = 0 if bounced else sc.active[k]
    if na > 0:  # the landings share the step's floor impulse and its loss at landing equally
        share = 1.0 / na
        lost = share * (sc.removed[0] - iw.split[0])
        if e_floor > 0.0:  # (the kind of each: its vertical velocity at the step's start, Newton's law)
            _point_velocities(chain.Y[0], sc.w_pre, sc.v_pre, sc.pv)
        for r in range(na):
            j = sc.new_anchor[r]
            kind = LOG_LANDING
            if anchored[j] == LEAVING:
                kind = LOG_BOUNCE
            elif e_floor > 0.0 and rebounds(floor_rebound(sc.pv[j, 2], e_floor), e_floor, RATE_TOL):
                kind = LOG_PIN  # (Newton's law would bounce it: too short a flight, or the energy fallback)
            log_row(log, t, kind, j, px * share, py * share, pz * share, lost, sc.pts, j)


@njit(cache=True, _nrt=False)
def _project(model, chain, ws, sc, books):
    """Part 6 (``sc``: its scratch, ``Projection``): the hinges found past their limit are put back on it, the anchors at
    their points (positions only).  A projection that would move a point by more than
    PROJ_MOVE_MAX, or by more than PROJ_MOVE_RATIO times the largest residual it removes
    (an ill-conditioned set of rows: a fully folded pair standing on one anchor under
    alpha = pi has dependent rows, and a residual of 1e-12 moved its free end by 0.07 b
    and, step after step, created energy), or one whose rows Gauss-Newton left unmet
    (a residual above PROJ_UNMET tolerances: it ended at a least-squares compromise that
    moves anchored points off their anchors; the usual case in falls is a set that no
    state meets, a loop of airborne chain landed with both ends anchored while bent past
    its limits, its anchors closer than its limits allow), is undone and tried with the
    anchors alone, then not at all.  The change of U + T it makes goes to
    the ledger (books.projected): of U alone, since the velocity state (V, w) is kept
    (T = sum 1/2 |V_i|^2 + |w_i|^2 / 6 does not depend on the axes).  Returns the number
    of tries undone."""
    e, anchored, locked = chain.Y[0], chain.anchored, chain.locked
    hinge_gaps(e, model.cos_alpha, sc.gaps)
    point_positions(e, sc.pv)
    if _nothing_to_project(model, chain, sc):
        return 0
    before = potential_energy(e)
    _copy3(e, sc.e_pred)
    undone = 0
    for attempt in range(2):
        for k in range(locked.shape[0]):
            if attempt == 0:
                sc.was[k] = locked[k]
            inside = limit_in_force(anchored, k, model.cone, model.alpha)
            locked[k] = 1 if (attempt == 0 and sc.gaps[k] < 0.0 and inside) else 0
            chain.lock_cos[k] = model.cos_alpha
        tol = projection_tol(e.shape[0])
        res0, res = project_state(chain, ws, sc.pts, sc.vel, tol, np.int64(PROJ_ITERS), False)
        point_positions(e, sc.pts)
        if _hold_sinking(model, chain, sc) > 0:  # (free points pushed below the floor: held at it, again)
            _copy3(sc.e_pred, e)
            r0h, rh = project_state(chain, ws, sc.pts, sc.vel, tol, np.int64(PROJ_ITERS), False)
            _release_held(chain, sc)
            if rh > PROJ_UNMET * tol:  # (no state meets the floor's rows beside the others: as before)
                _copy3(sc.e_pred, e)
                res0, res = project_state(chain, ws, sc.pts, sc.vel, tol, np.int64(PROJ_ITERS), False)
            else:
                res0, res = r0h, rh
            point_positions(e, sc.pts)
        unmet = attempt == 0 and res > PROJ_UNMET * tol
        moved = 0.0
        for j in range(sc.pts.shape[0]):
            for q in range(3):
                moved = max(moved, abs(sc.pts[j, q] - sc.pv[j, q]))
        if moved <= min(PROJ_MOVE_MAX, PROJ_MOVE_RATIO * res0) and not unmet:
            break
        _copy3(sc.e_pred, e)
        undone += 1
    for k in range(locked.shape[0]):
        locked[k] = sc.was[k]
    books.projected[PROJECTED_IN_STEPS] += potential_energy(e) - before
    return undone


@njit(cache=True, _nrt=False)
def _hold_sinking(model, chain, sc):
    """With restitution at the floor: the free points that the projection has pushed below
    the floor (below both their height before it, sc.pv, and the floor, by more than
    TOUCH_TOL; sc.pts their height after) are held at the floor's height for it
    (``LEAVING``: a height row, as a point bouncing off in this step; sc.held marks them,
    ``_release_held`` frees them again): the projection onto the constraints with the
    floor's row active where it binds.  A point that has bounced lies at the floor, free,
    beside the hinges the projection puts back on their limits.  Returns their number."""
    if model.e_floor == 0.0:
        return 0
    n = 0
    for j in range(chain.anchored.shape[0]):
        sc.held[j] = 0
        if chain.anchored[j] == 0 and sc.pts[j, 2] < min(sc.pv[j, 2], 0.0) - TOUCH_TOL:
            chain.anchored[j] = LEAVING
            sc.held[j] = 1
            n += 1
    return n


@njit(cache=True, _nrt=False)
def _release_held(chain, sc):
    """The points ``_hold_sinking`` held for the projection are free again."""
    for j in range(chain.anchored.shape[0]):
        if sc.held[j]:
            chain.anchored[j] = 0
            sc.held[j] = 0


@njit(cache=True, _nrt=False)
def _nothing_to_project(model, chain, sc):
    """No hinge in force past its limit (sc.gaps, by more than the projection's
    tolerance, ``projection_tol``: a hinge put on its limit by the last projection sits
    there to round-off, either side) and every anchored point whose drift a projection
    can remove (``drift_removable``) at its anchor to that tolerance (sc.pv: the point
    positions)."""
    anchored = chain.anchored
    tol = projection_tol(sc.gaps.shape[0] + 1)
    for k in range(sc.gaps.shape[0]):
        if sc.gaps[k] < -tol and limit_in_force(anchored, k, model.cone, model.alpha):
            return False
    for j in range(anchored.shape[0]):
        if anchored[j] != 0 and drift_removable(anchored, j):
            for q in range(3):
                if abs(sc.pv[j, q] - chain.anchor_pos[j, q]) > tol:
                    return False
    return True


@njit(cache=True, _nrt=False)
def record_frame(t, kinetic, chain, sc, books, frames):
    """Frame frames.count[0] at time t (the next frame's): the state (``chain``: the
    run's, or a frame's own, ``fill_frames``), the anchors' mean force on the airborne
    chain, the pile's pull and the tension over the last step (sc), the force a scale under the floor
    reads, energies (the kinetic one given) and the books (``books``)."""
    k = frames.count[0]
    e, w = chain.Y[0], chain.Y[1]
    n = e.shape[0]
    frames.t[k] = t
    for i in range(n):
        for q in range(3):
            frames.e[k, i, q] = e[i, q]
            frames.omega[k, i, q] = w[i, q]
    for j in range(n + 1):
        frames.anchored[k, j] = chain.anchored[j]
    for j in range(n - 1):
        frames.locked[k, j] = chain.locked[j]
    for q in range(3):
        frames.floor_force[k, q] = sc.force[q]
        frames.pile_pull[k, q] = sc.pull[q]
        frames.floor_impulse[k, q] = books.floor_flow[q] + books.floor_impulse[q]
    for j in range(n + 1):
        frames.tension[k, j] = sc.tension[j]
    frames.scale_force[k] = sc.force[2] + landed_count(chain.anchored)
    frames.kinetic[k] = kinetic
    frames.potential[k] = potential_energy(e)
    frames.lost_locking[k] = books.lost_locking[0]
    frames.lost_landing[k] = books.lost_landing[0]
    frames.lost_damping[k] = books.lost_damping[0]
    frames.lost_sliding[k] = books.lost_sliding[0]
    frames.count[0] = k + 1
    frames.fill[0] = k + 1
    frames.next[0] += frames.dt


@njit(cache=True, _nrt=False)
def _frame_tol(t):
    """A frame within this of a step's start or end is at it (round-off of the times)."""
    return t * 1e-12 + 1e-12


@njit(cache=True, _nrt=False)
def _frame_due(tf, t):
    """Is the frame at tf due at a step's start t (not inside an earlier step)?"""
    return tf <= t + _frame_tol(t)


@njit(cache=True, _nrt=False)
def _energies(chain, sc, books, out):
    """out: the run's T (of the velocities (V, w)), lost energies (locking, landing),
    floor impulse (3), lost to damping and to sliding, now."""
    out[0] = kinetic_energy_maximal(sc.vmax, chain.Y[1])
    out[1] = books.lost_locking[0]
    out[2] = books.lost_landing[0]
    for q in range(3):
        out[3 + q] = books.floor_flow[q] + books.floor_impulse[q]
    out[6] = books.lost_damping[0]
    out[7] = books.lost_sliding[0]


@njit(cache=True, _nrt=False)
def _state_between(s, model, chain, sc, fw):
    """The frame's state and books at the fraction s of the last step (``fill_frames``),
    from its start and its end (the run's chain, sc; fw.start, fw.end), in fw; returns
    its kinetic energy."""
    fc = fw.chain
    anchored = chain.anchored
    rotate_axes(fw.e0, sc.w_mid, s * fw.h[0], anchored, fc.Y[0])
    w, wf = chain.Y[1], fc.Y[1]
    for i in range(w.shape[0]):
        for q in range(3):
            wf[i, q] = (1.0 - s) * sc.w_pre[i, q] + s * w[i, q]
    for j in range(anchored.shape[0]):
        fc.anchored[j] = anchored[j]
        for q in range(3):
            fc.anchor_pos[j, q] = chain.anchor_pos[j, q]
    for k in range(chain.locked.shape[0]):
        fc.locked[k] = chain.locked[k]
    a, b, fb = fw.start, fw.end, fw.books
    fb.lost_locking[0] = (1.0 - s) * a[1] + s * b[1]
    fb.lost_landing[0] = (1.0 - s) * a[2] + s * b[2]
    fb.lost_damping[0] = (1.0 - s) * a[6] + s * b[6]
    fb.lost_sliding[0] = (1.0 - s) * a[7] + s * b[7]
    for q in range(3):
        fb.floor_flow[q] = (1.0 - s) * a[3 + q] + s * b[3 + q]
        fb.floor_impulse[q] = 0.0
    _project(model, fc, fw.ws, Projection(fw.gaps, fw.pv, fw.pts, fw.vel, fw.was, fw.e_pred, fw.held), fb)
    return (1.0 - s) * a[0] + s * b[0]


@njit(cache=True, _nrt=False)
def fill_frames(model, chain, sc, fw, books, frames):
    """The frames at times strictly inside the last step (t0, t0 + h), from the state at
    its start and at its end (one due at its end waits for the next step's start), as
    many as the buffers hold; False if some are left for when they have been emptied.
    A frame at tf, the fraction s = (tf - t0) / h of the step, on a state of its own
    (``FrameWork``; the run's is not touched):

    * axes: each turned from the step's start by s h times the rates the step turns it
      at (``rotate_axes``: the step's own turn when s = 1; landed segments stay), then
      put back on the anchors and the bend limits by the step's projection (``_project``);
    * rates w: linear in s between the step's start (before its impulses) and its end;
    * the kinetic energy and the books (lost energies, floor impulse): the start's plus
      s times the step's change (so the frame's energy books close as well as its ends'
      do: T of interpolated velocities would dip by s (1 - s) |dV|^2 / 2 in a step whose
      impulses change V by dV, a landing's);
    * anchors and locks: the step's end (its touches are made at its start);
    * the anchors' force and the pile's pull: the step's means."""
    t0, h = fw.t0[0], fw.h[0]
    if h <= 0.0:
        return True
    t_end = t0 + h
    _energies(chain, sc, books, fw.end)
    while frames.next[0] < t_end - _frame_tol(t_end):
        if frames.count[0] >= frames.t.shape[0]:
            return False
        kinetic = _state_between((frames.next[0] - t0) / h, model, chain, sc, fw)
        record_frame(frames.next[0], kinetic, fw.chain, sc, fw.books, frames)
    return True


@njit(cache=True, _nrt=False)
def fall_speed(e, w, anchored, pv, vel):
    """v = -mean V_z over the airborne segments, V their centres' velocities from the
    axes and rates alone (``kinematics.velocities``, into the scratch pv, vel); 0 when
    every segment has landed."""
    velocities(e, w, pv, vel)
    fall = 0.0
    m = 0
    for i in range(e.shape[0] - 1, -1, -1):
        if not is_landed(anchored, i):
            fall -= vel[i, 2]
            m += 1
    return fall / m if m > 0 else 0.0


@njit(cache=True, _nrt=False)
def _step_by_rule(dt, model, chain, sc):
    """The step before any cut (part 1): dt under dt_rule fixed; under landing
    dt v_ff / v, v the airborne segments' mean fall speed (``fall_speed``) and
    v_ff = g t_ff, within LANDING_STEP_RANGE of dt either way (its top when nothing falls).
    A segment takes about 2b / v to land: each landing gets the same number of steps at
    every speed, as many as dt gives it at the end of a free fall."""
    if model.dt_rule != DT_LANDING:
        return dt
    v = fall_speed(chain.Y[0], chain.Y[1], chain.anchored, sc.pv, sc.vel)
    if v <= model.v_ff / LANDING_STEP_RANGE:
        return LANDING_STEP_RANGE * dt
    return dt * max(1.0 / LANDING_STEP_RANGE, model.v_ff / v)


@njit(cache=True, _nrt=False)
def step(t, dt, model, chain, ws, sc, fw, books, frames, trace, log):
    """One Moreau-Jean step from t (module docstring, parts 1-6), of size dt at most.
    Returns (code, t + h): 0, or ERR_*."""
    e, w, anchored = chain.Y[0], chain.Y[1], chain.anchored
    if _frame_due(frames.next[0], t):
        record_frame(frames.next[0], kinetic_energy_maximal(sc.vmax, w), chain, sc, books, frames)
    h = min(_step_by_rule(dt, model, chain, sc), model.t_stop - t)
    fw.h[0] = 0.0  # no frame inside this step unless one may be (cuts only shorten it)
    inside = frames.next[0] < t + h
    if inside:
        _copy3(e, fw.e0)
        _energies(chain, sc, books, fw.start)
    _copy3(sc.vmax, sc.v_pre)
    na = _touches(t, 0, model, chain, sc, books)
    if model.e_floor > 0.0:
        _aim_rebounds(0, na, model.e_floor, sc)
    _copy3(w, sc.w_pre)
    reuse_factors(ws.S, np.bool_(True))  # the axes stay through the step's trials and cuts
    for attempt in range(MAX_CUTS + 1):  # the step, cut again while a point would pass the floor
        if attempt > 0:
            _copy3(sc.w_pre, w)
        _free_velocity(h, model, chain, ws, sc)
        _index_set(h, model, chain, sc)
        code = _solve(model, chain, ws, sc)
        if code < 0:
            reuse_factors(ws.S, np.bool_(False))
            return code, t
        s_turn = _turn_cut(h, w)
        s = _landing_cut(h, model, chain, sc)
        if (s >= 1.0 - LAND_SLACK and s_turn >= 1.0) or attempt == MAX_CUTS:
            break
        if s_turn < s:
            h *= s_turn
        elif s * h < MIN_CUT * dt:  # at the floor already: it touches now, the step stays
            _first_to_land(s, model.e_floor, sc)
            _copy3(sc.w_pre, w)
            more = _touches(t, na, model, chain, sc, books)
            if model.e_floor > 0.0:
                _aim_rebounds(na, more, model.e_floor, sc)
            na += more
        else:
            h *= s
    reuse_factors(ws.S, np.bool_(False))  # the position update turns them
    if model.e_floor > 0.0 and na > 0:
        _leave_floor(h, na, chain, sc)
    _book(t, h, na, model.e_floor, chain, ws, sc, books, log)
    if any_smooth_law(model):
        books.lost_damping[0] += _smooth_work(h, sc.w_pre, w, ws.tau)
    books.floor_flow[2] += h * landed_count(anchored)
    books.n_evals[0] += 1
    settle_anchors(chain, model.cone, model.alpha)
    for i in range(e.shape[0]):
        if is_landed(anchored, i):
            for q in range(3):
                sc.vmax[i, q] = 0.0
    z_top = 2.0 * np.sum(e[:, 2])
    _mid_rates(model.theta, w, sc)
    u0 = potential_energy(e)
    rotate_axes(e, sc.w_mid, h, anchored, e)
    books.work_error[0] += _kick_energy(h, anchored, sc.v_pre) + potential_energy(e) - u0
    _project(model, chain, ws, Projection(sc.gaps, sc.pv, sc.pts, sc.vel, sc.was, sc.e_pred, sc.held), books)
    if model.e_floor > 0.0:
        _let_go(chain)
    t_end = t + h
    if inside:
        fw.t0[0], fw.h[0] = t, h
    z_end = 2.0 * np.sum(e[:, 2])
    if top_event(model.floor) and z_top > 0.0 and z_end <= 0.0:
        if fall_ended(books, t + h * z_top / (z_top - z_end), True, False):
            point_positions(e, sc.pts)
            log_row(log, books.t_fall[0], LOG_TOP, 0, 0.0, 0.0, 0.0, 0.0, sc.pts, 0)
    lowest_point(e, books.lowest)
    books.n_steps[0] += 1
    kt = trace.count[0]
    trace.t[kt] = t_end
    trace.z[kt] = z_end
    trace.count[0] = kt + 1
    if not (math.isfinite(z_end) and math.isfinite(np.sum(w))):
        return ERR_NAN, t_end
    return 0, t_end


@entry
@njit(cache=True, nogil=True, _nrt=False)  # the GIL released: other threads (a sweep's event loop) run meanwhile
def run_steps(t, dt, model, chain, ws, sc, fw, books, frames, trace, log):
    """Steps until the fall ends, the stop time, full buffers or ``model.return_every``
    steps, each followed by the frames inside it (``fill_frames``; a return for full
    buffers fills the rest first on the next call).  Returns (code, t): TS_* or a
    negative ERR_*."""
    n = chain.Y.shape[1]
    room = 3 * n + 8
    taken = 0
    while True:
        if not fill_frames(model, chain, sc, fw, books, frames):  # the last step's first
            return TS_BUFFER, t
        if all_anchored(chain.anchored):
            books.t_landed[0] = t
            fall_ended(books, t, True, True)
            return TS_LANDED, t
        if taken >= model.return_every:
            return TS_RETURN, t
        if log.t.shape[0] - log.n[0] < room:
            return TS_RETURN, t
        if trace.count[0] >= trace.t.shape[0] - 2 or frames.count[0] >= frames.t.shape[0] - 1:
            return TS_BUFFER, t
        if t >= model.t_stop * (1.0 - 1e-14):
            return TS_STOP, t
        if books.n_steps[0] >= model.max_steps:
            return TS_MAX_STEPS, t
        code, t = step(t, dt, model, chain, ws, sc, fw, books, frames, trace, log)
        if code < 0:
            return code, t
        taken += 1
