"""The construction of the velocity and acceleration polygons (see :mod:`mechsolve.polygons`)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..constraints import AngleDriverConstraint, RevoluteConstraint, SliderConstraint
from ..errors import InputError, SolverError
from ..instants import Instant, solve_instants
from ..model import Mechanism, SliderJoint
from ..sweep import Analysis
from ..units import UnitError, parse_quantity

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


def _k_cross(w: float, r: np.ndarray) -> np.ndarray:
    """``w k × r``: the vector ``r`` turned by 90° counter-clockwise, times ``w``."""
    return np.array([-w * r[1], w * r[0]])


def _intersect(p1, d1, p2, d2, what: str) -> tuple[float, float]:
    """``(s, t)`` with ``p1 + s d1 = p2 + t d2``: where two direction lines cross."""
    m = np.array([[d1[0], -d2[0]], [d1[1], -d2[1]]], float)
    scale = float(np.linalg.norm(d1) * np.linalg.norm(d2))
    det = float(np.linalg.det(m))
    if scale == 0 or abs(det) <= 1e-10 * scale:
        raise SolverError(
            f"{what}: the two direction lines are parallel (a dead-centre or toggle "
            "position): the polygon does not close here; pick another position"
        )
    s, t = np.linalg.solve(m, np.asarray(p2, float) - np.asarray(p1, float))
    return float(s), float(t)


@dataclass
class Arrow:
    """One vector of a polygon, drawn from node ``tail`` to node ``head``.

    ``kind``: ``absolute`` (from the pole), ``relative`` (rotation about another point of
    the link), ``normal`` / ``tangential`` (components of a relative acceleration),
    ``coriolis`` or ``sliding`` (relative motion along a guide). ``along``: the signed
    value along the guide for sliding vectors (positive in the guide line's direction)."""

    name: str
    tail: str
    head: str
    vec: np.ndarray
    kind: str
    note: str = ""
    along: float | None = None

    @property
    def value(self) -> float:
        return float(np.hypot(*self.vec))


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


class _Construction:
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
        kinds = sorted(c.kind for c in cons)
        inside = set(g.bodies)
        if len(g.bodies) == 1 and kinds == ["driver", "revolute"]:
            return self.driver_link(g.bodies[0], cons)
        if len(g.bodies) == 2 and len(cons) == 3:
            inner = [c for c in cons if c.a in inside and c.b in inside]
            if len(inner) == 1:
                jm = inner[0]
                outer = {b: [c for c in cons if c is not jm and b in (c.a, c.b)] for b in inside}
                if all(len(v) == 1 for v in outer.values()):
                    b1, b2 = g.bodies
                    o1, o2 = outer[b1][0], outer[b2][0]
                    rev = [isinstance(c, RevoluteConstraint) for c in (o1, jm, o2)]
                    if rev == [True, True, True]:
                        return self.rrr(b1, b2, o1, jm, o2)
                    if rev == [True, True, False]:
                        return self.rrp(b1, b2, o1, jm, o2)
                    if rev == [False, True, True]:
                        return self.rrp(b2, b1, o2, jm, o1)
                    if rev == [True, False, True] and isinstance(jm, SliderConstraint):
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

    def driver_link(self, b: int, cons) -> None:
        pin = next(c for c in cons if isinstance(c, RevoluteConstraint))
        drv = next(c for c in cons if isinstance(c, AngleDriverConstraint))
        k = pin.a if pin.b == b else pin.b
        pname, P = self.pin_point(pin)
        other = drv.a if drv.b == b else drv.b
        sign = 1.0 if drv.b == b else -1.0
        w = self.kv[other][2] + sign * self.ud
        al = self.ka[other][2] + sign * self.udd
        nP = self.vnode(k, pname, P)
        aP = self.anode(k, pname, P)
        vP, accP = self.vp.nodes[nP], self.ap.nodes[aP]
        self.kv[b] = (P, vP, w)
        self.ka[b] = (P, accP, al)
        n = self.num[b]
        given = "ω" + str(n) + (" = the driver's speed" if other == self.nb else "")
        self.vp.equations.append(f"{self.link(b)} (driver link {n}): {given}")
        self.ap.equations.append(f"{self.link(b)} (driver link {n}): α{n} = {al:.6g} rad/s^2")
        lk = self.mech.link(self.link(b))
        first = None
        for name, loc in lk.points.items():
            if name == pname:
                continue
            r = self.pos(b, loc)
            lab = self.label(name, b)
            ground = k == self.nb
            rel = self.rel_name(pname, lab, ground)
            v = _k_cross(w, r - P)
            self.vp.nodes[lab] = vP + v
            self.where[lab] = (b, r)
            va = self.vp.add(
                Arrow(
                    f"v_{rel}",
                    nP,
                    lab,
                    v,
                    "absolute" if ground else "relative",
                    f"⟂ {pname}{name}, = ω{n}·l_{pname}{name}",
                )
            )
            an_ = -(w**2) * (r - P)
            at = _k_cross(al, r - P)
            key = lab + "'"
            self.ap.nodes[key] = accP + an_ + at
            if al == 0.0:
                self.ap.add(
                    Arrow(
                        f"a^n_{rel}" if not ground else f"a_{lab}",
                        aP,
                        key,
                        an_,
                        "normal" if not ground else "absolute",
                        f"∥ {name}{pname}, = ω{n}²·l_{pname}{name} (α{n} = 0)",
                    )
                )
                ta = None
            else:
                tip = f"n{n}{name}'"
                self.ap.nodes[tip] = accP + an_
                self.ap.add(
                    Arrow(f"a^n_{rel}", aP, tip, an_, "normal", f"∥ {name}{pname}, = ω{n}²·l")
                )
                ta = self.ap.add(
                    Arrow(f"a^t_{rel}", tip, key, at, "tangential", f"⟂ {pname}{name}, = α{n}·l")
                )
            if first is None:
                first = (va, ta, float(np.hypot(*(r - P))), f"{pname}{name}")
        if first is not None:
            self.add_angular(b, w, al, first[0], first[1], first[2], first[3])

    def rrr(self, b1: int, b2: int, j1, jm, j3) -> None:
        k1 = j1.a if j1.b == b1 else j1.b
        k2 = j3.a if j3.b == b2 else j3.b
        pn, P = self.pin_point(j1)
        qn, Q = self.pin_point(j3)
        mn, M = self.pin_point(jm)
        nP, nQ = self.vnode(k1, pn, P), self.vnode(k2, qn, Q)
        vP, vQ = self.vp.nodes[nP], self.vp.nodes[nQ]
        e1, e2 = _k_cross(1.0, M - P), _k_cross(1.0, M - Q)
        w1, w2 = _intersect(vP, e1, vQ, e2, f"velocity of {mn}")
        mlab = self.label(mn, b1)
        self.vp.nodes[mlab] = vP + w1 * e1
        self.where[mlab] = (b1, M)
        g1, g2 = k1 == self.nb, k2 == self.nb
        r1, r2 = self.rel_name(pn, mn, g1), self.rel_name(qn, mn, g2)
        self.vp.equations.append(
            f"{mn} (RRR, links {self.num[b1]} and {self.num[b2]}): v_{mn} = "
            + ("" if g1 else f"v_{pn} + ")
            + f"v_{r1} (⟂ {pn}{mn}) = "
            + ("" if g2 else f"v_{qn} + ")
            + f"v_{r2} (⟂ {qn}{mn})"
        )
        kind = {True: "absolute", False: "relative"}
        v1 = self.vp.add(Arrow(f"v_{r1}", nP, mlab, w1 * e1, kind[g1], f"⟂ {pn}{mn}"))
        v2 = self.vp.add(Arrow(f"v_{r2}", nQ, mlab, w2 * e2, kind[g2], f"⟂ {qn}{mn}"))
        self.kv[b1] = (P, vP, w1)
        self.kv[b2] = (Q, vQ, w2)
        aP, aQ = self.anode(k1, pn, P), self.anode(k2, qn, Q)
        accP, accQ = self.ap.nodes[aP], self.ap.nodes[aQ]
        n1, n2 = accP - w1**2 * (M - P), accQ - w2**2 * (M - Q)
        al1, al2 = _intersect(n1, e1, n2, e2, f"acceleration of {mn}")
        key = mlab + "'"
        self.ap.nodes[key] = n1 + al1 * e1
        t1n, t2n = f"n{self.num[b1]}'", f"n{self.num[b2]}'"
        self.ap.nodes[t1n], self.ap.nodes[t2n] = n1, n2
        self.ap.equations.append(
            f"{mn}: a_{mn} = "
            + ("" if g1 else f"a_{pn} + ")
            + f"a^n_{r1} + a^t_{r1} (⟂ {pn}{mn}) = "
            + ("" if g2 else f"a_{qn} + ")
            + f"a^n_{r2} + a^t_{r2} (⟂ {qn}{mn})"
        )
        self.ap.add(
            Arrow(
                f"a^n_{r1}",
                aP,
                t1n,
                n1 - accP,
                "normal",
                f"∥ {mn}{pn}, = ω{self.num[b1]}²·l_{pn}{mn}",
            )
        )
        t1 = self.ap.add(Arrow(f"a^t_{r1}", t1n, key, al1 * e1, "tangential", f"⟂ {pn}{mn}"))
        self.ap.add(
            Arrow(
                f"a^n_{r2}",
                aQ,
                t2n,
                n2 - accQ,
                "normal",
                f"∥ {mn}{qn}, = ω{self.num[b2]}²·l_{qn}{mn}",
            )
        )
        t2 = self.ap.add(Arrow(f"a^t_{r2}", t2n, key, al2 * e2, "tangential", f"⟂ {qn}{mn}"))
        self.ka[b1] = (P, accP, al1)
        self.ka[b2] = (Q, accQ, al2)
        self.add_angular(b1, w1, al1, v1, t1, float(np.hypot(*(M - P))), pn + mn)
        self.add_angular(b2, w2, al2, v2, t2, float(np.hypot(*(M - Q))), qn + mn)

    def rrp(self, rod: int, x: int, j1, jm, sl: SliderConstraint) -> None:
        """Rod pinned at P (known body k1) and at M to body x, which slides on body k2."""
        k1 = j1.a if j1.b == rod else j1.b
        k2 = sl.a if sl.b == x else sl.b
        sgn = 1.0 if sl.b == x else -1.0  # x's motion relative to k2 along the line
        pn, P = self.pin_point(j1)
        mn, M = self.pin_point(jm)
        d = self.line_dir(sl)
        g2 = k2 == self.nb
        if not g2:
            self.numbered.add(mn)
        nP = self.vnode(k1, pn, P)
        nK = self.vnode(k2, mn, M)
        vP, vK = self.vp.nodes[nP], self.vp.nodes[nK]
        e = _k_cross(1.0, M - P)
        w, vrel = _intersect(vP, e, vK, d, f"velocity of {mn}")
        mlab = self.label(mn, x)
        self.alias[(mn, rod)] = mlab
        self.vp.nodes[mlab] = vP + w * e
        self.where[mlab] = (x, M)
        g1 = k1 == self.nb
        r1 = self.rel_name(pn, mn, g1)
        rk = self.rel_name(self.label(mn, k2), mlab, g2)
        joint = sl.name
        self.vp.equations.append(
            f"{mn} (RRP, link {self.num[rod]} and slider {joint}): v_{mlab} = "
            + ("" if g1 else f"v_{pn} + ")
            + f"v_{r1} (⟂ {pn}{mn}) = "
            + ("" if g2 else f"v_{self.label(mn, k2)} + ")
            + f"v_{rk} (∥ {joint})"
        )
        va = self.vp.add(
            Arrow(f"v_{r1}", nP, mlab, w * e, "absolute" if g1 else "relative", f"⟂ {pn}{mn}")
        )
        self.vp.add(
            Arrow(
                f"v_{rk}",
                nK,
                mlab,
                vrel * d,
                "absolute" if g2 else "sliding",
                f"∥ {joint}",
                along=vrel,
            )
        )
        wk = self.kv[k2][2]
        self.kv[rod] = (P, vP, w)
        self.kv[x] = (M, self.vp.nodes[mlab], wk)
        aP, aK = self.anode(k1, pn, P), self.anode(k2, mn, M)
        accP, accK = self.ap.nodes[aP], self.ap.nodes[aK]
        n1 = accP - w**2 * (M - P)
        cor = 2 * _k_cross(wk, vrel * d)
        al, arel = _intersect(n1, e, accK + cor, d, f"acceleration of {mn}")
        key = mlab + "'"
        self.ap.nodes[key] = n1 + al * e
        nn = f"n{self.num[rod]}'"
        self.ap.nodes[nn] = n1
        self.ap.equations.append(
            f"{mn}: a_{mlab} = "
            + ("" if g1 else f"a_{pn} + ")
            + f"a^n_{r1} + a^t_{r1} (⟂ {pn}{mn}) = "
            + ("" if g2 else f"a_{self.label(mn, k2)} + a^k_{rk} + ")
            + (f"a^r_{rk} (∥ {joint})" if not g2 else f"a_{mlab} (∥ {joint})")
        )
        self.ap.add(
            Arrow(
                f"a^n_{r1}",
                aP,
                nn,
                n1 - accP,
                "normal",
                f"∥ {mn}{pn}, = ω{self.num[rod]}²·l_{pn}{mn}",
            )
        )
        ta = self.ap.add(Arrow(f"a^t_{r1}", nn, key, al * e, "tangential", f"⟂ {pn}{mn}"))
        if g2:
            self.ap.add(
                Arrow(f"a_{mlab}", "p'", key, arel * d, "absolute", f"∥ {joint}", along=arel)
            )
        else:
            kk = f"k{self.num[x]}'"
            self.ap.nodes[kk] = accK + cor
            self.ap.add(
                Arrow(
                    f"a^k_{rk}", aK, kk, cor, "coriolis", f"= 2 ω{self.num[k2]} v_{rk}, ⟂ {joint}"
                )
            )
            self.ap.add(Arrow(f"a^r_{rk}", kk, key, arel * d, "sliding", f"∥ {joint}", along=arel))
        self.ka[rod] = (P, accP, al)
        self.ka[x] = (M, self.ap.nodes[key], self.ka[k2][2])
        self.sliding.append((joint, sgn * vrel, sgn * arel))
        self.add_angular(rod, w, al, va, ta, float(np.hypot(*(M - P))), pn + mn)

    def rpr(self, blk: int, bar: int, jp, jq, sl: SliderConstraint) -> None:
        """Block pinned at A (known body) slides on a bar pinned at Q (known body)."""
        kp = jp.a if jp.b == blk else jp.b
        kq = jq.a if jq.b == bar else jq.b
        an_, A = self.pin_point(jp)
        qn, Q = self.pin_point(jq)
        d = self.line_dir(sl)
        joint = sl.name
        nA = self.vnode(kp, an_, A)
        self.numbered.add(an_)  # the block's point and the bar's point under it: A3, A4
        if nA != "p":
            self.rename(nA, self.label(an_, blk))
            nA = self.label(an_, blk)
            self.alias[(an_, kp)] = nA
        nQ = self.vnode(kq, qn, Q)
        vA, vQ = self.vp.nodes[nA], self.vp.nodes[nQ]
        e = _k_cross(1.0, A - Q)
        w, t = _intersect(vQ, e, vA, d, f"velocity of the bar's point under {an_}")
        vrel = -t  # the block relative to the bar, along the guide
        a3, a4 = self.label(an_, blk), self.label(an_, bar)
        self.vp.nodes[a4] = vQ + w * e
        self.where[a4] = (bar, A)
        gq = kq == self.nb
        r4 = self.rel_name(qn, a4, gq)
        rs = a3 + a4
        self.vp.equations.append(
            f"{joint} (RPR, block {self.num[blk]} on link {self.num[bar]}): v_{a3} = "
            + ("" if gq else f"v_{qn} + ")
            + f"v_{r4} (⟂ {qn}{an_}) + v_{rs} (∥ {joint})"
        )
        va = self.vp.add(
            Arrow(f"v_{r4}", nQ, a4, w * e, "absolute" if gq else "relative", f"⟂ {qn}{an_}")
        )
        self.vp.add(Arrow(f"v_{rs}", a4, nA, vrel * d, "sliding", f"∥ {joint}", along=vrel))
        self.kv[bar] = (Q, vQ, w)
        self.kv[blk] = (A, vA, w)
        aA, aQ = self.anode(kp, an_, A), self.anode(kq, qn, Q)
        accA, accQ = self.ap.nodes[aA], self.ap.nodes[aQ]
        n4 = accQ - w**2 * (A - Q)
        cor = 2 * _k_cross(w, vrel * d)
        al, t = _intersect(n4, e, accA - cor, d, f"acceleration of the bar's point under {an_}")
        arel = -t
        key4 = a4 + "'"
        self.ap.nodes[key4] = n4 + al * e
        nn, kk = f"n{self.num[bar]}'", f"k{self.num[blk]}'"
        self.ap.nodes[nn] = n4
        self.ap.nodes[kk] = self.ap.nodes[key4] + cor
        self.ap.equations.append(
            f"{joint}: a_{a3} = "
            + ("" if gq else f"a_{qn} + ")
            + f"a^n_{r4} + a^t_{r4} (⟂ {qn}{an_}) + a^k_{rs} + a^r_{rs} (∥ {joint})"
        )
        self.ap.add(
            Arrow(
                f"a^n_{r4}",
                aQ,
                nn,
                n4 - accQ,
                "normal",
                f"∥ {an_}{qn}, = ω{self.num[bar]}²·l_{qn}{an_}",
            )
        )
        ta = self.ap.add(Arrow(f"a^t_{r4}", nn, key4, al * e, "tangential", f"⟂ {qn}{an_}"))
        self.absolute(self.ap, key4, f"a_{a4}", f"= a^n_{r4} + a^t_{r4}")
        self.ap.add(
            Arrow(f"a^k_{rs}", key4, kk, cor, "coriolis", f"= 2 ω{self.num[bar]} v_{rs}, ⟂ {joint}")
        )
        self.ap.add(Arrow(f"a^r_{rs}", kk, aA, arel * d, "sliding", f"∥ {joint}", along=arel))
        self.ka[bar] = (Q, accQ, al)
        self.ka[blk] = (A, accA, al)
        self.sliding.append((joint, vrel, arel))
        self.add_angular(bar, w, al, va, ta, float(np.hypot(*(A - Q))), qn + a4)

    def prp(self, x1: int, x2: int, s1: SliderConstraint, jm, s2: SliderConstraint) -> None:
        """Two bodies pinned together at M, each sliding on a known body."""
        mn, M = self.pin_point(jm)
        sides = []
        for x, sl in ((x1, s1), (x2, s2)):
            k = sl.a if sl.b == x else sl.b
            if k != self.nb:
                self.numbered.add(mn)
            sides.append((x, sl, k, 1.0 if sl.b == x else -1.0, self.line_dir(sl)))
        nodes = [self.vnode(k, mn, M) for _, _, k, _, _ in sides]
        (_, sa, ka, sga, da), (_, sb, kb, sgb, db) = sides
        va_, vb_ = self.vp.nodes[nodes[0]], self.vp.nodes[nodes[1]]
        r1, r2 = _intersect(va_, da, vb_, db, f"velocity of {mn}")
        mlab = self.label(mn, x1)
        self.alias[(mn, x2)] = mlab
        self.vp.nodes[mlab] = va_ + r1 * da
        self.where[mlab] = (x1, M)
        vsides, asides = [], []
        for (_, sl, k, _, _), nd in zip(sides, nodes):
            if k == self.nb:
                vsides.append(f"v_{mlab} (∥ {sl.name})")
                asides.append(f"a_{mlab} (∥ {sl.name})")
            else:
                vsides.append(f"v_{nd} + v_{mlab}{nd} (∥ {sl.name})")
                asides.append(f"a_{nd} + a^k_{mlab}{nd} + a^r_{mlab}{nd} (∥ {sl.name})")
        self.vp.equations.append(
            f"{mn} (PRP, sliders {sa.name} and {sb.name}): v_{mlab} = " + " = ".join(vsides)
        )
        rels = (r1, r2)
        accs = []
        for (x, sl, k, _, d), nd, vr in zip(sides, nodes, rels):
            g = k == self.nb
            self.vp.add(
                Arrow(
                    f"v_{mlab}" if g else f"v_{mlab}{nd}",
                    nd,
                    mlab,
                    vr * d,
                    "absolute" if g else "sliding",
                    f"∥ {sl.name}",
                    along=vr,
                )
            )
            self.kv[x] = (M, self.vp.nodes[mlab], self.kv[k][2])
            an_ = self.anode(k, mn, M)
            cor = 2 * _k_cross(self.kv[k][2], vr * d)
            accs.append((an_, self.ap.nodes[an_] + cor, cor, d))
        (_, ba, _, _), (_, bb, _, _) = accs
        q1, q2 = _intersect(ba, da, bb, db, f"acceleration of {mn}")
        key = mlab + "'"
        self.ap.nodes[key] = ba + q1 * da
        self.ap.equations.append(f"{mn}: a_{mlab} = " + " = ".join(asides))
        for side, (an_, base, cor, _), q, nd, vr in zip(sides, accs, (q1, q2), nodes, rels):
            x, sl, k, sg, d = side
            g = k == self.nb
            if g:
                self.ap.add(
                    Arrow(f"a_{mlab}", "p'", key, q * d, "absolute", f"∥ {sl.name}", along=q)
                )
            else:
                kk = f"k{self.num[x]}'"
                self.ap.nodes[kk] = base
                self.ap.add(Arrow(f"a^k_{mlab}{nd}", an_, kk, cor, "coriolis", f"⟂ {sl.name}"))
                self.ap.add(
                    Arrow(f"a^r_{mlab}{nd}", kk, key, q * d, "sliding", f"∥ {sl.name}", along=q)
                )
            self.ka[x] = (M, self.ap.nodes[key], self.ka[k][2])
            self.sliding.append((sl.name, sg * vr, sg * q))

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

    def text(self) -> str:
        mech = self.mechanism
        lines = [f"{mech.name}: velocity and acceleration polygons at {self.label}"]
        lines.append("  links: " + ", ".join(f"{n} {name}" for name, n in self.links.items()))
        lines.append(
            f"  scales: μl = {self.length_scale:g} m/mm, μv = {self.velocity.scale:g} (m/s)/mm, "
            f"μa = {self.acceleration.scale:g} (m/s^2)/mm"
        )
        for poly in (self.velocity, self.acceleration):
            unit = poly.unit
            lines.append(f"{poly.quantity} polygon (pole {poly.pole}), group by group:")
            for eq in poly.equations:
                lines.append(f"  {eq}")
            w = max([len(a.name) for a in poly.arrows] + [6])
            lines.append(
                f"  {'vector':<{w}}  {'drawn':<12}  {'length':>8}  {'value':>9}  direction"
            )
            lines.append(f"  {'':<{w}}  {'':<12}  {'[mm]':>8}  {'[' + unit + ']':>9}")
            for a in poly.arrows:
                val = f"{a.value:.4g}" if a.along is None else f"{a.along:+.4g}"
                lines.append(
                    f"  {a.name:<{w}}  {a.tail + ' -> ' + a.head:<12}  {poly.mm(a):8.1f}  "
                    f"{val:>9}  {a.note}"
                )
        lines.append(
            "angular velocities and accelerations of the links (ω = v_rel / l, "
            "α = a^t / l; + counter-clockwise):"
        )
        for ang, unit in [(a, "rad/s") for a in self.omegas] + [
            (a, "rad/s^2") for a in self.alphas
        ]:
            sense = "counter-clockwise" if ang.value > 0 else "clockwise" if ang.value else ""
            lines.append(
                f"  {ang.symbol} ({ang.link}) = {ang.formula} = {ang.num:.4g} / "
                f"{ang.length:.4g} m = {ang.value:+.4g} {unit} {sense}".rstrip()
            )
        c = self.check
        lines.append(
            "check against mechsolve's analytic solution (largest differences): "
            f"velocities {c['velocity']:.2g} m/s ({c['velocity'] / self.velocity.scale:.2g} mm "
            f"on the drawing), accelerations {c['acceleration']:.2g} m/s^2 "
            f"({c['acceleration'] / self.acceleration.scale:.2g} mm), "
            f"ω {c['omega']:.2g} rad/s, α {c['alpha']:.2g} rad/s^2"
        )
        return "\n".join(lines)


_INDEX = re.compile(r"\s*(?:position\s*)?#?\s*(\d+)\s*")


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
    try:
        val = parse_quantity(text, kind)
    except UnitError:
        try:
            t = parse_quantity(text, "time")
        except UnitError:
            raise InputError(
                f"{where} {text!r}: expected a position number (1 to {per_turn}), a driver "
                f"{'position such as 20 mm' if an.linear else 'angle such as 196.8 deg'}, or "
                "a time from the start such as 0.5 s"
            ) from None
        u = u0 + d.speed * t
        return Instant(u, d.speed, 0.0, f"t = {t:g} s from the start ({an.format_u(u)})")
    if not re.search(r"[A-Za-z°]", text):
        raise InputError(
            f"{where} {text!r}: give the {kind} with its unit ('{text} "
            f"{'mm' if an.linear else 'deg'}'); a bare whole number is a position number"
        )
    if an.linear:
        u = val
    else:  # the same angle reached from the start along the driver's direction
        u = u0 + d.direction * ((d.direction * (val - u0)) % (2 * math.pi))
    return Instant(u, d.speed, 0.0, an.format_u(u))


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
    if not mech.__dict__.get("_validated"):
        mech.validate()
    for name, val in (("--scale-v", scale_v), ("--scale-a", scale_a)):
        if val is not None and not (val > 0 and math.isfinite(val)):
            raise InputError(f"{name} {val!r}: a scale is a positive number of units per mm")
    if isinstance(mech.joint(mech.driver.joint), SliderJoint):
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
