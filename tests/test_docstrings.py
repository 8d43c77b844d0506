"""Every public callable of the package is documented, and every parameter it takes is named
in its docstring (numpydoc ``Parameters`` section or prose)."""

from __future__ import annotations

import inspect

import pytest

import glocal_verify

PUBLIC = [getattr(glocal_verify, n) for n in glocal_verify.__all__]
CALLABLES = [obj for obj in PUBLIC if inspect.isfunction(obj)]


@pytest.mark.parametrize("func", CALLABLES, ids=[f.__name__ for f in CALLABLES])
def test_public_functions_document_every_parameter(func) -> None:  # type: ignore[no-untyped-def]
    doc = inspect.getdoc(func)
    assert doc, f"{func.__name__} has no docstring"
    for name, param in inspect.signature(func).parameters.items():
        if param.kind in (param.VAR_POSITIONAL, param.VAR_KEYWORD):
            continue
        assert name in doc, f"{func.__name__}: parameter {name!r} is not documented"


@pytest.mark.parametrize("obj", [o for o in PUBLIC if inspect.isclass(o)], ids=lambda o: o.__name__)
def test_public_classes_have_docstrings(obj) -> None:  # type: ignore[no-untyped-def]
    assert inspect.getdoc(obj)
