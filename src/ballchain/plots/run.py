"""The figures of one run, read from its Result (docs/measures.md, section 6).

Times are in units of t_ff, heights in units of z0, forces in units of the chain's
weight M g (pull: of one segment's weight m g), energies in units of the initial energy:
every figure reads the same for SI and nondimensional runs.  Each function returns a
matplotlib Figure whose artists hold exactly the plotted data (the tests read them).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; no screen needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from ..records.result import EVENT_CODES, Result  # noqa: E402
from .titles import run_title  # noqa: E402


def fall_figure(r: Result) -> Figure:
    """z_top(t)/z0 against a particle falling freely from z0: 1 - (t/t_ff)^2."""
    fig, ax = plt.subplots(figsize=(5.5, 4))
    tau = np.asarray(r.t) / r.t_ff
    ax.plot(tau, np.asarray(r.z_top) / r.z0, label="top end of the chain", lw=1.5)
    s = np.linspace(0.0, 1.0, 201)
    ax.plot(s, 1.0 - s**2, "k--", label="free fall", lw=1)
    if np.isfinite(r.t_fall):
        ax.axvline(r.t_fall / r.t_ff, color="C3", lw=0.8, label=f"t_fall = {r.t_fall / r.t_ff:.4g} t_ff")
    ax.set(xlabel="t / t_ff", ylabel="z_top / z0", title=run_title(r))
    ax.set_ylim(bottom=min(0.0, float(np.min(np.asarray(r.z_top) / r.z0))))
    ax.legend()
    return fig


def energy_figure(r: Result) -> Figure:
    """Kinetic, potential, lost to locking, to landing (and to damping and to sliding, where they acted), over the
    initial energy."""
    fig, ax = plt.subplots(figsize=(5.5, 4))
    tau = np.asarray(r.frame_t) / r.t_ff
    e0 = r.energy["initial"]
    for name, label in (
        ("frame_kinetic", "kinetic"),
        ("frame_potential", "potential"),
        ("frame_lost_locking", "lost to locking"),
        ("frame_lost_landing", "lost to landing"),
        ("frame_lost_damping", "lost to damping"),
        ("frame_lost_sliding", "lost to sliding"),
    ):
        if name in ("frame_lost_damping", "frame_lost_sliding") and not np.any(np.asarray(getattr(r, name))):
            continue  # (the law did not act)
        ax.plot(tau, np.asarray(getattr(r, name)) / e0, label=label)
    ax.set(xlabel="t / t_ff", ylabel="energy / initial energy", title=run_title(r))
    ax.legend()
    return fig


def floor_figure(r: Result) -> Figure:
    """Top: the scale reading over M g.  Bottom: the pile's pull on the hanging chain
    (vertical component, over one segment's weight m g; negative: pulls down)."""
    p = r.params
    weight = p.segment_mass * p.gravity  # m g in the run's units (1 if nondimensional)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(5.5, 5.5), sharex=True)
    tau = np.asarray(r.frame_t) / r.t_ff
    a1.plot(tau, np.asarray(r.frame_scale_force) / (p.segments * weight), label="scale reading (impulses excluded)")
    a1.axhline(1.0, color="k", lw=0.6, ls=":")
    a1.set(ylabel="floor force / M g", title=run_title(r))
    a1.legend()
    a2.plot(tau, np.asarray(r.frame_pile_pull)[:, 2] / weight, color="C1", label="pile's pull, z")
    a2.axhline(0.0, color="k", lw=0.6, ls=":")
    a2.set(xlabel="t / t_ff", ylabel="pull / m g")
    a2.legend()
    return fig


def pile_figure(r: Result) -> Figure:
    """Top view of the pile: every landed segment (both ends anchored) drawn from its
    upper to its lower anchor point, coloured by the time it landed."""
    fig, ax = plt.subplots(figsize=(5, 5))
    t_anchor = np.asarray(r.anchor_t)
    pos = np.asarray(r.anchor_pos)
    landed = np.flatnonzero(np.isfinite(t_anchor[:-1]) & np.isfinite(t_anchor[1:]))
    segs = np.stack([pos[landed, :2], pos[landed + 1, :2]], axis=1) / r.params.half_length
    when = np.maximum(t_anchor[landed], t_anchor[landed + 1]) / r.t_ff
    lc = LineCollection(segs, array=when, cmap="viridis", linewidths=1.5)
    ax.add_collection(lc)
    if landed.size:
        fig.colorbar(lc, ax=ax, label="landed at t / t_ff")
        ax.autoscale()
    ax.set_aspect("equal")
    ax.set(xlabel="x / b", ylabel="y / b", title=run_title(r) + f"\npile, {landed.size} segments landed")
    return fig


def lock_map_figure(r: Result) -> Figure:
    """Heights of the hinges at the instants they lock, with z_top(t) (the paper's Fig. 3)."""
    fig, ax = plt.subplots(figsize=(5.5, 4))
    lock = np.asarray(r.event_kind) == EVENT_CODES["lock"]
    ax.scatter(
        np.asarray(r.event_t)[lock] / r.t_ff, np.asarray(r.event_pos)[lock, 2] / r.z0, s=2, c="C3", label="hinge locks"
    )
    ax.plot(np.asarray(r.t) / r.t_ff, np.asarray(r.z_top) / r.z0, "k", lw=1, label="z_top")
    ax.set(xlabel="t / t_ff", ylabel="height / z0", title=run_title(r))
    ax.legend(markerscale=4)
    return fig


def tension_map_figure(r: Result) -> Figure:
    """The tension along the chain over time (``frame_tension``, in units of m g, pulling
    positive), points from the top end (0) to the bottom end (N), with the pile's top
    point (the first held point from the top) and the top end's acceleration over g
    below (``measures.top_acceleration``; under -1 it falls faster than free fall)."""
    from matplotlib.colors import Normalize

    from ..records.measures import pile_point, top_acceleration

    p = r.params
    fig, (ax, a2) = plt.subplots(2, 1, figsize=(6, 6), sharex=True, height_ratios=(3, 1.3))
    tau = np.asarray(r.frame_t) / r.t_ff
    T = np.asarray(r.frame_tension, dtype=float) / (p.segment_mass * p.gravity)
    n = p.segments
    if T.size and np.isfinite(T).any():
        # the colours span 99% of the values (a whip's few spikes would wash out the rest), beyond: the ends
        v = max(float(np.nanpercentile(np.abs(T), 99.0)), 1e-12)
        mesh = ax.pcolormesh(tau, np.arange(n + 1), T.T, cmap="RdBu_r", norm=Normalize(-v, v), shading="nearest")
        fig.colorbar(mesh, ax=ax, extend="both", label="tension / m g (pull > 0)")
    j = pile_point(r).astype(float)
    j[j < 0] = np.nan
    ax.plot(tau, j, "k", lw=0.8, label="pile's top point")
    ax.set(ylabel="point j (0: top end, N: bottom end)", ylim=(n + 0.5, -0.5), title=run_title(r))
    if np.isfinite(j).any():
        ax.legend(fontsize=7, loc="lower left")
    a2.plot(tau, top_acceleration(r)[:, 2], color="C0", lw=0.8, label="top end, a_z / g")
    a2.axhline(-1.0, color="k", lw=0.6, ls="--", label="free fall")
    a2.set(xlabel="t / t_ff", ylabel="a_z / g", ylim=(-4.0, 1.0))
    a2.legend(fontsize=7, loc="lower left")
    return fig


def gamma_figure(r: Result) -> Figure:
    """gamma measured from the floor (analysis.floor_gamma) per window of t/t_ff, its
    value over the fall, and the gamma that t_fall/t_ff implies (Hamm-Geminard)."""
    from ..records.measures import floor_gamma
    from ..theory import gamma_from_time_ratio

    fg = floor_gamma(r)
    fig, ax = plt.subplots(figsize=(5.5, 4))
    if fg.window_gamma.size:
        mid = 0.5 * (fg.window_edges[:-1] + fg.window_edges[1:])
        ax.step(
            fg.window_edges,
            np.append(fg.window_gamma, fg.window_gamma[-1]),
            where="post",
            color="C0",
            label="measured, per window",
            gid="windows",
        )
        ax.plot(mid, fg.window_gamma, "o", color="C0", ms=3)
    if np.isfinite(fg.gamma):
        ax.axhline(fg.gamma, color="C0", ls="--", lw=1, label=f"measured over the fall: {fg.gamma:.3f}", gid="whole")
    try:
        gi = gamma_from_time_ratio(r.t_fall / r.t_ff)
        ax.axhline(gi, color="C3", ls=":", lw=1.2, label=f"from t_fall/t_ff (Hamm-Geminard): {gi:.3f}", gid="inferred")
    except ValueError:
        pass
    ax.axhline(1.0, color="k", lw=0.5)
    ax.set(
        xlabel="t / t_ff",
        ylabel="gamma = removed / carried momentum",
        title=run_title(r) + f"\n{fg.landed} landings before t_fall",
    )
    if ax.get_legend_handles_labels()[0]:  # a run cut before any landing has none
        ax.legend(fontsize=7)
    return fig


FIGURES = {
    "fall": fall_figure,
    "energy": energy_figure,
    "floor": floor_figure,
    "pile": pile_figure,
    "lock_map": lock_map_figure,
    "tension": tension_map_figure,
    "gamma": gamma_figure,
}


def write_figures(makers: dict, out_dir, formats=("png", "pdf"), note=lambda s: None) -> list[Path]:
    """Draw each figure of ``makers`` (name -> function of no argument) and write it as
    ``out_dir/<name>.<format>``, closing it after; returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in makers.items():
        note(f"drawing {name}")
        fig = make()
        try:
            for fmt in formats:
                path = out / f"{name}.{fmt}"
                fig.savefig(path, dpi=150, bbox_inches="tight")
                paths.append(path)
        finally:
            plt.close(fig)
    return paths


def plot_run(r: Result, out_dir, formats=("png", "pdf")) -> list[Path]:
    """Write every figure of FIGURES for ``r`` as ``out_dir/<name>.<format>``."""
    return write_figures({name: (lambda make=make: make(r)) for name, make in FIGURES.items()}, out_dir, formats)
