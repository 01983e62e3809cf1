"""``ballchain simulate``."""

from __future__ import annotations

from typing import Any

import typer

from ..inputs import _CHAIN, _SOLVER, _START, START_OPTIONS, build_inputs, check_start
from ..methods.checkpoint import DEFAULT_EVERY
from ..model import ParameterError
from ..records.files import ResultFileError, check_writable, save_result
from .app import EXIT_INTERRUPTED, EXIT_RUN_ERROR, EXIT_TERMINATED, EXIT_USAGE, _error, _print_json, app
from .params import _with_method_options
from .running import _run_engine, _values_from_file
from .summary import human_summary, run_summary


@app.command()
@_with_method_options("simulate", "anchor_cone")
def simulate(
    ctx: typer.Context,
    segments: int | None = typer.Option(
        None,
        "--segments",
        "-N",
        help=f"Number of segments N (>= 1; default {_CHAIN.segments}, or the rows of --initial).",
    ),
    alpha: str = typer.Option(
        repr(_CHAIN.alpha), "--alpha", help="Critical bend angle in (0, pi]: 45deg, pi/4 or radians (default pi/4)."
    ),
    floor: str = typer.Option(
        _CHAIN.floor,
        "--floor",
        help="Floor model: all (every point is stopped by the floor) or pivot (the paper read literally).",
    ),
    anchor_cone: bool = typer.Option(
        _CHAIN.anchor_cone,
        "--anchor-cone",
        help="Keep the hinge limit between a landed segment and the airborne one hinged to it (beware: a landed segment then acts as a cantilever that can hold a locked chain up).",
    ),
    ic: str = typer.Option(_START.kind, "--ic", help="Initial condition family: helix, planar or random."),
    eps: float = typer.Option(_START.eps, "--eps", help="Amplitude of the initial tilt (>= 0)."),
    turns: float = typer.Option(_START.turns, "--turns", help="Turns q of the helix / wavenumber of the planar bend."),
    phase: str = typer.Option(
        repr(_START.phase), "--phase", help="Phase phi0 (radians, or 45deg, pi/4): rotates the chain about z."
    ),
    seed: int = typer.Option(_START.seed, "--seed", help="Seed of the random initial condition (>= 0)."),
    spawn_key: str = typer.Option(
        "", "--spawn-key", help="Spawn key of the random start's SeedSequence (run k of a sweep: k)."
    ),
    until: float | None = typer.Option(
        None,
        "--until",
        help="Stop at this time, in units of t_ff, landed or not (status until; replaces the --max-time cap).",
    ),
    max_time: float = typer.Option(
        _SOLVER.max_time,
        "--max-time",
        help="The time cap, in units of t_ff: a chain not landed by then stops with status max_time, a warning "
        "on stderr and exit code 0 (its numbers are those of an unfinished fall: t_fall may be NaN).",
    ),
    max_events: int = typer.Option(
        _SOLVER.max_events,
        "--max-events",
        help="Stop with status error after this many event instants (a guard against event accumulation).",
    ),
    frames_per_tff: float = typer.Option(
        _SOLVER.frames_per_tff,
        "--frames-per-tff",
        help="Output frames per t_ff (what is written: frames sample the fall and do not change it; the event-driven "
        "method's from its steps' dense output, the time-stepper's from the step each falls in).",
    ),
    method: str = typer.Option(
        _SOLVER.method,
        "--method",
        help="Integration method: event (event-driven, every event located exactly), timestep (Moreau-Jean "
        "time-stepping, first order in --dt; for large N; experimental) or rattle (nonsmooth RATTLE, second order where the "
        "motion is smooth; experimental).",
    ),
    output: str | None = typer.Option(None, "--output", "-o", help="Save the result to this HDF5 file."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing output file."),
    checkpoint: str | None = typer.Option(
        None,
        "--checkpoint",
        help="Save the run's state to this file (.npz) every --checkpoint-every seconds and when interrupted; "
        "if it holds this run's state (same chain, start, options and engine), resume from it. Removed once "
        "the run has ended and its result is saved.",
    ),
    checkpoint_every: float = typer.Option(
        DEFAULT_EVERY, "--checkpoint-every", help="Seconds of wall time between checkpoints (with --checkpoint)."
    ),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object (the run's summary) on stdout."),
    length: float | None = typer.Option(
        None, "--length", help="Total length of the chain in m (SI units; needs --mass)."
    ),
    mass: float | None = typer.Option(None, "--mass", help="Total mass of the chain in kg (SI units; needs --length)."),
    gravity: float | None = typer.Option(None, "--gravity", help="Gravity in m/s^2 (SI units; default 9.81)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
    from_: str | None = typer.Option(
        None,
        "--from",
        help="Rerun a result file's own parameters (chain, start, options); options given beside it override them.",
    ),
    initial: str | None = typer.Option(
        None,
        "--initial",
        help="Initial state from a file instead of --ic: a text or .npy array, N x 3 (segment axes from the top, pointing up the chain) or N x 6 (axes, then angular velocities in sqrt(g/b)).",
    ),
    **method_options: Any,
) -> None:
    """Simulate one fall (defaults: the paper's case N = 128, alpha = pi/4, helix)."""
    state = None
    try:
        values = dict(
            segments=segments,
            alpha=alpha,
            floor=floor,
            anchor_cone=anchor_cone,
            ic=ic,
            eps=eps,
            turns=turns,
            phase=phase,
            seed=seed,
            spawn_key=spawn_key,
            until=until,
            frames_per_tff=frames_per_tff,
            max_time=max_time,
            max_events=max_events,
            method=method,
            length=length,
            mass=mass,
            gravity=gravity,
            **method_options,  # the methods' own (methods.all_options)
        )
        if from_ is not None:
            values, state = _values_from_file(from_, values, ctx, initial is None)
            segments = values["segments"]
        if initial is not None:
            from ..initial import load_initial_state

            e0, w0 = load_initial_state(initial)
            if segments is not None and segments != e0.shape[0]:
                raise ParameterError(f"--segments {segments} disagrees with the {e0.shape[0]} rows of {initial!r}")
            segments = e0.shape[0]
            state = (e0, w0)
        if state is not None:
            check_start(
                [k for k in START_OPTIONS if getattr(ctx.get_parameter_source(k), "name", "") == "COMMANDLINE"],
                f"--initial {initial!r}" if initial is not None else f"--from {from_!r}",
            )
        values["segments"] = _CHAIN.segments if segments is None else segments
        params, init, options = build_inputs(values)
        if output is not None:
            check_writable(output, force, "--output")
        ck = None
        if checkpoint is not None:
            from ..methods.checkpoint import Checkpoint

            ck = Checkpoint(checkpoint, every=checkpoint_every)
    except (ParameterError, ResultFileError, FileExistsError) as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)

    try:
        result = _run_engine(
            params, None if state else init, options, show_progress=not quiet, state=state, checkpoint=ck
        )
        if initial is not None:
            result.extra["initial"] = str(initial)
        if from_ is not None:
            result.extra["from"] = str(from_)
    except KeyboardInterrupt as exc:  # before the run started, or a second signal: stop at once
        _error(f"interrupted ({getattr(exc, 'reason', 'SIGINT')}) before the run could save its work (nothing saved)")
        raise typer.Exit(EXIT_TERMINATED if "SIGTERM" in str(exc) else EXIT_INTERRUPTED)
    except ParameterError as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)

    saved = None
    save_failed = False
    if output is not None:
        try:
            saved = str(save_result(result, output, force=force, what="--output"))
        except KeyboardInterrupt:
            _error(f"interrupted while saving (no file written to {output!r})")
            raise typer.Exit(EXIT_INTERRUPTED)
        except (ResultFileError, FileExistsError, OSError) as e:
            _error(f"cannot save the result: {e}")
            save_failed = True

    summary = run_summary(result)
    if json_out:
        _print_json(summary)
    else:
        typer.echo(human_summary(summary, saved, header="ballchain simulate"))

    if result.status == "error":
        _error(
            f"the run failed: {result.message or 'unknown error'}"
            + (f" (partial result saved to {saved})" if saved else "")
        )
        raise typer.Exit(EXIT_RUN_ERROR)
    if result.status == "interrupted":
        _error(
            f"interrupted by {result.message}"
            + (f" (partial result saved to {saved})" if saved else " (no --output: not saved)")
            + (
                f"; the same command resumes from the checkpoint{' (with --force, to overwrite the partial result)' if saved and not force else ''}"
                if ck is not None
                else ""
            )
        )
        raise typer.Exit(EXIT_TERMINATED if "SIGTERM" in result.message else EXIT_INTERRUPTED)
    if save_failed:
        raise typer.Exit(EXIT_RUN_ERROR)
    if ck is not None:
        ck.discard()  # the run has ended and its result is saved (or was not asked for)
    if result.status == "max_time":
        typer.echo(f"warning: stopped at the time cap ({options.max_time} t_ff) before every segment landed", err=True)
    from ..records.audit import near_bounds

    for sentence in near_bounds(result):
        typer.echo(f"warning: {sentence}", err=True)
