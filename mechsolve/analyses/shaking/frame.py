"""The shaking force and moment: what the moving links transmit to the frame.

At every position the frame receives, through each joint that joins it to a moving
link (and through the driver, whose motor is taken to sit on the frame), the opposite
of the constraint force that joint exerts on the link. The force analysis solves
``Phi_q^T lambda = Q`` (:mod:`mechsolve.core.kinetostatics`), so the constraint's
generalised force on the moving body ``b`` is ``-Phi_b^T lambda`` (force components and
moment about ``b``'s frame origin) and the frame receives ``+Phi_b^T lambda``: every
joint kind answers through its own Jacobian blocks, a slider's moment and a gear's
tooth force included, without the analysis knowing the kind. A higher pair's
separating force on a gear fixed to the frame (:meth:`Constraint.separating`) is added
as the point force it is.

Sign convention: the shaking force ``(Fx, Fy)`` and the shaking moment ``M`` (counter-
clockwise positive, about a chosen point P, the frame's origin by default) are the load
ON THE FRAME. Newton-Euler for the moving links with no loads and gravity off gives::

    F = -sum m_i a_Gi = -dp/dt
    M_P = -sum (J_i alpha_i + m_i (r_Gi - P) x a_Gi) = -dH_P/dt

the second including the reaction of the driving torque (the motor's stator is on the
frame); with gravity and loads, their resultant is added (``F = W + F_loads - dp/dt``).
Springs and dampers anchored on the frame load it directly, outside its joints: they
are not in these figures and the summary says so.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from mechsolve.base.units import SI_OUTPUT, OutputUnits
from mechsolve.model import GROUND, Mechanism
from mechsolve.results.results import Column, Results


@dataclass
class Shaking:
    """The shaking force and moment over a sweep.

    Attributes
    ----------
    results
        The solved sweep with its force analysis.
    fx, fy
        The shaking force on the frame (N), per position (NaN where not determined).
    moment
        The shaking moment on the frame about :attr:`about` (N m, counter-clockwise).
    about
        The point P of the moment (m, global), and ``about_name`` how it was given.
    inertia_only
        True when gravity and the file's loads were switched off (the textbook shaking
        force: inertia forces only).
    """

    results: Results
    fx: np.ndarray
    fy: np.ndarray
    moment: np.ndarray
    about: tuple[float, float] = (0.0, 0.0)
    about_name: str = "the frame's origin"
    inertia_only: bool = False
    notes: list[str] = field(default_factory=list)

    @property
    def force(self) -> np.ndarray:
        """The magnitude of the shaking force (N)."""
        return np.hypot(self.fx, self.fy)

    @property
    def ok(self) -> np.ndarray:
        return np.isfinite(self.fx) & np.isfinite(self.fy) & np.isfinite(self.moment)

    def columns(self) -> list[Column]:
        """The CSV columns: the driver, the force's components and magnitude, the moment."""
        r = self.results
        kind, unit = ("input.s", "m") if r.linear else ("input.angle", "deg")
        at = f"about {self.about_name}"
        return [
            Column("t", "s", r.t),
            Column(kind, unit, r.driver_value),
            Column("shaking.Fx", "N", self.fx, "on the frame"),
            Column("shaking.Fy", "N", self.fy, "on the frame"),
            Column("shaking.F", "N", self.force),
            Column("shaking.M", "N*m", self.moment, f"on the frame, ccw, {at}"),
        ]

    # what the CSV writer reads (mechsolve.results.csv)
    def __len__(self) -> int:
        return len(self.results)

    def status(self) -> list[str]:
        return self.results.status()

    def methods(self) -> list[str]:
        return self.results.methods()

    def figures(self) -> dict[str, tuple[float, float, str]]:
        """Peak and RMS of the force's magnitude and of the moment: ``name -> (value,
        driver value at the peak (report units) or NaN, how it was found)``.

        A peak is the largest sample (the sweep's step decides how close it is to the
        true peak); an RMS over a full turn with no gaps is the mean square over the turn
        by the trapezoidal rule in the driver's coordinate (exact to rounding for a smooth
        periodic motion sampled uniformly), otherwise the RMS of the solved samples."""
        r = self.results
        ok = self.ok
        out: dict[str, tuple[float, float, str]] = {}
        if not np.any(ok):
            return out
        whole = bool(np.all(ok)) and r.is_full_cycle() and len(r.u) > 2
        for name, v in (("force", self.force), ("moment", self.moment)):
            a = np.abs(np.where(ok, v, np.nan))
            i = int(np.nanargmax(a))
            out[f"peak {name}"] = (float(a[i]), float(r.driver_value[i]), "largest sample")
            if whole:  # the trapezoidal rule over the turn (a last step may be shorter)
                du = np.diff(r.u)
                mean = float(np.sum(du * (v[1:] ** 2 + v[:-1] ** 2) / 2) / (r.u[-1] - r.u[0]))
                out[f"RMS {name}"] = (math.sqrt(mean), math.nan, "over the turn")
            else:
                rms = math.sqrt(float(np.nanmean(np.where(ok, v * v, np.nan))))
                out[f"RMS {name}"] = (rms, math.nan, "of the solved samples")
        return out

    def summary_lines(self, units: OutputUnits | None = None) -> list[str]:
        """The summary: peak and RMS of the force and the moment, with units: ``units``
        (default SI: N, N*m, the driver in deg or m)."""
        r = self.results
        u = units or SI_OUTPUT
        k_at, unit = u.convert("m" if r.linear else "deg")
        lines = [
            "shaking force and moment on the frame"
            + (" (inertia forces only: gravity and loads off)" if self.inertia_only else "")
            + f", moment about {self.about_name}:"
        ]
        figs = self.figures()
        if not figs:
            return lines + ["  not determined at any position"]
        for key, (val, at, how) in figs.items():
            k, un = u.convert("N" if key.endswith("force") else "N*m")
            where = f" at {_fmt(at * k_at)} {unit}" if math.isfinite(at) else ""
            lines.append(f"  {key:<13} {_fmt(val * k)} {un}{where} ({how})")
        bad = int(np.sum(~self.ok))
        if bad:
            lines.append(f"  {bad} position(s) not determined (left blank)")
        return lines + [f"  note: {n}" for n in self.notes]


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def frame_load(res: Results, about: tuple[float, float] = (0.0, 0.0)):
    """The load on the frame (Fx, Fy in N; moment about ``about`` in N m) from a sweep
    with its force analysis: the sum over the constraints that touch the frame of
    ``Phi_b^T lambda`` (see the module's docstring), and the friction of those joints."""
    if res.forces is None:
        raise ValueError("the sweep has no force analysis")
    an = res.analysis
    sys_ = an.system
    st = res.solution.state
    lam = res.forces.lam
    nb = sys_.nb
    n = st.n
    fx, fy, mo = np.zeros(n), np.zeros(n), np.zeros(n)
    for row in sys_.rows:
        c = row.constraint
        if nb not in c.bodies:
            continue
        lc = lam[:, row.start : row.start + c.m]  # (N, m)
        for body, blk in c.jacobian(st).items():  # blk (m, 3, N)
            if body == nb:
                continue
            gx, gy, gm = np.einsum("mkn,nm->kn", blk, lc)
            fx += gx
            fy += gy
            mo += gm + st.x[body] * gy - st.y[body] * gx  # about the global origin
        for b, px, py, sx, sy in c.separating(st, lc) or ():
            if b == nb:  # a tooth force on a gear fixed to the frame
                fx += sx
                fy += sy
                mo += px * sy - py * sx
    fric = res.forces.friction
    for row in sys_.rows if fric is not None else ():
        c = row.constraint
        t = fric.friction.get(c.name)
        if t is None or nb not in c.bodies:
            continue
        for body, x, y, ux, uy, tq in c.friction_pull(st):
            if body == nb:  # the friction the links' slip puts on the frame
                fx += t * ux
                fy += t * uy
                mo += t * (tq + x * uy - y * ux)
    px, py = about
    mo = mo - (px * fy - py * fx)
    bad = ~res.forces.ok
    for a in (fx, fy, mo):
        a[bad] = np.nan
    return fx, fy, mo


def inertia_only(mech: Mechanism) -> Mechanism:
    """The same mechanism with gravity and loads off: its frame load is the inertia
    forces' alone (the textbook shaking force)."""
    m = copy.copy(mech)
    m.gravity = (0.0, 0.0)
    m.loads = []
    return m


def frame_anchored(mech: Mechanism) -> list[str]:
    """The loads that act on the frame outside its joints (a spring or damper with an
    end on the ground): the shaking figures leave them out."""
    out = []
    for load in mech.loads:
        ends = getattr(load, "ends", None) or ()
        slider = getattr(load, "slider", None)
        if any(e[0] == GROUND for e in ends) or (
            slider is not None and mech.joint(slider).links[0] == GROUND
        ):
            out.append(load.name)
    return out


def shaking(
    mech: Mechanism,
    *,
    about: tuple[float, float] = (0.0, 0.0),
    about_name: str = "the frame's origin",
    step: float | None = None,
    inertia: bool = False,
) -> Shaking:
    """The shaking force and moment of ``mech`` over its sweep.

    Parameters
    ----------
    about
        The point of the moment (m, global).
    step
        The sweep's step (rad, or m), default the file's.
    inertia
        Switch gravity and the loads off (the inertia forces alone).
    """
    from mechsolve.results.run import solve

    model = inertia_only(mech) if inertia else mech
    res = solve(model, step=step, forces=True)
    fx, fy, mo = frame_load(res, about)
    notes = []
    anchored = [] if inertia else frame_anchored(mech)
    if anchored:
        notes.append(
            "the spring(s) or damper(s) "
            + ", ".join(repr(a) for a in anchored)
            + " act on the frame outside its joints and are not included"
        )
    return Shaking(res, fx, fy, mo, about, about_name, inertia, notes)
