"""The state at an event time (integrator.dopri.event_state): a quintic through the step's
ends and f at two interior points must have the Dormand-Prince step's own order (local
error O(h^6)), where the 4th-order continuous extension is O(h^5), and an error of the
size of the step's.  Checked against the same chain integrated in many small steps."""

import numpy as np

from ballchain.core.state import new_work
from ballchain.initial import helix_directions
from ballchain.methods.event_driven import dopri
from ballchain.methods.event_driven import integrator as itg

N = 8
THETA = 0.37


def _chain():
    e = helix_directions(N, 0.3, 1.0, 0.0)
    rng = np.random.default_rng(3)
    w = rng.normal(size=(N, 3)) * 0.3
    w -= np.sum(w * e, axis=1)[:, None] * e  # w perpendicular to e
    Y = np.stack([e, w])
    anchored = np.zeros(N + 1, dtype=np.uint8)
    anchored[N] = 1  # the pivot
    locked = np.zeros(N - 1, dtype=np.uint8)
    return Y, anchored, locked, new_work(N)


def _step(Y, h, anchored, locked, ws):
    """One Dormand-Prince step: (stages K, anchor forces F, 5th-order end Y1)."""
    st = itg.new_stepper(Y.shape[1])
    dopri.stage_rhs(Y, anchored, locked, ws, st.sg.K[0], st.sg.F[0])
    dopri.rk_stages(Y, h, st.sg, anchored, locked, ws)
    return st


def _fine(Y, t, anchored, locked, ws, m=200):
    """The state at time t and the anchors' impulse over [0, t]: m small steps."""
    Y = Y.copy()
    imp = np.zeros(4)
    for _ in range(m):
        st = _step(Y, t / m, anchored, locked, ws)
        dopri.floor_impulse_step(t / m, st.sg.F, np.int64(0), imp)
        Y = st.sg.Y1.copy()
    return Y, imp[:3]


def _errors(h):
    """Max errors at THETA h: the quintic, its impulse, the 4th-order extension; and the
    full step's error at h."""
    Y, anchored, locked, ws = _chain()
    st = _step(Y, h, anchored, locked, ws)
    K, Y1 = st.sg.K, st.sg.Y1.copy()
    ref, imp_ref = _fine(Y, THETA * h, anchored, locked, ws)
    ref_end, _ = _fine(Y, h, anchored, locked, ws)
    Ye = Y.copy()
    fint = np.zeros(4)
    dopri.event_state(Ye, st.sg, st.hb, h, THETA, anchored, locked, ws, np.int64(0), fint, np.zeros(1))
    Yd = np.empty_like(Y)
    dopri.dense_state(Y, K, h, THETA, Yd)
    return (
        np.abs(Ye - ref).max(),
        np.abs(fint[:3] - imp_ref).max(),
        np.abs(Yd - ref).max(),
        np.abs(Y1 - ref_end).max(),
    )


def test_event_state_has_the_steps_order():
    errs = np.array([_errors(h) for h in (0.05, 0.025, 0.0125)])
    quintic, impulse, dense4, step = errs.T
    # local error O(h^6): halving h divides it by ~64 (by ~32 for the 4th-order extension)
    assert np.all(quintic[:-1] / quintic[1:] > 45), quintic
    assert np.all(impulse[:-1] / impulse[1:] > 45), impulse
    assert dense4[-2] / dense4[-1] < 40, dense4  # (the test tells the orders apart)
    # of the size of the error the step itself makes (measured: 3 to 6 times)
    assert np.all(quintic < 10 * step), (quintic, step)
