"""Closed-form and quadrature results used to check the simulator (the paper's closed forms, derived again).

Every function names its units in its signature: ``m`` (mass of a segment), ``b`` (its
half-length; a segment is ``2b`` long), ``g`` (gravity).  With the defaults
``m = b = g = 1`` the results are in the engine's nondimensional units (time
``sqrt(b/g)``, force ``m g``, impulse ``m sqrt(g b)``).

Contents
--------
* :func:`free_fall_time` -- ``t_ff = sqrt(2 z0 / g)``.
* :func:`rod_fall_time` -- a single rod (N = 1) on a fixed frictionless pivot, released
  at rest at ``theta0`` from the vertical, until it is horizontal.
* :func:`hamm_geminard_time_ratio`, :func:`hamm_geminard_height_time` -- the
  Hamm-Geminard model of the paper's Discussion (Fig. 6), re-derived below.
* :func:`sliding_rod_fall_time`, :func:`sliding_rod_angular_velocity`,
  :func:`sliding_rod_normal_force` -- a single rod standing on a frictionless floor,
  released at rest at ``theta0``: its centre falls on a vertical line.
* :func:`pivot_rod_time`, :func:`pivot_rod_friction_ratio`, :func:`pivot_rod_slip_angle`
  -- the rod pivoting about its lower end on a rough floor: how long it takes to reach an
  angle, the friction it asks of the floor (F_x / F_z), and where that first exceeds a
  Coulomb coefficient ``mu`` (where it would start to slip).
* :func:`gamma_from_time_ratio` -- its inverse: the gamma whose fall takes a given
  ``t_fall / t_ff`` (ratios in (0, sqrt(pi/2))).
* :func:`pivot_rod_horizontal_force`, :func:`pivot_rod_critical_s` -- the horizontal
  reaction, and the launch rate beyond which the pivot's impulse is negative.
* :func:`pivot_rod_vertical_force`, :func:`pivot_rod_impulse` -- the vertical reaction
  of the floor on a rod pivoting about its lower end (the paper's Fig. 7 discussion),
  re-derived below.  **The paper's printed formula has a sign error** in the
  ``theta0`` term; see :func:`pivot_rod_vertical_force`.

Derivations
-----------
*Rod on a pivot.*  A uniform rod of mass ``m``, length ``2b``, lower end on a fixed
frictionless (spherical) pivot, moving in a vertical plane at angle ``theta`` from the
upward vertical.  Moment of inertia about the pivot ``I = m (2b)^2 / 3 = (4/3) m b^2``;
the centre is at height ``z_c = b cos(theta)``.  Energy conservation,

    (1/2) (4/3) m b^2 thetadot^2 + m g b cos(theta) = const,

gives ``thetadot^2 = thetadot0^2 + (3 g / (2 b)) (cos theta0 - cos theta)`` and the
torque about the pivot ``thetaddot = (3 g / (4 b)) sin(theta)``.  The floor's force on
the rod is ``F = m d2R_c/dt2 + m g e_z``; its vertical component, with
``d2z_c/dt2 = -b (sin(theta) thetaddot + cos(theta) thetadot^2)``, is

    F_z = m g - (3/4) m g sin^2(theta) - m b cos(theta) thetadot^2
        = (m g / 4) { 1 + 9 cos^2(theta) - 6 cos(theta0) cos(theta) - 4 s cos(theta) }
        = (m g / 4) { (1 - 3 cos theta)^2 + 6 (1 - cos theta0) cos theta - 4 s cos theta },

``s = b thetadot0^2 / g``.  Horizontally (``x`` the direction the rod leans to),
``d2x_c/dt2 = b (cos(theta) thetaddot - sin(theta) thetadot^2)``, so

    F_x = m g sin(theta) { (9/4) cos(theta) - (3/2) cos(theta0) - s }.

Checks: at release (``theta = theta0``, ``s = 0``) the
rod's centre accelerates only tangentially, ``F_z = m g (1 - (3/4) sin^2 theta0)``;
from the upright (``theta0 = 0, s = 0``) the textbook ``(m g / 4)(1 - 3 cos theta)^2``.

*Rod on a frictionless floor.*  The floor pushes only vertically, so the centre of a
rod released at rest keeps its x: ``x_c = const``, ``z_c = b cos(theta)``, and

    (1/2) m (b sin(theta) thetadot)^2 + (1/2) (m b^2 / 3) thetadot^2 + m g b cos(theta) = m g b cos(theta0),

i.e. ``thetadot^2 = (6 g / b) (cos theta0 - cos theta) / (1 + 3 sin^2 theta)``;
differentiating, ``thetaddot = 3 sin(theta) (g / b - cos(theta) thetadot^2) / (1 + 3 sin^2 theta)``.
The floor's force is ``N = m g + m d2z_c/dt2 = m g - m b (cos(theta) thetadot^2 + sin(theta) thetaddot)``.
The rod lies flat (its top end reaches the floor) at ``theta = pi/2``.

*Hamm-Geminard.*  The falling part of the chain (linear density ``mu``, height ``z``,
velocity ``zdot``; the pile is at rest) has momentum ``mu z zdot``.  The floor holds
the pile up (``mu (L - z) g``) and brakes the arriving chain with ``gamma mu zdot^2``
(``gamma = 1``: the whole momentum flux, free fall; ``gamma = 0``: none), so

    d/dt (mu z zdot) = -mu g z + gamma mu zdot^2,   i.e.   z zddot = -g z - (1 - gamma) zdot^2.

With ``u = zdot^2`` as a function of ``z``:
``du/dz + 2 (1 - gamma) u / z = -2 g``, and from rest at ``z0``,
``u = (2 g / c) (z0^c z^(2 gamma - 2) - z)``, ``c = 3 - 2 gamma``.  The time to fall
from ``z0`` to ``x z0`` is, with ``y = (z/z0)^c``, ``a = (2 - gamma) / c``,

    t(x) = sqrt(z0 / (2 g c)) int_{x^c}^1 y^(a-1) (1 - y)^(-1/2) dy
         = sqrt(z0 / (2 g c)) B(a, 1/2) (1 - I_{x^c}(a, 1/2)),

(``I`` the regularised incomplete beta function), so with ``t_ff = sqrt(2 z0 / g)``

    t_gamma / t_ff = t(0) / t_ff = B((2 - gamma)/(3 - 2 gamma), 1/2) / (2 sqrt(3 - 2 gamma)),

the paper's formula (confirmed).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import integrate, special

__all__ = [
    "free_fall_time",
    "rod_fall_time",
    "hamm_geminard_time_ratio",
    "hamm_geminard_height_time",
    "pivot_rod_vertical_force",
    "pivot_rod_vertical_force_as_printed",
    "pivot_rod_angular_velocity",
    "pivot_rod_impulse",
    "pivot_rod_horizontal_force",
    "pivot_rod_critical_s",
    "gamma_from_time_ratio",
    "sliding_rod_angular_velocity",
    "sliding_rod_normal_force",
    "sliding_rod_fall_time",
    "pivot_rod_time",
    "pivot_rod_friction_ratio",
    "pivot_rod_slip_angle",
]

_QUAD_EPSREL = 1e-13  # asks quad for better than the promised 1e-12
# An integrand that changes sign (the pivot's impulse) can integrate to nearly zero, where
# no relative tolerance can be met (quad then warns of round-off); there it is asked for
# this absolute one instead, in units of the integral (m sqrt(g b)), about round-off.
_QUAD_EPSABS_SIGNED = 1e-14


def free_fall_time(z0: float, g: float = 1.0) -> float:
    """Time for a particle released at rest at height ``z0`` to reach the floor:
    ``t_ff = sqrt(2 z0 / g)`` (units of ``sqrt(length / g)``)."""
    if z0 < 0 or g <= 0:
        raise ValueError("free_fall_time needs z0 >= 0 and g > 0")
    return math.sqrt(2.0 * z0 / g)


# --------------------------------------------------------------- rod on a pivot


def _sin_half_sq_over(u: float) -> float:
    """sin(u^2 / 2) / u^2, smooth at u = 0 (value 1/2)."""
    x = 0.5 * u * u
    if x < 1e-4:
        return 0.5 * (1.0 - x * x / 6.0 + x**4 / 120.0)
    return math.sin(x) / (u * u)


def _inv_thetadot_sub(u: float, theta0: float, s: float) -> float:
    """2 u / thetadot(theta0 + u^2) in units of sqrt(b/g), the integrand of
    int dtheta / thetadot after the substitution theta = theta0 + u^2, which removes
    the 1/sqrt singularity at theta0 when s = 0.  Uses
    cos theta0 - cos theta = 2 sin((theta + theta0)/2) sin((theta - theta0)/2)."""
    sm = math.sin(theta0 + 0.5 * u * u)  # sin((theta + theta0) / 2)
    q = 3.0 * sm * _sin_half_sq_over(u)  # (3/2)(cos theta0 - cos theta) / u^2
    if s == 0.0:
        return 2.0 / math.sqrt(q)
    return 2.0 * u / math.sqrt(s + q * u * u)


def _check_theta0(theta0: float) -> None:
    if not (0.0 <= theta0 < 0.5 * math.pi):
        raise ValueError(f"theta0 must be in [0, pi/2), got {theta0!r}")


def _quad_u(f, theta0: float, epsabs: float = 0.0, theta_end: float = 0.5 * math.pi) -> float:
    """int_0^umax f(u) du, umax = sqrt(theta_end - theta0), to _QUAD_EPSREL relative or
    ``epsabs`` absolute, whichever is larger."""
    umax = math.sqrt(theta_end - theta0)
    # a break point where the (theta0 + u^2/2) factor turns over, for small theta0
    pts = [min(math.sqrt(2.0 * theta0), 0.5 * umax)] if theta0 > 0 else None
    val, err = integrate.quad(f, 0.0, umax, epsabs=epsabs, epsrel=_QUAD_EPSREL, limit=400, points=pts)
    return val


def pivot_rod_angular_velocity(theta, theta0: float, s: float = 0.0, b: float = 1.0, g: float = 1.0):
    """thetadot(theta) of a rod (length 2b) pivoting about its lower end, from energy:
    ``thetadot^2 = (g / b) (s + (3/2)(cos theta0 - cos theta))``, ``s = b thetadot0^2 / g``.
    Radians per unit time (per sqrt(b/g) with the defaults; per second for SI inputs)."""
    th = np.asarray(theta, dtype=float)
    val = (g / b) * (s + 1.5 * (math.cos(theta0) - np.cos(th)))
    return np.sqrt(np.maximum(val, 0.0))


def rod_fall_time(theta0: float, b: float = 1.0, g: float = 1.0) -> float:
    """Time for a single rod (N = 1: uniform, length ``2b``, lower end on a fixed
    frictionless pivot) released at rest at angle ``theta0`` (radians) from the upward
    vertical to reach the horizontal (its top end reaches z = 0):

        t = int_{theta0}^{pi/2} dtheta / thetadot,
        thetadot^2 = (3 g / (2 b)) (cos theta0 - cos theta).

    Computed by ``scipy.integrate.quad`` after the substitution ``theta = theta0 + u^2``
    (removes the inverse-square-root singularity at the start); relative accuracy
    better than 1e-12.  Returns time in units of ``sqrt(b/g)`` scaled by the given
    ``b, g`` (seconds for SI inputs); ``inf`` for ``theta0 = 0`` (the upright rod is an
    equilibrium).  Equivalent closed form (used in the tests):
    ``t = (K(m) - F(psi1 | m)) / omega``, ``omega^2 = 3 g / (4 b)``,
    ``m = cos^2(theta0/2)``, ``sin psi1 = sin(pi/4) / cos(theta0/2)``.
    """
    _check_theta0(theta0)
    if b <= 0 or g <= 0:
        raise ValueError("b and g must be > 0")
    if theta0 == 0.0:
        return math.inf
    return math.sqrt(b / g) * _quad_u(lambda u: _inv_thetadot_sub(u, theta0, 0.0), theta0)


def pivot_rod_vertical_force(theta, theta0: float, s: float = 0.0, m: float = 1.0, g: float = 1.0):
    """Vertical component of the pivot's (floor's) force on a uniform rod of mass ``m``,
    length ``2b``, pivoting in a vertical plane about its lower end, at angle ``theta``
    from the upward vertical, having started at ``theta0`` with angular velocity
    ``thetadot0`` (``s = b thetadot0^2 / g``, dimensionless):

        F . e_z = (m g / 4) { (1 - 3 cos theta)^2 + 6 (1 - cos theta0) cos theta - 4 s cos theta }
                = (m g / 4) { 1 + 9 cos^2 theta - 6 cos theta0 cos theta - 4 s cos theta }.

    Units of ``m g`` (newtons for SI inputs; ``b`` enters only through ``s``).
    Derived in the module docstring from ``F = m d2R_c/dt2 + m g e_z``.

    **Differs from the paper**, which prints ``- 6 (1 - cos theta0) cos theta`` (see
    :func:`pivot_rod_vertical_force_as_printed`).  The two agree only for
    ``theta0 = 0``; the printed sign is wrong: at release from rest (``theta =
    theta0``, ``s = 0``) the printed form gives ``(m g/4)(1 - 12 c + 15 c^2)``
    (``c = cos theta0``; e.g. 0.004 m g at theta0 = pi/4), whereas the rod's centre then
    accelerates only tangentially and the reaction is ``m g (1 - (3/4) sin^2 theta0)``
    (0.625 m g at pi/4), which the formula above gives.
    """
    c = np.cos(np.asarray(theta, dtype=float))
    return 0.25 * m * g * ((1.0 - 3.0 * c) ** 2 + 6.0 * (1.0 - math.cos(theta0)) * c - 4.0 * s * c)


def pivot_rod_vertical_force_as_printed(theta, theta0: float, s: float = 0.0, m: float = 1.0, g: float = 1.0):
    """The paper's formula exactly as printed (Discussion section), kept for comparison:
    ``(m g / 4){(1 - 3 cos theta)^2 - 6 (1 - cos theta0) cos theta - 4 s cos theta}``.
    Wrong for ``theta0 != 0``; use :func:`pivot_rod_vertical_force`."""
    c = np.cos(np.asarray(theta, dtype=float))
    return 0.25 * m * g * ((1.0 - 3.0 * c) ** 2 - 6.0 * (1.0 - math.cos(theta0)) * c - 4.0 * s * c)


def pivot_rod_impulse(theta0: float, s: float, m: float = 1.0, b: float = 1.0, g: float = 1.0) -> float:
    """Vertical impulse of the pivot on the pivoting rod while it turns from ``theta0``
    to the horizontal (the paper's ``Delta p(theta0, s)``):

        Delta p = int_{theta0}^{pi/2} (F . e_z) / thetadot dtheta,
        thetadot^2 = (g / b) (s + (3/2)(cos theta0 - cos theta)),

    with ``F . e_z`` from :func:`pivot_rod_vertical_force` (the corrected formula).
    Units of ``m sqrt(g b)`` (N s for SI inputs).  By the momentum theorem it equals
    ``m (zdot_c(pi/2) - zdot_c(theta0)) + m g T`` (``T`` the time taken,
    ``zdot_c = -b sin(theta) thetadot``).  Negative means the pivot pulls the rod
    down on balance.  ``inf`` for ``theta0 = s = 0`` (the rod never leaves the upright).
    """
    _check_theta0(theta0)
    if s < 0:
        raise ValueError(f"s must be >= 0, got {s!r}")
    if m <= 0 or b <= 0 or g <= 0:
        raise ValueError("m, b and g must be > 0")
    if theta0 == 0.0 and s == 0.0:
        return math.inf
    c0 = math.cos(theta0)

    def f(u: float) -> float:
        c = math.cos(theta0 + u * u)
        fz = 0.25 * ((1.0 - 3.0 * c) ** 2 + 6.0 * (1.0 - c0) * c - 4.0 * s * c)
        return fz * _inv_thetadot_sub(u, theta0, s)

    return m * math.sqrt(g * b) * _quad_u(f, theta0, _QUAD_EPSABS_SIGNED)


def pivot_rod_time(theta: float, theta0: float, b: float = 1.0, g: float = 1.0) -> float:
    """Time for the rod of :func:`rod_fall_time` (pivoting about its lower end, released at
    rest at ``theta0``) to reach ``theta`` (radians, theta0 <= theta <= pi/2):
    ``int_{theta0}^{theta} dtheta / thetadot``.  Units of ``sqrt(b/g)`` scaled by ``b, g``."""
    _check_theta0(theta0)
    if not (theta0 <= theta <= 0.5 * math.pi):
        raise ValueError(f"theta must be in [theta0, pi/2] = [{theta0!r}, {0.5 * math.pi!r}], got {theta!r}")
    if theta == theta0:
        return 0.0
    if theta0 == 0.0:
        return math.inf
    return math.sqrt(b / g) * _quad_u(lambda u: _inv_thetadot_sub(u, theta0, 0.0), theta0, theta_end=theta)


def pivot_rod_friction_ratio(theta, theta0: float):
    """F_x / F_z: the friction the floor must give the rod pivoting about its lower end
    (released at rest at ``theta0``), per unit of its normal force, at ``theta``
    (:func:`pivot_rod_horizontal_force` over :func:`pivot_rod_vertical_force`, s = 0):

        F_x / F_z = sin(theta) (9 cos(theta) - 6 cos(theta0)) / (1 + 9 cos^2(theta) - 6 cos(theta0) cos(theta)),

    3 sin(theta0) cos(theta0) / (1 + 3 cos^2(theta0)) at release and 6 cos(theta0) when
    the rod lies flat.  F_z = (m g / 4) ((3 cos(theta) - cos(theta0))^2 + sin^2(theta0))
    > 0 for theta0 > 0: the foot does not lift off before it slips."""
    th = np.asarray(theta, dtype=float)
    c, c0 = np.cos(th), math.cos(theta0)
    return np.sin(th) * (9.0 * c - 6.0 * c0) / (1.0 + 9.0 * c * c - 6.0 * c0 * c)


def pivot_rod_slip_angle(theta0: float, mu: float) -> float:
    """The angle at which a rod pivoting about its lower end on a floor with Coulomb
    friction ``mu`` (released at rest at ``theta0``) starts to slip: the first theta in
    [theta0, pi/2] at which |F_x / F_z| (:func:`pivot_rod_friction_ratio`) reaches
    ``mu``; ``theta0`` if it exceeds ``mu`` at release, NaN if it never reaches it (the
    rod pivots until it lies flat: ``mu`` above the ratio's largest value on the way).
    Radians."""
    _check_theta0(theta0)
    mu = float(mu)
    if not (mu >= 0.0):
        raise ValueError(f"mu must be >= 0, got {mu!r}")
    if theta0 == 0.0:
        raise ValueError("theta0 = 0: the upright rod is an equilibrium and never starts to turn")

    def excess(th: float) -> float:
        return abs(float(pivot_rod_friction_ratio(th, theta0))) - mu

    if excess(theta0) >= 0.0:
        return theta0
    grid = np.linspace(theta0, 0.5 * math.pi, 4001)  # |ratio| has at most two humps: fine enough
    vals = np.abs(pivot_rod_friction_ratio(grid, theta0)) - mu
    hit = np.flatnonzero(vals >= 0.0)
    if hit.size == 0:
        return math.nan
    from scipy.optimize import brentq

    k = int(hit[0])
    return float(brentq(excess, float(grid[k - 1]), float(grid[k]), xtol=1e-15, rtol=1e-14))


# ------------------------------------------------------ rod on a frictionless floor


def sliding_rod_angular_velocity(theta, theta0: float, b: float = 1.0, g: float = 1.0):
    """thetadot(theta) of a rod (length 2b) standing on a frictionless floor, released at
    rest at ``theta0`` from the vertical (module docstring):
    ``thetadot^2 = (6 g / b) (cos theta0 - cos theta) / (1 + 3 sin^2 theta)``.
    Radians per unit time."""
    th = np.asarray(theta, dtype=float)
    val = (6.0 * g / b) * (math.cos(theta0) - np.cos(th)) / (1.0 + 3.0 * np.sin(th) ** 2)
    return np.sqrt(np.maximum(val, 0.0))


def sliding_rod_normal_force(theta, theta0: float, m: float = 1.0, g: float = 1.0):
    """The frictionless floor's (vertical) force on the rod of
    :func:`sliding_rod_angular_velocity` at ``theta``:
    ``N = m g - m b (cos(theta) thetadot^2 + sin(theta) thetaddot)``,
    ``thetaddot = 3 sin(theta) (g / b - cos(theta) thetadot^2) / (1 + 3 sin^2 theta)``.
    Units of ``m g`` (``b`` cancels)."""
    th = np.asarray(theta, dtype=float)
    sn, c = np.sin(th), np.cos(th)
    w2 = 6.0 * (math.cos(theta0) - c) / (1.0 + 3.0 * sn * sn)  # b thetadot^2 / g
    acc = 3.0 * sn * (1.0 - c * w2) / (1.0 + 3.0 * sn * sn)  # b thetaddot / g
    return m * g * (1.0 - c * w2 - sn * acc)


def sliding_rod_fall_time(theta0: float, b: float = 1.0, g: float = 1.0) -> float:
    """Time for a rod (length ``2b``) standing on a frictionless floor, released at rest at
    ``theta0`` (radians from the upward vertical), to lie flat (its top end reaches the
    floor, theta = pi/2): ``int_{theta0}^{pi/2} dtheta / thetadot`` with thetadot from
    :func:`sliding_rod_angular_velocity`, by ``scipy.integrate.quad`` after the
    substitution ``theta = theta0 + u^2``; relative accuracy better than 1e-12.  Units of
    ``sqrt(b/g)`` scaled by ``b, g``; ``inf`` for ``theta0 = 0``."""
    _check_theta0(theta0)
    if b <= 0 or g <= 0:
        raise ValueError("b and g must be > 0")
    if theta0 == 0.0:
        return math.inf

    def f(u: float) -> float:  # 2 u / thetadot(theta0 + u^2)
        th = theta0 + u * u
        q = 12.0 * math.sin(theta0 + 0.5 * u * u) * _sin_half_sq_over(u)  # 6 (cos theta0 - cos theta) / u^2
        return 2.0 / math.sqrt(q / (1.0 + 3.0 * math.sin(th) ** 2))

    return math.sqrt(b / g) * _quad_u(f, theta0)


# --------------------------------------------------------------- Hamm-Geminard


def _hg_params(gamma: float) -> tuple[float, float]:
    gamma = float(gamma)
    if not (math.isfinite(gamma) and gamma < 1.5):
        raise ValueError(f"gamma must be < 3/2 (c = 3 - 2 gamma > 0), got {gamma!r}")
    c = 3.0 - 2.0 * gamma
    return c, (2.0 - gamma) / c


def hamm_geminard_time_ratio(gamma: float) -> float:
    """Fall time of the Hamm-Geminard model in units of ``t_ff = sqrt(2 z0 / g)``:

        t_gamma / t_ff = B((2 - gamma)/(3 - 2 gamma), 1/2) / (2 sqrt(3 - 2 gamma)),

    from ``d/dt(mu z zdot) = -mu g z + gamma mu zdot^2`` released at rest (derivation in
    the module docstring; the paper's formula, confirmed).  ``gamma = 1`` gives 1,
    ``gamma = 0`` gives 0.7468...  Dimensionless; valid for ``gamma < 3/2``.
    """
    c, a = _hg_params(gamma)
    return float(special.beta(a, 0.5) / (2.0 * math.sqrt(c)))


def hamm_geminard_height_time(x, gamma: float):
    """Time for the top of the Hamm-Geminard chain to fall from ``z0`` to ``x z0``
    (``0 <= x <= 1``), in units of ``t_ff``:

        t(x) / t_ff = B(a, 1/2) (1 - I_{x^c}(a, 1/2)) / (2 sqrt(c)),
        c = 3 - 2 gamma,  a = (2 - gamma) / c,

    ``I`` the regularised incomplete beta function.  ``t(0) / t_ff`` is
    :func:`hamm_geminard_time_ratio`."""
    c, a = _hg_params(gamma)
    xx = np.asarray(x, dtype=float)
    if np.any((xx < 0) | (xx > 1)):
        raise ValueError("x must be in [0, 1]")
    return special.beta(a, 0.5) * (1.0 - special.betainc(a, 0.5, xx**c)) / (2.0 * math.sqrt(c))


def pivot_rod_horizontal_force(theta, theta0: float, s: float = 0.0, m: float = 1.0, g: float = 1.0):
    """Horizontal component of the pivot's force on the rod of
    :func:`pivot_rod_vertical_force`, along the direction the rod leans to:

        F_x = m g sin(theta) { (9/4) cos(theta) - (3/2) cos(theta0) - s }

    (derived in the module docstring from ``F = m d2R_c/dt2 + m g e_z``).  Positive: the
    pivot pushes the rod's foot towards the side it falls to.  Units of ``m g``."""
    th = np.asarray(theta, dtype=float)
    return m * g * np.sin(th) * (2.25 * np.cos(th) - 1.5 * math.cos(theta0) - s)


def pivot_rod_critical_s(theta0: float) -> float:
    """The launch rate ``s* = b thetadot0^2 / g`` at which the pivot's vertical impulse
    on the rod, from ``theta0`` to the horizontal (:func:`pivot_rod_impulse`), is zero:
    for ``s > s*`` the pivot pulls the rod down on balance.  Dimensionless."""
    _check_theta0(theta0)

    def f(s):  # (near the root the impulse is near zero: quad meets its absolute tolerance there)
        return pivot_rod_impulse(theta0, s)

    lo = 1e-12 if theta0 == 0.0 else 0.0
    hi = 1.0
    while f(hi) > 0.0:
        hi *= 2.0
        if hi > 1e6:
            raise ValueError(f"no sign change of the impulse for s up to 1e6 at theta0 = {theta0!r}")
    if f(lo) <= 0.0:
        return lo
    from scipy.optimize import brentq

    return float(brentq(f, lo, hi, xtol=1e-14, rtol=1e-13))


def gamma_from_time_ratio(ratio: float) -> float:
    """The Hamm-Geminard gamma whose fall takes ``ratio = t_gamma / t_ff`` (the inverse of
    :func:`hamm_geminard_time_ratio`, which increases from 0 (gamma -> -inf) through
    0.7468 (gamma = 0) and 1 (gamma = 1) towards sqrt(pi/2) = 1.2533 (gamma -> 3/2)).
    Dimensionless; ValueError outside (0, sqrt(pi/2))."""
    ratio = float(ratio)
    top = math.sqrt(math.pi / 2.0)
    if not (math.isfinite(ratio) and 0.0 < ratio < top):
        raise ValueError(f"ratio must be in (0, {top:.6f}), got {ratio!r}")
    from scipy.optimize import brentq

    f = lambda gam: hamm_geminard_time_ratio(gam) - ratio  # noqa: E731
    lo = -1.0
    while f(lo) > 0.0:
        lo *= 2.0
        if lo < -1e9:
            raise ValueError(f"ratio {ratio!r} too small to invert")
    hi = 1.5 - 1e-12
    if f(hi) < 0.0:
        raise ValueError(f"ratio {ratio!r} too close to its supremum {top:.6f}")
    return float(brentq(f, lo, hi, xtol=1e-15, rtol=1e-14))
