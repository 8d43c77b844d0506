"""The fast JSON text of audit rows is exactly json.dumps's text of their JSON form."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glocal_verify.reporting.audit_json import IndentedJson
from glocal_verify.results import audit_jsonable
from glocal_verify.results import Status

_leaves = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),  # non-ASCII and control characters included
    st.sampled_from(list(Status)),
    st.complex_numbers(allow_nan=False, allow_infinity=False),
    st.integers(-1000, 1000).map(np.int64),
    st.floats(allow_nan=True, allow_infinity=True, width=32).map(np.float32),
)
_values = st.recursive(
    _leaves,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.lists(inner, max_size=4).map(tuple),
        st.dictionaries(st.one_of(st.text(max_size=6), st.integers(0, 99)), inner, max_size=4),
    ),
    max_leaves=25,
)


@settings(max_examples=300, deadline=None)
@given(_values, st.integers(0, 3))
def test_the_written_text_is_json_dumps_of_the_json_form_at_any_depth(value: object, depth: int) -> None:
    expected = json.dumps(audit_jsonable(value), indent=2).replace("\n", "\n" + "  " * depth)
    assert IndentedJson().text(value, depth) == expected


def test_a_part_held_by_many_rows_reads_the_same_in_every_row() -> None:
    part = {"suspected": [3], "local.pencil": Status.HOLDS, "margin": 0.1}
    rows = [{"a": [i], "local": {"P1@1": part}} for i in range(5)]
    w = IndentedJson()
    texts = [w.text(r, 2) for r in rows]
    assert texts == [json.dumps(audit_jsonable(r), indent=2).replace("\n", "\n    ") for r in rows]


def test_a_value_json_cannot_write_is_refused_as_json_dumps_refuses_it() -> None:
    with pytest.raises(TypeError):
        json.dumps(audit_jsonable({"x": np.bool_(True)}))
    with pytest.raises(TypeError):
        IndentedJson().text({"x": np.bool_(True)})
    with pytest.raises(TypeError):
        IndentedJson().text({"x": object()})


def test_non_finite_complex_parts_keep_json_dumps_names() -> None:
    z = complex(math.inf, math.nan)
    assert IndentedJson().text([z]) == json.dumps(audit_jsonable([z]), indent=2)
