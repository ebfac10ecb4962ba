"""The hand-written batch reference of the study's four-bar (mechsolve_bench.fourbar_batch):
checked on its own (loop closure, rates by central differences, the power balance), then
against mechsolve's solve of the same file for a few designs computed in one batch."""

from __future__ import annotations

import math
import statistics
import time

import numpy as np
import pytest

import mechsolve as ms
from mechsolve_bench.fourbar_batch import kinematics, kinetostatics
from mechsolve_bench.study import _FOURBAR

C, D = 0.059, 0.0875  # rocker and ground (m)
M2, M3, M4 = 0.05, 0.2, 0.11  # kg
G = 9.81
LOAD = (0.0, -2.0)
# crank and coupler (mm): the file's own design and two inside the study's grid
DESIGNS = [(26.5, 105.6), (22.0, 98.5), (28.75, 108.0)]


def _yaml(a_mm: float, b_mm: float) -> str:
    text = _FOURBAR.replace("A: [26.5, 0]", f"A: [{a_mm!r}, 0]")
    text = text.replace("B: [105.6, 0]", f"B: [{b_mm!r}, 0]")
    assert text.count(f"A: [{a_mm!r}, 0]") == 1 and text.count(f"B: [{b_mm!r}, 0]") == 1
    return text


def _designs(rows=DESIGNS):
    ab = np.array(rows) / 1e3
    return ab[:, 0], ab[:, 1]


def _wrap(x):
    return np.angle(np.exp(1j * x))


def _power_terms(kin, frc, m=(M2, M3, M4), g=G, load=LOAD):
    """Driving power, dT/dt, dV/dt and the load's power from the reference's own arrays."""
    a, b, c = kin["a"], kin["b"], kin["c"]
    w2, al2 = kin["w2"], kin["al2"]
    J = (m[0] * a * a / 12, m[1] * b * b / 12, m[2] * c * c / 12)
    rates = ((w2, al2), (kin["w3"], kin["al3"]), (kin["w4"], kin["al4"]))
    dT = dV = 0.0
    for k, (mk, Jk, (w, al)) in enumerate(zip(m, J, rates)):
        gk = f"G{k + 2}."
        dT = dT + mk * (kin[gk + "vx"] * kin[gk + "ax"] + kin[gk + "vy"] * kin[gk + "ay"])
        dT = dT + Jk * w * al
        dV = dV + mk * g * kin[gk + "vy"]
    on = frc["pull.active"]
    p_load = on * (load[0] * kin["P.vx"] + load[1] * kin["P.vy"])
    return frc["torque"] * w2, dT, dV, p_load


# -- the reference on its own -------------------------------------------------------------


def test_closure_and_branch():
    a, b = _designs()
    u = np.linspace(0.0, 2 * math.pi, 361)
    k = kinematics(a, b, C, D, u)
    assert k["th3"].shape == (3, 361) and k["P.vy"].shape == (3, 361)
    Ax, Ay, Bx, By = k["A.x"], k["A.y"], k["B.x"], k["B.y"]
    np.testing.assert_allclose(np.hypot(Bx - Ax, By - Ay), b[:, None] + 0 * u, rtol=1e-14)
    np.testing.assert_allclose(np.hypot(Bx - D, By), C + 0 * Bx, rtol=1e-14)
    # B on the left of A -> O4
    assert np.all((D - Ax) * (By - Ay) - (-Ay) * (Bx - Ax) > 0)
    # P at 60 mm from A, 30 deg counter-clockwise from A -> B
    APx, APy = k["P.x"] - Ax, k["P.y"] - Ay
    np.testing.assert_allclose(np.hypot(APx, APy), 0.060, rtol=1e-14)
    ang = _wrap(np.arctan2(APy, APx) - k["th3"])
    np.testing.assert_allclose(ang, math.radians(30), rtol=1e-13)
    np.testing.assert_allclose(k["th3"], np.arctan2(By - Ay, Bx - Ax), rtol=0, atol=1e-15)
    np.testing.assert_allclose(k["G3.x"], (Ax + Bx) / 2, rtol=0, atol=1e-17)


@pytest.mark.parametrize("w2", [1.0, -2.5])
def test_rates_by_central_differences(w2):
    """At a constant crank speed, d/dt = w2 d/du: the closed-form rates against central
    differences of the closed-form positions and velocities."""
    a, b = _designs()
    u = np.linspace(0.0, 2 * math.pi, 73)
    h = 1e-6
    k0 = kinematics(a, b, C, D, u, w2=w2)
    kp = kinematics(a, b, C, D, u + h, w2=w2)
    km = kinematics(a, b, C, D, u - h, w2=w2)

    def ddt(key, wrap=False):
        diff = kp[key] - km[key]
        return w2 * (_wrap(diff) if wrap else diff) / (2 * h)

    pairs = [("th3", "w3", True), ("th4", "w4", True), ("w3", "al3", False), ("w4", "al4", False)]
    for pt in ("A", "B", "P", "G2", "G3", "G4"):
        for x in ("x", "y"):
            pairs += [(f"{pt}.{x}", f"{pt}.v{x}", False), (f"{pt}.v{x}", f"{pt}.a{x}", False)]
    for q, rate, wrap in pairs:
        scale = np.abs(k0[rate]).max()
        err = np.abs(ddt(q, wrap) - k0[rate]).max()
        assert err <= 1e-7 * scale, (q, rate, err, scale)


@pytest.mark.parametrize("w2, al2", [(1.0, 0.0), (-3.0, 0.0), (2.0, 7.5)])
def test_power_balance(w2, al2):
    """Driving power = dT/dt + dV/dt - P_load, to rounding, over every design and position
    (with an accelerating crank too, which exercises the crank's inertia couple)."""
    rng = np.random.default_rng(1)
    a = rng.uniform(0.020, 0.030, 50)
    b = rng.uniform(0.095, 0.110, 50)
    k = kinematics(a, b, C, D, np.linspace(0.0, 2 * math.pi, 361), w2=w2, al2=al2)
    f = kinetostatics(k, M2, M3, M4, g=G, load=LOAD)
    p_in, dT, dV, p_load = _power_terms(k, f)
    assert f["pull.active"].any() and not f["pull.active"].all()
    scale = max(np.abs(t).max() for t in (p_in, dT, dV, p_load))
    resid = p_in - (dT + dV - p_load)
    assert np.abs(resid).max() <= 1e-13 * scale, np.abs(resid).max() / scale


def test_force_balance_of_each_body():
    """The reactions close each body's d'Alembert force balance (sign convention: a
    joint [first, second]'s force acts on the second body, by the first)."""
    a, b = _designs()
    k = kinematics(a, b, C, D, np.linspace(0.0, 2 * math.pi, 361))
    f = kinetostatics(k, M2, M3, M4, g=G, load=LOAD)
    on = f["pull.active"]
    for c, grav, load in (("x", 0.0, LOAD[0]), ("y", -G, LOAD[1])):
        crank = f["O2.F" + c] - f["A.F" + c] + M2 * (grav - k["G2.a" + c])
        coupler = f["A.F" + c] - f["B.F" + c] + on * load + M3 * (grav - k["G3.a" + c])
        rocker = f["B.F" + c] + f["O4.F" + c] + M4 * (grav - k["G4.a" + c])
        for res in (crank, coupler, rocker):
            assert np.abs(res).max() <= 1e-14 * np.abs(f["A.F" + c]).max()


# -- against mechsolve ------------------------------------------------------------------


@pytest.fixture(scope="module")
def solved():
    """mechsolve's solve of each design's file, and the reference of all at once."""
    results = [ms.solve(ms.loads(_yaml(*ab))) for ab in DESIGNS]
    u = results[0].u
    for r in results:
        assert r.ok.all() and np.array_equal(r.u, u)
    a, b = _designs()
    kin = kinematics(a, b, C, D, u)
    frc = kinetostatics(kin, M2, M3, M4, g=G, load=LOAD)
    return results, kin, frc


def _away_from_switch(kin, i):
    """Positions where P.vx is clearly non-zero: the conditional load is the same in both."""
    pvx = kin["P.vx"][i]
    return np.abs(pvx) > 1e-6 * np.abs(pvx).max()


@pytest.mark.parametrize("i", range(len(DESIGNS)))
def test_kinematics_against_mechsolve(solved, i):
    results, kin, _ = solved
    r = results[i]
    ok = _away_from_switch(kin, i)
    assert ok.sum() >= 355
    for link, th, w, al in (("coupler", "th3", "w3", "al3"), ("rocker", "th4", "w4", "al4")):
        lm = r.link(link)
        assert np.abs(_wrap(lm.angle - kin[th][i]))[ok].max() <= 1e-10 * math.pi
        for got, key in ((lm.omega, w), (lm.alpha, al)):
            ref = kin[key][i]
            assert np.abs(got - ref)[ok].max() <= 1e-10 * np.abs(ref).max(), (link, key)
    for pt in ("A", "B", "P"):
        pm = r.point(pt)
        for comp in ("x", "y", "vx", "vy", "ax", "ay"):
            ref = kin[f"{pt}.{comp}"][i]
            scale = np.abs(ref).max()
            err = np.abs(getattr(pm, comp) - ref)[ok].max()
            assert err <= 1e-10 * scale, (pt, comp, err, scale)


@pytest.mark.parametrize("i", range(len(DESIGNS)))
def test_kinetostatics_against_mechsolve(solved, i):
    results, kin, frc = solved
    r = results[i]
    ok = _away_from_switch(kin, i)
    assert np.array_equal(r.forces.active["pull"][ok], frc["pull.active"][i][ok])
    for joint in ("O2", "A", "B", "O4"):
        got = r.reaction(joint)
        fx, fy = frc[joint + ".Fx"][i], frc[joint + ".Fy"][i]
        scale = np.hypot(fx, fy).max()
        for comp, ref in (("Fx", fx), ("Fy", fy)):
            err = np.abs(got[comp] - ref)[ok].max()
            assert err <= 1e-8 * scale, (joint, comp, err, scale)
        np.testing.assert_allclose(got["F"][ok], np.hypot(fx, fy)[ok], rtol=1e-8)
    ref = frc["torque"][i]
    err = np.abs(r.driving_effort - ref)[ok].max()
    assert err <= 1e-8 * np.abs(ref).max(), err


# -- its speed (printed, not asserted) -----------------------------------------------


def test_speed_1000_designs_by_361_positions():
    a = np.repeat(np.linspace(0.020, 0.030, 40), 25)
    b = np.tile(np.linspace(0.095, 0.110, 25), 40)
    u = np.linspace(0.0, 2 * math.pi, 361)
    t_kin, t_frc = [], []
    for _ in range(7):
        t0 = time.perf_counter()
        kin = kinematics(a, b, C, D, u)
        t1 = time.perf_counter()
        frc = kinetostatics(kin, M2, M3, M4, g=G, load=LOAD)
        t2 = time.perf_counter()
        t_kin.append(t1 - t0)
        t_frc.append(t2 - t1)
    assert frc["torque"].shape == (1000, 361) and np.isfinite(frc["torque"]).all()
    tk, tf = statistics.median(t_kin), statistics.median(t_frc)
    print(
        f"\nfour-bar batch reference, 1000 designs x 361 positions (median of 7): "
        f"kinematics {1e3 * tk:.1f} ms + kinetostatics {1e3 * tf:.1f} ms = "
        f"{1e3 * (tk + tf):.1f} ms ({1e6 * (tk + tf) / 1000:.1f} us per design)"
    )
