"""A small revolute group's Newton iterations in floats, written for its equations.

:meth:`~mechsolve.groups.reduced._Eqs._newton_list2` and ``_newton_list4`` are written
for any two or four angles: every coefficient of ``F = K + M1 cos + M2 sin + M3 theta``
enters the residual and ``F_theta``, zeros included (a four-bar's loop has eight of
twelve, the Stephenson triad's 32 of 48, and four of the sixteen entries of its
``F_theta`` are zero whatever the angles). The coarse continuation of a batched sweep
runs these iterations some hundred times a sweep, in Python, where each product costs
about as much as the arithmetic of a whole NumPy pass over a position.

:func:`sparse_newton` writes the same iterations as Python source for one group's
coefficients and compiles them once: the same tests, steps and results in the same
order, each sum with the products of zero coefficients left out and the adjugate's
products of entries that are zero for every angle left out. Leaving out a term that is
exactly zero changes no bit of a sum but the sign of a zero sum, so the iterates are
those of the general loops (the states of every mechanism of ``mechanisms/`` and of the
benchmark's are bit for bit the same).
"""

from __future__ import annotations

import math

Expr = str | None  # a term's source, None where it is zero for every angle


def _num(v: float) -> str:
    return repr(float(v))


def _sum(terms: list[tuple[int, Expr]]) -> Expr:
    """``t0 + t1 - t2 ...`` left to right (the signs +1 or -1), the zero terms left out:
    ``(0 - b) + c`` is ``-(b) + c`` exactly."""
    out: Expr = None
    for sign, e in terms:
        if e is None:
            continue
        if out is None:
            out = f"({e})" if sign > 0 else f"(-({e}))"
        else:
            out = f"({out} {'+' if sign > 0 else '-'} {e})"
    return out


def _mul(a: Expr, b: Expr) -> Expr:
    return None if a is None or b is None else f"{a} * {b}"


def _entry(m1: float, m2: float, m3: float, k: int) -> Expr:
    """``F_theta``'s entry ``m2 cos - m1 sin + m3`` of angle ``k``, as the loops write it
    (``(m2 c - m1 s) + m3``)."""
    return _sum(
        [
            (1, f"{_num(m2)} * c{k}" if m2 else None),
            (-1, f"{_num(m1)} * s{k}" if m1 else None),
            (1, _num(m3) if m3 else None),
        ]
    )


def _solve4_source(J: list[list[Expr]]) -> tuple[list[str], Expr, list[Expr]]:
    """:func:`~mechsolve.groups.reduced._solve4`'s minors, determinant and solution's
    numerators as source (the entries ``J`` names or None), zero products left out:
    ``(lines, det, [x_k times -det])``; the caller divides by ``-det``."""
    (a00, a01, a02, a03), (a10, a11, a12, a13), (a20, a21, a22, a23), (a30, a31, a32, a33) = J

    def minor(p, q, r, s):  # p q - r s
        return _sum([(1, _mul(p, q)), (-1, _mul(r, s))])

    # the minors of the first two rows (_solve4's s0..s5: here u0..u5) and of the last
    # two (its c0..c5: here v0..v5; the loop's names s, c and k are the angles' sines,
    # cosines and the constant terms)
    names = {
        "u0": minor(a00, a11, a10, a01),
        "u1": minor(a00, a12, a10, a02),
        "u2": minor(a00, a13, a10, a03),
        "u3": minor(a01, a12, a11, a02),
        "u4": minor(a01, a13, a11, a03),
        "u5": minor(a02, a13, a12, a03),
        "v5": minor(a22, a33, a32, a23),
        "v4": minor(a21, a33, a31, a23),
        "v3": minor(a21, a32, a31, a22),
        "v2": minor(a20, a33, a30, a23),
        "v1": minor(a20, a32, a30, a22),
        "v0": minor(a20, a31, a30, a21),
    }
    lines = [f"{k} = {v}" for k, v in names.items() if v is not None]
    v = {k: (k if e is not None else None) for k, e in names.items()}
    s0, s1, s2, s3, s4, s5 = (v[f"u{i}"] for i in range(6))
    c0, c1, c2, c3, c4, c5 = (v[f"v{i}"] for i in range(6))
    det = _sum(
        [
            (1, _mul(s0, c5)),
            (-1, _mul(s1, c4)),
            (1, _mul(s2, c3)),
            (1, _mul(s3, c2)),
            (-1, _mul(s4, c1)),
            (1, _mul(s5, c0)),
        ]
    )

    def lin(*terms):  # (sign, entry, minor) summed left to right
        return _sum([(sg, _mul(a, m)) for sg, a, m in terms])

    cols = [
        [
            lin((1, a11, c5), (-1, a12, c4), (1, a13, c3)),
            lin((-1, a01, c5), (1, a02, c4), (-1, a03, c3)),
            lin((1, a31, s5), (-1, a32, s4), (1, a33, s3)),
            lin((-1, a21, s5), (1, a22, s4), (-1, a23, s3)),
        ],
        [
            lin((-1, a10, c5), (1, a12, c2), (-1, a13, c1)),
            lin((1, a00, c5), (-1, a02, c2), (1, a03, c1)),
            lin((-1, a30, s5), (1, a32, s2), (-1, a33, s1)),
            lin((1, a20, s5), (-1, a22, s2), (1, a23, s1)),
        ],
        [
            lin((1, a10, c4), (-1, a11, c2), (1, a13, c0)),
            lin((-1, a00, c4), (1, a01, c2), (-1, a03, c0)),
            lin((1, a30, s4), (-1, a31, s2), (1, a33, s0)),
            lin((-1, a20, s4), (1, a21, s2), (-1, a23, s0)),
        ],
        [
            lin((-1, a10, c3), (1, a11, c1), (-1, a12, c0)),
            lin((1, a00, c3), (-1, a01, c1), (1, a02, c0)),
            lin((-1, a30, s3), (1, a31, s1), (-1, a32, s0)),
            lin((1, a20, s3), (-1, a21, s1), (1, a22, s0)),
        ],
    ]
    nums = [
        _sum([(1, _mul(f"({c})" if c else None, f"f{j}")) for j, c in enumerate(col)])
        for col in cols
    ]
    return lines, det, nums


def _residual_lines(rows, nb: int, flat: bool) -> list[str] | None:
    """The residual ``f_e`` of every equation as source lines: ``flat``, one sum left to
    right (:meth:`_newton_list2`'s), else ``k_e + (angle 0's terms)``, then ``+=`` each
    other angle's terms (:meth:`_newton_list4`'s)."""
    lines = []
    for e, row in enumerate(rows):
        groups = []
        for k, (m1, m2, m3) in enumerate(row):
            groups.append(
                [
                    (1, f"{_num(m1)} * c{k}" if m1 else None),
                    (1, f"{_num(m2)} * s{k}" if m2 else None),
                    (1, f"{_num(m3)} * x{k}" if m3 else None),
                ]
            )
        if flat:
            lines.append(f"f{e} = {_sum([(1, f'k{e}')] + [t for g in groups for t in g])}")
            continue
        first = _sum(groups[0])
        lines.append(f"f{e} = k{e}" + (f" + {first}" if first is not None else ""))
        for g in groups[1:]:
            s = _sum(g)
            if s is not None:
                lines.append(f"f{e} += {s}")
    return lines


def _step_lines(rows, nb: int) -> list[str] | None:
    """``dx0, ...`` (the Newton step ``-F_theta^-1 f``) as source lines, with ``break``
    where the determinant is zero; None where it is zero for every angle or an angle
    never moves (the general loops then)."""
    J = [[_entry(m1, m2, m3, k) for k, (m1, m2, m3) in enumerate(row)] for row in rows]
    names = [[f"a{e}{k}" if J[e][k] is not None else None for k in range(nb)] for e in range(nb)]
    lines = [f"{names[e][k]} = {J[e][k]}" for e in range(nb) for k in range(nb) if J[e][k]]
    if nb == 2:  # as _newton_list2: Cramer's rule
        (ja, jb), (jc, jd) = names
        det = _sum([(1, _mul(ja, jd)), (-1, _mul(jb, jc))])
        n0 = _sum([(1, _mul(jd, "f0")), (-1, _mul(jb, "f1"))])
        n1 = _sum([(1, _mul(ja, "f1")), (-1, _mul(jc, "f0"))])
        if det is None or n0 is None or n1 is None:
            return None
        return lines + [
            f"det = {det}",
            "if det == 0:",
            "    break",
            f"dx0, dx1 = -{n0} / det, -{n1} / det",
        ]
    solve, det, nums = _solve4_source(names)
    if det is None or any(v is None for v in nums):
        return None
    lines += solve + [
        f"det = {det}",
        "if det == 0:",
        "    break",
        "rd = -1.0 / det",
    ]
    return lines + [f"dx{k} = rd * {v}" for k, v in enumerate(nums)]


_LOOP = """\
def newton(K, x, atol, max_iterations, predict):
    xtol = 1e-3 * atol
    last = r = r_prev = inf
    {ks} = K
    {xs} = x
    for it in range(max_iterations + 1):
        {cos}
        {sin}
{residual}
        r = max({absf})
        if not r <= 1e300 or (it > 3 and r > 2 * r_prev):
            break
        r_prev = r
        if r <= atol and (last <= xtol or r == 0.0):
            return [{xs}], True, it, r, it + 1
        if it == max_iterations:
            break
{step}
        step = max({absdx})
        if not step <= 1e300:
            break
        if r <= atol and step >= last:
            return [{xs}], True, it, r, it + 1
        {xs} = {xnew}
        if predict and step <= 0.5 * last < inf and 2 * step * step <= xtol * last:
            return [{xs}], True, it + 1, r, it + 1
        last = step
    return [{xs}], r <= atol, max_iterations, r, max_iterations
"""


def sparse_newton(eqs):
    """``newton(K, x, atol, max_iterations, predict)``: :meth:`_Eqs.newton_list` of a
    group of two or four angles (``eqs._rows``), written out for its coefficients (see
    the module docstring); the same arguments, iterations and result. None for other
    sizes, or where a step would be zero for every angle."""
    nb = eqs.nb
    if nb not in (2, 4):
        return None
    rows = eqs._rows
    residual = _residual_lines(rows, nb, flat=nb == 2)
    step = _step_lines(rows, nb)
    if step is None:
        return None
    ind = " " * 8
    idx = range(nb)
    src = _LOOP.format(
        ks=", ".join(f"k{k}" for k in idx),
        xs=", ".join(f"x{k}" for k in idx),
        cos=", ".join(f"c{k}" for k in idx) + " = " + ", ".join(f"cos(x{k})" for k in idx),
        sin=", ".join(f"s{k}" for k in idx) + " = " + ", ".join(f"sin(x{k})" for k in idx),
        residual="\n".join(ind + line for line in residual),
        absf=", ".join(f"abs(f{e})" for e in idx),
        step="\n".join(ind + line for line in step),
        absdx=", ".join(f"abs(dx{k})" for k in idx),
        xnew=", ".join(f"x{k} + dx{k}" for k in idx),
    )
    space = {"cos": math.cos, "sin": math.sin, "inf": math.inf}
    exec(compile(src, f"<newton of {nb} angles>", "exec"), space)  # noqa: S102
    fn = space["newton"]
    fn.source = src
    return fn


_RUN = """\
def run(i, ul, Kr, newton, hu, ha, wj, atol, its, out, iters, max_jump):
    n = len(ul)
    u0, u1, u2 = hu
    ({h0}), ({h1}), ({h2}) = ha
    {ws} = wj
    while i < n:
        ui = ul[i]
        d01, d02, d12 = u0 - u1, u0 - u2, u1 - u2
        if d01 == 0 or d02 == 0 or d12 == 0:
            {qs} = {h2}
        else:
            a0, a1, a2 = ui - u0, ui - u1, ui - u2
            w0 = (a1 / d01) * (a2 / d02)
            w1 = (a0 / (u1 - u0)) * (a2 / d12)
            w2 = (a0 / (u2 - u0)) * (a1 / (u2 - u1))
{pred}
        thf, plain, it, _, _ = newton(Kr[i], [{qs}], atol, its, True)
        if not plain:
            break
        {ts} = thf
        if not max({jump}) <= max_jump:
            break
        out.append(thf)
        iters.append(it)
        u0, u1, u2 = u1, u2, ui
        {h0}, {h1}, {h2} = {h1}, {h2}, {ts}
        i += 1
    return i, [u0, u1, u2], [[{h0}], [{h1}], [{h2}]]
"""


def coarse_runner(nb: int):
    """``run(i, ul, Kr, newton, hu, ha, wj, atol, its, out, iters, max_jump) -> (i,
    hu, ha)``: the coarse pass's plain steps from position ``i`` with three positions
    of history (``hu`` their driver values, ``ha`` their free angles), as
    :meth:`~mechsolve.groups.newton_batched.BatchedSweep._coarse_floats` takes them
    (the three-point extrapolation, ``newton`` with the stop on a predicted error, the
    weighted jump check ``max(|theta - pred| w) <= max_jump``: the same operations),
    the angles of the history held in locals; appends each step's angles and
    iterations to ``out`` and ``iters``. Returns at the end or at the first step that
    is not plain (its position, not taken), with the history there."""
    got = _RUNNERS.get(nb)
    if got is not None:
        return got
    idx = range(nb)
    hist = [", ".join(f"p{j}{k}" for k in idx) for j in range(3)]
    src = _RUN.format(
        h0=hist[0],
        h1=hist[1],
        h2=hist[2],
        ws=", ".join(f"wj{k}" for k in idx) + ("," if nb == 1 else ""),
        qs=", ".join(f"q{k}" for k in idx),
        pred="\n".join(f"            q{k} = w0 * p0{k} + w1 * p1{k} + w2 * p2{k}" for k in idx),
        ts=", ".join(f"t{k}" for k in idx),
        jump=", ".join(f"abs(t{k} - q{k}) * wj{k}" for k in idx) + ("," if nb == 1 else ""),
    )
    space: dict = {}
    exec(compile(src, f"<coarse steps of {nb} angles>", "exec"), space)  # noqa: S102
    fn = space["run"]
    fn.source = src
    _RUNNERS[nb] = fn
    return fn


_RUNNERS: dict = {}
