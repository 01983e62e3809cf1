"""ballchain's full fall (limited bends, floor, pile-up) as faithfully as MuJoCo allows.

    python benchmarks/peers/mujoco_fall.py --n 32 --dt 1e-3 --integrator Euler

The chain of ``mujoco_chain.chain_spec`` (N rods of length 2, mass 1, bottom end pinned
at the origin by a ball joint, gravity (0, 0, -1)) with, in addition:

- every ball joint between two rods ``limited`` with range [0, alpha] (the pin is free): MuJoCo limits the ANGLE OF THE
  RELATIVE ROTATION of the two rods (twist included), not the bend angle; with no
  twist the two coincide (the peers' rods have a tiny axial inertia and no axial
  torque except contact friction, so twist stays small).  The limit is MuJoCo's
  default soft constraint: solref = (0.02, 1) (time constant 0.02, critically
  damped: close to ballchain's inelastic lock), solimp = (0.9, 0.95, 0.001, 0.5, 2);
- a capsule of radius r (default 0.05 b) along each rod, colliding with the floor only
  (contype/conaffinity: no rod-rod contact, as in ballchain); the floor is a plane at
  z = -r so that a rod lying on it has its axis at z = 0 (ballchain's floor for the
  points) and the pinned bottom end sits on it; friction mu (default 1.0, pyramidal
  cone, condim 3), MuJoCo's default contact solref/solimp;
- contact and limit constraints solved by MuJoCo's default solver (Newton).

A point is "down" when its height is <= r + 1e-3 (capsule surface within 2r + 1e-3 of
the floor surface, as proposed in the brief, measured from the floor plane at -r).
The run stops when every point is down (t_landed) or at a simulated-time or wall cap.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass, field

import mujoco
import numpy as np
from mujoco_chain import chain_spec
from rotations import tree_coordinates

DOWN_SLACK = 1e-3


def fall_spec(
    n: int,
    alpha: float,
    radius: float = 0.05,
    friction: float = 1.0,
    axial_inertia: float = 1e-6,
    timestep: float = 1e-3,
    integrator: str = "Euler",
    cone: str = "pyramidal",
) -> mujoco.MjSpec:
    """The chain of ``chain_spec`` with limited ball joints, capsules and a floor (module docstring)."""
    spec = chain_spec(n, axial_inertia, timestep, integrator)
    spec.option.cone = getattr(mujoco.mjtCone, "mjCONE_" + cone.upper())
    spec.compiler.degree = False  # joint ranges in radians
    spec.option.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    spec.worldbody.add_geom(
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[0.0, 0.0, 1.0],
        pos=[0.0, 0.0, -radius],
        contype=0,
        conaffinity=1,
        friction=[friction, 0.005, 1e-4],
    )
    for k in range(n):
        body = spec.body(f"rod{k}")
        if k > 0:  # the bottom rod's joint to the world (the pin) is free, as in ballchain
            joint = spec.joint(f"ball{k}")
            joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            joint.range = [0.0, alpha]
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0.0, 0.0, 0.0, 0.0, 0.0, 2.0],
            size=[radius, 0, 0],
            contype=1,
            conaffinity=0,
            friction=[friction, 0.005, 1e-4],
        )
    return spec


def points(data: mujoco.MjData, n: int) -> np.ndarray:
    """Positions (N+1, 3) of the chain's points in ballchain's order (0 = top, N = bottom)."""
    lower = data.xpos[1 : n + 1]  # lower ends, bottom rod first
    top = lower[-1] + 2.0 * data.xmat[n].reshape(3, 3)[:, 2]
    return np.vstack([top[None, :], lower[::-1]])


@dataclass
class FallResult:
    """Outcome of one MuJoCo fall; times in units of t_ff = sqrt(2 H0)."""

    n: int
    dt: float
    integrator: str
    status: str  # 'landed', 'wall cap', 'time cap' or 'unstable'
    t_ff: float
    t_end: float  # simulated time reached / t_ff
    t_fall: float | None  # top point first within reach of the floor / t_ff
    t_landed: float | None  # every point down / t_ff
    steps: int
    step_wall: float  # wall seconds in mj_step only
    e0: float
    max_excess: float  # max over samples of (T + U) - E0, relative to E0
    final_energy: float  # (T + U) / E0 at the end
    max_slide: float  # max over points of the horizontal distance moved after first going down
    max_limit_violation: float  # max over samples and joints of (relative rotation angle - alpha)
    down_fraction: float  # points down at the end
    samples: list = field(default_factory=list, repr=False)

    @property
    def us_per_step(self) -> float:
        return 1e6 * self.step_wall / max(self.steps, 1)


class MujocoFall:
    """A compiled fall model and its data, set to ballchain's initial condition at rest."""

    def __init__(
        self,
        n: int,
        alpha: float,
        e0: np.ndarray,
        dt: float,
        integrator: str = "Euler",
        radius: float = 0.05,
        friction: float = 1.0,
        axial_inertia: float = 1e-6,
        cone: str = "pyramidal",
    ):
        self.n, self.alpha, self.radius = n, alpha, radius
        self.model = fall_spec(n, alpha, radius, friction, axial_inertia, dt, integrator, cone).compile()
        self.data = mujoco.MjData(self.model)
        q_rel, _, _ = tree_coordinates(e0, np.zeros_like(e0))
        self.data.qpos[:] = q_rel.reshape(-1)
        mujoco.mj_forward(self.model, self.data)
        self.e0 = self.energy()
        self.t_ff = math.sqrt(2.0 * float(points(self.data, n)[0, 2]))

    def energy(self) -> float:
        """T + U at the current state (after mj_forward)."""
        mujoco.mj_energyPos(self.model, self.data)
        mujoco.mj_energyVel(self.model, self.data)
        return float(self.data.energy[0] + self.data.energy[1])

    def limit_violation(self) -> float:
        """max over joints of (angle of the relative rotation - alpha)."""
        q = self.data.qpos.reshape(self.n, 4)[1:]
        angle = 2.0 * np.arctan2(np.linalg.norm(q[:, 1:], axis=1), np.abs(q[:, 0]))
        return float((angle - self.alpha).max())

    def run(self, t_max: float = 3.0, wall_cap: float = 300.0, samples_per_tff: int = 400) -> FallResult:
        """Step until every point is down, t_max t_ff, or wall_cap seconds of stepping.

        Steps in chunks of ~1/samples_per_tff t_ff; between chunks (not timed) evaluates
        the state: points, energy, sliding of the points already down."""
        m, d, n = self.model, self.data, self.n
        dt = float(m.opt.timestep)
        chunk = max(1, int(round(self.t_ff / samples_per_tff / dt)))
        h_down = self.radius + DOWN_SLACK
        down_at = np.full((n + 1, 2), np.nan)  # xy where each point first went down
        down_at[n] = 0.0
        t_fall = t_landed = None
        max_excess = max_slide = max_viol = 0.0
        steps, wall, status = 0, 0.0, "time cap"
        samples = []
        while True:
            t0 = time.perf_counter()
            mujoco.mj_step(m, d, chunk)
            wall += time.perf_counter() - t0
            steps += chunk
            mujoco.mj_forward(m, d)
            p = points(d, n)
            t = d.time / self.t_ff
            if not np.all(np.isfinite(d.qpos)) or d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0:
                status = "unstable"  # (MuJoCo has reset the data: t_end is the last sample before)
                break
            down = p[:, 2] <= h_down
            new = down & np.isnan(down_at[:, 0])
            down_at[new] = p[new, :2]
            seen = ~np.isnan(down_at[:, 0])
            if seen.any():
                max_slide = max(max_slide, float(np.linalg.norm(p[seen, :2] - down_at[seen], axis=1).max()))
            e = self.energy()
            max_excess = max(max_excess, (e - self.e0) / self.e0)
            max_viol = max(max_viol, self.limit_violation())
            samples.append((t, e / self.e0, int(down.sum())))
            if t_fall is None and p[0, 2] <= h_down:
                t_fall = t
            if down.all():
                t_landed, status = t, "landed"
                break
            if t >= t_max:
                break
            if wall >= wall_cap:
                status = "wall cap"
                break
        return FallResult(
            n=n,
            dt=dt,
            integrator=mujoco.mjtIntegrator(m.opt.integrator).name.removeprefix("mjINT_"),
            status=status,
            t_ff=self.t_ff,
            t_end=samples[-1][0] if samples else 0.0,
            t_fall=t_fall,
            t_landed=t_landed,
            steps=steps,
            step_wall=wall,
            e0=self.e0,
            max_excess=max_excess,
            final_energy=samples[-1][1] if samples else math.nan,
            max_slide=max_slide,
            max_limit_violation=max_viol,
            down_fraction=float(down.mean()),
            samples=samples,
        )


def mujoco_fall(
    n: int,
    alpha: float = math.pi / 4,
    dt: float = 1e-3,
    integrator: str = "Euler",
    radius: float = 0.05,
    friction: float = 1.0,
    axial_inertia: float = 1e-2,
    cone: str = "pyramidal",
    t_max: float = 3.0,
    wall_cap: float = 300.0,
) -> FallResult:
    """One MuJoCo fall from ballchain's default helix at rest (``initial_directions``)."""
    from ballchain.initial import initial_directions
    from ballchain.model import InitialCondition

    e0 = initial_directions(InitialCondition(), n, alpha)
    fall = MujocoFall(n, alpha, e0, dt, integrator, radius, friction, axial_inertia, cone)
    return fall.run(t_max, wall_cap)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description="One MuJoCo full fall (see the module docstring).")
    ap.add_argument("--n", type=int, default=32)
    ap.add_argument("--alpha", type=float, default=math.pi / 4)
    ap.add_argument("--dt", type=float, default=1e-3)
    ap.add_argument("--integrator", default="Euler", help="Euler, RK4, implicit or implicitfast")
    ap.add_argument("--radius", type=float, default=0.05)
    ap.add_argument("--friction", type=float, default=1.0)
    ap.add_argument("--axial", type=float, default=1e-2, help="axial inertia of the rods (1e-6 blows up)")
    ap.add_argument("--wall-cap", type=float, default=300.0)
    a = ap.parse_args(argv)
    r = mujoco_fall(a.n, a.alpha, a.dt, a.integrator, a.radius, a.friction, a.axial, wall_cap=a.wall_cap)
    print({k: v for k, v in r.__dict__.items() if k != "samples"}, f"us/step {r.us_per_step:.1f}")


if __name__ == "__main__":
    main()
