"""Stage 1 of a RATTLE step (SHAKE, position level): u_half = u + h/2 W f + W G(q)^T P1,
q+ = q + h u_half, with the joints, axes and anchors as equalities at q+ and the bend
limits and the floor as Signorini conditions at q+ (g(q+) >= 0, P1 >= 0, complementary).
Simplified Newton on P1 with the factors of G W G^T (or of J(q+) W J(q)^T where that
chord stalls), inside an active-set loop (``stage1``); the half kicks and impulses that
both stages apply (``half_kick``, ``add_impulses``)."""

from __future__ import annotations

import math

from ...contacts.coulomb import grips
from ...core.forces import any_smooth_law
from ...core.rules import (
    is_landed,
    limit_in_force,
    unit_hinge_gap,
)
from ...floors.dispatch import floor_level, floor_watched_range
from ...jit import njit
from .blocks import factor_blocks, solve_blocks
from .codes import ERR_ACTIVE_SET, ERR_NEWTON
from .friction import friction_kick
from .rows import (
    K_BEND,
    K_FLOOR,
    booked_rates,
    carry_over,
    copy_layout,
    is_floor,
    layout,
    row_gradients,
    row_values,
    segment_force,
)
from .smooth import first_smooth_kick
from .state import point_z

NEWTON_MAX = 40  # simplified Newton iterations of stage 1 at most (per active set)
NEWTON_RATE = 0.05  # an iteration that cuts the residual less than this fold moves on to (a new) A
ROUNDS_MAX = 60  # active-set rounds of a stage at most
ITER_BUDGET = 60  # Newton iterations of stage 1 over all its rounds in a step that may still be halved: past
#   them it is (at N = 512, accepted steps took at most 45, 99.99% of them 30 or fewer; the attempts that
#   failed, 200-1500, 8% of the factorisations of a fall)
POS_TOL = 1e-10  # b: stage 1 meets every row to this, plus the round-off of the heights (1e-12 before:
#   the convergence table and the top the same to the digits shown, 14% fewer iterations at N = 256)
POS_ROUNDOFF = 4e-16  # ... times the chain's height 2N (positions are stored, not summed)
STALL_TOL = 1e-8  # b: finite friction: stage 1 stalled on its exact Newton matrix within this is met.  A stretch
#   lying on the floor between two held points, its points sliding, holds more rows than its motion has
#   freedoms (its hinges at their limits), and the held points' anchors agree with its lengths only to the
#   tolerance each was placed with: their drift (up to about 1e-9 b) is what the stage cannot meet (the
#   audit's bounds: 1e-8 b below the floor, 1e-6 b from an anchor)
UNMET_REACH = 4  # finite friction: a stage 1 that stalls on a row releases a locked hinge this near it
TURN_SPLIT = 0.2  # stage 1's first Newton matrix in a step keeps J W J^T's factors above the first point whose
#   segments turned in the step by more than this fraction of the most any did (``newton_split``): at N = 512 (4
#   starts) 1.40 factorisations a step against 1.75 (partial ones counted by their share of the points), the
#   same Newton evaluations (5.24 against 5.19); 0.05: 1.62; 0.5: 1.38, with 1% more evaluations
EARLY_ROUNDS = 4  # rounds of stage 1 in which rows found far past their limit are switched on within the iteration
EARLY_MARGIN = 10.0  # ... "far": by more than this many times the iterate's residual
EARLY_RES = 1e-6  # ... and the whole complementarity checked once the residual is below this (b), with
#   the same margin: a bend row released for pulling at an iterate that has not met it (|g| <= the
#   residual) is not switched on again by its own gap (that flip left the set as it was, round
#   after round: 8% of the steps at N = 256 took 5 rounds or more, 1% with the margin)


@njit(cache=True, _nrt=False)
def position_tol(n):
    """What stage 1 meets each row to (b): POS_TOL plus the round-off of heights up to 2n
    (n: the segments a step works on, ``active_points``: the rest lie on the floor)."""
    return POS_TOL + POS_ROUNDOFF * 2.0 * n


@njit(cache=True, _nrt=False)
def half_kick(h, anchored, vc, ve, ukc, uke):
    """u + h/2 W f: gravity's half kick on the centres of the segments not landed."""
    for i in range(vc.shape[0]):
        landed = is_landed(anchored, i)
        for q in range(3):
            ukc[i, q] = 0.0 if landed else vc[i, q]
            uke[i, q] = 0.0 if landed else ve[i, q]
        if not landed:
            ukc[i, 2] -= 0.5 * h


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
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
    j0, j1 = floor_watched_range(model.floor, anchored)  # (all: every point, the last one the bottom end,
    for j in range(j0, j1):  # free on a frictionless floor; pivot: the upper end of the bottom airborne segment)
        if anchored[j] == 0 and floor_on[j] == 0 and floor_gap(model, mo, j) < -margin:
            floor_on[j] = 1
            changed = True
    return changed


@njit(cache=True, inline="always")
def floor_gap(model, mo, j):
    """How far point j is above where the floor model meets it (b; < 0: through the
    floor): z_j, or on the floor "pivot" z_j less its segment's lower end's
    (``floors.dispatch.floor_level``)."""
    return point_z(mo, j) - floor_level(model.floor, mo.anchor_pos, j)


@njit(cache=True, _nrt=False)
def _factor(anchored, locked, floor_on, kind_old, nrow_old, lg, ws, e, reuse, factor, keep):
    """The rows of the current layout at axes e, and (with ``factor``) the factors of
    J W J^T; with ``reuse``, those of the last stage 2 (at these axes, ws.valid) if its
    layout is this one: a step's stage 1 starts where the last stage 2 ended, with its
    active set.  With ``keep`` (ws holds the rows at these axes of the last layout, and
    the factors of J W J^T if ``factor``) only the points from the one before the first
    changed point are done again.  Returns (whether ws holds the factors of J W J^T for
    these rows (without them, no row is marked redundant), that first point done again).
    (kind_old, nrow_old: scratch for the layout; the step's ledger lg counts the factorisations.)"""
    layout(anchored, locked, floor_on, kind_old, nrow_old)
    first = first_change(kind_old, nrow_old, ws.kind, ws.nrow)
    if reuse and ws.valid[0] != 0 and first == ws.nrow.shape[0]:
        return True, first
    ws.valid[0] = 0
    j0 = max(first - 1, 0) if keep else 0
    layout(anchored, locked, floor_on, ws.kind, ws.nrow)
    row_gradients(e, ws.kind, ws.nrow, ws.J, j0)
    if factor:
        _factor_symmetric(anchored, ws, lg, j0)
    else:
        for j in range(ws.nrow.shape[0]):
            for r in range(ws.nrow[j]):
                ws.sym.drop[j, r] = 0
    return factor, j0


@njit(cache=True, _nrt=False)
def _factor_symmetric(anchored, ws, lg, j0):
    """The factors of J W J^T for the rows in ws (ws.sym), its redundant rows dropped, from
    point j0 on (``blocks.factor_blocks``); the step's ledger lg counts it."""
    factor_blocks(anchored, ws.J, ws.J, ws.kind, ws.nrow, ws.sym.drop, ws.sym, True, j0)
    lg.factorisations[0] += 1


@njit(cache=True, _nrt=False)
def _factor_newton(mo, ws, j0):
    """The factors of stage 1's Newton matrix J(q+) W J(q)^T (ws.newt), from point j0 on:
    the rows at q+ (J1) taken there, the rows that ws.sym drops dropped; False if it is
    singular to round-off."""
    row_gradients(mo.e, ws.kind, ws.nrow, ws.J1, j0)
    return factor_blocks(mo.anchored, ws.J1, ws.J, ws.kind, ws.nrow, ws.sym.drop, ws.newt, False, j0) >= 0


@njit(cache=True, _nrt=False)
def _refactor_newton(mo, ws, sc, j0, have_sym):
    """Stage 1's Newton matrix A factored at this q+ from point j0 on; if it is singular
    and J W J^T's factors are not at hand, those (its redundant rows dropped) and A again
    from the top (the ledger counts each).  Returns (whether ws.newt holds A's factors,
    whether ws.sym holds J W J^T's)."""
    sc.ledger.factorisations[0] += 1
    exact = _factor_newton(mo, ws, j0)
    if not exact and not have_sym:
        _factor_symmetric(mo.anchored, ws, sc.ledger, 0)
        sc.ledger.factorisations[0] += 1
        exact = _factor_newton(mo, ws, 0)
        have_sym = True
    return exact, have_sym


@njit(cache=True, _nrt=False)
def _kept_above_turning(mo, ws, sc, sym_upto):
    """The step's first factors of A: J W J^T's (ws.sym, made for the current rows at the
    step's start before point sym_upto) copied to ws.newt above the part of the chain
    that turned (``newton_split``).  Returns the point A is to be factored from."""
    k = newton_split(mo.e, sc.start.e, ws.nrow.shape[0], sym_upto)
    copy_factors(ws.sym, ws.newt, ws.nrow, k)
    return k


@njit(cache=True, _nrt=False)
def newton_split(e, e0, npts, upto):
    """The first point (at most ``upto``) at which a segment has turned in the step,
    |e - e0|, by more than TURN_SPLIT of the most any has: A = J(q+) W J(q)^T differs from
    J W J^T at q only in the rows of segments that turned (axes, bends), so above that
    point J W J^T's rows stand in for A's within TURN_SPLIT of A's largest change."""
    n = min(e.shape[0], npts)
    big = 0.0
    for i in range(n):
        d = (e[i, 0] - e0[i, 0]) ** 2 + (e[i, 1] - e0[i, 1]) ** 2 + (e[i, 2] - e0[i, 2]) ** 2
        big = max(big, d)
    cut = TURN_SPLIT * TURN_SPLIT * big
    for i in range(n):
        d = (e[i, 0] - e0[i, 0]) ** 2 + (e[i, 1] - e0[i, 1]) ** 2 + (e[i, 2] - e0[i, 2]) ** 2
        if d > cut:
            return min(i, upto)  # (point i: the segment above is i - 1, below it i)
    return min(n, upto)


@njit(cache=True, _nrt=False)
def copy_factors(src, dst, nrow, k):
    """dst's factors of the points before k <- src's (their blocks, dropped rows and places)."""
    m = src.off[k]
    for i in range(m):
        dst.D[i] = src.D[i]
        dst.L[i] = src.L[i]
        dst.X[i] = src.X[i]
    for j in range(k + 1):
        dst.off[j] = src.off[j]
    for j in range(k):
        for r in range(nrow[j]):
            dst.drop[j, r] = src.drop[j, r]


@njit(cache=True, _nrt=False)
def first_change(kind_a, nrow_a, kind_b, nrow_b):
    """The first point whose rows differ between two layouts (the number of points if none)."""
    for j in range(nrow_a.shape[0]):
        if nrow_a[j] != nrow_b[j]:
            return j
        for r in range(nrow_a[j]):
            if kind_a[j, r] != kind_b[j, r]:
                return j
    return nrow_a.shape[0]


@njit(cache=True, _nrt=False)
def stage1(h, model, mo, ws, sc, budget):
    """Stage 1 (module docstring): q+ and u_half in mo, the impulses P1 in ws.x, their
    layout kept in sc (kind1, nrow1, x1) with the rates before and after of the rows the
    books take (rb1, ra1: ``booked_rates``).  Returns 0, ERR_NEWTON (also after ``budget``
    Newton iterations over all rounds) or ERR_ACTIVE_SET."""
    n = mo.e.shape[0]
    tol = position_tol(n)
    half_kick(h, mo.anchored, mo.vc, mo.ve, sc.ukc, sc.uke)
    grip = grips(model.friction)
    if grip:
        friction_kick(h, model.friction, mo, sc.ukc, sc.uke)
    if any_smooth_law(model):
        first_smooth_kick(h, model, mo, sc)
    for j in range(sc.floor_on.shape[0]):  # (a point that touched the floor at the last step starts on it)
        sc.floor_on[j] = 1 if (mo.touching[j] != 0 and mo.anchored[j] == 0) else 0
    newt_valid = False  # ws.newt holds the factors of a Newton matrix of this stage ...
    newt_from = 0  # ... whose rows are those of the current layout at the points before this one
    sym_upto = 0  # ws.sym holds the factors of J W J^T at the step's start for the current rows before this point
    for rnd in range(ROUNDS_MAX):
        sc.ledger.stage1_rounds[0] += 1
        if rnd > 0:  # (the last round's layout and impulses: kept past _factor for the carry-over)
            copy_layout(sc.kind_old, sc.nrow_old, sc.x_old, sc.kind1, sc.nrow1, sc.x1)
        have_sym, j0 = _factor(
            mo.anchored, mo.locked, sc.floor_on, sc.kind_old, sc.nrow_old, sc.ledger, ws, sc.start.e, rnd == 0, False,
            rnd > 0,
        )  # (J W J^T only if the last stage 2's serves)  # fmt: skip
        newt_from = min(newt_from, j0)  # (a round that did not factor A leaves its factors to the next)
        sym_upto = ws.nrow.shape[0] if (rnd == 0 and have_sym) else min(sym_upto, j0)
        restart = newt_from if newt_valid else 0  # the Newton matrix's factors kept for the points before it
        _first_guess(h, rnd, ws, sc)
        met = False
        exact = False  # the symmetric factors while each iteration cuts the residual NEWTON_RATE-fold, then A
        singular = False  # A was singular to round-off: the chord on J W J^T only
        switched = False  # rows switched on before the iteration met its rows
        last = math.inf
        for it in range(NEWTON_MAX):
            if sc.ledger.newton_iterations[0] >= budget:
                _record_unmet(ws, sc)
                return ERR_NEWTON
            add_impulses(h, mo, ws, sc, True)
            res = row_values(mo.c, mo.e, mo.anchor_pos, model.cos_alpha, model.floor, ws.kind, ws.nrow, sc.val)
            sc.ledger.newton_iterations[0] += 1
            if res <= tol or (grip and exact and res <= STALL_TOL and res > NEWTON_RATE * last):
                met = True  # (finite friction: a stall on the exact matrix within STALL_TOL is met, ``STALL_TOL``)
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
                    if not exact and not newt_valid and sym_upto > 0:  # A's first factors this step
                        restart = _kept_above_turning(mo, ws, sc, sym_upto)
                    exact, have_sym = _refactor_newton(mo, ws, sc, restart if not exact else 0, have_sym)
                    restart = 0
                    newt_from = ws.nrow.shape[0]
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
            sc.ledger.rounds_ended_early[0] += 1
            copy_layout(ws.kind, ws.nrow, ws.x, sc.kind_old, sc.nrow_old, sc.x_old)
            continue
        if not met:
            _record_unmet(ws, sc)
            if not _release_unmet_bend(mo, ws, sc, grip):
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
    _record_unsettled(model, mo, ws, sc, tol)
    return ERR_ACTIVE_SET


@njit(cache=True, _nrt=False)
def _record_unsettled(model, mo, ws, sc, tol):
    """Where stage 1's active set did not settle (sc.unmet): the first bend or floor row
    whose impulse pulls, or else the first limit or free point past its bound by more
    than tol (the rows its last round switched on), if any."""
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            if (ws.kind[j, r] == K_BEND or is_floor(ws.kind[j, r])) and ws.x[j, r] < 0.0:
                sc.unmet[0], sc.unmet[1], sc.unmet[2] = j, ws.kind[j, r], ws.x[j, r]
                return
    e = mo.e
    for k in range(mo.locked.shape[0]):
        g = unit_hinge_gap(e, k, model.cos_alpha)
        if g < -tol and limit_in_force(mo.anchored, k, model.cone, model.alpha):
            sc.unmet[0], sc.unmet[1], sc.unmet[2] = k + 1, K_BEND, g
            return
    j0, j1 = floor_watched_range(model.floor, mo.anchored)
    for j in range(j0, j1):
        if mo.anchored[j] == 0 and floor_gap(model, mo, j) < -tol:
            sc.unmet[0], sc.unmet[1], sc.unmet[2] = j, K_FLOOR, floor_gap(model, mo, j)
            return


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
def _release_unmet_bend(mo, ws, sc, grip):
    """Stage 1's Newton did not meet its rows: the active set is likely wrong, not the
    step.  The bend rows whose impulses pull are switched off, or else, if the row furthest
    from met (sc.unmet) is a bend row, that one, or else, with finite friction (``grip``),
    the locked hinge nearest to it (``_release_nearest_lock``).  Returns whether any was."""
    released = False
    for j in range(ws.nrow.shape[0]):
        for r in range(ws.nrow[j]):
            if ws.kind[j, r] == K_BEND and ws.x[j, r] < 0.0:
                mo.locked[j - 1] = 0
                released = True
    if not released and int(sc.unmet[1]) == K_BEND:
        mo.locked[int(sc.unmet[0]) - 1] = 0
        released = True
    if not released and grip:
        released = _release_nearest_lock(mo, int(sc.unmet[0]))
    return released


@njit(cache=True, _nrt=False)
def _release_nearest_lock(mo, j):
    """With finite friction: the locked hinge nearest to point j (within UNMET_REACH points)
    is released.  A stretch of m segments lying on the floor between two anchors, its
    points sliding, moves in the floor's plane with m - 2 degrees of freedom, so its m - 1
    hinges cannot all hold their limits as independent rows: one of them repeats the
    others, and stage 1 stalls on what their drift leaves (the anchors' or the joints'
    rows, just past its tolerance).  Returns whether one was."""
    nh = mo.locked.shape[0]
    for d in range(UNMET_REACH + 1):
        for k in (j - 1 - d, j - 1 + d):
            if 0 <= k < nh and mo.locked[k] != 0:
                mo.locked[k] = 0
                return True
    return False
