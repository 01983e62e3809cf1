"""The README a newcomer reads, and the site's front page (docs/index.md), held true.

* Every command of their code blocks runs (in a temporary directory, in their order; the
  slow ones on a small chain: ``SMALL`` below is the whole mapping), and the README's set-up
  is two commands, the second exactly what CI runs first (``.ci/run``: the fast tier; the
  slow tier after it).
* The "Which method when" table is the same on both, and each of its contact-law cells is
  what the methods' registry says (``ballchain.methods.honours``) and what a run does.
* Every number their prose and tables quote stands on a page the same paragraph links.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from test_quoted_numbers import _block_commands

from ballchain.contacts.registry import all_params
from ballchain.methods import METHOD_NAMES, check_contacts, honours

ROOT = Path(__file__).parents[1]
README = ROOT / "README.md"
INDEX = ROOT / "docs" / "index.md"
COMMAND = r"(?:python3 -m venv|ballchain)"

# The README's and the index's commands as the tests run them: a fall on 16 segments, a
# sweep of 2 starts on N = 16 and 32, the Python example on N = 16 (pattern -> replacement;
# a ``ballchain simulate`` that names no N gets ``--segments 16``).
SMALL = {
    r"--segments \d+": "--segments 16",
    r"-N [\d,]+": "-N 16,32",
    r"--runs \d+": "--runs 2",
    r"segments=\d+": "segments=16",
    r"runs=4": "runs=2",
}


def _small(command: str) -> str:
    for pattern, repl in SMALL.items():
        command = re.sub(pattern, repl, command)
    if command.startswith("ballchain simulate") and "--segments" not in command:
        command += " --segments 16"
    return command


def _commands(path: Path) -> list[str]:
    """A page's code-block commands (``ballchain ...`` and the set-up lines), comments off."""
    text = re.sub(r"^```\{.*?^```", "", path.read_text(), flags=re.M | re.S)  # (the site's directives)
    return [re.split(r"\s+#\s", c.replace("\\\n", " "))[0].strip() for c in _block_commands(text, COMMAND)]


def _setup(path: Path) -> list[str]:
    return [c for c in _commands(path) if c.startswith("python3 -m venv")]


def _ci_line(start: str) -> str:
    lines = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines() if ln.startswith(start)]
    assert len(lines) == 1, start
    return lines[0]


def _run(command: str, cwd: Path) -> subprocess.CompletedProcess:
    """One ``ballchain ...`` command, by this interpreter's package."""
    args = shlex.split(command)
    assert args[0] == "ballchain", command
    env = {**os.environ, "MPLBACKEND": "Agg"}
    out = subprocess.run(
        [sys.executable, "-m", "ballchain.cli", *args[1:]], cwd=cwd, capture_output=True, text=True, env=env
    )
    assert out.returncode == 0, (command, out.stdout[-2000:], out.stderr[-2000:])
    return out


def test_the_readme_is_read_in_five_minutes():
    assert len(README.read_text().splitlines()) <= 120


def test_the_set_up_is_two_commands_and_the_second_is_what_ci_runs():
    install_run, install_test = _setup(README)
    assert install_test == _ci_line("python3 -m venv")
    assert install_test.endswith('pytest -q -m "not slow"')  # the fast tier ...
    assert _ci_line("pytest -q -m slow")  # ... and CI runs the slow tier after it
    assert install_run.startswith("python3 -m venv .venv && . .venv/bin/activate && pip install ")
    assert "--force" in install_run.split(" && ")[-1]  # safe to run twice
    # the site's build command the README gives is the one CI runs
    build = _ci_line('pip install -q -e ".[docs]"')
    assert build in " ".join(README.read_text().split())


def test_the_main_job_runs_twice(tmp_path):
    """The README's first set-up command after its install, on 16 segments, twice: the second
    run overwrites its own file."""
    job = _small(_setup(README)[0].split(" && ")[-1])
    assert job.startswith("ballchain simulate ") and "--segments 16" in job
    for _ in range(2):
        _run(job, tmp_path)
        assert (tmp_path / "fall.h5").stat().st_size > 0


def _python_blocks(path: Path) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", path.read_text(), re.M | re.S)


@pytest.mark.slow
@pytest.mark.parametrize("page", [README, INDEX], ids=["README", "index"])
def test_every_command_the_page_shows_runs(page, tmp_path):
    """Each ``ballchain`` command of the page's code blocks, in its order and on a small chain
    (``SMALL``), then its Python example; the set-up lines run their last command (the
    installs and ``pytest -q`` are what CI runs)."""
    commands = [c.split(" && ")[-1] for c in _commands(page)]
    commands = [c for c in commands if c.startswith("ballchain ")]
    assert len(commands) >= (8 if page == README else 2), commands
    for command in commands:
        _run(_small(command), tmp_path)
    (python,) = _python_blocks(page)
    code = _small(python)
    assert "segments=16" in code
    subprocess.run([sys.executable, "-c", code], cwd=tmp_path, check=True, capture_output=True, timeout=900)


def _table(path: Path) -> list[list[str]]:
    text = path.read_text().split("## Which method when")[1].split("\n## ")[0]
    rows = [ln for ln in text.splitlines() if ln.startswith("|") and not ln.startswith("|---")]
    return [[c.strip() for c in row.strip().strip("|").split("|")] for row in rows]


def test_the_which_method_tables_are_one_table_and_the_registrys():
    """README and index give the same table; its method column lists the registry's methods,
    its last columns the contact laws' flags, and each cell what ``honours`` says."""
    table = _table(README)
    assert table == _table(INDEX)
    head, *rows = table
    params = list(all_params().values())
    assert head[-len(params) :] == [f"`{p.flag}`" for p in params]
    assert [re.match(r"`(\w+)`", row[0]).group(1) for row in rows] == list(METHOD_NAMES)
    assert rows[0][0] == "`event` (default)"
    for method, row in zip(METHOD_NAMES, rows, strict=True):
        for p, cell in zip(params, row[-len(params) :], strict=True):
            assert cell == honours(method, p.name), (method, p.name, cell)


@pytest.mark.parametrize("method", METHOD_NAMES)
def test_each_cell_is_what_a_run_does(method):
    """A run is refused, in one line naming the flag, where the table says "refused",
    beyond "up to B" or away from "A or B"; accepted at B, at A and B, and at either end
    where it says "any"."""
    from ballchain.errors import ParameterError
    from ballchain.model import ChainParams

    for name, p in all_params().items():
        cell = honours(method, name)
        away = 0.5  # away from the default: restitution (default 0) and friction (default inf)
        if cell == "any":
            accepted, refused = [away, 1.0 if p.default == 0 else 0.0], None
        elif cell.startswith("up to "):
            bound = float(cell.removeprefix("up to "))
            accepted, refused = [bound], bound + 0.01
        elif " or " in cell:  # (those values only: away from each, refused)
            accepted = [float(v) for v in cell.split(" or ")]
            refused = away
            assert p.default in accepted and refused not in accepted, cell
        else:
            assert cell == "refused", cell
            accepted, refused = [p.default], away
        for value in accepted:
            check_contacts(ChainParams(**{name: value}), method)
        if refused is not None:
            with pytest.raises(ParameterError) as err:
                check_contacts(ChainParams(**{name: refused}), method)
            assert p.flag in str(err.value) and "\n" not in str(err.value), str(err.value)


def _blocks(text: str) -> list[str]:
    """The page's prose paragraphs and tables (code blocks and headings left out)."""
    text = re.sub(r"^```.*?^```", "", text, flags=re.M | re.S)
    return [b for b in re.split(r"\n\s*\n", text) if b.strip() and not b.startswith(("    ", "#"))]


def _numbers(block: str) -> list[str]:
    """The numbers a paragraph quotes: its text without code, link targets and the table's
    contact-law cells (the registry's, checked above)."""
    block = re.sub(r"`[^`]*`|pi/\d+", "", block)
    block = re.sub(r"\]\([^)]*\)", "]", block)
    block = re.sub(r"\| (?:any|refused|up to [\d.]+|[\d.]+ or inf) (?=\|)", "|", block)
    return re.findall(r"(?<![\w.])[+-]?\d+(?:\.\d+)?(?:e[+-]?\d+)?%?(?![\w.]*\w)", block)


@pytest.mark.parametrize("page", [README, INDEX], ids=["README", "index"])
def test_every_number_stands_on_a_page_the_paragraph_links(page):
    """Each number of a paragraph (or table, with the paragraph before it) of the README and
    the index is stated on a page that paragraph links: the results pages are the one source
    of each number quoted."""
    blocks = _blocks(page.read_text())
    checked = 0
    for k, block in enumerate(blocks):
        numbers = _numbers(block)
        if not numbers:
            continue
        links = re.findall(r"\]\(([^)#]+)", block + (blocks[k - 1] if block.startswith("|") else ""))
        sources = [(page.parent / link).resolve() for link in links]
        sources = [" ".join(s.read_text().split()) for s in sources if s.suffix in (".md", ".toml") and s.is_file()]
        assert sources, ("a paragraph quotes numbers and links no page", block[:200])
        for number in numbers:
            assert any(re.search(rf"(?<![\w.]){re.escape(number)}(?![\d])", s) for s in sources), (number, block[:200])
            checked += 1
    assert checked >= 20


@pytest.mark.parametrize("page", [README, INDEX], ids=["README", "index"])
def test_each_value_at_an_n_stands_beside_that_n_on_its_page(page):
    """ "x at N = n" (and "N = n (x, k starts)") stands on a linked page beside that N: in the
    row of n of its table, or within a sentence of "N = n"."""
    for block in _blocks(page.read_text()):
        pairs = re.findall(r"(\d\.\d+) at N = (\d+)", block)
        pairs += [(x, n) for n, x in re.findall(r"N = (\d+) \((\d\.\d+), \d+ starts\)", block)]
        if not pairs:
            continue
        pages = [(page.parent / link).resolve() for link in re.findall(r"\]\(([^)#]+\.md)", block)]
        texts = [" ".join(p.read_text().split()) for p in pages]
        rows = [ln for p in pages for ln in p.read_text().splitlines() if ln.startswith("| ")]
        for x, n in pairs:
            beside = rf"N = {n}\b[^.]{{0,200}}?\b{re.escape(x)}\b|\b{re.escape(x)}\b[^;]{{0,80}}?N = {n}\b"
            in_row = any(re.match(rf"\| {n} \|.*\| {re.escape(x)}\b", row) for row in rows)
            assert in_row or any(re.search(beside, t) for t in texts), (page.name, x, n)
