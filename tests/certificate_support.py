"""Shared by the certificate tests and the campaign (``tests/certificate_campaign.py``):
certify a spec (verify, write the certificates, check them with ``glocal_check``) and mutate
certificates and specs.

A mutant is one certificate entry, changed, alone in a file (so rejecting the mutant is
rejecting that entry). Mutations (issue 51): ``digits`` (a number's last digit), ``zero``
(a number set to 0), ``lambda0`` (the exponent of a ZDA or the eigenvalue of an eigenvector
moved by 1/7), ``prime`` (the prime of a minor replaced by the next prime), ``weight`` (a
weight of the spec changed under the certificate; the file's ``assumes`` is refreshed so that
only the mathematics can catch it). An accepted mutant is shown to still prove a true
statement: ``verify(..., exact=True)`` on the (possibly mutated) spec gives its status.
"""

from __future__ import annotations

import copy
import json
import random
import re
import tomllib
from fractions import Fraction
from pathlib import Path
from typing import Any

from flint import fmpz

from glocal_check.check import assumptions as check_assumptions, check_files
from glocal_check.spec import read_spec
from glocal_verify import System, verify
from glocal_verify.certificates import certificate_document
from glocal_verify.spec import loads_spec, spec_from_dict
from glocal_verify.spec.writer import dump_spec

MUTATIONS = ("digits", "zero", "lambda0", "prime", "weight")

_NUMBER = re.compile(r"^-?\d+(/\d+)?$")


def certify(spec_text: str, folder: Path, name: str = "spec") -> tuple[Path, dict[str, Any], Any]:
    """Write the spec, verify it, write its certificate file; return (spec path, document, outcome)."""
    spec_path = folder / f"{name}.toml"
    spec_path.write_text(spec_text, encoding="utf-8")
    system = System(loads_spec(spec_text))
    report = verify(system)
    doc = certificate_document(system, report)
    cert_path = folder / f"{name}.cert.json"
    cert_path.write_text(json.dumps(doc), encoding="utf-8")
    lines: list[str] = []
    out = check_files(str(spec_path), str(cert_path), report=lines.append)
    return spec_path, doc, out


def _leaves(x: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Paths to the numbers of a certificate (ints and rational texts)."""
    out: list[tuple[Any, ...]] = []
    if isinstance(x, dict):
        for k, v in x.items():
            if k != "kind":
                out += _leaves(v, path + (k,))
    elif isinstance(x, list):
        for k, v in enumerate(x):
            out += _leaves(v, path + (k,))
    elif (isinstance(x, int) and not isinstance(x, bool)) or (isinstance(x, str) and _NUMBER.match(x)):
        out.append(path)
    return out


def _get(x: Any, path: tuple[Any, ...]) -> Any:
    for k in path:
        x = x[k]
    return x


def _set(x: Any, path: tuple[Any, ...], value: Any) -> None:
    for k in path[:-1]:
        x = x[k]
    x[path[-1]] = value


def _last_digit(v: Any) -> Any:
    text = str(v)
    head, _, den = text.partition("/")
    d = int(head[-1])
    head = head[:-1] + str((d + 1) % 10)
    if den and int(den) == 0:
        den = "1"
    out = head + ("/" + den if den else "")
    return int(out) if isinstance(v, int) else out


def _fields(cert: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Paths of the number-field moduli inside a certificate."""
    out: list[tuple[Any, ...]] = []
    if isinstance(cert, dict):
        for k, v in cert.items():
            if k == "field" and isinstance(v, dict):
                out.append(path + (k, "modulus", 0))
            else:
                out += _fields(v, path + (k,))
    return out


def mutate(entry: dict[str, Any], how: str, rng: random.Random) -> dict[str, Any] | None:
    """The entry with its certificate mutated ``how`` (None when the mutation does not apply
    or changes nothing)."""
    e = copy.deepcopy(entry)
    cert = e["certificate"]
    leaves = _leaves(cert)
    if how in ("digits", "zero"):
        if not leaves:
            return None
        path = rng.choice(leaves)
        old = _get(cert, path)
        new = _last_digit(old) if how == "digits" else (0 if isinstance(old, int) else "0")
        if new == old:
            return None
        _set(cert, path, new)
    elif how == "lambda0":
        fields = _fields(cert)
        if not fields:
            return None
        path = rng.choice(fields)
        _set(cert, path, str(Fraction(_get(cert, path)) - Fraction(1, 7)))
    elif how == "prime":
        paths = [p for p in leaves if p[-1] == "prime"]
        if not paths:
            return None
        path = rng.choice(paths)
        q = _get(cert, path) + 1
        while not fmpz(q).is_prime():
            q += 1
        _set(cert, path, q)
    else:
        raise ValueError(how)
    return e


def mutate_weight(spec_text: str, rng: random.Random) -> str:
    """The spec with one normal-mode weight increased by 1 (a valid spec)."""
    d = tomllib.loads(dump_spec(loads_spec(spec_text)))
    edges = d["graph"]["edges"]
    k = rng.randrange(len(edges))
    e = edges[k]
    w = Fraction(str(e[2])) if len(e) > 2 else Fraction(1)
    edges[k] = [e[0], e[1], str(w + 1)]
    return dump_spec(spec_from_dict(d))


def check_entry(spec_path: Path, doc: dict[str, Any], entry: dict[str, Any], folder: Path, refresh: bool = False) -> bool:
    """Is ``entry``, alone in a copy of ``doc`` (``assumes`` re-read from the spec when
    ``refresh``), accepted?"""
    one = dict(doc, verdicts=[entry])
    if refresh:
        one["assumes"] = json.loads(json.dumps(check_assumptions(read_spec(str(spec_path)))))
    path = folder / "mutant.cert.json"
    path.write_text(json.dumps(one), encoding="utf-8")
    out = check_files(str(spec_path), str(path), report=lambda _: None)
    return out.accepted == 1


def claim_is_true(spec_text: str, entry: dict[str, Any]) -> bool:
    """Does ``verify(..., exact=True)`` give the entry's status in its scope?"""
    system = System(loads_spec(spec_text))
    report = verify(system, [entry["id"]], exact=True, simulate="never")
    for r in report.conditions:
        if json.loads(json.dumps(dict(r.scope), default=str)) == entry["scope"]:
            return r.status.value == entry["status"]
    return False


def mutation_run(spec_text: str, folder: Path, count: int, seed: int) -> dict[str, Any]:
    """``count`` mutants of the certificates of one spec, the five kinds in turn: how many are
    rejected, and every accepted one with whether its claim is true (exact verify).

    A ``weight`` mutant is checked twice: with the file as written (its ``assumes`` then
    differs from the spec: counted with the others) and with ``assumes`` refreshed from the
    mutated spec (``weight_refreshed``: only the mathematics can reject it; a certificate
    that does not depend on the changed weight is still a proof).
    """
    spec_path, doc, _ = certify(spec_text, folder)
    certified = [e for e in doc["verdicts"] if e["certificate"] is not None]
    rng = random.Random(seed)
    main: dict[str, Any] = {"mutants": 0, "rejected": 0, "accepted": []}
    refreshed: dict[str, Any] = {"mutants": 0, "rejected": 0, "accepted": []}
    dead: set[str] = set()  # kinds no certificate of this spec has a number for: left out, never looped on
    misses = dict.fromkeys(MUTATIONS, 0)
    while main["mutants"] < count:
        live = [k for k in MUTATIONS if k not in dead]
        if not live:
            break
        entry = rng.choice(certified)
        how = live[main["mutants"] % len(live)]
        runs = []
        if how == "weight":
            text = mutate_weight(spec_text, rng)
            path = folder / "mutant.toml"
            path.write_text(text, encoding="utf-8")
            runs = [(main, check_entry(path, doc, entry, folder), text), (refreshed, check_entry(path, doc, entry, folder, refresh=True), text)]
        else:
            mutant = mutate(entry, how, rng)
            if mutant is None:
                misses[how] += 1
                if misses[how] > 20 * len(certified):
                    dead.add(how)
                continue
            misses[how] = 0
            entry = mutant
            runs = [(main, check_entry(spec_path, doc, mutant, folder), spec_text)]
        for tally, ok, truth in runs:
            tally["mutants"] += 1
            if ok:
                tally["accepted"].append({"how": how, "id": entry["id"], "scope": entry["scope"], "true": claim_is_true(truth, entry)})
            else:
                tally["rejected"] += 1
    return {**main, "weight_refreshed": refreshed}
