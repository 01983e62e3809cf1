"""Vectorised quaternion helpers shared by the peer models (scalar-first w, x, y, z).

The chain state maps to a tree of relative rotations the same way for every peer:
the absolute rotation of rod i is the minimal rotation taking local z to its
direction e_i (spin about the axis is arbitrary; this fixes it consistently).
"""

from __future__ import annotations

import numpy as np


def quat_from_z(e: np.ndarray) -> np.ndarray:
    """Minimal rotation (N, 4) taking +z to the unit vectors e (N, 3); e must not be -z."""
    q = np.empty((e.shape[0], 4))
    q[:, 0] = 1.0 + e[:, 2]
    q[:, 1] = -e[:, 1]
    q[:, 2] = e[:, 0]
    q[:, 3] = 0.0
    if np.any(q[:, 0] < 1e-8):
        raise ValueError("a rod points straight down: the minimal rotation from +z is undefined")
    return q / np.linalg.norm(q, axis=1)[:, None]


def quat_conj(q: np.ndarray) -> np.ndarray:
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a * b, row by row."""
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (N, 3) by unit quaternions q (N, 4)."""
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + q[..., :1] * t + np.cross(u, t)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of unit quaternions (N, 4)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )


def tree_coordinates(e: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ballchain state (e, w), indexed from the top -> joint coordinates of a chain whose
    root is the bottom rod, in joint order (bottom first):

    q_rel (N, 4): rotation of each rod relative to the one below (the world for the
        bottom rod), scalar first;
    v_rel (N, 3): angular velocity relative to the rod below, in the rod's own frame;
    q_abs (N, 4): absolute rotations (local z -> e).
    """
    qa = quat_from_z(e[::-1])
    wb = w[::-1]
    qp = np.concatenate([[[1.0, 0.0, 0.0, 0.0]], qa[:-1]])
    wp = np.concatenate([np.zeros((1, 3)), wb[:-1]])
    q_rel = quat_mul(quat_conj(qp), qa)
    v_rel = quat_rotate(quat_conj(qa), wb - wp)
    return q_rel, v_rel, qa


def chain_state(q_rel: np.ndarray, v_rel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of ``tree_coordinates``: joint coordinates (bottom first) -> (e, w) indexed
    from the top; w is the full angular velocity (it may have a small axial part)."""
    n = q_rel.shape[0]
    qa = np.empty((n, 4))
    w = np.empty((n, 3))
    q = np.array([1.0, 0.0, 0.0, 0.0])
    om = np.zeros(3)
    for k in range(n):
        q = quat_mul(q, q_rel[k])
        q /= np.linalg.norm(q)
        qa[k] = q
        om = om + quat_rotate(q, v_rel[k])
        w[k] = om
    e = quat_rotate(qa, np.tile([0.0, 0.0, 1.0], (n, 1)))
    return e[::-1].copy(), w[::-1].copy()
