"""An orbitable 3D view of a run in one self-contained HTML file (plotly, its library
embedded: it opens offline in any browser).

The chain in 3D with a time slider and play/pause, each segment coloured by its state
(free; next to a locked hinge; landed), the floor; beside it z_top(t) against free fall,
with a marker that follows the slider.  Size rule: a file holds at most ``POINT_BUDGET``
chain points in all (frames x (N + 1)); by default the frames are thinned evenly to that
(N = 4096: 244 frames, a file of about 30 MB), ``every``/``frames`` choose others.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..records.result import Result
from .animate import frame_indices
from .titles import run_title

POINT_BUDGET = 1_000_000  # chain points in a file at most, by default
# The 3D box's horizontal sides, as drawn, are at least this fraction of its height: a tall,
# thin chain in true proportions gets a box wide enough to read its ticks (the horizontal
# ranges grow, the proportions stay true)
MIN_WIDTH = 0.6
TICKS = 5  # at most about this many ticks on each horizontal axis of the box (nticks)
COLORS = {"free": "#1f5fbf", "locked": "#d62728", "landed": "#7f7f7f"}
STATES = ("free", "locked", "landed")
COLOURINGS = ("state", "tension")  # what colours the chain (``view_figure``)


def default_frames(result: Result) -> int:
    """The frames a view holds by default: all of them, or as many as POINT_BUDGET allows."""
    n_points = result.params.segments + 1
    return max(2, min(len(result.frame_t), POINT_BUDGET // n_points))


def segment_states(result: Result, i: int) -> np.ndarray:
    """State of each segment at frame i: 0 free, 1 next to a locked hinge, 2 landed."""
    anchored = np.asarray(result.frame_anchored[i], dtype=bool)
    locked = np.asarray(result.frame_locked[i], dtype=bool)
    n = result.params.segments
    state = np.zeros(n, dtype=np.int64)
    if n > 1:
        state[:-1] |= locked
        state[1:] |= locked
    state[anchored[:-1] & anchored[1:]] = 2
    return state


def _chain_traces(pts: np.ndarray, state: np.ndarray, go, visible: bool = True) -> list:
    """One Scatter3d per state: its segments as lines separated by gaps (None)."""
    traces = []
    for code, name in enumerate(STATES):
        xs, ys, zs = [], [], []
        for i in np.flatnonzero(state == code):
            for arr, q in ((xs, 0), (ys, 1), (zs, 2)):
                arr.extend([pts[i, q], pts[i + 1, q], None])
        traces.append(go.Scatter3d(x=xs, y=ys, z=zs, mode="lines", name=name, visible=visible,
                                   line=dict(color=COLORS[name], width=6), hoverinfo="skip", showlegend=True))  # fmt: skip
    return traces


def _tension_trace(pts: np.ndarray, tension: np.ndarray, vmax: float, go, visible: bool = True):
    """The chain as one line through its points, each coloured by its tension (m g; red
    pulls, blue pushes), the colours spanning -vmax..vmax."""
    scale = dict(colorscale="RdBu", reversescale=True, cmin=-vmax, cmax=vmax)
    return go.Scatter3d(x=pts[:, 0], y=pts[:, 1], z=pts[:, 2], mode="lines+markers", name="tension", visible=visible,
                        line=dict(color=tension, width=6, **scale),
                        marker=dict(size=2.5, color=tension, colorbar=dict(title="tension / m g", len=0.6, x=-0.08),
                                    **scale),
                        hoverinfo="skip", showlegend=True)  # fmt: skip


def _player(steps: list) -> dict:
    """The layout's time controls: the slider over the frames (``steps``) right of the
    play/pause buttons, its time above it, clear of them."""
    return dict(
        sliders=[
            dict(
                active=0,
                steps=steps,
                x=0.16,
                len=0.84,
                y=-0.02,
                yanchor="top",
                currentvalue=dict(prefix="t / t_ff = ", xanchor="left"),
                pad=dict(t=10),
            )
        ],  # fmt: skip
        updatemenus=[
            dict(
                type="buttons",
                direction="left",
                x=0.0,
                y=-0.06,
                xanchor="left",
                yanchor="top",
                buttons=[
                    dict(
                        label="play",
                        method="animate",
                        args=[
                            None,
                            dict(frame=dict(duration=60, redraw=True), fromcurrent=True, transition=dict(duration=0)),
                        ],
                    ),
                    dict(
                        label="pause",
                        method="animate",
                        args=[
                            [None],
                            dict(mode="immediate", frame=dict(duration=0, redraw=False), transition=dict(duration=0)),
                        ],
                    ),
                ],
            )
        ],  # fmt: skip
    )


def view_figure(
    result: Result, *, every: int | None = None, frames: int | None = None, stretch: float = 1.0, colour: str = "state"
):
    """The interactive figure (a ``plotly.graph_objects.Figure``) of the frames chosen as
    ``ballchain animate`` chooses them (``every`` K-th, or ``frames`` spread evenly;
    default: ``default_frames``).  The scene is in true proportions; ``stretch`` > 1 draws
    the horizontal lengths that many times longer than the vertical ones (the title says so).
    ``colour``: ``state`` (free, locked, landed segments) or ``tension`` (every point by
    ``frame_tension`` in m g, the colours spanning 99% of the shown values)."""
    if not (np.isfinite(stretch) and stretch > 0):
        raise ValueError(f"--stretch: expected a number > 0, got {stretch!r}")
    if colour not in COLOURINGS:
        raise ValueError(f"--colour: expected one of {', '.join(COLOURINGS)}, got {colour!r}")
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    if every is None and frames is None:
        frames = min(default_frames(result), len(result.frame_t))
    idx = frame_indices(len(result.frame_t), every=every, frames=frames)
    unit = result.params.half_length
    pts_all = np.round(result.points(idx) / unit, 4)  # units of b; 1e-4 b is finer than any screen
    lo, hi = np.nanmin(pts_all.reshape(-1, 3), axis=0), np.nanmax(pts_all.reshape(-1, 3), axis=0)
    span = float(max(hi[0] - lo[0], hi[1] - lo[1], 1.0))
    cx, cy = 0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])
    fig = make_subplots(rows=1, cols=2, column_widths=[0.62, 0.38], specs=[[{"type": "scene"}, {"type": "xy"}]],
                        subplot_titles=("the chain (drag to orbit)", "the top end"))  # fmt: skip
    t_ff = result.t_ff
    tau = np.asarray(result.frame_t)[idx] / t_ff
    if colour == "tension":
        p = result.params
        tension = np.asarray(result.frame_tension, dtype=float)[idx] / (p.segment_mass * p.gravity)
        if not np.isfinite(tension).all():
            raise ValueError("--colour tension: this result has no tension (a file written before format 6)")
        vmax = max(float(np.percentile(np.abs(tension), 99.0)), 1e-12)

        def chain(k, i):
            return [_tension_trace(pts_all[k], np.round(tension[k], 4), vmax, go)]
    else:

        def chain(k, i):
            return _chain_traces(pts_all[k], segment_states(result, int(i)), go)

    for tr in chain(0, idx[0]):
        fig.add_trace(tr, row=1, col=1)
    n_chain = len(fig.data)
    z0 = result.z0 / unit
    zmax = float(max(hi[2], z0)) * 1.02
    zmin = min(float(lo[2]), 0.0) - 0.5
    h = max(0.6 * span, 0.5 * MIN_WIDTH * (zmax - zmin) / stretch)  # half the box's horizontal side
    fig.add_trace(go.Mesh3d(x=[cx - h, cx + h, cx + h, cx - h], y=[cy - h, cy - h, cy + h, cy + h], z=[0, 0, 0, 0],
                            i=[0, 0], j=[1, 2], k=[2, 3], color="#c8b48c", opacity=0.35, name="floor",
                            hoverinfo="skip", showlegend=False), row=1, col=1)  # fmt: skip
    tt = np.asarray(result.t) / t_ff
    fig.add_trace(go.Scatter(x=tt, y=np.asarray(result.z_top) / unit, mode="lines", name="z_top",
                             line=dict(color="#2ca02c")), row=1, col=2)  # fmt: skip
    tf = np.linspace(0.0, 1.0, 200)
    fig.add_trace(go.Scatter(x=tf, y=z0 * (1.0 - tf**2), mode="lines", name="free fall",
                             line=dict(color="#555555", dash="dash")), row=1, col=2)  # fmt: skip
    fig.add_trace(go.Scatter(x=[tau[0]], y=[pts_all[0, 0, 2]], mode="markers", name="now",
                             marker=dict(size=11, color="#d62728")), row=1, col=2)  # fmt: skip
    marker = len(fig.data) - 1
    fig.frames = [
        go.Frame(
            name=str(k),
            traces=[*range(n_chain), marker],
            data=[
                *chain(k, i),
                go.Scatter(x=[tau[k]], y=[pts_all[k, 0, 2]]),
            ],
        )  # fmt: skip
        for k, i in enumerate(idx)
    ]
    steps = [dict(method="animate", label=f"{tau[k]:.3f}",
                  args=[[str(k)], dict(mode="immediate", frame=dict(duration=0, redraw=True), transition=dict(duration=0))])
             for k in range(len(idx))]  # fmt: skip
    # the box's sides in proportion to the lengths they span (times ``stretch`` across)
    sides = np.array([2 * h * stretch, 2 * h * stretch, zmax - zmin])
    sides = sides / sides.max()
    shape = "true proportions" if stretch == 1 else f"horizontal lengths drawn {stretch:.3g}x the vertical"
    fig.update_layout(
        title=f"ballchain: {run_title(result, sep=' | ')}<br><sup>lengths in b, time in t_ff; the chain in {shape}</sup>",
        scene=dict(
            xaxis=dict(range=[cx - h, cx + h], title="x", nticks=TICKS),
            yaxis=dict(range=[cy - h, cy + h], title="y", nticks=TICKS),
            zaxis=dict(range=[zmin, zmax], title="z"),
            aspectmode="manual",
            aspectratio=dict(x=sides[0], y=sides[1], z=sides[2]),
            camera=dict(eye=dict(x=1.25, y=1.25, z=0.3)),
        ),  # fmt: skip
        xaxis=dict(title="t / t_ff"),
        yaxis=dict(title="z_top / b", range=[min(0.0, float(np.nanmin(pts_all[:, 0, 2]))) - 0.5, zmax]),
        **_player(steps),
        legend=dict(x=0.0, y=1.0),
        margin=dict(l=10, r=10, t=90, b=40),
    )
    return fig


def write_view(
    result: Result,
    path,
    *,
    every: int | None = None,
    frames: int | None = None,
    stretch: float = 1.0,
    colour: str = "state",
) -> Path:
    """Write the view to one self-contained HTML file (plotly.js embedded); returns the path."""
    p = Path(path)
    tmp = p.with_name(f".{p.name}.tmp")
    view_figure(result, every=every, frames=frames, stretch=stretch, colour=colour).write_html(tmp, include_plotlyjs=True, full_html=True,
                                                              auto_play=False)  # fmt: skip
    tmp.replace(p)
    return p
