"""Checks of ballchain.theory against independent numerical solutions (scipy only).

Each closed form is compared with a direct numerical integration of the equation of
motion it comes from, not with a re-use of the same algebra.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, special

from ballchain.theory import (
    free_fall_time,
    hamm_geminard_height_time,
    hamm_geminard_time_ratio,
    pivot_rod_angular_velocity,
    pivot_rod_impulse,
    pivot_rod_vertical_force,
    pivot_rod_vertical_force_as_printed,
    rod_fall_time,
)

# ------------------------------------------------------------------ helpers


def rod_ode(b, g):
    """A rod of length 2b pivoting about its lower end: thetaddot = (3 g / (4 b)) sin theta
    (torque m g b sin theta about the pivot, moment of inertia (4/3) m b^2)."""

    def rhs(t, y):
        return [y[1], 0.75 * g / b * math.sin(y[0])]

    return rhs


def rod_solve(theta0, thetadot0, b=1.0, g=1.0, t_eval=None):
    """Integrate the rod until it is horizontal; returns the solve_ivp solution."""

    def horizontal(t, y):
        return y[0] - 0.5 * math.pi

    horizontal.terminal = True
    horizontal.direction = 1
    return integrate.solve_ivp(
        rod_ode(b, g),
        (0.0, 1e3),
        [theta0, thetadot0],
        method="DOP853",
        rtol=1e-13,
        atol=1e-14,
        events=horizontal,
        dense_output=True,
        t_eval=t_eval,
    )


def rod_fall_time_elliptic(theta0, b=1.0, g=1.0):
    """The same time by the pendulum's elliptic integrals: phi = pi - theta is an ordinary
    pendulum (omega^2 = 3g/(4b)) of amplitude pi - theta0; the time from the turning
    point to phi = pi/2 is (K(k) - F(psi1, k)) / omega, k = sin((pi - theta0)/2),
    sin(pi/4) = k sin(psi1)."""
    omega = math.sqrt(0.75 * g / b)
    k2 = math.cos(0.5 * theta0) ** 2
    psi1 = math.asin(math.sin(0.25 * math.pi) / math.cos(0.5 * theta0))
    kk = special.ellipkm1(math.sin(0.5 * theta0) ** 2)  # K(k2), accurate for k2 -> 1
    return (kk - special.ellipkinc(psi1, k2)) / omega


# ------------------------------------------------------------------ free fall


def test_free_fall_time():
    assert free_fall_time(2.0) == pytest.approx(2.0, rel=1e-15)
    assert free_fall_time(4.9, g=9.8) == pytest.approx(1.0, rel=1e-15)
    with pytest.raises(ValueError):
        free_fall_time(-1.0)


# ------------------------------------------------------------------ rod fall time


@pytest.mark.parametrize("theta0", [1e-6, 1e-3, 0.05, 0.1, 0.3, 0.7, 1.2, 1.55])
def test_rod_fall_time_elliptic(theta0):
    t = rod_fall_time(theta0)
    assert t == pytest.approx(rod_fall_time_elliptic(theta0), rel=1e-12)


@pytest.mark.parametrize("theta0", [0.02, 0.1, 0.4, 1.0])
def test_rod_fall_time_ode(theta0):
    sol = rod_solve(theta0, 0.0)
    t_ode = sol.t_events[0][0]
    assert rod_fall_time(theta0) == pytest.approx(t_ode, rel=1e-10)


def test_rod_fall_time_units():
    """t scales as sqrt(b/g): an SI rod against its own ODE."""
    b, g = 0.0016, 9.81
    t_ode = rod_solve(0.1, 0.0, b=b, g=g).t_events[0][0]
    assert rod_fall_time(0.1, b=b, g=g) == pytest.approx(t_ode, rel=1e-10)
    assert rod_fall_time(0.1, b=b, g=g) == pytest.approx(rod_fall_time(0.1) * math.sqrt(b / g), rel=1e-14)


def test_rod_fall_time_limits():
    assert rod_fall_time(0.0) == math.inf
    with pytest.raises(ValueError):
        rod_fall_time(-0.1)
    with pytest.raises(ValueError):
        rod_fall_time(math.pi / 2)
    # from the upright, t ~ (1/omega) log(const / theta0): one more decade of theta0
    # adds log(10)/omega
    omega = math.sqrt(0.75)
    assert rod_fall_time(1e-7) - rod_fall_time(1e-6) == pytest.approx(math.log(10) / omega, rel=1e-6)


# ------------------------------------------------------------------ Hamm-Geminard


def test_hamm_geminard_values():
    assert hamm_geminard_time_ratio(1.0) == pytest.approx(1.0, rel=1e-14)
    # gamma = 0: B(2/3, 1/2) / (2 sqrt 3) = Gamma(2/3) Gamma(1/2) / (Gamma(7/6) 2 sqrt 3)
    g0 = math.gamma(2 / 3) * math.sqrt(math.pi) / math.gamma(7 / 6) / (2 * math.sqrt(3))
    assert hamm_geminard_time_ratio(0.0) == pytest.approx(g0, rel=1e-14)
    assert hamm_geminard_time_ratio(0.0) == pytest.approx(0.747, abs=5e-4)
    # monotonic between the two: the paper's 0.74 <= t_gamma/t_ff <= 1
    gs = np.linspace(0, 1, 21)
    r = [hamm_geminard_time_ratio(x) for x in gs]
    assert np.all(np.diff(r) > 0)
    with pytest.raises(ValueError):
        hamm_geminard_time_ratio(1.5)


@pytest.mark.parametrize("gamma", [0.0, 0.4, 0.83, 1.0, 1.2])
def test_hamm_geminard_quadrature(gamma):
    """The Beta-function form against the defining integral
    t / t_ff = (sqrt(c)/2) int_0^1 dx / sqrt(x^(2 gamma - 2) - x), c = 3 - 2 gamma."""
    c = 3 - 2 * gamma

    # substitute x = 1 - v^2 to remove the 1/sqrt singularity at x = 1
    def f(v):
        x = 1.0 - v * v
        # x^(2g-2) - x = x^(2g-2) (1 - x^c); 1 - x^c = -expm1(c log x)
        return 2 * v * x ** (1 - gamma) / math.sqrt(-math.expm1(c * math.log(x))) if v > 0 else 2 / math.sqrt(c)

    val, _ = integrate.quad(f, 0.0, 1.0, epsabs=0, epsrel=1e-13, limit=200)
    assert hamm_geminard_time_ratio(gamma) == pytest.approx(0.5 * math.sqrt(c) * val, rel=1e-11)


@pytest.mark.parametrize("gamma", [0.0, 0.5, 0.83, 1.0])
def test_hamm_geminard_ode(gamma):
    """The Hamm-Geminard momentum equation d/dt(mu z zdot) = -mu g z + gamma mu zdot^2,
    integrated in the momentum form (state z, p = z zdot; mu cancels), released at rest
    from z0; times to reach x z0 against the incomplete-Beta closed form, then the
    limit x -> 0 against t_gamma (the ODE is singular at z = 0)."""
    z0, g = 3.7, 2.3
    t_ff = math.sqrt(2 * z0 / g)
    xs = [0.9, 0.5, 0.1, 1e-2, 1e-4]

    def rhs(t, y):
        z, p = y
        v = p / z
        return [v, -g * z + gamma * v * v]

    events = []
    for x in xs:

        def ev(t, y, x=x):
            return y[0] - x * z0

        ev.direction = -1
        events.append(ev)
    events[-1].terminal = True
    sol = integrate.solve_ivp(rhs, (0, 10 * t_ff), [z0, 0.0], method="DOP853", rtol=1e-13, atol=1e-13, events=events)
    for x, te in zip(xs, sol.t_events):
        assert te.size == 1
        assert hamm_geminard_height_time(x, gamma) == pytest.approx(te[0] / t_ff, rel=1e-9)
    # what is left from 1e-4 z0 to 0 is small: the full time is bounded by the ODE's
    assert hamm_geminard_height_time(0.0, gamma) == pytest.approx(hamm_geminard_time_ratio(gamma), rel=1e-14)
    rest = hamm_geminard_time_ratio(gamma) - sol.t_events[-1][0] / t_ff
    assert 0 < rest < 1e-2


# ------------------------------------------------------------------ pivoting rod: force


@pytest.mark.parametrize("theta0,s", [(0.0, 0.3), (0.1, 0.0), (0.3, 0.7), (math.pi / 4, 0.0), (0.5, 4.0), (1.2, 0.05)])
def test_pivot_force_newton(theta0, s):
    """F_z = m d2z_c/dt2 + m g along an ODE solution (mass and gravity not 1), with the
    centre's acceleration from the ODE state (theta, thetadot, thetaddot), not from
    the energy integral that the closed form uses."""
    m, b, g = 0.37, 0.8, 2.5
    thetadot0 = math.sqrt(s * g / b)
    sol = rod_solve(theta0, thetadot0, b=b, g=g)
    T = sol.t_events[0][0]
    ts = np.linspace(0, T, 41)
    th, thd = sol.sol(ts)
    thdd = 0.75 * g / b * np.sin(th)
    zdd = -b * (np.sin(th) * thdd + np.cos(th) * thd**2)  # z_c = b cos theta
    fz_newton = m * zdd + m * g
    fz = pivot_rod_vertical_force(th, theta0, s, m=m, g=g)
    assert np.max(np.abs(fz - fz_newton)) < 1e-10 * m * g
    # and the angular velocity from energy
    assert np.allclose(pivot_rod_angular_velocity(th, theta0, s, b=b, g=g), thd, rtol=1e-10, atol=1e-12)


def test_pivot_force_finite_difference():
    """The same with d2z_c/dt2 from finite differences of z_c(t) = b cos theta(t) on the
    ODE's dense output (no derivative formula at all)."""
    theta0, s = 0.4, 0.6
    thetadot0 = math.sqrt(s)
    sol = rod_solve(theta0, thetadot0)
    T = sol.t_events[0][0]
    h = 1e-3
    for t in np.linspace(0.1 * T, 0.9 * T, 9):
        z = [math.cos(sol.sol(t + k * h)[0]) for k in (-2, -1, 0, 1, 2)]
        zdd = (-z[0] + 16 * z[1] - 30 * z[2] + 16 * z[3] - z[4]) / (12 * h * h)
        th = sol.sol(t)[0]
        assert pivot_rod_vertical_force(th, theta0, s) == pytest.approx(zdd + 1.0, abs=1e-7)


def test_pivot_force_special_values():
    # released from rest: the centre accelerates tangentially only
    for th0 in (0.1, 0.5, math.pi / 4, 1.3):
        assert pivot_rod_vertical_force(th0, th0, 0.0) == pytest.approx(1 - 0.75 * math.sin(th0) ** 2, rel=1e-14)
    # from the upright: the textbook (m g / 4)(1 - 3 cos theta)^2
    th = np.linspace(0, math.pi / 2, 7)
    assert np.allclose(pivot_rod_vertical_force(th, 0.0, 0.0), 0.25 * (1 - 3 * np.cos(th)) ** 2, rtol=1e-14)
    # horizontal: the centre moves on a circle, purely horizontal centripetal; F_z = m g/4
    assert pivot_rod_vertical_force(math.pi / 2, 0.7, 2.0) == pytest.approx(0.25, rel=1e-12)


def test_paper_formula_has_sign_error():
    """The printed formula (-6 (1 - cos theta0) cos theta) agrees with the physics only
    at theta0 = 0; at release from theta0 = pi/4 it gives ~0.015 m g instead of 0.625 m g."""
    th = np.linspace(0, math.pi / 2, 9)
    assert np.allclose(pivot_rod_vertical_force_as_printed(th, 0.0, 0.8), pivot_rod_vertical_force(th, 0.0, 0.8))
    th0 = math.pi / 4
    printed = pivot_rod_vertical_force_as_printed(th0, th0, 0.0)
    assert printed == pytest.approx(0.25 * (1 - 12 * math.cos(th0) + 15 * math.cos(th0) ** 2), rel=1e-12)
    assert abs(printed - 0.625) > 0.6
    # the printed formula differs by 3 (m g)(1 - cos theta0) cos theta
    d = pivot_rod_vertical_force(th, 0.3, 1.0) - pivot_rod_vertical_force_as_printed(th, 0.3, 1.0)
    assert np.allclose(d, 3 * (1 - math.cos(0.3)) * np.cos(th), rtol=1e-13, atol=1e-15)


# ------------------------------------------------------------------ pivoting rod: impulse


@pytest.mark.parametrize("theta0,s", [(0.1, 0.0), (0.3, 0.0), (0.0, 0.5), (0.2, 1.0), (0.6, 3.0), (1.0, 10.0)])
def test_pivot_impulse_momentum(theta0, s):
    """Delta p = m (zdot_c(end) - zdot_c(start)) + m g T (momentum theorem), with T and the
    velocities from the ODE (m, b, g not 1)."""
    m, b, g = 1.7, 0.3, 9.81
    thetadot0 = math.sqrt(s * g / b)
    sol = rod_solve(theta0, thetadot0, b=b, g=g)
    T = sol.t_events[0][0]
    th1, thd1 = sol.y_events[0][0]
    zd0 = -b * math.sin(theta0) * thetadot0
    zd1 = -b * math.sin(th1) * thd1
    dp = m * (zd1 - zd0) + m * g * T
    assert pivot_rod_impulse(theta0, s, m=m, b=b, g=g) == pytest.approx(dp, rel=1e-9, abs=1e-11 * m * math.sqrt(g * b))


def test_pivot_impulse_ode_quadrature():
    """Delta p as int F_z dt along the ODE (augmented state), nondimensional."""
    theta0, s = 0.25, 0.4

    def rhs(t, y):
        th, thd, _ = y
        return [thd, 0.75 * math.sin(th), float(pivot_rod_vertical_force(th, theta0, s))]

    def horizontal(t, y):
        return y[0] - 0.5 * math.pi

    horizontal.terminal = True
    sol = integrate.solve_ivp(
        rhs, (0, 100), [theta0, math.sqrt(s), 0.0], method="DOP853", rtol=1e-13, atol=1e-14, events=horizontal
    )
    assert pivot_rod_impulse(theta0, s) == pytest.approx(sol.y_events[0][0][2], rel=1e-10)


def test_pivot_impulse_sign():
    """Positive from rest; negative for large enough s at any theta0 (the paper's claim)."""
    for th0 in (0.05, 0.3, 0.8, 1.3):
        assert pivot_rod_impulse(th0, 0.0) > 0
        assert pivot_rod_impulse(th0, 50.0) < 0
    assert pivot_rod_impulse(0.0, 0.0) == math.inf
    with pytest.raises(ValueError):
        pivot_rod_impulse(0.1, -1.0)


# ------------------------------------------------------- inverse, horizontal force, s*
def _rod_ode(theta0, s, t_end=None):
    """The rod by solve_ivp from Newton's law about the pivot (no closed form used):
    thetaddot = (3 g / 4 b) sin theta, b = g = m = 1; returns the solution up to the
    horizontal (event)."""
    from scipy.integrate import solve_ivp

    horizontal = lambda t, y: y[0] - math.pi / 2  # noqa: E731
    horizontal.terminal = True
    return solve_ivp(
        lambda t, y: [y[1], 0.75 * math.sin(y[0])],
        (0.0, 1e3),
        [theta0, math.sqrt(s)],
        events=horizontal,
        rtol=1e-12,
        atol=1e-13,
        dense_output=True,
    )


@pytest.mark.parametrize("gamma", [-3.0, -0.5, 0.0, 0.3, 0.8, 1.0, 1.3, 1.49])
def test_gamma_from_time_ratio_round_trip(gamma):
    from ballchain.theory import gamma_from_time_ratio

    assert gamma_from_time_ratio(hamm_geminard_time_ratio(gamma)) == pytest.approx(gamma, abs=1e-9)


def test_gamma_from_time_ratio_limits_and_errors():
    from ballchain.theory import gamma_from_time_ratio

    assert gamma_from_time_ratio(1.0) == pytest.approx(1.0, abs=1e-12)
    assert gamma_from_time_ratio(hamm_geminard_time_ratio(0.0)) == pytest.approx(0.0, abs=1e-12)
    for bad in (0.0, -0.1, math.sqrt(math.pi / 2), 2.0, math.nan):
        with pytest.raises(ValueError):
            gamma_from_time_ratio(bad)


@pytest.mark.parametrize("theta0, s", [(0.3, 0.0), (0.8, 0.4), (0.05, 1.2)])
def test_horizontal_force_is_m_times_the_centre_acceleration(theta0, s):
    """F_x = m d2x_c/dt2 along an ODE solution, x_c = b sin theta, differentiated
    numerically from the dense solution (independent of the closed form)."""
    from ballchain.theory import pivot_rod_horizontal_force

    sol = _rod_ode(theta0, s)
    T = sol.t_events[0][0]
    t = np.linspace(0.05 * T, 0.95 * T, 9)
    h = 1e-4 * T
    xc = lambda tt: np.sin(sol.sol(tt)[0])  # noqa: E731
    ax = (xc(t + h) - 2 * xc(t) + xc(t - h)) / h**2
    np.testing.assert_allclose(pivot_rod_horizontal_force(sol.sol(t)[0], theta0, s), ax, atol=1e-5)


@pytest.mark.parametrize("theta0", [0.0, 0.2, 0.7, 1.2])
def test_critical_s_is_where_the_momentum_balance_changes_sign(theta0):
    """At s* the pivot's vertical impulse m (zdot_c(end) - zdot_c(0)) + m g T, from the ODE
    alone, vanishes; below s* it is positive, above negative."""
    from ballchain.theory import pivot_rod_critical_s

    s_star = pivot_rod_critical_s(theta0)

    def impulse(s):
        sol = _rod_ode(theta0, s)
        T = sol.t_events[0][0]
        th, thd = sol.y_events[0][0]
        zdot = lambda th_, thd_: -math.sin(th_) * thd_  # noqa: E731
        return zdot(th, thd) - zdot(theta0, math.sqrt(s)) + T

    assert abs(impulse(s_star)) < 1e-8
    assert impulse(0.9 * s_star) > 0 > impulse(1.1 * s_star)


# ------------------------------------------- a rod on the floor: the constrained body


def constrained_rod(held_x: bool, b=1.0, g=1.0, m=1.0):
    """The rod as a free body in the plane, q = (x_c, z_c, phi) (phi from the upward
    vertical, leaning to +x), M = diag(m, m, m b^2 / 3), its lower end held on z = 0
    (and, with ``held_x``, at x = 0) by multipliers: M qdd = f + G^T lam,
    G qdd = -(dG/dt) qd.  Returns rhs(t, y) and forces(y) -> (F_x, F_z) at the foot.
    The foot is at (x_c - b sin phi, z_c - b cos phi)."""
    mass = np.diag([m, m, m * b * b / 3.0])

    def solve(y):
        x, z, ph, vx, vz, w = y
        s, c = math.sin(ph), math.cos(ph)
        rows = [[0.0, 1.0, b * s]]  # d/dq (z_c - b cos phi)
        bias = [b * c * w * w]  # (dG/dt) qd
        if held_x:
            rows.append([1.0, 0.0, -b * c])  # d/dq (x_c - b sin phi)
            bias.append(b * s * w * w)
        gm = np.array(rows)
        k = len(rows)
        a = np.zeros((3 + k, 3 + k))
        a[:3, :3] = mass
        a[:3, 3:] = -gm.T
        a[3:, :3] = gm
        rhs = np.concatenate([[0.0, -m * g, 0.0], -np.array(bias)])
        sol = np.linalg.solve(a, rhs)
        return sol[:3], sol[3:]

    def rhs(t, y):
        acc, _ = solve(y)
        return [y[3], y[4], y[5], *acc]

    def forces(y):
        _, lam = solve(y)
        return (lam[1] if held_x else 0.0), lam[0]

    return rhs, forces


def rod_start(theta0, b=1.0):
    return [b * math.sin(theta0), b * math.cos(theta0), theta0, 0.0, 0.0, 0.0]


def flat(t, y):
    return y[2] - 0.5 * math.pi


flat.terminal = True


@pytest.mark.parametrize("theta0", [0.05, math.radians(20), math.pi / 4, 1.2])
def test_a_rod_on_a_frictionless_floor_falls_when_the_quadrature_says(theta0):
    from ballchain.theory import sliding_rod_fall_time

    rhs, _ = constrained_rod(held_x=False)
    sol = integrate.solve_ivp(rhs, (0, 100), rod_start(theta0), rtol=1e-12, atol=1e-13, events=flat, method="DOP853")
    assert sol.t_events[0].size == 1
    assert sliding_rod_fall_time(theta0) == pytest.approx(sol.t_events[0][0], rel=1e-8)
    xc = sol.y[0]
    assert np.ptp(xc) < 1e-9  # its centre falls on a vertical line
    # and 2^2 in time for a floor of 4 g (the scaling with b and g)
    assert sliding_rod_fall_time(theta0, b=2.0, g=4.0) == pytest.approx(sliding_rod_fall_time(theta0) / math.sqrt(2.0))


@pytest.mark.parametrize("theta0", [math.radians(20), 1.0])
def test_the_frictionless_floor_pushes_what_the_closed_form_says_and_never_pulls(theta0):
    from ballchain.theory import sliding_rod_angular_velocity, sliding_rod_normal_force

    rhs, forces = constrained_rod(held_x=False)
    sol = integrate.solve_ivp(
        rhs, (0, 100), rod_start(theta0), rtol=1e-12, atol=1e-13, events=flat, method="DOP853", dense_output=True
    )
    for t in np.linspace(0.0, sol.t_events[0][0], 9)[1:-1]:
        y = sol.sol(t)
        n_z = forces(y)[1]
        assert sliding_rod_normal_force(y[2], theta0) == pytest.approx(n_z, rel=1e-7, abs=1e-9)
        assert sliding_rod_angular_velocity(y[2], theta0) == pytest.approx(y[5], rel=1e-7)
    th = np.linspace(theta0, 0.5 * math.pi, 2001)
    assert np.all(sliding_rod_normal_force(th, theta0) > 0.0)  # the foot stays on the floor
    assert sliding_rod_normal_force(0.5 * math.pi, theta0) == pytest.approx(0.25, abs=1e-15)


@pytest.mark.parametrize("theta0", [math.radians(10), math.radians(30), 1.0])
def test_the_pivoting_rods_friction_ratio_and_where_it_reaches_mu(theta0):
    from ballchain.theory import pivot_rod_friction_ratio, pivot_rod_slip_angle, pivot_rod_time

    rhs, forces = constrained_rod(held_x=True)
    sol = integrate.solve_ivp(
        rhs, (0, 100), rod_start(theta0), rtol=1e-12, atol=1e-13, events=flat, method="DOP853", dense_output=True
    )
    ts = np.linspace(0.0, sol.t_events[0][0], 401)[1:-1]
    phis = np.array([sol.sol(t)[2] for t in ts])
    ratio = np.array([(lambda f: f[0] / f[1])(forces(sol.sol(t))) for t in ts])
    # the foot's force by the multipliers, against the closed form; F_x along +x, the lean
    assert pivot_rod_friction_ratio(phis, theta0) == pytest.approx(ratio, rel=1e-6, abs=1e-9)
    assert pivot_rod_time(0.5 * math.pi, theta0) == pytest.approx(sol.t_events[0][0], rel=1e-8)
    for mu in (0.1, 0.3, 1.0):
        th = pivot_rod_slip_angle(theta0, mu)
        # the first sample of the integration at which |F_x| >= mu F_z lies just past it
        first = int(np.flatnonzero(np.abs(ratio) >= mu)[0]) if np.any(np.abs(ratio) >= mu) else None
        if first is None or first == 0:
            assert th == theta0 or (first == 0 and th <= phis[0])
            continue
        assert phis[first - 1] <= th <= phis[first]
        t_slip = pivot_rod_time(th, theta0)
        assert ts[first - 1] <= t_slip <= ts[first]
    assert pivot_rod_slip_angle(theta0, 0.0) == theta0
    assert math.isnan(pivot_rod_slip_angle(theta0, 1e9))
