"""Frames of a RATTLE fall: each one due inside a step is taken by a second step from
that step's start to the frame's time, on a copy of the state, so that the fall does
not depend on when frames are taken (``frame_substeps``); the state and books a frame
records (``record_frame``)."""

from __future__ import annotations

from ...core.kinematics import potential_energy, rates_for_axes
from ...core.rules import (
    landed_count,
)
from ...jit import njit
from .codes import RT_BUFFER
from .scheme import CUTS_MAX, _budget, keep_warm_start, rattle_step
from .state import base_at_origin, copy_motion, kinetic_energy_rattle

# frame info (fb, FB_SIZE): [0] lost at hinges, [1] at landings, [2:5] the floor's impulse
# so far, [5:8] the anchors' mean force over the last step, [8:11] the pile's pull, [11:16]
# [0:5] at the last step's start, [16] that step's t, [17] its h, [18] 1 while frames inside
# it are still to be taken (the frame buffer was full), [19] the step's level: it is
# dt t_ff/N / 2^level (a step whose stage 1 or 2 failed is taken again halved, one that
# changed U + T beyond its bound shortened as its h^3 error asks: ``_cut``, ``_growth``),
# [20] without the bound, the steps taken at that size (after GROW_AFTER the step is
# doubled), [21] the most a step may change U + T (SolverOptions.step_energy_tol E0; 0: no bound),
# [22] 1 with landing step "cut" (``stepper.landing_cut``), [23] > 0: the step is cut at a
# touch to this length (``stepper.touch_ahead``, ``stepper.cut_at_touch``), [24] how: 1 to
# end before the touch, 2 to take the landing just after it, [25] the last accepted step's [24],
# [26] the halvings a step takes beyond CUTS_MAX and SPLIT_CUTS (``scheme.extra_cuts``: 0 at the default --dt),
# [27] lost to the hinges' damping so far, [28] at the last step's start
FB_SIZE = 29


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
    frames.lost_locking[k] = fb[0]
    frames.lost_landing[k] = fb[1]
    frames.lost_damping[k] = fb[27]
    frames.count[0] = k + 1
    frames.fill[0] = k + 1
    frames.next[0] += frames.dt


@njit(cache=True)
def _books_now(books, fb):
    fb[0] = books.lost_locking[0]
    fb[1] = books.lost_landing[0]
    for q in range(3):
        fb[2 + q] = books.floor_impulse[q] + books.floor_flow[q]
    fb[27] = books.lost_damping[0]


@njit(cache=True)
def _step_forces(h, sc, fb):
    """fb[5:11] <- the anchors' mean force and the pile's pull over a step of size h."""
    for q in range(3):
        fb[5 + q] = sc.acc[2 + q] / h
        fb[8 + q] = sc.pull[q] / h


@njit(cache=True)
def _frame_state(t, hf, model, sc, fws, fm, fsc, fb):
    """fm <- the state hf after the last step's start, and fb[0:5] its books: one step of
    hf, or, where that fails, 2, 4, ... equal steps (at most 2^(CUTS_MAX + fb[26])).  Returns the
    length of the last of them (the frame's forces are its means), or the failure's code."""
    cuts_max = CUTS_MAX + int(fb[26])
    for cuts in range(cuts_max + 1):
        m = 2**cuts
        copy_motion(sc.start, fm)
        fws.valid[0] = 0
        fsc.h_last[0] = 0.0
        for q in range(5):
            fb[q] = fb[11 + q]
        fb[27] = fb[28]
        code = 0
        for _ in range(m):
            code, _ = rattle_step(t, hf / m, model, fm, fws, fsc, 0.0, False, False, _budget(cuts, cuts_max))
            if code < 0:
                break
            keep_warm_start(hf / m, fws, fsc)
            fb[0] += fsc.acc[0]
            fb[1] += fsc.acc[1]
            fb[27] += fsc.acc[13]
            for q in range(3):
                fb[2 + q] += fsc.acc[2 + q]
            # the landed segments' weight, held up by the floor (as ``books.commit`` books it)
            fb[4] += hf / m * landed_count(fsc.start.anchored)
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
    fb[27] = fb[28] + sc.acc[13]
    fb[0] += sc.acc[0]
    fb[1] += sc.acc[1]
    for q in range(3):
        fb[2 + q] += sc.acc[2 + q]
    _step_forces(h, sc, fb)
