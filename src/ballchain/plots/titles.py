"""The title of a figure of one run: what made it (the chain, the method and its step, the
contact laws away from their defaults), one text for every figure and view of a run
(``run``, ``animate``, ``paper``, ``view``); plain text, no plotting library."""

from __future__ import annotations

import numpy as np

from ..contacts.registry import all_params
from ..methods import method_package, option_owner
from ..records.result import Result


def _steps(method: str) -> bool:
    """Whether ``method`` advances in steps of dt t_ff/N: it owns the option ``dt`` or uses
    it (its package's ``USES``), as the methods' registry states."""
    return option_owner("dt") == method or "dt" in getattr(method_package(method), "USES", ())


def run_title(r: Result, sep: str = "\n") -> str:
    """What made the figure of one run, as its title: the chain (N, alpha, floor), then,
    after ``sep``, the method (and its step dt for a method that steps) and every contact
    law's parameter away from its default, by its flag (learnt from
    ``contacts.registry.all_params``), e.g. ``method rattle (dt 0.05 t_ff/N) |
    --restitution-lock 0.5``."""
    p, o = r.params, r.options
    method = f"method {o.method}" + (f" (dt {o.dt:.4g} t_ff/N)" if _steps(o.method) else "")
    laws = [f"{q.flag} {getattr(p, name):g}" for name, q in all_params().items() if getattr(p, name) != q.default]
    chain = f"N = {p.segments}, alpha = {np.degrees(p.alpha):.4g} deg, floor {p.floor}"
    return chain + sep + " | ".join([method, *laws])
