"""Turning what a caller passes into plain data that the spec schema can check quickly.

:func:`prepare` copies a mapping into dicts, lists and Python scalars without recursion,
refusing non-string keys and nesting deeper than :data:`~glocal_verify.spec.types.MAX_DEPTH`
(the JSON Schema validator recurses, and a list nested 10^4 deep would exhaust the stack).
:func:`elide` cuts the long arrays of scalars (labels, edges, poles) to their first item for the
schema, after checking their sizes; :func:`check_items` checks the rest of each array with plain
loops that give the schema's messages. Together they make a 10,000-agent spec validate in well
under a second. :func:`nesting_site` finds the key of a too-deep array in TOML text the parser
gave up on; :func:`show` and :func:`clip` keep echoed values and messages short.
"""

from __future__ import annotations

import copy
import re
import tomllib
from decimal import Decimal
from fractions import Fraction
from pathlib import Path
from typing import Any, Iterable, Mapping

from glocal_verify.errors import SpecError
from glocal_verify.spec.types import MAX_DEPTH, MAX_EDGES, MAX_EXPONENT, MAX_MODES, MAX_NODES, MAX_NUMBER_TEXT, MAX_SWITCH_STEPS

__all__ = [
    "MAX_FILE_BYTES",
    "NumberTextError",
    "bounded_rational",
    "check_items",
    "clip",
    "elide",
    "nesting_site",
    "parse_toml",
    "path_text",
    "plain_scalar",
    "prepare",
    "read_toml",
    "show",
]


def path_text(parts: Iterable[Any]) -> str:
    out = ""
    for p in parts:
        if isinstance(p, int):
            out += f"[{p}]"
        else:
            out += f".{p}" if out else str(p)
    return out


#: largest TOML text (characters) or file (bytes) the loaders read
MAX_FILE_BYTES = 64 * 1024 * 1024

_PLAIN = (str, int, float, bool)


def show(value: Any) -> str:
    """``repr(value)``, cut to at most about 80 characters."""
    try:
        r = repr(value)
    except Exception:  # noqa: BLE001 - a user object whose repr fails
        r = f"<{type(value).__name__}>"
    return r if len(r) <= 80 else f"{r[:60]}...<{len(r)} chars>"


def clip(text: str, n: int = 160) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."


def plain_scalar(value: Any) -> Any:
    """A leaf value with numpy scalars turned into Python ones."""
    if type(value) in _PLAIN or isinstance(value, (Fraction, Decimal)):
        return value
    mod = type(value).__module__
    if mod == "numpy" or mod.startswith("numpy."):
        if hasattr(value, "dtype") and getattr(value, "shape", None) == ():
            kind = value.dtype.kind
            if kind == "b":
                return bool(value)
            if kind in "iu":
                return int(value)
            if kind == "f":
                return float(value)
            if kind == "U":
                return str(value)
    return value


_EXPONENT = re.compile(r"[eE]\s*([-+]?\d+)")


class NumberTextError(ValueError):
    """Why :func:`bounded_rational` refused a number text: ``kind`` is ``"long"`` (too many
    characters; the message says how many), ``"range"`` (an exponent beyond the limit) or
    ``"syntax"`` (not a rational number). Callers word the message for their input."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind


def bounded_rational(text: str) -> Fraction:
    """The rational a string spells (``"1/3"``, ``"2.5e-3"``), bounded before conversion.

    At most :data:`~glocal_verify.spec.types.MAX_NUMBER_TEXT` characters and a decimal
    exponent of at most :data:`~glocal_verify.spec.types.MAX_EXPONENT` in magnitude, so that
    ``"1e9999999"`` is refused at once instead of being expanded. Every reader of numbers
    written as text (the spec loader, the graph files) calls it.

    Raises
    ------
    NumberTextError
        With its ``kind``.
    """
    t = text.strip()
    if len(t) > MAX_NUMBER_TEXT:
        raise NumberTextError("long", f"number text too long ({len(t)} characters; at most {MAX_NUMBER_TEXT})")
    for part in t.split("/"):
        m = _EXPONENT.search(part)
        if m is not None and (len(m.group(1).lstrip("+-")) > 6 or abs(int(m.group(1))) > MAX_EXPONENT):
            raise NumberTextError("range", "far outside the allowed range")
    try:
        return Fraction(t)
    except (ValueError, ZeroDivisionError):
        raise NumberTextError("syntax", "not a rational number") from None


def prepare(data: Any, source: str | None) -> Any:
    """A plain copy of ``data`` (dicts, lists, Python scalars), walked without recursion.

    Raises :class:`SpecError` for non-string keys and for nesting deeper than
    :data:`MAX_DEPTH`, before the schema validator (which recurses) sees the data.
    """
    holder: list[Any] = [None]
    # (value, container, key in container, parent path node, depth); a path node is
    # (parent node, key), turned into text only for an error
    stack: list[tuple[Any, Any, Any, Any, int]] = [(data, holder, 0, None, 0)]
    while stack:
        value, box, key, parent, depth = stack.pop()
        if type(value) in _PLAIN:
            box[key] = value
            continue
        node = (parent, key) if parent is not None or box is not holder else None
        if isinstance(value, Mapping):
            if depth >= MAX_DEPTH:
                raise SpecError(_node_text(node), f"tables and arrays nested deeper than {MAX_DEPTH} levels", source)
            new: dict[str, Any] = {}
            box[key] = new
            for k, v in value.items():
                k = plain_scalar(k)
                if not isinstance(k, str):
                    raise SpecError(_node_text(node) or "<top>", f"keys must be strings, got {show(k)}", source)
                new[k] = None
                stack.append((v, new, k, node, depth + 1))
        elif isinstance(value, (list, tuple)):
            if depth >= MAX_DEPTH:
                raise SpecError(_node_text(node), f"arrays nested deeper than {MAX_DEPTH} levels", source)
            if all(type(x) in _PLAIN for x in value):
                box[key] = list(value)
                continue
            lst: list[Any] = [None] * len(value)
            box[key] = lst
            for i, v in enumerate(value):
                stack.append((v, lst, i, node, depth + 1))
        else:
            box[key] = plain_scalar(value)
    return holder[0]


def _node_text(node: Any) -> str:
    """The key path of a path node, cut after the first index below the last key (a list nested
    64 deep is named ``graph.edges[0]``, not by 64 indices)."""
    parts: list[Any] = []
    while node is not None:
        node, key = node
        parts.append(key)
    parts.reverse()
    last = max((i for i, k in enumerate(parts) if isinstance(k, str)), default=-1)
    return path_text(parts[: last + 2])


def _long_arrays(d: Mapping[str, Any]) -> Iterable[tuple[str, Any, str, int]]:
    """``(path, array, kind, limit)`` of every array a spec may make long."""
    g = d.get("graph")
    if isinstance(g, dict):
        yield "graph.nodes", g.get("nodes"), "label", MAX_NODES
        yield "graph.edges", g.get("edges"), "edge", MAX_EDGES
    modes = d.get("modes")
    if isinstance(modes, list):
        if len(modes) > MAX_MODES:
            yield "modes", modes, "-", MAX_MODES
        for k, m in enumerate(modes):
            if isinstance(m, dict):
                yield f"modes[{k}].add", m.get("add"), "edge", MAX_EDGES
                yield f"modes[{k}].remove", m.get("remove"), "pair", MAX_EDGES
    clusters = d.get("clusters")
    if isinstance(clusters, list):
        if len(clusters) > MAX_NODES:
            yield "clusters", clusters, "-", MAX_NODES
        for k, c in enumerate(clusters):
            if isinstance(c, dict):
                yield f"clusters[{k}].nodes", c.get("nodes"), "label", MAX_NODES
                obs = c.get("observers")
                if isinstance(obs, list):
                    for j, o in enumerate(obs):
                        if isinstance(o, dict):
                            for key in ("positions", "velocities"):
                                yield f"clusters[{k}].observers[{j}].{key}", o.get(key), "label", MAX_NODES
                            yield f"clusters[{k}].observers[{j}].poles", o.get("poles"), "number", 4 * MAX_NODES
    for table, keys in (("monitor", ("positions", "velocities")), ("attack", ("actuators", "sensors"))):
        t = d.get(table)
        if isinstance(t, dict):
            for key in keys:
                yield f"{table}.{key}", t.get(key), "label", MAX_NODES
    sw = d.get("switching")
    if isinstance(sw, dict) and isinstance(sw.get("sequence"), list) and len(sw["sequence"]) > MAX_SWITCH_STEPS:
        yield "switching.sequence", sw["sequence"], "-", MAX_SWITCH_STEPS


def elide(d: Any, source: str | None) -> tuple[Any, list[tuple[str, list[Any], str]]]:
    """A copy of ``d`` for the schema, with every long array of scalars cut to its first item,
    and the ``(path, rest of the array, kind)`` the plain loops of :func:`check_items` check.

    Raises :class:`SpecError` for arrays longer than their size limit.
    """
    if not isinstance(d, dict):
        return d, []
    skeleton = copy.copy(d)
    owned = {id(skeleton)}
    out: list[tuple[str, list[Any], str]] = []
    total_edges = 0
    for path, items, kind, limit in list(_long_arrays(d)):
        if not isinstance(items, list):
            continue
        if len(items) > limit:
            raise SpecError(path, f"too many entries ({len(items)}; at most {limit})", source)
        if kind == "-":
            continue
        if kind in ("edge", "pair"):
            total_edges += len(items)
            if total_edges > MAX_EDGES:
                raise SpecError(path, f"too many edges in the graph and its modes (more than {MAX_EDGES})", source)
        if len(items) > 1:
            out.append((path, items, kind))
            _cut(skeleton, path, items[:1], owned)
    return skeleton, out


_STEP = re.compile(r"([A-Za-z_]+)(?:\[(\d+)\])?")


def _cut(skeleton: dict[str, Any], path: str, value: list[Any], owned: set[int]) -> None:
    """Set ``path`` (``a[1].b``) of ``skeleton`` to ``value``, copying on the way every table and
    array not yet copied (their ids are in ``owned``), so that the data itself is not changed."""
    node: Any = skeleton
    steps = path.split(".")
    for n, step in enumerate(steps):
        m = _STEP.fullmatch(step)
        assert m is not None
        key, idx = m.group(1), m.group(2)
        if n == len(steps) - 1:
            node[key] = value
            return
        child = node[key]
        if id(child) not in owned:
            child = node[key] = copy.copy(child)
            owned.add(id(child))
        if idx is not None:
            i = int(idx)
            if id(child[i]) not in owned:
                child[i] = copy.copy(child[i])
                owned.add(id(child[i]))
            child = child[i]
        node = child


_NUMBER_TEXT = re.compile(r"^\s*[-+]?[0-9./eE+-]+\s*$")


def _is_label(x: Any) -> bool:
    return (type(x) is int) or (type(x) is str and len(x) >= 1)


def _is_number(x: Any) -> bool:
    if type(x) in (int, float):
        return True
    if type(x) is str:
        return _NUMBER_TEXT.match(x) is not None
    return isinstance(x, (Fraction, Decimal)) or (isinstance(x, (int, float)) and not isinstance(x, bool))


def check_items(path: str, items: list[Any], kind: str, source: str | None) -> None:
    """Check ``items[1:]`` of a long array as the schema would, with the same messages."""
    if kind == "label":
        for k in range(1, len(items)):
            if not _is_label(items[k]):
                raise SpecError(f"{path}[{k}]", f"unexpected value {show(items[k])} (expected integer or string)", source)
        return
    if kind == "number":
        for k in range(1, len(items)):
            if not _is_number(items[k]):
                raise SpecError(f"{path}[{k}]", f"unexpected value {show(items[k])} (expected number or string)", source)
        return
    hi = 3 if kind == "edge" else 2
    for k in range(1, len(items)):
        e = items[k]
        if type(e) is not list:
            raise SpecError(f"{path}[{k}]", f"unexpected value {show(e)} (expected array)", source)
        if not 2 <= len(e) <= hi:
            raise SpecError(f"{path}[{k}]", f"an edge is [i, j] or [i, j, weight], got {show(e)}", source)
        for j in (0, 1):
            if not _is_label(e[j]):
                raise SpecError(f"{path}[{k}][{j}]", f"unexpected value {show(e[j])} (expected label)", source)
        if len(e) == 3 and not _is_number(e[2]):
            raise SpecError(f"{path}[{k}][2]", f"unexpected value {show(e[2])} (expected number)", source)


_TOKEN = re.compile(r'"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\'|#[^\n]*|[\[\]{}]|\n')
_HEADER = re.compile(r"\s*\[\[?\s*([^\]]*?)\s*\]\]?")
_KEY = re.compile(r"\s*([^=]+?)\s*=\s*$")


def nesting_site(text: str) -> tuple[str, int]:
    """(key path, line) where the brackets of ``text`` first nest deeper than :data:`MAX_DEPTH`.

    Used only after the TOML parser gave up (recursion), so that the message can still name
    the key; strings and comments are skipped, multi-line strings are not understood.
    """
    depth, line, line_start, table, key = 0, 1, 0, "", ""
    for m in _TOKEN.finditer(text):
        tok = m.group()
        if tok == "\n":
            line += 1
            line_start = m.end()
            continue
        if tok[0] in "\"'#":
            continue
        if tok in "[{":
            if depth == 0:
                before = text[line_start : m.start()]
                if not before.strip():  # a table header
                    h = _HEADER.match(text, m.start())
                    if h and tok == "[" and "=" not in text[m.start() : h.end()]:
                        table, key = h.group(1).replace('"', ""), ""
                        continue
                k = _KEY.match(before)
                key = k.group(1).strip('"') if k else key
            depth += 1
            if depth > MAX_DEPTH:
                where = ".".join(p for p in (table, key) if p)
                return clip(where, 120), line
        elif depth > 0:
            depth -= 1
    return "", line


def read_toml(path: str | Path) -> tuple[dict[str, Any], str]:
    """The mapping of a TOML file, read with the guarantees of the spec loader.

    Every TOML file the toolkit reads (specs, sweep files) goes through here: at most
    :data:`MAX_FILE_BYTES` bytes of UTF-8, arrays and inline tables nested at most
    :data:`~glocal_verify.spec.types.MAX_DEPTH` levels, integers of at most 4300 digits; a
    problem is one :class:`SpecError` naming the file (and the key, for the nesting).

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    (dict, str)
        The parsed mapping and the file name for messages.
    """
    if not isinstance(path, (str, Path)):
        raise SpecError("", f"expected a file name, got {show(path)}")
    p = Path(path)
    try:
        if p.stat().st_size > MAX_FILE_BYTES:
            raise SpecError("", f"file too large ({p.stat().st_size} bytes; at most {MAX_FILE_BYTES})", str(p))
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SpecError("", "file not found", str(p)) from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise SpecError("", f"cannot read file ({clip(str(exc))})", str(p)) from None
    return parse_toml(text, source=str(p)), str(p)


def parse_toml(text: str | bytes, source: str | None = None) -> dict[str, Any]:
    """TOML ``text`` as a mapping, with the guards of :func:`read_toml` (one :class:`SpecError`).

    Parameters
    ----------
    text : str or bytes
        Bytes are decoded as UTF-8.
    source : str, optional
        A file name for messages.
    """
    if isinstance(text, (bytes, bytearray)):
        try:
            text = bytes(text).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise SpecError("", f"not UTF-8 text ({exc})", source) from None
    if not isinstance(text, str):
        raise SpecError("", f"expected TOML text (str), got {type(text).__name__}", source)
    if len(text) > MAX_FILE_BYTES:
        raise SpecError("", f"text too large ({len(text)} characters; at most {MAX_FILE_BYTES})", source)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError("", f"not valid TOML ({clip(str(exc))})", source) from None
    except RecursionError:
        where, line = nesting_site(text)
        raise SpecError(where, f"arrays or inline tables nested deeper than {MAX_DEPTH} levels (line {line})", source) from None
    except ValueError as exc:  # an integer literal of more than 4300 digits
        raise SpecError("", f"not valid TOML ({clip(str(exc).split(';')[0])})", source) from None
