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
functions; an armed hinge also where the cubic through its gap and rate at the step's
ends has an interior minimum, ``_closest_approach``: a dip through the limit that
begins and ends inside the step), or at 16 points and at its predicted apex (departing functions that were
triggered; the event handler predicts where a departing constraint that accelerates
back peaks, ``events.apex_times``, so that a return within one step is seen positive
first and located as a crossing).  The sinking level is measured from where the
function started (``ref_*``: min(f, 0) after the event), since an event leaves it only
within round-off of its zero.

The step error is the largest component error over the state (a max norm), so its
meaning does not change with N.

``advance`` is the loop over the steps: ``_why_stop`` (a reason to return first),
``_try_step`` (one step and its error), ``_detect_events`` (each kind of event function
in turn), ``_emit_frames`` (frames up to the step's end or the event), then
``_stop_at_event`` or ``_accept_step`` (projection, re-arming, the trace).  Its state
travels in named bundles: ``core.state`` (Model, Chain, Work, Books, Frames, Trace),
``watch.Watch`` and this module's buffers, ``Stepper``.
"""

from __future__ import annotations

import math
from collections import namedtuple
from fractions import Fraction as Fr

import numpy as np

from ...core.books import PROJECTED_IN_STEPS, lowest_point, mechanical_energy
from ...core.dynamics import (
    accelerations,
    anchor_force_total,
    kinetic_energy,
    lock_multipliers,
    pile_pull,
    potential_energy,
    project_state,
    projection_tol,
    reuse_factors,
)
from ...core.rules import ARMED, OFF, ZERO_BAND, hinge_gap, landed_or_landing, point_height
from ...floors.dispatch import floor_value, floor_values
from ...jit import njit
from .watch import EV_LANDING, EV_LOCK, EV_TOP, EV_UNLOCK, arm_departed

# Dormand-Prince 5(4) (Hairer's DOPRI5; the coefficients of scipy's RK45)
C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
A = np.array(
    [
        [0, 0, 0, 0, 0],
        [1 / 5, 0, 0, 0, 0],
        [3 / 40, 9 / 40, 0, 0, 0],
        [44 / 45, -56 / 15, 32 / 9, 0, 0],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
    ]
)
B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
E = np.array([-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
P = np.array(
    [
        [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
        [0, 0, 0, 0],
        [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
        [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
        [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
        [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
        [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
    ]
)


def _hermite_birkhoff_inverse(sa, sb):
    """Exact inverse of the 4 x 4 system for the coefficients a_2..a_5 of the quintic
    p(s) = y0 + s h f0 + sum_m a_m s^m with p(1) = y1, p'(1) = h f1, p'(sa) = h fa,
    p'(sb) = h fb (rows in that order)."""
    m = [
        [Fr(1)] * 4,
        [Fr(2), Fr(3), Fr(4), Fr(5)],
        [2 * sa, 3 * sa**2, 4 * sa**3, 5 * sa**4],
        [2 * sb, 3 * sb**2, 4 * sb**3, 5 * sb**4],
    ]
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

ADV_STOP, ADV_EVENT, ADV_BUFFER, ADV_FAIL_STEP, ADV_FAIL_NAN, ADV_MAX_STEPS = 0, 1, 2, 3, 4, 5
ADV_GO = -1  # (internal) no reason to return: take the step

NSCAN = 16  # samples per step for a triggered departing function


Found = namedtuple(
    "Found",
    [
        "kind",  # kind of each event found in the last step (watch.EV_*)
        "idx",  # its hinge or point
        "time",  # where in the step (theta in [0, 1]); after _stop_at_event: the absolute time, inf if not
        "n",  # (1,) int64: events found
    ],
)

# The integrator's buffers, in bundles by purpose (each step function receives only the
# bundles it uses):
Stages = namedtuple(
    "Stages",
    [
        "K",  # (7, 2, N, 3): the stages of the step (K[0] = f(Y), K[6] = f(Y1))
        "F",  # (7, 3): the anchors' total force at the stages of K
        "Y1",  # (2, N, 3): the step's 5th-order end
        "Ytmp",  # (2, N, 3): scratch state (stages, the midpoint, dense output)
        "dYtmp",  # (2, N, 3): scratch derivative
    ],
)
Hermite = namedtuple("Hermite", ["K2", "F2"])  # f and the anchors' force at the event-state quintic's nodes
Detect = namedtuple(
    "Detect",
    [
        "lam1",  # lock multipliers at the step's end
        "fv_mid",  # (N+1,): floor event functions at the step's midpoint
        "fv_end",  # (N+1,): and at its end
        "found",  # the events found in the last step (Found)
    ],
)
Scratch = namedtuple(
    "Scratch",
    [
        "lam",  # lock multipliers (scratch of event_value)
        "pair",  # (2, 3): the two axes of a hinge on the dense output
        "fpart",  # (3,): the floor's impulse from the step's start to a frame
        "pts",  # (N+1, 3): point positions or velocities
        "vel",  # (N, 3): centre velocities
    ],
)
Stepper = namedtuple(
    "Stepper",
    [
        "sg",  # Stages
        "hb",  # Hermite
        "det",  # Detect
        "scr",  # Scratch
        "fsal",  # (1,) int64: 1 when K[0], F[0] hold f(Y) of a step to redo (after ADV_BUFFER)
    ],
)

# What locating an event needs: the step's start Y and stages K (its dense output),
# scratch (Yt, dYt, lam, pair) and the constraint state (for the lock multipliers).
Dense = namedtuple("Dense", ["Y", "K", "Yt", "dYt", "lam", "pair", "anchored", "locked"])


def new_stepper(n: int) -> Stepper:
    """The integrator's buffers for an N-segment chain."""
    nh = max(n - 1, 1)
    m = 3 * n + 4
    found = Found(np.zeros(m, np.int64), np.zeros(m, np.int64), np.zeros(m), np.zeros(1, np.int64))
    sg = Stages(np.zeros((7, 2, n, 3)), np.zeros((7, 3)), np.zeros((2, n, 3)), np.zeros((2, n, 3)), np.zeros((2, n, 3)))
    hb = Hermite(np.zeros((7, 2, n, 3)), np.zeros((7, 3)))
    det = Detect(np.zeros(nh), np.zeros(n + 1), np.zeros(n + 1), found)
    scr = Scratch(np.zeros(nh), np.zeros((2, 3)), np.zeros(3), np.zeros((n + 1, 3)), np.zeros((n, 3)))
    return Stepper(sg, hb, det, scr, np.zeros(1, np.int64))


@njit(cache=True)
def _rhs(Y, anchored, locked, ws, dY):
    return accelerations(Y[0], Y[1], anchored, locked, ws, dY[0], dY[1])


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
    anchor_force_total(ws.kind, ws.nrow, ws.x, F)


@njit(cache=True)
def _rk_stages(Y, h, sg, anchored, locked, ws):
    """Stages 2..7 of a Dormand-Prince step of size h from Y (sg.K[0] = f(Y), sg.F[0]
    given); sg.Y1 = the 5th-order solution, sg.K[6] = f(Y1); sg.F[s] the anchors' force
    at stage s."""
    K, Ytmp, Y1, F = sg.K, sg.Ytmp, sg.Y1, sg.F
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
def _event_state(Y, sg, hb, h, theta, anchored, locked, ws, n_landed, fint):
    """Y <- the state at t0 + theta h of the step from Y (stages sg.K, sg.F; sg.Y1 its
    5th-order end, K[6] = f(Y1)), fint advanced to that time.  The quintic p(s), s in
    [0, 1], with p(0) = y0, p'(0) = h f0, p(1) = y1, p'(1) = h f(y1) and p'(s_r) = h
    f(y(s_r)) at the nodes s_r = 1/3, 2/3, y(s_r) from the 4th-order continuous
    extension: two evaluations (K2[1:3], F2[1:3]), against five for a new step to
    t0 + theta h, and a local error of the step's own order, O(h^6) (the data's errors
    enter times h), a few times the full step's (tests/test_event_state.py).
    With c = M^-T (theta^2 .. theta^5) (``HB_MINV``):
      p(theta) = y0 + theta h f0 + c0 (y1 - y0 - h f0) + c1 h (f1 - f0)
                 + c2 h (f(y(1/3)) - f0) + c3 h (f(y(2/3)) - f0).
    The floor's impulse, the integral of F (an extra state J' = F), the same way."""
    K, K2, F, F2, Y1, Ytmp = sg.K, hb.K2, sg.F, hb.F2, sg.Y1, sg.Ytmp
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
                Y[a, i, q] = (
                    y0
                    + theta * k0
                    + c0 * (Y1[a, i, q] - y0 - k0)
                    + c1 * (h * K[6, a, i, q] - k0)
                    + c2 * (h * K2[1, a, i, q] - k0)
                    + c3 * (h * K2[2, a, i, q] - k0)
                )
    for q in range(3):
        acc = 0.0
        for s in range(6):
            acc += B[s] * F[s, q]
        k0 = h * F[0, q]
        fint[q] += (
            theta * k0
            + c0 * (h * acc - k0)
            + c1 * (h * F[6, q] - k0)
            + c2 * (h * F2[1, q] - k0)
            + c3 * (h * F2[2, q] - k0)
        )
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
def _copy_state(dst, src):
    """dst[...] = src for (2, N, 3) states (an explicit loop: cheaper than a slice copy)."""
    for a in range(2):
        for i in range(src.shape[1]):
            for q in range(3):
                dst[a, i, q] = src[a, i, q]


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


@njit(cache=True)
def event_value(kind, idx, theta, h, model, dense, ws):
    """Value of event function (kind, idx) at t0 + theta h on the dense output of the
    step of size h from dense.Y (stages dense.K)."""
    Y0, K, Yt = dense.Y, dense.K, dense.Yt
    b = np.empty(7)
    _dense_weights(h, theta, b)
    if kind == EV_LOCK:
        pair = dense.pair  # the two axes of the hinge (hinge_gap normalises: the dense output is not unit length)
        for r in range(2):
            for q in range(3):
                pair[r, q] = _dense_e(Y0, K, b, idx + r, q)
        return hinge_gap(pair, 0, model.cos_alpha)
    if kind == EV_LANDING:
        _dense_axes(Y0, K, b, Yt[0])
        return floor_value(model.floor, Yt[0], idx)
    if kind == EV_TOP:
        _dense_axes(Y0, K, b, Yt[0])
        return point_height(Yt[0], 0)
    # EV_UNLOCK: lambda_k at the interpolated state
    _dense(Y0, K, h, theta, Yt)
    _rhs(Yt, dense.anchored, dense.locked, ws, dense.dYt)
    lock_multipliers(ws.kind, ws.nrow, ws.x, dense.lam)
    return dense.lam[idx]


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True)
def _locate(kd, ix, mode, ref, tha, fmid, fend, h, model, dense, ws):
    """Where in the step (theta in [0, 1]) event function (kd, ix) fires, or 2.0 if it
    does not (module docstring).  ``fmid``, ``fend``: its values at the midpoint and the
    end (fmid = inf: unknown); ``tha``: the predicted apex of a departing function, in
    theta units (outside (0, 1): none in this step)."""
    if mode == ARMED:
        return _locate_armed(kd, ix, tha, fmid, fend, h, model, dense, ws)
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


@njit(cache=True)
def _detect_kind(kd, nev, t, h, model, watch, dense, ws, sg, det):
    """The event functions of kind kd that fire in the step: each watched function is
    checked at the step's midpoint (sg.Ytmp) and end (sg.Y1) and located where it
    crossed (``_locate``); they are appended to det.found from row nev on.  Returns the
    new count."""
    found = det.found
    nh = dense.locked.shape[0]
    m = nh if kd == EV_LOCK or kd == EV_UNLOCK else (dense.anchored.shape[0] if kd == EV_LANDING else 1)
    if kd == EV_LANDING:
        floor_values(model.floor, sg.Ytmp[0], dense.anchored, det.fv_mid)
        floor_values(model.floor, sg.Y1[0], dense.anchored, det.fv_end)
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
                _dense(dense.Y, dense.K, h, 0.5, sg.Ytmp)  # (the locating used Ytmp)
    return nev


@njit(cache=True)
def _detect_events(t, h, model, watch, dense, ws, sg, det, n_evals):
    """Every event function that fires in the step, kind by kind (watch.EVENT_FUNCTIONS
    order), into det.found; returns (theta of the first, whether any fires)."""
    _dense(dense.Y, dense.K, h, 0.5, sg.Ytmp)  # midpoint state, for the midpoint checks
    nev = 0
    for kd in range(EV_LOCK, EV_TOP + 1):
        n0 = nev
        nev = _detect_kind(kd, nev, t, h, model, watch, dense, ws, sg, det)
        if kd == EV_UNLOCK:
            n_evals[0] += 2 * (nev - n0)
            if nev > 0:
                _dense(dense.Y, dense.K, h, 0.5, sg.Ytmp)  # (the locating may have used Ytmp)
    det.found.n[0] = nev
    theta_stop = 1.0
    fire = False
    for r in range(nev):
        theta_stop = min(theta_stop, det.found.time[r])
        fire = fire or det.found.time[r] <= 1.0
    return theta_stop, fire


@njit(cache=True)
def _record_frame(Yt, dYt, tf, n_landed, chain, ws, scr, frames):
    """Frame frames.count[0] at time tf from the state Yt: the state, the anchors' force
    on the airborne chain, the pile's pull (``pile_pull``), the vertical force a scale
    under the floor reads (anchors' z force + the weight of the landed segments),
    energies."""
    k = frames.count[0]
    n = Yt.shape[1]
    frames.t[k] = tf
    for i in range(n):
        for q in range(3):
            frames.e[k, i, q] = Yt[0, i, q]
            frames.omega[k, i, q] = Yt[1, i, q]
    for j in range(n + 1):
        frames.anchored[k, j] = chain.anchored[j]
    for j in range(n - 1):
        frames.locked[k, j] = chain.locked[j]
    _rhs(Yt, chain.anchored, chain.locked, ws, dYt)
    anchor_force_total(ws.kind, ws.nrow, ws.x, frames.floor_force[k])
    pile_pull(chain.anchored, ws.kind, ws.nrow, ws.x, frames.pile_pull[k])
    frames.scale_force[k] = frames.floor_force[k, 2] + n_landed
    frames.kinetic[k] = kinetic_energy(Yt[0], Yt[1], scr.pts, scr.vel)
    frames.potential[k] = potential_energy(Yt[0])


@njit(cache=True)
def _emit_frames(t, h, t_end, n_landed, chain, ws, sg, scr, floor_flow, n_evals, frames):
    """The frames due up to t_end, from the step's dense output; False if the buffers
    filled first (the caller returns ADV_BUFFER and redoes the step once they are
    emptied)."""
    cap = frames.t.shape[0]
    while frames.next[0] <= t_end + 1e-300:
        if frames.count[0] >= cap:
            return False
        th = (frames.next[0] - t) / h
        _dense(chain.Y, sg.K, h, th, sg.Ytmp)
        _record_frame(sg.Ytmp, sg.dYtmp, frames.next[0], n_landed, chain, ws, scr, frames)
        floor_impulse_dense(h, th, sg.F, n_landed, scr.fpart)
        for q in range(3):
            frames.floor_impulse[frames.count[0], q] = floor_flow[q] + scr.fpart[q]
        n_evals[0] += 1
        frames.count[0] += 1
        frames.next[0] += frames.dt
    return True


@njit(cache=True)
def _trace_point(trace, t, e):
    k = trace.count[0]
    trace.t[k] = t
    trace.z[k] = point_height(e, 0)
    trace.count[0] = k + 1


@njit(cache=True)
def _stop_at_event(t, h, theta_stop, n_landed, chain, ws, sg, hb, found, floor_flow, n_evals, trace):
    """End the step at its first event: the state at the event time to the step's order
    (the 4th-order interpolant is good enough to locate the event, not to restart
    from), the floor's impulse to that time, the found events' absolute times (inf: not
    confirmed in this step); returns the event time."""
    Y = chain.Y
    if theta_stop < 1.0:
        if theta_stop > 0.0:
            _event_state(Y, sg, hb, h, theta_stop, chain.anchored, chain.locked, ws, n_landed, floor_flow)
            n_evals[0] += 2
    else:
        floor_impulse_step(h, sg.F, n_landed, floor_flow)
        _copy_state(Y, sg.Y1)
    for r in range(found.n[0]):
        found.time[r] = t + found.time[r] * h if found.time[r] <= 1.0 else math.inf
    t_event = t + theta_stop * h
    _trace_point(trace, t_event, Y[0])
    return t_event


@njit(cache=True)
def _accept_step(t_end, h, n_landed, model, chain, watch, ws, sg, det, scr, books, trace):
    """Accept the full step: the state at its end, the floor's impulse, the projection
    onto the constraints (f(Y) recomputed if it moved the state, else the last stage
    reused), departing functions armed, the lowest point and the trace."""
    Y = chain.Y
    floor_impulse_step(h, sg.F, n_landed, books.floor_flow)
    _copy_state(Y, sg.Y1)
    before = mechanical_energy(Y[0], Y[1], scr.pts, scr.vel)
    tol = projection_tol(Y.shape[1])
    res, _ = project_state(chain, ws, scr.pts, scr.vel, tol, np.int64(3))
    books.projected[PROJECTED_IN_STEPS] += mechanical_energy(Y[0], Y[1], scr.pts, scr.vel) - before
    if res > tol:
        _stage_rhs(Y, chain.anchored, chain.locked, ws, sg.K[0], sg.F[0])
        books.n_evals[0] += 1
    else:
        _copy_state(sg.K[0], sg.K[6])
        for q in range(3):
            sg.F[0, q] = sg.F[6, q]
    arm_departed(model, chain, watch, det.lam1, det.fv_end)
    lowest_point(Y[0], books.lowest)
    _trace_point(trace, t_end, Y[0])


@njit(cache=True)
def _count_landed(anchored):
    """Segments whose both ends are anchored (the floor holds up their weight)."""
    n_landed = np.int64(0)
    for i in range(anchored.shape[0] - 1):
        if landed_or_landing(anchored, i):
            n_landed += 1
    return n_landed


@njit(cache=True)
def _why_stop(t, h, model, fsal, n_steps, trace):
    """A reason to return before the next step (ADV_*), or ADV_GO."""
    if n_steps[0] >= model.max_steps:
        return ADV_MAX_STEPS
    if trace.count[0] >= trace.t.shape[0] - 2:
        fsal[0] = 1
        return ADV_BUFFER
    if t >= model.t_stop:
        return ADV_STOP
    if min(h, model.t_stop - t) < 1e-14 * max(1.0, abs(t)):
        return ADV_FAIL_STEP
    return ADV_GO


@njit(cache=True)
def _try_step(h, model, chain, ws, sg, lam1, n_evals):
    """One Dormand-Prince step of size h (sg.Y1, sg.K, sg.F); returns its error in units
    of the tolerance (inf: non-finite) and the lock multipliers at its end (lam1)."""
    _rk_stages(chain.Y, h, sg, chain.anchored, chain.locked, ws)
    n_evals[0] += 6
    err = _step_error(chain.Y, sg.Y1, sg.K, h, model.rtol, model.rtol)
    if not math.isfinite(err) or _nonfinite(sg.Y1):
        return math.inf
    lock_multipliers(ws.kind, ws.nrow, ws.x, lam1)  # lambda at Y1 (last stage)
    return err


@njit(cache=True)
def advance(t, h, model, chain, watch, ws, st, books, frames, trace):
    """Integrate from t until model.t_stop or the first event.

    Returns (code, t, h).  On ADV_EVENT, chain.Y holds the state at the event time t,
    and st.det.found (its n[0] rows) the triggered events with their located times (absolute; inf: not confirmed).  books: steps, evaluations, the lowest
    point, the floor's continuous impulse (``floor_impulse_step``).  Frames fill the
    buffers; a step with more frames than fit returns ADV_BUFFER before it is accepted
    (the caller empties the buffers and calls again: the step is redone from the same
    state and goes on where the frames stopped); st.fsal[0] = 1 then: st.sg.K[0], st.sg.F[0]
    still hold f(Y) of the step in progress, and the next call starts from them (so
    buffer sizes change no number).
    """
    n_landed = _count_landed(chain.anchored)
    sg, hb, det, scr = st.sg, st.hb, st.det, st.scr
    dense = Dense(chain.Y, sg.K, sg.Ytmp, sg.dYtmp, scr.lam, scr.pair, chain.anchored, chain.locked)
    if st.fsal[0] == 0:  # FSAL: derivative at the current state (kept across an ADV_BUFFER return)
        _stage_rhs(chain.Y, chain.anchored, chain.locked, ws, sg.K[0], sg.F[0])
        books.n_evals[0] += 1
    st.fsal[0] = 0
    reuse_factors(ws.S, np.bool_(False))  # the steps have new axes at every stage
    nfail = 0
    while True:
        code = _why_stop(t, h, model, st.fsal, books.n_steps, trace)
        if code != ADV_GO:
            return code, t, h
        h = min(h, model.t_stop - t)
        err = _try_step(h, model, chain, ws, sg, det.lam1, books.n_evals)
        if err == math.inf:
            nfail += 1
            if nfail > 20:
                return ADV_FAIL_NAN, t, h
            h *= 0.1
            continue
        if err > 1.0:
            h *= max(0.2, 0.9 * err**-0.2)
            continue
        nfail = 0
        theta_stop, fire = _detect_events(t, h, model, watch, dense, ws, sg, det, books.n_evals)
        books.n_steps[0] += 1
        t_end = t + theta_stop * h
        if not _emit_frames(t, h, t_end, n_landed, chain, ws, sg, scr, books.floor_flow, books.n_evals, frames):
            books.n_steps[0] -= 1  # buffers full: redo this step once they are emptied
            st.fsal[0] = 1
            return ADV_BUFFER, t, h
        if fire:
            t_event = _stop_at_event(
                t, h, theta_stop, n_landed, chain, ws, sg, hb, det.found, books.floor_flow, books.n_evals, trace
            )
            return ADV_EVENT, t_event, h
        _accept_step(t_end, h, n_landed, model, chain, watch, ws, sg, det, scr, books, trace)
        t = t_end
        h *= 10.0 if err == 0.0 else min(10.0, max(0.2, 0.9 * err**-0.2))
