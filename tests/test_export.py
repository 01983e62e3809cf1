"""ballchain export: extended XYZ and VTK polylines, read back by minimal readers written
from the formats' definitions (not from the writer), against the result's own points."""

import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from typer.testing import CliRunner

from ballchain.cli import app
from ballchain.engine import simulate
from ballchain.model import ChainParams, InitialCondition, SolverOptions
from ballchain.records.files import save_result


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    r = simulate(ChainParams(segments=7, alpha=0.7), InitialCondition(eps=0.1), SolverOptions(frames_per_tff=40))
    path = tmp_path_factory.mktemp("export") / "run.h5"
    save_result(r, path)
    return r, path


def read_extxyz(path):
    """Frames of an extended XYZ file: [(comment key=value dict, names, rows)]."""
    lines = path.read_text().splitlines()
    out, i = [], 0
    while i < len(lines):
        n = int(lines[i])
        info = dict(re.findall(r'(\w+)=("[^"]*"|\S+)', lines[i + 1]))
        rows = [ln.split() for ln in lines[i + 2 : i + 2 + n]]
        out.append((info, rows))
        i += 2 + n
    return out


def test_extxyz_holds_every_point_of_the_frames_asked_for(run_file, tmp_path):
    r, path = run_file
    out = tmp_path / "fall.xyz"
    res = CliRunner().invoke(app, ["export", str(path), "--format", "xyz", "--out", str(out), "--every", "3"])
    assert res.exit_code == 0, res.output
    frames = read_extxyz(out)
    idx = np.arange(0, len(r.frame_t), 3)
    assert len(frames) == idx.size
    pts = r.points()
    for (info, rows), i in zip(frames, idx):
        assert info["Properties"] == "species:S:1:pos:R:3:anchored:I:1"
        assert float(info["Time"]) == pytest.approx(r.frame_t[i], rel=1e-15, abs=1e-300)
        assert len(rows) == r.params.segments + 1 and all(row[0] == "P" for row in rows)
        xyz = np.array([[float(v) for v in row[1:4]] for row in rows])
        np.testing.assert_allclose(xyz, pts[i], rtol=1e-15, atol=1e-15)
        assert [int(row[4]) for row in rows] == r.frame_anchored[i].astype(int).tolist()
    # the chain's segments are 2b long in every frame written
    for _, rows in frames:
        xyz = np.array([[float(v) for v in row[1:4]] for row in rows])
        np.testing.assert_allclose(np.linalg.norm(np.diff(xyz, axis=0), axis=1), 2.0, rtol=1e-7)


def test_vtk_polylines_and_their_collection(run_file, tmp_path):
    r, path = run_file
    out = tmp_path / "vtk" / "fall.pvd"
    out.parent.mkdir()
    res = CliRunner().invoke(app, ["export", str(path), "--format", "vtk", "--out", str(out), "--frames", "4"])
    assert res.exit_code == 0, res.output
    sets = ET.parse(out).getroot().findall("./Collection/DataSet")
    assert len(sets) == 4
    times = [float(d.get("timestep")) for d in sets]
    assert times[0] == 0.0 and times[-1] == pytest.approx(r.frame_t[-1], rel=1e-15) and times == sorted(times)
    n = r.params.segments + 1
    for d in sets:
        text = (out.parent / d.get("file")).read_text().split("\n")
        assert text[0].startswith("# vtk DataFile") and text[2] == "ASCII" and text[3] == "DATASET POLYDATA"
        assert text[4] == f"POINTS {n} double"
        xyz = np.array([[float(v) for v in text[5 + k].split()] for k in range(n)])
        i = int(np.argmin(np.abs(r.frame_t - float(d.get("timestep")))))
        np.testing.assert_allclose(xyz, r.points()[i], rtol=1e-15, atol=1e-15)
        assert text[5 + n] == f"LINES 1 {n + 1}"
        assert [int(v) for v in text[6 + n].split()] == [n, *range(n)]  # one polyline, top to pivot in order


def test_bad_export_requests_fail_in_one_line(run_file, tmp_path):
    _, path = run_file
    for args in (["--format", "pdb", "--out", str(tmp_path / "a.pdb")],
                 ["--format", "vtk", "--out", str(tmp_path / "a.vtk")],
                 ["--format", "xyz", "--out", str(tmp_path / "nodir" / "a.xyz")],
                 ["--format", "xyz", "--out", str(tmp_path / "a.xyz"), "--every", "0"]):  # fmt: skip
        res = CliRunner().invoke(app, ["export", str(path), *args])
        assert res.exit_code == 2 and res.output.count("\n") == 1, (args, res.output)


@pytest.mark.parametrize("fmt, suffix, files", [("vtk", ".pvd", 6), ("xyz", ".xyz", 1)])
def test_export_says_how_many_files_it_wrote(run_file, tmp_path, fmt, suffix, files):
    _, path = run_file
    out = tmp_path / f"fall{suffix}"
    res = CliRunner().invoke(app, ["export", str(path), "--format", fmt, "--out", str(out), "--frames", "5"])
    assert res.exit_code == 0, res.output
    assert res.stdout.strip() == str(out)
    assert f"wrote {files} file" in res.stderr and "5 frames" in res.stderr
    assert len(list(tmp_path.iterdir())) == files


def test_vtk_frame_files_in_the_way_need_force(run_file, tmp_path):
    _, path = run_file
    (tmp_path / "fall_0001.vtk").write_text("precious")
    args = ["export", str(path), "--format", "vtk", "--out", str(tmp_path / "fall.pvd"), "--frames", "3"]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 2 and "fall_0001.vtk" in res.stderr and "--force" in res.stderr
    assert (tmp_path / "fall_0001.vtk").read_text() == "precious" and not (tmp_path / "fall.pvd").exists()
    assert CliRunner().invoke(app, [*args, "--force"]).exit_code == 0
