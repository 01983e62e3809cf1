"""An animation of one run: the chain falling and piling up (``ballchain animate``).

Each frame shows, from the Result alone (docs/measures.md, section 6, conventions): a 3D
view with the floor plane z = 0, a side view (x-z) and a top view (x-y).  In every view
the chain is the polyline of its points ``Result.points()`` in units of b (point 0, the
top end, first), the pile is the landed segments (both ends anchored at that frame),
and the locked hinges are marked (hinge k is point k + 1).  The title gives the time in
units of t_ff.  The axes' limits are fixed over the whole animation.

Frames are drawn on an Agg canvas and read back as RGB arrays (no savefig per frame);
``write_animation`` streams them to an ``.mp4`` (imageio with the ffmpeg binary that
imageio-ffmpeg ships, never a system one) or a ``.gif`` (Pillow).  matplotlib only;
never imported by the engine.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

from ..records.result import Result
from .titles import run_title

SUFFIXES = (".mp4", ".gif")
SIZE_PX = (1024, 576)  # multiples of 16: what H.264 encoders want, no rescaling
DPI = 100

CHAIN_COLOR = "C0"
PILE_COLOR = "C1"
LOCK_COLOR = "C3"


class AnimationError(ValueError):
    """Bad animation options or a result with nothing to show; the message is one line."""


def check_options(fps: float = 25.0, every: int | None = None, frames: int | None = None) -> None:
    """Raise AnimationError (one line, naming the option) for a bad ``fps``, ``every`` or
    ``frames``; these need no result."""
    if not (isinstance(fps, (int, float)) and np.isfinite(fps) and fps > 0):
        raise AnimationError(f"--fps must be a positive number, got {fps}")
    if every is not None and frames is not None:
        raise AnimationError("--every and --frames exclude each other: give one")
    if every is not None and every < 1:
        raise AnimationError(f"--every must be >= 1, got {every}")
    if frames is not None and frames < 1:
        raise AnimationError(f"--frames must be >= 1, got {frames}")


def frame_indices(n_frames: int, every: int | None = None, frames: int | None = None) -> np.ndarray:
    """Which of a run's ``n_frames`` frames to draw: all of them (default), every K-th
    from the first (``every``), or exactly ``frames`` frames spread evenly over the run,
    the first and the last included."""
    check_options(every=every, frames=frames)
    if n_frames < 1:
        raise AnimationError("the result has no frames to animate")
    if frames is not None:
        if frames > n_frames:
            raise AnimationError(f"--frames {frames}: the result has only {n_frames} frames")
        if frames == 1:
            return np.array([0], dtype=np.int64)
        # step >= 1, so the rounded positions are distinct and increasing
        return np.floor(np.linspace(0.0, n_frames - 1, frames) + 0.5).astype(np.int64)
    return np.arange(0, n_frames, 1 if every is None else every, dtype=np.int64)


def _limits(r: Result, idx: np.ndarray, chunk: int = 256):
    """Min and max of the points (units of b) over the frames ``idx``, chunk by chunk."""
    b = r.params.half_length
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for s in range(0, idx.size, chunk):
        p = r.points(idx[s : s + chunk]) / b
        lo = np.minimum(lo, np.nanmin(p.reshape(-1, 3), axis=0))
        hi = np.maximum(hi, np.nanmax(p.reshape(-1, 3), axis=0))
    return lo, hi


class ChainAnimation:
    """The animation's figure; ``draw(frame)`` sets every artist to frame ``frame`` of the
    run (an index into its frames), ``render(frame)`` returns its RGB image (H, W, 3).

    Artists (the tests read their data): ``chain3d``, ``chain_side``, ``chain_top`` (the
    polyline of points 0..N), ``pile3d``, ``pile_side``, ``pile_top`` (collections of the
    landed segments, each from point i to point i + 1), ``locks3d``, ``locks_side``,
    ``locks_top`` (markers on the locked hinges' points), ``title``.
    """

    def __init__(self, r: Result, frames=None):
        self.r = r
        n = int(np.asarray(r.frame_t).shape[0])
        idx = np.arange(n) if frames is None else np.asarray(frames, dtype=np.int64)
        if idx.size == 0 or n == 0:
            raise AnimationError("the result has no frames to animate")
        self.b = float(r.params.half_length)
        self.anchored = np.asarray(r.frame_anchored, dtype=bool)
        self.locked = np.asarray(r.frame_locked, dtype=bool)

        lo, hi = _limits(r, idx)
        lo[2] = min(lo[2], 0.0)  # the floor is always in view
        span = max(float(np.max(hi[:2] - lo[:2])), 2.0)  # at least one segment wide
        mid = 0.5 * (lo[:2] + hi[:2])
        half = 0.55 * span
        xy_lim = [(mid[0] - half, mid[0] + half), (mid[1] - half, mid[1] + half)]
        z_lim = (lo[2] - 0.02 * (hi[2] - lo[2]) - 0.5, hi[2] + 0.02 * (hi[2] - lo[2]) + 0.5)

        w, h = SIZE_PX
        fig = Figure(figsize=(w / DPI, h / DPI), dpi=DPI)
        self.canvas = FigureCanvasAgg(fig)
        self.fig = fig
        gs = fig.add_gridspec(
            1, 3, width_ratios=(1.5, 1.0, 1.0), left=0.02, right=0.98, bottom=0.12, top=0.87, wspace=0.3
        )

        # 3D view: floor plane first, then the chain, the pile and the locks over it
        ax3 = fig.add_subplot(gs[0, 0], projection="3d", computed_zorder=False)
        (x0, x1), (y0, y1) = xy_lim
        floor = Poly3DCollection(
            [[(x0, y0, 0.0), (x1, y0, 0.0), (x1, y1, 0.0), (x0, y1, 0.0)]],
            facecolors=(0.6, 0.6, 0.6, 0.35),
            edgecolors=(0.4, 0.4, 0.4, 0.6),
            zorder=0,
        )
        ax3.add_collection3d(floor, autolim=False)
        self.floor3d = floor
        self.pile3d = Line3DCollection([], colors=PILE_COLOR, linewidths=2.5, zorder=3)
        ax3.add_collection3d(self.pile3d, autolim=False)
        (self.chain3d,) = ax3.plot([], [], [], color=CHAIN_COLOR, lw=1.2, zorder=2)
        (self.locks3d,) = ax3.plot([], [], [], ls="none", marker="o", ms=4, color=LOCK_COLOR, zorder=4)
        ax3.set(xlim=xy_lim[0], ylim=xy_lim[1], zlim=z_lim, xlabel="x / b", ylabel="y / b", zlabel="z / b")
        ax3.set_box_aspect((1.0, 1.0, 1.6))
        ax3.view_init(elev=18, azim=-60)
        for axis in (ax3.xaxis, ax3.yaxis, ax3.zaxis):
            axis.set_major_locator(MaxNLocator(4))
        ax3.tick_params(labelsize=8)
        ax3.set_title("3D", fontsize=10)
        self.ax3d = ax3

        # side view (x-z) and top view (x-y): true proportions, unless the chain is too
        # tall for the side panel, whose x is then stretched (the title says by how much)
        def flat(ax, lims, xlabel, ylabel, title, equal=True):
            ax.set(xlim=lims[0], ylim=lims[1], xlabel=xlabel, ylabel=ylabel)
            if equal:
                ax.set_aspect("equal", adjustable="box")
            ax.set_title(title, fontsize=10)
            pile = LineCollection([], colors=PILE_COLOR, linewidths=2.5, zorder=3)
            ax.add_collection(pile)
            (chain,) = ax.plot([], [], color=CHAIN_COLOR, lw=1.2, zorder=2)
            (locks,) = ax.plot([], [], ls="none", marker="o", ms=4, color=LOCK_COLOR, zorder=4)
            return chain, pile, locks

        self.ax_side = fig.add_subplot(gs[0, 1])
        self.ax_side.axhspan(z_lim[0] - 10 * (z_lim[1] - z_lim[0]), 0.0, color="0.85", zorder=0)
        self.ax_side.axhline(0.0, color="0.4", lw=0.8, zorder=1)
        box = self.ax_side.get_position()
        stretch = ((z_lim[1] - z_lim[0]) / (box.height * h)) / ((xy_lim[0][1] - xy_lim[0][0]) / (box.width * w))
        self.side_stretch = max(float(stretch), 1.0)  # pixels per b along x over those along z
        side_title = "side (x-z)" if stretch <= 1.0 else f"side (x-z), x stretched {stretch:.3g}x"
        self.chain_side, self.pile_side, self.locks_side = flat(
            self.ax_side, (xy_lim[0], z_lim), "x / b", "z / b", side_title, equal=stretch <= 1.0
        )
        self.ax_top = fig.add_subplot(gs[0, 2])
        self.chain_top, self.pile_top, self.locks_top = flat(self.ax_top, xy_lim, "x / b", "y / b", "top (x-y)")
        # a legend of the three kinds of artist, once
        fig.legend(
            [self.chain_top, self.pile_top, self.locks_top],
            ["chain", "pile (landed segments)", "locked hinge"],
            loc="lower center",
            ncol=3,
            fontsize=9,
            frameon=False,
        )

        self._head = run_title(r, sep=" | ")  # the chain, the method, the contact laws
        self.title = fig.suptitle("", fontsize=11)
        self.frame = None
        self._background = None
        self.draw(int(idx[0]))

    # ------------------------------------------------------------------ one frame
    def data(self, frame: int):
        """Points (N+1, 3) in units of b, the landed segments' indices, the locked
        hinges' indices at frame ``frame``."""
        pts = self.r.points(frame) / self.b
        a = self.anchored[frame]
        landed = np.flatnonzero(a[:-1] & a[1:])
        locked = np.flatnonzero(self.locked[frame]) if self.locked.shape[1] else np.zeros(0, np.int64)
        return pts, landed, locked

    def draw(self, frame: int) -> None:
        """Set every artist to frame ``frame`` (no rendering)."""
        frame = int(frame)
        pts, landed, locked = self.data(frame)
        seg = np.stack([pts[landed], pts[landed + 1]], axis=1)  # (L, 2, 3)
        hinge = pts[locked + 1]  # hinge k is point k + 1

        self.chain3d.set_data_3d(pts[:, 0], pts[:, 1], pts[:, 2])
        self.pile3d.set_segments(list(seg))
        self.locks3d.set_data_3d(hinge[:, 0], hinge[:, 1], hinge[:, 2])
        for chain, pile, locks, (i, j) in (
            (self.chain_side, self.pile_side, self.locks_side, (0, 2)),
            (self.chain_top, self.pile_top, self.locks_top, (0, 1)),
        ):
            chain.set_data(pts[:, i], pts[:, j])
            pile.set_segments(list(seg[:, :, (i, j)]))
            locks.set_data(hinge[:, i], hinge[:, j])

        t = float(np.asarray(self.r.frame_t)[frame]) / self.r.t_ff
        self.title.set_text(
            f"{self._head}\nt = {t:.3f} t_ff    landed {landed.size}/{pts.shape[0] - 1}, locked {locked.size}"
        )
        self.frame = frame

    def _moving(self):
        """The artists that change from frame to frame, in drawing order."""
        return (
            self.chain3d,
            self.pile3d,
            self.locks3d,
            self.chain_side,
            self.pile_side,
            self.locks_side,
            self.chain_top,
            self.pile_top,
            self.locks_top,
            self.title,
        )

    def render(self, frame: int) -> np.ndarray:
        """The RGB image (H, W, 3) uint8 of frame ``frame``.

        Blitting: the first call draws everything that does not move (axes, ticks,
        floor, legend) once and keeps that image; each call then restores it and draws
        only the moving artists over it.  (After the first call those artists are
        marked animated, so ``fig.savefig`` would leave them out: for a still, use
        ``animation_figure``.)"""
        if self._background is None:
            for a in self._moving():
                a.set_animated(True)
            self.canvas.draw()
            self._background = self.canvas.copy_from_bbox(self.fig.bbox)
        self.draw(frame)
        self.canvas.restore_region(self._background)
        for col in (self.pile3d,):
            col.do_3d_projection()  # Axes3D.draw does this for the artists it draws itself
        for a in self._moving():
            (self.fig if a is self.title else a.axes).draw_artist(a)
        return np.asarray(self.canvas.buffer_rgba())[..., :3].copy()


def animation_figure(r: Result, frame: int = 0) -> Figure:
    """The animation's figure at one frame (e.g. for a still: ``.savefig``)."""
    return ChainAnimation(r, frames=[frame]).fig


# --------------------------------------------------------------------------- writing
def _write_mp4(path: Path, images, fps: float) -> None:
    import imageio.v2 as imageio  # lazy: only when writing
    import imageio_ffmpeg  # noqa: F401  (the ffmpeg binary imageio uses: imageio_ffmpeg.get_ffmpeg_exe())

    writer = imageio.get_writer(
        str(path),
        format="FFMPEG",
        mode="I",
        fps=fps,
        codec="libx264",
        pixelformat="yuv420p",
        quality=7,
        macro_block_size=16,
        ffmpeg_log_level="error",
    )
    try:
        for img in images:
            writer.append_data(img)
    finally:
        writer.close()


def _write_gif(path: Path, images, fps: float) -> None:
    from PIL import Image  # Pillow (a dependency, and matplotlib's)

    frames = [Image.fromarray(img).quantize(colors=128, method=Image.Quantize.MEDIANCUT) for img in images]
    if not frames:
        raise AnimationError("no frames to write")
    frames[0].save(
        path,
        format="GIF",
        save_all=True,
        append_images=frames[1:],
        duration=max(int(round(1000.0 / fps)), 10),
        loop=0,
        optimize=False,
        disposal=1,
    )


def write_animation(
    r: Result,
    path,
    *,
    fps: float = 25.0,
    every: int | None = None,
    frames: int | None = None,
    force: bool = False,
    progress=None,
) -> Path:
    """Write the animation of ``r`` to ``path`` (.mp4 or .gif by its suffix) and return
    the path.  ``every``/``frames`` thin the run's frames (``frame_indices``); ``fps``
    is the playback rate.  ``progress(done, total)`` is called after every frame.  The
    file is written to a temporary name beside it and moved into place at the end:
    an error or Ctrl-C leaves no half-written file."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise AnimationError(f"--out: expected a .mp4 or .gif file name, got {str(path)!r}")
    check_options(fps, every, frames)
    if path.exists() and not force:
        raise FileExistsError(f"--out: file {str(path)!r} exists (use --force to overwrite)")
    idx = frame_indices(int(np.asarray(r.frame_t).shape[0]), every=every, frames=frames)
    anim = ChainAnimation(r, frames=idx)

    def images():
        for done, f in enumerate(idx, 1):
            img = anim.render(int(f))
            if progress is not None:
                progress(done, idx.size)
            yield img

    tmp = path.with_name(f".{path.stem}.{os.getpid()}.part{suffix}")  # same directory: os.replace is atomic
    try:
        (_write_mp4 if suffix == ".mp4" else _write_gif)(tmp, images(), float(fps))
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path
