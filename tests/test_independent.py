"""An independent derivation of the chain's equations of motion, held against the fast
O(N) path (ballchain.core.dynamics) and, once it exists, the engine (ballchain.engine).

The reference is a Lagrangian in generalised coordinates, two spherical angles per rod,
with no constraints at all:

    e(th, ph) = (cos th, sin th cos ph, sin th sin ph)

(the pole is along x, so the nearly vertical chain is far from the coordinate
singularity).  Nondimensional m = b = g = 1, segment 0 at the top, the pivot (lower end
of the bottom segment) fixed at the origin.  Centres R_n = e_n + 2 sum_{k>n} e_k, i.e.
R = (C kron I3) E with C[n, n] = 1, C[n, k] = 2 (k > n); the kinetic energy

    T = sum 1/2 |dR_n/dt|^2 + 1/2 (1/3) |de_n/dt|^2 = 1/2 dE^T (A kron I3) dE,
    A = C^T C + I/3 (constant),

and U = sum_n z(R_n) = sum_n (2n + 1) e_n . e_z.  With E = E(q) and J = dE/dq, the
Euler-Lagrange equations read J^T [(A kron I3)(J qdd + Jdot qd) + grad_E U] = 0 (the
d/dt dT/dqd and dT/dq terms of Jdot cancel because d(J qd)/dq = Jdot), so

    (J^T Mbig J) qdd = -J^T (Mbig Jdot qd + grad_E U),

with Jdot qd from the analytic second derivatives of e(th, ph).  Nothing here shares
code or algebra with the hinge-force formulation of ballchain.core.dynamics.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from ballchain.core import dynamics as dyn
from ballchain.core.state import new_work
from ballchain.theory import pivot_rod_vertical_force, rod_fall_time

# ------------------------------------------------------------------ Lagrangian reference


def _angles_e(th, ph):
    st, ct, sp, cp = np.sin(th), np.cos(th), np.sin(ph), np.cos(ph)
    e = np.stack([ct, st * cp, st * sp], axis=-1)
    e_th = np.stack([-st, ct * cp, ct * sp], axis=-1)
    e_ph = np.stack([np.zeros_like(th), -st * sp, st * cp], axis=-1)
    e_thph = np.stack([np.zeros_like(th), -ct * sp, ct * cp], axis=-1)
    e_phph = np.stack([np.zeros_like(th), -st * cp, -st * sp], axis=-1)
    # e_thth = -e
    return e, e_th, e_ph, e_thph, e_phph


class Lagrangian:
    """The N-rod chain on a fixed pivot in spherical angles (pole along x)."""

    def __init__(self, n: int):
        self.n = n
        c = np.eye(n)
        for i in range(n):
            c[i, i + 1 :] = 2.0
        a = c.T @ c + np.eye(n) / 3.0
        self.mbig = np.kron(a, np.eye(3))
        self.grad_u = np.zeros(3 * n)
        self.grad_u[2::3] = 2.0 * np.arange(n) + 1.0  # U = sum (2i + 1) e_i.z (i = 0 top)

    def rhs(self, t, y):
        n = self.n
        th, ph = y[0 : 2 * n : 2], y[1 : 2 * n : 2]
        thd, phd = y[2 * n :: 2], y[2 * n + 1 :: 2]
        e, e_th, e_ph, e_thph, e_phph = _angles_e(th, ph)
        jac = np.zeros((3 * n, 2 * n))
        for i in range(n):
            jac[3 * i : 3 * i + 3, 2 * i] = e_th[i]
            jac[3 * i : 3 * i + 3, 2 * i + 1] = e_ph[i]
        jdot_qd = (-e * (thd**2)[:, None] + 2.0 * e_thph * (thd * phd)[:, None] + e_phph * (phd**2)[:, None]).reshape(
            -1
        )
        mq = jac.T @ self.mbig @ jac
        f = -jac.T @ (self.mbig @ jdot_qd + self.grad_u)
        qdd = np.linalg.solve(mq, f)
        return np.concatenate([y[2 * n :], qdd])

    # conversions between (q, qd) and the fast path's (e, w)
    def from_ew(self, e, w):
        n = self.n
        th = np.arccos(np.clip(e[:, 0], -1, 1))
        ph = np.arctan2(e[:, 2], e[:, 1])
        _, e_th, e_ph, _, _ = _angles_e(th, ph)
        edot = np.cross(w, e)
        q = np.empty(2 * n)
        qd = np.empty(2 * n)
        q[0::2], q[1::2] = th, ph
        for i in range(n):
            jac = np.stack([e_th[i], e_ph[i]], axis=1)
            sol, *_ = np.linalg.lstsq(jac, edot[i], rcond=None)
            qd[2 * i : 2 * i + 2] = sol
        return np.concatenate([q, qd])

    def to_ew(self, y):
        n = self.n
        th, ph = y[0 : 2 * n : 2], y[1 : 2 * n : 2]
        thd, phd = y[2 * n :: 2], y[2 * n + 1 :: 2]
        e, e_th, e_ph, _, _ = _angles_e(th, ph)
        edot = e_th * thd[:, None] + e_ph * phd[:, None]
        return e, np.cross(e, edot)  # w perpendicular to e: e x (w x e) = w

    def solve(self, e0, w0, times, rtol=1e-12, atol=1e-12):
        """e(t), w(t) at the given times (integrated exactly to each time, no interpolation)."""
        y = self.from_ew(e0, w0)
        t = 0.0
        es, ws, sin_min = [], [], 1.0
        for t1 in times:
            if t1 > t:
                sol = integrate.solve_ivp(self.rhs, (t, t1), y, method="DOP853", rtol=rtol, atol=atol)
                assert sol.success
                sin_min = min(sin_min, float(np.min(np.abs(np.sin(sol.y[0 : 2 * self.n : 2])))))
                y = sol.y[:, -1]
                t = t1
            e, w = self.to_ew(y)
            es.append(e)
            ws.append(w)
        return np.array(es), np.array(ws), sin_min


# ------------------------------------------------------------------ fast path driver


class FastPath:
    """A plain solve_ivp driver around ballchain.core.dynamics.accelerations: the chain free
    (no locks), the bottom point N anchored, no floor, no events."""

    def __init__(self, n: int):
        self.n = n
        self.ws = new_work(n)
        self.anchored = np.zeros(n + 1, np.uint8)
        self.anchored[n] = 1
        self.locked = np.zeros(max(n - 1, 0), np.uint8)
        self.de = np.zeros((n, 3))
        self.dw = np.zeros((n, 3))
        self.pts = np.zeros((n + 1, 3))
        self.force = np.zeros((n + 1, 3))

    def rhs(self, t, y):
        n = self.n
        e = np.ascontiguousarray(y[: 3 * n].reshape(n, 3))
        w = np.ascontiguousarray(y[3 * n :].reshape(n, 3))
        dyn.accelerations(e, w, self.anchored, self.locked, self.ws, self.de, self.dw)
        return np.concatenate([self.de.reshape(-1), self.dw.reshape(-1)])

    def pivot_force(self, e, w):
        """Force of the anchored pivot on the chain at state (e, w)."""
        self.rhs(0.0, np.concatenate([e.reshape(-1), w.reshape(-1)]))
        dyn.anchor_forces(self.ws.kind, self.ws.nrow, self.ws.x, self.force)
        return self.force[self.n].copy()

    def solve(self, e0, w0, times, rtol=1e-12, atol=1e-12):
        n = self.n
        y = np.concatenate([e0.reshape(-1), w0.reshape(-1)])
        t = 0.0
        es, ws = [], []
        for t1 in times:
            if t1 > t:
                sol = integrate.solve_ivp(self.rhs, (t, t1), y, method="DOP853", rtol=rtol, atol=atol)
                assert sol.success
                y = sol.y[:, -1]
                t = t1
            es.append(y[: 3 * n].reshape(n, 3).copy())
            ws.append(y[3 * n :].reshape(n, 3).copy())
        return np.array(es), np.array(ws)


# ------------------------------------------------------------------ energy, independent


def energy(e, w):
    """T + U of the chain on its pivot (nondimensional), from positions and velocities."""
    edot = np.cross(w, e)
    below = np.cumsum(2.0 * e[::-1], axis=0)[::-1]  # 2 sum_{k>=i} e_k
    below_d = np.cumsum(2.0 * edot[::-1], axis=0)[::-1]
    lower = np.vstack([below[1:], np.zeros((1, 3))])  # lower end of segment i
    lower_d = np.vstack([below_d[1:], np.zeros((1, 3))])
    centre = lower + e
    v = lower_d + edot
    kin = 0.5 * np.sum(v * v) + np.sum(edot * edot) / 6.0
    return kin + np.sum(centre[:, 2]), kin, np.sum(np.abs(centre[:, 2]))


# ------------------------------------------------------------------ initial states


def tilted_state(n, seed, tilt=0.3, spin=0.5):
    """Non-planar directions tilted by ~tilt from the vertical, w_i perpendicular to e_i
    of size ~spin (seeded)."""
    rng = np.random.default_rng(seed)
    a = tilt * (0.7 + 0.6 * rng.random(n))
    b = 2 * math.pi * rng.random(n)
    e = np.stack([np.sin(a) * np.cos(b), np.sin(a) * np.sin(b), np.cos(a)], axis=1)
    r = rng.standard_normal((n, 3))
    w = np.cross(e, r)
    w *= spin / np.linalg.norm(w, axis=1)[:, None]
    return e, w


def _state_n2():
    e0, w0 = tilted_state(2, seed=19)  # stays far from the x axis and above the floor to t = 2
    return e0, w0


def _heights(e):
    """z of points 0..N (point N the pivot)."""
    n = e.shape[0]
    z = np.zeros(n + 1)
    for j in range(n - 1, -1, -1):
        z[j] = z[j + 1] + 2.0 * e[j, 2]
    return z


TIMES = [0.1, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0]


# ------------------------------------------------------------------ tests: fast path


def test_lagrangian_matches_fast_path_n2():
    e0, w0 = _state_n2()
    lag = Lagrangian(2)
    e_ref, w_ref, sin_min = lag.solve(e0, w0, TIMES)
    assert sin_min > 0.5  # far from the coordinate pole along x
    # the reference reproduces its own initial state
    e_chk, w_chk = lag.to_ew(lag.from_ew(e0, w0))
    assert np.allclose(e_chk, e0, atol=1e-15) and np.allclose(w_chk, w0, atol=1e-14)
    e_fast, w_fast = FastPath(2).solve(e0, w0, TIMES)
    assert np.max(np.abs(e_fast - e_ref)) < 1e-9
    assert np.max(np.abs(w_fast - w_ref)) < 1e-8
    # something actually happened: the chain moved a lot, non-planar
    assert np.max(np.abs(e_ref[-1] - e0)) > 0.1


def test_lagrangian_matches_fast_path_n3():
    e0, w0 = tilted_state(3, seed=3, tilt=0.2, spin=0.4)
    times = [0.5, 1.0, 1.5]
    e_ref, w_ref, sin_min = Lagrangian(3).solve(e0, w0, times)
    assert sin_min > 0.5
    e_fast, w_fast = FastPath(3).solve(e0, w0, times)
    assert np.max(np.abs(e_fast - e_ref)) < 1e-9
    assert np.max(np.abs(w_fast - w_ref)) < 1e-8


@pytest.mark.parametrize("n,t_end", [(2, 2.0), (8, 2.0), (64, 2.0)])
def test_fast_path_energy(n, t_end):
    """Energy T + U is conserved along the free chain (alpha = pi, no events)."""
    e0, w0 = tilted_state(n, seed=n, tilt=0.05, spin=0.2)
    times = np.linspace(0.25, t_end, 8)
    es, ws = FastPath(n).solve(e0, w0, times)
    e_init, _, scale = energy(e0, w0)
    drift = max(abs(energy(e, w)[0] - e_init) for e, w in zip(es, ws))
    assert drift < 1e-10 * scale
    # it is a real motion (kinetic energy changed) and the chain stayed above the floor
    assert abs(energy(es[-1], ws[-1])[1] - energy(e0, w0)[1]) > 1e-3
    assert min(np.min(_heights(e)[:-1]) for e in es) > 0.0


def test_fast_path_rod_fall_time():
    """N = 1 through the fast path, top end reaching z = 0 located by an event."""
    theta0 = 0.1
    fp = FastPath(1)
    y0 = np.array([math.sin(theta0), 0.0, math.cos(theta0), 0.0, 0.0, 0.0])

    def top(t, y):
        return y[2]

    top.terminal = True
    top.direction = -1
    sol = integrate.solve_ivp(fp.rhs, (0, 20), y0, method="DOP853", rtol=1e-12, atol=1e-12, events=top)
    assert sol.t_events[0][0] == pytest.approx(rod_fall_time(theta0), rel=1e-10)


@pytest.mark.parametrize("theta0,s", [(0.0, 0.5), (0.1, 0.0), (math.pi / 4, 0.0), (0.4, 2.0), (1.0, 7.0)])
def test_fast_path_pivot_force(theta0, s):
    """The O(N) solver's anchor force on a single rod equals the (corrected) closed form
    F_z(theta) at states along the pivoting motion, for any azimuth of the plane."""
    fp = FastPath(1)
    for theta in np.linspace(theta0, math.pi / 2, 9):
        thd = math.sqrt(s + 1.5 * (math.cos(theta0) - math.cos(theta)))
        for az in (0.0, 1.1):
            u = np.array([math.cos(az), math.sin(az), 0.0])
            e = np.array([[math.sin(theta) * u[0], math.sin(theta) * u[1], math.cos(theta)]])
            w = thd * np.cross([[0.0, 0.0, 1.0]], u)  # w x e = thd de/dtheta
            f = fp.pivot_force(e, w)
            assert f[2] == pytest.approx(float(pivot_rod_vertical_force(theta, theta0, s)), abs=1e-12)


# ------------------------------------------------------------------ tests: engine


def test_engine_single_rod_landing():
    """N = 1 released at rest at theta0 = 0.1: t_fall is the rod's fall time, for both
    floor models (the rod lands when its top reaches the floor)."""
    from ballchain import engine
    from ballchain.model import ChainParams, SolverOptions

    theta0 = 0.1
    e0 = np.array([[math.sin(theta0), 0.0, math.cos(theta0)]])
    w0 = np.zeros((1, 3))
    expected = rod_fall_time(theta0)
    for floor in ("all", "pivot"):
        res = engine.simulate(
            ChainParams(segments=1, alpha=math.pi / 4, floor=floor),
            None,
            SolverOptions(rtol=1e-12),
            state=(e0.copy(), w0.copy()),
        )
        assert res.z0 == pytest.approx(2 * math.cos(theta0), rel=1e-14)
        assert res.t_ff == pytest.approx(math.sqrt(4 * math.cos(theta0)), rel=1e-14)
        assert res.t_fall == pytest.approx(expected, rel=1e-8), floor


def test_engine_single_rod_landing_si():
    """The same rod in SI units: t_fall in seconds = rod_fall_time(theta0, b, g)."""
    from ballchain import engine
    from ballchain.model import ChainParams, SolverOptions

    theta0, b, g = 0.1, 0.0016, 9.81
    e0 = np.array([[0.0, math.sin(theta0), math.cos(theta0)]])
    res = engine.simulate(
        ChainParams(segments=1, alpha=math.pi / 4, segment_mass=0.003, half_length=b, gravity=g),
        None,
        SolverOptions(rtol=1e-12),
        state=(e0, np.zeros((1, 3))),
    )
    assert res.t_fall == pytest.approx(rod_fall_time(theta0, b=b, g=g), rel=1e-8)


def test_engine_trajectory_matches_lagrangian_n2():
    """The engine's frames of a free (alpha = pi), non-planar, spinning N = 2 chain
    against the Lagrangian reference, over a short time with no event."""
    from ballchain import engine
    from ballchain.model import ChainParams, SolverOptions

    e0, w0 = _state_n2()
    T = 2.0
    z0 = 2.0 * float(np.sum(e0[:, 2]))
    t_ff = math.sqrt(2.0 * z0)
    res = engine.simulate(
        ChainParams(segments=2, alpha=math.pi, floor="all"),
        None,
        SolverOptions(rtol=1e-11, until=T / t_ff, frames_per_tff=40.0),
        state=(e0.copy(), w0.copy()),
    )
    assert res.t_ff == pytest.approx(t_ff, rel=1e-14)
    ft = np.asarray(res.frame_t)
    fe = np.asarray(res.frame_e)
    keep = ft <= T * (1 + 1e-12)
    assert np.count_nonzero(keep) >= 10
    assert ft[keep][-1] > 0.9 * T
    e_ref, w_ref, sin_min = Lagrangian(2).solve(e0, w0, ft[keep])
    assert sin_min > 0.5
    # no floor contact in this window: every point stays well above the floor
    assert min(np.min(_heights(e)[:-1]) for e in e_ref) > 0.5
    assert np.max(np.abs(fe[keep] - e_ref)) < 1e-8
    fw = np.asarray(res.frame_omega)
    assert np.max(np.abs(fw[keep] - w_ref)) < 1e-7
    assert len(res.event_t) == 0 or not np.any(np.asarray(res.event_t) <= T)
