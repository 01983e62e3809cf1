"""Event detection and location on a step's dense output (numba, nondimensional):
each kind of event function in turn (``detect_events``), sampled at the step's end and
midpoint (armed), where a hinge's gap has an interior minimum (``_closest_approach``),
or at NSCAN points and its predicted apex (departing functions that were triggered), and
located by Brent's method to ``xtol`` (``_brent``).  The module docstring of
``integrator`` states how each function is watched."""

from __future__ import annotations

import math

import numpy as np

from ...contacts.coulomb import slides
from ...core.base import floor_z
from ...core.dynamics import lock_multipliers
from ...core.rules import ARMED, OFF, ZERO_BAND, hinge_gap, point_height
from ...core.unilateral import vertical_multipliers
from ...floors.dispatch import floor_value, floor_values
from ...jit import njit
from .dopri import chain_rhs, dense_axes, dense_e, dense_state, dense_weights
from .watch import EV_LANDING, EV_LIFT, EV_LOCK, EV_TOP, EV_UNLOCK

NSCAN = 16  # samples per step for a triggered departing function


@njit(cache=True, _nrt=True)
def event_value(kind, idx, theta, h, model, dense, ws):
    """Value of event function (kind, idx) at t0 + theta h on the dense output of the
    step of size h from dense.Y (stages dense.K)."""
    Y0, K, Yt = dense.Y, dense.K, dense.Yt
    b = np.empty(7)
    dense_weights(h, theta, b)
    if kind == EV_LOCK:
        pair = dense.pair  # the two axes of the hinge (hinge_gap normalises: the dense output is not unit length)
        for r in range(2):
            for q in range(3):
                pair[r, q] = dense_e(Y0, K, b, idx + r, q)
        return hinge_gap(pair, 0, model.cos_alpha)
    if kind == EV_LANDING:
        dense_axes(Y0, K, b, Yt[0])
        zf = floor_z(Yt[0], dense.anchored, dense.base, dense.t0[0] + theta * h)
        return floor_value(model.floor, Yt[0], dense.anchored, zf, idx)
    if kind == EV_TOP:
        dense_axes(Y0, K, b, Yt[0])
        return point_height(Yt[0], 0)
    # EV_UNLOCK: lambda_k at the interpolated state; EV_LIFT: the floor's force on point idx
    dense_state(Y0, K, h, theta, Yt)
    chain_rhs(Yt, dense.anchored, dense.locked, ws, dense.dYt)
    if kind == EV_LIFT:
        vertical_multipliers(ws.kind, ws.nrow, ws.x, dense.pz)
        return dense.pz[idx]
    lock_multipliers(ws.kind, ws.nrow, ws.x, dense.lam)
    return dense.lam[idx]


@njit(cache=True, _nrt=False)
def _brent(kind, idx, off, a, b, fa, fb, h, model, dense, ws):
    """Root of f + off on [a, b] (theta units) with fa > 0 >= fb (the values of f + off
    there) by Brent's method; returns a theta at which f + off <= 0 (the crossing, to
    model.xtol)."""
    xtol = model.xtol / h
    c, fc = a, fa
    d = b - a
    e_ = d
    for _ in range(200):
        if fb * fc > 0.0:
            c, fc = a, fa
            d = b - a
            e_ = d
        if abs(fc) < abs(fb):
            a, b, c = b, c, b
            fa, fb, fc = fb, fc, fb
        tol1 = 2.0 * 1e-16 * abs(b) + 0.5 * xtol
        xm = 0.5 * (c - b)
        if abs(xm) <= tol1 or fb == 0.0:
            break
        if abs(e_) >= tol1 and abs(fa) > abs(fb):
            s = fb / fa
            if a == c:
                p = 2.0 * xm * s
                q = 1.0 - s
            else:
                q = fa / fc
                r = fb / fc
                p = s * (2.0 * xm * q * (q - r) - (b - a) * (r - 1.0))
                q = (q - 1.0) * (r - 1.0) * (s - 1.0)
            if p > 0.0:
                q = -q
            p = abs(p)
            if 2.0 * p < min(3.0 * xm * q - abs(tol1 * q), abs(e_ * q)):
                e_ = d
                d = p / q
            else:
                d = xm
                e_ = d
        else:
            d = xm
            e_ = d
        a, fa = b, fb
        if abs(d) > tol1:
            b += d
        else:
            b += tol1 if xm > 0 else -tol1
        fb = event_value(kind, idx, b, h, model, dense, ws) + off
    # return the end of the bracket on the far side of the crossing
    if fb <= 0.0:
        return b
    return c


@njit(cache=True, _nrt=False)
def _locate_armed(kd, ix, tha, fmid, fend, h, model, dense, ws):
    """Where an ARMED function fires in the step (theta), or 2.0: its first crossing of
    zero, bracketed by the start, the predicted closest approach ``tha`` (if in the
    step: a dip through zero shorter than the step), the midpoint (fmid; inf: unknown)
    and the end."""
    f0 = event_value(kd, ix, 0.0, h, model, dense, ws)
    if f0 <= 0.0:
        return 0.0
    if 0.0 < tha < 0.5 or (0.5 <= tha < 1.0 and fmid > 0.0):
        fa = event_value(kd, ix, tha, h, model, dense, ws)
        if fa <= 0.0:
            lo, flo = (0.5, fmid) if tha >= 0.5 else (0.0, f0)
            return _brent(kd, ix, 0.0, lo, tha, flo, fa, h, model, dense, ws)
    if fmid <= 0.0:
        return _brent(kd, ix, 0.0, 0.0, 0.5, f0, fmid, h, model, dense, ws)
    if fend <= 0.0:
        if fmid == math.inf:
            return _brent(kd, ix, 0.0, 0.0, 1.0, f0, fend, h, model, dense, ws)
        return _brent(kd, ix, 0.0, 0.5, 1.0, fmid, fend, h, model, dense, ws)
    return 2.0


@njit(cache=True, _nrt=False)
def _locate(kd, ix, mode, ref, tha, fmid, fend, h, model, dense, ws):
    """Where in the step (theta in [0, 1]) event function (kd, ix) fires, or 2.0 if it
    does not (module docstring).  ``fmid``, ``fend``: its values at the midpoint and the
    end (fmid = inf: unknown); ``tha``: the predicted apex of a departing function, in
    theta units (outside (0, 1): none in this step)."""
    if mode == ARMED:
        return _locate_armed(kd, ix, tha, fmid, fend, h, model, dense, ws)
    # DEPARTING: it fires when it returns to zero after a sample above ZERO_BAND, or,
    # never having been there, when it sinks below ref - ZERO_BAND
    nscan = NSCAN if (kd != EV_UNLOCK and kd != EV_LIFT) else 2  # a multiplier costs an evaluation per sample
    thp = -1.0
    fp = 0.0
    thq = 0.0
    fq = 0.0
    apex_done = not (0.0 < tha < 1.0)
    s = 0
    while s <= nscan:
        th = s / nscan
        if not apex_done and tha < th:  # the predicted apex comes first
            th = tha
            apex_done = True
            f = event_value(kd, ix, th, h, model, dense, ws)
        else:
            s += 1
            if th == 1.0:
                f = fend
            elif th == 0.5 and fmid != math.inf:
                f = fmid
            else:
                f = event_value(kd, ix, th, h, model, dense, ws)
        if f > ZERO_BAND:
            thp = th
            fp = f
        elif thp >= 0.0 and f <= 0.0:
            return _brent(kd, ix, 0.0, thp, th, fp, f, h, model, dense, ws)
        elif f < ref - ZERO_BAND:
            sink = ZERO_BAND - ref
            if th == 0.0 or fq + sink <= 0.0:
                return thq
            return _brent(kd, ix, sink, thq, th, fq + sink, f + sink, h, model, dense, ws)
        thq = th
        fq = f
    return 2.0


@njit(cache=True, _nrt=False)
def _closest_approach(Y0, Y1, K, h, k, g1, cos_alpha):
    """Theta in (0, 1) where hinge k's gap comes closest to its limit inside the step,
    or 2.0 if it has no interior minimum: the minimum of the cubic Hermite interpolant
    of g_k through its values g0, g1 and rates h dg/dt at the step's ends (dg/dt =
    de_k . e_{k+1} + e_k . de_{k+1}, the rates f(Y0) = K[0] and f(Y1) = K[6]).  The
    integrator samples the dense output there, so that a dip through the limit that
    starts and ends inside one step is seen and located (a free hinge released or
    passing by its limit between two instants)."""
    e0, e1 = Y0[0], Y1[0]
    g0 = hinge_gap(e0, k, cos_alpha)
    d0 = 0.0
    d1 = 0.0
    for q in range(3):
        d0 += K[0, 0, k, q] * e0[k + 1, q] + e0[k, q] * K[0, 0, k + 1, q]
        d1 += K[6, 0, k, q] * e1[k + 1, q] + e1[k, q] * K[6, 0, k + 1, q]
    d0 *= h
    d1 *= h
    # p(s) = g0 + d0 s + c2 s^2 + c3 s^3 with p(1) = g1, p'(1) = d1
    c2 = 3.0 * (g1 - g0) - 2.0 * d0 - d1
    c3 = 2.0 * (g0 - g1) + d0 + d1
    best = 2.0
    if abs(c3) < 1e-300:
        if c2 > 0.0:
            s = -d0 / (2.0 * c2)
            if 0.0 < s < 1.0:
                best = s
        return best
    disc = c2 * c2 - 3.0 * c3 * d0
    if disc < 0.0:
        return best
    r = math.sqrt(disc)
    for s in ((-c2 + r) / (3.0 * c3), (-c2 - r) / (3.0 * c3)):
        if 0.0 < s < 1.0 and 2.0 * c2 + 6.0 * c3 * s > 0.0:
            best = s
    return best


@njit(cache=True, _nrt=False)
def _detect_kind(kd, nev, t, h, model, watch, dense, ws, sg, det):
    """The event functions of kind kd that fire in the step: each watched function is
    checked at the step's midpoint (sg.Ytmp) and end (sg.Y1) and located where it
    crossed (``_locate``); they are appended to det.found from row nev on.  Returns the
    new count."""
    found = det.found
    nh = dense.locked.shape[0]
    m = (
        nh
        if kd == EV_LOCK or kd == EV_UNLOCK
        else (dense.anchored.shape[0] if kd == EV_LANDING or kd == EV_LIFT else 1)
    )
    if kd == EV_LANDING:
        zm = floor_z(sg.Ytmp[0], dense.anchored, dense.base, t + 0.5 * h)
        floor_values(model.floor, sg.Ytmp[0], dense.anchored, zm, det.fv_mid)
        ze = floor_z(sg.Y1[0], dense.anchored, dense.base, t + h)
        floor_values(model.floor, sg.Y1[0], dense.anchored, ze, det.fv_end)
    for i in range(m):
        if kd == EV_LOCK:
            if watch.arm_lock[i] == OFF or dense.locked[i]:
                continue
            mode, ref, tha = watch.arm_lock[i], watch.ref_lock[i], (watch.apex_lock[i] - t) / h
            fm = hinge_gap(sg.Ytmp[0], i, model.cos_alpha)
            fe = hinge_gap(sg.Y1[0], i, model.cos_alpha)
            if mode == ARMED:
                thc = _closest_approach(dense.Y, sg.Y1, dense.K, h, i, fe, model.cos_alpha)
                if thc < 1.0:
                    tha = thc
        elif kd == EV_UNLOCK:  # the multiplier, known at the end only (each sample costs an evaluation)
            if watch.arm_unlock[i] == OFF or not dense.locked[i]:
                continue
            mode, ref, tha = watch.arm_unlock[i], watch.ref_unlock[i], 2.0
            fm, fe = math.inf, det.lam1[i]
        elif kd == EV_LANDING:
            if watch.arm_land[i] == OFF:
                continue
            mode, ref, tha = watch.arm_land[i], watch.ref_land[i], (watch.apex_land[i] - t) / h
            fm, fe = det.fv_mid[i], det.fv_end[i]
        elif kd == EV_LIFT:  # the floor's force on a sliding point, known at the end only (as a multiplier)
            if watch.arm_lift[i] == OFF or dense.anchored[i] == 0:
                continue
            mode, ref, tha = watch.arm_lift[i], watch.ref_lift[i], 2.0
            fm, fe = math.inf, det.pz1[i]
        else:
            if watch.arm_top[0] == OFF:
                continue
            mode, ref, tha = watch.arm_top[0], watch.ref_top[0], 2.0
            fm, fe = point_height(sg.Ytmp[0], 0), point_height(sg.Y1[0], 0)
        if fm <= 0.0 or fe <= 0.0 or (mode == ARMED and 0.0 < tha < 1.0):
            found.kind[nev] = kd
            found.idx[nev] = i
            found.time[nev] = _locate(kd, i, mode, ref, tha, fm, fe, h, model, dense, ws)
            nev += 1
            if kd == EV_LANDING:
                dense_state(dense.Y, dense.K, h, 0.5, sg.Ytmp)  # (the locating used Ytmp)
    return nev


@njit(cache=True, _nrt=False)
def detect_events(t, h, model, watch, dense, ws, sg, det, n_evals):
    """Every event function that fires in the step, kind by kind (watch.EVENT_FUNCTIONS
    order), into det.found; returns (theta of the first, whether any fires)."""
    dense_state(dense.Y, dense.K, h, 0.5, sg.Ytmp)  # midpoint state, for the midpoint checks
    nev = 0
    for kd in range(EV_LOCK, (EV_LIFT if slides(model.friction) else EV_TOP) + 1):
        n0 = nev
        nev = _detect_kind(kd, nev, t, h, model, watch, dense, ws, sg, det)
        if kd == EV_UNLOCK or kd == EV_LIFT:
            n_evals[0] += 2 * (nev - n0)
            if nev > 0:
                dense_state(dense.Y, dense.K, h, 0.5, sg.Ytmp)  # (the locating may have used Ytmp)
    det.found.n[0] = nev
    theta_stop = 1.0
    fire = False
    for r in range(nev):
        theta_stop = min(theta_stop, det.found.time[r])
        fire = fire or det.found.time[r] <= 1.0
    return theta_stop, fire
