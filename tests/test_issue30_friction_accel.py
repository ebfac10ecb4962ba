"""The equation of motion with joint friction, solved for the acceleration directly.

A crank alone on a pin with Coulomb friction (friction circle rho = f r), its centre of
mass a distance e from the pin, no gravity: the pin's reaction is m a_G, with a_G of
size e sqrt(omega^4 + eps^2), so the friction moment rho m e sqrt(omega^4 + eps^2)
follows the acceleration it opposes. The driver's equation of motion about the pin,

    J_O eps = M - sign(omega) rho m e sqrt(omega^4 + eps^2),   J_O = J_G + m e^2,

is solved here by hand (Newton's method on the scalar) and the reduced model must give
the same acceleration to rounding, also where the friction's feedback is strong (a low
speed with a large torque, so that eps dominates omega^2).
"""

from __future__ import annotations

import math

import pytest

from mechsolve import api
from mechsolve.analyses.dynamics.model import ReducedModel

CRANK = """\
name: crank
units: {length: mm, angle: deg}
ground:
  O: [0, 0]
links:
  crank:
    points: {O: [0, 0], G: [40, 0]}
    mass: 3 kg
    com: G
    inertia: 0.002 kg m^2
joints:
  O: {revolute: [ground, crank], friction: {coefficient: 0.2, journal radius: 15 mm}}
driver: {joint: O, speed: 600 rpm, start: 0 deg}
sweep: {range: 360 deg, step: 5 deg}
gravity: off
motor: {stall: 2 N m, slope: 0 N m s}
simulate: {duration: 0.1 s, step: 0.01 s, method: DOP853, rtol: 1e-9, atol: 1e-11}
"""

M_KG, E_M, JG = 3.0, 0.040, 0.002
RHO = 0.2 * 0.015  # the friction circle, m
JO = JG + M_KG * E_M**2


def _by_hand(w: float, torque: float) -> float:
    k = math.copysign(RHO * M_KG * E_M, w)  # tanh(|w| / w_s) = 1 at these speeds
    eps = torque / JO
    for _ in range(100):
        h = math.hypot(w * w, eps)
        eps -= (JO * eps - torque + k * h) / (JO + k * eps / h)
    return eps


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    f = tmp_path_factory.mktemp("crank") / "crank.yaml"
    f.write_text(CRANK)
    return ReducedModel(api.load(f))


@pytest.mark.parametrize("phi", [0.0, 0.7, 2.0, 4.4])
@pytest.mark.parametrize(("w", "torque"), [(50.0, 2.0), (5.0, 2.0), (-8.0, -1.5), (1.0, 0.3)])
def test_acceleration_with_pin_friction_by_hand(model, phi, w, torque):
    eps, J = model.accel(phi, w, 0.0, torque)
    assert J == pytest.approx(JO, rel=1e-12)
    assert eps == pytest.approx(_by_hand(w, torque), rel=2e-13)
