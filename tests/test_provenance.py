"""Every number traceable to the engine that made it: a fingerprint of the engine's sources
and the package version in --json, in the result file, in the sweep table; stats says when a
table mixes engines."""

import json
import shutil

import h5py
import pandas as pd
from typer.testing import CliRunner

from ballchain import __version__
from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.provenance import PACKAGE_DIR, engine_fingerprint, engine_sources, fingerprint_of
from ballchain.records.files import load_result, save_result
from ballchain.sweeps.table import read_table


def test_the_fingerprint_follows_the_engine_sources(tmp_path):
    copy = tmp_path / "ballchain"
    shutil.copytree(PACKAGE_DIR, copy, ignore=shutil.ignore_patterns("__pycache__"))
    assert fingerprint_of(copy) == engine_fingerprint()  # the same sources, the same engine
    names = {p.relative_to(copy).as_posix() for p in engine_sources(copy)}
    assert {"engine.py", "core/dynamics.py", "methods/event_driven/events.py", "floors/pivot.py"} <= names
    (copy / "cli" / "app.py").write_text((copy / "cli" / "app.py").read_text() + "\n# not the engine\n")
    assert fingerprint_of(copy) == engine_fingerprint()  # the applications are not the engine
    kernel = copy / "core" / "rules.py"
    kernel.write_text(kernel.read_text() + "\n# an edit\n")
    changed = fingerprint_of(copy)
    assert changed != engine_fingerprint() and len(changed) == 12


def test_the_engine_and_version_are_in_the_json_the_file_and_the_table(tmp_path):
    res = CliRunner().invoke(app, ["simulate", "-N", "3", "--until", "0.2", "--json", "-q"])
    summary = json.loads(res.stdout)
    assert (summary["engine"], summary["version"]) == (engine_fingerprint(), __version__)
    r = simulate(ChainParams(segments=3), InitialCondition(), SolverOptions(until=0.2))
    assert (r.engine, r.version) == (engine_fingerprint(), __version__)
    path = save_result(r, tmp_path / "r.h5")
    with h5py.File(path, "r") as f:  # as any HDF5 reader sees them
        assert (f.attrs["engine"], f.attrs["version"], f.attrs["package_version"]) == (
            engine_fingerprint(),
            __version__,
            __version__,
        )
    loaded = load_result(path)
    assert (loaded.engine, loaded.version) == (engine_fingerprint(), __version__)
    r.version = "0.1.0"  # a run of an older ballchain, saved by this one: each version is its own
    with h5py.File(save_result(r, tmp_path / "old.h5"), "r") as f:
        assert (f.attrs["version"], f.attrs["package_version"]) == ("0.1.0", __version__)
    assert load_result(tmp_path / "old.h5").version == "0.1.0"
    out = tmp_path / "t.parquet"
    res = CliRunner().invoke(
        app, ["sweep", "-N", "3", "--until", "0.2", "--runs", "2", "--workers", "1", "-q", "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    table = pd.read_parquet(out)
    assert set(table["engine"]) == {engine_fingerprint()} and set(table["version"]) == {__version__}
    old = tmp_path / "old.parquet"  # a table written before the two columns: they read back empty
    table.drop(columns=["engine", "version"]).to_parquet(old)
    assert {(row["engine"], row["version"]) for row in read_table(old)} == {("", "")}
    stats = CliRunner().invoke(app, ["stats", str(out), "--json"])
    assert json.loads(stats.stdout)["engines"] == [engine_fingerprint()] and "mixes" not in stats.output
    table.loc[0, "engine"] = "0123456789ab"  # a row from another engine
    table.to_parquet(out)
    stats = CliRunner().invoke(app, ["stats", str(out), "--json"])
    assert stats.exit_code == 0
    assert json.loads(stats.stdout)["engines"] == sorted(["0123456789ab", engine_fingerprint()])
    assert "warning: the table mixes 2 engines" in stats.stderr
