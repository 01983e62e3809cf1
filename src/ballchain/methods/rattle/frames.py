"""Frames of a RATTLE fall: each one due inside a step is taken by a second step from
that step's start to the frame's time, on a copy of the state, so that the fall does
not depend on when frames are taken (``frame_substeps``); the state and books a frame
records (``record_frame``), from the frame books (``state.FrameBooks``)."""

from __future__ import annotations

from ...core.kinematics import potential_energy, rates_for_axes
from ...core.rules import (
    landed_count,
)
from ...jit import njit
from .codes import RT_BUFFER
from .scheme import CUTS_MAX, _budget, keep_warm_start, rattle_step
from .state import base_at_origin, copy_motion, kinetic_energy_rattle


@njit(cache=True, _nrt=False)
def record_frame(t, mo, fbk, frames):
    """Frame frames.count[0] at time t of the state mo, with the books fbk.now and the forces in fbk."""
    k = frames.count[0]
    e = mo.e
    n = e.shape[0]
    now = fbk.now
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
        frames.floor_force[k, q] = fbk.floor_force[q]
        frames.pile_pull[k, q] = fbk.pile_pull[q]
        frames.floor_impulse[k, q] = now.floor_impulse[q]
    for j in range(n + 1):
        frames.tension[k, j] = fbk.tension[j]
    frames.scale_force[k] = fbk.floor_force[2] + landed_count(mo.anchored)
    frames.kinetic[k] = kinetic_energy_rattle(mo.vc, mo.ve)
    if base_at_origin(mo):
        frames.potential[k] = potential_energy(e)  # (from the axes, point N at the origin)
    else:  # a floor that let the bottom end slide (U = sum c_z)
        u = 0.0
        for i in range(n):
            u += mo.c[i, 2]
        frames.potential[k] = u
        for q in range(3):
            frames.base[k, q] = mo.c[n - 1, q] - mo.e[n - 1, q]
            frames.base_velocity[k, q] = mo.vc[n - 1, q] - mo.ve[n - 1, q]
    frames.lost_locking[k] = now.lost_locking[0]
    frames.lost_landing[k] = now.lost_landing[0]
    frames.lost_damping[k] = now.lost_damping[0]
    frames.lost_sliding[k] = now.lost_sliding[0]
    frames.count[0] = k + 1
    frames.fill[0] = k + 1
    frames.next[0] += frames.dt


@njit(cache=True, _nrt=False)
def books_now(books, fbk):
    """fbk.now <- the run's books."""
    now = fbk.now
    now.lost_locking[0] = books.lost_locking[0]
    now.lost_landing[0] = books.lost_landing[0]
    for q in range(3):
        now.floor_impulse[q] = books.floor_impulse[q] + books.floor_flow[q]
    now.lost_damping[0] = books.lost_damping[0]
    now.lost_sliding[0] = books.lost_sliding[0]


@njit(cache=True, _nrt=False)
def copy_tally(a, b):
    """b <- a."""
    b.lost_locking[0] = a.lost_locking[0]
    b.lost_landing[0] = a.lost_landing[0]
    for q in range(3):
        b.floor_impulse[q] = a.floor_impulse[q]
    b.lost_damping[0] = a.lost_damping[0]
    b.lost_sliding[0] = a.lost_sliding[0]


@njit(cache=True, _nrt=False)
def add_ledger(tally, lg):
    """tally += what a step booked (its ledger lg)."""
    tally.lost_locking[0] += lg.lost_locking[0]
    tally.lost_landing[0] += lg.lost_landing[0]
    tally.lost_damping[0] += lg.smooth_loss[0]
    tally.lost_sliding[0] += lg.friction_loss[0]
    for q in range(3):
        tally.floor_impulse[q] += lg.floor_impulse[q]


@njit(cache=True, _nrt=False)
def _step_forces(h, lg, fbk):
    """fbk's forces <- the anchors' mean force, the pile's pull and the tension over a step of size h (its
    ledger lg)."""
    for q in range(3):
        fbk.floor_force[q] = lg.floor_impulse[q] / h
        fbk.pile_pull[q] = lg.pile_pull[q] / h
    for j in range(fbk.tension.shape[0]):
        fbk.tension[j] = lg.tension[j] / h


@njit(cache=True, _nrt=False)
def _frame_state(t, hf, model, start, fw, extra_cuts, fbk):
    """The frame work fw's motion <- the state hf after the last step's start (``start``),
    and the frame books fbk's ``now`` its books: one step of hf, or, where that fails, 2,
    4, ... equal steps (at most 2^(CUTS_MAX + extra_cuts)).  Returns the length of the
    last of them (the frame's forces are its means), or the failure's code."""
    fm, fws, fsc = fw.motion, fw.ws, fw.sc
    cuts_max = CUTS_MAX + extra_cuts
    for cuts in range(cuts_max + 1):
        m = 2**cuts
        copy_motion(start, fm)
        fws.valid[0] = 0
        fsc.h_last[0] = 0.0
        copy_tally(fbk.at_start, fbk.now)
        code = 0
        for _ in range(m):
            code, _ = rattle_step(t, hf / m, model, fm, fws, fsc, 0.0, False, False, _budget(cuts, cuts_max))
            if code < 0:
                break
            keep_warm_start(hf / m, fws, fsc)
            add_ledger(fbk.now, fsc.ledger)
            # the landed segments' weight, held up by the floor (as ``books.commit`` books it)
            fbk.now.floor_impulse[2] += hf / m * landed_count(fsc.start.anchored)
        if code == 0:
            return hf / m
    return code


@njit(cache=True, _nrt=False)
def frame_substeps(model, start, ledger, fw, extra_cuts, fbk, frames):
    """The frames due strictly inside the last step (the frame books fbk's step_t, step_h):
    each from a step of its own from the step's start (``start``, the fall's scratch's) to
    the frame's time, on the frame work fw's copy (the fall itself is not touched), with
    the books at the step's start plus that step's (its ``ledger``; ``extra_cuts``: the
    step control's).  Returns 0, RT_BUFFER (full: frames_due stays 1, the rest are taken
    on the next call) or the code of a sub-step that failed.  (The fall's parts, not the
    ``state.Fall`` bundle: not its rows, scratch and motion, ~80 arrays.)"""
    if fbk.frames_due[0] == 0:
        return 0
    t, h = fbk.step_t[0], fbk.step_h[0]
    while frames.next[0] < t + h * (1.0 - 1e-9):
        if frames.count[0] >= frames.t.shape[0] - 1:
            return RT_BUFFER
        hf = frames.next[0] - t
        last = _frame_state(t, hf, model, start, fw, extra_cuts, fbk)
        if last < 0.0:
            return int(last)
        _step_forces(last, fw.sc.ledger, fbk)
        record_frame(frames.next[0], fw.motion, fbk, frames)
    fbk.frames_due[0] = 0
    _books_after_step(h, ledger, fbk)
    return 0


@njit(cache=True, _nrt=False)
def _books_after_step(h, lg, fbk):
    """The frame books back to the books after the last step (at its start plus its ledger lg), and its forces."""
    copy_tally(fbk.at_start, fbk.now)
    add_ledger(fbk.now, lg)
    _step_forces(h, lg, fbk)
