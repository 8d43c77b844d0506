"""MATLAB v5 files through ``scipy.io``: a nested dict written as structs and cell arrays, and read back.

The tree is a mapping of field names to values: a mapping becomes a struct, a list a 1 x n cell
array (of structs, char arrays, ...), an array a double matrix, a non-finite float a 1 x 1
double. Reading undoes it: a struct becomes a dict, a cell array a list, a char array a str;
numbers stay arrays (the caller knows the kind of each leaf).
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Any, Mapping

import numpy as np

__all__ = ["mat_bytes", "read_mat"]


def _mat_value(x: Any) -> Any:
    if isinstance(x, Mapping):
        return {k: _mat_value(v) for k, v in x.items()}
    if isinstance(x, list):
        out = np.empty((1, len(x)), dtype=object)
        for k, v in enumerate(x):
            out[0, k] = _mat_value(v)
        return out
    if isinstance(x, np.ndarray):
        return np.asarray(x, dtype=float)
    if isinstance(x, float) and not math.isfinite(x):
        return np.array(x)
    return x


def mat_bytes(tree: Mapping[str, Any]) -> bytes:
    """The contents of a MATLAB v5 file holding ``tree`` (compressed, long field names, 1-D arrays as rows).

    Parameters
    ----------
    tree : mapping
        Top-level variables; every field name must be a valid MATLAB identifier.
    """
    import scipy.io

    buf = io.BytesIO()
    scipy.io.savemat(buf, {k: _mat_value(v) for k, v in tree.items()}, format="5", long_field_names=True, do_compression=True, oned_as="row")
    return buf.getvalue()


def _from_mat(x: Any) -> Any:
    import scipy.io

    if isinstance(x, scipy.io.matlab.mat_struct):
        return {k: _from_mat(getattr(x, k)) for k in x._fieldnames}
    if isinstance(x, np.ndarray) and x.dtype == object:
        items = list(x.reshape(-1))
        if len(items) == 1 and isinstance(items[0], scipy.io.matlab.mat_struct):
            return _from_mat(items[0])  # a struct (loadmat wraps it in a 1 x 1 array)
        return [_from_mat(v) for v in items]  # a cell array: lists
    if isinstance(x, np.ndarray) and x.dtype.kind == "U":
        return "".join(x.reshape(-1)) if x.size else ""
    return x


def read_mat(path: str | Path) -> dict[str, Any]:
    """The variables of the MATLAB file ``path`` as nested dicts, lists, strings and arrays.

    Parameters
    ----------
    path : str or Path
    """
    import scipy.io

    data = scipy.io.loadmat(path, squeeze_me=False, struct_as_record=False, chars_as_strings=True)
    return {k: _from_mat(v) for k, v in data.items() if not k.startswith("__")}
