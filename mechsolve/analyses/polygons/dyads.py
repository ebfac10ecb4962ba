"""The construction of each Assur group's unknown point, as the textbook draws it: the
driver link, RRR, RRP, RPR and PRP (see :mod:`mechsolve.analyses.polygons`)."""

from __future__ import annotations

import numpy as np

from mechsolve.analyses.polygons.vectors import Arrow, _intersect, _k_cross
from mechsolve.joints.slider import SliderConstraint
from mechsolve.system.constraints import AngleDriverConstraint


class DyadConstructions:
    """Methods of the polygons' construction (:class:`.construction._Construction`): one
    per kind of group."""

    def driver_link(self, b: int, cons) -> None:
        pin = next(c for c in cons if c.letter == "R")
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
        # the bar's point is the pivot's acceleration plus the rotation terms about it
        pivot = "" if gq else f"a_{qn} + "
        self.absolute(self.ap, key4, f"a_{a4}", f"= {pivot}a^n_{r4} + a^t_{r4}")
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
