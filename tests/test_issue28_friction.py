"""Friction in the joints: the file's keys, the force analysis with Coulomb friction,
efficiency and self-locking.

References, independent of the solver: hand free-body solutions with friction written
out below (a block on an incline, a slider-crank at one position), the wedge's closed
form eta = tan(lambda) / tan(lambda + phi) and its self-locking condition
lambda + phi >= 90 deg, and the power balance (input = output + losses + dE/dt).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
SLIDER_CRANK = (ROOT / "mechanisms" / "slider-crank.yaml").read_text()
GEARS = (ROOT / "mechanisms" / "gear-train.yaml").read_text()
PIN_O = "  O: [ground, crank]\n"
CYLINDER = "line: {through: [0, 10], angle: 0}}"


def check(tmp_path, text):
    f = tmp_path / "m.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["check", str(f)])
    assert r.exception is None or isinstance(r.exception, SystemExit), r.exception
    assert "Traceback" not in r.output
    return r


def with_pin_friction(text: str) -> str:
    return SLIDER_CRANK.replace(PIN_O, f"  O: {{revolute: [ground, crank], friction: {text}}}\n")


def with_slider_friction(text: str) -> str:
    return SLIDER_CRANK.replace(
        CYLINDER, f"line: {{through: [0, 10], angle: 0}}, friction: {text}}}"
    )


# -- the file's keys ---------------------------------------------------------------------
def test_friction_keys_are_read(tmp_path):
    import mechsolve as ms

    text = with_pin_friction("{coefficient: 0.1, journal radius: 10 mm, viscous: 0.01 N m s/rad}")
    text = text.replace(
        CYLINDER,
        "line: {through: [0, 10], angle: 0}, friction: {coefficient: 0.15, viscous: 2 N s/m}}",
    )
    mech = ms.loads(text)
    pin, cyl = mech.joint("O"), mech.joint("cylinder")
    assert pin.friction.coefficient == 0.1 and pin.friction.radius == pytest.approx(0.01)
    assert pin.friction.viscous == pytest.approx(0.01)
    assert cyl.friction.coefficient == 0.15 and cyl.friction.viscous == pytest.approx(2.0)
    assert check(tmp_path, text).exit_code == 0


@pytest.mark.parametrize(
    "text, fragments",
    [
        (
            with_pin_friction("{coefficient: -0.1, journal radius: 10 mm}"),
            ["joints.O.friction.coefficient", "zero or positive", "-0.1"],
        ),
        (
            with_pin_friction("{coefficient: 0.1, journal radius: -2 mm}"),
            ["joints.O.friction.journal radius", "positive", "-2 mm"],
        ),
        (
            with_pin_friction("{coefficient: 0.1}"),
            ["joints.O.friction", "no 'journal radius'", "rho = f r"],
        ),
        (
            with_pin_friction("{coefficent: 0.1, journal radius: 1 mm}"),
            ["joints.O.friction.coefficent", "did you mean 'coefficient'"],
        ),
        (
            with_pin_friction("{coefficient: 0.1, journal radius: 1 mm, viscous: 3 N s/m}"),
            ["joints.O.friction.viscous"],
        ),
        (
            with_slider_friction("{coefficient: 0.15, journal radius: 3 mm}"),
            ["joints.cylinder.friction.journal radius", "a slider has no journal"],
        ),
        (
            with_slider_friction("{coefficient: 0.15, viscous: -1 N s/m}"),
            ["joints.cylinder.friction.viscous", "zero or positive"],
        ),
        (
            with_slider_friction("{}"),
            ["joints.cylinder.friction", "needs 'coefficient' or 'viscous'"],
        ),
        (
            GEARS.replace("centres: [O1, O2]}", "centres: [O1, O2], friction: {coefficient: 0.1}}"),
            ["joints.mesh.friction", "applies to a revolute or a slider joint, not a gear_pair"],
        ),
    ],
)
def test_bad_friction_is_refused_with_key_and_line(tmp_path, text, fragments):
    r = check(tmp_path, text)
    assert r.exit_code == 2, r.output
    assert "m.yaml:" in r.output  # the file and the line
    for frag in fragments:
        assert frag in r.output, r.output


def test_schema_knows_the_friction_keys():
    from mechsolve.analyses.schema import build as schema

    s = schema.text()
    for key in ("joint friction", "journal radius", "viscous"):
        assert key in s
