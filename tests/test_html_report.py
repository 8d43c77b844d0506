"""The HTML report, the network drawing and the short displays of reports and systems.

The page is checked as text (escaping, no external resource, every result and witness shown)
and rendered in headless Chromium (Debian's ``chromium``; ``.ci/run`` installs it), whose
dumped DOM must hold the drawn network.
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import xml.etree.ElementTree as ET
from html.parser import HTMLParser
from pathlib import Path

import networkx as nx
import pytest
from browser import chromium_command

from glocal_verify import ModelError, Report, System, load_example, spec_from_graph, verify
from glocal_verify.reporting.html import residual_svg, to_html
from glocal_verify.reporting.network_svg import network_svg
from glocal_verify.simulation.engine import simulate
from glocal_verify.simulation.observer_models import ObserverBank
from glocal_verify.simulation.schedule import Schedule

SVG = "{http://www.w3.org/2000/svg}"
HAS_ASSESSMENT = importlib.util.find_spec("glocal_verify.reporting.assessment") is not None


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


@pytest.fixture(scope="module")
def report(paper19: System) -> Report:
    return verify(paper19)


@pytest.fixture(scope="module")
def page(report: Report, paper19: System) -> str:
    return to_html(report, paper19)


@pytest.fixture(scope="module")
def hostile() -> System:
    """A tiny system whose names and labels are HTML."""
    G = nx.Graph()
    G.add_edge("<script>alert(1)</script>", "a&b", weight=2)
    G.add_edge("a&b", '"q"', weight=1)
    spec = spec_from_graph(
        G,
        name="<i>net</i> & co",
        clusters={"<b>P</b>": ["<script>alert(1)</script>", "a&b", '"q"']},
        observers={"<b>P</b>": ["a&b"]},
        monitor_velocities=['"q"'],
        modes={"<m>": {"add": [("<script>alert(1)</script>", '"q"')]}},
    )
    return System(spec)


class _Collector(HTMLParser):
    """Tags and their attributes, to check what the page would fetch."""

    def __init__(self) -> None:
        super().__init__()
        self.tags: list[tuple[str, dict[str, str | None]]] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append((tag, dict(attrs)))


def _tags(page: str) -> list[tuple[str, dict[str, str | None]]]:
    c = _Collector()
    c.feed(page)
    return c.tags


# --------------------------------------------------------------------------------------------
# the page as text


def test_the_page_is_self_contained(page: str) -> None:
    tags = _tags(page)
    names = {t for t, _ in tags}
    assert not names & {"script", "link", "img", "iframe", "object", "embed"}
    for tag, attrs in tags:
        for key in ("src", "href"):
            value = attrs.get(key)
            assert value is None or value.startswith("#"), (tag, attrs)
    # the only URL is the SVG namespace name, which is never fetched
    assert set(re.findall(r"https?://[^\s\"'<>]+", page)) <= {"http://www.w3.org/2000/svg"}
    assert "@import" not in page and "url(" not in page


def test_the_page_leads_with_the_assessment_then_the_network_then_the_conditions(page: str) -> None:
    network, summary, conditions = page.index("<h2>Network</h2>"), page.index("<h2>Summary</h2>"), page.index("<h2>Conditions</h2>")
    assert network < summary < conditions
    if HAS_ASSESSMENT:
        assessment = page.index("<h2>Assessment</h2>")
        assert assessment < network
        assert "Privacy (Problem 1)" in page and "Problem 2" in page and "detected" in page


def test_every_result_has_its_row_its_mark_and_its_witness(page: str, report: Report) -> None:
    for r in report.conditions:
        assert f"<code>{r.id}</code>" in page
    assert page.count("<summary>witness</summary>") == len(report.conditions)
    for pol in ("favourable", "unfavourable", "vacuous", "undecided"):
        mark = {"favourable": "✓", "unfavourable": "✗", "vacuous": "–", "undecided": "?"}[pol]
        assert page.count(f"{mark} {pol}</span>") == sum(1 for r in report.conditions if r.polarity.value == pol)
    escalated = sum(1 for r in report.conditions if r.method.value == "exact (escalated)")
    assert page.count('<span class="escalated">exact (escalated)</span>') == escalated
    for f in report.findings:
        assert f.title.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;").replace("'", "&#x27;") in page


def test_the_network_is_drawn_in_every_mode_with_the_switching_mode_first(page: str, paper19: System) -> None:
    assert page.count('<svg xmlns="http://www.w3.org/2000/svg" class="network"') == len(paper19.modes)
    first = page.index("<summary>mode ", page.index("<h2>Network</h2>"))
    assert page[first:].startswith("<summary>mode case-2")


def test_user_strings_are_escaped_in_the_page_and_the_drawing(hostile: System) -> None:
    page = to_html(verify(hostile), hostile)
    assert "<script>" not in page and "<i>net</i>" not in page and "<b>P</b>" not in page and "<m>" not in page
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page and "&lt;i&gt;net&lt;/i&gt; &amp; co" in page
    svg = network_svg(hostile, "<m>")
    root = ET.fromstring(svg)  # well-formed XML despite the labels
    labels = {g.get("data-label") for g in root.iter(f"{SVG}g") if g.get("class") == "agent"}
    assert labels == {"<script>alert(1)</script>", "a&b", '"q"'}


def test_residual_plots_are_drawn_for_each_simulated_observer(report: Report, paper19: System) -> None:
    bank = ObserverBank.for_system(paper19, local=False)
    sim = simulate(paper19, schedule=Schedule.single("case-2", 1.0), observers=bank, horizon=2.0, step=0.01)
    page = to_html(report, paper19, {"attack-free run": sim})
    assert "<h2>Simulation: residuals</h2>" in page and "attack-free run" in page
    assert page.count('class="residual"') == len(sim.residuals) >= 1
    svg = residual_svg("central", sim.t, sim.residuals["central"], switch_times=[(1.0, "case-2")])
    root = ET.fromstring(svg)
    (line,) = [p for p in root.iter(f"{SVG}polyline")]
    assert len(line.get("points", "").split()) == len(sim.t)
    assert any(el.text == "case-2" for el in root.iter(f"{SVG}text"))


# --------------------------------------------------------------------------------------------
# the network drawing


def test_the_drawing_marks_agents_monitors_centres_attack_and_switching_links(paper19: System) -> None:
    root = ET.fromstring(network_svg(paper19, "case-3"))
    agents = [g for g in root.iter(f"{SVG}g") if g.get("class") == "agent"]
    assert len(agents) == paper19.n
    by_label = {g.get("data-label"): g for g in agents}
    centres = {str(o.center) for o in paper19.observers()}
    for lab, g in by_label.items():
        shapes = {el.get("class") for el in g}
        assert ("centre" in shapes) == (lab in centres), lab
        assert ("monitor" in shapes) == (lab in {str(a) for a in paper19.monitored}), lab
    attacked = {str(a) for a in paper19.attacked}
    for lab in attacked:
        (node,) = [el for el in by_label[lab] if el.get("class") == "node"]
        assert node.get("stroke") == "#d62828"
    lines = [el for el in root.iter(f"{SVG}polyline") if (el.get("class") or "").startswith("edge")]
    kinds = [el.get("class") for el in lines]
    links = paper19.switching_links("case-3")
    assert kinds.count("edge added") == sum(1 for *_, d in links if d > 0) == 2
    assert kinds.count("edge removed") == sum(1 for *_, d in links if d < 0) == 2
    assert len(lines) == len(set(paper19.edges("normal")) | set(paper19.edges("case-3")))
    clusters = [g.get("data-cluster") for g in root.iter(f"{SVG}g") if g.get("class") == "cluster"]
    assert clusters == ["P1", "P2", "P3"]
    legend = "".join(el.text or "" for g in root.iter(f"{SVG}g") if g.get("class") == "legend" for el in g.iter(f"{SVG}text"))
    assert "link added by case-3" in legend and "link removed by case-3" in legend and "attacked actuator" in legend


def test_the_drawing_is_deterministic_and_normal_mode_has_no_switching_links(paper19: System) -> None:
    a = network_svg(paper19)
    assert a == network_svg(paper19)
    assert "edge added" not in a and "edge removed" not in a
    assert "attacked actuator" not in network_svg(paper19, attack=False)


def test_an_unknown_mode_cannot_be_drawn(paper19: System) -> None:
    with pytest.raises(ModelError, match="no mode named"):
        network_svg(paper19, "case-9")


# --------------------------------------------------------------------------------------------
# short displays


def test_a_report_has_a_short_repr_and_a_summary_table(report: Report) -> None:
    assert len(repr(report)) < 200 and "paper19" in repr(report)
    text = report.summary()
    rows = [line.split() for line in text.splitlines()[2:]]
    assert sum(int(r[1]) + int(r[2]) + int(r[3]) + int(r[4]) for r in rows) == len(report.conditions)
    for col, pol in enumerate(("favourable", "unfavourable", "vacuous", "undecided"), start=1):
        assert sum(int(r[col]) for r in rows) == sum(1 for r in report.conditions if r.polarity.value == pol)
    assert {r[0] for r in rows} == {r.id for r in report.conditions}
    md = report._repr_markdown_()
    assert md.count("\n| `") == len(rows)
    ET.fromstring(report._repr_html_())


def test_a_system_has_a_short_repr(paper19: System, hostile: System) -> None:
    text = repr(paper19)
    assert len(text) < 300
    for part in ("N=19", "case-3", "P1 (7)", "v: [7, 12, 14]", "zda on [3, 4]"):
        assert part in text
    assert "| agents | 19 |" in paper19._repr_markdown_()
    ET.fromstring(paper19._repr_html_())
    assert "<script>" not in hostile._repr_html_()


# --------------------------------------------------------------------------------------------
# headless Chromium


def test_chromium_renders_the_page_with_the_drawn_network(tmp_path: Path, page: str, report: Report) -> None:
    common = chromium_command(tmp_path / "profile")
    html = tmp_path / "report.html"
    html.write_text(page, encoding="utf-8")
    dom = subprocess.run(common + ["--dump-dom", html.as_uri()], capture_output=True, text=True, timeout=180, check=True).stdout
    assert dom.lstrip().lower().startswith("<html") or "<body" in dom
    body = re.sub(r"<[^>]+>", " ", dom)
    for cid in {r.id for r in report.conditions}:
        assert cid in body
    if HAS_ASSESSMENT:
        assert "Assessment" in body and "Privacy (Problem 1)" in body
    assert "Summary" in body and "Conditions" in body
    svgs = re.findall(r"<svg\b.*?</svg>", dom, flags=re.S)
    assert svgs, "the dumped DOM holds no svg"
    first = svgs[0]
    assert first.count("<circle") >= 19 and first.count("<polyline") >= 27
    shot = tmp_path / "report.png"
    subprocess.run(common + [f"--screenshot={shot}", "--window-size=1200,2000", html.as_uri()], capture_output=True, timeout=180, check=True)
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
