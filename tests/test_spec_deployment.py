"""The [uncertainty] and [implementation] tables: exact values, round trips, one-line errors."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest

from glocal_verify import SpecError, load_example, loads_spec
from glocal_verify.cli import main
from glocal_verify.spec.writer import dump_spec

BASE = dump_spec(load_example("paper19"))

GOOD = """
[uncertainty]
initial_state = "1/2"
noise = {"*" = 0.001, "v:7" = "1/300", "x:*" = 0.002}
noise_std = 0.0001
false_alarm = 1e-6
disturbance = "1/1000"

[implementation]
period = 0.01
controller = "continuous"
switch_delay = 2
"""

BAD = [
    ("negative-noise", "[uncertainty]\nnoise = -1", "uncertainty.noise", "must be at least 0"),
    ("unknown-channel-node", '[uncertainty]\nnoise = {"v:99" = 1}', 'uncertainty.noise."v:99"', "not in the graph"),
    ("bad-channel", '[uncertainty]\nnoise = {"y:1" = 1}', 'uncertainty.noise."y:1"', "a channel is"),
    ("both-initial", "[uncertainty]\ninitial_state = 1\ninitial_error = 2", "uncertainty.initial_error", "not both"),
    ("fa-without-gauss", "[uncertainty]\nfalse_alarm = 0.1", "uncertainty.false_alarm", "Gaussian part"),
    ("fa-one", "[uncertainty]\nnoise_std = 1\nfalse_alarm = 1", "uncertainty.false_alarm", "must be < 1"),
    ("unknown-key", "[uncertainty]\nbogus = 0.1", "uncertainty.bogus", "unknown key"),
    ("zero-period", "[implementation]\nperiod = 0", "implementation.period", "must be > 0"),
    ("tiny-period", "[implementation]\nperiod = 1e-9", "implementation.period", "at least 1e-06"),
    ("too-many-samples", "[implementation]\nperiod = 1e-6", "implementation.period", "samples"),  # with horizon = 1000
    ("bad-controller", '[implementation]\nperiod = 0.1\ncontroller = "x"', "implementation.controller", "unknown controller"),
    ("bad-hold", '[implementation]\nperiod = 0.1\nhold = "foh"', "implementation.hold", "unknown hold"),
    ("fractional-delay", "[implementation]\nperiod = 0.1\nswitch_delay = 1.5", "implementation.switch_delay", "integer"),
    ("missing-period", '[implementation]\ncontroller = "sampled"', "implementation", "missing required key 'period'"),
]


def test_the_deployment_tables_are_read_as_exact_rationals_and_round_trip() -> None:
    spec = loads_spec(BASE + GOOD)
    u, m = spec.uncertainty, spec.implementation
    assert u is not None and m is not None
    assert u.box == Fraction(1, 2) and u.disturbance == Fraction(1, 1000)
    assert u.noise_bound("v:7") == Fraction(1, 300) and u.noise_bound("x:3") == Fraction(1, 500) and u.noise_bound("v:3") == Fraction(1, 1000)
    assert u.gaussian and u.noise_sigma("v:1") == Fraction(1, 10000)
    assert m.period == Fraction(1, 100) and m.controller == "continuous" and m.switch_delay == 2 and m.hold == "zoh"
    assert loads_spec(dump_spec(spec)) == spec


def test_without_the_tables_nothing_changes() -> None:
    spec = load_example("paper19")
    assert spec.uncertainty is None and spec.implementation is None
    assert "[uncertainty]" not in dump_spec(spec)


@pytest.mark.parametrize("case,text,path,fragment", BAD, ids=[c[0] for c in BAD])
def test_bad_deployment_input_names_its_key_path(case: str, text: str, path: str, fragment: str) -> None:
    base = BASE.replace("horizon = 30.0", "horizon = 1000.0") if case == "too-many-samples" else BASE
    with pytest.raises(SpecError) as exc:
        loads_spec(base + "\n" + text)
    msg = str(exc.value)
    assert msg.startswith(path + ":"), msg
    assert fragment in msg and "\n" not in msg


def test_the_cli_prints_one_line_and_exits_2_on_a_bad_period(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = tmp_path / "bad.toml"
    p.write_text(BASE + "\n[implementation]\nperiod = -1\n")
    assert main(["verify", str(p)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "implementation.period" in err[0]
