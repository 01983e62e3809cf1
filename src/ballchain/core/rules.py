"""The rules of the nonsmooth model, each stated once (docs/model.md, "Events").

Everything the methods decide about limits and event functions comes from here (what
the floor watches and what a touch creates: the floor models, ``ballchain.floors``);
the kernels in ``dynamics`` and ``impacts`` act on the masks these rules produce.  Nondimensional units (m = b = g = 1).

* which hinge limits are in force: ``limit_in_force``;
* the lock function of a hinge (``bend_gap``, ``hinge_gap``), the height of a point
  (``point_height``), which segments have landed (``is_landed``, ``landed_or_landing``);
* when the fall ends (``fall_ended``) and when the run does (``fall_over``);
* the event kinds of the log (``EVENT_KINDS``, ``EVENT_CODES``, ``EVENT_MEANINGS``);
* the thresholds that say when a constraint is *at* its limit, when an approach is an
  impact rather than a touch, and when a series of impacts is taken to its limit:
  ``GAP_TOL``, ``RATE_TOL``, ``Z_TOL``, ``ZERO_BAND`` and the options
  ``SolverOptions.hold_rate``, ``hold_apex`` (``must_hold``; at the floor
  ``hold_rate_floor``, hold_rate's unless set);
* how an event function is watched after an event: ``arm_state``;
* what a touch creates once its impact is solved: ``settle_anchors``.

The impact law (Moreau) is ``impacts.velocity_impact`` and the lock set (the
acceleration-level complementarity problem) ``impacts.lock_set``.
"""

from __future__ import annotations

import math

from ..jit import njit
from .kinds import (  # noqa: F401  (the event kinds are rules too; stated in a plain module)
    EVENT_CODES,
    EVENT_KINDS,
    EVENT_MEANINGS,
    LOG_ANCHOR,
    LOG_BOUNCE,
    LOG_HOLD,
    LOG_IMPULSE,
    LOG_JAM,
    LOG_LANDING,
    LOG_LIFT,
    LOG_LOCK,
    LOG_PIN,
    LOG_RELEASE,
    LOG_SLIP,
    LOG_STICK,
    LOG_TOP,
    LOG_UNLOCK,
)

GAP_TOL = 1e-9  # |g| below this: the hinge is at its limit
RATE_TOL = 1e-8  # |dg/dt| below this (sqrt(g/b)): a touch, not an impact
Z_TOL = 1e-9  # a free point below this height (b) touches the floor
# the marks of Chain.anchored: 0 free, 1 held by the floor (anchored), 2 being anchored in the
# current impact, SLIDING on a frictionless floor: held at the floor's height only, free along
# it (rows.ROW_SLIDE_*; no segment between sliding points has landed)
SLIDING = 3
COINCIDE_TOL = 1e-8  # a point touching the floor this close (b) to an anchored point is held there
COINCIDE_DEPTHS = 10.0  # ... plus this many times its depth at the touch (its error along the floor)
# Accumulation (Zeno) limit: a hinge released at an instant (it was locked or took an
# impulse) that accelerates back to its limit (d2g/dt2 = a < 0) and would return slower
# than the option ``hold_rate`` (sqrt(g/b)), or after an excursion v^2 / 2|a| below
# the option ``hold_apex`` (too small to resolve: ten ZERO_BANDs by default), is held
# at its limit instead
# (``must_hold``).  The series of ever smaller impacts it replaces converges to that
# state; docs/model.md gives the convergence study.  A point bouncing off the floor is
# held (anchored) by the same rule with the option ``hold_rate_floor`` (``hold_rate``'s
# value unless it is set) and its height's acceleration.

# how an event function is watched (arm_state)
ARMED = 1  # positive: fires when it reaches zero
DEPARTING = 0  # at zero after an event, leaving it: fires only after it has been positive
OFF = -1  # not watched
# The band of round-off about an event function's zero: a function above ZERO_BAND
# (after an event or a step) is armed; a departing function that has not yet been above
# it (a constraint hovering at its limit, rate and acceleration about zero) fires when
# it sinks below -ZERO_BAND.
ZERO_BAND = 1e-12


@njit(cache=True, _nrt=False)
def must_hold(rate, accel, hold_rate, hold_apex):
    """The accumulation rule for a hinge just released at its limit with rate dg/dt =
    ``rate`` >= 0 and free acceleration d2g/dt2 = ``accel``: hold it at its limit?"""
    return accel < 0.0 and (rate < hold_rate or rate * rate < -2.0 * hold_apex * accel)


@njit(cache=True, _nrt=False)
def arm_state(f):
    """ARMED if the event function f is clearly positive, else DEPARTING (it sits at
    its zero after the event that put it there, and is known to be leaving it)."""
    return ARMED if f > ZERO_BAND else DEPARTING


@njit(cache=True, inline="always")
def is_held(anchored, j):
    """Point j is held where it is by the floor (anchored, or being anchored in the current
    impact): not free, not sliding.  Branch-free, as ``is_landed``."""
    return (anchored[j] != 0) & (anchored[j] != SLIDING)


@njit(cache=True, inline="always")
def is_landed(anchored, i):
    """Segment i has landed: both its ends are anchored (an anchor marked 2 is being made
    in the current impact: the segments next to it still move until the impulse has
    stopped them).  Branch-free (&, not ``and``): a short-circuit here leaves numba a
    reference count of ``anchored`` to take and drop at every call in a loop."""
    return (anchored[i] == 1) & (anchored[i + 1] == 1)


@njit(cache=True, _nrt=False)
def landed_count(anchored):
    """How many segments have landed (``is_landed``): the floor holds up their weight."""
    m = 0
    for i in range(anchored.shape[0] - 1):
        if is_landed(anchored, i):
            m += 1
    return m


@njit(cache=True, inline="always")
def landed_or_landing(anchored, i):
    """Segment i has landed or lands in the current impact (both ends anchored or
    being anchored).  Branch-free, as ``is_landed``."""
    return is_held(anchored, i) & is_held(anchored, i + 1)


@njit(cache=True, inline="always")
def bend_gap(ax, ay, az, cx, cy, cz, cos_alpha):
    """The lock function g = e_a . e_c / (|e_a| |e_c|) - cos(alpha) of two segment axes
    (need not be unit length): g > 0 inside the limit, g = 0 at it."""
    d = ax * cx + ay * cy + az * cz
    return d / math.sqrt((ax * ax + ay * ay + az * az) * (cx * cx + cy * cy + cz * cz)) - cos_alpha


@njit(cache=True, inline="always")
def hinge_gap(e, k, cos_alpha):
    """g_k = bend_gap(e_k, e_{k+1}) of hinge k."""
    return bend_gap(e[k, 0], e[k, 1], e[k, 2], e[k + 1, 0], e[k + 1, 1], e[k + 1, 2], cos_alpha)


@njit(cache=True, inline="always")
def unit_hinge_gap(e, k, cos_alpha):
    """``hinge_gap`` of axes known to be unit length (|e_k| = |e_{k+1}| = 1: the state at
    an event instant, normalised by the projection): g_k = e_k . e_{k+1} - cos(alpha)."""
    return e[k, 0] * e[k + 1, 0] + e[k, 1] * e[k + 1, 1] + e[k, 2] * e[k + 1, 2] - cos_alpha


@njit(cache=True, _nrt=False)
def point_height(e, j):
    """z_j = 2 sum_{i>=j} e_i,z: the height of point j (units b; point N at the origin)."""
    z = 0.0
    for i in range(j, e.shape[0]):
        z += 2.0 * e[i, 2]
    return z


@njit(cache=True, _nrt=False)
def all_anchored(anchored):
    """Every point anchored: the fall is over (t_landed)."""
    for j in range(anchored.shape[0]):
        if anchored[j] == 0 or anchored[j] == SLIDING:
            return False
    return True


@njit(cache=True, _nrt=False)
def fall_over(anchored, anchor_t, touching, friction, e_floor):
    """The run is over: every point anchored (the anchor, friction inf: ``all_anchored``),
    or, on a floor that lets points slide (friction 0: nothing is anchored, the pile slides
    on; finite friction: a point may slip again), every point has touched the floor (its
    first touch in ``anchor_t``); on a frictionless floor with restitution (``e_floor`` > 0:
    a point that touched may bounce off again), every point on the floor at once (each
    ``touching`` it)."""
    if friction == math.inf:
        return all_anchored(anchored)
    for j in range(anchor_t.shape[0]):
        if not anchor_t[j] == anchor_t[j]:
            return False
        if e_floor > 0.0 and touching[j] == 0:
            return False
    return True


@njit(cache=True, _nrt=False)
def fall_ended(books, t, top_reached, top_anchored):
    """The t_fall rule: the fall ends when the top end first reaches the floor, either as
    an event of its own (``top_reached``, floor models with a top event) or when it is
    anchored (``top_anchored``); the first of these sets t_fall.  Returns whether t_fall
    was set now."""
    if math.isnan(books.t_fall[0]) and (top_reached or top_anchored):
        books.t_fall[0] = t
        return True
    return False


@njit(cache=True, _nrt=False)
def limit_in_force(anchored, k, cone, alpha):
    """Is the bend limit of hinge k (between segments k and k+1) in force?  Never when
    alpha = pi; between two segments that have not landed, yes, unless they span two
    anchors (points k and k+2 anchored, point k+1 free: their angle is then fixed by the
    distance of the anchors, |p_k - p_{k+2}| = 2 sqrt(2 + 2 e_k . e_{k+1}), so the
    limit can neither be reached nor bear a load, and its row would only repeat the
    anchors'); between a landed (or landing in the current impact) and an airborne
    segment only with ``cone`` (the ``anchor_cone`` option); between two landed
    segments, never."""
    if alpha >= math.pi:
        return False
    la = landed_or_landing(anchored, k)
    lc = landed_or_landing(anchored, k + 1)
    if not la and not lc:
        return not (is_held(anchored, k) and is_held(anchored, k + 2))
    return cone and (la != lc)


@njit(cache=True, _nrt=False)
def bottom_airborne(anchored):
    """Index of the lowest segment that has not landed (-1 if all have)."""
    n = anchored.shape[0] - 1
    for i in range(n - 1, -1, -1):
        if not landed_or_landing(anchored, i):
            return i
    return -1


@njit(cache=True, _nrt=False)
def hold_at(chain, j, pts):
    """Where the floor holds point j that touches it at pts[j] (points' positions):

    * exactly at an anchored point that is on the same spot of the floor, if j has no
      anchored neighbour: within COINCIDE_TOL of it along the floor, plus COINCIDE_DEPTHS
      times the depth at which j touched (a touch found d below the floor, on a path at
      an angle theta to it, is d / tan(theta) off along the floor: the time-stepper's
      touches end a step up to a few 1e-6 b deep, the event-driven ones 1e-9).  A fold
      of the chain whose two ends meet, as a planar two-segment fold that lands on its
      own pivot; two anchors a round-off apart would be a different, ill-posed
      constraint, the fold then swinging only about the line through them, a direction
      set by round-off;
    * else, beside an anchored neighbour, at that neighbour's anchor plus the segment
      between them (pts[j] - pts[j +- 1]), so that a landed segment's anchors are its
      length apart (the located state drifts from the old anchors by up to ~1e-10 b; an
      anchor at the drifted position left a residual no projection could remove);
    * else where it touched."""
    anchored, anchor_pos = chain.anchored, chain.anchor_pos
    n1 = anchored.shape[0]
    beside = (j + 1 < n1 and is_held(anchored, j + 1)) or (j >= 1 and is_held(anchored, j - 1))  # (2: in this instant)
    if not beside:
        tol = COINCIDE_TOL + COINCIDE_DEPTHS * max(0.0, -pts[j, 2])
        for i in range(n1):
            if i != j and anchored[i] == 1:
                d2 = (anchor_pos[i, 0] - pts[j, 0]) ** 2 + (anchor_pos[i, 1] - pts[j, 1]) ** 2
                if d2 <= tol * tol and abs(anchor_pos[i, 2] - pts[j, 2]) <= tol:
                    for q in range(3):
                        anchor_pos[j, q] = anchor_pos[i, q]
                    return
    for i in (j + 1, j - 1):
        if 0 <= i < n1 and anchored[i] == 1:
            for q in range(3):
                anchor_pos[j, q] = anchor_pos[i, q] + (pts[j, q] - pts[i, q])
            return
    for q in range(3):
        anchor_pos[j, q] = pts[j, q]


@njit(cache=True, _nrt=False)
def settle_anchors(chain, cone, alpha):
    """What a touch creates, once its impact is solved: the new anchors are made (2 -> 1),
    a lock whose limit is no longer in force (``limit_in_force``) is dropped, a landed
    segment is at rest (w = 0)."""
    anchored, locked, w = chain.anchored, chain.locked, chain.Y[1]
    for j in range(anchored.shape[0]):
        if anchored[j] == 2:
            anchored[j] = 1
    for k in range(locked.shape[0]):
        if locked[k] and not limit_in_force(anchored, k, cone, alpha):
            locked[k] = 0
    for i in range(w.shape[0]):
        if is_landed(anchored, i):
            w[i, 0] = 0.0
            w[i, 1] = 0.0
            w[i, 2] = 0.0
