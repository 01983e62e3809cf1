"""What the commands print: a run's summary (``run_summary``, ``human_summary``) and
``ballchain stats``'s text (``stats_text``)."""

from __future__ import annotations

import math
from typing import Any


def run_summary(result) -> dict:
    """``Result.summary()`` and the measurements of ``analysis`` on it: ``gamma_measured``
    (Hamm-Geminard gamma from the floor's momentum record, analysis.floor_gamma) and
    ``gamma_inferred`` (the gamma whose fall time is t_fall/t_ff); and
    ``wall_includes_compile`` (the run compiled the kernels first: its wall time has it;
    false for runs of the command line, which loads the kernels before the run), and
    from the command line ``setup_seconds`` (loading, or the first time compiling, the
    kernels before the run) and ``setup_compiled``."""
    from ..records.measures import derived_measures

    s = result.summary()
    for key, value in derived_measures(result).items():
        s[key] = value if math.isfinite(value) else None
    extra = getattr(result, "extra", {})
    s["wall_includes_compile"] = bool(extra.get("compiled_kernels", False))
    if "setup_seconds" in extra:
        s["setup_seconds"] = float(extra["setup_seconds"])
        s["setup_compiled"] = bool(extra.get("setup_compiled", False))
    return s


def _still_moving(kinetic) -> str:
    """The pile line's note where the chain still moved when the pile was read (above 1e-6 E0)."""
    if kinetic is None or not math.isfinite(kinetic) or kinetic <= 1e-6:
        return ""
    return f"; read while {100 * kinetic:.3g}% of E0 was still kinetic (it may still be moving)"


def _fmt(x: Any, spec: str = ".6g") -> str:
    if x is None:
        return "n/a"
    if isinstance(x, float) and not math.isfinite(x):
        return "n/a"
    return format(x, spec)


def _div(a, b):
    if a is None or b is None or b == 0:
        return None
    return a / b


def _contact_lines(s: dict) -> list[str]:
    """'  contact laws  ...': the contact laws' parameters away from their defaults (none: no line;
    a key the JSON gives as null is inf)."""
    from ..contacts.registry import all_params

    away = []
    for name, prm in all_params().items():
        if name not in s:
            continue
        v = math.inf if s[name] is None else float(s[name])
        if v != prm.default:
            away.append(f"{prm.flag} {v:g}")
    return [f"  contact laws       {', '.join(away)}"] if away else []


def human_summary(s: dict, output: str | None = None, header: str = "ballchain") -> str:
    """A short human-readable summary of ``Result.summary()``."""
    ic = s.get("ic")
    ic_text = (
        "n/a"
        if not ic
        else (
            f"{ic.get('kind')} (eps {_fmt(ic.get('eps'))}, turns {_fmt(ic.get('turns'))}, "
            f"phase {_fmt(ic.get('phase'))}, seed {ic.get('seed')})"
        )
    )
    alpha = s.get("alpha")
    ev = s.get("events") or {}
    en = s.get("energy") or {}
    init = en.get("initial")
    imb = en.get("imbalance")
    rel = _div(imb, abs(init) if init else None)
    units = s.get("units") or "nondimensional"
    from ..records.result import unit_of

    u_t, u_l, u_e, u_i = (unit_of(q, units) for q in ("t", "z0", "frame_kinetic", "floor_impulse"))

    def with_time(ratio_key, time_key):
        text = _fmt(s.get(ratio_key))
        return text + (f"  ({time_key} = {_fmt(s.get(time_key))} {u_t})" if s.get(time_key) is not None else "")

    fi = s.get("floor_impulse_total")
    lines = [
        f"{header}: N = {s.get('segments')}, alpha = {_fmt(alpha)} rad "
        f"({_fmt(None if alpha is None else math.degrees(alpha), '.4g')} deg), floor = {s.get('floor')}"
        + (", anchor cone" if s.get("anchor_cone") else "")
        + f", units = {units}",
        f"  initial condition  {ic_text}",
        *_contact_lines(s),
        f"  method             {_method_text(s)}",
        f"  status             {s.get('status')}" + (f" ({s['message']})" if s.get("message") else ""),
        f"  free-fall time     t_ff = {_fmt(s.get('t_ff'))} {u_t} (top end at z0 = {_fmt(s.get('z0'))} {u_l})",
        f"  t_fall / t_ff      {with_time('ratio', 't_fall')}",
        f"  t_landed / t_ff    {with_time('landed_ratio', 't_landed')}",
        f"  events             lock {ev.get('lock', 0)}, unlock {ev.get('unlock', 0)}, "
        f"landing {ev.get('landing', 0)}"
        + "".join(f", {k} {v}" for k, v in ev.items() if k not in ("lock", "unlock", "landing") and v)
        + _counted(s)
        + f"; first lock at t/t_ff = {_fmt(_div(s.get('first_lock_time'), s.get('t_ff')))}",
        f"  energy lost        {_losses(en, u_e)}",
        f"  energy imbalance   {_fmt(imb, '.3g')} {u_e} (relative to initial energy: {_fmt(rel, '.3g')})",
    ]
    if fi:
        lines.append(f"  floor impulse      ({', '.join(_fmt(v, '.6g') for v in fi)}) {u_i} (whole, from t = 0)")
    if "gamma_measured" in s:
        lines.append(
            f"  gamma              {_fmt(s.get('gamma_measured'), '.4g')} measured from the floor, "
            f"{_fmt(s.get('gamma_inferred'), '.4g')} from t_fall/t_ff (Hamm-Geminard)"
        )
    if s.get("pull_median") is not None:
        u_f = unit_of("frame_tension", units)
        lines.append(
            f"  pull of the pile   median {_fmt(s['pull_median'], '.4g')} {u_f} from the first landing to t_fall (the tension "
            "just above it; over time: ballchain plot, tension.png)"
        )
    if s.get("pile_radius") is not None:
        lines.append(
            f"  pile               radius of gyration {_fmt(s.get('pile_radius'), '.4g')} {u_l}, its centre "
            f"{_fmt(s.get('pile_offset'), '.4g')} {u_l} from the bottom end's start (seen from above)"
            + _still_moving(s.get("pile_kinetic"))
        )
    if s.get("floor") == "pivot":
        depth = s.get("max_depth")
        lines.append(f"  max depth          {_fmt(depth)} {u_l} below the floor")
        if depth is not None and s.get("z0") and depth > 0.05 * s["z0"]:
            lines.append(
                "  note               floor 'pivot' stops only the segment at the pivot: the rest of the "
                "chain may pass below the floor (use --floor all for a floor that stops every point)"
            )
    lines.append(
        f"  wall time          {_fmt(s.get('wall_seconds'), '.3g')} s "
        f"({s.get('n_steps')} steps, {s.get('n_evals')} evaluations)"
        + ("; includes compiling the kernels (first run only)" if s.get("wall_includes_compile") else "")
    )
    if s.get("setup_seconds") is not None:
        lines.append(
            f"  kernels            {'compiled' if s.get('setup_compiled') else 'loaded'} in "
            f"{_fmt(s['setup_seconds'], '.2g')} s before the run"
            + (" (first run only: cached afterwards)" if s.get("setup_compiled") else "")
        )
    if output:
        lines.append(f"  output             {output}")
    return "\n".join(lines)


def _losses(en: dict, unit: str) -> str:
    """The energy books by law: locking and landing, and damping and sliding where they acted."""
    parts = [f"locking {_fmt(en.get('lost_locking'), '.4g')}", f"landing {_fmt(en.get('lost_landing'), '.4g')}"]
    for key in ("lost_damping", "lost_sliding"):
        if en.get(key):
            parts.append(f"{key[5:]} {_fmt(en[key], '.4g')}")
    return ", ".join(parts) + f" {unit}"


def _counted(s: dict) -> str:
    """' (K instants)', ' (K steps)': what the run's method counts beside its events (its
    package's ``SUMMARY_COUNT``: the event method its instants, the steppers their steps)."""
    from ..methods import METHODS, method_package

    key, word = method_package(s["method"]).SUMMARY_COUNT if s.get("method") in METHODS else (None, "")
    return f" ({s[key]} {word})" if s.get(key) is not None else ""


def _method_text(s: dict) -> str:
    """The method and its accuracy setting, from a run's summary (each method's package
    says it: ``summary``)."""
    from ..methods import METHODS, method_package

    name = s.get("method")
    return method_package(name).summary(s) if name in METHODS else str(name)


NOT_LANDED_LISTED = 10  # runs that did not land named by ``ballchain stats`` (--json: all)


def stats_text(res: dict) -> str:
    """The human-readable ``ballchain stats``."""

    def f(x, spec=".4f"):
        return "-" if x is None else format(x, spec)

    from ..sweeps.stats import GROUP_KEYS

    # the other inputs that tell the points apart (a method, its step, a contact law's
    # parameter), one column each when they vary
    varying = [
        k
        for k in GROUP_KEYS
        if k not in ("segments", "alpha", "floor") and len({repr(p.get(k)) for p in res["points"]}) > 1
    ]

    from ..contacts.registry import all_params

    laws = all_params()

    def cell(k, v):
        if k in laws and (v is None or v == math.inf):
            return "inf"  # (a contact law's parameter at infinity: null in the JSON)
        if v is None or (isinstance(v, float) and not math.isfinite(v)) or v == "":
            return "-"  # (not this point's: an option of another method)
        return f"{v:.6g}" if isinstance(v, float) else str(v)

    lines = [
        f"{res['table']}: {res['rows']} rows ({', '.join(f'{v} {k}' for k, v in res['status'].items())})",
        f"{'N':>5} {'alpha':>7} {'floor':>5} "
        + "".join(f"{k:>{max(len(k), 8)}} " for k in varying)
        + f"{'runs':>4} {'fell':>4} {'t_fall/t_ff: mean':>17} {'95% interval':>17} "
        f"{'median':>7} {'t_landed/t_ff':>13} {'faster':>7} {'95% interval':>13}",
    ]
    for p in res["points"]:
        r, lr, fa = p["ratio"], p["landed_ratio"], p["faster_than_free_fall"]
        lines.append(
            f"{p['segments']:>5} {p['alpha_deg']:>6.4g}d {p['floor']:>5} "
            + "".join(f"{cell(k, p.get(k)):>{max(len(k), 8)}} " for k in varying)
            + f"{p['n_runs']:>4} {r['n']:>4} {f(r['mean']):>17} "
            f"{'[' + f(r['ci_low']) + ', ' + f(r['ci_high']) + ']':>17} {f(r['median']):>7} "
            f"{f(lr['mean']):>13} {f(fa['fraction'], '.2f'):>7} "
            f"{'[' + f(fa['ci_low'], '.2f') + ', ' + f(fa['ci_high'], '.2f') + ']':>13}"
        )
    from ..sweeps.stats import MIN_INTERVAL_N

    lines.append(
        f"(95% intervals of the mean: bootstrap over the runs that fell, column fell; none from fewer than "
        f"{MIN_INTERVAL_N} runs)"
    )
    if any(o["n_alpha"] > 1 for o in res["optimal_alpha"]):
        lines.append("optimal alpha (smallest mean t_fall/t_ff; paired bootstrap 95% interval):")
        for o in res["optimal_alpha"]:
            if o["n_alpha"] > 1 and o["alpha_deg"] is not None:
                lines.append(
                    f"  N = {o['segments']}, floor {o['floor']}: {o['alpha_deg']:.4g} deg "
                    f"[{o['ci_low_deg']:.4g}, {o['ci_high_deg']:.4g}], mean t_fall/t_ff {o['mean']:.4f} "
                    f"({o['n_starts']} starts)"
                )
    for method, b in res.get("books", {}).items():
        lines.append(
            f"books of the {b['runs']} landed runs ({method}): worst |imbalance| / E0 {f(b['worst_imbalance'], '.2g')}, "
            f"deepest point {f(b['deepest'], '.2g')} b below a floor that watches every point"
        )
    bad = res.get("not_landed", [])
    if bad:
        lines.append(f"runs that did not land ({len(bad)}):")
        for r in bad[:NOT_LANDED_LISTED]:
            lines.append(f"  {r['run_id']} ({r['status']}): {r['message']}")
        if len(bad) > NOT_LANDED_LISTED:
            lines.append(f"  ... and {len(bad) - NOT_LANDED_LISTED} more (--json lists them all)")
    for key in ("plot", "plot_n"):
        if res.get(key):
            lines.append(f"{key.replace('_', ' ')}: {res[key]}")
    return "\n".join(lines)
