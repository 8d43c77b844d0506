"""The files of a sweep: the results table (Parquet or CSV), the Markdown summary and its plots.

:func:`sweep_outputs` checks every location before a sweep starts (the output policy of
:mod:`glocal_verify.runtime.files`); :func:`write_sweep` writes what
:func:`~glocal_verify.design.sweep.compute_sweep` computed, all or nothing (an
:class:`~glocal_verify.runtime.files.OutputFolder`), and renders the rates of
:func:`~glocal_verify.design.sweep.sweep_rates` as the summary and one plot per grid parameter.
Nothing here runs a member or computes a rate.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

from glocal_verify.design.sweep import COLUMNS, AxisRates, SweepPlan, SweepRates, SweepRun
from glocal_verify.errors import SpecError
from glocal_verify.runtime.files import OutputFolder, check_output_dir, check_output_file, write_bytes_atomic
from glocal_verify.words import slug

__all__ = ["SweepResult", "summary_markdown", "sweep_outputs", "write_sweep"]


@dataclass(frozen=True, slots=True)
class SweepResult:
    """What a sweep wrote.

    Attributes
    ----------
    rows : tuple of dict
        Every result row, in member order.
    out : Path
        The results file.
    summary : Path or None
        The Markdown summary.
    computed, resumed : int
        Members computed in this run and members taken from earlier parts.
    """

    rows: tuple[dict[str, Any], ...]
    out: Path
    summary: Path | None
    computed: int
    resumed: int

    def __repr__(self) -> str:
        members = len({r.get("member") for r in self.rows})
        return f"<SweepResult {members} members, {len(self.rows)} rows ({self.computed} computed, {self.resumed} resumed) in {self.out.name}>"

    def _repr_html_(self) -> str:
        from html import escape

        pol: dict[str, int] = {}
        for r in self.rows:
            key = str(r.get("polarity") or ("favourable" if r.get("favourable") else "unfavourable" if r.get("favourable") is False else "undecided"))
            pol[key] = pol.get(key, 0) + 1
        counts = ", ".join(f"{n} {k}" for k, n in sorted(pol.items()))
        return f"<div><p><b>{escape(counts)}</b> &mdash; sweep results in <code>{escape(str(self.out))}</code></p></div>"


#: how the sweep's files are written: ``put(path, data)`` (default
#: :func:`~glocal_verify.runtime.files.write_bytes_atomic`; :func:`write_sweep` stages its outputs in an
#: :class:`~glocal_verify.runtime.files.OutputFolder`)
Put = Callable[[Path, bytes], Any]


def _columns(rows: Iterable[Mapping[str, Any]]) -> list[str]:
    params = sorted({k for r in rows for k in r if k.startswith("param.")})
    return [COLUMNS[0]] + params + list(COLUMNS[1:])


def _write_table(rows: Sequence[Mapping[str, Any]], out: Path, put: Put = write_bytes_atomic) -> None:
    cols = _columns(rows)
    if out.suffix.lower() == ".csv":
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=cols, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({c: ("" if r.get(c) is None else r.get(c)) for c in cols})
        put(out, buf.getvalue().encode("utf-8"))
        return
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pylist([{c: r.get(c) for c in cols} for r in rows])
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    put(out, sink.getvalue().to_pybytes())


def _plot_name(out_md: Path, axis: str) -> str:
    return f"{out_md.stem}-{slug(axis)}.svg"


def _plot_rates(axis: AxisRates, path: Path, put: Put) -> None:
    from glocal_verify.reporting.figures.sweep import rates_figure

    series = {c: [(x.rate, x.low, x.high) for x in cells] for c, cells in axis.rates.items()}
    fig = rates_figure(axis.axis, axis.values, series)
    buf = io.StringIO()
    fig.savefig(buf, format="svg")
    put(path, buf.getvalue().encode("utf-8"))


def summary_markdown(rates: SweepRates, plots: Mapping[str, str]) -> str:
    """The Markdown summary of a sweep: per grid parameter, the rate of ``holds`` of each
    condition with its Wilson 95% interval, the plot named in ``plots`` and the failed members.

    Parameters
    ----------
    rates : SweepRates
    plots : mapping of grid parameter to file name
        The plots to link (none when figures are off).
    """
    lines = ["# Sweep summary", "", f"- members: {rates.members}", f"- result rows: {rates.result_rows}", f"- failed members: {len(rates.errors)}", ""]
    for ax in rates.axes:
        axis, values = ax.axis, ax.values
        lines += [f"## Rate of `holds` against `{axis}`", "", "| condition | " + " | ".join(f"{axis} = {v}" for v in values) + " |", "|---|" + "---|" * len(values)]
        for c, cells in ax.rates.items():
            text = [f"{x.holds}/{x.members} ({x.low:.2f}-{x.high:.2f})" + (f", {x.undecided} undecided" if x.undecided else "") for x in cells]
            lines.append(f"| `{c}` | " + " | ".join(text) + " |")
        lines.append("")
        if axis in plots:
            lines += [f"![rates against {axis}]({plots[axis]})", ""]
    if rates.errors:
        lines += ["## Failed members", "", "| member | error |", "|---|---|"]
        for r in rates.errors[:50]:
            lines.append(f"| {r['member']} | {r['error_class']}: {str(r['error'])[:120]} |")
        lines.append("")
    return "\n".join(lines)


def _summarize(rates: SweepRates, out_md: Path, figures: bool, put: Put) -> Path:
    plots = {}
    for ax in rates.axes:
        if figures and ax.axis != "(all)" and rates.conditions:
            svg = out_md.with_name(_plot_name(out_md, ax.axis))
            _plot_rates(ax, svg, put)
            plots[ax.axis] = svg.name
    put(out_md, summary_markdown(rates, plots).encode("utf-8"))
    return out_md


def sweep_outputs(plan: SweepPlan, out: str | Path, *, summary: bool = True, figures: bool = True) -> tuple[Path, Path, list[str]]:
    """Check where a sweep writes, before it starts: (results file, parts folder, the names of
    the files written beside the results file).

    The output policy of :mod:`glocal_verify.runtime.files`: no output may be an input of the
    sweep (its file or a member's spec, by any path resolving to it), none may be a symbolic
    link or lie in a folder given through one, and the folder must be writable.

    Parameters
    ----------
    plan : SweepPlan
    out : str or Path
        The results file (``.parquet`` or ``.csv``).
    summary, figures : bool
        As for :func:`write_sweep`.

    Raises
    ------
    SpecError
        ``out`` does not end in ``.parquet`` or ``.csv``.
    OutputError
        An output location the policy refuses.
    """
    outp = Path(out)
    if outp.suffix.lower() not in (".parquet", ".csv"):
        raise SpecError("--out", "must end in .parquet or .csv", None)
    inputs = plan.inputs
    check_output_file(outp, inputs=inputs)
    names = [outp.name]
    if summary:
        md = outp.with_suffix(".md")
        names.append(md.name)
        if figures:
            names += [_plot_name(md, axis) for axis in plan.grid]
    for name in names[1:]:
        check_output_file(outp.with_name(name), inputs=inputs, what="--out (the summary beside it)")
    parts = outp.with_name(outp.name + ".parts")
    check_output_dir(parts, inputs=inputs, what="--out (its parts folder)")
    return outp, parts, names


def write_sweep(run: SweepRun, plan: SweepPlan, out: str | Path, *, rates: SweepRates | None = None, figures: bool = True) -> SweepResult:
    """Write the results file of ``run`` and, given its ``rates``, the Markdown summary and plots.

    The files are staged and moved into place together at the end
    (:class:`~glocal_verify.runtime.files.OutputFolder`), so a failure or a stop leaves none of
    them half written.

    Parameters
    ----------
    run : SweepRun
        What :func:`~glocal_verify.design.sweep.compute_sweep` returned.
    plan : SweepPlan
        The sweep (its grid and inputs).
    out : str or Path
        Results file: ``.parquet`` (pyarrow) or ``.csv``.
    rates : SweepRates, optional
        :func:`~glocal_verify.design.sweep.sweep_rates` of ``run.rows``: the Markdown summary
        (``<out stem>.md``) is written from them; None writes no summary.
    figures : bool
        Draw a plot per grid parameter in the summary.
    """
    outp, _, names = sweep_outputs(plan, out, summary=rates is not None, figures=figures)
    rows = list(run.rows)
    md: Path | None = None
    with OutputFolder(outp.parent if str(outp.parent) else Path("."), inputs=plan.inputs, names=names) as folder:

        def put(path: Path, data: bytes) -> None:
            folder.write_bytes(path.name, data)

        _write_table(rows, outp, put)
        if rates is not None:
            md = _summarize(rates, outp.with_suffix(".md"), figures, put)
    return SweepResult(run.rows, outp, md, run.computed, run.resumed)
