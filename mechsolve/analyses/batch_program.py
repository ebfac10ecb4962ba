"""A narrower program for a design batch whose plan is a driver link and closed-form dyads.

:func:`mechsolve.analyses.batch.solve_designs` runs the general group solvers over one
column per position of each design: every design's numbers spread over its columns, every
body's full state written for every column. When the plan is a crank on the ground turned
by the driver followed by RRR dyads (the four-bar, and chains of RRR dyads on it), and
no force analysis is asked for, the pass runs this program instead:

* the designs' numbers are columns ``(D, 1)``, the driver's positions a row ``(1, P)``:
  every formula broadcasts to ``(D, P)`` (the crank's angle, cosine and sine are one row
  for every design, a ground point one column);
* each quantity of a body is kept in the smallest shape that holds it (a float, a row, a
  column or ``(D, P)``), not spread over a state of ``(11, bodies, D P)``; a design's
  state is written from them when its results are asked for (:meth:`Program.state`);
* the screening of the general pass (indicator at least ``sin 5 deg``, the discriminant
  clear of zero at and between the samples) reads the dyad's own terms, reduced per
  design; a design that passes it closes at every position, so no per-column flag of
  closure is kept.

The formulas, and the order of their operations, are those of
:class:`mechsolve.groups.closed.DriverLink` and :class:`mechsolve.groups.closed.RRR`:
the states, rates and indicators are those of the general pass.
"""

from __future__ import annotations

import numpy as np

from mechsolve.base.state import State
from mechsolve.groups import Group
from mechsolve.groups.closed import RRR, DriverLink

__all__ = ["Program", "Programs", "plan_program", "run_program"]

NAMES = ("x", "y", "th", "c", "s", "vx", "vy", "w")  # what the program writes per body
ACCELERATIONS = ("ax", "ay", "al")  # and with accelerations


def _zero(v) -> bool:
    return isinstance(v, float) and v == 0.0


def _mul(a, b):
    """``a b`` where either may be a float zero (then 0.0: the term is dropped) or one
    (then the other, not a copy: the program writes in place only what it made)."""
    if _zero(a) or _zero(b):
        return 0.0
    if isinstance(a, float) and a == 1.0:
        return b
    if isinstance(b, float) and b == 1.0:
        return a
    return a * b


def _add(a, b):
    if _zero(b):
        return a
    if _zero(a):
        return b
    return a + b


def _sub(a, b):
    if _zero(b):
        return a
    if _zero(a):
        return -b
    return a - b


def plan_program(plan: list[Group], ground: int) -> bool:
    """Whether the program takes this plan: a crank on the ground whose angle the driver
    sets from the ground, then RRR dyads only."""
    if len(plan) < 2 or not isinstance(plan[0], DriverLink):
        return False
    g = plan[0]
    d = g.drv
    if g.k != ground or (d.a if d.b == g.b else d.b) != ground:
        return False
    if np.ndim(d.delta) != 0:
        return False
    return all(isinstance(x, RRR) for x in plan[1:])


class _Numbers:
    """A stacked number of the start's analysis (``2 D`` columns: branch + of each design,
    then branch -) as the program reads it for the designs ``lo`` to ``hi`` of a block:
    a float when the same in all of them, else their values as a column ``(hi - lo, 1)``.

    Each number is read from the analysis once per pass (:meth:`_of`): its ``D`` values,
    and where they change from one design to the next, so that a block's float or column
    is an index and a slice, not a test over the block's designs."""

    def __init__(self, nd: int) -> None:
        self.nd = nd
        self.lo, self.hi = 0, nd
        self._seen: dict = {}  # (id, row) -> (the object, values, changes so far)
        self.made: dict = {}  # what the pass derives from its numbers once

    def block(self, lo: int, hi: int) -> _Numbers:
        self.lo, self.hi = lo, hi
        return self

    def _of(self, v, i: int | None = None):
        got = self._seen.get((id(v), i))
        if got is None or got[0] is not v:
            w = v if i is None else v[i]
            if np.ndim(w) == 0:
                got = (v, float(w), None)
            else:
                a = np.asarray(w)[: self.nd]
                # changes[k]: how many designs before k differ from their predecessor (a
                # NaN differs from everything, itself included)
                changes = np.r_[0, np.cumsum(~(a[1:] == a[:-1]))]
                got = (v, a, changes)
            self._seen[id(v), i] = got
        return got[1], got[2]

    def _read(self, a, changes):
        if changes is None:
            return a
        lo, hi = self.lo, self.hi
        first = a[lo]
        if changes[hi - 1] == changes[lo] and first == first:  # one value, not a NaN
            return float(first)
        return a[lo:hi].reshape(-1, 1)

    def one(self, v):
        return self._read(*self._of(v))

    def pair(self, s):
        if np.ndim(s) == 1:  # the same in every design
            return float(s[0]), float(s[1])
        return self._read(*self._of(s, 0)), self._read(*self._of(s, 1))


class Program:
    """What the program keeps of a pass: per body, each quantity of :data:`NAMES` in its
    smallest shape (see the module docstring), per group its indicator, and the designs'
    rows. The design in row ``j`` is written into a state by :meth:`state`; a dyad's
    indicator is kept as its discriminant ``H`` (:meth:`indicator`)."""

    def __init__(self, nb: int, nd: int, P: int, acceleration: bool = False) -> None:
        self.nb, self.nd, self.P = nb, nd, P
        self.names = NAMES + ACCELERATIONS if acceleration else NAMES
        self.bodies: dict[int, dict] = {
            nb: dict.fromkeys(self.names, 0.0) | {"c": 1.0}  # the ground
        }
        self.indicators: list = []
        self.risky = np.zeros(nd, bool)
        self.hmin: list = []  # per dyad, each design's smallest H (see run_program)
        self.full = (nd, P)  # the shape of a quantity that varies with design and position
        self._tmp: np.ndarray | None = None
        self.crank: tuple | None = None  # the driven crank (see _dH_bound)
        self._negated: dict = {}  # id(-x) -> (-x, x)
        self.made: dict = {}  # arrays the block's groups share (see _zeros)

    def tmp(self) -> np.ndarray:
        """A scratch array of the block's size for a term that is used once: reused, so
        that it stays in the cache (one, not one per term)."""
        if self._tmp is None:
            self._tmp = np.empty(self.full)
        return self._tmp

    def neg(self, x):
        """``-x``, made once per array: the negation of an array this negated is its
        original, and an array negated twice gives the same negation (the same bits: a
        negation flips the sign bit only). Neither is written in place afterwards."""
        if isinstance(x, float):
            return -x
        got = self._negated.get(id(x))
        if got is not None and got[0] is x:
            return got[1]
        out = -x
        self._negated[id(out)] = (out, x)
        self._negated[id(x)] = (x, out)
        return out

    def sub(self, a, b):
        """:func:`_sub` with :meth:`neg` for ``0 - b``."""
        return self.neg(b) if _zero(a) else _sub(a, b)

    def _rot(self, b: int, s):
        """Global components of the local vector ``s = (s0, s1)`` on body ``b``."""
        q = self.bodies[b]
        c, sn = q["c"], q["s"]
        s0, s1 = s
        return _sub(_mul(c, s0), _mul(sn, s1)), _add(_mul(sn, s0), _mul(c, s1))

    def _point(self, b: int, s):
        q = self.bodies[b]
        rx, ry = self._rot(b, s)
        return _add(q["x"], rx), _add(q["y"], ry), rx, ry

    def _acceleration(self, b: int, rx, ry):
        """Acceleration of the point of body ``b`` at the arm ``(rx, ry)``."""
        q = self.bodies[b]
        al, w = q["al"], q["w"]
        w2 = _mul(w, w)
        ax = _sub(_sub(q["ax"], _mul(al, ry)), _mul(w2, rx))
        return ax, _sub(_add(q["ay"], _mul(al, rx)), _mul(w2, ry))

    def _velocity(self, b: int, rx, ry):
        """Velocity of the point of body ``b`` at the arm ``(rx, ry)`` from its frame."""
        q = self.bodies[b]
        w = q["w"]
        return self.sub(q["vx"], _mul(w, ry)), _add(q["vy"], _mul(w, rx))

    def state(self, j: int) -> State:
        """The state of the design in row ``j`` over the sweep (rates per unit time)."""
        st = State(self.nb, self.P)
        for b, q in self.bodies.items():
            if b == self.nb:
                continue
            for name in self.names:
                v = q[name]
                if isinstance(v, float):
                    if v:
                        getattr(st, name)[b] = v
                else:
                    getattr(st, name)[b] = v[j if v.shape[0] > 1 else 0]
        return st

    def indicator(self, j: int) -> np.ndarray:
        """The groups' singularity indicators of the design in row ``j``, (groups, P)."""
        out = np.ones((len(self.indicators), self.P))
        for row, H in zip(out, self.indicators):
            if H is not None:  # sin of the angle at M (H > 0 in every kept design)
                np.minimum(H[j], 1.0, out=row)
                np.sqrt(row, out=row)
        return out


def _crank_turn(g: DriverLink, u: np.ndarray) -> tuple:
    """The crank's angle, cosine and sine, each one row ``(1, P)`` for every design of
    a pass (its blocks share them: none is written in place), and its rate per unit of
    the driver coordinate."""
    d = g.drv
    sign, off = (1.0, -d.delta) if d.b == g.b else (-1.0, d.delta)
    th = np.multiply(u, sign)
    if off:
        th += off
    th = th.reshape(1, -1)
    return th, np.cos(th), np.sin(th), sign


def _driver_link(prog: Program, g: DriverLink, num: _Numbers, turn: tuple) -> None:
    """The crank: its angle, cosine and sine one row for every design (``turn``,
    :func:`_crank_turn`)."""
    th, c, s, sign = turn
    q = {"th": th, "c": c, "s": s, "w": sign}  # w: per unit of the driver coordinate
    prog.bodies[g.b] = q
    px, py = num.pair(g.sk)  # the pivot, on the ground
    prog.crank = (g, sign)  # for the dyads' screening bound (_dH_bound)
    rx, ry = prog._rot(g.b, num.pair(g.sp))
    q["x"], q["y"] = _sub(px, rx), _sub(py, ry)
    # body_velocity_from_point: the pivot is at rest, v = w k x (frame - pivot)
    q["vx"], q["vy"] = _mul(sign, ry), _sub(0.0, _mul(sign, rx))
    if "al" in prog.names:  # the driver's acceleration is zero per unit of its coordinate
        q["al"] = 0.0
        q["ax"], q["ay"] = _mul(1.0, rx), _mul(1.0, ry)  # w^2 (frame - pivot), w^2 = 1


def _place(q: dict, s0, sm, px, py, gx, gy) -> None:
    """``set_pose_from_vectors``: the body's local vector ``sm - s0`` lies along
    ``(gx, gy)`` and its point ``s0`` at ``(px, py)``."""
    ex, ey = _sub(sm[0], s0[0]), _sub(sm[1], s0[1])
    if _zero(ey) and isinstance(ex, float):
        l2 = ex * ex
        c, s = np.multiply(gx, ex / l2), np.multiply(gy, ex / l2)
    elif _zero(ey):  # x along the segment in every design, lengths that differ
        l2 = ex * ex
        if np.shape(gx) == np.shape(gy) and np.ndim(gx) == 2 and np.shape(ex)[0] > 1:
            # each column read by two products of the block's shape: written out once
            exf, l2f = _spread(ex, gx.shape), _spread(l2, gx.shape)
            c = np.multiply(exf, gx)
            c /= l2f
            s = np.multiply(exf, gy, out=exf)
            s /= l2f
        else:
            c = np.multiply(ex, gx)
            c /= l2
            s = np.multiply(ex, gy)
            s /= l2
    else:
        l2 = _add(ex * ex, ey * ey)
        c = (ex * gx + ey * gy) / l2
        s = (ex * gy - ey * gx) / l2
    q["c"], q["s"], q["th"] = c, s, np.arctan2(s, c)
    q["x"] = _sub(px, _sub(_mul(c, s0[0]), _mul(s, s0[1])))
    q["y"] = _sub(py, _add(_mul(s, s0[0]), _mul(c, s0[1])))


def _zeros(prog: Program) -> np.ndarray:
    """Zeros of the block's shape (read only; one array for every block of a pass,
    :func:`run_program`)."""
    z = prog.made.get("zeros")
    if z is None or z.shape != prog.full:
        z = prog.made["zeros"] = np.zeros(prog.full)
        z.flags.writeable = False
    return z


def _times(a, b, out: np.ndarray):
    """``a * b``, written into ``out`` when the product has its shape."""
    if np.shape(a) == out.shape or np.shape(b) == out.shape:
        return np.multiply(a, b, out=out)
    return a * b


def _spread(col, shape: tuple, out: np.ndarray | None = None) -> np.ndarray:
    """A column of the designs' numbers ``(D, 1)`` written out to the block's ``shape``:
    an operation of a column with an array of the block's shape runs row by row (some
    60 ns a row over a plain one's single loop), so a column read by two of them is
    written out once and read as a plain array (the same numbers, the same products)."""
    out = np.empty(shape) if out is None else out
    np.copyto(out, col)
    return out


def _lengths(num: _Numbers, g: RRR) -> tuple:
    """The dyad's terms of its lengths alone, as :meth:`RRR._triangle` and the screening
    form them: ``L1^2``, ``L2^2``, ``L1^2 - L2^2``, ``(L1^2 - L2^2) 0.5``,
    ``1 / (L1^2 L2^2)`` and ``L1^2 + L2^2``. Made once per pass over every design (the
    same operations per design), each read per block as its numbers are (a float where
    the block's designs share it, else a column)."""
    key = ("lengths", id(g))
    got = num.made.get(key)
    if got is None or got[0] is not g:
        lo, hi = num.lo, num.hi
        num.block(0, num.nd)
        L1, L2 = num.one(g.L1), num.one(g.L2)
        L1s, L2s = L1 * L1, L2 * L2
        d = L1s - L2s
        terms = (L1s, L2s, d, np.multiply(d, 0.5), 1.0 / (L1s * L2s), L1s + L2s)
        got = num.made[key] = (g, [t if np.ndim(t) == 0 else np.ravel(t) for t in terms])
        num.block(lo, hi)
    return tuple(num.one(t) for t in got[1])


def _triangle(lengths: tuple, D2, tmp: np.ndarray):
    """The RRR's triangle (:meth:`RRR._triangle`, the same operations): M's distance
    along P -> Q as a fraction of |PQ|, its squared height over |PQ|^2, and ``H``
    (``lengths`` from :func:`_lengths`; ``D2`` has the block's full shape; ``tmp`` is
    scratch)."""
    L1s, _, diff, half, k, _ = lengths
    inv = 1.0 / D2
    a = np.multiply(half, inv)  # (half is the pass's, read only)
    a += 0.5
    # L1^2 per design, read by two products of the block's shape: written out once
    L1f = _spread(L1s, D2.shape) if np.ndim(L1s) and np.shape(L1s)[0] > 1 else L1s
    h2 = np.multiply(L1f, inv, out=inv)  # (1 / D2 is read no more)
    h2 -= np.multiply(a, a, out=tmp)
    t = np.add(diff, D2)
    t *= 0.5
    t *= t
    H = np.multiply(L1f, D2, out=L1f if L1f is not L1s else None)
    H -= t
    H *= k
    return a, h2, H, t


def _rrr(prog: Program, g: RRR, num: _Numbers, mode, h: float) -> None:
    """One RRR dyad over every design and position, screened as the general pass does.
    The operations and their order are the general dyad's; a term used once is formed
    in a scratch array and a temporary that is read no more holds the next result."""
    P = prog.P
    px, py, rpx, rpy = prog._point(g.k1, num.pair(g.sPk))
    qx, qy, rqx, rqy = prog._point(g.k2, num.pair(g.sQk))
    vpx, vpy = prog._velocity(g.k1, rpx, rpy)
    vqx, vqy = prog._velocity(g.k2, rqx, rqy)
    dx, dy = prog.sub(qx, px), prog.sub(qy, py)
    if np.shape(dx) == prog.full and np.shape(dy) == prog.full:
        D2 = dx * dx
        D2 += np.multiply(dy, dy, out=prog.tmp())
    else:
        D2 = dx * dx + dy * dy
        if D2.shape != prog.full:  # P and Q move alike in every design of the block:
            D2 = np.broadcast_to(D2, prog.full).copy()  # the terms after it are in place
    lengths = _lengths(num, g)
    tmp = prog.tmp()
    a, h2, H, t = _triangle(lengths, D2, tmp)
    Hmin = H.min(axis=1)  # (for the screening: read while H is still in the cache)
    # (against an array of zeros: numpy's maximum with a float runs some 1.7 times as long)
    hh = np.maximum(h2, _zeros(prog), out=h2)
    np.sqrt(hh, out=hh)
    if not (isinstance(mode, float) and mode == 1.0):  # (x * 1.0 is x)
        hh *= mode
    g1x = _times(a, dx, t)  # (t is read no more)
    g1x -= _times(hh, dy, tmp)
    g1y = np.multiply(a, dy, out=a)  # (a is read no more)
    g1y += _times(hh, dx, tmp)
    del a, h2, t
    g2x = np.subtract(g1x, dx, out=hh)  # (hh is read no more)
    g2y = g1y - dy
    del hh
    q1, q2 = {}, {}
    prog.bodies[g.b1], prog.bodies[g.b2] = q1, q2
    _place(q1, num.pair(g.sP1), num.pair(g.sM1), px, py, g1x, g1y)
    _place(q2, num.pair(g.sQ2), num.pair(g.sM2), qx, qy, g2x, g2y)
    prog.indicators.append(H)  # the indicator is sqrt(min(H, 1)) (see Program.indicator)
    # rates per unit driver coordinate: w1 = (dv . g2) / (g1 x g2), w2 = (dv . g1) / ...
    dvx = _minus(prog, vpx) if _zero(vqx) else _sub(vqx, vpx)
    dvy = _minus(prog, vpy) if _zero(vqy) else _sub(vqy, vpy)
    inv = g1x * g2y
    inv -= _times(g1y, g2x, tmp)
    np.divide(1.0, inv, out=inv)
    w1 = _dot(dvx, g2x, dvy, g2y, tmp)
    w1 *= inv
    w2 = _dot(dvx, g1x, dvy, g1y, tmp)
    w2 *= inv
    _rates(prog, q1, num.pair(g.sP1), vpx, vpy, w1)
    # v_Q = v_P + (v_Q - v_P) as the general dyad writes it: exactly v_Q (0) at rest
    vqx = vqx if _zero(vqx) else _add(vpx, dvx)
    vqy = vqy if _zero(vqy) else _add(vpy, dvy)
    _rates(prog, q2, num.pair(g.sQ2), vqx, vqy, w2)
    if "al" in prog.names:
        _accelerations(prog, g, num, (rpx, rpy, rqx, rqy), (g1x, g1y, g2x, g2y), inv)
    del inv, g1x, g1y, g2x, g2y
    hbound = _dH_bound(prog, g, num, h)
    _screen(prog, H, Hmin, D2, dx, dy, dvx, dvy, lengths, h, P, hbound)


class _Negated:
    """``-x``, not formed: a term ``-x * y`` is subtracted instead (the same bits)."""

    __slots__ = ("of",)

    def __init__(self, of: np.ndarray) -> None:
        self.of = of


def _minus(prog: Program, x):
    """``0 - x`` (a velocity's difference to a point at rest): the negation of ``x`` if
    the block already made it, else a :class:`_Negated`."""
    if isinstance(x, float):
        return -x
    got = prog._negated.get(id(x))
    if got is not None and got[0] is x:
        return got[1]
    return _Negated(x)


def _real(prog: Program, x):
    """``x`` with a :class:`_Negated` formed."""
    return prog.neg(x.of) if isinstance(x, _Negated) else x


def _dot(ax, bx, ay, by, tmp: np.ndarray):
    """``ax * bx + ay * by`` (a new array), its second product in ``tmp``; ``ax`` or
    ``ay`` may be a :class:`_Negated`: ``p + (-q)`` is ``p - q`` and ``-p + q`` is
    ``q - p`` in floating point, bit for bit."""
    na, nb = isinstance(ax, _Negated), isinstance(ay, _Negated)
    if na and not nb:
        ax, bx, ay, by, na, nb = ay, by, ax, bx, nb, na
    out = (ax.of if na else ax) * bx
    if np.shape(out) != tmp.shape:
        out = np.array(np.broadcast_to(out, tmp.shape))
    term = _times(ay.of if nb else ay, by, tmp)
    if nb and not na:
        out -= term
    else:
        out += term
        if na:  # -p - q = -(p + q)
            np.negative(out, out=out)
    return out


def _accelerations(prog: Program, g: RRR, num: _Numbers, arms, gs, inv) -> None:
    """``RRR.acceleration``: the angular accelerations by the same projections, per unit
    driver coordinate, with the velocities' ``1 / (g1 x g2)``."""
    rpx, rpy, rqx, rqy = arms
    g1x, g1y, g2x, g2y = gs
    q1, q2 = prog.bodies[g.b1], prog.bodies[g.b2]
    apx, apy = prog._acceleration(g.k1, rpx, rpy)
    aqx, aqy = prog._acceleration(g.k2, rqx, rqy)
    w1s, w2s = q1["w"] * q1["w"], q2["w"] * q2["w"]
    dax = _add(_sub(_sub(aqx, apx), w2s * g2x), w1s * g1x)
    day = _add(_sub(_sub(aqy, apy), w2s * g2y), w1s * g1y)
    a1 = (dax * g2x + day * g2y) * inv
    a2 = (dax * g1x + day * g1y) * inv
    for q, s0, ax, ay, al in ((q1, g.sP1, apx, apy, a1), (q2, g.sQ2, aqx, aqy, a2)):
        q["al"] = al
        s0 = num.pair(s0)
        if _zero(s0[0]) and _zero(s0[1]):
            q["ax"], q["ay"] = ax, ay
            continue
        c, s, w = q["c"], q["s"], q["w"]
        rx = _sub(_mul(c, s0[0]), _mul(s, s0[1]))
        ry = _add(_mul(s, s0[0]), _mul(c, s0[1]))
        w2 = w * w
        q["ax"] = _add(_add(ax, al * ry), w2 * rx)
        q["ay"] = _add(_sub(ay, al * rx), w2 * ry)


def _rates(prog: Program, q: dict, s0, vpx, vpy, w) -> None:
    """``body_velocity_from_point``: the frame's velocity from its point ``s0``'s."""
    q["w"] = w
    if _zero(s0[0]) and _zero(s0[1]):
        q["vx"], q["vy"] = vpx, vpy
        return
    c, s = q["c"], q["s"]
    rx = _sub(_mul(c, s0[0]), _mul(s, s0[1]))
    ry = _add(_mul(s, s0[0]), _mul(c, s0[1]))
    q["vx"], q["vy"] = _add(vpx, w * ry), _sub(vpy, w * rx)


def _screen(prog: Program, H, Hmin, D2, dx, dy, dvx, dvy, lengths, h, P, hbound=None) -> None:
    """The general pass's screening of every position, decided per design from the
    dyad's own terms (a NaN fails every test):

    * the indicator ``sqrt(min(H, 1))`` above ``near`` at every sample: then ``H > 0``
      there, the loop closes with a margin far above the closure's tolerance, and
      ``D2 > 0``;
    * the discriminant clear of zero within a step, ``H - h |dH| > 0``, and the cubic
      Hermite interpolant's lower bound on each step,
      ``min(H_i, H_i+1) - (4/27) (h |dH_i| + h |dH_i+1|) > 0``.

    Rounding is monotonic, so the smallest ``H`` and the largest ``h |dH|`` of a design
    give the general pass's decisions exactly: ``sqrt`` of the smallest ``min(H, 1)`` is
    the smallest indicator, and ``min H - max h|dH| > 0`` implies both tests at every
    sample and step. Only a design where that bound fails is tested sample by sample.

    ``hbound``: per design, ``h k`` times a number at least the largest ``|dH|`` the
    general pass forms (:func:`_dH_bound`, made once per pass), or None. With it ``dH``
    is formed only for the designs where ``min H - hbound > 0`` fails, and they are
    tested sample by sample: the sample by sample test is what the general pass decides
    (its shortcut above never passes a design the test fails), so the decisions are the
    same.

    The indicator's test is made once per pass on every design's smallest ``H``, which
    this keeps (``prog.hmin``, :func:`run_program`); a design that fails it may be tested
    sample by sample here too (it is risky either way)."""
    risky = prog.risky
    prog.hmin.append(Hmin)  # (Hmin: H.min(axis=1))
    # dH = ((L1^2 + L2^2) - D^2) (d . d') / (L1^2 L2^2): its factor k > 0 and h are
    # applied to the largest |.| of each design (the same rounding as element-wise)
    _, _, _, _, k, S = lengths
    if hbound is None:
        dH = np.subtract(S, D2, out=D2)  # (D2 is read no more)
        if any(isinstance(v, float) for v in (dx, dvx, dy, dvy)):
            dvx, dvy = _real(prog, dvx), _real(prog, dvy)
            dH *= _add(_mul(dx, dvx), _mul(dy, dvy))
        else:
            dH *= _dot(dvx, dx, dvy, dy, prog.tmp())  # (x y is y x)
        big = np.maximum(dH.max(axis=1), -dH.min(axis=1))
        big *= np.ravel(k)
        big *= h
    else:
        dH, big = None, hbound
    unsure = ~(Hmin - big > 0)
    if unsure.any():  # those designs, sample by sample
        rows = np.flatnonzero(unsure)
        k = k[rows] if np.ndim(k) else k
        if dH is None:  # the general pass's dH of these designs, the same operations
            S = S[rows] if np.ndim(S) else S
            dH = np.subtract(S, D2[rows])
            dvx, dvy = _real(prog, dvx), _real(prog, dvy)
            dH *= _add(_mul(*_rows(prog, rows, dx, dvx)), _mul(*_rows(prog, rows, dy, dvy)))
            hdH = np.abs(dH)
        else:
            hdH = np.abs(dH[rows])
        hdH *= k
        hdH *= h
        Hr = H[rows]
        bad = ~((Hr - hdH).min(axis=1) > 0)
        if P > 1:
            low = np.minimum(Hr[:, :-1], Hr[:, 1:])
            low -= (4.0 / 27.0) * (hdH[:, :-1] + hdH[:, 1:])
            bad |= ~(low.min(axis=1) > 0)
        risky[rows] |= bad


def _rows(prog: Program, rows: np.ndarray, *xs):
    """The designs ``rows`` of each quantity (a float stays a float)."""
    return [x if isinstance(x, float) else np.broadcast_to(x, prog.full)[rows] for x in xs]


def _dH_bound(prog: Program, g: RRR, num: _Numbers, h: float):
    """For a dyad between the driven crank and the ground, a bound per design of the
    ``|dH|`` the general pass forms, from the design's numbers only (no array of the
    block's size), times ``h k`` (``k = 1 / (L1^2 L2^2)``, as :func:`_screen` scales
    it), or None for any other dyad. Made once per pass (its designs' numbers as
    columns), each block reads its rows.

    With P on the crank at the distance ``r`` from its ground pivot O and Q on the
    ground at the distance ``e`` from O (or the other way round), at every position
    ``|e - r| <= |d| <= e + r`` and ``|d'| = |w| r``, so that
    ``|dH| <= max|L1^2 + L2^2 - D^2| (e + r) |w| r``. The computed positions differ from
    these by a few units of rounding of the coordinates involved: the bound is widened
    by a relative ``1e-12`` and by ``1e-12`` times the sum of their sizes, some hundred
    times more than the rounding. A design it does not clear is tested with the dyad's
    own ``dH`` (:func:`_screen`)."""
    crank = prog.crank
    if crank is None or {g.k1, g.k2} != {crank[0].b, prog.nb} or g.k1 == g.k2:
        return None
    key = ("bound", id(g))
    got = num.made.get(key)
    if got is None or got[0] is not g:
        lo, hi = num.lo, num.hi
        num.block(0, num.nd)
        bound = _crank_bound(crank, g, num)
        # h k bound per design: the operations :func:`_screen` made on each block's rows
        L1, L2 = num.one(g.L1), num.one(g.L2)
        L1s, L2s = L1 * L1, L2 * L2
        big = np.array(np.broadcast_to(np.ravel(bound), (num.nd,)))
        big *= np.ravel(1.0 / (L1s * L2s))
        big *= h
        got = num.made[key] = (g, big)
        num.block(lo, hi)
    return got[1][num.lo : num.hi]


def _crank_bound(crank: tuple, g: RRR, num: _Numbers):
    """:func:`_dH_bound` over every design of the pass: an array (designs,) or a float."""
    g0, w = crank
    ox, oy = num.pair(g0.sk)  # the crank's pivot on the ground
    cx, cy = num.pair(g0.sp)  # and on the crank
    on_crank = g.k1 == g0.b
    sx, sy = num.pair(g.sPk if on_crank else g.sQk)
    qx, qy = num.pair(g.sQk if on_crank else g.sPk)  # on the ground
    L1, L2 = num.one(g.L1), num.one(g.L2)
    eps = 1e-12
    r = np.hypot(np.subtract(sx, cx), np.subtract(sy, cy))
    e = np.hypot(np.subtract(qx, ox), np.subtract(qy, oy))
    size = sum(np.abs(v) for v in (ox, oy, cx, cy, sx, sy, qx, qy))
    delta = eps * size
    hi = (e + r + delta) * (1.0 + eps)
    lo = np.maximum(np.abs(e - r) - delta, 0.0) * (1.0 - eps)
    S = L1 * L1 + L2 * L2
    span = np.maximum(np.abs(S - lo * lo * (1.0 - eps)), np.abs(S - hi * hi * (1.0 + eps)))
    v = abs(w) * (r + delta) * (1.0 + eps)
    out = span * (1.0 + eps) * hi * v * (1.0 + eps)
    return float(out) if np.ndim(out) == 0 else np.ravel(out)


# designs per block of the program: its temporaries (some 20 arrays of the block's size)
# then stay in the cache and the allocator's reach instead of being faulted in anew for
# every pass (1024 designs of 361 positions: 39 ms by default in one block of 363 designs,
# 27 ms in blocks of 90; with the memory kept 17 and 16 ms)
BLOCK_COLUMNS = 65536


class Programs:
    """The program's blocks of one pass (see :data:`BLOCK_COLUMNS`): the design in row
    ``j`` of the pass is row ``j % per`` of block ``j // per``."""

    def __init__(self, blocks: list[Program], per: int) -> None:
        self.blocks, self.per = blocks, per
        self.risky = np.concatenate([b.risky for b in blocks])

    def state(self, j: int) -> State:
        return self.blocks[j // self.per].state(j % self.per)

    def indicator(self, j: int) -> np.ndarray:
        return self.blocks[j // self.per].indicator(j % self.per)


def run_program(
    plan: list[Group],
    nb: int,
    nd: int,
    u: np.ndarray,
    modes: np.ndarray,
    speed: float,
    near: float,
    acceleration: bool = False,
) -> Programs:
    """Solve ``nd`` designs over the driver values ``u``, block by block: ``plan`` is the
    start's analysis (its numbers stacked on ``2 nd`` columns, see :class:`_Numbers`),
    ``modes`` every design's branches (groups, nd). Rates come out per unit time (times
    ``speed``)."""
    P = len(u)
    per = max(1, BLOCK_COLUMNS // P)
    h = float(abs(u[1] - u[0])) if P > 1 else 0.0
    blocks = []
    num = _Numbers(nd)
    turn = _crank_turn(plan[0], u)
    # a group's branch where every design of the pass takes the same (else per block)
    same = [float(m[0]) if m.size and np.all(m == m[0]) else None for m in modes]
    for lo in range(0, nd, per):
        hi = min(nd, lo + per)
        prog = Program(nb, hi - lo, P, acceleration)
        if blocks:  # (the zeros of the dyads' max(h2, 0), made once per pass)
            prog.made = {k: v[: hi - lo] for k, v in blocks[0].made.items()}
        num.block(lo, hi)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            prog.indicators.append(None)  # the driver link's: 1
            _driver_link(prog, plan[0], num, turn)
            for gi in range(1, len(plan)):
                mode = same[gi]  # the branches: one float when the same in the block
                if mode is None:
                    m = modes[gi, lo:hi]
                    mode = float(m[0]) if np.all(m == m[0]) else m.reshape(-1, 1)
                _rrr(prog, plan[gi], num, mode, h)
        if speed != 1.0:  # rates per unit driver coordinate -> time rates
            for b, q in prog.bodies.items():
                if b != nb:
                    for name in ("vx", "vy", "w"):
                        q[name] = _mul(q[name], speed)
                    for name in ACCELERATIONS if acceleration else ():
                        q[name] = _mul(q[name], speed * speed)
        blocks.append(prog)
    out = Programs(blocks, per)
    # the indicator above near at every sample (sqrt of the smallest min(H, 1) is the
    # smallest indicator), once per pass over every design's smallest H of each dyad
    for gi in range(len(blocks[0].hmin)):
        Hmin = np.concatenate([b.hmin[gi] for b in blocks]) if len(blocks) > 1 else prog.hmin[gi]
        out.risky |= ~(np.sqrt(np.minimum(Hmin, 1.0)) > near)
    return out
