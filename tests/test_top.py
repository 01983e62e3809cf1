"""The invariants of an airborne top end spinning on its anchored point
(``measures.top_invariants``), against rigid rotations whose angular momentum and energy
are known independently: a rod's closed form, and a quadrature over point masses.  Then
a top taken from a fall (``tests/data/top3-state.txt``: three segments locked at their
limits, spinning on the chain's lower end): the exact method keeps its two invariants,
and the time-stepper's loss of its energy, the method's error, shrinks with dt."""

import math
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ballchain.engine import simulate
from ballchain.model import ChainParams, SolverOptions
from ballchain.records.measures import top_invariants

TOP3 = Path(__file__).parent / "data" / "top3-state.txt"


def _unit(theta, phi):
    return np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])


def _rigid_spin(axes, omega, frames=5, m=1.0, b=1.0, g=1.0):
    """A run whose top end (the given airborne axes, top first) turns rigidly at omega
    about the vertical through its anchored pivot, the rest of a 6-segment chain landed
    flat; one event at t = 0, frames after it.  Each segment's angular velocity is the
    part of omega z normal to its axis (the model keeps w_i . e_i = 0; the axial part
    moves nothing)."""
    k, n = len(axes), 6
    zhat = np.array([0.0, 0.0, 1.0])
    e = np.array(list(axes) + [[1.0, 0.0, 0.0]] * (n - k))
    w = np.array([omega * (zhat - ei[2] * ei) for ei in axes] + [[0.0, 0.0, 0.0]] * (n - k))
    anchored = np.array([0] * k + [1] * (n + 1 - k), dtype=bool)
    ft = np.linspace(0.1, 0.5, frames)
    return SimpleNamespace(
        params=SimpleNamespace(segment_mass=m, half_length=b, gravity=g),
        frame_t=ft,
        event_t=np.array([0.0]),
        frame_e=np.repeat(e[None], frames, axis=0),
        frame_omega=np.repeat(w[None], frames, axis=0),
        frame_anchored=np.repeat(anchored[None], frames, axis=0),
    )


def test_a_rod_spinning_on_its_pivot():
    """One rod of length 2b tilted theta from the vertical, turning at Omega about it:
    L_z = (4/3) m b^2 sin^2(theta) Omega, T = L_z Omega / 2, U = m g b cos(theta)."""
    m, b, g, theta, om = 1.7, 0.6, 2.0, 0.7, 3.1
    r = _rigid_spin([_unit(theta, 0.4)], om, m=m, b=b, g=g)
    ti = top_invariants(r)
    lz = 4.0 / 3.0 * m * b * b * math.sin(theta) ** 2 * om
    assert ti.segments == 1 and ti.pivot == 1
    np.testing.assert_allclose(ti.angular_momentum_z, lz, rtol=1e-12)
    np.testing.assert_allclose(ti.kinetic, 0.5 * lz * om, rtol=1e-12)
    np.testing.assert_allclose(ti.energy, 0.5 * lz * om + m * g * b * math.cos(theta), rtol=1e-12)
    np.testing.assert_allclose(ti.lowest, 2 * b * math.cos(theta), rtol=1e-12)


def test_a_bent_piece_against_point_masses():
    """Three segments at different tilts and azimuths turning rigidly about the vertical:
    L_z and T against the sums over 20000 point masses per rod (midpoint rule: relative
    error about 1e-9)."""
    axes = [_unit(0.3, 2.0), _unit(1.1, -0.5), _unit(0.8, 0.9)]
    m, b, om = 0.8, 1.3, -2.4
    ti = top_invariants(_rigid_spin(axes, om, m=m, b=b))
    q = 20000
    s = (np.arange(q) + 0.5) / q * 2 * b  # along a rod from its lower point
    lz = t = u = 0.0
    low = np.zeros(3)  # the pivot
    for ei in axes[::-1]:  # from the pivot up
        r = low + s[:, None] * ei
        v = om * np.cross([0.0, 0.0, 1.0], r)
        dm = m / q
        lz += dm * np.sum(np.cross(r, v)[:, 2])
        t += 0.5 * dm * np.sum(v * v)
        u += dm * np.sum(r[:, 2])
        low = low + 2 * b * ei
    np.testing.assert_allclose(ti.angular_momentum_z, lz, rtol=1e-8)
    np.testing.assert_allclose(ti.kinetic, t, rtol=1e-8)
    np.testing.assert_allclose(ti.energy, t + u, rtol=1e-8)
    assert ti.segments == 3


def test_not_a_top_end_is_refused():
    r = _rigid_spin([_unit(0.3, 0.0)], 1.0)
    r.frame_anchored = r.frame_anchored.copy()
    r.frame_anchored[:, 0] = True  # the top end itself anchored: nothing hangs on a pivot
    with pytest.raises(ValueError, match="top end"):
        top_invariants(r)
    r = _rigid_spin([_unit(0.3, 0.0)], 1.0)
    r.frame_t = r.frame_t - 1.0  # every frame before the last event
    with pytest.raises(ValueError, match="no frame"):
        top_invariants(r)


def _top3(options):
    s = np.loadtxt(TOP3)
    return simulate(
        ChainParams(segments=3, alpha=math.pi / 4, floor="all"), state=(s[:, :3], s[:, 3:]), options=options
    )


def test_the_exact_method_keeps_a_tops_invariants():
    """Both bends lock at once (the start is 1e-4 rad inside them); then a rigid body on a
    frictionless pivot: no event, T + U and L_z constant, its points off the floor."""
    r = _top3(SolverOptions(max_time=1.0))
    assert r.status == "max_time"
    ti = top_invariants(r)
    assert ti.segments == 3 and ti.t_from < 1e-3 * r.t_ff
    assert np.ptp(ti.energy) < 1e-8 * abs(np.mean(ti.energy))
    assert np.ptp(ti.angular_momentum_z) < 1e-9 * abs(np.mean(ti.angular_momentum_z))
    assert ti.kinetic.min() > 0.99 * ti.kinetic.max()  # it keeps spinning (T about 845 m g b)
    assert ti.lowest.min() > 0.3
    # and the run says what stopped it
    assert "its top end, 3 segments locked at their bend limits, turns on landed point 3" in r.message
    said = float(re.search(r"kinetic energy ([0-9.e+-]+) m g b", r.message).group(1))
    assert said == pytest.approx(ti.kinetic[-1], rel=5e-3)  # its T at the last frame (it varies 0.3%)


def test_a_fall_stopped_early_is_not_called_a_top():
    r = simulate(ChainParams(segments=8, alpha=math.pi / 4, floor="all"), options=SolverOptions(max_time=0.3))
    assert r.status == "max_time" and "top end" not in r.message


def test_the_time_steppers_loss_of_a_top_shrinks_with_dt():
    """The time-stepper (theta = 1) damps the spin: the top's T + U after 0.2 t_ff falls
    short of the start by a loss that shrinks towards first order as dt halves."""
    lost = []
    for dt in (0.001, 0.0005, 0.00025):
        r = _top3(SolverOptions(method="timestep", dt=dt, theta=1.0, max_time=0.2))
        start = r.frame_kinetic[0] + r.frame_potential[0]
        lost.append(1.0 - (r.frame_kinetic[-1] + r.frame_potential[-1]) / start)
    assert all(x > 0 for x in lost)
    assert lost[0] / lost[1] > 1.35 and lost[1] / lost[2] > 1.45


def _top_end_chain(k: int, n: int, locked: list[int], w_top):
    """A chain of n segments whose points k..n are anchored (the segments below k lie flat
    on the floor, at rest) and whose top end, segments 0..k-1, stands upright with the
    rate w_top each; ``locked``: the hinges between the top end's segments that are held."""
    from ballchain.core.state import new_chain

    e = np.tile([1.0, 0.0, 0.0], (n, 1))
    e[:k] = [0.0, 0.0, 1.0]
    w = np.zeros((n, 3))
    w[:k] = w_top
    chain = new_chain(e, w, math.pi / 4)
    chain.anchored[k:] = 1
    chain.locked[: len(locked)] = locked
    return chain


def test_a_run_stopped_at_the_time_cap_names_the_top_end_that_keeps_moving():
    """``stop_status``: a top end of one segment, or of several with free hinges, moving on
    its landed point (which nothing but a lock slows) is named with its kinetic energy; a
    single segment turning about its lower end at |w| perpendicular to its axis has
    T = 1/2 (m b^2/3 + m b^2) |w|^2 = 2/3 |w|^2 m g b (b = m = g = 1); every hinge locked is
    the heavy top; a chain at rest is not a top."""
    from ballchain.methods.outputs import spinning_top_note, stop_status
    from ballchain.model import SolverOptions

    status, message = stop_status(SolverOptions(method="rattle"), _top_end_chain(1, 4, [], [0.0, 1.5, 0.0]))
    assert status == "max_time"
    assert "its top end, 1 segment, moving on landed point 1 (kinetic energy 1.5 m g b;" in message
    assert "1 of the 2 hinges between them locked" in spinning_top_note(_top_end_chain(3, 6, [1, 0], [0.0, 1.0, 0.0]))
    assert "heavy top" in spinning_top_note(_top_end_chain(3, 6, [1, 1], [0.0, 1.0, 0.0]))
    assert spinning_top_note(_top_end_chain(3, 6, [1, 0], [0.0, 0.0, 0.0])) == ""
    assert (
        spinning_top_note(_top_end_chain(3, 6, [1, 0], [0.0, 1.0, 0.0])._replace(anchored=np.zeros(7, np.uint8))) == ""
    )
