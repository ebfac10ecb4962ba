"""Structural analysis: degrees of freedom and the split into sequentially solvable groups.

The constraint equations are matched to the coordinates they determine (a maximum
bipartite matching) and ordered into strongly connected blocks (the block-triangular
form of Phi_q). Blocks that share a body are merged, so that each *group* determines the
full poses of its bodies from bodies determined before it. For the founding mechanisms
the groups are the Assur groups of the textbook programs: the driver link (class I),
then dyads such as RRR, RRP and RPR.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mechsolve.base.errors import InputError
from mechsolve.joints.base import Constraint
from mechsolve.model import Mechanism
from mechsolve.system.constraints import ConstraintSystem


def grubler(mech: Mechanism) -> int:
    """Mobility by the Grübler-Kutzbach count: ``3 n - sum of what each joint removes``
    (n moving links; a lower pair removes 2, a higher pair 1: ``3 n - 2 Pl - Ph``)."""
    return 3 * len(mech.links) - sum(j.removes for j in mech.joints)


@dataclass
class GroupSpec:
    """Bodies and constraints of one sequentially solvable group."""

    bodies: list[int]
    constraints: list[Constraint]
    depends: set[int] = field(default_factory=set)  # indices of earlier groups


class StructureError(InputError):
    """The constraints do not determine every coordinate exactly once."""


class RedundantStructure(StructureError):
    """More equations than coordinates, every coordinate determined: redundant constraints.

    ``extra`` lists (constraint, equation index) of the equations left over; whether they
    are consistent with the others can only be told numerically, at a position.
    """

    def __init__(self, message: str, extra, **kw) -> None:
        super().__init__(message, **kw)
        self.extra = extra


def _matching(
    rows: list[list[int]], nvar: int, first: list[int] | None = None
) -> tuple[list[int], list[int]]:
    """Maximum matching rows -> variables (greedy start, then augmenting paths).

    Rows listed in ``first`` are matched first, so that when some rows must stay
    unmatched (redundant constraints) they are not among those.
    """
    row_of = [-1] * nvar
    var_of = [-1] * len(rows)
    firsts = set(first or [])
    order = list(first or []) + [r for r in range(len(rows)) if r not in firsts]
    for r in order:
        vs = rows[r]
        for v in vs:
            if row_of[v] < 0:
                row_of[v] = r
                var_of[r] = v
                break
    for r0 in order:
        if var_of[r0] >= 0:
            continue
        # breadth-first search for an augmenting path from row r0
        prev_row = {}
        seen_var = set()
        frontier = [r0]
        found = -1
        while frontier and found < 0:
            nxt = []
            for r in frontier:
                for v in rows[r]:
                    if v in seen_var:
                        continue
                    seen_var.add(v)
                    prev_row[v] = r
                    if row_of[v] < 0:
                        found = v
                        break
                    nxt.append(row_of[v])
                if found >= 0:
                    break
            frontier = nxt
        if found < 0:
            continue
        v = found
        while True:
            r = prev_row[v]
            pv = var_of[r]
            row_of[v] = r
            var_of[r] = v
            if r == r0:
                break
            v = pv
    return var_of, row_of


def _tarjan(n: int, succ: list[list[int]]) -> list[list[int]]:
    """Strongly connected components, each listed after the components it points to."""
    index = [0] * n
    low = [0] * n
    on = [False] * n
    seen = [False] * n
    stack: list[int] = []
    comps: list[list[int]] = []
    counter = 1
    for root in range(n):
        if seen[root]:
            continue
        work = [(root, 0)]
        while work:
            v, i = work.pop()
            if i == 0:
                seen[v] = True
                index[v] = low[v] = counter
                counter += 1
                stack.append(v)
                on[v] = True
            recurse = False
            while i < len(succ[v]):
                w = succ[v][i]
                i += 1
                if not seen[w]:
                    work.append((v, i))
                    work.append((w, 0))
                    recurse = True
                    break
                if on[w]:
                    low[v] = min(low[v], index[w])
            if recurse:
                continue
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on[w] = False
                    comp.append(w)
                    if w == v:
                        break
                comps.append(comp)
            if work:
                u = work[-1][0]
                low[u] = min(low[u], low[v])
    return comps


# the split of a structure already seen: it depends only on the bodies, the constraints'
# kinds and which coordinates each equation involves (every solve of a model, every
# design of a study, builds the same system again)
_SPLITS: dict[tuple, list[tuple[list[int], list[int], set[int]]]] = {}
_SPLITS_MAX = 256


def decompose(system: ConstraintSystem) -> list[GroupSpec]:
    """Split the constraint system into groups solvable one after another.

    Raises
    ------
    StructureError
        When some coordinates are determined by no equation (too few constraints or
        drivers) or some equations determine nothing new (redundant constraints).
    """
    nb = system.nb
    rows: list[list[int]] = []
    row_con: list[int] = []
    kinds = []
    for ci, c in enumerate(system.constraints):
        kinds.append(c.kind)
        for r in c.incidence(nb):
            rows.append(r)
            row_con.append(ci)
    key = (nb, tuple(kinds), tuple(row_con), tuple(tuple(r) for r in rows))
    split = _SPLITS.get(key)
    if split is None:
        split = _split(system, rows, row_con)  # raises on a structural error: not kept
        if len(_SPLITS) >= _SPLITS_MAX:
            _SPLITS.clear()
        _SPLITS[key] = split
    cons = system.constraints
    return [GroupSpec(list(b), [cons[ci] for ci in cs], set(d)) for b, cs, d in split]


def _split(
    system: ConstraintSystem, rows: list[list[int]], row_con: list[int]
) -> list[tuple[list[int], list[int], set[int]]]:
    """:func:`decompose`'s groups as (bodies, constraint indices, earlier groups)."""
    nb = system.nb
    nvar = 3 * nb
    first = [r for r, ci in enumerate(row_con) if system.constraints[ci].kind == "driver"]
    var_of, row_of = _matching(rows, nvar, first)
    free = [v for v in range(nvar) if row_of[v] < 0]
    extra = [r for r in range(len(rows)) if var_of[r] < 0]
    if free or extra:
        raise _structure_error(system, free, extra, row_con)

    # Rows that must be solved together: the rows of one constraint (a joint's equations
    # stay together) and the rows that determine coordinates of one body (a group
    # determines whole poses). Union-find over rows, then the strongly connected
    # components of the graph between these classes (rows that need each other's
    # coordinates), each listed after the ones it depends on.
    nr = len(rows)
    parent = list(range(nr))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    first_of: dict[tuple[str, int], int] = {}
    for r in range(nr):
        for key in (("c", row_con[r]), ("b", var_of[r] // 3)):
            other = first_of.setdefault(key, r)
            if other != r:
                parent[find(r)] = find(other)
    roots = sorted({find(r) for r in range(nr)})
    cls = {root: i for i, root in enumerate(roots)}
    row_cls = [cls[find(r)] for r in range(nr)]
    succ = [set() for _ in roots]
    for r in range(nr):
        a = row_cls[r]
        for v in rows[r]:
            b = row_cls[row_of[v]]
            if b != a:
                succ[a].add(b)
    comps = _tarjan(len(roots), [sorted(x) for x in succ])
    comp_of = {}
    for k, comp in enumerate(comps):
        for a in comp:
            comp_of[a] = k
    members: list[list[int]] = [[] for _ in comps]
    for r in range(nr):
        members[comp_of[row_cls[r]]].append(r)
    specs: list[tuple[list[int], list[int], set[int]]] = []
    for k, rs in enumerate(members):
        cons = sorted({row_con[r] for r in rs})
        bodies = sorted({var_of[r] // 3 for r in rs})
        deps = {comp_of[b] for r in rs for b in succ[row_cls[r]] if comp_of[b] != k}
        specs.append((bodies, cons, deps))
    return specs


def _structure_error(system, free, extra, row_con) -> StructureError:
    mech = system.mech
    names = system.body_names
    dof = grubler(mech)
    drivers = 1 if system.driver is not None else 0
    if free:
        bodies = sorted({names[v // 3] for v in free})
        if system.driver is None and dof >= 1:
            msg = (
                f"the mechanism has {dof} degree(s) of freedom (Grübler) and no driver; "
                "add a 'driver' section"
            )
        elif dof > drivers:
            msg = (
                f"the mechanism has {dof} degrees of freedom (Grübler) but only {drivers} driver: "
                "the motion of " + ", ".join(repr(b) for b in bodies) + " is not determined "
                "(a joint or link is missing?)"
            )
            if getattr(mech, "motor", None) is not None:
                msg += (
                    "; mechsolve simulate handles machines of one degree of freedom (the "
                    "motor's driver moves every link); a free, spring-loaded link is not "
                    "supported yet"
                )
        else:
            msg = (
                "the motion of " + ", ".join(repr(b) for b in bodies) + " is not determined "
                "by the joints (some other part of the mechanism is over-constrained)"
            )
    else:
        cons = []
        extra_eq = []
        for r in extra:
            ci = row_con[r]
            c = system.constraints[ci]
            local = r - row_con.index(ci)
            extra_eq.append((c, local))
            if c.name not in cons:
                cons.append(c.name)
        msg = (
            f"the mechanism is over-constrained: Grübler gives {dof} degree(s) of freedom "
            f"with {drivers} driver(s); the joint(s) "
            + ", ".join(repr(c) for c in cons)
            + " add constraints that nothing is left to satisfy (redundant constraints)"
        )
        return RedundantStructure(msg, extra_eq, file=mech.source.file if mech.source else None)
    return StructureError(msg, file=mech.source.file if mech.source else None)
