"""The smooth laws beside gravity in RATTLE (``core.forces``; today the hinges' viscous
damping, ``contacts.damping``): their force on the axes in each half kick, and what it
removed, booked as ``lost_damping``.

The first half kick takes the force at the step's start, f1 = f(q, u); the second at its
end, f2 = f(q+, u~), with the rates u~ = 2 u_half - u (u+ to O(h^2): the kick stays
explicit and the step second order).  What a half kick removed is its force's work over
the step's displacement, -f . (e+ - e) / 2, as for the sliding points' friction
(``friction.friction_work``); a segment landed between the two kicks takes only the first.
"""

from __future__ import annotations

from ...core.forces import smooth_axis_forces
from ...core.rules import is_landed
from ...jit import njit

W_AXIS = 3.0  # the axes' inverse mass (W = diag(1, 3): rods, m b^2 / 3)


@njit(cache=True, _nrt=False)
def _kick(h, anchored, f, uke):
    """uke += h/2 W f on the segments not landed."""
    for i in range(f.shape[0]):
        if not is_landed(anchored, i):
            for q in range(3):
                uke[i, q] += 0.5 * h * W_AXIS * f[i, q]


@njit(cache=True, _nrt=False)
def _work(anchored, f, e, e0):
    """What a half kick of f removed over the step's displacement: -f . (e - e0) / 2 on the
    segments not landed."""
    loss = 0.0
    for i in range(f.shape[0]):
        if not is_landed(anchored, i):
            for q in range(3):
                loss -= 0.5 * f[i, q] * (e[i, q] - e0[i, q])
    return loss


@njit(cache=True, _nrt=False)
def first_smooth_kick(h, model, mo, sc):
    """Stage 1's half kick of the smooth laws' force at the step's start (sc.fdamp keeps it)."""
    smooth_axis_forces(model, mo.e, mo.ve, sc.fdamp)
    _kick(h, mo.anchored, sc.fdamp, sc.uke)


@njit(cache=True, _nrt=False)
def first_smooth_work(mo, sc):
    """After stage 1 (mo at q+): what the first half kick removed, into the ledger's smooth_loss."""
    sc.ledger.smooth_loss[0] += _work(sc.start.anchored, sc.fdamp, mo.e, sc.start.e)


@njit(cache=True, _nrt=False)
def second_smooth_kick(h, model, mo, sc):
    """Stage 2's half kick at q+ with the rates 2 u_half - u (mo.ve: u_half), and its work into the ledger's smooth_loss."""
    v = sc.vdamp
    for i in range(v.shape[0]):
        for q in range(3):
            v[i, q] = 2.0 * mo.ve[i, q] - sc.start.ve[i, q]
    smooth_axis_forces(model, mo.e, v, sc.fdamp)
    _kick(h, mo.anchored, sc.fdamp, sc.uke)
    sc.ledger.smooth_loss[0] += _work(mo.anchored, sc.fdamp, mo.e, sc.start.e)
