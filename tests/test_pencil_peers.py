"""analyze_pencil against invariant-zero examples published by other control libraries.

Only the numeric data of each example and its published answer are transcribed here; every
example names its source. Each case is checked by the *defining* property of an invariant
zero, not only against a stored number:

* for every reported zero z, the pencil P(z) = [[z I - A, -B], [C, D]] loses rank: with r the
  normal rank, sigma_r of the *balanced* pencil (a power-of-two diagonal state similarity plus
  input and output scaling, computed here independently of the library) is tiny relative to its
  norm; the reported zeroing direction is a kernel vector of that balanced pencil;
* the reported zeros (counted with multiplicity) are the published ones and nothing else;
* the normal rank is the published (or exactly derived) one and the analysis is ``decided``.

Every example is also run under diagonal state scalings T = diag(2^k_i): A -> T A T^-1,
B -> T B, C -> C T^-1 leaves the zeros and the normal rank unchanged (the pencil is multiplied
by nonsingular diagonal matrices on both sides), so each answer must survive it.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache

import flint
import numpy as np
import pytest

from glocal_verify.numerics.pencil import PencilAnalysis, analyze_pencil, pencil_matrix

# ------------------------------------------------------------------------------------------
# the examples


@dataclass(frozen=True)
class Example:
    name: str
    source: str
    A: tuple[tuple[float, ...], ...]
    B: tuple[tuple[float, ...], ...]
    C: tuple[tuple[float, ...], ...]
    D: tuple[tuple[float, ...], ...]
    zeros: tuple[complex, ...]  # published, with multiplicity
    normal_rank: int
    rtol: float = 1e-6  # relative tolerance of the match with the published zeros
    atol: float = 0.0  # absolute slack for zeros published to few digits
    #: False when sigma_r / sigma_1 of the balanced pencil is tiny at *every* point far out (high
    #: relative degree: for c(s)/s^15, sigma_min(P(lam)) <= |c(lam)| / |lam|^15), so the rank-drop
    #: oracle cannot tell a zero from a non-zero there; the set comparison still does
    discriminating: bool = True

    def system(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        n = len(self.A)
        A = np.array(self.A, dtype=float).reshape(n, n)
        B = np.array(self.B, dtype=float).reshape(n, -1)
        C = np.array(self.C, dtype=float).reshape(-1, n)
        D = np.array(self.D, dtype=float).reshape(C.shape[0], B.shape[1])
        return A, B, C, D


def _rows(M: np.ndarray) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(x) for x in r) for r in np.atleast_2d(M))


def _chain(n: int, c: list[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Controllable realization of c(s) / s^n: A = upper shift, B = e_n, C = coefficients of c."""
    A = np.diag(np.ones(n - 1), 1)
    B = np.zeros((n, 1))
    B[-1, 0] = 1.0
    C = np.zeros((1, n))
    C[0, : len(c)] = c
    return A, B, C


_AB08ND_A = ((1, 0, 0, 0, 0, 0), (0, 1, 0, 0, 0, 0), (0, 0, 3, 0, 0, 0), (0, 0, 0, -4, 0, 0), (0, 0, 0, 0, -1, 0), (0, 0, 0, 0, 0, 3))
_AB08ND_B = ((0, -1), (-1, 0), (1, -1), (0, 0), (0, 1), (-1, -1))
_AB08ND_C = ((1, 0, 0, 1, 0, 0), (0, 1, 0, 1, 0, 1), (0, 0, 1, 0, 0, 1))

_A9, _B9, _C9 = _chain(15, [-20.0, 1.0])
_A5, _B5, _C5 = _chain(15, [1.0])

EXAMPLES: tuple[Example, ...] = (
    Example(
        "slicot_ab08nd",
        "SLICOT/SLICOT-Reference doc/AB08ND.html (Program Data / Results: finite invariant zeros 2, -1; "
        "no right Kronecker index, i.e. full column normal rank); same data as python-control "
        "control/tests/statesp_test.py test_zero_mimo_sys623_non_square; normal rank 8 published by "
        "andreasvarga/MatrixPencils.jl test/test_sklfapps.jl (kinfo.nrank == 8)",
        _AB08ND_A, _AB08ND_B, _AB08ND_C, ((0, 0), (0, 0), (0, 0)),
        (2.0, -1.0), 8,
    ),
    Example(
        "slicot_ab08nd_first_input",
        "andreasvarga/MatrixPencils.jl test/test_sklfapps.jl (spzeros of the AB08ND example with B[:,1]: "
        "finite zeros -1, 2; kinfo.nrank == 7)",
        _AB08ND_A, tuple((r[0],) for r in _AB08ND_B), _AB08ND_C, ((0,), (0,), (0,)),
        (2.0, -1.0), 7,
    ),
    Example(
        "python_control_sys322",
        "python-control/python-control control/tests/statesp_test.py test_zero_mimo_sys322_square "
        "(normal rank: D invertible, so n + m)",
        ((-3, 4, 2), (-1, -3, 0), (2, 5, 3)), ((1, 4), (-3, -3), (-2, 1)), ((4, 2, -3), (1, 4, 3)), ((-2, 4), (0, 1)),
        (44.41465, -0.490252, -5.924398), 5, atol=1e-6,
    ),
    Example(
        "python_control_sys222",
        "python-control/python-control control/tests/statesp_test.py test_zero_mimo_sys222_square "
        "(normal rank: D invertible, so n + m)",
        ((4, 1), (2, -3)), ((5, 2), (-3, -3)), ((2, -4), (0, 1)), ((3, 2), (1, -1)),
        (-10.568501, 3.368501), 4, atol=1e-6,
    ),
    Example(
        "emami_naeini_van_dooren_example_3",
        "JuliaControl/ControlSystems.jl lib/ControlSystemsBase/test/test_analysis.jl (Emami-Naeini & "
        "Van Dooren 1982, Example 3)",
        ((0, 1, 0, 0, 0, 0), (0, 0, 1, 0, 0, 0), (0, 0, 0, 0, 0, 0), (0, 0, 0, 0, 1, 0), (0, 0, 0, 0, 0, 1), (0, 0, 0, 0, 0, 0)),
        ((0, 0), (0, 0), (1, 0), (0, 0), (0, 0), (0, 1)),
        ((1, 1, 0, 0, 0, 0), (0, 0, 0, 1, -1, 0)), ((1, 0), (1, 0)),
        (0.3411639019140099 + 1.161541399997252j, 0.3411639019140099 - 1.161541399997252j, 1.0, -0.6823278038280199), 8,
    ),
    Example(
        "emami_naeini_van_dooren_aircraft_example_4",
        "JuliaControl/ControlSystems.jl lib/ControlSystemsBase/test/test_analysis.jl (Emami-Naeini & "
        "Van Dooren 1982, Example 4, the 5-state aircraft model)",
        (
            (-0.129, 0.0, 0.396e-1, 0.25e-1, 0.191e-1),
            (0.329e-2, 0.0, -0.779e-4, 0.122e-3, -0.621),
            (0.718e-1, 0.0, -0.1, 0.887e-3, -0.385e1),
            (0.411e-1, 0.0, 0.0, -0.822e-1, 0.0),
            (0.361e-3, 0.0, 0.35e-4, 0.426e-4, -0.743e-1),
        ),
        ((0.0, 0.139e-2), (0.0, 0.359e-4), (0.0, -0.989e-2), (0.249e-4, 0.0), (0.0, -0.534e-5)),
        ((1, 0, 0, 0, 0), (0, 1, 0, 0, 0)), ((0, 0), (0, 0)),
        (-0.06467751189940692, -0.3680512036036696), 7,
    ),
    Example(
        "emami_naeini_van_dooren_example_5",
        "JuliaControl/ControlSystems.jl lib/ControlSystemsBase/test/test_analysis.jl (Example 5: "
        "1/s^15 has no finite zero; realized here in controllable form)",
        _rows(_A5), _rows(_B5), _rows(_C5), ((0,),),
        (), 16,
    ),
    Example(
        "emami_naeini_van_dooren_example_6",
        "JuliaControl/ControlSystems.jl lib/ControlSystemsBase/test/test_analysis.jl (Example 6: "
        "'a regular pencil containing the single zero at 2'; the pencil is singular, normal rank 3)",
        ((2, -1, 0), (0, 0, 0), (-1, 0, 0)), ((0,), (0,), (1,)), ((0, -1, 0),), ((0,),),
        (2.0,), 3,
    ),
    Example(
        "emami_naeini_van_dooren_example_7",
        "JuliaControl/ControlSystems.jl lib/ControlSystemsBase/test/test_analysis.jl (Example 7: no zero; "
        "the transfer function is 0, so the 3 x 3 pencil has normal rank 2, exact rank here)",
        ((0, 0), (0, 0)), ((0,), (1,)), ((-1, 0),), ((0,),),
        (), 2,
    ),
    Example(
        "emami_naeini_van_dooren_example_8",
        "JuliaControl/ControlSystems.jl lib/ControlSystemsBase/test/test_analysis.jl (Example 8: double "
        "zero at -1, published with atol 1e-6)",
        (
            (-2, 1, 0, 0, 0, 0),
            (1, -2, 1, 0, 1, -1),
            (0, 1, -2, 1, 0, 0),
            (0, 0, 1, -1, 0, 1),
            (0, -1, 0, 0, 0, 0),
            (0, 1, 0, -1, 0, 0),
        ),
        ((1,), (0,), (0,), (0,), (1,), (0,)), ((0, 0, 0, 1, 0, 0),), ((0,),),
        (-1.0, -1.0), 7, atol=1e-6,
    ),
    Example(
        "emami_naeini_van_dooren_example_9",
        "JuliaControl/ControlSystems.jl lib/ControlSystemsBase/test/test_analysis.jl (Example 9: "
        "(s - 20)/s^15 has the single zero 20; realized here in controllable form)",
        _rows(_A9), _rows(_B9), _rows(_C9), ((0,),),
        (20.0,), 16, discriminating=False,
    ),
    Example(
        "emami_naeini_van_dooren_example_11",
        "JuliaControl/ControlSystems.jl lib/ControlSystemsBase/test/test_analysis.jl (Example 11)",
        ((-2, -6, 3, -7, 6), (0, -5, 4, -4, 8), (0, 2, 0, 2, -2), (0, 6, -3, 5, -6), (0, -2, 2, -2, 5)),
        ((-2, 7), (-8, -5), (-3, 0), (1, 5), (-8, 0)),
        ((0, -1, 2, -1, -1), (1, 1, 1, 0, -1), (0, 3, -2, 3, -1)), ((0, 0), (0, 0), (0, 0)),
        (4.0, -3.0), 7,
    ),
    Example(
        "constructed_zeros_two_and_minus_one",
        "constructed: (s - 2)(s + 1) / ((s + 3)(s + 4)(s + 5)) in controllable form, zeros exactly 2 and -1",
        ((0, 1, 0), (0, 0, 1), (-60, -47, -12)), ((0,), (0,), (1,)), ((-2, -1, 1),), ((0,),),
        (2.0, -1.0), 4,
    ),
)

#: diagonal state scalings T = diag(2^k_i), k_i = round(linspace(0, spread, n)) (or reversed)
SCALINGS: tuple[tuple[str, int, bool], ...] = (
    ("unscaled", 0, False),
    ("spread_2^8", 8, False),
    ("spread_2^16", 16, False),
    ("spread_2^28", 28, False),
    ("reversed_spread_2^28", 28, True),
)


def _exponents(n: int, spread: int, reverse: bool) -> np.ndarray:
    k = np.round(np.linspace(0.0, float(spread), n)) if n > 1 else np.zeros(n)
    return k[::-1].copy() if reverse else k


def _scaled(ex: Example, spread: int, reverse: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    A, B, C, D = ex.system()
    t = 2.0 ** _exponents(A.shape[0], spread, reverse)  # powers of two: the scaling is exact
    return t[:, None] * A / t[None, :], t[:, None] * B, C / t[None, :], D


@lru_cache(maxsize=None)
def _analysis(name: str, spread: int, reverse: bool) -> PencilAnalysis:
    ex = next(e for e in EXAMPLES if e.name == name)
    return analyze_pencil(*_scaled(ex, spread, reverse))


CASES = [
    pytest.param(ex, spread, rev, id=f"{ex.name}-{label}") for ex in EXAMPLES for (label, spread, rev) in SCALINGS
]

# ------------------------------------------------------------------------------------------
# the oracle: balancing and the rank drop, independent of glocal_verify.numerics.pencil


def _balancing(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Power-of-two scalings (t, su, sy) in the spirit of SLICOT TB01ID / MatrixPencils lsbalance!.

    The balanced system is (T^-1 A T, T^-1 B Su, Sy C T, Sy D Su) with T = diag(t): its pencil is
    diag(T^-1, Sy) P(lam) diag(T, Su), so its rank at every lam is that of P(lam). The exponents
    minimize the sum of squared log2-magnitudes of the nonzero balanced entries (the diagonal of A
    is invariant and left out): a linear least-squares problem. A state scaling of the data by
    integer powers of two only shifts its solution, so the balanced system, and with it this
    oracle, is exactly the same for every scaling used in this file.
    """
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    rows: list[np.ndarray] = []
    rhs: list[float] = []

    def add(val: float, coef: dict[int, float]) -> None:
        r = np.zeros(n + m + p)
        for k, c in coef.items():
            r[k] += c
        rows.append(r)
        rhs.append(-float(np.log2(abs(val))))

    for i in range(n):
        for j in range(n):
            if i != j and A[i, j] != 0:
                add(A[i, j], {i: -1.0, j: 1.0})
        for j in range(m):
            if B[i, j] != 0:
                add(B[i, j], {i: -1.0, n + j: 1.0})
    for k in range(p):
        for j in range(n):
            if C[k, j] != 0:
                add(C[k, j], {n + m + k: 1.0, j: 1.0})
        for j in range(m):
            if D[k, j] != 0:
                add(D[k, j], {n + m + k: 1.0, n + j: 1.0})
    if not rows:
        return np.ones(n), np.ones(m), np.ones(p)
    x = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
    e = 2.0 ** np.round(x)
    return e[:n], e[n : n + m], e[n + m :]


def _balanced(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, lam: complex) -> tuple[np.ndarray, np.ndarray]:
    """(balanced pencil at lam, right scaling diag(T, Su)) for the system as given."""
    t, su, sy = _balancing(A, B, C, D)
    Pb = pencil_matrix(A / t[:, None] * t[None, :], B / t[:, None] * su[None, :], sy[:, None] * C * t[None, :], sy[:, None] * D * su[None, :], lam)
    return Pb, np.concatenate([t, su])


def _rank_drop(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, lam: complex, r: int) -> float:
    """sigma_r / sigma_1 of the balanced pencil at lam (r = the normal rank)."""
    Pb, _ = _balanced(A, B, C, D, lam)
    s = np.linalg.svd(Pb, compute_uv=False)
    return float(s[r - 1] / s[0]) if r >= 1 else 0.0


def _exact_rank(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, lam: Fraction) -> int:
    """Rank over Q of P(lam) (every double is a rational, so this is exact for the data given)."""
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    P = pencil_matrix(A, B, C, D, 0.0)
    rows = []
    for i in range(n + p):
        row = []
        for j in range(n + m):
            v = Fraction(float(P[i, j].real))
            if i < n and i == j:
                v += lam
            row.append(flint.fmpq(v.numerator, v.denominator))
        rows.append(row)
    return int(flint.fmpq_mat(n + p, n + m, [x for r in rows for x in r]).rank())


#: rational points where none of the examples has a zero
_RATIONAL_POINTS = (Fraction(7, 3), Fraction(-5, 2), Fraction(13, 11))
#: sigma_r / sigma_1 of the balanced pencil at a true zero (double zeros: ~eps after the split)
_DROP = 1e-8


def _expand(pa: PencilAnalysis) -> list[complex]:
    out: list[complex] = []
    for z in pa.zeros:
        out.extend([complex(z.value)] * z.multiplicity)
    return out


def _unmatched(found: list[complex], wanted: tuple[complex, ...], rtol: float, atol: float) -> tuple[list[complex], list[complex]]:
    """Greedy one-to-one matching: (found values without a partner, wanted values without one)."""
    left = list(wanted)
    extra: list[complex] = []
    for z in sorted(found, key=lambda c: (c.real, c.imag)):
        k = next((i for i, w in enumerate(left) if abs(z - w) <= rtol * abs(w) + atol), None)
        if k is None:
            extra.append(z)
        else:
            left.pop(k)
    return extra, left


# ------------------------------------------------------------------------------------------
# the oracle is sound on every example (so a failure below is the library's)


@pytest.mark.parametrize("ex, spread, rev", CASES)
def test_the_balanced_pencil_loses_rank_at_each_published_zero_and_not_beside_it(ex: Example, spread: int, rev: bool) -> None:
    """Sources: see ``EXAMPLES``. Checks the test's own oracle: the published zeros satisfy the
    defining property on the balanced (scaled) pencil, points next to them do not."""
    A, B, C, D = _scaled(ex, spread, rev)
    for w in ex.zeros:
        # published values carry few digits for some sources: slack atol/|w| on the drop
        assert _rank_drop(A, B, C, D, w, ex.normal_rank) <= max(_DROP, 100 * ex.atol), w
        off = w + 0.1 * (1.0 + abs(w))
        if ex.discriminating:
            assert _rank_drop(A, B, C, D, off, ex.normal_rank) > 1e-5, off


@pytest.mark.parametrize("ex, spread, rev", CASES)
def test_the_tabled_normal_rank_is_the_exact_rank_at_rational_points(ex: Example, spread: int, rev: bool) -> None:
    """Sources: see ``EXAMPLES``. The normal rank in the table equals the exact rank over Q of
    P(lam) at points that are no zero (max over three points), for the data as scaled."""
    A, B, C, D = _scaled(ex, spread, rev)
    assert max(_exact_rank(A, B, C, D, t) for t in _RATIONAL_POINTS) == ex.normal_rank


# ------------------------------------------------------------------------------------------
# analyze_pencil against the published answers


@pytest.mark.parametrize("ex, spread, rev", CASES)
def test_every_reported_zero_makes_the_balanced_pencil_lose_rank(ex: Example, spread: int, rev: bool) -> None:
    """Sources: see ``EXAMPLES``. Defining property: sigma_r(balanced P(z)) / ||.|| is tiny at
    every reported zero z, r = the published normal rank."""
    A, B, C, D = _scaled(ex, spread, rev)
    pa = _analysis(ex.name, spread, rev)
    drops = {z.value: _rank_drop(A, B, C, D, z.value, ex.normal_rank) for z in pa.zeros}
    assert all(v <= _DROP for v in drops.values()), drops


@pytest.mark.parametrize("ex, spread, rev", CASES)
def test_every_reported_direction_is_a_kernel_vector_of_the_balanced_pencil(ex: Example, spread: int, rev: bool) -> None:
    """Sources: see ``EXAMPLES``. P(z) [x; u] = 0: with P_b = L P(z) R balanced, R^-1 [x; u] is
    in the kernel of P_b up to a tiny relative residual."""
    A, B, C, D = _scaled(ex, spread, rev)
    pa = _analysis(ex.name, spread, rev)
    res = {}
    for z in pa.zeros:
        Pb, right = _balanced(A, B, C, D, z.value)
        w = np.concatenate([z.x, z.u]) / right
        res[z.value] = float(np.linalg.norm(Pb @ w) / (np.linalg.norm(Pb, 2) * np.linalg.norm(w)))
    assert all(v <= 1e-8 for v in res.values()), res


@pytest.mark.parametrize("ex, spread, rev", CASES)
def test_every_published_zero_is_found(ex: Example, spread: int, rev: bool) -> None:
    """Sources: see ``EXAMPLES``. Each published zero (with multiplicity) matches a reported one
    to a relative tolerance of 1e-6 (plus the digits the source published)."""
    _, missing = _unmatched(_expand(_analysis(ex.name, spread, rev)), ex.zeros, ex.rtol, ex.atol)
    assert missing == []


@pytest.mark.parametrize("ex, spread, rev", CASES)
def test_no_zero_outside_the_published_set_is_reported(ex: Example, spread: int, rev: bool) -> None:
    """Sources: see ``EXAMPLES``. A reported zero (with multiplicity) that is not among the
    published zeros is a spurious zero and fails."""
    extra, _ = _unmatched(_expand(_analysis(ex.name, spread, rev)), ex.zeros, ex.rtol, ex.atol)
    assert extra == []


@pytest.mark.parametrize("ex, spread, rev", CASES)
def test_the_normal_rank_is_the_published_one(ex: Example, spread: int, rev: bool) -> None:
    """Sources: see ``EXAMPLES`` (published where the source gives it, else the exact rank)."""
    pa = _analysis(ex.name, spread, rev)
    assert pa.normal_rank == ex.normal_rank
    assert pa.full_normal_column_rank == (ex.normal_rank == pa.n_states + pa.n_inputs)


@pytest.mark.parametrize("ex, spread, rev", CASES)
def test_the_analysis_is_decided(ex: Example, spread: int, rev: bool) -> None:
    """Sources: see ``EXAMPLES``. Well-posed examples with exactly known answers must not end in
    the undecided band, scaled or not."""
    pa = _analysis(ex.name, spread, rev)
    assert pa.decided, pa.notes


# ------------------------------------------------------------------------------------------
# the named hard cases


def _by_name(name: str) -> Example:
    return next(e for e in EXAMPLES if e.name == name)


def test_slicot_ab08nd_example_zeros_are_found() -> None:
    """SLICOT/SLICOT-Reference doc/AB08ND.html: finite invariant zeros 2 and -1, normal rank 8
    (MatrixPencils.jl test/test_sklfapps.jl)."""
    ex = _by_name("slicot_ab08nd")
    pa = analyze_pencil(*ex.system())
    assert pa.decided and pa.normal_rank == 8 and pa.full_normal_column_rank
    assert sorted(z.value.real for z in pa.zeros) == pytest.approx([-1.0, 2.0], rel=1e-9)
    assert all(abs(z.value.imag) < 1e-12 for z in pa.zeros)


def test_slicot_ab08nd_input_decoupling_zero_minus_four_is_not_an_invariant_zero() -> None:
    """SLICOT/SLICOT-Reference doc/AB08ND.html: -4 is an input decoupling zero of (A, B) but not
    an invariant zero of the non-square (9 x 8) pencil, which keeps full column rank there."""
    ex = _by_name("slicot_ab08nd")
    A, B, C, D = ex.system()
    assert _rank_drop(A, B, C, D, -4.0, 8) > 1e-3
    assert all(abs(z.value + 4.0) > 1e-3 for z in analyze_pencil(A, B, C, D).zeros)


@pytest.mark.parametrize("k", [4, 8, 12, 16, 20, 24, 28])
def test_slicot_ab08nd_zeros_survive_a_diagonal_state_scaling(k: int) -> None:
    """SLICOT/SLICOT-Reference doc/AB08ND.html under T = diag(2^(k i / 5)), i = 0..5: the zeros
    2, -1 and the normal rank 8 are invariant."""
    ex = _by_name("slicot_ab08nd")
    A, B, C, D = ex.system()
    t = 2.0 ** np.round(np.linspace(0, k, 6))
    pa = analyze_pencil(t[:, None] * A / t[None, :], t[:, None] * B, C / t[None, :], D)
    assert pa.decided, pa.notes
    assert pa.normal_rank == 8
    assert sorted(z.value.real for z in pa.zeros) == pytest.approx([-1.0, 2.0], rel=1e-6)


def test_emami_naeini_van_dooren_aircraft_example_is_decided_with_its_two_zeros() -> None:
    """JuliaControl/ControlSystems.jl lib/ControlSystemsBase/test/test_analysis.jl, Example 4:
    zeros -0.06467751189940692 and -0.3680512036036696 (entries of B down to 5e-6)."""
    ex = _by_name("emami_naeini_van_dooren_aircraft_example_4")
    pa = analyze_pencil(*ex.system())
    assert sorted(z.value.real for z in pa.zeros) == pytest.approx(sorted(w.real for w in ex.zeros), rel=1e-9)
    assert pa.normal_rank == 7
    assert pa.decided, pa.notes


def test_zeros_two_and_minus_one_survive_a_state_scaling_of_condition_2_to_the_28() -> None:
    """Constructed: (s - 2)(s + 1)/((s + 3)(s + 4)(s + 5)), T = diag(1, 2^14, 2^28)
    (cond T = 2^28); the zeros stay exactly 2 and -1."""
    ex = _by_name("constructed_zeros_two_and_minus_one")
    A, B, C, D = ex.system()
    t = 2.0 ** np.array([0.0, 14.0, 28.0])
    As, Bs, Cs = t[:, None] * A / t[None, :], t[:, None] * B, C / t[None, :]
    pa = analyze_pencil(As, Bs, Cs, D)
    assert sorted(z.value.real for z in pa.zeros) == pytest.approx([-1.0, 2.0], rel=1e-6)
    assert all(_rank_drop(As, Bs, Cs, D, z.value, 4) <= _DROP for z in pa.zeros)
    assert pa.normal_rank == 4 and pa.decided, pa.notes
