"""The touch test of a safe mode at lambda0 = 0, in exact arithmetic, from potentials of L_1.

At lambda0 = 0 the stealthy kernel of eq. ``zda_cond`` is (s = 0, the outputs at lambda = 0
are the monitored positions M_x)

.. math::

    Z_0 = \\{(\\xi, u_0) : \\alpha L_1 \\xi = S_F^\\top u_0,\\ S_{M_x} \\xi = 0\\}.

With no monitored position and a connected G_1, :math:`\\mathbf 1^\\top L_1 = 0` forces
:math:`\\mathbf 1^\\top S_F^\\top u_0 = 0`, so :math:`u_0 = \\sum_{k \\ge 2} c_k (e_1 - e_k)` (in the
coordinates of F = (f_1, ..., f_m)) and

.. math::

    \\xi = \\frac{1}{\\alpha} \\sum_{k \\ge 2} c_k\\, y_k + c_1 \\mathbf 1, \\qquad
    L_1 y_k = e_{f_1} - e_{f_k},

the potentials of unit currents between attacked agents (y_k is unique up to a constant: ground
one agent r, y_k[r] = 0, and solve the grounded Laplacian, nonsingular on a connected graph).
Since :math:`\\Delta L_q \\mathbf 1 = 0`, a direction with an input avoids the switch to mode q
(``switching.avoids-attack`` holds, Remark III.3.1) iff the columns :math:`\\Delta L_q y_k`
are linearly dependent, i.e. :math:`\\operatorname{rank} [\\Delta L_q y_2, \\dots, \\Delta L_q y_m] < m - 1`;
otherwise every stealthy direction at lambda0 = 0 is touched. Everything is decided over Q
(python-flint ``fmpq_mat``): one solve of the grounded Laplacian per attack set, shared by
the modes. Physically: a link change between i and j is invisible to the attack iff the
attack's potential field takes the same value at i and j.

How it is decided, cheapest proof first (every step exact):

1. *A cut vertex* (above ``zero_touch_exact_max_agents`` agents, where the exact solve of
   step 4 that gives an exact avoiding direction is not affordable). The current between attacked agents flows only through the blocks
   (biconnected components) of G_1 on the block-cut tree between them; a part of the graph
   hanging off that subtree at a cut vertex c carries no current, so every potential there
   equals y_k[c]. A switching link whose two ends hang off the same vertex sees no potential
   difference for any k: when every link does, dL_q y_k = 0 for all k and the switch is
   avoided (:meth:`~glocal_verify.analysis.laplacian.blocks.BlockCutTree.attach_points`).
2. *Too few links* (the same sizes). rank [dL_q y_k] <= rank dL_q: a mode whose change has rank below m - 1
   (one link and three attacked agents) is avoided whatever the potentials.
3. *Potentials modulo a prime* prove a touch: rank m - 1 of [dL_q y_k] modulo p is rank
   m - 1 over Q. The potentials modulo p come, for one attack set, from a sparse solve of the
   grounded Laplacian L_g by Wiedemann's method (:func:`_potentials_mod`: 3N sparse products
   and one Berlekamp-Massey, O(N nnz), no N x N array); an audit of many sets inverts L_g
   modulo p once instead (:func:`_inverse_mod`, O(N^3) shared by every set).
4. Otherwise the exact solve over Q (``fmpq_mat``), when its estimated cost is within
   ``zero_touch_exact_max_agents``; beyond, no verdict (the caller stays undecided and says so).

The potential differences can be tiny (a link far from the attack, behind a two-vertex cut)
while nonzero: the numeric test, which compares ||dL_q xi|| with ||dL_q|| ||xi|| against the
tolerance, is then undecided, and this exact test settles it. The margin it reports is that
ratio for the attack's potential without its constant part (small: the switch exposes the attack
only by a small signal, and the result is marked fragile).
"""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction
from typing import Any, Sequence

import numpy as np
import scipy.sparse

from glocal_verify import config
from glocal_verify.analysis.switching.touch import Avoidance, block_norm, delta_block
from glocal_verify.analysis.laplacian.blocks import BlockCutTree, block_cut_tree
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.analysis.stealthy.zda import ZdaDirection, ZdaZero
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.results import Status
from glocal_verify.spec.types import NORMAL_MODE

__all__ = ["ZeroTouch", "zero_touch", "touch_at_zero"]

#: derived results this module keeps on the system (glocal_verify.derived)
_DELTA_NORM_KIND: Kind[float] = Kind("delta-norm", __name__, "float")
_GROUNDED_LAPLACIAN_INVERSE_MOD_KIND: Kind[Any] = Kind("grounded-laplacian-inverse-mod", __name__, "Any")
_NORMAL_GRAPH_CONNECTED_KIND: Kind[bool] = Kind("normal-graph-connected", __name__, "bool")
_POTENTIALS_MOD_KIND: Kind[Any] = Kind("attack-potentials-mod", __name__, "Any")
_BLOCKS_KIND: Kind[BlockCutTree] = Kind("normal-block-cut-tree", __name__, "BlockCutTree")


@dataclasses.dataclass(frozen=True, slots=True)
class ZeroTouch:
    """The exact touch test of one safe mode at lambda0 = 0 (module docstring).

    Attributes
    ----------
    mode : str
    avoids : bool
        Some stealthy direction with an input at lambda0 = 0 has dL_q xi = 0 exactly.
    rank : int
        rank over Q of [dL_q y_2, ..., dL_q y_m]; when the avoidance is proved by the rank of
        dL_q alone (step 2 of the module docstring), that rank, an upper bound.
    inputs : int
        m - 1, the dimension of the inputs of Z_0.
    touched_agents : tuple of labels
        Rows of dL_q y_2 proved nonzero (the agents whose links see the potential of the
        first attacked pair); empty when the avoidance is proved without the exact potentials.
    ratio : float
        ||dL_q y|| / (||dL_q||_2 ||y - mean(y)||) for y = y_2 (a magnitude, not a decision).
    xi, u0 : tuple of Fraction, optional
        When ``avoids``: an avoiding direction over Q (xi = sum c_k y_k / alpha with
        [dL_q y_k] c = 0, u0 on F), scaled to max |xi_i| = 1.
    xi_float, u0_float : tuple of float, optional
        When ``avoids`` was proved by a cut vertex or by the rank of dL_q: the avoiding
        direction from the floating-point potentials (the proof needs no exact one).
    """

    mode: str
    avoids: bool
    rank: int
    inputs: int
    touched_agents: tuple[Any, ...]
    ratio: float
    xi: tuple[Fraction, ...] | None = None
    u0: tuple[Fraction, ...] | None = None
    #: the avoiding direction in floating point when the avoidance is proved without the exact potentials (a cut vertex, too few links)
    xi_float: tuple[float, ...] | None = None
    u0_float: tuple[float, ...] | None = None


def _grounded(system: System) -> Any:
    """The grounded Laplacian L_1 without its last row and column, as an fmpq_mat.

    Built per call (it is only needed when the modular screen does not prove a touch): flint
    matrices do not pickle, and the system's analysis store travels to Dask workers.
    """
    from flint import fmpq, fmpq_mat

    L = system.laplacian_exact(NORMAL_MODE)
    n = system.n - 1
    return fmpq_mat(n, n, [fmpq(L[i][j].numerator, L[i][j].denominator) for i in range(n) for j in range(n)])


#: the modular screen inverts the grounded Laplacian modulo a prime (O(N^3) once per system) up
#: to ``zero_touch_modular_max_agents`` agents (:mod:`glocal_verify.config`, read when used);
#: above, every set takes the exact solve


def _inverse_mod(system: System) -> tuple[int, np.ndarray] | None:
    """(p, L_g^{-1} mod p as an int64 array) for a prime p below 2^62 that divides no weight denominator and not det L_g.

    Reduction modulo p is a ring homomorphism on the rationals whose denominators are units
    modulo p, and L_g^{-1} = adj(L_g) / det(L_g) with det(L_g) a unit: so (L_g^{-1} b) mod p is
    the reduction of the exact potential, and a potential difference nonzero modulo p is
    nonzero over Q.
    """
    from flint import fmpz, nmod_mat

    def build() -> tuple[int, Any] | None:
        n = system.n - 1
        nonzero = {(i, j): Fraction(v) for (i, j), v in laplacian_entries(system, NORMAL_MODE).items() if i < n and j < n and v != 0}
        dens = {abs(v.denominator) for v in nonzero.values()}
        q = (1 << 62) - 1
        for _ in range(200):
            q -= 2
            if not fmpz(q).is_prime() or any(d % q == 0 for d in dens):
                continue
            entries = [0] * (n * n)
            for (i, j), v in nonzero.items():
                entries[i * n + j] = (v.numerator % q) * pow(v.denominator % q, -1, q) % q
            M = nmod_mat(n, n, entries, q)
            try:
                inv = M.inv()
            except ZeroDivisionError:  # det L_g = 0 modulo q: the next prime
                continue
            # a plain array (entries < 2^62 fit int64): flint matrices do not pickle
            return q, np.array([int(x) for x in inv.entries()], dtype=np.int64).reshape(n, n)
        return None

    if system.n - 1 > config.get("zero_touch_modular_max_agents"):
        return None
    return _GROUNDED_LAPLACIAN_INVERSE_MOD_KIND.get(system, (NORMAL_MODE,), build)  # type: ignore[no-any-return]


def _potentials_mod(system: System, F: Sequence[int]) -> tuple[int, np.ndarray] | None:
    """(p, Y) with Y[:, k - 1] = L_g^{-1} (e_f1 - e_fk) modulo a prime p (Y[r] = 0 at the grounded agent r = N - 1), or None.

    Wiedemann's method on A = L_g D (D a random nonsingular diagonal modulo p): the minimal
    polynomial f of the sequence u^T A^i v (Berlekamp-Massey on 2(N - 1) terms, python-flint)
    divides the minimal polynomial of A, which divides its characteristic polynomial; so a
    degree N - 1 makes f the characteristic polynomial, and f(0) = +-det(L_g) det(D) != 0
    proves L_g nonsingular modulo p. Then A^{-1} = -(f_1 I + f_2 A + ... + f_(N-1) A^(N-2)) / f_0
    (Cayley-Hamilton) gives z = A^{-1} b in N - 2 more products, y = D z, and the solution is
    checked: L_g y = b modulo p. With L_g nonsingular modulo p (p divides no denominator of
    L_g), y is the reduction of the exact rational potential. The random choices (u, v, D, the
    prime) decide only whether the proof is found. Entries stay below p < 2^31 and every row's
    sum of products below 2^63.
    """
    from flint import fmpz_mod_poly_ctx

    from glocal_verify.numerics.minors import prime_for

    n = system.n - 1
    m = len(F)
    if n < 1 or m < 2:
        return None
    ent = {(i, j): Fraction(v) for (i, j), v in laplacian_entries(system, NORMAL_MODE).items() if i < n and j < n and v != 0}
    width = np.bincount(np.array([i for i, _ in ent], dtype=np.int64), minlength=n).max(initial=1)
    limit = min(2**31, math.isqrt((2**62) // int(width + 1)))
    rng = np.random.default_rng((n, *F))
    B = np.zeros((n, m - 1), dtype=np.int64)
    rows = np.array([i for i, _ in ent], dtype=np.int64)
    cols = np.array([j for _, j in ent], dtype=np.int64)
    for _ in range(config.get("zero_touch_primes")):
        p = prime_for(list(ent.values()), limit=limit)
        limit = p - 1
        vals = np.array([(v.numerator % p) * pow(v.denominator % p, -1, p) % p for v in ent.values()], dtype=np.int64)
        Lg = scipy.sparse.csr_matrix((vals, (rows, cols)), shape=(n, n), dtype=np.int64)
        d = rng.integers(1, p, size=n, dtype=np.int64)
        A = scipy.sparse.csr_matrix((vals * d[cols] % p, (rows, cols)), shape=(n, n), dtype=np.int64)
        u = rng.integers(0, p, size=n, dtype=np.int64)
        x = rng.integers(0, p, size=n, dtype=np.int64)
        seq = [0] * (2 * n)
        for k in range(2 * n):
            seq[k] = int(((u * x) % p).sum() % p)
            x = (A @ x) % p
        f = [int(c) for c in fmpz_mod_poly_ctx(p).minpoly(seq).coeffs()]
        if len(f) != n + 1 or f[0] == 0:
            continue  # A derogatory modulo p (or p divides det L_g): another prime and diagonal
        B[:] = 0
        for k in range(1, m):
            for idx, sign in ((F[0], 1), (F[k], -1)):
                if idx != n:
                    B[idx, k - 1] = (B[idx, k - 1] + sign) % p
        acc = (f[n] * B) % p
        for i in range(n - 1, 0, -1):  # Horner: acc = f_1 B + A (f_2 B + A (...))
            acc = ((A @ acc) % p + f[i] * B) % p
        z = acc * ((-pow(f[0], -1, p)) % p) % p
        Y = (z * d[:, None]) % p
        if np.any((Lg @ Y) % p != B):  # pragma: no cover - Cayley-Hamilton makes it exact
            raise ArithmeticError("the modular potentials do not solve the grounded Laplacian: please report")
        return p, np.vstack([Y, np.zeros((1, m - 1), dtype=np.int64)])
    return None


def _normal_blocks(system: System) -> BlockCutTree:
    """The block-cut tree of G_1 on agent indices (once per system: an audit asks every attack set)."""
    def build() -> BlockCutTree:
        return block_cut_tree(range(system.n), ((system.index[u], system.index[v]) for u, v in (tuple(k) for k in system.edges(NORMAL_MODE))))

    return _BLOCKS_KIND.get(system, (NORMAL_MODE,), build)


def _float_potentials(system: System, F: Sequence[int]) -> np.ndarray:
    """y_k = L_1^+ (e_f1 - e_fk) in floating point from the normal mode's eigen-decomposition (columns k = 2..m; a direction, not a proof)."""
    w, U = system.eigh()
    scale = max(1.0, float(np.max(np.abs(w))))
    inv = np.where(np.abs(w) > 1e-12 * scale, 1.0 / np.where(w == 0, 1.0, w), 0.0)
    C = np.column_stack([(U[F[0], :] - U[F[k], :]) * inv for k in range(1, len(F))])
    return np.asarray(U @ C)


def _applies(system: System, F: Sequence[int]) -> bool:
    return (
        system.n >= 2
        and len(F) >= 2
        and len(set(F)) == len(F)
        and not system.monitored_positions
        and _NORMAL_GRAPH_CONNECTED_KIND.get(system, (), lambda: len(system.components(NORMAL_MODE)) == 1)
    )


def _links(system: System, mode: str) -> tuple[list[tuple[int, int, Fraction]], list[int]]:
    """The switching links (i, j, dw) of ``mode`` as agent indices, and the agents they touch (sorted)."""
    links = [(system.index[u], system.index[v], Fraction(dw)) for u, v, dw in system.switching_links(mode)]
    return links, sorted({a for i, j, _ in links for a in (i, j)})


def _structural(system: System, F: Sequence[int], mode: str) -> ZeroTouch | None:
    """Steps 1 and 2 of the module docstring: the switch avoided by a cut vertex or by too few links, with a float direction, or None."""
    links, rows = _links(system, mode)
    m = len(F)
    if not rows:
        return None
    attach = _normal_blocks(system).attach_points(F, rows)
    if all(attach[i] == attach[j] for i, j, _ in links):
        rank = 0
    else:
        from flint import fmpq, fmpq_mat

        pos = {i: k for k, i in enumerate(rows)}
        D = fmpq_mat(len(rows), len(rows))
        for i, j, dw in links:
            w = fmpq(dw.numerator, dw.denominator)
            D[pos[i], pos[i]] += w
            D[pos[j], pos[j]] += w
            D[pos[i], pos[j]] -= w
            D[pos[j], pos[i]] -= w
        rank = int(D.rank())
        if rank >= m - 1:
            return None  # rank [dL_q y_k] <= rank dL_q: an upper bound, kept as the rank
    Y = _float_potentials(system, F)
    dL = system.delta_laplacian_sparse(mode)
    Wf = np.asarray(dL @ Y)
    c = np.linalg.svd(Wf)[2][-1] if Wf.size and rank != 0 else np.eye(m - 1)[0]
    xi = Y @ c / float(system.alpha)
    u0 = np.concatenate([[float(np.sum(c))], -c])
    top = float(np.max(np.abs(xi))) if xi.size else 0.0
    if top == 0.0:
        xi, top = xi + 1.0, 1.0
    return ZeroTouch(mode, True, rank, m - 1, (), _ratio(system, mode, F, rows, links), None, None, tuple(xi / top), tuple(u0 / top))


def _ratio(system: System, mode: str, F: Sequence[int], rows: Sequence[int], links: Sequence[tuple[int, int, Fraction]]) -> float:
    """||dL_q y|| / (||dL_q||_2 ||y||) for y = L_1^+ (e_f1 - e_f2) in floating point (a magnitude).

    With L_1 = U diag(mu) U^T: y = U c, c = (U[f1, :] - U[f2, :]) / mu off the zero mode, so
    ||y|| = ||c|| and y_i - y_j = (U[i, :] - U[j, :]) c, O(N) per link.
    """
    w, U = system.eigh()
    scale = max(1.0, float(np.max(np.abs(w))))
    c = (U[F[0], :] - U[F[1], :]) / np.where(np.abs(w) > 1e-12 * scale, w, np.inf)
    pos = {i: k for k, i in enumerate(rows)}
    col = np.zeros(len(rows))
    for i, j, dw in links:
        d = float(dw) * float((U[i, :] - U[j, :]) @ c)
        col[pos[i]] += d
        col[pos[j]] -= d
    dl_norm = _DELTA_NORM_KIND.get(system, (mode,), lambda: block_norm(delta_block(system, mode)[1]))
    ny = float(np.linalg.norm(c))
    return float(np.linalg.norm(col)) / (dl_norm * ny) if dl_norm > 0 and ny > 0 else 0.0


def _modular(system: System, F: Sequence[int], mode: str, many: bool) -> ZeroTouch | None:
    """The proof that every direction is touched, modulo a prime (rank m - 1 modulo p), or None.

    The potentials modulo p come from the grounded inverse (``many``: an audit of many attack
    sets, up to :data:`MODULAR_MAX_AGENTS` agents) or from the sparse solve of this set."""
    from flint import nmod_mat

    r, m = system.n - 1, len(F)
    links, rows = _links(system, mode)
    if not rows:
        return None
    inv = _inverse_mod(system) if many else None
    if inv is not None:
        q, X = inv

        def y(i: int, k: int) -> int:  # (L_g^{-1} (e_f1 - e_fk))_i modulo q, y[r] = 0
            if i == r:
                return 0
            a = int(X[i, F[0]]) if F[0] != r else 0
            b = int(X[i, F[k]]) if F[k] != r else 0
            return (a - b) % q
    else:
        pot = _POTENTIALS_MOD_KIND.get(system, (NORMAL_MODE, tuple(F)), lambda: _potentials_mod(system, F))
        if pot is None:
            return None
        q, Y = pot

        def y(i: int, k: int) -> int:
            return int(Y[i, k - 1])

    pos = {i: k for k, i in enumerate(rows)}

    W = [[0] * (m - 1) for _ in rows]
    for i, j, dw in links:
        w = (dw.numerator % q) * pow(dw.denominator % q, -1, q) % q
        for k in range(1, m):
            d = w * (y(i, k) - y(j, k)) % q
            W[pos[i]][k - 1] = (W[pos[i]][k - 1] + d) % q
            W[pos[j]][k - 1] = (W[pos[j]][k - 1] - d) % q
    rank = nmod_mat(len(rows), m - 1, [x for row in W for x in row], q).rank()
    if rank < m - 1:
        return None
    touched = tuple(system.labels[i] for i in rows if W[pos[i]][0] != 0)
    return ZeroTouch(mode, False, rank, m - 1, touched, _ratio(system, mode, F, rows, links))


def zero_touch(system: System, F: Sequence[int], modes: Sequence[str], *, many: bool = False) -> list[ZeroTouch | None] | None:
    """The exact touch test at lambda0 = 0 of each mode for actuators F, or None where it does not apply.

    Applies when G_1 is connected, no position is monitored and |F| >= 2 (with |F| = 1 the
    kernel Z_0 has no input: u_0 = 0). The steps of the module docstring, in order: a cut
    vertex or too few links prove the switch avoided; rank m - 1 of [dL_q y_k] modulo a
    prime proves every direction touched (a nonzero minor modulo p is nonzero); otherwise one
    exact solve over Q (``fmpq_mat``) decides, up to ``zero_touch_exact_max_agents`` agents.

    Parameters
    ----------
    system : System
    F : sequence of int
        Agent indices of the attacked actuators.
    modes : sequence of str
        Safe modes.
    many : bool
        Many attack sets share this system (an audit): the potentials modulo p come from one
        inverse of the grounded Laplacian (up to :data:`MODULAR_MAX_AGENTS` agents) instead of
        a sparse solve per set.

    Returns
    -------
    list of (ZeroTouch or None), or None
        ``touched_agents`` are the rows of dL_q y_2 proved nonzero (modulo p, or over Q); an
        entry is None where no step decided (the exact solve was beyond its limit).
    """
    from flint import fmpq, fmpq_mat

    if not _applies(system, F):
        return None
    n = system.n
    r = n - 1  # the grounded agent: y_k[r] = 0
    m = len(F)
    found: dict[str, ZeroTouch | None] = {}
    small = n <= config.get("zero_touch_exact_max_agents")  # the exact solve is affordable: it gives an exact avoiding direction
    for mode in modes:
        st = None if small else _structural(system, F, mode)
        if st is not None:
            found[mode] = st
            continue
        mt = _modular(system, F, mode, many)
        if mt is not None:
            found[mode] = mt
    rest = [mode for mode in modes if mode not in found]
    if rest and not small:
        found.update({mode: None for mode in rest})
        rest = []
    if rest:
        rhs = fmpq_mat(n - 1, m - 1)
        for k in range(1, m):
            for idx, sign in ((F[0], 1), (F[k], -1)):
                if idx != r:
                    rhs[idx, k - 1] += sign
        Y = _grounded(system).solve(rhs)  # (n - 1) x (m - 1), exact
        for mode in rest:
            links, rows = _links(system, mode)
            pos = {i: k for k, i in enumerate(rows)}
            W = fmpq_mat(max(len(rows), 1), m - 1)
            for i, j, dw in links:
                w = fmpq(dw.numerator, dw.denominator)
                for k in range(m - 1):
                    yi = Y[i, k] if i != r else fmpq(0)
                    yj = Y[j, k] if j != r else fmpq(0)
                    d = w * (yi - yj)  # dL_q = sum dw (e_i - e_j)(e_i - e_j)^T
                    W[pos[i], k] += d
                    W[pos[j], k] -= d
            rank = W.rank()
            touched = tuple(system.labels[i] for i in rows if W[pos[i], 0] != 0)
            xi = u0 = None
            if rank < m - 1:
                xi, u0 = _avoiding(system, F, Y, W, r)
            found[mode] = ZeroTouch(mode, rank < m - 1, rank, m - 1, touched, _ratio(system, mode, F, rows, links) if rows else 0.0, xi, u0)
    return [found[mode] for mode in modes]


def _avoiding(system: System, F: Sequence[int], Y: Any, W: Any, r: int) -> tuple[tuple[Fraction, ...], tuple[Fraction, ...]]:
    """An exact avoiding direction: c in ker W, xi = Y c / alpha (xi_r = 0), u0 = sum_k c_k (e_1 - e_k)."""
    from glocal_verify.numerics import exact as ex

    rows = [[Fraction(int(W[i, k].p), int(W[i, k].q)) for k in range(W.ncols())] for i in range(W.nrows())]
    K = ex.nullspace(rows, W.ncols())
    assert K, "rank < m - 1 leaves a kernel"
    c = [Fraction(x) for x in K[0]]
    alpha = Fraction(system.alpha_q)
    xi = [Fraction(0)] * system.n
    for i in range(system.n):
        if i != r:
            xi[i] = sum((Fraction(int(Y[i, k].p), int(Y[i, k].q)) * c[k] for k in range(len(c))), Fraction(0)) / alpha
    u0 = [sum(c, Fraction(0))] + [-ck for ck in c]
    top = max(xi, key=abs)
    if top == 0:  # only the constant part moves: shift it (dL_q 1 = 0, L_1 1 = 0)
        xi = [x + 1 for x in xi]
        top = Fraction(1)
    return tuple(x / top for x in xi), tuple(v / top for v in u0)


def touch_at_zero(system: System, mode: str, z: ZdaZero, source: str, F: Sequence[int], *, many: bool = False) -> Avoidance | None:
    """``switching.avoids-attack`` for mode q at the witness z (lambda0 = 0) over Q, or None where :func:`zero_touch` does not apply.

    ``holds`` when some stealthy direction with an input at lambda0 = 0 has dL_q xi = 0
    (with the exact avoiding direction), ``fails`` when every one is touched. The margin is
    :attr:`ZeroTouch.ratio`; a note says how it was decided.

    Parameters
    ----------
    system : System
    mode : str
        A safe mode q.
    z : ZdaZero
        The witness of ``stealthy.zda`` (its exponent must be 0).
    source : str
        Why ``stealthy.zda`` chose it.
    F : sequence of int
        Agent indices of the attacked actuators.
    many : bool
        As for :func:`zero_touch`.
    """
    if complex(z.value) != 0:
        return None
    zt = zero_touch(system, F, [mode], many=many)
    t = None if zt is None else zt[0]
    if t is None:
        return None
    if t.avoids and t.xi is None:
        how = (
            f"decided over Q at lambda0 = 0: the attack's potentials y_k (L_1 y_k = e_f1 - e_fk) agree across every switching link "
            "(its ends hang off the current's blocks at one cut vertex), or dL_q has rank below the m - 1 inputs"
        )
    else:
        how = (
            f"decided over Q at lambda0 = 0: rank [dL_q y_2 .. dL_q y_m] = {t.rank} of {t.inputs} for the attack's potentials "
            "y_k (L_1 y_k = e_f1 - e_fk; modulo a prime for a touch, solved over Q otherwise)"
        )
    chosen = z.direction()
    direction: ZdaDirection | None = None
    if t.avoids:
        xs, us = (t.xi, t.u0) if t.xi is not None and t.u0 is not None else (t.xi_float, t.u0_float)
        assert xs is not None and us is not None
        xi = np.array([float(x) for x in xs])
        direction = ZdaDirection(0j, xi, np.array([float(x) for x in us]), np.concatenate([xi, 0.0 * xi]), 0.0)
    # Z_0 has one direction with an input (up to the constant) when m = 2: the chosen one
    one = t.inputs == 1
    return Avoidance(
        mode=mode,
        status=Status.HOLDS if t.avoids else Status.FAILS,
        lambda0=0j,
        growth=z.growth,
        chosen=chosen,
        chosen_source=source,
        chosen_touched=(not t.avoids) if one else None,
        chosen_touched_agents=t.touched_agents if one else (),
        direction=direction,
        direction_source=("exact potentials of the attack (L_1 xi = S_F^T u0 / alpha over Q)" if t.xi is not None else
                          "floating-point potentials of the attack (the avoidance itself is proved exactly)") if t.avoids else "",
        dimension=t.inputs - t.rank,
        margin=t.ratio,
        dl_residual=0.0 if t.avoids else float("nan"),
        exact_xi=t.xi,
        exact_u0=t.u0,
        notes=(how,),
    )
