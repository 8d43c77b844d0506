"""Reading communication graphs from GraphML, GML and edge-list files, validated.

:func:`load_graph` returns an undirected simple :class:`networkx.Graph` whose ``weight`` edge
attributes are exact :class:`fractions.Fraction` values and whose node labels are ``int`` or
``str`` (the :data:`~glocal_verify.spec.types.Label` of a spec), ready for
:func:`~glocal_verify.spec.load.spec_from_graph`. Every problem raises
:class:`~glocal_verify.errors.SpecError` naming the file and, where there is one, the line or
the edge.

Weights, as exact rationals (the convention of :mod:`glocal_verify.spec.load`):

* edge lists keep the text: ``0.1`` is 1/10, ``1/3`` is 1/3, ``2`` is 2, all exactly;
* GraphML and GML readers (networkx) turn numeric fields into floats; a float is read back
  through its shortest decimal text (``0.1`` is 1/10), which is the written decimal whenever
  it has at most 15 significant digits; string fields (``"1/3"``) are read exactly;
* a missing weight is 1; zero, negative, NaN, infinite, boolean and non-numeric weights are
  errors.

Limits: the spec loader's (:mod:`glocal_verify.spec.types`): at most 64 MiB of text, at most
:data:`~glocal_verify.spec.types.MAX_NODES` nodes and :data:`~glocal_verify.spec.types.MAX_EDGES`
edges, GML lists nested at most :data:`~glocal_verify.spec.types.MAX_DEPTH` levels; the readers'
warnings (a GraphML ``<port>``, which has no meaning for a communication graph) are not
printed; every message is one line with its echoed values cut short.

Labels: text that spells a canonical integer (``"7"``, ``"-2"``, not ``"07"``) becomes that
``int``, other text stays ``str``; GML nodes are named by their ``label`` when every node has
one, else by their ``id``. Other label types (floats, tuples, lists) are errors.
"""

from __future__ import annotations

import ast
import math
import re
import warnings
from fractions import Fraction
from pathlib import Path
from typing import Any

import networkx as nx

from glocal_verify.errors import SpecError
from glocal_verify.spec.prepare import MAX_FILE_BYTES, NumberTextError, bounded_rational, clip, show
from glocal_verify.spec.types import MAX_DEPTH, MAX_EDGES, MAX_EXPONENT, MAX_NODES, Label

__all__ = [
    "GRAPH_SUFFIXES",
    "load_graph",
]

#: file suffixes understood by :func:`load_graph` and the reader used for each
GRAPH_SUFFIXES = (".graphml", ".gml", ".edgelist", ".txt", ".csv")

_INT = re.compile(r"^-?(0|[1-9][0-9]*)$")
_CSV_HEADERS = frozenset({("source", "target"), ("u", "v"), ("from", "to"), ("node1", "node2"), ("i", "j")})


def _label(raw: Any, where: str, source: str) -> Label:
    if isinstance(raw, bool):
        raise SpecError(where, f"node label {raw!r} is a boolean (expected an integer or a string)", source)
    if isinstance(raw, int):
        return int(raw)
    if isinstance(raw, str):
        text = raw.strip()
        if not text:
            raise SpecError(where, "empty node label", source)
        return int(text) if _INT.match(text) else text
    try:
        hash(raw)
    except TypeError:
        raise SpecError(where, f"node label {raw!r} is not hashable (expected an integer or a string)", source) from None
    raise SpecError(where, f"node label {raw!r} is a {type(raw).__name__} (expected an integer or a string)", source)


def _weight(raw: Any, where: str, source: str) -> Fraction:
    if raw is None:
        return Fraction(1)
    if isinstance(raw, bool):
        raise SpecError(where, f"weight {raw!r} is not a number", source)
    if isinstance(raw, int):
        if raw.bit_length() > 4 * MAX_EXPONENT:
            raise SpecError(where, f"weight {clip(show(raw), 40)} is far outside the allowed range", source)
        q = Fraction(raw)
    elif isinstance(raw, float):
        if not math.isfinite(raw):
            raise SpecError(where, f"weight {raw!r} is not a finite number", source)
        q = Fraction(repr(raw))
    elif isinstance(raw, str):
        text = raw.strip()
        if text.lower() in ("nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "-infinity"):
            raise SpecError(where, f"weight {clip(raw, 40)!r} is not a finite number", source)
        try:
            q = bounded_rational(text)
        except NumberTextError as exc:
            why = {"long": f"is not accepted: {exc}", "range": "is far outside the allowed range"}.get(exc.kind, "is not a number")
            raise SpecError(where, f"weight {clip(raw, 40)!r} {why}", source) from None
    else:
        raise SpecError(where, f"weight {raw!r} is not a number", source)
    if q <= 0:
        raise SpecError(where, f"weight {raw!r} must be > 0", source)
    return q


def _build(nodes: list[tuple[Any, str]], edges: list[tuple[Any, Any, Any, str]], source: str) -> nx.Graph:
    """The validated graph from raw nodes ``(label, where)`` and edges ``(u, v, weight, where)``."""
    if len(edges) > MAX_EDGES:
        raise SpecError("", f"too many edges ({len(edges)}; at most {MAX_EDGES})", source)
    G = nx.Graph()
    for raw, where in nodes:
        G.add_node(_label(raw, where, source))
    seen: dict[frozenset[Label], str] = {}
    for ru, rv, rw, where in edges:
        u, v = _label(ru, where, source), _label(rv, where, source)
        if u == v:
            raise SpecError(where, f"self loop at node {u!r}", source)
        key = frozenset((u, v))
        if key in seen:
            raise SpecError(where, f"edge {u!r}-{v!r} is listed twice (also {seen[key]}): parallel edges are not allowed", source)
        seen[key] = where
        G.add_edge(u, v, weight=_weight(rw, where, source))
    if G.number_of_nodes() > MAX_NODES:
        raise SpecError("", f"too many nodes ({G.number_of_nodes()}; at most {MAX_NODES})", source)
    if G.number_of_nodes() == 0:
        raise SpecError("", "the graph has no nodes", source)
    return G


def _from_networkx(H: Any, source: str, *, gml: bool = False) -> nx.Graph:
    if H.is_directed():
        raise SpecError("", "the graph is directed; the network must be undirected", source)
    if H.is_multigraph():
        raise SpecError("", "the graph has parallel edges (a multigraph); each pair of agents has at most one link", source)
    names: dict[Any, Any] = {n: n for n in H.nodes}
    if gml and H.number_of_nodes() and all("label" in d for _, d in H.nodes(data=True)):
        names = {n: d["label"] for n, d in H.nodes(data=True)}
        seen: dict[Label, Any] = {}
        for n, raw in names.items():
            lab = _label(raw, f"node id {n}", source)
            if lab in seen:
                raise SpecError(f"node id {n}", f"label {raw!r} is also the label of node id {seen[lab]}", source)
            seen[lab] = n
    else:
        seen_ids: dict[Label, Any] = {}
        for n in H.nodes:
            lab = _label(n, f"node {n!r}", source)
            if lab in seen_ids:
                raise SpecError(f"node {n!r}", f"reads as the same label as node {seen_ids[lab]!r}", source)
            seen_ids[lab] = n
    nodes = [(names[n], f"node {n!r}") for n in H.nodes]
    edges = [(names[u], names[v], d.get("weight"), f"edge {u!r}-{v!r}") for u, v, d in H.edges(data=True)]
    return _build(nodes, edges, source)


def _edge_list(text: str, source: str, *, csv: bool) -> nx.Graph:
    edges: list[tuple[Any, Any, Any, str]] = []
    first = True
    for k, line in enumerate(text.splitlines(), start=1):
        body = line.split("#", 1)[0].strip()
        if not body:
            continue
        where = f"line {k}"
        fields = [f.strip() for f in body.split(",")] if csv else body.split(None, 2)
        if first:
            first = False
            if csv and tuple(f.lower() for f in fields[:2]) in _CSV_HEADERS:
                continue
        if len(fields) < 2:
            raise SpecError(where, f"expected 'u v [weight]', got {show(body)}", source)
        u, v = fields[0], fields[1]
        rest = ",".join(fields[2:]).strip() if csv else (fields[2].strip() if len(fields) > 2 else "")
        weight: Any = None
        if rest.startswith("{"):
            try:
                data = ast.literal_eval(rest)
            except (ValueError, SyntaxError, TypeError, RecursionError, MemoryError):
                raise SpecError(where, f"cannot read the edge data {show(rest)}", source) from None
            if not isinstance(data, dict):
                raise SpecError(where, f"cannot read the edge data {show(rest)}", source)
            weight = data.get("weight")
            if isinstance(weight, float):
                # the text of the literal, exactly
                m = re.search(r"['\"]weight['\"]\s*:\s*([^,}]+)", rest)
                weight = m.group(1).strip() if m else weight
        elif rest:
            if len(rest.split()) > 1 or (csv and len(fields) > 3):
                raise SpecError(where, f"expected 'u v [weight]', got {show(body)}", source)
            weight = rest
        edges.append((u, v, weight, where))
    nodes = [(x, w) for u, v, _, w in edges for x in (u, v)]
    return _build(nodes, edges, source)


def load_graph(path: str | Path) -> nx.Graph:
    """Read a communication graph from a GraphML, GML or edge-list file, validated.

    Parameters
    ----------
    path : str or Path
        The file; its suffix chooses the reader: ``.graphml`` (networkx ``read_graphml``),
        ``.gml`` (``read_gml``), ``.edgelist`` and ``.txt`` (whitespace-separated
        ``u v [weight]`` or ``u v {'weight': w}`` per line, ``#`` comments), ``.csv``
        (comma-separated, an optional ``source,target[,weight]`` header).

    Returns
    -------
    networkx.Graph
        Undirected and simple; node labels ``int`` or ``str``; edge attribute ``weight`` an
        exact positive :class:`~fractions.Fraction` (module docstring for how text and floats
        are read). Pass it to :func:`~glocal_verify.spec.load.spec_from_graph`.

    Raises
    ------
    SpecError
        Naming the file and the problem: unknown suffix, unreadable or malformed file, a
        directed graph or a multigraph, a self loop, a duplicate edge, a zero, negative,
        NaN, infinite or non-numeric weight, a label that is not an integer or a string
        (unhashable labels included).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "g.txt"
    >>> _ = p.write_text("1 2 0.1\\n2 3 1/3\\n")
    >>> sorted(load_graph(p).edges(data="weight"))
    [(1, 2, Fraction(1, 10)), (2, 3, Fraction(1, 3))]
    """
    p = Path(path)
    source = str(p)
    suffix = p.suffix.lower()
    if suffix not in GRAPH_SUFFIXES:
        raise SpecError("", f"unknown graph file type {p.suffix!r} (expected one of {', '.join(GRAPH_SUFFIXES)})", source)
    try:
        if p.stat().st_size > MAX_FILE_BYTES:
            raise SpecError("", f"file too large ({p.stat().st_size} bytes; at most {MAX_FILE_BYTES})", source)
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SpecError("", "file not found", source) from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise SpecError("", f"cannot read file ({clip(str(exc))})", source) from None
    if suffix in (".edgelist", ".txt", ".csv"):
        return _edge_list(text, source, csv=suffix == ".csv")
    what = "GraphML" if suffix == ".graphml" else "GML"
    if suffix == ".gml":
        _check_gml_nesting(text, source)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # e.g. "GraphML port tag not supported": ports mean nothing here
            H = nx.parse_graphml(text, node_type=str) if suffix == ".graphml" else nx.parse_gml(text, label="id")
    except SpecError:
        raise
    except (nx.NetworkXError, ValueError, TypeError, KeyError, SyntaxError, IndexError, AttributeError) as exc:  # ElementTree.ParseError is a SyntaxError
        raise SpecError("", f"not a valid {what} graph ({clip(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)})", source) from None
    except RecursionError:
        raise SpecError("", f"not a valid {what} graph (nested deeper than {MAX_DEPTH} levels)", source) from None
    return _from_networkx(H, source, gml=suffix == ".gml")


_GML_TOKEN = re.compile(r'"[^"]*"|\[|\]|\n')


def _check_gml_nesting(text: str, source: str) -> None:
    """Refuse GML whose lists nest deeper than :data:`MAX_DEPTH` levels (networkx's reader
    recurses once per level), naming the line, before the reader sees it."""
    depth, line = 0, 1
    for m in _GML_TOKEN.finditer(text):
        tok = m.group()
        if tok == "\n":
            line += 1
        elif tok == "[":
            depth += 1
            if depth > MAX_DEPTH:
                raise SpecError(f"line {line}", f"lists nested deeper than {MAX_DEPTH} levels", source)
        elif tok == "]":
            depth = max(0, depth - 1)
        else:
            line += tok.count("\n")
