"""The release's bookkeeping: one version, semantic, named by the changelog's newest release,
and a changelog in Keep a Changelog's form (the CI's wheel step checks the built wheel)."""

import datetime as dt
import re
import tomllib
from pathlib import Path

import ballchain

ROOT = Path(__file__).resolve().parents[1]
RELEASE = re.compile(r"^## \[(\d+)\.(\d+)\.(\d+)\] - (\d{4}-\d{2}-\d{2})$")
GROUPS = {"Added", "Changed", "Deprecated", "Removed", "Fixed", "Security"}


def _changelog_headings() -> list[str]:
    return [line for line in (ROOT / "CHANGELOG.md").read_text().splitlines() if line.startswith("## ")]


def test_the_version_is_semantic_and_read_from_its_one_place():
    assert re.fullmatch(r"\d+\.\d+\.\d+", ballchain.__version__)
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    source = ROOT / project["tool"]["hatch"]["version"]["path"]
    assert source.resolve() == Path(ballchain.__file__).resolve()
    assert "\nversion:" not in (ROOT / "CITATION.cff").read_text()  # no second copy to go stale


def test_the_changelog_newest_release_is_the_version_and_releases_go_back_in_time():
    headings = _changelog_headings()
    assert headings[0] == "## [Unreleased]"
    releases = [RELEASE.match(h) for h in headings[1:]]
    assert all(releases), [h for h, m in zip(headings[1:], releases) if not m]
    versions = [tuple(int(x) for x in m.groups()[:3]) for m in releases]
    dates = [dt.date.fromisoformat(m.group(4)) for m in releases]
    assert ".".join(map(str, versions[0])) == ballchain.__version__
    assert versions == sorted(versions, reverse=True) and len(set(versions)) == len(versions)
    assert dates == sorted(dates, reverse=True)


def test_the_changelog_groups_are_keep_a_changelog_s():
    groups = [line[4:] for line in (ROOT / "CHANGELOG.md").read_text().splitlines() if line.startswith("### ")]
    assert groups and set(groups) <= GROUPS, sorted(set(groups) - GROUPS)
