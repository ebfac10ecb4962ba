"""Group solvers and the recognition of Assur groups in the structural decomposition."""

from __future__ import annotations

from mechsolve.groups.base import Drive, Group
from mechsolve.groups.closed import RPR, RRP, RRR, DrivenSlider, DriverLink
from mechsolve.groups.generic import NewtonGroup
from mechsolve.system.constraints import (
    AngleDriverConstraint,
    ConstraintSystem,
    SliderDriverConstraint,
)
from mechsolve.system.structure import GroupSpec, decompose

__all__ = ["Drive", "Group", "NewtonGroup", "build_plan", "recognise"]


def recognise(spec: GroupSpec, system: ConstraintSystem, atol: float, max_iterations: int) -> Group:
    """Return the closed-form solver for a group if its pattern is known, else Newton."""
    names = system.body_names
    bodies = spec.bodies
    cons = spec.constraints
    # the group's pattern in the Assur notation: the letters of its joints (R, P), and its
    # driver (D); each closed form below solves one pattern
    pattern = "".join(sorted(c.letter for c in cons))
    inside = set(bodies)

    def generic() -> Group:
        return NewtonGroup(bodies, cons, names, atol, max_iterations)

    if len(bodies) == 1:
        (b,) = bodies
        if pattern == "DR":
            pin = next(c for c in cons if c.letter == "R")
            drv = next((c for c in cons if isinstance(c, AngleDriverConstraint)), None)
            if drv is not None:
                return DriverLink(b, pin, drv, names)
        if pattern == "DP":
            sl = next(c for c in cons if c.letter == "P")
            drv = next((c for c in cons if isinstance(c, SliderDriverConstraint)), None)
            if drv is not None and drv.slider is sl and sl.b == b:
                return DrivenSlider(b, sl, drv, names)
        return generic()
    if len(bodies) != 2 or len(cons) != 3:
        return generic()
    b1, b2 = bodies
    inner = [c for c in cons if c.a in inside and c.b in inside]
    if len(inner) != 1:
        return generic()
    (jm,) = inner
    outer = [c for c in cons if c is not jm]

    def outer_of(body):
        found = [c for c in outer if body in (c.a, c.b)]
        return found[0] if len(found) == 1 else None

    o1, o2 = outer_of(b1), outer_of(b2)
    if o1 is None or o2 is None:
        return generic()
    if pattern == "RRR":
        return RRR(b1, b2, o1, jm, o2, names)
    if jm.letter == "R":
        # RRP: a rod pinned to a solved body, its block on a solved guide
        for rod, blk, jr, js in ((b1, b2, o1, o2), (b2, b1, o2, o1)):
            if jr.letter == "R" and js.letter == "P" and js.b == blk and js.a not in inside:
                return RRP(rod, blk, jr, jm, js, names)
        return generic()
    if jm.letter == "P" and all(c.letter == "R" for c in outer):
        bar, blk = jm.a, jm.b
        jq = o1 if bar == b1 else o2
        jp = o2 if bar == b1 else o1
        return RPR(blk, bar, jp, jq, jm, names)
    return generic()


def build_plan(
    system: ConstraintSystem, method: str, atol: float, max_iterations: int
) -> list[Group]:
    """The ordered list of group solvers for ``system``.

    ``method="auto"`` splits into groups and uses closed forms where recognised;
    ``method="newton"`` solves the whole system as one Newton group;
    ``method="split-newton"`` splits into groups but solves each by Newton.
    """
    if method == "newton":
        spec = GroupSpec(list(range(system.nb)), list(system.constraints))
        decompose(system)  # still diagnose structural problems with a clear message
        return [NewtonGroup(spec.bodies, spec.constraints, system.body_names, atol, max_iterations)]
    if method == "split-newton":  # the split into groups, every group by Newton (benchmarks)
        return [
            NewtonGroup(s.bodies, s.constraints, system.body_names, atol, max_iterations)
            for s in decompose(system)
        ]
    return [recognise(s, system, atol, max_iterations) for s in decompose(system)]
