"""The tension along the chain (``Result.frame_tension``), against independent truths:
statics (a straight chain standing on its foot carries the weight above each point),
Newton's second law for the part of the chain above each point (its momentum, from the
frames' kinematics alone), and the time-steppers' convergence to the exact method's."""

from __future__ import annotations

import numpy as np
import pytest

from ballchain import api

N = 8


def _standing(n):
    """A straight vertical chain at rest on its anchored foot (an equilibrium)."""
    e = np.zeros((n, 3))
    e[:, 2] = 1.0
    return e


@pytest.mark.parametrize("method", ["event", "timestep", "rattle"])
def test_a_standing_chain_carries_the_weight_above_each_point(method):
    """Point j of a straight chain standing at rest has j segments above it: it is
    compressed by their weight, T_j = -j m g, the free top carries nothing."""
    n = 6
    kw = {} if method == "event" else {"dt": 0.01}
    r = api.simulate(initial=_standing(n), alpha="pi", method=method, until=0.05, frames_per_tff=400, **kw)
    assert r.frame_tension.shape == (len(r.frame_t), n + 1)
    # (a time-stepper's tension is its last step's mean: none before the first step)
    first = 0 if method == "event" else 1
    np.testing.assert_allclose(
        r.frame_tension[first:], np.tile(-np.arange(n + 1.0), (len(r.frame_t) - first, 1)), atol=1e-9
    )


def _momentum_above(r):
    """P[:, j - 1] = the momentum of segments 0..j-1 (m = 1) at every frame, from the
    axes and rates alone (point N held at the origin: the anchor)."""
    e, w = r.frame_e, r.frame_omega
    de = np.cross(w, e)
    n = e.shape[1]
    vp = np.zeros((len(r.frame_t), n + 1, 3))  # the points' velocities
    for j in range(n - 1, -1, -1):
        vp[:, j] = vp[:, j + 1] + 2.0 * de[:, j]
    vc = vp[:, 1:] + de  # centre i = point i + 1 + e_i
    return np.cumsum(vc, axis=1)


def test_the_tension_is_the_force_that_moves_the_chain_above():
    """d/dt P_above(j) = F_j - j m g e_z for the segments above point j, F_j the force
    on them at j; so T_j = -(dP/dt + j e_z) . e_{j-1}, with dP/dt from the frames'
    velocities (a five-point difference, away from events).  The exact method at
    rtol 1e-12: the difference is the dense output's error (2e-6 at rtol 1e-10, 3.5e-8
    at 1e-12, measured), against tensions of up to 8 m g."""
    r = api.simulate(segments=N, alpha="45deg", ic="random", seed=3, until=0.6, frames_per_tff=4000, rtol=1e-12)
    assert r.status == "until" and len(r.event_t) > 5  # (locks and landings in the window)
    P = _momentum_above(r)
    t = r.frame_t
    dt = t[1] - t[0]
    dP = (-P[4:] + 8.0 * P[3:-1] - 8.0 * P[1:-3] + P[:-4]) / (12.0 * dt)
    k = np.arange(2, len(t) - 2)
    smooth = np.ones(len(k), bool)  # no event within the stencil
    for te in r.event_t:
        smooth &= ~((t[k - 2] <= te) & (te <= t[k + 2]))
    assert smooth.sum() > 0.9 * len(k)
    force = dP.copy()
    force[:, :, 2] += np.arange(1, N + 1)  # + the weight of the j segments above point j
    expected = -np.einsum("kjq,kjq->kj", force, r.frame_e[k])
    got = r.frame_tension[k][:, 1:]
    err = np.abs(expected - got)[smooth]
    assert np.abs(got).max() > 5.0  # (the check has something to check)
    assert err.max() < 2e-7 and np.median(err) < 1e-8
    assert np.all(r.frame_tension[:, 0] == 0.0)  # the free top


@pytest.mark.parametrize("method", ["timestep", "rattle"])
def test_a_time_steppers_tension_converges_to_the_exact_methods(method):
    """A time-stepper's tension is its step's mean: first order in the step.  With free
    hinges (no lock) on the first half of the fall, halving the step halves its largest
    difference from the exact method's (measured: 0.47, 0.23, 0.12 m g for the
    time-stepper at dt 0.02, 0.01, 0.005; RATTLE 0.12, 0.058, 0.029)."""
    kw = dict(segments=N, alpha="pi", ic="random", seed=3, until=0.5, frames_per_tff=100)
    exact = api.simulate(**kw, rtol=1e-12)
    assert len(exact.event_t) == 0
    errs = []
    for dt in (0.02, 0.01):
        r = api.simulate(**kw, method=method, dt=dt)
        n = min(len(r.frame_t), len(exact.frame_t))
        np.testing.assert_allclose(r.frame_t[:n], exact.frame_t[:n], rtol=1e-12)
        errs.append(np.abs(r.frame_tension[1:n] - exact.frame_tension[1:n]).max())
    assert 1.8 < errs[0] / errs[1] < 2.2
    assert errs[1] < 0.3


def test_the_top_of_a_falling_rod_accelerates_as_the_pendulum_says():
    """A rod (length 2b) pivoting on its anchored foot from theta0 = 0.3 rad: from its
    energy, theta'^2 = (3 g / 2 b)(cos theta0 - cos theta), and its equation,
    theta'' = (3 g / 4 b) sin theta, its top (at 2 b (sin theta, cos theta)) accelerates
    at a_z / g = -(3/2) sin^2 theta - 3 (cos theta0 - cos theta) cos theta: beyond -1,
    faster than free fall, once theta passes about 0.98 rad.  ``measures.top_acceleration``
    (centred differences of the frames' velocities) against it, and the tension of the
    free top 0."""
    from ballchain.records.measures import top_acceleration

    th0 = 0.3
    r = api.simulate(initial=[[np.sin(th0), 0.0, np.cos(th0)]], rtol=1e-12, frames_per_tff=2000, until=1.4)
    a = top_acceleration(r)[1:-1]
    cos = r.frame_e[1:-1, 0, 2]
    sin2 = 1.0 - cos**2
    expected = -1.5 * sin2 - 3.0 * (np.cos(th0) - cos) * cos
    assert expected.min() < -1.4  # (the top passes free fall)
    np.testing.assert_allclose(a[:, 2], expected, atol=1e-5)  # (measured: 2.3e-6, the differences' error)
    assert np.all(r.frame_tension[:, 0] == 0.0)


def test_the_pull_on_a_pivoting_rods_foot():
    """A rod pivoting on its held foot: the foot's force F = M a_cm + M g e_z, whose part
    along the rod, with a_cm . e = -b theta'^2 and b theta'^2 = (3 g / 2)(cos theta0 -
    cos theta), gives the tension there T = m g (3/2 cos theta0 - 5/2 cos theta): the
    rod pushes on its foot early and pulls on it once cos theta < 3/5 cos theta0.
    ``measures.pile_tension`` (at the first held point, the foot) against it."""
    from ballchain.records.measures import pile_point, pile_tension

    th0 = 0.3
    r = api.simulate(initial=[[np.sin(th0), 0.0, np.cos(th0)]], rtol=1e-12, frames_per_tff=500, until=1.4)
    assert np.all(pile_point(r) == 1)
    cos = r.frame_e[:, 0, 2]
    expected = 1.5 * np.cos(th0) - 2.5 * cos
    assert expected.min() < -0.9 and expected.max() > 0.5  # (it pushes, then pulls)
    np.testing.assert_allclose(pile_tension(r), expected, atol=1e-10)  # (measured: 2.9e-12)
