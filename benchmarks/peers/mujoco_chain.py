"""The ballchain chain as a MuJoCo model; ballchain state <-> (qpos, qvel); stepping.

MJCF (nondimensional m = b = g = 1): nested bodies, the BOTTOM rod (ballchain's
segment N-1) attached to the world by a ``ball`` joint at the origin, each rod above
hinged by a ``ball`` joint at its lower end, 2 above its parent's.  Each body frame has
its origin at the rod's lower end with the rod along local +z; explicit inertial:
mass 1 at (0, 0, 1), diaginertia (1/3, 1/3, eps) (eps: a small axial inertia, as
ballchain has no spin about the axis).  No geoms (contact is disabled anyway), no
damping, no armature; gravity (0, 0, -1).

MuJoCo's mass matrix of a chain is dense (nv = 3N): a step costs O(N^3) at large N
(~N^2.7 between N = 64 and 128 here).  Trees deeper than ~1000 bodies do not compile.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
from rotations import chain_state, tree_coordinates

OPTIONS_MJCF = """<mujoco model="ballchain">
  <option gravity="0 0 -1" timestep="{timestep!r}" integrator="{integrator}">
    <flag contact="disable"/>
  </option>
</mujoco>"""


def chain_spec(n: int, axial_inertia: float = 1e-6, timestep: float = 0.002, integrator: str = "RK4") -> mujoco.MjSpec:
    """MjSpec of an N-rod chain (see module docstring): the options come from MJCF, the
    nested bodies are added through the spec (MJCF text nested deeper than ~500 elements
    is refused by MuJoCo's XML parser).  ``chain_spec(n).to_xml()`` gives the full MJCF."""
    spec = mujoco.MjSpec.from_string(OPTIONS_MJCF.format(timestep=timestep, integrator=integrator))
    parent = spec.worldbody
    for k in range(n):
        body = parent.add_body(name=f"rod{k}", pos=[0.0, 0.0, 0.0 if k == 0 else 2.0])
        body.add_joint(name=f"ball{k}", type=mujoco.mjtJoint.mjJNT_BALL)
        body.explicitinertial = True
        body.mass = 1.0
        body.ipos = [0.0, 0.0, 1.0]
        body.inertia = [1.0 / 3.0, 1.0 / 3.0, axial_inertia]
        parent = body
    return spec


class MujocoChain:
    """A compiled chain model plus its data."""

    def __init__(self, n: int, axial_inertia: float = 1e-6, timestep: float = 0.002, integrator: str = "RK4"):
        self.n = n
        self.model = chain_spec(n, axial_inertia, timestep, integrator).compile()
        self.data = mujoco.MjData(self.model)
        assert self.model.nq == 4 * n and self.model.nv == 3 * n

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    @timestep.setter
    def timestep(self, dt: float) -> None:
        self.model.opt.timestep = dt

    def set_state(self, e: np.ndarray, w: np.ndarray) -> None:
        """Set qpos (relative quaternions w, x, y, z, bottom joint first) and qvel (relative
        angular velocities in the child's frame) from ballchain's (e, w); time = 0."""
        mujoco.mj_resetData(self.model, self.data)
        q_rel, v_rel, _ = tree_coordinates(e, w)
        self.data.qpos[:] = q_rel.reshape(-1)
        self.data.qvel[:] = v_rel.reshape(-1)

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Current (e, w) indexed from the top (w includes any axial part)."""
        return chain_state(self.data.qpos.reshape(self.n, 4), self.data.qvel.reshape(self.n, 3))

    def angular_accelerations(self) -> np.ndarray:
        """World-frame angular accelerations (N, 3), from the top, at the current state
        (mj_forward's qacc, the relative accelerations in the child frames, summed up
        the chain with the velocity-product terms)."""
        mujoco.mj_forward(self.model, self.data)
        v_rel = self.data.qvel.reshape(self.n, 3)
        a_rel = self.data.qacc.reshape(self.n, 3)
        R = self.data.xmat[1:].reshape(self.n, 3, 3)  # absolute rotations, bottom first
        om = np.einsum("kij,kj->ki", R, v_rel)  # relative angular velocities, world frame
        w_abs = np.cumsum(om, axis=0)
        # alpha_k = alpha_{k-1} + R_k a_k + w_k x (R_k v_k)
        incr = np.einsum("kij,kj->ki", R, a_rel) + np.cross(w_abs, om)
        return np.cumsum(incr, axis=0)[::-1].copy()

    def run(self, t_end: float, dt: float) -> tuple[float, int]:
        """Step from the current state to t_end with nsteps = ceil(t_end/dt) equal steps
        (dt adjusted down to land on t_end).  Returns (wall seconds, steps)."""
        nsteps = max(1, int(np.ceil(t_end / dt - 1e-9)))
        self.timestep = t_end / nsteps
        t0 = time.perf_counter()
        mujoco.mj_step(self.model, self.data, nsteps)
        return time.perf_counter() - t0, nsteps

    def seconds_per_step(self, steps: int = 5) -> float:
        """Wall time of one step (median of ``steps`` single steps) at the current state;
        the state is restored afterwards."""
        qpos, qvel = self.data.qpos.copy(), self.data.qvel.copy()
        times = []
        for _ in range(steps):
            t0 = time.perf_counter()
            mujoco.mj_step(self.model, self.data)
            times.append(time.perf_counter() - t0)
        self.data.qpos[:], self.data.qvel[:] = qpos, qvel
        self.data.time = 0.0
        return float(np.median(times))
