"""The bundled paper19 example fits the sentences of Section IV its comments cite."""

from __future__ import annotations

import numpy as np
import pytest

from glocal_verify import System, load_example, verify
from glocal_verify.results import Status


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


def _status(system: System, cid: str, mode: str, exact: bool = False) -> Status:
    (r,) = [r for r in verify(system, [cid], exact=exact).conditions if r.scope.get("mode") == mode]
    return r.status


def test_paper19_has_the_sizes_and_monitors_of_section_iv(paper19: System) -> None:
    assert paper19.n == 19
    assert [c.nodes for c in paper19.clusters] == [tuple(range(1, 8)), tuple(range(8, 13)), tuple(range(13, 20))]
    assert paper19.monitored_positions == () and paper19.monitored_velocities == (7, 12, 14)
    assert paper19.attacked == (3, 4)
    assert 5 in [o.center for o in paper19.observers("P1")] and len(paper19.observers("P1")) == 2


def test_the_zda_direction_of_s6_moves_only_agents_3_and_4(paper19: System) -> None:
    xi = np.zeros(19)
    xi[paper19.idx([3, 4])] = [1.0, -2.0]
    L = paper19.laplacian()
    for s in (0.3, 1.0, 2.5):  # any s = lam^2 + gamma lam
        r = (s * np.eye(19) + paper19.alpha * L) @ xi
        assert set(np.flatnonzero(np.abs(r) > 1e-12)) <= set(paper19.idx([3, 4]))


@pytest.mark.parametrize("exact", [False, True])
def test_cases_1_and_2_meet_theorem_iii3_and_case_3_meets_none(paper19: System, exact: bool) -> None:
    for cid in ("switching.image-kernel", "switching.distinct-eigenvalues"):
        assert _status(paper19, cid, "case-1", exact) is Status.HOLDS
        assert _status(paper19, cid, "case-2", exact) is Status.HOLDS
        assert _status(paper19, cid, "case-3", exact) is Status.FAILS


def test_case_1_avoids_the_attacked_agents_and_case_2_touches_them(paper19: System) -> None:
    xi = np.zeros(19)
    xi[paper19.idx([3, 4])] = [1.0, -2.0]
    assert np.allclose(paper19.delta_laplacian("case-1") @ xi, 0.0)
    assert not np.allclose(paper19.delta_laplacian("case-2") @ xi, 0.0)
