"""The CSV a user reads: every column's values, in its header's unit, against references
computed here without mechsolve.

``mechsolve run FILE -o DIR --no-plots`` is run (in-process with click's CliRunner and in
a real subprocess) on small mechanisms whose every reported quantity has a closed form or
a hand Newton-Euler solution (tests/handcalc.py, tests/closed_form.py, tests/refsol.py):

* a crank-rocker four-bar with a coupler point, a point on a rocker whose frame is turned
  90 degrees from its pin line, uniform bars, gravity, a spring, a torque and a load that
  acts only while the coupler point moves right;
* an offset slider-crank driven clockwise from 30 degrees, with masses off the pin lines
  (so the slider's moment is not zero) and a force on the piston;
* a non-Grashof four-bar driven through a full turn: the positions where its loop cannot
  close must keep their rows, with empty cells and a status naming the loop.

The file is read back with the csv module. Each header is split into a name and a unit
and must be exactly the expected set (every point, link, slider, joint and load named,
every quantity with its unit); each column is compared with the reference in that unit
(angles in degrees, unwrapped along the sweep, the first value in [0, 360)). The values
must also equal the in-memory Results to 12 significant digits, and a streamed CSV must
hold the same cells as the one-piece CSV.
"""

from __future__ import annotations

import csv
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.cli.main import main

from closed_form import fourbar_disc, slider_crank
from handcalc import fourbar_kinematics
from refsol import Body, Rigid, newton_euler

G = 9.81
DEG = math.pi / 180

# -- the mechanisms -------------------------------------------------------------------------

FOURBAR_YAML = """\
name: csv four-bar
units: {length: mm, angle: deg}
ground:
  O2: [10, -5]
  O4: [100, -5]
links:
  crank: {points: {O2: [0, 0], A: [30, 0]}, mass: 0.05 kg, uniform_bar: [O2, A]}
  coupler:
    points: {A: [0, 0], B: [100, 0], P: {length: 50, angle: 35}}
    mass: 0.2 kg
    uniform_bar: [A, B]
  rocker:
    points: {O4: [0, 0], B: [0, 70], R: [20, 30]}
    mass: 0.11 kg
    uniform_bar: [O4, B]
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {joint: O2, speed: 45 rpm, start: 20 deg}
sweep: {range: 360 deg, step: STEP}
gravity: 9.81 m/s^2
loads:
  pull: {force: [3 N, -2 N], at: P, when: P.vx > 0}
  # O4 is a point of the ground and of the rocker: 'on' anchors the spring to the ground
  k1: {spring: [P, O4], on: [coupler, ground], stiffness: 150 N/m, free_length: 60 mm}
  brake: {torque: -0.02 N m, on: rocker}
"""
FB = dict(a=0.03, b=0.1, c=0.07, d=0.09, O2=(0.01, -0.005), w2=45 * 2 * math.pi / 60)
FB_P = (0.05 * math.cos(35 * DEG), 0.05 * math.sin(35 * DEG))  # on the coupler, from A
FB_R = (0.02, 0.03)  # on the rocker, whose frame's y axis runs O4 -> B
FB_MASS = dict(crank=0.05, coupler=0.2, rocker=0.11)
FB_PULL, FB_K, FB_L0, FB_BRAKE = (3.0, -2.0), 150.0, 0.06, -0.02

SLIDER_YAML = """\
name: csv slider-crank
units: {length: mm, angle: deg}
ground:
  O: [0, 0]
links:
  crank: {points: {O: [0, 0], A: [50, 0], G1: [-5, 0]}, mass: 2.4 kg, com: G1,
          inertia: 0.004 kg m^2}
  rod: {points: {A: [0, 0], C: [200, 0], G: [60, 0]}, mass: 0.9 kg, com: G,
        inertia: 0.0045 kg m^2}
  piston: {points: {C: [0, 0], Gp: [15, 5]}, mass: 0.6 kg, com: Gp, inertia: 0.001 kg m^2}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cylinder: {slider: [ground, piston], point: C, line: {through: [-20, 10], angle: 0}}
assembly:
  - C.x > A.x
driver: {joint: O, speed: 600 rpm, direction: cw, start: 30 deg}
sweep: {range: 360 deg, step: 6 deg}
gravity: 9.81 m/s^2
loads:
  push: {force: [-300 N, 0], at: C, on: piston}
"""
SC = dict(r=0.05, l=0.2, e=0.01, x0=-0.02, w2=-600 * 2 * math.pi / 60)
SC_PTS = dict(crank=dict(A=(0.05, 0.0), G1=(-0.005, 0.0)), rod=dict(C=(0.2, 0), G=(0.06, 0)))
SC_MASS = dict(crank=(2.4, (-0.005, 0.0), 0.004), rod=(0.9, (0.06, 0.0), 0.0045))
SC_PISTON = (0.6, (0.015, 0.005), 0.001)
SC_PUSH = (-300.0, 0.0)

NONGRASHOF_YAML = """\
name: csv non-Grashof four-bar
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [80, 0]}
links:
  crank: {points: {O2: [0, 0], A: [60, 0]}}
  coupler: {points: {A: [0, 0], B: [40, 0]}}
  rocker: {points: {O4: [0, 0], B: [50, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: [B left of A -> O4]
driver: {joint: O2, speed: 2 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 7 deg}
"""
NG = dict(a=0.06, b=0.04, c=0.05, d=0.08, w2=2.0)


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# -- running and reading --------------------------------------------------------------------


def run_cli(path: Path, out: Path, how: str = "inprocess") -> str:
    """``mechsolve run path -o out --no-plots --units SI``; returns the printed summary.
    (The closed forms here are in SI; without ``--units SI`` a file in mm writes mm.)"""
    args = ["run", str(path), "-o", str(out), "--no-plots", "--units", "SI"]
    if how == "subprocess":
        p = subprocess.run(
            [sys.executable, "-m", "mechsolve", *args],
            capture_output=True,
            text=True,
            timeout=120,
            cwd=path.parent,
        )
        code, text = p.returncode, p.stdout + p.stderr
    else:
        r = CliRunner().invoke(main, args)
        code, text = r.exit_code, r.output
    # one exit-code rule (README, Exit codes): positions that do not close are a result,
    # exit 0, said on stderr as a warning
    assert code == 0, text
    if "non-Grashof" in path.read_text():
        assert "warning: the results are incomplete" in text
    return text


HEADER = re.compile(r"(?P<name>\S+) \[(?P<unit>[^\[\]]+)\]")


class Table:
    """A results.csv read with the csv module: ``cols[name] = (unit, floats)``, NaN for
    an empty cell."""

    def __init__(self, path: Path) -> None:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
        self.header, self.rows = rows[0], rows[1:]
        assert self.header[0] == "step", self.header[:3]
        assert self.header[-2:] == ["status", "solver.method"], self.header[-2:]
        assert all(len(r) == len(self.header) for r in self.rows)
        assert [r[0] for r in self.rows] == [str(i) for i in range(len(self.rows))]
        self.status = [r[-2] for r in self.rows]
        self.method = [r[-1] for r in self.rows]
        self.cols: dict[str, tuple[str, np.ndarray]] = {}
        self.cells: dict[str, list[str]] = {}
        for k, h in enumerate(self.header[1:-2], start=1):
            m = HEADER.fullmatch(h)
            assert m, f"header {h!r} is not 'name [unit]'"
            name = m["name"]
            assert name not in self.cols, f"two columns named {name}"
            cells = [r[k] for r in self.rows]
            self.cells[name] = cells
            self.cols[name] = (m["unit"], np.array([float(c) if c else np.nan for c in cells]))

    def __len__(self) -> int:
        return len(self.rows)


class Ref:
    """An expected column: unit, values; the tolerance is ``rtol |ref| + atol``, with
    ``atol`` by default ``1e-11`` of the column's largest value."""

    def __init__(self, unit: str, values, rtol: float = 1e-9, atol: float | None = None):
        self.unit, self.values, self.rtol, self.atol = unit, np.asarray(values, float), rtol, atol


def check_table(table: Table, expected: dict[str, Ref]) -> None:
    """Every column is expected (and every expected column is there), with the expected
    unit, empty exactly where the reference is NaN, and within tolerance elsewhere."""
    names = set(table.cols)
    assert names == set(expected), (
        f"missing {sorted(set(expected) - names)}, unexpected {sorted(names - set(expected))}"
    )
    n = len(table)
    for name, want in expected.items():
        unit, got = table.cols[name]
        assert unit == want.unit, f"{name}: unit [{unit}], expected [{want.unit}]"
        ref = np.broadcast_to(want.values, (n,))
        empty, nan = np.isnan(got), np.isnan(ref)
        assert np.array_equal(empty, nan), (
            f"{name}: empty cells at {np.flatnonzero(empty)}, expected at {np.flatnonzero(nan)}"
        )
        if nan.all():
            continue
        g, r = got[~nan], ref[~nan]
        atol = want.atol if want.atol is not None else 1e-11 * float(np.max(np.abs(r)))
        err = np.abs(g - r)
        tol = want.rtol * np.abs(r) + atol
        i = int(np.argmax(err - tol))
        assert np.all(err <= tol), (
            f"{name} [{unit}]: row {np.flatnonzero(~nan)[i]}: {g[i]!r} != {r[i]!r} "
            f"(error {err[i]:.3g} > {tol[i]:.3g})"
        )


# -- independent references -----------------------------------------------------------------


def unwrapped_deg(th) -> np.ndarray:
    """An angle (rad) in degrees, continuous over the finite values, the first in [0, 360)."""
    out = np.array(th, float)
    good = np.isfinite(out)
    deg = np.degrees(np.unwrap(out[good]))
    out[good] = deg - 360.0 * math.floor(deg[0] / 360.0)
    return out


def vector_tol(v) -> float:
    """Absolute tolerance of a vector's components (they may stay at or pass through
    zero): 1e-11 of the vector's largest magnitude."""
    return 1e-11 * float(np.nanmax(np.hypot(v[0], v[1])))


def point_refs(name: str, P, vP, aP) -> dict[str, Ref]:
    p, v, a = vector_tol(P), vector_tol(vP), vector_tol(aP)
    return {
        f"{name}.x": Ref("m", P[0], atol=p),
        f"{name}.y": Ref("m", P[1], atol=p),
        f"{name}.vx": Ref("m/s", vP[0], atol=v),
        f"{name}.vy": Ref("m/s", vP[1], atol=v),
        f"{name}.ax": Ref("m/s^2", aP[0], atol=a),
        f"{name}.ay": Ref("m/s^2", aP[1], atol=a),
    }


def link_refs(name: str, th, w, al, w_scale: float | None = None) -> dict[str, Ref]:
    """``w_scale``: the driver's speed, for a link that does not turn (rates zero)."""
    ws = None if w_scale is None else 1e-11 * w_scale
    return {
        f"{name}.angle": Ref("deg", unwrapped_deg(th), atol=None if ws is None else 1e-11),
        f"{name}.omega": Ref("rad/s", w, atol=ws),
        f"{name}.alpha": Ref("rad/s^2", al, atol=None if ws is None else ws * w_scale),
    }


def pin_refs(label: str, F) -> dict[str, Ref]:
    scale = vector_tol(F)
    return {
        f"{label}.Fx": Ref("N", F[0], atol=scale),
        f"{label}.Fy": Ref("N", F[1], atol=scale),
        f"{label}.F": Ref("N", np.hypot(F[0], F[1])),
    }


def rcond2(c1, c2) -> np.ndarray:
    """Reciprocal 2-norm condition number of the 2x2 matrices with columns c1, c2."""
    M = np.stack([np.stack([c1[0], c2[0]], -1), np.stack([c1[1], c2[1]], -1)], -2)
    return 1.0 / np.linalg.cond(M)


def driver_refs(th0_deg: float, step_deg: float, n: int, w2: float) -> tuple[np.ndarray, dict]:
    """The driver angle (rad) at each row and the time and driver columns."""
    sign = 1.0 if w2 > 0 else -1.0
    travel = step_deg * np.arange(n)
    th2 = np.radians(th0_deg + sign * travel)
    return th2, {
        "t": Ref("s", np.radians(travel) / abs(w2)),
        "input.angle": Ref("deg", th0_deg + sign * travel),
        "input.travel": Ref("deg", travel),
    }


def energy_refs(parts, power_input, kinetic_rate, potential_rate, power_loads, V, T):
    scale = max(float(np.max(np.abs(x))) for x in parts)
    return {
        "energy.kinetic": Ref("J", T),
        "energy.potential": Ref("J", V),
        "power.input": Ref("W", power_input, atol=1e-11 * scale),
        "power.kinetic_rate": Ref("W", kinetic_rate, atol=1e-11 * scale),
        "power.potential_rate": Ref("W", potential_rate, atol=1e-11 * scale),
        "power.loads": Ref("W", power_loads, atol=1e-11 * scale),
        # P_driver - dT/dt - dV/dt + P_loads: zero, to rounding of the largest term
        "power.residual": Ref("W", np.zeros_like(T), atol=1e-12 * scale),
    }


def solver_refs(rcond, ok) -> dict[str, Ref]:
    return {
        "jacobian.rcond": Ref("-", np.where(ok, rcond, np.nan)),
        "solver.iterations": Ref("-", 0.0),  # closed form: no iterations
        "solver.residual": Ref("m", np.where(ok, 0.0, np.nan), atol=1e-15),  # closes exactly
    }


def fourbar_reference(step_deg: float) -> dict[str, Ref]:
    """Every column of FOURBAR_YAML, from the closed form and a Newton-Euler solution."""
    a, b, c, d, w2 = FB["a"], FB["b"], FB["c"], FB["d"], FB["w2"]
    n = int(round(360 / step_deg)) + 1
    th2, exp = driver_refs(20.0, step_deg, n, w2)
    k = fourbar_kinematics(a, b, c, d, th2, w2, side=1)
    th3, th4, w3, w4, al3, al4 = (k[s] for s in ("th3", "th4", "w3", "w4", "al3", "al4"))
    O2 = np.array(FB["O2"])[:, None] + np.zeros(n)
    O4 = O2 + np.array([[d], [0.0]])
    zero = np.zeros((2, n))
    crank = Rigid(O2, zero, zero, th2, np.full(n, w2), np.zeros(n))
    A, vA, aA = crank.pos((a, 0)), crank.vel((a, 0)), crank.acc((a, 0))
    coupler = Rigid(A, vA, aA, th3, w3, al3)
    rocker = Rigid(O4, zero, zero, th4 - math.pi / 2, w4, al4)  # its frame: y along O4 -> B
    B = coupler.pos((b, 0))
    np.testing.assert_allclose(B, rocker.pos((0, c)), atol=1e-15)  # the reference closes
    np.testing.assert_allclose(B - O2, k["B"], atol=1e-15)
    P, vP, aP = coupler.pos(FB_P), coupler.vel(FB_P), coupler.acc(FB_P)
    exp.update(point_refs("A", A, vA, aA))
    exp.update(point_refs("B", B, coupler.vel((b, 0)), coupler.acc((b, 0))))
    exp.update(point_refs("P", P, vP, aP))
    exp.update(point_refs("R", rocker.pos(FB_R), rocker.vel(FB_R), rocker.acc(FB_R)))
    exp.update(link_refs("crank", th2, np.full(n, w2), np.zeros(n)))
    exp.update(link_refs("coupler", th3, w3, al3))
    exp.update(link_refs("rocker", th4 - math.pi / 2, w4, al4))

    # forces: uniform bars, gravity, the spring P-O4, the pull while P moves right, a torque
    active = vP[0] > 0
    assert 5 < active.sum() < n - 5  # the condition switches within the sweep
    pull = np.array(FB_PULL)[:, None] * active
    dvec = O4 - P
    L = np.hypot(*dvec)
    tension = FB_K * (L - FB_L0)
    spring = tension * dvec / L  # on P, towards O4
    Ldot = -(dvec[0] * vP[0] + dvec[1] * vP[1]) / L
    bars = {"crank": (crank, (a / 2, 0), a), "coupler": (coupler, (b / 2, 0), b)}
    bars["rocker"] = (rocker, (0, c / 2), c)
    bodies = {}
    T = np.zeros(n)
    V = 0.5 * FB_K * (L - FB_L0) ** 2
    Tdot = np.zeros(n)
    Vdot = tension * Ldot
    for name, (lk, gc, length) in bars.items():
        m = FB_MASS[name]
        J = m * length**2 / 12
        bodies[name] = Body(lk).mass(m, gc, J)
        v, acc = lk.vel(gc), lk.acc(gc)
        T += 0.5 * m * (v[0] ** 2 + v[1] ** 2) + 0.5 * J * lk.w**2
        Tdot += m * (v[0] * acc[0] + v[1] * acc[1]) + J * lk.w * lk.al
        V = V + m * G * lk.pos(gc)[1]
        Vdot = Vdot + m * G * v[1]
    bodies["coupler"].force(P, pull).force(P, spring)
    bodies["rocker"].torque = FB_BRAKE
    sol = newton_euler(
        bodies,
        [
            ("pin", "O2", "ground", "crank", O2),
            ("pin", "A", "crank", "coupler", A),
            ("pin", "B", "coupler", "rocker", B),
            ("pin", "O4", "ground", "rocker", O4),
            ("driver", "input", "crank"),
        ],
        gravity=(0.0, -G),
    )
    torque = sol["input"]
    exp["input.torque"] = Ref("N*m", torque, atol=1e-11 * float(np.max(np.abs(torque))))
    exp.update(pin_refs("O2(ground->crank)", sol["O2"]))
    exp.update(pin_refs("A(crank->coupler)", sol["A"]))
    exp.update(pin_refs("B(coupler->rocker)", sol["B"]))
    exp.update(pin_refs("O4(ground->rocker)", sol["O4"]))
    exp["load.pull.active"] = Ref("-", active.astype(float))
    p_in = torque * w2
    p_loads = pull[0] * vP[0] + pull[1] * vP[1] + FB_BRAKE * w4
    exp.update(energy_refs((p_in, Tdot, Vdot, p_loads), p_in, Tdot, Vdot, p_loads, V, T))
    # the RRR dyad's rates (w3, w4) solve a 2x2 system whose columns are unit normals of
    # the coupler's and the rocker's lines
    e3n = np.array([-np.sin(th3), np.cos(th3)])
    e4n = np.array([-np.sin(th4), np.cos(th4)])
    exp.update(solver_refs(rcond2(e3n, e4n), np.ones(n, bool)))
    return exp


def slider_reference() -> dict[str, Ref]:
    """Every column of SLIDER_YAML."""
    r, l, e, w2 = SC["r"], SC["l"], SC["e"], SC["w2"]
    n = 61
    th2, exp = driver_refs(30.0, 6.0, n, w2)
    x, xd, xdd, phi, phid, phidd = slider_crank(r, l, e, th2, w2, ahead=True)
    zero = np.zeros((2, n))
    crank = Rigid(zero, zero, zero, th2, np.full(n, w2), np.zeros(n))
    A, vA, aA = crank.pos((r, 0)), crank.vel((r, 0)), crank.acc((r, 0))
    rod = Rigid(A, vA, aA, phi, phid, phidd)
    C = np.array([x, np.full(n, e)])
    piston = Rigid(C, np.array([xd, 0 * xd]), np.array([xdd, 0 * xdd]), *np.zeros((3, n)))
    np.testing.assert_allclose(rod.pos((l, 0)), C, atol=1e-15)
    for name, lk in (("crank", crank), ("rod", rod)):
        for p, loc in SC_PTS[name].items():
            exp.update(point_refs(p, lk.pos(loc), lk.vel(loc), lk.acc(loc)))
    gp = SC_PISTON[1]
    exp.update(point_refs("Gp", piston.pos(gp), piston.vel(gp), piston.acc(gp)))
    exp.update(link_refs("crank", th2, np.full(n, w2), np.zeros(n)))
    exp.update(link_refs("rod", phi, phid, phidd))
    # the block keeps the orientation of its (ground) guide: angle 0, no rotation
    exp.update(link_refs("piston", np.zeros(n), np.zeros(n), np.zeros(n), abs(w2)))
    exp["cylinder.s"] = Ref("m", x - SC["x0"])  # along the line from its 'through' point
    exp["cylinder.v"] = Ref("m/s", xd)
    exp["cylinder.a"] = Ref("m/s^2", xdd)

    bodies, T, V, Tdot, Vdot = {}, np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    for name, lk, (m, gc, J) in (
        ("crank", crank, SC_MASS["crank"]),
        ("rod", rod, SC_MASS["rod"]),
        ("piston", piston, SC_PISTON),
    ):
        bodies[name] = Body(lk).mass(m, gc, J)
        v, acc = lk.vel(gc), lk.acc(gc)
        T += 0.5 * m * (v[0] ** 2 + v[1] ** 2) + 0.5 * J * lk.w**2
        Tdot += m * (v[0] * acc[0] + v[1] * acc[1]) + J * lk.w * lk.al
        V += m * G * lk.pos(gc)[1]
        Vdot += m * G * v[1]
    push = np.array(SC_PUSH)[:, None] + np.zeros(n)
    bodies["piston"].force(C, push)
    O = np.zeros((2, n))
    sol = newton_euler(
        bodies,
        [
            ("pin", "O", "ground", "crank", O),
            ("pin", "A", "crank", "rod", A),
            ("pin", "C", "rod", "piston", C),
            ("slider", "cylinder", "ground", "piston", C, (np.zeros(n), np.ones(n))),
            ("driver", "input", "crank"),
        ],
        gravity=(0.0, -G),
    )
    torque = sol["input"]
    exp["input.torque"] = Ref("N*m", torque, atol=1e-11 * float(np.max(np.abs(torque))))
    exp.update(pin_refs("O(ground->crank)", sol["O"]))
    exp.update(pin_refs("A(crank->rod)", sol["A"]))
    exp.update(pin_refs("C(rod->piston)", sol["C"]))
    N, M = sol["cylinder"]
    assert np.max(np.abs(M)) > 0.5  # the piston's centre is off C: a real moment
    fs = 1e-11 * float(np.max(np.abs(N)))
    lab = "cylinder(ground->piston)"
    exp[f"{lab}.N"] = Ref("N", N, atol=fs)  # along the line's left normal, +y
    exp[f"{lab}.M"] = Ref("N*m", M, atol=1e-11 * float(np.max(np.abs(M))))
    exp[f"{lab}.Fx"] = Ref("N", np.zeros(n), atol=fs)
    exp[f"{lab}.Fy"] = Ref("N", N, atol=fs)
    p_in = torque * w2
    p_loads = push[0] * xd
    exp.update(energy_refs((p_in, Tdot, Vdot, p_loads), p_in, Tdot, Vdot, p_loads, V, T))
    # the RRP dyad's rates (rod omega, slider velocity): columns the rod's unit normal and
    # the line's direction
    rn = np.array([-np.sin(phi), np.cos(phi)])
    exp.update(solver_refs(rcond2(rn, np.array([np.ones(n), np.zeros(n)])), np.ones(n, bool)))
    return exp


def nongrashof_reference() -> tuple[dict[str, Ref], np.ndarray]:
    """Every column of NONGRASHOF_YAML, NaN where the loop cannot close; and that mask."""
    a, b, c, d, w2 = NG["a"], NG["b"], NG["c"], NG["d"], NG["w2"]
    n = 53  # 360 / 7 = 51.4: 52 steps of 7 degrees and the end of the turn
    exp = {}
    travel = np.minimum(7.0 * np.arange(n), 360.0)
    th2 = np.radians(travel)
    exp["t"] = Ref("s", th2 / w2)
    exp["input.angle"] = Ref("deg", travel)
    exp["input.travel"] = Ref("deg", travel)
    disc = fourbar_disc(a, b, c, d, th2)
    ok = disc > 0
    assert 10 < ok.sum() < n - 10 and np.min(np.abs(disc)) > 1e-3 * np.max(np.abs(disc))
    nan = np.full(n, np.nan)
    th3, th4, w3, w4, al3, al4 = (nan.copy() for _ in range(6))
    k = fourbar_kinematics(a, b, c, d, th2[ok], w2, side=1)
    for arr, key in zip((th3, th4, w3, w4, al3, al4), ("th3", "th4", "w3", "w4", "al3", "al4")):
        arr[ok] = k[key]
    zero = np.zeros((2, n))
    crank = Rigid(zero, zero, zero, th2, np.full(n, w2), np.zeros(n))
    # the crank is driven: its pin and angle are known where the loop cannot close
    exp.update(point_refs("A", crank.pos((a, 0)), crank.vel((a, 0)), crank.acc((a, 0))))
    coupler = Rigid(crank.pos((a, 0)), crank.vel((a, 0)), crank.acc((a, 0)), th3, w3, al3)
    exp.update(point_refs("B", coupler.pos((b, 0)), coupler.vel((b, 0)), coupler.acc((b, 0))))
    exp.update(link_refs("crank", th2, np.full(n, w2), np.zeros(n)))
    exp.update(link_refs("coupler", th3, w3, al3))
    exp.update(link_refs("rocker", th4, w4, al4))
    e3n = np.array([-np.sin(th3), np.cos(th3)])
    e4n = np.array([-np.sin(th4), np.cos(th4)])
    with np.errstate(invalid="ignore"):
        rc = rcond2(np.nan_to_num(e3n), np.nan_to_num(e4n))
    exp.update(solver_refs(rc, ok))
    return exp, ok


# -- the tests ------------------------------------------------------------------------------


@pytest.mark.parametrize("how", ["inprocess", "subprocess"])
def test_fourbar_every_column(tmp_path, how):
    path = write(tmp_path, "fb.yaml", FOURBAR_YAML.replace("STEP", "5 deg"))
    run_cli(path, tmp_path / "out", how)
    table = Table(tmp_path / "out" / "results.csv")
    assert len(table) == 73
    check_table(table, fourbar_reference(5.0))
    assert table.status == ["ok"] * 73 and table.method == ["closed form"] * 73


@pytest.mark.parametrize("how", ["inprocess", "subprocess"])
def test_offset_slider_crank_every_column(tmp_path, how):
    path = write(tmp_path, "sc.yaml", SLIDER_YAML)
    run_cli(path, tmp_path / "out", how)
    table = Table(tmp_path / "out" / "results.csv")
    assert len(table) == 61
    check_table(table, slider_reference())
    assert table.status == ["ok"] * 61 and table.method == ["closed form"] * 61


def test_unassemblable_rows_are_empty_and_name_the_loop(tmp_path):
    path = write(tmp_path, "ng.yaml", NONGRASHOF_YAML)
    run_cli(path, tmp_path / "out")
    table = Table(tmp_path / "out" / "results.csv")
    exp, ok = nongrashof_reference()
    assert len(table) == len(ok)
    # solver.iterations: no iterations where solved; nothing to count where not
    its = table.cols.pop("solver.iterations")
    assert its[0] == "-" and np.all((its[1] == 0) | np.isnan(its[1]))
    del exp["solver.iterations"]
    check_table(table, exp)
    for i in np.flatnonzero(ok):
        assert table.status[i] == "ok" and table.method[i] == "closed form"
    for i in np.flatnonzero(~ok):
        st = table.status[i]
        assert st.startswith("unassemblable") and "loop B" in st, st
        assert "coupler" in st and "rocker" in st, st
        assert table.method[i] == ""
        for name in table.cols:  # every quantity of the loop that cannot close is empty
            if name.split(".")[0] in ("B", "coupler", "rocker", "jacobian", "solver"):
                assert table.cells[name][i] == "", (i, name)


def in_memory(res: ms.Results) -> dict[str, np.ndarray]:
    """The Results arrays by CSV column name, in the units of the README (named accessors
    for the quantities a user asks for; the table's own columns for the bookkeeping)."""
    out = {c.name: np.asarray(c.values, float) for c in res.columns()}
    out["t"] = res.t
    out["input.angle"] = np.degrees(res.u)
    out["input.travel"] = np.degrees(np.abs(res.u - res.u[0]))
    for p in res.point_names():
        m = res.point(p)
        for q in ("x", "y", "vx", "vy", "ax", "ay"):
            out[f"{p}.{q}"] = getattr(m, q)
    for ln in res.link_names():
        m = res.link(ln)
        out[f"{ln}.angle"] = np.degrees(m.angle)
        out[f"{ln}.omega"], out[f"{ln}.alpha"] = m.omega, m.alpha
    for sn in res.slider_names():
        m = res.slider(sn)
        out[f"{sn}.s"], out[f"{sn}.v"], out[f"{sn}.a"] = m.s, m.v, m.a
    if res.forces is not None:
        out["input.torque"] = res.driving_effort
        for j in res.mechanism.joints:
            for comp, v in res.reaction(j.name).items():
                out[f"{res.joint_label(j.name)}.{comp}"] = np.where(res.forces.ok, v, np.nan)
    return out


@pytest.mark.parametrize(
    "name,text", [("fb", FOURBAR_YAML), ("sc", SLIDER_YAML), ("ng", NONGRASHOF_YAML)]
)
def test_twelve_significant_digits_round_trip(tmp_path, name, text):
    """The cells hold the in-memory values to 12 significant digits (a relative 1e-11): a
    writer that keeps 6 digits fails."""
    path = write(tmp_path, f"{name}.yaml", text.replace("STEP", "5 deg"))
    run_cli(path, tmp_path / "out")
    table = Table(tmp_path / "out" / "results.csv")
    mem = in_memory(ms.run(path))
    assert set(mem) == set(table.cols)
    digits = 0
    for col, (_, got) in table.cols.items():
        want = np.asarray(mem[col], float)
        assert np.array_equal(np.isnan(got), np.isnan(want)), col
        g, w = got[~np.isnan(got)], want[~np.isnan(want)]
        np.testing.assert_allclose(g, w, rtol=1e-11, atol=0, err_msg=col)
        for cell in table.cells[col]:  # the digits written
            mant = cell.lstrip("-").split("e")[0].replace(".", "").lstrip("0")
            digits = max(digits, len(mant))
    assert digits >= 12


def test_streamed_csv_equals_the_one_piece_csv(tmp_path, monkeypatch):
    """A run of 201 positions above MECHSOLVE_STREAM_ABOVE=50 is streamed; its cells are
    those of the one-piece CSV, which are right; so are those of a stream in chunks of 37
    positions."""
    path = write(tmp_path, "fb.yaml", FOURBAR_YAML.replace("STEP", "1.8 deg"))
    monkeypatch.delenv("MECHSOLVE_STREAM_ABOVE", raising=False)
    text = run_cli(path, tmp_path / "one")
    assert "streamed in" not in text
    one = Table(tmp_path / "one" / "results.csv")
    assert len(one) == 201
    check_table(one, fourbar_reference(1.8))
    power = max(float(np.max(np.abs(one.cols[c][1]))) for c in ("power.input", "power.loads"))
    monkeypatch.setenv("MECHSOLVE_STREAM_ABOVE", "50")
    text = run_cli(path, tmp_path / "streamed")
    assert "streamed in" in text, text
    summary, _ = ms.stream(ms.load(path), tmp_path / "chunks.csv", chunk=37)
    assert summary.chunks == 6
    for other in (tmp_path / "streamed" / "results.csv", tmp_path / "chunks.csv"):
        streamed = Table(other)
        assert streamed.header == one.header
        assert streamed.status == one.status and streamed.method == one.method
        for col in one.cols:
            if col == "power.residual":  # rounding noise (1e-16 W), not identical
                _, a = streamed.cols[col]
                assert np.max(np.abs(a - one.cols[col][1])) <= 1e-12 * power
                continue
            assert streamed.cells[col] == one.cells[col], (other.name, col)


def test_streamed_unassemblable_rows_equal_the_one_piece_csv(tmp_path, monkeypatch):
    """The non-Grashof sweep streamed in chunks of 10 (its dead zone spans three chunk
    boundaries) writes the cells, empty ones and statuses of the one-piece CSV."""
    path = write(tmp_path, "ng.yaml", NONGRASHOF_YAML)
    monkeypatch.delenv("MECHSOLVE_STREAM_ABOVE", raising=False)
    run_cli(path, tmp_path / "one")
    one = Table(tmp_path / "one" / "results.csv")
    summary, _ = ms.stream(ms.load(path), tmp_path / "chunks.csv", chunk=10)
    assert summary.chunks == 6 and len(summary.failures) == 1
    streamed = Table(tmp_path / "chunks.csv")
    assert streamed.header == one.header
    assert streamed.status == one.status and streamed.method == one.method
    assert streamed.cells == one.cells
    assert sum(s.startswith("unassemblable") for s in one.status) == 29
