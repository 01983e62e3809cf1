"""What happens at an event instant (docs/model.md, "Events"), compiled: the one event
handler ``handle_event``, and the loop ``run_events`` that alternates the integrator
and the handler without returning to Python.

``handle_event`` applies, in this order:

1. unlock the hinges whose multiplier crossed zero (they cannot re-lock in this
   instant); in the pivot model, record the top end reaching the floor;
2. anchor the points the floor model lets touch the floor (``rules.floor_contacts``);
3. one Moreau impact (``impacts.velocity_impact``) over every new anchor and every
   hinge at its limit;
4. the acceleration-level LCP (``impacts.lock_set``): which hinges at the limit stay
   locked.  A hinge released in this instant that accelerates back to its limit and
   would return slower than ``hold_rate``, or after an excursion below
   ``hold_apex``, is held at its limit (``rules.must_hold``: the limit of the
   converging series of impacts it would start), and steps 3-4 are solved again;
5. new locks hold the angle reached; the state is projected onto the constraints; each
   event function is armed or marked departing (``arm_functions``), and the apex of
   each departing constraint that will come back is predicted (``apex_times``), so that
   its return is resolved even within one step.

The event log is kept in preallocated arrays (``log_*``, ``log_n[0]`` rows); each row is
one of ``result.EVENT_KINDS``.  The run's scalars are in ``acc``: [lost_locking, lost_landing,
floor impulse x, y, z, t_fall, t_landed].
"""

from __future__ import annotations

import math

import numpy as np

from ...core.jit import entry, njit

from ...core.dynamics import kinetic_energy, point_positions, project_state, reuse_factors, velocities
from ...core.impacts import hinge_gaps, hinge_rates, lock_set, velocity_impact
from ...records.result import EVENT_CODES
from .integrator import ADV_EVENT, EV_LANDING, EV_TOP, EV_UNLOCK, PROJ_TOL, advance
from ...core.rules import (
    DEPARTING,
    FLOOR_PIVOT,
    GAP_TOL,
    OFF,
    RATE_TOL,
    ZERO_BAND,
    arm_state,
    floor_contacts,
    floor_values,
    floor_watched,
    limit_in_force,
    must_hold,
)

# event-log kinds (result.EVENT_KINDS says what each means)
LOG_LOCK, LOG_UNLOCK, LOG_LANDING, LOG_TOP = EVENT_CODES["lock"], EVENT_CODES["unlock"], EVENT_CODES["landing"], \
    EVENT_CODES["top"]
LOG_IMPULSE, LOG_RELEASE, LOG_HOLD = EVENT_CODES["impulse"], EVENT_CODES["release"], EVENT_CODES["hold"]
LOG_ANCHOR = EVENT_CODES["anchor"]

ACC_LOST_LOCKING, ACC_LOST_LANDING, ACC_FLOOR_IMPULSE, ACC_T_FALL, ACC_T_LANDED = 0, 1, 2, 5, 6

@entry
@njit(cache=True)
def log_room(n):
    """Log rows one event instant can add at most: per hinge a lock/impulse/hold row and
    a release row, unlocks, per point a landing or an anchor-impulse row, the top."""
    return 3 * (n - 1) + (n + 1) + 8


# handle_event / run_events status codes (negative: the run cannot go on)
EV_OK = 0
EV_LANDED = 10  # every point anchored
EV_RETURN = 11  # returned to Python for progress, log space or the trace buffer
ERR_IMPACT_LCP, ERR_ENERGY, ERR_LOCK_LCP, ERR_ZENO, ERR_MAX_EVENTS = -1, -2, -3, -4, -5


@njit(cache=True, inline="always")
def _log(log, log_n, t, kind, index, i0, i1, i2, energy, pts, j):
    """One row of the event log ``log`` = (t, kind, index, impulse, energy, position);
    the position is that of point j (a hinge k: its point j = k + 1)."""
    log_t, log_kind, log_index, log_imp, log_energy, log_pos = log
    k = log_n[0]
    log_t[k] = t
    log_kind[k] = kind
    log_index[k] = index
    log_imp[k, 0] = i0
    log_imp[k, 1] = i1
    log_imp[k, 2] = i2
    log_energy[k] = energy
    for q in range(3):
        log_pos[k, q] = pts[j, q]
    log_n[0] = k + 1


@entry
@njit(cache=True)
def arm_functions(floor, alpha, cone, e, anchored, locked, gaps, lam, t_fall_known, arms, refs, fv):
    """Arm state of every event function after an instant (or at the start): a function
    is watched only where its rule applies, ARMED where positive, DEPARTING at its zero;
    its reference level (where a departing function starts) is min(f, 0).
    ``arms`` = (arm_lock, arm_unlock, arm_land, arm_top), ``refs`` likewise."""
    arm_lock, arm_unlock, arm_land, arm_top = arms
    ref_lock, ref_unlock, ref_land, ref_top = refs
    nh = locked.shape[0]
    for k in range(nh):
        arm_lock[k] = OFF
        arm_unlock[k] = OFF
        if not limit_in_force(anchored, k, cone, alpha):
            continue
        if locked[k] != 0:
            arm_unlock[k] = arm_state(lam[k])
            ref_unlock[k] = min(lam[k], 0.0)
        else:
            arm_lock[k] = arm_state(gaps[k])
            ref_lock[k] = min(gaps[k], 0.0)
    floor_values(floor, e, anchored, fv)
    for j in range(arm_land.shape[0]):
        arm_land[j] = arm_state(fv[j]) if floor_watched(floor, anchored, j) else OFF
        ref_land[j] = min(fv[j], 0.0)
    arm_top[0] = OFF
    if floor == FLOOR_PIVOT and not t_fall_known:
        z = 0.0
        for i in range(e.shape[0]):
            z += 2.0 * e[i, 2]
        arm_top[0] = arm_state(z)
        ref_top[0] = min(z, 0.0)


@njit(cache=True)
def apex_times(t, e, w, de, dw, arm_lock, arm_land, rates, ddg, pv, apex_lock, apex_land):
    """Predicted apex time of every departing constraint that accelerates back: a hinge
    (or a free point, floor ``all``) that leaves its zero at rate v > 0 while its
    acceleration a < 0 pulls it back peaks at t + v/|a| and returns at t + 2v/|a|.  The
    integrator samples a departing function there, so that a return within one step is
    located as a crossing (it fires only after the function has been seen positive).
    Only excursions that rise above rules.ZERO_BAND (v^2 / 2|a|) can be resolved; the
    others get inf (the accumulation rule has held those that would come back)."""
    for k in range(arm_lock.shape[0]):
        apex_lock[k] = math.inf
        if arm_lock[k] == DEPARTING and ddg[k] < 0.0 and rates[k] ** 2 > -2.0 * ZERO_BAND * ddg[k]:
            apex_lock[k] = t + rates[k] / -ddg[k]
    n = e.shape[0]
    apex_land[n] = math.inf
    az = 0.0  # d2z/dt2 of point j = 2 sum_{i>=j} (dw_i x e_i + w_i x de_i)_z
    for j in range(n - 1, -1, -1):
        az += 2.0 * (dw[j, 0] * e[j, 1] - dw[j, 1] * e[j, 0] + w[j, 0] * de[j, 1] - w[j, 1] * de[j, 0])
        apex_land[j] = math.inf
        if arm_land[j] == DEPARTING and az < 0.0 and pv[j, 2] > 0.0 and pv[j, 2] ** 2 > -2.0 * ZERO_BAND * az:
            apex_land[j] = t + pv[j, 2] / -az


@njit(cache=True)
def handle_event(t, ev_kind, ev_idx, ev_time, nev, xtol, hold_rate, hold_apex, alpha, floor, cone,
                 e, w, anchored, locked, lock_cos, anchor_pos, anchor_t,
                 arms, refs, apexes, ws, sc, pts, pv, vel, log, log_n, acc):
    """Apply everything that happens at the instant t (module docstring, steps 1-5).
    ``ws``: the Workspace arrays; ``sc``: scratch (``engine.Run.scratch``);
    ``apexes`` = (apex_lock, apex_land) (``apex_times``).  Returns EV_OK or a negative
    error code."""
    J, kind, nrow, S, G, drop, rhs, x, gf = ws
    (gaps, rates, rates_after, impulse, anchor_impulse, split, jv, w_plus, de, dw, ddg, lam,
     exclude, cand, active, was_locked, new_lock, in_force, new_anchor, pre_v,
     forced, entry, imp_sum, lost_h, stage_aimp, fv) = sc
    n = e.shape[0]
    nh = n - 1
    cos_alpha = math.cos(alpha)
    reuse_factors(S, np.bool_(True))  # the axes stay (off after the next evaluation: integrator.advance)
    point_positions(e, pts)  # (positions do not change at an instant)
    # 1. unlocks; the top end crossing the floor in the pivot model
    for k in range(nh):
        exclude[k] = 0
    any_landing = np.bool_(False)
    for i in range(nev):
        if ev_time[i] > t + 10.0 * xtol:
            continue
        if ev_kind[i] == EV_UNLOCK:
            k = ev_idx[i]
            if locked[k]:
                locked[k] = 0
                exclude[k] = 1
                _log(log, log_n, t, LOG_UNLOCK, k, 0.0, 0.0, 0.0, 0.0, pts, k + 1)
        elif ev_kind[i] == EV_TOP:
            if math.isnan(acc[ACC_T_FALL]):
                acc[ACC_T_FALL] = t
                _log(log, log_n, t, LOG_TOP, 0, 0.0, 0.0, 0.0, 0.0, pts, 0)
        elif ev_kind[i] == EV_LANDING:
            any_landing = True
    # 2. floor contacts
    velocities(e, w, pv, vel)
    na = floor_contacts(floor, e, pts, pv, anchored, any_landing, new_anchor)
    for r in range(na):
        j = new_anchor[r]
        for q in range(3):
            pre_v[r, q] = pv[j, q]
            anchor_pos[j, q] = pts[j, q]  # held where it touched (|z| < Z_TOL)
        anchored[j] = 2  # anchored; its neighbours still move during the impact
        anchor_t[j] = t
    # 3-4. one impact over the new anchors and every hinge at its limit, then the lock
    # set; repeated while the accumulation rule holds another hinge (rules.must_hold)
    hinge_gaps(e, cos_alpha, gaps)
    hinge_rates(e, w, rates)
    any_approaching = False
    for k in range(nh):
        in_force[k] = 1 if limit_in_force(anchored, k, cone, alpha) else 0
        if not in_force[k]:
            locked[k] = 0
        cand[k] = 1 if (in_force[k] and (gaps[k] <= GAP_TOL or locked[k] != 0) and exclude[k] == 0) else 0
        approaching = cand[k] != 0 and rates[k] < -RATE_TOL
        any_approaching = any_approaching or approaching
        was_locked[k] = locked[k]
        new_lock[k] = 0
        forced[k] = 0
        imp_sum[k] = 0.0
        lost_h[k] = 0.0
        active[k] = 1 if (locked[k] != 0 or approaching) else 0
    for j in range(n + 1):
        for q in range(3):
            anchor_impulse[j, q] = 0.0
    T0 = kinetic_energy(e, w, pv, vel)
    impact = na > 0 or any_approaching
    for rnd in range(nh + 1):  # each round holds at least one more hinge
        if impact:
            for k in range(nh):
                entry[k] = active[k]
            hinge_rates(e, w, rates)
            it = velocity_impact(e, w, anchored, cand, forced, active, J, kind, nrow, S, G, drop, rhs, x, gf,
                                 pv, vel, jv, w_plus, rates_after, impulse, stage_aimp, split)
            if it < 0:
                return ERR_IMPACT_LCP
            acc[ACC_LOST_LOCKING] += split[0]
            acc[ACC_LOST_LANDING] += split[1]
            for j in range(n + 1):  # the floor's impulse on the chain: every anchor, new or old
                for q in range(3):
                    anchor_impulse[j, q] += stage_aimp[j, q]
                    acc[ACC_FLOOR_IMPULSE + q] += stage_aimp[j, q]
            for k in range(nh):
                imp_sum[k] += impulse[k]
                lost_h[k] += -0.5 * impulse[k] * (rates[k] + rates_after[k])
                if rnd == 0 and active[k] and not was_locked[k]:
                    new_lock[k] = 1
                locked[k] = active[k]  # hinges kept at the limit by the impact
            hinge_rates(e, w, rates)
        if rnd == 0:
            for j in range(n + 1):
                if anchored[j] == 2:
                    anchored[j] = 1
            for k in range(nh):
                in_force[k] = 1 if limit_in_force(anchored, k, cone, alpha) else 0
                if not in_force[k]:
                    locked[k] = 0
            for i in range(n):
                if anchored[i] != 0 and anchored[i + 1] != 0:
                    w[i, 0] = 0.0
                    w[i, 1] = 0.0
                    w[i, 2] = 0.0
        # which hinges at the limit stay locked (acceleration-level LCP)
        for k in range(nh):
            c2 = (((in_force[k] and gaps[k] <= GAP_TOL and abs(rates[k]) <= RATE_TOL) or locked[k] != 0)
                  and exclude[k] == 0)
            cand[k] = 1 if c2 else 0
            active[k] = 1 if (locked[k] != 0 and c2) else 0
        it = lock_set(e, w, anchored, cand, active, J, kind, nrow, S, G, drop, rhs, x, gf, de, dw, ddg, lam)
        if it < 0:
            return ERR_LOCK_LCP
        for k in range(nh):
            locked[k] = active[k]
        # the accumulation limit: a hinge this instant has released (it was locked, or
        # took an impulse) that accelerates back to its limit and would return either
        # slower than hold_rate or after an excursion too small to resolve
        nhold = 0
        for k in range(nh):
            if locked[k] or forced[k] or not (was_locked[k] or new_lock[k]) or exclude[k] or gaps[k] > GAP_TOL:
                continue
            if must_hold(rates[k], ddg[k], hold_rate, hold_apex):
                forced[k] = 1
                nhold += 1
        if nhold == 0:
            break
        impact = True
        for k in range(nh):
            cand[k] = 1 if (in_force[k] and (gaps[k] <= GAP_TOL or locked[k] != 0 or forced[k])) and not exclude[k] \
                else 0
            active[k] = 1 if (locked[k] or forced[k]) else 0
    T1 = kinetic_energy(e, w, pv, vel)
    if T1 > T0 * (1 + 1e-9) + 1e-12:
        return ERR_ENERGY
    # the log: one row per constraint that acted
    for k in range(nh):
        if forced[k]:
            _log(log, log_n, t, LOG_HOLD, k, imp_sum[k], 0.0, 0.0, lost_h[k], pts, k + 1)
        elif imp_sum[k] != 0.0 or new_lock[k]:
            _log(log, log_n, t, LOG_IMPULSE if was_locked[k] else LOG_LOCK, k, imp_sum[k], 0.0, 0.0, lost_h[k],
                 pts, k + 1)
        elif locked[k] and not was_locked[k]:  # a touch that locks
            _log(log, log_n, t, LOG_LOCK, k, 0.0, 0.0, 0.0, 0.0, pts, k + 1)
        if not locked[k] and (was_locked[k] or new_lock[k] or forced[k]):
            _log(log, log_n, t, LOG_RELEASE, k, 0.0, 0.0, 0.0, 0.0, pts, k + 1)
    for r in range(na):
        j = new_anchor[r]
        i0, i1, i2 = anchor_impulse[j, 0], anchor_impulse[j, 1], anchor_impulse[j, 2]
        lost = -0.5 * (i0 * pre_v[r, 0] + i1 * pre_v[r, 1] + i2 * pre_v[r, 2])
        _log(log, log_n, t, LOG_LANDING, j, i0, i1, i2, lost, pts, j)
    for j in range(n + 1):  # impulses of the floor on points anchored before this instant
        if anchored[j] != 0 and anchor_t[j] != t:
            i0, i1, i2 = anchor_impulse[j, 0], anchor_impulse[j, 1], anchor_impulse[j, 2]
            if i0 != 0.0 or i1 != 0.0 or i2 != 0.0:
                _log(log, log_n, t, LOG_ANCHOR, j, i0, i1, i2, 0.0, pts, j)
    # 5. hold new locks at the angle reached, project, arm the event functions
    for k in range(nh):
        if was_locked[k] == 0 and locked[k] != 0:
            lock_cos[k] = cos_alpha + gaps[k]
    velocities(e, w, pv, vel)
    project_state(e, w, anchored, locked, lock_cos, anchor_pos, J, kind, nrow, S, G, drop, rhs, x, gf,
                  pts, vel, PROJ_TOL, np.int64(5))
    hinge_gaps(e, cos_alpha, gaps)
    if floor != FLOOR_PIVOT and anchored[0] and math.isnan(acc[ACC_T_FALL]):
        acc[ACC_T_FALL] = t
    arm_functions(floor, alpha, cone, e, anchored, locked, gaps, lam, not math.isnan(acc[ACC_T_FALL]), arms, refs,
                  fv)
    hinge_rates(e, w, rates)
    velocities(e, w, pv, vel)
    apex_times(t, e, w, de, dw, arms[0], arms[2], rates, ddg, pv, apexes[0], apexes[1])
    return EV_OK


@njit(cache=True)
def _all_anchored(anchored):
    for j in range(anchored.shape[0]):
        if anchored[j] == 0:
            return False
    return True


@entry
@njit(cache=True)
def run_events(Y, t, h, t_stop, alpha, floor, cone, anchored, locked, lock_cos, anchor_pos, anchor_t,
               arms, refs, apexes, rtol, xtol, hold_rate, hold_apex, ws, adv, frames, trace, ev, pts, pv, vel,
               counters, max_steps, stats, sc, log, log_n, acc, zeno_t, zeno_n, zeno_window, max_events,
               return_every):
    """Integrate and handle events in one compiled loop.  Returns (code, t, h): an
    integrator code (integrator.ADV_*; never ADV_EVENT; ADV_BUFFER: the trace or frame
    buffers are full), EV_LANDED, EV_RETURN (after ``return_every`` events, or when the
    log has no room for another event), or a negative error code (ERR_*).  ``arms`` =
    (arm_lock, arm_unlock, arm_land, arm_top), ``refs`` their reference levels
    (``arm_functions``), ``apexes`` = (apex_lock, apex_land) (``apex_times``),
    ``adv`` = (K, K2, Y1, Ytmp, dYtmp, lam, lam1, F, F2, fint, fsal) (``integrator.advance``),
    ``frames`` = (frame_dt, frame_next, cap, fr_t, fr_e, fr_w, fr_anch, fr_lock,
    fr_force, fr_kin, fr_pot, fr_count, fr_pull, fr_scale, fr_fimp, fr_lostl, fr_lostf,
    fill), ``trace`` = (tr_t, tr_z, tr_count), ``ev`` = (ev_kind, ev_idx, ev_theta),
    ``log`` = (log_t, log_kind, log_index, log_imp, log_energy, log_pos).  ``zeno_t``:
    ring of the latest event times (length ZENO_EVENTS + 1), ``zeno_n[0]`` events seen.
    Frames ``fill[0]`` .. ``fr_count[0]`` get the cumulative losses and floor impulses
    of the impacts as they stand when the integrator returns (no impact happens between
    events)."""
    K, K2, Y1, Ytmp, dYtmp, lam, lam1, F, F2, fint, fsal = adv
    (frame_dt, frame_next, cap, fr_t, fr_e, fr_w, fr_anch, fr_lock, fr_force, fr_kin, fr_pot, fr_count,
     fr_pull, fr_scale, fr_fimp, fr_lostl, fr_lostf, fill) = frames
    tr_t, tr_z, tr_count = trace
    ev_kind, ev_idx, ev_theta = ev
    log_t = log[0]
    arm_lock, arm_unlock, arm_land, arm_top = arms
    ref_lock, ref_unlock, ref_land, ref_top = refs
    n = Y.shape[1]
    room = log_room(n)
    handled = 0
    zcap = zeno_t.shape[0]
    while True:
        if log_t.shape[0] - log_n[0] < room:
            return EV_RETURN, t, h
        code, t, h = advance(Y, t, h, t_stop, alpha, floor, anchored, locked, lock_cos, anchor_pos,
                             arm_lock, arm_land, arm_unlock, arm_top, ref_lock, ref_land, ref_unlock, ref_top,
                             apexes[0], apexes[1], rtol, rtol, xtol, ws, K, K2, Y1, Ytmp, dYtmp,
                             lam, lam1, F, F2, fint, fsal, frame_dt, frame_next, cap, fr_t, fr_e, fr_w, fr_anch, fr_lock,
                             fr_force, fr_kin, fr_pot, fr_count, fr_pull, fr_scale, fr_fimp, tr_t, tr_z, tr_count,
                             ev_kind, ev_idx, ev_theta, pts, vel, counters, max_steps, stats)
        for f in range(fill[0], fr_count[0]):
            fr_lostl[f] = acc[ACC_LOST_LOCKING]
            fr_lostf[f] = acc[ACC_LOST_LANDING]
            for q in range(3):
                fr_fimp[f, q] += acc[ACC_FLOOR_IMPULSE + q]
        fill[0] = fr_count[0]
        if code != ADV_EVENT:
            return code, t, h
        status = handle_event(t, ev_kind, ev_idx, ev_theta, counters[2], xtol, hold_rate, hold_apex, alpha, floor,
                              cone, Y[0], Y[1], anchored, locked, lock_cos, anchor_pos, anchor_t, arms, refs, apexes,
                              ws, sc, pts, pv, vel, log, log_n, acc)
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
