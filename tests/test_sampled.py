"""The sampled implementation: modal blocks against dense and exact discretisations, the h scan,
the sampling zero at -1, the sampled UIO's exact decoupling."""

from __future__ import annotations

import math
from fractions import Fraction

import flint
import networkx as nx
import numpy as np
import pytest

from glocal_verify import System, load_example, spec_from_graph, verify
from glocal_verify.analysis.sampled.loop import (
    exact_unobservable_dimension,
    sampled_aliasing,
    sampled_matrices,
    sampled_matrices_exact,
    sampled_modes,
    sampled_observability,
    sampled_stability,
)
from glocal_verify.analysis.sampled.scan import scan_periods
from glocal_verify.analysis.sampled.zda import sampled_zda
from glocal_verify.analysis.unobservable.subspace import unobservable_subspace_exact
from glocal_verify.numerics.hurwitz import schur_cohn as schur_stable_exact
from glocal_verify.observers.sampled import sampled_cluster_model, to_float
from glocal_verify.results import Status
from glocal_verify.spec.types import ImplementationSpec

H100 = Fraction(1, 100)


def _small(seed: int, monitors: tuple[int, ...] = (1,)) -> System:
    rng = np.random.default_rng(seed)
    G = nx.connected_watts_strogatz_graph(6, 2, 0.5, seed=seed)
    G = nx.relabel_nodes(G, {i: i + 1 for i in G.nodes})
    for u, v in G.edges:
        G[u][v]["weight"] = int(rng.integers(1, 4))
    return System(spec_from_graph(G, monitor_velocities=list(monitors), attack={"kind": "zda", "actuators": [3, 4]}))


@pytest.mark.parametrize("controller", ["sampled", "continuous"])
def test_the_modal_blocks_carry_the_eigenvalues_of_the_dense_sampled_matrix(controller: str) -> None:
    sy = System(load_example("paper19"))
    impl = ImplementationSpec(H100, controller=controller)
    for mode in ("normal", "case-2"):
        sm = sampled_modes(sy, mode, impl)
        Phi, Gam = sampled_matrices(sy, mode, impl)
        dense = np.sort_complex(np.linalg.eigvals(Phi))
        modal = np.sort_complex(sm.z.reshape(-1))
        assert np.max(np.abs(dense - modal)) < 1e-12
        U = sy.eigh(mode)[1]
        n = sy.n
        assert np.allclose(np.diag(U.T @ Gam[:n] @ U), sm.inputs[:, 0], atol=1e-14)
        assert np.allclose(np.diag(U.T @ Gam[n:] @ U), sm.inputs[:, 1], atol=1e-14)


def test_the_continuous_loops_enclosure_contains_the_dense_exponential_and_its_eigenvalues() -> None:
    sy = _small(3)
    impl = ImplementationSpec(Fraction(1, 7), controller="continuous")
    Phi, _ = sampled_matrices(sy, "normal", impl)
    P, _ = sampled_matrices_exact(sy, "normal", impl)
    n2 = 2 * sy.n
    assert all(abs(float(P[i, j].mid()) - Phi[i, j]) <= float(P[i, j].rad()) + 1e-14 for i in range(n2) for j in range(n2))
    enc = flint.acb_mat(P).eig()
    sm = sampled_modes(sy, "normal", impl)
    for e in enc:
        z = complex(float(e.real.mid()), float(e.imag.mid()))
        assert np.min(np.abs(sm.z.reshape(-1) - z)) <= 1e-9


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
@pytest.mark.parametrize("h", [Fraction(1, 100), Fraction(1, 3), Fraction(7, 5)])
@pytest.mark.parametrize("controller", ["sampled", "continuous"])
def test_sampled_verdicts_agree_with_exact_arithmetic_on_the_discretisation(seed: int, h: Fraction, controller: str) -> None:
    sy = _small(seed)
    impl = ImplementationSpec(h, controller=controller)
    for f in (sampled_stability, sampled_aliasing, sampled_observability):
        num, ex = f(sy, "normal", impl).status, f(sy, "normal", impl, exact=True).status  # type: ignore[operator]
        assert ex is not Status.UNDECIDED
        assert num in (ex, Status.UNDECIDED), (f.__name__, num, ex)
    if controller == "sampled":
        # the definitions over Q: the Krylov closure of (Phi, C) and a Schur-Cohn test of Phi
        # without its consensus eigenvalue
        Phi, _ = sampled_matrices_exact(sy, "normal", impl)
        C = flint.fmpq_mat([[int(x) for x in row] for row in sy.C()])
        same = exact_unobservable_dimension(Phi, C) == len(unobservable_subspace_exact(sy))
        assert (sampled_observability(sy, "normal", impl, exact=True).status is Status.HOLDS) == same
        chi = Phi.charpoly()
        q, r = divmod(chi, flint.fmpq_poly([-1, 1]))
        assert r == 0
        assert (sampled_stability(sy, "normal", impl, exact=True).status is Status.HOLDS) == schur_stable_exact(q)


def test_a_sampled_controller_is_unstable_beyond_its_largest_stable_period() -> None:
    sy = System(load_example("paper19"))
    lim = sampled_stability(sy, "normal", ImplementationSpec(H100)).limit_period
    assert lim is not None and 0.16 < float(lim) < 0.17
    for h, want in ((Fraction(16, 100), Status.HOLDS), (Fraction(17, 100), Status.FAILS)):
        impl = ImplementationSpec(h)
        assert sampled_stability(sy, "normal", impl).status is want
        assert sampled_stability(sy, "normal", impl, exact=True).status is want


def test_gamma_h_two_aliases_every_block_at_minus_one_and_hides_velocities() -> None:
    sy = _small(0)
    impl = ImplementationSpec(Fraction(2))
    assert sampled_aliasing(sy, "normal", impl).status is Status.FAILS
    so = sampled_observability(sy, "normal", impl, exact=True)
    assert so.status is Status.FAILS and so.dim_sampled is not None and so.dim_continuous is not None and so.dim_sampled > so.dim_continuous


def test_the_h_scan_finds_a_planted_pathological_period_and_the_rank_drop_is_real() -> None:
    # a path 1-2-3 (mu = 0, 1, 3), alpha = gamma = 1, one velocity monitor: the planted periods are
    # pi / omega(1) = 2 pi / sqrt 3 (the mu = 1 block becomes a multiple of I) and
    # 2 pi / (omega(1) + omega(3)) = 4 pi / (sqrt 3 + sqrt 11) (the two blocks alias)
    sy = System(spec_from_graph(nx.path_graph([1, 2, 3]), monitor_velocities=[1]))
    scan = scan_periods(sy, 0.5, 5.0, controller="continuous")
    planted = {"scalar-block": 2 * math.pi / math.sqrt(3), "aliasing": 4 * math.pi / (math.sqrt(3) + math.sqrt(11))}
    for kind, hstar in planted.items():
        p = min((q for q in scan.periods if q.kind == kind), key=lambda q: abs(q.period - hstar))
        assert p.enclosure[0] <= hstar <= p.enclosure[1]
        assert "sampled.observability" in p.fails and p.observability_loss >= 1
        # the generic dense method confirms it: the sampled observability matrix loses rank at h*
        ranks = []
        for h in (hstar, 1.05 * hstar):
            Phi, _ = sampled_matrices(sy, "normal", ImplementationSpec(Fraction(h), controller="continuous"))
            O = np.vstack([sy.C() @ np.linalg.matrix_power(Phi, k) for k in range(6)])
            s = np.linalg.svd(O, compute_uv=False)
            ranks.append(int(np.sum(s > 1e-9 * s[0])))
        assert ranks[0] < ranks[1] == 5  # dim N(A, C) = 1 (the consensus), one more at h*
    # a rational period near h* keeps every verdict, with a margin that shrinks towards h*
    near = sampled_aliasing(sy, "normal", ImplementationSpec(Fraction(3627598, 1000000), controller="continuous"))
    far = sampled_aliasing(sy, "normal", ImplementationSpec(Fraction(1), controller="continuous"))
    assert near.status is Status.HOLDS and near.margin < 1e-5 < far.margin


def test_the_sampling_zero_at_minus_one_moves_velocities_only_and_is_invisible() -> None:
    sy = System(load_example("paper19"))
    impl = ImplementationSpec(H100)
    za = sampled_zda(sy, impl)
    assert za.status is Status.HOLDS and za.nyquist == (3, 4)
    # the definition over Q: x~0 = [0; c S_F^T u0] with c = -h / (2 - gamma h) satisfies
    # Phi x~0 + Gamma_F u0 = -x~0 and C x~0 = 0
    Phi, Gam = sampled_matrices_exact(sy, "normal", impl)
    n = sy.n
    h, g = impl.period, sy.gamma_q
    c = -h / (2 - g * h)
    u0 = [Fraction(1), Fraction(-2)]
    x = flint.fmpq_mat(2 * n, 1)
    F = sy.idx([3, 4])
    for i, u in zip(F, u0):
        x[n + i, 0] = flint.fmpq(*(c * u).as_integer_ratio())
    u = flint.fmpq_mat(n, 1)
    for i, uu in zip(F, u0):
        u[i, 0] = flint.fmpq(*uu.as_integer_ratio())
    assert Phi * x + Gam * u == -x
    C = flint.fmpq_mat([[int(v) for v in row] for row in sy.C()])
    assert C * x == flint.fmpq_mat(C.nrows(), 1)


def test_the_sampled_zda_numeric_verdict_agrees_with_the_exact_pencil() -> None:
    for seed in (0, 1):
        sy = _small(seed, monitors=(1, 2, 3, 4, 5, 6))
        impl = ImplementationSpec(Fraction(1, 10))
        num, ex = sampled_zda(sy, impl), sampled_zda(sy, impl, exact=True)
        assert num.status in (ex.status, Status.UNDECIDED)


def test_the_sampled_uio_decouples_its_neighbours_exactly() -> None:
    sy = System(load_example("paper19"))
    impl = ImplementationSpec(H100)
    for lo in sy.observers():
        m = sampled_cluster_model(sy, lo, impl)
        assert m.T * m.E == flint.fmpq_mat(m.E.nrows(), m.E.ncols())
        assert np.all(np.isfinite(to_float(m.Abar)))


def test_schur_cohn_agrees_with_the_roots() -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        c = [Fraction(int(x), 8) for x in rng.integers(-9, 10, size=int(rng.integers(2, 7)))]
        if c[-1] == 0:
            continue
        p = flint.fmpq_poly([flint.fmpq(x.numerator, x.denominator) for x in c])
        r = np.roots([float(x) for x in reversed(c)])
        if np.any(np.abs(np.abs(r) - 1) < 1e-9):
            continue
        assert schur_stable_exact(p) == bool(np.all(np.abs(r) < 1))


def test_verify_runs_the_sampled_checks_only_with_an_implementation() -> None:
    sy = System(load_example("paper19"))
    assert verify(sy, ["sampled.*"]).conditions == ()
