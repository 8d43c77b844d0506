"""Certificates of the local-observer verdicts (Proposition III.2): ``local.pencil`` (minors of
the reduced pencil modulo a prime, or an exact kernel vector) and ``local.uio`` (the gain K1
of each mode, whose error matrix the checker encloses)."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np
from flint import fmpq, fmpq_mat, fmpq_poly, nmod_mat, nmod_poly

from glocal_verify.certificates.encode import field, stability_claim, mod_residues, pivots_mod, q, state_matrix_exact, system_prime, unit, vector
from glocal_verify import config
from glocal_verify.certificates.global_certificates import NoCertificate
from glocal_verify.certificates.kernels import fq, kernel_vectors, laplacian_rows
from glocal_verify.certificates.zero_sets import NoZeroSet, Pencil, zero_set, zero_with_kernel
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.results import ConditionResult

__all__ = ["pencil_certificate", "uio_certificate"]

#: the ``uio`` certificate of one observer (cluster, centre), shared by its suspected sets
_UIO: Kind[dict[str, Any]] = Kind("certificate-uio", __name__, "the uio certificate of one observer")



class _Case:
    """The reduced pencil of one cluster scope: T_0 = alpha L[P \\ I, P \\ pos] and
    T(s) = (s I + alpha L)[P \\ I, U], U = P \\ (pos u vel)."""

    def __init__(self, system: System, r: ConditionResult) -> None:
        sc = r.scope
        self.system = system
        self.cm = cm = system.cluster_model(sc["cluster"], "normal")
        self.obs = next(o for o in system.observers(sc["cluster"]) if o.center == sc["observer"])
        F = set(system.attacked)
        self.suspected = [a for a in cm.nodes if sc["suspected"] == "all" or a in F]
        self.inputs = set(self.suspected) | set(cm.boundary)
        pos, vel = set(self.obs.positions), set(self.obs.velocities)
        self.rows = [a for a in cm.nodes if a not in self.inputs]
        self.U0 = [a for a in cm.nodes if a not in pos]
        self.U = [a for a in cm.nodes if a not in pos and a not in vel]
        members = set(cm.nodes)
        L = laplacian_rows(system, "normal")
        self.L = {a: {system.labels[j]: x for j, x in L[system.index[a]].items() if system.labels[j] in members} for a in cm.nodes}
        self.alpha = fq(system.alpha_q)

    def pencil(self) -> Pencil:
        """T(s) = (s I + alpha L[P, P])[P \\ I, U] by agent index."""
        idx = self.system.index
        K = {idx[a]: {idx[c]: self.alpha * x for c, x in row.items()} for a, row in self.L.items()}
        return Pencil([idx[a] for a in self.rows], [idx[a] for a in self.U], K)

    def residues(self, rows: list[Any], cols: list[Any], p: int) -> list[list[int]]:
        return [mod_residues([self.alpha * self.L[a].get(c, fmpq(0)) for c in cols], p) for a in rows]


def pencil_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``structure`` (suspected and boundary), ``pencil-kernel`` (fails) or ``pencil-minors``
    (the Bezout identity of a few minors, or an empty zero set of T(s))."""
    if r.witness.get("suspected_and_boundary"):
        return {"kind": "structure"}
    case = _Case(system, r)
    if r.status.value == "fails":
        return _pencil_fails(case, r)
    try:
        return _pencil_holds(case)
    except NoCertificate as exc:
        first = str(exc)
    cert = _pencil_zero(case)
    try:
        zs, factors = zero_set(system, case.pencil())
    except NoZeroSet as exc:
        raise NoCertificate(f"{first}; and no zero set of T(s): {exc}") from None
    if factors:  # pragma: no cover - a verdict bug
        raise NoCertificate("T(s) loses column rank at the roots of the zero set's factors")
    return {**cert, "zero_set": zs}


def _pencil_zero(case: "_Case") -> dict[str, Any]:
    """``pencil-minors`` with its T_0 part only: a nonzero minor of T_0 modulo the prime."""
    p = system_prime(case.system)
    R0, _ = pivots_mod(case.residues(case.rows, case.U0, p), len(case.U0), p)
    if len(R0) < len(case.U0):
        raise NoCertificate("T_0 has no full column rank modulo the prime")
    rows0 = [case.rows[i] for i in R0]
    det = int(nmod_mat(len(R0), len(R0), [x for rr in case.residues(rows0, case.U0, p) for x in rr], p).det()) if R0 else 1
    return {"kind": "pencil-minors", "prime": p, "zero": {"rows": [str(a) for a in rows0], "det": unit(det, p)}}


def _pencil_holds(case: _Case) -> dict[str, Any]:
    if not case.U0 and not case.U:
        return {"kind": "pencil-minors"}  # every position and velocity is measured
    cert = {**_pencil_zero(case), "minors": []}
    p = cert["prime"]
    if not case.U:
        return cert
    pencil, labels = case.pencil(), case.system.labels
    try:
        anchor = pencil.anchor(p)  # its degree modulo p is its exact degree (the checker proves it)
    except NoZeroSet as exc:
        raise NoCertificate(str(exc)) from None
    g = pencil.minor(anchor, p)
    cert["minors"].append({"rows": [str(labels[a]) for a in anchor], "degree": g.degree()})
    polys = [g]
    rng = np.random.default_rng(51)
    for _ in range(config.get("certificate_minor_tries")):
        if g.degree() == 0:
            break
        pick = sorted(pencil.rows[i] for i in rng.choice(len(pencil.rows), len(pencil.U), replace=False))
        f = pencil.minor(pick, p)
        if f == 0 or g.gcd(f).degree() == g.degree():
            continue
        g = g.gcd(f)
        polys.append(f)
        cert["minors"].append({"rows": [str(labels[a]) for a in pick], "degree": f.degree()})
    if g.degree() != 0:
        raise NoCertificate(f"the minors tried share a factor of degree {g.degree()} modulo the prime")
    cert["bezout"] = _bezout(polys, p)
    return cert


def _bezout(polys: list[nmod_poly], p: int) -> list[list[int]]:
    """b_k with sum_k b_k f_k = 1 modulo p (coprime f_k), by repeated extended gcds."""
    g, coeffs = polys[0], [nmod_poly([1], p)]
    for f in polys[1:]:
        d, a, b = g.xgcd(f)
        coeffs = [a * c for c in coeffs] + [b]
        g = d
    inv = pow(int(g.coeffs()[0]), -1, p)
    return [[int(x) * inv % p for x in c.coeffs()] for c in coeffs]


def _pencil_fails(case: _Case, r: ConditionResult) -> dict[str, Any]:
    """A kernel vector at lam = 0, or at the roots of lam^2 + gamma lam = s for a rational s
    (the witness's zeros rounded, 0, 1), or for the roots s of an irreducible factor of the
    pencil's zero polynomial (:func:`~glocal_verify.certificates.zero_sets.zero_with_kernel`)."""
    sys_ = case.system
    p = system_prime(sys_)
    gamma = fq(sys_.gamma_q)
    col0 = {a: k for k, a in enumerate(case.U0)}
    for z in kernel_vectors([{col0[c]: case.alpha * x for c, x in case.L[a].items() if c in col0} for a in case.rows], len(case.U0), p, limit=1):
        x = {a: z[col0[a]] for a in case.U0}
        return _kernel_cert(case, x, fmpq(0), fmpq_poly([0, 1]))
    ss: list[Fraction] = []
    for zero in (r.witness.get("zeros") or [])[:6]:
        lam = zero.get("lambda") if isinstance(zero, dict) else None
        if isinstance(lam, (list, tuple)):
            lam = complex(float(lam[0]), float(lam[1]))
        if lam is not None:
            sz = complex(lam) ** 2 + float(sys_.gamma_q) * complex(lam)
            if abs(sz.imag) < 1e-9 * max(1.0, abs(sz)):
                ss.append(Fraction(sz.real).limit_denominator(1000))
    for s in dict.fromkeys(ss + [Fraction(0), Fraction(1)]):
        sq = fq(s)
        colU = {a: k for k, a in enumerate(case.U)}
        rows = []
        for a in case.rows:
            rr = {colU[c]: case.alpha * x for c, x in case.L[a].items() if c in colU}
            if a in colU:
                rr[colU[a]] = rr.get(colU[a], fmpq(0)) + sq
            rows.append(rr)
        for z in kernel_vectors(rows, len(case.U), p, limit=1):
            x = {a: z[colU[a]] for a in case.U}
            return _kernel_cert(case, x, sq, fmpq_poly([-sq, gamma, 1]))
    try:
        g, vec = zero_with_kernel(sys_, case.pencil())
    except NoZeroSet as exc:
        raise NoCertificate(f"no exact kernel vector at lam = 0 or at a rational s = lam^2 + gamma lam, nor at a zero of T(s): {exc}") from None
    sub = fmpq_poly([0, gamma, 1])  # s = lam^2 + gamma lam
    G = g(sub)
    while G(0) == 0:  # lam = 0 is the pencil T_0, not T(s)
        G = G // fmpq_poly([0, 1])
    G = G / G.leading_coefficient()
    labels = sys_.labels
    xg: dict[Any, Any] = {labels[a]: v(sub) % G for a, v in zip(case.pencil().U, vec)}
    return _kernel_cert(case, xg, sub, G)


def _kernel_cert(case: _Case, x: dict[Any, Any], s: Any, g: fmpq_poly) -> dict[str, Any]:
    """The kernel vector [x; t x; u_b; u_e] over Q[t]/(g), u from the input rows (x and s
    rationals, or polynomials in t)."""
    ub: dict[Any, Any] = {}
    ue: dict[Any, Any] = {}
    for a in case.inputs:
        val = (s * x.get(a, fmpq(0)) + case.alpha * sum((w * x.get(c, fmpq(0)) for c, w in case.L[a].items()), fmpq(0))) % g
        (ub if a in set(case.suspected) else ue)[a] = val if a in set(case.suspected) else -val
    t = fmpq_poly([0, 1])
    return {
        "kind": "pencil-kernel",
        "field": field(g),
        "x": vector(case.system, x),
        "v": vector(case.system, {a: (t * v) % g for a, v in x.items()}),
        "attack_input": vector(case.system, ub),
        "coupling_input": vector(case.system, ue),
    }


def uio_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``uio``: per mode, K1 = (T A - F) C^T of the designed observer (binary floating-point
    numbers taken exactly), so that F = (I - h C) A - K1 C for the exact A."""
    if r.status.value == "fails":
        if r.witness.get("unmeasured_boundary") or r.witness.get("normal", {}).get("unmeasured_boundary"):
            return {"kind": "structure"}
        raise NoCertificate("an unstable unobservable mode has no certificate yet")
    # the observer's design does not depend on the suspected set: one certificate per observer
    return _UIO.get(system, (r.scope["cluster"], r.scope["observer"]), lambda: _uio_modes(system, r.scope["cluster"], r.scope["observer"]))


def _uio_modes(system: System, cluster: str, observer: Any) -> dict[str, Any]:
    from glocal_verify.observers.uio import local_uio

    cm = system.cluster_model(cluster, "normal")
    obs = next(o for o in system.observers(cluster) if o.center == observer)
    modes = {}
    p = system_prime(system)
    n = len(cm.nodes)
    for m in system.modes:
        d = local_uio(system, obs, mode=m, method="auto")
        K1 = (d.T @ d.A - d.F) @ d.C.T
        A = state_matrix_exact(system.cluster_laplacian_exact(cm.name, m), system.alpha_q, system.gamma_q)
        at = {a: k for k, a in enumerate(cm.nodes)}
        cols = [at[a] for a in obs.positions] + [n + at[a] for a in obs.velocities]
        claim = stability_claim(A, K1, cols, p, zero_rows=[n + at[b] for b in cm.boundary])
        modes[m] = {"K1": [[q(float(x)) for x in row] for row in K1], **claim}
    return {"kind": "uio", "modes": modes}

