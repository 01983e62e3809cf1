"""Where the chain is on a frictionless floor (``core.base``): its bottom end's position and
velocity from the centre of mass's uniform motion along the floor and the point the floor
holds.  Checked by a conservation law the relative energies do not obey: a chain sliding
on its bottom end, and one in flight, integrated from the core's equations of motion by
scipy, keep U + T to the integrator's tolerance, where the energy measured with point N at
rest drifts by O(1)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ballchain.core.base import base_point, energy_on_floor, new_base, set_base
from ballchain.core.books import mechanical_energy
from ballchain.core.dynamics import accelerations
from ballchain.core.rules import SLIDING
from ballchain.core.state import new_work


def _fall(n, anchored, seed, t_end):
    rng = np.random.default_rng(seed)
    e = rng.normal(size=(n, 3))
    e[:, 2] = np.abs(e[:, 2]) + 0.5
    e /= np.linalg.norm(e, axis=1)[:, None]
    w = rng.normal(size=(n, 3))
    w -= np.sum(w * e, axis=1)[:, None] * e  # (rates perpendicular to the axes)
    ws = new_work(n)
    locked = np.zeros(max(n - 1, 0), np.uint8)
    de, dw = np.zeros((n, 3)), np.zeros((n, 3))

    def rhs(t, y):
        ee, ww = y[: 3 * n].reshape(n, 3), y[3 * n :].reshape(n, 3)
        accelerations(np.ascontiguousarray(ee), np.ascontiguousarray(ww), anchored, locked, ws, de, dw)
        return np.concatenate([np.cross(ww, ee).ravel(), dw.ravel()])

    sol = solve_ivp(
        rhs, (0.0, t_end), np.concatenate([e.ravel(), w.ravel()]), rtol=1e-11, atol=1e-12, dense_output=True
    )
    return rng, sol


@pytest.mark.parametrize("n, seed", [(1, 1), (4, 2), (7, 3)])
def test_a_chain_sliding_on_its_bottom_end_keeps_its_energy_and_its_centres_line(n, seed):
    anchored = np.zeros(n + 1, np.uint8)
    anchored[n] = SLIDING
    rng, sol = _fall(n, anchored, seed, 0.6)
    base = new_base()
    pts, pv, vel, pu = np.zeros((n + 1, 3)), np.zeros((n + 1, 3)), np.zeros((n, 3)), np.zeros((2, 3))
    y0 = sol.sol(0.0)
    e0, w0 = y0[: 3 * n].reshape(n, 3), y0[3 * n :].reshape(n, 3)
    drift = rng.normal(size=3)
    set_base(e0, w0, anchored, base, 0.0, pts, pv, vel, np.array([0.3, -0.2, 0.0]), np.array([drift[0], drift[1], 0.0]))
    energies, rel = [], []
    for t in np.linspace(0.0, 0.6, 13):
        y = sol.sol(t)
        e, w = y[: 3 * n].reshape(n, 3).copy(), y[3 * n :].reshape(n, 3).copy()
        assert base_point(e, w, anchored, base, t, pts, pv, vel, pu) == n
        energies.append(energy_on_floor(e, w, anchored, base, t, pts, pv, vel))
        rel.append(mechanical_energy(e, w, pv, vel))
        point_positions = pts + pu[0]
        assert point_positions[n, 2] == 0.0 and pu[1, 2] == pytest.approx(0.0, abs=1e-14)
        cm = np.mean(0.5 * (point_positions[:-1] + point_positions[1:]), axis=0)
        np.testing.assert_allclose(cm[:2], base.cm0[:2] + base.vcm0[:2] * t, atol=1e-12)
    assert np.ptp(energies) < 1e-8 * max(1.0, abs(energies[0]))
    assert np.ptp(rel) > 1e-3  # (measured with point N at rest it is not kept: the check can fail)


@pytest.mark.parametrize("n, seed", [(1, 4), (5, 5)])
def test_a_chain_in_flight_keeps_its_energy_and_its_centre_of_mass_falls_freely(n, seed):
    anchored = np.zeros(n + 1, np.uint8)
    rng, sol = _fall(n, anchored, seed, 0.8)
    base = new_base()
    pts, pv, vel, pu = np.zeros((n + 1, 3)), np.zeros((n + 1, 3)), np.zeros((n, 3)), np.zeros((2, 3))
    y0 = sol.sol(0.0)
    p0, u0 = rng.normal(size=3), rng.normal(size=3)
    set_base(y0[: 3 * n].reshape(n, 3), y0[3 * n :].reshape(n, 3), anchored, base, 0.0, pts, pv, vel, p0, u0)
    energies = []
    for t in np.linspace(0.0, 0.8, 9):
        y = sol.sol(t)
        e, w = y[: 3 * n].reshape(n, 3).copy(), y[3 * n :].reshape(n, 3).copy()
        assert base_point(e, w, anchored, base, t, pts, pv, vel, pu) == -1
        energies.append(energy_on_floor(e, w, anchored, base, t, pts, pv, vel))
        cm = np.mean(0.5 * (pts[:-1] + pts[1:]) + pu[0], axis=0)
        np.testing.assert_allclose(cm, base.cm0 + base.vcm0 * t - [0.0, 0.0, 0.5 * t * t], atol=1e-12)
    assert np.ptp(energies) < 1e-8 * max(1.0, abs(energies[0]))
    assert math.isfinite(energies[-1])
