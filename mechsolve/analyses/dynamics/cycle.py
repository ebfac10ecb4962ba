"""The machine's cycle in turns of its crank.

A crank-driven linkage repeats after one turn of the crank, but a machine with gears
need not: a pinion of 20 teeth driving a wheel of 60 brings the wheel (and whatever it
drives) back to its start only after three turns of the pinion. The flywheel's energy
method, the stroke extremes that ``stroke(q)`` in a load condition means, and a
simulation's reference sweep all need the whole cycle, so it is found here, once, from
the mechanism itself: the driver is swept turn after turn (1 degree apart, on the
branches the sweep follows) and the cycle ends at the first whole turn after which every
body is back at its starting pose with the same rates per unit of the driver (as
:func:`_repeats` compares them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mechsolve.base.errors import InputError
from mechsolve.core import evaluate as core
from mechsolve.core.solution import Solution
from mechsolve.core.sweep import Analysis

__all__ = ["MAX_CYCLE_TURNS", "Cycle", "cycle_cause", "machine_cycle"]

# the most turns of the crank a cycle is looked for over (a gear pair of coprime tooth
# counts z1, z2 repeats after z2 turns of the pinion z1: a hunting-tooth pair of up to
# 100 teeth on the wheel)
MAX_CYCLE_TURNS = 100


@dataclass
class Cycle:
    """The driver's sweep over the machine's cycle.

    ``turns``: the crank's turns per cycle (1 for a plain linkage); 0 when the crank turns
    fully but the machine does not come back to its start within :data:`MAX_CYCLE_TURNS`
    turns; None when the crank does not turn fully. ``sweep``: the states (per unit of the
    driver, 1 degree apart) over the cycle; over one turn when ``turns`` is 0 or None
    (those of its positions that close)."""

    turns: int | None
    sweep: Solution

    @property
    def span(self) -> float:
        """The cycle's travel of the driver (rad)."""
        return 2 * math.pi * (self.turns or 1)

    def require(self, what: str, mech=None) -> int:
        """The turns per cycle, or an input error saying why ``what`` (e.g. 'a flywheel')
        has no cycle to work over (at the file's driver, when ``mech`` is given)."""
        if self.turns is None:
            text = f"the mechanism does not turn fully: {what} needs a full cycle of the crank"
        elif self.turns == 0:
            why = (
                cycle_cause(mech)
                if mech is not None
                else "its gear ratios, or a linkage that changes branch every turn"
            )
            text = (
                f"the machine does not come back to its starting position within "
                f"{MAX_CYCLE_TURNS} turns of the driver ({why}): {what} needs the "
                "machine's cycle"
            )
        else:
            return self.turns
        if mech is not None and getattr(mech, "source", None) is not None:
            raise mech.error(("driver",), text)
        raise InputError(text)


def cycle_cause(mech) -> str:
    """What makes the cycle of ``mech`` longer than a turn of its crank, in words: its
    gears (a gear pair or a rack), or else, in a linkage of pivots and sliders alone, a
    change of assembly branch (the positions of such a linkage are fixed by the crank's
    angle and the branch: back at the start angle but not at the start, it is on another
    branch, which it reaches through a change point, where its links line up)."""
    kinds = {getattr(j, "kind", None) for j in getattr(mech, "joints", ())}
    if kinds & {"gear_pair", "rack"}:
        return "its gear ratios"
    if kinds <= {"revolute", "slider"}:
        return (
            "no gears: its linkage changes assembly branch where its links line up, at a "
            "change point, and is back at its start only on the same branch"
        )
    return "its gears, cams or a change of branch of its linkage"


def machine_cycle(
    an: Analysis, *, velocity: bool = True, acceleration: bool = True, step: float = 1.0
) -> Cycle:
    """The machine's cycle: the fewest whole turns of the revolute driver after which
    every body is back where it started, with the same rates per unit of the driver.

    Parameters
    ----------
    an
        The analysis (a revolute driver; a linear driver has no turns: its sweep's range).
    velocity, acceleration
        Whether the returned sweep's states carry rates (per unit of the driver).
    step
        The sweep's step (degrees): the turn's positions are checked at the multiples of
        360 degrees, so 360 / step must be whole.
    """
    if an.linear:
        raise InputError("a slider driver has no turns: its cycle is the file's sweep")
    per = int(round(360.0 / step))
    u0 = an.start_value()
    d = an.mech.driver.direction
    one = core.states(
        an, u0 + d * np.radians(np.arange(per + 1) * step), 1.0, 0.0,
        velocity=velocity, acceleration=acceleration,
    )  # fmt: skip
    if not one.ok.all():
        return Cycle(None, one)
    if _repeats(one.state, an.scale):
        return Cycle(1, one)
    n = MAX_CYCLE_TURNS * per + 1
    many = core.states(
        an, u0 + d * np.radians(np.arange(n) * step), 1.0, 0.0,
        velocity=velocity, acceleration=acceleration,
    )  # fmt: skip
    for k in range(2, MAX_CYCLE_TURNS + 1):
        end = k * per
        if not many.ok[: end + 1].all():
            break
        if _repeats(many.state.take(np.array([0, end])), an.scale):
            return Cycle(k, core._take(many, np.arange(end + 1)))
    return Cycle(0, one)


def _repeats(st, scale: float) -> bool:
    """Whether the first and last positions of a state are the same configuration
    (poses and rates per unit of the driver)."""
    rows = [0, 1, 3, 4, 5, 6, 7]  # x, y, cos, sin, vx, vy, w
    blk = st.block
    return bool(np.allclose(blk[rows, :, 0], blk[rows, :, -1], rtol=0, atol=1e-8 * max(1, scale)))
