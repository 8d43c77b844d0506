"""``stealthy.zda`` on the structured family: the share of networks left undecided, per range of N.

The family (:func:`glocal_verify.design.generators.structured_family`) spans the adverse end of
what makes the ZDA's zero set hard to certify: 2-4 identical copies of 15-50 agents (joined on a
hub, in a ring, or asymmetrically), 10-40 twin leaves, weights p^2 / 10^6 or p^2 / 10^7 for the
largest primes below 2^24 and 2^30, symmetries broken by 10^-9..10^-15 in one weight, position
and velocity monitors in different amounts, a ZDA of 2-3 agents inside a copy, across copies or
on twins, 0-2 safe modes.

Each member runs numeric ``verify`` of ``stealthy.zda`` alone (no escalation, no simulation) in
a forked child process with a time budget; a member out of its budget counts as undecided (not
finished). Per range (N = 60-105 and 120-200, ``MEMBERS`` members each, spread over four sizes)
the rows give the share of networks whose ``stealthy.zda`` is undecided (goal of issue 47:
<= 1 %) and the worst member's time against one ``numpy.linalg.eigh`` of its Laplacian. A third
row is the never-wrong evidence: small members (N = 20-40) decided numerically and over Q
(``ZdaOptions(exact=True)``, within a budget), counting contradictions (goal: none; the
property test ``tests/properties/test_structured_vs_exact.py`` checks the same).
"""

from __future__ import annotations

import multiprocessing
import os
import time
from typing import Any

from glocal_verify import System
from glocal_verify.design.generators import StructuredMember, structured_family

from .harness import Row, eigh_seconds

#: members per range of N (spread over four sizes)
MEMBERS = int(os.environ.get("GLOCAL_BENCH_STRUCTURED_MEMBERS", "40"))

#: longest one member may run (numeric verify of stealthy.zda) before it counts as not finished
BUDGET = float(os.environ.get("GLOCAL_BENCH_STRUCTURED_BUDGET", "30"))

#: the goal of issue 47: networks with stealthy.zda undecided, per range
UNDECIDED_GOAL = 0.01

RANGES = {"N = 60-105": (60, 75, 90, 105), "N = 120-200": (120, 147, 173, 200)}

GROUP = "structured family: stealthy.zda on identical copies, twin leaves, prime-square weights, broken symmetries (numeric verify in a forked child; ratio = eigh / verify)"


def _numeric(member: StructuredMember) -> tuple[str, str]:
    from glocal_verify import verify

    report = verify(System(member.spec()), ["stealthy.zda"], escalate="never", simulate="never")
    r = next(c for c in report.conditions if c.id == "stealthy.zda")
    return r.status.value, r.note


def _exact_pair(member: StructuredMember) -> tuple[str, str]:
    from glocal_verify.analysis.stealthy.zda_verdict import ZdaOptions, decide_zda

    system = System(member.spec())
    return decide_zda(system).status.value, decide_zda(system, options=ZdaOptions(exact=True)).status.value


def _child(conn: Any, func: Any, member: StructuredMember) -> None:
    t0 = time.perf_counter()
    try:
        out = func(member)
    except Exception as err:  # reported as a result, never a crash of the benchmark
        out = ("error", f"{type(err).__name__}: {err}"[:200])
    conn.send((*out, time.perf_counter() - t0))
    conn.close()


def _in_child(func: Any, member: StructuredMember, budget: float) -> tuple[str, str, float]:
    """``func(member)`` in a forked child: (first, second, seconds), or ('not finished', '', budget)."""
    ctx = multiprocessing.get_context("fork")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(child, func, member))
    proc.start()
    child.close()
    if parent.poll(budget):
        out = parent.recv()
        proc.join()
        return out  # type: ignore[no-any-return]
    proc.kill()
    proc.join()
    return "not finished", "", budget


def _range_rows(name: str, sizes: tuple[int, ...], per_size: int) -> list[Row]:
    runs: list[dict[str, Any]] = []
    for n in sizes:
        for m in structured_family(n, per_size):
            status, note, seconds = _in_child(_numeric, m, BUDGET)
            runs.append({"member": m, "status": status, "note": note, "seconds": seconds, "eigh": eigh_seconds(System(m.spec()).laplacian())})
    undecided = [r for r in runs if r["status"] not in ("holds", "fails")]
    share = len(undecided) / len(runs) if runs else 0.0
    worst = max(runs, key=lambda r: r["seconds"] / r["eigh"] if r["eigh"] > 0 else float("inf"))
    total = sum(r["seconds"] for r in runs)
    why = "; ".join(f"N = {r['member'].n} {r['member'].label}: {r['status']} ({r['note'][:120]})" for r in undecided[:6])
    ratio = worst["seconds"] / worst["eigh"] if worst["eigh"] > 0 else float("nan")
    return [
        Row(GROUP, f"{name}, undecided over {len(runs)} networks", "-", None, "verify stealthy.zda", total,
            f"{100 * share:.1f} % of networks undecided or not finished in {BUDGET:g} s (goal <= {100 * UNDECIDED_GOAL:g} %)" + (f"; {why}" if why else ""),
            None, f"{len(undecided)} of {len(runs)}"),
        Row(GROUP, f"{name}, worst of {len(runs)} members", f"one eigh of L ({worst['member'].n} x {worst['member'].n})", worst["eigh"],
            "verify stealthy.zda", worst["seconds"], f"{worst['member'].label}; {ratio:.0f} x eigh; {worst['status']}", None,
            "1 of 1" if worst["status"] not in ("holds", "fails") else "0 of 1"),
    ]


def _never_wrong_row(count: int) -> Row:
    compared = contradicted = unfinished = 0
    t0 = time.perf_counter()
    for n in (20, 30, 40):
        for m in structured_family(n, count):
            numeric, exact, _ = _in_child(_exact_pair, m, BUDGET)
            if numeric == "not finished" or exact not in ("holds", "fails"):
                unfinished += 1
                continue
            compared += 1
            contradicted += numeric in ("holds", "fails") and numeric != exact
    return Row(GROUP, f"N = 20-40, numeric against exact on {3 * count} members", "-", None, "decide_zda numeric and exact", time.perf_counter() - t0,
               f"{contradicted} contradicted of {compared} compared (goal: none); {unfinished} without an exact verdict in {BUDGET:g} s", None, "")


def run(quick: bool) -> list[Row]:
    per_size = max(1, (8 if quick else MEMBERS) // 4)
    rows: list[Row] = []
    for name, sizes in RANGES.items():
        rows += _range_rows(name, sizes, per_size)
    rows.append(_never_wrong_row(2 if quick else 4))
    return rows
