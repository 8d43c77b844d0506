"""The drawn geometry of every network picture: no link passes through, or near, an agent it
does not join; agents do not overlap; weights are written when asked; legends cover no data.

The geometry is read back from what is drawn (the SVG's circles and polylines, the matplotlib
artists of the case figures), not from the layout that made it, and checked with a distance
computed here: from every agent's centre to every segment of every link (and observer spoke)
that does not end at that agent, more than the node radius plus :data:`MARGIN` radii.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from glocal_verify import System, load_example
from glocal_verify.design.generators import random_clustered_spec
from glocal_verify.reporting.figures.sweep import rates_figure
from glocal_verify.reporting.figures.network import draw_network
from glocal_verify.reporting.network_svg import network_svg

SVG = "{http://www.w3.org/2000/svg}"
#: a link keeps at least (1 + MARGIN) node radii from the centre of an agent it does not join
MARGIN = 0.5


def _generated(seed: int) -> System:
    n = (12, 20, 30, 40, 50)[seed % 5]
    return System(random_clustered_spec(n, clusters=1 + seed % 5, seed=seed, attack=False, modes=2))


GENERATED = list(range(20))


def _distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    t = 0.0 if not d.any() else min(1.0, max(0.0, float((p - a) @ d / (d @ d))))
    return float(np.hypot(*(a + t * d - p)))


def _violations(centres: dict[str, np.ndarray], radius: float, paths: list[tuple[str, str, np.ndarray]]) -> list[str]:
    bad = []
    for u, v, pts in paths:
        for w, c in centres.items():
            if w in (u, v):
                continue
            near = min(_distance(c, pts[k], pts[k + 1]) for k in range(len(pts) - 1))
            if near <= (1 + MARGIN) * radius:
                bad.append(f"link {u}-{v} passes {near / radius:.2f} radii from agent {w}")
    labels = list(centres)
    for i, a in enumerate(labels):
        for b in labels[i + 1 :]:
            if float(np.hypot(*(centres[a] - centres[b]))) <= 2 * radius:
                bad.append(f"agents {a} and {b} overlap")
    return bad


def _svg_geometry(svg: str) -> tuple[dict[str, np.ndarray], float, list[tuple[str, str, np.ndarray]]]:
    root = ET.fromstring(svg)
    centres: dict[str, np.ndarray] = {}
    radii = set()
    for g in root.iter(f"{SVG}g"):
        if g.get("class") != "agent":
            continue
        node = next((el for el in g if el.get("class") == "node"), None)
        if node is not None and node.tag == f"{SVG}circle" and node.get("fill") != "none":
            centres[str(g.get("data-label"))] = np.array([float(node.get("cx", "")), float(node.get("cy", ""))])
            radii.add(float(node.get("r", "")))
        else:
            rect = next(el for el in g if el.get("class") == "centre")
            s = float(rect.get("width", "")) / 2
            centres[str(g.get("data-label"))] = np.array([float(rect.get("x", "")) + s, float(rect.get("y", "")) + s])
    paths = []
    for el in root.iter(f"{SVG}polyline"):
        cls = el.get("class") or ""
        if not (cls.startswith("edge") or cls == "spoke"):
            continue
        u, v = str(el.get("data-ends")).split(" ")
        pts = np.array([[float(c) for c in p.split(",")] for p in str(el.get("points")).split()])
        paths.append((u, v, pts))
    (radius,) = radii
    return centres, radius, paths


def _figure_geometry(system: System, mode: str) -> tuple[dict[str, np.ndarray], float, list[tuple[str, str, np.ndarray]]]:
    fig = Figure(figsize=(6, 6))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    draw_network(ax, system, mode, (), system.attacked, "topology")
    centres, radii = {}, set()
    for patch in ax.patches:
        gid = patch.get_gid() or ""
        if gid.startswith("node:"):
            centres[gid[5:]] = np.asarray(patch.center, dtype=float)  # type: ignore[attr-defined]
            radii.add(float(patch.radius))  # type: ignore[attr-defined]
    paths = []
    for line in ax.lines:
        gid = line.get_gid() or ""
        if gid.startswith("edge:"):
            _, u, v = gid.split(":")
            paths.append((u, v, np.column_stack([line.get_xdata(), line.get_ydata()]).astype(float)))
    (radius,) = radii
    assert ax.get_aspect() == 1.0  # equal aspect: data distances are drawn distances
    return centres, radius, paths


@pytest.fixture(scope="module")
def paper19() -> System:
    return System(load_example("paper19"))


# --------------------------------------------------------------------------------------------
# no link through an agent


@pytest.mark.parametrize("mode", ["normal", "case-1", "case-2", "case-3"])
def test_no_link_of_the_paper19_drawing_passes_through_an_agent_it_does_not_join(paper19: System, mode: str) -> None:
    centres, radius, paths = _svg_geometry(network_svg(paper19, mode))
    assert len(centres) == paper19.n
    assert len([p for p in paths if p[0] in centres]) >= len(paper19.edges(mode))
    assert _violations(centres, radius, paths) == []


def test_the_paper19_links_that_crossed_cluster_p1_and_agent_19_now_go_around(paper19: System) -> None:
    centres, radius, paths = _svg_geometry(network_svg(paper19))
    by_ends = {(u, v): pts for u, v, pts in paths}
    for (u, v), avoid in {("7", "8"): ("3", "5"), ("12", "13"): ("19",)}.items():
        pts = by_ends[(u, v)]
        for w in avoid:
            assert min(_distance(centres[w], pts[k], pts[k + 1]) for k in range(len(pts) - 1)) > (1 + MARGIN) * radius


@pytest.mark.parametrize("seed", GENERATED)
def test_no_link_of_a_generated_clustered_network_passes_through_an_agent(seed: int) -> None:
    system = _generated(seed)
    for mode in system.modes:
        centres, radius, paths = _svg_geometry(network_svg(system, mode))
        assert len(centres) == system.n
        assert _violations(centres, radius, paths) == [], (seed, mode)


@pytest.mark.parametrize("mode", ["case-2", "case-3"])
def test_the_case_figures_topology_keeps_its_links_off_other_agents(paper19: System, mode: str) -> None:
    centres, radius, paths = _figure_geometry(paper19, mode)
    assert len(centres) == paper19.n and len(paths) == len(set(paper19.edges("normal")) | set(paper19.edges(mode)))
    assert _violations(centres, radius, paths) == []


@pytest.mark.parametrize("seed", GENERATED[::4])
def test_the_figure_of_a_generated_network_keeps_its_links_off_other_agents(seed: int) -> None:
    system = _generated(seed)
    centres, radius, paths = _figure_geometry(system, system.modes[-1])
    assert _violations(centres, radius, paths) == []


# --------------------------------------------------------------------------------------------
# weights and legends


def test_weights_are_written_on_every_link_when_asked_and_by_default_when_they_differ(paper19: System) -> None:
    def weights(svg: str) -> list[str]:
        return [el.text or "" for el in ET.fromstring(svg).iter(f"{SVG}text") if el.get("class") == "weight"]

    shown = weights(network_svg(paper19, "case-2", weights=True))
    assert sorted(shown) == sorted(str(w) for w in paper19.edges("case-2").values())
    assert weights(network_svg(paper19, "case-2", weights=False)) == []
    assert weights(network_svg(paper19, "case-2")) == shown  # paper19's weights are 1, 2 and 3
    uniform = System(random_clustered_spec(12, clusters=2, seed=1, attack=False, max_weight=1))
    assert weights(network_svg(uniform)) == []


def test_the_draw_command_writes_weights_on_request(tmp_path: object, capsys: pytest.CaptureFixture[str]) -> None:
    from glocal_verify.cli import main

    assert main(["draw", "--example", "paper19", "--no-weights"]) == 0
    assert 'class="weight"' not in capsys.readouterr().out
    assert main(["draw", "--example", "paper19", "--weights"]) == 0
    assert capsys.readouterr().out.count('class="weight"') == len(System(load_example("paper19")).edges("normal"))


def test_coinciding_sweep_curves_stay_apart_and_the_legend_covers_no_data() -> None:
    values = [10, 20, 30]
    series = {f"condition.{k}": [(1.0, 0.8, 1.0)] * len(values) for k in range(8)}
    fig = rates_figure("agents", values, series)
    fig.canvas.draw()
    (ax,) = fig.axes
    legend = ax.get_legend()
    assert legend is not None
    box, frame = legend.get_window_extent(), ax.get_window_extent()
    assert box.x0 >= frame.x1 or box.y1 <= frame.y0 or box.x1 <= frame.x0 or box.y0 >= frame.y1
    curves = [c.lines[0] for c in ax.containers]  # the data line of each errorbar
    xs = [tuple(np.round(np.asarray(line.get_xdata(), dtype=float), 6)) for line in curves]
    assert len(xs) == 8 and len(set(xs)) == 8
    assert len({line.get_marker() for line in curves}) == 8
    assert all(math.isclose(x[0], 0.0, abs_tol=0.3) for x in xs)  # small offsets around the first tick
