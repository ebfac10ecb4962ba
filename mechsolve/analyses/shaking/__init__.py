"""Shaking force and moment on the frame, and balancing by counterweights.

:func:`shaking` gives the load the moving links transmit to the frame over a sweep
(:mod:`.frame`); :func:`balanced` finds the counterweights of a four-bar or a
slider-crank (:mod:`.balance`), writes them into a runnable file and gives the shaking
before and after.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mechsolve.analyses.shaking.balance import (
    Balance,
    Counterweight,
    balance,
    balanced_data,
    find_linkage,
    inline,
    least_squares,
)
from mechsolve.analyses.shaking.edit import with_counterweights
from mechsolve.analyses.shaking.frame import Shaking, frame_load, inertia_only, shaking
from mechsolve.base.errors import InputError
from mechsolve.base.units import SI_OUTPUT, OutputUnits
from mechsolve.model import Mechanism

__all__ = [
    "Balance",
    "Balanced",
    "Counterweight",
    "Shaking",
    "balance",
    "balanced",
    "find_linkage",
    "frame_load",
    "inertia_only",
    "least_squares",
    "shaking",
]


@dataclass
class Balanced:
    """A balancing: the counterweights, the balanced file's text, the shaking before and
    after (inertia forces only: the counterweights cancel those)."""

    balance: Balance
    before: Shaking
    after: Shaking
    text: str

    def lines(self, units: OutputUnits | None = None) -> list[str]:
        """The counterweights and the residual shaking, in ``units`` (default SI)."""
        u = units or SI_OUTPUT
        lines = self.balance.lines(u)
        drv = self.before.results.mechanism.driver
        lines += self.balance.textbook(drv.speed if drv.motion is None else None, u)
        lines.append(
            "residual shaking (inertia forces only: gravity and loads off), "
            f"moment about {self.before.about_name}:"
        )
        fb, fa = self.before.figures(), self.after.figures()
        r = self.before.results
        k_at, unit = u.convert("m" if r.linear else "deg")
        for key in fb:
            k, un = u.convert("N" if key.endswith("force") else "N*m")
            (vb, ab, how), (va, aa, _) = fb[key], fa.get(key, (float("nan"),) * 2 + ("",))
            vb, va, ab, aa = vb * k, va * k, ab * k_at, aa * k_at
            after = f"{va:.6g} {un}{_at(aa, unit)}"
            if va <= ROUNDING * vb:  # what is left is rounding: no figure to print
                after = f"0 {un} to rounding (below {ROUNDING:g} of before)"
            lines.append(f"  {key:<13} before {vb:.6g} {un}{_at(ab, unit)}, after {after} ({how})")
        if self.balance.fraction is None:
            lines.append(
                "  note: counterweights cancel the shaking force, not the moment (their "
                "inertia may increase it)"
            )
        return lines


ROUNDING = 1e-12  # a residual below this fraction of the unbalanced one is rounding


def _at(value: float, unit: str) -> str:
    return f" at {value:.6g} {unit}" if math.isfinite(value) else ""


def balanced(
    mech: Mechanism,
    *,
    fraction: float | None = None,
    radius: dict[str, float] | None = None,
    about: tuple[float, float] = (0.0, 0.0),
    about_name: str = "the frame's origin",
    step: float | None = None,
    variant: str | None = None,
    rms: bool = False,
) -> Balanced:
    """Balance ``mech`` (see :func:`~mechsolve.analyses.shaking.balance.balance`), write
    the counterweights into the file's text and solve the balanced file again: the
    shaking before and after are of the two runnable files. ``variant``: the name of the
    file's variant ``mech`` was loaded with (its data has it applied), for the header.
    ``rms``: the counterweights that minimise the RMS shaking force over the turn
    (:func:`~mechsolve.analyses.shaking.balance.least_squares`) instead."""
    import yaml

    from mechsolve.model.parse import loads

    if rms and fraction is not None:
        raise InputError("--rms chooses the counterweight itself: give it or --fraction")
    bal = balance(mech, fraction=fraction, radius=radius)
    kw = dict(about=about, about_name=about_name, step=step, inertia=True)
    before = shaking(mech, **kw)
    if rms:
        bal = least_squares(mech, bal, before, radius)
    if bal.fraction is not None:
        bal.inline = bal.inline and inline(before.results, bal.linkage)
    data = balanced_data(mech, bal)
    names = ", ".join(f"{cw.point} on {cw.link}" for cw in bal.counterweights)
    head = (
        f"# {mech.name}, balanced by 'mechsolve shaking --balance': counterweights {names}\n"
        "# (point masses, see links.*.point_masses)\n"
        + (f"# from the variant {variant!r} of the file, applied\n" if variant else "")
    )
    body = None
    if mech.source.text is not None and not variant:  # the file's text, comments kept
        body = with_counterweights(mech.source.text, _entries(mech, bal), data)
    if body is None:  # a variant applied, or a layout the edit does not handle
        body = yaml.safe_dump(data, sort_keys=False, allow_unicode=True, default_flow_style=None)
    text = head + body
    after = shaking(loads(text, file=mech.source.file), **kw)  # the variant is in the data
    return Balanced(bal, before, after, text)


def _entries(mech: Mechanism, bal: Balance) -> list[tuple[str, str, str, str]]:
    """Each counterweight as the balanced file writes it: its link, its point's name,
    its position ``[x, y]`` in the file's length unit and its mass (kg)."""
    from mechsolve.base.units import parse_quantity

    scale = parse_quantity(f"1 {mech.length_unit}", "length")
    return [
        (
            cw.link,
            cw.point,
            f"[{float(cw.local[0] / scale)!r}, {float(cw.local[1] / scale)!r}]",
            f"{float(cw.mass)!r} kg",
        )
        for cw in bal.counterweights
    ]
