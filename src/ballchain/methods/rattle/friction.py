"""Coulomb's friction at the floor in a RATTLE step, 0 < mu < inf (``contacts.coulomb.grips``).

*Stick is the anchor.*  A point that lands is anchored where it touched, as with mu = inf,
and a segment lying on the floor between two anchors drops out of the stages: the pile
brings no rows that repeat each other.  After every step the force that holds an
anchored point, F = (P1 + P2) / h from its anchor rows plus m g / 2 of each landed
segment beside it (which the stages do not see), is checked against the cone
(``let_go``): where F_n <= 0 the point is let go (it lifts off), where |F_t| > mu F_n it
starts to slide.  A landing whose impact leaves the cone slides at once: stage 2 is
solved again with the point's floor row and the friction impulse mu P_n d of its impact
(``landing_slips``, a fixed point on P_n).

*Slip is the frictionless floor's row plus a known force.*  A sliding point keeps its
floor row (a Signorini condition in stage 1, Moreau's law in stage 2, as at mu = 0) and
takes the friction force mu F_n d in both half kicks (``friction_kick``), d against its
sliding velocity at the step's start (``friction_directions``; at the onset, along the
force that held it) and F_n the floor's normal force on it over the step before
(``normal_forces``): the stages' matrices are the frictionless floor's.  The friction
force lags a step (first order in it).  A point whose sliding velocity the friction
reverses within a step stops: it is anchored there (``stops``), its tangential velocity
taken by the anchor's impulse (booked at the floor).  What the friction force removes in
a step, -F . (p(q+) - p(q)), is booked as ``lost_sliding`` (``friction_work``, half a kick at
a time); the floor's impulse record takes its impulse h F.  Where the friction force
reverses a slow point within a step (it is then anchored), that work can come out
negative: the explicit force overshoots by O(h).  Where it creates more than the step's
energy bound (a step's friction impulse far beyond what stops the point: mu large, or a
slow point pressed hard), the step is taken again at the same size with the points it
reversed held from its start (``hold_reversed``: a stick, logged), as the cone would hold a
point at rest under a friction that can stop it: without it, mu 1e6 threw a chain's foot
off at 500 sqrt(g b) on its first slip, the created energy booked as a negative loss.
"""

from __future__ import annotations

import math

from ...core.rules import LOG_JAM, LOG_LIFT, LOG_SLIP, LOG_STICK, hold_at, is_landed
from ...jit import njit
from .rows import K_ANCHOR_LOWER, K_AXIS, is_floor
from .state import point_positions

V_SLIP = 1e-9  # sqrt(g b): a sliding point slower than this keeps the direction its friction had
FIXED_POINT_TOL = 1e-12  # a landing's friction impulse (m sqrt(g b)) settled to this, relative (``landing_slips``)
SLIDING, STOPPING, HELD, JAMMED = 1, 2, 3, 4  # Motion.touching at finite friction: slides; reversed in the last
#   stage 2 (anchored next); reversed by its friction in a step that created energy (``hold_reversed``: held at the
#   step's start, a stick); in a stretch that a stage could not move (``hold_stuck_stretch``: held at the next
#   step's start by a fallback rule, a jam)
FLAT_FOLD = (
    1e-6  # b: a free point this near the floor between two held points lies in a flat fold (``hold_stuck_stretch``)
)
STUCK_REACH = 4  # points: a stage that fails on a row at point j holds the sliding stretches this near it


@njit(cache=True, inline="always")
def point_velocity(mo, j):
    """dp_j/dt: the upper end of segment j (c' + e'), or for the last point the lower end
    of the segment above it (c' - e')."""
    n = mo.e.shape[0]
    if j < n:
        return mo.vc[j, 0] + mo.ve[j, 0], mo.vc[j, 1] + mo.ve[j, 1], mo.vc[j, 2] + mo.ve[j, 2]
    return mo.vc[n - 1, 0] - mo.ve[n - 1, 0], mo.vc[n - 1, 1] - mo.ve[n - 1, 1], mo.vc[n - 1, 2] - mo.ve[n - 1, 2]


@njit(cache=True, inline="always")
def _point_xy(c, e, j):
    n = e.shape[0]
    if j < n:
        return c[j, 0] + e[j, 0], c[j, 1] + e[j, 1]
    return c[n - 1, 0] - e[n - 1, 0], c[n - 1, 1] - e[n - 1, 1]


@njit(cache=True, inline="always")
def _point_height(mo, j):
    n = mo.e.shape[0]
    if j < n:
        return 0.0, 0.0, mo.c[j, 2] + mo.e[j, 2]
    return 0.0, 0.0, mo.c[n - 1, 2] - mo.e[n - 1, 2]


@njit(cache=True, inline="always")
def point_kick(px, py, pz, j, ukc, uke):
    """u += W Q_j^T P: an impulse P at point j on the segment below it (its upper end,
    dp/dq = (1, +1)), the last point on the segment above (its lower end, (1, -1));
    W = diag(1, 3)."""
    n = ukc.shape[0]
    i, s = (j, 3.0) if j < n else (n - 1, -3.0)
    ukc[i, 0] += px
    ukc[i, 1] += py
    ukc[i, 2] += pz
    uke[i, 0] += s * px
    uke[i, 1] += s * py
    uke[i, 2] += s * pz


@njit(cache=True, _nrt=False)
def friction_directions(mo):
    """At a step's start: the friction force at a sliding point opposes its sliding
    velocity, d = -v_t / |v_t| (kept where |v_t| < V_SLIP: the direction it started to
    slide in)."""
    for j in range(mo.anchored.shape[0]):
        if mo.anchored[j] == 0 and mo.touching[j] == SLIDING:
            vx, vy, _ = point_velocity(mo, j)
            s = math.hypot(vx, vy)
            if s > V_SLIP:
                mo.grip[j, 1] = -vx / s
                mo.grip[j, 2] = -vy / s


@njit(cache=True, _nrt=False)
def friction_kick(h, mu, mo, ukc, uke):
    """The sliding points' friction force over half a step: u += h/2 W Q_j^T F_j,
    F_j = mu F_n d (``Motion.grip``)."""
    for j in range(mo.anchored.shape[0]):
        if mo.anchored[j] == 0 and mo.touching[j] == SLIDING:
            f = 0.5 * h * mu * mo.grip[j, 0]
            point_kick(f * mo.grip[j, 1], f * mo.grip[j, 2], 0.0, j, ukc, uke)


@njit(cache=True, _nrt=False)
def friction_work(h, mu, mo, start, lg):
    """The books of one half kick of the sliding points' friction force (``friction_kick``,
    after stage 1 for its own and at stage 2's start for the second), into the step's
    ledger lg: friction_loss += what it removed, -sum F_j . (p_j(q+) - p_j(q)) / 2 (the
    step's displacement, stage 1's), and its impulse h/2 F_j into floor_impulse (x, y).  A point anchored in the step between
    the two takes only the first."""
    loss = 0.0
    for j in range(mo.anchored.shape[0]):
        if mo.anchored[j] == 0 and mo.touching[j] == SLIDING:
            f = 0.5 * mu * mo.grip[j, 0]
            fx, fy = f * mo.grip[j, 1], f * mo.grip[j, 2]
            x1, y1 = _point_xy(mo.c, mo.e, j)
            x0, y0 = _point_xy(start.c, start.e, j)
            loss -= fx * (x1 - x0) + fy * (y1 - y0)
            lg.floor_impulse[0] += h * fx
            lg.floor_impulse[1] += h * fy
    lg.friction_loss[0] += loss


@njit(cache=True, _nrt=False)
def hold_reversed(mo, start):
    """After a step whose friction created energy: the points sliding at its start that moved
    along their friction force over it (d . (p(q+) - p(q)) > 0, d the step's, in ``mo``: the
    explicit force reversed them) are marked HELD in the step's start (``start``), so that the step taken again
    anchors them there (``hold_marked``).  Returns how many."""
    marked = 0
    for j in range(start.anchored.shape[0]):
        if start.anchored[j] == 0 and start.touching[j] == SLIDING:
            x1, y1 = _point_xy(mo.c, mo.e, j)
            x0, y0 = _point_xy(start.c, start.e, j)
            if mo.grip[j, 1] * (x1 - x0) + mo.grip[j, 2] * (y1 - y0) > 0.0:  # (the step's d: ``friction_directions``)
                start.touching[j] = HELD
                marked += 1
    return marked


@njit(cache=True, _nrt=False)
def stops(mo, j):
    """Does the sliding point j stop (to be anchored in this step, ``stage2.land``)? It
    reversed in the last stage 2 (STOPPING), or its velocity after stage 1 runs along
    its friction force (the friction reversed it within the step)."""
    if mo.touching[j] == STOPPING:
        return True
    vx, vy, _ = point_velocity(mo, j)
    return vx * mo.grip[j, 1] + vy * mo.grip[j, 2] >= 0.0


@njit(cache=True, inline="always")
def _impulse_at(j, kind, nrow, x, floor):
    """The impulse of point j's anchor rows (floor False: x, y, z) or floor rows (True: z)."""
    px, py, pz = 0.0, 0.0, 0.0
    for r in range(nrow[j]):
        k = kind[j, r]
        if floor:
            if is_floor(k):
                pz += x[j, r]
        elif K_ANCHOR_LOWER <= k < K_AXIS:
            q = (k - K_ANCHOR_LOWER) % 3
            if q == 0:
                px += x[j, r]
            elif q == 1:
                py += x[j, r]
            else:
                pz += x[j, r]
    return px, py, pz


@njit(cache=True, _nrt=False)
def landing_slips(mu, mo, ws, sc):
    """After a round of stage 2: a point anchored in this step (mark 2) whose anchor
    impulse P leaves the cone (P_n <= 0, or |P_t| > mu P_n) is let go: it gets a floor
    row (sc.floor_on, sc.fcand) and, pressed (P_n > 0), the friction impulse of its
    impact x d, d = P_t / |P_t| (sc.fimp, kicked into sc.ukc, sc.uke), where x = mu P_n
    of its floor row in the round that x gives.  Stage 2 is linear, so P_n is affine in
    x: the root of g(x) = mu P_n(x) - x is found by secant steps, point by point (one
    more round after the first guess x = mu P_n of the anchor).  A sliding point that
    ``stops`` held in this step and that is let go here never stuck (its sliding reversed
    through zero speed with the force beyond the cone): its ``stick`` row is withdrawn and
    its last anchor (``anchor_pos``) is again the one before.
    Returns whether the set or an impulse changed (stage 2 is solved again)."""
    changed = False
    for j in range(mo.anchored.shape[0]):
        if mo.anchored[j] == 2:
            if sc.fimp[j, 2] < 0.0:  # (held: its slide would have reversed it, or did not settle)
                continue
            px, py, pz = _impulse_at(j, ws.kind, ws.nrow, ws.x, False)
            pt = math.hypot(px, py)
            if pz > 0.0 and pt <= mu * pz:
                continue
            mo.anchored[j] = 0
            sc.floor_on[j] = 1
            sc.fcand[j] = 1
            changed = True
            if sc.grip_log[j, 0] == LOG_STICK:  # (a sliding point that ``stops`` held: it never stuck, its
                sc.grip_log[j, 0] = 0.0  # sliding reversed through zero speed, the force beyond the cone)
                for q in range(3):  # (nor was it held there: its last anchor is still the one before)
                    mo.anchor_pos[j, q] = sc.start.anchor_pos[j, q]
            if mo.touching[j] != 0:
                _slides_on(j, mo, sc)
            sc.fsec[j, 0] = math.nan  # (no secant point yet)
            if pz > 0.0 and pt > 0.0:
                mo.grip[j, 1], mo.grip[j, 2] = px / pt, py / pt
                _set_impact_friction(j, mu * pz, mo, sc)
        elif mo.anchored[j] == 0 and sc.fimp[j, 2] > 0.0:
            _, _, pn = _impulse_at(j, ws.kind, ws.nrow, ws.x, True)
            x = sc.fimp[j, 2]
            g = mu * max(pn, 0.0) - x
            if abs(g) <= FIXED_POINT_TOL * (1.0 + x):
                vx, vy, _ = point_velocity(mo, j)
                if vx * mo.grip[j, 1] + vy * mo.grip[j, 2] > 0.0:  # the friction reversed it: it sticks
                    _hold(j, mo, sc, LOG_STICK)
                    changed = True
                continue
            x0, g0 = sc.fsec[j, 0], sc.fsec[j, 1]
            sc.fsec[j, 0], sc.fsec[j, 1] = x, g
            nxt = x + g if (x0 != x0 or g == g0) else x - g * (x - x0) / (g - g0)
            _set_impact_friction(j, max(nxt, 0.0), mo, sc)
            changed = True
    return changed


@njit(cache=True, _nrt=False)
def _slides_on(j, mo, sc):
    """A sliding point that ``stops`` held and the cone let go slides on, the other way: its
    friction is a force again from the next step (SLIDING, no longer STOPPING), against
    the velocity it had at the step's start (its sliding had reversed: ``normal_forces``)."""
    mo.touching[j] = SLIDING
    vx, vy, _ = point_velocity(sc.start, j)
    s = math.hypot(vx, vy)
    if s > V_SLIP:
        mo.grip[j, 1], mo.grip[j, 2] = -vx / s, -vy / s


@njit(cache=True, _nrt=False)
def jam(mo, sc):
    """Where the landings' friction impulses did not settle (sliding has no solution: an
    impact of Painleve's kind, where the friction would press the point harder into the
    floor than it is pressed), the points let go in this stage 2 are held instead (the
    anchor's impulse, outside the cone: a jam, logged).  Their friction impulses are withdrawn."""
    for j in range(mo.anchored.shape[0]):
        if mo.anchored[j] == 0 and sc.fimp[j, 2] > 0.0:
            _hold(j, mo, sc, LOG_JAM)


@njit(cache=True, _nrt=False)
def _hold(j, mo, sc, kind):
    """The landing j, let go in this stage 2, is held again (anchored, marked: not let go
    again in it), its friction impulse withdrawn; a sliding point (one that ``stops`` held
    and ``landing_slips`` let go) is held after all, where it is (``rules.hold_at``;
    sc.pts: the positions ``stage2.land`` took).  Its row: ``kind`` (LOG_STICK, or LOG_JAM
    where a fallback rule holds it; a landing's own row is its landing: it sticks)."""
    if mo.touching[j] != 0:
        hold_at(mo, j, sc.pts)
    if mo.touching[j] != 0 or kind == LOG_JAM:
        sc.grip_log[j, 0] = kind
    _set_impact_friction(j, 0.0, mo, sc)
    sc.fimp[j, 2] = -1.0
    mo.anchored[j] = 2
    sc.floor_on[j] = 0
    sc.fcand[j] = 0


@njit(cache=True, _nrt=False)
def _set_impact_friction(j, p, mo, sc):
    """sc.fimp[j] <- (p d, p) (d: mo.grip[j, 1:3]; p the impulse's magnitude, its mark),
    its change kicked into sc.ukc, sc.uke."""
    fx, fy = p * mo.grip[j, 1], p * mo.grip[j, 2]
    point_kick(fx - sc.fimp[j, 0], fy - sc.fimp[j, 1], 0.0, j, sc.ukc, sc.uke)
    sc.fimp[j, 0], sc.fimp[j, 1], sc.fimp[j, 2] = fx, fy, max(p, 1e-300)  # (> 0: slides)


@njit(cache=True, _nrt=False)
def clear_impact_friction(sc):
    """No landing has slipped yet in this stage 2."""
    for j in range(sc.fimp.shape[0]):
        sc.fimp[j, 0] = 0.0
        sc.fimp[j, 1] = 0.0
        sc.fimp[j, 2] = 0.0


@njit(cache=True, _nrt=False)
def impact_friction_impulse(sc):
    """The landings' friction impulses of the step into the floor's (the ledger's floor_impulse, x, y)."""
    impulse = sc.ledger.floor_impulse
    for j in range(sc.fimp.shape[0]):
        impulse[0] += sc.fimp[j, 0]
        impulse[1] += sc.fimp[j, 1]


@njit(cache=True, _nrt=False)
def normal_forces(h, mo, ws, sc):
    """After an accepted step: each sliding point's normal force over it, F_n = (P1 + P2)
    / h of its floor rows (Motion.grip[:, 0]: the next step's friction is mu F_n); 0 for a
    landing that slipped in it (its impact took its friction).  A sliding point that the
    stage 2 friction reversed (its velocity along d) is STOPPING."""
    for j in range(mo.anchored.shape[0]):
        if mo.anchored[j] != 0 or mo.touching[j] == 0:
            continue
        if sc.fimp[j, 2] > 0.0:
            mo.grip[j, 0] = 0.0
            continue
        _, _, p1 = _impulse_at(j, sc.kind1, sc.nrow1, sc.x1, True)
        _, _, p2 = _impulse_at(j, ws.kind, ws.nrow, ws.x, True)
        mo.grip[j, 0] = max(p1 + p2, 0.0) / h
        vx, vy, _ = point_velocity(mo, j)
        if vx * mo.grip[j, 1] + vy * mo.grip[j, 2] > 0.0:
            mo.touching[j] = STOPPING


@njit(cache=True, _nrt=False)
def stop_rigid_stretches(mo):
    """After an accepted step: the sliding points of a stretch lying between two held points
    whose hinges are all at their limits (or of two segments: a fold between two anchors)
    cannot move along the floor (m segments there have m - 2 freedoms in its plane, which
    m - 1 locked hinges take) and are STOPPING: anchored at the next step.  Their rows
    would only repeat one another (``stage1.STALL_TOL``).  The cone lets them go again."""
    n1 = mo.anchored.shape[0]
    a = -1  # the last held point seen
    for j in range(n1):
        if mo.anchored[j] != 0:
            if a >= 0 and j - a >= 2:
                rigid = j - a == 2
                if not rigid:
                    rigid = True
                    for k in range(a, j - 1):  # (the hinges at the stretch's inner points a + 1 .. j - 1)
                        if mo.locked[k] == 0:
                            rigid = False
                            break
                inner = True
                for i in range(a + 1, j):
                    if mo.touching[i] == 0:
                        inner = False
                        break
                if rigid and inner:
                    for i in range(a + 1, j):
                        mo.touching[i] = STOPPING
            a = j
        elif mo.touching[j] == 0:
            a = -1  # (a point off the floor: the stretch is not lying on it)


@njit(cache=True, _nrt=False)
def let_go(h, mu, mo, ws, sc):
    """After an accepted step: an anchored point (not anchored in it) whose anchor force
    F = (P1 + P2) / h, plus m g / 2 for each landed segment beside it, leaves the cone
    is let go: lifted off (F_n <= 0) or sliding (|F_t| > mu F_n: Motion.grip = (F_n,
    F_t / |F_t|), the friction's direction until it moves).  Points with no anchor rows
    (inside the pile) stay.  Returns whether any was."""
    changed = False
    n1 = mo.anchored.shape[0]
    a0 = sc.start.anchored  # (the landed segments the stages saw: those of the step's start)
    for j in range(n1):
        if mo.anchored[j] != 1 or a0[j] != 1:
            continue
        ax, ay, az = _impulse_at(j, sc.kind1, sc.nrow1, sc.x1, False)
        bx, by, bz = _impulse_at(j, ws.kind, ws.nrow, ws.x, False)
        if sc.nrow1[j] + ws.nrow[j] == 0:
            continue
        fx, fy = (ax + bx) / h, (ay + by) / h
        fn = (az + bz) / h
        if j >= 1 and is_landed(a0, j - 1):
            fn += 0.5
        if j + 1 < n1 and is_landed(a0, j):
            fn += 0.5
        ft = math.hypot(fx, fy)
        if fn > 0.0 and ft <= mu * fn:
            continue
        mo.anchored[j] = 0
        changed = True
        sc.grip_log[j, 0] = LOG_LIFT if fn <= 0.0 else LOG_SLIP
        sc.grip_log[j, 1], sc.grip_log[j, 2], sc.grip_log[j, 3] = h * fx, h * fy, h * fn
        if fn <= 0.0:
            mo.touching[j] = 0
            continue
        mo.touching[j] = SLIDING
        mo.grip[j, 0], mo.grip[j, 1], mo.grip[j, 2] = fn, fx / ft, fy / ft
    return changed


@njit(cache=True, _nrt=False)
def hold_stuck_stretch(mo, j):
    """A stage failed even at its shortest step on a row at point j (``Scratch.unmet``):
    the sliding points there are held (JAMMED, anchored at the step's start when it is taken
    again: ``hold_marked``, a ``jam`` row: a fallback rule), each whole stretch of consecutive sliding points within
    STUCK_REACH of j.  Such a stretch lies on the floor between held points with its hinges
    at their limits: its rows repeat one another (a taut or rigid stretch: m segments in
    the floor's plane have m - 2 freedoms), and the friction cone decides from the next
    step on whether it slides again (``let_go``).  Where no sliding point lies that near
    (the row is up the chain), every sliding point is held: a friction force mu F_n far
    beyond what stops a point within the step (F_n the last step's floor impulse over h:
    8.5e3 m g on one point at mu = 1e6) kicks the chain so hard that stage 1 cannot
    follow it at any step, and a point so braked sticks.  Returns how many points it marks."""
    n1 = mo.anchored.shape[0]
    if j < 0 or j >= n1:
        return 0
    lo, hi = max(j - STUCK_REACH, 0), min(j + STUCK_REACH, n1 - 1)
    marked = _hold_stretches(mo, lo, hi)
    if marked == 0:
        marked = _hold_flat_folds(mo, lo, hi)
    return marked if marked > 0 else _hold_stretches(mo, 0, n1 - 1)


@njit(cache=True, _nrt=False)
def _hold_flat_folds(mo, lo, hi):
    """Mark JAMMED each free point in lo..hi that lies on the floor (within FLAT_FOLD b)
    between two held points: a fold lying flat, whose only freedom (turning about the line
    through its neighbours) the bend rows beside it do not see at first order (their
    gradient vanishes there), so that no active set of them settles.  Returns how many."""
    n1 = mo.anchored.shape[0]
    marked = 0
    for i in range(max(lo, 1), min(hi, n1 - 2) + 1):
        if mo.anchored[i] != 0 or mo.touching[i] != 0 or mo.anchored[i - 1] == 0 or mo.anchored[i + 1] == 0:
            continue
        _, _, z = _point_height(mo, i)
        if z < FLAT_FOLD:
            mo.touching[i] = JAMMED
            marked += 1
    return marked


@njit(cache=True, _nrt=False)
def _hold_stretches(mo, lo, hi):
    """Mark JAMMED each whole stretch of consecutive sliding points that has a point in
    lo..hi; returns how many points."""
    n1 = mo.anchored.shape[0]
    marked = 0
    for i in range(lo, hi + 1):
        if mo.anchored[i] != 0 or mo.touching[i] == 0 or _marked(mo.touching[i]):
            continue
        a, b = i, i
        while a > 0 and mo.anchored[a - 1] == 0 and mo.touching[a - 1] != 0:
            a -= 1
        while b < n1 - 1 and mo.anchored[b + 1] == 0 and mo.touching[b + 1] != 0:
            b += 1
        for k in range(a, b + 1):
            mo.touching[k] = JAMMED
            marked += 1
    return marked


@njit(cache=True, inline="always")
def _marked(touching):
    """Is a point marked to be held at the next step's start (HELD or JAMMED)?"""
    return touching == HELD or touching == JAMMED


@njit(cache=True, _nrt=False)
def hold_marked(mo, sc):
    """At a step's start: the points marked HELD or JAMMED are anchored where they are
    (``rules.hold_at``), their stop logged (``stick``, or ``jam`` for a fallback rule's
    hold; the stages take their velocity, as a landing's).  A
    segment that lies between two anchors from then on has landed: the stages do not see
    it, so it is stopped here, its momentum taken by the floor (the ledger's floor_impulse; its kinetic
    energy is the step's loss, booked at the floor).  Returns how many points."""
    n = mo.e.shape[0]
    held = 0
    for j in range(n + 1):
        if _marked(mo.touching[j]) and mo.anchored[j] == 0:
            held += 1
    if held == 0:
        return 0
    point_positions(mo.c, mo.e, sc.pts)
    for j in range(n + 1):
        if _marked(mo.touching[j]):
            kind = LOG_JAM if mo.touching[j] == JAMMED else LOG_STICK
            mo.touching[j] = SLIDING
            if mo.anchored[j] == 0:
                hold_at(mo, j, sc.pts)
                mo.anchored[j] = 1
                sc.grip_log[j, 0] = kind
    for i in range(n):
        if is_landed(mo.anchored, i):
            for q in range(3):
                sc.ledger.floor_impulse[q] -= mo.vc[i, q]  # (m = 1)
                mo.vc[i, q] = 0.0
                mo.ve[i, q] = 0.0
    return held
