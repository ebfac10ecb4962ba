"""The construction of the velocity and acceleration polygons.

See :mod:`mechsolve.analyses.polygons`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mechsolve.analyses.instants import Instant, solve_instants
from mechsolve.analyses.polygons.dyads import DyadConstructions
from mechsolve.analyses.polygons.vectors import Arrow, _k_cross
from mechsolve.base.errors import InputError, SolverError
from mechsolve.base.units import (
    LIMITS,
    SI_OUTPUT,
    OutputUnits,
    UnitError,
    parse_quantity,
    read_number,
)
from mechsolve.core.sweep import Analysis
from mechsolve.joints.revolute import RevoluteConstraint
from mechsolve.joints.slider import SliderConstraint
from mechsolve.model import Mechanism

PAGE_MM = 120.0  # the largest extent of a polygon drawn at an automatic scale


def round_scale(extent: float, page: float = PAGE_MM) -> float:
    """The smallest round scale (1, 2 or 5 times a power of ten, units per mm) at which
    ``extent`` fits in ``page`` mm."""
    if not (extent > 0 and math.isfinite(extent)):
        return 1.0
    need = extent / page
    k = math.floor(math.log10(need))
    for base in (1.0, 2.0, 5.0, 10.0):
        mu = base * 10.0**k
        if mu >= need * (1 - 1e-12):
            return float(f"{mu:.12g}")
    return 10.0 ** (k + 1)  # pragma: no cover - the loop always returns


@dataclass
class Polygon:
    """A velocity or acceleration polygon: nodes (vectors from the pole, SI) and arrows."""

    quantity: str  # "velocity" or "acceleration"
    unit: str  # "m/s" or "m/s^2"
    pole: str  # "p" or "p'"
    scale: float = 1.0  # μ: units per mm of the drawing
    nodes: dict[str, np.ndarray] = field(default_factory=dict)
    arrows: list[Arrow] = field(default_factory=list)
    equations: list[str] = field(default_factory=list)

    def node(self, label: str) -> np.ndarray:
        return self.nodes[label]

    def add(self, arrow: Arrow) -> Arrow:
        for a in self.arrows:  # a vector already drawn between the same nodes
            if a.tail == arrow.tail and a.head == arrow.head:
                return a
        self.arrows.append(arrow)
        return arrow

    def extent(self) -> float:
        pts = np.array(list(self.nodes.values()))
        return float(np.max(pts.max(axis=0) - pts.min(axis=0))) if len(pts) else 0.0

    def mm(self, arrow: Arrow) -> float:
        return arrow.value / self.scale


@dataclass
class Angular:
    """An angular velocity or acceleration read from the polygon: ``value = num / length``."""

    symbol: str  # "ω4" or "α4"
    link: str
    value: float  # counter-clockwise positive (rad/s or rad/s^2)
    arrow: Arrow  # the relative velocity or tangential acceleration it is read from
    length: float  # the distance it is divided by (m)
    between: str  # the two points of that distance, e.g. "O4A4"

    @property
    def formula(self) -> str:
        return f"{self.arrow.name} / l_{self.between}"

    @property
    def num(self) -> float:
        return self.arrow.value


class _Construction(DyadConstructions):
    """The textbook construction, group by group, from the positions only."""

    def __init__(self, an: Analysis, st, ud: float, udd: float) -> None:
        self.an = an
        self.mech = an.mech
        self.system = an.system
        self.nb = self.system.nb
        self.st = st  # only x, y and th of the bodies are read from it
        self.ud, self.udd = ud, udd
        self.num = {self.nb: 1}
        for i in range(self.nb):
            self.num[i] = i + 2
        self.vp = Polygon("velocity", "m/s", "p")
        self.ap = Polygon("acceleration", "m/s^2", "p'")
        self.vp.nodes["p"] = np.zeros(2)
        self.ap.nodes["p'"] = np.zeros(2)
        # known motion of each body: a reference point (global), its velocity/acceleration
        # and the angular velocity/acceleration
        z = np.zeros(2)
        self.kv: dict[int, tuple[np.ndarray, np.ndarray, float]] = {self.nb: (z, z, 0.0)}
        self.ka: dict[int, tuple[np.ndarray, np.ndarray, float]] = {self.nb: (z, z, 0.0)}
        self.where: dict[str, tuple[int, np.ndarray]] = {}  # node -> (body, global point)
        self.omegas: list[Angular] = []
        self.alphas: list[Angular] = []
        self.sliding: list[tuple[str, float, float]] = []  # joint, v_rel, a_rel (block/guide)
        self.numbered: set[str] = set()  # point names shown with their link's number
        self.alias: dict[tuple[str, int], str] = {}  # (point, body) -> the node's label

    # -- geometry (positions only) ----------------------------------------------------
    def pos(self, b: int, s) -> np.ndarray:
        s = np.asarray(s, float)
        if b == self.nb:
            return s.copy()
        th = float(self.st.th[b, 0])
        c, sn = math.cos(th), math.sin(th)
        return np.array(
            [
                float(self.st.x[b, 0]) + c * s[0] - sn * s[1],
                float(self.st.y[b, 0]) + sn * s[0] + c * s[1],
            ]
        )

    def line_dir(self, sl: SliderConstraint) -> np.ndarray:
        th = 0.0 if sl.a == self.nb else float(self.st.th[sl.a, 0])
        c, s = math.cos(th), math.sin(th)
        u = sl.u_loc
        return np.array([c * u[0] - s * u[1], s * u[0] + c * u[1]])

    def pin_point(self, c: RevoluteConstraint) -> tuple[str, np.ndarray]:
        return self.an.joint_point[c], self.pos(c.a, c.sa)

    def link(self, b: int) -> str:
        return "ground" if b == self.nb else self.system.body_names[b]

    def label(self, name: str, b: int) -> str:
        if (name, b) in self.alias:  # a body pinned at a numbered point shares its node
            return self.alias[(name, b)]
        return f"{name}{self.num[b]}" if name in self.numbered else name

    # -- known motion of bodies -------------------------------------------------------
    def v_of(self, b: int, r: np.ndarray) -> np.ndarray:
        r0, v0, w = self.kv[b]
        return v0 + _k_cross(w, r - r0)

    def a_of(self, b: int, r: np.ndarray) -> np.ndarray:
        r0, a0, al = self.ka[b]
        d = r - r0
        return a0 + _k_cross(al, d) - self.kv[b][2] ** 2 * d

    def vnode(self, b: int, name: str, r: np.ndarray) -> str:
        """The velocity image of point ``name`` (at ``r``) of the known body ``b``."""
        if b == self.nb:
            return "p"
        lab = self.label(name, b)
        if lab not in self.vp.nodes:
            self.vp.nodes[lab] = self.v_of(b, r)
            self.where[lab] = (b, r)
            self.absolute(self.vp, lab, f"v_{lab}", f"image on link {self.num[b]}")
        return lab

    def anode(self, b: int, name: str, r: np.ndarray) -> str:
        if b == self.nb:
            return "p'"
        lab = self.label(name, b)
        key = lab + "'"
        if key not in self.ap.nodes:
            self.ap.nodes[key] = self.a_of(b, r)
            self.absolute(self.ap, key, f"a_{lab}", f"image on link {self.num[b]}")
        return key

    @staticmethod
    def absolute(poly: Polygon, key: str, name: str, note: str) -> None:
        """The vector from the pole to node ``key``, unless the node is at the pole."""
        vec = poly.nodes[key]
        pts = np.array(list(poly.nodes.values()))
        size = float(np.max(np.abs(pts))) if len(pts) else 0.0
        if np.hypot(*vec) > 1e-12 * size:
            poly.add(Arrow(name, poly.pole, key, vec, "absolute", note))

    def rename(self, old: str, new: str) -> None:
        """Give a node the name with its link's number once a slider makes it ambiguous."""
        for poly, o, n in ((self.vp, old, new), (self.ap, old + "'", new + "'")):
            if o not in poly.nodes or o == n:
                continue
            poly.nodes[n] = poly.nodes.pop(o)
            for a in poly.arrows:
                a.tail = n if a.tail == o else a.tail
                a.head = n if a.head == o else a.head
                if a.name in (f"v_{old}", f"a_{old}"):
                    a.name = a.name[:2] + new
        if old in self.where:
            self.where[new] = self.where.pop(old)

    def rel_name(self, q: str, m: str, ground: bool) -> str:
        return m if ground else m + q

    def add_angular(
        self,
        b: int,
        w: float,
        al: float,
        v_arrow: Arrow,
        t_arrow: Arrow | None,
        length: float,
        pts: str,
    ) -> None:
        n = self.num[b]
        self.omegas.append(Angular(f"ω{n}", self.link(b), w, v_arrow, length, pts))
        if t_arrow is not None:
            self.alphas.append(Angular(f"α{n}", self.link(b), al, t_arrow, length, pts))

    # -- the groups ------------------------------------------------------------------
    def run(self) -> None:
        if self.an.redundant:
            raise InputError(
                "polygons: the mechanism has redundant constraints; the graphical method "
                "needs a mechanism built of Assur groups"
            )
        for g in self.an.groups:
            self.group(g)
        self.images()

    def group(self, g) -> None:
        cons = list(g.constraints)
        pattern = "".join(sorted(c.letter for c in cons))  # the Assur notation
        inside = set(g.bodies)
        if len(g.bodies) == 1 and pattern == "DR":
            return self.driver_link(g.bodies[0], cons)
        if len(g.bodies) == 2 and len(cons) == 3:
            inner = [c for c in cons if c.a in inside and c.b in inside]
            if len(inner) == 1:
                jm = inner[0]
                outer = {b: [c for c in cons if c is not jm and b in (c.a, c.b)] for b in inside}
                if all(len(v) == 1 for v in outer.values()):
                    b1, b2 = g.bodies
                    o1, o2 = outer[b1][0], outer[b2][0]
                    rev = [c.letter == "R" for c in (o1, jm, o2)]
                    if rev == [True, True, True]:
                        return self.rrr(b1, b2, o1, jm, o2)
                    if rev == [True, True, False]:
                        return self.rrp(b1, b2, o1, jm, o2)
                    if rev == [False, True, True]:
                        return self.rrp(b2, b1, o2, jm, o1)
                    if rev == [True, False, True] and jm.letter == "P":
                        blk, bar = jm.b, jm.a
                        jp = o1 if blk == b1 else o2
                        jq = o2 if blk == b1 else o1
                        return self.rpr(blk, bar, jp, jq, jm)
                    if rev == [False, True, False]:
                        return self.prp(b1, b2, o1, jm, o2)
        raise InputError(
            f"polygons: the graphical method here draws groups of the kinds driver link, "
            f"RRR, RRP, RPR and PRP; {g.label} is not one of them (its velocities and "
            "accelerations are in `mechsolve run --at`)"
        )

    def images(self) -> None:
        """The images of every named point of the moving links, and the absolute vectors
        from the poles to them."""
        for b, name in enumerate(self.system.body_names):
            if b not in self.kv:
                continue
            for pname, loc in self.mech.link(name).points.items():
                r = self.pos(b, loc)
                lab = self.label(pname, b)
                if lab not in self.vp.nodes:
                    self.vnode(b, pname, r)
                if lab + "'" not in self.ap.nodes:
                    self.anode(b, pname, r)
                self.where.setdefault(lab, (b, r))
                note = f"image on link {self.num[b]}"
                self.absolute(self.vp, lab, f"v_{lab}", note)
                self.absolute(self.ap, lab + "'", f"a_{lab}", note)


@dataclass
class PolygonResult:
    """The polygons at one position, the values read from them, and their check.

    ``velocity`` and ``acceleration`` are the :class:`Polygon` objects (their ``scale`` is
    μv in (m/s)/mm and μa in (m/s^2)/mm); ``omegas``/``alphas`` the angular velocities and
    accelerations of the links derived from them; ``check`` the differences from
    mechsolve's analytic solution; ``images`` the files written (by :func:`draw_polygons`)."""

    mechanism: Mechanism
    analysis: Analysis
    state: object
    label: str
    u: float
    links: dict[str, int]
    velocity: Polygon
    acceleration: Polygon
    omegas: list[Angular]
    alphas: list[Angular]
    sliding: list[tuple[str, float, float]]
    check: dict[str, float]
    length_scale: float
    images: list[Path] = field(default_factory=list)

    def value(self, name: str) -> float:
        """The magnitude of the vector named ``name`` (e.g. ``"v_A3"``, ``"a^k_A3A4"``)."""
        for poly in (self.velocity, self.acceleration):
            for a in poly.arrows:
                if a.name == name:
                    return a.value
        raise KeyError(name)

    def arrow(self, name: str) -> Arrow:
        for poly in (self.velocity, self.acceleration):
            for a in poly.arrows:
                if a.name == name:
                    return a
        raise KeyError(name)

    def angular(self, symbol: str) -> Angular:
        for a in self.omegas + self.alphas:
            if a.symbol == symbol:
                return a
        raise KeyError(symbol)

    def text(self, units: OutputUnits | None = None) -> str:
        """The printed summary; its figures in ``units`` (default SI: m, m/s, rad/s). The
        drawn lengths stay mm of the drawing, and the scales are the shown unit per mm."""
        u = units or SI_OUTPUT
        L = u.unit_of("length")
        k_len, _ = u.convert("m")
        mech = self.mechanism
        lines = [f"{mech.name}: velocity and acceleration polygons at {self.label}"]
        lines.append("  links: " + ", ".join(f"{n} {name}" for name, n in self.links.items()))
        kv, uv = u.convert("m/s")
        ka, ua = u.convert("m/s^2")
        kw, uw = u.convert("rad/s")
        kal, ual = u.convert("rad/s^2")
        lines.append(
            f"  scales: μl = {self.length_scale * k_len:g} {L}/mm, "
            f"μv = {self.velocity.scale * kv:g} ({uv})/mm, "
            f"μa = {self.acceleration.scale * ka:g} ({ua})/mm"
        )
        for poly in (self.velocity, self.acceleration):
            k, unit = u.convert(poly.unit)
            lines.append(f"{poly.quantity} polygon (pole {poly.pole}), group by group:")
            for eq in poly.equations:
                lines.append(f"  {eq}")
            w = max([len(a.name) for a in poly.arrows] + [6])
            lines.append(
                f"  {'vector':<{w}}  {'drawn':<12}  {'length':>8}  {'value':>9}  direction"
            )
            lines.append(f"  {'':<{w}}  {'':<12}  {'[mm]':>8}  {'[' + unit + ']':>9}")
            for a in poly.arrows:
                val = f"{a.value * k:.4g}" if a.along is None else f"{a.along * k:+.4g}"
                lines.append(
                    f"  {a.name:<{w}}  {a.tail + ' -> ' + a.head:<12}  {poly.mm(a):8.1f}  "
                    f"{val:>9}  {a.note}"
                )
        lines.append(
            "angular velocities and accelerations of the links (ω = v_rel / l, "
            "α = a^t / l; + counter-clockwise):"
        )
        for ang, k, k_num, unit in [(a, kw, kv, uw) for a in self.omegas] + [
            (a, kal, ka, ual) for a in self.alphas
        ]:
            sense = "counter-clockwise" if ang.value > 0 else "clockwise" if ang.value else ""
            lines.append(
                f"  {ang.symbol} ({ang.link}) = {ang.formula} = {ang.num * k_num:.4g} / "
                f"{ang.length * k_len:.4g} {L} = {ang.value * k:+.4g} {unit} {sense}".rstrip()
            )
        c = self.check
        lines.append(
            "check against mechsolve's analytic solution (largest differences): "
            f"velocities {c['velocity'] * kv:.2g} {uv} "
            f"({c['velocity'] / self.velocity.scale:.2g} mm "
            f"on the drawing), accelerations {c['acceleration'] * ka:.2g} {ua} "
            f"({c['acceleration'] / self.acceleration.scale:.2g} mm), "
            f"ω {c['omega'] * kw:.2g} {uw}, α {c['alpha'] * kal:.2g} {ual}"
        )
        return "\n".join(lines)


_INDEX = re.compile(r"\s*(?:position\s*)?#?\s*([0-9]+)\s*")  # ASCII digits, as the file's


def resolve_at(an: Analysis, at: int | str, per_turn: int = 12) -> Instant:
    """The instant of ``at``: a position number (1 at the file's driver start, ``per_turn``
    per turn of a crank in its direction of motion, or per sweep of a linear driver), a
    driver angle (``"196.8 deg"``) or position (``"20 mm"``), or a time from the start
    (``"0.5 s"``)."""
    mech = an.mech
    d = mech.driver
    where = "--at"
    if per_turn < 1:
        raise InputError(f"{where}: the number of positions per turn must be at least 1")
    text = str(at)
    m = _INDEX.fullmatch(text) if not isinstance(at, float) else None
    law = d.motion
    if law is not None:
        try:
            t = parse_quantity(text, "time")
        except UnitError:
            raise InputError(
                f"{where} {text!r}: this driver follows a motion law of time: give the "
                "instant as a time from the start, e.g. '0.5 s'"
            ) from None
        u, ud, udd = (float(np.asarray(v).ravel()[0]) for v in law.at(np.array([t])))
        _within_reach(an, u - float(law.at(np.array([0.0]))[0][0]), text, t)
        return Instant(u, ud, udd, f"t = {t:g} s")
    u0 = an.start_value()
    if not math.isfinite(u0):
        raise SolverError("polygons: the driver's start position could not be determined")
    travel = 2 * math.pi if not an.linear else mech.sweep.travel
    if m is not None:
        k = int(m.group(1))
        last = per_turn if not an.linear else per_turn + 1
        if not 1 <= k <= last:
            raise InputError(
                f"{where} {text!r}: positions are numbered 1 to {last} ({per_turn} per "
                f"{'turn' if not an.linear else 'sweep'}, position 1 at the driver's start)"
            )
        if an.linear and not travel:
            raise InputError(f"{where}: a linear driver's positions need the sweep's range")
        du = (k - 1) * travel / per_turn
        t = du / abs(d.speed) if d.speed else 0.0
        u = u0 + d.direction * du
        what = "turn" if not an.linear else "sweep"
        return Instant(
            u,
            d.speed,
            0.0,
            f"position {k} of {per_turn} per {what} "
            f"({an.format_u(u)}, t = {t:.6g} s from position 1)",
        )
    kind = "length" if an.linear else "angle"
    if _bare_number(text):
        raise InputError(
            f"{where} {text!r}: give the {kind} with its unit ('{text} "
            f"{'mm' if an.linear else 'deg'}'); a bare whole number is a position number"
        )
    try:
        val = parse_quantity(text, kind)
    except UnitError as exc:
        bad = exc
        try:
            t = parse_quantity(text, "time")
        except UnitError as exc2:
            for e in (bad, exc2):  # a number out of range or not read: say why
                if any(w in str(e) for w in _WHY):
                    raise InputError(f"{where} {text!r}: {e}") from None
            raise InputError(
                f"{where} {text!r}: expected a position number (1 to {per_turn}), a driver "
                f"{'position such as 20 mm' if an.linear else 'angle such as 196.8 deg'}, or "
                "a time from the start such as 0.5 s"
            ) from None
        _within_reach(an, d.speed * t, text, t)
        u = u0 + d.speed * t
        return Instant(u, d.speed, 0.0, f"t = {t:g} s from the start ({an.format_u(u)})")
    u = val if an.linear else _on_its_turn(val, u0, d.direction)
    return Instant(u, d.speed, 0.0, an.format_u(u))


def _on_its_turn(val: float, u0: float, direction: int) -> float:
    """The driver angle ``val`` ahead of the start ``u0`` as written, on the turn it names
    (solved within the machine's cycle: 400 deg of a 20-tooth pinion driving a 60-tooth
    wheel is not 40 deg, nor is 390 deg of a four-bar that changes branch at a change
    point); behind it, the same angle reached from the start along the driver's
    ``direction``, on its first turn."""
    if direction * (val - u0) >= 0:
        return val
    return u0 + direction * ((direction * (val - u0)) % (2 * math.pi))


# the reasons of parse_quantity worth more than "expected ...": out of range, or a number
# the file's rule does not read (full-width digits, 1_000, 1:45, a decimal comma)
_WHY = ("too large", "not a finite", "is not a number", "digits other than ASCII")


def _bare_number(text: str) -> bool:
    """Whether ``text`` is a number without a unit (``'1.5'``, ``'1e9'``)."""
    try:  # read as the file's numbers are (full-width digits and 1_000 are not numbers)
        read_number(text)
    except UnitError:
        return False
    return True


def _within_reach(an: Analysis, travel: float, text: str, t: float) -> None:
    """Refuse an instant whose driver travel from the start (rad, or m for a linear
    driver) is beyond what mechsolve accepts as a position (as ``run --at`` does): the
    instant is reached by solving along the motion from the start, whose size grows with
    the travel (1e9 rad asked for hundreds of GB)."""
    kind, unit = ("length", "m") if an.linear else ("angle", "rad")
    limit = LIMITS[kind]
    if not math.isfinite(travel):
        raise InputError(f"--at {text!r}: the driver's motion is not finite at t = {t:g} s")
    if not abs(travel) <= limit:
        raise InputError(
            f"--at {text!r}: the driver would travel {abs(travel):.6g} {unit} from the "
            f"start by t = {t:g} s; mechsolve accepts at most {limit:g} {unit} in magnitude "
            f"for {'a length' if an.linear else 'an angle'}: give an earlier time, or the "
            f"driver {'position' if an.linear else 'angle'} itself"
        )


def build_polygons(
    mech: Mechanism,
    at: int | str,
    *,
    scale_v: float | None = None,
    scale_a: float | None = None,
    per_turn: int = 12,
    method: str | None = None,
) -> PolygonResult:
    """Construct the polygons of ``mech`` at ``at`` (see :func:`resolve_at`) and check
    them against the analytic solution; nothing is drawn."""
    mech.ensure_valid()  # built in code, or edited since it was loaded: check it first
    for name, val in (("--scale-v", scale_v), ("--scale-a", scale_a)):
        if val is not None and not (val > 0 and math.isfinite(val)):
            raise InputError(f"{name} {val!r}: a scale is a positive number of units per mm")
    if mech.joint(mech.driver.joint).coordinate == "length":
        raise InputError(
            "polygons: the graphical method here starts from a crank (a revolute driver); "
            f"{mech.driver.joint} is a slider"
        )
    an = Analysis(mech, method)
    inst = resolve_at(an, at, per_turn)
    res = solve_instants(mech, [inst], method=method, forces=False)
    if not res.ok[0]:
        raise SolverError(
            f"polygons: the mechanism cannot close at {inst.label}: {res.status()[0]}"
        )
    an = res.analysis
    st = res.solution.state
    con = _Construction(an, st, float(inst.ud), float(inst.udd))
    con.run()
    check = _check(con, st)
    con.vp.scale = scale_v or round_scale(con.vp.extent())
    con.ap.scale = scale_a or round_scale(con.ap.extent())
    pts = np.array([con.pos(r.body, r.local) for r in an.points.values()])
    size = float(np.max(pts.max(axis=0) - pts.min(axis=0))) if len(pts) else 1.0
    links = {"ground": 1, **{n: i + 2 for i, n in enumerate(an.system.body_names)}}
    return PolygonResult(
        mech,
        an,
        st,
        inst.label,
        inst.u,
        links,
        con.vp,
        con.ap,
        con.omegas,
        con.alphas,
        con.sliding,
        check,
        round_scale(size),
    )


def _check(con: _Construction, st) -> dict[str, float]:
    """Largest differences between the construction and the analytic state."""
    dv = da = 0.0
    for lab, (b, r) in con.where.items():
        if b == con.nb:
            continue
        x0 = np.array([st.x[b, 0], st.y[b, 0]])
        v = np.array([st.vx[b, 0], st.vy[b, 0]]) + _k_cross(float(st.w[b, 0]), r - x0)
        a = (
            np.array([st.ax[b, 0], st.ay[b, 0]])
            + _k_cross(float(st.al[b, 0]), r - x0)
            - float(st.w[b, 0]) ** 2 * (r - x0)
        )
        dv = max(dv, float(np.hypot(*(v - con.vp.nodes[lab]))))
        da = max(da, float(np.hypot(*(a - con.ap.nodes[lab + "'"]))))
    dw = dal = 0.0
    for b in con.kv:
        if b == con.nb:
            continue
        dw = max(dw, abs(con.kv[b][2] - float(st.w[b, 0])))
        dal = max(dal, abs(con.ka[b][2] - float(st.al[b, 0])))
    for joint, vrel, arel in con.sliding:
        sl = con.system.by_joint[joint]
        dv = max(dv, abs(vrel - float(sl.velocity(st)[0])))
        da = max(da, abs(arel - float(sl.acceleration(st)[0])))
    return {"velocity": dv, "acceleration": da, "omega": dw, "alpha": dal}
