"""The centralised observer (eq. obs_cent): ``central.observer``.

The claim: the gain H makes A_1 - H C stable on the observable part, i.e. on the quotient of
the state space by the unobservable subspace N (its eigenvalues there are fixed for every H).

* ``central-gain``: H exactly (the design's binary floating-point numbers), a rational basis X
  with C X = 0 and A_1 X = X R (so span X lies in N and is invariant under F = A_1 - H C), and
  pivot rows where X is invertible. On the quotient by span X, F acts as
  F_bar = (Q F)[rest, rest] with Q = I - X X[piv]^-1 E_piv^T; its eigenvalues, enclosed by
  python-flint, have negative real parts (its characteristic polynomial is the one stated,
  modulo a prime), or a Lyapunov matrix proves them so (``lyapunov``,
  :func:`~glocal_check.algebra.lyapunov`: large quotients). The quotient by N is a further quotient, whose
  eigenvalues are some of these.
* ``central-injection``: H = [0; alpha S_Mx^T] (the design of large networks). Then
  F = [[0, I], [-K, -gamma I]] with K = alpha (L_1 + S_Mx^T S_Mx) symmetric >= 0; an
  eigenvector [x; lam x] has lam^2 + gamma lam + x* K x / x* x = 0, so Re lam < 0 unless
  K x = 0, where [x; 0] is unobservable (C [x; 0] = 0, A_1 [x; 0] = 0) and has no Jordan
  chain (F [y; z] = [x; 0] gives K y = -gamma x, so x^T x = 0). The checker verifies that
  K is built from positive weights; nothing else is needed.
"""

from __future__ import annotations

from typing import Any

from flint import fmpq, fmpq_mat

from glocal_check.algebra import hurwitz, lyapunov, require
from glocal_check.context import Context
from glocal_check.spec import rational

__all__ = ["central"]


def central(ctx: Context, cert: dict[str, Any]) -> None:
    sp = ctx.spec
    kind = cert.get("kind")
    if kind == "central-injection":
        require(all(w > 0 for w in sp.weights["normal"].values()) and sp.gamma > 0 and sp.alpha > 0, "non-positive weights or gains")
        return
    require(kind == "central-gain", f"unknown certificate kind {kind!r}")
    n = sp.n
    names = [f"x:{lab}" for lab in sp.labels] + [f"v:{lab}" for lab in sp.labels]
    at = {s: k for k, s in enumerate(names)}
    C_cols = [a for a in sp.positions] + [n + a for a in sp.velocities]
    H = cert.get("H")
    require(isinstance(H, list) and len(H) == 2 * n and all(isinstance(r, list) and len(r) == len(C_cols) for r in H), "H is not 2N x |channels|")
    Hq = [[rational(x, "H") for x in r] for r in H]
    L = ctx.lap("normal")
    A = [[fmpq(0)] * (2 * n) for _ in range(2 * n)]
    for i in range(n):
        A[i][n + i] = fmpq(1)
        for j, x in L[i].items():
            A[n + i][j] = -sp.alpha * x
        A[n + i][n + i] = -sp.gamma
    F = [list(r) for r in A]
    for i in range(2 * n):
        for k, c in enumerate(C_cols):
            F[i][c] -= Hq[i][k]
    X = []
    for v in cert.get("basis", []):
        require(isinstance(v, dict), "a basis vector is not {state: value}")
        col = [fmpq(0)] * (2 * n)
        for s, x in v.items():
            require(s in at, f"unknown state {s!r}")
            col[at[s]] = rational(x, "basis")
        X.append(col)
    d = len(X)
    piv = [at.get(s, -1) for s in cert.get("pivots", [])]
    require(len(piv) == d and len(set(piv)) == d and all(k >= 0 for k in piv), "one pivot state per basis vector")
    if d:
        require(all(X[k][c] == 0 for k in range(d) for c in C_cols), "C X != 0")
        R = [[rational(x, "R") for x in r] for r in cert.get("R", [])]
        require(len(R) == d and all(len(r) == d for r in R), "R is not d x d")
        for k in range(d):
            AX = [sum((A[i][j] * X[k][j] for j in range(2 * n) if X[k][j] != 0), fmpq(0)) for i in range(2 * n)]
            XR = [sum((X[l][i] * R[l][k] for l in range(d)), fmpq(0)) for i in range(2 * n)]
            require(AX == XR, f"A_1 X != X R in column {k}")
        Xp = fmpq_mat(d, d, [X[k][i] for i in piv for k in range(d)])
        require(Xp.det() != 0, "X is singular on the pivots")
        W = Xp.inv()  # W = X[piv]^-1 (d x d)
        # Q F = F - X (X[piv]^-1 F[piv, :])
        Fp = fmpq_mat(d, 2 * n, [F[i][j] for i in piv for j in range(2 * n)])
        G = (W * Fp).tolist()  # d x 2N
        for i in range(2 * n):
            coeffs = [X[k][i] for k in range(d)]
            if any(coeffs):
                F[i] = [F[i][j] - sum((coeffs[k] * G[k][j] for k in range(d)), fmpq(0)) for j in range(2 * n)]
    keep = [i for i in range(2 * n) if i not in set(piv)]
    Fbar = [[F[i][j] for j in keep] for i in keep]
    if "lyapunov" in cert:
        return lyapunov(Fbar, cert["lyapunov"])
    top = hurwitz(Fbar, cert)
    require(top < 0, f"A_1 - H C is not shown stable on the observable part (max Re <= {top:.3g})")
