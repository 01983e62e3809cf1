"""Each method's package states its own options (``options.MethodOption``) and
everything that names an option learns it from the registry (``methods.all_options``):
a new option touches one file.  Importing ballchain (and the registry, the CLI, the
sweeps) loads no method's kernels."""

import dataclasses
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from ballchain import methods
from ballchain.errors import ParameterError
from ballchain.model import SolverOptions
from ballchain.options import MethodOption

TESTS = Path(__file__).parent

# A new option of the RATTLE method, stated in its package's OPTIONS and nowhere else (the
# subprocess adds it before anything reads the registry), then looked for everywhere.
NEW_OPTION = textwrap.dedent(
    """
    import json, sys, types
    import ballchain.methods.rattle as rattle
    from ballchain.options import MethodOption, positive

    rattle.OPTIONS = rattle.OPTIONS + (MethodOption(
        "fake_gain", float, 2.0, "--method rattle: a fake gain, in units of E0 (at most 10).",
        positive(at_most=10.0, unit="units of E0"), flag="--fake-gain", json="the fake gain (E0)",
        column="the fake gain, E0"),)

    sys.path.insert(0, sys.argv[1])  # the tests: the CLI's fake engine
    sys.path.insert(0, sys.argv[2])  # docs/_ext: the generated pages
    from typer.testing import CliRunner
    import ballchain as bc
    from ballchain import api
    from ballchain.cli import app, command_options
    from ballchain.inputs import build_inputs
    from ballchain.model import ParameterError, SolverOptions
    from ballchain.records.json_keys import RUN
    from ballchain.sweeps import SweepSpec
    from ballchain.sweeps.table import COLUMNS, CONVENTIONS, input_row
    from generated_tables import _cli_reference, _json_keys, _sweep_columns
    from test_cli import FakeEngine

    out = {}
    runner = CliRunner()
    for command in ("simulate", "sweep"):
        res = runner.invoke(app, [command, "--help"])
        out[command + "_help"] = "--fake-gain" in res.stdout and "a fake gain" in res.stdout
        out[command + "_flag"] = command_options(command).get("fake_gain")
    out["cli_docs"] = "--fake-gain" in _cli_reference()
    out["default"] = SolverOptions().fake_gain
    out["set"] = SolverOptions(method="rattle", fake_gain=3).fake_gain
    for bad in (-1.0, 11.0, "x"):
        try:
            SolverOptions(fake_gain=bad)
            out.setdefault("unchecked", []).append(bad)
        except ParameterError as exc:
            out.setdefault("errors", []).append(str(exc))
    out["inputs"] = build_inputs({"method": "rattle", "fake_gain": 4.0})[2].fake_gain
    res = runner.invoke(app, ["simulate", "--fake-gain", "-1", "--quiet"])
    out["cli_error"] = (res.exit_code, res.stderr.strip())

    engine = FakeEngine()
    sys.modules["ballchain.engine"] = types.SimpleNamespace(
        simulate=engine.simulate, kernels_cached=lambda method="event": True, load_kernels=lambda method="event": False
    )
    res = runner.invoke(app, ["simulate", "-N", "4", "--method", "rattle", "--fake-gain", "3", "--json", "--quiet"])
    out["json"] = json.loads(res.stdout).get("fake_gain") if res.exit_code == 0 else res.stderr
    out["json_key"] = RUN.get("fake_gain")
    out["json_docs"] = "the fake gain (E0)" in _json_keys()

    spec = SweepSpec(segments=(4,), alphas=(1.0,), method="rattle", fake_gain=3.0)
    task = spec.tasks()[0]
    out["sweep_option"] = task.options.fake_gain
    out["run_id"] = task.run_id
    out["default_run_id"] = SweepSpec(segments=(4,), alphas=(1.0,), method="rattle").tasks()[0].run_id
    out["column"] = COLUMNS.get("fake_gain")
    out["row"] = input_row(task).get("fake_gain")
    out["conventions"] = "--fake-gain FAKE_GAIN" in CONVENTIONS
    out["column_docs"] = "the fake gain, E0" in _sweep_columns()
    out["api"] = ["fake_gain" in api.SIMULATE_KEYWORDS, api.SWEEP_KEYWORDS.get("fake_gain")]
    out["api_docs"] = ["``fake_gain``" in f.__doc__ for f in (bc.simulate, bc.sweep)]
    out["dataclass_docs"] = "fake_gain" in SolverOptions.__doc__
    print(json.dumps(out))
    """
)


def test_a_new_option_touches_one_file():
    """One ``MethodOption`` added to the RATTLE package's ``OPTIONS``: it is a
    ``SolverOptions`` field with its default and check, a flag of ``simulate`` and
    ``sweep`` with its help (also in the generated CLI reference), a key of
    ``simulate --json``, a sweep option with its column and its part of the run key, and a
    keyword of ``bc.simulate`` and ``bc.sweep`` with its help."""
    docs_ext = TESTS.parent / "docs" / "_ext"
    res = subprocess.run(
        [sys.executable, "-c", NEW_OPTION, str(TESTS), str(docs_ext)], capture_output=True, text=True, timeout=300
    )
    assert res.returncode == 0, res.stderr[-3000:]
    out = json.loads(res.stdout.strip().splitlines()[-1])
    assert out["simulate_help"] and out["sweep_help"] and out["cli_docs"]
    help_text = "--method rattle: a fake gain, in units of E0 (at most 10)."
    assert command_help(out, "simulate") == command_help(out, "sweep") == [help_text, 2.0]
    assert out["default"] == 2.0 and out["set"] == 3.0 and out["inputs"] == 4.0
    assert "unchecked" not in out, out.get("unchecked")
    assert [e.split(",")[0] for e in out["errors"]] == [
        "fake_gain must be finite and > 0",
        "fake_gain must be at most 10 (units of E0)",
        "fake_gain must be a number",
    ]
    assert out["cli_error"] == [2, "error: fake_gain must be finite and > 0, got -1.0"]
    assert out["json"] == 3.0 and out["json_key"] == "the fake gain (E0)" and out["json_docs"]
    assert out["sweep_option"] == 3.0 and out["row"] == 3.0
    assert out["run_id"] == out["default_run_id"] + "_fake_gain3"  # runs that do not set it keep their keys
    assert out["column"] == ["float64", "the fake gain, E0"] and out["conventions"] and out["column_docs"]
    assert out["api"] == [True, 2.0] and out["api_docs"] == [True, True] and out["dataclass_docs"]


def command_help(out: dict, command: str) -> list:
    """(help, default) of the fake option in ``command``, as ``cli.command_options`` read it."""
    return out[command + "_flag"]


def test_the_registry_states_every_method_option_once():
    """The methods' options are the fields of SolverOptions after its own, each stated by
    one method, its default passes its own check, and its flag is unique."""
    opts = methods.all_options()
    fields = [f.name for f in dataclasses.fields(SolverOptions)]
    assert fields[-len(opts) :] == list(opts)
    assert {methods.option_owner(n) for n in ("rtol", "event_xtol", "hold_rate", "hold_apex")} == {"event"}
    assert {methods.option_owner(n) for n in ("dt", "theta", "dt_rule")} == {"timestep"}
    assert {methods.option_owner(n) for n in ("step_energy_tol", "landing_step")} == {"rattle"}
    for name, opt in opts.items():
        assert isinstance(opt, MethodOption) and opt.validated(opt.default) == opt.default, name
        assert getattr(SolverOptions(), name) == opt.default, name
    flags = [o.flag for o in opts.values() if o.flag]
    assert len(flags) == len(set(flags))
    assert methods.option_names("simulate") == [
        "rtol",
        "hold_rate",
        "hold_rate_floor",
        "dt",
        "theta",
        "dt_rule",
        "step_energy_tol",
        "landing_step",
    ]
    assert methods.option_names("sweep") == methods.option_names("simulate")


def test_defaults_by_n_come_from_the_owner_or_the_method():
    """dt and theta left to None: the time-stepper's step by N, RATTLE's own (its
    DEFAULTS), the short step recorded by the event method, as before."""
    assert methods.default_step("timestep", 1023) == (0.01, 0.5)
    assert methods.default_step("timestep", 1024) == (0.02, 1.0)
    assert methods.default_step("rattle", 4096) == (0.05, 1.0)
    assert methods.default_step("event", 4096) == (0.01, 0.5)
    o = SolverOptions(method="rattle", theta=0.75).for_segments(64)
    assert (o.dt, o.theta, o.step_energy_tol) == (0.05, 0.75, None)
    assert "--method rattle: default 0.05 (0.1 or 0.2 for ensembles at N >= 1024" in methods.option_help("dt")


@pytest.mark.parametrize(
    "kw, words",
    [
        (dict(rtol=0.0), "rtol must be finite and in (0, 1)"),
        (dict(rtol=1e-15), "below what double precision can honour"),
        (dict(dt=5.0), "dt must be at most 4 (units of t_ff/N)"),
        (dict(theta=0.4), "theta must be in [0.5, 1] (below 1/2 the step is unstable)"),
        (dict(theta=1.5), "theta must be in [0.5, 1] (above 1 the axes would turn at rates beyond those after"),
        (dict(dt_rule="adaptive"), "dt_rule must be one of ('fixed', 'landing')"),
        (dict(step_energy_tol=-1.0), "step_energy_tol must be finite and >= 0"),
        (dict(hold_apex=1e-13), "hold_apex must be >= 1e-12"),
        (dict(event_xtol=0.0), "event_xtol must be finite and > 0"),
    ],
)
def test_method_options_are_checked_by_their_spec(kw, words):
    with pytest.raises(ParameterError) as exc:
        SolverOptions(**kw)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_importing_ballchain_loads_no_method_kernels():
    """Importing ballchain, the registry (every method's options and bounds), the model,
    the CLI, the API and the sweeps imports no numba and no method's kernels; the
    default method's run imports no other method's modules."""
    code = textwrap.dedent(
        """
        import sys, json
        import ballchain, ballchain.model, ballchain.cli, ballchain.api, ballchain.sweeps.spec, ballchain.sweeps.table
        from ballchain import methods
        methods.all_options(); [methods.audit_bounds(m) for m in methods.METHODS]
        ballchain.model.SolverOptions(method="rattle").for_segments(64)
        light = sorted(m for m in sys.modules if m == "numba" or m.startswith("numba."))
        from ballchain import engine
        methods.method_runner("event"), methods.entry_kernel("event")
        others = sorted(m for m in sys.modules if m.startswith(("ballchain.methods.timestep.", "ballchain.methods.rattle.")))
        print(json.dumps([light, others]))
        """
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    light, others = json.loads(res.stdout.strip().splitlines()[-1])
    assert light == []
    assert others == []


# An option of one method given to another that neither owns nor uses it (issue 82): refused
# in one line naming the option, its methods and the method in use, by the one check
# (``methods.check_options``) that the command line, ``bc.simulate`` and the sweeps call.
OTHER_METHODS = [
    ("event", dict(dt=0.1), "--dt 0.1 is an option of --method timestep and rattle, not used by --method event"),
    ("event", dict(theta=1.0), "--theta 1 is an option of --method timestep, not used by --method event"),
    ("event", dict(step_energy_tol=0.0), "--step-energy-tol 0 is an option of --method rattle, not used by"),
    ("event", dict(dt_rule="landing"), "--dt-rule landing is an option of --method timestep, not used by"),
    ("rattle", dict(theta=0.5), "--theta 0.5 is an option of --method timestep, not used by --method rattle"),
    ("rattle", dict(dt_rule="landing"), "--dt-rule landing is an option of --method timestep, not used by"),
    ("timestep", dict(step_energy_tol=1e-6), "--step-energy-tol 1e-06 is an option of --method rattle, not used"),
    ("timestep", dict(landing_step="whole"), "--landing-step whole is an option of --method rattle, not used by"),
    ("timestep", dict(rtol=1e-9), "--rtol 1e-09 is an option of --method event, not used by --method timestep"),
    ("rattle", dict(hold_rate=1e-3), "--hold-rate 0.001 is an option of --method event, not used by --method rattle"),
]


@pytest.mark.parametrize("method, kw, words", OTHER_METHODS, ids=[f"{m}-{list(kw)[0]}" for m, kw, _ in OTHER_METHODS])
def test_an_option_of_another_method_is_refused_in_one_line(method, kw, words):
    from ballchain import engine
    from ballchain.inputs import build_inputs
    from ballchain.model import ChainParams
    from ballchain.sweeps import SweepSpec

    calls = {
        "keywords": lambda: build_inputs({"segments": 8, "method": method, **kw}),  # the CLI, bc.simulate
        "options": lambda: engine.simulate(ChainParams(segments=8), options=SolverOptions(method=method, **kw)),
        "sweep": lambda: SweepSpec(segments=(8,), alphas=(1.0,), method=method, **kw),
    }
    for where, call in calls.items():
        with pytest.raises(ParameterError) as exc:
            call()
        assert str(exc.value).startswith(words) and "\n" not in str(exc.value), (where, str(exc.value))


def test_options_a_method_takes_or_records_are_not_refused():
    """What a method owns or uses (RATTLE's --dt), what is left at its default, and the
    options a run records (``for_segments``: every option, given or not) pass; given
    as keywords, the value another method's run records is refused all the same."""
    from ballchain.inputs import build_inputs

    build_inputs({"segments": 8, "method": "rattle", "dt": 0.1, "step_energy_tol": 0.0, "landing_step": "whole"})
    build_inputs({"segments": 8, "method": "event", "rtol": 1e-9, "hold_rate_floor": 0.1, "landing_step": "cut"})
    for method in methods.METHOD_NAMES:
        for n in (8, 4096):
            methods.check_options(SolverOptions(method=method).for_segments(n), n, filled=True)
    with pytest.raises(ParameterError, match="--dt 0.01 is an option of"):
        build_inputs({"segments": 8, "method": "event", "dt": 0.01})
