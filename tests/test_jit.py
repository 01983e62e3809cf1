"""The compile policy (ballchain.jit): nested compiles under a kernel of the package get
numba's cheap pipeline, the kernel called from Python and ``entry`` kernels the full one;
numbers are unchanged (every physics test runs with the policy in force)."""

import os
import subprocess
import sys

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


needs_policy = pytest.mark.skipif(not jit.policy_active(), reason="numba's private method changed shape: "
                                  "the policy is not installed (numba compiles as it always does)")


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
    out = subprocess.run([sys.executable, "-c", "from ballchain import jit; print(jit.policy_active())"],
                         env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
