"""Where the chain is on a frictionless floor, numba kernels, nondimensional (m = b = g = 1).

The exact method's state is the axes and their rates; positions are summed from point N at
the origin and velocities taken with point N at rest (``kinematics.point_positions``,
``velocities``: the chain's shape relative to point N).  On a frictionless floor point N
moves, and where it is follows, without a new state to integrate, from what the law
conserves and what the floor holds:

* nothing acts along the floor, so the centre of mass moves uniformly along it,
  X(t) = X0 + V (t - t0), for the whole run;
* a point k the floor holds is at its height and moves along it: z_k = 0 and dz_k/dt = 0;
  with no point held the centre of mass falls freely from t0,
  Z(t) = Z0 + W0 (t - t0) - (t - t0)^2 / 2.

With c_i^rel, v_i^rel the centres' positions and velocities relative to point N, point
N's position p and velocity u are

    p_h = X(t) - mean_i c_i,h^rel,   u_h = V - mean_i v_i,h^rel,
    p_z = -z_k^rel, u_z = -dz_k^rel/dt (k held),  or  Z(t) - mean_i c_i,z^rel, W(t) - mean_i v_i,z^rel,

and every point and centre moves by p and u (``Base``: X0, Z0 in cm0, V, W0 in vcm0, t0).
"""

from __future__ import annotations

import numpy as np

from ..jit import njit
from .kinematics import point_positions, velocities
from .state import Base, new_base  # noqa: F401  (the bundle, allocated beside its kin)


@njit(cache=True, _nrt=False)
def held_point(anchored):
    """The largest index of a point the floor holds (any mark), -1 if none."""
    for j in range(anchored.shape[0] - 1, -1, -1):
        if anchored[j] != 0:
            return j
    return -1


@njit(cache=True, _nrt=False)
def floor_z(e, anchored, base, t):
    """The floor's height in the chain's frame (positions summed from point N at the
    origin): 0 while point N is held (always, but on a frictionless floor); the height of
    the held point of largest index while another holds the chain; in flight, -p_z(t),
    point N's height from the centre of mass's free fall (module docstring)."""
    n = e.shape[0]
    if anchored[n] != 0:
        return 0.0
    z = 0.0
    csum = 0.0  # sum of the centres' heights relative to point N
    for j in range(n - 1, -1, -1):
        csum += z + e[j, 2]
        z += 2.0 * e[j, 2]
        if anchored[j] != 0:
            return z
    s = t - base.t0[0]
    return csum / n - (base.cm0[2] + base.vcm0[2] * s - 0.5 * s * s)


@njit(cache=True, _nrt=False)
def floor_z_rates(e, w, de, dw, anchored, base, t):
    """The floor's vertical rate and acceleration in the chain's frame (``floor_z``'s), for
    the rates w, de = w x e and accelerations dw of the axes: 0, 0 while point N is held;
    a held point's relative ones; in flight the centre of mass's less the mean relative
    centre's (its acceleration -g)."""
    n = e.shape[0]
    if anchored[n] != 0:
        return 0.0, 0.0
    v, a = 0.0, 0.0  # point j's relative vertical rate and acceleration
    vs, as_ = 0.0, 0.0  # sums over the centres below
    for j in range(n - 1, -1, -1):
        dv = w[j, 0] * e[j, 1] - w[j, 1] * e[j, 0]  # (w x e)_z
        da = dw[j, 0] * e[j, 1] - dw[j, 1] * e[j, 0] + w[j, 0] * de[j, 1] - w[j, 1] * de[j, 0]
        vs += v + dv
        as_ += a + da
        v += 2.0 * dv
        a += 2.0 * da
        if anchored[j] != 0:
            return v, a
    s = t - base.t0[0]
    return vs / n - (base.vcm0[2] - s), as_ / n + 1.0


@njit(cache=True, _nrt=False)
def _centre_mean(e, vel, pts, out):
    """out[0] = mean_i c_i^rel, out[1] = mean_i v_i^rel (pts, vel: relative to point N)."""
    n = e.shape[0]
    for q in range(3):
        c, v = 0.0, 0.0
        for i in range(n):
            c += pts[i + 1, q] + e[i, q]
            v += vel[i, q]
        out[0, q] = c / n
        out[1, q] = v / n


@njit(cache=True, _nrt=True)
def base_point(e, w, anchored, base, t, pts, pv, vel, out):
    """out[0] = point N's position p, out[1] = its velocity u at time t (module docstring);
    pts, pv, vel leave holding the positions and velocities relative to point N.  Returns
    the held point that fixed the height (-1: the chain in flight)."""
    point_positions(e, pts)
    velocities(e, w, pv, vel)
    mean = np.empty((2, 3))
    _centre_mean(e, vel, pts, mean)
    s = t - base.t0[0]
    for q in range(2):
        out[0, q] = base.cm0[q] + base.vcm0[q] * s - mean[0, q]
        out[1, q] = base.vcm0[q] - mean[1, q]
    k = held_point(anchored)
    if k >= 0:
        out[0, 2] = -pts[k, 2]
        out[1, 2] = -pv[k, 2]
    else:
        out[0, 2] = base.cm0[2] + base.vcm0[2] * s - 0.5 * s * s - mean[0, 2]
        out[1, 2] = base.vcm0[2] - s - mean[1, 2]
    return k


@njit(cache=True, _nrt=True)
def set_base(e, w, anchored, base, t, pts, pv, vel, p, u):
    """base <- the centre of mass's position and velocity at t for point N at p moving at u
    (the start of a run, or the whole chain leaving the floor at t)."""
    point_positions(e, pts)
    velocities(e, w, pv, vel)
    mean = np.empty((2, 3))
    _centre_mean(e, vel, pts, mean)
    for q in range(3):
        base.cm0[q] = p[q] + mean[0, q]
        base.vcm0[q] = u[q] + mean[1, q]
    base.t0[0] = t
    base.flying[0] = 1 if held_point(anchored) < 0 else 0


@njit(cache=True, _nrt=False)
def energies_moved(e, w, pts, vel, pu, out):
    """out[0] = U, out[1] = T (m g b) of the chain whose point N is at pu[0] moving at pu[1],
    from its positions pts and centres' velocities vel relative to point N: sum_i (z_i^rel
    + p_z) and sum_i |v_i^rel + u|^2 / 2 + |w_i|^2 / 6."""
    u = 0.0
    tk = 0.0
    for i in range(e.shape[0]):
        u += pts[i + 1, 2] + e[i, 2] + pu[0, 2]
        for q in range(3):
            v = vel[i, q] + pu[1, q]
            tk += 0.5 * v * v + w[i, q] * w[i, q] / 6.0
    out[0] = u
    out[1] = tk


@njit(cache=True, _nrt=True)
def energy_on_floor(e, w, anchored, base, t, pts, pv, vel):
    """U + T of the chain whose point N is where ``base_point`` puts it (m g b)."""
    pu = np.empty((2, 3))
    base_point(e, w, anchored, base, t, pts, pv, vel, pu)
    out = np.empty(2)
    energies_moved(e, w, pts, vel, pu, out)
    return out[0] + out[1]
