"""The keys of the JSON objects the command line prints (``--json``), each with what it
holds: a contract (keys are added, never renamed).  The documentation's JSON page is
generated from here, and the tests check these lists against the objects the commands
print, so a key cannot appear or go without its line here."""

from __future__ import annotations

from ..contacts.registry import all_params as contact_params
from ..methods import all_options

# ``ballchain simulate --json`` and ``ballchain info --json``: Result.summary() and the
# measures of cli.run_summary.  Units: the run's (``units``), times in its time unit.
RUN = {
    "segments": "N, the number of rods",
    "alpha": "the critical bend angle, radians",
    "floor": "the floor model: all or pivot",
    "anchor_cone": "whether the hinge limit is kept between a landed segment and the airborne one hinged to it",
    # the contact laws' parameters (contacts.registry: those with a key)
    **{name: prm.json for name, prm in contact_params().items() if prm.json is not None},
    "ic": "the initial condition (kind, eps, turns, phase, seed, modes, spawn_key), or null for an explicit state",
    "units": "nondimensional (lengths in b, times in sqrt(b/g)) or SI",
    "status": "landed, until, max_time, error or interrupted",
    "message": "why the run stopped, when it did not land",
    "z0": "the height of the top end at t = 0",
    "t_ff": "the free-fall time of the top end, sqrt(2 z0 / g)",
    "t_fall": "the time the top end first reaches the floor (null if it did not)",
    "t_landed": "the time the last segment landed (null if not)",
    "ratio": "t_fall / t_ff",
    "landed_ratio": "t_landed / t_ff",
    "events": "rows of the event log by kind (lock, unlock, landing, top, impulse, release, hold, anchor)",
    "first_lock_time": "the time of the first lock (null if none)",
    "energy": "initial, potential, kinetic, lost_locking, lost_landing, lost_damping, lost_sliding, imbalance, and the "
    "parts of the imbalance the method can name",
    "max_depth": "the deepest airborne point below the floor (0 if none)",
    "floor_impulse": "the floor's impulse on the chain at impacts, (x, y, z)",
    "floor_impulse_total": "the floor's whole impulse from t = 0 to the end, (x, y, z)",
    "method": "the integration method (event, timestep or rattle)",
    # the methods' own options (methods.all_options: those with a key), in the registry's order
    **{name: opt.json for name, opt in all_options().items() if opt.json is not None},
    "n_steps": "accepted integration steps",
    "n_evals": "evaluations of the equations of motion",
    "n_instants": "event instants (times at which one or more events were resolved)",
    "wall_seconds": "the run's wall time, s",
    "version": "the ballchain version that ran it",
    "engine": "the fingerprint of the engine's sources",
    "gamma_measured": "the Hamm-Geminard gamma measured from the floor's momentum record (null if undefined)",
    "gamma_inferred": "the Hamm-Geminard gamma whose fall takes t_fall / t_ff (null if out of range)",
    "pile_radius": "the radius of gyration of the pile on the floor at the end, seen from above (null: fewer "
    "than two points on the floor)",
    "pile_offset": "the horizontal distance of the pile's centroid from the bottom end's start (null: fewer "
    "than two points on the floor)",
    "pile_kinetic": "the kinetic energy the chain still had where the pile was read, over the initial energy "
    "(a pile on a floor that lets points slide may still be moving at the end)",
    "pull_median": "the median of the tension just above the pile (the pile's pull on the hanging chain along its "
    "lowest segment; a time-stepper's: its steps' means, impacts included) over the frames from the first landed "
    "segment to t_fall, in units "
    "of force (null: no frame with a chain hanging above a held point)",
    "wall_includes_compile": "whether the wall time includes compiling the kernels",
    "setup_seconds": "(runs of the command line) seconds spent loading or compiling the kernels before the run",
    "setup_compiled": "(runs of the command line) whether the kernels were compiled before the run",
}

# ``ballchain sweep --json``: what the sweep did (sweeps.execute.SweepReport).
SWEEP = {
    "table": "the Parquet table written",
    "total": "runs in the grid",
    "skipped": "runs already in the table (not run again)",
    "ran": "runs done now",
    "failed": "runs done now that ended with status error",
    "interrupted": "whether a signal stopped the sweep before every run was done",
    "workers": "worker processes (or the scheduler's workers)",
    "scheduler": "local, or the address of the Dask scheduler",
    "wall_seconds": "the sweep's wall time, s",
    "statuses": "rows of the table by status",
}

# ``ballchain stats --json`` (sweeps.stats.table_stats), and its points.
STATS = {
    "table": "the table read",
    "rows": "its rows",
    "engines": "the engine fingerprints that made the rows",
    "status": "rows by status",
    "points": "one object per point of the grid (keys below)",
    "optimal_alpha": "per N and floor: the alpha of the smallest mean t_fall / t_ff, with its paired "
    "bootstrap interval in degrees (ci_low_deg, ci_high_deg), n_alpha, n_starts, share_best",
    "books": "per method: runs, worst |energy imbalance| / E0, deepest point below a floor that watches every point",
    "not_landed": "the runs that did not land: run_id, status, message",
    "plot": "(with --plot) the figure written",
    "plot_n": "(with --plot-n) the figure written",
}
STATS_POINT = {
    "segments": "N",
    "alpha": "alpha, radians",
    "alpha_deg": "alpha, degrees",
    "floor": "the floor model",
    "anchor_cone": "the anchor cone setting",
    **{name: prm.column for name, prm in contact_params().items() if prm.column is not None},
    "ic": "the start's family",
    "eps": "the start's tilt",
    "method": "the integration method",
    # the methods' own options with a sweep column (methods.all_options), in the registry's order
    **{name: opt.column for name, opt in all_options().items() if opt.column is not None},
    "until": "the stop time asked for, if any",
    "n_runs": "rows of the point",
    "n_error": "rows with status error",
    "ratio": "t_fall / t_ff over the runs that fell: n, mean, median, std, ci_low, ci_high (95% bootstrap; "
    "null below 5 runs)",
    "landed_ratio": "t_landed / t_ff, as ratio",
    "faster_than_free_fall": "runs with t_fall < t_ff: k of n, fraction, ci_low, ci_high (Wilson 95%)",
}

PAGES = (
    ("ballchain simulate --json, ballchain info --json", RUN),
    ("ballchain sweep --json", SWEEP),
    ("ballchain stats --json", STATS),
    ("ballchain stats --json: each of points", STATS_POINT),
)
