"""Initial-condition families: ``eps`` is the largest horizontal tilt |e_xy| / e_z of
any segment, in every family (docs/model.md, section 5)."""

import numpy as np
import pytest

from ballchain.initial import initial_directions
from ballchain.model import InitialCondition


@pytest.mark.parametrize("kind", ["helix", "planar", "random"])
@pytest.mark.parametrize("n, eps, seed", [(16, 0.02, 0), (128, 0.05, 3), (7, 0.2, 11)])
def test_eps_is_the_largest_tilt(kind, n, eps, seed):
    e = initial_directions(InitialCondition(kind=kind, eps=eps, seed=seed), n, np.pi / 4)
    np.testing.assert_allclose(np.linalg.norm(e, axis=1), 1.0, rtol=1e-14)
    tilt = np.hypot(e[:, 0], e[:, 1]) / e[:, 2]
    assert tilt.max() == pytest.approx(eps, rel=1e-12)


def test_random_family_is_seeded_and_not_a_helix():
    a = initial_directions(InitialCondition(kind="random", eps=0.05, seed=1), 64, np.pi / 4)
    b = initial_directions(InitialCondition(kind="random", eps=0.05, seed=1), 64, np.pi / 4)
    c = initial_directions(InitialCondition(kind="random", eps=0.05, seed=2), 64, np.pi / 4)
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - c).max() > 1e-3
    tilt = np.hypot(a[:, 0], a[:, 1]) / a[:, 2]
    assert tilt.min() < 0.9 * tilt.max()  # tilts vary along the chain
