"""Error dynamics of the local unknown-input observer (eq. ``obs_decent``).

Claim: with T = I - h C, (h C - I) E = 0 (eq. ``uio_conds_1``), F = A_bar - K_bar C,
K = F h (eq. ``uio_conds_2``) and A_bar = A - h C A (eq. ``uio_conds_3``), the error
e = x - x_hat of the observer z' = F z + (K + K_bar) y, x_hat = z + h y, for the cluster
x' = A x + E d + B u, y = C x (eqs. ``cluster_dyn2``, ``E_definition``), obeys eq.
``obs_decent_error``: e' = F e + T B u, r = C e, independently of the neighbours' states d.

The symbolic step is block algebra (non-commutative blocks: any cluster size, any mode,
since T does not depend on the mode). The exact step builds a real cluster of a random
graph, with h = E (C E)^+ computed exactly.
"""

from __future__ import annotations

import random

import sympy as sp

from ._instances import laplacian, noncomm, random_edges, selection, state_matrix
from .core import StepList

__all__ = ["STEPS", "cluster_instance"]

STEPS = StepList("uio_error")
REF = "Section III-D, decentralized observer"

A, B, C, E, h, Kb, x, z, d, u, G = noncomm("A B C E h Kbar x z d u G")


def _uio():
    T = 1 - h * C
    Abar = A - h * C * A
    F = Abar - Kb * C
    K = F * h
    return T, Abar, F, K


@STEPS.add("error_dynamics", equation="uio_conds_1-uio_conds_3 -> obs_decent_error", reference=REF)
def _error_dynamics() -> sp.Expr:
    """e' - F e - T B u = -(h C - I) E d: zero by eq. ``uio_conds_1``, for every d.

    Residual: e' - F e - T B u + (h C - I) E d, with e' = x' - z' - h C x' computed from the
    cluster and observer equations (block identity).
    """
    T, _Abar, F, K = _uio()
    xdot = A * x + E * d + B * u
    y = C * x
    zdot = F * z + (K + Kb) * y
    e = x - (z + h * y)
    edot = xdot - zdot - h * C * xdot
    return edot - F * e - T * B * u + (h * C - 1) * E * d


@STEPS.add("residual_is_C_e", equation="obs_decent_error", reference=REF)
def _residual() -> sp.Matrix:
    """r = y - C x_hat equals C e, and e(0) = x(0) because x_hat(0) = 0 (eq. ``obs_decent``)."""
    y = C * x
    xhat = z + h * y
    e = x - xhat
    x0 = noncomm("x_0")[0]
    return sp.Matrix([(y - C * xhat) - C * e, (x0 - 0) - x0])


@STEPS.add("h_solves_uio_conds_1", equation="uio_conds_1", reference="Appendix C, h = E (C E)^+")
def _h_solves() -> sp.Expr:
    """h = E G with G = (C E)^+: (h C - I) E = E (G C E - I), zero when C E has full column
    rank (condition (ii) with E of full column rank, so G C E = I)."""
    hh = E * G
    return (hh * C - 1) * E - E * (G * C * E - 1)


def cluster_instance(seed: int = 7):
    """A cluster of a seeded random 8-agent graph with its local observer (exact).

    Returns (A^i, B^i, C_loc, E^i, coupling) where coupling is the map from the outside states
    x_out to the coupling term sum_j A^{ij} x_j (eq. ``E_definition``).
    """
    rng = random.Random(seed)
    n = 8
    while True:
        edges = random_edges(rng, n, 0.45)
        P = [0, 1, 2, 3]
        out = [4, 5, 6, 7]
        cut = [(i, j) for (i, j) in edges if (i in P) != (j in P)]
        inner = [(i, j) for (i, j) in edges if i in P and j in P]
        if len(cut) >= 2 and len(inner) >= 3:
            break
    alpha, gamma = sp.Rational(3, 2), sp.Integer(2)
    L = laplacian(n, edges)
    Li = L.extract(P, P)
    Ai = state_matrix(Li, alpha, gamma)
    boundary = sorted({i if i in P else j for (i, j) in cut})
    bidx = [P.index(b) for b in boundary]
    Ei = sp.Matrix.vstack(sp.zeros(4, len(bidx)), selection(bidx, 4).T)
    coupling = sp.Matrix.vstack(sp.zeros(4, 2 * len(out)), sp.Matrix.hstack(-alpha * L.extract(P, out), sp.zeros(4, len(out))))
    suspected = [i for i in range(4) if i not in bidx][:1]
    Bi = sp.Matrix.vstack(sp.zeros(4, len(suspected)), selection(suspected, 4).T)
    # a partial local output: the position of agent 1 and the velocities of the boundary
    # agents (the least that satisfies condition (ii))
    Cl = sp.Matrix.vstack(
        sp.Matrix.hstack(selection([0], 4), sp.zeros(1, 4)),
        sp.Matrix.hstack(sp.zeros(len(bidx), 4), selection(bidx, 4)),
    )
    return Ai, Bi, Cl, Ei, coupling


@STEPS.add("cluster_instance_exact", equation="E_definition, uio_conds_1-uio_conds_3, obs_decent_error", reference=REF)
def _cluster_exact() -> list[sp.Matrix]:
    """Real cluster (agents 1-4 of a seeded random 8-agent graph; C measures the position of
    agent 1 and the velocities of the boundary agents), h = E (C E)^+ exactly, a random
    rational K_bar and random rational x, z, x_out, u: the coupling lies in Im E
    ((I - E E^+) coupling = 0), (h C - I) E = 0, and e' - F e - T B u = 0."""
    rng = random.Random(11)
    Ai, Bi, Cl, Ei, coupling = cluster_instance()
    n2 = Ai.shape[0]
    R = lambda: sp.Rational(rng.randint(-5, 5), rng.randint(1, 4))  # noqa: E731
    hh = Ei * (Cl * Ei).pinv()
    T = sp.eye(n2) - hh * Cl
    Abar = Ai - hh * Cl * Ai
    Kbar = sp.Matrix(n2, Cl.shape[0], lambda i, j: R())
    F = Abar - Kbar * Cl
    K = F * hh
    xv = sp.Matrix(n2, 1, lambda i, j: R())
    zv = sp.Matrix(n2, 1, lambda i, j: R())
    xo = sp.Matrix(coupling.shape[1], 1, lambda i, j: R())
    uv = sp.Matrix(Bi.shape[1], 1, lambda i, j: R())
    cpl = coupling * xo
    xdot = Ai * xv + cpl + Bi * uv
    zdot = F * zv + (K + Kbar) * (Cl * xv)
    e = xv - zv - hh * Cl * xv
    edot = xdot - zdot - hh * Cl * xdot
    in_range = (sp.eye(n2) - Ei * Ei.pinv()) * cpl
    return [in_range, (hh * Cl - sp.eye(n2)) * Ei, edot - F * e - T * Bi * uv]


@STEPS.add("h_fails_without_condition_ii", equation="uio_conds_1", reference="Proposition III.2 (ii)", expected="nonzero")
def _h_fails() -> sp.Matrix:
    """Without (ii) h = E (C E)^+ does not solve eq. ``uio_conds_1``: two agents (cluster
    {1, 2}, agent 2 on the boundary) with only the velocity of agent 1 measured: C E = 0,
    h = 0 and (h C - I) E = -E != 0."""
    Ei = sp.Matrix([0, 0, 0, 1])
    Cl = sp.Matrix([[0, 0, 1, 0]])
    hh = Ei * (Cl * Ei).pinv()
    return (hh * Cl - sp.eye(4)) * Ei
