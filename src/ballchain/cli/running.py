"""Running the engine from the command line: ``--from``, the compile notice, the
progress bar, the time-stepper's warnings, and a run that Ctrl-C interrupts cleanly."""

from __future__ import annotations

import functools
import math
import time

import typer

from ..contacts.registry import all_params as contact_params
from ..methods import all_options, method_takes, option_names
from ..methods.timestep import LONG_STEP, LONG_STEP_FROM, SHORT_STEP
from ..model import ParameterError
from ..records.files import load_result


def _its_options(o, method: str) -> dict:
    """The methods' options of a saved run (``o``: its ``SolverOptions``) as ``--from`` reruns
    them with ``method``: those both its method and ``method`` take (``methods.method_takes``);
    the others at their defaults (a run records a value of each, given or not)."""
    opts = all_options()
    return {
        name: getattr(o, name) if method_takes(o.method, name) and method_takes(method, name) else opts[name].default
        for name in option_names("simulate")
    }


def _values_from_file(path: str, values: dict, ctx, use_its_start: bool) -> tuple[dict, tuple | None]:
    """``--from``: the option values of the run saved in ``path`` (``values`` given on the
    command line override them) and, for a run started from an explicit state
    (``--initial``), that state (its first frame)."""
    import numpy as np

    r = load_result(path)
    p, o = r.params, r.options
    given = {k for k in values if getattr(ctx.get_parameter_source(k), "name", "") == "COMMANDLINE"}
    base = dict(segments=p.segments, alpha=p.alpha, floor=p.floor, anchor_cone=p.anchor_cone,
                **{name: getattr(p, name) for name in contact_params()},
                until=o.until, frames_per_tff=o.frames_per_tff, max_time=o.max_time, max_events=o.max_events,
                method=o.method, **_its_options(o, values["method"] if "method" in given else o.method))  # fmt: skip
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
    if state is not None and "segments" in given and values["segments"] != p.segments:
        raise ParameterError(f"--segments {values['segments']} disagrees with the {p.segments} segments of {path!r}")
    base.update({k: values[k] for k in given})
    return base, state


def _progress_console():
    """Where the progress bar goes: stderr, never stdout."""
    from rich.console import Console

    return Console(stderr=True)


COMPILE_NOTICE = "compiling the numba kernels"  # (of --method M: first run only, cached afterwards)


def compile_notice(method: str) -> str:
    """What stderr says while the kernels of ``method`` compile (``_compile_with_notice``)."""
    return (
        f"{COMPILE_NOTICE} of --method {method} (first run only, cached afterwards; minutes of CPU: "
        "`ballchain warmup` compiles every method's ahead, in parallel)"
    )


class _Elapsed:
    """A line that shows the seconds since it was made each time it is drawn."""

    def __init__(self, text: str):
        self.text = text
        self.t0 = time.perf_counter()

    def __rich__(self) -> str:
        return f"{self.text}: {time.perf_counter() - self.t0:.0f} s"


def _compile_with_notice(load_kernels, show_progress: bool, method: str = "event") -> None:
    """Compile the kernels of ``method`` (``load_kernels``) saying so on stderr, naming the
    method: a line with the elapsed seconds, kept up to date while it works on a terminal;
    elsewhere (a log, a pipe) the line when it starts and one when it is done, with the
    seconds it took (wall and this process's CPU)."""
    console = _progress_console()
    t0, c0 = time.perf_counter(), time.process_time()
    notice = compile_notice(method)
    if show_progress and console.is_terminal:
        with console.status(_Elapsed(notice)):
            load_kernels()
    else:
        typer.echo(f"{notice}...", err=True)
        load_kernels()
    typer.echo(
        f"compiled the kernels of --method {method} in {time.perf_counter() - t0:.0f} s "
        f"({time.process_time() - c0:.0f} s of CPU)",
        err=True,
    )


# The time-stepper's warnings say what is checked and where the numbers are (the pages, which
# a test keeps in step with their data); they quote no study's numbers themselves.
TIMESTEP_WARNING = (
    "warning: --method timestep is experimental: first order in --dt; its ensembles of t_fall were checked "
    f"against the event-driven method's, its single falls were not (default step: --dt {SHORT_STEP[0]:g} --theta {SHORT_STEP[1]:g} "
    f"below N = {LONG_STEP_FROM}, --dt {LONG_STEP[0]:g} --theta {LONG_STEP[1]:g} from N = {LONG_STEP_FROM} on); the checks and their numbers: docs/timestep.md"
)
RATTLE_WARNING = (
    "warning: --method rattle is experimental: second order where the motion is smooth; its ensembles of "
    "t_fall and of the losses were checked against the event-driven method's, not everywhere (where, and "
    "how far: docs/rattle.md)"
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


# A run's cost before it starts (``cost_warning``): steps of dt t_ff/N beyond this many (to
# --until, else in the fall's first t_ff) are absurd (the largest documented runs, N = 16384 at
# the default step, take about 1e6), and a rough wall time per step (s) of N segments: from the
# median falls of docs/index.md (a 2-core machine), within a factor of two from N = 128 to 4096.
ABSURD_STEPS = 1e8


def step_seconds(segments: int) -> float:
    """A rough wall time of one step of N = ``segments`` (s)."""
    return 5e-6 + 5e-7 * segments


def cost_warning(segments: int, options, what: str = "") -> str | None:
    """One line warning of a run of ``options`` (``SolverOptions``) with N = ``segments`` whose
    first t_ff (a fall takes about that at least; or its --until, if shorter) takes more than
    ABSURD_STEPS steps, with the steps per t_ff, a rough wall time and how to shorten it; None
    for another run, and for the event method (which sizes its own steps).  ``what``: the run's
    name."""
    from ..methods import method_default, steps_per_tff

    per_tff = steps_per_tff(options, segments)
    until = options.until
    if per_tff is None or per_tff * min(1.0, until or 1.0) <= ABSURD_STEPS:
        return None
    hours = per_tff * step_seconds(segments) / 3600.0
    end = f"--max-time {options.max_time:g}" if until is None else f"--until {until:g}"
    return (
        f"warning: {what}--method {options.method} --dt {options.for_segments(segments).dt:g} at N = {segments} "
        f"takes about {per_tff:.2g} steps per t_ff of the fall (roughly {hours:.2g} h each, up to {end} t_ff): "
        f"a larger --dt (its default there: {method_default(options.method, 'dt', segments):g}) or a shorter "
        "--until ends it sooner"
    )


def _run_engine(params, init, options, show_progress: bool, state=None, checkpoint=None):
    from ..engine import kernels_cached, load_kernels, simulate  # lazy: the engine (numba) is heavy to import

    cost = cost_warning(params.segments, options)
    if cost is not None:
        typer.echo(cost, err=True)
    if options.method == "rattle":
        typer.echo(RATTLE_WARNING, err=True)
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
        _compile_with_notice(load, show_progress, options.method)
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
