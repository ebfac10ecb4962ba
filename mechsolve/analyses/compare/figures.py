"""The figures of one scheme for ``mechsolve compare``: its output's stroke and time
ratio, the output's velocity and its uniformity over the working stroke, the smallest
transmission angle, the driving torque, the largest joint reaction, the flywheel and the
requirements.

Each scheme is solved over one full turn of its crank at 0.1° (:func:`solve`, with the
plots' events added by :func:`for_plots`: the exact limit positions, load switches and
a cam program's joins).

Definitions (the same for every scheme, so that the columns compare):

* **The output** is one coordinate: a point's ``x`` or ``y`` (``C.x``), a slider's
  displacement along its guide (``ram_guide``) or a link's angle (a rocker:
  ``guide_bar``); a point alone (``C``) is the coordinate of the two that travels further.
  Default: the file's first ``outputs.points`` entry, else its first ``outputs.sliders``,
  else its first slider on the ground (see :func:`resolve_output`).
* **Stroke** (swing for a rocker) = the largest minus the smallest value over the turn.
  Each extreme is located between the samples where the output's rate changes sign, on
  the cubic Hermite interpolant of the rate (values and their derivatives, the output's
  acceleration, at both samples: error of order h^4 at h = 0.1°).
* **Time ratio** K = the crank's travel over the slower stroke / over the faster (>= 1).
  The **working stroke** is the slower one, as in every quick-return machine (for K = 1
  exactly, the stroke from the smaller value to the larger).
* **Mean working velocity** = stroke / time of the working stroke; **peak** velocities:
  the largest magnitude over each stroke.
* **Uniformity**: the coefficient of variation (standard deviation over mean) of the
  output's speed over the middle ``middle`` (default 80 %) of the working stroke, weighted
  by the displacement (each millimetre of the cut counts once: the mean is
  integral v ds / integral ds). The ends are left out because every reciprocating output
  must start and stop there: over the whole stroke the figure would mostly measure that
  unavoidable acceleration and braking, the same for every scheme, and say little about
  the cut itself, which in the seed's shaper runs over the middle 90 % only (no cutting
  force in the first and last 5 %). 0 is a perfectly uniform cut.
* **Transmission**: the smallest transmission angle of any loop over the turn (the exact
  minimum, :meth:`Results.transmission_angles`); the largest pressure angle is 90° minus it.
  A joint that reports its own pressure angle (a cam contact: between the common normal
  and the follower's motion) has its largest over the turn, at the 0.1° samples, apart:
  a loop's transmission angle does not see the cam.
* **Driving torque** along the crank's motion (positive: the motor drives): the largest
  magnitude, and the RMS and the mean over the turn (integrals over the crank angle; the
  mean is the driver's work over the turn, :meth:`Results.mean_effort`, exact between
  the samples, where the trapezoid would cross a cam law's jumps in acceleration).
* **Peak joint reaction**: the largest magnitude of any joint's reaction (a pin's force,
  a slider's normal force) over the turn, with the joint; joints whose reactions redundant
  constraints leave indeterminate are left out (said so).
* **Flywheel** for a coefficient of fluctuation delta, by the energy method of
  :func:`mechsolve.analyses.flywheel.size_flywheel` at the driver's speed (all schemes at
  the same speed): the largest energy excursion dE_max, the inertia the driver's shaft
  needs, dE_max / (omega^2 delta), and the flywheel beyond the machine's own mean inertia.
  Not checked by simulation here (``mechsolve flywheel`` does that).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mechsolve.base.errors import InputError
from mechsolve.model import GROUND, Mechanism
from mechsolve.model.validate import suggest
from mechsolve.results.results import Results
from mechsolve.results.run import for_plots, solve
from mechsolve.results.summary import unbounded_towards

STEP = math.radians(0.1)  # the comparison's sweep
TWO_PI = 2 * math.pi


@dataclass
class Output:
    """What "the output" of a scheme is: one coordinate and its rates."""

    spec: str  # as resolved: "C.x", "ram_guide", "guide_bar"
    kind: str  # "point", "slider" or "link"
    name: str
    component: str = ""  # "x" or "y" for a point

    @property
    def angular(self) -> bool:
        return self.kind == "link"

    def values(self, res: Results) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The coordinate (m or rad), its rate (m/s or rad/s) and its acceleration."""
        if self.kind == "point":
            m = res.point(self.name)
            c = self.component
            return getattr(m, c), getattr(m, "v" + c), getattr(m, "a" + c)
        if self.kind == "link":
            lk = res.link(self.name)
            return lk.angle, lk.omega, lk.alpha
        s = res.slider(self.name)  # a slider's travel
        return s.s, s.v, s.a


@dataclass
class SchemeFigures:
    """The figures of one scheme (SI: m, rad, s, N, J; see the module docstring)."""

    name: str
    file: str
    variant: str | None
    output: Output
    speed: float  # rad/s, the crank's
    stroke: float  # m, or rad for a rocker
    time_ratio: float
    work_travel: float  # rad of crank over the working stroke
    return_travel: float
    work_sign: int  # +1: the working stroke runs from the smaller value to the larger
    v_mean: float  # over the working stroke (m/s or rad/s)
    v_peak_work: float
    v_peak_return: float
    uniformity: float  # coefficient of variation over the middle of the working stroke
    v_band: tuple[float, float]  # the speed's range there
    middle: float
    transmission: float = math.nan  # rad
    transmission_loop: str = ""
    transmission_at: float = math.nan  # crank travel from the working stroke's start (rad)
    contact_pressure: float = math.nan  # rad, the largest at a cam contact
    contact_pressure_joint: str = ""
    contact_pressure_at: float = math.nan
    torque_peak: float = math.nan  # N m, the largest magnitude along the motion
    torque_peak_value: float = math.nan  # signed, along the motion
    torque_peak_at: float = math.nan
    torque_rms: float = math.nan
    torque_mean: float = math.nan
    reaction_peak: float = math.nan  # N
    reaction_joint: str = ""
    reaction_at: float = math.nan
    delta: float = math.nan
    energy_max: float = math.nan  # J
    inertia_needed: float = math.nan  # kg m^2
    inertia_own: float = math.nan
    flywheel: float = math.nan
    verdicts: list = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    # the curves over one turn, against the crank's travel from the start of the working
    # stroke (rad, 0 .. 2 pi): displacement from that start along the working stroke,
    # velocity along the working stroke, driving torque along the motion (or None)
    x: np.ndarray = field(default_factory=lambda: np.zeros(0))
    displacement: np.ndarray = field(default_factory=lambda: np.zeros(0))
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(0))
    torque: np.ndarray | None = None

    @property
    def failed(self) -> list[str]:
        """The names of the requirements that failed."""
        return [v.name for v in self.verdicts if not v.passed]

    @property
    def pressure(self) -> float:
        """The largest pressure angle (rad): 90° minus the smallest transmission angle."""
        return math.pi / 2 - self.transmission if math.isfinite(self.transmission) else math.nan


# -- the schemes and their outputs ------------------------------------------------------
def parse_scheme(text: str | Path) -> tuple[Path, str | None]:
    """``FILE`` or ``FILE@VARIANT`` (a file whose own name has an ``@`` is taken whole)."""
    text = str(text)
    if "@" in text and not Path(text).exists():
        file, _, variant = text.rpartition("@")
        if not variant:
            raise InputError(f"{text!r}: name the variant after '@' (FILE@VARIANT)")
        return Path(file), variant
    return Path(text), None


def resolve_output(mech: Mechanism, spec: str | None, where: str = "--output") -> Output:
    """The output of ``mech`` that ``spec`` names (see the module docstring), or its default.

    Raises :class:`InputError` naming ``where`` for a name the file does not have (with a
    did-you-mean), or when there is no default."""
    points = [p for p in _moving_points(mech)]
    sliders = [j.name for j in mech.sliders]
    links = [lk.name for lk in mech.links]
    if spec is None:
        if mech.outputs.points:
            return Output(mech.outputs.points[0], "point", mech.outputs.points[0])
        if mech.outputs.sliders:
            return Output(mech.outputs.sliders[0], "slider", mech.outputs.sliders[0])
        on_ground = [j.name for j in mech.sliders if GROUND in j.links]
        if on_ground:
            return Output(on_ground[0], "slider", on_ground[0])
        raise InputError(
            f"{mech.name}: which output to compare? The file declares no output point or "
            "slider and has no slider on the ground: give one with --output (a point's "
            "coordinate such as C.x, a slider or a rocker link)"
        )
    text = spec.strip()
    name, dot, comp = text.partition(".")
    if dot and name in points and comp in ("x", "y"):
        return Output(text, "point", name, comp)
    if dot and name in sliders and comp == "s":
        return Output(name, "slider", name)
    if dot and name in links and comp == "angle":
        return Output(name, "link", name)
    if not dot:
        if name in points:
            return Output(name, "point", name)
        if name in sliders:
            return Output(name, "slider", name)
        if name in links:
            return Output(name, "link", name)
    choices = [f"{p}.x" for p in points] + [f"{p}.y" for p in points] + points + sliders + links
    if dot and name in points:
        why = f"a point's coordinate is {name}.x or {name}.y"
    else:
        why = f"no point, slider or link named {name!r}"
    raise InputError(
        f"{where} {spec!r} for {mech.name}: {why}{suggest(text, choices)}; the output is a "
        f"point's coordinate (points: {', '.join(points) or 'none'}), a slider "
        f"({', '.join(sliders) or 'none'}) or a link's angle (a rocker: {', '.join(links)})"
    )


def _moving_points(mech: Mechanism) -> list[str]:
    out: list[str] = []
    for lk in mech.links:
        out += [p for p in lk.points if p not in out and p not in mech.ground]
    return out


def check_comparable(mech: Mechanism, label: str) -> float:
    """The crank's speed (rad/s) of a scheme ``compare`` can take: a revolute driver at a
    constant, non-zero speed (no motion law of time). Raises :class:`InputError`."""
    drv = mech.driver
    if drv is None:
        raise InputError(f"{label}: the file has no driver")
    if mech.joint(drv.joint).coordinate != "angle":
        raise InputError(
            f"{label}: its driver {drv.joint} is a slider; compare takes schemes driven by a "
            "crank (a revolute driver turning fully), whose stroke and time ratio compare"
        )
    if drv.motion is not None:
        raise InputError(
            f"{label}: its driver follows a motion law of time; compare takes cranks at a "
            "constant speed"
        )
    if drv.speed == 0:
        raise InputError(f"{label}: its driver's speed is 0 (at rest): give the crank's speed")
    return abs(float(drv.speed))


def full_turn(mech: Mechanism) -> Mechanism:
    """``mech`` swept over exactly one turn of its crank (a copy when the file's sweep is
    another range)."""
    if mech.sweep.travel is not None and abs(mech.sweep.travel - TWO_PI) < 1e-12:
        return mech
    out = copy.copy(mech)
    out.sweep = dataclasses.replace(mech.sweep, travel=TWO_PI)
    return out


def without_ties(mech: Mechanism) -> tuple[Mechanism, list[str]]:
    """``mech`` without its ties: links pinned to the ground at two points or more and
    joined to nothing else, on which no load acts (scheme 3's link 4 between the ground
    pivots). A tie cannot move, so its constraints are redundant and leaving it out
    changes no motion, no driving torque, no energy and no reaction of another joint (its
    own are indeterminate); the groups then solve the rest in closed form, with their
    transmission angles. Returns (the mechanism, the names of the ties left out)."""
    ties = []
    for lk in mech.links:
        joints = [j for j in mech.joints if lk.name in j.links]
        pins = [j for j in joints if j.coordinate == "angle" and GROUND in j.links]
        if len(pins) >= 2 and len(pins) == len(joints):
            if not any(lk.name in _load_links(ld) for ld in mech.loads):
                ties.append(lk.name)
    if not ties:
        return mech, []
    out = copy.copy(mech)
    out.__dict__.pop("_validated", None)
    out.links = [lk for lk in mech.links if lk.name not in ties]
    out.joints = [j for j in mech.joints if not set(j.links) & set(ties)]
    kept = {p for lk in out.links for p in lk.points} | set(mech.ground)
    o = mech.outputs
    out.outputs = dataclasses.replace(
        o,
        points=None if o.points is None else [p for p in o.points if p in kept],
        links=None if o.links is None else [n for n in o.links if n not in ties],
        relative=[r for r in o.relative if not set(r) & set(ties)],
    )
    return out.validate(), ties


def _load_links(load) -> set[str]:
    """Every name a load mentions (its link, its ends' links and points, its slider):
    a tie any load mentions is kept."""
    names: set[str] = set()

    def walk(v) -> None:
        if isinstance(v, str):
            names.add(v)
        elif isinstance(v, (list, tuple)):
            for x in v:
                walk(x)

    for f in dataclasses.fields(load):
        if f.name not in ("name", "when", "where"):
            walk(getattr(load, f.name))
    return names


# -- interpolation between samples --------------------------------------------------------
def _hermite(t: np.ndarray | float, h: float, y0, y1, d0, d1):
    """The cubic Hermite interpolant on [0, 1] (values y, derivatives d per unit x)."""
    t2, t3 = t * t, t * t * t
    return (
        (2 * t3 - 3 * t2 + 1) * y0
        + (t3 - 2 * t2 + t) * h * d0
        + (-2 * t3 + 3 * t2) * y1
        + (t3 - t2) * h * d1
    )


def _hermite_root(h: float, y0: float, y1: float, d0: float, d1: float) -> float:
    """The t in [0, 1] where the cubic Hermite interpolant of (y, d) crosses zero (y0 and
    y1 of opposite signs or zero); the linear interpolant's root if the cubic has none."""
    if y0 == 0:
        return 0.0
    if y1 == 0:
        return 1.0
    # coefficients of t^3, t^2, t, 1
    a = 2 * y0 + h * d0 - 2 * y1 + h * d1
    b = -3 * y0 - 2 * h * d0 + 3 * y1 - h * d1
    c = h * d0
    lin = y0 / (y0 - y1)
    roots = np.roots([a, b, c, y0]) if np.all(np.isfinite([a, b, c, y0])) else []
    real = [float(r.real) for r in roots if abs(r.imag) < 1e-9 and -1e-9 <= r.real <= 1 + 1e-9]
    if not real:
        return lin
    return min(max(min(real, key=lambda r: abs(r - lin)), 0.0), 1.0)


class _Cycle:
    """One turn of samples of the output, cyclic: the crank's travel x (rad, from the
    sweep's start, increasing), q, dq/dx and d2q/dx2, without the sample at 2 pi that
    repeats the first."""

    def __init__(self, x: np.ndarray, q: np.ndarray, rate: np.ndarray, acc: np.ndarray, w: float):
        keep = x < TWO_PI - 1e-9
        self.x = x[keep]
        self.q = q[keep]
        self.dq = rate[keep] / w
        self.ddq = acc[keep] / (w * w)

    def _interval(self, k: int) -> tuple[int, int, float]:
        n = len(self.x)
        j = (k + 1) % n
        h = (self.x[j] - self.x[k]) % TWO_PI
        return k % n, j, h

    def extreme(self, largest: bool) -> tuple[float, float]:
        """(x, q) at the largest (smallest) value, located between the samples."""
        k = int(np.argmax(self.q) if largest else np.argmin(self.q))
        best = (float(self.x[k]), float(self.q[k]))
        for i in (k - 1, k):
            a, b, h = self._interval(i)
            g0, g1 = self.dq[a], self.dq[b]
            if not (h > 0 and np.isfinite(g0) and np.isfinite(g1)) or g0 * g1 > 0:
                continue
            t = _hermite_root(h, g0, g1, self.ddq[a], self.ddq[b])
            q = float(_hermite(t, h, self.q[a], self.q[b], g0, g1))
            if (q > best[1]) if largest else (q < best[1]):
                best = (float((self.x[a] + t * h) % TWO_PI), q)
        return best

    def crossing(self, target: float, start: float, span: float, first: bool) -> float:
        """The crank travel (from ``start``, in [0, span]) where q first (last) crosses
        ``target`` between ``start`` and ``start + span``."""
        rel = (self.x - start) % TWO_PI
        order = np.argsort(rel)
        found = None
        for idx in range(len(order)):
            a = order[idx]
            b = order[(idx + 1) % len(order)]
            x0 = rel[a]
            h = (rel[b] - x0) % TWO_PI
            if x0 > span or h <= 0:
                continue
            y0, y1 = self.q[a] - target, self.q[b] - target
            if not (np.isfinite(y0) and np.isfinite(y1)) or y0 * y1 > 0:
                continue
            t = _hermite_root(h, y0, y1, self.dq[a], self.dq[b])
            found = x0 + t * h
            if first:
                return found
        if found is None:
            raise ValueError("no crossing")
        return found

    def rate_at(self, xr: float, start: float) -> float:
        """dq/dx at the crank travel ``xr`` from ``start`` (Hermite of the rate)."""
        x = (start + xr) % TWO_PI
        k = int(np.searchsorted(self.x, x, side="right")) - 1
        a, b, h = self._interval(k)
        t = ((x - self.x[a]) % TWO_PI) / h if h > 0 else 0.0
        return float(_hermite(t, h, self.dq[a], self.dq[b], self.ddq[a], self.ddq[b]))


# -- one scheme ---------------------------------------------------------------------------
def _turns_fully(name: str, res) -> None:
    """An :class:`InputError` unless the mechanism closes over the whole turn of ``res``:
    at every sample and between them (a dead zone the sweep steps over between two
    samples is a range where it cannot close, though every sample does)."""
    why = ""
    if not np.all(res.ok):
        bad = res.failures[0]
        why = f"{bad.reason} at {res.describe_u(bad.first)}"
    else:
        zones = [e for e in res.solution.events if e.kind == "dead zone"]
        if zones:
            e, fu = zones[0], res.format_u
            span = f"near {fu(e.u)}"
            if math.isfinite(e.edge_in) and math.isfinite(e.edge_out):
                span = f"between {fu(e.edge_in)} and {fu(e.edge_out)}"
            why = f"{e.group} cannot close {span}, a dead zone between two samples"
    if why:
        raise InputError(
            f"{name}: the mechanism cannot close over the whole turn ({why}): compare "
            "needs a crank that turns fully"
        )


def scheme_figures(
    mech: Mechanism,
    *,
    name: str,
    file: str = "",
    variant: str | None = None,
    output: str | None = None,
    delta: float = 1 / 40,
    middle: float = 0.8,
    method: str | None = None,
) -> SchemeFigures:
    """Solve ``mech`` over one turn and compute its figures (see the module docstring)."""
    w = check_comparable(mech, name)
    out = resolve_output(mech, output)
    solved, ties = without_ties(mech)
    turn = full_turn(solved)
    res = solve(turn, step=STEP, method=method, velocity=True, acceleration=True)
    _turns_fully(name, res)
    fine = for_plots(turn, res, method)
    _turns_fully(name, fine)
    d = turn.driver.direction
    x_all = d * (fine.u - fine.u[0])  # crank travel from the sweep's start (rad)
    if out.kind == "point" and not out.component:  # the coordinate that travels further
        m = fine.point(out.name)
        comp = "x" if np.ptp(m.x) >= np.ptp(m.y) else "y"
        out = Output(f"{out.name}.{comp}", "point", out.name, comp)
    q, rate, acc = out.values(fine)
    cyc = _Cycle(x_all, q, rate, acc, w)
    x_lo, q_lo = cyc.extreme(largest=False)
    x_hi, q_hi = cyc.extreme(largest=True)
    stroke = q_hi - q_lo
    moves = np.nanmax(np.abs(rate)) if np.any(np.isfinite(rate)) else 0.0
    if not (stroke > 1e-9 * max(1.0, abs(q_hi))) or not (moves > 0):
        raise InputError(f"{name}: the output {out.spec} does not move over the turn")
    if not (np.any(rate > 0) and np.any(rate < 0)):
        raise InputError(
            f"{name}: the output {out.spec} does not move back and forth over a turn (it "
            "turns fully or only one way): choose a reciprocating output with --output"
        )
    forward = (x_hi - x_lo) % TWO_PI  # crank travel from the low extreme to the high one
    back = TWO_PI - forward
    sign = 1 if forward >= back else -1  # the working stroke is the slower
    work, ret = (forward, back) if sign > 0 else (back, forward)
    start = x_lo if sign > 0 else x_hi
    tq = d * fine.driving_effort if fine.forces is not None else None
    xs, disp, vel, tq = _curves(
        x_all, start, sign * (q - (q_lo if sign > 0 else q_hi)), sign * rate, tq
    )
    in_work = xs <= work
    v_peak_work = float(np.nanmax(np.abs(vel[in_work])))
    v_peak_ret = float(np.nanmax(np.abs(vel[~in_work]))) if np.any(~in_work) else math.nan
    cv, band = _uniformity(cyc, start, work, q_lo, q_hi, sign, middle, w)
    fig = SchemeFigures(
        name=name,
        file=file,
        variant=variant,
        output=out,
        speed=w,
        stroke=stroke,
        time_ratio=max(work, ret) / min(work, ret),
        work_travel=work,
        return_travel=ret,
        work_sign=sign,
        v_mean=stroke * w / work,
        v_peak_work=v_peak_work,
        v_peak_return=v_peak_ret,
        uniformity=cv,
        v_band=band,
        middle=middle,
        x=xs,
        displacement=disp,
        velocity=vel,
        torque=tq,
    )
    _more(fig, mech, fine, turn, ties, start, delta, method)
    return fig


def _more(fig, mech, fine, turn, ties, start, delta, method) -> None:
    """The figures beyond the output's motion: transmission, forces, flywheel, the
    requirements (on the file's own sweep, as ``run`` checks them)."""
    if ties:
        fig.notes.append(
            f"{', '.join(ties)} joined only to the ground (a redundant tie) cannot move: "
            "solved without it, which changes no motion, torque, energy or other reaction"
        )
    _transmission(fig, fine, start, turn.driver.direction)
    if fine.forces is not None:
        _forces(fig, fine, turn.driver.direction * (fine.u - fine.u[0]), start)
        _flywheel(fig, turn, delta, fig.speed)
    else:
        fig.notes.append("no masses or loads: no torque, reactions or flywheel")
    if mech.requirements:
        from mechsolve.results.requirements import check_requirements

        fig.verdicts = check_requirements(mech, solve(mech, method=method))


def _curves(x_all, start, disp, vel, tq):
    """The curves over one turn against the crank's travel from the working stroke's
    start (0 .. 2 pi, the first sample again at 2 pi to close the turn)."""
    rel = (x_all - start) % TWO_PI
    keep = x_all < TWO_PI - 1e-9  # the sample at 2 pi repeats the first
    order = np.argsort(rel[keep], kind="stable")
    out = [rel[keep][order]] + [
        None if a is None else np.asarray(a)[keep][order] for a in (disp, vel, tq)
    ]
    out[0] = np.append(out[0], out[0][0] + TWO_PI)
    return [None if a is None else (a if k == 0 else np.append(a, a[0])) for k, a in enumerate(out)]


def _uniformity(cyc: _Cycle, start, work, q_lo, q_hi, sign, middle, w):
    """The displacement-weighted coefficient of variation of the speed over the middle
    ``middle`` of the working stroke, and the speed's range there (see the module)."""
    stroke = q_hi - q_lo
    edge = 0.5 * (1 - middle) * stroke
    qa, qb = (q_lo + edge, q_hi - edge) if sign > 0 else (q_hi - edge, q_lo + edge)
    try:
        xa = cyc.crossing(qa, start, work, first=True)
        xb = cyc.crossing(qb, start, work, first=False)
    except ValueError:
        return math.nan, (math.nan, math.nan)
    rel = (cyc.x - start) % TWO_PI
    inside = (rel > xa) & (rel < xb)
    order = np.argsort(rel[inside])
    xx = np.concatenate([[xa], rel[inside][order], [xb]])
    speed = np.abs(
        np.concatenate([[cyc.rate_at(xa, start)], cyc.dq[inside][order], [cyc.rate_at(xb, start)]])
    )
    speed = speed * w  # dq/dx * dx/dt: m/s (rad/s)
    ds = speed  # ds = |v| dt = |v| dx / w: the weight, up to the constant 1 / w
    total = np.trapezoid(ds, xx)
    mean = np.trapezoid(speed * ds, xx) / total
    var = np.trapezoid((speed - mean) ** 2 * ds, xx) / total
    return float(math.sqrt(max(var, 0.0)) / mean), (float(speed.min()), float(speed.max()))


def _transmission(fig: SchemeFigures, fine: Results, start: float, d: int) -> None:
    tr = fine.transmission_angles()
    if not tr:
        fig.notes.append("no loop with a transmission angle (no two-branch group)")
        return
    t = min(tr, key=lambda t: t.angle)
    fig.transmission = float(t.angle)
    fig.transmission_loop = t.group
    fig.transmission_at = float((d * (t.u - fine.u[0]) - start) % TWO_PI)


def _forces(fig: SchemeFigures, fine: Results, x_all: np.ndarray, start: float) -> None:
    f = fine.forces
    d = fine.mechanism.driver.direction
    T = d * fine.driving_effort  # along the motion
    ok = np.isfinite(T)
    x = x_all
    if np.any(ok):
        i = int(np.nanargmax(np.abs(T)))
        fig.torque_peak = float(abs(T[i]))
        fig.torque_peak_value = float(T[i])
        fig.torque_peak_at = float((x[i] - start) % TWO_PI)
        span = float(x[ok][-1] - x[ok][0])
        if np.all(ok) and span > 0:
            fig.torque_rms = float(math.sqrt(np.trapezoid(T**2, x) / span))
            fig.torque_mean = float(np.trapezoid(T, x) / span)
            mean, kind = fine.mean_effort()  # the work over the turn: exact between the
            if kind == "mean" and math.isfinite(mean):  # samples (across a cam law's jumps)
                fig.torque_mean = float(d * mean)
    _contact_pressure(fig, fine, x, start)
    best = None
    skipped: list[str] = []
    unbounded: list[str] = []
    towards: dict[str, list[str]] = {}
    for j in fine.mechanism.joints:
        r = f.reactions[j.name]
        comp = j.magnitude  # the joint's own: F (pin), N (slider, cam), Fn (gear, rack)
        if comp in f.nonunique.get(j.name, ()):
            skipped.append(j.name)
            continue
        mag = np.where(f.ok, np.abs(r[comp]), np.nan)
        if np.any(np.isfinite(mag)):
            i = int(np.nanargmax(mag))
            toward = unbounded_towards(fine, mag, i)
            if toward is not None:  # its largest sample is only the one nearest a toggle
                unbounded.append(j.name)
                towards.setdefault(toward, []).append(j.name)
            elif best is None or mag[i] > best[0]:
                best = (float(mag[i]), j.name, float((x[i] - start) % TWO_PI))
    if unbounded:  # no peak: "unbounded" in the table, blank in the CSV
        best = (math.inf, ", ".join(unbounded), math.nan)
    for toward, names in towards.items():
        fig.notes.append(f"the reactions at {', '.join(names)} grow without bound towards {toward}")
    if best is not None:
        fig.reaction_peak, fig.reaction_joint, fig.reaction_at = best
    if skipped:
        fig.notes.append(
            "reactions left out of the peak (indeterminate: redundant constraints): "
            + ", ".join(skipped)
        )


def _contact_pressure(fig: SchemeFigures, fine: Results, x: np.ndarray, start: float) -> None:
    """The largest pressure angle of the joints that report one (cam contacts)."""
    f = fine.forces
    best = None
    for j in fine.mechanism.joints:
        if "pressure_angle" not in dict(j.components):
            continue
        pa = np.where(f.ok, f.reactions[j.name]["pressure_angle"], np.nan)
        if np.any(np.isfinite(pa)):
            i = int(np.nanargmax(pa))
            if best is None or pa[i] > best[0]:
                best = (float(pa[i]), j.name, float((x[i] - start) % TWO_PI))
    if best is not None:
        fig.contact_pressure = math.radians(best[0])
        fig.contact_pressure_joint, fig.contact_pressure_at = best[1], best[2]


def _flywheel(fig: SchemeFigures, mech: Mechanism, delta: float, w: float) -> None:
    from mechsolve.analyses.flywheel import size_flywheel

    fig.delta = delta
    try:
        fw = size_flywheel(mech, delta, omega_mean=w, check=False)
    except InputError as exc:
        fig.notes.append(f"no flywheel: {exc.message}")
        return
    fig.energy_max = fw.energy_max
    fig.inertia_needed = fw.energy_max / (w * w * delta)
    fig.inertia_own = fw.J_mean
    fig.flywheel = fw.J_flywheel
