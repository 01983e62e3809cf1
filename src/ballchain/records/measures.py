"""Measurements made on a Result after the run (result -> analysis -> figures).

``floor_gamma``: the Hamm-Geminard coefficient gamma measured from the floor's momentum
record.  In their model the airborne chain (mass per length mu, height z) obeys
d/dt(mu z zdot) = -mu g z + gamma mu zdot^2: the floor takes from the airborne chain
gamma times the momentum that the landing chain carries into it (mu zdot^2 per unit
time).  gamma = 1: the airborne part falls freely; gamma < 1: the pile pulls it down.
Measured on a run:

    removed(t) = J_z(t) - m g sum_i max(0, t - t_i)     the floor's impulse on the chain
                 minus the static support of the segments landed (both ends) at t_i
    carried(t) = sum_{s_i <= t} m |v_i(s_i-)|             the vertical momentum each segment
                 had when it first touched the floor (one end anchored at s_i)
    gamma      = removed / carried   over the fall, or per time window.

Counted: the segments that first touch the floor before the top end first reaches it
(t_fall, the fall time that gamma explains; the whole run if it never does).  A
segment's velocity is read at the last frame before it touches (so to
1/frames_per_tff), the floor's record J_z interpolated between frames.  Checked
against the Hamm-Geminard chain itself (tests/test_analysis.py): the estimate
converges to its gamma as the chain is cut finer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def segment_velocities(r) -> np.ndarray:
    """Velocity of each segment's centre at every frame (F, N, 3), from the frames' axes
    and angular velocities: v_i = v_point(i+1) + b w_i x e_i, point N at rest or, on a
    frictionless floor, at ``frame_base_velocity``."""
    b = r.params.half_length
    e, w = np.asarray(r.frame_e), np.asarray(r.frame_omega)
    de = b * np.cross(w, e)
    upper = 2.0 * np.cumsum(de[:, ::-1], axis=1)[:, ::-1]  # velocity of point i relative to point N
    lower = np.concatenate([upper[:, 1:], np.zeros_like(upper[:, :1])], axis=1)
    base = getattr(r, "frame_base_velocity", None)  # (records without it: the bottom end at rest)
    return lower + de + (0.0 if base is None else np.asarray(base)[:, None, :])


def momentum(r) -> np.ndarray:
    """Momentum M v_cm of the chain at every frame (F, 3)."""
    return r.params.segment_mass * np.sum(segment_velocities(r), axis=1)


def top_velocity(r) -> np.ndarray:
    """Velocity of the top end (point 0) at every frame (F, 3): v_0 = v_N + 2 b sum_i w_i x e_i."""
    b = r.params.half_length
    de = b * np.cross(np.asarray(r.frame_omega), np.asarray(r.frame_e))
    base = getattr(r, "frame_base_velocity", None)
    return 2.0 * de.sum(axis=1) + (0.0 if base is None else np.asarray(base))


def top_acceleration(r) -> np.ndarray:
    """The top end's acceleration over g at every frame (F, 3), its velocity's centred
    difference between the frames beside it (one-sided at the first and last): the mean
    over two frame intervals, impulses included (a lock inside them shows as a spike).
    a_z / g < -1: the top falls faster than free fall."""
    t = np.asarray(r.frame_t, dtype=float)
    v = top_velocity(r)
    if len(t) < 2:
        return np.full((len(t), 3), np.nan)
    return np.gradient(v, t, axis=0) / r.params.gravity


def pile_point(r) -> np.ndarray:
    """The first point from the top that the floor holds, at every frame (F,) int; -1
    where none is, or where it is the top end (nothing hangs above it)."""
    held = np.asarray(r.frame_anchored, dtype=bool)
    j = np.where(held.any(axis=1), held.argmax(axis=1), -1)
    j[j == 0] = -1
    return j


def pile_tension(r) -> np.ndarray:
    """The tension just above the pile at every frame (F,): ``frame_tension`` at the pile's
    top point (``pile_point``), the pile's pull on the hanging chain along its lowest
    segment (run units of force; NaN where no point hangs above a held one)."""
    j = pile_point(r)
    T = np.asarray(r.frame_tension, dtype=float)
    out = np.full(len(j), np.nan)
    ok = j >= 0
    out[ok] = T[np.flatnonzero(ok), j[ok]]
    return out


def pull_median(r) -> float:
    """The median of the tension just above the pile (``pile_tension``) over the frames
    from the first at which a segment lies landed (both ends held: a pile, not the foot
    alone) to t_fall; NaN where there is none."""
    t = np.asarray(r.frame_t, dtype=float)
    pull = pile_tension(r)
    held = np.asarray(r.frame_anchored, dtype=bool)
    pile = np.maximum.accumulate((held[:, :-1] & held[:, 1:]).any(axis=1)) if len(t) else np.zeros(0, bool)
    end = r.t_fall if math.isfinite(r.t_fall) else math.inf
    keep = pile & (t <= end) & np.isfinite(pull)
    return float(np.median(pull[keep])) if keep.any() else math.nan


def touch_times(r) -> np.ndarray:
    """Time each segment first touched the floor (one end anchored), (N,); NaN: never."""
    a = np.asarray(r.anchor_t, dtype=float)
    return np.fmin(a[:-1], a[1:])


def landing_times(r) -> np.ndarray:
    """Time each segment finished landing (both ends anchored), (N,); NaN: never."""
    a = np.asarray(r.anchor_t, dtype=float)
    return np.maximum(a[:-1], a[1:])  # NaN if either end never anchored


@dataclass(frozen=True)
class FloorGamma:
    """gamma measured from the floor: whole fall and per window of t/t_ff."""

    gamma: float  # removed / carried over the segments landed before t_fall
    removed: float  # the floor's impulse beyond the landed segments' support (run units)
    carried: float  # the momentum the landing segments carried in (run units)
    landed: int  # segments counted
    window_edges: np.ndarray  # (W+1,) t/t_ff
    window_gamma: np.ndarray  # (W,) NaN where nothing landed


def floor_gamma(r, windows: int = 8, velocities: np.ndarray | None = None) -> FloorGamma:
    """See the module docstring.  ``windows``: equal windows of t/t_ff from the first to
    the last touch counted.  ``velocities`` (F, N, 3): the segments' velocities at the
    frames (default: from the frames' state, ``segment_velocities``)."""
    p = r.params
    m, g = p.segment_mass, p.gravity
    ft = np.asarray(r.frame_t, dtype=float)
    J = np.asarray(r.frame_floor_impulse, dtype=float)[:, 2]
    nan = FloorGamma(math.nan, math.nan, math.nan, 0, np.array([]), np.array([]))
    if ft.size < 2 or not np.all(np.isfinite(J)):
        return nan
    v = segment_velocities(r) if velocities is None else np.asarray(velocities, dtype=float)
    # the record at the frames, and at the end of the run (the summary's total impulse)
    t_run = float(np.asarray(r.t)[-1]) if getattr(r, "t", None) is not None and len(r.t) else float(ft[-1])
    fj_t, fj = ft, J
    if t_run > ft[-1] and np.all(np.isfinite(getattr(r, "floor_impulse_total", [np.nan] * 3))):
        fj_t, fj = np.append(ft, t_run), np.append(J, float(np.asarray(r.floor_impulse_total)[2]))
    landed = landing_times(r)
    landed = landed[np.isfinite(landed)]
    touch = touch_times(r)
    t_fall = float(getattr(r, "t_fall", math.nan))
    stop = t_fall if math.isfinite(t_fall) else float(fj_t[-1])
    idx = np.flatnonzero(np.isfinite(touch) & (touch > ft[0]) & (touch < stop))
    if idx.size == 0:
        return nan
    s_i = touch[idx]
    before = np.searchsorted(ft, s_i, side="left") - 1  # the last frame before the touch
    carried_each = m * np.abs(v[before, idx, 2])

    def removed_at(t):
        return float(np.interp(t, fj_t, fj)) - m * g * float(np.sum(np.maximum(0.0, t - landed)))

    order = np.argsort(s_i)
    s_i, carried_each = s_i[order], carried_each[order]
    removed = removed_at(stop)
    carried = float(np.sum(carried_each))
    edges = np.linspace(s_i[0], s_i[-1], windows + 1) if s_i.size > 1 else np.array([s_i[0], stop])
    wg = np.full(len(edges) - 1, math.nan)
    for k in range(len(edges) - 1):
        sel = (s_i > edges[k]) & (s_i <= edges[k + 1])
        c = float(np.sum(carried_each[sel]))
        if c > 0.0:
            wg[k] = (removed_at(edges[k + 1]) - removed_at(edges[k])) / c
    return FloorGamma(
        gamma=removed / carried if carried > 0 else math.nan,
        removed=removed,
        carried=carried,
        landed=int(s_i.size),
        window_edges=edges / r.t_ff,
        window_gamma=wg,
    )


@dataclass(frozen=True)
class PileShape:
    """The pile the chain leaves on the floor at the end of a run, seen from above (the
    run's length unit): ``radius``, the radius of gyration of its points in the floor's
    plane, sqrt(mean |r_j - c|^2) over their horizontal positions r_j about their centroid
    c; ``offset``, |c|, how far that centroid lies from where the bottom end started (the
    origin); ``points``, how many points it counts; ``kinetic``, the kinetic energy the
    chain still had where the pile was read, over the initial energy (0 on a floor that
    holds what it touches once every segment has landed; on one that lets points slide the
    run ends when every point has touched the floor, and the pile may still be moving)."""

    radius: float
    offset: float
    points: int
    kinetic: float = math.nan


def pile_shape(r) -> PileShape:
    """``PileShape`` of a run's end.  The pile's points are those that have touched the
    floor (``anchor_t`` finite; point N, the bottom end, from t = 0).  Where the floor
    holds what it touches (friction inf: the anchor, and the restitution floor once a
    point stops bouncing) they are where they were anchored (``anchor_pos``, exact);
    on a floor that lets them slide they are where the last frame has them (within
    1/frames_per_tff of the end: such a pile is still moving).  NaN with fewer than two
    points."""
    touched = np.isfinite(np.asarray(r.anchor_t, dtype=float))
    e0 = float(r.energy.get("initial", math.nan)) if r.energy else math.nan
    if r.params.friction == math.inf:
        pos = np.asarray(r.anchor_pos, dtype=float)
        kinetic = float(r.energy.get("kinetic", math.nan)) / e0 if e0 else math.nan
    else:
        pts = r.points(slice(-1, None)) if len(r.frame_t) else np.zeros((1, touched.size, 3))
        pos = np.asarray(pts, dtype=float)[0]
        kinetic = float(np.asarray(r.frame_kinetic)[-1]) / e0 if len(r.frame_t) and e0 else math.nan
    xy = pos[touched, :2]
    if xy.shape[0] < 2:
        return PileShape(math.nan, math.nan, int(xy.shape[0]), kinetic)
    c = xy.mean(axis=0)
    radius = math.sqrt(float(np.mean(np.sum((xy - c) ** 2, axis=1))))
    return PileShape(radius, float(np.hypot(c[0], c[1])), int(xy.shape[0]), kinetic)


def derived_measures(result) -> dict[str, float]:
    """The measures derived from a run, computed in this one place for the summary,
    ``--json`` and the sweep table: ``gamma_measured`` (``floor_gamma``: the Hamm-Geminard
    gamma of the floor's momentum record), ``gamma_inferred`` (the gamma whose fall
    time is t_fall/t_ff, ``theory.gamma_from_time_ratio``) and the pile's shape at the
    end (``pile_shape``: ``pile_radius``, ``pile_offset``, and ``pile_kinetic``, the kinetic
    energy left there over E0) and the pile's pull (``pull_median``).  NaN where a run does
    not define them (a partial run, a ratio outside the theory's range)."""
    from ..theory import gamma_from_time_ratio

    try:
        measured = float(floor_gamma(result).gamma)
    except Exception:  # noqa: BLE001 - a partial or odd result: no measurement
        measured = math.nan
    try:
        inferred = float(gamma_from_time_ratio(result.t_fall / result.t_ff))
    except (ValueError, ZeroDivisionError):
        inferred = math.nan
    pile = pile_shape(result)
    try:
        pull = pull_median(result)
    except Exception:  # noqa: BLE001 - a partial or odd result: no measurement
        pull = math.nan
    return {
        "gamma_measured": measured,
        "gamma_inferred": inferred,
        "pile_radius": pile.radius,
        "pile_offset": pile.offset,
        "pile_kinetic": pile.kinetic,
        "pull_median": pull,
    }


@dataclass(frozen=True)
class TopInvariants:
    """The airborne top end of a run that did not land, hung on its one anchored point,
    at the frames after the run's last event (a piece that no event changes: a rigid
    body when its hinges are locked, on a frictionless pivot).  Arrays (F,) over those
    frames; run units (m g b, m b sqrt(g b), b)."""

    t_from: float  # the last event's time (run units)
    segments: int  # airborne segments of the top end (0 .. segments-1)
    t: np.ndarray  # frame times
    kinetic: np.ndarray  # T of the piece
    energy: np.ndarray  # T + U of the piece (U: m g z of its centres)
    angular_momentum_z: np.ndarray  # L_z about the vertical through the pivot
    lowest: np.ndarray  # the height of its lowest point above the floor (the pivot excluded)

    @property
    def pivot(self) -> int:
        """The anchored point the top end hangs on: the first below its segments."""
        return self.segments


def top_invariants(r) -> TopInvariants:
    """The invariants of a heavy top on a frictionless ball joint, for the airborne top end
    of a run (segments 0..k-1 airborne, point k anchored, every segment below landed) at
    the frames after its last event: its energy T + U (constant: no hinge locks or
    unlocks, no point lands, gravity and the pivot's force do no work) and its angular
    momentum about the vertical through the pivot, L_z = sum_i [m (c_i - p) x v_i + I w_i]_z
    with I = m b^2 / 3 (constant: gravity's torque about the pivot is horizontal and the
    pivot's force has no arm).  Raises ValueError when the run has no such piece."""
    p = r.params
    m, b, g = p.segment_mass, p.half_length, p.gravity
    ft = np.asarray(r.frame_t, dtype=float)
    t_from = float(np.max(r.event_t)) if len(r.event_t) else float(ft[0])
    sel = np.flatnonzero(ft > t_from)
    if sel.size == 0:
        raise ValueError("no frame after the run's last event")
    anchored = np.asarray(r.frame_anchored)[sel]
    k = int(np.argmax(anchored[0] != 0))  # the first anchored point from the top end
    if not anchored[0, k] or k == 0 or np.any(anchored[:, :k]) or not np.all(anchored[:, k:]):
        raise ValueError("the run's airborne part is not one top end hung on one anchored point")
    e = np.asarray(r.frame_e, dtype=float)[sel][:, :k]
    w = np.asarray(r.frame_omega, dtype=float)[sel][:, :k]
    v = segment_velocities(r)[sel][:, :k]  # (the landed segments below are at rest)
    # from the pivot up: lower point of segment i = 2b sum_{i<j<k} e_j, centre b e_i above it
    lower_pos = 2.0 * b * (np.cumsum(e[:, ::-1], axis=1)[:, ::-1] - e)
    c = lower_pos + b * e
    kinetic = np.sum(0.5 * m * np.sum(v * v, axis=2) + 0.5 * (m * b * b / 3.0) * np.sum(w * w, axis=2), axis=1)
    energy = kinetic + m * g * np.sum(c[:, :, 2], axis=1)
    lz = np.sum(m * np.cross(c, v)[:, :, 2] + (m * b * b / 3.0) * w[:, :, 2], axis=1)
    upper_z = lower_pos[:, :, 2] + 2.0 * b * e[:, :, 2]  # the points 0..k-1
    return TopInvariants(t_from, k, ft[sel], kinetic, energy, lz, np.min(upper_z, axis=1))
