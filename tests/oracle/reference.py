"""Dense reference equations of motion and impacts: the 3N components of the axes as
coordinates, a constant mass matrix, KKT solves.

Slow (O(N^3)), plain numpy, written independently of ``dynamics.py`` / ``impacts.py``
so that the O(N) production path can be tested against it.  Not for production runs.

Indexing is the package's (0-based, from the top): segment ``i = 0..N-1`` with unit
axis ``e[i]``; point ``j = 0..N`` is the upper end of segment ``j`` and the lower end
of segment ``j-1``; point 0 is the free top, point N the pivot ``p`` (always anchored);
hinge ``k`` (point ``k+1``) joins segments ``k`` and ``k+1``.  Segment ``i`` is *landed*
when points ``i`` and ``i+1`` are both anchored (it is frozen).  The limit of hinge
``k`` is in force when neither segment ``k`` nor ``k+1`` has landed (the
``anchor_cone`` option is not modelled here).

Coordinates.  The 3N components of all axes ``e_i`` plus the pivot position ``p``
(3 more; held at its anchor by the constraint of point N).  Carrying ``p`` costs
nothing and gives the pivot force as an ordinary multiplier.  Internally ``p`` is
scaled, ``q = (p / b, e_0, ..., e_{N-1})``, so that every constraint row is
dimensionless.  Centre of segment i:

    R_i = p + b sum_k C_ik e_k,   C_ii = 1, C_ik = 2 (k > i), 0 (k < i),

so with ``s_k = sum_i C_ik = 2k + 1`` and ``A = C^T C + I/3`` (rods: no spin inertia,
moment m b^2 / 3 about the centre)

    T = 1/2 m b^2 [ N |dp/b|^2 + 2 (dp/b) . sum_k s_k de_k + de^T (A kron I3) de ],
    U = m g sum_i z(R_i) = m g b [ N p_z / b + sum_k s_k e_kz ].

Constraints (rows of R, with R ddq = gamma at the acceleration level):
  * unit  i (not landed):  e_i . dde_i = -|de_i|^2;
  * landed i:              dde_i = 0 (3 rows: the segment is frozen);
  * anchor j:              d2/dt2 (p/b + 2 sum_{i >= j} e_i) = 0 (3 rows; linear in q);
  * lock  k (in force):    e_{k+1} . dde_k + e_k . dde_{k+1} = -2 de_k . de_{k+1}.

Gauss / KKT:  M ddq = f + R^T nu,  R ddq = gamma.  Redundant rows (a landed segment
with two anchors, two rods locked between two anchors, ...) are handled by the
null-space method with an SVD rank decision; the accelerations are unique, the
multipliers are the minimum-norm ones, and each multiplier is flagged as *determined*
when it does not depend on that choice (its row has no component in the left null
space of R).

Multiplier conventions (as in the production path):
  * lock ``lam_k``: generalised force ``lam_k e_{k+1}`` on ``e_k`` and ``lam_k e_k`` on
    ``e_{k+1}``, i.e. the couple ``lam_k e_k x e_{k+1}`` on segment k; ``lam >= 0``
    pushes the hinge open.  Units of energy (m g b).
  * anchor force at point j: the force of the anchor on the chain at that point (the
    sum of the forces on the two segments meeting there).  Units m g.

Impacts (Moreau / Gauss): the post-impact velocity minimises the kinetic energy of the
velocity jump, 1/2 (dq+ - dq-)^T M (dq+ - dq-), over velocities with every anchored
point at rest, unit lengths kept, landed segments still, and ``dg_k/dt >= 0`` on the
candidate hinges (in force).  The small QP is solved exactly by enumerating the active
sets of the candidate hinges (2^(#candidates) equality-constrained solves).
"""

from __future__ import annotations

import numpy as np

_RANK_RTOL = 1e-10  # singular values below this fraction of the largest: rank deficient
_NULL_TOL = 1e-8  # a multiplier is determined if its row's left-null-space weight is below


# --------------------------------------------------------------------------- helpers


def _masks(n, anchored, locked):
    anc = np.asarray(anchored).astype(bool).reshape(n + 1).copy()
    anc[n] = True  # the pivot is always anchored
    lck = np.asarray(locked).astype(bool).reshape(max(n - 1, 0)).copy()
    return anc, lck


def landed_segments(anchored):
    """Segment i is landed iff points i and i+1 are anchored."""
    anc = np.asarray(anchored).astype(bool)
    return anc[:-1] & anc[1:]


def limits_in_force(anchored):
    """Hinge k's limit is in force iff neither segment k nor k+1 has landed."""
    landed = landed_segments(anchored)
    return ~landed[:-1] & ~landed[1:]


def point_positions(e, b=1.0, p=(0.0, 0.0, 0.0)):
    """Points 0..N: point j = p + 2 b sum_{i >= j} e_i."""
    e = np.asarray(e, dtype=float)
    n = e.shape[0]
    out = np.zeros((n + 1, 3))
    out[n] = p
    for j in range(n - 1, -1, -1):
        out[j] = out[j + 1] + 2.0 * b * e[j]
    return out


def _s(n):
    """s_k = sum_i C_ik = 2k + 1 (number of centres that e_k moves, weighted)."""
    C = np.eye(n) + 2.0 * np.triu(np.ones((n, n)), 1)
    return C, C.sum(axis=0)


def mass_matrix(n, m=1.0, b=1.0):
    """Mass matrix in the scaled coordinates q = (p / b, e) (kinetic energy 1/2 dq M dq)."""
    C, s = _s(n)
    A = C.T @ C + np.eye(n) / 3.0
    I3 = np.eye(3)
    M = np.zeros((3 + 3 * n, 3 + 3 * n))
    M[:3, :3] = n * I3
    M[:3, 3:] = np.kron(s[None, :], I3)
    M[3:, :3] = M[:3, 3:].T
    M[3:, 3:] = np.kron(A, I3)
    return m * b * b * M


def generalized_gravity(n, m=1.0, b=1.0, g=1.0):
    """f = -dU/dq in the scaled coordinates."""
    _, s = _s(n)
    f = np.zeros(3 + 3 * n)
    f[2] = -m * g * b * n
    f[3 + 2 :: 3] = -m * g * b * s
    return f


def kinetic_energy(e, w, m=1.0, b=1.0):
    """T from the dense metric (pivot at rest)."""
    e = np.asarray(e, dtype=float)
    de = np.cross(np.asarray(w, dtype=float), e)
    u = np.concatenate([np.zeros(3), de.reshape(-1)])
    return 0.5 * u @ mass_matrix(e.shape[0], m, b) @ u


def potential_energy(e, m=1.0, b=1.0, g=1.0):
    """U = m g sum_i z(R_i) with the pivot at the origin."""
    e = np.asarray(e, dtype=float)
    _, s = _s(e.shape[0])
    return m * g * b * float(s @ e[:, 2])


def constraint_rows(e, anchored, locked, de=None):
    """Constraint rows R on q = (p/b, e) and, if ``de`` is given, the acceleration
    right-hand side gamma (R ddq = gamma).  ``locked`` selects lock rows (only where the
    limit is in force).  Returns (R, gamma, labels) with labels[r] = (kind, index,
    component), kind in {"unit", "landed", "anchor", "lock"}."""
    e = np.asarray(e, dtype=float)
    n = e.shape[0]
    anc, lck = _masks(n, anchored, locked)
    landed = landed_segments(anc)
    inforce = limits_in_force(anc)
    rows, gam, labels = [], [], []
    ncol = 3 + 3 * n

    def col(i):
        return 3 + 3 * i

    for i in range(n):
        if landed[i]:
            for q in range(3):
                r = np.zeros(ncol)
                r[col(i) + q] = 1.0
                rows.append(r)
                gam.append(0.0)
                labels.append(("landed", i, q))
        else:
            r = np.zeros(ncol)
            r[col(i) : col(i) + 3] = e[i]
            rows.append(r)
            gam.append(0.0 if de is None else -float(de[i] @ de[i]))
            labels.append(("unit", i, 0))
    for j in range(n + 1):
        if not anc[j]:
            continue
        for q in range(3):
            r = np.zeros(ncol)
            r[q] = 1.0
            for i in range(j, n):
                r[col(i) + q] = 2.0
            rows.append(r)
            gam.append(0.0)
            labels.append(("anchor", j, q))
    for k in range(n - 1):
        if lck[k] and inforce[k]:
            r = np.zeros(ncol)
            r[col(k) : col(k) + 3] = e[k + 1]
            r[col(k + 1) : col(k + 1) + 3] = e[k]
            rows.append(r)
            gam.append(0.0 if de is None else -2.0 * float(de[k] @ de[k + 1]))
            labels.append(("lock", k, 0))
    R = np.array(rows).reshape(len(rows), ncol)
    return R, np.array(gam), labels


def _svd_split(R, ncol):
    """Null space Z of R (columns), left null space L (columns), rank."""
    if R.shape[0] == 0:
        return np.eye(ncol), np.zeros((0, 0)), 0
    U, sv, Vt = np.linalg.svd(R, full_matrices=True)
    rank = int(np.sum(sv > _RANK_RTOL * max(sv[0], 1e-300)))
    return Vt[rank:].T, U[:, rank:], rank


def _determined(L, nrows):
    if L.size == 0:
        return np.ones(nrows, dtype=bool)
    return np.sqrt(np.sum(L * L, axis=1)) < _NULL_TOL


def _m_projection(M, Z, u):
    """M-orthogonal projection of u onto span(Z)."""
    if Z.shape[1] == 0:
        return np.zeros_like(u)
    H = Z.T @ M @ Z
    return Z @ np.linalg.solve(H, Z.T @ (M @ u))


def project_velocity(e, w, anchored, locked, m=1.0, b=1.0):
    """Consistent angular velocities: the velocity closest to ``w x e`` (kinetic-energy
    metric) with anchored points at rest, landed segments still, locked hinges (in
    force) at constant angle.  Returns w (N, 3), perpendicular to e."""
    e = np.asarray(e, dtype=float)
    n = e.shape[0]
    R, _, _ = constraint_rows(e, anchored, locked)
    Z, _, _ = _svd_split(R, 3 + 3 * n)
    u = np.concatenate([np.zeros(3), np.cross(np.asarray(w, dtype=float), e).reshape(-1)])
    u = _m_projection(mass_matrix(n, m, b), Z, u)
    de = u[3:].reshape(n, 3)
    return np.cross(e, de)


# --------------------------------------------------------------------- accelerations


def reference_accelerations(e, w, anchored, locked, alpha, m=1.0, b=1.0, g=1.0):
    """Accelerations from the dense KKT system (Gauss's principle).

    ``e`` (N, 3) unit axes, ``w`` (N, 3) angular velocities (perpendicular to e, zero on
    landed segments, consistent with anchors and locks), ``anchored`` (N+1,) and
    ``locked`` (N-1,) masks.  ``alpha`` is accepted for symmetry (the acceleration level
    only needs the constraint gradient).  Returns a dict:

      dde (N,3), dw (N,3) = e x dde, lam (N-1,) lock multipliers (0 where not locked or
      not in force), lam_determined (N-1,) bool, anchor_force (N+1,3) (force of the
      anchor on the chain at each anchored point), anchor_determined (N+1,) bool (true
      where the force is unique and neither neighbour segment has landed: only there is
      it comparable with the production path), nu, labels (raw multipliers and rows).
    """
    del alpha
    e = np.asarray(e, dtype=float)
    w = np.asarray(w, dtype=float)
    n = e.shape[0]
    anc, lck = _masks(n, anchored, locked)
    landed = landed_segments(anc)
    de = np.cross(w, e)
    M = mass_matrix(n, m, b)
    f = generalized_gravity(n, m, b, g)
    R, gamma, labels = constraint_rows(e, anc, lck, de)
    ncol = 3 + 3 * n
    Z, L, _ = _svd_split(R, ncol)
    if R.shape[0]:
        acc_p = np.linalg.lstsq(R, gamma, rcond=None)[0]
        res = np.linalg.norm(R @ acc_p - gamma)
        if res > 1e-8 * max(1.0, np.linalg.norm(gamma)):
            raise ValueError(f"inconsistent velocity state (acceleration constraints residual {res:.3g})")
    else:
        acc_p = np.zeros(ncol)
    if Z.shape[1]:
        y = np.linalg.solve(Z.T @ M @ Z, Z.T @ (f - M @ acc_p))
        acc = acc_p + Z @ y
    else:
        acc = acc_p
    if R.shape[0]:
        rhs = M @ acc - f
        nu = np.linalg.lstsq(R.T, rhs, rcond=None)[0]
        res = np.linalg.norm(R.T @ nu - rhs)
        if res > 1e-8 * max(1.0, np.linalg.norm(rhs)):
            raise RuntimeError(f"KKT multipliers inconsistent (residual {res:.3g})")
    else:
        nu = np.zeros(0)
    det = _determined(L, R.shape[0])

    dde = acc[3:].reshape(n, 3).copy()
    dde[landed] = 0.0
    lam = np.zeros(max(n - 1, 0))
    lam_det = np.ones(max(n - 1, 0), dtype=bool)
    af = np.zeros((n + 1, 3))
    af_det = np.zeros(n + 1, dtype=bool)
    af_rows_ok = np.ones(n + 1, dtype=bool)
    for r, (kind, idx, q) in enumerate(labels):
        if kind == "lock":
            lam[idx] = nu[r]
            lam_det[idx] = det[r]
        elif kind == "anchor":
            af[idx, q] = nu[r] / b  # rows scaled by 1/b: physical force = nu / b
            af_rows_ok[idx] &= det[r]
    for j in range(n + 1):
        nb_landed = (j >= 1 and landed[j - 1]) or (j < n and landed[j])
        af_det[j] = anc[j] and af_rows_ok[j] and not nb_landed
    return {
        "dde": dde,
        "dw": np.cross(e, dde),
        "lam": lam,
        "lam_determined": lam_det,
        "anchor_force": af,
        "anchor_determined": af_det,
        "nu": nu,
        "labels": labels,
    }


# --------------------------------------------------------------------------- impacts


def hinge_rates(e, w):
    """dg_k/dt = de_k . e_{k+1} + e_k . de_{k+1}."""
    e = np.asarray(e, dtype=float)
    de = np.cross(np.asarray(w, dtype=float), e)
    return np.einsum("ij,ij->i", de[:-1], e[1:]) + np.einsum("ij,ij->i", e[:-1], de[1:])


def reference_impact(e, w_minus, anchored, candidates, alpha, m=1.0, b=1.0, g=1.0, tol=1e-10, in_force=None):
    """Moreau's perfectly inelastic impact by enumeration of active sets.

    ``anchored`` includes points that just touched (they may be moving before).
    ``candidates`` (N-1,) mask of hinges at their limit; only those in force count.
    Returns a dict: w_plus (N,3), Lambda (N-1,) lock impulses (>= 0, generalised
    impulse Lambda e_{k+1} on e_k; units m b sqrt(g b) in physical terms),
    Lambda_determined (N-1,) (False where the impulse is not unique, e.g. two rods
    between two anchors), rates (N-1,) dg/dt after, anchor_impulse (N+1,3) (impulse of
    the anchor on the chain), anchor_determined (N+1,) (unique and no landed
    neighbour), lost_energy (>= 0), active (N-1,)
    bool, kkt (True if an active set satisfying primal and dual feasibility was found;
    False if the fallback "cheapest primal-feasible" was used, e.g. redundant rows).
    ``g`` and ``alpha`` do not enter (accepted for a uniform signature).
    ``in_force`` (N-1,) optionally overrides which hinge limits are in force (default:
    neither neighbour segment landed, counting the points anchored by this impact).
    """
    del alpha, g
    e = np.asarray(e, dtype=float)
    w_minus = np.asarray(w_minus, dtype=float)
    n = e.shape[0]
    anc, cand = _masks(n, anchored, candidates)
    if in_force is None:
        in_force = limits_in_force(anc)
    cand = cand & np.asarray(in_force).astype(bool).reshape(cand.shape)
    M = mass_matrix(n, m, b)
    ncol = 3 + 3 * n
    E, _, elabels = constraint_rows(e, anc, np.zeros(max(n - 1, 0), dtype=bool))
    G = np.zeros((max(n - 1, 0), ncol))
    for k in range(n - 1):
        G[k, 3 + 3 * k : 6 + 3 * k] = e[k + 1]
        G[k, 6 + 3 * k : 9 + 3 * k] = e[k]
    u_minus = np.concatenate([np.zeros(3), np.cross(w_minus, e).reshape(-1)])
    vscale = max(np.max(np.abs(u_minus)), 1e-300)
    rate_tol = tol * vscale
    imp_tol = tol * m * b * b * vscale
    idx = np.flatnonzero(cand)
    best = None  # (cost, u, nu, S, kkt)
    for mask in range(1 << idx.size):
        S = idx[[(mask >> t) & 1 == 1 for t in range(idx.size)]]
        R = np.vstack([E, G[S]])
        Z, _, _ = _svd_split(R, ncol)
        u = _m_projection(M, Z, u_minus)
        rates = G @ u
        if idx.size and np.min(rates[idx]) < -rate_tol:
            continue
        du = u - u_minus
        cost = 0.5 * du @ M @ du
        nu = np.linalg.lstsq(R.T, M @ du, rcond=None)[0]
        lam_s = nu[E.shape[0] :]
        kkt = bool(np.all(lam_s >= -imp_tol))
        key = (not kkt, cost)
        if best is None or key < (not best[4], best[0]):
            best = (cost, u, nu, S, kkt)
    assert best is not None  # the full active set is always primal feasible
    cost, u, nu, S, kkt = best
    de = u[3:].reshape(n, 3)
    w_plus = np.cross(e, de)
    Lam = np.zeros(max(n - 1, 0))
    Lam[S] = nu[E.shape[0] :]
    # uniqueness of the impulses: a hinge with dg/dt = 0 after the impact could carry an
    # impulse (inactive or not); its impulse is unique iff its row is not in the span of
    # the other rows (no weight in the left null space of all rows that may carry one)
    rates = G @ u
    Sz = np.union1d(S, idx[np.abs(rates[idx]) <= rate_tol]).astype(int)
    _, L, _ = _svd_split(np.vstack([E, G[Sz]]), ncol)
    det = _determined(L, E.shape[0] + Sz.size)
    Lam_det = np.ones(max(n - 1, 0), dtype=bool)
    Lam_det[Sz] = det[E.shape[0] :]
    landed = landed_segments(anc)
    ai = np.zeros((n + 1, 3))
    ai_det = anc.copy()
    for r, (kind, j, q) in enumerate(elabels):
        if kind == "anchor":
            ai[j, q] = nu[r] / b
            ai_det[j] &= det[r]
    for j in range(n + 1):
        if (j >= 1 and landed[j - 1]) or (j < n and landed[j]):
            ai_det[j] = False
    active = np.zeros(max(n - 1, 0), dtype=bool)
    active[S] = True
    T0 = 0.5 * u_minus @ M @ u_minus
    T1 = 0.5 * u @ M @ u
    return {
        "w_plus": w_plus,
        "Lambda": Lam,
        "Lambda_determined": Lam_det,
        "rates": rates,
        "anchor_impulse": ai,
        "anchor_determined": ai_det,
        "lost_energy": T0 - T1,
        "jump_energy": cost,
        "active": active,
        "kkt": kkt,
    }


def reference_newton_impact(e, w_minus, anchored, candidates, restitution, m=1.0, b=1.0, tol=1e-10):
    """Newton's restitution at the bend limits (Glocker's form: xi = gamma+ + e gamma- >= 0,
    Lambda >= 0, complementary; the anchors inelastic), by enumeration of active sets:
    for each set S, the velocity closest to u- (kinetic-energy metric) with the equality
    rows' rates 0 and the rows of S at -e gamma-; the set whose impulses are >= 0 and whose
    other candidates have xi >= 0.  Then, if a candidate comes out closing (one that was
    leaving its limit, pushed back), Moreau's impact from there (``reference_impact``).
    If the result has more kinetic energy than u- (possible when a landing's inelastic rows
    act beside the elastic ones), the inelastic impact instead (``inelastic``).
    Returns w_plus (N,3), Lambda (N-1,) summed over both, Lambda_determined (N-1,) (False
    where an impulse is not unique), lost_energy, two_passes, inelastic."""
    e = np.asarray(e, dtype=float)
    w_minus = np.asarray(w_minus, dtype=float)
    n = e.shape[0]
    anc, cand = _masks(n, anchored, candidates)
    cand = cand & limits_in_force(anc)
    M = mass_matrix(n, m, b)
    Minv = np.linalg.inv(M)
    E, _, _ = constraint_rows(e, anc, np.zeros(max(n - 1, 0), dtype=bool))
    G = np.zeros((max(n - 1, 0), 3 + 3 * n))
    for k in range(n - 1):
        G[k, 3 + 3 * k : 6 + 3 * k] = e[k + 1]
        G[k, 6 + 3 * k : 9 + 3 * k] = e[k]
    u_minus = np.concatenate([np.zeros(3), np.cross(w_minus, e).reshape(-1)])
    g_minus = G @ u_minus
    vscale = max(np.max(np.abs(u_minus)), 1e-300)
    # a hinge whose rate the equality rows fix (two rods between two anchors) cannot take
    # the law: its impulse is not determined and its rate after is theirs
    rank_e = _svd_split(E, 3 + 3 * n)[2]
    for k in np.flatnonzero(cand):
        if _svd_split(np.vstack([E, G[k : k + 1]]), 3 + 3 * n)[2] == rank_e:
            cand[k] = False
    idx = np.flatnonzero(cand)
    found = None
    for mask in range(1 << idx.size):
        S = idx[[(mask >> t) & 1 == 1 for t in range(idx.size)]]
        R = np.vstack([E, G[S]])
        target = np.concatenate([np.zeros(E.shape[0]), -restitution * g_minus[S]])
        # u = u- + M^-1 R^T nu with R u = target (least squares for dependent rows)
        nu = np.linalg.lstsq(R @ Minv @ R.T, target - R @ u_minus, rcond=1e-12)[0]
        u = u_minus + Minv @ R.T @ nu
        if np.abs(R @ u - target).max(initial=0.0) > tol * vscale:
            continue
        lam = nu[E.shape[0] :]
        xi = G @ u + restitution * g_minus
        others = np.setdiff1d(idx, S)
        if np.all(lam >= -tol * vscale) and np.all(xi[others] >= -tol * vscale):
            found = (u, S, lam)
            break
    assert found is not None
    u, S, lam = found
    Lam = np.zeros(max(n - 1, 0))
    Lam[S] = lam
    # an impulse is unique iff its row is not in the span of the other rows that act
    det = np.ones(max(n - 1, 0), dtype=bool)
    if S.size:
        _, L, _ = _svd_split(np.vstack([E, G[S]]), 3 + 3 * n)
        det[S] = _determined(L, E.shape[0] + S.size)[E.shape[0] :]
    w_plus = np.cross(e, u[3:].reshape(n, 3))
    rates = G @ u
    two = bool(idx.size and np.min(rates[idx]) < -tol * vscale)
    if two:
        second = reference_impact(e, w_plus, anchored, candidates, 1.0, m=m, b=b, tol=tol)
        w_plus = second["w_plus"]
        Lam = Lam + second["Lambda"]
        det &= second["Lambda_determined"]
        u = np.concatenate([np.zeros(3), np.cross(w_plus, e).reshape(-1)])
    T0 = 0.5 * u_minus @ M @ u_minus
    T1 = 0.5 * u @ M @ u
    if T1 > T0 * (1 + 1e-12):  # (mixed with a landing's inelastic rows): the inelastic impact
        r = reference_impact(e, w_minus, anchored, candidates, 1.0, m=m, b=b, tol=tol)
        return {
            "w_plus": r["w_plus"],
            "Lambda": r["Lambda"],
            "Lambda_determined": r["Lambda_determined"],
            "lost_energy": r["lost_energy"],
            "two_passes": False,
            "inelastic": True,
        }
    return {
        "w_plus": w_plus,
        "Lambda": Lam,
        "Lambda_determined": det,
        "lost_energy": T0 - T1,
        "two_passes": two,
        "inelastic": False,
    }
