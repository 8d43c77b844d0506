#!/usr/bin/env python
"""A fuzzing campaign against every surface of the ``glocal-verify`` CLI (no pytest or hypothesis needed).

    nice -n 10 python tests/fuzz_campaign.py --inputs all --count 5000 --out /tmp/fuzz.jsonl

``--inputs`` chooses the input kinds (``tests/fuzz_support.py``, "every surface"): ``spec``
(mutated specs through the commands of ``--commands``), ``graph`` (mutated GraphML, GML, edge
lists and CSV through ``verify --graph``), ``sweep`` (mutated sweep files), ``options``
(every command with option values at and beyond their domains), ``output`` (writing
commands whose ``--out`` is an input, a hard link, ``sub/../input``, a symbolic link, a folder
given through a link, a full disk ...) and ``signal`` (SIGINT to the process group, SIGTERM
or SIGHUP at a random moment of a real run in its own session); ``all`` is every kind, each
run drawn with the weights of :data:`WEIGHTS` (``spec:3,graph:2`` sets weights). Besides the
outcome classes below, every run is checked against the output policy: an input changed
(``overwrote-input``), a write through a symbolic link (``symlink-write``), a
``.glocal-partial-*`` left (``partial-left``), an empty folder left by a failed run
(``empty-folder``), a process of a stopped run alive after it (``survivor``).

With ``--inputs spec`` (the default, the first campaign) it makes ``--count`` mutated specs
and runs each through every command of ``--commands`` (default all four: ``verify``,
``verify --exact``, ``simulate``, ``place-observers``), so the campaign has
``count x commands`` runs; with other inputs each of the ``--count`` draws is one run. A pool of ``--workers``
(default 2) runs them; each run is a fresh ``python -c`` that bounds its address space with
``RLIMIT_AS`` (``--memory-gib``, default 4), calls ``glocal_verify.cli.main`` through
:func:`fuzz_support.run_cli` and is killed after ``--timeout`` seconds (default 60).
``--isolation fork`` instead keeps one warm interpreter per worker that forks a child per run
(same limits, no 2-3 s import per run).

One JSON line per run: the input kind, the mutation, the command, the outcome class (ok,
clean-error, traceback, multi-line, hang, blowup, crash, bad-exit, and the policy violations
above), the last stderr line (300 chars), the exception type, and the innermost file:line of
the traceback (``innermost``; and ``innermost_project``, the innermost frame inside
``glocal_verify/``). Specs (or whole cases, as JSON) of runs that did not end ok /
clean-error are kept in ``--keep-dir`` (default ``<out>.specs/``) for replay:

    python tests/fuzz_campaign.py --replay /tmp/fuzz.jsonl.specs/000123.toml --commands simulate
    python tests/fuzz_campaign.py --replay /tmp/fuzz.jsonl.specs/000456.json

``--clustered K`` instead runs ``verify --exact`` and ``design`` (``--allow-large``) on K random
clustered networks (N = 30-120, 2-5 clusters, random seeds; ``random_clustered_spec``), the
valid specs the exact path must decide without an internal error:

    nice -n 10 python tests/fuzz_campaign.py --clustered 20 --timeout 3600 --out /tmp/clustered.jsonl

``--one-command`` runs each mutated spec through one command only (the commands in turn), so
``--count`` specs make ``--count`` runs; ``--commands simulate-figures`` adds ``simulate`` with its
figures. ``--summary`` prints counts per outcome and per distinct failure of an existing JSONL file.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter, defaultdict
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

import fuzz_support as fs  # noqa: E402

# The per-run program: bounded address space, then run_cli in-process (SIGALRM budget a little
# under the parent's hard timeout, faulthandler dump just before it, in case C code is stuck).
RUN_CODE = r"""
import faulthandler, json, os, resource, signal, sys
out_path, timeout, mem, fsize = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
if mem:
    resource.setrlimit(resource.RLIMIT_AS, (mem, mem))
faulthandler.dump_traceback_later(max(1.0, timeout - 2.0), exit=False)
sys.path.insert(0, os.environ["GLOCAL_FUZZ_TESTS"])
import fuzz_support
if fsize >= 0:  # a full disk: writes past fsize bytes fail with EFBIG (the result goes through a pipe-free path below)
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, resource.RLIM_INFINITY))
res = fuzz_support.run_cli(sys.argv[5:], max(1.0, timeout - 5.0))
if fsize >= 0:
    resource.setrlimit(resource.RLIMIT_FSIZE, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
with open(out_path, "w", encoding="utf-8") as f:
    json.dump(res.to_json(), f)
"""

# A warm worker for --isolation fork: one request (JSON) per stdin line, one answer per line.
WORKER_CODE = r"""
import json, os, sys
sys.path.insert(0, os.environ["GLOCAL_FUZZ_TESTS"])
import fuzz_support
import glocal_verify.cli, glocal_verify.conditions.registry, glocal_verify.design.placement, glocal_verify.simulation.engine
for line in sys.stdin:
    req = json.loads(line)
    res = fuzz_support.run_cli(req["argv"], req["timeout"] - 5.0, fork=True, memory_bytes=req["mem"] or None, cwd=req.get("cwd"), fsize=req.get("fsize"))
    sys.stdout.write(json.dumps(res.to_json()) + "\n")
    sys.stdout.flush()
"""


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env["GLOCAL_FUZZ_TESTS"] = str(HERE)
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    env.setdefault("OMP_NUM_THREADS", "1")
    env.setdefault("MKL_NUM_THREADS", "1")
    env["MPLBACKEND"] = "Agg"
    return env


def run_exec(argv: list[str], timeout: float, mem: int, work: Path, fsize: int | None = None) -> dict[str, Any]:
    """One run in a fresh ``python -c`` working in ``work``."""
    res_path = Path(tempfile.mkdtemp(prefix="glocal-fuzz-result-")) / "result.json"
    t0 = time.monotonic()
    p = subprocess.Popen(
        [sys.executable, "-c", RUN_CODE, str(res_path), str(timeout), str(mem), str(-1 if fsize is None else fsize), *argv],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env(), cwd=str(work), start_new_session=True,
    )
    try:
        out, err = p.communicate(timeout=timeout)
        killed = False
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        out, err = p.communicate()
        killed = True
    elapsed = time.monotonic() - t0
    err_text = err.decode(errors="replace")
    if not res_path.exists():
        shutil.rmtree(res_path.parent, ignore_errors=True)
    else:
        try:
            d = json.loads(res_path.read_text(encoding="utf-8"))
            d["elapsed"] = elapsed
            return d
        except ValueError:
            pass
        finally:
            shutil.rmtree(res_path.parent, ignore_errors=True)
    # no result: killed, OOM, segfault, or the wrapper itself failed
    inner, proj = fs.stack_frames(err_text)
    if killed:
        outcome, exc = "hang", "FuzzTimeout"
    elif "MemoryError" in err_text:
        outcome, exc = "blowup", "MemoryError"
    elif p.returncode is not None and p.returncode < 0:
        outcome, exc = "crash", f"signal {-p.returncode}"
    else:
        outcome, exc = "crash", f"wrapper exit {p.returncode}"
    return {"outcome": outcome, "rc": p.returncode, "stdout": out.decode(errors="replace")[:2000], "stderr": err_text[-20000:],
            "exc_type": exc, "exc_message": "", "innermost": inner, "innermost_project": proj, "elapsed": elapsed}


class ForkWorker:
    """A warm interpreter that forks one child per run (``--isolation fork``)."""

    def __init__(self) -> None:
        self.p: subprocess.Popen[str] | None = None

    def _start(self) -> subprocess.Popen[str]:
        if self.p is None or self.p.poll() is not None:
            self.p = subprocess.Popen([sys.executable, "-c", WORKER_CODE], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                      env=_env(), text=True, start_new_session=True)
        return self.p

    def run(self, argv: list[str], timeout: float, mem: int, work: Path, fsize: int | None = None) -> dict[str, Any]:
        p = self._start()
        assert p.stdin is not None and p.stdout is not None
        t0 = time.monotonic()
        p.stdin.write(json.dumps({"argv": argv, "timeout": timeout, "mem": mem, "cwd": str(work), "fsize": fsize}) + "\n")
        p.stdin.flush()
        line = p.stdout.readline()  # run_cli enforces the timeout (kills the child)
        if not line:
            self.p = None
            return {"outcome": "crash", "rc": None, "stdout": "", "stderr": "", "exc_type": "worker died", "exc_message": "",
                    "innermost": None, "innermost_project": None, "elapsed": time.monotonic() - t0}
        return json.loads(line)

    def close(self) -> None:
        if self.p is not None and self.p.poll() is None:
            assert self.p.stdin is not None
            self.p.stdin.close()
            try:
                self.p.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(self.p.pid, signal.SIGKILL)


#: how often each input kind is drawn by ``--inputs all`` (a signal run costs several seconds)
WEIGHTS = {"spec": 3, "graph": 2, "sweep": 2, "options": 2, "output": 2, "signal": 1}


def _inputs(text: str) -> dict[str, int]:
    if text == "all":
        return dict(WEIGHTS)
    out: dict[str, int] = {}
    for part in (p for p in text.split(",") if p):
        kind, _, w = part.partition(":")
        if kind not in fs.INPUTS:
            raise SystemExit(f"--inputs: unknown input kind {kind!r} (known: {', '.join(fs.INPUTS)}, all)")
        out[kind] = int(w or WEIGHTS[kind])
    return out


def record(idx: int, seed: int, case: fs.Case, d: dict[str, Any], spec_file: str | None) -> dict[str, Any]:
    lines = [ln for ln in (d.get("stderr") or "").splitlines() if ln.strip()]
    return {
        "id": idx,
        "seed": seed,
        "kind": case.kind,
        "base": case.description.split(":", 1)[0] if case.kind == "spec" else case.kind,
        "mutation": case.description,
        "command": case.command,
        "outcome": d["outcome"],
        "rc": d.get("rc"),
        "last_stderr_line": (lines[-1] if lines else "")[:300],
        "stderr_lines": len(lines),
        "stderr_max_line": max((len(ln) for ln in lines), default=0),
        "exc_type": d.get("exc_type"),
        "exc_message": (d.get("exc_message") or "")[:300],
        "innermost": d.get("innermost"),
        "innermost_project": d.get("innermost_project"),
        "elapsed": round(float(d.get("elapsed") or 0.0), 2),
        "spec_file": spec_file,
    }


def _jobs(args: argparse.Namespace) -> list[tuple[int, int, fs.Case]]:
    commands = [c for c in args.commands.split(",") if c]
    bases = [b for b in args.bases.split(",") if b] if args.bases else [n for n, _ in fs.base_specs() if n != "paper19"]
    kinds = [k for k in args.kinds.split(",") if k] if args.kinds else list(fs.KINDS)
    weights = _inputs(args.inputs)
    pool = [k for k, w in weights.items() for _ in range(w)]
    jobs = []
    for i in range(args.count):
        seed = args.seed * 1_000_003 + i
        c = fs.RandomChooser(seed)
        kind = c.choice(pool)
        if kind != "spec":
            jobs.append((i, seed, fs.random_case(c, kind)))
            continue
        m = fs.random_mutant(c, max_mutations=args.max_mutations, kinds=kinds, bases=bases)
        for cmd in [commands[i % len(commands)]] if args.one_command or len(weights) > 1 else commands:
            case = fs.Case("spec", cmd, fs.command_argv(cmd, "spec.toml", "."), {"spec.toml": m.text.encode()}, protected=["spec.toml"],
                           description=m.description[:2000])
            jobs.append((i, seed, case))
    return jobs


def campaign(args: argparse.Namespace) -> int:
    out = Path(args.out)
    keep = Path(args.keep_dir or f"{args.out}.specs")
    keep.mkdir(parents=True, exist_ok=True)
    mem = int(args.memory_gib * (1 << 30))
    jobs = _jobs(args)
    lock = threading.Lock()
    counts: Counter[str] = Counter()
    done = [0]
    t_start = time.monotonic()
    local = threading.local()
    workers: list[ForkWorker] = []
    out.parent.mkdir(parents=True, exist_ok=True)
    fh = out.open("w", encoding="utf-8")

    def runner(argv: list[str], timeout: float, work: Path, fsize: int | None) -> fs.RunResult:
        if args.isolation == "fork":
            if not hasattr(local, "w"):
                local.w = ForkWorker()
                with lock:
                    workers.append(local.w)
            d = local.w.run(argv, timeout, mem, work, fsize)
        else:
            d = run_exec(argv, timeout, mem, work, fsize)
        return fs.RunResult(d["outcome"], d.get("rc"), d.get("stdout", ""), d.get("stderr", ""), d.get("exc_type"), d.get("exc_message"),
                            d.get("innermost"), d.get("innermost_project"), float(d.get("elapsed") or 0.0))

    def one(job: tuple[int, int, fs.Case]) -> None:
        i, seed, case = job
        if args.max_wall and time.monotonic() - t_start > args.max_wall:
            return
        res = fs.run_case(case, args.timeout, memory_bytes=mem, runner=runner)
        d = res.to_json()
        spec_file = None
        if d["outcome"] not in fs.GOOD_OUTCOMES:
            if case.kind == "spec":
                sp = keep / f"{i:06d}.toml"
                if not sp.exists():
                    sp.write_text(f"# {case.description[:2000]}\n" + case.files["spec.toml"].decode("utf-8", "replace"), encoding="utf-8")
            else:
                sp = keep / f"{i:06d}.json"
                sp.write_text(json.dumps(case.to_json()), encoding="utf-8")
            spec_file = str(sp)
        rec = record(i, seed, case, d, spec_file)
        with lock:
            fh.write(json.dumps(rec) + "\n")
            fh.flush()
            counts[rec["outcome"]] += 1
            done[0] += 1
            if not args.quiet and (done[0] % 25 == 0 or done[0] == len(jobs)):
                el = time.monotonic() - t_start
                print(f"[{done[0]}/{len(jobs)} {el:6.0f}s] " + ", ".join(f"{k}={v}" for k, v in sorted(counts.items())), file=sys.stderr, flush=True)

    try:
        with ThreadPoolExecutor(max_workers=args.workers) as ex:
            list(ex.map(one, jobs))
    finally:
        fh.close()
        for w in workers:
            w.close()
    print(summarize(out), end="")
    return 0


def _failure_key(r: dict[str, Any]) -> tuple[str, str, str]:
    return (r["outcome"], r.get("exc_type") or "-", r.get("innermost_project") or r.get("innermost") or "-")


def summarize(path: Path) -> str:
    rows = [json.loads(ln) for ln in path.read_text(encoding="utf-8").splitlines() if ln.strip()]
    lines = [f"{len(rows)} runs in {path}", ""]
    by_cmd: dict[str, Counter[str]] = defaultdict(Counter)
    for r in rows:
        by_cmd[f"{r.get('kind', 'spec')}: {r['command']}"][r["outcome"]] += 1
        by_cmd[f"{r.get('kind', 'spec')}: ALL"][r["outcome"]] += 1
        by_cmd["ALL"][r["outcome"]] += 1
    shown = [o for o in fs.ALL_OUTCOMES if by_cmd["ALL"][o] or o in fs.OUTCOMES]
    head = ["input: command"] + shown
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|" + "---|" * len(head))
    for key in sorted(k for k in by_cmd if k != "ALL") + ["ALL"]:
        lines.append("| " + " | ".join([key] + [str(by_cmd[key][o]) for o in shown]) + " |")
    groups: dict[tuple[str, str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        if r["outcome"] not in fs.GOOD_OUTCOMES:
            groups[_failure_key(r)].append(r)
    lines += ["", "distinct failures (outcome, exception, innermost glocal_verify frame):", ""]
    for key, rs in sorted(groups.items(), key=lambda kv: -len(kv[1])):
        short = min(rs, key=lambda r: (len(r["mutation"]), r["elapsed"]))
        cmds = ",".join(sorted({r["command"] for r in rs}))
        inner = sorted({r.get("innermost") or "-" for r in rs})
        lines.append(f"- {len(rs):4d}  {key[0]:10s} {key[1]:22s} {key[2]}  [{cmds}]")
        lines.append(f"        innermost: {', '.join(inner[:3])}{' ...' if len(inner) > 3 else ''}")
        lines.append(f"        e.g. #{short['id']} {short['base']}: {short['mutation'][:200]}")
        msg = f"{short['exc_type']}: {short['exc_message'][:160]}" if short["outcome"] in ("traceback", "blowup") else short["last_stderr_line"][:200]
        lines.append(f"        -> {msg}")
    return "\n".join(lines) + "\n"


def replay(args: argparse.Namespace) -> int:
    path = Path(args.replay)
    if path.suffix == ".json":
        case = fs.Case.from_json(json.loads(path.read_text(encoding="utf-8")))
        res = fs.run_case(case, args.timeout, memory_bytes=int(args.memory_gib * (1 << 30)))
        print(f"{case.kind} {case.command}: {res.outcome} rc={res.rc} {res.exc_type or ''} {res.innermost_project or res.innermost or ''}")
        print(f"   argv: {case.argv}")
        print("   " + "\n   ".join((res.stderr or "").strip().splitlines()[-12:]))
        return 0
    with tempfile.TemporaryDirectory(prefix="glocal-fuzz-") as tmp:
        for cmd in [c for c in args.commands.split(",") if c]:
            argv = fs.command_argv(cmd, path.resolve(), tmp)
            d = run_exec(argv, args.timeout, int(args.memory_gib * (1 << 30)), Path(tmp))
            print(f"{cmd}: {d['outcome']} rc={d.get('rc')} {d.get('exc_type') or ''} {d.get('innermost_project') or d.get('innermost') or ''}")
            print("   " + "\n   ".join((d.get("stderr") or "").strip().splitlines()[-12:]))
    return 0


def clustered(args: argparse.Namespace) -> int:
    """``verify --exact`` and ``design`` on ``args.clustered`` generated clustered networks."""
    import random

    from glocal_verify.design.generators import random_clustered_spec

    rng = random.Random(args.seed)
    nets = []
    for _ in range(args.clustered):
        n, c, seed = rng.randint(30, 120), rng.randint(2, 5), rng.randrange(10**6)
        nets.append((n, c, seed, random_clustered_spec(n, c, seed=seed).to_toml()))
    runs = [(net, cmd) for net in nets for cmd in ("verify-exact", "design")]
    mem = int(args.memory_gib * (1 << 30))
    out = Path(args.out)
    lock = threading.Lock()
    counts: Counter[str] = Counter()

    def one(job: tuple[tuple[int, int, int, str], str]) -> dict[str, Any]:
        (n, c, seed, text), cmd = job
        with tempfile.TemporaryDirectory(prefix="glocal-clustered-") as tmp:
            Path(tmp, "spec.toml").write_text(text, encoding="utf-8")
            argv = ["verify", "spec.toml", "--exact", "--quiet", "--allow-large", "--out", "r.md"] if cmd == "verify-exact" else ["design", "spec.toml", "--quiet", "--allow-large", "--out", "d.toml"]
            d = run_exec(argv, args.timeout, mem, Path(tmp))
        lines = [ln for ln in (d.get("stderr") or "").splitlines() if ln.strip()]
        rec = {"n": n, "clusters": c, "seed": seed, "command": cmd, "outcome": d["outcome"], "rc": d.get("rc"), "elapsed": round(float(d.get("elapsed") or 0), 1),
               "last_stderr_line": (lines[-1] if lines else "")[:300], "internal_error": any("internal error" in ln for ln in lines)}
        with lock:
            counts[f"{cmd} {rec['outcome']} rc={rec['rc']}"] += 1
            if not args.quiet:
                print(f"N={n} clusters={c} seed={seed} {cmd}: {rec['outcome']} rc={rec['rc']} {rec['elapsed']} s {rec['last_stderr_line'][:120]}", file=sys.stderr, flush=True)
        return rec

    with ThreadPoolExecutor(max_workers=args.workers) as ex:
        recs = list(ex.map(one, runs))
    out.write_text("".join(json.dumps(r) + "\n" for r in recs), encoding="utf-8")
    errors = sum(r["internal_error"] for r in recs)
    print(f"{len(nets)} networks, {len(recs)} runs: " + ", ".join(f"{k}: {v}" for k, v in sorted(counts.items())) + f"; internal errors: {errors}")
    return 1 if errors else 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--count", type=int, default=100, help="draws (a spec draw runs through every --commands command when --inputs is spec)")
    p.add_argument("--inputs", default="spec", help=f"input kinds, comma list with optional weights ({', '.join(fs.INPUTS)}; 'all': {WEIGHTS})")
    p.add_argument("--out", default="/tmp/fuzz.jsonl", help="JSONL output (one line per run)")
    p.add_argument("--keep-dir", help="where specs (or cases, as JSON) of failing runs are kept (default <out>.specs/)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--commands", default=",".join(fs.COMMANDS), help=f"comma list of {', '.join(fs.COMMANDS + fs.EXTRA_COMMANDS)}")
    p.add_argument("--bases", help="comma list of base specs (default: all but the 30 s paper19; paper19-short stays)")
    p.add_argument("--kinds", help=f"comma list of mutation kinds (default all: {', '.join(fs.KINDS)})")
    p.add_argument("--max-mutations", type=int, default=3)
    p.add_argument("--one-command", action="store_true", help="run each mutated spec through one command (in turn) instead of all")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--timeout", type=float, default=60.0, help="seconds per run")
    p.add_argument("--memory-gib", type=float, default=4.0, help="RLIMIT_AS per run")
    p.add_argument("--isolation", choices=("exec", "fork"), default="exec", help="exec: fresh python -c per run (default); fork: warm worker forks per run")
    p.add_argument("--max-wall", type=float, default=0.0, help="stop starting new runs after this many seconds (0: no limit)")
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--summary", metavar="JSONL", help="only summarize an existing campaign file")
    p.add_argument("--clustered", type=int, default=0, metavar="K", help="run verify --exact and design on K random clustered networks instead")
    p.add_argument("--replay", metavar="FILE", help="run --commands on one kept spec file (.toml), or run one kept case (.json), and show stderr")
    args = p.parse_args(argv)
    if args.summary:
        print(summarize(Path(args.summary)), end="")
        return 0
    if args.replay:
        return replay(args)
    if args.clustered:
        return clustered(args)
    return campaign(args)


if __name__ == "__main__":
    sys.exit(main())
