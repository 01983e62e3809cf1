"""The ``ballchain`` application: its one-line errors, exit codes and the small helpers
every command uses."""

from __future__ import annotations

import json
import sys

import typer
from typer.core import TyperGroup

from .. import __version__

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


def _error(message: str) -> None:
    text = " ".join(str(message).split())  # one line, always
    typer.echo(f"error: {text}", err=True)


def _print_json(obj: dict) -> None:
    typer.echo(json.dumps(obj, allow_nan=False))
