"""The paper's figures, redrawn from ballchain results and the theory (figure code only:
the runs come from ``ballchain.paper``).  Times in t_ff, heights in z0, lengths in b."""

from __future__ import annotations

import math
import warnings

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from .. import theory
from ..records.measures import floor_gamma  # noqa: E402
from ..records.result import Result  # noqa: E402
from .run import lock_map_figure  # noqa: E402
from .titles import run_title  # noqa: E402

STROBE = 0.13  # the paper's Fig. 2: a side view every 0.13 t_ff
SPLIT = 0.55  # the paper's Fig. 4: segments landed before / after 0.55 t_ff


def _frame_at(r: Result, tau: float) -> int:
    return int(np.argmin(np.abs(np.asarray(r.frame_t) / r.t_ff - tau)))


def fig2_strobe(r: Result) -> Figure:
    """Side views (x-z) every STROBE t_ff, side by side, and z_top(t) with a free particle."""
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4.5), gridspec_kw={"width_ratios": [2.2, 1]})
    pts = r.points() / r.params.half_length
    taus = np.arange(0.0, float(np.asarray(r.frame_t)[-1] / r.t_ff) + 1e-9, STROBE)
    width = 0.35 * float(np.max(pts[:, 0, 2])) if pts.size else 1.0
    for k, tau in enumerate(taus):
        f = _frame_at(r, tau)
        a1.plot(pts[f, :, 0] + k * width, pts[f, :, 2], lw=1, color="C0")
        a1.text(k * width, -0.06 * np.max(pts[:, 0, 2]), f"{tau:.2f}", ha="center", fontsize=7)
    a1.axhline(0.0, color="k", lw=0.8)
    a1.set(xlabel=f"x / b (views every {STROBE} t_ff, shifted)", ylabel="z / b", title="side views")
    zmax = float(np.max(pts[:, 0, 2]))
    a1.set_ylim(-0.1 * zmax, 1.05 * zmax)
    a1.set_aspect("equal", adjustable="box")
    a2.plot(np.asarray(r.t) / r.t_ff, np.asarray(r.z_top) / r.z0, label="top end")
    s = np.linspace(0, 1, 201)
    a2.plot(s, 1 - s**2, "k--", lw=1, label="free particle")
    a2.set(xlabel="t / t_ff", ylabel="z_top / z0", title=f"N = {r.params.segments}")
    a2.legend()
    fig.suptitle(run_title(r, sep=" | "), fontsize=10)
    return fig


def fig3_lock_map(r: Result) -> Figure:
    """Heights of hinges at the instants they lock, with z_top(t)."""
    return lock_map_figure(r)


def fig4_pile(r: Result, split: float = SPLIT) -> Figure:
    """Top view of the pile: segments landed before and after ``split`` t_ff."""
    fig, ax = plt.subplots(figsize=(5, 5))
    a = np.asarray(r.anchor_t)
    pos = np.asarray(r.anchor_pos) / r.params.half_length
    idx = np.flatnonzero(np.isfinite(a[:-1]) & np.isfinite(a[1:]))
    when = np.maximum(a[idx], a[idx + 1]) / r.t_ff
    for sel, color, label in (
        (when < split, "C0", f"landed before {split} t_ff"),
        (when >= split, "C3", f"landed after {split} t_ff"),
    ):
        segs = np.stack([pos[idx[sel], :2], pos[idx[sel] + 1, :2]], axis=1)
        ax.add_collection(LineCollection(segs, colors=color, linewidths=1.5, label=label))
    ax.autoscale()
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8)
    ax.set(xlabel="x / b", ylabel="y / b", title=run_title(r) + "\npile, top view")
    return fig


def fig5_alpha(runs: list[Result], window=(0.38, 0.84)) -> Figure:
    """z_top(t) in the window for several alpha (same chain, same initial condition)."""
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for r in sorted(runs, key=lambda r: r.params.alpha):
        tau = np.asarray(r.t) / r.t_ff
        sel = (tau >= window[0]) & (tau <= window[1])
        ax.plot(tau[sel], np.asarray(r.z_top)[sel] / r.z0, label=f"alpha = {math.degrees(r.params.alpha):.0f} deg")
    s = np.linspace(*window, 100)
    ax.plot(s, 1 - s**2, "k--", lw=1, label="free particle")
    ax.set(xlabel="t / t_ff", ylabel="z_top / z0", title=f"N = {runs[0].params.segments}" if runs else "")
    ax.legend(fontsize=8)
    return fig


def fig6_hamm_geminard(runs: list[Result]) -> Figure:
    """t_gamma / t_ff of the Hamm-Geminard model against gamma, with each run placed on
    the curve at the gamma its t_fall / t_ff implies (theory.gamma_from_time_ratio,
    filled circles) and at the gamma measured from its floor record (open squares,
    analysis.floor_gamma)."""
    fig, ax = plt.subplots(figsize=(5.5, 4))
    g = np.linspace(-1.0, 1.45, 300)
    ax.plot(g, [theory.hamm_geminard_time_ratio(x) for x in g], "k", lw=1, label="Hamm-Geminard")
    for r in runs:
        ratio = r.t_fall / r.t_ff
        try:
            gam = theory.gamma_from_time_ratio(ratio)
        except ValueError:
            continue
        (mark,) = ax.plot(
            [gam], [ratio], "o", ms=5, label=f"N = {r.params.segments}, alpha = {math.degrees(r.params.alpha):.0f} deg"
        )
        measured = floor_gamma(r).gamma  # gamma measured from the floor's momentum record
        if math.isfinite(measured):
            ax.plot([measured], [ratio], "s", ms=5, mfc="none", color=mark.get_color(), gid="measured")
            ax.plot([gam, measured], [ratio, ratio], ":", lw=0.8, color=mark.get_color())
    ax.plot([], [], "o", color="0.4", label="gamma from t_fall / t_ff")
    ax.plot([], [], "s", mfc="none", color="0.4", label="gamma measured from the floor")
    ax.axhline(1.0, color="k", lw=0.5, ls=":")
    ax.set(xlabel="gamma", ylabel="t_fall / t_ff")
    ax.legend(fontsize=7)
    return fig


def fig7_pivot_rod(theta0s=(0.0, 0.2, 0.5), s_max: float = 1.5, n: int = 41) -> Figure:
    """Left: the pivot's vertical reaction on a rod (units m g) against theta.  Right:
    the pivot's impulse Delta p(theta0, s) until the rod is horizontal, with its zero
    s*(theta0) (the pivot pulls on balance above it)."""
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    th = np.linspace(0, math.pi / 2, 200)
    for t0 in theta0s:
        a1.plot(th, theory.pivot_rod_vertical_force(th, t0), label=f"theta0 = {t0}, s = 0")
    a1.plot(th, theory.pivot_rod_vertical_force(th, 0.0, 1.0), "--", label="theta0 = 0, s = 1")
    a1.axhline(0, color="k", lw=0.5)
    a1.set(xlabel="theta (rad)", ylabel="F_z / m g", title="pivot reaction")
    a1.legend(fontsize=7)
    t0 = np.linspace(0.02, 1.4, n)
    ss = np.linspace(0.02, s_max, n)
    with warnings.catch_warnings():  # (quad's round-off notes at 1e-13: far below the picture's resolution)
        warnings.simplefilter("ignore")
        dp = np.array([[theory.pivot_rod_impulse(a, b) for a in t0] for b in ss])
    mesh = a2.pcolormesh(t0, ss, dp, cmap="RdBu_r", vmin=-np.max(np.abs(dp)), vmax=np.max(np.abs(dp)), shading="auto")
    fig.colorbar(mesh, ax=a2, label="Delta p / m sqrt(g b)")
    a2.plot(t0, [theory.pivot_rod_critical_s(a) for a in t0], "k", lw=1.2, label="Delta p = 0")
    a2.set(xlabel="theta0 (rad)", ylabel="s = b thetadot0^2 / g", title="pivot impulse")
    a2.legend(fontsize=7)
    return fig
