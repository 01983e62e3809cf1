"""Coulomb's friction between the floor and the points on it (``registry.LAWS["coulomb"]``),
compiled.

A point j on the floor (height z_j = 0) is pressed by the floor's normal force (or impulse)
P_n >= 0 and dragged by its tangential force P_t, |P_t| <= mu P_n.  Two limits are built:

* mu = inf, the anchor (``anchors``): a point that touches the floor is held where it
  touched, for good (its three rows are equalities; the model's law);
* mu = 0, a frictionless floor (``slides``): the floor's only row at a touching point is
  its height, a Signorini condition at the position level (z_j >= 0, P_n >= 0,
  z_j P_n = 0) and Moreau's inelastic law at an impact (dz_j/dt+ >= 0, P_n >= 0,
  complementary: ``released``, ``closes``).  The point slides with no loss, and leaves the
  floor when the normal force would pull.  Nothing horizontal acts on the chain: its
  horizontal momentum is constant, a chain released at rest keeps its centre of mass on
  a vertical line.

* 0 < mu < inf (``grips``): stick and slip.  A point on the floor is held where it is
  while the force that holds it lies in the cone |F_t| <= mu F_n (F_n >= 0); beyond it
  the point slides, dragged by mu F_n against its sliding velocity, and it lifts off
  where the floor would pull.  Only RATTLE honours it (``methods.rattle.friction``: stick
  is the anchor, slip the frictionless row plus the friction force).
"""

from __future__ import annotations

import math

from ..jit import njit


@njit(cache=True, inline="always")
def anchors(mu):
    """A point that touches the floor is anchored there (mu = inf: the anchor)."""
    return mu == math.inf


@njit(cache=True, inline="always")
def slides(mu):
    """A point on the floor slides on it, held by its height row alone (mu = 0)."""
    return mu == 0.0


@njit(cache=True, inline="always")
def grips(mu):
    """Finite friction (0 < mu < inf): a point on the floor sticks while the force that
    holds it lies in the cone, and slides against mu F_n when it does not."""
    return 0.0 < mu < math.inf


@njit(cache=True, inline="always")
def released(impulse):
    """The floor's row at a point is released when its impulse (or force) would pull: P_n < 0."""
    return impulse < 0.0


@njit(cache=True, inline="always")
def closes(rate, rate_tol):
    """A released point at the floor that still moves into it (dz/dt < -rate_tol) is
    stopped by the floor again (Moreau's inelastic law: its row is put back)."""
    return rate < -rate_tol
