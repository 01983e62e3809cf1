"""Dormand-Prince 5(4) with dense output, event detection and location (numba).

The whole step loop runs compiled (``advance``); it returns to Python only at an
event, at the stop time, when an output buffer is full, or on failure.  Nondimensional
units throughout (m = b = g = 1).

State: ``Y`` of shape (2, N, 3): ``Y[0]`` the unit axes e, ``Y[1]`` the angular
velocities w.

Event functions (each located by Brent's method on the dense output to ``xtol``):

  kind 1  lock       g_k = e_k . e_{k+1} - cos(alpha)     unlocked hinge whose limit is in force
  kind 2  unlock     lambda_k                              locked hinge
  kind 3  landing    rules.floor_value (floor "all": the height of every free point;
                     floor "pivot": e_M . e_z of the bottom airborne segment M)
  kind 4  top        z_0 (floor "pivot" only: t_fall, no state change)

How each function is watched is its arm state (``rules.arm_state``, arrays ``arm_*``):
ARMED functions are positive and fire when they reach zero; a DEPARTING function sits at
its zero after the event that put it there and is known to leave it (the event
handler has made its rate non-negative), so it fires only when it returns to zero
after having been positive, and that return is located like any other crossing: no
penetration margin delays an event.  A departing function becomes armed once a step
ends with it above ``rules.ZERO_BAND``.  One that has not yet been above it (a
constraint hovering at its limit: rate and acceleration both about zero) fires when it
sinks below ``-rules.ZERO_BAND``.  A step is checked at its end and its midpoint (armed
functions), or at 16 points and at its predicted apex (departing functions that were
triggered; the event handler predicts where a departing constraint that accelerates
back peaks, ``events.apex_times``, so that a return within one step is seen positive
first and located as a crossing).  The sinking level is measured from where the
function started (``ref_*``: min(f, 0) after the event), since an event leaves it only
within round-off of its zero.

The step error is the largest component error over the state (a max norm), so its
meaning does not change with N.
"""

from __future__ import annotations

import math
from fractions import Fraction as Fr

import numpy as np
from ...core.jit import njit

from ...core.dynamics import (
    accelerations,
    anchor_force_total,
    pile_pull,
    kinetic_energy,
    lock_multipliers,
    potential_energy,
    project_state,
    reuse_factors,
)
from ...core.rules import ARMED, DEPARTING, OFF, ZERO_BAND, floor_value, floor_values

# Dormand-Prince 5(4) (Hairer's DOPRI5; the coefficients of scipy's RK45)
C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
A = np.array([
    [0, 0, 0, 0, 0],
    [1 / 5, 0, 0, 0, 0],
    [3 / 40, 9 / 40, 0, 0, 0],
    [44 / 45, -56 / 15, 32 / 9, 0, 0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
])
B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
E = np.array([-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
P = np.array([
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 0, 0, 0],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
])


def _hermite_birkhoff_inverse(sa, sb):
    """Exact inverse of the 4 x 4 system for the coefficients a_2..a_5 of the quintic
    p(s) = y0 + s h f0 + sum_m a_m s^m with p(1) = y1, p'(1) = h f1, p'(sa) = h fa,
    p'(sb) = h fb (rows in that order)."""
    m = [[Fr(1)] * 4, [Fr(2), Fr(3), Fr(4), Fr(5)],
         [2 * sa, 3 * sa ** 2, 4 * sa ** 3, 5 * sa ** 4], [2 * sb, 3 * sb ** 2, 4 * sb ** 3, 5 * sb ** 4]]
    inv = [[Fr(int(i == j)) for j in range(4)] for i in range(4)]
    for col in range(4):  # Gauss-Jordan in exact rationals
        piv = next(r for r in range(col, 4) if m[r][col] != 0)
        m[col], m[piv] = m[piv], m[col]
        inv[col], inv[piv] = inv[piv], inv[col]
        d = m[col][col]
        m[col] = [v / d for v in m[col]]
        inv[col] = [v / d for v in inv[col]]
        for r in range(4):
            if r != col and m[r][col] != 0:
                fac = m[r][col]
                m[r] = [a - fac * b for a, b in zip(m[r], m[col])]
                inv[r] = [a - fac * b for a, b in zip(inv[r], inv[col])]
    return np.array([[float(v) for v in row] for row in inv])


# the state at an event: a quintic through the step's ends and f at the 4th-order dense
# output at these nodes (``_event_state``)
HB_NODES = np.array([1 / 3, 2 / 3])
HB_MINV = _hermite_birkhoff_inverse(Fr(1, 3), Fr(2, 3))

EV_LOCK, EV_UNLOCK, EV_LANDING, EV_TOP = 1, 2, 3, 4
ADV_STOP, ADV_EVENT, ADV_BUFFER, ADV_FAIL_STEP, ADV_FAIL_NAN, ADV_MAX_STEPS = 0, 1, 2, 3, 4, 5

NSCAN = 16  # samples per step for a triggered departing function
PROJ_TOL = 1e-12  # constraint drift tolerated before projection


@njit(cache=True)
def _rhs(Y, anchored, locked, ws, dY):
    J, kind, nrow, S, G, drop, rhs, x, gf = ws
    return accelerations(Y[0], Y[1], anchored, locked, J, kind, nrow, S, G, drop, rhs, x, gf, dY[0], dY[1])


@njit(cache=True, inline="always")
def _dense_weights(h, theta, b):
    """b_s = h sum_p P[s, p] theta^(p+1): y(t0 + theta h) = y0 + sum_s b_s K_s."""
    for s in range(7):
        acc = 0.0
        tp = theta
        for p in range(4):
            acc += P[s, p] * tp
            tp *= theta
        b[s] = acc * h


@njit(cache=True)
def _dense(Y0, K, h, theta, out):
    """Continuous extension of the step (4th order) at t0 + theta h, whole state."""
    b = np.empty(7)
    _dense_weights(h, theta, b)
    n = Y0.shape[1]
    for a in range(2):
        for i in range(n):
            for q in range(3):
                v = Y0[a, i, q]
                for s in range(7):
                    v += b[s] * K[s, a, i, q]
                out[a, i, q] = v


@njit(cache=True, inline="always")
def _dense_e(Y0, K, b, i, q):
    """One component e[i, q] of the dense output, weights b from _dense_weights."""
    v = Y0[0, i, q]
    for s in range(7):
        v += b[s] * K[s, 0, i, q]
    return v


@njit(cache=True)
def _stage_rhs(Y, anchored, locked, ws, dY, F):
    """dY = f(Y) and F = the anchors' total force on the chain at Y."""
    _rhs(Y, anchored, locked, ws, dY)
    anchor_force_total(ws[1], ws[2], ws[7], F)


@njit(cache=True)
def _rk_stages(Y, h, K, Ytmp, Y1, anchored, locked, ws, F):
    """Stages 2..7 of a Dormand-Prince step of size h from Y (K[0] = f(Y), F[0] given);
    Y1 = the 5th-order solution, K[6] = f(Y1); F[s] the anchors' force at stage s."""
    n = Y.shape[1]
    for s in range(1, 7):
        for a in range(2):
            for i in range(n):
                for q in range(3):
                    v = Y[a, i, q]
                    if s < 6:
                        for r in range(s):
                            v += h * A[s, r] * K[r, a, i, q]
                    else:
                        for r in range(6):
                            v += h * B[r] * K[r, a, i, q]
                    Ytmp[a, i, q] = v
        if s < 6:
            _stage_rhs(Ytmp, anchored, locked, ws, K[s], F[s])
        else:
            for a in range(2):
                for i in range(n):
                    for q in range(3):
                        Y1[a, i, q] = Ytmp[a, i, q]
            _stage_rhs(Y1, anchored, locked, ws, K[6], F[6])


@njit(cache=True)
def _event_state(Y, K, K2, F, F2, Y1, Ytmp, h, theta, anchored, locked, ws, n_landed, fint):
    """Y <- the state at t0 + theta h of the step from Y (stages K, F; Y1 its 5th-order
    end, K[6] = f(Y1)), fint advanced to that time.  The quintic p(s), s in [0, 1], with
    p(0) = y0, p'(0) = h f0, p(1) = y1, p'(1) = h f(y1) and p'(s_r) = h f(y(s_r)) at the
    nodes s_r = 1/3, 2/3, y(s_r) from the 4th-order continuous extension: two
    evaluations (K2[1:3], F2[1:3]), against five for a new step to t0 + theta h, and a
    local error of the step's own order, O(h^6) (the data's errors enter times h), a
    few times the full step's (tests/test_event_state.py).
    With c = M^-T (theta^2 .. theta^5) (``HB_MINV``):
      p(theta) = y0 + theta h f0 + c0 (y1 - y0 - h f0) + c1 h (f1 - f0)
                 + c2 h (f(y(1/3)) - f0) + c3 h (f(y(2/3)) - f0).
    The floor's impulse, the integral of F (an extra state J' = F), the same way."""
    n = Y.shape[1]
    for r in range(2):
        _dense(Y, K, h, HB_NODES[r], Ytmp)
        _stage_rhs(Ytmp, anchored, locked, ws, K2[1 + r], F2[1 + r])
    c0 = c1 = c2 = c3 = 0.0
    tp = theta * theta
    for m in range(4):
        c0 += HB_MINV[m, 0] * tp
        c1 += HB_MINV[m, 1] * tp
        c2 += HB_MINV[m, 2] * tp
        c3 += HB_MINV[m, 3] * tp
        tp *= theta
    for a in range(2):
        for i in range(n):
            for q in range(3):
                y0 = Y[a, i, q]
                k0 = h * K[0, a, i, q]
                Y[a, i, q] = (y0 + theta * k0 + c0 * (Y1[a, i, q] - y0 - k0) + c1 * (h * K[6, a, i, q] - k0)
                              + c2 * (h * K2[1, a, i, q] - k0) + c3 * (h * K2[2, a, i, q] - k0))
    for q in range(3):
        acc = 0.0
        for s in range(6):
            acc += B[s] * F[s, q]
        k0 = h * F[0, q]
        fint[q] += (theta * k0 + c0 * (h * acc - k0) + c1 * (h * F[6, q] - k0) + c2 * (h * F2[1, q] - k0)
                    + c3 * (h * F2[2, q] - k0))
    fint[2] += theta * h * n_landed


@njit(cache=True)
def floor_impulse_step(h, F, n_landed, out):
    """out += int_0^h (F(t) + n_landed m g e_z) dt by the step's own quadrature,
    h sum_s b_s F_s (the weights of the 5th-order solution): the floor's continuous
    impulse on the airborne chain plus its support of the landed segments (at rest)."""
    for q in range(3):
        acc = 0.0
        for s in range(6):
            acc += B[s] * F[s, q]
        out[q] += h * acc
    out[2] += h * n_landed


@njit(cache=True)
def floor_impulse_dense(h, theta, F, n_landed, out):
    """out = int_0^(theta h) (F + n_landed m g e_z) dt from the continuous extension
    (the quadrature dense output gives for an extra state dJ/dt = F)."""
    b = np.empty(7)
    _dense_weights(h, theta, b)
    for q in range(3):
        acc = 0.0
        for s in range(7):
            acc += b[s] * F[s, q]
        out[q] = acc
    out[2] += theta * h * n_landed


@njit(cache=True)
def _nonfinite(Y):
    for a in range(2):
        for i in range(Y.shape[1]):
            for q in range(3):
                if not math.isfinite(Y[a, i, q]):
                    return True
    return False


@njit(cache=True)
def _dense_axes(Y0, K, b, out):
    """The axes e of the dense output (weights b from _dense_weights) into out."""
    for i in range(Y0.shape[1]):
        for q in range(3):
            out[i, q] = _dense_e(Y0, K, b, i, q)


@njit(cache=True, inline="always")
def _gap(e, k, cos_alpha):
    """g_k of unit-normalised axes."""
    d = 0.0
    na = 0.0
    nc = 0.0
    for q in range(3):
        d += e[k, q] * e[k + 1, q]
        na += e[k, q] * e[k, q]
        nc += e[k + 1, q] * e[k + 1, q]
    return d / math.sqrt(na * nc) - cos_alpha


@njit(cache=True)
def _zpoint(e, j):
    z = 0.0
    for i in range(j, e.shape[0]):
        z += 2.0 * e[i, 2]
    return z


@njit(cache=True)
def event_value(kind, idx, theta, Y0, K, h, cos_alpha, floor, anchored, locked, ws, Yt, dYt, lam):
    """Value of event function (kind, idx) at t0 + theta h on the dense output."""
    b = np.empty(7)
    _dense_weights(h, theta, b)
    if kind == EV_LOCK:
        acc = 0.0
        na = 0.0
        nc = 0.0
        for q in range(3):
            ea = _dense_e(Y0, K, b, idx, q)
            ec = _dense_e(Y0, K, b, idx + 1, q)
            acc += ea * ec
            na += ea * ea
            nc += ec * ec
        # normalise: the dense output is not exactly unit length
        return acc / math.sqrt(na * nc) - cos_alpha
    if kind == EV_LANDING:
        _dense_axes(Y0, K, b, Yt[0])
        return floor_value(floor, Yt[0], idx)
    if kind == EV_TOP:
        _dense_axes(Y0, K, b, Yt[0])
        return _zpoint(Yt[0], 0)
    # EV_UNLOCK: lambda_k at the interpolated state
    _dense(Y0, K, h, theta, Yt)
    _rhs(Yt, anchored, locked, ws, dYt)
    J, kind_, nrow, S, G, drop, rhs, x, gf = ws
    lock_multipliers(kind_, nrow, x, lam)
    return lam[idx]


@njit(cache=True)
def _brent(kind, idx, off, a, b, fa, fb, xtol, Y0, K, h, cos_alpha, floor, anchored, locked, ws, Yt, dYt,
           lam):
    """Root of f + off on [a, b] (theta units) with fa > 0 >= fb (the values of f + off
    there) by Brent's method; returns a theta at which f + off <= 0 (the crossing, to
    xtol)."""
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
        fb = event_value(kind, idx, b, Y0, K, h, cos_alpha, floor, anchored, locked, ws, Yt, dYt, lam) + off
    # return the end of the bracket on the far side of the crossing
    if fb <= 0.0:
        return b
    return c


@njit(cache=True)
def _locate(kd, ix, mode, ref, tha, fmid, fend, Y, K, h, xtol, cos_alpha, floor, anchored, locked, ws, Yt, dYt,
            lam):
    """Where in the step (theta in [0, 1]) event function (kd, ix) fires, or 2.0 if it
    does not (module docstring).  ``fmid``, ``fend``: its values at the midpoint and the
    end (fmid = inf: unknown); ``tha``: the predicted apex of a departing function, in
    theta units (outside (0, 1): none in this step)."""
    if mode == ARMED:
        f0 = event_value(kd, ix, 0.0, Y, K, h, cos_alpha, floor, anchored, locked, ws, Yt, dYt, lam)
        if f0 <= 0.0:
            return 0.0
        if fmid <= 0.0:
            return _brent(kd, ix, 0.0, 0.0, 0.5, f0, fmid, xtol, Y, K, h, cos_alpha, floor, anchored, locked,
                          ws, Yt, dYt, lam)
        if fend <= 0.0:
            if fmid == math.inf:
                return _brent(kd, ix, 0.0, 0.0, 1.0, f0, fend, xtol, Y, K, h, cos_alpha, floor, anchored, locked,
                              ws, Yt, dYt, lam)
            return _brent(kd, ix, 0.0, 0.5, 1.0, fmid, fend, xtol, Y, K, h, cos_alpha, floor, anchored, locked,
                          ws, Yt, dYt, lam)
        return 2.0
    # DEPARTING: it fires when it returns to zero after a sample above ZERO_BAND, or,
    # never having been there, when it sinks below ref - ZERO_BAND
    nscan = NSCAN if kd != EV_UNLOCK else 2  # lambda costs an evaluation per sample
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
            f = event_value(kd, ix, th, Y, K, h, cos_alpha, floor, anchored, locked, ws, Yt, dYt, lam)
        else:
            s += 1
            if th == 1.0:
                f = fend
            elif th == 0.5 and fmid != math.inf:
                f = fmid
            else:
                f = event_value(kd, ix, th, Y, K, h, cos_alpha, floor, anchored, locked, ws, Yt, dYt, lam)
        if f > ZERO_BAND:
            thp = th
            fp = f
        elif thp >= 0.0 and f <= 0.0:
            return _brent(kd, ix, 0.0, thp, th, fp, f, xtol, Y, K, h, cos_alpha, floor, anchored, locked, ws,
                          Yt, dYt, lam)
        elif f < ref - ZERO_BAND:
            sink = ZERO_BAND - ref
            if th == 0.0 or fq + sink <= 0.0:
                return thq
            return _brent(kd, ix, sink, thq, th, fq + sink, f + sink, xtol, Y, K, h, cos_alpha, floor, anchored,
                          locked, ws, Yt, dYt, lam)
        thq = th
        fq = f
    return 2.0


@njit(cache=True)
def _step_error(Y, Y1, K, h, rtol, atol):
    """Largest component error of the step, in units of its tolerance (max norm)."""
    n = Y.shape[1]
    err = 0.0
    for a in range(2):
        for i in range(n):
            for q in range(3):
                ev = 0.0
                for s in range(7):
                    ev += E[s] * K[s, a, i, q]
                sc = atol + rtol * max(abs(Y[a, i, q]), abs(Y1[a, i, q]))
                r = abs(ev * h) / sc
                if r > err or not math.isfinite(r):
                    err = r
    return err


@njit(cache=True)
def advance(Y, t, h, t_stop, alpha, floor, anchored, locked, lock_cos, anchor_pos,
            arm_lock, arm_land, arm_unlock, arm_top, ref_lock, ref_land, ref_unlock, ref_top, apex_lock, apex_land,
            rtol, atol, xtol, ws, K, K2, Y1, Ytmp, dYtmp, lam, lam1, F, F2, fint, fsal,
            frame_dt, frame_next, frame_cap, fr_t, fr_e, fr_w, fr_anch, fr_lock, fr_force, fr_kin, fr_pot, fr_count,
            fr_pull, fr_scale, fr_fimp,
            tr_t, tr_z, tr_count, ev_kind, ev_idx, ev_theta, pts, vel, counters, max_steps, stats):
    """Integrate from t until t_stop or the first event.

    Returns (code, t, h).  On ADV_EVENT, ``Y`` holds the state at the event time t,
    and ``ev_kind/ev_idx/ev_theta`` (``counters[2]`` rows) the triggered events with
    their located times (absolute; inf: not confirmed).  ``counters``: [0] steps,
    [1] evaluations, [2] events found.  ``stats[0]``: lowest point seen (max depth is
    -stats[0]).  ``arm_*``, ``ref_*``: how each event function is watched (module
    docstring).  ``F``, ``F2``: the anchors' force at the stages of K, K2; ``fint``
    (4,): the floor's continuous impulse so far (x, y, z, and its z part that holds
    up the landed segments), advanced by each step's quadrature (``floor_impulse_step``).
    Frames fill the buffers up to ``frame_cap``; a step with more frames than fit
    returns ADV_BUFFER before it is accepted (the caller empties the buffers and calls
    again: the step is redone from the same state and goes on where the frames stopped).
    ``fsal[0]`` = 1 on an ADV_BUFFER return: K[0], F[0] still hold f(Y) of the step
    in progress, and the next call starts from them (so buffer sizes change no number).
    """
    n = Y.shape[1]
    nh = n - 1
    cos_alpha = math.cos(alpha)
    fr_k = fr_count[0]
    tr_k = tr_count[0]
    fv_mid = np.empty(n + 1)
    fv_end = np.empty(n + 1)
    fpart = np.empty(3)
    # int64, not literal constants: a literal argument to a compiled callee compiles
    # it once more for that value (the whole callee tree again)
    kd_lock, kd_unlock, kd_landing = np.int64(EV_LOCK), np.int64(EV_UNLOCK), np.int64(EV_LANDING)
    kd_top, ix_top = np.int64(EV_TOP), np.int64(0)
    n_landed = np.int64(0)
    for i in range(n):
        if anchored[i] != 0 and anchored[i + 1] != 0:
            n_landed += 1
    # FSAL: derivative at the current state (kept across an ADV_BUFFER return)
    if fsal[0] == 0:
        _stage_rhs(Y, anchored, locked, ws, K[0], F[0])
        counters[1] += 1
    fsal[0] = 0
    reuse_factors(ws[3], np.bool_(False))  # the steps have new axes at every stage
    nfail = 0
    while True:
        if counters[0] >= max_steps:
            return ADV_MAX_STEPS, t, h
        if tr_k >= tr_t.shape[0] - 2:
            fr_count[0] = fr_k
            tr_count[0] = tr_k
            fsal[0] = 1
            return ADV_BUFFER, t, h
        if t >= t_stop:
            fr_count[0] = fr_k
            tr_count[0] = tr_k
            return ADV_STOP, t, h
        if h > t_stop - t:
            h = t_stop - t
        if h < 1e-14 * max(1.0, abs(t)):
            return ADV_FAIL_STEP, t, h
        # --- one Dormand-Prince step
        _rk_stages(Y, h, K, Ytmp, Y1, anchored, locked, ws, F)
        counters[1] += 6
        err = _step_error(Y, Y1, K, h, rtol, atol)
        if not math.isfinite(err) or _nonfinite(Y1):
            nfail += 1
            if nfail > 20:
                return ADV_FAIL_NAN, t, h
            h *= 0.1
            continue
        if err > 1.0:
            h *= max(0.2, 0.9 * err ** -0.2)
            continue
        nfail = 0
        J, kind_, nrow, S, G, drop, rhs, x, gf = ws
        lock_multipliers(kind_, nrow, x, lam1)  # lambda at Y1 (last stage)
        # --- event detection at the end and the midpoint of the step
        nev = 0
        _dense(Y, K, h, 0.5, Ytmp)  # midpoint state, for the midpoint checks
        for k in range(nh):
            if arm_lock[k] == OFF or locked[k]:
                continue
            fm = _gap(Ytmp[0], k, cos_alpha)
            fe = _gap(Y1[0], k, cos_alpha)
            if fm <= 0.0 or fe <= 0.0:
                ev_kind[nev] = EV_LOCK
                ev_idx[nev] = k
                ev_theta[nev] = _locate(kd_lock, k, arm_lock[k], ref_lock[k], (apex_lock[k] - t) / h, fm, fe, Y, K,
                                        h, xtol / h, cos_alpha, floor, anchored, locked, ws, Ytmp, dYtmp, lam)
                nev += 1
        for k in range(nh):
            if arm_unlock[k] == OFF or not locked[k]:
                continue
            if lam1[k] <= 0.0:
                ev_kind[nev] = EV_UNLOCK
                ev_idx[nev] = k
                ev_theta[nev] = _locate(kd_unlock, k, arm_unlock[k], ref_unlock[k], 2.0, math.inf, lam1[k], Y, K,
                                        h, xtol / h, cos_alpha, floor, anchored, locked, ws, Ytmp, dYtmp, lam)
                counters[1] += 2
                nev += 1
        if nev > 0:
            _dense(Y, K, h, 0.5, Ytmp)  # (the locating above used Ytmp)
        floor_values(floor, Ytmp[0], anchored, fv_mid)
        floor_values(floor, Y1[0], anchored, fv_end)
        for j in range(n + 1):
            if arm_land[j] == OFF:
                continue
            fm = fv_mid[j]
            fe = fv_end[j]
            if fm <= 0.0 or fe <= 0.0:
                ev_kind[nev] = EV_LANDING
                ev_idx[nev] = j
                ev_theta[nev] = _locate(kd_landing, j, arm_land[j], ref_land[j], (apex_land[j] - t) / h, fm, fe, Y,
                                        K, h, xtol / h, cos_alpha, floor, anchored, locked, ws, Ytmp, dYtmp, lam)
                nev += 1
                _dense(Y, K, h, 0.5, Ytmp)
        if arm_top[0] != OFF:
            fm = _zpoint(Ytmp[0], 0)
            fe = _zpoint(Y1[0], 0)
            if fm <= 0.0 or fe <= 0.0:
                ev_kind[nev] = EV_TOP
                ev_idx[nev] = 0
                ev_theta[nev] = _locate(kd_top, ix_top, arm_top[0], ref_top[0], 2.0, fm, fe, Y, K, h, xtol / h,
                                        cos_alpha, floor, anchored, locked, ws, Ytmp, dYtmp, lam)
                nev += 1
        theta_stop = 1.0
        for r in range(nev):
            if ev_theta[r] < theta_stop:
                theta_stop = ev_theta[r]
        counters[0] += 1
        fire = False
        for r in range(nev):
            if ev_theta[r] <= 1.0:
                fire = True
        # --- frames and trace up to the step end (or the event)
        t_end = t + theta_stop * h
        while frame_next[0] <= t_end + 1e-300:
            if fr_k >= frame_cap:  # buffers full: redo this step once they are emptied
                counters[0] -= 1
                fr_count[0] = fr_k
                tr_count[0] = tr_k
                fsal[0] = 1
                return ADV_BUFFER, t, h
            th = (frame_next[0] - t) / h
            _dense(Y, K, h, th, Ytmp)
            _record_frame(Ytmp, anchored, locked, ws, dYtmp, pts, vel, fr_k, frame_next[0],
                          fr_t, fr_e, fr_w, fr_anch, fr_lock, fr_force, fr_kin, fr_pot, fr_pull, fr_scale, n_landed)
            floor_impulse_dense(h, th, F, n_landed, fpart)
            for q in range(3):
                fr_fimp[fr_k, q] = fint[q] + fpart[q]
            counters[1] += 1
            fr_k += 1
            frame_next[0] += frame_dt
        if fire:
            # the state at the event time to the step's order (the 4th-order interpolant
            # is good enough to locate the event, not to restart from)
            if theta_stop < 1.0:
                if theta_stop > 0.0:
                    _event_state(Y, K, K2, F, F2, Y1, Ytmp, h, theta_stop, anchored, locked, ws, n_landed, fint)
                    counters[1] += 2
            else:
                floor_impulse_step(h, F, n_landed, fint)
                for a in range(2):
                    for i in range(n):
                        for q in range(3):
                            Y[a, i, q] = Y1[a, i, q]
            for r in range(nev):
                ev_theta[r] = t + ev_theta[r] * h if ev_theta[r] <= 1.0 else math.inf
            counters[2] = nev
            t = t_end
            tr_t[tr_k] = t
            tr_z[tr_k] = _zpoint(Y[0], 0)
            tr_k += 1
            fr_count[0] = fr_k
            tr_count[0] = tr_k
            return ADV_EVENT, t, h
        # accept the full step
        floor_impulse_step(h, F, n_landed, fint)
        for a in range(2):
            for i in range(n):
                for q in range(3):
                    Y[a, i, q] = Y1[a, i, q]
        t = t_end
        res = project_state(Y[0], Y[1], anchored, locked, lock_cos, anchor_pos, J, kind_, nrow, S, G, drop,
                            rhs, x, gf, pts, vel, PROJ_TOL, np.int64(3))
        if res > PROJ_TOL:
            _stage_rhs(Y, anchored, locked, ws, K[0], F[0])
            counters[1] += 1
        else:
            for a in range(2):
                for i in range(n):
                    for q in range(3):
                        K[0, a, i, q] = K[6, a, i, q]
            for q in range(3):
                F[0, q] = F[6, q]
        # departing functions that have left their zero are armed
        for k in range(nh):
            if arm_lock[k] == DEPARTING and not locked[k] and _gap(Y[0], k, cos_alpha) > ZERO_BAND:
                arm_lock[k] = ARMED
            if arm_unlock[k] == DEPARTING and locked[k] and lam1[k] > ZERO_BAND:
                arm_unlock[k] = ARMED
        floor_values(floor, Y[0], anchored, fv_end)
        for j in range(n + 1):
            if arm_land[j] == DEPARTING and fv_end[j] > ZERO_BAND:
                arm_land[j] = ARMED
        if arm_top[0] == DEPARTING and _zpoint(Y[0], 0) > ZERO_BAND:
            arm_top[0] = ARMED
        zlow = 0.0
        zacc = 0.0
        for j in range(n - 1, -1, -1):
            zacc += 2.0 * Y[0, j, 2]
            if zacc < zlow:
                zlow = zacc
        if zlow < stats[0]:
            stats[0] = zlow
        tr_t[tr_k] = t
        tr_z[tr_k] = _zpoint(Y[0], 0)
        tr_k += 1
        # next step size
        fac = 10.0 if err == 0.0 else min(10.0, max(0.2, 0.9 * err ** -0.2))
        h *= fac


@njit(cache=True)
def _record_frame(Yt, anchored, locked, ws, dYt, pts, vel, k, tf,
                  fr_t, fr_e, fr_w, fr_anch, fr_lock, fr_force, fr_kin, fr_pot, fr_pull, fr_scale, n_landed):
    """Frame k at time tf from the state Yt: the state, the anchors' force on the
    airborne chain, the pile's pull (``pile_pull``), the vertical force a scale under
    the floor reads (anchors' z force + the weight of the landed segments), energies."""
    n = Yt.shape[1]
    fr_t[k] = tf
    for i in range(n):
        for q in range(3):
            fr_e[k, i, q] = Yt[0, i, q]
            fr_w[k, i, q] = Yt[1, i, q]
    for j in range(n + 1):
        fr_anch[k, j] = anchored[j]
    for j in range(n - 1):
        fr_lock[k, j] = locked[j]
    _rhs(Yt, anchored, locked, ws, dYt)
    J, kind_, nrow, S, G, drop, rhs, x, gf = ws
    anchor_force_total(kind_, nrow, x, fr_force[k])
    pile_pull(anchored, kind_, nrow, x, fr_pull[k])
    fr_scale[k] = fr_force[k, 2] + n_landed
    fr_kin[k] = kinetic_energy(Yt[0], Yt[1], pts, vel)
    fr_pot[k] = potential_energy(Yt[0])
