"""The nonsmooth RATTLE method (``--method rattle``, experimental) against independent truths:
second order against the exact method where the motion is smooth, a fall whose floor and
books hold, frames that do not change the fall, and the floor "pivot" (a rod's closed-form
fall, the first landing to second order, a whole fall's floor and books)."""

import math
from pathlib import Path

import numpy as np
import pytest

from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions

TOP3 = Path(__file__).parent / "data" / "top3-state.txt"
SMOOTH = (ChainParams(segments=8, alpha=math.pi), InitialCondition(eps=0.2))  # no limits; first landing after 0.5 t_ff


def _frame_error(r, ref, k):
    return float(np.abs(r.frame_e[k] - ref.frame_e[k]).max())


def test_second_order_where_the_motion_is_smooth():
    """Before its first landing a chain with no limits moves smoothly: the axes at 0.25 t_ff
    (a frame taken inside a step) converge to the exact method's about fourfold per halving of dt."""
    params, ic = SMOOTH
    ref = simulate(params, ic, SolverOptions(until=0.3, rtol=1e-12, frames_per_tff=4))
    assert ref.frame_anchored[1].sum() == 1  # only the pivot: the motion is smooth up to the frame
    errors = []
    for dt in (0.2, 0.1, 0.05, 0.025):
        r = simulate(params, ic, SolverOptions(method="rattle", dt=dt, until=0.3, frames_per_tff=4, step_energy_tol=0))
        assert r.status == "until"
        assert r.frame_t[1] == pytest.approx(ref.frame_t[1], rel=1e-12)
        errors.append(_frame_error(r, ref, 1))
    ratios = [a / b for a, b in zip(errors, errors[1:])]
    assert all(3.6 < q < 4.4 for q in ratios), (errors, ratios)


def test_a_fall_with_no_limits_holds_the_floor_and_closes_its_books():
    """alpha = pi, N = 8 to the end: every point anchored, none below the floor beyond the
    solver's tolerance, the books closed to 1e-3 of E0 (the smooth steps' second-order error)."""
    r = simulate(ChainParams(segments=8, alpha=math.pi), options=SolverOptions(method="rattle", dt=0.05))
    assert r.status == "landed", r.message
    assert r.max_depth <= 1e-8
    assert abs(r.energy["imbalance"]) <= 1e-3 * r.energy["initial"]
    assert r.energy["lost_landing"] > 0.5 * r.energy["initial"]  # a fall ends with its energy lost at the floor


def test_a_fall_with_limits_closes_its_books():
    """alpha = pi/4, N = 8 to the end at the defaults: the impact steps book what they remove,
    the smooth steps' error stays below 1e-4 of E0, nothing below the floor, and the losses
    sum to what the chain lost (E0 = U + T + E_lock + E_land, the chain at rest on the floor)."""
    r = simulate(ChainParams(segments=8, alpha=math.pi / 4), options=SolverOptions(method="rattle"))
    assert r.status == "landed", r.message
    e = r.energy
    assert abs(e["imbalance"]) <= 1e-4 * e["initial"]
    assert r.max_depth <= 1e-8
    assert e["lost_locking"] > 0.1 * e["initial"] and e["lost_landing"] > 0.1 * e["initial"]


def test_the_top_is_held():
    """The top of tests/data/top3-state.txt (three segments locked, spinning on a landed
    point) to 1 t_ff at the defaults: it keeps turning (status max_time), its books close to
    1e-4 of E0, and its hinges lose no more at their locks than the exact method's."""
    s = np.loadtxt(TOP3)
    runs = {
        m: simulate(
            ChainParams(segments=3, alpha=math.pi / 4),
            state=(s[:, :3], s[:, 3:]),
            options=SolverOptions(method=m, max_time=1.0),
        )
        for m in ("event", "rattle")
    }
    r, ex = runs["rattle"], runs["event"]
    assert r.status == "max_time"
    assert abs(r.energy["imbalance"]) <= 1e-4 * r.energy["initial"]
    assert r.energy["lost_locking"] <= ex.energy["lost_locking"] + 1e-6 * r.energy["initial"]
    assert r.energy["kinetic"] == pytest.approx(ex.energy["kinetic"], rel=2e-3)


def test_frames_do_not_change_the_fall():
    """Frames are taken by a step of their own from the step's start, on a copy: the fall's
    steps, and so its t_fall, are the same whatever the frame rate."""
    params = ChainParams(segments=6, alpha=math.pi / 4)
    runs = [
        simulate(params, InitialCondition(kind="random", seed=9090), SolverOptions(method="rattle", frames_per_tff=f))
        for f in (37.0, 100.0, 1000.0)
    ]
    assert len({r.n_steps for r in runs}) == 1
    for r in runs[1:]:
        assert r.t_fall == pytest.approx(runs[0].t_fall, rel=1e-12, abs=0.0)
        assert r.energy["lost_locking"] == pytest.approx(runs[0].energy["lost_locking"], rel=1e-9)


class _Watcher:
    """A step observer (``driver.StepObserver``) that counts the attempts and accepted steps,
    tries to write the state it is shown, and pauses the fall at ``pause`` if given."""

    def __init__(self, pause=None):
        self.attempts, self.accepted, self.writes, self.pause, self.steps = 0, 0, 0, pause, 0

    def before(self, t, seen):
        self.steps = int(seen.books.n_steps[0])
        for a in (seen.fall.motion.e, seen.fall.control.level, seen.fall.scratch.ledger.impact, seen.books.n_steps):
            try:
                a[0] = 0
                self.writes += 1
            except ValueError:
                pass
        return None if self.pause is None else t + self.pause

    def after(self, t, seen, code):
        self.attempts += 1
        self.accepted += int(seen.books.n_steps[0]) > self.steps


def test_an_observed_fall_is_the_fall_and_its_observer_only_reads():
    """``simulate(observer=)``: the observer is called around every attempt of a step and
    shown read-only views; the fall is the same to every digit.  A fall it pauses (a short
    time ahead of each attempt) lands too, in more steps, cut at the pauses."""
    params, ic = ChainParams(segments=6, alpha=math.pi / 4), InitialCondition(kind="random", seed=9090)
    options = SolverOptions(method="rattle")
    plain = simulate(params, ic, options)
    seen = _Watcher()
    watched = simulate(params, ic, options, observer=seen)
    assert seen.writes == 0 and seen.accepted == watched.n_steps and seen.attempts > seen.accepted
    for name in ("t", "z_top", "frame_e", "frame_omega", "event_t", "event_energy", "event_impulse"):
        assert np.array_equal(getattr(plain, name), getattr(watched, name)), name
    assert plain.energy == watched.energy
    paused = simulate(params, ic, options, observer=_Watcher(pause=0.01))
    assert paused.status == "landed" and paused.n_steps > plain.n_steps
    assert paused.t_fall == pytest.approx(plain.t_fall, rel=0.05)  # (2.61 and 2.63 t_ff)
    assert abs(paused.energy["imbalance"]) < 1e-4 * paused.energy["initial"]
    with pytest.raises(TypeError, match="no observer"):
        simulate(params, ic, SolverOptions(method="event"), observer=seen)


def test_every_frame_balances_the_floors_record_with_the_momentum():
    """The anchor: what the floor gave the chain up to each frame (its impulse record, the
    landed segments' support included) is the chain's momentum change plus the weight's
    impulse, M (v_cm(t) - v_cm(0)) + M g t, at every frame, frames taken inside steps
    included (a frame's step books the landed segments' weight as the fall's step does)."""
    from ballchain.records.measures import momentum

    r = simulate(
        ChainParams(segments=16, alpha=math.pi / 4),
        InitialCondition(kind="random", seed=11),
        SolverOptions(method="rattle", frames_per_tff=200),
    )
    assert r.status == "landed", r.message
    p, ft = momentum(r), np.asarray(r.frame_t)
    record, m = np.asarray(r.frame_floor_impulse), r.params.segments
    assert np.asarray(r.frame_anchored)[-1].sum() > m // 2  # (segments landed while frames were taken)
    np.testing.assert_allclose(record[:, :2], p[:, :2] - p[0, :2], rtol=0, atol=1e-8 * m * ft[-1])
    np.testing.assert_allclose(record[:, 2], p[:, 2] - p[0, 2] + m * ft, rtol=0, atol=1e-6 * m * ft[-1])


def _kind_times(r, kind):
    from ballchain.core.kinds import EVENT_CODES

    return np.asarray(r.event_t)[np.asarray(r.event_kind) == EVENT_CODES[kind]]


def test_on_the_pivot_floor_the_first_landing_is_second_order():
    """Floor "pivot", alpha = pi, N = 8: the first landing (the bottom segment lying flat on
    its pivot) comes at the exact method's instant to second order: the error shrinks about
    fourfold per halving of dt (three halvings, without the energy control's step halving)."""
    params = ChainParams(segments=8, alpha=math.pi, floor="pivot")
    first = _kind_times(simulate(params, options=SolverOptions(rtol=1e-12)), "landing")[0]
    errors = []
    for dt in (0.1, 0.05, 0.025, 0.0125):
        r = simulate(params, options=SolverOptions(method="rattle", dt=dt, step_energy_tol=0))
        errors.append(abs(_kind_times(r, "landing")[0] - first))
    ratios = [a / b for a, b in zip(errors, errors[1:])]
    assert all(3.5 < q < 4.5 for q in ratios), (errors, ratios)


def test_on_the_pivot_floor_a_rod_falls_in_its_closed_form_time():
    """N = 1 released at rest at theta0 = 0.1 on its pivot: the top end reaches the floor
    (the event "top", once, which sets t_fall) at the rigid rod's time, to 1e-4 of it at the
    default step."""
    from ballchain.theory import rod_fall_time

    theta0 = 0.1
    e0 = np.array([[math.sin(theta0), 0.0, math.cos(theta0)]])
    r = simulate(
        ChainParams(segments=1, floor="pivot"), None, SolverOptions(method="rattle"), state=(e0, np.zeros((1, 3)))
    )
    assert r.status == "landed", r.message
    tops = _kind_times(r, "top")
    assert len(tops) == 1 and tops[0] == r.t_fall
    assert r.t_fall == pytest.approx(rod_fall_time(theta0), rel=1e-4)


@pytest.mark.parametrize("kind", ["helix", "planar"])
def test_on_the_pivot_floor_segments_that_lie_flat_land_together_as_in_the_exact_method(kind):
    """N = 3, alpha = pi: when the bottom segment lies flat, the segments above it that
    point below the horizontal land in the same instant (the cascade), anchored where they
    are (below the floor); the same points land together as in the exact method, at its
    instants to 1e-3 and heights to 2e-3 b, and the top end's crossing of z = 0 (t_fall)
    to 1e-3."""
    params, ic = ChainParams(segments=3, alpha=math.pi, floor="pivot"), InitialCondition(kind=kind)
    ref = simulate(params, ic, SolverOptions(rtol=1e-12))
    r = simulate(params, ic, SolverOptions(method="rattle"))
    assert r.status == "landed", r.message
    together = np.isclose(ref.anchor_t[:, None], ref.anchor_t[None, :], rtol=0, atol=1e-9)
    assert together[:3, :3].sum() > 3  # (a cascade: at least two points landed at one instant)
    assert np.array_equal(np.isclose(r.anchor_t[:, None], r.anchor_t[None, :], rtol=0, atol=1e-12), together)
    np.testing.assert_allclose(r.anchor_t, ref.anchor_t, rtol=0, atol=1e-3)
    np.testing.assert_allclose(np.asarray(r.anchor_pos)[:, 2], np.asarray(ref.anchor_pos)[:, 2], rtol=0, atol=2e-3)
    assert abs(r.t_fall - ref.t_fall) < 1e-3
    assert abs(r.energy["imbalance"]) <= 1e-4 * r.energy["initial"]


@pytest.mark.parametrize("alpha", [math.pi / 4, math.pi])
def test_a_fall_on_the_pivot_floor_holds_its_segment_on_the_floor_and_closes_its_books(alpha):
    """Floor "pivot", N = 16 to the end at the defaults: in every frame the bottom airborne
    segment (the one the floor meets) points nowhere below the horizontal beyond the
    solver's tolerance, the books close to 1e-4 of E0, and the fall ends once, when the top
    end crosses z = 0, before the last segment lands."""
    n = 16
    r = simulate(
        ChainParams(segments=n, alpha=alpha, floor="pivot"), options=SolverOptions(method="rattle", frames_per_tff=2000)
    )
    assert r.status == "landed", r.message
    assert abs(r.energy["imbalance"]) <= 1e-4 * r.energy["initial"]
    lowest = math.inf
    for anchored, e in zip(np.asarray(r.frame_anchored), np.asarray(r.frame_e)):
        free = np.flatnonzero(anchored[:n] == 0)  # (segment i's upper end is point i)
        if len(free):
            lowest = min(lowest, e[free.max(), 2])
    assert lowest >= -1e-8
    tops = _kind_times(r, "top")
    assert len(tops) == 1 and tops[0] == r.t_fall < r.t_landed


def _pile_and_hanging_part(n=12, landed=4, seed=3):
    """A chain whose last ``landed`` segments lie on the floor (their points anchored) and
    whose upper part hangs above them, bent within the limit, moving: points P_j (j = 0 the
    top), velocities V_j built from the anchored point up (lengths and joints kept)."""
    from ballchain.methods.rattle.state import Motion

    rng = np.random.default_rng(seed)
    k = n - landed  # the first anchored point
    P, V = np.zeros((n + 1, 3)), np.zeros((n + 1, 3))
    for j in range(k, n + 1):
        P[j] = (2.0 * (j - k), 0.0, 0.0)
    for j in range(k - 1, -1, -1):
        u = np.array([0.0, 0.0, 1.0]) + 0.2 * rng.standard_normal(3)
        u /= np.linalg.norm(u)
        P[j] = P[j + 1] + 2.0 * u
        V[j] = V[j + 1] + 2.0 * np.cross(rng.standard_normal(3), u)
    c, e = 0.5 * (P[:-1] + P[1:]), 0.5 * (P[:-1] - P[1:])
    vc, ve = 0.5 * (V[:-1] + V[1:]), 0.5 * (V[:-1] - V[1:])
    anchored = np.zeros(n + 1, np.uint8)
    anchored[k:] = 1
    return Motion(
        c,
        e,
        vc,
        ve,
        anchored,
        P.copy(),
        np.zeros(n + 1),
        np.zeros(n - 1, np.uint8),
        np.zeros(n + 1, np.uint8),
        np.zeros((n + 1, 3)),
    )


def test_the_landed_part_takes_no_part_in_a_step():
    """A step works on the points down to the landed part only (``active_points``): the
    segments lying on the floor have no rows and do not move, so 40 steps on that part and
    the same steps on the whole chain leave the same state (up to the solver's tolerance,
    whose round-off term counts the segments it works on)."""
    from ballchain.core.state import new_model
    from ballchain.methods.rattle import scheme as S
    from ballchain.methods.rattle.rows import new_rows
    from ballchain.methods.rattle.state import clear_ledger, copy_motion, new_scratch

    n = 12
    model = new_model(math.pi / 4, 0, False, SolverOptions(method="rattle").for_segments(n), 1e9, 0.0, 1)
    runs = []
    for whole in (False, True):
        mo, ws, sc = _pile_and_hanging_part(n), new_rows(n), new_scratch(n)
        assert S.active_points(mo.anchored) == n - 4 + 2  # down to the lower end of the first landed segment
        t, h, locks = 0.0, 0.01, 0
        for _ in range(40):
            if whole:  # (rattle_step's preamble, on every point)
                clear_ledger(sc.ledger)
                copy_motion(mo, sc.start)
                code, na = S._step_points(t, h, model, mo, ws, sc, 0.0, True, False, S.ITER_BUDGET)
            else:
                code, na = S.rattle_step(t, h, model, mo, ws, sc, 0.0, True, False, S.ITER_BUDGET)
            assert code == 0 and na == 0
            S.keep_warm_start(h, ws, sc)
            locks += int(mo.locked.sum())
            t += h
        runs.append(mo)
    part, whole = runs
    assert locks > 0  # (the hanging part's limits took part)
    assert np.all(part.anchored == whole.anchored) and np.all(part.locked == whole.locked)
    for name in ("c", "e", "vc", "ve"):
        assert np.allclose(getattr(part, name), getattr(whole, name), rtol=0, atol=1e-9), name
    assert np.all(part.c[n - 4 :] == _pile_and_hanging_part(n).c[n - 4 :])  # the pile did not move
    assert np.all(part.vc[n - 4 :] == 0.0) and np.all(part.ve[n - 4 :] == 0.0)


def test_a_landing_step_cut_at_the_touch_lands_the_point_there():
    """--landing-step cut: the first landing after the pivot (alpha = pi, N = 8) comes at the
    exact method's time to within 5% of a step, and the loss at the floor up to then is
    within 1e-3 E0 of the exact method's; a step taken whole resolves the landing at its end,
    up to a step late, and its loss is four times further off (first order in the step)."""
    from ballchain.core.kinds import EVENT_CODES

    params, ic = SMOOTH
    ref = simulate(params, ic, SolverOptions(until=0.75, rtol=1e-12))

    def first_landing(r):
        k = np.flatnonzero((r.event_kind == EVENT_CODES["landing"]) & (r.event_index != params.segments))
        return r.event_t[k[0]], r.event_index[k[0]], r.energy["lost_landing"] / r.energy["initial"]

    t_ref, j_ref, lost_ref = first_landing(ref)
    for dt in (0.2, 0.1):
        runs = {}
        for how in ("whole", "cut"):
            o = SolverOptions(method="rattle", dt=dt, until=0.75, landing_step=how, step_energy_tol=0)
            r = simulate(params, ic, o)
            assert r.status == "until", r.message
            runs[how] = first_landing(r)
        h = dt * ref.t_ff / params.segments
        t_cut, j_cut, lost_cut = runs["cut"]
        assert j_cut == j_ref
        assert abs(t_cut - t_ref) <= 0.05 * h, (dt, (t_cut - t_ref) / h)
        assert abs(lost_cut - lost_ref) <= 1e-3
        assert abs(lost_cut - lost_ref) < abs(runs["whole"][2] - lost_ref) / 4.0


def test_the_method_line_names_a_whole_landing_step_also_in_files_before_the_key():
    """A RATTLE file written before `landing_step` was recorded took its landing steps whole
    (the only rule then): its method line says so, as a whole run's does; a cut run's does not."""
    from ballchain.methods.rattle import summary

    base = {"method": "rattle", "dt": 0.05, "step_energy_tol": None}
    assert summary(base).endswith(", landing steps whole")
    assert summary({**base, "landing_step": "whole"}).endswith(", landing steps whole")
    assert "landing steps" not in summary({**base, "landing_step": "cut"})


def test_a_longer_step_is_halved_more_so_its_shortest_is_the_default_steps():
    """--dt longer than the default takes ceil(log2(dt / 0.05)) more halvings, so that its
    shortest step, dt / 2^(10 + extra), is never longer than the default's, 0.05 / 2^10 (a
    longer ceiling must not be coarser where the steps must be short); the default and
    shorter steps keep 10."""
    from ballchain.methods.rattle import DEFAULT_DT
    from ballchain.methods.rattle.scheme import CUTS_MAX, extra_cuts

    for dt in (0.0125, 0.025, DEFAULT_DT):
        assert extra_cuts(dt) == 0
    for dt in (0.06, 0.1, 0.2, 0.35, 1.0):
        k = extra_cuts(dt)
        assert dt / 2 ** (CUTS_MAX + k) <= DEFAULT_DT / 2**CUTS_MAX * (1 + 1e-12)
        assert dt / 2 ** (CUTS_MAX + k - 1) > DEFAULT_DT / 2**CUTS_MAX  # (no halving more than that)
    assert extra_cuts(0.1) == 1 and extra_cuts(0.2) == 2
