"""Certificates of the global verdicts: unobservable subspaces (privacy, observability), the
stealthy ZDA and the switch's touch (Proposition II.4 (ii), Remark III.3.1), the eigenstructure
of a safe mode (Theorem III.3 (ii), (iii)) and the central observer (eq. obs_cent).

Each function returns the certificate (a JSON-ready mapping, ``docs/certificates.md``) or
raises :class:`NoCertificate` saying why none is written.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Mapping

import numpy as np
from flint import fmpq, fmpq_poly, nmod_mat

from glocal_verify.certificates.encode import charpoly_claim, field, krylov_residue, laplacian_mod, lyapunov_claim, mod_residues, pivots_mod, q, state_matrix_exact, system_prime, unit, vector
from glocal_verify.certificates.facts import schedule_modes
from glocal_verify.certificates.kernels import eigenvector_in_field, fq, kernel_vectors, laplacian_rows
from glocal_verify.certificates.zero_sets import NoZeroSet, zda_zero_set
from glocal_verify import config
from glocal_verify.model import System
from glocal_verify.results import ConditionResult

__all__ = [
    "NoCertificate",
    "central_certificate",
    "differences_certificate",
    "distinct_certificate",
    "hidden_certificate",
    "no_zda_certificate",
    "observable_certificate",
    "touch_certificate",
    "zda_certificate",
]



class NoCertificate(Exception):
    """No certificate is written for this verdict; the message says why."""


def _delta_rows(system: System, mode: str) -> list[dict[int, fmpq]]:
    rows: list[dict[int, fmpq]] = [{} for _ in range(system.n)]
    for u, v, d in system.switching_links(mode):
        a, b, x = system.index[u], system.index[v], fq(d)
        for i, j in ((a, b), (b, a)):
            rows[i][j] = rows[i].get(j, fmpq(0)) - x
            rows[i][i] = rows[i].get(i, fmpq(0)) + x
    return rows


# -------------------------------------------------------------------------------------------
# unobservable subspaces


def hidden_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``invariant-subspace``: indicators of the components, common to the scope's modes,
    without a monitored position (W x {0} lies in every N(A_q, C) and is fixed by exp(A_q t))."""
    modes = schedule_modes(system, r.scope)
    parent = list(range(system.n))

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for m in modes:
        for key in system.edges(m):
            a, b = (system.index[x] for x in key)
            parent[find(a)] = find(b)
    px = {system.index[a] for a in system.monitored_positions}
    groups: dict[int, list[int]] = {}
    for i in range(system.n):
        groups.setdefault(find(i), []).append(i)
    blind = [g for g in groups.values() if not px & set(g)]
    if not blind:
        raise NoCertificate("every component has a monitored position: the hidden subspace lies in the nonzero eigenvalues (no certificate yet)")
    return {"kind": "invariant-subspace", "variant": "positions", "basis": [{str(system.labels[i]): "1" for i in g} for g in blind[:1]]}


def observable_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``observable``: N Krylov rows e_a^T L_q^k (a monitored) with a nonzero minor modulo p."""
    if system.n > config.get("certificate_dense_max_agents"):
        raise NoCertificate(f"more than {config.get('certificate_dense_max_agents')} agents")
    mode = schedule_modes(system, r.scope)[0]
    p = system_prime(system)
    L = laplacian_mod(system, mode, p)
    keys, rows = [], []
    for a in system.monitored:
        v = np.zeros(system.n, dtype=np.int64)
        v[system.index[a]] = 1
        for k in range(system.n):
            keys.append([str(a), k])
            rows.append([int(x) for x in v])
            v = (L.T @ v) % p
    R, _ = pivots_mod(rows, system.n, p)
    if len(R) < system.n:
        raise NoCertificate("the Krylov rows do not reach rank N modulo the prime")
    det = int(nmod_mat(system.n, system.n, [x for i in R for x in rows[i]], p).det())
    return {"kind": "observable", "mode": mode, "prime": p, "rows": [keys[i] for i in R], "det": unit(det, p)}


# -------------------------------------------------------------------------------------------
# zero-dynamics attacks


def _zda_rows(system: System, s: fmpq, lam0_zero: bool, extra: list[dict[int, fmpq]] | None = None) -> tuple[list[dict[int, fmpq]], list[int]]:
    """Rows of (s I + alpha L_1)[V \\ F, U] (and ``extra`` restricted to U), U the agents the
    output leaves free; columns renumbered over U. Returns (rows, U)."""
    F = {system.index[a] for a in system.attacked}
    out = set(system.monitored_positions) if lam0_zero else set(system.monitored)
    U = [i for i, lab in enumerate(system.labels) if lab not in out]
    col = {j: k for k, j in enumerate(U)}
    alpha = fq(system.alpha_q)
    rows = []
    L = laplacian_rows(system, "normal")
    for a in range(system.n):
        if a in F:
            continue
        r = {col[j]: alpha * x for j, x in L[a].items() if j in col}
        if a in col:
            r[col[a]] = r.get(col[a], fmpq(0)) + s
        rows.append(r)
    for e in extra or []:
        rows.append({col[j]: x for j, x in e.items() if j in col})
    return rows, U


def _zda_at(system: System, lam0: Fraction, dL: list[dict[int, fmpq]] | None = None) -> dict[str, Any] | None:
    """A ``zda`` certificate at the rational ``lam0`` (with dL xi = 0 when ``dL`` is given)."""
    lq = fq(lam0)
    s = lq * lq + fq(system.gamma_q) * lq
    extra = [e for e in dL if e] if dL else None
    rows, U = _zda_rows(system, s, lam0 == 0, extra)
    p = system_prime(system)
    L = laplacian_rows(system, "normal")
    alpha = fq(system.alpha_q)
    for z in kernel_vectors(rows, len(U), p, limit=8):
        xi = [fmpq(0)] * system.n
        for k, j in enumerate(U):
            xi[j] = z[k]
        u0 = {}
        for a in system.attacked:
            i = system.index[a]
            val = s * xi[i] + alpha * sum((x * xi[j] for j, x in L[i].items()), fmpq(0))
            if val != 0:
                u0[a] = val
        if u0:
            return {"kind": "zda", "field": field(fmpq_poly([-lq, 1])), "xi": vector(system, xi), "u0": vector(system, u0)}
    return None


def _rational(x: Any) -> Fraction | None:
    if isinstance(x, (list, tuple)) and len(x) == 2:
        if float(x[1]) != 0.0:
            return None
        x = x[0]
    try:
        return Fraction(float(x)) if not isinstance(x, (int, Fraction)) else Fraction(x)
    except (TypeError, ValueError):
        return None


def zda_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``zda``: an exact ZDA at a rational exponent: the spec's lambda0, the witness's, 0 or 1."""
    if system.n > 2000:
        raise NoCertificate("more than 2000 agents")
    cands: list[Fraction] = []
    spec_lam = system.spec.attack.lambda0 if system.spec.attack else None
    if spec_lam is not None and spec_lam.imag == 0:
        cands.append(Fraction(repr(spec_lam.real)))
    got = _rational((r.witness.get("direction") or {}).get("lambda0"))
    if got is not None:
        cands.append(got)
    cands += [Fraction(0), Fraction(1)]
    for lam0 in dict.fromkeys(cands):
        if system.n > config.get("certificate_dense_max_agents") and lam0 != 0:
            continue
        cert = _zda_at(system, lam0)
        if cert is not None:
            return cert
    try:
        _, factors = zda_zero_set(system)
    except NoZeroSet as exc:
        raise NoCertificate(f"no ZDA at a rational exponent (the spec's lambda0, the witness's, 0, 1), and no zero set: {exc}") from None
    for g, vecs in factors:
        for v in vecs:
            cert = _zda_in_field(system, g, v)
            if cert is not None:
                return cert
    raise NoCertificate("no ZDA at a rational exponent, and no zero of the certified zero set has an input direction")


def _zda_in_field(system: System, g: fmpq_poly, v: list[fmpq_poly]) -> dict[str, Any] | None:
    """A ``zda`` certificate over Q[t]/(G), G(t) = g(t^2 + gamma t), from a kernel vector v of
    T(s) over Q[s]/(g) (supported on U = V \\ M), when its input u = rows F of
    (s I + alpha L_1) v has an entry prime to g; else None."""
    U = [a for a in range(system.n) if system.labels[a] not in set(system.monitored)]
    xi = [fmpq_poly(0)] * system.n
    for a, x in zip(U, v):
        xi[a] = x
    L = laplacian_rows(system, "normal")
    alpha = fq(system.alpha_q)
    s = fmpq_poly([0, 1])
    u = {}
    for f in system.attacked:
        i = system.index[f]
        u[f] = (s * xi[i] + alpha * sum((x * xi[j] for j, x in L[i].items() if xi[j] != 0), fmpq_poly(0))) % g
    if not any(x != 0 and g.gcd(x).degree() == 0 for x in u.values()):
        return None
    sub = fmpq_poly([0, fq(system.gamma_q), 1])
    G = g(sub)
    G = G / G.leading_coefficient()
    return {
        "kind": "zda",
        "field": field(G),
        "xi": vector(system, [x(sub) % G for x in xi]),
        "u0": vector(system, {f: x(sub) % G for f, x in u.items()}),
    }


def touch_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``switching.avoids-attack`` at the spec's real lambda0: the ZDA (with dL_q xi = 0 when it
    holds), or the rank certificate that every stealthy direction is touched."""
    lam = system.spec.attack.lambda0 if system.spec.attack else None
    wl = _rational(r.witness.get("lambda0"))
    if system.n > config.get("certificate_dense_max_agents"):
        raise NoCertificate(f"more than {config.get('certificate_dense_max_agents')} agents")
    extra: dict[str, Any] = {}
    if lam is None and wl == 0:
        try:
            extra["zero_set"] = zda_zero_set(system)[0]  # 0 is the fastest-growing zero: every other decays
        except NoZeroSet as exc:
            raise NoCertificate(f"lambda0 = 0 is the fastest-growing zero of the computed zero set, whose certificate failed: {exc}") from None
    elif lam is None or lam.imag != 0 or wl is None or wl != Fraction(repr(lam.real)):
        raise NoCertificate("the verdict's lambda0 is neither the spec's real attack.lambda0 nor a computed 0")
    lam0 = wl if lam is None else Fraction(repr(lam.real))
    mode = r.scope["mode"]
    dL = _delta_rows(system, mode)
    if r.status.value == "holds":
        cert = _zda_at(system, lam0, dL)
        if cert is None:
            raise NoCertificate("no exact avoiding direction found")
        return {"kind": "zda-avoids", "zda": cert, **extra}
    zda = _zda_at(system, lam0)
    if zda is None:
        raise NoCertificate("no exact ZDA at the verdict's lambda0")
    return {"kind": "zda-touched", "zda": zda, **_touch_rank(system, lam0, dL), **extra}


def no_zda_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``no-zda`` (``stealthy.zda`` fails): the zero set of the pencil in s, every kernel
    vector input-free, and the rank certificate that every kernel vector at lambda = 0 has
    u0 = 0."""
    try:
        cert, factors = zda_zero_set(system)
    except NoZeroSet as exc:
        raise NoCertificate(f"no ZDA for any lambda0, but no zero set: {exc}") from None
    if any(_zda_in_field(system, g, v) is not None for g, vecs in factors for v in vecs):  # pragma: no cover - a verdict bug
        raise NoCertificate("a zero of the zero set has an input direction")
    return {"kind": "no-zda", "zero_set": cert, "zero": _touch_rank(system, Fraction(0), [{} for _ in range(system.n)])}


def _touch_rank(system: System, lam0: Fraction, dL: list[dict[int, fmpq]]) -> dict[str, Any]:
    """Rows/columns of a nonzero minor of G of size (N - k) + |F| modulo p, and k exact kernel
    vectors of its xi-columns (``switching.avoids-attack`` fails)."""
    n = system.n
    lq = fq(lam0)
    s = lq * lq + fq(system.gamma_q) * lq
    F = [system.index[a] for a in system.attacked]
    out = [system.index[a] for a in (system.monitored_positions if lam0 == 0 else system.monitored)]
    L = laplacian_rows(system, "normal")
    alpha = fq(system.alpha_q)
    names, rows = [], []
    for a in range(n):
        row = {j: alpha * x for j, x in L[a].items()}
        row[a] = row.get(a, fmpq(0)) + s
        for k, f in enumerate(F):
            if f == a:
                row[n + k] = fmpq(-1)
        names.append(f"L:{system.labels[a]}")
        rows.append(row)
        if dL[a]:
            names.append(f"dL:{system.labels[a]}")
            rows.append(dict(dL[a]))
    for a in out:
        names.append(f"out:{system.labels[a]}")
        rows.append({a: fmpq(1)})
    cols = [f"xi:{lab}" for lab in system.labels] + [f"u:{system.labels[f]}" for f in F]
    p = system_prime(system)
    res = [[0] * len(cols) for _ in rows]
    for i, row in enumerate(rows):
        for j, x in zip(row.keys(), mod_residues(row.values(), p)):
            res[i][j] = x
    R, C = pivots_mod(res, len(cols), p)
    xi_rows = [{j: x for j, x in row.items() if j < n} for row in rows]
    Z = kernel_vectors(xi_rows, n, p) if len(R) < n + len(F) else []
    if len(R) != (n - len(Z)) + len(F):
        raise NoCertificate("the rank of G modulo the prime does not separate u0 from the kernel")
    det = int(nmod_mat(len(R), len(C), [res[i][j] for i in R for j in C], p).det()) if R else 1
    out_cert: dict[str, Any] = {"prime": p, "rows": [names[i] for i in R], "cols": [cols[j] for j in C], "det": unit(det, p), "kernel": [vector(system, z) for z in Z]}
    if Z:
        zres = [mod_residues([z[a] for z in Z], p) for a in range(n)]
        ZR, _ = pivots_mod(zres, len(Z), p)
        out_cert["kernel_rows"] = [str(system.labels[a]) for a in ZR]
        out_cert["kernel_det"] = unit(int(nmod_mat(len(Z), len(Z), [zres[a][k] for a in ZR for k in range(len(Z))], p).det()), p)
    return out_cert


# -------------------------------------------------------------------------------------------
# eigenstructure of a safe mode


def distinct_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``krylov`` (holds) or ``eigenvectors`` (a rational repeated eigenvalue, fails)."""
    mode = r.scope["mode"]
    if r.status.value == "fails":
        w = r.witness
        mu, vs = w.get("eigenvalue_exact"), w.get("rational_eigenvectors") or []
        if mu is None or len(vs) < 2:
            raise NoCertificate("the repeated eigenvalue has no rational eigenvectors in the witness")
        v1, v2 = ({system.index[k]: Fraction(x) for k, x in v.items()} for v in vs[:2])
        pair = next(((a, b) for a in v1 for b in v1 if v1.get(a, 0) * v2.get(b, 0) != v1.get(b, 0) * v2.get(a, 0)), None)
        if pair is None:
            raise NoCertificate("the witness's eigenvectors are dependent")
        return {
            "kind": "eigenvectors",
            "field": field(fmpq_poly([-fq(Fraction(mu)), 1])),
            "mu": ["0", "1"],
            "vectors": [vector(system, {system.labels[i]: x for i, x in v.items()}) for v in (v1, v2)],
            "rows": [str(system.labels[pair[0]]), str(system.labels[pair[1]])],
        }
    p = system_prime(system)
    rng = np.random.default_rng(51)
    for _ in range(3):
        b = [int(x) for x in rng.integers(1, 1000, system.n)]
        det = krylov_residue(system, mode, b, system.n, p)
        if det:
            return {"kind": "krylov", "prime": p, "start": vector(system, b), "det": unit(det, p)}
    raise NoCertificate("three Krylov matrices were singular modulo the prime")


def differences_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``krylov-pairs`` (holds) or ``eigenvector`` (fails: an exact eigenvector with equal
    entries on the witness's pair, over Q[t]/(g) for the minimal polynomial g of its eigenvalue).

    The witness's rational eigenvector is used when it has one; otherwise a nonzero v over
    Q[t]/(g) with ``L_q v = t v`` and ``v(i) = v(j)`` is solved for
    (:func:`~glocal_verify.certificates.kernels.eigenvector_in_field`), g the minimal
    polynomial of the witness's exact eigenvalue (irreducible: every nonzero entry of v is
    prime to g)."""
    mode = r.scope["mode"]
    if r.status.value == "fails":
        w = r.witness
        mu, v = w.get("eigenvalue_exact"), w.get("eigenvector_exact")
        pair = [str(x) for x in w["pair"]]
        if isinstance(mu, (int, Fraction)) and v and mu != 0:
            return {
                "kind": "eigenvector",
                "field": field(fmpq_poly([-fq(Fraction(mu)), 1])),
                "mu": ["0", "1"],
                "vector": {str(k): q(Fraction(x)) for k, x in v.items() if x != 0},
                "pair": pair,
            }
        g = _minimal_polynomial(mu)
        if g is None or g.degree() < 1 or g(0) == 0:
            raise NoCertificate("the witness has no exact nonzero eigenvalue (an irrational repeated eigenvalue is not certified yet)")
        most = config.get("certificate_field_unknowns")
        if system.n * g.degree() > most:
            raise NoCertificate(f"the eigenvector over Q[t]/(g) has N deg g = {system.n * g.degree()} rational unknowns (at most {most} are solved)")
        i, j = (system.index[x] for x in w["pair"])
        u = eigenvector_in_field(laplacian_rows(system, mode), g, [{i: fmpq(1), j: fmpq(-1)}], system_prime(system))
        if u is None:
            raise NoCertificate("no exact eigenvector with equal entries on the pair over Q[t]/(g), g the eigenvalue's minimal polynomial")
        return {"kind": "eigenvector", "field": field(g), "mu": ["0", "1"], "vector": vector(system, u), "pair": pair}
    if len(system.components(mode)) != 1:
        raise NoCertificate("the safe mode's graph is disconnected")
    comps = system.switching_components(mode)
    pairs = [(a, b) for c in comps for i, a in enumerate(c) for b in c[i + 1 :]]
    if len(pairs) > 200:
        raise NoCertificate(f"{len(pairs)} pairs (at most 200 are certified)")
    for p in (system_prime(system), system_prime(system, 2**24)):
        got: list[list[Any]] = []
        for a, b in pairs:
            d = [0] * system.n
            d[system.index[a]], d[system.index[b]] = 1, p - 1
            got.append([str(a), str(b), krylov_residue(system, mode, d, system.n - 1, p, drop_last_column=True)])
        if all(x[2] for x in got):
            for x in got:
                x[2] = unit(x[2], p)
            return {"kind": "krylov-pairs", "prime": p, "pairs": got}
    raise NoCertificate("a Krylov minor vanished modulo two primes")


def _minimal_polynomial(mu: Any) -> fmpq_poly | None:
    """The minimal polynomial of an exact eigenvalue as a witness states it (a rational, or
    :func:`~glocal_verify.analysis.switching.eigenstructure.algebraic_root_witness`'s mapping
    with its integer ``coefficients``, lowest degree first), or None."""
    if isinstance(mu, (int, Fraction)):
        return fmpq_poly([-fq(Fraction(mu)), 1])
    coeffs = mu.get("coefficients") if isinstance(mu, Mapping) else None
    if not coeffs:
        return None
    g = fmpq_poly([int(c) for c in coeffs])
    return g / g.leading_coefficient()


# -------------------------------------------------------------------------------------------
# the central observer


def central_certificate(system: System, r: ConditionResult, options: Mapping[str, Any]) -> dict[str, Any]:
    """``central-injection`` or ``central-gain`` (H, the blind components' [1_c; 0], the pivots)."""
    design = (r.witness.get("design") or {}).get("method")
    if design == "injection":
        return {"kind": "central-injection"}
    from glocal_verify.observers.central import design_central_observer

    obsv = design_central_observer(system, poles=options.get("central_poles"))
    if obsv.method == "injection":
        return {"kind": "central-injection"}
    px = set(system.monitored_positions)
    blind = [c for c in system.components("normal") if not px & set(c)]
    basis = [{f"x:{a}": "1" for a in c} for c in blind]
    H = np.asarray(obsv.H)
    L = [[Fraction(0)] * system.n for _ in range(system.n)]
    for key, w in system.edges("normal").items():
        a, b = (system.index[x] for x in key)
        L[a][b] = L[b][a] = -w
        L[a][a] += w
        L[b][b] += w
    A = state_matrix_exact(L, system.alpha_q, system.gamma_q)
    cols = [system.index[a] for a in system.monitored_positions] + [system.n + system.index[a] for a in system.monitored_velocities]
    # F = A_1 - H C is 0 on each [1_c; 0] (R = 0): the quotient's polynomial is charpoly(F) / t^d
    states, most = 2 * system.n - len(blind), config.get("certificate_max_states")
    claim: dict[str, Any] = {}
    if states > most:  # the quotient by span X (F - X F[pivots, :] on the other states) and a Lyapunov matrix of it
        Ff = np.array([[float(x) for x in row] for row in A])
        Ff[:, cols] -= H
        piv = [system.index[c[0]] for c in blind]
        for comp, rep in zip(blind, piv):
            for lab in comp:
                if system.index[lab] != rep:
                    Ff[system.index[lab]] -= Ff[rep]
        keep = [i for i in range(2 * system.n) if i not in set(piv)]
        try:
            claim = lyapunov_claim(Ff[np.ix_(keep, keep)])
        except ValueError as exc:
            if states > 2 * most:
                raise NoCertificate(str(exc)) from None
    if not claim:
        claim = charpoly_claim(A, H, cols, system_prime(system), drop_zeros=len(blind))
    return {
        "kind": "central-gain",
        "H": [[q(float(x)) for x in row] for row in H],
        "basis": basis,
        "R": [["0"] * len(blind) for _ in blind],
        "pivots": [f"x:{c[0]}" for c in blind],
        **claim,
    }
