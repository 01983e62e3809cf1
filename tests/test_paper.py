"""``ballchain paper --quick``: every figure is written, runs are cached, and the plotted
data are the runs' and the theory's."""

import math

import numpy as np
import pytest
from typer.testing import CliRunner

from ballchain import theory
from ballchain.cli import app
from ballchain.plots import paper as pp
from ballchain.records.files import load_result

NAMES = ("fig2_strobe", "fig3_lock_map", "fig4_pile", "fig5_alpha", "fig6_hamm_geminard", "fig7_pivot_rod")


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    res = CliRunner().invoke(app, ["paper", "--quick", "--out", str(out), "--formats", "png"])
    assert res.exit_code == 0, res.output
    return out, res


def test_every_figure_written_and_runs_cached(made):
    out, res = made
    for name in NAMES:
        assert (out / f"{name}.png").stat().st_size > 5000, name
    cached = sorted((out / "cache").glob("run-*.h5"))
    assert len(cached) == 4  # the main chain and three alphas
    again = CliRunner().invoke(app, ["paper", "--quick", "--out", str(out), "--formats", "png"])
    assert again.exit_code == 0 and "running" not in again.output  # (stderr is mixed in by CliRunner)
    assert sorted((out / "cache").glob("run-*.h5")) == cached


def _runs(out):
    return [load_result(p) for p in sorted((out / "cache").glob("run-*.h5"))]


def test_fig5_and_fig6_plot_the_runs(made):
    out, _ = made
    runs = _runs(out)
    series = [r for r in runs if r.params.segments == 16]
    fig = pp.fig5_alpha(series)
    lines = fig.axes[0].lines[: len(series)]
    for line, r in zip(lines, sorted(series, key=lambda r: r.params.alpha)):
        tau = r.t / r.t_ff
        sel = (tau >= 0.38) & (tau <= 0.84)
        np.testing.assert_array_equal(line.get_xdata(), tau[sel])
        np.testing.assert_array_equal(line.get_ydata(), r.z_top[sel] / r.z0)
    fig6 = pp.fig6_hamm_geminard(runs)
    marks = [ln for ln in fig6.axes[0].lines if ln.get_marker() == "o" and len(ln.get_xdata())]
    placed = [r for r in runs if 0 < r.t_fall / r.t_ff < math.sqrt(math.pi / 2)]
    assert len(marks) == len(placed)
    for ln in marks:
        gam, ratio = ln.get_xdata()[0], ln.get_ydata()[0]
        assert theory.hamm_geminard_time_ratio(gam) == pytest.approx(ratio, rel=1e-9)
    # the measured gammas: one open square per run, at that run's floor_gamma
    from ballchain.records.measures import floor_gamma

    squares = [ln for ln in fig6.axes[0].lines if ln.get_gid() == "measured"]
    expected = sorted((floor_gamma(r).gamma, r.t_fall / r.t_ff) for r in placed if math.isfinite(floor_gamma(r).gamma))
    assert sorted((ln.get_xdata()[0], ln.get_ydata()[0]) for ln in squares) == expected


def test_fig2_and_fig4_draw_the_main_run(made):
    out, _ = made
    main = [r for r in _runs(out) if r.params.segments == 12][0]
    fig = pp.fig2_strobe(main)
    n_views = len(np.arange(0.0, main.frame_t[-1] / main.t_ff + 1e-9, pp.STROBE))
    views = fig.axes[0].lines
    assert len(views) == n_views + 1  # and the floor line
    f0 = pp._frame_at(main, 0.0)
    np.testing.assert_allclose(views[0].get_ydata(), main.points()[f0, :, 2] / main.params.half_length)
    np.testing.assert_array_equal(fig.axes[1].lines[0].get_ydata(), main.z_top / main.z0)
    fig4 = pp.fig4_pile(main)
    before, after = fig4.axes[0].collections
    a = main.anchor_t
    when = np.maximum(a[:-1], a[1:]) / main.t_ff
    assert len(before.get_segments()) == int(np.sum(when < pp.SPLIT))
    assert len(after.get_segments()) == int(np.sum(when >= pp.SPLIT))


def test_fig7_is_the_theory():
    fig = pp.fig7_pivot_rod(n=5)
    first = fig.axes[0].lines[0]
    np.testing.assert_allclose(first.get_ydata(), theory.pivot_rod_vertical_force(first.get_xdata(), 0.0))
    zero = [ln for ln in fig.axes[1].lines][0]
    for t0, s in zip(zero.get_xdata(), zero.get_ydata()):
        assert abs(theory.pivot_rod_impulse(t0, s)) < 1e-8


def test_a_changed_engine_does_not_reuse_the_cache(tmp_path, monkeypatch):
    """A run cached by other engine code is not taken for this engine's (the key holds a
    hash of the engine's source, not only the package version)."""
    from ballchain import paper
    from ballchain.model import ChainParams, InitialCondition, SolverOptions

    args = (ChainParams(segments=3), InitialCondition(), SolverOptions(until=0.05))
    notes = []
    paper.cached_run(*args, tmp_path, notes.append)
    paper.cached_run(*args, tmp_path, notes.append)
    assert len(notes) == 1 and notes[0].startswith("running")  # simulated once, then reused
    assert len(list(tmp_path.glob("run-*.h5"))) == 1
    monkeypatch.setattr(paper, "engine_fingerprint", lambda: "another engine")
    paper.cached_run(*args, tmp_path, notes.append)
    assert len(notes) == 2 and notes[1].startswith("running")  # simulated again, under a new name
    assert len(list(tmp_path.glob("run-*.h5"))) == 2
