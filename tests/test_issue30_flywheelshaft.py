"""Issue 30 (flywheel shaft, simulate's driver work with friction).

* ``mechsolve flywheel`` sizes the inertia for the driver's shaft (the energy method's
  omega_m is the driver's speed): the summary names the driver joint, its link and its
  speed, not "the crank" (the gear train's driver is the pinion, which turns three times
  as fast as the wheel that is its crank), and gives the same flywheel on every other
  shaft geared to it at a constant ratio: J_F (omega_driver / omega_shaft)^2.
* ``simulate`` with joint friction: the driver's work is the motor's, integrated along
  the motion (a constant torque: M times the travel, exactly), and the friction losses
  follow from the energy balance W_motor + W_loads - dT, not from a trapezoid on the
  output rows.
"""

from __future__ import annotations

import copy
import math
import re
from pathlib import Path

import pytest

from mechsolve import api
from mechsolve.analyses.flywheel import size_flywheel
from mechsolve.model.machine import Flywheel, Motor, Simulation

MECH = Path(__file__).resolve().parents[1] / "mechanisms"
RPM = math.pi / 30


@pytest.fixture(scope="module")
def gear_train():
    mech = api.load(MECH / "gear-train.yaml")
    return mech, size_flywheel(mech, 0.05, check=False)


def test_gear_train_flywheel_is_named_for_the_pinions_shaft(gear_train):
    """The file's driver O1 turns the pinion at 300 rpm; the wheel (teeth 60 against the
    pinion's 20) at 100 rpm. J_F = dE / (omega^2 delta) - J_mean with omega the pinion's
    speed, and on the wheel the same flywheel is (300 / 100)^2 = 9 times J_F."""
    mech, out = gear_train
    w = 300 * RPM
    assert out.omega_mean == pytest.approx(w, rel=1e-12)
    assert out.J_flywheel == pytest.approx(out.energy_max / (w * w * 0.05) - out.J_mean, rel=1e-12)
    text = out.text()
    assert "crank" not in text
    line = next(ln for ln in text.splitlines() if ln.startswith("  flywheel J_F ="))
    assert "driver's shaft, O1, link 'pinion', at 300 rpm" in line
    wheel = next(ln for ln in text.splitlines() if "'wheel'" in ln)
    assert "O2" in wheel and "100 rpm" in wheel
    nums = [float(v) for v in re.findall(r"= ([0-9.e+-]+) kg\*m\^2", wheel)]
    assert nums and nums[-1] == pytest.approx(9 * out.J_flywheel, rel=1e-5)
    assert "J_F x 9 " in wheel


def test_the_wheels_equivalent_adds_J_F_at_the_pinion(gear_train):
    """The flywheel put where the summary says, 9 J_F on the wheel (or J_F on the pinion),
    raises the mean reduced inertia at the driver by J_F: the wheel turns at a third of
    the pinion's speed (kinetic energy 1/2 (9 J_F) (omega / 3)^2)."""
    mech, out = gear_train
    for link, inertia in (("wheel", 9 * out.J_flywheel), ("pinion", out.J_flywheel)):
        m = copy.copy(mech)
        m.flywheel = Flywheel(link, inertia)
        again = size_flywheel(m, 0.05, check=False)
        assert again.J_mean - out.J_mean == pytest.approx(out.J_flywheel, rel=1e-9)


def test_driver_that_is_the_crank_keeps_its_numbers():
    """The shaper's driver is its crank (joint O2): the sizing names it, and J_F is still
    dE / (omega^2 delta) - J_mean at its 60 rpm (the file's --speed here)."""
    mech = api.load(MECH / "shaper.yaml")
    out = size_flywheel(mech, 1 / 40, omega_mean=60 * RPM, check=False)
    w = 60 * RPM
    assert out.J_flywheel == pytest.approx(out.energy_max / (w * w / 40) - out.J_mean, rel=1e-12)
    line = next(ln for ln in out.text().splitlines() if ln.startswith("  flywheel J_F ="))
    joint = mech.driver.joint
    assert f"driver's shaft, {joint}, link 'crank', at 60 rpm" in line


def test_the_check_puts_J_F_on_the_drivers_link(gear_train, monkeypatch):
    """The check by simulation adds J_F on the driver's link even where the file's own
    flywheel is on another shaft (there J_F would act at the wrong speed)."""
    import mechsolve.analyses.flywheel as fw

    mech, out = gear_train
    m = copy.copy(mech)
    m.motor = Motor("linear", stall=30.0, slope=0.5)
    m.flywheel = Flywheel("wheel", 0.5)
    m.simulation = Simulation(duration=1.0, step=0.01)
    seen = {}

    class Stop(Exception):
        pass

    def fake(machine):
        seen["machine"] = machine
        raise Stop

    monkeypatch.setattr(fw, "simulate", fake)
    with pytest.raises(Stop):
        fw._check_by_simulation(out, m, fw.Analysis(m))
    machine = seen["machine"]
    wheel0 = mech.link("wheel").inertia or 0.0
    pinion0 = mech.link("pinion").inertia or 0.0
    # the file's flywheel stays on the wheel, J_F goes on the pinion
    wheel = machine.link("wheel").inertia + (
        machine.flywheel.inertia if machine.flywheel.link == "wheel" else 0.0
    )
    pinion = machine.link("pinion").inertia + (
        machine.flywheel.inertia if machine.flywheel.link == "pinion" else 0.0
    )
    assert wheel == pytest.approx(wheel0 + 0.5, rel=1e-12)
    assert pinion == pytest.approx(pinion0 + out.J_flywheel, rel=1e-12)
