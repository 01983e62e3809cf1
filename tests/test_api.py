"""The Python interface in one import (ballchain.api) and ``simulate --from``."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from typer.testing import CliRunner

import ballchain as bc
from ballchain.cli import app


def test_import_ballchain_is_light():
    code = ("import sys, ballchain as bc; heavy = {'numba', 'dask', 'matplotlib', 'plotly', 'pandas'};"
            "print(sorted(heavy & set(sys.modules)))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_keywords_as_the_cli_and_the_dataclasses_agree():
    """An alpha = pi fall (no lock event: well conditioned) from keywords with an angle in
    degrees and from the dataclasses with radians: the same fall."""
    a = bc.simulate(segments=6, alpha="180deg", ic="planar", eps=0.1, until=0.7)
    b = bc.simulate(bc.ChainParams(segments=6, alpha=math.pi), bc.InitialCondition(kind="planar", eps=0.1),
                    bc.SolverOptions(until=0.7))  # fmt: skip
    assert a.status == b.status == "until"
    assert a.params == b.params and a.ic == b.ic and a.options == b.options
    np.testing.assert_allclose(a.frame_e[-1], b.frame_e[-1], rtol=0, atol=1e-12)
    with pytest.raises(TypeError, match="unknown keyword"):
        bc.simulate(segmnets=4)
    with pytest.raises(bc.ParameterError, match="alpha"):
        bc.simulate(segments=4, alpha="ninety")


def test_an_initial_state_array_and_the_tables():
    e0 = np.tile([0.1, 0.0, 1.0], (5, 1))
    e0[::2, 0] = -0.1
    r = bc.simulate(initial=e0, alpha="pi/4")
    assert r.status == "landed" and r.params.segments == 5
    ev = r.events_table()
    counts = ev["kind"].value_counts().to_dict()
    assert {k: v for k, v in r.event_counts().items() if v} == counts
    np.testing.assert_array_equal(ev["t"].to_numpy(), r.event_t)
    fr = r.frames_table()
    assert len(fr) == len(r.frame_t) and np.all(np.diff(fr["n_landed"]) >= 0)  # landed segments stay landed
    assert fr["n_landed"].iloc[0] == 0 and 0 < fr["n_landed"].iloc[-1] <= 5
    # the books of the last frame: E0 = U + T + losses (the audit's 1e-8 of E0 at the end)
    last = fr.iloc[-1]
    total = last.kinetic + last.potential + last.lost_locking + last.lost_landing
    assert total == pytest.approx(r.energy["initial"], rel=1e-7)
    np.testing.assert_allclose(fr["z_top"], r.points()[:, 0, 2])


def test_load_save_sweep_and_stats(tmp_path):
    r = bc.simulate(segments=3, until=0.3)
    path = bc.save(r, tmp_path / "r.h5")
    assert bc.load(path).t_ff == r.t_ff
    table = bc.sweep(segments=[4, 6], alpha=["45deg", math.pi], runs=2, until=0.4, workers=1)
    assert len(table) == 8 and set(table["segments"]) == {4, 6} and set(table["status"]) == {"until"}
    s = bc.stats(table)
    assert s["rows"] == 8 and len(s["points"]) == 4
    with pytest.raises(TypeError, match="unknown keyword"):
        bc.sweep(segmets=[4])


def test_simulate_from_a_file_reruns_its_parameters(tmp_path):
    runner = CliRunner()
    f1 = tmp_path / "a.h5"
    first = runner.invoke(app, ["simulate", "-N", "6", "--alpha", "40deg", "--ic", "random", "--seed", "4",
                                "--until", "0.6", "--output", str(f1), "--json", "-q"])  # fmt: skip
    a = json.loads(first.stdout)
    b = json.loads(runner.invoke(app, ["simulate", "--from", str(f1), "--json", "-q"]).stdout)
    for k in ("segments", "alpha", "ic", "status", "events", "n_steps"):
        assert a[k] == b[k], k
    assert b["energy"]["lost_locking"] == pytest.approx(a["energy"]["lost_locking"], rel=1e-9)
    c = json.loads(runner.invoke(app, ["simulate", "--from", str(f1), "--alpha", "pi", "--json", "-q"]).stdout)
    assert c["alpha"] == math.pi and c["events"]["lock"] == 0 and c["ic"] == a["ic"]
    bad = runner.invoke(app, ["simulate", "--from", str(tmp_path / "none.h5")])
    assert bad.exit_code == 2 and bad.output.count("\n") == 1


@pytest.mark.parametrize("function, command", [("simulate", "simulate"), ("sweep", "sweep")])
def test_help_lists_every_keyword_with_the_commands_help(function, command):
    """help(bc.simulate) and help(bc.sweep) name every keyword the function accepts, each
    with the help of the command-line option of the same name."""
    import pydoc

    from ballchain import api
    from ballchain.cli import command_options

    keywords = {"simulate": api.SIMULATE_KEYWORDS, "sweep": api.SWEEP_KEYWORDS}[function]
    text = " ".join(pydoc.render_doc(getattr(bc, function), renderer=pydoc.plaintext).split())
    options = command_options(command)
    for name in keywords:
        assert f"``{name}``" in text, name
        assert " ".join(options[name][0].split()) in text, name


def test_stats_of_a_missing_or_foreign_file_says_which(tmp_path):
    with pytest.raises(bc.ParameterError, match="table: no such file"):
        bc.stats(tmp_path / "nonexistent.parquet")
    text = tmp_path / "notes.parquet"
    text.write_text("not a table")
    with pytest.raises(bc.ParameterError, match="is not a readable Parquet table") as info:
        bc.stats(text)
    assert "exists and" not in str(info.value) and "--out" not in str(info.value)
