"""Local observers (Proposition III.2): ``local.pencil`` (iii) and ``local.uio``.

Cluster model (eq. cluster_dyn2) in cluster coordinates: L = L_q[P, P] (the principal block,
degrees counting cut edges), A = [[0, I], [-alpha L, -gamma I]], B = [0; S_sus^T],
E = [0; S_dP^T], C_loc = blkdiag(S_pos, S_vel).

``local.pencil`` asks that P(lam) = [[lam I - A, -B, E], [C_loc, 0, 0]] have full column rank
for every complex lam. With I = sus u dP (disjoint, else it fails at every lam), a kernel
vector is [x; lam x; u] with x = 0 on the measured positions, x = 0 on the measured
velocities when lam != 0, and (s I + alpha L) x = S_I^T u (signed), s = lam^2 + gamma lam;
if x = 0 then u = 0. Every s in C is lam^2 + gamma lam for some lam != 0. So it holds iff

    T_0 = alpha L[P \\ I, P \\ pos]                    has full column rank, and
    T(s) = (s I + alpha L)[P \\ I, U], U = P \\ (pos u vel),   has full column rank for all s.

Certificate ``pencil-minors``: a nonzero minor of T_0 modulo a prime, and square minors f_k(s)
of T(s) (row sets), computed modulo p by evaluation, whose gcd modulo p is 1, the first one
keeping its exact degree over Q modulo p (:func:`~glocal_check.algebra.pencil_minors`).
If the f_k had a common complex root, its minimal polynomial h would divide each of them, and
h mod p, of degree >= 1, would divide every f_k mod p, and so 1 = sum_k b_k f_k mod p (the
stated Bezout coefficients): so T(s) has full column rank everywhere.

Or, with ``zero_set``, T(s) loses column rank nowhere: the zero set of T(s) without factors
(:func:`~glocal_check.zeros.pencil_zero_set`).

Certificate ``pencil-kernel`` (fails): a kernel vector of P(lam) over Q[t]/(g), t = lam,
checked on the definition above, with an entry prime to g.

``local.uio`` (holds, certificate ``uio``): for each mode, K1 with F = (I - h C) A - K1 C
Hurwitz, h = E (C E)^T (C E has orthonormal columns when every boundary velocity is measured:
the rank condition). Then T = I - h C, K = K1 + F h give the unknown-input observer
z' = F z + T B u + K y, x^ = z + h y, whose error obeys e' = F e whatever the coupling (Chen,
Patton & Zhang 1996). Hurwitz: python-flint root enclosures of the exact characteristic
polynomial of F (stated modulo a prime in the certificate), or a Lyapunov matrix
(:func:`~glocal_check.algebra.lyapunov`) for large clusters.
"""

from __future__ import annotations

from typing import Any

from flint import fmpq, nmod_poly

from glocal_check.algebra import Field, det_mod, hurwitz, lyapunov, mod, pencil_minors, prime, require, unit
from glocal_check.context import Context, LocalScope
from glocal_check.zeros import pencil_zero_set
from glocal_check.spec import rational

__all__ = ["pencil", "uio"]


def _block(ctx: Context, ls: LocalScope, mode: str) -> list[dict[int, fmpq]]:
    """Rows of L_q[P, P] (global column indices, only columns in P)."""
    L = ctx.lap(mode)
    return [{j: x for j, x in L[a].items() if j in ls.members} for a in ls.cluster.nodes]


def pencil(ctx: Context, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    sp = ctx.spec
    ls = LocalScope(sp, scope)
    if status == "fails":
        return _pencil_kernel(ctx, ls, cert)
    require(cert.get("kind") == "pencil-minors", "local.pencil holds needs a pencil-minors certificate")
    sus, bnd = set(ls.suspected), set(ls.boundary)
    require(not sus & bnd, "an agent is both suspected and on the boundary")
    inputs = sus | bnd
    pos, vel = set(ls.observer.positions), set(ls.observer.velocities)
    P = ls.cluster.nodes
    rows_ok = [a for a in P if a not in inputs]
    U0 = [a for a in P if a not in pos]
    U = [a for a in P if a not in pos and a not in vel]
    block = dict(zip(P, _block(ctx, ls, "normal")))
    p = prime(cert.get("prime")) if U0 or U else 0
    al = mod(sp.alpha, p) if p else 0

    def rows_of(key: Any, size: int) -> list[int]:
        got = [sp.idx(a, "rows") for a in key]
        require(len(got) == size and len(set(got)) == size and all(a in rows_ok for a in got), "a minor's rows are not distinct rows of P \\ I of the right number")
        return got

    zero = cert.get("zero", {})
    if not U0 and not U:
        return  # every position and velocity is measured: nothing can hide
    R0 = rows_of(zero.get("rows", []), len(U0))
    d0 = det_mod([[al * mod(block[r].get(c, fmpq(0)), p) % p for c in U0] for r in R0], p)
    unit(d0, zero.get("det"), p, "the minor of T_0")
    if not U:
        return
    K = {a: {c: sp.alpha * x for c, x in row.items()} for a, row in block.items()}
    if "zero_set" in cert:  # T(s) loses column rank nowhere: a zero set without factors
        require(not pencil_zero_set(ctx, cert["zero_set"], rows_ok, U, K), "the zero set of T(s) is not empty")
        return
    polys = pencil_minors(K, rows_ok, U, ctx.minors(cert.get("minors")), p)
    # coprime modulo p: the stated Bezout coefficients give sum_k b_k f_k = 1
    bez = cert.get("bezout")
    require(isinstance(bez, list) and len(bez) == len(polys), "one Bezout coefficient per minor")
    total = nmod_poly([0], p)
    for b, f in zip(bez, polys):
        require(isinstance(b, list) and all(isinstance(c, int) and not isinstance(c, bool) for c in b), "a Bezout coefficient is not a list of residues")
        total += nmod_poly(b, p) * f
    require(total == 1, f"the Bezout identity of the minors fails modulo {p}")


def _pencil_kernel(ctx: Context, ls: LocalScope, cert: dict[str, Any]) -> None:
    sp = ctx.spec
    require(cert.get("kind") == "pencil-kernel", "local.pencil fails needs a pencil-kernel or structure certificate")
    K = Field(cert.get("field"))
    t = K.t
    x = K.vector(cert.get("x", {}), sp.idx, sp.n, "x")
    v = K.vector(cert.get("v", {}), sp.idx, sp.n, "v")
    ub = K.vector(cert.get("attack_input", {}), sp.idx, sp.n, "attack_input")
    ue = K.vector(cert.get("coupling_input", {}), sp.idx, sp.n, "coupling_input")
    P = set(ls.members)
    require(all(x[a] == 0 and v[a] == 0 for a in range(sp.n) if a not in P), "the vector leaves the cluster")
    require(all(ub[a] == 0 for a in range(sp.n) if a not in set(ls.suspected)), "an attack input on an agent not suspected")
    require(all(ue[a] == 0 for a in range(sp.n) if a not in set(ls.boundary)), "a coupling input on an agent not on the boundary")
    require(any(K.nonzero_everywhere(w[a]) for w in (x, v, ub, ue) for a in range(sp.n)), "the kernel vector may vanish")
    block = _block(ctx, ls, "normal")
    Lx = K.apply(block, x)
    for a, Lxa in zip(ls.cluster.nodes, Lx):
        require(K.is_zero(t * x[a] - v[a]), f"lam x != v at agent {sp.labels[a]}")
        row = sp.alpha * Lxa + (t + sp.gamma) * v[a] - ub[a] + ue[a]
        require(K.is_zero(row), f"the velocity row of agent {sp.labels[a]} does not vanish")
    require(all(K.is_zero(x[a]) for a in ls.observer.positions), "a measured position moves")
    require(all(K.is_zero(v[a]) for a in ls.observer.velocities), "a measured velocity moves")


def uio(ctx: Context, scope: dict[str, Any], cert: dict[str, Any]) -> None:
    sp = ctx.spec
    ls = LocalScope(sp, scope)
    require(all(b in set(ls.observer.velocities) for b in ls.boundary), "a boundary velocity is not measured: rank(C E) < rank(E)")
    n, channels = len(ls.cluster.nodes), len(ls.observer.positions) + len(ls.observer.velocities)
    modes = cert.get("modes", {})
    require(isinstance(modes, dict) and set(modes) == set(sp.modes), "the certificate must cover every mode")
    for m in sp.modes:
        K1 = modes[m].get("K1")
        require(isinstance(K1, list) and len(K1) == 2 * n and all(isinstance(r, list) and len(r) == channels for r in K1), f"K1 of mode {m} is not 2n x m")
        top = _stability(ctx, ls, _block(ctx, ls, m), modes[m])
        require(top < 0, f"F of mode {m} is not shown Hurwitz (max Re <= {top:.3g})")


def _observer_matrix(ctx: Context, ls: LocalScope, block: list[dict[int, fmpq]], K1: list[list[Any]]) -> list[list[fmpq]]:
    """F = (I - h C) A - K1 C for the cluster block ``block`` = L_q[P, P] of a mode (exact)."""
    sp = ctx.spec
    nodes = ls.cluster.nodes
    n = len(nodes)
    at = {a: k for k, a in enumerate(nodes)}
    # h C: the rows of the measured boundary velocities pass through (h = E (C E)^T)
    passthrough = {n + at[b] for b in ls.boundary}
    C_cols = [at[a] for a in ls.observer.positions] + [n + at[a] for a in ls.observer.velocities]
    A = [[fmpq(0)] * (2 * n) for _ in range(2 * n)]
    for i in range(n):
        A[i][n + i] = fmpq(1)
        for j, x in block[i].items():
            A[n + i][at[j]] = -sp.alpha * x
        A[n + i][n + i] = -sp.gamma
    F = [[(fmpq(0) if i in passthrough else A[i][j]) for j in range(2 * n)] for i in range(2 * n)]
    for i in range(2 * n):
        for k, c in enumerate(C_cols):
            F[i][c] -= rational(K1[i][k], "K1")
    return F


def _stability(ctx: Context, ls: LocalScope, block: list[dict[int, fmpq]], claim: dict[str, Any]) -> float:
    """The bound on max Re of the eigenvalues of F (:func:`_observer_matrix`) that ``claim``
    proves (its Lyapunov matrix, or its characteristic polynomial).

    F is a function of the cluster and observer, the mode's block and the claim's K1 (alpha
    and gamma are the spec's): a claim equal to one already checked (the certificate's JSON
    values, compared whole) for an equal block (exact rationals) of the same cluster and
    observer is the same proof, checked once (a mode whose block is the normal one, an
    observer serving two suspected sets)."""
    proven = ctx.memo.setdefault(("stability", ls.cluster.name, ls.observer.center), [])
    for seen_block, seen_claim, top in proven:
        if seen_block == block and seen_claim == claim:
            return top
    F = _observer_matrix(ctx, ls, block, claim["K1"])
    top = lyapunov(F, claim["lyapunov"]) or -1.0 if "lyapunov" in claim else hurwitz(F, claim)
    proven.append((block, claim, top))
    return top
