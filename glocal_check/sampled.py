"""The sampled implementation (``[implementation]``, period h): ``sampled.stability``,
``sampled.no-aliasing``, ``sampled.observability`` and ``sampled.zda``.

Sampled controller (every agent samples its neighbours and holds its command), exact over Q:

    Phi_q = [[I - (alpha h^2 / 2) L_q, (h - gamma h^2 / 2) I], [-alpha h L_q, (1 - gamma h) I]],
    Gamma = [(h^2 / 2) I; h I].

Per eigenvalue mu of L_q the 2 x 2 block has the characteristic polynomial
p_mu(z) = (z - 1)(z - 1 + gamma h) + (alpha mu h^2 / 2)(z + 1).

* Stability (Jury's test on p_mu): the loop is stable apart from one z = 1 per component iff
  gamma h < 2 and every eigenvalue of L_q is below c = 2 gamma / (alpha h). ``jury``: gamma h < 2
  and c I - L_q > 0 (:func:`~glocal_check.algebra.positive_definite`, the stated shift and
  factor);
  ``rayleigh`` (fails): a rational x with x^T L_q x >= c x^T x; ``structure`` (fails):
  gamma h >= 2.
* Aliasing: p_a - p_b = (alpha (mu_a - mu_b) h^2 / 2)(z + 1), so two blocks share an eigenvalue
  only at z = -1, where p_mu(-1) = 2 (2 - gamma h): only when gamma h = 2, which is also the only
  way a block is a multiple of I. Without aliasing A_q is a polynomial in Phi_q and the two have
  the same unobservable subspace (``sampled.observability`` holds).
* A ZDA of the sampled pencil (``sampled-zda``): [[z0 I - Phi_1, -Gamma_F], [C, 0]] [x; u0] = 0,
  u0 != 0, checked over Q at the stated rational z0.

Continuous loop (only the detectors sample): Phi_q = exp(A_q h). Its eigenvalues exp(lam h) are
inside the unit circle except exp(0) = 1 once per component (Re lam < 0 otherwise, and the
mu = 0 block is diagonalisable): stable. Two distinct algebraic eigenvalues lam_a != lam_b of
A_q alias iff (lam_a - lam_b) h = 2 pi i k; with h rational that makes pi algebraic unless
k = 0 (Lindemann-Weierstrass): no aliasing at any rational period, so observability holds.
"""

from __future__ import annotations

from typing import Any

from flint import fmpq, fmpq_mat

from glocal_check.algebra import Rejected, integer_matrix, lyapunov, positive_definite, require
from glocal_check.context import Context, LocalScope
from glocal_check.spec import rational

__all__ = ["SAMPLED_STRUCTURAL", "detector_stable", "sampled_stability", "sampled_uio", "sampled_zda"]


def _impl(ctx: Context) -> tuple[fmpq, str]:
    impl = ctx.spec.implementation
    require(impl is not None, "the spec has no [implementation]")
    require(impl["controller"] in ("sampled", "continuous"), f"unknown controller {impl['controller']!r}")
    return impl["period"], impl["controller"]


def no_aliasing(ctx: Context, scope: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """Sampled controller: holds iff gamma h != 2; continuous loop at a rational period: holds."""
    ctx.mode(scope.get("mode"))
    h, kind = _impl(ctx)
    gh = ctx.spec.gamma * h
    return ("holds" if kind == "continuous" or gh != 2 else "fails"), {"controller": kind, "gamma_h": str(gh)}


def observability(ctx: Context, scope: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """Holds without aliasing (A_q is then a polynomial in Phi_q); with aliasing the dimensions
    decide, which a structure certificate does not state."""
    st, facts = no_aliasing(ctx, scope)
    require(st == "holds", "with aliasing sampled.observability needs the dimensions (no structure certificate)")
    return "holds", facts


def stability_structural(ctx: Context, scope: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """Continuous loop: holds; sampled controller: fails when gamma h >= 2 (Jury: 4 - 2 gamma h
    = p_mu(-1) must be positive); otherwise the spectrum decides (``jury`` / ``rayleigh``)."""
    ctx.mode(scope.get("mode"))
    h, kind = _impl(ctx)
    gh = ctx.spec.gamma * h
    if kind == "continuous":
        require(ctx.spec.alpha > 0 and ctx.spec.gamma > 0, "alpha and gamma must be positive")
        return "holds", {"controller": kind, "gamma_h": str(gh)}
    require(gh >= 2, "gamma h < 2: the spectrum of L_q decides (a jury or rayleigh certificate)")
    return "fails", {"controller": kind, "gamma_h": str(gh)}


def uio_rank(ctx: Context, scope: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """``sampled.local-uio`` fails on its rank condition: E_d has the column (h^2/2) e_b on the
    position and h e_b on the velocity of each boundary agent b, so rank(C E_d) = rank(E_d)
    iff every boundary agent has its position or its velocity measured."""
    ls = LocalScope(ctx.spec, {**scope, "suspected": "all"})
    seen = set(ls.observer.positions) | set(ls.observer.velocities)
    miss = [a for a in ls.boundary if a not in seen]
    require(bool(miss), "the rank condition holds: a sampled-uio certificate is needed")
    return "fails", {"unmeasured_boundary": ctx.labels(miss)}


#: condition id -> its rule on the spec (``structure`` certificates)
SAMPLED_STRUCTURAL = {
    "sampled.no-aliasing": no_aliasing,
    "sampled.observability": observability,
    "sampled.stability": stability_structural,
    "sampled.local-uio": uio_rank,
}


def sampled_stability(ctx: Context, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    """Sampled controller, gamma h < 2: every eigenvalue of L_q below c = 2 gamma / (alpha h)
    (``jury``, holds) or not (``rayleigh``, fails)."""
    sp = ctx.spec
    m = ctx.mode(scope.get("mode"))
    h, kind = _impl(ctx)
    require(kind == "sampled" and sp.gamma * h < 2, "jury and rayleigh certificates concern a sampled controller with gamma h < 2")
    c = 2 * sp.gamma / (sp.alpha * h)
    L = ctx.lap(m)
    if status == "holds":
        require(cert.get("kind") == "jury", "sampled.stability holds needs a jury certificate")
        rows = [[(c if i == j else fmpq(0)) - L[i].get(j, fmpq(0)) for j in range(sp.n)] for i in range(sp.n)]
        Z, den = integer_matrix(rows)
        positive_definite(Z, den, rational(cert.get("shift"), "shift"), cert.get("R"), f"2 gamma / (alpha h) I - L_{m}")
        return
    require(cert.get("kind") == "rayleigh", "sampled.stability fails needs a rayleigh or structure certificate")
    x = sp.vector(cert.get("x"), "x")
    Lx = [sum((a * x[j] for j, a in L[i].items()), fmpq(0)) for i in range(sp.n)]
    xx = sum((v * v for v in x), fmpq(0))
    require(xx != 0 and sum((u * v for u, v in zip(x, Lx)), fmpq(0)) >= c * xx, f"x^T L_{m} x < 2 gamma / (alpha h) x^T x")


def sampled_zda(ctx: Context, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    """``sampled-zda`` (holds, sampled controller): (z0 I - Phi_1) x = Gamma_F u0, C x = 0,
    u0 != 0, at the stated rational z0 (x = [position part; velocity part])."""
    sp = ctx.spec
    h, kind = _impl(ctx)
    require(status == "holds" and not scope and cert.get("kind") == "sampled-zda" and kind == "sampled", "sampled.zda: only a ZDA of a sampled controller has a certificate")
    require(sp.attack is not None, "no [attack] in the spec")
    z0 = rational(cert.get("z0"), "z0")
    xp, xv = sp.vector(cert.get("x_position", {}), "x_position"), sp.vector(cert.get("x_velocity", {}), "x_velocity")
    u = sp.vector(cert.get("u0", {}), "u0")
    F = set(sp.attack["actuators"])
    require(any(u[a] != 0 for a in F) and all(u[a] == 0 for a in range(sp.n) if a not in F), "u0 is zero or acts outside F")
    a, g = sp.alpha, sp.gamma
    L = ctx.lap("normal")
    Lx = [sum((w * xp[j] for j, w in L[i].items()), fmpq(0)) for i in range(sp.n)]
    for i in range(sp.n):  # rows of [z0 I - Phi_1, -Gamma_F] [x; u0]
        top = z0 * xp[i] - (xp[i] - a * h * h / 2 * Lx[i] + (h - g * h * h / 2) * xv[i]) - h * h / 2 * u[i]
        bottom = z0 * xv[i] - (-a * h * Lx[i] + (1 - g * h) * xv[i]) - h * u[i]
        if top != 0 or bottom != 0:
            raise Rejected(f"(z0 I - Phi_1) x != Gamma_F u0 at agent {sp.labels[i]}")
    require(all(xp[i] == 0 for i in sp.positions) and all(xv[i] == 0 for i in sp.velocities), "C x != 0")


def sampled_uio(ctx: Context, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    """``sampled-uio`` (holds, sampled controller): F = T A_d - K1 C (:func:`_uio_error`) is
    Schur stable by a Stein certificate (:func:`~glocal_check.algebra.lyapunov` with
    ``discrete``)."""
    _, kind = _impl(ctx)
    require(status == "holds" and kind == "sampled" and cert.get("kind") == "sampled-uio", "sampled.local-uio holds needs a sampled-uio certificate of a sampled controller")
    lyapunov(_uio_error(ctx, scope, cert.get("K1")).tolist(), cert.get("stein"), discrete=True)


def _uio_error(ctx: Context, scope: dict[str, Any], K1: Any) -> fmpq_mat:
    """The error matrix F = T A_d - K1 C of a local observer's sampled UIO: A_d the cluster's
    block of Phi_1 (its rows and columns: the principal block of L_1 keeps the degrees), E_d,
    C the observer's channels (positions, then velocities, as listed),
    H = E_d ((C E_d)^T C E_d)^-1 (C E_d)^T, T = I - H C, K1 as stated."""
    sp = ctx.spec
    h, _ = _impl(ctx)
    ls = LocalScope(sp, {**scope, "suspected": "all"})
    P = list(ls.cluster.nodes)
    k = len(P)
    at = {a: i for i, a in enumerate(P)}
    L = ctx.lap("normal")
    a, g = sp.alpha, sp.gamma
    A = fmpq_mat(2 * k, 2 * k)
    for i, u in enumerate(P):
        A[i, i] += 1
        A[i, k + i] = h - g * h * h / 2
        A[k + i, k + i] = 1 - g * h
        for v, w in L[u].items():
            if v in at:
                A[i, at[v]] -= a * h * h / 2 * w
                A[k + i, at[v]] -= a * h * w
    cols = [at[u] for u in ls.observer.positions] + [k + at[u] for u in ls.observer.velocities]
    C = fmpq_mat(len(cols), 2 * k, [int(c == j) for c in cols for j in range(2 * k)])
    E = fmpq_mat(2 * k, len(ls.boundary))
    for j, b in enumerate(ls.boundary):
        E[at[b], j], E[k + at[b], j] = h * h / 2, h
    T = fmpq_mat(2 * k, 2 * k, [int(i == j) for i in range(2 * k) for j in range(2 * k)])
    if ls.boundary:
        CE = C * E
        require(CE.rank() == E.ncols(), "rank(C E_d) < rank(E_d)")
        T = T - E * (CE.transpose() * CE).inv() * CE.transpose() * C
    require(isinstance(K1, list) and len(K1) == 2 * k and all(isinstance(r, list) and len(r) == len(cols) for r in K1), "K1 is not 2 n_i x |channels|")
    return T * A - fmpq_mat(2 * k, len(cols), [rational(x, "K1") for r in K1 for x in r]) * C


def _central_error(ctx: Context, reps: Any, gain: Any) -> fmpq_mat:
    """The error matrix F = pi Phi_1 sigma - K C sigma of the sampled central observer, on the
    quotient by [1_c; 0] of each component of G_1 without a position monitor: sigma keeps every
    state but the representatives' positions (the stated ``reps``, one per such component), pi
    maps x to x_i - x_rep on a component's positions (pi sigma = I); K the stated gain."""
    sp = ctx.spec
    h, _ = _impl(ctx)
    n = sp.n
    blind = [c for c in sp.components("normal") if not set(sp.positions) & set(c)]
    rep = [sp.idx(x, "reps") for x in (reps if isinstance(reps, list) else [None])]
    require(len(rep) == len(blind) and all(any(r in c for r in rep) for c in blind), "one representative per component without a position monitor")
    rep_of = {i: r for c in blind for r in rep if r in c for i in c}
    keep = [i for i in range(2 * n) if i not in set(rep)]
    L = ctx.lap("normal")
    a, g = sp.alpha, sp.gamma
    Phi = fmpq_mat(2 * n, 2 * n)
    for i in range(n):
        Phi[i, i] += 1
        Phi[i, n + i] = h - g * h * h / 2
        Phi[n + i, n + i] = 1 - g * h
        for j, w in L[i].items():
            Phi[i, j] -= a * h * h / 2 * w
            Phi[n + i, j] -= a * h * w
    pi = fmpq_mat(len(keep), 2 * n)
    sigma = fmpq_mat(2 * n, len(keep))
    for r, i in enumerate(keep):
        pi[r, i], sigma[i, r] = 1, 1
        if i < n and i in rep_of:
            pi[r, rep_of[i]] = -1
    cols = list(sp.positions) + [n + i for i in sp.velocities]
    C = fmpq_mat(len(cols), 2 * n, [int(c == j) for c in cols for j in range(2 * n)])
    require(isinstance(gain, list) and len(gain) == len(keep) and all(isinstance(r, list) and len(r) == len(cols) for r in gain), "the gain is not (2N - d) x |channels|")
    K = fmpq_mat(len(keep), len(cols), [rational(x, "gain") for r in gain for x in r])
    return pi * Phi * sigma - K * C * sigma


def detector_stable(ctx: Context, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    """``detection.thresholds`` holds: the detector's exact error dynamics are Schur stable (a
    Stein certificate), which is what decides the verdict: with a bounded initial state, noise
    and disturbance the residual is then bounded at every sample, so a threshold no
    attack-free run crosses exists. The threshold values of the report are its witness, not
    part of the claim checked here."""
    _, kind = _impl(ctx)
    require(status == "holds" and kind == "sampled" and cert.get("kind") == "detector-stable", "detection.thresholds holds needs a detector-stable certificate of a sampled controller")
    name = scope.get("observer")
    require(isinstance(name, str), "the scope names no observer")
    if name == "central":
        F = _central_error(ctx, cert.get("reps"), cert.get("gain"))
    else:
        cluster, _, centre = name.partition("@")
        F = _uio_error(ctx, {"cluster": cluster, "observer": centre}, cert.get("K1"))
    lyapunov(F.tolist(), cert.get("stein"), discrete=True)
