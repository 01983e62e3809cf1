"""A RATTLE step's books: what the impulses of each kind of row did to T (``_work``), the
anchors' impulse and the pile's pull, the loss of a step with an impact shared between
the locks and the landings in the exact method's order (``lock_loss_after_landing``,
``_book_impact``), and the books and log of an accepted step (``commit``)."""

from __future__ import annotations

from ...core.blocks import _weights
from ...core.books import log_row, lowest_point
from ...core.rules import (
    LOG_BOUNCE,
    LOG_HOLD,
    LOG_LANDING,
    LOG_LOCK,
    LOG_PIN,
    LOG_TOP,
    LOG_UNLOCK,
    RATE_TOL,
    fall_ended,
    landed_count,
)
from ...floors.dispatch import top_event
from ...jit import njit
from .blocks import factor_blocks, solve_blocks
from .rows import (
    K_ANCHOR_LOWER,
    K_ANCHOR_UPPER,
    K_AXIS,
    K_BEND,
    K_FLOOR,
    is_floor,
    layout,
    row_gradients,
    row_rates,
    segment_force,
)
from .state import HELD, PINNED, active_points, base_at_origin, point_vz, point_z


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
def _anchor_impulse(kind, nrow, x, impulse):
    """impulse (3,) += the anchors' and the floor's impulse on the chain (rows' P)."""
    for j in range(nrow.shape[0]):
        for r in range(nrow[j]):
            k = kind[j, r]
            if K_ANCHOR_LOWER <= k < K_AXIS:
                impulse[(k - K_ANCHOR_LOWER) % 3] += x[j, r]
            elif is_floor(k):
                impulse[2] += x[j, r]


@njit(cache=True, _nrt=False)
def tension_impulse(e, kind, nrow, x, out):
    """out[j] += the tension's impulse at point j, pulling positive (``core.dynamics.
    chain_tension``'s convention, from a stage's impulses x): -P_j . e_{j-1}, P_j the
    joint's or the lower anchor's impulse on the segment above; at a point with only an
    upper anchor's rows (a held top end) its impulse on the segment below, along it."""
    n = e.shape[0]
    for j in range(n + 1):
        above, nh = 0.0, 0  # the joint's or the lower anchor's impulse on the segment above, along it
        below, nu = 0.0, 0  # the upper anchor's impulse on the segment below, along it
        for r in range(nrow[j]):
            k = kind[j, r]
            if k < K_ANCHOR_UPPER and j > 0:  # a joint's (K_JOINT + q) or a lower anchor's (K_ANCHOR_LOWER + q) row
                above += x[j, r] * e[j - 1, k % 3]
                nh += 1
            elif K_ANCHOR_UPPER <= k < K_AXIS and j < n:  # an upper anchor's
                below += x[j, r] * e[j, k - K_ANCHOR_UPPER]
                nu += 1
        out[j] += -above if nh > 0 else (below if nu > 0 else 0.0)


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
def _new_lock(locked0, kind1, nrow1, x1):
    """Did a hinge not locked at the step's start take impulse in stage 1 (an impact)?"""
    for j in range(nrow1.shape[0]):
        for r in range(nrow1[j]):
            if kind1[j, r] == K_BEND and locked0[j - 1] == 0 and x1[j, r] > 0.0:
                return True
    return False


@njit(cache=True, _nrt=False)
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
    sc.ledger.factorisations[0] += 1
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


@njit(cache=True, _nrt=False)
def _book_impact(lost, lock_work, land_work, lock_after, na, lg):
    """A step with an impact (a new lock, a landing): what it removed from U + T (``lost``)
    is what the impact dissipated.  With a landing and a new lock, the locks take what
    they dissipate after the landing (``lock_after``, ``lock_loss_after_landing``), the
    landing the rest; otherwise it is shared between the hinges and the landings as their
    impulses' work.  The step's impact is resolved at the step's end, not at its instant,
    so gravity's work over the step is not the change of U: that O(h) error is the
    impact's, and the imbalance keeps only the smooth steps' error (second order).
    Into the step's ledger lg."""
    if na > 0 and lock_after >= 0.0:
        lg.lost_locking[0] = min(lock_after, max(lost, 0.0))
        lg.lost_landing[0] = lost - lg.lost_locking[0]
        return
    lw = max(lock_work, 0.0)
    dw = max(land_work, 0.0) if na > 0 else 0.0
    share = lw / (lw + dw) if lw + dw > 0.0 else (0.0 if na > 0 else 1.0)
    lg.lost_locking[0] = share * lost
    lg.lost_landing[0] = lost - lg.lost_locking[0]


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
def _held_by_fallback(k, e_lock, sc):
    """With restitution at the limit, did hinge k lock in the step although Newton's law would
    rebound it (``rules`` ``hold`` row)?  It was closing at the step's start faster than
    RATE_TOL, or stage 2 found its rebound too slow to resolve (Scratch.fallback's HELD)."""
    if e_lock <= 0.0:
        return False
    if sc.fallback[k + 1] & HELD:
        return True
    st = sc.start
    rate = 0.0  # d/dt (e_k . e_k+1) at the step's start
    for q in range(3):
        rate += st.ve[k, q] * st.e[k + 1, q] + st.e[k, q] * st.ve[k + 1, q]
    return rate < -RATE_TOL


@njit(cache=True, _nrt=False)
def commit(t, h, na, model, mo, ws, sc, books, log):
    """The step's books and log: energy lost at hinges and landings, the floor's impulse
    (a step with a landing: the impacts' account, else the flow), the landed segments'
    weight, locks (a hinge starts taking impulse in stage 2), unlocks, landings (sharing
    the step's floor impulse and loss at landing equally), t_fall and the counts."""
    anchored, locked, lg = mo.anchored, mo.locked, sc.ledger
    books.lost_locking[0] += lg.lost_locking[0]
    books.lost_landing[0] += lg.lost_landing[0]
    books.lost_damping[0] += lg.smooth_loss[0]
    books.lost_sliding[0] += lg.friction_loss[0]
    account = books.floor_impulse if na > 0 else books.floor_flow
    for q in range(3):
        account[q] += lg.floor_impulse[q]
    books.floor_flow[2] += h * landed_count(sc.start.anchored)
    if top_event(model.floor):  # (logged first: its instant is within the step, the others' at its end)
        _top_reached(t, h, mo, sc, books, log)
    pa = active_points(sc.start.anchored)  # (the step's points: past them nothing changed)
    for k in range(min(locked.shape[0], max(pa - 2, 0))):
        rebounded = sc.hrebound[k] > 0.0  # (restitution: it took its impulse and left its limit)
        sc.hrebound[k] = 0.0
        if (locked[k] or rebounded) and not sc.start.locked[k]:
            p, lost = _hinge_impulse(
                k, sc.kind1, sc.nrow1, sc.x1, sc.rb1, sc.ra1, ws.kind, ws.nrow, ws.x, sc.val, sc.rate
            )
            held = not rebounded and _held_by_fallback(k, model.e_lock, sc)
            log_row(log, t + h, LOG_HOLD if held else LOG_LOCK, k, p, 0.0, 0.0, lost, sc.pts, k + 1)
        elif sc.start.locked[k] and not locked[k]:
            log_row(log, t + h, LOG_UNLOCK, k, 0.0, 0.0, 0.0, 0.0, sc.pts, k + 1)
    for j in range(pa):  # (finite friction: the floor's hold let go, or taken again)
        kind = int(sc.grip_log[j, 0])
        if kind != 0:
            g = sc.grip_log
            log_row(log, t + h, kind, j, g[j, 1], g[j, 2], g[j, 3], 0.0, sc.pts, j)
            g[j, 0] = 0.0
    if na > 0:
        share = 1.0 / na
        impulse = lg.floor_impulse
        for r in range(na):
            j = sc.new_anchor[r]
            kind = LOG_BOUNCE if sc.rebound[j] > 0.0 else (LOG_PIN if sc.fallback[j] & PINNED else LOG_LANDING)
            sc.rebound[j] = 0.0
            log_row(
                log, t + h, kind, j, share * impulse[0], share * impulse[1], share * impulse[2],
                share * lg.lost_landing[0], sc.pts, j,
            )  # fmt: skip
        if not top_event(model.floor) and _top_touched(na, anchored, sc):  # the top end landed: when, within the step
            s = ballistic_touch(point_z(sc.start, 0), point_vz(sc.start, 0), h)
            fall_ended(books, t + s * h, False, True)
    books.n_steps[0] += 1
    books.n_evals[0] += lg.factorisations[0]
    if base_at_origin(mo):
        lowest_point(mo.e, books.lowest)  # (heights from the anchored bottom end)
    else:
        for j in range(mo.anchored.shape[0]):  # (a floor that let the bottom end slide)
            books.lowest[0] = min(books.lowest[0], point_z(mo, j))


@njit(cache=True, inline="always")
def ballistic_touch(zs, vz, h):
    """Where within a step (0 <= s <= 1) the top end, at height zs (b) and rising at vz at
    the step's start, reaches the floor under gravity alone: the chord from zs to
    z_b = zs + h vz - h^2 / 2 crosses 0 at s = zs / (zs - z_b) (1 if z_b does not go below
    0: the touch is taken at the step's end)."""
    zb = zs + h * vz - 0.5 * h * h
    s = zs / (zs - zb) if zb < 0.0 < zs else 1.0
    return min(max(s, 0.0), 1.0)


@njit(cache=True, _nrt=False)
def _top_reached(t, h, mo, sc, books, log):
    """A floor model whose top end's height is an event of its own (``top_event``): the
    fall ends where z_0 crosses 0 within the step, z_0(t + s h) = z_s + s (z_f - z_s); if
    the step anchored the top end instead (it lay flat on the floor, held a hair above
    it), at ``ballistic_touch`` (as the floor ``all`` times a top end's touch), else at
    the step's end.  Logged as the event "top"."""
    zs, zf = point_z(sc.start, 0), point_z(mo, 0)
    if zs > 0.0 >= zf:
        s = zs / (zs - zf)
    elif mo.anchored[0] != 0 and sc.start.anchored[0] == 0:
        s = ballistic_touch(zs, point_vz(sc.start, 0), h)
    else:
        return
    if fall_ended(books, t + s * h, True, False):
        log_row(log, books.t_fall[0], LOG_TOP, 0, 0.0, 0.0, 0.0, 0.0, sc.pts, 0)


@njit(cache=True, _nrt=False)
def _top_touched(na, anchored, sc):
    """Did the top end reach the floor in this step (anchored, or, on a frictionless floor,
    a new contact: listed in sc.new_anchor)?"""
    if anchored[0] != 0 and sc.start.anchored[0] == 0:
        return True
    for r in range(na):
        if sc.new_anchor[r] == 0 and sc.start.anchor_t[0] != sc.start.anchor_t[0]:
            return True
    return False
