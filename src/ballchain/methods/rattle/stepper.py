"""The RATTLE method's compiled loop (``run_steps``) and its step control (``step``):
the step is dt t_ff/N halved (``_cut``) where a stage fails or a step changes U + T beyond
its bound, lengthened again (``_growth``) as its h^3 error allows, and shortened so that
no segment turns more than TURN_MAX in a step.  One step itself: ``scheme.rattle_step``."""

from __future__ import annotations

import math

from ...contacts.coulomb import anchors, grips
from ...core.rules import (
    fall_ended,
    fall_over,
)
from ...floors.dispatch import floor_watched_range
from ...jit import entry, njit
from .books import commit
from .codes import (
    ERR_ACTIVE_SET,
    ERR_FRICTION,
    ERR_NAN,
    ERR_NEWTON,
    ERR_REBOUND,
    ERR_STEP_ENERGY,
    RT_BUFFER,
    RT_LANDED,
    RT_MAX_STEPS,
    RT_RETURN,
    RT_STOP,
)
from .frames import books_now, copy_tally, frame_substeps, record_frame
from .friction import hold_stuck_stretch
from .scheme import CUTS_MAX, SPLIT_CUTS, _budget, keep_warm_start, rattle_step
from .stage1 import floor_gap
from .state import active_points, point_vz, undo_step

GROW_AFTER = 8  # without the energy bound: steps at a halved size before the next is tried doubled
SAFETY = 0.8  # the energy control aims a step's change of U + T at this fraction of its bound
SHRINK_MIN = 1.5  # ... and shortens a refused step at least this many fold
GROW_MAX = 2.0  # ... and changes an accepted one's successor by at most this factor
TURN_MAX = 0.1  # rad: a step turns no segment further (second order needs h |w| small)
TOUCH_CUT = 0.9  # landing step "cut": a step that anchored a point that touched before this fraction of it ...
TOUCH_BEFORE = 0.98  # ... is taken again, to end this many times the touch's time after its start ...
TOUCH_MIN = 1.0 / 16.0  # ... if that is at least this fraction of the step; else ...
TOUCH_AFTER = 1.02  # ... to end this many times the touch's time after its start (the landing in it) ...
TOUCH_SHORTEST = 1.0 / 1024.0  # ... but not shorter than this fraction of the step


@njit(cache=True, _nrt=False)
def _fastest_turn(ve):
    """max_i |e_i'| = max_i |w_i| (rad per sqrt(b/g))."""
    m = 0.0
    for i in range(ve.shape[0]):
        m = max(m, ve[i, 0] ** 2 + ve[i, 1] ** 2 + ve[i, 2] ** 2)
    return math.sqrt(m)


@njit(cache=True, inline="always")
def gravity_touch(z, vz):
    """The time s at which a point at height z >= 0 with rate z' reaches the floor under
    gravity alone: z + z' s - s^2/2 = 0, s = 2 z / (sqrt(z'^2 + 2 z) - z') (sqrt(b/g))."""
    z = max(z, 0.0)
    root = math.sqrt(vz * vz + 2.0 * z) - vz
    return 2.0 * z / root if root > 0.0 else 0.0


@njit(cache=True, _nrt=False)
def touch_time(model, start, new_anchor, na):
    """The earliest ``gravity_touch`` of the points a step anchored (new_anchor[:na]) that
    the floor watched at its start (not those that landed with them: ``floor_cascade``),
    from the state at its start (``start``)."""
    s = math.inf
    j0, j1 = floor_watched_range(model.floor, start.anchored)
    for r in range(na):
        j = new_anchor[r]
        if j0 <= j < j1:
            s = min(s, gravity_touch(floor_gap(model, start, j), point_vz(start, j)))
    return s


@njit(cache=True, _nrt=False)
def landing_cut(s, h, after):
    """The rule of landing step "cut" for a step h in which a point touches the floor at s:
    (length, how).  A step taken whole resolves a landing at its end: its point stopped with
    the velocity it reached there, and the locks beside it held through the touch, though
    the exact sequence may release them before it (open, land, lock).  So a step in which
    the touch comes before TOUCH_CUT h ends just before it (TOUCH_BEFORE s; how = 1), where
    that leaves at least TOUCH_MIN h, and the step after it takes the landing, ending just
    after the touch (TOUCH_AFTER s, at least TOUCH_SHORTEST h; how = 2), if ``after``;
    else (0, 0): the step stands whole."""
    if s >= TOUCH_CUT * h:
        return 0.0, 0
    if TOUCH_BEFORE * s >= TOUCH_MIN * h:
        return TOUCH_BEFORE * s, 1
    if after:
        return max(TOUCH_AFTER * s, TOUCH_SHORTEST * h), 2
    return 0.0, 0


@njit(cache=True, inline="always")
def _cuts_landings(model, control):
    """Landing step "cut" (control.landing_cut) where points land to stay: not with
    restitution at the floor, nor on a floor that lets them slide."""
    return control.landing_cut[0] != 0 and model.e_floor == 0.0 and anchors(model.friction)


@njit(cache=True, _nrt=False)
def touch_ahead(h, model, mo, control):
    """Landing step "cut", ahead of the step: (length, how) of ``landing_cut`` for the
    earliest ``gravity_touch`` of the free points moving down, from the state now; the
    landing just after a touch (how = 2) only in the step after one that ended before a
    touch (control.last_how = 1), so that a point that hangs just above the floor cannot shrink the
    steps to TOUCH_SHORTEST.  (0, 0): the step is not cut."""
    if not _cuts_landings(model, control):
        return 0.0, 0
    s = math.inf
    j0, j1 = floor_watched_range(model.floor, mo.anchored)
    for j in range(j0, min(j1, active_points(mo.anchored))):
        if mo.anchored[j] == 0:
            vz = point_vz(mo, j)
            if vz < 0.0:
                s = min(s, gravity_touch(floor_gap(model, mo, j), vz))
    return landing_cut(s, h, control.last_how[0] == 1)


@njit(cache=True, _nrt=False)
def cut_at_touch(h, na, model, sc, control):
    """Landing step "cut", after a step h that anchored points (na) and was not cut
    (control.touch_cut = 0): (length, how) of ``landing_cut`` for the earliest touch of the points it
    anchored (``touch_time``), the step to be taken again so; (0, 0): it stands.  Catches
    the landings that ``touch_ahead`` did not foresee (a point moving up at the step's
    start, a landing right after a step that did not end before a touch)."""
    if na == 0 or control.touch_cut[0] > 0.0 or not _cuts_landings(model, control):
        return 0.0, 0
    return landing_cut(touch_time(model, sc.start, sc.new_anchor, na), h, True)


@njit(cache=True, _nrt=False)
def _cut(code, change, etol):
    """How many halvings (log2, not only whole) a refused step is shortened by: for a step
    that changed U + T by ``change`` beyond etol, the local error of a second-order step
    (h^3) brought to SAFETY etol, at least SHRINK_MIN-fold; for a failed stage, one."""
    if code != ERR_STEP_ENERGY or not (abs(change) > etol > 0.0):
        return 1.0
    return max(math.log2(SHRINK_MIN), math.log2(abs(change) / (SAFETY * etol)) / 3.0)


@njit(cache=True, _nrt=False)
def _growth(change, impact, etol, control, grip):
    """How many halvings (log2) the next step is lengthened by after one accepted: with the
    energy bound, the smooth step's change of U + T brought to SAFETY etol (h^3), by a
    factor in [1/GROW_MAX, GROW_MAX] (an impact step, whose change is its loss, keeps the
    size; with finite friction (``grip``), where points stop on the floor at almost every
    step, one halving is undone after GROW_AFTER impact steps at a size: else a step cut for
    one landing stayed cut for the rest of the fall); without the bound, one halving undone
    after GROW_AFTER steps at a size."""
    if etol > 0.0:
        if impact:
            return _count_up(control) if grip else 0.0
        if change == 0.0:
            return math.log2(GROW_MAX)
        g = math.log2(SAFETY * etol / abs(change)) / 3.0
        return min(max(g, -math.log2(GROW_MAX)), math.log2(GROW_MAX))
    return _count_up(control)


@njit(cache=True, _nrt=False)
def _count_up(control):
    """One halving undone after GROW_AFTER accepted steps at a size (control.steps_at_level counts them)."""
    control.steps_at_level[0] += 1
    if control.steps_at_level[0] >= GROW_AFTER:
        control.steps_at_level[0] = 0
        return 1.0
    return 0.0


@njit(cache=True, _nrt=False)
def _stuck(code, model):
    """Finite friction: a stage that failed even at the shortest step holds the sliding
    stretch where it failed (``friction.hold_stuck_stretch``) rather than end the run."""
    return grips(model.friction) and (code == ERR_NEWTON or code == ERR_ACTIVE_SET)


@njit(cache=True, _nrt=False)
def _level(h, mo, control, cuts_max):
    """The level of the next step (control.level), raised so that it turns no segment
    further than TURN_MAX (the landed segments, past the active points, are at rest)."""
    level = control.level[0]  # (the step is h / 2^level, level >= 0, not only whole: the energy control sets it)
    wmax = _fastest_turn(mo.ve[: active_points(mo.anchored) - 1])
    if h / 2.0**level * wmax > TURN_MAX:
        level = min(cuts_max, math.log2(h * wmax / TURN_MAX))
    control.level[0] = level
    return level


@njit(cache=True, _nrt=False)
def _retake(mo, ws, sc, books):
    """A step refused: the state back to its start, its factorisations counted."""
    undo_step(mo, sc)
    ws.valid[0] = 0
    books.n_evals[0] += sc.ledger.factorisations[0]


@njit(cache=True, _nrt=False)
def _frames_from(t, h, fbk, books):
    """After an accepted step from t of h: the frame books fbk at its start and end, the
    frames inside it pending (``frames.frame_substeps``)."""
    books_now(books, fbk)
    copy_tally(fbk.now, fbk.at_start)
    fbk.step_t[0], fbk.step_h[0], fbk.frames_due[0] = t, h, 1


@njit(cache=True, _nrt=False)
def step(t, h, model, mo, ws, sc, control, fbk, books, frames, trace, log):
    """One step from t (h at most: cut at the stop time) of the fall's motion mo, rows ws,
    scratch sc and step control, with its books, log and trace; the frames inside it are
    left pending (the frame books fbk's frames_due).  Returns (code, t + h).  (The fall's
    parts, not the ``state.Fall`` bundle: not its frame work, which a step does not use,
    ~90 arrays that every call would pass.)"""
    lg = sc.ledger
    if frames.next[0] <= t * (1.0 + 1e-12) + 1e-12:
        books_now(books, fbk)
        record_frame(t, mo, fbk, frames)
    extra = control.extra_cuts[0]
    cuts_max, split_cuts = CUTS_MAX + extra, SPLIT_CUTS + extra  # (a longer --dt halves more: ``extra_cuts``)
    level = _level(h, mo, control, cuts_max)
    h = h / 2.0**level
    left = model.t_stop - t
    if left < 2.0 * h:  # the last steps before the stop: no step shorter than h / 2
        h = left if left <= h else 0.5 * left
    whole = h
    if control.touch_cut[0] == 0.0:  # landing step "cut": a touch foreseen in the step
        control.touch_cut[0], control.touch_how[0] = touch_ahead(h, model, mo, control)
    if control.touch_cut[0] > 0.0:  # cut at a touch (``touch_ahead``, or taken again: ``cut_at_touch``)
        h = min(h, control.touch_cut[0])
    etol = control.energy_bound[0]
    code, na = _attempt(t, h, model, mo, ws, sc, etol, level < split_cuts, _budget(level, cuts_max))
    if code == ERR_FRICTION:  # taken again at its size, the points the friction reversed held
        _retake(mo, ws, sc, books)
        return 0, t
    if code < 0 and code != ERR_NAN and level < cuts_max:  # taken again, shorter
        control.level[0] = min(cuts_max, level + _cut(code, lg.energy_lost[0], etol))
        control.steps_at_level[0] = 0
        control.touch_cut[0] = 0.0  # (the shorter step may be cut at its touch again)
        _retake(mo, ws, sc, books)
        return 0, t
    if code < 0:
        undo_step(mo, sc)  # (the run ends at the last accepted state, its books true)
        ws.valid[0] = 0
        if _stuck(code, model) and hold_stuck_stretch(mo, int(sc.unmet[0])) > 0:
            books.n_evals[0] += lg.factorisations[0]
            return 0, t  # taken again with the stretch held (finite friction)
        return code, t
    cut, how = cut_at_touch(h, na, model, sc, control)
    if cut > 0.0:  # taken again, to end just before (or, where the touch is early, just after) the touch
        control.touch_cut[0], control.touch_how[0] = cut, how
        _retake(mo, ws, sc, books)
        return 0, t
    _frames_from(t, h, fbk, books)
    _accept(t, h, h == whole, level, na, model, mo, ws, sc, control, books, log)
    return _trace_step(t + h, mo, trace)


@njit(cache=True, _nrt=False)
def _attempt(t, h, model, mo, ws, sc, etol, split, budget):
    """The fall's ``rattle_step``; one whose impacts by Newton's law created energy
    (ERR_REBOUND) is taken again with its impacts inelastic.  Returns (code, new anchors)."""
    code, na = rattle_step(t, h, model, mo, ws, sc, etol, True, split, budget)
    if code == ERR_REBOUND:
        undo_step(mo, sc)
        ws.valid[0] = 0
        sc.inelastic[0] = 1
        code, na = rattle_step(t, h, model, mo, ws, sc, etol, True, split, budget)
        sc.inelastic[0] = 0
    return code, na


@njit(cache=True, _nrt=False)
def _accept(t, h, grow, level, na, model, mo, ws, sc, control, books, log):
    """A step from t of h accepted: its warm start kept, the control's next level (as its
    change of U + T asks, if it was not cut at a touch: ``grow``; ``level``: its own), its
    books and log (its frames are left pending by the caller: ``_frames_from``)."""
    lg = sc.ledger
    if control.touch_how[0] != 2:  # (a landing's own short step: its impact impulse, scaled up to the
        keep_warm_start(h, ws, sc)  # next step's size, is no guess; the step's before it is)
    control.touch_cut[0], control.last_how[0] = 0.0, control.touch_how[0]
    if grow:  # (after a step cut at its touch, the next at the size it was cut from)
        etol = control.energy_bound[0]
        control.level[0] = max(
            0.0, level - _growth(lg.energy_lost[0], lg.impact[0], etol, control, grips(model.friction))
        )
    commit(t, h, na, model, mo, ws, sc, books, log)


@njit(cache=True, _nrt=False)
def _trace_step(t_end, mo, trace):
    """The top end's height at an accepted step's end into the trace.  Returns (code, t_end):
    ERR_NAN if it is not finite."""
    kt = trace.count[0]
    z_end = mo.c[0, 2] + mo.e[0, 2]
    trace.t[kt] = t_end
    trace.z[kt] = z_end
    trace.count[0] = kt + 1
    if not math.isfinite(z_end):  # (the velocities: U + T was finite, ``rattle_step``)
        return ERR_NAN, t_end
    return 0, t_end


@entry
@njit(cache=True, nogil=True, _nrt=False)  # the GIL released: other threads (a sweep's event loop) run meanwhile
def run_steps(t, h, model, fall, books, frames, trace, log):
    """Steps of size h until the fall ends, the stop time, full buffers or
    ``model.return_every`` steps.  Returns (code, t): RT_* or a negative ERR_*."""
    mo, ws, sc, fw, control, fbk = fall
    n = mo.e.shape[0]
    room = 4 * n + 8  # (log rows a step can write at most: locks, unlocks, landings, the floor's hold)
    taken = 0
    while True:
        # the last step's frames, if pending
        code = frame_substeps(model, sc.start, sc.ledger, fw, control.extra_cuts[0], fbk, frames)
        if code != 0:
            return code, t
        if fall_over(mo.anchored, mo.anchor_t, mo.touching, model.friction, model.e_floor):
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
        code, t = step(t, h, model, mo, ws, sc, control, fbk, books, frames, trace, log)
        if code < 0:
            return code, t
        taken += 1
        if taken >= model.return_every and not fall_over(
            mo.anchored, mo.anchor_t, mo.touching, model.friction, model.e_floor
        ):
            return RT_RETURN, t
