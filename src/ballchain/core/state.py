"""The kernel state as named bundles, each allocated here beside its definition.

The way MuJoCo splits a constant model (``mjModel``) from all mutable data (``mjData``):

* ``Model``: what does not change during a run (the bend limit, the floor model, the
  tolerances, the stop time);
* ``Chain``: the mechanical state (axes and angular velocities, anchors, locks);
* ``Work``: the O(N) solver's workspace (constraint rows, factors, multipliers);
* ``Books``: the run's accounts, shared by every method (energy lost, the floor's
  impulse, t_fall and t_landed, counts, the lowest point seen);
* ``Frames``, ``Trace``, ``Log``: the outputs (frames at fixed times, z_top at every
  step, the event log).

The bundles are ``collections.namedtuple`` instances of arrays (numba types them as
named tuples: fields are read by name in compiled code, and arrays are mutable in place);
scalars in ``Model`` are constants.  Nondimensional units (m = b = g = 1).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

MAXR = 7  # constraint rows per point at most: 3 + 3 + 1

Model = namedtuple(
    "Model",
    [
        "alpha",  # bend limit (rad)
        "cos_alpha",  # cos(alpha): a hinge is at its limit when e_k . e_{k+1} = cos_alpha
        "floor",  # the floor model's code (floors.registry)
        "cone",  # keep the limit between a landed and an airborne segment (anchor_cone)
        "rtol",  # relative (and absolute) tolerance of the integrator
        "xtol",  # event-time tolerance (sqrt(b/g))
        "hold_rate",  # accumulation rule: hold a returning hinge slower than this (sqrt(g/b))
        "hold_apex",  # accumulation rule: hold a hinge whose excursion stays below this
        "hold_rate_floor",  # accumulation rule at the floor: anchor a bouncing point returning slower (sqrt(g b))
        "t_stop",  # stop time (sqrt(b/g))
        "max_steps",  # integrator steps at most
        "max_events",  # event instants at most
        "zeno_window",  # event accumulation: ZENO_EVENTS instants within this time stop the run
        "return_every",  # event instants handled in compiled code between returns to Python
        "theta",  # time-stepping: the axes turn by h (theta w+ + (1 - theta) w)
        "dt_rule",  # time-stepping: how steps are sized (methods.DT_RULES: 0 fixed, 1 landing)
        "v_ff",  # time-stepping, dt_rule landing: g t_ff, the speed of free fall at t_ff (sqrt(g b))
        "e_lock",  # Newton's restitution at the bend limit (contacts.newton; 0: the hinge locks)
        "e_floor",  # Newton's restitution at the floor (contacts.newton; 0: a landing point is anchored)
        "friction",  # Coulomb's friction coefficient at the floor (contacts.coulomb; inf: the anchor)
        "damping",  # the hinges' viscous coefficient C (contacts.damping; 0: free hinges), m g b sqrt(b/g)
    ],
)


def new_model(alpha, floor, cone, options, t_stop, zeno_window, return_every, dt_rule=0, v_ff=0.0, laws=None) -> Model:
    """The constant model of a run (``options``: ``model.SolverOptions``; ``dt_rule``,
    ``v_ff``: the time-stepper's step rule, as its code, and g t_ff).  ``laws``: the run's
    ``ChainParams``, the one place the methods' runs read the contact laws from (the
    restitutions, the friction and the hinges' damping, this in units of m g b sqrt(b/g));
    None: every law at its default."""
    if laws is None:
        e_lock, e_floor, friction, damping = 0.0, 0.0, math.inf, 0.0
    else:
        e_lock, e_floor, friction = laws.restitution_lock, laws.restitution_floor, laws.friction
        damping = laws.hinge_damping / laws.damping_unit
    return Model(
        float(alpha),
        math.cos(alpha),
        np.int64(floor),
        np.bool_(cone),
        float(options.rtol),
        float(options.event_xtol),
        float(options.hold_rate),
        float(options.hold_apex),
        float(options.hold_rate if options.hold_rate_floor is None else options.hold_rate_floor),
        float(t_stop),
        np.int64(options.max_steps),
        np.int64(options.max_events),
        float(zeno_window),
        np.int64(return_every),
        float(options.theta),
        np.int64(dt_rule),
        float(v_ff),
        float(e_lock),
        float(e_floor),
        float(friction),
        float(damping),
    )


Base = namedtuple(
    "Base",
    [
        "cm0",  # (3,): the centre of mass at t0 (its height used in flight only)
        "vcm0",  # (3,): its velocity at t0 (the horizontal part for the whole run)
        "t0",  # (1,): when cm0, vcm0 were taken (the start, or the whole chain leaving the floor)
        "flying",  # (1,) int64: 1 while the whole chain is off the floor and cm0, vcm0, t0 describe its flight
    ],
)
Chain = namedtuple(
    "Chain",
    [
        "Y",  # (2, N, 3): Y[0] the unit axes e (lower end -> upper end), Y[1] the angular velocities w
        "anchored",  # (N+1,) uint8: point held by the floor (2 while its impact is solved)
        "locked",  # (N-1,) uint8: hinge held at its limit
        "lock_cos",  # (N-1,): the cosine each lock holds (cos_alpha to within the event tolerance)
        "anchor_pos",  # (N+1, 3): where each anchored point is held (NaN: free)
        "anchor_t",  # (N+1,): when it was anchored (NaN: free)
        "base",  # Base: where point N is on a frictionless floor (``core.base``; unused on the others)
    ],
)


def new_base() -> Base:
    """A chain whose centre of mass is at the origin at rest at t = 0 (``base.set_base`` sets it)."""
    return Base(np.zeros(3), np.zeros(3), np.zeros(1), np.zeros(1, np.int64))


def new_chain(e0: np.ndarray, w0: np.ndarray, alpha: float) -> Chain:
    """The chain at rest on its pivot (point N anchored at the origin), axes e0, rates w0."""
    n = e0.shape[0]
    nh = max(n - 1, 0)
    Y = np.zeros((2, n, 3))
    Y[0] = e0
    Y[1] = w0
    anchored = np.zeros(n + 1, np.uint8)
    anchored[n] = 1
    anchor_pos = np.full((n + 1, 3), np.nan)
    anchor_pos[n] = 0.0
    anchor_t = np.full(n + 1, np.nan)
    anchor_t[n] = 0.0
    return Chain(Y, anchored, np.zeros(nh, np.uint8), np.full(nh, math.cos(alpha)), anchor_pos, anchor_t, new_base())


# The smooth laws' constants (``core.forces`` reads them; ``Model`` has the same fields)
SmoothLaws = namedtuple("SmoothLaws", ["damping"])  # the hinges' viscous coefficient C (m g b sqrt(b/g))

Work = namedtuple(
    "Work",
    [
        "J",  # (N+1, MAXR, 12): constraint rows per point (segment above: columns 0:6, below: 6:12)
        "kind",  # (N+1, MAXR) int8: each row's kind (dynamics.ROW_*)
        "nrow",  # (N+1,) int64: rows per point
        "S",  # (N+1, MAXR+3, MAXR): block factors, then factor4's restart record
        "G",  # (N+1, MAXR, MAXR): coupling blocks
        "drop",  # (N+1, MAXR) uint8: redundant rows dropped
        "rhs",  # (N+1, MAXR): right-hand sides
        "x",  # (N+1, MAXR): multipliers (forces, lock multipliers, impulses)
        "gf",  # (N, 6): force and torque of the multipliers on each segment
        "laws",  # the smooth laws' constants (forces.SmoothLaws, from the Model: the accelerations read them here)
        "tau",  # (N, 3): the smooth laws' torques on the segments at the last evaluation (core.forces)
        "power",  # (1,): the power they removed there (m g b / sqrt(b/g))
    ],
)


def new_work(n: int, model=None) -> Work:
    """Preallocated arrays for the O(N) kernels of an N-segment chain (``model``: the run's
    ``Model``, whose smooth laws the accelerations apply; none without it)."""
    p = n + 1
    return Work(
        np.zeros((p, MAXR, 12)),
        np.zeros((p, MAXR), dtype=np.int8),
        np.zeros(p, dtype=np.int64),
        np.zeros((p, MAXR + 3, MAXR)),
        np.zeros((p, MAXR, MAXR)),
        np.zeros((p, MAXR), dtype=np.uint8),
        np.zeros((p, MAXR)),
        np.zeros((p, MAXR)),
        np.zeros((n, 6)),
        SmoothLaws(0.0 if model is None else float(model.damping)),
        np.zeros((n, 3)),
        np.zeros(1),
    )


Books = namedtuple(
    "Books",
    [
        "lost_locking",  # (1,): kinetic energy lost at the hinges' impacts (m g b)
        "lost_landing",  # (1,): kinetic energy lost at the floor's impacts (m g b)
        "floor_impulse",  # (3,): the floor's impulses at impacts (m sqrt(g b))
        "floor_flow",  # (3,): the floor's continuous impulse (forces integrated over time)
        "t_fall",  # (1,): the top end first reaches the floor (NaN: not yet)
        "t_landed",  # (1,): every segment has landed (NaN: not yet)
        "lowest",  # (1,): the lowest point height seen (<= 0; max depth = -lowest)
        "n_steps",  # (1,) int64: integrator steps
        "n_evals",  # (1,) int64: evaluations of the equations of motion
        "n_instants",  # (1,) int64: event instants handled
        "projected",  # (2,): energy U + T changed by the projections onto the constraints (m g b):
        #   [0] at event instants, [1] after integrator steps (part of the imbalance, reported)
        "work_error",  # (1,): time-stepping: gravity's kick on T plus the position update's change of U,
        #   summed over the steps (m g b; zero in exact dynamics: part of -imbalance, reported)
        "lost_damping",  # (1,): energy the smooth laws removed, their power integrated (contacts.damping; m g b)
        "lost_sliding",  # (1,): energy the friction force removed from sliding points, its work (contacts.coulomb; m g b)
    ],
)


def new_books() -> Books:
    """Empty accounts."""
    return Books(
        np.zeros(1),
        np.zeros(1),
        np.zeros(3),
        np.zeros(3),
        np.full(1, math.nan),
        np.full(1, math.nan),
        np.zeros(1),
        np.zeros(1, np.int64),
        np.zeros(1, np.int64),
        np.zeros(1, np.int64),
        np.zeros(2),
        np.zeros(1),
        np.zeros(1),
        np.zeros(1),
    )


Frames = namedtuple(
    "Frames",
    [
        "dt",  # time between frames (a constant)
        "next",  # (1,): time of the next frame
        "count",  # (1,) int64: frames in the buffers
        "fill",  # (1,) int64: frames whose impact books are filled in (the rest get them on return)
        "t",
        "e",
        "omega",
        "anchored",
        "locked",
        "floor_force",
        "kinetic",
        "potential",
        "pile_pull",
        "scale_force",
        "floor_impulse",
        "lost_locking",
        "lost_landing",
        "lost_damping",  # the smooth laws' loss to the frame's time (Books.lost_damping plus the step's part)
        "base",  # (3,): the position of point N (the bottom end): 0 unless it slides (a frictionless floor)
        "base_velocity",  # (3,): its velocity
        "lost_sliding",  # the friction force's work on sliding points to the frame's time (Books.lost_sliding)
        "tension",  # (N+1,): the tension at every point (``dynamics.chain_tension``; a stepper's: the step's mean)
    ],
)
FRAME_FIELDS = Frames._fields[4:]  # the per-frame arrays, in the order of the fields


def new_frames(n: int, dt: float, cap: int) -> Frames:
    """Frame buffers for ``cap`` frames of an N-segment chain, one every ``dt``."""
    nh = max(n - 1, 0)
    return Frames(
        float(dt),
        np.zeros(1),
        np.zeros(1, np.int64),
        np.zeros(1, np.int64),
        np.zeros(cap),
        np.zeros((cap, n, 3)),
        np.zeros((cap, n, 3)),
        np.zeros((cap, n + 1), np.uint8),
        np.zeros((cap, nh), np.uint8),
        np.zeros((cap, 3)),
        np.zeros(cap),
        np.zeros(cap),
        np.zeros((cap, 3)),
        np.zeros(cap),
        np.zeros((cap, 3)),
        np.zeros(cap),
        np.zeros(cap),
        np.zeros(cap),
        np.zeros((cap, 3)),
        np.zeros((cap, 3)),
        np.zeros(cap),
        np.zeros((cap, n + 1)),
    )


Trace = namedtuple("Trace", ["t", "z", "count"])  # z_top at every step and event; count: rows written


def new_trace(cap: int = 65536) -> Trace:
    return Trace(np.zeros(cap), np.zeros(cap), np.zeros(1, np.int64))


Log = namedtuple(
    "Log",
    [
        "t",
        "kind",  # rules.EVENT_KINDS
        "index",  # hinge k or point j
        "impulse",  # (rows, 3)
        "energy",  # kinetic energy lost by this constraint
        "pos",  # (rows, 3): position of the point
        "n",  # (1,) int64: rows written
    ],
)


def new_log(cap: int, n_rows=None) -> Log:
    """An event log with room for ``cap`` rows (``n_rows``: the shared row counter)."""
    return Log(
        np.zeros(cap),
        np.zeros(cap, np.int64),
        np.zeros(cap, np.int64),
        np.zeros((cap, 3)),
        np.zeros(cap),
        np.zeros((cap, 3)),
        np.zeros(1, np.int64) if n_rows is None else n_rows,
    )
