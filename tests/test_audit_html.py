"""The attack audit as one self-contained HTML page (``glocal-verify audit --format html``).

The page is parsed with :mod:`html.parser` (well-formed, every row shown, undetected sets
first, nothing fetched), a hostile spec checks the escaping, and headless Chromium renders it.
"""

from __future__ import annotations

import re
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import networkx as nx
import pytest
from browser import chromium_command

from glocal_verify import System, load_example, spec_from_graph
from glocal_verify.cli import main
from glocal_verify.design.audit import AuditResult, audit
from glocal_verify.reporting.audit_html import audit_to_html

#: elements that need no end tag in HTML5
VOID = {"meta", "br", "hr", "img", "input", "link", "area", "base", "col", "embed", "source", "track", "wbr"}
HOSTILE = "<script>alert(1)</script>"


@pytest.fixture(scope="module")
def result() -> AuditResult:
    return audit(System(load_example("paper19")), 2, [3, 4, 5, 7, 8, 13])


@pytest.fixture(scope="module")
def page(result: AuditResult) -> str:
    return audit_to_html(result)


@pytest.fixture(scope="module")
def hostile() -> AuditResult:
    G = nx.Graph()
    G.add_edge(HOSTILE, "a&b", weight=2)
    G.add_edge("a&b", '"q"', weight=1)
    spec = spec_from_graph(
        G,
        name="<i>net</i> & co",
        clusters={"<b>P</b>": [HOSTILE, "a&b", '"q"']},
        observers={"<b>P</b>": ["a&b"]},
        monitor_velocities=['"q"'],
        modes={"<m>": {"add": [(HOSTILE, '"q"')]}},
    )
    return audit(System(spec), 2)


class _Tree(HTMLParser):
    """Start/end tag balance, the tags with their attributes, and the table rows' cells."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.rows: list[list[str]] = []
        self._cell: list[str] | None = None
        self._in_audit = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        self.tags.append((tag, a))
        if tag == "table" and a.get("class") == "audit":
            self._in_audit = True
        if self._in_audit and tag == "tr":
            self.rows.append([])
        if self._in_audit and tag == "td":
            self._cell = []
        if tag not in VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if tag in VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1] if self.stack else 'nothing'}")
            return
        self.stack.pop()
        if tag == "td" and self._cell is not None:
            self.rows[-1].append("".join(self._cell))
            self._cell = None
        if tag == "table":
            self._in_audit = False

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


def _parse(page: str) -> _Tree:
    t = _Tree()
    t.feed(page)
    t.close()
    return t


def test_the_audit_page_is_well_formed_html(page: str) -> None:
    t = _parse(page)
    assert page.startswith("<!DOCTYPE html>")
    assert not t.errors and not t.stack, (t.errors, t.stack)


def test_the_page_holds_every_row_with_its_seven_columns(page: str, result: AuditResult) -> None:
    rows = [r for r in _parse(page).rows if r]
    assert len(rows) == len(result.rows)
    shown = {tuple(r[0].split(", ")): r for r in rows}
    for row in result.rows:
        cells = shown[tuple(map(str, row.actuators))]
        assert len(cells) == 7
        assert cells[6].startswith(row.verdict)
        assert cells[5] == (", ".join(row.exposed_by_modes) or "-")


def test_undetected_sets_come_first_then_undecided_then_detected(page: str, result: AuditResult) -> None:
    verdicts = [re.match(r"(undetected|undecided|detected)", r[6]).group(1) for r in _parse(page).rows if r]  # type: ignore[union-attr]
    rank = {"undetected": 0, "undecided": 1, "detected": 2}
    assert [rank[v] for v in verdicts] == sorted(rank[v] for v in verdicts)
    assert "undetected" in verdicts and "detected" in verdicts


def test_the_page_shows_the_counts_and_the_theorem_verdict_of_every_safe_mode(page: str, result: AuditResult) -> None:
    c = result.summary()["counts"]
    assert f"{c['undetected']} undetected" in page and f"{c['detected']} detected" in page and f"{c['undecided']} undecided" in page
    for mode, ok in result.modes.items():
        expect = "(i)-(iii) hold" if ok else ("undecided" if ok is None else "some of (i)-(iii) fail")
        assert re.search(rf"<code>{re.escape(mode)}</code></td><td[^>]*>{re.escape(expect)}<", page), mode


def test_the_audit_page_fetches_nothing(page: str) -> None:
    tags = _parse(page).tags
    assert not {t for t, _ in tags} & {"script", "link", "img", "iframe", "object", "embed"}
    for tag, attrs in tags:
        for key in ("src", "href"):
            assert attrs.get(key) is None or str(attrs[key]).startswith("#"), (tag, attrs)
    assert set(re.findall(r"https?://[^\s\"'<>]+", page)) <= {"http://www.w3.org/2000/svg"}
    assert "@import" not in page and "url(" not in page
    assert page.count("<svg") >= 2  # the heat map and the exposure bars, inline


def test_a_hostile_agent_name_is_escaped_everywhere(hostile: AuditResult) -> None:
    page = audit_to_html(hostile)
    t = _parse(page)
    assert not t.errors and not t.stack
    assert "<script" not in page and "<i>net" not in page and "<b>P" not in page and "<m>" not in page
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page and "a&amp;b" in page and "&lt;m&gt;" in page
    cells = [r[0] for r in t.rows if r]
    assert any(HOSTILE in c for c in cells) and len(cells) == len(hostile.rows)


def test_audit_command_writes_the_html_page(tmp_path: Path) -> None:
    out = tmp_path / "audit.html"
    args = ["audit", "--example", "paper19", "--max-attackers", "1", "--agents", "3,4,13", "--format", "html", "--out", str(out), "--quiet"]
    assert main(args) == 0
    rows = [r for r in _parse(out.read_text(encoding="utf-8")).rows if r]
    assert sorted(r[0] for r in rows) == ["13", "3", "4"]


def test_chromium_renders_the_audit_page_with_its_heat_map(tmp_path: Path, page: str, result: AuditResult) -> None:
    common = chromium_command(tmp_path / "profile")
    html = tmp_path / "audit.html"
    html.write_text(page, encoding="utf-8")
    dom = subprocess.run(common + ["--dump-dom", html.as_uri()], capture_output=True, text=True, timeout=180, check=True).stdout
    heat = re.search(r'<svg\b[^>]*class="heatmap".*?</svg>', dom, flags=re.DOTALL)
    assert heat is not None
    pairs = sum(1 for r in result.rows if len(r.actuators) == 2)
    singles = sum(1 for r in result.rows if len(r.actuators) == 1)
    assert heat.group(0).count("<rect") == 1 + singles + 2 * pairs  # frame, diagonal, both halves
    assert "Attack sets" in re.sub(r"<[^>]+>", " ", dom)
