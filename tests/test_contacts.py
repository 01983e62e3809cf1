"""The contact laws (``ballchain.contacts``): Newton's restitution at the bend limit and
at the floor in whole falls of the event method, against what the law implies
independently of the code that solves it (nothing lost at e = 1; the first lock, the
same instant for every e, loses (1 - e^2) of the inelastic loss; a rod's bounces against
the rigid rod's closed forms), and the parameters as a contract: the command line, the
sweep's column and key, the result file, and a method that cannot honour them refusing
them in one line."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, ParameterError, SolverOptions
from ballchain.records.result import EVENT_CODES

START = InitialCondition(kind="random", seed=2026, spawn_key=(0,))


def fall(n, e, **opts):
    return simulate(ChainParams(segments=n, restitution_lock=e), START, SolverOptions(**opts))


@pytest.mark.parametrize("n", [4, 8])
def test_an_elastic_limit_loses_nothing_at_the_locks(n):
    """e = 1: every lock impact gives back what it took (the loss of Newton's law is
    (1 - e)/(1 + e) P.GP); the books still close, landings still take their share."""
    r = fall(n, 1.0)
    en, e0 = r.energy, r.energy["initial"]
    assert r.status == "landed"
    locks = r.event_kind == EVENT_CODES["lock"]
    assert locks.sum() > 0
    assert abs(en["lost_locking"]) < 1e-10 * e0
    assert np.abs(r.event_energy[locks]).max() < 1e-10 * e0
    assert abs(en["imbalance"]) < 1e-8 * e0
    assert en["lost_landing"] > 0.1 * e0


@pytest.mark.parametrize("e", [0.25, 0.5, 0.9])
def test_the_first_lock_loses_one_minus_e_squared_of_the_inelastic_loss(e):
    """Before the first impact the fall does not know e: the first lock comes at the same
    instant, and (one hinge closing) loses (1 - e^2) of what the inelastic lock loses."""
    ref = fall(8, 0.0, until=0.7)
    r = fall(8, e, until=0.7)
    assert r.first_lock_time == ref.first_lock_time
    first = np.flatnonzero(ref.event_kind == EVENT_CODES["lock"])[0]
    same_instant = ref.event_t == ref.event_t[first]
    assert (ref.event_kind[same_instant] == EVENT_CODES["lock"]).sum() == 1  # one hinge
    k = np.flatnonzero(r.event_kind == EVENT_CODES["lock"])[0]
    assert r.event_t[k] == ref.event_t[first] and r.event_index[k] == ref.event_index[first]
    assert r.event_energy[k] == pytest.approx((1.0 - e * e) * ref.event_energy[first], rel=1e-9)
    assert r.energy["lost_locking"] >= 0.0
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]


@pytest.mark.parametrize("e", [0.3, 0.7])
def test_a_partly_elastic_limit_closes_its_books_and_stays_inside_its_limits(e):
    """Rebounds, the accumulation rule that ends their series, and the second inelastic
    pass of a hinge pushed back to its limit: the books close to the event method's bound
    and no hinge passes its limit."""
    r = fall(8, e)
    assert r.status == "landed", r.message
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]
    assert r.energy["lost_locking"] > 0.0
    cos_a = np.cos(r.params.alpha)
    g = np.einsum("fij,fij->fi", r.frame_e[:, :-1], r.frame_e[:, 1:]) - cos_a
    landed = r.frame_anchored[:, :-1].astype(bool)
    free_pair = ~(landed[:, :-1] | landed[:, 1:])
    assert g[free_pair].min() > -1e-7


@pytest.mark.parametrize(
    "law, method", [("restitution_floor", "timestep"), ("friction", "timestep"), ("friction", "event")]
)
def test_a_method_that_cannot_honour_it_refuses_it_in_one_line(method, law):
    flag = "--" + law.replace("_", "-")
    with pytest.raises(ParameterError, match=f"not honoured by --method {method}"):
        simulate(ChainParams(segments=4, **{law: 0.5}), START, SolverOptions(method=method))
    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--method", method, flag, "0.5", "-q"])
    assert res.exit_code == 2
    assert len(res.stderr.strip().splitlines()) == 1 and f"{flag} 0.5" in res.stderr
    res = CliRunner().invoke(app, ["sweep", "-N", "4", "--method", method, flag, "0.5", "--out", "x.parquet", "-q"])
    assert res.exit_code == 2 and "not honoured" in res.stderr


@pytest.mark.parametrize("bad", ["-0.1", "1.5", "nan"])
def test_a_restitution_outside_0_1_is_refused(bad):
    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--restitution-lock", bad, "-q"])
    said = "must be a number in [0, 1]" if bad == "nan" else "must be in [0, 1]"  # (nan is no number, not a rebound)
    assert res.exit_code == 2 and f"restitution_lock {said}" in res.stderr
    why = {"-0.1": "through its limit", "1.5": "creates energy", "nan": "got nan"}[bad]  # (each side its own reason)
    assert why in res.stderr and len(res.stderr.strip().splitlines()) == 1


def test_the_parameter_in_the_json_the_file_the_sweep_table_and_its_key(tmp_path):
    from ballchain.records.files import load_result, save_result
    from ballchain.sweeps import SweepSpec
    from ballchain.sweeps.execute import run_sweep
    from ballchain.sweeps.stats import table_stats
    from ballchain.sweeps.table import read_table

    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--restitution-lock", "0.5", "--json", "-q"])
    assert res.exit_code == 0 and json.loads(res.stdout)["restitution_lock"] == 0.5
    r = fall(4, 0.5)
    save_result(r, tmp_path / "r.h5")
    assert load_result(tmp_path / "r.h5").params == r.params
    out = tmp_path / "t.parquet"
    for e in (0.0, 0.5):
        run_sweep(SweepSpec(segments=(4,), alphas=(0.8,), runs=2, restitution_lock=e), out, workers=1, progress=False)
    rows = read_table(out)
    assert sorted(r["restitution_lock"] for r in rows) == [0.0, 0.0, 0.5, 0.5]
    keys = {r["run_id"] for r in rows}
    assert len(keys) == 4 and sum(k.endswith("_restitution_lock0.5") for k in keys) == 2
    points = table_stats(out)["points"]
    assert sorted(p["restitution_lock"] for p in points) == [0.0, 0.5]  # two points, never pooled


def test_without_limits_the_law_never_acts():
    """alpha = pi: no hinge ever reaches a limit, so a fall with restitution at the limit
    is the fall without it, bit for bit (the law acts only where a limit does)."""
    a = simulate(ChainParams(segments=6, alpha=np.pi), START, SolverOptions())
    b = simulate(ChainParams(segments=6, alpha=np.pi, restitution_lock=0.7), START, SolverOptions())
    assert a.status == b.status == "landed"
    assert a.t_fall == b.t_fall and a.energy == b.energy
    np.testing.assert_array_equal(a.frame_e, b.frame_e)
    assert (a.event_kind == EVENT_CODES["lock"]).sum() == 0


# --------------------------------------------------------------------------- the floor


def _rod(theta0, e_floor, **opts):
    """N = 1 leaning by theta0 from the vertical, its lower end anchored: it pivots down
    and its top end strikes the floor."""
    e0 = np.array([[np.sin(theta0), 0.0, np.cos(theta0)]])
    return simulate(ChainParams(segments=1, restitution_floor=e_floor), state=(e0, None), options=SolverOptions(**opts))


def _flight(omega):
    """Time a rod pivoting on its anchored lower end spends off the floor after its top end
    leaves it at angular velocity omega (m = b = g = 1, I = 4/3 about the end): phi'^2 =
    omega^2 - (3/2) sin phi, up to sin phi_m = (2/3) omega^2 and back, by quadrature (phi =
    phi_m - x^2 removes the turning point's singularity)."""
    from scipy.integrate import quad

    pm = np.arcsin(omega**2 / 1.5)
    f = lambda x: (
        2.0 * x / np.sqrt(1.5 * (np.sin(pm) - np.sin(pm - x * x))) if x > 0 else 2.0 / np.sqrt(1.5 * np.cos(pm))
    )  # noqa: E731
    return 2.0 * quad(f, 0.0, np.sqrt(pm), epsabs=1e-13, epsrel=1e-12)[0]


def test_a_rod_bounces_on_its_top_end_until_the_accumulation_rule_anchors_it():
    """Restitution at the floor on a pivoting rod, against the rigid rod's closed forms:
    it strikes flat at omega^2 = (3/2) cos theta0 (energy), each bounce leaves at e times
    the rate it came with and loses (1 - e^2) of the kinetic energy, each flight lasts
    what the quadrature of the pivoting rod says, and the series ends where the
    accumulation rule (v^2 < 2 hold_apex |a_z|, v < hold_rate; a_z = -3/2 at the flat
    rod's top end) says: then the top end is anchored, logged as a ``pin`` (Newton's law
    would have bounced it once more: the fallback rule's row, never a plain ``landing``),
    whose loss is all the kinetic energy the series had left, cos(theta0) e^(2K) after K
    bounces, and the books hold all of E0."""
    theta0, e = 0.4, 0.5
    r = _rod(theta0, e)
    assert r.status == "landed", r.message
    top = r.event_index == 0
    bounce = top & (r.event_kind == EVENT_CODES["bounce"])
    landing = top & (r.event_kind == EVENT_CODES["landing"])
    pin = top & (r.event_kind == EVENT_CODES["pin"])
    omega = np.sqrt(1.5 * np.cos(theta0))
    o = SolverOptions()
    v = 2.0 * omega * e ** np.arange(1, 60)  # the top end's speed leaving the k-th bounce
    held = (v < o.hold_rate) | (v**2 < 2.0 * o.hold_apex * 1.5)
    k = bounce.sum()
    assert k == np.argmax(held) and pin.sum() == 1 and landing.sum() == 0
    assert r.event_t[pin][0] > r.event_t[bounce].max()  # the series' last row
    assert r.event_energy[pin][0] == pytest.approx(np.cos(theta0) * e ** (2 * k), rel=1e-6)
    assert r.event_counts()["pin"] == 1 and r.summary()["events"]["pin"] == 1
    t = r.event_t[bounce]
    assert r.t_fall == t[0]  # the fall ends at the top end's first touch
    flights = np.array([_flight(omega * e**k) for k in range(1, 7)])
    np.testing.assert_allclose(np.diff(t)[:6], flights, rtol=1e-7)
    lost = r.event_energy[bounce][:6]
    expected = (1 - e**2) * np.cos(theta0) * e ** (2 * np.arange(6))
    np.testing.assert_allclose(lost, expected, rtol=0, atol=1e-9 * np.cos(theta0))  # (the integrator's tolerance)
    en = r.energy
    assert en["lost_landing"] == pytest.approx(en["initial"], rel=1e-9) and en["lost_locking"] == 0.0
    assert abs(en["imbalance"]) < 1e-10 * en["initial"]


@pytest.mark.parametrize(
    "opts, floor_rate", [(dict(hold_rate_floor=0.2), 0.2), (dict(hold_rate=0.2, hold_rate_floor=1e-6), 1e-6)]
)
def test_the_floor_has_its_own_accumulation_threshold(opts, floor_rate):
    """--hold-rate-floor alone ends the series of bounces: the top end is anchored at the
    first bounce that would leave slower than it (the closed form's speeds 2 omega e^k),
    whatever the hinges' threshold; the books still hold all of E0."""
    theta0, e = 0.4, 0.5
    r = _rod(theta0, e, **opts)
    assert r.status == "landed", r.message
    top = r.event_index == 0
    bounce = top & (r.event_kind == EVENT_CODES["bounce"])
    omega = np.sqrt(1.5 * np.cos(theta0))
    v = 2.0 * omega * e ** np.arange(1, 60)
    held = (v < floor_rate) | (v**2 < 2.0 * SolverOptions().hold_apex * 1.5)
    assert bounce.sum() == np.argmax(held) and (top & (r.event_kind == EVENT_CODES["pin"])).sum() == 1
    assert r.energy["lost_landing"] == pytest.approx(r.energy["initial"], rel=1e-9)


def test_the_floor_threshold_leaves_the_hinges_alone():
    """With no bounces (restitution 0 at the floor) the floor's threshold has nothing to
    hold: a fall with locks, unlocks and landings is the same fall, event for event."""
    kw = dict(segments=12, alpha=math.pi / 4)
    a = simulate(ChainParams(**kw), options=SolverOptions(until=1.0))
    b = simulate(ChainParams(**kw), options=SolverOptions(until=1.0, hold_rate_floor=0.5))
    assert (a.event_kind == EVENT_CODES["unlock"]).sum() > 0 and (a.event_kind == EVENT_CODES["lock"]).sum() > 0
    np.testing.assert_array_equal(a.event_kind, b.event_kind)
    np.testing.assert_allclose(a.event_t, b.event_t, rtol=0, atol=1e-9)


def test_an_elastic_floor_under_a_rod_gives_back_every_bounce():
    """e = 1: the rod bounces forever at the rate it first struck with (its top end moves
    vertically at the flat rod: nothing for the rough floor to stop), nothing is lost."""
    theta0 = 0.6
    r = _rod(theta0, 1.0, until=6.0)
    assert r.status == "until"
    t = r.event_t[(r.event_index == 0) & (r.event_kind == EVENT_CODES["bounce"])]
    assert t.size >= 3
    np.testing.assert_allclose(np.diff(t), _flight(np.sqrt(1.5 * np.cos(theta0))), rtol=1e-7)
    assert abs(r.energy["lost_landing"]) < 1e-12 and abs(r.energy["imbalance"]) < 1e-10


@pytest.mark.parametrize("e_floor, e_lock", [(0.5, 0.0), (0.8, 0.5), (1.0, 1.0)])
def test_restitution_at_the_floor_closes_the_books_and_keeps_every_point_above_it(e_floor, e_lock):
    """Whole falls with points that bounce: the books close to the event method's bound,
    no point passes below the floor (the audit), the fall ends at the top end's first
    touch; with the rough floor a bounce stops a point's sliding, so even e = 1 at the
    floor and at the limits loses something at the landings, never at the locks."""
    r = simulate(
        ChainParams(segments=10, restitution_floor=e_floor, restitution_lock=e_lock),
        START,
        SolverOptions(until=None if e_floor < 1 else 2.0, max_time=8.0),  # (a bouncing tent settles slowly)
    )
    assert r.status == ("landed" if e_floor < 1 else "until"), r.message
    bounces = r.event_kind == EVENT_CODES["bounce"]
    assert bounces.sum() > 0
    en, e0 = r.energy, r.energy["initial"]
    assert abs(en["imbalance"]) < 1e-8 * e0
    assert r.max_depth <= 1e-9
    top = (r.event_index == 0) & (bounces | np.isin(r.event_kind, [EVENT_CODES["landing"], EVENT_CODES["pin"]]))
    if e_floor < 1:
        assert r.t_fall == r.event_t[top][0]
    if e_lock == 1.0:
        assert abs(en["lost_locking"]) < 1e-10 * e0


def test_restitution_at_the_floor_needs_the_floor_that_watches_every_point():
    with pytest.raises(ParameterError, match="needs floor all"):
        ChainParams(segments=4, floor="pivot", restitution_floor=0.5)
    res = CliRunner().invoke(app, ["simulate", "-N", "4", "--restitution-floor", "0.5", "--json", "-q"])
    assert res.exit_code == 0 and json.loads(res.stdout)["restitution_floor"] == 0.5


def test_a_point_kicked_down_at_the_floor_lands_at_once_and_every_series_of_bounces_ends():
    """A point that has just bounced and is turned back down by a neighbour's lock lands
    at that instant (it does not sink a round-off band deeper at each of its returns: a
    start of N = 128 once made 687000 bounces and went 2.8e-7 b into the floor). Each
    series of bounces is geometric (ratio E), so no point bounces more than a few
    series' worth; every point stays above the floor to round-off."""
    r = simulate(
        ChainParams(segments=128, restitution_floor=0.3),
        InitialCondition(kind="random", seed=2026, spawn_key=(6,)),
        SolverOptions(),
    )
    assert r.status == "landed", r.message
    bounces = r.event_kind == EVENT_CODES["bounce"]
    assert bounces.sum() > 500
    assert np.bincount(r.event_index[bounces]).max() < 200
    assert r.max_depth <= 1e-10
    assert abs(r.energy["imbalance"]) < 1e-8 * r.energy["initial"]


def test_at_an_elastic_limit_only_the_fallback_rules_rows_lose_energy():
    """e = 1 at the limits: Newton's law loses nothing at any impact, whatever the number of
    rows it acts on ((1 - e)/(1 + e) P.GP = 0), so every bit of E_lock a fall books must sit
    in rows of the fallback rules (``hold``: a hinge the law would rebound, kept at its
    limit); the lock and impulse rows lose nothing, and the hold rows add up to E_lock."""
    r = simulate(
        ChainParams(segments=8, alpha=math.pi / 2, restitution_lock=1.0),
        InitialCondition(kind="random", seed=3),
        SolverOptions(max_time=2.0),
    )
    e0 = r.energy["initial"]
    kind, lost = r.event_kind, r.event_energy
    law = np.isin(kind, [EVENT_CODES["lock"], EVENT_CODES["impulse"]])
    held = kind == EVENT_CODES["hold"]
    assert law.sum() > 0
    assert np.abs(lost[law]).sum() < 1e-10 * e0
    assert lost[held].sum() == pytest.approx(r.energy["lost_locking"], rel=1e-9, abs=1e-12 * e0)
    assert r.summary()["events"]["hold"] == held.sum()
