"""How each event function is watched (docs/model.md, "Events"), compiled.

Five kinds of event function: ``EV_LOCK`` (g_k of an unlocked hinge whose limit is in
force), ``EV_UNLOCK`` (the multiplier lambda_k of a locked hinge), ``EV_LANDING`` (the
floor model's function of each watched point), ``EV_TOP`` (the top end's height, for
floor models with a top event), ``EV_LIFT`` (the floor's vertical force on a point that
slides on a frictionless floor, ``slides``).  Each has an arm state (``rules.arm_state``: ARMED,
DEPARTING or OFF), a reference level (where a departing function started:
min(f, 0) after the event) and, for hinges and points, the predicted apex time of a
departing constraint that accelerates back (``apex_times``).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ...core.rules import (
    ARMED,
    DEPARTING,
    OFF,
    SLIDING,
    ZERO_BAND,
    arm_state,
    hinge_gap,
    limit_in_force,
    point_height,
)
from ...floors.dispatch import floor_values, floor_watched, top_event
from ...jit import entry, njit

EV_LOCK, EV_UNLOCK, EV_LANDING, EV_TOP, EV_LIFT = 1, 2, 3, 4, 5
EVENT_FUNCTIONS = (EV_LOCK, EV_UNLOCK, EV_LANDING, EV_TOP, EV_LIFT)

Watch = namedtuple(
    "Watch",
    [
        "arm_lock",  # (N-1,) int8 per hinge: its lock function
        "arm_unlock",  # (N-1,) int8 per hinge: its multiplier
        "arm_land",  # (N+1,) int8 per point: the floor's function
        "arm_top",  # (1,) int8: the top end's height
        "ref_lock",
        "ref_unlock",
        "ref_land",
        "ref_top",
        "apex_lock",  # (N-1,): predicted apex time of a departing hinge (inf: none)
        "apex_land",  # (N+1,): predicted apex time of a departing point (inf: none)
        "arm_lift",  # (N+1,) int8 per point: the floor's force on a sliding point
        "ref_lift",
    ],
)


def new_watch(n: int) -> Watch:
    """Nothing watched yet (``arm_functions`` sets it up)."""
    nh = max(n - 1, 0)
    return Watch(
        np.zeros(nh, np.int8),
        np.zeros(nh, np.int8),
        np.zeros(n + 1, np.int8),
        np.zeros(1, np.int8),
        np.zeros(nh),
        np.zeros(nh),
        np.zeros(n + 1),
        np.zeros(1),
        np.full(nh, np.inf),
        np.full(n + 1, np.inf),
        np.zeros(n + 1, np.int8),
        np.zeros(n + 1),
    )


@entry
@njit(cache=True, _nrt=False)
def arm_functions(model, chain, watch, gaps, lam, pz, zf, t_fall_known, fv):
    """Arm state of every event function after an instant (or at the start): a function
    is watched only where its rule applies, ARMED where positive, DEPARTING at its zero;
    its reference level (where a departing function starts) is min(f, 0).  ``gaps``:
    g_k of every hinge; ``lam``: the lock multipliers; ``pz``: the floor's vertical force
    on each point (a sliding point's lift-off function); ``zf``: the floor's height in the
    chain's frame (``core.base.floor_z``); ``fv``: scratch (N+1)."""
    e, anchored, locked = chain.Y[0], chain.anchored, chain.locked
    for k in range(locked.shape[0]):
        watch.arm_lock[k] = OFF
        watch.arm_unlock[k] = OFF
        if not limit_in_force(anchored, k, model.cone, model.alpha):
            continue
        if locked[k] != 0:
            watch.arm_unlock[k] = arm_state(lam[k])
            watch.ref_unlock[k] = min(lam[k], 0.0)
        else:
            watch.arm_lock[k] = arm_state(gaps[k])
            watch.ref_lock[k] = min(gaps[k], 0.0)
    floor_values(model.floor, e, anchored, zf, fv)
    for j in range(watch.arm_land.shape[0]):
        watch.arm_land[j] = arm_state(fv[j]) if floor_watched(model.floor, anchored, j) else OFF
        watch.ref_land[j] = min(fv[j], 0.0)
        watch.arm_lift[j] = arm_state(pz[j]) if anchored[j] == SLIDING else OFF
        watch.ref_lift[j] = min(pz[j], 0.0)
    watch.arm_top[0] = OFF
    if top_event(model.floor) and not t_fall_known:
        z = point_height(e, 0)
        watch.arm_top[0] = arm_state(z)
        watch.ref_top[0] = min(z, 0.0)


@njit(cache=True, _nrt=False)
def apex_times(t, e, w, de, dw, watch, rates, ddg, pv, vz0, az0):
    """Predicted apex time of every departing constraint that accelerates back, and of
    every armed hinge or point that approaches its limit while turning back: a hinge
    (or a free point, floor ``all``) that leaves its zero at rate v > 0 while its
    acceleration a < 0 pulls it back peaks at t + v/|a| and returns at t + 2v/|a|.  The
    integrator samples a departing function there, so that a return within one step is
    located as a crossing (it fires only after the function has been seen positive).
    Only excursions that rise above rules.ZERO_BAND (v^2 / 2|a|) can be resolved; the
    others get inf (the accumulation rule has held those that would come back).  A point's
    vertical rate and acceleration are measured from the floor's (vz0, az0: 0 but where a
    frictionless floor has let point N leave it, ``core.base.floor_z_rates``)."""
    arm_lock, arm_land, apex_lock, apex_land = watch.arm_lock, watch.arm_land, watch.apex_lock, watch.apex_land
    for k in range(arm_lock.shape[0]):
        apex_lock[k] = math.inf
        if arm_lock[k] == DEPARTING and ddg[k] < 0.0 and rates[k] ** 2 > -2.0 * ZERO_BAND * ddg[k]:
            apex_lock[k] = t + rates[k] / -ddg[k]
        elif arm_lock[k] == ARMED and rates[k] < 0.0 and ddg[k] > 0.0:
            # an armed hinge heading for its limit and turning back (one an impact has just
            # re-armed): where it comes closest, sampled by the integrator, so that a dip
            # through the limit shorter than a step is seen and located
            apex_lock[k] = t - rates[k] / ddg[k]
    n = e.shape[0]
    apex_land[n] = math.inf
    az = 0.0  # d2z/dt2 of point j = 2 sum_{i>=j} (dw_i x e_i + w_i x de_i)_z
    for j in range(n - 1, -1, -1):
        az += 2.0 * (dw[j, 0] * e[j, 1] - dw[j, 1] * e[j, 0] + w[j, 0] * de[j, 1] - w[j, 1] * de[j, 0])
        apex_land[j] = math.inf
        a, v = az - az0, pv[j, 2] - vz0
        if arm_land[j] == DEPARTING and a < 0.0 and v > 0.0 and v**2 > -2.0 * ZERO_BAND * a:
            apex_land[j] = t + v / -a
        elif arm_land[j] == ARMED and v < 0.0 and a > 0.0:
            # an armed point heading for the floor and turning back (one that has just
            # bounced off it): where it comes closest, sampled as for the hinges
            apex_land[j] = t - v / a


@njit(cache=True, _nrt=False)
def arm_departed(model, chain, watch, lam1, pz1, zf, fv):
    """After an accepted step: departing functions that have left their zero (above
    ZERO_BAND) are armed.  ``lam1``, ``pz1``: the lock multipliers and the floor's vertical
    forces at the step's end, ``zf`` the floor's height in the chain's frame there."""
    e, locked = chain.Y[0], chain.locked
    for k in range(locked.shape[0]):
        if watch.arm_lock[k] == DEPARTING and not locked[k] and hinge_gap(e, k, model.cos_alpha) > ZERO_BAND:
            watch.arm_lock[k] = ARMED
        if watch.arm_unlock[k] == DEPARTING and locked[k] and lam1[k] > ZERO_BAND:
            watch.arm_unlock[k] = ARMED
    floor_values(model.floor, e, chain.anchored, zf, fv)
    for j in range(fv.shape[0]):
        if watch.arm_land[j] == DEPARTING and fv[j] > ZERO_BAND:
            watch.arm_land[j] = ARMED
    if watch.arm_top[0] == DEPARTING and point_height(e, 0) > ZERO_BAND:
        watch.arm_top[0] = ARMED
    for j in range(pz1.shape[0]):
        if watch.arm_lift[j] == DEPARTING and pz1[j] > ZERO_BAND:
            watch.arm_lift[j] = ARMED
