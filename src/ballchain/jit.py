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
module pass numba runs before the full one) and links nothing in: its calls to its
callees stay declarations, resolved in numba's JIT engine (where every callee was added
before its caller).  The full pipeline runs once, on the module of the kernel called from
Python (``events.run_events``), into which every library of its call tree is linked,
callers before callees, and optimised together.  The machine code that runs is that of
this outer module, optimised in full as before.  Kernels that the package calls from
Python as well (``@entry``) are linked and optimised in full wherever they are compiled.
Any other kernel's own machine code runs only if Python calls it later with the types of
a nested compile (tests do), and is then less optimised.  A nested library is not
self-contained, so it is never written to numba's cache (loaded alone in a later process
it would call into nothing): a later process that calls such a kernel from Python
compiles it afresh, in full.  ``benchmarks/compile_time.py`` measures the effect (cold
compiles side by side, the policy on and off); ``BALLCHAIN_OPTIMIZE_CALLEES=1`` switches
the policy off.

The policy is installed only where numba's private methods it wraps
(``CPUCodeLibrary.finalize`` and ``_optimize_final_module``, and the cache's
``check_cachable``) still have the shape it was written for; elsewhere numba compiles as
it always does (slower, same results).  ``pyproject.toml`` bounds numba to the versions
checked, and ``tests/test_jit.py`` fails if the policy is not in force.

A call from one kernel to another with a constant argument (``True``, ``0``) would make
numba compile the callee for that literal value (``Literal[bool](True)``), one
specialisation per constant, each with its own copy of the callee's call tree in the
caller's module: RATTLE's step was compiled twice that way (the fall's and a frame's),
its factorisation four times.  The package's kernels take the plain types of such
arguments instead (``_install_unliteral_calls``: one specialisation per plain signature,
the branch on the constant taken at run time; results unchanged): RATTLE's cold compile
went from 206 to 150 s of CPU, the others' by under 2%.

numba also gives every specialisation it compiles two wrappers, one that Python calls
(unboxing each argument: every array of every bundle a kernel takes) and one for C.  A
kernel compiled only because another kernel of ours calls it (a nested compile of a
function that is not an ``entry``) is compiled without them (``_install_bare_callees``):
compiled code calls its body directly, so the machine code that runs is unchanged, and
its library is cheap and never cached anyway.  Such a *bare* specialisation serves
compiled callers only; a call from Python with its types compiles the kernel afresh, in
full, wrappers included.  The wrappers were about a third of the event method's and the
time-stepper's cold compile (their bundles have up to 80 arrays).

Nor is a bare kernel's library given machine code: only the machine code of the full
libraries runs (each with its own copy of every function of its call tree, linked in), so
the JIT engine is handed a copy of a bare kernel's module (and of the subroutines' compiled
for it) whose functions are ``available_externally`` (LLVM emits no code for them), its
globals as they were (the environment that numba's ``set_env`` fills).  LLVM's code
generation for those libraries was about 9 of RATTLE's 136 s of CPU.

Kernels compiled with ``_nrt=False`` (numba's option; every method's and the core's, the
floors' and the contact laws') take no reference counts: no incref and decref of every
array of every bundle on each use, entry and exit, which numba lowers and LLVM must then
optimise away (RATTLE's bundles hold up to ~190 arrays, the event handler's scratch ~30).
They borrow the arrays their caller passes (which the caller holds for the call), so such
a kernel may neither allocate (numba refuses to compile it), nor return an array, nor take
one that a call returns (a view its callee made: the reference would never be released; a
bundle it builds of views of its own arrays, ``Dense(...)``, is not a call in this sense):
the kernels that allocate (``lcp.dense_lcp``, ``dopri.dense_state`` ...), make views
(``scheme.motion_view`` ...) and their callers keep numba's reference counts, ``_nrt=True``
written out (numba's callee inherits its caller's setting where it states none).
``borrowing_problems`` lists the kernels of a process that break the rule
(``tests/test_jit.py`` runs it after a cold compile of each method).  The machine code
computes the same numbers.  Without reference counts the event method's cold compile went
from 88 to 70 s of CPU (one compile each on a loaded machine; docs/notes/benchmarks-history.md).

The on-disk cache is keyed to every engine source, not only the kernel's own file:
numba keys a cached kernel to a hash of the file that defines it, so a caller compiled
against an old callee in another file would load stale machine code after an edit of
that callee (or a package upgrade).  The cache locators of the package's kernels add
``provenance.engine_fingerprint()`` (a hash of all the engine's sources) to that key
(``_keyed_locator``): any edit recompiles every kernel once.  An index with another key
is rewritten in place, so stale entries do not pile up.  An index that cannot even be read
back (an older engine's, naming a type that has since moved or gone: numba unpickles it
before it compares the key, and would stop the run there) is a miss as well
(``_install_stale_index_guard``).
"""

from __future__ import annotations

import os
import pickle

from numba import njit  # noqa: F401  (the kernels' decorator: ``from ..jit import njit``)
from numba.core import caching as _caching
from numba.core import codegen as _codegen
from numba.core import config as _config
from numba.core import event as _event

from .provenance import PACKAGE_DIR, engine_fingerprint

__all__ = [
    "njit",
    "entry",
    "policy_active",
    "nested_depth",
    "cheap_libraries",
    "cache_keyed",
    "unliteral_calls",
    "bare_callees",
    "borrowing_problems",
]

_PACKAGE = __name__.partition(".")[0]  # "ballchain"


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


def _is_cheap(library) -> bool:
    """Was this library compiled with the cheap pipeline, linking nothing?"""
    return getattr(library, "_ballchain_cheap", False)


def _no_check():
    return None


def _closure(libraries) -> list:
    """The libraries linked into a library optimised in full: its callees and, for those
    compiled with the cheap pipeline (which link nothing), their callees in turn.  Callers
    come before their callees: LLVM's linker copies a ``linkonce_odr`` function only if
    the module it is linked into already calls it."""
    post, seen = [], set()

    def visit(lib):
        seen.add(lib)
        if _is_cheap(lib):
            for callee in lib._linking_libraries:
                if callee not in seen:
                    visit(callee)
        post.append(lib)

    for lib in libraries:
        if lib not in seen:
            visit(lib)
    return post[::-1]


def _cheap_only(library) -> None:
    """numba's cheap module pipeline and reference-count pruning, without the full one
    (the first half of ``CPUCodeLibrary._optimize_final_module``)."""
    cg = library._codegen
    mpm, mpb = cg._module_pass_manager(
        loop_vectorize=cg._loopvect, slp_vectorize=False, opt=cg._opt_level, cost="cheap"
    )
    with library._recorded_timings.record("Module passes (cheap optimization for refprune)", mpb):
        mpm.run(library._final_module, mpb)
    if not _config.LLVM_REFPRUNE_PASS:
        library._final_module = _codegen.remove_redundant_nrt_refct(library._final_module)


def _names(owner, method: str) -> set:
    """The names a method's code uses (empty if it is not plain Python)."""
    code = getattr(getattr(owner, method, None), "__code__", None)
    return set(code.co_names) if code is not None else set()


def _shape_known() -> bool:
    """Do numba's methods still do what the policy relies on: ``finalize`` links the
    ``_linking_libraries`` then optimises, ``_finalize_final_module`` verifies the
    declarations, ``_optimize_final_module`` runs what ``_cheap_only`` copies the first
    half of, and the cache asks ``check_cachable`` before it saves?"""
    lib = getattr(_codegen, "CPUCodeLibrary", None)
    impl = getattr(_caching, "CompileResultCacheImpl", None)
    cache = getattr(_caching, "Cache", None)
    return (
        lib is not None
        and impl is not None
        and cache is not None
        and {
            "_module_pass_manager",
            "_final_module",
            "_recorded_timings",
            "LLVM_REFPRUNE_PASS",
            "remove_redundant_nrt_refct",
            "run",
        }
        <= _names(lib, "_optimize_final_module")
        and {
            "_linking_libraries",
            "link_in",
            "_get_module_for_linking",
            "_optimize_final_module",
            "_reload_init",
            "_finalize_final_module",
        }
        <= _names(lib, "finalize")
        and {"_verify_declare_only_symbols", "_add_module", "_final_module"} <= _names(lib, "_finalize_final_module")
        and "check_cachable" in _names(cache, "_save_overload")
        and hasattr(impl, "check_cachable")
        and hasattr(_codegen, "remove_redundant_nrt_refct")
    )


def _install() -> bool:
    if os.environ.get("BALLCHAIN_OPTIMIZE_CALLEES", "") not in ("", "0"):
        return False
    lib = getattr(_codegen, "CPUCodeLibrary", None)
    if getattr(getattr(lib, "_optimize_final_module", None), "_ballchain_policy", False):
        return True  # installed already (the module was reloaded)
    if not _shape_known():
        return False
    full = lib._optimize_final_module
    finalize = lib.finalize
    finalize_final = lib._finalize_final_module
    check_cachable = _caching.CompileResultCacheImpl.check_cachable

    def _finalize(self):
        self._ballchain_cheap = not _DEPTH.optimise_in_full(self)
        # (bare: compiled without wrappers, ``_install_bare_callees``; nothing asks for its code)
        self._ballchain_unemitted = (
            self._ballchain_cheap and _BARE_CALLEES and _DEPTH.depth > 0 and _bare(_DEPTH.stack[-1])
        )
        linking = self._linking_libraries
        if self._ballchain_cheap:
            # nothing linked in: calls to the callees are resolved in the JIT engine,
            # where the callees were added before; a full caller links them all
            for callee in linking:
                self._reload_init.update(callee._reload_init)
            self._linking_libraries = []
            self._verify_declare_only_symbols = _no_check
        else:
            self._linking_libraries = _closure(linking)
        try:
            finalize(self)
        finally:
            self._linking_libraries = linking
            self.__dict__.pop("_verify_declare_only_symbols", None)

    def _optimize_final_module(self):
        if _is_cheap(self):
            _cheap_only(self)  # linked into the caller being compiled, optimised there
            _CHEAP.append(self.name)
        else:
            full(self)

    def _check_cachable(self, cres):
        if _is_cheap(cres.library) or getattr(cres.library, "_ballchain_bare", False):
            return False  # not self-contained (or no wrapper): never loaded without its callees
        return check_cachable(self, cres)

    def _finalize_final_module(self):
        if not getattr(self, "_ballchain_unemitted", False):
            return finalize_final(self)
        # a bare kernel's cheap library (or a subroutine's, compiled for it): only the full
        # callers' machine code runs, each with its own copy of the library's functions
        # (linked in), so the JIT engine is given its globals (the environments that
        # ``set_env`` fills) and its functions as available_externally: no machine code
        # (module docstring); the library keeps its module as it was, for linking
        own = self._final_module
        shown = own.clone()
        for fn in shown.functions:
            if not fn.is_declaration:
                fn.linkage = "available_externally"
        self._final_module = shown
        try:
            finalize_final(self)
        finally:
            self._final_module = own

    _optimize_final_module._ballchain_policy = True
    _optimize_final_module.__doc__ = full.__doc__
    lib._optimize_final_module = _optimize_final_module
    lib.finalize = _finalize
    lib._finalize_final_module = _finalize_final_module
    _caching.CompileResultCacheImpl.check_cachable = _check_cachable
    _event.register("numba:compile", _DEPTH)
    return True


_ACTIVE = _install()


def policy_active() -> bool:
    """Is the compile policy of this module in force (module docstring)?"""
    return _ACTIVE


def _bare(py_func) -> bool:
    """Compile this function without its Python and C wrappers?  Yes for a kernel of
    ours compiled only because another kernel of ours calls it (a nested compile of a
    function that is not an ``entry``: its library gets the cheap pipeline and is never
    cached, see ``_install``); only compiled code calls that specialisation."""
    if _DEPTH.depth <= 1 or not _DEPTH.outer_is_ours or _DEPTH.stack[-1] is not py_func:
        return False
    module = getattr(py_func, "__module__", "") or ""
    return py_func not in _ENTRIES and (module == _PACKAGE or module.startswith(_PACKAGE + "."))


def _is_bare(cres) -> bool:
    return getattr(cres.library, "_ballchain_bare", False)


def _install_bare_callees() -> bool:
    """numba's compile of a kernel called from compiled code, without the wrappers that
    let Python call it (module docstring): the specialisation is kept for compiled
    callers (``overloads``) but not offered to Python calls; a Python call with its
    types compiles it afresh, in full, wrappers included."""
    from numba.core import compiler as _compiler
    from numba.core import dispatcher as _dispatcher
    from numba.core import sigutils as _sigutils
    from numba.core.compiler_lock import global_compiler_lock

    fc = getattr(_dispatcher, "_FunctionCompiler", None)
    disp = getattr(_dispatcher, "Dispatcher", None)
    flags = getattr(_compiler, "Flags", None)
    if (
        not _ACTIVE
        or fc is None
        or disp is None
        or not all(hasattr(flags, f) for f in ("no_cpython_wrapper", "no_cfunc_wrapper"))
        or "_customize_flags" not in _names(fc, "_compile_core")
        or not {"_insert", "overloads"} <= _names(disp, "add_overload")
        or not {"overloads", "entry_point"} <= _names(disp, "compile")
    ):
        return False
    if getattr(fc._compile_core, "_ballchain_bare", False):
        return True  # installed already (the module was reloaded)
    customize, compile_core, add_overload, compile_ = (
        fc._customize_flags,
        fc._compile_core,
        disp.add_overload,
        disp.compile,
    )

    def _customize_flags(self, flags):
        flags = customize(self, flags)
        if _bare(self.py_func):
            flags.no_cpython_wrapper = True
            flags.no_cfunc_wrapper = True
        return flags

    def _compile_core(self, args, return_type):
        bare = _bare(self.py_func)  # (the compile stack is the same before and after)
        cres = compile_core(self, args, return_type)
        if bare:
            cres.library._ballchain_bare = True
        return cres

    def _add_overload(self, cres):
        if _is_bare(cres):  # for compiled callers only: no wrapper for Python to call
            self.overloads[tuple(cres.signature.args)] = cres
            return
        add_overload(self, cres)

    def _compile(self, sig):
        with global_compiler_lock:
            if _DEPTH.depth == 0:  # called from Python: a bare specialisation will not do
                args, _ = _sigutils.normalize_signature(sig)
                existing = self.overloads.get(tuple(args))
                if existing is not None and _is_bare(existing):
                    del self.overloads[tuple(args)]
            return compile_(self, sig)

    _compile_core._ballchain_bare = True
    fc._customize_flags = _customize_flags
    fc._compile_core = _compile_core
    disp.add_overload = _add_overload
    disp.compile = _compile
    return True


_BARE_CALLEES = _install_bare_callees()


def bare_callees() -> bool:
    """Are kernels compiled only for compiled callers compiled without wrappers (module
    docstring)?"""
    return _BARE_CALLEES


def _ours(py_file) -> bool:
    """Is this source file part of the package?"""
    try:
        return os.path.commonpath([os.path.realpath(py_file), str(PACKAGE_DIR)]) == str(PACKAGE_DIR)
    except ValueError:
        return False


def _keyed_locator(base):
    """numba's cache locator ``base``, for the package's kernels only, with the engine's
    fingerprint added to the key of every cached kernel (module docstring)."""

    class EngineKeyed(base):
        def get_source_stamp(self):
            return (super().get_source_stamp(), engine_fingerprint())

        @classmethod
        def from_function(cls, py_func, py_file):
            if not _ours(py_file):
                return None
            return super().from_function(py_func, py_file)

    EngineKeyed.__name__ = EngineKeyed.__qualname__ = f"EngineKeyed{base.__name__}"
    return EngineKeyed


def _install_cache_key() -> bool:
    def find(name):  # numba < 0.62 names them with a leading underscore
        return getattr(_caching, name, None) or getattr(_caching, "_" + name, None)

    impl = find("CacheImpl")
    bases = [find("UserProvidedCacheLocator"), find("InTreeCacheLocator")]
    if impl is None or not isinstance(getattr(impl, "_locator_classes", None), list) or None in bases:
        return False
    if any(getattr(c, "__name__", "").startswith("EngineKeyed") for c in impl._locator_classes):
        return True  # installed already (the module was reloaded)
    impl._locator_classes[:0] = [_keyed_locator(b) for b in bases]
    return True


_CACHE_KEYED = _install_cache_key()

# what reading back an index written by another engine can raise (a type it names has moved
# or gone, a module renamed, a truncated file)
_STALE_INDEX_ERRORS = (AttributeError, ImportError, EOFError, pickle.UnpicklingError, TypeError, ValueError)


def _install_stale_index_guard() -> bool:
    """numba's cache index reader, with an index that cannot be read back taken as empty
    (a miss: the kernel compiles and the index is rewritten) instead of an error."""
    cls = getattr(_caching, "IndexDataCacheFile", None) or getattr(_caching, "_IndexDataCacheFile", None)
    read = getattr(cls, "_load_index", None)
    if read is None:
        return False
    if getattr(read, "guards_stale_index", False):
        return True  # installed already (the module was reloaded)

    def _load_index(self):
        try:
            return read(self)
        except _STALE_INDEX_ERRORS:
            return {}

    _load_index.guards_stale_index = True
    cls._load_index = _load_index
    return True


_STALE_GUARDED = _install_stale_index_guard()


def _install_unliteral_calls() -> bool:
    """numba's typing of a call from compiled code to a dispatcher, with the argument types
    of the package's kernels made non-literal (``types.unliteral``) before it compiles a
    specialisation (module docstring)."""
    from numba.core import dispatcher as _dispatcher
    from numba.core import types as _types

    base = getattr(_dispatcher, "_DispatcherBase", None)
    template = getattr(base, "get_call_template", None)
    if template is None or not {"fold_argument_types", "compile"} <= _names(base, "get_call_template"):
        return False
    if getattr(template, "unliterals_ours", False):
        return True  # installed already (the module was reloaded)

    def get_call_template(self, args, kws):
        if getattr(self.py_func, "__module__", "").partition(".")[0] == _PACKAGE:
            args = tuple(_types.unliteral(a) for a in args)
            kws = {k: _types.unliteral(v) for k, v in kws.items()}
        return template(self, args, kws)

    get_call_template.unliterals_ours = True
    get_call_template.__doc__ = template.__doc__
    base.get_call_template = get_call_template
    return True


_UNLITERAL = _install_unliteral_calls()


def unliteral_calls() -> bool:
    """Do the package's kernels compile one specialisation for a call from compiled code
    whatever constants it passes (module docstring)?"""
    return _UNLITERAL


def cache_keyed() -> bool:
    """Are the package's cached kernels keyed to every engine source (module docstring)?"""
    return _CACHE_KEYED


def _holds_references(ty) -> bool:
    """Does a value of this numba type hold reference-counted memory (an array, a bundle
    of them, a list, a string)?"""
    from numba.core import types

    if isinstance(ty, types.BaseTuple):
        return any(_holds_references(t) for t in ty.types)
    if isinstance(ty, types.Optional):
        return _holds_references(ty.type)
    return isinstance(ty, (types.Array, types.List, types.ListType, types.DictType, types.UnicodeType))


def borrowing_problems() -> list:
    """The package's kernels compiled in this process without reference counts
    (``_nrt=False``, module docstring) that return reference-counted values or take them
    from a call (each a line; empty: none).  A kernel loaded from the cache is not seen
    (its callees were linked into it): run it after a cold compile."""
    import sys

    from numba.core import types
    from numba.core.registry import CPUDispatcher

    problems = []
    for name, module in list(sys.modules.items()):
        if name.partition(".")[0] != _PACKAGE:
            continue
        for attr, disp in list(vars(module).items()):
            if not isinstance(disp, CPUDispatcher) or disp.py_func.__module__ != name:
                continue
            for cres in list(disp.overloads.values()):
                if cres.target_context.enable_nrt:
                    continue
                where = f"{name}.{attr}"
                if _holds_references(cres.signature.return_type):
                    problems.append(f"{where} returns {cres.signature.return_type}")
                typemap = cres.fndesc.typemap or {}
                for expr, sig in (cres.fndesc.calltypes or {}).items():
                    if getattr(expr, "op", None) != "call" or sig is None or not _holds_references(sig.return_type):
                        continue
                    if isinstance(typemap.get(getattr(expr.func, "name", None)), types.NamedTupleClass):
                        continue  # a bundle of the arrays it is given (views of borrowed arrays: borrowed)
                    problems.append(f"{where} takes {sig.return_type} from a call ({expr.loc.short()})")
    return problems
