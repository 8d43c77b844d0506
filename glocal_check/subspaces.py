"""Unobservable subspaces: ``switched-observability``, ``privacy.initial-state`` and
``privacy.consensus-value`` (Lemma II.3, Problem 1 (i)).

N(A_q, C) = {0} or not, and whether f = [1/N 1; 0] is orthogonal to it:

* ``invariant-subspace`` (something is hidden): rational vectors W with either
  L_q W = 0 and S_Mx W = 0 (then W x {0} is A_q-invariant inside ker C), or L_q W = W R_q
  and S_M W = 0 (then W x W is), for every mode of the scope. A subspace invariant under
  every A_k of a schedule and inside ker C is fixed by every exp(A_k tau), so it lies in the
  switched unobservable subspace N_1^m for every dwell time.
* ``observable`` (nothing is hidden): by the modal structure,
  N(A_q, C) = (W^x_0 x W_0) + sum_{mu > 0} (W_mu x W_mu), which is {0} iff
  ker L_q meets ker S_Mx only in 0 (every component of G_q has a monitored position) and the
  pair (L_q, S_M) is observable; the latter is an N x N minor of the Krylov rows
  e_a^T L_q^k, a in M, nonzero modulo a prime. N_1^m lies in N(A_first, C), so an observable
  first mode makes the schedule observable.
"""

from __future__ import annotations

from typing import Any

from flint import fmpq, nmod_mat

from glocal_check.algebra import Rejected, matvec, prime, require, unit
from glocal_check.context import Context
from glocal_check.spec import rational

__all__ = ["hidden", "observable"]


def hidden(ctx: Context, scope: dict[str, Any], cert: dict[str, Any], *, consensus: bool = False) -> None:
    """Check an ``invariant-subspace`` certificate: a nonzero subspace of N (and, with
    ``consensus``, one that f is not orthogonal to)."""
    sp = ctx.spec
    basis = [sp.vector(w, "basis") for w in cert.get("basis", [])]
    require(bool(basis) and any(any(x != 0 for x in w) for w in basis), "the basis is empty or zero")
    variant = cert.get("variant")
    for m in ctx.scope_modes(scope):
        L = ctx.lap(m)
        images = [matvec(L, w, fmpq(0)) for w in basis]
        if variant == "positions":
            require(all(x == 0 for y in images for x in y), f"L_{m} w != 0 for a basis vector")
            out = sp.positions
        elif variant == "pairs":
            R = cert.get("R", {}).get(m)
            require(isinstance(R, list) and len(R) == len(basis), f"R for mode {m} missing or of the wrong size")
            Rq = [[rational(x, "R") for x in row] for row in R]
            require(all(len(r) == len(basis) for r in Rq), f"R for mode {m} is not square")
            d = len(basis)
            for k in range(d):  # column k of L W equals W times column k of R
                want = [sum((basis[i][a] * Rq[i][k] for i in range(d)), fmpq(0)) for a in range(sp.n)]
                require(images[k] == want, f"L_{m} W != W R in column {k}")
            out = sp.monitored
        else:
            raise Rejected(f"unknown variant {variant!r}")
        require(all(w[a] == 0 for w in basis for a in out), "a basis vector is nonzero on a monitored agent")
    if consensus:
        require(any(sum(w, fmpq(0)) != 0 for w in basis), "f = [1/N 1; 0] is orthogonal to every basis vector")


def observable(ctx: Context, scope: dict[str, Any], cert: dict[str, Any]) -> None:
    """Check an ``observable`` certificate for the scope's (first) mode."""
    sp = ctx.spec
    m = ctx.first_mode(scope)
    px = set(sp.positions)
    require(all(px & set(c) for c in sp.components(m)), f"a component of G_{m} has no monitored position: [1_c; 0] is unobservable")
    p = prime(cert.get("prime"))
    rows = cert.get("rows")
    require(isinstance(rows, list) and len(rows) == sp.n, f"expected {sp.n} Krylov rows")
    mon = sp.monitored
    want: dict[int, set[int]] = {}
    for r in rows:
        require(isinstance(r, list) and len(r) == 2 and isinstance(r[1], int) and 0 <= r[1] < sp.n, f"bad Krylov row {r!r}")
        a = sp.idx(r[0], "rows")
        require(a in mon, f"agent {r[0]} is not monitored")
        want.setdefault(a, set()).add(r[1])
    require(sum(len(v) for v in want.values()) == sp.n, "a Krylov row is repeated")
    Lp = ctx.lap_mod(m, p)
    order = sorted(want)
    S = nmod_mat(len(order), sp.n, [1 if j == a else 0 for a in order for j in range(sp.n)], p)
    top = max(max(v) for v in want.values())
    picked: dict[tuple[int, int], list[int]] = {}
    P = S
    for k in range(top + 1):
        block = P.tolist()
        for i, a in enumerate(order):
            if k in want[a]:
                picked[(a, k)] = [int(x) for x in block[i]]
        if k < top:
            P = P * Lp
    M = [picked[(sp.idx(r[0]), r[1])] for r in rows]
    d = int(nmod_mat(sp.n, sp.n, [x for row in M for x in row], p).det())
    unit(d, cert.get("det"), p, "the Krylov minor")
