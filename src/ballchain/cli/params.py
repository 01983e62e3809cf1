"""The options the registries state (the methods', the contact laws'), given to a command
as typer options."""

from __future__ import annotations

import inspect

import typer

from ..contacts.registry import all_params as contact_params
from ..methods import all_options, option_help, option_names


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


def _contact_parameters(axes: bool = False) -> list[inspect.Parameter]:
    """A typer option for each of the contact laws' parameters (``contacts.registry``);
    ``axes``: each takes a comma-separated list of values, an axis of a sweep's grid (text,
    parsed by ``sweeps.spec.law_values``)."""
    prms = contact_params()
    names = [n for n, p in prms.items() if p.flag]
    if not axes:
        return _typer_parameters(prms, names, lambda n: prms[n].help)
    return [
        inspect.Parameter(
            n,
            inspect.Parameter.POSITIONAL_OR_KEYWORD,
            default=typer.Option(
                f"{prms[n].default:g}",
                prms[n].flag,
                help=f"{prms[n].help} A comma-separated list (0,0.3,inf) makes it an axis of the grid.",
            ),
            annotation=str,
        )
        for n in names
    ]


def _with_method_options(command: str, contacts_after: str):
    """Give the command (whose ``**method_options`` receives them) the methods' options as
    typer options after its ``--method``, and the contact laws' parameters after its
    option ``contacts_after`` (typer reads the function's ``__signature__``; for ``sweep``
    each takes a list of values, an axis of the grid)."""

    def decorate(func):
        sig = inspect.signature(func)
        params = [p for p in sig.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
        at = next(i for i, p in enumerate(params) if p.name == "method") + 1
        params = params[:at] + _method_option_parameters(command) + params[at:]
        at = next(i for i, p in enumerate(params) if p.name == contacts_after) + 1
        laws = _contact_parameters(axes=command == "sweep")
        func.__signature__ = sig.replace(parameters=params[:at] + laws + params[at:])
        return func

    return decorate
