"""Low-rank spectral updates for safe modes that change several links (a rank-s update of L_1).

The machinery behind the multi-link search of :mod:`glocal_verify.design.safe_modes` (its
module docstring, "Multi-link modes", has the proofs). A change of s links {i_m, j_m} with
signed weights delta_m (+w added, -w removed) is dL = B D B^T, B = [e_{i_m} - e_{j_m}],
D = diag(delta). Everything here works on agent indices, so it needs no spec object.

* :func:`link_forest` -- the switching components (Definition A.1) of a forest of links;
* :func:`image_kernel_holds` -- Theorem III.3 (i), rank(S_M B) = s, decided over Q;
* :func:`rank_one_update` -- one rank-one update of a diagonal matrix (Golub's secular
  equation), carrying tracked vectors into the new eigenbasis;
* :func:`screen_changes` -- (ii) and (iii) for many changes at once, from s successive
  rank-one updates of the eigenbasis of L_1 (batched; a change whose update deflates falls
  back to :func:`rank_one_update`, one at a time);
* :func:`touch_cover` -- which changes touch every stealthy direction of which attack.

The screen is not a proof: the search re-verifies every proposal with the checkers. Its
thresholds: eigenvalues positive and apart by more than ``SCREEN_MARGIN`` times the
largest, eigenvector differences (unit eigenvectors) above ``SCREEN_MARGIN`` (the tunable
``multilink_screen_margin``).
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction

import numpy as np

from glocal_verify import config

__all__ = ["image_kernel_holds", "link_forest", "rank_one_update", "screen_changes", "touch_cover"]

#: the screen's margin and the bisection steps of the secular equation are the tunables
#: ``multilink_screen_margin`` and ``multilink_bisection_steps`` (:mod:`glocal_verify.config`),
#: read when used (each step halves the interlacing bracket; plain Newton steps from either
#: side converge badly next to a pole, so none are taken)

Pair = tuple[int, int]


def link_forest(pairs: Sequence[Pair]) -> list[list[int]] | None:
    """The node sets of the switching components of ``pairs``; None if a pair repeats or the links close a cycle.

    Parameters
    ----------
    pairs : sequence of (int, int)
        Agent indices of the changed links.
    """
    parent: dict[int, int] = {}

    def find(a: int) -> int:
        while parent.setdefault(a, a) != a:
            a = parent[a]
        return a

    for i, j in pairs:
        ri, rj = find(i), find(j)
        if ri == rj:  # a repeated pair is a cycle of length two
            return None
        parent[ri] = rj
    comps: dict[int, list[int]] = {}
    for a in list(parent):
        comps.setdefault(find(a), []).append(a)
    return sorted(sorted(v) for v in comps.values())


def image_kernel_holds(pairs: Sequence[Pair], monitored: set[int]) -> bool:
    """Theorem III.3 (i) for a forest of links: rank over Q of the monitored rows of B is the number of links.

    Parameters
    ----------
    pairs : sequence of (int, int)
        Agent indices of the changed links (a forest: B has full column rank).
    monitored : set of int
        Indices of M = M_x ∪ M_v.

    Notes
    -----
    rank(S_M dL) = rank(S_M B D B^T) = rank(S_M B) since B^T has full row rank and D is
    invertible; Gaussian elimination over Fraction, so exact.
    """
    rows = [[Fraction(int(i == m) - int(j == m)) for i, j in pairs] for m in sorted(monitored)]
    rows = [r for r in rows if any(r)]
    rank = 0
    for col in range(len(pairs)):
        piv = next((r for r in range(rank, len(rows)) if rows[r][col] != 0), None)
        if piv is None:
            continue
        rows[rank], rows[piv] = rows[piv], rows[rank]
        for r in range(len(rows)):
            if r != rank and rows[r][col] != 0:
                f = rows[r][col] / rows[rank][col]
                rows[r] = [x - f * y for x, y in zip(rows[r], rows[rank])]
        rank += 1
    return rank == len(pairs)


def _brackets(d: np.ndarray, z: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """Signed bracket widths of the roots measured from their origin pole d_l (batched, last axis).

    rho > 0: root l in (d_l, d_{l+1}), the last in (d_n, d_n + rho ||z||^2); rho < 0: root l in
    (d_{l-1}, d_l), the first in (d_1 - |rho| ||z||^2, d_1). Origin d_l in both cases.
    """
    span = np.abs(rho) * np.sum(z * z, axis=-1)
    gaps = np.diff(d, axis=-1)
    up = np.concatenate([gaps, span[..., None]], axis=-1)
    down = -np.concatenate([span[..., None], gaps], axis=-1)
    return np.where((rho > 0)[..., None], up, down)


def _secular(d: np.ndarray, z: np.ndarray, rho: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Roots tau (offsets from d_l) and d_k - d_l - tau_l of 1 + rho sum z^2 / (d - x) = 0 (batched)."""
    width = _brackets(d, z, rho)
    rel = d[..., None, :] - d[..., :, None]  # [.., l, k] = d_k - d_l
    z2 = (z * z)[..., None, :]
    r = rho[..., None]
    lo, hi = np.minimum(0.0, width), np.maximum(0.0, width)
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(config.get("multilink_bisection_steps")):
            tau = 0.5 * (lo + hi)
            f = 1.0 + r * np.sum(z2 / (rel - tau[..., None]), axis=-1)
            right = r * f < 0  # the root lies above tau
            lo, hi = np.where(right, tau, lo), np.where(right, hi, tau)
    tau = 0.5 * (lo + hi)
    return tau, rel - tau[..., None]


def rank_one_update(d: np.ndarray, T: np.ndarray, col: int, rho: float) -> tuple[np.ndarray, np.ndarray] | None:
    """Eigenvalues of diag(d) + rho z z^T (z = T[:, col]) and the tracked vectors T in the new eigenbasis.

    Golub's secular equation 1 + rho sum_k z_k^2 / (d_k - x) = 0 on the non-deflated poles
    (|z_k| > 1e-13 ||z||; a deflated (d_k, e_k) stays an eigenpair), solved by
    ``multilink_bisection_steps`` bisection steps in the interlacing brackets, each root measured from
    its origin pole (so d_k - x keeps its relative accuracy next to it); eigenvectors
    (diag(d) - x)^{-1} z, normalised.

    Parameters
    ----------
    d : ndarray (n,)
        Distinct ascending eigenvalues.
    T : ndarray (n, c)
        Tracked vectors in the eigenbasis.
    col : int
        The column of T that is z.
    rho : float
        The weight of the update.

    Returns
    -------
    (ndarray, ndarray) or None
        New ascending eigenvalues and the tracked vectors in the new eigenbasis; None when a
        root cannot be separated from a pole.
    """
    z = T[:, col]
    act = np.abs(z) > 1e-13 * max(float(np.linalg.norm(z)), 1e-300)
    if not act.any():
        return d, T
    tau, diff = _secular(d[act], z[act], np.asarray(rho))
    if not np.all(diff != 0):
        return None
    W = z[act][None, :] / diff
    W /= np.linalg.norm(W, axis=1, keepdims=True)
    if not np.all(np.isfinite(W)):
        return None
    n, ia, keep = len(d), np.flatnonzero(act), np.flatnonzero(~act)
    V = np.zeros((n, n))  # columns: the new eigenvectors in the old basis
    V[np.ix_(ia, ia)] = W.T
    V[keep, keep] = 1.0
    vals = np.empty(n)
    vals[ia] = d[act] + tau
    vals[keep] = d[keep]
    order = np.argsort(vals, kind="stable")
    return vals[order], V[:, order].T @ T


def _accept(d: np.ndarray, T: np.ndarray, s: int) -> np.ndarray:
    """(ii) and (iii) at the screen margin for a batch of final spectra d (B, n) and tracked T (B, n, c)."""
    scale = np.maximum(1.0, np.max(np.abs(d), axis=-1))
    margin = config.get("multilink_screen_margin")
    ok = d[..., 0] > margin * scale
    ok &= np.all(np.diff(d, axis=-1) > margin * scale[..., None], axis=-1)
    return ok & np.all(np.abs(T[..., s:]) > margin, axis=(-2, -1))


def screen_changes(U: np.ndarray, values: np.ndarray, changes: Sequence[tuple[Sequence[Pair], Sequence[float]]]) -> np.ndarray:
    """(ii) and (iii) of Theorem III.3 for changes of s links each, by s rank-one updates of L_1 = U diag(values) U^T.

    In the eigenbasis of L_1 with the constant eigenvector deflated (every e_i - e_j is
    orthogonal to it), the links are added one at a time, carrying the coordinates of every
    link vector and of every difference e_i - e_j of a pair in one switching component. A
    change passes when the N - 1 nonzero eigenvalues of L_q are positive and apart, and
    every carried difference is nonzero on every eigenvector (``SCREEN_MARGIN``). Changes of
    one size are updated together (arrays (B, N - 1, N - 1) per bisection step); a change
    whose update deflates (some z_k = 0) is redone alone with :func:`rank_one_update`.
    O(s N^2) per bisection step and change; no fresh eigendecomposition.

    Parameters
    ----------
    U : ndarray (N, N)
        Orthonormal eigenvectors of L_1, ascending, u_1 constant.
    values : ndarray (N,)
        The eigenvalues (distinct).
    changes : sequence of (pairs, deltas)
        Each change's links (agent indices, a forest) and signed weights, all of one size s.

    Returns
    -------
    ndarray of bool
        Per change: proposed (the checkers still decide).
    """
    out = np.zeros(len(changes), dtype=bool)
    if not changes:
        return out
    s = len(changes[0][0])
    U1, d0 = U[:, 1:], np.asarray(values, dtype=float)[1:]
    tracked = []
    for pairs, _ in changes:
        comps = link_forest(pairs) or []
        vecs = [U1[i] - U1[j] for i, j in pairs] + [U1[i] - U1[j] for c in comps for a, i in enumerate(c) for j in c[a + 1 :]]
        tracked.append(vecs)
    width = max(len(v) for v in tracked)
    T = np.stack([np.column_stack(v + [v[-1]] * (width - len(v))) for v in tracked])  # (B, n, c)
    d = np.broadcast_to(d0, (len(changes), len(d0))).copy()
    rho_all = np.array([list(dl) for _, dl in changes], dtype=float)
    alone = np.zeros(len(changes), dtype=bool)
    for m in range(s):
        z = T[:, :, m]
        alone |= np.any(np.abs(z) <= 1e-13 * np.maximum(np.linalg.norm(z, axis=1, keepdims=True), 1e-300), axis=1)
        live = np.flatnonzero(~alone)
        if len(live) == 0:
            break
        tau, diff = _secular(d[live], z[live], rho_all[live, m])
        with np.errstate(divide="ignore", invalid="ignore"):
            W = z[live][:, None, :] / diff
            W /= np.linalg.norm(W, axis=-1, keepdims=True)
        bad = ~np.all(np.isfinite(W), axis=(1, 2))
        alone[live[bad]] = True
        d[live] = d[live] + tau
        T[live] = W @ T[live]
    live = np.flatnonzero(~alone)
    out[live] = _accept(d[live], T[live], s)
    for b in np.flatnonzero(alone):
        db, Tb = d0.copy(), np.column_stack(tracked[b])
        ok = True
        for m in range(s):
            got = rank_one_update(db, Tb, m, float(rho_all[b, m]))
            if got is None:
                ok = False
                break
            db, Tb = got
        out[b] = ok and bool(_accept(db[None], Tb[None], s)[0])
    return out


def touch_cover(targets: Sequence[tuple[np.ndarray, np.ndarray]], I: np.ndarray, J: np.ndarray, thr: float) -> np.ndarray:
    """(P, T) mask: change p (links I[p, m]-J[p, m]) touches every stealthy direction of target t.

    dL X c = B D (B^T X) c vanishes iff (B^T X) c = 0 (B of full column rank for a forest, D
    invertible), so the switch is unavoidable iff the kernel of the s x r matrix
    A = X[I] - X[J] has no input part (batched SVD, numerical rank at ``thr``).

    Parameters
    ----------
    targets : sequence of (X, B)
        Per attack: the xi-orthonormal basis (N x r) of its possible stealthy kernel and its
        input part (m x r).
    I, J : ndarray (P, s) of int
        Endpoints of the links of each change.
    thr : float
        Zero threshold of the touch test.
    """
    out = np.zeros((len(I), len(targets)), dtype=bool)
    for t, (X, Bin) in enumerate(targets):
        r = X.shape[1]
        if r == 0 or len(I) == 0 or (r == 1 and float(np.linalg.norm(Bin)) <= thr):
            continue
        A = X[I] - X[J]  # (P, s, r)
        _, sv, Vh = np.linalg.svd(A, full_matrices=True)
        rank = np.sum(sv > thr, axis=1)
        colnorm = np.linalg.norm(np.einsum("mr,pqr->pmq", Bin, Vh.conj()), axis=1)  # (P, r)
        kernel = np.arange(r)[None, :] >= rank[:, None]
        out[:, t] = (rank > 0) & np.all(~kernel | (colnorm <= thr), axis=1)
    return out
