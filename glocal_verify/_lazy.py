"""Public names of a package imported on first use (PEP 562), shared by the package initialisers.

Layer: none of the package's own; imports only the standard library.
"""

from __future__ import annotations

import importlib
from typing import Any, Callable, Mapping, MutableMapping

__all__ = ["lazy_getattr"]


def lazy_getattr(package: str, names: Mapping[str, str], namespace: MutableMapping[str, Any]) -> Callable[[str], Any]:
    """A module ``__getattr__`` that imports ``names[name]`` on first access and keeps the value.

    Parameters
    ----------
    package : str
        The package's name, for the error message.
    names : mapping
        Public name -> module that defines it.
    namespace : mutable mapping
        The package's ``globals()``, where a loaded name is kept.
    """

    def __getattr__(name: str) -> Any:
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    return __getattr__
