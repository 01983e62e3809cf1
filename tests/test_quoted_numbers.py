"""The numbers the README, the index and the large-N results page quote, recomputed from
the committed tables (docs/data) by the command the page gives: a number in the text
that its data no longer give fails here.

The command is read from the page itself (its code block that runs
``studies/large_n.py``), so the page's command is the one checked."""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
PAGE = ROOT / "docs" / "large-n.md"
sys.path.insert(0, str(ROOT / "studies"))

pytestmark = pytest.mark.slow  # (about 20 s: the command's bootstrap intervals and fits)


def _block_commands(text: str, head: str) -> list[str]:
    """The commands of a page's code blocks that start with ``head`` (a regex): each
    indented block's (its continuation lines indented further), and each line of a fenced
    (```) block's with its backslash continuations (a command that names engines stands
    there)."""
    found = re.findall(rf"^ {{4}}({head} .*?)(?=\n(?! {{8}}\S)|\n\n)", text, re.M | re.S)
    for fenced in re.findall(r"^```[^\n]*\n(.*?)^```", text, re.M | re.S):
        found += re.findall(rf"^({head} (?:[^\n]*\\\n)*[^\n]*)", fenced, re.M)
    return found


def _page_command(page: Path = PAGE) -> list[str]:
    """The page's ``python studies/large_n.py ...`` command, as arguments: in an indented
    block, or in a fenced (```) one (a command that names engines stands there)."""
    commands = _block_commands(page.read_text(), r"python studies/large_n\.py")
    assert commands, "the page gives no large_n.py command"
    args = shlex.split(commands[0].replace("\\\n", " "))[2:]
    if "--plot" in args:
        plot = args.index("--plot")
        del args[plot : plot + 2]  # the figure is not redrawn here
    return [sys.executable, str(ROOT / "studies" / "large_n.py"), *args]


def _run(args: list[str]) -> str:
    out = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, check=True, timeout=600)
    return out.stdout


@pytest.fixture(scope="module")
def computed():
    cmd = _page_command()
    data = json.loads(_run([*[a for a in cmd if a not in ("--events", "--paired")], "--json"]))
    text = _run(cmd)
    event_tables = [a for a in cmd if re.search(r"(optimal-alpha|reproduction|largeN-event\d+)\.parquet$", a)]
    exact_only = _run([cmd[0], cmd[1], *event_tables, "--pool-engines", "3f1506e64dc4,9f716c31d3bb"])
    return data, text, exact_only


def _mean(g) -> str:
    return f"{g['mean']:.3f} [{g['lo']:.3f}, {g['hi']:.3f}]"


def _representative(groups) -> dict:
    """One ensemble per N, the one the fit uses (large_n._best_per_n)."""
    from large_n import _best_per_n

    return _best_per_n([g for g in groups if g["runs"] >= 2], "event")


def _check_row(g, method, starts, mean, g_meas, g_inf, row):
    assert method.split(",")[0] == g["method"], row
    if g["method"] == "timestep":
        assert f"theta {g['theta']:g}" in method and f"dt {g['dt']:g}" in method, row
    assert (int(starts), mean) == (g["runs"], _mean(g)), row
    assert (g_meas, g_inf) == (f"{g['gamma_measured']:.2f}", f"{g['gamma_inferred']:.2f}"), row


def test_the_gamma_page_is_what_its_data_give(computed):
    """The gamma page's table (and so its findings, which quote it) from the same command."""
    data, _, _ = computed
    page = ROOT / "docs" / "gamma.md"
    assert _page_command(page) == [a for a in _page_command() if a not in ("--events", "--paired")]
    rep = _representative(data["groups"])
    rows = [ln for ln in page.read_text().splitlines() if re.match(r"\| \d+ \|", ln)]
    assert len(rows) >= 8
    for row in rows:
        n, method, starts, g_meas, g_inf, mean = (c.strip() for c in row.strip("|").split("|"))
        _check_row(rep[int(n)], method, starts, mean, g_meas, g_inf, row)
    findings = " ".join(page.read_text().split("## Findings")[1].split("| N |")[0].split())
    table = " ".join(rows)
    for value in re.findall(r"\b\d\.\d\d\b", findings):
        assert f"| {value} |" in table, value


def test_the_results_table_is_what_its_data_give(computed):
    data, _, _ = computed
    rows = [ln for ln in PAGE.read_text().splitlines() if re.match(r"\| \d+ \|", ln)]
    assert len(rows) >= 10
    rep = _representative(data["groups"])
    for row in rows:
        n, method, starts, mean, fast, g_meas, g_inf = (c.strip() for c in row.strip("|").split("|"))
        g = rep[int(n)]
        _check_row(g, method, starts, mean, g_meas, g_inf, row)
        assert fast == f"{g['fast']:.2f}", row


def test_every_interval_the_page_quotes_is_computed_by_its_command(computed):
    """Each "x [lo, hi]" of the findings and of what would change them is a mean, a
    paired difference or a fit that the command (or the exact method's fit) prints."""
    data, text, exact_only = computed
    page = PAGE.read_text()
    prose = " ".join((page.split("| N | method |")[0] + page.split("## What would change the answer")[1]).split())
    fit = data["fit"]
    printed = text + exact_only + f" r_inf = {fit['r_inf']:.3f} [{fit['r_inf_95'][0]:.3f}, {fit['r_inf_95'][1]:.3f}]"
    quoted = re.findall(r"[+-]?\d\.\d{3,4} \[[+-]?\d\.\d{3,4}, [+-]?\d\.\d{3,4}\]", prose)
    assert len(quoted) >= 12
    for q in quoted:
        assert q in printed or q.replace(" [", ", r_inf 95% [") in printed or _fit_text(q, exact_only), q
    assert f"p = {fit['p']:.2f}" in prose


def _fit_text(quoted: str, printed: str) -> bool:
    """``0.925 [0.923, 0.928]`` against the fit line ``t_fall/t_ff = 0.925 + ...; r_inf 95% [0.923, 0.928]``."""
    m = re.match(r"(\S+) \[(\S+), (\S+)\]", quoted)
    fit = re.search(r"t_fall/t_ff = (\S+) \+ .*?r_inf 95% \[(\S+), (\S+)\]", printed)
    return bool(m and fit and m.groups() == fit.groups())


def test_the_readme_and_the_index_quote_what_the_data_give(computed):
    data, _, _ = computed
    rep = _representative(data["groups"])
    fit = data["fit"]
    for path in (ROOT / "README.md", ROOT / "docs" / "index.md"):
        text = " ".join(path.read_text().split())
        found = 0
        for value, n in re.findall(r"(\d\.\d+) at N = (\d+)", text):
            g = rep[int(n)]
            assert float(value) == round(g["mean"], len(value) - 2), (path.name, value, n)
            found += 1
        for n, value, starts in re.findall(r"N = (\d+) \((\d\.\d+), (\d+) starts\)", text):
            g = rep[int(n)]
            assert (float(value), int(starts)) == (round(g["mean"], 3), g["runs"]), (path.name, n)
            found += 1
        for value, starts in re.findall(r"(\d\.\d+) at N = \d+ \((\d+) starts\)", text):
            assert any(round(g["mean"], 3) == float(value) and g["runs"] == int(starts) for g in rep.values())
        ends, of = re.search(r"(\d+) of (\d+) starts", text).groups()
        g = rep[1024]
        assert (int(ends), int(of)) == (g["runs"], g["runs"] + g["failed"]), path.name
        r_inf = f"{fit['r_inf']:.3f} [{fit['r_inf_95'][0]:.3f}, {fit['r_inf_95'][1]:.3f}]"
        assert r_inf in text, path.name
        assert found >= 3, path.name


def test_the_time_steppers_page_quotes_the_paired_differences_the_command_prints(computed):
    """The time-stepper's page gives its default's change at N = 1024 from the paired
    differences of the large-N command."""
    _, text, _ = computed
    page = (ROOT / "docs" / "timestep.md").read_text()
    section = " ".join(page.split("## Why the default step changes at N = 1024")[1].split("\n## ")[0].split())
    quoted = re.findall(r"[+-]\d\.\d{4} \[[+-]\d\.\d{4}, [+-]\d\.\d{4}\]", section)
    assert len(quoted) == 4
    for q in quoted:
        assert q in text, q


def test_the_methods_compared_page_is_what_its_command_prints():
    """Every row of the paired table and every interval of the findings of the page that
    sets the two methods against each other, from the page's own command."""
    page = ROOT / "docs" / "methods-compared.md"
    printed = _run(_page_command(page))
    out_rows = {}
    for line in printed.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) >= 8 and cells[0].isdigit() and cells[1].startswith("dt "):  # (later columns: E_land, the sum)
            out_rows.setdefault((int(cells[0]), cells[1], int(cells[4])), []).append(tuple(cells[5:8]))
    text = page.read_text()
    rows = [ln for ln in text.splitlines() if re.match(r"\| \d+ \| dt ", ln)]
    assert len(rows) >= 8
    for row in rows:
        n, step, pairs, diff, ks, elock = (c.strip() for c in row.strip("|").split("|"))
        key = (int(n), step.replace(", theta 1/2", ""), int(pairs))
        assert (diff, ks, elock) in out_rows.get(key, []), row
    findings = " ".join(text.split("## Findings")[1].split("| N |")[0].split())
    quoted = re.findall(r"[+-]\d\.\d{4} \[[+-]\d\.\d{4}, [+-]\d\.\d{4}\]", findings)
    assert len(quoted) >= 8
    for q in quoted:
        assert q in printed, q


def _page_commands(page: Path) -> str:
    """The output of every ``python studies/...``, ``python benchmarks/...`` and ``ballchain stats`` command of a
    page's code blocks (figures they would write left out): the indented blocks, and the
    lines of fenced (```) blocks that start with such a command, with their backslash
    continuations (a results page keeps a command that names engines there)."""
    blocks = _block_commands(page.read_text(), r"(?:python (?:studies|benchmarks)/\S+\.py|ballchain stats)")
    out = []
    for block in blocks:
        args = shlex.split(block.split("#")[0].replace("\\\n", " "))
        for option in ("--plot", "--plot-n"):
            while option in args:
                del args[args.index(option) : args.index(option) + 2]
        if args[0] == "python":
            args = [sys.executable, *args[1:]]
        else:
            args = [sys.executable, "-m", "ballchain.cli", *args[1:]]
        out.append(_run(args))
    assert out, page.name
    return "\n".join(out)


def _intervals(text: str) -> set[str]:
    return set(re.findall(r"\d\.\d{2,4} \[\d\.\d{2,4}, \d\.\d{2,4}\]", " ".join(text.split())))


def test_the_optimal_alpha_page_quotes_what_its_commands_print():
    page = ROOT / "docs" / "optimal-alpha.md"
    printed = _page_commands(page)
    quoted = _intervals(page.read_text())
    assert len(quoted) >= 20
    assert sorted(q for q in quoted if q not in printed) == []


def test_the_paper_case_page_quotes_what_its_commands_and_data_give():
    """The reproduction page's intervals: from its commands, and the two means it gives
    without the falls slower than 1.2 t_ff, recomputed here from its table."""
    import pandas as pd

    from ballchain.sweeps.stats import mean_interval

    page = ROOT / "docs" / "reproduction.md"
    printed = _page_commands(page)
    df = pd.read_parquet(ROOT / "docs" / "data" / "reproduction.parquet")
    for n in (128, 256):
        x = df[(df.segments == n) & (df.rtol == 1e-10) & (df.status == "landed")]["ratio"].to_numpy()
        x = x[x <= 1.2]
        lo, hi = mean_interval(x)
        printed += f"\n{x.mean():.3f} [{lo:.3f}, {hi:.3f}]"
    quoted = _intervals(page.read_text())
    assert len(quoted) >= 10
    assert sorted(q for q in quoted if q not in printed) == []


@pytest.mark.parametrize(
    "name",
    [
        "rattle.md",
        "notes/rattle-record.md",
        "notes/rattle-engines.md",
        "restitution.md",
        "restitution-floor.md",
        "friction-floor.md",
        "experiment.md",
    ],
)
def test_the_rattle_page_quotes_what_its_command_prints(name):
    """Every interval the RATTLE method's page quotes (its ensembles against the exact
    method, the paired differences; and the engines' history in the notes), and the page
    on restitution at the bend limit (the fall times, the paired differences), is printed
    by the page's own commands."""
    page = ROOT / "docs" / name
    printed = " ".join(_page_commands(page).split())
    text = " ".join(page.read_text().split())
    quoted = re.findall(r"[+-]?\d\.\d{3,4} \[[+-]?\d\.\d{3,4}, [+-]?\d\.\d{3,4}\]", text)
    assert len(quoted) >= 4
    for q in quoted:
        assert q in printed, q


def test_the_rattle_page_quotes_each_start_at_n16384_from_its_table():
    """Item 5c of the RATTLE record (N = 16384, a sweep under way) quotes each landed start's
    t_fall/t_ff, E_lock/E0 and the books' imbalance: recomputed from the committed table."""
    import pandas as pd

    page = (ROOT / "docs" / "notes" / "rattle-record.md").read_text()
    item = " ".join(page.split("**5c. At N = 16384**")[1].split("**6. ")[0].split())
    df = pd.read_parquet(ROOT / "docs" / "data" / "rattle16384.parquet")
    assert (df.status == "landed").all()
    assert f"{len(df)} of 16 starts" in item
    for row in df.itertuples():
        assert f"start {row.spawn_key}: {row.ratio:.4f}" in item
        assert f"{row.energy_lost_locking / row.energy_initial:.3f}" in item
    assert f"{abs(df.energy_imbalance / df.energy_initial).max():.1e}" in item
    assert f"their mean {df.ratio.mean():.4f}" in item
    assert "no point below the floor by more than 1e-8 b" in item and df.max_depth.max() <= 1e-8


def _study_rows(printed: str) -> dict:
    """The rows of restitution_study.py --against's two tables, by (N, E): the paired one
    (8 cells) and the one of the landings by the cap (10 cells)."""
    rows: dict = {}
    for line in printed.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells and cells[0].isdigit() and len(cells) in (8, 10):
            rows.setdefault((int(cells[0]), cells[1]), {})[len(cells)] = cells
    return rows


def test_the_restitution_floor_page_pairs_the_time_stepper_as_its_commands_and_data_give():
    """Finding 6 of the page on restitution at the floor (the time-stepper against the exact
    method): each row of its table from the page's two commands that pair the time-stepper's
    tables with the exact method's (the pairs, the means, the paired differences, KS p, the
    landings by the cap) and from the committed tables (the runs in error); the finding's
    counts, medians and imbalances from the same tables. (Its intervals are checked with
    the page's others, by test_the_rattle_page_quotes_what_its_command_prints.)"""
    import pandas as pd

    page = (ROOT / "docs" / "restitution-floor.md").read_text()
    data = ROOT / "docs" / "data"
    ts = {16: pd.read_parquet(data / "timestep-restitution-floor.parquet")}
    ts[64] = pd.read_parquet(data / "timestep-restitution-floor-n64.parquet")
    exact64 = pd.read_parquet(data / "restitution-floor-n64.parquet")
    commands = [
        c
        for c in _block_commands(page, r"python studies/restitution_study\.py")
        if "timestep-restitution-floor" in shlex.split(c)[2]
    ]
    assert len(commands) == 2
    printed = {}
    for c in commands:
        args = shlex.split(c)
        starts = 64 if args[2].endswith("-n64.parquet") else 16
        printed[starts] = _study_rows(_run([sys.executable, *args[1:]]))
    section = page.split("6. **The time-stepper")[1].split("## The command")[0]
    rows = [ln for ln in section.splitlines() if re.match(r"\| \d+ \| [\d.]+ \| \d+ \|", ln)]
    assert len(rows) == 11
    for row in rows:
        n, e, starts, errors, landed, pairs, mean, ref, diff, ks, elock = (c.strip() for c in row.strip("|").split("|"))
        paired, cap = (printed[int(starts)][(int(n), e)][k] for k in (8, 10))
        assert [pairs, mean, ref, diff, ks, elock] == paired[2:], row
        assert (starts, *landed.split(" / ")) == tuple(cap[2:5]), row
        df = ts[int(starts)]
        g = df[(df.segments == int(n)) & (df.restitution_floor == float(e))]
        assert int(errors) == (g.status == "error").sum(), row
    finding = " ".join(section.split("| N |")[0].split())
    e_pos = {k: d[d.restitution_floor > 0] for k, d in ts.items()}
    assert "39 of the 96 runs" in finding and (e_pos[16].status == "error").sum() == 39 and len(e_pos[16]) == 96
    assert "40 of the 192" in finding and (e_pos[64].status == "error").sum() == 40 and len(e_pos[64]) == 192
    assert (
        "none of its 32 at E = 0" in finding and (ts[16][ts[16].restitution_floor == 0].status == "landed").sum() == 32
    )
    # the 16 starts at N = 64 are the first 16 of the 64, the same runs to every digit
    a = ts[16][(ts[16].segments == 64) & (ts[16].restitution_floor > 0)]
    same = a.merge(ts[64], on=["restitution_floor", "run_index"])
    assert len(same) == 48 and (same.status_x == same.status_y).all()
    assert (same.energy_imbalance_x == same.energy_imbalance_y).all()
    distinct = pd.concat([e_pos[16][e_pos[16].segments == 128], e_pos[64]])
    err = distinct[distinct.status == "error"].message
    for count, what in (
        (len(err), "distinct runs in error"),
        (err.str.contains("below the floor").sum(), "had a point more than 0.1 b below the floor"),
        (err.str.contains("from its anchor").sum(), "an anchored point off its anchor"),
        (err.str.contains("books do not close").sum(), "the energy books open"),
        (err.str.contains("raised the kinetic energy").sum(), "an impact that raised the kinetic energy"),
    ):
        assert f"{count} {what}" in finding, (count, what)
    worst = {
        "below": max(err.str.extract(r"went ([\d.]+) b below")[0].dropna().astype(float)),
        "anchor": max(err.str.extract(r"anchored point was ([\d.]+) b")[0].dropna().astype(float)),
        "books": max(err.str.extract(r"([\d.]+) of E0 lost unaccounted")[0].dropna().astype(float)),
    }
    assert f"up to {worst['below']:g} b" in finding and f"up to {worst['anchor']:g} b" in finding
    assert f"(up to {worst['books']:g})" in finding
    # the medians over all runs at N = 64, 64 starts, each method; the time-stepper's books
    medians = []
    for d in (ts[64], exact64):
        by_e = d.groupby("restitution_floor")
        medians.append(
            (
                [f"{v:.0f}" for v in by_e.apply(lambda g: (g.events_bounce / g.segments).median())],
                [f"{v:.3f}" for v in by_e.apply(lambda g: (g.energy_lost_landing / g.energy_initial).median())],
            )
        )
    (b_ts, l_ts), (b_ex, l_ex) = medians
    assert f"medians of {b_ts[0]}, {b_ts[1]} and {b_ts[2]} bounces per segment" in finding
    assert f"against {b_ex[0]}, {b_ex[1]} and {b_ex[2]})" in finding
    assert f"E_land/E0 {l_ts[0]}, {l_ts[1]} and {l_ts[2]} against {l_ex[0]}, {l_ex[1]} and {l_ex[2]}," in finding
    note = " ".join(section.split("The time-stepper's landed counts")[1].split())

    def books(d):
        d = d[d.status == "landed"]
        return f"{100 * (d.energy_imbalance / d.energy_initial).median():.1f}%"

    at = [books(ts[64][ts[64].restitution_floor == e]) for e in (0.3, 0.6, 0.9)]
    zero = [books(ts[16][(ts[16].segments == n) & (ts[16].restitution_floor == 0)]) for n in (64, 128)]
    assert f"{at[0]}, {at[1]} and {at[2]} at E = 0.3, 0.6, 0.9" in note
    assert f"{zero[0]} and {zero[1]} at E = 0 (N = 64 and 128)" in note
    cap = [(d.status == "max_time").sum() for d in (ts[16][ts[16].segments == 64], ts[64])]
    assert f"({cap[0]} at N = 64, E = 0.9 on 16 starts, {cap[1]} on 64)" in note


def test_the_hinge_damping_page_quotes_what_its_command_prints():
    """Each row of the page's table is its method's row of the study's output (the page
    names the method where the output gives the runs), and each interval of its findings
    is printed by the command."""
    page = ROOT / "docs" / "hinge-damping.md"
    printed = _page_commands(page)
    sections: dict = {}  # each method's rows, over every command of the page
    for method, rows in re.findall(r"^(\w+): \d+ runs.*?\n(.*?)(?=^\w+: \d+ runs|^\w+ minus|\Z)", printed, re.M | re.S):
        sections[method] = sections.get(method, "") + rows
    assert set(sections) == {"event", "rattle", "timestep"}
    text = page.read_text()
    rows = [ln for ln in text.splitlines() if re.match(r"\| \d+ \| [\d.]+ \| \w+ \|", ln)]
    assert len(rows) == 6
    for row in rows:
        n, c, method, *rest = (x.strip() for x in row.strip("|").split("|"))
        assert f"| {n} | {c} | 16 | " + " | ".join(rest) + " |" in sections[method], row
    findings = " ".join(text.split("## Findings")[1].split("![")[0].split())
    quoted = re.findall(r"[+-]?\d\.\d{3,4} \[[+-]?\d\.\d{3,4}, [+-]?\d\.\d{3,4}\]", findings)
    assert len(quoted) >= 10
    for q in quoted:
        assert q in printed, q


def test_the_pull_page_quotes_what_its_command_prints():
    """Each row of the pull page's table is a row of its study's output on the committed
    table, and each interval and correlation its findings quote is printed by it."""
    page = ROOT / "docs" / "pull.md"
    printed = _page_commands(page)
    text = page.read_text()
    rows = [ln for ln in text.splitlines() if re.match(r"\| \d+ \| \d+ \| 16 \|", ln)]
    assert len(rows) == 7
    for row in rows:
        assert row in printed, row
    findings = " ".join(text.split("## Findings")[1].split("![")[0].split())
    quoted = re.findall(r"\d+\.\d{2,4} \[\d+\.\d{2,4}, \d+\.\d{2,4}\]", findings)
    assert len(quoted) >= 13
    for q in quoted:
        assert q in printed, q
    assert len(re.findall(r"[+-]\d\.\d\d, p \d\.\d\d", findings)) == 4
    for rho, p in re.findall(r"([+-]\d\.\d\d), p (\d\.\d\d)", findings):
        assert f"{rho} ({p})" in printed, (rho, p)
