"""The animation of a real run (``ballchain animate``): the files read back with the
frames asked for, every view draws the result's own points (units of b), the pile is the
landed segments and the marks are exactly the locked hinges; errors are one line, exit 2."""

import io
import subprocess
import sys

import imageio.v2 as imageio
import numpy as np
import pytest
from typer.testing import CliRunner

from ballchain import cli
from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.plots.animate import AnimationError, ChainAnimation, frame_indices, write_animation
from ballchain.records.files import save_result


@pytest.fixture(scope="module")
def run():
    return simulate(ChainParams(segments=6), InitialCondition(eps=0.05), SolverOptions(frames_per_tff=60))


@pytest.fixture(scope="module")
def si_run():  # b != 1: positions must be divided by it
    return simulate(
        ChainParams.from_chain(6, length_m=0.3, mass_kg=0.01),
        InitialCondition(eps=0.05),
        SolverOptions(frames_per_tff=60),
    )


@pytest.fixture(scope="module")
def run_file(run, tmp_path_factory):
    f = tmp_path_factory.mktemp("anim") / "run.h5"
    save_result(run, f)
    return f


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def read_frames(path):
    with imageio.get_reader(str(path)) as r:
        return [np.asarray(f)[..., :3] for f in r]


# --------------------------------------------------------------------------- frames
def test_frame_indices():
    np.testing.assert_array_equal(frame_indices(7), np.arange(7))
    np.testing.assert_array_equal(frame_indices(10, every=3), [0, 3, 6, 9])
    for n, k in ((138, 12), (138, 138), (10, 2), (5, 1), (101, 100)):
        idx = frame_indices(n, frames=k)
        assert idx.size == k and idx[0] == 0 and (k == 1 or idx[-1] == n - 1)
        assert np.all(np.diff(idx) >= 1) and idx.max() < n
    for kw, word in (
        (dict(every=0), "--every"),
        (dict(frames=0), "--frames"),
        (dict(frames=11), "only 10"),
        (dict(every=2, frames=3), "exclude"),
    ):
        with pytest.raises(AnimationError, match=word):
            frame_indices(10, **kw)


# --------------------------------------------------------------------------- artists
def _frames_to_check(r):
    """Frames with some hinges locked and some free, some segments landed and some not,
    the first and the last."""
    locked = r.frame_locked.sum(axis=1)
    a = r.frame_anchored
    landed = (a[:, :-1] & a[:, 1:]).sum(axis=1)
    n = r.params.segments
    mixed_lock = np.flatnonzero((locked > 0) & (locked < n - 1))
    mixed_pile = np.flatnonzero((landed > 0) & (landed < n))
    assert mixed_lock.size and mixed_pile.size
    return sorted(
        {0, int(mixed_lock[len(mixed_lock) // 2]), int(mixed_pile[0]), int(mixed_pile[-1]), r.frame_t.size - 1}
    )


@pytest.mark.parametrize("which", ["run", "si_run"])
def test_every_view_draws_the_points_the_pile_and_the_locked_hinges(which, request):
    r = request.getfixturevalue(which)
    b = r.params.half_length
    anim = ChainAnimation(r)
    for f in _frames_to_check(r):
        img = anim.render(f)  # the path the writer takes (blitting)
        assert img.shape == (576, 1024, 3) and anim.frame == f
        pts = r.points()[f] / b
        x, y, z = anim.chain3d.get_data_3d()
        np.testing.assert_allclose(np.column_stack([x, y, z]), pts, rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.column_stack(anim.chain_side.get_data()), pts[:, [0, 2]], atol=1e-12)
        np.testing.assert_allclose(np.column_stack(anim.chain_top.get_data()), pts[:, [0, 1]], atol=1e-12)

        locked = np.flatnonzero(r.frame_locked[f])  # hinge k is point k + 1
        x, y, z = anim.locks3d.get_data_3d()
        np.testing.assert_allclose(np.column_stack([x, y, z]).reshape(-1, 3), pts[locked + 1], atol=1e-12)
        np.testing.assert_allclose(
            np.column_stack(anim.locks_side.get_data()).reshape(-1, 2), pts[locked + 1][:, [0, 2]], atol=1e-12
        )
        np.testing.assert_allclose(
            np.column_stack(anim.locks_top.get_data()).reshape(-1, 2), pts[locked + 1][:, [0, 1]], atol=1e-12
        )

        a = r.frame_anchored[f]
        landed = np.flatnonzero(a[:-1] & a[1:])
        want = np.stack([pts[landed], pts[landed + 1]], axis=1)
        got3 = np.array(anim.pile3d._segments3d).reshape(-1, 2, 3)
        np.testing.assert_allclose(got3, want, atol=1e-12)
        np.testing.assert_allclose(np.array(anim.pile_top.get_segments()).reshape(-1, 2, 2), want[:, :, :2], atol=1e-12)
        np.testing.assert_allclose(
            np.array(anim.pile_side.get_segments()).reshape(-1, 2, 2), want[:, :, [0, 2]], atol=1e-12
        )
        assert f"t = {r.frame_t[f] / r.t_ff:.3f} t_ff" in anim.title.get_text()


# --------------------------------------------------------------------------- files
def test_mp4_and_gif_read_back_with_the_frames_asked_for(run_file, run, tmp_path):
    mp4, gif = tmp_path / "fall.mp4", tmp_path / "fall.GIF"
    res = invoke("animate", run_file, "--out", mp4, "--frames", 12, "--fps", 10, "-q")
    assert res.exit_code == 0, res.output
    assert res.stdout.strip() == str(mp4)
    res = invoke("animate", run_file, "--out", gif, "--every", 10)
    assert res.exit_code == 0, res.output
    for path, count in ((mp4, 12), (gif, len(range(0, run.frame_t.size, 10)))):
        frames = read_frames(path)
        assert len(frames) == count, path
        assert {f.shape for f in frames} == {(576, 1024, 3)}, path
        assert len({f.tobytes() for f in frames}) > count // 2, path  # the chain moves
    with imageio.get_reader(str(mp4)) as r:
        assert r.get_meta_data()["fps"] == 10
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fall.GIF", "fall.mp4"]  # no temporary left


def test_existing_output_needs_force(run_file, tmp_path):
    out = tmp_path / "fall.gif"
    out.write_bytes(b"old")
    res = invoke("animate", run_file, "--out", out, "--frames", 2)
    assert res.exit_code == 2 and out.read_bytes() == b"old"
    assert "--force" in res.stderr
    res = invoke("animate", run_file, "--out", out, "--frames", 2, "--force")
    assert res.exit_code == 0, res.output
    assert len(read_frames(out)) == 2


@pytest.mark.parametrize(
    "args, word",
    [
        (["--out", "fall.avi"], ".mp4 or .gif"),
        (["--out", "fall"], ".mp4 or .gif"),
        (["--fps", "0"], "--fps"),
        (["--fps", "x"], "--fps"),
        (["--every", "0"], "--every"),
        (["--frames", "0"], "--frames"),
        (["--frames", "100000"], "only"),
        (["--every", "2", "--frames", "3"], "exclude"),
        (["--out", "no/such/dir/fall.mp4"], "does not exist"),
    ],
)
def test_bad_options_one_line_exit_2(run_file, tmp_path, monkeypatch, args, word):
    monkeypatch.chdir(tmp_path)
    res = invoke("animate", run_file, *args)
    assert res.exit_code == 2, res.output
    err = res.stderr.strip()
    assert len(err.splitlines()) == 1 and err.startswith("error: ") and word in err, err
    assert "Traceback" not in res.output
    assert list(tmp_path.iterdir()) == []


def test_bad_result_file_one_line_exit_2(tmp_path):
    text = tmp_path / "notes.txt"
    text.write_text("hello\n")
    for f, word in ((tmp_path / "missing.h5", "no such file"), (text, "not an HDF5 file")):
        res = invoke("animate", f, "--out", tmp_path / "a.mp4")
        assert res.exit_code == 2 and res.stderr.startswith("error: ") and word in res.stderr, res.stderr
        assert len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "a.mp4").exists()


def test_progress_bar_on_its_console_and_quiet(run_file, tmp_path, monkeypatch):
    from rich.console import Console

    buf = io.StringIO()
    monkeypatch.setattr(cli.running, "_progress_console", lambda: Console(file=buf, force_terminal=True, width=100))
    assert invoke("animate", run_file, "--out", tmp_path / "a.gif", "--frames", 3).exit_code == 0
    assert "animating" in buf.getvalue() and "3/3" in buf.getvalue()
    buf.truncate(0)
    buf.seek(0)
    assert invoke("animate", run_file, "--out", tmp_path / "b.gif", "--frames", 3, "-q").exit_code == 0
    assert buf.getvalue() == ""


def test_interrupt_leaves_no_file(run, tmp_path):
    def stop(done, total):
        if done == 2:
            raise KeyboardInterrupt

    for name in ("a.mp4", "a.gif"):
        with pytest.raises(KeyboardInterrupt):
            write_animation(run, tmp_path / name, frames=4, progress=stop)
    assert list(tmp_path.iterdir()) == []


def test_animation_does_not_import_the_engine():
    code = (
        "import sys, ballchain.plots.animate, ballchain.plots; "
        "assert 'ballchain.engine' not in sys.modules and 'numba' not in sys.modules, sorted(sys.modules)"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
