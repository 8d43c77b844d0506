"""json_preview cuts the JSON text of a witness exactly as encoding it whole and cutting would."""

from __future__ import annotations

import json
from fractions import Fraction
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from glocal_verify.results import Status, json_preview, jsonable

_leaves = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-10**6, 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8),
    st.fractions(max_denominator=50),
    st.complex_numbers(allow_nan=False, max_magnitude=1e6),
    st.sampled_from(list(Status)),
    st.lists(st.floats(-1e3, 1e3), max_size=12).map(np.array),
    st.lists(st.complex_numbers(max_magnitude=10), max_size=6).map(lambda v: np.array(v, dtype=complex)),
    st.lists(st.booleans(), max_size=5).map(lambda v: np.array(v, dtype=bool)),
    st.just(np.float64(0.5)),
)
_values = st.recursive(_leaves, lambda inner: st.one_of(st.lists(inner, max_size=5), st.tuples(inner, inner), st.dictionaries(st.text(max_size=5), inner, max_size=5)), max_leaves=30)


def _cut(obj: Any, limit: int) -> str:
    text = json.dumps(jsonable(obj), separators=(", ", ": "))
    return text if len(text) <= limit else text[: limit - 3] + "..."


@settings(max_examples=300, deadline=None)
@given(_values, st.integers(5, 200))
def test_the_preview_equals_the_cut_full_encoding_for_any_witness(obj: Any, limit: int) -> None:
    assert json_preview(obj, limit) == _cut(obj, limit)


def test_a_long_vector_is_previewed_from_its_front() -> None:
    witness = {"lambda": Fraction(1, 3), "xi": np.arange(100_000, dtype=float), "note": "long"}
    text = json_preview(witness, 60)
    assert text == _cut(witness, 60)
    assert len(text) == 60 and text.endswith("...")
