"""Oscillating guide-bar (slotted lever) quick-return mechanisms.

The crank O2A (radius r) carries a block sliding in the bar pivoted at O4, |O2O4| = d > r.
At the bar's limit positions the crank is perpendicular to it, so the bar swings
psi = 2 asin(r / d) and the crank turns 180 deg +- psi between the limits: theta = psi and
K = (180 + theta) / (180 - theta). A bar of length L sweeps its end B over the chord
H = 2 L sin(psi / 2). The block's force on the bar is normal to the bar, as is the bar's
velocity there: the transmission angle is 90 deg throughout.
"""

from __future__ import annotations

import math

from mechsolve.analyses.synth.common import Design, time_ratio_angle, time_ratio_of
from mechsolve.base.errors import InputError

__all__ = ["guide_bar"]


def guide_bar(
    frame: float | None = None,
    crank: float | None = None,
    k: float | None = None,
    bar: float | None = None,
    stroke: float | None = None,
) -> list[Design]:
    """Two of frame d, crank r and time ratio K give the third; the bar length L, or the
    chord H of its end's stroke, gives the other (both optional)."""

    def err(key: str, message: str) -> InputError:
        exc = InputError(message)
        exc.problem_key = key  # type: ignore[attr-defined]  (the problem file's key)
        return exc

    given = [x is not None for x in (frame, crank, k)]
    if sum(given) != 2:
        raise InputError("give exactly two of frame, crank and time_ratio")
    for name, x in (("frame", frame), ("crank", crank), ("bar", bar), ("stroke", stroke)):
        if x is not None and not (math.isfinite(x) and x > 0):
            raise err(name, f"{name} {x!r}: it must be positive")
    if bar is not None and stroke is not None:
        raise err("stroke", "give the bar length or the stroke, not both")
    if k is not None:
        theta = time_ratio_angle(k)
        if theta < 1e-12:
            raise err("time_ratio", "K = 1 is not possible with a guide bar (the crank would be 0)")
        if frame is not None:
            crank = frame * math.sin(theta / 2)
        else:
            frame = crank / math.sin(theta / 2)
    if crank >= frame:
        raise err(
            "crank",
            f"crank {crank:g} m >= frame {frame:g} m: the bar would turn fully (a rotating "
            "guide bar), not oscillate",
        )
    theta = 2 * math.asin(crank / frame)
    if stroke is not None:
        bar = stroke / (2 * math.sin(theta / 2))
    if bar is not None and bar < frame + crank:
        if stroke is not None:
            raise err(
                "stroke",
                f"stroke {stroke:g} m needs a bar of H / (2 sin(theta/2)) = {bar:g} m, but "
                f"the slot must reach the block at its farthest, d + r = "
                f"{frame + crank:g} m: a stroke of at least "
                f"{2 * (frame + crank) * math.sin(theta / 2):g} m",
            )
        raise err(
            "bar",
            f"bar {bar:g} m: the slot must reach the block at its farthest, d + r = "
            f"{frame + crank:g} m",
        )
    lengths = {"crank": crank, "frame": frame}
    if bar is not None:
        lengths["bar"] = bar
    return [
        Design(
            method="guide bar: psi = theta = 2 asin(r / d)",
            family="oscillating guide bar (mirror: the same lengths)",
            lengths=lengths,
            ground={"O4": (0.0, 0.0), "O2": (0.0, frame)},
            grashof="crank r < frame d: the bar oscillates",
            min_transmission=math.pi / 2,
            time_ratio=time_ratio_of(theta),
            extra={
                "swing": theta,
                "theta": theta,
                "stroke": None if bar is None else 2 * bar * math.sin(theta / 2),
            },
        )
    ]
