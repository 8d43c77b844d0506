"""Zero-dynamics attacks over Q: the N-sized pencil in s, factor by factor, with certified directions."""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Iterable, Sequence

import flint
import numpy as np

from glocal_verify.analysis.zda import (
    GROWTH_DECAYING,
    GROWTH_PERSISTENT,
    GROWTH_UNBOUNDED,
    ZdaDirection,
    _actuators,
    _lambda_request,
    _normalize,
)
from glocal_verify.model import System
from glocal_verify.numerics.pencil_exact import (
    RootEnclosures,
    analyze_pencil_exact,
    classify_real_parts,
    _inv_mod,
    eval_at_root,
    kernel_over_field,
)
from glocal_verify.spec.types import Label

__all__ = [
    "ExactZdaZero",
    "ExactZdaAnalysis",
    "zda_analysis_exact",
    "exact_witness",
    "transfer_kernel",
]

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
        ``switching.safe``).
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
        return {1: GROWTH_UNBOUNDED, 0: GROWTH_PERSISTENT, -1: GROWTH_DECAYING}[self.real_sign]

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


def _transfer(system: System, F: Sequence[int]) -> tuple[Any, list[list[Any]]]:
    """d(s) = det(sI + alpha L) and the numerators P(s) = adj(sI + alpha L) S_F^T (N x m, in s).

    Faddeev-LeVerrier on the input columns only: with A = -alpha L and d(s) = sum_j c_j s^j,
    adj(sI - A) = sum_{j<N} s^j B_j, B_{N-1} = I, B_{j-1} = A B_j + c_j I; so W_j = B_j S_F^T
    costs N products of A with an N x m matrix over Q. Kept on ``system.analysis``.
    """
    key = ("zda-exact-transfer", tuple(F))
    cache = system.analysis
    if key in cache:
        return cache[key]  # type: ignore[no-any-return]
    N, m = system.n, len(F)
    L = system.laplacian_exact()
    a = system.alpha_q
    A = flint.fmpq_mat(N, N, [_fq(-a * L[i][j]) for i in range(N) for j in range(N)])
    d = A.charpoly()
    c = d.coeffs()
    EF = flint.fmpq_mat(N, m, [int(F[k] == i) for i in range(N) for k in range(m)])
    W = EF
    Ws = [W]
    for j in range(N - 1, 0, -1):
        W = A * W + EF * c[j]
        Ws.append(W)
    Ws.reverse()  # Ws[j] = B_j S_F^T
    P = [[flint.fmpq_poly([Wj[i, k] for Wj in Ws]) for k in range(m)] for i in range(N)]
    cache[key] = (d, P)
    return d, P


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


def _exact_at(system: System, F: Sequence[int], g: Any, s_poly: Any, zero_lambda: bool) -> tuple[bool, Any | None, int]:
    """(attack?, chosen kernel vector over Q[x]/g, kernel dimension) of Q at the roots of g."""
    rows_out = system.idx(system.monitored_positions) if zero_lambda else system.idx(system.monitored)
    tk = transfer_kernel(system, F, g, s_poly, rows_out, first_only=True)
    if tk is not None:
        basis, dim = tk
        return bool(basis), basis[0] if basis else None, dim
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
        xi, u = _normalize(v[:N], v[N:])
        xf = tuple(vec[:N])
    uf: tuple[Any, ...] = () if vec is None else tuple(vec[N:])
    return ExactZdaZero(root, rational, str(g), sign, attack, xi, u, xf, g, mult, uf)


def zda_analysis_exact(
    system: System,
    actuators: Iterable[Label] | None = None,
    *,
    lambda0: complex | float | Sequence[float] | None = None,
) -> ExactZdaAnalysis:
    """Exact version of :func:`zda_analysis` (rational weights and gains; no tolerance).

    Parameters
    ----------
    system : System
        The system (its weights and alpha, gamma are exact rationals).
    actuators : iterable of labels, optional
        F; default the spec's attacked actuators.
    lambda0 : complex, float or [re, im], optional
        Exponent for the witness (default the spec's ``attack.lambda0``); its real and
        imaginary parts are read as exact binary rationals.

    Returns
    -------
    ExactZdaAnalysis
    """
    F_lab = _actuators(system, actuators)
    F = system.idx(F_lab)
    lam_req = _lambda_request(system, lambda0)
    N, m = system.n, len(F)
    L = system.laplacian_exact()
    a = system.alpha_q
    As = [[-a * L[i][j] for j in range(N)] for i in range(N)]
    Bs = [[Fraction(int(F[k] == i)) for k in range(m)] for i in range(N)]
    M = system.idx(system.monitored)
    Cs = [[Fraction(int(j == r)) for j in range(N)] for r in M]
    es = analyze_pencil_exact(As, Bs, Cs, directions=False, n_inputs=m)
    k0 = N + m - es.normal_rank
    g_q = _fq(system.gamma_q)
    x = flint.fmpq_poly([0, 1])
    s_poly = x * x + g_q * x
    Z = es.zero_polynomial(s_poly) if es.zero_polynomial.degree() > 0 else flint.fmpq_poly(1)
    attack: list[ExactZdaZero] = []
    unobs: list[ExactZdaZero] = []
    notes: list[str] = []
    if Z.degree() > 0:
        _, facs = Z.factor()
        for g, mult in facs:
            g = g / g.leading_coefficient()
            if g == x:
                continue
            is_attack, vec, kdim = _exact_at(system, F, g, s_poly, False)
            if kdim <= k0:  # pragma: no cover - a theorem, kept as a self-check
                raise AssertionError(f"root of {g} is not a zero of the pencil; please report")
            enclosures = RootEnclosures(g)
            for root, sign in classify_real_parts(g):
                zz = _exact_zero(system, g, vec, root, sign, is_attack, int(mult), m, enclosures)
                (attack if is_attack else unobs).append(zz)
    # lambda = 0
    g0 = x
    is_attack0, vec0, kdim0 = _exact_at(system, F, g0, s_poly, True)
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
        is_att, vec, _ = _exact_at(system, F, g, s_poly, lam == 0)
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
        if not es.left_invertible and (best is None or best.real_sign <= 0):
            direction = at(1 + 0j)
            source = "lambda0 = 1 (not left-invertible: a ZDA exists at every lambda0)"
        if direction is None and best is not None:
            direction, source = best, "fastest-growing zero"
    return ExactZdaAnalysis(
        F_lab, es.left_invertible, N + es.normal_rank, k0, str(es.zero_polynomial), tuple(attack), tuple(unobs), direction, source, tuple(notes)
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
