"""gamma measured from the floor (analysis.floor_gamma) against cases whose answer is
derived independently: the Hamm-Geminard chain itself (its ODE solved numerically, the
floor's record built from the momentum theorem), where the estimator must return the
gamma of the ODE, converging as the chain is cut finer; and real runs, where the
record obeys the momentum theorem so that removed - carried is fixed by the fall."""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records.measures import floor_gamma, landing_times, momentum, touch_times


def hamm_geminard_record(gamma: float, n: int, frames: int = 4000):
    """A chain of n segments (m = b = g = 1, z0 = 2n) falling as Hamm and Geminard's:
    d/dt(mu z zdot) = -mu g z + gamma mu zdot^2, mu = m / 2b.  Point j reaches the
    floor when z = 2 b j; the floor's impulse is J(t) = P(t) + M g t (momentum theorem,
    P = mu z zdot)."""
    mu, z0 = 0.5, 2.0 * n

    def rhs(t, y):  # y = (z, u = z zdot)
        z, u = y
        return [u / z, -z + gamma * (u / z) ** 2]

    hit = lambda t, y: y[0] - 1e-4 * z0  # noqa: E731  (the top lands; z = 0 is singular for gamma < 1)
    hit.terminal = True
    sol = solve_ivp(rhs, (0, 10 * math.sqrt(z0)), [z0, 0.0], rtol=1e-12, atol=1e-12 * z0, dense_output=True, events=hit)
    t_end = float(sol.t_events[0][0])
    t_ff = math.sqrt(2 * z0)
    ft = np.linspace(0.0, t_end, frames)
    z, u = sol.sol(ft)
    J = mu * u + n * ft  # P + M g t
    # anchor times: point j (0 = top) lands when z = 2 j (z decreases monotonically:
    # invert it on a fine grid of the dense solution); point n at t = 0, the top at t_end
    fine = np.linspace(0.0, t_end, 400001)
    zf = sol.sol(fine)[0]
    anchor_t = np.interp(-2.0 * np.arange(n + 1), -zf, fine)
    anchor_t[0], anchor_t[n] = t_end, 0.0
    frame_floor_impulse = np.zeros((frames, 3))
    frame_floor_impulse[:, 2] = J
    velocities = np.zeros((frames, n, 3))  # the airborne chain moves as one: zdot
    velocities[:, :, 2] = (u / z)[:, None]
    return velocities, SimpleNamespace(
        params=ChainParams(segments=n, alpha=math.pi),
        t_ff=t_ff,
        frame_t=ft,
        frame_floor_impulse=frame_floor_impulse,
        anchor_t=anchor_t,
        frame_e=np.tile([0.0, 0.0, 1.0], (frames, n, 1)),
        frame_omega=np.zeros((frames, n, 3)),
        t_fall=t_end,
    )


@pytest.mark.parametrize("gamma", [0.0, 0.5, 1.0])
def test_gamma_of_the_hamm_geminard_chain_is_recovered(gamma):
    errors = []
    for n in (50, 200, 800):
        v, rec = hamm_geminard_record(gamma, n, frames=40000)
        fg = floor_gamma(rec, velocities=v)
        assert fg.landed == n - 1  # all but the top one, which lands at t_fall
        errors.append(abs(fg.gamma - gamma))
    # converges as the chain is cut finer (the airborne mass is counted by whole segments)
    assert errors[2] < errors[1] < errors[0] and errors[2] < 0.02
    # and over time: every window away from the start measures the same gamma
    v, rec = hamm_geminard_record(gamma, 800, frames=40000)
    fg = floor_gamma(rec, windows=5, velocities=v)
    assert np.all(np.abs(fg.window_gamma[1:] - gamma) < 0.02)


def test_a_whip_is_resolved_only_to_the_frames():
    """gamma < 0: the top end whips (its speed diverges as z -> 0), and the last landings
    are measured to the frames' resolution; the windows before the end still agree."""
    v, rec = hamm_geminard_record(-0.5, 800, frames=40000)
    fg = floor_gamma(rec, windows=8, velocities=v)
    assert np.all(np.abs(fg.window_gamma[1:-1] + 0.5) < 0.03)


@pytest.mark.slow
@pytest.mark.parametrize("floor", ["all", "pivot"])
def test_measured_gamma_on_real_runs_obeys_the_momentum_theorem(floor):
    """The floor's removed momentum equals what the chain's state says it must be:
    removed(t_fall) = P(t_fall) - P(0) + g * integral_0^t_fall M_air dt, with P from the
    frames' kinematics (not from the floor's record) and M_air from the landing times."""
    n = 8
    r = simulate(
        ChainParams(segments=n, alpha=math.pi / 4, floor=floor),
        InitialCondition(kind="helix", eps=0.05),
        SolverOptions(frames_per_tff=4000),
    )
    assert r.status == "landed" and math.isfinite(r.t_fall)
    fg = floor_gamma(r)
    tt = touch_times(r)
    assert fg.landed == int(np.sum((tt > 0) & (tt < r.t_fall))) >= 1 and fg.carried > 0 and math.isfinite(fg.gamma)
    tl = landing_times(r)
    P = np.interp(r.t_fall, r.frame_t, momentum(r)[:, 2]) - momentum(r)[0, 2]
    air = float(np.sum(np.minimum(np.nan_to_num(tl, nan=np.inf), r.t_fall)))  # m = g = 1
    assert fg.removed == pytest.approx(P + air, rel=1e-5)
