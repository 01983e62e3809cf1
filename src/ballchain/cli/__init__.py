"""Command line interface: ``ballchain simulate``, ``info``, ``plot``, ``paper``, ``animate``,
``sweep``, ``stats``, ``theory`` and ``warmup``.

Errors in the input (every invalid parameter, an unwritable or existing output file,
a damaged result file) are reported as one line ``error: <message>`` on stderr with
exit code 2 and no traceback.  A run that stops with ``status == "error"`` exits 1
(after saving what was computed); Ctrl-C (SIGTERM) during the run saves what was
computed with status ``interrupted`` and exits 130 (143); an interrupt never leaves a
half-written file.  Stdout carries only the summary (one JSON object with ``--json``); the progress
bar goes to stderr.

The package, a module per part: ``app`` (the application, its one-line errors and exit
codes), ``params`` (the registries' options as typer options), ``running`` (the engine
with its progress and warnings), ``summary`` (what is printed), and the commands:
``simulate``, ``files`` (``info``, ``plot``, ``paper``, ``animate``, ``view``,
``export``), ``sweeps`` (``sweep``, ``stats``), ``theory``, ``warmup`` (the kernels
compiled ahead).
"""

from __future__ import annotations

import importlib
from typing import Any

import typer

from ..inputs import build_inputs  # noqa: F401  (part of the CLI's interface)
from .app import EXIT_INTERRUPTED, EXIT_RUN_ERROR, EXIT_TERMINATED, EXIT_USAGE, app  # noqa: F401
from .running import (  # noqa: F401
    COMPILE_NOTICE,
    LANDING_WARNING,
    SHORT_STEP_WARNING,
    TIMESTEP_WARNING,
    _compile_with_notice,
    _run_engine,
)
from .summary import human_summary, run_summary, stats_text  # noqa: F401

for _part in (
    "simulate",
    "files",
    "sweeps",
    "theory",
    "warmup",
):  # each registers its commands (--help lists them in this order)
    importlib.import_module(f"{__name__}.{_part}")


def command_options(*path: str) -> dict[str, tuple[str, Any]]:
    """The options of ``ballchain PATH...`` (e.g. ``"simulate"``, ``"theory", "gamma"``) by
    their Python name: (help, default), read from the app itself (``ballchain.api``'s
    docstrings list its keywords from here, so they say what ``--help`` says)."""
    cmd = typer.main.get_command(app)
    for name in path:
        cmd = cmd.commands[name]
    return {
        p.name: (p.help or "", p.default if getattr(p, "show_default", True) is not False else None)
        for p in cmd.params
        if isinstance(p, typer.core.TyperOption)
    }


def main() -> None:  # pragma: no cover - ``python -m ballchain.cli``
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
