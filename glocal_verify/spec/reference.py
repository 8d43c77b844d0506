"""The spec-format reference (``docs/spec.md``), generated from the JSON Schema.

``python -m glocal_verify.spec.reference > docs/spec.md`` regenerates the page: every key of
``glocal_verify/spec/schemas/spec.schema.json`` with its type (read from the schema), whether
it is required, its default, its description (the schema's ``description``) and a TOML
example. Defaults and examples are kept here, in :data:`KEYS`, next to the generator; the
tests check that every schema key has a description and an entry here, and that the page is
up to date.
"""

from __future__ import annotations

import json
import sys
from importlib import resources
from types import MappingProxyType
from typing import Any, Iterator, Mapping

__all__ = ["KEYS", "schema", "schema_keys", "type_text", "generate", "main"]

#: key path -> (default, TOML example); "-" = no default (required, or absent means "none")
KEYS: Mapping[str, tuple[str, str]] = MappingProxyType({
    "format": ("- (required)", "format = 1"),
    "name": ("the file name without extension", 'name = "drones8"'),
    "description": ('""', 'description = "8 drones, two clusters"'),
    "dynamics": ("alpha = 1, gamma = 1", "[dynamics]\nalpha = 1\ngamma = \"1/2\""),
    "dynamics.alpha": ("1", "alpha = 1"),
    "dynamics.gamma": ("1", 'gamma = "1/2"'),
    "graph": ("- (required)", "[graph]\nnodes = 4\nedges = [[1, 2], [2, 3, 2], [3, 4]]"),
    "graph.nodes": ("- (required)", 'nodes = 19            # or nodes = ["a", "b", "c"]'),
    "graph.edges": ("- (required)", 'edges = [[1, 2], [2, 3, "3/2"]]'),
    "modes": ("none (no safe mode)", '[[modes]]\nname = "case-1"\nadd = [[1, 7]]'),
    "modes[].name": ("- (required)", 'name = "case-1"'),
    "modes[].description": ('""', 'description = "add link 1-7"'),
    "modes[].add": ("[]", "add = [[1, 7], [4, 7, 2]]"),
    "modes[].remove": ("[]", "remove = [[15, 18]]"),
    "clusters": ("none (no local observers)", '[[clusters]]\nname = "P1"\nnodes = [1, 2, 3, 4, 5, 6, 7]'),
    "clusters[].name": ("- (required)", 'name = "P1"'),
    "clusters[].nodes": ("- (required)", "nodes = [1, 2, 3, 4, 5, 6, 7]"),
    "clusters[].observers": ("none", "[[clusters.observers]]\ncenter = 5"),
    "clusters[].observers[].center": ("- (required)", "center = 5"),
    "clusters[].observers[].positions": ("the centre and its neighbours in the cluster", "positions = [8, 9, 10, 11, 12]"),
    "clusters[].observers[].velocities": ("the centre and its neighbours in the cluster", "velocities = [8, 9, 10, 11, 12]"),
    "clusters[].observers[].poles": ("the default pole design", "poles = [-1, -1.5, -2]"),
    "monitor": ("nothing measured", "[monitor]\npositions = []\nvelocities = [7, 12, 14]"),
    "monitor.positions": ("[]", "positions = []"),
    "monitor.velocities": ("[]", "velocities = [7, 12, 14]"),
    "attack": ("none (no attack)", '[attack]\nkind = "zda"\nactuators = [3, 4]\nlambda0 = 0.5'),
    "attack.kind": ("- (required)", 'kind = "zda"'),
    "attack.actuators": ("- (required)", "actuators = [3, 4]"),
    "attack.sensors": ("[]", "sensors = [7]"),
    "attack.lambda0": ("the fastest-growing stealthy zero", "lambda0 = 0.5             # or [0.1, 2.0] for 0.1 + 2i"),
    "attack.start": ("0.0", "start = 0.0"),
    "attack.signal": ('"step" (covert attacks)', 'signal = "sine"'),
    "attack.amplitude": ("1.0", "amplitude = 1.0"),
    "attack.frequency": ("1.0", "frequency = 0.5"),
    "switching": ("none (no switch)", '[switching]\nmode = "case-2"\ntime = 10.0'),
    "switching.mode": ("none", 'mode = "case-2"'),
    "switching.time": ("none (required with mode)", "time = 10.0"),
    "switching.sequence": ("[]", 'sequence = [{mode = "normal", duration = 10}, {mode = "case-2", duration = 20}]'),
    "switching.sequence[].mode": ("- (required)", 'mode = "normal"'),
    "switching.sequence[].duration": ("- (required)", "duration = 10"),
    "simulation": ("horizon = 30, step = 0.01, seed = 0", "[simulation]\nhorizon = 30.0\nstep = 0.01"),
    "simulation.horizon": ("30.0", "horizon = 30.0"),
    "simulation.step": ("0.01", "step = 0.01"),
    "simulation.seed": ("0", "seed = 0"),
    "uncertainty": ("none (no detection.* results)", '[uncertainty]\ninitial_state = 1\nnoise = 0.001\ndisturbance = "1/1000"'),
    "uncertainty.initial_state": ("1 (when initial_error is absent)", "initial_state = 1"),
    "uncertainty.initial_error": ("none", "initial_error = 0.5"),
    "uncertainty.noise": ("0 (no noise)", 'noise = 0.001             # or {"*" = 0.001, "v:7" = 0.002, "x:*" = 0.01}'),
    "uncertainty.noise_std": ("none (no Gaussian part)", "noise_std = 0.0002"),
    "uncertainty.false_alarm": ("1e-6 (with noise_std)", "false_alarm = 1e-6"),
    "uncertainty.disturbance": ("0", 'disturbance = "1/1000"'),
    "implementation": ("none (no sampled.* or detection.* results)", "[implementation]\nperiod = 0.01"),
    "implementation.period": ("- (required)", 'period = 0.01            # or "1/100"'),
    "implementation.hold": ('"zoh"', 'hold = "zoh"'),
    "implementation.controller": ('"sampled"', 'controller = "sampled"'),
    "implementation.switch_delay": ("1", "switch_delay = 1"),
    "finding": ("none", '[finding]\nclaim = "Remark III.2.1: B^i = I can be used"\nreference = "Remark III.2.1"'),
    "finding.claim": ("- (required)", 'claim = "Remark III.2.1: B^i = I can be used to select local monitors"'),
    "finding.reference": ("- (required)", 'reference = "Remark III.2.1"'),
    "finding.paper_says": ('""', 'paper_says = "..."'),
    "finding.explanation": ('""', 'explanation = "..."'),
    "finding.conditions": ("[]", 'conditions = ["local.pencil"]'),
    "finding.expect": ("[]", 'expect = [{id = "local.pencil", status = "fails", suspected = "all"}]'),
    "finding.expect[].id": ("- (required)", 'id = "local.pencil"'),
    "finding.expect[].status": ("- (required)", 'status = "fails"'),
    "finding.expect[].mode": ("any mode", 'mode = "case-1"'),
    "finding.expect[].cluster": ("any cluster", 'cluster = "P1"'),
    "finding.expect[].observer": ("any observer", "observer = 5"),
    "finding.expect[].suspected": ("any suspected set", 'suspected = "all"'),
})

_DEF_TEXT = MappingProxyType({
    "label": "label (integer or string)",
    "labels": "list of labels",
    "number": "exact number (integer, decimal, or a fraction string such as \"1/3\")",
    "edge": "[u, v] or [u, v, weight]",
    "pair": "[u, v]",
})


def schema() -> dict[str, Any]:
    """The spec JSON Schema (``glocal-verify/spec@1``)."""
    text = resources.files("glocal_verify.spec").joinpath("schemas/spec.schema.json").read_text(encoding="utf-8")
    return dict(json.loads(text))


def schema_keys(node: dict[str, Any] | None = None, prefix: str = "") -> Iterator[tuple[str, dict[str, Any], bool]]:
    """``(path, property schema, required)`` for every property, depth first in schema order.

    Paths use ``.`` for tables and ``[]`` for arrays of tables: ``clusters[].observers[].center``.
    """
    node = schema() if node is None else node
    required = set(node.get("required", []))
    for key, sub in node.get("properties", {}).items():
        path = f"{prefix}{key}"
        yield path, sub, key in required
        yield from schema_keys(sub, path + ".")
        items = sub.get("items")
        if isinstance(items, dict) and "properties" in items:
            yield from schema_keys(items, path + "[].")


def type_text(sub: dict[str, Any]) -> str:
    """A short, readable type of a property schema (``$ref``, ``anyOf``, ``enum``, arrays)."""
    if "$ref" in sub:
        return _DEF_TEXT.get(sub["$ref"].rsplit("/", 1)[-1], sub["$ref"])
    if "const" in sub:
        return f"constant {json.dumps(sub['const'])}"
    if "enum" in sub:
        return "one of " + ", ".join(json.dumps(v) for v in sub["enum"])
    if "anyOf" in sub:
        return " or ".join(type_text(s) for s in sub["anyOf"])
    t = sub.get("type")
    if isinstance(t, list):
        return " or ".join(t)
    if t == "array":
        items = sub.get("items")
        if isinstance(items, dict):
            if "properties" in items:
                return "array of tables"
            return f"list of {type_text(items)}"
        return "array"
    if t == "object":
        return "table"
    return str(t or "any")


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def generate() -> str:
    """The Markdown of ``docs/spec.md``.

    Raises
    ------
    KeyError
        When a schema key has no entry in :data:`KEYS` (add its default and example).
    """
    lines = [
        "# The spec format (format 1)",
        "",
        "<!-- generated by `python -m glocal_verify.spec.reference > docs/spec.md`; do not edit by hand -->",
        "",
        "A system is a TOML file validated against the JSON Schema",
        "`glocal_verify/spec/schemas/spec.schema.json`. `glocal-verify example paper19` prints a",
        "complete example (the paper's Section IV network). Weights and gains are exact rationals:",
        'an integer, a decimal, or a string such as `"1/3"`. An error names the key path, e.g.',
        "`clusters[2].observers[0].center: node 25 is not in the graph`. What each condition",
        "does with these keys: [conditions.md](conditions.md).",
        "",
        "Key paths use `.` for tables and `[]` for arrays of tables (`[[clusters]]`,",
        "`[[clusters.observers]]`).",
        "",
    ]
    scalars_done = False
    for path, sub, required in schema_keys():
        default, example = KEYS[path]
        head = path.split(".")[0].split("[")[0]
        items = sub.get("items")
        if path == head:
            if isinstance(items, dict) and "properties" in items:
                lines += [f"## `[[{head}]]`", ""]
            elif "properties" in sub:
                lines += [f"## `[{head}]`", ""]
            elif not scalars_done:
                lines += ["## Top-level keys", ""]
                scalars_done = True
        lines += [
            f"### `{path}`",
            "",
            sub.get("description", ""),
            "",
            f"- type: {type_text(sub)}",
            f"- required: {('yes' if path == head else 'yes, when its table is present') if required else 'no'}",
            f"- default: {default}",
            "",
            "```toml",
            example,
            "```",
            "",
        ]
    while lines and lines[-1] == "":
        lines.pop()
    return "\n".join(lines) + "\n"


def main() -> int:
    """Write :func:`generate` to stdout."""
    sys.stdout.write(generate())
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
