"""The exact method on a frictionless floor (``contacts.coulomb.slides``, mu = 0), compiled:
a point that touches the floor slides on it, held by its height row alone, and leaves it
where the floor would pull.  What differs from the anchor, in one place:

* where the chain is (``core.base``): point N moves; the centre of mass moves uniformly
  along the floor, a held point fixes the height (``rules.floor_height``); the points'
  positions and velocities at an instant, the energies and the frames' base take it;
* what a touch creates (``touch_candidates``): a floor candidate (``core.unilateral``), no
  anchor; its first touch in anchor_t (the fall ends when every point has touched:
  ``rules.fall_over``);
* the impact (``unilateral.floor_impact``, called by ``events._apply_impact``): the hinges
  and every point the floor holds or that touches it in one LCP, the centres moving with
  point N's velocity (``ImpactWork.dv``);
* the lock set (``unilateral.floor_lock_set``): the hinges and the points the floor holds,
  which it keeps while it pushes; one it lets go is logged ``lift``;
* a lift-off between instants: a held point's vertical force crossing zero
  (``watch.EV_LIFT``, located as a lock's multiplier is), logged ``lift``;
* the accumulation limit at the floor (``hold_leaving``, the hinges' ``rules.must_hold``
  with ``hold_rate_floor``): a point the impact lifts off the floor and that would land
  again slower than that, or after a flight too small to resolve, is held (logged ``pin``);
* restitution at the floor (``release_bounces``): the impact's height rows take Newton's
  targets (``contacts.newton.floor_rebound``, in ``unilateral.floor_impact``); a point
  that leaves at its target is let go (logged ``bounce``), keeping its horizontal velocity.

With nothing held (the bottom end yanked up by a lock while nothing else lies on the
floor) the chain flies: its centre of mass falls freely from point N's position and
velocity at the instant it left (``start_flight``), until a point lands again.
"""

from __future__ import annotations

import numpy as np

from ...contacts.newton import floor_rebound, rebounds
from ...core.base import base_point, energies_moved, held_point, set_base
from ...core.books import log_row
from ...core.impacts import clear_rebounds
from ...core.kinematics import point_positions, velocities
from ...core.rules import LOG_LIFT, RATE_TOL, SLIDING, Z_TOL, must_hold
from ...floors.dispatch import floor_contacts
from ...jit import njit

# why the accumulation rule holds a point (``hold_leaving``; FloorWork.forced)
PINNED, AT_REST = 1, 2


@njit(cache=True, _nrt=False)
def base_of(t, chain, pts, pv, vel, pu):
    """pu <- point N's position and velocity (``core.base.base_point``), and pts, pv, vel
    the points' and centres' relative to it; within an instant that has just let go the
    last point the floor held (its flight not yet begun: ``Base.flying`` 0), the last ones
    known are kept in pu (``start_flight`` begins it from them)."""
    e, w = chain.Y[0], chain.Y[1]
    if held_point(chain.anchored) >= 0 or chain.base.flying[0] != 0:
        base_point(e, w, chain.anchored, chain.base, t, pts, pv, vel, pu)
    else:
        point_positions(e, pts)
        velocities(e, w, pv, vel)


@njit(cache=True, _nrt=False)
def start_flight(t, chain, pt, pu):
    """At the end of an instant: with no point held, the flight goes on from point N's
    position and velocity after it (pu; ``core.base.set_base``: the instant's impacts may
    have changed the centre of mass's velocity, a landing that the floor let go again);
    with one held, none is under way."""
    if held_point(chain.anchored) >= 0:
        chain.base.flying[0] = 0
    else:
        set_base(chain.Y[0], chain.Y[1], chain.anchored, chain.base, t, pt.pts, pt.pv, pt.vel, pu[0], pu[1])


@njit(cache=True, _nrt=False)
def after_impact(chain, vc, pu):
    """pu[1] <- point N's velocity after an impact, from the centres' velocities vc of its
    maximal coordinates (the lower end of segment N - 1: v - w x e)."""
    e, w = chain.Y[0], chain.Y[1]
    i = e.shape[0] - 1
    pu[1, 0] = vc[i, 0] - (w[i, 1] * e[i, 2] - w[i, 2] * e[i, 1])
    pu[1, 1] = vc[i, 1] - (w[i, 2] * e[i, 0] - w[i, 0] * e[i, 2])
    pu[1, 2] = vc[i, 2] - (w[i, 0] * e[i, 1] - w[i, 1] * e[i, 0])


@njit(cache=True, _nrt=False)
def absolute_points(t, chain, pt, pu):
    """pt.pts, pt.pv, pt.vel <- the points' positions and velocities and the centres'
    velocities where point N is (``base_of``: pu[0] its position, pu[1] its velocity)."""
    base_of(t, chain, pt.pts, pt.pv, pt.vel, pu)
    for j in range(pt.pts.shape[0]):
        for q in range(3):
            pt.pts[j, q] += pu[0, q]
            pt.pv[j, q] += pu[1, q]
    for i in range(pt.vel.shape[0]):
        for q in range(3):
            pt.vel[i, q] += pu[1, q]


@njit(cache=True, _nrt=False)
def touch_candidates(t, model, chain, ct, pt, any_landing, iw, fcand, lifted, pu):
    """The instant's floor candidates (fcand: ``SLIDING`` where the floor may hold a point):
    every point it holds, and the free points that touch it now (the floor model's rule on
    the absolute heights and velocities; not one that lifted off at this instant), listed
    in ct.new_anchor with their velocities before the impact (ct.pre_v), their first touch
    in anchor_t and, with restitution at the floor, their rebound (iw.rebound); then the
    free points at the floor (z <= Z_TOL) that move up: the impact may push them down (no
    touch, unless it does: ``events._log_instant``).  Returns the number listed."""
    anchored = chain.anchored
    absolute_points(t, chain, pt, pu)
    na = floor_contacts(model.floor, chain.Y[0], pt.pts, pt.pv, anchored, any_landing, Z_TOL, ct.touch)
    iw.n_rebound[0] = 0
    for j in range(anchored.shape[0]):
        fcand[j] = SLIDING if anchored[j] != 0 else 0
        iw.rebound[j] = 0.0
    m = 0
    for r in range(na):
        j = ct.touch[r]
        if lifted[j]:
            continue
        ct.new_anchor[m] = j
        for q in range(3):
            ct.pre_v[m, q] = pt.pv[j, q]
        m += 1
        fcand[j] = SLIDING
        if not chain.anchor_t[j] == chain.anchor_t[j]:  # (NaN: its first touch)
            chain.anchor_t[j] = t
        iw.rebound[j] = floor_rebound(pt.pv[j, 2], model.e_floor)
        iw.n_rebound[0] += 1 if iw.rebound[j] > 0.0 else 0
    for j in range(anchored.shape[0]):  # free points at the floor moving up: candidates too (an
        if anchored[j] == 0 and fcand[j] == 0 and not lifted[j] and pt.pts[j, 2] <= Z_TOL:  # impact may push them down)
            ct.new_anchor[m] = j
            for q in range(3):
                ct.pre_v[m, q] = pt.pv[j, q]
            m += 1
            fcand[j] = SLIDING
    return m


@njit(cache=True, _nrt=True)
def base_velocity(t, chain, pu, iw):
    """iw.dv <- point N's velocity (``core.base``) on every centre: the velocity the
    centres move with beside the rates' (``kinematics.velocities``: point N at rest), before
    an impact (each round's: an impact changes it)."""
    n = chain.Y.shape[1]
    base_of(t, chain, np.empty((n + 1, 3)), np.empty((n + 1, 3)), np.empty((n, 3)), pu)
    for i in range(n):
        for q in range(3):
            iw.dv[i, q] = pu[1, q]


@njit(cache=True, _nrt=False)
def held_candidates(anchored, lifted, fcand):
    """The lock set's floor candidates: the points the floor holds (not one that lifted off
    at this instant)."""
    for j in range(anchored.shape[0]):
        fcand[j] = SLIDING if (anchored[j] != 0 and not lifted[j]) else 0


@njit(cache=True, _nrt=False)
def hold_leaving(t, model, chain, pt, fl, seen):
    """The accumulation limit at a frictionless floor: a point the floor held or that
    touched it at this instant (``seen``), which the instant has let go (not at a
    lift-off event: fl.lifted) and which accelerates back down (z'' < 0, from the lock
    set's fl.fw.vz) and would land again slower than hold_rate_floor, or after a flight
    too small to resolve (``rules.must_hold``: vz < hold_rate_floor, or vz^2 < 2 hold_apex
    |z''|), is held (fl.fw.forced: the next round's impact holds it whatever its impulse;
    ``PINNED``, logged ``pin``, where it leaves faster than RATE_TOL, the law's outcome
    changed; ``AT_REST`` where it leaves no faster: at rest on the floor within round-off).
    The series of ever smaller landings it replaces would end in it held.  Returns the
    number newly held."""
    anchored = chain.anchored
    absolute_points(t, chain, pt, fl.pu)
    nheld = 0
    for j in range(anchored.shape[0]):
        if anchored[j] != 0 or seen[j] == 0 or fl.lifted[j] or fl.fw.forced[j]:
            continue
        if must_hold(pt.pv[j, 2], fl.fw.vz[j], model.hold_rate_floor, model.hold_apex):
            fl.fw.forced[j] = PINNED if pt.pv[j, 2] > RATE_TOL else AT_REST
            nheld += 1
    return nheld


@njit(cache=True, _nrt=False)
def release_bounces(model, chain, ct, iw, fw, na):
    """After a round's impact, with restitution at the floor: a point listed at this instant
    (ct.new_anchor[:na]) that landed fast enough to rebound (``floor_rebound`` of its
    velocity before the instant, ct.pre_v) and leaves the floor faster than RATE_TOL
    (``rebounds``, on its height rate after the impact, fw.vz) is let go, ct.bounce its
    upward velocity; one the floor holds does not bounce (ct.bounce 0).  Newton's targets
    are then zeroed (iw.rebound): the instant's later rounds take Moreau's law at the floor,
    so that a point the next round pushes back down is stopped there and the rounds end."""
    for r in range(na):
        j = ct.new_anchor[r]
        if floor_rebound(ct.pre_v[r, 2], model.e_floor) > 0.0 and rebounds(fw.vz[j], model.e_floor, RATE_TOL):
            chain.anchored[j] = 0
            ct.bounce[j] = fw.vz[j]
        elif chain.anchored[j] != 0:
            ct.bounce[j] = 0.0
    clear_rebounds(iw)


@njit(cache=True, _nrt=False)
def log_lifts(t, held_before, anchored, pts, log):
    """A ``lift`` row for each point the floor held before the lock set and no longer holds."""
    for j in range(anchored.shape[0]):
        if held_before[j] != 0 and anchored[j] == 0:
            log_row(log, t, LOG_LIFT, j, 0.0, 0.0, 0.0, 0.0, pts, j)


@njit(cache=True, _nrt=False)
def energies(t, chain, pts, pv, vel, pu, out):
    """out[0] = U, out[1] = T of the chain where point N is (``base_of``: pu), m g b."""
    base_of(t, chain, pts, pv, vel, pu)
    energies_moved(chain.Y[0], chain.Y[1], pts, vel, pu, out)


@njit(cache=True, _nrt=True)
def frame_state(e, w, t, chain, pts, pv, vel, en, p, u):
    """A frame's state (e, w) at t on the chain's floor: en[0] = U, en[1] = T (m g b), and
    point N's position p and velocity u (``core.base.base_point``, taken once)."""
    pu = np.empty((2, 3))
    base_point(e, w, chain.anchored, chain.base, t, pts, pv, vel, pu)
    energies_moved(e, w, pts, vel, pu, en)
    for q in range(3):
        p[q] = pu[0, q]
        u[q] = pu[1, q]


@njit(cache=True, _nrt=True)
def mechanical(t, chain, pts, pv, vel):
    """U + T where point N is (``energies``; between instants)."""
    out = np.empty(2)
    energies(t, chain, pts, pv, vel, np.empty((2, 3)), out)
    return out[0] + out[1]
