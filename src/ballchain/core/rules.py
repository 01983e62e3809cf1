"""The rules of the nonsmooth model, each stated once (docs/model.md, "Events").

Everything the event handler and the integrator decide about limits, the floor and
event functions comes from here; the kernels in ``dynamics`` and ``impacts`` act on
the masks these rules produce.  Nondimensional units (m = b = g = 1).

* which hinge limits are in force: ``limit_in_force``;
* what a floor model lets touch the floor, and the event function that watches it:
  ``floor_watched``, ``floor_value``, ``floor_contacts``;
* the thresholds that say when a constraint is *at* its limit, when an approach is an
  impact rather than a touch, and when a series of impacts is taken to its limit:
  ``GAP_TOL``, ``RATE_TOL``, ``Z_TOL``, ``ZERO_BAND`` and the options
  ``SolverOptions.hold_rate``, ``hold_apex`` (``must_hold``);
* how an event function is watched after an event: ``arm_state``.

The impact law (Moreau) is ``impacts.velocity_impact`` and the lock set (the
acceleration-level complementarity problem) ``impacts.lock_set``.
"""

from __future__ import annotations

import math

from .jit import njit

# floor models (ChainParams.floor)
FLOOR_ALL, FLOOR_PIVOT = 0, 1
FLOOR_CODES = {"all": FLOOR_ALL, "pivot": FLOOR_PIVOT}

GAP_TOL = 1e-9  # |g| below this: the hinge is at its limit
RATE_TOL = 1e-8  # |dg/dt| below this (sqrt(g/b)): a touch, not an impact
Z_TOL = 1e-9  # a free point below this height (b) touches the floor
# Accumulation (Zeno) limit: a hinge released at an instant (it was locked or took an
# impulse) that accelerates back to its limit (d2g/dt2 = a < 0) and would return slower
# than the option ``hold_rate`` (sqrt(g/b)), or after an excursion v^2 / 2|a| below
# the option ``hold_apex`` (too small to resolve: ten ZERO_BANDs by default), is held
# at its limit instead
# (``must_hold``).  The series of ever smaller impacts it replaces converges to that
# state; docs/model.md gives the convergence study.

# how an event function is watched (arm_state)
ARMED = 1  # positive: fires when it reaches zero
DEPARTING = 0  # at zero after an event, leaving it: fires only after it has been positive
OFF = -1  # not watched
# The band of round-off about an event function's zero: a function above ZERO_BAND
# (after an event or a step) is armed; a departing function that has not yet been above
# it (a constraint hovering at its limit, rate and acceleration about zero) fires when
# it sinks below -ZERO_BAND.
ZERO_BAND = 1e-12


@njit(cache=True)
def must_hold(rate, accel, hold_rate, hold_apex):
    """The accumulation rule for a hinge just released at its limit with rate dg/dt =
    ``rate`` >= 0 and free acceleration d2g/dt2 = ``accel``: hold it at its limit?"""
    return accel < 0.0 and (rate < hold_rate or rate * rate < -2.0 * hold_apex * accel)


@njit(cache=True)
def arm_state(f):
    """ARMED if the event function f is clearly positive, else DEPARTING (it sits at
    its zero after the event that put it there, and is known to be leaving it)."""
    return ARMED if f > ZERO_BAND else DEPARTING


@njit(cache=True, inline="always")
def _landed_or_landing(anchored, i):
    return anchored[i] != 0 and anchored[i + 1] != 0


@njit(cache=True)
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
    la = _landed_or_landing(anchored, k)
    lc = _landed_or_landing(anchored, k + 1)
    if not la and not lc:
        return not (anchored[k] != 0 and anchored[k + 2] != 0)
    return cone and (la != lc)


@njit(cache=True)
def bottom_airborne(anchored):
    """Index of the lowest segment that has not landed (-1 if all have)."""
    n = anchored.shape[0] - 1
    for i in range(n - 1, -1, -1):
        if not (anchored[i] != 0 and anchored[i + 1] != 0):
            return i
    return -1


@njit(cache=True)
def floor_watched(floor, anchored, j):
    """Is floor event function j watched?  ``all``: point j, for every free point;
    ``pivot``: the upper end j of the bottom airborne segment (it anchors when that
    segment lies flat)."""
    if anchored[j] != 0:
        return False
    if floor == FLOOR_ALL:
        return True
    return j == bottom_airborne(anchored)


@njit(cache=True)
def floor_value(floor, e, j):
    """Floor event function j of axes e (need not be unit length): ``all``: the height
    of point j, z_j = 2 sum_{i>=j} e_i,z (units b); ``pivot``: e_j,z / |e_j| of the
    segment whose upper end is point j."""
    if floor == FLOOR_ALL:
        z = 0.0
        for i in range(j, e.shape[0]):
            z += 2.0 * e[i, 2]
        return z
    return e[j, 2] / math.sqrt(e[j, 0] ** 2 + e[j, 1] ** 2 + e[j, 2] ** 2)


@njit(cache=True)
def floor_values(floor, e, anchored, out):
    """out[j] = floor_value(floor, e, j) for every watched j (others: inf), in O(N)."""
    n = e.shape[0]
    z = 0.0
    m = bottom_airborne(anchored) if floor == FLOOR_PIVOT else -1
    out[n] = math.inf
    for j in range(n - 1, -1, -1):
        z += 2.0 * e[j, 2]
        if anchored[j] != 0:
            out[j] = math.inf
        elif floor == FLOOR_ALL:
            out[j] = z
        else:
            out[j] = floor_value(floor, e, j) if j == m else math.inf
    return out


@njit(cache=True)
def floor_contacts(floor, e, pts, pv, anchored, landing_event, out):
    """Points that the floor anchors at this instant; returns their number (in out).
    ``all``: every free point at z <= Z_TOL that is not moving up (dz/dt <= RATE_TOL).
    ``pivot`` (after a landing event): the upper end of the bottom airborne segment
    once it lies flat (e_z <= Z_TOL), cascading up while the next one does too."""
    n = e.shape[0]
    na = 0
    if floor == FLOOR_ALL:
        for j in range(n):
            if anchored[j] == 0 and pts[j, 2] <= Z_TOL and pv[j, 2] <= RATE_TOL:
                out[na] = j
                na += 1
    elif landing_event:
        m = bottom_airborne(anchored)
        while m >= 0 and floor_value(floor, e, m) <= Z_TOL:
            out[na] = m
            na += 1
            m -= 1
    return na
