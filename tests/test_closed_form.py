"""Kinematics against independent closed-form solutions (tests/closed_form.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms

from closed_form import fourbar, slider_crank, slotted_bar

RTOL = 1e-10


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def close(got, want, scale, rtol=RTOL):
    got, want = np.asarray(got, float), np.asarray(want, float)
    err = np.max(np.abs(got - want))
    assert err <= rtol * scale, f"max error {err:.3g} > {rtol * scale:.3g}"


def fourbar_model(a, b, c, d, side, method, th0=0.3, w=1.7, step=7.0):
    return ms.loads(
        f"""
name: four-bar
units: {{length: m, angle: deg}}
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: ["B {side} of A -> O4"]
driver: {{joint: O2, speed: {w} rad/s, start: {th0} rad}}
sweep: {{range: 360 deg, step: {step} deg}}
solver: {{method: {method}}}
"""
    )


GEOMETRIES = [
    (0.0265, 0.1056, 0.059, 0.0875),  # the benchmark crank-rocker
    (1.0, 3.0, 2.5, 3.2),
    (0.2, 0.9, 0.5, 0.8),
    (2.0, 7.0, 9.0, 6.0),
]


@pytest.mark.parametrize("geom", GEOMETRIES)
@pytest.mark.parametrize("side", ["left", "right"])
@pytest.mark.parametrize("method", ["auto", "newton"])
def test_fourbar_against_freudenstein(geom, side, method):
    a, b, c, d = geom
    w = 1.7
    res = ms.solve(fourbar_model(a, b, c, d, side, method, w=w))
    th2 = res.u
    # pick the closed-form branch that puts B on the requested side of A -> O4
    for branch in (1, -1):
        th3, th4, w3, w4, al3, al4 = fourbar(a, b, c, d, th2, w, branch)
        ax, ay = a * np.cos(th2[0]), a * np.sin(th2[0])
        bx, by = d + c * np.cos(th4[0]), c * np.sin(th4[0])
        cross = (d - ax) * (by - ay) - (0 - ay) * (bx - ax)
        if (cross > 0) == (side == "left"):
            break
    assert res.ok.all()
    cp, rk = res.link("coupler"), res.link("rocker")
    close(wrap(cp.angle - th3), 0, 1.0)
    close(wrap(rk.angle - th4), 0, 1.0)
    close(cp.omega, w3, w)
    close(rk.omega, w4, w)
    close(cp.alpha, al3, w * w)
    close(rk.alpha, al4, w * w)
    B = res.point("B")
    close(B.x, d + c * np.cos(th4), d)
    close(B.y, c * np.sin(th4), d)
    close(B.vx, -c * w4 * np.sin(th4), w * d)
    close(B.ay, c * (al4 * np.cos(th4) - w4**2 * np.sin(th4)), w * w * d)


def slider_crank_model(r, l, e, ahead, method, w=3.0):
    cond = "C.x > A.x" if ahead else "C.x < A.x"
    return ms.loads(
        f"""
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [{r}, 0]}}}}
  rod: {{points: {{A: [0, 0], C: [{l}, 0]}}}}
  piston: {{points: {{C: [0, 0]}}}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cyl: {{slider: [ground, piston], point: C, line: {{offset: {e}, angle: 0}}}}
assembly: ["{cond}"]
driver: {{joint: O, speed: {w} rad/s, start: 10 deg}}
sweep: {{range: 360 deg, step: 5 deg}}
solver: {{method: {method}}}
"""
    )


@pytest.mark.parametrize("r,l,e", [(0.05, 0.2, 0.0), (0.05, 0.2, 0.01), (1.0, 2.5, -0.7)])
@pytest.mark.parametrize("ahead", [True, False])
@pytest.mark.parametrize("method", ["auto", "newton"])
def test_slider_crank_against_sine_rule(r, l, e, ahead, method):
    w = 3.0
    res = ms.solve(slider_crank_model(r, l, e, ahead, method, w))
    x, xd, xdd, phi, phid, phidd = slider_crank(r, l, e, res.u, w, ahead)
    C = res.point("C")
    assert res.ok.all()
    close(C.x, x, l)
    close(C.y, e, l)
    close(C.vx, xd, w * l)
    close(C.ax, xdd, w * w * l)
    rod = res.link("rod")
    close(wrap(rod.angle - phi), 0, 1.0)
    close(rod.omega, phid, w)
    close(rod.alpha, phidd, w * w)
    cyl = res.slider("cyl")
    close(cyl.s, x, l)
    close(cyl.v, xd, w * l)
    close(cyl.a, xdd, w * w * l)


@pytest.mark.parametrize("method", ["auto", "newton"])
def test_slotted_bar_against_polar_coordinates(method):
    r, d, w = 0.11, 0.38, -2 * math.pi
    mech = ms.loads(
        f"""
ground: {{O4: [0, 0], O2: [0, {d}]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{r}, 0]}}}}
  block: {{points: {{A: [0, 0]}}}}
  bar: {{points: {{O4: [0, 0], B: [0.54, 0]}}}}
joints:
  O2: [ground, crank]
  A: [crank, block]
  slot: {{slider: [bar, block], point: A, line: [O4, B]}}
  O4: [ground, bar]
driver: {{joint: O2, speed: {w} rad/s, start: 30 deg}}
sweep: {{range: 360 deg, step: 6 deg}}
solver: {{method: {method}}}
"""
    )
    res = ms.solve(mech)
    psi, psid, psidd, s, sd, sdd = slotted_bar(r, d, res.u, w)
    bar = res.link("bar")
    close(wrap(bar.angle - psi), 0, 1.0)
    close(bar.omega, psid, abs(w))
    close(bar.alpha, psidd, w * w)
    slot = res.slider("slot")
    close(slot.s, s, d)
    close(slot.v, sd, abs(w) * d)
    close(slot.a, sdd, w * w * d)
    blk = res.link("block")
    close(blk.omega, psid, abs(w))
