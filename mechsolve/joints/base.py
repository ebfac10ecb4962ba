"""The joint contract: what every joint kind knows and answers.

A joint kind is two small classes in one module:

* a :class:`Joint` (a dataclass the model holds, built from the file or in code): which
  links it joins and where, its share of Grübler's count, the relative coordinate a
  driver may drive, its keys and reader, its own checks, its description and drawing;
* a :class:`Constraint`: its equations bound to body indices, ``m`` equations
  ``Phi(q, t) = 0`` between bodies ``a`` and ``b`` with their Jacobian blocks, the
  velocity and acceleration right-hand sides, the coordinates each equation involves
  (for the structural split), the names of its equations, and the reaction its
  multipliers stand for.

Everything is evaluated for N positions at once from a :class:`~mechsolve.base.state.State`.
Velocities solve ``Phi_q qdot = nu`` and accelerations ``Phi_q qddot = gamma`` with
``nu = -Phi_t`` and ``gamma = -(Phi_q qdot)_q qdot - 2 Phi_qt qdot - Phi_tt``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from mechsolve.base.errors import suggest
from mechsolve.base.keyspec import JOINT_FRICTION, Key
from mechsolve.base.state import State

if TYPE_CHECKING:
    from collections.abc import Mapping


GROUND = "ground"
KeyPath = tuple[Any, ...]


class Constraint:
    """``m`` equations between bodies ``a`` and ``b`` (index ``nb`` is the ground).

    Subclasses return arrays of shape (m, N) for the residual, the velocity right-hand
    side ``nu`` and the acceleration right-hand side ``gamma``, and for each moving body
    involved the Jacobian block of shape (m, 3, N).

    ``letter`` is the kind's letter in the names of structural groups (``R``: revolute,
    ``P``: prismatic, ``D``: a driver; ``RRP`` is a dyad of two revolutes and a slider);
    the closed-form groups are recognised by these letters.

    ``joins_points`` is True for a constraint whose equations are exactly
    ``r_a + R(theta_a) sa - r_b - R(theta_b) sb = 0`` (a pin at local points ``sa``,
    ``sb``): code that evaluates many such equations at once as arrays may rely on it.
    """

    m: int = 0
    name: str = ""
    a: int
    b: int
    kind: str = ""
    letter: str = ""
    joins_points: bool = False
    # its slip is a sliding speed and its friction a force (a slider), not a turning rate
    # and a moment (a pin)
    slides: bool = False

    def residual(self, st: State, u) -> np.ndarray:
        raise NotImplementedError

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        raise NotImplementedError

    def nu(self, st: State, ud) -> np.ndarray:
        return np.zeros((self.m, st.n))

    def gamma(self, st: State, udd) -> np.ndarray:
        raise NotImplementedError

    def max_residual_into(self, st: State, u, out: np.ndarray) -> None:
        """``out = max(out, max |Phi|)`` over this constraint's equations, in place."""
        np.maximum(out, np.abs(self.residual(st, u)).max(axis=0), out=out)

    def incidence(self, nb: int) -> list[list[int]]:
        """For each equation, the coordinates (``3 * body + k``) it involves."""
        raise NotImplementedError

    def equation_names(self) -> list[str]:
        """One short name per equation, for messages about redundant equations."""
        return [f"{self.name} ({k + 1})" for k in range(self.m)]

    def reaction(self, st: State, lam: np.ndarray) -> dict[str, np.ndarray] | None:
        """The named reaction components from this constraint's multipliers ``lam`` (N, m),
        or ``None`` when its multipliers are not a joint's reaction (a driver's effort)."""
        return None

    def guide(self, st: State, scale: float) -> np.ndarray | None:
        """How a drawing shows this constraint beyond its links' outlines: a fixed guide
        line's segment ``[[x0, y0], [x1, y1]]`` over the travel seen in ``st`` (padded by
        a fraction of the mechanism's ``scale``), or ``None``."""
        return None

    def drawing(self, st: State, i: int) -> list[np.ndarray]:
        """What a drawing of position ``i`` adds for this constraint that moves with its
        links (a gear's pitch circle, a rack's pitch line): polylines, each an array of
        points ``(k, 2)``; none by default (see :meth:`guide` for fixed guides)."""
        return []

    def separating(self, st: State, lam: np.ndarray) -> list[tuple] | None:
        """A higher pair's contact force that its multipliers ``lam`` (N, m) do not carry
        and that does no work while the pair keeps contact (the radial, separating part of
        a gear tooth's force): point forces ``(body, x, y, fx, fy)`` (global point and
        components, arrays over the positions), which the force analysis applies as known
        loads to find what they add to the other joints' reactions. ``None``: nothing."""
        return None

    def cannot_close(self, st: State) -> None:
        """Where its group cannot close at the start (``st``: one position, the groups
        before it solved), raise an input error saying why if the joint can tell (a
        follower that cannot reach its cam), naming its key and line; else return."""

    def outlines(self) -> list[tuple[int, np.ndarray]]:
        """Curves this constraint draws fixed in its bodies (a cam's profile, its roller):
        each a body and the curve's points (k, 2) in the body's frame."""
        return []

    def indeterminate(self, free: np.ndarray) -> set[str]:
        """The reaction components that the multipliers flagged ``free`` (m,) leave
        undetermined (redundant constraints)."""
        return {"effort"}

    def law_breaks(self, st: State) -> np.ndarray | None:
        """Where the joint's own motion law is not smooth (a cam program's joins, where
        the follower's acceleration, and with it the forces, jump): for each such place
        a row of the signed distance to it at each position of ``st``, in the joint's own
        coordinate (rad), wrapped to (-pi, pi], shape (k, N); it changes sign where the
        motion passes the place. ``None``: the joint's motion is smooth everywhere."""
        return None

    @property
    def bodies(self) -> tuple[int, int]:
        return (self.a, self.b)

    # -- friction (see :mod:`mechsolve.core.friction`) ----------------------------------
    #: Coulomb friction per unit of :meth:`load`: a pin's friction circle rho = f r (m),
    #: a slider's coefficient f; zero: none.
    coulomb: float = 0.0
    #: The viscous part: friction per unit of :meth:`slip` (N m s/rad or N s/m).
    viscous: float = 0.0

    def slip(self, st: State) -> np.ndarray:
        """The relative speed whose sign friction opposes (a pin's relative angular speed
        of ``b`` on ``a``, a slider's sliding speed), (N,)."""
        raise NotImplementedError

    def load(self, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The load Coulomb's law multiplies from the multipliers ``lam`` (N, m) (a pin's
        force magnitude, a slider's normal force magnitude), and its gradient (N, m)."""
        raise NotImplementedError

    def friction_pull(self, st: State) -> list[tuple]:
        """A unit of friction opposing the slip (N,) at every position, as loads on the
        two bodies ``(body, x, y, fx, fy, torque)`` (a point force at the global point
        ``(x, y)`` and a torque, arrays over the positions), the second body's (the one
        :meth:`reaction` gives the force on) first; zero where the slip is."""
        raise NotImplementedError

    def friction_reaction(self, st: State, t: np.ndarray) -> dict[str, np.ndarray]:
        """The friction's part of the reaction components :meth:`reaction` names, for a
        friction of magnitude ``t`` (N,): what the joint's contact carries besides its
        ideal reaction (a slider's force along the line). None by default."""
        return {}


class Reader(Protocol):
    """What a joint's reader uses of the model's file reader (:mod:`mechsolve.model.reader`)."""

    def fail(self, path: tuple, message: str) -> Exception: ...

    def name(self, value: Any, path: tuple, what: str) -> str: ...

    def names(
        self,
        value: Any,
        path: tuple,
        what: str,
        count: int | None = None,
        least: int | None = None,
    ) -> list: ...

    def quantity(self, value: Any, path: tuple, kind: str) -> float: ...

    def xy(self, value: Any, path: tuple) -> tuple[float, float]: ...

    def mapping(self, value: Any, path: tuple, allowed: tuple, what: str) -> dict: ...


class Joint:
    """The contract of a joint kind (subclasses are dataclasses with ``name`` and ``where``).

    Class attributes
    ----------------
    kind
        The file's key of the kind (``revolute: [a, b]``) and its name in messages.
    title
        What it is, in a few words (the schema's description).
    roles
        What its two links are called in messages (``[guide, block]``).
    letter
        Its letter in the names of structural groups (``R``, ``P``).
    pair
        ``"lower"`` (surface contact: revolute, prismatic) or ``"higher"`` (line or point
        contact: gears, cams): Grübler's count lists them apart (Pl, Ph).
    removes
        The degrees of freedom it takes away (2 for a lower pair, 1 for a higher pair).
    coordinate
        The dimension of its relative coordinate (``"angle"``, ``"length"``), which a
        driver may drive and the results report; ``None`` if it has none.
    magnitude
        The reaction component plots show as its magnitude (``"F"``, ``"N"``), and
        ``magnitude_note`` what to add to its label.
    keys
        Its own keys in the file, beyond ``point`` and ``description``, in the order the
        messages list them.
    components
        Its reaction's CSV columns, ``(component, unit)`` in order; empty: a pin's
        (``Fx``, ``Fy``, ``F``) or a slider's (``N``, ``M``, ``Fx``, ``Fy``), as its
        reaction has them.
    """

    kind: ClassVar[str]
    title: ClassVar[str]
    roles: ClassVar[tuple[str, str]] = ("link", "link")
    letter: ClassVar[str]
    pair: ClassVar[str] = "lower"
    removes: ClassVar[int] = 2
    coordinate: ClassVar[str | None] = None
    magnitude: ClassVar[str] = "F"
    magnitude_note: ClassVar[str] = ""
    keys: ClassVar[dict[str, Key]] = {}
    components: ClassVar[tuple[tuple[str, str], ...]] = ()
    #: its friction (a revolute's and a slider's ``friction:``); None: an ideal joint
    friction: Friction | None = None

    name: str
    point: str
    where: KeyPath
    a: str  # the first link of :attr:`links`
    b: str  # the second

    @property
    def links(self) -> tuple[str, str]:
        """The two links it joins, in the order the file gives them."""
        raise NotImplementedError

    @property
    def label(self) -> str:
        """Where the joint is, for messages: its point, or its own name."""
        return self.name

    def joins(self, point: str) -> bool:
        """Does the joint make ``point`` one place on both its links?"""
        return False

    @property
    def local_dof(self) -> int:
        """Local degrees of freedom textbooks count with this joint that the file leaves
        out (a cam's roller spinning on its pin: 1); Grübler's count is the same either
        way, ``check`` shows both."""
        return 0

    # -- the file ---------------------------------------------------------------------
    @classmethod
    def read(
        cls, r: Reader, name: str, m: Mapping, path: tuple, points: Mapping[str, Mapping]
    ) -> Joint:
        """The joint from its mapping ``m`` in the file at ``path`` (``points``: every
        link's named points, the ground's under ``"ground"``)."""
        raise NotImplementedError

    def check(self, mech: Any, in_range: Callable[..., None]) -> None:
        """The kind's own checks on a mechanism (``mech.error(where, message)`` raises);
        ``in_range(mech, path, dimension, *values)`` refuses absurd magnitudes."""

    def check_start(self, mech: Any, c: Constraint, st: State) -> None:
        """The kind's checks of the assembled start position ``st`` (one position; ``c``
        its constraint), for what the file alone does not settle (a rack's pinion at its
        pitch radius from the pitch line); ``mech.error(where, message)`` raises."""

    # -- numbers that a batch of designs may vary -------------------------------------
    def geometry(self) -> list[float]:
        """The joint's own numbers (its points belong to its links)."""
        return []

    def with_geometry(self, cols: Any) -> Joint:
        """The same joint with its numbers taken in the order of :meth:`geometry` from
        ``cols`` (``cols.one()``: a number, ``cols.pair()``: a point; a batch of designs
        gives arrays)."""
        return self

    # -- the system -------------------------------------------------------------------
    def equations(self, mech: Any, index: Mapping[str, int]) -> Constraint:
        """Its constraint equations, bound to the body indices ``index``."""
        raise NotImplementedError

    # -- what is written ---------------------------------------------------------------
    def findings(
        self,
        r: Mapping[str, np.ndarray],
        ok: np.ndarray,
        u: np.ndarray,
        at: Callable,
        solve: Callable[[np.ndarray, int], Mapping[str, np.ndarray]] | None = None,
    ) -> tuple[list[str], list[str]]:
        """Lines for the force summary and warnings from its reaction ``r`` over the sweep
        (``ok``: the positions solved, ``u``: the driver's values, ``at(u)``: a driver
        value in words; ``solve(x, i)``, when given: its reaction solved at driver values
        ``x`` next to sample ``i``, to locate a figure between the samples)."""
        return [], []

    def describe(
        self, length: Callable[[float], str], angle: Callable[[float], str], unit: str
    ) -> tuple[str, str, str]:
        """The report's row: the links, the point, the kind's own geometry (``length``
        and ``angle`` format a length in ``unit`` and an angle in degrees)."""
        return (f"{self.a} – {self.b}", self.point, "")


@dataclass(frozen=True)
class Friction:
    """A joint's friction: Coulomb's coefficient ``coefficient``, a revolute's journal
    radius ``radius`` (m; its friction circle is ``coefficient * radius``) and a viscous
    part ``viscous`` (N m s/rad for a revolute, N s/m for a slider)."""

    coefficient: float = 0.0
    radius: float = 0.0
    viscous: float = 0.0

    @property
    def any(self) -> bool:
        return self.coefficient > 0 or self.viscous > 0


def read_friction(r: Reader, value: Any, path: tuple, kind: str, name: str) -> Friction:
    """A joint's ``friction: {coefficient, journal radius, viscous}`` at ``path``: a
    revolute needs its journal radius for a Coulomb part, a slider has none."""
    m = r.mapping(value, path, JOINT_FRICTION.allowed, f"the friction of joint {name!r}")
    f = 0.0
    if "coefficient" in m:
        f = r.quantity(m["coefficient"], path + ("coefficient",), "dimensionless")
        if not math.isfinite(f) or f < 0:
            raise r.fail(
                path + ("coefficient",),
                f"a friction coefficient is zero or positive, got {m['coefficient']!r}",
            )
    rad = 0.0
    if kind == "revolute":
        if "journal radius" in m:
            rad = r.quantity(m["journal radius"], path + ("journal radius",), "length")
            if not math.isfinite(rad) or rad <= 0:
                raise r.fail(
                    path + ("journal radius",),
                    f"a journal radius is positive, got {m['journal radius']!r}",
                )
        elif f > 0:
            raise r.fail(
                path,
                f"revolute {name!r} has a friction coefficient but no 'journal radius': "
                "its friction circle is rho = f r, e.g. friction: {coefficient: 0.1, "
                "journal radius: 10 mm}",
            )
    elif "journal radius" in m:
        raise r.fail(
            path + ("journal radius",),
            f"a {kind} has no journal: 'journal radius' applies to a revolute joint",
        )
    visc = 0.0
    if "viscous" in m:
        dim = "rotational damping" if kind == "revolute" else "damping"
        visc = r.quantity(m["viscous"], path + ("viscous",), dim)
        if not math.isfinite(visc) or visc < 0:
            raise r.fail(
                path + ("viscous",),
                f"a viscous coefficient is zero or positive, got {m['viscous']!r}",
            )
    if "coefficient" not in m and "viscous" not in m:
        raise r.fail(path, f"the friction of joint {name!r} needs 'coefficient' or 'viscous'")
    return Friction(f, rad, visc)


def read_meshing_links(
    r: Reader, m: Mapping, key: str, what: str, name: str, path: tuple, points: Mapping
) -> tuple[str, str]:
    """The two links of a higher pair's ``key: [a, b]``: distinct and existing (``what``
    names the pair in messages: "gear pair", "rack")."""
    a, b = r.names(m[key], path + (key,), "link", 2)
    if a == b:
        raise r.fail(path + (key,), f"{what} {name!r} meshes link {a!r} with itself")
    for i, ln in enumerate((a, b)):
        if ln not in points:
            raise r.fail(path + (key, i), f"no link named {ln!r}" + suggest(ln, list(points)))
    return a, b
