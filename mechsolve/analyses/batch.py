"""Designs that differ only in their numbers, solved as one batch.

A design study varies dimensions, masses and loads of one mechanism: every design has the
same links, joints, driver, sweep, loads and conditions, hence the same constraint
structure and group plan; only numbers differ. :func:`solve_designs` stacks the designs'
numbers into arrays with one value per column, a column being one position of one design
(design-major), and runs the vectorised group solvers and the force analysis once over
all the columns: local point coordinates, masses and loads are then arrays of N values
instead of numbers (see :mod:`mechsolve.base.state`).

The batch keeps every guarantee of a design's own sweep by handing a design to
:func:`mechsolve.solve` whenever its sweep needs more than closed forms on branches fixed
at the start:

* a model the batch does not take: a group solved by Newton, redundant constraints, a
  driver with a motion law or a start at a limit, a method other than ``auto``;
* a design whose structure differs from the first one's (another load, another sweep);
* a design whose start assembly the batch cannot decide alone (no branch closes, no
  branch satisfies the conditions: the design's own solve says why);
* a design whose sweep comes near a singular position: a position that does not close,
  a group's singularity indicator below ``sin 5 deg`` (the sweep reports near-singular
  minima below 3 deg), a discriminant that could reach zero within a step, joints that
  coincide. There the sweep's branch events and singular limits apply.

Designs solved either way give the same :class:`~mechsolve.results.results.Results`
(:meth:`DesignBatch.results`); the tests compare them with separate solves.

A batch without forces whose plan is a crank on the ground and RRR dyads runs a narrower
program (:mod:`mechsolve.analyses.batch_program`): the designs' numbers as columns against
the driver's row, only what a design's results are made of, the same screening decided
per design. Its states, rates and indicators are those of the general pass.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mechsolve.analyses.batch_program import Programs, plan_program, run_program
from mechsolve.base.errors import MechsolveError
from mechsolve.base.state import State
from mechsolve.core.branch_choice import _PendingConditions
from mechsolve.core.force_result import FrictionResult
from mechsolve.core.kinetostatics import ForceResult, solve_forces
from mechsolve.core.solution import PointRef, Solution, StartAssembly, StateView
from mechsolve.core.sweep import Analysis, _scale
from mechsolve.groups import Drive, NewtonGroup, build_plan
from mechsolve.model import (
    Damper,
    Limit,
    Mechanism,
    PointForce,
    Spring,
    Torque,
    as_snapshotted,
)
from mechsolve.results.results import Results
from mechsolve.results.run import checked_mechanism
from mechsolve.results.run import solve as solve_sweep
from mechsolve.system.constraints import ConstraintSystem

__all__ = ["DesignBatch", "number_index", "solve_designs", "solve_parsed"]

NEAR = math.sin(math.radians(5.0))  # indicators below this: the design's own sweep


# columns per pass: a pass's fixed cost (rebuilding the analysis, about 2 ms) against its
# arrays' memory. 1024 four-bar designs of 361 positions: 2.1 ms per pass at 4096 columns
# (90 passes), and 32768, 65536 and 131072 columns take 219, 189 and 177 ms with a peak
# of 289, 301 and 325 MB (284 MB of it the results kept)
CHUNK_COLUMNS = 131072
# the narrower program's passes (mechsolve.analyses.batch_program): it works in blocks of
# its own and keeps some 13 arrays of its pass's size, not a state of 44, so that one
# pass takes 8 times the columns; fewer passes, fewer start assemblies
PROGRAM_COLUMNS = 8 * CHUNK_COLUMNS


@dataclass
class DesignBatch:
    """Designs of one mechanism solved together (see the module docstring).

    Attributes
    ----------
    mechanisms
        The designs, in the order given.
    u
        The driver values of every design's sweep (rad or m).
    batched
        Which designs the batch solved (the others were solved one at a time).
    why
        For each design solved on its own: why the batch did not take it.
    """

    mechanisms: Sequence[Mechanism]
    u: np.ndarray
    batched: np.ndarray
    why: dict[int, str] = field(default_factory=dict)
    _separate: dict = field(default_factory=dict, repr=False)
    _passes: list = field(default_factory=list, repr=False)
    _where: dict = field(default_factory=dict, repr=False)  # design -> (pass, slot)
    # (first, end, pass): the designs first to end - 1 in the slots 0, 1, ... of the pass
    # (a pass that kept a run of consecutive designs: no entry per design in _where)
    _spans: list = field(default_factory=list, repr=False)
    # forces by default: a design without masses or loads gets none, as alone
    _auto_forces: bool = field(default=False, repr=False)
    # the designs' contents as solved (mechsolve.model.content_snapshot): a user's design
    # edited after solve_designs still gets the results of the design as solved
    _snapshots: list | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return len(self.mechanisms)

    def results(self, k: int):
        """The :class:`~mechsolve.results.results.Results` of design ``k``: the same as
        ``mechsolve.solve`` gives; raises the design's error if it could not be solved."""

        if k in self._separate:
            out = self._separate[k]
            if isinstance(out, BaseException):
                raise out
            return out
        pi, j = self._slot(k)
        b = self._passes[pi]
        P = len(self.u)
        sl = slice(j * P, (j + 1) * P)
        mech, snap = self.mechanisms[k], None
        if self._snapshots is not None:  # a user's design, as solved (see Results.model_as_solved)
            mech, snap = as_snapshotted(mech, self._snapshots[k])
        an = Analysis(mech, "auto")  # the only method the batch takes
        an.solved_snapshot = snap  # (None: a design of a study, the batch's own)
        modes = [float(m) for m in b["modes"][:, j]]
        start = StartAssembly(
            modes, {}, [r[j] for r in b["reasons"]], b["start"].take([j]), b["u0"], modes
        )
        prog: Programs | None = b.get("program")
        if prog is not None:  # the narrower program's pass: the design's row written out
            sol = Solution(
                an,
                self.u.copy(),
                b["t"].copy(),
                prog.state(j),
                np.ones(P, bool),  # (a kept design closes everywhere)
                [],
                prog.indicator(j),
                np.zeros(P, int),
                None,
                None,
                start,
                [],
                b["has_velocity"],
                b["has_acceleration"],
                [],
                {gi: [] for gi in range(len(an.plan))},
            )
            return Results(an, sol, None)
        sol_b: Solution = b["solution"]
        sol = Solution(
            an,
            self.u.copy(),
            sol_b.t[sl].copy(),
            sol_b.state.take(sl),
            sol_b.ok[sl].copy(),
            [],
            sol_b.indicator[:, sl].copy(),
            np.zeros(P, int),
            None,
            None,
            start,
            [],
            sol_b.has_velocity,
            sol_b.has_acceleration,
            [],
            {gi: [] for gi in range(len(an.plan))},
        )
        f = b["forces"]
        if f is None or (self._auto_forces and not mech.needs_forces):
            return Results(an, sol, None)
        return Results(an, sol, _slice_forces(f, sl, j))

    def _slot(self, k: int) -> tuple[int, int]:
        """The pass and the slot in it of design ``k`` (solved by the batch)."""
        got = self._where.get(k)
        if got is not None:
            return got
        for lo, hi, pi in self._spans:
            if lo <= k < hi:
                return pi, k - lo
        raise KeyError(k)


def _slice_forces(f: ForceResult, sl: slice, j: int) -> ForceResult:
    def cut(d):
        return {k: v[sl] for k, v in d.items()}

    terms = f._terms if f.energy_terms is not None else None
    return ForceResult(
        f.lam[sl],
        f.effort[sl],
        {joint: cut(v) for joint, v in f.reactions.items()},
        cut(f.active),
        f.power_loads[sl],
        [(i - sl.start, g) for i, g in f.singular if sl.start <= i < sl.stop],
        None if f.ok is None else f.ok[sl],
        load_power=cut(f.load_power),
        nonunique=f.nonunique,
        stroke_extremes=[(float(lo[j]), float(hi[j])) for lo, hi in f.stroke_extremes],
        speed=f.speed[sl] if np.ndim(f.speed) else f.speed,
        energy_terms=(lambda: tuple(a[sl] for a in terms())) if terms is not None else None,
        friction=None if f.friction is None else _slice_friction(f.friction, sl),
    )


def _slice_friction(fr: FrictionResult, sl: slice) -> FrictionResult:
    """One design's share of the joints' friction."""
    return FrictionResult(
        {k: v[sl] for k, v in fr.friction.items()},
        {k: v[sl] for k, v in fr.loss.items()},
        fr.ideal_effort[sl],
        fr.locked[sl],
        fr.iterations,
    )


# -- the designs' structure and numbers -------------------------------------------------
_LOAD_KEYS = ("link", "point", "frame", "ends", "slider", "drag")  # a load's structure


def _split(m: Mechanism) -> tuple[tuple, list[float]]:
    """A design's structure and its numbers, in one pass over it (a design study checks
    thousands of designs: plain loops, each object read once).

    The structure is everything but the numbers the batch stacks: two designs whose
    structures are equal differ only in those numbers, and can be solved as one batch.
    The numbers come in a fixed order (see :func:`_with_numbers`)."""
    nums: list[float] = []
    add, one = nums.extend, nums.append
    for xy in m.ground.values():
        add(xy)
    links = []
    for lk in m.links:
        pts, mass, inertia, com = lk.points, lk.mass, lk.inertia, lk.com
        for xy in pts.values():
            add(xy)
        if mass is not None:
            one(mass)
        if inertia is not None:
            one(inertia)
        if com is not None:
            add(com)
        links.append((lk.name, tuple(pts), mass is None, com is None, inertia is None))
    joints = []
    for j in m.joints:
        add(j.geometry())
        joints.append((j.kind, j.name, j.a, j.b, j.point))
    loads = []
    for ld in m.loads:
        when = ld.when
        loads.append(
            (type(ld), ld.name, None if when is None else when.text)
            + tuple([getattr(ld, k, None) for k in _LOAD_KEYS])
        )
        if isinstance(ld, PointForce):
            nums += ld.force
        elif isinstance(ld, Torque):
            one(ld.torque)
        elif isinstance(ld, Spring):
            nums += [ld.stiffness, ld.free_length]
        elif isinstance(ld, Damper):
            one(ld.coefficient)
    structure = (
        m.driver,
        m.sweep,
        m.outputs,
        m.solver,
        m.assembly.sketch,
        m.gravity_vector(),
        tuple(m.ground),
        tuple(links),
        tuple(joints),
        tuple(loads),
        tuple([c.text for c in m.assembly.conditions]),
    )
    return structure, nums  # numbers: np.array(..., float) makes them floats


def number_index(m: Mechanism) -> dict[tuple, int]:
    """Where each number of a design's geometry and masses sits among the stacked
    numbers (:func:`_split`'s order): ``("ground", P, i)``, ``("point", LINK, P, i)``,
    ``("mass", LINK)``, ``("inertia", LINK)``, ``("com", LINK, i)``. The numbers after
    them (joints' geometry, loads) are not named."""
    out: dict[tuple, int] = {}
    n = 0
    for p in m.ground:
        out["ground", p, 0], out["ground", p, 1] = n, n + 1
        n += 2
    for lk in m.links:
        for p in lk.points:
            out["point", lk.name, p, 0], out["point", lk.name, p, 1] = n, n + 1
            n += 2
        if lk.mass is not None:
            out["mass", lk.name] = n
            n += 1
        if lk.inertia is not None:
            out["inertia", lk.name] = n
            n += 1
        if lk.com is not None:
            out["com", lk.name, 0], out["com", lk.name, 1] = n, n + 1
            n += 2
    return out


def _numbers(m: Mechanism) -> list[float]:
    """The numbers the batch stacks, in a fixed order (see :func:`_with_numbers`)."""
    return _split(m)[1]


def _stackable(mechs: list[Mechanism], alone: dict[int, str]) -> dict[int, list[float]]:
    """The numbers of every design whose structure is the first one's; the others go to
    ``alone``, with the reason."""
    ref_structure, nums = _split(mechs[0])
    rows = {0: nums}
    ref_line = _driver_line(mechs[0])
    for k in range(1, len(mechs)):
        structure, nums = _split(mechs[k])
        if structure != ref_structure:
            alone[k] = "its structure differs from the first design's"
        elif _driver_line(mechs[k]) != ref_line:
            # the driver's angle is measured from a line whose direction is one number of
            # the constraint system, not a stacked column
            alone[k] = "the line its driver's angle is measured from differs from the first's"
        else:
            rows[k] = nums
    return rows


def _driver_line(m: Mechanism) -> tuple[float, ...] | None:
    """The local coordinates of the two points the driver's angle is measured from, or
    None when it is measured from the link's own x axis."""
    d = m.driver
    if d.line is None or m.joint(d.joint).coordinate == "length":
        return None
    b = m.joint(d.joint).b
    return tuple(float(v) for p in d.line for v in m.local_point(b, p))


class _Columns:
    """Hands out the stacked numbers in :func:`_numbers`' order: a number equal in every
    design stays a float; one that varies is an array over the columns.

    The columns are either given by their designs (``design_of_column``), or each
    design has ``per`` consecutive columns (the sweep's layout): then a design's number
    is written into its columns by broadcasting, without an index array."""

    def __init__(self, X: np.ndarray, design_of_column=None, *, per: int = 0) -> None:
        self.X, self.cols, self.k, self.per = X, design_of_column, 0, per
        self.n = X.shape[0] * per if per else len(design_of_column)
        # the numbers equal in every design (np.all(col == col[0]) per column, at once)
        self.same = (X == X[:1]).all(axis=0).tolist() if X.shape[0] else []

    def _next(self):
        """The next number: a float when every design has the same, else its column."""
        k = self.k
        self.k += 1
        return float(self.X[0, k]) if self.same[k] else self.X[:, k]

    def _spread(self, col: np.ndarray, out: np.ndarray) -> np.ndarray:
        if self.per:
            out.reshape(-1, self.per)[:] = col[:, None]
        else:
            np.take(col, self.cols, out=out)
        return out

    def one(self):
        v = self._next()
        return v if isinstance(v, float) else self._spread(v, np.empty(self.n))

    def pair(self):
        """A point or vector: a pair of floats, or one array (2, N) (which ``np.asarray``
        takes as it is, where the model's pairs are read)."""
        a, b = self._next(), self._next()
        if isinstance(a, float) and isinstance(b, float):
            return (a, b)
        out = np.empty((2, self.n))
        for row, v in zip(out, (a, b)):
            if isinstance(v, float):
                row[:] = v
            else:
                self._spread(v, row)
        return out


def _with_numbers(m: Mechanism, cols: _Columns) -> Mechanism:
    """A copy of ``m`` holding the stacked numbers (the inverse of :func:`_numbers`)."""
    out = copy.copy(m)
    out.__dict__.pop("_link_index", None)
    out.ground = {p: cols.pair() for p in m.ground}
    links = []
    for lk in m.links:
        pts = {p: cols.pair() for p in lk.points}
        mass = cols.one() if lk.mass is not None else None
        inertia = cols.one() if lk.inertia is not None else None
        com = cols.pair() if lk.com is not None else None
        links.append(dataclasses.replace(lk, points=pts, mass=mass, inertia=inertia, com=com))
    out.links = links
    joints = []
    for j in m.joints:
        joints.append(j.with_geometry(cols))
    out.joints = joints
    loads = []
    for ld in m.loads:
        if isinstance(ld, PointForce):
            ld = dataclasses.replace(ld, force=cols.pair())
        elif isinstance(ld, Torque):
            ld = dataclasses.replace(ld, torque=cols.one())
        elif isinstance(ld, Spring):
            ld = dataclasses.replace(ld, stiffness=cols.one(), free_length=cols.one())
        elif isinstance(ld, Damper):
            ld = dataclasses.replace(ld, coefficient=cols.one())
        loads.append(ld)
    out.loads = loads
    return out


def _not_batchable(m: Mechanism, an, method: str | None) -> str | None:
    """Why the batch cannot take this model at all, or None."""
    if (method or m.solver.method) != "auto":
        return f"method {method or m.solver.method}"
    if m.driver.motion is not None:
        return "a driver with a motion law"
    if isinstance(m.driver.start, Limit):
        return "a start at a limit"
    if an.redundant:
        return "redundant constraints"
    if any(isinstance(g, NewtonGroup) for g in an.plan):
        return "a group solved by Newton"
    return None


def _reference(ref: Mechanism, method: str | None, like: Analysis | None) -> Analysis:
    """The analysis of the batch's reference design ``ref``: a new one, or, given
    ``like`` (an analysis of a design with ``ref``'s structure, the study's file:
    :mod:`mechsolve.analyses.study.family`), a copy of it with ``ref``'s mechanism, size
    and tolerance. Its constraint system, plan and named points are then ``like``'s: the
    batch reads their structure only, and each pass's analysis is rebuilt from the
    stacked numbers with the reference's size (:func:`_analysis_of`)."""
    if like is None:
        return Analysis(ref, method)
    an = copy.copy(like)
    an.mech = ref
    an.scale = _scale(ref)  # (as Analysis makes them)
    an.atol = ref.solver.tolerance * an.scale
    return an


def _analysis_of(an0, mech_b: Mechanism):
    """The first design's analysis with the stacked numbers: its constraint system, group
    plan and named points rebuilt from ``mech_b`` (the structure is the same), its
    groups' size and direction the first design's (as :class:`Analysis` sets them)."""
    ab = copy.copy(an0)
    ab.mech = mech_b
    ab.system = ConstraintSystem(mech_b)
    its = mech_b.solver.max_iterations
    ab.groups = ab.plan = build_plan(ab.system, "auto", an0.atol, its)
    sizes = {"scale": an0.scale, "lref": an0.scale, "direction": float(an0.mech.driver.direction)}
    for g0, g in zip(an0.plan, ab.plan):
        for attr, v in sizes.items():
            if hasattr(g0, attr):
                setattr(g, attr, v)
    points = {}
    for p, ref in an0.points.items():
        if ref.body == ab.system.nb and p in mech_b.ground:
            loc = mech_b.ground[p]
        else:
            lk = next(lk for lk in mech_b.links if ab.system.index[lk.name] == ref.body)
            loc = lk.points[p]
        points[p] = PointRef(ref.body, np.asarray(loc, float))
    ab.points = points
    return ab


# -- the start assembly of every design at once ----------------------------------------
def _design_states(an0, X: np.ndarray, modes: np.ndarray, speed: float):
    """A function of driver values ``u`` (designs, L) solving each design (numbers ``X``,
    branches ``modes``) at its own values, at the driver's speed: the analysis of those
    columns, their state and where they close (for stroke(q)'s extremes between the
    samples, :func:`mechsolve.core.loads.exact_extremes`)."""

    def solve(u: np.ndarray):
        nd, L = u.shape
        a = _analysis_of(an0, _with_numbers(an0.mech, _Columns(X, per=L)))
        n = nd * L
        st = State(a.system.nb, n)
        unit = Drive(u.ravel(), np.ones(n), np.zeros(n))
        ok = np.ones(n, bool)
        with np.errstate(invalid="ignore", divide="ignore"):
            for gi, g in enumerate(a.plan):
                good, _ = g.position(st, unit, np.repeat(modes[gi], L) if g.n_modes == 2 else 1.0)
                g.velocity(st, unit)
                g.acceleration(st, unit)
                ok &= good
        if speed != 1.0:
            st.block[5:8] *= speed
            st.block[8:11] *= speed * speed
            st.token = State.new_token()
        return a, st, ok

    return solve


def _bodies(bodies) -> slice | list[int]:
    """A group's bodies as an index of the state's rows: a slice when consecutive."""
    b = list(bodies)
    if b and b == list(range(b[0], b[0] + len(b))):
        return slice(b[0], b[0] + len(b))
    return b


def _assemble(ab, u0: float, nd: int):
    """Every design's branches at the start, as :meth:`Analysis.assemble` chooses them
    (conditions, then the sketch, then branch +), on ``2 nd`` columns: branch + of each
    design, then branch -. Returns the modes (groups, nd), the reasons, the state at the
    start (nd columns, rates per unit driver coordinate) and the designs it could not
    decide (their own assembly says why)."""

    n2 = 2 * nd
    st2 = State(ab.system.nb, n2)
    unit2 = Drive(np.full(n2, u0), np.ones(n2), np.zeros(n2))
    conds = _PendingConditions(ab, ab.mech.assembly.conditions)
    G = len(ab.plan)
    modes = np.ones((G, nd))
    reasons = [[""] * nd for _ in range(G)]
    undecided = np.zeros(nd, bool)
    sign = np.ones(n2)
    sign[nd:] = -1.0
    for gi, g in enumerate(ab.plan):
        conds.solved(g.bodies)
        ready = conds.ready()
        if g.n_modes < 2:
            ok, _ = g.position(st2, unit2, 1.0)
            g.velocity(st2, unit2)
            undecided |= ~ok[:nd]
            continue
        ok2, _ = g.position(st2, unit2, sign)
        g.velocity(st2, unit2)
        okp, okm = ok2[:nd], ok2[nd:]
        co = getattr(g, "coincident", None)
        c = co(st2) if co is not None else None
        if c is not None:
            undecided |= c[:nd] | c[nd:]
        take_m, why, conflict, _ = ab._choose_branches(g, st2, ok2, ready)
        undecided |= ~(okp | okm) | conflict
        modes[gi] = np.where(take_m, -1.0, 1.0)
        reasons[gi] = list(why)
        # keep the chosen branch in both halves
        b = _bodies(g.bodies)
        blk = st2.block
        if take_m.any():
            chosen = np.where(take_m, blk[:, b, nd:], blk[:, b, :nd])
            blk[:, b, :nd] = chosen
            blk[:, b, nd:] = chosen
        else:  # branch + in every design (the same values, without the selection)
            blk[:, b, nd:] = blk[:, b, :nd]
        st2.token = State.new_token()
        conds.use(ready)
    view = StateView(ab, st2)
    view.has_velocity = view.has_acceleration = False
    for _, cond in conds.remaining():  # conditions no group decided: they must hold
        holds = np.broadcast_to(np.asarray(cond.evaluate(view), bool), (n2,))
        undecided |= ~holds[:nd]
    return modes, reasons, st2.take(slice(0, nd)), undecided


# -- the batch --------------------------------------------------------------------------
def solve_designs(
    mechs: Sequence[Mechanism],
    *,
    step: float | None = None,
    method: str | None = None,
    forces: bool | None = None,
    acceleration: bool | None = None,
) -> DesignBatch:
    """Solve the sweeps of many designs of one mechanism at once.

    Parameters
    ----------
    mechs
        The designs (e.g. ``Study.mechanism(k)``). Each is validated as
        :func:`mechsolve.solve` validates it: one built in code, or edited since it was
        loaded or validated, is checked again (its :class:`InputError` raised here). Designs
        whose structure differs from the first one's are solved one at a time.
    step, method
        As for :func:`mechsolve.solve` (the same for every design).
    forces
        Run the force analysis (default: for the designs that have masses or loads, as
        ``mechsolve.solve`` decides for each).
    acceleration
        Compute the accelerations (default: as the first design's outputs ask). The
        force analysis needs them: with forces they are always computed. A caller that
        reads no acceleration (a study without forces whose figures are positions,
        rates and transmission angles) saves their work; the results then say that
        they have none (``solution.has_acceleration``), as ``mechsolve.solve`` with
        ``acceleration=False`` does.

    Returns
    -------
    DesignBatch
        ``results(k)`` gives design ``k``'s Results, the same as ``mechsolve.solve``
        would; designs that cannot be solved raise their error there.
    """

    mechs = list(mechs)
    checked: set[int] = set()
    for m in mechs:  # as mechsolve.solve: built in code, or edited since it was validated
        if id(m) not in checked:  # (a design listed twice is checked once)
            checked.add(id(m))
            checked_mechanism(m).ensure_valid()
    out = solve_parsed(mechs, step=step, method=method, forces=forces, acceleration=acceleration)
    out._snapshots = [m.__dict__.get("_validated") for m in mechs]  # (just validated)
    return out


def solve_parsed(
    mechs: list[Mechanism],
    *,
    step: float | None = None,
    method: str | None = None,
    forces: bool | None = None,
    acceleration: bool | None = None,
) -> DesignBatch:
    """:func:`solve_designs` of designs known to be valid as they are: each parsed and
    validated by the caller a moment before, none edited since (a study's chunk). The
    check :func:`solve_designs` makes (a snapshot of each design's content, some 27 us
    a design) is not repeated."""
    nd = len(mechs)
    out = DesignBatch(mechs, np.zeros(0), np.zeros(nd, bool), _auto_forces=forces is None)
    if not nd:
        return out
    # by default, forces where any design needs them; results(k) gives them to the designs
    # that do, as mechsolve.solve would
    want_forces = any(m.needs_forces for m in mechs) if forces is None else forces
    return solve_stacked(out, None, {}, want_forces, step, method, forces, acceleration)


def solve_stacked(
    out: DesignBatch,
    rows: dict[int, Sequence[float]] | np.ndarray | None,
    alone: dict[int, str],
    want_forces: bool,
    step: float | None,
    method: str | None,
    forces: bool | None,
    acceleration: bool | None,
    like: Analysis | None = None,
) -> DesignBatch:
    """Solve the designs of ``out`` (its ``mechanisms``, a sequence that builds a design
    when asked for it) into ``out``. ``rows``: every design's stacked numbers
    (:func:`_split`'s order), by design or as an array (designs, numbers) whose row ``k``
    is design ``k``'s, given by a caller that knows every design has the first one's
    structure (:mod:`mechsolve.analyses.study.family`); None reads them from the designs.
    ``alone``: designs the caller already knows go on their own (with the reason); the
    first design not among them is the batch's reference. ``like``: an analysis (method
    ``method``) of a design whose structure is every design's (:func:`_reference`)."""
    mechs = out.mechanisms
    nd = len(mechs)
    first = next((k for k in range(nd) if k not in alone), None)
    if first is None:
        _solve_alone(out, alone, step, method, acceleration, forces)
        return out
    ref = mechs[first]
    want_acc = bool(
        want_forces or (ref.outputs.acceleration if acceleration is None else acceleration)
    )
    try:
        an0 = _reference(ref, method, like)
        why = _not_batchable(ref, an0, method)
    except MechsolveError as exc:
        an0, why = None, str(exc)
    if why is not None:
        alone.update((k, why) for k in range(nd) if k not in alone)
    elif rows is None:
        todo = [k for k in range(nd) if k not in alone]
        alone_sub: dict[int, str] = {}
        got = _stackable([mechs[k] for k in todo], alone_sub)
        alone.update((todo[j], r) for j, r in alone_sub.items())
        rows = {todo[j]: v for j, v in got.items()}
    inside = [k for k in range(nd) if k not in alone] if alone else list(range(nd))
    if inside:
        u0 = an0.start_value()
        u, t = an0.sweep_values(u0, step=step)
        out.u = u
        if isinstance(rows, np.ndarray):
            X = rows if len(inside) == nd else rows[inside]
        else:
            X = np.array([rows[k] for k in inside], dtype=float)
        program = not want_forces and plan_program(an0.plan, an0.system.nb)
        per = max(1, (PROGRAM_COLUMNS if program else CHUNK_COLUMNS) // max(len(u), 1))
        for i in range(0, len(inside), per):
            todo = (inside[i : i + per], X[i : i + per])
            _solve_pass(out, an0, *todo, u, t, alone, want_forces, want_acc)
        for k in alone:
            out._where.pop(k, None)
    _solve_alone(out, alone, step, method, None if want_forces else acceleration, forces)
    if out.u.size == 0 and out._separate:
        first_res = next(iter(out._separate.values()))
        if not isinstance(first_res, BaseException):
            out.u = first_res.u
    return out


def _solve_alone(out: DesignBatch, alone: dict, step, method, acceleration, forces) -> None:
    """The designs the batch did not take, each solved on its own (its error kept)."""
    for k, reason in alone.items():
        if k in out._separate:  # (given by the caller: an invalid design's error)
            continue
        out.why[k] = reason
        try:
            out._separate[k] = solve_sweep(
                out.mechanisms[k],
                step=step,
                method=method,
                acceleration=acceleration,
                forces=forces,
            )
        except MechsolveError as exc:
            out._separate[k] = exc


def _program_pass(out, an0, a2, inside, modes, reasons, start, risky, u, t, alone, acc) -> None:
    """The pass of a plan the narrower program takes (:mod:`mechsolve.analyses.batch_program`):
    kinematics without forces, the same designs kept and the same results."""
    nd = len(inside)
    prog = run_program(a2.plan, a2.system.nb, nd, u, modes, an0.speed, NEAR, acc)
    risky = risky | prog.risky
    why = "its sweep comes near a singular position or does not close"
    for j in np.flatnonzero(risky).tolist():
        alone[inside[j]] = why
    if risky.all():
        return
    pi = len(out._passes)
    has_vel = bool(acc or an0.mech.outputs.velocity)
    out._passes.append(
        {
            "modes": modes,
            "reasons": reasons,
            "start": start,
            "u0": float(u[0]),
            "program": prog,
            "t": np.asarray(t, float),
            "has_velocity": has_vel,
            "has_acceleration": bool(acc),
        }
    )
    if risky.any():
        kept = np.flatnonzero(~risky).tolist()  # a design's row in the program is its row
        ks = [inside[j] for j in kept]
    else:
        kept, ks = range(nd), inside
    if ks and ks[-1] - ks[0] == len(ks) - 1:  # (inside is increasing: consecutive designs)
        out.batched[ks[0] : ks[-1] + 1] = True
        if not kept[0]:  # design ks[0] + j in row j: one span, not an entry per design
            out._spans.append((ks[0], ks[-1] + 1, pi))
            return
    else:
        out.batched[ks] = True
    out._where.update(zip(ks, zip(itertools.repeat(pi), kept)))


def _solve_pass(out: DesignBatch, an0, inside, X, u, t, alone, want_forces, has_acc) -> None:
    """Solve the designs ``inside`` (numbers ``X``) as one pass into ``out``; designs that
    leave the closed forms' safe ground go to ``alone``. The velocities are always
    computed (the discriminant's rate reads them), the accelerations with ``has_acc``."""
    ref = an0.mech
    has_vel = bool(has_acc or ref.outputs.velocity)
    nd = len(inside)
    u0 = float(u[0])
    P = len(u)
    with np.errstate(invalid="ignore", divide="ignore"):
        # the start: two columns per design (branch + and -)
        cols2 = np.tile(np.arange(nd), 2)
        a2 = _analysis_of(an0, _with_numbers(ref, _Columns(X, cols2)))
        modes, reasons, start_state, risky = _assemble(a2, u0, nd)
        if not want_forces and plan_program(an0.plan, an0.system.nb):
            todo = (inside, modes, reasons, start_state, risky, u, t, alone, has_acc)
            _program_pass(out, an0, a2, *todo)
            return
        # the sweep: one column per position of each design
        ab = _analysis_of(an0, _with_numbers(ref, _Columns(X, per=P)))
        N = nd * P
        st = State(ab.system.nb, N)
        unit = Drive(np.tile(u, nd), np.ones(N), np.zeros(N), period=P)
        ok_all = np.ones(N, bool)
        inds = []
        h = float(abs(u[1] - u[0])) if P > 1 else 0.0
        for gi, g in enumerate(ab.plan):
            two = g.n_modes == 2
            ok, ind = g.position(st, unit, np.repeat(modes[gi], P) if two else 1.0)
            g.velocity(st, unit)
            if has_acc:
                g.acceleration(st, unit)
            ok_all &= ok
            inds.append(ind)
            bad = ~ok | ~(ind > NEAR)
            if two:
                # the discriminant stays clear of zero at and between the samples: no
                # toggle, bifurcation or dead zone that the sweep's branch analysis meets
                H, dH = g.disc(st)
                hdH = np.abs(dH)  # h |dH|: how far H can move within a step
                hdH *= h
                clear = np.subtract(H, hdH)
                bad |= ~(clear > 0)
                del clear
                if P > 1:
                    # a lower bound of the cubic Hermite interpolant on each step (the
                    # sweep's branch analysis interpolates so): its value weights are
                    # positive and sum to 1, its slope weights are at most 4/27 in size
                    Hd, dHd = H.reshape(nd, P), hdH.reshape(nd, P)
                    low = np.minimum(Hd[:, :-1], Hd[:, 1:])
                    low -= (4.0 / 27.0) * (dHd[:, :-1] + dHd[:, 1:])
                    bad.reshape(nd, P)[:, 1:] |= ~(low > 0)
                co = getattr(g, "coincident", None)
                c = co(st) if co is not None else None
                if c is not None:
                    bad |= c
            risky |= bad.reshape(nd, P).any(axis=1)
    speed = an0.speed
    if speed != 1.0:  # rates per unit driver coordinate -> time rates
        st.block[5:8] *= speed
        if has_acc:
            st.block[8:11] *= speed * speed
        st.token = State.new_token()
    for j, k in enumerate(inside):
        if risky[j]:
            alone[k] = "its sweep comes near a singular position or does not close"
    keep = np.flatnonzero(~risky)
    if not keep.size:
        return
    if keep.size < nd:  # only the designs that stay on safe ground
        cols = (keep[:, None] * P + np.arange(P)).ravel()
        st = st.take(cols)
        ok_all = ok_all[cols]
        inds = [i[cols] for i in inds]
        ab = _analysis_of(an0, _with_numbers(ref, _Columns(X[keep], per=P)))
        modes = modes[:, keep]
        reasons = [[r[j] for j in keep] for r in reasons]
        start_state = start_state.take(keep)
    ab.blocks = int(keep.size)  # stroke(q): each design's own extremes
    ab.design_states = _design_states(an0, X[keep], modes, speed)  # ... located exactly
    n = keep.size * P
    sol = Solution(
        ab,
        unit.u if keep.size == nd else np.tile(u, keep.size),  # (the sweep's own)
        np.tile(t, keep.size),
        st,
        ok_all,
        [],
        np.array(inds),
        np.zeros(n, int),
        None,
        None,
        StartAssembly(list(modes[:, 0]), {}, [r[0] for r in reasons], start_state, u0),
        [],
        has_vel,
        has_acc,
        [],
        {gi: [] for gi in range(len(ab.plan))},
    )
    forces = None
    if want_forces:
        with np.errstate(invalid="ignore", divide="ignore"):
            forces = solve_forces(ab, sol)
    pi = len(out._passes)
    out._passes.append(
        {
            "modes": modes,
            "reasons": reasons,
            "start": start_state,
            "u0": u0,
            # without the pass's analysis: a design's results are made from the state,
            # the flags and the forces, and the analysis holds the stacked numbers and
            # its groups' intermediate arrays (some twenty of the pass's size), whose
            # memory the next pass can then reuse
            "solution": dataclasses.replace(sol, analysis=None),
            "forces": forces,
        }
    )
    for slot, j in enumerate(keep):
        out._where[inside[j]] = (pi, slot)
        out.batched[inside[j]] = True
