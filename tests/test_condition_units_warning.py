"""A plain number in a condition is SI; where it meets a length or an angle in a file
whose plain lengths or angles are not SI, the user is told (it was silently read as
metres or radians: a load that never acted, a stop condition that never fired)."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.base.errors import InputWarning
from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
SLIDER_CRANK = (ROOT / "mechanisms" / "slider-crank.yaml").read_text()
WHEN = "when: C.vx < 0 and stroke(C.x) > 0.3"


def test_plain_length_in_a_millimetre_file_is_warned_with_key_and_line(tmp_path):
    f = tmp_path / "sc.yaml"
    f.write_text(SLIDER_CRANK.replace(WHEN, "when: C.x > 200"))
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots", "-q"])
    assert r.exit_code == 0, r.output
    line = next(s for s in r.output.splitlines() if "plain number" in s)
    n = 1 + SLIDER_CRANK.replace(WHEN, "when: C.x > 200").splitlines().index("    when: C.x > 200")
    assert line.startswith(f"warning: {f}:{n}: loads.gas.when:")
    assert "200 m" in line and "'200 mm'" in line


@pytest.mark.parametrize(
    "condition, warned",
    [
        ("C.x > 200", True),
        ("C.x > 200 mm", False),
        ("C.x > 0.2 m", False),
        ("C.vx < 0", False),  # zero is zero in any unit
        ("stroke(C.x) > 0.3", False),  # a fraction
        ("C.vx < -1", False),  # a speed: plain speeds are SI in every file
        ("crank.angle > 30", True),  # plain angles are degrees in this file
    ],
)
def test_which_conditions_are_warned(condition, warned):
    text = SLIDER_CRANK.replace(WHEN, f"when: {condition}")
    with pytest.warns(InputWarning) if warned else _none():
        ms.loads(text)


def test_a_metre_radian_file_is_not_warned():
    text = SLIDER_CRANK.replace("units: {length: mm, angle: deg}", "units: {length: m, angle: rad}")
    with _none():
        ms.loads(text.replace(WHEN, "when: C.x > 0.2"))


class _none:
    """No InputWarning inside (others may come)."""

    def __enter__(self):
        import warnings

        self._cm = warnings.catch_warnings()
        self._cm.__enter__()
        warnings.simplefilter("error", InputWarning)

    def __exit__(self, *exc):
        return self._cm.__exit__(*exc)
