"""ballchain view: one self-contained HTML file, rendered in a real browser (Debian's
chromium, headless) to a screenshot in which the chain must be drawn: the chain's colour
is on the picture, and absent from the same page with the chain's traces emptied; and the
3D box is wide enough to read (its walls span 18 % of the page or more)."""

import os
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.plots.view import COLORS, MIN_WIDTH, POINT_BUDGET, TICKS, default_frames, segment_states, view_figure
from ballchain.records.files import save_result

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    r = simulate(ChainParams(segments=10, alpha=0.8), InitialCondition(eps=0.1), SolverOptions(until=0.8))
    path = tmp_path_factory.mktemp("view") / "run.h5"
    save_result(r, path)
    return r, path


def screenshot(html, png, tmp_path):
    if CHROMIUM is None:
        if os.environ.get("CI"):
            pytest.fail("CI must have Debian's chromium for the browser test (.ci/run installs it)")
        pytest.skip("no chromium on this machine (apt-get install chromium)")
    subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-unsafe-swiftshader", "--use-angle=swiftshader", f"--user-data-dir={tmp_path / 'profile'}",
         "--window-size=1400,800", "--virtual-time-budget=15000", f"--screenshot={png}", f"file://{html}"],
        capture_output=True, timeout=120, check=True,
    )  # fmt: skip
    return np.asarray(Image.open(png).convert("RGB")).astype(int)


def chain_pixels(img) -> int:
    """Pixels of the free segments' colour in the 3D panel (the left 60 % of the page)."""
    rgb = np.array([int(COLORS["free"][k : k + 2], 16) for k in (1, 3, 5)])
    left = img[:, : int(0.6 * img.shape[1])]
    return int(np.sum(np.all(np.abs(left - rgb) <= 40, axis=-1)))


def box_width(img) -> int:
    """Columns of the 3D box's walls (plotly's scene background, #E5ECF6) in the 3D panel
    (the left 62 % of the page): the width the box is drawn at, in pixels."""
    left = img[:, : int(0.62 * img.shape[1])]
    wall = np.all(np.abs(left - np.array([229, 236, 246])) <= 3, axis=-1)
    cols = np.flatnonzero(wall.sum(axis=0) >= 5)
    return int(cols.max() - cols.min()) if cols.size else 0


@pytest.mark.slow
def test_the_view_is_drawn_in_a_browser(run, tmp_path):
    r, path = run
    html = tmp_path / "fall.html"
    res = CliRunner().invoke(app, ["view", str(path), "--out", str(html)])
    assert res.exit_code == 0, res.output
    text = html.read_text()
    assert 'src="http' not in text and "plotly" in text  # offline: the library is embedded
    img = screenshot(html, tmp_path / "view.png", tmp_path)
    drawn = chain_pixels(img)
    assert box_width(img) >= 0.18 * img.shape[1], box_width(img)  # not a sliver (was 154 px of 1400)
    fig = view_figure(r)
    for k in range(3):  # the chain's traces emptied: the negative control
        fig.data[k].update(x=[], y=[], z=[])
    fig.frames = []
    empty = tmp_path / "empty.html"
    fig.write_html(empty, include_plotlyjs=True, full_html=True)
    blank = chain_pixels(screenshot(empty, tmp_path / "empty.png", tmp_path))
    assert drawn > 300 and blank < 20, (drawn, blank)


def test_frames_states_and_the_size_rule(run, tmp_path):
    r, path = run
    fig = view_figure(r, frames=5)
    assert len(fig.frames) == 5 and fig.layout.sliders[0].steps[-1].label == f"{r.frame_t[-1] / r.t_ff:.3f}"
    # the segments' states: landed where both ends are anchored, locked next to a locked hinge
    i = len(r.frame_t) - 1
    state = segment_states(r, i)
    anchored, locked = r.frame_anchored[i], r.frame_locked[i]
    for s in range(r.params.segments):
        if anchored[s] and anchored[s + 1]:
            assert state[s] == 2
        elif (s > 0 and locked[s - 1]) or (s < r.params.segments - 1 and locked[s]):
            assert state[s] == 1
        else:
            assert state[s] == 0
    assert default_frames(r) == len(r.frame_t)  # a small run keeps every frame
    big = type("R", (), {"params": ChainParams(segments=4096), "frame_t": np.zeros(10_000)})()
    assert default_frames(big) * 4097 <= POINT_BUDGET < (default_frames(big) + 1) * 4097
    for bad in (["--out", str(tmp_path / "v.png")], ["--out", str(tmp_path / "v.html"), "--every", "0"]):
        res = CliRunner().invoke(app, ["view", str(path), *bad])
        assert res.exit_code == 2 and res.output.count("\n") == 1, res.output


@pytest.mark.parametrize("stretch", [1.0, 4.0])
def test_the_scene_is_in_true_proportions_unless_stretched_and_says_so(run, stretch):
    """The box's sides are in proportion to the lengths they span (x and y times the
    stretch asked for), the title says which, and the slider's time is clear of the buttons."""
    r, _ = run
    fig = view_figure(r, stretch=stretch)
    scene = fig.layout.scene
    spans = [scene[a].range[1] - scene[a].range[0] for a in ("xaxis", "yaxis", "zaxis")]
    ratio = scene.aspectratio
    assert scene.aspectmode == "manual"
    assert ratio.x / ratio.z == pytest.approx(stretch * spans[0] / spans[2], rel=1e-12)
    assert ratio.y / ratio.z == pytest.approx(stretch * spans[1] / spans[2], rel=1e-12)
    # a tall, thin chain: the box is drawn at least MIN_WIDTH as wide as tall (its horizontal
    # ranges grow, the proportions stay), with few ticks across, so that they do not overlap
    assert min(ratio.x, ratio.y) >= MIN_WIDTH * ratio.z * (1 - 1e-12)
    assert scene.xaxis.nticks == scene.yaxis.nticks == TICKS
    assert ("true proportions" in fig.layout.title.text) == (stretch == 1.0)
    assert "| method event" in fig.layout.title.text  # what made it (plots.titles.run_title)
    assert ("drawn 4x" in fig.layout.title.text) == (stretch == 4.0)
    assert scene.zaxis.range[0] < 0.0  # the floor and what lies on it inside the box
    (buttons,), (slider,) = fig.layout.updatemenus, fig.layout.sliders
    assert slider.x >= 0.15 and buttons.x < slider.x  # the time above the slider, not under the buttons


def test_a_bad_stretch_is_one_line(run, tmp_path):
    _, path = run
    res = CliRunner().invoke(app, ["view", str(path), "--out", str(tmp_path / "v.html"), "--stretch", "0"])
    assert res.exit_code == 2 and res.stderr.startswith("error: --stretch") and res.stderr.count("\n") == 1


def test_the_chain_coloured_by_its_tension(run, tmp_path):
    """--colour tension: one line through the points, each coloured by the run's tension
    there in m g at that frame (in every animation frame), the scale symmetric about 0;
    a bad colouring, or a file without the tension, is one line."""
    r, path = run
    fig = view_figure(r, frames=4, colour="tension")
    chain = fig.data[0]
    n = r.params.segments
    assert chain.name == "tension" and len(chain.x) == n + 1
    assert chain.marker.cmin == -chain.marker.cmax > -np.inf and chain.marker.cmax > 0
    idx = np.linspace(0, len(r.frame_t) - 1, 4).round().astype(int)
    for k, i in enumerate(idx):
        np.testing.assert_allclose(fig.frames[k].data[0].marker.color, np.round(r.frame_tension[i], 4), atol=1e-12)
    np.testing.assert_allclose(chain.z, np.round(r.points([idx[0]])[0, :, 2] / r.params.half_length, 4))
    res = CliRunner().invoke(app, ["view", str(path), "--out", str(tmp_path / "v.html"), "--colour", "heat"])
    assert res.exit_code == 2 and res.output.count("\n") == 1, res.output
    old = r.__class__(**{**r.__dict__, "frame_tension": np.full_like(r.frame_tension, np.nan)})
    save_result(old, tmp_path / "old.h5")
    res = CliRunner().invoke(
        app, ["view", str(tmp_path / "old.h5"), "--out", str(tmp_path / "o.html"), "--colour", "tension"]
    )
    assert res.exit_code == 2 and "no tension" in res.output and res.output.count("\n") == 1, res.output
