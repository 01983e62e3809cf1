"""What a RATTLE fall works on (numba bundles, each allocated here beside its definition,
as ``core.state``'s): the motion in maximal coordinates (``Motion``: centres, axes and
their velocities beside the chain's anchors and locks), a step's scratch (``Scratch``)
and what it booked and counted (``StepLedger``), a frame's own copy of the motion and
scratch (``FrameWork``), the step control (``StepControl``), the books that frames
record (``FrameBooks``), and all of a fall's own bundles together (``Fall``); the
energies in these coordinates (m = b = g = 1) and the points' heights."""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ...core.rules import bottom_airborne
from ...jit import njit

PINNED, HELD = 1, 2  # Scratch.fallback's bits: a point anchored, a hinge held, by a fallback rule
MAX_NEW = 32  # new contacts in one step whose approach rates are estimated together (``impact_rates``)


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
        "touching",  # (N+1,) uint8: a point that slides on the floor (friction 0 or finite): its floor row is
        #   active (after stage 2)
        "grip",  # (N+1, 3): finite friction, a sliding point: [F_n, d_x, d_y], the floor's normal force on it
        #   over the last step and the direction of the friction force mu F_n d (``friction``)
    ],
)


# What one attempt of a step booked and counted (cleared at its start: ``clear_ledger``);
# the books take it when the step is accepted (``books.commit``), the frames inside it
# from their own steps' (``frames``), the step control its change of U + T and impact.
StepLedger = namedtuple(
    "StepLedger",
    [
        "lost_locking",  # (1,): energy the step's impacts dissipated at the hinges (m g b)
        "lost_landing",  # (1,): ... at the landings (m g b)
        "floor_impulse",  # (3,): the anchors' and the floor's impulse on the chain in the step (m sqrt(g b))
        "pile_pull",  # (3,): the pile's impulse on the hanging chain in the step (m sqrt(g b))
        "tension",  # (N+1,): the tension's impulse at every point in the step (``books.tension_impulse``)
        "energy_lost",  # (1,): U + T at the step's start minus at its end, less friction_loss and smooth_loss
        #   (m g b): what its impacts dissipated, else its error (the step control's measure)
        "friction_loss",  # (1,): what the sliding points' friction force removed (``friction.friction_work``; m g b):
        #   booked as lost_sliding
        "smooth_loss",  # (1,): what the smooth laws removed (``smooth``: the hinges' damping; m g b)
        "impact",  # (1,) uint8: 1 if the step had an impact (a landing, a new lock, a touch of the floor)
        "new_anchors",  # (1,) int64: points anchored in the step
        "factorisations",  # (1,) int64: block factorisations, whole or partial (``books.n_evals`` adds them)
        "newton_iterations",  # (1,) int64: stage 1's Newton iterations (its budget counts them)
        "stage1_rounds",  # (1,) int64: stage 1's active-set rounds
        "rounds_ended_early",  # (1,) int64: ... of them ended early, a limit or the floor found passed (``stage1``)
    ],
)


def new_step_ledger(n: int) -> StepLedger:
    """An empty ledger of an N-segment chain."""
    f, i = (lambda m=1: np.zeros(m)), (lambda: np.zeros(1, np.int64))  # noqa: E731
    return StepLedger(f(), f(), f(3), f(3), f(n + 1), f(), f(), f(), np.zeros(1, np.uint8), i(), i(), i(), i(), i())


@njit(cache=True, _nrt=False)
def clear_ledger(lg):
    """lg <- empty (an attempt's start)."""
    for a in (lg.lost_locking, lg.lost_landing, lg.energy_lost, lg.friction_loss, lg.smooth_loss):
        a[0] = 0.0
    for q in range(3):
        lg.floor_impulse[q] = 0.0
        lg.pile_pull[q] = 0.0
    for j in range(lg.tension.shape[0]):
        lg.tension[j] = 0.0
    lg.impact[0] = 0
    for a in (lg.new_anchors, lg.factorisations, lg.newton_iterations, lg.stage1_rounds, lg.rounds_ended_early):
        a[0] = 0


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
        "ledger",  # StepLedger: what the step booked and counted
        "h_last",  # (1,): the step of that stage 2 (its impulses, the warm start, scale with it)
        "unmet",  # (3,): where stage 1 last failed: the point, the row's kind, its value
        "fcand",  # (N+1,) uint8: on a frictionless floor, stage 2's candidates at the floor
        "rebound",  # (N+1,): a point bouncing off the floor in this step: the upward velocity it leaves with
        "hrebound",  # (N-1,): a hinge that rebounds from its limit in this step: the rate it leaves with
        "newrow",  # (MAX_NEW, 2) int64: the new contacts of a step (point, row), ``impact_rates``
        "inelastic",  # (1,) uint8: 1 while a step is taken again with its impacts inelastic (ERR_REBOUND)
        "fimp",  # (N+1, 3): finite friction, a landing that slips: the friction impulse of its impact (stage 2):
        #   x, y and its magnitude (0: none)
        "fsec",  # (N+1, 2): ... the last secant point of its magnitude (``friction.landing_slips``)
        "grip_log",  # (N+1, 4): finite friction, what the floor's hold on a point did in the step: [0] 0, or the
        #   event's kind (LOG_SLIP, LOG_LIFT, LOG_STICK), [1:4] the force that left the cone, times h
        "fallback",  # (N+1,) uint8: with restitution, the step's new contacts that Newton's law would rebound
        #   and a fallback rule held instead: bit 1 point j anchored (logged ``pin``), bit 2 hinge j - 1 held at its
        #   limit (logged ``hold``)
        "fdamp",  # (N, 3): the smooth laws' force on the axes at the last half kick (``smooth``)
        "vdamp",  # (N, 3): the rates it was taken at in stage 2 (2 u_half - u)
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
        np.zeros(p, np.int64), v3(p), new_step_ledger(n), np.zeros(1), np.zeros(3), np.zeros(p, np.uint8),
        np.zeros(p), np.zeros(nh), np.zeros((MAX_NEW, 2), np.int64), np.zeros(1, np.uint8), v3(p), np.zeros((p, 2)), np.zeros((p, 4)),
        np.zeros(p, np.uint8), v3(n), v3(n),
    )  # fmt: skip


# What a frame inside a step is stepped with: its own state, workspace and scratch.
FrameWork = namedtuple("FrameWork", ["motion", "ws", "sc"])


def new_frame_work(n: int) -> FrameWork:
    from .rows import new_rows

    return FrameWork(new_motion(n), new_rows(n), new_scratch(n))


# The step control: how long the next step is, and how it is cut at a touch of the floor
# (``stepper``: ``step``, ``_cut``, ``_growth``, ``touch_ahead``, ``cut_at_touch``).
StepControl = namedtuple(
    "StepControl",
    [
        "level",  # (1,): the step is dt t_ff/N / 2^level (level >= 0, not only whole: a step whose stage 1 or 2
        #   failed is taken again halved, one that changed U + T beyond energy_bound shortened as its h^3 error
        #   asks)
        "steps_at_level",  # (1,) int64: without the bound, the steps taken at that size (after GROW_AFTER the
        #   step is doubled); with it, finite friction's impact steps
        "energy_bound",  # (1,): the most a step may change U + T (SolverOptions.step_energy_tol E0; m g b; 0: no bound)
        "landing_cut",  # (1,) uint8: 1 with landing step "cut" (``stepper.landing_cut``)
        "touch_cut",  # (1,): > 0: the next step is cut at a touch of the floor to this length (sqrt(b/g))
        #   (``stepper.touch_ahead``, ``stepper.cut_at_touch``)
        "touch_how",  # (1,) int64: how: 1 to end before the touch, 2 to take the landing just after it (0: no cut)
        "last_how",  # (1,) int64: the last accepted step's touch_how
        "extra_cuts",  # (1,) int64: the halvings a step takes beyond CUTS_MAX and SPLIT_CUTS (``scheme.extra_cuts``:
        #   0 at the default --dt)
    ],
)


def new_step_control(energy_bound: float, landing_cut: bool, extra_cuts: int, level: float = 0.0) -> StepControl:
    """The control of a fall's first step (or of a copy stepped from ``level``): no cut pending."""
    i = lambda v=0: np.full(1, v, np.int64)  # noqa: E731
    return StepControl(
        np.full(1, float(level)), i(), np.full(1, float(energy_bound)), np.full(1, int(landing_cut), np.uint8),
        np.zeros(1), i(), i(), i(extra_cuts),
    )  # fmt: skip


# The books a frame records (the run's, the step's forces), as of now or at the last step's start.
Tally = namedtuple(
    "Tally",
    [
        "lost_locking",  # (1,): energy lost at the hinges so far (m g b)
        "lost_landing",  # (1,): ... at the landings (m g b)
        "floor_impulse",  # (3,): the floor's whole impulse on the chain so far (m sqrt(g b))
        "lost_damping",  # (1,): what the smooth laws removed so far (m g b)
        "lost_sliding",  # (1,): what the friction force removed from sliding points so far (m g b)
    ],
)


def new_tally() -> Tally:
    return Tally(np.zeros(1), np.zeros(1), np.zeros(3), np.zeros(1), np.zeros(1))


# What the frames inside a step are taken with (``frames``): the books now and at the last
# step's start, the step's forces, and that step (its frames pending while frames_due).
FrameBooks = namedtuple(
    "FrameBooks",
    [
        "now",  # Tally: the books at the state a frame records (after the last step, or inside it)
        "at_start",  # Tally: the books at the last step's start
        "floor_force",  # (3,): the anchors' mean force on the chain over the last step (m g)
        "pile_pull",  # (3,): the pile's mean pull on the hanging chain over the last step (m g)
        "tension",  # (N+1,): the mean tension at every point over the last step (m g)
        "step_t",  # (1,): the last step's start (sqrt(b/g))
        "step_h",  # (1,): its length (sqrt(b/g))
        "frames_due",  # (1,) uint8: 1 while frames inside it are still to be taken (the frame buffer was full)
    ],
)


def new_frame_books(n: int) -> FrameBooks:
    """Empty books of an N-segment chain, no step pending."""
    return FrameBooks(
        new_tally(), new_tally(), np.zeros(3), np.zeros(3), np.zeros(n + 1), np.zeros(1), np.zeros(1),
        np.zeros(1, np.uint8),
    )  # fmt: skip


# A RATTLE fall's own bundles (beside the shared ``core.state`` ones: books and outputs).
Fall = namedtuple(
    "Fall",
    [
        "motion",  # Motion: the state (it aliases the chain's arrays)
        "rows",  # Rows: the last stage 2's rows and factors (the next stage 1 iterates on them)
        "scratch",  # Scratch: the last step's scratch, its start and ledger
        "frame_work",  # FrameWork: what frames inside a step are stepped with
        "control",  # StepControl
        "frame_books",  # FrameBooks
    ],
)


def new_motion(n: int) -> Motion:
    """A free-standing state (a frame's copy)."""
    p = n + 1
    return Motion(
        np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)),
        np.zeros(p, np.uint8), np.zeros((p, 3)), np.zeros(p), np.zeros(max(n - 1, 0), np.uint8),
        np.zeros(p, np.uint8), np.zeros((p, 3)),
    )  # fmt: skip


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False)
def kinetic_energy_rattle(vc, ve):
    """T = sum 1/2 |c_i'|^2 + 1/6 |e_i'|^2 (m g b)."""
    tc, te = 0.0, 0.0
    for i in range(vc.shape[0]):
        tc += vc[i, 0] * vc[i, 0] + vc[i, 1] * vc[i, 1] + vc[i, 2] * vc[i, 2]
        te += ve[i, 0] * ve[i, 0] + ve[i, 1] * ve[i, 1] + ve[i, 2] * ve[i, 2]
    return 0.5 * tc + te / 6.0


@njit(cache=True, _nrt=False)
def _copy(src, dst, m):
    """dst[:m] <- src[:m] (rows of a 2-D array)."""
    for i in range(min(m, src.shape[0])):
        for q in range(src.shape[1]):
            dst[i, q] = src[i, q]


@njit(cache=True, _nrt=False)
def copy_motion(a, b):
    """b <- a (every array of a Motion)."""
    copy_motion_points(a, b, a.anchored.shape[0])


@njit(cache=True, _nrt=False)
def copy_motion_points(a, b, p):
    """b <- a on the chain's first p points: the points, the segments between them (p - 1)
    and the hinges between those (p - 2)."""
    s = p - 1
    _copy(a.c, b.c, s)
    _copy(a.e, b.e, s)
    _copy(a.vc, b.vc, s)
    _copy(a.ve, b.ve, s)
    _copy(a.anchor_pos, b.anchor_pos, p)
    _copy(a.grip, b.grip, p)
    for j in range(p):
        b.anchored[j] = a.anchored[j]
        b.anchor_t[j] = a.anchor_t[j]
        b.touching[j] = a.touching[j]
    for k in range(max(s - 1, 0)):
        b.locked[k] = a.locked[k]


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


@njit(cache=True, _nrt=False)
def point_positions(c, e, pts):
    """pts[j] <- p_j: the upper end of segment j (c + e), the last point the lower end of the
    last segment (c - e)."""
    n = e.shape[0]
    for j in range(n):
        for q in range(3):
            pts[j, q] = c[j, q] + e[j, q]
    for q in range(3):
        pts[n, q] = c[n - 1, q] - e[n - 1, q]


@njit(cache=True, _nrt=False)
def mechanical_energy(c, vc, ve):
    """U + T in maximal coordinates: sum c_i,z + 1/2 |c_i'|^2 + 1/6 |e_i'|^2 (m g b)."""
    u = 0.0
    for i in range(c.shape[0]):
        u += c[i, 2]
    return u + kinetic_energy_rattle(vc, ve)


@njit(cache=True, inline="always")
def base_at_origin(mo):
    """Is point N, the bottom end, still anchored at the origin (heights can be summed
    from it: ``core.kinematics``)?  Not on a floor that let it slide (friction 0 or finite:
    it may also be anchored again elsewhere)."""
    n = mo.e.shape[0]
    p = mo.anchor_pos
    return mo.anchored[n] != 0 and p[n, 0] == 0.0 and p[n, 1] == 0.0 and p[n, 2] == 0.0


@njit(cache=True, _nrt=False)
def active_points(anchored):
    """How many points, from the top, a step works on: down to the lower end of the segment
    below the lowest one not landed (the hinge between them may bear a limit: the anchor
    cone, ``rules.limit_in_force``).  Below them the chain has landed: no rows, no motion."""
    n = anchored.shape[0] - 1
    return min(bottom_airborne(anchored) + 3, n + 1)


@njit(cache=True, _nrt=False)
def undo_step(mo, sc):
    """mo <- the step's start (sc.start): a step changes only its own points (``active_points``
    of its start)."""
    copy_motion_points(sc.start, mo, active_points(sc.start.anchored))
