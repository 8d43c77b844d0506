"""Zero-dynamics attacks over Q: the N-sized pencil in s, factor by factor, with certified directions."""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Iterable, Sequence

import flint
import numpy as np

from glocal_verify.analysis.stealthy.zda import (
    ZdaDirection,
    _actuators,
    requested_lambda0,
    normalize_direction,
)
from glocal_verify.analysis.laplacian.transfer import laplacian_transfer as _transfer
from glocal_verify.analysis.laplacian.twins import laplacian_entries
from glocal_verify.derived import Kind
from glocal_verify.model import System
from glocal_verify.numerics.minors import GroundedTables, MinorCertificate, full_rank_certificate, grounded_tables
from glocal_verify.numerics.symmetry import twin_modes
from glocal_verify.numerics.pencil_exact import (
    RootEnclosures,
    analyze_pencil_exact,
    classify_real_parts,
    inv_mod as _inv_mod,
    rational_kernel as _kernel,
    eval_at_root,
    kernel_over_field,
)
from glocal_verify.numerics.zero_polynomial import left_invertible_zero_polynomial
from glocal_verify.results import growth_of_sign
from glocal_verify.spec.types import NORMAL_MODE, Label

__all__ = [
    "ExactZdaZero",
    "ExactZdaAnalysis",
    "zda_analysis_exact",
    "exact_witness",
    "transfer_kernel",
    "has_fast_exact_path",
]

#: derived results this module keeps on the system (glocal_verify.derived)
_ZDA_EXACT_MINORS_KIND: Kind[dict[Any, Any]] = Kind("zda-exact-minor-cache", __name__, "dict[Any, Any]")
_ZDA_EXACT_MINOR_TABLES_KIND: Kind[Any] = Kind("zda-exact-minor-tables", __name__, "Any")
_ZDA_EXACT_TWINS_KIND: Kind[Any] = Kind("zda-exact-twins", __name__, "Any")

# ------------------------------------------------------------------------------------------
# exact path


@dataclass(frozen=True, slots=True)
class ExactZdaZero:
    """A zero (or the witness exponent) of the exact analysis.

    Attributes
    ----------
    value : complex
        lambda0 (exact when ``rational`` is set; else a certified approximation).
    rational : Fraction or None
        lambda0 when rational.
    factor : str
        Its minimal polynomial over Q (variable ``x`` = lambda).
    real_sign : int
        Exact sign of Re lambda0.
    attack : bool
        ker P(lambda0) holds a direction with u0 != 0 (decided in Q[x]/(factor)).
    xi, u0 : ndarray
        The exact kernel vector (over Q[x]/(factor)) evaluated at lambda0, xi scaled to
        max |xi_k| = 1.
    xi_field : tuple
        The same xi as ``fmpq_poly`` residues modulo ``field`` (exact; used by
        ``switching.avoids-attack``).
    field : fmpq_poly
        The minimal polynomial (``factor``) as a flint object.
    multiplicity : int
        Multiplicity in z(lambda^2 + gamma lambda) (1 for a requested exponent).
    u0_field : tuple
        The u0 part of the same kernel vector as residues modulo ``field`` (exact).
    """

    value: complex
    rational: Fraction | None
    factor: str
    real_sign: int
    attack: bool
    xi: np.ndarray
    u0: np.ndarray
    xi_field: tuple[Any, ...]
    field: Any
    multiplicity: int = 1
    u0_field: tuple[Any, ...] = ()

    @property
    def growth(self) -> str:
        """``unbounded`` / ``persistent`` / ``decaying`` from the exact sign of Re lambda0."""
        return growth_of_sign(self.real_sign)

    def direction(self) -> ZdaDirection:
        """This zero as a :class:`ZdaDirection` (numeric values of the exact vectors)."""
        return ZdaDirection(self.value, self.xi, self.u0, np.concatenate([self.xi, self.value * self.xi]), 0.0)


@dataclass(frozen=True, slots=True)
class ExactZdaAnalysis:
    """Stealthy ZDAs decided over Q.

    Attributes
    ----------
    actuators : tuple of labels
    left_invertible : bool
    normal_rank : int
        Of the 2N pencil.
    normal_kernel_dim : int
    s_zero_polynomial : str
        Zero polynomial of the N-sized pencil in s.
    zeros : tuple of ExactZdaZero
        Zeros with an input direction (stealthy ZDAs), fastest growing first.
    unobservable : tuple of ExactZdaZero
        Zeros all of whose directions have u0 = 0.
    direction : ExactZdaZero or None
        Witness (same selection rule as :func:`zda_analysis`).
    direction_source : str
    notes : tuple of str
    """

    actuators: tuple[Label, ...]
    left_invertible: bool
    normal_rank: int
    normal_kernel_dim: int
    s_zero_polynomial: str
    zeros: tuple[ExactZdaZero, ...]
    unobservable: tuple[ExactZdaZero, ...]
    direction: ExactZdaZero | None
    direction_source: str
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def exists(self) -> bool:
        """A stealthy ZDA exists."""
        return self.direction is not None


def _fq(x: Fraction) -> Any:
    return flint.fmpq(x.numerator, x.denominator)


def _q_matrix(system: System, F: Sequence[int], rows_out: Sequence[int], s_poly: Any) -> list[list[Any]]:
    """[[s(x) I + alpha L, -S_F^T], [S_out, 0]] with fmpq_poly entries."""
    N = system.n
    L = system.laplacian_exact()
    a = _fq(system.alpha_q)
    rows: list[list[Any]] = []
    for i in range(N):
        row = [flint.fmpq_poly(a * _fq(L[i][j])) + (s_poly if i == j else 0) for j in range(N)]
        row += [flint.fmpq_poly(-1 if F[k] == i else 0) for k in range(len(F))]
        rows.append(row)
    for r in rows_out:
        rows.append([flint.fmpq_poly(int(j == r)) for j in range(N)] + [flint.fmpq_poly(0)] * len(F))
    return rows


def transfer_kernel(
    system: System, F: Sequence[int], g: Any, s_poly: Any, rows_out: Sequence[int], extra: Sequence[Sequence[Fraction]] = (), first_only: bool = False
) -> tuple[list[tuple[Any, ...]], int] | None:
    """Kernel over Q[x]/(g) of [Q(s(x)); extra 0] through the transfer function, or None at a pole.

    When d(s(x)) = det(s(x) I + alpha L) is a unit of the field (g does not divide d(s(x))),
    (s I + alpha L) xi = S_F^T u0 gives xi = P(s) u0 / d(s) (:func:`_transfer`), so the kernel is
    {(P u0 / d, u0) : [S_out P; extra P] u0 = 0}: a (|rows_out| + |extra|) x m elimination
    instead of an (N + p) x (N + m) one. Every kernel vector has u0 != 0, so its last nonzero
    entry lies in the u0 part and the reduced basis (identity at the free columns, as
    :func:`~glocal_verify.numerics.pencil_exact.kernel_over_field` returns it) is the lift of
    the reduced kernel basis of the small matrix: the result is the same vectors, exactly.

    Parameters
    ----------
    system : System
    F : sequence of int
        Attacked agent indices.
    g : fmpq_poly
        Monic irreducible polynomial in x (= lambda).
    s_poly : fmpq_poly
        s(x) = x^2 + gamma x.
    rows_out : sequence of int
        The monitored rows S_out.
    extra : rows of rationals (length N)
        Further rows acting on xi only (e.g. dL_q[D, :]).
    first_only : bool
        Lift only the first basis vector (the others are counted).

    Returns
    -------
    (basis, dim) or None
        The lifted basis vectors (``fmpq_poly`` residues mod g, xi then u0) and the kernel
        dimension; None when g divides d(s(x)) (then use the full elimination).
    """
    d, P = _transfer(system, F)
    N, m = system.n, len(F)
    dg = d(s_poly) % g
    if dg.is_zero():
        return None
    rows: list[list[Any]] = [[P[r][k](s_poly) % g for k in range(m)] for r in rows_out]
    for er in extra:
        rows.append([sum((P[j][k] * _fq(er[j]) for j in range(N) if er[j] != 0), flint.fmpq_poly(0))(s_poly) % g for k in range(m)])
    K = kernel_over_field(rows, g, m)
    dinv = _inv_mod(dg, g)
    lifted = []
    for u in K.basis[: 1 if first_only else len(K.basis)]:
        xi = []
        for i in range(N):
            acc = flint.fmpq_poly(0)
            for k in range(m):
                if not u[k].is_zero():
                    acc += P[i][k](s_poly) * u[k]
            xi.append(acc * dinv % g)
        lifted.append((*xi, *u))
    return lifted, len(K.basis)


def _exact_at(
    system: System, F: Sequence[int], g: Any, s_poly: Any, zero_lambda: bool, z: Any | None = None
) -> tuple[bool, Any | None, int]:
    """(attack?, chosen kernel vector over Q[x]/g, kernel dimension) of Q at the roots of g.

    Off the poles the transfer function decides (:func:`transfer_kernel`). At a pole
    s0 = -alpha mu of a twin family of t modes (exact eigenvectors e_a - e_r of L vanishing
    on M, :func:`_twins`), when the zero polynomial ``z`` (in s, exact) has s + alpha mu to
    the power t, the kernel is exactly the twin span: it holds the t twin modes, and its
    dimension is at most ord_{s0}(z) (the pencil being left-invertible, every invariant factor
    that vanishes at s0 contributes at least one; ``z`` is given only then), so u = 0 on all of it and the kernel vector is the reduced
    basis of the span (:func:`_first_reduced_kernel_vector`), the vector the elimination
    over Q[x]/(g) returns. Otherwise the (N + p) x (N + m) pencil is eliminated over Q[x]/(g).
    """
    rows_out = system.idx(system.monitored_positions) if zero_lambda else system.idx(system.monitored)
    tk = transfer_kernel(system, F, g, s_poly, rows_out, first_only=True)
    if tk is not None:
        basis, dim = tk
        return bool(basis), basis[0] if basis else None, dim
    if z is not None and zero_lambda and g == flint.fmpq_poly([0, 1]):
        return _zero_lambda_kernel(system, F)
    if z is not None and not zero_lambda:
        a = _fq(system.alpha_q)
        for mu, pairs in _twins(system):
            lin = flint.fmpq_poly([a * _fq(mu), 1])
            if ((s_poly + a * _fq(mu)) % g).is_zero() and _order(z, lin) == len(pairs):
                N, m = system.n, len(F)
                vecs = [[Fraction(int(i == a_) - int(i == r_)) for i in range(N + m)] for a_, r_ in pairs]
                return False, _first_reduced_kernel_vector(vecs, N + m), len(pairs)
    Q = _q_matrix(system, F, rows_out, s_poly)
    N = system.n
    K = kernel_over_field(Q, g, N + len(F))
    pick = next((v for v in K.basis if any(not e.is_zero() for e in v[N:])), None)
    return pick is not None, pick if pick is not None else (K.basis[0] if K.basis else None), len(K.basis)


def _exact_zero(
    system: System, g: Any, vec: Any, root: complex, sign: int, attack: bool, mult: int, m: int, enclosures: RootEnclosures | None = None
) -> ExactZdaZero:
    N = system.n
    c = g.coeffs()
    rational = None
    if g.degree() == 1:
        rational = -Fraction(int(c[0].p), int(c[0].q)) / Fraction(int(c[1].p), int(c[1].q))
        root = complex(float(rational))
    xf: tuple[Any, ...]
    if vec is None:
        xi, u = np.zeros(N), np.zeros(m)
        xf = ()
    else:
        v = eval_at_root(vec, g, root, enclosures)
        xi, u = normalize_direction(v[:N], v[N:])
        xf = tuple(vec[:N])
    uf: tuple[Any, ...] = () if vec is None else tuple(vec[N:])
    return ExactZdaZero(root, rational, str(g), sign, attack, xi, u, xf, g, mult, uf)


def _order(z: Any, g: Any) -> int:
    """The multiplicity of the factor g in z."""
    k = 0
    while z.degree() > 0 and (z % g).is_zero():
        z, k = z // g, k + 1
    return k


def _twins(system: System) -> tuple[tuple[Fraction, tuple[tuple[int, int], ...]], ...]:
    """The twin modes of (L_1, M) (:func:`~glocal_verify.numerics.symmetry.twin_modes`), each family re-checked exactly."""

    def build() -> tuple[tuple[Fraction, tuple[tuple[int, int], ...]], ...]:
        M = system.idx(system.monitored)
        Lq = system.laplacian_exact()
        fams = twin_modes(system.n, laplacian_entries(system, NORMAL_MODE), M)
        return tuple((mu, pairs) for mu, pairs in fams if _twin_vectors_hold(Lq, mu, pairs, set(M)))

    return _ZDA_EXACT_TWINS_KIND.get(system, (), build)  # type: ignore[no-any-return]


def _proved_zero_polynomial(system: System, F: Sequence[int]) -> Any | None:
    """z(s) of the N-sized pencil, proved by the bounds of :mod:`glocal_verify.numerics.zero_polynomial`, or None.

    The system is (A, B, C) = (-alpha L_1, S_F^T, S_M) with the transfer numerators of
    :func:`_transfer`; the twin modes (an exact L-invariant subspace of ker S_M) supply the
    factor prod (s + alpha mu)^t of the lower bound. None when the system is not shown
    left-invertible or the bounds do not meet (the dense V* iteration then runs).
    """
    if not F or not system.monitored:
        return None
    d, P = _transfer(system, F)
    a = system.alpha_q
    A = {k: -a * v for k, v in laplacian_entries(system, NORMAL_MODE).items() if v != 0}
    inv = flint.fmpq_poly(1)
    for mu, pairs in _twins(system):
        inv *= flint.fmpq_poly([_fq(a * mu), 1]) ** len(pairs)
    proof = left_invertible_zero_polynomial(system.n, A, F, system.idx(system.monitored), d, P, inv)
    return None if proof is None else proof.zero_polynomial


# ------------------------------------------------------------------------------------------
# fast path: the minor certificate (no zero with an input direction at lambda != 0)


def _minor_tables(system: System) -> GroundedTables | None:
    """Numerator tables of the normal mode's reduced pencil with outputs M = M_x ∪ M_v (kept on ``system.analysis``)."""
    if not system.monitored:
        return None
    return _ZDA_EXACT_MINOR_TABLES_KIND.get(system, (), lambda: grounded_tables(system.n, laplacian_entries(system, NORMAL_MODE), Fraction(system.alpha_q), system.idx(system.monitored)),)


def has_fast_exact_path(system: System, actuators: Iterable[Label] | None = None) -> bool:
    """Whether :func:`zda_analysis_exact` will take its fast path (the minor certificate) for F.

    Cheap (the certificate modulo a prime, cached on ``system.analysis``); used to estimate
    the cost of an exact re-decision before it starts. False means the general path (dense
    V* iteration over Q) would run.

    Parameters
    ----------
    system : System
    actuators : iterable of labels, optional
        F; default the spec's attacked actuators.
    """
    attack = system.spec.attack
    labels = tuple(actuators) if actuators is not None else (attack.actuators if attack is not None else ())
    tables = _minor_tables(system)
    if not labels or tables is None or any(mu == 0 for mu, _ in tables.twins):
        return False
    cache: dict[Any, Any] = _ZDA_EXACT_MINORS_KIND.get(system, (), dict)
    return full_rank_certificate(tables, system.idx(labels), cache, modulo_twins=True) is not None


def _twin_vectors_hold(L: Sequence[Sequence[Fraction]], mu: Fraction, pairs: Sequence[tuple[int, int]], M: set[int]) -> bool:
    """L (e_a - e_r) = mu (e_a - e_r) exactly and a, r outside M, for every pair (an exact re-check of the twin modes)."""
    for a, r in pairs:
        if a in M or r in M or a == r:
            return False
        for i in range(len(L)):
            want = mu * ((i == a) - (i == r))
            if L[i][a] - L[i][r] != want:
                return False
    return True


def _first_reduced_kernel_vector(vectors: Sequence[Sequence[Fraction]], ncols: int) -> tuple[Any, ...]:
    """The first vector of the reduced kernel basis that :func:`kernel_over_field` returns, given the kernel's span.

    :func:`kernel_over_field` (and its rational branch) returns, for each free column f of the
    RREF of the matrix (ascending), the kernel vector with 1 at f and 0 at the other free
    columns. Column j is free iff some kernel vector has its last nonzero entry at j; these
    are the pivots of the RREF of a spanning set with the column order reversed, whose rows
    are those same vectors (RREF is unique). The first one belongs to the smallest free column.
    """
    t = len(vectors)
    W = flint.fmpq_mat(t, ncols, [_fq(Fraction(v[ncols - 1 - j])) for v in vectors for j in range(ncols)])
    R, r = W.rref()
    row = int(r) - 1  # pivots ascend in the reversed order: the last row has the smallest free column
    return tuple(flint.fmpq_poly(R[row, ncols - 1 - j]) for j in range(ncols))


def _zero_lambda_kernel(system: System, F: Sequence[int]) -> tuple[bool, Any | None, int]:
    """(attack?, chosen kernel vector, kernel dimension) at lambda = 0, exactly as :func:`_exact_at` decides them.

    At lambda = 0 the kernel is that of Q_0 = [[alpha L, -S_F^T], [S_{M_x}, 0]] over Q
    (det(alpha L) = 0, so :func:`transfer_kernel` never applies there and the general path
    eliminates Q_0 with flint's RREF, :func:`kernel_over_field`); the same RREF basis is
    computed here from an ``fmpq_mat`` built directly (no polynomial entries).
    """
    N, m = system.n, len(F)
    L = system.laplacian_exact()
    a = system.alpha_q
    rows_out = system.idx(system.monitored_positions)
    ent: list[Any] = []
    for i in range(N):
        ent.extend(_fq(a * L[i][j]) for j in range(N))
        ent.extend(flint.fmpq(-1 if F[k] == i else 0) for k in range(m))
    for r in rows_out:
        ent.extend(flint.fmpq(int(j == r)) for j in range(N + m))
    Kq = _kernel(flint.fmpq_mat(N + len(rows_out), N + m, ent))
    basis = [tuple(flint.fmpq_poly(Kq[i, c]) for i in range(N + m)) for c in range(Kq.ncols())]
    pick = next((v for v in basis if any(not e.is_zero() for e in v[N:])), None)
    return pick is not None, pick if pick is not None else (basis[0] if basis else None), len(basis)


def _certified_analysis(system: System, F_lab: tuple[Label, ...], F: Sequence[int], lam_req: complex | None) -> ExactZdaAnalysis | None:
    """The exact analysis from the maximal-minor certificate, or None (then the general path runs).

    When :func:`~glocal_verify.numerics.minors.full_rank_certificate` (``modulo_twins=True``)
    holds for F, every kernel vector of the N-sized pencil P(s) = [[sI + alpha L, -S_F^T],
    [S_M, 0]] at every s is an exact twin mode (u = 0), and the order of vanishing of a
    maximal minor at s0 = -alpha mu is exactly the twin dimension t_mu. Hence P is
    left-invertible (full normal column rank, 2N pencil of normal rank 2N + m), its zero
    polynomial (gcd of the maximal minors = the monic characteristic polynomial of A + BK on
    V*, the general path's ``s_zero_polynomial``) is prod_mu (s + alpha mu)^(t_mu), and
    ker P(s0) is spanned by the twin modes of mu. So every factor g of
    z(lambda^2 + gamma lambda) is unobservable, with the kernel vector the reduced basis of
    the twin span (:func:`_first_reduced_kernel_vector`), and a stealthy ZDA can only have
    lambda0 = 0, decided over Q (:func:`_zero_lambda_kernel`). The selection of the direction
    is the general path's (requested lambda0, else the fastest-growing zero). Every field
    equals the general path's (tests/test_zda_exact_fast.py compares them).
    """
    tables = _minor_tables(system)
    if tables is None or any(mu == 0 for mu, _ in tables.twins):
        return None  # s0 = 0 (isolated twins) would put a twin factor at lambda = 0: general path
    cache: dict[Any, Any] = _ZDA_EXACT_MINORS_KIND.get(system, (), dict)
    cert: MinorCertificate | None = full_rank_certificate(tables, F, cache, modulo_twins=True)
    if cert is None:
        return None
    Mset = set(system.idx(system.monitored))
    Lq = system.laplacian_exact()
    if not all(_twin_vectors_hold(Lq, mu, pairs, Mset) for mu, pairs in tables.twins):  # pragma: no cover - a theorem
        return None
    N, m = system.n, len(F)
    a = _fq(system.alpha_q)
    x = flint.fmpq_poly([0, 1])
    s_poly = x * x + _fq(system.gamma_q) * x
    z = flint.fmpq_poly(1)
    for mu, pairs in tables.twins:
        z *= flint.fmpq_poly([a * _fq(mu), 1]) ** len(pairs)
    attack: list[ExactZdaZero] = []
    unobs: list[ExactZdaZero] = []
    if z.degree() > 0:
        _, facs = z(s_poly).factor()
        for g, mult in facs:
            g = g / g.leading_coefficient()
            fam = [(mu, pairs) for mu, pairs in tables.twins if ((s_poly + a * _fq(mu)) % g).is_zero()]
            if g == x or len(fam) != 1:  # pragma: no cover - excluded above (mu != 0; distinct mu give coprime factors)
                return None
            mu, pairs = fam[0]
            vecs = [[Fraction(int(i == a_) - int(i == r_)) for i in range(N + m)] for a_, r_ in pairs]
            vec = _first_reduced_kernel_vector(vecs, N + m)
            enclosures = RootEnclosures(g)
            for root, sign in classify_real_parts(g):
                unobs.append(_exact_zero(system, g, vec, root, sign, False, int(mult), m, enclosures))
    is_attack0, vec0, kdim0 = _zero_lambda_kernel(system, F)
    if kdim0 > 0:
        (attack if is_attack0 else unobs).append(_exact_zero(system, x, vec0, 0j, 0, is_attack0, kdim0, m))
    attack.sort(key=lambda zz: (-zz.value.real, -abs(zz.value.imag)))
    unobs.sort(key=lambda zz: (-zz.value.real, -abs(zz.value.imag)))
    notes: list[str] = []
    direction: ExactZdaZero | None = None
    source = "none"
    if lam_req is not None:
        if lam_req == 0 and is_attack0:  # lambda0 != 0 carries no input direction (the certificate)
            direction, source = _exact_zero(system, x, vec0, 0j, 0, True, 1, m), "requested lambda0"
        else:
            notes.append(f"no stealthy ZDA at the requested lambda0 = {lam_req}")
    if direction is None and attack:
        direction, source = attack[0], "fastest-growing zero"
    return ExactZdaAnalysis(F_lab, True, 2 * N + m, 0, str(z), tuple(attack), tuple(unobs), direction, source, tuple(notes))


def zda_analysis_exact(
    system: System,
    actuators: Iterable[Label] | None = None,
    *,
    lambda0: complex | float | Sequence[float] | None = None,
    _general: bool = False,
    _dense: bool = False,
) -> ExactZdaAnalysis:
    """Exact version of :func:`zda_analysis` (rational weights and gains; no tolerance).

    Fast path: when the maximal minors of the reduced pencil prove (exactly, modulo a prime,
    :func:`glocal_verify.numerics.minors.full_rank_certificate` with ``modulo_twins``) that no
    kernel vector at any lambda != 0 has an input part, the pencil is left-invertible, the
    only zeros with lambda != 0 are the exact twin modes (u = 0; lambda^2 + gamma lambda +
    alpha mu = 0) and a stealthy ZDA can only have lambda0 = 0, one rational kernel over Q
    (:func:`_certified_analysis`). The result is the one the general path returns, field by
    field; the general path (dense V* iteration over Q, O(N^4) and more) runs otherwise.

    Parameters
    ----------
    system : System
        The system (its weights and alpha, gamma are exact rationals).
    actuators : iterable of labels, optional
        F; default the spec's attacked actuators.
    lambda0 : complex, float or [re, im], optional
        Exponent for the witness (default the spec's ``attack.lambda0``); its real and
        imaginary parts are read as exact binary rationals.
    _general : bool
        Private: skip the certificate fast path (tests compare both paths).
    _dense : bool
        Private: with ``_general``, take the zero polynomial from the dense V* iteration
        (:func:`~glocal_verify.numerics.pencil_exact.analyze_pencil_exact`, the reference)
        instead of its proof by minors and kernels (:func:`_proved_zero_polynomial`), and no
        twin shortcut at the poles.

    Returns
    -------
    ExactZdaAnalysis
    """
    F_lab = _actuators(system, actuators)
    F = system.idx(F_lab)
    lam_req = requested_lambda0(system, lambda0)
    if not _general:
        fast = _certified_analysis(system, F_lab, F, lam_req)
        if fast is not None:
            return fast
    N, m = system.n, len(F)
    z_proved = None if _dense else _proved_zero_polynomial(system, F)
    if z_proved is not None:  # left-invertible: normal rank N + m, z from its proof
        left_inv, normal_rank, z_s = True, N + m, z_proved
    else:
        L = system.laplacian_exact()
        a = system.alpha_q
        As = [[-a * L[i][j] for j in range(N)] for i in range(N)]
        Bs = [[Fraction(int(F[k] == i)) for k in range(m)] for i in range(N)]
        M = system.idx(system.monitored)
        Cs = [[Fraction(int(j == r)) for j in range(N)] for r in M]
        es = analyze_pencil_exact(As, Bs, Cs, directions=False, n_inputs=m)
        left_inv, normal_rank, z_s = es.left_invertible, es.normal_rank, es.zero_polynomial
    z_hint = z_s if left_inv and not _dense else None  # the twin shortcut of _exact_at needs full normal column rank
    k0 = N + m - normal_rank
    g_q = _fq(system.gamma_q)
    x = flint.fmpq_poly([0, 1])
    s_poly = x * x + g_q * x
    Z = z_s(s_poly) if z_s.degree() > 0 else flint.fmpq_poly(1)
    attack: list[ExactZdaZero] = []
    unobs: list[ExactZdaZero] = []
    notes: list[str] = []
    if Z.degree() > 0:
        _, facs = Z.factor()
        for g, mult in facs:
            g = g / g.leading_coefficient()
            if g == x:
                continue
            is_attack, vec, kdim = _exact_at(system, F, g, s_poly, False, z_hint)
            if kdim <= k0:  # pragma: no cover - a theorem, kept as a self-check
                raise AssertionError(f"root of {g} is not a zero of the pencil; please report")
            enclosures = RootEnclosures(g)
            for root, sign in classify_real_parts(g):
                zz = _exact_zero(system, g, vec, root, sign, is_attack, int(mult), m, enclosures)
                (attack if is_attack else unobs).append(zz)
    # lambda = 0
    g0 = x
    is_attack0, vec0, kdim0 = _exact_at(system, F, g0, s_poly, True, z_hint)
    if kdim0 > k0:
        zz = _exact_zero(system, g0, vec0, 0j, 0, is_attack0, kdim0 - k0, m)
        (attack if is_attack0 else unobs).append(zz)
    attack.sort(key=lambda z: (-z.value.real, -abs(z.value.imag)))
    unobs.sort(key=lambda z: (-z.value.real, -abs(z.value.imag)))

    def at(lam: complex) -> ExactZdaZero | None:
        re, im = Fraction(lam.real), Fraction(lam.imag)
        if im == 0:
            g = x - _fq(re)
        else:
            g = (x - _fq(re)) ** 2 + _fq(im) ** 2
        is_att, vec, _ = _exact_at(system, F, g, s_poly, lam == 0, z_hint)
        if not is_att:
            return None
        sign = (re > 0) - (re < 0)
        zz = _exact_zero(system, g, vec, complex(float(re), float(im)), sign, True, 1, m)
        return zz

    direction: ExactZdaZero | None = None
    source = "none"
    if lam_req is not None:
        direction = at(lam_req)
        if direction is not None:
            source = "requested lambda0"
        else:
            notes.append(f"no stealthy ZDA at the requested lambda0 = {lam_req}")
    if direction is None:
        best = attack[0] if attack else None
        if not left_inv and (best is None or best.real_sign <= 0):
            direction = at(1 + 0j)
            source = "lambda0 = 1 (not left-invertible: a ZDA exists at every lambda0)"
        if direction is None and best is not None:
            direction, source = best, "fastest-growing zero"
    return ExactZdaAnalysis(
        F_lab, left_inv, N + normal_rank, k0, str(z_s), tuple(attack), tuple(unobs), direction, source, tuple(notes)
    )


def _coeffs(p: Any) -> list[str]:
    return [str(c) for c in flint.fmpq_poly(p).coeffs()]


def exact_witness(system: System, F: Sequence[Label], z: ExactZdaZero) -> dict[str, Any]:
    """The exact direction (xi, u0) of a zero, as the witness entries of ``stealthy.zda``.

    Rational lambda0: ``xi_exact`` and ``u0_exact`` map labels to rationals (strings), scaled so
    that the largest |xi_k| is 1 -- exactly (sI + alpha L) xi = S_F^T u0, S_M xi = 0. Irrational
    lambda0: ``field`` (the minimal polynomial g of lambda0 in x; ``field_coefficients``
    lowest degree first), ``xi_residues`` and
    ``u0_residues`` (coefficient lists, lowest degree first, of polynomials r_k with xi_k =
    r_k(lambda0): an exact kernel vector over Q[x]/(g), the defining equations hold modulo g)
    and ``lambda0_enclosure`` (a certified python-flint ``acb`` ball around the root the
    numeric values refer to). Empty when the zero carries no kernel vector.

    Parameters
    ----------
    system : System
    F : sequence of labels
        The attacked actuators (labels of u0).
    z : ExactZdaZero
    """
    if not z.xi_field:
        return {}
    labels = system.labels
    if z.rational is not None:
        r = flint.fmpq(z.rational.numerator, z.rational.denominator)
        xi = [flint.fmpq_poly(p)(r) for p in z.xi_field]
        u0 = [flint.fmpq_poly(p)(r) for p in z.u0_field]
        big = max(xi, key=lambda q: abs(Fraction(int(q.p), int(q.q))))
        if big == 0:
            big = flint.fmpq(1)
        return {
            "xi_exact": {lab: str(x / big) for lab, x in zip(labels, xi) if x != 0},
            "u0_exact": {lab: str(u / big) for lab, u in zip(F, u0)},
            "exact_note": "exact rationals: (s I + alpha L) xi = S_F^T u0 and S_M xi = 0 hold exactly (entries not listed are 0)",
        }
    encl = RootEnclosures(z.field).at(128)
    ball = min(encl, key=lambda b: abs(complex(float(b.real.mid()), float(b.imag.mid())) - z.value))
    return {
        "field": z.factor,
        "field_coefficients": _coeffs(z.field),
        "xi_residues": {lab: _coeffs(p) for lab, p in zip(labels, z.xi_field) if not flint.fmpq_poly(p).is_zero()},
        "u0_residues": {lab: _coeffs(p) for lab, p in zip(F, z.u0_field)},
        "lambda0_enclosure": str(ball),
        "exact_note": "xi_k = r_k(lambda0), u0_k likewise, with r_k the residue polynomials (coefficients lowest degree first) modulo field",
    }
