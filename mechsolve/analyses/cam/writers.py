"""Files of a cam: the motion table and the profile as CSV, the profile as DXF (with
ezdxf, an optional dependency: ``pip install "mechsolve[cam]"``), and plots."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from mechsolve.analyses.cam.analysis import CamResult, face_offsets
from mechsolve.analyses.cam.design import extremes
from mechsolve.base.atomic import replacing

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
    L = res.model.unit
    u, v = L.name, L.speed  # lengths in the file's unit; speeds in m/s or in/s, ft/s
    vf = 1.0 if L.metric else 1.0 / L.factor
    if osc:
        names = ["swing [deg]", "angular velocity [rad/s]", "angular acceleration [rad/s^2]",
                 "angular jerk [rad/s^3]"]  # fmt: skip
        s = np.degrees(t.s)
        vf = 1.0
    else:
        names = [f"displacement [{u}]", f"velocity [{v}/s]", f"acceleration [{v}/s^2]",
                 f"jerk [{v}/s^3]"]  # fmt: skip
        s = L(t.s)
    sn = "ccw" if t.sense > 0 else "cw"
    on = "ccw" if o.sense > 0 else "cw"
    header = ["cam angle [deg]", *names,
              f"pressure angle {sn} [deg]", f"pressure angle {on} [deg]"]  # fmt: skip
    cols = [np.degrees(t.theta), s, t.ds * w * vf, t.d2s * w**2 * vf, t.d3s * w**3 * vf,
            np.degrees(t.pressure), np.degrees(o.pressure)]  # fmt: skip
    if t.pitch is not None:
        header += [f"pitch x [{u}]", f"pitch y [{u}]"]
        cols += [L(t.pitch[:, 0]), L(t.pitch[:, 1])]
    header += [f"profile x [{u}]", f"profile y [{u}]"]
    cols += [L(t.profile[:, 0]), L(t.profile[:, 1])]
    if t.rho_pitch is not None:
        header.append(f"pitch curvature radius [{u}]")
        cols.append(L(t.rho_pitch))
    header.append(f"profile curvature radius [{u}]")
    cols.append(L(t.rho_profile))
    if res.follower.contact == "flat-faced":
        header.append(
            f"contact along the face [{u}]" if osc else f"contact offset from the axis [{u}]"
        )
        cols.append(L(face_offsets(t)))
    header.append("undercut [1/0]")
    cols.append(t.undercut(res.model.allowance.rho_min).astype(float))
    return _atomic_csv(path, header, zip(*cols))


def write_profile_csv(res: CamResult, path: Path) -> Path:
    """The dense profile (and pitch curve) in the cam's frame, drawn at cam angle 0."""
    p = res.profile
    L = res.model.unit
    u = L.name
    header = ["cam angle [deg]", f"profile x [{u}]", f"profile y [{u}]"]
    cols = [np.degrees(p.theta), L(p.profile[:, 0]), L(p.profile[:, 1])]
    if p.pitch is not None:
        header += [f"pitch x [{u}]", f"pitch y [{u}]"]
        cols += [L(p.pitch[:, 0]), L(p.pitch[:, 1])]
    return _atomic_csv(path, header, zip(*cols))


def write_dxf(res: CamResult, path: Path) -> Path | None:
    """The profile (layer PROFILE), the pitch curve (PITCH), the base circle (BASE: the
    smallest circle touching the profile; for a roller, PRIME too: the roller centre's)
    and the cam centre, in the file's length unit, as closed polylines. None when ezdxf is
    not installed."""
    try:
        import ezdxf
    except ImportError:
        return None
    from mechsolve.writers.drawing import dxf_unit_code, imperial_codes

    L = res.model.unit
    code = dxf_unit_code(L.name)  # by the unit's size: "inch" and "µm" are named too
    k = 1.0 / L.factor if code is not None else MM  # a unit DXF does not name: mm
    doc = ezdxf.new("R2010")
    doc.units = code if code is not None else ezdxf.units.MM
    doc.header["$MEASUREMENT"] = 0 if code in imperial_codes() else 1
    msp = doc.modelspace()
    for name, color in (("PROFILE", 7), ("PITCH", 3), ("BASE", 8), ("PRIME", 5), ("CENTRE", 1)):
        doc.layers.add(name, color=color)
    p = res.profile
    f = res.follower
    msp.add_lwpolyline((p.profile * k).tolist(), close=True, dxfattribs={"layer": "PROFILE"})
    if p.pitch is not None and f.contact == "roller":
        msp.add_lwpolyline((p.pitch * k).tolist(), close=True, dxfattribs={"layer": "PITCH"})
        msp.add_circle((0, 0), f.base_radius * k, dxfattribs={"layer": "PRIME"})
    msp.add_circle((0, 0), _base_circle(res) * k, dxfattribs={"layer": "BASE"})
    r = 0.05 * f.base_radius * k
    msp.add_line((-r, 0), (r, 0), dxfattribs={"layer": "CENTRE"})
    msp.add_line((0, -r), (0, r), dxfattribs={"layer": "CENTRE"})
    with replacing(path) as tmp:
        doc.saveas(tmp)
    return path


def _base_circle(res: CamResult) -> float:
    """The cam's base circle (m): the prime circle less the roller, for a roller."""
    f = res.follower
    return f.base_radius - f.roller if f.contact == "roller" else f.base_radius


def _plt():
    from mechsolve.writers.fonts import pyplot

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
    L = res.model.unit
    u, v = L.name, L.speed
    vf = 1.0 if L.metric else 1.0 / L.factor
    if osc:
        labels = ["swing psi [deg]", "angular velocity [rad/s]",
                  "angular acceleration [rad/s^2]", "angular jerk [rad/s^3]"]  # fmt: skip
        ys = [np.degrees(p.s), p.ds * w, p.d2s * w**2, p.d3s * w**3]
    else:
        labels = [f"displacement s [{u}]", f"velocity [{v}/s]", f"acceleration [{v}/s^2]",
                  f"jerk [{v}/s^3]"]  # fmt: skip
        ys = [L(p.s), p.ds * w * vf, p.d2s * w**2 * vf, p.d3s * w**3 * vf]
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
                f"{math.degrees(a):.1f}°",  # the unit, as the summary gives it
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


def _save(fig, path: Path, plt, tight: bool = False) -> Path:
    """Write ``fig`` (``tight``: cropped to what is drawn, with a small margin)."""
    from mechsolve.writers.plots import pretty_figure

    pretty_figure(fig)
    extra = {"bbox_inches": "tight", "pad_inches": 0.12} if tight else {}
    try:
        with replacing(path) as tmp:
            fig.savefig(tmp, dpi=120, format="png", **extra)
    finally:
        plt.close(fig)
    return path


def draw_cam(res: CamResult, path: Path, positions: int = 4) -> Path:
    """The cam at cam angle 0 with the follower drawn (by inversion) where it stands
    relative to the cam at a few cam angles: the start of each segment, and mid-rise."""
    plt = _plt()
    p = res.profile
    f = res.follower
    MM = 1.0 / res.model.unit.factor  # noqa: N806 - the drawing's scale: the file's unit
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.plot(*(np.vstack([p.profile, p.profile[:1]]) * MM).T, "k-", lw=1.6, label="cam profile")
    if p.pitch is not None and f.contact == "roller":
        ax.plot(*(np.vstack([p.pitch, p.pitch[:1]]) * MM).T, "b--", lw=0.8, label="pitch curve")
    t = np.linspace(0, 2 * math.pi, 361)
    rb = _base_circle(res) * MM
    ax.plot(rb * np.cos(t), rb * np.sin(t), color="0.6", lw=0.6, label="base circle")
    if f.contact == "roller":
        rp = f.base_radius * MM
        ax.plot(rp * np.cos(t), rp * np.sin(t), color="0.6", ls=":", lw=0.6,
                label="prime circle")  # fmt: skip
    ax.plot([0], [0], "k+", ms=10)
    n = p.theta.size
    picks = sorted({int(round(g.start / (2 * math.pi) * n)) % n
                    for g in res.model.program.segments if g.kind != "dwell"}
                   | {int(round((g.start + g.angle / 2) / (2 * math.pi) * n)) % n
                      for g in res.model.program.segments if g.kind == "rise"})  # fmt: skip
    picks = picks[: max(positions, 1)]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    face = res.face_extent() if f.contact == "flat-faced" else None
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
            # the face as wide as it needs to be (the contact's range along it), drawn
            # from its reference point: the axis, or the foot of the pivot's perpendicular
            m = p.normal[i]
            if f.oscillating:  # as face_offsets measures: along J m from the foot
                ref, along = np.array([f.pivot, 0.0]) - f.offset * m, np.array([-m[1], m[0]])
            else:  # x - e from the axis x = e
                ref, along = np.array([f.offset, p.contact[i, 1]]), np.array([1.0, 0.0])
            ends = np.array([R @ (ref + k * along) * MM for k in (face[0], face[1])])
            ax.plot(ends[:, 0], ends[:, 1], "-", color=c, lw=2)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.set_xlabel(f"x [{res.model.unit.name}]")
    ax.set_ylabel(f"y [{res.model.unit.name}]")
    sense = "ccw" if p.sense > 0 else "cw"
    ax.set_title(
        f"{res.model.name}: cam at 0 deg (turns {sense}),\nfollower by inversion", fontsize=10
    )
    _fit(fig, ax)
    return _save(fig, path, plt, tight=True)


def _fit(fig, ax, width: float = 7.0) -> None:
    """Size ``fig`` to the drawing: the axes as wide as ``width`` inches and as tall as
    the drawing's aspect (equal scales) makes them, the legend in columns below, so that
    the sheet has no blank band (a square sheet around a wide drawing was half empty)."""
    ax.autoscale_view()
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    ratio = min(max((y1 - y0) / max(x1 - x0, 1e-12), 0.3), 2.0)
    handles, _ = ax.get_legend_handles_labels()
    rows = math.ceil(len(handles) / 3)
    legend = 0.25 + 0.2 * rows  # inches below the axes for the legend
    fig.set_size_inches(width + 1.0, width * ratio + 1.3 + legend)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=3, frameon=False)
    fig.tight_layout()
