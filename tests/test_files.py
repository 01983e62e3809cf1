"""Result files: exact round trip, atomic writes, no clobbering, clear errors."""

from __future__ import annotations

import dataclasses
import json
import math
import os

import h5py
import numpy as np
import pytest

from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records import files
from ballchain.records.files import (
    FORMAT_NAME,
    FORMAT_VERSION,
    ResultFileError,
    check_writable,
    load_result,
    save_result,
)
from ballchain.records.result import EVENT_KINDS, Result, unit_of


def make_result(
    n=5, frames=7, events=6, steps=40, seed=0, *, ic=True, units="nondimensional", params=None, **over
) -> Result:
    """A synthetic Result with random arrays of the right shapes (not physics)."""
    rng = np.random.default_rng(seed)
    if params is None:
        params = ChainParams(segments=n, alpha=math.pi / 4)
    e = rng.normal(size=(frames, n, 3))
    e /= np.linalg.norm(e, axis=-1, keepdims=True)
    anchor_t = rng.uniform(0, 3, size=n + 1)
    anchor_t[: n // 2] = np.nan
    anchor_t[-1] = 0.0
    kw = dict(
        params=params,
        ic=InitialCondition(kind="helix", eps=0.03, turns=2.0, phase=0.1, seed=7) if ic else None,
        options=SolverOptions(rtol=1e-8, until=0.5),
        version="0.1.0",
        status="landed",
        message="",
        z0=2.0 * n - 0.01,
        t_ff=math.sqrt(2 * (2.0 * n - 0.01)),
        t_fall=float(rng.uniform(1, 2)),
        t_landed=math.nan,
        t=np.sort(rng.uniform(0, 3, size=steps)),
        z_top=rng.normal(size=steps),
        frame_t=np.linspace(0, 3, frames),
        frame_e=e,
        frame_omega=rng.normal(size=(frames, n, 3)),
        frame_anchored=rng.random((frames, n + 1)) < 0.5,
        frame_locked=rng.random((frames, n - 1)) < 0.3,
        frame_floor_force=rng.normal(size=(frames, 3)),
        frame_kinetic=rng.random(frames),
        frame_potential=rng.random(frames),
        frame_lost_locking=np.cumsum(rng.random(frames)),
        frame_lost_landing=np.cumsum(rng.random(frames)),
        frame_lost_damping=np.cumsum(rng.random(frames)),
        frame_pile_pull=rng.normal(size=(frames, 3)),
        frame_scale_force=rng.normal(size=frames),
        frame_floor_impulse=np.cumsum(rng.normal(size=(frames, 3)), axis=0),
        frame_base=np.zeros((frames, 3)),
        frame_base_velocity=np.zeros((frames, 3)),
        frame_lost_sliding=np.cumsum(rng.random(frames)),
        frame_tension=rng.normal(size=(frames, n + 1)),
        event_t=np.sort(rng.uniform(0, 3, size=events)),
        event_kind=rng.integers(1, 9, size=events).astype(np.int8),
        event_index=rng.integers(0, n + 1, size=events).astype(np.int64),
        event_impulse=rng.normal(size=(events, 3)),
        event_energy=rng.random(events),
        event_pos=rng.normal(size=(events, 3)),
        anchor_t=anchor_t,
        anchor_pos=rng.normal(size=(n + 1, 3)),
        energy={
            "initial": 10.0,
            "potential": 3.0,
            "kinetic": 2.5,
            "lost_locking": 4.0,
            "lost_landing": 0.5,
            "imbalance": 1.2e-15,
        },
        max_depth=0.0,
        floor_impulse=rng.normal(size=3),
        floor_impulse_total=rng.normal(size=3),
        wall_seconds=1.25,
        n_steps=steps,
        n_evals=6 * steps,
        n_instants=steps // 10,
        units=units,
        extra={"note": "synthetic", "list": [1, 2.5, None], "nested": {"a": math.nan}},
    )
    kw.update(over)
    return Result(**kw)


def assert_results_identical(a: Result, b: Result) -> None:
    for f in dataclasses.fields(Result):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            assert isinstance(y, np.ndarray), f.name
            assert x.dtype == y.dtype, f.name
            assert x.shape == y.shape, f.name
            assert x.tobytes() == y.tobytes(), f.name  # bit for bit, NaN included
        elif isinstance(x, (float, int, np.number)) and not isinstance(x, bool):
            # numbers: same value bit for bit (NaN included), builtin or numpy scalar
            assert isinstance(y, (float, int, np.number)), f.name
            assert np.asarray(x).tobytes() == np.asarray(type(x)(y)).tobytes(), f.name
            assert (x == y) or (math.isnan(x) and math.isnan(y)), f.name
        elif f.name == "extra":
            assert repr(x) == repr(y), f.name  # NaN != NaN inside dicts
        else:
            assert type(x) is type(y), f.name
            assert x == y, f.name


@pytest.mark.parametrize("case", ["basic", "n1", "no_events", "no_ic", "si", "big"])
def test_round_trip_bit_identical(tmp_path, case):
    if case == "basic":
        r = make_result()
    elif case == "n1":  # N = 1: frame_locked is (F, 0)
        r = make_result(n=1)
        assert r.frame_locked.shape == (7, 0)
    elif case == "no_events":
        r = make_result(events=0)
        assert r.event_t.shape == (0,) and r.event_impulse.shape == (0, 3)
    elif case == "no_ic":
        r = make_result(ic=False, status="error", message="blow-up at t = 1.5")
    elif case == "si":
        r = make_result(
            units="SI", params=ChainParams.from_chain(5, 0.535, 0.0054567, 9.81, floor="pivot", anchor_cone=True)
        )
    else:  # compressed + chunked
        r = make_result(n=200, frames=150, events=500, steps=5000)
    path = tmp_path / "run.h5"
    save_result(r, path)
    back = load_result(path)
    assert_results_identical(r, back)
    assert back.summary() == r.summary()
    assert math.isnan(back.t_landed)
    assert np.isnan(back.anchor_t).sum() == np.isnan(r.anchor_t).sum()


def test_file_is_self_describing(tmp_path):
    r = make_result(n=300, frames=120, units="SI", params=ChainParams.from_chain(300, 0.535, 0.0054567))
    path = tmp_path / "run.h5"
    save_result(r, path)
    with h5py.File(path, "r") as f:
        assert f.attrs["format"] == FORMAT_NAME
        assert int(f.attrs["format_version"]) == 6
        assert f.attrs["units"] == "SI"
        assert "created" in f.attrs and "package_version" in f.attrs
        assert set(f.attrs) == set(files.ROOT_ATTRS)  # the root's attributes are those documented
        assert int(f.attrs["seed"]) == 7
        assert f["params"].attrs["segments"] == 300
        assert f["params"].attrs["floor"] == "all"
        assert f["ic"].attrs["kind"] == "helix"
        assert f["options"].attrs["until"] == 0.5
        assert f["trace/t"].attrs["units"] == "s"
        assert f["trace/z_top"].attrs["units"] == "m"
        assert f["frames/frame_floor_force"].attrs["units"] == "N"
        assert f["frames/frame_omega"].attrs["units"] == "1/s"
        assert f["events/event_impulse"].attrs["units"] == "N s"
        assert f["frames/frame_kinetic"].attrs["units"] == "J"
        assert f["energy"].attrs["units"] == "J"
        assert f["energy"].attrs["initial"] == 10.0
        for g in ("trace", "frames", "events", "anchors", "summary"):
            for name, ds in f[g].items():
                assert "units" in ds.attrs and ds.attrs["description"], name
        assert f["frames/frame_floor_impulse"].attrs["units"] == "N s"
        assert f["events/event_pos"].attrs["units"] == "m"
        assert "Point N, the original pivot, is at the origin" in f["frames"].attrs["conventions"]
        kinds = json.loads(f["events"].attrs["kinds"])
        assert kinds == {str(c): name for c, name in EVENT_KINDS.items()}
        assert set(json.loads(f["events"].attrs["kind_meanings"])) == set(EVENT_KINDS.values())
        big = f["frames/frame_e"]
        assert big.compression == "gzip" and big.shuffle and big.chunks is not None


def test_version_1_file_loads_with_the_new_datasets_as_nan(tmp_path):
    """A file written before the floor momentum record still loads; what it lacks is NaN."""
    r = make_result(n=6, frames=7, events=5)
    path = tmp_path / "v1.h5"
    save_result(r, path)
    with h5py.File(path, "r+") as f:
        f.attrs["format_version"] = np.int64(1)
        for key in (
            "summary/floor_impulse_total",
            "frames/frame_pile_pull",
            "frames/frame_scale_force",
            "frames/frame_floor_impulse",
            "events/event_pos",
        ):
            del f[key]
    back = load_result(path)
    assert back.frame_pile_pull.shape == (7, 3) and np.all(np.isnan(back.frame_pile_pull))
    assert back.event_pos.shape == (5, 3) and np.all(np.isnan(back.floor_impulse_total))
    np.testing.assert_array_equal(back.frame_e, r.frame_e)


def test_version_2_file_loads_with_the_bottom_end_at_the_origin(tmp_path):
    """A file written before the frictionless floor lacks the bottom end's record: every
    run then stood on the origin, so it loads as zeros and its points are as they were."""
    r = make_result(n=6, frames=7, events=5)
    path = tmp_path / "v2.h5"
    save_result(r, path)
    with h5py.File(path, "r+") as f:
        f.attrs["format_version"] = np.int64(2)
        del f["frames/frame_base"], f["frames/frame_base_velocity"]
    back = load_result(path)
    assert back.frame_base.shape == back.frame_base_velocity.shape == (7, 3)
    assert np.all(back.frame_base == 0.0) and np.all(back.frame_base_velocity == 0.0)
    np.testing.assert_array_equal(back.points(), r.points())


@pytest.mark.parametrize(
    "version, name, kept",
    [
        (3, "frame_lost_damping", "frame_lost_landing"),  # (no smooth law acted before the hinges' damping)
        (4, "frame_lost_sliding", "frame_lost_damping"),  # (the friction's work was then in lost_landing)
    ],
)
def test_a_file_from_before_a_ledger_loads_with_nothing_booked_there(tmp_path, version, name, kept):
    """A file written before a law had a ledger of its own lacks that ledger's loss per
    frame: it loads as zeros, the other books as written."""
    r = make_result(n=6, frames=7, events=5)
    path = tmp_path / f"v{version}.h5"
    save_result(r, path)
    with h5py.File(path, "r+") as f:
        f.attrs["format_version"] = np.int64(version)
        del f[f"frames/{name}"]
    back = load_result(path)
    assert getattr(back, name).shape == (7,) and np.all(getattr(back, name) == 0.0)
    np.testing.assert_array_equal(getattr(back, kept), getattr(r, kept))


def test_a_file_from_before_the_tension_loads_it_as_not_computed(tmp_path):
    """A file written before the tension was recorded (version 5) lacks it: it loads as
    NaN, one value per point and frame, the rest as written."""
    r = make_result(n=6, frames=7, events=5)
    path = tmp_path / "v5.h5"
    save_result(r, path)
    with h5py.File(path, "r+") as f:
        f.attrs["format_version"] = np.int64(5)
        del f["frames/frame_tension"]
    back = load_result(path)
    assert back.frame_tension.shape == (7, 7) and np.all(np.isnan(back.frame_tension))
    np.testing.assert_array_equal(back.frame_pile_pull, r.frame_pile_pull)


def test_units_nondimensional():
    assert unit_of("t", "nondimensional") == "sqrt(b/g)"
    assert unit_of("anchor_pos", "nondimensional") == "b"
    assert unit_of("frame_floor_force", "nondimensional") == "m g"
    assert unit_of("event_impulse", "nondimensional") == "m sqrt(g b)"
    assert unit_of("event_energy", "nondimensional") == "m g b"
    assert unit_of("frame_omega", "nondimensional") == "sqrt(g/b)"
    assert unit_of("wall_seconds", "nondimensional") == "s"
    assert unit_of("frame_e", "SI") == "1"


def test_no_overwrite_without_force(tmp_path):
    path = tmp_path / "run.h5"
    save_result(make_result(seed=1), path)
    before = path.read_bytes()
    with pytest.raises(FileExistsError, match="force=True"):
        save_result(make_result(seed=2), path)
    assert path.read_bytes() == before
    with pytest.raises(FileExistsError):
        check_writable(path, False)
    save_result(make_result(seed=2), path, force=True)
    assert_results_identical(load_result(path), make_result(seed=2))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.h5"]


@pytest.mark.parametrize("exc", [RuntimeError("disk on fire"), KeyboardInterrupt()])
def test_atomic_write_failure_leaves_nothing(tmp_path, monkeypatch, exc):
    calls = {"n": 0}
    real = files._create

    def failing(group, name, data, units):
        calls["n"] += 1
        if calls["n"] == 12:  # in the middle of the frames
            raise exc
        return real(group, name, data, units)

    monkeypatch.setattr(files, "_create", failing)
    path = tmp_path / "run.h5"
    with pytest.raises(type(exc)):
        save_result(make_result(), path)
    assert calls["n"] == 12
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_failure_keeps_old_file(tmp_path, monkeypatch):
    path = tmp_path / "run.h5"
    save_result(make_result(seed=1), path)
    before = path.read_bytes()

    def failing(f, result):
        f.create_group("trace")
        raise OSError("no space left on device")

    monkeypatch.setattr(files, "_write", failing)
    with pytest.raises(OSError):
        save_result(make_result(seed=2), path, force=True)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["run.h5"]


def test_check_writable(tmp_path):
    assert check_writable(tmp_path / "new.h5", False) == tmp_path / "new.h5"
    with pytest.raises(ResultFileError, match="does not exist"):
        check_writable(tmp_path / "missing" / "x.h5", False)
    with pytest.raises(ResultFileError, match="directory"):
        check_writable(tmp_path, True)
    with pytest.raises(ResultFileError, match="does not exist"):
        save_result(make_result(), tmp_path / "missing" / "x.h5")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root can write into read-only directories")
def test_check_writable_read_only_dir(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(ResultFileError, match="cannot create"):
            check_writable(ro / "x.h5", False)
    finally:
        ro.chmod(0o700)


def _one_line_error(path) -> str:
    with pytest.raises(ResultFileError) as info:
        load_result(path)
    msg = str(info.value)
    assert "\n" not in msg and msg
    return msg


def test_missing_file(tmp_path):
    assert "no such file" in _one_line_error(tmp_path / "nope.h5")


def test_text_file(tmp_path):
    p = tmp_path / "notes.h5"
    p.write_text("this is not HDF5\n" * 100)
    assert "not an HDF5 file" in _one_line_error(p)
    e = tmp_path / "empty.h5"
    e.write_bytes(b"")
    assert "empty" in _one_line_error(e)


def test_directory(tmp_path):
    assert "directory" in _one_line_error(tmp_path)


def test_foreign_hdf5(tmp_path):
    p = tmp_path / "foreign.h5"
    with h5py.File(p, "w") as f:
        f.create_dataset("x", data=np.arange(10))
    assert "not a ballchain result" in _one_line_error(p)
    q = tmp_path / "other.h5"
    with h5py.File(q, "w") as f:
        f.attrs["format"] = "someone-else"
    assert "not a ballchain result" in _one_line_error(q)


def test_newer_format_version(tmp_path):
    p = tmp_path / "run.h5"
    save_result(make_result(), p)
    with h5py.File(p, "r+") as f:
        f.attrs["format_version"] = FORMAT_VERSION + 1
    assert "newer" in _one_line_error(p)


@pytest.mark.parametrize("fraction", [0.1, 0.5, 0.9, 0.999])
def test_truncated_file(tmp_path, fraction):
    p = tmp_path / "run.h5"
    save_result(make_result(n=50, frames=60, steps=2000), p)
    data = p.read_bytes()
    p.write_bytes(data[: int(len(data) * fraction)])
    msg = _one_line_error(p)
    assert "damaged" in msg or "truncated" in msg or "not an HDF5" in msg


def test_missing_dataset_is_damaged(tmp_path):
    p = tmp_path / "run.h5"
    save_result(make_result(), p)
    with h5py.File(p, "r+") as f:
        del f["frames/frame_e"]
    assert "damaged" in _one_line_error(p)


def test_corrupted_parameters_are_damaged(tmp_path):
    p = tmp_path / "run.h5"
    save_result(make_result(), p)
    with h5py.File(p, "r+") as f:
        f.attrs["params_json"] = '{"segments": -3}'
    assert "damaged" in _one_line_error(p)


def test_file_info(tmp_path):
    p = tmp_path / "run.h5"
    save_result(make_result(), p)
    info = files.file_info(p)
    assert info["format"] == FORMAT_NAME and info["format_version"] == FORMAT_VERSION == 6
    assert info["units"] == "nondimensional" and info["status"] == "landed"


def test_outputs_are_checked_before_any_work(tmp_path):
    """--force replaces only a regular file: a device, a FIFO, a directory or a symbolic link
    is refused in one line with exit code 2, as is every output path of every command whose
    directory is missing or that is the wrong kind of thing, before any work is done."""
    import os
    import stat

    from typer.testing import CliRunner

    from ballchain.cli import app

    afile = tmp_path / "afile.h5"
    afile.write_bytes(b"keep me")
    link = tmp_path / "alink.h5"
    link.symlink_to(afile)
    fifo = tmp_path / "fifo.h5"
    os.mkfifo(fifo)
    runner = CliRunner()
    sim = ["simulate", "-N", "2", "--until", "0.1", "-q", "--force", "--output"]
    cases = [
        (sim + ["/dev/full"], "not a regular file"),
        (sim + [str(fifo)], "not a regular file"),
        (sim + [str(link)], "symbolic link"),
        (sim + [str(tmp_path)], "is a directory"),
        (["paper", "--quick", "--out", str(afile)], "is not a directory"),
        (["sweep", "-N", "4", "-q", "--out", str(tmp_path / "nodir" / "t.parquet")], "does not exist"),
        (
            ["sweep", "-N", "4", "-q", "--out", str(tmp_path / "t.parquet"), "--save-runs", str(afile)],
            "not a directory",
        ),
        (["stats", str(afile), "--plot", str(tmp_path / "nodir" / "x.png")], "does not exist"),
    ]
    for args, words in cases:
        res = runner.invoke(app, args)
        assert res.exit_code == 2, (args, res.output)
        assert words in res.output and res.output.count("\n") == 1, (args, res.output)
    assert afile.read_bytes() == b"keep me" and link.is_symlink() and stat.S_ISFIFO(fifo.lstat().st_mode)
    assert not (tmp_path / "t.parquet").exists()


@pytest.mark.parametrize("ic", [True, False])
def test_repr_is_one_short_line_whatever_the_size_of_the_run(ic):
    """repr(Result) names the run and the size of its records, never the arrays."""
    small, large = make_result(n=5, frames=7, ic=ic), make_result(n=200, frames=500, events=2000, steps=5000, ic=ic)
    for r in (small, large):
        text = repr(r)
        assert "\n" not in text and len(text) < 300, text
        assert f"N={r.params.segments}" in text and f"frames={len(r.frame_t)}" in text
        assert f"status={r.status}" in text and ("explicit state" in text) == (not ic)
    assert abs(len(repr(large)) - len(repr(small))) < 20
