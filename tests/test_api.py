"""The Python API: a model built in code, the scipy fallback, partial outputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms

from closed_form import slider_crank


def build_slider_crank(**solver):
    mech = ms.Mechanism(
        name="engine",
        ground={"O": (0.0, 0.0)},
        links=[
            ms.Link("crank", {"O": (0.0, 0.0), "A": (0.05, 0.0)}),
            ms.Link("rod", {"A": (0.0, 0.0), "C": (0.2, 0.0)}),
            ms.Link("piston", {"C": (0.0, 0.0)}),
        ],
        joints=[
            ms.PinJoint("O", "ground", "crank", "O"),
            ms.PinJoint("A", "crank", "rod", "A"),
            ms.PinJoint("C", "rod", "piston", "C"),
            ms.SliderJoint("cyl", "ground", "piston", "C", origin=(0.0, 0.01), angle=0.0),
        ],
        driver=ms.Driver("O", speed=2 * math.pi * 25, start=0.0),
        sweep=ms.Sweep(travel=2 * math.pi, step=math.radians(10)),
        solver=ms.SolverOptions(**solver),
    )
    return mech.validate()


def test_model_built_in_code():
    res = ms.solve(build_slider_crank())
    w = 2 * math.pi * 25
    x, xd, xdd, *_ = slider_crank(0.05, 0.2, 0.01, res.u, w, ahead=True)
    C = res.point("C")
    np.testing.assert_allclose(C.x, x, atol=1e-12)
    np.testing.assert_allclose(C.vx, xd, atol=1e-9 * w)
    np.testing.assert_allclose(C.ax, xdd, atol=1e-9 * w * w)
    assert len(res) == 37 and res.ok.all()


def test_scipy_fallback_is_used_and_reported():
    """With Newton allowed a single iteration, scipy must take over, and say so."""
    res = ms.solve(build_slider_crank(method="newton", max_iterations=1))
    assert res.ok.all()
    methods = res.methods()
    used = [m for m in methods if m.startswith("scipy")]
    assert len(used) > len(methods) // 2, methods
    assert set(methods) <= {"newton", "scipy-hybr", "scipy-lm", "scipy-lsq"}
    assert f"scipy fallback at {len(used)} position(s)" in res.summary()
    x, *_ = slider_crank(0.05, 0.2, 0.01, res.u, 1.0, ahead=True)
    np.testing.assert_allclose(res.point("C").x, x, atol=1e-11)


def test_positions_only_does_no_velocity_work():
    mech = build_slider_crank()
    mech.outputs.velocity = mech.outputs.acceleration = False
    res = ms.solve(mech)
    headers = [c.header for c in res.columns()]
    assert "C.x [m]" in headers and "C.vx [m/s]" not in headers and "C.ax [m/s^2]" not in headers
    assert np.all(np.isnan(res.point("C").vx))


def test_invalid_model_in_code_raises_input_error():
    mech = build_slider_crank()
    mech.joints.append(ms.PinJoint("X", "crank", "crank", "A"))
    with pytest.raises(ms.InputError, match="joins the link 'crank' to itself"):
        mech.validate()


@pytest.mark.parametrize(
    "change,message",
    [
        (lambda m: setattr(m.links[1], "mass", -1.0), "mass must be zero or positive"),
        (lambda m: setattr(m.joints[2], "point", "Z"), "no point 'Z'"),
        (
            lambda m: m.loads.append(ms.PointForce("f", link="rod", point="Q", force=(0, 1))),
            "load 'f' acts at point 'Q', which link 'rod' does not have",
        ),
        (
            lambda m: m.loads.append(
                ms.Spring("s", ends=(("crank", "A"), ("ground", "O")), stiffness=-5.0)
            ),
            "stiffness must be zero or positive",
        ),
    ],
)
def test_solve_validates_a_model_built_in_code(change, message):
    """ms.solve checks a model built in code that was never validated: a clear
    InputError, not a KeyError from deep inside or a silent result."""
    mech = build_slider_crank()
    del mech.__dict__["_validated"]  # as if built without calling validate()
    change(mech)
    with pytest.raises(ms.InputError, match=message):
        ms.solve(mech)
