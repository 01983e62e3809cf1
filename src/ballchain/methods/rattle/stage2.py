"""The landings and stage 2 of a RATTLE step: the points that stage 1 stopped at the
floor anchored or bounced (``land``), the velocities with the joints as equalities and
the impact law on the contacts active after stage 1 (``stage2``), and the state settled
after a landing (``settle``)."""

from __future__ import annotations

from ...contacts.coulomb import closes, grips, released, slides
from ...contacts.newton import bounce_resolved, floor_rebound
from ...core.forces import any_smooth_law
from ...core.rules import (
    LOG_STICK,
    Z_TOL,
    hold_at,
    is_landed,
    limit_in_force,
)
from ...core.rules import RATE_TOL as TOUCH_RATE  # (an approach slower than this is a touch, not an impact)
from ...floors.dispatch import floor_cascade
from ...jit import njit
from .blocks import solve_blocks
from .codes import ERR_ACTIVE_SET
from .friction import clear_impact_friction, friction_kick, friction_work, jam, landing_slips, stops
from .rebounds import leave_limits, rebound_targets, restitution
from .rows import (
    BOUNCE,
    K_BEND,
    K_FLOOR,
    booked_rates,
    is_floor,
    row_rates,
)
from .smooth import second_smooth_kick
from .stage1 import ROUNDS_MAX, _factor, add_impulses, half_kick, position_tol
from .state import HELD, PINNED, point_positions, point_vz, point_z

RATE_TOL = 1e-10  # sqrt(g b): a released hinge closing faster than this is put back in stage 2
HOLD_RATE = 1e-6  # sqrt(g b): a rebound slower than this is not made (held: the event method's default threshold)
FIXED_POINT_MAX = 40  # finite friction: stage 2 solved again at most this many times for the landings' slips
#   (secant steps: an affine root takes two); then the points that would slip are held (``friction.jam``)
# ... nor one off the floor whose flight, 2 v / g, would last fewer steps than newton.FLIGHT_STEPS
#   (``newton.bounce_resolved``): a point resting on the floor reaches it again at g h a step, and at
#   HOLD_RATE alone bounced every other step for good (N = 512 at E = 0.3: the step cut to 1/500 of its
#   size and 600 000 bounces a point)


@njit(cache=True, _nrt=False)
def land(t, h, model, mo, sc, landings):
    """Step 2: the points that stage 1 stopped at the floor are anchored there, for good
    (marked 2 while stage 2 solves their impact; where: ``rules.hold_at``).  Returns
    their number (listed in sc.new_anchor).  With restitution at the floor a point that
    would leave it faster than HOLD_RATE (``newton.floor_rebound`` of the vertical velocity
    it reached the floor with, ``impact_rates``), on a flight of ``newton.FLIGHT_STEPS`` steps
    of h or more (``newton.bounce_resolved``), bounces instead: not anchored, listed, its
    velocity's rows in stage 2 (``rows.BOUNCE``: sc.rebound its upward velocity).  A
    shorter flight is not resolved by the steps: the series of bounces ends there, at
    the step's scale, and the point is anchored.  On a
    frictionless floor (``coulomb.slides``)
    nothing is anchored: the points that stage 1 stopped and that were not touching it
    are its new contacts (listed; a first touch's time in anchor_t), and the floor rows
    stay on for stage 2; with restitution at the floor a new contact that would bounce
    (the rule above) keeps its height row, aimed at its upward velocity (sc.rebound; its
    horizontal velocity kept), and a shorter bounce is not made: it stays on the floor,
    sliding (a ``pin`` row).  With finite friction (``coulomb.grips``) a new touch is anchored
    (listed; stage 2 checks its impact against the cone: ``friction.landing_slips``) and a
    sliding point keeps its floor row, or, where it stops (``friction.stops``), is anchored
    (not listed: counted in the second number returned); a frame's step (not ``landings``)
    anchors nothing.  Returns (landings, stops)."""
    slide = slides(model.friction)
    grip = grips(model.friction)
    point_positions(mo.c, mo.e, sc.pts)
    na, ns = 0, 0
    for j in range(mo.e.shape[0] + 1):
        approach = sc.rebound[j]  # (``impact_rates``: 0 without restitution)
        sc.rebound[j] = 0.0
        if grip:
            if sc.floor_on[j] == 0 or mo.anchored[j] != 0 or not landings:
                continue
            hold = mo.touching[j] == 0 or stops(mo, j)
            if hold:
                hold_at(mo, j, sc.pts)
                mo.anchored[j] = 2
                sc.floor_on[j] = 0
                if mo.touching[j] != 0:
                    ns += 1
                    sc.grip_log[j, 0] = LOG_STICK
                    continue
                if not mo.anchor_t[j] == mo.anchor_t[j]:  # (NaN: its first touch)
                    mo.anchor_t[j] = t
                sc.new_anchor[na] = j
                na += 1
            continue
        if slide:
            if sc.floor_on[j] != 0 and mo.touching[j] == 0:
                if not mo.anchor_t[j] == mo.anchor_t[j]:  # (NaN: its first touch)
                    mo.anchor_t[j] = t
                sc.new_anchor[na] = j
                na += 1
                v = floor_rebound(approach, model.e_floor)  # (0 for e_floor 0)
                if bounce_resolved(v, h, HOLD_RATE):  # it bounces: its height row aims at v in stage 2
                    sc.rebound[j] = v
                elif model.e_floor > 0.0 and (v > TOUCH_RATE or point_vz(sc.start, j) < -TOUCH_RATE):
                    sc.fallback[j] |= PINNED  # (kept on the floor: the bounce is too short to resolve)
            continue
        if sc.floor_on[j] != 0 and mo.anchored[j] == 0:
            v = floor_rebound(approach, model.e_floor)  # (0 for e_floor 0)
            if bounce_resolved(v, h, HOLD_RATE):  # it bounces: not anchored; stage 2 gives it (0, 0, v)
                sc.rebound[j] = v
                sc.floor_on[j] = BOUNCE
                sc.new_anchor[na] = j
                na += 1
                continue
            if model.e_floor > 0.0 and (v > TOUCH_RATE or point_vz(sc.start, j) < -TOUCH_RATE):
                sc.fallback[j] |= PINNED  # (Newton's law would bounce it: the bounce is too short to resolve)
            hold_at(mo, j, sc.pts)
            mo.anchored[j] = 2
            mo.anchor_t[j] = t
            sc.new_anchor[na] = j
            na += 1
        sc.floor_on[j] = 0
    if na > 0 and not slide:
        na = _cascade(t, model, mo, sc, na)
    return na, ns


@njit(cache=True, _nrt=False)
def _cascade(t, model, mo, sc, na):
    """The points that land with the step's touches (``floors.dispatch.floor_cascade``: on
    the floor "pivot", the segments above the one that landed that lie flat or point below
    the horizontal), anchored where they are, after the na listed; returns the new count."""
    k = floor_cascade(model.floor, mo.e, mo.anchored, Z_TOL, sc.new_anchor[na:])  # (the other methods' tolerance)
    for r in range(k):
        j = sc.new_anchor[na + r]
        hold_at(mo, j, sc.pts)
        mo.anchored[j] = 2
        mo.anchor_t[j] = t
    return na + k


@njit(cache=True, _nrt=False)
def _switch_stage2(mo, ws, sc, slide):
    """The impact law of stage 2: a hinge whose impulse pulls is released; a candidate
    released that closes (dg/dt < -RATE_TOL), or with restitution separates slower than its
    rebound (sc.hrebound), is put back; the same for the floor's rows on
    a frictionless floor (``slide``: ``coulomb.released``, ``coulomb.closes``).  Returns
    whether the set changed."""
    e, ve, locked = mo.e, mo.ve, mo.locked
    changed = False
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            if ws.kind[j, r] == K_BEND and ws.x[j, r] < 0.0:
                locked[j - 1] = 0
                changed = True
                _flipped(sc, j, ws.kind[j, r], ws.x[j, r])
            elif is_floor(ws.kind[j, r]) and released(ws.x[j, r]):
                sc.floor_on[j] = 0
                changed = True
                _flipped(sc, j, ws.kind[j, r], ws.x[j, r])
    for j in range(sc.fcand.shape[0] if slide else 0):
        if sc.fcand[j] != 0 and sc.floor_on[j] == 0 and closes(point_vz(mo, j) - sc.rebound[j], RATE_TOL):
            sc.floor_on[j] = 1
            changed = True
            _flipped(sc, j, K_FLOOR, point_vz(mo, j))
    for k in range(locked.shape[0]):
        if sc.cand[k] != 0 and locked[k] == 0:
            rate = 0.0
            for q in range(3):
                rate += ve[k, q] * e[k + 1, q] + e[k, q] * ve[k + 1, q]
            if rate - sc.hrebound[k] < -RATE_TOL:  # (Newton's law: xi = rate + e rate-, sc.hrebound = -e rate-)
                locked[k] = 1
                changed = True
                _flipped(sc, k + 1, K_BEND, rate)
    return changed


@njit(cache=True, inline="always")
def _flipped(sc, j, kind, value):
    """sc.unmet <- a row at point j that the active set changed (the last one names where a
    stage 2 that does not settle failed: ``friction.hold_stuck_stretch``)."""
    sc.unmet[0], sc.unmet[1], sc.unmet[2] = j, kind, value


@njit(cache=True, _nrt=False)
def stage2(h, model, mo, ws, sc):
    """Stage 2 (module docstring): u+ in mo, P2 in ws.x, the rows' rates before (sc.val)
    and after (sc.rate: the rows the books take, ``booked_rates``).  The candidates (hinges in force active in stage 1 or at their
    limit within the position tolerance) start all locked.  Returns 0 or ERR_ACTIVE_SET (a
    singular solve leaves velocities that are not finite: ``rattle_step`` refuses the step)."""
    e, anchored, locked = mo.e, mo.anchored, mo.locked
    tol = position_tol(e.shape[0])
    half_kick(h, anchored, mo.vc, mo.ve, sc.ukc, sc.uke)
    if any_smooth_law(model):
        second_smooth_kick(h, model, mo, sc)
    grip = grips(model.friction)
    if grip:
        friction_kick(h, model.friction, mo, sc.ukc, sc.uke)
        friction_work(h, model.friction, mo, sc.start, sc.ledger)
        clear_impact_friction(sc)
    for k in range(locked.shape[0]):
        g = e[k, 0] * e[k + 1, 0] + e[k, 1] * e[k + 1, 1] + e[k, 2] * e[k + 1, 2] - model.cos_alpha
        cand = (locked[k] != 0 or g <= tol) and limit_in_force(anchored, k, model.cone, model.alpha)
        sc.cand[k] = 1 if cand else 0
        locked[k] = sc.cand[k]
    bounce = restitution(model)
    for k in range(locked.shape[0] if bounce else 0):  # (sc.hrebound: the approach rates, ``impact_rates``)
        v = -model.e_lock * sc.hrebound[k] if sc.cand[k] != 0 else 0.0
        sc.hrebound[k] = v if v > HOLD_RATE else 0.0
        if TOUCH_RATE < v <= HOLD_RATE:  # (a rebound too slow to resolve: the accumulation rule holds it)
            sc.fallback[k + 1] |= HELD
    slide = slides(model.friction) or grip  # (else sc.floor_on is all 0 after ``land``: no floor rows)
    for j in range(sc.fcand.shape[0] if slide else 0):  # the floor's candidates: active in stage 1, or at it
        on = anchored[j] == 0 and (sc.floor_on[j] != 0 or point_z(mo, j) <= tol)
        sc.fcand[j] = 1 if on else 0
        sc.floor_on[j] = sc.fcand[j]
    for fp in range(FIXED_POINT_MAX + 1 if grip else 1):  # (finite friction: until the landings' slips settle)
        settled = False
        for rnd in range(ROUNDS_MAX):
            keep = rnd > 0 or fp > 0
            _factor(mo.anchored, mo.locked, sc.floor_on, sc.kind_old, sc.nrow_old, sc.ledger, ws, e, False, True, keep)
            row_rates(ws.J, ws.kind, ws.nrow, sc.ukc, sc.uke, sc.val)
            for j in range(ws.nrow.shape[0]):
                for r in range(ws.nrow[j]):
                    ws.rhs[j, r] = -sc.val[j, r]
            if bounce:
                rebound_targets(anchored, ws, sc)
            solve_blocks(ws.nrow, ws.sym, ws.rhs, ws.x)
            add_impulses(h, mo, ws, sc, False)
            if not _switch_stage2(mo, ws, sc, slide):  # (a singular solve: U + T is not finite, ``rattle_step``)
                settled = True
                break
        if not settled:
            return ERR_ACTIVE_SET
        if grip and fp < FIXED_POINT_MAX and landing_slips(model.friction, mo, ws, sc):
            if fp == FIXED_POINT_MAX - 1:
                jam(mo, sc)  # (no sliding solution: held; solved once more as held)
            continue
        booked_rates(ws.J, ws.kind, ws.nrow, anchored, mo.vc, mo.ve, sc.rate)
        ws.valid[0] = 1
        for j in range(sc.fcand.shape[0] if slide else 0):  # (a floor that lets points slide: its contacts)
            mo.touching[j] = sc.floor_on[j]
        if bounce:
            leave_limits(mo, sc)
        return 0
    return ERR_ACTIVE_SET  # (not reached: the last round returns)


@njit(cache=True, _nrt=False)
def settle(model, mo):
    """Step 4: the new anchors made (2 -> 1), a lock whose limit is no longer in force
    dropped, a landed segment put on its anchors (c = (p_j + p_{j+1}) / 2,
    e = (p_j - p_{j+1}) / 2) and at rest."""
    anchored, locked, pos = mo.anchored, mo.locked, mo.anchor_pos
    for j in range(anchored.shape[0]):
        if anchored[j] == 2:
            anchored[j] = 1
    for k in range(locked.shape[0]):
        if locked[k] and not limit_in_force(anchored, k, model.cone, model.alpha):
            locked[k] = 0
    for i in range(mo.e.shape[0]):
        if is_landed(anchored, i):
            for q in range(3):
                mo.c[i, q] = 0.5 * (pos[i, q] + pos[i + 1, q])
                mo.e[i, q] = 0.5 * (pos[i, q] - pos[i + 1, q])
                mo.vc[i, q] = 0.0
                mo.ve[i, q] = 0.0
