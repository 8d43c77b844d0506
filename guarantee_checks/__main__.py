"""Confirm the detection guarantees of the sampled paper19 deployment by simulation.

``python -m guarantee_checks`` writes ``reports/paper19/guarantees/`` (``guarantees.md``,
``guarantees.json`` and the figures): the certified thresholds at h = 0.01 with noise 1e-3,
an initial box of 1 and a disturbance of 1e-3; 10,000 attack-free runs (random, vertex and
worst-case) that must never cross them; the ZDA of case 2 detected within the certified times
in every simulated run; the smallest size guaranteed to be caught within 1 s, checked just
above and below it; the Gaussian variant; the sampled conditions and the pathological periods.
``--runs`` changes the number of attack-free runs, ``--out`` the folder.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from glocal_verify import System, load_example, verify
from glocal_verify.analysis.sampled.scan import scan_periods
from glocal_verify.errors import ArgumentError, GlocalVerifyError
from glocal_verify.reporting.figures.canvas import figure_bytes
from glocal_verify.reporting.figures.guarantees import detection_figure, detection_times_figure, period_scan_figure, thresholds_figure
from glocal_verify.reporting.output import check_output_dir, write_bytes_atomic, write_text_atomic
from glocal_verify.runtime.lines import write_line
from glocal_verify.runtime.processes import Stopped, signal_name, stop_on_signals
from glocal_verify.results import jsonable
from glocal_verify.simulation.certified_thresholds import certified_thresholds
from glocal_verify.simulation.guarantees import detection_guarantee
from glocal_verify.simulation.sampled_attack import sampled_attack_from_spec
from glocal_verify.simulation.escape import escape_run
from glocal_verify.simulation.sampled_runs import Target, plan_of_escape, simulate_sampled
from glocal_verify.spec import loads_spec
from glocal_verify.spec.writer import dump_spec

UNCERTAINTY = """
[uncertainty]
initial_state = 1
noise = 0.001
disturbance = 0.001

[implementation]
period = 0.01
controller = "sampled"
switch_delay = 1
"""

SIZE_HORIZON = 1.0


def _log(msg: str, t0: float) -> None:
    print(f"guarantee_checks: {msg} ({time.perf_counter() - t0:.1f} s)", file=sys.stderr, flush=True)


def paper19_sampled(extra: str = "") -> System:
    """paper19 with the deployment of this report (module docstring)."""
    return System(loads_spec(dump_spec(load_example("paper19")) + UNCERTAINTY + extra, source="<paper19 sampled>"))


def _targets(th: Any, count: int, rng: np.random.Generator) -> list[Target]:
    """Worst-case targets: every detector in turn, a channel and a sample at random (half of
    them in the first 2 s, where the thresholds move fastest), a random sign."""
    names = list(th.observers)
    out = []
    for i in range(count):
        name = names[i % len(names)]
        q = len(th.observers[name].channels)
        k = int(rng.integers(1, 200)) if i % 2 else int(rng.integers(1, th.horizon))
        out.append(Target(name, int(rng.integers(q)), k, float(rng.choice([-1.0, 1.0]))))
    return out


def _conservatism(th: Any, batch: Any, start: int) -> dict[str, dict[str, float]]:
    """theta / (largest simulated |r|) over samples k >= start: min and median per detector."""
    out = {}
    for name, o in th.observers.items():
        peak = batch.peak[name][start:]
        thr = o.theta[start:]
        ok = peak > 0
        ratio = thr[ok] / peak[ok]
        out[name] = {"min": float(ratio.min()), "median": float(np.median(ratio))} if ratio.size else {"min": float("nan"), "median": float("nan")}
    return out


#: the command's name in its messages
PROG = "python -m guarantee_checks"
#: fewest attack-free runs (each of the three kinds gets at least one) and attacked runs (both kinds)
MIN_RUNS, MIN_ATTACK_RUNS = 10, 2


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line (exit 2), as the ``glocal-verify`` command gives them."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise ArgumentError(message)


def _count(lo: int) -> Any:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lo}, got {text[:40]!r}") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lo}, got {value}")
        return value

    return parse


def main(argv: list[str] | None = None) -> int:
    """Run the checks (module docstring); bad arguments and a bad ``--out`` are one line, exit 2,
    before any work; a stop signal is one line, exit 130/143/129."""
    try:
        with stop_on_signals():
            return _main(argv)
    except GlocalVerifyError as exc:
        write_line(f"{PROG}: error: {exc}", fresh=True)
        return 2
    except Stopped as exc:
        write_line(f"{PROG}: stopped ({signal_name(exc.signum)})", fresh=True)
        return exc.exit_code
    except KeyboardInterrupt:
        write_line(f"{PROG}: interrupted", fresh=True)
        return 130


def _main(argv: list[str] | None) -> int:
    ap = _Parser(prog=PROG, description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=_count(MIN_RUNS), default=10_000, help=f"attack-free runs (split 40 %% random, 30 %% vertex, 30 %% worst case; at least {MIN_RUNS})")
    ap.add_argument("--attack-runs", type=_count(MIN_ATTACK_RUNS), default=1_000, help=f"attacked runs of the ZDA of case 2 (at least {MIN_ATTACK_RUNS})")
    ap.add_argument("--out", default="reports/paper19/guarantees", help="output folder (created when missing)")
    ap.add_argument("--seed", type=_count(0), default=2024, help="seed of the random runs (an integer >= 0)")
    args = ap.parse_args(argv)
    out = check_output_dir(args.out)  # before minutes of work
    t0 = time.perf_counter()
    rng = np.random.default_rng(args.seed)
    rep: dict[str, Any] = {"command": "python -m guarantee_checks" + ("" if argv is None else " " + " ".join(argv))}
    system = paper19_sampled()
    _log("verify sampled.* (numeric and exact)", t0)
    for exact in (False, True):
        r = verify(system, ["sampled.*"], exact=exact)
        rep["sampled_" + ("exact" if exact else "numeric")] = [{"id": c.id, "scope": dict(c.scope), "status": c.status.value, "margin": c.margin} for c in r.conditions]
    _log("certified thresholds", t0)
    t1 = time.perf_counter()
    th = certified_thresholds(system)
    rep["thresholds_seconds"] = time.perf_counter() - t1
    rep["thresholds"] = th.to_json()
    n_rand, n_vert = int(0.4 * args.runs), int(0.3 * args.runs)
    n_adv = args.runs - n_rand - n_vert
    batches = []
    for kind, n in (("random", n_rand), ("vertex", n_vert), ("adversarial", n_adv)):
        _log(f"{n} attack-free {kind} runs", t0)
        t1 = time.perf_counter()
        tg = _targets(th, n, rng) if kind == "adversarial" else None
        b = simulate_sampled(system, th, n, kind=kind, seed=int(rng.integers(2**31)), targets=tg, mode=None)
        batches.append(b)
        rep[f"attack_free_{kind}"] = {
            "runs": n,
            "seconds": time.perf_counter() - t1,
            "crossings": b.crossings,
            "switches": int(np.sum(b.switch >= 0)),
            "max_ratio": {k: float(v.max()) for k, v in b.max_ratio.items()},
            "conservatism_after_1s": _conservatism(th, b, int(round(1.0 / th.period))),
            "conservatism_all": _conservatism(th, b, 0),
        }
        if kind == "adversarial" and b.target_ratio is not None:
            tr = b.target_ratio[np.isfinite(b.target_ratio)]
            rep["attack_free_adversarial"]["target_ratio"] = {"min": float(tr.min()), "median": float(np.median(tr)), "max": float(tr.max())}
    rep["attack_free_total_runs"] = args.runs
    rep["attack_free_crossings"] = int(sum(sum(b.crossings.values()) for b in batches))
    # the ZDA of case 2 (and case 1)
    _log("detection guarantees (case 2, case 1)", t0)
    atk = sampled_attack_from_spec(system)
    g2 = detection_guarantee(system, mode="case-2", thresholds=th, size_horizon=SIZE_HORIZON)
    g1 = detection_guarantee(system, mode="case-1", thresholds=th, size_horizon=SIZE_HORIZON)
    rep["guarantee_case2"], rep["guarantee_case1"] = g2.to_json(), g1.to_json()
    assert g2.switch_thresholds is not None
    per = dict(g2.per_switch)
    local_name = g2.detected_by or "P1@5"
    lg = next(s for s in g2.local if s.observer == local_name)
    attacked = {}
    for kind in ("random", "vertex"):
        n = args.attack_runs // 2
        _log(f"{n} attacked {kind} runs (case 2)", t0)
        b = simulate_sampled(system, th, n, kind=kind, seed=int(rng.integers(2**31)), attack=atk, mode="case-2", switch_thresholds=g2.switch_thresholds, keep_traces=3 if kind == "random" else 0)
        fa = b.first_alarm[local_name]
        any_local = np.min(np.stack([np.where(v >= 0, v, 10**9) for k_, v in b.first_alarm.items() if k_ != "central"]), axis=0)
        ok_central = [bool(b.central_alarm[i] >= 0 and per.get(int(b.switch[i])) is not None and b.central_alarm[i] <= per[int(b.switch[i])]) for i in range(n)]
        attacked[kind] = {
            "runs": n,
            "local_alarm_max_s": float((any_local.max() - atk.start) * th.period),
            "local_alarm_certified_s": lg.within,
            "local_within_certificate": bool(np.all(any_local <= lg.guaranteed)) if lg.guaranteed is not None else False,
            "switch_range_s": [float(b.switch.min() * th.period), float(b.switch.max() * th.period)],
            "central_alarm_after_switch_max_s": float(((b.central_alarm - b.switch)[b.central_alarm >= 0]).max() * th.period) if np.any(b.central_alarm >= 0) else None,
            "central_within_certificate_all_runs": bool(all(ok_central)),
            "central_alarm_before_switch": int(np.sum(b.first_alarm["central"] >= 0)),
        }
        if kind == "random":
            fig_run = b
    rep["attacked_case2"] = attacked
    # the smallest size within 1 s, checked above and below
    _log("smallest guaranteed size within 1 s: above and below", t0)
    a_star = g2.min_size
    rep["min_size"] = {"size_horizon_s": SIZE_HORIZON, "certified": a_star}
    if a_star is not None:
        ka = atk.start
        kT = ka + int(round(SIZE_HORIZON / th.period))
        resp = g2.responses[local_name]
        th_l = th.observers[local_name].theta
        lo = np.maximum(np.abs(resp.rho) - resp.err, 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            need = np.where(lo[ka : kT + 1] > 0, 2 * th_l[ka : kT + 1] / lo[ka : kT + 1], np.inf)
        kk, jj = np.unravel_index(int(np.argmin(need)), need.shape)
        kb = ka + int(kk)
        checks: dict[str, Any] = {}
        a = 1.01 * a_star
        sign = -float(np.sign(resp.rho[kb, jj]))
        runs = {}
        # just above a*: the worst case against the binding sample, random and vertex runs
        for kind, n, t_ in (("adversarial", 1, [Target(local_name, int(jj), kb, sign)]), ("random", 250, None), ("vertex", 250, None)):
            b = simulate_sampled(system, th, n, kind=kind, seed=int(rng.integers(2**31)), attack=atk, size=a, targets=t_, mode=None)
            al = np.min(np.stack([np.where(v >= 0, v, 10**9) for v in b.first_alarm.values()]), axis=0)
            runs[kind] = {"runs": n, "detected_within_T": int(np.sum(al <= kT)), "latest_alarm_s": float((al.max() - ka) * th.period) if al.max() < 10**9 else None}
        checks["above"] = {"size": a, **runs}
        # below: the largest size some admissible run hides up to T (linear program), simulated
        esc = escape_run(system, th, g2, SIZE_HORIZON)
        pl = plan_of_escape(esc, th.period)
        for label, f in (("escape", 0.99), ("escape_limit", 1.0)):
            b = simulate_sampled(system, th, 1, kind="given", plans=[pl], attack=atk, size=f * esc.size, mode=None)
            al = min(int(v[0]) if v[0] >= 0 else 10**9 for v in b.first_alarm.values())
            checks[label] = {"size": f * esc.size, "first_alarm_s": al * th.period if al < 10**9 else None, "escapes_T": bool(al > kT)}
        checks["a_escape"] = esc.size
        checks["certificate_over_escape"] = a_star / esc.size
        rep["min_size"].update({"binding": {"observer": local_name, "channel": th.observers[local_name].channels[jj], "time_s": kb * th.period}, "checks": checks})
        rep["min_size_by_horizon"] = {f"{T:g}": detection_guarantee(system, mode="case-2", thresholds=th, size_horizon=T).min_size for T in (0.5, 2.0, 5.0)}
    # Gaussian variant
    _log("Gaussian noise: thresholds and false alarms", t0)
    gs = paper19_sampled().spec
    sysg = System(loads_spec(dump_spec(gs).replace("noise = 0.001", "noise = 0.001\nnoise_std = 0.0005\nfalse_alarm = 1e-6"), source="<paper19 sampled gaussian>"))
    thg = certified_thresholds(sysg)
    bg = simulate_sampled(sysg, thg, 1000, kind="random", seed=int(rng.integers(2**31)))
    rep["gaussian"] = {"false_alarm_bound": thg.false_alarm, "z": next(iter(thg.observers.values())).z, "runs": 1000, "crossings": bg.crossings}
    # pathological periods
    _log("pathological periods", t0)
    sc = scan_periods(system, 0.005, 2.0, controller="continuous")
    ss = scan_periods(system, 0.005, 2.0, controller="sampled")
    first = {}
    for p in sc.periods:
        first.setdefault(p.mode, p.to_json())
    rep["scan_continuous"] = {"count": sc.count, "first_per_mode": first}
    rep["scan_sampled"] = ss.to_json()
    # figures
    _log("figures", t0)
    figs = {
        "thresholds": thresholds_figure(th, batches),
        "detection": detection_figure(th, g2, fig_run, local_name, g2.switch_thresholds.theta, 0),
        "detection-times": detection_times_figure(g2, fig_run, local_name, th.period),
        "periods": period_scan_figure(sc, th.period),
    }
    for name, fig in figs.items():
        for ext, data in figure_bytes(fig).items():
            write_bytes_atomic(out / f"{name}.{ext}", data, create_parents=True)
    write_text_atomic(out / "guarantees.json", json.dumps(jsonable(rep), indent=1) + "\n", create_parents=True)
    write_text_atomic(out / "guarantees.md", _markdown(rep), create_parents=True)
    _log(f"wrote {out}", t0)
    return 0


def _fmt(x: Any) -> str:
    if x is None:
        return "-"
    if isinstance(x, float):
        return f"{x:.4g}"
    return str(x)


def _markdown(rep: dict[str, Any]) -> str:
    L = ["# Detection guarantees of the sampled paper19 deployment", "", f"Generated by `{rep['command']}`.", ""]
    L += ["Deployment: paper19 (Section IV), sampled-data consensus at h = 0.01 s with a zero-order hold,",
          "initial states in the box |x_i(0)|, |v_i(0)| <= 1, measurement noise |n| <= 0.001 on every",
          "channel of every detector, acceleration disturbance |d| <= 0.001; switch one period after the",
          "first local alarm. What the numbers mean: [../../../docs/guarantees.md](../../../docs/guarantees.md).", ""]
    L += ["## Sampled conditions", "", "| id | scope | numeric | exact |", "|---|---|---|---|"]
    for a, b in zip(rep["sampled_numeric"], rep["sampled_exact"]):
        L.append(f"| `{a['id']}` | {a['scope']} | {a['status']} | {b['status']} |")
    L += ["", "## Certified thresholds", "", f"Computed in {rep['thresholds_seconds']:.2f} s.", "",
          "| detector | peak (t = 0) | tail (t >= 30 s) | slack | window m0 | ||F^m0|| |", "|---|---|---|---|---|---|"]
    for name, o in rep["thresholds"]["observers"].items():
        L.append(f"| {name} | {_fmt(max(o['peak'].values()))} | {_fmt(max(o['tail'].values()))} | {_fmt(o['slack'])} | {o['certificate']['window']} | {_fmt(o['certificate']['theta_M'])} |")
    L += ["", f"## {rep['attack_free_total_runs']} attack-free runs", "",
          f"Crossings of a certified threshold: **{rep['attack_free_crossings']}**.", "",
          "| runs | kind | seconds | largest r / theta (any detector) | theta / largest r after 1 s, min (median) per detector |", "|---|---|---|---|---|"]
    for kind in ("random", "vertex", "adversarial"):
        b = rep[f"attack_free_{kind}"]
        cons = "; ".join(f"{k} {v['min']:.3g} ({v['median']:.3g})" for k, v in b["conservatism_after_1s"].items())
        L.append(f"| {b['runs']} | {kind} | {b['seconds']:.1f} | {max(b['max_ratio'].values()):.10f} | {cons} |")
    tr = rep["attack_free_adversarial"].get("target_ratio")
    if tr:
        L += ["", f"Worst-case runs reach their target's threshold within a factor {tr['min']:.6f} - {tr['max']:.10f} (|r| / theta at the target sample): the threshold is the exact worst case, up to its stated slack."]
    g = rep["guarantee_case2"]
    L += ["", "## The ZDA of case 2", "", f"Certified (size {g['size']:g}, {g['attack']['kind']} at z = {_fmt(abs(complex(*g['attack']['z'])) if isinstance(g['attack']['z'], list) else g['attack']['z'])}): status **{g['status']}**; "
          f"detected by {g['detected_by']} within {_fmt(g['within'])} s; switch window {g['switch_window']}; control centre within {_fmt(g['global_within'])} s of the switch "
          f"({_fmt(g['global_detection'])} s after the attack starts). Case 1: **{rep['guarantee_case1']['status']}** ({'; '.join(rep['guarantee_case1']['notes'])}).", "",
          "| runs | kind | latest local alarm (certified) | local within certificate | latest central alarm after the switch (certified) | central within certificate in every run |", "|---|---|---|---|---|---|"]
    for kind, a in rep["attacked_case2"].items():
        L.append(f"| {a['runs']} | {kind} | {_fmt(a['local_alarm_max_s'])} s ({_fmt(a['local_alarm_certified_s'])} s) | {a['local_within_certificate']} | {_fmt(a['central_alarm_after_switch_max_s'])} s ({_fmt(g['global_within'])} s) | {a['central_within_certificate_all_runs']} |")
    m = rep["min_size"]
    L += ["", f"## Smallest size caught within {m['size_horizon_s']:g} s", "", f"Certified: a* = {_fmt(m['certified'])} (binding: {m.get('binding')}); other horizons: {rep.get('min_size_by_horizon')}.", ""]
    ch = m.get("checks", {})
    if ch:
        ab = ch["above"]
        parts = ", ".join(f"{k}: {v['detected_within_T']}/{v['runs']}" for k, v in ab.items() if isinstance(v, dict))
        L.append(f"- just above, 1.01 a* = {_fmt(ab['size'])}: detected within T in every run ({parts}; the worst case is the one against the binding sample).")
        L.append(f"- below: the largest size that some admissible run hides from every detector up to T is a_escape = {_fmt(ch['a_escape'])} (linear program over the initial state, each detector's noise and a held disturbance); "
                 f"the certificate's a* is {_fmt(ch['certificate_over_escape'])} times it. That run, simulated at 0.99 a_escape = {_fmt(ch['escape']['size'])}: first alarm at {_fmt(ch['escape']['first_alarm_s'])} s, escapes T: {ch['escape']['escapes_T']}. "
                 f"Between a_escape and a* detection within T holds in every run found, but the pointwise certificate does not prove it.")
    gs = rep["gaussian"]
    L += ["", "## Gaussian noise", "", f"noise_std = 0.0005 on top of the bounded noise, false_alarm = 1e-6: z = {_fmt(gs['z'])}, certified false-alarm bound over the horizon {_fmt(gs['false_alarm_bound'])}; {gs['runs']} random runs, crossings {gs['crossings']}."]
    L += ["", "## Pathological periods in [0.005, 2] s", "", f"Continuous loop: {rep['scan_continuous']['count']} periods; the first per mode:", ""]
    for mode, p in rep["scan_continuous"]["first_per_mode"].items():
        L.append(f"- {mode}: h* = {p['period']:.6g} s ({p['kind']}, mu = {p['mu']}, fails {p['fails']}, observability loss {p['observability_loss']})")
    L += ["", "Sampled controller: " + "; ".join(rep["scan_sampled"]["persistent"]), "",
          "Figures: `thresholds.png`, `detection.png`, `detection-times.png`, `periods.png` (and `.svg`).", ""]
    return "\n".join(L)


if __name__ == "__main__":
    sys.exit(main())
