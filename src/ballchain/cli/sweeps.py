"""``ballchain sweep`` and ``ballchain stats``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from ..inputs import _CHAIN, _SOLVER, _START
from ..methods import METHODS
from ..methods.checkpoint import DEFAULT_EVERY
from ..model import ParameterError
from ..records.files import ResultFileError, check_output_dir, check_writable
from .app import EXIT_INTERRUPTED, EXIT_USAGE, _error, _print_json, app
from .params import _with_method_options
from .running import cost_warning
from .summary import stats_text


@app.command()
@_with_method_options("sweep", "floor")
def sweep(
    segments: str = typer.Option("64", "--segments", "-N", help="N values: a list (64,128) or range start:stop:step."),
    alpha: str = typer.Option(
        repr(_CHAIN.alpha),
        "--alpha",
        help="alpha values: a list (30deg,pi/4) or range (10deg:120deg:10deg), in (0, pi].",
    ),
    floor: str = typer.Option(_CHAIN.floor, "--floor", help="Floor models: all, pivot or all,pivot."),
    ic: str = typer.Option(
        "random", "--ic", help="Initial-condition families (random; helix and planar with --runs 1)."
    ),
    runs: int = typer.Option(1, "--runs", help="Initial conditions per point (independent streams of --seed)."),
    seed: int = typer.Option(
        0, "--seed", help="Entropy of numpy.random.SeedSequence; run k uses its k-th spawned child."
    ),
    eps: float = typer.Option(_START.eps, "--eps", help="Largest initial tilt."),
    until: float | None = typer.Option(
        None, "--until", help="Stop each run at this time in t_ff (default: until landed)."
    ),
    frames_per_tff: float = typer.Option(
        _SOLVER.frames_per_tff,
        "--frames-per-tff",
        help="Output frames per t_ff (as simulate: what is written; the falls do not depend on it).",
    ),
    max_time: float = typer.Option(
        _SOLVER.max_time, "--max-time", help="The time cap of each run, in t_ff (as simulate: status max_time)."
    ),
    method: str = typer.Option(
        _SOLVER.method,
        "--method",
        help=f"Integration method of every run: {', '.join(list(METHODS)[:-1])} or {list(METHODS)[-1]} (as simulate).",
    ),
    out: str = typer.Option(
        "sweep.parquet", "--out", help="The Parquet table (one row per run; an existing table is resumed)."
    ),
    workers: int | None = typer.Option(None, "--workers", help="Local worker processes (default: all cores)."),
    scheduler: str | None = typer.Option(
        None, "--scheduler", help="Address of an existing Dask scheduler (tcp://host:8786) instead of a local cluster."
    ),
    save_runs: str | None = typer.Option(
        None, "--save-runs", help="Also keep each run's result file (HDF5) in this directory."
    ),
    checkpoints: str | None = typer.Option(
        None,
        "--checkpoints",
        help="Each run saves its state in this directory every --checkpoint-every seconds; a sweep run again "
        "resumes its unfinished runs from there (long falls survive a kill).",
    ),
    checkpoint_every: float = typer.Option(
        DEFAULT_EVERY,
        "--checkpoint-every",
        help="Seconds of wall time between a run's checkpoints (with --checkpoints).",
    ),
    retry_errors: bool = typer.Option(False, "--retry-errors", help="Run again the runs whose row says error."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object (what the sweep did) on stdout."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    **method_options: Any,
) -> None:
    """Run a grid of falls on dask.distributed into one Parquet table (resumable)."""
    from ..model import FLOOR_MODELS, IC_KINDS
    from ..sweeps import SweepSpec, parse_alphas, parse_choices, parse_segments

    try:
        if workers is not None and workers < 1:
            raise ParameterError(f"workers must be >= 1, got {workers}")
        spec = SweepSpec(
            segments=tuple(parse_segments(segments)),
            alphas=tuple(parse_alphas(alpha)),
            floors=tuple(parse_choices(floor, FLOOR_MODELS, "floor")),
            ics=tuple(parse_choices(ic, IC_KINDS, "ic")),
            runs=runs,
            seed=seed,
            eps=eps,
            until=until,
            frames_per_tff=frames_per_tff,
            max_time=max_time,
            method=method,
            save_runs=save_runs,
            checkpoints=checkpoints,
            checkpoint_every=checkpoint_every,
            **method_options,  # the methods' own (methods.all_options)
        )
        from ..sweeps.execute import check_scheduler, run_sweep

        spec.tasks()  # every run validated before anything starts
        cost = cost_warning(max(spec.segments), spec.options, "each run of ")  # (the longest: the largest N)
        if cost is not None:
            typer.echo(cost, err=True)
        if Path(out).suffix.lower() != ".parquet":
            raise ParameterError(f"--out: expected a .parquet file name, got {out!r}")
        check_writable(out, force=True, what="--out")  # (an existing table is resumed, then rewritten)
        if save_runs is not None:
            check_output_dir(save_runs, "--save-runs")
        if checkpoints is not None:
            check_output_dir(checkpoints, "--checkpoints")
        if scheduler is not None:
            check_scheduler(scheduler)
        report = run_sweep(
            spec, out, workers=workers, scheduler=scheduler, retry_errors=retry_errors, progress=not quiet
        )
    except (ParameterError, ResultFileError) as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    if json_out:
        _print_json(report.to_dict())
    else:
        st = ", ".join(f"{v} {k}" for k, v in sorted(report.statuses.items()))
        typer.echo(
            f"{report.table}: {report.total} runs in the grid ({st}); ran {report.ran} now "
            f"({report.failed} failed), {report.skipped} were already there; "
            f"{report.wall_seconds:.1f} s on {report.workers} workers"
        )
    if report.interrupted:
        raise typer.Exit(EXIT_INTERRUPTED)


@app.command()
def stats(
    table: str = typer.Argument(..., help="A table written by ballchain sweep."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object on stdout."),
    plot: str | None = typer.Option(
        None, "--plot", help="Write t_fall/t_ff against alpha with 95% bands (PNG, PDF or SVG)."
    ),
    plot_n: str | None = typer.Option(
        None, "--plot-n", help="Write t_fall/t_ff against N with 95% bands, per alpha and floor."
    ),
) -> None:
    """Means, medians and 95% intervals per point of a sweep; the optimal alpha per N."""
    from ..sweeps.stats import table_stats

    if not Path(table).is_file():
        _error(f"table: no such file {table!r}")
        raise typer.Exit(EXIT_USAGE)
    for name, value in (("--plot", plot), ("--plot-n", plot_n)):
        if value is not None and Path(value).suffix.lower() not in (".png", ".pdf", ".svg"):
            _error(f"{name}: expected a .png, .pdf or .svg file name, got {value!r}")
            raise typer.Exit(EXIT_USAGE)
        if value is not None:
            try:  # a figure is replaced if it exists (a regular file only)
                check_writable(value, force=True, what=name)
            except ResultFileError as e:
                _error(str(e))
                raise typer.Exit(EXIT_USAGE)
    try:
        res = table_stats(table)
    except ParameterError as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    if len(res.get("engines", [])) > 1:
        typer.echo(
            f"warning: the table mixes {len(res['engines'])} engines ({', '.join(res['engines'])}): its rows are "
            f"not all reruns of one engine, and a chaotic fall differs between engines",
            err=True,
        )
    if plot is not None:
        from ..plots.sweep import write_alpha_figure

        write_alpha_figure(res["points"], plot, res["optimal_alpha"])
        res["plot"] = plot
    if plot_n is not None:
        from ..plots.sweep import write_segments_figure

        write_segments_figure(res["points"], plot_n)
        res["plot_n"] = plot_n
    if json_out:
        _print_json(res)
        return
    typer.echo(stats_text(res))
