"""ballchain side by side with Pinocchio and MuJoCo, in one process.

    python benchmarks/peers/compare.py [--sizes 16,64,128,256,1024,4096] [--quick] [--output FILE.md]

(a) one evaluation of the accelerations: ballchain's O(N) kernel (without and with
    ~30% locked hinges) vs Pinocchio's ABA on the same random near-vertical state;
    agreement of the angular accelerations with ABA and with MuJoCo's mj_forward;
    effect of the small axial inertia the peers need.
(b) a fixed interval of free motion (alpha = pi, default helix start, before the first
    floor contact): ballchain's ``simulate`` vs MuJoCo stepping the same chain, at
    matched accuracy against a ballchain reference at rtol = 1e-12.
(c) full falls (``--only full``; not run by default): bend limit alpha, floor, pile-up,
    until every segment has landed: ballchain's ``simulate`` vs MuJoCo (limited ball
    joints, capsules on a floor plane, friction; ``mujoco_fall.py``) at a fixed step.

Single-threaded (the thread variables are set before numpy is imported).  Prints the
machine and library versions and markdown tables of medians; ``--output`` also writes
them to a file.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from ballchain_chain import ballchain_eval, random_state, simulate_interval  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from machine import machine_info as shared_machine_info  # noqa: E402

PIN_BYTES_PER_NV3 = 64  # pinocchio.Data holds ~8 dense nv x nv x nv tensors (measured)
MJ_MAX_N = 512  # MuJoCo: compile refuses trees > ~1000 deep, its M is singular near 1000, O(N^3) check


# ------------------------------------------------------------------ helpers


def machine_info() -> list[str]:
    """CPU model, cores and library versions."""
    return [shared_machine_info(("numpy", "numba", "ballchain", "mujoco", "pinocchio")) + " (runs single-threaded)"]


def time_per_call(fn, repeats: int, target: float) -> float:
    """Median over ``repeats`` of the mean time of ``fn()`` in an inner loop sized so that
    one repeat takes about ``target`` seconds (after two warm-up calls)."""
    fn()
    t0 = time.perf_counter()
    fn()
    one = max(time.perf_counter() - t0, 1e-7)
    inner = max(1, int(target / one))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        times.append((time.perf_counter() - t0) / inner)
    return statistics.median(times)


def perpendicular(d: np.ndarray, e: np.ndarray) -> np.ndarray:
    """The part of each row of d perpendicular to the unit rows of e."""
    return d - np.einsum("ij,ij->i", d, e)[:, None] * e


def rel_diff(d_peer: np.ndarray, d_ref: np.ndarray, e: np.ndarray) -> float:
    """max_i |P d_peer_i - d_ref_i| / max_i |d_ref_i| (P: projection perpendicular to e_i)."""
    return float(np.linalg.norm(perpendicular(d_peer, e) - d_ref, axis=1).max() / np.linalg.norm(d_ref, axis=1).max())


def table(headers: list[str], rows: list[list], align: str | None = None) -> str:
    """A markdown table (numbers right-aligned)."""
    align = align or "l" + "r" * (len(headers) - 1)
    sep = ["---:" if a == "r" else ":---" for a in align]
    lines = ["| " + " | ".join(headers) + " |", "| " + " | ".join(sep) + " |"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def ratio_fmt(x: float) -> str:
    return f"{x:.1f}" if x < 10 else f"{x:.0f}"


def fmt(x: float | None, spec: str = ".3g") -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


# ------------------------------------------------------------------ (a) one evaluation


def pinocchio_fits(n: int, max_gb: float) -> bool:
    return PIN_BYTES_PER_NV3 * (3 * n) ** 3 <= max_gb * 1e9


def bench_eval(sizes, repeats, target, axial, pin_max_gb):
    """Rows of section (a): timings and agreement at each N."""
    from mujoco_chain import MujocoChain
    from pinocchio_chain import PinocchioChain

    rows = []
    for n in sizes:
        rng = np.random.default_rng(n)
        e, w, locked = random_state(n, rng)
        free = ballchain_eval(e, w)
        _, dw = free()
        dw = dw.copy()
        t_free = time_per_call(free, repeats, target)
        t_lock = time_per_call(ballchain_eval(e, w, locked), repeats, target)
        row = dict(n=n, bc=t_free, bc_locked=t_lock, pin=None, diff_aba=None, diff_crba=None, diff_mj=None)
        if pinocchio_fits(n, pin_max_gb):
            pc = PinocchioChain(n, axial)
            pc.set_state(e, w)
            row["diff_aba"] = rel_diff(pc.dw(), dw, e)
            row["diff_crba"] = rel_diff(pc.dw_dense(), dw, e)
            row["pin"] = time_per_call(pc.timed_call(), repeats, target)
            del pc  # (Convention.WORLD is ~10-15% faster but less accurate; LOCAL, the default, is timed)
        if n <= MJ_MAX_N:
            mc = MujocoChain(n, axial)
            mc.set_state(e, w)
            row["diff_mj"] = rel_diff(mc.angular_accelerations(), dw, e)
        rows.append(row)
        log(
            f"  (a) N={n}: ballchain {t_free * 1e6:.2f} us (locked {t_lock * 1e6:.2f} us), "
            f"pinocchio {fmt(row['pin'] and row['pin'] * 1e6, '.2f')} us, "
            f"diff ABA {fmt(row['diff_aba'], '.1e')}, diff MuJoCo {fmt(row['diff_mj'], '.1e')}"
        )
    return rows


def eval_tables(rows, axial, pin_max_gb, repeats, target) -> str:
    measured = [r for r in rows if r["pin"] is not None]
    pin_ns = measured[-1]["pin"] / measured[-1]["n"] if measured else None
    out = []
    for r in rows:
        n = r["n"]
        if r["pin"] is not None:
            pin_t, mark = r["pin"], ""
        elif pin_ns is not None:
            pin_t, mark = pin_ns * n, "~"
        else:
            pin_t, mark = None, ""
        ratio = None if pin_t is None else pin_t / r["bc"]
        ratio_l = None if pin_t is None else pin_t / r["bc_locked"]
        ok = ratio_l is not None and ratio_l >= 3.0 and r["bc_locked"] / n <= 1e-7
        verdict = "n/a" if n < 64 else ("yes" if ok else "no") + ("" if not mark else " ~")
        out.append(
            [
                n,
                fmt(r["bc"] * 1e6, ".2f"),
                fmt(r["bc"] / n * 1e9, ".1f"),
                fmt(r["bc_locked"] * 1e6, ".2f"),
                fmt(r["bc_locked"] / n * 1e9, ".1f"),
                mark + fmt(pin_t and pin_t * 1e6, ".2f"),
                mark + fmt(pin_t and pin_t / n * 1e9, ".1f"),
                mark + fmt(ratio, ".2f"),
                mark + fmt(ratio_l, ".2f"),
                verdict,
                fmt(r["diff_aba"], ".1e"),
                fmt(r["diff_crba"], ".1e"),
                fmt(r["diff_mj"], ".1e"),
            ]
        )
    headers = [
        "N",
        "ballchain µs",
        "ns/seg",
        "ballchain locked µs",
        "ns/seg",
        "Pinocchio ABA µs",
        "ns/seg",
        "Pin/bc",
        "Pin/bc locked",
        "target met",
        "Δ vs ABA",
        "Δ vs Pin CRBA",
        "Δ vs MuJoCo",
    ]
    notes = [
        f"Medians of {repeats} repeats of an inner loop of ~{target:g} s. Same random near-vertical state for "
        f"all (tilts ~0.3 rad, random w ⊥ e); 'locked': ~30% of the hinges locked (ballchain only). "
        f"Peers' axial inertia {axial:g}.",
        "Target (issue): with locked hinges, ≥ 3x faster than Pinocchio ABA and ≤ 0.1 µs per segment.",
        "Δ: max over segments of |dw_peer (⊥ e) - dw_ballchain| / max |dw_ballchain| (world-frame angular "
        "accelerations). 'Pin CRBA': Pinocchio's crba + nonLinearEffects and a dense LAPACK solve; "
        "'MuJoCo': mj_forward (dense LDL of its CRB mass matrix); both run only where they fit (MuJoCo: "
        f"N <= {MJ_MAX_N}). Pinocchio's ABA loses accuracy roughly geometrically with N on this chain (~2x per rod; "
        "its own RNEA residual shows it), whereas both dense solvers agree with ballchain to their condition number.",
        f"~: Pinocchio not run (pinocchio.Data allocates ~{PIN_BYTES_PER_NV3} nv^3 bytes, nv = 3N: "
        f"> {pin_max_gb:g} GB); its time is extrapolated linearly (ABA is O(N)) from the largest N measured.",
    ]
    return table(headers, out) + "\n\n" + "\n".join(f"- {x}" for x in notes)


def axial_study(sizes, eps_list) -> str:
    """Agreement with ballchain vs the peers' axial inertia (no timing)."""
    from mujoco_chain import MujocoChain
    from pinocchio_chain import PinocchioChain

    rows = []
    for n in sizes:
        rng = np.random.default_rng(n)
        e, w, _ = random_state(n, rng)
        _, dw = ballchain_eval(e, w)()
        for eps in eps_list:
            pc = PinocchioChain(n, eps)
            pc.set_state(e, w)
            d_pin = pc.dw()
            mc = MujocoChain(n, eps)
            mc.set_state(e, w)
            d_mj = mc.angular_accelerations()
            rows.append(
                [
                    n,
                    f"{eps:g}",
                    fmt(rel_diff(d_pin, dw, e), ".1e"),
                    fmt(float(np.abs(np.einsum("ij,ij->i", d_pin, e)).max()), ".1e"),
                    fmt(rel_diff(d_mj, dw, e), ".1e"),
                    fmt(float(np.abs(np.einsum("ij,ij->i", d_mj, e)).max()), ".1e"),
                ]
            )
    return table(["N", "axial inertia", "Δ ABA", "max axial dw (ABA)", "Δ MuJoCo", "max axial dw (MuJoCo)"], rows)


# ------------------------------------------------------------------ (b) free motion


def state_error(e, w, ref) -> float:
    """max over segments of max(|e - e_ref|, |P w - w_ref|) (P: perpendicular to e)."""
    return float(
        max(np.linalg.norm(e - ref["e"], axis=1).max(), np.linalg.norm(perpendicular(w, e) - ref["w"], axis=1).max())
    )


def mujoco_run(mc, ref, nsteps):
    """Run MuJoCo from the initial state over the interval in nsteps; (error, wall)."""
    n = ref["e0"].shape[0]
    mc.set_state(ref["e0"], np.zeros((n, 3)))
    wall, _ = mc.run(ref["t"], ref["t"] / nsteps)
    e, w = mc.state()
    return state_error(e, w, ref), wall


def match_mujoco(mc, ref, target, order, step_cost, max_seconds):
    """The largest MuJoCo step (fewest equal steps, ~10% apart) whose error is <= target.

    Probes a cheap step count, predicts the count from err ~ dt^order (the order is
    re-estimated from the last two runs), then refines.  Returns a dict (steps, err,
    wall), or (skip, steps) when the predicted run exceeds max_seconds."""
    t = ref["t"]
    runs = {}

    def run(ns):
        if ns not in runs:
            runs[ns] = mujoco_run(mc, ref, ns)
        return runs[ns][0]

    def too_long(ns):
        return ns * step_cost > max_seconds

    ns = max(4, int(math.ceil(t / 0.05)))
    if too_long(ns):
        return dict(skip=f"one probe > {max_seconds:g} s")
    err, prev = run(ns), None
    for _ in range(20):
        if err <= target:
            fewer = int(ns / 1.1)
            if fewer < 1 or fewer == ns or err * (ns / fewer) ** order > target or run(fewer) > target:
                break
            prev, ns, err = (ns, err), fewer, runs[fewer][0]
            continue
        p = order
        if prev is not None and prev[1] > 0 and err > 0 and prev[0] != ns:
            p = min(6.0, max(0.5, math.log(prev[1] / err) / math.log(ns / prev[0]))) if prev[1] > err else order
        nxt = max(ns + 1, int(math.ceil(ns * (err / target) ** (1.0 / p) * 1.02)))
        if too_long(nxt):
            return dict(skip=f"needs ~{nxt:.2g} steps, ~{nxt * step_cost:.2g} s", steps=nxt)
        prev, ns = (ns, err), nxt
        err = run(ns)
    if err > target:
        return dict(skip="did not converge")
    return dict(steps=ns, err=err, wall=runs[ns][1])


def bench_free_motion(sizes, interval, rtols, integrators, axial, repeats, max_seconds):
    """Rows of section (b)."""
    from mujoco_chain import MujocoChain

    simulate_interval(4, interval, 1e-9)  # numba warm-up (compiled or loaded from the cache)
    rows = []
    for n in sizes:
        ref = simulate_interval(n, interval, 1e-12, frames=50)
        if ref["landings"] or ref["min_z"] <= 0.0 or ref["status"] != "until":
            raise RuntimeError(f"N={n}: a point reached the floor within {interval} t_ff; use a shorter --interval")
        motion = float(np.linalg.norm(ref["e"] - ref["e0"], axis=1).max())
        for rtol in rtols:
            runs = [simulate_interval(n, interval, rtol) for _ in range(repeats)]
            bc_err = state_error(runs[0]["e"], runs[0]["w"], ref)
            bc_wall = statistics.median(r["wall"] for r in runs)
            for integ in integrators:
                mc = MujocoChain(n, axial, integrator=integ)
                mc.set_state(ref["e0"], np.zeros((n, 3)))
                step_cost = mc.seconds_per_step()
                order = 4 if integ == "RK4" else 1
                m = match_mujoco(mc, ref, bc_err, order, step_cost, max_seconds)
                if "wall" in m and m["wall"] < 1.0 and repeats > 1:  # re-time cheap runs
                    m["wall"] = statistics.median(
                        [m["wall"]] + [mujoco_run(mc, ref, m["steps"])[1] for _ in range(min(repeats, 3) - 1)]
                    )
                rows.append(
                    dict(
                        n=n,
                        t=ref["t"],
                        t_ff=ref["t_ff"],
                        motion=motion,
                        min_z=ref["min_z"],
                        rtol=rtol,
                        bc_err=bc_err,
                        bc_wall=bc_wall,
                        bc_steps=runs[0]["steps"],
                        integ=integ,
                        step_cost=step_cost,
                        **m,
                    )
                )
                r = rows[-1]
                log(
                    f"  (b) N={n} rtol={rtol:g}: ballchain err {bc_err:.2e} in {bc_wall:.4f} s; MuJoCo {integ}: "
                    + (
                        f"skip ({r['skip']})"
                        if "skip" in r
                        else f"{r['steps']} steps, err {r['err']:.2e} in {r['wall']:.3f} s"
                    )
                )
    return rows


def free_motion_table(rows, interval, axial, max_seconds) -> str:
    out = []
    for r in rows:
        dt = None if "steps" not in r else r["t"] / r["steps"]
        skipped = "skip" in r
        out.append(
            [
                r["n"],
                fmt(r["t"], ".3f"),
                fmt(r["motion"], ".2f"),
                fmt(r["min_z"], ".2f"),
                f"{r['rtol']:g}",
                fmt(r["bc_err"], ".1e"),
                r["bc_steps"],
                fmt(r["bc_wall"] * 1e3, ".2f"),
                r["integ"],
                fmt(r["step_cost"] * 1e6, ".0f"),
                fmt(dt, ".2e") + (" (est.)" if skipped and dt else ""),
                "–" if skipped else fmt(r["err"], ".1e"),
                ("skipped: " + r["skip"]) if skipped else fmt(r["wall"] * 1e3, ".1f"),
                "–" if skipped else ratio_fmt(r["wall"] / r["bc_wall"]),
            ]
        )
    headers = [
        "N",
        "T (√(b/g))",
        "max Δe over T",
        "min z",
        "ballchain rtol",
        "ballchain err",
        "bc steps",
        "ballchain ms",
        "MuJoCo integrator",
        "µs/step",
        "matched dt",
        "MuJoCo err",
        "MuJoCo ms",
        "MuJoCo/ballchain",
    ]
    notes = [
        f"Free motion (alpha = pi, no locks) from the default helix at rest over T = {interval:g} t_ff (before "
        "the first floor contact: 'min z' is the lowest point height over 50 frames of the reference; no "
        "landing event). 'max Δe': largest change of a direction over T.",
        "err: max over segments of max(|e - e_ref|, |w⊥ - w_ref|) at T against ballchain at rtol = 1e-12.",
        "MuJoCo: the largest step (equal steps landing on T, ~10% apart) whose error is <= ballchain's; "
        f"axial inertia {axial:g}; runs predicted to exceed {max_seconds:g} s are skipped.",
        "Wall times: ballchain's whole `simulate` call (median of the repeats); MuJoCo's `mj_step` loop.",
    ]
    return table(headers, out) + "\n\n" + "\n".join(f"- {x}" for x in notes)


# ------------------------------------------------------------------ (c) full falls


def parse_runs(text: str) -> list[tuple[str, float]]:
    """'Euler:1e-3,RK4:1e-3' -> [('Euler', 0.001), ('RK4', 0.001)]."""
    return [(x.split(":")[0], float(x.split(":")[1])) for x in text.split(",") if x.strip()]


def bench_full_falls(sizes, alpha, runs, study_runs, opts):
    """Rows of section (c): per N, ballchain's fall then MuJoCo's (the dt study at the
    smallest N adds the ``study_runs``)."""
    from ballchain_chain import full_fall
    from mujoco_fall import mujoco_fall

    full_fall(4, alpha)  # numba warm-up
    rows = []
    for n in sizes:
        bc = full_fall(n, alpha)
        log(
            f"  (c) N={n}: ballchain {bc['status']} in {bc['wall']:.1f} s, t_fall {bc['t_fall']:.3f}, "
            f"t_landed {fmt(bc['t_landed'], '.3f')}"
        )
        rows.append(dict(n=n, code="ballchain", **bc))
        for integ, dt in (runs + [r for r in study_runs if r not in runs]) if n == min(sizes) else runs:
            r = mujoco_fall(
                n,
                alpha,
                dt,
                integ,
                opts["radius"],
                opts["friction"],
                opts["axial"],
                t_max=opts["t_max"],
                wall_cap=opts["wall_cap"],
            )
            log(
                f"  (c) N={n}: MuJoCo {integ} dt={dt:g}: {r.status} at {r.t_end:.3f} t_ff, {r.step_wall:.1f} s, "
                f"{r.us_per_step:.0f} us/step"
            )
            rows.append(dict(n=n, code="MuJoCo", integ=integ, dt=dt, res=r, bc_wall=bc["wall"]))
    return rows


def full_fall_table(rows, alpha, opts, main_run, project_to=512) -> str:
    out = []
    for row in rows:
        if row["code"] == "ballchain":
            out.append(
                [
                    row["n"],
                    "ballchain",
                    "adaptive",
                    row["steps"],
                    fmt(row["wall"] / row["steps"] * 1e6, ".0f"),
                    fmt(row["wall"], ".2f"),
                    row["status"],
                    fmt(row["t_fall"], ".3f"),
                    fmt(row["t_landed"], ".3f"),
                    fmt(row["imbalance"], ".1e") + " (imbalance)",
                    "0 (anchored)",
                    "0 (locks)",
                    "1",
                ]
            )
            continue
        r = row["res"]
        status = {
            "wall cap": f"did not finish in {r.step_wall:.0f} s (at {r.t_end:.2f} t_ff)",
            "unstable": f"blew up at {r.t_end:.2f} t_ff",
            "time cap": f"not landed at {r.t_end:.2f} t_ff",
        }.get(r.status, r.status)
        out.append(
            [
                row["n"],
                "MuJoCo",
                f"{row['integ']} {row['dt']:g}",
                r.steps,
                fmt(r.us_per_step, ".0f"),
                fmt(r.step_wall, ".2f"),
                status,
                fmt(r.t_fall, ".3f"),
                fmt(r.t_landed, ".3f"),
                fmt(r.max_excess, ".1e") + " (max excess)",
                fmt(r.max_slide, ".2g"),
                fmt(r.max_limit_violation, ".2f"),
                ratio_fmt(r.step_wall / row["bc_wall"]),
            ]
        )
    headers = [
        "N",
        "code",
        "step",
        "steps",
        "µs/step",
        "wall s",
        "status",
        "t_fall/t_ff",
        "t_landed/t_ff",
        "energy / E0",
        "max slide (b)",
        "max over-bend (rad)",
        "wall / ballchain wall",
    ]
    mj = [r for r in rows if r["code"] == "MuJoCo" and (r["integ"], r["dt"]) == main_run]
    proj = ""
    if mj:
        big = max(mj, key=lambda r: r["n"])
        r = big["res"]
        us = r.us_per_step * (project_to / big["n"]) ** 2.7
        t_land = (r.t_landed or r.t_end) * r.t_ff * math.sqrt(project_to / big["n"])
        proj = (
            f"N = {project_to} not run: from {r.us_per_step:.0f} µs/step at N = {big['n']} and MuJoCo's ~N^2.7 "
            f"step cost, ~{us / 1e3:.0f} ms/step; ~{t_land / big['dt']:.2g} steps of {big['dt']:g} to land "
            f"(t_ff ∝ √N) -> ~{us * 1e-6 * t_land / big['dt'] / 3600:.1f} h."
        )
    notes = [
        f"alpha = {alpha:.4g}, default helix at rest. ballchain: default `simulate` (floor 'all': points anchored on "
        "landing; inelastic locks); energy: |imbalance| / E0 of its closed budget. 'wall s': ballchain's whole "
        "`simulate` call; MuJoCo's `mj_step` loop only (diagnostics between chunks of ~t_ff/400 not timed).",
        f"MuJoCo: bend limit = ball-joint range [0, alpha] on the relative rotation angle (twist included; = the "
        f"bend angle only without twist), default soft limit solref (0.02, 1), solimp (0.9, 0.95, 0.001, 0.5, 2); "
        f"capsules r = {opts['radius']:g} b colliding only with a floor plane at z = -r (rod axes rest at z = 0), "
        f"friction {opts['friction']:g} (pyramidal cone, condim 3), default contact solref/solimp, Newton solver; "
        f"axial inertia {opts['axial']:g} (1e-6, as in (a)/(b), blows up within 0.3 t_ff at every dt and integrator "
        "tried: the limit constraint acts on the twist). A point is down at height <= r + 1e-3; t_fall: the top "
        f"point first down; t_landed: all points down at once; runs capped at {opts['t_max']:g} t_ff or "
        f"{opts['wall_cap']:g} s of stepping.",
        "energy / E0 (MuJoCo): max over samples of ((T + U) - E0) / E0 (> 0: energy injected; MuJoCo's contacts "
        "and limits otherwise dissipate). 'max slide': largest horizontal distance a point moved after first going "
        "down (ballchain: 0, points are anchored). 'max over-bend': largest (relative rotation angle - alpha) over "
        "the samples (soft limit).",
        "Single falls are chaotic: t_fall/t_ff differs between codes and between MuJoCo steps; ballchain's ensemble "
        "at N = 128, pi/4: t_fall/t_ff = 0.978 ± 0.010, t_landed/t_ff = 1.019 ± 0.012.",
    ] + ([proj] if proj else [])
    return table(headers, out) + "\n\n" + "\n".join(f"- {x}" for x in notes)


# ------------------------------------------------------------------ main


def parse_list(text: str, kind=int) -> list:
    return [kind(x) for x in text.split(",") if x.strip()]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default=None, help="N for (a) (default 16,64,128,256,1024,4096; quick 16,64,256)")
    ap.add_argument("--fall-sizes", default=None, help="N for (b) (default 16,32,64,128; quick 16,32)")
    ap.add_argument("--interval", type=float, default=0.1, help="simulated interval of (b), in t_ff (default 0.1)")
    ap.add_argument("--rtols", default="1e-9,1e-6", help="ballchain tolerances matched in (b)")
    ap.add_argument("--integrators", default="RK4,Euler", help="MuJoCo integrators tried in (b)")
    ap.add_argument("--axial", type=float, default=1e-6, help="axial inertia of the peers' rods (default 1e-6)")
    ap.add_argument("--axial-study", default="1e-2,1e-4,1e-6,1e-9", help="axial inertias compared (empty: skip)")
    ap.add_argument("--max-seconds", type=float, default=None, help="cap of one MuJoCo run (default 60; quick 5)")
    ap.add_argument("--pin-max-gb", type=float, default=4.0, help="skip Pinocchio when its Data would exceed this")
    ap.add_argument(
        "--only",
        choices=("eval", "fall", "full"),
        default=None,
        help="run only section (a), (b) or (c) ((c), full falls, runs only when asked for)",
    )
    ap.add_argument("--full-sizes", default="32,128", help="N for (c) (default 32,128)")
    ap.add_argument("--full-alpha", type=float, default=math.pi / 4, help="bend limit of (c) (default pi/4)")
    ap.add_argument("--full-runs", default="Euler:1e-3", help="MuJoCo integrator:dt of (c) at every N")
    ap.add_argument(
        "--full-dt-study",
        default="Euler:3e-4,Euler:1e-4,RK4:1e-3,implicitfast:1e-3",
        help="extra MuJoCo integrator:dt of (c) at the smallest N",
    )
    ap.add_argument("--full-axial", type=float, default=1e-2, help="axial inertia of MuJoCo's rods in (c)")
    ap.add_argument("--full-radius", type=float, default=0.05, help="capsule radius in (c)")
    ap.add_argument("--full-friction", type=float, default=1.0, help="floor friction in (c)")
    ap.add_argument("--full-t-max", type=float, default=3.0, help="simulated-time cap of a MuJoCo fall, in t_ff")
    ap.add_argument("--full-wall-cap", type=float, default=300.0, help="cap of mj_step wall time of one fall (s)")
    ap.add_argument("--quick", action="store_true", help="small sizes and few repeats (a ~1 minute smoke test)")
    ap.add_argument("--output", default=None, help="also write the markdown section to this file")
    a = ap.parse_args(argv)
    sizes = parse_list(a.sizes or ("16,64,256" if a.quick else "16,64,128,256,1024,4096"))
    fall_sizes = parse_list(a.fall_sizes or ("16,32" if a.quick else "16,32,64,128"))
    repeats, target = (3, 0.02) if a.quick else (7, 0.1)
    max_seconds = a.max_seconds if a.max_seconds is not None else (5.0 if a.quick else 60.0)
    study_sizes = (16, 32) if a.quick else (16, 32, 48, 64)

    cmd = "python benchmarks/peers/compare.py " + " ".join(sys.argv[1:] if argv is None else argv)
    parts = ["## ballchain vs Pinocchio and MuJoCo", "", f"Command: `{cmd.strip()}`", "", *machine_info(), ""]
    print("\n".join(parts), flush=True)
    if a.only not in ("fall", "full"):
        rows = bench_eval(sizes, repeats, target, a.axial, a.pin_max_gb)
        sec = [
            "### (a) One evaluation of the accelerations",
            "",
            eval_tables(rows, a.axial, a.pin_max_gb, repeats, target),
            "",
        ]
        if a.axial_study:
            sec += [
                "Agreement vs the peers' axial inertia (same kind of state; Δ as above):",
                "",
                axial_study(study_sizes, parse_list(a.axial_study, float)),
                "",
            ]
        print("\n".join(sec), flush=True)
        parts += sec
    if a.only == "full":
        opts = dict(
            radius=a.full_radius,
            friction=a.full_friction,
            axial=a.full_axial,
            t_max=a.full_t_max,
            wall_cap=a.full_wall_cap,
        )
        rows = bench_full_falls(
            parse_list(a.full_sizes), a.full_alpha, parse_runs(a.full_runs), parse_runs(a.full_dt_study), opts
        )
        sec = [
            "### (c) Full falls: bend limit, floor, pile-up",
            "",
            full_fall_table(rows, a.full_alpha, opts, parse_runs(a.full_runs)[0]),
            "",
        ]
        print("\n".join(sec), flush=True)
        parts += sec
    if a.only not in ("eval", "full"):
        rows = bench_free_motion(
            fall_sizes,
            a.interval,
            parse_list(a.rtols, float),
            a.integrators.split(","),
            a.axial,
            3 if a.quick else 5,
            max_seconds,
        )
        sec = [
            "### (b) A fixed interval of free motion at matched accuracy",
            "",
            free_motion_table(rows, a.interval, a.axial, max_seconds),
            "",
        ]
        print("\n".join(sec), flush=True)
        parts += sec
    if a.output:
        with open(a.output, "w") as f:
            f.write("\n".join(parts))
        log(f"wrote {a.output}")


if __name__ == "__main__":
    main()
