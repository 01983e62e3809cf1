"""Nonsmooth RATTLE over the compiled core (numba, nondimensional: m = b = g = 1).

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
from collections import namedtuple

import numpy as np

from ...contacts.coulomb import anchors, closes, released, slides
from ...contacts.newton import floor_rebound
from ...core.blocks import _weights
from ...core.books import log_row, lowest_point
from ...core.kinematics import potential_energy, rates_for_axes
from ...core.rules import (
    LOG_BOUNCE,
    LOG_LANDING,
    LOG_LOCK,
    LOG_UNLOCK,
    bottom_airborne,
    fall_ended,
    fall_over,
    hold_at,
    is_landed,
    landed_count,
    limit_in_force,
)
from ...jit import entry, njit
from .blocks import factor_blocks, factors_view, solve_blocks
from .rows import (
    BOUNCE,
    K_ANCHOR_LOWER,
    K_ANCHOR_UPPER,
    K_AXIS,
    K_BEND,
    K_FLOOR,
    Rows,
    booked_rates,
    carry_over,
    copy_layout,
    is_floor,
    layout,
    row_gradients,
    row_rates,
    row_values,
    segment_force,
)

NEWTON_MAX = 40  # simplified Newton iterations of stage 1 at most (per active set)
NEWTON_RATE = 0.05  # an iteration that cuts the residual less than this fold moves on to (a new) A
ROUNDS_MAX = 60  # active-set rounds of a stage at most
SPLIT_CUTS = 8  # a landing step with a new lock beside it is taken again halved, down to h / 2^SPLIT_CUTS
SPLIT_REACH = 4  # ... "beside": the hinge's point within this many points of the landing point
ITER_BUDGET = 60  # Newton iterations of stage 1 over all its rounds in a step that may still be halved: past
#   them it is (at N = 512, accepted steps took at most 45, 99.99% of them 30 or fewer; the attempts that
#   failed, 200-1500, 8% of the factorisations of a fall)
POS_TOL = 1e-10  # b: stage 1 meets every row to this, plus the round-off of the heights (1e-12 before:
#   the convergence table and the top the same to the digits shown, 14% fewer iterations at N = 256)
POS_ROUNDOFF = 4e-16  # ... times the chain's height 2N (positions are stored, not summed)
EARLY_ROUNDS = 4  # rounds of stage 1 in which rows found far past their limit are switched on within the iteration
EARLY_MARGIN = 10.0  # ... "far": by more than this many times the iterate's residual
EARLY_RES = 1e-6  # ... and the whole complementarity checked once the residual is below this (b), with
#   the same margin: a bend row released for pulling at an iterate that has not met it (|g| <= the
#   residual) is not switched on again by its own gap (that flip left the set as it was, round
#   after round: 8% of the steps at N = 256 took 5 rounds or more, 1% with the margin)
RATE_TOL = 1e-10  # sqrt(g b): a released hinge closing faster than this is put back in stage 2
REBOUND_TOL = 0.02  # a step with rebounds may raise U + T by this fraction of the energy they carry (the
#   approach rate is estimated within the step, ``impact_rates``: its error does not shrink with a
#   shorter step from the same start)
MAX_NEW = 32  # new contacts in one step whose approach rates are estimated together (``impact_rates``)
HOLD_RATE = 1e-6  # sqrt(g b): a rebound slower than this is not made (held: the event method's default threshold)
FLIGHT_STEPS = 4.0  # ... nor one off the floor whose flight, 2 v / g, would last fewer steps than this: a
#   point resting on the floor reaches it again at g h a step, and at HOLD_RATE alone bounced every other
#   step for good (N = 512 at E = 0.3: the step cut to 1/500 of its size and 600 000 bounces a point)
ROOT_TURN = 0.5  # rad: a stage 1 that turns a segment further (5 turn limits) found another root of its equations

# run_steps codes (negative: the run cannot go on)
RT_STOP, RT_BUFFER, RT_RETURN, RT_LANDED, RT_MAX_STEPS = 0, 2, 11, 10, 5
ERR_NEWTON, ERR_ACTIVE_SET, ERR_STEP_ENERGY, ERR_STEP_NAN, ERR_NAN = -1, -2, -3, -4, -6
ERR_REBOUND = -8  # a step's rebounds created energy (Newton's law at several contacts, some held): taken
#   again with its impacts inelastic (as the event method takes such an impact; not returned by run_steps)
ERR_MERGED = -7  # a landing and a lock beside it in one step: taken again halved (not returned by run_steps)

# The state a step advances: the centres and their velocities beside the chain's axes,
# anchors and locks (the main state aliases the chain's arrays; a frame's is a copy).
Motion = namedtuple(
    "Motion",
    [
        "c",  # (N, 3): centres
        "e",  # (N, 3): axes (lower end -> upper end)
        "vc",  # (N, 3): the centres' velocities
        "ve",  # (N, 3): the axes' velocities de/dt
        "anchored",  # (N+1,) uint8 (2 while its landing impact is solved)
        "anchor_pos",  # (N+1, 3)
        "anchor_t",  # (N+1,)
        "locked",  # (N-1,) uint8: bend rows active (stage 1), taking impulse (stage 2)
        "touching",  # (N+1,) uint8: on a frictionless floor, the point's floor row is active (after stage 2)
    ],
)

# A step's scratch and what it hands to the books.
Scratch = namedtuple(
    "Scratch",
    [
        "start",  # Motion: the state at the step's start (its frames are stepped from it)
        "ukc", "uke",  # (N, 3): the velocity after a half kick of gravity
        "val",  # (N+1, RMAX): row values (stage 1) or rates before (stage 2)
        "rate",  # (N+1, RMAX): rates after
        "floor_on",  # (N+1,) uint8: floor rows active in stage 1 (none in stage 2)
        "cand",  # (N-1,) uint8: stage 2's candidates, the hinges at their limit after stage 1
        "kind1", "nrow1", "x1", "rb1", "ra1",  # stage 1's layout, impulses, rates before/after
        "kind_old", "nrow_old", "x_old",  # a layout before the last switch (carry-over)
        "kind_w", "nrow_w", "x_w",  # the last accepted step's stage 2 impulses: the next stage 1's warm start
        "new_anchor",  # (N+1,) int64: points anchored in this step
        "pts",  # (N+1, 3): point positions
        "acc",  # (10,): [0] lost at hinges, [1] lost at landings, [2:5] anchors' impulse,
        #   [5] factorisations, [6] new anchors, [7] Newton iterations, [8] U + T at the
        #   step's start minus at its end, [9] 1 if the step had an impact
        "pull",  # (3,): the pile's impulse on the hanging chain in the step
        "h_last",  # (1,): the step of that stage 2 (its impulses, the warm start, scale with it)
        "unmet",  # (3,): where stage 1 last failed: the point, the row's kind, its value
        "fcand",  # (N+1,) uint8: on a frictionless floor, stage 2's candidates at the floor
        "rebound",  # (N+1,): a point bouncing off the floor in this step: the upward velocity it leaves with
        "hrebound",  # (N-1,): a hinge that rebounds from its limit in this step: the rate it leaves with
        "newrow",  # (MAX_NEW, 2) int64: the new contacts of a step (point, row), ``impact_rates``
        "inelastic",  # (1,) uint8: 1 while a step is taken again with its impacts inelastic (ERR_REBOUND)
    ],
)  # fmt: skip


def new_scratch(n: int) -> Scratch:
    from .rows import RMAX

    nh = max(n - 1, 0)
    v3 = lambda m: np.zeros((m, 3))  # noqa: E731
    p = n + 1
    return Scratch(
        new_motion(n),
        v3(n), v3(n),
        np.zeros((p, RMAX)), np.zeros((p, RMAX)),
        np.zeros(p, np.uint8), np.zeros(nh, np.uint8),
        np.zeros((p, RMAX), np.int8), np.zeros(p, np.int64), np.zeros((p, RMAX)), np.zeros((p, RMAX)), np.zeros((p, RMAX)),
        np.zeros((p, RMAX), np.int8), np.zeros(p, np.int64), np.zeros((p, RMAX)),
        np.zeros((p, RMAX), np.int8), np.zeros(p, np.int64), np.zeros((p, RMAX)),
        np.zeros(p, np.int64), v3(p), np.zeros(10), np.zeros(3), np.zeros(1), np.zeros(3), np.zeros(p, np.uint8),
        np.zeros(p), np.zeros(nh), np.zeros((MAX_NEW, 2), np.int64), np.zeros(1, np.uint8),
    )  # fmt: skip


# What a frame inside a step is stepped with: its own state, workspace and scratch.
FrameWork = namedtuple("FrameWork", ["motion", "ws", "sc"])


def new_frame_work(n: int) -> FrameWork:
    from .rows import new_rows

    return FrameWork(new_motion(n), new_rows(n), new_scratch(n))


def new_motion(n: int) -> Motion:
    """A free-standing state (a frame's copy)."""
    p = n + 1
    return Motion(
        np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)),
        np.zeros(p, np.uint8), np.zeros((p, 3)), np.zeros(p), np.zeros(max(n - 1, 0), np.uint8),
        np.zeros(p, np.uint8),
    )  # fmt: skip


@njit(cache=True)
def maximal_state(e, w, c, vc, ve):
    """Centres c, their velocities vc and the axes' velocities ve = w x e of the chain
    with axes e and rates w standing on point N at the origin."""
    n = e.shape[0]
    px, py, pz = 0.0, 0.0, 0.0  # the lower end of segment i and its velocity
    ux, uy, uz = 0.0, 0.0, 0.0
    for i in range(n - 1, -1, -1):
        dx = w[i, 1] * e[i, 2] - w[i, 2] * e[i, 1]
        dy = w[i, 2] * e[i, 0] - w[i, 0] * e[i, 2]
        dz = w[i, 0] * e[i, 1] - w[i, 1] * e[i, 0]
        c[i, 0], c[i, 1], c[i, 2] = px + e[i, 0], py + e[i, 1], pz + e[i, 2]
        ve[i, 0], ve[i, 1], ve[i, 2] = dx, dy, dz
        vc[i, 0], vc[i, 1], vc[i, 2] = ux + dx, uy + dy, uz + dz
        px, py, pz = px + 2.0 * e[i, 0], py + 2.0 * e[i, 1], pz + 2.0 * e[i, 2]
        ux, uy, uz = ux + 2.0 * dx, uy + 2.0 * dy, uz + 2.0 * dz


@njit(cache=True)
def kinetic_energy_rattle(vc, ve):
    """T = sum 1/2 |c_i'|^2 + 1/6 |e_i'|^2 (m g b)."""
    tc, te = 0.0, 0.0
    for i in range(vc.shape[0]):
        tc += vc[i, 0] * vc[i, 0] + vc[i, 1] * vc[i, 1] + vc[i, 2] * vc[i, 2]
        te += ve[i, 0] * ve[i, 0] + ve[i, 1] * ve[i, 1] + ve[i, 2] * ve[i, 2]
    return 0.5 * tc + te / 6.0


@njit(cache=True)
def position_tol(n):
    """What stage 1 meets each row to (b): POS_TOL plus the round-off of heights up to 2n
    (n: the segments a step works on, ``active_points``: the rest lie on the floor)."""
    return POS_TOL + POS_ROUNDOFF * 2.0 * n


@njit(cache=True)
def _copy(src, dst):
    for i in range(src.shape[0]):
        for q in range(src.shape[1]):
            dst[i, q] = src[i, q]


@njit(cache=True)
def copy_motion(a, b):
    """b <- a (every array of a Motion)."""
    _copy(a.c, b.c)
    _copy(a.e, b.e)
    _copy(a.vc, b.vc)
    _copy(a.ve, b.ve)
    _copy(a.anchor_pos, b.anchor_pos)
    for j in range(a.anchored.shape[0]):
        b.anchored[j] = a.anchored[j]
        b.anchor_t[j] = a.anchor_t[j]
        b.touching[j] = a.touching[j]
    for k in range(a.locked.shape[0]):
        b.locked[k] = a.locked[k]


@njit(cache=True)
def half_kick(h, anchored, vc, ve, ukc, uke):
    """u + h/2 W f: gravity's half kick on the centres of the segments not landed."""
    for i in range(vc.shape[0]):
        landed = is_landed(anchored, i)
        for q in range(3):
            ukc[i, q] = 0.0 if landed else vc[i, q]
            uke[i, q] = 0.0 if landed else ve[i, q]
        if not landed:
            ukc[i, 2] -= 0.5 * h


@njit(cache=True)
def add_impulses(h, mo, ws, sc, move):
    """u = u_kick + W J^T x on the segments not landed, W = diag(1, 3) (u_kick: sc.ukc,
    sc.uke; the forces of ws's rows and impulses gathered per segment,
    ``rows.segment_force``), and with ``move`` the drift q+ = q0 + h u (q0: sc.start) in
    the same pass."""
    anchored, J, kind, nrow, x = mo.anchored, ws.J, ws.kind, ws.nrow, ws.x
    ukc, uke, vc, ve, c0, e0, c, e = sc.ukc, sc.uke, mo.vc, mo.ve, sc.start.c, sc.start.e, mo.c, mo.e
    for i in range(vc.shape[0]):
        if is_landed(anchored, i):
            for q in range(3):
                vc[i, q] = 0.0
                ve[i, q] = 0.0
            continue
        f0, f1, f2, f3, f4, f5 = segment_force(J, kind, nrow, x, i)
        vc[i, 0], vc[i, 1], vc[i, 2] = ukc[i, 0] + f0, ukc[i, 1] + f1, ukc[i, 2] + f2
        ve[i, 0], ve[i, 1], ve[i, 2] = uke[i, 0] + 3.0 * f3, uke[i, 1] + 3.0 * f4, uke[i, 2] + 3.0 * f5
        if move:
            for q in range(3):
                c[i, q] = c0[i, q] + h * vc[i, q]
                e[i, q] = e0[i, q] + h * ve[i, q]


@njit(cache=True)
def _work(kind, nrow, x, before, after, which):
    """sum over the rows of kind ``which`` (K_BEND, K_FLOOR: both floor kinds; -1: anchor rows) of
    P (rate before + rate after) / 2: what their impulses did to T."""
    s = 0.0
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            k = kind[j, r]
            if which == K_FLOOR:
                hit = is_floor(k)
            else:
                hit = k == which if which >= 0 else (K_ANCHOR_LOWER <= k < K_AXIS)
            if hit:
                s += 0.5 * x[j, r] * (before[j, r] + after[j, r])
    return s


@njit(cache=True)
def _new_anchor_work(anchored, kind, nrow, x, before, after):
    """What the anchor rows of the anchors made in this step (marked 2), and of the points
    bouncing off the floor in it (anchor rows at a free point: ``rows.BOUNCE``), did to T."""
    s = 0.0
    for j in range(nrow.shape[0]):
        if anchored[j] == 1:
            continue
        for r in range(nrow[j]):
            k = kind[j, r]
            if K_ANCHOR_LOWER <= k < K_AXIS:
                s += 0.5 * x[j, r] * (before[j, r] + after[j, r])
    return s


@njit(cache=True)
def _anchor_impulse(kind, nrow, x, acc):
    """acc[2:5] += the anchors' and the floor's impulse on the chain (rows' P)."""
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            k = kind[j, r]
            if K_ANCHOR_LOWER <= k < K_AXIS:
                acc[2 + (k - K_ANCHOR_LOWER) % 3] += x[j, r]
            elif is_floor(k):
                acc[4] += x[j, r]


@njit(cache=True)
def _pile_impulse(anchored, kind, nrow, x, pull):
    """pull += the impulse of the first anchored point from the top on the segment above
    it (its lower-anchor rows): the pile's pull on the hanging chain."""
    for j in range(anchored.shape[0]):
        if anchored[j] != 0:
            if j > 0:
                for r in range(nrow[j]):
                    k = kind[j, r]
                    if K_ANCHOR_LOWER <= k < K_ANCHOR_UPPER:
                        pull[k - K_ANCHOR_LOWER] += x[j, r]
            return


@njit(cache=True)
def _switch_stage1(model, mo, kind, nrow, x, floor_on, tol):
    """The complementarity of stage 1 at q+ (rows ``kind``, ``nrow``, impulses ``x``): a
    bend or floor row whose impulse pulls is switched off; a hinge in force or a free
    point found past its limit by more than tol switched on (``switch_on_violated``).
    Returns whether the active set changed.  (Arrays, not the scratch bundle: a call
    with a bundle costs numba a reference count of each of its arrays.)"""
    changed = False
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            k = kind[j, r]
            if x[j, r] < 0.0:
                if k == K_BEND:
                    mo.locked[j - 1] = 0
                    changed = True
                elif is_floor(k):
                    floor_on[j] = 0
                    changed = True
    return switch_on_violated(model, mo, floor_on, tol) or changed


@njit(cache=True)
def switch_on_violated(model, mo, floor_on, margin):
    """A hinge in force past its limit, or a free point below the floor, by more than
    ``margin`` is switched on.  Inside stage 1's Newton iteration the margin is far beyond
    what the iterate's residual can account for: the set is known wrong before the
    iteration has met its rows.  Returns whether any was."""
    anchored, locked, e = mo.anchored, mo.locked, mo.e
    changed = False
    for k in range(locked.shape[0]):
        if locked[k] == 0:
            g = e[k, 0] * e[k + 1, 0] + e[k, 1] * e[k + 1, 1] + e[k, 2] * e[k + 1, 2] - model.cos_alpha
            if g < -margin and limit_in_force(anchored, k, model.cone, model.alpha):
                locked[k] = 1
                changed = True
    for j in range(e.shape[0] + 1):  # (the last point: the bottom end, free on a frictionless floor)
        if anchored[j] == 0 and floor_on[j] == 0 and point_z(mo, j) < -margin:
            floor_on[j] = 1
            changed = True
    return changed


@njit(cache=True, inline="always")
def point_z(mo, j):
    """z_j: the upper end of segment j, or, for the last point (j = the number of segments),
    the lower end of the segment above it."""
    if j < mo.e.shape[0]:
        return mo.c[j, 2] + mo.e[j, 2]
    return mo.c[j - 1, 2] - mo.e[j - 1, 2]


@njit(cache=True, inline="always")
def point_vz(mo, j):
    """dz_j/dt (``point_z``'s rate)."""
    if j < mo.e.shape[0]:
        return mo.vc[j, 2] + mo.ve[j, 2]
    return mo.vc[j - 1, 2] - mo.ve[j - 1, 2]


@njit(cache=True)
def _factor(anchored, locked, floor_on, kind_old, nrow_old, acc, ws, e, reuse, factor, keep):
    """The rows of the current layout at axes e, and (with ``factor``) the factors of
    J W J^T; with ``reuse``, those of the last stage 2 (at these axes, ws.valid) if its
    layout is this one: a step's stage 1 starts where the last stage 2 ended, with its
    active set.  With ``keep`` (ws holds the rows at these axes of the last layout, and
    the factors of J W J^T if ``factor``) only the points from the one before the first
    changed point are done again.  Returns (whether ws holds the factors of J W J^T for
    these rows (without them, no row is marked redundant), that first point done again).
    (kind_old, nrow_old: scratch for the layout; acc[5] counts the factorisations.)"""
    layout(anchored, locked, floor_on, kind_old, nrow_old)
    first = first_change(kind_old, nrow_old, ws.kind, ws.nrow)
    if reuse and ws.valid[0] != 0 and first == ws.nrow.shape[0]:
        return True, first
    ws.valid[0] = 0
    j0 = max(first - 1, 0) if keep else 0
    layout(anchored, locked, floor_on, ws.kind, ws.nrow)
    row_gradients(e, ws.kind, ws.nrow, ws.J, j0)
    if factor:
        _factor_symmetric(anchored, ws, acc, j0)
    else:
        for j in range(ws.nrow.shape[0]):
            for r in range(ws.nrow[j]):
                ws.sym.drop[j, r] = 0
    return factor, j0


@njit(cache=True)
def _factor_symmetric(anchored, ws, acc, j0):
    """The factors of J W J^T for the rows in ws (ws.sym), its redundant rows dropped, from
    point j0 on (``blocks.factor_blocks``); acc[5] counts it."""
    factor_blocks(anchored, ws.J, ws.J, ws.kind, ws.nrow, ws.sym.drop, ws.sym, True, j0)
    acc[5] += 1.0


@njit(cache=True)
def _factor_newton(mo, ws, j0):
    """The factors of stage 1's Newton matrix J(q+) W J(q)^T (ws.newt), from point j0 on:
    the rows at q+ (J1) taken there, the rows that ws.sym drops dropped; False if it is
    singular to round-off."""
    row_gradients(mo.e, ws.kind, ws.nrow, ws.J1, j0)
    return factor_blocks(mo.anchored, ws.J1, ws.J, ws.kind, ws.nrow, ws.sym.drop, ws.newt, False, j0) >= 0


@njit(cache=True)
def first_change(kind_a, nrow_a, kind_b, nrow_b):
    """The first point whose rows differ between two layouts (the number of points if none)."""
    for j in range(nrow_a.shape[0]):
        if nrow_a[j] != nrow_b[j]:
            return j
        for r in range(nrow_a[j]):
            if kind_a[j, r] != kind_b[j, r]:
                return j
    return nrow_a.shape[0]


@njit(cache=True)
def stage1(h, model, mo, ws, sc, budget):
    """Stage 1 (module docstring): q+ and u_half in mo, the impulses P1 in ws.x, their
    layout kept in sc (kind1, nrow1, x1) with the rates before and after of the rows the
    books take (rb1, ra1: ``booked_rates``).  Returns 0, ERR_NEWTON (also after ``budget``
    Newton iterations over all rounds) or ERR_ACTIVE_SET."""
    n = mo.e.shape[0]
    tol = position_tol(n)
    half_kick(h, mo.anchored, mo.vc, mo.ve, sc.ukc, sc.uke)
    for j in range(sc.floor_on.shape[0]):  # (a point that touched the floor at the last step starts on it)
        sc.floor_on[j] = 1 if (mo.touching[j] != 0 and mo.anchored[j] == 0) else 0
    newt_valid = False  # ws.newt holds the factors of a Newton matrix of this stage ...
    newt_from = 0  # ... whose rows are those of the current layout at the points before this one
    for rnd in range(ROUNDS_MAX):
        if rnd > 0:  # (the last round's layout and impulses: kept past _factor for the carry-over)
            copy_layout(sc.kind_old, sc.nrow_old, sc.x_old, sc.kind1, sc.nrow1, sc.x1)
        have_sym, j0 = _factor(
            mo.anchored, mo.locked, sc.floor_on, sc.kind_old, sc.nrow_old, sc.acc, ws, sc.start.e, rnd == 0, False,
            rnd > 0,
        )  # (J W J^T only if the last stage 2's serves)  # fmt: skip
        newt_from = min(newt_from, j0)  # (a round that did not factor A leaves its factors to the next)
        restart = newt_from if newt_valid else 0  # the Newton matrix's factors kept for the points before it
        _first_guess(h, rnd, ws, sc)
        met = False
        exact = False  # the symmetric factors while each iteration cuts the residual NEWTON_RATE-fold, then A
        singular = False  # A was singular to round-off: the chord on J W J^T only
        switched = False  # rows switched on before the iteration met its rows
        last = math.inf
        for it in range(NEWTON_MAX):
            if sc.acc[7] >= budget:
                _record_unmet(ws, sc)
                return ERR_NEWTON
            add_impulses(h, mo, ws, sc, True)
            res = row_values(mo.c, mo.e, mo.anchor_pos, model.cos_alpha, ws.kind, ws.nrow, sc.val)
            sc.acc[7] += 1.0
            if res <= tol:
                met = True
                break
            if not math.isfinite(res):
                break
            if rnd < EARLY_ROUNDS and (
                switch_on_violated(model, mo, sc.floor_on, max(tol, EARLY_MARGIN * res))
                or (
                    res <= EARLY_RES
                    and _switch_stage1(model, mo, ws.kind, ws.nrow, ws.x, sc.floor_on, max(tol, EARLY_MARGIN * res))
                )
            ):
                switched = True
                break  # a limit or the floor passed by far more than the residual: the set is wrong, not yet the iterate
            for j in range(ws.nrow.shape[0]):
                for r in range(ws.nrow[j]):
                    ws.rhs[j, r] = -sc.val[j, r] / h
            if (not exact) and (singular or (have_sym and (it == 0 or res <= NEWTON_RATE * last))):
                solve_blocks(ws.nrow, ws.sym, ws.rhs, sc.rate)  # the chord on J W J^T
            else:
                if not exact or res > NEWTON_RATE * last:  # (re)factor A at this q+
                    sc.acc[5] += 1.0
                    exact = _factor_newton(mo, ws, restart if not exact else 0)
                    restart = 0
                    newt_from = ws.nrow.shape[0]
                    singular = not exact
                    if singular and not have_sym:  # J W J^T, its redundant rows dropped, and A again
                        _factor_symmetric(mo.anchored, ws, sc.acc, 0)
                        have_sym = True
                        sc.acc[5] += 1.0
                        exact = _factor_newton(mo, ws, 0)
                        singular = not exact
                    newt_valid = exact
                if exact:
                    solve_blocks(ws.nrow, ws.newt, ws.rhs, sc.rate)
                else:
                    solve_blocks(ws.nrow, ws.sym, ws.rhs, sc.rate)
            last = res
            for j in range(ws.nrow.shape[0]):
                for r in range(ws.nrow[j]):
                    ws.x[j, r] += sc.rate[j, r]
        if switched:  # a new round with the rows switched on, from these impulses
            copy_layout(ws.kind, ws.nrow, ws.x, sc.kind_old, sc.nrow_old, sc.x_old)
            continue
        if not met:
            _record_unmet(ws, sc)
            if not _release_unmet_bend(mo, ws, sc):
                return ERR_NEWTON
            for j in range(ws.nrow.shape[0]):  # (a diverged iterate is no warm start)
                for r in range(ws.nrow[j]):
                    if not abs(ws.x[j, r]) < 1e30:
                        ws.x[j, r] = 0.0
            copy_layout(ws.kind, ws.nrow, ws.x, sc.kind_old, sc.nrow_old, sc.x_old)
            continue
        copy_layout(ws.kind, ws.nrow, ws.x, sc.kind_old, sc.nrow_old, sc.x_old)
        if not _switch_stage1(model, mo, ws.kind, ws.nrow, ws.x, sc.floor_on, tol):
            copy_layout(ws.kind, ws.nrow, ws.x, sc.kind1, sc.nrow1, sc.x1)
            booked_rates(ws.J, ws.kind, ws.nrow, mo.anchored, sc.ukc, sc.uke, sc.rb1)
            booked_rates(ws.J, ws.kind, ws.nrow, mo.anchored, mo.vc, mo.ve, sc.ra1)
            return 0
    return ERR_ACTIVE_SET


@njit(cache=True)
def _first_guess(h, rnd, ws, sc):
    """Stage 1's impulses to start a round from (ws.x): in the first, the last accepted
    step's stage 2 impulses (h/2 times the forces at this step's start), scaled to this
    step (a non-finite impulse is no warm start); in a later one, the last round's, row by
    row (``carry_over``)."""
    if rnd > 0:
        carry_over(sc.kind1, sc.nrow1, sc.x1, ws.kind, ws.nrow, ws.x)
        return
    carry_over(sc.kind_w, sc.nrow_w, sc.x_w, ws.kind, ws.nrow, ws.x)
    scale = h / sc.h_last[0] if sc.h_last[0] > 0.0 else 1.0
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            ws.x[j, r] = ws.x[j, r] * scale if abs(ws.x[j, r]) < 1e30 else 0.0


@njit(cache=True)
def _record_unmet(ws, sc):
    """sc.unmet <- the row of stage 1 furthest from being met (sc.val): point, kind, value
    (a non-finite value first)."""
    worst = -1.0
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            v = abs(sc.val[j, r])
            if not math.isfinite(v) or v > worst:
                if not math.isfinite(v):
                    sc.unmet[0], sc.unmet[1], sc.unmet[2] = j, ws.kind[j, r], sc.val[j, r]
                    return
                worst = abs(sc.val[j, r])
                sc.unmet[0], sc.unmet[1], sc.unmet[2] = j, ws.kind[j, r], sc.val[j, r]


@njit(cache=True)
def _release_unmet_bend(mo, ws, sc):
    """Stage 1's Newton did not meet its rows: the active set is likely wrong, not the
    step.  The bend rows whose impulses pull are switched off, or else, if the row furthest
    from met (sc.unmet) is a bend row, that one.  Returns whether any was."""
    released = False
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            if ws.kind[j, r] == K_BEND and ws.x[j, r] < 0.0:
                mo.locked[j - 1] = 0
                released = True
    if not released and int(sc.unmet[1]) == K_BEND:
        mo.locked[int(sc.unmet[0]) - 1] = 0
        released = True
    return released


@njit(cache=True)
def land(t, h, model, mo, sc):
    """Step 2: the points that stage 1 stopped at the floor are anchored there, for good
    (marked 2 while stage 2 solves their impact; where: ``rules.hold_at``).  Returns
    their number (listed in sc.new_anchor).  With restitution at the floor a point that
    would leave it faster than HOLD_RATE (``newton.floor_rebound`` of the vertical velocity
    it reached the floor with, ``impact_rates``), on a flight of FLIGHT_STEPS steps of h
    or more (v > FLIGHT_STEPS g h / 2), bounces instead: not anchored, listed, its
    velocity's rows in stage 2 (``rows.BOUNCE``: sc.rebound its upward velocity).  A
    shorter flight is not resolved by the steps: the series of bounces ends there, at
    the step's scale, and the point is anchored.  On a
    frictionless floor (``coulomb.slides``)
    nothing is anchored: the points that stage 1 stopped and that were not touching it
    are its new contacts (listed; a first touch's time in anchor_t), and the floor rows
    stay on for stage 2."""
    slide = slides(model.friction)
    v_min = max(HOLD_RATE, 0.5 * FLIGHT_STEPS * h)  # (g = 1)
    c, e = mo.c, mo.e
    n = e.shape[0]
    for j in range(n):
        for q in range(3):
            sc.pts[j, q] = c[j, q] + e[j, q]
    for q in range(3):
        sc.pts[n, q] = c[n - 1, q] - e[n - 1, q]
    na = 0
    for j in range(n + 1):
        approach = sc.rebound[j]  # (``impact_rates``: 0 without restitution)
        sc.rebound[j] = 0.0
        if slide:
            if sc.floor_on[j] != 0 and mo.touching[j] == 0:
                if not mo.anchor_t[j] == mo.anchor_t[j]:  # (NaN: its first touch)
                    mo.anchor_t[j] = t
                sc.new_anchor[na] = j
                na += 1
            continue
        if sc.floor_on[j] != 0 and mo.anchored[j] == 0:
            v = floor_rebound(approach, model.e_floor)  # (0 for e_floor 0)
            if v > v_min:  # it bounces: not anchored; stage 2 gives it (0, 0, v)
                sc.rebound[j] = v
                sc.floor_on[j] = BOUNCE
                sc.new_anchor[na] = j
                na += 1
                continue
            hold_at(mo, j, sc.pts)
            mo.anchored[j] = 2
            mo.anchor_t[j] = t
            sc.new_anchor[na] = j
            na += 1
        sc.floor_on[j] = 0
    return na


@njit(cache=True)
def _switch_stage2(mo, ws, sc, slide):
    """The impact law of stage 2: a hinge whose impulse pulls is released; a candidate
    released that closes (dg/dt < -RATE_TOL), or with restitution separates slower than its
    rebound (sc.hrebound), is put back; the same for the floor's rows on
    a frictionless floor (``slide``: ``coulomb.released``, ``coulomb.closes``).  Returns
    whether the set changed."""
    e, ve, locked = mo.e, mo.ve, mo.locked
    changed = False
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            if ws.kind[j, r] == K_BEND and ws.x[j, r] < 0.0:
                locked[j - 1] = 0
                changed = True
            elif is_floor(ws.kind[j, r]) and released(ws.x[j, r]):
                sc.floor_on[j] = 0
                changed = True
    for j in range(sc.fcand.shape[0] if slide else 0):
        if sc.fcand[j] != 0 and sc.floor_on[j] == 0 and closes(point_vz(mo, j), RATE_TOL):
            sc.floor_on[j] = 1
            changed = True
    for k in range(locked.shape[0]):
        if sc.cand[k] != 0 and locked[k] == 0:
            rate = 0.0
            for q in range(3):
                rate += ve[k, q] * e[k + 1, q] + e[k, q] * ve[k + 1, q]
            if rate - sc.hrebound[k] < -RATE_TOL:  # (Newton's law: xi = rate + e rate-, sc.hrebound = -e rate-)
                locked[k] = 1
                changed = True
    return changed


@njit(cache=True)
def stage2(h, model, mo, ws, sc):
    """Stage 2 (module docstring): u+ in mo, P2 in ws.x, the rows' rates before (sc.val)
    and after (sc.rate: the rows the books take, ``booked_rates``).  The candidates (hinges in force active in stage 1 or at their
    limit within the position tolerance) start all locked.  Returns 0 or ERR_ACTIVE_SET (a
    singular solve leaves velocities that are not finite: ``rattle_step`` refuses the step)."""
    e, anchored, locked = mo.e, mo.anchored, mo.locked
    tol = position_tol(e.shape[0])
    half_kick(h, anchored, mo.vc, mo.ve, sc.ukc, sc.uke)
    for k in range(locked.shape[0]):
        g = e[k, 0] * e[k + 1, 0] + e[k, 1] * e[k + 1, 1] + e[k, 2] * e[k + 1, 2] - model.cos_alpha
        cand = (locked[k] != 0 or g <= tol) and limit_in_force(anchored, k, model.cone, model.alpha)
        sc.cand[k] = 1 if cand else 0
        locked[k] = sc.cand[k]
    bounce = restitution(model)
    for k in range(locked.shape[0] if bounce else 0):  # (sc.hrebound: the approach rates, ``impact_rates``)
        v = -model.e_lock * sc.hrebound[k] if sc.cand[k] != 0 else 0.0
        sc.hrebound[k] = v if v > HOLD_RATE else 0.0
    slide = slides(model.friction)  # (else sc.floor_on is all 0 after ``land``: no floor rows)
    for j in range(sc.fcand.shape[0] if slide else 0):  # the floor's candidates: active in stage 1, or at it
        on = anchored[j] == 0 and (sc.floor_on[j] != 0 or point_z(mo, j) <= tol)
        sc.fcand[j] = 1 if on else 0
        sc.floor_on[j] = sc.fcand[j]
    for rnd in range(ROUNDS_MAX):
        _factor(mo.anchored, mo.locked, sc.floor_on, sc.kind_old, sc.nrow_old, sc.acc, ws, e, False, True, rnd > 0)
        row_rates(ws.J, ws.kind, ws.nrow, sc.ukc, sc.uke, sc.val)
        for j in range(ws.nrow.shape[0]):
            for r in range(ws.nrow[j]):
                ws.rhs[j, r] = -sc.val[j, r]
        if bounce:
            rebound_targets(anchored, ws, sc)
        solve_blocks(ws.nrow, ws.sym, ws.rhs, ws.x)
        add_impulses(h, mo, ws, sc, False)
        if not _switch_stage2(mo, ws, sc, slide):  # (a singular solve: U + T is not finite, ``rattle_step``)
            booked_rates(ws.J, ws.kind, ws.nrow, anchored, mo.vc, mo.ve, sc.rate)
            ws.valid[0] = 1
            for j in range(sc.fcand.shape[0] if slide else 0):  # (on a frictionless floor: its contacts)
                mo.touching[j] = sc.floor_on[j]
            if bounce:
                leave_limits(mo, sc)
            return 0
    return ERR_ACTIVE_SET


@njit(cache=True, inline="always")
def _is_new_contact(k, locked0, mark, p):
    """Is a row of kind k, after stage 1, a new contact: the bend row of a hinge not locked
    at the step's start (locked0), or the floor row of a free point (its mark in
    ``anchored``: 0), with impulse p > 0?  (Numbers, not the bundles: a call with them in
    the loop over the rows costs numba a reference count of each of their arrays.)"""
    bend = k == K_BEND and locked0 == 0
    return (bend or (is_floor(k) and mark == 0)) and p > 0.0


@njit(cache=True)
def impact_rates(h, model, mo, ws, sc):
    """After stage 1, with restitution: the rate at which each new contact reached its
    limit (``_is_new_contact``), into sc.hrebound (hinges) and sc.rebound (points); 0
    elsewhere.  The impacts fall inside the step: from a row's gap g0 and rate v0 at the
    step's start and its free mean rate over the step vbar (the rates at u_half less what
    the new contacts' impulses P_B did: vbar_B = rate_B - ((G^-1)_BB)^-1 P_B, G = J W J^T
    at the step's start with the joints, anchors and held rows; one solve per new
    contact, MAX_NEW at most, else none is estimated: a touch), with d2g/dt2 = a =
    2 (vbar - v0) / h, the row reaches its limit at -sqrt(v0^2 - 2 a g0).  It takes the
    inelastic law instead (0) where its free motion would not reach its limit in the step
    (g0 + h vbar > 0: the others' impulses pushed it there, as in the event method's second
    pass), and where it was leaving its limit at the step's start (v0 > 0: it rebounded at
    the last step and is back within one; the series of ever smaller rebounds ends at the
    step's scale, as the accumulation rule ends it in the event method).  Second order in
    the impact's time into the step; the step start's own rate errs by a tau, which
    halving the step does not shorten."""
    for k in range(sc.hrebound.shape[0]):
        sc.hrebound[k] = 0.0
    for j in range(sc.rebound.shape[0]):
        sc.rebound[j] = 0.0
    m = 0
    kind, nrow, x, locked0, anchored = ws.kind, ws.nrow, ws.x, sc.start.locked, mo.anchored
    for j in range(nrow.shape[0]):
        nk = locked0.shape[0]  # (hinge j - 1, at point j: its mark where it exists, clamped elsewhere, unused there)
        lock0 = locked0[min(max(j - 1, 0), nk - 1)] if nk > 0 else 0
        for r in range(nrow[j]):
            if _is_new_contact(kind[j, r], lock0, anchored[j], x[j, r]):
                if m < MAX_NEW:
                    sc.newrow[m, 0], sc.newrow[m, 1] = j, r
                m += 1
    if m == 0 or m > MAX_NEW:
        return
    _factor_symmetric(mo.anchored, ws, sc.acc, 0)
    ginv = np.zeros((m, m))
    for c in range(m):
        for jj in range(ws.nrow.shape[0]):
            for rr in range(ws.nrow[jj]):
                ws.rhs[jj, rr] = 0.0
        ws.rhs[sc.newrow[c, 0], sc.newrow[c, 1]] = 1.0
        solve_blocks(ws.nrow, ws.sym, ws.rhs, sc.rate)
        for b in range(m):
            ginv[b, c] = sc.rate[sc.newrow[b, 0], sc.newrow[b, 1]]
    p = np.zeros(m)
    for b in range(m):
        p[b] = ws.x[sc.newrow[b, 0], sc.newrow[b, 1]]
        if not ginv[b, b] > 0.0:  # (a redundant row: no estimate)
            return
    y = np.linalg.solve(ginv, p)
    st = sc.start
    for b in range(m):
        j, r = sc.newrow[b, 0], sc.newrow[b, 1]
        vbar = sc.ra1[j, r] - y[b]
        bend = ws.kind[j, r] == K_BEND
        if bend:
            g0, v0 = -model.cos_alpha, 0.0
            for q in range(3):
                g0 += st.e[j - 1, q] * st.e[j, q]
                v0 += st.ve[j - 1, q] * st.e[j, q] + st.e[j - 1, q] * st.ve[j, q]
        else:
            g0, v0 = point_z(st, j), point_vz(st, j)
        a = 2.0 * (vbar - v0) / h
        rad = v0 * v0 - 2.0 * a * max(g0, 0.0)
        v = -math.sqrt(rad) if (rad > 0.0 and v0 <= 0.0 and g0 + h * vbar <= 0.0) else 0.0
        if bend:
            sc.hrebound[j - 1] = v
        else:
            sc.rebound[j] = v


@njit(cache=True, inline="always")
def restitution(model):
    """Does either restitution law act (``contacts.newton``; 0, the default, is inelastic)?"""
    return model.e_lock > 0.0 or model.e_floor > 0.0


@njit(cache=True, inline="always")
def _bounce_row(anchored, j, k):
    """Is a row of kind k at point j the vertical row of a point bouncing off the floor
    (an anchor's z row at a free point: ``rows.BOUNCE``)?"""
    return anchored[j] == 0 and (k == K_ANCHOR_UPPER + 2 or k == K_ANCHOR_LOWER + 2)


@njit(cache=True)
def rebound_targets(anchored, ws, sc):
    """Stage 2's right-hand side with restitution: a rebounding hinge's row and a bouncing
    point's vertical row aim at the rate they leave with (G P = target - rate before)."""
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            k = ws.kind[j, r]
            if k == K_BEND:
                ws.rhs[j, r] += sc.hrebound[j - 1]
            elif _bounce_row(anchored, j, k):
                ws.rhs[j, r] += sc.rebound[j]


@njit(cache=True)
def rebound_energy(anchored, ws, sc):
    """(1/2) sum P2 v over the rows that rebound in stage 2 (v their target rate): about the
    kinetic energy the rebounds carry away from their limits."""
    s = 0.0
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            k = ws.kind[j, r]
            if k == K_BEND:
                s += 0.5 * abs(ws.x[j, r]) * sc.hrebound[j - 1]
            elif _bounce_row(anchored, j, k):
                s += 0.5 * abs(ws.x[j, r]) * sc.rebound[j]
    return s


@njit(cache=True)
def leave_limits(mo, sc):
    """After stage 2 with restitution: a hinge that took its impulse and rebounds is not
    locked (sc.hrebound stays its rate: ``commit`` logs its impact as a lock's); one that
    was released takes no rebound (0).  A bouncing point's floor rows are off again."""
    for k in range(mo.locked.shape[0]):
        if sc.hrebound[k] > 0.0:
            if mo.locked[k] != 0:
                mo.locked[k] = 0
            else:
                sc.hrebound[k] = 0.0
    for j in range(sc.floor_on.shape[0]):
        if sc.floor_on[j] == BOUNCE:
            sc.floor_on[j] = 0


@njit(cache=True)
def keep_warm_start(h, ws, sc):
    """After a step of size h is accepted: its stage 2's layout and impulses are the next
    stage 1's warm start (scaled to that step).  Not after a step that is refused: its
    stage 2 may hold an impact's impulses (a landing, a lock), far from h/2 times the
    forces, and from there the next stage 1's Newton can reach another assembly of a
    stretch closed between anchors (two segments' axes swapped) with huge impulses."""
    copy_layout(ws.kind, ws.nrow, ws.x, sc.kind_w, sc.nrow_w, sc.x_w)
    sc.h_last[0] = h


@njit(cache=True)
def settle(model, mo):
    """Step 4: the new anchors made (2 -> 1), a lock whose limit is no longer in force
    dropped, a landed segment put on its anchors (c = (p_j + p_{j+1}) / 2,
    e = (p_j - p_{j+1}) / 2) and at rest."""
    anchored, locked, pos = mo.anchored, mo.locked, mo.anchor_pos
    for j in range(anchored.shape[0]):
        if anchored[j] == 2:
            anchored[j] = 1
    for k in range(locked.shape[0]):
        if locked[k] and not limit_in_force(anchored, k, model.cone, model.alpha):
            locked[k] = 0
    for i in range(mo.e.shape[0]):
        if is_landed(anchored, i):
            for q in range(3):
                mo.c[i, q] = 0.5 * (pos[i, q] + pos[i + 1, q])
                mo.e[i, q] = 0.5 * (pos[i, q] - pos[i + 1, q])
                mo.vc[i, q] = 0.0
                mo.ve[i, q] = 0.0


@njit(cache=True)
def rattle_step(t, h, model, mo, ws, sc, etol, landings, split, budget):
    """One step of size h from t (stages 1-4 of the module docstring) on the state mo;
    what the books need is left in sc (acc, pull, new_anchor, stage 1's layout and
    rates; stage 2's in ws, sc.val, sc.rate).  With etol > 0 a step is refused
    (ERR_STEP_ENERGY) that changes U + T by more than etol without an impact, or raises
    it by more than etol with one (an impact removes energy).  Without ``landings`` (a
    frame's step, inside a step of the fall) a point stopped by the floor is not anchored:
    the fall anchors it, at its own step's end.  With ``split`` a step in which a point
    lands and a hinge beside it locks is refused (ERR_MERGED: ``_lock_beside_landing``).
    ``budget``: stage 1's Newton iterations at most.
    Returns (code, new anchors).  The stages see the chain down to its landed part only
    (``active_points``: views of the same arrays, its indices the chain's)."""
    for q in range(sc.acc.shape[0]):
        sc.acc[q] = 0.0
    for q in range(3):
        sc.pull[q] = 0.0
    copy_motion(mo, sc.start)  # (all of it: a refused step is undone from it)
    p = active_points(mo.anchored)
    _no_rows_from(p, ws, sc)
    return _step_points(
        t, h, model, motion_view(mo, p), rows_view(ws, p), scratch_view(sc, p), etol, landings, split, budget
    )


@njit(cache=True)
def active_points(anchored):
    """How many points, from the top, a step works on: down to the lower end of the segment
    below the lowest one not landed (the hinge between them may bear a limit: the anchor
    cone, ``rules.limit_in_force``).  Below them the chain has landed: no rows, no motion."""
    n = anchored.shape[0] - 1
    return min(bottom_airborne(anchored) + 3, n + 1)


@njit(cache=True)
def _no_rows_from(p, ws, sc):
    """No point from p on has rows (their last rows, from before the segments there
    landed, are not the layouts')."""
    for j in range(p, ws.nrow.shape[0]):
        ws.nrow[j] = 0
        sc.nrow1[j] = 0
        sc.nrow_old[j] = 0
        sc.nrow_w[j] = 0


@njit(cache=True)
def motion_view(mo, p):
    """The state of the chain's first p points (p - 1 segments): views."""
    s = p - 1
    return Motion(
        mo.c[:s], mo.e[:s], mo.vc[:s], mo.ve[:s], mo.anchored[:p], mo.anchor_pos[:p], mo.anchor_t[:p],
        mo.locked[: max(s - 1, 0)], mo.touching[:p],
    )  # fmt: skip


@njit(cache=True)
def rows_view(ws, p):
    """The rows of the first p points and their factors: views."""
    return Rows(
        ws.J[:p], ws.kind[:p], ws.nrow[:p], ws.rhs[:p], ws.x[:p], ws.J1[:p],
        factors_view(ws.sym, p), factors_view(ws.newt, p), ws.valid,
    )  # fmt: skip


@njit(cache=True)
def scratch_view(sc, p):
    """A step's scratch for the first p points: views (the counters whole)."""
    s, k = p - 1, max(p - 2, 0)
    return Scratch(
        motion_view(sc.start, p), sc.ukc[:s], sc.uke[:s], sc.val[:p], sc.rate[:p], sc.floor_on[:p], sc.cand[:k],
        sc.kind1[:p], sc.nrow1[:p], sc.x1[:p], sc.rb1[:p], sc.ra1[:p],
        sc.kind_old[:p], sc.nrow_old[:p], sc.x_old[:p], sc.kind_w[:p], sc.nrow_w[:p], sc.x_w[:p],
        sc.new_anchor[:p], sc.pts[:p], sc.acc, sc.pull, sc.h_last, sc.unmet, sc.fcand[:p], sc.rebound[:p],
        sc.hrebound[:k], sc.newrow, sc.inelastic,
    )  # fmt: skip


@njit(cache=True)
def _step_points(t, h, model, mo, ws, sc, etol, landings, split, budget):
    """``rattle_step`` on the points of the views (sc.start holds the step's start)."""
    e_start = mechanical_energy(mo.c, mo.vc, mo.ve)
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
    _anchor_impulse(sc.kind1, sc.nrow1, sc.x1, sc.acc)
    _pile_impulse(mo.anchored, sc.kind1, sc.nrow1, sc.x1, sc.pull)
    na, touched = 0, 0
    if landings or slides(model.friction):  # (a frame's step on a frictionless floor too: it anchors nothing)
        na = land(t + h, h, model, mo, sc)
    else:
        for j in range(sc.floor_on.shape[0]):
            touched += sc.floor_on[j]
            sc.floor_on[j] = 0
    sc.acc[6] = na
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
    _anchor_impulse(ws.kind, ws.nrow, ws.x, sc.acc)
    _pile_impulse(mo.anchored, ws.kind, ws.nrow, ws.x, sc.pull)
    if na > 0 and anchors(model.friction):  # (landed segments do not move: nothing else to settle)
        settle(model, mo)
        ws.valid[0] = 0  # landed segments: the columns of the factors are not the state's
    lost = e_start - mechanical_energy(mo.c, mo.vc, mo.ve)
    sc.acc[8] = lost
    if not math.isfinite(lost):  # (a singular stage: taken again halved, as a failed one)
        return ERR_STEP_NAN, na
    if na > 0 or touched > 0 or _new_lock(sc.start.locked, sc.kind1, sc.nrow1, sc.x1):
        sc.acc[9] = 1.0
        created = etol + (REBOUND_TOL * rebound_energy(mo.anchored, ws, sc) if bounce else 0.0)
        if etol > 0.0 and lost < -created:
            return (ERR_REBOUND if created > etol else ERR_STEP_ENERGY), na
        _book_impact(lost, lock_work, land_work, lock_after, na + touched, sc.acc)
    elif etol > 0.0 and abs(lost) > etol:
        return ERR_STEP_ENERGY, na
    return 0, na


@njit(cache=True)
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


@njit(cache=True)
def _largest_turn(e0, e1):
    """max_i |e1_i - e0_i|: how far a step turned its most turned segment (about the angle, rad)."""
    m = 0.0
    for i in range(e0.shape[0]):
        m = max(m, (e1[i, 0] - e0[i, 0]) ** 2 + (e1[i, 1] - e0[i, 1]) ** 2 + (e1[i, 2] - e0[i, 2]) ** 2)
    return math.sqrt(m)


@njit(cache=True)
def mechanical_energy(c, vc, ve):
    """U + T in maximal coordinates: sum c_i,z + 1/2 |c_i'|^2 + 1/6 |e_i'|^2 (m g b)."""
    u = 0.0
    for i in range(c.shape[0]):
        u += c[i, 2]
    return u + kinetic_energy_rattle(vc, ve)


@njit(cache=True)
def _new_lock(locked0, kind1, nrow1, x1):
    """Did a hinge not locked at the step's start take impulse in stage 1 (an impact)?"""
    for j in range(nrow1.shape[0]):
        for r in range(nrow1[j]):
            if kind1[j, r] == K_BEND and locked0[j - 1] == 0 and x1[j, r] > 0.0:
                return True
    return False


@njit(cache=True)
def lock_loss_after_landing(mo, ws, sc):
    """What a step's new locks dissipated after its landings, the impacts taken in the
    exact method's order: the landings first (with the locks held from the step's start),
    then the new locks.  Inelastic impacts are projections of u in the metric of M onto
    the velocities the rows allow, and those of all rows lie within those the landing's
    allow, so u+ is the same in either order and the locks' share is
    1/2 |Pi_land W G_b^T P_b|_M^2  (P_b: the new locks' impulses over both stages, G_b
    their rows at q+, Pi_land = 1 - W G_L^T (G_L W G_L^T)^{-1} G_L over the landing's
    rows G_L).  One more factorisation; ws.J1 and ws.newt (stage 1's) and the scratch
    that stage 2 is done with hold the work.  Returns -1 if no hinge locked anew."""
    e, anchored, locked = mo.e, mo.anchored, mo.locked
    n = e.shape[0]
    dc, de = sc.ukc, sc.uke
    for i in range(n):
        for q in range(3):
            dc[i, q] = 0.0
            de[i, q] = 0.0
    new = False
    for k in range(locked.shape[0]):
        sc.cand[k] = 0
        if sc.start.locked[k] != 0:
            continue
        p, _ = _hinge_impulse(k, sc.kind1, sc.nrow1, sc.x1, sc.rb1, sc.ra1, ws.kind, ws.nrow, ws.x, sc.val, sc.rate)
        if p == 0.0:
            continue
        new = True
        wa = _weights(anchored, k, n)[1]
        wc = _weights(anchored, k + 1, n)[1]
        for q in range(3):  # (the bend row's gradient: e_c on e_a, e_a on e_c)
            de[k, q] += wa * p * e[k + 1, q]
            de[k + 1, q] += wc * p * e[k, q]
        if locked[k] != 0:
            sc.cand[k] = 1
            locked[k] = 0
    if not new:
        return -1.0
    layout(anchored, locked, sc.floor_on, sc.kind_old, sc.nrow_old)  # (no floor rows after ``land``)
    for k in range(locked.shape[0]):
        if sc.cand[k] != 0:
            locked[k] = 1
    row_gradients(e, sc.kind_old, sc.nrow_old, ws.J1, 0)
    factor_blocks(anchored, ws.J1, ws.J1, sc.kind_old, sc.nrow_old, ws.newt.drop, ws.newt, True, 0)
    sc.acc[5] += 1.0
    row_rates(ws.J1, sc.kind_old, sc.nrow_old, dc, de, ws.rhs)
    solve_blocks(sc.nrow_old, ws.newt, ws.rhs, sc.x_old)
    loss = 0.0
    for i in range(n):
        wv, ww = _weights(anchored, i, n)
        if wv + ww == 0.0:
            continue
        f0, f1, f2, f3, f4, f5 = segment_force(ws.J1, sc.kind_old, sc.nrow_old, sc.x_old, i)
        loss += 0.5 * ((dc[i, 0] - wv * f0) ** 2 + (dc[i, 1] - wv * f1) ** 2 + (dc[i, 2] - wv * f2) ** 2)
        loss += ((de[i, 0] - ww * f3) ** 2 + (de[i, 1] - ww * f4) ** 2 + (de[i, 2] - ww * f5) ** 2) / 6.0
    return loss


@njit(cache=True)
def _book_impact(lost, lock_work, land_work, lock_after, na, acc):
    """A step with an impact (a new lock, a landing): what it removed from U + T (``lost``)
    is what the impact dissipated.  With a landing and a new lock, the locks take what
    they dissipate after the landing (``lock_after``, ``lock_loss_after_landing``), the
    landing the rest; otherwise it is shared between the hinges and the landings as their
    impulses' work.  The step's impact is resolved at the step's end, not at its instant,
    so gravity's work over the step is not the change of U: that O(h) error is the
    impact's, and the imbalance keeps only the smooth steps' error (second order)."""
    if na > 0 and lock_after >= 0.0:
        acc[0] = min(lock_after, max(lost, 0.0))
        acc[1] = lost - acc[0]
        return
    lw = max(lock_work, 0.0)
    dw = max(land_work, 0.0) if na > 0 else 0.0
    share = lw / (lw + dw) if lw + dw > 0.0 else (0.0 if na > 0 else 1.0)
    acc[0] = share * lost
    acc[1] = lost - acc[0]


@njit(cache=True)
def _hinge_impulse(k, kind1, nrow1, x1, rb1, ra1, kind2, nrow2, x2, rb2, ra2):
    """(impulse, energy lost) at hinge k over the step: its bend rows in both stages."""
    j = k + 1
    p, lost = 0.0, 0.0
    for r in range(nrow1[j]):
        if kind1[j, r] == K_BEND:
            p += x1[j, r]
            lost -= 0.5 * x1[j, r] * (rb1[j, r] + ra1[j, r])
    for r in range(nrow2[j]):
        if kind2[j, r] == K_BEND:
            p += x2[j, r]
            lost -= 0.5 * x2[j, r] * (rb2[j, r] + ra2[j, r])
    return p, lost


@njit(cache=True)
def commit(t, h, na, mo, ws, sc, books, log):
    """The step's books and log: energy lost at hinges and landings, the floor's impulse
    (a step with a landing: the impacts' account, else the flow), the landed segments'
    weight, locks (a hinge starts taking impulse in stage 2), unlocks, landings (sharing
    the step's floor impulse and loss at landing equally), t_fall and the counts."""
    anchored, locked = mo.anchored, mo.locked
    books.lost_locking[0] += sc.acc[0]
    books.lost_landing[0] += sc.acc[1]
    account = books.floor_impulse if na > 0 else books.floor_flow
    for q in range(3):
        account[q] += sc.acc[2 + q]
    books.floor_flow[2] += h * landed_count(sc.start.anchored)
    for k in range(locked.shape[0]):
        rebounded = sc.hrebound[k] > 0.0  # (restitution: it took its impulse and left its limit)
        sc.hrebound[k] = 0.0
        if (locked[k] or rebounded) and not sc.start.locked[k]:
            p, lost = _hinge_impulse(
                k, sc.kind1, sc.nrow1, sc.x1, sc.rb1, sc.ra1, ws.kind, ws.nrow, ws.x, sc.val, sc.rate
            )
            log_row(log, t + h, LOG_LOCK, k, p, 0.0, 0.0, lost, sc.pts, k + 1)
        elif sc.start.locked[k] and not locked[k]:
            log_row(log, t + h, LOG_UNLOCK, k, 0.0, 0.0, 0.0, 0.0, sc.pts, k + 1)
    if na > 0:
        share = 1.0 / na
        for r in range(na):
            j = sc.new_anchor[r]
            kind = LOG_BOUNCE if sc.rebound[j] > 0.0 else LOG_LANDING
            sc.rebound[j] = 0.0
            log_row(
                log, t + h, kind, j, share * sc.acc[2], share * sc.acc[3], share * sc.acc[4],
                share * sc.acc[1], sc.pts, j,
            )  # fmt: skip
        if _top_touched(na, anchored, sc):  # the top end landed: when, within the step
            zs = sc.start.c[0, 2] + sc.start.e[0, 2]
            zf = zs + h * (sc.start.vc[0, 2] + sc.start.ve[0, 2]) - 0.5 * h * h
            s = zs / (zs - zf) if zf < 0.0 < zs else 1.0
            fall_ended(books, t + min(max(s, 0.0), 1.0) * h, False, True)
    books.n_steps[0] += 1
    books.n_evals[0] += np.int64(sc.acc[5])
    if mo.anchored[mo.anchored.shape[0] - 1] != 0:
        lowest_point(mo.e, books.lowest)  # (heights from the anchored bottom end)
    else:
        for j in range(mo.anchored.shape[0]):  # (a frictionless floor: the bottom end moves)
            books.lowest[0] = min(books.lowest[0], point_z(mo, j))


@njit(cache=True)
def _top_touched(na, anchored, sc):
    """Did the top end reach the floor in this step (anchored, or, on a frictionless floor,
    a new contact: listed in sc.new_anchor)?"""
    if anchored[0] != 0 and sc.start.anchored[0] == 0:
        return True
    for r in range(na):
        if sc.new_anchor[r] == 0 and sc.start.anchor_t[0] != sc.start.anchor_t[0]:
            return True
    return False


# frame info (fb, FB_SIZE): [0] lost at hinges, [1] at landings, [2:5] the floor's impulse
# so far, [5:8] the anchors' mean force over the last step, [8:11] the pile's pull, [11:16]
# [0:5] at the last step's start, [16] that step's t, [17] its h, [18] 1 while frames inside
# it are still to be taken (the frame buffer was full), [19] the step's level: it is
# dt t_ff/N / 2^level (a step whose stage 1 or 2 failed is taken again halved, one that
# changed U + T beyond its bound shortened as its h^3 error asks: ``_cut``, ``_growth``),
# [20] without the bound, the steps taken at that size (after GROW_AFTER the step is
# doubled), [21] the most a step may change U + T (SolverOptions.step_energy_tol E0; 0: no bound)
FB_SIZE = 22
CUTS_MAX = 10  # a step is halved at most this many times (its level is at most this)
GROW_AFTER = 8  # without the energy bound: steps at a halved size before the next is tried doubled
SAFETY = 0.8  # the energy control aims a step's change of U + T at this fraction of its bound
SHRINK_MIN = 1.5  # ... and shortens a refused step at least this many fold
GROW_MAX = 2.0  # ... and changes an accepted one's successor by at most this factor
TURN_MAX = 0.1  # rad: a step turns no segment further (second order needs h |w| small)


@njit(cache=True)
def _budget(level):
    """Stage 1's Newton iterations at most in a step at this level: ITER_BUDGET while it
    may still be halved, else every round's."""
    return ITER_BUDGET if level < CUTS_MAX else NEWTON_MAX * ROUNDS_MAX


@njit(cache=True)
def _fastest_turn(ve):
    """max_i |e_i'| = max_i |w_i| (rad per sqrt(b/g))."""
    m = 0.0
    for i in range(ve.shape[0]):
        m = max(m, ve[i, 0] ** 2 + ve[i, 1] ** 2 + ve[i, 2] ** 2)
    return math.sqrt(m)


@njit(cache=True)
def record_frame(t, mo, fb, frames):
    """Frame frames.count[0] at time t of the state mo, with the books in fb."""
    k = frames.count[0]
    e = mo.e
    n = e.shape[0]
    frames.t[k] = t
    rates_for_axes(e, mo.ve, frames.omega[k])
    for i in range(n):
        for q in range(3):
            frames.e[k, i, q] = e[i, q]
    for j in range(n + 1):
        frames.anchored[k, j] = mo.anchored[j]
    for j in range(n - 1):
        frames.locked[k, j] = mo.locked[j]
    for q in range(3):
        frames.floor_force[k, q] = fb[5 + q]
        frames.pile_pull[k, q] = fb[8 + q]
        frames.floor_impulse[k, q] = fb[2 + q]
    frames.scale_force[k] = fb[7] + landed_count(mo.anchored)
    frames.kinetic[k] = kinetic_energy_rattle(mo.vc, mo.ve)
    if mo.anchored[n] != 0:
        frames.potential[k] = potential_energy(e)  # (from the axes, point N at the origin)
    else:  # a frictionless floor: the bottom end moves (U = sum c_z)
        u = 0.0
        for i in range(n):
            u += mo.c[i, 2]
        frames.potential[k] = u
        for q in range(3):
            frames.base[k, q] = mo.c[n - 1, q] - mo.e[n - 1, q]
            frames.base_velocity[k, q] = mo.vc[n - 1, q] - mo.ve[n - 1, q]
    frames.lost_locking[k] = fb[0]
    frames.lost_landing[k] = fb[1]
    frames.count[0] = k + 1
    frames.fill[0] = k + 1
    frames.next[0] += frames.dt


@njit(cache=True)
def _books_now(books, fb):
    fb[0] = books.lost_locking[0]
    fb[1] = books.lost_landing[0]
    for q in range(3):
        fb[2 + q] = books.floor_impulse[q] + books.floor_flow[q]


@njit(cache=True)
def _step_forces(h, sc, fb):
    """fb[5:11] <- the anchors' mean force and the pile's pull over a step of size h."""
    for q in range(3):
        fb[5 + q] = sc.acc[2 + q] / h
        fb[8 + q] = sc.pull[q] / h


@njit(cache=True)
def _frame_state(t, hf, model, sc, fws, fm, fsc, fb):
    """fm <- the state hf after the last step's start, and fb[0:5] its books: one step of
    hf, or, where that fails, 2, 4, ... equal steps (at most 2^CUTS_MAX).  Returns the
    length of the last of them (the frame's forces are its means), or the failure's code."""
    for cuts in range(CUTS_MAX + 1):
        m = 2**cuts
        copy_motion(sc.start, fm)
        fws.valid[0] = 0
        fsc.h_last[0] = 0.0
        for q in range(5):
            fb[q] = fb[11 + q]
        code = 0
        for _ in range(m):
            code, _ = rattle_step(t, hf / m, model, fm, fws, fsc, 0.0, False, False, _budget(cuts))
            if code < 0:
                break
            keep_warm_start(hf / m, fws, fsc)
            fb[0] += fsc.acc[0]
            fb[1] += fsc.acc[1]
            for q in range(3):
                fb[2 + q] += fsc.acc[2 + q]
        if code == 0:
            return hf / m
    return code


@njit(cache=True)
def frame_substeps(model, sc, fws, fm, fsc, fb, frames):
    """The frames due strictly inside the last step (fb[16], fb[17]: its t and h): each
    from a step of its own from the step's start (state in sc) to the frame's time, on the
    copy fm (the fall itself is not touched), with the books at the step's start
    (fb[11:16]) plus that step's.  Returns 0, RT_BUFFER (full: fb[18] stays 1, the rest
    are taken on the next call) or the code of a sub-step that failed."""
    if fb[18] == 0.0:
        return 0
    t, h = fb[16], fb[17]
    while frames.next[0] < t + h * (1.0 - 1e-9):
        if frames.count[0] >= frames.t.shape[0] - 1:
            return RT_BUFFER
        hf = frames.next[0] - t
        last = _frame_state(t, hf, model, sc, fws, fm, fsc, fb)
        if last < 0.0:
            return int(last)
        _step_forces(last, fsc, fb)
        record_frame(frames.next[0], fm, fb, frames)
    fb[18] = 0.0
    _books_now_and_forces(h, sc, fb)
    return 0


@njit(cache=True)
def _books_now_and_forces(h, sc, fb):
    """fb[0:5] back to the books after the last step (fb[11:16] plus its own), fb[5:11] its forces."""
    for q in range(5):
        fb[q] = fb[11 + q]
    fb[0] += sc.acc[0]
    fb[1] += sc.acc[1]
    for q in range(3):
        fb[2 + q] += sc.acc[2 + q]
    _step_forces(h, sc, fb)


@njit(cache=True)
def _cut(code, change, etol):
    """How many halvings (log2, not only whole) a refused step is shortened by: for a step
    that changed U + T by ``change`` beyond etol, the local error of a second-order step
    (h^3) brought to SAFETY etol, at least SHRINK_MIN-fold; for a failed stage, one."""
    if code != ERR_STEP_ENERGY or not (abs(change) > etol > 0.0):
        return 1.0
    return max(math.log2(SHRINK_MIN), math.log2(abs(change) / (SAFETY * etol)) / 3.0)


@njit(cache=True)
def _growth(change, impact, etol, fb):
    """How many halvings (log2) the next step is lengthened by after one accepted: with the
    energy bound, the smooth step's change of U + T brought to SAFETY etol (h^3), by a
    factor in [1/GROW_MAX, GROW_MAX] (an impact step, whose change is its loss, keeps the
    size); without it, one halving undone after GROW_AFTER steps at a size."""
    if etol > 0.0:
        if impact:
            return 0.0
        if change == 0.0:
            return math.log2(GROW_MAX)
        g = math.log2(SAFETY * etol / abs(change)) / 3.0
        return min(max(g, -math.log2(GROW_MAX)), math.log2(GROW_MAX))
    fb[20] += 1.0
    if fb[20] >= GROW_AFTER:
        fb[20] = 0.0
        return 1.0
    return 0.0


@njit(cache=True)
def step(t, h, model, mo, ws, sc, fb, books, frames, trace, log):
    """One step from t (h at most: cut at the stop time) with its books, log and trace;
    the frames inside it are left pending (fb[18]).  Returns (code, t + h)."""
    if frames.next[0] <= t * (1.0 + 1e-12) + 1e-12:
        _books_now(books, fb)
        record_frame(t, mo, fb, frames)
    level = fb[19]  # the step is h / 2^level (level >= 0, not only whole: the energy control sets it)
    wmax = _fastest_turn(mo.ve)  # a step turns no segment more than TURN_MAX
    if h / 2.0**level * wmax > TURN_MAX:
        level = min(float(CUTS_MAX), math.log2(h * wmax / TURN_MAX))
    fb[19] = level
    h = h / 2.0**level
    left = model.t_stop - t
    if left < 2.0 * h:  # the last steps before the stop: no step shorter than h / 2
        h = left if left <= h else 0.5 * left
    etol = fb[21]
    code, na = rattle_step(t, h, model, mo, ws, sc, etol, True, level < SPLIT_CUTS, _budget(level))
    if code == ERR_REBOUND:  # the same step with its impacts inelastic
        copy_motion(sc.start, mo)
        ws.valid[0] = 0
        sc.inelastic[0] = 1
        code, na = rattle_step(t, h, model, mo, ws, sc, etol, True, level < SPLIT_CUTS, _budget(level))
        sc.inelastic[0] = 0
    if code < 0 and code != ERR_NAN and level < CUTS_MAX:  # taken again, shorter
        copy_motion(sc.start, mo)
        ws.valid[0] = 0
        fb[19] = min(float(CUTS_MAX), level + _cut(code, sc.acc[8], etol))
        fb[20] = 0.0
        books.n_evals[0] += np.int64(sc.acc[5])
        return 0, t
    if code < 0:
        return code, t
    keep_warm_start(h, ws, sc)
    fb[19] = max(0.0, level - _growth(sc.acc[8], sc.acc[9], etol, fb))
    _books_now(books, fb)
    for q in range(5):
        fb[11 + q] = fb[q]
    fb[16], fb[17], fb[18] = t, h, 1.0
    commit(t, h, na, mo, ws, sc, books, log)
    kt = trace.count[0]
    z_end = mo.c[0, 2] + mo.e[0, 2]
    trace.t[kt] = t + h
    trace.z[kt] = z_end
    trace.count[0] = kt + 1
    if not math.isfinite(z_end):  # (the velocities: U + T was finite, ``rattle_step``)
        return ERR_NAN, t + h
    return 0, t + h


@entry
@njit(cache=True, nogil=True)  # the GIL released: other threads (a sweep's event loop) run meanwhile
def run_steps(t, h, model, mo, ws, sc, fr, fb, books, frames, trace, log):
    """Steps of size h until the fall ends, the stop time, full buffers or
    ``model.return_every`` steps.  Returns (code, t): RT_* or a negative ERR_*."""
    n = mo.e.shape[0]
    room = 3 * n + 8
    taken = 0
    while True:
        code = frame_substeps(model, sc, fr.ws, fr.motion, fr.sc, fb, frames)  # the last step's, if pending
        if code != 0:
            return code, t
        if fall_over(mo.anchored, mo.anchor_t, model.friction):
            books.t_landed[0] = t
            fall_ended(books, t, True, True)
            return RT_LANDED, t
        if log.t.shape[0] - log.n[0] < room:
            return RT_RETURN, t
        if trace.count[0] >= trace.t.shape[0] - 2 or frames.count[0] >= frames.t.shape[0] - 1:
            return RT_BUFFER, t
        if t >= model.t_stop * (1.0 - 1e-14):
            return RT_STOP, t
        if books.n_steps[0] >= model.max_steps:
            return RT_MAX_STEPS, t
        code, t = step(t, h, model, mo, ws, sc, fb, books, frames, trace, log)
        if code < 0:
            return code, t
        taken += 1
        if taken >= model.return_every and not fall_over(mo.anchored, mo.anchor_t, model.friction):
            return RT_RETURN, t
