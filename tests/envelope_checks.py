"""Comparisons shared by the simulation tests that check a fast envelope against its reference."""

from __future__ import annotations

import numpy as np

__all__ = ["assert_envelopes_agree"]


def assert_envelopes_agree(rows: dict[str, np.ndarray], cols: dict[str, np.ndarray]) -> None:
    """Per observer, the same shape and entries within 1e-9 of the reference's largest entry (at least 1)."""
    assert rows.keys() == cols.keys()
    for name in rows:
        scale = max(1.0, float(np.max(cols[name], initial=0.0)))
        assert rows[name].shape == cols[name].shape, name
        assert np.max(np.abs(rows[name] - cols[name]), initial=0.0) <= 1e-9 * scale, name
