"""A cam worked out from its file: the base size (given or designed), the profile for
both senses of rotation, the checks, and a summary as a textbook prints it."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mechsolve.analyses.cam.design import Sizing, extremes, size
from mechsolve.analyses.cam.model import CamModel
from mechsolve.base.cam.profile import Profile, closed, self_intersections, solve
from mechsolve.base.cam.program import Remark

DENSE = 3600  # points of the drawn profile per turn (0.1 deg)


@dataclass
class CamResult:
    model: CamModel
    profile: Profile  # dense, in the file's sense
    other: Profile  # dense, in the other sense
    table: Profile  # at the table step, in the file's sense
    table_other: Profile
    sizing: Sizing | None  # the design for the allowances (when they are given)
    remarks: list[Remark]
    crossings: list[tuple[int, int]]
    crossings_pitch: list[tuple[int, int]]
    closed: bool
    problems: list[str] = field(default_factory=list)

    @property
    def follower(self):
        return self.profile.follower

    def undercut_ranges(self) -> list[tuple[float, float]]:
        """Cam-angle ranges (rad) where the profile is undercut (or below the margin)."""
        m = self.profile.undercut(self.model.allowance.rho_min)
        return _ranges(m, self.profile.theta)

    def better_sense(self) -> int:
        """The sense with the smaller pressure angle where the cam drives the follower
        (the rise); the return decides only on a tie (force closure drives it)."""
        mine = extremes(self.profile, self.model.program)
        theirs = extremes(self.other, self.model.program)
        allow = self.model.allowance

        def key(ex):
            over = 0.0
            for k in ("rise", "return"):
                lim = allow.of(k)
                if lim is not None and k in ex:
                    over = max(over, ex[k][0] - lim)
            return (round(over, 9), round(ex.get("rise", (0, 0))[0], 9),
                    round(ex.get("return", (0, 0))[0], 9))  # fmt: skip

        return self.profile.sense if key(mine) <= key(theirs) else self.other.sense

    def summary(self) -> str:
        return _summary(self)

    def face_extent(self) -> tuple[float, float, float, float] | None:
        """A flat face's contact range along the face (see :func:`face_offsets`): (least,
        largest offset (m), cam angle of each (rad)), the extremes located exactly (each
        refined from the densest sample by a bounded search on the law); None for a
        roller or knife edge."""
        if self.follower.contact != "flat-faced":
            return None
        from scipy.optimize import minimize_scalar

        p = self.profile
        t = face_offsets(p)
        h = float(p.theta[1] - p.theta[0])
        out = []
        for sign in (1.0, -1.0):  # the least, then the largest
            i = int(np.argmin(sign * t))

            def f(x: float, sign: float = sign) -> float:
                one = solve(self.model.program, p.follower, p.sense, np.array([x]))
                return sign * float(face_offsets(one)[0])

            r = minimize_scalar(f, bounds=(p.theta[i] - h, p.theta[i] + h), method="bounded",
                                options={"xatol": 1e-12})  # fmt: skip
            best = (r.fun, r.x) if r.fun < sign * t[i] else (sign * t[i], p.theta[i])
            out.append((sign * best[0], float(best[1]) % (2 * math.pi)))
        (lo, at_lo), (hi, at_hi) = out
        return lo, hi, at_lo, at_hi


def face_offsets(prof: Profile) -> np.ndarray:
    """Where a flat face touches the cam, along the face (m), at each cam angle: for a
    translating follower the contact's offset from the follower's axis (x - e: the
    contact lies at x = sigma ds/dtheta, so this is sigma ds/dtheta - e); for an
    oscillating one its distance along the face from the foot of the perpendicular from
    the pivot, toward the cam."""
    f = prof.follower
    if f.oscillating:
        m = prof.normal  # the face's normal
        along = np.stack([-m[:, 1], m[:, 0]], axis=-1)
        return np.sum((prof.contact - np.array([f.pivot, 0.0])) * along, axis=-1)
    return prof.contact[:, 0] - f.offset


def _ranges(mask: np.ndarray, theta: np.ndarray) -> list[tuple[float, float]]:
    out = []
    n = mask.size
    if not np.any(mask):
        return out
    if np.all(mask):
        return [(0.0, 2 * math.pi)]
    start = None
    # begin at a sample outside, so that a range over 360 deg stays whole
    k0 = int(np.argmin(mask))
    for j in range(n + 1):
        i = (k0 + j) % n
        if mask[i] and start is None:
            start = i
        elif not mask[i] and start is not None:
            last = (i - 1) % n
            out.append((float(theta[start]), float(theta[last])))
            start = None
    return out


def analyse(model: CamModel) -> CamResult:
    """Work out ``model``: design its base when the file leaves it out (or for
    comparison when allowances are given), then solve, check and compare the senses."""
    allow = model.allowance
    sizing = None
    fol = model.follower
    if model.designed or allow.rise is not None or allow.ret is not None:
        if model.designed and allow.rise is None and allow.ret is None:
            if fol.contact != "flat-faced" and not (fol.contact == "roller" and allow.rho_min):
                raise ValueError(
                    "the file gives no base size and no 'allowable_pressure_angle' to design "
                    "it for: give one of them"
                )
        sizing = size(model.program, fol, model.sense, allow)
        if model.designed:
            fol = sizing.follower
    th = np.linspace(0.0, 2 * math.pi, DENSE, endpoint=False)
    prof = solve(model.program, fol, model.sense, th)
    other = solve(model.program, fol, -model.sense, th)
    n_tab = int(round(2 * math.pi / model.table_step))
    tt = np.linspace(0.0, 2 * math.pi, n_tab + 1)
    table = solve(model.program, fol, model.sense, tt)
    table_other = solve(model.program, fol, -model.sense, tt)
    crossings = self_intersections(prof.profile)
    crossings_pitch = self_intersections(prof.pitch) if prof.pitch is not None else []
    res = CamResult(
        model, prof, other, table, table_other, sizing, model.program.remarks(), crossings,
        crossings_pitch, closed(prof.profile, th),
    )  # fmt: skip
    ex = extremes(prof, model.program)
    for k, lim in (("rise", allow.rise), ("return", allow.ret)):
        if lim is not None and k in ex and ex[k][0] > lim + 1e-9:
            res.problems.append(
                f"the pressure angle on the {k} reaches {math.degrees(ex[k][0]):.2f} deg at "
                f"{math.degrees(ex[k][1]):.1f} deg of cam angle, over the allowed "
                f"{math.degrees(lim):g} deg"
            )
    und = res.undercut_ranges()
    if und:
        what = "undercut" if not allow.rho_min else "undercut or below the curvature margin"
        res.problems.append(
            f"the profile is {what} at cam angles " + ", ".join(_range_text(a, b) for a, b in und)
        )
    if crossings:
        res.problems.append(f"the working profile crosses itself ({len(crossings)} crossing(s))")
    if not prof.valid:
        res.problems.append("the flat face does not envelope a cam: the base size is too small")
    return res


def _range_text(a: float, b: float) -> str:
    a, b = math.degrees(a), math.degrees(b)
    return f"{a:.1f} deg" if abs(b - a) < 1e-9 else f"{a:.1f}...{b:.1f} deg"


def _sense_name(s: int) -> str:
    return "ccw" if s > 0 else "cw"


def _summary(res: CamResult) -> str:
    """The cam's text summary: program, base values, displacement table, pressure angles,
    curvature, face size, undercut and profile, sizing and the verdict."""
    lines = _program_lines(res)
    lines += _base_lines(res)
    lines += _table_lines(res)
    lines += _pressure_lines(res)
    lines += _curvature_lines(res)
    lines += _face_lines(res)
    lines += _profile_lines(res)
    lines += _sizing_lines(res)
    return "\n".join(lines)


def _program_lines(res: CamResult) -> list[str]:
    """The cam and its follower, its speed, the motion program and its continuity."""
    m = res.model
    f = res.follower
    osc = f.oscillating
    prog = m.program
    L = m.unit  # lengths in the file's unit
    u = L.name

    def disp(x: float) -> str:
        return f"{math.degrees(x):.6g} deg" if osc else f"{L(x):.6g} {u}"

    lines = [f"{m.name}: cam with {f.describe(u, L.factor)}"]
    lines.append(
        f"  cam turns {_sense_name(m.sense)} at {m.speed * 30 / math.pi:.6g} rpm "
        f"({m.speed:.6g} rad/s)"
    )
    lines.append("  motion program (cam angle):")
    for g in prog.segments:
        a0, a1 = math.degrees(g.start), math.degrees(g.end)
        if g.kind == "dwell":
            lines.append(f"    {a0:7.2f} - {a1:7.2f} deg  dwell at {disp(g.s0)}")
        else:
            lines.append(
                f"    {a0:7.2f} - {a1:7.2f} deg  {g.kind:<6} {disp(abs(g.lift))}, "
                f"{g.law.title if g.law else ''}"
            )
    lines.append("  continuity:")
    if not res.remarks:
        lines.append("    velocity and acceleration continuous over the whole cycle")
    for r in res.remarks:
        lines.append(f"    at {math.degrees(r.angle):7.2f} deg: {r.text}")
    return lines


def _base_lines(res: CamResult) -> list[str]:
    """The base values (designed or as given), the roller's base circle, the model's notes."""
    m = res.model
    f = res.follower
    osc = f.oscillating
    L = m.unit
    u = L.name
    lines: list[str] = []
    if osc:
        base = (f"a = {L(f.pivot):.4f} {u}, phi0 = {math.degrees(f.start_angle):.4f} deg, "
                f"r0 = {L(f.base_radius):.4f} {u}")  # fmt: skip
    else:
        base = f"r0 = {L(f.base_radius):.4f} {u}"
        if f.contact != "flat-faced":
            s0 = math.sqrt(max(f.base_radius**2 - f.offset**2, 0.0))
            base += f", s0 = sqrt(r0^2 - e^2) = {L(s0):.4f} {u}"
    lines.append(f"  base values ({'designed' if m.designed else 'as given'}): {base}")
    if f.contact == "roller":
        lines.append(
            f"    r0 is the prime circle's radius (the roller centre's); the cam's base "
            f"circle r0 - roller = {L(f.base_radius - f.roller):.4f} {u}"
        )
    for note in m.notes:
        lines.append(f"    {note}")
    return lines


def _table_lines(res: CamResult) -> list[str]:
    """The displacement table of the moving segments, as textbooks print it."""
    m = res.model
    prog = m.program
    osc = res.follower.oscillating
    L = m.unit
    u = L.name
    lines: list[str] = []
    lines.append(
        f"  displacement table (every {math.degrees(m.table_step):g} deg of each segment):"
    )
    for g in prog.segments:
        if g.kind == "dwell":
            continue
        n = int(round(g.angle / m.table_step))
        if n < 1 or abs(n * m.table_step - g.angle) > 1e-9:
            continue
        th = g.start + np.arange(n + 1) * m.table_step
        s = prog.eval(th)[0]
        s[-1] = g.s0 + g.lift  # the end value itself (theta = end is the next segment's)
        vals = [math.degrees(x) if osc else L(x) for x in s]
        unit = "deg" if osc else u
        lines.append(f"    {g.kind} at {math.degrees(g.start):g} deg, delta [deg] / s [{unit}]:")
        for k in range(0, n + 1, 8):
            row = range(k, min(k + 8, n + 1))
            lines.append("      " + " ".join(f"{math.degrees(th[j] - g.start):8g}" for j in row))
            lines.append("      " + " ".join(f"{vals[j]:8.3f}" for j in row))
    return lines


def _pressure_lines(res: CamResult) -> list[str]:
    """The largest pressure angles on rise and return for both senses, the allowances,
    and the better sense."""
    m = res.model
    prog = m.program
    lines: list[str] = []
    allow = m.allowance
    lines.append("  maximum pressure angle     rise                    return")
    for prof, tag in ((res.profile, "as given"), (res.other, "reversed")):
        ex = extremes(prof, prog)
        cells = []
        for k in ("rise", "return"):
            if k in ex:
                cells.append(f"{math.degrees(ex[k][0]):6.2f} deg at {math.degrees(ex[k][1]):6.1f}")
            else:
                cells.append(" " * 20)
        lines.append(f"    {_sense_name(prof.sense):>3} ({tag}):      {cells[0]}    {cells[1]}")
    if allow.rise is not None or allow.ret is not None:
        lines.append(
            "    allowed:                "
            + (f"{math.degrees(allow.rise):6.2f} deg" if allow.rise is not None else "  -")
            + "                "
            + (f"{math.degrees(allow.ret):6.2f} deg" if allow.ret is not None else "  -")
        )
    best = res.better_sense()
    why = "smaller pressure angle on the rise, where the cam drives the follower"
    if allow.rise is not None or allow.ret is not None:
        why = "within the allowances, or nearer to them; then the smaller angle on the rise"
    lines.append(
        f"    better sense: {_sense_name(best)} ({why})"
        + ("" if best == m.sense else ": reverse the cam or mirror the follower")
    )
    return lines


def _curvature_lines(res: CamResult) -> list[str]:
    """The smallest radius of curvature of the pitch curve (or of the profile)."""
    f = res.follower
    osc = f.oscillating
    L = res.model.unit
    u = L.name
    lines: list[str] = []
    prof = res.profile
    if prof.rho_pitch is not None:
        cv = prof.rho_pitch > 0
        i = int(np.argmin(np.where(cv, prof.rho_pitch, np.inf)))
        lines.append(
            f"  radius of curvature: pitch curve, smallest on convex parts "
            f"{L(prof.rho_pitch[i]):.3f} {u} at {math.degrees(prof.theta[i]):.1f} deg"
        )
        if f.contact == "roller":
            lines.append(
                f"    working profile there {L(prof.rho_profile[i]):.3f} {u} (pitch radius "
                f"- roller {L(f.roller):g} {u})"
            )
    else:
        i = int(np.argmin(prof.rho_profile))
        lines.append(
            f"  radius of curvature of the profile: smallest {L(prof.rho_profile[i]):.3f} {u} "
            f"at {math.degrees(prof.theta[i]):.1f} deg "
            + ("(h + d2h/dmu2 of the face's envelope)" if osc else "(r0 + s + s'')")
        )
    return lines


def _face_lines(res: CamResult) -> list[str]:
    """A flat face's needed length or width, with its margin (nothing for other followers)."""
    m = res.model
    osc = res.follower.oscillating
    L = m.unit
    u = L.name
    lines: list[str] = []
    ext = res.face_extent()
    if ext is not None:
        lo, hi, a_lo, a_hi = ext
        where = (f"{L(lo):.4f} {u} (at {math.degrees(a_lo):.1f} deg) to {L(hi):.4f} {u} "
                 f"(at {math.degrees(a_hi):.1f} deg)")  # fmt: skip
        if osc:
            lines.append(
                f"  face length: the contact runs along the face from {where} from the foot "
                f"of the perpendicular from the pivot: the face needs at least "
                f"{L(hi - lo):.4f} {u}"
            )
        else:
            lines.append(
                f"  face width: the contact runs from {where} off the follower's axis "
                f"(sigma ds/dtheta - e): the face needs at least {L(hi - lo):.4f} {u} "
                f"(the range of ds/dtheta); centred on the axis 2 max|offset| = "
                f"{L(2 * max(abs(lo), abs(hi))):.4f} {u}"
            )
        if m.face_margin is not None:
            c = m.face_margin
            lines.append(
                f"    with the face_margin {L(c):g} {u} at each end: {L(hi - lo + 2 * c):.4f} {u}"
                + ("" if osc else f" (centred: {L(2 * max(abs(lo), abs(hi)) + 2 * c):.4f} {u})")
            )
        else:
            lines.append("    no clearance added at the ends (give follower.face_margin)")
    return lines


def _profile_lines(res: CamResult) -> list[str]:
    """Undercut, and whether the working profile closes without crossing itself."""
    allow = res.model.allowance
    L = res.model.unit
    u = L.name
    lines: list[str] = []
    und = res.undercut_ranges()
    margin = f" (margin {L(allow.rho_min):g} {u})" if allow.rho_min else ""
    lines.append(
        "  undercut" + margin + ": "
        + ("no" if not und else "YES at " + ", ".join(_range_text(a, b) for a, b in und))
    )  # fmt: skip
    lines.append(
        f"  profile: {DENSE} points, "
        + ("closed" if res.closed else "NOT closed")
        + ", "
        + ("no self-intersection" if not res.crossings else f"{len(res.crossings)} crossing(s)")
    )
    return lines


def _sizing_lines(res: CamResult) -> list[str]:
    """The smallest base for the allowances (or how the base was designed), and the verdict."""
    m = res.model
    f = res.follower
    osc = f.oscillating
    L = m.unit
    u = L.name
    lines: list[str] = []
    if res.sizing is not None and not m.designed:
        sz = res.sizing.follower
        if osc:
            txt = (f"a = {L(sz.pivot):.3f} {u}, phi0 = {math.degrees(sz.start_angle):.3f} deg, "
                   f"r0 = {L(sz.base_radius):.3f} {u}")  # fmt: skip
        else:
            txt = f"r0 = {L(sz.base_radius):.3f} {u}"
        if f.contact == "roller":
            txt += f" (prime circle; base circle {L(sz.base_radius - f.roller):.3f} {u})"
        reach = ", ".join(f"{k} {math.degrees(v[0]):.2f} deg" for k, v in res.sizing.reached.items()
                          if k != "dwell")  # fmt: skip
        lines.append(f"  smallest base for the allowances ({_sense_name(m.sense)}): {txt} "
                     f"(reaches {reach})")  # fmt: skip
        lines.append(f"    by {res.sizing.method}")
    elif res.sizing is not None:
        lines.append(f"    designed by {res.sizing.method}")
    if res.problems:
        lines.append("  THE DESIGN FAILS: " + "; ".join(res.problems))
    else:
        lines.append("  design: acceptable")
    return lines
