"""ballchain sweep and stats: the grid and its streams, a real dask LocalCluster on
loopback, the same table from 1 and 2 workers, resume after kill -9, failed runs as
rows, one-line errors before anything runs, and the statistics against hand-computed
values."""

import json
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.initial import initial_directions
from ballchain.model import ChainParams, InitialCondition, ParameterError, SolverOptions
from ballchain.sweeps import SweepSpec, Task, parse_alphas, parse_segments, run_id
from ballchain.sweeps.execute import run_sweep, run_tasks
from ballchain.sweeps.stats import mean_interval, table_stats
from ballchain.sweeps.table import COLUMNS, VOLATILE, read_table, write_table

runner = CliRunner()


# ------------------------------------------------------------------ the grid
def test_lists_and_ranges():
    assert parse_segments("64,128") == [64, 128]
    assert parse_segments("8:32:8,64") == [8, 16, 24, 32, 64]
    a = parse_alphas("10deg:120deg:10deg")
    assert a == [math.radians(d) for d in range(10, 121, 10)]  # exactly the degrees, as --alpha 30deg gives
    assert parse_alphas("pi/4,45deg,0.7853981633974483") == [pytest.approx(math.pi / 4)]  # duplicates merged
    assert parse_alphas("pi") == [math.pi]


@pytest.mark.parametrize(
    "args, words",
    [
        (["--alpha", "120deg:10deg:10deg"], "empty range"),
        (["--alpha", "10deg:120deg:0deg"], "step must be > 0"),
        (["--alpha", "0deg,30deg"], "alpha must be in (0, pi]"),
        (["--alpha", "200deg"], "alpha must be in (0, pi]"),
        (["--alpha", "30deg,,60deg"], "empty item"),
        (["--floor", "all,wall"], "floor must be one of"),
        (["--segments", "0,8"], "segments must be >= 1"),
        (["--segments", "64:8:8"], "empty range"),
        (["--ic", "helix", "--runs", "3"], "needs --ic random"),
        (["--runs", "0"], "runs must be"),
        (["--workers", "0"], "workers must be >= 1"),
        (["--eps", "0.9", "--alpha", "10deg", "--segments", "8"], "not strictly inside"),
        (["--scheduler", "tcp://127.0.0.1:9"], "cannot reach"),
    ],
)
def test_bad_specifications_fail_in_one_line_before_anything_runs(tmp_path, args, words):
    out = tmp_path / "t.parquet"
    res = runner.invoke(app, ["sweep", "--segments", "4", "--out", str(out), "-q", *args])
    assert res.exit_code == 2, res.output
    err = res.stderr.strip()
    assert err.startswith("error:") and len(err.splitlines()) == 1 and words in err, err
    assert not out.exists()


def test_run_k_starts_from_the_kth_spawned_stream():
    spec = SweepSpec(segments=(8, 16), alphas=(math.pi / 4,), runs=3, seed=77)
    tasks = spec.tasks()
    assert len(tasks) == 6 and len({t.run_id for t in tasks}) == 6
    children = np.random.SeedSequence(77).spawn(3)
    for t in tasks:
        ss = np.random.SeedSequence(t.ic.seed, spawn_key=t.ic.spawn_key)
        # numpy's own spawn gives the same stream: the run is rebuilt from (seed, spawn_key)
        assert np.array_equal(ss.generate_state(8), children[t.run_index].generate_state(8))
    # different k: different starts; the same k at another N: the same random modes
    e = [initial_directions(t.ic, 8, math.pi / 4) for t in tasks if t.params.segments == 8]
    assert not np.allclose(e[0], e[1]) and not np.allclose(e[1], e[2])
    for e_k in e:  # eps is the largest tilt of each start
        tilt = np.hypot(e_k[:, 0], e_k[:, 1]) / e_k[:, 2]
        assert tilt.max() == pytest.approx(0.02, rel=1e-12)


# ------------------------------------------------------------------ execution
SMALL = ["--segments", "6,10", "--alpha", "40deg,pi", "--floor", "all,pivot", "--runs", "2", "--seed", "5"]


def _table(path) -> pd.DataFrame:
    return pd.read_parquet(path)


def test_same_table_from_one_and_two_workers_and_rows_obey_momentum_balance(tmp_path):
    t1, t2 = tmp_path / "w1.parquet", tmp_path / "w2.parquet"
    r1 = runner.invoke(app, ["sweep", *SMALL, "--out", str(t1), "--workers", "1", "--json", "-q"])
    r2 = runner.invoke(app, ["sweep", *SMALL, "--out", str(t2), "--workers", "2", "--json", "-q"])
    assert r1.exit_code == 0 and r2.exit_code == 0, r1.output + r2.output
    rep = json.loads(r2.stdout)
    assert rep["total"] == 16 and rep["ran"] == 16 and rep["failed"] == 0 and rep["statuses"] == {"landed": 16}
    a, b = _table(t1), _table(t2)
    assert list(a.columns) == list(COLUMNS) and len(a) == 16 and a["run_id"].is_unique
    stable = [c for c in COLUMNS if c not in VOLATILE]
    pd.testing.assert_frame_equal(a[stable], b[stable])  # same rows, same numbers, same order
    # independent truth: the floor's whole impulse on a chain at rest at both ends is M g t_landed
    fz = a["floor_impulse_total_z"].to_numpy()
    mg_t = a["segments"].to_numpy() * a["landed_ratio"].to_numpy() * a["t_ff"].to_numpy()
    np.testing.assert_allclose(fz, mg_t, rtol=1e-7)
    # alpha = pi never locks; the starts of a point are its spawn keys 0 and 1
    assert (a.loc[a["alpha"] == math.pi, "events_lock"] == 0).all()
    assert sorted(a["spawn_key"].unique()) == ["0", "1"]


def test_a_row_rebuilds_with_simulate(tmp_path):
    out = tmp_path / "t.parquet"
    res = runner.invoke(
        app,
        [
            "sweep",
            "--segments",
            "12",
            "--alpha",
            "50deg",
            "--runs",
            "2",
            "--seed",
            "9",
            "--out",
            str(out),
            "--workers",
            "1",
            "-q",
        ],
    )
    assert res.exit_code == 0, res.output
    row = _table(out).iloc[1]
    assert row.alpha == math.radians(50)  # a degree is converted once, as simulate does
    sim = runner.invoke(
        app,
        [
            "simulate",
            "-N",
            "12",
            "--alpha",
            repr(float(row.alpha)),
            "--ic",
            "random",
            "--seed",
            str(row.seed),
            "--spawn-key",
            row.spawn_key,
            "--json",
            "-q",
        ],
    )
    s = json.loads(sim.stdout)
    # the same run on the same machine: identical
    assert s["ratio"] == row.ratio and s["n_evals"] == row.n_evals and s["events"]["lock"] == row.events_lock


def test_a_timestep_sweep_states_method_dt_theta_and_rule_and_its_rows_rebuild(tmp_path):
    out = tmp_path / "ts.parquet"
    args = ["sweep", "-N", "10", "--runs", "2", "--seed", "4", "--method", "timestep", "--dt", "0.02"]
    res = runner.invoke(app, [*args, "--theta", "1", "--dt-rule", "landing", "--out", str(out), "--workers", "1", "-q"])
    assert res.exit_code == 0, res.output
    table = _table(out)
    assert list(table.method) == ["timestep"] * 2 and list(table.dt) == [0.02] * 2 and list(table.theta) == [1.0] * 2
    assert list(table.dt_rule) == ["landing"] * 2
    assert all(rid.endswith("_timestep_dt0.02_theta1_landing") for rid in table.run_id)
    row = table.iloc[1]
    sim = runner.invoke(
        app,
        ["simulate", "-N", "10", "--ic", "random", "--seed", "4", "--spawn-key", row.spawn_key, "--method",
         "timestep", "--dt", "0.02", "--theta", "1", "--dt-rule", "landing", "--json", "-q"],
    )  # fmt: skip
    s = json.loads(sim.stdout)
    assert s["ratio"] == row.ratio and s["n_steps"] == row.n_steps  # the same run on the same machine


def test_a_run_that_fails_is_a_row_and_the_sweep_goes_on(tmp_path):
    good = SweepSpec(segments=(6,), alphas=(math.pi / 3,), runs=2).tasks()
    # a task built by hand around the validation: its start is outside the cone, so the
    # engine raises inside the worker
    p, ic, o = ChainParams(segments=8, alpha=math.radians(5)), InitialCondition(kind="random", eps=0.9), SolverOptions()
    bad = Task(run_id(p, ic, o), 0, p, ic, o)
    out = tmp_path / "t.parquet"
    rep = run_tasks([*good, bad], out, workers=2, progress=False)
    assert rep.ran == 3 and rep.failed == 1
    df = _table(out).set_index("run_id")
    assert df.loc[bad.run_id, "status"] == "error"
    assert "ParameterError" in df.loc[bad.run_id, "message"] and "inside" in df.loc[bad.run_id, "message"]
    assert (df.loc[[t.run_id for t in good], "status"] == "landed").all()
    # the failed run is not repeated unless asked
    assert run_tasks([*good, bad], out, workers=1, progress=False).ran == 0
    assert run_tasks([*good, bad], out, workers=1, progress=False, retry_errors=True).ran == 1


def test_a_saved_run_whose_row_was_lost_is_recorded_not_run_again(tmp_path, monkeypatch):
    """A sweep killed between saving a run (--save-runs) and writing its row: the next
    sweep records the run from its file.  A file of another engine, or one cut short, is
    run again."""
    import ballchain.engine as engine
    import ballchain.provenance as provenance

    spec = SweepSpec(segments=(8,), alphas=(math.pi / 4,), runs=2, seed=3, save_runs=str(tmp_path / "runs"))
    out = tmp_path / "t.parquet"
    assert run_sweep(spec, out, workers=1, progress=False).ran == 2
    first = _table(out).set_index("run_id")
    out.unlink()  # the rows are lost; the saved runs stay

    real = engine.simulate
    ran = []

    def counted(*args, **kwargs):
        if args[0].segments == 8:  # a run of the sweep, not the kernels' warm-up
            ran.append(args[0].segments)
        return real(*args, **kwargs)

    monkeypatch.setattr(engine, "simulate", counted)
    assert run_sweep(spec, out, workers=1, progress=False).ran == 2
    assert ran == []  # nothing was run again
    again = _table(out).set_index("run_id")
    cols = ["status", "ratio", "landed_ratio", "events_lock", "energy_imbalance", "n_evals", "wall_seconds", "engine"]
    assert again.loc[first.index, cols].equals(first[cols])

    # another engine's file, or a file cut short, is not trusted: those runs run again
    t0, t1 = spec.tasks()
    with open(t1.save_path, "r+b") as f:
        f.truncate(os.path.getsize(t1.save_path) // 2)
    out.unlink()
    monkeypatch.setattr(provenance, "engine_fingerprint", lambda: "another")
    import ballchain.sweeps.execute as execute

    assert execute._saved_result(t0) is None
    monkeypatch.undo()
    monkeypatch.setattr(engine, "simulate", counted)
    assert execute._saved_result(t0) is not None and execute._saved_result(t1) is None
    assert run_sweep(spec, out, workers=1, progress=False).ran == 2
    assert ran == [8]  # only the cut file's run
    assert _table(out).set_index("run_id").loc[t1.run_id, "ratio"] == first.loc[t1.run_id, "ratio"]


@pytest.mark.slow
def test_resume_after_kill_9_recomputes_only_what_is_missing(tmp_path):
    out = tmp_path / "t.parquet"
    cmd = [
        sys.executable,
        "-m",
        "ballchain.cli",
        "sweep",
        "--segments",
        "8,12,16,24",
        "--alpha",
        "30deg,45deg,60deg,pi",
        "--runs",
        "16",  # long enough to be killed mid-way
        "--out",
        str(out),
        "--workers",
        "1",
        "-q",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 240
        n_before = 0
        while time.monotonic() < deadline and proc.poll() is None:
            if out.exists():
                n_before = len(read_table(out))
                if n_before >= 3:
                    break
            time.sleep(0.05)
        assert proc.poll() is None, "the sweep ended before it could be killed"
        os.killpg(proc.pid, signal.SIGKILL)  # the sweep and its workers, at once
        proc.wait(30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    before = _table(out)  # a complete table: the file is replaced atomically
    assert 3 <= len(before) < 256 and before["run_id"].is_unique
    res = subprocess.run(cmd + ["--json"], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    rep = json.loads(res.stdout)
    after = _table(out)
    assert rep["skipped"] >= len(before) and rep["ran"] == 256 - rep["skipped"]
    assert len(after) == 256 and after["run_id"].is_unique
    kept = after.set_index("run_id").loc[before["run_id"]]
    stable = [c for c in COLUMNS if c not in VOLATILE and c != "run_id"]
    pd.testing.assert_frame_equal(kept[stable].reset_index(drop=True), before[stable].reset_index(drop=True))


# ------------------------------------------------------------------ statistics
def _synthetic(tmp_path, values: dict, n_alpha_floor="all") -> str:
    """A table whose ratio at (alpha_deg, run_index) is given."""
    rows = []
    for (a_deg, k), ratio in values.items():
        p, ic, o = (
            ChainParams(segments=64, alpha=math.radians(a_deg)),
            InitialCondition(kind="random", spawn_key=(k,)),
            SolverOptions(),
        )
        rows.append(
            {
                "run_id": run_id(p, ic, o),
                "segments": 64,
                "alpha": p.alpha,
                "alpha_deg": a_deg,
                "floor": n_alpha_floor,
                "anchor_cone": False,
                "ic": "random",
                "eps": 0.02,
                "turns": 1.0,
                "phase": 0.0,
                "seed": 0,
                "spawn_key": str(k),
                "run_index": k,
                "rtol": 1e-9,
                "until": math.nan,
                "frames_per_tff": 100.0,
                "status": "landed",
                "ratio": ratio,
                "landed_ratio": ratio + 0.5,
                "method": "event",
                "energy_initial": 1000.0 + a_deg,
                "energy_imbalance": (-1.0) ** k * 1e-8 * k * a_deg,
                "max_depth": 1e-12 * k,
            }
        )
    path = tmp_path / "syn.parquet"
    write_table(path, rows)
    return str(path)


def test_statistics_against_hand_computed_values(tmp_path):
    r30 = [0.9, 1.1, 0.95, 1.2, 0.97]
    r60 = [1.3, 1.4, 1.2, 1.5, 1.35]
    path = _synthetic(tmp_path, {**{(30, k): v for k, v in enumerate(r30)}, **{(60, k): v for k, v in enumerate(r60)}})
    res = table_stats(path)
    p30 = next(p for p in res["points"] if abs(p["alpha_deg"] - 30) < 1e-9)
    assert p30["ratio"]["mean"] == pytest.approx(sum(r30) / 5, abs=1e-15)
    assert p30["ratio"]["median"] == 0.97
    assert p30["landed_ratio"]["mean"] == pytest.approx(sum(r30) / 5 + 0.5)
    # 3 of 5 faster than free fall; Wilson interval by hand, z = 1.959963984540054
    z, n, phat = 1.959963984540054, 5, 0.6
    centre = (phat + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(phat * (1 - phat) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    fa = p30["faster_than_free_fall"]
    assert (fa["k"], fa["n"]) == (3, 5)
    assert fa["ci_low"] == pytest.approx(centre - half, abs=1e-12) and fa["ci_high"] == pytest.approx(
        centre + half, abs=1e-12
    )
    assert fa["ci_low"] == pytest.approx(0.2307, abs=1e-4) and fa["ci_high"] == pytest.approx(0.8824, abs=1e-4)
    # every start is faster at 30 deg: the optimum is 30 deg in every paired resample
    (opt,) = res["optimal_alpha"]
    assert opt["alpha_deg"] == pytest.approx(30) and opt["ci_low_deg"] == pytest.approx(30)
    assert opt["ci_high_deg"] == pytest.approx(30) and opt["share_best"] == 1.0
    assert opt["mean"] == pytest.approx(sum(r30) / 5)


def test_optimum_interval_spans_alphas_that_the_data_cannot_separate(tmp_path):
    rng = np.random.default_rng(1)
    vals = {}
    for k in range(12):
        common = rng.normal(1.0, 0.05)
        vals[(40, k)] = common + rng.normal(0, 0.05)
        vals[(50, k)] = common + rng.normal(0, 0.05)
        vals[(90, k)] = common + 0.5
    (opt,) = table_stats(_synthetic(tmp_path, vals))["optimal_alpha"]
    assert opt["alpha_deg"] in (40, 50)
    assert opt["ci_low_deg"] == pytest.approx(40) and opt["ci_high_deg"] == pytest.approx(50)


def test_bootstrap_interval_of_the_mean_matches_the_normal_theory():
    x = np.random.default_rng(3).normal(1.0, 0.2, 400)
    lo, hi = mean_interval(x)
    se = x.std(ddof=1) / math.sqrt(x.size)
    assert lo < x.mean() < hi
    # large n: the bootstrap interval is the CLT interval mean +- 1.96 se, to a few %
    assert (hi - lo) == pytest.approx(2 * 1.959964 * se, rel=0.08)
    assert (lo + hi) / 2 == pytest.approx(x.mean(), abs=0.1 * se)
    assert mean_interval([1.0, 1.0, 1.0]) == (1.0, 1.0)
    assert all(math.isnan(v) for v in mean_interval([1.0]))


def test_stats_cli_json_and_plot(tmp_path):
    path = _synthetic(tmp_path, {(a, k): 1.0 + 0.001 * a + 0.01 * k for a in (20, 45, 70) for k in range(4)})
    png = tmp_path / "alpha.png"
    res = runner.invoke(app, ["stats", path, "--json", "--plot", str(png)])
    assert res.exit_code == 0, res.output
    s = json.loads(res.stdout)
    assert s["rows"] == 12 and len(s["points"]) == 3 and png.stat().st_size > 0
    from ballchain.plots.sweep import alpha_figure

    fig = alpha_figure(s["points"], optimal=s["optimal_alpha"])
    (line,) = [ln for ln in fig.axes[0].get_lines() if ln.get_gid() == "N64"]
    np.testing.assert_allclose(line.get_xdata(), [20, 45, 70])
    np.testing.assert_allclose(line.get_ydata(), [1.0 + 0.001 * a + 0.015 for a in (20, 45, 70)])
    # against N: two sizes of one alpha
    from ballchain.plots.sweep import segments_figure

    pts = [dict(p, segments=n) for p in s["points"][:1] for n in (64, 128)]
    pts[1]["ratio"] = dict(pts[1]["ratio"], mean=0.95)
    (ln,) = [x for x in segments_figure(pts).axes[0].get_lines() if x.get_gid() == "a20-all"]
    np.testing.assert_allclose(ln.get_xdata(), [64, 128])
    np.testing.assert_allclose(ln.get_ydata(), [s["points"][0]["ratio"]["mean"], 0.95])
    (books,) = s["books"].values()  # the worst of the rows: alpha 70, run 3, by hand
    assert books["runs"] == 12 and books["worst_imbalance"] == pytest.approx(3 * 70e-8 / 1070, rel=1e-12)
    assert books["deepest"] == pytest.approx(3e-12, rel=1e-12)
    text = runner.invoke(app, ["stats", path])
    assert text.exit_code == 0 and "optimal alpha" in text.stdout and "20 deg" in text.stdout
    assert "books of the 12 landed runs (event): worst |imbalance| / E0 2e-09" in text.stdout
    bad = runner.invoke(app, ["stats", str(tmp_path / "none.parquet")])
    assert bad.exit_code == 2 and bad.stderr.startswith("error:")


def test_stats_names_the_runs_that_did_not_land(tmp_path):
    import pandas as pd

    path = _synthetic(tmp_path, {(45, k): 0.95 for k in range(14)})
    df = pd.read_parquet(path)
    stopped = df["run_index"] >= 2  # twelve runs stopped at the time cap, each saying why
    df.loc[stopped, "status"] = "max_time"
    df.loc[stopped, "ratio"] = math.nan
    df.loc[stopped, "message"] = [f"time cap, run {k}" for k in df.loc[stopped, "run_index"]]
    df.to_parquet(path, index=False)
    res = table_stats(path)
    assert res["status"] == {"max_time": 12, "landed": 2}
    assert [r["message"] for r in res["not_landed"]] == [f"time cap, run {k}" for k in range(2, 14)]
    assert res["not_landed"][0]["run_id"] == df.loc[df["run_index"] == 2, "run_id"].item()
    text = runner.invoke(app, ["stats", path]).stdout
    assert "runs that did not land (12):" in text and "(max_time): time cap, run 11" in text
    assert "time cap, run 12" not in text and "... and 2 more (--json lists them all)" in text


def test_stats_depth_only_where_the_floor_watches_every_point(tmp_path):
    """Under floor pivot the chain passes through the floor by design: its depth is not a
    missed landing and is left out of the books' deepest point (NaN when no run watches)."""
    from ballchain.sweeps.stats import books_stats

    df = pd.read_parquet(_synthetic(tmp_path, {(45, k): 1.0 for k in range(3)}))
    df["max_depth"] = [1e-12, 5e-12, 2e-12]
    assert books_stats(df)["event"]["deepest"] == pytest.approx(5e-12, rel=1e-12)
    df.loc[1, "floor"] = "pivot"
    df.loc[1, "max_depth"] = 300.0  # sunk through the floor, as floor pivot does
    assert books_stats(df)["event"]["deepest"] == pytest.approx(2e-12, rel=1e-12)
    df["floor"] = "pivot"
    assert math.isnan(books_stats(df)["event"]["deepest"])


def test_a_foreign_parquet_file_is_refused(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = tmp_path / "other.parquet"
    pq.write_table(pa.table({"x": [1, 2]}), path)
    with pytest.raises(ParameterError, match="not a ballchain sweep table"):
        read_table(path)
    res = runner.invoke(app, ["sweep", "--segments", "4", "--out", str(path), "-q"])
    assert res.exit_code == 2 and "not a ballchain sweep table" in res.stderr


def test_an_existing_cluster_by_its_address(tmp_path):
    """--scheduler ADDRESS: the same code on a cluster the sweep did not start; the rows
    equal those of the sweep's own local cluster."""
    from distributed import LocalCluster

    spec = SweepSpec(segments=(6,), alphas=(math.pi / 4, math.pi), runs=2, seed=3)
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0", host="127.0.0.1"
    ) as cluster:
        rep = run_sweep(spec, tmp_path / "remote.parquet", scheduler=cluster.scheduler_address, progress=False)
    assert rep.ran == 4 and rep.failed == 0 and rep.workers == 1 and rep.scheduler.startswith("tcp://127.0.0.1")
    local = run_sweep(spec, tmp_path / "local.parquet", workers=1, progress=False)
    assert local.ran == 4
    stable = [c for c in COLUMNS if c not in VOLATILE]
    pd.testing.assert_frame_equal(
        _table(tmp_path / "remote.parquet")[stable], _table(tmp_path / "local.parquet")[stable]
    )


def test_a_one_worker_sweep_never_loses_its_worker_to_late_heartbeats():
    """The one-worker sweep's worker is a thread of this process: while a task holds the
    GIL its event loop sends no heartbeats, and a scheduler with a time-to-live removes
    such a worker and loses the result of the run it holds (the sweep then waits for it
    forever; seen with a time-to-live of 1 s and a task holding the GIL 4 s at a time).
    The runs' compiled loops release the GIL (``test_engine.py``); beyond that the
    in-process scheduler has no time-to-live, even where the configuration sets one.
    A cluster of worker processes keeps it (a worker process can die alone)."""
    import dask
    import distributed  # noqa: F401  (its configuration keys)

    from ballchain.sweeps.execute import _connect

    with dask.config.set({"distributed.scheduler.worker-ttl": "1s"}):
        client, cluster = _connect(None, 1, None)
    try:
        assert cluster.scheduler.worker_ttl is None
        assert client.submit(sum, [1, 2], pure=False).result(timeout=60) == 3
    finally:
        client.close()
        cluster.close()


def test_no_interval_of_a_mean_from_too_few_runs(tmp_path):
    """A point with fewer runs than MIN_INTERVAL_N has its mean and no interval; the text
    says from how many runs an interval is drawn."""
    from ballchain.sweeps.stats import MIN_INTERVAL_N

    few, many = MIN_INTERVAL_N - 1, MIN_INTERVAL_N
    vals = {(30, k): 0.9 + 0.01 * k for k in range(few)} | {(60, k): 1.1 + 0.01 * k for k in range(many)}
    path = _synthetic(tmp_path, vals)
    p30, p60 = table_stats(path)["points"]
    assert p30["ratio"]["n"] == few and p30["ratio"]["mean"] == pytest.approx(0.9 + 0.005 * (few - 1))
    assert p30["ratio"]["ci_low"] is None and p30["ratio"]["ci_high"] is None
    assert p60["ratio"]["n"] == many and p60["ratio"]["ci_low"] < p60["ratio"]["mean"] < p60["ratio"]["ci_high"]
    text = runner.invoke(app, ["stats", path]).stdout
    assert f"none from fewer than {MIN_INTERVAL_N} runs" in text
    (row30,) = [ln for ln in text.splitlines() if ln.split()[:2] == ["64", "30d"]]
    assert "[-, -]" in row30


@pytest.mark.parametrize("finished", [2, 1])
def test_a_signal_after_the_last_run_is_not_an_interruption(tmp_path, monkeypatch, finished):
    """Ctrl-C while the cluster closes, every run already in the table: the sweep reports
    done (exit 0), not interrupted; a signal with a run still to do is an interruption."""
    import io

    import ballchain.sweeps.execute as execute

    tasks = SweepSpec(segments=(6,), alphas=(math.pi / 3,), runs=2).tasks()

    def fake_cluster(todo, scheduler, workers, writer, report, progress, log):
        for task in todo[:finished]:
            writer.add(execute.error_row(task, "made by the test"))
            report.ran += 1
        raise execute._Stop("SIGINT")

    monkeypatch.setattr(execute, "_run_on_cluster", fake_cluster)
    monkeypatch.setattr(execute, "warm_kernels", lambda method: False)
    log = io.StringIO()
    rep = run_tasks(tasks, tmp_path / "t.parquet", workers=1, progress=False, log=log)
    assert rep.ran == finished and len(read_table(tmp_path / "t.parquet")) == finished
    assert rep.interrupted == (finished < len(tasks))
    assert ("every run is in" in log.getvalue()) == (finished == len(tasks))
    assert ("sweep interrupted" in log.getvalue()) == (finished < len(tasks))


def test_the_json_keys_page_lists_the_keys_of_stats(tmp_path):
    from ballchain.records import json_keys

    path = _synthetic(tmp_path, {(a, k): 1.0 + 0.01 * k for a in (30, 60) for k in range(5)})
    png = tmp_path / "a.png"
    s = json.loads(runner.invoke(app, ["stats", path, "--json", "--plot", str(png), "--plot-n", str(png)]).stdout)
    assert set(s) == set(json_keys.STATS)
    assert {k for p in s["points"] for k in p} == set(json_keys.STATS_POINT)


@pytest.mark.parametrize(
    "name",
    [
        "reproduction.parquet",  # the event method at rtol 1e-11 (the option in the key's middle)
        "largeN-timestep2048.parquet",  # the time-stepper before its theta column (then 0.5)
        "largeN-timestep1024-theta1-landing.parquet",  # ... with its step rule
        "rattle1024-dt01-64starts.parquet",  # RATTLE with its own options set
    ],
)
def test_committed_tables_keep_their_run_ids(name):
    """The keys written by the versions that ran the committed tables are what today's
    run_id makes of their rows (a sweep resumed into such a table skips its runs)."""
    from pathlib import Path

    from ballchain.sweeps.table import OPTION_COLUMNS

    rows = read_table(Path(__file__).resolve().parents[1] / "docs" / "data" / name)
    for r in rows:
        params = ChainParams(segments=r["segments"], alpha=r["alpha"], floor=r["floor"], anchor_cone=r["anchor_cone"])
        spawn = tuple(int(k) for k in r["spawn_key"].split(",")) if r["spawn_key"] else ()
        ic = InitialCondition(
            kind=r["ic"], eps=r["eps"], turns=r["turns"], phase=r["phase"], seed=r["seed"], spawn_key=spawn
        )
        given = {k: r[k] for k in OPTION_COLUMNS if r[k] == r[k] and r[k] != ""}  # (NaN, '': not in the table)
        if r["method"] == "timestep":
            given.setdefault("theta", 0.5)  # the only position update before the column
        if r["method"] == "rattle":
            given.setdefault("landing_step", "whole")  # the only landing step before the column
        until = None if math.isnan(r["until"]) else r["until"]
        options = SolverOptions(method=r["method"], until=until, frames_per_tff=r["frames_per_tff"], **given)
        assert run_id(params, ic, options.for_segments(r["segments"])) == r["run_id"]


def test_runs_of_two_methods_or_two_steps_are_two_points(tmp_path):
    """One table holding the same starts by two methods (or one method at two steps) gives
    a point each: their statistics are never pooled."""
    path = _synthetic(tmp_path, {(45, k): 0.9 + 0.01 * k for k in range(6)})
    rows = read_table(path)
    other = [dict(r, run_id=r["run_id"] + "_rattle", method="rattle", dt=0.05, ratio=1.0) for r in rows]
    third = [dict(r, run_id=r["run_id"] + "_rattle01", method="rattle", dt=0.1, ratio=1.1) for r in rows]
    write_table(path, rows + other + third)
    points = table_stats(path)["points"]
    assert sorted((p["method"], p["dt"] if p["dt"] == p["dt"] else None) for p in points) == [
        ("event", None),
        ("rattle", 0.05),
        ("rattle", 0.1),
    ]
    means = sorted(p["ratio"]["mean"] for p in points)
    assert means == pytest.approx([0.925, 1.0, 1.1])
    from ballchain.cli import stats_text

    text = stats_text(table_stats(path)).splitlines()
    assert "method" in text[1].split() and "dt" in text[1].split() and "rtol" not in text[1].split()
    assert sorted(line.split()[3:5] for line in text[2:5]) == [["event", "-"], ["rattle", "0.05"], ["rattle", "0.1"]]


def test_a_table_read_while_a_sweep_replaces_it_is_one_version(tmp_path):
    """A reader (``ballchain stats``, a sweep's resume, a test polling a sweep) meets the
    table whole while a writer replaces it again and again (``write_table``: a new file
    renamed over the old): each read gives one version's rows, never an error.  (Reading
    by path, pyarrow opened the file more than once and could take the footer of one
    version and the columns of the next: 71 reads of 300 failed so.)"""
    import threading

    path = _synthetic(tmp_path, {(45, k): 0.9 + 0.001 * k for k in range(64)})
    rows = read_table(path)
    sizes = (3, 64)
    stop = threading.Event()

    def rewrite():
        k = 0
        while not stop.is_set():
            write_table(path, rows[: sizes[k % 2]])
            k += 1

    writer = threading.Thread(target=rewrite)
    writer.start()
    try:
        seen = [len(read_table(path)) for _ in range(300)]
    finally:
        stop.set()
        writer.join()
    assert set(seen) <= set(sizes)


def test_each_contact_law_is_an_axis_of_the_grid(tmp_path):
    """``--friction 0,inf --restitution-lock 0,0.5`` runs the four laws of the product on
    the same starts: each row is the run its law gives alone (a one-law sweep of the same
    start), the table has one column per law, and ``stats`` keeps the four points apart."""
    out = tmp_path / "laws.parquet"
    args = ["sweep", "-N", "4", "--alpha", "0.8", "--runs", "2", "--method", "rattle", "--workers", "1", "-q"]
    res = CliRunner().invoke(app, [*args, "--friction", "0,inf", "--restitution-lock", "0,0.5", "--out", str(out)])
    assert res.exit_code == 0, res.output
    rows = read_table(out)
    laws = sorted((r["friction"], r["restitution_lock"], r["run_index"]) for r in rows)
    assert laws == sorted((mu, e, k) for mu in (0.0, math.inf) for e in (0.0, 0.5) for k in (0, 1))
    assert len({r["run_id"] for r in rows}) == 8
    for mu, e in ((0.0, 0.5), (math.inf, 0.0)):  # two of the four, each swept alone
        alone = tmp_path / f"alone{mu}{e}.parquet"
        run_sweep(
            SweepSpec(segments=(4,), alphas=(0.8,), runs=2, method="rattle", friction=mu, restitution_lock=e),
            alone,
            workers=1,
            progress=False,
        )
        for a in read_table(alone):
            (b,) = [r for r in rows if r["run_id"] == a["run_id"]]
            assert b["friction"] == mu and b["restitution_lock"] == e
            assert b["ratio"] == pytest.approx(a["ratio"], rel=1e-9)
            assert b["energy_lost_locking"] == pytest.approx(a["energy_lost_locking"], rel=1e-9, abs=1e-12)
    res = CliRunner().invoke(app, ["stats", str(out), "--json"])
    points = json.loads(res.stdout)["points"]
    assert sorted((str(p["friction"]), p["restitution_lock"]) for p in points) == [
        ("0.0", 0.0),
        ("0.0", 0.5),
        ("None", 0.0),
        ("None", 0.5),
    ]


def test_a_law_of_the_grid_that_cannot_run_is_named_before_anything_runs(tmp_path):
    """A combination the model refuses stops the sweep before it starts, in one line naming
    the grid's point; a bad value of an axis is named as the single option's would be."""
    out = tmp_path / "t.parquet"
    base = ["sweep", "-N", "4", "--alpha", "0.8", "--method", "rattle", "--out", str(out)]
    res = CliRunner().invoke(app, [*base, "--friction", "0,0.3", "--restitution-floor", "0,0.5"])
    assert res.exit_code == 2 and not out.exists()
    assert "sweep point --restitution-floor 0.5, --friction 0.3:" in res.stderr
    res = CliRunner().invoke(app, [*base, "--friction", "0,-1"])
    assert res.exit_code == 2 and "negative friction" in res.stderr and not out.exists()


_STARTED: list = []  # (the fake run below: when each run started, and whether a stop request ended it)


def _run_until_asked_to_stop(task):
    """A run of a one-worker sweep (a thread of this process, which signals do not reach)
    that goes on for 30 s unless asked to stop (``engine.request_stop``)."""
    from ballchain.engine import stop_requested
    from ballchain.sweeps.execute import _interrupted_row, error_row

    _STARTED.append([time.monotonic(), False])
    end = time.monotonic() + 30.0
    while time.monotonic() < end:
        if stop_requested() is not None:
            _STARTED[-1][1] = True
            return _interrupted_row(task)
        time.sleep(0.01)
    return error_row(task, "ran on after the sweep was interrupted")


def test_an_interrupted_one_worker_sweep_stops_its_run_under_way(tmp_path, monkeypatch):
    """Ctrl-C on ``sweep --workers 1`` without checkpoints (issue 82): the run under way is
    asked to stop, and the runs not started return at once (or never start), so that the
    sweep returns (and its process exits) after saying it was interrupted, not when its
    runs are done."""
    import io
    import threading

    import ballchain.sweeps.execute as execute

    monkeypatch.setattr(execute, "run_task", _run_until_asked_to_stop)
    monkeypatch.setattr(execute, "warm_kernels", lambda method="event": False)
    _STARTED.clear()
    tasks = SweepSpec(segments=(6,), alphas=(math.pi / 3,), runs=3).tasks()

    def interrupt():
        end = time.monotonic() + 60.0
        while not _STARTED and time.monotonic() < end:
            time.sleep(0.05)
        time.sleep(0.2)
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=interrupt, daemon=True).start()
    log = io.StringIO()
    rep = run_tasks(tasks, tmp_path / "t.parquet", workers=1, progress=False, log=log)
    assert rep.interrupted and rep.ran == 0 and "sweep interrupted (SIGINT)" in log.getvalue()
    started = len(_STARTED)
    time.sleep(1.0)  # (a run that would start after the sweep returned)
    assert len(_STARTED) == started and all(stopped for _, stopped in _STARTED), _STARTED
    from ballchain.engine import stop_requested

    assert stop_requested() is None  # the request ends with the sweep
