"""Every force element and mass description of the file format, by value.

Each case is a four-bar (or a slider-crank) with one element added. The reference is a
free-body solution written body by body (tests/refsol.py: ``newton_euler``) on kinematics
in closed form (tests/handcalc.py), never mechsolve's own output: the driving torque and
every joint reaction are compared at 15 positions. A power balance alone would not do:
it never involves the reactions, and it holds whatever the accelerations are as long as
they are used consistently.

Point masses are given to the reference as separate particles, each with its own inertia
force, so the parallel-axis term of the combined link is checked, not repeated.
"""

from __future__ import annotations

import numpy as np
import pytest

import mechsolve as ms

from handcalc import fourbar_kinematics, slider_crank_kinematics
from refsol import Body, Rigid, newton_euler

# --- the four-bar --------------------------------------------------------------------
a_, b_, c_, d_ = 0.3, 1.1, 0.8, 1.0
W2 = 2.5
G1 = (0.2, 0.9)  # a ground anchor for springs
LOCAL = {
    "crank": {"O2": (0.0, 0.0), "A": (a_, 0.0), "E": (-0.1, 0.05)},
    "coupler": {"A": (0.0, 0.0), "B": (b_, 0.0), "P": (0.7, 0.25), "Q": (0.4, -0.15)},
    "rocker": {"O4": (0.0, 0.0), "B": (c_, 0.0), "R": (0.5, -0.1)},
}
OWNER = {"E": "crank", "P": "coupler", "Q": "coupler", "R": "rocker"}
# base mass properties (mass, com, inertia), as given in the file
BASE = {
    "crank": (2.0, (0.12, 0.02), 0.02),
    "coupler": (5.0, (0.5, -0.07), 0.6),
    "rocker": (3.5, (0.35, 0.04), 0.2),
}


def _mass_yaml(link):
    m, g, J = BASE[link]
    return f"mass: {m} kg, com: {list(g)}, inertia: {J} kg m^2"


def fourbar_text(masses: dict, loads: str, gravity: str = "9.81 m/s^2", w2=W2) -> str:
    pts = {k: ", ".join(f"{p}: {list(v)}" for p, v in LOCAL[k].items()) for k in LOCAL}
    ms_ = {k: masses.get(k, _mass_yaml(k)) for k in LOCAL}
    lines = "\n".join(f"  {k}: {{points: {{{pts[k]}}}, {ms_[k]}}}" for k in LOCAL)
    return f"""
ground: {{O2: [0, 0], O4: [{d_}, 0], G1: {list(G1)}}}
links:
{lines}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: {w2} rad/s, start: 10 deg}}
sweep: {{range: 360 deg, step: 25 deg}}
gravity: {gravity}
loads:
{loads}
"""


class FourBar:
    """Closed-form motion of the four-bar (handcalc) as rigid links, and the free bodies."""

    def __init__(self, th2, w2=W2):
        k = fourbar_kinematics(a_, b_, c_, d_, th2, w2, 1)
        z = np.zeros_like(th2)
        crank = Rigid((0.0, 0.0), (0.0, 0.0), (0.0, 0.0), th2, z + w2, z)
        A = k["A"]
        self.links = {
            "crank": crank,
            "coupler": Rigid(A, crank.vel(LOCAL["crank"]["A"]), crank.acc(LOCAL["crank"]["A"]),
                             k["th3"], k["w3"], k["al3"]),
            "rocker": Rigid((d_, 0.0), (0.0, 0.0), (0.0, 0.0), k["th4"], k["w4"], k["al4"]),
        }  # fmt: skip
        self.bodies = {n: Body(lk) for n, lk in self.links.items()}
        self.n = len(th2)

    def pos(self, name, link=None):
        if name == "G1":
            return np.array(G1, float)[:, None] + np.zeros((2, self.n))
        link = link or OWNER[name]
        return self.links[link].pos(LOCAL[link][name])

    def vel(self, name, link=None):
        if name == "G1":
            return np.zeros((2, self.n))
        link = link or OWNER[name]
        return self.links[link].vel(LOCAL[link][name])

    def base_masses(self, skip=()):
        for n, (m, g, J) in BASE.items():
            if n not in skip:
                self.bodies[n].mass(m, g, J)

    def solve(self, gravity=(0.0, -9.81)):
        z = self.pos("A", "crank")
        joints = [
            ("pin", "O2", "ground", "crank", z * 0),
            ("pin", "A", "crank", "coupler", z),
            ("pin", "B", "coupler", "rocker", self.pos("B", "rocker")),
            ("pin", "O4", "ground", "rocker", self.pos("O4", "rocker")),
            ("driver", "T", "crank"),
        ]
        return newton_euler(self.bodies, joints, gravity)


def two_point(fb: FourBar, p, q, tension):
    """Equal and opposite forces pulling p and q together with ``tension`` (N)."""
    P, Q = fb.pos(p), fb.pos(q)
    e = (Q - P) / np.hypot(*(Q - P))
    for name, X, sgn in ((p, P, 1.0), (q, Q, -1.0)):
        if name != "G1":
            fb.bodies[OWNER[name]].force(X, sgn * tension * e)


def spring_tension(fb, p, q, k, L0):
    return k * (np.hypot(*(fb.pos(q) - fb.pos(p))) - L0)


def damper_tension(fb, p, q, c):
    d = fb.pos(q) - fb.pos(p)
    e = d / np.hypot(*d)
    return c * np.sum(e * (fb.vel(q) - fb.vel(p)), axis=0)


# each case: YAML mass overrides, the loads section, the gravity, and the reference
# (a function adding the case's masses and loads to the free bodies, returning the gravity
# vector and the masks of conditional loads)
def _spring_ground(fb):
    two_point(fb, "P", "G1", spring_tension(fb, "P", "G1", 300.0, 0.5))


def _spring_moving(fb):
    two_point(fb, "P", "R", spring_tension(fb, "P", "R", 500.0, 0.3))


def _spring_when(fb):
    on = fb.vel("R")[1] > 0
    two_point(fb, "E", "R", on * spring_tension(fb, "E", "R", 400.0, 0.6))
    return {"k": on}


def _damper(fb):
    two_point(fb, "P", "R", damper_tension(fb, "P", "R", 40.0))


def _drag(fb):
    fb.bodies["coupler"].force(fb.pos("P"), -25.0 * fb.vel("P"))


def _force_global(fb):
    fb.bodies["coupler"].force(fb.pos("P"), np.array([40.0, -25.0])[:, None])


def _force_link(fb):
    fb.bodies["coupler"].force(fb.pos("Q"), fb.links["coupler"].vec((30.0, 12.0)))


def _force_direction(fb):
    F = 35.0 * np.array([np.cos(np.radians(120)), np.sin(np.radians(120))])
    fb.bodies["rocker"].force(fb.pos("B", "rocker"), F[:, None])


def _force_direction_link(fb):
    t = np.radians(-35.0)
    fb.bodies["rocker"].force(fb.pos("R"), fb.links["rocker"].vec((18 * np.cos(t), 18 * np.sin(t))))


def _torques(fb):
    fb.bodies["rocker"].torque += -3.0
    fb.bodies["coupler"].torque += 1.7


def _force_when(fb):
    on = fb.vel("P")[0] < 0
    fb.bodies["coupler"].force(fb.pos("P"), on * np.array([0.0, -60.0])[:, None])
    tq_on = fb.links["coupler"].w > 0
    fb.bodies["rocker"].torque += 2.5 * tq_on
    return {"cut": on, "hold": tq_on}


def _point_masses(fb):
    m, g, J = BASE["coupler"]
    fb.bodies["coupler"].mass(m, g, J).mass(1.5, LOCAL["coupler"]["P"]).mass(
        0.8, LOCAL["coupler"]["Q"]
    )
    # only point masses: no base body, the combined link has the particles' inertia
    fb.bodies["rocker"].mass(1.2, LOCAL["rocker"]["B"]).mass(2.0, LOCAL["rocker"]["R"])


def _uniform_bar(fb):
    fb.bodies["rocker"].mass(3.5, (c_ / 2, 0.0), 3.5 * c_**2 / 12)
    fb.bodies["crank"].mass(2.0, (a_ / 2, 0.0), 2.0 * a_**2 / 12)


def _weight_com(fb):
    fb.bodies["crank"].mass(19.62 / 9.81, LOCAL["crank"]["E"])  # weight, com a point
    fb.bodies["coupler"].mass(5.0, LOCAL["coupler"]["P"], 0.6)  # com a point name


NONE = "  none: {torque: 0, on: rocker}"
CASES = {
    "spring to ground": (
        {},
        "  k: {spring: [P, G1], stiffness: 300 N/m, free_length: 0.5}",
        _spring_ground,
    ),
    "spring between links": (
        {},
        "  k: {spring: [P, R], stiffness: 500 N/m, free_length: 300 mm}",
        _spring_moving,
    ),
    "spring with a condition": (
        {},
        '  k: {spring: [E, R], stiffness: 400 N/m, free_length: 0.6, when: "R.vy > 0"}',
        _spring_when,
    ),
    "damper between points": ({}, "  c: {damper: [P, R], coefficient: 40 N s/m}", _damper),
    "drag": ({}, "  air: {drag: P, coefficient: 25 N s/m}", _drag),
    "force global": ({}, "  F: {force: [40 N, -25 N], at: P}", _force_global),
    "force in the link frame": ({}, "  F: {force: [30 N, 12 N], at: Q, frame: link}", _force_link),
    "force by direction": (
        {},
        "  F: {force: 35 N, direction: 120 deg, at: B, on: rocker}",
        _force_direction,
    ),
    "force by direction in the link frame": (
        {},
        "  F: {force: 18 N, direction: -35 deg, at: R, frame: link}",
        _force_direction_link,
    ),
    "torques": (
        {},
        "  t4: {torque: -3 N m, on: rocker}\n  t3: {torque: 1.7 N m, on: coupler}",
        _torques,
    ),
    "conditional loads": (
        {},
        '  cut: {force: [0, -60 N], at: P, when: "P.vx < 0"}\n'
        '  hold: {torque: 2.5 N m, on: rocker, when: "coupler.omega > 0"}',
        _force_when,
    ),
    "point masses": (
        {
            "coupler": "mass: 5 kg, com: [0.5, -0.07], inertia: 0.6 kg m^2, "
            "point_masses: {P: 1.5 kg, Q: 0.8 kg}",
            "rocker": "point_masses: {B: 1.2 kg, R: 2 kg}",
        },
        NONE,
        _point_masses,
    ),
    "uniform bars": (
        {
            "rocker": "mass: 3.5 kg, uniform_bar: [O4, B]",
            "crank": "mass: 2 kg, uniform_bar: [O2, A]",
        },
        NONE,
        _uniform_bar,
    ),
    "weight and com by name": (
        {"crank": "weight: 19.62 N, com: E", "coupler": "mass: 5 kg, com: P, inertia: 0.6 kg m^2"},
        NONE,
        _weight_com,
    ),
}


def _compare(res, ref, masks, joints=("O2", "A", "B", "O4")):
    assert res.ok.all() and res.forces.ok.all()
    T = ref["T"]
    tol = 1e-9 * max(1.0, float(np.max(np.abs(T))))
    np.testing.assert_allclose(res.driving_effort, T, rtol=0, atol=tol)
    for j in joints:
        r = res.reaction(j)
        s = 1e-9 * max(1.0, float(np.max(np.abs(ref[j]))))
        np.testing.assert_allclose(r["Fx"], ref[j][0], rtol=0, atol=s, err_msg=f"{j}.Fx")
        np.testing.assert_allclose(r["Fy"], ref[j][1], rtol=0, atol=s, err_msg=f"{j}.Fy")
    for name, on in masks.items():
        np.testing.assert_array_equal(res.forces.active[name], on, err_msg=name)
    # and the built-in power balance holds for a correct model
    f = res.forces
    assert np.max(np.abs(f.residual)) <= 1e-9 * max(res.power_scale(), 1e-30)


@pytest.mark.parametrize("case", list(CASES))
def test_fourbar_element(case):
    masses, loads, ref = CASES[case]
    res = ms.solve(ms.loads(fourbar_text(masses, loads)))
    fb = FourBar(res.u)
    fb.base_masses(skip=masses)
    masks = ref(fb) or {}
    _compare(res, fb.solve(), masks)


def test_gravity_with_a_direction():
    """gravity: {g, direction}: every mass is pulled along the direction, and a weight is
    divided by this g."""
    text = fourbar_text(
        {"crank": "weight: 14 N, com: E"},
        NONE,
        gravity="{g: 7 m/s^2, direction: 200 deg}",
    )
    res = ms.solve(ms.loads(text))
    fb = FourBar(res.u)
    fb.base_masses(skip=("crank",))
    fb.bodies["crank"].mass(14.0 / 7.0, LOCAL["crank"]["E"])  # weight / |g|
    g = 7.0 * np.array([np.cos(np.radians(200)), np.sin(np.radians(200))])
    _compare(res, fb.solve(gravity=tuple(g)), {})


def test_every_load_at_once_crank_clockwise():
    """All the loads of the cases together, the crank turning clockwise (velocity-dependent
    loads and conditions change, inertia forces do not)."""
    w2 = -1.7
    loads, refs = [], []
    for i, (masses, text, ref) in enumerate(CASES.values()):
        if masses:
            continue
        for line in text.splitlines():
            name = line.split(":")[0].strip()
            loads.append(line.replace(f"  {name}:", f"  {name}{i}:", 1))
        refs.append((i, ref))
    res = ms.solve(ms.loads(fourbar_text({}, "\n".join(loads), w2=w2)))
    fb = FourBar(res.u, w2=w2)
    fb.base_masses()
    masks = {}
    for i, ref in refs:
        masks.update({f"{k}{i}": v for k, v in (ref(fb) or {}).items()})
    _compare(res, fb.solve(), masks)


# --- the slider-crank: elements along a slider ---------------------------------------
R_, L_, E_, WS = 0.3, 1.0, 0.1, 3.0


def slider_text(loads: str) -> str:
    return f"""
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [{R_}, 0]}}, mass: 1.5 kg, com: [0.1, 0.02], inertia: 0.01 kg m^2}}
  rod: {{points: {{A: [0, 0], C: [{L_}, 0]}}, mass: 2.5 kg, com: [0.4, -0.03], inertia: 0.3 kg m^2}}
  piston: {{points: {{C: [0, 0], T: [0.1, 0.05]}}, mass: 1.2 kg, com: [0.05, 0.03], inertia: 0.004 kg m^2}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cyl: {{slider: [ground, piston], point: C, line: {{offset: {E_}, angle: 0}}}}
assembly: ["C.x > A.x"]
driver: {{joint: O, speed: {WS} rad/s, start: 10 deg}}
sweep: {{range: 360 deg, step: 25 deg}}
gravity: 9.81 m/s^2
loads:
{loads}
"""  # noqa: E501


def slider_reference(th2, extra):
    k = slider_crank_kinematics(R_, L_, E_, th2, WS)
    z = np.zeros_like(th2)
    crank = Rigid((0.0, 0.0), (0.0, 0.0), (0.0, 0.0), th2, z + WS, z)
    rod = Rigid(k["A"], crank.vel((R_, 0)), crank.acc((R_, 0)), k["th3"], k["w3"], k["al3"])
    C = k["C"]
    piston = Rigid(C, np.array([k["xd"], z]), np.array([k["xdd"], z]), z, z, z)
    bodies = {
        "crank": Body(crank).mass(1.5, (0.1, 0.02), 0.01),
        "rod": Body(rod).mass(2.5, (0.4, -0.03), 0.3),
        "piston": Body(piston).mass(1.2, (0.05, 0.03), 0.004),
    }
    extra(bodies, k)
    joints = [
        ("pin", "O", "ground", "crank", C * 0),
        ("pin", "A", "crank", "rod", k["A"]),
        ("pin", "C", "rod", "piston", C),
        ("slider", "cyl", "ground", "piston", C, np.array([z, z + 1.0])),
        ("driver", "T", "crank"),
    ]
    return newton_euler(bodies, joints)


def _slider_damper(bodies, k):
    bodies["piston"].force(k["C"], np.array([-45.0 * k["xd"], 0 * k["xd"]]))


def _piston_force(bodies, k):
    T = bodies["piston"].link.pos((0.1, 0.05))
    bodies["piston"].force(T, np.array([-300.0, 80.0])[:, None])
    bodies["piston"].torque = 4.0


@pytest.mark.parametrize(
    "loads,extra",
    [
        ("  d: {damper: cyl, coefficient: 45 N s/m}", _slider_damper),
        ("  F: {force: [-300 N, 80 N], at: T}\n  t: {torque: 4 N m, on: piston}", _piston_force),
    ],
    ids=["damper along the slider", "force off the line"],
)
def test_slider_crank_element(loads, extra):
    res = ms.solve(ms.loads(slider_text(loads)))
    ref = slider_reference(res.u, extra)
    _compare(res, ref, {}, joints=("O", "A", "C"))
    cyl = res.reaction("cyl")
    s = 1e-9 * max(1.0, float(np.max(np.abs(ref["cyl"]))))
    np.testing.assert_allclose(cyl["N"], ref["cyl"][0], rtol=0, atol=s)
    np.testing.assert_allclose(cyl["M"], ref["cyl"][1], rtol=0, atol=s)
    assert np.max(np.abs(ref["cyl"][1])) > 0.1  # the couple is not trivially zero


def test_a_reversed_spring_is_caught():
    """The reference is sensitive to the spring's direction: a spring that pushed where it
    should pull changes the torque by far more than the tolerance."""
    res = ms.solve(ms.loads(fourbar_text({}, CASES["spring between links"][1])))
    fb = FourBar(res.u)
    fb.base_masses()
    t = spring_tension(fb, "P", "R", 500.0, 0.3)
    two_point(fb, "P", "R", -t)
    wrong = fb.solve()
    assert np.max(np.abs(res.driving_effort - wrong["T"])) > 1.0
