"""The result of one run: named fields, in the run's units (SI if the chain was given
in SI, else nondimensional m = b = g = 1).  Saved to / loaded from one HDF5 file
(see ``files.py``).

Units of every field (``UNITS``): time ``s`` (or ``sqrt(b/g)``), length ``m`` (or
``b``), force ``N`` (or ``m g``), impulse ``N s``, energy ``J`` (or ``m g b``),
angular velocity ``1/s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..contacts.registry import all_params as contact_params
from ..core.kinds import EVENT_CODES, EVENT_KINDS, EVENT_MEANINGS  # noqa: F401  (re-exported)
from ..methods import all_options
from ..model import ChainParams, InitialCondition, SolverOptions

# field -> physical quantity; unit_of turns these into unit strings
QUANTITY = {
    "z0": "length",
    "t_ff": "time",
    "t_fall": "time",
    "t_landed": "time",
    "t": "time",
    "z_top": "length",
    "frame_t": "time",
    "frame_e": "1",
    "frame_omega": "1/time",
    "frame_anchored": "1",
    "frame_locked": "1",
    "frame_floor_force": "force",
    "frame_kinetic": "energy",
    "frame_potential": "energy",
    "frame_lost_locking": "energy",
    "frame_lost_landing": "energy",
    "frame_lost_damping": "energy",
    "frame_lost_sliding": "energy",
    "frame_tension": "force",
    "frame_pile_pull": "force",
    "frame_scale_force": "force",
    "frame_floor_impulse": "impulse",
    "frame_base": "length",
    "frame_base_velocity": "velocity",
    "event_t": "time",
    "event_kind": "1",
    "event_index": "1",
    "event_impulse": "impulse",
    "event_energy": "energy",
    "event_pos": "length",
    "anchor_t": "time",
    "anchor_pos": "length",
    "floor_impulse": "impulse",
    "floor_impulse_total": "impulse",
    "max_depth": "length",
    "wall_seconds": "s",
    "n_steps": "1",
    "n_evals": "1",
    "n_instants": "1",
}


_UNITS_SI = {
    "time": "s",
    "length": "m",
    "force": "N",
    "impulse": "N s",
    "energy": "J",
    "1/time": "1/s",
    "velocity": "m/s",
    "1": "1",
    "s": "s",
}
_UNITS_ND = {
    "time": "sqrt(b/g)",
    "length": "b",
    "force": "m g",
    "impulse": "m sqrt(g b)",
    "energy": "m g b",
    "1/time": "sqrt(g/b)",
    "velocity": "sqrt(g b)",
    "1": "1",
    "s": "s",
}


def unit_of(name: str, units: str) -> str:
    """Unit string of a Result field in the given units system (``SI`` or not)."""
    table = _UNITS_SI if units == "SI" else _UNITS_ND
    return table[QUANTITY.get(name, "1")]


@dataclass
class Result:
    """Everything one run measures (docs/measures.md, section 6).

    Scalars: ``z0`` (top height at t = 0), ``t_ff = sqrt(2 z0 / g)``, ``t_fall`` (top end
    first reaches z = 0; NaN if not reached), ``t_landed`` (last segment landed; NaN if
    not reached), ``max_depth`` (deepest airborne point below the floor; 0 if none).
    ``status``: ``landed`` (ran to the end), ``until`` (stopped at the requested time),
    ``max_time`` (hit the safety cap), ``error`` (stopped by a failure; ``message``
    says why and the arrays hold what was computed up to then), ``interrupted``
    (Ctrl-C or SIGTERM; the arrays hold what was computed up to the stop).

    Trace (every accepted step and event): ``t``, ``z_top``.
    Frames (every 1/frames_per_tff of t_ff): ``frame_t``, directions ``frame_e``
    (F, N, 3), ``frame_omega`` (F, N, 3), ``frame_anchored`` (F, N+1), ``frame_locked``
    (F, N-1), ``frame_floor_force`` (F, 3: continuous force of all anchors on the
    airborne chain), ``frame_pile_pull`` (F, 3: the force of the pile on the hanging
    chain through the first anchored point from the top; z < 0 pulls down),
    ``frame_scale_force`` (F,: the vertical force a scale under the floor reads, the
    anchors' plus the weight of the landed segments; impulses excluded),
    ``frame_floor_impulse`` (F, 3: the floor's whole impulse on the chain from t = 0,
    impacts included), energies ``frame_kinetic``, ``frame_potential``,
    ``frame_lost_locking``, ``frame_lost_landing``, ``frame_lost_damping`` (cumulative: the
    hinges' viscous damping, a smooth law, removes energy between impacts),
    ``frame_lost_sliding`` (cumulative: the work of Coulomb's friction force on the points
    sliding on the floor, finite friction only), ``frame_base`` and
    ``frame_base_velocity`` (F, 3: the position and velocity of point N, the bottom end:
    zero unless it slides, on a frictionless floor), ``frame_tension`` (F, N+1: the
    tension at every point, pulling positive: the force on the segment above point j
    there, along it, -F_j . e_{j-1}; at a held point the support's pull on the segment
    above, and on the segment below at a held top end; 0 at a free end and between
    landed segments; the time-steppers' the mean over the step before the frame, its
    impacts included, 0 at t = 0; NaN in files written before it).  ``points()`` gives the positions of
    the points at every frame.
    Events, one row per constraint that acted: ``event_t``, ``event_kind`` (see
    EVENT_KINDS), ``event_index`` (hinge k = 0..N-2 between segments k and k+1, or point
    j = 0..N; points counted from the top, point N the original pivot), ``event_impulse``
    (lock, impulse, hold: (Lambda, 0, 0); landing, anchor: impulse of the floor on the
    chain), ``event_energy`` (kinetic energy that constraint dissipated), ``event_pos``
    (position of the hinge, i.e. point k + 1, or of the point j).
    Anchors: ``anchor_t`` (N+1,) time each point was anchored (NaN: never; 0 for the
    pivot), ``anchor_pos`` (N+1, 3).
    ``energy``: initial, potential, kinetic, lost_locking, lost_landing, lost_damping, lost_sliding, imbalance
    (initial - potential - kinetic - losses), at the end of the run; and what parts of
    the imbalance the method can name: ``projected_at_instants``, ``projected_in_steps``
    (U + T changed by the projections onto the constraints) and ``work_error_in_steps``
    (time-stepping: gravity's kick on T plus the position update's change of U).
    ``floor_impulse``: the floor's impulses on the chain at impacts (3,: landings and
    anchored points); ``floor_impulse_total``: its whole impulse from t = 0 to the end
    (3,: impacts, the continuous force integrated by the integrator's quadrature, and
    the support of the landed segments).  Momentum balance: ``floor_impulse_total`` =
    M (v_cm(end) - v_cm(0)) + M g t_end e_z.
    """

    params: ChainParams
    ic: InitialCondition | None
    options: SolverOptions
    version: str  # the ballchain version that ran it (ballchain.__version__)
    status: str
    message: str
    z0: float
    t_ff: float
    t_fall: float
    t_landed: float
    t: np.ndarray
    z_top: np.ndarray
    frame_t: np.ndarray
    frame_e: np.ndarray
    frame_omega: np.ndarray
    frame_anchored: np.ndarray
    frame_locked: np.ndarray
    frame_floor_force: np.ndarray
    frame_kinetic: np.ndarray
    frame_potential: np.ndarray
    frame_lost_locking: np.ndarray
    frame_lost_landing: np.ndarray
    frame_lost_damping: np.ndarray
    frame_pile_pull: np.ndarray
    frame_scale_force: np.ndarray
    frame_floor_impulse: np.ndarray
    frame_base: np.ndarray
    frame_base_velocity: np.ndarray
    frame_lost_sliding: np.ndarray
    frame_tension: np.ndarray
    event_t: np.ndarray
    event_kind: np.ndarray
    event_index: np.ndarray
    event_impulse: np.ndarray
    event_energy: np.ndarray
    event_pos: np.ndarray
    anchor_t: np.ndarray
    anchor_pos: np.ndarray
    energy: dict
    max_depth: float
    floor_impulse: np.ndarray
    floor_impulse_total: np.ndarray
    wall_seconds: float
    n_steps: int
    n_evals: int
    n_instants: int
    units: str = "nondimensional"
    extra: dict = field(default_factory=dict)
    engine: str = "unknown"  # fingerprint of the engine's sources (provenance.engine_fingerprint)

    def __repr__(self) -> str:
        """One line: the chain, the start, the method, how the run ended and the size of
        its records (the arrays themselves: the fields, ``summary()``, the tables)."""
        p, ic = self.params, self.ic
        start = "explicit state" if ic is None else f"{ic.kind}" + (f" seed {ic.seed}" if ic.kind == "random" else "")
        ratio = self.t_fall / self.t_ff if self.t_ff else math.nan
        return (
            f"Result(N={p.segments}, alpha={math.degrees(p.alpha):.4g}deg, floor={p.floor}, start={start}, "
            f"method={self.options.method}, status={self.status}, t_fall/t_ff={ratio:.6g}, "
            f"frames={len(self.frame_t)}, events={len(self.event_t)}, units={self.units})"
        )

    # ----------------------------------------------------------------- summaries
    def event_counts(self) -> dict:
        """Rows of the event log by kind (EVENT_KINDS), every kind listed."""
        k = np.asarray(self.event_kind)
        return {name: int(np.sum(k == code)) for code, name in EVENT_KINDS.items()}

    def points(self, frames=slice(None)) -> np.ndarray:
        """Positions of the points j = 0..N at the frames (F, N+1, 3), in the run's
        length unit: point N (the original pivot) at ``frame_base`` (the origin unless it
        slid, on a frictionless floor), point j at r_N + 2 b sum_{i >= j} e_i (e_i pointing
        up segment i, from point i + 1 to point i), z up, the floor at z = 0."""
        e = np.asarray(self.frame_e)[frames]
        two_b = 2.0 * self.params.half_length
        r = np.zeros(e.shape[:-2] + (e.shape[-2] + 1, 3))
        r[..., :-1, :] = two_b * np.cumsum(e[..., ::-1, :], axis=-2)[..., ::-1, :]
        return r + np.asarray(self.frame_base)[frames][..., None, :]

    @property
    def first_lock_time(self) -> float:
        k = np.asarray(self.event_kind)
        idx = np.flatnonzero(k == 1)
        return float(self.event_t[idx[0]]) if idx.size else math.nan

    @property
    def ratio(self) -> float:
        return self.t_fall / self.t_ff

    def events_table(self):
        """The event log as a pandas DataFrame, one row per constraint that acted at an
        event instant: t, kind (its name, ``EVENT_KINDS``), index (hinge k or point j),
        impulse_x/y/z, energy (kinetic energy lost there), x, y, z (the point's position).
        Units of every column in ``DataFrame.attrs["units"]``."""
        import pandas as pd

        imp, pos = np.asarray(self.event_impulse), np.asarray(self.event_pos)
        df = pd.DataFrame({
            "t": np.asarray(self.event_t),
            "kind": [EVENT_KINDS.get(int(k), str(int(k))) for k in np.asarray(self.event_kind)],
            "index": np.asarray(self.event_index),
            "impulse_x": imp[:, 0], "impulse_y": imp[:, 1], "impulse_z": imp[:, 2],
            "energy": np.asarray(self.event_energy),
            "x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2],
        })  # fmt: skip
        u = self.units
        df.attrs["units"] = {
            "t": unit_of("event_t", u), "impulse": unit_of("event_impulse", u), "energy": unit_of("event_energy", u),
            "x, y, z": unit_of("event_pos", u),
        }  # fmt: skip
        return df

    def frames_table(self):
        """One row per output frame as a pandas DataFrame: t, z_top (the top end's
        height), kinetic, potential, lost_locking, lost_landing, lost_damping, lost_sliding (the
        energy books),
        floor_force_z, pile_pull_z, scale_force, floor_impulse_z, n_landed (segments
        with both ends anchored), n_locked (locked hinges).  Units in ``attrs["units"]``;
        the frames' axes and rates stay arrays (``frame_e``, ``points()``)."""
        import pandas as pd

        anchored = np.asarray(self.frame_anchored, dtype=bool)
        landed = anchored[:, :-1] & anchored[:, 1:] if anchored.size else np.zeros((0, 0), bool)
        pts = self.points() if len(self.frame_t) else np.zeros((0, 1, 3))
        df = pd.DataFrame({
            "t": np.asarray(self.frame_t),
            "z_top": pts[:, 0, 2],
            "kinetic": np.asarray(self.frame_kinetic), "potential": np.asarray(self.frame_potential),
            "lost_locking": np.asarray(self.frame_lost_locking), "lost_landing": np.asarray(self.frame_lost_landing),
            "lost_damping": np.asarray(self.frame_lost_damping), "lost_sliding": np.asarray(self.frame_lost_sliding),
            "floor_force_z": np.asarray(self.frame_floor_force)[:, 2],
            "pile_pull_z": np.asarray(self.frame_pile_pull)[:, 2],
            "scale_force": np.asarray(self.frame_scale_force),
            "floor_impulse_z": np.asarray(self.frame_floor_impulse)[:, 2],
            "n_landed": landed.sum(axis=1), "n_locked": np.asarray(self.frame_locked, dtype=bool).sum(axis=1),
        })  # fmt: skip
        u = self.units
        df.attrs["units"] = {
            "t": unit_of("frame_t", u), "z_top": unit_of("z_top", u), "energies": unit_of("frame_kinetic", u),
            "forces": unit_of("frame_floor_force", u), "floor_impulse_z": unit_of("frame_floor_impulse", u),
        }  # fmt: skip
        return df

    def summary(self) -> dict:
        """The ``--json`` object of ``ballchain simulate`` (keys are a contract)."""

        def num(x):
            x = float(x)
            return x if math.isfinite(x) else None

        p = self.params
        return {
            "segments": p.segments,
            "alpha": p.alpha,
            "floor": p.floor,
            "anchor_cone": p.anchor_cone,
            **{  # the contact laws' parameters (contacts.registry: those with a key; inf: null)
                name: num(getattr(p, name)) for name, prm in contact_params().items() if prm.json is not None
            },
            "ic": None if self.ic is None else self.ic.to_dict(),
            "units": self.units,
            "status": self.status,
            "message": self.message,
            "z0": num(self.z0),
            "t_ff": num(self.t_ff),
            "t_fall": num(self.t_fall),
            "t_landed": num(self.t_landed),
            "ratio": num(self.t_fall / self.t_ff),
            "landed_ratio": num(self.t_landed / self.t_ff),
            "events": self.event_counts(),
            "first_lock_time": num(self.first_lock_time),
            "energy": {k: num(v) for k, v in self.energy.items()},
            "max_depth": num(self.max_depth),
            "floor_impulse": [num(v) for v in np.asarray(self.floor_impulse)],
            "floor_impulse_total": [num(v) for v in np.asarray(self.floor_impulse_total)],
            "method": self.options.method,
            **{  # the methods' own options (methods.all_options: those with a key)
                name: getattr(self.options, name) for name, opt in all_options().items() if opt.json is not None
            },
            "n_steps": int(self.n_steps),
            "n_evals": int(self.n_evals),
            "n_instants": int(self.n_instants),
            "wall_seconds": num(self.wall_seconds),
            "version": self.version,
            "engine": self.engine,
        }
