"""Zero-dynamics attacks: ``stealthy.zda`` (Proposition II.4 (ii), Definition II.2) and
``switching.avoids-attack`` (Remark III.3.1).

A ZDA at lam0 is [x~0; u0] with u0 != 0 in the kernel of the Rosenbrock pencil
[[lam0 I - A_1, -B], [C, 0]]. With x~0 = [xi; lam0 xi] and s = lam0^2 + gamma lam0 the first
block row vanishes identically and the rest reads

    (s I + alpha L_1) xi = S_F^T u0,   S_Mx xi = 0,   lam0 S_Mv xi = 0.

Certificate ``zda``: lam0 is the variable t of Q[t]/(g) (``g = t - lam0`` for a rational
lam0), xi and u0 have entries in Q[t]/(g); the equations are checked modulo g, so they hold
at every root of g, and u0 has an entry prime to g, so u0 != 0 at every root. The velocity
equation is dropped only when g = t (lam0 = 0).
"""

from __future__ import annotations

from typing import Any

from flint import fmpq, fmpq_poly

from glocal_check.algebra import Field, hurwitz_poly, minor_of, prime, require, unit
from glocal_check.context import Context
from glocal_check.zeros import pencil_zero_set

__all__ = ["avoids_attack", "fastest_is_zero", "input_free", "no_zda", "zda_exists", "zero_set"]


def zda_exists(ctx: Context, cert: dict[str, Any]) -> tuple[Field, list[fmpq_poly]]:
    """Check a ``zda`` certificate; return its field and xi."""
    sp = ctx.spec
    require(sp.attack is not None, "no [attack] in the spec")
    K = Field(cert.get("field"), "field")
    xi = K.vector(cert.get("xi"), sp.idx, sp.n, "xi")
    u0 = K.vector(cert.get("u0"), sp.idx, sp.n, "u0")
    F = set(sp.attack["actuators"])
    require(all(u0[a] == 0 for a in range(sp.n) if a not in F), "u0 acts on an agent outside F")
    require(any(K.nonzero_everywhere(u0[a]) for a in F), "u0 may vanish at a root of g (no entry prime to g)")
    t = K.t
    s = K.reduce(t * t + sp.gamma * t)
    Lxi = K.apply(ctx.lap("normal"), xi)
    for a in range(sp.n):
        require(K.is_zero(s * xi[a] + sp.alpha * Lxi[a] - u0[a]), f"(s I + alpha L_1) xi != S_F^T u0 at agent {sp.labels[a]}")
    out = list(sp.positions)
    if K.g != fmpq_poly([0, 1]):
        out += list(sp.velocities)
    require(all(K.is_zero(xi[a]) for a in out), "xi is nonzero on a monitored agent (C x~0 != 0)")
    return K, xi


def _spec_lambda0(ctx: Context) -> fmpq_poly:
    """The monic minimal polynomial of the spec's lambda0 over Q."""
    lam = ctx.spec.attack["lambda0"] if ctx.spec.attack else None
    require(lam is not None, "the spec gives no attack.lambda0")
    re, im = lam
    if im == 0:
        return fmpq_poly([-re, 1])
    return fmpq_poly([re * re + im * im, -2 * re, 1])


def avoids_attack(ctx: Context, scope: dict[str, Any], status: str, cert: dict[str, Any]) -> None:
    """Remark III.3.1 at the rule's exponent lambda0: the spec's lambda0 (the rule's exponent
    whenever a ZDA exists there, which the certificate's ZDA shows), or, with a ``zero_set``
    and no spec lambda0, lambda0 = 0 once every other zero is shown to decay (so 0 is the
    fastest-growing zero, :func:`fastest_is_zero`).

    ``holds``: the ZDA has dL_q xi = 0 (the switch leaves it untouched).
    ``fails`` (real lambda0 only): every stealthy direction at lambda0 is touched, i.e. the
    kernel of G = [[s I + alpha L_1, -S_F^T], [S_out, 0], [dL_q, 0]] has u0 = 0
    (:func:`input_free`).
    """
    sp = ctx.spec
    m = ctx.mode(scope.get("mode"))
    K, xi = zda_exists(ctx, cert.get("zda", {}))
    if "zero_set" in cert:
        require(sp.attack["lambda0"] is None, "the spec gives lambda0: the rule's exponent is the spec's")
        require(K.g == fmpq_poly([0, 1]), "a zero set certifies lambda0 = 0 only")
        fastest_is_zero(ctx, zero_set(ctx, cert["zero_set"]))
    else:
        require(K.g == _spec_lambda0(ctx), "the ZDA is not at the spec's lambda0")
    dL = sp.delta_laplacian(m)
    if status == "holds":
        moved = K.apply(dL, xi)
        require(all(K.is_zero(x) for x in moved), "dL_q xi != 0: the switch touches this direction")
        return
    lam0 = K.root_if_rational()
    require(lam0 is not None, "a touch certificate needs a real lambda0")
    input_free(ctx, lam0, dL, cert)


def input_free(ctx: Context, lam0: fmpq, extra: list[dict[int, fmpq]], cert: dict[str, Any]) -> None:
    """Every kernel vector [xi; u0] of G = [[s I + alpha L_1, -S_F^T], [S_out, 0], [extra, 0]]
    (s = lam0^2 + gamma lam0, S_out = S_Mx if lam0 = 0 else S_M) has u0 = 0.

    Certified by rank(G) >= r (an r x r minor nonzero modulo a prime) and dim ker G_xi >= k
    (k exact kernel vectors of the xi-columns, independent by a k x k minor modulo the prime)
    with r = (N - k) + |F|: then rank G = rank G_xi + |F|, so G [xi; u0] = 0 forces u0 = 0.
    """
    sp = ctx.spec
    s = lam0 * lam0 + sp.gamma * lam0
    n = sp.n
    F = list(sp.attack["actuators"])
    out = list(sp.positions) if lam0 == 0 else sp.monitored
    L = ctx.lap("normal")
    cols = {f"xi:{sp.labels[j]}": j for j in range(n)}
    cols.update({f"u:{sp.labels[f]}": n + k for k, f in enumerate(F)})
    rows: dict[str, dict[int, fmpq]] = {}
    for a in range(n):
        r = {j: sp.alpha * x for j, x in L[a].items()}
        r[a] = r.get(a, fmpq(0)) + s
        for k, f in enumerate(F):
            if f == a:
                r[n + k] = fmpq(-1)
        rows[f"L:{sp.labels[a]}"] = r
        if extra[a]:
            rows[f"dL:{sp.labels[a]}"] = dict(extra[a])
    for a in out:
        rows[f"out:{sp.labels[a]}"] = {a: fmpq(1)}
    p = prime(cert.get("prime"))
    rk, ck = cert.get("rows", []), cert.get("cols", [])
    require(all(isinstance(x, str) and x in rows for x in rk), "a minor row is not a row of G")
    require(all(isinstance(x, str) and x in cols for x in ck), "a minor column is not a column of G")
    sub = [[rows[r].get(cols[c], fmpq(0)) for c in ck] for r in rk]
    d = minor_of(sub, list(range(len(rk))), list(range(len(ck))), p) if rk else 1
    unit(d, cert.get("det"), p, "the minor of G")
    Z = [sp.vector(z, "kernel") for z in cert.get("kernel", [])]
    for z in Z:
        for key, r in rows.items():
            require(sum((x * z[j] for j, x in r.items() if j < n), fmpq(0)) == 0, f"a kernel vector is not in ker G_xi (row {key})")
    if Z:
        zr = [sp.idx(a, "kernel_rows") for a in cert.get("kernel_rows", [])]
        require(len(zr) == len(Z), "kernel_rows must pick one row per kernel vector")
        kd = minor_of([[z[a] for z in Z] for a in range(n)], zr, list(range(len(Z))), p)
        unit(kd, cert.get("kernel_det"), p, "the minor of the kernel vectors")
    require(len(rk) == (n - len(Z)) + len(F), f"rank {len(rk)} of G does not reach (N - {len(Z)}) + |F|")



def zero_set(ctx: Context, cert: Any) -> list[tuple[Field, list[list[fmpq_poly]]]]:
    """Check a ``zero-set`` certificate of the ZDA pencil in s = lambda^2 + gamma lambda and
    return its factors (:func:`pencil_zero_set` of T(s) below).

    For lambda != 0 the Rosenbrock pencil loses column rank exactly where
    T(s) = (s I + alpha L_1)[V \\ F, U], U = V \\ M, does (xi = 0 on M, u = rows F of
    (s I + alpha L_1) xi). Let z be the gcd over Q of its maximal minors: by the Smith form,
    dim ker T(r) <= ord_r z at every r, and T(s) has full column rank off the roots of z.
    Checked: (i) the first minor f_1 keeps its exact degree modulo p and the stated
    combinations are multiples of z modulo p (:func:`~glocal_check.algebra.pencil_minors`,
    :func:`~glocal_check.algebra.combination_det`), so deg z <= D = deg gcd (mod p); (ii) for
    each stated g_i (squarefree, pairwise coprime) k_i vectors over Q[s]/(g_i), supported on
    U, with T(s) xi = 0 modulo g_i and a k_i x k_i minor prime to g_i, so ord_r z >= k_i at
    every root r of g_i; (iii) sum_i k_i deg g_i = D. Hence z = prod g_i^k_i: T(s) loses rank
    exactly at the roots of the g_i, and there its kernel is spanned by the k_i vectors.
    """
    sp = ctx.spec
    require(sp.attack is not None, "a zero set of the ZDA pencil needs an [attack]")
    F = set(sp.attack["actuators"])
    rows = [a for a in range(sp.n) if a not in F]
    U = [a for a in range(sp.n) if a not in set(sp.monitored)]
    Kr = {a: {j: sp.alpha * x for j, x in row.items()} for a, row in enumerate(ctx.lap("normal"))}
    return pencil_zero_set(ctx, cert, rows, U, Kr)


def input_rows(ctx: Context, K: Field, v: list[fmpq_poly]) -> list[fmpq_poly]:
    """u = rows F of (s I + alpha L_1) xi over Q[s]/(g)."""
    sp = ctx.spec
    L = ctx.lap("normal")
    return [K.reduce(K.t * v[f] + sp.alpha * sum((x * v[j] for j, x in L[f].items() if v[j] != 0), fmpq_poly(0))) for f in sp.attack["actuators"]]


def fastest_is_zero(ctx: Context, factors: list[tuple[Field, list[list[fmpq_poly]]]]) -> None:
    """Every zero lambda != 0 of (A_1, B, C) has Re lambda < 0: for every factor g of the zero
    set, the roots of g(lambda^2 + gamma lambda) other than lambda = 0 (which is no zero of
    T: it is the pencil of lambda = 0) lie in the open left half-plane (ball enclosures)."""
    gam = fmpq_poly([0, ctx.spec.gamma, 1])
    for K, _ in factors:
        h = K.g(gam)
        while h.degree() > 0 and h(0) == 0:
            h = h // fmpq_poly([0, 1])
        if h.degree() > 0:
            require(hurwitz_poly(h) < 0, f"a zero lambda != 0 at a root of {K.g}(lambda^2 + gamma lambda) is not shown to decay")


def no_zda(ctx: Context, scope: dict[str, Any], cert: dict[str, Any]) -> None:
    """``stealthy.zda`` fails: left-invertible and no zero with an input direction.

    lambda != 0: the zero set (whose first minor is nonzero: T(s), hence the 2N pencil, has
    full normal column rank) has u = 0 for every kernel vector, which spans the kernel at each
    root; lambda = 0: ``zero`` certifies that every kernel vector of the pencil at 0 has u0 = 0
    (:func:`input_free`).
    """
    require(not scope and cert.get("kind") == "no-zda", "stealthy.zda fails needs a no-zda certificate (global scope)")
    for K, vecs in zero_set(ctx, cert.get("zero_set")):
        require(all(K.is_zero(u) for v in vecs for u in input_rows(ctx, K, v)), f"a zero at a root of {K.g} has an input direction")
    input_free(ctx, fmpq(0), [{} for _ in range(ctx.spec.n)], cert.get("zero", {}))
