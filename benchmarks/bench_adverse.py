"""`glocal-verify verify` on the adverse family: the worst member per N beside the median.

The family (:func:`glocal_verify.design.generators.adverse_family`) draws networks the way people
draw them: stochastic-block-model clusters of 30-300 agents with mean degree 3-10, links between
consecutive or random pairs of clusters, observers measuring their neighbours only (the spec's
default), also the boundary, or the whole cluster, 0-3 safe modes, the ZDA present or absent; its
first member is the network of issue 47 (clusters of about 100 agents of mean degree 8, random
links, neighbours only, one safe mode, a two-agent ZDA).

Each member runs ``glocal-verify verify --format json`` in its own process (wall and CPU time,
peak resident memory) against one ``numpy.linalg.eigh`` of its own Laplacian timed in this
process; per N the rows give the worst member (the largest ratio of its time to its eigh) and
the median one, each with its undecided verdicts, and a third row sums the undecided verdicts
of every member (the goal: at most 0.5 % of a member's verdicts, and the bottom line decided).
``MEMBERS`` members per N at N = 1000, 2000, 4000; with ``--large`` two at N = 10,000.
"""

from __future__ import annotations

import json
import os
import statistics
import tempfile
from pathlib import Path

from glocal_verify import System
from glocal_verify.design.generators import adverse_family

from .harness import Row, cli, eigh_seconds, run_command, write_spec

#: members per N (the large size runs fewer)
MEMBERS = int(os.environ.get("GLOCAL_BENCH_ADVERSE_MEMBERS", "6"))

#: the goal of issue 47: the worst member costs at most this many eigendecompositions
EIGH_GOAL = 5.0

#: longest a member may run before it is killed and reported as not finished
BUDGET = float(os.environ.get("GLOCAL_BENCH_BUDGET", "420"))

GROUP = "adverse family: verify on networks drawn the way people draw them (each member in its own process; ratio = eigh / command)"


def _report(path: str) -> tuple[int, int, str]:
    """(undecided, verdicts, bottom line) of a ``verify --format json`` report."""
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except (OSError, ValueError):
        return 0, 0, "no report"
    results = data.get("conditions", [])
    und = sum(1 for r in results if r.get("status") == "undecided")
    attack = (data.get("assessment") or {}).get("attack") or {}
    return und, len(results), str(attack.get("verdict", "not assessed"))


def _members(n: int, count: int, tmp: Path) -> list[dict[str, object]]:
    out = []
    for m in adverse_family(n, count):
        spec = m.spec()
        path = write_spec(spec, tmp, f"adv{n}-{m.seed}")
        t_eigh = eigh_seconds(System(spec).laplacian())
        report = str(tmp / "r.json")
        if os.path.exists(report):
            os.unlink(report)
        budget = 1800.0 if n >= 10_000 else BUDGET
        run = run_command(cli("verify", str(path), "--quiet", "--format", "json", "--out", report), timeout=budget)
        und, total, bottom = _report(report)
        out.append({"label": m.label, "eigh": t_eigh, "run": run, "budget": budget, "undecided": und, "verdicts": total, "bottom": bottom})
    return out


def _row(n: int, which: str, m: dict[str, object], goal: str) -> Row:
    run = m["run"]
    t_eigh = float(m["eigh"])  # type: ignore[arg-type]
    x = run.seconds / t_eigh if t_eigh > 0 else float("nan")  # type: ignore[attr-defined]
    note = f"{m['label']}; {run.describe(m['budget'])}; {x:.1f} x eigh; goal {goal}; bottom line: {m['bottom']}"  # type: ignore[attr-defined]
    return Row(GROUP, f"N = {n}, {which}", f"one eigh of L ({n} x {n})", t_eigh, "glocal-verify verify", run.seconds, note, run.peak_mib,  # type: ignore[attr-defined]
               f"{m['undecided']} of {m['verdicts']}")


def run(quick: bool) -> list[Row]:
    sizes = [250, 500] if quick else [1000, 2000, 4000]
    if os.environ.get("GLOCAL_BENCH_LARGE") and not quick:
        sizes.append(10_000)
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            count = 2 if n >= 10_000 else (3 if quick else MEMBERS)
            ms = _members(n, count, Path(tmp))
            ratio = [m["run"].seconds / float(m["eigh"]) if float(m["eigh"]) > 0 else float("inf") for m in ms]  # type: ignore[attr-defined]
            order = sorted(range(len(ms)), key=ratio.__getitem__)
            goal = "< 5 min, < 8 GiB" if n >= 10_000 else f"<= {EIGH_GOAL:g} x eigh"
            rows.append(_row(n, f"worst of {len(ms)} members", ms[order[-1]], goal))
            rows.append(_row(n, f"median of {len(ms)} members", ms[order[len(ms) // 2]], goal))
            und = [int(m["undecided"]) for m in ms]  # type: ignore[call-overload]
            tot = [int(m["verdicts"]) for m in ms]  # type: ignore[call-overload]
            worst_share = max((u / t for u, t in zip(und, tot) if t), default=0.0)
            undecided_bottom = sum(1 for m in ms if m["bottom"] == "undecided")
            rows.append(Row(
                GROUP, f"N = {n}, undecided over all {len(ms)} members", "-", None, "glocal-verify verify",
                sum(m["run"].seconds for m in ms),  # type: ignore[attr-defined]
                f"largest share on one member {100 * worst_share:.2f} % (goal <= 0.5 %); bottom line undecided on {undecided_bottom} member(s); "
                f"median ratio {statistics.median(ratio):.1f} x eigh; members: " + "; ".join(f"{m['label']} {r:.1f}x" for m, r in zip(ms, ratio)),
                None, f"{sum(und)} of {sum(tot)}",
            ))
    return rows
