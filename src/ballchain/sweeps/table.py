"""The sweep's table: one Parquet row per run, written incrementally and atomically.

The whole table is rewritten under a temporary name and renamed over the old one
(``os.replace``, atomic on POSIX), at most every ``flush_seconds`` and at the end: after a
``kill -9`` at any moment the file is the last complete table, never a half-written one,
and the same command recomputes only the runs it does not hold.  Rows are sorted by
their inputs, so the table does not depend on the order in which runs finished.

The file states its conventions in its Parquet key-value metadata (``ballchain``: the
version, the units, the meaning of every column).
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path

import numpy as np

from ..contacts.registry import all_params as contact_params
from ..methods import all_options
from ..model import ParameterError
from ..records.result import EVENT_KINDS

# column -> (arrow type name, meaning).  Units: nondimensional m = b = g = 1 (times in
# sqrt(b/g), energies in m g b, impulses in m sqrt(g b)); ratios in units of t_ff.
COLUMNS: dict[str, tuple[str, str]] = {
    "run_id": ("string", "key of the run: every input that changes it"),
    "segments": ("int64", "N, number of rods"),
    "alpha": ("float64", "critical bend angle, rad"),
    "alpha_deg": ("float64", "critical bend angle, degrees"),
    "floor": ("string", "floor model: all or pivot"),
    "anchor_cone": ("bool", "hinge limit kept between landed and airborne segments"),
    # the contact laws' parameters (contacts.registry), in the registry's order
    **{name: (prm.column_type, prm.column) for name, prm in contact_params().items() if prm.column is not None},
    "ic": ("string", "initial-condition family"),
    "eps": ("float64", "largest initial tilt"),
    "turns": ("float64", "q of the helix / planar bend"),
    "phase": ("float64", "phi0, rad"),
    "seed": ("int64", "entropy of numpy.random.SeedSequence (random family)"),
    "spawn_key": ("string", "spawn key of the run's SeedSequence child, comma-separated ('' for none)"),
    "run_index": ("int64", "k: the run's index among the starts of its point"),
    "method": (
        "string",
        "integration method: event (event-driven), timestep (Moreau-Jean) or rattle (nonsmooth RATTLE)",
    ),
    # the methods' own options (methods.all_options: those with a column), in the registry's order
    **{name: (opt.column_type, opt.column) for name, opt in all_options().items() if opt.column is not None},
    "until": ("float64", "stop time in t_ff (NaN: until landed)"),
    "frames_per_tff": ("float64", "output frames per t_ff"),
    "version": ("string", "ballchain version that ran it (what ballchain --version printed; semantic versioning)"),
    "engine": ("string", "fingerprint of the engine's sources that ran it (rows of one engine rerun exactly)"),
    "status": ("string", "landed, until, max_time, error, interrupted"),
    "message": ("string", "why a run stopped early ('' if it did not)"),
    "ratio": ("float64", "t_fall / t_ff: top end first at z = 0 (NaN: not reached)"),
    "landed_ratio": ("float64", "t_landed / t_ff: last segment landed (NaN: not reached)"),
    "t_ff": ("float64", "free-fall time of the top end, sqrt(2 z0), sqrt(b/g)"),
    "z0": ("float64", "initial height of the top end, b"),
    "first_lock_ratio": ("float64", "first lock impact / t_ff (NaN: none)"),
    **{f"events_{name}": ("int64", f"rows of the event log of kind {name}") for name in EVENT_KINDS.values()},
    "n_instants": ("int64", "event instants handled"),
    "energy_initial": ("float64", "initial energy, m g b"),
    "energy_lost_locking": ("float64", "kinetic energy lost in hinge locking, m g b"),
    "energy_lost_landing": ("float64", "kinetic energy lost in landings, m g b"),
    "energy_lost_damping": (
        "float64",
        "energy removed by the hinges' viscous damping, m g b (empty in tables written before the column: 0)",
    ),
    "energy_lost_sliding": (
        "float64",
        "energy removed by Coulomb's friction force from sliding points, m g b (empty in tables written before the "
        "column: 0, the friction's work then in energy_lost_landing)",
    ),
    "energy_imbalance": ("float64", "initial - potential - kinetic - losses at the end, m g b"),
    "energy_work_error": (
        "float64",
        "time-stepping: gravity's kick on T plus the position update's change of U over the steps, m g b "
        "(zero in exact dynamics; part of -imbalance; empty in tables written before the column)",
    ),
    "floor_impulse_x": ("float64", "floor's impulse at impacts, x, m sqrt(g b)"),
    "floor_impulse_y": ("float64", "floor's impulse at impacts, y"),
    "floor_impulse_z": ("float64", "floor's impulse at impacts, z"),
    "floor_impulse_total_x": ("float64", "floor's whole impulse from t = 0, x, m sqrt(g b)"),
    "floor_impulse_total_y": ("float64", "floor's whole impulse from t = 0, y"),
    "floor_impulse_total_z": ("float64", "floor's whole impulse from t = 0, z (at rest: M g t_landed)"),
    "max_depth": ("float64", "deepest airborne point below the floor, b"),
    "gamma_inferred": ("float64", "Hamm-Geminard gamma whose fall time equals t_fall (NaN outside its range)"),
    "gamma_measured": (
        "float64",
        "gamma from the floor's momentum record: removed / carried momentum, "
        "landings before t_fall (analysis.floor_gamma)",
    ),
    "pile_radius": (
        "float64",
        "the pile's radius of gyration in the floor's plane at the end, b (records.measures.pile_shape; "
        "empty in tables written before the column)",
    ),
    "pile_offset": (
        "float64",
        "the horizontal distance of the pile's centroid from the bottom end's start, b (empty in tables "
        "written before the column)",
    ),
    "pile_kinetic": (
        "float64",
        "the kinetic energy left where the pile was read, over the initial energy (a pile on a floor that lets "
        "points slide may still be moving; empty in tables written before the column)",
    ),
    "pull_median": (
        "float64",
        "the median tension just above the pile over the frames from the first landed segment to t_fall, in the "
        "run's force unit (m g; "
        "records.measures.pull_median; "
        "empty in tables written before the column)",
    ),
    "wall_seconds": ("float64", "wall time of the run, s"),
    "n_steps": ("int64", "accepted integrator steps"),
    "n_evals": ("int64", "right-hand-side evaluations"),
    "worker": ("string", "where it ran"),
}
# the methods' options with a column (``methods.all_options``), in the registry's order
OPTION_COLUMNS = tuple(name for name, opt in all_options().items() if opt.column is not None)
# the contact laws' parameters with a column (``contacts.registry``)
CONTACT_COLUMNS = tuple(name for name, prm in contact_params().items() if prm.column is not None)
# the columns every sweep table has had (a file without one of them is not a sweep table;
# the methods' own columns came and come later, and are filled in when missing)
INPUT_COLUMNS = (
    "segments",
    "alpha",
    "floor",
    "anchor_cone",
    "ic",
    "eps",
    "turns",
    "phase",
    "seed",
    "spawn_key",
    "method",
    "until",
    "frames_per_tff",
)
# what tells a table's points apart (the chain: segments, alpha, floor, anchor_cone; its
# contact laws; the start's family and size; the method and its options; the stop), then
# the start
POINT_KEYS = (*INPUT_COLUMNS[:4], *CONTACT_COLUMNS, "ic", "eps", "method", *OPTION_COLUMNS, "until")
SORT_KEYS = (*POINT_KEYS, "seed", "run_index", "run_id")
# columns that differ between two executions of the same sweep (the rest must not)
VOLATILE = ("wall_seconds", "worker")
CONVENTIONS = (
    "nondimensional units m = b = g = 1: times in sqrt(b/g), lengths in b, energies in m g b, "
    "impulses in m sqrt(g b); ratio columns in units of t_ff = sqrt(2 z0 / g); one row per run; "
    "rebuild run k of a random start with: ballchain simulate --ic random --seed SEED "
    "--spawn-key SPAWN_KEY --eps EPS -N SEGMENTS --alpha ALPHA --floor FLOOR --method METHOD "
    + "".join(f"{opt.flag} {name.upper()} " for name, opt in all_options().items() if opt.column and opt.flag)
    + "".join(f"{prm.flag} {name.upper()} " for name, prm in contact_params().items() if prm.column and prm.flag)
    + "--frames-per-tff FRAMES_PER_TFF (and --until UNTIL if set; an empty value: leave the option out)"
)
EMPTY = {"string": "", "int64": 0, "float64": math.nan, "bool": False}  # a column's value for None


def schema():
    import pyarrow as pa

    types = {"string": pa.string(), "int64": pa.int64(), "float64": pa.float64(), "bool": pa.bool_()}
    meta = {"ballchain": json.dumps({"conventions": CONVENTIONS, "columns": {k: v[1] for k, v in COLUMNS.items()}})}
    return pa.schema([(k, types[t]) for k, (t, _) in COLUMNS.items()], metadata=meta)


def _num(x) -> float:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return math.nan
    return x


def input_row(task) -> dict:
    """The columns a run's inputs fill (also for a run that never started)."""
    p, ic, o = task.params, task.ic, task.options
    return {
        "run_id": task.run_id,
        "segments": p.segments,
        "alpha": p.alpha,
        "alpha_deg": math.degrees(p.alpha),
        "floor": p.floor,
        "anchor_cone": p.anchor_cone,
        **{name: getattr(p, name) for name in CONTACT_COLUMNS},
        "ic": ic.kind,
        "eps": ic.eps,
        "turns": ic.turns,
        "phase": ic.phase,
        "seed": ic.seed,
        "spawn_key": ",".join(str(k) for k in ic.spawn_key),
        "run_index": task.run_index,
        "method": o.method,
        **{  # the methods' own options (None: the column's empty value)
            name: EMPTY[opt.column_type] if getattr(o, name) is None else getattr(o, name)
            for name, opt in all_options().items()
            if opt.column is not None
        },
        "until": math.nan if o.until is None else o.until,
        "frames_per_tff": o.frames_per_tff,
    }


def result_row(task, result, worker: str = "") -> dict:
    """One row from a finished (or failed) run's Result."""
    from ..records.measures import derived_measures

    s = result.summary()
    row = input_row(task)
    fi = np.asarray(result.floor_impulse, dtype=float)
    ft = np.asarray(result.floor_impulse_total, dtype=float)
    ratio = _num(s["ratio"])
    row.update(
        {
            "version": str(result.version),
            "engine": str(result.engine),
            "status": str(result.status),
            "message": str(result.message or ""),
            "ratio": ratio,
            "landed_ratio": _num(s["landed_ratio"]),
            "t_ff": _num(result.t_ff),
            "z0": _num(result.z0),
            "first_lock_ratio": _num(result.first_lock_time) / _num(result.t_ff),
            **{f"events_{k}": int(v) for k, v in s["events"].items()},
            "n_instants": int(result.n_instants),
            **{
                f"energy_{k}": _num(result.energy.get(k))
                for k in ("initial", "lost_locking", "lost_landing", "lost_damping", "lost_sliding", "imbalance")
            },
            "energy_work_error": _num(result.energy.get("work_error_in_steps")),
            "floor_impulse_x": fi[0],
            "floor_impulse_y": fi[1],
            "floor_impulse_z": fi[2],
            "floor_impulse_total_x": ft[0],
            "floor_impulse_total_y": ft[1],
            "floor_impulse_total_z": ft[2],
            "max_depth": _num(result.max_depth),
            **derived_measures(result),
            "wall_seconds": _num(result.wall_seconds),
            "n_steps": int(result.n_steps),
            "n_evals": int(result.n_evals),
            "worker": worker,
        }
    )
    return row


def error_row(task, message: str, wall_seconds: float = math.nan, worker: str = "") -> dict:
    """The row of a run that raised (or whose worker died): its inputs, status error, the message."""
    from .. import __version__
    from ..provenance import engine_fingerprint

    row = input_row(task)
    row.update(
        {
            "version": __version__,
            "engine": engine_fingerprint(),
            "status": "error",
            "message": message,
            "wall_seconds": wall_seconds,
            "worker": worker,
        }
    )
    return row


def _complete(row: dict) -> dict:
    out = {}
    for k, (t, _) in COLUMNS.items():
        v = row.get(k)
        if v is None:
            v = EMPTY[t]
        out[k] = v
    return out


def _sort_key(row: dict):
    def k(v):
        if isinstance(v, float) and math.isnan(v):
            return (1, 0.0)
        return (0, v)

    return tuple(k(row[c]) for c in SORT_KEYS)


def read_table(path, what: str = "out") -> list[dict]:
    """The rows of an existing sweep table (ParameterError if it is not one; ``what``: the
    option or argument that named it, for the message).  Read through one open file: a
    sweep replacing the table meanwhile (``write_table``'s rename) cannot mix two versions
    (given a path, pyarrow opens it more than once: the footer of one version and the
    columns of the next)."""
    import pyarrow.parquet as pq

    if not Path(path).is_file():
        raise ParameterError(f"{what}: no such file {str(path)!r}")
    try:
        with open(path, "rb") as fh:
            t = pq.read_table(fh)
    except Exception as exc:  # noqa: BLE001 - any unreadable file: one line
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ParameterError(f"{what}: {str(path)!r} is not a readable Parquet table ({msg})") from None
    core = [c for c in ("run_id", "status", *INPUT_COLUMNS) if c not in t.column_names]
    if core:
        raise ParameterError(
            f"{what}: {str(path)!r} is not a ballchain sweep table (no column {core[0]!r})"
            + ("; choose another --out" if what == "out" else "")
        )
    # a table of an older version: columns it lacks are filled with their empty value
    return [_complete(r) for r in t.select([c for c in COLUMNS if c in t.column_names]).to_pylist()]


def write_table(path, rows: list[dict]) -> None:
    """Write every row atomically: a temporary file in the same directory, fsync, rename."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = Path(path)
    rows = sorted((_complete(r) for r in rows), key=_sort_key)
    table = pa.Table.from_pylist(rows, schema=schema())
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        pq.write_table(table, tmp)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    try:  # the rename itself survives a crash of the machine too
        fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError:  # pragma: no cover - directories that cannot be fsynced
        pass


class TableWriter:
    """Rows kept in memory, the file rewritten atomically as rows come: at most every
    ``flush_seconds``, and more often while a rewrite is cheap (the time since the last
    one at least 20 times what it took: at most 5% of the sweep's time spent writing)."""

    def __init__(self, path, rows: list[dict] | None = None, flush_seconds: float = 2.0):
        self.path = Path(path)
        self.rows = {r["run_id"]: r for r in (rows or [])}
        self.flush_seconds = flush_seconds
        self._dirty = False
        self._last = 0.0
        self._took = 0.0

    def __contains__(self, run_id: str) -> bool:
        return run_id in self.rows

    def add(self, row: dict) -> None:
        self.rows[row["run_id"]] = row
        self._dirty = True
        if time.monotonic() - self._last >= min(self.flush_seconds, 20.0 * self._took):
            self.flush()

    def flush(self) -> None:
        t0 = time.monotonic()
        if self._dirty or not self.path.exists():
            write_table(self.path, list(self.rows.values()))
            self._dirty = False
            self._took = time.monotonic() - t0
        self._last = time.monotonic()
