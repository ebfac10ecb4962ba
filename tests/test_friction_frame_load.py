"""The load on the frame does not depend on the friction inside the machine.

For the same motion, the frame carries the external loads less the links' inertia
forces: sum F_ext - sum m a_G, and for the moment the loads' moments less dH/dt. Joint
friction is internal (between the frame and the links, or between links), so the
shaking force and moment of a slider-crank with friction in every joint must equal
those without it; they differed by the guide's friction (up to 45 N) and the pins'
friction moments when the friction forces on the frame were left out.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mechsolve as ms
from mechsolve.analyses.shaking.frame import frame_load

ROOT = Path(__file__).resolve().parents[1]
TEXT = (ROOT / "mechanisms" / "slider-crank.yaml").read_text()


def with_friction(text: str) -> str:
    text = text.replace(
        "  O: [ground, crank]\n",
        "  O: {revolute: [ground, crank], friction: {coefficient: 0.1, journal radius: 10 mm}}\n",
    )
    text = text.replace(
        "  A: [crank, rod]\n",
        "  A: {revolute: [crank, rod], friction: {coefficient: 0.08, journal radius: 8 mm}}\n",
    )
    return text.replace(
        "line: {through: [0, 10], angle: 0}}",
        "line: {through: [0, 10], angle: 0}, friction: {coefficient: 0.15, viscous: 0.5 N s/m}}",
    )


def test_frame_load_is_independent_of_joint_friction():
    plain = ms.solve(ms.loads(TEXT))
    rough = ms.solve(ms.loads(with_friction(TEXT)))
    assert rough.forces.friction is not None
    assert np.nanmax(np.abs(rough.forces.friction.friction["cylinder"])) > 1.0  # it has some
    a, b = frame_load(plain), frame_load(rough)
    scale = np.nanmax(np.hypot(a[0], a[1]))
    for x, y in zip(a, b):
        assert np.allclose(x, y, rtol=0, atol=1e-9 * scale)
