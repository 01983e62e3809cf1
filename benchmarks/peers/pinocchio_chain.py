"""The ballchain chain as a Pinocchio model; ballchain state <-> (q, v); ABA.

The model (nondimensional m = b = g = 1): N rods of mass 1 and length 2 chained by
quaternion spherical joints (``JointModelSpherical``).  Joint 1 is the BOTTOM rod
(ballchain's segment N-1), pinned at the origin; joint k holds segment i = N - k.
Each body frame has its origin at the rod's lower end with the rod along local +z,
centre of mass (0, 0, 1), inertia diag(1/3, 1/3, eps) about the centre of mass: eps is
a small axial inertia (ballchain has no spin about the rod's axis; zero would make the
joint-space inertia singular).  Gravity (0, 0, -1).

ballchain's state: directions ``e`` (N, 3), lower end -> upper end, and world-frame
angular velocities ``w`` (N, 3) perpendicular to ``e``, both indexed from the top.

Caveats found with pinocchio 4.1: ``model.createData()`` allocates about 64 nv^3 bytes
(dense nv^3 second-order-derivative tensors; nv = 3N: 3.5 GB at N = 128, ~29 GB at
N = 256), and ABA's result on this chain loses accuracy roughly geometrically with N
(exact to 1e-14 at N = 16, wrong at N = 64; CRBA + a dense solve stays accurate).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from rotations import tree_coordinates


def build_model(n: int, axial_inertia: float = 1e-6) -> pin.Model:
    """Pinocchio model of an N-rod chain pinned at the bottom (see module docstring)."""
    model = pin.Model()
    model.gravity.linear = np.array([0.0, 0.0, -1.0])
    inertia = pin.Inertia(1.0, np.array([0.0, 0.0, 1.0]), np.diag([1.0 / 3.0, 1.0 / 3.0, axial_inertia]))
    parent = 0
    for k in range(n):
        placement = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.0 if k == 0 else 2.0]))
        parent = model.addJoint(parent, pin.JointModelSpherical(), placement, f"hinge_{k}")
        model.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
    return model


def state_to_qv(e: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ballchain (e, w) -> Pinocchio (q, v).

    Absolute rotation R_i: minimal rotation from z to e_i.  Joint rotation = R_parent^T
    R_child (the parent of segment i is segment i+1 below it; of the bottom one, the
    world), stored as (x, y, z, w).  Joint velocity = R_child^T (w_child - w_parent),
    in the child's frame.
    """
    q_rel, v_rel, _ = tree_coordinates(e, w)
    q = np.ascontiguousarray(q_rel[:, [1, 2, 3, 0]]).reshape(-1)
    return q, np.ascontiguousarray(v_rel).reshape(-1)


def qv_to_state(model: pin.Model, data: pin.Data, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pinocchio (q, v) -> (e, w) indexed from the top (w includes any axial part)."""
    pin.forwardKinematics(model, data, q, v)
    n = model.njoints - 1
    e = np.empty((n, 3))
    w = np.empty((n, 3))
    for k in range(1, n + 1):
        Rk = data.oMi[k].rotation
        e[n - k] = Rk[:, 2]
        w[n - k] = Rk @ data.v[k].angular
    return e, w


def angular_accelerations(model: pin.Model, data: pin.Data, q, v, ddq) -> np.ndarray:
    """World-frame angular accelerations (N, 3), indexed from the top, of the bodies for
    joint accelerations ddq (the angular part of Pinocchio's body spatial acceleration
    is the true angular acceleration, expressed in the body frame)."""
    pin.forwardKinematics(model, data, q, v, ddq)
    n = model.njoints - 1
    dw = np.empty((n, 3))
    for k in range(1, n + 1):
        dw[n - k] = data.oMi[k].rotation @ data.a[k].angular
    return dw


class PinocchioChain:
    """A chain model plus its data; ``aba()`` is the timed call."""

    def __init__(self, n: int, axial_inertia: float = 1e-6, convention=None):
        self.n = n
        self.model = build_model(n, axial_inertia)
        self.data = self.model.createData()
        self.tau = np.zeros(self.model.nv)
        self.convention = pin.Convention.LOCAL if convention is None else convention
        self.q = pin.neutral(self.model)
        self.v = np.zeros(self.model.nv)

    def set_state(self, e: np.ndarray, w: np.ndarray) -> None:
        self.q, self.v = state_to_qv(e, w)

    def aba(self) -> np.ndarray:
        """Joint accelerations ddq (nv,) by the articulated-body algorithm."""
        return pin.aba(self.model, self.data, self.q, self.v, self.tau, self.convention)

    def timed_call(self):
        """A zero-argument callable doing exactly one ABA evaluation (for timing)."""
        model, data, q, v, tau, conv = self.model, self.data, self.q, self.v, self.tau, self.convention
        aba = pin.aba
        return lambda: aba(model, data, q, v, tau, conv)

    def dw(self) -> np.ndarray:
        """World-frame angular accelerations (N, 3) from the top, at the current state."""
        ddq = np.array(self.aba())
        return angular_accelerations(self.model, self.data, self.q, self.v, ddq)

    def dw_dense(self) -> np.ndarray:
        """Like ``dw`` but with ddq = -M^-1 nle from Pinocchio's CRBA and a dense LAPACK solve
        (a check of the model and of ABA's accuracy; O(N^3))."""
        data = self.data
        M = pin.crba(self.model, data, self.q)
        M = np.triu(M) + np.triu(M, 1).T  # crba fills the upper triangle
        nle = pin.nonLinearEffects(self.model, data, self.q, self.v)
        ddq = np.linalg.solve(M, self.tau - nle)
        return angular_accelerations(self.model, data, self.q, self.v, ddq)
