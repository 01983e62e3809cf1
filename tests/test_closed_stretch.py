"""A locked stretch closed between two anchors near an extreme of its chord: the geometry
the error message names (``outputs.closed_stretch_note``), checked against chains built
by rotating one axis into the next."""

import math

import numpy as np
import pytest

from ballchain.methods.outputs import closed_stretch_note, stretch_chord_extremes


def _rotate(v, axis, angle):
    """Rodrigues' rotation of v about the unit axis by angle."""
    return v * math.cos(angle) + np.cross(axis, v) * math.sin(angle) + axis * (axis @ v) * (1 - math.cos(angle))


def bent_axes(k, alpha, twists, first=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)):
    """k unit axes, each turned by alpha from the one before about a normal that the
    twist before it turns about that axis (twists: k - 1 angles)."""
    e, n = [np.array(first, float)], np.array(normal, float)
    for phi in twists:
        n = _rotate(n, e[-1], phi)
        e.append(_rotate(e[-1], n, alpha))
    return np.array(e)


def chord(e):
    """The distance between the ends of segments of length 2b along the axes e (b)."""
    return float(np.linalg.norm(2.0 * e.sum(axis=0)))


@pytest.mark.parametrize(
    "k,alpha",
    [(2, math.pi / 4), (3, math.pi / 4), (4, math.pi / 4), (3, math.pi / 3), (6, math.pi / 6)]
    + [(5, math.pi / 4), (7, math.pi / 4), (4, math.pi / 3), (5, math.pi / 3), (3, math.pi / 2)],  # pi < k alpha < 2 pi
)
def test_the_arc_and_the_zigzag_bound_the_chord_of_a_stretch_locked_at_its_limits(k, alpha):
    """No twists: the planar arc, at chord 2 |sin(k alpha/2)|/sin(alpha/2); twists of pi: the
    zigzag (2 k cos(alpha/2) for even k); any other twists lie between them, the arc the
    least while k alpha <= 2 pi (a stretch whose arc turns back on itself included)."""
    arc, zigzag = stretch_chord_extremes(k, alpha)
    e = bent_axes(k, alpha, [0.0] * (k - 1))
    assert np.allclose([e[i] @ e[i + 1] for i in range(k - 1)], math.cos(alpha))
    assert chord(e) == pytest.approx(arc, rel=1e-12)
    assert chord(bent_axes(k, alpha, [0.0] + [math.pi] * (k - 2))) == pytest.approx(zigzag, rel=1e-12)
    if k % 2 == 0:
        assert zigzag == pytest.approx(2 * k * math.cos(alpha / 2), rel=1e-12)
    rng = np.random.default_rng(k)
    for _ in range(200):
        d = chord(bent_axes(k, alpha, rng.uniform(-math.pi, math.pi, k - 1)))
        assert arc - 1e-12 <= d <= zigzag + 1e-12


def _chain(e_stretch, before=1, after=1):
    """A chain whose segments before..before+k-1 are e_stretch, between anchored points at
    both its ends, its hinges locked; the other segments straight down from them."""
    k = len(e_stretch)
    down = np.array([0.0, 0.0, 1.0])
    e = np.array([down] * before + list(e_stretch) + [down] * after)
    n = len(e)
    points = np.array([2.0 * e[j:].sum(axis=0) for j in range(n + 1)])  # point j = 2b sum_{i >= j} e_i
    anchored = np.zeros(n + 1, np.uint8)
    anchored[[before, before + k, n]] = 1
    locked = np.zeros(n - 1, np.uint8)
    locked[before : before + k - 1] = 1
    return e, anchored, locked, points


def test_a_locked_stretch_curled_to_its_arc_between_anchors_is_named():
    alpha = math.pi / 4
    e, anchored, locked, points = _chain(bent_axes(4, alpha, [0.01, -0.02, 0.015]))
    arc, _ = stretch_chord_extremes(4, alpha)
    gap = abs(float(np.linalg.norm(points[5] - points[1])) - arc) / arc
    assert 0 < gap < 1e-2
    note = closed_stretch_note(e, anchored, locked, points, alpha)
    assert "4 segments 1-4 between anchored points 1 and 5, its 3 hinges locked" in note
    assert f"within {gap:.2g} of the chord of its tightest curl" in note


def test_a_locked_stretch_whose_arc_turns_back_is_named_at_its_tightest_curl():
    """Five segments at alpha = pi/4 (k alpha = 5 pi/4): their tightest curl is a U, the last
    axis opposite the first (a fall at N = 128 ended in one, 3.3e-5 from its chord)."""
    alpha = math.pi / 4
    e, anchored, locked, points = _chain(bent_axes(5, alpha, [0.004, -0.003, 0.002, 0.003]))
    arc, _ = stretch_chord_extremes(5, alpha)
    assert arc == pytest.approx(2.0 + 2.0 * math.sqrt(2.0), rel=1e-12)  # the U: 2 (1 + 2 cos(pi/4)) + 0
    note = closed_stretch_note(e, anchored, locked, points, alpha)
    assert "5 segments 1-5 between anchored points 1 and 6, its 4 hinges locked" in note
    assert "tightest curl" in note


def test_a_locked_stretch_at_its_zigzag_between_anchors_is_named():
    alpha = math.pi / 4
    e, anchored, locked, points = _chain(bent_axes(3, alpha, [0.0, math.pi - 0.01]))
    assert "straightest reach (a planar zigzag)" in closed_stretch_note(e, anchored, locked, points, alpha)


def test_a_stretch_with_room_or_a_free_hinge_is_not_named():
    alpha = math.pi / 4
    e, anchored, locked, points = _chain(bent_axes(4, alpha, [1.0, -1.2, 0.8]))  # halfway: room to move
    assert closed_stretch_note(e, anchored, locked, points, alpha) == ""
    e, anchored, locked, points = _chain(bent_axes(4, alpha, [0.0, 0.0, 0.0]))
    assert closed_stretch_note(e, anchored, locked, points, alpha) != ""
    locked[2] = 0  # one hinge free: the stretch can fold there
    assert closed_stretch_note(e, anchored, locked, points, alpha) == ""
