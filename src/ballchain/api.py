"""ballchain from Python in one import: ``import ballchain as bc``.

    r = bc.simulate(segments=128, alpha="45deg", floor="all", ic="random", seed=3, rtol=1e-9)
    r.events_table()            # the event log as a pandas DataFrame
    bc.save(r, "run.h5"); r2 = bc.load("run.h5")
    table = bc.sweep(segments=[16, 32], alpha=["30deg", "45deg"], runs=4)   # a pandas DataFrame
    bc.stats(table)

The keywords are the command line's options (``ballchain simulate --help``); angles are
strings (``"45deg"``, ``"pi/4"``) or radians; the parameter dataclasses are accepted as
well (``params=``, ``ic=``, ``options=``).  Defaults are the dataclasses' own.
"""

from __future__ import annotations

import tempfile
from dataclasses import fields
from pathlib import Path
from typing import Any

from .contacts.registry import all_params as contact_params
from .inputs import build_inputs, check_start
from .methods import option_names
from .methods.checkpoint import DEFAULT_EVERY
from .model import ChainParams, InitialCondition, ParameterError, SolverOptions

SIMULATE_KEYWORDS = (
    "segments", "alpha", "floor", "anchor_cone",
    *contact_params(),  # the contact laws' parameters (contacts.registry)
    "ic", "eps", "turns", "phase", "seed", "spawn_key",
    "until", "max_time", "max_events", "frames_per_tff", "method",
    *option_names("simulate"),  # the methods' own options (methods.all_options)
    "length", "mass", "gravity", "initial",
)  # fmt: skip


def _keywords_doc(command: str, names, defaults: dict | None = None) -> str:
    """The keywords ``names`` with the help of ``ballchain COMMAND``'s options of the same
    name (one source: the command line's help), appended to a docstring."""
    from .cli import command_options

    options = command_options(command)
    lines = [
        "",
        "",
        f"    Keywords (the options of ``ballchain {command}``; their help, read from the command line):",
        "",
    ]
    for name in names:
        text, default = options[name]
        default = (defaults or {}).get(name, default) if "default" not in text.lower() else None
        lines += [f"    ``{name}``", f"        {text}" + ("" if default is None else f" Default: ``{default!r}``."), ""]
    return "\n".join(lines)


def _spawn_text(key) -> str:
    if isinstance(key, (tuple, list)):
        return ",".join(str(int(k)) for k in key)
    return str(key)


def simulate(
    params: ChainParams | None = None,
    ic: InitialCondition | str | None = None,
    options: SolverOptions | None = None,
    *,
    progress=None,
    checkpoint=None,
    **keywords: Any,
):
    """One fall: ``simulate(segments=128, alpha="45deg", ...)`` (the CLI's options as
    keywords), or ``simulate(ChainParams(...), InitialCondition(...), SolverOptions(...))``.
    ``initial``: an initial state instead of ``ic`` (an N x 3 or N x 6 array, or a file as
    ``--initial`` takes).  Returns the ``Result`` (in SI units if ``length``/``mass`` were
    given).  ``checkpoint``: a file the run saves its state to every 10 minutes and
    resumes from (``engine.simulate``).  Unknown keywords raise TypeError; invalid
    values ParameterError."""
    from .engine import simulate as run

    unknown = sorted(set(keywords) - set(SIMULATE_KEYWORDS))
    if unknown:
        raise TypeError(
            f"simulate() got unknown keyword(s) {', '.join(unknown)}; known: {', '.join(SIMULATE_KEYWORDS)}"
        )
    if keywords.get("initial") is not None:
        check_start([*keywords, *(["ic"] if ic is not None else [])], "initial=")
    if isinstance(ic, InitialCondition):
        if any(k in keywords for k in ("eps", "turns", "phase", "seed", "spawn_key")):
            raise TypeError("give the start either as ic=InitialCondition(...) or as keywords, not both")
    elif ic is not None:
        keywords["ic"] = ic
        ic = None
    state = None
    initial = keywords.pop("initial", None)
    if initial is not None:
        state = _initial_state(initial)
        keywords.setdefault("segments", state[0].shape[0])
    if "spawn_key" in keywords:
        keywords["spawn_key"] = _spawn_text(keywords["spawn_key"])
    kw_params, kw_ic, kw_options = build_inputs(keywords)
    if params is not None and any(
        k in keywords for k in ("segments", "alpha", "floor", "anchor_cone", *contact_params())
    ):
        raise TypeError("give the chain either as params=ChainParams(...) or as keywords, not both")
    return run(
        params if params is not None else kw_params,
        ic if ic is not None else kw_ic,
        options if options is not None else kw_options,
        state=state,
        progress=progress,
        checkpoint=checkpoint,
    )


_DEFAULTS = {
    f.name: getattr(d, f.name) for d in (ChainParams(), InitialCondition(), SolverOptions()) for f in fields(d)
}
simulate.__doc__ += _keywords_doc("simulate", SIMULATE_KEYWORDS, {**_DEFAULTS, "ic": InitialCondition().kind})


def _initial_state(initial):
    import numpy as np

    from .initial import load_initial_state

    if isinstance(initial, (str, Path)):
        return load_initial_state(str(initial))
    a = np.asarray(initial, dtype=float)
    if a.ndim != 2 or a.shape[1] not in (3, 6):
        raise ParameterError(f"initial: expected an N x 3 or N x 6 array, got shape {a.shape}")
    return a[:, :3].copy(), (a[:, 3:].copy() if a.shape[1] == 6 else None)


def load(path):
    """The ``Result`` saved in an HDF5 file (``save``, ``ballchain simulate --output``)."""
    from .records.files import load_result

    return load_result(path)


def save(result, path, *, force: bool = False) -> Path:
    """Save a ``Result`` to an HDF5 file (atomically; an existing file only with force)."""
    from .records.files import save_result

    return save_result(result, path, force=force)


SWEEP_KEYWORDS = {  # the grid and the per-run options, as ``ballchain sweep`` takes them, with their defaults
    "segments": (64,),
    "alpha": ("45deg",),
    "floor": ("all",),
    **{name: prm.default for name, prm in contact_params().items()},  # the contact laws' parameters
    "ic": ("random",),
    "runs": 1,
    "seed": 0,
    "eps": InitialCondition.eps,
    "until": SolverOptions.until,
    "frames_per_tff": SolverOptions.frames_per_tff,
    "max_time": SolverOptions.max_time,
    "method": SolverOptions.method,
    **{name: getattr(SolverOptions, name) for name in option_names("sweep")},  # the methods' own options
    "checkpoints": None,
    "checkpoint_every": DEFAULT_EVERY,
}


def sweep(*, out=None, workers: int | None = 1, progress: bool = False, **grid: Any):
    """A grid of falls (every N x alpha x floor x start family, ``runs`` starts each) on a
    local Dask cluster, as ``ballchain sweep`` runs it; returns the table as a pandas
    DataFrame (one row per run; columns as ``ballchain sweep`` writes them).  ``grid``:
    the keywords below (``segments``, ``alpha``, ``floor``, ``ic`` and each contact law's
    parameter, ``friction=[0, 0.3, inf]``: one value or a list, an axis of the grid).
    ``out``: the Parquet file to keep (and resume); default a temporary one.  ``workers``
    > 1 starts worker processes: in a script, call it under ``if __name__ == "__main__":``."""
    import pandas as pd

    from .model import parse_angle
    from .sweeps import SweepSpec
    from .sweeps.execute import run_sweep
    from .sweeps.table import read_table

    unknown = sorted(set(grid) - set(SWEEP_KEYWORDS))
    if unknown:
        raise TypeError(f"sweep() got unknown keyword(s) {', '.join(unknown)}; known: {', '.join(SWEEP_KEYWORDS)}")
    g = {**SWEEP_KEYWORDS, **grid}

    def listed(v):
        return list(v) if isinstance(v, (list, tuple)) else [v]

    spec = SweepSpec(
        segments=tuple(int(n) for n in listed(g["segments"])),
        alphas=tuple(parse_angle(a) for a in listed(g["alpha"])),
        floors=tuple(listed(g["floor"])),
        ics=tuple(listed(g["ic"])),
        **{k: v for k, v in g.items() if k not in ("segments", "alpha", "floor", "ic")},
    )
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(out) if out is not None else Path(tmp) / "sweep.parquet"
        run_sweep(spec, path, workers=workers, progress=progress)
        return pd.DataFrame(read_table(path))


sweep.__doc__ += _keywords_doc("sweep", SWEEP_KEYWORDS, SWEEP_KEYWORDS)


def stats(table) -> dict:
    """The statistics of a sweep table (a path, or the DataFrame ``sweep`` returned), as
    ``ballchain stats --json`` gives them."""
    from .sweeps.stats import table_stats

    if isinstance(table, (str, Path)):
        return table_stats(table)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "table.parquet"
        table.to_parquet(path)
        return table_stats(path)
