"""local.pencil fails by a square restriction whose determinant is not constant modulo a prime: never where exact arithmetic finds full column rank."""

from __future__ import annotations

import itertools

import pytest

from glocal_verify import System
from glocal_verify.analysis.local.cases import LocalCase, _square_zero_mod_p
from glocal_verify.analysis.local.pencil import pencil_verdict, pencil_verdict_exact
from glocal_verify.design.generators import adverse_clustered_spec
from glocal_verify.results import Status


def _cases(system: System, limit: int) -> list[LocalCase]:
    out = []
    for c in system.clusters:
        cm = system.cluster_model(c.name)
        for obs in system.observers(c.name):
            for sus in itertools.islice(itertools.combinations(c.nodes, 2), limit):
                out.append(LocalCase(cm, obs, "attack", sus))
    return out


@pytest.mark.parametrize("seed", [0, 2])
def test_a_zero_proven_by_a_nonconstant_determinant_modulo_p_is_a_rank_loss_over_q(seed: int) -> None:
    spec = adverse_clustered_spec(40, cluster_size=20, degree=5.0, links="random", measure="neighbours", modes=0, attack=False, seed=seed)
    system = System(spec)
    proved = 0
    for case in _cases(system, 25):
        v = pencil_verdict(system, case, margin=False)
        if v.status is Status.HOLDS:
            assert _square_zero_mod_p(system, case, v.witness) is None or pencil_verdict_exact(system, case).status is Status.FAILS
            continue
        if _square_zero_mod_p(system, case, v.witness) is not None:
            proved += 1
            assert pencil_verdict_exact(system, case).status is Status.FAILS, case.suspected
    assert proved >= 1  # the pairs of these clusters include zeros the proof finds (19 and 2 of them)
