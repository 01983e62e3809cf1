"""Viscous damping at the hinges (contacts.damping), against an independent derivation.

A planar two-segment chain standing on its anchored foot is a double inverted pendulum.
In its own angles phi_1 (the bottom segment from the vertical) and phi_2 (the top one),
with m = b = g = 1 (rods of length 2, moment of inertia 1/3 about the centre), Lagrange's
equations are written here from scratch:

    T = 1/2 (16/3 phi1'^2 + 4/3 phi2'^2 + 4 cos(phi1 - phi2) phi1' phi2'),
    U = 3 cos phi1 + cos phi2,   D = C/2 (phi2' - phi1')^2 (the hinge bends at phi2 - phi1),

and integrated by scipy to 1e-13: the model's run must follow them to 1e-8 until the top
reaches the floor, and its books must hold the dissipated energy C int (phi2' - phi1')^2 dt.
Linearised (M phi'' + D phi' + K phi = 0, M = [[16/3, 2], [2, 4/3]], K = -diag(3, 1),
D = C [[1, -1], [-1, 1]]) the motion grows at the largest root of det(M s^2 + D s + K) = 0,
which damping lowers: a closed form for the rate.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ballchain as bc
from ballchain.errors import ParameterError

C_TEST = 0.3


def _lagrange_rhs(c):
    def rhs(t, y):
        p1, p2, w1, w2 = y
        cs, sn = math.cos(p1 - p2), math.sin(p1 - p2)
        m = np.array([[16.0 / 3.0, 2.0 * cs], [2.0 * cs, 4.0 / 3.0]])
        # d/dt dT/dphi' - dT/dphi = -dU/dphi - dD/dphi'
        # dT/dphi1 = -2 sin(p1 - p2) w1 w2, dT/dphi2 = +2 sin(p1 - p2) w1 w2
        # d/dt (2 cos(p1 - p2)) = -2 sin(p1 - p2)(w1 - w2)
        rel = w2 - w1
        f1 = 3.0 * math.sin(p1) + 2.0 * sn * (w1 - w2) * w2 - 2.0 * sn * w1 * w2 + c * rel
        f2 = math.sin(p2) + 2.0 * sn * (w1 - w2) * w1 + 2.0 * sn * w1 * w2 - c * rel
        a1, a2 = np.linalg.solve(m, [f1, f2])
        return [w1, w2, a1, a2]

    return rhs


def _axes(p1, p2):
    """The model's axes, segment 0 the top: e = (sin phi, 0, cos phi)."""
    return np.array([[math.sin(p2), 0.0, math.cos(p2)], [math.sin(p1), 0.0, math.cos(p1)]])


def _reference(c, p1, p2, t_end):
    """Lagrange's solution and the energy it dissipated, C int (phi2' - phi1')^2 dt, as an extra state."""
    rhs = _lagrange_rhs(c)

    def full(t, y):
        d = rhs(t, y[:4])
        return [*d, c * (y[3] - y[2]) ** 2]

    return solve_ivp(
        full, (0.0, t_end), [p1, p2, 0.0, 0.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-15, dense_output=True
    )


@pytest.mark.parametrize("c", [0.0, C_TEST])
def test_two_segments_follow_lagranges_equations_and_book_the_loss(c):
    p1, p2 = 0.05, 0.12
    r = bc.simulate(segments=2, alpha=math.pi, initial=_axes(p1, p2), hinge_damping=c, until=0.9, frames_per_tff=50)
    ref = _reference(c, p1, p2, r.frame_t[-1])
    lost = 0.0
    for k, t in enumerate(r.frame_t):
        if np.any(r.frame_anchored[k, :2]):  # (up to the first touch of the floor)
            break
        y = ref.sol(t)
        np.testing.assert_allclose(r.frame_e[k], _axes(y[0], y[1]), atol=1e-8, rtol=0)
        # the rates: w = e x de/dt, here (0, phi', 0)
        np.testing.assert_allclose(r.frame_omega[k][:, 1], [y[3], y[2]], atol=1e-8, rtol=0)
        lost = y[4]
        assert abs(r.frame_lost_damping[k] - lost) < 1e-9
        # the books close frame by frame: nothing but the damping has acted yet
        books = r.frame_kinetic[k] + r.frame_potential[k] + r.frame_lost_damping[k]
        assert abs(books - r.energy["initial"]) < 1e-9
    assert k > 20 and (lost > 1e-3 if c else lost == 0.0)


def _stepper_errors(method, dt, c=C_TEST, p1=0.05, p2=0.12):
    """A stepper's largest errors against Lagrange's solution until the first touch of the
    floor: the axes, the energy booked as lost to damping, and the books' imbalance there."""
    r = bc.simulate(
        segments=2,
        alpha=math.pi,
        initial=_axes(p1, p2),
        hinge_damping=c,
        until=0.9,
        frames_per_tff=50,
        method=method,
        dt=dt,
    )
    ref = _reference(c, p1, p2, r.frame_t[-1])
    axes = lost = books = 0.0
    for k, t in enumerate(r.frame_t):
        if np.any(r.frame_anchored[k, :2]):
            break
        y = ref.sol(t)
        axes = max(axes, np.abs(r.frame_e[k] - _axes(y[0], y[1])).max())
        lost = max(lost, abs(r.frame_lost_damping[k] - y[4]))
        books = max(
            books, abs(r.frame_kinetic[k] + r.frame_potential[k] + r.frame_lost_damping[k] - r.energy["initial"])
        )
    assert k > 20
    return np.array([axes, lost, books])


@pytest.mark.parametrize(("method", "order"), [("rattle", 2), ("timestep", 1)])
def test_the_steppers_converge_to_lagranges_solution_at_their_order(method, order):
    """RATTLE (second order: the second half kick takes the rates 2 u_half - u) and the
    time-stepper (first order: an explicit kick) approach the same solution, the energy
    they book as lost to damping and their books' closure at their orders."""
    coarse, fine = _stepper_errors(method, 0.02), _stepper_errors(method, 0.01)
    ratio = coarse / fine
    assert np.all(ratio > 0.75 * 2**order) and np.all(ratio < 1.4 * 2**order), ratio
    assert fine[1] < (2e-6 if order == 2 else 1e-3), fine


def test_damping_lowers_the_linear_growth_rate_to_its_closed_form():
    """Near the upright state the motion grows at the largest root s of
    det(M s^2 + D s + K) = 0: started on that mode (angles and rates), the run's angles
    grow as exp(s t) while they stay small (to their square, relatively)."""
    m = np.array([[16.0 / 3.0, 2.0], [2.0, 4.0 / 3.0]])
    k = -np.diag([3.0, 1.0])
    rates = {}
    for c in (0.0, C_TEST):
        d = c * np.array([[1.0, -1.0], [-1.0, 1.0]])
        # the quartic det(M s^2 + D s + K), from its coefficients in s
        q = np.polysub(
            np.polymul([m[0, 0], d[0, 0], k[0, 0]], [m[1, 1], d[1, 1], k[1, 1]]),
            np.polymul([m[0, 1], d[0, 1], k[0, 1]], [m[0, 1], d[0, 1], k[0, 1]]),
        )
        s = max(np.roots(q).real)
        # its mode: (M s^2 + D s + K) v = 0
        a = m * s * s + d * s + k
        v = np.array([-a[0, 1], a[0, 0]])
        v *= 1e-5 / v[0]
        start = np.zeros((2, 6))
        start[:, :3] = _axes(v[0], v[1])
        start[:, 4] = [s * v[1], s * v[0]]  # w = (0, phi', 0), segment 0 the top
        r = bc.simulate(segments=2, alpha=math.pi, initial=start, hinge_damping=c, until=1.5, rtol=1e-12)
        t = np.asarray(r.frame_t)
        phi = np.arcsin(np.asarray(r.frame_e)[:, 1, 0])  # the bottom segment's angle
        small = np.abs(phi) < 1e-3  # (the neglected terms: phi^2 ~ 1e-6 of it)
        assert small.sum() > 30
        np.testing.assert_allclose(phi[small], v[0] * np.exp(s * t[small]), rtol=1e-5)
        rates[c] = s
    assert rates[C_TEST] < rates[0.0]


def test_the_books_close_on_a_whole_fall_with_damping():
    r = bc.simulate(segments=8, alpha=math.pi / 2, ic="random", seed=3, hinge_damping=0.05)
    e0 = r.energy["initial"]
    assert r.status == "landed"
    assert r.energy["lost_damping"] > 1e-3 * e0
    assert abs(r.energy["imbalance"]) < 1e-8 * e0
    lost = np.asarray(r.frame_lost_damping)
    assert np.all(np.diff(lost) >= -1e-14)  # power is removed, never given back


@pytest.mark.parametrize("method", ["rattle", "timestep"])
def test_a_steppers_books_close_on_a_whole_fall_with_damping(method):
    r = bc.simulate(segments=8, alpha=math.pi / 2, ic="random", seed=3, hinge_damping=0.05, method=method)
    e0 = r.energy["initial"]
    assert r.status == "landed"
    assert r.energy["lost_damping"] > 1e-3 * e0
    assert abs(r.energy["imbalance"]) < (1e-4 if method == "rattle" else 2e-2) * e0


def test_a_negative_or_infinite_damping_is_refused_with_its_reason():
    with pytest.raises(ParameterError, match="feed energy"):
        bc.simulate(segments=4, hinge_damping=-0.1)
    with pytest.raises(ParameterError, match="freeze every hinge"):
        bc.simulate(segments=4, hinge_damping=math.inf)
