"""Certificates of the local-observer verdicts (Proposition III.2): ``local.pencil`` (minors of
the reduced pencil modulo a prime, or an exact kernel vector) and ``local.uio`` (the gain K1
of each mode, whose error matrix the checker encloses)."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import numpy as np
from flint import fmpq, fmpq_mat, fmpq_poly, nmod_mat, nmod_poly

from glocal_verify.certificates.encode import charpoly_claim, field, mod_residues, pivots_mod, q, state_matrix_exact, system_prime, unit, vector
from glocal_verify import config
from glocal_verify.certificates.global_certificates import NoCertificate
from glocal_verify.certificates.kernels import fq, kernel_vectors, laplacian_rows
from glocal_verify.model import System
from glocal_verify.results import ConditionResult

__all__ = ["pencil_certificate", "uio_certificate"]



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

    def residues(self, rows: list[Any], cols: list[Any], p: int) -> list[list[int]]:
        return [mod_residues([self.alpha * self.L[a].get(c, fmpq(0)) for c in cols], p) for a in rows]

    def minor_poly(self, rows: list[Any], p: int) -> nmod_poly:
        """det T(s)[rows, U] modulo p (evaluation at 0..d, Lagrange's formula)."""
        K = self.residues(rows, self.U, p)
        diag = [(i, self.U.index(a)) for i, a in enumerate(rows) if a in set(self.U)]
        d, k = len(diag), len(self.U)
        acc = nmod_poly([0], p)
        pts = list(range(d + 1))
        for x in pts:
            M = [list(r) for r in K]
            for i, j in diag:
                M[i][j] = (M[i][j] + x) % p
            y = int(nmod_mat(k, k, [v for r in M for v in r], p).det())
            basis = nmod_poly([1], p)
            for z in pts:
                if z != x:
                    basis = basis * nmod_poly([-z % p, 1], p) * pow(x - z, -1, p)
            acc = acc + basis * y
        return acc


def pencil_certificate(system: System, r: ConditionResult) -> dict[str, Any]:
    """``structure`` (suspected and boundary), ``pencil-kernel`` (fails) or ``pencil-minors``."""
    if r.witness.get("suspected_and_boundary"):
        return {"kind": "structure"}
    case = _Case(system, r)
    return _pencil_holds(case) if r.status.value == "holds" else _pencil_fails(case, r)


def _pencil_holds(case: _Case) -> dict[str, Any]:
    if not case.U0 and not case.U:
        return {"kind": "pencil-minors"}  # every position and velocity is measured
    p = system_prime(case.system)
    R0, _ = pivots_mod(case.residues(case.rows, case.U0, p), len(case.U0), p)
    if len(R0) < len(case.U0):
        raise NoCertificate("T_0 has no full column rank modulo the prime")
    rows0 = [case.rows[i] for i in R0]
    zero = {"rows": [str(a) for a in rows0], "det": unit(int(nmod_mat(len(R0), len(R0), [x for rr in case.residues(rows0, case.U0, p) for x in rr], p).det()) if R0 else 1, p)}
    cert: dict[str, Any] = {"kind": "pencil-minors", "prime": p, "zero": zero, "minors": []}
    if not case.U:
        return cert
    inner = [a for a in case.U if a not in case.inputs]
    hit = [a for a in case.U if a in case.inputs]
    others = [a for a in case.rows if a not in set(case.U)]
    Ra, _ = pivots_mod(case.residues(others, hit, p), len(hit), p)
    rng = np.random.default_rng(51)
    if len(Ra) == len(hit):
        anchor = inner + [others[i] for i in Ra]
        g = case.minor_poly(anchor, p)
        cert["minors"].append({"rows": [str(a) for a in anchor], "degree": g.degree()})
    else:
        # no minor reaches its degree bound: an anchor whose exact degree survives modulo p
        anchor, g = _exact_anchor(case, p, rng)
        cert["minors"].append({"rows": [str(a) for a in anchor], "degree": g.degree(), "exact": True})
    polys = [g]
    for _ in range(config.get("certificate_minor_tries")):
        if g.degree() == 0:
            break
        pick = [case.rows[i] for i in sorted(rng.choice(len(case.rows), len(case.U), replace=False))]
        f = case.minor_poly(pick, p)
        if f == 0 or g.gcd(f).degree() == g.degree():
            continue
        g = g.gcd(f)
        polys.append(f)
        cert["minors"].append({"rows": [str(a) for a in pick], "degree": f.degree()})
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


def _exact_anchor(case: _Case, p: int, rng: np.random.Generator) -> tuple[list[Any], nmod_poly]:
    """Rows of T(s) whose minor, computed over Q, keeps its degree modulo p."""
    most = config.get("certificate_exact_anchor_max")
    if len(case.U) > most:
        raise NoCertificate(f"no minor of T(s) reaches its degree bound and U has more than {most} agents")
    for _ in range(config.get("certificate_minor_tries")):
        rows = [case.rows[i] for i in sorted(rng.choice(len(case.rows), len(case.U), replace=False))]
        diag = {i: case.U.index(a) for i, a in enumerate(rows) if a in set(case.U)}
        values = []
        for x in range(len(diag) + 1):
            M = fmpq_mat(len(rows), len(case.U))
            for i, a in enumerate(rows):
                for j, c in enumerate(case.U):
                    M[i, j] = case.alpha * case.L[a].get(c, fmpq(0)) + (x if diag.get(i) == j else 0)
            values.append(M.det())
        f = fmpq_poly(0)
        for x, y in enumerate(values):  # Lagrange's formula over the points 0..d
            term = fmpq_poly([y])
            for z in range(len(values)):
                if z != x:
                    term = term * fmpq_poly([fmpq(-z, x - z), fmpq(1, x - z)])
            f += term
        if f == 0:
            continue
        g = nmod_poly(mod_residues(f.coeffs(), p), p)
        if g.degree() == f.degree():
            return rows, g
    raise NoCertificate("no minor of T(s) found whose exact degree survives modulo the prime")


def _pencil_fails(case: _Case, r: ConditionResult) -> dict[str, Any]:
    """A kernel vector at lam = 0, or at the roots of lam^2 + gamma lam = s for a rational s
    (the witness's zeros rounded, 0, 1)."""
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
    raise NoCertificate("no exact kernel vector at lam = 0 or at a rational s = lam^2 + gamma lam")


def _kernel_cert(case: _Case, x: dict[Any, fmpq], s: fmpq, g: fmpq_poly) -> dict[str, Any]:
    """The kernel vector [x; t x; u_b; u_e] over Q[t]/(g), u from the input rows."""
    ub: dict[Any, fmpq] = {}
    ue: dict[Any, fmpq] = {}
    for a in case.inputs:
        val = s * x.get(a, fmpq(0)) + case.alpha * sum((w * x.get(c, fmpq(0)) for c, w in case.L[a].items()), fmpq(0))
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
    cm = system.cluster_model(r.scope["cluster"], "normal")
    if 2 * len(cm.nodes) > config.get("certificate_max_states"):
        raise NoCertificate(f"more than {config.get('certificate_max_states')} states to enclose")
    from glocal_verify.observers.uio import local_uio

    obs = next(o for o in system.observers(r.scope["cluster"]) if o.center == r.scope["observer"])
    modes = {}
    p = system_prime(system)
    n = len(cm.nodes)
    for m in system.modes:
        d = local_uio(system, obs, mode=m, method="auto")
        K1 = (d.T @ d.A - d.F) @ d.C.T
        A = state_matrix_exact(system.cluster_laplacian_exact(cm.name, m), system.alpha_q, system.gamma_q)
        at = {a: k for k, a in enumerate(cm.nodes)}
        cols = [at[a] for a in obs.positions] + [n + at[a] for a in obs.velocities]
        claim = charpoly_claim(A, K1, cols, p, zero_rows=[n + at[b] for b in cm.boundary])
        modes[m] = {"K1": [[q(float(x)) for x in row] for row in K1], **claim}
    return {"kind": "uio", "modes": modes}

