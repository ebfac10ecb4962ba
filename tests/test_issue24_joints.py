"""Issue 24, item 3: the joint contract.

Each joint kind is one module under ``mechsolve/joints/`` (a :class:`Joint` and its
:class:`Constraint`); everything else asks the joint and never tests its kind. Two checks:

* no module outside ``mechsolve/joints/`` tests a joint's kind (``isinstance`` on a joint
  class, ``type(c) is ...``, or a comparison with a kind's string);
* a new kind needs only its own module and a registry line: a pin in a straight slot (a
  higher pair, one equation) written in this file and registered, read from a YAML file,
  solves a Scotch yoke to its closed form x = r cos(theta), with velocities,
  accelerations, the driving torque from the power balance and Grübler's count
  3 n - 2 Pl - Ph.
"""

from __future__ import annotations

import ast
import math
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

import mechsolve
from mechsolve.base.keyspec import K, names
from mechsolve.joints import registry
from mechsolve.joints.base import Joint
from mechsolve.joints.slider import SliderConstraint, SliderJoint, read_line

PKG = Path(mechsolve.__file__).parent
JOINT_CLASSES = {"PinJoint", "SliderJoint", "RevoluteConstraint", "SliderConstraint"}
KIND_STRINGS = {"revolute", "slider"}


def kind_tests(path: Path) -> list[str]:
    """The places in a module that test a joint's kind."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "isinstance":
            classes = node.args[1]
            elts = classes.elts if isinstance(classes, ast.Tuple) else [classes]
            if any(getattr(e, "id", getattr(e, "attr", "")) in JOINT_CLASSES for e in elts):
                found.append(f"{path.name}:{node.lineno} isinstance")
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(isinstance(op, (ast.Is, ast.IsNot)) for op in node.ops) and any(
                getattr(s, "id", "") in JOINT_CLASSES for s in sides
            ):
                found.append(f"{path.name}:{node.lineno} type is")
            kind_attr = any(isinstance(s, ast.Attribute) and s.attr == "kind" for s in sides)
            strings = {s.value for s in sides if isinstance(s, ast.Constant)}
            if kind_attr and strings & KIND_STRINGS:
                found.append(f"{path.name}:{node.lineno} kind ==")
    return found


def test_nothing_outside_the_joints_tests_a_joint_kind():
    bad = []
    for path in sorted(PKG.rglob("*.py")):
        if "joints" in path.relative_to(PKG).parts:
            continue
        bad += kind_tests(path)
    assert not bad, bad


def test_the_scan_finds_a_kind_test(tmp_path):
    """The scan above can fail: it finds each form it looks for."""
    src = tmp_path / "m.py"
    src.write_text(
        "if isinstance(j, PinJoint): pass\n"
        "if type(c) is RevoluteConstraint: pass\n"
        "if c.kind == 'slider': pass\n"
    )
    assert len(kind_tests(src)) == 3


# -- a new kind: a pin in a straight slot (one equation, a higher pair) ----------------


@dataclass
class PinInSlot(Joint):
    """The point ``point`` of link ``pinned`` stays on a straight slot of link ``slotted``."""

    name: str
    slotted: str
    pinned: str
    point: str
    origin: tuple[float, float]
    angle: float
    where: tuple = ()

    kind: ClassVar[str] = "pin_in_slot"
    title: ClassVar[str] = "a pin in a straight slot"
    roles: ClassVar[tuple[str, str]] = ("slotted", "pinned")
    letter: ClassVar[str] = "H"
    pair: ClassVar[str] = "higher"
    removes: ClassVar[int] = 1
    magnitude: ClassVar[str] = "N"
    keys: ClassVar[dict] = {
        "pin_in_slot": K(names("link", 2), "[slotted, pinned]: the pin slides in the slot."),
        "line": SliderJoint.keys["line"],
    }

    @property
    def a(self) -> str:
        return self.slotted

    @property
    def b(self) -> str:
        return self.pinned

    @property
    def links(self) -> tuple[str, str]:
        return (self.slotted, self.pinned)

    @classmethod
    def read(cls, r, name, m, path, points):
        a, b = r.names(m["pin_in_slot"], path + ("pin_in_slot",), "link", 2)
        point = r.name(m.get("point", name), path + ("point",), "point")
        origin, angle = read_line(r, m["line"], path + ("line",), a, points[a])
        return cls(name, a, b, point, origin, angle, where=path)

    def equations(self, mech, index):
        pinned = mech.local_point(self.pinned, self.point)
        return SlotEquation(
            self.name, index[self.slotted], index[self.pinned], self.origin, self.angle, pinned
        )


class SlotEquation(SliderConstraint):
    """The slider's first equation alone: the pin on the slot's line."""

    kind = "pin_in_slot"
    letter = "H"
    m = 1

    def __init__(self, name, a, b, origin, angle, sb) -> None:
        super().__init__(name, a, b, origin, angle, sb, 0.0)

    def residual(self, st, u=None):
        return super().residual(st, u)[:1]

    def jacobian(self, st):
        return {k: v[:1] for k, v in super().jacobian(st).items()}

    def gamma(self, st, udd=None):
        return super().gamma(st, udd)[:1]

    def incidence(self, nb):
        return super().incidence(nb)[:1]

    def equation_names(self):
        return [f"{self.name} (in slot)"]

    def reaction(self, st, lam):
        nrm = -lam[:, 0]
        _, _, nx, ny, _, _ = self.frame(st)
        return {"N": nrm, "Fx": nrm * nx, "Fy": nrm * ny}

    def indeterminate(self, free):
        return {"N", "Fx", "Fy"}

    def guide(self, st, scale):
        return None


YOKE = """
name: Scotch yoke (a pin in a slot)
units: {length: mm, angle: deg}
ground:
  O: [0, 0]
links:
  crank: {points: {O: [0, 0], A: [40, 0]}}
  yoke:
    points: {P: [0, 0]}
    mass: 2 kg
    com: P
    inertia: 0.01 kg*m^2
joints:
  O: [ground, crank]
  guide: {slider: [ground, yoke], point: P, line: {through: [0, 0], angle: 0 deg}}
  slot: {pin_in_slot: [yoke, crank], point: A, line: {through: [0, 0], angle: 90 deg}}
driver: {joint: O, speed: 30 rad/s, start: 10 deg}
sweep: {range: 360 deg, step: 5 deg}
gravity: off
"""


@pytest.fixture
def with_pin_in_slot(monkeypatch):
    monkeypatch.setitem(registry.KINDS, PinInSlot.kind, PinInSlot)


def test_a_new_kind_needs_its_module_and_a_registry_line(with_pin_in_slot):
    mech = mechsolve.loads(YOKE)
    assert [j.kind for j in mech.joints] == ["revolute", "slider", "pin_in_slot"]
    # Grübler: 3 n - 2 Pl - Ph = 3*2 - 2*2 - 1 = 1
    assert mechsolve.check(mech).grubler == 1
    res = mechsolve.solve(mech)
    r, w = 0.040, 30.0
    th = np.asarray(res.u)
    yoke = res.slider("guide")
    np.testing.assert_allclose(yoke.s, r * np.cos(th), atol=1e-12)
    np.testing.assert_allclose(yoke.v, -r * w * np.sin(th), atol=1e-9)
    np.testing.assert_allclose(yoke.a, -r * w * w * np.cos(th), atol=1e-7)
    # the power balance: T w = m a v (the yoke's kinetic energy rate), no other load
    m = 2.0
    torque = m * (r * w * w * np.cos(th)) * (r * w * np.sin(th)) / w
    np.testing.assert_allclose(res.driving_effort, torque, atol=1e-8)
    # the pin's reaction is normal to the slot (horizontal): the yoke's inertia force
    slot = res.reaction("slot")
    np.testing.assert_allclose(np.abs(slot["N"]), np.abs(m * r * w * w * np.cos(th)), atol=1e-8)
    np.testing.assert_allclose(slot["Fy"], 0.0, atol=1e-9)


def test_an_unregistered_kind_is_an_input_error():
    with pytest.raises(mechsolve.InputError, match="pin_in_slot"):
        mechsolve.loads(YOKE)


def test_the_shipped_kinds_keep_their_contract():
    for kind, cls in registry.KINDS.items():
        assert cls.kind == kind and issubclass(cls, Joint)
        assert kind in cls.keys and cls.removes in (1, 2) and cls.letter
        assert cls.pair in ("lower", "higher")
    assert math.isclose(registry.KINDS["slider"].removes, 2)
