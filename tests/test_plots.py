"""Figures of a real run: every figure's artists hold the result's own data (in the
stated units), and the command writes every file."""

import numpy as np
import pytest
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.plots import FIGURES, fall_figure, floor_figure, lock_map_figure, pile_figure
from ballchain.records.files import save_result


@pytest.fixture(scope="module")
def run():
    return simulate(
        ChainParams.from_chain(10, length_m=0.5, mass_kg=0.02),
        InitialCondition(eps=0.05),
        SolverOptions(frames_per_tff=200),
    )


def test_fall_figure_is_z_top_and_free_fall(run):
    fig = fall_figure(run)
    top, free = fig.axes[0].lines[:2]
    np.testing.assert_array_equal(top.get_xdata(), run.t / run.t_ff)
    np.testing.assert_array_equal(top.get_ydata(), run.z_top / run.z0)
    x = free.get_xdata()
    np.testing.assert_allclose(free.get_ydata(), 1.0 - x**2)


def test_floor_figure_in_units_of_the_weight(run):
    fig = floor_figure(run)
    scale, pull = fig.axes[0].lines[0], fig.axes[1].lines[0]
    mg = run.params.segment_mass * run.params.gravity
    np.testing.assert_allclose(scale.get_ydata(), run.frame_scale_force / (10 * mg), rtol=1e-14)
    np.testing.assert_allclose(pull.get_ydata(), run.frame_pile_pull[:, 2] / mg, rtol=1e-14)


def test_pile_figure_draws_the_landed_segments_where_they_landed(run):
    fig = pile_figure(run)
    lc = fig.axes[0].collections[0]
    segs = np.array(lc.get_segments())
    assert segs.shape == (10, 2, 2)  # every segment landed
    b = run.params.half_length
    np.testing.assert_allclose(segs[:, 0], run.anchor_pos[:-1, :2] / b)
    np.testing.assert_allclose(segs[:, 1], run.anchor_pos[1:, :2] / b)
    np.testing.assert_allclose(np.linalg.norm(segs[:, 0] - segs[:, 1], axis=1), 2.0, atol=1e-6)  # lying flat
    np.testing.assert_allclose(lc.get_array(), np.maximum(run.anchor_t[:-1], run.anchor_t[1:]) / run.t_ff)


def test_lock_map_is_the_lock_rows(run):
    fig = lock_map_figure(run)
    pts = fig.axes[0].collections[0].get_offsets()
    lock = run.event_kind == 1
    assert lock.sum() > 5
    np.testing.assert_allclose(pts[:, 0], run.event_t[lock] / run.t_ff)
    np.testing.assert_allclose(pts[:, 1], run.event_pos[lock, 2] / run.z0)


def test_plot_command_writes_every_figure(run, tmp_path):
    f = tmp_path / "run.h5"
    save_result(run, f)
    res = CliRunner().invoke(app, ["plot", str(f), "--out", str(tmp_path / "figs")])
    assert res.exit_code == 0, res.output
    for name in FIGURES:
        for fmt in ("png", "pdf"):
            p = tmp_path / "figs" / f"{name}.{fmt}"
            assert p.stat().st_size > 1000, p
    bad = CliRunner().invoke(app, ["plot", str(f), "--formats", "bmp"])
    assert bad.exit_code == 2 and "--formats" in bad.output


def test_every_figure_names_the_event_method_and_no_law_by_default(run):
    """A run with the defaults: its figures name the event method, no step and no law."""
    from ballchain.contacts.registry import all_params

    for name, make in FIGURES.items():
        title = make(run).axes[0].get_title()
        assert "method event" in title and "dt" not in title, (name, title)
        assert not any(p.flag in title for p in all_params().values()), (name, title)


def test_a_rattle_run_with_a_law_says_so_in_every_figure_and_the_animation():
    """A RATTLE run with Newton's restitution at the bend limit: every figure's title names
    the method, its step and the law's flag and value (and nothing of the other laws)."""
    from ballchain.plots import ChainAnimation, run_title

    r = simulate(
        ChainParams(segments=4, restitution_lock=0.5), InitialCondition(eps=0.05),
        SolverOptions(method="rattle", dt=0.05, until=0.3),
    )  # fmt: skip
    want = "method rattle (dt 0.05 t_ff/N) | --restitution-lock 0.5"
    assert run_title(r).splitlines()[1] == want
    for name, make in FIGURES.items():
        title = make(r).axes[0].get_title()
        assert want in title and "--friction" not in title and "--restitution-floor" not in title, (name, title)
    assert want in ChainAnimation(r).title.get_text()
