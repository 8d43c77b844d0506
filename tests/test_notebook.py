"""The tour notebook (docs/tour.ipynb) runs in a Jupyter kernel, and every result type a user
meets there shows itself: a rich (HTML or SVG) display where it has one, and a short ``repr``.

Each cell that shows an object is tagged ``show:<Type>``. :data:`RICH_DISPLAYS` lists the types
whose display must already be rich; :data:`SHORT_REPRS` the result types whose ``repr`` must
stay under :data:`REPR_LIMIT` characters. A type that gains its rich display or its short repr
joins the list.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Callable

import pytest

nbformat = pytest.importorskip("nbformat", reason="the test extra installs nbformat, nbclient and ipykernel")
nbclient = pytest.importorskip("nbclient", reason="the test extra installs nbformat, nbclient and ipykernel")

from glocal_verify import System, load_example, verify  # noqa: E402

NOTEBOOK = Path(__file__).resolve().parent.parent / "docs" / "tour.ipynb"
REPR_LIMIT = 300

#: tagged cells whose output must carry text/html (or image/svg+xml for a drawing)
RICH_DISPLAYS = ["System", "Report", "NetworkDrawing", "Assessment", "AuditResult", "ConditionResult", "NetworkDesign"]


def _system() -> System:
    return System(load_example("paper19"))


def _report() -> Any:
    return verify(_system(), ["privacy.kernel", "stealthy.zda"])


def _schedule() -> Any:
    from glocal_verify.simulation.schedule import Schedule

    return Schedule.from_spec(_system())


def _layout() -> Any:
    from glocal_verify.reporting.layout import network_layout

    return network_layout(_system())


def _central() -> Any:
    from glocal_verify.observers.central import design_central_observer

    return design_central_observer(_system())


def _uio() -> Any:
    from glocal_verify.observers.uio import local_uio

    system = _system()
    return local_uio(system, system.observers()[0])


def _bank() -> Any:
    from glocal_verify.simulation.observer_models import ObserverBank

    return ObserverBank.for_system(_system())


def _simulation() -> Any:
    from glocal_verify import simulate

    return simulate(_system(), horizon=1.0)


#: result types whose repr stays short, with a factory of a typical instance (paper19)
def _assessment() -> Any:
    return verify(_system(), simulate="never").assessment


def _result() -> Any:
    return _report().conditions[-1]


def _audit() -> Any:
    from glocal_verify.design.audit import audit

    return audit(_system(), 1, [3, 4, 5])


def _design() -> Any:
    from glocal_verify import loads_spec
    from glocal_verify.design.network import design_network

    ring = 'format = 1\nname = "ring6"\n[graph]\nnodes = 6\nedges = [[1,2],[2,3],[3,4],[4,5],[5,6],[6,1,2]]\n[monitor]\nvelocities = [1]\n'
    return design_network(System(loads_spec(ring, "ring6.toml")), max_attackers=1)


SHORT_REPRS: list[tuple[str, Callable[[], Any]]] = [
    ("System", _system),
    ("Report", _report),
    ("Assessment", _assessment),
    ("ConditionResult", _result),
    ("AuditResult", _audit),
    ("NetworkDesign", _design),
    ("Schedule", _schedule),
    ("NetworkLayout", _layout),
    ("CentralObserver", _central),
    ("UnknownInputObserver", _uio),
    ("ObserverBank", _bank),
    ("SimulationResult", _simulation),
]


@pytest.fixture(scope="module")
def executed(tmp_path_factory: pytest.TempPathFactory) -> Any:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    where = tmp_path_factory.mktemp("tour")
    limit = sys.getrecursionlimit()  # the Jupyter client raises it to 3000 for this process
    try:
        nbclient.NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(where)}}).execute()
    finally:
        sys.setrecursionlimit(limit)
    return nb


def _shown(nb: Any) -> dict[str, list[dict[str, Any]]]:
    out = {}
    for cell in nb.cells:
        for tag in cell.get("metadata", {}).get("tags", []):
            if tag.startswith("show:"):
                out[tag[5:]] = [o for o in cell.outputs if o.get("output_type") in ("execute_result", "display_data")]
    return out


@pytest.mark.slow
def test_the_tour_notebook_runs_and_every_tagged_cell_shows_its_object(executed: Any) -> None:
    errors = [o for c in executed.cells if c.cell_type == "code" for o in c.outputs if o.get("output_type") == "error"]
    assert errors == []
    shown = _shown(executed)
    assert set(RICH_DISPLAYS) <= set(shown)
    for name, outputs in shown.items():
        assert outputs and all("text/plain" in o["data"] for o in outputs), name


@pytest.mark.parametrize("name", RICH_DISPLAYS)
def test_each_result_type_displays_richly_in_the_notebook(executed: Any, name: str) -> None:
    (output,) = _shown(executed)[name]
    assert {"text/html", "image/svg+xml"} & set(output["data"]), sorted(output["data"])


@pytest.mark.parametrize("name,make", SHORT_REPRS, ids=[n for n, _ in SHORT_REPRS])
def test_a_result_types_repr_is_short(name: str, make: Callable[[], Any]) -> None:
    obj = make()
    assert type(obj).__name__ == name
    text = repr(obj)
    assert len(text) < REPR_LIMIT and "\n" not in text, text[:400]
