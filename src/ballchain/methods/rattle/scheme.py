"""One step of nonsmooth RATTLE over the compiled core (numba, nondimensional: m = b = g = 1).

The scheme of Breuling, Capobianco, Eugster and Leine (Nonlinear Analysis: Hybrid
Systems, 2024) in maximal coordinates q = (c_i, e_i), u = q' (``rows``), with the
constant inverse mass W and gravity f = -e_z on the centres.  One step from t to t + h:

1. **Stage 1** (SHAKE, position level): u_half = u + h/2 W f + W G(q)^T P1,
   q+ = q + h u_half, with the joints, axes and anchors as equalities at q+ and the
   bend limits and the floor as Signorini conditions at q+: g(q+) >= 0, P1 >= 0,
   complementary.  Simplified Newton on P1 with the factors of G(q) W G(q)^T (residual
   g(q+), step (h G W G^T)^{-1}), inside an active-set loop: a unilateral row whose P1
   pulls is switched off, one found violated at q+ switched on (``stage1``).
2. **Touches** (the floor model ``all``: ``rules.hold_at``): a point stopped by the
   floor in stage 1 is anchored where it stands, for good (``land``).
3. **Stage 2** (velocity level): u+ = u_half + h/2 W f + W G(q+)^T P2 with the
   equalities' rates zero (a new anchor's velocity: zero, the landing) and, on every
   hinge at its limit after stage 1, the model's impact law: Moreau's inelastic
   dg/dt+ >= 0, P2 >= 0, complementary, or with restitution e (``contacts.newton``)
   Newton's xi = dg/dt+ + e dg/dt- >= 0 instead on a hinge not locked at the step's start,
   dg/dt- the rate at which it reached its limit inside the step (``impact_rates``); a
   point that lands with restitution at the floor leaves it at -e times the vertical
   velocity it reached it with, its horizontal velocity stopped (``land``,
   ``rebound_targets``).  A hinge or point that rebounds is not locked or anchored
   (``leave_limits``) (``stage2``).
4. **Settle** (``rules.settle_anchors``): new anchors made, a landed segment put on its
   anchors and at rest, a lock whose limit is no longer in force dropped.

Second order where the motion is smooth (persistent locks included); nothing passes the
floor or a limit by more than the solver's tolerance at the end of a step.  What an
impulse P on row r does to T is P (rate before + rate after) / 2 (exact for impulses
applied together); the bend rows' share is booked to the hinges, the floor rows' and new
anchors' share to the landings, the equalities' share is the method's own error
(the imbalance, second order).  A hinge is *locked* while it takes impulse in stage 2.
A landing and a new lock beside it (``_lock_beside_landing``) are not resolved in one
step: such a step is taken again halved (down to h / 2^SPLIT_CUTS) until they fall in
steps of their own.  The exact method lands the point and then locks the hinge that the
landing made close; in one step, stage 1 would hold the hinge from the step's start,
before the landing (without the split, t_fall/t_ff came out 0.009 [0.003, 0.016] long at
N = 1024, paired on 63 starts).  Where a step still holds both (the split gave up, or the
hinge was further away), the books take them in the exact method's order, the landing
first and then the lock (``lock_loss_after_landing``): the rows' own work would book the
lock's loss to the landing, the bend row's rate before being the one before the landing.
Frames come from a second step from the step's start to the frame's time, on a copy of
the state (``frame_substep``): the fall does not depend on when frames are taken.
"""

from __future__ import annotations

import math

from ...contacts.coulomb import anchors, grips, slides
from ...core.forces import any_smooth_law
from ...jit import njit
from .blocks import factors_view
from .books import (
    _anchor_impulse,
    _book_impact,
    _new_anchor_work,
    _new_lock,
    _pile_impulse,
    _work,
    lock_loss_after_landing,
    tension_impulse,
)
from .codes import ERR_FRICTION, ERR_MERGED, ERR_NEWTON, ERR_REBOUND, ERR_STEP_ENERGY, ERR_STEP_NAN
from .friction import (
    friction_directions,
    friction_work,
    hold_marked,
    hold_reversed,
    impact_friction_impulse,
    let_go,
    normal_forces,
    stop_rigid_stretches,
)
from .rebounds import REBOUND_TOL, impact_rates, rebound_energy, restitution
from .rows import (
    K_BEND,
    K_FLOOR,
    Rows,
    copy_layout,
)
from .smooth import first_smooth_work
from .stage1 import ITER_BUDGET, NEWTON_MAX, ROUNDS_MAX, stage1
from .stage2 import land, settle, stage2
from .state import Motion, Scratch, active_points, clear_ledger, copy_motion_points, mechanical_energy

SPLIT_CUTS = 8  # a landing step with a new lock beside it is taken again halved, down to h / 2^SPLIT_CUTS
SPLIT_REACH = 16  # ... "beside": the hinge's point within this many points of the landing point
ROOT_TURN = 0.5  # rad: a stage 1 that turns a segment further (5 turn limits) found another root of its equations


@njit(cache=True, _nrt=False)
def keep_warm_start(h, ws, sc):
    """After a step of size h is accepted: its stage 2's layout and impulses are the next
    stage 1's warm start (scaled to that step).  Not after a step that is refused: its
    stage 2 may hold an impact's impulses (a landing, a lock), far from h/2 times the
    forces, and from there the next stage 1's Newton can reach another assembly of a
    stretch closed between anchors (two segments' axes swapped) with huge impulses."""
    copy_layout(ws.kind, ws.nrow, ws.x, sc.kind_w, sc.nrow_w, sc.x_w)
    sc.h_last[0] = h


@njit(cache=True, _nrt=True)
def rattle_step(t, h, model, mo, ws, sc, etol, landings, split, budget):
    """One step of size h from t (stages 1-4 of the module docstring) on the state mo;
    what the books need is left in sc (its ledger, new_anchor, stage 1's layout and
    rates; stage 2's in ws, sc.val, sc.rate).  With etol > 0 a step is refused
    (ERR_STEP_ENERGY) that changes U + T by more than etol without an impact, or raises
    it by more than etol with one (an impact removes energy).  Without ``landings`` (a
    frame's step, inside a step of the fall) a point stopped by the floor is not anchored:
    the fall anchors it, at its own step's end.  With ``split`` a step in which a point
    lands and a hinge beside it locks is refused (ERR_MERGED: ``_lock_beside_landing``).
    ``budget``: stage 1's Newton iterations at most.
    Returns (code, new anchors).  The stages see the chain down to its landed part only
    (``active_points``: views of the same arrays, its indices the chain's)."""
    clear_ledger(sc.ledger)
    sc.unmet[0] = -1.0  # (where a stage fails in this step: set by it)
    p = active_points(mo.anchored)
    # sc.start <- mo (a refused step is undone from it).  In the fall, sc.start already holds
    # the last step's start, and that step changed only its own points: they (and this
    # step's) are copied.  A frame's step starts from another state: all of it.
    last = active_points(sc.start.anchored) if landings else mo.anchored.shape[0]
    copy_motion_points(mo, sc.start, max(p, last))
    _no_rows_from(p, max(p, last), ws, sc)
    return _step_points(
        t, h, model, motion_view(mo, p), rows_view(ws, p), scratch_view(sc, p), etol, landings, split, budget
    )


@njit(cache=True, _nrt=False)
def _no_rows_from(p, last, ws, sc):
    """No point from p on has rows (their last rows, from before the segments there
    landed, are not the layouts'): those of points p to last - 1 are cleared (a step
    writes rows of its own points only: past the last step's, none are left)."""
    for j in range(p, last):
        ws.nrow[j] = 0
        sc.nrow1[j] = 0
        sc.nrow_old[j] = 0
        sc.nrow_w[j] = 0


@njit(cache=True, _nrt=True)
def motion_view(mo, p):
    """The state of the chain's first p points (p - 1 segments): views."""
    s = p - 1
    return Motion(
        mo.c[:s], mo.e[:s], mo.vc[:s], mo.ve[:s], mo.anchored[:p], mo.anchor_pos[:p], mo.anchor_t[:p],
        mo.locked[: max(s - 1, 0)], mo.touching[:p], mo.grip[:p],
    )  # fmt: skip


@njit(cache=True, _nrt=True)
def rows_view(ws, p):
    """The rows of the first p points and their factors: views."""
    return Rows(
        ws.J[:p], ws.kind[:p], ws.nrow[:p], ws.rhs[:p], ws.x[:p], ws.J1[:p],
        factors_view(ws.sym, p), factors_view(ws.newt, p), ws.valid,
    )  # fmt: skip


@njit(cache=True, _nrt=True)
def scratch_view(sc, p):
    """A step's scratch for the first p points: views (the counters whole)."""
    s, k = p - 1, max(p - 2, 0)
    return Scratch(
        motion_view(sc.start, p), sc.ukc[:s], sc.uke[:s], sc.val[:p], sc.rate[:p], sc.floor_on[:p], sc.cand[:k],
        sc.kind1[:p], sc.nrow1[:p], sc.x1[:p], sc.rb1[:p], sc.ra1[:p],
        sc.kind_old[:p], sc.nrow_old[:p], sc.x_old[:p], sc.kind_w[:p], sc.nrow_w[:p], sc.x_w[:p],
        sc.new_anchor[:p], sc.pts[:p], sc.ledger, sc.h_last, sc.unmet, sc.fcand[:p], sc.rebound[:p],
        sc.hrebound[:k], sc.newrow, sc.inelastic, sc.fimp[:p], sc.fsec[:p], sc.grip_log[:p], sc.fallback[:p],
        sc.fdamp[:s], sc.vdamp[:s],
    )  # fmt: skip


@njit(cache=True, _nrt=False)
def _step_points(t, h, model, mo, ws, sc, etol, landings, split, budget):
    """``rattle_step`` on the points of the views (sc.start holds the step's start)."""
    grip = grips(model.friction)
    if grip:
        friction_directions(mo)
        sc.grip_log[:, 0] = 0.0
    if restitution(model):
        sc.fallback[:] = 0  # (this attempt's marks: ``books.commit`` logs them)
    e_start = mechanical_energy(mo.c, mo.vc, mo.ve)
    held = hold_marked(mo, sc) if grip and landings else 0  # (``friction.hold_stuck_stretch``)
    code = stage1(h, model, mo, ws, sc, budget)
    if code == 0 and _largest_turn(sc.start.e, mo.e) > ROOT_TURN:
        code = ERR_NEWTON  # another root of stage 1's equations, not this step's: taken again halved
    if code < 0:
        return code, 0
    bounce = restitution(model) and sc.inelastic[0] == 0
    if bounce:
        impact_rates(h, model, mo, ws, sc)
    elif restitution(model):  # (taken again inelastic: no approach rates, no rebound)
        sc.hrebound[:] = 0.0
        sc.rebound[:] = 0.0
    lock_work = -_work(sc.kind1, sc.nrow1, sc.x1, sc.rb1, sc.ra1, K_BEND)
    land_work = -_work(sc.kind1, sc.nrow1, sc.x1, sc.rb1, sc.ra1, K_FLOOR)
    lg = sc.ledger
    _anchor_impulse(sc.kind1, sc.nrow1, sc.x1, lg.floor_impulse)
    _pile_impulse(mo.anchored, sc.kind1, sc.nrow1, sc.x1, lg.pile_pull)
    tension_impulse(mo.e, sc.kind1, sc.nrow1, sc.x1, lg.tension)
    if grip:
        friction_work(h, model.friction, mo, sc.start, lg)
    if any_smooth_law(model):
        first_smooth_work(mo, sc)
    na, touched, ns = 0, 0, 0
    if landings or slides(model.friction) or grip:  # (a frame's step on a floor that lets points slide too)
        na, ns = land(t + h, h, model, mo, sc, landings)
        ns += held
    else:
        for j in range(sc.floor_on.shape[0]):
            touched += sc.floor_on[j]
            sc.floor_on[j] = 0
    lg.new_anchors[0] = na
    code = stage2(h, model, mo, ws, sc)
    if code < 0:
        return code, na
    if (
        split
        and na > 0
        and _lock_beside_landing(sc.start.locked, mo.locked, sc.kind1, sc.nrow1, sc.x1, sc.new_anchor, na)
    ):
        return ERR_MERGED, na
    lock_work -= _work(ws.kind, ws.nrow, ws.x, sc.val, sc.rate, K_BEND)
    land_work -= _new_anchor_work(mo.anchored, ws.kind, ws.nrow, ws.x, sc.val, sc.rate)
    land_work -= _work(ws.kind, ws.nrow, ws.x, sc.val, sc.rate, K_FLOOR)  # (a frictionless floor's rows)
    lock_after = lock_loss_after_landing(mo, ws, sc) if na > 0 else -1.0
    _anchor_impulse(ws.kind, ws.nrow, ws.x, lg.floor_impulse)
    _pile_impulse(mo.anchored, ws.kind, ws.nrow, ws.x, lg.pile_pull)
    tension_impulse(mo.e, ws.kind, ws.nrow, ws.x, lg.tension)
    if grip:
        impact_friction_impulse(sc)
    if (na > 0 or ns > 0) and (
        anchors(model.friction) or grip
    ):  # (landed segments do not move: nothing else to settle)
        settle(model, mo)
        ws.valid[0] = 0  # landed segments: the columns of the factors are not the state's
    fric = lg.friction_loss[0]  # (what the sliding points' friction removed: booked as lost_sliding, not as error)
    if grip and landings and etol > 0.0 and fric < -etol and hold_reversed(mo, sc.start) > 0:
        return ERR_FRICTION, na  # (friction creates no energy: the points it reversed held, ``hold_reversed``)
    damp = lg.smooth_loss[0]  # (what the hinges' damping removed: booked as lost_damping)
    lost = e_start - mechanical_energy(mo.c, mo.vc, mo.ve) - fric - damp
    lg.energy_lost[0] = lost
    if not math.isfinite(lost):  # (a singular stage: taken again halved, as a failed one)
        return ERR_STEP_NAN, na
    if na > 0 or ns > 0 or touched > 0 or _new_lock(sc.start.locked, sc.kind1, sc.nrow1, sc.x1):
        lg.impact[0] = 1
        created = etol + (REBOUND_TOL * rebound_energy(mo.anchored, ws, sc) if bounce else 0.0)
        if etol > 0.0 and lost < -created:
            return (ERR_REBOUND if created > etol else ERR_STEP_ENERGY), na
        _book_impact(lost, lock_work, land_work, lock_after, na + touched + ns, lg)
    elif etol > 0.0 and abs(lost) > etol:
        return ERR_STEP_ENERGY, na
    if grip and landings:  # the sliding points' normal forces for the next step; anchors that let go
        normal_forces(h, mo, ws, sc)
        stop_rigid_stretches(mo)
        if let_go(h, model.friction, mo, ws, sc):
            ws.valid[0] = 0
    return 0, na


@njit(cache=True, _nrt=False)
def _lock_beside_landing(locked0, locked, kind1, nrow1, x1, new_anchor, na):
    """Did a hinge not locked at the step's start, its point within SPLIT_REACH points of a
    point anchored in this step, lock in it (impulse in stage 1, or locked after stage 2)?
    The exact method lands the point first and then locks the hinge, which the landing
    made close fast (the lock a few 1e-3 to 0.5 steps later, at about 3e-4 E0 each at
    N = 512): resolved together, stage 1 holds the hinge from the step's start."""
    nh = locked0.shape[0]
    for r in range(na):
        j = new_anchor[r]
        for k in range(max(j - 1 - SPLIT_REACH, 0), min(j - 1 + SPLIT_REACH, nh - 1) + 1):
            if locked0[k] != 0:
                continue
            if locked[k] != 0:
                return True
            for q in range(nrow1[k + 1]):
                if kind1[k + 1, q] == K_BEND and x1[k + 1, q] > 0.0:
                    return True
    return False


@njit(cache=True, _nrt=False)
def _largest_turn(e0, e1):
    """max_i |e1_i - e0_i|: how far a step turned its most turned segment (about the angle, rad)."""
    m = 0.0
    for i in range(e0.shape[0]):
        m = max(m, (e1[i, 0] - e0[i, 0]) ** 2 + (e1[i, 1] - e0[i, 1]) ** 2 + (e1[i, 2] - e0[i, 2]) ** 2)
    return math.sqrt(m)


CUTS_MAX = 10  # a step of the default --dt is halved at most this many times (a longer --dt: more, ``extra_cuts``)


def extra_cuts(dt: float) -> int:
    """The halvings a step of ``dt`` (t_ff/N) takes beyond CUTS_MAX (and SPLIT_CUTS), so
    that its shortest step is no longer than the default step's: ceil(log2(dt / 0.05)), at
    least 0 (a longer --dt is no coarser where the steps must be short)."""
    from . import DEFAULT_DT

    return max(0, math.ceil(math.log2(dt / DEFAULT_DT) - 1e-12))


@njit(cache=True, _nrt=False)
def _budget(level, cuts_max):
    """Stage 1's Newton iterations at most in a step at this level: ITER_BUDGET while it
    may still be halved (level < cuts_max, the run's most halvings), else every round's."""
    return ITER_BUDGET if level < cuts_max else NEWTON_MAX * ROUNDS_MAX
