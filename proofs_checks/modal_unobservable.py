"""The modal decomposition of the unobservable subspace (the project's lemma, ``CONDITIONS.md``).

Statement. For an undirected graph (L symmetric), alpha > 0, any gamma, and
C = blkdiag(S_{M_x}, S_{M_v}), let E_mu be the eigenspace of L for mu,
W^x_0 = E_0 ∩ ker S_{M_x}, W_mu = E_mu ∩ ker S_M (M = M_x ∪ M_v). Then

.. math::

    \\mathcal N(A_q, C) = (W^x_0 \\times W_0) \\oplus \\bigoplus_{\\mu > 0} (W_\\mu \\times W_\\mu).

Proof, as checked below.

1. E_mu x E_mu is A-invariant: A [w; z] = [z; -alpha mu w - gamma z] when L w = mu w,
   L z = mu z (step ``eigenspace_pair_invariant``).
2. For mu != mu' the quadratics lam^2 + gamma lam + alpha mu have no common root (their
   resultant is alpha^2 (mu - mu')^2, step ``spectral_separation``); hence the projector
   blkdiag(Pi_mu, Pi_mu) onto E_mu x E_mu is a spectral projector of A, a polynomial in A
   (step ``spectral_projector_commutes`` checks that it commutes with A). The unobservable
   subspace V is A-invariant, so V = ⊕_mu (V ∩ (E_mu x E_mu)).
3. Inside E_mu x E_mu, mu > 0: C x = 0 and C A x = 0 force S_v w = 0 and S_x z = 0
   (step ``kernel_and_invariance_force_W_mu``); so V ∩ (E_mu x E_mu) ⊆ W_mu x W_mu, and
   W_mu x W_mu is A-invariant inside ker C (step 1), hence equality.
4. mu = 0: C A x = 0 forces S_x z = 0 while S_v w stays free; W^x_0 x W_0 is A-invariant
   inside ker C (step ``zero_eigenvalue_block``).

Blocks are non-commutative symbols, so steps 1, 3, 4 hold for every size. Step
``random_graphs_exact_rank`` then compares the statement with the exact rank of the
observability matrix (C, CA, ..., CA^{2N-1}) on seeded random and named graphs, in rational
arithmetic (this module is the only place that builds that matrix: the library never does).
"""

from __future__ import annotations

import random

import flint
import sympy as sp

from . import _exact as X
from ._instances import complete, cycle, laplacian, noncomm, path, random_edges, star
from .core import StepList

__all__ = ["STEPS", "predicted_unobservable", "observability_rank"]

STEPS = StepList("modal_unobservable")
REF = "CONDITIONS.md, modal structure (project lemma)"

alpha, gamma, mu, mu2, lam = sp.symbols("alpha gamma mu mu2 lambda")
L, Sx, Sv, w, z, Pi = noncomm("L S_x S_v w z Pi")

A_nc = sp.Matrix([[0, 1], [-alpha * L, -gamma]])
C_nc = sp.Matrix([[Sx, 0], [0, Sv]])
x_nc = sp.Matrix([w, z])


@STEPS.add("eigenspace_pair_invariant", equation="cl_sys", reference=REF)
def _pair_invariant() -> sp.Matrix:
    """A [w; z] = [z; -alpha mu w - gamma z] modulo the hypotheses L w = mu w, L z = mu z.

    Residual: A x - [z; -alpha mu w - gamma z] - [0; -alpha (L w - mu w)] (block identity).
    """
    claim = sp.Matrix([z, -alpha * mu * w - gamma * z])
    certificate = sp.Matrix([0, -alpha * (L * w - mu * w)])
    return A_nc * x_nc - claim - certificate


@STEPS.add("kernel_and_invariance_force_W_mu", equation="cl_sys", reference=REF)
def _force_w_mu() -> sp.Matrix:
    """For mu != 0: S_v w and S_x z are combinations of C x, C A x and L w - mu w.

    S_v w = -(1/(alpha mu)) [(C A x)_v + gamma (C x)_v + alpha S_v (L w - mu w)] and
    S_x z = (C A x)_x; so x in V (C x = 0, C A x = 0) gives w, z in ker S_x ∩ ker S_v.
    """
    Cx = C_nc * x_nc
    CAx = C_nc * A_nc * x_nc
    r1 = Sv * w + (CAx[1] + gamma * Cx[1] + alpha * Sv * (L * w - mu * w)) / (alpha * mu)
    r2 = Sx * z - CAx[0]
    return sp.Matrix([r1, r2])


@STEPS.add("zero_eigenvalue_block", equation="cl_sys", reference=REF)
def _zero_block() -> sp.Matrix:
    """mu = 0: S_x z = (C A x)_x, and A [w; z] = [z; -gamma z] modulo L w = 0: the block
    W^x_0 x W_0 is A-invariant (z in W_0 ⊆ W^x_0) and lies in ker C."""
    CAx = C_nc * A_nc * x_nc
    inv = A_nc * x_nc - sp.Matrix([z, -gamma * z]) - sp.Matrix([0, -alpha * (L * w)])
    return sp.Matrix([Sx * z - CAx[0], inv[0], inv[1]])


@STEPS.add("spectral_separation", equation="cl_sys", reference=REF)
def _separation() -> sp.Expr:
    """res_lam(lam^2 + gamma lam + alpha mu, lam^2 + gamma lam + alpha mu2) = alpha^2 (mu - mu2)^2:
    distinct eigenvalues of L give disjoint pairs of eigenvalues of A (alpha != 0)."""
    r = sp.resultant(lam**2 + gamma * lam + alpha * mu, lam**2 + gamma * lam + alpha * mu2, lam)
    return r - alpha**2 * (mu - mu2) ** 2


@STEPS.add("spectral_projector_commutes", equation="cl_sys", reference=REF)
def _projector_commutes() -> sp.Matrix:
    """A blkdiag(Pi, Pi) - blkdiag(Pi, Pi) A = [[0, 0], [-alpha (L Pi - Pi L), 0]], which is 0
    for Pi = Pi_mu, the eigenprojector of L (a polynomial in L)."""
    P = sp.Matrix([[Pi, 0], [0, Pi]])
    return A_nc * P - P * A_nc - sp.Matrix([[0, 0], [-alpha * (L * Pi - Pi * L), 0]])


@STEPS.add("double_root_jordan_chain", equation="cl_sys", reference=REF)
def _jordan() -> sp.Matrix:
    """With gamma^2 = 4 alpha mu, (M + gamma/2 I)^2 = 0 for M = [[0, 1], [-alpha mu, -gamma]]
    (a double root with a Jordan chain, since M + gamma/2 I has the entry 1)."""
    M = sp.Matrix([[0, 1], [-gamma**2 / 4, -gamma]])
    N = M + gamma / 2 * sp.eye(2)
    return N * N


# -- exact check on graphs --------------------------------------------------------------
def observability_rank(Lm: sp.Matrix, a: sp.Rational, g: sp.Rational, Mx: list[int], Mv: list[int]) -> tuple[int, flint.fmpq_mat]:
    """Exact rank of (C, CA, ..., CA^{2N-1}) and that matrix (rational arithmetic)."""
    n = Lm.shape[0]
    A = X.zeros(2 * n, 2 * n)
    Lq = X.qmat(Lm)
    for i in range(n):
        A[i, n + i] = 1
        A[n + i, n + i] = X._fmpq(-g)
        for j in range(n):
            A[n + i, j] = -X._fmpq(a) * Lq[i, j]
    p = len(Mx) + len(Mv)
    C = X.zeros(p, 2 * n)
    for r, i in enumerate(Mx):
        C[r, i] = 1
    for r, i in enumerate(Mv):
        C[len(Mx) + r, n + i] = 1
    if p == 0:
        return 0, X.zeros(0, 2 * n)
    blocks = [C]
    for _ in range(2 * n - 1):
        blocks.append(blocks[-1] * A)
    O = X.vstack(blocks)
    return X.rank(O), O


def predicted_unobservable(Lm: sp.Matrix, Mx: list[int], Mv: list[int]) -> flint.fmpq_mat:
    """A basis (columns) of (W^x_0 x W_0) ⊕ ⊕_{mu>0} (W_mu x W_mu), exactly.

    Eigenspaces are grouped by irreducible factor f of the characteristic polynomial of L over
    Q: for f != mu, ⊕_{f(mu)=0} W_mu = {v in ker f(L) : S_M L^k v = 0, k < N} (the largest
    L-invariant subspace of ker f(L) ∩ ker S_M), so no algebraic numbers are needed.
    """
    n = Lm.shape[0]
    Lq = X.qmat(Lm)
    M = sorted(set(Mx) | set(Mv))
    SM = X.zeros(len(M), n)
    for r, i in enumerate(M):
        SM[r, i] = 1
    SX = X.zeros(len(Mx), n)
    for r, i in enumerate(Mx):
        SX[r, i] = 1
    _, facs = Lq.charpoly().factor()
    cols: list[flint.fmpq_mat] = []
    zero = X.zeros(n, 0)

    def emb(top: flint.fmpq_mat, bottom: flint.fmpq_mat) -> flint.fmpq_mat:
        return X.vstack([top, bottom])

    for f, _mult in facs:
        K = X.nullspace(X.matpoly(f, Lq))
        if f.degree() == 1 and f.coeffs()[0] == 0:  # the root mu = 0
            Wx = K * X.nullspace(SX * K)
            W0 = K * X.nullspace(SM * K)
            cols.append(emb(Wx, X.zeros(n, Wx.ncols())))
            cols.append(emb(X.zeros(n, W0.ncols()), W0))
        else:
            stack = X.vstack([SM * _pow(Lq, k) * K for k in range(n)], ncols=K.ncols())
            W = K * X.nullspace(stack)
            cols.append(emb(W, X.zeros(n, W.ncols())))
            cols.append(emb(X.zeros(n, W.ncols()), W))
    cols = [c for c in cols if c.ncols()]
    return X.hstack(cols, nrows=2 * n) if cols else X.hstack([zero, zero])


def _pow(M: flint.fmpq_mat, k: int) -> flint.fmpq_mat:
    out = X.eye(M.nrows())
    for _ in range(k):
        out = out * M
    return out


def _instances() -> list[tuple[str, sp.Matrix, sp.Rational, sp.Rational, list[int], list[int]]]:
    rng = random.Random(20240611)
    R = sp.Rational
    out = [
        ("K4, M_v={1}", laplacian(4, complete(4)), R(1), R(1), [], [0]),
        ("star S5, M_v={2}", laplacian(5, star(5)), R(1), R(2), [], [1]),
        ("cycle C4, M_v={1}", laplacian(4, cycle(4)), R(1), R(1), [], [0]),
        ("cycle C4, M_x={1}, M_v={2}", laplacian(4, cycle(4)), R(2), R(1), [0], [1]),
        ("two components {1,2},{3,4,5}, M_v={1}", laplacian(5, {(0, 1): R(1), (2, 3): R(1), (3, 4): R(2)}), R(1), R(1), [], [0]),
        ("empty graph N=3, M_x={1}", sp.zeros(3, 3), R(1), R(1), [0], []),
        ("path P2, gamma^2 = 4 alpha mu (mu=2)", laplacian(2, path(2)), R(1, 2), R(2), [], [0]),
        ("path P3, no monitors", laplacian(3, path(3)), R(1), R(1), [], []),
        ("path P4, M_v={2}", laplacian(4, path(4)), R(1), R(3, 2), [], [1]),
    ]
    for k in range(48):
        n = rng.randint(2, 7)
        edges = random_edges(rng, n, rng.choice([0.3, 0.5, 0.8]))
        a = rng.choice([R(1), R(2), R(1, 2), R(3, 2)])
        g = rng.choice([R(1), R(2), R(1, 2), R(3)])
        Mx = [i for i in range(n) if rng.random() < 0.2]
        Mv = [i for i in range(n) if rng.random() < 0.3]
        out.append((f"random #{k} (N={n}, {len(edges)} edges)", laplacian(n, edges), a, g, Mx, Mv))
    return out


@STEPS.add("random_graphs_exact_rank", equation="obsv_nullspace_matrix", reference=REF)
def _random_graphs() -> sp.Matrix:
    """On 57 graphs (48 seeded random, 9 named: repeated eigenvalues, disconnected, empty, a
    double root gamma^2 = 4 alpha mu, no monitors), per graph the row
    [dim pred - (2N - rank O), dim pred - rank(pred basis), #nonzero entries of O pred]
    is zero: the predicted subspace is independent, inside ker O, and of the right dimension."""
    rows = []
    for _name, Lm, a, g, Mx, Mv in _instances():
        n = Lm.shape[0]
        rO, O = observability_rank(Lm, a, g, Mx, Mv)
        Bp = predicted_unobservable(Lm, Mx, Mv)
        d = Bp.ncols()
        inside = 0 if O.nrows() == 0 or d == 0 else sum(1 for x in (O * Bp).entries() if x != 0)
        rows.append([d - (2 * n - rO), d - X.rank(Bp), inside])
    return sp.Matrix(rows)


@STEPS.add("velocity_constraint_free_at_mu_zero", equation="cl_sys", reference=REF, expected="nonzero")
def _sv_free() -> sp.Expr:
    """The mu = 0 factor is W^x_0, not W_0: for two agents with M_v = {1}, [1; 0] is
    unobservable although S_v 1 = 1 != 0 (residual: dim of the predicted subspace whose
    position part has S_v w != 0 = 1)."""
    Lm = laplacian(2, path(2))
    Bp = predicted_unobservable(Lm, [], [0])
    rO, _ = observability_rank(Lm, sp.Integer(1), sp.Integer(1), [], [0])
    assert Bp.ncols() == 4 - rO
    # position parts of the basis, seen by S_v = e_1^T
    return sp.Integer(sum(1 for c in range(Bp.ncols()) if Bp[0, c] != 0))
