"""A cam worked out from its file: the base size (given or designed), the profile for
both senses of rotation, the checks, and a summary as a textbook prints it."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .design import Sizing, extremes, size
from .model import CamModel
from .profile import Profile, closed, self_intersections, solve
from .program import Remark

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
    m = res.model
    f = res.follower
    osc = f.oscillating
    prog = m.program
    mm = 1e3

    def disp(x: float) -> str:
        return f"{math.degrees(x):.6g} deg" if osc else f"{x * mm:.6g} mm"

    lines = [f"{m.name}: cam with {f.describe()}"]
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
    # base values
    if osc:
        base = (f"a = {f.pivot * mm:.4f} mm, phi0 = {math.degrees(f.start_angle):.4f} deg, "
                f"r0 = {f.base_radius * mm:.4f} mm")  # fmt: skip
    else:
        base = f"r0 = {f.base_radius * mm:.4f} mm"
        if f.contact != "flat-faced":
            s0 = math.sqrt(max(f.base_radius**2 - f.offset**2, 0.0))
            base += f", s0 = sqrt(r0^2 - e^2) = {s0 * mm:.4f} mm"
    lines.append(f"  base values ({'designed' if m.designed else 'as given'}): {base}")
    for note in m.notes:
        lines.append(f"    {note}")
    # table of the moving segments, as textbooks print it
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
        vals = [math.degrees(x) if osc else x * mm for x in s]
        unit = "deg" if osc else "mm"
        lines.append(f"    {g.kind} at {math.degrees(g.start):g} deg, delta [deg] / s [{unit}]:")
        for k in range(0, n + 1, 8):
            row = range(k, min(k + 8, n + 1))
            lines.append("      " + " ".join(f"{math.degrees(th[j] - g.start):8g}" for j in row))
            lines.append("      " + " ".join(f"{vals[j]:8.3f}" for j in row))
    # pressure angles for both senses
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
    # curvature
    prof = res.profile
    if prof.rho_pitch is not None:
        cv = prof.rho_pitch > 0
        i = int(np.argmin(np.where(cv, prof.rho_pitch, np.inf)))
        lines.append(
            f"  radius of curvature: pitch curve, smallest on convex parts "
            f"{prof.rho_pitch[i] * mm:.3f} mm at {math.degrees(prof.theta[i]):.1f} deg"
        )
        if f.contact == "roller":
            lines.append(
                f"    working profile there {prof.rho_profile[i] * mm:.3f} mm (pitch radius "
                f"- roller {f.roller * mm:g} mm)"
            )
    else:
        i = int(np.argmin(prof.rho_profile))
        lines.append(
            f"  radius of curvature of the profile: smallest {prof.rho_profile[i] * mm:.3f} mm "
            f"at {math.degrees(prof.theta[i]):.1f} deg "
            + ("(h + d2h/dmu2 of the face's envelope)" if osc else "(r0 + s + s'')")
        )
    und = res.undercut_ranges()
    margin = f" (margin {allow.rho_min * mm:g} mm)" if allow.rho_min else ""
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
    if res.sizing is not None and not m.designed:
        sz = res.sizing.follower
        if osc:
            txt = (f"a = {sz.pivot * mm:.3f} mm, phi0 = {math.degrees(sz.start_angle):.3f} deg, "
                   f"r0 = {sz.base_radius * mm:.3f} mm")  # fmt: skip
        else:
            txt = f"r0 = {sz.base_radius * mm:.3f} mm"
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
    return "\n".join(lines)
