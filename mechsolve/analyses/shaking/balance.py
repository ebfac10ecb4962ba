"""Balancing the shaking force: counterweights for a four-bar and a slider-crank.

Four-bar (the linearly independent vectors method, Berkof and Lowen): with the link
vectors in complex numbers, each link's pin-to-pin vector ``d_k e^{i theta_k}`` and its
centre of mass ``g_k e^{i theta_k}`` from its first pin (``d_k``, ``g_k``: complex, in
the link's own frame), the loop ``d2 e^{i th2} + d3 e^{i th3} - d4 e^{i th4} = const``
eliminates the coupler's ``e^{i th3}`` from the total first moment of mass::

    M r_G = const + e^{i th2} (m2 g2 + m3 d2 (1 - g3/d3)) + e^{i th4} (m4 g4 + m3 g3 d4/d3)

``e^{i th2}`` and ``e^{i th4}`` are linearly independent over the motion, so the centre
of mass is stationary (the shaking force zero at every speed) if and only if both
brackets vanish. The coupler's mass is thereby redistributed to its pins:
``m3 (1 - g3/d3)`` at A and ``m3 g3/d3`` at B (complex when its centre is off the line
AB), and the counterweights on the crank and the rocker, about their ground pivots, are
the mass-radius products ``U2 = -(m2 g2 + m3 d2 (1 - g3/d3))`` and
``U4 = -(m4 g4 + m3 g3 d4/d3)``.

Slider-crank (partial balancing): the rod's mass is split statically between its pins,
``m3 (1 - g3/d3)`` at the crank pin (rotating) and ``m3 g3/d3`` at the piston
(reciprocating, with the block's mass: ``m_rec``). The counterweight balances the
rotating mass fully and a fraction ``c`` of the reciprocating mass, opposite the crank
pin: ``U2 = -(m2 g2 + m3 (1 - g3/d3) d2) - c m_rec d2``. For an in-line slider-crank
turning at a constant speed the residual shaking force on the frame is, along the
stroke, ``(1 - c) m_rec r w^2 cos th`` (primary) ``+ m_rec r w^2 (r/l) cos 2th``
(secondary, the first term of a series), and across it ``-c m_rec r w^2 sin th``, with
``th`` the crank angle from the line of stroke.

A counterweight is a point mass at ``radius`` from its pivot (its own inertia about its
centre is neglected): its mass is ``|U| / radius``. It is written back into the file as
a named point of its link with a ``point_masses`` entry, so that the balanced file runs.
"""

from __future__ import annotations

import cmath
import copy
import math
from dataclasses import dataclass, field

import numpy as np

from mechsolve.base.errors import InputError
from mechsolve.base.units import SI_OUTPUT, OutputUnits, parse_quantity
from mechsolve.model import GROUND, Mechanism


@dataclass
class Counterweight:
    """A counterweight on a link, about the link's ground pivot.

    ``mr``: its mass-radius product (kg m); ``angle``: its direction from the pivot,
    counter-clockwise from the line pivot -> the link's other pin (rad); ``radius`` (m)
    and ``mass`` (kg); ``local``: its position in the link's frame (m); ``point``: the
    name it has in the balanced file."""

    link: str
    pivot: str
    towards: str
    mr: float
    angle: float
    radius: float
    mass: float
    local: np.ndarray
    point: str


@dataclass
class Linkage:
    """The links and pins of a four-bar (``rocker`` and ``O4``) or a slider-crank
    (``rocker`` None, ``block`` and the piston pin ``B``)."""

    crank: str
    coupler: str
    O2: str
    A: str
    B: str
    rocker: str | None = None
    O4: str | None = None
    block: str | None = None

    @property
    def kind(self) -> str:
        return "four-bar" if self.rocker is not None else "slider-crank"


@dataclass
class Balance:
    """Counterweights and what they leave."""

    linkage: Linkage
    counterweights: list[Counterweight]
    shares: dict[str, complex]  # the coupler's (rod's) mass at its pins (kg, complex)
    fraction: float | None = None  # c, for a slider-crank
    m_rec: float = math.nan  # the reciprocating mass (kg)
    crank_length: float = math.nan  # r (m)
    rod_length: float = math.nan  # l (m)
    inline: bool = False  # an in-line slider-crank with the rod's centre on its line
    notes: list[str] = field(default_factory=list)
    method: str = "exact"  # "rms": least squares over the turn (see least_squares)
    rms_fraction: complex | None = None  # a slider-crank's equivalent c (rms)

    def lines(self, units: OutputUnits | None = None) -> list[str]:
        """The counterweights and the mass distribution, with units: lengths in
        ``units`` (default SI: m)."""
        k_len, L = (units or SI_OUTPUT).convert("m")
        lk = self.linkage
        out = [f"balancing ({lk.kind}):"]
        pins = (lk.A, lk.B)
        rod = "coupler" if lk.kind == "four-bar" else "rod"
        for pin, m in zip(pins, self.shares.values()):
            ang = math.degrees(cmath.phase(m)) if abs(m) > 0 else 0.0
            out.append(
                f"  {rod} {lk.coupler!r} mass at {pin}: {abs(m):.6g} kg"
                + (f" at {ang:.6g} deg from {lk.A}->{lk.B}" if abs(ang) > 1e-9 else "")
            )
        if self.method == "rms":
            out.append(
                "  counterweights that minimise the RMS shaking force over the turn "
                "(least squares over the samples, trapezoidal weights)"
            )
        if self.fraction is not None:
            out.append(
                f"  reciprocating mass m_rec = {self.m_rec:.6g} kg, balanced fraction "
                f"c = {self.fraction:.6g}"
                + (" (the least-squares counterweight's share)" if self.method == "rms" else "")
            )
        if self.rms_fraction is not None and abs(self.rms_fraction.imag) > 1e-9:
            out.append(
                f"  the least-squares counterweight also leans {self.rms_fraction.imag:.6g} "
                "m_rec d2 across the crank (an offset or an off-line centre of mass)"
            )
        for cw in self.counterweights:
            out.append(
                f"  counterweight on {cw.link!r} about {cw.pivot}: m*r = {cw.mr * k_len:.6g} "
                f"kg*{L} at {math.degrees(cw.angle):.6g} deg from {cw.pivot}->{cw.towards}; "
                f"{cw.mass:.6g} kg at r = {cw.radius * k_len:.6g} {L} (point {cw.point})"
            )
        return out + [f"  note: {n}" for n in self.notes]

    def textbook(self, omega: float | None, units: OutputUnits | None = None) -> list[str]:
        """The slider-crank's residual by the textbook formulas (in-line only), in
        ``units`` (default SI: rad/s, N)."""
        if self.fraction is None or not omega:
            return []
        if not self.inline:
            return [
                "  textbook residual formulas not shown: they hold for an in-line slider-"
                "crank with the rod's centre of mass on its pin line"
            ]
        c, m, r = self.fraction, self.m_rec, self.crank_length
        lam = r / self.rod_length
        a = m * r * omega * omega
        u = units or SI_OUTPUT
        kw, uw = u.convert("rad/s")
        kf, uf = u.convert("N")
        return [
            f"  textbook residual at {omega * kw:.6g} {uw}: along the stroke, primary "
            f"(1 - c) m_rec r w^2 = {(1 - c) * a * kf:.6g} {uf} (x cos th), secondary "
            f"m_rec r w^2 r/l = {a * lam * kf:.6g} {uf} (x cos 2th, first term of a series); "
            f"across it c m_rec r w^2 = {c * a * kf:.6g} {uf} (x sin th)"
        ]


def _z(v) -> complex:
    return complex(float(v[0]), float(v[1]))


def _mass(mech: Mechanism, link: str) -> tuple[float, complex]:
    lk = mech.link(link)
    m = 0.0 if lk.mass is None else float(lk.mass)
    com = (0.0, 0.0) if lk.com is None else lk.com
    return m, _z(com)


def find_linkage(mech: Mechanism) -> Linkage:
    """The four-bar or slider-crank in ``mech``: three moving links, the driven one a
    crank pinned to the frame; four pins (a four-bar) or three pins and a slider on a
    fixed guide (a slider-crank)."""

    def no(why: str) -> InputError:
        return mech.error(
            ("joints",),
            "balancing needs a four-bar or a slider-crank driven by its crank: " + why,
        )

    if len(mech.links) != 3:
        raise no(f"this mechanism has {len(mech.links)} moving links, not 3")
    drv = mech.joint(mech.driver.joint)
    if GROUND not in drv.links or drv.coordinate != "angle":
        raise no(f"the driver's joint {drv.name!r} is not a pivot on the frame")
    crank = drv.links[1] if drv.links[0] == GROUND else drv.links[0]
    pins = [j for j in mech.joints if j.letter == "R"]
    others = [j for j in mech.joints if j.letter != "R"]

    def between(a: str, b: str):
        return next((j for j in pins if set(j.links) == {a, b}), None)

    rest = [ln for ln in mech.link_names if ln != crank]
    if len(pins) == 4 and not others:
        grounded = [j for j in pins if GROUND in j.links and j is not drv]
        if len(grounded) != 1:
            raise no("a four-bar has two pivots on the frame")
        o4 = grounded[0]
        rocker = o4.links[1] if o4.links[0] == GROUND else o4.links[0]
        coupler = next(ln for ln in rest if ln != rocker)
        a, b = between(crank, coupler), between(coupler, rocker)
        if a is None or b is None or rocker == crank:
            raise no("its links are not joined crank - coupler - rocker")
        return Linkage(crank, coupler, drv.point, a.point, b.point, rocker, o4.point)
    if len(pins) == 3 and len(others) == 1 and others[0].roles == ("guide", "block"):
        sl = others[0]
        if sl.links[0] != GROUND:
            raise no(f"the slider {sl.name!r} does not run on a guide fixed to the frame")
        block = sl.links[1]
        rod = next((ln for ln in rest if ln != block), None)
        a, b = between(crank, rod), between(rod, block)
        if rod is None or a is None or b is None:
            raise no("its links are not joined crank - rod - block")
        return Linkage(crank, rod, drv.point, a.point, b.point, block=block)
    raise no("its joints are not four pins, or three pins and a slider")


def balance(
    mech: Mechanism,
    *,
    fraction: float | None = None,
    radius: dict[str, float] | None = None,
) -> Balance:
    """The counterweights that make a four-bar's centre of mass stationary, or balance a
    slider-crank's rotating mass and the fraction ``fraction`` of its reciprocating mass.

    ``radius``: the counterweight's radius on a link (m), default the link's length
    between its pins."""
    lk = find_linkage(mech)
    radius = dict(radius or {})
    targets = [lk.crank] + ([lk.rocker] if lk.rocker else [])
    for name in radius:
        if name == GROUND:
            raise InputError(
                "--radius: the frame (ground) cannot carry a counterweight; the "
                f"counterweights go on {', '.join(repr(t) for t in targets)}"
            )
        if name not in targets:
            raise InputError(
                f"--radius: no counterweight goes on {name!r}; the {lk.kind}'s "
                f"counterweights go on {', '.join(repr(t) for t in targets)}"
            )
        if not radius[name] > 0:
            raise InputError(f"--radius {name}: the radius must be positive")
    if lk.kind == "four-bar" and fraction is not None:
        raise InputError("--fraction is for a slider-crank's reciprocating mass, not a four-bar")
    if fraction is not None and not 0.0 <= fraction <= 1.0:
        raise InputError(f"--fraction {fraction:g}: the fraction c must be in [0, 1]")

    links = [lk.crank, lk.coupler, lk.rocker or lk.block]
    if not any(_mass(mech, ln)[0] for ln in links):
        raise mech.error(("links",), "balancing: the links have no mass, nothing shakes")

    def lp(link: str, point: str) -> complex:
        return _z(mech.local_point(link, point))

    m2, c2 = _mass(mech, lk.crank)
    m3, c3 = _mass(mech, lk.coupler)
    d2 = lp(lk.crank, lk.A) - lp(lk.crank, lk.O2)
    g2 = c2 - lp(lk.crank, lk.O2)
    d3 = lp(lk.coupler, lk.B) - lp(lk.coupler, lk.A)
    g3 = c3 - lp(lk.coupler, lk.A)
    if abs(d2) == 0 or abs(d3) == 0:
        raise mech.error(("links",), "balancing: a link's two pins coincide")
    rho = g3 / d3
    shares = {lk.A: m3 * (1 - rho), lk.B: m3 * rho}
    out = Balance(lk, [], shares)
    if lk.kind == "four-bar":
        m4, c4 = _mass(mech, lk.rocker)
        d4 = lp(lk.rocker, lk.B) - lp(lk.rocker, lk.O4)
        g4 = c4 - lp(lk.rocker, lk.O4)
        u2 = -(m2 * g2 + m3 * d2 * (1 - rho))
        u4 = -(m4 * g4 + m3 * rho * d4)
        out.counterweights = [
            _weight(mech, lk.crank, lk.O2, lk.A, u2, d2, radius),
            _weight(mech, lk.rocker, lk.O4, lk.B, u4, d4, radius),
        ]
    else:
        c = 0.5 if fraction is None else fraction
        mb, _ = _mass(mech, lk.block)
        m_rec = mb + m3 * rho.real
        u2 = -(m2 * g2 + m3 * (1 - rho) * d2) - c * m_rec * d2
        out.counterweights = [_weight(mech, lk.crank, lk.O2, lk.A, u2, d2, radius)]
        out.fraction, out.m_rec = c, m_rec
        out.crank_length, out.rod_length = abs(d2), abs(d3)
        out.inline = abs(rho.imag) < 1e-12  # and no offset: see inline()
        if abs(rho.imag) > 1e-12:
            out.notes.append(
                "the rod's centre of mass is off its pin line: its share at the piston is "
                "not a mass on the line of stroke, and that part is left unbalanced"
            )
    return out


def least_squares(mech: Mechanism, bal: Balance, before, radius: dict | None) -> Balance:
    """The counterweights that minimise the RMS of the shaking force over the turn: on the
    crank of a slider-crank (complete balancing is impossible there), on the crank and
    the rocker of a four-bar (then the complete balance, to rounding).

    A counterweight of mass-radius product ``U`` (complex, in its link's frame, from its
    ground pivot) adds ``-(i alpha - w^2) e^{i theta} U`` to the force on the frame (its
    link's angle, speed and acceleration at each sample), linear in ``U``; the ``U`` of
    least ``sum_k w_k |F_k + sum_l A_kl U_l|^2`` (``F``: the shaking ``before``, inertia
    forces only; ``w_k`` the trapezoidal weights in the driver's coordinate over the
    turn) is a linear least-squares problem. For a slider-crank its share of the
    reciprocating mass, ``c = (U_rot - U) / (m_rec d2)``, is reported (1/2 for an in-line
    one at constant speed: the classic optimum)."""
    res = before.results
    if not (np.all(before.ok) and res.is_full_cycle() and len(res.u) > 2):
        raise mech.error(
            ("sweep",), "least-squares balancing needs the shaking over a full turn, solved"
        )
    lk = bal.linkage
    links = [(lk.crank, lk.O2, lk.A)] + ([(lk.rocker, lk.O4, lk.B)] if lk.rocker else [])
    st, index = res.solution.state, res.analysis.system.index
    du = np.diff(res.u)
    w = np.zeros(len(res.u))
    w[:-1] += du / 2
    w[1:] += du / 2
    sw = np.sqrt(np.abs(w))
    cols = []
    for link, _, _ in links:
        b = index[link]
        a = -(1j * st.al[b] - st.w[b] ** 2) * np.exp(1j * st.th[b])  # per unit U
        cols += [a, 1j * a]  # Re U and Im U
    A = np.stack(cols, axis=1)  # (n, 2 links)
    F = before.fx + 1j * before.fy
    M = np.concatenate([(A * sw[:, None]).real, (A * sw[:, None]).imag])
    rhs = -np.concatenate([(F * sw).real, (F * sw).imag])
    x = np.linalg.lstsq(M, rhs, rcond=None)[0]
    us = [complex(x[2 * k], x[2 * k + 1]) for k in range(len(links))]
    radius = dict(radius or {})
    out = copy.copy(bal)
    out.method = "rms"
    out.counterweights = []
    for (link, pivot, towards), u in zip(links, us):
        d = _z(mech.local_point(link, towards)) - _z(mech.local_point(link, pivot))
        out.counterweights.append(_weight(mech, link, pivot, towards, u, d, radius))
    if lk.rocker is None:
        m2, c2 = _mass(mech, lk.crank)
        d2 = _z(mech.local_point(lk.crank, lk.A)) - _z(mech.local_point(lk.crank, lk.O2))
        g2 = c2 - _z(mech.local_point(lk.crank, lk.O2))
        u_rot = -(m2 * g2 + bal.shares[lk.A] * d2)
        c = (u_rot - us[0]) / (bal.m_rec * d2) if bal.m_rec > 0 else complex("nan")
        out.rms_fraction = c
        out.fraction = c.real
    return out


def inline(res, lk: Linkage) -> bool:
    """Whether the piston pin's path (from a solved sweep ``res``) is a line through the
    crank's pivot: an in-line slider-crank."""
    p = res.point(lk.B)
    o = res.mechanism.ground[lk.O2]
    ok = np.isfinite(p.x) & np.isfinite(p.y)
    if np.sum(ok) < 2:
        return False
    x, y = p.x[ok], p.y[ok]
    i, j = int(np.argmin(x + y)), int(np.argmax(x + y))
    ex, ey = x[j] - x[i], y[j] - y[i]
    n = math.hypot(ex, ey)
    if n == 0:
        return False
    dist = abs((o[0] - x[i]) * ey - (o[1] - y[i]) * ex) / n
    return dist <= 1e-9 * n


def _weight(mech, link, pivot, towards, u: complex, d: complex, radius) -> Counterweight:
    r = radius.get(link, abs(d))
    mr = abs(u)
    direction = u / mr if mr > 0 else d / abs(d)
    local = mech.local_point(link, pivot) + r * np.array([direction.real, direction.imag])
    ang = cmath.phase(direction / d)
    return Counterweight(link, pivot, towards, mr, ang, r, mr / r, local, f"CW_{link}")


def balanced_data(mech: Mechanism, bal: Balance) -> dict:
    """The file's data with the counterweights added: a point ``CW_<link>`` (in the
    file's length unit) and a ``point_masses`` entry on each balanced link."""
    if mech.source is None or not isinstance(mech.source.data, dict):
        raise InputError("balancing writes the balanced file: the mechanism needs its file")
    data = copy.deepcopy(mech.source.data)
    scale = parse_quantity(f"1 {mech.length_unit}", "length")
    for cw in bal.counterweights:
        link = data["links"][cw.link]
        pts = link.setdefault("points", {})
        if cw.point in pts:
            raise InputError(f"link {cw.link!r} already has a point {cw.point!r}")
        pts[cw.point] = [float(cw.local[0] / scale), float(cw.local[1] / scale)]
        pm = link.setdefault("point_masses", {})
        pm[cw.point] = f"{float(cw.mass)!r} kg"  # a numpy scalar's repr is not a number
    return data
