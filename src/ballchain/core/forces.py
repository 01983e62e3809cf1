"""The smooth forces beside gravity, summed in one place (numba, nondimensional: m = b = g = 1).

Gravity, -m g e_z on every centre, has no torque about a centre and enters each method
where it moves the centres (the event method's row right-hand sides, ``rows``; the
steppers' kicks).  Every other smooth law adds torques on the segments here, with the
power they remove, and each method applies them in its own coordinates: the event method
through the rows (``torque_rhs``) and its angular accelerations, the time-stepper in its
free velocity, RATTLE in its half kicks (as forces on the axes).  A new smooth law is a
module of ``contacts`` and a term in ``smooth_torques`` and ``smooth_axis_forces``.
Today's one: viscous damping at the hinges (``contacts.damping``).
"""

from __future__ import annotations

from ..contacts.damping import axis_forces, damped, hinge_torques
from ..jit import njit
from .rows import ROW_ANCHOR_LOWER, ROW_ANCHOR_UPPER, ROW_HINGE, ROW_LOCK, W_W
from .rules import is_landed

# The smooth laws' constants are read from any bundle with their fields: ``state.Model``, or
# the event method's ``Work.laws`` (a ``state.SmoothLaws``), which carries them to its
# accelerations.


@njit(cache=True, inline="always")
def any_smooth_law(laws):
    """Some smooth law acts beside gravity (``laws``: a ``SmoothLaws`` or ``state.Model``)."""
    return damped(laws.damping)


@njit(cache=True, _nrt=False)
def smooth_torques(laws, e, w, anchored, tau):
    """tau <- the smooth laws' torques on the segments not landed (landed ones: zero;
    their rates are zero, so the power is what acts on the rest), w the angular
    velocities; returns the power the laws remove (m g b / sqrt(b/g))."""
    power = hinge_torques(laws.damping, e, w, tau)
    for i in range(e.shape[0]):
        if is_landed(anchored, i):
            for q in range(3):
                tau[i, q] = 0.0
    return power


@njit(cache=True, _nrt=False)
def smooth_axis_forces(laws, e, de, f):
    """f <- the same laws' forces on the axes in the axes' rates de = de/dt (maximal
    coordinates: the force f_i on e_i does what the torque e_i x f_i does); returns the
    power they remove.  The caller applies them to the segments not landed."""
    return axis_forces(laws.damping, e, de, f)


@njit(cache=True, _nrt=False)
def torque_rhs(e, tau, kind, nrow, rhs):
    """rhs -= J W f for applied torques tau on the segments (W = 3 on the rates): the rows'
    acceleration right-hand side with the torques applied (kinds as in ``rows``:
    hinge 3 (e_a x tau_a + e_c x tau_c), anchor lower 3 e_a x tau_a, anchor upper
    -3 e_c x tau_c, lock 3 (e_a x e_c) . (tau_a - tau_c); a = j - 1, c = j)."""
    n = e.shape[0]
    for j in range(n + 1):
        a = j - 1
        c = j
        for r in range(nrow[j]):
            k = kind[j, r]
            if k == ROW_LOCK:
                cx = e[a, 1] * e[c, 2] - e[a, 2] * e[c, 1]
                cy = e[a, 2] * e[c, 0] - e[a, 0] * e[c, 2]
                cz = e[a, 0] * e[c, 1] - e[a, 1] * e[c, 0]
                rhs[j, r] -= W_W * (
                    cx * (tau[a, 0] - tau[c, 0]) + cy * (tau[a, 1] - tau[c, 1]) + cz * (tau[a, 2] - tau[c, 2])
                )
                continue
            q = r % 3
            v = 0.0
            if (k == ROW_HINGE or k == ROW_ANCHOR_LOWER) and a >= 0:
                v += _cross_q(e, tau, a, q)
            if k == ROW_HINGE and c < n:
                v += _cross_q(e, tau, c, q)
            elif k == ROW_ANCHOR_UPPER and c < n:
                v -= _cross_q(e, tau, c, q)
            rhs[j, r] -= W_W * v


@njit(cache=True, inline="always")
def _cross_q(e, tau, i, q):
    """Component q of e_i x tau_i."""
    if q == 0:
        return e[i, 1] * tau[i, 2] - e[i, 2] * tau[i, 1]
    if q == 1:
        return e[i, 2] * tau[i, 0] - e[i, 0] * tau[i, 2]
    return e[i, 0] * tau[i, 1] - e[i, 1] * tau[i, 0]
