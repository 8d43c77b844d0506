"""A :class:`~glocal_verify.simulation.deployment.Deployment` as a file: MATLAB ``.mat``, JSON or NumPy ``.npz``.

:func:`export_observers` writes the deployment that
:func:`~glocal_verify.simulation.deployment.design_deployment` computed (the central observer,
every local unknown-input observer with its mode-matched dynamics, the attack-free thresholds,
the monitor sets, the modes' Laplacians and the switching schedule) in the stated and
versioned schema of ``docs/export.md`` (:data:`SCHEMA`, :data:`SCHEMA_VERSION`). It renders
only: every design and threshold is in the value it is given. :func:`read_deployment` reads
any of the three formats back into the nested structure of dicts, lists, strings, numbers and
arrays that :func:`deployment_tree` builds.

Formats
-------
``mat``
    MATLAB v5 (:func:`glocal_verify.extra.matlab.mat_bytes`): the tree as nested structs, lists
    of records as cell arrays of structs, lists of strings as cell arrays of char; every field
    name is a valid MATLAB identifier. Reads with ``load`` in MATLAB/Octave and ``scipy.io.loadmat``.
``json``
    One JSON object; matrices as lists of rows, complex eigenvalues as ``*_re``/``*_im``
    vectors, a non-finite number as ``null``.
``npz``
    ``numpy.savez_compressed`` with one array per leaf, keyed by its path
    (``local/0/F``, ``thresholds/observers/1/envelope``); strings are unicode arrays, so
    ``numpy.load(allow_pickle=False)`` reads it.
"""

from __future__ import annotations

import io
import itertools
import json
import math
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping

import numpy as np

from glocal_verify.errors import ArgumentError, GlocalVerifyError, shorten
from glocal_verify.extra.matlab import mat_bytes, read_mat
from glocal_verify.reporting.output import check_output_file, write_bytes_atomic
from glocal_verify.simulation.certified_thresholds import ROUNDING
from glocal_verify.simulation.deployment import CentralDesign, Deployment, LocalDesign
from glocal_verify.simulation.sampled_deployment import ALGORITHM1, SampledDeployment
from glocal_verify.spec.arguments import instance_arg
from glocal_verify.spec.types import NORMAL_MODE, Label
from glocal_verify.version import __version__

__all__ = [
    "EXPORT_FORMATS",
    "SCHEMA",
    "SCHEMA_VERSION",
    "READABLE_VERSIONS",
    "ExportError",
    "deployment_tree",
    "export_observers",
    "read_deployment",
]

#: the schema's name, stored in every file (``schema``)
SCHEMA = "glocal-verify.observers"
#: the schema's version (``schema_version``); docs/export.md says what each version holds
SCHEMA_VERSION = 2
#: the versions :func:`read_deployment` reads (1: no per-mode decoupling matrices, no sampled section)
READABLE_VERSIONS = (1, 2)
#: the file formats, by the name ``--format`` takes (and the file suffix it implies)
EXPORT_FORMATS = ("mat", "json", "npz")

# the kinds of the schema's leaves, by field name (what read_deployment restores)
_TEXT = frozenset(
    {
        "schema", "generator", "name", "label_type", "state", "mode", "method", "note", "cluster", "center", "hurwitz", "kind", "description",
        "equations", "controller", "start_state", "algorithm1", "safe_mode", "initial", "status", "detected_by", "channel", "observer", "assumes",
        "attack_kind",
    }
)  # fmt: skip
_TEXTS = frozenset({"labels", "positions", "velocities", "channels", "nodes", "notes", "u", "v", "not_decoupled", "noise_channels", "attack_actuators"})
_NUMBER = frozenset(
    {
        "schema_version", "n", "alpha", "gamma", "present", "stability_margin", "hurwitz_margin", "box", "rounding", "time", "horizon", "step",
        "period", "switch_delay", "disturbance", "within", "global_within", "global_detection", "min_size", "size_horizon", "size", "sample",
        "guaranteed_sample", "attack_start", "samples",
    }
)  # fmt: skip
_VECTOR = frozenset({"eigenvalues_re", "eigenvalues_im", "t", "delta", "tail", "noise", "noise_std", "switch_window", "covered"})
_RECORDS = frozenset({"modes", "local", "designs", "segments", "observers", "switches", "detectors", "blocks"})


class ExportError(GlocalVerifyError, ValueError):
    """A deployment file that cannot be written or read (unknown format, wrong schema)."""


# --------------------------------------------------------------------------------------------
# the tree


def _text(label: Label) -> str:
    return str(label)


def _texts(labels: Any) -> list[str]:
    return [_text(a) for a in labels]



def _complex(eig: np.ndarray) -> dict[str, np.ndarray]:
    return {"eigenvalues_re": eig.real.copy(), "eigenvalues_im": eig.imag.copy()}


def _central(co: CentralDesign | None, note: str) -> dict[str, Any]:
    if co is None:
        return {"present": 0, "note": note, "mode": NORMAL_MODE}
    return {
        "present": 1,
        "note": "",
        "mode": co.mode,
        "equations": "dz/dt = F z + H y, r = y - C z, z(0) = 0, F = A - H C (A: normal-mode model, kept in every mode)",
        "channels": list(co.channels),
        "A": co.A,
        "C": co.C,
        "H": co.H,
        "F": co.F,
        **_complex(co.eigenvalues),
        "stability_margin": co.stability_margin,
        "method": co.method,
    }


def _uio_fields(u: Any) -> dict[str, Any]:
    """The design matrices of one UIO (eqs. uio_conds_1-uio_conds_3) and its certified spectrum."""
    return {
        "A": u.A,
        "E": u.E,
        "h": u.h,
        "T": u.T,
        "A1": u.A1,
        "K1": u.K1,
        "F": u.F,
        "K": u.K,
        **_complex(np.asarray(u.eigenvalues, dtype=complex)),
        "hurwitz_margin": float(u.hurwitz_margin),
        "hurwitz": u.hurwitz.value,
    }


def _local(d: LocalDesign) -> dict[str, Any]:
    u = d.uio
    return {
        "name": d.name,
        "cluster": u.cluster,
        "center": _text(u.center),
        "equations": "in mode q (designs[.].mode, else the normal-mode fields): dz/dt = F_q z + K_q y, x_hat = z + h_q y, "
        "r = y - C_loc x_hat = Ry_q y - Rz z, y = C_loc S x; z(0) = -h y(0) (x_hat(0) = 0); "
        "at a switch from mode p to mode q: z <- z + (h_p - h_q) y (x_hat stays continuous)",
        "nodes": _texts(u.nodes),
        "positions": _texts(u.positions),
        "velocities": _texts(u.velocities),
        "channels": list(d.channels),
        "S": d.S,
        "C_loc": u.C,
        "E": u.E,
        "A": u.A,
        "h": u.h,
        "T": u.T,
        "A1": u.A1,
        "K1": u.K1,
        "F": d.F,
        "K": d.K,
        "Ry": d.Ry,
        "Rz": d.Rz,
        "designs": [{"mode": g.mode, **_uio_fields(g.uio), "Ry": g.Ry, "reset": g.reset} for g in d.designs],
        "not_decoupled": [m for m, _ in d.not_decoupled],
        **_complex(np.asarray(u.eigenvalues, dtype=complex)),
        "hurwitz_margin": float(u.hurwitz_margin),
        "hurwitz": u.hurwitz.value,
        "notes": list(d.notes),
    }


def _finite_or(x: Any, default: float = math.nan) -> float:
    return float(x) if x is not None else default


def _sampled(d: SampledDeployment | None, note: str) -> dict[str, Any]:
    """The sampled deployment: detectors per mode, certified thresholds over the schedule,
    Algorithm 1 and the guarantee (docs/export.md, "The sampled deployment")."""
    if d is None:
        return {"present": 0, "note": note}
    th = d.thresholds
    model = th.model
    spec = model.spec
    noise_channels = sorted({c for det in d.detectors for c in det.channels})
    tree: dict[str, Any] = {
        "present": 1,
        "note": "",
        "period": th.period,
        "switch_delay": int(d.implementation.switch_delay),
        "controller": d.implementation.controller,
        "start_state": "z(0) = 0 for every detector (the certified thresholds assume it)",
        "equations": "z[k+1] = Fo z[k] + Go y[k], r[k] = Ry y[k] - Rz z[k], y[k] = C x(k h) + n[k] (rows: channels), with the matrices of the "
        "mode active at sample k; when the mode changes from p to q at sample s: z[s] <- z[s] + (H_p - H_q) y[s] before r[s] and the update",
        "algorithm1": ALGORITHM1,
        "safe_mode": d.safe_mode or "",
        "uncertainty": {
            "initial": model.initial,
            "box": model.box,
            "disturbance": model.disturbance,
            "noise_channels": noise_channels,
            "noise": model.noise(tuple(noise_channels)) if noise_channels else np.zeros(0),
            "noise_std": model.sigma(tuple(noise_channels)) if noise_channels else np.zeros(0),
        },
        "detectors": [
            {"name": det.name, "kind": det.kind, "channels": list(det.channels), "C": det.C, "modes": [{"mode": m.mode, "Fo": m.Fo, "Go": m.Go, "Ry": m.Ry, "Rz": m.Rz, "H": m.H} for m in det.modes]}
            for det in d.detectors
        ],
        "thresholds": {
            "rule": {
                "kind": "certified",
                "description": "theta[k, j] is a certified upper bound of |r[k, j]| over every admissible attack-free run: |x(0)|_inf <= box "
                "(initial = state; or the box of initial estimation errors), |n| <= noise per channel and sample, |d(t)| <= disturbance, "
                "detectors from z(0) = 0 running the equations above (rounding allowance 1e-9 of the uncertainty scale), the "
                "defender's schedule; a residual above it is an alarm",
                "rounding": ROUNDING,
                "assumes": "the spec's [uncertainty] (box, noise, disturbance); z(0) = 0; the switches of schedule.segments at the samples "
                "ceil(time / period); a non-finite theta (null in JSON) promises nothing there",
            },
            "samples": th.samples,
            "t": np.arange(th.samples) * th.period,
            "segments": [{"sample": s, "time": s * th.period, "mode": m} for s, m in th.segments],
            "observers": [
                {"name": ds.name, "channels": list(ds.channels), "theta": ds.theta, "tail": ds.tail, "covered": np.array([1.0 if c else 0.0 for _, _, c in ds.segments])}
                for ds in th.detectors.values()
            ],
        },
        "after_switch": {"present": 0, "mode": d.safe_mode or ""},
        "guarantee": {"present": 0},
        "notes": list(d.notes),
    }
    a = th.after_switch
    if a is not None:
        tree["after_switch"] = {
            "present": 1,
            "mode": a.mode,
            "description": "the control centre's threshold m = k - s samples after Algorithm 1's switch at sample s: the block whose sample is "
            "the largest at or below s, theta[m] for m < rows, tail after",
            "blocks": [{"sample": s0, "theta": t, "tail": tl} for s0, t, tl in zip(a.starts, a.theta, a.tail)],
        }
    g = d.guarantee
    if g is not None:
        tree["guarantee"] = {
            "present": 1,
            "status": g.status.value,
            "attack_kind": str(g.attack.get("kind", "")),
            "attack_actuators": [str(x) for x in g.attack.get("actuators", [])],
            "attack_start": g.attack.get("start_sample", 0),
            "size": g.size,
            "detected_by": g.detected_by or "",
            "within": _finite_or(g.within),
            "switch_window": np.array(g.switch_window if g.switch_window else [math.nan, math.nan], dtype=float),
            "global_within": _finite_or(g.global_within),
            "global_detection": _finite_or(g.global_detection),
            "min_size": _finite_or(g.min_size),
            "size_horizon": g.size_horizon,
            "local": [
                {"observer": st.observer, "guaranteed_sample": _finite_or(st.guaranteed), "within": _finite_or(st.within), "channel": st.channel or "", "min_size": _finite_or(st.min_size)}
                for st in g.local
            ],
            "notes": list(g.notes),
        }
    return tree


def deployment_tree(deployment: Deployment) -> dict[str, Any]:
    """``deployment`` as the nested structure of the export schema.

    Parameters
    ----------
    deployment : Deployment
        What :func:`~glocal_verify.simulation.deployment.design_deployment` computed.

    Returns
    -------
    dict
        Keys and meaning in ``docs/export.md``: ``schema``, ``schema_version``, ``generator``,
        ``system``, ``monitors``, ``central``, ``local``, ``thresholds``, ``schedule``, ``notes``.
        Labels are written as text (``system.label_type`` says whether they were integers).
    """
    if not isinstance(deployment, Deployment):
        raise ArgumentError(f"deployment: expected a Deployment (glocal_verify.simulation.deployment.design_deployment(system)), got {type(deployment).__name__}")
    d = deployment
    tree_thr: dict[str, Any] = {"present": 0, "horizon": d.horizon, "step": d.step}
    if d.thresholds is not None:
        rule = d.thresholds.rule
        tree_thr = {
            "present": 1,
            "horizon": d.horizon,
            "step": d.step,
            "rule": {"kind": rule.kind, "box": float(rule.box), "rounding": float(rule.rounding), "description": rule.describe()},
            "equations": "threshold_k(t) = envelope[t, k] + rounding * max(box, ||s(t)||_2), s the plant and observer state; "
            "envelope[t, k] + rounding * box is the state-free lower bound",
            "t": d.thresholds.t,
            "observers": [{"name": o.name, "channels": list(o.channels), "envelope": o.envelope} for o in d.thresholds.observers],
        }
    switches = [
        {"mode": s.mode, "u": [_text(u) for u, _, _ in s.links], "v": [_text(v) for _, v, _ in s.links], "delta": np.array([float(w) for *_, w in s.links])}
        for s in d.switches
    ]
    return {
        "schema": SCHEMA,
        "schema_version": SCHEMA_VERSION,
        "generator": f"glocal-verify {__version__}",
        "system": {
            "name": d.name,
            "n": len(d.labels),
            "labels": _texts(d.labels),
            "label_type": "int" if all(isinstance(a, int) for a in d.labels) else "str",
            "state": "x = [positions; velocities] of the agents in the order of labels (2N entries)",
            "alpha": d.alpha,
            "gamma": d.gamma,
            "modes": [{"name": m, "L": L} for m, L in d.laplacians],
        },
        "monitors": {
            "positions": _texts(d.monitored_positions),
            "velocities": _texts(d.monitored_velocities),
            "channels": list(d.channels),
            "C": d.C,
        },
        "central": _central(d.central, d.central_note),
        "local": [_local(x) for x in d.local],
        "thresholds": tree_thr,
        "schedule": {
            "segments": [{"time": float(t), "mode": m} for t, m in d.schedule.segments],
            "switches": switches,
        },
        "sampled": _sampled(d.sampled, "the spec has no [implementation] with a sampled controller" if d.sampled is None else ""),
        "notes": list(d.notes),
    }


# --------------------------------------------------------------------------------------------
# writers


def _json_value(x: Any) -> Any:
    if isinstance(x, Mapping):
        return {k: _json_value(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_value(v) for v in x]
    if isinstance(x, np.ndarray):
        return _json_value(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return int(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(float(x)) else None
    return x


def _json_scalar(x: Any) -> str:
    """The JSON text of one leaf as ``json.dumps(_json_value(x))`` writes it."""
    return json.dumps(_json_value(x), allow_nan=False)


def _json_floats(values: list[Any]) -> list[str]:
    """JSON texts of the floats of one array row: ``repr`` (what ``json.dumps`` writes) or ``null``."""
    return [repr(v) if math.isfinite(v) else "null" for v in values]


def _json_chunks(x: Any, level: int = 0) -> Iterator[str]:
    """The text of ``json.dumps(_json_value(x), indent=1)``, in pieces, without the nested lists of
    Python floats: an array is converted one row at a time (a 2N x 2N matrix of a large network
    never exists as 4 N^2 float objects), and each row's text is joined at once (the pure-Python
    encoder that ``indent`` selects writes a float at a time)."""
    pad, inner = "\n" + " " * level, "\n" + " " * (level + 1)
    if isinstance(x, np.ndarray) and x.dtype.kind in "fiu" and x.size:
        if x.ndim == 1:
            texts = _json_floats(x.astype(float).tolist()) if x.dtype.kind == "f" else [str(int(v)) for v in x.tolist()]
            yield "[" + inner + ("," + inner).join(texts) + pad + "]"
            return
        yield "["
        for k in range(x.shape[0]):
            yield ("," if k else "") + inner
            yield from _json_chunks(x[k], level + 1)
        yield pad + "]"
    elif isinstance(x, np.ndarray):
        yield from _json_chunks(x.tolist(), level)
    elif isinstance(x, Mapping):
        if not x:
            yield "{}"
            return
        yield "{"
        for k, (key, v) in enumerate(x.items()):
            yield ("," if k else "") + inner + json.dumps(str(key)) + ": "
            yield from _json_chunks(v, level + 1)
        yield pad + "}"
    elif isinstance(x, (list, tuple)):
        if not x:
            yield "[]"
            return
        yield "["
        for k, v in enumerate(x):
            yield ("," if k else "") + inner
            yield from _json_chunks(v, level + 1)
        yield pad + "]"
    else:
        yield _json_scalar(x)


def _batched(texts: Iterable[str], size: int = 1 << 20) -> Iterator[bytes]:
    """UTF-8 of ``texts`` in blocks of about ``size`` characters (one write per block, not per piece)."""
    block: list[str] = []
    held = 0
    for t in texts:
        block.append(t)
        held += len(t)
        if held >= size:
            yield "".join(block).encode("utf-8")
            block, held = [], 0
    if block:
        yield "".join(block).encode("utf-8")


def _flatten(x: Any, prefix: str, out: dict[str, np.ndarray]) -> None:
    if isinstance(x, Mapping):
        for k, v in x.items():
            _flatten(v, f"{prefix}{k}/", out)
        return
    key = prefix[:-1]
    if isinstance(x, list) and (not x or isinstance(x[0], (Mapping, list))) and key.rsplit("/", 1)[-1] in _RECORDS:
        out[f"{key}/#"] = np.array(len(x))
        for k, v in enumerate(x):
            _flatten(v, f"{prefix}{k}/", out)
        return
    if isinstance(x, list):
        out[key] = np.array([str(v) for v in x], dtype=str) if x else np.zeros(0, dtype="<U1")
    else:
        out[key] = np.asarray(x)


def _encode(tree: Mapping[str, Any], fmt: str) -> bytes | Iterator[bytes]:
    """The file's bytes: JSON streamed in blocks (the text of ``json.dumps(..., indent=1)``),
    .mat and .npz whole (compressed, small)."""
    if fmt == "json":
        return _batched(itertools.chain(_json_chunks(tree), ["\n"]))
    if fmt == "mat":
        return mat_bytes(tree)
    buf = io.BytesIO()
    flat: dict[str, np.ndarray] = {}
    _flatten(tree, "", flat)
    np.savez_compressed(buf, **flat)  # type: ignore[arg-type]
    return buf.getvalue()


def _format_of(path: Path, fmt: str | None) -> str:
    chosen = fmt if fmt is not None else path.suffix.lower().lstrip(".")
    if chosen not in EXPORT_FORMATS:
        how = f"format {fmt!r}" if fmt is not None else f"the suffix of {path.name!r}"
        raise ExportError(f"{how} is not one of {', '.join(EXPORT_FORMATS)}")
    return chosen


def export_observers(deployment: Deployment, path: str | Path, fmt: str | None = None) -> Path:
    """Write ``deployment`` to ``path`` (module docstring, ``docs/export.md``).

    Parameters
    ----------
    deployment : Deployment
        What :func:`~glocal_verify.simulation.deployment.design_deployment` computed.
    path : str or Path
        Output file, written atomically.
    fmt : str, optional
        ``"mat"``, ``"json"`` or ``"npz"``; default: the suffix of ``path``.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    ExportError
        For an unknown format.
    """
    if not isinstance(deployment, Deployment):
        raise ArgumentError(
            f"export_observers: expected a Deployment (design_deployment(system) computes one), got {type(deployment).__name__}"
        )
    instance_arg("path", path, (str, Path), "a file name (str or Path)")
    p = Path(path)
    chosen = _format_of(p, fmt)
    check_output_file(p, what=str(p))  # a bad path fails before the file is encoded
    return write_bytes_atomic(p, _encode(deployment_tree(deployment), chosen))


# --------------------------------------------------------------------------------------------
# reader


def _restore(key: str, x: Any) -> Any:
    """A leaf or subtree, as read by any format, in the schema's kind for ``key``."""
    if isinstance(x, Mapping):
        return {k: _restore(k, v) for k, v in x.items()}
    if key in _RECORDS:
        return [_restore("", v) for v in x]
    if key in _TEXT:
        return str(x)
    if key in _TEXTS:
        return [str(v) for v in x]
    if key in _NUMBER:
        flat = np.asarray(np.nan if x is None else x, dtype=float).reshape(-1)
        v = float(flat[0]) if flat.size else math.nan
        return int(v) if key in ("schema_version", "n", "present", "sample", "samples", "switch_delay") and math.isfinite(v) else v
    if key in _VECTOR:
        return np.asarray(x, dtype=float).reshape(-1)
    return np.atleast_2d(np.asarray(x, dtype=float))


def _from_npz(flat: Mapping[str, np.ndarray]) -> dict[str, Any]:
    tree: dict[str, Any] = {}
    for key, value in flat.items():
        node = tree
        parts = key.split("/")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = value.item() if value.ndim == 0 and value.dtype.kind in "Uif" else value

    def lists(x: Any) -> Any:
        if isinstance(x, dict):
            if "#" in x:
                return [lists(x[str(k)]) for k in range(int(x["#"]))]
            return {k: lists(v) for k, v in x.items()}
        return x

    return dict(lists(tree))


def _small_int(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) and math.isfinite(float(value)) and abs(float(value)) < 2**31


def _parse_deployment(p: Path, fmt: str) -> dict[str, Any]:
    """The schema's tree of the file ``p`` in format ``fmt``, unchecked (:func:`read_deployment` checks it)."""
    if fmt == "json":
        raw: Any = json.loads(p.read_text(encoding="utf-8"))
    elif fmt == "mat":
        raw = read_mat(p)
    else:
        with np.load(p, allow_pickle=False) as z:
            raw = _from_npz({k: z[k] for k in z.files})
    if not isinstance(raw, dict):
        raise ExportError(f"{shorten(str(p), 120)}: not a deployment file (its top level is a {type(raw).__name__}, not a table)")
    return {k: _restore(k, v) for k, v in raw.items()}


def read_deployment(path: str | Path) -> dict[str, Any]:
    """Read a file of :func:`export_observers` (any format, by its suffix) into the schema's tree.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict
        The structure :func:`deployment_tree` returns: matrices as 2-D float arrays, vectors
        as 1-D arrays, lists of strings as lists, numbers as Python numbers.

    Raises
    ------
    ExportError
        For an unknown suffix, a file that cannot be read or parsed (corrupt, truncated, of
        another kind), or a file of another schema or a newer version.
    """
    instance_arg("read_deployment", path, (str, Path), "a file name (str or Path)")
    p = Path(path)
    fmt = _format_of(p, None)
    try:
        tree = _parse_deployment(p, fmt)
    except ExportError:
        raise
    except OSError as exc:
        raise ExportError(f"{shorten(str(p), 120)}: cannot read ({exc.strerror or exc})") from None
    except MemoryError:
        raise
    except Exception as exc:  # noqa: BLE001 - the parsers of an untrusted file
        # a corrupt or foreign file trips the parsers in many ways (UnicodeDecodeError,
        # JSONDecodeError, zlib.error, zipfile.BadZipFile, scipy's MatReadError, EOFError,
        # RecursionError, KeyError, OverflowError ...): one line naming the file and the cause
        raise ExportError(f"{shorten(str(p), 120)}: not a readable {fmt} deployment file ({type(exc).__name__}: {shorten(str(exc), 120)})") from None
    if tree.get("schema") != SCHEMA or not _small_int(tree.get("schema_version")) or int(tree["schema_version"]) not in READABLE_VERSIONS:
        raise ExportError(
            f"{shorten(str(p), 120)}: not a {SCHEMA} file of version {' or '.join(map(str, READABLE_VERSIONS))} "
            f"(schema {shorten(repr(tree.get('schema')), 60)}, version {shorten(repr(tree.get('schema_version')), 30)}); export it again with glocal-verify {__version__}"
        )
    return tree
