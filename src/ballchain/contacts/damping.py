"""Viscous damping at the hinges (``registry.LAWS["damping"]``), compiled: a smooth law,
the first that acts between impacts.

Hinge k joins segments k and k+1 and bends them by the angle theta_k,
cos theta_k = e_k . e_{k+1}.  A rod has no spin, so that angle is all a hinge can change:
turning the pair about either axis is a rigid motion.  The law is a viscous torque on it,
from the dissipation function D = C/2 sum_k thetadot_k^2:

    tau_k = C thetadot_k n_k,   tau_{k+1} = -C thetadot_k n_k,   n_k = e_k x e_{k+1} / sin theta_k,
    thetadot_k = -(w_k - w_{k+1}) . n_k,

that is, -C times the part of the relative angular velocity that bends the hinge (in a
planar motion, all of it).  It removes the power C sum_k thetadot_k^2 (booked as
``lost_damping``).  At a hinge held at its limit theta is constant and the torque vanishes;
at a straight hinge (sin theta < ``SIN_STRAIGHT``) the bend's rate has no direction and the
torque is taken as zero there.

In the axes' rates (RATTLE's coordinates, de/dt for w) the same law is the force
f_k = -C thetadot_k d theta / d e_k = C thetadot_k (e_{k+1} - cos theta e_k) / sin theta on
the axis e_k (``axis_forces``), with thetadot_k = -(de_k . e_{k+1} + e_k . de_{k+1}) / sin theta.

C is in units of m sqrt(g b^3) (a torque times a time); C = 0 leaves the hinges free.
"""

from __future__ import annotations

import math

from ..jit import njit

SIN_STRAIGHT = 1e-12  # a hinge this close to straight has no bending direction: no torque


@njit(cache=True, inline="always")
def damped(c):
    """The law acts (C > 0)."""
    return c > 0.0


@njit(cache=True, inline="always")
def _bend(e, k):
    """Hinge k's bend: the unit normal n = e_k x e_{k+1} / sin theta and sin theta."""
    nx = e[k, 1] * e[k + 1, 2] - e[k, 2] * e[k + 1, 1]
    ny = e[k, 2] * e[k + 1, 0] - e[k, 0] * e[k + 1, 2]
    nz = e[k, 0] * e[k + 1, 1] - e[k, 1] * e[k + 1, 0]
    s = math.sqrt(nx * nx + ny * ny + nz * nz)
    if s < SIN_STRAIGHT:
        return 0.0, 0.0, 0.0, s
    return nx / s, ny / s, nz / s, s


@njit(cache=True, _nrt=False)
def hinge_torques(c, e, w, tau):
    """tau <- the damping torques on the segments (N, 3), tau_k = C thetadot_k n_k and
    -C thetadot_k n_k on segment k+1 (w: the angular velocities); returns the power they
    remove, C sum_k thetadot_k^2 (m g b / sqrt(b/g))."""
    tau[:, :] = 0.0
    power = 0.0
    for k in range(e.shape[0] - 1):
        nx, ny, nz, s = _bend(e, k)
        if s < SIN_STRAIGHT:
            continue
        rate = -((w[k, 0] - w[k + 1, 0]) * nx + (w[k, 1] - w[k + 1, 1]) * ny + (w[k, 2] - w[k + 1, 2]) * nz)
        m = c * rate
        tau[k, 0] += m * nx
        tau[k, 1] += m * ny
        tau[k, 2] += m * nz
        tau[k + 1, 0] -= m * nx
        tau[k + 1, 1] -= m * ny
        tau[k + 1, 2] -= m * nz
        power += m * rate
    return power


@njit(cache=True, _nrt=False)
def axis_forces(c, e, de, f):
    """f <- the damping forces on the axes (N, 3) in the axes' rates de = de/dt,
    f_k = C thetadot_k (e_{k+1} - cos theta e_k) / sin theta and the same with k and k+1
    exchanged on e_{k+1}; returns the power they remove, C sum_k thetadot_k^2."""
    f[:, :] = 0.0
    power = 0.0
    for k in range(e.shape[0] - 1):
        s = _bend(e, k)[3]
        if s < SIN_STRAIGHT:
            continue
        cs = e[k, 0] * e[k + 1, 0] + e[k, 1] * e[k + 1, 1] + e[k, 2] * e[k + 1, 2]
        gdot = 0.0
        for q in range(3):
            gdot += de[k, q] * e[k + 1, q] + e[k, q] * de[k + 1, q]
        rate = -gdot / s
        m = c * rate / s
        for q in range(3):
            f[k, q] += m * (e[k + 1, q] - cs * e[k, q])
            f[k + 1, q] += m * (e[k, q] - cs * e[k + 1, q])
        power += c * rate * rate
    return power
