"""The commands on result files: ``info``, ``plot``, ``paper``, ``animate``, ``view``,
``export``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import typer

from ..inputs import _START, _parse_angle
from ..model import InitialCondition, ParameterError
from ..records.files import ResultFileError, check_output_dir, check_writable, file_info, load_result
from . import running
from .app import EXIT_INTERRUPTED, EXIT_USAGE, _error, _print_json, app
from .summary import human_summary, run_summary


@app.command()
def info(
    file: str = typer.Argument(..., help="A result file written by ballchain simulate --output."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object (the run's summary)."),
) -> None:
    """Print the summary of a result file."""
    try:
        meta = file_info(file)
        result = load_result(file)
    except ResultFileError as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    summary = run_summary(result)
    if json_out:
        _print_json(summary)
        return
    typer.echo(human_summary(summary, header=file))
    typer.echo(
        f"  file               {meta.get('format')} v{meta.get('format_version')}, "
        f"written by ballchain {meta.get('package_version')} at {meta.get('created')}"
    )


@app.command()
def plot(
    file: str = typer.Argument(..., help="A result file written by ballchain simulate --output."),
    out: str = typer.Option("figures", "--out", help="Directory for the figures (created if missing)."),
    formats: str = typer.Option("png,pdf", "--formats", help="Comma-separated file formats, e.g. png,pdf,svg."),
) -> None:
    """Figures of one run: z_top against free fall, energy budget, floor force and the
    pile's pull, top view of the pile, lock map, the tension along the chain (with the top end's
    acceleration), gamma measured from the floor (one file per figure and format)."""
    fmts = tuple(f.strip().lower() for f in formats.split(",") if f.strip())
    bad = [f for f in fmts if f not in ("png", "pdf", "svg")]
    if not fmts or bad:
        _error(f"--formats: expected png, pdf or svg, got {formats!r}")
        raise typer.Exit(EXIT_USAGE)
    try:
        result = load_result(file)
    except ResultFileError as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    from ..plots import plot_run  # lazy: matplotlib is heavy to import

    try:
        paths = plot_run(result, out, fmts)
    except OSError as e:
        _error(f"--out: cannot write figures to {out!r} ({e.strerror or e})")
        raise typer.Exit(EXIT_USAGE)
    for p in paths:
        typer.echo(str(p))


@app.command()
def paper(
    out: str = typer.Option("paper-figures", "--out", help="Directory for the figures and the run cache."),
    segments: int = typer.Option(128, "--segments", "-N", help="N of the main chain (Figs. 2-4, 6)."),
    alpha: str = typer.Option("pi/4", "--alpha", help="alpha of the main chain."),
    floor: str = typer.Option("all", "--floor", help="Floor model: all or pivot."),
    ic: str = typer.Option(_START.kind, "--ic", help="Initial condition family: helix, planar or random."),
    eps: float = typer.Option(_START.eps, "--eps", help="Largest initial tilt."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random initial condition."),
    alpha_segments: int = typer.Option(256, "--alpha-segments", help="N of the alpha series (Fig. 5)."),
    alphas: str = typer.Option("30deg,45deg,60deg,90deg,180deg", "--alphas", help="alpha values of Fig. 5."),
    quick: bool = typer.Option(
        False, "--quick", help="Small chains (N = 12 and 16, three alphas): seconds, for tests."
    ),
    formats: str = typer.Option("png,pdf", "--formats", help="Comma-separated file formats."),
) -> None:
    """The paper's figures 2-7 from one command (runs are cached under OUT/cache)."""
    from ..paper import QUICK, PaperSetup, paper_figures

    fmts = tuple(f.strip().lower() for f in formats.split(",") if f.strip())
    if not fmts or any(f not in ("png", "pdf", "svg") for f in fmts):
        _error(f"--formats: expected png, pdf or svg, got {formats!r}")
        raise typer.Exit(EXIT_USAGE)
    try:
        kw = dict(
            segments=segments,
            alpha=_parse_angle("--alpha", alpha),
            floor=floor,
            ic=InitialCondition(kind=ic, eps=eps, seed=seed),
            alpha_segments=alpha_segments,
            alphas=tuple(_parse_angle("--alphas", a) for a in alphas.split(",") if a.strip()),
        )
        if quick:
            kw.update(QUICK)
        setup = PaperSetup(**kw)
    except (ParameterError, ValueError) as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    try:
        check_output_dir(out, "--out")
    except ResultFileError as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    for p in paper_figures(setup, out, fmts, note=lambda msg: typer.echo(msg, err=True)):
        typer.echo(str(p))


@app.command()
def animate(
    file: str = typer.Argument(..., help="A result file written by ballchain simulate --output."),
    out: str = typer.Option("fall.mp4", "--out", help="The animation file: .mp4 (H.264) or .gif, by its suffix."),
    fps: float = typer.Option(25.0, "--fps", help="Frames per second of the animation."),
    every: int | None = typer.Option(None, "--every", help="Draw every K-th frame of the run (default: every frame)."),
    frames: int | None = typer.Option(None, "--frames", help="Draw exactly N frames spread evenly over the run."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing output file."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
) -> None:
    """Animation of one run: 3D view with the floor, side view (x-z) and top view (x-y);
    the chain, the pile (landed segments) and the locked hinges, time in units of t_ff."""
    from ..plots.animate import (  # lazy: matplotlib
        SUFFIXES,
        AnimationError,
        check_options,
        frame_indices,
        write_animation,
    )

    try:
        if Path(out).suffix.lower() not in SUFFIXES:
            raise AnimationError(f"--out: expected a .mp4 or .gif file name, got {out!r}")
        check_options(fps, every, frames)
        try:
            check_writable(out, force, "--out")
        except (FileExistsError, ResultFileError) as e:
            raise AnimationError(str(e)) from None
        result = load_result(file)
        n = int(result.frame_t.shape[0])
        total = frame_indices(n, every=every, frames=frames).size
    except (AnimationError, ResultFileError) as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)

    def run(progress=None):
        return write_animation(result, out, fps=fps, every=every, frames=frames, force=True, progress=progress)

    try:
        console = None if quiet else running._progress_console()
        if console is None or not console.is_terminal:
            path = run()
        else:
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            with Progress(
                TextColumn("animating"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeElapsedColumn(),
                console=console,
                transient=True,
            ) as bar:
                task = bar.add_task("animating", total=total)
                path = run(lambda done, _total: bar.update(task, completed=done))
    except KeyboardInterrupt:
        _error(f"interrupted (nothing written to {out!r})")
        raise typer.Exit(EXIT_INTERRUPTED)
    except AnimationError as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    except OSError as e:
        _error(f"--out: cannot write {out!r} ({e.strerror or e})")
        raise typer.Exit(EXIT_USAGE)
    typer.echo(str(path))


@app.command()
def view(
    file: str = typer.Argument(..., help="A result file written by ballchain simulate --output."),
    out: str = typer.Option("fall.html", "--out", help="The HTML file (self-contained: opens offline in any browser)."),
    every: int | None = typer.Option(None, "--every", help="Every K-th frame of the run."),
    frames: int | None = typer.Option(
        None,
        "--frames",
        help="Exactly N frames spread evenly (default: all, at most 1,000,000 chain points in a file).",
    ),
    stretch: float = typer.Option(
        1.0,
        "--stretch",
        help="Draw the horizontal lengths this many times the vertical ones (default 1: true proportions; "
        "the title says when it is not 1).",
    ),
    colour: str = typer.Option(
        "state",
        "--colour",
        help="What colours the chain: state (free, locked and landed segments) or tension (every point by the "
        "tension there, in m g: red pulls, blue pushes).",
    ),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing output file."),
) -> None:
    """An orbitable 3D view of a run with a time slider, in one HTML file (plotly)."""
    from ..plots.animate import AnimationError, frame_indices

    try:
        if Path(out).suffix.lower() not in (".html", ".htm"):
            raise ParameterError(f"--out: expected a .html file name, got {out!r}")
        if not (math.isfinite(stretch) and stretch > 0):
            raise ParameterError(f"--stretch: expected a number > 0, got {stretch!r}")
        if colour not in ("state", "tension"):
            raise ParameterError(f"--colour: expected state or tension, got {colour!r}")
        check_writable(out, force, "--out")
        result = load_result(file)
        frame_indices(len(result.frame_t), every=every, frames=frames)  # checks the options against the run
        if colour == "tension" and not np.isfinite(np.asarray(result.frame_tension, dtype=float)).all():
            raise ParameterError(f"--colour tension: {file} has no tension (written before result format 6)")
    except (ParameterError, ResultFileError, FileExistsError, AnimationError) as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    from ..plots.view import write_view  # lazy: plotly

    typer.echo(str(write_view(result, out, every=every, frames=frames, stretch=stretch, colour=colour)))


@app.command()
def export(
    file: str = typer.Argument(..., help="A result file written by ballchain simulate --output."),
    fmt: str = typer.Option(
        ..., "--format", help="xyz (extended XYZ: OVITO, ASE) or vtk (VTK polylines and a .pvd collection: ParaView)."
    ),
    out: str = typer.Option(
        ..., "--out", help="The output file: .xyz (or .extxyz), or .pvd for vtk (its frames beside it)."
    ),
    every: int | None = typer.Option(None, "--every", help="Every K-th frame of the run (default: every frame)."),
    frames: int | None = typer.Option(None, "--frames", help="Exactly N frames spread evenly over the run."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing output file."),
) -> None:
    """Write a run's frames for OVITO or ParaView (positions in the run's length unit)."""
    from ..plots.animate import AnimationError, frame_indices
    from ..records.export import FORMATS, export_frames, vtk_frame_names

    try:
        if fmt not in FORMATS:
            raise ParameterError(f"--format: expected one of {', '.join(FORMATS)}, got {fmt!r}")
        want = (".xyz", ".extxyz") if fmt == "xyz" else (".pvd",)
        if Path(out).suffix.lower() not in want:
            raise ParameterError(f"--out: expected a {' or '.join(want)} file name for --format {fmt}, got {out!r}")
        check_writable(out, force, "--out")
        result = load_result(file)
        idx = frame_indices(len(result.frame_t), every=every, frames=frames)
        if fmt == "vtk":  # the frame files beside the collection: none replaced without --force
            for name in vtk_frame_names(out, idx.size):
                check_writable(Path(out).parent / name, force, "--out")
    except (ParameterError, ResultFileError, FileExistsError, AnimationError) as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    path = export_frames(result, fmt, out, idx, force=force)
    typer.echo(str(path))
    if fmt == "vtk":
        names = vtk_frame_names(path, idx.size)
        typer.echo(
            f"wrote {idx.size + 1} files: the collection {path.name} and its {idx.size} frames "
            f"{names[0]} ... {names[-1]} beside it, in {str(path.parent)!r}",
            err=True,
        )
    else:
        typer.echo(f"wrote 1 file: {idx.size} frames in {path.name}", err=True)
