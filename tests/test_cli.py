"""The command line: contract of options, one-line errors, JSON output, exit codes.

The engine is replaced by a fake ``simulate`` (installed as ``ballchain.engine`` in
``sys.modules``), so these tests are fast and do not depend on the physics.
"""

from __future__ import annotations

import json
import math
import sys
import types

import numpy as np
import pytest
from typer.testing import CliRunner

from ballchain import cli
from ballchain.cli import app
from ballchain.errors import ParameterError
from ballchain.model import ChainParams, InitialCondition, SolverOptions, parse_angle
from ballchain.records.files import load_result, save_result
from ballchain.records.result import Result


def fake_result(
    params: ChainParams, ic: InitialCondition, options: SolverOptions, *, status="landed", message=""
) -> Result:
    n = params.segments
    rng = np.random.default_rng(ic.seed)
    frames, steps = 5, 20
    z0 = 2.0 * n - 0.01
    t_ff = math.sqrt(2 * z0)
    units = "SI" if params.is_si else "nondimensional"
    return Result(
        params=params,
        ic=ic,
        options=options,
        version="0.1.0",
        status=status,
        message=message,
        z0=z0,
        t_ff=t_ff,
        t_fall=0.94 * t_ff,
        t_landed=1.1 * t_ff,
        t=np.linspace(0, t_ff, steps),
        z_top=np.linspace(z0, 0, steps),
        frame_t=np.linspace(0, t_ff, frames),
        frame_e=np.tile([0.0, 0.0, 1.0], (frames, n, 1)),
        frame_omega=np.zeros((frames, n, 3)),
        frame_anchored=np.zeros((frames, n + 1), bool),
        frame_locked=np.zeros((frames, n - 1), bool),
        frame_floor_force=rng.normal(size=(frames, 3)),
        frame_kinetic=np.zeros(frames),
        frame_potential=np.zeros(frames),
        frame_lost_locking=np.zeros(frames),
        frame_lost_landing=np.zeros(frames),
        frame_lost_damping=np.zeros(frames),
        frame_pile_pull=np.zeros((frames, 3)),
        frame_scale_force=np.zeros(frames),
        frame_floor_impulse=np.zeros((frames, 3)),
        frame_base=np.zeros((frames, 3)),
        frame_base_velocity=np.zeros((frames, 3)),
        frame_lost_sliding=np.zeros(frames),
        frame_tension=np.zeros((frames, n + 1)),
        event_t=np.array([0.1, 0.2, 0.3, 0.4]),
        event_kind=np.array([1, 1, 2, 3], np.int8),
        event_index=np.array([0, 1, 0, n], np.int64),
        event_impulse=np.zeros((4, 3)),
        event_energy=np.zeros(4),
        event_pos=np.zeros((4, 3)),
        anchor_t=np.full(n + 1, np.nan),
        anchor_pos=np.zeros((n + 1, 3)),
        energy={
            "initial": 1.0 * n * n,
            "potential": 0.0,
            "kinetic": 0.0,
            "lost_locking": 0.5 * n * n,
            "lost_landing": 0.5 * n * n,
            "imbalance": 1e-13,
        },
        max_depth=0.0,
        floor_impulse=np.zeros(3),
        floor_impulse_total=np.zeros(3),
        wall_seconds=0.01,
        n_steps=steps,
        n_evals=6 * steps,
        n_instants=steps // 10,
        units=units,
    )


class FakeEngine:
    def __init__(self):
        self.calls = []
        self.behaviour = None  # None | "error" | "interrupt" | "progress"

    def simulate(self, params, ic, options, *, progress=None, state=None):
        self.calls.append((params, ic, options, progress))
        if self.behaviour == "interrupt":
            raise KeyboardInterrupt
        if progress is not None:
            progress(
                0.5,
                {
                    "t_over_tff": 0.5,
                    "events": {"lock": 3, "landing": 1},
                    "instants": 4,
                    "landed": 1,
                    "segments": params.segments,
                },
            )
        if self.behaviour == "error":
            return fake_result(params, ic, options, status="error", message="NaN in the state at t = 3.2")
        return fake_result(params, ic, options)


@pytest.fixture
def engine(monkeypatch):
    fake = FakeEngine()
    mod = types.ModuleType("ballchain.engine")
    mod.simulate = fake.simulate
    mod.kernels_cached = lambda method="event": True
    mod.load_kernels = lambda method="event": False
    monkeypatch.setitem(sys.modules, "ballchain.engine", mod)
    return fake


def run(*args):
    runner = CliRunner()
    return runner.invoke(app, list(args))


def assert_one_line_error(res, code, *words):
    assert res.exit_code == code, (res.exit_code, res.stdout, res.stderr)
    err = res.stderr.strip()
    assert "Traceback" not in res.stderr and "Traceback" not in res.stdout
    assert len(err.splitlines()) == 1, err
    assert err.startswith("error: "), err
    for w in words:
        assert w in err, (w, err)
    return err


# --------------------------------------------------------------------------- JSON
SUMMARY_KEYS = (
    "segments",
    "alpha",
    "floor",
    "z0",
    "t_ff",
    "t_fall",
    "t_landed",
    "ratio",
    "events",
    "first_lock_time",
    "energy",
    "max_depth",
    "wall_seconds",
)


def test_json_summary(engine):
    res = run("simulate", "--json", "--segments", "16")
    assert res.exit_code == 0, res.stderr
    out = json.loads(res.stdout)  # stdout is exactly one JSON object
    assert isinstance(out, dict)
    for k in SUMMARY_KEYS:
        assert k in out, k
    assert set(out["events"]) >= {"lock", "unlock", "landing"}
    assert out["events"] == {
        "lock": 2,
        "unlock": 1,
        "landing": 1,
        "top": 0,
        "impulse": 0,
        "release": 0,
        "hold": 0,
        "anchor": 0,
        "bounce": 0,
        "slip": 0,
        "stick": 0,
        "lift": 0,
        "pin": 0,
        "jam": 0,
    }
    assert set(out["energy"]) >= {"initial", "potential", "kinetic", "lost_locking", "lost_landing", "imbalance"}
    assert out["segments"] == 16 and out["floor"] == "all"
    assert out["ratio"] == pytest.approx(0.94)
    assert out["first_lock_time"] == 0.1
    assert res.stderr == ""


def test_defaults_are_the_papers_case(engine):
    res = run("simulate", "--json", "--quiet")
    assert res.exit_code == 0, res.stderr
    params, ic, options, progress = engine.calls[-1]
    assert params == ChainParams(segments=128, alpha=math.pi / 4, floor="all", anchor_cone=False)
    assert ic == InitialCondition(kind="helix", eps=0.02, turns=1.0, phase=0.0, seed=0)
    assert options.rtol == 1e-10 and options.until is None and options.frames_per_tff == 100.0
    assert progress is None
    assert not params.is_si


def test_all_options_reach_the_engine(engine):
    res = run(
        "simulate",
        "--json",
        "--segments",
        "8",
        "--alpha",
        "60deg",
        "--floor",
        "pivot",
        "--anchor-cone",
        "--ic",
        "random",
        "--eps",
        "0.05",
        "--turns",
        "2",
        "--phase",
        "pi/2",
        "--seed",
        "3",
        "--rtol",
        "1e-7",
        "--until",
        "0.5",
        "--frames-per-tff",
        "20",
        "--quiet",
    )
    assert res.exit_code == 0, res.stderr
    params, ic, options, _ = engine.calls[-1]
    assert params == ChainParams(segments=8, alpha=math.radians(60), floor="pivot", anchor_cone=True)
    assert ic == InitialCondition(kind="random", eps=0.05, turns=2.0, phase=math.pi / 2, seed=3)
    assert (options.rtol, options.until, options.frames_per_tff) == (1e-7, 0.5, 20.0)


@pytest.mark.parametrize("text", ["45deg", "pi/4", "0.7853981633974483"])
def test_alpha_parsing(engine, text):
    res = run("simulate", "--json", "--alpha", text, "--segments", "4")
    assert res.exit_code == 0, res.stderr
    assert json.loads(res.stdout)["alpha"] == 0.7853981633974483
    assert parse_angle(text) == math.pi / 4


def test_si_units(engine):
    res = run("simulate", "--json", "--segments", "170", "--length", "0.535", "--mass", "0.0054567")
    assert res.exit_code == 0, res.stderr
    params, *_ = engine.calls[-1]
    assert params == ChainParams.from_chain(170, 0.535, 0.0054567, 9.81)
    assert json.loads(res.stdout)["units"] == "SI"
    res = run("simulate", "--json", "--segments", "10", "--length", "1", "--mass", "1", "--gravity", "1.62")
    assert res.exit_code == 0, res.stderr
    assert engine.calls[-1][0].gravity == 1.62


def test_human_summary(engine, tmp_path):
    out = tmp_path / "run.h5"
    res = run("simulate", "--segments", "4", "--output", str(out))
    assert res.exit_code == 0, res.stderr
    for word in (
        "t_fall / t_ff",
        "t_landed / t_ff",
        "lock 2",
        "unlock 1",
        "landing 1",
        "energy imbalance",
        "wall time",
        str(out),
    ):
        assert word in res.stdout, word
    assert res.stderr == ""


# --------------------------------------------------------------------------- errors
BAD = [
    (["--segments", "0"], "segments"),
    (["--segments", "-3"], "segments"),
    (["--segments", "abc"], "segments"),
    (["--segments", "2.5"], "segments"),
    (["--alpha", "0"], "alpha"),
    (["--alpha", "-0.1"], "alpha"),
    (["--alpha", "4"], "alpha"),
    (["--alpha", "200deg"], "alpha"),
    (["--alpha", "nan"], "alpha"),
    (["--alpha", "inf"], "alpha"),
    (["--alpha", "banana"], "alpha"),
    (["--floor", "wall"], "floor"),
    (["--ic", "spiral"], "ic"),
    (["--eps", "-0.1"], "eps"),
    (["--eps", "nan"], "eps"),
    (["--eps", "inf"], "eps"),
    (["--turns", "nan"], "turns"),
    (["--phase", "banana"], "phase"),
    (["--phase", "inf"], "phase"),
    (["--seed", "-1"], "seed"),
    (["--rtol", "0"], "rtol"),
    (["--rtol", "-1e-9"], "rtol"),
    (["--rtol", "nan"], "rtol"),
    (["--rtol", "inf"], "rtol"),
    (["--rtol", "2"], "rtol"),
    (["--until", "0"], "until"),
    (["--until", "nan"], "until"),
    (["--frames-per-tff", "0"], "frames_per_tff"),
    (["--length", "-1", "--mass", "1"], "length"),
    (["--length", "nan", "--mass", "1"], "length"),
    (["--length", "inf", "--mass", "1"], "length"),
    (["--length", "1", "--mass", "0"], "mass"),
    (["--length", "1", "--mass", "-2"], "mass"),
    (["--length", "1", "--mass", "nan"], "mass"),
    (["--length", "1", "--mass", "1", "--gravity", "-9.81"], "gravity"),
    (["--length", "1", "--mass", "1", "--gravity", "nan"], "gravity"),
    (["--length", "1", "--mass", "1", "--gravity", "inf"], "gravity"),
    (["--length", "1"], "--mass"),
    (["--mass", "1"], "--length"),
    (["--gravity", "9.81"], "--length"),
    (["--length", "1", "--mass", "1", "--segments", "0"], "segments"),
    (["--output", "/nonexistent-dir-ballchain/x.h5"], "output"),
    (["--no-such-option"], "--no-such-option"),
]


@pytest.mark.parametrize("args,word", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_parameter_one_line_exit_2(engine, args, word):
    res = run("simulate", "--json", *args)
    assert_one_line_error(res, 2, word)
    assert res.stdout == ""
    assert engine.calls == []  # rejected before any simulation work


def test_existing_output_needs_force(engine, tmp_path):
    out = tmp_path / "run.h5"
    out.write_bytes(b"precious")
    res = run("simulate", "--segments", "4", "--output", str(out))
    assert_one_line_error(res, 2, "output", "--force")
    assert engine.calls == [] and out.read_bytes() == b"precious"
    res = run("simulate", "--segments", "4", "--output", str(out), "--force", "--json")
    assert res.exit_code == 0, res.stderr
    assert load_result(out).params.segments == 4


def test_output_is_a_directory(engine, tmp_path):
    res = run("simulate", "--output", str(tmp_path), "--force")
    assert_one_line_error(res, 2, "output", "directory")
    assert engine.calls == []


def test_output_round_trip(engine, tmp_path):
    out = tmp_path / "run.h5"
    res = run("simulate", "--json", "--segments", "6", "--seed", "2", "--ic", "planar", "--output", str(out))
    assert res.exit_code == 0, res.stderr
    r = load_result(out)
    s = json.loads(res.stdout)
    # the summary of the file read back, plus the measurements the CLI adds to it
    added = (
        "gamma_measured",
        "gamma_inferred",
        "pile_radius",
        "pile_offset",
        "pile_kinetic",
        "pull_median",
        "wall_includes_compile",
        "setup_seconds",
        "setup_compiled",
    )
    assert {k: v for k, v in s.items() if k not in added} == r.summary()
    assert "gamma_measured" in s and "gamma_inferred" in s
    assert [p.name for p in tmp_path.iterdir()] == ["run.h5"]


def test_run_error_saves_partial_result_and_exits_1(engine, tmp_path):
    engine.behaviour = "error"
    out = tmp_path / "run.h5"
    res = run("simulate", "--json", "--segments", "4", "--output", str(out))
    err = assert_one_line_error(res, 1, "NaN in the state")
    assert "saved" in err
    assert json.loads(res.stdout)["status"] == "error"
    r = load_result(out)
    assert r.status == "error" and r.message == "NaN in the state at t = 3.2"


def test_ctrl_c_before_the_run_starts_exit_130_no_file(engine, tmp_path):
    engine.behaviour = "interrupt"
    out = tmp_path / "run.h5"
    res = run("simulate", "--segments", "4", "--output", str(out))
    assert_one_line_error(res, 130, "interrupted")
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_while_saving_leaves_no_file(engine, tmp_path, monkeypatch):
    from ballchain.records import files

    def interrupted(f, result):
        f.create_group("trace")
        raise KeyboardInterrupt

    monkeypatch.setattr(files, "_write", interrupted)
    out = tmp_path / "run.h5"
    res = run("simulate", "--segments", "4", "--output", str(out))
    assert_one_line_error(res, 130, "interrupted")
    assert list(tmp_path.iterdir()) == []


def test_progress_bar_goes_to_its_console_and_survives_odd_reports(monkeypatch):
    import io

    from rich.console import Console

    buf = io.StringIO()
    monkeypatch.setattr(cli.running, "_progress_console", lambda: Console(file=buf, force_terminal=True, width=100))
    seen = []

    def simulate(params, ic, options, *, progress=None, state=None):
        seen.append(progress)
        if progress is None:
            return fake_result(params, ic, options)
        progress(0.25, {"t_over_tff": 0.25, "events": {"lock": 7}, "instants": 3, "landed": 2, "segments": 3})
        progress(float("nan"), {})
        progress(2.0, None)
        progress(0.5, {"t_over_tff": "junk"})
        return fake_result(params, ic, options)

    mod = types.ModuleType("ballchain.engine")
    mod.simulate = simulate
    mod.kernels_cached = lambda method="event": True
    mod.load_kernels = lambda method="event": False
    monkeypatch.setitem(sys.modules, "ballchain.engine", mod)
    p, i, o = cli.build_inputs(dict(segments=3))
    r = cli._run_engine(p, i, o, show_progress=True)
    assert r.status == "landed" and callable(seen[0])
    assert "simulating" in buf.getvalue()  # rendered on the given console (stderr in real use)
    # quiet: no callback at all
    cli._run_engine(p, i, o, show_progress=False)
    assert seen[-1] is None


# --------------------------------------------------------------------------- info
def test_info(engine, tmp_path):
    out = tmp_path / "run.h5"
    assert run("simulate", "--json", "--segments", "5", "--output", str(out)).exit_code == 0
    res = run("info", str(out), "--json")
    assert res.exit_code == 0, res.stderr
    s = json.loads(res.stdout)
    assert s["segments"] == 5 and s["events"]["lock"] == 2
    res = run("info", str(out))
    assert res.exit_code == 0 and "t_fall / t_ff" in res.stdout and "ballchain-result" in res.stdout


def test_info_errors(tmp_path):
    import h5py

    missing = tmp_path / "missing.h5"
    assert_one_line_error(run("info", str(missing)), 2, "no such file")
    text = tmp_path / "notes.txt"
    text.write_text("hello\n")
    assert_one_line_error(run("info", str(text)), 2, "not an HDF5 file")
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["x"] = np.arange(3)
    assert_one_line_error(run("info", str(foreign), "--json"), 2, "not a ballchain result")
    good = tmp_path / "good.h5"
    p, i, o = cli.build_inputs(dict(segments=4))
    save_result(fake_result(p, i, o), good)
    data = good.read_bytes()
    trunc = tmp_path / "trunc.h5"
    trunc.write_bytes(data[: len(data) // 2])
    assert_one_line_error(run("info", str(trunc)), 2, "truncated")


def test_no_command_shows_help():
    res = run()
    assert res.exit_code in (0, 2)
    assert "simulate" in res.stdout + res.stderr
    assert "Traceback" not in res.stdout + res.stderr


def test_help_lists_the_contract_options():
    res = run("simulate", "--help")
    assert res.exit_code == 0
    for opt in (
        "--segments",
        "--alpha",
        "--floor",
        "--anchor-cone",
        "--ic",
        "--eps",
        "--turns",
        "--phase",
        "--seed",
        "--rtol",
        "--until",
        "--output",
        "--force",
        "--json",
        "--length",
        "--mass",
        "--gravity",
        "--frames-per-tff",
        "--quiet",
    ):
        assert opt in res.stdout, opt


def test_version():
    from ballchain import __version__

    res = run("--version")
    assert res.exit_code == 0 and res.stdout.strip() == f"ballchain {__version__}"


def test_rtol_below_double_precision_is_refused(engine):
    res = run("simulate", "--rtol", "1e-16")
    assert_one_line_error(res, 2, "rtol", "double precision")
    assert engine.calls == []


def test_a_first_run_says_it_compiles_the_kernels_before_the_run(engine, monkeypatch):
    """The kernels are loaded (the first time: compiled) before the run, so the run's
    wall time is its integration alone; the summary reports the setup beside it."""
    monkeypatch.setattr(sys.modules["ballchain.engine"], "kernels_cached", lambda method="event": False)
    res = run("simulate", "--segments", "4", "--json", "-q")
    s = json.loads(res.stdout)
    assert res.exit_code == 0 and s["setup_compiled"] is True and s["wall_includes_compile"] is False
    assert s["setup_seconds"] >= 0.0
    assert "compiling the numba kernels" in res.stderr
    res = run("simulate", "--segments", "4", "-q")
    assert "compiled in" in res.stdout and "(first run only" in res.stdout
    monkeypatch.setattr(sys.modules["ballchain.engine"], "kernels_cached", lambda method="event": True)
    res = run("simulate", "--segments", "4", "--json", "-q")
    s = json.loads(res.stdout)
    assert s["setup_compiled"] is False and s["wall_includes_compile"] is False
    res = run("simulate", "--segments", "4", "-q")
    assert "loaded in" in res.stdout


@pytest.mark.parametrize("command", ["simulate", "sweep"])
def test_cli_defaults_are_the_dataclasses_defaults(command):
    """The options' defaults are read from the parameter dataclasses, not restated: a run
    built from a command's defaults has the dataclasses' default parameters."""
    import typer.main

    cmd = typer.main.get_command(app).commands[command]
    defaults = {p.name: p.default for p in cmd.params}
    values = {k: defaults[k] for k in ("alpha", "floor", "eps", "rtol", "until", "frames_per_tff") if k in defaults}
    for k in ("anchor_cone", "ic", "turns", "phase", "seed", "spawn_key"):
        if command == "simulate":
            values[k] = defaults[k]
    p, i, o = cli.build_inputs(values)
    assert (p.alpha, p.floor, p.anchor_cone) == (ChainParams().alpha, ChainParams().floor, ChainParams().anchor_cone)
    assert (o.rtol, o.until, o.frames_per_tff) == (
        SolverOptions().rtol,
        SolverOptions().until,
        SolverOptions().frames_per_tff,
    )
    assert i.eps == InitialCondition().eps
    if command == "simulate":
        assert i == InitialCondition()


def test_the_time_cap_and_the_event_limit_are_options():
    """--max-time: a chain held up (the anchor cone's cantilever) or just slow stops with
    status max_time, a message that says it had not landed, a warning and exit code 0;
    --max-events: status error, exit code 1."""
    runner = CliRunner()
    res = runner.invoke(app, ["simulate", "-N", "4", "--max-time", "0.5", "--json", "-q"])
    assert res.exit_code == 0, res.output
    s = json.loads(res.stdout)
    assert s["status"] == "max_time" and "had not landed by t = 0.5 t_ff" in s["message"]
    assert s["t_landed"] is None
    res = runner.invoke(app, ["simulate", "-N", "8", "--max-events", "3", "--json", "-q"])
    assert res.exit_code == 1
    assert "max_events = 3" in json.loads(res.stdout)["message"]
    for bad in (["--max-time", "0"], ["--max-events", "0"]):
        res = runner.invoke(app, ["simulate", "-N", "4", *bad])
        assert res.exit_code == 2 and res.output.count("\n") == 1, res.output


def test_the_compile_notice_counts_the_seconds(monkeypatch):
    """On a terminal the notice shows the seconds elapsed while the kernels compile (it is
    redrawn as they pass); elsewhere a line when it starts and one when it is done."""
    import io
    import time as _t

    from rich.console import Console

    buf = io.StringIO()
    monkeypatch.setattr(cli.running, "_progress_console", lambda: Console(file=buf, force_terminal=True, width=120))
    cli._compile_with_notice(lambda: _t.sleep(1.3), show_progress=True)
    drawn = buf.getvalue()
    assert "compiling the numba kernels" in drawn and ": 1 s" in drawn  # redrawn after a second
    plain = io.StringIO()
    monkeypatch.setattr(cli.running, "_progress_console", lambda: Console(file=plain, force_terminal=False))
    lines = []
    monkeypatch.setattr(cli.typer, "echo", lambda msg, err=False: lines.append(msg))
    cli._compile_with_notice(lambda: None, show_progress=True)
    assert lines[0].startswith("compiling the numba kernels of --method event")
    assert lines[1].startswith("compiled the kernels of --method event in") and "s of CPU)" in lines[1]
    cli._compile_with_notice(lambda: None, show_progress=False, method="rattle")
    assert lines[2].startswith("compiling the numba kernels of --method rattle") and "warmup" in lines[2]


@pytest.mark.parametrize("text", ["pi/0", "1.2.3pi/4", "2pi/", "1e999pi"])
@pytest.mark.parametrize(
    "command",
    [
        ("simulate", "--alpha"),
        ("simulate", "--phase"),
        ("sweep", "--alpha"),
        ("paper", "--alpha"),
        ("paper", "--alphas"),
        ("theory", "pivot-rod", "--theta0"),
        ("theory", "rod-on-floor", "--theta0"),
    ],
)
def test_bad_angle_is_one_line(engine, tmp_path, command, text):
    """An angle expression that is not an angle (a division by zero, a malformed number)
    ends in one line that names the option, not a traceback."""
    *cmd, option = command
    res = run(*cmd, option, text, *(["--out", str(tmp_path / "t.parquet")] if cmd == ["sweep"] else []))
    assert_one_line_error(res, 2, "cannot parse angle", option.lstrip("-"))


@pytest.mark.parametrize(
    "args, option",
    [
        (("simulate", "--segments", "4", "--output"), "--output"),
        (("view", "RUN", "--out"), "--out"),
        (("export", "RUN", "--format", "xyz", "--out"), "--out"),
        (("animate", "RUN", "--out"), "--out"),
    ],
)
def test_a_file_in_the_way_names_the_commands_option(engine, tmp_path, args, option):
    """A message names the option the command has and the fix the command line offers
    (not a Python call)."""
    run_file = tmp_path / "run.h5"
    save_result(fake_result(ChainParams(segments=4), InitialCondition(), SolverOptions()), run_file)
    suffix = {"view": ".html", "export": ".xyz", "animate": ".gif"}.get(args[0], ".h5")
    target = tmp_path / f"exists{suffix}"
    target.write_bytes(b"precious")
    argv = [str(run_file) if a == "RUN" else a for a in args]
    err = assert_one_line_error(run(*argv, str(target)), 2, f"{option}: file", "exists", "use --force")
    assert "save_result" not in err and "force=True" not in err
    assert target.read_bytes() == b"precious"


def test_the_json_keys_page_lists_exactly_the_keys_printed(engine, tmp_path):
    """records.json_keys (the documentation's JSON page) against the objects printed:
    a key printed without its line there, or listed and gone, fails here."""
    import dataclasses

    from ballchain.records import json_keys
    from ballchain.sweeps.execute import SweepReport

    out = tmp_path / "run.h5"
    res = run("simulate", "--json", "--segments", "4", "--output", str(out))
    assert res.exit_code == 0, res.stderr
    assert set(json.loads(res.stdout)) == set(json_keys.RUN)
    info = run("info", str(out), "--json")
    cli_only = {k for k, v in json_keys.RUN.items() if v.startswith("(runs of the command line)")}
    assert cli_only and set(json_keys.RUN) - cli_only <= set(json.loads(info.stdout)) <= set(json_keys.RUN)
    assert {f.name for f in dataclasses.fields(SweepReport)} == set(json_keys.SWEEP)


def test_theory_rod_on_floor_prints_the_closed_forms_and_null_for_a_rod_that_never_falls():
    """``ballchain theory rod-on-floor``: the numbers of ballchain.theory, in JSON; an
    upright rod (never falls) and a slip that never comes are null, not a traceback."""
    from ballchain import theory

    out = json.loads(run(*["theory", "rod-on-floor", "--theta0", "30deg", "--mu", "0.4", "--json"]).stdout)
    th0 = math.radians(30)
    assert out["frictionless_fall_time"] == theory.sliding_rod_fall_time(th0)
    assert out["pivot_fall_time"] == theory.rod_fall_time(th0)
    assert out["slip_angle"] == theory.pivot_rod_slip_angle(th0, 0.4) and th0 < out["slip_angle"] < math.pi / 2
    assert out["slip_time"] == theory.pivot_rod_time(out["slip_angle"], th0)
    up = json.loads(run(*["theory", "rod-on-floor", "--theta0", "0", "--json"]).stdout)
    assert up["frictionless_fall_time"] is None and up["pivot_fall_time"] is None
    never = json.loads(run(*["theory", "rod-on-floor", "--theta0", "0.3", "--mu", "1e9", "--json"]).stdout)
    assert never["slip_angle"] is None and never["slip_time"] is None
    bad = run(*["theory", "rod-on-floor", "--theta0", "0.3", "--mu", "-1"])
    assert bad.exit_code == 2 and "mu must be >= 0" in bad.stderr


# ------------------------------------------------------- issue 82: nothing silently ignored
def test_an_option_of_another_method_is_refused_before_the_run(engine):
    res = run("simulate", "-N", "8", "--method", "event", "--dt", "0.1", "--quiet")
    assert_one_line_error(res, 2, "--dt 0.1", "--method timestep and rattle", "not used by --method event")
    res = run("simulate", "-N", "8", "--method", "rattle", "--theta", "0.5", "--quiet")
    assert_one_line_error(res, 2, "--theta 0.5", "--method timestep", "not used by --method rattle")
    assert engine.calls == []


def test_from_a_run_of_another_method_takes_only_the_options_both_take(engine, tmp_path):
    """``--from`` a time-stepper's file (which records dt and theta) rerun with another
    method: its dt is RATTLE's too, its theta nobody else's; the event method takes neither."""
    path = tmp_path / "ts.h5"
    o = SolverOptions(method="timestep", dt=0.02, theta=1.0)
    save_result(fake_result(ChainParams(segments=8), InitialCondition(), o), path)
    for method, dt in (("event", None), ("rattle", 0.02), ("timestep", 0.02)):
        res = run("simulate", "--from", str(path), "--method", method, "--quiet")
        assert res.exit_code == 0, res.stderr
        options = engine.calls[-1][2]
        assert (options.method, options.dt, options.theta) == (method, dt, 1.0 if method == "timestep" else None)


@pytest.mark.parametrize(
    "args, words",
    [
        (["--ic", "random"], "--ic is not used beside --initial"),
        (["--eps", "0.1", "--seed", "3"], "--eps, --seed are not used beside --initial"),
    ],
)
def test_a_start_option_beside_an_explicit_state_is_refused(engine, tmp_path, args, words):
    f = tmp_path / "f.txt"
    f.write_text("0 0 1\n0 0 1\n0 0 1\n")
    assert_one_line_error(run("simulate", "--initial", str(f), *args, "--quiet"), 2, words)
    import ballchain as bc

    with pytest.raises(ParameterError, match="--ic is not used beside initial="):
        bc.simulate(initial=str(f), ic="random")
    assert engine.calls == []


def test_nan_is_refused_as_not_a_number(engine):
    for flag in ("--friction", "--restitution-lock", "--restitution-floor", "--theta"):
        err = assert_one_line_error(run("simulate", flag, "nan", "--quiet"), 2, "must be a number in [", "got nan")
        assert "negative" not in err and "creates energy" not in err and "unstable" not in err


def _bad_files(tmp_path):
    (tmp_path / "empty.txt").write_text("")
    (tmp_path / "empty.npy").write_bytes(b"")
    (tmp_path / "comments.txt").write_text("# no rows\n\n")
    (tmp_path / "text.npy").write_text("0 0 1\n")
    np.save(tmp_path / "objects.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    return {
        "empty.txt": "is empty (no rows)",
        "empty.npy": "is empty (no rows)",
        "comments.txt": "holds no rows (only comments or blank lines)",
        "text.npy": "not a .npy file",
        "objects.npy": "an array of Python objects, not numbers",
    }


def test_a_bad_initial_file_is_named_with_its_own_cause(engine, tmp_path):
    for name, words in _bad_files(tmp_path).items():
        err = assert_one_line_error(run("simulate", "--initial", str(tmp_path / name), "--quiet"), 2, name, words)
        assert "allow_pickle" not in err and "Warning" not in err and ".py" not in err.replace(".npy", "")
    assert engine.calls == []


def test_an_explicit_state_outside_the_cone_does_not_say_reduce_eps():
    from ballchain.engine import _initial_state

    e0 = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.1]])
    with pytest.raises(ParameterError) as exc:
        _initial_state(ChainParams(segments=2), None, (e0, None))
    assert "eps" not in str(exc.value) and "explicit initial state" in str(exc.value)


def test_an_absurd_run_is_warned_of_before_it_starts(engine):
    """``--method timestep --dt 1e-9``: one line on stderr with the steps, a rough wall time
    and what shortens it; the run is not refused.  The default step is not warned of, nor the
    event method (which sizes its own steps)."""
    res = run("simulate", "-N", "8", "--method", "timestep", "--dt", "1e-9", "--quiet")
    assert res.exit_code == 0 and len(engine.calls) == 1, res.stderr
    (line,) = [ln for ln in res.stderr.splitlines() if "steps" in ln]
    assert line.startswith("warning: --method timestep --dt 1e-09 at N = 8 takes about 8e+09 steps per t_ff")
    assert " h each, up to --max-time 3 t_ff)" in line and "a larger --dt (its default there: 0.01)" in line
    for args in (["--method", "timestep"], ["--method", "rattle", "--dt", "0.2"], []):
        assert "takes about" not in run("simulate", "-N", "4096", *args, "--quiet").stderr
    from ballchain.cli.running import cost_warning

    short = cost_warning(8, SolverOptions(method="rattle", dt=1e-9, until=0.1))
    assert "takes about 8e+09 steps per t_ff of the fall (roughly" in short and "up to --until 0.1 t_ff" in short
    assert "its default there: 0.05" in short
    assert cost_warning(8, SolverOptions(method="rattle", dt=1e-9, until=1e-3)) is None


def test_every_experimental_method_says_so_and_counts_what_it_counts(engine):
    """Both steppers are experimental (docs/timestep.md, docs/rattle.md): each says so on
    stderr and on its summary's method line; the event method does not.  The line of events
    counts the event method's instants and a stepper's steps (never '0 instants')."""
    for method in ("timestep", "rattle", "event"):
        res = run("simulate", "-N", "8", "--method", method, "--quiet")
        assert res.exit_code == 0, res.stderr
        (line,) = [ln for ln in res.stdout.splitlines() if ln.strip().startswith("method")]
        (events,) = [ln for ln in res.stdout.splitlines() if ln.strip().startswith("events")]
        stepper = method != "event"
        assert ("experimental" in line) == stepper and (f"--method {method} is experimental" in res.stderr) == stepper
        assert ("(20 steps)" in events) == stepper and ("(2 instants)" in events) == (not stepper), events
    assert "experimental" in cli.command_options("simulate")["method"][0].split("timestep")[1].split("rattle")[0]


def test_warmup_compiles_each_method_in_a_process_of_its_own_and_says_what_it_cost():
    """``ballchain warmup --method M``: the method's kernels are in numba's cache afterwards
    (a worker process compiled or loaded them), and it reports, per method, whether it
    compiled and the wall and CPU seconds; a method that does not exist is one line, exit 2."""
    from ballchain.engine import kernels_cached

    res = CliRunner().invoke(app, ["warmup", "--method", "event", "--json"])
    assert res.exit_code == 0, res.output
    (d,) = json.loads(res.stdout)
    assert d["method"] == "event" and isinstance(d["compiled"], bool)
    assert d["wall_seconds"] > 0.0 and d["cpu_seconds"] > 0.0
    assert kernels_cached("event")
    res = CliRunner().invoke(app, ["warmup", "--method", "event"])
    assert res.exit_code == 0 and "event: already compiled, loaded in" in res.stdout
    res = CliRunner().invoke(app, ["warmup", "--method", "exact"])
    assert res.exit_code == 2 and len(res.stderr.strip().splitlines()) == 1 and "--method" in res.stderr
