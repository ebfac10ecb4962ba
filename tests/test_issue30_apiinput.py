"""Issue 30 (API input): a model edited in code after it was loaded or solved is checked
again, the arguments of ``solve`` are checked as the command line checks them, and the
Results' accessors answer a user's mistake with an InputError, not an internal exception."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.model import validate as validate_module

from conftest import MECH

FOURBAR = MECH / "fourbar.yaml"


# -- 1. a loaded or once-solved model edited in code is validated again ----------------


def _negative_mass(m):
    m.links[1].mass = -1.0


def _negative_step(m):
    m.sweep.step = -0.1


def _zero_step(m):
    m.sweep.step = 0.0


def _misspelt_link(m):
    m.joints[1].b = "couplr"


def _unknown_driver_joint(m):
    m.driver = dataclasses.replace(m.driver, joint="Z")


def _point_far_away(m):
    m.links[0].points["A"] = (1e9, 0.0)


EDITS = [
    (_negative_mass, r"mass: mass must be zero or positive, got -1"),
    (_negative_step, r"step: the step must be positive"),
    (_zero_step, r"step: the step must be positive"),
    (_misspelt_link, r"couplr"),
    (_unknown_driver_joint, r"the driver names the joint 'Z', which does not exist"),
    (_point_far_away, r"points\.A"),
]


@pytest.mark.parametrize("solved_first", [False, True])
@pytest.mark.parametrize(("edit", "message"), EDITS, ids=[e[0].__name__ for e in EDITS])
def test_an_edited_model_is_validated_again(edit, message, solved_first):
    """The file reader refuses each of these edits; made in code on a loaded model (or on
    one solved before, whose analysis is kept) they give the same InputError naming the
    key, not a silent result (a negative mass flips the driving torque's sign, a negative
    step gives one position) or a ZeroDivisionError / KeyError."""
    m = ms.load(FOURBAR)
    if solved_first:
        ms.solve(m)
    edit(m)
    with pytest.raises(ms.InputError, match=message):
        ms.solve(m)
    with pytest.raises(ms.InputError, match=message):
        ms.check(m)


def test_stream_validates_an_edited_model(tmp_path):
    m = ms.load(FOURBAR)
    m.sweep.step = 0.0
    with pytest.raises(ms.InputError, match="step must be positive"):
        ms.stream(m, tmp_path / "out.csv")


def test_a_valid_edit_is_solved_and_an_unchanged_model_not_checked_again(monkeypatch):
    """A valid edit gives the new sweep: 10 degree steps over a turn are 36 intervals;
    solving the same content again does not run the checks again (they cost about as much
    as building the analysis)."""
    calls = []
    real = validate_module.validate
    monkeypatch.setattr(validate_module, "validate", lambda m: (calls.append(1), real(m)))
    m = ms.load(FOURBAR)
    n0 = len(calls)
    ms.solve(m)
    ms.solve(m)
    assert len(calls) == n0  # loaded (validated) and unchanged: not checked again
    m.sweep.step = math.radians(10)
    res = ms.solve(m)
    assert len(res) == 37 and len(calls) == n0 + 1
    np.testing.assert_allclose(np.diff(res.u), math.radians(10), rtol=1e-12)
    ms.solve(m)
    assert len(calls) == n0 + 1
