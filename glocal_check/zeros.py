"""Zero sets of pencils in s: where T(s) = (s I + K)[rows, U] loses column rank, and its kernel
there (certificate ``zero-set``). The ZDA pencil of ``stealthy.zda`` / ``switching.avoids-attack``
(:func:`glocal_check.zda.zero_set` states the argument) and the local pencil of ``local.pencil``
are of this form.
"""

from __future__ import annotations

from typing import Any

from flint import fmpq, fmpq_poly

from glocal_check.algebra import Field, combination_det, pencil_minors, poly_det, prime, require
from glocal_check.context import Context

__all__ = ["pencil_zero_set"]


def pencil_zero_set(ctx: Context, cert: Any, rows: list[int], U: list[int], Kr: dict[int, dict[int, fmpq]]) -> list[tuple[Field, list[list[fmpq_poly]]]]:
    """Check the ``zero-set`` certificate of T(s) = (s I + K)[rows, U] (:func:`glocal_check.zda.zero_set`
    gives the argument) and return its factors (Q[s]/(g_i), kernel vectors supported on U)."""
    sp = ctx.spec
    require(isinstance(cert, dict), "a zero set is a mapping")
    p = prime(cert.get("prime"))
    polys = pencil_minors(Kr, rows, U, ctx.minors(cert.get("minors")), p)
    for c in cert.get("combinations", []):
        polys.append(combination_det(Kr, rows, U, [sp.idx(a, "extra") for a in c.get("extra", [])], c.get("Y"), p))
        require([int(x) for x in polys[-1].coeffs()] == c.get("det"), f"a combination's determinant is not the one stated (modulo {p})")
    g = polys[0]
    for f in polys[1:]:
        g = g.gcd(f)
    out: list[tuple[Field, list[list[fmpq_poly]]]] = []
    count = 0
    Us = set(U)
    for k, fac in enumerate(cert.get("factors", [])):
        K = Field(fac.get("field"), f"factor {k}")
        require(K.g.gcd(K.g.derivative()).degree() == 0, f"factor {k} is not squarefree")
        require(all(K.g.gcd(other.g).degree() == 0 for other, _ in out), f"factor {k} shares a root with another factor")
        vecs = [K.vector(v, sp.idx, sp.n, "kernel") for v in fac.get("kernel", [])]
        require(bool(vecs), f"factor {k} has no kernel vector")
        for v in vecs:
            require(all(v[a] == 0 for a in range(sp.n) if a not in Us), "a kernel vector is nonzero on a monitored agent")
            Tv = K.apply([Kr[a] for a in rows], v)
            require(all(K.is_zero(K.t * v[a] + x) for a, x in zip(rows, Tv)), f"T(s) xi != 0 modulo factor {k}")
        at = [sp.idx(a, "rows") for a in fac.get("rows", [])]
        require(len(at) == len(vecs), "one row per kernel vector")
        require(K.nonzero_everywhere(poly_det([[v[a] for v in vecs] for a in at])), f"the kernel vectors of factor {k} are not shown independent")
        out.append((K, vecs))
        count += K.g.degree() * len(vecs)
    require(count == g.degree(), f"the factors account for {count} zeros, the minors' gcd modulo {p} for {g.degree()}")
    return out
