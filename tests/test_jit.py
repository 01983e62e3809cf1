"""The compile policy (ballchain.jit): nested compiles under a kernel of the package get
numba's cheap pipeline, the kernel called from Python and ``entry`` kernels the full one;
numbers are unchanged (every physics test runs with the policy in force)."""

import collections
import os
import shutil
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from ballchain import jit


def _chain(module, entry_middle=False):
    def leaf(x):
        return np.sqrt(x) + 1.0

    leaf.__module__ = module
    leaf.__qualname__ = f"{module.replace('.', '_')}_leaf_{entry_middle}"
    leaf_j = jit.njit(leaf)

    def middle(x):
        return 2.0 * leaf_j(x)

    middle.__module__ = module
    middle.__qualname__ = f"{module.replace('.', '_')}_middle_{entry_middle}"
    middle_j = jit.njit(middle)
    if entry_middle:
        jit.entry(middle_j)

    def outer(a):
        s = 0.0
        for v in a:
            s += middle_j(v)
        return s

    outer.__module__ = module
    outer.__qualname__ = f"{module.replace('.', '_')}_outer_{entry_middle}"
    return leaf.__qualname__, middle.__qualname__, jit.njit(outer)


needs_policy = pytest.mark.skipif(
    not jit.policy_active(),
    reason="numba's private method changed shape: the policy is not installed (numba compiles as it always does)",
)


@needs_policy
def test_nested_compiles_of_package_kernels_are_cheap():
    leaf, middle, outer = _chain("ballchain._probe")
    a = np.array([1.0, 4.0, 9.0])
    assert outer(a) == pytest.approx(2.0 * (2.0 + 3.0 + 4.0), rel=1e-15)
    cheap = jit.cheap_libraries()
    assert leaf in cheap and middle in cheap
    assert outer.py_func.__qualname__ not in cheap  # called from Python: full pipeline


@needs_policy
def test_entry_kernels_and_foreign_code_get_the_full_pipeline():
    leaf, middle, outer = _chain("ballchain._probe", entry_middle=True)
    assert outer(np.array([4.0])) == pytest.approx(6.0, rel=1e-15)
    cheap = jit.cheap_libraries()
    assert leaf in cheap and middle not in cheap
    # a call chain outside the package is compiled as numba always does
    leaf2, middle2, outer2 = _chain("someone_else")
    assert outer2(np.array([4.0])) == pytest.approx(6.0, rel=1e-15)
    cheap = jit.cheap_libraries()
    assert leaf2 not in cheap and middle2 not in cheap
    assert jit.nested_depth() == 0


def test_policy_can_be_switched_off():
    env = dict(os.environ, BALLCHAIN_OPTIMIZE_CALLEES="1")
    out = subprocess.run(
        [sys.executable, "-c", "from ballchain import jit; print(jit.policy_active())"],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    assert out.stdout.strip() == "False"


@needs_policy
def test_cheap_libraries_link_nothing_and_the_outer_one_everything():
    leaf, middle, outer = _chain("ballchain._probe_link")
    assert outer(np.array([1.0, 4.0])) == pytest.approx(2.0 * (2.0 + 3.0), rel=1e-15)
    (outer_cres,) = outer.overloads.values()
    middle_lib = next(lib for lib in outer_cres.library._linking_libraries if lib.name == middle)
    leaf_fn = next(fn.name for fn in middle_lib._final_module.functions if leaf in fn.name)
    # the cheap library only declares its callee (resolved in the JIT engine) ...
    assert middle_lib._final_module.get_function(leaf_fn).is_declaration
    # ... while the module whose machine code runs holds every kernel it calls
    assert not any(
        fn.is_declaration and ("_probe_link" in fn.name) for fn in outer_cres.library._final_module.functions
    )


PROBE_MODULE = """
import numpy as np
from ballchain.jit import njit

_ours = njit(cache=True)

@_ours
def leaf(x):
    return np.sqrt(x) + 1.0

@_ours
def middle(x):
    return 2.0 * leaf(x)

@_ours
def outer(a):
    s = 0.0
    for v in a:
        s += middle(v)
    return s
"""


@needs_policy
def test_cheap_libraries_are_not_cached_and_compile_when_called_later(tmp_path):
    """A cheap library calls its callees through the JIT engine, so loaded alone from the
    cache it could not run: only self-contained libraries are cached."""
    (tmp_path / "probe_cache_mod.py").write_text(PROBE_MODULE)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(tmp_path))

    def run(code):
        # the policy counts this module's kernels as the package's own
        head = "from ballchain import jit; jit._PACKAGE = 'probe_cache_mod'\nimport numpy as np, probe_cache_mod as m\n"
        return subprocess.run(
            [sys.executable, "-c", head + code], env=env, capture_output=True, text=True, check=True, cwd=tmp_path
        ).stdout

    assert float(run("print(m.outer(np.array([1.0, 4.0, 9.0])))")) == pytest.approx(18.0, rel=1e-15)
    cached = sorted(p.name.split("-")[0] for p in (tmp_path / "cache").rglob("*.nbc"))
    assert cached == ["probe_cache_mod.outer"]
    # a later process calls the cheap kernels on their own, then the cached outer one
    out = run("print(m.middle(4.0), m.leaf(9.0), m.outer(np.array([4.0])))").split()
    assert [float(v) for v in out] == pytest.approx([6.0, 4.0, 6.0], rel=1e-15)
    cached = sorted(p.name.split("-")[0] for p in (tmp_path / "cache").rglob("*.nbc"))
    # middle was compiled as called from Python (self-contained, cached); leaf, compiled
    # under it, is cheap again and not cached, but where such callees are compiled without
    # wrappers (``jit.bare_callees``) the call of leaf from Python compiles it afresh, in
    # full: self-contained, cached
    expected = ["probe_cache_mod.middle", "probe_cache_mod.outer"]
    if jit.bare_callees():
        expected = ["probe_cache_mod.leaf", *expected]
    assert cached == expected


def test_the_policy_and_the_cache_key_are_in_force():
    """On the numba versions pyproject.toml admits, both wrappers of numba's private methods
    install: if a numba release changes their shape, this fails loudly instead of the
    package silently compiling slower or caching stale code."""
    if os.environ.get("BALLCHAIN_OPTIMIZE_CALLEES", "") in ("", "0"):
        assert jit.policy_active()
    assert jit.cache_keyed()
    from ballchain.core.impacts import hinge_gaps

    locator = hinge_gaps._cache._impl.locator
    assert type(locator).__name__.startswith("EngineKeyed")
    from ballchain.provenance import engine_fingerprint

    assert locator.get_source_stamp()[1] == engine_fingerprint()


EDIT_PROBE = """
import numpy as np
from ballchain.core.impacts import hinge_gaps
e = np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8]])
out = np.zeros(1)
hinge_gaps(e, 0.5, out)
print(repr(float(out[0])))
"""


def test_an_edited_callee_recompiles_its_callers(tmp_path):
    """``impacts.hinge_gaps`` (cached next to impacts.py) calls ``rules.unit_hinge_gap``
    (another file): after an edit of the callee alone, the next process must run the
    edited code, not the cached machine code of the old one."""
    shutil.copytree(
        Path(jit.__file__).resolve().parent, tmp_path / "ballchain", ignore=shutil.ignore_patterns("__pycache__")
    )
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    env.pop("NUMBA_CACHE_DIR", None)

    def run():
        out = subprocess.run(
            [sys.executable, "-c", EDIT_PROBE], env=env, capture_output=True, text=True, check=True, cwd=tmp_path
        )
        return float(out.stdout.strip())

    assert run() == pytest.approx(0.8 - 0.5, abs=1e-15)  # compiles and caches
    assert list((tmp_path / "ballchain" / "core" / "__pycache__").glob("impacts.hinge_gaps*.nbi"))
    rules = tmp_path / "ballchain" / "core" / "rules.py"
    text = rules.read_text()
    old = "e[k, 0] * e[k + 1, 0] + e[k, 1] * e[k + 1, 1] + e[k, 2] * e[k + 1, 2] - cos_alpha"
    assert text.count(old) == 1
    rules.write_text(text.replace(old, old + " - 1.0"))
    assert run() == pytest.approx(0.8 - 0.5 - 1.0, abs=1e-15)


def test_an_index_naming_a_type_that_has_gone_is_a_miss_not_an_error(tmp_path, monkeypatch):
    """An older engine's cache index can name a type that has since moved (a bundle moved
    from one module to another): reading it back must give an empty index, so the kernel
    compiles again, rather than stop the run with an AttributeError."""
    import pickle
    import types

    from numba.core import caching

    import ballchain.jit  # noqa: F401  (installs the guard)

    mod = types.ModuleType("ballchain_gone_module")
    monkeypatch.setitem(sys.modules, mod.__name__, mod)

    class Gone:
        pass

    Gone.__module__, Gone.__qualname__ = mod.__name__, "Gone"
    mod.Gone = Gone
    cache = caching.IndexDataCacheFile(str(tmp_path), "kernel", "stamp")
    cache._save_index({("sig", Gone): "kernel.1.nbc"})
    assert cache._load_index() == {("sig", Gone): "kernel.1.nbc"}  # readable while the type exists
    del mod.Gone
    with open(cache._index_path, "rb") as f:  # numba's own reader stops on it
        pickle.load(f)
        with pytest.raises(AttributeError):
            pickle.loads(f.read())
    assert cache._load_index() == {}


def _constant_caller(module):
    """A package kernel that calls another with two different constants, and the callee."""

    def scale(x, twice):
        return 2.0 * x if twice else x

    scale.__module__ = module
    scale.__qualname__ = f"{module.replace('.', '_')}_scale"
    scale_j = jit.njit(scale)

    def both(x):
        return scale_j(x, True) + scale_j(x, False)

    both.__module__ = module
    both.__qualname__ = f"{module.replace('.', '_')}_both"
    return jit.njit(both), scale_j


def test_a_kernel_called_with_constants_compiles_once_and_computes_the_same():
    """numba compiles a callee once per literal constant a compiled caller passes it
    (``Literal[bool](True)``, then ``(False)``): the package's kernels take the plain type
    instead, one specialisation, each branch taken at run time as the constant says.
    Code outside the package keeps numba's behaviour (two specialisations)."""
    assert jit.unliteral_calls()
    ours, scale = _constant_caller("ballchain.tests_probe")
    assert ours(1.5) == 4.5  # 2 * 1.5 + 1.5
    assert len(scale.signatures) == 1
    assert "Literal" not in str(scale.signatures[0])
    theirs, other = _constant_caller("someone_else")
    assert theirs(1.5) == 4.5
    assert len(other.signatures) == 2


def _wrapped(dispatcher) -> list:
    """Is each specialisation of the dispatcher compiled with numba's Python wrapper?"""
    return [
        cres.library.get_pointer_to_function(cres.fndesc.llvm_cpython_wrapper_name) != 0
        for cres in dispatcher.overloads.values()
    ]


def _callee(caller, qualname):
    """The kernel ``caller`` calls under that name (a cell of its closure)."""
    return next(c.cell_contents for c in caller.py_func.__closure__ if c.cell_contents.py_func.__qualname__ == qualname)


@needs_policy
def test_callees_compile_bare_and_python_calls_compile_them_in_full():
    """A kernel compiled only for a compiled caller of the package has no wrappers (the
    Python one unboxes every array of every bundle it takes: a third of a cold compile);
    a call from Python with its types compiles it again with them, and computes the same.
    Entries, foreign code and the kernel called from Python keep theirs."""
    assert jit.bare_callees()
    leaf, middle, outer = _chain("ballchain._probe_bare")
    assert outer(np.array([1.0, 4.0])) == pytest.approx(2.0 * (2.0 + 3.0), rel=1e-15)
    middle_j = _callee(outer, middle)
    leaf_j = _callee(middle_j, leaf)
    assert _wrapped(outer) == [True]
    assert _wrapped(middle_j) == [False] and _wrapped(leaf_j) == [False]
    # ... and no machine code of their own in the JIT engine: the outer kernel's runs
    for bare in (middle_j, leaf_j):
        assert [getattr(c.library, "_ballchain_unemitted", False) for c in bare.overloads.values()] == [True]
    assert not getattr(next(iter(outer.overloads.values())).library, "_ballchain_unemitted", False)
    # called from Python with the same types: compiled afresh, in full, wrappers included
    assert middle_j(4.0) == 6.0 and leaf_j(9.0) == 4.0
    assert _wrapped(middle_j) == [True] and _wrapped(leaf_j) == [True]
    assert len(middle_j.signatures) == 1 and len(leaf_j.signatures) == 1
    assert outer(np.array([4.0])) == 6.0
    # an entry kernel keeps its wrappers wherever it is compiled, and so does code outside the package
    leaf2, middle2, outer2 = _chain("ballchain._probe_bare", entry_middle=True)
    assert outer2(np.array([4.0])) == 6.0
    assert _wrapped(_callee(outer2, middle2)) == [True]
    leaf3, middle3, outer3 = _chain("someone_else_bare")
    assert outer3(np.array([4.0])) == 6.0
    assert _wrapped(_callee(outer3, middle3)) == [True]


def test_kernels_without_reference_counts_that_return_or_take_arrays_are_listed(monkeypatch):
    """A kernel compiled with ``_nrt=False`` borrows its arrays: one that returns an array,
    or takes one from a call (a view its callee made), would leave a reference count wrong
    (``jit.borrowing_problems``)."""

    def same(a):
        return a

    def view(a):
        return a[:2]

    def total(a):
        s = 0.0
        for v in view_j(a):
            s += v
        return s + same_j(a)[0]

    def fine(a):
        return a[0] + 1.0

    def first(pair):
        return pair.head[0] + pair.tail[0]

    def bundled(a):  # a bundle of views of the arrays it borrows: borrowed too
        return first_j(Pair(a[:1], a[1:]))

    Pair = collections.namedtuple("Pair", ["head", "tail"])
    probe = types.ModuleType("ballchain._probe_borrow")  # (the checker reads the kernels of the modules)
    for f in (same, view, total, fine, first, bundled):
        f.__module__ = probe.__name__
    same_j = probe.same = jit.njit(_nrt=False)(same)
    view_j = probe.view = jit.njit(_nrt=True)(view)
    total_j = probe.total = jit.njit(_nrt=False)(total)
    fine_j = probe.fine = jit.njit(_nrt=False)(fine)
    first_j = probe.first = jit.njit(_nrt=False)(first)
    bundled_j = probe.bundled = jit.njit(_nrt=False)(bundled)
    monkeypatch.setitem(sys.modules, probe.__name__, probe)
    a = np.array([1.0, 2.0, 3.0])
    assert total_j(a) == 4.0 and fine_j(a) == 2.0 and bundled_j(a) == 3.0
    problems = [p for p in jit.borrowing_problems() if "_probe_borrow" in p]
    assert any(p.startswith("ballchain._probe_borrow.same returns") for p in problems)
    assert sum(p.startswith("ballchain._probe_borrow.total takes") for p in problems) == 2
    assert not any(".fine " in p or ".view " in p or ".bundled " in p or ".first " in p for p in problems)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["event", "timestep", "rattle"])
def test_kernels_without_reference_counts_borrow_only(tmp_path, method):
    """Each method's kernels compiled with ``_nrt=False`` (and the core's) neither return
    arrays nor take them from calls (a cold compile in a fresh process, its own cache)."""
    code = (
        f"from ballchain import engine, jit; engine.load_kernels({method!r}); "
        "p = jit.borrowing_problems(); print('\\n'.join(p) or 'none')"
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "none", out.stdout
