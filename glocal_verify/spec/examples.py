"""The bundled example specifications (``data/*.toml``): paper19, its case-3 companion, and the
counterexample specs of the findings report (``data/findings/*.toml``, named ``findings/NAME``).

They are package data: every command that reads them (``--example NAME``, ``example NAME``,
``findings``) works from an installed wheel alone, wherever it runs.
"""

from __future__ import annotations

from importlib import resources
from importlib.resources.abc import Traversable
from typing import TYPE_CHECKING

from glocal_verify.errors import SpecError

if TYPE_CHECKING:
    from glocal_verify.spec.types import SystemSpec

__all__ = [
    "FINDINGS_PREFIX",
    "example_names",
    "finding_names",
    "example_text",
    "load_example",
]

#: the names of the bundled counterexample specs start with this
FINDINGS_PREFIX = "findings/"

# --------------------------------------------------------------------------------------------
# bundled examples


def _data() -> Traversable:
    return resources.files("glocal_verify.spec").joinpath("data")


def _stems(folder: Traversable) -> tuple[str, ...]:
    return tuple(sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml") and p.is_file()))


def example_names() -> tuple[str, ...]:
    """Names of the system specifications bundled with the package (``paper19`` ...)."""
    return _stems(_data())


def finding_names() -> tuple[str, ...]:
    """Names of the bundled counterexample specs of the findings report (``findings/NAME``)."""
    folder = _data().joinpath("findings")
    return tuple(FINDINGS_PREFIX + s for s in _stems(folder)) if folder.is_dir() else ()


def example_text(name: str) -> str:
    """TOML text of a bundled example (e.g. ``"paper19"`` or ``"findings/central-hurwitz-infeasible"``)."""
    if name in example_names():
        return _data().joinpath(f"{name}.toml").read_text(encoding="utf-8")
    if name in finding_names():
        return _data().joinpath("findings", f"{name[len(FINDINGS_PREFIX):]}.toml").read_text(encoding="utf-8")
    more = f", and {len(finding_names())} counterexamples findings/NAME (glocal-verify example --list)" if finding_names() else ""
    raise SpecError("", f"no bundled example named {name!r} (available: {', '.join(example_names())}{more})")


def load_example(name: str) -> SystemSpec:
    """Load the bundled example specification called ``name`` (see :func:`example_names` and
    :func:`finding_names`)."""
    from glocal_verify.spec.load import loads_spec

    return loads_spec(example_text(name), source=f"<example {name}>")
