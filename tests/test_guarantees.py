"""Certified thresholds and detection guarantees of the sampled paper19 deployment, confirmed by
simulation (a small subset of ``python -m guarantee_checks``; horizon 10 s)."""

from __future__ import annotations

import numpy as np
import pytest

from glocal_verify import System, load_example, loads_spec, verify
from glocal_verify.observers.sampled import to_float
from glocal_verify.results import Status
from glocal_verify.simulation.certified_thresholds import certified_thresholds
from glocal_verify.simulation.escape import escape_run
from glocal_verify.simulation.guarantees import detection_guarantee
from glocal_verify.simulation.sampled_attack import sampled_attack_from_spec
from glocal_verify.simulation.sampled_runs import Target, plan_of_escape, simulate_sampled
from glocal_verify.spec.writer import dump_spec

DEPLOYMENT = """
[uncertainty]
initial_state = 1
noise = 0.001
disturbance = 0.001

[implementation]
period = 0.01
"""


def _system(extra: str = "") -> System:
    text = dump_spec(load_example("paper19")).replace("horizon = 30.0", "horizon = 10.0") + DEPLOYMENT + extra
    return System(loads_spec(text))


@pytest.fixture(scope="module")
def deployed() -> tuple[System, object, object]:
    sy = _system()
    th = certified_thresholds(sy)
    g = detection_guarantee(sy, mode="case-2", thresholds=th, size_horizon=1.0)
    return sy, th, g


def test_the_threshold_is_the_supremum_of_the_attack_free_residual(deployed: tuple) -> None:
    # brute force on the error equation of one local observer: sum of |impulse responses|
    sy, th, _ = deployed
    det = next(o for o in th.detectors if o.name == "P1@5")
    f = det.floats()
    t = th.observers["P1@5"]
    K = 40
    eps = f["Px"] @ np.eye(2 * sy.n)
    init = np.zeros((K, len(det.channels)))
    noise = np.zeros((K, len(det.channels)))
    nbar = th.model.noise(det.channels)
    resp = []
    for k in range(K):
        init[k] = np.abs(f["Ce"] @ eps).sum(axis=1)
        eps = f["F"] @ eps
        resp.append(np.abs(f["Ce"] @ np.linalg.matrix_power(f["F"], k) @ f["Kn"]) @ nbar)
    for k in range(1, K):
        noise[k] = np.sum(resp[:k], axis=0)
    noise += np.abs(f["Dn"]) @ nbar
    brute = init + noise
    assert np.all(t.parts["initial"][:K] + t.parts["noise"][:K] >= brute * (1 - 1e-12))
    assert np.allclose(t.parts["initial"][:K] + t.parts["noise"][:K], brute, rtol=1e-9)


def test_no_attack_free_run_crosses_a_certified_threshold(deployed: tuple) -> None:
    sy, th, _ = deployed
    rng = np.random.default_rng(0)
    names = list(th.observers)
    targets = [Target(names[i % len(names)], int(rng.integers(len(th.observers[names[i % len(names)]].channels))), int(rng.integers(1, 300)), float(rng.choice([-1, 1]))) for i in range(30)]
    for kind, n, tg in (("random", 60, None), ("vertex", 60, None), ("adversarial", 30, targets)):
        b = simulate_sampled(sy, th, n, kind=kind, seed=1, targets=tg)
        assert sum(b.crossings.values()) == 0, (kind, b.crossings)
        assert max(float(v.max()) for v in b.max_ratio.values()) <= 1.0
        if kind == "adversarial":
            # the worst case is attained: the threshold is tight up to its stated slack
            assert b.target_ratio is not None and np.nanmin(b.target_ratio) > 0.999


def test_the_zda_response_is_the_simulated_attack_part(deployed: tuple) -> None:
    sy, th, g = deployed
    atk = sampled_attack_from_spec(sy)
    from glocal_verify.analysis.sampled.loop import sampled_matrices

    Phi, Gam = sampled_matrices(sy)
    det = next(o for o in th.detectors if o.name == "P1@5")
    f = det.floats()
    x, z = np.real(atk.x0).copy(), np.zeros(det.order)
    U = atk.inputs(200)
    r = g.responses["P1@5"]
    for k in range(200):
        res = f["Ry"] @ (f["C"] @ x) - f["Rz"] @ z
        assert np.all(np.abs(res - r.rho[k]) <= r.err[k] + 1e-12)
        z = f["Fo"] @ z + f["Go"] @ (f["C"] @ x)
        x = Phi @ x + Gam[:, sy.idx(atk.actuators)] @ U[k]


def test_the_zda_of_case_2_is_detected_within_the_certified_times(deployed: tuple) -> None:
    sy, th, g = deployed
    assert g.status is Status.HOLDS and g.detected_by == "P1@5" and g.global_within is not None
    atk = sampled_attack_from_spec(sy)
    per = dict(g.per_switch)
    lg = next(s for s in g.local if s.observer == "P1@5")
    for kind in ("random", "vertex"):
        b = simulate_sampled(sy, th, 30, kind=kind, seed=2, attack=atk, mode="case-2", switch_thresholds=g.switch_thresholds)
        first_local = np.min(np.stack([np.where(v >= 0, v, 10**9) for k, v in b.first_alarm.items() if k != "central"]), axis=0)
        assert np.all(first_local <= lg.guaranteed)
        assert np.all((b.switch >= 0) & (b.switch <= lg.guaranteed + 1))
        assert all(0 <= b.central_alarm[i] <= per[int(b.switch[i])] for i in range(b.runs))
        assert np.all(b.first_alarm["central"] < 0)  # stealthy before the switch


def test_case_1_fails_by_a_proven_escape(deployed: tuple) -> None:
    sy, th, _ = deployed
    g1 = detection_guarantee(sy, mode="case-1", thresholds=th)
    assert g1.status is Status.FAILS and g1.caught_locally


@pytest.mark.slow
def test_the_smallest_guaranteed_size_is_checked_above_and_below(deployed: tuple) -> None:
    sy, th, g = deployed
    a_star = g.min_size
    assert a_star is not None
    atk = sampled_attack_from_spec(sy)
    kT = 100
    b = simulate_sampled(sy, th, 40, kind="vertex", seed=3, attack=atk, size=1.01 * a_star)
    first = np.min(np.stack([np.where(v >= 0, v, 10**9) for v in b.first_alarm.values()]), axis=0)
    assert np.all(first <= kT)
    esc = escape_run(sy, th, g, 1.0)
    assert esc.size <= a_star
    b = simulate_sampled(sy, th, 1, kind="given", plans=[plan_of_escape(esc, th.period)], attack=atk, size=0.99 * esc.size)
    assert min(int(v[0]) if v[0] >= 0 else 10**9 for v in b.first_alarm.values()) > kT


def test_gaussian_thresholds_bound_the_false_alarm_probability() -> None:
    sy = _system().spec
    text = dump_spec(sy).replace("noise = 0.001", "noise = 0.001\nnoise_std = 0.0005\nfalse_alarm = 1e-3")
    s2 = System(loads_spec(text))
    th = certified_thresholds(s2)
    assert th.false_alarm is not None and th.false_alarm <= 1e-3 * (1 + 1e-9)
    b = simulate_sampled(s2, th, 50, kind="random", seed=4)
    assert sum(b.crossings.values()) == 0


@pytest.mark.slow
def test_the_detection_checkers_report_through_verify() -> None:
    sy = _system()
    rep = verify(sy, ["detection.*"])
    got = {(r.id, tuple(sorted(r.scope.items()))): r.status for r in rep.conditions}
    assert got[("detection.guarantee", (("mode", "case-2"),))] is Status.HOLDS
    assert got[("detection.local-alarm", (("observer", "P1@5"),))] is Status.HOLDS
    assert got[("detection.local-alarm", (("observer", "P2@10"),))] is Status.FAILS
    assert all(got[k] is Status.HOLDS for k in got if k[0] == "detection.thresholds")
    w = rep.results("detection.guarantee")[0].witness
    assert w["detected_by"] == "P1@5" and w["global_within"] > 0
    assert np.all(np.isfinite(to_float(next(iter(sy.analysis[("sampled-deployment",)].thresholds.certified.detectors)).F)))


@pytest.mark.slow
def test_the_assessment_reads_the_deployment_guarantee_into_the_answer() -> None:
    import json

    from glocal_verify.reporting.render import to_json_text, to_markdown, validate_report_json

    rep = verify(_system(), ["stealthy.*", "local.*", "switching.*", "detection.*"], escalate="never", simulate="never")
    a = rep.assessment
    assert a is not None and a.attack.deployment is not None
    g = rep.results("detection.guarantee")[0]
    assert a.attack.deployment.guaranteed is (g.status is Status.HOLDS) is True
    assert a.attack.deployment.detection_time == g.witness["global_detection"] and a.attack.deployment.mode == g.scope["mode"]
    assert "sampled deployment: guaranteed" in a.headline()
    assert "in the sampled deployment (detection.*): **guaranteed**" in to_markdown(rep)
    data = json.loads(to_json_text(rep))
    validate_report_json(data)
    assert data["assessment"]["attack"]["deployment"]["guaranteed"] is True
    assert {"detection.thresholds", "detection.guarantee"} <= set(a.based_on)
