"""Command line interface: ``ballchain simulate``, ``info``, ``plot``, ``paper``, ``animate``,
``sweep``, ``stats`` and ``theory``.

Errors in the input (every invalid parameter, an unwritable or existing output file,
a damaged result file) are reported as one line ``error: <message>`` on stderr with
exit code 2 and no traceback.  A run that stops with ``status == "error"`` exits 1
(after saving what was computed); Ctrl-C (SIGTERM) during the run saves what was
computed with status ``interrupted`` and exits 130 (143); an interrupt never leaves a
half-written file.  Stdout carries only the summary (one JSON object with ``--json``); the progress
bar goes to stderr.
"""

from __future__ import annotations

import functools
import inspect
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import typer
from typer.core import TyperGroup

from . import __version__
from .contacts.registry import all_params as contact_params
from .inputs import _CHAIN, _SOLVER, _START, _parse_angle, build_inputs  # noqa: F401  (build_inputs: part of the CLI)
from .methods import METHODS, all_options, option_help, option_names
from .methods.checkpoint import DEFAULT_EVERY
from .methods.timestep import LONG_STEP, LONG_STEP_FROM, SHORT_STEP
from .model import InitialCondition, ParameterError
from .records.files import ResultFileError, check_output_dir, check_writable, file_info, load_result, save_result

try:  # typer >= 0.16 vendors click
    from typer._click.exceptions import ClickException, NoArgsIsHelpError
except ImportError:  # pragma: no cover - older typer on top of click
    from click.exceptions import ClickException, NoArgsIsHelpError

EXIT_RUN_ERROR = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143  # SIGTERM


class _OneLineErrors(TyperGroup):
    """Report usage errors (bad option values, unknown options) as one line."""

    def main(
        self, args=None, prog_name=None, complete_var=None, standalone_mode=True, windows_expand_args=True, **extra
    ):
        if not standalone_mode:
            return super().main(
                args=args,
                prog_name=prog_name,
                complete_var=complete_var,
                standalone_mode=False,
                windows_expand_args=windows_expand_args,
                **extra,
            )
        try:
            rv = super().main(
                args=args,
                prog_name=prog_name,
                complete_var=complete_var,
                standalone_mode=False,
                windows_expand_args=windows_expand_args,
                **extra,
            )
        except NoArgsIsHelpError as e:
            e.show()
            sys.exit(e.exit_code)
        except ClickException as e:
            _error(e.format_message())
            sys.exit(e.exit_code)
        except typer.Abort:
            _error("aborted")
            sys.exit(EXIT_RUN_ERROR)
        sys.exit(rv if isinstance(rv, int) else 0)


app = typer.Typer(
    cls=_OneLineErrors,
    help="Event-driven 3D simulation of a falling ball chain (Itano & Sugihara-Seki model).",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_show_locals=False,
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"ballchain {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: bool = typer.Option(
        False, "--version", callback=_version, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """Event-driven 3D simulation of a falling ball chain (Itano & Sugihara-Seki model)."""


# --------------------------------------------------------------------------- helpers
def _error(message: str) -> None:
    text = " ".join(str(message).split())  # one line, always
    typer.echo(f"error: {text}", err=True)


def run_summary(result) -> dict:
    """``Result.summary()`` and the measurements of ``analysis`` on it: ``gamma_measured``
    (Hamm-Geminard gamma from the floor's momentum record, analysis.floor_gamma) and
    ``gamma_inferred`` (the gamma whose fall time is t_fall/t_ff); and
    ``wall_includes_compile`` (the run compiled the kernels first: its wall time has it;
    false for runs of the command line, which loads the kernels before the run), and
    from the command line ``setup_seconds`` (loading, or the first time compiling, the
    kernels before the run) and ``setup_compiled``."""
    from .records.measures import derived_measures

    s = result.summary()
    for key, value in derived_measures(result).items():
        s[key] = value if math.isfinite(value) else None
    extra = getattr(result, "extra", {})
    s["wall_includes_compile"] = bool(extra.get("compiled_kernels", False))
    if "setup_seconds" in extra:
        s["setup_seconds"] = float(extra["setup_seconds"])
        s["setup_compiled"] = bool(extra.get("setup_compiled", False))
    return s


def _fmt(x: Any, spec: str = ".6g") -> str:
    if x is None:
        return "n/a"
    if isinstance(x, float) and not math.isfinite(x):
        return "n/a"
    return format(x, spec)


def _div(a, b):
    if a is None or b is None or b == 0:
        return None
    return a / b


def human_summary(s: dict, output: str | None = None, header: str = "ballchain") -> str:
    """A short human-readable summary of ``Result.summary()``."""
    ic = s.get("ic")
    ic_text = (
        "n/a"
        if not ic
        else (
            f"{ic.get('kind')} (eps {_fmt(ic.get('eps'))}, turns {_fmt(ic.get('turns'))}, "
            f"phase {_fmt(ic.get('phase'))}, seed {ic.get('seed')})"
        )
    )
    alpha = s.get("alpha")
    ev = s.get("events") or {}
    en = s.get("energy") or {}
    init = en.get("initial")
    imb = en.get("imbalance")
    rel = _div(imb, abs(init) if init else None)
    units = s.get("units") or "nondimensional"
    from .records.result import unit_of

    u_t, u_l, u_e, u_i = (unit_of(q, units) for q in ("t", "z0", "frame_kinetic", "floor_impulse"))

    def with_time(ratio_key, time_key):
        text = _fmt(s.get(ratio_key))
        return text + (f"  ({time_key} = {_fmt(s.get(time_key))} {u_t})" if s.get(time_key) is not None else "")

    fi = s.get("floor_impulse_total")
    lines = [
        f"{header}: N = {s.get('segments')}, alpha = {_fmt(alpha)} rad "
        f"({_fmt(None if alpha is None else math.degrees(alpha), '.4g')} deg), floor = {s.get('floor')}"
        + (", anchor cone" if s.get("anchor_cone") else "")
        + f", units = {units}",
        f"  initial condition  {ic_text}",
        f"  method             {_method_text(s)}",
        f"  status             {s.get('status')}" + (f" ({s['message']})" if s.get("message") else ""),
        f"  free-fall time     t_ff = {_fmt(s.get('t_ff'))} {u_t} (top end at z0 = {_fmt(s.get('z0'))} {u_l})",
        f"  t_fall / t_ff      {with_time('ratio', 't_fall')}",
        f"  t_landed / t_ff    {with_time('landed_ratio', 't_landed')}",
        f"  events             lock {ev.get('lock', 0)}, unlock {ev.get('unlock', 0)}, "
        f"landing {ev.get('landing', 0)}"
        + "".join(f", {k} {v}" for k, v in ev.items() if k not in ("lock", "unlock", "landing") and v)
        + (f" ({s['n_instants']} instants)" if s.get("n_instants") is not None else "")
        + f"; first lock at t/t_ff = {_fmt(_div(s.get('first_lock_time'), s.get('t_ff')))}",
        f"  energy imbalance   {_fmt(imb, '.3g')} {u_e} (relative to initial energy: {_fmt(rel, '.3g')})",
    ]
    if fi:
        lines.append(f"  floor impulse      ({', '.join(_fmt(v, '.6g') for v in fi)}) {u_i} (whole, from t = 0)")
    if "gamma_measured" in s:
        lines.append(
            f"  gamma              {_fmt(s.get('gamma_measured'), '.4g')} measured from the floor, "
            f"{_fmt(s.get('gamma_inferred'), '.4g')} from t_fall/t_ff (Hamm-Geminard)"
        )
    if s.get("floor") == "pivot":
        depth = s.get("max_depth")
        lines.append(f"  max depth          {_fmt(depth)} {u_l} below the floor")
        if depth is not None and s.get("z0") and depth > 0.05 * s["z0"]:
            lines.append(
                "  note               floor 'pivot' stops only the segment at the pivot: the rest of the "
                "chain may pass below the floor (use --floor all for a floor that stops every point)"
            )
    lines.append(
        f"  wall time          {_fmt(s.get('wall_seconds'), '.3g')} s "
        f"({s.get('n_steps')} steps, {s.get('n_evals')} evaluations)"
        + ("; includes compiling the kernels (first run only)" if s.get("wall_includes_compile") else "")
    )
    if s.get("setup_seconds") is not None:
        lines.append(
            f"  kernels            {'compiled' if s.get('setup_compiled') else 'loaded'} in "
            f"{_fmt(s['setup_seconds'], '.2g')} s before the run"
            + (" (first run only: cached afterwards)" if s.get("setup_compiled") else "")
        )
    if output:
        lines.append(f"  output             {output}")
    return "\n".join(lines)


def _print_json(obj: dict) -> None:
    typer.echo(json.dumps(obj, allow_nan=False))


def _method_text(s: dict) -> str:
    """The method and its accuracy setting, from a run's summary (each method's package
    says it: ``summary``)."""
    from .methods import METHODS, method_package

    name = s.get("method")
    return method_package(name).summary(s) if name in METHODS else str(name)


def _values_from_file(path: str, values: dict, ctx, use_its_start: bool) -> tuple[dict, tuple | None]:
    """``--from``: the option values of the run saved in ``path`` (``values`` given on the
    command line override them) and, for a run started from an explicit state
    (``--initial``), that state (its first frame)."""
    import numpy as np

    r = load_result(path)
    p, o = r.params, r.options
    base = dict(segments=p.segments, alpha=p.alpha, floor=p.floor, anchor_cone=p.anchor_cone,
                **{name: getattr(p, name) for name in contact_params()},
                until=o.until, frames_per_tff=o.frames_per_tff, max_time=o.max_time, max_events=o.max_events,
                method=o.method, **{name: getattr(o, name) for name in option_names("simulate")})  # fmt: skip
    if p.is_si:
        base.update(length=2.0 * p.half_length * p.segments, mass=p.segment_mass * p.segments, gravity=p.gravity)
    state = None
    if r.ic is not None:
        base.update(ic=r.ic.kind, eps=r.ic.eps, turns=r.ic.turns, phase=r.ic.phase, seed=r.ic.seed,
                    spawn_key=",".join(str(k) for k in r.ic.spawn_key))  # fmt: skip
    elif use_its_start:
        if len(r.frame_t) == 0 or r.frame_t[0] != 0.0:
            raise ParameterError(f"--from {path!r}: its run started from an explicit state and has no frame at t = 0")
        state = (np.array(r.frame_e[0]), np.array(r.frame_omega[0]) * p.time_unit)
    given = {k for k in values if getattr(ctx.get_parameter_source(k), "name", "") == "COMMANDLINE"}
    if state is not None and "segments" in given and values["segments"] != p.segments:
        raise ParameterError(f"--segments {values['segments']} disagrees with the {p.segments} segments of {path!r}")
    base.update({k: values[k] for k in given})
    return base, state


def _progress_console():
    """Where the progress bar goes: stderr, never stdout."""
    from rich.console import Console

    return Console(stderr=True)


COMPILE_NOTICE = "compiling the numba kernels (first run only; about a minute, cached afterwards)"


class _Elapsed:
    """A line that shows the seconds since it was made each time it is drawn."""

    def __init__(self, text: str):
        self.text = text
        self.t0 = time.perf_counter()

    def __rich__(self) -> str:
        return f"{self.text}: {time.perf_counter() - self.t0:.0f} s"


def _compile_with_notice(load_kernels, show_progress: bool) -> None:
    """Compile the kernels (``load_kernels``) saying so on stderr: a line with the elapsed
    seconds, kept up to date while it works on a terminal; elsewhere (a log, a pipe) the
    line when it starts and one when it is done."""
    console = _progress_console()
    t0 = time.perf_counter()
    if show_progress and console.is_terminal:
        with console.status(_Elapsed(COMPILE_NOTICE)):
            load_kernels()
    else:
        typer.echo(f"{COMPILE_NOTICE}...", err=True)
        load_kernels()
    typer.echo(f"compiled the kernels in {time.perf_counter() - t0:.0f} s", err=True)


# The time-stepper's warnings say what is checked and where the numbers are (the pages, which
# a test keeps in step with their data); they quote no study's numbers themselves.
TIMESTEP_WARNING = (
    "warning: --method timestep is experimental: first order in --dt; its ensembles of t_fall were checked "
    f"against the event-driven method's, its single falls were not (default step: --dt {SHORT_STEP[0]:g} --theta {SHORT_STEP[1]:g} "
    f"below N = {LONG_STEP_FROM}, --dt {LONG_STEP[0]:g} --theta {LONG_STEP[1]:g} from N = {LONG_STEP_FROM} on); the checks and their numbers: docs/timestep.md"
)
SHORT_STEP_EARLY_FROM = 2048  # N from which theta = 1/2 was seen to fall early against the exact method
SHORT_STEP_WARNING = (
    "warning: at N = {n} --theta 0.5 falls early against the exact method, where the default from "
    f"N = {LONG_STEP_FROM} on (--dt {LONG_STEP[0]:g} --theta {LONG_STEP[1]:g}) agrees with it (how far: docs/timestep.md)"
)


LANDING_CHECKED_FROM = 256  # --dt-rule landing was checked against the fixed step from this N on
LANDING_WARNING = (
    "warning: --dt-rule landing was checked from N = {n} on; below it some of its falls did not close their "
    "books (their slow ends take its longest steps; docs/timestep.md)"
)


def _run_engine(params, init, options, show_progress: bool, state=None, checkpoint=None):
    from .engine import kernels_cached, load_kernels, simulate  # lazy: the engine (numba) is heavy to import

    if options.method == "timestep":
        typer.echo(TIMESTEP_WARNING, err=True)
        if params.segments >= SHORT_STEP_EARLY_FROM and options.theta == SHORT_STEP[1]:
            typer.echo(SHORT_STEP_WARNING.format(n=params.segments), err=True)
        if options.dt_rule == "landing" and params.segments < LANDING_CHECKED_FROM:
            typer.echo(LANDING_WARNING.format(n=LANDING_CHECKED_FROM), err=True)

    cold = not kernels_cached(options.method)
    t0 = time.perf_counter()
    load = functools.partial(load_kernels, options.method)
    if cold:
        _compile_with_notice(load, show_progress)
    else:
        load()  # before the run: its wall time is the integration alone
    setup = time.perf_counter() - t0
    result = _simulate_with_progress(simulate, params, init, options, show_progress, state, checkpoint)
    result.extra["setup_seconds"] = setup
    result.extra["setup_compiled"] = cold
    return result


def _simulate_with_progress(simulate, params, init, options, show_progress: bool, state, checkpoint=None):
    if checkpoint is not None:
        simulate = functools.partial(simulate, checkpoint=checkpoint)
    if not show_progress:
        return simulate(params, init, options, progress=None, state=state)

    from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn

    console = _progress_console()
    if not console.is_terminal:
        return simulate(params, init, options, progress=None, state=state)
    with Progress(
        TextColumn("simulating"),
        BarColumn(),
        TaskProgressColumn(),
        TimeElapsedColumn(),
        TextColumn("{task.fields[info]}"),
        console=console,
        transient=True,
    ) as bar:
        task = bar.add_task("simulating", total=1.0, info="")

        def progress(fraction: float, info: dict | None = None) -> None:
            try:  # a progress report must never stop the run
                info = info or {}
                parts = []
                if info.get("t_over_tff") is not None:
                    parts.append(f"t/t_ff {float(info['t_over_tff']):.3f}")
                ev = info.get("events")
                if isinstance(ev, dict):
                    parts.append(f"lock {ev.get('lock', 0)}")
                if info.get("instants") is not None:
                    parts.append(f"instants {info['instants']}")
                if info.get("landed") is not None:
                    parts.append(f"landed {info['landed']}/{info.get('segments', '?')}")
                f = float(fraction)
                f = min(max(f, 0.0), 1.0) if math.isfinite(f) else 0.0
                bar.update(task, completed=f, info="  ".join(parts))
            except Exception:
                pass

        return simulate(params, init, options, progress=progress, state=state)


# --------------------------------------------------------------------------- commands
def _typer_parameters(opts: dict, names, helptext) -> list[inspect.Parameter]:
    """A typer option for each of ``names`` of ``opts`` (``MethodOption`` data): flag,
    default, type and help (``helptext(name)``)."""
    return [
        inspect.Parameter(
            name,
            inspect.Parameter.POSITIONAL_OR_KEYWORD,
            default=typer.Option(
                opts[name].default, opts[name].flag, help=helptext(name), show_default=opts[name].default is not None
            ),
            annotation=opts[name].annotation,
        )
        for name in names
    ]


def _method_option_parameters(command: str) -> list[inspect.Parameter]:
    """A typer option for each of the methods' options ``command`` takes (``option_names``)."""
    return _typer_parameters(all_options(), option_names(command), option_help)


def _contact_parameters() -> list[inspect.Parameter]:
    """A typer option for each of the contact laws' parameters (``contacts.registry``)."""
    prms = contact_params()
    return _typer_parameters(prms, [n for n, p in prms.items() if p.flag], lambda n: prms[n].help)


def _with_method_options(command: str, contacts_after: str):
    """Give the command (whose ``**method_options`` receives them) the methods' options as
    typer options after its ``--method``, and the contact laws' parameters after its
    option ``contacts_after`` (typer reads the function's ``__signature__``)."""

    def decorate(func):
        sig = inspect.signature(func)
        params = [p for p in sig.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
        at = next(i for i, p in enumerate(params) if p.name == "method") + 1
        params = params[:at] + _method_option_parameters(command) + params[at:]
        at = next(i for i, p in enumerate(params) if p.name == contacts_after) + 1
        func.__signature__ = sig.replace(parameters=params[:at] + _contact_parameters() + params[at:])
        return func

    return decorate


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
        "time-stepping, first order in --dt; for large N) or rattle (nonsmooth RATTLE, second order where the "
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
            from .initial import load_initial_state

            e0, w0 = load_initial_state(initial)
            if segments is not None and segments != e0.shape[0]:
                raise ParameterError(f"--segments {segments} disagrees with the {e0.shape[0]} rows of {initial!r}")
            segments = e0.shape[0]
            state = (e0, w0)
        values["segments"] = _CHAIN.segments if segments is None else segments
        params, init, options = build_inputs(values)
        if output is not None:
            check_writable(output, force, "--output")
        ck = None
        if checkpoint is not None:
            from .methods.checkpoint import Checkpoint

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
    from .records.audit import near_bounds

    for sentence in near_bounds(result):
        typer.echo(f"warning: {sentence}", err=True)


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
    pile's pull, top view of the pile, lock map, gamma measured from the floor (one file per figure and format)."""
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
    from .plots import plot_run  # lazy: matplotlib is heavy to import

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
    from .paper import QUICK, PaperSetup, paper_figures

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
    from .plots.animate import (  # lazy: matplotlib
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
        console = None if quiet else _progress_console()
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
    force: bool = typer.Option(False, "--force", help="Overwrite an existing output file."),
) -> None:
    """An orbitable 3D view of a run with a time slider, in one HTML file (plotly)."""
    from .plots.animate import AnimationError, frame_indices

    try:
        if Path(out).suffix.lower() not in (".html", ".htm"):
            raise ParameterError(f"--out: expected a .html file name, got {out!r}")
        if not (math.isfinite(stretch) and stretch > 0):
            raise ParameterError(f"--stretch: expected a number > 0, got {stretch!r}")
        check_writable(out, force, "--out")
        result = load_result(file)
        frame_indices(len(result.frame_t), every=every, frames=frames)  # checks the options against the run
    except (ParameterError, ResultFileError, FileExistsError, AnimationError) as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    from .plots.view import write_view  # lazy: plotly

    typer.echo(str(write_view(result, out, every=every, frames=frames, stretch=stretch)))


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
    from .plots.animate import AnimationError, frame_indices
    from .records.export import FORMATS, export_frames, vtk_frame_names

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
    from .model import FLOOR_MODELS, IC_KINDS
    from .sweeps import SweepSpec, parse_alphas, parse_choices, parse_segments

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
        from .sweeps.execute import check_scheduler, run_sweep

        spec.tasks()  # every run validated before anything starts
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
    from .sweeps.stats import table_stats

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
        from .plots.sweep import write_alpha_figure

        write_alpha_figure(res["points"], plot, res["optimal_alpha"])
        res["plot"] = plot
    if plot_n is not None:
        from .plots.sweep import write_segments_figure

        write_segments_figure(res["points"], plot_n)
        res["plot_n"] = plot_n
    if json_out:
        _print_json(res)
        return
    typer.echo(stats_text(res))


NOT_LANDED_LISTED = 10  # runs that did not land named by ``ballchain stats`` (--json: all)


def stats_text(res: dict) -> str:
    """The human-readable ``ballchain stats``."""

    def f(x, spec=".4f"):
        return "-" if x is None else format(x, spec)

    from .sweeps.stats import GROUP_KEYS

    # the other inputs that tell the points apart (a method, its step, a contact law's
    # parameter), one column each when they vary
    varying = [
        k
        for k in GROUP_KEYS
        if k not in ("segments", "alpha", "floor") and len({repr(p.get(k)) for p in res["points"]}) > 1
    ]

    def cell(v):
        if v is None or (isinstance(v, float) and not math.isfinite(v)) or v == "":
            return "-"  # (not this point's: an option of another method)
        return f"{v:.6g}" if isinstance(v, float) else str(v)

    lines = [
        f"{res['table']}: {res['rows']} rows ({', '.join(f'{v} {k}' for k, v in res['status'].items())})",
        f"{'N':>5} {'alpha':>7} {'floor':>5} "
        + "".join(f"{k:>{max(len(k), 8)}} " for k in varying)
        + f"{'runs':>4} {'fell':>4} {'t_fall/t_ff: mean':>17} {'95% interval':>17} "
        f"{'median':>7} {'t_landed/t_ff':>13} {'faster':>7} {'95% interval':>13}",
    ]
    for p in res["points"]:
        r, lr, fa = p["ratio"], p["landed_ratio"], p["faster_than_free_fall"]
        lines.append(
            f"{p['segments']:>5} {p['alpha_deg']:>6.4g}d {p['floor']:>5} "
            + "".join(f"{cell(p.get(k)):>{max(len(k), 8)}} " for k in varying)
            + f"{p['n_runs']:>4} {r['n']:>4} {f(r['mean']):>17} "
            f"{'[' + f(r['ci_low']) + ', ' + f(r['ci_high']) + ']':>17} {f(r['median']):>7} "
            f"{f(lr['mean']):>13} {f(fa['fraction'], '.2f'):>7} "
            f"{'[' + f(fa['ci_low'], '.2f') + ', ' + f(fa['ci_high'], '.2f') + ']':>13}"
        )
    from .sweeps.stats import MIN_INTERVAL_N

    lines.append(
        f"(95% intervals of the mean: bootstrap over the runs that fell, column fell; none from fewer than "
        f"{MIN_INTERVAL_N} runs)"
    )
    if any(o["n_alpha"] > 1 for o in res["optimal_alpha"]):
        lines.append("optimal alpha (smallest mean t_fall/t_ff; paired bootstrap 95% interval):")
        for o in res["optimal_alpha"]:
            if o["n_alpha"] > 1 and o["alpha_deg"] is not None:
                lines.append(
                    f"  N = {o['segments']}, floor {o['floor']}: {o['alpha_deg']:.4g} deg "
                    f"[{o['ci_low_deg']:.4g}, {o['ci_high_deg']:.4g}], mean t_fall/t_ff {o['mean']:.4f} "
                    f"({o['n_starts']} starts)"
                )
    for method, b in res.get("books", {}).items():
        lines.append(
            f"books of the {b['runs']} landed runs ({method}): worst |imbalance| / E0 {f(b['worst_imbalance'], '.2g')}, "
            f"deepest point {f(b['deepest'], '.2g')} b below a floor that watches every point"
        )
    bad = res.get("not_landed", [])
    if bad:
        lines.append(f"runs that did not land ({len(bad)}):")
        for r in bad[:NOT_LANDED_LISTED]:
            lines.append(f"  {r['run_id']} ({r['status']}): {r['message']}")
        if len(bad) > NOT_LANDED_LISTED:
            lines.append(f"  ... and {len(bad) - NOT_LANDED_LISTED} more (--json lists them all)")
    for key in ("plot", "plot_n"):
        if res.get(key):
            lines.append(f"{key.replace('_', ' ')}: {res[key]}")
    return "\n".join(lines)


theory_app = typer.Typer(
    cls=_OneLineErrors,
    no_args_is_help=True,
    add_completion=False,
    help="Closed forms of the model's theory (ballchain.theory), nondimensional.",
)
app.add_typer(theory_app, name="theory")


def _theory_out(values: dict, json_out: bool) -> None:
    if json_out:  # (inf, nan: null: an upright rod never falls, a slip that never comes)
        _print_json({k: None if isinstance(v, float) and not math.isfinite(v) else v for k, v in values.items()})
    else:
        for k, v in values.items():
            typer.echo(f"{k:<24} {v:.12g}" if isinstance(v, float) else f"{k:<24} {v}")


def _theory_call(fn, *args):
    try:
        return fn(*args)
    except ValueError as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)


@theory_app.command("hamm-geminard")
def theory_hamm_geminard(
    gamma: float = typer.Option(..., "--gamma", help="Braking coefficient gamma < 3/2."),
    json_out: bool = typer.Option(False, "--json"),
) -> None:
    """t_gamma / t_ff of the Hamm-Geminard model: B((2-g)/(3-2g), 1/2) / (2 sqrt(3-2g))."""
    from .theory import hamm_geminard_time_ratio

    _theory_out({"gamma": gamma, "time_ratio": _theory_call(hamm_geminard_time_ratio, gamma)}, json_out)


@theory_app.command("gamma")
def theory_gamma(
    ratio: float = typer.Option(..., "--ratio", help="t_fall / t_ff, in (0, sqrt(pi/2))."),
    json_out: bool = typer.Option(False, "--json"),
) -> None:
    """The Hamm-Geminard gamma whose fall takes t_fall / t_ff = RATIO."""
    from .theory import gamma_from_time_ratio

    _theory_out({"time_ratio": ratio, "gamma": _theory_call(gamma_from_time_ratio, ratio)}, json_out)


@theory_app.command("pivot-rod")
def theory_pivot_rod(
    theta0: str = typer.Option(..., "--theta0", help="Start angle from the vertical (rad, or 30deg)."),
    s: float = typer.Option(0.0, "--s", help="Launch rate s = b thetadot0^2 / g (>= 0)."),
    theta: str | None = typer.Option(None, "--theta", help="Angle at which to give the reaction."),
    json_out: bool = typer.Option(False, "--json"),
) -> None:
    """A rod pivoting on the floor: the pivot's vertical impulse Delta p(theta0, s) until
    the rod is horizontal (units m sqrt(g b)), the critical s*(theta0) beyond which it is
    negative, and the reaction (units m g) at --theta."""
    from .theory import pivot_rod_critical_s, pivot_rod_horizontal_force, pivot_rod_impulse, pivot_rod_vertical_force

    try:
        th0 = _parse_angle("--theta0", theta0)
        th = None if theta is None else _parse_angle("--theta", theta)
    except ParameterError as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    out = {
        "theta0": th0,
        "s": s,
        "impulse": _theory_call(pivot_rod_impulse, th0, s),
        "critical_s": _theory_call(pivot_rod_critical_s, th0),
    }
    if th is not None:
        out["theta"] = th
        out["force_z"] = float(pivot_rod_vertical_force(th, th0, s))
        out["force_x"] = float(pivot_rod_horizontal_force(th, th0, s))
    _theory_out(out, json_out)


@theory_app.command("rod-on-floor")
def theory_rod_on_floor(
    theta0: str = typer.Option(..., "--theta0", help="Start angle from the vertical (rad, or 30deg), at rest."),
    mu: float | None = typer.Option(None, "--mu", help="Coulomb friction coefficient of the floor (>= 0)."),
    json_out: bool = typer.Option(False, "--json"),
) -> None:
    """A single rod (N = 1) standing on the floor, released at rest: the time to lie flat
    on a frictionless floor (its centre falls on a vertical line) and pivoting about its
    foot (units sqrt(b/g)); with --mu, the friction ratio F_x / F_z the pivoting asks at
    release and the angle and time at which it first reaches MU (where the foot slips)."""
    from .theory import (
        pivot_rod_friction_ratio,
        pivot_rod_slip_angle,
        pivot_rod_time,
        rod_fall_time,
        sliding_rod_fall_time,
    )

    try:
        th0 = _parse_angle("--theta0", theta0)
    except ParameterError as e:
        _error(str(e))
        raise typer.Exit(EXIT_USAGE)
    out = {
        "theta0": th0,
        "frictionless_fall_time": _theory_call(sliding_rod_fall_time, th0),
        "pivot_fall_time": _theory_call(rod_fall_time, th0),
    }
    if mu is not None:
        out["mu"] = mu
        out["ratio_at_release"] = float(pivot_rod_friction_ratio(th0, th0))
        th = _theory_call(pivot_rod_slip_angle, th0, mu)
        out["slip_angle"] = th
        out["slip_time"] = math.nan if math.isnan(th) else _theory_call(pivot_rod_time, th, th0)
    _theory_out(out, json_out)


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
