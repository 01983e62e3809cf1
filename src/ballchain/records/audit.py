"""Every run checks its own books (the rule is here, once).

At the end of every run (and so of every sweep row) the energy books and the floor depth
are checked against stated tolerances; a run that fails them ends with status ``error``
and a message that names the book and the amounts (its data is kept).

* Energy: E0 = U + T + E_lock + E_land at the end, to ``ENERGY_RTOL`` of E0.  Each term
  comes from its own source (the state for U and T, the impulses for the losses), so the
  imbalance measures what the integrator, the projections and the impacts did not
  conserve; well-conditioned falls close it to 1e-9 of E0 and below at the default
  tolerance (``tests/test_events.py``), so 1e-8 flags a run whose books do not close.
* Depth: under a floor model that watches every free point, no point goes below the
  floor by more than ``DEPTH_TOL`` (units b): a deeper point is a missed landing.
* Anchors: in every frame, every anchored point that a turn of the airborne chain can
  move is within ``ANCHOR_TOL`` (units b) of its anchor (``anchor_miss``); a point
  further off means the constraints were broken (a projection that could not converge).
* Hinge limits: in every frame, no hinge whose limit is in force is bent past it by
  more than ``HINGE_TOL`` in the cosine (``hinge_excess``); the time-stepping method,
  whose bends pass their limits within a step and are not always put back by its
  projection, by more than ``TIMESTEP_HINGE_PER_DT`` times its --dt.

Each method states its bounds in its package (``AUDIT``, a ``methods.bounds.AuditBounds``;
``methods.audit_bounds``): the exact method's are round-off's; the time-stepper's, first
order in its step, are looser bounds (``TIMESTEP_ENERGY_RTOL``, ``TIMESTEP_DEPTH_TOL``,
``TIMESTEP_HINGE_PER_DT``) that a broken run exceeds (a chain through the floor, a
blown-up step) and a sound one does not at the default dt; the RATTLE method's hold the
floor and the bends as the exact method's and the books to 1e-2 of E0.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..floors.registry import WATCHES_EVERY_POINT
from ..methods import audit_bounds
from .result import EVENT_CODES, Result

ENERGY_RTOL = audit_bounds("event").energy_rtol  # the exact method's bounds (its package states them)
DEPTH_TOL = audit_bounds("event").depth_tol
HINGE_TOL = audit_bounds("event").hinge_tol
TIMESTEP_ENERGY_RTOL = audit_bounds("timestep").energy_rtol  # the time-stepper's
TIMESTEP_DEPTH_TOL = audit_bounds("timestep").depth_tol
TIMESTEP_HINGE_PER_DT = audit_bounds("timestep").hinge_per_dt
ANCHOR_TOL = 1e-6  # b: an anchored point this far from its anchor in a frame breaks a constraint (every method)


def tolerances(method: str) -> tuple[float, float]:
    """(energy, depth) tolerances of the books of a run by ``method`` (its package states them)."""
    b = audit_bounds(method)
    return b.energy_rtol, b.depth_tol


def _projection_share(e: dict, e0: float) -> str:
    """How much of it the projections onto the constraints made (the rest: the
    integrator's error), if the result records it."""
    pi, ps = e.get("projected_at_instants"), e.get("projected_in_steps")
    if pi is None or ps is None or not e0 > 0:
        return ""
    share = (
        f"; the projections onto the constraints changed U + T by {(pi + ps) / e0:+.3g} of E0 "
        f"({pi / e0:+.3g} at event instants, {ps / e0:+.3g} after steps)"
    )
    we = e.get("work_error_in_steps", 0.0)
    if we:
        share += f", the steps' error in gravity's work (kick against position update) {we / e0:+.3g} of E0"
    return share + ", the integrator's error the rest"


def _measured(result: Result) -> tuple[float, float, float]:
    """(E0, the imbalance, the deepest point in b: NaN unless the floor watches every
    point) of ``result``'s books."""
    e = result.energy
    depth = math.nan
    if result.params.floor in WATCHES_EVERY_POINT:
        depth = float(result.max_depth) / result.params.half_length
    return abs(float(e.get("initial", math.nan))), float(e.get("imbalance", math.nan)), depth


def anchor_miss(result: Result) -> tuple[float, float]:
    """(the largest distance of an anchored point from its anchor over the frames, in b;
    the time of that frame), over the points a turn of the airborne chain can move: the
    rule of ``core.kinematics.drift_removable`` (an anchored point whose lower segment has
    not landed), over whole frames at once.  Both
    methods keep these on their anchors to their projection's tolerance (1e-12 b to
    1e-13 N b); (0, NaN) without frames or anchors.  A point is checked in the frames from
    the last time the floor took hold of it (its last ``landing``, ``pin`` or ``stick`` row in the
    log; point N from t = 0 if it has none) on, against ``anchor_pos``, its last anchor:
    with finite friction a point can slip and be held again elsewhere, between two frames;
    at friction inf, once anchored it stays."""
    e = np.asarray(result.frame_e)
    anchored = np.asarray(result.frame_anchored) != 0
    if e.size == 0 or not anchored.any():
        return 0.0, math.nan
    anchor = np.asarray(result.anchor_pos, dtype=float)
    since = np.full(anchored.shape[1], -math.inf)
    kind, index, te = (np.asarray(getattr(result, f)) for f in ("event_kind", "event_index", "event_t"))
    took = np.isin(kind, [EVENT_CODES[k] for k in ("landing", "pin", "stick", "jam")])
    np.maximum.at(since, index[took].astype(int), te[took].astype(float))
    ft = np.asarray(result.frame_t, dtype=float)
    held = anchored & (ft[:, None] >= since[None, :])
    worst, when = 0.0, math.nan
    for k in range(e.shape[0]):
        a = held[k]
        movable = a.copy()
        movable[-1] = False  # the pivot's point: the origin of the sum
        movable[:-1] &= ~(a[:-1] & a[1:])  # the segment below has landed
        if not movable.any():
            continue
        miss = float(np.max(np.abs(result.points(k)[movable] - anchor[movable])))
        if miss > worst:
            worst, when = miss, float(result.frame_t[k])
    return worst / result.params.half_length, when


def hinge_tolerance(options) -> float:
    """The most a bend may pass its limit (in the cosine) in a frame of a run with
    ``options``: its method's bound (``AuditBounds.hinge``: per unit dt for the time-stepper)."""
    return audit_bounds(options.method).hinge(options.dt)


def hinge_excess(result: Result) -> tuple[float, float, int]:
    """(the largest cos(alpha) - cos(bend) over the frames and the hinges whose limit is
    in force, 0 if none is past it; the time of that frame; the hinge, -1 if none): the
    rule of ``core.rules.limit_in_force`` over whole frames at once (a frame has no
    anchor being made: its marks are 0 or 1)."""
    p = result.params
    e = np.asarray(result.frame_e, dtype=float)
    if e.size == 0 or p.alpha >= math.pi or e.shape[1] < 2:
        return 0.0, math.nan, -1
    anchored = np.asarray(result.frame_anchored) != 0
    cos_alpha = math.cos(p.alpha)
    worst, when, where = 0.0, math.nan, -1
    for k in range(e.shape[0]):
        a = anchored[k]
        landed = a[:-1] & a[1:]
        la, lc = landed[:-1], landed[1:]
        in_force = (~la & ~lc & ~(a[:-2] & a[2:])) | (bool(p.anchor_cone) & (la != lc))
        if not in_force.any():
            continue
        ea, ec = e[k, :-1], e[k, 1:]
        cosine = np.einsum("ij,ij->i", ea, ec) / np.sqrt(np.einsum("ij,ij->i", ea, ea) * np.einsum("ij,ij->i", ec, ec))
        excess = np.where(in_force, cos_alpha - cosine, -np.inf)
        h = int(np.argmax(excess))
        if excess[h] > worst:
            worst, when, where = float(excess[h]), float(result.frame_t[k]), h
    return worst, when, where


def audit(result: Result) -> list[str]:
    """The books of ``result`` that do not close, each as a sentence (empty: all close)."""
    failed = []
    energy_rtol, depth_tol = tolerances(result.options.method)
    e = result.energy
    e0, imbalance, depth = _measured(result)
    if not (math.isfinite(imbalance) and abs(imbalance) <= energy_rtol * e0):
        kind = "created" if imbalance < 0 else "lost unaccounted"
        failed.append(
            f"the energy books do not close: {abs(imbalance) / e0:.3g} of E0 {kind} "
            f"(E0 - U - T - the losses booked = {imbalance:.6g}; tolerance {energy_rtol:g} of E0)"
            + _projection_share(e, e0)
        )
    if result.params.floor in WATCHES_EVERY_POINT and not depth <= depth_tol:
        failed.append(f"a point went {depth:.3g} b below the floor (tolerance {depth_tol:g} b): a missed landing")
    miss, when = anchor_miss(result)
    if not miss <= ANCHOR_TOL:
        failed.append(
            f"an anchored point was {miss:.3g} b from its anchor at t = {when:.6g} "
            f"(tolerance {ANCHOR_TOL:g} b): the constraints were broken"
        )
    excess, when, hinge = hinge_excess(result)
    hinge_tol = hinge_tolerance(result.options)
    if not excess <= hinge_tol:
        failed.append(
            f"hinge {hinge} was bent past its limit by {excess:.3g} in the cosine at t = {when:.6g} "
            f"(tolerance {hinge_tol:g}): the constraints were broken"
        )
    return failed


NEAR_BOUND = 0.5  # a time-stepping run past this fraction of a bound gets a warning


def near_bounds(result: Result) -> list[str]:
    """For a time-stepping run whose books close: the ones past NEAR_BOUND of the
    method's bound, each as a sentence (its error is first order in dt: halving --dt
    halves it).  Empty for the event-driven method, whose bounds are round-off's."""
    if not audit_bounds(result.options.method).warn_near:
        return []
    energy_rtol, depth_tol = tolerances(result.options.method)
    e0, imbalance, depth = _measured(result)
    ratio = abs(imbalance) / e0 if e0 > 0 else math.nan
    out = []
    dt = result.options.dt
    if NEAR_BOUND * energy_rtol < ratio <= energy_rtol:
        out.append(
            f"the energy books close to {ratio:.3g} of E0, past half the method's bound ({energy_rtol:g}): "
            f"the error is first order, --dt {dt / 2:g} would about halve it"
        )
    if NEAR_BOUND * depth_tol < depth <= depth_tol:  # NaN (floor pivot): never
        out.append(
            f"a point went {depth:.3g} b below the floor, past half the method's bound ({depth_tol:g} b): "
            f"--dt {dt / 2:g} would about halve it"
        )
    excess, _, _ = hinge_excess(result)
    hinge_tol = hinge_tolerance(result.options)
    if NEAR_BOUND * hinge_tol < excess <= hinge_tol:
        out.append(
            f"a hinge was bent {excess:.3g} past its limit in the cosine, past half the method's bound "
            f"({hinge_tol:g}): --dt {dt / 2:g} would about halve it"
        )
    return out


def audited(result: Result) -> Result:
    """``result`` with status ``error`` and the failed books in its message if any does
    not close: they are its cause, and come first; the message of the status it had (a
    time cap, a top that keeps turning) follows as where it stopped (a run that already
    failed keeps its own cause first and gets them appended)."""
    failed = audit(result)
    if not failed:
        return result
    books = "; ".join(failed)
    if result.status == "error":
        message = f"{result.message}; {books}"
    else:
        message = books + (f" (it had stopped with status {result.status}: {result.message})" if result.message else "")
    return dataclasses.replace(result, status="error", message=message)
