"""Files of a cam: the motion table and the profile as CSV, the profile as DXF (with
ezdxf, an optional dependency: ``pip install "mechsolve[cam]"``), and plots."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from ..writers.atomic import replacing
from .analysis import CamResult
from .design import extremes

MM = 1e3
DXF_HINT = 'the DXF needs ezdxf: pip install "mechsolve[cam]" (or pip install ezdxf)'


def _atomic_csv(path: Path, header: list[str], rows) -> Path:
    with replacing(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for r in rows:
            w.writerow(["" if not np.isfinite(v) else format(float(v), ".12g") for v in r])
    return path


def write_motion_csv(res: CamResult, path: Path) -> Path:
    """One row per table step: cam angle, follower motion (displacement or swing and its
    time derivatives), pressure angle (both senses), pitch and profile points, radii."""
    t, o = res.table, res.table_other
    w = res.model.speed
    osc = res.follower.oscillating
    if osc:
        names = ["swing [deg]", "angular velocity [rad/s]", "angular acceleration [rad/s^2]",
                 "angular jerk [rad/s^3]"]  # fmt: skip
        s = np.degrees(t.s)
    else:
        names = ["displacement [mm]", "velocity [m/s]", "acceleration [m/s^2]", "jerk [m/s^3]"]
        s = t.s * MM
    sn = "ccw" if t.sense > 0 else "cw"
    on = "ccw" if o.sense > 0 else "cw"
    header = ["cam angle [deg]", *names,
              f"pressure angle {sn} [deg]", f"pressure angle {on} [deg]"]  # fmt: skip
    cols = [np.degrees(t.theta), s, t.ds * w, t.d2s * w**2, t.d3s * w**3,
            np.degrees(t.pressure), np.degrees(o.pressure)]  # fmt: skip
    if t.pitch is not None:
        header += ["pitch x [mm]", "pitch y [mm]"]
        cols += [t.pitch[:, 0] * MM, t.pitch[:, 1] * MM]
    header += ["profile x [mm]", "profile y [mm]"]
    cols += [t.profile[:, 0] * MM, t.profile[:, 1] * MM]
    if t.rho_pitch is not None:
        header.append("pitch curvature radius [mm]")
        cols.append(t.rho_pitch * MM)
    header.append("profile curvature radius [mm]")
    cols.append(t.rho_profile * MM)
    header.append("undercut [1/0]")
    cols.append(t.undercut(res.model.allowance.rho_min).astype(float))
    return _atomic_csv(path, header, zip(*cols))


def write_profile_csv(res: CamResult, path: Path) -> Path:
    """The dense profile (and pitch curve) in the cam's frame, drawn at cam angle 0."""
    p = res.profile
    header = ["cam angle [deg]", "profile x [mm]", "profile y [mm]"]
    cols = [np.degrees(p.theta), p.profile[:, 0] * MM, p.profile[:, 1] * MM]
    if p.pitch is not None:
        header += ["pitch x [mm]", "pitch y [mm]"]
        cols += [p.pitch[:, 0] * MM, p.pitch[:, 1] * MM]
    return _atomic_csv(path, header, zip(*cols))


def write_dxf(res: CamResult, path: Path) -> Path | None:
    """The profile (layer PROFILE), the pitch curve (PITCH), the base circle and the
    cam centre, in mm, as closed polylines. None when ezdxf is not installed."""
    try:
        import ezdxf
    except ImportError:
        return None
    doc = ezdxf.new("R2010")
    doc.units = ezdxf.units.MM
    msp = doc.modelspace()
    for name, color in (("PROFILE", 7), ("PITCH", 3), ("BASE", 8), ("CENTRE", 1)):
        doc.layers.add(name, color=color)
    p = res.profile
    msp.add_lwpolyline((p.profile * MM).tolist(), close=True, dxfattribs={"layer": "PROFILE"})
    if p.pitch is not None and res.follower.contact == "roller":
        msp.add_lwpolyline((p.pitch * MM).tolist(), close=True, dxfattribs={"layer": "PITCH"})
    msp.add_circle((0, 0), res.follower.base_radius * MM, dxfattribs={"layer": "BASE"})
    r = 0.05 * res.follower.base_radius * MM
    msp.add_line((-r, 0), (r, 0), dxfattribs={"layer": "CENTRE"})
    msp.add_line((0, -r), (0, r), dxfattribs={"layer": "CENTRE"})
    with replacing(path) as tmp:
        doc.saveas(tmp)
    return path


def _plt():
    from ..writers.fonts import pyplot

    return pyplot()


def write_plots(res: CamResult, outdir: Path) -> list[Path]:
    """motion.png (s, v, a, j against cam angle), pressure.png (both senses, with the
    allowances), cam.png (profile, pitch and base circles, follower in a few positions)."""
    plt = _plt()
    out = []
    p = res.profile
    w = res.model.speed
    deg = np.degrees(p.theta)
    osc = res.follower.oscillating
    if osc:
        labels = ["swing psi [deg]", "angular velocity [rad/s]",
                  "angular acceleration [rad/s^2]", "angular jerk [rad/s^3]"]  # fmt: skip
        ys = [np.degrees(p.s), p.ds * w, p.d2s * w**2, p.d3s * w**3]
    else:
        labels = ["displacement s [mm]", "velocity [m/s]", "acceleration [m/s^2]",
                  "jerk [m/s^3]"]  # fmt: skip
        ys = [p.s * MM, p.ds * w, p.d2s * w**2, p.d3s * w**3]
    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    for ax, y, lab in zip(axes, ys, labels):
        ax.plot(deg, y, lw=1.2)
        ax.set_ylabel(lab, fontsize=8)
        ax.grid(alpha=0.3)
        for g in res.model.program.segments:
            ax.axvline(math.degrees(g.start), color="0.7", lw=0.6)
    # a jump of velocity is an infinite acceleration, a jump of acceleration an infinite jerk
    for r in res.remarks:
        ax = axes[2] if r.what == "velocity" else axes[3]
        x = math.degrees(r.angle)
        ax.axvline(x, color="red", ls=":", lw=1.0)
        ax.annotate("inf", (x, 1.0), xycoords=("data", "axes fraction"), color="red",
                    fontsize=7, ha="center", va="bottom")  # fmt: skip
    axes[-1].set_xlabel("cam angle [deg]")
    axes[-1].set_xlim(0, 360)
    axes[0].set_title(f"{res.model.name}: follower motion")
    fig.tight_layout()
    out.append(_save(fig, outdir / "motion.png", plt))

    fig, ax = plt.subplots(figsize=(8, 4))
    for prof, style in ((res.profile, "-"), (res.other, "--")):
        tag = "ccw" if prof.sense > 0 else "cw"
        given = " (as given)" if prof is res.profile else ""
        ax.plot(deg, np.degrees(prof.pressure), style, lw=1.2, label=f"cam {tag}{given}")
    allow = res.model.allowance
    for g in res.model.program.segments:
        lim = allow.of(g.kind) if g.kind != "dwell" else None
        if lim is not None:
            ax.plot([math.degrees(g.start), math.degrees(g.end)], [math.degrees(lim)] * 2,
                    color="red", lw=1.0)  # fmt: skip
    if allow.rise is not None or allow.ret is not None:
        ax.plot([], [], color="red", label="allowed")
    ex = extremes(p, res.model.program)
    for k, (a, t) in ex.items():
        if k != "dwell":
            ax.annotate(
                f"{math.degrees(a):.1f}",
                (math.degrees(t), math.degrees(a)),
                textcoords="offset points",
                xytext=(0, 4),
                ha="center",
                fontsize=8,
            )
    ax.set_xlabel("cam angle [deg]")
    ax.set_ylabel("pressure angle [deg]")
    ax.set_xlim(0, 360)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"{res.model.name}: pressure angle")
    fig.tight_layout()
    out.append(_save(fig, outdir / "pressure.png", plt))
    out.append(draw_cam(res, outdir / "cam.png"))
    return out


def _save(fig, path: Path, plt) -> Path:
    try:
        with replacing(path) as tmp:
            fig.savefig(tmp, dpi=120, format="png")
    finally:
        plt.close(fig)
    return path


def draw_cam(res: CamResult, path: Path, positions: int = 4) -> Path:
    """The cam at cam angle 0 with the follower drawn (by inversion) where it stands
    relative to the cam at a few cam angles: the start of each segment, and mid-rise."""
    plt = _plt()
    p = res.profile
    f = res.follower
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.plot(*(np.vstack([p.profile, p.profile[:1]]) * MM).T, "k-", lw=1.6, label="cam profile")
    if p.pitch is not None and f.contact == "roller":
        ax.plot(*(np.vstack([p.pitch, p.pitch[:1]]) * MM).T, "b--", lw=0.8, label="pitch curve")
    t = np.linspace(0, 2 * math.pi, 361)
    rb = f.base_radius * MM
    ax.plot(rb * np.cos(t), rb * np.sin(t), color="0.6", lw=0.6, label="base circle")
    ax.plot([0], [0], "k+", ms=10)
    n = p.theta.size
    picks = sorted({int(round(g.start / (2 * math.pi) * n)) % n
                    for g in res.model.program.segments if g.kind != "dwell"}
                   | {int(round((g.start + g.angle / 2) / (2 * math.pi) * n)) % n
                      for g in res.model.program.segments if g.kind == "rise"})  # fmt: skip
    picks = picks[: max(positions, 1)]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for c, i in zip(colors, picks):
        ang = -p.sense * p.theta[i]
        R = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
        lab = f"follower at {math.degrees(p.theta[i]):.0f} deg"
        pt = R @ p.point[i] * MM
        if f.oscillating:
            piv = R @ np.array([f.pivot, 0.0]) * MM
            ax.plot([piv[0], pt[0]], [piv[1], pt[1]], "-", color=c, lw=1.2, label=lab)
            ax.plot(*piv, "o", color=c, ms=4)
        else:
            top = R @ (p.point[i] + np.array([0.0, 0.6 * f.base_radius])) * MM
            ax.plot([pt[0], top[0]], [pt[1], top[1]], "-", color=c, lw=1.2, label=lab)
        if f.contact == "roller":
            ax.add_patch(plt.Circle(tuple(pt), f.roller * MM, fill=False, color=c, lw=1.0))
        if f.contact == "flat-faced":
            tdir = R @ np.array([-p.normal[i, 1], p.normal[i, 0]])
            half = 0.5 * f.base_radius * MM
            cp = R @ p.contact[i] * MM
            ends = np.array([cp - half * tdir, cp + half * tdir])
            ax.plot(ends[:, 0], ends[:, 1], "-", color=c, lw=2)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    sense = "ccw" if p.sense > 0 else "cw"
    ax.set_title(
        f"{res.model.name}: cam at 0 deg (turns {sense}),\nfollower by inversion", fontsize=10
    )
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout()
    return _save(fig, path, plt)
