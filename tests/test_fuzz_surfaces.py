"""The derandomized subset of the campaign over every surface (``tests/fuzz_campaign.py --inputs all``).

Fixed draws of each input kind of ``tests/fuzz_support.py`` (graph files, sweep files, options,
output paths) and three stopped runs (SIGTERM during a forked exact re-decision, Ctrl-C to the
process group of a sweep on Dask, SIGHUP during ``simulate --cases``) end ok or with one clean
line, and hold the output policy: no input overwritten, nothing written through a link, no
``.glocal-partial-*`` and no empty folder left, no process of a stopped run alive after it. The
mutated specs have their own property test (``tests/test_spec_fuzzer.py``). The full campaign
and its counts: docs/reliability.md.
"""

from __future__ import annotations

import os
import signal
import sys
from concurrent.futures import ThreadPoolExecutor

import pytest

import fuzz_support as fs

#: draws per input kind in CI (the campaign runs thousands)
DRAWS = int(os.environ.get("GLOCAL_FUZZ_DRAWS", "30"))


def _cases(kind: str) -> list[fs.Case]:
    return [fs.random_case(fs.RandomChooser(7919 * k + 17), kind) for k in range(DRAWS)]


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["graph", "sweep", "options", "output"])
def test_fixed_draws_of_every_input_kind_end_cleanly_and_keep_the_output_policy(kind: str) -> None:
    bad = []
    for case in _cases(kind):
        res = fs.run_case(case, 60.0)
        if not res.good:
            bad.append(f"{case.description}: {res.summary()}")
    assert not bad, "\n".join(bad)


def _stopped(label: str, sig: int, at: float) -> fs.Case:
    _, argv, make, _ = next(s for s in fs.SIGNALLED if s[0] == label)
    files = make()
    return fs.Case("signal", label, list(argv), files, protected=list(files), signal=(int(sig), at), description=f"{label}: {signal.Signals(sig).name} after {at} s")


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc for surviving processes")
def test_runs_stopped_at_work_print_one_line_and_leave_no_process_behind() -> None:
    cases = [
        _stopped("verify escalating", signal.SIGTERM, 7.0),  # inside the forked exact re-decision
        _stopped("sweep on Dask", signal.SIGINT, 6.0),  # a terminal's Ctrl-C: the whole process group
        _stopped("simulate --cases", signal.SIGHUP, 4.0),  # between the staging of the case files
    ]
    with ThreadPoolExecutor(max_workers=len(cases)) as ex:
        results = list(ex.map(lambda c: fs.run_case(c, 60.0), cases))
    bad = [f"{c.description}: {r.summary()}" for c, r in zip(cases, results) if not r.good]
    assert not bad, "\n".join(bad)


_SINGLE_FILE_WRITERS = [w[0] for w in fs.WRITERS if not w[3]]


@pytest.mark.slow
@pytest.mark.parametrize("target", ["null-device", "fifo"])
@pytest.mark.parametrize("label", _SINGLE_FILE_WRITERS)
def test_every_single_file_output_into_a_device_or_a_fifo_leaves_it_what_it_was(label: str, target: str) -> None:
    if os.geteuid() != 0 and target == "null-device":
        pytest.skip("making a device node needs root")
    res = fs.run_case(fs.target_case(label, target, fs.RandomChooser(1)), 60.0)
    assert res.outcome == "ok", res.summary()


@pytest.mark.parametrize("target", ["socket", "block-device", "long-name", "long-path", "empty", "deep-new"])
def test_an_output_that_cannot_be_written_is_one_line_before_any_work(target: str) -> None:
    if os.geteuid() != 0 and target == "block-device":
        pytest.skip("making a device node needs root")
    res = fs.run_case(fs.target_case("verify", target, fs.RandomChooser(1)), 60.0)
    assert res.outcome == "clean-error", res.summary()
