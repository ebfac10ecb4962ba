"""The validated model of a planar mechanism: links, joints, driver, sweep, outputs.

A :class:`Mechanism` is what a mechanism file becomes after parsing, and what a user
builds in code. All values are SI (m, rad, s, kg, N). Coordinates of a link's points are
in the link's own frame; the ground's points are global.

Names of points, links and joints are identifiers (letters, digits, ``_``) so that they
can be used in CSV headers and conditions. A point name is global: the same name on two
links means the same physical point, so those links must be joined there.
"""

from __future__ import annotations

import copyreg
import io
import pickle
import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from mechsolve.base.errors import InputError
from mechsolve.base.units import OutputUnits, file_output_units
from mechsolve.joints.base import GROUND, Joint  # noqa: F401 (the model holds joints)
from mechsolve.joints.revolute import PinJoint  # noqa: F401
from mechsolve.joints.slider import SliderJoint  # noqa: F401
from mechsolve.model.expr import Expression

if TYPE_CHECKING:
    from mechsolve.model.source import Source

STANDARD_G = 9.81  # m/s^2, the textbooks' value
NAME_RE = re.compile(r"^[^\W\d]\w*$")  # letters of any script (曲柄, кривошип), digits, _
KeyPath = tuple[Any, ...]


MAX_POSITIONS = 10_000_000  # a sweep longer than this is a mistake (about 2 min streamed)


# a parsed condition is pickled for a snapshot as its text (its tree follows from it); the
# snapshot holds the expression objects themselves besides, so that a model rebuilt from
# it has the very same ones (an expression is a value, never edited in place; a derivative
# of a motion law has a text that may not parse back)
def _expression(text: str, variables: tuple[str, ...]) -> Expression:
    return Expression(text, variables)


_PARTS = ("driver", "sweep", "assembly", "outputs", "solver")
_LISTS = ("links", "joints", "loads")


def content_snapshot(mech: Mechanism) -> tuple | None:
    """Everything :meth:`Mechanism.validate` checks, as a snapshot: the types of the
    model's parts and every public field of the model, its links, joints, driver, sweep,
    assembly, outputs, solver options and loads, pickled to bytes (the source file
    aside). Two snapshots are equal when nothing was edited in between; None when a field
    cannot be pickled (a motion law written as a lambda): such a model is checked at
    every solve. :func:`model_from_snapshot` rebuilds the model from it (what a result
    was solved with, see :meth:`mechsolve.results.results.Results.model_as_solved`)."""
    d = mech.__dict__
    top = {k: v for k, v in d.items() if k[0] != "_" and k not in _SKIP}
    objs = (mech.driver, mech.sweep, mech.assembly, mech.outputs, mech.solver)
    kinds = (*map(type, objs), *map(type, mech.links), None, *map(type, mech.joints))
    kinds += (None, *map(type, mech.loads))
    parts = (
        top,
        [None if o is None else o.__dict__ for o in objs],
        [lk.__dict__ for lk in mech.links],
        [j.__dict__ for j in mech.joints],
        [ld.__dict__ for ld in mech.loads],
    )
    exprs: list[Expression] = []

    def expression(e: Expression) -> tuple:
        exprs.append(e)
        return (_expression, (e.text, e.variables))

    buf = io.BytesIO()
    pickler = pickle.Pickler(buf, pickle.HIGHEST_PROTOCOL)
    pickler.dispatch_table = table = copyreg.dispatch_table.copy()
    table[Expression] = expression
    try:
        pickler.dump(parts)
    except Exception:  # (pickle raises PicklingError, TypeError, AttributeError, ...)
        return None
    return (kinds, buf.getvalue(), tuple(exprs))


_SKIP = frozenset(("source", *_PARTS, *_LISTS))


def _rebuilt(kind: type, state: dict) -> Any:
    out = object.__new__(kind)
    out.__dict__.update(state)
    return out


def model_from_snapshot(snapshot: tuple, source: Source | None = None) -> Mechanism:
    """The model a :func:`content_snapshot` was taken of, rebuilt as a new object (its
    own links, joints, loads and parts, none shared with the model it was taken of but
    the expressions, which are values), with ``source`` for its messages."""
    kinds, data, exprs = snapshot
    known = {(e.text, e.variables): e for e in exprs}

    class Unpickler(pickle.Unpickler):
        def find_class(self, module: str, name: str) -> Any:
            if module == __name__ and name == "_expression":
                return lambda *key: known[key] if key in known else _expression(*key)
            return super().find_class(module, name)

    top, objs, links, joints, loads = Unpickler(io.BytesIO(data)).load()
    nl, nj = len(links), len(joints)
    mech = object.__new__(Mechanism)
    mech.__dict__.update(top)
    for name, kind, state in zip(_PARTS, kinds, objs):
        setattr(mech, name, None if state is None else _rebuilt(kind, state))
    k = len(_PARTS)
    mech.links = [_rebuilt(t, s) for t, s in zip(kinds[k : k + nl], links)]
    k += nl + 1
    mech.joints = [_rebuilt(t, s) for t, s in zip(kinds[k : k + nj], joints)]
    k += nj + 1
    mech.loads = [_rebuilt(t, s) for t, s in zip(kinds[k:], loads)]
    mech.source = source
    return mech


def as_snapshotted(mech: Mechanism, snapshot: object) -> tuple[Mechanism, tuple | None]:
    """``mech`` as it was when ``snapshot`` (its :func:`content_snapshot`) was taken, and
    the snapshot its results compare it with from then on: the model itself while its
    content is the snapshot's, else a copy rebuilt from the snapshot (with that copy's
    own snapshot); ``(mech, None)`` without a snapshot (a model that cannot be pickled)."""
    if not isinstance(snapshot, tuple):
        return mech, None
    if content_snapshot(mech) == snapshot:
        return mech, snapshot
    out = model_from_snapshot(snapshot, mech.source)
    return out, content_snapshot(out)


@dataclass
class Link:
    """A rigid body carrying named points.

    Parameters
    ----------
    name
        The link's name, e.g. ``"crank"``.
    points
        Local coordinates (m) of each named point in the link's frame. The link's angle is
        the angle of its frame's x axis.
    mass
        Mass in kg, or ``None`` for a massless link.
    com
        Centre of mass in the link frame (m); the frame origin if not given.
    inertia
        Moment of inertia about the centre of mass (kg m^2).
    """

    name: str
    points: dict[str, tuple[float, float]]
    mass: float | None = None
    com: tuple[float, float] | None = None
    inertia: float | None = None
    where: KeyPath = ()

    def local(self, point: str) -> np.ndarray:
        """Local coordinates of a point of this link."""
        return np.asarray(self.points[point], dtype=float)


@dataclass
class Load:
    """Base of applied loads. ``when``: a condition; the load acts only where it holds."""

    name: str
    when: Expression | None = None
    where: KeyPath = ()


@dataclass
class PointForce(Load):
    """A force at a point of a link: global components, or link-fixed with ``frame="link"``."""

    link: str = ""
    point: str = ""
    force: tuple[float, float] = (0.0, 0.0)
    frame: Literal["global", "link"] = "global"


@dataclass
class Torque(Load):
    """A torque (counter-clockwise positive) applied to a link by the ground."""

    link: str = ""
    torque: float = 0.0


@dataclass
class Spring(Load):
    """A linear spring between two points: force ``k (L - L0)`` along the line between them."""

    ends: tuple[tuple[str, str], tuple[str, str]] = (("", ""), ("", ""))  # (link, point) x 2
    stiffness: float = 0.0
    free_length: float = 0.0


@dataclass
class Damper(Load):
    """A viscous damper: between two points (force ``c dL/dt`` along the line), along a
    slider (force ``c ds/dt`` on the block), or at a point against its velocity (``drag``)."""

    ends: tuple[tuple[str, str], tuple[str, str]] | None = None
    slider: str | None = None
    drag: tuple[str, str] | None = None  # (link, point)
    coefficient: float = 0.0


@dataclass
class Limit:
    """A start position defined as the extreme of a quantity, e.g. K's right limit."""

    quantity: Expression
    extreme: Literal["min", "max"]


@dataclass
class Driver:
    """The input motion: a joint's coordinate moving at constant speed.

    For a :class:`PinJoint` the coordinate is the angle of link ``b`` relative to link
    ``a`` (of the line ``line`` of ``b`` when given, else of ``b``'s frame), in rad; for a
    :class:`SliderJoint` it is the slider displacement in m.

    Parameters
    ----------
    joint
        Name of the driven joint.
    speed
        Signed speed (rad/s or m/s); positive is counter-clockwise or along the line.
        Zero gives a quasi-static sweep: positions at rest (velocities and inertia zero),
        swept in the direction ``sense``.
    start
        Driver coordinate at the start of the sweep, or a :class:`Limit`.
    line
        Two points of the driven link whose direction the driver angle measures.
    """

    joint: str
    speed: float = 1.0
    start: float | Limit = 0.0
    line: tuple[str, str] | None = None
    sense: int | None = None  # +1 / -1: the direction of the sweep when speed is 0
    where: KeyPath = ()
    # a motion law of time instead of the constant speed (see mechsolve.model.motion);
    # ``speed`` then holds its nominal speed, whose sign is the direction of motion
    motion: object | None = None

    @property
    def direction(self) -> int:
        """+1 when the driver coordinate increases along the sweep, -1 otherwise."""
        if self.speed != 0:
            return 1 if self.speed > 0 else -1
        return self.sense if self.sense is not None else 1


@dataclass
class Sweep:
    """The positions to solve: driver ``travel`` from the start in steps of ``step``.

    Both are positive and measured in the direction of motion (rad or m). The number of
    intervals is ``round(travel / step)``; both ends are solved.
    """

    travel: float | None = None
    step: float | None = None
    where: KeyPath = ()
    # a sweep in time (a driver with a motion law): its length and step (s)
    duration: float | None = None
    time_step: float | None = None


@dataclass
class Assembly:
    """How to choose the assembly branch at the start of the sweep.

    Parameters
    ----------
    conditions
        Conditions the start position must satisfy, e.g. ``"B left of O3 -> A"`` or
        ``"C.x > B.x"``.
    sketch
        Approximate global coordinates of some points at the start (m); each loop is
        closed on the branch nearest to the sketch.
    """

    conditions: list[Expression] = field(default_factory=list)
    sketch: dict[str, tuple[float, float]] = field(default_factory=dict)
    where: KeyPath = ()
    condition_where: list[KeyPath] = field(default_factory=list)  # each condition's key

    def where_of(self, k: int) -> KeyPath:
        """The key path of condition ``k`` as the file wrote it."""
        if k < len(self.condition_where):
            return self.condition_where[k]
        return self.where + ("conditions", k)


@dataclass
class Outputs:
    """What to report. ``None`` means all.

    ``relative``: pairs of links ``(a, b)`` whose relative angle (a's minus b's), angular
    velocity and angular acceleration are reported as ``a/b.angle`` and so on.
    """

    points: list[str] | None = None
    links: list[str] | None = None
    sliders: list[str] | None = None
    velocity: bool = True
    acceleration: bool = True
    where: KeyPath = ()
    relative: list[tuple[str, str]] = field(default_factory=list)


@dataclass
class SolverOptions:
    """Options of the position solver.

    ``method``: ``"auto"`` splits the constraints into Assur groups and solves the
    groups it recognises in closed form, the others by Newton-Raphson; ``"newton"``
    solves the whole constraint system by Newton-Raphson at each position.
    ``compiled``: the Newton groups' batched sweeps take their coarse continuation
    through numba's compiled kernels (the ``fast`` extra; the same results).
    """

    method: Literal["auto", "newton"] = "auto"
    tolerance: float = 1e-10
    max_iterations: int = 30
    compiled: bool = False
    where: KeyPath = ()


@dataclass
class Mechanism:
    """A complete planar mechanism with its analysis request."""

    name: str
    ground: dict[str, tuple[float, float]]
    links: list[Link]
    joints: list[Joint]
    driver: Driver | None = None
    sweep: Sweep = field(default_factory=Sweep)
    assembly: Assembly = field(default_factory=Assembly)
    outputs: Outputs = field(default_factory=Outputs)
    solver: SolverOptions = field(default_factory=SolverOptions)
    gravity: tuple[float, float] | None = None  # None: (0, -9.81) if any link has mass
    loads: list[Load] = field(default_factory=list)
    length_unit: str = "m"
    angle_unit: str | None = None  # the file's units.angle, None when it names none
    source: Source | None = field(default=None, repr=False)
    # instants to solve besides the sweep: (u, u', u'', label), see mechsolve.analyses.instants
    instants: list[tuple[float, float, float, str]] = field(default_factory=list)
    # forward dynamics (mechsolve.model.machine): the motor, a flywheel, the simulation
    motor: object | None = None
    motors: dict = field(default_factory=dict)  # name -> (joint, Motor): simulate's general path
    flywheel: object | None = None
    simulation: object | None = None
    requirements: list = field(default_factory=list)  # mechsolve.results.requirements.Requirement

    # -- lookup --------------------------------------------------------------------
    def link(self, name: str) -> Link:
        # an index by name, rebuilt when the list of links is replaced or changes length
        # (a model built in code may be edited); a renamed link is found by a scan
        idx = self.__dict__.get("_link_index")
        if idx is None or idx[0] is not self.links or idx[1] != len(self.links):
            idx = (self.links, len(self.links), {lk.name: lk for lk in self.links})
            self.__dict__["_link_index"] = idx
        lk = idx[2].get(name)
        if lk is not None and lk.name == name:
            return lk
        for lk in self.links:
            if lk.name == name:
                return lk
        raise KeyError(name)

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)

    @property
    def link_names(self) -> list[str]:
        return [lk.name for lk in self.links]

    def output_units(self) -> OutputUnits:
        """The units results are shown in by default: the file's ``units:`` (lengths in
        its length unit, angles and, when it names one, angular rates in its angle unit;
        torques in N times its length unit), SI for a file without them."""
        return file_output_units(self.length_unit, self.angle_unit)

    def point_owners(self) -> dict[str, list[str]]:
        """For every point name, the links (``ground`` included) that carry it."""
        owners: dict[str, list[str]] = {p: [GROUND] for p in self.ground}
        for lk in self.links:
            for p in lk.points:
                owners.setdefault(p, []).append(lk.name)
        return owners

    def local_point(self, link: str, point: str) -> np.ndarray:
        if link == GROUND:
            return np.asarray(self.ground[point], dtype=float)
        return self.link(link).local(point)

    def has_point(self, link: str, point: str) -> bool:
        if link == GROUND:
            return point in self.ground
        return point in self.link(link).points

    @property
    def has_masses(self) -> bool:
        return any(lk.mass for lk in self.links)

    @property
    def needs_forces(self) -> bool:
        """Force analysis runs when the model has masses or loads."""
        return self.has_masses or bool(self.loads)

    def gravity_vector(self) -> tuple[float, float]:
        if self.gravity is not None:
            return self.gravity
        return (0.0, -STANDARD_G) if self.has_masses else (0.0, 0.0)

    @property
    def sliders(self) -> list[Joint]:
        """The joints with a relative travel (a length): sliders, whose displacement,
        velocity and acceleration the results report."""
        return [j for j in self.joints if j.coordinate == "length"]

    # -- errors --------------------------------------------------------------------
    def error(self, where: KeyPath, message: str) -> InputError:
        """An :class:`InputError` located at ``where`` in the source file, if any."""
        if self.source is not None:
            return self.source.error(where, message)
        from mechsolve.model.source import format_keypath

        return InputError(message, keypath=format_keypath(where) or None)

    # -- validation ----------------------------------------------------------------
    def validate(self) -> Mechanism:
        """Check the model's consistency; raise :class:`InputError` on the first problem."""
        from mechsolve.model.validate import validate

        validate(self)
        # what was checked: the next solve checks again only if the content changed since
        self.__dict__["_validated"] = content_snapshot(self) or True
        return self

    def ensure_valid(self) -> Mechanism:
        """Validate the model unless it was validated with this very content.

        A model loaded from a file, or solved once, may be edited in code afterwards (a
        mass, the sweep's step, a joint's link): it is checked again, as the file reader
        would check it, before it is solved. An unchanged model is not (the snapshot costs
        some 10 to 30 us, the checks ten times that)."""
        done = self.__dict__.get("_validated")
        if done is None or done is True or done != content_snapshot(self):
            self.validate()
        return self
