"""``ballchain theory``: the closed forms of ``ballchain.theory``."""

from __future__ import annotations

import math

import typer

from ..inputs import _parse_angle
from ..model import ParameterError
from .app import EXIT_USAGE, _error, _OneLineErrors, _print_json, app

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
    from ..theory import hamm_geminard_time_ratio

    _theory_out({"gamma": gamma, "time_ratio": _theory_call(hamm_geminard_time_ratio, gamma)}, json_out)


@theory_app.command("gamma")
def theory_gamma(
    ratio: float = typer.Option(..., "--ratio", help="t_fall / t_ff, in (0, sqrt(pi/2))."),
    json_out: bool = typer.Option(False, "--json"),
) -> None:
    """The Hamm-Geminard gamma whose fall takes t_fall / t_ff = RATIO."""
    from ..theory import gamma_from_time_ratio

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
    from ..theory import pivot_rod_critical_s, pivot_rod_horizontal_force, pivot_rod_impulse, pivot_rod_vertical_force

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
    from ..theory import (
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
