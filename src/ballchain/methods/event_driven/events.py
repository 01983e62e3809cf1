"""What happens at an event instant (docs/model.md, "Events"), compiled: the one event
handler ``handle_event``, and the loop ``run_events`` that alternates the integrator
and the handler without returning to Python.

``handle_event`` applies, in this order:

1. unlock the hinges whose multiplier crossed zero (they cannot re-lock in this
   instant); in the pivot model, record the top end reaching the floor;
2. anchor the points the floor model lets touch the floor (``rules.floor_contacts``);
3. one Moreau impact (``impacts.velocity_impact``) over every new anchor and every
   hinge at its limit (Newton's with restitution: ``contacts.newton``); with
   restitution at the floor, a landing point that rebounds is not anchored;
4. the acceleration-level LCP (``impacts.lock_set``): which hinges at the limit stay
   locked.  A hinge released in this instant that accelerates back to its limit and
   would return slower than ``hold_rate``, or after an excursion below
   ``hold_apex``, is held at its limit (``rules.must_hold``: the limit of the
   converging series of impacts it would start), and so is a point that rebounded from
   the floor and would come back slower than ``hold_rate_floor`` (anchored); steps 3-4
   are then solved again;
5. new locks hold the angle reached; the state is projected onto the constraints; each
   event function is armed or marked departing (``arm_functions``), and the apex of
   each departing constraint that will come back is predicted (``apex_times``), so that
   its return is resolved even within one step.

The event log is kept in preallocated arrays (``state.Log``); each row is one of
``rules.EVENT_KINDS``.  The run's accounts are ``state.Books``; the handler's scratch is
``Instant`` (allocated by ``new_instant`` beside it).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ...contacts.coulomb import slides
from ...contacts.newton import floor_rebound, rebounds
from ...core.base import floor_z, floor_z_rates
from ...core.blocks import reuse_factors
from ...core.books import PROJECTED_AT_INSTANTS, fill_frame_books, log_row, mechanical_energy
from ...core.impacts import hinge_gaps, hinge_rates, lock_set, new_impact_work, velocity_impact
from ...core.kinematics import kinetic_energy, point_positions, project_state, projection_tol, velocities
from ...core.rules import (
    GAP_TOL,
    LOG_ANCHOR,
    LOG_BOUNCE,
    LOG_HOLD,
    LOG_IMPULSE,
    LOG_LANDING,
    LOG_LIFT,
    LOG_LOCK,
    LOG_PIN,
    LOG_RELEASE,
    LOG_TOP,
    LOG_UNLOCK,
    RATE_TOL,
    SLIDING,
    Z_TOL,
    fall_ended,
    fall_over,
    hold_at,
    limit_in_force,
    must_hold,
    settle_anchors,
)
from ...core.unilateral import floor_lock_set, floor_velocity_impact, new_floor_work
from ...floors.dispatch import floor_contacts, top_event
from ...jit import entry, njit
from .integrator import ADV_EVENT, advance
from .slides import (
    PINNED,
    absolute_points,
    after_impact,
    base_velocity,
    energies,
    held_candidates,
    hold_leaving,
    log_lifts,
    mechanical,
    release_bounces,
    start_flight,
    touch_candidates,
)
from .watch import EV_LANDING, EV_LIFT, EV_TOP, EV_UNLOCK, apex_times, arm_functions


@entry
@njit(cache=True, _nrt=False)
def log_room(n):
    """Log rows one event instant can add at most: per hinge a lock/impulse/hold row and
    a release row, unlocks, per point a landing or an anchor-impulse row, the top."""
    return 3 * (n - 1) + (n + 1) + 8


# handle_event / run_events status codes (negative: the run cannot go on)
EV_OK = 0
EV_LANDED = 10  # every point anchored
EV_RETURN = 11  # returned to Python for progress, log space or the trace buffer
ERR_IMPACT_LCP, ERR_ENERGY, ERR_LOCK_LCP, ERR_ZENO, ERR_MAX_EVENTS = -1, -2, -3, -4, -5
ZENO_EVENTS = 20000  # event instants within the model's zeno_window that stop the run

# The event handler's scratch, in bundles by purpose (a step of the handler receives only
# the bundles it uses):
Hinges = namedtuple(
    "Hinges",
    [
        "gaps",  # (N-1,): g_k of every hinge
        "rates",  # (N-1,): dg_k/dt
        "exclude",  # (N-1,) uint8: unlocked in this instant (cannot re-lock in it)
        "cand",  # (N-1,) uint8: candidates of the complementarity problem
        "active",  # (N-1,) uint8: its active set
        "was_locked",  # (N-1,) uint8: locked before the instant
        "new_lock",  # (N-1,) uint8: took an impulse in the first round without having been locked
        "in_force",  # (N-1,) uint8: the hinge's limit is in force (rules.limit_in_force)
        "forced",  # (N-1,) uint8: held at its limit by the accumulation rule
        "imp_sum",  # (N-1,): each hinge's impulse, summed over the rounds
        "lost_h",  # (N-1,): kinetic energy lost at each hinge
    ],
)
Accel = namedtuple(
    "Accel",
    [
        "de",  # (N, 3): de/dt at the lock set's accelerations
        "dw",  # (N, 3)
        "ddg",  # (N-1,): d2g_k/dt2
        "lam",  # (N-1,): lock multipliers
    ],
)
Contacts = namedtuple(
    "Contacts",
    [
        "new_anchor",  # (N+1,) int64: the points anchored at this instant
        "pre_v",  # (N+1, 3): their velocities before the impact
        "anchor_impulse",  # (N+1, 3): the floor's impulse per point, summed over the rounds
        "fv",  # (N+1,): scratch of the floor functions
        "bounce",  # (N+1,): the upward velocity of a point that left the floor at this instant (else 0)
        "az",  # (N+1,): scratch, the points' vertical accelerations
        "touch",  # (N+1,) int64: scratch, points touching the floor after a round
    ],
)
Points = namedtuple(
    "Points",
    [
        "pts",  # (N+1, 3): point positions (they do not change at an instant)
        "pv",  # (N+1, 3): point velocities
        "vel",  # (N, 3): centre velocities
    ],
)
Floor = namedtuple(
    "Floor",
    [
        "fcand",  # (N+1,) uint8: the instant's floor candidates (a frictionless floor: ``slides``)
        "lifted",  # (N+1,) uint8: left the floor at this instant (not a candidate again in it)
        "held",  # (N+1,) uint8: held by the floor before the lock set (its lift-offs logged)
        "seen",  # (N+1,) uint8: the instant's first floor candidates (held before it, or touching)
        "pz",  # (N+1,): the floor's vertical force on each point after the lock set
        "pu",  # (2, 3): point N's position and velocity
        "fw",  # the floor's complementarity scratch (unilateral.FloorWork)
        "en",  # (2,): U, T
    ],
)
Instant = namedtuple(
    "Instant",
    [
        "hs",  # Hinges
        "acc",  # Accel
        "ct",  # Contacts
        "pt",  # Points
        "iw",  # the impacts' scratch (impacts.ImpactWork)
        "recent",  # (ZENO_EVENTS + 1,): ring of the latest event instants' times
        "fl",  # Floor
    ],
)


def new_instant(n: int) -> Instant:
    """The event handler's scratch for an N-segment chain."""
    nh = max(n - 1, 0)
    u8 = lambda: np.zeros(nh, np.uint8)  # noqa: E731
    hs = Hinges(np.zeros(nh), np.zeros(nh), u8(), u8(), u8(), u8(), u8(), u8(), u8(), np.zeros(nh), np.zeros(nh))
    acc = Accel(np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(nh), np.zeros(nh))
    ct = Contacts(
        np.zeros(n + 1, np.int64),
        np.zeros((n + 1, 3)),
        np.zeros((n + 1, 3)),
        np.zeros(n + 1),
        np.zeros(n + 1),
        np.zeros(n + 1),
        np.zeros(n + 1, np.int64),
    )
    pt = Points(np.zeros((n + 1, 3)), np.zeros((n + 1, 3)), np.zeros((n, 3)))
    u8p = lambda: np.zeros(n + 1, np.uint8)  # noqa: E731
    fl = Floor(u8p(), u8p(), u8p(), u8p(), np.zeros(n + 1), np.zeros((2, 3)), new_floor_work(n), np.zeros(2))
    return Instant(hs, acc, ct, pt, new_impact_work(n), np.zeros(ZENO_EVENTS + 1), fl)


@njit(cache=True, _nrt=False)
def _unlocks_and_top(t, model, chain, hs, pt, fl, books, log, found):
    """Step 1: unlock the hinges whose multiplier crossed zero (they cannot re-lock in
    this instant); on a frictionless floor, let go the points whose floor force crossed
    zero (a lift-off; not held again in this instant); the top end reaching the floor
    (floor models with a top event) ends the fall.  Returns whether a landing event fired."""
    for k in range(hs.exclude.shape[0]):
        hs.exclude[k] = 0
    for j in range(fl.lifted.shape[0]):
        fl.lifted[j] = 0
    any_landing = np.bool_(False)
    for i in range(found.n[0]):
        if found.time[i] > t + 10.0 * model.xtol:
            continue
        kd = found.kind[i]
        if kd == EV_UNLOCK:
            k = found.idx[i]
            if chain.locked[k]:
                chain.locked[k] = 0
                hs.exclude[k] = 1
                log_row(log, t, LOG_UNLOCK, k, 0.0, 0.0, 0.0, 0.0, pt.pts, k + 1)
        elif kd == EV_TOP:
            if fall_ended(books, t, True, False):
                log_row(log, t, LOG_TOP, 0, 0.0, 0.0, 0.0, 0.0, pt.pts, 0)
        elif kd == EV_LANDING:
            any_landing = True
        elif kd == EV_LIFT:
            j = found.idx[i]
            if chain.anchored[j] != 0:
                chain.anchored[j] = 0
                fl.lifted[j] = 1
                log_row(log, t, LOG_LIFT, j, 0.0, 0.0, 0.0, 0.0, pt.pts, j)
    return any_landing


@njit(cache=True, _nrt=False)
def _anchor_contacts(t, model, chain, ct, pt, any_landing, iw):
    """Step 2: the points the floor model lets touch the floor are anchored where they
    touched (marked 2: their neighbours still move during the impact); returns their
    number (ct.new_anchor, their velocities before the impact in ct.pre_v).  With
    restitution at the floor, iw.rebound gets the velocity each is to leave it with
    (``contacts.newton.floor_rebound``)."""
    e, w = chain.Y[0], chain.Y[1]
    velocities(e, w, pt.pv, pt.vel)
    na = floor_contacts(model.floor, e, pt.pts, pt.pv, chain.anchored, any_landing, Z_TOL, ct.new_anchor)
    iw.n_rebound[0] = 0
    if model.e_floor > 0.0:
        for j in range(ct.bounce.shape[0]):
            ct.bounce[j] = 0.0
    for r in range(na):
        j = ct.new_anchor[r]
        for q in range(3):
            ct.pre_v[r, q] = pt.pv[j, q]
        _touch(t, chain, j, pt, iw, model.e_floor)
    return na


@njit(cache=True, _nrt=False)
def _touch(t, chain, j, pt, iw, e_floor):
    """Point j touches the floor at t: anchored where it touched (|z| < Z_TOL; marked 2
    while its impact is solved) and, with restitution at the floor (``e_floor`` > 0), given
    the velocity it is to leave with (iw.rebound, ``contacts.newton.floor_rebound``)."""
    hold_at(chain, j, pt.pts)
    chain.anchored[j] = 2
    chain.anchor_t[j] = t
    iw.rebound[j] = floor_rebound(pt.pv[j, 2], e_floor)  # (0 for e_floor = 0)
    iw.n_rebound[0] += 1 if iw.rebound[j] > 0.0 else 0


@njit(cache=True, _nrt=False)
def _leave_floor(model, chain, ct, pt, na, iw):
    """After a round's impact, with restitution at the floor: a point that landed in it
    and rebounds (``contacts.newton.rebounds``) is not anchored (ct.bounce: its upward
    velocity)."""
    if iw.n_rebound[0] == 0:  # (no landing of this round rebounds)
        return
    e, w = chain.Y[0], chain.Y[1]
    velocities(e, w, pt.pv, pt.vel)
    for r in range(na):
        j = ct.new_anchor[r]
        if iw.rebound[j] > 0.0 and rebounds(pt.pv[j, 2], model.e_floor, RATE_TOL):
            chain.anchored[j] = 0
            chain.anchor_t[j] = np.nan
            for q in range(3):
                chain.anchor_pos[j, q] = np.nan
            ct.bounce[j] = pt.pv[j, 2]
        iw.rebound[j] = 0.0
    iw.n_rebound[0] = 0


@njit(cache=True, _nrt=False)
def _touch_floor(t, model, chain, ct, pt, na, iw):
    """With restitution at the floor, after a round: a free point at the floor that this
    instant's impulses have turned down (``floor_contacts`` on the new velocities) lands
    now, in the next round, not a round-off band deeper at the next step (otherwise a
    point kicked down again and again by its neighbours' locks would creep into the
    floor); one that has touched before in this instant lands inelastically, so that
    the rounds end.  Returns the new count of the instant's touches (ct.new_anchor) and
    the number of points that touch now."""
    e, w = chain.Y[0], chain.Y[1]
    velocities(e, w, pt.pv, pt.vel)
    n_new = floor_contacts(model.floor, e, pt.pts, pt.pv, chain.anchored, np.bool_(True), Z_TOL, ct.touch)
    for s in range(n_new):
        j = ct.touch[s]
        r = 0
        while r < na and ct.new_anchor[r] != j:
            r += 1
        again = r < na
        if not again:
            ct.new_anchor[na] = j
            for q in range(3):
                ct.pre_v[na, q] = pt.pv[j, q]
            na += 1
        ct.bounce[j] = 0.0
        _touch(t, chain, j, pt, iw, 0.0 if again else model.e_floor)
    return na, n_new


@njit(cache=True, _nrt=False)
def _hold_bouncing(t, model, chain, ct, pt, acc, iw):
    """The accumulation limit at the floor: a point that left the floor at this instant
    and would come back slower than hold_rate_floor (``--hold-rate-floor``; hold_rate's by
    default), or after a flight too small to resolve
    (``rules.must_hold`` on its height), or that a later round's impulses have turned
    back down (it no longer rebounds), is anchored where it is instead (marked 2: the
    next round's impact stops it).  Returns the number anchored."""
    e, w = chain.Y[0], chain.Y[1]
    n = e.shape[0]
    az = 0.0  # d2z_j/dt2 = 2 sum_{i>=j} (dw_i x e_i + w_i x de_i)_z
    ct.az[n] = 0.0
    for j in range(n - 1, -1, -1):
        az += 2.0 * (acc.dw[j, 0] * e[j, 1] - acc.dw[j, 1] * e[j, 0] + w[j, 0] * acc.de[j, 1] - w[j, 1] * acc.de[j, 0])
        ct.az[j] = az
    velocities(e, w, pt.pv, pt.vel)
    nheld = 0
    for j in range(n + 1):
        if ct.bounce[j] > 0.0 and chain.anchored[j] == 0:
            vz = pt.pv[j, 2]  # (a later round's impulses may have turned it back down)
            if not rebounds(vz, model.e_floor, RATE_TOL) or must_hold(
                vz, ct.az[j], model.hold_rate_floor, model.hold_apex
            ):
                _touch(t, chain, j, pt, iw, 0.0)
                ct.bounce[j] = 0.0
                nheld += 1
    return nheld


@njit(cache=True, _nrt=False)
def _impact_candidates(model, chain, hs, ct):
    """The hinges the impact concerns: limits in force, at the limit or locked, not just
    unlocked (hs.cand); the initial active set: locked or approaching (rate < -RATE_TOL).
    Returns whether any candidate approaches (an impact, not a touch)."""
    e, w, anchored, locked = chain.Y[0], chain.Y[1], chain.anchored, chain.locked
    hinge_gaps(e, model.cos_alpha, hs.gaps)
    hinge_rates(e, w, hs.rates)
    any_approaching = False
    for k in range(locked.shape[0]):
        hs.in_force[k] = 1 if limit_in_force(anchored, k, model.cone, model.alpha) else 0
        if not hs.in_force[k]:
            locked[k] = 0
        hs.cand[k] = 1 if (hs.in_force[k] and (hs.gaps[k] <= GAP_TOL or locked[k] != 0) and hs.exclude[k] == 0) else 0
        approaching = hs.cand[k] != 0 and hs.rates[k] < -RATE_TOL
        any_approaching = any_approaching or approaching
        hs.was_locked[k] = locked[k]
        hs.new_lock[k] = 0
        hs.forced[k] = 0
        hs.imp_sum[k] = 0.0
        hs.lost_h[k] = 0.0
        hs.active[k] = 1 if (locked[k] != 0 or approaching) else 0
    ct.anchor_impulse[:] = 0.0
    return any_approaching


@njit(cache=True, _nrt=False)
def _apply_impact(t, rnd, model, chain, ws, hs, ct, iw, fl, books):
    """Step 3: one impact over the new anchors and the candidates (Moreau's, or Newton's
    restitution at the limits, ``model.e_lock``, and at the floor, iw.rebound; impulses summed into the books, the
    hinge log and the floor's impulse); the hinges it keeps at their limit are locked (a
    hinge that rebounds, ``contacts.newton.rebounds``, is not).  Returns False if the
    impact problem failed."""
    e, w, locked = chain.Y[0], chain.Y[1], chain.locked
    hinge_rates(e, w, hs.rates)
    if rnd == 0:  # (Newton's law compares with the rates before the instant, in every round)
        hinge_rates(e, w, iw.rates_before)
    if slides(model.friction):  # (the floor's rows unilateral: ``slides``; the centres move with point N)
        base_velocity(t, chain, fl.pu, iw)
        if (
            floor_velocity_impact(
                e, w, chain.anchored, hs.cand, hs.forced, hs.active, fl.fcand, model.e_lock, ws, iw, fl.fw
            )
            < 0
        ):
            return False
        after_impact(chain, fl.fw.vc, fl.pu)
    elif velocity_impact(e, w, chain.anchored, hs.cand, hs.forced, hs.active, model.e_lock, ws, iw) < 0:
        return False
    books.lost_locking[0] += iw.split[0]
    books.lost_landing[0] += iw.split[1]
    for j in range(ct.anchor_impulse.shape[0]):  # the floor's impulse on the chain: every anchor, new or old
        for q in range(3):
            ct.anchor_impulse[j, q] += iw.anchor_impulse[j, q]
            books.floor_impulse[q] += iw.anchor_impulse[j, q]
    for k in range(locked.shape[0]):
        hs.imp_sum[k] += iw.impulse[k]
        if model.e_lock > 0.0:  # (its impact may have taken two passes: velocity_impact)
            hs.lost_h[k] += iw.lost_hinge[k]
        else:
            hs.lost_h[k] += -0.5 * iw.impulse[k] * (hs.rates[k] + iw.rates_after[k])
        if rnd == 0 and hs.active[k] and not hs.was_locked[k]:
            hs.new_lock[k] = 1
        # hinges kept at the limit by the impact (not one that rebounds from it)
        locked[k] = 0 if rebounds(iw.rates_after[k], model.e_lock, RATE_TOL) and not hs.forced[k] else hs.active[k]
    hinge_rates(e, w, hs.rates)
    return True


@njit(cache=True, _nrt=False)
def _settle_anchors(model, chain, hs):
    """After the first impact: the new anchors are made (``rules.settle_anchors``) and
    the limits in force recorded (hs.in_force)."""
    settle_anchors(chain, model.cone, model.alpha)
    for k in range(chain.locked.shape[0]):
        hs.in_force[k] = 1 if limit_in_force(chain.anchored, k, model.cone, model.alpha) else 0


@njit(cache=True, _nrt=False)
def _lock_set(model, chain, ws, hs, acc, fl):
    """Step 4: which hinges at the limit (at rest there, or locked) stay locked, the
    acceleration-level LCP (on a frictionless floor with the points it holds: which it
    keeps, ``slides``; fl.pz their forces).  Returns False if it failed."""
    e, w, locked = chain.Y[0], chain.Y[1], chain.locked
    for k in range(locked.shape[0]):
        c2 = (
            (hs.in_force[k] and hs.gaps[k] <= GAP_TOL and abs(hs.rates[k]) <= RATE_TOL) or locked[k] != 0
        ) and hs.exclude[k] == 0
        hs.cand[k] = 1 if c2 else 0
        hs.active[k] = 1 if (locked[k] != 0 and c2) else 0
    if slides(model.friction):
        held_candidates(chain.anchored, fl.lifted, fl.fcand)
        if (
            floor_lock_set(
                e, w, chain.anchored, hs.cand, hs.active, fl.fcand, ws, acc.de, acc.dw, acc.ddg, acc.lam, fl.fw
            )
            < 0
        ):
            return False
        for j in range(fl.pz.shape[0]):
            fl.pz[j] = fl.fw.pz[j] if chain.anchored[j] != 0 else 0.0
    elif lock_set(e, w, chain.anchored, hs.cand, hs.active, ws, acc.de, acc.dw, acc.ddg, acc.lam) < 0:
        return False
    for k in range(locked.shape[0]):
        locked[k] = hs.active[k]
    return True


@njit(cache=True, _nrt=False)
def _hold_returning(model, chain, hs, acc):
    """The accumulation limit: a hinge this instant has released (it was locked, or took
    an impulse) that accelerates back to its limit and would return either slower than
    hold_rate or after an excursion too small to resolve is held (hs.forced), and the
    next round's candidates are set.  Returns the number newly held."""
    locked = chain.locked
    nh = locked.shape[0]
    nhold = 0
    for k in range(nh):
        if (
            locked[k]
            or hs.forced[k]
            or not (hs.was_locked[k] or hs.new_lock[k])
            or hs.exclude[k]
            or hs.gaps[k] > GAP_TOL
        ):
            continue
        if must_hold(hs.rates[k], acc.ddg[k], model.hold_rate, model.hold_apex):
            hs.forced[k] = 1
            nhold += 1
    return nhold


@njit(cache=True, _nrt=False)
def _next_round(chain, hs):
    """The candidates and the initial active set of the next round's impact, once the
    accumulation rule has held a hinge or a point."""
    locked = chain.locked
    for k in range(locked.shape[0]):
        hs.cand[k] = (
            1
            if ((hs.in_force[k] and (hs.gaps[k] <= GAP_TOL or locked[k] != 0 or hs.forced[k])) and not hs.exclude[k])
            else 0
        )
        hs.active[k] = 1 if (locked[k] or hs.forced[k]) else 0


@njit(cache=True, _nrt=False)
def _log_instant(t, na, model, chain, hs, ct, pt, iw, fl, log):
    """The log: one row per constraint that acted (hinges, new anchors, old anchors that
    took an impulse).  A contact that Newton's law would rebound (``contacts.newton``: it
    approached faster than RATE_TOL / e before the instant) and that a fallback rule kept
    at its limit is logged as such: ``hold`` (a hinge: the accumulation rule, or an impact
    taken inelastic because the law would create energy) or ``pin`` (a landing point; on a
    frictionless floor also one the impact would lift off a little, held by the
    accumulation rule: ``slides.hold_leaving``, its impulse of either sign)."""
    locked, pts = chain.locked, pt.pts
    e_lock, e_floor = model.e_lock, model.e_floor
    slide = slides(model.friction)
    for k in range(locked.shape[0]):
        was, new = hs.was_locked[k], hs.new_lock[k]
        held = e_lock > 0.0 and locked[k] != 0 and rebounds(-e_lock * iw.rates_before[k], e_lock, RATE_TOL)
        if hs.forced[k] or (held and (hs.imp_sum[k] != 0.0 or new)):
            log_row(log, t, LOG_HOLD, k, hs.imp_sum[k], 0.0, 0.0, hs.lost_h[k], pts, k + 1)
        elif hs.imp_sum[k] != 0.0 or new:
            log_row(log, t, LOG_IMPULSE if was else LOG_LOCK, k, hs.imp_sum[k], 0.0, 0.0, hs.lost_h[k], pts, k + 1)
        elif locked[k] and not was:  # a touch that locks
            log_row(log, t, LOG_LOCK, k, 0.0, 0.0, 0.0, 0.0, pts, k + 1)
        if not locked[k] and (was or new or hs.forced[k]):
            log_row(log, t, LOG_RELEASE, k, 0.0, 0.0, 0.0, 0.0, pts, k + 1)
    aimp = ct.anchor_impulse
    for r in range(na):
        j = ct.new_anchor[r]
        i0, i1, i2 = aimp[j, 0], aimp[j, 1], aimp[j, 2]
        if slide and chain.anchored[j] == 0 and i2 == 0.0 and fl.fw.forced[j] == 0:
            continue  # (a point at the floor that the impact neither held nor touched: no landing)
        lost = -0.5 * (i0 * ct.pre_v[r, 0] + i1 * ct.pre_v[r, 1] + i2 * (ct.pre_v[r, 2] + ct.bounce[j]))
        kind = LOG_LANDING
        if chain.anchored[j] == 0 and (not slide or ct.bounce[j] > 0.0):
            kind = LOG_BOUNCE
        elif rebounds(floor_rebound(ct.pre_v[r, 2], e_floor), e_floor, RATE_TOL) or (
            slide and fl.fw.forced[j] == PINNED
        ):
            kind = LOG_PIN  # (a fallback rule held it: Newton's law would bounce it, or the impact lift it, a little)
        log_row(log, t, kind, j, i0, i1, i2, lost, pts, j)
    for j in range(chain.anchored.shape[0]):  # impulses of the floor on points anchored before this instant
        if chain.anchored[j] != 0 and (fl.held[j] != 0 if slide else chain.anchor_t[j] != t):
            i0, i1, i2 = aimp[j, 0], aimp[j, 1], aimp[j, 2]
            if (
                slide and fl.fw.forced[j] == PINNED
            ):  # (the accumulation rule kept it on the floor: ``slides.hold_leaving``)
                log_row(log, t, LOG_PIN, j, i0, i1, i2, 0.0, pts, j)
            elif i0 != 0.0 or i1 != 0.0 or i2 != 0.0:
                log_row(log, t, LOG_ANCHOR, j, i0, i1, i2, 0.0, pts, j)


@njit(cache=True, _nrt=False)
def _finish_instant(t, model, chain, watch, ws, sc, books):
    """Step 5: new locks hold the angle reached, the state is projected onto the
    constraints, the fall may end (the top end anchored), each event function is armed
    or marked departing and the apex of each departing constraint is predicted."""
    e, w, locked = chain.Y[0], chain.Y[1], chain.locked
    for k in range(locked.shape[0]):
        if sc.hs.was_locked[k] == 0 and locked[k] != 0:
            chain.lock_cos[k] = model.cos_alpha + sc.hs.gaps[k]
    slide = slides(model.friction)
    pt, fl = sc.pt, sc.fl
    before = _mechanical(t, model, chain, pt, fl)
    project_state(chain, ws, pt.pts, pt.vel, projection_tol(e.shape[0]), np.int64(5))
    books.projected[PROJECTED_AT_INSTANTS] += _mechanical(t, model, chain, pt, fl) - before
    hinge_gaps(e, model.cos_alpha, sc.hs.gaps)
    touched = chain.anchor_t[0] == chain.anchor_t[0] if slide else chain.anchored[0] != 0
    fall_ended(books, t, False, not top_event(model.floor) and (touched or sc.ct.bounce[0] > 0.0))
    pz = fl.pz if slide else fl.fw.pz  # (the floor's forces on sliding points: none but on a frictionless floor)
    zf = floor_z(e, chain.anchored, chain.base, t)
    arm_functions(model, chain, watch, sc.hs.gaps, sc.acc.lam, pz, zf, not math.isnan(books.t_fall[0]), sc.ct.fv)
    hinge_rates(e, w, sc.hs.rates)
    velocities(e, w, pt.pv, pt.vel)
    vz0, az0 = floor_z_rates(e, w, sc.acc.de, sc.acc.dw, chain.anchored, chain.base, t)
    apex_times(t, e, w, sc.acc.de, sc.acc.dw, watch, sc.hs.rates, sc.acc.ddg, pt.pv, vz0, az0)


@njit(cache=True, _nrt=False)
def _mechanical(t, model, chain, pt, fl):
    """U + T (on a frictionless floor, where point N is: ``slides``)."""
    if slides(model.friction):
        return mechanical(t, chain, pt.pts, pt.pv, pt.vel)
    return mechanical_energy(chain.Y[0], chain.Y[1], pt.pv, pt.vel)


@njit(cache=True, _nrt=False)
def handle_event(t, model, chain, watch, ws, sc, books, log, found):
    """Apply everything that happens at the instant t (module docstring, steps 1-5) to
    the events the integrator found (``integrator.Found``).  Returns EV_OK or a negative
    error code."""
    e, w = chain.Y[0], chain.Y[1]
    hs, acc, ct, pt, fl = sc.hs, sc.acc, sc.ct, sc.pt, sc.fl
    slide = slides(model.friction)
    reuse_factors(ws.S, np.bool_(True))  # the axes stay (off after the next evaluation: integrator.advance)
    point_positions(e, pt.pts)  # (positions do not change at an instant)
    if not slide:
        any_landing = _unlocks_and_top(t, model, chain, hs, pt, fl, books, log, found)
    if slide:  # (a touch is a floor candidate, no anchor; the absolute points: ``slides``)
        absolute_points(t, chain, pt, fl.pu)  # (point N where it is, before a lift-off lets the last held point go)
        chain.base.flying[0] = 0  # (in the instant, with nothing held, point N's motion is fl.pu's: ``start_flight``)
        any_landing = _unlocks_and_top(t, model, chain, hs, pt, fl, books, log, found)
        na = touch_candidates(t, model, chain, ct, pt, any_landing, sc.iw, fl.fcand, fl.lifted, fl.pu)
        for j in range(fl.held.shape[0]):
            fl.held[j] = chain.anchored[j]
            fl.seen[j] = fl.fcand[j]
            fl.fw.forced[j] = 0
            ct.bounce[j] = 0.0
    else:
        na = _anchor_contacts(t, model, chain, ct, pt, any_landing, sc.iw)
    impact = _impact_candidates(model, chain, hs, ct) or na > 0
    T0 = _kinetic(t, model, chain, pt, fl)
    if model.e_lock > 0.0:  # (Newton's law compares with the rates before the instant, whichever round impacts first)
        hinge_rates(e, w, sc.iw.rates_before)
    settle = True
    # each round holds one more hinge, anchors one more point or makes one bounce
    for rnd in range(chain.locked.shape[0] + 2 * chain.anchored.shape[0] + 1):
        if impact and not _apply_impact(t, rnd, model, chain, ws, hs, ct, sc.iw, fl, books):
            return ERR_IMPACT_LCP
        if model.e_floor > 0.0 and not slide:
            _leave_floor(model, chain, ct, pt, na, sc.iw)
        elif model.e_floor > 0.0 and impact:
            release_bounces(model, chain, ct, sc.iw, fl.fw, na)
        if settle:
            _settle_anchors(model, chain, hs)
        if not _lock_set(model, chain, ws, hs, acc, fl):
            return ERR_LOCK_LCP
        nhold = _hold_returning(model, chain, hs, acc)
        npts = 0
        if model.e_floor > 0.0 and not slide:
            npts = _hold_bouncing(t, model, chain, ct, pt, acc, sc.iw)
            na, n_touch = _touch_floor(t, model, chain, ct, pt, na, sc.iw)
            npts += n_touch
        if slide:
            npts = hold_leaving(t, model, chain, pt, fl, fl.seen)
        if nhold + npts == 0:
            break
        if slide:  # (the next round's floor candidates: every point at the floor in this instant, not one let go
            for j in range(fl.fcand.shape[0]):  # at a lift-off event: its impact may push a free one down)
                at_floor = chain.anchored[j] != 0 or fl.fw.forced[j] != 0 or (fl.seen[j] != 0 and not fl.lifted[j])
                fl.fcand[j] = SLIDING if at_floor else 0
        _next_round(chain, hs)
        settle = npts > 0
        impact = True
    if slide:
        start_flight(t, chain, pt, fl.pu)
    if _kinetic(t, model, chain, pt, fl) > T0 * (1 + 1e-9) + 1e-12:
        return ERR_ENERGY
    if slide:
        absolute_points(t, chain, pt, fl.pu)  # (the log's positions: where point N is)
        log_lifts(t, fl.held, chain.anchored, pt.pts, log)
    _log_instant(t, na, model, chain, hs, ct, pt, sc.iw, fl, log)
    _finish_instant(t, model, chain, watch, ws, sc, books)
    return EV_OK


@njit(cache=True, _nrt=False)
def _kinetic(t, model, chain, pt, fl):
    """The kinetic energy (on a frictionless floor, with point N's velocity: ``slides``)."""
    if slides(model.friction):
        energies(t, chain, pt.pts, pt.pv, pt.vel, fl.pu, fl.en)
        return fl.en[1]
    return kinetic_energy(chain.Y[0], chain.Y[1], pt.pv, pt.vel)


@njit(cache=True, _nrt=False)
def _count_instant(t, model, ring, books):
    """Count an event instant; the accumulation guard: ERR_ZENO if ZENO_EVENTS instants
    fell within model.zeno_window, ERR_MAX_EVENTS past model.max_events, else EV_OK."""
    zcap = ring.shape[0]
    zk = books.n_instants[0]
    ring[zk % zcap] = t
    books.n_instants[0] = zk + 1
    if zk + 1 >= zcap and t - ring[(zk + 1) % zcap] < model.zeno_window:
        return ERR_ZENO
    if zk + 1 > model.max_events:  # event instants handled (not log rows)
        return ERR_MAX_EVENTS
    return EV_OK


@entry
@njit(cache=True, nogil=True, _nrt=False)  # the GIL released: other threads (a sweep's event loop) run meanwhile
def run_events(t, h, model, chain, watch, ws, st, sc, books, frames, trace, log):
    """Integrate and handle events in one compiled loop.  Returns (code, t, h): an
    integrator code (integrator.ADV_*; never ADV_EVENT; ADV_BUFFER: the trace or frame
    buffers are full), EV_LANDED, EV_RETURN (after ``model.return_every`` events, or
    when the log has no room for another event), or a negative error code (ERR_*).
    Frames get the books of the impacts as they stand when the integrator returns
    (``books.fill_frame_books``)."""
    room = log_room(chain.Y.shape[1])
    handled = 0
    while True:
        if log.t.shape[0] - log.n[0] < room:
            return EV_RETURN, t, h
        code, t, h = advance(t, h, model, chain, watch, ws, st, books, frames, trace)
        fill_frame_books(frames, books)
        if code != ADV_EVENT:
            return code, t, h
        status = handle_event(t, model, chain, watch, ws, sc, books, log, st.det.found)
        if status < 0:
            return status, t, h
        status = _count_instant(t, model, sc.recent, books)
        if status < 0:
            return status, t, h
        if fall_over(chain.anchored, chain.anchor_t, chain.anchored, model.friction, model.e_floor):
            books.t_landed[0] = t
            fall_ended(books, t, True, True)
            return EV_LANDED, t, h
        handled += 1
        if handled >= model.return_every:
            return EV_RETURN, t, h
