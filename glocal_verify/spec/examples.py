"""The bundled example specifications (``data/*.toml``): paper19 and its case-3 companion."""

from __future__ import annotations

from importlib import resources
from typing import TYPE_CHECKING

from glocal_verify.errors import SpecError

if TYPE_CHECKING:
    from glocal_verify.spec.types import SystemSpec

__all__ = [
    "example_names",
    "example_text",
    "load_example",
]

# --------------------------------------------------------------------------------------------
# bundled examples


def example_names() -> tuple[str, ...]:
    """Names of the specifications bundled with the package."""
    root = resources.files("glocal_verify.spec").joinpath("data")
    return tuple(sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".toml")))


def example_text(name: str) -> str:
    """TOML text of a bundled example (e.g. ``"paper19"``)."""
    if name not in example_names():
        raise SpecError("", f"no bundled example named {name!r} (available: {', '.join(example_names())})")
    return resources.files("glocal_verify.spec").joinpath(f"data/{name}.toml").read_text(encoding="utf-8")


def load_example(name: str) -> SystemSpec:
    """Load the bundled example specification called ``name`` (see :func:`example_names`)."""
    from glocal_verify.spec.load import loads_spec

    return loads_spec(example_text(name), source=f"<example {name}>")
