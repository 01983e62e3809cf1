"""What happens at an event instant (MODEL.md section 3), compiled: ``handle_event``,
and the loop ``run_events`` that alternates the integrator and the event handler
without returning to Python.

``handle_event`` applies, in this order (engine.py's module docstring states the
rules; ``engine.Run.handle_event`` is the plain-Python version it is tested against):

1. unlock the hinges whose multiplier crossed zero (they cannot re-lock in this instant);
2. anchor the points that reached the floor moving down (floor ``all``), or the bottom
   airborne segment that lies flat, cascading (floor ``pivot``);
3. one Moreau impact over every new anchor and every hinge at its limit;
4. the acceleration-level LCP: which hinges at the limit stay locked;
5. new locks hold the angle reached; the state is projected onto the constraints and
   the event functions sitting at zero are disarmed.

The event log is kept in preallocated arrays (``log_*``, ``log_n[0]`` rows); the run's
scalars in ``acc``: [lost_locking, lost_landing, floor impulse x, y, z, t_fall, t_landed].
"""

from __future__ import annotations

import math

from numba import njit

from .dynamics import (
    kinetic_energy,
    lock_active,
    point_positions,
    project_state,
    velocities,
)
from .impacts import GAP_TOL, RATE_TOL, hinge_gaps, hinge_rates, lock_set, velocity_impact
from .integrator import ADV_EVENT, ARM, EV_LANDING, EV_TOP, EV_UNLOCK, PEN, PROJ_TOL, advance

Z_TOL = 1e-9  # a free point with z below this (units b) at an event touches the floor
LOG_LOCK, LOG_UNLOCK, LOG_LANDING, LOG_IMPULSE = 1, 2, 3, 5
ACC_LOST_LOCKING, ACC_LOST_LANDING, ACC_FLOOR_IMPULSE, ACC_T_FALL, ACC_T_LANDED = 0, 1, 2, 5, 6

# handle_event / run_events status codes (negative: the run cannot go on)
EV_OK = 0
EV_LANDED = 10  # every point anchored
EV_RETURN = 11  # returned to Python for progress, log space or the trace buffer
ERR_IMPACT_LCP, ERR_ENERGY, ERR_LOCK_LCP, ERR_ZENO, ERR_MAX_EVENTS = -1, -2, -3, -4, -5


@njit(cache=True, inline="always")
def _log(log_t, log_kind, log_index, log_imp, log_energy, log_n, t, kind, index, i0, i1, i2, energy):
    k = log_n[0]
    log_t[k] = t
    log_kind[k] = kind
    log_index[k] = index
    log_imp[k, 0] = i0
    log_imp[k, 1] = i1
    log_imp[k, 2] = i2
    log_energy[k] = energy
    log_n[0] = k + 1


@njit(cache=True)
def bottom_airborne(anchored):
    """Index of the lowest segment that has not landed (-1 if all have)."""
    n = anchored.shape[0] - 1
    for i in range(n - 1, -1, -1):
        if not (anchored[i] != 0 and anchored[i + 1] != 0):
            return i
    return -1


@njit(cache=True)
def _in_force(anchored, cone, alpha, out):
    """out[k] = 1 if the limit of hinge k is in force (never when alpha = pi)."""
    for k in range(out.shape[0]):
        out[k] = 1 if (alpha < math.pi and lock_active(anchored, k, cone)) else 0


@njit(cache=True)
def _thr(f):
    """Threshold of an event function at value f after an event: armed or disarmed."""
    return 0.0 if f > ARM else min(f, 0.0) - PEN


@njit(cache=True)
def handle_event(t, ev_kind, ev_idx, ev_time, nev, xtol, alpha, floor_all, cone,
                 e, w, anchored, locked, lock_cos, anchor_pos, anchor_t,
                 thr_lock, thr_unlock, thr_land, thr_top, ws, sc, pts, pv, vel,
                 log_t, log_kind, log_index, log_imp, log_energy, log_n, acc):
    """Apply everything that happens at the instant t (module docstring, steps 1-5).
    ``ws``: the Workspace arrays; ``sc``: scratch (see ``engine.Run``).  Returns EV_OK
    or a negative error code."""
    J, kind, nrow, S, G, drop, rhs, x, gf = ws
    (gaps, rates, rates_after, impulse, anchor_impulse, split, jv, w_plus, de, dw, ddg, lam,
     exclude, cand, active, was_locked, new_lock, in_force, new_anchor, pre_v) = sc
    n = e.shape[0]
    nh = n - 1
    cos_alpha = math.cos(alpha)
    # 1. unlocks (and the top end crossing the floor in the pivot model)
    for k in range(nh):
        exclude[k] = 0
    any_top = False
    any_landing = False
    for i in range(nev):
        if ev_time[i] > t + 10.0 * xtol:
            continue
        if ev_kind[i] == EV_UNLOCK:
            k = ev_idx[i]
            if locked[k]:
                locked[k] = 0
                exclude[k] = 1
                _log(log_t, log_kind, log_index, log_imp, log_energy, log_n, t, LOG_UNLOCK, k, 0.0, 0.0, 0.0, 0.0)
        elif ev_kind[i] == EV_TOP:
            any_top = True
        elif ev_kind[i] == EV_LANDING:
            any_landing = True
    if any_top and math.isnan(acc[ACC_T_FALL]):
        acc[ACC_T_FALL] = t
        thr_top[0] = -math.inf  # recorded once
    # 2. floor contacts
    point_positions(e, pts)
    velocities(e, w, pv, vel)
    na = 0
    if floor_all:
        for j in range(n):
            if anchored[j] == 0 and pts[j, 2] <= Z_TOL and pv[j, 2] <= RATE_TOL:
                new_anchor[na] = j
                na += 1
    else:
        m = bottom_airborne(anchored)
        if any_landing:
            while m >= 0 and e[m, 2] / math.sqrt(e[m, 0] ** 2 + e[m, 1] ** 2 + e[m, 2] ** 2) <= Z_TOL:  # cascade
                new_anchor[na] = m  # point m = upper end of segment m
                na += 1
                m -= 1
    for r in range(na):
        j = new_anchor[r]
        for q in range(3):
            pre_v[r, q] = pv[j, q]
            anchor_pos[j, q] = pts[j, q]  # held where it touched (|z| < Z_TOL)
        anchored[j] = 2  # anchored; its neighbours still move during the impact
        anchor_t[j] = t
    # 3. one impact over the new anchors and every hinge at its limit
    hinge_gaps(e, cos_alpha, gaps)
    hinge_rates(e, w, rates)
    _in_force(anchored, cone, alpha, in_force)
    any_approaching = False
    for k in range(nh):
        if not in_force[k]:
            locked[k] = 0
        cand[k] = 1 if (in_force[k] and (gaps[k] <= GAP_TOL or locked[k] != 0) and exclude[k] == 0) else 0
        approaching = cand[k] != 0 and rates[k] < -RATE_TOL
        any_approaching = any_approaching or approaching
        was_locked[k] = locked[k]
        new_lock[k] = 0
        active[k] = 1 if (locked[k] != 0 or approaching) else 0
    if na > 0 or any_approaching:
        T0 = kinetic_energy(e, w, pv, vel)
        it = velocity_impact(e, w, anchored, cand, cone, active, J, kind, nrow, S, G, drop, rhs, x, gf,
                             pv, vel, jv, w_plus, rates_after, impulse, anchor_impulse, split)
        if it < 0:
            return ERR_IMPACT_LCP
        T1 = kinetic_energy(e, w, pv, vel)
        if T1 > T0 * (1 + 1e-9) + 1e-12:
            return ERR_ENERGY
        acc[ACC_LOST_LOCKING] += split[0]
        acc[ACC_LOST_LANDING] += split[1]
        hinge_rates(e, w, rates_after)
        for k in range(nh):
            if impulse[k] > 0:
                lost = -0.5 * impulse[k] * (rates[k] + rates_after[k])
                _log(log_t, log_kind, log_index, log_imp, log_energy, log_n, t,
                     LOG_IMPULSE if was_locked[k] else LOG_LOCK, k, impulse[k], 0.0, 0.0, lost)
                new_lock[k] = 0 if was_locked[k] else 1
        for r in range(na):
            j = new_anchor[r]
            i0, i1, i2 = anchor_impulse[j, 0], anchor_impulse[j, 1], anchor_impulse[j, 2]
            acc[ACC_FLOOR_IMPULSE] += i0
            acc[ACC_FLOOR_IMPULSE + 1] += i1
            acc[ACC_FLOOR_IMPULSE + 2] += i2
            lost = -0.5 * (i0 * pre_v[r, 0] + i1 * pre_v[r, 1] + i2 * pre_v[r, 2])
            _log(log_t, log_kind, log_index, log_imp, log_energy, log_n, t, LOG_LANDING, j, i0, i1, i2, lost)
        for k in range(nh):
            locked[k] = active[k]  # hinges kept at the limit by the impact
            rates[k] = rates_after[k]
    for j in range(n + 1):
        if anchored[j] == 2:
            anchored[j] = 1
    _in_force(anchored, cone, alpha, in_force)
    for k in range(nh):
        if not in_force[k]:
            locked[k] = 0
    for i in range(n):
        if anchored[i] != 0 and anchored[i + 1] != 0:
            w[i, 0] = 0.0
            w[i, 1] = 0.0
            w[i, 2] = 0.0
    # 4. which hinges at the limit stay locked (acceleration-level LCP)
    for k in range(nh):
        c2 = ((in_force[k] and gaps[k] <= GAP_TOL and abs(rates[k]) <= RATE_TOL) or locked[k] != 0) and exclude[k] == 0
        cand[k] = 1 if c2 else 0
        active[k] = 1 if (locked[k] != 0 and c2) else 0
    it = lock_set(e, w, anchored, cand, cone, active, J, kind, nrow, S, G, drop, rhs, x, gf, de, dw, ddg, lam)
    if it < 0:
        return ERR_LOCK_LCP
    for k in range(nh):
        locked[k] = active[k]
    for k in range(nh):
        if was_locked[k] == 0 and locked[k] != 0 and not new_lock[k]:
            _log(log_t, log_kind, log_index, log_imp, log_energy, log_n, t, LOG_LOCK, k, 0.0, 0.0, 0.0, 0.0)
    for k in range(nh):
        if locked[k] == 0 and (was_locked[k] != 0 or new_lock[k]):
            # released (possibly right after its impact: stopped, then separating)
            _log(log_t, log_kind, log_index, log_imp, log_energy, log_n, t, LOG_UNLOCK, k, 0.0, 0.0, 0.0, 0.0)
    # 5. hold new locks at the angle reached, project, disarm what sits at zero
    for k in range(nh):
        if was_locked[k] == 0 and locked[k] != 0:
            lock_cos[k] = cos_alpha + gaps[k]
    project_state(e, w, anchored, locked, cone, lock_cos, anchor_pos, J, kind, nrow, S, G, drop, rhs, x, gf,
                  pts, vel, PROJ_TOL, 5)
    hinge_gaps(e, cos_alpha, gaps)
    for k in range(nh):
        if locked[k] != 0:
            thr_unlock[k] = _thr(lam[k])
        else:
            thr_lock[k] = _thr(gaps[k])
    point_positions(e, pts)
    if floor_all:
        for j in range(n + 1):
            if anchored[j] == 0:
                thr_land[j] = _thr(pts[j, 2])
        if anchored[0] and math.isnan(acc[ACC_T_FALL]):
            acc[ACC_T_FALL] = t
    else:
        m = bottom_airborne(anchored)
        if m >= 0:
            thr_land[m] = _thr(e[m, 2] / math.sqrt(e[m, 0] ** 2 + e[m, 1] ** 2 + e[m, 2] ** 2))
        z = pts[0, 2]
        if math.isnan(acc[ACC_T_FALL]) and thr_top[0] == 0.0 and z <= ARM:
            thr_top[0] = min(z, 0.0) - PEN
    return EV_OK


@njit(cache=True)
def _all_anchored(anchored):
    for j in range(anchored.shape[0]):
        if anchored[j] == 0:
            return False
    return True


@njit(cache=True)
def run_events(Y, t, h, t_stop, alpha, floor_all, cone, anchored, locked, lock_cos, anchor_pos, anchor_t,
               thr_lock, thr_land, thr_unlock, thr_top, rtol, xtol, ws, adv, frames, trace, ev, pts, pv, vel, afor,
               counters, max_steps, stats, sc, log, log_n, acc, zeno_t, zeno_n, zeno_window, max_events,
               return_every, fr_lostl, fr_lostf, fill):
    """Integrate and handle events in one compiled loop.  Returns (code, t, h): an
    integrator code (integrator.ADV_*; never ADV_EVENT), EV_LANDED, EV_RETURN (after
    ``return_every`` events, or when the log has no room for another event), or a
    negative error code (ERR_*).  ``adv`` = (K, K2, Y1, Ytmp, dYtmp, lam, lam1),
    ``frames`` = (frame_dt, frame_next, cap, fr_t, fr_e, fr_w, fr_anch, fr_lock, fr_force,
    fr_kin, fr_pot, fr_count), ``trace`` = (tr_t, tr_z, tr_count), ``ev`` = (ev_kind,
    ev_idx, ev_theta), ``log`` = (log_t, log_kind, log_index, log_imp, log_energy).
    ``zeno_t``: ring of the latest event times (length ZENO_EVENTS + 1), ``zeno_n[0]``
    events seen.  Frames ``fill[0]`` .. ``fr_count[0]`` get the cumulative losses as
    they stand when the integrator returns (no loss happens between events)."""
    K, K2, Y1, Ytmp, dYtmp, lam, lam1 = adv
    frame_dt, frame_next, cap, fr_t, fr_e, fr_w, fr_anch, fr_lock, fr_force, fr_kin, fr_pot, fr_count = frames
    tr_t, tr_z, tr_count = trace
    ev_kind, ev_idx, ev_theta = ev
    log_t, log_kind, log_index, log_imp, log_energy = log
    n = Y.shape[1]
    room = 3 * n + 8  # log rows one event can add at most
    handled = 0
    zcap = zeno_t.shape[0]
    while True:
        if log_t.shape[0] - log_n[0] < room:
            return EV_RETURN, t, h
        code, t, h = advance(Y, t, h, t_stop, alpha, floor_all, cone, anchored, locked, lock_cos, anchor_pos,
                             thr_lock, thr_land, thr_unlock, thr_top, rtol, rtol, xtol, ws, K, K2, Y1, Ytmp, dYtmp,
                             lam, lam1, frame_dt, frame_next, cap, fr_t, fr_e, fr_w, fr_anch, fr_lock, fr_force,
                             fr_kin, fr_pot, fr_count, tr_t, tr_z, tr_count, ev_kind, ev_idx, ev_theta, pts, vel,
                             afor, counters, max_steps, stats)
        for f in range(fill[0], fr_count[0]):
            fr_lostl[f] = acc[ACC_LOST_LOCKING]
            fr_lostf[f] = acc[ACC_LOST_LANDING]
        fill[0] = fr_count[0]
        if code != ADV_EVENT:
            return code, t, h
        status = handle_event(t, ev_kind, ev_idx, ev_theta, counters[2], xtol, alpha, floor_all, cone,
                              Y[0], Y[1], anchored, locked, lock_cos, anchor_pos, anchor_t,
                              thr_lock, thr_unlock, thr_land, thr_top, ws, sc, pts, pv, vel,
                              log_t, log_kind, log_index, log_imp, log_energy, log_n, acc)
        if status < 0:
            return status, t, h
        # event accumulation: ZENO_EVENTS (= zcap - 1) events within zeno_window
        zk = zeno_n[0]
        zeno_t[zk % zcap] = t
        zeno_n[0] = zk + 1
        if zk + 1 >= zcap and t - zeno_t[(zk + 1) % zcap] < zeno_window:
            return ERR_ZENO, t, h
        if zk + 1 > max_events:  # event instants handled (not log rows)
            return ERR_MAX_EVENTS, t, h
        if _all_anchored(anchored):
            acc[ACC_T_LANDED] = t
            if math.isnan(acc[ACC_T_FALL]):
                acc[ACC_T_FALL] = t
            return EV_LANDED, t, h
        handled += 1
        if handled >= return_every:
            return EV_RETURN, t, h
