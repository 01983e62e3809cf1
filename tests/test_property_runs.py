"""Never a silent bad run: a property over small random chains (hypothesis).

Over N = 1..12, alpha in (0, pi], both floor models, every start family, eps from 0 to
0.3 and several turns (planar starts with several bends fold the chain), every run of
the event-driven method either lands with its books closed (energy to 1e-8 of E0, no
point below a floor that watches every point, the fall's times in order) or ends with
status ``error`` and a message that says why (or, a chain that stands still, such as a
straight one with eps = 0, ends ``max_time``; a start bent past alpha is refused before
the run with a ParameterError with its books closed and a message saying
it had not landed).  It never ends ``landed`` or ``max_time`` with books that do not
close, and never raises.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from ballchain.engine import simulate
from ballchain.floors.registry import WATCHES_EVERY_POINT
from ballchain.model import ChainParams, InitialCondition, ParameterError, SolverOptions
from ballchain.records.audit import tolerances

chains = st.fixed_dictionaries(
    {
        "segments": st.integers(1, 12),
        "alpha": st.floats(0.2, math.pi),
        "floor": st.sampled_from(["all", "pivot"]),
        "kind": st.sampled_from(["helix", "planar", "random"]),
        "eps": st.floats(0.0, 0.3),
        "turns": st.sampled_from([0.5, 1.0, 2.0, 3.5]),
        "seed": st.integers(0, 2**16),
    }
)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(chains)
def test_every_run_lands_with_closed_books_or_fails_loudly(c):
    _lands_with_closed_books_or_fails_loudly(c, "event")


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(chains)
def test_every_time_stepped_run_lands_with_closed_books_or_fails_loudly(c):
    """The same property for the time-stepper, its books to its own bounds (its
    first-order error: records.audit.tolerances)."""
    _lands_with_closed_books_or_fails_loudly(c, "timestep")


def _lands_with_closed_books_or_fails_loudly(c, method):
    params = ChainParams(segments=c["segments"], alpha=c["alpha"], floor=c["floor"])
    ic = InitialCondition(kind=c["kind"], eps=c["eps"], turns=c["turns"], seed=c["seed"])
    energy_rtol, depth_tol = tolerances(method)
    try:
        r = simulate(params, ic, SolverOptions(frames_per_tff=4, method=method))
    except ParameterError as exc:  # a start outside the cone is refused before the run, saying why
        assert "inside alpha" in str(exc)
        event("refused: start outside the cone")
        return
    event(f"status {r.status}")
    assert r.status in ("landed", "max_time", "error"), (r.status, r.message)
    if r.status == "error":
        assert r.message.strip()
        return
    e = r.energy
    assert abs(e["imbalance"]) <= energy_rtol * abs(e["initial"]), e
    if c["floor"] in WATCHES_EVERY_POINT:
        assert r.max_depth / params.half_length <= depth_tol
    if r.status == "max_time":
        assert "had not landed" in r.message
        return
    assert math.isfinite(r.t_fall) and math.isfinite(r.t_landed)
    assert 0.0 < r.t_fall <= r.t_landed * (1 + 1e-12)
    assert np.all(r.frame_kinetic >= 0.0)
    assert e["kinetic"] == 0.0  # every segment at rest on the floor
