"""What a method's runs are audited against (``records.audit``): each method's package
states its own ``AUDIT`` (plain data, importable without the kernels)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class AuditBounds:
    """energy_rtol: |E0 - U - T - E_lock - E_land| / E0 at most; depth_tol: the deepest
    point below a floor that watches every point (b); hinge_tol + hinge_per_dt * dt: the
    most a bend in force may pass its limit in a frame, in the cosine; warn_near: a run
    past half a bound is warned (a method whose error is its step's)."""

    energy_rtol: float
    depth_tol: float
    hinge_tol: float
    hinge_per_dt: float = 0.0
    warn_near: bool = False

    def hinge(self, dt: float | None) -> float:
        """The bend bound of a run with step dt (t_ff / N)."""
        return self.hinge_tol + self.hinge_per_dt * float(dt or 0.0)
