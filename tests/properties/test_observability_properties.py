"""Cross-validation of the unobservable-subspace machinery and the new checkers.

- the modal formula (structured) against exact rational ranks of the observability matrix
  (built here, over Q, as ground truth) and against the exact Krylov kernel;
- structured against the generic dense staircase (dimension and principal angles);
- unobservable basis vectors against the definition (scaled output derivatives vanish);
- numeric and exact verdicts of the new conditions agree (a numeric verdict may be
  ``undecided``; it may never contradict the exact one);
- two-mode schedules: the numeric switched dimension equals the exact one.
"""

from __future__ import annotations

from typing import Any

import flint
import numpy as np
from hypothesis import example, given
from hypothesis import strategies as st
from strategies import assert_numeric_matches_exact, systems
from test_observability import NEW_IDS

from glocal_verify import System, spec_from_dict
from glocal_verify.analysis.unobservable.switched import (
    switched_unobservable_bounds_exact,
    switched_unobservable_subspace,
)
from glocal_verify.analysis.unobservable.subspace import (
    unobservable_subspace,
    unobservable_subspace_exact,
)
from glocal_verify.numerics.staircase import unobservable_subspace_dense
from glocal_verify.numerics.tolerance import principal_sines


def exact_observability_rank(system: System, mode: str) -> int:
    """rank over Q of (C, CA, ..., CA^{2N-1}); tests only (forbidden in the library)."""
    n, n2 = system.n, 2 * system.n
    L = system.laplacian_exact(mode)
    al, ga = system.alpha_q, system.gamma_q
    A = flint.fmpq_mat(n2, n2)
    for i in range(n):
        A[i, n + i] = 1
        A[n + i, n + i] = flint.fmpq(-ga.numerator, ga.denominator)
        for j in range(n):
            x = -al * L[i][j]
            A[n + i, j] = flint.fmpq(x.numerator, x.denominator)
    C = system.C()
    if C.shape[0] == 0:
        return 0
    M = flint.fmpq_mat(C.astype(int).tolist())
    rows: list[list[Any]] = []
    for _ in range(n2):
        rows.extend([[M[r, c] for c in range(n2)] for r in range(M.nrows())])
        M = M * A
    return int(flint.fmpq_mat(rows).rank())


@given(systems(max_n=12))
def test_the_modal_formula_has_the_dimension_of_exact_observability_ranks(system: System) -> None:
    for mode in system.modes:
        S = unobservable_subspace(system, mode)
        truth = 2 * system.n - exact_observability_rank(system, mode)
        assert len(unobservable_subspace_exact(system, mode)) == truth
        assert S.dim <= truth <= S.dim_upper
        assert S.decided  # integer weights: no undecided gap or kernel at the default tolerance
        if truth:
            E = np.array([[float(x) for x in v] for v in unobservable_subspace_exact(system, mode)]).T
            Q, _ = np.linalg.qr(E)
            assert principal_sines(S.basis, Q).max() < 1e-7


# a hub of 30 agents with a 16-fold Laplacian eigenvalue and one velocity monitor: the dense
# staircase needs 25 steps and loses the true 35-dimensional subspace (found by the fuzz profile)
_HUB_EDGES = [[1, k, "1/2"] for k in (2, 4, 7, 8, 10, 12, 13, 14, 15, 16, 17, 20, 21, 23, 24, 25, 27, 29, 30)] + [
    [2, 3, "1/2"], [2, 5, "1/2"], [2, 6, 3], [2, 19, 3], [3, 9, "1/2"], [6, 11, "3/2"],
    [13, 18, "1/2"], [13, 26, "1/2"], [19, 28, "3/2"], [21, 22, "1/2"],
]
HUB30 = System(spec_from_dict({"format": 1, "graph": {"nodes": 30, "edges": _HUB_EDGES}, "monitor": {"velocities": [20]}}))
# an eigenvector entry of 4.7e-7 at the monitored agent 9: the modal method is undecided (fuzz profile)
_BAND_EDGES = [
    [1, 7, 2], [1, 21, "3/2"], [2, 3, "1/2"], [2, 5, 3], [2, 14, "1/2"], [3, 11, 2],
    [3, 19, "3/2"], [4, 13, "5/2"], [4, 19, 1], [5, 9, 1], [5, 21, 3], [6, 17, 3],
    [6, 22, "3/2"], [7, 22, "5/2"], [8, 9, "3/2"], [8, 12, 3], [9, 16, 1], [10, 23, 1],
    [11, 18, 1], [11, 23, 1], [15, 20, "5/2"], [17, 19, "1/2"], [20, 23, "5/2"],
]
BAND23 = System(spec_from_dict({"format": 1, "graph": {"nodes": 23, "edges": _BAND_EDGES}, "monitor": {"velocities": [9]}}))


@example(system=HUB30)
@example(system=BAND23)
@given(systems(max_n=30, integer=False))
def test_the_structured_and_the_dense_staircase_subspaces_agree(system: System) -> None:
    # the weights are rational, so the exact kernel arbitrates any disagreement
    for mode in system.modes:
        S = unobservable_subspace(system, mode)
        D = unobservable_subspace_dense(system.A(mode), system.C())
        if not S.decided:
            # e.g. an eigenvector entry of 4.7e-7 at the monitor: inside the undecided band
            assert S.dim <= len(unobservable_subspace_exact(system, mode)) <= S.dim_upper
            continue
        if not D.decided:
            continue
        if S.dim != D.dim:
            # the generic staircase is only backward stable; the modal result must be the exact one
            assert S.dim == len(unobservable_subspace_exact(system, mode)) != D.dim
            continue
        assert principal_sines(S.basis, D.basis).max(initial=0.0) < 1e-6
        assert principal_sines(D.basis, S.basis).max(initial=0.0) < 1e-6


@given(systems(max_n=14, integer=False))
def test_unobservable_basis_vectors_have_vanishing_output_derivatives(system: System) -> None:
    C = system.C()
    for mode in system.modes:
        S = unobservable_subspace(system, mode)
        A = system.A(mode)
        scale = max(np.linalg.norm(A, 2), 1.0)
        assert np.allclose(S.basis.T @ S.basis, np.eye(S.dim), atol=1e-10)
        for v in S.basis.T:
            x = v.copy()
            for k in range(5):
                assert np.linalg.norm(C @ x) <= 1e-9 * scale**k
                x = A @ x


@given(systems(max_n=12))
def test_numeric_and_exact_verdicts_of_the_new_conditions_agree(system: System) -> None:
    assert_numeric_matches_exact(system, NEW_IDS)


@given(systems(max_n=10, max_modes=2), st.floats(0.1, 3.0), st.floats(0.1, 3.0))
def test_two_mode_schedules_have_the_exact_dimension_for_every_dwell_time(system: System, t1: float, t2: float) -> None:
    for q in system.safe_modes:
        seq = [("normal", t1), (q, t2)]
        S = switched_unobservable_subspace(system, seq)
        b = switched_unobservable_bounds_exact(system, seq)
        assert b.exact_dimension
        if S.decided:
            assert S.dim == b.dim_lower
        # the consensus direction survives every schedule when no position is monitored
        if not system.monitored_positions:
            e = np.concatenate([np.ones(system.n), np.zeros(system.n)]) / np.sqrt(system.n)
            assert np.linalg.norm(e - S.basis @ (S.basis.T @ e)) < 1e-8
