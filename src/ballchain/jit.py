"""How the kernels are compiled: numba's ``njit``, with one change to how much LLVM work a
first run does.

numba compiles each jitted function into its own LLVM module, links into it the modules
of every function it calls, and optimises the result with its full pipeline.  A kernel
called from Python (``events.run_events``) is thus compiled with all of the engine's
kernels linked in, but so is every function on the way down: a kernel ``d`` calls deep
is optimised ``d`` times, once in each module it is linked into, and the engine's call
tree makes the one-time compile several times the work of optimising its code once
(numba knows the problem: numba/numba pull request 9566, not merged).

The policy here: a library compiled only because a kernel of ours being compiled calls it
(a *nested* compile) gets numba's cheap pipeline (the per-function passes and the cheap
module pass numba runs before the full one); the full pipeline runs once, on the module
of the kernel called from Python, where every callee has been linked in and is optimised
with it.  The machine code that runs is that of the outer module, optimised in full as
before.  Kernels that the package calls from Python as well (``@entry``) are optimised in
full wherever they are compiled; any other kernel's own machine code runs only if Python
calls it later with the types of a nested compile (tests do), and is then less optimised.
``benchmarks/compile_time.py`` measures the effect (cold compiles side by side, the
policy on and off); ``BALLCHAIN_OPTIMIZE_CALLEES=1`` switches the policy off.

The policy is installed only where numba's private method it wraps
(``CPUCodeLibrary._optimize_final_module``) still has the shape it was written for;
elsewhere numba compiles as it always does (slower, same results).
"""

from __future__ import annotations

import os

from numba import njit  # noqa: F401  (the kernels' decorator: ``from .jit import njit``)
from numba.core import codegen as _codegen
from numba.core import config as _config
from numba.core import event as _event

__all__ = ["njit", "entry", "policy_active", "nested_depth", "cheap_libraries"]

_PACKAGE = __name__.rpartition(".")[0]  # "ballchain"


class _CompileDepth(_event.Listener):
    """Counts the compiles in progress (numba's "numba:compile" events nest: a callee is
    compiled while its caller is being typed) and whether the outermost one is ours."""

    def __init__(self):
        self.stack = []  # the Python functions being compiled, outermost first
        self.outer_is_ours = False

    @property
    def depth(self) -> int:
        return len(self.stack)

    def on_start(self, ev):
        disp = ev.data.get("dispatcher") if isinstance(ev.data, dict) else None
        py_func = getattr(disp, "py_func", None)
        if not self.stack:
            module = getattr(py_func, "__module__", "") or ""
            self.outer_is_ours = module == _PACKAGE or module.startswith(_PACKAGE + ".")
        self.stack.append(py_func)

    def on_end(self, ev):
        self.stack.pop()

    def optimise_in_full(self, library) -> bool:
        """Full pipeline for this library?  Yes unless it is a nested compile under a
        kernel of ours, of a function that is not an ``entry``."""
        if self.depth <= 1 or not self.outer_is_ours:
            return True
        inner = self.stack[-1]
        return inner in _ENTRIES and library.name == getattr(inner, "__qualname__", None)


_DEPTH = _CompileDepth()
_ENTRIES: set = set()
_CHEAP: list = []  # names of the libraries given the cheap pipeline, in this process


def cheap_libraries() -> tuple:
    """Names of the libraries compiled with the cheap pipeline so far in this process."""
    return tuple(_CHEAP)


def entry(dispatcher):
    """Mark a kernel that the package also calls from Python: its own machine code runs,
    so it is optimised in full even when compiled because another kernel calls it."""
    _ENTRIES.add(dispatcher.py_func)
    return dispatcher


def nested_depth() -> int:
    """How many compiles are in progress (0: none; 1: a kernel called from Python)."""
    return _DEPTH.depth


def _cheap_only(library) -> None:
    """numba's cheap module pipeline and reference-count pruning, without the full one
    (the first half of ``CPUCodeLibrary._optimize_final_module``)."""
    cg = library._codegen
    mpm, mpb = cg._module_pass_manager(loop_vectorize=cg._loopvect, slp_vectorize=False,
                                       opt=cg._opt_level, cost="cheap")
    with library._recorded_timings.record("Module passes (cheap optimization for refprune)", mpb):
        mpm.run(library._final_module, mpb)
    if not _config.LLVM_REFPRUNE_PASS:
        library._final_module = _codegen.remove_redundant_nrt_refct(library._final_module)


def _shape_known() -> bool:
    """Does numba's method still do what ``_cheap_only`` copies the first half of?"""
    lib = getattr(_codegen, "CPUCodeLibrary", None)
    method = getattr(lib, "_optimize_final_module", None)
    code = getattr(method, "__code__", None)
    if code is None:
        return False
    needed = {"_module_pass_manager", "_final_module", "_recorded_timings", "LLVM_REFPRUNE_PASS",
              "remove_redundant_nrt_refct", "run"}
    return needed <= set(code.co_names) and hasattr(_codegen, "remove_redundant_nrt_refct")


def _install() -> bool:
    if os.environ.get("BALLCHAIN_OPTIMIZE_CALLEES", "") not in ("", "0"):
        return False
    lib = getattr(_codegen, "CPUCodeLibrary", None)
    if getattr(getattr(lib, "_optimize_final_module", None), "_ballchain_policy", False):
        return True  # installed already (the module was reloaded)
    if not _shape_known():
        return False
    full = lib._optimize_final_module

    def _optimize_final_module(self):
        if _DEPTH.optimise_in_full(self):
            full(self)
        else:
            _cheap_only(self)  # linked into the caller being compiled, optimised there
            _CHEAP.append(self.name)

    _optimize_final_module._ballchain_policy = True
    _optimize_final_module.__doc__ = full.__doc__
    lib._optimize_final_module = _optimize_final_module
    _event.register("numba:compile", _DEPTH)
    return True


_ACTIVE = _install()


def policy_active() -> bool:
    """Is the compile policy of this module in force (module docstring)?"""
    return _ACTIVE
