"""``ballchain warmup``: compile the methods' kernels ahead of the first run."""

from __future__ import annotations

import json
import time

import typer

from ..methods import METHOD_NAMES
from .app import EXIT_USAGE, _error, app


def warm(method: str) -> dict:
    """Load the kernels of ``method`` in this process (``engine.load_kernels``: compiled
    the first time, from numba's cache after); what it cost, wall and CPU seconds."""
    t0, c0 = time.perf_counter(), time.process_time()
    from ..engine import load_kernels  # (the engine imports numba: in the worker, not before)

    compiled = load_kernels(method)
    return {
        "method": method,
        "compiled": bool(compiled),
        "wall_seconds": time.perf_counter() - t0,
        "cpu_seconds": time.process_time() - c0,
    }


@app.command()
def warmup(
    method: str = typer.Option(
        "all", "--method", help=f"The method whose kernels to compile: {', '.join(METHOD_NAMES)} or all."
    ),
    workers: int | None = typer.Option(
        None, "--workers", help="Processes compiling at once, one method each (default: one per method)."
    ),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object per method as a list on stdout."),
) -> None:
    """Compile the kernels of a method, or of every method, ahead of the first run (each in
    its own process, in parallel; numba caches them on disk), so that no run waits for it."""
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    methods = list(METHOD_NAMES) if method == "all" else [method]
    if any(m not in METHOD_NAMES for m in methods):
        _error(f"--method must be one of {', '.join(METHOD_NAMES)} or all, got {method!r}")
        raise typer.Exit(EXIT_USAGE)
    if workers is not None and workers < 1:
        _error(f"--workers must be >= 1, got {workers}")
        raise typer.Exit(EXIT_USAGE)
    n = min(len(methods), workers or len(methods))
    if not json_out:
        typer.echo(f"compiling the kernels of {', '.join(methods)} ({n} at a time; minutes the first time)", err=True)
    with ProcessPoolExecutor(max_workers=n, mp_context=get_context("spawn")) as pool:
        done = list(pool.map(warm, methods))
    if json_out:
        typer.echo(json.dumps(done))
        return
    for d in done:
        what = "compiled" if d["compiled"] else "already compiled, loaded"
        typer.echo(f"{d['method']:>8}: {what} in {d['wall_seconds']:.1f} s ({d['cpu_seconds']:.1f} s of CPU)")
