"""Newton's restitution at an impact (``registry.LAWS["newton"]``), compiled.

On the rows an impact acts on (a hinge at its limit: its lock row), with gamma- and
gamma+ the row's rate before and after and P its impulse, the law is the
complementarity

    xi = gamma+ + e gamma- >= 0,   P >= 0,   xi P = 0

(Glocker's form of Newton's law for many contacts at once; e = 0 is Moreau's inelastic
impact).  With the rows' Delassus matrix G = J W J^T, gamma+ = gamma- + G P, so an
active set is solved by G P = -(1 + e) gamma- (``impulse_rhs``), and the kinetic energy
changes by

    T+ - T- = P . (gamma- + gamma+) / 2 = -(1/2) (1 - e) / (1 + e) P . G P <= 0

(xi . P = 0 gives gamma- . P = -P . G P / (1 + e)): nothing is created for e in [0, 1],
nothing is lost for e = 1.  A row that was leaving its limit (gamma- > 0) and is pushed
back to it by the others comes out closing, at -e gamma-: the impact then takes a second,
inelastic pass from there (Moreau's, dissipative too) that stops it at its limit
(``core.impacts.velocity_impact``).  A single row closing at rate v < 0 rebounds at -e v and loses
(1 - e^2) of what the inelastic impact loses, v^2 / (2 G).  A row held at its limit by the
accumulation rule (``rules.must_hold``) takes e = 0: it is held, not bounced.

At the floor (``floor_rebound``) the law acts on a landing point's vertical row: it
leaves the floor at -e times the vertical velocity it landed with, its horizontal
velocity stopped (the floor is rough: friction inf).  A point that rebounds is not
anchored; one that would come back slower than the accumulation threshold is anchored
instead, and the anchoring's impact books what the series of ever smaller bounces would
have lost.
"""

from __future__ import annotations

from ..jit import njit


@njit(cache=True, inline="always")
def impulse_rhs(rate_now, rate_before, e):
    """The right-hand side of G P = -(gamma + e gamma-) for a row that carries an impulse,
    solved from a velocity whose row rate is ``rate_now`` (gamma- itself in the impact's
    first round; the last round's result when more hinges are held and it is solved
    again: gamma- stays the rate before the instant)."""
    return -(rate_now + e * rate_before)


@njit(cache=True, inline="always")
def law_rate(rate_after, rate_before, e):
    """xi = gamma+ + e gamma-: what the law keeps >= 0 (complementary to the impulse)."""
    return rate_after + e * rate_before


@njit(cache=True, inline="always")
def rebounds(rate_after, e, rate_tol):
    """A row that carried an impulse leaves its limit (e > 0 and it separates faster
    than ``rate_tol``): it is not locked."""
    return e > 0.0 and rate_after > rate_tol


@njit(cache=True, inline="always")
def floor_rebound(vz_before, e):
    """The upward velocity a point that lands at vertical velocity ``vz_before`` (< 0)
    leaves the floor with: -e vz_before (Newton's law on the floor's normal row; the
    rough floor stops its horizontal motion in the impact); 0 for a touch or e = 0."""
    return -e * vz_before if (e > 0.0 and vz_before < 0.0) else 0.0


FLIGHT_STEPS = 4.0  # a time-stepping method makes a bounce only if its flight lasts this many steps


@njit(cache=True, inline="always")
def bounce_resolved(v, h, hold_rate):
    """Is a bounce off the floor at upward velocity v (sqrt(g b)) one a time-stepping method
    with steps h (sqrt(b/g)) resolves: faster than ``hold_rate`` and on a flight 2 v / g of
    FLIGHT_STEPS steps or more (v > FLIGHT_STEPS g h / 2)?  A shorter flight is not resolved
    by the steps: the series of bounces ends there, at the step's scale, and the point is
    anchored (a ``pin`` row), as the accumulation rule ends it in the event method."""
    return v > max(hold_rate, 0.5 * FLIGHT_STEPS * h)
