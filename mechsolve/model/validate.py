"""Consistency checks of a :class:`~mechsolve.model.Mechanism`.

These checks need the whole model (names across sections), so they run after the file's
sections were read one by one. Each failure names the key where the user must look.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from mechsolve.base.errors import suggest  # noqa: F401 (re-exported for the readers)
from mechsolve.base.units import UnitError, check_range
from mechsolve.model import (
    GROUND,
    MAX_POSITIONS,
    NAME_RE,
    Damper,
    Limit,
    PointForce,
    Spring,
    Torque,
)
from mechsolve.model.expr import DimensionError, Ref, Side

if TYPE_CHECKING:
    from mechsolve.model import Link, Mechanism


def _check_name(mech: Mechanism, name: str, where, what: str) -> None:
    if not isinstance(name, str) or not NAME_RE.match(name):
        raise mech.error(
            where,
            f"{what} name {name!r} must start with a letter or '_' and contain only "
            "letters, digits and '_'",
        )


def _in_range(mech: Mechanism, where, kind: str, *values: float) -> None:
    """Each value finite and within the sane range of its kind (see units.LIMITS), so that
    no formula downstream overflows; a model built in code is held to what a file is."""
    for v in values:
        try:
            check_range(float(v), kind)
        except (UnitError, TypeError, ValueError, OverflowError) as exc:
            msg = str(exc) if isinstance(exc, UnitError) else f"{v!r} is not a number"
            raise mech.error(where, msg) from None


def _find(parent: dict[str, str], x: str) -> str:
    while parent[x] != x:
        x = parent[x]
    return x


def validate(mech: Mechanism) -> None:
    """Check a mechanism built from a file or in code; raise an :class:`InputError` that
    names the key path (and so the file's line) of the first mistake found."""
    links = _check_links(mech)
    names = _check_joints(mech, links)
    owners = _check_point_names(mech, links)
    _check_connected(mech)
    _check_joint_points_distinct(mech)
    _check_driver(mech, names)
    _check_sweep(mech)
    _check_solver(mech)
    _check_loads(mech, links)
    _check_requirements(mech)
    _check_references(mech, links, owners)


def _check_links(mech: Mechanism) -> dict[str, Link]:
    """The links and the ground: unique names, finite points of sensible size, masses."""
    links = {lk.name: lk for lk in mech.links}
    if len(links) != len(mech.links):
        seen: set[str] = set()
        for lk in mech.links:
            if lk.name in seen:
                raise mech.error(lk.where, f"two links are named {lk.name!r}")
            seen.add(lk.name)
    if not mech.links:
        raise mech.error(("links",), "the mechanism has no moving links")
    for p, xy in mech.ground.items():
        _check_name(mech, p, ("ground", p), "point")
        if not all(math.isfinite(v) for v in xy):
            raise mech.error(("ground", p), "coordinates must be finite numbers")
        _in_range(mech, ("ground", p), "length", *xy)
    for lk in mech.links:
        _check_name(mech, lk.name, lk.where, "link")
        if lk.name == GROUND:
            raise mech.error(
                lk.where, "'ground' is reserved for the frame; name the link otherwise"
            )
        if not lk.points:
            raise mech.error(lk.where + ("points",), f"link {lk.name!r} has no points")
        for p, xy in lk.points.items():
            _check_name(mech, p, lk.where + ("points", p), "point")
            if not all(math.isfinite(v) for v in xy):
                raise mech.error(lk.where + ("points", p), "coordinates must be finite numbers")
            _in_range(mech, lk.where + ("points", p), "length", *xy)
        if lk.mass is not None and not (lk.mass >= 0 and math.isfinite(lk.mass)):
            raise mech.error(lk.where + ("mass",), f"mass must be zero or positive, got {lk.mass}")
        if lk.inertia is not None and not (lk.inertia >= 0 and math.isfinite(lk.inertia)):
            raise mech.error(
                lk.where + ("inertia",),
                f"moment of inertia must be zero or positive, got {lk.inertia}",
            )
        if lk.mass is not None:
            _in_range(mech, lk.where + ("mass",), "mass", lk.mass)
        if lk.inertia is not None:
            _in_range(mech, lk.where + ("inertia",), "moment of inertia", lk.inertia)
        if lk.com is not None:
            _in_range(mech, lk.where + ("com",), "length", *lk.com)
    return links


def _check_joints(mech: Mechanism, links: dict[str, Link]) -> set[str]:
    """The joints: unique names, existing links, and each kind's own checks."""
    link_names = [GROUND] + list(links)
    names: set[str] = set()
    for j in mech.joints:
        _check_name(mech, j.name, j.where, "joint")
        if j.name in names:
            raise mech.error(j.where, f"two joints are named {j.name!r}")
        names.add(j.name)
        for ln in j.links:
            if ln not in link_names:
                raise mech.error(
                    j.where,
                    f"joint {j.name!r} names the link {ln!r}, which does not exist"
                    + suggest(ln, link_names),
                )
        a, b = j.links
        if a == b:
            raise mech.error(j.where, f"joint {j.name!r} joins the link {a!r} to itself")
        j.check(mech, _in_range)
    return names


def _check_point_names(mech: Mechanism, links: dict[str, Link]) -> dict[str, list[str]]:
    """Points, links and sliders share one namespace; a point on two links is a joint."""
    # the same point name on two links must be a joint between them (directly or in a chain)
    owners = mech.point_owners()
    # points, links and sliders share one namespace in conditions and CSV headers
    # ("crank.vx"): one name may not stand for two of them
    sliders = {j.name: j for j in mech.sliders}
    for p, ls in owners.items():
        clash = "link" if p in links else "slider" if p in sliders else None
        if clash:
            where = ("ground", p) if ls[0] == GROUND else links[ls[0]].where + ("points", p)
            raise mech.error(
                where,
                f"point {p!r} has the name of a {clash}; names of points, links and sliders "
                "must differ (conditions and CSV columns such as 'crank.vx' use them)",
            )
    for name, j in sliders.items():
        if name in links:
            raise mech.error(j.where, f"slider {name!r} has the name of a link; rename one")
    for p, ls in owners.items():
        if len(ls) < 2:
            continue
        parent = {ln: ln for ln in ls}
        for j in mech.joints:
            if j.joins(p) and j.a in parent and j.b in parent:
                parent[_find(parent, j.a)] = _find(parent, j.b)
        roots = {_find(parent, ln) for ln in ls}
        if len(roots) > 1:
            ln = [x for x in ls if x != GROUND][0]
            where = ("ground", p) if ls[0] == GROUND else links[ln].where + ("points", p)
            raise mech.error(
                where,
                f"point {p!r} is on " + ", ".join(repr(x) for x in ls) + " but no joint pins "
                "them together there; add a revolute joint or rename one of the points",
            )
    return owners


def _check_connected(mech: Mechanism) -> None:
    """Every link is connected to the ground by a chain of joints."""
    # every link must be connected to the ground
    adj: dict[str, set[str]] = {ln: set() for ln in [GROUND] + [lk.name for lk in mech.links]}
    for j in mech.joints:
        adj[j.links[0]].add(j.links[1])
        adj[j.links[1]].add(j.links[0])
    seen_links = {GROUND}
    stack = [GROUND]
    while stack:
        for nb in adj[stack.pop()]:
            if nb not in seen_links:
                seen_links.add(nb)
                stack.append(nb)
    for lk in mech.links:
        if lk.name not in seen_links:
            raise mech.error(
                lk.where, f"link {lk.name!r} is not connected to the ground by any chain of joints"
            )


def _check_joint_points_distinct(mech: Mechanism) -> None:
    """The joint points of a link are distinct places (no zero-length links)."""
    # joint points of a link must be distinct places (no zero-length links)
    for lk in mech.links:
        used = sorted({j.point for j in mech.joints if lk.name in j.links and j.point in lk.points})
        scale = max(1e-9, max(math.hypot(*lk.points[p]) for p in lk.points))
        for i, p in enumerate(used):
            for q in used[i + 1 :]:
                d = math.dist(lk.points[p], lk.points[q])
                if d <= 1e-9 * scale:
                    raise mech.error(
                        lk.where + ("points", q),
                        f"points {p!r} and {q!r} of link {lk.name!r} coincide: the link between "
                        "them has zero length",
                    )


def _check_driver(mech: Mechanism, names: set[str]) -> None:
    """The driver: an existing joint with a coordinate to drive, its line, speed and start."""
    # driver
    d = mech.driver
    if d is not None:
        if d.joint not in names:
            raise mech.error(
                d.where + ("joint",),
                f"the driver names the joint {d.joint!r}, which does not exist"
                + suggest(d.joint, sorted(names)),
            )
        j = mech.joint(d.joint)
        if d.line is not None:
            if j.coordinate != "angle":
                raise mech.error(d.where + ("line",), "'line' applies to a revolute driver only")
            for p in d.line:
                if not mech.has_point(j.b, p):
                    raise mech.error(
                        d.where + ("line",),
                        f"the driver's line uses point {p!r}, which is not on the driven link "
                        f"{j.b!r}",
                    )
            p0 = mech.local_point(j.b, d.line[0])
            p1 = mech.local_point(j.b, d.line[1])
            if math.dist(p0, p1) == 0:
                raise mech.error(d.where + ("line",), "the driver's line needs two distinct points")
        if d.motion is not None:  # its speed is derived from the law: the law is named
            _check_motion(mech, d)
        if not math.isfinite(d.speed):
            raise mech.error(d.where + ("speed",), "the driver speed must be a finite number")
        if j.coordinate is None:
            raise mech.error(
                d.where + ("joint",),
                f"the driver names the joint {d.joint!r}, a {j.kind}, which has no coordinate "
                "a driver could drive",
            )
        linear = j.coordinate == "length"
        _in_range(mech, d.where + ("speed",), "speed" if linear else "angular speed", d.speed)
        if not isinstance(d.start, Limit):
            _in_range(mech, d.where + ("start",), "length" if linear else "angle", d.start)
        if isinstance(d.start, Limit):
            check_refs(mech, d.start.quantity, d.where + ("start",))


def _check_motion(mech: Mechanism, d) -> None:
    """A motion law finite, with its rates, at the times read from it: those its nominal
    speed and direction are read at (its natural duration, or 1 s, in 256 steps) and the
    samples of a sweep in time. A failure names the law's key and the first such time."""
    import numpy as np

    from mechsolve.model.motion import ExpressionMotion

    law = d.motion
    t = np.linspace(0.0, law.duration or 1.0, 257)
    sw = mech.sweep
    if sw is not None and sw.duration is not None and sw.time_step:
        n = max(0, math.ceil(sw.duration / sw.time_step - 1e-9))
        if n < MAX_POSITIONS:
            t = np.union1d(t, np.minimum(np.arange(n + 1) * sw.time_step, sw.duration))
    with np.errstate(all="ignore"):
        vals = [np.isfinite(v) for v in law.at(t)]
    bad = ~(vals[0] & vals[1] & vals[2])
    if not bad.any():
        return
    k = int(np.argmax(bad))
    names = [w for w, v in zip(("position", "speed", "acceleration"), vals) if not v[k]]
    which = "" if "position" in names else f" (its {' and '.join(names)})"
    key = ("motion", "law") if isinstance(law, ExpressionMotion) else ("motion",)
    raise mech.error(d.where + key, f"the law is not finite at t = {t[k]:.6g} s{which}")


def _check_sweep(mech: Mechanism) -> None:
    """The sweep: a positive step and range, not more positions than one run solves."""
    sw = mech.sweep
    if sw.step is not None and not (sw.step > 0 and math.isfinite(sw.step)):
        raise mech.error(sw.where + ("step",), "the step must be positive")
    if sw.travel is not None and not (sw.travel >= 0 and math.isfinite(sw.travel)):
        raise mech.error(sw.where, "the sweep range must be zero or positive")
    travel = sw.travel if sw.travel is not None else 2 * math.pi
    if sw.step is not None and not travel / sw.step < MAX_POSITIONS:
        raise mech.error(
            sw.where or ("sweep",),
            f"the sweep has {travel / sw.step:.3g} positions, more than the "
            f"{MAX_POSITIONS:,} mechsolve solves in one run: use a larger step or a smaller "
            "range",
        )


def _check_solver(mech: Mechanism) -> None:
    """The solver options as the file reader takes them (a model built in code too)."""
    from mechsolve.model.keys import METHODS

    opts, where = mech.solver, mech.solver.where or ("solver",)
    if not isinstance(opts.method, str) or opts.method not in METHODS:
        raise mech.error(
            where + ("method",),
            f"method is {', '.join(repr(x) for x in METHODS)}, got {opts.method!r}",
        )
    t = opts.tolerance
    if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0 < t < 1e-2:
        raise mech.error(where + ("tolerance",), "the tolerance must be between 0 and 0.01")
    n = opts.max_iterations
    if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= 1000:
        raise mech.error(where + ("max_iterations",), "max_iterations is a whole number 1..1000")


def _check_loads(mech: Mechanism, links: dict[str, Link]) -> None:
    """Gravity, the sketch's coordinates and the loads with their conditions."""
    if mech.gravity is not None:
        _in_range(mech, ("gravity",), "acceleration", *mech.gravity)
    for p, xy in mech.assembly.sketch.items():
        _in_range(mech, mech.assembly.where + ("sketch", p), "length", *xy)
    for load in mech.loads:
        _check_load(mech, load, links)
        if load.when is not None:
            check_refs(mech, load.when, load.where + ("when",))
    sim = mech.simulation
    if sim is not None and sim.stop is not None:
        check_refs(mech, sim.stop, sim.where + ("stop when",))


def _check_references(
    mech: Mechanism, links: dict[str, Link], owners: dict[str, list[str]]
) -> None:
    """The assembly's conditions and sketch, and the outputs, name existing things."""
    # assembly and outputs refer to existing things
    for k, cond in enumerate(mech.assembly.conditions):
        check_refs(mech, cond, mech.assembly.where_of(k))
    for p in mech.assembly.sketch:
        if p not in owners:
            raise mech.error(
                mech.assembly.where + ("sketch", p),
                f"the sketch places point {p!r}, which no link has" + suggest(p, list(owners)),
            )
    out = mech.outputs
    for key, pool in (
        ("points", [p for p in owners if owners[p] != [GROUND]]),
        ("links", list(links)),
        ("sliders", [j.name for j in mech.sliders]),
    ):
        wanted = getattr(out, key)
        for i, n in enumerate(wanted or []):
            if n not in pool:
                raise mech.error(
                    out.where + (key, i),
                    f"no {key[:-1]} named {n!r} to report" + suggest(n, pool),
                )


POINT_ATTRS = ("x", "y", "vx", "vy", "ax", "ay", "v", "a")
LINK_ATTRS = ("angle", "omega", "alpha")
SLIDER_ATTRS = ("s", "v", "a")


def check_refs(mech: Mechanism, expr, where) -> None:
    """Check that every name an expression reads exists, with a did-you-mean hint."""
    owners = mech.point_owners()
    links = mech.link_names
    sliders = [j.name for j in mech.sliders]
    for r in expr.refs():
        if isinstance(r, Side):
            for p in (r.point, r.start, r.end):
                if p not in owners:
                    raise mech.error(
                        where, f"{expr.text!r}: no point named {p!r}" + suggest(p, list(owners))
                    )
            continue
        assert isinstance(r, Ref)
        if r.name in owners:
            attrs = POINT_ATTRS
        elif r.name in links:
            attrs = LINK_ATTRS
        elif r.name in sliders:
            attrs = SLIDER_ATTRS
        else:
            pool = list(owners) + links + sliders
            raise mech.error(
                where, f"{expr.text!r}: nothing is named {r.name!r}" + suggest(r.name, pool)
            )
        if r.attr not in attrs:
            raise mech.error(
                where,
                f"{expr.text!r}: {r.name!r} has no quantity {r.attr!r} (it has "
                + ", ".join(attrs)
                + ")",
            )
    try:  # what is compared or added is of one kind (a speed with a speed)
        expr.dimension()
    except DimensionError as exc:
        raise mech.error(where, str(exc)) from None
    warn_bare_numbers(mech, expr, where)


def warn_bare_numbers(mech: Mechanism, expr, where, ref_dim=None, driver=None) -> None:
    """Warn (:class:`InputWarning`) where a plain number meets a length or an angle in a
    condition: it is read in SI (metres, radians), but the file's other plain lengths are
    in ``units.length`` and its plain angles in ``units.angle`` (degrees by default)."""
    import warnings

    from mechsolve.base.errors import InputWarning
    from mechsolve.model.expr.dims import bare_lengths_and_angles, condition_dim

    file_unit = {"length": mech.length_unit or "m", "angle": mech.angle_unit or "deg"}
    si = {"length": "m", "angle": "rad"}
    for value, kind in bare_lengths_and_angles(expr.tree, ref_dim or condition_dim, driver):
        unit = file_unit[kind]
        if unit == si[kind]:
            continue
        message = str(
            mech.error(
                where,
                f"{expr.text!r}: the plain number {value:g} meets {kind_word(kind)} and is "
                f"read in SI, {value:g} {si[kind]}, though the file's plain {kind}s are in "
                f"{unit}: write '{value:g} {unit}' if that is what is meant (or "
                f"'{value:g} {si[kind]}' to keep it and silence this warning)",
            )
        )
        warnings.warn(message, InputWarning, stacklevel=2)


def kind_word(kind: str) -> str:
    return "a length" if kind == "length" else "an angle"


def _check_requirements(mech: Mechanism) -> None:
    """Each requirement names the kind of thing its figures belong to (``time_ratio`` of
    a rocker or a ram, not of the link a slider carries) and compares quantities of one
    kind (a model built in code is checked here; a file's also as it is read)."""
    from mechsolve.model.expr import ExprError
    from mechsolve.model.requirement import _ANGLE, _LENGTH, check_names, figure_dim

    linear = mech.driver is not None and any(
        j.coordinate == "length" and j.name == mech.driver.joint for j in mech.joints
    )
    for req in getattr(mech, "requirements", None) or []:
        if req.expr is None:
            continue
        try:
            check_names(mech, req)
            req.expr.dimension(lambda ref: figure_dim(ref, linear), _LENGTH if linear else _ANGLE)
        except ExprError as exc:
            raise mech.error(("requirements", req.name), str(exc)) from None
        warn_bare_numbers(
            mech,
            req.expr,
            ("requirements", req.name),
            lambda ref: figure_dim(ref, linear),
            _LENGTH if linear else _ANGLE,
        )


def _check_load(mech: Mechanism, load, links: dict) -> None:
    """A load acts on links and points that exist, with sensible coefficients (the file
    reader checks these as it reads; a model built in code is checked here)."""

    def on(link: str | None, point: str | None, key: str) -> None:
        if link not in links and link != GROUND:
            raise mech.error(
                load.where + (key,),
                f"load {load.name!r} acts on link {link!r}, which does not exist"
                + suggest(str(link), list(links)),
            )
        pts = mech.ground if link == GROUND else links[link].points
        if point is not None and point not in pts:
            raise mech.error(
                load.where + (key,),
                f"load {load.name!r} acts at point {point!r}, which link {link!r} does not "
                "have" + suggest(str(point), list(pts)),
            )

    if isinstance(load, PointForce):
        on(load.link, load.point, "at")
        if not all(math.isfinite(v) for v in load.force):
            raise mech.error(load.where + ("force",), "the force must be finite")
        _in_range(mech, load.where + ("force",), "force", *load.force)
    elif isinstance(load, Torque):
        on(load.link, None, "torque")
        if not math.isfinite(load.torque):
            raise mech.error(load.where + ("torque",), "the torque must be finite")
        _in_range(mech, load.where + ("torque",), "torque", load.torque)
    elif isinstance(load, (Spring, Damper)):
        key = "spring" if isinstance(load, Spring) else "damper"
        for link, point in getattr(load, "ends", None) or ():
            on(link, point, key)
        if isinstance(load, Damper) and load.drag is not None:
            on(load.drag[0], load.drag[1], "drag")
        if isinstance(load, Damper) and load.slider is not None:
            if load.slider not in [j.name for j in mech.sliders]:
                raise mech.error(
                    load.where + ("slider",),
                    f"damper {load.name!r} acts along slider {load.slider!r}, which does not exist",
                )
        if isinstance(load, Spring):
            if not (load.stiffness >= 0 and math.isfinite(load.stiffness)):
                raise mech.error(
                    load.where + ("stiffness",),
                    f"a spring's stiffness must be zero or positive, got {load.stiffness}",
                )
            if not (load.free_length >= 0 and math.isfinite(load.free_length)):
                raise mech.error(
                    load.where + ("free_length",),
                    f"a spring's free length must be zero or positive, got {load.free_length}",
                )
            _in_range(mech, load.where + ("stiffness",), "stiffness", load.stiffness)
            _in_range(mech, load.where + ("free_length",), "length", load.free_length)
        elif not (load.coefficient >= 0 and math.isfinite(load.coefficient)):
            raise mech.error(
                load.where + ("coefficient",),
                f"a damping coefficient must be zero or positive, got {load.coefficient}",
            )
        if isinstance(load, Damper):
            _in_range(mech, load.where + ("coefficient",), "damping", load.coefficient)
